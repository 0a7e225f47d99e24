//! Diagnostics for bad model files: one test per kind of mistake, each with its own fixture
//! in `tests/bad-models/` (a shipped or good model with exactly one problem). Every test
//! asserts the line and column (found by searching the fixture for the offending token), the
//! key path and the rule text. Plus: every diagnostic reads `file:line:column: …`, values a
//! variant overrides are reported at the variant's line, and mangled models never panic.

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};

use hapticgen_codegen::load;
use hapticgen_codegen::model::Source;
use hapticgen_codegen::{Diagnostic, Diagnostics};

/// Every fixture of `tests/bad-models/` and the variant it is loaded with.
const CASES: &[(&str, Option<&str>)] = &[
    ("closure-actuated-joint", None),
    ("closure-points-swapped", None),
    ("closure-spatial", None),
    ("closure-unreachable", None),
    ("spatial-closure-cannot-close", None),
    ("spatial-closure-over-constrained", None),
    ("spatial-closure-singular", None),
    ("spatial-closure-under-constrained", None),
    ("com-three-entries", None),
    ("current-loop-infeasible", None),
    ("dh-and-origin", None),
    ("dh-axis-not-z", None),
    ("dh-planar", None),
    ("dh-undefined-parameter", None),
    ("dh-unknown-convention", None),
    ("dh-unknown-key", None),
    ("duplicate-joint", None),
    ("duplicate-key", None),
    ("empty-value", None),
    ("filter-order", None),
    ("frame-clashes-with-point", None),
    ("frame-duplicate", None),
    ("frame-planar", None),
    ("frame-rpy-entries", None),
    ("frame-unknown-body", None),
    ("frame-unknown-key", None),
    ("gravity-three-entries", None),
    ("impedance-faster-than-current", None),
    ("inertia-not-positive-definite", None),
    ("inertia-triangle-inequality", None),
    ("inf-literal", None),
    ("transmission-singular", None),
    ("transmission-unknown-joint", None),
    ("transmission-unknown-row", None),
    ("joint-moves-no-body", None),
    ("limits-inverted", None),
    ("measured-body-with-mass", None),
    ("measured-point", None),
    ("measured-with-drive", None),
    ("mimic-multiplier", None),
    ("mimic-not-actuated", None),
    ("missing-key", None),
    ("nan-literal", None),
    ("negative-counts", None),
    ("negative-mass", None),
    ("negative-resistance", None),
    ("parent-cycle", None),
    ("passive-not-closed", None),
    ("passive-prismatic", None),
    ("passive-with-drive", None),
    ("pose-parent-cycle", None),
    ("pose-plane-cycle", None),
    ("pose-planar-plane", None),
    ("pose-spatial-no-plane", None),
    ("scalar-inertia-spatial", None),
    ("spherical-angle-as-joint", None),
    ("spherical-assembly-count", None),
    ("spherical-axes-in-one-plane", None),
    ("spherical-axis-zero", None),
    ("spherical-damped", None),
    ("spherical-invalid-name", None),
    ("spherical-moves-two-bodies", None),
    ("spherical-name-clash", None),
    ("spherical-coordinate-name", None),
    ("spherical-not-passive", None),
    ("task-unknown-point", None),
    ("undefined-drive", None),
    ("undefined-joint", None),
    ("undefined-parameter", None),
    ("undefined-parent", None),
    ("undefined-pose-origin", None),
    ("unknown-default-variant", None),
    ("unknown-joint-type", None),
    ("unknown-key-nested", None),
    ("unknown-key-top", None),
    ("unknown-variant", Some("nope")),
    ("variant-negative-mass", Some("horizontal")),
    ("variant-remove-unknown", None),
    ("variant-set-unknown-path", Some("horizontal")),
    ("variants-without-default", None),
    ("wrong-type", None),
    ("yaml-syntax", None),
    ("zero-gear-ratio", None),
    ("unit-wrong-dimension", None),
    ("expression-unknown-parameter", None),
    ("expression-unknown-function", None),
    ("expression-bad-token", None),
    ("expression-division-by-zero", None),
    ("expression-not-finite", None),
    ("expression-tunable-in-function", None),
    ("expression-tunable-in-fixed-field", None),
    ("parameter-cycle", None),
    ("drive-like-unknown", None),
    ("drive-like-cycle", None),
    ("inertia-shape-incomplete", None),
    ("value-not-a-number", None),
];

fn manifest_dir() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn fixture_path(name: &str) -> PathBuf {
    manifest_dir().join("tests/bad-models").join(format!("{name}.yaml"))
}

fn fixture(name: &str) -> String {
    let path = fixture_path(name);
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()))
}

/// Loads the fixture, which must be rejected; returns its text and the diagnostics.
fn reject(name: &str, variant: Option<&str>) -> (String, Diagnostics) {
    let text = fixture(name);
    let file = format!("{name}.yaml");
    match load(&Source { name: &file, text: &text }, variant) {
        Ok(_) => panic!("{file} (variant {variant:?}) was accepted"),
        Err(d) => {
            assert!(!d.0.is_empty(), "{file}: an error without diagnostics");
            (text, d)
        }
    }
}

/// 1-based line and column (in characters) of `token` inside `context`, where `context`
/// occurs exactly once in `text`.
fn locate(text: &str, context: &str, token: &str) -> (usize, usize) {
    let matches: Vec<usize> = text.match_indices(context).map(|(i, _)| i).collect();
    assert_eq!(
        matches.len(),
        1,
        "`{context}` must occur exactly once in the fixture, found {}",
        matches.len()
    );
    let within = context.find(token).unwrap_or_else(|| panic!("`{token}` is not part of `{context}`"));
    let offset = matches[0] + within;
    let before = &text[..offset];
    let line = before.matches('\n').count() + 1;
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    (line, text[line_start..offset].chars().count() + 1)
}

/// What a test expects of the first diagnostic.
struct Expect<'a> {
    /// A snippet occurring once in the fixture …
    context: &'a str,
    /// … and the token in it the diagnostic must point at.
    token: &'a str,
    path: &'a str,
    message: &'a str,
}

/// Loads a fixture and checks its first diagnostic; returns all of them for further checks.
fn check(name: &str, variant: Option<&str>, expect: Expect<'_>) -> Diagnostics {
    let (text, diagnostics) = reject(name, variant);
    let d = &diagnostics.0[0];
    let (line, column) = locate(&text, expect.context, expect.token);
    assert_eq!(d.file, format!("{name}.yaml"));
    assert_eq!(
        (d.line, d.column, d.path.as_str(), d.message.as_str()),
        (line, column, expect.path, expect.message),
        "{name}: unexpected diagnostic\n{diagnostics}"
    );
    diagnostics
}

