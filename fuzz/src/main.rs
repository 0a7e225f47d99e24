//! `hapticgen-fuzz`: fuzzes the model loader alone or `hapticgen_codegen::generate` end to
//! end for a given time.
//!
//! ```text
//! cargo run --release -p hapticgen-fuzz -- [--stage loader|generator] [--seconds S] [--seed N]
//!     [--timeout-ms MS] [--stack-mb MB] [--workers N] [--out DIR]
//! cargo run --release -p hapticgen-fuzz -- --replay FILE [--variant V] [--stage S]   # one input
//! cargo run --release -p hapticgen-fuzz -- --minimise FILE                            # shrink a finding
//! ```
//!
//! `--stage` defaults to `generator` (load, mechanics, emission, formatting: milliseconds per
//! input); `loader` stops after the model is loaded and checked (tens of microseconds), and
//! runs inputs in batches of [`LOADER_BATCH`]. `--workers` (default 2) worker threads each
//! run their own batches while the main thread draws the next. `--seconds` defaults to
//! `$HAPTICGEN_FUZZ_SECONDS`, else 60. The process supervises a child that does the fuzzing:
//! before a batch runs, the child writes it and the batches the other workers are running to
//! `DIR/current.batch`, so when a stack overflow aborts the child, the supervisor replays
//! those inputs one by one in fresh processes and reports the one that aborts (copied to
//! `DIR/crash-stack-overflow.yaml`). Panics and invariant violations are saved as
//! `DIR/finding-*.yaml`, the batches running at a hang as `DIR/hang.batch`, the slowest input
//! as `DIR/slowest.yaml`.
//! `DIR` defaults to `fuzz/` in the target directory this executable was built in (`target/`
//! or wherever `CARGO_TARGET_DIR` puts it). Exit code 0 when inputs ran, some of them through
//! to generated code and some to a diagnostic, and none broke the invariant; 1 otherwise (a
//! run that executed nothing, or whose seed directories are missing or empty, fails too).

use std::io::{Seek as _, Write as _};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::{Duration, Instant};

use arbitrary::Unstructured;
use hapticgen_codegen::Scalar;
use hapticgen_fuzz::{
    corpus_dirs, load_corpus, mutate, quiet_worker_panics, seed_pool, structured, Input, PendingBatch,
    Runner, Stage, Verdict,
};

/// mimalloc: at the loader stage a fifth of the instructions were glibc's `malloc` and
/// `free` (about 260 instructions per allocation and free, 2,200 of each per input, many
/// freed on another thread than the one that made them); mimalloc takes 18 % fewer
/// instructions per input in all (callgrind). Its `secure` option (guard pages, encrypted
/// free lists) cost as much as glibc and is off: glibc's incidental heap-consistency aborts
/// (`double free detected`) are not made here; the code under test is safe Rust apart from
/// unsafe-libyaml.
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

/// Inputs per batch at the loader stage: enough that the round trip to the worker thread is
/// a small part of a batch, few enough that a batch takes milliseconds.
const LOADER_BATCH: usize = 64;
use rand::rngs::SmallRng;
use rand::{Rng, RngCore, SeedableRng};

struct Options {
    seconds: f64,
    seed: u64,
    timeout: Duration,
    stack_bytes: usize,
    out: PathBuf,
    child: bool,
    replay: Option<PathBuf>,
    minimise: Option<PathBuf>,
    variant: Option<String>,
    stage: Stage,
    workers: usize,
}

