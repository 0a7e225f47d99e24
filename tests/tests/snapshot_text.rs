//! Checks on the text of every snapshot of generated code (`tests/snapshots/`), which users
//! review as product: no doc line names another rig, no two functions have identical bodies,
//! one value is bound under one name, every float literal has the fewest significant
//! digits that give its value's bits and none is a short decimal with rounding noise, and no
//! sign is written twice (`x - -c`).

use std::collections::{BTreeMap, BTreeSet};
use std::path::PathBuf;

/// Every snapshot: its file name and the generated code (without insta's header).
fn snapshots() -> Vec<(String, String)> {
    let folder = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/snapshots");
    let mut out = Vec::new();
    for entry in std::fs::read_dir(&folder).unwrap_or_else(|e| panic!("{}: {e}", folder.display())) {
        let path = entry.expect("directory entry").path();
        if path.extension().is_none_or(|e| e != "snap") {
            continue;
        }
        let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        // insta's header is the first `---` … `---` block.
        let code = text.splitn(3, "---\n").nth(2).unwrap_or(&text).to_string();
        out.push((path.file_name().unwrap().to_string_lossy().into_owned(), code));
    }
    assert!(!out.is_empty(), "no snapshots in {}", folder.display());
    out.sort();
    out
}

/// The rig a snapshot was generated from: the model name on its `@generated` line.
fn rig_of(code: &str) -> String {
    let line = code.lines().find(|l| l.contains("@generated")).expect("an @generated line");
    let file = line.split("models/").nth(1).expect("a model path").split(".yaml").next().unwrap();
    file.to_string()
}

/// How a text would name a rig: its model name's words without those holding digits, and
/// trailing digits dropped (`parallel_link_2dof` → "parallel link", `puma560` → "puma").
fn rig_phrase(model: &str) -> String {
    model
        .split('_')
        .map(|w| w.trim_end_matches(|c: char| c.is_ascii_digit()))
        .filter(|w| !w.is_empty() && !w.contains(|c: char| c.is_ascii_digit()))
        .collect::<Vec<_>>()
        .join(" ")
}

#[test]
fn no_snapshot_names_another_rig() {
    let snapshots = snapshots();
    let rigs: BTreeSet<String> = snapshots.iter().map(|(_, code)| rig_of(code)).collect();
    let mut failures = Vec::new();
    for (file, code) in &snapshots {
        let own = rig_of(code);
        // The rig's own name is not another's, even when another's phrase is part of it
        // (`phantom_3dof`'s "phantom" in `phantom_premium`); no line is removed, so the line
        // numbers below count in the lowered text.
        let lower = code
            .to_lowercase()
            .replace(&own.replace('_', ""), "") // the struct, `PhantomPremium`
            .replace('_', " ")
            .replace(&own.replace('_', " "), "");
        for other in rigs.iter().filter(|r| **r != own) {
            for phrase in [other.replace('_', " "), rig_phrase(other)] {
                if let Some(at) = lower.find(&phrase) {
                    let line = lower[..at].lines().count();
                    failures.push(format!("{file}:{line}: names the rig `{other}` (\"{phrase}\")"));
                }
            }
        }
    }
    assert!(failures.is_empty(), "generated text about another rig:\n{}", failures.join("\n"));
}

/// Each function of a generated file: its name and its body, whitespace removed.
fn functions(code: &str) -> Vec<(String, String)> {
    let mut out = Vec::new();
    let mut rest = code;
    while let Some(at) = rest.find("fn ") {
        let after = &rest[at + 3..];
        let name: String = after.chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect();
        // The body: from the first `{` after the signature to its matching `}`.
        let Some(open) = after.find('{') else { break };
        let mut depth = 0usize;
        let mut end = open;
        for (i, c) in after[open..].char_indices() {
            match c {
                '{' => depth += 1,
                '}' => {
                    depth -= 1;
                    if depth == 0 {
                        end = open + i;
                        break;
                    }
                }
                _ => {}
            }
        }
        let body: String = after[open + 1..end].chars().filter(|c| !c.is_whitespace()).collect();
        if !name.is_empty() {
            out.push((name, body));
        }
        rest = &after[end..];
    }
    out
}

