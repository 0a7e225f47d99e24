//! The `rig!` macro on every shipped model (all variants, f32 and f64): the compiled
//! functions equal the numeric evaluator at 100 random states (f64 to 1e-12, f32 to 1e-5 of
//! each output's scale), and the expansion is the same code as the build-script helper's.

use std::path::Path;

use hapticgen_codegen::rig_macro::expansion_items;
use hapticgen_codegen::Scalar;
use hapticgen_tests::check::EvaluatorCheck;
use hapticgen_tests::{RigInfo, RigVisitor};
use quote::quote;

hapticgen_macros::rig!(mod joystick_f64 = "../models/joystick_1dof.yaml");
hapticgen_macros::rig!(mod joystick_f32 = "../models/joystick_1dof.yaml", scalar = f32);
hapticgen_macros::rig!(mod vertical_f64 = "../models/parallel_link_2dof.yaml", variant = "vertical", scalar = f64);
hapticgen_macros::rig!(mod vertical_f32 = "../models/parallel_link_2dof.yaml", variant = "vertical", scalar = f32);
hapticgen_macros::rig!(mod horizontal_f64 = "../models/parallel_link_2dof.yaml", variant = "horizontal");
hapticgen_macros::rig!(mod horizontal_f32 = "../models/parallel_link_2dof.yaml", variant = "horizontal", scalar = f32);
hapticgen_macros::rig!(mod pantograph_f64 = "../models/pantograph_5bar.yaml", variant = "vertical");
hapticgen_macros::rig!(mod pantograph_f32 = "../models/pantograph_5bar.yaml", scalar = f32);
hapticgen_macros::rig!(mod five_bar_f64 = "../codegen/tests/good-models/five_bar_2dof.yaml");
hapticgen_macros::rig!(mod vertical_f32_fma = "../models/parallel_link_2dof.yaml", variant = "vertical", scalar = f32, fma = true);
hapticgen_macros::rig!(mod pantograph_regressor = "../models/pantograph_5bar.yaml", variant = "vertical", regressor = true);
hapticgen_macros::rig!(mod pantograph_regressor_f32 = "../models/pantograph_5bar.yaml", variant = "vertical", scalar = f32, regressor = true);
hapticgen_macros::rig!(mod phantom_regressor_f32 = "../models/phantom_3dof.yaml", scalar = f32, regressor = true);

#[test]
fn macro_generated_rigs_equal_the_evaluator() {
    let mut check = EvaluatorCheck::default();
    let info = |variant, module| RigInfo { file: "models/joystick_1dof.yaml", variant, module };
    check.visit_f64(&info(None, "joystick_f64"), &joystick_f64::Joystick1dof::NOMINAL);
    check.visit_f32(&info(None, "joystick_f32"), &joystick_f32::Joystick1dof::NOMINAL);
    let info = |variant, module| RigInfo { file: "models/parallel_link_2dof.yaml", variant, module };
    check.visit_f64(&info(Some("vertical"), "vertical_f64"), &vertical_f64::ParallelLink2dof::NOMINAL);
    check.visit_f32(&info(Some("vertical"), "vertical_f32"), &vertical_f32::ParallelLink2dof::NOMINAL);
    check.visit_f64(&info(Some("horizontal"), "horizontal_f64"), &horizontal_f64::ParallelLink2dof::NOMINAL);
    check.visit_f32(&info(Some("horizontal"), "horizontal_f32"), &horizontal_f32::ParallelLink2dof::NOMINAL);
    // Closed chains: the five-bars, reduced to their motors.
    let info = |variant, module| RigInfo { file: "models/pantograph_5bar.yaml", variant, module };
    check.visit_f64(&info(Some("vertical"), "pantograph_f64"), &pantograph_f64::Pantograph5bar::NOMINAL);
    check.visit_f32(&info(Some("horizontal"), "pantograph_f32"), &pantograph_f32::Pantograph5bar::NOMINAL);
    let info = RigInfo {
        file: "codegen/tests/good-models/five_bar_2dof.yaml",
        variant: None,
        module: "five_bar_f64",
    };
    check.visit_f64(&info, &five_bar_f64::FiveBar2dof::NOMINAL);
    let info = RigInfo {
        file: "models/parallel_link_2dof.yaml",
        variant: Some("vertical"),
        module: "vertical_f32_fma",
    };
    check.visit_f32(&info, &vertical_f32_fma::ParallelLink2dof::NOMINAL);
    assert_eq!(check.rigs, 10);
}

