//! From identified base parameters `β̂` to physically consistent standard parameters `π`.
//!
//! The inverse dynamics is linear in the base parameters, `τ = Y(q, q̇, q̈) β`, and
//! `β = K π` with `K` the base combinations of the regressor
//! ([`hapticgen_codegen::dynamics::regressor`]). Many `π` give the same `β`; this module picks
//!
//! ```text
//! min_π  ‖W (K π − β̂)‖² + λ ‖S (π − π₀)‖²
//! s.t.   J_b(π) ⪰ 0 for every body (m_b > 0),  ia, fv, fc ≥ 0
//! ```
//!
//! with `W = diag(1/σ_i)` (the identified standard deviations; without them `1/s_i`, `s_i` the
//! base parameter's size from the nominal model's scales), `S` a relative scaling per
//! parameter (mass `m₀`, first moment `m₀ ℓ`, inertia `m₀ ℓ²`, `ℓ` the body's radius of
//! gyration about its frame origin, at least a tenth of the model's largest), `π₀` the model
//! file's values, and `J_b` the body's pseudo-inertia (Wensing, Kim and Slotine 2017)
//!
//! ```text
//! J = [ ½ tr(Ī) 1 − Ī   h ]   = ∫ [p; 1] [p; 1]ᵀ dm,     Ī the inertia about the frame origin,
//!     [ hᵀ              m ]                              h = m c
//! ```
//!
//! positive semi-definite exactly when some mass distribution has those moments.
//!
//! **Method: a barrier method on the standard parameters** (Boyd and Vandenberghe, *Convex
//! Optimization*, ch. 11). The unknowns are the body parameters `v_b = (m, m c, Ī_o)` in the
//! file's body frames and the drive parameters, so `π` is linear in them, the objective is a
//! convex quadratic and the constraints are the cones `J_b ⪰ 0`, `x ≥ 0`: the problem is
//! convex, and
//!
//! ```text
//! min  ‖r(v)‖² − t (Σ_b log det J_b(v) + Σ log x)
//! ```
//!
//! is solved by damped Newton steps that stay strictly inside the cones (every iterate is a
//! physical model), for `t` from 10⁻⁴ down to 10⁻¹⁸; the gradient and Hessian of `log det J`
//! are `tr(J⁻¹ A_k)` and `−tr(J⁻¹ A_k J⁻¹ A_l)`, `A_k = ∂J/∂v_k` constant. The solution then
//! lies within about `t` of the cone's boundary where the data push it there: the shipped
//! models' bodies are slender rods and point masses, on the boundary already.
//!
//! Tried first and dropped: the log-Cholesky parametrisation `J = U Uᵀ` (Rucker and Wensing
//! 2022) with Levenberg–Marquardt, as the task suggested — every iterate consistent and no
//! constraint handling, but on these models, whose true bodies lie on the boundary, it
//! crawled (`e^{d} → 0`; the PHANToM Premium-like arm stalled at a misfit of 10⁻³ after
//! 1,200 iterations). An SDP solver (Clarabel) would do the same job with a dependency and,
//! for its PSD cones, a BLAS/LAPACK backend; the barrier method is 100 lines on nalgebra.
//!
//! **Exact when feasible.** The weight `λ` goes down by 100 per stage from 10⁻² to
//! [`FitOptions::regularisation`] (10⁻¹⁰), each stage started from the last: the data term is
//! met to about `λ` where a consistent `π` reproduces `β̂`, and the parameters `β̂` leaves
//! free stay near the file's values. Where no consistent `π` reproduces `β̂`, lowering `λ` no
//! longer improves the fit and only lets the free parameters drift (a fixed-base link's mass
//! grows without bound to make room for a too-small inertia): the stages stop when a stage
//! does not halve the misfit.
//!
//! **Planar models** (`space: planar`) have a body's mass, its centre of mass in the plane and
//! its moment about z only (the file cannot say more): per body the unknowns are
//! `(m, h_x, h_y, zz)`, the out-of-plane parameters following from these as the loader computes
//! them (`c_z = 0`, no out-of-plane central inertia; no base parameter holds them).
//! Consistency is then `m > 0`, `I_zz,c = zz − |h|²/m ≥ 0`, i.e. the plane's pseudo-inertia
//! `[[zz, h_x, h_y], [h_x, m, 0], [h_y, 0, m]] ⪰ 0` (reported as the equivalent
//! `[[I_zz,c/2·1 + m c cᵀ, m c], [m cᵀ, m]]`).
//!
//! **Massless bodies** (the crosses of universal joints, a measured gimbal's lumped bodies:
//! `mass: 0` in the file) keep every parameter 0: the file says their mass is elsewhere.
//! **Drives**: viscous (`fv`, the joint's `damping`) and Coulomb (`fc`) friction are
//! `≥ 0`; the offset `off` is free (the model file has no field for it); a reflected rotor
//! inertia `ia = N² J_m ≥ 0` is fitted only where it is a base parameter of its own, and
//! otherwise kept at the file's value (its base parameter's other members take the change).
//!
//! The body parameters are fitted in the file's body frame (what the model file writes); the
//! regressor's frame (a serial tree's joint frames) is reached by the linear map
//! `π_b = L_b v_b`, `v_b = (m, m c, Ī_o)` in the body frame, which is taken from
//! [`Regressor::standard_values`] on probe models (a congruence of `J`, so consistency is the
//! same in either frame).