fn hint(d: &Diagnostic) -> &str {
    d.hint.as_deref().unwrap_or_default()
}

#[test]
fn yaml_syntax_error() {
    let d = check(
        "yaml-syntax",
        None,
        Expect {
            context: "description: angle: from",
            token: ": from",
            path: "",
            message: "invalid YAML: mapping values are not allowed in this context",
        },
    );
    assert_eq!(d.0.len(), 1);
}

#[test]
fn duplicate_key_points_at_the_repetition() {
    let d = check(
        "duplicate-key",
        None,
        Expect {
            context: "    mass: 0.06",
            token: "mass",
            path: "bodies[1].mass",
            message: "duplicate key `mass`",
        },
    );
    assert_eq!(hint(&d.0[0]), "a key may appear only once in a mapping");
}

#[test]
fn empty_value_points_at_its_key() {
    check(
        "empty-value",
        None,
        Expect {
            context: "inductance:\n",
            token: "inductance",
            path: "drives.re40_gp42.motor.inductance",
            message: "expected a number, got an empty value",
        },
    );
}

#[test]
fn wrong_type_string_for_number() {
    check(
        "wrong-type",
        None,
        Expect {
            context: "gear_ratio: twelve",
            token: "twelve",
            path: "drives.re40_gp42.gear_ratio",
            message: "unknown parameter `twelve`",
        },
    );
}

#[test]
fn negative_number_for_a_count() {
    check(
        "negative-counts",
        None,
        Expect {
            context: "counts_per_turn: -2000",
            token: "-2000",
            path: "drives.re40_gp42.encoder.counts_per_turn",
            message: "expected a whole number from 0 to 4294967295, got integer `-2000`",
        },
    );
}

#[test]
fn unknown_value_of_a_fixed_set() {
    let d = check(
        "unknown-joint-type",
        None,
        Expect {
            context: "type: rotary",
            token: "rotary",
            path: "joints[0].type",
            message: "unknown value `rotary`",
        },
    );
    assert_eq!(hint(&d.0[0]), "expected one of `revolute`, `prismatic`, `universal`, `spherical`");
}

#[test]
fn unknown_key_at_top_level() {
    let d = check(
        "unknown-key-top",
        None,
        Expect { context: "colour: red", token: "colour", path: "colour", message: "unknown key `colour`" },
    );
    assert!(hint(&d.0[0]).starts_with("expected one of `name`, `description`, `space`"), "{}", d.0[0]);
}

#[test]
fn unknown_key_nested() {
    let d = check(
        "unknown-key-nested",
        None,
        Expect {
            context: "winding: copper",
            token: "winding",
            path: "drives.re40_gp42.motor.winding",
            message: "unknown key `winding`",
        },
    );
    assert_eq!(
        hint(&d.0[0]),
        "expected one of `rotor_inertia`, `resistance`, `inductance`, `torque_constant`"
    );
}

#[test]
fn missing_key_points_at_the_mapping() {
    // The joint mapping starts at its first key, `name` (not at the first key's `:`).
    check(
        "missing-key",
        None,
        Expect { context: "  - name: q\n", token: "name", path: "joints[0]", message: "missing key `drive`" },
    );
}

#[test]
fn non_positive_mass() {
    check(
        "negative-mass",
        None,
        Expect {
            context: "mass: -0.020358",
            token: "-0.020358",
            path: "bodies[0].mass",
            message: "must be positive, got -0.020358",
        },
    );
}

#[test]
fn zero_gear_ratio() {
    check(
        "zero-gear-ratio",
        None,
        Expect {
            context: "gear_ratio: 0.0",
            token: "0.0",
            path: "drives.re40_gp42.gear_ratio",
            message: "must be positive, got 0",
        },
    );
}

#[test]
fn negative_resistance() {
    check(
        "negative-resistance",
        None,
        Expect {
            context: "resistance: -0.299",
            token: "-0.299",
            path: "drives.re40_gp42.motor.resistance",
            message: "must be positive, got -0.299",
        },
    );
}

#[test]
fn inertia_tensor_not_positive_definite() {
    // ixx = iyy = 6e-4 with ixy = 8e-4: principal moments −2e-4, 4e-4 (izz) and 1.4e-3.
    let d = check(
        "inertia-not-positive-definite",
        None,
        Expect {
            context: "inertia: {ixx: 6.0e-4, iyy: 6.0e-4, izz: 4.0e-4, ixy: 8.0e-4}",
            token: "{",
            path: "bodies[0].inertia",
            message: "invalid inertia tensor: not positive semi-definite \
                      (principal moments -2.000000e-4, 4.000000e-4, 1.400000e-3)",
        },
    );
    assert!(hint(&d.0[0]).contains("positive (semi-)definite"));
    assert_eq!(d.0.len(), 1, "{d}");
}

#[test]
fn inertia_tensor_violating_the_triangle_inequality() {
    let d = check(
        "inertia-triangle-inequality",
        None,
        Expect {
            context: "inertia: {ixx: 1.0e-6, iyy: 2.0e-6, izz: 5.0e-6}",
            token: "{",
            path: "bodies[3].inertia",
            message: "invalid inertia tensor: principal moments 1.000000e-6, 2.000000e-6, 5.000000e-6 \
                      violate the triangle inequality",
        },
    );
    assert!(hint(&d.0[0]).contains("at most the sum of the other two"));
}

#[test]
fn scalar_inertia_in_a_spatial_model() {
    let d = check(
        "scalar-inertia-spatial",
        None,
        Expect {
            context: "inertia: 5.0e-6",
            token: "5.0e-6",
            path: "bodies[3].inertia",
            message: "invalid inertia: a spatial model takes a full tensor",
        },
    );
    assert!(hint(&d.0[0]).contains("{ixx, iyy, izz, ixy, ixz, iyz}"));
}

#[test]
fn dh_and_origin_together() {
    let d = check(
        "dh-and-origin",
        None,
        Expect {
            context: "    dh: {convention: modified, alpha: 1.5707963267948966}",
            token: "{",
            path: "bodies[1].dh",
            message: "body `upper_arm` has both `origin` and `dh`",
        },
    );
    assert!(hint(&d.0[0]).contains("either `origin`"));
    assert_eq!(d.0.len(), 1, "{d}");
}

