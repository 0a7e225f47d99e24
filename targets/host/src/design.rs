//! The device design figures of a model, the ones on a haptic device's datasheet and in the
//! field's design literature (Hayward & Astley 1996; Salcudean & Stocco 2000): where it
//! reaches, what force it holds in every direction there, how heavy it feels and how finely it
//! senses, computed from the model's own `p(q)`, `J(q)`, `D(q)`, `g(q)` and drive data.
//!
//! - **Workspace**: the task points of a grid over the box of the actuated joints' limits
//!   (closed chains: where the loops close); the largest inscribed hypercube (cube, square or
//!   interval, edges along the model's world axes) found by bisection on its edge about a
//!   centre improved by pattern search, a cube counted inside when every point of a
//!   `CUBE_PROBES`-per-edge lattice on it is reached by inverse kinematics within the limits.
//! - **Force capability**: with the torque `τ = Jᵀ F + g` of eq. (3) holding a grip force `F`
//!   against gravity, mapped to the drives through the transmission (`C⁻ᵀ τ`), each drive `i`
//!   bounds `F` to the slab `|a_iᵀ F + g_i| ≤ τ_i`; the largest ball about `F = 0` inside every
//!   slab has the radius `min_i (τ_i − |g_i|) / |a_i|`: the force available in every direction.
//!   Peak from the drives' torque limits, continuous from their current limits
//!   (`i_max · k_t · N · η`, at most the torque limit).
//! - **Apparent inertia**: the eigenvalues of `Λ = (J D⁻¹ Jᵀ)⁻¹`, the mass the operator feels
//!   at the grip in its heaviest and lightest directions.
//! - **Resolution**: the largest task-space step one encoder count of one drive makes,
//!   `max_i |J C⁻¹ e_i| δ_i` with `δ_i = 2π / (counts per turn · N)`.

use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;
use serde::Serialize;

use crate::rig::CompiledModel;
use hapticgen_codegen::CheckedModel;

/// Points per edge of the lattice a candidate cube is tested on (corners included).
pub const CUBE_PROBES: usize = 5;

/// The quantities of the model at one joint state.
#[derive(Clone, Debug)]
pub struct Sample {
    /// The actuated joints' coordinates.
    pub q: Vec<f64>,
    /// The task point, m.
    pub position: Vec<f64>,
    /// The task Jacobian, `M × N` rows.
    pub jacobian: Vec<Vec<f64>>,
    /// The inertia matrix, `N × N`.
    pub inertia: Vec<Vec<f64>>,
    /// The gravity torques, `N`.
    pub gravity: Vec<f64>,
}

/// The design figures at one pose.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Figures {
    /// Force available in every direction from the torque limits, N.
    pub force_peak: f64,
    /// Force available in every direction from the current limits, N.
    pub force_continuous: f64,
    /// The smallest eigenvalue of `Λ`, kg (NaN at a singular pose).
    pub inertia_min: f64,
    /// The largest eigenvalue of `Λ`, kg (NaN at a singular pose).
    pub inertia_max: f64,
    /// `κ(J)`, the Jacobian's condition number.
    pub condition: f64,
    /// Holding the device against gravity, % of the most loaded drive's peak torque.
    pub gravity_load: f64,
    /// The largest step of one encoder count, m.
    pub resolution: f64,
}

/// The model's design quantities, evaluated through its compiled tapes.
pub struct Design {
    compiled: CompiledModel,
    /// The actuated joints' names.
    pub names: Vec<String>,
    /// The actuated joints' limits.
    pub limits: Vec<(f64, f64)>,
    /// Each drive's peak torque (its `torque_limit`).
    pub peak: Vec<f64>,
    /// Each drive's continuous torque (`i_max k_t N η`, at most the peak).
    pub continuous: Vec<f64>,
    /// One encoder count of each drive, rad at the drive's output.
    pub count_size: Vec<f64>,
    /// `C⁻¹` of a transmission, else the identity.
    pub joint_from_drive: Vec<Vec<f64>>,
    /// Whether the task is a point (m), not joint coordinates (rad).
    point: bool,
}

/// Why the design figures could not be computed.
#[derive(Debug, thiserror::Error)]
pub enum DesignError {
    /// No pose of the joint box gives finite kinematics (the loops never close).
    #[error(
        "the model's loops close at none of the {0} poses of the box of the joint limits ({1}): no workspace \
         (check the closures and the joints' limits)"
    )]
    NoWorkspace(usize, String),
    /// The workspace holds no cube: a rig whose task has fewer dimensions than it moves in.
    #[error("no {0} fits in the workspace around its centre {1:?}")]
    NoCube(&'static str, Vec<f64>),
    /// A file could not be written.
    #[error("cannot write {0}: {1}")]
    Write(String, std::io::Error),
    /// The maps could not be drawn or written.
    #[error("maps: {0}")]
    Map(String),
    /// The wall-stiffness simulation could not run.
    #[error("the renderable stiffness: {0}")]
    Simulation(String),
}