use hapticgen_codegen::dynamics::regressor::Regressor;
use hapticgen_codegen::model::JointKind;
use hapticgen_codegen::sym::poly::Poly;
use hapticgen_codegen::CheckedModel;
use nalgebra::{DMatrix, DVector, Matrix3, Matrix4, SymmetricEigen};

/// The six distinct entries of a symmetric 3 × 3 tensor, in the regressor's order
/// (`xx, xy, xz, yy, yz, zz`).
const ENTRIES: [(usize, usize); 6] = [(0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)];

/// Why a fit could not start.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum FitError {
    /// `β̂` has the wrong length.
    #[error("{given} identified base parameters given, the regressor has {expected}")]
    BaseCount {
        /// How many were given.
        given: usize,
        /// How many the regressor has.
        expected: usize,
    },
    /// `σ` has the wrong length.
    #[error("{given} standard deviations given, the regressor has {expected} base parameters")]
    SigmaCount {
        /// How many were given.
        given: usize,
        /// How many the regressor has.
        expected: usize,
    },
    /// A value of `β̂` is NaN or infinite.
    #[error("base parameter `{name}`: identified value {value} is not finite")]
    NotFinite {
        /// The base parameter's name.
        name: String,
        /// The value given.
        value: f64,
    },
    /// A standard deviation is not a positive finite number.
    #[error("base parameter `{name}`: standard deviation must be positive and finite, got {value}")]
    BadSigma {
        /// The base parameter's name.
        name: String,
        /// The value given.
        value: f64,
    },
    /// The regressor was built for another model.
    #[error("the regressor does not belong to this model: standard parameter {index} is `{found}`, expected `{expected}`")]
    Mismatch {
        /// Index into the regressor's standard parameters.
        index: usize,
        /// The regressor's name there.
        found: String,
        /// The model's.
        expected: String,
    },
}

/// Settings of [`fit`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FitOptions {
    /// The last stage's weight `λ` of the pull toward the file's values (relative to the data
    /// term, both scaled; see the module documentation).
    pub regularisation: f64,
    /// Newton iterations per value of the barrier weight, at most.
    pub iterations: usize,
}

impl Default for FitOptions {
    fn default() -> Self {
        FitOptions { regularisation: 1e-10, iterations: 200 }
    }
}

/// One body of the fitted model, in the file's terms.
#[derive(Clone, Debug, PartialEq)]
pub struct IdentifiedBody {
    /// The body's name.
    pub name: String,
    /// Mass, kg.
    pub mass: f64,
    /// Centre of mass in the body frame, m.
    pub com: [f64; 3],
    /// Inertia about the centre of mass, body axes, kg·m².
    pub inertia: [[f64; 3]; 3],
    /// Smallest eigenvalue of its pseudo-inertia (the plane's 3 × 3 one for a planar model),
    /// ≥ 0 for a physical body.
    pub smallest_eigenvalue: f64,
    /// Largest eigenvalue of the same (to judge the smallest).
    pub largest_eigenvalue: f64,
    /// `false` for a massless body (kept at zero).
    pub fitted: bool,
}

/// One actuated joint's drive parameters of the fitted model.
#[derive(Clone, Debug, PartialEq)]
pub struct IdentifiedJoint {
    /// The joint's name.
    pub name: String,
    /// Reflected rotor inertia `N² J_m`, kg·m² (kg).
    pub reflected_rotor_inertia: f64,
    /// Whether the rotor inertia was fitted (a base parameter of its own); else the file's.
    pub rotor_fitted: bool,
    /// Viscous friction, the joint's `damping`.
    pub damping: f64,
    /// Coulomb friction, the drive's `coulomb_friction`.
    pub coulomb_friction: f64,
    /// Constant torque offset (no field in the model file).
    pub offset: f64,
}

/// The result of [`fit`].
#[derive(Clone, Debug, PartialEq)]
pub struct ConsistentParameters {
    /// Standard parameters in the regressor's order and frames.
    pub standard: Vec<f64>,
    /// Their base parameters, `K π`.
    pub base: Vec<f64>,
    /// `‖W (K π − β̂)‖ / ‖W β̂‖` (`W` as in the module documentation).
    pub residual: f64,
    /// Largest `|K π − β̂|_i / s_i` over the base parameters (`s_i` their nominal scale).
    pub largest_error: f64,
    /// The model's bodies, in its order.
    pub bodies: Vec<IdentifiedBody>,
    /// The actuated joints, in the model's order.
    pub joints: Vec<IdentifiedJoint>,
}

/// How a body's parameters are written.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Kind {
    /// Massless: zero.
    Fixed,
    /// `(m, h_x, h_y, zz)`.
    Planar,
    /// `v_b`, ten numbers.
    Spatial,
}

