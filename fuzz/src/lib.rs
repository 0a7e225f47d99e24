//! Fuzzing of hapticgen's model loader and whole code generator, on the stable toolchain.
//!
//! Inputs come from two sources: [`structured`] documents (random but plausible models drawn
//! with `arbitrary` and serialised to YAML) and [`mutate`]d seeds (the corpus in
//! `fuzz/corpus/` plus every model file of the repository). Each input goes through one of two
//! [`Stage`]s: the model loader alone (parse → resolve → checks → diagnostics, at the rate a
//! parser deserves), or `hapticgen_codegen::generate` end to end — load, mechanics, emission —
//! with the emitted items formatted by prettyplease. The invariant ([`check`]): every input
//! ends in a loaded model (or generated code) or in diagnostics whose line and column are at
//! least 1 and within the file; never a panic, a hang (the [`Runner`] measures every input
//! against a time limit) or a stack overflow (inputs run on a thread with a bounded stack; an
//! overflow aborts the process, and the binary's supervisor finds the input that was running).
#![deny(missing_docs)]

pub mod mutate;
pub mod structured;

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError, Sender};
use std::time::{Duration, Instant};

use hapticgen_codegen::{Scalar, Source};

/// The name every input is loaded under (diagnostics must name it).
pub const INPUT_NAME: &str = "fuzz.yaml";

/// How far an input goes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stage {
    /// `hapticgen_codegen::model::load`: parsing, the variant, resolution and validation
    /// (the model-level analyses — current-loop design, closure analysis — belong to the
    /// generator stage).
    Loader,
    /// `hapticgen_codegen::generate_with` and formatting: load, mechanics, emission.
    Generator,
}

impl Stage {
    /// The stage's name on the command line (`--stage`).
    pub fn name(self) -> &'static str {
        match self {
            Stage::Loader => "loader",
            Stage::Generator => "generator",
        }
    }
}

/// One input.
#[derive(Clone, Debug)]
pub struct Input {
    /// The model text (lossily decoded: the loader takes `&str`, as every front end does).
    pub text: String,
    /// The variant to request.
    pub variant: Option<String>,
    /// Scalar type of the emitted code.
    pub scalar: Scalar,
    /// Emit fused multiply-adds (`hapticgen generate --fma`).
    pub fused_multiply_add: bool,
    /// How far the input goes.
    pub stage: Stage,
}

/// How an input ended when the invariant held.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Outcome {
    /// Code was generated and formatted (the generator stage), or the model loaded (the
    /// loader stage).
    Generated,
    /// The loader rejected the input with diagnostics inside the file.
    Rejected,
}

/// Runs one input through its stage and checks the invariant (except time and stack, which
/// the [`Runner`] watches). Panics propagate to the caller.
pub fn check(input: &Input) -> Result<Outcome, String> {
    let source = Source { name: INPUT_NAME, text: &input.text };
    let variant = input.variant.as_deref();
    let diagnostics = match input.stage {
        Stage::Loader => match hapticgen_codegen::model::load(&source, variant) {
            Ok(_) => return Ok(Outcome::Generated),
            Err(diagnostics) => diagnostics,
        },
        Stage::Generator => {
            let options = hapticgen_codegen::EmitOptions {
                fused_multiply_add: input.fused_multiply_add,
                ..Default::default()
            };
            match hapticgen_codegen::generate_with(&source, variant, input.scalar, options) {
                Ok(generated) => {
                    if generated.formatted_items().trim().is_empty() {
                        return Err("generation succeeded but the formatted code is empty".into());
                    }
                    return Ok(Outcome::Generated);
                }
                Err(diagnostics) => diagnostics,
            }
        }
    };
    if diagnostics.0.is_empty() {
        return Err("the model was rejected without a diagnostic".into());
    }
    let lines = yaml_lines(&input.text);
    for d in &diagnostics.0 {
        if d.file != INPUT_NAME {
            return Err(format!("diagnostic names file `{}`, not `{INPUT_NAME}`: {d}", d.file));
        }
        if d.message.trim().is_empty() {
            return Err(format!("diagnostic without a message at {}:{}", d.line, d.column));
        }
        if d.line == lines.len() + 1 && d.column == 1 && !lines.is_empty() {
            return Err(format!(
                "diagnostic one line past the end of a file without a final line break: {d}"
            ));
        }
        if !position_within_lines(&lines, d.line, d.column) {
            return Err(format!("diagnostic outside the file ({} lines): {d}", lines.len()));
        }
    }
    Ok(Outcome::Rejected)
}

