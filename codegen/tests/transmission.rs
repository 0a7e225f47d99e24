//! Transmissions (`a = C q` between joints and drives): the rotor inertia they reflect into
//! `D` against `Cᵀ diag(N² J_m) C` multiplied out by hand from the drive's data sheet values,
//! for the shipped differential wrist (`C = [[1, 1], [1, −1]]`, whose cross terms cancel) and
//! the good-model fixture `coupled_wrist` (`C = [[1, 0], [1, 1]]`, whose do not), and the
//! coupling the generated code carries (`C`, `C⁻¹`). The recursive derivation's `D` and inverse
//! dynamics of the fixture are compared with these polynomials in `tests/recursive.rs`.

use std::path::Path;

use hapticgen_codegen::eval::{evaluate, State};
use hapticgen_codegen::load;
use hapticgen_codegen::model::Source;

/// The wrist's drive: N = 5, J_m = 1.7e-7 kg·m² (the spec's Falcon motors).
const REFLECTED: f64 = 5.0 * 5.0 * 1.7e-7;

fn inertia_matrices(file: &str, q: [f64; 2]) -> ([[f64; 2]; 2], [[f64; 2]; 2]) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(file);
    let text = std::fs::read_to_string(&path).unwrap();
    // The same file without its transmission: each drive turns its own joint.
    let start = text.find("\ntransmission:").expect("the file has a transmission") + 1;
    let end = start + text[start..].find("\n\n").unwrap();
    let uncoupled = format!("{}{}", &text[..start], &text[end + 2..]);
    let d = |text: &str| {
        let model = load(&Source { name: file, text }, None).unwrap_or_else(|d| panic!("{d}"));
        let mechanics = hapticgen_codegen::derive(&model);
        let evaluated = evaluate(&mechanics, &State { q: &q, qd: &[0.3, -0.7], parameters: &[] }, None);
        let row = |i: usize| [evaluated.inertia_matrix[i][0], evaluated.inertia_matrix[i][1]];
        [row(0), row(1)]
    };
    (d(&text), d(&uncoupled))
}

fn assert_reflected(file: &str, expected: [[f64; 2]; 2]) {
    for q in [[0.0, 0.0], [0.4, -1.1], [-0.9, 1.3]] {
        let (coupled, uncoupled) = inertia_matrices(file, q);
        for i in 0..2 {
            for k in 0..2 {
                // Uncoupled, each joint carries N² J_m on its diagonal.
                let own = if i == k { REFLECTED } else { 0.0 };
                let got = coupled[i][k] - uncoupled[i][k] + own;
                assert!(
                    (got - expected[i][k]).abs() < 1e-18,
                    "{file} at q = {q:?}: D[{i}][{k}] reflects {got:e}, want {:e}",
                    expected[i][k]
                );
            }
        }
    }
}

#[test]
fn the_differential_reflects_twice_each_rotor_on_each_joint() {
    // Cᵀ diag(J, J) C with C = [[1, 1], [1, −1]]: [[2J, J − J], [J − J, 2J]].
    assert_reflected("../models/differential_wrist.yaml", [[2.0 * REFLECTED, 0.0], [0.0, 2.0 * REFLECTED]]);
}

#[test]
fn an_absolute_angle_drive_couples_the_joints_inertia() {
    // C = [[1, 0], [1, 1]]: Cᵀ diag(J, J) C = [[1, 1], [0, 1]] [[J, 0], [J, J]] = [[2J, J], [J, J]].
    assert_reflected(
        "tests/good-models/coupled_wrist.yaml",
        [[2.0 * REFLECTED, REFLECTED], [REFLECTED, REFLECTED]],
    );
}

#[test]
fn the_generated_rig_carries_the_coupling_and_its_inverse() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/good-models/coupled_wrist.yaml");
    let text = std::fs::read_to_string(&path).unwrap();
    let model =
        load(&Source { name: "coupled_wrist.yaml", text: &text }, None).unwrap_or_else(|d| panic!("{d}"));
    let code = hapticgen_codegen::generate_model(model, hapticgen_codegen::Scalar::F64).file_text();
    let code: String = code.split_whitespace().collect();
    // C⁻¹ of [[1, 0], [1, 1]] is [[1, 0], [−1, 1]].
    assert!(
        code.contains(
            "drive_from_joint:[[1.0_f64,0.0_f64],[1.0_f64,1.0_f64]],joint_from_drive:[[1.0_f64,0.0_f64],[-1.0_f64,1.0_f64]]"
        ),
        "{code}"
    );
    assert!(code.contains(
        "impl_rig_model!(CoupledWrist,f64,2,2,\"coupled_wrist\",7500u32,1000u32;couplingCOUPLING)"
    ));
}

#[test]
fn the_urdf_export_says_what_it_cannot_carry() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/good-models/coupled_wrist.yaml");
    let text = std::fs::read_to_string(&path).unwrap();
    let model =
        load(&Source { name: "coupled_wrist.yaml", text: &text }, None).unwrap_or_else(|d| panic!("{d}"));
    let urdf = hapticgen_codegen::urdf::export(&model).unwrap();
    assert!(urdf.contains("transmission: joint pitch's drive turns pitch 1.0 (not part of URDF)"), "{urdf}");
    assert!(
        urdf.contains("transmission: joint roll's drive turns pitch 1.0, roll 1.0 (not part of URDF)"),
        "{urdf}"
    );
    // Cᵀ diag(J, J) C with J = N² J_m = 4.25e-6: [[2J, J], [J, J]].
    assert!(
        urdf.contains("reflected rotor inertia Cᵀ diag(N² J_m) C (adds to D instead): [8.5e-6 4.25e-6; 4.25e-6 4.25e-6]"),
        "{urdf}"
    );
}
