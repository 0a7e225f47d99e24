//! The architecture, checked so that it cannot erode: every dependency between codegen's
//! source files points one way (no import cycles; the same for the protocol's), each of the
//! generator's layers uses only the layers below it, every path ARCHITECTURE.md names exists,
//! the maps (ARCHITECTURE.md, the README's layout) name every
//! workspace member, CLI command and runtime module the code has, and the README's firmware
//! figures are the ones its sources (docs/firmware.md and the pages it links) state.
//!
//! A file depends on another when its code (comments aside) names a path into it: `crate::…`,
//! `super::…`, or, in a module's own file, one of its child modules (`use closure::…`).

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn source_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("src")
}

/// Every `.rs` file under `dir`, as paths relative to `root` (a crate's `src/`) with `/`
/// separators.
fn rust_files(root: &Path, dir: &Path, out: &mut Vec<String>) {
    let mut entries: Vec<_> = std::fs::read_dir(dir).expect("readable source dir").flatten().collect();
    entries.sort_by_key(|e| e.path());
    for entry in entries {
        let path = entry.path();
        if path.is_dir() {
            rust_files(root, &path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            let relative = path.strip_prefix(root).expect("under src").to_string_lossy().replace('\\', "/");
            out.push(relative);
        }
    }
}

/// The directory a file's child modules live in: `a/mod.rs` → `a`, `a/b.rs` → `a/b`, `lib.rs` → ``.
fn module_dir(file: &str) -> String {
    if file == "lib.rs" {
        String::new()
    } else if let Some(dir) = file.strip_suffix("/mod.rs") {
        dir.to_string()
    } else {
        file.trim_end_matches(".rs").to_string()
    }
}

/// The file a module path lands in, walking from the module directory `start`: the deepest
/// segment that is a module file (the rest are items inside it).
fn resolve(start: &str, segments: &[&str], files: &BTreeSet<String>) -> Option<String> {
    let mut dir = start.to_string();
    let mut found = None;
    for segment in segments {
        let join = |name: &str| if dir.is_empty() { name.to_string() } else { format!("{dir}/{name}") };
        let (flat, nested) = (join(&format!("{segment}.rs")), join(&format!("{segment}/mod.rs")));
        if files.contains(&flat) {
            found = Some(flat);
        } else if files.contains(&nested) {
            found = Some(nested);
        } else {
            break;
        }
        dir = join(segment);
    }
    found
}

/// The code of a line without its comment.
fn code(line: &str) -> &str {
    match line.find("//") {
        Some(i) => &line[..i],
        None => line,
    }
}

fn identifier_run(text: &str) -> Vec<&str> {
    // `a::b::{c, d}` → [a, b]; stops at the first non-identifier segment.
    let mut segments = Vec::new();
    for part in text.split("::") {
        let name: &str =
            &part[..part.find(|c: char| !(c.is_alphanumeric() || c == '_')).unwrap_or(part.len())];
        if name.is_empty() {
            break;
        }
        segments.push(name);
        if name.len() != part.len() {
            break;
        }
    }
    segments
}

/// File → the files it depends on, for codegen's sources.
fn dependency_graph() -> BTreeMap<String, BTreeSet<String>> {
    crate_dependency_graph(&source_root())
}

/// The items `lib.rs` re-exports (`pub use frame::{encode, Received};`), each with the file
/// that defines it: `crate::Received` is a path into `frame.rs`, not into `lib.rs`.
fn reexports(root: &Path, files: &BTreeSet<String>) -> BTreeMap<String, String> {
    let lib = std::fs::read_to_string(root.join("lib.rs")).unwrap_or_default();
    let lib: String = lib.lines().map(code).collect::<Vec<_>>().join(" ");
    let mut items = BTreeMap::new();
    for statement in lib.split("pub use ").skip(1) {
        let statement = &statement[..statement.find(';').unwrap_or(statement.len())];
        let (path, names) = match statement.find("::{") {
            Some(i) => (&statement[..i], statement[i + 3..].trim_end().trim_end_matches('}')),
            None => statement.rsplit_once("::").unwrap_or(("", statement)),
        };
        let segments: Vec<&str> = path.split("::").map(str::trim).collect();
        if let Some(file) = resolve("", &segments, files) {
            for name in names.split(',').map(str::trim).filter(|n| !n.is_empty()) {
                items.insert(name.to_string(), file.clone());
            }
        }
    }
    items
}

/// File → the files it depends on, for the crate whose sources are under `root`.
fn crate_dependency_graph(root: &Path) -> BTreeMap<String, BTreeSet<String>> {
    let mut list = Vec::new();
    rust_files(root, root, &mut list);
    let files: BTreeSet<String> = list.iter().cloned().collect();
    let reexported = reexports(root, &files);
    let mut graph = BTreeMap::new();
    for file in &list {
        let text = std::fs::read_to_string(root.join(file)).expect("readable source");
        let own_dir = module_dir(file);
        let parent_dir = match own_dir.rfind('/') {
            Some(i) => own_dir[..i].to_string(),
            None => String::new(),
        };
        let mut edges = BTreeSet::new();
        // Inside an inline module (`mod tests { use super::*; }`, at the end of a file),
        // `super::` is the file itself.
        let mut inline_module = false;
        for line in text.lines().map(code) {
            let trimmed = line.trim_start();
            if trimmed.starts_with("mod ") && trimmed.trim_end().ends_with('{') {
                inline_module = true;
            }
            for (prefix, start) in [("crate::", String::new()), ("super::", parent_dir.clone())] {
                if inline_module && prefix == "super::" {
                    continue;
                }
                let mut rest = line;
                while let Some(i) = rest.find(prefix) {
                    let before = rest[..i].chars().last();
                    let after = &rest[i + prefix.len()..];
                    rest = after;
                    if before.is_some_and(|c| c.is_alphanumeric() || c == '_') {
                        continue;
                    }
                    // `use crate::{a, b::c}`: each member of the group.
                    let groups: Vec<&str> = match after.strip_prefix('{') {
                        Some(group) => group[..group.find('}').unwrap_or(group.len())].split(',').collect(),
                        None => vec![after],
                    };
                    for member in groups {
                        let segments = identifier_run(member.trim());
                        let target = resolve(&start, &segments, &files).unwrap_or_else(|| {
                            // An item of the module file itself (`crate::Item`, `super::Item`),
                            // or one `lib.rs` re-exports from the file that defines it.
                            if let Some(file) = segments.first().and_then(|s| reexported.get(*s)) {
                                if start.is_empty() {
                                    return file.clone();
                                }
                            }
                            if start.is_empty() {
                                "lib.rs".to_string()
                            } else {
                                format!("{start}/mod.rs")
                            }
                        });
                        if &target != file {
                            edges.insert(target);
                        }
                    }
                }
            }
            // A module's file using its own child modules by their plain names.
            if let Some(path) = trimmed.strip_prefix("pub use ").or_else(|| trimmed.strip_prefix("use ")) {
                let segments = identifier_run(path);
                if let Some(first) =
                    segments.first().filter(|s| !["crate", "super", "self", "std"].contains(s))
                {
                    if let Some(target) = resolve(&own_dir, &[first], &files) {
                        edges.insert(target);
                    }
                }
            }
        }
        graph.insert(file.clone(), edges);
    }
    graph
}

/// A cycle of the graph, if there is one.
fn find_cycle(graph: &BTreeMap<String, BTreeSet<String>>) -> Option<Vec<String>> {
    fn visit(
        node: &str,
        graph: &BTreeMap<String, BTreeSet<String>>,
        state: &mut BTreeMap<String, u8>,
        stack: &mut Vec<String>,
    ) -> Option<Vec<String>> {
        state.insert(node.to_string(), 1);
        stack.push(node.to_string());
        for next in graph.get(node).into_iter().flatten() {
            match state.get(next.as_str()).copied().unwrap_or(0) {
                1 => {
                    let from = stack.iter().position(|n| n == next).unwrap_or(0);
                    let mut cycle = stack[from..].to_vec();
                    cycle.push(next.clone());
                    return Some(cycle);
                }
                0 => {
                    if let Some(cycle) = visit(next, graph, state, stack) {
                        return Some(cycle);
                    }
                }
                _ => {}
            }
        }
        stack.pop();
        state.insert(node.to_string(), 2);
        None
    }
    let mut state = BTreeMap::new();
    for node in graph.keys() {
        if state.get(node).copied().unwrap_or(0) == 0 {
            if let Some(cycle) = visit(node, graph, &mut state, &mut Vec::new()) {
                return Some(cycle);
            }
        }
    }
    None
}

/// The layer of a file, lowest first: a file may use its own layer and those below.
fn layer(file: &str) -> usize {
    const LAYERS: &[&[&str]] = &[
        &["diag", "math", "version"],
        &["sym"],
        &["model"],
        &["dynamics"],
        &["eval"],
        &["check"],
        &["plan"],
        &["emit"],
        &["urdf"],
        &["build", "mesh", "rig_macro", "scene", "lib"],
    ];
    let top = file.split('/').next().unwrap_or(file).trim_end_matches(".rs");
    LAYERS.iter().position(|names| names.contains(&top)).unwrap_or_else(|| {
        panic!("`{file}` belongs to no layer: add its top-level module to LAYERS and ARCHITECTURE.md")
    })
}

#[test]
fn codegen_modules_import_no_cycle() {
    let graph = dependency_graph();
    assert!(graph.len() > 30, "only {} source files found: the scan is broken", graph.len());
    let edges: usize = graph.values().map(BTreeSet::len).sum();
    assert!(edges > 60, "only {edges} dependencies found: the scan is broken");
    if let Some(cycle) = find_cycle(&graph) {
        panic!("import cycle among codegen's files: {}", cycle.join(" → "));
    }
}

#[test]
fn protocol_modules_import_no_cycle() {
    // The framing knows nothing of the messages it carries: `message` uses `frame`, never the
    // other way round.
    let graph = crate_dependency_graph(&repo_root().join("protocol/src"));
    assert!(graph.len() >= 3, "only {} source files found in protocol: the scan is broken", graph.len());
    let edge = |from: &str, to: &str| graph.get(from).is_some_and(|targets| targets.contains(to));
    assert!(edge("message.rs", "frame.rs"), "the scan misses message.rs's use of frame.rs: {graph:?}");
    if let Some(cycle) = find_cycle(&graph) {
        panic!("import cycle among protocol's files: {}", cycle.join(" → "));
    }
}

#[test]
fn codegen_layers_depend_only_downwards() {
    let graph = dependency_graph();
    let mut violations = Vec::new();
    for (file, targets) in &graph {
        for target in targets {
            if layer(target) > layer(file) {
                violations.push(format!("{file} → {target}"));
            }
        }
    }
    assert!(violations.is_empty(), "dependencies pointing up the layers:\n{}", violations.join("\n"));
}

#[test]
fn the_scan_sees_a_planted_cycle() {
    // The detector itself: a two-file cycle and a clean chain.
    let mut graph = BTreeMap::new();
    graph.insert("a.rs".to_string(), BTreeSet::from(["b.rs".to_string()]));
    graph.insert("b.rs".to_string(), BTreeSet::from(["c.rs".to_string()]));
    graph.insert("c.rs".to_string(), BTreeSet::new());
    assert_eq!(find_cycle(&graph), None);
    graph.get_mut("c.rs").unwrap().insert("a.rs".to_string());
    assert_eq!(find_cycle(&graph).map(|c| c.len()), Some(4));
    // And the resolver: a path into a nested module lands in its file.
    let files: BTreeSet<String> =
        ["dynamics/mod.rs", "dynamics/closure.rs", "lib.rs"].iter().map(|s| s.to_string()).collect();
    assert_eq!(resolve("", &["dynamics", "closure", "Loop"], &files).as_deref(), Some("dynamics/closure.rs"));
    assert_eq!(resolve("", &["dynamics", "derive"], &files).as_deref(), Some("dynamics/mod.rs"));
}

#[test]
fn every_path_architecture_md_names_exists() {
    let text =
        std::fs::read_to_string(repo_root().join("ARCHITECTURE.md")).expect("ARCHITECTURE.md at the root");
    let mut named = 0;
    let mut missing = Vec::new();
    // Paths are written in backticks: `codegen/src/dynamics/`, `runtime/src/tick.rs`.
    for (i, chunk) in text.split('`').enumerate() {
        if i % 2 == 0
            || !chunk.contains('/')
            || chunk.contains(' ')
            || chunk.contains("::")
            || chunk.contains('<')
        {
            continue;
        }
        let looks_like_path = chunk.ends_with('/')
            || [".rs", ".md", ".yaml", ".sh", ".toml", ".txt", ".json"].iter().any(|e| chunk.ends_with(e));
        if !looks_like_path {
            continue;
        }
        named += 1;
        if !repo_root().join(chunk).exists() {
            missing.push(chunk.to_string());
        }
    }
    assert!(named >= 30, "ARCHITECTURE.md names only {named} paths: the scan is broken");
    assert!(missing.is_empty(), "ARCHITECTURE.md names paths that do not exist: {missing:?}");
}

/// The workspace's members, from the root `Cargo.toml`'s `members = [...]`.
fn workspace_members() -> Vec<String> {
    let manifest = std::fs::read_to_string(repo_root().join("Cargo.toml")).unwrap();
    let start = manifest.find("members = [").expect("a members list") + "members = [".len();
    let end = start + manifest[start..].find(']').unwrap();
    manifest[start..end]
        .split(',')
        .map(|m| m.trim().trim_matches('"').to_string())
        .filter(|m| !m.is_empty())
        .collect()
}

/// The CLI's commands as a user types them: the variants of `enum Command` in the host's
/// `cli/args.rs` (the command line's grammar), in clap's kebab case (`ImportUrdf` →
/// `import-urdf`).
fn cli_commands() -> Vec<String> {
    let args = std::fs::read_to_string(repo_root().join("targets/host/src/cli/args.rs")).unwrap();
    let start = args.find("pub enum Command {").expect("the CLI's Command enum");
    let body = &args[start..start + args[start..].find("\n}").unwrap()];
    body.lines()
        .filter_map(|line| {
            // A variant starts at the enum's indentation: `    Name {`, `    Name(…)`, `    Name,`.
            let name = line.strip_prefix("    ")?;
            let end = name.find(|c: char| !c.is_ascii_alphanumeric())?;
            let name = &name[..end];
            name.starts_with(|c: char| c.is_ascii_uppercase()).then(|| {
                let mut kebab = String::new();
                for (i, c) in name.chars().enumerate() {
                    if c.is_ascii_uppercase() && i > 0 {
                        kebab.push('-');
                    }
                    kebab.push(c.to_ascii_lowercase());
                }
                kebab
            })
        })
        .collect()
}

/// The runtime's modules, from the `mod` lines of its `lib.rs` (`mod x;`, `pub mod x;`,
/// `pub(crate) mod x;`).
fn runtime_modules() -> Vec<String> {
    let lib = std::fs::read_to_string(repo_root().join("runtime/src/lib.rs")).unwrap();
    lib.lines()
        .filter_map(|line| {
            let line = code(line).trim();
            let rest = line.strip_prefix("pub ").or_else(|| line.strip_prefix("pub(crate) ")).unwrap_or(line);
            rest.strip_prefix("mod ")?.strip_suffix(';').map(|name| name.trim().to_string())
        })
        .collect()
}

/// The part of `text` from the line that starts with `start` to the next line that starts
/// with `next` (or the end), or an empty string when no line starts with `start`.
fn part<'t>(text: &'t str, start: &str, next: &str) -> &'t str {
    let Some(from) = text.find(&format!("\n{start}")).map(|i| i + 1) else {
        return "";
    };
    let after = from + start.len();
    let to = text[after..].find(&format!("\n{next}")).map_or(text.len(), |i| after + i);
    &text[from..to]
}

