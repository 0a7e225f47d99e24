//! Property tests (proptest) over random valid serial models: planar and spatial chains of
//! 1–4 revolute or prismatic joints with random masses, lengths, centres of mass, inertias,
//! axes, joint-frame rotations, rotor inertias and gravity, written as model files and loaded
//! by the real loader. For each model, at a random state:
//!
//! 1. `D(q)` is symmetric positive definite (Cholesky);
//! 2. `Ḋ − 2C` is skew-symmetric, `Ḋ` by a central finite difference along `q̇`;
//! 3. total energy `½ q̇ᵀ D q̇ + V(q)` is conserved over 0.1 s of undamped, unforced motion
//!    (RK4, 0.2 ms steps, evaluated through the emitted expression DAG);
//! 4. the expression DAG the emitter prints (`Dag::polynomial`, shared across all outputs
//!    as in emission, evaluated node by node) equals the term-by-term polynomial evaluator
//!    for every entry of `p`, `J`, `J̇`, `J̇q̇`, `D`, `C`, `Cq̇`, `g` and `V`.
//!
//! Cases: 48 per property by default (a few seconds in a debug build); set `PROPTEST_CASES`
//! for a longer run (`PROPTEST_CASES=1000 cargo test -p hapticgen-tests --test workspace properties::`).

// Matrix checks read best with explicit indices.
#![allow(clippy::needless_range_loop)]

use hapticgen_codegen::dynamics::mechanics::Mechanics;
use hapticgen_codegen::eval::State;
use hapticgen_codegen::model::Model;
use hapticgen_codegen::sym::dag::{Dag, Node, NodeId};
use hapticgen_codegen::sym::poly::{Atom, AtomValues, Poly};
use hapticgen_codegen::Source;
use hapticgen_tests::dense::{is_positive_definite, solve};
use proptest::prelude::*;

/// One joint and the body it moves.
#[derive(Clone, Debug)]
struct Link {
    prismatic: bool,
    /// Axis direction angles (spatial: azimuth, elevation; planar prismatic: angle in x–y;
    /// planar revolute: the sign of z).
    axis: (f64, f64),
    /// Offset from the parent's frame to this joint frame.
    offset: [f64; 3],
    /// Roll, pitch, yaw of the joint frame (spatial) or the angle (planar).
    rpy: [f64; 3],
    mass: f64,
    com: [f64; 3],
    /// Principal moments satisfying the triangle inequality.
    moments: [f64; 3],
    rotor_inertia: f64,
}

#[derive(Clone, Debug)]
struct Chain {
    planar: bool,
    gravity: [f64; 3],
    links: Vec<Link>,
    /// Task: the chain's tip point (true) or the joint coordinates.
    tip_task: bool,
    q: Vec<f64>,
    qd: Vec<f64>,
}

fn link() -> impl Strategy<Value = Link> {
    (
        prop::bool::weighted(0.2),
        (-3.1f64..3.1, -1.5f64..1.5),
        prop::array::uniform3(-0.3f64..0.3),
        prop::array::uniform3(-3.1f64..3.1),
        0.01f64..1.0,
        prop::array::uniform3(-0.15f64..0.15),
        (1e-5f64..1e-3, 1e-5f64..1e-3, 0.0f64..1.0),
        0.0f64..2e-5,
    )
        .prop_map(|(prismatic, axis, offset, rpy, mass, com, (a, b, t), rotor_inertia)| {
            let c = (a - b).abs() + t * (a + b - (a - b).abs());
            Link { prismatic, axis, offset, rpy, mass, com, moments: [a, b, c.max(1e-6)], rotor_inertia }
        })
}

fn chain() -> impl Strategy<Value = Chain> {
    (
        any::<bool>(),
        prop::array::uniform3(-10.0f64..10.0),
        prop::collection::vec(link(), 1..=4),
        any::<bool>(),
    )
        .prop_flat_map(|(planar, gravity, links, tip_task)| {
            let n = links.len();
            (
                Just((planar, gravity, links, tip_task)),
                prop::collection::vec(-3.0f64..3.0, n),
                prop::collection::vec(-2.0f64..2.0, n),
            )
        })
        .prop_map(|((planar, gravity, links, tip_task), q, qd)| Chain {
            planar,
            gravity,
            links,
            tip_task,
            q,
            qd,
        })
}

