//! The contact scenarios of `hapticgen simulate` and `hapticgen contact`: a hand (a
//! spring-damper whose other end follows a path) presses the device's task point onto solids
//! that the runtime's god object renders, and the checks made on the resulting trace.
//!
//! Every scenario is placed from the start's task position `x₀`, "down" being `−e_last` (the
//! last task axis: z for a spatial device, whose gravity usually points that way):
//!
//! | scenario | solids | the hand | checks |
//! | --- | --- | --- | --- |
//! `push` is the hand's depth into a surface (1 cm by default); every scenario also checks
//! that no joint torque was clamped (the rendering asked of the device is within its drives).
//!
//! | scenario | solids | the hand | checks |
//! | --- | --- | --- | --- |
//! | `wall` | a floor 2 cm below `x₀` (any task dimension) | presses `push` into it, holds, lets go | the proxy never inside; the held depth `d` with `K_w d = k_h (push − d)` |
//! | `slide` | the floor | presses, slides 3 cm along the first axis, lets go | never inside; the rendered force's tangential over normal part: 0 without friction, `μ_d` while sliding with it, never over `μ_s` |
//! | `sphere` | a ball of radius 3 cm, its top 1 cm below `x₀` | presses on the top, traces a circle 35° from it, `push` deep | never inside; the rendered force along the ball's normal |
//! | `box-edges` | a box 4 × 4 × 2 cm, its top 1 cm below `x₀`, a corner near `x₀` | presses onto the top `2 push` deep, slides to just inside an edge, along it to the corner, off over the corner | never inside; while the device is in the box, nearer its side than its top, the force stays up (the proxy keeps to the top; a minimum-distance rule would push it out sideways) |
//! | `thin-plate` | a plate 1 mm thick, its top 1 cm below `x₀` | pushes `3 push` below the top, through the plate's thickness | never below the top (no pop-through); the force stays up |
//! | `mesh` | a closed triangle mesh (a UV sphere, or an OBJ or STL file) its top 1 cm below `x₀` | presses on the top, circles pressed in | never inside (ray parity, every face) |
//!
//! The solids are scene objects (codegen's, as a scene file's are). The inside tests are
//! their own ([`ContactGeometry::reference_depth`]), written apart from the runtime's
//! closest-point code; the force is the renderer's spring, `K (proxy − x_h)`, whose direction
//! the proxy's offset from the HIP `x_h` gives (the device's position as its encoders measured
//! it, which the proxy was rendered for: up to a few encoder steps from where it is).

use std::path::Path;
use std::sync::Arc;

use hapticgen_codegen::mesh::TriangleMesh;

use crate::closed_loop::{Trace, PROXY_SKIN};
use crate::report::Check;
use crate::scene::{SceneObject, SceneShape};
use crate::solids::ContactGeometry;
use crate::vector::{dot, norm};

/// One of the contact scenarios (module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Contact {
    /// Press into a floor and hold.
    Wall,
    /// Press onto a floor and slide along it.
    Slide,
    /// Trace a circle on a ball.
    Sphere,
    /// Press in next to a box's edge and corner, and slide off over the corner.
    BoxEdges,
    /// Push hard through a thin plate.
    ThinPlate,
    /// Press on a triangle mesh and circle on it.
    Mesh,
}

impl Contact {
    /// Every scenario, in the report's order.
    pub const ALL: [Contact; 6] = [
        Contact::Wall,
        Contact::Slide,
        Contact::Sphere,
        Contact::BoxEdges,
        Contact::ThinPlate,
        Contact::Mesh,
    ];

    /// The scenario's name on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            Contact::Wall => "wall",
            Contact::Slide => "slide",
            Contact::Sphere => "sphere",
            Contact::BoxEdges => "box-edges",
            Contact::ThinPlate => "thin-plate",
            Contact::Mesh => "mesh",
        }
    }
}