impl Design {
    /// The design quantities of `model`.
    pub fn new(model: &CheckedModel) -> Design {
        let compiled = CompiledModel::new(model, 1.0);
        let n = model.joints.len();
        let identity = (0..n).map(|i| (0..n).map(|j| f64::from(u8::from(i == j))).collect()).collect();
        Design {
            names: model.joints.iter().map(|j| j.name.clone()).collect(),
            limits: model.joints.iter().map(|j| (j.lower, j.upper)).collect(),
            peak: model.joints.iter().map(|j| j.drive.torque_limit).collect(),
            continuous: model
                .joints
                .iter()
                .map(|j| {
                    let d = &j.drive;
                    (d.current_limit * d.motor.torque_constant * d.gear_ratio * d.efficiency)
                        .min(d.torque_limit)
                })
                .collect(),
            count_size: model.joints.iter().map(|j| j.drive.count_size()).collect(),
            joint_from_drive: model.coupling.as_ref().map_or(identity, |c| c.joint_from_drive.clone()),
            point: matches!(model.task, hapticgen_codegen::model::TaskSpec::Point(_)),
            compiled,
        }
    }

    /// Joints `N`.
    pub fn joints(&self) -> usize {
        self.compiled.joints
    }

    /// Task dimension `M`.
    pub fn task_dim(&self) -> usize {
        self.compiled.task_dim
    }

    /// Whether the task is a point in metres (else joint coordinates in radians, whose
    /// forces are torques).
    pub fn task_is_point(&self) -> bool {
        self.point
    }

    /// The quantities at `q`, or `None` where the loops do not close (non-finite values).
    pub fn sample(&self, q: &[f64]) -> Option<Sample> {
        let (n, m) = (self.joints(), self.task_dim());
        let zero = vec![0.0; n];
        let c = &self.compiled;
        let mut kin = vec![0.0; c.kinematics.len()];
        c.kinematics.eval(&mut c.kinematics.scratch(), q, &zero, &c.parameters, &mut kin);
        let mut dynamics = vec![0.0; c.dynamics.len()];
        c.dynamics.eval(&mut c.dynamics.scratch(), q, &zero, &c.parameters, &mut dynamics);
        if kin.iter().chain(&dynamics).any(|v| !v.is_finite()) {
            return None;
        }
        // The rotors' reflected inertia belongs to what the operator moves.
        let inertia = (0..n)
            .map(|i| {
                (0..n)
                    .map(|j| dynamics[i * n + j] + if i == j { c.reflected_rotor_inertia[i] } else { 0.0 })
                    .collect()
            })
            .collect();
        Some(Sample {
            q: q.to_vec(),
            position: kin[..m].to_vec(),
            jacobian: (0..m).map(|i| kin[m + i * n..m + (i + 1) * n].to_vec()).collect(),
            inertia,
            gravity: dynamics[n * n + n..n * n + 2 * n].to_vec(),
        })
    }

    /// The task point and Jacobian at `q` (kinematics only, for inverse kinematics), or `None`
    /// where the loops do not close.
    fn position_jacobian(
        &self,
        q: &[f64],
        scratch: &mut [f64],
        out: &mut [f64],
    ) -> Option<(Vec<f64>, DMatrix<f64>)> {
        let (n, m) = (self.joints(), self.task_dim());
        let c = &self.compiled;
        let zero = [0.0; 16];
        c.kinematics.eval(scratch, q, &zero[..n.min(16)], &c.parameters, out);
        if out[..m + m * n].iter().any(|v| !v.is_finite()) {
            return None;
        }
        Some((out[..m].to_vec(), DMatrix::from_fn(m, n, |i, k| out[m + i * n + k])))
    }

    /// The rows `a_i` of `C⁻ᵀ Jᵀ` (drive `i`'s torque per unit grip force) and the drives'
    /// gravity torques `C⁻ᵀ g`.
    fn drive_rows(&self, s: &Sample) -> (Vec<Vec<f64>>, Vec<f64>) {
        let (n, m) = (self.joints(), self.task_dim());
        let inv = &self.joint_from_drive;
        // (C⁻ᵀ v)_i = Σ_j C⁻¹[j][i] v_j.
        let rows = (0..n)
            .map(|i| (0..m).map(|k| (0..n).map(|j| inv[j][i] * s.jacobian[k][j]).sum()).collect())
            .collect();
        let gravity = (0..n).map(|i| (0..n).map(|j| inv[j][i] * s.gravity[j]).sum()).collect();
        (rows, gravity)
    }

    /// The force available in every direction at `s`, N (negative where gravity alone exceeds a
    /// drive), against the drives' `limits`.
    pub fn force_capability(&self, s: &Sample, limits: &[f64]) -> f64 {
        let (rows, gravity) = self.drive_rows(s);
        rows.iter()
            .zip(&gravity)
            .zip(limits)
            .map(|((a, g), limit)| {
                let spare = limit - g.abs();
                let reach = a.iter().map(|x| x * x).sum::<f64>().sqrt();
                if reach > 0.0 {
                    spare / reach
                } else if spare >= 0.0 {
                    f64::INFINITY // this drive carries no grip force
                } else {
                    spare
                }
            })
            .fold(f64::INFINITY, f64::min)
    }