/// The lines of `text` as YAML counts them: a line break is `\r\n`, `\n` or a lone `\r`,
/// and libyaml also breaks at U+0085, U+2028 and U+2029 (editors do too). The text after the
/// last break is a line of its own (possibly empty: the end of input).
pub fn yaml_lines(text: &str) -> Vec<&str> {
    let mut lines = Vec::new();
    let mut start = 0;
    let mut chars = text.char_indices().peekable();
    while let Some((i, c)) = chars.next() {
        let end = match c {
            '\r' => {
                if let Some((_, '\n')) = chars.peek() {
                    chars.next();
                    i + 2
                } else {
                    i + 1
                }
            }
            '\n' | '\u{85}' | '\u{2028}' | '\u{2029}' => i + c.len_utf8(),
            _ => continue,
        };
        lines.push(&text[start..i]);
        start = end;
    }
    lines.push(&text[start..]);
    lines
}

/// `true` when (`line`, `column`), both 1-based, lie in `text`: an existing line (the empty
/// line after a final newline counts, since parsers report the end of input there) and a
/// column at most one past the line's last character (counted in bytes or characters,
/// whichever is larger: parsers differ).
pub fn position_within(text: &str, line: usize, column: usize) -> bool {
    position_within_lines(&yaml_lines(text), line, column)
}

/// [`position_within`] for a text already split by [`yaml_lines`].
pub fn position_within_lines(lines: &[&str], line: usize, column: usize) -> bool {
    if line == 0 || column == 0 {
        return false;
    }
    match lines.get(line - 1) {
        Some(content) => column <= content.len().max(content.chars().count()) + 1,
        None => false,
    }
}

/// What the runner observed for one input.
#[derive(Clone, Debug)]
pub enum Verdict {
    /// The invariant held.
    Ok(Outcome, Duration),
    /// The generator panicked (message).
    Panic(String),
    /// The invariant was broken (description).
    Violation(String),
    /// The input ended (with this outcome) but took longer than the limit, in CPU time.
    Slow(Outcome, Duration),
    /// No answer within ten times the limit of wall time: the worker is still busy.
    Hang(Duration),
}

/// What the worker answers for one input: the check's result (or the panic's message) and
/// the input's CPU time.
type Answer = (Result<Result<Outcome, String>, String>, Duration);
type Job = (Vec<Input>, Sender<Vec<Answer>>);

/// CPU time of the calling thread (wall time where the platform has no thread clock):
/// the machine is shared, so a wall-clock limit would flag inputs that merely waited.
pub fn thread_cpu_time() -> Duration {
    #[cfg(unix)]
    {
        let mut ts = libc::timespec { tv_sec: 0, tv_nsec: 0 };
        // SAFETY: `clock_gettime` writes one `timespec` through a valid pointer.
        if unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) } == 0 {
            return Duration::new(ts.tv_sec as u64, ts.tv_nsec as u32);
        }
    }
    static START: std::sync::OnceLock<Instant> = std::sync::OnceLock::new();
    START.get_or_init(Instant::now).elapsed()
}

/// Runs inputs on a worker thread with a bounded stack, catching panics and measuring each
/// input's CPU time against a time limit. Inputs go to the worker one at a time or in
/// batches (the loader takes tens of microseconds per input, so a round trip between threads
/// per input would cost as much as the input itself). A batch that does not finish within
/// ten times the limit of wall time (a real hang, or a machine too busy to tell) is a hang.
pub struct Runner {
    jobs: Option<Sender<Job>>,
    timeout: Duration,
}

fn answer(input: &Input) -> Answer {
    let start = thread_cpu_time();
    let result = catch_unwind(AssertUnwindSafe(|| check(input))).map_err(|payload| {
        payload
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| payload.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "non-string panic payload".into())
    });
    (result, thread_cpu_time().saturating_sub(start))
}

impl Runner {
    /// A runner whose worker has `stack_bytes` of stack; inputs slower than `timeout` hang.
    pub fn new(stack_bytes: usize, timeout: Duration) -> std::io::Result<Runner> {
        let (jobs, receiver): (Sender<Job>, Receiver<Job>) = mpsc::channel();
        std::thread::Builder::new().name("fuzz-worker".into()).stack_size(stack_bytes).spawn(move || {
            for (inputs, reply) in receiver {
                let mut answers = Vec::with_capacity(inputs.len());
                for input in &inputs {
                    let answer = answer(input);
                    let failed = !matches!(answer.0, Ok(Ok(_)));
                    answers.push(answer);
                    if failed {
                        break;
                    }
                }
                let _ = reply.send(answers);
            }
        })?;
        Ok(Runner { jobs: Some(jobs), timeout })
    }

