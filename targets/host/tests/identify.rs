//! Dynamic identification end to end, against numbers nobody chose: a "true" device (every
//! body's mass, centre of mass and inertia changed by 10–40 %, friction changed) whose base
//! parameters follow from its own file, and logs that either come straight from the regressor
//! (noise-free: the fit must recover β to 1e-6) or from the simulator playing a designed
//! excitation on the true device with every sensor effect on.

use std::path::{Path, PathBuf};

use hapticgen_codegen::sym::poly::Poly;
use hapticgen_codegen::CheckedModel;
use hapticgen_host::identify::excite::{self, ExciteSettings};
use hapticgen_host::identify::fit::{self, FitSettings};
use hapticgen_host::identify::log::IdentificationLog;
use hapticgen_host::identify::regressor::RegressorTape;
use hapticgen_host::identify::trajectory::TrajectoryFile;

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn load(file: &str, variant: Option<&str>) -> CheckedModel {
    hapticgen_codegen::load_file(&workspace().join(file), file, variant).unwrap_or_else(|e| panic!("{e}"))
}

/// A deterministic factor in `±[1.1, 1.4]` (10–40 % up or down).
fn factor(state: &mut u64) -> f64 {
    *state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
    let u = (*state >> 11) as f64 / (1u64 << 53) as f64;
    let change = 0.1 + 0.3 * u;
    if (*state >> 7) & 1 == 0 {
        1.0 + change
    } else {
        1.0 / (1.0 + change)
    }
}

/// The "true" device: every body's mass, centre of mass and central inertia scaled by its own
/// factor of 10–40 %, every joint's viscous and Coulomb friction too.
fn perturbed(model: &CheckedModel, seed: u64) -> CheckedModel {
    let mut state = seed;
    let mut truth = model.clone();
    for body in &mut truth.model.bodies {
        body.mass = body.mass.scale(factor(&mut state));
        for c in body.com.iter_mut() {
            *c = c.scale(factor(&mut state));
        }
        let k = factor(&mut state);
        body.inertia = body.inertia.clone().map(|row| row.map(|p| p.scale(k)));
    }
    for joint in &mut truth.model.joints {
        joint.damping = joint.damping.scale(factor(&mut state)).add(&Poly::constant(1e-4));
        joint.drive.coulomb_friction = joint.drive.coulomb_friction * factor(&mut state) + 2e-3;
    }
    truth
}

/// The true device's base parameters (the nominal model's combinations of its standard ones).
fn true_base(regressor: &RegressorTape, truth: &CheckedModel) -> Vec<f64> {
    regressor.regressor.base_values(&regressor.regressor.standard_values(truth))
}

fn quick_design(model: &CheckedModel) -> TrajectoryFile {
    let settings = ExciteSettings { evaluations: 60, samples: 40, ..ExciteSettings::default() };
    excite::design(model, None, &settings, |_, _| {}).unwrap_or_else(|e| panic!("{e}")).file
}

/// A log straight from the regressor: exact angles, `τ = Y β_true` as the commanded torque,
/// at 1 kHz for `duration` from the end of the blend (the series itself: its highest harmonic
/// is what the filter must pass).
fn noise_free_log(
    regressor: &RegressorTape,
    trajectory: &TrajectoryFile,
    beta: &[f64],
    duration: f64,
) -> IdentificationLog {
    let (n, p) = (regressor.joints(), regressor.columns());
    let series = trajectory.series();
    let names = trajectory.joints.iter().map(|j| j.name.clone()).collect();
    let mut log = IdentificationLog::new(names);
    let mut scratch = regressor.scratch();
    let mut y = vec![0.0; n * p];
    for k in 0..(duration * 1000.0) as usize {
        let t = trajectory.ramp + k as f64 * 1e-3;
        let (q, qd, qdd) = TrajectoryFile::reference(&series, t, n);
        regressor.eval(&mut scratch, &q, &qd, &qdd, &mut y);
        let tau: Vec<f64> = (0..n).map(|r| (0..p).map(|c| y[r * p + c] * beta[c]).sum()).collect();
        log.push(t, &q, &vec![0.0; n], &tau);
    }
    log
}

#[test]
fn a_noise_free_log_gives_the_true_base_parameters() {
    for (file, variant) in [
        ("models/joystick_1dof.yaml", None),
        ("models/parallel_link_2dof.yaml", Some("vertical")),
        ("models/phantom_premium.yaml", None),
        ("models/falcon_delta.yaml", None),
    ] {
        let model = load(file, variant);
        let truth = perturbed(&model, 7);
        let regressor = RegressorTape::new(&model);
        let beta = true_base(&regressor, &truth);
        let trajectory = quick_design(&model);
        let log = noise_free_log(&regressor, &trajectory, &beta, 12.0);
        // Without noise no smoothing is needed: a cutoff far above the series' 0.5 Hz passes it
        // with a gain within 1e-10 of 1, and no row is left out.
        let settings =
            FitSettings { min_speed: 0.0, cutoff_hz: 100.0, decimate: 4, ..FitSettings::default() };
        let segment = fit::prepare(&log, &settings, file).unwrap_or_else(|e| panic!("{e}"));
        let fitted = fit::fit(&regressor, &[segment], &settings).unwrap_or_else(|e| panic!("{file}: {e}"));
        let norm = beta.iter().map(|b| b * b).sum::<f64>().sqrt();
        let error = fitted.beta.iter().zip(&beta).map(|(a, b)| (a - b).powi(2)).sum::<f64>().sqrt();
        for (c, base) in regressor.regressor.base.iter().enumerate() {
            println!("{file} {:>24}: true {:+.9e} fitted {:+.9e}", base.name, beta[c], fitted.beta[c]);
        }
        assert!(error <= 1e-6 * norm, "{file}: |β̂ − β| = {error:.3e}, |β| = {norm:.3e}");
    }
}
