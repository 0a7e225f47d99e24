//! The composed impedance tick (`HapticLoop`) with the rig's fused, generated law gives the
//! same commands and statuses as with the runtime's generic law, tick after tick, for every law
//! on the parallel link rendering a virtual circle (paper, section 4, Fig. 7).

use hapticgen_runtime::control::{ControlOptions, ImpedanceController, ImpedanceLaw, ImpedanceParameters};
use hapticgen_runtime::current_loop::CurrentLoopGains;
use hapticgen_runtime::estimation::{EstimatorSettings, ForceSensorCalibration};
use hapticgen_runtime::render::{ObjectKind, Scene, Shape, VirtualObject};
use hapticgen_runtime::tick::{HapticLoop, HapticLoopSettings, ImpedanceInputs};
use hapticgen_tests::parallel_link_2dof_vertical_f64::ParallelLink2dof;

fn haptic_loop(law: ImpedanceLaw) -> HapticLoop<ParallelLink2dof, Scene<f64, 2, 8>, 2, 2> {
    let mut scene: Scene<f64, 2, 8> = Scene::new(0.0, 5.0, 0.3e-3);
    scene.add(VirtualObject {
        shape: Shape::Circle { center: [0.0, 0.13], radius: 0.02 },
        kind: ObjectKind::Cavity,
        stiffness: 1500.0,
        damping: 5.0,
    });
    let settings = HapticLoopSettings {
        controller: ImpedanceController {
            law,
            parameters: ImpedanceParameters { stiffness: [0.0; 2], damping: [5.0; 2], mass: [0.2; 2] },
            options: ControlOptions {
                omit_damping_compensation: false,
                min_abs_jacobian_determinant: 1e-4,
                spring_lead_time: 0.0,
            },
        },
        estimator: EstimatorSettings {
            sample_period: 1e-3,
            velocity_cutoff_hz: 50.0,
            acceleration_cutoff_hz: 20.0,
        },
        zero_offset: [1.4, 0.1],
        initial_counts: [0; 2],
        force_calibration: ForceSensorCalibration { scale: [5.0; 2], offset: [2.5; 2] },
        current_gains: ParallelLink2dof::CURRENT_LOOP_GAINS[0],
        max_tick_gap: 1,
    };
    let _: CurrentLoopGains<f64> = settings.current_gains;
    HapticLoop::new(ParallelLink2dof::NOMINAL, scene, &settings).expect("valid settings")
}

#[test]
fn fused_tick_equals_generic_tick() {
    for law in [
        ImpedanceLaw::Controller3,
        ImpedanceLaw::Controller2Mobility,
        ImpedanceLaw::Controller2Accel,
        ImpedanceLaw::Controller1ForceSensing,
    ] {
        let (mut generic, mut fused) = (haptic_loop(law), haptic_loop(law));
        let mut compared = 0;
        for tick in 0..2000u32 {
            // The handle moves on a slow loop through the cavity's wall (24,000 counts per
            // joint turn through the 12:1 gearhead), with a varying sensed force.
            let t = f64::from(tick) * 1e-3;
            let counts = [(600.0 * (2.0 * t).sin()) as i32, (900.0 * (1.3 * t).sin()) as i32];
            let inputs = ImpedanceInputs {
                encoder_counts: counts,
                force_readings: [2.5 + 0.2 * t.sin(), 2.5 - 0.1 * t.cos()],
                tick,
            };
            let a = generic.impedance_tick(&inputs);
            let b = fused.impedance_tick_fused(&inputs);
            assert_eq!(a.control_status, b.control_status, "{law:?} tick {tick}");
            assert_eq!(a.command.fault, b.command.fault, "{law:?} tick {tick}");
            for i in 0..2 {
                let (x, y) = (a.command.torque[i], b.command.torque[i]);
                assert!(
                    (x - y).abs() <= 1e-12 * x.abs().max(1.0),
                    "{law:?} tick {tick} joint {i}: {x} vs {y}"
                );
            }
            compared += 1;
        }
        assert_eq!(compared, 2000);
        assert!(generic.safety().fault().is_none(), "{law:?}: {:?}", generic.safety().fault());
    }
}