#[test]
fn macro_expansion_equals_the_build_helper_output() {
    let manifest_dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    let cases = [
        (
            quote!(pub mod rig = "../models/joystick_1dof.yaml"),
            "../models/joystick_1dof.yaml",
            None,
            Scalar::F64,
        ),
        (
            quote!(pub mod rig = "../models/parallel_link_2dof.yaml", variant = "horizontal", scalar = f32),
            "../models/parallel_link_2dof.yaml",
            Some("horizontal"),
            Scalar::F32,
        ),
    ];
    for (input, file, variant, scalar) in cases {
        let expanded = expansion_items(input, manifest_dir).expect("the expansion is a module with items");
        let loaded =
            hapticgen_codegen::load_file(&manifest_dir.join(file), file, variant).expect("valid model");
        let built = hapticgen_codegen::generate_model(loaded, scalar).formatted_items();
        assert_eq!(expanded, built, "{file} {variant:?}");
        assert!(expanded.contains("::hapticgen_runtime::impl_rig_model!("));
    }
    // `fma = true` is the build helper's fused multiply-add emission.
    let input = quote!(pub mod rig = "../models/parallel_link_2dof.yaml", variant = "vertical", fma = true);
    let expanded = expansion_items(input, manifest_dir).expect("the expansion is a module with items");
    let file = "../models/parallel_link_2dof.yaml";
    let loaded =
        hapticgen_codegen::load_file(&manifest_dir.join(file), file, Some("vertical")).expect("valid model");
    let options = hapticgen_codegen::EmitOptions { fused_multiply_add: true, ..Default::default() };
    let built = hapticgen_codegen::generate_model_with(loaded, Scalar::F64, options).formatted_items();
    assert_eq!(expanded, built);
    assert!(expanded.contains("::hapticgen_runtime::Real::mul_add("));
    // `regressor = true` is the build helper's emission with the identification regressor.
    let input =
        quote!(pub mod rig = "../models/pantograph_5bar.yaml", variant = "vertical", regressor = true);
    let expanded = expansion_items(input, manifest_dir).expect("the expansion is a module with items");
    let file = "../models/pantograph_5bar.yaml";
    let loaded =
        hapticgen_codegen::load_file(&manifest_dir.join(file), file, Some("vertical")).expect("valid model");
    let options = hapticgen_codegen::EmitOptions { regressor: true, ..Default::default() };
    let built = hapticgen_codegen::generate_model_with(loaded, Scalar::F64, options).formatted_items();
    assert_eq!(expanded, built);
    assert!(expanded.contains("pub fn regressor("));
}

#[test]
fn macro_regressor_is_the_build_scripts() {
    use hapticgen_tests::pantograph_5bar_vertical_f64_regressor::Pantograph5bar as Built;
    let (rig, built) = (pantograph_regressor::Pantograph5bar::NOMINAL, Built::NOMINAL);
    assert_eq!(pantograph_regressor::Pantograph5bar::BASE_PARAMETERS, Built::BASE_PARAMETERS);
    assert_eq!(rig.base_parameters(), built.base_parameters());
    // The middle of the joint ranges, where the loop closes.
    let middle = |d: &hapticgen_runtime::DriveTrain<f64>| 0.5 * (d.position_lower + d.position_upper);
    let q = [middle(&Built::DRIVES[0]), middle(&Built::DRIVES[1])];
    let (qd, qdd) = ([0.3, -0.7], [1.5, 2.0]);
    let y = rig.regressor(&q, &qd, &qdd);
    assert!(y.iter().flatten().all(|x| x.is_finite()), "{y:?}");
    assert_eq!(y, built.regressor(&q, &qd, &qdd));
}

#[test]
fn expansion_tracks_the_model_file() {
    let manifest_dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    let tokens =
        hapticgen_codegen::rig_macro::expand(quote!(mod rig = "../models/joystick_1dof.yaml"), manifest_dir)
            .to_string();
    let tracked = manifest_dir.join("../models/joystick_1dof.yaml");
    assert!(tokens.contains("include_bytes"), "no include_bytes! in the expansion");
    assert!(tokens.contains(&format!("{:?}", tracked.to_string_lossy())), "the model path is not tracked");
}

