// A body references a joint that does not exist.
hapticgen_macros::rig!(pub mod pendulum = "tests/ui/models/undefined-joint.yaml");

fn main() {}