/// A map's parts: where it lists the crates, where it describes the host (which names every
/// command) and where it describes the runtime (which names every module).
struct Map<'t> {
    crates: &'t str,
    host: &'t str,
    runtime: &'t str,
}

impl<'t> Map<'t> {
    /// ARCHITECTURE.md: a bullet per crate under "## Crates" (`` - `runtime/` … ``); the host's
    /// bullet names each command in backticks, the runtime's each module's file.
    fn architecture(text: &'t str) -> Self {
        let crates = part(text, "## Crates", "## ");
        Map {
            crates,
            host: part(crates, "- `targets/host/`", "- `"),
            runtime: part(crates, "- `runtime/`", "- `"),
        }
    }

    /// The README: a row per crate in the table under "## Layout" (`` | `runtime/` | … ``);
    /// the host's row names each command in backticks, the runtime's row each module.
    fn readme(text: &'t str) -> Self {
        let crates = part(text, "## Layout", "## ");
        Map {
            crates,
            host: part(crates, "| `targets/host/`", "| `"),
            runtime: part(crates, "| `runtime/`", "| `"),
        }
    }
}

/// What `map` leaves out, each as the text it lacks: a crate's bullet or row (`` - `protocol/` ``
/// or `` | `protocol/` ``), a command in the host's part (`` `zwidth` ``), a runtime module in
/// the runtime's part (`` `runtime/src/tick.rs` `` in ARCHITECTURE.md, `` `tick` `` in the README).
fn omissions(
    map: &Map,
    crate_entry: &str,
    module_entry: fn(&str) -> String,
    (crates, commands, modules): (&[String], &[String], &[String]),
) -> Vec<String> {
    let mut missing = Vec::new();
    for name in crates {
        let needle = format!("{crate_entry}`{name}/`");
        if !map.crates.contains(&needle) {
            missing.push(format!("crate {needle}"));
        }
    }
    for name in commands {
        let needle = format!("`{name}`");
        if !map.host.contains(&needle) {
            missing.push(format!("command {needle}"));
        }
    }
    for name in modules {
        let needle = module_entry(name);
        if !map.runtime.contains(&needle) {
            missing.push(format!("runtime module {needle}"));
        }
    }
    missing
}

