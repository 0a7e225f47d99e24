//! Side-by-side benchmarks: each generated quantity (D, C q̇, g, p, J, J̇ q̇, the fused
//! `terms`) of every shipped open-chain rig, the inverse dynamics of the serial ones and the
//! parallel link's full control tick against the baseline a user would write instead, a
//! generic implementation on nalgebra, in the same run; prints the ratios. The baselines:
//! for the joystick and the parallel link, per-body Jacobians and the Lagrangian formulas
//! (`hapticgen_tests::baseline`); for the serial rigs (planar arm, PHANToM-like arm,
//! PUMA 560), the recursive Newton–Euler and composite-rigid-body algorithms and the geometric
//! Jacobian (`hapticgen_tests::baseline_serial`).
//!
//! `cargo bench -p hapticgen-tests --bench dynamics`
//!
//! Timing: each measurement is the best of 25 batches of 2,000 calls over 64 prepared random
//! states (the minimum is the least disturbed by the shared machine).

use std::hint::black_box;
use std::time::Instant;

use hapticgen_codegen::model;
use hapticgen_runtime::control::{
    ControlOptions, ImpedanceController, ImpedanceLaw, ImpedanceParameters, TaskReference,
};
use hapticgen_runtime::current_loop::CurrentLoopBank;
use hapticgen_runtime::current_loop::CurrentLoopGains;
use hapticgen_runtime::estimation::JointStateEstimator;
use hapticgen_runtime::estimation::{EstimatorSettings, ForceSensorCalibration};
use hapticgen_runtime::fused::FusedImpedance;
use hapticgen_runtime::safety::SafetyMonitor;
use hapticgen_runtime::tick::{HapticLoop, HapticLoopSettings, ImpedanceInputs};
use hapticgen_runtime::RigModel;
use hapticgen_tests::baseline::{BaselineTerms, PlanarBaseline};
use hapticgen_tests::baseline_serial::SerialBaseline;
use hapticgen_tests::stack::{circle_scene, encoder_counts, parallel_link_settings};
use hapticgen_tests::workspace_root;
use hapticgen_tests::{
    joystick_1dof_f64, parallel_link_2dof_horizontal_f64, parallel_link_2dof_vertical_f64, phantom_3dof_f64,
    planar_arm_2dof_horizontal_f64, planar_arm_2dof_vertical_f64, puma560_f64,
};
use nalgebra::{DMatrix, DVector};
use rand::rngs::SmallRng;
use rand::{Rng, SeedableRng};

const STATES: usize = 64;
const CALLS: usize = 2000;
const BATCHES: usize = 25;

/// Nanoseconds per call, best batch.
fn nanoseconds(mut call: impl FnMut(usize)) -> f64 {
    let mut best = f64::INFINITY;
    for _ in 0..BATCHES {
        let start = Instant::now();
        for k in 0..CALLS {
            call(k % STATES);
        }
        best = best.min(start.elapsed().as_secs_f64() * 1e9 / CALLS as f64);
    }
    best
}

fn row(rig: &str, what: &str, generated: f64, baseline: f64) {
    println!("| {rig} | {what} | {generated:.1} | {baseline:.1} | {:.1}× |", baseline / generated);
}

/// The functions both baselines offer.
trait Baseline {
    fn inertia_matrix(&self, q: &DVector<f64>) -> DMatrix<f64>;
    fn coriolis_times_qdot(&self, q: &DVector<f64>, qd: &DVector<f64>) -> DVector<f64>;
    fn gravity(&self, q: &DVector<f64>) -> DVector<f64>;
    fn position(&self, q: &DVector<f64>) -> DVector<f64>;
    fn jacobian(&self, q: &DVector<f64>) -> DMatrix<f64>;
    fn jacobian_dot_times_qdot(&self, q: &DVector<f64>, qd: &DVector<f64>) -> DVector<f64>;
    fn terms(&self, q: &DVector<f64>, qd: &DVector<f64>) -> BaselineTerms;
    /// `τ = D q̈ + C q̇ + g`, if the baseline has it.
    fn inverse_dynamics(&self, _: &DVector<f64>, _: &DVector<f64>, _: &DVector<f64>) -> Option<DVector<f64>> {
        None
    }
}

