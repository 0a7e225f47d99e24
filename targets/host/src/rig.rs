//! Rigs at run time: any model file as a [`RigModel`], and a wrapper that changes a rig's
//! drive trains for the simulator.
//!
//! * [`CompiledModel`] holds the terms of the paper's eq. (1)–(2) of one model, derived by
//!   `hapticgen_codegen::derive` and compiled into [`Tape`]s, optionally after
//!   scaling every body's mass and inertia (the plant/model mismatch the paper discusses in
//!   section 2: "assuming no modeling mismatch").
//! * [`TapeRig`] implements `RigModel<N, M, Scalar = f64>` on a [`CompiledModel`], so the
//!   runtime's controllers run on a model file the binary was not built with.
//! * [`SimRig`] wraps any rig and replaces its drive trains (finer encoder for ideal sensing,
//!   no limits when saturation is switched off); everything else is the wrapped rig's.

use std::cell::RefCell;
use std::sync::Arc;

use hapticgen_codegen::model::Coupling;
use hapticgen_codegen::sym::poly::Poly;
use hapticgen_codegen::CheckedModel;
use hapticgen_runtime::current_loop::CurrentLoopGains;
use hapticgen_runtime::{DriveTrain, RigModel, RigTerms};

use crate::tape::Tape;

/// The mechanics of one model compiled into evaluation tapes.
#[derive(Clone, Debug)]
pub struct CompiledModel {
    /// Number of joints `N`.
    pub joints: usize,
    /// Task-space dimension `M`.
    pub task_dim: usize,
    /// Outputs `D` (row-major, `N²`), `C q̇` (`N`), `g` (`N`).
    pub dynamics: Tape,
    /// Outputs `p` (`M`), `J` (row-major, `M·N`), `J̇ q̇` (`M`).
    pub kinematics: Tape,
    /// Output `C` (row-major, `N²`).
    pub coriolis: Tape,
    /// Output `J̇` (row-major, `M·N`).
    pub jacobian_dot: Tape,
    /// Diagonal of `B`.
    pub damping: Vec<f64>,
    /// Reflected rotor inertia on each joint's diagonal, `N_j² J_m,j` (through a coupling
    /// `C`: `Σ_k C_kj² N_k² J_m,k`; part of `D`).
    pub reflected_rotor_inertia: Vec<f64>,
    /// The model's coupling between joints and drives (`transmission`), if any.
    pub coupling: Option<Coupling>,
    /// Values of the model's tunable parameters.
    pub parameters: Vec<f64>,
    /// The drive train of each joint, in the runtime's form.
    pub drives: Vec<DriveTrain<f64>>,
    /// Backlash and friction of each joint's drive (the plant's; the controller's friction
    /// compensation reads the Coulomb friction too, `RigModel::coulomb_friction`).
    pub drive_extras: Vec<DriveExtras>,
    /// The factor applied to every body's mass and inertia.
    pub mass_scale: f64,
}

/// The parts of a drive the controller's rig terms leave out (model file): backlash and
/// static friction are simulated only; Coulomb friction is also fed forward by the friction
/// compensation when it is on.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DriveExtras {
    /// Total gearhead backlash, rad (joint side).
    pub backlash: f64,
    /// Coulomb (sliding) friction torque, N·m (joint side).
    pub coulomb_friction: f64,
    /// Static (breakaway) friction torque, N·m (joint side).
    pub static_friction: f64,
}

/// A copy of `model` whose bodies' masses and inertia tensors are multiplied by `factor`
/// (same geometry, denser material). Rotor inertias are not changed.
pub fn scale_masses(model: &CheckedModel, factor: f64) -> CheckedModel {
    let mut scaled = model.clone();
    for body in &mut scaled.model.bodies {
        body.mass = body.mass.scale(factor);
        body.inertia = body.inertia.clone().map(|row| row.map(|p| p.scale(factor)));
    }
    scaled
}

