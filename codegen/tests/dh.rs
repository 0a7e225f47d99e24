//! Denavit–Hartenberg parameters: the conventions mean what the guide says.
//!
//! - the PUMA 560 of `models/puma560.yaml` (standard DH, Corke's data) has the forward
//!   kinematics and gravity torques Corke's Robotics Toolbox documents;
//! - a chain written with standard DH and the same chain written with modified DH have the same
//!   mechanics;
//! - right angles of `alpha` and `theta` are exact: no polynomial carries the 6e-17 residue of
//!   `cos(π/2)`.

use std::path::Path;

use hapticgen_codegen::dynamics::mechanics::Mechanics;
use hapticgen_codegen::eval::{evaluate, Evaluated, State};
use hapticgen_codegen::model::{Model, Source};
use hapticgen_codegen::{load, load_file};

fn puma() -> (Model, Mechanics) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../models/puma560.yaml");
    let model = load_file(&path, "models/puma560.yaml", None).unwrap_or_else(|d| panic!("{d}"));
    let mech = hapticgen_codegen::derive(&model);
    (model.model, mech)
}

fn at(mech: &Mechanics, q: &[f64], point: Option<&str>) -> Evaluated {
    let qd = vec![0.0; q.len()];
    let selected = point.map(|name| mech.points.iter().find(|p| p.name == name).expect("the point exists"));
    evaluate(mech, &State { q, qd: &qd, parameters: &[] }, selected)
}

fn assert_close(what: &str, got: &[f64], want: &[f64], tol: f64) {
    assert_eq!(got.len(), want.len(), "{what}");
    for (i, (a, b)) in got.iter().zip(want).enumerate() {
        assert!((a - b).abs() <= tol, "{what}[{i}]: got {a}, want {b} (got {got:?})");
    }
}

#[test]
fn puma560_matches_the_robotics_toolbox() {
    let (_, mech) = puma();
    let half_pi = std::f64::consts::FRAC_PI_2;
    // p560.fkine(qz) and p560.fkine(qr): the position of link 6's frame (the wrist centre).
    let qz = [0.0; 6];
    let qr = [0.0, half_pi, -half_pi, 0.0, 0.0, 0.0];
    assert_close("fkine(qz)", &at(&mech, &qz, Some("wrist_centre")).p, &[0.4521, -0.15005, 0.4318], 1e-12);
    assert_close("fkine(qr)", &at(&mech, &qr, Some("wrist_centre")).p, &[0.0203, -0.15005, 0.8636], 1e-12);
    // p560.gravload(qz) = [0 37.4837 0.2489 0 0 0] (4 decimals in the toolbox's documentation).
    assert_close("gravload(qz)", &at(&mech, &qz, None).g, &[0.0, 37.4837, 0.2489, 0.0, 0.0, 0.0], 5e-5);
}

#[test]
fn right_angles_leave_no_residue() {
    let (_, mech) = puma();
    let mut polys: Vec<&hapticgen_codegen::sym::poly::Poly> = Vec::new();
    polys.extend(mech.inertia_matrix.iter().flatten());
    polys.extend(mech.coriolis_matrix.iter().flatten());
    polys.extend(&mech.gravity);
    polys.extend(&mech.task.position);
    polys.extend(mech.task.jacobian.iter().flatten());
    let smallest = polys.iter().flat_map(|p| p.terms().map(|(_, c)| c.abs())).fold(f64::INFINITY, f64::min);
    // The smallest physical coefficient is a product of the wrist's small inertias and lengths
    // (≥ 1e-8); a residue of cos(π/2) would be ~1e-17 times a coefficient.
    assert!(smallest > 1e-9, "a coefficient of {smallest:e}: a right angle was not exact");
    // And joint 1 does not enter the inertia matrix (the waist axis is vertical).
    for p in mech.inertia_matrix.iter().flatten() {
        for atom in p.atoms() {
            assert!(
                !matches!(
                    atom,
                    hapticgen_codegen::sym::poly::Atom::Sin(0) | hapticgen_codegen::sym::poly::Atom::Cos(0)
                ),
                "D depends on q1"
            );
        }
    }
}

/// A three-joint chain with `a_i = 0` on the first two links (so a link's standard (distal)
/// and modified (proximal) frames share their origin and differ by `Rx(alpha_i)`, to which
/// the isotropic inertias of those links are blind) and `a_3 = alpha_3 = 0` (so the last
/// frames coincide): written both ways, every quantity must agree.
fn chain(bodies: &str) -> String {
    format!(
        r#"
name: dh_chain
space: spatial
gravity: [0.0, 0.0, -9.81]
parameters:
  upper: {{value: 0.3}}
drives:
  m:
    motor: {{rotor_inertia: 1.0e-5, resistance: 0.3, inductance: 0.1e-3, torque_constant: 0.03}}
    gear_ratio: 10.0
    torque_limit: 3.0
    current_limit: 8.0
    supply_voltage: 24.0
    encoder: {{counts_per_turn: 2000}}
joints:
  - {{name: q1, type: revolute, limits: {{lower: -3.0, upper: 3.0}}, drive: m}}
  - {{name: q2, type: revolute, limits: {{lower: -3.0, upper: 3.0}}, drive: m}}
  - {{name: q3, type: prismatic, limits: {{lower: -0.1, upper: 0.1}}, drive: m}}
bodies:
{bodies}
points:
  - {{name: tip, body: l3, position: [0.05, 0.02, 0.1]}}
task: {{point: tip}}
rates: {{current_loop_hz: 7500, impedance_loop_hz: 1000}}
current_loop: {{bandwidth_hz: 700.0, damping_ratio: 1.05, anti_alias_cutoff_hz: 2500.0}}
"#
    )
}

