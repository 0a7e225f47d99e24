//! The simulated device: rigid-body dynamics of eq. (1) with the drive's electrical and
//! mechanical non-idealities, integrated with a fixed-step classical Runge–Kutta (RK4) method.
//!
//! Per joint `j` (all torques joint-side, `k_j = N_j η_j k_t,j` the torque per motor ampere):
//!
//! * **Links** (eq. (1) without the rotor): `D_l(q) q̈ + C(q, q̇) q̇ + B q̇ + g(q) = τ_g + τ_ext`,
//!   where `D_l = D − diag(N² J_m)` and `τ_ext = Jᵀ f_op` is the operator's torque.
//! * **Gearhead backlash** (`backlash` of the drive, 0.8° in the paper): the rotor (joint-side
//!   angle `θ`, inertia `N² J_m`) drives the link through a dead zone of total width `b`:
//!   `τ_g = k_g (δ ∓ b/2) + c_g δ̇` when `|δ| > b/2` (`δ = θ − q`, the damping never pulls
//!   the teeth apart), zero inside the gap; `k_g` = [`GEAR_STIFFNESS`] and `c_g` gives the
//!   mesh a damping ratio of [`GEAR_DAMPING_RATIO`] on the rotor inertia.
//!   Rotor: `N² J_m θ̈ = k i − τ_g + τ_f`. Without backlash, `θ = q` and the full `D` is used.
//! * **Friction** `τ_f` on the rotor (Karnopp stick–slip model): outside the velocity band
//!   `|θ̇| > `[`STICK_VELOCITY`] it is Coulomb friction `−τ_c sign θ̇`; inside the band the
//!   joint sticks: friction cancels the other torques on the rotor (`τ_net`) and nulls the
//!   residual velocity over [`STICK_TIME`], `τ_f = −clamp(τ_net + J θ̇ / t_s, ±τ_s)`, so it
//!   breaks away only when `|τ_net|` exceeds the static friction `τ_s`.
//! * **Armature** (paper, section 2): `L di/dt = V − R i − k_t N θ̇` (back-EMF), with `V`
//!   clamped to the supply when saturation is on; the current loop measures `i` through the
//!   anti-aliasing filter, modelled as the first-order lag its design assumes.
//! * **Encoder** on the motor shaft: `counts = round(θ N cpt / 2π)` (quantisation), wrapping
//!   like a hardware counter.
//!
//! * **Transmission** (`a = C q`): the drives turn their outputs `a`, so the encoders count
//!   `C q`, the motors' torques reach the joints as `Cᵀ τ_a`, each back EMF is its own
//!   output's, and friction acts on each motor's output velocity `ȧ = C q̇` against the
//!   torque on it, `C⁻ᵀ τ_net` (backlash with a transmission is refused).
//!
//! The inputs (armature voltages, operator torques) are held over a step (zero-order hold).
//! Every effect can be switched off through [`Effects`].

use std::sync::Arc;

use hapticgen_runtime::linalg;

use crate::rig::CompiledModel;

/// Gear mesh stiffness when backlash is simulated, N·m/rad (joint side).
pub const GEAR_STIFFNESS: f64 = 2000.0;
/// Damping ratio of the gear mesh on the rotor inertia.
pub const GEAR_DAMPING_RATIO: f64 = 0.3;
/// Half-width of the sticking velocity band of the friction model, rad/s (joint side).
pub const STICK_VELOCITY: f64 = 0.01;
/// Time constant with which a sticking joint's residual velocity is nulled, s.
pub const STICK_TIME: f64 = 2e-3;

/// Encoder counts per radian at a drive's output: `cpt N / 2π` for `counts_per_turn` counts per
/// motor turn through a gear of ratio `N`. The host's one scale between encoder counts and
/// angles: the plant counts with it ([`Plant::encoder_counts`]) and reads counts back as
/// angles with it ([`output_angle_at_counts`]).
pub fn counts_per_radian(counts_per_turn: u32, gear_ratio: f64) -> f64 {
    f64::from(counts_per_turn) * gear_ratio / std::f64::consts::TAU
}

