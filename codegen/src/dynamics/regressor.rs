//! The dynamic-identification regressor: the inverse dynamics written linear in the base
//! parameters,
//!
//! ```text
//! τ = D(q) q̈ + C(q, q̇) q̇ + g(q) + F_v q̇ + F_c sgn_δ(q̇) + τ_off = Y(q, q̇, q̈) β
//! ```
//!
//! **Standard parameters.** Per body ten (Khalil and Kleinfinger's): mass `m`, first moment
//! `m c = (mx, my, mz)` and the inertia about the frame origin `(xx, xy, xz, yy, yz, zz)`
//! (tensor entries); per joint four: the reflected rotor inertia `ia = N² J_m` (through a
//! transmission's coupling `a = C q`, drive `k`'s column is `C_kᵀ (C_k q̈)`), viscous
//! friction `fv` (the model's damping `B`), Coulomb friction `fc` (the drive's
//! `coulomb_friction`) with the smoothed sign `sgn_δ(v) = v / √(v² + δ²)`, `δ =`
//! [`COULOMB_BAND`], and a constant torque offset `off` (nominal 0). Serial trees (the
//! recursive path) take each body's parameters in its *joint frame* (after the joint, before a
//! Denavit–Hartenberg tail); every other model (closed chains, direct poses, measured or mimic
//! joints) in its *body frame*.
//!
//! **Columns.** The inverse dynamics is linear in the standard parameters, so each column is
//! the inverse dynamics with that parameter 1 and every other 0: on the recursive path the
//! Newton–Euler algorithm with unit parameters ([`super::recursive`]); otherwise the Lagrangian
//! derivation run once with every body parameter a symbolic atom, `τ` split by the atoms'
//! monomials (`m` alone, `m·c_i`, the central inertia's entries: the `m c_i c_j` terms are the
//! parallel-axis part and belong to the inertia's columns). A closed chain's columns reduce as
//! its dynamics do: `Y_a = Sᵀ Y_tree(q, S q̇_a, S q̈_a + Ṡ q̇_a)` with `S = [I; A]`
//! ([`super::closure`]), in the atoms of the loop solution.
//!
//! **Base parameters.** The columns are sampled at random states (actuated joints inside their
//! limits, loops closing) and stacked; going through them in order (bodies from the base out,
//! then the drives' columns), a column in the span of the columns kept before it (modified
//! Gram–Schmidt, relative residual below 1e-7) is not kept: its parameter is regrouped into
//! the kept ones with the coefficients of that dependence, `Y₂ = Y₁ K`, `β = β₁ + K β₂`
//! (Gautier 1990; the same grouping as Khalil's symbolic rules, e.g. `zz1 + l1²·m2`). Columns
//! that are zero everywhere (parameters that no motion reveals) are dropped, and so are the
//! parameters of a body the model makes massless as an expression (a universal joint's cross,
//! a frame carrying a point): zero by construction, not unknowns. Coefficients are
//! numbers at the nominal values of the tunable parameters.

// Matrix code reads best with explicit indices.
#![allow(clippy::needless_range_loop)]

use rustc_hash::FxHashMap as HashMap;

use super::closure::Closures;
use super::kinematics::{body_frames, mat_vec, vec_add};
use super::lagrangian::lagrangian_inertia_matrix;
use super::recursive::{self, INERTIA_ENTRIES};
use crate::model::{JointKind, Model};
use crate::sym::dag::{Dag, NodeId};
use crate::sym::poly::{Atom, AtomValues, Monomial, Poly, State};

/// The velocity band `δ` of the Coulomb columns' smoothed sign `v / √(v² + δ²)`, rad/s (m/s for
/// a prismatic joint): 0.995 of the full value at 10 δ.
pub const COULOMB_BAND: f64 = 0.01;

/// Relative residual under which a column counts as a combination of the columns before it.
const DEPENDENT: f64 = 1e-7;