#[test]
fn no_snapshot_has_two_functions_with_identical_bodies() {
    let mut failures = Vec::new();
    for (file, code) in snapshots() {
        let mut by_body: BTreeMap<String, Vec<String>> = BTreeMap::new();
        for (name, body) in functions(&code) {
            // A constant result (`[0.0_f64, 0.0_f64]` for gravity and damping of a horizontal
            // rig) is no repeated computation.
            let constant = body.split(['_', '[', ']', ',', '-', '.']).all(|w| {
                w.is_empty() || w == "f32" || w == "f64" || w.chars().all(|c| c.is_ascii_digit() || c == 'e')
            });
            // Nor is a call of another function (`Self::jacobian(self, q)`): that is how a
            // repeated computation is removed, and several may call the same one.
            let delegation = body.starts_with("Self::") && body.matches(';').count() == 0;
            if !constant && !delegation {
                by_body.entry(body).or_default().push(name);
            }
        }
        for names in by_body.values().filter(|names| names.len() > 1) {
            failures.push(format!("{file}: {} have the same body", names.join(", ")));
        }
    }
    assert!(
        failures.is_empty(),
        "duplicate functions (emit one and let the other call it, or drop it):\n{}",
        failures.join("\n")
    );
}

#[test]
fn one_value_has_one_name_in_each_snapshot() {
    let mut failures = Vec::new();
    for (file, code) in snapshots() {
        // `let name = value;` with the value's text as the key.
        let mut by_value: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
        for statement in code.split("let ").skip(1) {
            let Some((name, rest)) = statement.split_once(" = ") else { continue };
            if !name.chars().all(|c| c.is_alphanumeric() || c == '_') {
                continue;
            }
            let value: String =
                rest.split(';').next().unwrap_or_default().chars().filter(|c| !c.is_whitespace()).collect();
            by_value.entry(value).or_default().insert(name.to_string());
        }
        for (value, names) in by_value.iter().filter(|(_, names)| names.len() > 1) {
            let names: Vec<&str> = names.iter().map(String::as_str).collect();
            failures.push(format!("{file}: {value} is named {}", names.join(" and ")));
        }
    }
    assert!(failures.is_empty(), "one value under several names:\n{}", failures.join("\n"));
}

/// The significant digits of a decimal literal (`0.00120` → 2, `1.5e-3` → 2).
fn significant_digits(text: &str) -> usize {
    let mantissa = text.split(['e', 'E']).next().unwrap_or_default();
    let digits: String = mantissa.chars().filter(char::is_ascii_digit).collect();
    digits.trim_start_matches('0').trim_end_matches('0').len().max(1)
}

/// The fewest significant digits a literal with `value`'s bits needs (Rust's shortest
/// round-trip formatting).
fn shortest_f64(value: f64) -> usize {
    significant_digits(&format!("{value:e}"))
}

fn shortest_f32(value: f32) -> usize {
    significant_digits(&format!("{value:e}"))
}

/// Every float literal of `code`: its text without sign or suffix, and its suffix (`_f64`,
/// `_f32`).
fn float_literals(code: &str) -> Vec<(&str, &'static str)> {
    let mut out = Vec::new();
    for suffix in ["_f64", "_f32"] {
        for (at, _) in code.match_indices(suffix) {
            let start = code[..at]
                .rfind(|c: char| !(c.is_ascii_digit() || matches!(c, '.' | 'e' | '-' | '+')))
                .map_or(0, |i| i + 1);
            // A leading sign belongs to the expression, not the literal.
            let text = code[start..at].trim_start_matches(['-', '+']);
            if !text.is_empty() && text.starts_with(|c: char| c.is_ascii_digit()) {
                out.push((text, suffix));
            }
        }
    }
    out
}

/// A decimal literal rounded (half up) to `digits` significant digits, as `d.ddde±x` text:
/// on the digits of the text, not on its value, so that it shares nothing with the
/// generator's `short_decimal`.
fn rounded_to_digits(text: &str, digits: usize) -> String {
    let (mantissa, exponent) = match text.split_once(['e', 'E']) {
        Some((m, e)) => (m, e.parse::<i32>().expect("an exponent")),
        None => (text, 0),
    };
    let (whole, fraction) = mantissa.split_once('.').unwrap_or((mantissa, ""));
    let all: String = format!("{whole}{fraction}");
    let leading = all.len() - all.trim_start_matches('0').len();
    let significant: Vec<u8> = all.trim_start_matches('0').bytes().map(|b| b - b'0').collect();
    if significant.is_empty() {
        return "0".to_string();
    }
    // The value is 0.d1d2d3… × 10^point.
    let mut point = whole.len() as i32 - leading as i32 + exponent;
    let mut kept: Vec<u8> = significant.iter().copied().take(digits).collect();
    if significant.get(digits).is_some_and(|&d| d >= 5) {
        let mut i = kept.len();
        loop {
            if i == 0 {
                kept.insert(0, 1);
                kept.pop();
                point += 1;
                break;
            }
            i -= 1;
            if kept[i] == 9 {
                kept[i] = 0;
            } else {
                kept[i] += 1;
                break;
            }
        }
    }
    let digits: String = kept.iter().map(|d| char::from(b'0' + d)).collect();
    format!("{}.{}e{}", &digits[..1], &digits[1..], point - 1)
}