fn architecture_omissions(text: &str, code: (&[String], &[String], &[String])) -> Vec<String> {
    omissions(&Map::architecture(text), "- ", |m| format!("`runtime/src/{m}.rs`"), code)
}

fn readme_omissions(text: &str, code: (&[String], &[String], &[String])) -> Vec<String> {
    omissions(&Map::readme(text), "| ", |m| format!("`{m}`"), code)
}

#[test]
fn the_maps_name_every_crate_command_and_runtime_module() {
    let (crates, commands, modules) = (workspace_members(), cli_commands(), runtime_modules());
    assert!(crates.len() >= 7 && crates.contains(&"protocol".to_string()), "{crates:?}");
    assert!(commands.len() >= 15 && commands.contains(&"import-urdf".to_string()), "{commands:?}");
    assert!(modules.len() >= 18 && modules.contains(&"tick".to_string()), "{modules:?}");
    let code = (&crates[..], &commands[..], &modules[..]);
    let architecture = std::fs::read_to_string(repo_root().join("ARCHITECTURE.md")).unwrap();
    let readme = std::fs::read_to_string(repo_root().join("README.md")).unwrap();
    let mut problems = Vec::new();
    for missing in architecture_omissions(&architecture, code) {
        problems.push(format!("ARCHITECTURE.md (## Crates) does not name the {missing}"));
    }
    for missing in readme_omissions(&readme, code) {
        problems.push(format!("README.md (## Layout) does not name the {missing}"));
    }
    assert!(problems.is_empty(), "the maps leave out what the code has:\n{}", problems.join("\n"));
}