struct Body {
    kind: Kind,
    /// First unknown.
    offset: usize,
    /// First standard parameter.
    standard: usize,
    /// `π_b = map · v_b`.
    map: [[f64; 10]; 10],
    /// The file's `v_b = (m, m c, Ī_o)`.
    nominal: [f64; 10],
    /// Scale of each entry of `v_b`.
    scale: [f64; 10],
}

struct Drive {
    /// Standard parameter.
    standard: usize,
    offset: usize,
    nonnegative: bool,
    nominal: f64,
    scale: f64,
}

struct Problem {
    bodies: Vec<Body>,
    drives: Vec<Drive>,
    /// Every standard parameter's value where nothing is fitted.
    fixed: Vec<f64>,
    /// `K`, dense.
    k: DMatrix<f64>,
    weights: Vec<f64>,
    target: Vec<f64>,
    unknowns: usize,
}

/// `v = (m, m c, I_c + m (|c|² 1 − c cᵀ))`.
fn body_vector(m: f64, c: [f64; 3], ic: &[[f64; 3]; 3]) -> [f64; 10] {
    let c2 = c[0] * c[0] + c[1] * c[1] + c[2] * c[2];
    let mut v = [0.0; 10];
    v[0] = m;
    for i in 0..3 {
        v[1 + i] = m * c[i];
    }
    for (e, &(r, s)) in ENTRIES.iter().enumerate() {
        let delta = if r == s { 1.0 } else { 0.0 };
        v[4 + e] = ic[r][s] + m * (c2 * delta - c[r] * c[s]);
    }
    v
}

/// `(m, c, I_c)` from `v` (`m > 0`).
fn body_from_vector(v: &[f64; 10]) -> (f64, [f64; 3], [[f64; 3]; 3]) {
    let m = v[0];
    if m <= 0.0 {
        return (0.0, [0.0; 3], [[0.0; 3]; 3]);
    }
    let c = [v[1] / m, v[2] / m, v[3] / m];
    let c2 = c[0] * c[0] + c[1] * c[1] + c[2] * c[2];
    let mut ic = [[0.0; 3]; 3];
    for (e, &(r, s)) in ENTRIES.iter().enumerate() {
        let delta = if r == s { 1.0 } else { 0.0 };
        ic[r][s] = v[4 + e] - m * (c2 * delta - c[r] * c[s]);
        ic[s][r] = ic[r][s];
    }
    (m, c, ic)
}

/// The central inertia with its second moments `Σ_c = ½ tr(I) 1 − I` at least 10⁻⁷ of the
/// largest: a body on the cone's boundary (a rod, a point mass) written just inside it, where
/// the loader's check of the triangle inequality (10⁻⁹, with eigenvalues of repeated moments
/// good to about 10⁻⁸) accepts it.
fn clamp_central(inertia: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    let i = Matrix3::from_fn(|r, s| inertia[r][s]);
    let sigma = Matrix3::identity() * (0.5 * i.trace()) - i;
    let eigen = SymmetricEigen::new(sigma);
    let floor = 1e-7 * eigen.eigenvalues.iter().copied().fold(0.0, f64::max);
    if eigen.eigenvalues.iter().all(|&x| x >= floor) {
        return *inertia;
    }
    let clamped = eigen.eigenvalues.map(|x| x.max(floor));
    let sigma = eigen.eigenvectors * Matrix3::from_diagonal(&clamped) * eigen.eigenvectors.transpose();
    let i = Matrix3::identity() * sigma.trace() - sigma;
    std::array::from_fn(|r| std::array::from_fn(|s| 0.5 * (i[(r, s)] + i[(s, r)])))
}

/// The spatial pseudo-inertia of `v`.
fn pseudo_inertia(v: &[f64; 10]) -> Matrix4<f64> {
    let mut inertia = Matrix3::zeros();
    for (e, &(r, s)) in ENTRIES.iter().enumerate() {
        inertia[(r, s)] = v[4 + e];
        inertia[(s, r)] = v[4 + e];
    }
    let sigma = Matrix3::identity() * (0.5 * inertia.trace()) - inertia;
    let mut j = Matrix4::zeros();
    j.fixed_view_mut::<3, 3>(0, 0).copy_from(&sigma);
    for i in 0..3 {
        j[(i, 3)] = v[1 + i];
        j[(3, i)] = v[1 + i];
    }
    j[(3, 3)] = v[0];
    j
}

/// `v` of a pseudo-inertia (linear).
fn vector_of_pseudo_inertia(j: &Matrix4<f64>) -> [f64; 10] {
    let sigma = j.fixed_view::<3, 3>(0, 0).into_owned();
    let inertia = Matrix3::identity() * sigma.trace() - sigma;
    let mut v = [0.0; 10];
    v[0] = j[(3, 3)];
    for i in 0..3 {
        v[1 + i] = j[(i, 3)];
    }
    for (e, &(r, s)) in ENTRIES.iter().enumerate() {
        v[4 + e] = inertia[(r, s)];
    }
    v
}

