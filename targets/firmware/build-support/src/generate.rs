//! The generation half of the crate (feature `generate`, on by default): the rig's code
//! through `hapticgen-codegen`, and the glue module around it.

use std::fmt::Write as _;
use std::path::Path;

use hapticgen_codegen::{emit, model, EmitOptions, Scalar};

use crate::{Glue, ModelShape, Variant};

fn literal(value: f64) -> String {
    // `{:?}` prints the shortest representation that round-trips, always with a `.` or `e`.
    format!("{value:?}")
}

/// The emission options of every image and of the host reference, which must agree so that the
/// reference runs the same arithmetic as the target: unfused by default; with
/// `HAPTICGEN_FW_FMA=1`, fused multiply-adds (`hapticgen generate --fma`; `vfma.f32` on the
/// target through the runtime's `fpu-fma` feature, libm's exact `fmaf` on the host, bit for bit
/// the same). Not the default because on the Cortex-M4F it costs instructions: stable Rust
/// reaches `vfma.f32` only by inline assembly through core registers (about nine instructions
/// for a fused operation against two for `vmul` + `vadd`; see docs/firmware.md for the
/// measurement). Tells cargo to rerun the calling build script when the variable changes.
pub fn emit_options() -> EmitOptions {
    println!("cargo:rerun-if-env-changed=HAPTICGEN_FW_FMA");
    let on = std::env::var("HAPTICGEN_FW_FMA").map(|v| v == "1").unwrap_or(false);
    EmitOptions { fused_multiply_add: on, ..Default::default() }
}

/// Generates the rig of `v` in `scalar` into `out_dir/<module>_rig.rs` and returns the text of
/// the glue module `<module>` (to be written into a file the crate `include!`s).
pub fn generate(
    v: &Variant,
    firmware_dir: &Path,
    scalar: Scalar,
    out_dir: &Path,
    module: &str,
    glue_kind: Glue,
) -> Result<String, String> {
    let rig = generate_rig(v, firmware_dir, scalar, &out_dir.join(format!("{module}_rig.rs")))?;
    Ok(rig.glue(module, glue_kind))
}

/// A rig generated into a file, and what its glue modules say about it.
#[derive(Clone, Debug)]
pub struct GeneratedRig {
    name: String,
    description: String,
    scenario: String,
    type_name: String,
    scalar: &'static str,
    joints: usize,
    task_dim: usize,
    current_loop_hz: String,
    impedance_loop_hz: String,
    gains: Vec<String>,
    start: Vec<String>,
    rendering: String,
    sense_time_constant: f64,
    /// The scenario's mesh as Rust source (`static` arrays), for the scenarios that render one.
    mesh: Option<String>,
    /// The scene file's objects as Rust source (`hapticgen_codegen::scene::emit`), for
    /// `scene_contact`.
    scene: Option<String>,
    /// The frame whose orientation the image reads from the gimbal, for `stylus_cavity`.
    stylus_frame: Option<String>,
}

/// The frame a `stylus_cavity` image reads from its gimbal.
pub const STYLUS_FRAME: &str = "stylus";

/// The measured joints a `stylus_cavity` image reads (`hapticgen_fw_sim::scenario::GIMBAL_JOINTS`).
pub const GIMBAL_JOINTS: usize = 3;