fn list(values: &[f64]) -> String {
    let items: Vec<String> = values.iter().map(|v| format!("{v:e}")).collect();
    format!("[{}]", items.join(", "))
}

/// The model file of a chain (no damping: energy must be conserved).
fn model_text(c: &Chain) -> String {
    let dim = if c.planar { 2 } else { 3 };
    let mut t = String::new();
    t.push_str("name: random_chain\n");
    t.push_str(if c.planar { "space: planar\n" } else { "space: spatial\n" });
    t.push_str(&format!("gravity: {}\n", list(&c.gravity[..dim])));
    t.push_str("drives:\n");
    for (i, l) in c.links.iter().enumerate() {
        t.push_str(&format!(
            "  d{i}:\n    motor: {{rotor_inertia: {:e}, resistance: 0.3, inductance: 1.0e-4, torque_constant: 0.03}}\n    \
             gear_ratio: 12.0\n    torque_limit: 3.0\n    current_limit: 8.0\n    supply_voltage: 24.0\n    \
             encoder: {{counts_per_turn: 2000}}\n",
            l.rotor_inertia
        ));
    }
    t.push_str("joints:\n");
    for (i, l) in c.links.iter().enumerate() {
        let (a, e) = l.axis;
        let axis = match (c.planar, l.prismatic) {
            (true, false) => vec![0.0, 0.0, if a >= 0.0 { 1.0 } else { -1.0 }],
            (true, true) => vec![a.cos(), a.sin()],
            (false, _) => vec![e.cos() * a.cos(), e.cos() * a.sin(), e.sin()],
        };
        let kind = if l.prismatic { "prismatic" } else { "revolute" };
        t.push_str(&format!(
            "  - name: j{i}\n    type: {kind}\n    axis: {}\n    limits: {{lower: -3.2, upper: 3.2}}\n    drive: d{i}\n",
            list(&axis)
        ));
    }
    t.push_str("bodies:\n");
    for (i, l) in c.links.iter().enumerate() {
        let parent = if i == 0 { "base".to_string() } else { format!("b{}", i - 1) };
        let inertia = if c.planar {
            format!("{:e}", l.moments[2])
        } else {
            format!("{{ixx: {:e}, iyy: {:e}, izz: {:e}}}", l.moments[0], l.moments[1], l.moments[2])
        };
        let rpy = if c.planar { list(&l.rpy[2..]) } else { list(&l.rpy) };
        t.push_str(&format!(
            "  - name: b{i}\n    mass: {:e}\n    com: {}\n    inertia: {inertia}\n    parent: {parent}\n    \
             origin: {{xyz: {}, rpy: {rpy}}}\n    joint: j{i}\n",
            l.mass,
            list(&l.com[..dim]),
            list(&l.offset[..dim]),
        ));
    }
    let last = c.links.len() - 1;
    t.push_str(&format!(
        "points:\n  - name: tip\n    body: b{last}\n    position: {}\n",
        list(&[0.1, 0.02, 0.01][..dim])
    ));
    if c.tip_task {
        t.push_str("task:\n  point: tip\n");
    } else {
        let names: Vec<String> = (0..c.links.len()).map(|i| format!("j{i}")).collect();
        t.push_str(&format!("task:\n  joints: [{}]\n", names.join(", ")));
    }
    t.push_str(
        "rates: {current_loop_hz: 7500, impedance_loop_hz: 1000}\n\
         current_loop: {bandwidth_hz: 700.0, damping_ratio: 1.05, anti_alias_cutoff_hz: 2500.0}\n",
    );
    t
}

fn load(c: &Chain) -> Result<(Model, Mechanics), TestCaseError> {
    let text = model_text(c);
    let m = hapticgen_codegen::load(&Source { name: "random_chain.yaml", text: &text }, None)
        .map_err(|d| TestCaseError::fail(format!("a valid random model was rejected: {d}\n{text}")))?;
    let mech = hapticgen_codegen::derive(&m);
    Ok((m.model, mech))
}

fn eval(p: &Poly, q: &[f64], qd: &[f64]) -> f64 {
    p.eval(&State { q, qd, parameters: &[] })
}

fn matrix(m: &[Vec<Poly>], q: &[f64], qd: &[f64]) -> Vec<Vec<f64>> {
    m.iter().map(|row| row.iter().map(|p| eval(p, q, qd)).collect()).collect()
}

