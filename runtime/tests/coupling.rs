//! A rig whose two drives turn its two joints through a coupling `a = C q`, `C = [[1, 1],
//! [0, 1]]`: drive 1 turns the sum of the joint angles (a motor on the base that turns an
//! absolute angle, as the PHANToM's forearm motor), drive 2 joint 2 alone. `C` is not
//! symmetric, so a transposition shows. The haptic loop reads the joints from the drives'
//! counters by `C⁻¹`, limits and commands the drives' torques `C⁻ᵀ τ`, and feeds each drive's
//! own back EMF forward. Every expected value is worked out here by hand, apart from the
//! runtime.

use crate::common::re40_drive;
use hapticgen_runtime::control::{ImpedanceController, ImpedanceLaw, TaskReference};
use hapticgen_runtime::current_loop::CurrentLoopGains;
use hapticgen_runtime::tick::{HapticLoop, HapticLoopSettings, ImpedanceInputs};
use hapticgen_runtime::{Coupling, DriveTrain, RigModel, RigTerms};

/// Each drive's gear ratio (motor turns per output turn).
const RATIO: f64 = 5.0;
const STIFFNESS: f64 = 2.0;

/// Two joints in the task (`x = q`), constant inertia, no gravity.
struct Differential;

impl RigModel<2, 2> for Differential {
    type Scalar = f64;
    const NAME: &'static str = "differential";
    const CURRENT_LOOP_HZ: u32 = 7500;
    const IMPEDANCE_LOOP_HZ: u32 = 1000;
    fn inertia_matrix(&self, _q: &[f64; 2]) -> [[f64; 2]; 2] {
        [[1e-3, 0.0], [0.0, 2e-3]]
    }
    fn coriolis_matrix(&self, _q: &[f64; 2], _qd: &[f64; 2]) -> [[f64; 2]; 2] {
        [[0.0; 2]; 2]
    }
    fn coriolis_times_qdot(&self, _q: &[f64; 2], _qd: &[f64; 2]) -> [f64; 2] {
        [0.0; 2]
    }
    fn gravity(&self, _q: &[f64; 2]) -> [f64; 2] {
        [0.0; 2]
    }
    fn damping(&self) -> [f64; 2] {
        [0.0; 2]
    }
    fn position(&self, q: &[f64; 2]) -> [f64; 2] {
        *q
    }
    fn jacobian(&self, _q: &[f64; 2]) -> [[f64; 2]; 2] {
        [[1.0, 0.0], [0.0, 1.0]]
    }
    fn jacobian_dot(&self, _q: &[f64; 2], _qd: &[f64; 2]) -> [[f64; 2]; 2] {
        [[0.0; 2]; 2]
    }
    fn jacobian_dot_times_qdot(&self, _q: &[f64; 2], _qd: &[f64; 2]) -> [f64; 2] {
        [0.0; 2]
    }
    fn terms(&self, q: &[f64; 2], qd: &[f64; 2]) -> RigTerms<f64, 2, 2> {
        RigTerms {
            inertia_matrix: self.inertia_matrix(q),
            coriolis_times_qdot: self.coriolis_times_qdot(q, qd),
            gravity: self.gravity(q),
            position: self.position(q),
            jacobian: self.jacobian(q),
            jacobian_dot_times_qdot: self.jacobian_dot_times_qdot(q, qd),
        }
    }
    fn drives(&self) -> [DriveTrain<f64>; 2] {
        let drive =
            DriveTrain { gear_ratio: RATIO, position_lower: -1.0, position_upper: 1.0, ..re40_drive() };
        [drive; 2]
    }
    fn current_loop_gains(&self) -> [CurrentLoopGains<f64>; 2] {
        [CurrentLoopGains {
            kp: 0.0,
            ki: 0.0,
            sample_period: 1.0 / 7500.0,
            proportional_setpoint_weight: 0.0,
        }; 2]
    }
    fn coupling(&self) -> Option<Coupling<f64, 2>> {
        Some(Coupling {
            drive_from_joint: [[1.0, 1.0], [0.0, 1.0]],
            joint_from_drive: [[1.0, -1.0], [0.0, 1.0]],
        })
    }
}

/// The loop with the spring of `STIFFNESS` to the origin, homed at joint angles
/// `zero_offset` (where the counters read zero).
fn haptic_loop(zero_offset: [f64; 2]) -> HapticLoop<Differential, TaskReference<f64, 2>, 2, 2> {
    let controller =
        ImpedanceController::new(ImpedanceLaw::JacobianTranspose, [STIFFNESS; 2], [0.0; 2], [0.01; 2]);
    let mut settings = HapticLoopSettings::for_rig(&Differential, controller);
    settings.zero_offset = zero_offset;
    HapticLoop::new(Differential, TaskReference::at_rest([0.0; 2]), &settings).unwrap()
}

/// A drive's output angle for its counter reading.
fn output_angle(counts: i32) -> f64 {
    let drive = re40_drive();
    2.0 * std::f64::consts::PI * f64::from(counts) / (f64::from(drive.encoder_counts_per_turn) * RATIO)
}

