//! Fault injection: the runtime's [`HapticLoop`] on a rig's generated code, in closed loop
//! with the simulated [`Plant`], while a sensor, the schedule or the operator misbehaves.
//!
//! Every scenario checks these safety criteria on **everything that leaves the runtime** (the
//! torque and current commands of every impedance tick, the armature voltages of every current
//! tick):
//!
//! 1. the commanded torque never exceeds the joint's limit `min(torque_limit, N·η·k_t·i_max)`;
//! 2. no NaN or infinity ever leaves the runtime;
//! 3. for a fault the runtime can detect, a safe state — zero torque, zero volts, fault
//!    latched — within 1 ms of the fault;
//! 4. normal control resumes only after an explicit reset: the fault stays latched (and the
//!    output zero) until [`HapticLoop::reset_fault`], and control resumes after it.
//!
//! A fault the runtime has no way to detect (a current-sense offset, a frozen encoder, a
//! railed force sensor, a count jump) cannot meet criterion 3: such a scenario passes when
//! criteria 1 and 2 hold and the device stays bounded, and its row says that the fault went
//! undetected — the table is a map of what the runtime does and does not catch.

// Per-joint arrays read best with explicit indices.
#![allow(clippy::needless_range_loop)]

use std::sync::Arc;

use hapticgen_runtime::control::ControlOptions;
use hapticgen_runtime::control::{ImpedanceController, ImpedanceLaw, ImpedanceParameters, TaskReference};
use hapticgen_runtime::estimation::{EstimatorSettings, ForceSensorCalibration};
use hapticgen_runtime::linalg;
use hapticgen_runtime::tick::{HapticLoop, HapticLoopSettings, ImpedanceInputs};
use hapticgen_runtime::RigModel;

use crate::closed_loop::{Operator, Path as HandPath};
use crate::generated::{self, RigVisitor};
use crate::plant::{Effects, Plant};
use crate::rig::{CompiledModel, TapeRig};
use crate::simulation::Simulation;

/// What goes wrong in a scenario, from [`Fault::start`] on.
#[derive(Clone, Debug, PartialEq)]
pub enum Injection {
    /// Nothing (a reference run).
    None,
    /// Joint 0's encoder counter jumps by this many counts, once.
    EncoderGlitch(i32),
    /// Joint 0's encoder counter stops changing.
    StuckEncoder,
    /// Every force-sensor reading is NaN.
    ForceNan,
    /// The force sensor's output rails at this raw value.
    ForceRail(f64),
    /// Joint 0's current sense reads this many amperes too much.
    CurrentOffset(f64),
    /// This many consecutive impedance ticks do not run (the tick counter keeps counting).
    MissedTicks(u32),
}

/// One fault-injection scenario.
#[derive(Clone, Debug)]
pub struct Fault {
    /// Short name, for the table.
    pub name: &'static str,
    /// What is injected.
    pub injection: Injection,
    /// When, s.
    pub start: f64,
    /// How long the injected condition lasts, s (the glitch and missed ticks end by
    /// themselves).
    pub duration: f64,
    /// When the operator resets a latched fault, s (after the condition has ended).
    pub reset_at: f64,
    /// Simulated time, s.
    pub total: f64,
    /// The impedance law.
    pub law: ImpedanceLaw,
    /// `K_d`, `B_d`, `M_d`.
    pub gains: (f64, f64, f64),
    /// The operator.
    pub operator: Operator,
    /// Factor on the plant's masses (model mismatch).
    pub plant_mass_scale: f64,
    /// Initial joint angles (`None`: mid-range).
    pub initial_q: Option<Vec<f64>>,
    /// `|det J|` below which Controllers 1 and 2 fall back to Controller 3.
    pub singular_fallback: f64,
    /// Whether the runtime is expected to detect the fault (criterion 3 applies).
    pub detectable: bool,
}

/// What a scenario measured.
#[derive(Clone, Debug, PartialEq)]
pub struct FaultResult {
    /// The scenario's name.
    pub name: String,
    /// Largest commanded joint torque, N·m.
    pub worst_torque: f64,
    /// Largest commanded torque as a fraction of its joint's limit.
    pub worst_torque_fraction: f64,
    /// The joint torque limit (joint 0), N·m.
    pub torque_limit: f64,
    /// Largest torque the motors actually produced (`k·i`), N·m.
    pub worst_motor_torque: f64,
    /// Any NaN or infinity left the runtime.
    pub non_finite_output: bool,
    /// The first latched fault (`Debug` name) and when, s.
    pub fault: Option<(String, f64)>,
    /// Time from the injection to zero torque, zero volts and a latched fault, s.
    pub time_to_safe: Option<f64>,
    /// The output stayed zero from the safe state until the reset.
    pub held_until_reset: bool,
    /// Control resumed (fault cleared, torque commanded) after the reset.
    pub resumed_after_reset: bool,
    /// Largest task-space excursion from the start, m (or rad).
    pub max_excursion: f64,
    /// Whether the runtime was expected to detect the fault.
    pub detectable: bool,
    /// The criteria held.
    pub pass: bool,
    /// Why not, or what went undetected.
    pub note: String,
}

