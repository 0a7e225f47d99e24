//! `hapticgen report`'s figures against independent computations: the force available in
//! every direction against a search over directions of the torque equation itself, the
//! apparent inertia against Rayleigh quotients of the mobility, the inscribed square's
//! lattice against the polynomial evaluator's forward kinematics and against a brute-force
//! sampling of the joint box; the condition number against the closed-form eigenvalues of
//! the evaluator's J Jᵀ and the gravity load against its g; the maps' cells against the evaluator's forward
//! kinematics and a brute-force sampling; the stiffest stable wall against the analytic bound.

use hapticgen_codegen::eval::{evaluate, State};
use hapticgen_host::design::{cube_lattice, joint_grid, Design, Sample};

fn model(name: &str) -> hapticgen_codegen::CheckedModel {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models").join(name);
    hapticgen_codegen::load_file(&path, name, None).unwrap_or_else(|d| panic!("{d}"))
}

/// Unit directions spread over the sphere (a Fibonacci lattice), or the circle for 2-D tasks.
fn directions(dim: usize, count: usize) -> Vec<Vec<f64>> {
    (0..count)
        .map(|i| {
            if dim == 2 {
                let a = std::f64::consts::TAU * i as f64 / count as f64;
                vec![a.cos(), a.sin()]
            } else {
                let z = 1.0 - 2.0 * (i as f64 + 0.5) / count as f64;
                let r = (1.0 - z * z).sqrt();
                let a = i as f64 * std::f64::consts::PI * (3.0 - 5f64.sqrt());
                vec![r * a.cos(), r * a.sin(), z]
            }
        })
        .collect()
}

/// The largest force along `u` every drive holds, by bisection on `|τ_i(f u)| ≤ limit_i` with
/// `τ = Jᵀ F + g` written out here.
fn largest_force_along(s: &Sample, u: &[f64], limits: &[f64]) -> f64 {
    let holds = |f: f64| {
        (0..s.gravity.len()).all(|i| {
            let tau: f64 = (0..u.len()).map(|k| s.jacobian[k][i] * f * u[k]).sum::<f64>() + s.gravity[i];
            tau.abs() <= limits[i]
        })
    };
    if !holds(0.0) {
        return 0.0;
    }
    let (mut lo, mut hi) = (0.0, 1e4);
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if holds(mid) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    lo
}

#[test]
fn force_capability_is_the_least_force_over_directions() {
    for name in ["falcon_delta.yaml", "phantom_3dof.yaml", "pantograph_5bar.yaml"] {
        let m = model(name);
        let design = Design::new(&m);
        let grid = joint_grid(&design.limits, 3);
        for q in grid.iter().step_by(4) {
            let Some(s) = design.sample(q) else { continue };
            let capability = design.force_capability(&s, &design.peak);
            let searched = directions(design.task_dim(), 4000)
                .iter()
                .map(|u| largest_force_along(&s, u, &design.peak))
                .fold(f64::INFINITY, f64::min);
            assert!(capability > 0.0, "{name} at {q:?}: {capability}");
            // Every direction holds at least the capability; the sampled directions come
            // within 2 % of the weakest.
            assert!(searched >= capability * (1.0 - 1e-9), "{name} at {q:?}: {searched} < {capability}");
            assert!(searched <= capability * 1.02, "{name} at {q:?}: {searched} vs {capability}");
        }
    }
}