/// The planar pseudo-inertia `[[I_zz,c/2·1 + m c cᵀ, m c], [m cᵀ, m]]` of `v`.
fn planar_pseudo_inertia(v: &[f64; 10]) -> Matrix3<f64> {
    let m = v[0];
    let (h, zz) = ([v[1], v[2]], v[9]);
    let izz_c = if m > 0.0 { zz - (h[0] * h[0] + h[1] * h[1]) / m } else { zz };
    let mut j = Matrix3::zeros();
    for r in 0..2 {
        for s in 0..2 {
            j[(r, s)] = if m > 0.0 { h[r] * h[s] / m } else { 0.0 } + if r == s { 0.5 * izz_c } else { 0.0 };
        }
        j[(r, 2)] = h[r];
        j[(2, r)] = h[r];
    }
    j[(2, 2)] = m;
    j
}

impl Body {
    fn unknowns(&self) -> usize {
        match self.kind {
            Kind::Fixed => 0,
            Kind::Planar => 4,
            Kind::Spatial => 10,
        }
    }

    /// `v_b` and `∂v_b/∂θ` (one column per unknown): the unknowns are `v_b` itself
    /// (spatial) or `(m, h_x, h_y, zz)` (planar; the out-of-plane entries, which no base
    /// parameter holds, are filled in by [`Problem::result`]).
    fn vector(&self, theta: &[f64]) -> ([f64; 10], Vec<[f64; 10]>) {
        let unit = |k: usize| {
            let mut e = [0.0; 10];
            e[k] = 1.0;
            e
        };
        match self.kind {
            Kind::Fixed => (self.nominal, Vec::new()),
            Kind::Planar => {
                let mut v = [0.0; 10];
                for (u, &k) in PLANAR.iter().enumerate() {
                    v[k] = theta[u];
                }
                (v, PLANAR.iter().map(|&k| unit(k)).collect())
            }
            Kind::Spatial => {
                let mut v = [0.0; 10];
                v.copy_from_slice(&theta[..10]);
                (v, (0..10).map(unit).collect())
            }
        }
    }

    /// The body's pseudo-inertia at `theta` (4 × 4, or the plane's 3 × 3
    /// `[[zz, h_x, h_y], [h_x, m, 0], [h_y, 0, m]]`), as a dynamic matrix.
    fn pseudo_inertia(&self, theta: &[f64]) -> DMatrix<f64> {
        match self.kind {
            Kind::Fixed => DMatrix::zeros(0, 0),
            Kind::Planar => {
                let (m, hx, hy, zz) = (theta[0], theta[1], theta[2], theta[3]);
                DMatrix::from_row_slice(3, 3, &[zz, hx, hy, hx, m, 0.0, hy, 0.0, m])
            }
            Kind::Spatial => {
                let mut v = [0.0; 10];
                v.copy_from_slice(&theta[..10]);
                let j = pseudo_inertia(&v);
                DMatrix::from_fn(4, 4, |r, c| j[(r, c)])
            }
        }
    }

    /// The starting unknowns: the file's values, moved 10⁻⁶ inside the cone (a rod or a point
    /// mass is on its boundary, where the barrier is infinite).
    fn start(&self) -> Vec<f64> {
        let v = &self.nominal;
        let (m, l2) = (self.scale[0], self.scale[4] / self.scale[0].max(1e-300));
        match self.kind {
            Kind::Fixed => Vec::new(),
            Kind::Planar => {
                let h2 = (v[1] * v[1] + v[2] * v[2]) / m.max(1e-300);
                vec![v[0], v[1], v[2], v[9].max(h2) + 1e-6 * m * l2]
            }
            Kind::Spatial => {
                let mut j = pseudo_inertia(v);
                for i in 0..3 {
                    j[(i, i)] += 1e-6 * m * l2;
                }
                vector_of_pseudo_inertia(&j).to_vec()
            }
        }
    }
}

/// The entries of `v_b` a planar body's unknowns are: `m, h_x, h_y, zz`.
const PLANAR: [usize; 4] = [0, 1, 2, 9];

/// A model's body and standard parameter values with every body set to `(m, c, I_c)`.
fn standard_with(
    model: &CheckedModel,
    regressor: &Regressor,
    m: f64,
    c: [f64; 3],
    ic: [[f64; 3]; 3],
) -> Vec<f64> {
    let mut probe = model.model.clone();
    for body in &mut probe.bodies {
        body.mass = Poly::constant(m);
        body.com = c.map(Poly::constant);
        body.inertia = ic.map(|row| row.map(Poly::constant));
    }
    regressor.standard_values(&probe)
}

/// Each body's map `L_b` from `v_b` (body frame) to its ten standard parameters, by probing.
fn body_maps(model: &CheckedModel, regressor: &Regressor) -> Vec<[[f64; 10]; 10]> {
    let zero = [[0.0; 3]; 3];
    let s0 = standard_with(model, regressor, 1.0, [0.0; 3], zero);
    let mut columns = vec![s0.clone()];
    for i in 0..3 {
        let mut c = [0.0; 3];
        c[i] = 1.0;
        // I_c = −(|c|² 1 − c cᵀ): the inertia about the origin is zero.
        let mut ic = [[0.0; 3]; 3];
        for (r, row) in ic.iter_mut().enumerate() {
            row[r] = if r == i { 0.0 } else { -1.0 };
        }
        let s = standard_with(model, regressor, 1.0, c, ic);
        columns.push(s.iter().zip(&s0).map(|(a, b)| a - b).collect());
    }
    for &(r, s) in &ENTRIES {
        let mut ic = [[0.0; 3]; 3];
        ic[r][s] = 1.0;
        ic[s][r] = 1.0;
        let values = standard_with(model, regressor, 1.0, [0.0; 3], ic);
        columns.push(values.iter().zip(&s0).map(|(a, b)| a - b).collect());
    }
    (0..model.model.bodies.len())
        .map(|b| {
            let mut map = [[0.0; 10]; 10];
            for (j, column) in columns.iter().enumerate() {
                for i in 0..10 {
                    map[i][j] = column[10 * b + i];
                }
            }
            map
        })
        .collect()
}

