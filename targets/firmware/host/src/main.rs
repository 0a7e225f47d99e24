//! `hapticgen-fw-host`: the host side of `scripts/firmware.sh`.
//!
//! ```text
//! hapticgen-fw-host list                          image names, one per line
//! hapticgen-fw-host run <image> <f32|f64>         the scenario on the host (same output format)
//! hapticgen-fw-host size <elf>                    flash and static RAM of an image
//! hapticgen-fw-host push <image>                  the operator's push (N) of a `wall_contact` image
//! hapticgen-fw-host check <image> <qemu-output> <elf> [--limits=warn]
//! ```
//!
//! `check` compares the QEMU run with the host runs of the same scenario and enforces the
//! limits; it prints one result row and exits non-zero, naming every violation, on failure.

use std::process::ExitCode;

use hapticgen_fw_control::board::NoClock;
use hapticgen_fw_control::report::Sink;

mod elf;

#[allow(clippy::all, missing_docs, dead_code)]
mod variants {
    use super::*;
    include!(concat!(env!("OUT_DIR"), "/variants.rs"));
}

/// The limits of one image, from its line of `variants.txt`.
#[derive(Clone, Copy, Debug)]
pub struct Limits {
    /// Largest impedance tick, instructions.
    pub impedance: u64,
    /// Largest current-loop tick (all motors), instructions.
    pub current: u64,
    /// Flash (text + rodata + vector table + data load image), bytes.
    pub flash: u64,
    /// Static RAM (data + bss), bytes.
    pub ram: u64,
}
/// SysTick/APB-timer ticks per instruction under `-icount shift=10` at the MPS2's 25 MHz:
/// 2^10 ns per instruction / 40 ns per tick = 25.6.
const TICKS_PER_INSTRUCTION: f64 = 1024.0 / 40.0;

struct Buffer(Vec<u8>);

impl Sink for Buffer {
    fn write(&mut self, bytes: &[u8]) {
        self.0.extend_from_slice(bytes);
    }
}

struct Stdout;

impl Sink for Stdout {
    fn write(&mut self, bytes: &[u8]) {
        use std::io::Write as _;
        let _ = std::io::stdout().write_all(bytes);
    }
}

fn host_run(name: &str, scalar: &str) -> Result<String, String> {
    let mut buffer = Buffer(Vec::new());
    variants::run(name, scalar, &mut buffer).map_err(|e| format!("{name} {scalar}: {e}"))?;
    String::from_utf8(buffer.0).map_err(|e| e.to_string())
}

/// `key=value` of a line.
fn field<'a>(line: &'a str, key: &str) -> Option<&'a str> {
    line.split_whitespace().find_map(|part| part.strip_prefix(key).and_then(|rest| rest.strip_prefix('=')))
}

fn int(line: &str, key: &str) -> Result<i64, String> {
    field(line, key)
        .ok_or_else(|| format!("no `{key}` in `{line}`"))?
        .parse()
        .map_err(|e| format!("`{key}` in `{line}`: {e}"))
}

fn find<'a>(text: &'a str, prefix: &str) -> Result<&'a str, String> {
    text.lines().find(|l| l.starts_with(prefix)).ok_or_else(|| format!("no `{prefix}` line"))
}

fn list(line: &str, key: &str) -> Result<Vec<i64>, String> {
    field(line, key)
        .ok_or_else(|| format!("no `{key}` in `{line}`"))?
        .split(',')
        .map(|v| v.parse().map_err(|e| format!("`{key}` in `{line}`: {e}")))
        .collect()
}

fn instructions(ticks: i64) -> u64 {
    (ticks as f64 / TICKS_PER_INSTRUCTION).round() as u64
}