/// What a contact scenario is made of besides its kind.
#[derive(Clone, Debug)]
pub struct ContactSettings {
    /// Surface stiffness, N/m, and damping, N·s/m.
    pub surface: (f64, f64),
    /// Static and dynamic friction coefficients of every surface.
    pub friction: (f64, f64),
    /// Hand stiffness, N/m, and damping, N·s/m.
    pub hand: (f64, f64),
    /// How far the hand's path goes into a surface, m (`box-edges` twice, `thin-plate` three
    /// times as far).
    pub push: f64,
    /// The `mesh` scenario's mesh, BVH built (`None`: a UV sphere of radius 3 cm, 960 triangles).
    pub mesh: Option<Arc<TriangleMesh>>,
}

/// A scenario placed at the start: the solids, the hand's path and how long to run.
#[derive(Clone, Debug)]
pub struct ContactSetup {
    /// The kind.
    pub contact: Contact,
    /// The solids.
    pub solids: Vec<SceneObject>,
    /// The hand's path: `(time s, position)` keys.
    pub keys: Vec<(f64, Vec<f64>)>,
    /// Simulated time, s.
    pub duration: f64,
    /// The time window of the scenario's steady part (held press, sliding, tracing), s.
    pub window: (f64, f64),
    /// The hand's stiffness, N/m.
    pub hand_stiffness: f64,
    /// How far the hand's path goes into a surface, m.
    pub push: f64,
    /// The friction coefficients.
    pub friction: (f64, f64),
    /// `true` when the solids are a scene file's, not the scenario's ([`ContactSetup::with_scene`]).
    pub from_scene: bool,
}

impl ContactSetup {
    /// The scenario's hand path and timing with `solids` (a scene file's) rendered instead of
    /// its own; its checks are then only those that hold for any scene (no fault, no torque
    /// clamped, the proxy never inside a solid).
    pub fn with_scene(self, solids: Vec<SceneObject>) -> Self {
        ContactSetup { solids, from_scene: true, ..self }
    }
}

const CM: f64 = 0.01;

/// A UV sphere of radius `radius` with 16 rings and 32 segments (960 triangles), BVH built.
pub fn uv_sphere_mesh(radius: f64) -> Result<Arc<TriangleMesh>, String> {
    Ok(Arc::new(TriangleMesh::uv_sphere(radius, 16, 32)?.with_bvh(4)))
}

/// A mesh from an OBJ or STL file, BVH built.
pub fn mesh_file(path: &Path) -> Result<Arc<TriangleMesh>, String> {
    let mesh = hapticgen_codegen::mesh::load(path).map_err(|e| format!("error: {}: {e}", path.display()))?;
    Ok(Arc::new(mesh.with_bvh(4)))
}