/// The drive's output angle, rad, that encoder `counts` stand for: `counts / (cpt N / 2π)`
/// ([`counts_per_radian`]); the joint angle itself without a transmission. What a controller
/// decoding the counts reads, before its own zero offset.
pub fn output_angle_at_counts(counts: i32, counts_per_turn: u32, gear_ratio: f64) -> f64 {
    f64::from(counts) / counts_per_radian(counts_per_turn, gear_ratio)
}

/// Which non-idealities the simulation includes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Effects {
    /// Coulomb and static friction of the drives.
    pub friction: bool,
    /// Gearhead backlash.
    pub backlash: bool,
    /// Encoder quantisation at the model's counts per turn (off: 2²² counts per turn).
    pub encoder_quantisation: bool,
    /// Force-sensor noise, quantisation and full-scale clipping.
    pub sensor_noise: bool,
    /// Torque limit (controller) and supply-voltage limit (current loop and bridge).
    pub saturation: bool,
    /// Armature dynamics with back-EMF (off: the motor current equals its setpoint).
    pub motor_electrics: bool,
}

impl Effects {
    /// Every effect on: the device as built.
    pub const ALL: Effects = Effects {
        friction: true,
        backlash: true,
        encoder_quantisation: true,
        sensor_noise: true,
        saturation: true,
        motor_electrics: true,
    };

    /// Ideal mechanics and sensing; the electrical dynamics and limits of the drive stay.
    pub const IDEAL: Effects = Effects {
        friction: false,
        backlash: false,
        encoder_quantisation: false,
        sensor_noise: false,
        saturation: true,
        motor_electrics: true,
    };

    /// Parses a comma-separated list of effect names to switch off (`friction`, `backlash`,
    /// `encoder`, `sensor`, `saturation`, `electrics`, or `all`).
    pub fn without(mut self, names: &str) -> Result<Effects, String> {
        for name in names.split(',').map(str::trim).filter(|s| !s.is_empty()) {
            match name {
                "friction" => self.friction = false,
                "backlash" => self.backlash = false,
                "encoder" => self.encoder_quantisation = false,
                "sensor" => self.sensor_noise = false,
                "saturation" => self.saturation = false,
                "electrics" => self.motor_electrics = false,
                "all" => self = Effects::IDEAL,
                other => {
                    return Err(format!(
                        "unknown effect `{other}`; expected friction, backlash, encoder, sensor, \
                         saturation, electrics or all"
                    ))
                }
            }
        }
        Ok(self)
    }
}

/// The continuous state of the device.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlantState<const N: usize> {
    /// Link angles `q`.
    pub q: [f64; N],
    /// Link velocities `q̇`.
    pub qd: [f64; N],
    /// Rotor angles, joint side (`θ`; equal to `q` without backlash).
    pub theta: [f64; N],
    /// Rotor velocities, joint side.
    pub theta_dot: [f64; N],
    /// Armature currents, A.
    pub current: [f64; N],
    /// Currents as measured through the anti-aliasing filter, A.
    pub measured_current: [f64; N],
}

impl<const N: usize> PlantState<N> {
    fn axpy(&self, h: f64, d: &PlantState<N>) -> PlantState<N> {
        let f = |a: &[f64; N], b: &[f64; N]| std::array::from_fn(|i| a[i] + h * b[i]);
        PlantState {
            q: f(&self.q, &d.q),
            qd: f(&self.qd, &d.qd),
            theta: f(&self.theta, &d.theta),
            theta_dot: f(&self.theta_dot, &d.theta_dot),
            current: f(&self.current, &d.current),
            measured_current: f(&self.measured_current, &d.measured_current),
        }
    }
}

