// A scalar type other than f32 or f64.
hapticgen_macros::rig!(pub mod pendulum = "tests/ui/models/pendulum.yaml", scalar = f16);

fn main() {}