/// Generates the rig of `v` in `scalar` into `rig_file`; its glue modules come from
/// [`GeneratedRig::glue`], any number of them (a crate's `OUT_DIR` must then hold the rig as
/// `<module>_rig.rs`).
pub fn generate_rig(
    v: &Variant,
    firmware_dir: &Path,
    scalar: Scalar,
    rig_file: &Path,
) -> Result<GeneratedRig, String> {
    let repo_root = firmware_dir.join("../..");
    let model_path = v.model_path(&repo_root);
    let model_name = v.model_name();
    let load = |path: &Path, name: &str| {
        hapticgen_codegen::load_file(path, name, v.variant.as_deref()).map_err(|e| e.to_string())
    };
    let loaded = load(&model_path, &model_name)?;
    if v.replaced_by.is_some() {
        // The replacing file (HAPTICGEN_FW_MODEL) must be the line's rig with other numbers.
        let line = load(&repo_root.join(&v.model), &v.model)?;
        crate::check_same_shape(v, &shape(&line), &shape(&loaded))?;
    }
    hapticgen_codegen::build::generate_with(
        &model_path,
        v.variant.as_deref(),
        scalar,
        emit_options(),
        rig_file,
    )
    .map_err(|e| e.to_string())?;
    let (n, m) = (loaded.joints.len(), loaded.task_dim());
    if n == 0 {
        return Err(format!("{model_name}: the model has no joints"));
    }
    if v.pose.len() != n {
        return Err(format!(
            "image `{}`: the pose has {} values, `{model_name}` has {n} joints",
            v.name,
            v.pose.len(),
        ));
    }
    // The model's own per-joint designs (the generated `CURRENT_LOOP_GAINS`), in f64; the
    // glue converts them with `from_f64`, as the scenario converts everything else.
    let designs = &loaded.analyses.current_loop_designs;
    if designs.len() != n {
        return Err(format!("{model_name}: {} current-loop designs for {n} joints", designs.len()));
    }
    let type_name = emit::rig_type_name(&loaded);
    let s = scalar.name();
    let rendering = match &loaded.rendering {
        Some(r) => format!(
            "Some([S::from_f64({}), S::from_f64({}), S::from_f64({})])",
            literal(r.grid_spacing),
            literal(r.wall_stiffness),
            literal(r.wall_damping)
        ),
        None => "None".to_string(),
    };
    let gains: Vec<String> = designs
        .iter()
        .map(|d| {
            format!(
                "::hapticgen_runtime::current_loop::CurrentLoopGains {{ kp: S::from_f64({}), ki: S::from_f64({}), \
                 sample_period: S::from_f64({}), proportional_setpoint_weight: S::from_f64({}) }}",
                literal(d.kp),
                literal(d.ki),
                literal(d.sample_period),
                literal(d.proportional_setpoint_weight)
            )
        })
        .collect();
    // Degrees (revolute) or millimetres (prismatic) to SI; `x / 180 · π` is exact for the
    // multiples of 45° the table uses.
    let start: Vec<String> = v
        .pose
        .iter()
        .zip(loaded.joints.iter())
        .map(|(&x, j)| match j.kind {
            model::JointKind::Revolute => {
                format!("S::from_f64({})", literal(x / 180.0 * std::f64::consts::PI))
            }
            model::JointKind::Prismatic => format!("S::from_f64({})", literal(x / 1000.0)),
        })
        .collect();
    // Every joint has the same anti-aliasing filter: its time constant from the first design.
    let tau = designs[0].filter_time_constant;
    let mesh = scenario_mesh(&v.scenario, scalar)?;
    let scene = match &v.scene {
        None => None,
        Some(file) => {
            let path = repo_root.join(file);
            // The file and what it names (meshes, usually beside it: cargo scans a directory
            // for any change).
            println!("cargo:rerun-if-changed={}", path.display());
            if let Some(directory) = path.parent() {
                println!("cargo:rerun-if-changed={}", directory.display());
            }
            let scene = hapticgen_codegen::scene::load(&path)?;
            if scene.objects.len() > SCENE_CAPACITY {
                return Err(format!(
                    "image `{}`: {file} has {} objects; `scene_contact` renders at most {SCENE_CAPACITY}",
                    v.name,
                    scene.objects.len()
                ));
            }
            Some(hapticgen_codegen::scene::emit(&scene, m, scalar)?)
        }
    };
    let stylus_frame = if v.scenario == "stylus_cavity" {
        if loaded.measured.len() != GIMBAL_JOINTS || !loaded.frames.iter().any(|f| f.name == STYLUS_FRAME) {
            return Err(format!(
                "image `{}`: the scenario `stylus_cavity` reads a gimbal of {GIMBAL_JOINTS} measured joints into the \
                 frame `{STYLUS_FRAME}`; `{model_name}` has {} measured joints and frames {:?}",
                v.name,
                loaded.measured.len(),
                loaded.frames.iter().map(|f| f.name.as_str()).collect::<Vec<_>>()
            ));
        }
        Some(STYLUS_FRAME.to_string())
    } else {
        None
    };
    Ok(GeneratedRig {
        name: v.name.clone(),
        description: format!(
            "`{}`{}{}, scenario `{}`",
            model_name,
            match &v.replaced_by {
                Some(_) => format!(" (in place of `{}`)", v.model),
                None => String::new(),
            },
            v.variant.as_ref().map(|x| format!(" variant `{x}`")).unwrap_or_default(),
            v.scenario
        ),
        scenario: v.scenario.clone(),
        type_name,
        scalar: s,
        joints: n,
        task_dim: m,
        current_loop_hz: loaded.rates.current_loop_hz.to_string(),
        impedance_loop_hz: loaded.rates.impedance_loop_hz.to_string(),
        gains,
        start,
        rendering,
        sense_time_constant: tau,
        mesh,
        scene,
        stylus_frame,
    })
}

