//! A spatial closed chain's loops as the runtime solves them: the implementation of
//! `::hapticgen_runtime::loops::LoopConstraints` (the constraints `Φ(q_a, q_p) = 0` of
//! [`crate::dynamics::spatial_loops`], their Jacobians `Φ_p`, `Φ_a`, rates `Φ̇_p`, `Φ̇_a` and
//! convective term `γ = Φ̇_p q̇_p + Φ̇_a q̇_a`,
//! straight-line over `q` and the argument `passive`), the assembly Newton's method starts
//! from, and the solver's bounds. The rig's other functions call
//! `::hapticgen_runtime::loops::close_loops` on it at their top (see `lower`), and read the
//! passive coordinates, their rates and `A`, `Ȧ` from its result.

use proc_macro2::TokenStream;
use quote::{format_ident, quote};

use crate::dynamics::mechanics::Mechanics;
use crate::dynamics::spatial_loops::WARM_START_RADIUS;
use crate::model::Model;
use crate::sym::dag::{Dag, Node, NodeId, OpCounts};
use crate::sym::poly::{Atom, Poly};

use super::literal::{unsuffixed, Scalar};
use super::lower::{BodyEmitter, EmitOptions};
use super::naming::SharedNames;

/// The machine epsilon of `scalar`.
fn epsilon(scalar: Scalar) -> f64 {
    match scalar {
        Scalar::F32 => f64::from(f32::EPSILON),
        Scalar::F64 => f64::EPSILON,
    }
}

