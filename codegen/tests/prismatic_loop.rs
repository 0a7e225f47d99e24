//! A passive prismatic joint in a spatial loop: the spatial slider-crank
//! (`codegen/tests/closed-chains/slider_crank_spatial.yaml`: a crank about z drives a slider
//! along x, `h` above the crank's plane, through a rod with a universal joint at the crank pin
//! and a ball joint at the slider, the closure) reduced to its crank angle by the generator's
//! numerical elimination, against the mechanism's closed form written here, which shares no
//! code with the generator:
//!
//! - **Kinematics**: the slider at `s = c cos θ + √(L² − c² sin² θ − h²)` (the rod's end on the
//!   slide's line), the rod's tilt `−asin(h/L)` whatever the crank angle, its swing the
//!   azimuth of `end − pin` less `θ`; the loop's residual ≤ 1e-12 m;
//! - **Dynamics** from the bodies' kinetic energies with the exact derivatives of those
//!   positions: the crank turning about its axis (`m c²/3`, plus the reflected rotor `N² J_m`),
//!   the rod a uniform slender rod with ends `A`, `B` (`T = m/6 (v_A² + v_A·v_B + v_B²)`), the
//!   slider a point mass on its line; `C q̇ = ½ D′(θ) θ̇²` by central differences of that `D`;
//!   `g = 0`, as no centre of mass changes height (the rod's stays at `h/2`).
//!
//! The same mechanism is written a second time (`slider_crank_ball.yaml`) with its ball joint
//! kept, as one `spherical` entry, and the universal joint at the crank pin cut open instead:
//! its three angles must turn the rod's axis onto the line from the pin to the slider, in the
//! order the format documents (`R = R(a₁, x) R(a₂, y) R(a₃, z)`, first axis fixed in the
//! parent), and its dynamics must be the same bodies'. A universal joint written as one entry
//! must generate the code of the same joint written as two revolute joints and a massless
//! cross, which the format also allows.

use std::path::Path;

use hapticgen_codegen::dynamics::mechanics::Mechanics;
use hapticgen_codegen::eval::{evaluate, State};
use hapticgen_codegen::sym::poly::Atom;

mod support;
use support::TreePositions;

const FILE: &str = "codegen/tests/closed-chains/slider_crank_spatial.yaml";
const BALL_FILE: &str = "codegen/tests/closed-chains/slider_crank_ball.yaml";
/// Crank, rod and the slide's height, m (the model file's parameters, copied).
const CRANK: f64 = 0.03;
const ROD: f64 = 0.08;
const HEIGHT: f64 = 0.02;
const CRANK_MASS: f64 = 0.015;
const ROD_MASS: f64 = 0.012;
const SLIDER_MASS: f64 = 0.05;
/// `N² J_m` of the crank's drive.
const REFLECTED_ROTOR: f64 = 7.72 * 7.72 * 1.7e-7;

/// The slider's travel and its derivative by the crank angle.
fn slider(theta: f64) -> (f64, f64) {
    let (sin, cos) = theta.sin_cos();
    let root = (ROD * ROD - CRANK * CRANK * sin * sin - HEIGHT * HEIGHT).sqrt();
    (CRANK * cos + root, -CRANK * sin - CRANK * CRANK * sin * cos / root)
}

/// `D(θ)` from the bodies' kinetic energies.
fn independent_inertia(theta: f64) -> f64 {
    let (sin, cos) = theta.sin_cos();
    let (_, slider_rate) = slider(theta);
    // Velocities per unit crank rate: the crank pin, and the rod's far end on the slider.
    let pin_rate = [-CRANK * sin, CRANK * cos, 0.0];
    let end_rate = [slider_rate, 0.0, 0.0];
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let rod = ROD_MASS / 3.0 * (dot(pin_rate, pin_rate) + dot(pin_rate, end_rate) + dot(end_rate, end_rate));
    CRANK_MASS * CRANK * CRANK / 3.0 + REFLECTED_ROTOR + rod + SLIDER_MASS * slider_rate * slider_rate
}