    /// Runs one input. After a [`Verdict::Hang`] the worker is still busy: the runner is
    /// unusable and the caller should stop.
    pub fn run(&mut self, input: Input) -> Verdict {
        self.run_batch(vec![input])
            .pop()
            .unwrap_or_else(|| Verdict::Violation("the worker answered nothing".into()))
    }

    /// Runs a batch of inputs in order, up to and including the first that fails (a panic or
    /// a broken invariant): one verdict per input run, so a failing input is the last one.
    /// A hang is one [`Verdict::Hang`] for the whole batch, after which the runner is
    /// unusable.
    pub fn run_batch(&mut self, inputs: Vec<Input>) -> Vec<Verdict> {
        let pending = self.submit(inputs);
        self.collect(pending)
    }

    /// Hands a batch to the worker and returns at once, so that the caller can draw the next
    /// batch while this one runs (the fuzzer then keeps both cores busy); [`Runner::collect`]
    /// waits for its verdicts.
    pub fn submit(&mut self, inputs: Vec<Input>) -> PendingBatch {
        let Some(jobs) = &self.jobs else { return PendingBatch(None) };
        let (reply, answers) = mpsc::channel();
        if jobs.send((inputs, reply)).is_err() {
            return PendingBatch(None);
        }
        PendingBatch(Some(answers))
    }

    /// The verdicts of a submitted batch, as [`Runner::run_batch`] describes them. The time
    /// limit for the whole batch runs from this call.
    pub fn collect(&mut self, pending: PendingBatch) -> Vec<Verdict> {
        let Some(answers) = pending.0 else {
            return vec![Verdict::Violation("the runner's worker is gone".into())];
        };
        match answers.recv_timeout(self.timeout * 10) {
            Ok(answers) => answers
                .into_iter()
                .map(|answer| match answer {
                    (Ok(Ok(outcome)), elapsed) if elapsed > self.timeout => Verdict::Slow(outcome, elapsed),
                    (Ok(Ok(outcome)), elapsed) => Verdict::Ok(outcome, elapsed),
                    (Ok(Err(violation)), _) => Verdict::Violation(violation),
                    (Err(message), _) => Verdict::Panic(message),
                })
                .collect(),
            Err(RecvTimeoutError::Timeout) => {
                self.jobs = None;
                vec![Verdict::Hang(self.timeout * 10)]
            }
            Err(RecvTimeoutError::Disconnected) => vec![Verdict::Violation("the worker died".into())],
        }
    }
}

/// A batch the worker is running ([`Runner::submit`]); `None` when it could not be handed over.
pub struct PendingBatch(Option<Receiver<Vec<Answer>>>);

/// The seed corpus: every `*.yaml` file under `dirs` (deduplicated by content, sorted by
/// path for reproducibility).
pub fn load_corpus(dirs: &[PathBuf]) -> Vec<(PathBuf, Vec<u8>)> {
    let mut files: Vec<(PathBuf, Vec<u8>)> = Vec::new();
    for dir in dirs {
        let Ok(entries) = std::fs::read_dir(dir) else { continue };
        for entry in entries.flatten() {
            let path = entry.path();
            if path.extension().is_some_and(|e| e == "yaml") {
                if let Ok(bytes) = std::fs::read(&path) {
                    files.push((path, bytes));
                }
            }
        }
    }
    files.sort_by(|a, b| a.0.cmp(&b.0));
    let mut seen = std::collections::HashSet::new();
    files.retain(|(_, bytes)| seen.insert(bytes.clone()));
    files
}

/// One seed in this many also enters the mutator's pool as written, comments, blank lines and
/// descriptions included, so that the scanner's comment handling stays fuzzed; every seed
/// enters it compacted ([`compact_seed`]).
pub const SEEDS_KEPT_AS_WRITTEN: usize = 8;

/// The mutator's seed pool: every seed of `corpus` compacted ([`compact_seed`]) and one in
/// [`SEEDS_KEPT_AS_WRITTEN`] also as written. The loader's time per input grows with the
/// input's size, and comments and descriptions (a third of the seeds' bytes) exercise
/// nothing past the YAML scanner.
pub fn seed_pool(corpus: &[(PathBuf, Vec<u8>)]) -> Vec<(PathBuf, Vec<u8>)> {
    let mut pool = Vec::with_capacity(corpus.len() + corpus.len() / SEEDS_KEPT_AS_WRITTEN + 1);
    for (i, (path, bytes)) in corpus.iter().enumerate() {
        let compact = compact_seed(bytes);
        if i % SEEDS_KEPT_AS_WRITTEN == 0 && compact != *bytes {
            pool.push((path.clone(), bytes.clone()));
        }
        pool.push((path.clone(), compact));
    }
    pool
}