const BODY_PARAMETERS: [&str; 10] = ["m", "mx", "my", "mz", "xx", "xy", "xz", "yy", "yz", "zz"];

/// How a standard parameter's column is built.
#[derive(Clone, Debug)]
enum Column {
    /// One polynomial per actuated joint.
    Poly(Vec<Poly>),
    /// Column `k` of [`recursive::standard_columns`].
    Recursive(usize),
    /// The smoothed sign of joint `j`'s velocity, in row `j`.
    Coulomb(usize),
}

/// One standard parameter.
#[derive(Clone, Debug)]
pub struct StandardParameter {
    /// Its name, e.g. `zz_upper_arm`, `fv_shoulder`.
    pub name: String,
    /// Its unit.
    pub unit: &'static str,
    /// Its value in the model (at the nominal tunable parameters).
    pub nominal: f64,
    column: Column,
}

/// One base parameter: a kept standard parameter and what is regrouped into it.
#[derive(Clone, Debug)]
pub struct BaseParameter {
    /// A readable name: the kept standard parameter's, `_r` appended where others are
    /// regrouped into it (Khalil's `R`).
    pub name: String,
    /// `(standard parameter, coefficient)`, the kept one first with coefficient 1.
    pub combination: Vec<(usize, f64)>,
    /// Its value at the nominal model.
    pub nominal: f64,
}

/// A model's base regressor (see the module documentation).
#[derive(Clone, Debug)]
pub struct Regressor {
    /// Every standard parameter, in column order.
    pub standard: Vec<StandardParameter>,
    /// The base parameters, in the order of the regressor's columns.
    pub base: Vec<BaseParameter>,
    /// Number of actuated joints (rows).
    pub joints: usize,
    /// Whether the body parameters are in the joint frames (the recursive path).
    pub joint_frames: bool,
}

impl BaseParameter {
    /// `zz_link1 + 0.09·m_link2 + ia_shoulder`: the standard parameters it combines.
    pub fn describe(&self, standard: &[StandardParameter]) -> String {
        let mut out = String::new();
        for (i, &(s, c)) in self.combination.iter().enumerate() {
            let name = &standard[s].name;
            let (sign, magnitude) = if c < 0.0 { ("−", -c) } else { ("+", c) };
            if i == 0 {
                if sign == "−" {
                    out.push('−');
                }
            } else {
                out.push_str(&format!(" {sign} "));
            }
            if (magnitude - 1.0).abs() > 1e-12 {
                out.push_str(&format!("{}·", number(magnitude)));
            }
            out.push_str(name);
        }
        out
    }
}

/// A coefficient with six significant digits, trailing zeros trimmed.
fn number(x: f64) -> String {
    let digits = 5 - x.abs().log10().floor().clamp(-10.0, 5.0) as i32;
    let text = format!("{:.*}", digits.max(0) as usize, x);
    if text.contains('.') {
        text.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        text
    }
}

/// The tunable parameters' values (what the model's inertial data and damping may depend on).
struct Nominal<'a>(&'a [f64]);

impl AtomValues for Nominal<'_> {
    fn value(&self, atom: Atom) -> f64 {
        match atom {
            Atom::Param(k) => self.0.get(usize::from(k)).copied().unwrap_or(0.0),
            _ => 0.0,
        }
    }
}

/// Atom values at a sample: the state, its accelerations and a closed chain's elimination.
struct Sample<'a> {
    state: State<'a>,
    qdd: &'a [f64],
    eliminated: HashMap<Atom, f64>,
}

impl AtomValues for Sample<'_> {
    fn value(&self, atom: Atom) -> f64 {
        if let Atom::Qdd(j) = atom {
            return self.qdd.get(usize::from(j)).copied().unwrap_or(0.0);
        }
        match self.eliminated.get(&atom) {
            Some(&v) => v,
            None => self.state.value(atom),
        }
    }
}

/// A small deterministic generator (xorshift64*), so that generation is reproducible.
struct Random(u64);

