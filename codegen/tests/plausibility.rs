//! Plausibility checks (`hapticgen_codegen::check::plausibility`) on the shipped models, which
//! must pass silently, and on copies with the mistakes a newcomer makes: grams typed as
//! kilograms, millimetres as metres, kg·mm² as kg·m², a drive too weak for its rig, a Delta
//! whose platform point has the wrong sign; each found at its line with its numbers.

use hapticgen_codegen::check::plausibility::{plausibility, Plausibility, Severity};
use hapticgen_codegen::diag::Diagnostic;
use hapticgen_codegen::Source;

const FALCON: &str = include_str!("../../models/falcon_delta.yaml");
const PARALLEL: &str = include_str!("../../models/parallel_link_2dof.yaml");
const PHANTOM: &str = include_str!("../../models/phantom_3dof.yaml");

fn check(text: &str, variant: Option<&str>) -> (Plausibility, Vec<(Severity, Diagnostic)>) {
    let m = hapticgen_codegen::load(&Source { name: "rig.yaml", text }, variant)
        .unwrap_or_else(|d| panic!("{d}"));
    let found = plausibility(&m, &hapticgen_codegen::derive(&m), text);
    let diagnostics =
        found.findings.iter().map(|f| (f.severity, f.diagnostic("rig.yaml", text, &m))).collect();
    (found, diagnostics)
}

/// The 1-based line of the `occurrence`-th line of `text` containing `needle`.
fn line_of(text: &str, needle: &str, occurrence: usize) -> usize {
    text.lines().enumerate().filter(|(_, l)| l.contains(needle)).nth(occurrence).map(|(i, _)| i + 1).unwrap()
}

/// What `hapticgen check` warns of for the shipped models: the Slotine & Li arm, standing
/// vertical, is too heavy for its 12 N·m drives with the arm stretched sideways.
const SHIPPED_WARNINGS: [(&str, &str, &str); 1] = [(
    "planar_arm_2dof.yaml",
    "vertical",
    "drive `gearmotor` of joint `shoulder` cannot hold the rig against gravity in 60 % of the joint box",
)];

#[test]
fn every_shipped_model_and_variant_is_plausible() {
    for entry in std::fs::read_dir(concat!(env!("CARGO_MANIFEST_DIR"), "/../models")).unwrap() {
        let path = entry.unwrap().path();
        let text = std::fs::read_to_string(&path).unwrap();
        let m = hapticgen_codegen::load(&Source { name: "m.yaml", text: &text }, None).unwrap();
        let mut variants: Vec<Option<String>> = m.variants.iter().cloned().map(Some).collect();
        variants.push(None);
        for variant in variants {
            let (found, diagnostics) = check(&text, variant.as_deref());
            let file = path.file_name().unwrap().to_str().unwrap();
            let chosen = variant.clone().or(m.variant.clone()).unwrap_or_default();
            let expected: Vec<&str> = SHIPPED_WARNINGS
                .iter()
                .filter(|(f, v, _)| *f == file && *v == chosen)
                .map(|(_, _, w)| *w)
                .collect();
            assert!(!found.has_errors(), "{}: {diagnostics:?}", path.display());
            assert_eq!(diagnostics.len(), expected.len(), "{}: {diagnostics:?}", path.display());
            for ((_, d), want) in diagnostics.iter().zip(expected) {
                assert!(d.message.starts_with(want), "{}: {d}", path.display());
            }
            assert!(found.grid.1 > 0 && found.grid.1 == found.grid.0, "{}: {:?}", path.display(), found.grid);
        }
    }
}