#[test]
fn apparent_inertia_bounds_every_rayleigh_quotient_of_the_mobility() {
    let m = model("phantom_3dof.yaml");
    let design = Design::new(&m);
    let mech = hapticgen_codegen::derive(&m);
    let rotor = hapticgen_codegen::dynamics::reflected_rotor_inertia(&m);
    for q in [[0.1, 0.4, -0.3], [0.5, 0.9, 0.2], [-0.4, 0.2, 0.6]] {
        let s = design.sample(&q).unwrap();
        let (least, most) = design.apparent_inertia(&s).unwrap();
        // D and J from the polynomial evaluator, the mobility J D⁻¹ Jᵀ by Gauss–Jordan here.
        let e = evaluate(&mech, &State { q: &q, qd: &[0.0; 3], parameters: &[] }, None);
        let mut d: Vec<Vec<f64>> =
            (0..3).map(|i| (0..3).map(|j| e.inertia_matrix[i][j] + rotor[i][j]).collect()).collect();
        let mut inverse: Vec<Vec<f64>> =
            (0..3).map(|i| (0..3).map(|j| f64::from(u8::from(i == j))).collect()).collect();
        for c in 0..3 {
            let pivot = d[c][c];
            for k in 0..3 {
                d[c][k] /= pivot;
                inverse[c][k] /= pivot;
            }
            for r in (0..3).filter(|&r| r != c) {
                let f = d[r][c];
                for k in 0..3 {
                    d[r][k] -= f * d[c][k];
                    inverse[r][k] -= f * inverse[c][k];
                }
            }
        }
        let j = &e.jacobian;
        let quotients: Vec<f64> = directions(3, 3000)
            .iter()
            .map(|u| {
                let jt_u: Vec<f64> = (0..3).map(|i| (0..3).map(|k| j[k][i] * u[k]).sum()).collect();
                let mobility: f64 =
                    (0..3).map(|i| (0..3).map(|k| jt_u[i] * inverse[i][k] * jt_u[k]).sum::<f64>()).sum();
                1.0 / mobility
            })
            .collect();
        let (lo, hi) = quotients.iter().fold((f64::INFINITY, 0.0f64), |(a, b), &x| (a.min(x), b.max(x)));
        assert!(
            lo >= least * (1.0 - 1e-9) && hi <= most * (1.0 + 1e-9),
            "{q:?}: [{lo}, {hi}] vs [{least}, {most}]"
        );
        assert!(lo <= least * 1.01 && hi >= most * 0.99, "{q:?}: [{lo}, {hi}] vs [{least}, {most}]");
    }
}

/// Brute force: the task points of a planar two-joint rig at a grid of 301 values per joint
/// over `limits`, by the polynomial evaluator (≈ 0.4 mm apart for the five-bar).
fn planar_cloud(
    mech: &hapticgen_codegen::dynamics::mechanics::Mechanics,
    limits: &[(f64, f64)],
) -> Vec<[f64; 2]> {
    joint_grid(limits, 301)
        .iter()
        .filter_map(|q| {
            let p = evaluate(mech, &State { q, qd: &[0.0; 2], parameters: &[] }, None).p;
            (p[0].is_finite() && p[1].is_finite()).then_some([p[0], p[1]])
        })
        .collect()
}

#[test]
fn the_inscribed_square_and_disc_are_reached_and_larger_ones_are_not() {
    let m = model("pantograph_5bar.yaml");
    let mech = hapticgen_codegen::derive(&m);
    let design = Design::new(&m);
    let ws = design.workspace(21).unwrap();
    assert!(ws.edge > 0.02, "{}", ws.edge);
    // Every lattice point's joint state lies within the limits and reaches the point, by the
    // polynomial evaluator's forward kinematics.
    let lattice = cube_lattice(&ws.centre, ws.edge, hapticgen_host::design::CUBE_PROBES);
    for (x, q) in lattice.iter().zip(&ws.lattice) {
        assert!(design.limits.iter().zip(q).all(|(&(lo, hi), v)| (lo..=hi).contains(v)), "{q:?}");
        let p = evaluate(&mech, &State { q, qd: &[0.0; 2], parameters: &[] }, None).p;
        assert!((p[0] - x[0]).hypot(p[1] - x[1]) < 2e-6, "{p:?} vs {x:?}");
    }
    // Brute force: the task points of a fine grid over the joint box (spacing ≈ 0.4 mm). The
    // square's points all lie among them; a square 10 % larger reaches out of them.
    let cloud = planar_cloud(&mech, &design.limits);
    let farthest = |edge: f64| {
        cube_lattice(&ws.centre, edge, 11)
            .iter()
            .map(|x| cloud.iter().map(|c| (c[0] - x[0]).hypot(c[1] - x[1])).fold(f64::INFINITY, f64::min))
            .fold(0.0, f64::max)
    };
    assert!(farthest(ws.edge) < 0.6e-3, "{}", farthest(ws.edge));
    assert!(farthest(1.1 * ws.edge) > 1.0e-3, "{}", farthest(1.1 * ws.edge));
    // The inscribed disc the same way, on 360 points of its circle: inside the cloud, and a disc
    // 10 % larger about the same centre reaching out of it. It holds the square's inscribed disc.
    let (centre, radius) = &ws.ball;
    assert!(*radius >= 0.5 * ws.edge * (1.0 - 1e-3), "{radius} vs the square's {}", ws.edge);
    let farthest_on_circle = |r: f64| {
        (0..360)
            .map(|i| {
                let a = f64::from(i).to_radians();
                let x = [centre[0] + r * a.cos(), centre[1] + r * a.sin()];
                cloud.iter().map(|c| (c[0] - x[0]).hypot(c[1] - x[1])).fold(f64::INFINITY, f64::min)
            })
            .fold(0.0, f64::max)
    };
    assert!(farthest_on_circle(*radius) < 0.6e-3, "{}", farthest_on_circle(*radius));
    assert!(farthest_on_circle(1.1 * radius) > 1.0e-3, "{}", farthest_on_circle(1.1 * radius));
}

