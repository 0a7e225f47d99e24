//! `rig!` on an identified model file (`hapticgen identify -o`): the committed
//! `tests/models/joystick_identified.yaml`, which the host's test
//! `consistent::the_rig_macro_s_identified_fixture_is_what_identify_writes` keeps equal to what
//! identification writes for `scripts/pil-identify.sh`'s "true" joystick (the stick 40 %
//! heavier, its centre of mass 20 % further out, the grip 36 % heavier, 30 % more friction). It
//! expands and compiles like any model file's, in both scalars, and its rig is that joystick,
//! not the shipped file's.

use hapticgen_runtime::RigModel;

hapticgen_macros::rig!(mod identified = "tests/models/joystick_identified.yaml");
hapticgen_macros::rig!(mod identified_f32 = "tests/models/joystick_identified.yaml", scalar = f32);
hapticgen_macros::rig!(mod nominal = "../models/joystick_1dof.yaml");

/// The fixture's text.
fn fixture() -> String {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/models/joystick_identified.yaml");
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{path}: {e}"))
}

#[test]
fn the_fixture_is_an_identified_file() {
    let text = fixture();
    for marked in ["(was mass 0.05)", "(was damping 1.0e-3)", "(was coulomb_friction 0.01)"] {
        assert!(text.contains(&format!("# identified {marked}")), "no `{marked}` in\n{text}");
    }
}

#[test]
fn the_identified_rig_is_the_true_joystick_not_the_shipped_file() {
    let (rig, shipped) = (identified::Joystick1dof::NOMINAL, nominal::Joystick1dof::NOMINAL);
    // About the pivot: the stick a slender rod of 0.15 m, the grip a point mass at 0.12 m; the
    // rotor's reflected inertia is the same in both files.
    let pivot =
        |stick: f64, com: f64, grip: f64| stick * (0.15 * 0.15 / 12.0 + com * com) + grip * 0.12 * 0.12;
    let (shipped_links, true_links) = (pivot(0.020358, 0.075, 0.05), pivot(0.0285, 0.09, 0.068));
    let moment = |stick: f64, com: f64, grip: f64| stick * com + grip * 0.12;
    let (shipped_moment, true_moment) = (moment(0.020358, 0.075, 0.05), moment(0.0285, 0.09, 0.068));
    for q in [-1.2, -0.3, 0.0, 0.4, 1.1] {
        let d_shipped = shipped.inertia_matrix(&[q])[0][0];
        let d_true = d_shipped - shipped_links + true_links;
        let d = rig.inertia_matrix(&[q])[0][0];
        assert!((d - d_true).abs() <= 1e-6 * d_true, "q = {q}: D {d:e}, the true joystick's {d_true:e}");
        assert!(d > 1.1 * d_shipped, "q = {q}: D {d:e} against the shipped file's {d_shipped:e}");
        let g_shipped = shipped.gravity(&[q])[0];
        let g_true = g_shipped * true_moment / shipped_moment;
        let g = rig.gravity(&[q])[0];
        assert!(
            (g - g_true).abs() <= 1e-6 * g_true.abs().max(1e-9),
            "q = {q}: g {g:e}, the true joystick's {g_true:e}"
        );
        // The f32 rig: the same numbers to f32's precision.
        let d32 = identified_f32::Joystick1dof::NOMINAL.inertia_matrix(&[q as f32])[0][0];
        assert!((f64::from(d32) - d).abs() <= 1e-5 * d, "q = {q}: f32 D {d32:e}, f64 {d:e}");
    }
    assert!((rig.damping()[0] - 1.3e-3).abs() <= 1e-9, "{:?}", rig.damping());
    assert!((rig.coulomb_friction()[0] - 0.013).abs() <= 1e-9, "{:?}", rig.coulomb_friction());
    assert_eq!(shipped.damping(), [1.0e-3]);
}