#[test]
fn the_map_check_sees_a_planted_omission() {
    let (crates, commands, modules) = (workspace_members(), cli_commands(), runtime_modules());
    let code = (&crates[..], &commands[..], &modules[..]);
    let architecture = std::fs::read_to_string(repo_root().join("ARCHITECTURE.md")).unwrap();
    for (planted, reported) in [
        ("- `protocol/`", "crate - `protocol/`"),
        ("`zwidth`", "command `zwidth`"),
        ("`runtime/src/tick.rs`", "runtime module `runtime/src/tick.rs`"),
    ] {
        let without = architecture.replace(planted, "(left out)");
        assert_eq!(architecture_omissions(&without, code), vec![reported.to_string()], "{planted}");
    }
    let readme = std::fs::read_to_string(repo_root().join("README.md")).unwrap();
    for (planted, reported) in [
        ("| `fuzz/`", "crate | `fuzz/`"),
        ("`import-urdf`", "command `import-urdf`"),
        ("`schedule`", "runtime module `schedule`"),
    ] {
        let without = readme.replace(planted, "(left out)");
        assert_eq!(readme_omissions(&without, code), vec![reported.to_string()], "{planted}");
    }
}

/// A section of a Markdown file: from its `## title` line to the next `## ` heading.
fn section<'t>(text: &'t str, title: &str) -> &'t str {
    let section = part(text, &format!("## {title}\n"), "## ");
    assert!(!section.is_empty(), "no section `## {title}`");
    section
}