fn parse() -> Result<Options, String> {
    let workspace = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let seconds = std::env::var("HAPTICGEN_FUZZ_SECONDS").ok().and_then(|s| s.parse().ok()).unwrap_or(60.0);
    let mut o = Options {
        seconds,
        seed: 1,
        timeout: Duration::from_millis(1000),
        stack_bytes: 8 << 20,
        out: default_out_dir().unwrap_or_else(|| workspace.join("target/fuzz")),
        child: false,
        replay: None,
        minimise: None,
        variant: None,
        stage: Stage::Generator,
        workers: 2,
    };
    let mut args = std::env::args().skip(1);
    while let Some(arg) = args.next() {
        let mut value = || args.next().ok_or_else(|| format!("{arg} needs a value"));
        let number = |v: String| v.parse::<f64>().map_err(|e| format!("{arg}: {e}"));
        match arg.as_str() {
            "--seconds" => o.seconds = number(value()?)?,
            "--seed" => o.seed = number(value()?)? as u64,
            "--timeout-ms" => o.timeout = Duration::from_millis(number(value()?)? as u64),
            "--stack-mb" => o.stack_bytes = (number(value()?)? * 1048576.0) as usize,
            "--out" | "-o" => o.out = PathBuf::from(value()?),
            "--replay" => o.replay = Some(PathBuf::from(value()?)),
            "--minimise" => o.minimise = Some(PathBuf::from(value()?)),
            "--variant" => o.variant = Some(value()?),
            "--child" => o.child = true,
            "--workers" => o.workers = (number(value()?)? as usize).max(1),
            "--stage" => {
                o.stage = match value()?.as_str() {
                    "loader" => Stage::Loader,
                    "generator" => Stage::Generator,
                    other => return Err(format!("--stage: `{other}` is neither `loader` nor `generator`")),
                }
            }
            other => return Err(format!("unknown argument `{other}`")),
        }
    }
    Ok(o)
}

/// `fuzz/` in the target directory this executable was built in: it runs from
/// `<target dir>/<profile>/hapticgen-fuzz` (or `<target dir>/<triple>/<profile>/…`).
fn default_out_dir() -> Option<PathBuf> {
    let exe = std::env::current_exe().ok()?;
    Some(exe.parent()?.parent()?.join("fuzz"))
}

