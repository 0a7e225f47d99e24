//! The generator's architecture, checked so that it cannot erode: every dependency between
//! codegen's source files points one way (no import cycles), each layer uses only the layers
//! below it, and every path ARCHITECTURE.md names exists.
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

/// Every `.rs` file under `dir`, as paths relative to `src/` with `/` separators.
fn rust_files(dir: &Path, out: &mut Vec<String>) {
    let mut entries: Vec<_> = std::fs::read_dir(dir).expect("readable source dir").flatten().collect();
    entries.sort_by_key(|e| e.path());
    for entry in entries {
        let path = entry.path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            let relative =
                path.strip_prefix(source_root()).expect("under src").to_string_lossy().replace('\\', "/");
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

/// File → the files it depends on.
fn dependency_graph() -> BTreeMap<String, BTreeSet<String>> {
    let mut list = Vec::new();
    rust_files(&source_root(), &mut list);
    let files: BTreeSet<String> = list.iter().cloned().collect();
    let mut graph = BTreeMap::new();
    for file in &list {
        let text = std::fs::read_to_string(source_root().join(file)).expect("readable source");
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
                            // An item of the module file itself (`crate::Item`, `super::Item`).
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
/// `main.rs`, in clap's kebab case (`ImportUrdf` → `import-urdf`).
fn cli_commands() -> Vec<String> {
    let main = std::fs::read_to_string(repo_root().join("targets/host/src/main.rs")).unwrap();
    let start = main.find("enum Command {").expect("the CLI's Command enum");
    let body = &main[start..start + main[start..].find("\n}").unwrap()];
    body.lines()
        .filter_map(|line| {
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

/// The runtime's modules, from `pub mod` lines of its `lib.rs`.
fn runtime_modules() -> Vec<String> {
    let lib = std::fs::read_to_string(repo_root().join("runtime/src/lib.rs")).unwrap();
    lib.lines().filter_map(|l| l.strip_prefix("pub mod ")?.strip_suffix(';').map(str::to_string)).collect()
}

/// What a map (`text`) leaves out: each crate as `` `path/` ``, each command as `` `name` ``,
/// each runtime module as `` `runtime/src/name.rs` ``.
fn omissions(text: &str, crates: &[String], commands: &[String], modules: &[String]) -> Vec<String> {
    let crates = crates.iter().map(|c| format!("`{c}/`"));
    let commands = commands.iter().map(|c| format!("`{c}`"));
    let modules = modules.iter().map(|m| format!("`runtime/src/{m}.rs`"));
    crates.chain(commands).chain(modules).filter(|needle| !text.contains(needle.as_str())).collect()
}

#[test]
fn the_maps_name_every_crate_command_and_runtime_module() {
    let (crates, commands, modules) = (workspace_members(), cli_commands(), runtime_modules());
    assert!(crates.len() >= 7 && crates.contains(&"protocol".to_string()), "{crates:?}");
    assert!(commands.len() >= 15 && commands.contains(&"import-urdf".to_string()), "{commands:?}");
    assert!(modules.len() >= 18 && modules.contains(&"tick".to_string()), "{modules:?}");
    let architecture = std::fs::read_to_string(repo_root().join("ARCHITECTURE.md")).unwrap();
    let missing = omissions(&architecture, &crates, &commands, &modules);
    assert!(missing.is_empty(), "ARCHITECTURE.md does not name {missing:?}");
    // The README's layout table names every crate, and its CLI section every command.
    let readme = std::fs::read_to_string(repo_root().join("README.md")).unwrap();
    let missing = omissions(&readme, &crates, &commands, &[]);
    assert!(missing.is_empty(), "README.md does not name {missing:?}");
}

#[test]
fn the_map_check_sees_a_planted_omission() {
    let architecture = std::fs::read_to_string(repo_root().join("ARCHITECTURE.md")).unwrap();
    let (crates, commands, modules) = (workspace_members(), cli_commands(), runtime_modules());
    for planted in ["`protocol/`", "`zwidth`", "`runtime/src/tick.rs`"] {
        let without = architecture.replace(planted, "(left out)");
        assert_eq!(omissions(&without, &crates, &commands, &modules), vec![planted.to_string()]);
    }
}
