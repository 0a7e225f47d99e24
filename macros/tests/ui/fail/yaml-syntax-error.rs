// A YAML syntax error (an unclosed flow mapping).
hapticgen_macros::rig!(pub mod pendulum = "tests/ui/models/yaml-syntax-error.yaml");

fn main() {}