/// The runtime's drive trains of a model's joints.
pub fn drive_trains(model: &CheckedModel) -> Vec<DriveTrain<f64>> {
    model
        .joints
        .iter()
        .map(|joint| {
            let d = &joint.drive;
            DriveTrain {
                gear_ratio: d.gear_ratio,
                efficiency: d.efficiency,
                torque_constant: d.motor.torque_constant,
                resistance: d.motor.resistance,
                inductance: d.motor.inductance,
                rotor_inertia: d.motor.rotor_inertia,
                torque_limit: d.torque_limit,
                current_limit: d.current_limit,
                supply_voltage: d.supply_voltage,
                encoder_counts_per_turn: d.encoder.counts_per_turn,
                position_lower: joint.lower,
                position_upper: joint.upper,
            }
        })
        .collect()
}

impl CompiledModel {
    /// Derives and compiles `model` with body masses scaled by `mass_scale` (1 = nominal).
    pub fn new(model: &CheckedModel, mass_scale: f64) -> CompiledModel {
        let scaled = scale_masses(model, mass_scale);
        let mech = hapticgen_codegen::derive(&scaled);
        let n = mech.joints;
        let m = mech.task_dim;
        let flat = |rows: &[Vec<Poly>]| -> Vec<Poly> { rows.iter().flatten().cloned().collect() };
        let mut dynamics: Vec<Poly> = flat(&mech.inertia_matrix);
        dynamics.extend(mech.coriolis_times_qdot.iter().cloned());
        dynamics.extend(mech.gravity.iter().cloned());
        let mut kinematics: Vec<Poly> = mech.task.position.clone();
        kinematics.extend(flat(&mech.task.jacobian));
        kinematics.extend(mech.task.jacobian_dot_times_qdot.iter().cloned());
        let coriolis = flat(&mech.coriolis_matrix);
        let jacobian_dot = flat(&mech.task.jacobian_dot);
        let compile =
            |v: Vec<Poly>| Tape::compile_closed(&v.iter().collect::<Vec<_>>(), n, mech.closures.as_ref());
        let parameters = model.nominal_parameters();
        let nominal = hapticgen_codegen::eval::NominalAtoms(&parameters);
        CompiledModel {
            joints: n,
            task_dim: m,
            dynamics: compile(dynamics),
            kinematics: compile(kinematics),
            coriolis: compile(coriolis),
            jacobian_dot: compile(jacobian_dot),
            damping: mech.damping.iter().map(|p| p.eval(&nominal)).collect(),
            reflected_rotor_inertia: hapticgen_codegen::dynamics::reflected_rotor_inertia(model)
                .iter()
                .enumerate()
                .map(|(j, row)| row[j])
                .collect(),
            coupling: model.coupling.clone(),
            parameters,
            drives: drive_trains(model),
            drive_extras: model
                .joints
                .iter()
                .map(|j| DriveExtras {
                    backlash: j.drive.backlash,
                    coulomb_friction: j.drive.coulomb_friction,
                    static_friction: j.drive.static_friction,
                })
                .collect(),
            mass_scale,
        }
    }
}

fn vector<const K: usize>(values: &[f64]) -> [f64; K] {
    let mut out = [0.0; K];
    for (slot, v) in out.iter_mut().zip(values) {
        *slot = *v;
    }
    out
}

fn matrix<const R: usize, const C: usize>(values: &[f64]) -> [[f64; C]; R] {
    let mut out = [[0.0; C]; R];
    for (i, row) in out.iter_mut().enumerate() {
        for (j, slot) in row.iter_mut().enumerate() {
            *slot = values.get(i * C + j).copied().unwrap_or(0.0);
        }
    }
    out
}

/// Any model file as a rig for the runtime's controllers, evaluated through tapes.
///
/// The associated loop rates are the paper's (7.5 kHz, 1 kHz); the simulator schedules the
/// loops from the model's own `rates` and does not read them.
pub struct TapeRig<const N: usize, const M: usize> {
    model: Arc<CompiledModel>,
    current_gains: [CurrentLoopGains<f64>; N],
    scratch: RefCell<[Vec<f64>; 4]>,
}