#[test]
fn grams_typed_as_kilograms_are_an_error_at_the_drive_and_a_warning_at_each_mass() {
    // The Falcon-like Delta's masses in grams: 20, 10 and 60 "kg".
    let grams = FALCON
        .replace("value: 20 g", "value: 20")
        .replace("mass: 10 g", "mass: 10")
        .replace("mass: 60 g", "mass: 60");
    assert_eq!(
        grams.matches("value: 20\n").count() + grams.matches("mass: 10\n").count(),
        4,
        "the shipped Falcon writes its masses in grams"
    );
    let (_, diagnostics) = check(&grams, None);
    let errors: Vec<_> = diagnostics.iter().filter(|(s, _)| *s == Severity::Error).map(|(_, d)| d).collect();
    assert_eq!(errors.len(), 1, "{diagnostics:?}");
    let drive = errors[0];
    assert_eq!(drive.path, "drives.capstan.torque_limit");
    assert_eq!((drive.line, drive.column), (line_of(&grams, "torque_limit:", 0), 19));
    assert!(
        drive.message.contains("cannot hold the rig against gravity in 99 % of the joint box"),
        "{drive}"
    );
    assert!(drive.message.contains("against a torque limit of 1.0036 N·m"), "{drive}");
    // The thighs (20 kg within 0.06 m of their frames: a 0.12 m steel cube is 13.6 kg) and
    // the platform are heavier than steel; the shins (10 kg, 0.1025 m) are not.
    let masses: Vec<_> =
        diagnostics.iter().filter(|(_, d)| d.path.ends_with(".mass")).map(|(_, d)| d).collect();
    let paths: Vec<&str> = masses.iter().map(|d| d.path.as_str()).collect();
    assert_eq!(paths, ["bodies[0].mass", "bodies[2].mass", "bodies[4].mass", "bodies[6].mass"], "{masses:?}");
    assert_eq!((masses[0].line, masses[0].column), (line_of(&grams, "mass: thigh_mass", 0), 11));
    assert!(masses[0].message.contains("weighs 20 kg"), "{}", masses[0]);
    assert!(masses[0].hint.as_deref().unwrap().contains("did you mean 20 g (0.02 kg)?"), "{}", masses[0]);
}

#[test]
fn a_drive_too_weak_for_part_of_the_box_is_a_warning_with_the_worst_pose() {
    // The largest gravity torque of the vertical parallel link over the check's grid, computed
    // here from the evaluator: a limit 1 % below it holds the rig in part of the box only.
    let m = hapticgen_codegen::load(&Source { name: "rig.yaml", text: PARALLEL }, Some("vertical")).unwrap();
    let mech = hapticgen_codegen::derive(&m);
    let (found, _) = check(PARALLEL, Some("vertical"));
    let steps = (found.grid.0 as f64).sqrt().round() as usize;
    assert_eq!(steps * steps, found.grid.0);
    let worst = largest_over_grid(&m, &mech, steps, |g| g[0].abs());
    assert!(worst > 0.1, "the vertical link carries its weight: {worst}");
    let limit = format!("{:.4}", worst * 0.99);
    let weak = PARALLEL.replace("torque_limit: 3.0", &format!("torque_limit: {limit}"));
    let (found, diagnostics) = check(&weak, Some("vertical"));
    assert!(!found.has_errors(), "{diagnostics:?}");
    let (severity, d) = &diagnostics[0];
    assert_eq!(*severity, Severity::Warning);
    assert!(d.message.contains("% of the joint box"), "{d}");
    assert!(d.message.contains(&format!("against a torque limit of {limit} N·m")), "{d}");
    assert!(d.message.contains(&format!("needs up to {worst:.3} N·m")), "{d}, worst {worst}");
    // Holding it everywhere: silent; the horizontal variant carries no weight at all.
    let strong = PARALLEL.replace("torque_limit: 3.0", &format!("torque_limit: {}", worst * 1.001));
    assert!(check(&strong, Some("vertical")).0.findings.is_empty());
    assert!(check(&weak, Some("horizontal")).0.findings.is_empty());
}

#[test]
fn millimetres_typed_as_metres_are_a_warning_at_the_body() {
    // The PHANToM-like arm's upper arm in millimetres.
    let mm = PHANTOM.replacen("value: 0.215", "value: 215", 1);
    assert_ne!(mm, PHANTOM, "the PHANToM-like model has a 0.215 m upper arm");
    let (_, diagnostics) = check(&mm, None);
    let sizes: Vec<_> =
        diagnostics.iter().filter(|(_, d)| d.message.contains("larger than a haptic device")).collect();
    assert!(!sizes.is_empty(), "{diagnostics:?}");
    assert!(sizes[0].1.hint.as_deref().unwrap().contains("did you mean 0.215 m?"), "{}", sizes[0].1);
}

#[test]
fn an_inertia_in_kg_mm2_is_a_warning_at_the_inertia() {
    // The first thigh's slender-rod inertia, m·a²/12 = 6e-6 kg·m², typed in kg·mm².
    let typed = FALCON.replacen(
        "inertia: {ixx: 0.0, iyy: thigh_mass * thigh_length^2 / 12, izz: thigh_mass * thigh_length^2 / 12}",
        "inertia: {ixx: 0.0, iyy: 6.0, izz: 6.0}",
        1,
    );
    assert_ne!(typed, FALCON, "the shipped Falcon writes its thighs' inertia as an expression");
    let (found, diagnostics) = check(&typed, None);
    assert_eq!(found.findings.len(), 1, "{diagnostics:?}");
    let d = &diagnostics[0].1;
    assert_eq!(d.path, "bodies[0].inertia");
    assert_eq!(d.line, line_of(&typed, "iyy: 6.0,", 0));
    assert!(
        d.message.contains("radius of gyration of 17.321 m about its centre of mass, more than 4 times"),
        "{d}"
    );
    assert!(d.hint.as_deref().unwrap().contains("did you mean 6e-6 kg·m²"), "{d}");
}

