//! The scenarios a variant can name in `targets/firmware/variants.txt`. Each module offers
//! `Source<R, N, M>` (the reference source its controller runs: a fixed reference or a
//! renderer), `Run<R, N, M>` (the scenario type for a rig `R` with `N` joints and `M` task
//! coordinates) and `new(name, rig, setup, sense_time_constant, profile)`; `new` states which
//! `N`, `M` it accepts (a line that pairs a scenario with an unsuitable rig does not compile).
//! Every run starts at rest at the `pose` of its line, with the image's model-derived
//! [`Setup`] (the same a board image gets) and the simulated current sense's time constant.

use hapticgen_fw_control::{Controller, Setup};
use hapticgen_runtime::control::{ControlOptions, ImpedanceController, ImpedanceLaw, ImpedanceParameters};
use hapticgen_runtime::estimation::{EstimatorSettings, ForceSensorCalibration};
use hapticgen_runtime::fused::FusedImpedance;
use hapticgen_runtime::tick::{HapticLoopSettings, ReferenceSource};
use hapticgen_runtime::{Real, RigModel};

use crate::plant::SimBoard;
use crate::scenario::{current_tolerance, trace_tolerance, Load, Scenario};

fn s<S: Real>(value: f64) -> S {
    S::from_f64(value)
}

/// Rendering parameters when the model has no `rendering:` section: the paper's Fig. 7 values
/// (grid 0.3 mm, walls and free space 1500 N/m and 5 N·s/m).
pub const PAPER_RENDERING: [f64; 3] = [0.3e-3, 1500.0, 5.0];

fn rendering<S: Real, const N: usize>(setup: &Setup<S, N>) -> [S; 3] {
    setup.rendering.unwrap_or([s(PAPER_RENDERING[0]), s(PAPER_RENDERING[1]), s(PAPER_RENDERING[2])])
}

/// Controller 3 (`a_q = 0`, no `J⁻¹`: any `N`, `M`) with `K_d`, `B_d` on every task axis.
fn jacobian_transpose<S: Real, const M: usize>(
    stiffness: S,
    damping: S,
    omit_damping_compensation: bool,
) -> ImpedanceController<S, M> {
    ImpedanceController {
        law: ImpedanceLaw::JacobianTranspose,
        parameters: ImpedanceParameters {
            stiffness: [stiffness; M],
            damping: [damping; M],
            mass: [S::ONE; M],
        },
        options: ControlOptions {
            omit_damping_compensation,
            min_abs_jacobian_determinant: s(1e-6),
            spring_lead_time: s(0.0),
            friction_compensation_band: None,
        },
    }
}

/// The firmware controller for `rig` at the line's pose, with each joint's own current-loop
/// gains.
fn controller<R, Src, const N: usize, const M: usize>(
    rig: R,
    source: Src,
    law: ImpedanceController<R::Scalar, M>,
    setup: &Setup<R::Scalar, N>,
    profile: bool,
) -> Option<Controller<R, Src, N, M>>
where
    R: FusedImpedance<N, M> + Clone,
    Src: ReferenceSource<R::Scalar, M> + Clone,
{
    let settings = HapticLoopSettings {
        controller: law,
        estimator: EstimatorSettings {
            sample_period: R::Scalar::ONE / s(f64::from(R::IMPEDANCE_LOOP_HZ)),
            velocity_cutoff_hz: s(50.0),
            acceleration_cutoff_hz: s(20.0),
        },
        zero_offset: setup.start,
        initial_counts: [0; N],
        force_calibration: ForceSensorCalibration {
            scale: [R::Scalar::ONE; M],
            offset: [R::Scalar::ZERO; M],
        },
        current_gains: setup.current_gains,
        max_tick_gap: 1,
    };
    Controller::new(rig, source, &settings, profile)
}