/// Places `contact` at the task position `x0`.
pub fn setup(contact: Contact, x0: &[f64], settings: &ContactSettings) -> Result<ContactSetup, String> {
    let m = x0.len();
    if m == 0 {
        return Err("error: a contact scenario needs a task position".into());
    }
    if contact != Contact::Wall && m != 3 {
        return Err(format!(
            "error: scenario {} needs a 3-D task space; this model's task has {m} coordinates",
            contact.name()
        ));
    }
    let last = m - 1;
    let (stiffness, damping) = settings.surface;
    let push = settings.push;
    if !(push.is_finite() && push > 0.0 && push <= 2.0 * CM) {
        return Err(format!("error: the push depth must be in (0, 2 cm], got {push} m"));
    }
    let solid = |shape| SceneObject {
        cavity: false,
        shape,
        stiffness,
        damping,
        static_friction: settings.friction.0,
        dynamic_friction: settings.friction.1,
        motion: None,
        location: format!("the {} scenario's solid", contact.name()),
    };
    let at = |offset: &[f64]| -> Vec<f64> { x0.iter().zip(offset).map(|(x, d)| x + d).collect() };
    let down = |depth: f64| -> Vec<f64> {
        let mut offset = vec![0.0; m];
        offset[last] = -depth;
        offset
    };
    let floor = || {
        let mut normal = vec![0.0; m];
        normal[last] = 1.0;
        solid(SceneShape::HalfSpace { point: at(&down(2.0 * CM)), normal })
    };
    let start = x0.to_vec();
    let mut setup = ContactSetup {
        contact,
        solids: Vec::new(),
        keys: Vec::new(),
        duration: 0.0,
        window: (0.0, 0.0),
        hand_stiffness: settings.hand.0,
        push,
        friction: settings.friction,
        from_scene: false,
    };
    match contact {
        Contact::Wall => {
            // Rest, press into the floor within 1 s, hold 2 s, let go.
            let pressed = at(&down(2.0 * CM + push));
            setup.solids = vec![floor()];
            setup.keys = press_and_hold(start, pressed, 3.3);
            setup.duration = 4.8;
            setup.window = (2.3, 3.3);
        }
        Contact::Slide => {
            let pressed = at(&down(2.0 * CM + push));
            let mut slid = pressed.clone();
            slid[0] += 3.0 * CM;
            setup.solids = vec![floor()];
            setup.keys = vec![
                (0.0, start.clone()),
                (0.3, start.clone()),
                (1.3, pressed.clone()),
                (1.8, pressed),
                (3.8, slid.clone()),
                (4.3, slid),
                (5.3, start),
            ];
            setup.duration = 5.8;
            // Sliding at a steady 1.5 cm/s, after the proxy has broken away.
            setup.window = (2.3, 3.8);
        }
        Contact::Sphere | Contact::Mesh => {
            let radius = 3.0 * CM;
            let (shape, top, centre, circle) = match (contact, &settings.mesh) {
                (Contact::Mesh, Some(mesh)) => {
                    // The mesh's bounding box: its top 1 cm below the start, centred under it.
                    let (low, high) = bounds(mesh);
                    let offset: Vec<f64> = vec![
                        x0[0] - 0.5 * (low[0] + high[0]),
                        x0[1] - 0.5 * (low[1] + high[1]),
                        x0[2] - CM - high[2],
                    ];
                    let half_width = 0.5 * (high[0] - low[0]).min(high[1] - low[1]);
                    let centre = vec![x0[0], x0[1], x0[2] - CM - 0.5 * (high[2] - low[2])];
                    (SceneShape::Mesh { mesh: mesh.clone(), offset }, x0[2] - CM, centre, 0.4 * half_width)
                }
                (Contact::Mesh, None) => {
                    let centre = at(&down(radius + CM));
                    (
                        SceneShape::Mesh { mesh: uv_sphere_mesh(radius)?, offset: centre.clone() },
                        x0[2] - CM,
                        centre,
                        radius * 35f64.to_radians().sin(),
                    )
                }
                _ => {
                    let centre = at(&down(radius + CM));
                    (
                        SceneShape::Sphere { center: centre.clone(), radius },
                        x0[2] - CM,
                        centre,
                        radius * 35f64.to_radians().sin(),
                    )
                }
            };
            setup.solids = vec![solid(shape)];
            // Pressed 1 cm in along the way to the centre (on the ball: radially; on a mesh:
            // straight down from a circle of `circle` around the top).
            let pressed_towards_centre = |angle: f64| -> Vec<f64> {
                let surface = if contact == Contact::Sphere {
                    let polar = (circle / radius).asin();
                    vec![
                        centre[0] + radius * polar.sin() * angle.cos(),
                        centre[1] + radius * polar.sin() * angle.sin(),
                        centre[2] + radius * polar.cos(),
                    ]
                } else {
                    vec![centre[0] + circle * angle.cos(), centre[1] + circle * angle.sin(), top]
                };
                let towards: Vec<f64> = centre.iter().zip(&surface).map(|(c, s)| c - s).collect();
                let length = norm(&towards).max(1e-12);
                let direction: Vec<f64> = if contact == Contact::Sphere {
                    towards.iter().map(|v| v / length).collect()
                } else {
                    vec![0.0, 0.0, -1.0]
                };
                surface.iter().zip(&direction).map(|(s, d)| s + push * d).collect()
            };
            let mut keys = vec![(0.0, start.clone()), (0.3, start.clone()), (1.3, at(&down(CM + push)))];
            keys.push((2.3, pressed_towards_centre(0.0)));
            for step in 1..=48 {
                let angle = std::f64::consts::TAU * f64::from(step) / 48.0;
                keys.push((2.3 + 4.0 * f64::from(step) / 48.0, pressed_towards_centre(angle)));
            }
            keys.push((6.8, at(&down(CM + push))));
            keys.push((7.8, start));
            setup.keys = keys;
            setup.duration = 8.3;
            setup.window = (2.5, 6.3);
        }
        Contact::BoxEdges => {
            // A box 4 × 4 × 2 cm, its top 1 cm below the start, its +x, +y corner 5 mm beyond the
            // start in x and y. The hand presses onto the top 5 mm inside the +x edge, twice as
            // deep as elsewhere, slides to `gap` inside the edge, along it to `gap` inside the
            // corner, and off over the corner. `gap` is 0.6 times the depth the device settles
            // at, so that there the side is nearer than the top: a minimum-distance rule would
            // push the device out sideways, the god object keeps it on the top it came from.
            let half = [2.0 * CM, 2.0 * CM, CM];
            let (edge_x, edge_y, top) = (x0[0] + 0.5 * CM, x0[1] + 0.5 * CM, x0[2] - CM);
            let centre = vec![edge_x - half[0], edge_y - half[1], top - half[2]];
            setup.solids = vec![solid(SceneShape::axis_aligned_box(centre, half.to_vec()))];
            let depth = 2.0 * push * settings.hand.0 / (stiffness + settings.hand.0);
            let gap = 0.6 * depth;
            let pressed = top - 2.0 * push;
            let inside_edge = vec![edge_x - gap, x0[1] - CM, pressed];
            let inside_corner = vec![edge_x - gap, edge_y - gap, pressed];
            let beyond_corner = vec![edge_x + CM, edge_y + CM, pressed];
            setup.keys = vec![
                (0.0, start.clone()),
                (0.3, start.clone()),
                (1.3, vec![edge_x - 0.5 * CM, x0[1] - CM, pressed]),
                (2.3, inside_edge.clone()),
                (2.8, inside_edge),
                (3.6, inside_corner.clone()),
                (4.4, inside_corner),
                (5.4, beyond_corner.clone()),
                (5.9, beyond_corner),
                (6.9, start),
            ];
            setup.duration = 7.4;
            setup.window = (2.3, 4.4);
        }
        Contact::ThinPlate => {
            let half = [5.0 * CM, 5.0 * CM, 0.05 * CM];
            let top = x0[2] - CM;
            let centre = vec![x0[0], x0[1], top - half[2]];
            setup.solids = vec![solid(SceneShape::axis_aligned_box(centre, half.to_vec()))];
            let through = at(&down(CM + 3.0 * push));
            setup.keys = press_and_hold(start, through, 2.3);
            setup.duration = 3.8;
            setup.window = (1.3, 2.3);
        }
    }
    Ok(setup)
}