/// The fault scenarios on a 2-joint, 2-D-task rig (the parallel link).
pub fn scenarios(sim: &Simulation) -> Vec<Fault> {
    let hold = |k: f64| Operator::Hand {
        stiffness: k,
        damping: 1.0,
        path: HandPath { keys: vec![(0.0, sim.task_at(&sim.home()).0)] },
    };
    let base = Fault {
        name: "",
        injection: Injection::None,
        start: 0.3,
        duration: 0.2,
        reset_at: 0.7,
        total: 1.0,
        law: ImpedanceLaw::JacobianTranspose,
        gains: (300.0, 3.0, 0.05),
        operator: hold(100.0),
        plant_mass_scale: 1.0,
        initial_q: None,
        singular_fallback: 0.0,
        detectable: false,
    };
    let (x0, _) = sim.task_at(&sim.home());
    let yank_to: Vec<f64> = x0.iter().enumerate().map(|(i, v)| if i == 0 { v + 0.05 } else { *v }).collect();
    let singular_q = sim.nearest_singular(&sim.home()).ok();
    let mut out = vec![
        Fault { name: "reference (no fault)", ..base.clone() },
        Fault {
            name: "encoder glitch (+2000 counts)",
            injection: Injection::EncoderGlitch(2000),
            ..base.clone()
        },
        Fault { name: "stuck encoder", injection: Injection::StuckEncoder, ..base.clone() },
        Fault {
            name: "force sensor NaN (Controller 1)",
            injection: Injection::ForceNan,
            law: ImpedanceLaw::ForceFeedback,
            detectable: true,
            ..base.clone()
        },
        Fault {
            name: "force sensor railed (Controller 1)",
            injection: Injection::ForceRail(5.0),
            law: ImpedanceLaw::ForceFeedback,
            ..base.clone()
        },
        Fault {
            name: "current-sense offset +0.5 A",
            injection: Injection::CurrentOffset(0.5),
            ..base.clone()
        },
        Fault {
            name: "1 missed impedance tick",
            injection: Injection::MissedTicks(1),
            detectable: true,
            ..base.clone()
        },
        Fault {
            name: "5 missed impedance ticks",
            injection: Injection::MissedTicks(5),
            detectable: true,
            ..base.clone()
        },
        Fault {
            name: "operator yanks the handle (5 cm in 20 ms)",
            operator: Operator::Hand {
                stiffness: 2000.0,
                damping: 5.0,
                path: HandPath { keys: vec![(0.0, x0.clone()), (0.3, x0.clone()), (0.32, yank_to)] },
            },
            ..base.clone()
        },
        Fault {
            name: "plant masses −30 % (Controller 2a)",
            law: ImpedanceLaw::AccelerationFeedback,
            plant_mass_scale: 0.7,
            ..base.clone()
        },
        Fault {
            name: "plant masses +30 % (Controller 2a)",
            law: ImpedanceLaw::AccelerationFeedback,
            plant_mass_scale: 1.3,
            ..base.clone()
        },
    ];
    if let Some(target) = singular_q {
        let (target_x, _) = sim.task_at(&target);
        let beyond: Vec<f64> = x0.iter().zip(&target_x).map(|(a, b)| b + 0.3 * (b - a)).collect();
        for (name, law) in [
            ("driven into the singular boundary (Controller 2b)", ImpedanceLaw::NaturalInertia),
            ("driven into the singular boundary (Controller 3)", ImpedanceLaw::JacobianTranspose),
        ] {
            out.push(Fault {
                name,
                law,
                gains: (100.0, 2.0, 0.05),
                singular_fallback: 1e-3,
                total: 2.5,
                reset_at: 2.4,
                operator: Operator::Hand {
                    stiffness: 200.0,
                    damping: 1.0,
                    path: HandPath {
                        keys: vec![(0.0, x0.clone()), (0.3, x0.clone()), (2.3, beyond.clone())],
                    },
                },
                ..base.clone()
            });
        }
    }
    out
}

