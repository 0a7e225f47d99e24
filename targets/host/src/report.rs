//! Pass/fail rows of a report (`hapticgen paper`, `hapticgen contact`): what was checked, the
//! expectation, the measured figure, and the Markdown table and failure lines made of them.

use std::fmt::Write as _;

/// One line of a report.
#[derive(Clone, Debug)]
pub struct Check {
    /// Experiment (figure, section or scenario).
    pub experiment: String,
    /// What is checked.
    pub criterion: String,
    /// The expected value or bound.
    pub expected: String,
    /// The measured value.
    pub measured: String,
    /// Whether it passed.
    pub pass: bool,
}

/// The checks as a Markdown table, one row each.
pub fn table(checks: &[Check]) -> String {
    let mut text = String::from(
        "| experiment | criterion | expected | measured | result |\n| --- | --- | --- | --- | --- |\n",
    );
    for c in checks {
        writeln!(
            text,
            "| {} | {} | {} | {} | {} |",
            c.experiment,
            c.criterion,
            c.expected,
            c.measured,
            if c.pass { "pass" } else { "**FAIL**" }
        )
        .ok();
    }
    text
}

/// A line `FAIL experiment: criterion: expected …, measured …` per failed check.
pub fn failures(checks: &[Check]) -> String {
    let mut text = String::new();
    for c in checks.iter().filter(|c| !c.pass) {
        writeln!(
            text,
            "FAIL {}: {}: expected {}, measured {}",
            c.experiment, c.criterion, c.expected, c.measured
        )
        .ok();
    }
    text
}