/// The trait's functions as the baseline's inherent functions of the same names.
macro_rules! inherent {
    ($t:ty) => {
        fn inertia_matrix(&self, q: &DVector<f64>) -> DMatrix<f64> {
            <$t>::inertia_matrix(self, q)
        }
        fn coriolis_times_qdot(&self, q: &DVector<f64>, qd: &DVector<f64>) -> DVector<f64> {
            <$t>::coriolis_times_qdot(self, q, qd)
        }
        fn gravity(&self, q: &DVector<f64>) -> DVector<f64> {
            <$t>::gravity(self, q)
        }
        fn position(&self, q: &DVector<f64>) -> DVector<f64> {
            <$t>::position(self, q)
        }
        fn jacobian(&self, q: &DVector<f64>) -> DMatrix<f64> {
            <$t>::jacobian(self, q)
        }
        fn jacobian_dot_times_qdot(&self, q: &DVector<f64>, qd: &DVector<f64>) -> DVector<f64> {
            <$t>::jacobian_dot_times_qdot(self, q, qd)
        }
        fn terms(&self, q: &DVector<f64>, qd: &DVector<f64>) -> BaselineTerms {
            <$t>::terms(self, q, qd)
        }
    };
}

impl Baseline for PlanarBaseline {
    inherent!(PlanarBaseline);
}

impl Baseline for SerialBaseline {
    inherent!(SerialBaseline);
    fn inverse_dynamics(
        &self,
        q: &DVector<f64>,
        qd: &DVector<f64>,
        qdd: &DVector<f64>,
    ) -> Option<DVector<f64>> {
        Some(SerialBaseline::inverse_dynamics(self, q, qd, qdd))
    }
}

/// A shipped model file, loaded with one variant.
fn load(file: &str, variant: Option<&str>) -> model::Model {
    hapticgen_codegen::load_file(&workspace_root().join(file), file, variant).expect("shipped model").model
}

/// Times every quantity of one rig against `baseline` (of the model `loaded`), printing one
/// row each; the inverse dynamics too when the baseline has it.
fn quantities<R: RigModel<N, M, Scalar = f64>, B: Baseline, const N: usize, const M: usize>(
    name: &str,
    loaded: &model::Model,
    rig: &R,
    baseline: &B,
) {
    let mut rng = SmallRng::seed_from_u64(1);
    let states: Vec<([f64; N], [f64; N], [f64; N])> = (0..STATES)
        .map(|_| {
            let q = std::array::from_fn(|i| rng.gen_range(loaded.joints[i].lower..loaded.joints[i].upper));
            let qd = std::array::from_fn(|_| rng.gen_range(-2.0..2.0));
            let qdd = std::array::from_fn(|_| rng.gen_range(-2.0..2.0));
            (q, qd, qdd)
        })
        .collect();
    let vectors: Vec<(DVector<f64>, DVector<f64>, DVector<f64>)> = states
        .iter()
        .map(|(q, qd, qdd)| {
            (DVector::from_column_slice(q), DVector::from_column_slice(qd), DVector::from_column_slice(qdd))
        })
        .collect();
    macro_rules! compare {
        ($what:expr, $gen:expr, $base:expr) => {{
            let g = nanoseconds(|k| {
                let (q, qd, qdd) = &states[k];
                black_box($gen(black_box(q), black_box(qd), black_box(qdd)));
            });
            let b = nanoseconds(|k| {
                let (q, qd, qdd) = &vectors[k];
                black_box($base(black_box(q), black_box(qd), black_box(qdd)));
            });
            row(name, $what, g, b);
        }};
    }
    compare!("D", |q, _, _| rig.inertia_matrix(q), |q, _, _| baseline.inertia_matrix(q));
    compare!("C q̇", |q, qd, _| rig.coriolis_times_qdot(q, qd), |q, qd, _| baseline
        .coriolis_times_qdot(q, qd));
    compare!("g", |q, _, _| rig.gravity(q), |q, _, _| baseline.gravity(q));
    compare!("p", |q, _, _| rig.position(q), |q, _, _| baseline.position(q));
    compare!("J", |q, _, _| rig.jacobian(q), |q, _, _| baseline.jacobian(q));
    compare!("J̇ q̇", |q, qd, _| rig.jacobian_dot_times_qdot(q, qd), |q, qd, _| baseline
        .jacobian_dot_times_qdot(q, qd));
    compare!("all six (fused `terms`)", |q, qd, _| rig.terms(q, qd), |q, qd, _| baseline.terms(q, qd));
    if baseline.inverse_dynamics(&vectors[0].0, &vectors[0].1, &vectors[0].2).is_some() {
        compare!("inverse dynamics (RNEA)", |q, qd, qdd| rig.inverse_dynamics(q, qd, qdd), |q, qd, qdd| {
            baseline.inverse_dynamics(q, qd, qdd)
        });
    }
}