/// The structure of a loaded model that [`crate::check_same_shape`] compares.
fn shape(model: &hapticgen_codegen::CheckedModel) -> ModelShape {
    ModelShape {
        joints: model
            .joints
            .iter()
            .map(|j| {
                let kind = match j.kind {
                    model::JointKind::Revolute => "revolute",
                    model::JointKind::Prismatic => "prismatic",
                };
                (j.name.clone(), kind.to_string())
            })
            .collect(),
        task_dim: model.task_dim(),
        measured: model.measured.iter().map(|j| j.name.clone()).collect(),
    }
}

/// The most objects the scenario `scene_contact` renders (its god object's capacity,
/// `hapticgen_fw_sim::scenarios::scene_contact::CAPACITY`).
pub const SCENE_CAPACITY: usize = 8;

/// The sphere of the scenario `mesh_contact` (`hapticgen_fw_sim::scenarios::mesh_contact`):
/// radius, m (the cavity of `sphere_cavity`, as a mesh).
pub const MESH_CONTACT_RADIUS: f64 = 0.010;
/// Its bands of latitude and longitude: `2 × 25 × (21 − 1)` = 1,000 triangles.
pub const MESH_CONTACT_RINGS_SEGMENTS: (usize, usize) = (21, 25);
/// The most triangles in a leaf of its BVH.
pub const MESH_CONTACT_LEAF_SIZE: usize = 4;

/// The mesh a scenario renders, as the Rust source of `static SPHERE: Mesh<'static, S, 3>` and
/// its arrays (`hapticgen_codegen::mesh::emit`), for the scenarios whose `new` takes one;
/// `None` for the others. (Here, not in the scenario's crate: the board images build with
/// this crate and must not depend on the simulator.)
fn scenario_mesh(scenario: &str, scalar: Scalar) -> Result<Option<String>, String> {
    match scenario {
        "mesh_contact" => {
            let (rings, segments) = MESH_CONTACT_RINGS_SEGMENTS;
            let sphere =
                hapticgen_codegen::mesh::TriangleMesh::uv_sphere(MESH_CONTACT_RADIUS, rings, segments)?
                    .with_bvh(MESH_CONTACT_LEAF_SIZE);
            Ok(Some(hapticgen_codegen::mesh::emit(&sphere, "SPHERE", scalar)))
        }
        _ => Ok(None),
    }
}