/// Checks that `regressor` was built for `model` (body parameters first, ten per body, then
/// four per joint).
fn check_layout(model: &CheckedModel, regressor: &Regressor) -> Result<(), FitError> {
    const BODY: [&str; 10] = ["m", "mx", "my", "mz", "xx", "xy", "xz", "yy", "yz", "zz"];
    const JOINT: [&str; 4] = ["ia", "fv", "fc", "off"];
    let mut expected: Vec<String> = Vec::new();
    for body in &model.model.bodies {
        expected.extend(BODY.iter().map(|p| format!("{p}_{}", body.name)));
    }
    for joint in &model.model.joints {
        expected.extend(JOINT.iter().map(|p| format!("{p}_{}", joint.name)));
    }
    for (index, name) in expected.iter().enumerate() {
        let found = regressor.standard.get(index).map(|s| s.name.clone()).unwrap_or_default();
        if &found != name {
            return Err(FitError::Mismatch { index, found, expected: name.clone() });
        }
    }
    if regressor.standard.len() != expected.len() {
        let index = expected.len();
        return Err(FitError::Mismatch {
            index,
            found: regressor.standard[index].name.clone(),
            expected: "no more parameters".into(),
        });
    }
    Ok(())
}

/// A length: the square root of `x` where positive, else 0.
fn root(x: f64) -> f64 {
    if x > 0.0 {
        x.sqrt()
    } else {
        0.0
    }
}

/// Finds physically consistent standard parameters that reproduce `beta` (the identified base
/// parameters, in the regressor's order), weighted by `sigma` (their standard deviations)
/// where given; see the module documentation.
pub fn fit(
    model: &CheckedModel,
    regressor: &Regressor,
    beta: &[f64],
    sigma: Option<&[f64]>,
    options: &FitOptions,
) -> Result<ConsistentParameters, FitError> {
    check_layout(model, regressor)?;
    let p = regressor.base.len();
    if beta.len() != p {
        return Err(FitError::BaseCount { given: beta.len(), expected: p });
    }
    for (b, &value) in regressor.base.iter().zip(beta) {
        if !value.is_finite() {
            return Err(FitError::NotFinite { name: b.name.clone(), value });
        }
    }
    if let Some(sigma) = sigma {
        if sigma.len() != p {
            return Err(FitError::SigmaCount { given: sigma.len(), expected: p });
        }
        for (b, &value) in regressor.base.iter().zip(sigma) {
            if !(value.is_finite() && value > 0.0) {
                return Err(FitError::BadSigma { name: b.name.clone(), value });
            }
        }
    }
    let problem = setup(model, regressor, beta, sigma);
    let mut theta = problem.start();
    let mut lambda = 1e-2_f64.max(options.regularisation);
    let mut misfit = f64::INFINITY;
    loop {
        let next = problem.barrier_newton(theta.clone(), lambda, options.iterations);
        let next_misfit = problem.misfit(&next);
        // A smaller weight that no longer improves the fit (β̂ out of reach of a consistent
        // model) only lets the free parameters drift: keep the last stage's.
        if next_misfit > 0.5 * misfit {
            if next_misfit < misfit {
                theta = next;
            }
            break;
        }
        theta = next;
        misfit = next_misfit;
        if lambda <= options.regularisation {
            break;
        }
        lambda = (lambda * 1e-2).max(options.regularisation);
    }
    Ok(problem.result(model, regressor, &theta, beta))
}