#[test]
fn dh_joint_axis_must_be_z() {
    let d = check(
        "dh-axis-not-z",
        None,
        Expect {
            context: "axis: [0.0, 1.0, 0.0]",
            token: "[",
            path: "joints[1].axis",
            message: "joint `shoulder` moves body `upper_arm`, placed with Denavit–Hartenberg parameters: \
                      its axis must be z",
        },
    );
    assert!(hint(&d.0[0]).contains("`theta` and `alpha`"));
    assert_eq!(d.0.len(), 1, "{d}");
}

#[test]
fn dh_in_a_planar_model() {
    let d = check(
        "dh-planar",
        None,
        Expect {
            context: "dh: {convention: standard, a: l1}",
            token: "{",
            path: "bodies[1].dh",
            message: "Denavit–Hartenberg parameters need a spatial model",
        },
    );
    assert_eq!(d.0.len(), 1, "{d}");
}

#[test]
fn dh_length_naming_no_parameter() {
    let d = check(
        "dh-undefined-parameter",
        None,
        Expect { context: "a: l3,", token: "l3", path: "bodies[2].dh.a", message: "unknown parameter `l3`" },
    );
    assert_eq!(hint(&d.0[0]), "defined parameters: l1, l2");
}

#[test]
fn dh_unknown_convention() {
    let d = check(
        "dh-unknown-convention",
        None,
        Expect {
            context: "convention: craig",
            token: "craig",
            path: "bodies[2].dh.convention",
            message: "unknown value `craig`",
        },
    );
    assert_eq!(hint(&d.0[0]), "expected `standard` or `modified`");
}

#[test]
fn dh_unknown_key() {
    let d = check(
        "dh-unknown-key",
        None,
        Expect {
            context: "offset: -1.57",
            token: "offset",
            path: "bodies[2].dh.offset",
            message: "unknown key `offset`",
        },
    );
    assert_eq!(hint(&d.0[0]), "expected one of `convention`, `a`, `alpha`, `d`, `theta`");
}

#[test]
fn undefined_joint() {
    let d = check(
        "undefined-joint",
        None,
        Expect {
            context: "joint: q9",
            token: "q9",
            path: "bodies[0].joint",
            message: "body `stick` references unknown joint `q9`",
        },
    );
    assert_eq!(hint(&d.0[0]), "defined joints: q");
}

#[test]
fn undefined_parent_body() {
    check(
        "undefined-parent",
        None,
        Expect {
            context: "parent: stik",
            token: "stik",
            path: "bodies[1].parent",
            message: "body `grip` references unknown body `stik`",
        },
    );
}

#[test]
fn undefined_pose_origin_body() {
    check(
        "undefined-pose-origin",
        None,
        Expect {
            context: "{body: link7,",
            token: "link7",
            path: "bodies[2].pose.origin.body",
            message: "body `link3` references unknown body `link7`",
        },
    );
}

#[test]
fn undefined_drive() {
    let d = check(
        "undefined-drive",
        None,
        Expect {
            context: "drive: re50",
            token: "re50",
            path: "joints[0].drive",
            message: "joint `q` references unknown drive `re50`",
        },
    );
    assert_eq!(hint(&d.0[0]), "defined drives: re40_gp42");
}

#[test]
fn undefined_parameter() {
    let d = check(
        "undefined-parameter",
        None,
        Expect {
            context: "point: [l_x, 0.0]",
            token: "l_x",
            path: "bodies[3].pose.origin.point[0]",
            message: "unknown parameter `l_x`",
        },
    );
    assert_eq!(hint(&d.0[0]), "defined parameters: l_e, l_l");
}

#[test]
fn parents_forming_a_cycle() {
    let d = check(
        "parent-cycle",
        None,
        Expect {
            context: "  - name: stick\n",
            token: "name",
            path: "bodies[0]",
            message: "bodies form a cycle: stick → grip → stick",
        },
    );
    assert_eq!(d.0.len(), 1, "{d}");
}

#[test]
fn parent_and_pose_forming_a_cycle() {
    check(
        "pose-parent-cycle",
        None,
        Expect {
            context: "  - name: link1\n",
            token: "name",
            path: "bodies[0]",
            message: "bodies form a cycle: link1 → link4 → link1",
        },
    );
}

#[test]
fn a_pose_and_its_plane_forming_a_cycle() {
    let d = check(
        "pose-plane-cycle",
        None,
        Expect {
            context: "  - name: upper_arm\n",
            token: "name",
            path: "bodies[1]",
            message: "bodies form a cycle: upper_arm → forearm → upper_arm",
        },
    );
    assert_eq!(d.0.len(), 1, "one cycle, reported once: {d}");
}

#[test]
fn a_spatial_direct_pose_names_its_plane() {
    check(
        "pose-spatial-no-plane",
        None,
        Expect {
            context: "      origin: {body: upper_arm, point: [l1, 0.0, 0.0]}",
            token: "origin",
            path: "bodies[2].pose",
            message: "body `forearm`: a spatial direct pose names the plane its angle turns in",
        },
    );
}

#[test]
fn a_planar_direct_pose_turns_in_the_base_plane() {
    check(
        "pose-planar-plane",
        None,
        Expect {
            context: "      plane: {body: base}",
            token: "{",
            path: "bodies[2].pose.plane",
            message: "body `link3`: a planar model's direct pose turns in the base plane",
        },
    );
}

#[test]
fn a_measured_joint_has_no_drive() {
    check(
        "measured-with-drive",
        None,
        Expect {
            context: "    drive: arm_capstan\n    measured",
            token: "arm_capstan",
            path: "joints[4].drive",
            message: "joint `gimbal_pitch` is measured: it takes no `drive`",
        },
    );
}

#[test]
fn a_measured_joint_s_bodies_are_massless() {
    check(
        "measured-body-with-mass",
        None,
        Expect {
            context: "mass: 0.005",
            token: "0.005",
            path: "bodies[7].mass",
            message: "body `gimbal_yoke` turns with measured joint `gimbal_pitch`, whose bodies are lumped (`dynamics: lumped`): it must be massless",
        },
    );
}

#[test]
fn no_point_turns_with_a_measured_joint() {
    check(
        "measured-point",
        None,
        Expect {
            context: "    body: stylus\n    position",
            token: "stylus",
            path: "points[0].body",
            message: "point `stylus_tip` turns with measured joint `stylus_spin`: it would not be a function of the actuated joints",
        },
    );
}