    /// The smallest and largest eigenvalue of `Λ = (J D⁻¹ Jᵀ)⁻¹`, kg; `None` at a singular pose.
    pub fn apparent_inertia(&self, s: &Sample) -> Option<(f64, f64)> {
        let (n, m) = (self.joints(), self.task_dim());
        let d = DMatrix::from_fn(n, n, |i, j| s.inertia[i][j]);
        let j = DMatrix::from_fn(m, n, |i, k| s.jacobian[i][k]);
        let mobility = &j * d.try_inverse()? * j.transpose();
        let eigen = nalgebra::SymmetricEigen::new(mobility);
        let (least, most) =
            eigen.eigenvalues.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), &e| (lo.min(e), hi.max(e)));
        // Λ's eigenvalues are the mobility's reciprocals.
        (least > 0.0).then(|| (1.0 / most, 1.0 / least))
    }

    /// The largest task-space step of one encoder count of one drive, m.
    pub fn resolution(&self, s: &Sample) -> f64 {
        let (n, m) = (self.joints(), self.task_dim());
        (0..n)
            .map(|i| {
                // A count of drive i moves the joints by C⁻¹ e_i δ_i.
                let step: f64 = (0..m)
                    .map(|k| {
                        let v: f64 = (0..n).map(|j| s.jacobian[k][j] * self.joint_from_drive[j][i]).sum();
                        v * v
                    })
                    .sum::<f64>()
                    .sqrt();
                step * self.count_size[i]
            })
            .fold(0.0, f64::max)
    }

    /// The condition number `κ(J) = σ_max / σ_min` of the task Jacobian (infinite at a
    /// singular pose): 1 where the grip moves alike in every direction (isotropy).
    pub fn condition(&self, s: &Sample) -> f64 {
        let (n, m) = (self.joints(), self.task_dim());
        let j = DMatrix::from_fn(m, n, |i, k| s.jacobian[i][k]);
        let values = j.singular_values();
        let (least, most) =
            values.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), &v| (lo.min(v), hi.max(v)));
        if least > 0.0 {
            most / least
        } else {
            f64::INFINITY
        }
    }

    /// The largest share of a drive's peak torque that holding the device against gravity takes,
    /// `max_i |(C⁻ᵀ g)_i| / τ_i`, %.
    pub fn gravity_load(&self, s: &Sample) -> f64 {
        let (_, gravity) = self.drive_rows(s);
        gravity.iter().zip(&self.peak).map(|(g, limit)| 100.0 * g.abs() / limit).fold(0.0, f64::max)
    }

    /// Every figure at `s`.
    pub fn figures(&self, s: &Sample) -> Figures {
        let (inertia_min, inertia_max) = self.apparent_inertia(s).unwrap_or((f64::NAN, f64::NAN));
        Figures {
            force_peak: self.force_capability(s, &self.peak),
            force_continuous: self.force_capability(s, &self.continuous),
            inertia_min,
            inertia_max,
            condition: self.condition(s),
            gravity_load: self.gravity_load(s),
            resolution: self.resolution(s),
        }
    }

    /// Joint coordinates reaching task point `x` within the limits, by damped Newton from `start`;
    /// `None` if it does not converge to within 1 µm inside the limits.
    pub fn inverse_kinematics(&self, x: &[f64], start: &[f64]) -> Option<Vec<f64>> {
        let m = self.task_dim();
        let c = &self.compiled;
        let (mut scratch, mut out) = (c.kinematics.scratch(), vec![0.0; c.kinematics.len()]);
        let mut q = start.to_vec();
        for _ in 0..40 {
            let (position, j) = self.position_jacobian(&q, &mut scratch, &mut out)?;
            let error = DVector::from_fn(m, |k, _| x[k] - position[k]);
            if error.norm() < 1e-6 {
                return self.limits.iter().zip(&q).all(|(&(lo, hi), &v)| (lo..=hi).contains(&v)).then_some(q);
            }
            // Damped least squares, Δq = Jᵀ (J Jᵀ + λ² I)⁻¹ e, each step at most 0.2 rad.
            let jjt = &j * j.transpose() + DMatrix::identity(m, m) * 1e-10;
            let step = j.transpose() * jjt.lu().solve(&error)?;
            let scale = (0.2 / step.norm()).min(1.0);
            for (v, d) in q.iter_mut().zip(step.iter()) {
                *v += scale * d;
            }
        }
        None
    }
}

/// Grid values per joint of `hapticgen report`'s workspace: 21, or as many as keep `n` joints'
/// grid within 20,000 points (at least 3).
pub fn default_steps(n: usize) -> usize {
    (3..=21).rev().find(|s: &usize| s.checked_pow(n as u32).is_some_and(|p| p <= 20_000)).unwrap_or(3)
}

/// The grid over the joint box: `steps` values per joint (codegen's one grid, also behind
/// `check`'s plausibility and wall-stability analyses).
pub fn joint_grid(limits: &[(f64, f64)], steps: usize) -> Vec<Vec<f64>> {
    hapticgen_codegen::grid::box_grid(limits, steps).collect()
}

/// The lattice of `probes` points per edge on the hypercube of edge `edge` about `centre`.
pub fn cube_lattice(centre: &[f64], edge: f64, probes: usize) -> Vec<Vec<f64>> {
    let limits: Vec<(f64, f64)> = centre.iter().map(|c| (c - edge / 2.0, c + edge / 2.0)).collect();
    joint_grid(&limits, probes)
}

