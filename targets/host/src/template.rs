//! Starting points for a new rig: `hapticgen new delta|five-bar|serial` writes a commented model
//! file from a few named dimensions, masses and motor data, with everything a user would
//! otherwise compute by hand worked out here: a Delta's leg frames, platform points,
//! perpendicular axes and assembly angles (the inverse kinematics of its symmetric pose at the
//! middle of the thigh ranges), a five-bar's home pose and joint ranges, slender-rod inertias.
//!
//! Dimensions stay named parameters and the derived values are written as expressions of them
//! (`platform_radius * (cos(120 deg) - 1)`), so the file reads like the drawing; what cannot be
//! an expression (an assembly angle, the solution of the loop equations) is computed here and
//! commented. The file is loaded and checked before it is written ([`write_checked`]): a
//! template whose dimensions cannot assemble is refused with the generator's diagnostics and
//! nothing is written.

use std::fmt::Write as _;
use std::path::Path;

use hapticgen_codegen::check::plausibility::{plausibility, Severity};
use hapticgen_codegen::model::quantity::{self, Dim};
use hapticgen_codegen::Source;

/// A quantity as the user typed it (`37.2 mm`, `0.0372`) and its value in SI units.
#[derive(Clone, Debug, PartialEq)]
pub struct Quantity {
    /// The text, written into the model file as it is.
    pub text: String,
    /// The value in SI units.
    pub si: f64,
}

impl Quantity {
    /// Reads `text` as a model file would (a number in SI units, a number with a unit, or an
    /// expression of numbers, `hapticgen_codegen::model::quantity`), of dimension `dim` if it
    /// carries a unit.
    pub fn parse(text: &str, what: &str, dim: Dim) -> Result<Quantity, TemplateError> {
        let refuse =
            |why: String| TemplateError::Option { option: what.to_string(), text: text.to_string(), why };
        let value = quantity::parse(text)
            .and_then(|e| e.eval(&|_| None))
            .map_err(|e| refuse(format!("{} (at character {})", e.message, e.offset + 1)))?;
        if value.unit_at.is_some() && value.dim != dim {
            return Err(refuse(format!(
                "expects a quantity in {}, got one in {}",
                quantity::dim_name(dim),
                quantity::dim_name(value.dim)
            )));
        }
        if !value.value.is_finite() {
            return Err(refuse("not a finite number".into()));
        }
        Ok(Quantity { text: text.trim().to_string(), si: value.value })
    }
}

/// Why a template could not be written.
#[derive(Debug, thiserror::Error)]
pub enum TemplateError {
    /// An option's value is not a quantity.
    #[error("--{option} {text:?}: {why}")]
    Option {
        /// The option's name.
        option: String,
        /// Its value as given.
        text: String,
        /// Why it is refused.
        why: String,
    },
    /// The dimensions do not make a rig (a leg too short to reach the platform, …).
    #[error("{0}")]
    Geometry(String),
    /// The written model does not pass `hapticgen check`: the diagnostics.
    #[error("the model for these dimensions does not pass `hapticgen check`:\n{0}")]
    Check(String),
    /// The file could not be written.
    #[error("cannot write {path}: {source}")]
    Write {
        /// The output path.
        path: String,
        /// The error.
        source: std::io::Error,
    },
}

/// A drive's motor, gearhead and encoder.
#[derive(Clone, Debug)]
pub struct MotorData {
    /// Rotor inertia, kg·m².
    pub rotor_inertia: Quantity,
    /// Winding resistance, Ω.
    pub resistance: Quantity,
    /// Winding inductance, H.
    pub inductance: Quantity,
    /// Torque constant, N·m/A.
    pub torque_constant: Quantity,
    /// Motor turns per joint turn.
    pub gear_ratio: Quantity,
    /// Largest motor current, A.
    pub current_limit: Quantity,
    /// Supply voltage, V.
    pub supply_voltage: Quantity,
    /// Encoder counts per motor turn.
    pub counts_per_turn: u32,
}

impl MotorData {
    /// The drive entry `name`, its torque limit the torque at the current limit.
    fn drive(&self, name: &str, comment: &str) -> String {
        let torque_limit = self.current_limit.si * self.torque_constant.si * self.gear_ratio.si;
        format!(
            "  {name}:
    # {comment}
    motor:
      rotor_inertia: {}
      resistance: {}
      inductance: {}
      torque_constant: {}
    gear_ratio: {}
    torque_limit: {} N m   # the current limit × torque constant × gear ratio
    current_limit: {}
    supply_voltage: {}
    encoder:
      counts_per_turn: {}
",
            self.rotor_inertia.text,
            self.resistance.text,
            self.inductance.text,
            self.torque_constant.text,
            self.gear_ratio.text,
            number(torque_limit),
            self.current_limit.text,
            self.supply_voltage.text,
            self.counts_per_turn
        )
    }
}

