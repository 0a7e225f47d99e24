//! The consistent fit and the identified model file (`hapticgen_host::identify`): a "true"
//! model made by changing every body's mass, centre of mass and inertia by 10–40 % and adding
//! friction; its base parameters fitted from the nominal file, written back, re-loaded and
//! compared with the truth.

use hapticgen_codegen::dynamics::regressor::Regressor;
use hapticgen_codegen::eval::NominalAtoms;
use hapticgen_codegen::sym::poly::Poly;
use hapticgen_codegen::{CheckedModel, Source};
use hapticgen_host::identify::consistent::{fit, ConsistentParameters, FitOptions};
use hapticgen_host::identify::model_file::write_model_file;
use hapticgen_host::rig::CompiledModel;
use nalgebra::{Matrix3, Matrix4, SymmetricEigen};
use rand::rngs::SmallRng;
use rand::{Rng, SeedableRng};

fn read(file: &str) -> String {
    let path = format!("{}/../../models/{file}", env!("CARGO_MANIFEST_DIR"));
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"))
}

fn load(name: &str, text: &str, variant: Option<&str>) -> CheckedModel {
    match hapticgen_codegen::load(&Source { name, text }, variant) {
        Ok(model) => model,
        Err(diagnostics) => panic!("{name} does not load:\n{diagnostics}\n{text}"),
    }
}

fn regressor(model: &CheckedModel) -> Regressor {
    Regressor::new(&model.model, model.analyses.closures.as_ref())
}

/// A factor 1 ± (10–40 %).
fn factor(rng: &mut SmallRng) -> f64 {
    let u = rng.gen_range(0.1..0.4);
    if rng.gen_bool(0.5) {
        1.0 + u
    } else {
        1.0 - u
    }
}

/// The "true" device: every body's mass, centre of mass and inertia changed by 10–40 % (the
/// central second moments `Σ_c = ½ tr(I) 1 − I` scaled by `D Σ_c D`, so it stays a physical
/// body), more damping and per-joint Coulomb friction.
fn true_model(model: &CheckedModel, seed: u64) -> CheckedModel {
    let mut rng = SmallRng::seed_from_u64(seed);
    let mut truth = model.clone();
    let params = model.nominal_parameters();
    let nominal = NominalAtoms(&params);
    let planar = model.planar;
    for body in &mut truth.model.bodies {
        let m = body.mass.eval(&nominal);
        if m <= 0.0 {
            continue;
        }
        let c = body.com.clone().map(|p| p.eval(&nominal));
        let i = body.inertia.clone().map(|row| row.map(|p| p.eval(&nominal)));
        let size = c.iter().map(|x| x * x).sum::<f64>().sqrt().max(0.01);
        let dims = if planar { 2 } else { 3 };
        let mut c_new = c;
        for x in c_new.iter_mut().take(dims) {
            *x = *x * factor(&mut rng) + 0.1 * size * rng.gen_range(-1.0..1.0);
        }
        let i_new = if planar {
            let mut t = [[0.0; 3]; 3];
            t[2][2] = i[2][2] * factor(&mut rng);
            t
        } else {
            let inertia = Matrix3::from_fn(|r, s| i[r][s]);
            let sigma = Matrix3::identity() * (0.5 * inertia.trace()) - inertia;
            let d = Matrix3::from_diagonal(&nalgebra::Vector3::from_fn(|_, _| factor(&mut rng)));
            // A real body has thickness: its second moments get an isotropic part (2 % of
            // their mean, and at least those of a 2 mm ball), off the cone's boundary.
            let mass = m;
            let thickness = 0.02 * sigma.trace() / 3.0 + mass * 2e-3 * 2e-3;
            let sigma = d * sigma * d + Matrix3::identity() * thickness;
            let t = Matrix3::identity() * sigma.trace() - sigma;
            [
                [t[(0, 0)], t[(0, 1)], t[(0, 2)]],
                [t[(1, 0)], t[(1, 1)], t[(1, 2)]],
                [t[(2, 0)], t[(2, 1)], t[(2, 2)]],
            ]
        };
        body.mass = Poly::constant(m * factor(&mut rng));
        body.com = c_new.map(Poly::constant);
        body.inertia = i_new.map(|row| row.map(Poly::constant));
    }
    for joint in &mut truth.model.joints {
        let b = joint.damping.eval(&nominal);
        joint.damping = Poly::constant(b * factor(&mut rng) + 1e-4 * rng.gen_range(0.5..1.5));
        joint.drive.coulomb_friction = joint.drive.torque_limit * rng.gen_range(0.002..0.02);
    }
    truth
}

