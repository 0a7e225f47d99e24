//! Build-time virtual-wall checks (`hapticgen_codegen::check::stability`) on the shipped models and
//! on edited copies: bounds, verdicts and the diagnostic's position.

use hapticgen_codegen::check::stability::{check_wall, WallCheck, WallVerdict};
use hapticgen_codegen::model::Model;
use hapticgen_codegen::Source;

const PARALLEL: &str = include_str!("../../models/parallel_link_2dof.yaml");

fn load(text: &str, variant: Option<&str>) -> (Model, WallCheck) {
    let m = hapticgen_codegen::load(&Source { name: "rig.yaml", text }, variant).unwrap();
    let wall = check_wall(&m, &hapticgen_codegen::derive(&m)).expect("the model renders walls");
    (m.model, wall)
}

#[test]
fn the_paper_wall_is_stable_but_not_passive() {
    let (m, wall) = load(PARALLEL, None);
    // Mid-range pose q = (1.55, 0): J ≈ diag(−0.15, −0.05) up to the small angle, so the
    // least damped direction has b ≈ 1e-3 / 0.15² = 0.044 N·s/m.
    assert!((wall.task_damping - 1e-3 / 0.15f64.powi(2)).abs() < 2e-3, "b = {}", wall.task_damping);
    assert!(wall.worst_task_damping <= wall.task_damping);
    assert_eq!(wall.passive_stiffness, 0.0, "B_d = 5 N·s/m exceeds b: nothing is passive");
    assert!((wall.stable_stiffness - 2.0 * (wall.task_damping + 5.0) / 1e-3).abs() < 1e-6);
    assert_eq!(wall.verdict, WallVerdict::BeyondPassivity);
    let (error, d) = wall.diagnostic("models/parallel_link_2dof.yaml", PARALLEL, &m).unwrap();
    assert!(!error, "the shipped model must pass `hapticgen check`");
    assert_eq!(d.path, "rendering.wall_stiffness");
    let line = PARALLEL.lines().position(|l| l.trim_start().starts_with("wall_stiffness:")).unwrap() + 1;
    assert_eq!((d.line, d.column), (line, 19));
}

#[test]
fn a_wall_beyond_the_stability_bound_is_an_error_unless_allowed() {
    let stiff = PARALLEL.replace("wall_stiffness: 1500.0", "wall_stiffness: 20000.0");
    let (m, wall) = load(&stiff, None);
    assert_eq!(wall.verdict, WallVerdict::BeyondStability);
    let (error, d) = wall.diagnostic("rig.yaml", &stiff, &m).unwrap();
    assert!(error);
    assert!(d.message.contains("beyond the stability bound"), "{d}");
    assert!(d.hint.as_deref().unwrap_or("").contains("allow_unstable_stiffness"));

    let allowed = stiff.replace("wall_damping: 5.0", "wall_damping: 5.0\n  allow_unstable_stiffness: true");
    let (m, wall) = load(&allowed, None);
    let (error, _) = wall.diagnostic("rig.yaml", &allowed, &m).unwrap();
    assert!(!error, "the override turns the error into a warning");
}

#[test]
fn a_passive_wall_has_no_diagnostic_and_variants_are_located() {
    // Joint damping 1 N·m·s/rad: b ≈ 44 N·s/m, so K = 50 N/m with B = 1 is passive.
    let damped = PARALLEL
        .replace("damping: 1.0e-3", "damping: 1.0")
        .replace("wall_stiffness: 1500.0", "wall_stiffness: 50.0")
        .replace("wall_damping: 5.0", "wall_damping: 1.0");
    let (m, wall) = load(&damped, None);
    assert_eq!(wall.verdict, WallVerdict::Passive);
    assert!(wall.diagnostic("rig.yaml", &damped, &m).is_none());

    // A variant that sets the stiffness is reported at the variant's line.
    let text = damped.replace(
        "      gravity: [0.0, 0.0]",
        "      gravity: [0.0, 0.0]\n      rendering.wall_stiffness: 1.0e6",
    );
    let (m, wall) = load(&text, Some("horizontal"));
    assert_eq!(wall.verdict, WallVerdict::BeyondStability);
    let (error, d) = wall.diagnostic("rig.yaml", &text, &m).unwrap();
    assert!(error);
    let line = text.lines().position(|l| l.contains("rendering.wall_stiffness: 1.0e6")).unwrap() + 1;
    assert_eq!(d.line, line, "{d}");
}