impl Random {
    fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        let bits = self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11;
        lo + (hi - lo) * (bits as f64 / (1u64 << 53) as f64)
    }
}

impl Regressor {
    /// The base regressor of a model (`closures`: a closed chain's analysis).
    pub fn new(model: &Model, closures: Option<&Closures>) -> Self {
        let joint_frames = recursive::applies(model);
        let params = model.nominal_parameters();
        // Per body (ten standard parameters each, in order): whether the model makes it
        // massless as an expression, whatever the tunable parameters (a universal joint's
        // cross, a frame that only carries a point).
        let massless: Vec<bool> = if joint_frames {
            recursive::joint_frame_parameters(model)
                .iter()
                .map(|(_, values)| values.iter().all(Poly::is_zero))
                .collect()
        } else {
            model
                .bodies
                .iter()
                .map(|b| b.mass.is_zero() && b.inertia.iter().flatten().all(Poly::is_zero))
                .collect()
        };
        let mut standard = if joint_frames {
            let mut out = Vec::new();
            for (body, values) in recursive::joint_frame_parameters(model) {
                for (k, value) in values.iter().enumerate() {
                    out.push(StandardParameter {
                        name: format!("{}_{body}", BODY_PARAMETERS[k]),
                        unit: body_unit(k),
                        nominal: value.eval(&Nominal(&params)),
                        column: Column::Recursive(out.len()),
                    });
                }
            }
            out
        } else {
            polynomial_columns(model, closures, &params)
        };
        standard.extend(drive_columns(model));
        let n = model.joints.len();
        let mut samples = sample(model, closures, &standard, &params);
        // A massless body's parameters are zero by the model's construction, not unknowns: the
        // file has nowhere to write a cross's mass. Their columns are dropped as a column no
        // motion reveals would be, so what they would have absorbed stays with the bodies
        // that have mass (and a Delta's fit has ten fewer barely-seen combinations).
        for (body, _) in massless.iter().enumerate().filter(|(_, &m)| m) {
            for column in &mut samples[10 * body..10 * body + 10] {
                column.fill(0.0);
            }
        }
        let base = reduce(&standard, &samples, n);
        Regressor { standard, base, joints: n, joint_frames }
    }

    /// The standard parameters' values of a model with the same structure as the one this
    /// regressor was built for (e.g. with other masses), in the order of [`Self::standard`].
    pub fn standard_values(&self, model: &Model) -> Vec<f64> {
        let params = model.nominal_parameters();
        let nominal = Nominal(&params);
        let mut values: Vec<f64> = if self.joint_frames {
            recursive::joint_frame_parameters(model)
                .iter()
                .flat_map(|(_, v)| v.iter().map(|p| p.eval(&nominal)).collect::<Vec<_>>())
                .collect()
        } else {
            model.bodies.iter().flat_map(|b| body_frame_parameters(b, &nominal)).collect()
        };
        values.extend(drive_columns(model).iter().map(|p| p.nominal));
        values
    }

    /// The base parameters from standard ones (`β = β₁ + K β₂`).
    pub fn base_values(&self, standard: &[f64]) -> Vec<f64> {
        self.base.iter().map(|b| b.combination.iter().map(|&(s, c)| c * standard[s]).sum()).collect()
    }

    /// Builds `Y` into `dag`, row-major (`joints` rows, one column per base parameter).
    pub fn build(&self, dag: &mut Dag, model: &Model) -> Vec<NodeId> {
        let recursive_columns = if self.joint_frames {
            let columns = recursive::standard_columns(dag, model);
            // The passes with unit parameters name their forces and moments as the dynamics'
            // would; those values are not forces here (the kinematics' names stay true).
            dag.retain_hints(|name| !name.contains("_force") && !name.contains("_moment"));
            columns
        } else {
            Vec::new()
        };
        let p = self.base.len();
        let mut out = vec![dag.constant(0.0); self.joints * p];
        for (c, base) in self.base.iter().enumerate() {
            let column = &self.standard[base.combination[0].0].column;
            for row in 0..self.joints {
                out[row * p + c] = match column {
                    Column::Poly(polys) => dag.polynomial(&polys[row]),
                    Column::Recursive(k) => recursive_columns[*k][row],
                    Column::Coulomb(j) if *j == row => {
                        let qd = dag.input(Atom::Qd(row as u16));
                        let square = dag.mul(qd, qd);
                        let band = dag.constant(COULOMB_BAND * COULOMB_BAND);
                        let sum = dag.add(square, band);
                        let root = dag.sqrt(sum);
                        dag.div(qd, root)
                    }
                    Column::Coulomb(_) => dag.constant(0.0),
                };
            }
        }
        out
    }
}

