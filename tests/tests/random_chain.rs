//! Random valid serial chains for the property tests, written as model files and loaded by the
//! real loader: planar or spatial chains of revolute or prismatic joints with random masses,
//! lengths, centres of mass, inertias (principal moments that satisfy the triangle
//! inequality), axes, joint-frame rotations, rotor inertias and gravity; the task is the tip
//! point or the joint coordinates. No damping, so that energy is conserved.

use std::ops::RangeInclusive;

use proptest::prelude::*;
use proptest::test_runner::TestCaseError;

/// One joint and the body it moves.
#[derive(Clone, Debug)]
pub struct Link {
    pub prismatic: bool,
    /// Axis direction angles (spatial: azimuth, elevation; planar prismatic: angle in x–y;
    /// planar revolute: the sign of z).
    pub axis: (f64, f64),
    /// Offset from the parent's frame to this joint frame.
    pub offset: [f64; 3],
    /// Roll, pitch, yaw of the joint frame (spatial) or the angle (planar).
    pub rpy: [f64; 3],
    pub mass: f64,
    pub com: [f64; 3],
    /// Principal moments satisfying the triangle inequality.
    pub moments: [f64; 3],
    pub rotor_inertia: f64,
}

#[derive(Clone, Debug)]
pub struct Chain {
    pub planar: bool,
    pub gravity: [f64; 3],
    pub links: Vec<Link>,
    /// Task: the chain's tip point (true) or the joint coordinates.
    pub tip_task: bool,
    pub q: Vec<f64>,
    pub qd: Vec<f64>,
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

/// Chains of `joints` joints, planar with probability `planar_weight`.
pub fn chain(joints: RangeInclusive<usize>, planar_weight: f64) -> impl Strategy<Value = Chain> {
    (
        prop::bool::weighted(planar_weight),
        prop::array::uniform3(-10.0f64..10.0),
        prop::collection::vec(link(), joints),
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
pub fn model_text(c: &Chain) -> String {
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

/// Checks that `Ḋ − 2C` is skew-symmetric at the chain's state, `Ḋ` by the central difference
/// of `D` along `q̇` (`inertia_along(t)` is `D(q + t q̇)`), to 1e-6 of `D`'s size times `|q̇|`.
pub fn check_ddot_minus_two_c_skew(
    c: &Chain,
    inertia_along: impl Fn(f64) -> Vec<Vec<f64>>,
    coriolis_matrix: &[Vec<f64>],
) -> Result<(), TestCaseError> {
    let h = 1e-6;
    let (plus, minus) = (inertia_along(h), inertia_along(-h));
    let scale = plus.iter().flatten().fold(1e-3f64, |m, v| m.max(v.abs()))
        * c.qd.iter().fold(1.0f64, |m, v| m.max(v.abs()));
    let n = coriolis_matrix.len();
    for i in 0..n {
        for j in 0..n {
            let nij = (plus[i][j] - minus[i][j]) / (2.0 * h) - 2.0 * coriolis_matrix[i][j];
            let nji = (plus[j][i] - minus[j][i]) / (2.0 * h) - 2.0 * coriolis_matrix[j][i];
            prop_assert!(
                (nij + nji).abs() < 1e-6 * scale,
                "N[{}][{}] + N[{}][{}] = {}",
                i,
                j,
                j,
                i,
                nij + nji
            );
        }
    }
    Ok(())
}