/// The simulated board at rest at the line's pose, stepped at the current-loop rate, its
/// current sensed through a lag of `sense_time_constant` s (the model's anti-aliasing filter
/// as the current-loop design approximates it).
fn board<R: RigModel<N, M> + Clone, const N: usize, const M: usize>(
    rig: &R,
    setup: &Setup<R::Scalar, N>,
    sense_time_constant: R::Scalar,
) -> SimBoard<R, N, M> {
    let period = R::Scalar::ONE / s(f64::from(R::CURRENT_LOOP_HZ));
    SimBoard::new(rig.clone(), setup.start, period, sense_time_constant)
}

/// The paper's Fig. 4 on a 1-DOF rig: Controller 2, second variant (`M_d = W⁻¹`),
/// `K_d = 1 N·m/rad`, `B_d = 0.01 N·m·s/rad`, reference at the start pose (upright for the
/// joystick's line), a 1 N·m step of operator torque at 0.1 s held to the end of the 2 s run.
/// The closed loop is `D q̈ + B_d q̇ + K_d q = τ_op`: a lightly damped (ζ ≈ 0.09) 2.9 Hz
/// oscillation settling at 1 rad.
pub mod fig4_step {
    use super::*;
    use hapticgen_runtime::control::TaskReference;

    /// The reference source: fixed at the start.
    pub type Source<R, const N: usize, const M: usize> = TaskReference<<R as RigModel<N, M>>::Scalar, M>;

    /// The scenario type for a rig `R` (`N = M = 1`).
    pub type Run<R, const N: usize, const M: usize> = Scenario<R, Source<R, N, M>, N, M>;

    /// Builds the run; `None` if the rig's rates are unusable.
    pub fn new<R: FusedImpedance<1, 1> + Clone>(
        name: &'static str,
        rig: R,
        setup: &Setup<R::Scalar, 1>,
        sense_time_constant: R::Scalar,
        profile: bool,
    ) -> Option<Run<R, 1, 1>> {
        let law = ImpedanceController {
            law: ImpedanceLaw::NaturalInertia,
            parameters: ImpedanceParameters {
                stiffness: [s(1.0)],
                damping: [s(0.01)],
                mass: [R::Scalar::ONE],
            },
            options: ControlOptions {
                omit_damping_compensation: false,
                min_abs_jacobian_determinant: s(1e-6),
                spring_lead_time: s(0.0),
                friction_compensation_band: None,
            },
        };
        let fast = R::CURRENT_LOOP_HZ;
        let board = board(&rig, setup, sense_time_constant);
        let reference = TaskReference::at_rest(rig.position(&setup.start));
        let controller = controller(rig, reference, law, setup, profile)?;
        let load = Load { start: fast / 10, end: u32::MAX, force: [s(1.0)] };
        let tolerance = trace_tolerance(board.rig(), &setup.start, R::Scalar::ZERO);
        let mut run = Scenario::new(name, controller, board, load, 2 * fast, fast / 100);
        run.task_tolerance = tolerance;
        run.current_tolerance = current_tolerance(run.board.rig(), &setup.start, s(1.0), tolerance);
        Some(run)
    }
}

/// A spring in joint space for a rig whose task is its joint coordinates (`task: {joints}`,
/// any `N = M`), such as a wrist: Controller 3 holds the start with the model's rendering
/// stiffness and damping on every axis, and the operator twists the last axis by
/// [`SHARE`](joint_spring::SHARE) of that stiffness (a torque that settles at 0.1 rad) from
/// 0.1 s to 1.0 s, then lets go; 1.5 s in all. On a coupled rig (a differential) the last axis
/// takes both drives turning against each other, the others standing still.
pub mod joint_spring {
    use super::*;
    use hapticgen_runtime::control::TaskReference;

    /// The twist over the stiffness, rad: where the twisted axis settles.
    pub const SHARE: f64 = 0.1;

    /// The reference source: fixed at the start.
    pub type Source<R, const N: usize, const M: usize> = TaskReference<<R as RigModel<N, M>>::Scalar, M>;

