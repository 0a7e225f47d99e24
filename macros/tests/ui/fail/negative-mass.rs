// A negative mass.
hapticgen_macros::rig!(pub mod pendulum = "tests/ui/models/negative-mass.yaml");

fn main() {}