fn main() -> ExitCode {
    let options = match parse() {
        Ok(o) => o,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    quiet_worker_panics();
    if let Some(path) = &options.replay {
        return replay(path, &options);
    }
    if let Some(path) = &options.minimise {
        return minimise(path, &options);
    }
    if options.child {
        return fuzz(&options);
    }
    supervise(&options)
}

/// Runs the fuzzing child and reports an abort (stack overflow) with its input.
fn supervise(options: &Options) -> ExitCode {
    if let Err(e) = std::fs::create_dir_all(&options.out) {
        eprintln!("error: cannot create {}: {e}", options.out.display());
        return ExitCode::FAILURE;
    }
    let exe = match std::env::current_exe() {
        Ok(e) => e,
        Err(e) => {
            eprintln!("error: cannot find this executable: {e}");
            return ExitCode::FAILURE;
        }
    };
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    args.push("--child".into());
    let status = match std::process::Command::new(&exe).args(&args).status() {
        Ok(s) => s,
        Err(e) => {
            eprintln!("error: cannot start the fuzzing process: {e}");
            return ExitCode::FAILURE;
        }
    };
    match status.code() {
        Some(0) => ExitCode::SUCCESS,
        Some(1) => ExitCode::FAILURE,
        _ => {
            eprintln!("fuzz: FAIL: the fuzzing process died ({status}), most likely a stack overflow");
            report_crash(&exe, options);
            ExitCode::FAILURE
        }
    }
}

/// The inputs of the batches the fuzzing child was running when it died, as written by
/// [`write_batches`].
fn read_batch(path: &Path) -> Vec<(String, Vec<u8>)> {
    let Ok(bytes) = std::fs::read(path) else { return Vec::new() };
    let fields: Vec<&[u8]> = bytes.split(|&b| b == 0).collect();
    fields
        .chunks_exact(2)
        .map(|pair| (String::from_utf8_lossy(pair[0]).into_owned(), pair[1].to_vec()))
        .collect()
}

/// A batch as `variant NUL text NUL` per input, the format of `current.batch` (the texts are
/// valid UTF-8 without NUL bytes only by chance, so NULs are replaced: the loader sees the
/// same lossy text).
fn encode_batch(inputs: &[Input]) -> Vec<u8> {
    let mut buffer = Vec::with_capacity(inputs.iter().map(|i| i.text.len() + 16).sum());
    for input in inputs {
        buffer.extend_from_slice(input.variant.as_deref().unwrap_or("").as_bytes());
        buffer.push(0);
        let start = buffer.len();
        buffer.extend_from_slice(input.text.as_bytes());
        for b in &mut buffer[start..] {
            if *b == 0 {
                *b = b' ';
            }
        }
        buffer.push(0);
    }
    buffer
}

/// Writes the batches the workers are running (each encoded by [`encode_batch`]) to
/// `current.batch`, one after the other: the supervisor replays all their inputs.
fn write_batches(file: &mut std::fs::File, batches: &[&[u8]]) -> std::io::Result<()> {
    file.set_len(0)?;
    file.rewind()?;
    for batch in batches {
        file.write_all(batch)?;
    }
    file.flush()
}

/// Finds the input of the dead child's batch that kills a process on its own (each replayed
/// in a fresh child), and saves it as `crash-stack-overflow.yaml`.
fn report_crash(exe: &Path, options: &Options) {
    let batch = read_batch(&options.out.join("current.batch"));
    let replay_file = options.out.join("crash-candidate.yaml");
    for (variant, text) in &batch {
        if std::fs::write(&replay_file, text).is_err() {
            break;
        }
        let mut command = std::process::Command::new(exe);
        command.arg("--replay").arg(&replay_file).args(["--stage", options.stage.name()]);
        command.args(["--stack-mb", &(options.stack_bytes >> 20).to_string()]);
        if !variant.is_empty() {
            command.args(["--variant", variant]);
        }
        let died = command
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .status()
            .is_ok_and(|status| status.code().is_none());
        if died {
            let crash = options.out.join("crash-stack-overflow.yaml");
            let _ = std::fs::rename(&replay_file, &crash);
            eprintln!("fuzz: the input that kills the process is {} (variant {variant:?})", crash.display());
            return;
        }
    }
    eprintln!(
        "fuzz: none of the {} inputs of the last batch ({}) kills a process on its own",
        batch.len(),
        options.out.join("current.batch").display()
    );
}

fn scalar_of(rng: &mut SmallRng) -> Scalar {
    if rng.gen_bool(0.5) {
        Scalar::F64
    } else {
        Scalar::F32
    }
}

/// The fuzzing loop (in the child process).
fn fuzz(options: &Options) -> ExitCode {
    let workspace = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    // Every seed directory must contribute: one that moved or emptied would shrink the corpus
    // without a word.
    for dir in corpus_dirs(&workspace) {
        let seeds = load_corpus(std::slice::from_ref(&dir)).len();
        if seeds == 0 {
            eprintln!("fuzz: FAIL: no seed files (*.yaml) in {}", dir.display());
            return ExitCode::FAILURE;
        }
    }
    let corpus = seed_pool(&load_corpus(&corpus_dirs(&workspace)));
    if corpus.is_empty() {
        eprintln!("error: empty seed corpus");
        return ExitCode::FAILURE;
    }
    // One runner (a worker thread) per core: each runs its own batches, so that loading uses
    // both of CI's cores while this thread draws the next batch.
    let mut runners = Vec::with_capacity(options.workers);
    for _ in 0..options.workers {
        match Runner::new(options.stack_bytes, options.timeout) {
            Ok(r) => runners.push(r),
            Err(e) => {
                eprintln!("error: cannot start a worker thread: {e}");
                return ExitCode::FAILURE;
            }
        }
    }
    let current_path = options.out.join("current.batch");
    let mut current = match std::fs::File::create(&current_path) {
        Ok(f) => f,
        Err(e) => {
            eprintln!("error: cannot write {}: {e}", current_path.display());
            return ExitCode::FAILURE;
        }
    };
    let batch_size = match options.stage {
        Stage::Loader => LOADER_BATCH,
        Stage::Generator => 1,
    };
    println!(
        "fuzz: the {}, {} seeds (compacted, one in {} also as written), {:.0} s, seed {}, time limit {} ms per \
         input, {} workers, worker stack {} MiB",
        options.stage.name(),
        corpus.len(),
        hapticgen_fuzz::SEEDS_KEPT_AS_WRITTEN,
        options.seconds,
        options.seed,
        options.timeout.as_millis(),
        options.workers,
        options.stack_bytes >> 20
    );
    let mut rng = SmallRng::seed_from_u64(options.seed);
    let mut bytes = vec![0u8; 8192];
    let start = Instant::now();
    let deadline = Duration::from_secs_f64(options.seconds.max(0.0));
    let (mut executions, mut generated, mut rejected, mut structured_count) = (0u64, 0u64, 0u64, 0u64);
    // Total length of the inputs run, bytes: the stage's time per input grows with it.
    let (mut input_bytes, mut structured_bytes) = (0u64, 0u64);
    let mut slowest = (Duration::ZERO, String::new());
    let mut findings: Vec<String> = Vec::new();
    let mut known: Vec<String> = Vec::new();
    let mut next_report = Duration::from_secs(10);
    // CPU time inside the stage (on the workers), against the run's wall time: the rest is
    // drawing inputs and bookkeeping.
    let mut checking = Duration::ZERO;
    // The batch each worker runs: its encoding as written to `current.batch`, its texts and
    // variants (to save a failing one) and which inputs are structured.
    struct InFlight {
        pending: PendingBatch,
        encoded: Vec<u8>,
        texts: Vec<(String, Option<String>)>,
        structured: Vec<bool>,
    }
    let mut in_flight: Vec<Option<InFlight>> = runners.iter().map(|_| None).collect();
    'fuzzing: loop {
        for slot in 0..runners.len() {
            // The next batch for this worker is drawn while every worker still runs its own.
            let next = (start.elapsed() < deadline)
                .then(|| draw_batch(&mut rng, &corpus, &mut bytes, batch_size, options.stage));
            if let Some(flight) = in_flight[slot].take() {
                let verdicts = runners[slot].collect(flight.pending);
                for ((verdict, (text, variant)), from_structured) in
                    verdicts.into_iter().zip(flight.texts).zip(flight.structured)
                {
                    executions += 1;
                    input_bytes += text.len() as u64;
                    structured_count += u64::from(from_structured);
                    if from_structured {
                        structured_bytes += text.len() as u64;
                    }
                    match verdict {
                        Verdict::Ok(outcome, elapsed) => {
                            checking += elapsed;
                            match outcome {
                                hapticgen_fuzz::Outcome::Generated => generated += 1,
                                hapticgen_fuzz::Outcome::Rejected => rejected += 1,
                            }
                            if elapsed > slowest.0 {
                                slowest = (elapsed, text);
                            }
                        }
                        Verdict::Panic(message) => {
                            let list = if is_known(&message) { &mut known } else { &mut findings };
                            record(&options.out, list, "panic", &message, &text, variant.as_deref());
                        }
                        Verdict::Violation(message) => {
                            let list = if is_known(&message) { &mut known } else { &mut findings };
                            record(&options.out, list, "violation", &message, &text, variant.as_deref());
                        }
                        Verdict::Slow(outcome, took) => {
                            let what = match outcome {
                                hapticgen_fuzz::Outcome::Generated => "slow acceptance of a valid model",
                                hapticgen_fuzz::Outcome::Rejected => "slow rejection",
                            };
                            let message = format!(
                                "{what} ({}): {} ms CPU, over the limit of {} ms",
                                options.stage.name(),
                                took.as_millis(),
                                options.timeout.as_millis()
                            );
                            let list = if is_known(&message) { &mut known } else { &mut findings };
                            record(&options.out, list, "slow", &message, &text, variant.as_deref());
                            if took > slowest.0 {
                                slowest = (took, text);
                            }
                        }
                        Verdict::Hang(took) => {
                            // The batch as a whole gave no answer: save it; `--replay` each input to
                            // find the one that hangs.
                            let path = options.out.join("hang.batch");
                            let _ = std::fs::copy(&current_path, &path);
                            eprintln!(
                                "fuzz: FAIL: a batch of {batch_size} inputs gave no answer within {} ms (limit {} ms CPU \
                                 per input); saved as {} (variant NUL text NUL per input)",
                                took.as_millis(),
                                options.timeout.as_millis(),
                                path.display()
                            );
                            findings.push("hang".into());
                            break 'fuzzing; // the worker is still busy
                        }
                    }
                }
            }
            if findings.len() >= 20 {
                eprintln!("fuzz: stopping after 20 distinct findings");
                break 'fuzzing;
            }
            if let Some((batch, structured)) = next {
                // `current.batch` holds every batch a worker may be running before it runs.
                let encoded = encode_batch(&batch);
                let others = in_flight.iter().flatten().map(|f| f.encoded.as_slice());
                let running: Vec<&[u8]> = std::iter::once(encoded.as_slice()).chain(others).collect();
                let _ = write_batches(&mut current, &running);
                let texts = batch.iter().map(|i| (i.text.clone(), i.variant.clone())).collect();
                let pending = runners[slot].submit(batch);
                in_flight[slot] = Some(InFlight { pending, encoded, texts, structured });
            }
        }
        if in_flight.iter().all(Option::is_none) {
            break;
        }
        if start.elapsed() >= next_report {
            println!(
                "fuzz: {:>5.0} s  {executions} executions ({:.0}/s), {generated} accepted, {rejected} rejected",
                start.elapsed().as_secs_f64(),
                executions as f64 / start.elapsed().as_secs_f64()
            );
            next_report += Duration::from_secs(10);
        }
    }
    let seconds = start.elapsed().as_secs_f64();
    let _ = std::fs::write(options.out.join("slowest.yaml"), &slowest.1);
    println!(
        "fuzz: {executions} executions in {seconds:.1} s ({:.0} executions/s; {structured_count} structured, {} \
         mutated) at the {}: {generated} {}, {rejected} rejected with a diagnostic; slowest input {:.1} ms \
         (limit {} ms), {:.1} s of CPU time in the {}; inputs of {:.0} bytes on average ({:.0} structured, {:.0} mutated); {} findings, {} known findings (not failing: see \
         docs/reliability.md)",
        executions as f64 / seconds.max(1e-9),
        executions - structured_count,
        options.stage.name(),
        match options.stage {
            Stage::Loader => "loaded",
            Stage::Generator => "generated code",
        },
        slowest.0.as_secs_f64() * 1e3,
        options.timeout.as_millis(),
        checking.as_secs_f64(),
        options.stage.name(),
        input_bytes as f64 / executions.max(1) as f64,
        structured_bytes as f64 / structured_count.max(1) as f64,
        (input_bytes - structured_bytes) as f64 / (executions - structured_count).max(1) as f64,
        findings.len(),
        known.len()
    );
    if !findings.is_empty() {
        return ExitCode::FAILURE;
    }
    // A run that executed nothing, or never reached one of the two outcomes, checked nothing
    // (or only half of the generator): fail rather than pass on it.
    if executions == 0 || generated == 0 || rejected == 0 {
        eprintln!(
            "fuzz: FAIL: the run exercised too little: {executions} inputs executed, {generated} accepted, \
             {rejected} rejected (each must be at least 1; --seconds {})",
            options.seconds
        );
        return ExitCode::FAILURE;
    }
    ExitCode::SUCCESS
}