type ParallelLink = parallel_link_2dof_vertical_f64::ParallelLink2dof;

/// One full 1 kHz tick of the parallel link (estimation, Controller 3, rendering, safety, one
/// current-loop step): the runtime with the fused generated law, the runtime's generic law on
/// the generated terms, and the same runtime pieces around the nalgebra baseline.
fn full_tick() {
    let measured = [0.1, -0.1];
    let mut fused = HapticLoop::new(
        ParallelLink::NOMINAL,
        circle_scene(),
        &parallel_link_settings(ImpedanceLaw::JacobianTranspose),
    )
    .expect("settings");
    let mut tick = 0u32;
    let fused_ns = nanoseconds(|_| {
        tick = tick.wrapping_add(1);
        let inputs = ImpedanceInputs { encoder_counts: encoder_counts(tick), force_readings: [2.5; 2], tick };
        black_box(fused.impedance_tick_fused(black_box(&inputs)));
        black_box(fused.current_tick(black_box(&measured)));
    });
    let mut generic = HapticLoop::new(
        ParallelLink::NOMINAL,
        circle_scene(),
        &parallel_link_settings(ImpedanceLaw::JacobianTranspose),
    )
    .expect("settings");
    let mut tick = 0u32;
    let generic_ns = nanoseconds(|_| {
        tick = tick.wrapping_add(1);
        let inputs = ImpedanceInputs { encoder_counts: encoder_counts(tick), force_readings: [2.5; 2], tick };
        black_box(generic.impedance_tick(black_box(&inputs)));
        black_box(generic.current_tick(black_box(&measured)));
    });
    // The baseline tick: the same estimator, renderer, safety rules and current loop, with the
    // rig terms and the law on nalgebra.
    let file = "models/parallel_link_2dof.yaml";
    let loaded = hapticgen_codegen::load_file(&workspace_root().join(file), file, Some("vertical"))
        .expect("shipped model");
    let baseline = PlanarBaseline::new(&loaded).expect("planar");
    let s = parallel_link_settings(ImpedanceLaw::JacobianTranspose);
    let drives = ParallelLink::DRIVES;
    let mut estimator = JointStateEstimator::new(&drives, &s.estimator, s.zero_offset, s.initial_counts);
    let mut scene = circle_scene();
    let mut safety = SafetyMonitor::new(&drives, 1);
    let mut currents = CurrentLoopBank::with_gains(&s.current_gains, &[24.0; 2]);
    let mut parameters = s.controller.parameters;
    let mut tick = 0u32;
    let baseline_ns = nanoseconds(|_| {
        tick = tick.wrapping_add(1);
        safety.check_tick(tick);
        let _ = estimator.update(&encoder_counts(tick));
        let state = *estimator.state();
        let q = DVector::from_column_slice(&state.position);
        let qd = DVector::from_column_slice(&state.velocity);
        let terms = baseline.terms(&q, &qd);
        let reference = scene.update_reference(&[terms.position[0], terms.position[1]], &mut parameters);
        let torque = baseline.jacobian_transpose(
            &terms,
            &qd,
            &DVector::from_column_slice(&reference.position),
            &DVector::from_column_slice(&parameters.stiffness),
            &DVector::from_column_slice(&parameters.damping),
        );
        let command = safety.limit(&[torque[0], torque[1]]);
        black_box(currents.step(&command.current, black_box(&measured)));
    });
    println!("| parallel link (vertical) | full tick, generic runtime law on the generated terms | {generic_ns:.1} | {baseline_ns:.1} | {:.1}× |", baseline_ns / generic_ns);
    println!("| parallel link (vertical) | full tick, fused generated law | {fused_ns:.1} | {baseline_ns:.1} | {:.1}× |", baseline_ns / fused_ns);
}