/// Per-joint drive constants of the plant.
#[derive(Clone, Copy, Debug)]
struct Drive {
    torque_per_amp: f64,
    back_emf: f64,
    resistance: f64,
    inductance: f64,
    supply: f64,
    rotor: f64,
    half_backlash: f64,
    gear_damping: f64,
    coulomb: f64,
    stiction: f64,
    counts_per_radian: f64,
}

/// The simulated device with `N` joints and an `M`-dimensional task space.
pub struct Plant<const N: usize, const M: usize> {
    model: Arc<CompiledModel>,
    effects: Effects,
    drives: [Drive; N],
    /// The transmission's `C` (drive outputs `a = C θ`); `None`: each drive turns its joint.
    coupling: Option<[[f64; N]; N]>,
    /// `C⁻¹`, which maps joint torques to the drives' (`C⁻ᵀ τ`) for friction on the motor side.
    joint_from_drive: Option<[[f64; N]; N]>,
    filter_time_constant: f64,
    dynamics_scratch: Vec<f64>,
    dynamics_out: Vec<f64>,
    kinematics_scratch: Vec<f64>,
    kinematics_out: Vec<f64>,
    /// The state.
    pub state: PlantState<N>,
}

/// Task-space kinematics of the device at its current state.
#[derive(Clone, Copy, Debug)]
pub struct TaskKinematics<const N: usize, const M: usize> {
    /// Position `p(q)`.
    pub position: [f64; M],
    /// Velocity `J q̇`.
    pub velocity: [f64; M],
    /// Jacobian `J(q)`.
    pub jacobian: [[f64; N]; M],
}

impl<const N: usize, const M: usize> Plant<N, M> {
    /// A plant at rest at `q0` (with backlash, the rotor pressed against the teeth that carry
    /// the gravity load; zero current).
    /// `counts_per_turn` are the encoder resolutions the controller decodes with;
    /// `filter_time_constant` is the current-sense lag, s.
    pub fn new(
        model: Arc<CompiledModel>,
        effects: Effects,
        q0: [f64; N],
        counts_per_turn: [u32; N],
        filter_time_constant: f64,
    ) -> Result<Self, String> {
        if model.joints != N || model.task_dim != M {
            return Err("error: the plant model's dimensions differ from the controller's".into());
        }
        let coupling: Option<[[f64; N]; N]> = model.coupling.as_ref().map(|coupling| {
            std::array::from_fn(|k| std::array::from_fn(|j| coupling.drive_from_joint[k][j]))
        });
        let joint_from_drive: Option<[[f64; N]; N]> = model.coupling.as_ref().map(|coupling| {
            std::array::from_fn(|j| std::array::from_fn(|k| coupling.joint_from_drive[j][k]))
        });
        if coupling.is_some()
            && effects.backlash
            && model.drive_extras.iter().any(|extras| extras.backlash > 0.0)
        {
            return Err("error: the simulator models backlash per joint, and this model's drives turn its \
                        joints through a transmission: set the drives' backlash to 0"
                .into());
        }
        let drives: [Drive; N] = std::array::from_fn(|j| {
            let d = &model.drives[j];
            let extras = &model.drive_extras[j];
            let rotor = model.reflected_rotor_inertia[j];
            let half_backlash = if effects.backlash { 0.5 * extras.backlash.max(0.0) } else { 0.0 };
            let (coulomb, stiction) = if effects.friction {
                (
                    extras.coulomb_friction.max(0.0),
                    extras.static_friction.max(extras.coulomb_friction).max(0.0),
                )
            } else {
                (0.0, 0.0)
            };
            Drive {
                torque_per_amp: d.gear_ratio * d.efficiency * d.torque_constant,
                back_emf: d.torque_constant * d.gear_ratio,
                resistance: d.resistance,
                inductance: d.inductance,
                supply: if effects.saturation { d.supply_voltage } else { f64::INFINITY },
                rotor,
                half_backlash,
                gear_damping: 2.0 * GEAR_DAMPING_RATIO * (GEAR_STIFFNESS * rotor).sqrt(),
                coulomb,
                stiction,
                counts_per_radian: counts_per_radian(counts_per_turn[j], d.gear_ratio),
            }
        });
        // At rest the links lean on the gear teeth: the gear carries the gravity load.
        let mut scratch = model.dynamics.scratch();
        let mut out = vec![0.0; model.dynamics.len()];
        model.dynamics.eval(&mut scratch, &q0, &[0.0; N], &model.parameters, &mut out);
        let theta0: [f64; N] = std::array::from_fn(|j: usize| {
            let load: f64 = out[N * N + N + j];
            let half = drives[j].half_backlash;
            if half > 0.0 && load != 0.0 {
                q0[j] + load.signum() * (half + load.abs() / GEAR_STIFFNESS)
            } else {
                q0[j]
            }
        });
        let state = PlantState {
            q: q0,
            qd: [0.0; N],
            theta: theta0,
            theta_dot: [0.0; N],
            current: [0.0; N],
            measured_current: [0.0; N],
        };
        Ok(Self {
            dynamics_scratch: model.dynamics.scratch(),
            dynamics_out: vec![0.0; model.dynamics.len()],
            kinematics_scratch: model.kinematics.scratch(),
            kinematics_out: vec![0.0; model.kinematics.len()],
            model,
            effects,
            drives,
            coupling,
            joint_from_drive,
            filter_time_constant: filter_time_constant.max(0.0),
            state,
        })
    }