/// A batch of `size` inputs, half drawn by the structured generator, half mutated from the
/// seed corpus, with a flag per input saying which (`true`: structured).
fn draw_batch(
    rng: &mut SmallRng,
    corpus: &[(PathBuf, Vec<u8>)],
    bytes: &mut [u8],
    batch_size: usize,
    stage: Stage,
) -> (Vec<Input>, Vec<bool>) {
    let mut batch = Vec::with_capacity(batch_size);
    let mut structured_flags = Vec::with_capacity(batch_size);
    while batch.len() < batch_size {
        let from_structured = rng.gen_bool(0.5);
        let input = if from_structured {
            rng.fill_bytes(bytes);
            let mut u = Unstructured::new(bytes);
            let Ok(doc) = structured::document(&mut u) else { continue };
            Input {
                text: doc.text,
                variant: doc.variant,
                scalar: scalar_of(rng),
                fused_multiply_add: rng.gen_bool(0.5),
                stage,
            }
        } else {
            let seed = &corpus[rng.gen_range(0..corpus.len())].1;
            let other = &corpus[rng.gen_range(0..corpus.len())].1;
            let data = mutate::mutate(seed, other, rng);
            let variant = match rng.gen_range(0..6) {
                0 => Some("horizontal".to_string()),
                1 => Some("vertical".to_string()),
                _ => None,
            };
            Input {
                text: String::from_utf8_lossy(&data).into_owned(),
                variant,
                scalar: scalar_of(rng),
                fused_multiply_add: rng.gen_bool(0.5),
                stage,
            }
        };
        batch.push(input);
        structured_flags.push(from_structured);
    }
    (batch, structured_flags)
}