#[test]
fn a_lopsided_delta_shows_its_grip_off_the_axis_and_a_true_delta_does_not_turn() {
    // The shipped Delta's platform translates: no turning finding (checked on its grid).
    let (found, _) = check(FALCON, None);
    assert!(found.findings.is_empty(), "{:?}", found.findings);
    // Leg 2's platform joint mirrored onto leg 3's: the legs still keep the platform from
    // turning (the perpendicular conditions), but the grip leaves the axis at equal thigh
    // angles, which the assembly line shows.
    let lopsided = FALCON.replacen(
        "[-1.5 * platform_radius, 0.023669261503, 0.0]",
        "[-1.5 * platform_radius, -0.023669261503, 0.0]",
        1,
    );
    assert_ne!(lopsided, FALCON);
    let (found, _) = check(&lopsided, None);
    let p = found.assembly.unwrap().task_point.unwrap();
    assert!(p[0].hypot(p[1]) > 0.01, "{p:?}");
}

#[test]
fn the_delta_reports_its_assembly_branch_below_the_base() {
    let (found, _) = check(FALCON, None);
    let assembly = found.assembly.expect("a closed chain reports its branch");
    assert_eq!(assembly.middle, vec![0.35; 3]);
    let p = assembly.task_point.unwrap();
    assert!(p[0].abs() < 1e-9 && p[1].abs() < 1e-9 && p[2] < -0.05, "{p:?}");
    let knee = assembly.passive.iter().find(|(n, _)| n == "knee1_swing").unwrap().1;
    assert!((knee - 1.924).abs() < 1e-3, "{knee}");
    // Open chains have no branch to report.
    assert!(check(PARALLEL, None).0.assembly.is_none());
}

#[test]
fn a_differential_is_judged_by_its_motors_torques() {
    // The wrist's drives turn a = C q with C = [[1, 1], [1, −1]]: the motors' torques for
    // joint torques τ are C⁻ᵀ τ = ((τ_pitch + τ_roll)/2, (τ_pitch − τ_roll)/2).
    let wrist = include_str!("../../models/differential_wrist.yaml");
    let m = hapticgen_codegen::load(&Source { name: "rig.yaml", text: wrist }, None).unwrap();
    let mech = hapticgen_codegen::derive(&m);
    let grid = check(wrist, None).0.grid.0;
    let steps = (grid as f64).sqrt().round() as usize;
    let worst = largest_over_grid(&m, &mech, steps, |g| (0.5 * (g[0] + g[1])).abs());
    assert!(worst > 0.01, "{worst}");
    let limit = format!("{:.5}", worst * 0.5);
    let weak = wrist.replace("torque_limit: 0.65", &format!("torque_limit: {limit}"));
    let (_, diagnostics) = check(&weak, None);
    assert_eq!(diagnostics.len(), 1, "{diagnostics:?}");
    let d = &diagnostics[0].1;
    assert!(d.message.contains("joint `pitch`"), "{d}");
    assert!(d.message.contains(&format!("needs up to {worst:.3} N·m")), "{d}, motor 1's worst {worst}");
}

/// The largest of `measure(g(q))` over the `steps × steps` grid of a two-joint rig's joint box,
/// from the polynomial evaluator (the same grid `check` reports having used).
fn largest_over_grid(
    m: &hapticgen_codegen::CheckedModel,
    mech: &hapticgen_codegen::dynamics::mechanics::Mechanics,
    steps: usize,
    measure: impl Fn(&[f64]) -> f64,
) -> f64 {
    let at = |j: usize, s: usize| {
        m.joints[j].lower + (m.joints[j].upper - m.joints[j].lower) * s as f64 / (steps - 1) as f64
    };
    let mut worst: f64 = 0.0;
    for i in 0..steps {
        for k in 0..steps {
            let q = [at(0, i), at(1, k)];
            let state = hapticgen_codegen::eval::State { q: &q, qd: &[0.0, 0.0], parameters: &[] };
            worst = worst.max(measure(&hapticgen_codegen::eval::evaluate(mech, &state, None).g));
        }
    }
    worst
}
