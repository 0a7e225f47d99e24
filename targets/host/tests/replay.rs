//! `hapticgen report --replay RUN`: a `simulate` run (the five-bar tracing a circle) and a
//! `contact` run (the five-bar pressing a floor) replayed in the design page, whose replay data
//! is read back here: each frame's task point, drawn from the model's kinematics, is where the
//! simulator recorded it in the trace (`x*`), the proxy is the trace's `xp*`, and the scene's
//! objects are where the scenario placed them from the start; long traces are subsampled to
//! 2,000 frames with their first and last rows. Bad runs are refused with the file (line,
//! column) named and nothing written.

use std::path::Path;

use crate::cli::{hapticgen, scratch};

/// The trace's header and rows.
fn trace(path: &Path) -> (Vec<String>, Vec<Vec<f64>>) {
    let mut reader = csv::Reader::from_path(path).expect("the trace opens");
    let header = reader.headers().expect("a header").iter().map(str::to_string).collect();
    let rows = reader
        .records()
        .map(|r| r.expect("a row").iter().map(|v| v.parse().expect("a number")).collect())
        .collect();
    (header, rows)
}

/// The JSON of the page's `<script id="ID" type="application/json">` block.
fn page_json(page: &str, id: &str) -> serde_json::Value {
    let open = format!("<script id=\"{id}\" type=\"application/json\">");
    let start = page.find(&open).unwrap_or_else(|| panic!("no {id} block")) + open.len();
    let end = start + page[start..].find("</script>").expect("the block ends");
    serde_json::from_str(&page[start..end].replace("<\\/", "</")).expect("valid JSON")
}

fn numbers(value: &serde_json::Value) -> Vec<f64> {
    value.as_array().expect("an array").iter().map(|v| v.as_f64().expect("a number")).collect()
}

/// Runs `report MODEL --replay RUN`, checks every frame against the trace, and returns the
/// replay's data and the trace.
fn replayed(model: &str, run: &Path, name: &str) -> (serde_json::Value, Vec<String>, Vec<Vec<f64>>) {
    let out = scratch(name);
    let output = hapticgen(&[
        "report",
        model,
        "--steps",
        "5",
        "--replay",
        run.to_str().expect("UTF-8"),
        "-o",
        out.to_str().expect("UTF-8"),
    ]);
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let page = std::fs::read_to_string(out.join("index.html")).expect("the page");
    let task = page_json(&page, "data")["task"].as_u64().expect("a task point") as usize;
    let replay = page_json(&page, "replay-data");
    let (header, rows) = trace(&run.join("trace.csv"));
    let column = |name: &str| header.iter().position(|h| h == name).unwrap_or_else(|| panic!("{name}"));
    let m = header.iter().filter(|h| h.starts_with("xp")).count();
    let lines = numbers(&replay["lines"]);
    let frames = lines.len();
    assert_eq!(frames, rows.len().min(2000), "{name}: frames");
    assert_eq!(replay["rows"].as_u64(), Some(rows.len() as u64));
    // The first and last rows (line 2 is the first after the header), in order.
    assert_eq!((lines[0], lines[frames - 1]), (2.0, rows.len() as f64 + 1.0));
    assert!(lines.windows(2).all(|w| w[0] < w[1]));
    let (poses, proxy, times) = (&replay["poses"], &replay["proxy"], numbers(&replay["t"]));
    let mut largest = 0.0f64;
    for k in 0..frames {
        let row = &rows[lines[k] as usize - 2];
        assert_eq!(times[k], row[column("t")]);
        let pose = numbers(&poses[k]);
        let drawn_proxy = numbers(&proxy[k]);
        for c in 0..m {
            // The drawing (the model's kinematics) against the simulator's task position.
            let off = (pose[3 * task + c] - row[column(&format!("x{c}"))]).abs();
            largest = largest.max(off);
            assert!(
                off < 1e-6,
                "{name}: frame {k}, x{c}: drawn {} vs trace {}",
                pose[3 * task + c],
                row[column(&format!("x{c}"))]
            );
            assert!(
                (drawn_proxy[c] - row[column(&format!("xp{c}"))]).abs() < 1e-6,
                "{name}: frame {k}, xp{c}"
            );
        }
    }
    eprintln!(
        "{name}: {frames} frames of {} rows; drawn task point within {largest:.2e} m of the trace's",
        rows.len()
    );
    let _ = std::fs::remove_dir_all(out);
    (replay, header, rows)
}

/// `hapticgen simulate` of the five-bar with Controller 3: `scenario` for `duration` s into `run`.
fn simulate_five_bar(scenario: &str, duration: &str, run: &Path) {
    let run = run.to_str().expect("UTF-8");
    let output = hapticgen(&[
        "simulate",
        "models/pantograph_5bar.yaml",
        "--controller",
        "3",
        "--scenario",
        scenario,
        "--duration",
        duration,
        "-o",
        run,
    ]);
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
}