struct FaultVisitor<'a> {
    sim: &'a Simulation,
    fault: &'a Fault,
}

impl RigVisitor for FaultVisitor<'_> {
    type Output = Result<FaultResult, String>;
    fn visit<R: RigModel<N, M, Scalar = f64>, const N: usize, const M: usize>(self, rig: R) -> Self::Output {
        run_fault::<R, N, M>(rig, self.sim, self.fault)
    }
}

/// Runs one scenario on the rig's generated code (or its tapes for a model the binary was
/// not built with).
pub fn run(sim: &Simulation, fault: &Fault) -> Result<FaultResult, String> {
    let visitor = FaultVisitor { sim, fault };
    if let Some(index) = sim.shipped {
        return generated::visit(index, visitor)
            .unwrap_or_else(|| Err("error: inconsistent rig registry".into()));
    }
    match (sim.joints(), sim.task_dim()) {
        (1, 1) => visitor.visit(
            TapeRig::<1, 1>::new(sim.nominal.clone(), &sim.data.current_gains).ok_or("error: bad model")?,
        ),
        (2, 2) => visitor.visit(
            TapeRig::<2, 2>::new(sim.nominal.clone(), &sim.data.current_gains).ok_or("error: bad model")?,
        ),
        (3, 3) => visitor.visit(
            TapeRig::<3, 3>::new(sim.nominal.clone(), &sim.data.current_gains).ok_or("error: bad model")?,
        ),
        (n, m) => Err(format!("error: fault injection supports square tasks of 1–3 joints, not {n}×{m}")),
    }
}