/// The workspace: its samples and the inscribed hypercube.
pub struct Workspace {
    /// The grid's samples where the loops close.
    pub samples: Vec<Sample>,
    /// Grid points per joint, and all grid points.
    pub grid: (usize, usize),
    /// The inscribed hypercube's centre, m.
    pub centre: Vec<f64>,
    /// Its edge, m.
    pub edge: f64,
    /// The joint coordinates reaching each point of its test lattice.
    pub lattice: Vec<Vec<f64>>,
    /// The inscribed ball's (sphere's, disc's) centre and radius, m ([`ball_probes`]).
    pub ball: (Vec<f64>, f64),
}

/// The sample whose task point is nearest `x` (the start of inverse kinematics); `samples` is
/// never empty ([`Design::workspace`] refuses an empty workspace).
fn nearest<'s>(samples: &'s [Sample], x: &[f64]) -> &'s Sample {
    let distance = |s: &Sample| s.position.iter().zip(x).map(|(a, b)| (a - b) * (a - b)).sum::<f64>();
    samples.iter().min_by(|a, b| distance(a).total_cmp(&distance(b))).expect("a non-empty workspace")
}

impl Workspace {
    /// The sample whose task point is nearest `x`.
    pub fn nearest(&self, x: &[f64]) -> &Sample {
        nearest(&self.samples, x)
    }

    /// The least and largest task coordinates sampled.
    pub fn bounds(&self) -> (Vec<f64>, Vec<f64>) {
        sample_bounds(&self.samples, self.centre.len())
    }
}

/// The least and largest of each of the `m` task coordinates of `samples`.
fn sample_bounds(samples: &[Sample], m: usize) -> (Vec<f64>, Vec<f64>) {
    let lower = (0..m).map(|k| samples.iter().map(|s| s.position[k]).fold(f64::INFINITY, f64::min)).collect();
    let upper =
        (0..m).map(|k| samples.iter().map(|s| s.position[k]).fold(f64::NEG_INFINITY, f64::max)).collect();
    (lower, upper)
}

impl Design {
    /// The joint states reaching every point of `points`, or `None` if one is out of reach.
    fn all_reached(&self, samples: &[Sample], points: Vec<Vec<f64>>) -> Option<Vec<Vec<f64>>> {
        points.par_iter().map(|x| self.inverse_kinematics(x, &nearest(samples, x).q)).collect()
    }