    /// The plant's model (possibly with perturbed masses).
    pub fn model(&self) -> &CompiledModel {
        &self.model
    }

    /// Whether backlash is simulated (rotor and link are separate bodies).
    fn has_backlash(&self) -> bool {
        self.drives.iter().any(|d| d.half_backlash > 0.0)
    }

    /// Encoder counters (motor shaft), wrapping like 32-bit hardware counters.
    pub fn encoder_counts(&self) -> [i32; N] {
        let output_angle = self.drive_outputs(&self.state.theta);
        std::array::from_fn(|j| {
            let counts = (output_angle[j] * self.drives[j].counts_per_radian).round();
            (counts as i64) as i32
        })
    }

    /// The drives' outputs `C x` for joint-side values `x` (angles, velocities); `x` itself
    /// without a transmission.
    fn drive_outputs(&self, joint_side: &[f64; N]) -> [f64; N] {
        match &self.coupling {
            Some(coupling) => linalg::mat_vec(coupling, joint_side),
            None => *joint_side,
        }
    }

    /// The joint torques `Cᵀ τ_a` the drives' output torques `τ_a` make; `τ_a` itself without a
    /// transmission.
    fn joint_torques(&self, drive_torques: &[f64; N]) -> [f64; N] {
        match &self.coupling {
            Some(coupling) => linalg::transpose_mul_vec(coupling, drive_torques),
            None => *drive_torques,
        }
    }

    /// Task position, velocity and Jacobian at the current state.
    pub fn task(&mut self) -> TaskKinematics<N, M> {
        let s = self.state;
        self.model.kinematics.eval(
            &mut self.kinematics_scratch,
            &s.q,
            &s.qd,
            &self.model.parameters,
            &mut self.kinematics_out,
        );
        let out = &self.kinematics_out;
        let position: [f64; M] = std::array::from_fn(|k| out[k]);
        let jacobian: [[f64; N]; M] = std::array::from_fn(|k| std::array::from_fn(|j| out[M + k * N + j]));
        let velocity = linalg::mat_vec(&jacobian, &s.qd);
        TaskKinematics { position, velocity, jacobian }
    }

    /// Joint-side motor torque of each joint at the current state, N·m.
    pub fn motor_torque(&self) -> [f64; N] {
        self.joint_torques(&std::array::from_fn(|j| self.drives[j].torque_per_amp * self.state.current[j]))
    }