/// The hand's path of a press: at `start` for 0.3 s, at `pressed` 1 s later, held there until
/// `held`, back at `start` 1 s after that.
fn press_and_hold(start: Vec<f64>, pressed: Vec<f64>, held: f64) -> Vec<(f64, Vec<f64>)> {
    vec![
        (0.0, start.clone()),
        (0.3, start.clone()),
        (1.3, pressed.clone()),
        (held, pressed),
        (held + 1.0, start),
    ]
}

fn bounds(mesh: &TriangleMesh) -> ([f64; 3], [f64; 3]) {
    mesh.vertices.iter().fold(([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]), |(low, high), v| {
        (std::array::from_fn(|k| low[k].min(v[k])), std::array::from_fn(|k| high[k].max(v[k])))
    })
}

/// The samples of a trace as rows of named columns.
struct Samples<'a> {
    trace: &'a Trace,
    time: usize,
    device: Vec<usize>,
    proxy: Vec<usize>,
    hip: Vec<usize>,
    rendered_at: usize,
}

impl<'a> Samples<'a> {
    fn new(trace: &'a Trace) -> Option<Self> {
        let index = |name: &str| trace.columns.iter().position(|c| c == name);
        let task = trace.task_dim;
        Some(Samples {
            trace,
            time: index("t")?,
            device: (0..task).map(|k| index(&format!("x{k}"))).collect::<Option<_>>()?,
            proxy: (0..task).map(|k| index(&format!("xp{k}"))).collect::<Option<_>>()?,
            hip: (0..task).map(|k| index(&format!("xh{k}"))).collect::<Option<_>>()?,
            rendered_at: index("tr")?,
        })
    }

