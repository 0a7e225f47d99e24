// A sequence where a number is expected.
hapticgen_macros::rig!(pub mod pendulum = "tests/ui/models/wrong-type.yaml");

fn main() {}