fn setup(model: &CheckedModel, regressor: &Regressor, beta: &[f64], sigma: Option<&[f64]>) -> Problem {
    let params = model.nominal_parameters();
    let nominal = hapticgen_codegen::eval::NominalAtoms(&params);
    let maps = body_maps(model, regressor);
    let fixed = regressor.standard_values(&model.model);
    // Bodies: the file's values and scales.
    let mut values: Vec<(f64, [f64; 10])> = Vec::new();
    for body in &model.model.bodies {
        let m = body.mass.eval(&nominal);
        let c = body.com.clone().map(|p| p.eval(&nominal));
        let ic = body.inertia.clone().map(|row| row.map(|p| p.eval(&nominal)));
        values.push((m, body_vector(m, c, &ic)));
    }
    let radius =
        |(m, v): &(f64, [f64; 10])| if *m > 0.0 { root(0.5 * (v[4] + v[7] + v[9]) / m) } else { 0.0 };
    let longest = values.iter().map(radius).fold(0.0, f64::max).max(1e-3);
    let mut bodies = Vec::new();
    let mut offset = 0;
    for (b, (value, map)) in values.iter().zip(maps).enumerate() {
        let (m, v) = *value;
        let kind = if m <= 0.0 {
            Kind::Fixed
        } else if model.model.planar {
            Kind::Planar
        } else {
            Kind::Spatial
        };
        let l = radius(value).max(0.1 * longest);
        let mass = m.max(0.0);
        let scale = [
            mass,
            mass * l,
            mass * l,
            mass * l,
            mass * l * l,
            mass * l * l,
            mass * l * l,
            mass * l * l,
            mass * l * l,
            mass * l * l,
        ];
        let body = Body { kind, offset, standard: 10 * b, map, nominal: v, scale };
        offset += body.unknowns();
        bodies.push(body);
    }
    let inertia_scale =
        bodies.iter().filter(|b| b.kind != Kind::Fixed).map(|b| b.scale[4]).fold(0.0, f64::max).max(1e-12);
    // Drives.
    let in_base = |s: usize| regressor.base.iter().any(|b| b.combination.iter().any(|&(t, _)| t == s));
    let kept_alone = |s: usize| regressor.base.iter().any(|b| b.combination[0].0 == s);
    let first = 10 * model.model.bodies.len();
    let mut drives = Vec::new();
    for (j, joint) in model.model.joints.iter().enumerate() {
        let torque = joint.drive.torque_limit.abs().max(1e-9);
        let speed = if joint.kind == JointKind::Revolute { 1.0 } else { 0.1 };
        for k in 0..4 {
            let s = first + 4 * j + k;
            let x0 = fixed[s];
            let (fitted, nonnegative, scale) = match k {
                0 => (kept_alone(s), true, if x0 > 0.0 { x0 } else { inertia_scale }),
                1 => (in_base(s), true, x0.max(1e-3 * torque / speed)),
                2 => (in_base(s), true, x0.max(1e-2 * torque)),
                _ => (in_base(s), false, 1e-2 * torque),
            };
            if fitted {
                drives.push(Drive { standard: s, offset, nonnegative, nominal: x0, scale });
                offset += 1;
            }
        }
    }
    // K and the weights.
    let n = regressor.standard.len();
    let mut k = DMatrix::zeros(beta.len(), n);
    for (i, b) in regressor.base.iter().enumerate() {
        for &(s, c) in &b.combination {
            k[(i, s)] = c;
        }
    }
    let mut standard_scale = vec![0.0; n];
    for body in &bodies {
        for i in 0..10 {
            standard_scale[body.standard + i] = (0..10).map(|j| body.map[i][j].abs() * body.scale[j]).sum();
        }
    }
    for d in &drives {
        standard_scale[d.standard] = d.scale;
    }
    for s in first..n {
        if standard_scale[s] == 0.0 {
            standard_scale[s] = fixed[s].abs();
        }
    }
    let weights: Vec<f64> = match sigma {
        Some(sigma) => sigma.iter().map(|s| 1.0 / s).collect(),
        None => regressor
            .base
            .iter()
            .map(|b| {
                let size: f64 = b.combination.iter().map(|&(s, c)| c.abs() * standard_scale[s]).sum();
                if size > 0.0 {
                    1.0 / size
                } else {
                    1.0
                }
            })
            .collect(),
    };
    Problem { bodies, drives, fixed, k, weights, target: beta.to_vec(), unknowns: offset }
}

impl Problem {
    fn start(&self) -> Vec<f64> {
        let mut theta = vec![0.0; self.unknowns];
        for body in &self.bodies {
            let start = body.start();
            theta[body.offset..body.offset + start.len()].copy_from_slice(&start);
        }
        for d in &self.drives {
            theta[d.offset] = if d.nonnegative { d.nominal.max(1e-3 * d.scale) } else { d.nominal };
        }
        theta
    }

    /// Standard parameters, the bodies' `v_b` and `∂π/∂θ`.
    fn standard(&self, theta: &[f64], with_jacobian: bool) -> (Vec<f64>, Vec<[f64; 10]>, DMatrix<f64>) {
        let mut pi = self.fixed.clone();
        let mut jacobian = DMatrix::zeros(if with_jacobian { pi.len() } else { 0 }, self.unknowns);
        let mut vectors = Vec::with_capacity(self.bodies.len());
        for body in &self.bodies {
            let (v, dv) = body.vector(&theta[body.offset..body.offset + body.unknowns()]);
            for i in 0..10 {
                let row = body.standard + i;
                pi[row] = (0..10).map(|j| body.map[i][j] * v[j]).sum();
                if !with_jacobian {
                    continue;
                }
                for (u, d) in dv.iter().enumerate() {
                    jacobian[(row, body.offset + u)] = (0..10).map(|j| body.map[i][j] * d[j]).sum();
                }
            }
            vectors.push(v);
        }
        for d in &self.drives {
            let (x, dx) = (theta[d.offset], 1.0);
            pi[d.standard] = x;
            if with_jacobian {
                jacobian[(d.standard, d.offset)] = dx;
            }
        }
        (pi, vectors, jacobian)
    }