impl<const N: usize, const M: usize> TapeRig<N, M> {
    /// A rig on `model` whose motors have the PI current-loop gains `current_gains` (one per
    /// joint); `None` unless the model has `N` joints and `M` task coordinates and `N` gains.
    pub fn new(model: Arc<CompiledModel>, current_gains: &[CurrentLoopGains<f64>]) -> Option<Self> {
        if model.joints != N || model.task_dim != M {
            return None;
        }
        let current_gains: [CurrentLoopGains<f64>; N] = current_gains.try_into().ok()?;
        let scratch = RefCell::new([
            model.dynamics.scratch(),
            model.kinematics.scratch(),
            model.coriolis.scratch(),
            model.jacobian_dot.scratch(),
        ]);
        Some(Self { model, current_gains, scratch })
    }

    fn run(&self, which: usize, q: &[f64; N], qd: &[f64; N], out: &mut [f64]) {
        let tape = match which {
            0 => &self.model.dynamics,
            1 => &self.model.kinematics,
            2 => &self.model.coriolis,
            _ => &self.model.jacobian_dot,
        };
        let mut scratch = self.scratch.borrow_mut();
        tape.eval(&mut scratch[which], q, qd, &self.model.parameters, out);
    }

    fn dynamics(&self, q: &[f64; N], qd: &[f64; N]) -> Vec<f64> {
        let mut out = vec![0.0; N * N + 2 * N];
        self.run(0, q, qd, &mut out);
        out
    }

    fn kinematics(&self, q: &[f64; N], qd: &[f64; N]) -> Vec<f64> {
        let mut out = vec![0.0; M + M * N + M];
        self.run(1, q, qd, &mut out);
        out
    }
}

impl<const N: usize, const M: usize> RigModel<N, M> for TapeRig<N, M> {
    type Scalar = f64;
    const NAME: &'static str = "tape";
    const CURRENT_LOOP_HZ: u32 = 7500;
    const IMPEDANCE_LOOP_HZ: u32 = 1000;

    fn inertia_matrix(&self, q: &[f64; N]) -> [[f64; N]; N] {
        matrix(&self.dynamics(q, &[0.0; N]))
    }
    fn coriolis_matrix(&self, q: &[f64; N], qd: &[f64; N]) -> [[f64; N]; N] {
        let mut out = vec![0.0; N * N];
        self.run(2, q, qd, &mut out);
        matrix(&out)
    }
    fn coriolis_times_qdot(&self, q: &[f64; N], qd: &[f64; N]) -> [f64; N] {
        vector(&self.dynamics(q, qd)[N * N..])
    }
    fn gravity(&self, q: &[f64; N]) -> [f64; N] {
        vector(&self.dynamics(q, &[0.0; N])[N * N + N..])
    }
    fn damping(&self) -> [f64; N] {
        vector(&self.model.damping)
    }
    fn position(&self, q: &[f64; N]) -> [f64; M] {
        vector(&self.kinematics(q, &[0.0; N]))
    }
    fn jacobian(&self, q: &[f64; N]) -> [[f64; N]; M] {
        matrix(&self.kinematics(q, &[0.0; N])[M..])
    }
    fn jacobian_dot(&self, q: &[f64; N], qd: &[f64; N]) -> [[f64; N]; M] {
        let mut out = vec![0.0; M * N];
        self.run(3, q, qd, &mut out);
        matrix(&out)
    }
    fn jacobian_dot_times_qdot(&self, q: &[f64; N], qd: &[f64; N]) -> [f64; M] {
        vector(&self.kinematics(q, qd)[M + M * N..])
    }
    fn terms(&self, q: &[f64; N], qd: &[f64; N]) -> RigTerms<f64, N, M> {
        let dynamics = self.dynamics(q, qd);
        let kinematics = self.kinematics(q, qd);
        RigTerms {
            inertia_matrix: matrix(&dynamics),
            coriolis_times_qdot: vector(&dynamics[N * N..]),
            gravity: vector(&dynamics[N * N + N..]),
            position: vector(&kinematics),
            jacobian: matrix(&kinematics[M..]),
            jacobian_dot_times_qdot: vector(&kinematics[M + M * N..]),
        }
    }
    fn drives(&self) -> [DriveTrain<f64>; N] {
        let mut out = [self.model.drives[0]; N];
        for (slot, d) in out.iter_mut().zip(&self.model.drives) {
            *slot = *d;
        }
        out
    }
    fn current_loop_gains(&self) -> [CurrentLoopGains<f64>; N] {
        self.current_gains
    }
    fn coulomb_friction(&self) -> [f64; N] {
        let mut out = [0.0; N];
        for (slot, extras) in out.iter_mut().zip(&self.model.drive_extras) {
            *slot = extras.coulomb_friction;
        }
        out
    }
    fn coupling(&self) -> Option<hapticgen_runtime::Coupling<f64, N>> {
        self.model.coupling.as_ref().map(|coupling| hapticgen_runtime::Coupling {
            drive_from_joint: std::array::from_fn(|k| vector(&coupling.drive_from_joint[k])),
            joint_from_drive: std::array::from_fn(|j| vector(&coupling.joint_from_drive[j])),
        })
    }
}