/// Loads a slider-crank file, reduces it, and hands `check` each of 41 states over the crank's
/// range: the crank angle, its rate, the passive coordinates the loops solve for, and the
/// reduced mechanics; returns the model's passive and body names.
fn for_each_crank_state(
    file: &str,
    passive_count: usize,
    mut check: impl FnMut(f64, f64, &[f64], &Mechanics),
) -> (Vec<String>, Vec<String>) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(file);
    let model = hapticgen_codegen::load_file(&path, file, None).unwrap_or_else(|e| panic!("{e}"));
    let mech = hapticgen_codegen::derive(&model);
    let closures = mech.closures.as_ref().expect("a closed chain");
    let spatial = closures.spatial.as_ref().expect("spatial loops");
    assert_eq!((spatial.actuated, spatial.passive), (1, passive_count));
    let (lower, upper) = (model.joints[0].lower, model.joints[0].upper);
    for k in 0..=40 {
        let theta = lower + (upper - lower) * f64::from(k) / 40.0;
        let theta_rate = 1.5 - 0.07 * f64::from(k);
        let values = closures.values(&[theta], &[theta_rate], &[]);
        let passive: Vec<f64> = (1..=passive_count as u16)
            .map(|j| {
                values.iter().find(|(a, _)| *a == Atom::Q(j)).map(|&(_, v)| v).expect("a passive coordinate")
            })
            .collect();
        check(theta, theta_rate, &passive, &mech);
    }
    (
        model.passive.iter().map(|j| j.name.clone()).collect(),
        model.bodies.iter().map(|b| b.name.clone()).collect(),
    )
}

#[test]
fn a_passive_prismatic_joint_closes_a_spatial_loop_and_its_dynamics_are_the_bodies() {
    let mut checked = 0;
    for_each_crank_state(FILE, 3, |theta, theta_rate, passive, mech| {
        let (swing, tilt, travel) = (passive[0], passive[1], passive[2]);
        // The kinematics against the closed form.
        let (expected_travel, _) = slider(theta);
        assert!((travel - expected_travel).abs() <= 1e-12, "s at θ = {theta}: {travel} vs {expected_travel}");
        assert!((tilt + (HEIGHT / ROD).asin()).abs() <= 1e-12, "tilt at θ = {theta}: {tilt}");
        let azimuth = (-CRANK * theta.sin()).atan2(expected_travel - CRANK * theta.cos());
        assert!((swing - (azimuth - theta)).abs() <= 1e-12, "swing at θ = {theta}: {swing}");
        // The loop's residual at the solution.
        let spatial = mech.closures.as_ref().and_then(|c| c.spatial.as_ref()).expect("spatial loops");
        let tree = [theta, swing, tilt, travel];
        for (name, residual) in spatial.equation_names.iter().zip(&spatial.residual) {
            let value = residual.eval(&TreePositions(&tree));
            assert!(value.abs() <= 1e-12, "{name} at θ = {theta}: {value:e}");
        }
        assert_dynamics_are_the_bodies(mech, theta, theta_rate);
        checked += 1;
    });
    assert_eq!(checked, 41);
}

/// `D`, `C q̇` and `g` of the reduced model at crank angle `theta` against the bodies' energies.
fn assert_dynamics_are_the_bodies(mech: &Mechanics, theta: f64, theta_rate: f64) {
    let evaluated = evaluate(mech, &State { q: &[theta], qd: &[theta_rate], parameters: &[] }, None);
    let inertia = evaluated.inertia_matrix[0][0];
    let expected = independent_inertia(theta);
    assert!((inertia - expected).abs() <= 1e-9 * expected, "D at θ = {theta}: {inertia} vs {expected}");
    let step = 1e-5;
    let slope = (independent_inertia(theta + step) - independent_inertia(theta - step)) / (2.0 * step);
    let coriolis = 0.5 * slope * theta_rate * theta_rate;
    let tolerance = 1e-7 * expected * (1.0 + theta_rate * theta_rate);
    assert!(
        (evaluated.coriolis_times_qdot[0] - coriolis).abs() <= tolerance,
        "C q̇ at θ = {theta}: {} vs {coriolis}",
        evaluated.coriolis_times_qdot[0]
    );
    assert!(evaluated.g[0].abs() <= 1e-12, "g at θ = {theta}: {}", evaluated.g[0]);
}

/// The first two columns of `R(a, x) R(b, y) R(c, z)`, worked out by hand.
fn ball_rotation_x_and_y_columns(a: f64, b: f64, c: f64) -> ([f64; 3], [f64; 3]) {
    let ((sa, ca), (sb, cb), (sc, cc)) = (a.sin_cos(), b.sin_cos(), c.sin_cos());
    (
        [cb * cc, ca * sc + sa * sb * cc, sa * sc - ca * sb * cc],
        [-cb * sc, ca * cc - sa * sb * sc, sa * cc + ca * sb * sc],
    )
}

