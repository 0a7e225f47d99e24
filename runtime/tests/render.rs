//! Haptic rendering (paper, section 4): proxies on the surface at the true closest point,
//! tracing a circle and a square from the inside, and the anti-drift grid.

// Index loops mirror the equations component by component.
#![allow(clippy::needless_range_loop)]

use crate::common::{forward_dynamics, Parallelogram};
use hapticgen_runtime::control::{
    ControlOptions, ImpedanceController, ImpedanceLaw, ImpedanceParameters, TaskSensing,
};
use hapticgen_runtime::render::{AntiDriftGrid, ObjectKind, Scene, Shape, VirtualObject};
use hapticgen_runtime::RigModel;
use rand::rngs::SmallRng;
use rand::{Rng, SeedableRng};

fn distance(a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

fn segment_closest(a: [f64; 2], b: [f64; 2], p: [f64; 2]) -> [f64; 2] {
    let e = [b[0] - a[0], b[1] - a[1]];
    let t = (((p[0] - a[0]) * e[0] + (p[1] - a[1]) * e[1]) / (e[0] * e[0] + e[1] * e[1])).clamp(0.0, 1.0);
    [a[0] + t * e[0], a[1] + t * e[1]]
}

fn polyline_closest(points: &[[f64; 2]], closed: bool, p: [f64; 2]) -> [f64; 2] {
    let n = points.len();
    let edges = if closed { n } else { n - 1 };
    (0..edges)
        .map(|i| segment_closest(points[i], points[(i + 1) % n], p))
        .min_by(|a, b| distance(*a, p).partial_cmp(&distance(*b, p)).unwrap())
        .unwrap()
}

fn scene_with(shape: Shape<f64, 8>) -> Scene<f64, 2, 8> {
    let mut scene = Scene::new(200.0, 2.0, 0.3e-3);
    scene.add(VirtualObject { shape, kind: ObjectKind::Solid, stiffness: 1500.0, damping: 5.0 });
    scene
}

fn wavy(x: f64) -> f64 {
    0.01 * (30.0 * x).sin() + 0.5 * x * x
}
fn wavy_slope(x: f64) -> f64 {
    0.3 * (30.0 * x).cos() + x
}
fn wavy_curvature(x: f64) -> f64 {
    -9.0 * (30.0 * x).sin() + 1.0
}

/// The true closest point on the graph of `wavy`: dense sampling, then Newton on eq. (16)'s
/// gradient with the exact second derivative.
fn wavy_closest(p: [f64; 2], range: [f64; 2]) -> [f64; 2] {
    let n = 200_000;
    let mut best = range[0];
    for i in 0..=n {
        let t = range[0] + (range[1] - range[0]) * i as f64 / n as f64;
        if distance([t, wavy(t)], p) < distance([best, wavy(best)], p) {
            best = t;
        }
    }
    for _ in 0..50 {
        let g = (best - p[0]) + (wavy(best) - p[1]) * wavy_slope(best);
        let dg = 1.0 + wavy_slope(best).powi(2) + (wavy(best) - p[1]) * wavy_curvature(best);
        best = (best - g / dg).clamp(range[0], range[1]);
    }
    [best, wavy(best)]
}

#[test]
fn proxy_pushed_into_each_primitive_sits_at_the_true_closest_point() {
    let mut rng = SmallRng::seed_from_u64(7);
    let (angle, half, center) = (0.4f64, [0.03, 0.015], [0.02, 0.1]);
    let (s, c) = angle.sin_cos();
    let corners: Vec<[f64; 2]> = [[1.0, 1.0], [-1.0, 1.0], [-1.0, -1.0], [1.0, -1.0]]
        .iter()
        .map(|[a, b]| {
            let (x, y) = (a * half[0], b * half[1]);
            [center[0] + c * x - s * y, center[1] + s * x + c * y]
        })
        .collect();
    let hexagon: Vec<[f64; 2]> = (0..6)
        .map(|i| {
            let t = i as f64 * std::f64::consts::PI / 3.0 + 0.1;
            [0.05 + 0.04 * t.cos(), 0.08 + 0.03 * t.sin()]
        })
        .collect();
    let mut hexagon_vertices = [[0.0; 2]; 8];
    hexagon_vertices[..6].copy_from_slice(&hexagon);
    let table_x: Vec<f64> = (0..8).map(|i| -0.1 + 0.2 * i as f64 / 7.0).collect();
    let mut table = [0.0; 8];
    for (slot, &x) in table.iter_mut().zip(&table_x) {
        *slot = wavy(x);
    }
    let table_points: Vec<[f64; 2]> = table_x.iter().zip(table).map(|(&x, y)| [x, y]).collect();

    let mut worst = [0.0f64; 5];
    for trial in 0..200 {
        // Circle.
        let (cc, r) = ([0.1, 0.05], 0.04);
        let p = [cc[0] + rng.gen_range(-0.028..0.028), cc[1] + rng.gen_range(-0.028..0.028)];
        let out = scene_with(Shape::Circle { center: cc, radius: r }).render(&p);
        assert_eq!(out.contact, Some(0));
        let d = distance(p, cc);
        let truth = [cc[0] + r * (p[0] - cc[0]) / d, cc[1] + r * (p[1] - cc[1]) / d];
        worst[0] = worst[0].max(distance(out.proxy, truth));
        // Rotated rectangle.
        let local = [rng.gen_range(-0.029..0.029), rng.gen_range(-0.014..0.014)];
        let p = [center[0] + c * local[0] - s * local[1], center[1] + s * local[0] + c * local[1]];
        let out = scene_with(Shape::Rectangle { center, half_extents: half, angle }).render(&p);
        assert_eq!(out.contact, Some(0));
        worst[1] = worst[1].max(distance(out.proxy, polyline_closest(&corners, true, p)));
        // Convex polygon.
        let p = [0.05 + rng.gen_range(-0.02..0.02), 0.08 + rng.gen_range(-0.015..0.015)];
        let out = scene_with(Shape::ConvexPolygon { vertices: hexagon_vertices, count: 6 }).render(&p);
        assert_eq!(out.contact, Some(0), "trial {trial}");
        worst[2] = worst[2].max(distance(out.proxy, polyline_closest(&hexagon, true, p)));
        // Contour function (solid: region below the curve).
        let range = [-0.1, 0.1];
        let x = rng.gen_range(-0.09..0.09);
        let p = [x, wavy(x) - rng.gen_range(0.0005..0.01)];
        let out = scene_with(Shape::ContourFunction { function: wavy, slope: wavy_slope, x1_range: range })
            .render(&p);
        assert_eq!(out.contact, Some(0));
        worst[3] = worst[3].max(distance(out.proxy, wavy_closest(p, range)));
        // Sampled contour table.
        let p = [x, wavy(x) - rng.gen_range(0.0005..0.01)];
        let out =
            scene_with(Shape::ContourTable { samples: table, count: 8, x1_range: [-0.1, 0.1] }).render(&p);
        if out.contact == Some(0) {
            worst[4] = worst[4].max(distance(out.proxy, polyline_closest(&table_points, false, p)));
        }
    }
    println!(
        "worst distance to the true closest point [circle, rectangle, polygon, contour fn, table]: {worst:?}"
    );
    for w in worst {
        assert!(w < 1e-9, "{worst:?}");
    }
}

#[test]
fn sliding_along_circle_and_square_from_inside_traces_the_contour() {
    // Fig. 7: cavities, HIP pushed 2 mm beyond the wall while going round.
    let mut circle: Scene<f64, 1, 4> = Scene::new(0.0, 0.0, 0.3e-3);
    circle.add(VirtualObject {
        shape: Shape::Circle { center: [0.1, 0.0], radius: 0.04 },
        kind: ObjectKind::Cavity,
        stiffness: 1500.0,
        damping: 5.0,
    });
    let mut square: Scene<f64, 1, 4> = Scene::new(0.0, 0.0, 0.3e-3);
    square.add(VirtualObject {
        shape: Shape::Rectangle { center: [0.1, 0.0], half_extents: [0.03, 0.03], angle: 0.0 },
        kind: ObjectKind::Cavity,
        stiffness: 1500.0,
        damping: 5.0,
    });
    for i in 0..720 {
        let t = i as f64 * std::f64::consts::PI / 360.0;
        let hip = [0.1 + 0.042 * t.cos(), 0.042 * t.sin()];
        let out = circle.render(&hip);
        assert_eq!(out.contact, Some(0));
        assert_eq!(out.stiffness, [1500.0; 2]);
        assert!((distance(out.proxy, [0.1, 0.0]) - 0.04).abs() < 1e-12);
        assert!((out.proxy[1].atan2(out.proxy[0] - 0.1) - hip[1].atan2(hip[0] - 0.1)).abs() < 1e-9);
        // Square: HIP on a square 2 mm outside the wall, corners included.
        let side = (i / 180) as f64;
        let u = (i % 180) as f64 / 180.0 * 0.064 - 0.032;
        let local = match side as u32 {
            0 => [0.032, u],
            1 => [-u, 0.032],
            2 => [-0.032, -u],
            _ => [u, -0.032],
        };
        let out = square.render(&[0.1 + local[0], local[1]]);
        assert_eq!(out.contact, Some(0));
        let proxy = [out.proxy[0] - 0.1, out.proxy[1]];
        let on_wall = (proxy[0].abs() - 0.03).abs() < 1e-12 || (proxy[1].abs() - 0.03).abs() < 1e-12;
        assert!(on_wall && proxy[0].abs() <= 0.03 + 1e-12 && proxy[1].abs() <= 0.03 + 1e-12);
        assert!((proxy[0] - local[0].clamp(-0.03, 0.03)).abs() < 1e-12);
        assert!((proxy[1] - local[1].clamp(-0.03, 0.03)).abs() < 1e-12);
    }
    // Back inside: free space.
    assert_eq!(circle.render(&[0.1, 0.0]).contact, None);
}

#[test]
fn with_the_grid_and_no_operator_force_the_ihip_never_moves() {
    // Closed loop on the vertical 2-DOF rig, Controller 3, free space only, f_l = 0, the HIP
    // starting about 0.1 mm from its grid node and moving (q̇1 = 0.01 rad/s): 5 s at 1 kHz
    // (plant integrated at 10 kHz).
    let rig = Parallelogram;
    let mut scene: Scene<f64, 1, 4> = Scene::new(300.0, 3.0, 0.3e-3);
    let mut controller = ImpedanceController {
        law: ImpedanceLaw::JacobianTranspose,
        parameters: ImpedanceParameters { stiffness: [0.0; 2], damping: [0.0; 2], mass: [0.0; 2] },
        options: ControlOptions {
            omit_damping_compensation: true,
            min_abs_jacobian_determinant: 1e-4,
            spring_lead_time: 0.0,
            friction_compensation_band: None,
        },
    };
    let mut q = [1.6, -0.4];
    let mut qd = [0.0, 0.0];
    let start = rig.position(&q);
    let node = scene.render(&start).proxy;
    let mut moved = false;
    qd[0] = 0.01;
    for _ in 0..5000 {
        let terms = rig.terms(&q, &qd);
        let reference = scene.update_reference(&terms.position, &mut controller.parameters);
        moved |= reference.position != node;
        let torque = controller.torque(&rig, &terms, &qd, &reference, &TaskSensing::default()).torque;
        for _ in 0..10 {
            let qdd = forward_dynamics(&rig, &q, &qd, &torque, &[0.0, 0.0]);
            for i in 0..2 {
                qd[i] += 1e-4 * qdd[i];
                q[i] += 1e-4 * qd[i];
            }
        }
    }
    let end = rig.position(&q);
    println!("start {:?} node {:?} end {:?}, |end − node| = {:.3e} m", start, node, end, distance(end, node));
    assert!(!moved, "the IHIP moved");
    assert!(distance(end, node) < 1e-5);
}

/// The contour `x2 = x1` over `[0, 1]`: the closest point to `(x, y)` is `t = (x + y)/2` on the
/// line, clamped to the range (an end point when the foot of the perpendicular is outside).
fn diagonal(t: f64) -> f64 {
    t
}
fn diagonal_slope(_: f64) -> f64 {
    1.0
}

#[test]
fn a_contour_function_is_closest_at_the_perpendicular_foot_or_an_end_and_acts_only_in_range() {
    // Written to kill mutants that survived `cargo mutants` (docs/mutation-testing.md).
    let contour: Shape<f64, 4> =
        Shape::ContourFunction { function: diagonal, slope: diagonal_slope, x1_range: [0.0, 1.0] };
    // Interior: the foot of the perpendicular from (0.6, 0.2) is t = 0.4; the point is below.
    let out = contour.closest_surface_point(&[0.6, 0.2]).unwrap();
    assert!(distance(out.point, [0.4, 0.4]) < 1e-12, "{:?}", out.point);
    assert!(out.inside);
    // The foot at t = −0.2495 is left of the range: the end point (0, 0); the search starts
    // at the first sample there.
    let out = contour.closest_surface_point(&[0.001, -0.5]).unwrap();
    assert!(distance(out.point, [0.0, 0.0]) < 1e-12, "{:?}", out.point);
    // The foot at t = 1.3 is right of it: the other end; above the curve, so outside.
    let out = contour.closest_surface_point(&[0.9, 1.7]).unwrap();
    assert!(distance(out.point, [1.0, 1.0]) < 1e-12, "{:?}", out.point);
    assert!(!out.inside);
    // Outside the x1 range, or an empty range: the contour does not act.
    for p in [[-0.01, -0.5], [1.01, 0.0]] {
        assert!(contour.closest_surface_point(&p).is_none(), "{p:?}");
    }
    let empty: Shape<f64, 4> =
        Shape::ContourFunction { function: diagonal, slope: diagonal_slope, x1_range: [1.0, 0.0] };
    assert!(empty.closest_surface_point(&[0.5, 0.0]).is_none());
}

#[test]
fn a_contour_table_interpolates_the_height_that_decides_inside() {
    // Written to kill mutants that survived `cargo mutants` (docs/mutation-testing.md).
    // Three samples over [0, 1] (spacing 0.5) of x2 = x1, heights 0, 0.5, 1: at x1 = 0.75 the
    // interpolated height is 0.75, so 0.7 is inside (below) and 0.8 outside.
    let mut samples = [0.0; 4];
    samples[..3].copy_from_slice(&[0.0, 0.5, 1.0]);
    let table: Shape<f64, 4> = Shape::ContourTable { samples, count: 3, x1_range: [0.0, 1.0] };
    let below = table.closest_surface_point(&[0.75, 0.7]).unwrap();
    assert!(below.inside);
    assert!(distance(below.point, [0.725, 0.725]) < 1e-12, "{:?}", below.point);
    let above = table.closest_surface_point(&[0.75, 0.8]).unwrap();
    assert!(!above.inside);
    assert!(distance(above.point, [0.775, 0.775]) < 1e-12, "{:?}", above.point);
    // Outside the x1 range the table does not act.
    for p in [[-0.01, -0.5], [1.01, 0.0]] {
        assert!(table.closest_surface_point(&p).is_none(), "{p:?}");
    }
}

#[test]
fn the_anti_drift_grid_holds_its_node_within_one_spacing_and_snaps_beyond() {
    // Written to kill mutants that survived `cargo mutants` (docs/mutation-testing.md).
    let mut grid = AntiDriftGrid::new(0.01);
    assert_eq!(grid.update(&[0.001, -0.002]), [0.0, 0.0]);
    // Within one spacing of the node on both axes: held.
    assert_eq!(grid.update(&[0.009, -0.0095]), [0.0, 0.0]);
    assert_eq!(grid.node(), Some([0.0, 0.0]));
    // Beyond on one axis: snapped to the nearest node, 0.0151 → 0.02 and −0.0095 → −0.01.
    let node = grid.update(&[0.0151, -0.0095]);
    assert!(distance(node, [0.02, -0.01]) < 1e-15, "{node:?}");
    // Away from the origin (where `hip − node` and `hip + node` agree): spacing 1/4, the node
    // (1, 2) holds a HIP 0.2 away on both axes, though (1.2, 2.2) would snap to (1.25, 2.25).
    // (Written for the held-out cargo-mutants survivor `hip − node` → `hip + node`, shard 6/8.)
    let mut grid = AntiDriftGrid::new(0.25);
    assert_eq!(grid.update(&[1.1, 2.1]), [1.0, 2.0]);
    assert_eq!(grid.update(&[1.2, 2.2]), [1.0, 2.0]);
    assert_eq!(grid.update(&[0.8, 1.8]), [1.0, 2.0]);
    assert_eq!(grid.update(&[1.3, 2.2]), [1.25, 2.25]);
    // Disabled by a zero spacing: the IHIP is the HIP.
    let mut off = AntiDriftGrid::new(0.0);
    assert_eq!(off.update(&[0.0151, -0.0095]), [0.0151, -0.0095]);
}

/// A circle queried at its exact centre, where every boundary point is equally close: a finite
/// boundary point one radius away (the one along +x1), inside. Guards the centre case of the
/// circle (a held-out cargo-mutants survivor: `distance > 0` → `>=` divided 0 by 0 there and
/// the query gave no point).
#[test]
fn a_circle_queried_at_its_centre_gives_a_boundary_point_one_radius_away() {
    let circle: Shape<f64, 4> = Shape::Circle { center: [0.02, -0.01], radius: 0.05 };
    let out = circle.closest_surface_point(&[0.02, -0.01]).unwrap();
    assert!((distance(out.point, [0.02, -0.01]) - 0.05).abs() < 1e-15, "{:?}", out.point);
    assert!(distance(out.point, [0.07, -0.01]) < 1e-15, "{:?}", out.point);
    assert!(out.inside);
    // Exactly on the circle (distances in powers of two): its own closest point, not inside,
    // `inside` being strict. (Held-out shard 3/8: `distance < radius` → `<=` counted it in.)
    let circle: Shape<f64, 4> = Shape::Circle { center: [0.25, 0.0], radius: 0.5 };
    for p in [[0.75, 0.0], [0.25, -0.5]] {
        let out = circle.closest_surface_point(&p).unwrap();
        assert!(!out.inside, "{p:?}");
        assert_eq!(out.point, p);
    }
}

/// `inside` means strictly inside (`SurfacePoint::inside`): a point exactly on a rectangle's
/// edge is on the boundary, its own closest point, and not inside. Guards the strict
/// comparisons of the rectangle's inside test (a held-out cargo-mutants survivor: the second
/// axis' `|y| < h` → `<=` counted its edges as inside).
#[test]
fn a_point_on_a_rectangle_edge_is_not_inside() {
    let rectangle: Shape<f64, 4> =
        Shape::Rectangle { center: [0.0, 0.0], half_extents: [0.03, 0.015], angle: 0.0 };
    for p in [[0.01, 0.015], [-0.02, -0.015], [0.03, 0.005], [-0.03, 0.0]] {
        let out = rectangle.closest_surface_point(&p).unwrap();
        assert!(!out.inside, "{p:?}");
        assert_eq!(out.point, p);
    }
    // Just inside the top edge: inside, pushed out to it.
    let out = rectangle.closest_surface_point(&[0.01, 0.0149]).unwrap();
    assert!(out.inside);
    assert!(distance(out.point, [0.01, 0.015]) < 1e-15, "{:?}", out.point);
}

/// A contour over a range that does not start at 0, `x2 = x1` over `[1, 3]`: the closest point
/// to `(x, y)` is the foot `t = (x + y)/2` when it is in the range, else the nearer end (the
/// distance is convex in `t`). From `(2.8, 4)` the foot `t = 3.4` is beyond the range: the end
/// `(3, 3)`, not a point of the line outside the range. Guards the sample spacing
/// `(b − a)/(n − 1)`: with `b + a` the samples would run beyond `b`, which a range `[0, 1]`
/// cannot show. (Written for the held-out cargo-mutants survivor `n − 1` → `n + 1`, which it
/// does not kill: the bisection around the best sample finds the same point with samples
/// 1/34 of the range apart; it kills `b − a` → `b + a`, a mutant of the next shard.)
#[test]
fn a_contour_over_a_range_away_from_zero_is_closest_within_its_range() {
    let contour: Shape<f64, 4> =
        Shape::ContourFunction { function: diagonal, slope: diagonal_slope, x1_range: [1.0, 3.0] };
    let out = contour.closest_surface_point(&[2.8, 4.0]).unwrap();
    assert!(distance(out.point, [3.0, 3.0]) < 1e-12, "{:?}", out.point);
    assert!(!out.inside);
    let out = contour.closest_surface_point(&[2.0, 2.4]).unwrap();
    assert!(distance(out.point, [2.2, 2.2]) < 1e-12, "{:?}", out.point);
    let out = contour.closest_surface_point(&[1.2, -1.0]).unwrap();
    assert!(distance(out.point, [1.0, 1.0]) < 1e-12, "{:?}", out.point);
}

/// Two solid circles the HIP is equally deep in (1/4 inside each, exactly, in powers of two):
/// on an exact tie the object added first is in contact (`Scene::render`), with its gains and
/// its closest point. Guards the tie rule of the deepest-violation choice (a held-out
/// cargo-mutants survivor: `depth > d` → `>=` let the later object win ties).
#[test]
fn on_an_exact_tie_of_depths_the_first_object_is_in_contact() {
    let mut scene: Scene<f64, 2, 8> = Scene::new(200.0, 2.0, 0.0);
    for (center, stiffness) in [([0.25, 0.0], 1000.0), ([0.0, 0.25], 3000.0)] {
        scene.add(VirtualObject {
            shape: Shape::Circle { center, radius: 0.5 },
            kind: ObjectKind::Solid,
            stiffness,
            damping: 5.0,
        });
    }
    let out = scene.render(&[0.0, 0.0]);
    assert_eq!(out.contact, Some(0));
    assert_eq!(out.proxy, [-0.25, 0.0]);
    assert_eq!(out.stiffness, [1000.0; 2]);
}

/// Degenerate 2-D shapes give no point (`Shape::closest_surface_point`: "`None` for a
/// degenerate shape"): a rectangle with one half side zero or negative, and a contour whose
/// range is a single point. Guards `half₀ > 0 && half₁ > 0` and `a < b` (cargo-mutants
/// survivors of held-out shard 2/8: `&&` → `||` accepted a flat rectangle, `<` → `<=` an
/// empty range).
#[test]
fn a_flat_rectangle_and_a_point_range_contour_give_no_point() {
    for half_extents in [[0.03, 0.0], [0.0, 0.015], [0.03, -0.015]] {
        let flat: Shape<f64, 4> = Shape::Rectangle { center: [0.0, 0.0], half_extents, angle: 0.0 };
        assert!(flat.closest_surface_point(&[0.01, 0.005]).is_none(), "{half_extents:?}");
    }
    let point: Shape<f64, 4> =
        Shape::ContourFunction { function: diagonal, slope: diagonal_slope, x1_range: [0.5, 0.5] };
    assert!(point.closest_surface_point(&[0.5, 0.2]).is_none());
}

/// A convex polygon of three vertices, the fewest allowed (`ConvexPolygon`: 3 to `V`): the
/// right triangle (0, 0), (0.1, 0), (0, 0.1) queried inside near its hypotenuse, at
/// (0.04, 0.05), is closest at the foot of the perpendicular on `x + y = 0.1`,
/// (0.045, 0.055), and inside; from below, (0.03, −0.02), at (0.03, 0), outside. Guards
/// `count < 3` (a cargo-mutants survivor of held-out shard 2/8: `<=` refused triangles).
#[test]
fn a_triangle_is_a_convex_polygon() {
    let mut vertices = [[0.0; 2]; 4];
    vertices[..3].copy_from_slice(&[[0.0, 0.0], [0.1, 0.0], [0.0, 0.1]]);
    let triangle: Shape<f64, 4> = Shape::ConvexPolygon { vertices, count: 3 };
    let out = triangle.closest_surface_point(&[0.04, 0.05]).unwrap();
    assert!(out.inside);
    assert!(distance(out.point, [0.045, 0.055]) < 1e-15, "{:?}", out.point);
    let out = triangle.closest_surface_point(&[0.03, -0.02]).unwrap();
    assert!(!out.inside);
    assert!(distance(out.point, [0.03, 0.0]) < 1e-15, "{:?}", out.point);
}

/// Held-out shard 3/8's survivors in the 2-D shapes (cargo-mutants), each against values
/// worked out by hand: a point exactly on a contour is not inside (`inside` is strict; the
/// mutant `<` → `<=` counted it in); a contour table of two samples, the fewest allowed, is a
/// segment (`count < 2` → `<=` refused it); and a table's inside test uses the height of the
/// segment over the query, not another one extended (`&&` → `||` took the last segment's
/// line: for the tent 0, 1, 0 over `[0, 1]` at x1 = 0.25 that line gives 1.5 instead of 0.5).
#[test]
fn contours_on_the_curve_two_sample_tables_and_a_tent() {
    let contour: Shape<f64, 4> =
        Shape::ContourFunction { function: diagonal, slope: diagonal_slope, x1_range: [0.0, 1.0] };
    let on = contour.closest_surface_point(&[0.5, 0.5]).unwrap();
    assert!(!on.inside);
    assert!(distance(on.point, [0.5, 0.5]) < 1e-12, "{:?}", on.point);

    let mut samples = [0.0; 4];
    samples[..2].copy_from_slice(&[0.0, 1.0]);
    let segment: Shape<f64, 4> = Shape::ContourTable { samples, count: 2, x1_range: [0.0, 1.0] };
    let out = segment.closest_surface_point(&[0.6, 0.2]).unwrap();
    assert!(out.inside);
    assert!(distance(out.point, [0.4, 0.4]) < 1e-12, "{:?}", out.point);

    samples[..3].copy_from_slice(&[0.0, 1.0, 0.0]);
    let tent: Shape<f64, 4> = Shape::ContourTable { samples, count: 3, x1_range: [0.0, 1.0] };
    // Above the rising side (height 0.5 at x1 = 0.25): outside; the foot on the segment
    // (0, 0)–(0.5, 1) at t = (0.25·0.5 + 0.7·1)/1.25 = 0.66 of it, (0.33, 0.66).
    let out = tent.closest_surface_point(&[0.25, 0.7]).unwrap();
    assert!(!out.inside);
    assert!(distance(out.point, [0.33, 0.66]) < 1e-12, "{:?}", out.point);
    assert!(tent.closest_surface_point(&[0.25, 0.4]).unwrap().inside);
}

/// With two violated objects of different depths the deeper one is in contact in the 2-D
/// scene too: the HIP at the origin is 1/4 inside the first circle and 3/8 inside the second,
/// whose boundary point is (0, −0.375). (Held-out shard 3/8: `depth > d` → `<` chose the
/// shallower; only the 3-D scene's rule was tested.)
#[test]
fn the_deeper_of_two_objects_is_in_contact() {
    let mut scene: Scene<f64, 2, 8> = Scene::new(200.0, 2.0, 0.0);
    for (center, stiffness) in [([0.25, 0.0], 1000.0), ([0.0, 0.125], 3000.0)] {
        scene.add(VirtualObject {
            shape: Shape::Circle { center, radius: 0.5 },
            kind: ObjectKind::Solid,
            stiffness,
            damping: 5.0,
        });
    }
    let out = scene.render(&[0.0, 0.0]);
    assert_eq!(out.contact, Some(1));
    assert_eq!(out.proxy, [0.0, -0.375]);
    assert_eq!(out.stiffness, [3000.0; 2]);
}

/// A narrow bump of height 0.9 and half width 0.005 at `x1 = 1/4` on the floor `x2 = 0`, and a
/// wide hill of height 0.85 around `x1 = 3/4`, over `[0, 1]`: `1/4` is one of the 33 uniform
/// samples (`i/32`), so the bump's top is found. From `(1/4, 1)` the closest point is that top
/// `(1/4, 0.9)` (0.1 away; every point of the hill is at least 0.3 away). Guards the sample
/// spacing `(b − a)/(n − 1)`: samples `1/34` apart (the held-out cargo-mutants survivor `n − 1`
/// → `n + 1`) step over the bump, and the search ends on the hill.
fn bump_and_hill(t: f64) -> f64 {
    let bump = (t - 0.25) / 0.005;
    let hill = (t - 0.75) / 0.2;
    let bump = if bump.abs() < 1.0 { 0.9 * (1.0 - bump * bump) } else { 0.0 };
    let hill = if hill.abs() < 1.0 { 0.85 * (1.0 - hill * hill) } else { 0.0 };
    bump + hill
}
fn bump_and_hill_slope(t: f64) -> f64 {
    let bump = (t - 0.25) / 0.005;
    let hill = (t - 0.75) / 0.2;
    let bump = if bump.abs() < 1.0 { -0.9 * 2.0 * bump / 0.005 } else { 0.0 };
    let hill = if hill.abs() < 1.0 { -0.85 * 2.0 * hill / 0.2 } else { 0.0 };
    bump + hill
}

#[test]
fn a_narrow_bump_on_a_sample_of_a_contour_is_found() {
    let contour: Shape<f64, 4> =
        Shape::ContourFunction { function: bump_and_hill, slope: bump_and_hill_slope, x1_range: [0.0, 1.0] };
    let out = contour.closest_surface_point(&[0.25, 1.0]).unwrap();
    assert!(distance(out.point, [0.25, 0.9]) < 1e-9, "{:?}", out.point);
    assert!(!out.inside);
}

/// A narrow dip right under the query: the floor `x2 = 0` left of `x1 = 0.49` and `x2 = −0.01`
/// right of `0.51` (or the other way round), with a parabolic dip of depth 0.2 between, whose
/// bottom `x1 = 1/2` is a sample (`16/32`). From `(1/2, 0.1)` the distance is largest at the
/// bottom (gradient exactly zero there) and smallest at the rim on the higher side, `(0.49, 0)`
/// or `(0.51, 0)`, √0.0101 away (into the dip the walls fall 40 times faster than the rim
/// moves away sideways). The best sample is the neighbour on that side, `15/32` or `17/32`;
/// the minimum lies between it and the bottom, where the gradient is zero rather than of the
/// opposite sign. (Found through the held-out cargo-mutants survivor `gradient(right) > 0` →
/// `>= 0`: with the strict test the search stopped at the sample, 0.1048 away.)
fn dip(t: f64, left: f64, right: f64) -> f64 {
    let s = (t - 0.5) / 0.01;
    if s <= -1.0 {
        left
    } else if s >= 1.0 {
        right
    } else if s < 0.0 {
        -0.2 + (0.2 + left) * s * s
    } else {
        -0.2 + (0.2 + right) * s * s
    }
}
fn dip_slope(t: f64, left: f64, right: f64) -> f64 {
    let s = (t - 0.5) / 0.01;
    if s <= -1.0 || s >= 1.0 {
        0.0
    } else if s < 0.0 {
        2.0 * (0.2 + left) * s / 0.01
    } else {
        2.0 * (0.2 + right) * s / 0.01
    }
}
fn dip_higher_left(t: f64) -> f64 {
    dip(t, 0.0, -0.01)
}
fn dip_higher_left_slope(t: f64) -> f64 {
    dip_slope(t, 0.0, -0.01)
}
fn dip_higher_right(t: f64) -> f64 {
    dip(t, -0.01, 0.0)
}
fn dip_higher_right_slope(t: f64) -> f64 {
    dip_slope(t, -0.01, 0.0)
}

#[test]
fn a_contour_is_closest_at_the_rim_of_a_narrow_dip_under_the_query() {
    let query = [0.5, 0.1];
    let closest = 0.0101f64.sqrt();
    type Contour = fn(f64) -> f64;
    let cases: [(Contour, Contour, [f64; 2]); 2] = [
        (dip_higher_left, dip_higher_left_slope, [0.49, 0.0]),
        (dip_higher_right, dip_higher_right_slope, [0.51, 0.0]),
    ];
    for (function, slope, rim) in cases {
        // The set-up as described: a stationary bottom on a sample, the rim the closest.
        assert_eq!(slope(0.5), 0.0);
        assert!(distance(rim, query) < distance([15.0 / 32.0, function(15.0 / 32.0)], query));
        assert!(distance(rim, query) < distance([17.0 / 32.0, function(17.0 / 32.0)], query));
        let contour: Shape<f64, 4> = Shape::ContourFunction { function, slope, x1_range: [0.0, 1.0] };
        let out = contour.closest_surface_point(&query).unwrap();
        assert!(distance(out.point, rim) < 1e-9, "rim {rim:?}: {:?}", out.point);
        assert!((distance(out.point, query) - closest).abs() < 1e-9);
        assert!(!out.inside);
    }
}

/// A contour whose height is not a number anywhere gives no surface point ("`None` for … a
/// non-finite result", `Shape::closest_surface_point`), although the closest point's `x1` is
/// finite. (Written for the held-out cargo-mutants survivor that accepted a point with either
/// coordinate finite, shard 6/8.)
#[test]
fn a_contour_of_nan_heights_gives_no_surface_point() {
    let contour: Shape<f64, 4> =
        Shape::ContourFunction { function: |_| f64::NAN, slope: |_| 0.0, x1_range: [0.0, 1.0] };
    assert!(contour.closest_surface_point(&[0.5, 0.0]).is_none());
    let contour: Shape<f64, 4> =
        Shape::ContourFunction { function: |_| f64::INFINITY, slope: |_| 0.0, x1_range: [0.0, 1.0] };
    assert!(contour.closest_surface_point(&[0.5, 0.0]).is_none());
}

/// A HIP with one coordinate NaN or infinite and the other finite is not a HIP: the 2-D scene
/// keeps the last proxy with zero gains and no contact (`RenderOutput::valid`), for either
/// coordinate; and a circle of zero radius is degenerate: no surface point. (Written for the
/// held-out cargo-mutants survivors that accepted a HIP with one finite coordinate and a
/// circle of radius 0.)
#[test]
fn a_half_finite_hip_is_refused_and_a_zero_circle_is_degenerate() {
    let mut scene = scene_with(Shape::Circle { center: [0.1, 0.0], radius: 0.04 });
    let good = scene.render(&[0.13, 0.0]);
    assert!(good.valid && good.contact == Some(0), "{good:?}");
    for hip in [[f64::NAN, 0.0], [0.13, f64::NAN], [f64::INFINITY, 0.0], [0.13, f64::NEG_INFINITY]] {
        let out = scene.render(&hip);
        assert!(!out.valid, "{hip:?}: {out:?}");
        assert_eq!(
            (out.proxy, out.stiffness, out.damping, out.contact),
            (good.proxy, [0.0; 2], [0.0; 2], None)
        );
    }
    let point: Shape<f64, 4> = Shape::Circle { center: [0.1, 0.0], radius: 0.0 };
    assert!(point.closest_surface_point(&[0.13, 0.0]).is_none());
    assert!(point.closest_surface_point(&[0.1, 0.0]).is_none());
}
