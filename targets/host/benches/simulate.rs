//! `cargo bench -p hapticgen --bench simulate`: one simulated second of the 2-DOF parallel link
//! with the full control stack (generated rig, estimation, Controller 3 with haptic rendering,
//! safety, PI current loops at 7.5 kHz) and every plant effect on, and the real-time factor
//! (simulated seconds per wall second; the target is at least 100).

use std::time::Instant;

use criterion::{criterion_group, criterion_main, Criterion};
use hapticgen_host::closed_loop::SimConfig;
use hapticgen_host::generated;
use hapticgen_host::simulation::{Scenario, ScenarioSettings, Simulation};
use hapticgen_runtime::control::ImpedanceLaw;

fn setup() -> (Simulation, SimConfig) {
    let model = generated::load_shipped("parallel_link_2dof", Some("vertical")).expect("shipped model");
    let sim = Simulation::from_model(model).expect("simulation");
    let mut cfg = SimConfig::new(sim.home());
    cfg.law = ImpedanceLaw::JacobianTranspose;
    cfg.stiffness = 1500.0;
    cfg.damping = 5.0;
    sim.apply_scenario(Scenario::TraceCircle, &ScenarioSettings::default(), &mut cfg).expect("scenario");
    cfg.duration = 1.0;
    (sim, cfg)
}

fn simulate(c: &mut Criterion) {
    let (sim, cfg) = setup();
    let start = Instant::now();
    let mut simulated = 0.0;
    for _ in 0..5 {
        simulated += sim.run(&cfg).expect("runs").duration();
    }
    let ratio = simulated / start.elapsed().as_secs_f64();
    println!("2-DOF parallel link, full stack: {ratio:.0}× faster than real time (simulated s / wall s)");
    let mut group = c.benchmark_group("simulate");
    group.sample_size(10);
    group.bench_function("parallel_link_2dof_1s_full_stack", |b| b.iter(|| sim.run(&cfg).expect("runs")));
    group.finish();
}

criterion_group!(benches, simulate);
criterion_main!(benches);