#[test]
fn joints_come_from_the_drives_counters_and_torques_go_back_through_the_transpose() {
    let mut haptic = haptic_loop([0.0; 2]);
    let counts = [300, 100];
    let report =
        haptic.impedance_tick(&ImpedanceInputs { encoder_counts: counts, force_readings: [0.0; 2], tick: 1 });
    assert_eq!(report.command.fault, None);
    // q₁ = a₁ − a₂, q₂ = a₂; the spring to the origin gives τ = −K q.
    let (a1, a2) = (output_angle(counts[0]), output_angle(counts[1]));
    // The estimator keeps the drives' outputs; the loop reports the joints.
    let drives = haptic.estimator().state().position;
    assert!((drives[0] - a1).abs() < 1e-15 && (drives[1] - a2).abs() < 1e-15, "{drives:?}");
    let joints = haptic.joint_state().position;
    assert!((joints[0] - (a1 - a2)).abs() < 1e-15 && (joints[1] - a2).abs() < 1e-15, "{joints:?}");
    let joint_torque = [-STIFFNESS * (a1 - a2), -STIFFNESS * a2];
    for (got, want) in report.command.torque.iter().zip(joint_torque) {
        assert!(
            (got - want).abs() < 1e-12,
            "joint torques {:?}, want {joint_torque:?}",
            report.command.torque
        );
    }
    // Each drive makes τ_a = C⁻ᵀ τ at its output, (τ₁, τ₂ − τ₁), from N η k_t i.
    let drive = re40_drive();
    let per_amp = RATIO * drive.efficiency * drive.torque_constant;
    let drive_torque = [joint_torque[0], joint_torque[1] - joint_torque[0]];
    for (got, want) in haptic.current_setpoints().iter().zip(drive_torque) {
        assert!((got - want / per_amp).abs() < 1e-12, "currents {:?}", haptic.current_setpoints());
    }
    assert!(drive_torque.iter().all(|t| t.abs() > 1e-3), "both drives must carry torque: {drive_torque:?}");
}

#[test]
fn a_limited_drive_limits_the_joint_torques_it_makes() {
    // Homed at q = (0.8, 0.8) rad (drive outputs C q = (1.6, 0.8)), counters at zero: the
    // spring gives τ = −K q = (−1.6, −1.6) N·m, so τ_a = C⁻ᵀ τ = (−1.6, 0): beyond drive 1's
    // limit alone, min(3 N·m, N k_t i_max = 1.51 N·m). Drive 1's torque is clamped, drive
    // 2's is not, and the joints get Cᵀ τ_a = (τ_a1, τ_a1 + τ_a2) of the limited ones.
    let mut haptic = haptic_loop([0.8, 0.8]);
    let report =
        haptic.impedance_tick(&ImpedanceInputs { encoder_counts: [0; 2], force_readings: [0.0; 2], tick: 1 });
    let drive = re40_drive();
    let limit = drive.torque_limit.min(RATIO * drive.torque_constant * drive.current_limit);
    assert!(STIFFNESS * 0.8 > limit, "the pose must exceed the limit");
    assert_eq!(report.command.clamped, [true, false]);
    let expected = [-limit, -limit];
    for (got, want) in report.command.torque.iter().zip(expected) {
        assert!((got - want).abs() < 1e-12, "joint torques {:?}, want {expected:?}", report.command.torque);
    }
}

#[test]
fn each_drive_feeds_forward_its_own_back_emf() {
    // Only drive 2's counter moves: its output turns (ȧ₂ ≠ 0), drive 1's stands still, though
    // both joints move (q̇ = C⁻¹ ȧ = (−ȧ₂, ȧ₂)). The voltages (PI gains zero) are the
    // feedforward alone: k_t N ȧ_k.
    let mut haptic = haptic_loop([0.0; 2]);
    let drive = re40_drive();
    let (mut tick, mut counts, mut drive_velocity) = (0, 0, [0.0; 2]);
    let mut moving_checked = 0;
    for _ in 0..200 {
        let (out, due) = haptic.current_tick(&[0.0; 2]);
        for k in 0..2 {
            let expected = drive.torque_constant * RATIO * drive_velocity[k];
            assert!(
                (out[k].voltage - expected).abs() < 1e-12,
                "drive {k}: {} V, want {expected} V",
                out[k].voltage
            );
        }
        if drive_velocity[1].abs() > 0.1 {
            moving_checked += 1;
        }
        if due {
            tick += 1;
            counts += 10;
            let inputs = ImpedanceInputs { encoder_counts: [0, counts], force_readings: [0.0; 2], tick };
            assert_eq!(haptic.impedance_tick(&inputs).command.fault, None);
            drive_velocity = haptic.estimator().state().velocity;
        }
    }
    assert!(moving_checked > 50, "drive 2 must have turned: {moving_checked} ticks");
    assert_eq!(drive_velocity[0], 0.0);
}
