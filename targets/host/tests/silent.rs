//! No silent successes: `eval` refuses a state outside the joints' limits, where a
//! closed chain's loops cannot close on the file's branch, or where a value is not finite; a
//! scene nothing touched fails its check; every trace column is documented next to the trace;
//! `scripts/firmware.sh --plan` says what `--only` runs.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn hapticgen(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_hapticgen")).args(args).current_dir(workspace()).output().expect("runs")
}

fn scratch(name: &str) -> PathBuf {
    std::env::temp_dir().join(format!("hapticgen-silent-{name}-{}", std::process::id()))
}

/// The exit code, standard output and standard error of a run.
fn outcome(output: &Output) -> (Option<i32>, String, String) {
    (
        output.status.code(),
        String::from_utf8_lossy(&output.stdout).into_owned(),
        String::from_utf8_lossy(&output.stderr).into_owned(),
    )
}

/// Degrees typed as radians: refused at the limits, naming the joint and the likely mistake;
/// with `--beyond-limits`, refused because the Delta's loops cannot close there — never a line
/// of nulls with exit code 0.
#[test]
fn eval_refuses_degrees_and_loops_that_cannot_close() {
    let model = "models/falcon_delta.yaml";
    let (code, stdout, stderr) = outcome(&hapticgen(&["eval", model, "--q", "20,20,20"]));
    assert_eq!(code, Some(1), "{stdout}{stderr}");
    assert!(stdout.is_empty(), "{stdout}");
    assert!(
        stderr.contains(
            "joint `theta1` = 20 rad is outside its limits [-0.15, 0.85] rad (degrees? --q takes radians)"
        ) && stderr.contains("--beyond-limits"),
        "{stderr}"
    );
    let (code, stdout, stderr) = outcome(&hapticgen(&["eval", model, "--q", "20,20,20", "--beyond-limits"]));
    assert_eq!(code, Some(1), "{stdout}{stderr}");
    assert!(stdout.is_empty(), "{stdout}");
    assert!(stderr.contains("loops"), "{stderr}");
    // Just beyond the limits, on the assembly's branch: evaluated when asked for.
    let (code, stdout, stderr) =
        outcome(&hapticgen(&["eval", model, "--q", "0.9,0.9,0.9", "--beyond-limits"]));
    assert_eq!(code, Some(0), "{stdout}{stderr}");
    assert!(!stdout.contains("null"), "{stdout}");
}

/// A measured joint's angle outside its limits is refused too, where it is used: in a frame.
#[test]
fn eval_checks_measured_joints_in_a_frame() {
    let model = "models/phantom_premium.yaml";
    let frame = |measured: &str| {
        outcome(&hapticgen(&["eval", model, "--q", "0,0.1,0.1", "--frame", "stylus", "--measured", measured]))
    };
    let (code, stdout, stderr) = frame("0,0,0");
    assert_eq!(code, Some(0), "{stdout}{stderr}");
    let (code, _, stderr) = frame("0,1.5,0");
    assert_eq!(code, Some(1));
    assert!(
        stderr.contains("joint `gimbal_pitch` = 1.5 rad is outside its limits [-1.2, 1.2] rad"),
        "{stderr}"
    );
}

/// A planar closed chain whose two arms are spread too far apart: the loop named, exit code 1.
#[test]
fn eval_names_a_planar_loop_that_cannot_close() {
    let model = "codegen/tests/good-models/five_bar_2dof.yaml";
    let (code, stdout, stderr) = outcome(&hapticgen(&["eval", model, "--q", "0,3.1", "--beyond-limits"]));
    assert_eq!(code, Some(1), "{stdout}{stderr}");
    assert!(stdout.is_empty(), "{stdout}");
    assert!(stderr.contains("the loop `handle_loop` cannot close at this state"), "{stderr}");
}

/// Far from the assembly the Delta's loops are not solved on another branch: the continuation
/// from the assembly stops at the singular configuration between. All three thighs at one
/// angle put the platform on the axis, `p_x = p_y = 0`, on the assembly's branch; the
/// evaluator's former continuation (8 steps, no check of `det Φ_p`) printed a platform off the
/// axis (another branch) at these states, e.g. `p_x = 0.041` m at −2 rad.
#[test]
fn eval_does_not_land_on_another_assembly_branch() {
    for q in ["-2,-2,-2", "1.8,1.8,1.8"] {
        let (code, stdout, stderr) =
            outcome(&hapticgen(&["eval", "models/falcon_delta.yaml", "--q", q, "--beyond-limits"]));
        assert_eq!(code, Some(1), "{q}: {stdout}{stderr}");
        assert!(stderr.contains("determinant changes sign"), "{q}: {stderr}");
    }
    // Beyond the limits but before the singular configuration: on the axis.
    let (code, stdout, stderr) =
        outcome(&hapticgen(&["eval", "models/falcon_delta.yaml", "--q", "1.5,1.5,1.5", "--beyond-limits"]));
    assert_eq!(code, Some(0), "{stdout}{stderr}");
    let values: serde_json::Value = serde_json::from_str(&stdout).expect("JSON");
    let p: Vec<f64> =
        values["p"].as_array().expect("p").iter().filter_map(serde_json::Value::as_f64).collect();
    assert!(p[0].abs() < 1e-9 && p[1].abs() < 1e-9, "{p:?}");
}