    /// The scenario type for a rig `R`.
    pub type Run<R, const N: usize, const M: usize> = Scenario<R, Source<R, N, M>, N, M>;

    /// Builds the run; `None` if the rig's rates are unusable or `M = 0`.
    pub fn new<R: FusedImpedance<N, M> + Clone, const N: usize, const M: usize>(
        name: &'static str,
        rig: R,
        setup: &Setup<R::Scalar, N>,
        sense_time_constant: R::Scalar,
        profile: bool,
    ) -> Option<Run<R, N, M>> {
        let [_, stiffness, damping] = rendering(setup);
        let reference = TaskReference::at_rest(rig.position(&setup.start));
        let mut twist = [R::Scalar::ZERO; M];
        *twist.last_mut()? = s::<R::Scalar>(SHARE) * stiffness;
        pushed_run(
            name,
            rig,
            setup,
            sense_time_constant,
            profile,
            reference,
            [stiffness, damping, R::Scalar::ZERO],
            twist,
        )
    }
}

/// A virtual wall for a planar task (`M = 2`, any number of joints) with Controller 3 and the
/// runtime's proxy renderer: the task point starts in free space at the line's pose, a solid
/// wall's face [`WALL`](wall_contact::WALL) (5 mm) to its +x1 side; the operator pushes along
/// +x1 from 0.1 s to 1.0 s, then lets go; 1.5 s in all. The push is
/// [`FORCE`](wall_contact::FORCE) (2 N), or less on a rig whose drives cannot hold that
/// much at the start pose: see [`push`](wall_contact::push). `K_d`, `B_d` of the wall and of
/// free space and the anti-drift grid come from the model's `rendering:` section (1500 N/m,
/// 5 N·s/m, 0.3 mm for the paper's rig), else [`PAPER_RENDERING`]. Penetration settles at
/// push / `K_d`.
pub mod wall_contact {
    use super::*;
    use hapticgen_runtime::render::{ObjectKind, Scene, Shape, VirtualObject};

    /// The operator's push, N, on a rig strong enough for it (the paper's rigs, the planar arm).
    pub const FORCE: f64 = 2.0;
    /// Distance from the start to the wall's face, m.
    pub const WALL: f64 = 0.005;
    /// The share of the drives' force capacity along +x1 at the start (see [`push`]) that
    /// the push may take.
    pub const CAPACITY_SHARE: f64 = 0.6;

    /// The push along +x1 for `rig` at `q0`, N: [`FORCE`], or [`CAPACITY_SHARE`] of the force
    /// the drives can hold along +x1 at `q0` after holding up the rig's weight, whichever is
    /// less. Capacity: `min_j (τ_max,j − |g_j(q0)|) / |J_1j(q0)|`, with
    /// `τ_max,j = min(torque_limit, N η k_t current_limit)` (the safety monitor's clamp). The
    /// impact after the 5 mm approach briefly asks for several times the push (the energy
    /// bound of the wall test: `F + √(F² + 2 K F d)`, 7.8 N for 2 N), and a drive that
    /// saturates there makes the wall soft and lets the point through; a small direct-drive
    /// device (the pantograph, 0.12 N·m motors: 2.2 N along x) gets a push it can render.
    pub fn push<R: RigModel<N, 2>, const N: usize>(rig: &R, q0: &[R::Scalar; N]) -> R::Scalar {
        let jacobian = rig.jacobian(q0);
        let gravity = rig.gravity(q0);
        let mut capacity: Option<R::Scalar> = None;
        for (j, drive) in rig.drives().iter().enumerate() {
            let lever = jacobian[0][j].abs();
            if lever <= R::Scalar::ZERO {
                continue;
            }
            let from_current =
                drive.gear_ratio * drive.efficiency * drive.torque_constant * drive.current_limit;
            let spare = (drive.torque_limit.min(from_current) - gravity[j].abs()).max(R::Scalar::ZERO);
            let here = spare / lever;
            capacity = Some(capacity.map_or(here, |c| c.min(here)));
        }
        let force = s::<R::Scalar>(FORCE);
        match capacity {
            Some(c) => force.min(s::<R::Scalar>(CAPACITY_SHARE) * c),
            None => force,
        }
    }