#[test]
fn closed_chain_where_the_loop_cannot_close_is_non_finite_without_panicking() {
    let rig = five_bar_f64::FiveBar2dof::NOMINAL;
    // The elbows 16 mm apart, closer than the difference of the distal lengths (20 mm): one
    // circle lies inside the other and the loop cannot close.
    let (q, qd) = ([std::f64::consts::FRAC_PI_2, 0.95], [0.1, -0.1]);
    let terms = rig.terms(&q, &qd);
    assert!(terms.inertia_matrix.iter().flatten().all(|x| !x.is_finite()), "{:?}", terms.inertia_matrix);
    assert!(terms.position.iter().all(|x| !x.is_finite()));
    assert!(rig.closure_margin(&q)[0] < 0.0, "the margin says so: {:?}", rig.closure_margin(&q));
    // Inside the workspace everything is finite.
    let terms = rig.terms(&[1.2, 1.9], &qd);
    let margin = rig.closure_margin(&[1.2, 1.9])[0];
    assert!(margin > 0.3 && margin <= 1.0, "{margin}");
    assert!(terms
        .inertia_matrix
        .iter()
        .flatten()
        .chain(terms.jacobian.iter().flatten())
        .all(|x| x.is_finite()));
}

/// The pantograph's elbows (the passive joints' axes): `(∓s + l cos q_k, l sin q_k)`, from
/// `models/pantograph_5bar.yaml`'s parameters, written out here independently of the generator.
fn pantograph_elbows(q: &[f64; 2]) -> [[f64; 2]; 2] {
    let (l_proximal, half_spacing) = (0.07, 0.019);
    [
        [-half_spacing + l_proximal * q[0].cos(), l_proximal * q[0].sin()],
        [half_spacing + l_proximal * q[1].cos(), l_proximal * q[1].sin()],
    ]
}

#[test]
fn closure_margin_is_the_squared_sine_between_the_distal_links_and_vanishes_where_the_loop_is_singular() {
    let rig = pantograph_f64::Pantograph5bar::NOMINAL;
    // Inside the workspace: the squared sine of the angle between the two distal links, from
    // the elbows and the handle (the rig's own task position) by the cross product.
    for q in [[1.6, 1.2], [2.0, 0.9], [2.5, 0.6], [1.45, 1.7], [2.6, 1.7]] {
        let [e1, e2] = pantograph_elbows(&q);
        let handle = rig.position(&q);
        let u1 = [handle[0] - e1[0], handle[1] - e1[1]];
        let u2 = [handle[0] - e2[0], handle[1] - e2[1]];
        let cross = u1[0] * u2[1] - u1[1] * u2[0];
        let sine_squared =
            cross * cross / ((u1[0].powi(2) + u1[1].powi(2)) * (u2[0].powi(2) + u2[1].powi(2)));
        let margin = rig.closure_margin(&q)[0];
        assert!((margin - sine_squared).abs() < 1e-12, "at {q:?}: margin {margin}, sin² {sine_squared}");
    }
    // The elbows coincide where `2 l cos q1 = 2 s` and `q2 = π − q1`: both distal links then
    // lie along the same line, `Φ_p` is singular and `D` grows without bound as the
    // configuration approaches it. The margin must go to zero with it.
    let coincident = (0.019_f64 / 0.07).acos();
    let mut previous_largest = 0.0;
    for offset in [1e-2, 1e-3, 1e-4] {
        let q = [coincident, std::f64::consts::PI - coincident + offset];
        let margin = rig.closure_margin(&q)[0];
        let d = rig.inertia_matrix(&q);
        // The larger eigenvalue of the symmetric 2 × 2 `D`.
        let (mean, half_gap) =
            (0.5 * (d[0][0] + d[1][1]), (0.25 * (d[0][0] - d[1][1]).powi(2) + d[0][1].powi(2)).sqrt());
        let largest = mean + half_gap;
        assert!(margin >= 0.0 && margin < 10.0 * offset * offset, "offset {offset}: margin {margin}");
        assert!(
            largest > 10.0 * previous_largest,
            "offset {offset}: D's largest eigenvalue {largest} did not grow"
        );
        previous_largest = largest;
    }
}