/// Every body's pseudo-inertia's smallest eigenvalue relative to its largest (the plane's for
/// a planar model); massless bodies are skipped.
fn pseudo_inertia_eigenvalues(model: &CheckedModel) -> Vec<(String, f64)> {
    let params = model.nominal_parameters();
    let nominal = NominalAtoms(&params);
    let mut out = Vec::new();
    for body in &model.bodies {
        let m = body.mass.eval(&nominal);
        if m == 0.0 {
            continue;
        }
        let c = body.com.clone().map(|p| p.eval(&nominal));
        let i = Matrix3::from_fn(|r, s| body.inertia[r][s].eval(&nominal));
        let eigenvalues: Vec<f64> = if model.planar {
            let half = 0.5 * i[(2, 2)];
            let j = Matrix3::new(
                half + m * c[0] * c[0],
                m * c[0] * c[1],
                m * c[0],
                m * c[0] * c[1],
                half + m * c[1] * c[1],
                m * c[1],
                m * c[0],
                m * c[1],
                m,
            );
            SymmetricEigen::new(j).eigenvalues.iter().copied().collect()
        } else {
            let cv = nalgebra::Vector3::from_fn(|k, _| c[k]);
            let sigma = Matrix3::identity() * (0.5 * i.trace()) - i + cv * cv.transpose() * m;
            let mut j = Matrix4::zeros();
            j.fixed_view_mut::<3, 3>(0, 0).copy_from(&sigma);
            for k in 0..3 {
                j[(k, 3)] = m * c[k];
                j[(3, k)] = m * c[k];
            }
            j[(3, 3)] = m;
            SymmetricEigen::new(j).eigenvalues.iter().copied().collect()
        };
        let largest = eigenvalues.iter().copied().fold(0.0, f64::max);
        let smallest = eigenvalues.iter().copied().fold(f64::INFINITY, f64::min);
        out.push((body.name.clone(), smallest / largest));
    }
    out
}

/// Largest difference of `D`, `C q̇` and `g` between two models at random states, each
/// relative to the truth's norm of the same quantity.
fn dynamics_difference(truth: &CheckedModel, other: &CheckedModel, seed: u64) -> f64 {
    let a = CompiledModel::new(truth, 1.0);
    let b = CompiledModel::new(other, 1.0);
    let n = a.joints;
    let mut rng = SmallRng::seed_from_u64(seed);
    let (mut sa, mut sb) = (a.dynamics.scratch(), b.dynamics.scratch());
    let mut out_a = vec![0.0; a.dynamics.len()];
    let mut out_b = vec![0.0; b.dynamics.len()];
    let mut worst: f64 = 0.0;
    for _ in 0..20 {
        let q: Vec<f64> = truth
            .joints
            .iter()
            .map(|j| {
                let (lo, hi) = (j.lower.max(-3.0), j.upper.min(3.0));
                let margin = 0.2 * (hi - lo);
                rng.gen_range(lo + margin..hi - margin)
            })
            .collect();
        let qd: Vec<f64> = (0..n).map(|_| rng.gen_range(-2.0..2.0)).collect();
        a.dynamics.eval(&mut sa, &q, &qd, &a.parameters, &mut out_a);
        b.dynamics.eval(&mut sb, &q, &qd, &b.parameters, &mut out_b);
        for range in [0..n * n, n * n..n * n + n, n * n + n..n * n + 2 * n] {
            let norm = out_a[range.clone()].iter().map(|x| x * x).sum::<f64>().sqrt();
            let diff = out_a[range.clone()]
                .iter()
                .zip(&out_b[range])
                .map(|(x, y)| (x - y).powi(2))
                .sum::<f64>()
                .sqrt();
            if norm > 1e-12 {
                worst = worst.max(diff / norm);
            } else {
                assert!(diff < 1e-12, "a zero quantity became {diff}");
            }
        }
    }
    worst
}

