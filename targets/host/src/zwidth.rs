//! Z-width of a rig's virtual wall (Colgate & Brown): the stable `(K, B)` region mapped by
//! simulation and drawn against the analytic bounds of `hapticgen_codegen::check::stability`.
//!
//! For each wall damping `B` of a sweep, the largest stable wall stiffness `K` is found by
//! bisection (on a log scale) over closed-loop simulations, run in parallel with rayon: the
//! device's task point is pressed by a soft hand (a spring-damper whose anchor sits 5 mm inside
//! a flat virtual wall: for a planar task a solid rendered by the runtime's proxy method with
//! Controller 3, for a spatial task a half-space rendered by the god object) and
//! the contact counts as stable when its oscillation decays: the task velocity's rms over the
//! last 30 % of the run is below 90 % of its rms over the 30 % before (or below 2 mm/s). The
//! simulated plant has ideal mechanics and sensing (no friction, backlash or quantisation) but
//! the drive's electrical dynamics, its current loop and the sampled 1 kHz law, so the
//! difference to the analytic bound `K < 2 (b + B) / T` (Gil et al.) is the effect of the
//! delays the bound leaves out. Here `b` is the hand's damping, [`HAND_DAMPING`]: the law
//! cancels the joints' own viscous damping (the `B q̇` of eq. (3)).

use std::path::Path;

use hapticgen_codegen::check::stability;
use hapticgen_runtime::control::ImpedanceLaw;
use hapticgen_runtime::render::{ObjectKind, Shape, VirtualObject};
use rayon::prelude::*;

use crate::closed_loop::{Operator, Path as HandPath, Reference, SimConfig};
use crate::plant::Effects;
use crate::plot::{self, Chart, Series};
use crate::scene::{SceneObject, SceneShape};
use crate::simulation::Simulation;

/// Stiffness of the pressing hand, N/m.
pub const HAND_STIFFNESS: f64 = 100.0;
/// Damping of the pressing hand, N·s/m: the only dissipation besides the wall's own.
pub const HAND_DAMPING: f64 = 0.5;

/// Sweep settings.
#[derive(Clone, Debug, PartialEq)]
pub struct Sweep {
    /// Wall damping values `B`, N·s/m.
    pub damping: Vec<f64>,
    /// Bisection range of `K`, N/m.
    pub stiffness_range: (f64, f64),
    /// Bisection steps per `B`.
    pub steps: usize,
    /// Simulated time per run, s.
    pub duration: f64,
}

impl Sweep {
    /// The full map: 9 values of `B` from 0 to 8 N·s/m, 10 bisection steps.
    pub fn full() -> Sweep {
        Sweep {
            damping: (0..9).map(f64::from).collect(),
            stiffness_range: (50.0, 40_000.0),
            steps: 10,
            duration: 1.0,
        }
    }

    /// A short map for tests and CI: 3 values of `B`, 7 steps.
    pub fn quick() -> Sweep {
        Sweep { damping: vec![0.0, 2.0, 5.0], stiffness_range: (50.0, 40_000.0), steps: 7, duration: 1.0 }
    }
}

/// One point of the boundary.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BoundaryPoint {
    /// Wall damping `B`, N·s/m.
    pub damping: f64,
    /// Largest stiffness found stable, N/m (the lower end of the range if none was).
    pub stable_stiffness: f64,
    /// Analytic passivity bound `2 (b − |B|)/T`, N/m.
    pub passive_bound: f64,
    /// Analytic stability bound of the device alone `2 (b + B)/T`, N/m.
    pub stable_bound: f64,
}

/// The result of a sweep.
#[derive(Clone, Debug)]
pub struct ZWidth {
    /// `b`, the physical damping at the wall (the hand's; the law cancels the joints'), N·s/m.
    pub task_damping: f64,
    /// `T`, s.
    pub sample_period: f64,
    /// One point per `B`.
    pub boundary: Vec<BoundaryPoint>,
}

/// Where a wall is pressed: the joint state the device starts at, and the task axis and side
/// (`+1` or `−1`) the wall lies on from the task point there.
#[derive(Clone, Debug, PartialEq)]
pub struct Press {
    /// The joint state at the start.
    pub start: Vec<f64>,
    /// The task axis the wall is normal to.
    pub axis: usize,
    /// The side of the task point the wall lies on along `axis`, `+1.0` or `−1.0`.
    pub side: f64,
}