    /// The reference source: the runtime's planar proxy renderer with one object.
    pub type Source<R, const N: usize, const M: usize> = Scene<<R as RigModel<N, M>>::Scalar, 1, 1>;

    /// The scenario type for a rig `R` (`M = 2`).
    pub type Run<R, const N: usize, const M: usize> = Scenario<R, Source<R, N, M>, N, M>;

    /// Builds the run; `None` if the rig's rates are unusable.
    pub fn new<R: FusedImpedance<N, 2> + Clone, const N: usize>(
        name: &'static str,
        rig: R,
        setup: &Setup<R::Scalar, N>,
        sense_time_constant: R::Scalar,
        profile: bool,
    ) -> Option<Run<R, N, 2>> {
        let [grid, wall_stiffness, wall_damping] = rendering(setup);
        let start = rig.position(&setup.start);
        let mut scene = Scene::new(wall_stiffness, wall_damping, grid);
        let half = [s(0.05), s(0.1)];
        scene.add(VirtualObject {
            shape: Shape::Rectangle {
                center: [start[0] + s(WALL) + half[0], start[1]],
                half_extents: half,
                angle: R::Scalar::ZERO,
            },
            kind: ObjectKind::Solid,
            stiffness: wall_stiffness,
            damping: wall_damping,
        })?;
        let force = [push(&rig, &setup.start), R::Scalar::ZERO];
        // Two grid spacings: on the rebound after the operator lets go, each run snaps the
        // proxy through its own sequence of grid nodes (a discontinuous, path-dependent map),
        // so the runs can differ by a node at the moment of a jump and by a node at rest.
        let rendering = [wall_stiffness, wall_damping, grid + grid];
        pushed_run(name, rig, setup, sense_time_constant, profile, scene, rendering, force)
    }
}

/// A spherical cavity for a spatial task (`M = 3`, any number of joints) with Controller 3
/// and the runtime's `M`-dimensional renderer (`hapticgen_runtime::spatial`, the paper's
/// minimum-distance rule): the task point starts
/// at rest at the centre of a 10 mm-radius cavity; the operator pushes with 1 N along the
/// oblique direction `(2, 1, 2)/3` (forward, sideways and up: the arm's gravity load and the
/// push do not add up beyond the drives' current limit) from 0.1 s to 1.0 s (through free space on the anti-drift
/// grid, then against the curved wall, where the proxy is the sphere's closest point and the
/// point settles 1 N / `K_d` beyond the wall along the push: a stable equilibrium, the
/// inside of a sphere being concave), then lets go; 1.5 s in all. Exercises all three task
/// axes, gravity and the coupling of every joint. Gains and grid as in [`wall_contact`].
pub mod sphere_cavity {
    use super::*;
    use hapticgen_runtime::render::ObjectKind;
    use hapticgen_runtime::shape::{Material, Object, Shape};
    use hapticgen_runtime::spatial::MinDistanceScene;

    /// Radius of the cavity, m.
    pub const RADIUS: f64 = 0.010;
    /// Operator force, N, along `(2, 1, 2)/3`.
    pub const FORCE: f64 = 1.0;

    /// The reference source: the `M`-dimensional renderer with one object.
    pub type Source<R, const N: usize, const M: usize> =
        MinDistanceScene<'static, <R as RigModel<N, M>>::Scalar, 1, M>;

    /// The scenario type for a rig `R` (`M = 3`).
    pub type Run<R, const N: usize, const M: usize> = Scenario<R, Source<R, N, M>, N, M>;