/// A seed without what only the YAML scanner reads: blank lines, comment lines, trailing
/// comments (on lines without quotes, where ` #` cannot be inside a string), and
/// `description:` entries on a line of their own with a sibling on the line before or after
/// (not the first entry of a sequence item, whose removal would join the item to the
/// previous one, nor a mapping's only entry, nor one continued on the next lines). Line by line on the bytes: no YAML parser (a seed that is not YAML stays a seed).
pub fn compact_seed(seed: &[u8]) -> Vec<u8> {
    let indent = |line: &[u8]| line.iter().take_while(|&&b| b == b' ').count();
    let blank_or_comment = |line: &[u8]| {
        let rest = &line[indent(line)..];
        rest.iter().all(|b| b.is_ascii_whitespace()) || rest.first() == Some(&b'#')
    };
    let lines: Vec<&[u8]> = seed.split(|&b| b == b'\n').filter(|line| !blank_or_comment(line)).collect();
    let mut out = Vec::with_capacity(seed.len());
    for (i, line) in lines.iter().enumerate() {
        let depth = indent(line);
        let next = lines.get(i + 1).map(|next| indent(next));
        let previous = i.checked_sub(1).map(|p| indent(lines[p]));
        if line[depth..].starts_with(b"description:")
            && next.is_none_or(|n| n <= depth)
            && (next == Some(depth) || previous == Some(depth))
        {
            continue;
        }
        let mut line: &[u8] = line;
        if !line.iter().any(|&b| b == b'"' || b == b'\'') {
            if let Some(hash) = line.windows(2).position(|w| (w[0] == b' ' || w[0] == b'\t') && w[1] == b'#')
            {
                line = line[..hash].trim_ascii_end();
            }
        }
        out.extend_from_slice(line);
        out.push(b'\n');
    }
    // A seed without a final line break stays without one.
    if !seed.ends_with(b"\n") {
        out.pop();
    }
    out
}

/// The corpus directories of a workspace: the committed seeds and the repository's models.
pub fn corpus_dirs(workspace: &Path) -> Vec<PathBuf> {
    [
        "fuzz/corpus",
        "models",
        "codegen/tests/bad-models",
        "codegen/tests/good-models",
        "codegen/tests/closed-chains",
        "tests/ui/models",
    ]
    .iter()
    .map(|d| workspace.join(d))
    .collect()
}

/// Findings that are known and reported, with their fix, in `docs/reliability.md`: a
/// finding whose message contains one of these texts is counted, printed and saved, but does
/// not fail the run. Remove an entry when its fix lands.
pub const KNOWN_FINDINGS: [(&str, &str); 0] = [];

/// The known finding a message matches, if any.
pub fn known_finding(message: &str) -> Option<&'static str> {
    KNOWN_FINDINGS.iter().find(|(pattern, _)| message.contains(pattern)).map(|(_, why)| *why)
}