impl Press {
    /// The map's press: at the model's home pose, the wall beyond it along `+x`.
    pub fn home(sim: &Simulation) -> Press {
        Press { start: sim.home(), axis: 0, side: 1.0 }
    }
}

/// Whether a wall `(K, B)` holds the pressed device still, pressed at the model's home pose.
pub fn is_stable(sim: &Simulation, stiffness: f64, damping: f64, duration: f64) -> Result<bool, String> {
    is_stable_at(sim, &Press::home(sim), stiffness, damping, duration)
}

/// Whether a wall `(K, B)` holds the device still when pressed as `press` says: a flat wall
/// 2 mm from the start's task point, the hand's anchor 5 mm into it. A 2-D task renders the
/// wall as a rectangle with the proxy method and Controller 3; a 3-D task as a half-space with
/// the god object.
pub fn is_stable_at(
    sim: &Simulation,
    press: &Press,
    stiffness: f64,
    damping: f64,
    duration: f64,
) -> Result<bool, String> {
    let (x0, _) = sim.task_at(&press.start);
    if x0.is_empty() {
        return Err("error: the model has no task coordinates".into());
    }
    if press.axis >= x0.len() {
        return Err(format!("error: no task axis {} in a {}-D task", press.axis, x0.len()));
    }
    let (axis, side) = (press.axis, press.side.signum());
    let mut face = x0.clone();
    face[axis] += side * 0.002;
    let mut anchor = x0.clone();
    anchor[axis] += side * 0.007;
    let mut cfg = SimConfig::new(press.start.clone());
    cfg.reference = match x0.len() {
        2 => {
            let mut center = [face[0], face[1]];
            center[axis] += side * 0.05;
            let half_extents = if axis == 0 { [0.05, 0.1] } else { [0.1, 0.05] };
            let shape = Shape::Rectangle { center, half_extents, angle: 0.0 };
            Reference::Scene {
                objects: vec![VirtualObject { shape, kind: ObjectKind::Solid, stiffness, damping }],
                free_stiffness: 0.0,
                free_damping: 0.0,
                grid_spacing: 0.0,
            }
        }
        3 => {
            // The half-space's outward normal points back at the task point.
            let mut normal = vec![0.0; 3];
            normal[axis] = -side;
            let wall = SceneObject {
                shape: SceneShape::HalfSpace { point: face, normal },
                cavity: false,
                stiffness,
                damping,
                static_friction: 0.0,
                dynamic_friction: 0.0,
                motion: None,
                location: "zwidth's wall".into(),
            };
            Reference::Solids { solids: vec![wall], effect: None }
        }
        m => {
            return Err(format!(
                "error: zwidth renders a wall in a 2-D or 3-D task; this one has {m} coordinates"
            ))
        }
    };
    cfg.law = ImpedanceLaw::JacobianTranspose;
    cfg.stiffness = 0.0;
    cfg.damping = 0.0;
    cfg.duration = duration;
    cfg.effects = Effects::IDEAL;
    cfg.record_hz = 1000.0;
    cfg.operator = Operator::Hand {
        stiffness: HAND_STIFFNESS,
        damping: HAND_DAMPING,
        path: HandPath { keys: vec![(0.0, anchor)] },
    };
    cfg.substeps = cfg.substeps.max(sim.hand_substeps(&press.start, HAND_STIFFNESS, HAND_DAMPING));
    let trace = sim.run(&cfg)?;
    let t = trace.column("t").ok_or("error: no time column")?;
    let velocities: Vec<Vec<f64>> = (0..x0.len()).filter_map(|k| trace.column(&format!("x{k}"))).collect();
    // Task speed from the recorded positions (1 kHz rows), rms over two windows.
    let rms = |from: f64, to: f64| -> f64 {
        let (a, b) = ((from * t.len() as f64) as usize, (to * t.len() as f64) as usize);
        let mut sum = 0.0;
        let mut count = 0usize;
        for i in a.max(1)..b.min(t.len()) {
            let dt = t[i] - t[i - 1];
            if dt > 0.0 {
                sum += velocities.iter().map(|x| ((x[i] - x[i - 1]) / dt).powi(2)).sum::<f64>();
                count += 1;
            }
        }
        if count > 0 {
            (sum / count as f64).sqrt()
        } else {
            f64::INFINITY
        }
    };
    let (middle, late) = (rms(0.4, 0.7), rms(0.7, 1.0));
    if !late.is_finite() || !middle.is_finite() {
        return Ok(false);
    }
    Ok(late < 2e-3 || late < 0.9 * middle)
}