    /// Builds the run; `None` if the rig's rates are unusable.
    pub fn new<R: FusedImpedance<N, 3> + Clone, const N: usize>(
        name: &'static str,
        rig: R,
        setup: &Setup<R::Scalar, N>,
        sense_time_constant: R::Scalar,
        profile: bool,
    ) -> Option<Run<R, N, 3>> {
        let [grid, wall_stiffness, wall_damping] = rendering(setup);
        let start = rig.position(&setup.start);
        let mut scene = MinDistanceScene::new(wall_stiffness, wall_damping, grid);
        scene.add(Object {
            shape: Shape::Sphere { center: start, radius: s(RADIUS) },
            kind: ObjectKind::Cavity,
            material: Material::frictionless(wall_stiffness, wall_damping),
        })?;
        // As for the wall: the free-space proxy may rest one node apart in each run.
        let rendering = [wall_stiffness, wall_damping, grid + grid];
        pushed_run(name, rig, setup, sense_time_constant, profile, scene, rendering, along_221(FORCE))
    }
}

/// `sphere_cavity` with a stylus on a gimbal of three measured joints (the PHANToM Premium-like
/// arm): each impedance tick the firmware reads the gimbal's encoders into the stylus's
/// orientation ([`Stylus`](hapticgen_fw_control::stylus::Stylus), with the rig's generated
/// `MEASURED_JOINTS` and `<frame>_orientation`), while the operator turns the stylus, each
/// joint along a sine over 80 % of its range ([`SimGimbal`](crate::gimbal::SimGimbal)); at the
/// reads [`GLITCH_READS`] one counter reads far out of range, which must be refused. The run
/// reports the reads, the refusals and the largest angle between a read orientation and the
/// true one (`STYLUS`), and the read's cost (`COST stylus`).
pub mod stylus_cavity {
    use super::*;
    use crate::gimbal::SimGimbal;
    use crate::scenario::{StylusRun, GIMBAL_JOINTS};
    use hapticgen_fw_control::stylus::{OrientationFn, Stylus};
    use hapticgen_runtime::measured::MeasuredJoint;

    /// The reads (0-based) at which a counter glitches: roll, pitch, then spin (1,500 reads in
    /// the run).
    pub const GLITCH_READS: [u32; 3] = [300, 700, 1100];

    /// The reference source: `sphere_cavity`'s.
    pub type Source<R, const N: usize, const M: usize> = sphere_cavity::Source<R, N, M>;

    /// The scenario type for a rig `R` (`M = 3`).
    pub type Run<R, const N: usize, const M: usize> =
        Scenario<R, Source<R, N, M>, N, M, StylusRun<<R as RigModel<N, M>>::Scalar, N>>;

    /// Builds the run with the gimbal's `joints` and the stylus frame's `orientation_of`;
    /// `None` if the rig's rates are unusable.
    pub fn new<R: FusedImpedance<N, 3> + Clone, const N: usize>(
        name: &'static str,
        rig: R,
        setup: &Setup<R::Scalar, N>,
        sense_time_constant: R::Scalar,
        profile: bool,
        joints: [MeasuredJoint<R::Scalar>; GIMBAL_JOINTS],
        orientation_of: OrientationFn<R::Scalar, N, GIMBAL_JOINTS>,
    ) -> Option<Run<R, N, 3>> {
        let run = sphere_cavity::new(name, rig, setup, sense_time_constant, profile)?;
        let period = R::Scalar::ONE / R::Scalar::from_f64(f64::from(R::CURRENT_LOOP_HZ));
        let run = run.with(StylusRun {
            gimbal: SimGimbal::new(joints, period, &GLITCH_READS),
            stylus: Stylus::new(joints),
            orientation_of,
            max_error: R::Scalar::ZERO,
            count_lag: (i64::MAX, i64::MIN),
        });
        Some(run)
    }
}

