//! Units, expressions, inertia shapes and drives `like` another, end to end: a model written
//! with them resolves to the same model as the one written in plain SI numbers.

use std::path::{Path, PathBuf};

use hapticgen_codegen::model::{load, Model, Source};
use hapticgen_codegen::{generate, Scalar};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn shipped(name: &str) -> String {
    let path = root().join("models").join(name);
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// `text` with each `(from, to)` replaced; each `from` must occur exactly once.
fn rewrite(text: &str, replacements: &[(&str, &str)]) -> String {
    let mut out = text.to_string();
    for (from, to) in replacements {
        assert_eq!(out.matches(from).count(), 1, "`{from}` must occur once");
        out = out.replace(from, to);
    }
    out
}

/// The generated code (named alike, so that only the model can differ).
fn code(text: &str) -> String {
    generate(&Source { name: "model.yaml", text }, None, Scalar::F64)
        .unwrap_or_else(|e| panic!("{e}"))
        .file_text()
}

fn same_code(a: &str, b: &str) {
    let (a, b) = (code(a), code(b));
    if let Some((x, y)) = a.lines().zip(b.lines()).find(|(x, y)| x != y) {
        panic!("the generated code differs:\n  {x}\n  {y}");
    }
    assert_eq!(a.len(), b.len());
}

fn model(text: &str) -> Model {
    load(&Source { name: "model.yaml", text }, None).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn a_model_with_units_and_expressions_generates_the_same_code() {
    let plain = shipped("joystick_1dof.yaml");
    let written = rewrite(
        &plain,
        &[
            (
                "drives:\n",
                "parameters:\n  stick_length: {value: 15 cm}\n  ratio: {value: 3 * 4}\n\ndrives:\n",
            ),
            ("rotor_inertia: 1.42e-5", "rotor_inertia: 142 g cm^2"),
            ("resistance: 0.299", "resistance: 299 mohm"),
            ("inductance: 0.082e-3", "inductance: 0.082 mH"),
            ("torque_constant: 30.2e-3", "torque_constant: 30.2 mNm/A"),
            ("gear_ratio: 12.0", "gear_ratio: ratio"),
            ("supply_voltage: 24.0", "supply_voltage: 24 V"),
            ("counts_per_turn: 2000", "counts_per_turn: 4 * 500"),
            ("limits: {lower: -1.5, upper: 1.5}", "limits: {lower: -1.5 rad, upper: 3 / 2}"),
            ("com: [0.0, 0.075]", "com: [0.0, stick_length / 2]"),
            ("inertia: {slender_rod: 0.15}", "inertia: {slender_rod: stick_length}"),
        ],
    );
    assert_ne!(plain, written);
    same_code(&plain, &written);
}

#[test]
fn tunable_expressions_resolve_to_the_same_polynomials() {
    let plain = rewrite(
        &shipped("joystick_1dof.yaml"),
        &[
            ("drives:\n", "parameters:\n  grip_mass: {value: 0.05, tunable: true}\n\ndrives:\n"),
            ("    mass: 0.05\n", "    mass: grip_mass\n"),
        ],
    );
    let written = rewrite(&plain, &[("    mass: grip_mass\n", "    mass: 3 * (2 * grip_mass) / 6 + 0 g\n")]);
    same_code(&plain, &written);
    // A polynomial of degree two, its value at the nominal mass.
    let squared = rewrite(
        &plain,
        &[("    inertia: 0.0\n    parent: stick", "    inertia: grip_mass^2\n    parent: stick")],
    );
    let grip = model(&squared).bodies.into_iter().find(|b| b.name == "grip").expect("grip");
    let terms: Vec<(String, f64)> = grip.inertia[2][2].terms().map(|(m, c)| (format!("{m:?}"), c)).collect();
    assert_eq!(terms, vec![("[(Param(0), 2)]".to_string(), 1.0)]);
}

#[test]
fn a_drive_like_another_overrides_only_what_it_names() {
    let text = rewrite(
        &shipped("joystick_1dof.yaml"),
        &[
            ("\njoints:\n", "  fast:\n    like: re40_gp42\n    gear_ratio: 6\n    torque_limit: 1.5 N m\n    encoder: {}\n\njoints:\n"),
            ("    drive: re40_gp42", "    drive: fast"),
        ],
    );
    let m = model(&text);
    let base = model(&shipped("joystick_1dof.yaml")).joints[0].drive.clone();
    let joint = &m.joints[0];
    assert_eq!(joint.drive_name, "fast");
    assert_eq!((joint.drive.gear_ratio, joint.drive.torque_limit), (6.0, 1.5));
    assert_eq!(joint.drive.current_limit, base.current_limit);
    assert_eq!(joint.drive.motor.resistance, base.motor.resistance);
    assert_eq!(joint.drive.motor.torque_constant, base.motor.torque_constant);
    assert_eq!(joint.drive.encoder.counts_per_turn, base.encoder.counts_per_turn);
    assert_eq!(joint.drive.backlash, base.backlash);
}

#[test]
fn spatial_inertia_shapes_give_the_textbook_tensors() {
    let text = rewrite(
        &shipped("phantom_3dof.yaml"),
        &[
            (
                "inertia: {ixx: 8.0e-6, iyy: 2.9e-4, izz: 2.9e-4, ixy: 1.0e-6, ixz: 6.0e-6}",
                "inertia: {rod: {length: 20 cm, axis: [1, 0, 0]}}",
            ),
            (
                "inertia: {ixx: 5.0e-6, iyy: 1.6e-4, izz: 1.6e-4, ixy: -3.0e-6}",
                "inertia: {cylinder: {radius: 5 mm, length: 0.18, axis: [1, 0, 0]}}",
            ),
            ("inertia: {ixx: 4.0e-6, iyy: 4.0e-6, izz: 2.0e-6}", "inertia: {sphere: {radius: 1 cm}}"),
            (
                "inertia: {ixx: 6.0e-4, iyy: 8.0e-4, izz: 7.0e-4, ixz: 1.0e-4}",
                "inertia: {box: {x: 0.1, y: 0.2, z: 0.05}}",
            ),
        ],
    );
    let m = model(&text);
    let inertia = |name: &str| {
        let b = m.bodies.iter().find(|b| b.name == name).expect(name);
        let mass = b.mass.as_constant().expect("constant mass");
        let entries = b.inertia.clone().map(|row| row.map(|p| p.as_constant().unwrap_or(f64::NAN)));
        (mass, entries)
    };
    let close = |a: f64, b: f64| assert!((a - b).abs() <= 1e-15 * b.abs().max(1e-12), "{a} != {b}");
    let (m_arm, arm) = inertia("upper_arm");
    close(arm[1][1], m_arm * 0.2 * 0.2 / 12.0);
    close(arm[2][2], m_arm * 0.2 * 0.2 / 12.0);
    assert_eq!((arm[0][0], arm[0][1], arm[1][2]), (0.0, 0.0, 0.0));
    let (m_fore, fore) = inertia("forearm");
    close(fore[0][0], m_fore * 0.005 * 0.005 / 2.0);
    close(fore[1][1], m_fore * (3.0 * 0.005 * 0.005 + 0.18 * 0.18) / 12.0);
    let (m_gimbal, gimbal) = inertia("gimbal");
    close(gimbal[2][2], 2.0 * m_gimbal * 0.01 * 0.01 / 5.0);
    let (m_turret, turret) = inertia("turret");
    close(turret[0][0], m_turret * (0.2 * 0.2 + 0.05 * 0.05) / 12.0);
    close(turret[2][2], m_turret * (0.1 * 0.1 + 0.2 * 0.2) / 12.0);
}

#[test]
fn assembly_angles_take_units() {
    let text = shipped("falcon_delta.yaml");
    let m = model(&text);
    // The first `assembly: [a, b]` of the file, rewritten in degrees.
    let start = text.find("assembly: [").expect("an assembly list");
    let end = start + text[start..].find(']').expect("]");
    let list: Vec<f64> = text[start + "assembly: [".len()..end]
        .split(',')
        .map(|x| x.trim().parse().expect("number"))
        .collect();
    let degrees: Vec<String> = list.iter().map(|x| format!("{} deg", x.to_degrees())).collect();
    let written = format!("{}assembly: [{}]{}", &text[..start], degrees.join(", "), &text[end + 1..]);
    let w = model(&written);
    assert!(written.contains(" deg, "));
    assert_eq!(m.passive.len(), w.passive.len());
    for (a, b) in m.passive.iter().zip(&w.passive) {
        assert!((a.assembly - b.assembly).abs() < 1e-12, "{}: {} != {}", a.name, a.assembly, b.assembly);
    }
    assert!(w.passive.iter().any(|p| p.assembly == 1.924 || (p.assembly - 1.924).abs() < 1e-12));
}