    /// Every sample of the trace.
    fn rows(&self) -> impl Iterator<Item = Sample> + '_ {
        let pick = |row: &Vec<f64>, columns: &[usize]| columns.iter().map(|&k| row[k]).collect::<Vec<f64>>();
        self.trace.rows.iter().map(move |row| Sample {
            t: row[self.time],
            device: pick(row, &self.device),
            proxy: pick(row, &self.proxy),
            hip: pick(row, &self.hip),
            rendered_at: row[self.rendered_at],
        })
    }
}

/// One sample: the device where it is, the proxy, and the device where the controller measured
/// it (the HIP, encoder steps apart), which the proxy was rendered for.
struct Sample {
    t: f64,
    device: Vec<f64>,
    proxy: Vec<f64>,
    hip: Vec<f64>,
    /// When the proxy was rendered (moving solids were where their motion had them then).
    rendered_at: f64,
}

fn degrees_between(a: &[f64], b: &[f64]) -> f64 {
    let cosine = dot(a, b) / (norm(a) * norm(b)).max(1e-300);
    cosine.clamp(-1.0, 1.0).acos().to_degrees()
}

/// Proxy offsets under this, m, count as no contact (the skin, encoder steps).
const CONTACT: f64 = 2e-4;

/// What a bound on the samples in contact measured when there were none (the row fails).
const NO_SAMPLE: &str = "no sample in contact";

