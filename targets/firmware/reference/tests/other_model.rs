//! `other_model_rules`: what `check-other-model` asks of a run of an image built from another
//! model file than its line's (`HAPTICGEN_FW_MODEL`).

use hapticgen_fw_reference::other_model_rules;

fn output(summary: &str, trace_lines: usize) -> String {
    let mut text = String::from("CAL instructions=1000 ticks=25600\n");
    for k in 0..trace_lines {
        text.push_str(&format!("S k={k} q=0 x=0 i=0\n"));
    }
    text.push_str(&format!("SUMMARY {summary}\n"));
    text
}

const LINE: &str = "periods=15000 impedance_ticks=2000 fault=0 plant_ok=1 checksum=0x1111";

#[test]
fn a_run_of_the_scenario_s_length_without_a_fault_and_with_its_own_trajectory_passes() {
    let (host32, reference) = (output(LINE, 3), output(LINE, 3));
    let target = output("periods=15000 impedance_ticks=2000 fault=0 plant_ok=1 checksum=0x2222", 3);
    assert_eq!(other_model_rules(&target, &host32, &reference), Vec::<String>::new());
}

#[test]
fn each_broken_rule_is_named() {
    let (host32, reference) = (output(LINE, 3), output(LINE, 3));
    let cases = [
        (
            "periods=14999 impedance_ticks=2000 fault=0 plant_ok=1 checksum=0x2",
            3,
            "`periods`: target Ok(14999)",
        ),
        ("periods=15000 impedance_ticks=1999 fault=0 plant_ok=1 checksum=0x2", 3, "`impedance_ticks`"),
        ("periods=15000 impedance_ticks=2000 fault=3 plant_ok=1 checksum=0x2", 3, "a fault was latched"),
        ("periods=15000 impedance_ticks=2000 fault=0 plant_ok=0 checksum=0x2", 3, "plant broke"),
        // The line's own trajectory bit for bit: the image was built from the line's model.
        (
            "periods=15000 impedance_ticks=2000 fault=0 plant_ok=1 checksum=0x1111",
            3,
            "is the line's own model's",
        ),
        ("periods=15000 impedance_ticks=2000 fault=0 plant_ok=1", 3, "trajectory checksum ?"),
        (
            "periods=15000 impedance_ticks=2000 fault=0 plant_ok=1 checksum=0x2",
            2,
            "2 trace lines on the target, 3",
        ),
    ];
    for (summary, lines, expected) in cases {
        let errors = other_model_rules(&output(summary, lines), &host32, &reference);
        assert_eq!(errors.len(), 1, "{summary}: {errors:?}");
        assert!(errors[0].contains(expected), "{summary}: {errors:?}");
    }
    let errors = other_model_rules("no summary", &host32, &reference);
    assert_eq!(errors, vec!["missing SUMMARY line (did the image finish?)".to_string()]);
}