fn run_fault<R, const N: usize, const M: usize>(
    rig: R,
    sim: &Simulation,
    fault: &Fault,
) -> Result<FaultResult, String>
where
    R: RigModel<N, M, Scalar = f64>,
{
    let data = &sim.data;
    let drives = rig.drives();
    let q0v = fault.initial_q.clone().unwrap_or_else(|| sim.home());
    let q0: [f64; N] = std::array::from_fn(|j| q0v.get(j).copied().unwrap_or(0.0));
    let plant_model = if fault.plant_mass_scale == 1.0 {
        sim.nominal.clone()
    } else {
        Arc::new(CompiledModel::new(&sim.model, fault.plant_mass_scale))
    };
    let counts_per_turn: [u32; N] = std::array::from_fn(|j| drives[j].encoder_counts_per_turn);
    let mut plant =
        Plant::<N, M>::new(plant_model, Effects::ALL, q0, counts_per_turn, data.filter_time_constant)?;
    let initial_counts = plant.encoder_counts();
    let zero_offset =
        crate::closed_loop::joint_angles_at_counts(&initial_counts, &drives, rig.coupling().as_ref());
    let start = plant.task();
    let sensor = data.sensors.first().copied();
    let (scale, offset) = sensor.map_or((1.0, 0.0), |s| (s.scale, s.offset));
    let (k, b, m) = fault.gains;
    let settings = HapticLoopSettings {
        controller: ImpedanceController {
            law: fault.law,
            parameters: ImpedanceParameters { stiffness: [k; M], damping: [b; M], mass: [m; M] },
            options: ControlOptions {
                min_abs_jacobian_determinant: fault.singular_fallback,
                ..ControlOptions::paper()
            },
        },
        estimator: EstimatorSettings {
            sample_period: 1.0 / f64::from(data.impedance_loop_hz),
            velocity_cutoff_hz: 100.0,
            acceleration_cutoff_hz: 25.0,
        },
        zero_offset,
        initial_counts,
        force_calibration: ForceSensorCalibration { scale: [scale; M], offset: [offset; M] },
        current_gains: rig.current_loop_gains(),
        max_tick_gap: 1,
    };
    let reference = TaskReference::at_rest(start.position);
    let mut haptic = HapticLoop::new(rig, reference, &settings).ok_or("error: unusable loop rates")?;
    let limits = *haptic.safety().torque_limits();
    let torque_per_amp: [f64; N] =
        std::array::from_fn(|j| drives[j].gear_ratio * drives[j].efficiency * drives[j].torque_constant);
    let dt = 1.0 / f64::from(data.current_loop_hz);
    let impedance_period = 1.0 / f64::from(data.impedance_loop_hz);
    let steps = (fault.total / dt).round() as u64;

    let mut result = FaultResult {
        name: fault.name.to_string(),
        worst_torque: 0.0,
        worst_torque_fraction: 0.0,
        torque_limit: limits[0],
        worst_motor_torque: 0.0,
        non_finite_output: false,
        fault: None,
        time_to_safe: None,
        held_until_reset: true,
        resumed_after_reset: false,
        max_excursion: 0.0,
        detectable: fault.detectable,
        pass: false,
        note: String::new(),
    };
    let mut tick_counter: u32 = 0;
    let mut missed_left = 0u32;
    let mut glitch_done = false;
    let mut frozen: Option<[i32; N]> = None;
    let mut encoder_offset = [0i32; N];
    let mut safe_since: Option<f64> = None;
    // When the injected condition first reached the runtime (the time to the safe state is
    // measured from here).
    let mut injected_at: Option<f64> = None;
    let mut reset_done = false;
    let mut torque_after_reset = false;
    let in_fault = |t: f64| t >= fault.start && t < fault.start + fault.duration;
    for step in 0..steps {
        let t = step as f64 * dt;
        let task = plant.task();
        let force = fault.operator.force(t, &task.position, &task.velocity);
        let force: [f64; M] = std::array::from_fn(|i| force.get(i).copied().unwrap_or(0.0));
        let excursion =
            task.position.iter().zip(&start.position).map(|(a, b)| (a - b) * (a - b)).sum::<f64>().sqrt();
        result.max_excursion = result.max_excursion.max(excursion);

        if !reset_done && t >= fault.reset_at {
            reset_done = true;
            if haptic.safety().fault().is_some() {
                haptic.reset_fault();
            }
        }
        let mut measured = plant.state.measured_current;
        if let (Injection::CurrentOffset(a), true) = (&fault.injection, in_fault(t)) {
            measured[0] += a;
            injected_at.get_or_insert(t);
        }
        // The loop's own scheduler says when the impedance tick is due (as in the firmware).
        let (voltages, due) = haptic.current_tick(&measured);
        let volts: [f64; N] = std::array::from_fn(|j| voltages[j].voltage);
        if volts.iter().any(|v| !v.is_finite()) {
            result.non_finite_output = true;
        }
        if due {
            tick_counter = tick_counter.wrapping_add(1);
            // Missed ticks: the impedance task does not run, the counter keeps counting.
            if let Injection::MissedTicks(count) = fault.injection {
                if missed_left == 0 && t >= fault.start && t < fault.start + impedance_period {
                    missed_left = count;
                }
            }
            let skip = missed_left > 0;
            if skip
                || (in_fault(t) && fault.injection != Injection::None)
                || (glitch_done && injected_at.is_none())
            {
                injected_at.get_or_insert(t);
            }
            missed_left = missed_left.saturating_sub(1);
            if !skip {
                let mut counts = plant.encoder_counts();
                match &fault.injection {
                    Injection::EncoderGlitch(jump) if t >= fault.start && !glitch_done => {
                        encoder_offset[0] = encoder_offset[0].wrapping_add(*jump);
                        glitch_done = true;
                    }
                    Injection::StuckEncoder if in_fault(t) => {
                        counts = *frozen.get_or_insert(counts);
                    }
                    _ => {}
                }
                if !in_fault(t) && fault.injection == Injection::StuckEncoder && frozen.is_some() {
                    // The counter recovers to the true count (a jump of its own).
                    frozen = None;
                }
                for (c, o) in counts.iter_mut().zip(encoder_offset) {
                    *c = c.wrapping_add(o);
                }
                let readings: [f64; M] = std::array::from_fn(|i| match (&fault.injection, in_fault(t)) {
                    (Injection::ForceNan, true) => f64::NAN,
                    (Injection::ForceRail(raw), true) => *raw,
                    _ => offset - force[i] / scale,
                });
                let inputs =
                    ImpedanceInputs { encoder_counts: counts, force_readings: readings, tick: tick_counter };
                let report = haptic.impedance_tick(&inputs);
                let command = report.command;
                for j in 0..N {
                    let u = command.torque[j];
                    if !u.is_finite() || !command.current[j].is_finite() {
                        result.non_finite_output = true;
                        continue;
                    }
                    result.worst_torque = result.worst_torque.max(u.abs());
                    if limits[j] > 0.0 {
                        result.worst_torque_fraction = result.worst_torque_fraction.max(u.abs() / limits[j]);
                    }
                }
                if let (Some(code), None) = (command.fault, &result.fault) {
                    result.fault = Some((format!("{code:?}"), t));
                }
                if reset_done && command.fault.is_none() && command.torque.iter().any(|u| *u != 0.0) {
                    torque_after_reset = true;
                }
            }
        }
        // The safe state: fault latched, zero torque and zero volts.
        let latched = haptic.safety().fault().is_some();
        let zero = volts.iter().all(|v| *v == 0.0) && haptic.current_setpoints().iter().all(|i| *i == 0.0);
        if latched && zero {
            safe_since.get_or_insert(t);
        } else if safe_since.is_some() && !reset_done {
            result.held_until_reset = false;
        }
        let setpoints = *haptic.current_setpoints();
        let external = linalg::transpose_mul_vec(&task.jacobian, &force);
        plant.step(dt, &volts, &setpoints, &external);
        for j in 0..N {
            result.worst_motor_torque =
                result.worst_motor_torque.max((torque_per_amp[j] * plant.state.current[j]).abs());
        }
        if !plant.state.q.iter().all(|v| v.is_finite()) {
            result.note = format!("the device diverged at t = {t:.4} s");
            return Ok(result);
        }
    }
    let origin = injected_at.unwrap_or(fault.start);
    result.time_to_safe = safe_since.map(|s| (s - origin).max(0.0));
    result.resumed_after_reset = torque_after_reset;
    let within_limits = result.worst_torque_fraction <= 1.0 + 1e-12;
    let bounded = result.max_excursion < 0.5;
    let mut notes = Vec::new();
    if !within_limits {
        notes.push(format!("torque {:.3} N·m over its limit", result.worst_torque));
    }
    if result.non_finite_output {
        notes.push("a non-finite value left the runtime".to_string());
    }
    if !bounded {
        notes.push(format!("the device ran away ({:.3} m)", result.max_excursion));
    }
    if result.worst_motor_torque > 1.5 * result.torque_limit {
        notes.push(format!(
            "motor torque transient {:.1} N·m = {:.1}× the limit (the current loop, not the command)",
            result.worst_motor_torque,
            result.worst_motor_torque / result.torque_limit
        ));
    }
    let mut pass = within_limits && !result.non_finite_output && bounded;
    if fault.detectable {
        match result.time_to_safe {
            Some(ts) if ts <= 1e-3 + 1e-9 => {}
            Some(ts) => {
                pass = false;
                notes.push(format!("safe state {:.1} ms after the fault (criterion 1 ms)", ts * 1e3));
            }
            None => {
                pass = false;
                notes.push("no safe state".into());
            }
        }
        if !result.held_until_reset {
            pass = false;
            notes.push("output resumed before the reset".into());
        }
        if !result.resumed_after_reset {
            pass = false;
            notes.push("control did not resume after the reset".into());
        }
    } else if fault.injection != Injection::None {
        match &result.fault {
            Some((code, t)) => notes.push(format!("latched {code} at {:.1} ms", (t - fault.start) * 1e3)),
            None => notes.push("not detected by the runtime (bounded by the limits)".into()),
        }
    } else if result.fault.is_some() {
        pass = false;
        notes.push("a fault latched without a fault".into());
    }
    result.pass = pass;
    result.note = notes.join("; ");
    Ok(result)
}