fn body_unit(k: usize) -> &'static str {
    match k {
        0 => "kg",
        1..=3 => "kg·m",
        _ => "kg·m²",
    }
}

/// A body's ten standard parameters in its body frame: `m`, `m c`, `I_c + m (|c|² 1 − c cᵀ)`.
fn body_frame_parameters(body: &crate::model::ResolvedBody, nominal: &impl AtomValues) -> Vec<f64> {
    let m = body.mass.eval(nominal);
    let c: Vec<f64> = body.com.iter().map(|p| p.eval(nominal)).collect();
    let c2: f64 = c.iter().map(|x| x * x).sum();
    let mut out = vec![m, m * c[0], m * c[1], m * c[2]];
    for (r, s) in INERTIA_ENTRIES {
        let delta = if r == s { 1.0 } else { 0.0 };
        out.push(body.inertia[r][s].eval(nominal) + m * (c2 * delta - c[r] * c[s]));
    }
    out
}

/// The drives' columns: rotor inertia, viscous and Coulomb friction, offset, per joint.
fn drive_columns(model: &Model) -> Vec<StandardParameter> {
    let n = model.joints.len();
    let params = model.nominal_parameters();
    let mut out = Vec::new();
    let unit_vector = |j: usize, value: Poly| -> Vec<Poly> {
        (0..n).map(|r| if r == j { value.clone() } else { Poly::zero() }).collect()
    };
    for (j, joint) in model.joints.iter().enumerate() {
        let revolute = joint.kind == JointKind::Revolute;
        let rotor = joint.drive.gear_ratio * joint.drive.gear_ratio * joint.drive.motor.rotor_inertia;
        // Drive k's rotor turns with a_k = C_k q: its column is C_kᵀ (C_k q̈).
        let rotor_column: Vec<Poly> = match &model.coupling {
            None => unit_vector(j, Poly::atom(Atom::Qdd(j as u16))),
            Some(coupling) => {
                let row = &coupling.drive_from_joint[j];
                let acceleration = Poly::sum(
                    &(0..n).map(|b| Poly::atom(Atom::Qdd(b as u16)).scale(row[b])).collect::<Vec<_>>(),
                );
                (0..n).map(|r| acceleration.scale(row[r])).collect()
            }
        };
        let name = &joint.name;
        out.push(StandardParameter {
            name: format!("ia_{name}"),
            unit: if revolute { "kg·m²" } else { "kg" },
            nominal: rotor,
            column: Column::Poly(rotor_column),
        });
        out.push(StandardParameter {
            name: format!("fv_{name}"),
            unit: if revolute { "N·m·s/rad" } else { "N·s/m" },
            nominal: joint.damping.eval(&Nominal(&params)),
            column: Column::Poly(unit_vector(j, Poly::atom(Atom::Qd(j as u16)))),
        });
        out.push(StandardParameter {
            name: format!("fc_{name}"),
            unit: if revolute { "N·m" } else { "N" },
            nominal: joint.drive.coulomb_friction,
            column: Column::Coulomb(j),
        });
        out.push(StandardParameter {
            name: format!("off_{name}"),
            unit: if revolute { "N·m" } else { "N" },
            nominal: 0.0,
            column: Column::Poly(unit_vector(j, Poly::constant(1.0))),
        });
    }
    out
}

