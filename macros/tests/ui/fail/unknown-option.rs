// An option the macro does not know.
hapticgen_macros::rig!(pub mod pendulum = "tests/ui/models/pendulum.yaml", precision = f32);

fn main() {}