    /// Advances by `dt` with armature `voltage` (electrics on) or motor `current_setpoint`
    /// (electrics off) and joint-side operator torques `external`, all held over the step.
    pub fn step(&mut self, dt: f64, voltage: &[f64; N], current_setpoint: &[f64; N], external: &[f64; N]) {
        if !self.effects.motor_electrics {
            self.state.current = *current_setpoint;
            self.state.measured_current = *current_setpoint;
        }
        let volts: [f64; N] = std::array::from_fn(|j| {
            let supply = self.drives[j].supply;
            voltage[j].clamp(-supply, supply)
        });
        let s0 = self.state;
        let k1 = self.derivative(&s0, &volts, external);
        let k2 = self.derivative(&s0.axpy(0.5 * dt, &k1), &volts, external);
        let k3 = self.derivative(&s0.axpy(0.5 * dt, &k2), &volts, external);
        let k4 = self.derivative(&s0.axpy(dt, &k3), &volts, external);
        let mut next = s0;
        let combine = |x: &mut [f64; N], a: &[f64; N], b: &[f64; N], c: &[f64; N], d: &[f64; N]| {
            for j in 0..N {
                x[j] += dt / 6.0 * (a[j] + 2.0 * b[j] + 2.0 * c[j] + d[j]);
            }
        };
        combine(&mut next.q, &k1.q, &k2.q, &k3.q, &k4.q);
        combine(&mut next.qd, &k1.qd, &k2.qd, &k3.qd, &k4.qd);
        combine(&mut next.theta, &k1.theta, &k2.theta, &k3.theta, &k4.theta);
        combine(&mut next.theta_dot, &k1.theta_dot, &k2.theta_dot, &k3.theta_dot, &k4.theta_dot);
        combine(&mut next.current, &k1.current, &k2.current, &k3.current, &k4.current);
        combine(
            &mut next.measured_current,
            &k1.measured_current,
            &k2.measured_current,
            &k3.measured_current,
            &k4.measured_current,
        );
        if !self.has_backlash() {
            next.theta = next.q;
            next.theta_dot = next.qd;
        }
        self.state = next;
    }

    /// Karnopp friction on a rotor with velocity `v`, other torques `net`, inertia `inertia`.
    fn friction(drive: &Drive, v: f64, net: f64, inertia: f64) -> f64 {
        if drive.stiction <= 0.0 && drive.coulomb <= 0.0 {
            return 0.0;
        }
        if v.abs() > STICK_VELOCITY {
            -drive.coulomb * v.signum()
        } else {
            let hold = -(net + inertia * v / STICK_TIME);
            hold.clamp(-drive.stiction, drive.stiction)
        }
    }

