//! The simulator's controller gets each motor's own current-loop gains: on the generated rigs
//! the same gains as the generator emitted (`CURRENT_LOOP_GAINS`), and on a model the binary
//! was not built with (run on tapes) one design per joint's motor, not the first joint's for
//! all.

use std::path::Path;

use hapticgen_host::closed_loop::SimConfig;
use hapticgen_host::generated::{self, RigVisitor};
use hapticgen_host::simulation::Simulation;
use hapticgen_runtime::current_loop::CurrentLoopGains;
use hapticgen_runtime::RigModel;

struct GainsOf;

impl RigVisitor for GainsOf {
    type Output = Vec<CurrentLoopGains<f64>>;
    fn visit<R: RigModel<N, M, Scalar = f64>, const N: usize, const M: usize>(self, rig: R) -> Self::Output {
        rig.current_loop_gains().to_vec()
    }
}

fn model_path(file: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models").join(file)
}

#[test]
fn the_simulator_designs_the_gains_the_generator_emitted() {
    let mut compared = 0;
    for (file, variant) in [
        ("joystick_1dof.yaml", None),
        ("parallel_link_2dof.yaml", Some("vertical")),
        ("planar_arm_2dof.yaml", Some("horizontal")),
        ("phantom_3dof.yaml", None),
        ("pantograph_5bar.yaml", Some("horizontal")),
    ] {
        let sim = Simulation::load(&model_path(file), variant).unwrap();
        let index = sim.shipped.unwrap_or_else(|| panic!("{file} runs on its generated code"));
        let emitted = generated::visit(index, GainsOf).expect("a registered rig");
        assert_eq!(sim.data.current_gains, emitted, "{file}");
        compared += 1;
    }
    assert_eq!(compared, 5);
}

#[test]
fn a_rig_whose_motors_differ_gets_one_design_per_motor() {
    // The planar arm with a second motor of twice the armature's resistance and inductance
    // on the elbow: a model the binary was not built with, so its controller runs on tapes.
    let text = std::fs::read_to_string(model_path("planar_arm_2dof.yaml")).unwrap();
    let elbow_motor = "  elbow_gearmotor:
    motor: {rotor_inertia: 1.42e-5, resistance: 0.598, inductance: 0.164e-3, torque_constant: 30.2e-3}
    gear_ratio: 50.0
    efficiency: 0.9
    torque_limit: 12.0
    current_limit: 8.0
    supply_voltage: 24.0
    encoder: {counts_per_turn: 2000}
";
    let with_second_drive = text.replacen("\njoints:\n", &format!("{elbow_motor}\njoints:\n"), 1);
    let elbow = "limits: {lower: 0.1, upper: 2.8}\n    drive: gearmotor";
    assert!(with_second_drive.contains(elbow), "the planar arm's elbow changed; update this test");
    let edited =
        with_second_drive.replacen(elbow, "limits: {lower: 0.1, upper: 2.8}\n    drive: elbow_gearmotor", 1);
    let source = hapticgen_codegen::Source { name: "two_motors.yaml", text: &edited };
    let model = hapticgen_codegen::load(&source, Some("horizontal")).unwrap();
    let sim = Simulation::from_model(model).unwrap();
    assert!(!sim.uses_generated_code());
    let [shoulder, elbow] = [sim.data.current_gains[0], sim.data.current_gains[1]];
    // Same target bandwidth on an armature with the same time constant L/R: kp scales with L,
    // ki with R, so both double.
    assert!((elbow.kp / shoulder.kp - 2.0).abs() < 1e-9, "{shoulder:?} {elbow:?}");
    assert!((elbow.ki / shoulder.ki - 2.0).abs() < 1e-9, "{shoulder:?} {elbow:?}");
    // The closed loop runs on them (the tape rig's controller, not generated code).
    let trace = sim.run(&SimConfig::new(sim.home())).unwrap();
    assert!(trace.impedance_ticks > 0);
}