    /// The largest size (a cube's edge, a ball's radius) about `centre` whose `probes` are all
    /// reached, by bisection up to `upper` (to `upper / 2¹⁶`).
    fn largest_size(&self, samples: &[Sample], centre: &[f64], upper: f64, probes: Probes) -> f64 {
        let (mut lo, mut hi) = (0.0, upper);
        if self.all_reached(samples, probes(centre, 1e-9)).is_none() {
            return 0.0;
        }
        for _ in 0..16 {
            let mid = 0.5 * (lo + hi);
            if self.all_reached(samples, probes(centre, mid)).is_some() {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        lo
    }

    /// The centre and size of the largest shape `probes` describes inside the workspace: the
    /// largest about `start`, its centre then moved by a pattern search where the shape grows.
    fn largest_shape(
        &self,
        samples: &[Sample],
        start: Vec<f64>,
        span: f64,
        probes: Probes,
    ) -> (Vec<f64>, f64) {
        let mut centre = start;
        let mut size = self.largest_size(samples, &centre, span, probes);
        let mut step = 0.25 * size.max(span / 20.0);
        while step > 1e-3 * span {
            let mut improved = false;
            for k in 0..centre.len() {
                for sign in [-1.0, 1.0] {
                    let mut moved = centre.clone();
                    moved[k] += sign * step;
                    if self.all_reached(samples, probes(&moved, size)).is_some() {
                        let grown = self.largest_size(samples, &moved, span, probes);
                        if grown > size * (1.0 + 1e-6) {
                            (centre, size, improved) = (moved, grown, true);
                        }
                    }
                }
            }
            if !improved {
                step *= 0.5;
            }
        }
        (centre, size)
    }

    /// Samples the joint box with `steps` per joint and finds the inscribed hypercube and ball.
    pub fn workspace(&self, steps: usize) -> Result<Workspace, DesignError> {
        let grid = joint_grid(&self.limits, steps);
        let samples: Vec<Sample> = grid.par_iter().filter_map(|q| self.sample(q)).collect();
        if samples.is_empty() {
            let limits: Vec<String> = self
                .names
                .iter()
                .zip(&self.limits)
                .map(|(name, (lo, hi))| format!("{name} in [{lo}, {hi}]"))
                .collect();
            return Err(DesignError::NoWorkspace(grid.len(), limits.join(" × ")));
        }
        let m = self.task_dim();
        let (lower, upper) = sample_bounds(&samples, m);
        let span = lower.iter().zip(&upper).map(|(a, b)| b - a).fold(f64::INFINITY, f64::min);
        // Start at the middle of the joint box's image.
        let middle: Vec<f64> = self.limits.iter().map(|(lo, hi)| 0.5 * (lo + hi)).collect();
        let start = self.sample(&middle).map_or_else(
            || {
                (0..m)
                    .map(|k| samples.iter().map(|s| s.position[k]).sum::<f64>() / samples.len() as f64)
                    .collect()
            },
            |s| s.position,
        );
        let cube_probes: Probes = |centre, edge| cube_lattice(centre, edge, CUBE_PROBES);
        let (centre, edge) = self.largest_shape(&samples, start.clone(), span, cube_probes);
        let name = ["interval", "square", "cube"].get(m.saturating_sub(1)).copied().unwrap_or("hypercube");
        let lattice = self
            .all_reached(&samples, cube_lattice(&centre, edge, CUBE_PROBES))
            .filter(|_| edge > 0.0)
            .ok_or_else(|| DesignError::NoCube(name, centre.clone()))?;
        // The ball from the cube's centre: it holds the cube's inscribed ball already.
        let (ball_centre, radius) = self.largest_shape(&samples, centre.clone(), 0.5 * span, ball_probes);
        Ok(Workspace {
            samples,
            grid: (steps, grid.len()),
            centre,
            edge,
            lattice,
            ball: (ball_centre, radius),
        })
    }
}

/// The points a shape of some size about a centre is tested on.
type Probes = fn(&[f64], f64) -> Vec<Vec<f64>>;

/// Directions a ball is probed along: 16 on a circle, 32 over a sphere (a Fibonacci lattice),
/// both ways along each axis for other dimensions.
pub const BALL_DIRECTIONS: (usize, usize) = (16, 32);

/// The points a ball of `radius` about `centre` is tested on: its centre and, along each of
/// [`BALL_DIRECTIONS`], the points at half and at the full radius.
pub fn ball_probes(centre: &[f64], radius: f64) -> Vec<Vec<f64>> {
    let m = centre.len();
    let directions: Vec<Vec<f64>> = match m {
        2 => (0..BALL_DIRECTIONS.0)
            .map(|i| {
                let a = std::f64::consts::TAU * i as f64 / BALL_DIRECTIONS.0 as f64;
                vec![a.cos(), a.sin()]
            })
            .collect(),
        3 => (0..BALL_DIRECTIONS.1)
            .map(|i| {
                let z = 1.0 - 2.0 * (i as f64 + 0.5) / BALL_DIRECTIONS.1 as f64;
                let r = (1.0 - z * z).sqrt();
                let a = i as f64 * std::f64::consts::PI * (3.0 - 5f64.sqrt());
                vec![r * a.cos(), r * a.sin(), z]
            })
            .collect(),
        _ => (0..2 * m)
            .map(|i| {
                let mut axis = vec![0.0; m];
                axis[i / 2] = if i % 2 == 0 { 1.0 } else { -1.0 };
                axis
            })
            .collect(),
    };
    let mut points = vec![centre.to_vec()];
    for fraction in [0.5, 1.0] {
        points.extend(
            directions.iter().map(|d| centre.iter().zip(d).map(|(c, u)| c + fraction * radius * u).collect()),
        );
    }
    points
}

/// `v` with `digits` decimals, never `-0.0` (a centre 0.03 µm left of an axis is at 0.0 mm).
pub fn fixed(v: f64, digits: usize) -> String {
    let text = format!("{v:.digits$}");
    if text.trim_start_matches('-').chars().all(|c| c == '0' || c == '.') {
        text.trim_start_matches('-').to_string()
    } else {
        text
    }
}

/// Least, median and largest of some values.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct Spread {
    /// The least.
    pub min_over_cube: f64,
    /// The median.
    pub median_over_cube: f64,
    /// The largest.
    pub max_over_cube: f64,
}

fn spread(mut values: Vec<f64>) -> Spread {
    values.sort_by(f64::total_cmp);
    let median = if values.is_empty() { f64::NAN } else { values[values.len() / 2] };
    Spread {
        min_over_cube: values.first().copied().unwrap_or(f64::NAN),
        median_over_cube: median,
        max_over_cube: values.last().copied().unwrap_or(f64::NAN),
    }
}

/// The hypercube in `summary.json`.
#[derive(Clone, Debug, Serialize)]
pub struct CubeSummary {
    /// Edge, m.
    pub edge: f64,
    /// Centre, m, world frame of the model.
    pub centre: Vec<f64>,
    /// Points per edge of the lattice it was tested on.
    pub probes_per_edge: usize,
}

/// The figures `hapticgen report` writes to `summary.json`.
#[derive(Clone, Debug, Serialize)]
pub struct Summary {
    /// The model's name.
    pub model: String,
    /// The task coordinates' unit: `m` for a point, `rad` for joint coordinates (then forces
    /// are torques, N·m, and inertias kg·m²).
    pub task_unit: &'static str,
    /// The variant.
    pub variant: Option<String>,
    /// Joint-box grid points per joint, all grid points, and those where the loops close.
    pub grid: GridSummary,
    /// The workspace's bounds and inscribed hypercube.
    pub workspace: WorkspaceSummary,
    /// Force available in every direction over the inscribed hypercube's lattice, N.
    pub force: ForceSummary,
    /// Apparent inertia's eigenvalues over the lattice, kg.
    pub inertia: InertiaSummary,
    /// The largest step of one encoder count over the lattice, m.
    pub resolution: ResolutionSummary,
    /// The Jacobian's conditioning over the lattice.
    pub isotropy: IsotropySummary,
    /// Holding the device against gravity over the lattice.
    pub gravity: GravitySummary,
    /// The stiffest wall rendered stably at the hypercube's centre and corners (2-D and 3-D
    /// tasks; absent for one task coordinate).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub renderable_stiffness: Option<StiffnessSummary>,
    /// The published figures of the device the model resembles, beside the model's
    /// (`None` from [`summarise`]; [`crate::design_published::compare`] fills it for the
    /// shipped models).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub published: Option<Comparison>,
}

/// The grid the workspace was sampled on.
#[derive(Clone, Debug, Serialize)]
pub struct GridSummary {
    /// Points per actuated joint.
    pub steps_per_joint: usize,
    /// All points.
    pub points: usize,
    /// Points where the loops close.
    pub closed: usize,
}

/// The workspace's figures.
#[derive(Clone, Debug, Serialize)]
pub struct WorkspaceSummary {
    /// Least task coordinates sampled, m.
    pub lower: Vec<f64>,
    /// Largest task coordinates sampled, m.
    pub upper: Vec<f64>,
    /// The inscribed cube (3-D tasks).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub inscribed_cube: Option<CubeSummary>,
    /// The inscribed square (planar tasks).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub inscribed_square: Option<CubeSummary>,
    /// The inscribed interval (1-D tasks).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub inscribed_interval: Option<CubeSummary>,
    /// The inscribed sphere (3-D tasks).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub inscribed_sphere: Option<BallSummary>,
    /// The inscribed disc (planar tasks).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub inscribed_disc: Option<BallSummary>,
}

/// The inscribed ball in `summary.json`.
#[derive(Clone, Debug, Serialize)]
pub struct BallSummary {
    /// Radius, m.
    pub radius: f64,
    /// Centre, m, world frame of the model.
    pub centre: Vec<f64>,
    /// Directions it was tested along (at half and at the full radius, and its centre).
    pub directions: usize,
}

/// Peak and continuous force capability.
#[derive(Clone, Debug, Serialize)]
pub struct ForceSummary {
    /// From the drives' torque limits.
    pub peak: Spread,
    /// From the drives' current limits.
    pub continuous: Spread,
}

/// Apparent inertia over the lattice.
#[derive(Clone, Debug, Serialize)]
pub struct InertiaSummary {
    /// The largest eigenvalue of Λ anywhere on the lattice, kg.
    pub max_over_cube: f64,
    /// The smallest eigenvalue of Λ anywhere on the lattice, kg.
    pub min_over_cube: f64,
    /// The largest ratio of Λ's largest to its smallest eigenvalue at one lattice point.
    pub anisotropy_max_over_cube: f64,
}

/// Resolution over the lattice.
#[derive(Clone, Debug, Serialize)]
pub struct ResolutionSummary {
    /// The coarsest step of one count, m.
    pub max_over_cube: f64,
}

/// The Jacobian's conditioning over the lattice.
#[derive(Clone, Debug, Serialize)]
pub struct IsotropySummary {
    /// `κ(J) = σ_max / σ_min` (1: isotropic).
    pub condition: Spread,
    /// The mean of `1/κ(J)` over the lattice (Gosselin & Angeles' global conditioning index
    /// over the cube, whose lattice samples it evenly): 1 for a device isotropic everywhere.
    pub global_conditioning_index: f64,
}

/// The gravity load over the lattice.
#[derive(Clone, Debug, Serialize)]
pub struct GravitySummary {
    /// Holding the device still, % of the most loaded drive's peak torque.
    pub load_percent: Spread,
}

/// The stiffest wall rendered stably, by simulation ([`crate::zwidth::largest_stable_stiffness`]).
#[derive(Clone, Debug, Serialize)]
pub struct StiffnessSummary {
    /// The wall's damping `B`, N·s/m.
    pub wall_damping: f64,
    /// The pressing hand's stiffness, N/m, and damping, N·s/m.
    pub hand: (f64, f64),
    /// Bisection steps on a log scale over `range`, N/m.
    pub bisection_steps: usize,
    /// The stiffness range searched, N/m.
    pub range: (f64, f64),
    /// The analytic bound `2 (b + B) / T` of the sampled wall with the hand's damping `b`, N/m.
    pub stability_bound: f64,
    /// The largest stable stiffness pressed at the centre along `+x`, N/m (`null`: not even
    /// the range's lower end was stable).
    pub centre: Option<f64>,
    /// At each corner, pressed along `x` towards the centre: the corner's position (m) and the
    /// stiffness, N/m (`null` as at the centre).
    pub corners: Vec<(Vec<f64>, Option<f64>)>,
    /// The least over the corners, N/m (`null` if one corner had no stable wall).
    pub min_over_corners: Option<f64>,
    /// Whether a wall at the top of `range` was stable somewhere: the figures there are lower
    /// bounds.
    pub reached_range_top: bool,
}

impl StiffnessSummary {
    /// The centre's figure with its unit (`force`/`length`), `at least` where the search's top
    /// was stable, or `none ≥` the range's lower end.
    pub fn describe(&self, force: &str, length: &str) -> String {
        match self.centre {
            Some(k) => {
                format!("{}{k:.0} {force}/{length}", if self.reached_range_top { "at least " } else { "" })
            }
            None => format!("none down to {:.0} {force}/{length}", self.range.0),
        }
    }
}

impl Summary {
    /// The inscribed ball's name (`sphere`, `disc`) and figures, for 3-D and planar tasks.
    pub fn ball(&self) -> Option<(&'static str, &BallSummary)> {
        let w = &self.workspace;
        w.inscribed_sphere.as_ref().map(|b| ("sphere", b)).or(w.inscribed_disc.as_ref().map(|b| ("disc", b)))
    }