/// Whether a finding's message is a known one (counted and saved, not failing the run).
fn is_known(message: &str) -> bool {
    hapticgen_fuzz::known_finding(message).is_some()
}

/// Saves a finding (once per distinct message).
fn record(
    out: &Path,
    findings: &mut Vec<String>,
    kind: &str,
    message: &str,
    text: &str,
    variant: Option<&str>,
) {
    // One finding per kind of message (numbers and quoted names stripped).
    let first = message.lines().next().unwrap_or("");
    let key = match hapticgen_fuzz::known_finding(message) {
        Some(why) => format!("{kind}: known: {why}"),
        None => format!("{kind}: {}", first.chars().filter(|c| !c.is_ascii_digit()).collect::<String>()),
    };
    if findings.contains(&key) {
        return;
    }
    let known = hapticgen_fuzz::known_finding(message);
    let prefix = if known.is_some() { "known" } else { "finding" };
    let path = out.join(format!("{prefix}-{}-{kind}.yaml", findings.len() + 1));
    let _ = std::fs::write(&path, text);
    match known {
        Some(_) => eprintln!(
            "fuzz: known finding (not failing): {first}\n  {key}\n  input saved as {}",
            path.display()
        ),
        None => eprintln!("fuzz: FAIL: {key}\n  variant {variant:?}; input saved as {}", path.display()),
    }
    findings.push(key);
}

