//! The `simulate` command end to end: CSV with the documented header that a standard CSV
//! reader parses, valid PNG figures, and the exit codes of bad input.

use std::path::{Path, PathBuf};
use std::process::Command;

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// Runs `hapticgen ARGS` from the workspace's root (the replay tests use it too).
pub(crate) fn hapticgen(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_hapticgen")).args(args).current_dir(workspace()).output().expect("runs")
}

/// A scratch path of this test process under the system's temporary directory.
pub(crate) fn scratch(name: &str) -> PathBuf {
    std::env::temp_dir().join(format!("hapticgen-cli-{name}-{}", std::process::id()))
}

/// Width and height from a PNG's signature and IHDR chunk.
fn png_size(path: &Path) -> (u32, u32) {
    let bytes = std::fs::read(path).expect("the PNG exists");
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "{} is not a PNG", path.display());
    assert_eq!(&bytes[12..16], b"IHDR");
    let word = |at: usize| u32::from_be_bytes([bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]]);
    (word(16), word(20))
}

fn check_csv(path: &Path, joints: usize, task: usize) -> Vec<csv::StringRecord> {
    let mut reader = csv::Reader::from_path(path).expect("trace.csv opens");
    let header: Vec<String> = reader.headers().expect("a header").iter().map(str::to_string).collect();
    let mut expected = vec!["t".to_string()];
    for (prefix, count) in
        [("q", joints), ("qd", joints), ("x", task), ("u", joints), ("f", task), ("xp", task), ("xh", task)]
    {
        expected.extend((0..count).map(|k| format!("{prefix}{k}")));
    }
    expected.push("tr".to_string());
    assert_eq!(header, expected);
    let rows: Vec<csv::StringRecord> = reader.records().map(|r| r.expect("a well-formed row")).collect();
    for row in &rows {
        assert_eq!(row.len(), expected.len());
        for value in row.iter() {
            assert!(value.parse::<f64>().expect("a number").is_finite());
        }
    }
    rows
}