struct Outcome {
    fit: ConsistentParameters,
    written: String,
    reloaded: CheckedModel,
    /// Largest `|β_written − β_true| / max(|β_true|, 10⁻³ β_unit)` over the base parameters,
    /// `β_unit` the largest true base parameter of the same unit (a product of inertia
    /// 10⁻⁹ kg·m² beside moments of 10⁻⁴ is judged against 10⁻⁷).
    base_error: f64,
}

fn identify(
    file: &str,
    variant: Option<&str>,
    beta: Option<&[f64]>,
    seed: u64,
) -> (CheckedModel, Vec<f64>, Outcome) {
    let text = read(file);
    let model = load(file, &text, variant);
    let regressor = regressor(&model);
    let truth = true_model(&model, seed);
    let beta_true = regressor.base_values(&regressor.standard_values(&truth.model));
    let beta = beta.map(<[f64]>::to_vec).unwrap_or_else(|| beta_true.clone());
    let fit = fit(&model, &regressor, &beta, None, &FitOptions::default()).expect("the fit starts");
    let written = write_model_file(&text, &model, &fit).unwrap_or_else(|e| panic!("{file}: {e}"));
    let reloaded = load(file, &written, variant);
    let beta_written = regressor.base_values(&regressor.standard_values(&reloaded.model));
    let base_error = beta_written
        .iter()
        .zip(&beta_true)
        .zip(&regressor.base)
        .map(|((w, t), b)| {
            let same_unit = regressor.base.iter().zip(&beta_true).filter(|(o, _)| {
                regressor.standard[o.combination[0].0].unit == regressor.standard[b.combination[0].0].unit
            });
            let largest = same_unit.map(|(_, v)| v.abs()).fold(0.0, f64::max);
            (w - t).abs() / t.abs().max(1e-3 * largest).max(1e-300)
        })
        .fold(0.0, f64::max);
    (truth, beta_true, Outcome { fit, written, reloaded, base_error })
}

fn check_recovers(file: &str, variant: Option<&str>, seed: u64) {
    let (truth, _, outcome) = identify(file, variant, None, seed);
    let Outcome { fit, written, reloaded, base_error } = &outcome;
    let dynamics = dynamics_difference(&truth, reloaded, seed + 1);
    let eigen = pseudo_inertia_eigenvalues(reloaded);
    let smallest = eigen.iter().map(|e| e.1).fold(f64::INFINITY, f64::min);
    eprintln!(
        "{file} {variant:?}: fit residual {:.2e}, largest error {:.2e}; written file: base parameters {:.2e}, \
         D/Cq̇/g {:.2e}, smallest relative pseudo-inertia eigenvalue {:.2e}",
        fit.residual, fit.largest_error, base_error, dynamics, smallest
    );
    assert!(*base_error < 1e-6, "{file}: base parameters off by {base_error:e}\n{written}");
    assert!(dynamics < 1e-6, "{file}: D, C q̇, g off by {dynamics:e}\n{written}");
    for (name, e) in &eigen {
        assert!(
            *e >= -1e-12,
            "{file}: body {name}'s pseudo-inertia has eigenvalue {e:e} (relative)\n{written}"
        );
    }
    for body in &fit.bodies {
        assert!(
            body.smallest_eigenvalue >= -1e-12 * body.largest_eigenvalue || !body.fitted,
            "{file}: {body:?}"
        );
    }
    check_comments_kept(&read(file), written);
}