    fn derivative(&mut self, s: &PlantState<N>, volts: &[f64; N], external: &[f64; N]) -> PlantState<N> {
        self.model.dynamics.eval(
            &mut self.dynamics_scratch,
            &s.q,
            &s.qd,
            &self.model.parameters,
            &mut self.dynamics_out,
        );
        let out = &self.dynamics_out;
        let mut inertia: [[f64; N]; N] = std::array::from_fn(|i| std::array::from_fn(|j| out[i * N + j]));
        let bias: [f64; N] =
            std::array::from_fn(|j| out[N * N + j] + out[N * N + N + j] + self.model.damping[j] * s.qd[j]);
        let electrics = self.effects.motor_electrics;
        let mut d = PlantState {
            q: s.qd,
            qd: [0.0; N],
            theta: s.theta_dot,
            theta_dot: [0.0; N],
            current: [0.0; N],
            measured_current: [0.0; N],
        };
        let motor =
            self.joint_torques(&std::array::from_fn(|j| self.drives[j].torque_per_amp * s.current[j]));
        if self.has_backlash() {
            let mut link_rhs = [0.0; N];
            for j in 0..N {
                let drive = &self.drives[j];
                inertia[j][j] -= drive.rotor;
                let delta = s.theta[j] - s.q[j];
                let delta_dot = s.theta_dot[j] - s.qd[j];
                let gear = if delta > drive.half_backlash {
                    (GEAR_STIFFNESS * (delta - drive.half_backlash) + drive.gear_damping * delta_dot).max(0.0)
                } else if delta < -drive.half_backlash {
                    (GEAR_STIFFNESS * (delta + drive.half_backlash) + drive.gear_damping * delta_dot).min(0.0)
                } else {
                    0.0
                };
                link_rhs[j] = gear + external[j] - bias[j];
                let net = motor[j] - gear;
                let friction = Self::friction(drive, s.theta_dot[j], net, drive.rotor);
                d.theta_dot[j] = (net + friction) / drive.rotor;
            }
            d.qd = linalg::cholesky_solve(&inertia, &link_rhs).unwrap_or([0.0; N]);
        } else if let (Some(_), Some(joint_from_drive)) = (&self.coupling, &self.joint_from_drive) {
            // Friction acts on the motors: each drive's on its own output velocity `ȧ = C q̇`,
            // against the torque on it `C⁻ᵀ τ` and its inertia `(C⁻ᵀ D C⁻¹)_kk`; the joints feel
            // `Cᵀ τ_f`.
            let net: [f64; N] = std::array::from_fn(|j| motor[j] + external[j] - bias[j]);
            let drive_velocity = self.drive_outputs(&s.qd);
            let drive_net = linalg::transpose_mul_vec(joint_from_drive, &net);
            let drive_friction: [f64; N] = std::array::from_fn(|k| {
                let inertia_on_drive: f64 = (0..N)
                    .map(|i| {
                        (0..N)
                            .map(|j| joint_from_drive[i][k] * inertia[i][j] * joint_from_drive[j][k])
                            .sum::<f64>()
                    })
                    .sum();
                Self::friction(&self.drives[k], drive_velocity[k], drive_net[k], inertia_on_drive)
            });
            let joint_friction = self.joint_torques(&drive_friction);
            let rhs: [f64; N] = std::array::from_fn(|j| net[j] + joint_friction[j]);
            d.qd = linalg::cholesky_solve(&inertia, &rhs).unwrap_or([0.0; N]);
            d.theta_dot = d.qd;
        } else {
            let mut rhs = [0.0; N];
            for j in 0..N {
                let net = motor[j] + external[j] - bias[j];
                rhs[j] = net + Self::friction(&self.drives[j], s.qd[j], net, inertia[j][j]);
            }
            d.qd = linalg::cholesky_solve(&inertia, &rhs).unwrap_or([0.0; N]);
            d.theta_dot = d.qd;
        }
        if electrics {
            let output_velocity = self.drive_outputs(&s.theta_dot);
            for (j, (drive, &volt)) in self.drives.iter().zip(volts).enumerate() {
                d.current[j] = (volt - drive.resistance * s.current[j] - drive.back_emf * output_velocity[j])
                    / drive.inductance;
                d.measured_current[j] = if self.filter_time_constant > 0.0 {
                    (s.current[j] - s.measured_current[j]) / self.filter_time_constant
                } else {
                    d.current[j]
                };
            }
        }
        d
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The good-model fixture whose transmission is not symmetric, `C = [[1, 0], [1, 1]]`
    /// (roll's motor turns pitch + roll), N = 5 on both drives, 1280 counts per motor turn,
    /// `k_t` 0.0154 N·m/A.
    fn coupled_wrist() -> Plant<2, 2> {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../codegen/tests/good-models/coupled_wrist.yaml");
        let model = hapticgen_codegen::load_file(std::path::Path::new(path), "coupled_wrist.yaml", None)
            .unwrap_or_else(|d| panic!("{d}"));
        let compiled = Arc::new(CompiledModel::new(&model, 1.0));
        Plant::new(compiled, Effects::IDEAL, [0.3, -0.2], [1280; 2], 0.0).unwrap()
    }

    /// Counts read back as angles land within half a count of the angle counted: the plant's
    /// encoder and the controller's decoding share one scale.
    #[test]
    fn counts_read_back_within_half_a_count() {
        let (counts_per_turn, gear_ratio) = (1280, 5.0);
        let half_count = 0.5 / counts_per_radian(counts_per_turn, gear_ratio);
        for angle in [-1.3, 0.0, 0.1, 0.3, 2.9] {
            let counts = (angle * counts_per_radian(counts_per_turn, gear_ratio)).round() as i32;
            let read = output_angle_at_counts(counts, counts_per_turn, gear_ratio);
            assert!((read - angle).abs() <= half_count, "{angle} rad read back as {read} rad");
        }
    }

    #[test]
    fn a_transmission_turns_the_encoders_and_the_joints_through_its_matrix() {
        let mut plant = coupled_wrist();
        // Drive outputs a = C q = (0.3, 0.1); motor counts N a · 1280 / 2π.
        let per_radian = 5.0 * 1280.0 / std::f64::consts::TAU;
        let expected = [(0.3 * per_radian).round() as i32, (0.1 * per_radian).round() as i32];
        assert_eq!(plant.encoder_counts(), expected);
        // Currents (1, 2) A make drive torques N k_t i = (0.077, 0.154) N·m and joint torques
        // Cᵀ τ_a = (τ_a1 + τ_a2, τ_a2).
        plant.state.current = [1.0, 2.0];
        let per_amp = 5.0 * 0.0154;
        let torque = plant.motor_torque();
        let want = [per_amp * 1.0 + per_amp * 2.0, per_amp * 2.0];
        assert!((torque[0] - want[0]).abs() < 1e-15 && (torque[1] - want[1]).abs() < 1e-15, "{torque:?}");
    }

    #[test]
    fn friction_acts_on_the_motors_through_the_transmission() {
        // q̇ = (1, 0) turns both outputs (ȧ = C q̇ = (1, 1)): both drives slide, with Coulomb
        // torques 0.01 and 0.02 N·m, and the joints feel Cᵀ (−0.01, −0.02) = (−0.03, −0.02).
        // (Friction per joint would make the still roll joint stick instead.)
        let mut plant = coupled_wrist();
        plant.state.qd = [1.0, 0.0];
        plant.state.theta_dot = [1.0, 0.0];
        let state = plant.state;
        let without = plant.derivative(&state, &[0.0; 2], &[0.0; 2]);
        plant.effects.friction = true;
        for (drive, coulomb) in plant.drives.iter_mut().zip([0.01, 0.02]) {
            (drive.coulomb, drive.stiction) = (coulomb, coulomb);
        }
        let with = plant.derivative(&state, &[0.0; 2], &[0.0; 2]);
        let mut scratch = plant.model.dynamics.scratch();
        let mut out = vec![0.0; plant.model.dynamics.len()];
        plant.model.dynamics.eval(&mut scratch, &state.q, &state.qd, &plant.model.parameters, &mut out);
        let friction: Vec<f64> =
            (0..2).map(|i| (0..2).map(|j| out[i * 2 + j] * (with.qd[j] - without.qd[j])).sum()).collect();
        assert!((friction[0] + 0.03).abs() < 1e-12 && (friction[1] + 0.02).abs() < 1e-12, "{friction:?}");
    }

    #[test]
    fn each_motor_sees_the_back_emf_of_its_own_output() {
        // Electrics on, zero volts and current: di/dt = −k_t N ȧ / L with ȧ = C q̇; q̇ = (1, −1)
        // turns drive 1 (ȧ₁ = 1) and not drive 2 (ȧ₂ = 0).
        let mut plant = coupled_wrist();
        plant.effects.motor_electrics = true;
        plant.state.qd = [1.0, -1.0];
        plant.state.theta_dot = [1.0, -1.0];
        let state = plant.state;
        let derivative = plant.derivative(&state, &[0.0; 2], &[0.0; 2]);
        let (back_emf, inductance) = (0.0154 * 5.0, 1.0e-3);
        assert!((derivative.current[0] + back_emf / inductance).abs() < 1e-9, "{:?}", derivative.current);
        assert_eq!(derivative.current[1], 0.0);
    }
}