#[test]
fn a_revolute_mimic_joint_turns_by_plus_or_minus_its_leader() {
    check(
        "mimic-multiplier",
        None,
        Expect {
            context: "multiplier: 2.0",
            token: "2.0",
            path: "joints[4].mimic.multiplier",
            message: "a revolute mimic joint's multiplier must be 1 or -1, not 2",
        },
    );
}

#[test]
fn a_mimic_joint_follows_an_actuated_joint() {
    check(
        "mimic-not-actuated",
        None,
        Expect {
            context: "mimic: {joint: finger_joint",
            token: "finger_joint",
            path: "joints[4].mimic.joint",
            message: "joint `plate` mimics `finger_joint`, which is no actuated joint",
        },
    );
}

#[test]
fn planar_com_with_three_entries() {
    check(
        "com-three-entries",
        None,
        Expect {
            context: "com: [0.0, 0.075, 0.0]",
            token: "[",
            path: "bodies[0].com",
            message: "expected 2 entries (x, y), got 3",
        },
    );
}

#[test]
fn planar_gravity_with_three_entries() {
    check(
        "gravity-three-entries",
        None,
        Expect {
            context: "gravity: [0.0, -9.81, 0.0]",
            token: "[",
            path: "gravity",
            message: "expected 2 entries (x, y), got 3",
        },
    );
}

#[test]
fn unknown_variant_lists_the_known_ones() {
    let d = check(
        "unknown-variant",
        Some("nope"),
        Expect { context: "\nvariants:", token: "variants", path: "", message: "unknown variant `nope`" },
    );
    assert_eq!(hint(&d.0[0]), "the model defines: horizontal, vertical");
}

#[test]
fn unknown_default_variant() {
    let d = check(
        "unknown-default-variant",
        None,
        Expect {
            context: "default_variant: upright",
            token: "upright",
            path: "default_variant",
            message: "unknown variant `upright`",
        },
    );
    assert_eq!(hint(&d.0[0]), "the model defines: horizontal, vertical");
}

#[test]
fn variants_without_a_default() {
    let d = check(
        "variants-without-default",
        None,
        Expect {
            context: "\nvariants:",
            token: "variants",
            path: "variants",
            message: "a model with variants must name one of them as `default_variant`",
        },
    );
    assert_eq!(hint(&d.0[0]), "the model defines: horizontal, vertical");
}

#[test]
fn variant_set_path_naming_nothing() {
    check(
        "variant-set-unknown-path",
        Some("horizontal"),
        Expect {
            context: "bodies.link9.mass: 0.1",
            token: "bodies.link9.mass",
            path: "variants.horizontal.set.bodies.link9.mass",
            message:
                "`bodies.link9.mass` does not name a value of the model: no item named `link9` in `bodies`",
        },
    );
    // The default variant does not touch the bad path.
    let text = fixture("variant-set-unknown-path");
    assert!(load(&Source { name: "v.yaml", text: &text }, None).is_ok());
}

#[test]
fn variant_remove_path_naming_nothing() {
    check(
        "variant-remove-unknown",
        None,
        Expect {
            context: "remove: [sensors.wrist_force]",
            token: "sensors.wrist_force",
            path: "variants.bare.remove[0]",
            message: "`sensors.wrist_force` does not name an item of the model",
        },
    );
}

#[test]
fn value_set_by_a_variant_is_reported_at_the_variant() {
    let d = check(
        "variant-negative-mass",
        Some("horizontal"),
        Expect {
            context: "bodies.link1.mass: -1",
            token: "-1",
            path: "bodies[0].mass",
            message: "must be positive, got -1",
        },
    );
    assert_eq!(d.0.len(), 1, "{d}");
    // The base file's own mass of link1 is fine: the default variant loads.
    let text = fixture("variant-negative-mass");
    assert!(load(&Source { name: "v.yaml", text: &text }, Some("vertical")).is_ok());
}

#[test]
fn nan_literal() {
    check(
        "nan-literal",
        None,
        Expect {
            context: "damping: .nan",
            token: ".nan",
            path: "joints[0].damping",
            message: "must be a finite number, got NaN",
        },
    );
}

#[test]
fn infinite_literal() {
    check(
        "inf-literal",
        None,
        Expect {
            context: "torque_limit: .inf",
            token: ".inf",
            path: "drives.re40_gp42.torque_limit",
            message: "must be a finite number, got inf",
        },
    );
}

#[test]
fn duplicate_joint_name() {
    let d = check(
        "duplicate-joint",
        None,
        Expect {
            context: "  - name: q\n    type: revolute\n    limits",
            token: "q",
            path: "joints[1].name",
            message: "joint `q` is defined twice",
        },
    );
    assert_eq!(hint(&d.0[0]), "the first definition is `joints[0]`");
    // Only the duplicate is reported: bodies still find the first `q`, and the duplicate is
    // not also reported as moving no body.
    assert_eq!(d.0.len(), 1, "{d}");
}

#[test]
fn joint_limits_lower_not_below_upper() {
    check(
        "limits-inverted",
        None,
        Expect {
            context: "limits: {lower: 1.5, upper: -1.5}",
            token: "{",
            path: "joints[0].limits",
            message: "lower limit 1.5 must be below upper limit -1.5",
        },
    );
}

#[test]
fn impedance_rate_above_current_rate() {
    check(
        "impedance-faster-than-current",
        None,
        Expect {
            context: "impedance_loop_hz: 10000",
            token: "10000",
            path: "rates.impedance_loop_hz",
            message: "the impedance loop (10000 Hz) cannot run faster than the current loop (7500 Hz)",
        },
    );
}

#[test]
fn task_naming_an_unknown_point() {
    check(
        "task-unknown-point",
        None,
        Expect {
            context: "point: end_efector",
            token: "end_efector",
            path: "task.point",
            message: "task references unknown point `end_efector`",
        },
    );
}

#[test]
fn joint_that_moves_no_body() {
    let d = check(
        "joint-moves-no-body",
        None,
        Expect {
            context: "name: spare",
            token: "spare",
            path: "joints[0].name",
            message: "joint `spare` moves no body",
        },
    );
    assert_eq!(d.0.len(), 1, "{d}");
}

