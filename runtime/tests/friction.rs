//! The friction compensation in the laws (`ControlOptions::friction_compensation_band`): off,
//! the torque is the paper's eq. (3) to the bit; on, every law adds exactly
//! `F_c sat(q̇/δ)` (the joystick's model value, `F_c = 0.01 N·m`) at velocities inside and
//! outside the band; a non-finite band is refused; and through the haptic loop's tick.

use crate::common::{Joystick, JOINT_COULOMB_FRICTION};
use hapticgen_runtime::control::{
    ControlStatus, ImpedanceController, ImpedanceLaw, TaskReference, TaskSensing,
};
use hapticgen_runtime::tick::{HapticLoop, HapticLoopSettings, ImpedanceInputs};
use hapticgen_runtime::RigModel;

const BAND: f64 = 0.2;

const LAWS: [ImpedanceLaw; 4] = [
    ImpedanceLaw::ForceFeedback,
    ImpedanceLaw::AccelerationFeedback,
    ImpedanceLaw::NaturalInertia,
    ImpedanceLaw::JacobianTranspose,
];

fn torque(law: ImpedanceLaw, band: Option<f64>, qd: f64) -> (f64, ControlStatus) {
    let mut controller = ImpedanceController::new(law, [1.0], [0.01], [0.01]);
    controller.options.friction_compensation_band = band;
    let q = [0.3];
    let reference = TaskReference::at_rest([0.1]);
    let sensed = TaskSensing { operator_force: [0.2], acceleration: [1.5] };
    let out = controller.torque(&Joystick, &Joystick.terms(&q, &[qd]), &[qd], &reference, &sensed);
    (out.torque[0], out.status)
}

#[test]
fn off_is_the_papers_law() {
    // Controller 3 on the joystick (x = q, J = 1): u = g + B q̇ − (B_d q̇ + K_d (q − x_d)).
    for qd in [-2.0, -0.05, 0.0, 0.05, 2.0] {
        let (u, status) = torque(ImpedanceLaw::JacobianTranspose, None, qd);
        assert_eq!(status, ControlStatus::Ok);
        let expected =
            Joystick.gravity(&[0.3])[0] + Joystick.damping()[0] * qd - (0.01 * qd + 1.0 * (0.3 - 0.1));
        assert!((u - expected).abs() < 1e-15, "q̇ = {qd}: {u} vs {expected}");
    }
}

#[test]
fn on_every_law_adds_the_coulomb_friction_outside_the_band_and_a_ramp_inside() {
    for law in LAWS {
        for (qd, fraction) in [
            (-3.0, -1.0),
            (-BAND, -1.0),
            (-0.5 * BAND, -0.5),
            (0.0, 0.0),
            (0.25 * BAND, 0.25),
            (BAND, 1.0),
            (3.0, 1.0),
        ] {
            let (off, off_status) = torque(law, None, qd);
            let (on, on_status) = torque(law, Some(BAND), qd);
            assert_eq!((off_status, on_status), (ControlStatus::Ok, ControlStatus::Ok), "{law:?}");
            let added = on - off;
            let expected = fraction * JOINT_COULOMB_FRICTION;
            assert!(
                (added - expected).abs() < 1e-12,
                "{law:?} at q̇ = {qd}: added {added}, expected {expected}"
            );
        }
    }
}

#[test]
fn a_non_finite_band_is_refused() {
    for band in [f64::NAN, f64::INFINITY] {
        let (u, status) = torque(ImpedanceLaw::JacobianTranspose, Some(band), 1.0);
        assert_eq!((u, status), (0.0, ControlStatus::NonFiniteInput), "band {band}");
    }
}

#[test]
fn the_haptic_loop_feeds_the_friction_forward_when_set() {
    // The joint moves by 2 counts per tick (a steady 0.52 rad/s, outside the band), so the
    // compensated tick's torque exceeds the paper's by F_c once the velocity filter has settled.
    let run = |band: Option<f64>| {
        let mut controller = ImpedanceController::new(ImpedanceLaw::JacobianTranspose, [1.0], [0.0], [0.01]);
        controller.options.friction_compensation_band = band;
        let settings = HapticLoopSettings::for_rig(&Joystick, controller);
        let mut haptic =
            HapticLoop::new(Joystick, TaskReference::at_rest([0.0]), &settings).expect("usable rates");
        let mut torque = 0.0;
        for tick in 1..=200u32 {
            let inputs = ImpedanceInputs { encoder_counts: [2 * tick as i32], force_readings: [0.0], tick };
            let report = haptic.impedance_tick(&inputs);
            assert_eq!(report.command.fault, None);
            torque = report.command.torque[0];
        }
        torque
    };
    let added = run(Some(BAND)) - run(None);
    assert!((added - JOINT_COULOMB_FRICTION).abs() < 1e-9, "added {added}");
}
