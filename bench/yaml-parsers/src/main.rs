//! Instructions per byte of each YAML parser on the fuzzer's seed pool (`hapticgen_fuzz`'s own:
//! its corpus directories, each seed compacted, one in eight also as written). Run under
//! callgrind, one parser per run, by `bench/yaml-parsers.sh`, which divides a run's
//! instructions, less those of the same parser's run of no passes, by the bytes parsed.
//!
//! `hapticgen-bench-yaml-parsers PARSER ROUNDS`: PARSER is one of
//! * `read`: nothing but reading the files (the baseline);
//! * `serde_yaml-value`: `serde_yaml::from_str::<serde_yaml::Value>`, the loader's parse
//!   (libyaml's events inside it are read off callgrind's inclusive cost of
//!   `unsafe_libyaml::parser::yaml_parser_parse`);
//! * `yaml-rust2-events`: yaml-rust2's marked events, what the loader's position index reads;
//! * `yaml-rust2-value`: those events made into a `serde_yaml::Value` (plain scalars resolved
//!   as null, bool, integer, float or string): what one parse with positions and values
//!   would cost at least;
//! * `saphyr-events`: saphyr-parser's events (the `saphyr` project's parser);
//! * `serde-saphyr-json`: serde-saphyr into a `serde_json::Value`.
//!
//! Files a parser refuses count their bytes all the same (each parser reads up to the error).

use std::hint::black_box;

use serde_yaml::{Mapping, Value};
use yaml_rust2::parser::{Event, MarkedEventReceiver, Parser};
use yaml_rust2::scanner::{Marker, TScalarStyle};

#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [parser, rounds] = args.as_slice() else {
        eprintln!("usage: hapticgen-bench-yaml-parsers PARSER ROUNDS");
        std::process::exit(2);
    };
    let Ok(rounds) = rounds.parse::<usize>() else {
        eprintln!("ROUNDS must be a whole number, got `{rounds}`");
        std::process::exit(2);
    };
    let texts = seed_pool();
    let bytes: usize = texts.iter().map(String::len).sum();
    let parse: fn(&str) = match parser.as_str() {
        "read" => |text| {
            black_box(text);
        },
        "serde_yaml-value" => |text| {
            black_box(serde_yaml::from_str::<Value>(text).ok());
        },
        "yaml-rust2-events" => |text| {
            let mut counter = EventCounter(0);
            let _ = Parser::new_from_str(text).load(&mut counter, false);
            black_box(counter.0);
        },
        "yaml-rust2-value" => |text| {
            black_box(value_from_events(text));
        },
        "saphyr-events" => |text| {
            for event in saphyr_parser::Parser::new_from_str(text) {
                let Ok(event) = event else { break };
                black_box(event);
            }
        },
        "serde-saphyr-json" => |text| {
            black_box(serde_saphyr::from_str::<serde_json::Value>(text).ok());
        },
        other => {
            eprintln!("unknown parser `{other}`");
            std::process::exit(2);
        }
    };
    for _ in 0..rounds {
        for text in &texts {
            parse(text);
        }
    }
    println!("{parser}: {} seeds, {bytes} bytes, {rounds} rounds", texts.len());
}

/// The fuzzer's seed pool, as text (a seed that is not UTF-8 is left out: no parser here reads
/// bytes).
fn seed_pool() -> Vec<String> {
    let workspace = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let corpus = hapticgen_fuzz::load_corpus(&hapticgen_fuzz::corpus_dirs(&workspace));
    let texts: Vec<String> = hapticgen_fuzz::seed_pool(&corpus)
        .into_iter()
        .filter_map(|(_, bytes)| String::from_utf8(bytes).ok())
        .collect();
    if texts.is_empty() {
        eprintln!("no seed found under {}", workspace.display());
        std::process::exit(2);
    }
    texts
}

/// Counts yaml-rust2's events (the receiver the position index has, doing nothing).
struct EventCounter(usize);

impl MarkedEventReceiver for EventCounter {
    fn on_event(&mut self, event: Event, mark: Marker) {
        black_box((&event, mark));
        self.0 += 1;
    }
}

/// A collection being built, with its anchor id.
enum Open {
    Sequence(Vec<Value>, usize),
    Mapping(Mapping, Option<Value>, usize),
}

/// Builds a `serde_yaml::Value` from yaml-rust2's events.
#[derive(Default)]
struct ValueBuilder {
    open: Vec<Open>,
    root: Option<Value>,
    anchors: Vec<(usize, Value)>,
}

impl ValueBuilder {
    fn add(&mut self, value: Value, anchor: usize) {
        if anchor > 0 {
            self.anchors.push((anchor, value.clone()));
        }
        match self.open.last_mut() {
            None => self.root = Some(value),
            Some(Open::Sequence(items, _)) => items.push(value),
            Some(Open::Mapping(entries, key, _)) => match key.take() {
                None => *key = Some(value),
                Some(key) => {
                    entries.insert(key, value);
                }
            },
        }
    }
}

/// A plain scalar's value as YAML 1.2's core schema reads it; quoted ones are strings.
fn scalar(text: String, style: TScalarStyle) -> Value {
    if style != TScalarStyle::Plain {
        return Value::String(text);
    }
    match text.as_str() {
        "" | "~" | "null" | "Null" | "NULL" => Value::Null,
        "true" | "True" | "TRUE" => Value::Bool(true),
        "false" | "False" | "FALSE" => Value::Bool(false),
        _ => {
            if let Ok(unsigned) = text.parse::<u64>() {
                Value::from(unsigned)
            } else if let Ok(signed) = text.parse::<i64>() {
                Value::from(signed)
            } else if let Ok(float) = text.parse::<f64>() {
                Value::from(float)
            } else {
                Value::String(text)
            }
        }
    }
}

impl MarkedEventReceiver for ValueBuilder {
    fn on_event(&mut self, event: Event, mark: Marker) {
        black_box(mark);
        match event {
            Event::Scalar(text, style, anchor, _) => self.add(scalar(text, style), anchor),
            Event::Alias(anchor) => {
                let value = self.anchors.iter().rev().find(|(id, _)| *id == anchor).map(|(_, v)| v.clone());
                self.add(value.unwrap_or(Value::Null), 0);
            }
            Event::SequenceStart(anchor, _) => self.open.push(Open::Sequence(Vec::new(), anchor)),
            Event::MappingStart(anchor, _) => self.open.push(Open::Mapping(Mapping::new(), None, anchor)),
            Event::SequenceEnd => {
                if let Some(Open::Sequence(items, anchor)) = self.open.pop() {
                    self.add(Value::Sequence(items), anchor);
                }
            }
            Event::MappingEnd => {
                if let Some(Open::Mapping(entries, _, anchor)) = self.open.pop() {
                    self.add(Value::Mapping(entries), anchor);
                }
            }
            _ => {}
        }
    }
}

fn value_from_events(text: &str) -> Option<Value> {
    let mut builder = ValueBuilder::default();
    Parser::new_from_str(text).load(&mut builder, false).ok()?;
    builder.root
}