/// The rows of the first Markdown table in `text` whose header starts with `header`: each
/// row's cells, trimmed.
fn table_rows(text: &str, header: &str) -> Vec<Vec<String>> {
    let start = text.find(&format!("\n{header}")).unwrap_or_else(|| panic!("no table `{header}`")) + 1;
    text[start..]
        .lines()
        .skip(2) // The header and its `| --- |` line.
        .take_while(|line| line.starts_with('|'))
        .map(|line| line.trim_matches('|').split(" | ").map(|cell| cell.trim().to_string()).collect())
        .collect()
}

/// The images of `targets/firmware/variants.txt`: name → its limits (impedance and current
/// tick instructions, flash and RAM bytes).
fn firmware_variants() -> BTreeMap<String, [u64; 4]> {
    let text = std::fs::read_to_string(repo_root().join("targets/firmware/variants.txt")).unwrap();
    text.lines()
        .filter(|line| !line.starts_with('#') && !line.trim().is_empty())
        .map(|line| {
            let fields: Vec<&str> = line.split_whitespace().collect();
            let limit = |i: usize| fields[i].parse::<u64>().unwrap_or_else(|_| panic!("a number: {line}"));
            (fields[0].to_string(), [limit(5), limit(6), limit(7), limit(8)])
        })
        .collect()
}

