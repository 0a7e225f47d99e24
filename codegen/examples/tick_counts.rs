//! Prints the operation counts of one control tick's quantities (D, C q̇, g, J, J̇ q̇ together,
//! with and without p) for a model: `cargo run -p hapticgen-codegen --example tick_counts -- MODEL [VARIANT]`.
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let Some(path) = args.get(1) else {
        eprintln!("usage: tick_counts MODEL [VARIANT]");
        std::process::exit(2);
    };
    let model = match hapticgen_codegen::model::load_file(
        std::path::Path::new(path),
        path,
        args.get(2).map(String::as_str),
    ) {
        Ok(m) => m,
        Err(e) => {
            eprintln!("{e}");
            std::process::exit(1);
        }
    };
    let mech = hapticgen_codegen::mechanics::derive(&model);
    for include_position in [false, true] {
        let c = hapticgen_codegen::emit::tick_counts(&model, &mech, include_position);
        println!(
            "{} p: {} arithmetic ({} add, {} mul, {} neg, {} div), {} trig",
            if include_position { "with" } else { "without" },
            c.arithmetic(),
            c.additions,
            c.multiplications,
            c.negations,
            c.divisions,
            c.trigonometric
        );
    }
}