#[test]
fn joystick_step_writes_a_trace_and_figures() {
    let out = scratch("step");
    let output = hapticgen(&[
        "simulate",
        "models/joystick_1dof.yaml",
        "--controller",
        "natural-inertia",
        "--scenario",
        "step",
        "--duration",
        "2",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    assert!(String::from_utf8_lossy(&output.stdout).contains("generated code"));
    let rows = check_csv(&out.join("trace.csv"), 1, 1);
    assert!(rows.len() > 1500, "{} rows for 2 s", rows.len());
    // The 1 N·m step moves the stick towards +1 rad.
    let last: f64 = rows.last().unwrap()[1].parse().unwrap();
    assert!(last > 0.5 && last < 1.5, "q at the end: {last}");
    for figure in ["joints", "task", "torque", "force"] {
        assert_eq!(png_size(&out.join(format!("{figure}.png"))), (900, 600));
        assert!(out.join(format!("{figure}.svg")).exists());
    }
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn parallel_link_traces_a_circle_on_a_tape_model_too() {
    // The shipped model runs on its generated code; a copy with a changed mass runs on tapes.
    let dir = scratch("circle");
    std::fs::create_dir_all(&dir).unwrap();
    let text = std::fs::read_to_string(workspace().join("models/parallel_link_2dof.yaml")).unwrap();
    let edited = text.replacen("mass: 0.06075", "mass: 0.07", 1);
    assert_ne!(text, edited);
    let copy = dir.join("edited.yaml");
    std::fs::write(&copy, edited).unwrap();
    for (model, marker) in
        [("models/parallel_link_2dof.yaml", "generated code"), (copy.to_str().unwrap(), "tapes")]
    {
        let out = dir.join(marker.replace(' ', "-"));
        let output = hapticgen(&[
            "simulate",
            model,
            "--controller",
            "3",
            "--scenario",
            "trace-circle",
            "--duration",
            "2",
            "-o",
            out.to_str().unwrap(),
        ]);
        assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
        assert!(String::from_utf8_lossy(&output.stdout).contains(marker));
        let rows = check_csv(&out.join("trace.csv"), 2, 2);
        assert!(!rows.is_empty());
        assert_eq!(png_size(&out.join("path.png")), (900, 600));
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_input_gives_the_right_exit_codes() {
    let out = scratch("bad");
    let out = out.to_str().unwrap();
    let usage = hapticgen(&[
        "simulate",
        "models/joystick_1dof.yaml",
        "--controller",
        "4",
        "--scenario",
        "step",
        "-o",
        out,
    ]);
    assert_eq!(usage.status.code(), Some(2));
    let missing =
        hapticgen(&["simulate", "models/nope.yaml", "--controller", "3", "--scenario", "step", "-o", out]);
    assert_eq!(missing.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&missing.stderr).contains("models/nope.yaml:1:1"));
    // The paper's numbering names the laws too, and the help says which is which.
    let help = hapticgen(&["simulate", "--help"]);
    let help = String::from_utf8_lossy(&help.stdout);
    for (name, paper) in [
        ("force-feedback", "Controller 1"),
        ("acceleration-feedback", "Controller 2, first variant"),
        ("natural-inertia", "Controller 2, second variant"),
        ("jacobian-transpose", "Controller 3"),
    ] {
        assert!(help.contains(name) && help.contains(paper), "{name} / {paper} in\n{help}");
    }
    let no_2d = hapticgen(&[
        "simulate",
        "models/joystick_1dof.yaml",
        "--controller",
        "3",
        "--scenario",
        "trace-circle",
        "-o",
        out,
    ]);
    assert_eq!(no_2d.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&no_2d.stderr).contains("2-D task"));
    let bad_effect = hapticgen(&[
        "simulate",
        "models/joystick_1dof.yaml",
        "--controller",
        "3",
        "--scenario",
        "step",
        "--without",
        "gravity",
        "-o",
        out,
    ]);
    assert_eq!(bad_effect.status.code(), Some(1));
    let _ = std::fs::remove_dir_all(out);
}

/// The tutorial's arm (`docs/tutorial.md`) runs `trace-circle` from its default start, the
/// middle of the joint limits, without a warning; `--start` at a singular pose of the parallel
/// link (q1 = q2: the links folded onto each other) is warned about, and a start outside the
/// limits or of the wrong length is refused.
#[test]
fn start_pose_and_singular_warnings() {
    let out = scratch("start");
    let out = out.to_str().unwrap();
    // `hapticgen simulate ARGS -o OUT`, the arguments written as on a command line.
    let simulate = |args: &str| {
        let mut words: Vec<&str> = args.split_whitespace().collect();
        words.extend(["-o", out]);
        hapticgen(&words)
    };
    let tutorial =
        simulate("simulate docs/tutorial/desk_arm_2dof.yaml --controller 3 --scenario trace-circle");
    let stderr = String::from_utf8_lossy(&tutorial.stderr);
    assert!(tutorial.status.success(), "{stderr}");
    assert!(!stderr.contains("warning"), "{stderr}");
    let from = |start: &str| {
        simulate(&format!(
            "simulate models/parallel_link_2dof.yaml --controller 3 --scenario step --duration 0.05 --start {start}"
        ))
    };
    let singular = from("0.775,0.775");
    let stderr = String::from_utf8_lossy(&singular.stderr);
    assert!(singular.status.success(), "{stderr}");
    assert!(stderr.contains("warning: the start pose q = (0.775, 0.775) rad is singular"), "{stderr}");
    let regular = from("1.55,0.0");
    assert!(!String::from_utf8_lossy(&regular.stderr).contains("warning"));
    for bad in ["3.5,0.0", "1.0"] {
        let refused = from(bad);
        assert_eq!(refused.status.code(), Some(1), "--start {bad}");
        assert!(String::from_utf8_lossy(&refused.stderr).contains("--start"), "--start {bad}");
    }
    let _ = std::fs::remove_dir_all(out);
}

/// `hapticgen pil` says what is missing and how to get it, before starting anything: an image
/// that is not built, a model variant without an image, a QEMU that is not there. (The PIL
/// runs themselves need QEMU and the image: `scripts/firmware.sh --only pil`.)
#[test]
fn pil_names_what_is_missing() {
    let out = scratch("pil-missing");
    let out = out.to_str().expect("a UTF-8 temporary directory");
    let joystick =
        ["pil", "models/joystick_1dof.yaml", "--controller", "natural-inertia", "--scenario", "step"];
    let run = |extra: &[&str]| {
        let mut args: Vec<&str> = joystick.to_vec();
        args.extend_from_slice(extra);
        args.extend_from_slice(&["-o", out]);
        let output = hapticgen(&args);
        (output.status.code(), String::from_utf8_lossy(&output.stderr).into_owned())
    };
    let (code, stderr) = run(&["--image", "/nonexistent/joystick.pil.elf"]);
    assert_eq!(code, Some(1), "{stderr}");
    assert!(stderr.contains("no PIL firmware image for `joystick`"), "{stderr}");
    assert!(stderr.contains("/nonexistent/joystick.pil.elf"), "{stderr}");
    assert!(stderr.contains("scripts/firmware.sh --only pil"), "{stderr}");

    // Any existing file passes the image lookup; then QEMU is looked for.
    let (code, stderr) =
        run(&["--image", "models/joystick_1dof.yaml", "--qemu", "/nonexistent/qemu-system-arm"]);
    assert_eq!(code, Some(1), "{stderr}");
    assert!(stderr.contains("--qemu /nonexistent/qemu-system-arm: no such file"), "{stderr}");

    // The parallel link has images of its two variants only.
    let output = hapticgen(&[
        "pil",
        "models/parallel_link_2dof.yaml",
        "--controller",
        "jacobian-transpose",
        "--scenario",
        "step",
        "--variant",
        "vertical",
        "--image",
        "/nonexistent/vertical.pil.elf",
        "-o",
        out,
    ]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(stderr.contains("no PIL firmware image for `vertical`"), "{stderr}");
    let _ = std::fs::remove_dir_all(out);
}

/// A spatial closed chain (the Falcon-like Delta): `check` and `eval` work, with the platform
/// where the legs' geometry puts it; `generate` solves its loops in closed form, `stats` says
/// so, and `simulate` runs a step. A spatial chain of another shape is solved by Newton's
/// method, and `check` says why.
#[test]
fn a_spatial_closed_chain_checks_evaluates_generates_and_simulates() {
    let model = "models/falcon_delta.yaml";
    let check = hapticgen(&["check", model]);
    assert!(check.status.success(), "{}", String::from_utf8_lossy(&check.stderr));
    assert!(String::from_utf8_lossy(&check.stdout).contains(
        "3 joints (+8 passive, eliminated by 2 closures, in closed form), 11 bodies (4 of them massless)"
    ));
    // All thighs at θ = 0.35 rad: the platform straight below the centre, at the knee's height
    // less the shin's vertical reach, z = −a sin θ − √(b² − (r + a cos θ − s)²).
    let eval = hapticgen(&["eval", model, "--q", "0.35,0.35,0.35", "--qd", "0,0,0"]);
    assert!(eval.status.success(), "{}", String::from_utf8_lossy(&eval.stderr));
    let values: serde_json::Value = serde_json::from_slice(&eval.stdout).expect("JSON");
    let p: Vec<f64> =
        values["p"].as_array().expect("p").iter().map(|x| x.as_f64().expect("a number")).collect();
    let (r, a, b, s, theta) = (0.037233758_f64, 0.060_f64, 0.1025_f64, 0.027330909_f64, 0.35_f64);
    let z = -a * theta.sin() - (b * b - (r + a * theta.cos() - s).powi(2)).sqrt();
    assert!(p[0].abs() < 1e-12 && p[1].abs() < 1e-12 && (p[2] - z).abs() < 1e-12, "{p:?} vs z = {z}");
    let slider = hapticgen(&["check", "codegen/tests/closed-chains/slider_crank_spatial.yaml"]);
    assert!(
        String::from_utf8_lossy(&slider.stdout).contains(
            "by Newton's method at run time; no closed form: not a Delta: 1 closure and 3 passive joints"
        ),
        "{}",
        String::from_utf8_lossy(&slider.stdout)
    );
    // The generated code solves the loops in closed form, no Newton solver.
    let generated = hapticgen(&["generate", model]);
    assert!(generated.status.success(), "{}", String::from_utf8_lossy(&generated.stderr));
    let text = String::from_utf8_lossy(&generated.stdout);
    assert!(!text.contains("LoopConstraints") && text.contains("let cos_knee1_twist ="));
    // `stats` says that its counts include the closed form.
    let stats = hapticgen(&["stats", model]);
    assert!(stats.status.success(), "{}", String::from_utf8_lossy(&stats.stderr));
    let stats = String::from_utf8_lossy(&stats.stdout);
    assert!(!stats.contains("loop_constraints") && stats.contains("in closed form first"), "{stats}");
    // A 1 N step on x against a 200 N/m task-space spring: the grip settles 5 mm along x.
    let output = scratch("delta");
    let output_text = output.to_string_lossy().into_owned();
    let run = hapticgen(&[
        "simulate",
        model,
        "--controller",
        "3",
        "--scenario",
        "step",
        "--kd",
        "200",
        "--bd",
        "2",
        "--duration",
        "1",
        "--output",
        &output_text,
    ]);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{stderr}");
    assert!(!stderr.contains("latched"), "{stderr}");
    let trace = std::fs::read_to_string(output.join("trace.csv")).expect("a trace");
    let last: Vec<f64> =
        trace.lines().last().expect("rows").split(',').map(|x| x.parse().expect("a number")).collect();
    let header: Vec<&str> = trace.lines().next().expect("a header").split(',').collect();
    let x = last[header.iter().position(|&h| h == "x0").expect("x0")];
    assert!((x - 1.0 / 200.0).abs() < 1e-4, "x = {x}");
}

/// The Delta in contact (`hapticgen contact`, three of its runs): its report passes, and the
/// wall run's trace, read here, shows a floor 2 cm below the grip, rendered by the runtime's god
/// object, that a hand (200 N/m) presses 1 cm into: the proxy never enters the floor, and while
/// the hand holds still the grip sinks until the wall's spring balances the hand's,
/// `K_w d = k_h (1 cm − d)`. The box's edge and corner (a frictionless slide along a box's top)
/// and a non-convex mesh shipped as an OBJ file pass their checks.
#[test]
fn a_spatial_device_presses_into_god_object_solids() {
    let output = scratch("delta-contact");
    let output_text = output.to_string_lossy().into_owned();
    let run = hapticgen(&[
        "contact",
        "models/falcon_delta.yaml",
        "--mesh",
        "scenes/meshes/knob.obj",
        "--only",
        "wall,box-edges,mesh-knob",
        "--output",
        &output_text,
    ]);
    let stderr = String::from_utf8_lossy(&run.stderr);
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(run.status.success(), "{stdout}{stderr}");
    assert!(stdout.contains("10 of 10 checks pass"), "{stdout}");
    let report = std::fs::read_to_string(output.join("report.md")).expect("a report");
    assert!(
        !report.contains("FAIL") && report.contains("| mesh-knob | the proxy never inside a solid |"),
        "{report}"
    );
    let output = output.join("wall");
    assert!(!stderr.contains("latched"), "{stderr}");
    let trace = std::fs::read_to_string(output.join("trace.csv")).expect("a trace");
    let header: Vec<&str> = trace.lines().next().expect("a header").split(',').collect();
    let column = |name: &str| header.iter().position(|&h| h == name).unwrap_or_else(|| panic!("{name}"));
    let (t, x, y, z, proxy_z) = (column("t"), column("x0"), column("x1"), column("x2"), column("xp2"));
    let rows: Vec<Vec<f64>> = trace
        .lines()
        .skip(1)
        .map(|line| line.split(',').map(|v| v.parse().expect("a number")).collect())
        .collect();
    let wall = rows[0][z] - 0.02;
    let deepest_proxy = rows.iter().map(|r| r[proxy_z] - wall).fold(f64::INFINITY, f64::min);
    assert!(deepest_proxy >= 0.0, "the proxy entered the wall by {:e} m", -deepest_proxy);
    let held: Vec<&Vec<f64>> = rows.iter().filter(|r| (2.3..3.3).contains(&r[t])).collect();
    assert!(held.len() > 100, "{} rows while the hand holds", held.len());
    let expected_depth = 200.0 * 0.01 / (1500.0 + 200.0);
    for row in held {
        let depth = wall - row[z];
        assert!(
            (depth - expected_depth).abs() < 0.03 * expected_depth,
            "depth {depth:e} m at t = {}, expected {expected_depth:e} m",
            row[t]
        );
        assert!(row[x].abs() < 1e-6 && row[y].abs() < 1e-6, "sideways drift at t = {}: {row:?}", row[t]);
    }
}

/// `--scene FILE` renders the file's objects instead of the contact scenario's: a floor 12 mm
/// below the start instead of the `wall` scenario's 20 mm holds the proxy at its own height;
/// only the checks that hold for any scene are made; a bad file is refused at its line and
/// column, and a scene needs a contact scenario.
#[test]
fn a_scene_file_replaces_the_contact_scenarios_solids() {
    let model = "models/parallel_link_2dof.yaml";
    let first = scratch("scene-start");
    let run = |scenario: &str, extra: &[&str], out: &Path, duration: &str| {
        let out = out.to_str().expect("a UTF-8 path").to_string();
        let mut args =
            vec!["simulate", model, "--controller", "3", "--scenario", scenario, "--duration", duration];
        args.extend_from_slice(extra);
        args.extend_from_slice(&["-o", &out]);
        hapticgen(&args)
    };
    let output = run("step", &[], &first, "0.01");
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let start: Vec<f64> = check_csv(&first.join("trace.csv"), 2, 2)[0]
        .iter()
        .skip(1 + 2 + 2)
        .take(2)
        .map(|v| v.parse().expect("a number"))
        .collect();
    let floor = start[1] - 0.012;
    let dir = scratch("scene-files");
    std::fs::create_dir_all(&dir).expect("a scratch directory");
    let scene = dir.join("floor.yaml");
    std::fs::write(
        &scene,
        format!("objects:\n  - half_space: {{point: [0, {floor}], normal: [0, 1], stiffness: 1500, damping: 5}}\n"),
    )
    .expect("the scene is written");
    let out = scratch("scene-run");
    let output = run("wall", &["--scene", scene.to_str().expect("UTF-8")], &out, "2.5");
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(output.status.success(), "{stdout}{}", String::from_utf8_lossy(&output.stderr));
    assert!(stdout.contains("the proxy never inside a solid") && !stdout.contains("held depth"), "{stdout}");
    let rows = check_csv(&out.join("trace.csv"), 2, 2);
    // Columns: t, q (2), qd (2), x (2), u (2), f (2), xp (2), xh (2).
    let proxy_y = |row: &csv::StringRecord| row[12].parse::<f64>().expect("a number");
    let lowest = rows.iter().map(proxy_y).fold(f64::INFINITY, f64::min);
    assert!((lowest - floor).abs() < 1e-5, "the proxy rests at {lowest}, the scene's floor is at {floor}");

    let bad = dir.join("bad.yaml");
    std::fs::write(
        &bad,
        "objects:\n  - half_space: {point: [0, 0], normal: [0, 0], stiffness: 1, damping: 0}\n",
    )
    .expect("written");
    let output = run("wall", &["--scene", bad.to_str().expect("UTF-8")], &out, "0.01");
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(!output.status.success());
    assert!(
        stderr.contains("bad.yaml:2:") && stderr.contains("objects[0].half_space.normal: must not be zero"),
        "{stderr}"
    );
    let output = run("step", &["--scene", scene.to_str().expect("UTF-8")], &out, "0.01");
    assert!(!output.status.success());
    assert!(String::from_utf8_lossy(&output.stderr).contains("--scene needs a contact scenario"));
    for path in [first, dir, out] {
        let _ = std::fs::remove_dir_all(path);
    }
}

/// The differential wrist's roll (1.05e-5 kg·m²) under the operator's hand (200 N·m/rad,
/// 1 N·m·s/rad in its joint-space task): held over a whole 133 µs period the hand's damping
/// alone is 13 times faster than the step, and the run diverged; with the hand following the
/// device over substeps the wall scenario holds the wrist where the wall's spring balances the
/// hand's, `K_w d = k_h (push − d)`, which the run's own check reports.
#[test]
fn a_light_axis_under_the_hand_is_integrated_in_substeps() {
    let out = scratch("wrist-wall");
    let output = hapticgen(&[
        "simulate",
        "models/differential_wrist.yaml",
        "--controller",
        "3",
        "--scenario",
        "wall",
        "-o",
        out.to_str().expect("a UTF-8 path"),
    ]);
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(output.status.success(), "{}\n{stdout}", String::from_utf8_lossy(&output.stderr));
    let held = stdout.lines().find(|l| l.contains("held depth")).unwrap_or_else(|| panic!("{stdout}"));
    assert!(held.ends_with("| pass |"), "{held}");
}

/// The Delta under the `wall` scenario's hand (Controller 3) on a scene file written from
/// `scene_text` for `duration` seconds: the report's text and the trace, as its header and rows.
fn delta_wall_on_scene(name: &str, scene_text: &str, duration: &str) -> (String, Vec<String>, Vec<Vec<f64>>) {
    let output = scratch(name);
    std::fs::create_dir_all(&output).expect("a scratch directory");
    let scene = output.join("scene.yaml");
    std::fs::write(&scene, scene_text).expect("writable");
    let run = hapticgen(&[
        "simulate",
        "models/falcon_delta.yaml",
        "--controller",
        "3",
        "--scenario",
        "wall",
        "--duration",
        duration,
        "--scene",
        &scene.to_string_lossy(),
        "--output",
        &output.to_string_lossy(),
    ]);
    let stdout = String::from_utf8_lossy(&run.stdout).into_owned();
    assert!(run.status.success(), "{name}: {stdout}{}\n{scene_text}", String::from_utf8_lossy(&run.stderr));
    let trace = std::fs::read_to_string(output.join("trace.csv")).expect("a trace");
    let header: Vec<String> = trace.lines().next().expect("a header").split(',').map(String::from).collect();
    let rows = trace
        .lines()
        .skip(1)
        .map(|line| line.split(',').map(|v| v.parse().expect("a number")).collect())
        .collect();
    (stdout, header, rows)
}

/// A scene's box turned by `rotation` (pitch 0.35 rad), and the same slab written as a
/// polytope of its six planes: the Delta's hand presses straight down on the tilted top face,
/// and the rendered force (the proxy's offset from the HIP) points along that face's normal
/// `Ry(0.35) e_z = (sin 0.35, 0, cos 0.35)`, never inside the solid.
#[test]
fn a_turned_box_and_a_polytope_push_along_their_tilted_face() {
    let (centre, half, pitch) = ([0.0, 0.0, -0.1288], [0.03, 0.03, 0.01], 0.35f64);
    let turned_box = format!(
        "objects:\n  - box: {{centre: {centre:?}, half_extents: {half:?}, rotation: [0.0, {pitch}, 0.0], stiffness: 1500, damping: 5}}\n"
    );
    // The slab's axes: Ry(pitch) e_x, e_y, Ry(pitch) e_z; a plane on each side of each.
    let axes = [[pitch.cos(), 0.0, -pitch.sin()], [0.0, 1.0, 0.0], [pitch.sin(), 0.0, pitch.cos()]];
    let mut planes = String::new();
    for (axis, h) in axes.iter().zip(half) {
        for side in [1.0, -1.0] {
            let normal: Vec<f64> = axis.iter().map(|a| side * a).collect();
            let point: Vec<f64> = centre.iter().zip(axis).map(|(c, a)| c + side * h * a).collect();
            planes.push_str(&format!("      - {{point: {point:?}, normal: {normal:?}}}\n"));
        }
    }
    let polytope =
        format!("objects:\n  - polytope:\n      stiffness: 1500\n      damping: 5\n      planes:\n{planes}");
    for (name, scene_text) in [("turned-box", turned_box), ("polytope", polytope)] {
        let (stdout, header, rows) = delta_wall_on_scene(name, &scene_text, "2.5");
        assert!(
            stdout.contains("| wall | the proxy never inside a solid |") && !stdout.contains("FAIL"),
            "{stdout}"
        );
        let column = |name: &str| header.iter().position(|h| h == name).unwrap_or_else(|| panic!("{name}"));
        let (t, proxy, hip) = (column("t"), column("xp0"), column("xh0"));
        let pressed: Vec<[f64; 3]> = rows
            .iter()
            .filter(|row| (2.0..2.5).contains(&row[t]))
            .map(|row| std::array::from_fn(|k| row[proxy + k] - row[hip + k]))
            .collect();
        assert!(pressed.len() > 100, "{name}: {} rows pressed", pressed.len());
        let normal = axes[2];
        for offset in pressed {
            let length = offset.iter().map(|v| v * v).sum::<f64>().sqrt();
            assert!(length > 1e-4, "{name}: not pressed in: {offset:?}");
            for k in 0..3 {
                assert!(
                    (offset[k] / length - normal[k]).abs() < 1e-6,
                    "{name}: force {offset:?} off the face's normal {normal:?}"
                );
            }
        }
    }
}

/// A moving object: a slab under the Delta's hand tilts about the y axis through its centre at
/// 0.1 rad/s (`motion: {angular_velocity, pivot}`). Pressed on its top, the rendered force (the
/// proxy's offset from the HIP) follows the slab's turning normal `Ry(ω t_r) e_z`, `t_r` the
/// time the proxy was rendered (the trace's `tr`), up to the proxy's 1 µm skin sideways, and
/// the proxy is never inside the slab where it was then.
#[test]
fn a_tilting_slab_turns_the_force_with_its_face() {
    let (centre, rate) = ([0.0, 0.0, -0.1288], 0.1f64);
    let scene_text = format!(
        "objects:\n  - box:\n      centre: {centre:?}\n      half_extents: [0.03, 0.03, 0.01]\n      stiffness: 1500\n      damping: 5\n      motion: {{angular_velocity: [0, {rate}, 0], pivot: {centre:?}}}\n"
    );
    let (stdout, header, rows) = delta_wall_on_scene("tilting-slab", &scene_text, "2.5");
    assert!(
        stdout.contains("| wall | the proxy never inside a solid |") && !stdout.contains("FAIL"),
        "{stdout}"
    );
    let column = |name: &str| header.iter().position(|h| h == name).unwrap_or_else(|| panic!("{name}"));
    let (t, proxy, hip, rendered_at) = (column("t"), column("xp0"), column("xh0"), column("tr"));
    let pressed: Vec<(f64, [f64; 3])> = rows
        .iter()
        .filter(|row| (1.0..2.5).contains(&row[t]))
        .map(|row| (row[rendered_at], std::array::from_fn(|k| row[proxy + k] - row[hip + k])))
        .collect();
    assert!(pressed.len() > 100, "{} rows pressed", pressed.len());
    let mut largest_sideways = 0.0f64;
    for (time, offset) in pressed {
        let length = offset.iter().map(|v| v * v).sum::<f64>().sqrt();
        assert!(length > 1e-4, "not pressed in at t = {time}: {offset:?}");
        let pitch = rate * time;
        let normal = [pitch.sin(), 0.0, pitch.cos()];
        let cosine = (0..3).map(|k| offset[k] * normal[k]).sum::<f64>() / length;
        let angle = cosine.clamp(-1.0, 1.0).acos();
        largest_sideways = largest_sideways.max(angle * length);
        // The proxy may end a move up to its skin (1 µm) short of its goal along the face.
        assert!(
            angle * length < 1.05e-6,
            "at t = {time}: force {offset:?} {angle} rad off the face's normal {normal:?}"
        );
    }
    println!("largest sideways offset of the proxy from the HIP's projection: {largest_sideways:.2e} m");
}

/// A scene file's free-space effect: a spring of 500 N/m anchored at the Delta's start, and no
/// object. The wall scenario's hand (200 N/m) pulls 3 cm down and holds: the grip settles
/// where the two springs balance, `k d = k_h (3 cm − d)`, d = 8.57 mm, and the reference (the
/// trace's proxy) is the anchor throughout.
#[test]
fn a_scene_s_spring_effect_holds_the_grip_against_the_hand() {
    let anchor = [0.0, 0.0, -0.0987734318];
    let scene_text = format!("objects: []\neffect: {{spring: {{anchor: {anchor:?}, stiffness: 500}}}}\n");
    let (_, header, rows) = delta_wall_on_scene("spring-effect", &scene_text, "3");
    let column = |name: &str| header.iter().position(|h| h == name).unwrap_or_else(|| panic!("{name}"));
    let (t, z, proxy_z) = (column("t"), column("x2"), column("xp2"));
    let expected = 200.0 * 0.03 / (500.0 + 200.0);
    let held: Vec<&Vec<f64>> = rows.iter().filter(|r| (2.0..3.0).contains(&r[t])).collect();
    assert!(held.len() > 100, "{} rows held", held.len());
    for row in held {
        let depth = anchor[2] - row[z];
        assert!(
            (depth - expected).abs() < 0.01 * expected,
            "{depth} m at t = {}, expected {expected}",
            row[t]
        );
        assert!((row[proxy_z] - anchor[2]).abs() < 1e-9, "the reference left the anchor: {row:?}");
    }
}

/// `generate --regressor` adds the identification regressor (and says so in the header);
/// `stats --regressor` counts it; without the flag neither changes.
#[test]
fn regressor_on_request_in_generate_and_stats() {
    let model = "models/planar_arm_2dof.yaml";
    let plain = hapticgen(&["generate", model, "--variant", "vertical"]);
    assert!(plain.status.success(), "{}", String::from_utf8_lossy(&plain.stderr));
    assert!(!String::from_utf8_lossy(&plain.stdout).contains("fn regressor("));
    let with = hapticgen(&["generate", model, "--variant", "vertical", "--regressor"]);
    assert!(with.status.success(), "{}", String::from_utf8_lossy(&with.stderr));
    let text = String::from_utf8_lossy(&with.stdout);
    assert!(text.contains("--scalar f64 --regressor -o <this file>"), "{}", &text[..400]);
    assert!(
        text.contains("pub fn regressor(") && text.contains("pub fn base_parameters(&self) -> [f64; 13]")
    );
    assert!(text.contains("\"zz_link1 + m_link2 + ia_shoulder\""));
    let stats = |extra: &[&str]| {
        let output = hapticgen(&[&["stats", model, "--variant", "vertical"], extra].concat());
        assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
        String::from_utf8_lossy(&output.stdout).into_owned()
    };
    assert!(!stats(&[]).lines().any(|l| l.starts_with("regressor ")));
    assert!(stats(&["--regressor"]).lines().any(|l| l.starts_with("regressor ")));
}

/// `hapticgen report` on the five-bar: the page, the figures a program reads, every map as SVG
/// and PNG and inlined in the page; a model whose loops cannot close is refused at its line,
/// nothing written.
#[test]
fn report_writes_the_page_figures_and_maps_and_refuses_a_model_that_cannot_close() {
    let out = scratch("report");
    let result =
        hapticgen(&["report", "models/pantograph_5bar.yaml", "--steps", "9", "-o", out.to_str().unwrap()]);
    assert!(result.status.success(), "{}", String::from_utf8_lossy(&result.stderr));
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    for key in [
        "/workspace/inscribed_square/edge",
        "/force/peak/min_over_cube",
        "/force/continuous/min_over_cube",
        "/inertia/max_over_cube",
        "/inertia/min_over_cube",
        "/resolution/max_over_cube",
        "/isotropy/global_conditioning_index",
        "/gravity/load_percent/max_over_cube",
        "/renderable_stiffness/centre",
        "/grid/steps_per_joint",
    ] {
        assert!(summary.pointer(key).is_some_and(|v| v.is_number()), "{key} in {summary}");
    }
    let page = std::fs::read_to_string(out.join("index.html")).unwrap();
    let maps = std::fs::read_dir(out.join("maps")).unwrap().count();
    // Seven quantities as SVG and PNG, and the slice's CSV.
    assert_eq!(maps, 7 * 2 + 1);
    assert_eq!(page.matches("<img alt=").count(), 7, "every map inlined in the page");
    let refused = scratch("report-refused");
    let result = hapticgen(&[
        "report",
        "codegen/tests/bad-models/spatial-closure-cannot-close.yaml",
        "-o",
        refused.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&result.stderr);
    assert!(!result.status.success(), "{stderr}");
    assert!(
        stderr.contains("spatial-closure-cannot-close.yaml:216:3:") && stderr.contains("do not close"),
        "{stderr}"
    );
    assert!(!refused.exists(), "nothing written for a refused model");
}

/// docs/design-your-device.md's walk-through, run as written (the stiffest-wall search left
/// out: the page quotes none of its figures): a five-bar from the template, its motor links
/// lengthened from 70 to 90 mm by one line, and the page's table of figures against the two
/// reports' summary.json.
#[test]
fn the_design_walkthrough_quotes_what_the_reports_compute() {
    let dir = scratch("walkthrough");
    std::fs::create_dir_all(&dir).unwrap();
    let short = dir.join("my_five_bar.yaml");
    let result = hapticgen(&["new", "five-bar", "-o", short.to_str().unwrap()]);
    assert!(result.status.success(), "{}", String::from_utf8_lossy(&result.stderr));
    let text = std::fs::read_to_string(&short).unwrap();
    let edited = text.replacen("    value: 70 mm", "    value: 90 mm", 1);
    assert_ne!(edited, text, "the template's proximal length line");
    let long = dir.join("my_five_bar_long.yaml");
    std::fs::write(&long, edited).unwrap();
    let summary = |model: &Path, name: &str| -> serde_json::Value {
        let out = dir.join(name);
        let result =
            hapticgen(&["report", model.to_str().unwrap(), "--no-zwidth", "-o", out.to_str().unwrap()]);
        assert!(result.status.success(), "{}", String::from_utf8_lossy(&result.stderr));
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap()
    };
    let (a, b) = (summary(&short, "short"), summary(&long, "long"));
    let at = |s: &serde_json::Value, key: &str| s.pointer(key).and_then(|v| v.as_f64()).expect(key);
    let rows: [(&str, &str, f64, usize, &str); 5] = [
        ("| inscribed square, edge |", "/workspace/inscribed_square/edge", 1e3, 1, " mm"),
        (
            "| peak force in every direction, least over the square |",
            "/force/peak/min_over_cube",
            1.0,
            2,
            " N",
        ),
        ("| one encoder count, largest step over the square |", "/resolution/max_over_cube", 1e6, 1, " µm"),
        (
            "| condition number of J, largest over the square |",
            "/isotropy/condition/max_over_cube",
            1.0,
            2,
            "",
        ),
        ("| apparent inertia, heaviest direction over the square |", "/inertia/max_over_cube", 1e3, 1, " g"),
    ];
    let page = std::fs::read_to_string(workspace().join("docs/design-your-device.md")).unwrap();
    for (row, key, scale, digits, unit) in rows {
        let expected = format!(
            "{row} {:.digits$}{unit} | {:.digits$}{unit} |",
            at(&a, key) * scale,
            at(&b, key) * scale
        );
        assert!(page.contains(&expected), "docs/design-your-device.md should read\n{expected}");
    }
    let _ = std::fs::remove_dir_all(dir);
}

/// `connect --excite` refuses at parse time what it cannot honour beside an excitation run
/// (a scene, the safety checks, impedance settings: each would replace the excitation's law)
/// and runs without the model or the log, naming the flag; before any link is opened.
#[test]
fn connect_excite_refuses_flags_that_conflict_and_needs_a_model_and_a_log() {
    let base = ["connect", "--port", "unix:/nonexistent/hapticgen.sock", "--excite", "traj.yaml"];
    let full = [&base[..], &["--model", "models/parallel_link_2dof.yaml", "--log", "run.csv"]].concat();
    for (extra, flag) in [
        (&["--scene", "scenes/device-wall.yaml"][..], "--scene"),
        (&["--check-safety"][..], "--check-safety"),
        (&["--impedance", "1500,5"][..], "--impedance"),
    ] {
        let output = hapticgen(&[&full[..], extra].concat());
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(2), "{stderr}");
        assert!(stderr.contains("cannot be used with") && stderr.contains(flag), "{stderr}");
    }
    for (args, missing) in [
        ([&base[..], &["--log", "run.csv"]].concat(), "--model"),
        ([&base[..], &["--model", "models/parallel_link_2dof.yaml"]].concat(), "--log"),
    ] {
        let output = hapticgen(&args);
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(2), "{stderr}");
        assert!(stderr.contains("required") && stderr.contains(missing), "{stderr}");
    }
    // `--model` belongs to `--excite`.
    let output = hapticgen(&["connect", "--port", "unix:/x", "--model", "models/parallel_link_2dof.yaml"]);
    assert_eq!(output.status.code(), Some(2));
}