/// Every comment of the input, whole lines and trailing, is in the output.
fn check_comments_kept(input: &str, output: &str) {
    let out_lines: Vec<&str> = output.lines().collect();
    for line in input.lines() {
        let trimmed = line.trim_start();
        if trimmed.starts_with('#') {
            assert!(out_lines.contains(&line), "comment line lost: {line}");
        } else if let Some(at) = line.find(" #") {
            let comment = &line[at + 1..];
            assert!(output.contains(comment), "trailing comment lost: {comment}");
        }
    }
}

#[test]
fn joystick_is_recovered() {
    check_recovers("joystick_1dof.yaml", None, 1);
}

#[test]
fn parallel_link_vertical_is_recovered() {
    check_recovers("parallel_link_2dof.yaml", Some("vertical"), 2);
}

#[test]
fn parallel_link_horizontal_is_recovered() {
    check_recovers("parallel_link_2dof.yaml", Some("horizontal"), 3);
}

#[test]
fn phantom_premium_is_recovered() {
    check_recovers("phantom_premium.yaml", None, 4);
}

#[test]
fn falcon_delta_is_recovered() {
    check_recovers("falcon_delta.yaml", None, 5);
}

/// A base parameter with a mass in it made negative (and the rest noisy): no consistent model
/// reproduces it, the fit still gives physical bodies and a file that loads.
#[test]
fn infeasible_base_parameters_still_give_a_physical_model() {
    for (file, variant) in [
        ("joystick_1dof.yaml", None),
        ("parallel_link_2dof.yaml", Some("vertical")),
        ("phantom_premium.yaml", None),
    ] {
        let text = read(file);
        let model = load(file, &text, variant);
        let regressor = regressor(&model);
        let mut rng = SmallRng::seed_from_u64(9);
        let mut beta: Vec<f64> = regressor.base.iter().map(|b| b.nominal * rng.gen_range(0.7..1.3)).collect();
        let mass_like = regressor
            .base
            .iter()
            .position(|b| b.name.starts_with("m_") || b.name.starts_with("zz"))
            .expect("a mass-like base parameter");
        beta[mass_like] = -2.0 * beta[mass_like].abs() - 1e-3;
        let (_, _, outcome) = identify(file, variant, Some(&beta), 10);
        eprintln!(
            "{file}: infeasible β̂ ({} negated): residual {:.3}",
            regressor.base[mass_like].name, outcome.fit.residual
        );
        assert!(outcome.fit.residual > 1e-3, "{file}: an infeasible β̂ was met exactly?");
        for body in outcome.fit.bodies.iter().filter(|b| b.fitted) {
            assert!(
                body.smallest_eigenvalue >= -1e-12 * body.largest_eigenvalue && body.mass > 0.0,
                "{file}: {body:?}"
            );
            assert!(body.inertia.iter().flatten().chain(&body.com).all(|x| x.is_finite()));
        }
        for (name, e) in pseudo_inertia_eigenvalues(&outcome.reloaded) {
            assert!(e >= -1e-12, "{file}: body {name}: {e:e}");
        }
        assert!(!outcome.written.contains("NaN") && !outcome.written.contains("inf"));
        check_comments_kept(&text, &outcome.written);
    }
}