    /// The stacked residual (data, then the pull toward the file) and, if asked for, its
    /// Jacobian (else an empty matrix).
    fn residual(&self, theta: &[f64], lambda: f64, with_jacobian: bool) -> (DVector<f64>, DMatrix<f64>) {
        let (pi, vectors, dpi) = self.standard(theta, with_jacobian);
        let p = self.target.len();
        let regularised: usize =
            self.bodies.iter().filter(|b| b.kind != Kind::Fixed).count() * 10 + self.drives.len();
        let mut r = DVector::zeros(p + regularised);
        let rows = if with_jacobian { p + regularised } else { 0 };
        let mut jac = DMatrix::zeros(rows, self.unknowns);
        let kpi = &self.k * DVector::from_vec(pi.clone());
        let kd = if with_jacobian { &self.k * &dpi } else { DMatrix::zeros(0, 0) };
        for i in 0..p {
            r[i] = self.weights[i] * (kpi[i] - self.target[i]);
            if !with_jacobian {
                continue;
            }
            for u in 0..self.unknowns {
                jac[(i, u)] = self.weights[i] * kd[(i, u)];
            }
        }
        let w = lambda.sqrt();
        let mut row = p;
        for (body, v) in self.bodies.iter().zip(&vectors) {
            if body.kind == Kind::Fixed {
                continue;
            }
            let (_, dv) = body.vector(&theta[body.offset..body.offset + body.unknowns()]);
            for i in 0..10 {
                let s = w / body.scale[i].max(1e-300);
                r[row] = s * (v[i] - body.nominal[i]);
                for (u, d) in dv.iter().enumerate().filter(|_| with_jacobian) {
                    jac[(row, body.offset + u)] = s * d[i];
                }
                row += 1;
            }
        }
        for d in &self.drives {
            let s = w / d.scale;
            r[row] = s * (pi[d.standard] - d.nominal);
            if with_jacobian {
                jac[(row, d.offset)] = s * dpi[(d.standard, d.offset)];
            }
            row += 1;
        }
        (r, jac)
    }

    /// `‖W (K π − β̂)‖`.
    fn misfit(&self, theta: &[f64]) -> f64 {
        let (r, _) = self.residual(theta, 0.0, false);
        r.rows(0, self.target.len()).norm()
    }

    /// The barrier `φ = −Σ_b log det J_b − Σ log x` (drives that must not be negative), its
    /// gradient and Hessian; `None` outside the cones.
    fn barrier(&self, theta: &[f64], derivatives: bool) -> Option<(f64, DVector<f64>, DMatrix<f64>)> {
        let n = self.unknowns;
        let mut value = 0.0;
        let mut gradient = DVector::zeros(if derivatives { n } else { 0 });
        let mut hessian = DMatrix::zeros(if derivatives { n } else { 0 }, if derivatives { n } else { 0 });
        for body in self.bodies.iter().filter(|b| b.kind != Kind::Fixed) {
            let k = body.unknowns();
            let local = &theta[body.offset..body.offset + k];
            let j = body.pseudo_inertia(local);
            let cholesky = j.clone().cholesky()?;
            value -= 2.0 * cholesky.l().diagonal().iter().map(|x| x.ln()).sum::<f64>();
            if !derivatives {
                continue;
            }
            let inverse = cholesky.inverse();
            // A_u = ∂J/∂θ_u (J is linear in θ); B_u = J⁻¹ A_u.
            let b: Vec<DMatrix<f64>> = (0..k)
                .map(|u| {
                    let mut e = vec![0.0; k];
                    e[u] = 1.0;
                    &inverse * body.pseudo_inertia(&e)
                })
                .collect();
            for u in 0..k {
                gradient[body.offset + u] -= b[u].trace();
                for w in 0..k {
                    hessian[(body.offset + u, body.offset + w)] += (&b[u] * &b[w]).trace();
                }
            }
        }
        for d in self.drives.iter().filter(|d| d.nonnegative) {
            let x = theta[d.offset];
            if x <= 0.0 {
                return None;
            }
            value -= x.ln();
            if derivatives {
                gradient[d.offset] -= 1.0 / x;
                hessian[(d.offset, d.offset)] += 1.0 / (x * x);
            }
        }
        Some((value, gradient, hessian))
    }