/// A whole number as docs/firmware.md writes it (`32 768`, `4 096`).
fn spaced_number(cell: &str) -> u64 {
    cell.replace(' ', "").parse().unwrap_or_else(|_| panic!("not a number: {cell:?}"))
}

/// The figures of a text: a number (`4.93`, `1,896`) followed by a space and one of the units
/// the README's firmware section measures in, e.g. `4.93 ms`, `0.18 encoder counts`.
fn figures(text: &str) -> Vec<String> {
    const UNITS: &[&str] = &["encoder counts", "counts", "ms", "µs", "mm", "N", "%", "MHz", "B"];
    let bytes = text.as_bytes();
    let mut found = Vec::new();
    let mut i = 0;
    while i < bytes.len() {
        let starts_number = bytes[i].is_ascii_digit()
            && (i == 0 || !(bytes[i - 1].is_ascii_alphanumeric() || b".,_".contains(&bytes[i - 1])));
        if !starts_number {
            i += 1;
            continue;
        }
        let mut end = i;
        while end < bytes.len()
            && (bytes[end].is_ascii_digit()
                || (b".,".contains(&bytes[end]) && bytes.get(end + 1).is_some_and(u8::is_ascii_digit)))
        {
            end += 1;
        }
        let rest = &text[end..];
        if let Some(unit) = rest.strip_prefix(' ').and_then(|rest| {
            UNITS.iter().find(|unit| {
                rest.starts_with(*unit)
                    && !rest[unit.len()..].starts_with(|c: char| c.is_alphanumeric() || c == '·' || c == '/')
            })
        }) {
            found.push(format!("{} {unit}", &text[i..end]));
        }
        i = end;
    }
    found
}