    /// The inscribed hypercube's name and figures.
    pub fn cube(&self) -> (&'static str, Option<&CubeSummary>) {
        let w = &self.workspace;
        match (&w.inscribed_cube, &w.inscribed_square, &w.inscribed_interval) {
            (Some(c), _, _) => ("cube", Some(c)),
            (_, Some(c), _) => ("square", Some(c)),
            (_, _, c) => ("interval", c.as_ref()),
        }
    }

    /// One line with the datasheet figures, in mm, N, g and µm (rad, N·m, kg·m² and µrad for
    /// a task of joint coordinates).
    pub fn describe(&self) -> String {
        let point = self.task_unit == "m";
        let (length, scale, force, mass, mass_scale, fine) = if point {
            ("mm", 1e3, "N", "g", 1e3, "µm")
        } else {
            ("rad", 1.0, "N·m", "kg·m²", 1.0, "µrad")
        };
        let (name, cube) = self.cube();
        let Some(cube) = cube else { return format!("no inscribed {name}") };
        let centre: Vec<String> = cube.centre.iter().map(|c| fixed(c * scale, 1)).collect();
        let ball = self.ball().map_or(String::new(), |(name, b)| {
            format!("; inscribed {name} of radius {:.1} {length}", b.radius * scale)
        });
        let wall = self.renderable_stiffness.as_ref().map_or(String::new(), |k| {
            format!(
                "; stable wall {} at the centre, {} at the least corner",
                k.describe(force, self.task_unit),
                {
                    let least = StiffnessSummary { centre: k.min_over_corners, ..k.clone() };
                    least.describe(force, self.task_unit)
                }
            )
        });
        format!(
            "inscribed {name} {:.1} {length} at ({}) {length}{ball}; force in every direction over it {:.2}-{:.2} {force} \
             peak, {:.2} {force} continuous at least; apparent inertia {:.3}-{:.3} {mass}; resolution {:.1} {fine} at \
             worst; condition number of J {:.2}-{:.2}; gravity load {:.0} % of peak at most{wall}",
            cube.edge * scale,
            centre.join(", "),
            self.force.peak.min_over_cube,
            self.force.peak.max_over_cube,
            self.force.continuous.min_over_cube,
            self.inertia.min_over_cube * mass_scale,
            self.inertia.max_over_cube * mass_scale,
            self.resolution.max_over_cube * 1e6,
            self.isotropy.condition.min_over_cube,
            self.isotropy.condition.max_over_cube,
            self.gravity.load_percent.max_over_cube,
        )
    }
}

/// One figure of the model beside the device's.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct Row {
    /// The figure.
    pub figure: String,
    /// The model's, as `hapticgen report` computed it.
    pub model: String,
    /// The device's, as published.
    pub published: String,
}