#[test]
fn current_loop_without_a_design() {
    // 2000 Hz is below the current loop's Nyquist frequency (3750 Hz) but too close to it for
    // the PI design, which needs the bandwidth below half of it: the validation says so at the
    // value, with the limit, as the reference's table does (`current_loop_hz / 4`).
    let d = check(
        "current-loop-infeasible",
        None,
        Expect {
            context: "bandwidth_hz: 2000",
            token: "2000",
            path: "current_loop.bandwidth_hz",
            message: "must be below a quarter of `rates.current_loop_hz` (1875 Hz, half the current loop's \
                      Nyquist frequency), got 2000 Hz",
        },
    );
    assert_eq!(d.0.len(), 1, "{d}");
}

#[test]
fn anti_alias_filter_order_out_of_range() {
    check(
        "filter-order",
        None,
        Expect {
            context: "anti_alias_filter_order: 5",
            token: "5",
            path: "current_loop.anti_alias_filter_order",
            message: "must be 1, 2, 3 or 4, got 5",
        },
    );
}

/// Every fixture is listed in `CASES`, and every diagnostic of every fixture reads
/// `file:line:column: ` and points inside the file.
#[test]
fn every_diagnostic_starts_with_file_line_column() {
    let mut on_disk: Vec<String> = std::fs::read_dir(manifest_dir().join("tests/bad-models"))
        .expect("tests/bad-models")
        .map(|e| e.expect("directory entry").file_name().to_string_lossy().into_owned())
        .filter_map(|n| n.strip_suffix(".yaml").map(str::to_string))
        .collect();
    on_disk.sort();
    let mut listed: Vec<String> = CASES.iter().map(|(n, _)| n.to_string()).collect();
    listed.sort();
    assert_eq!(on_disk, listed, "every fixture in tests/bad-models/ needs an entry in CASES");

    for (name, variant) in CASES {
        let (text, diagnostics) = reject(name, *variant);
        let lines = text.lines().count();
        for d in &diagnostics.0 {
            let shown = d.to_string();
            let prefix = format!("{name}.yaml:{}:{}: ", d.line, d.column);
            assert!(shown.starts_with(&prefix), "{name}: `{shown}` does not start with `{prefix}`");
            assert!(d.line >= 1 && d.line <= lines, "{name}: line {} outside the file: {shown}", d.line);
            let width = text.lines().nth(d.line - 1).unwrap_or_default().chars().count();
            assert!(
                d.column >= 1 && d.column <= width + 1,
                "{name}: column {} outside line: {shown}",
                d.column
            );
            assert!(!d.message.is_empty() && !d.message.ends_with('.'), "{name}: message style: {shown}");
        }
        assert!(diagnostics.to_string().starts_with(&format!("error: {name}.yaml:")));
    }
}

/// Mutations of a model text: truncations, deleted and duplicated lines (not comments),
/// digits turned into letters.
fn mutations(text: &str) -> Vec<(String, String)> {
    let mut out = Vec::new();
    let boundaries: Vec<usize> = text.char_indices().map(|(i, _)| i).collect();
    for &cut in boundaries.iter().step_by(53) {
        out.push((format!("truncated at byte {cut}"), text[..cut].to_string()));
    }
    let lines: Vec<&str> = text.lines().collect();
    for i in 0..lines.len() {
        // Deleting or repeating a comment or blank line changes nothing.
        if lines[i].trim().is_empty() || lines[i].trim_start().starts_with('#') {
            continue;
        }
        let mut deleted = lines.clone();
        deleted.remove(i);
        out.push((format!("line {} deleted", i + 1), deleted.join("\n")));
        if i % 4 == 0 {
            let mut doubled = lines.clone();
            doubled.insert(i, lines[i]);
            out.push((format!("line {} duplicated", i + 1), doubled.join("\n")));
        }
    }
    let digits: Vec<usize> =
        text.char_indices().filter(|(_, c)| c.is_ascii_digit()).map(|(i, _)| i).collect();
    for (k, &i) in digits.iter().step_by(11).enumerate() {
        let letter = ["O", "l", "e", "x"][k % 4];
        out.push((
            format!("digit at byte {i} replaced by {letter}"),
            format!("{}{letter}{}", &text[..i], &text[i + 1..]),
        ));
    }
    out
}

#[test]
fn mutated_models_never_panic() {
    let mut sources: Vec<PathBuf> = Vec::new();
    let shipped = manifest_dir().join("../models");
    for entry in std::fs::read_dir(&shipped).unwrap_or_else(|e| panic!("{}: {e}", shipped.display())) {
        let path = entry.expect("directory entry").path();
        if path.extension().is_some_and(|e| e == "yaml") {
            sources.push(path);
        }
    }
    sources.sort();
    assert!(sources.len() >= 2, "expected the shipped models, found {sources:?}");

    let (mut total, mut rejected) = (0, 0);
    let mut failures = Vec::new();
    for path in &sources {
        let text = std::fs::read_to_string(path).expect("model text");
        for (what, mutated) in mutations(&text) {
            total += 1;
            let result =
                catch_unwind(AssertUnwindSafe(|| load(&Source { name: "m.yaml", text: &mutated }, None)));
            match result {
                Err(_) => failures.push(format!("{}: {what}: load panicked", path.display())),
                Ok(Ok(_)) => {}
                Ok(Err(diagnostics)) => {
                    rejected += 1;
                    let lines = mutated.lines().count().max(1);
                    for d in &diagnostics.0 {
                        if d.line < 1 || d.line > lines + 1 || d.column < 1 {
                            failures
                                .push(format!("{}: {what}: position outside the text: {d}", path.display()));
                        }
                    }
                }
            }
        }
    }
    assert!(total >= 300, "only {total} mutations");
    assert!(rejected > total / 4, "suspiciously few mutations rejected: {rejected} of {total}");
    assert!(failures.is_empty(), "{} of {total} mutations failed:\n{}", failures.len(), failures.join("\n"));
}

#[test]
fn closure_naming_an_actuated_joint() {
    let d = check(
        "closure-actuated-joint",
        None,
        Expect {
            context: "joints: [q1, right_elbow]",
            token: "q1",
            path: "closures[0].joints[0]",
            message: "joint `q1` is actuated: a closure eliminates passive joints",
        },
    );
    // The passive joint it should have named is left over.
    assert_eq!(d.0[1].message, "passive joint `left_elbow` is not eliminated by any closure");
}

#[test]
fn passive_joint_with_a_drive() {
    check(
        "passive-with-drive",
        None,
        Expect {
            context: "passive: true\n    drive: direct",
            token: "direct",
            path: "joints[2].drive",
            message: "joint `left_elbow` is passive: it has no drive",
        },
    );
}

