// An inertia tensor that is not positive definite.
hapticgen_macros::rig!(pub mod pendulum = "tests/ui/models/invalid-inertia.yaml");

fn main() {}