/// A number with no more digits than it needs (at most 9 significant).
fn number(x: f64) -> String {
    crate::output::yaml_number(x, 9)
}

/// The sections every template ends with: rates and the current loop's targets.
const RATES_AND_CURRENT_LOOP: &str = "
rates:
  current_loop_hz: 7500
  impedance_loop_hz: 1000

current_loop:
  bandwidth_hz: 700 Hz
  damping_ratio: 1.05
  anti_alias_cutoff_hz: 2500 Hz
";

/// The dimensions of a Delta: three RUU legs at 0°, 120° and 240° about the vertical z axis,
/// a translating platform.
#[derive(Clone, Debug)]
pub struct DeltaSpec {
    /// The rig's name (snake_case).
    pub name: String,
    /// Base centre to each thigh axis.
    pub base_radius: Quantity,
    /// Platform centre to each platform joint.
    pub platform_radius: Quantity,
    /// Thigh axis to knee.
    pub thigh_length: Quantity,
    /// Knee to platform joint.
    pub shin_length: Quantity,
    /// Each thigh's mass (a slender rod).
    pub thigh_mass: Quantity,
    /// Each shin's mass (a slender rod).
    pub shin_mass: Quantity,
    /// The platform's mass with its grip (a point mass at its centre).
    pub platform_mass: Quantity,
    /// The thigh angle's lower limit (below the horizontal).
    pub lower: Quantity,
    /// The thigh angle's upper limit.
    pub upper: Quantity,
    /// The motors.
    pub motor: MotorData,
}

/// A Delta's symmetric pose: the knee swing and the shin's total pitch from the horizontal at
/// thigh angle `theta` (rad), and the platform's depth below the base, from the leg in the
/// x–z plane: the knee at `(r + a cos θ, −a sin θ)`, the platform joint at `(s, z)` with
/// `|knee − joint| = b`.
pub fn delta_pose(r: f64, s: f64, a: f64, b: f64, theta: f64) -> Result<(f64, f64, f64), String> {
    let reach = r + a * theta.cos() - s;
    let drop_squared = b * b - reach * reach;
    if drop_squared.is_nan() || drop_squared <= 0.0 {
        return Err(format!(
            "the shins ({} m) cannot reach the platform joints {} m inward of the knees at the middle of the thigh \
             range: make the shins longer or the platform radius larger",
            number(b),
            number(reach)
        ));
    }
    let z = -a * theta.sin() - drop_squared.sqrt();
    // The shin's direction (s − r − a cos θ, z + a sin θ)/b is the thigh's x axis turned by the
    // total pitch θ + σ about y: (cos(θ + σ), −sin(θ + σ)).
    let pitch = (-(z + a * theta.sin()) / b).atan2(-reach / b);
    Ok((pitch - theta, pitch, z))
}