#[test]
fn the_page_draws_the_rig_where_the_evaluator_puts_it() {
    // The drawing's task node at every state of its grid is the task point of the polynomial
    // evaluator; the Delta's platform joints meet the far ends of their shins (the loops closed).
    for name in ["pantograph_5bar.yaml", "falcon_delta.yaml"] {
        let m = model(name);
        let mech = hapticgen_codegen::derive(&m);
        let grid = hapticgen_host::design_page::pose_grid(&m, 4);
        let task = grid.task_node.expect("a point task");
        let n = m.joints.len();
        for (q, pose) in joint_grid(&grid.limits, 4).iter().zip(&grid.positions) {
            let p = evaluate(&mech, &State { q, qd: &vec![0.0; n], parameters: &[] }, None).p;
            for k in 0..p.len() {
                assert!((pose[task][k] - p[k]).abs() < 1e-12, "{name} at {q:?}: {:?} vs {p:?}", pose[task]);
            }
            let node = |name: &str| grid.nodes.iter().position(|n| n == name);
            for (end, joint) in [("shin2_end", "platform_joint2"), ("shin3_end", "platform_joint3")] {
                if let (Some(a), Some(b)) = (node(end), node(joint)) {
                    let gap: f64 = (0..3).map(|k| (pose[a][k] - pose[b][k]).powi(2)).sum::<f64>().sqrt();
                    assert!(gap < 1e-9, "{name} at {q:?}: {end} is {gap} m from {joint}");
                }
            }
        }
        // Every segment joins two nodes of the drawing.
        assert!(grid.segments.iter().all(|&(a, b)| a < grid.nodes.len() && b < grid.nodes.len() && a != b));
    }
}

/// The evaluator's quantities at `q` as a [`Sample`] (D without the rotors: the gravity and the
/// Jacobian are what the checks below use).
fn evaluator_sample(mech: &hapticgen_codegen::dynamics::mechanics::Mechanics, q: &[f64]) -> Sample {
    let n = q.len();
    let e = evaluate(mech, &State { q, qd: &vec![0.0; n], parameters: &[] }, None);
    Sample { q: q.to_vec(), position: e.p, jacobian: e.jacobian, inertia: e.inertia_matrix, gravity: e.g }
}

/// The eigenvalues of a symmetric 2×2 or 3×3 matrix in closed form (the quadratic formula;
/// Smith's trigonometric solution of the characteristic cubic), least first.
fn symmetric_eigenvalues(a: &[Vec<f64>]) -> Vec<f64> {
    if a.len() == 2 {
        let (mean, half) = (0.5 * (a[0][0] + a[1][1]), 0.5 * (a[0][0] - a[1][1]));
        let r = half.hypot(a[0][1]);
        return vec![mean - r, mean + r];
    }
    let q = (a[0][0] + a[1][1] + a[2][2]) / 3.0;
    let off = a[0][1].powi(2) + a[0][2].powi(2) + a[1][2].powi(2);
    let p =
        (((a[0][0] - q).powi(2) + (a[1][1] - q).powi(2) + (a[2][2] - q).powi(2) + 2.0 * off) / 6.0).sqrt();
    let b: Vec<Vec<f64>> =
        (0..3).map(|i| (0..3).map(|j| (a[i][j] - if i == j { q } else { 0.0 }) / p).collect()).collect();
    let det = b[0][0] * (b[1][1] * b[2][2] - b[1][2] * b[2][1])
        - b[0][1] * (b[1][0] * b[2][2] - b[1][2] * b[2][0])
        + b[0][2] * (b[1][0] * b[2][1] - b[1][1] * b[2][0]);
    let phi = (det / 2.0).clamp(-1.0, 1.0).acos() / 3.0;
    let largest = q + 2.0 * p * phi.cos();
    let least = q + 2.0 * p * (phi + 2.0 * std::f64::consts::PI / 3.0).cos();
    vec![least, 3.0 * q - largest - least, largest]
}