/// The model's figures beside a device's published ones.
#[derive(Clone, Debug, Serialize)]
pub struct Comparison {
    /// The device.
    pub device: String,
    /// Where its figures were published.
    pub sources: Vec<String>,
    /// Figure by figure.
    pub rows: Vec<Row>,
    /// Why the model's figures may differ.
    pub notes: Vec<String>,
}

/// The Z-width search of the report for a rig whose analytic bound `2 (b + B) / T` is `bound`:
/// a wall without damping, 4 bisection steps on a log scale from `bound / 16` to `2 bound`
/// (the last step 24 % wide), runs of at least 0.75 s.
pub fn report_sweep(bound: f64) -> crate::zwidth::Sweep {
    crate::zwidth::Sweep {
        damping: vec![0.0],
        stiffness_range: (bound / 16.0, 2.0 * bound),
        steps: 4,
        duration: 0.75,
    }
}

/// The stiffest stable wall at the workspace's hypercube centre and corners.
pub fn renderable_stiffness(
    model: &CheckedModel,
    design: &Design,
    ws: &Workspace,
) -> Result<Option<StiffnessSummary>, String> {
    use crate::zwidth::{largest_stable_stiffness, Press, HAND_DAMPING, HAND_STIFFNESS};
    let m = design.task_dim();
    if !(2..=3).contains(&m) {
        return Ok(None);
    }
    let sim = crate::simulation::Simulation::from_model(model.clone())?;
    let sample_period = 1.0 / f64::from(model.rates.impedance_loop_hz);
    let wall_damping = 0.0;
    let stability_bound =
        hapticgen_codegen::check::stability::stable_stiffness(HAND_DAMPING, wall_damping, sample_period);
    let settings = report_sweep(stability_bound);
    let half = 0.5 * ws.edge;
    // The centre, then the corners (first coordinate fastest).
    let mut places = vec![(ws.centre.clone(), 1.0)];
    for corner in 0..1usize << m {
        let at: Vec<f64> =
            (0..m).map(|k| ws.centre[k] + if corner >> k & 1 == 1 { half } else { -half }).collect();
        let side = if corner & 1 == 1 { -1.0 } else { 1.0 };
        places.push((at, side));
    }
    let stiffness: Result<Vec<Option<f64>>, String> = places
        .par_iter()
        .map(|(x, side)| {
            let start = design
                .inverse_kinematics(x, &ws.nearest(x).q)
                .ok_or_else(|| format!("no joint state reaches the cube's point {x:?}"))?;
            // The run lasts four periods of the device's heaviest direction on the hand's spring
            // (at least 0.75 s, at most 6 s), so that a slow device's approach has settled.
            let heaviest =
                design.sample(&start).and_then(|s| design.apparent_inertia(&s)).map_or(0.0, |l| l.1);
            let period = std::f64::consts::TAU * (heaviest / HAND_STIFFNESS).sqrt();
            let settings = crate::zwidth::Sweep {
                duration: (4.0 * period).clamp(settings.duration, 6.0),
                ..settings.clone()
            };
            largest_stable_stiffness(&sim, &Press { start, axis: 0, side: *side }, wall_damping, &settings)
        })
        .collect();
    let stiffness = stiffness?;
    // A value within the search's last step of its top is only a lower bound.
    let (low, high) = settings.stiffness_range;
    let last_step = (high / low).powf(0.5f64.powi(settings.steps as i32));
    let reached_range_top = stiffness.iter().flatten().any(|&k| k * last_step >= high * (1.0 - 1e-9));
    let corners: Vec<(Vec<f64>, Option<f64>)> =
        places[1..].iter().map(|p| p.0.clone()).zip(stiffness[1..].iter().copied()).collect();
    Ok(Some(StiffnessSummary {
        wall_damping,
        hand: (HAND_STIFFNESS, HAND_DAMPING),
        bisection_steps: settings.steps,
        range: settings.stiffness_range,
        stability_bound,
        reached_range_top,
        centre: stiffness[0],
        min_over_corners: corners
            .iter()
            .map(|c| c.1)
            .try_fold(f64::INFINITY, |least, k| k.map(|k| least.min(k))),
        corners,
    }))
}