/// The Delta's model file.
pub fn delta(spec: &DeltaSpec) -> Result<String, TemplateError> {
    let theta = 0.5 * (spec.lower.si + spec.upper.si);
    let (swing, pitch, depth) = delta_pose(
        spec.base_radius.si,
        spec.platform_radius.si,
        spec.thigh_length.si,
        spec.shin_length.si,
        theta,
    )
    .map_err(TemplateError::Geometry)?;
    let mut out = String::new();
    let name = &spec.name;
    let _ = write!(
        out,
        "# {name}: a Delta haptic device written by `hapticgen new delta`. Three RUU legs at 0°, 120° and
# 240° about the vertical z axis between a fixed base and a translating platform; the three
# thigh angles are actuated.
#
# Conventions. World frame at the base centre, z up, leg 1 on +x. Leg k at angle φ_k: its
# thigh frame sits at base_radius·(cos φ_k, sin φ_k, 0) turned by φ_k about z, and its motor
# turns the thigh about the frame's y axis; theta_k = 0 points the thigh radially outwards,
# positive turns it downwards. Each shin is one rigid slender rod on a universal knee; the
# platform hangs on leg 1's shin through a universal joint (its frame at leg 1's platform
# joint), and legs 2 and 3 are cut open at their platform joints (closures `leg2`, `leg3`), whose
# perpendicular conditions keep the platform translating.
#
# Change a dimension in `parameters` and run `hapticgen check` on the file: every position
# follows, except the `assembly` angles, computed for the dimensions given to `hapticgen new`
# (at theta = {theta_text} rad the knees swing {swing_text} rad and the platform is {depth_text} m below
# the base); they only need to be near the assembly (a few tenths of a radian): write them
# again, or run `hapticgen new delta` with the new dimensions, if `check` says the loops do not
# close near them.
name: {name}
description: Delta haptic device (three RUU legs, translating platform), from `hapticgen new delta`
space: spatial
gravity: [0.0, 0.0, -9.81]

parameters:
  base_radius:
    value: {base_radius}
    description: base centre to each thigh axis
  platform_radius:
    value: {platform_radius}
    description: platform centre to each platform joint
  thigh_length:
    value: {thigh_length}
    description: thigh axis to knee
  shin_length:
    value: {shin_length}
    description: knee to platform joint
  thigh_mass:
    value: {thigh_mass}
    description: each thigh, a slender rod
  shin_mass:
    value: {shin_mass}
    description: each shin (parallelogram) as one slender rod
  platform_mass:
    value: {platform_mass}
    description: the platform with its grip, a point mass at its centre

drives:
{drive}
joints:
",
        theta_text = number(theta),
        swing_text = number(swing),
        depth_text = number(-depth),
        base_radius = spec.base_radius.text,
        platform_radius = spec.platform_radius.text,
        thigh_length = spec.thigh_length.text,
        shin_length = spec.shin_length.text,
        thigh_mass = spec.thigh_mass.text,
        shin_mass = spec.shin_mass.text,
        platform_mass = spec.platform_mass.text,
        drive =
            spec.motor.drive("capstan", "the three legs' motors (each thigh turned through its own drive)"),
    );
    for k in 1..=3 {
        let _ = write!(
            out,
            "  - name: theta{k}
    type: revolute
    description: leg {k}'s thigh angle below the horizontal, about the base circle's tangent
    axis: [0.0, 1.0, 0.0]
    limits: {{lower: {lower}, upper: {upper}}}
    drive: capstan
",
            lower = spec.lower.text,
            upper = spec.upper.text
        );
    }
    let swing = number(swing);
    for k in 1..=3 {
        let _ = write!(
            out,
            "  - name: knee{k}
    type: universal
    description: leg {k}'s knee, a Cardan joint between thigh and shin
    axes: [[0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]   # parallel to the thigh's axis; square to it, fixed in the shin
    coordinates: [knee{k}_swing, knee{k}_twist]
    passive: true
    assembly: [{swing}, 0.0]
"
        );
    }
    let _ = write!(
        out,
        "  - name: platform_mount
    type: universal
    description: the platform's Cardan joint on leg 1's shin
    axes: [[0.0, 0.0, 1.0], [0.0, 1.0, 0.0]]   # parallel to the knee's second axis; parallel to leg 1's thigh axis
    coordinates: [platform_swing, platform_twist]
    passive: true
    assembly: [0.0, {}]   # undoes leg 1's pitch: the platform level
\nbodies:
",
        number(-pitch)
    );
    for (k, angle) in [(1, 0), (2, 120), (3, 240)] {
        let origin = if angle == 0 {
            "{xyz: [base_radius, 0.0, 0.0]}".to_string()
        } else {
            format!(
                "{{xyz: [base_radius * cos({angle} deg), base_radius * sin({angle} deg), 0.0], rpy: [0.0, 0.0, {angle} deg]}}"
            )
        };
        let _ = write!(
            out,
            "  - name: thigh{k}
    description: leg {k}'s upper arm, a slender rod
    mass: thigh_mass
    com: [thigh_length / 2, 0.0, 0.0]
    inertia: {{ixx: 0.0, iyy: thigh_mass * thigh_length^2 / 12, izz: thigh_mass * thigh_length^2 / 12}}
    parent: base
    origin: {origin}
    joint: theta{k}
  - name: shin{k}
    description: leg {k}'s parallelogram as one rigid slender rod
    mass: shin_mass
    com: [shin_length / 2, 0.0, 0.0]
    inertia: {{ixx: 0.0, iyy: shin_mass * shin_length^2 / 12, izz: shin_mass * shin_length^2 / 12}}
    parent: thigh{k}
    origin: {{xyz: [thigh_length, 0.0, 0.0]}}
    joint: knee{k}
"
        );
    }
    out.push_str(
        "  - name: platform
    description: the platform with its grip, a point mass at its centre; its frame at leg 1's joint
    mass: platform_mass
    com: [-platform_radius, 0.0, 0.0]
    inertia: {ixx: 0.0, iyy: 0.0, izz: 0.0}
    parent: shin1
    origin: {xyz: [shin_length, 0.0, 0.0]}
    joint: platform_mount

points:
  - name: grip
    description: the platform centre (the task point)
    body: platform
    position: [-platform_radius, 0.0, 0.0]
",
    );
    for (k, angle) in [(2, 120), (3, 240)] {
        let _ = write!(
            out,
            "  - name: shin{k}_end
    description: the far end of leg {k}'s shin
    body: shin{k}
    position: [shin_length, 0.0, 0.0]
  - name: platform_joint{k}
    description: leg {k}'s joint on the platform, at the platform radius from its centre
    body: platform
    position: [platform_radius * (cos({angle} deg) - 1), platform_radius * sin({angle} deg), 0.0]
"
        );
    }
    out.push_str("\nclosures:\n");
    for (k, angle) in [(2, 120), (3, 240)] {
        let _ = write!(
            out,
            "  - name: leg{k}
    description: leg {k}'s shin meets the platform at a universal joint (cut open here)
    points: [shin{k}_end, platform_joint{k}]
    perpendicular:
      - {{body: shin{k}, axis: [0.0, 0.0, 1.0]}}
      - {{body: platform, axis: [-sin({angle} deg), cos({angle} deg), 0.0]}}   # leg {k}'s thigh axis
"
        );
    }
    out.push_str("\ntask:\n  point: grip\n");
    out.push_str(RATES_AND_CURRENT_LOOP);
    Ok(out)
}

/// The dimensions of a planar five-bar (pantograph): two motors on the base, `2·half_spacing`
/// apart on the x axis, each turning a proximal link; two distal links meet at the handle.
#[derive(Clone, Debug)]
pub struct FiveBarSpec {
    /// The rig's name.
    pub name: String,
    /// Half the distance between the motor axes.
    pub half_spacing: Quantity,
    /// Each proximal (motor) link's length.
    pub proximal_length: Quantity,
    /// Each distal link's length.
    pub distal_length: Quantity,
    /// Each proximal link's mass (a slender rod).
    pub proximal_mass: Quantity,
    /// Each distal link's mass (a slender rod).
    pub distal_mass: Quantity,
    /// The handle's mass (a point mass).
    pub handle_mass: Quantity,
    /// Each motor's range about the home pose, rad (the pose with the elbows square).
    pub range: Quantity,
    /// The motors.
    pub motor: MotorData,
}

/// The five-bar's home pose: the left motor's absolute angle and the handle's height with the
/// distal links square to the proximal ones (the best-conditioned pose of the symmetric
/// linkage), the handle above the base's midpoint.
pub fn five_bar_home(half_spacing: f64, proximal: f64, distal: f64) -> Result<(f64, f64), String> {
    let height_squared = proximal * proximal + distal * distal - half_spacing * half_spacing;
    if height_squared.is_nan() || height_squared <= 0.0 {
        return Err(
            "the links are too short to meet above the base: make them longer or the motors closer".into()
        );
    }
    let height = height_squared.sqrt();
    let to_handle = (half_spacing * half_spacing + height * height).sqrt();
    let towards = height.atan2(half_spacing);
    let cos_offset =
        (proximal * proximal + to_handle * to_handle - distal * distal) / (2.0 * proximal * to_handle);
    // The left proximal link turned outward from the line to the handle (the `left` branch).
    Ok((towards + cos_offset.clamp(-1.0, 1.0).acos(), height))
}

/// The five-bar's model file.
pub fn five_bar(spec: &FiveBarSpec) -> Result<String, TemplateError> {
    let (left_home, height) =
        five_bar_home(spec.half_spacing.si, spec.proximal_length.si, spec.distal_length.si)
            .map_err(TemplateError::Geometry)?;
    let right_home = std::f64::consts::PI - left_home;
    let range = spec.range.si;
    let name = &spec.name;
    let drive = spec.motor.drive("direct", "both motors");
    Ok(format!(
        "# {name}: a planar five-bar (pantograph) written by `hapticgen new five-bar`. Two motors on the
# base, at x = ∓half_spacing, each turn a proximal link; the distal links meet at the handle.
# The joint ranges are ±{range_text} rad about the home pose, where the distal links are square to the
# proximal ones and the handle is {height_text} m above the base's midpoint (computed for the dimensions
# given to `hapticgen new`: if you change them, `hapticgen check` tells you whether the loop still
# closes over the ranges).
name: {name}
description: planar five-bar pantograph with both motors on the base, from `hapticgen new five-bar`
space: planar
gravity: [0.0, 0.0]

parameters:
  half_spacing:
    value: {half_spacing}
    description: half the distance between the two motor axes
  proximal_length:
    value: {proximal_length}
    description: each proximal (motor) link
  distal_length:
    value: {distal_length}
    description: each distal link
  proximal_mass:
    value: {proximal_mass}
    description: each proximal link, a slender rod
  distal_mass:
    value: {distal_mass}
    description: each distal link, a slender rod

drives:
{drive}
joints:
  - name: q1
    type: revolute
    description: absolute angle of the left proximal link from the base x axis (motor 1)
    limits: {{lower: {l1}, upper: {u1}}}
    drive: direct
  - name: q2
    type: revolute
    description: absolute angle of the right proximal link from the base x axis (motor 2)
    limits: {{lower: {l2}, upper: {u2}}}
    drive: direct
  - name: left_elbow
    type: revolute
    description: angle of the left distal link relative to the left proximal link
    passive: true
  - name: right_elbow
    type: revolute
    description: angle of the right distal link relative to the right proximal link
    passive: true

bodies:
  - name: left_proximal
    mass: proximal_mass
    com: [proximal_length / 2, 0.0]
    inertia: {{slender_rod: proximal_length}}
    parent: base
    origin: {{xyz: [-half_spacing, 0.0]}}
    joint: q1
  - name: right_proximal
    mass: proximal_mass
    com: [proximal_length / 2, 0.0]
    inertia: {{slender_rod: proximal_length}}
    parent: base
    origin: {{xyz: [half_spacing, 0.0]}}
    joint: q2
  - name: left_distal
    mass: distal_mass
    com: [distal_length / 2, 0.0]
    inertia: {{slender_rod: distal_length}}
    parent: left_proximal
    origin: {{xyz: [proximal_length, 0.0]}}
    joint: left_elbow
  - name: right_distal
    mass: distal_mass
    com: [distal_length / 2, 0.0]
    inertia: {{slender_rod: distal_length}}
    parent: right_proximal
    origin: {{xyz: [proximal_length, 0.0]}}
    joint: right_elbow
  - name: handle
    description: the handle on the common hinge of the distal links, a point mass
    mass: {handle_mass}
    com: [0.0, 0.0]
    inertia: 0.0
    parent: left_distal
    origin: {{xyz: [distal_length, 0.0]}}

points:
  - name: end_effector
    description: the handle, at the far end of the left distal link
    body: left_distal
    position: [distal_length, 0.0]
  - name: right_tip
    description: the far end of the right distal link
    body: right_distal
    position: [distal_length, 0.0]

closures:
  - name: tip
    description: the distal links meet at the handle
    joints: [left_elbow, right_elbow]
    points: [end_effector, right_tip]
    branch: left

task:
  point: end_effector
{rates}
default_variant: horizontal
variants:
  horizontal:
    description: lying on the desk, no gravity in the plane of motion
  vertical:
    description: standing upright, gravity along −y
    set:
      gravity: [0.0, -9.81]
",
        range_text = number(range),
        height_text = number(height),
        half_spacing = spec.half_spacing.text,
        proximal_length = spec.proximal_length.text,
        distal_length = spec.distal_length.text,
        proximal_mass = spec.proximal_mass.text,
        distal_mass = spec.distal_mass.text,
        handle_mass = spec.handle_mass.text,
        l1 = number(left_home - range),
        u1 = number(left_home + range),
        l2 = number(right_home - range),
        u2 = number(right_home + range),
        rates = RATES_AND_CURRENT_LOOP,
    ))
}

/// A planar serial arm: links in a chain from the base, each turned by its own motor.
#[derive(Clone, Debug)]
pub struct SerialSpec {
    /// The rig's name.
    pub name: String,
    /// Each link's length, joint axis to the next (the last: to the tip).
    pub lengths: Vec<Quantity>,
    /// Each link's mass (a slender rod).
    pub masses: Vec<Quantity>,
    /// Each joint's range either side of straight (the first: of the base x axis).
    pub range: Quantity,
    /// The motors.
    pub motor: MotorData,
}

/// The serial arm's model file.
pub fn serial(spec: &SerialSpec) -> Result<String, TemplateError> {
    let n = spec.lengths.len();
    if n == 0 || n != spec.masses.len() {
        return Err(TemplateError::Geometry(format!(
            "a serial arm needs one mass per link: {} lengths, {} masses",
            n,
            spec.masses.len()
        )));
    }
    let name = &spec.name;
    let mut out = format!(
        "# {name}: a planar serial arm written by `hapticgen new serial`: {n} links in a chain from the base,
# each turned by its own motor about z; joint k's angle is link k's turn from link k−1 (the
# first: from the base x axis), each within ±{range} of straight. Links are slender rods.
name: {name}
description: planar {n}-link serial arm, from `hapticgen new serial`
space: planar
gravity: [0.0, 0.0]

parameters:
",
        range = spec.range.text
    );
    for (k, (length, mass)) in spec.lengths.iter().zip(&spec.masses).enumerate() {
        let _ = write!(
            out,
            "  link{i}_length:
    value: {}
    description: link {i}, its joint axis to the next
  link{i}_mass:
    value: {}
    description: link {i}, a slender rod
",
            length.text,
            mass.text,
            i = k + 1
        );
    }
    let _ = write!(out, "\ndrives:\n{}\njoints:\n", spec.motor.drive("motor", "every joint's motor"));
    for k in 1..=n {
        let _ = write!(
            out,
            "  - name: joint{k}
    type: revolute
    description: link {k}'s angle from {}
    limits: {{lower: -{range}, upper: {range}}}
    drive: motor
",
            if k == 1 { "the base x axis".to_string() } else { format!("link {}", k - 1) },
            range = spec.range.text
        );
    }
    out.push_str("\nbodies:\n");
    for k in 1..=n {
        let (parent, origin) = if k == 1 {
            ("base".to_string(), String::new())
        } else {
            (format!("link{}", k - 1), format!("\n    origin: {{xyz: [link{}_length, 0.0]}}", k - 1))
        };
        let _ = write!(
            out,
            "  - name: link{k}
    mass: link{k}_mass
    com: [link{k}_length / 2, 0.0]
    inertia: {{slender_rod: link{k}_length}}
    parent: {parent}{origin}
    joint: joint{k}
"
        );
    }
    let _ = write!(
        out,
        "
points:
  - name: tip
    description: the far end of the last link
    body: link{n}
    position: [link{n}_length, 0.0]

task:
  point: tip
{RATES_AND_CURRENT_LOOP}
default_variant: horizontal
variants:
  horizontal:
    description: lying on the desk, no gravity in the plane of motion
  vertical:
    description: standing upright, gravity along −y
    set:
      gravity: [0.0, -9.81]
"
    );
    Ok(out)
}

/// What [`write_checked`] found: the `check` warnings the written file has.
#[derive(Clone, Debug, Default)]
pub struct Written {
    /// Plausibility warnings, as `hapticgen check` prints them.
    pub warnings: Vec<String>,
}

/// Loads `text` as the model file `path` (every variant), runs the plausibility checks and
/// writes it; nothing is written if it does not pass `hapticgen check`.
pub fn write_checked(text: &str, path: &Path) -> Result<Written, TemplateError> {
    let display = path.display().to_string();
    let source = Source { name: &display, text };
    let first = hapticgen_codegen::load(&source, None).map_err(|d| TemplateError::Check(d.to_string()))?;
    let mut variants: Vec<Option<String>> = vec![None];
    variants.extend(first.variants.iter().filter(|v| Some(*v) != first.variant.as_ref()).cloned().map(Some));
    let mut written = Written::default();
    for variant in variants {
        let m = hapticgen_codegen::load(&source, variant.as_deref())
            .map_err(|d| TemplateError::Check(d.to_string()))?;
        let found = plausibility(&m, &hapticgen_codegen::derive(&m), text);
        for f in &found.findings {
            let d = f.diagnostic(&display, text, &m);
            match f.severity {
                Severity::Error => return Err(TemplateError::Check(format!("error: {d}"))),
                Severity::Warning => written.warnings.push(format!(
                    "warning{}: {d}",
                    variant.as_deref().map(|v| format!(" (variant {v})")).unwrap_or_default()
                )),
            }
        }
    }
    std::fs::write(path, text).map_err(|source| TemplateError::Write { path: display, source })?;
    Ok(written)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_falcon_like_delta_pose_is_the_shipped_models_assembly() {
        // The shipped falcon_delta.yaml's assembly at theta = 0.35: knees 1.924, platform
        // twist −2.274, the grip 0.0988 m below the base (`hapticgen check` prints it).
        let (swing, pitch, depth) = delta_pose(0.037233758, 0.027330909, 0.060, 0.1025, 0.35).unwrap();
        assert!((swing - 1.924).abs() < 5e-4, "{swing}");
        assert!((pitch - 2.274).abs() < 5e-4, "{pitch}");
        assert!((depth + 0.0988).abs() < 5e-5, "{depth}");
        // The shin's length is kept: |knee − platform joint| = b.
        let knee = (0.037233758 + 0.06 * 0.35f64.cos(), -0.06 * 0.35f64.sin());
        let joint = (0.027330909, depth);
        assert!(((knee.0 - joint.0).hypot(knee.1 - joint.1) - 0.1025).abs() < 1e-12);
        assert!(delta_pose(0.04, 0.0, 0.06, 0.02, 0.35).is_err(), "shins too short to reach the platform");
    }

    #[test]
    fn the_five_bar_home_has_square_elbows() {
        let (d, l, big_l) = (0.019, 0.07, 0.09);
        let (q1, height) = five_bar_home(d, l, big_l).unwrap();
        let elbow = (-d + l * q1.cos(), l * q1.sin());
        // The distal link from the elbow to the handle (0, height) has its length and is
        // square to the proximal link.
        let distal = (0.0 - elbow.0, height - elbow.1);
        assert!((distal.0.hypot(distal.1) - big_l).abs() < 1e-12);
        assert!((distal.0 * q1.cos() + distal.1 * q1.sin()).abs() < 1e-12);
        // The left branch: the left elbow lies left of the left motor's line to the handle.
        assert!(elbow.0 < -d, "{elbow:?}");
        assert!(five_bar_home(0.2, 0.05, 0.05).is_err());
    }

    #[test]
    fn numbers_are_written_with_a_decimal_point_and_no_noise() {
        assert_eq!(number(8.44 * 0.0154 * 7.72), "1.00341472");
        assert_eq!(number(3.0), "3.0");
        assert_eq!(number(1.7e-7), "1.7e-7");
        assert_eq!(number(0.0), "0.0");
    }
}

/// The motor options every template takes (defaults: the Falcon-like Delta's capstan motors).
#[derive(Clone, Debug, clap::Args)]
pub struct MotorArgs {
    /// Rotor inertia (`1.7e-7 kg m^2`).
    #[arg(long, default_value = "1.7e-7 kg m^2")]
    pub rotor_inertia: String,
    /// Winding resistance.
    #[arg(long, default_value = "2.1 ohm")]
    pub resistance: String,
    /// Winding inductance.
    #[arg(long, default_value = "1 mH")]
    pub inductance: String,
    /// Torque constant.
    #[arg(long, default_value = "0.0154 N m/A")]
    pub torque_constant: String,
    /// Motor turns per joint turn.
    #[arg(long, default_value = "7.72")]
    pub gear_ratio: String,
    /// Largest motor current.
    #[arg(long, default_value = "8.44 A")]
    pub current_limit: String,
    /// Supply voltage.
    #[arg(long, default_value = "30 V")]
    pub supply_voltage: String,
    /// Encoder counts per motor turn.
    #[arg(long, default_value_t = 1280)]
    pub counts_per_turn: u32,
}

impl MotorArgs {
    fn read(&self) -> Result<MotorData, TemplateError> {
        Ok(MotorData {
            rotor_inertia: Quantity::parse(&self.rotor_inertia, "rotor-inertia", quantity::INERTIA)?,
            resistance: Quantity::parse(&self.resistance, "resistance", quantity::RESISTANCE)?,
            inductance: Quantity::parse(&self.inductance, "inductance", quantity::INDUCTANCE)?,
            torque_constant: Quantity::parse(
                &self.torque_constant,
                "torque-constant",
                quantity::TORQUE_CONSTANT,
            )?,
            gear_ratio: Quantity::parse(&self.gear_ratio, "gear-ratio", quantity::ONE)?,
            current_limit: Quantity::parse(&self.current_limit, "current-limit", quantity::CURRENT)?,
            supply_voltage: Quantity::parse(&self.supply_voltage, "supply-voltage", quantity::VOLTAGE)?,
            counts_per_turn: self.counts_per_turn,
        })
    }
}

/// `hapticgen new`'s kinds of rig, each with its named dimensions (every quantity may carry a
/// unit, as in a model file).
#[derive(Clone, Debug, clap::Subcommand)]
pub enum NewRig {
    /// A Delta: three RUU legs at 0°, 120°, 240°, a translating platform (defaults: Falcon-like).
    Delta {
        /// The rig's name (snake_case; default: the output file's stem).
        #[arg(long)]
        name: Option<String>,
        /// Base centre to each thigh axis.
        #[arg(long, default_value = "37.233758 mm")]
        base_radius: String,
        /// Platform centre to each platform joint.
        #[arg(long, default_value = "27.330909 mm")]
        platform_radius: String,
        /// Thigh axis to knee.
        #[arg(long, default_value = "60 mm")]
        thigh_length: String,
        /// Knee to platform joint.
        #[arg(long, default_value = "102.5 mm")]
        shin_length: String,
        /// Each thigh's mass.
        #[arg(long, default_value = "20 g")]
        thigh_mass: String,
        /// Each shin's mass.
        #[arg(long, default_value = "10 g")]
        shin_mass: String,
        /// The platform's mass with its grip.
        #[arg(long, default_value = "60 g")]
        platform_mass: String,
        /// The thigh angles' lower limit (below the horizontal).
        #[arg(long, default_value = "-0.15", allow_hyphen_values = true)]
        lower: String,
        /// The thigh angles' upper limit.
        #[arg(long, default_value = "0.85")]
        upper: String,
        /// The motors.
        #[command(flatten)]
        motor: MotorArgs,
        /// The model file to write.
        #[arg(short, long)]
        output: std::path::PathBuf,
    },
    /// A planar five-bar (pantograph) with both motors on the base (defaults: Haply 2DIY-like).
    FiveBar {
        /// The rig's name (snake_case; default: the output file's stem).
        #[arg(long)]
        name: Option<String>,
        /// Half the distance between the motor axes.
        #[arg(long, default_value = "19 mm")]
        half_spacing: String,
        /// Each proximal (motor) link's length.
        #[arg(long, default_value = "70 mm")]
        proximal_length: String,
        /// Each distal link's length.
        #[arg(long, default_value = "90 mm")]
        distal_length: String,
        /// Each proximal link's mass.
        #[arg(long, default_value = "15 g")]
        proximal_mass: String,
        /// Each distal link's mass.
        #[arg(long, default_value = "12 g")]
        distal_mass: String,
        /// The handle's mass.
        #[arg(long, default_value = "10 g")]
        handle_mass: String,
        /// Each motor's range either side of the home pose.
        #[arg(long, default_value = "30 deg")]
        range: String,
        /// The motors.
        #[command(flatten)]
        motor: MotorArgs,
        /// The model file to write.
        #[arg(short, long)]
        output: std::path::PathBuf,
    },
    /// A planar serial arm of any number of links.
    Serial {
        /// The rig's name (snake_case; default: the output file's stem).
        #[arg(long)]
        name: Option<String>,
        /// Each link's length, comma-separated (`150 mm,120 mm`).
        #[arg(long, value_delimiter = ',', default_value = "150 mm,120 mm")]
        lengths: Vec<String>,
        /// Each link's mass, comma-separated.
        #[arg(long, value_delimiter = ',', default_value = "80 g,50 g")]
        masses: Vec<String>,
        /// Each joint's range either side of straight.
        #[arg(long, default_value = "150 deg")]
        range: String,
        /// The motors.
        #[command(flatten)]
        motor: MotorArgs,
        /// The model file to write.
        #[arg(short, long)]
        output: std::path::PathBuf,
    },
}

/// The rig's name: as given, else the output file's stem made a snake_case identifier.
fn rig_name(name: &Option<String>, output: &Path) -> String {
    if let Some(name) = name {
        return name.clone();
    }
    let stem = output.file_stem().map(|s| s.to_string_lossy().to_lowercase()).unwrap_or_default();
    let mut ident: String = stem.chars().map(|c| if c.is_ascii_alphanumeric() { c } else { '_' }).collect();
    if !ident.starts_with(|c: char| c.is_ascii_alphabetic()) {
        ident.insert_str(0, "rig_");
    }
    ident
}

/// `hapticgen new`: the model file's text for `rig`, checked and written to its output.
pub fn run_new(rig: &NewRig) -> Result<(std::path::PathBuf, Written), TemplateError> {
    let q = Quantity::parse;
    let (text, output) = match rig {
        NewRig::Delta {
            name,
            base_radius,
            platform_radius,
            thigh_length,
            shin_length,
            thigh_mass,
            shin_mass,
            platform_mass,
            lower,
            upper,
            motor,
            output,
        } => {
            let spec = DeltaSpec {
                name: rig_name(name, output),
                base_radius: q(base_radius, "base-radius", quantity::LENGTH)?,
                platform_radius: q(platform_radius, "platform-radius", quantity::LENGTH)?,
                thigh_length: q(thigh_length, "thigh-length", quantity::LENGTH)?,
                shin_length: q(shin_length, "shin-length", quantity::LENGTH)?,
                thigh_mass: q(thigh_mass, "thigh-mass", quantity::MASS)?,
                shin_mass: q(shin_mass, "shin-mass", quantity::MASS)?,
                platform_mass: q(platform_mass, "platform-mass", quantity::MASS)?,
                lower: q(lower, "lower", quantity::ANGLE)?,
                upper: q(upper, "upper", quantity::ANGLE)?,
                motor: motor.read()?,
            };
            (delta(&spec)?, output)
        }
        NewRig::FiveBar {
            name,
            half_spacing,
            proximal_length,
            distal_length,
            proximal_mass,
            distal_mass,
            handle_mass,
            range,
            motor,
            output,
        } => {
            let spec = FiveBarSpec {
                name: rig_name(name, output),
                half_spacing: q(half_spacing, "half-spacing", quantity::LENGTH)?,
                proximal_length: q(proximal_length, "proximal-length", quantity::LENGTH)?,
                distal_length: q(distal_length, "distal-length", quantity::LENGTH)?,
                proximal_mass: q(proximal_mass, "proximal-mass", quantity::MASS)?,
                distal_mass: q(distal_mass, "distal-mass", quantity::MASS)?,
                handle_mass: q(handle_mass, "handle-mass", quantity::MASS)?,
                range: q(range, "range", quantity::ANGLE)?,
                motor: motor.read()?,
            };
            (five_bar(&spec)?, output)
        }
        NewRig::Serial { name, lengths, masses, range, motor, output } => {
            let spec = SerialSpec {
                name: rig_name(name, output),
                lengths: lengths
                    .iter()
                    .map(|l| q(l, "lengths", quantity::LENGTH))
                    .collect::<Result<_, _>>()?,
                masses: masses.iter().map(|m| q(m, "masses", quantity::MASS)).collect::<Result<_, _>>()?,
                range: q(range, "range", quantity::ANGLE)?,
                motor: motor.read()?,
            };
            (serial(&spec)?, output)
        }
    };
    let written = write_checked(&text, output)?;
    Ok((output.clone(), written))
}