const STANDARD: &str = r#"
  - {name: l1, mass: 1.0, com: [0.0, 0.0, 0.0], inertia: {ixx: 0.01, iyy: 0.01, izz: 0.01}, parent: base,
     dh: {convention: standard, d: upper, alpha: 1.5707963267948966, theta: 0.2}, joint: q1}
  - {name: l2, mass: 0.5, com: [0.0, 0.0, 0.0], inertia: {ixx: 0.004, iyy: 0.004, izz: 0.004}, parent: l1,
     dh: {convention: standard, d: 0.1, alpha: -1.5707963267948966}, joint: q2}
  - {name: l3, mass: 0.3, com: [0.02, -0.01, 0.08], inertia: {ixx: 0.002, iyy: 0.0025, izz: 0.001, ixy: 1.0e-4},
     parent: l2, dh: {convention: standard, d: 0.2, theta: 0.4}, joint: q3}
"#;

const MODIFIED: &str = r#"
  - {name: l1, mass: 1.0, com: [0.0, 0.0, 0.0], inertia: {ixx: 0.01, iyy: 0.01, izz: 0.01}, parent: base,
     dh: {convention: modified, d: upper, theta: 0.2}, joint: q1}
  - {name: l2, mass: 0.5, com: [0.0, 0.0, 0.0], inertia: {ixx: 0.004, iyy: 0.004, izz: 0.004}, parent: l1,
     dh: {convention: modified, alpha: 1.5707963267948966, d: 0.1}, joint: q2}
  - {name: l3, mass: 0.3, com: [0.02, -0.01, 0.08], inertia: {ixx: 0.002, iyy: 0.0025, izz: 0.001, ixy: 1.0e-4},
     parent: l2, dh: {convention: modified, alpha: -1.5707963267948966, d: 0.2, theta: 0.4}, joint: q3}
"#;

#[test]
fn standard_and_modified_dh_describe_the_same_chain() {
    let derive = |bodies: &str| {
        let text = chain(bodies);
        let model = load(&Source { name: "chain.yaml", text: &text }, None).unwrap_or_else(|d| panic!("{d}"));
        hapticgen_codegen::derive(&model)
    };
    let (standard, modified) = (derive(STANDARD), derive(MODIFIED));
    let flat = |m: &[Vec<f64>]| m.iter().flatten().copied().collect::<Vec<f64>>();
    let mut max_difference = 0.0f64;
    for k in 0..20 {
        let t = f64::from(k);
        let q = [(0.7 * t).sin() * 2.5, (1.3 * t).cos() * 2.5, (0.9 * t).sin() * 0.1];
        let qd = [(0.4 * t).cos(), (1.1 * t).sin(), (2.1 * t).cos()];
        let e = |m: &Mechanics| evaluate(m, &State { q: &q, qd: &qd, parameters: &[] }, None);
        let (a, b) = (e(&standard), e(&modified));
        assert_close("p", &a.p, &b.p, 1e-12);
        assert_close("J", &flat(&a.jacobian), &flat(&b.jacobian), 1e-12);
        assert_close("D", &flat(&a.inertia_matrix), &flat(&b.inertia_matrix), 1e-12);
        assert_close("C q̇", &a.coriolis_times_qdot, &b.coriolis_times_qdot, 1e-12);
        assert_close("g", &a.g, &b.g, 1e-12);
        max_difference = max_difference.max((a.p[0] - b.p[0]).abs());
        // The chain moves: the tip is not at a fixed place.
        assert!(a.jacobian.iter().flatten().any(|x| x.abs() > 1e-3));
    }
    assert!(max_difference < 1e-12);
    // A sign error in one convention would not go unnoticed: flipping a twist changes p.
    let flipped = derive(&MODIFIED.replace("alpha: -1.5707963267948966", "alpha: 1.5707963267948966"));
    let q = [0.3, 0.7, 0.05];
    let e = |m: &Mechanics| evaluate(m, &State { q: &q, qd: &[0.0; 3], parameters: &[] }, None).p;
    let d: f64 = e(&standard).iter().zip(e(&flipped)).map(|(a, b)| (a - b).abs()).sum();
    assert!(d > 1e-3, "the twist's sign makes no difference");
}