/// A rig whose drive trains are replaced (everything else is `R`'s).
#[derive(Clone, Copy, Debug)]
pub struct SimRig<R, const N: usize> {
    /// The wrapped rig.
    pub inner: R,
    /// The drive trains reported to the controller.
    pub drives: [DriveTrain<f64>; N],
}

impl<R, const N: usize, const M: usize> RigModel<N, M> for SimRig<R, N>
where
    R: RigModel<N, M, Scalar = f64>,
{
    type Scalar = f64;
    const NAME: &'static str = R::NAME;
    const CURRENT_LOOP_HZ: u32 = R::CURRENT_LOOP_HZ;
    const IMPEDANCE_LOOP_HZ: u32 = R::IMPEDANCE_LOOP_HZ;

    fn inertia_matrix(&self, q: &[f64; N]) -> [[f64; N]; N] {
        self.inner.inertia_matrix(q)
    }
    fn coriolis_matrix(&self, q: &[f64; N], qd: &[f64; N]) -> [[f64; N]; N] {
        self.inner.coriolis_matrix(q, qd)
    }
    fn coriolis_times_qdot(&self, q: &[f64; N], qd: &[f64; N]) -> [f64; N] {
        self.inner.coriolis_times_qdot(q, qd)
    }
    fn gravity(&self, q: &[f64; N]) -> [f64; N] {
        self.inner.gravity(q)
    }
    fn damping(&self) -> [f64; N] {
        self.inner.damping()
    }
    fn position(&self, q: &[f64; N]) -> [f64; M] {
        self.inner.position(q)
    }
    fn jacobian(&self, q: &[f64; N]) -> [[f64; N]; M] {
        self.inner.jacobian(q)
    }
    fn jacobian_dot(&self, q: &[f64; N], qd: &[f64; N]) -> [[f64; N]; M] {
        self.inner.jacobian_dot(q, qd)
    }
    fn jacobian_dot_times_qdot(&self, q: &[f64; N], qd: &[f64; N]) -> [f64; M] {
        self.inner.jacobian_dot_times_qdot(q, qd)
    }
    fn terms(&self, q: &[f64; N], qd: &[f64; N]) -> RigTerms<f64, N, M> {
        self.inner.terms(q, qd)
    }
    fn coupling(&self) -> Option<hapticgen_runtime::Coupling<f64, N>> {
        self.inner.coupling()
    }
    fn coulomb_friction(&self) -> [f64; N] {
        self.inner.coulomb_friction()
    }
    fn drives(&self) -> [DriveTrain<f64>; N] {
        self.drives
    }
    fn current_loop_gains(&self) -> [CurrentLoopGains<f64>; N] {
        self.inner.current_loop_gains()
    }
}