/// Joints sharing a drive but given different friction get drives of their own, `like` it.
#[test]
fn a_shared_drive_splits_where_friction_differs() {
    let (_, _, outcome) = identify("parallel_link_2dof.yaml", Some("vertical"), None, 2);
    assert!(
        outcome.written.contains("re40_gp42_q2: {like: re40_gp42, coulomb_friction: "),
        "{}",
        outcome.written
    );
    assert!(
        outcome.written.contains("drive: re40_gp42_q2  # identified (was drive re40_gp42)"),
        "{}",
        outcome.written
    );
    let joints = &outcome.reloaded.joints;
    for (joint, fitted) in joints.iter().zip(&outcome.fit.joints) {
        let written = joint.drive.coulomb_friction;
        assert!((written - fitted.coulomb_friction).abs() < 1e-10 * written, "{written} {fitted:?}");
    }
    assert!((joints[0].drive.coulomb_friction - joints[1].drive.coulomb_friction).abs() > 1e-6);
}

/// Only changed values are replaced, each marked with what it was.
#[test]
fn changed_values_are_marked_with_what_they_were() {
    let (_, _, outcome) = identify("joystick_1dof.yaml", None, None, 1);
    let text = read("joystick_1dof.yaml");
    assert!(outcome.written.contains("# identified (was mass 0.020358)"), "{}", outcome.written);
    assert!(outcome.written.contains("(was inertia {slender_rod: 0.15})"), "{}", outcome.written);
    assert_eq!(text.lines().count(), outcome.written.lines().count());
    for (a, b) in text.lines().zip(outcome.written.lines()) {
        if a != b {
            assert!(b.contains("# identified (was "), "changed without a mark: {b}");
        }
    }
}

/// A key the file does not have (a joint's `damping`, a drive's `coulomb_friction`) is added
/// on a line of its own, in the entry's indentation.
#[test]
fn missing_keys_are_added() {
    let text = read("joystick_1dof.yaml")
        .replace("    damping: 1.0e-3\n", "")
        .replace("    coulomb_friction: 0.01        # estimate (simulation only)\n", "");
    let model = load("joystick_1dof.yaml", &text, None);
    let regressor = regressor(&model);
    let truth = true_model(&model, 11);
    let beta = regressor.base_values(&regressor.standard_values(&truth.model));
    let fitted = fit(&model, &regressor, &beta, None, &FitOptions::default()).expect("the fit starts");
    let written = write_model_file(&text, &model, &fitted).unwrap_or_else(|e| panic!("{e}"));
    assert!(written.contains("\n    damping: "), "{written}");
    assert!(written.contains("\n    coulomb_friction: "), "{written}");
    let reloaded = load("joystick_1dof.yaml", &written, None);
    let joint = &reloaded.joints[0];
    assert!((joint.drive.coulomb_friction - fitted.joints[0].coulomb_friction).abs() < 1e-10);
    let params = reloaded.nominal_parameters();
    let damping = joint.damping.eval(&NominalAtoms(&params));
    assert!((damping - fitted.joints[0].damping).abs() < 1e-12, "{damping} {:?}", fitted.joints[0]);
    check_comments_kept(&text, &written);
}

/// The identified model file `rig!` is tested on (`macros/tests/rig_identified.rs`), committed
/// because the macro reads its file at compile time.
const MACRO_FIXTURE: &str = "macros/tests/models/joystick_identified.yaml";

/// `a` and `b` line by line, their numbers within `1e-9` of each other (relative) and
/// everything else the same; the first difference otherwise.
fn same_up_to_rounding(a: &str, b: &str) -> Result<(), String> {
    let (la, lb): (Vec<&str>, Vec<&str>) = (a.lines().collect(), b.lines().collect());
    if la.len() != lb.len() {
        return Err(format!("{} lines against {}", la.len(), lb.len()));
    }
    let tokens = |line: &str| -> Vec<String> {
        line.split(|c: char| c.is_whitespace() || "[]{},:()".contains(c))
            .filter(|t| !t.is_empty())
            .map(str::to_string)
            .collect()
    };
    for (k, (x, y)) in la.iter().zip(&lb).enumerate() {
        let (tx, ty) = (tokens(x), tokens(y));
        let same = tx.len() == ty.len()
            && tx.iter().zip(&ty).all(|(p, q)| match (p.parse::<f64>(), q.parse::<f64>()) {
                (Ok(u), Ok(v)) => (u - v).abs() <= 1e-9 * u.abs().max(v.abs()),
                _ => p == q,
            });
        if !same {
            return Err(format!("line {}:\n  {x}\n  {y}", k + 1));
        }
    }
    Ok(())
}