/// Computes every figure of `model` on a grid of `steps` per joint (the renderable stiffness
/// only with `zwidth`: it simulates).
pub fn summarise(
    model: &CheckedModel,
    steps: usize,
    zwidth: bool,
) -> Result<(Summary, Workspace), DesignError> {
    let design = Design::new(model);
    eprintln!(
        "report: sampling {} poses of the joint box ({steps} per joint)",
        steps.pow(design.joints() as u32)
    );
    let ws = design.workspace(steps)?;
    let m = design.task_dim();
    let (unit, scale) = if design.task_is_point() { ("mm", 1e3) } else { ("rad", 1.0) };
    eprintln!(
        "report: the inscribed hypercube ({:.1} {unit} edge) and ball ({:.1} {unit} radius) found; figures over the \
         hypercube's lattice",
        ws.edge * scale,
        ws.ball.1 * scale
    );
    let on_cube: Vec<Figures> =
        ws.lattice.iter().filter_map(|q| design.sample(q)).map(|s| design.figures(&s)).collect();
    let cube = CubeSummary { edge: ws.edge, centre: ws.centre.clone(), probes_per_edge: CUBE_PROBES };
    let ball = BallSummary {
        radius: ws.ball.1,
        centre: ws.ball.0.clone(),
        directions: if m == 2 { BALL_DIRECTIONS.0 } else { BALL_DIRECTIONS.1 },
    };
    let (lower, upper) = ws.bounds();
    let over = |f: fn(&Figures) -> f64| spread(on_cube.iter().map(f).collect());
    let finite_inertia: Vec<&Figures> = on_cube.iter().filter(|f| f.inertia_max.is_finite()).collect();
    let renderable_stiffness = if zwidth {
        eprintln!("report: the stiffest stable wall at the centre and the corners (simulated)");
        renderable_stiffness(model, &design, &ws).map_err(DesignError::Simulation)?
    } else {
        None
    };
    let summary = Summary {
        model: model.name.clone(),
        task_unit: if design.task_is_point() { "m" } else { "rad" },
        variant: model.variant.clone(),
        grid: GridSummary { steps_per_joint: ws.grid.0, points: ws.grid.1, closed: ws.samples.len() },
        workspace: WorkspaceSummary {
            lower,
            upper,
            inscribed_cube: (m == 3).then(|| cube.clone()),
            inscribed_square: (m == 2).then(|| cube.clone()),
            inscribed_interval: (m == 1).then_some(cube),
            inscribed_sphere: (m == 3).then(|| ball.clone()),
            inscribed_disc: (m == 2).then_some(ball),
        },
        force: ForceSummary { peak: over(|f| f.force_peak), continuous: over(|f| f.force_continuous) },
        inertia: InertiaSummary {
            max_over_cube: finite_inertia.iter().map(|f| f.inertia_max).fold(0.0, f64::max),
            min_over_cube: finite_inertia.iter().map(|f| f.inertia_min).fold(f64::INFINITY, f64::min),
            anisotropy_max_over_cube: finite_inertia
                .iter()
                .map(|f| f.inertia_max / f.inertia_min)
                .fold(0.0, f64::max),
        },
        resolution: ResolutionSummary {
            max_over_cube: on_cube.iter().map(|f| f.resolution).fold(0.0, f64::max),
        },
        isotropy: IsotropySummary {
            condition: over(|f| f.condition),
            global_conditioning_index: on_cube.iter().map(|f| 1.0 / f.condition).sum::<f64>()
                / on_cube.len().max(1) as f64,
        },
        gravity: GravitySummary { load_percent: over(|f| f.gravity_load) },
        renderable_stiffness,
        published: None,
    };
    Ok((summary, ws))
}
