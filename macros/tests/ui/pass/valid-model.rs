// A valid model expands to a module whose rig implements the runtime's traits.
hapticgen_macros::rig!(pub mod pendulum = "tests/ui/models/pendulum.yaml", scalar = f32);

fn main() {
    use hapticgen_runtime::RigModel;
    let rig = pendulum::Pendulum::NOMINAL;
    let d = RigModel::inertia_matrix(&rig, &[0.3]);
    assert!(d[0][0] > 0.0);
}