/// The largest wall stiffness `K` (with damping `damping`) found stable when pressed as `press`
/// says, by bisection on a log scale over `settings`' range and steps; `None` if even the
/// range's lower end is not stable.
pub fn largest_stable_stiffness(
    sim: &Simulation,
    press: &Press,
    damping: f64,
    settings: &Sweep,
) -> Result<Option<f64>, String> {
    let (mut low, mut high) = (settings.stiffness_range.0.ln(), settings.stiffness_range.1.ln());
    if !is_stable_at(sim, press, low.exp(), damping, settings.duration)? {
        return Ok(None);
    }
    for _ in 0..settings.steps {
        if high <= low {
            break;
        }
        let mid = 0.5 * (low + high);
        if is_stable_at(sim, press, mid.exp(), damping, settings.duration)? {
            low = mid;
        } else {
            high = mid;
        }
    }
    Ok(Some(low.exp()))
}

/// Maps the boundary of the stable region.
pub fn sweep(sim: &Simulation, settings: &Sweep) -> Result<ZWidth, String> {
    let task_damping = HAND_DAMPING;
    let sample_period = 1.0 / f64::from(sim.model.rates.impedance_loop_hz);
    let press = Press::home(sim);
    let boundary: Result<Vec<BoundaryPoint>, String> = settings
        .damping
        .par_iter()
        .map(|&b| {
            Ok(BoundaryPoint {
                damping: b,
                stable_stiffness: largest_stable_stiffness(sim, &press, b, settings)?
                    .unwrap_or(settings.stiffness_range.0),
                passive_bound: stability::passive_stiffness(task_damping, b, sample_period),
                stable_bound: stability::stable_stiffness(task_damping, b, sample_period),
            })
        })
        .collect();
    Ok(ZWidth { task_damping, sample_period, boundary: boundary? })
}

/// Writes `zwidth.csv`, `zwidth.svg`/`.png` and `zwidth.md` into `out`.
pub fn write(z: &ZWidth, model: &str, out: &Path) -> Result<(), String> {
    std::fs::create_dir_all(out).map_err(|e| format!("error: cannot create {}: {e}", out.display()))?;
    let mut csv = String::from("B,K_stable_simulated,K_passive_bound,K_stable_bound\n");
    let mut table = String::from("| B (N·s/m) | largest stable K, simulated (N/m) | passivity bound (N/m) | stability bound (N/m) |\n| --- | --- | --- | --- |\n");
    for p in &z.boundary {
        csv.push_str(&format!(
            "{},{},{},{}\n",
            p.damping, p.stable_stiffness, p.passive_bound, p.stable_bound
        ));
        table.push_str(&format!(
            "| {:.1} | {:.0} | {:.0} | {:.0} |\n",
            p.damping, p.stable_stiffness, p.passive_bound, p.stable_bound
        ));
    }
    std::fs::write(out.join("zwidth.csv"), csv).map_err(|e| format!("error: {e}"))?;
    let points = |f: fn(&BoundaryPoint) -> f64| -> Vec<(f64, f64)> {
        z.boundary.iter().map(|p| (p.damping, f(p))).collect()
    };
    let chart = Chart {
        title: format!("Z-width of a virtual wall: {model}"),
        x_label: "wall damping B (N·s/m)".into(),
        y_label: "wall stiffness K (N/m)".into(),
        series: vec![
            Series::marked("largest stable K, simulated", points(|p| p.stable_stiffness)),
            Series::dashed("stability bound 2(b + B)/T", points(|p| p.stable_bound)),
            Series::dashed("passivity bound 2(b − |B|)/T", points(|p| p.passive_bound)),
        ],
        equal_aspect: false,
    };
    plot::save(&chart, &out.join("zwidth"))?;
    let text = format!(
        "# Z-width: {model}\n\n`b` = {:.4} N·s/m (the pressing hand's damping; the law cancels the joints' own), `T` = {} s. \
         The simulated boundary lies below the analytic stability bound because the bound leaves out the \
         current loop's and the sampled law's delays.\n\n{table}\n![z-width](zwidth.png)\n",
        z.task_damping, z.sample_period
    );
    std::fs::write(out.join("zwidth.md"), text).map_err(|e| format!("error: {e}"))
}
