//! Prints the operation counts of one control tick's quantities (D, C q̇, g, J, J̇ q̇ together,
//! with and without p) for a model:
//! `cargo run -p hapticgen-codegen --example tick_counts -- MODEL [VARIANT] [--fma]`
//! (`--fma`: counted as emitted with fused multiply-adds, each one operation in `fused`).
fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let fused_multiply_add = args.iter().any(|a| a == "--fma");
    let positional: Vec<&String> = args.iter().filter(|a| *a != "--fma").collect();
    let Some(path) = positional.first() else {
        eprintln!("usage: tick_counts MODEL [VARIANT] [--fma]");
        std::process::exit(2);
    };
    let model = match hapticgen_codegen::load_file(
        std::path::Path::new(path.as_str()),
        path,
        positional.get(1).map(|v| v.as_str()),
    ) {
        Ok(m) => m,
        Err(e) => {
            eprintln!("{e}");
            std::process::exit(1);
        }
    };
    let mech = hapticgen_codegen::derive(&model);
    let options = hapticgen_codegen::EmitOptions { fused_multiply_add, ..Default::default() };
    for include_position in [false, true] {
        let c = hapticgen_codegen::emit::tick_counts_with(&model, &mech, include_position, options);
        println!(
            "{} p: {} arithmetic ({} add, {} mul, {} neg, {} div, {} fused), {} trig",
            if include_position { "with" } else { "without" },
            c.arithmetic(),
            c.additions,
            c.multiplications,
            c.negations,
            c.divisions,
            c.fused,
            c.trigonometric
        );
    }
}