#[test]
fn numbers_are_compared_up_to_rounding_and_everything_else_exactly() {
    assert_eq!(
        same_up_to_rounding("a: 1.0  # x\nb: [2, 3]\n", "a: 1.0000000000001  # x\nb: [2, 3]\n"),
        Ok(())
    );
    assert!(same_up_to_rounding("a: 1.0\n", "a: 1.001\n").unwrap_err().starts_with("line 1"));
    assert!(same_up_to_rounding("a: 1.0  # x\n", "a: 1.0  # y\n").is_err());
    assert!(same_up_to_rounding("a: 1.0\n", "a: 1.0\nb: 2\n").is_err());
}

/// `rig!`'s identified fixture is what `identify -o` writes (the consistent fit and the
/// writer) for the joystick whose base parameters are those of `scripts/pil-identify.sh`'s
/// "true" joystick (the stick 40 % heavier, its centre of mass 20 % further out, the grip 36 %
/// heavier, 30 % more friction). `HAPTICGEN_BLESS=1` rewrites the fixture after a deliberate
/// change of the writer or of the joystick's file.
#[test]
fn the_rig_macro_s_identified_fixture_is_what_identify_writes() {
    let file = "joystick_1dof.yaml";
    let text = read(file);
    let mut truth_text = text.clone();
    for (from, to) in [
        ("    mass: 0.020358\n", "    mass: 0.0285\n"),
        ("    com: [0.0, 0.075]\n", "    com: [0.0, 0.09]\n"),
        ("    mass: 0.05\n", "    mass: 0.068\n"),
        ("    damping: 1.0e-3\n", "    damping: 1.3e-3\n"),
        ("    coulomb_friction: 0.01 ", "    coulomb_friction: 0.013 "),
    ] {
        assert_eq!(truth_text.matches(from).count(), 1, "`{from}` in {file} (did the model file change?)");
        truth_text = truth_text.replace(from, to);
    }
    let model = load(file, &text, None);
    let truth = load("true.yaml", &truth_text, None);
    let regressor = regressor(&model);
    let beta = regressor.base_values(&regressor.standard_values(&truth.model));
    let fitted = fit(&model, &regressor, &beta, None, &FitOptions::default()).expect("the fit starts");
    let written = write_model_file(&text, &model, &fitted).unwrap_or_else(|e| panic!("{e}"));
    let path = format!("{}/../../{MACRO_FIXTURE}", env!("CARGO_MANIFEST_DIR"));
    if std::env::var("HAPTICGEN_BLESS").as_deref() == Ok("1") {
        std::fs::write(&path, &written).unwrap_or_else(|e| panic!("{path}: {e}"));
        eprintln!("wrote {path}");
    }
    let committed = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"));
    if let Err(difference) = same_up_to_rounding(&committed, &written) {
        panic!(
            "{MACRO_FIXTURE} is not what identify writes now ({difference}); if the change is meant, \
             rewrite it: HAPTICGEN_BLESS=1 cargo test -p hapticgen --test host consistent::the_rig_macro\n{written}"
        );
    }
    // The file is the true joystick's dynamics: its base parameters are the truth's.
    let reloaded = load(MACRO_FIXTURE, &committed, None);
    let beta_file = regressor.base_values(&regressor.standard_values(&reloaded.model));
    for ((b, t), base) in beta_file.iter().zip(&beta).zip(&regressor.base) {
        assert!((b - t).abs() <= 1e-6 * t.abs().max(1e-9), "{}: file {b:e}, truth {t:e}", base.name);
    }
}
