// The `mod` keyword is missing.
hapticgen_macros::rig!(pub pendulum = "tests/ui/models/pendulum.yaml");

fn main() {}