fn read_input(path: &Path, options: &Options) -> Result<Input, String> {
    let bytes = std::fs::read(path).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    Ok(Input {
        text: String::from_utf8_lossy(&bytes).into_owned(),
        variant: options.variant.clone(),
        scalar: Scalar::F64,
        fused_multiply_add: false,
        stage: options.stage,
    })
}

/// Runs one saved input and prints the verdict.
fn replay(path: &Path, options: &Options) -> ExitCode {
    let input = match read_input(path, options) {
        Ok(i) => i,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    let mut runner = match Runner::new(options.stack_bytes, options.timeout) {
        Ok(r) => r,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::FAILURE;
        }
    };
    let verdict = runner.run(input);
    println!("{}: {verdict:?}", path.display());
    if matches!(verdict, Verdict::Ok(..)) {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    }
}

/// The kind of a failing verdict with its first line, to keep while shrinking.
fn signature(verdict: &Verdict) -> Option<String> {
    match verdict {
        Verdict::Ok(..) => None,
        Verdict::Panic(m) => Some(format!("panic: {}", m.lines().next().unwrap_or(""))),
        Verdict::Violation(m) => Some(format!("violation: {}", m.split(':').next().unwrap_or(""))),
        Verdict::Slow(..) => Some("slow".into()),
        Verdict::Hang(_) => Some("hang".into()),
    }
}

/// Shrinks a failing input (lines, then characters) while it keeps failing the same way;
/// writes `FILE.min.yaml`.
fn minimise(path: &Path, options: &Options) -> ExitCode {
    let input = match read_input(path, options) {
        Ok(i) => i,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    let run = |text: &str| -> Option<String> {
        let mut runner = Runner::new(options.stack_bytes, options.timeout).ok()?;
        signature(&runner.run(Input { text: text.to_string(), ..input.clone() }))
    };
    let Some(target) = run(&input.text) else {
        println!("{}: the input does not fail", path.display());
        return ExitCode::SUCCESS;
    };
    let mut units: Vec<String> = input.text.split_inclusive('\n').map(str::to_string).collect();
    for by_chars in [false, true] {
        if by_chars {
            units = units.concat().chars().map(String::from).collect();
        }
        let mut chunk = units.len().div_ceil(2).max(1);
        while chunk >= 1 {
            let mut i = 0;
            while i < units.len() {
                let mut candidate = units.clone();
                candidate.drain(i..(i + chunk).min(units.len()));
                if run(&candidate.concat()).as_ref() == Some(&target) {
                    units = candidate;
                } else {
                    i += chunk;
                }
            }
            if chunk == 1 {
                break;
            }
            chunk /= 2;
        }
    }
    let out = path.with_extension("min.yaml");
    let text = units.concat();
    let _ = std::fs::write(&out, &text);
    println!("{target}\nminimised to {} bytes: {}\n{text}", text.len(), out.display());
    ExitCode::FAILURE
}