/// The run of the contact scenarios (`wall_contact`, `sphere_cavity`, `mesh_contact`): the
/// Jacobian-transpose law with `rendering = [K_d, B_d, extra]` on the reference `source`, the
/// operator pushing with `force` from 0.1 s to 1.0 s, 1.5 s in all; the trace tolerance is the
/// encoder counts' plus `extra` (what the renderer adds).
#[allow(clippy::too_many_arguments)]
fn pushed_run<R, Src, const N: usize, const M: usize>(
    name: &'static str,
    rig: R,
    setup: &Setup<R::Scalar, N>,
    sense_time_constant: R::Scalar,
    profile: bool,
    source: Src,
    rendering: [R::Scalar; 3],
    force: [R::Scalar; M],
) -> Option<Scenario<R, Src, N, M>>
where
    R: FusedImpedance<N, M> + Clone,
    Src: ReferenceSource<R::Scalar, M> + Clone,
{
    let [stiffness, damping, extra] = rendering;
    let fast = R::CURRENT_LOOP_HZ;
    let board = board(&rig, setup, sense_time_constant);
    let controller = controller(rig, source, jacobian_transpose(stiffness, damping, false), setup, profile)?;
    let load = Load { start: fast / 10, end: fast, force };
    let tolerance = trace_tolerance(board.rig(), &setup.start, extra);
    let mut run = Scenario::new(name, controller, board, load, 3 * fast / 2, fast / 100);
    run.task_tolerance = tolerance;
    run.current_tolerance = current_tolerance(run.board.rig(), &setup.start, stiffness, tolerance);
    Some(run)
}

/// The push of the spatial cavity scenarios: `force` N along `(2, 1, 2)/3`.
fn along_221<S: Real>(force: f64) -> [S; 3] {
    let third = force / 3.0;
    [s(2.0 * third), s(third), s(2.0 * third)]
}

/// The inside of a closed triangle mesh touched through the god-object proxy (`M = 3`, any `N`;
/// the PHANToM-like arm): the runtime's [`GodObject`](hapticgen_runtime::proxy::GodObject) with
/// one mesh, a UV sphere of 10 mm radius with 1,000 triangles and its BVH (dimensions in
/// `hapticgen-fw-build`, `MESH_CONTACT_*`), which the image's glue emits as
/// `static` arrays (the mesh is in flash) in the sphere's own frame; the scenario places it
/// about the start's task point (`Shape::MeshAt`). `sphere_cavity` with a mesh instead of the
/// analytic sphere: the Jacobian-transpose law with the rendering's wall `K_d`, `B_d`; the
/// operator pushes with [`FORCE`](mesh_contact::FORCE) along `(2, 1, 2)/3` from 0.1 s to 1.0 s,
/// the proxy stops on the facet it reaches and the HIP rests `F/K_d` beyond it; 1.5 s in all.
/// (From inside, the surface is concave and the rest stable; pushed from outside onto a
/// frictionless sphere, the HIP would slide off it, and an `f32` and an `f64` run would slide
/// off differently.)
pub mod mesh_contact {
    use super::*;
    use hapticgen_runtime::proxy::GodObject;
    use hapticgen_runtime::render::ObjectKind;
    use hapticgen_runtime::shape::{Material, Mesh, Object, RigidMotion, Shape};

    /// Operator force, N, along `(2, 1, 2)/3`.
    pub const FORCE: f64 = 1.0;
    /// Radius of the proxy, m (a point).
    pub const PROXY_RADIUS: f64 = 0.0;
    /// The proxy's contact tolerance, m (1 µm suits metres in `f32` and `f64` alike).
    pub const SKIN: f64 = 1e-6;

    /// The reference source: the god-object renderer with one object.
    pub type Source<R, const N: usize, const M: usize> =
        GodObject<'static, <R as RigModel<N, M>>::Scalar, 1, M>;

    /// The scenario type for a rig `R` (`M = 3`).
    pub type Run<R, const N: usize, const M: usize> = Scenario<R, Source<R, N, M>, N, M>;