/// No literal lies within 4 units in the last place of a decimal of at most 8 significant
/// digits that it does not equal: that is rounding noise of a product or sum of the model's
/// short decimals folded in binary (`0.0028799999999999997` for 0.0024 × 1.2), which the
/// generator writes as the decimal itself.
#[test]
fn no_float_literal_is_a_short_decimal_with_rounding_noise() {
    assert_eq!(rounded_to_digits("0.0028799999999999997", 8), "2.8800000e-3");
    assert_eq!(rounded_to_digits("9.999999995e-5", 8), "1.0000000e-4");
    assert_eq!(rounded_to_digits("24.525000000000002", 8), "2.4525000e1");
    let mut failures = Vec::new();
    for (file, code) in snapshots() {
        for (text, suffix) in float_literals(&code) {
            let Ok(value) = text.parse::<f64>() else { continue };
            let short: f64 = rounded_to_digits(text, 8).parse().expect("a decimal");
            let apart = if suffix == "_f32" {
                (value as f32).to_bits().abs_diff((short as f32).to_bits()) as u64
            } else {
                value.to_bits().abs_diff(short.to_bits())
            };
            if apart != 0 && apart <= 4 {
                failures.push(format!("{file}: {text}{suffix} is {apart} ulps from {short:e}"));
            }
        }
    }
    assert!(failures.is_empty(), "{} literals with rounding noise:\n{}", failures.len(), failures.join("\n"));
}

#[test]
fn every_float_literal_has_the_fewest_digits_with_its_bits() {
    let mut failures = Vec::new();
    for (file, code) in snapshots() {
        for (text, suffix) in float_literals(&code) {
            let shortest = if suffix == "_f32" {
                text.parse::<f32>().map(shortest_f32)
            } else {
                text.parse::<f64>().map(shortest_f64)
            };
            match shortest {
                Ok(n) if significant_digits(text) > n => failures
                    .push(format!("{file}: {text}{suffix} has the same bits with {n} significant digits")),
                Ok(_) => {}
                Err(e) => failures.push(format!("{file}: {text}{suffix}: {e}")),
            }
        }
    }
    assert!(failures.is_empty(), "float literals longer than they need be:\n{}", failures.join("\n"));
}

/// `x - -c * y` and `x + -c` read as a sign puzzle: the emitter writes `x + c * y` and `x - c`.
#[test]
fn no_snapshot_writes_a_sign_twice() {
    let mut failures = Vec::new();
    for (file, code) in snapshots() {
        for (number, line) in code.lines().enumerate() {
            // Collapse line breaks inside expressions: the formatter may break before `-`.
            let trimmed = line.trim_start();
            let starts_with_operator = trimmed.starts_with("- -") || trimmed.starts_with("+ -");
            if starts_with_operator || line.contains(" - -") || line.contains(" + -") {
                failures.push(format!("{file}:{}: {}", number + 1, trimmed));
            }
        }
    }
    assert!(failures.is_empty(), "a sign written twice:\n{}", failures.join("\n"));
}

/// docs/generated-code.md counts, per snapshot, the `let` bindings and those still named
/// `<function>_partN`; the table must be the snapshots' own counts.
#[test]
fn the_docs_count_the_numbered_names_of_every_snapshot() {
    let docs = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../docs/generated-code.md");
    let text = std::fs::read_to_string(&docs).unwrap_or_else(|e| panic!("{}: {e}", docs.display()));
    let table: BTreeMap<String, (usize, usize)> = text
        .lines()
        .filter_map(|line| {
            let cells: Vec<&str> = line.trim().trim_matches('|').split('|').map(str::trim).collect();
            let [name, lets, parts] = cells[..] else { return None };
            Some((name.to_string(), (lets.parse().ok()?, parts.parse().ok()?)))
        })
        .collect();
    let mut counted = BTreeMap::new();
    for (file, code) in snapshots() {
        let name = file.trim_start_matches("snapshots__").trim_end_matches(".snap").to_string();
        let bindings: Vec<&str> = code
            .match_indices("let ")
            .filter(|(at, _)| *at == 0 || !code[..*at].ends_with(|c: char| c.is_alphanumeric() || c == '_'))
            .map(|(at, _)| {
                code[at + 4..].split(|c: char| !(c.is_alphanumeric() || c == '_')).next().unwrap_or("")
            })
            .filter(|ident| !ident.is_empty())
            .collect();
        let numbered = bindings
            .iter()
            .filter(|ident| {
                ident
                    .rsplit_once("_part")
                    .is_some_and(|(_, n)| !n.is_empty() && n.bytes().all(|b| b.is_ascii_digit()))
            })
            .count();
        counted.insert(name, (bindings.len(), numbered));
    }
    assert_eq!(table, counted, "docs/generated-code.md's table (left) against the snapshots (right)");
}