/// One full 1 kHz tick of a serial rig (estimation, Controller 3 towards a fixed task-space
/// reference 1 cm from the start, safety, one current-loop step), as [`full_tick`] times the
/// parallel link's: the runtime with the fused generated law, its generic law on the generated
/// terms, and the same runtime pieces around the Newton–Euler baseline. The joints move on
/// slow sines about `start` (rad); a fixed reference stands in for the renderer, which is
/// planar.
fn serial_tick<R, const N: usize, const M: usize>(
    name: &str,
    rig: R,
    baseline: &SerialBaseline,
    current_gains: [CurrentLoopGains<f64>; N],
    start: [f64; N],
) where
    R: FusedImpedance<N, M, Scalar = f64> + Clone,
{
    let measured = [0.1; N];
    let drives = rig.drives();
    let supply = drives.map(|d| d.supply_voltage);
    let start_position = rig.position(&start);
    let reference = TaskReference::at_rest(std::array::from_fn(|i| start_position[i] + 0.01));
    let settings = HapticLoopSettings {
        controller: ImpedanceController {
            law: ImpedanceLaw::JacobianTranspose,
            parameters: ImpedanceParameters { stiffness: [200.0; M], damping: [5.0; M], mass: [0.2; M] },
            options: ControlOptions { min_abs_jacobian_determinant: 1e-4, ..ControlOptions::paper() },
        },
        estimator: EstimatorSettings {
            sample_period: 1e-3,
            velocity_cutoff_hz: 50.0,
            acceleration_cutoff_hz: 20.0,
        },
        zero_offset: start,
        initial_counts: [0; N],
        force_calibration: ForceSensorCalibration { scale: [5.0; M], offset: [2.5; M] },
        current_gains,
        max_tick_gap: 1,
    };
    // About ±0.03 rad at the joints (24,000 counts per joint turn or more), at 0.3–0.5 Hz.
    let counts = |tick: u32| -> [i32; N] {
        let t = f64::from(tick) * 1e-3;
        std::array::from_fn(|j| (120.0 * ((2.0 + 0.3 * j as f64) * t).sin()) as i32)
    };
    // The three loops see the same inputs, so their last commands must agree.
    let mut last = [[f64::NAN; N]; 3];
    let mut fused = HapticLoop::new(rig.clone(), reference, &settings).expect("settings");
    let mut tick = 0u32;
    let fused_ns = nanoseconds(|_| {
        tick = tick.wrapping_add(1);
        let inputs = ImpedanceInputs { encoder_counts: counts(tick), force_readings: [2.5; M], tick };
        let report = black_box(fused.impedance_tick_fused(black_box(&inputs)));
        assert!(report.command.fault.is_none(), "{name}: fault {:?}", report.command.fault);
        last[0] = report.command.torque;
        black_box(fused.current_tick(black_box(&measured)));
    });
    let mut generic = HapticLoop::new(rig, reference, &settings).expect("settings");
    let mut tick = 0u32;
    let generic_ns = nanoseconds(|_| {
        tick = tick.wrapping_add(1);
        let inputs = ImpedanceInputs { encoder_counts: counts(tick), force_readings: [2.5; M], tick };
        let report = black_box(generic.impedance_tick(black_box(&inputs)));
        last[1] = report.command.torque;
        black_box(generic.current_tick(black_box(&measured)));
    });
    let mut estimator = JointStateEstimator::new(&drives, &settings.estimator, start, [0; N]);
    let mut safety = SafetyMonitor::new(&drives, 1);
    let mut currents = CurrentLoopBank::with_gains(&current_gains, &supply);
    let parameters = settings.controller.parameters;
    let mut tick = 0u32;
    let baseline_ns = nanoseconds(|_| {
        tick = tick.wrapping_add(1);
        safety.check_tick(tick);
        let _ = estimator.update(&counts(tick));
        let state = *estimator.state();
        let q = DVector::from_column_slice(&state.position);
        let qd = DVector::from_column_slice(&state.velocity);
        let terms = baseline.terms(&q, &qd);
        let torque = baseline.jacobian_transpose(
            &terms,
            &qd,
            &DVector::from_column_slice(&reference.position),
            &DVector::from_column_slice(&parameters.stiffness),
            &DVector::from_column_slice(&parameters.damping),
        );
        let command = safety.limit(&std::array::from_fn(|j| torque[j]));
        last[2] = command.torque;
        black_box(currents.step(&command.current, black_box(&measured)));
    });
    for j in 0..N {
        let scale = last[2].iter().fold(1.0f64, |m, x| m.max(x.abs()));
        assert!(
            (last[0][j] - last[2][j]).abs() <= 1e-9 * scale
                && (last[1][j] - last[2][j]).abs() <= 1e-9 * scale,
            "{name}: last torques differ: fused {:?}, generic {:?}, baseline {:?}",
            last[0],
            last[1],
            last[2]
        );
    }
    row(name, "full tick, generic runtime law on the generated terms", generic_ns, baseline_ns);
    row(name, "full tick, fused generated law", fused_ns, baseline_ns);
}