/// `figure` written in `text` as a figure of its own (not the tail of a longer number).
fn states(text: &str, figure: &str) -> bool {
    text.match_indices(figure).any(|(i, _)| {
        !text[..i].ends_with(|c: char| c.is_ascii_digit() || c == '.' || c == ',')
            && !text[i + figure.len()..].starts_with(|c: char| c.is_alphanumeric())
    })
}

/// What the README's firmware section says that its sources do not: each image of its table
/// must be a line of `variants.txt` and a row of docs/firmware.md's measured table with the
/// same joints and task axes, and each figure of the section must be stated in a doc the
/// section links (docs/firmware.md, its scenarios, the link's pages).
fn readme_firmware_disagreements(readme: &str, docs: &BTreeMap<String, String>) -> Vec<String> {
    let readme = section(readme, "Firmware");
    let variants = firmware_variants();
    let firmware_md = docs.get("docs/firmware.md").expect("the section links docs/firmware.md");
    let measured: BTreeMap<String, String> = table_rows(firmware_md, "| image | N / M |")
        .into_iter()
        .map(|row| (row[0].split_whitespace().next().unwrap_or_default().to_string(), row[1].clone()))
        .collect();
    let mut problems = Vec::new();
    let rows = table_rows(readme, "| image | model (joints / task) |");
    assert!(rows.len() >= 8, "the README's firmware table has {} rows: the parse is broken", rows.len());
    for row in rows {
        let image = &row[0];
        if !variants.contains_key(image) {
            problems.push(format!("image `{image}` is not a line of targets/firmware/variants.txt"));
        }
        let readme_shape =
            row[1].split('(').nth(1).and_then(|s| s.split([',', ')']).next()).unwrap_or_default();
        match measured.get(image) {
            Some(shape) if shape == readme_shape.trim() => {}
            Some(shape) => problems.push(format!(
                "image `{image}`: the README says {readme_shape} joints / task, docs/firmware.md {shape}"
            )),
            None => problems.push(format!("image `{image}` has no row in docs/firmware.md's measured table")),
        }
    }
    let figures = figures(readme);
    assert!(figures.len() >= 5, "only {figures:?} in the README's firmware section: the scan is broken");
    for figure in figures {
        if !docs.values().any(|doc| states(doc, &figure)) {
            problems.push(format!("{figure:?} is stated in none of {:?}", docs.keys().collect::<Vec<_>>()));
        }
    }
    problems
}

