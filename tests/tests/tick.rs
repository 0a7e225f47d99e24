//! The composed impedance tick (`HapticLoop`) with the rig's fused, generated law gives the
//! same commands and statuses as with the runtime's generic law, tick after tick, for every law
//! on the parallel link rendering a virtual circle (paper, section 4, Fig. 7).

use hapticgen_runtime::control::ImpedanceLaw;
use hapticgen_runtime::render::Scene;
use hapticgen_runtime::tick::{HapticLoop, ImpedanceInputs};
use hapticgen_tests::parallel_link_2dof_vertical_f64::ParallelLink2dof;
use hapticgen_tests::stack::{circle_scene, encoder_counts, parallel_link_settings};

fn haptic_loop(law: ImpedanceLaw) -> HapticLoop<ParallelLink2dof, Scene<f64, 2, 8>, 2, 2> {
    HapticLoop::new(ParallelLink2dof::NOMINAL, circle_scene(), &parallel_link_settings(law))
        .expect("valid settings")
}

#[test]
fn fused_tick_equals_generic_tick() {
    for law in [
        ImpedanceLaw::JacobianTranspose,
        ImpedanceLaw::NaturalInertia,
        ImpedanceLaw::AccelerationFeedback,
        ImpedanceLaw::ForceFeedback,
    ] {
        let (mut generic, mut fused) = (haptic_loop(law), haptic_loop(law));
        let mut compared = 0;
        for tick in 0..2000u32 {
            // The handle moves on a slow loop through the cavity's wall (24,000 counts per
            // joint turn through the 12:1 gearhead), with a varying sensed force.
            let t = f64::from(tick) * 1e-3;
            let counts = encoder_counts(tick);
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

#[test]
fn a_stalled_impedance_task_stops_the_motors_within_a_millisecond() {
    let mut haptic = haptic_loop(ImpedanceLaw::JacobianTranspose);
    let measured = [0.0; 2];
    let (mut tick, mut current_ticks, mut stalled_at) = (0u32, 0u32, None);
    loop {
        current_ticks += 1;
        let (out, due) = haptic.current_tick(&measured);
        if let Some(at) = stalled_at {
            if haptic.safety().fault().is_some() {
                // 7.5 current ticks per millisecond.
                let waited = current_ticks - at;
                assert!(waited <= 7, "safe state after {waited} current ticks");
                assert!(out.iter().all(|o| o.voltage == 0.0));
                break;
            }
            assert!(current_ticks - at < 100, "the stall was never detected");
            continue;
        }
        if due {
            tick += 1;
            if tick == 50 {
                // The impedance task stops running from here on.
                stalled_at = Some(current_ticks);
                continue;
            }
            let inputs =
                ImpedanceInputs { encoder_counts: encoder_counts(tick), force_readings: [2.5; 2], tick };
            haptic.impedance_tick_fused(&inputs);
            assert!(haptic.safety().fault().is_none(), "{:?} at tick {tick}", haptic.safety().fault());
        }
    }
    assert_eq!(haptic.safety().fault(), Some(hapticgen_runtime::safety::FaultCode::MissedTicks));
}
