use hapticgen_codegen::model::{load, Source};

#[test]
fn dump() {
    let mut names: Vec<_> = std::fs::read_dir(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/bad-models"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    names.sort();
    for p in names {
        let text = std::fs::read_to_string(&p).unwrap();
        let name = p.file_name().unwrap().to_str().unwrap().to_string();
        let v = if name.contains("variant") && !name.contains("variant-set") && !name.contains("variant-negative") { Some(if name.contains("remove") { "bare" } else { "nope" }) } else { None };
        match load(&Source { name: &name, text: &text }, v) {
            Ok(_) => println!("{name}: OK"),
            Err(d) => println!("{d}"),
        }
    }
}