/// Every node of a DAG at one state (children precede parents).
fn eval_nodes(dag: &Dag, q: &[f64], qd: &[f64]) -> Vec<f64> {
    let state = State { q, qd, parameters: &[] };
    let mut values: Vec<f64> = Vec::with_capacity(dag.nodes().len());
    for node in dag.nodes() {
        let v = match *node {
            Node::Const(bits) => f64::from_bits(bits),
            Node::Input(atom) => state.value(atom),
            Node::Add(a, b) => values[a] + values[b],
            Node::Sub(a, b) => values[a] - values[b],
            Node::Mul(a, b) => values[a] * values[b],
            Node::Neg(a) => -values[a],
            Node::Div(a, b) => values[a] / values[b],
            Node::Sqrt(a) => values[a].sqrt(),
        };
        values.push(v);
    }
    values
}

/// `D`, `C q̇`, `g` and `V` as one DAG, for the simulation.
struct Dynamics {
    dag: Dag,
    inertia: Vec<Vec<NodeId>>,
    coriolis: Vec<NodeId>,
    gravity: Vec<NodeId>,
    potential: NodeId,
}

impl Dynamics {
    fn new(mech: &Mechanics) -> Dynamics {
        let mut dag = Dag::new();
        let inertia =
            mech.inertia_matrix.iter().map(|r| r.iter().map(|p| dag.polynomial(p)).collect()).collect();
        let coriolis = mech.coriolis_times_qdot.iter().map(|p| dag.polynomial(p)).collect();
        let gravity = mech.gravity.iter().map(|p| dag.polynomial(p)).collect();
        let potential = dag.polynomial(&mech.potential_energy);
        Dynamics { dag, inertia, coriolis, gravity, potential }
    }

    /// `q̈ = D⁻¹ (−C q̇ − g)` and the total energy.
    fn accel_energy(&self, q: &[f64], qd: &[f64]) -> (Vec<f64>, f64) {
        let v = eval_nodes(&self.dag, q, qd);
        let n = q.len();
        let d: Vec<Vec<f64>> = self.inertia.iter().map(|r| r.iter().map(|&i| v[i]).collect()).collect();
        let rhs: Vec<f64> = (0..n).map(|k| -v[self.coriolis[k]] - v[self.gravity[k]]).collect();
        let kinetic: f64 = (0..n).map(|i| (0..n).map(|j| 0.5 * qd[i] * d[i][j] * qd[j]).sum::<f64>()).sum();
        (solve(d, rhs), kinetic + v[self.potential])
    }
}