/// The body columns of a model off the recursive path, by the Lagrangian derivation with
/// symbolic body parameters (see the module documentation), reduced to the actuated joints.
fn polynomial_columns(model: &Model, closures: Option<&Closures>, params: &[f64]) -> Vec<StandardParameter> {
    let first = model.tunable.len();
    let atom = |b: usize, k: usize| Atom::Param((first + 10 * b + k) as u16);
    let mut symbolic = model.clone();
    for (b, body) in symbolic.bodies.iter_mut().enumerate() {
        body.mass = Poly::atom(atom(b, 0));
        body.com = std::array::from_fn(|i| Poly::atom(atom(b, 1 + i)));
        let mut inertia: [[Poly; 3]; 3] = Default::default();
        for (e, &(r, c)) in INERTIA_ENTRIES.iter().enumerate() {
            inertia[r][c] = Poly::atom(atom(b, 4 + e));
            inertia[c][r] = Poly::atom(atom(b, 4 + e));
        }
        body.inertia = inertia;
    }
    for joint in &mut symbolic.joints {
        joint.drive.motor.rotor_inertia = 0.0;
    }
    let n_tree = symbolic.tree_coordinates();
    let frames = body_frames(&symbolic);
    let inertia = lagrangian_inertia_matrix(&symbolic, &frames);
    let mut potential = Vec::new();
    for (body, frame) in symbolic.bodies.iter().zip(&frames) {
        let com_world = vec_add(&frame.origin, &mat_vec(&frame.rotation, &body.com));
        for (g, r) in symbolic.gravity.iter().zip(&com_world) {
            potential.push(body.mass.mul(g).mul(r).scale(-1.0));
        }
    }
    let potential = Poly::sum(&potential);

    // Which column a monomial of the parameter atoms belongs to (None: a parallel-axis term).
    let key = |params: &[(Atom, u32)]| -> Option<(usize, usize)> {
        let index = |a: Atom| match a {
            Atom::Param(k) => usize::from(k) - first,
            _ => unreachable!(),
        };
        match params {
            [(a, 1)] => Some((index(*a) / 10, index(*a) % 10)).filter(|&(_, k)| k == 0 || k >= 4),
            [(a, 1), (c, 1)] if index(*a) % 10 == 0 => Some((index(*a) / 10, index(*c) % 10)),
            _ => None,
        }
    };
    let split = |poly: &Poly| -> HashMap<(usize, usize), Poly> {
        let mut terms: HashMap<(usize, usize), Vec<(Monomial, f64)>> = HashMap::default();
        for (monomial, c) in poly.terms() {
            let (params, rest): (Vec<_>, Vec<_>) =
                monomial.iter().partition(|(a, _)| matches!(a, Atom::Param(k) if usize::from(*k) >= first));
            if params.is_empty() {
                continue;
            }
            if let Some(k) = key(&params) {
                terms.entry(k).or_default().push((rest, c));
            }
        }
        terms.into_iter().map(|(k, t)| (k, Poly::from_terms(t))).collect()
    };
    let mut d_columns: HashMap<(usize, usize), Vec<Vec<Poly>>> = HashMap::default();
    for r in 0..n_tree {
        for c in 0..n_tree {
            for (k, p) in split(&inertia[r][c]) {
                d_columns.entry(k).or_insert_with(|| vec![vec![Poly::zero(); n_tree]; n_tree])[r][c] = p;
            }
        }
    }
    let v_columns = split(&potential);

    let n = model.joints.len();
    // q̈ of the tree: q̈_a, and S q̈_a + Ṡ q̇_a for a closed chain's passive joints.
    let entry = |i: usize, j: usize, rate: bool| -> Poly {
        match closures.and_then(|c| c.sensitivity_atom(i, j, rate)) {
            Some(atom) => Poly::atom(atom),
            None if !rate && i == j => Poly::constant(1.0),
            None => Poly::zero(),
        }
    };
    let tree_qdd: Vec<Poly> = (0..n_tree)
        .map(|i| {
            let terms: Vec<Poly> = (0..n)
                .flat_map(|j| {
                    [
                        entry(i, j, false).mul(&Poly::atom(Atom::Qdd(j as u16))),
                        entry(i, j, true).mul(&Poly::atom(Atom::Qd(j as u16))),
                    ]
                })
                .collect();
            Poly::sum(&terms)
        })
        .collect();
    let qd = |i: usize| Poly::atom(Atom::Qd(i as u16));
    let nominal = Nominal(params);
    let mut out = Vec::new();
    for (b, body) in model.bodies.iter().enumerate() {
        let values = body_frame_parameters(body, &nominal);
        for (k, &value) in values.iter().enumerate() {
            let zero = vec![vec![Poly::zero(); n_tree]; n_tree];
            let d = d_columns.get(&(b, k)).unwrap_or(&zero);
            let v = v_columns.get(&(b, k)).cloned().unwrap_or_default();
            let partials: Vec<Vec<Vec<Poly>>> = (0..n_tree)
                .map(|a| d.iter().map(|row| row.iter().map(|p| p.diff_q(a as u16)).collect()).collect())
                .collect();
            // τ_i = Σ_l D_il q̈_l + Σ_ac (∂_a D_ic − ½ ∂_i D_ac) q̇_a q̇_c + ∂_i V
            let tree: Vec<Poly> = (0..n_tree)
                .map(|i| {
                    let mut terms: Vec<Poly> = Vec::new();
                    for l in 0..n_tree {
                        if !d[i][l].is_zero() {
                            terms.push(d[i][l].mul(&tree_qdd[l]));
                        }
                    }
                    for a in 0..n_tree {
                        for c in 0..n_tree {
                            let symbol = partials[a][i][c].sub(&partials[i][a][c].scale(0.5));
                            if !symbol.is_zero() {
                                terms.push(symbol.mul(&qd(a)).mul(&qd(c)));
                            }
                        }
                    }
                    terms.push(v.diff_q(i as u16));
                    Poly::sum(&terms)
                })
                .collect();
            // Y_a = Sᵀ Y_tree.
            let reduced: Vec<Poly> = (0..n)
                .map(|j| {
                    Poly::sum(&(0..n_tree).map(|i| entry(i, j, false).mul(&tree[i])).collect::<Vec<_>>())
                })
                .collect();
            out.push(StandardParameter {
                name: format!("{}_{}", BODY_PARAMETERS[k], body.name),
                unit: body_unit(k),
                nominal: value,
                column: Column::Poly(reduced),
            });
        }
    }
    out
}