#[test]
fn passive_joint_without_a_closure() {
    let d = check(
        "passive-not-closed",
        None,
        Expect {
            context: "left proximal link\n    passive: true",
            token: "true",
            path: "joints[2].passive",
            message: "passive joint `left_elbow` is not eliminated by any closure",
        },
    );
    assert_eq!(d.0.len(), 2);
}

#[test]
fn closure_that_cannot_close() {
    let (text, d) = reject("closure-unreachable", None);
    let (line, column) = locate(&text, "  - name: tip\n", "name");
    let first = &d.0[0];
    assert_eq!((first.line, first.column, first.path.as_str()), (line, column, "closures[0]"));
    assert!(
        first.message.starts_with(
            "the loop cannot close at the middle of the actuated joints' ranges (q1 = 2.0500, q2 = 1.0900)"
        ) && first.message.ends_with("do not intersect: they are too far apart"),
        "{first}"
    );
}

#[test]
fn closure_points_paired_with_the_wrong_joints() {
    check(
        "closure-points-swapped",
        None,
        Expect {
            context: "points: [right_tip, end_effector]",
            token: "[right_tip",
            path: "closures[0].points",
            message: "point `right_tip` moves with passive joint `right_elbow`, but it must hang on the link of `left_elbow`",
        },
    );
}

#[test]
fn planar_closure_keys_in_a_spatial_model() {
    let d = check(
        "closure-spatial",
        None,
        Expect {
            context: "    joints: [a, b]",
            token: "[a, b]",
            path: "closures[0].joints",
            message: "a spatial closure does not name joints",
        },
    );
    assert!(
        d.0.iter()
            .any(|d| d.path == "closures[0].branch" && d.message == "a spatial closure has no `branch`"),
        "{d}"
    );
}

/// A spherical joint written as one entry: its rules, and the rules of its three revolute
/// angles, reported at the entry as written (`axes[1]`, `coordinates[1]`), not at the expanded
/// joints the loader makes of it.
#[test]
fn spherical_joint_axes_in_one_plane() {
    let d = check(
        "spherical-axes-in-one-plane",
        None,
        Expect {
            context: "axes: [[1.0, 2.0, 3.0], [2.0, -1.0, 0.5], [3.0, 1.0, 3.5]]",
            token: "[[1.0",
            path: "joints[1].axes",
            message: "the axes of spherical joint `ball` are in one plane: it would lose a rotation",
        },
    );
    assert_eq!(d.0.len(), 1, "{d}");
}

#[test]
fn spherical_joint_zero_axis_is_reported_at_that_axis() {
    let d = check(
        "spherical-axis-zero",
        None,
        Expect {
            context: "[0.0, 0.0, 0.0], [0.0, 0.0, 1.0]]",
            token: "[0.0, 0.0, 0.0]",
            path: "joints[1].axes[1]",
            message: "must not be the zero vector",
        },
    );
    assert_eq!(d.0.len(), 1, "{d}");
}

#[test]
fn spherical_joint_assembly_has_one_angle_per_axis() {
    check(
        "spherical-assembly-count",
        None,
        Expect {
            context: "assembly: [0.0, -0.2527]\n",
            token: "[0.0",
            path: "joints[1].assembly",
            message: "a spherical joint takes 3 assembly angles, one per axis, got 2",
        },
    );
}

#[test]
fn spherical_joint_angle_names_are_checked_where_written() {
    let d = check(
        "spherical-coordinate-name",
        None,
        Expect {
            context: "coordinates: [ball_x, Ball_y, ball_z]",
            token: "Ball_y",
            path: "joints[1].coordinates[1]",
            message: "`Ball_y` is not a valid joint name",
        },
    );
    assert_eq!(d.0.len(), 1, "{d}");
}

#[test]
fn spherical_joint_damped_is_reported_once_not_once_per_angle() {
    let d = check(
        "spherical-damped",
        None,
        Expect {
            context: "damping: 1.0e-5\n    assembly",
            token: "1.0e-5",
            path: "joints[1].damping",
            message: "spherical joint `ball` is passive: damping of passive joints is not supported",
        },
    );
    assert_eq!(d.0.len(), 1, "{d}");
}

#[test]
fn spherical_joint_default_angle_names_are_checked_at_its_name() {
    // Without `coordinates` the angles are named from `name`: their rule points there.
    let d = check(
        "spherical-invalid-name",
        None,
        Expect {
            context: "  - name: Ball\n",
            token: "Ball",
            path: "joints[1].name",
            message: "`Ball_1` is not a valid joint name",
        },
    );
    assert_eq!(d.0.iter().filter(|d| d.path == "joints[1].name").count(), 1, "{d}");
}

#[test]
fn a_joint_named_like_a_spherical_joints_angle_is_a_duplicate_of_that_entry() {
    let d = check(
        "spherical-name-clash",
        None,
        Expect {
            context: "  - name: ball_2\n",
            token: "ball_2",
            path: "joints[2].name",
            message: "joint `ball_2` is defined twice",
        },
    );
    // The first definition is the spherical joint's entry, not the expanded list's index.
    assert_eq!(hint(&d.0[0]), "the first definition is `joints[1]`");
}

#[test]
fn a_spherical_joint_moves_one_body() {
    let (text, d) = reject("spherical-moves-two-bodies", None);
    let (line, column) = locate(&text, "    parent: slider\n    joint: ball\n", "ball\n");
    let found = d.0.iter().find(|d| d.path == "bodies[2].joint").unwrap_or_else(|| panic!("{d}"));
    assert_eq!(
        (found.line, found.column, found.message.as_str()),
        (line, column, "spherical joint `ball` already moves body `slider`; a joint moves one body"),
        "{d}"
    );
}

#[test]
fn spherical_joint_must_be_passive() {
    let d = check(
        "spherical-not-passive",
        None,
        Expect {
            context: "  - name: ball\n",
            token: "name: ball",
            path: "joints[1]",
            message: "spherical joint `ball` must be passive",
        },
    );
    assert!(hint(&d.0[0]).starts_with("add `passive: true`"), "{d}");
}

#[test]
fn a_body_names_the_spherical_joint_not_one_of_its_angles() {
    let d = check(
        "spherical-angle-as-joint",
        None,
        Expect {
            context: "    joint: ball_2",
            token: "ball_2",
            path: "bodies[2].joint",
            message: "`ball_2` is an angle of joint `ball`, not a joint",
        },
    );
    assert_eq!(hint(&d.0[0]), "name the joint: `joint: ball`");
    // The joint itself is then unused, reported once by its own name, not once per angle.
    let unused: Vec<&str> =
        d.0.iter().filter(|d| d.message.contains("moves no body")).map(|d| d.message.as_str()).collect();
    assert_eq!(unused, ["spherical joint `ball` moves no body"], "{d}");
}