    /// Builds the run on `mesh` (the UV sphere above, about the origin); `None` if the rig's
    /// rates are unusable.
    pub fn new<R: FusedImpedance<N, 3> + Clone, const N: usize>(
        name: &'static str,
        rig: R,
        setup: &Setup<R::Scalar, N>,
        sense_time_constant: R::Scalar,
        profile: bool,
        mesh: &'static Mesh<'static, R::Scalar, 3>,
    ) -> Option<Run<R, N, 3>> {
        let [_, wall_stiffness, wall_damping] = rendering(setup);
        let start = rig.position(&setup.start);
        let mut scene = GodObject::new(wall_stiffness, wall_damping, s(PROXY_RADIUS), s(SKIN));
        scene.add(Object {
            shape: Shape::MeshAt { mesh, placement: RigidMotion::translation(start) },
            kind: ObjectKind::Cavity,
            material: Material::frictionless(wall_stiffness, wall_damping),
        })?;
        // The proxy has no grid: the two runs differ by rounding and the skin.
        let rendering = [wall_stiffness, wall_damping, s(4.0 * SKIN)];
        pushed_run(name, rig, setup, sense_time_constant, profile, scene, rendering, along_221(FORCE))
    }
}

/// A scene file's objects touched through the god-object proxy (any `N` and `M`; the
/// `variants.txt` line names the file, docs/scenes.md): the runtime's
/// [`GodObject`](hapticgen_runtime::proxy::GodObject) with the file's objects and free-space
/// effect, which the image's glue emits (`hapticgen_codegen::scene::emit`; meshes as `static`
/// arrays, in flash), in the task frame as written (place them about the start's task point).
/// The Jacobian-transpose law with the rendering's wall `K_d`, `B_d`; the operator pushes with
/// [`FORCE`](scene_contact::FORCE) along the last task axis's negative direction (down, for a
/// spatial device) from 0.1 s to the end, 1.5 s, so that the proxy stops on what is below the
/// start and the HIP rests `F/K_d` beyond it (or, held in free space by a spring effect of
/// stiffness `k`, rests `F/k` below the spring's anchor). (The push lasts to the end, unlike the other
/// contact scenarios': let go above a solid, the device would drift in free space, where
/// nothing holds it and an `f32` and an `f64` run drift apart.)
pub mod scene_contact {
    use super::*;
    use hapticgen_runtime::effects::Effect;
    use hapticgen_runtime::motion::{MovingObjects, ObjectMotion};
    use hapticgen_runtime::proxy::GodObject;
    use hapticgen_runtime::shape::Object;

    /// Operator force, N, down the last task axis.
    pub const FORCE: f64 = 1.0;
    /// The most objects a scene may have (the god object's slots).
    pub const CAPACITY: usize = 8;
    /// Radius of the proxy, m (a point).
    pub const PROXY_RADIUS: f64 = 0.0;
    /// The proxy's contact tolerance, m (1 µm suits metres in `f32` and `f64` alike).
    pub const SKIN: f64 = 1e-6;

    /// The reference source: the god-object renderer with the scene's objects, moving those
    /// with a motion before each update.
    pub type Source<R, const N: usize, const M: usize> =
        MovingObjects<'static, <R as RigModel<N, M>>::Scalar, CAPACITY, M>;

    /// The scenario type for a rig `R`.
    pub type Run<R, const N: usize, const M: usize> = Scenario<R, Source<R, N, M>, N, M>;