/// `eval` prints no negative zero.
#[test]
fn eval_prints_no_negative_zero() {
    for (model, q) in [
        ("models/joystick_1dof.yaml", "0"),
        ("models/planar_arm_2dof.yaml", "0,1.5"),
        ("models/puma560.yaml", "0,0,0,0,0,0"),
        ("models/falcon_delta.yaml", "0.35,0.35,0.35"),
    ] {
        let (code, stdout, stderr) = outcome(&hapticgen(&["eval", model, "--q", q]));
        assert_eq!(code, Some(0), "{stdout}{stderr}");
        assert!(!stdout.contains("-0.0,") && !stdout.contains("-0.0]"), "{model}: {stdout}");
    }
}

/// A scene written in millimetres is metres away from the device: nothing is touched, and the
/// run fails "no sample in contact" instead of passing every check.
#[test]
fn a_scene_nothing_touched_fails() {
    let dir = scratch("millimetres");
    std::fs::create_dir_all(&dir).expect("a scratch directory");
    let scene = dir.join("desk-mm.yaml");
    std::fs::write(
        &scene,
        "objects:\n  - half_space: {point: [0, 0, -118.8], normal: [0, 0, 1], stiffness: 1500, damping: 5}\n",
    )
    .expect("written");
    let out = dir.join("run");
    let (code, stdout, stderr) = outcome(&hapticgen(&[
        "simulate",
        "models/falcon_delta.yaml",
        "--controller",
        "3",
        "--scenario",
        "wall",
        "--duration",
        "0.5",
        "--scene",
        &scene.to_string_lossy(),
        "-o",
        &out.to_string_lossy(),
    ]));
    assert_eq!(code, Some(1), "{stdout}{stderr}");
    let row =
        stdout.lines().find(|l| l.contains("some sample in contact")).unwrap_or_else(|| panic!("{stdout}"));
    assert!(row.contains("no sample in contact") && row.contains("**FAIL**"), "{row}");
    // Every column of the trace is documented, with a unit, next to it.
    let trace = std::fs::read_to_string(out.join("trace.csv")).expect("a trace");
    let columns = std::fs::read_to_string(out.join("trace.columns.md")).expect("the columns' sidecar");
    let header = trace.lines().next().expect("a header");
    for name in header.split(',') {
        let line = columns
            .lines()
            .find(|l| l.starts_with(&format!("| `{name}` |")))
            .unwrap_or_else(|| panic!("`{name}` is not documented:\n{columns}"));
        assert!(!line.contains("not documented"), "{line}");
    }
    let _ = std::fs::remove_dir_all(dir);
}

/// `scripts/firmware.sh --plan --only NAME` lists that image's steps only: no host-side lint or
/// unit tests, no other image; the full plan has them; an unknown name is refused.
#[test]
fn firmware_plan_for_one_image() {
    let plan = |args: &[&str]| {
        let output = Command::new("bash")
            .arg("scripts/firmware.sh")
            .args(args)
            .current_dir(workspace())
            .output()
            .expect("bash runs");
        outcome(&output)
    };
    let (code, stdout, stderr) = plan(&["--plan", "--only", "joystick"]);
    assert_eq!(code, Some(0), "{stdout}{stderr}");
    let images: Vec<&str> = stdout.lines().filter(|l| l.starts_with("plan: image ")).collect();
    assert_eq!(images.len(), 1, "{stdout}");
    assert!(images[0].starts_with("plan: image joystick: lint, build"), "{stdout}");
    assert!(!stdout.contains("lint: host-side") && !stdout.contains("unit tests"), "{stdout}");
    assert!(stdout.ends_with("plan: summary: 1 image(s): joystick\n"), "{stdout}");
    let (code, stdout, _) = plan(&["--plan"]);
    assert_eq!(code, Some(0));
    assert!(stdout.contains("lint: host-side") && stdout.contains("plan: image premium:"), "{stdout}");
    let (code, _, stderr) = plan(&["--plan", "--only", "no_such_image"]);
    assert_eq!(code, Some(1));
    assert!(stderr.contains("--only no_such_image: no such image"), "{stderr}");
}