#[test]
fn the_impedance_tick_latches_a_loop_singularity_and_nothing_else_does() {
    use hapticgen_runtime::control::{ImpedanceController, ImpedanceLaw, TaskReference};
    use hapticgen_runtime::safety::FaultCode;
    use hapticgen_runtime::tick::{HapticLoop, HapticLoopSettings, ImpedanceInputs};
    use hapticgen_runtime::RigModel;

    let rig = pantograph_f64::Pantograph5bar::NOMINAL;
    let coincident = (0.019_f64 / 0.07).acos();
    let first_tick = |start: [f64; 2]| {
        let controller =
            ImpedanceController::new(ImpedanceLaw::NaturalInertia, [200.0; 2], [2.0; 2], [0.5; 2]);
        let mut settings = HapticLoopSettings::for_rig(&rig, controller);
        settings.zero_offset = start;
        let reference = TaskReference::at_rest(rig.position(&start));
        let mut haptic = HapticLoop::new(rig, reference, &settings).expect("valid settings");
        let inputs = ImpedanceInputs { encoder_counts: [0; 2], force_readings: [0.0; 2], tick: 0 };
        let report = haptic.impedance_tick(&inputs);
        (rig.loop_margin(&start), report.command.fault)
    };
    // In the workspace: a margin near 1, no fault.
    let (margin, fault) = first_tick([2.0, 0.9]);
    assert!(margin > 0.5, "{margin}");
    assert_eq!(fault, None);
    // Five millidegrees from the elbows' coincidence every term is still finite (no other check
    // fires), but the loop is singular.
    let (margin, fault) = first_tick([coincident, std::f64::consts::PI - coincident + 1e-4]);
    assert!(margin < 1e-6, "{margin}");
    assert_eq!(fault, Some(FaultCode::LoopSingular));
}

#[test]
fn f32_regressors_agree_with_the_f64_ones() {
    use hapticgen_tests::pantograph_5bar_vertical_f64_regressor::Pantograph5bar as Pantograph;
    use hapticgen_tests::phantom_3dof_f64_regressor::Phantom3dof as Phantom;
    let close = |a: f32, b: f64, scale: f64| (f64::from(a) - b).abs() <= 1e-4 * scale;
    let middle = |d: &hapticgen_runtime::DriveTrain<f64>| 0.5 * (d.position_lower + d.position_upper);

    let q = [middle(&Pantograph::DRIVES[0]), middle(&Pantograph::DRIVES[1])];
    let (qd, qdd) = ([0.3, -0.7], [1.5, 2.0]);
    let want = Pantograph::NOMINAL.regressor(&q, &qd, &qdd);
    let to32 = |v: &[f64]| -> Vec<f32> { v.iter().map(|&x| x as f32).collect() };
    let (q32, qd32, qdd32) = (to32(&q), to32(&qd), to32(&qdd));
    let got = pantograph_regressor_f32::Pantograph5bar::NOMINAL.regressor(
        &q32.clone().try_into().unwrap(),
        &qd32.clone().try_into().unwrap(),
        &qdd32.clone().try_into().unwrap(),
    );
    let scale = want.iter().flatten().fold(1.0f64, |m, x| m.max(x.abs()));
    for (g, w) in got.iter().flatten().zip(want.iter().flatten()) {
        assert!(close(*g, *w, scale), "pantograph f32 {g} against f64 {w}");
    }

    let q = [0.3, -0.4, 0.8];
    let (qd, qdd) = ([0.3, -0.7, 0.2], [1.5, 2.0, -1.0]);
    let want = Phantom::NOMINAL.regressor(&q, &qd, &qdd);
    let got = phantom_regressor_f32::Phantom3dof::NOMINAL.regressor(
        &to32(&q).try_into().unwrap(),
        &to32(&qd).try_into().unwrap(),
        &to32(&qdd).try_into().unwrap(),
    );
    let scale = want.iter().flatten().fold(1.0f64, |m, x| m.max(x.abs()));
    for (g, w) in got.iter().flatten().zip(want.iter().flatten()) {
        assert!(close(*g, *w, scale), "phantom f32 {g} against f64 {w}");
    }
    let base: Vec<f64> =
        phantom_regressor_f32::Phantom3dof::NOMINAL.base_parameters().iter().map(|&x| f64::from(x)).collect();
    for (g, w) in base.iter().zip(Phantom::NOMINAL.base_parameters()) {
        assert!((g - w).abs() <= 1e-6 * w.abs().max(1e-6), "base parameter {g} against {w}");
    }
}