/// The results as a Markdown table.
pub fn table(results: &[FaultResult]) -> String {
    let mut out = String::from(
        "| scenario | worst commanded torque (N·m, limit) | worst motor torque (N·m) | fault latched | time to safe state | \
         reset | result | note |\n| --- | --- | --- | --- | --- | --- | --- | --- |\n",
    );
    for r in results {
        let fault = r.fault.as_ref().map_or("none".to_string(), |(c, t)| format!("{c} at {t:.4} s"));
        let safe = match (r.detectable, r.time_to_safe) {
            (_, Some(t)) => format!("{:.3} ms", t * 1e3),
            (true, None) => "never".to_string(),
            (false, None) => "n/a".to_string(),
        };
        let reset = if r.fault.is_none() {
            "n/a".to_string()
        } else {
            format!(
                "{}held until reset, {}",
                if r.held_until_reset { "" } else { "NOT " },
                if r.resumed_after_reset { "resumed after" } else { "did not resume" }
            )
        };
        out.push_str(&format!(
            "| {} | {:.3} ({:.0} % of {:.2}) | {:.3} | {fault} | {safe} | {reset} | {} | {} |\n",
            r.name,
            r.worst_torque,
            r.worst_torque_fraction * 100.0,
            r.torque_limit,
            r.worst_motor_torque,
            if r.pass { "pass" } else { "FAIL" },
            r.note
        ));
    }
    out
}
