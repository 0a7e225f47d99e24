//! Time of `model::load` (parse, variant, resolve, validate) per model file, against a parse
//! with serde_yaml alone and with yaml-rust2 alone (the loader runs both: see
//! docs/reliability.md, "Fuzzing the loader and the generator"). `ROUNDS` (default 200) loads per file:
//!
//! ```sh
//! cargo run --release -p hapticgen-codegen --example load_rate -- models/*.yaml
//! ROUNDS=5 valgrind --tool=callgrind target/release/examples/load_rate models/puma560.yaml
//! ```
use std::time::Instant;

fn main() {
    for path in std::env::args().skip(1) {
        let text = std::fs::read_to_string(&path).unwrap();
        let source = hapticgen_codegen::Source { name: &path, text: &text };
        let rounds: u32 = std::env::var("ROUNDS").ok().and_then(|r| r.parse().ok()).unwrap_or(200);
        let start = Instant::now();
        let mut ok = 0;
        for _ in 0..rounds {
            ok += usize::from(hapticgen_codegen::model::load(&source, None).is_ok());
        }
        let per = start.elapsed().as_secs_f64() / f64::from(rounds) * 1e6;
        let t = Instant::now();
        for _ in 0..rounds {
            let _: serde_yaml::Value = serde_yaml::from_str(&text).unwrap_or(serde_yaml::Value::Null);
        }
        let serde = t.elapsed().as_secs_f64() / f64::from(rounds) * 1e6;
        let t = Instant::now();
        for _ in 0..rounds {
            let _ = yaml_rust2::YamlLoader::load_from_str(&text);
        }
        let yr = t.elapsed().as_secs_f64() / f64::from(rounds) * 1e6;
        println!(
            "{path}: {} bytes, load {per:.0} µs (ok {ok}), serde_yaml {serde:.0} µs, yaml-rust2 {yr:.0} µs",
            text.len()
        );
    }
}