/// The spatial loops' mobility count and assembly, on the Falcon-like Delta with one change.
fn spatial_closures(name: &str, message: &str) -> Diagnostics {
    check(
        name,
        None,
        Expect { context: "closures:\n  - name: leg2", token: "- name: leg2", path: "closures", message },
    )
}

#[test]
fn spatial_loops_under_constrained() {
    let d = spatial_closures(
        "spatial-closure-under-constrained",
        "the loops are under-constrained: 7 constraint equations for 8 passive joint coordinates (knee1_swing, knee1_twist, knee2_swing, knee2_twist, knee3_swing, knee3_twist, platform_swing, platform_twist)",
    );
    assert!(hint(&d.0[0]).contains("`perpendicular`"), "{d}");
}

#[test]
fn spatial_loops_over_constrained() {
    spatial_closures(
        "spatial-closure-over-constrained",
        "the loops are over-constrained: 11 constraint equations for 8 passive joint coordinates (knee1_swing, knee1_twist, knee2_swing, knee2_twist, knee3_swing, knee3_twist, platform_swing, platform_twist)",
    );
}

#[test]
fn spatial_loops_singular_name_the_free_joints_and_the_redundant_equations() {
    // Leg 3's closure repeats leg 2's equations: the rank is short by 4. Knee 3 appears in no
    // equation, so it is free; the other two free coordinates lie among legs 1 and 2 and the
    // platform (4 equations for their 6), and pivoting names the platform's. Which copy of the
    // repeated equations is called redundant is the pivoting's choice too.
    let d = spatial_closures(
        "spatial-closure-singular",
        "the loops are singular at their assembly: the constraints do not determine passive joints `knee3_swing`, `knee3_twist`, `platform_swing`, `platform_twist` (redundant equations: `leg2.x`, `leg2.y`, `leg2.z`, `leg2.perpendicular`)",
    );
    assert_eq!(d.0.len(), 1, "{d}");
}

#[test]
fn spatial_loops_that_cannot_close() {
    let (text, d) = reject("spatial-closure-cannot-close", None);
    let (line, column) = locate(&text, "closures:\n  - name: leg2", "- name: leg2");
    assert_eq!((d.0[0].line, d.0[0].column, d.0[0].path.as_str()), (line, column, "closures"));
    assert!(
        d.0[0].message.starts_with("the loops do not close near the passive joints' `assembly` angles at the middle of the actuated ranges (there `"),
        "{d}"
    );
    assert!(hint(&d.0[0]).contains("`assembly` angle"), "{d}");
}

/// A planar loop's passive joint that slides (a spatial loop may have one:
/// `tests/prismatic_loop.rs`).
#[test]
fn passive_joint_that_slides() {
    check(
        "passive-prismatic",
        None,
        Expect {
            context: "type: prismatic",
            token: "prismatic",
            path: "joints[3].type",
            message: "passive joint `right_elbow` of a planar loop must be revolute",
        },
    );
}

#[test]
fn frame_on_an_unknown_body() {
    let d = check(
        "frame-unknown-body",
        None,
        Expect {
            context: "body: wrist",
            token: "wrist",
            path: "frames[0].body",
            message: "frame `stylus_frame` references unknown body `wrist`",
        },
    );
    assert_eq!(hint(&d.0[0]), "name a body of `bodies`, or `base` for the fixed ground");
    assert_eq!(d.0.len(), 1, "{d}");
}

#[test]
fn frame_defined_twice() {
    let d = check(
        "frame-duplicate",
        None,
        Expect {
            context: "  - name: stylus_frame\n    body: forearm",
            token: "stylus_frame",
            path: "frames[1].name",
            message: "frame `stylus_frame` is defined twice",
        },
    );
    assert_eq!(d.0.len(), 1, "{d}");
}

#[test]
fn frame_in_a_planar_model() {
    let d = check(
        "frame-planar",
        None,
        Expect {
            context: "  - name: tool_frame",
            token: "name",
            path: "frames[0]",
            message: "frames (orientation outputs) need a spatial model",
        },
    );
    assert_eq!(d.0.len(), 1, "{d}");
}

#[test]
fn frame_with_an_unknown_key() {
    let d = check(
        "frame-unknown-key",
        None,
        Expect {
            context: "    xyz: [0.05",
            token: "xyz",
            path: "frames[0].xyz",
            message: "unknown key `xyz`",
        },
    );
    assert_eq!(hint(&d.0[0]), "expected one of `name`, `description`, `body`, `rpy`");
}

#[test]
fn frame_rpy_with_two_entries() {
    check(
        "frame-rpy-entries",
        None,
        Expect {
            context: "rpy: [0.0, 1.0]",
            token: "[",
            path: "frames[0].rpy",
            message: "expected 3 entries (roll, pitch, yaw), got 2",
        },
    );
}

#[test]
fn frame_whose_methods_clash_with_a_point() {
    let d = check(
        "frame-clashes-with-point",
        None,
        Expect {
            context: "frames:\n  - name: stylus",
            token: "stylus",
            path: "frames[0].name",
            message: "frame `stylus` clashes with point `stylus_angular`: both would emit `stylus_angular_jacobian`",
        },
    );
    assert_eq!(d.0.len(), 1, "{d}");
}

/// Deep flow nesting (a fuzz finding: 28,000 `[` took the YAML scanner 2.9 s to reject) is
/// refused before parsing, at the bracket that goes one level too deep; brackets in comments
/// do not count, and the shipped models' nesting stays far below the limit.
#[test]
fn deep_flow_nesting_is_refused_at_the_bracket_before_parsing() {
    let limit = hapticgen_codegen::model::MAX_FLOW_NESTING;
    let text = format!("# {}\nname: deep\ngravity: {}\n", "[".repeat(10 * limit), "[".repeat(30_000));
    let diagnostics = match load(&Source { name: "deep.yaml", text: &text }, None) {
        Ok(_) => panic!("30,000 nested sequences were accepted"),
        Err(d) => d,
    };
    let d = &diagnostics.0[0];
    assert!(d.message.contains("nested deeper than"), "{d}");
    // Line 3, column 10 (after `gravity: `) is the first `[`; the one past the limit is `limit` further.
    assert_eq!((d.line, d.column), (3, 10 + limit), "{d}");
    // Nesting within the limit goes on to the parser's own verdict.
    let shallow = format!("name: ok\ngravity: {}0{}\n", "[".repeat(limit), "]".repeat(limit));
    if let Err(d) = load(&Source { name: "shallow.yaml", text: &shallow }, None) {
        assert!(!d.0[0].message.contains("nested deeper than"), "{}", d.0[0]);
    }
}

