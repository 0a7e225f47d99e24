//! The sign-choice pass (`Dag::negations_after_signs`) on every function of every shipped
//! model: the values are bit-for-bit those of the DAG as built (a negation is exact), no
//! negation is added, and the other operations are unchanged in number.

use std::path::Path;

use hapticgen_codegen::dynamics::recursive::{self, PointQuantity, Quantity};
use hapticgen_codegen::load_file;
use hapticgen_codegen::sym::dag::Dag;
use hapticgen_codegen::sym::poly::Atom;

#[test]
fn chosen_signs_keep_every_value_and_never_add_a_negation() {
    let models = Path::new(env!("CARGO_MANIFEST_DIR")).join("../models");
    let mut removed = 0;
    let mut checked = 0;
    for entry in std::fs::read_dir(&models).expect("models/ exists") {
        let path = entry.expect("readable").path();
        let text = path.display().to_string();
        let model = load_file(&path, &text, None).unwrap_or_else(|d| panic!("{d}"));
        if !recursive::applies(&model) {
            continue;
        }
        let mech = hapticgen_codegen::derive(&model);
        let mut quantities = vec![
            Quantity::InertiaMatrix,
            Quantity::CoriolisTimesQdot,
            Quantity::Gravity,
            Quantity::InverseDynamics,
        ];
        for i in 0..model.points.len() {
            quantities.push(Quantity::Point(i, PointQuantity::Jacobian));
            quantities.push(Quantity::Point(i, PointQuantity::JacobianDotTimesQdot));
        }
        for quantity in quantities {
            let mut dag = Dag::new();
            let roots = recursive::build(&mut dag, &model, quantity);
            // Also the Lagrangian polynomials of the same model, a differently shaped DAG.
            let poly_roots: Vec<_> = mech.gravity.iter().map(|p| dag.polynomial(p)).collect();
            let roots: Vec<_> = roots.into_iter().chain(poly_roots).collect();
            let result = dag.negations_after_signs(&roots);
            let (signed, signed_roots) = (result.dag, result.roots);
            let (before, after) = (dag.count(&roots), signed.count(&signed_roots));
            assert!(after.negations <= before.negations, "{text} {quantity:?}: {before:?} → {after:?}");
            assert_eq!(
                (after.additions, after.multiplications, after.divisions, after.trigonometric),
                (before.additions, before.multiplications, before.divisions, before.trigonometric),
                "{text} {quantity:?}"
            );
            removed += before.negations - after.negations;
            for k in 0..5u64 {
                let value = |atom: Atom| {
                    let (j, salt) = match atom {
                        Atom::Sin(j) => (j, 1),
                        Atom::Cos(j) => (j, 2),
                        Atom::Q(j) => (j, 3),
                        Atom::Qd(j) => (j, 4),
                        Atom::Qdd(j) => (j, 5),
                        _ => (0, 6),
                    };
                    let x = (k * 7 + u64::from(j) * 13 + salt * 31) as f64;
                    (x * 0.618_033_988_749_895).sin() * 2.0
                };
                let (all, all_signed) = (dag.eval_all(&value), signed.eval_all(&value));
                for (r, s) in roots.iter().zip(&signed_roots) {
                    assert_eq!(all[*r].to_bits(), all_signed[*s].to_bits(), "{text} {quantity:?}");
                }
            }
            checked += 1;
        }
    }
    assert!(checked >= 20, "only {checked} DAGs checked");
    assert!(removed > 0, "the pass removed no negation anywhere");
}