/// Builds each of `polys` on a graph.
fn nodes<'a>(polys: &'a [&'a Poly]) -> impl Fn(&mut Dag) -> Vec<NodeId> + 'a {
    move |dag: &mut Dag| polys.iter().map(|poly| dag.polynomial(poly)).collect()
}

/// The entries of a matrix of polynomials, row-major.
fn flat(m: &[Vec<Poly>]) -> Vec<&Poly> {
    m.iter().flatten().collect()
}

/// The `LoopConstraints` implementation of a spatial closed chain, with the operation counts
/// of its functions; `None` for any other rig.
pub(crate) fn loop_constraints_impl(
    model: &Model,
    mech: &Mechanics,
    scalar: Scalar,
    options: EmitOptions,
    names: &SharedNames,
) -> Option<(TokenStream, Vec<(String, OpCounts)>)> {
    let spatial = mech.closures.as_ref()?.solved_at_run_time()?;
    let (n, p) = (spatial.actuated, spatial.passive);
    let (n_lit, p_lit) = (unsuffixed(n), unsuffixed(p));
    let s = scalar.tokens();
    let literal = |x: f64| scalar.literal(x);
    let vector = |v: &[f64]| {
        let entries = v.iter().map(|&x| literal(x));
        quote!([#(#entries),*])
    };
    let assembly_actuated = vector(&spatial.nominal_actuated);
    let assembly_passive = vector(&spatial.assembly);
    let sensitivity_rows = spatial.assembly_sensitivity.iter().map(|row| vector(row));
    let max_steps = proc_macro2::Literal::u32_unsuffixed(spatial.newton_step_bound() as u32);
    // Converged at a few tens of roundings of the loops' lengths (an order of magnitude above
    // the residual's own rounding); singular (refused) only
    // near the precision's end, the safety monitor's loop-margin threshold coming far earlier.
    let tolerance = literal(32.0 * epsilon(scalar) * spatial.length_scale());
    let min_pivot_ratio = literal(1e3 * epsilon(scalar));
    let warm_start_radius = literal(WARM_START_RADIUS);
    let tolerance_doc = format!(
        " Newton's method from the last solution within {WARM_START_RADIUS} of the actuated coordinates, else from the assembly's tangent: at most {max_steps} steps (the generator saw at most {} over the actuated ranges), converged when every `|Φ_i|` is at most 32 ε times the loops' largest length.",
        spatial.newton_steps
    );

    let mut counts = Vec::new();
    // A function of the constraints: `roots` builds its outputs on the body's graph.
    let mut function = |name: &str, roots: &dyn Fn(&mut Dag) -> Vec<NodeId>, output_names: Vec<String>| {
        let mut body = BodyEmitter::new(model, mech, scalar, options);
        body.share_names(names);
        if let Some(loops) = &mut body.naming.loops {
            loops.solved = false;
        }
        let roots = roots(&mut body.dag);
        let (statements, outputs, op_counts) = body.emit_named(&roots, name, &output_names);
        counts.push((name.to_string(), op_counts));
        // Which arguments the body reads: actuated angles, passive coordinates, the passive
        // angles' sines and cosines, and the rates.
        let (mut actuated, mut passive, mut passive_trig, mut actuated_rate, mut passive_rate) =
            (false, false, false, false, false);
        for id in body.dag.reachable(&roots) {
            if let Node::Input(atom) = body.dag.nodes()[id] {
                match atom {
                    Atom::Q(j) | Atom::Sin(j) | Atom::Cos(j) if usize::from(j) < n => actuated = true,
                    Atom::Q(_) => passive = true,
                    Atom::Sin(_) | Atom::Cos(_) => passive_trig = true,
                    Atom::Qd(j) if usize::from(j) < n => actuated_rate = true,
                    Atom::Qd(_) => passive_rate = true,
                    _ => {}
                }
            }
        }
        let argument = |read: bool, name: &str| format_ident!("{}{}", if read { "" } else { "_" }, name);
        let arguments = [
            argument(actuated, "q"),
            argument(passive, "passive"),
            argument(passive_trig, "passive_sin_cos"),
            argument(actuated_rate, "qd"),
            argument(passive_rate, "passive_rate"),
        ];
        (statements, outputs, arguments)
    };
    let matrix_names = |base: &str, columns: usize| -> Vec<String> {
        (0..p).flat_map(|r| (0..columns).map(move |c| format!("{base}_{r}_{c}"))).collect()
    };
    let rows = |outputs: &[TokenStream], columns: usize| {
        let rows = outputs.chunks(columns.max(1)).map(|row| quote!([#(#row),*]));
        quote!([#(#rows),*])
    };

    let equation_names = |suffix: &str| -> Vec<String> {
        spatial.equation_names.iter().map(|e| format!("{}_{suffix}", e.replace('.', "_"))).collect()
    };
    let residual_names = equation_names("residual");
    let polys: Vec<&Poly> = spatial.residual.iter().chain(flat(&spatial.passive_jacobian)).collect();
    let names_all = residual_names.into_iter().chain(matrix_names("passive_jacobian", p)).collect();
    let (statements, outputs, [q, passive, passive_sin_cos, ..]) =
        function("loop_constraints", &nodes(&polys), names_all);
    let (residual, passive_jacobian) = outputs.split_at(p);
    let passive_jacobian = rows(passive_jacobian, p);
    let constraints = quote! {
        #[inline]
        fn loop_constraints(
            &self,
            #q: &[#s; #n_lit],
            #passive: &[#s; #p_lit],
            #passive_sin_cos: &[(#s, #s); #p_lit],
        ) -> ([#s; #p_lit], [[#s; #p_lit]; #p_lit]) {
            #statements
            ([#(#residual),*], #passive_jacobian)
        }
    };

    let (statements, outputs, [q, passive, passive_sin_cos, ..]) = function(
        "loop_actuated_jacobian",
        &nodes(&flat(&spatial.actuated_jacobian)),
        matrix_names("actuated_jacobian", n),
    );
    let actuated_jacobian = rows(&outputs, n);
    let actuated = quote! {
        #[inline]
        fn loop_actuated_jacobian(
            &self,
            #q: &[#s; #n_lit],
            #passive: &[#s; #p_lit],
            #passive_sin_cos: &[(#s, #s); #p_lit],
        ) -> [[#s; #n_lit]; #p_lit] {
            #statements
            #actuated_jacobian
        }
    };

    // `γ_i = Σ_k (Φ̇_q)_ik q̇_k` over the rates' polynomials: expanded, `Φ`'s second derivative
    // is a larger quadratic form in the velocities (1,451 operations on the Falcon-like Delta
    // against 1,232 this way).
    let convective_roots = |dag: &mut Dag| -> Vec<NodeId> {
        let total = n + p;
        spatial
            .passive_jacobian_dot
            .iter()
            .zip(&spatial.actuated_jacobian_dot)
            .map(|(passive_row, actuated_row)| {
                let terms: Vec<NodeId> = actuated_row
                    .iter()
                    .chain(passive_row)
                    .zip(0..total)
                    .map(|(rate, k)| {
                        let rate = dag.polynomial(rate);
                        let velocity = dag.input(Atom::Qd(k as u16));
                        dag.mul(rate, velocity)
                    })
                    .collect();
                terms.into_iter().reduce(|sum, term| dag.add(sum, term)).unwrap_or_else(|| dag.constant(0.0))
            })
            .collect()
    };
    let (statements, outputs, [q, passive, passive_sin_cos, qd, passive_rate]) =
        function("loop_convective", &convective_roots, equation_names("convective"));
    let convective = quote! {
        #[inline]
        fn loop_convective(
            &self,
            #q: &[#s; #n_lit],
            #qd: &[#s; #n_lit],
            #passive: &[#s; #p_lit],
            #passive_sin_cos: &[(#s, #s); #p_lit],
            #passive_rate: &[#s; #p_lit],
        ) -> [#s; #p_lit] {
            #statements
            [#(#outputs),*]
        }
    };

    let polys: Vec<&Poly> =
        flat(&spatial.passive_jacobian_dot).into_iter().chain(flat(&spatial.actuated_jacobian_dot)).collect();
    let names_all = matrix_names("passive_jacobian_rate", p)
        .into_iter()
        .chain(matrix_names("actuated_jacobian_rate", n))
        .collect();
    let (statements, outputs, [q, passive, passive_sin_cos, qd, passive_rate]) =
        function("loop_jacobian_rates", &nodes(&polys), names_all);
    let (passive_rate_rows, actuated_rate_rows) = outputs.split_at(p * p);
    let (passive_rate_rows, actuated_rate_rows) = (rows(passive_rate_rows, p), rows(actuated_rate_rows, n));
    let rates = quote! {
        #[inline]
        fn loop_jacobian_rates(
            &self,
            #q: &[#s; #n_lit],
            #qd: &[#s; #n_lit],
            #passive: &[#s; #p_lit],
            #passive_sin_cos: &[(#s, #s); #p_lit],
            #passive_rate: &[#s; #p_lit],
        ) -> ([[#s; #p_lit]; #p_lit], [[#s; #n_lit]; #p_lit]) {
            #statements
            (#passive_rate_rows, #actuated_rate_rows)
        }
    };

    let type_name = format_ident!("{}", super::naming::rig_type_name(model));
    let tokens = quote! {
        // The loops' constraints, for `::hapticgen_runtime::loops::close_loops`.
        impl ::hapticgen_runtime::loops::LoopConstraints<#s, #n_lit, #p_lit> for #type_name {
            const ASSEMBLY_ACTUATED: [#s; #n_lit] = #assembly_actuated;
            const ASSEMBLY_PASSIVE: [#s; #p_lit] = #assembly_passive;
            const ASSEMBLY_SENSITIVITY: [[#s; #n_lit]; #p_lit] = [#(#sensitivity_rows),*];
            #[doc = #tolerance_doc]
            const LOOP_SOLVER: ::hapticgen_runtime::loops::LoopSolverSettings<#s> =
                ::hapticgen_runtime::loops::LoopSolverSettings {
                    max_steps: #max_steps,
                    tolerance: #tolerance,
                    min_pivot_ratio: #min_pivot_ratio,
                    warm_start_radius: #warm_start_radius,
                };
            #[inline]
            fn loop_cache(&self) -> &::hapticgen_runtime::loops::LoopCache<#s, #n_lit, #p_lit> {
                &self.loop_cache
            }
            #constraints
            #actuated
            #convective
            #rates
        }
    };
    Some((tokens, counts))
}
