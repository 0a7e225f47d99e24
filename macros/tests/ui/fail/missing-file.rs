// The model file does not exist.
hapticgen_macros::rig!(pub mod pendulum = "tests/ui/models/does-not-exist.yaml");

fn main() {}
