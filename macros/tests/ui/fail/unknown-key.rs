// An unknown key in a body.
hapticgen_macros::rig!(pub mod pendulum = "tests/ui/models/unknown-key.yaml");

fn main() {}
