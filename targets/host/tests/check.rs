//! `hapticgen check`, `eval` and `stats` from the command line: every bad-model fixture
//! (`codegen/tests/bad-models/`, one broken rule each) is rejected with exit code 1 and a
//! diagnostic starting `file:line:column:`; the shipped models pass; `eval --json` prints the
//! documented keys with the right shapes; `stats --json` counts every emitted function.

use std::path::{Path, PathBuf};
use std::process::Command;

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn hapticgen(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_hapticgen")).args(args).current_dir(workspace()).output().expect("runs")
}

#[test]
fn check_rejects_every_bad_model_with_line_and_column() {
    let dir = workspace().join("codegen/tests/bad-models");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().path()).collect();
    files.sort();
    assert!(files.len() >= 30, "only {} fixtures", files.len());
    for file in files.iter().filter(|f| f.extension().is_some_and(|x| x == "yaml")) {
        let name = format!("codegen/tests/bad-models/{}", file.file_name().unwrap().to_string_lossy());
        // Without --variant, `check` loads every variant, so a fixture broken in a non-default
        // variant is rejected too.
        let mut output = hapticgen(&["check", &name]);
        if output.status.success() {
            // Only bad for a variant the user names (unknown-variant.yaml).
            output = hapticgen(&["check", &name, "--variant", "no_such_variant"]);
        }
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(1), "{name}: {stderr}");
        let prefix = format!("error: {name}:");
        assert!(stderr.starts_with(&prefix), "{name}: {stderr}");
        let rest = &stderr[prefix.len()..];
        let mut parts = rest.splitn(3, ':');
        let line: usize = parts
            .next()
            .and_then(|l| l.parse().ok())
            .unwrap_or_else(|| panic!("{name}: no line in {stderr}"));
        let column: usize = parts
            .next()
            .and_then(|c| c.parse().ok())
            .unwrap_or_else(|| panic!("{name}: no column in {stderr}"));
        let lines = std::fs::read_to_string(file).unwrap().lines().count();
        assert!(line >= 1 && line <= lines.max(1) + 1 && column >= 1, "{name}: {line}:{column}");
    }
}

#[test]
fn shipped_models_pass_check() {
    for entry in std::fs::read_dir(workspace().join("models")).unwrap() {
        let path = entry.unwrap().path();
        let name = format!("models/{}", path.file_name().unwrap().to_string_lossy());
        let output = hapticgen(&["check", &name]);
        assert!(output.status.success(), "{name}: {}", String::from_utf8_lossy(&output.stderr));
    }
}

#[test]
fn eval_prints_every_quantity_with_its_shape() {
    let output =
        hapticgen(&["eval", "models/parallel_link_2dof.yaml", "--q", "1.2,0.3", "--qd", "0.5,-1", "--json"]);
    assert!(output.status.success());
    let value: serde_json::Value = serde_json::from_slice(&output.stdout).expect("JSON");
    for (key, rows, cols) in [
        ("p", 2, 0),
        ("J", 2, 2),
        ("Jdot", 2, 2),
        ("Jdot_qd", 2, 0),
        ("D", 2, 2),
        ("C", 2, 2),
        ("C_qd", 2, 0),
        ("g", 2, 0),
        ("B", 2, 2),
    ] {
        let v = value[key].as_array().unwrap_or_else(|| panic!("no key {key}"));
        assert_eq!(v.len(), rows, "{key}");
        if cols > 0 {
            assert!(v.iter().all(|row| row.as_array().map(Vec::len) == Some(cols)), "{key}");
        }
    }
    // Eq. (14): p = (l_l cos q1 − l_e cos q2, l_l sin q1 − l_e sin q2).
    let p0 = value["p"][0].as_f64().unwrap();
    assert!((p0 - (0.15 * 1.2f64.cos() - 0.05 * 0.3f64.cos())).abs() < 1e-15);
    // Another named point, and errors.
    let output = hapticgen(&["eval", "models/joystick_1dof.yaml", "--q", "0.3", "--point", "tip", "--json"]);
    let value: serde_json::Value = serde_json::from_slice(&output.stdout).expect("JSON");
    assert!((value["p"][0].as_f64().unwrap() - 0.15 * 0.3f64.sin()).abs() < 1e-15);
    assert_eq!(hapticgen(&["eval", "models/joystick_1dof.yaml", "--q", "0.3,0.1"]).status.code(), Some(1));
    assert_eq!(
        hapticgen(&["eval", "models/joystick_1dof.yaml", "--q", "0.3", "--point", "nope"]).status.code(),
        Some(1)
    );
}

#[test]
fn stats_counts_every_emitted_function() {
    let output = hapticgen(&["stats", "models/parallel_link_2dof.yaml", "--json"]);
    assert!(output.status.success());
    let value: serde_json::Value = serde_json::from_slice(&output.stdout).expect("JSON");
    for f in
        ["inertia_matrix", "coriolis_times_qdot", "gravity", "jacobian", "jacobian_dot_times_qdot", "terms"]
    {
        let counts = &value[f];
        for k in ["additions", "multiplications", "divisions", "square_roots", "trigonometric"] {
            assert!(counts[k].is_u64(), "{f}.{k}");
        }
    }
    assert!(value["terms"]["trigonometric"].as_u64().unwrap() <= 4);
}