/// The scenario's checks on `trace`, named after `experiment`.
pub fn checks(setup: &ContactSetup, trace: &Trace, experiment: &str) -> Vec<Check> {
    let mut checks = Vec::new();
    let mut check = |criterion: &str, expected: String, measured: String, pass: bool| {
        checks.push(Check {
            experiment: experiment.into(),
            criterion: criterion.into(),
            expected,
            measured,
            pass,
        });
    };
    let Some(samples) = Samples::new(trace) else {
        check("trace", "columns t, x*, xp*, xh*, tr".into(), "missing".into(), false);
        return checks;
    };
    if let Some((t, fault)) = &trace.fault {
        check("no fault latched", "none".into(), format!("{fault} at t = {t:.3} s"), false);
    }
    // A clamped torque renders less than the law asks: the other checks would measure the
    // drives' limits, not the rendering.
    check(
        "joint torques within the drives' limits",
        "clamped on 0 % of impedance ticks".into(),
        format!("{:.1} %", 100.0 * trace.saturation_fraction()),
        trace.clamped_ticks == 0,
    );
    // The proxy never inside a solid (a tolerance of a nanometre for rounding), a moving one
    // taken where it was when the proxy was rendered.
    let deepest = samples
        .rows()
        .filter(|sample| sample.rendered_at.is_finite())
        .flat_map(|sample| {
            setup
                .solids
                .iter()
                .map(|s| s.reference_depth_at(&sample.proxy, sample.rendered_at))
                .collect::<Vec<_>>()
        })
        .fold(f64::NEG_INFINITY, f64::max);
    check(
        "the proxy never inside a solid",
        "depth ≤ 1 nm".into(),
        if setup.solids.is_empty() {
            "no solid in the scene".to_string()
        } else {
            format!(
                "deepest {:.3} µm {}",
                1e6 * deepest.abs(),
                if deepest > 0.0 { "inside" } else { "outside" }
            )
        },
        deepest <= 1e-9,
    );
    // A scene nothing touched checks nothing (a scene written in millimetres is metres away):
    // some sample must have the HIP inside a solid, taken where it was when rendered. (The
    // scenarios' own solids, placed where the hand presses, have their own checks of contact.)
    if setup.from_scene && !setup.solids.is_empty() {
        let touching = samples
            .rows()
            .filter(|sample| {
                sample.rendered_at.is_finite()
                    && setup
                        .solids
                        .iter()
                        .any(|s| s.reference_depth_at(&sample.hip, sample.rendered_at) > 0.0)
            })
            .count();
        check(
            "some sample in contact with a solid",
            "at least 1 sample".into(),
            if touching == 0 {
                format!("{NO_SAMPLE} (are the solids where the device reaches, in metres?)")
            } else {
                format!("{touching} of {} samples", trace.rows.len())
            },
            touching > 0,
        );
    }
    // The other checks are about the scenario's own solids.
    if setup.from_scene {
        return checks;
    }
    let window: Vec<Sample> =
        samples.rows().filter(|s| (setup.window.0..=setup.window.1).contains(&s.t)).collect();
    if window.is_empty() {
        check("samples in the scenario's window", "some".into(), "none".into(), false);
        return checks;
    }
    let last = trace.task_dim - 1;
    // The rendered spring force K (proxy − HIP) per sample, by its offset.
    let offsets: Vec<Vec<f64>> =
        window.iter().map(|s| s.proxy.iter().zip(&s.hip).map(|(p, h)| p - h).collect()).collect();
    let in_contact = offsets.iter().filter(|o| norm(o) > CONTACT).count();
    match setup.contact {
        Contact::Wall => {
            let (stiffness, hand) = (setup.solids[0].stiffness, setup.hand_stiffness);
            let expected = hand * setup.push / (stiffness + hand);
            let depths: Vec<f64> =
                window.iter().map(|s| setup.solids[0].reference_depth(&s.device)).collect();
            let mean = depths.iter().sum::<f64>() / depths.len() as f64;
            check(
                "held depth: wall spring balances the hand's, K_w d = k_h (push − d)",
                format!("{:.3} mm ± 3 %", 1e3 * expected),
                format!("{:.3} mm", 1e3 * mean),
                (mean - expected).abs() <= 0.03 * expected,
            );
        }
        Contact::Slide => {
            let pressed: Vec<&Vec<f64>> = offsets.iter().filter(|o| o[last].abs() > CONTACT).collect();
            let ratios: Vec<f64> = pressed.iter().map(|o| norm(&o[..last]) / o[last].abs()).collect();
            // Frictionless, the proxy is the HIP's projection on the floor up to the god
            // object's skin: it ends a move shorter than that, so it may trail the HIP by it.
            let tangential = pressed.iter().map(|o| norm(&o[..last])).fold(0.0, f64::max);
            let mean = ratios.iter().sum::<f64>() / ratios.len().max(1) as f64;
            let largest = ratios.iter().copied().fold(0.0, f64::max);
            let (static_friction, dynamic_friction) = setup.friction;
            check(
                "in contact while sliding",
                "every sample".into(),
                format!("{} of {}", ratios.len(), window.len()),
                ratios.len() == window.len(),
            );
            // A bound on the samples in contact holds of none: with none, the row fails.
            if dynamic_friction == 0.0 {
                check(
                    "frictionless: the proxy over the HIP while sliding (tangential force offset)",
                    format!("≤ the proxy's skin, {:.1} µm", 1e6 * PROXY_SKIN),
                    if ratios.is_empty() {
                        NO_SAMPLE.into()
                    } else {
                        format!(
                            "largest {:.3} µm (tangential over normal force: mean {mean:.2e}, largest {largest:.2e})",
                            1e6 * tangential
                        )
                    },
                    !ratios.is_empty() && tangential <= PROXY_SKIN,
                );
            } else {
                check(
                    "friction: tangential over normal force while sliding, mean",
                    format!("μ_d = {dynamic_friction} ± 10 %"),
                    format!("{mean:.4}"),
                    (mean - dynamic_friction).abs() <= 0.1 * dynamic_friction,
                );
                check(
                    "friction: never outside the static cone",
                    format!("≤ μ_s = {static_friction}"),
                    if ratios.is_empty() { NO_SAMPLE.into() } else { format!("largest {largest:.4}") },
                    !ratios.is_empty() && largest <= static_friction * (1.0 + 1e-9) + 1e-6,
                );
            }
        }
        Contact::Sphere | Contact::Mesh => {
            check(
                "in contact along the circle",
                "≥ 95 % of samples".into(),
                format!("{:.1} %", 100.0 * in_contact as f64 / window.len() as f64),
                in_contact as f64 >= 0.95 * window.len() as f64,
            );
            if setup.contact == Contact::Sphere {
                let angles: Vec<f64> = window
                    .iter()
                    .zip(&offsets)
                    .filter(|(_, o)| norm(o) > CONTACT)
                    .filter_map(|(s, o)| {
                        setup.solids[0].outward_normal(&s.proxy).map(|n| degrees_between(o, &n))
                    })
                    .collect();
                let worst = angles.iter().copied().fold(0.0, f64::max);
                check(
                    "the force along the ball's normal at the proxy",
                    "within 0.5°".into(),
                    if angles.is_empty() { NO_SAMPLE.into() } else { format!("largest {worst:.3}°") },
                    !angles.is_empty() && worst <= 0.5,
                );
            }
        }
        Contact::BoxEdges | Contact::ThinPlate => {
            // Wherever the device is inside the solid, the force points up (the proxy kept to
            // the top face it came from).
            let mut up = vec![0.0; trace.task_dim];
            up[last] = 1.0;
            // The plate is thinner than the device sinks: below its top is what counts there.
            let pushed_in = |x: &[f64]| match (&setup.solids[0].shape, setup.contact) {
                (SceneShape::Box { center, half_extents, .. }, Contact::ThinPlate) => {
                    x[last] < center[last] + half_extents[last]
                }
                _ => setup.solids[0].reference_depth(x) > 0.0,
            };
            let pressed: Vec<f64> = window
                .iter()
                .zip(&offsets)
                .filter(|(s, o)| pushed_in(&s.device) && norm(o) > CONTACT)
                .map(|(_, o)| degrees_between(o, &up))
                .collect();
            let worst = pressed.iter().copied().fold(0.0, f64::max);
            let what = if setup.contact == Contact::ThinPlate {
                "pushed through the plate"
            } else {
                "pressed in next to an edge and a corner"
            };
            check(
                &format!("{what}: the device in it"),
                "most samples".into(),
                format!("{} of {}", pressed.len(), window.len()),
                pressed.len() * 2 > window.len(),
            );
            check(
                &format!("{what}: the force up"),
                "within 0.5°".into(),
                if pressed.is_empty() { NO_SAMPLE.into() } else { format!("largest {worst:.3}°") },
                !pressed.is_empty() && worst <= 0.5,
            );
        }
    }
    checks
}
