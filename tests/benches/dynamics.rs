//! Side-by-side benchmarks: each generated quantity (D, C q̇, g, p, J, J̇ q̇) and the full
//! control tick of every shipped planar rig against the baseline a user would write instead, a
//! generic implementation on nalgebra (`hapticgen_tests::baseline`: per-body Jacobians and the
//! Lagrangian formulas), in the same run; prints the ratios.
//!
//! `cargo bench -p hapticgen-tests --bench dynamics`
//!
//! Timing: each measurement is the best of 25 batches of 2,000 calls over 64 prepared random
//! states (the minimum is the least disturbed by the shared machine).

use std::hint::black_box;
use std::time::Instant;

use hapticgen_codegen::model;
use hapticgen_runtime::control::ImpedanceLaw;
use hapticgen_runtime::current_loop::CurrentLoopBank;
use hapticgen_runtime::estimation::JointStateEstimator;
use hapticgen_runtime::safety::SafetyMonitor;
use hapticgen_runtime::tick::{HapticLoop, ImpedanceInputs};
use hapticgen_runtime::RigModel;
use hapticgen_tests::baseline::PlanarBaseline;
use hapticgen_tests::stack::{circle_scene, encoder_counts, parallel_link_settings};
use hapticgen_tests::workspace_root;
use hapticgen_tests::{
    joystick_1dof_f64, parallel_link_2dof_horizontal_f64, parallel_link_2dof_vertical_f64,
};
use nalgebra::DVector;
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

fn quantities<R: RigModel<N, M, Scalar = f64>, const N: usize, const M: usize>(
    name: &str,
    file: &str,
    variant: Option<&str>,
    rig: &R,
) {
    let loaded = model::load_file(&workspace_root().join(file), file, variant).expect("shipped model");
    let baseline = PlanarBaseline::new(&loaded).expect("a planar rig");
    let mut rng = SmallRng::seed_from_u64(1);
    let states: Vec<([f64; N], [f64; N])> = (0..STATES)
        .map(|_| {
            let q = std::array::from_fn(|i| rng.gen_range(loaded.joints[i].lower..loaded.joints[i].upper));
            let qd = std::array::from_fn(|_| rng.gen_range(-2.0..2.0));
            (q, qd)
        })
        .collect();
    let vectors: Vec<(DVector<f64>, DVector<f64>)> = states
        .iter()
        .map(|(q, qd)| (DVector::from_column_slice(q), DVector::from_column_slice(qd)))
        .collect();
    macro_rules! compare {
        ($what:expr, $gen:expr, $base:expr) => {{
            let g = nanoseconds(|k| {
                let (q, qd) = &states[k];
                black_box($gen(black_box(q), black_box(qd)));
            });
            let b = nanoseconds(|k| {
                let (q, qd) = &vectors[k];
                black_box($base(black_box(q), black_box(qd)));
            });
            row(name, $what, g, b);
        }};
    }
    compare!("D", |q, _qd| rig.inertia_matrix(q), |q, _qd| baseline.inertia_matrix(q));
    compare!("C q̇", |q, qd| rig.coriolis_times_qdot(q, qd), |q, qd| baseline.coriolis_times_qdot(q, qd));
    compare!("g", |q, _qd| rig.gravity(q), |q, _qd| baseline.gravity(q));
    compare!("p", |q, _qd| rig.position(q), |q, _qd| baseline.position(q));
    compare!("J", |q, _qd| rig.jacobian(q), |q, _qd| baseline.jacobian(q));
    compare!("J̇ q̇", |q, qd| rig.jacobian_dot_times_qdot(q, qd), |q, qd| baseline
        .jacobian_dot_times_qdot(q, qd));
    compare!("all six (fused `terms`)", |q, qd| rig.terms(q, qd), |q, qd| baseline.terms(q, qd));
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
        &parallel_link_settings(ImpedanceLaw::Controller3),
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
        &parallel_link_settings(ImpedanceLaw::Controller3),
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
    let loaded =
        model::load_file(&workspace_root().join(file), file, Some("vertical")).expect("shipped model");
    let baseline = PlanarBaseline::new(&loaded).expect("planar");
    let s = parallel_link_settings(ImpedanceLaw::Controller3);
    let drives = ParallelLink::DRIVES;
    let mut estimator = JointStateEstimator::new(&drives, &s.estimator, s.zero_offset, s.initial_counts);
    let mut scene = circle_scene();
    let mut safety = SafetyMonitor::new(&drives, 1);
    let mut currents = CurrentLoopBank::new(s.current_gains, &[24.0; 2]);
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
        let torque = baseline.controller3(
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

fn main() {
    // `cargo bench` passes `--bench`; `cargo test --benches` passes nothing: run quickly then.
    let benchmarking = std::env::args().any(|a| a == "--bench");
    if !benchmarking {
        println!("dynamics benchmark: run with `cargo bench -p hapticgen-tests --bench dynamics`");
        return;
    }
    println!("| rig | quantity | generated ns | nalgebra baseline ns | ratio |");
    println!("| --- | --- | --- | --- | --- |");
    quantities("joystick", "models/joystick_1dof.yaml", None, &joystick_1dof_f64::Joystick1dof::NOMINAL);
    quantities(
        "parallel link (vertical)",
        "models/parallel_link_2dof.yaml",
        Some("vertical"),
        &parallel_link_2dof_vertical_f64::ParallelLink2dof::NOMINAL,
    );
    quantities(
        "parallel link (horizontal)",
        "models/parallel_link_2dof.yaml",
        Some("horizontal"),
        &parallel_link_2dof_horizontal_f64::ParallelLink2dof::NOMINAL,
    );
    full_tick();
}