fn check(name: &str, qemu_output: &str, elf_path: &str, limits_warn: bool) -> Result<(), Vec<String>> {
    let mut errors = Vec::new();
    let mut limit_errors = Vec::new();
    let budget = match variants::VARIANTS.iter().find(|(n, _)| *n == name) {
        Some((_, l)) => *l,
        None => return Err(vec![format!("unknown image `{name}`")]),
    };
    let target = std::fs::read_to_string(qemu_output).map_err(|e| vec![format!("{qemu_output}: {e}")])?;
    let reference = host_run(name, "f64").map_err(|e| vec![e])?;
    let host32 = host_run(name, "f32").map_err(|e| vec![e])?;
    let mut fail = |message: String| errors.push(format!("{name}: {message}"));

    // Summary: same length of run, no fault, and the f32 trajectory bit for bit as on the host.
    let summaries = (find(&target, "SUMMARY"), find(&host32, "SUMMARY"), find(&reference, "SUMMARY"));
    let (t_sum, h32_sum, h64_sum) = match summaries {
        (Ok(a), Ok(b), Ok(c)) => (a, b, c),
        _ => return Err(vec![format!("{name}: missing SUMMARY line (did the image finish?)")]),
    };
    for key in ["periods", "impedance_ticks", "fault", "plant_ok"] {
        let values = (int(t_sum, key), int(h32_sum, key), int(h64_sum, key));
        match values {
            (Ok(a), Ok(b), Ok(c)) if a == b && b == c => {}
            other => fail(format!(
                "`{key}` differs: target {:?}, host f32 {:?}, host f64 {:?}",
                other.0, other.1, other.2
            )),
        }
    }
    if int(t_sum, "fault").ok() != Some(0) {
        fail(format!("a fault was latched: {t_sum}"));
    }
    let checksum = field(t_sum, "checksum").unwrap_or("?");
    if field(h32_sum, "checksum") != Some(checksum) {
        fail(format!(
            "trajectory checksum {checksum} on the target, {} for the same f32 code on the host",
            field(h32_sum, "checksum").unwrap_or("?")
        ));
    }

    // Trace against the f64 reference.
    let trace =
        |text: &str| text.lines().filter(|l| l.starts_with("S ")).map(str::to_owned).collect::<Vec<_>>();
    let (t_trace, r_trace) = (trace(&target), trace(&reference));
    if t_trace.len() != r_trace.len() || t_trace.is_empty() {
        fail(format!("{} trace lines on the target, {} in the reference", t_trace.len(), r_trace.len()));
    }
    let mut worst: [(i64, String); 3] = Default::default();
    for (t, r) in t_trace.iter().zip(r_trace.iter()) {
        if int(t, "k").ok() != int(r, "k").ok() {
            fail(format!("trace out of step: `{t}` vs `{r}`"));
            break;
        }
        for (slot, key) in worst.iter_mut().zip(["q", "x", "i"]) {
            match (list(t, key), list(r, key)) {
                (Ok(a), Ok(b)) if a.len() == b.len() => {
                    for (x, y) in a.iter().zip(b.iter()) {
                        let d = (x - y).abs();
                        if d > slot.0 {
                            *slot = (d, format!("target `{t}`, reference `{r}`"));
                        }
                    }
                }
                _ => fail(format!("bad trace line `{t}` / `{r}`")),
            }
        }
    }
    // Tolerances come from the reference run (`TOL` line, see hapticgen_fw_sim::scenario).
    let tolerance = find(&reference, "TOL").and_then(|l| Ok((int(l, "x")?, int(l, "i")?)));
    let (x_tol, i_tol) = match tolerance {
        Ok(t) => t,
        Err(e) => return Err(vec![format!("{name}: reference: {e}")]),
    };
    // q is not limited on its own: on a non-singular configuration it follows from x.
    let limits = [("q", i64::MAX, "µrad"), ("x", x_tol, "µm or µrad"), ("i", i_tol, "mA")];
    for ((d, at), (key, tol, unit)) in worst.iter().zip(limits) {
        if *d > tol {
            fail(format!("f32 target vs f64 reference: |Δ{key}| = {d} {unit} > {tol} at {at}"));
        }
    }
    // Cost.
    let cal = find(&target, "CAL").and_then(|l| Ok((int(l, "instructions")?, int(l, "ticks")?)));
    match cal {
        Ok((n, ticks)) => {
            let per = ticks as f64 / n as f64;
            if (per - TICKS_PER_INSTRUCTION).abs() > 0.01 * TICKS_PER_INSTRUCTION {
                fail(format!(
                    "calibration: {n} instructions took {ticks} ticks ({per:.2}/instruction, expected {TICKS_PER_INSTRUCTION}): is QEMU run with -icount shift=10?"
                ));
            }
        }
        Err(e) => fail(format!("calibration: {e}")),
    }
    let cost = |label: &str| -> Result<(u64, u64, u64), String> {
        let line = target
            .lines()
            .find(|l| l.starts_with("COST ") && l.split_whitespace().nth(1) == Some(label))
            .ok_or_else(|| format!("no COST {label} line"))?;
        Ok((
            instructions(int(line, "min")?),
            instructions(int(line, "max")?),
            instructions(int(line, "mean")?),
        ))
    };
    let (imp, cur) = match (cost("impedance"), cost("current")) {
        (Ok(a), Ok(b)) => (a, b),
        (a, b) => {
            fail(format!("cost lines: {:?} {:?}", a.err(), b.err()));
            ((0, 0, 0), (0, 0, 0))
        }
    };
    if imp.1 > budget.impedance {
        limit_errors
            .push(format!("{name}: impedance tick: max {} instructions > limit {}", imp.1, budget.impedance));
    }
    if cur.1 > budget.current {
        limit_errors.push(format!(
            "{name}: current-loop tick: max {} instructions > limit {}",
            cur.1, budget.current
        ));
    }
    let mut profile = String::new();
    for line in target.lines().filter(|l| l.starts_with("PROFILE ")) {
        let step = line.split_whitespace().nth(1).unwrap_or("?");
        if let (Ok(lo), Ok(hi)) = (int(line, "min"), int(line, "max")) {
            profile.push_str(&format!(" {step}={}..{}", instructions(lo), instructions(hi)));
        }
    }

    // Size.
    let (flash, ram) = match elf::sizes(elf_path) {
        Ok(s) => (s.flash(), s.ram()),
        Err(e) => {
            fail(format!("{elf_path}: {e}"));
            (0, 0)
        }
    };
    if flash > budget.flash {
        limit_errors.push(format!("{name}: flash {flash} B > limit {} B", budget.flash));
    }
    if ram > budget.ram {
        limit_errors.push(format!("{name}: static RAM {ram} B > limit {} B", budget.ram));
    }

    println!(
        "| {name} | {} | {} | {} (≤ {}) | {} | {} | {} (≤ {}) | {flash} (≤ {}) | {ram} (≤ {}) | {checksum} | {} (≤ {x_tol}) / {} (≤ {i_tol}) |",
        imp.0,
        imp.2,
        imp.1,
        budget.impedance,
        cur.0,
        cur.2,
        cur.1,
        budget.current,
        budget.flash,
        budget.ram,
        worst[1].0,
        worst[2].0
    );
    println!("  profile (instructions, min..max):{profile}");
    for e in limit_errors {
        if limits_warn {
            eprintln!("WARN (limit, not enforced) {e}");
        } else {
            errors.push(e);
        }
    }
    if errors.is_empty() {
        Ok(())
    } else {
        Err(errors)
    }
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    match args.as_slice() {
        ["push", name] => match variants::wall_push(name) {
            Some(f) => {
                println!("{f}");
                ExitCode::SUCCESS
            }
            None => ExitCode::FAILURE,
        },
        ["list"] => {
            for (name, _) in variants::VARIANTS {
                println!("{name}");
            }
            ExitCode::SUCCESS
        }
        ["run", name, scalar] => match variants::run(name, scalar, &mut Stdout) {
            Ok(()) => ExitCode::SUCCESS,
            Err(e) => {
                eprintln!("error: {e}");
                ExitCode::FAILURE
            }
        },
        ["size", path] => match elf::sizes(path) {
            Ok(s) => {
                println!("text={} data={} bss={} flash={} ram={}", s.text, s.data, s.bss, s.flash(), s.ram());
                ExitCode::SUCCESS
            }
            Err(e) => {
                eprintln!("error: {path}: {e}");
                ExitCode::FAILURE
            }
        },
        ["check", name, output, elf_path, rest @ ..] if rest.is_empty() || rest == ["--limits=warn"] => {
            match check(name, output, elf_path, !rest.is_empty()) {
                Ok(()) => ExitCode::SUCCESS,
                Err(errors) => {
                    for e in errors {
                        eprintln!("FAIL {e}");
                    }
                    ExitCode::FAILURE
                }
            }
        }
        _ => {
            eprintln!("usage: hapticgen-fw-host list | run <image> <f32|f64> | size <elf> | push <image> | check <image> <qemu-output> <elf> [--limits=warn]");
            ExitCode::from(2)
        }
    }
}