#[test]
fn a_spherical_joint_written_as_one_entry_turns_about_its_axes_in_order() {
    let mut checked = 0;
    let (passive, bodies) = for_each_crank_state(BALL_FILE, 4, |theta, theta_rate, passive, mech| {
        let (ball, travel) = ([passive[0], passive[1], passive[2]], passive[3]);
        let (expected_travel, _) = slider(theta);
        assert!((travel - expected_travel).abs() <= 1e-12, "s at θ = {theta}: {travel} vs {expected_travel}");
        // The rod's x axis points from the crank pin to the ball; its y axis stays square to z.
        let (rod_axis, rod_y) = ball_rotation_x_and_y_columns(ball[0], ball[1], ball[2]);
        let pin_to_ball = [expected_travel - CRANK * theta.cos(), -CRANK * theta.sin(), HEIGHT];
        for (axis, (&got, &towards)) in rod_axis.iter().zip(&pin_to_ball).enumerate() {
            assert!(
                (got - towards / ROD).abs() <= 1e-12,
                "rod axis {axis} at θ = {theta}: {got} vs {}",
                towards / ROD
            );
        }
        assert!(
            rod_y[2].abs() <= 1e-12,
            "the rod's y axis leaves the crank's plane at θ = {theta}: {rod_y:?}"
        );
        assert_dynamics_are_the_bodies(mech, theta, theta_rate);
        checked += 1;
    });
    assert_eq!(checked, 41);
    assert_eq!(passive, ["ball_1", "ball_2", "ball_3", "slide"]);
    assert_eq!(bodies, ["crank_arm", "slider", "ball_cross1", "ball_cross2", "rod"]);
}

#[test]
fn a_universal_joint_written_as_one_entry_is_two_revolute_joints_and_a_massless_cross() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(FILE);
    let explicit = std::fs::read_to_string(&path).expect("the fixture");
    // The rod's two revolute joints and their cross, as the one entry the format also takes.
    let (joints_from, joints_to) =
        (explicit.find("  - name: rod_swing").unwrap(), explicit.find("  - name: slide").unwrap());
    let (cross_from, cross_to) =
        (explicit.find("  - name: rod_cross").unwrap(), explicit.find("  - name: slider\n").unwrap());
    let rod = &explicit[explicit.find("  - name: rod\n").unwrap()..cross_to];
    let compact = [
        &explicit[..joints_from],
        "  - name: rod_pin\n    type: universal\n    axes: [[0.0, 0.0, 1.0], [0.0, 1.0, 0.0]]\n",
        "    coordinates: [rod_swing, rod_tilt]\n    passive: true\n    assembly: [0.0, -0.2527]\n",
        &explicit[joints_to..cross_from],
        &rod.replace("parent: rod_cross", "parent: crank_arm\n    origin: {xyz: [crank_length, 0.0, 0.0]}")
            .replace("joint: rod_tilt", "joint: rod_pin"),
        &explicit[cross_to..],
    ]
    .concat();
    assert!(!compact.contains("rod_cross") && compact.contains("type: universal"), "{compact}");
    // The loader's cross: one massless body, named after the joint.
    let resolved =
        hapticgen_codegen::load(&hapticgen_codegen::model::Source { name: FILE, text: &compact }, None)
            .unwrap_or_else(|e| panic!("{e}"));
    let cross =
        resolved.bodies.iter().find(|b| b.name == "rod_pin_cross").expect("the cross `rod_pin_cross`");
    assert!(cross.mass.is_zero(), "the cross has a mass");
    let generate = |text: &str| {
        let model = hapticgen_codegen::load(&hapticgen_codegen::model::Source { name: FILE, text }, None)
            .unwrap_or_else(|e| panic!("{e}"));
        hapticgen_codegen::generate_model(model, hapticgen_codegen::Scalar::F64).file_text()
    };
    let (from_explicit, from_compact) = (generate(&explicit), generate(&compact));
    assert!(from_explicit.contains("LoopConstraints<f64, 1, 3>"), "{from_explicit}");
    assert!(from_explicit == from_compact, "the generated code differs:\n{from_compact}");
}

/// The emitted code of the loop: the passive travel is read as a length, never through a sine
/// or cosine, and the loop is solved at run time like the Delta's.
#[test]
fn a_passive_prismatic_joint_is_emitted_as_a_length() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(FILE);
    let model = hapticgen_codegen::load_file(&path, FILE, None).unwrap_or_else(|e| panic!("{e}"));
    let text = hapticgen_codegen::generate_model_with(
        model,
        hapticgen_codegen::Scalar::F64,
        hapticgen_codegen::EmitOptions::default(),
    )
    .file_text();
    assert!(text.contains("LoopConstraints<f64, 1, 3> for SliderCrankSpatial"), "{text}");
    assert!(text.contains("let slide = passive[2];"), "the travel read in the constraints");
    assert!(!text.contains("sin_slide") && !text.contains("cos_slide"), "a sine of a length");
}