impl GeneratedRig {
    /// The text of the glue module `module` of `kind`; it includes the rig from
    /// `$OUT_DIR/<module>_rig.rs`.
    pub fn glue(&self, module: &str, kind: Glue) -> String {
        let mut glue = String::new();
        let _ = writeln!(
            glue,
            "/// Image `{name}`: {description}, {s}.\n\
             pub mod {module} {{\n\
             \x20   #[allow(clippy::all, missing_docs)]\n\
             \x20   pub mod rig {{ include!(concat!(env!(\"OUT_DIR\"), \"/{module}_rig.rs\")); }}\n\
             \x20   /// The generated rig.\n\
             \x20   pub type Rig = rig::{type_name};\n\
             \x20   /// Number of joints.\n\
             \x20   pub const JOINTS: usize = {n};\n\
             \x20   /// Number of task coordinates.\n\
             \x20   pub const TASK_DIM: usize = {m};\n\
             \x20   /// The image name.\n\
             \x20   pub const NAME: &str = \"{name}\";\n\
             \x20   /// The rig's current-loop rate, Hz (the interrupt rate).\n\
             \x20   pub const CURRENT_LOOP_HZ: u32 = {hz};\n\
             \x20   /// The rig's impedance-loop rate, Hz.\n\
             \x20   pub const IMPEDANCE_LOOP_HZ: u32 = {imp_hz};\n\
             \x20   /// Model-derived settings: per-joint current-loop gains (designed from each joint's\n\
             \x20   /// motor), the start pose of `variants.txt`, rendering.\n\
             \x20   pub fn setup() -> ::hapticgen_fw_control::Setup<{s}, JOINTS> {{\n\
             \x20       type S = {s};\n\
             \x20       use ::hapticgen_runtime::Real as _;\n\
             \x20       ::hapticgen_fw_control::Setup {{\n\
             \x20           current_gains: [{gains}],\n\
             \x20           start: [{start}],\n\
             \x20           rendering: {rendering},\n\
             \x20       }}\n\
             \x20   }}",
            name = self.name,
            description = self.description,
            s = self.scalar,
            type_name = self.type_name,
            n = self.joints,
            m = self.task_dim,
            hz = self.current_loop_hz,
            imp_hz = self.impedance_loop_hz,
            gains = self.gains.join(", "),
            start = self.start.join(", "),
            rendering = self.rendering,
        );
        let _ = match &self.stylus_frame {
            Some(frame) => writeln!(
                glue,
                "\x20   /// The orientation of the frame `{frame}` from the actuated joints' and the gimbal's angles.\n\
                 \x20   pub fn stylus_orientation(q: &[{s}; JOINTS], measured: &[{s}; {k}]) -> [[{s}; 3]; 3] {{\n\
                 \x20       Rig::NOMINAL.{frame}_orientation(q, measured)\n\
                 \x20   }}\n\
                 \x20   /// The image reads its gimbal each impedance tick: a control-path probe's read, on a\n\
                 \x20   /// reader, actuated joints and counters the optimiser cannot see\n\
                 \x20   /// (`hapticgen_fw_control::probe`; linked, never run).\n\
                 \x20   pub fn probe_stylus_read() {{\n\
                 \x20       use ::hapticgen_fw_control::probe::{{opaque, OpaqueBoard, OpaqueClock}};\n\
                 \x20       type Reader = ::hapticgen_fw_control::stylus::Stylus<{s}, JOINTS, {k}>;\n\
                 \x20       // SAFETY: a probe is never run.\n\
                 \x20       if let (Some(stylus), Some(q)) = unsafe {{ (opaque::<Reader>(), opaque::<[{s}; JOINTS]>()) }} {{\n\
                 \x20           let _ = stylus.read(&mut OpaqueBoard, q, stylus_orientation, &OpaqueClock);\n\
                 \x20       }}\n\
                 \x20   }}",
                s = self.scalar,
                k = GIMBAL_JOINTS,
            ),
            None => writeln!(
                glue,
                "\x20   /// The image reads no gimbal: a control-path probe has no stylus read.\n\
                 \x20   pub fn probe_stylus_read() {{}}",
            ),
        };
        if kind == Glue::Simulation {
            let _ = writeln!(
                glue,
                "\x20   /// The scenario's reference source.\n\
                 \x20   pub type Source = ::hapticgen_fw_sim::scenarios::{scenario}::Source<Rig, JOINTS, TASK_DIM>;\n\
                 \x20   /// The firmware's control state for this rig and source (what the interrupt runs).\n\
                 \x20   pub type Control = ::hapticgen_fw_control::Controller<Rig, Source, JOINTS, TASK_DIM>;\n\
                 \x20   /// The scenario for this rig.\n\
                 \x20   pub type Run = ::hapticgen_fw_sim::scenarios::{scenario}::Run<Rig, JOINTS, TASK_DIM>;\n\
                 \x20   /// Time constant of the simulated current sense, s: the model's anti-aliasing filter\n\
                 \x20   /// as its current-loop design approximates it (a first-order lag).\n\
                 \x20   pub fn sense_time_constant() -> {s} {{\n\
                 \x20       <{s} as ::hapticgen_runtime::Real>::from_f64({tau})\n\
                 \x20   }}\n\
                 \x20   /// The scenario, ready to run.\n\
                 \x20   pub fn new(profile: bool) -> Option<Run> {{\n\
                 \x20       ::hapticgen_fw_sim::scenarios::{scenario}::new(NAME, Rig::NOMINAL, &setup(), sense_time_constant(), profile{mesh_argument})\n\
                 \x20   }}",
                scenario = self.scenario,
                s = self.scalar,
                tau = literal(self.sense_time_constant),
                mesh_argument = match (&self.mesh, &self.scene, &self.stylus_frame) {
                    (Some(_), _, _) => ", &mesh::SPHERE",
                    (None, Some(_), _) => ", scene::objects(), scene::effect, scene::motions()",
                    (None, None, Some(_)) => ", Rig::MEASURED_JOINTS, stylus_orientation",
                    (None, None, None) => "",
                },
            );
            if let Some(mesh) = &self.mesh {
                let _ = writeln!(
                    glue,
                    "\x20   /// The scenario's mesh: `static` arrays, in flash on the target.\n\
                     \x20   #[allow(clippy::all)]\n\
                     \x20   pub mod mesh {{\n{mesh}\x20   }}"
                );
            }
            if let Some(scene) = &self.scene {
                let _ = writeln!(
                    glue,
                    "\x20   /// The scene file's objects (meshes as `static` arrays, in flash on the target) and its\n\
                     \x20   /// free-space effect.\n\
                     \x20   #[allow(clippy::all, missing_docs)]\n\
                     \x20   pub mod scene {{\n{scene}\x20   }}"
                );
            }
        }
        glue.push_str("}\n");
        glue
    }
}