/// Every standard column at random states, stacked: `columns[s]` has one entry per joint per
/// state.
fn sample(
    model: &Model,
    closures: Option<&Closures>,
    standard: &[StandardParameter],
    params: &[f64],
) -> Vec<Vec<f64>> {
    let n = model.joints.len();
    let states = (3 * standard.len()).div_ceil(n.max(1)) + 10;
    let mut recursive_dag = Dag::new();
    let recursive_columns = if standard.iter().any(|s| matches!(s.column, Column::Recursive(_))) {
        recursive::standard_columns(&mut recursive_dag, model)
    } else {
        Vec::new()
    };
    let mut rng = Random(0x9E37_79B9_7F4A_7C15);
    let mut columns = vec![Vec::with_capacity(states * n); standard.len()];
    let mut taken = 0;
    let mut attempts = 0;
    while taken < states && attempts < 100 * states {
        attempts += 1;
        let range = |lo: f64, hi: f64| {
            let (lo, hi) = (lo.max(-std::f64::consts::PI), hi.min(std::f64::consts::PI));
            let margin = 0.1 * (hi - lo);
            (lo + margin, hi - margin)
        };
        let q: Vec<f64> = model
            .joints
            .iter()
            .map(|j| {
                let (lo, hi) = range(j.lower, j.upper);
                rng.uniform(lo, hi)
            })
            .collect();
        let qd: Vec<f64> = (0..n).map(|_| rng.uniform(-2.0, 2.0)).collect();
        let qdd: Vec<f64> = (0..n).map(|_| rng.uniform(-5.0, 5.0)).collect();
        let eliminated =
            closures.map(|c| c.values(&q, &qd, params).into_iter().collect()).unwrap_or_default();
        let values = Sample { state: State { q: &q, qd: &qd, parameters: params }, qdd: &qdd, eliminated };
        let dag_values = if recursive_columns.is_empty() {
            Vec::new()
        } else {
            recursive_dag.eval_all(&|a| values.value(a))
        };
        let mut block: Vec<Vec<f64>> = Vec::with_capacity(standard.len());
        for s in standard {
            let column: Vec<f64> = match &s.column {
                Column::Poly(polys) => polys.iter().map(|p| p.eval(&values)).collect(),
                Column::Recursive(k) => recursive_columns[*k].iter().map(|&id| dag_values[id]).collect(),
                Column::Coulomb(j) => (0..n)
                    .map(|r| {
                        if r == *j {
                            qd[r] / (qd[r] * qd[r] + COULOMB_BAND * COULOMB_BAND).sqrt()
                        } else {
                            0.0
                        }
                    })
                    .collect(),
            };
            block.push(column);
        }
        if block.iter().flatten().any(|x| !x.is_finite()) {
            continue;
        }
        for (column, values) in columns.iter_mut().zip(block) {
            column.extend(values);
        }
        taken += 1;
    }
    columns
}

