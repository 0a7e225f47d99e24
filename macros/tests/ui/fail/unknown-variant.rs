// A variant the model does not define.
hapticgen_macros::rig!(pub mod parallel_link = "models/parallel_link_2dof.yaml", variant = "diagonal");

fn main() {}