    /// Builds the run on `objects`, each moving by its entry of `motions`, with the free-space
    /// effect `effect(impedance period)`; `None` if the rig's rates are unusable, the task has no
    /// coordinate or the scene has more than [`CAPACITY`] objects.
    // The glue's uniform arguments (name, rig, setup, sense lag, profile), then the scene's three.
    #[allow(clippy::too_many_arguments)]
    pub fn new<R: FusedImpedance<N, M> + Clone, const N: usize, const M: usize, const K: usize>(
        name: &'static str,
        rig: R,
        setup: &Setup<R::Scalar, N>,
        sense_time_constant: R::Scalar,
        profile: bool,
        objects: [Object<'static, R::Scalar, M>; K],
        effect: fn(R::Scalar) -> Effect<R::Scalar, M>,
        motions: [Option<ObjectMotion<R::Scalar, M>>; K],
    ) -> Option<Run<R, N, M>> {
        let [_, wall_stiffness, wall_damping] = rendering(setup);
        let mut god_object = GodObject::new(wall_stiffness, wall_damping, s(PROXY_RADIUS), s(SKIN));
        let mut slot_motions = [None; CAPACITY];
        for (object, motion) in objects.into_iter().zip(motions) {
            let slot = god_object.add(object)?;
            *slot_motions.get_mut(slot)? = motion;
        }
        let period = s(1.0 / f64::from(R::IMPEDANCE_LOOP_HZ));
        god_object.effect = effect(period);
        let scene = MovingObjects::new(god_object, slot_motions, period);
        let mut force = [R::Scalar::ZERO; M];
        *force.last_mut()? = s(-FORCE);
        // The proxy has no grid: the two runs differ by rounding and the skin.
        let rendering = [wall_stiffness, wall_damping, s(4.0 * SKIN)];
        let mut run = pushed_run(name, rig, setup, sense_time_constant, profile, scene, rendering, force)?;
        run.load.end = run.periods;
        Some(run)
    }
}

/// Holding a pose against gravity and a push, for any rig (`N` joints, `M` task coordinates,
/// redundant ones included): Controller 3 with a fixed reference at the start pose's task
/// point, `K_d` = [`STIFFNESS`](hold_pose::STIFFNESS), `B_d` = [`DAMPING`](hold_pose::DAMPING)
/// on every axis; the generated `g(q)` holds the arm up. The operator pushes with
/// [`FORCE`](hold_pose::FORCE) along −x_M (down, for a spatial arm) from 0.1 s to 1.0 s (the
/// point settles `FORCE / K_d` = 10 mm down), then lets go; 1.5 s in all.
/// The device's own viscous friction is *not* compensated (`omit_damping_compensation`): it is
/// what damps the `N − M` joint-space directions the task spring does not see (the null space
/// of `J`).
pub mod hold_pose {
    use super::*;
    use hapticgen_runtime::control::TaskReference;

    /// `K_d`, N/m.
    pub const STIFFNESS: f64 = 2000.0;
    /// `B_d`, N·s/m.
    pub const DAMPING: f64 = 150.0;
    /// Operator force, N.
    pub const FORCE: f64 = 20.0;

    /// The reference source: fixed at the start's task point.
    pub type Source<R, const N: usize, const M: usize> = TaskReference<<R as RigModel<N, M>>::Scalar, M>;

    /// The scenario type for a rig `R`.
    pub type Run<R, const N: usize, const M: usize> = Scenario<R, Source<R, N, M>, N, M>;

    /// Builds the run; `None` if the rig's rates are unusable or `M = 0`.
    pub fn new<R: FusedImpedance<N, M> + Clone, const N: usize, const M: usize>(
        name: &'static str,
        rig: R,
        setup: &Setup<R::Scalar, N>,
        sense_time_constant: R::Scalar,
        profile: bool,
    ) -> Option<Run<R, N, M>> {
        let fast = R::CURRENT_LOOP_HZ;
        let board = board(&rig, setup, sense_time_constant);
        let reference = TaskReference::at_rest(rig.position(&setup.start));
        let law = jacobian_transpose(s(STIFFNESS), s(DAMPING), true);
        let controller = controller(rig, reference, law, setup, profile)?;
        let mut force = [R::Scalar::ZERO; M];
        *force.last_mut()? = s(-FORCE);
        let load = Load { start: fast / 10, end: fast, force };
        let tolerance = trace_tolerance(board.rig(), &setup.start, R::Scalar::ZERO);
        let mut run = Scenario::new(name, controller, board, load, 3 * fast / 2, fast / 100);
        run.task_tolerance = tolerance;
        run.current_tolerance = current_tolerance(run.board.rig(), &setup.start, s(STIFFNESS), tolerance);
        Some(run)
    }
}
