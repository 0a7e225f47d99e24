//! `hapticgen check`, `eval` and `stats` from the command line: every bad-model fixture
//! (`codegen/tests/bad-models/`, one broken rule each) is rejected with exit code 1 and a
//! diagnostic starting `file:line:column:`; the shipped models pass; `eval --json` prints the
//! documented keys with the right shapes; `stats --json` counts every emitted function; a model
//! typed in grams is refused at the drive's line with the numbers, and a closed chain names the
//! assembly branch its `assembly` angles led to.

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
    let output = hapticgen(&["eval", "models/parallel_link_2dof.yaml", "--q", "1.2,0.3", "--qd", "0.5,-1"]);
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
    let output = hapticgen(&["eval", "models/joystick_1dof.yaml", "--q", "0.3", "--point", "tip"]);
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

#[test]
fn grams_typed_as_kilograms_fail_check_with_the_numbers() {
    let text = std::fs::read_to_string(workspace().join("models/falcon_delta.yaml")).unwrap();
    // The shipped file writes its masses with units (`20 g`); a newcomer who drops the unit
    // writes kilograms.
    let grams = text
        .replace("value: 20 g", "value: 20")
        .replace("mass: 10 g", "mass: 10")
        .replace("mass: 60 g", "mass: 60");
    assert_ne!(grams, text, "the shipped Falcon no longer writes its masses as `20 g`; update this test");
    let file = std::env::temp_dir().join(format!("hapticgen-check-grams-{}.yaml", std::process::id()));
    std::fs::write(&file, grams).unwrap();
    let output = hapticgen(&["check", file.to_str().unwrap()]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(!output.status.success(), "{stderr}");
    assert!(output.stdout.is_empty(), "no `ok` line: {}", String::from_utf8_lossy(&output.stdout));
    assert!(stderr.contains(&format!("error: {}:", file.display())), "{stderr}");
    assert!(
        stderr.contains("drives.capstan.torque_limit: drive `capstan` of joint `theta1` cannot hold the rig"),
        "{stderr}"
    );
    assert!(
        stderr.contains("warning:") && stderr.contains("bodies[0].mass: body `thigh1` weighs 20 kg"),
        "{stderr}"
    );
    assert!(stderr.contains("did you mean 20 g (0.02 kg)?"), "{stderr}");
    std::fs::remove_file(&file).ok();
}

#[test]
fn a_closed_chain_names_its_assembly_branch() {
    let output = hapticgen(&["check", "models/falcon_delta.yaml"]);
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    assert!(
        output.stderr.is_empty(),
        "the shipped Delta is plausible: {}",
        String::from_utf8_lossy(&output.stderr)
    );
    assert!(
        stdout.contains(
            "assembly branch: at the middle of the joint ranges, q = (0.350, 0.350, 0.350) rad: the task point `grip` at \
             (0.0000, 0.0000, -0.0988) m"
        ),
        "{stdout}"
    );
}

#[test]
fn simulate_names_an_implausible_model_before_the_run() {
    // The joystick's masses in grams: its drive cannot hold it in most of its range.
    let text = std::fs::read_to_string(workspace().join("models/joystick_1dof.yaml")).unwrap();
    let grams = text.replace("mass: 0.020358", "mass: 20.358").replace("mass: 0.05\n", "mass: 50\n");
    assert_ne!(grams, text);
    let dir = std::env::temp_dir().join(format!("hapticgen-check-simulate-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("heavy.yaml");
    std::fs::write(&file, grams).unwrap();
    let out = dir.join("out");
    let output = hapticgen(&[
        "simulate",
        file.to_str().unwrap(),
        "--controller",
        "natural-inertia",
        "--scenario",
        "step",
        "--duration",
        "0.2",
        "-o",
        out.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        stderr.contains("warning: `hapticgen check` refuses this model:")
            && stderr.contains("drive `re40_gp42` of joint `q` cannot hold the rig against gravity"),
        "{stderr}"
    );
    // The shipped model: no warning.
    let output = hapticgen(&[
        "simulate",
        "models/joystick_1dof.yaml",
        "--controller",
        "natural-inertia",
        "--scenario",
        "step",
        "--duration",
        "0.2",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(output.status.success());
    assert!(
        !String::from_utf8_lossy(&output.stderr).contains("warning"),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// `hapticgen new KIND ARGS… -o FILE` into a fresh directory: the output and the file's text.
fn new_rig(kind: &str, args: &[&str], name: &str) -> (std::process::Output, PathBuf) {
    let dir = std::env::temp_dir().join(format!("hapticgen-new-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join(format!("{name}.yaml"));
    std::fs::remove_file(&file).ok();
    let mut all = vec!["new", kind];
    all.extend_from_slice(args);
    let path = file.to_str().unwrap().to_string();
    all.extend_from_slice(&["-o", &path]);
    (hapticgen(&all), file)
}

/// `D`, `g` and the task point of two models at the same states, to `tolerance` relative to
/// each quantity's largest entry.
fn same_mechanics(a: &Path, b: &Path, variant: Option<&str>, states: &[Vec<f64>], tolerance: f64) {
    let load = |p: &Path| hapticgen_codegen::load_file(p, &p.display().to_string(), variant).unwrap();
    let (ma, mb) = (load(a), load(b));
    let (da, db) = (hapticgen_codegen::derive(&ma), hapticgen_codegen::derive(&mb));
    for q in states {
        let qd = vec![0.0; q.len()];
        let state = hapticgen_codegen::eval::State { q, qd: &qd, parameters: &[] };
        let (ea, eb) = (
            hapticgen_codegen::eval::evaluate(&da, &state, None),
            hapticgen_codegen::eval::evaluate(&db, &state, None),
        );
        let close = |x: &[f64], y: &[f64], what: &str| {
            let scale = x.iter().fold(1e-12f64, |m, v| m.max(v.abs()));
            for (u, v) in x.iter().zip(y) {
                assert!((u - v).abs() <= tolerance * scale, "{what} at {q:?}: {x:?} vs {y:?}");
            }
        };
        close(&ea.p, &eb.p, "p");
        close(&ea.g, &eb.g, "g");
        close(&ea.inertia_matrix.concat(), &eb.inertia_matrix.concat(), "D");
    }
}

#[test]
fn new_delta_with_the_falcons_dimensions_is_the_shipped_delta() {
    // The defaults are the Falcon-like Delta's: the generated file, written from named
    // dimensions with expressions, has the hand-written model's mechanics.
    let (output, file) = new_rig("delta", &[], "falcon_like");
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let text = std::fs::read_to_string(&file).unwrap();
    assert!(text.contains("base_radius * cos(120 deg)") && text.contains("value: 60 mm"), "{text}");
    let states: Vec<Vec<f64>> = [[0.35, 0.35, 0.35], [0.0, 0.6, 0.2], [0.8, -0.1, 0.45], [0.5, 0.5, -0.1]]
        .iter()
        .map(|q| q.to_vec())
        .collect();
    same_mechanics(&file, &workspace().join("models/falcon_delta.yaml"), None, &states, 1e-8);
    let check = hapticgen(&["check", file.to_str().unwrap()]);
    assert!(check.status.success() && check.stderr.is_empty(), "{}", String::from_utf8_lossy(&check.stderr));
    std::fs::remove_dir_all(file.parent().unwrap()).ok();
}

#[test]
fn new_five_bar_with_the_pantographs_dimensions_is_the_shipped_pantograph() {
    let (output, file) =
        new_rig("five-bar", &["--gear-ratio", "1", "--rotor-inertia", "3.3e-6"], "pantograph_like");
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    // States inside both files' joint ranges.
    let states: Vec<Vec<f64>> = [[2.2, 0.9], [2.0, 1.1], [2.4, 0.8]].iter().map(|q| q.to_vec()).collect();
    // The defaults are the shipped pantograph's links; its direct drives have their own rotor:
    // compare the vertical variants, which carry weight.
    same_mechanics(&file, &workspace().join("models/pantograph_5bar.yaml"), Some("vertical"), &states, 1e-8);
    std::fs::remove_dir_all(file.parent().unwrap()).ok();
}

#[test]
fn new_refuses_wrong_units_and_impossible_dimensions_and_writes_nothing() {
    let (output, file) = new_rig("delta", &["--thigh-mass", "20 mm"], "grams");
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(!output.status.success());
    assert!(stderr.contains("--thigh-mass \"20 mm\": expects a quantity in kg, got one in m"), "{stderr}");
    assert!(!file.exists());
    // Shins too short to reach the platform.
    let (output, file) = new_rig("delta", &["--shin-length", "10 mm"], "short");
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(!output.status.success() && stderr.contains("cannot reach the platform"), "{stderr}");
    assert!(!file.exists());
    // A drive too weak for the arm: `check` refuses the file, so `new` writes nothing.
    let (output, file) = new_rig("serial", &["--masses", "8 kg,5 kg", "--current-limit", "0.1 A"], "heavy");
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(!output.status.success() && stderr.contains("cannot hold the rig against gravity"), "{stderr}");
    assert!(!file.exists());
    std::fs::remove_dir_all(file.parent().unwrap()).ok();
}
