//! Shortened runs of every experiment of the paper's section 6 (`hapticgen paper --quick`),
//! asserting the criteria of the report.

use hapticgen_host::paper::{run_experiments, Durations};

#[test]
fn every_experiment_meets_its_criteria() {
    let out = std::env::temp_dir().join(format!("hapticgen-paper-test-{}", std::process::id()));
    let report = run_experiments(&out, Durations::QUICK).expect("the experiments run");
    let experiments: Vec<&str> = report.checks.iter().map(|c| c.experiment.as_str()).collect();
    for name in ["Fig. 4", "Fig. 5", "Fig. 6", "§6.1", "Fig. 7", "free space"] {
        assert!(experiments.contains(&name), "no check for {name}");
    }
    for check in &report.checks {
        assert!(
            check.pass,
            "{}: {}: expected {}, measured {}",
            check.experiment, check.criterion, check.expected, check.measured
        );
    }
    let text = std::fs::read_to_string(out.join("report.md")).expect("report.md");
    assert!(text.contains("| experiment | criterion | expected | measured | result |"));
    for figure in ["fig4", "fig5", "fig6", "sec6-1", "fig7a-square", "fig7b-circle", "free-space"] {
        for extension in ["png", "svg"] {
            let path = out.join(format!("{figure}.{extension}"));
            assert!(path.exists(), "{} missing", path.display());
        }
        assert!(text.contains(&format!("{figure}.png")), "report does not show {figure}");
    }
    // Fig. 7's table: a cell under every header column, and the spring split s each row shows
    // is the one its penetration check quotes.
    let header = text.lines().find(|l| l.starts_with("| shape |")).expect("Fig. 7's table");
    let cells = |line: &str| {
        line.trim().trim_matches('|').split('|').map(|c| c.trim().to_string()).collect::<Vec<_>>()
    };
    for shape in ["square", "circle"] {
        let row = text.lines().find(|l| l.starts_with(&format!("| {shape} |"))).expect("a row");
        assert_eq!(cells(row).len(), cells(header).len(), "{header}\n{row}");
        let split_column =
            cells(header).iter().position(|c| c.starts_with("spring split")).expect("a split column");
        let check = report
            .checks
            .iter()
            .find(|c| {
                c.experiment == "Fig. 7" && c.criterion.starts_with(&format!("{shape}: maximum penetration"))
            })
            .expect("the check");
        let quoted =
            check.expected.split("spring split s = ").nth(1).expect("s quoted").trim_end_matches(" mm)");
        assert_eq!(cells(row)[split_column], quoted, "{row} vs {}", check.expected);
        assert_eq!(cells(row)[1], check.measured.trim_end_matches(" mm"), "{row} vs {}", check.measured);
    }
    let _ = std::fs::remove_dir_all(&out);
}

/// Fig. 4's step on the joystick with friction on in the plant: feeding the model's Coulomb
/// friction forward brings the response at small displacements back towards the
/// friction-free one. Measured on 3 s runs: the error falls to about 0.3× (the FULL run's
/// report, whose window also holds 3 s more of the final stick, says 0.65×).
#[test]
fn friction_compensation_cuts_the_small_displacement_error() {
    use hapticgen_host::closed_loop::SimConfig;
    use hapticgen_host::generated;
    use hapticgen_host::paper::small_displacement_error;
    use hapticgen_host::plant::Effects;
    use hapticgen_host::simulation::{Scenario, ScenarioSettings, Simulation};
    use hapticgen_runtime::control::ImpedanceLaw;

    let sim = Simulation::from_model(generated::load_shipped("joystick_1dof", None).expect("the joystick"))
        .expect("a simulation");
    let run = |friction: bool, compensation: Option<f64>| {
        let mut cfg = SimConfig::new(sim.home());
        cfg.law = ImpedanceLaw::NaturalInertia;
        cfg.duration = 3.0;
        cfg.spring_lead_time = sim.sampled_loop_delay();
        cfg.effects = Effects { friction, ..Effects::ALL };
        cfg.friction_compensation = compensation;
        let settings = ScenarioSettings { step: (1.0, 0.2), ..ScenarioSettings::default() };
        sim.apply_scenario(Scenario::Step, &settings, &mut cfg).expect("the step");
        let trace = sim.run(&cfg).expect("the run");
        assert_eq!(trace.fault, None);
        (trace.column("t").expect("t"), trace.column("x0").expect("x0"))
    };
    let (t, free) = run(false, None);
    let (_, rough) = run(true, None);
    let band = sim.friction_compensation_band();
    let (_, compensated) = run(true, Some(band));
    let steady = free[free.len() - 500..].iter().sum::<f64>() / 500.0;
    let (without, from) = small_displacement_error(&t, &rough, &free, steady).expect("the response settles");
    let (with, _) = small_displacement_error(&t, &compensated, &free, steady).expect("the response settles");
    assert!(from > 0.5 && from < 2.5, "the window starts at {from} s");
    assert!(without > 0.01, "friction shows: {without} rad");
    assert!(with <= 0.5 * without, "with compensation {with} rad, without {without} rad");
}