#[test]
fn a_simulate_run_is_replayed_frame_by_frame() {
    let run = scratch("replay-simulate");
    simulate_five_bar("trace-circle", "1", &run);
    let (replay, header, rows) = replayed("models/pantograph_5bar.yaml", &run, "replay-simulate-page");
    // The circle's cavity, centred where the scenario started: the first row's task point.
    let objects = replay["objects"].as_array().expect("the scene's objects");
    assert_eq!(objects.len(), 1, "{objects:?}");
    let shape = &objects[0]["shape"];
    assert_eq!((shape["kind"].as_str(), objects[0]["cavity"].as_bool()), (Some("sphere"), Some(true)));
    let x0 = header.iter().position(|h| h == "x0").expect("x0");
    let centre = numbers(&shape["centre"]);
    assert!(
        (centre[0] - rows[0][x0]).abs() < 1e-8 && (centre[1] - rows[0][x0 + 1]).abs() < 1e-8,
        "{centre:?}"
    );
    let _ = std::fs::remove_dir_all(run);
}

#[test]
fn a_contact_run_is_replayed_subsampled_with_its_floor() {
    // The five-bar pressing a floor (the contact scenarios' `wall`, the one a planar task has):
    // 4.8 s recorded at 1 kHz, more rows than the page's frames.
    let run = scratch("replay-contact");
    let output = hapticgen(&[
        "contact",
        "models/pantograph_5bar.yaml",
        "--only",
        "wall",
        "-o",
        run.to_str().expect("UTF-8"),
    ]);
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stdout));
    let (replay, header, rows) =
        replayed("models/pantograph_5bar.yaml", &run.join("wall"), "replay-contact-page");
    assert!(rows.len() > 2000, "{} rows: not subsampled", rows.len());
    // The floor: 2 cm below the start, facing up.
    let objects = replay["objects"].as_array().expect("the scene's objects");
    assert_eq!(objects.len(), 1, "{objects:?}");
    let shape = &objects[0]["shape"];
    assert_eq!(shape["kind"].as_str(), Some("half_space"));
    assert_eq!(numbers(&shape["normal"]), [0.0, 1.0]);
    let y = header.iter().position(|h| h == "x1").expect("x1");
    assert!((numbers(&shape["point"])[1] - (rows[0][y] - 0.02)).abs() < 1e-9, "{shape}");
    let _ = std::fs::remove_dir_all(run);
}

/// A missing run, an empty trace, a header without rows, another model's joint columns, a
/// cell that is no number and a trace of another model with as many joints: each refused
/// naming the file (and line, column), nothing written.
#[test]
fn bad_runs_are_refused_naming_the_file() {
    let dir = scratch("replay-bad");
    std::fs::create_dir_all(&dir).expect("a scratch directory");
    let run = dir.join("five-bar");
    simulate_five_bar("step", "0.01", &run);
    let text = std::fs::read_to_string(run.join("trace.csv")).expect("the trace");
    let header = text.lines().next().expect("a header");
    let write = |name: &str, content: &str| {
        let path = dir.join(name);
        std::fs::write(&path, content).expect("written");
        path.to_str().expect("UTF-8").to_string()
    };
    let empty = write("empty.csv", "");
    let header_only = write("header-only.csv", &format!("{header}\n"));
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    // Line 4 of the file (the header is line 1), column q1.
    let mut cells: Vec<&str> = lines[3].split(',').collect();
    cells[2] = "abc";
    lines[3] = cells.join(",");
    let not_a_number = write("not-a-number.csv", &(lines.join("\n") + "\n"));
    let missing = dir.join("no-such-run").to_str().expect("UTF-8").to_string();
    let five_bar = run.to_str().expect("UTF-8").to_string();
    let cases: [(&str, &str, &[&str]); 6] = [
        ("models/pantograph_5bar.yaml", &missing, &["no-such-run: no such file or directory"]),
        ("models/pantograph_5bar.yaml", &empty, &["empty.csv: empty"]),
        ("models/pantograph_5bar.yaml", &header_only, &["header-only.csv: the trace has a header but no rows"]),
        (
            "models/falcon_delta.yaml",
            &five_bar,
            &["trace.csv:1: the trace's joint columns are q0, q1 but models/falcon_delta.yaml has 3 actuated joints"],
        ),
        ("models/pantograph_5bar.yaml", &not_a_number, &["not-a-number.csv:4: column `q1`: `abc` is not a number"]),
        ("models/parallel_link_2dof.yaml", &five_bar, &["trace.csv:2: at the trace's joint angles", "another model or variant"]),
    ];
    for (model, trace, expected) in cases {
        let out = dir.join("report");
        let output = hapticgen(&["report", model, "--replay", trace, "-o", out.to_str().expect("UTF-8")]);
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(!output.status.success(), "{trace} accepted");
        assert!(expected.iter().all(|e| stderr.contains(e)), "{trace}: {stderr}");
        assert!(!out.exists(), "{trace}: a report was written");
    }
    let _ = std::fs::remove_dir_all(dir);
}
