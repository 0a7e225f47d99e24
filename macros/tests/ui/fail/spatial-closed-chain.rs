// A spatial closed chain (a Delta) loads and evaluates, but code is not emitted for it yet: the
// macro says so at the model's `closures`, instead of emitting a rig that computes nothing.
hapticgen_macros::rig!(mod delta = "codegen/tests/closed-chains/falcon_delta.yaml");

fn main() {}