fn main() {
    // `cargo bench` passes `--bench`; `cargo test --benches` passes nothing: run quickly then.
    let benchmarking = std::env::args().any(|a| a == "--bench");
    if !benchmarking {
        println!("dynamics benchmark: run with `cargo bench -p hapticgen-tests --bench dynamics`");
        return;
    }
    println!("| rig | quantity | generated ns | nalgebra baseline ns | ratio |");
    println!("| --- | --- | --- | --- | --- |");
    let planar = |file, variant| {
        let loaded = load(file, variant);
        let baseline = PlanarBaseline::new(&loaded).expect("a planar rig");
        (loaded, baseline)
    };
    let serial = |file, variant| {
        let loaded = load(file, variant);
        let baseline = SerialBaseline::new(&loaded).expect("a serial rig");
        (loaded, baseline)
    };
    let (m, b) = planar("models/joystick_1dof.yaml", None);
    quantities("joystick", &m, &joystick_1dof_f64::Joystick1dof::NOMINAL, &b);
    let (m, b) = planar("models/parallel_link_2dof.yaml", Some("vertical"));
    quantities(
        "parallel link (vertical)",
        &m,
        &parallel_link_2dof_vertical_f64::ParallelLink2dof::NOMINAL,
        &b,
    );
    let (m, b) = planar("models/parallel_link_2dof.yaml", Some("horizontal"));
    quantities(
        "parallel link (horizontal)",
        &m,
        &parallel_link_2dof_horizontal_f64::ParallelLink2dof::NOMINAL,
        &b,
    );
    full_tick();
    let (m, b) = serial("models/planar_arm_2dof.yaml", Some("vertical"));
    quantities("planar arm (vertical)", &m, &planar_arm_2dof_vertical_f64::PlanarArm2dof::NOMINAL, &b);
    type PlanarArm = planar_arm_2dof_vertical_f64::PlanarArm2dof;
    let start = [70f64.to_radians(), 30f64.to_radians()];
    serial_tick("planar arm (vertical)", PlanarArm::NOMINAL, &b, PlanarArm::CURRENT_LOOP_GAINS, start);
    let (m, b) = serial("models/planar_arm_2dof.yaml", Some("horizontal"));
    quantities("planar arm (horizontal)", &m, &planar_arm_2dof_horizontal_f64::PlanarArm2dof::NOMINAL, &b);
    let (m, b) = serial("models/phantom_3dof.yaml", None);
    quantities("PHANToM-like arm", &m, &phantom_3dof_f64::Phantom3dof::NOMINAL, &b);
    type Phantom = phantom_3dof_f64::Phantom3dof;
    let start = [0.0, 20f64.to_radians(), 30f64.to_radians()];
    serial_tick("PHANToM-like arm", Phantom::NOMINAL, &b, Phantom::CURRENT_LOOP_GAINS, start);
    let (m, b) = serial("models/puma560.yaml", None);
    quantities("PUMA 560", &m, &puma560_f64::Puma560::NOMINAL, &b);
    type Puma = puma560_f64::Puma560;
    let start = [0.0, 45f64, -180.0, 0.0, 45.0, 0.0].map(f64::to_radians);
    serial_tick("PUMA 560", Puma::NOMINAL, &b, Puma::CURRENT_LOOP_GAINS, start);
}