#[test]
fn a_transmission_names_actuated_joints() {
    let d = check(
        "transmission-unknown-joint",
        None,
        Expect {
            context: "yaw: -1.0",
            token: "yaw",
            path: "transmission.roll.yaw",
            message: "`yaw` is not an actuated joint",
        },
    );
    assert_eq!(hint(&d.0[0]), "actuated joints: pitch, roll");
    let d = check(
        "transmission-unknown-row",
        None,
        Expect {
            context: "wrist: {pitch",
            token: "wrist",
            path: "transmission.wrist",
            message: "`wrist` is not an actuated joint: a row names the joint whose drive it describes",
        },
    );
    assert_eq!(hint(&d.0[0]), "actuated joints: pitch, roll");
}

#[test]
fn a_singular_transmission_is_refused_at_the_section() {
    let d = check(
        "transmission-singular",
        None,
        Expect {
            context: "transmission:",
            token: "transmission",
            path: "transmission",
            message: "the drives' outputs do not determine the joints: the coupling matrix is singular",
        },
    );
    assert_eq!(hint(&d.0[0]), "each drive must add a combination of joint angles the others do not make");
}

// Units and expressions: each error points at the faulty token inside the scalar.

#[test]
fn unit_of_the_wrong_dimension() {
    let d = check(
        "unit-wrong-dimension",
        None,
        Expect {
            context: "mass: 20.358 mm",
            token: "mm",
            path: "bodies[0].mass",
            message: "expected kg, got m",
        },
    );
    assert_eq!(hint(&d.0[0]), "a number without a unit is read in SI units");
}

#[test]
fn expression_naming_no_parameter() {
    let d = check(
        "expression-unknown-parameter",
        None,
        Expect {
            context: "current_limit: 3 N m / (12 * torque_konstant)",
            token: "torque_konstant",
            path: "drives.re40_gp42.current_limit",
            message: "unknown parameter `torque_konstant`",
        },
    );
    assert_eq!(hint(&d.0[0]), "defined parameters: grip_mass, stick_length");
}

#[test]
fn expression_calling_no_known_function() {
    let d = check(
        "expression-unknown-function",
        None,
        Expect {
            context: "backlash: degrees(0.8)",
            token: "degrees",
            path: "drives.re40_gp42.backlash",
            message: "unknown function `degrees`",
        },
    );
    assert!(hint(&d.0[0]).starts_with("functions: sin, cos"), "{}", d.0[0]);
}

#[test]
fn expression_with_a_bad_token_in_a_quoted_scalar() {
    check(
        "expression-bad-token",
        None,
        Expect {
            context: "efficiency: \"1.0 % 1\"",
            token: "%",
            path: "drives.re40_gp42.efficiency",
            message: "unexpected character `%`",
        },
    );
}

#[test]
fn expression_dividing_by_zero() {
    check(
        "expression-division-by-zero",
        None,
        Expect {
            context: "gear_ratio: 24 / (stick_length - 15 cm)",
            token: "/",
            path: "drives.re40_gp42.gear_ratio",
            message: "division by zero",
        },
    );
}

#[test]
fn expression_overflowing() {
    check(
        "expression-not-finite",
        None,
        Expect {
            context: "supply_voltage: 1e300 V * 1e10",
            token: "*",
            path: "drives.re40_gp42.supply_voltage",
            message: "the result of `*` is not a finite number",
        },
    );
}

#[test]
fn tunable_parameter_inside_a_function() {
    check(
        "expression-tunable-in-function",
        None,
        Expect {
            context: "mass: 0.1 * cos(grip_mass)",
            token: "grip_mass",
            path: "bodies[1].mass",
            message: "the tunable parameter `grip_mass` cannot be used inside `cos`",
        },
    );
}

#[test]
fn tunable_parameter_in_a_fixed_field() {
    check(
        "expression-tunable-in-fixed-field",
        None,
        Expect {
            context: "torque_limit: 60 * grip_mass",
            token: "grip_mass",
            path: "drives.re40_gp42.torque_limit",
            message: "the tunable parameter `grip_mass` cannot be used here: this field is a fixed number",
        },
    );
}

#[test]
fn parameters_in_a_cycle() {
    let d = check(
        "parameter-cycle",
        None,
        Expect {
            context: "{value: grip_diameter / 2}",
            token: "grip_diameter",
            path: "parameters.grip_radius.value",
            message: "the parameters depend on each other in a cycle: grip_diameter → grip_mass → grip_radius → grip_diameter",
        },
    );
    assert_eq!(d.0.len(), 1, "{d}");
}

#[test]
fn drive_like_an_unknown_drive() {
    let d = check(
        "drive-like-unknown",
        None,
        Expect {
            context: "like: re40_gp24",
            token: "re40_gp24",
            path: "drives.fast.like",
            message: "unknown drive `re40_gp24`",
        },
    );
    assert_eq!(hint(&d.0[0]), "defined drives: re40_gp42, fast");
}

#[test]
fn drives_like_each_other_in_a_cycle() {
    check(
        "drive-like-cycle",
        None,
        Expect {
            context: "like: fast",
            token: "fast",
            path: "drives.slow.like",
            message: "the drives are `like` each other in a cycle: fast → slow → fast",
        },
    );
}

#[test]
fn incomplete_inertia_shape_names_the_forms() {
    let d = check(
        "inertia-shape-incomplete",
        None,
        Expect {
            context: "inertia: {rod: {length: 0.15}}",
            token: "{rod",
            path: "bodies[0].inertia",
            message: "not a valid inertia",
        },
    );
    assert!(hint(&d.0[0]).contains("`{rod: {length, axis}}`"), "{}", d.0[0]);
    assert!(!d.0[0].message.contains("untagged"));
}

#[test]
fn value_of_the_wrong_shape_names_the_forms() {
    let d = check(
        "value-not-a-number",
        None,
        Expect {
            context: "mass: [0.05]",
            token: "[0.05]",
            path: "bodies[1].mass",
            message: "expected a number, a number with a unit, a parameter name or an expression",
        },
    );
    assert!(!d.to_string().contains("untagged"));
}