    /// Minimises `‖r(θ)‖² + t φ(θ)` (`r` the stacked residual at weight `lambda`, linear in
    /// `θ`) for `t` from 10⁻⁴ down to 10⁻¹⁸ by damped Newton steps that stay inside the cones
    /// (a barrier method, Boyd and Vandenberghe ch. 11; the objective is convex).
    fn barrier_newton(&self, mut theta: Vec<f64>, lambda: f64, iterations: usize) -> Vec<f64> {
        let n = self.unknowns;
        if n == 0 {
            return theta;
        }
        let merit = |theta: &[f64], t: f64| -> Option<f64> {
            let (phi, _, _) = self.barrier(theta, false)?;
            let (r, _) = self.residual(theta, lambda, false);
            Some(r.norm_squared() + t * phi)
        };
        let mut t = 1e-4;
        while t >= 1e-18 {
            for _ in 0..iterations {
                let Some((_, g_phi, h_phi)) = self.barrier(&theta, true) else { return theta };
                let (r, jac) = self.residual(&theta, lambda, true);
                let gradient = 2.0 * jac.transpose() * &r + t * g_phi;
                let hessian = 2.0 * jac.transpose() * &jac + t * h_phi;
                // Solve with the Hessian's diagonal scaled to 1.
                let d: Vec<f64> = (0..n).map(|i| hessian[(i, i)].max(1e-300).sqrt()).collect();
                let scaled = DMatrix::from_fn(n, n, |i, j| hessian[(i, j)] / (d[i] * d[j]));
                let rhs = DVector::from_fn(n, |i, _| -gradient[i] / d[i]);
                let y = match scaled.clone().cholesky() {
                    Some(c) => c.solve(&rhs),
                    None => {
                        let ridge = scaled + DMatrix::identity(n, n) * 1e-12;
                        match ridge.lu().solve(&rhs) {
                            Some(y) => y,
                            None => break,
                        }
                    }
                };
                let step = DVector::from_fn(n, |i, _| y[i] / d[i]);
                let decrement = -gradient.dot(&step);
                let Some(current) = merit(&theta, t) else { return theta };
                if decrement.is_nan() || decrement <= 1e-30 + 1e-15 * current.abs() {
                    break;
                }
                let mut alpha = 1.0;
                let mut moved = false;
                for _ in 0..60 {
                    let candidate: Vec<f64> =
                        theta.iter().zip(step.iter()).map(|(x, s)| x + alpha * s).collect();
                    if let Some(value) = merit(&candidate, t) {
                        if value <= current - 1e-4 * alpha * decrement {
                            theta = candidate;
                            moved = true;
                            break;
                        }
                    }
                    alpha *= 0.5;
                }
                if !moved || decrement < 1e-9 * t {
                    break;
                }
            }
            t *= 0.1;
        }
        theta
    }

    fn result(
        &self,
        model: &CheckedModel,
        regressor: &Regressor,
        theta: &[f64],
        beta: &[f64],
    ) -> ConsistentParameters {
        let (mut pi, vectors, _) = self.standard(theta, false);
        let planar = model.model.planar;
        // Each body as the file writes it, and its standard parameters from that.
        let mut bodies = Vec::new();
        for ((body, fit), v) in model.model.bodies.iter().zip(&self.bodies).zip(&vectors) {
            let (mass, com, inertia) = match fit.kind {
                Kind::Fixed => body_from_vector(v),
                Kind::Planar => {
                    let m = v[0];
                    let c = [v[1] / m, v[2] / m, 0.0];
                    let izz = (v[9] - m * (c[0] * c[0] + c[1] * c[1])).max(0.0);
                    (m, c, [[0.0; 3], [0.0; 3], [0.0, 0.0, izz]])
                }
                Kind::Spatial => {
                    let (m, c, inertia) = body_from_vector(v);
                    (m, c, clamp_central(&inertia))
                }
            };
            let v = if fit.kind == Kind::Fixed { *v } else { body_vector(mass, com, &inertia) };
            for i in 0..10 {
                pi[fit.standard + i] = (0..10).map(|j| fit.map[i][j] * v[j]).sum();
            }
            let eigenvalues: Vec<f64> = if planar {
                SymmetricEigen::new(planar_pseudo_inertia(&v)).eigenvalues.iter().copied().collect()
            } else {
                SymmetricEigen::new(pseudo_inertia(&v)).eigenvalues.iter().copied().collect()
            };
            bodies.push(IdentifiedBody {
                name: body.name.clone(),
                mass,
                com,
                inertia,
                smallest_eigenvalue: eigenvalues.iter().copied().fold(f64::INFINITY, f64::min),
                largest_eigenvalue: eigenvalues.iter().copied().fold(f64::NEG_INFINITY, f64::max),
                fitted: fit.kind != Kind::Fixed,
            });
        }
        let base = regressor.base_values(&pi);
        let weighted = |x: &dyn Fn(usize) -> f64| {
            (0..beta.len()).map(|i| (self.weights[i] * x(i)).powi(2)).sum::<f64>().sqrt()
        };
        let error = weighted(&|i| base[i] - beta[i]);
        let size = weighted(&|i| beta[i]);
        let residual = if size > 0.0 { error / size } else { error };
        let largest_error =
            (0..beta.len()).map(|i| (self.weights[i] * (base[i] - beta[i])).abs()).fold(0.0, f64::max);
        let first = 10 * model.model.bodies.len();
        let joints = model
            .model
            .joints
            .iter()
            .enumerate()
            .map(|(j, joint)| {
                let s = first + 4 * j;
                IdentifiedJoint {
                    name: joint.name.clone(),
                    reflected_rotor_inertia: pi[s],
                    rotor_fitted: self.drives.iter().any(|d| d.standard == s),
                    damping: pi[s + 1],
                    coulomb_friction: pi[s + 2],
                    offset: pi[s + 3],
                }
            })
            .collect();
        ConsistentParameters { standard: pi, base, residual, largest_error, bodies, joints }
    }
}
