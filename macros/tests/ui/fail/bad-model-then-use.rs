// A bad model whose rig the crate goes on to use: the model's error is the only error, not a
// second "unresolved import" (the stub module holds a struct of the rig's name).
hapticgen_macros::rig!(mod pendulum = "tests/ui/models/negative-mass.yaml");

use pendulum::Pendulum;

fn main() {
    let _ = core::mem::size_of::<Pendulum>();
}