#[test]
fn condition_number_and_gravity_load_match_the_evaluator() {
    // κ(J) = √(λ_max / λ_min) of J Jᵀ, with the polynomial evaluator's J and the eigenvalues in
    // closed form; the gravity load from the evaluator's g and the drives' torque limits.
    for name in ["falcon_delta.yaml", "phantom_3dof.yaml", "pantograph_5bar.yaml"] {
        let m = model(name);
        let mech = hapticgen_codegen::derive(&m);
        let design = Design::new(&m);
        let limits: Vec<f64> = m.joints.iter().map(|j| j.drive.torque_limit).collect();
        for q in joint_grid(&design.limits, 3).iter().step_by(4) {
            let Some(s) = design.sample(q) else { continue };
            let e = evaluator_sample(&mech, q);
            let dim = e.jacobian.len();
            let jjt: Vec<Vec<f64>> = (0..dim)
                .map(|i| {
                    (0..dim)
                        .map(|k| (0..q.len()).map(|j| e.jacobian[i][j] * e.jacobian[k][j]).sum())
                        .collect()
                })
                .collect();
            let eigen = symmetric_eigenvalues(&jjt);
            let expected = (eigen[dim - 1] / eigen[0]).sqrt();
            let condition = design.condition(&s);
            assert!(
                (condition / expected - 1.0).abs() < 1e-6,
                "{name} at {q:?}: κ {condition} vs {expected}"
            );
            let load = e.gravity.iter().zip(&limits).map(|(g, l)| 100.0 * g.abs() / l).fold(0.0, f64::max);
            assert!((design.gravity_load(&s) - load).abs() <= 1e-9 * load.max(1.0), "{name} at {q:?}");
        }
    }
}

#[test]
fn the_maps_cells_are_reached_where_the_joint_box_reaches() {
    use hapticgen_host::design_maps::slices;
    let m = model("pantograph_5bar.yaml");
    let mech = hapticgen_codegen::derive(&m);
    let design = Design::new(&m);
    let ws = design.workspace(15).unwrap();
    let slice = slices(&design, &ws, 24).pop().expect("a planar task has one slice");
    assert_eq!(slice.cells.len(), 24 * 24);
    // A reached cell: its joint state within the limits reaches the cell's centre by the
    // evaluator's forward kinematics, and its force is the weakest over directions of the
    // torque equation at the evaluator's J and g.
    let mut reached = 0;
    for (k, cell) in slice.cells.iter().enumerate() {
        let Some(cell) = cell else { continue };
        reached += 1;
        let x = [slice.u[k % 24], slice.v[k / 24]];
        assert!(
            design.limits.iter().zip(&cell.q).all(|(&(lo, hi), v)| (lo..=hi).contains(v)),
            "{:?}",
            cell.q
        );
        let e = evaluator_sample(&mech, &cell.q);
        assert!((e.position[0] - x[0]).hypot(e.position[1] - x[1]) < 2e-6, "{:?} vs {x:?}", e.position);
        let searched = directions(2, 720)
            .iter()
            .map(|u| largest_force_along(&e, u, &design.peak))
            .fold(f64::INFINITY, f64::min);
        let mapped = cell.figures.force_peak;
        assert!(searched >= mapped * (1.0 - 1e-9) && searched <= mapped * 1.02, "{searched} vs {mapped}");
    }
    assert!(reached > 24 * 24 / 5, "only {reached} cells reached");
    // An unreached cell: no pose of a fine grid over the joint box (≈ 0.4 mm apart) lands within
    // 0.2 mm of its centre, but for a few at the workspace's edge.
    let cloud = planar_cloud(&mech, &design.limits);
    let missed = slice
        .cells
        .iter()
        .enumerate()
        .filter(|(_, c)| c.is_none())
        .filter(|(k, _)| {
            let x = [slice.u[k % 24], slice.v[k / 24]];
            cloud.iter().any(|c| (c[0] - x[0]).hypot(c[1] - x[1]) < 0.2e-3)
        })
        .count();
    let unreached = 24 * 24 - reached;
    assert!(missed * 50 <= unreached, "{missed} of {unreached} unreached cells lie in the workspace");
}

#[test]
fn the_stiffest_wall_lies_under_the_bound_at_the_centre_and_every_corner() {
    let m = model("pantograph_5bar.yaml");
    let design = Design::new(&m);
    let ws = design.workspace(11).unwrap();
    let k = hapticgen_host::design::renderable_stiffness(&m, &design, &ws).unwrap().expect("a planar task");
    assert_eq!(k.corners.len(), 4);
    for value in std::iter::once(k.centre).chain(k.corners.iter().map(|c| c.1)) {
        let value = value.expect("a stable wall");
        assert!(value >= k.range.0 && value <= 1.05 * k.stability_bound, "{value} vs {k:?}");
    }
    assert_eq!(k.min_over_corners, k.corners.iter().map(|c| c.1.unwrap()).reduce(f64::min));
}
