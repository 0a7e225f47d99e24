use hapticgen_host::analysis::fit_step_response;
use hapticgen_host::generated;
use hapticgen_host::plant::Effects;
use hapticgen_host::sim::SimConfig;
use hapticgen_host::simulate::{Scenario, ScenarioSettings, Simulation};
use hapticgen_runtime::control::ImpedanceLaw;

fn main() {
    let sim = Simulation::from_model(generated::load_shipped("joystick_1dof", None).unwrap()).unwrap();
    let cases: Vec<(&str, Effects, usize)> = vec![
        ("all-but-friction", Effects { friction: false, ..Effects::ALL }, 1),
        ("ideal", Effects::IDEAL, 1),
        ("ideal no electrics", Effects { motor_electrics: false, ..Effects::IDEAL }, 1),
        ("ideal substeps4", Effects::IDEAL, 4),
        ("no backlash", Effects { friction: false, backlash: false, ..Effects::ALL }, 1),
    ];
    for (name, effects, sub) in cases {
        let mut cfg = SimConfig::new(sim.home());
        cfg.law = ImpedanceLaw::Controller2Mobility;
        cfg.stiffness = 1.0;
        cfg.damping = 0.01;
        cfg.effects = effects;
        cfg.substeps = sub;
        cfg.duration = 6.0;
        sim.apply_scenario(Scenario::Step, &ScenarioSettings::default(), &mut cfg).unwrap();
        let tr = sim.run(&cfg).unwrap();
        let t = tr.column("t").unwrap();
        let x = tr.column("x0").unwrap();
        let fit = fit_step_response(&t, &x, 0.2, 6.0, 0.0).unwrap();
        println!("{name}: {fit:?}");
    }
}