/// Silences the default panic message of the fuzz worker (panics are reported as verdicts),
/// unless `HAPTICGEN_FUZZ_VERBOSE` is set (then the message and, with `RUST_BACKTRACE=1`,
/// the backtrace of each panic are printed).
pub fn quiet_worker_panics() {
    if std::env::var_os("HAPTICGEN_FUZZ_VERBOSE").is_some() {
        return;
    }
    let default = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        if std::thread::current().name() != Some("fuzz-worker") {
            default(info);
        }
    }));
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Compacting a seed removes only what no stage looks at: every seed that parses parses
    /// to the same document, descriptions aside, and the pool is smaller than the corpus.
    #[test]
    fn compacted_seeds_are_the_same_documents() {
        fn without_descriptions(value: &mut serde_yaml::Value) {
            match value {
                serde_yaml::Value::Mapping(map) => {
                    map.remove("description");
                    map.values_mut().for_each(without_descriptions);
                }
                serde_yaml::Value::Sequence(items) => items.iter_mut().for_each(without_descriptions),
                _ => {}
            }
        }
        let parse = |bytes: &[u8]| {
            let mut value: serde_yaml::Value = serde_yaml::from_slice(bytes).ok()?;
            without_descriptions(&mut value);
            Some(value)
        };
        let workspace = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
        let corpus = load_corpus(&corpus_dirs(&workspace));
        let (mut compared, mut before, mut after) = (0, 0, 0);
        for (path, seed) in &corpus {
            let compact = compact_seed(seed);
            before += seed.len();
            after += compact.len();
            if let Some(original) = parse(seed) {
                assert_eq!(parse(&compact).as_ref(), Some(&original), "{}", path.display());
                compared += 1;
            }
        }
        assert!(compared * 2 > corpus.len(), "only {compared} of {} seeds parse", corpus.len());
        assert!(after * 10 < before * 7, "compacted seeds are {after} bytes of {before}");
        let pool = seed_pool(&corpus);
        assert!(pool.len() > corpus.len() && pool.len() < corpus.len() * 5 / 4, "{} seeds", pool.len());
    }

    #[test]
    fn positions_are_checked_against_the_text() {
        let text = "a: 1\nbb: ü\n";
        assert!(position_within(text, 1, 1));
        assert!(position_within(text, 1, 5));
        assert!(!position_within(text, 1, 6));
        assert!(position_within(text, 2, 6)); // "bb: ü" is 5 characters, 6 bytes
        assert!(position_within(text, 3, 1)); // end of input after the final newline
        assert!(!position_within(text, 3, 2));
        assert!(!position_within(text, 4, 1));
        assert!(!position_within(text, 0, 1));
        assert!(!position_within(text, 1, 0));
        assert!(position_within("a\rb\r\nc", 3, 2)); // lone CR and CRLF are line breaks
        assert!(!position_within("a\rb\r\nc", 4, 1));
    }

    #[test]
    fn runner_reports_outcomes_and_panics_are_caught() {
        let mut runner = Runner::new(8 << 20, Duration::from_secs(30)).unwrap();
        let good =
            std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../models/joystick_1dof.yaml"))
                .unwrap();
        let verdict = runner.run(Input {
            text: good,
            variant: None,
            scalar: Scalar::F64,
            fused_multiply_add: false,
            stage: Stage::Generator,
        });
        assert!(matches!(verdict, Verdict::Ok(Outcome::Generated, _)), "{verdict:?}");
        let bad = Input {
            text: "name: [\n".into(),
            variant: None,
            scalar: Scalar::F32,
            fused_multiply_add: true,
            stage: Stage::Generator,
        };
        assert!(matches!(runner.run(bad), Verdict::Ok(Outcome::Rejected, _)));
        // Without the final newline the parsers point past the last line; the loader clamps.
        let unterminated = Input {
            text: "name: [".into(),
            variant: None,
            scalar: Scalar::F32,
            fused_multiply_add: false,
            stage: Stage::Generator,
        };
        assert!(matches!(runner.run(unterminated), Verdict::Ok(Outcome::Rejected, _)));
    }

    #[test]
    fn a_batch_runs_every_input_in_order_and_the_loader_stage_only_loads() {
        let mut runner = Runner::new(8 << 20, Duration::from_secs(30)).unwrap();
        let good =
            std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../models/joystick_1dof.yaml"))
                .unwrap();
        let input = |text: &str| Input {
            text: text.to_string(),
            variant: None,
            scalar: Scalar::F64,
            fused_multiply_add: false,
            stage: Stage::Loader,
        };
        let verdicts = runner.run_batch(vec![input(&good), input("name: [\n"), input(&good)]);
        let outcomes: Vec<Option<Outcome>> =
            verdicts.iter().map(|v| if let Verdict::Ok(o, _) = v { Some(*o) } else { None }).collect();
        assert_eq!(outcomes, [Some(Outcome::Generated), Some(Outcome::Rejected), Some(Outcome::Generated)]);
    }

    #[test]
    fn fixed_findings_stay_fixed() {
        let mut runner = Runner::new(8 << 20, Duration::from_secs(30)).unwrap();
        let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/findings");
        for (file, scalar) in [
            ("constant-singular-jacobian-nan-literal.yaml", Scalar::F64),
            ("f32-overflow-inf-literal.yaml", Scalar::F32),
            ("eof-past-last-line.yaml", Scalar::F64),
            ("slow-4-joint-spatial.yaml", Scalar::F64),
            ("slow-deep-flow-nesting.yaml", Scalar::F64),
        ] {
            let text = std::fs::read_to_string(format!("{dir}/{file}")).unwrap();
            let verdict = runner.run(Input {
                text,
                variant: None,
                scalar,
                fused_multiply_add: true,
                stage: Stage::Generator,
            });
            assert!(matches!(verdict, Verdict::Ok(..)), "{file}: {verdict:?}");
        }
    }
}