/// The docs a part of the README links (`](docs/link.md)`, anchors dropped), by path.
fn linked_docs(text: &str) -> BTreeMap<String, String> {
    text.split("](")
        .skip(1)
        .filter_map(|link| {
            let target = &link[..link.find([')', '#'])?];
            (target.starts_with("docs/") && target.ends_with(".md")).then(|| target.to_string())
        })
        .map(|path| {
            let text = std::fs::read_to_string(repo_root().join(&path)).unwrap_or_else(|_| panic!("{path}"));
            (path, text)
        })
        .collect()
}

#[test]
fn readme_firmware_figures_come_from_the_docs() {
    let readme = std::fs::read_to_string(repo_root().join("README.md")).unwrap();
    let docs = linked_docs(section(&readme, "Firmware"));
    let problems = readme_firmware_disagreements(&readme, &docs);
    assert!(
        problems.is_empty(),
        "the README's firmware section disagrees with its sources:\n{}",
        problems.join("\n")
    );
}

#[test]
fn firmware_md_states_every_image_with_its_limits() {
    let text = std::fs::read_to_string(repo_root().join("docs/firmware.md")).unwrap();
    let variants = firmware_variants();
    let mut problems = Vec::new();
    let mut seen = BTreeSet::new();
    for row in table_rows(&text, "| image | N / M |") {
        let image = row[0].split_whitespace().next().unwrap_or_default().to_string();
        // impedance limit, current limit, flash limit, RAM limit.
        let limits = [5, 7, 9, 11].map(|i| spaced_number(&row[i]));
        match variants.get(&image) {
            Some(file) if *file == limits => {}
            Some(file) => problems.push(format!(
                "{image}: docs/firmware.md's limits {limits:?}, targets/firmware/variants.txt's {file:?}"
            )),
            None => {
                problems.push(format!("{image}: in docs/firmware.md, not in targets/firmware/variants.txt"))
            }
        }
        seen.insert(image);
    }
    for image in variants.keys().filter(|image| !seen.contains(*image)) {
        problems.push(format!(
            "{image}: in targets/firmware/variants.txt, not in docs/firmware.md's measured table"
        ));
    }
    assert!(
        problems.is_empty(),
        "docs/firmware.md disagrees with targets/firmware/variants.txt:\n{}",
        problems.join("\n")
    );
}

#[test]
fn the_figure_check_sees_a_planted_disagreement() {
    let readme = std::fs::read_to_string(repo_root().join("README.md")).unwrap();
    let docs = linked_docs(section(&readme, "Firmware"));
    assert_eq!(readme_firmware_disagreements(&readme, &docs), Vec::<String>::new());
    let changed = readme.replace("| phantom | PHANToM-like (3 / 3)", "| phantom | PHANToM-like (3 / 2)");
    assert_eq!(readme_firmware_disagreements(&changed, &docs).len(), 1);
    let changed = readme.replace("0.18 encoder counts", "0.17 encoder counts");
    assert_eq!(
        readme_firmware_disagreements(&changed, &docs),
        vec![format!("\"0.17 encoder counts\" is stated in none of {:?}", docs.keys().collect::<Vec<_>>())]
    );
}

#[test]
fn runtime_and_host_modules_import_no_cycle() {
    // The runtime's and the host's modules, like codegen's, depend one way: a rig's code never
    // needs the safety monitor that watches it, the design report's computations never the
    // page or the maps drawn from them.
    for (krate, least_files) in [("runtime/src", 15), ("targets/host/src", 30)] {
        let graph = crate_dependency_graph(&repo_root().join(krate));
        assert!(
            graph.len() >= least_files,
            "only {} source files found in {krate}: the scan is broken",
            graph.len()
        );
        let edges: usize = graph.values().map(BTreeSet::len).sum();
        assert!(edges >= least_files, "only {edges} dependencies found in {krate}: the scan is broken");
        if let Some(cycle) = find_cycle(&graph) {
            panic!("import cycle among {krate}'s files: {}", cycle.join(" → "));
        }
    }
}
