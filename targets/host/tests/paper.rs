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
    let _ = std::fs::remove_dir_all(&out);
}