/// The reference runs against what each scenario's physics predicts in closed form (the
/// numbers come from the scenario's own constants, not from earlier runs). Every image whose
/// line names the scenario is checked.
#[cfg(test)]
mod tests {
    use super::*;
    use hapticgen_fw_sim::scenarios::{hold_pose, sphere_cavity, wall_contact, PAPER_RENDERING};

    /// `(k, q, x)` of every trace line of the f64 reference run (µrad, µm or µrad).
    fn trace(name: &str) -> Vec<(i64, Vec<i64>, Vec<i64>)> {
        let text = host_run(name, "f64").unwrap();
        let summary = find(&text, "SUMMARY").unwrap();
        assert_eq!(int(summary, "fault").unwrap(), 0, "{name}: {summary}");
        text.lines()
            .filter(|l| l.starts_with("S "))
            .map(|l| (int(l, "k").unwrap(), list(l, "q").unwrap(), list(l, "x").unwrap()))
            .collect()
    }

    fn images(scenario: &str) -> Vec<&'static str> {
        variants::SCENARIOS.iter().filter(|(_, s)| *s == scenario).map(|(n, _)| *n).collect()
    }

    /// The sample at period `k` (the push ends at `CURRENT_LOOP_HZ` = 7500 periods, 1 s).
    fn at(trace: &[(i64, Vec<i64>, Vec<i64>)], k: i64) -> &[i64] {
        &trace.iter().find(|(kk, _, _)| *kk == k).unwrap().2
    }

    fn offset(a: &[i64], b: &[i64]) -> Vec<f64> {
        a.iter().zip(b).map(|(x, y)| (x - y) as f64 * 1e-6).collect()
    }

    fn norm(v: &[f64]) -> f64 {
        v.iter().map(|x| x * x).sum::<f64>().sqrt()
    }

    #[test]
    fn hold_pose_gives_way_by_force_over_stiffness_and_returns() {
        let names = images("hold_pose");
        assert!(!names.is_empty());
        for name in names {
            let t = trace(name);
            let start = &t[0].2;
            // End of the push: the spring alone holds F, along −x_M only.
            let d = offset(at(&t, 7500), start);
            let expected = -hold_pose::FORCE / hold_pose::STIFFNESS;
            let last = d.len() - 1;
            assert!((d[last] - expected).abs() < 0.1 * expected.abs(), "{name}: {d:?} vs {expected}");
            for (axis, v) in d[..last].iter().enumerate() {
                assert!(v.abs() < 0.1 * expected.abs(), "{name}: axis {axis} moved {v} m");
            }
            // 0.5 s after letting go: back within a tenth of the deflection.
            let end = offset(&t.last().unwrap().2, start);
            assert!(norm(&end) < 0.1 * expected.abs(), "{name}: ends {end:?} from the start");
        }
    }

    #[test]
    fn sphere_cavity_holds_the_point_on_its_wall_along_the_push() {
        let names = images("sphere_cavity");
        assert!(!names.is_empty());
        let (grid, stiffness) = (PAPER_RENDERING[0], PAPER_RENDERING[1]);
        for name in names {
            let t = trace(name);
            let start = &t[0].2;
            let d = offset(at(&t, 7500), start);
            // Concave wall: at rest beyond the wall by F/K, along the push (2, 1, 2)/3.
            let expected = sphere_cavity::RADIUS + sphere_cavity::FORCE / stiffness;
            assert!((norm(&d) - expected).abs() < 2.0 * grid, "{name}: |{d:?}| vs {expected}");
            let cosine = (2.0 * d[0] + d[1] + 2.0 * d[2]) / 3.0 / norm(&d);
            assert!(cosine > 0.995, "{name}: direction {d:?}, cosine {cosine}");
            // After letting go the wall pushes it back inside, where the grid holds it.
            let end = offset(&t.last().unwrap().2, start);
            assert!(norm(&end) < sphere_cavity::RADIUS, "{name}: ends {end:?} outside the cavity");
        }
    }

    #[test]
    fn wall_contact_stops_the_point_at_the_wall() {
        let names = images("wall_contact");
        assert!(!names.is_empty());
        for name in names {
            let force = variants::wall_push(name).unwrap();
            let [_, stiffness, _] = variants::rendering(name).unwrap_or(PAPER_RENDERING);
            let t = trace(name);
            let start = &t[0].2;
            let wall = wall_contact::WALL;
            let pushed: Vec<(i64, f64)> = t
                .iter()
                .filter(|(k, _, _)| (750..=7500).contains(k))
                .map(|(k, _, x)| (*k, offset(x, start)[0]))
                .collect();
            // Over the last 0.3 s of the push the point rests (on average over the ring) in
            // the wall by F/K.
            let late: Vec<f64> = pushed.iter().filter(|(k, _)| *k >= 5250).map(|(_, x)| x - wall).collect();
            let mean = late.iter().sum::<f64>() / late.len() as f64;
            let penetration = force / stiffness;
            assert!(
                (mean - penetration).abs() < 0.1 * penetration,
                "{name}: in the wall by {mean} m, F/K = {penetration}"
            );
            // Passivity: the deepest penetration p cannot exceed what the operator's work
            // F (d + p) can store in the wall spring, K p² / 2 = F (d + p).
            let deepest = pushed.iter().map(|(_, x)| x - wall).fold(f64::MIN, f64::max);
            let bound = (force + (force * force + 2.0 * stiffness * force * wall).sqrt()) / stiffness;
            assert!(deepest < bound, "{name}: {deepest} m into the wall, energy bound {bound} m");
        }
    }

    #[test]
    fn fig4_step_settles_at_force_over_stiffness() {
        let names = images("fig4_step");
        assert!(!names.is_empty());
        for name in names {
            let t = trace(name);
            // K_d = 1 N·m/rad, 1 N·m: 1 rad; after 1.9 s of a ζ ≈ 0.09 ring, within 10 %.
            let (_, q, _) = t.last().unwrap();
            let end = (q[0] - t[0].1[0]) as f64 * 1e-6;
            assert!((end - 1.0).abs() < 0.1, "{name}: ends at {end} rad");
        }
    }
}
