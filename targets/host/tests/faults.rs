//! Fault injection on the parallel link's generated code (`hapticgen faults`): the safety
//! criteria that must hold in every scenario, and the detection of the faults the runtime
//! can see. The table with every measurement is in docs/reliability.md.

use std::path::Path;

use hapticgen_host::faults::{run, scenarios, table};
use hapticgen_host::simulation::Simulation;

#[test]
fn every_fault_scenario_keeps_the_commands_limited_finite_and_bounded() {
    let model = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models/parallel_link_2dof.yaml");
    let sim = Simulation::load(&model, None).unwrap();
    assert!(sim.uses_generated_code(), "the shipped model must run on its generated code");
    let all = scenarios(&sim);
    assert!(all.len() >= 13, "{} scenarios", all.len());
    let results: Vec<_> = all.iter().map(|f| run(&sim, f).unwrap()).collect();
    let report = table(&results);
    for r in &results {
        assert!(r.worst_torque_fraction <= 1.0 + 1e-12, "{}: torque over its limit\n{report}", r.name);
        assert!(!r.non_finite_output, "{}: a non-finite value left the runtime\n{report}", r.name);
        assert!(r.max_excursion < 0.5, "{}: the device ran away\n{report}", r.name);
        if r.fault.is_some() {
            assert!(r.held_until_reset, "{}: output resumed before the reset\n{report}", r.name);
            assert!(r.resumed_after_reset, "{}: control did not resume after the reset\n{report}", r.name);
        }
    }
    let by_name = |prefix: &str| results.iter().find(|r| r.name.starts_with(prefix)).unwrap();
    assert!(by_name("reference").pass && by_name("reference").fault.is_none(), "{report}");
    let nan = by_name("force sensor NaN");
    assert_eq!(nan.fault.as_ref().map(|f| f.0.as_str()), Some("NonFiniteInput"), "{report}");
    assert!(nan.time_to_safe.unwrap() <= 1e-3, "{report}");
    assert!(nan.pass, "{report}");
    for name in ["1 missed", "5 missed"] {
        let r = by_name(name);
        assert_eq!(r.fault.as_ref().map(|f| f.0.as_str()), Some("MissedTicks"), "{report}");
        // Detected at the next impedance tick that runs (see docs/reliability.md for the
        // current-loop watchdog that would bring this under 1 ms).
        assert!(r.time_to_safe.unwrap() <= 1e-3 * 6.5, "{report}");
    }
    for name in ["operator yanks", "plant masses", "driven into the singular"] {
        for r in results.iter().filter(|r| r.name.starts_with(name)) {
            assert!(r.pass, "{}: {}\n{report}", r.name, r.note);
            assert!(r.fault.is_none(), "{}: spurious fault\n{report}", r.name);
        }
    }
}
