use hapticgen_codegen::model::{load, Source};
#[test]
fn sample() {
    let mut seen = std::collections::BTreeSet::new();
    for p in [
        "../models/joystick_1dof.yaml",
        "../models/parallel_link_2dof.yaml",
        "tests/good-models/spatial_arm_3dof.yaml",
        "tests/good-models/planar_arm_2dof.yaml",
    ] {
        let text = std::fs::read_to_string(p).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        for i in 0..lines.len() {
            let mut l = lines.clone();
            l.remove(i);
            let t = l.join("\n");
            if let Err(d) = load(&Source { name: "m", text: &t }, None) {
                let s = d.0[0].to_string();
                let key: String = d.0[0].message.chars().take(40).collect();
                if seen.insert(key) {
                    println!("{p} del {}: {s}", i + 1);
                }
            }
        }
        for cut in (0..text.len()).step_by(41) {
            if !text.is_char_boundary(cut) {
                continue;
            }
            if let Err(d) = load(&Source { name: "m", text: &text[..cut] }, None) {
                let key: String = d.0[0].message.chars().take(30).collect();
                if seen.insert(key) {
                    println!("{p} cut {cut}: {}", d.0[0]);
                }
            }
        }
    }
}
