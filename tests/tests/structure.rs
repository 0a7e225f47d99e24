//! Structural properties of the parallel link's generated dynamics that the paper's
//! derivation predicts (section 5, Spong's five-bar): constant diagonal inertia, an
//! off-diagonal entry proportional to cos(q1 − q2), and only the sines and cosines of q1 and
//! q2 evaluated (two sin/cos pairs) for D, C q̇, g, J and J̇ q̇ together; and the operation
//! counts of those quantities against the targets docs/operation-counts.md states.

use hapticgen_codegen::dynamics::mechanics;
use hapticgen_codegen::emit;
use hapticgen_codegen::sym::poly::Atom;
use hapticgen_codegen::{EmitOptions, Scalar};
use hapticgen_tests::workspace_root;

fn parallel_link(variant: &str) -> (hapticgen_codegen::CheckedModel, mechanics::Mechanics) {
    let path = workspace_root().join("models/parallel_link_2dof.yaml");
    let m = hapticgen_codegen::load_file(&path, "models/parallel_link_2dof.yaml", Some(variant)).unwrap();
    let mech = hapticgen_codegen::derive(&m);
    (m, mech)
}

#[test]
fn inertia_matrix_has_constant_diagonal_and_cosine_of_the_difference_off_diagonal() {
    for variant in ["vertical", "horizontal"] {
        let (_, mech) = parallel_link(variant);
        let d = &mech.inertia_matrix;
        assert!(d[0][0].as_constant().is_some(), "D11 = {}", d[0][0]);
        assert!(d[1][1].as_constant().is_some(), "D22 = {}", d[1][1]);
        // D12 = k (cos q1 cos q2 + sin q1 sin q2) = k cos(q1 − q2).
        let terms: Vec<_> = d[0][1].terms().collect();
        assert_eq!(terms.len(), 2, "D12 = {}", d[0][1]);
        let cc = vec![(Atom::Cos(0), 1), (Atom::Cos(1), 1)];
        let ss = vec![(Atom::Sin(0), 1), (Atom::Sin(1), 1)];
        let k_cc = terms.iter().find(|(m, _)| **m == cc).map(|(_, c)| *c).expect("cos q1 cos q2 term");
        let k_ss = terms.iter().find(|(m, _)| **m == ss).map(|(_, c)| *c).expect("sin q1 sin q2 term");
        assert_eq!(k_cc, k_ss);
        // Independent value: m3·l2·lc3 + m4·l1·lc4 (link 3's and link 4's cross terms).
        let expected = 0.020358 * 0.15 * 0.075 + 0.081 * 0.15 * 0.05;
        assert!((k_cc - expected).abs() < 1e-15, "coefficient {k_cc}, expected {expected}");
    }
}

#[test]
fn tick_quantities_need_two_sine_cosine_pairs() {
    for variant in ["vertical", "horizontal"] {
        let (m, mech) = parallel_link(variant);
        let counts = emit::tick_counts(&m, &mech, false);
        assert!(counts.trigonometric <= 4, "{variant}: {counts:?}");
        // The emitted fused function evaluates sin and cos of q1 and of q2 in one call each.
        let text = hapticgen_codegen::generate_model(m, Scalar::F64).file_text();
        let terms = &text[text.find("pub fn terms").unwrap()..];
        let terms = &terms[..terms.find("\n    }\n").unwrap()];
        assert_eq!(terms.matches("Real::sin_cos(").count(), 2, "{terms}");
        assert_eq!(terms.matches("Real::sin(").count() + terms.matches("Real::cos(").count(), 0, "{terms}");
    }
}

/// D, C q̇, g, J and J̇ q̇ of the parallel link (vertical) together in at most 25
/// arithmetic operations with 4 trigonometric evaluations, and, with fused multiply-adds (each
/// one operation), fewer than 25 operations with the trigonometric ones counted (SymPy with
/// `simplify` + `cse`: 19 + 6 = 25). The counts are deterministic.
#[test]
fn parallel_link_tick_meets_the_operation_count_targets() {
    let (m, mech) = parallel_link("vertical");
    let plain = emit::tick_counts(&m, &mech, false);
    assert!(plain.arithmetic() <= 25 && plain.trigonometric == 4, "{plain:?}");
    assert_eq!(plain.fused, 0, "{plain:?}");
    let fma = EmitOptions { fused_multiply_add: true, ..Default::default() };
    let fused = emit::tick_counts_with(&m, &mech, false, fma);
    assert!(fused.arithmetic() + fused.trigonometric < 25, "{fused:?}");
    assert!(fused.fused > 0 && fused.trigonometric == 4, "{fused:?}");
    // The horizontal variant has no gravity terms: two multiplications fewer.
    let (m, mech) = parallel_link("horizontal");
    let plain_h = emit::tick_counts(&m, &mech, false);
    let fused_h = emit::tick_counts_with(&m, &mech, false, fma);
    assert_eq!(plain_h.arithmetic() + 2, plain.arithmetic(), "{plain_h:?}");
    assert_eq!(fused_h.arithmetic() + 2, fused.arithmetic(), "{fused_h:?}");
}

/// The counts `tick_counts` reports are those of the emitted `terms` function (with p), and the
/// fused code calls the runtime's fused multiply-adds exactly `fused` times.
#[test]
fn emitted_fused_terms_match_their_counts() {
    for variant in ["vertical", "horizontal"] {
        let (m, mech) = parallel_link(variant);
        let fma = EmitOptions { fused_multiply_add: true, ..Default::default() };
        let counts = emit::tick_counts_with(&m, &mech, true, fma);
        let generated = hapticgen_codegen::generate_model_with(m, Scalar::F32, fma);
        let terms = generated.stats.functions.iter().find(|(name, _)| name == "terms").unwrap().1;
        assert_eq!(terms, counts, "{variant}");
        let text = generated.file_text();
        let body = &text[text.find("pub fn terms").unwrap()..];
        let body = &body[..body.find("\n    }\n").unwrap()];
        let calls = ["Real::mul_add(", "Real::mul_sub(", "Real::neg_mul_add(", "Real::neg_mul_sub("]
            .iter()
            .map(|f| body.matches(f).count())
            .sum::<usize>();
        assert_eq!(calls, counts.fused, "{variant}: {body}");
    }
}