/// The base parameters from the sampled columns (see the module documentation).
fn reduce(standard: &[StandardParameter], columns: &[Vec<f64>], joints: usize) -> Vec<BaseParameter> {
    let _ = joints;
    let norm = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
    let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
    let largest = columns.iter().map(|c| norm(c)).fold(0.0, f64::max);
    // Orthonormal basis of the kept columns, and R (kept column k = Σ_i R[i][k] basis_i).
    let mut basis: Vec<Vec<f64>> = Vec::new();
    let mut r: Vec<Vec<f64>> = Vec::new();
    let mut kept: Vec<usize> = Vec::new();
    let mut base: Vec<BaseParameter> = Vec::new();
    for (s, column) in columns.iter().enumerate() {
        let size = norm(column);
        if size <= 1e-10 * largest {
            continue;
        }
        let mut residual = column.clone();
        let mut coefficients = vec![0.0; basis.len()];
        for _ in 0..2 {
            for (i, b) in basis.iter().enumerate() {
                let c = dot(b, &residual);
                coefficients[i] += c;
                for (x, y) in residual.iter_mut().zip(b) {
                    *x -= c * y;
                }
            }
        }
        let rest = norm(&residual);
        if rest > DEPENDENT * size {
            for x in &mut residual {
                *x /= rest;
            }
            basis.push(residual);
            coefficients.push(rest);
            r.push(coefficients);
            kept.push(s);
            base.push(BaseParameter {
                name: standard[s].name.clone(),
                combination: vec![(s, 1.0)],
                nominal: 0.0,
            });
            continue;
        }
        // column = Σ_k x_k kept_k: back-substitution R x = coefficients.
        let m = kept.len();
        let mut x = vec![0.0; m];
        for k in (0..m).rev() {
            let mut value = coefficients[k];
            for (l, &xl) in x.iter().enumerate().skip(k + 1) {
                value -= r[l][k] * xl;
            }
            x[k] = value / r[k][k];
        }
        for (k, &c) in x.iter().enumerate() {
            let c = if (c - c.round()).abs() < 1e-9 { c.round() } else { c };
            if c.abs() > 1e-9 {
                base[k].combination.push((s, c));
            }
        }
    }
    for b in &mut base {
        if b.combination.len() > 1 {
            b.name.push_str("_r");
        }
        b.nominal = b.combination.iter().map(|&(s, c)| c * standard[s].nominal).sum();
    }
    base
}