fn config() -> ProptestConfig {
    ProptestConfig { cases: 48, ..ProptestConfig::default() }
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn inertia_matrix_is_symmetric_positive_definite(c in chain()) {
        let (_, mech) = load(&c)?;
        let d = matrix(&mech.inertia_matrix, &c.q, &c.qd);
        let n = d.len();
        for i in 0..n {
            for j in 0..n {
                prop_assert_eq!(d[i][j], d[j][i], "D not symmetric at {:?}", c.q);
            }
        }
        prop_assert!(is_positive_definite(&d), "D not positive definite at {:?}: {:?}", c.q, d);
    }

    #[test]
    fn ddot_minus_two_c_is_skew_symmetric(c in chain()) {
        let (_, mech) = load(&c)?;
        let h = 1e-6;
        let along = |t: f64| {
            let q: Vec<f64> = c.q.iter().zip(&c.qd).map(|(a, b)| a + t * b).collect();
            matrix(&mech.inertia_matrix, &q, &c.qd)
        };
        let (plus, minus) = (along(h), along(-h));
        let cm = matrix(&mech.coriolis_matrix, &c.q, &c.qd);
        let n = cm.len();
        let scale = plus.iter().flatten().fold(1e-3f64, |m, v| m.max(v.abs())) * c.qd.iter().fold(1.0f64, |m, v| m.max(v.abs()));
        for i in 0..n {
            for j in 0..n {
                let nij = (plus[i][j] - minus[i][j]) / (2.0 * h) - 2.0 * cm[i][j];
                let nji = (plus[j][i] - minus[j][i]) / (2.0 * h) - 2.0 * cm[j][i];
                prop_assert!((nij + nji).abs() < 1e-6 * scale, "N[{}][{}] + N[{}][{}] = {}", i, j, j, i, nij + nji);
            }
        }
    }

    #[test]
    fn energy_is_conserved_without_damping(c in chain()) {
        let (_, mech) = load(&c)?;
        let dynamics = Dynamics::new(&mech);
        let (mut q, mut qd) = (c.q.clone(), c.qd.clone());
        let n = q.len();
        let (_, e0) = dynamics.accel_energy(&q, &qd);
        let dt = 2e-4;
        let mut scale = e0.abs();
        for _ in 0..500 {
            let step = |q: &[f64], qd: &[f64], dq: &[f64], dqd: &[f64], h: f64| {
                let q2: Vec<f64> = (0..n).map(|i| q[i] + h * dq[i]).collect();
                let qd2: Vec<f64> = (0..n).map(|i| qd[i] + h * dqd[i]).collect();
                let (a, _) = dynamics.accel_energy(&q2, &qd2);
                (qd2, a)
            };
            let (k1v, k1a) = (qd.clone(), dynamics.accel_energy(&q, &qd).0);
            let (k2v, k2a) = step(&q, &qd, &k1v, &k1a, dt / 2.0);
            let (k3v, k3a) = step(&q, &qd, &k2v, &k2a, dt / 2.0);
            let (k4v, k4a) = step(&q, &qd, &k3v, &k3a, dt);
            for i in 0..n {
                q[i] += dt / 6.0 * (k1v[i] + 2.0 * k2v[i] + 2.0 * k3v[i] + k4v[i]);
                qd[i] += dt / 6.0 * (k1a[i] + 2.0 * k2a[i] + 2.0 * k3a[i] + k4a[i]);
            }
            let (_, e) = dynamics.accel_energy(&q, &qd);
            scale = scale.max(e.abs());
        }
        let (_, e1) = dynamics.accel_energy(&q, &qd);
        // Kinetic and potential energy exchange, so scale by the largest magnitude seen
        // and by the kinetic energy's size at the start.
        let kinetic0: f64 = {
            let d = matrix(&mech.inertia_matrix, &c.q, &c.qd);
            (0..n).map(|i| (0..n).map(|j| 0.5 * c.qd[i] * d[i][j] * c.qd[j]).sum::<f64>()).sum()
        };
        let tolerance = 1e-7 * scale.max(kinetic0).max(1e-6);
        prop_assert!(q.iter().chain(&qd).all(|v| v.is_finite()), "the simulation diverged");
        prop_assert!((e1 - e0).abs() < tolerance, "energy drifted from {} to {} (tolerance {})", e0, e1, tolerance);
    }

    #[test]
    fn emitted_dag_equals_the_polynomial_evaluator(c in chain()) {
        let (m, mech) = load(&c)?;
        prop_assert_eq!(m.joints.len(), c.links.len());
        let mut polys: Vec<&Poly> = Vec::new();
        let task = &mech.task;
        polys.extend(&task.position);
        polys.extend(task.jacobian.iter().flatten());
        polys.extend(task.jacobian_dot.iter().flatten());
        polys.extend(&task.jacobian_dot_times_qdot);
        polys.extend(mech.inertia_matrix.iter().flatten());
        polys.extend(mech.coriolis_matrix.iter().flatten());
        polys.extend(&mech.coriolis_times_qdot);
        polys.extend(&mech.gravity);
        polys.push(&mech.potential_energy);
        let mut dag = Dag::new();
        let roots: Vec<NodeId> = polys.iter().map(|p| dag.polynomial(p)).collect();
        let values = eval_nodes(&dag, &c.q, &c.qd);
        for (k, (p, &root)) in polys.iter().zip(&roots).enumerate() {
            let expected = eval(p, &c.q, &c.qd);
            let got = values[root];
            // Also through the DAG's own evaluator.
            let direct = dag.eval(root, &|a: Atom| State { q: &c.q, qd: &c.qd, parameters: &[] }.value(a));
            prop_assert_eq!(got.to_bits(), direct.to_bits());
            let magnitude: f64 = p.terms().map(|(mono, coeff)| {
                mono.iter().fold(coeff.abs(), |acc, (a, e)| acc * State { q: &c.q, qd: &c.qd, parameters: &[] }.value(*a).abs().powi(*e as i32))
            }).sum();
            prop_assert!((got - expected).abs() <= 1e-12 * magnitude.max(1e-300) + 1e-300,
                "output {}: DAG {} vs polynomial {} (term magnitude {})", k, got, expected, magnitude);
        }
    }
}
