//! The scenarios a variant can name in `targets/firmware/variants.txt`. Each module offers
//! `Run<R>` (the scenario type for a rig `R`) and `new(name, rig, setup, profile)`.

use hapticgen_fw_control::Controller;
use hapticgen_runtime::control::{ControlOptions, ImpedanceController, ImpedanceLaw, ImpedanceParameters};
use hapticgen_runtime::estimation::{EstimatorSettings, ForceSensorCalibration};
use hapticgen_runtime::tick::HapticLoopSettings;
use hapticgen_runtime::{Real, RigModel};

use crate::plant::SimBoard;
use crate::scenario::{trace_tolerance, Load, Scenario, Setup};

fn s<S: Real>(value: f64) -> S {
    S::from_f64(value)
}

fn settings<S: Real, const N: usize, const M: usize>(
    controller: ImpedanceController<S, M>,
    setup: &Setup<S>,
    impedance_hz: u32,
    q0: [S; N],
) -> HapticLoopSettings<S, N, M> {
    HapticLoopSettings {
        controller,
        estimator: EstimatorSettings {
            sample_period: S::ONE / s(f64::from(impedance_hz)),
            velocity_cutoff_hz: s(50.0),
            acceleration_cutoff_hz: s(20.0),
        },
        zero_offset: q0,
        initial_counts: [0; N],
        force_calibration: ForceSensorCalibration { scale: [S::ONE; M], offset: [S::ZERO; M] },
        current_gains: setup.current_gains,
        max_tick_gap: 1,
    }
}

/// The paper's Fig. 4 on a 1-DOF rig: Controller 2, second variant (`M_d = W⁻¹`),
/// `K_d = 1 N·m/rad`, `B_d = 0.01 N·m·s/rad`, reference `x_d = 0` (upright), a 1 N·m step
/// of operator torque at 0.1 s held to the end of the 2 s run. The closed loop is
/// `D q̈ + B_d q̇ + K_d q = τ_op`: a lightly damped (ζ ≈ 0.09) 2.9 Hz oscillation settling at
/// 1 rad.
pub mod fig4_step {
    use super::*;
    use hapticgen_runtime::control::TaskReference;

    /// The scenario type for a rig `R`.
    pub type Run<R> = Scenario<R, TaskReference<<R as RigModel<1, 1>>::Scalar, 1>, 1, 1>;

    /// Builds the run; `None` if the rig's rates are unusable.
    pub fn new<R: hapticgen_runtime::fused::FusedImpedance<1, 1> + Clone>(
        name: &'static str,
        rig: R,
        setup: &Setup<R::Scalar>,
        profile: bool,
    ) -> Option<Run<R>> {
        let controller = ImpedanceController {
            law: ImpedanceLaw::Controller2Mobility,
            parameters: ImpedanceParameters {
                stiffness: [s(1.0)],
                damping: [s(0.01)],
                mass: [R::Scalar::ONE],
            },
            options: ControlOptions {
                omit_damping_compensation: false,
                min_abs_jacobian_determinant: s(1e-6),
                spring_lead_time: s(0.0),
            },
        };
        let q0 = [R::Scalar::ZERO];
        let fast = R::CURRENT_LOOP_HZ;
        let period = R::Scalar::ONE / s(f64::from(fast));
        let board = SimBoard::new(rig.clone(), q0, period, setup.sense_time_constant);
        let reference = TaskReference::at_rest([R::Scalar::ZERO]);
        let settings = settings(controller, setup, R::IMPEDANCE_LOOP_HZ, q0);
        let controller = Controller::new(rig, reference, &settings, profile)?;
        let load = Load { start: fast / 10, end: u32::MAX, force: [s(1.0)] };
        let tolerance = trace_tolerance(board.rig(), &q0, R::Scalar::ZERO);
        let mut run = Scenario::new(name, controller, board, load, 2 * fast, fast / 100);
        run.task_tolerance = tolerance;
        Some(run)
    }
}

/// A virtual wall on a 2-DOF planar rig with Controller 3 and the proxy renderer: the
/// end-effector starts in free space at `q = (π/2, 0)`, a solid wall's face 5 mm to its +x1
/// side; the operator pushes with 2 N along +x1 from 0.1 s to 1.0 s, then lets go; 1.5 s in
/// all. `K_d`, `B_d` of the wall and of free space, and the anti-drift grid, come from the
/// model's `rendering:` section (1500 N/m, 5 N·s/m, 0.3 mm for the paper's rig).
pub mod wall_contact {
    use super::*;
    use hapticgen_runtime::render::{ObjectKind, Scene, Shape, VirtualObject};

    /// The scenario type for a rig `R`.
    pub type Run<R> = Scenario<R, Scene<<R as RigModel<2, 2>>::Scalar, 1, 1>, 2, 2>;

    /// Builds the run; `None` if the rig's rates are unusable or the model has no
    /// `rendering:` section.
    pub fn new<R: hapticgen_runtime::fused::FusedImpedance<2, 2> + Clone>(
        name: &'static str,
        rig: R,
        setup: &Setup<R::Scalar>,
        profile: bool,
    ) -> Option<Run<R>> {
        let [grid, wall_stiffness, wall_damping] = setup.rendering?;
        let q0 = [s(core::f64::consts::FRAC_PI_2), R::Scalar::ZERO];
        let start = rig.position(&q0);
        let mut scene = Scene::new(wall_stiffness, wall_damping, grid);
        let half = [s(0.05), s(0.1)];
        scene.add(VirtualObject {
            shape: Shape::Rectangle {
                center: [start[0] + s(0.005) + half[0], start[1]],
                half_extents: half,
                angle: R::Scalar::ZERO,
            },
            kind: ObjectKind::Solid,
            stiffness: wall_stiffness,
            damping: wall_damping,
        })?;
        let controller = ImpedanceController {
            law: ImpedanceLaw::Controller3,
            parameters: ImpedanceParameters {
                stiffness: [wall_stiffness; 2],
                damping: [wall_damping; 2],
                mass: [R::Scalar::ONE; 2],
            },
            options: ControlOptions {
                omit_damping_compensation: false,
                min_abs_jacobian_determinant: s(1e-6),
                spring_lead_time: s(0.0),
            },
        };
        let fast = R::CURRENT_LOOP_HZ;
        let period = R::Scalar::ONE / s(f64::from(fast));
        let board = SimBoard::new(rig.clone(), q0, period, setup.sense_time_constant);
        let settings = settings(controller, setup, R::IMPEDANCE_LOOP_HZ, q0);
        let controller = Controller::new(rig, scene, &settings, profile)?;
        let load = Load { start: fast / 10, end: fast, force: [s(2.0), R::Scalar::ZERO] };
        // Two grid spacings: on the rebound after the operator lets go, each run snaps the
        // proxy through its own sequence of grid nodes (a discontinuous, path-dependent map),
        // so the runs can differ by a node at the moment of a jump and by a node at rest.
        let tolerance = trace_tolerance(board.rig(), &q0, grid + grid);
        let mut run = Scenario::new(name, controller, board, load, 3 * fast / 2, fast / 100);
        run.task_tolerance = tolerance;
        Some(run)
    }
}
