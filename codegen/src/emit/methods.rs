//! The rig's methods: each catalogue entry lowered to one `pub fn` (with the cheapest
//! derivation of its outputs), the fused per-tick `terms` and a closed chain's
//! `closure_margin`.

use proc_macro2::TokenStream;
use quote::{format_ident, quote};

use crate::dynamics::mechanics::Mechanics;
use crate::model::Model;
use crate::plan::{cheapest_choice, derivation_note, output_roots, output_roots_with};
use crate::sym::dag::{Dag, Node, NodeId, OpCounts};
use crate::sym::poly::Atom;

use super::catalogue::{output_names, tick_outputs, FunctionSpec, Shape};
use super::literal::{unsuffixed, Scalar};
use super::lower::{BodyEmitter, EmitOptions};
use super::naming::SharedNames;

/// The Rust type of a result of `shape`.
fn shape_tokens(shape: Shape, scalar: Scalar) -> TokenStream {
    let s = scalar.tokens();
    match shape {
        Shape::Scalar => s,
        Shape::Vector(n) => {
            let n = unsuffixed(n);
            quote!([#s; #n])
        }
        Shape::Matrix(r, c) => {
            let (r, c) = (unsuffixed(r), unsuffixed(c));
            quote!([[#s; #c]; #r])
        }
    }
}

/// The value of a result of `shape` from its outputs, row-major.
fn shape_value(shape: Shape, outputs: &[TokenStream]) -> TokenStream {
    match shape {
        Shape::Scalar => outputs[0].clone(),
        Shape::Vector(_) => quote!([#(#outputs),*]),
        Shape::Matrix(_, c) => {
            let rows = outputs.chunks(c.max(1)).map(|row| quote!([#(#row),*]));
            quote!([#(#rows),*])
        }
    }
}

/// Whether any input reachable from `roots` satisfies `pred`.
fn uses_atom(dag: &Dag, roots: &[NodeId], pred: impl Fn(Atom) -> bool) -> bool {
    dag.reachable(roots).into_iter().any(|id| matches!(dag.nodes()[id], Node::Input(a) if pred(a)))
}

/// Whether the body of `roots` reads `q` and `qd` (a spatial closed chain's loop values are
/// solved from them).
fn arguments_used(body: &BodyEmitter<'_>, roots: &[NodeId]) -> (bool, bool) {
    let loops = body.naming.loops;
    let reads_loops = |a: Atom| loops.is_some_and(|l| l.read(a).is_some());
    let measured_from = body.naming.model.tree_coordinates();
    let q_used = uses_atom(&body.dag, roots, |a| {
        matches!(a, Atom::Sin(j) | Atom::Cos(j) | Atom::Q(j) if usize::from(j) < measured_from)
            || reads_loops(a)
    });
    let qd_used = uses_atom(&body.dag, roots, |a| body.naming.reads_velocity(a));
    (q_used, qd_used)
}

/// Emits one method; returns it with its operation counts.
pub fn function(
    model: &Model,
    mech: &Mechanics,
    scalar: Scalar,
    options: EmitOptions,
    spec: &FunctionSpec<'_>,
) -> (TokenStream, OpCounts) {
    function_sharing(model, mech, scalar, options, spec, &SharedNames::default())
}

/// [`function`], naming its values as the rig's other functions sharing `names` do.
pub(crate) fn function_sharing(
    model: &Model,
    mech: &Mechanics,
    scalar: Scalar,
    options: EmitOptions,
    spec: &FunctionSpec<'_>,
    names: &SharedNames,
) -> (TokenStream, OpCounts) {
    let mut body = BodyEmitter::new(model, mech, scalar, options);
    body.share_names(names);
    let choice = cheapest_choice(model, mech, &spec.outputs, options.fused_multiply_add);
    let roots = output_roots_with(&mut body.dag, model, mech, &spec.outputs, choice);
    let doc = format!("{}{}", spec.doc, derivation_note(&spec.outputs, choice));
    let (statements, outputs, counts) =
        body.emit_named(&roots, &spec.name, &output_names(&spec.name, spec.shape));
    let value = shape_value(spec.shape, &outputs);
    let ret = shape_tokens(spec.shape, scalar);
    let n = unsuffixed(model.joints.len());
    let s = scalar.tokens();
    let (q_used, qd_used) = arguments_used(&body, &roots);
    let q = if q_used { quote!(q) } else { quote!(_q) };
    let qd = if qd_used { quote!(qd) } else { quote!(_qd) };
    let name = format_ident!("{}", spec.name);
    let measured_from = model.tree_coordinates();
    let measured_used = uses_atom(
        &body.dag,
        &roots,
        |a| matches!(a, Atom::Sin(j) | Atom::Cos(j) | Atom::Q(j) if usize::from(j) >= measured_from),
    );
    let measured = if measured_used { quote!(measured) } else { quote!(_measured) };
    let k = unsuffixed(model.measured.len());
    let args = if spec.takes_measured {
        quote!(&self, #q: &[#s; #n], #measured: &[#s; #k])
    } else if spec.takes_qdd {
        let qdd_used = uses_atom(&body.dag, &roots, |a| matches!(a, Atom::Qdd(_)));
        let qdd = if qdd_used { quote!(qdd) } else { quote!(_qdd) };
        quote!(&self, #q: &[#s; #n], #qd: &[#s; #n], #qdd: &[#s; #n])
    } else if spec.takes_qd {
        quote!(&self, #q: &[#s; #n], #qd: &[#s; #n])
    } else {
        quote!(&self, #q: &[#s; #n])
    };
    let body = match &spec.same_as {
        // The same outputs as a task function: call it (same arithmetic, same counts).
        Some(target) => {
            let target = format_ident!("{}", target);
            let call_args = if spec.takes_qd { quote!(self, #q, #qd) } else { quote!(self, #q) };
            quote!(Self::#target(#call_args))
        }
        None => quote!(#statements #value),
    };
    let tokens = quote! {
        #[doc = #doc]
        #[inline]
        #[must_use]
        pub fn #name(#args) -> #ret {
            #body
        }
    };
    (tokens, counts)
}

/// The fused per-tick `terms` method; returns it with its operation counts.
pub(crate) fn terms_function(
    model: &Model,
    mech: &Mechanics,
    scalar: Scalar,
    options: EmitOptions,
    names: &SharedNames,
) -> (TokenStream, OpCounts) {
    let mut body = BodyEmitter::new(model, mech, scalar, options);
    body.share_names(names);
    let roots = output_roots(&mut body.dag, model, mech, &tick_outputs(mech, true));
    let n = mech.joints;
    let m = mech.task_dim;
    let root_names: Vec<String> = [
        ("inertia_matrix", Shape::Matrix(n, n)),
        ("coriolis_times_qdot", Shape::Vector(n)),
        ("gravity", Shape::Vector(n)),
        ("position", Shape::Vector(m)),
        ("jacobian", Shape::Matrix(m, n)),
        ("jacobian_dot_times_qdot", Shape::Vector(m)),
    ]
    .into_iter()
    .flat_map(|(name, shape)| output_names(name, shape))
    .collect();
    let (statements, values, counts) = body.emit_named(&roots, "terms", &root_names);
    let mut rest = values.as_slice();
    let mut take = |k: usize| {
        let (head, tail) = rest.split_at(k);
        rest = tail;
        head.to_vec()
    };
    let inertia = shape_value(Shape::Matrix(n, n), &take(n * n));
    let coriolis = shape_value(Shape::Vector(n), &take(n));
    let gravity = shape_value(Shape::Vector(n), &take(n));
    let position = shape_value(Shape::Vector(m), &take(m));
    let jacobian = shape_value(Shape::Matrix(m, n), &take(m * n));
    let jdot = shape_value(Shape::Vector(m), &take(m));
    let (n, m) = (unsuffixed(n), unsuffixed(m));
    let s = scalar.tokens();
    let (q_used, qd_used) = arguments_used(&body, &roots);
    let q = if q_used { quote!(q) } else { quote!(_q) };
    let qd = if qd_used { quote!(qd) } else { quote!(_qd) };
    let tokens = quote! {
        /// Every term one control tick needs (`D`, `C q̇`, `g`, `p`, `J`, `J̇ q̇`), computed in one
        /// pass so that sines, cosines and products are shared.
        #[inline]
        #[must_use]
        pub fn terms(&self, #q: &[#s; #n], #qd: &[#s; #n]) -> ::hapticgen_runtime::RigTerms<#s, #n, #m> {
            #statements
            ::hapticgen_runtime::RigTerms {
                inertia_matrix: #inertia,
                coriolis_times_qdot: #coriolis,
                gravity: #gravity,
                position: #position,
                jacobian: #jacobian,
                jacobian_dot_times_qdot: #jdot,
            }
        }
    };
    (tokens, counts)
}

/// A closed chain's `closure_margin` method (see `crate::dynamics::closure::Installed::margins`).
pub(crate) fn closure_margin_function(
    model: &Model,
    mech: &Mechanics,
    scalar: Scalar,
    options: EmitOptions,
    names: &SharedNames,
) -> Option<(TokenStream, OpCounts)> {
    let closures = mech.closures.as_ref()?;
    if closures.solved_at_run_time().is_some() {
        return Some(spatial_loop_margin_function(model, scalar));
    }
    let mut body = BodyEmitter::new(model, mech, scalar, options);
    body.share_names(names);
    // The body's graph starts as the shared one with the elimination, whose margins these are.
    let roots = closures.installed().1.margins.clone();
    let (statements, values, counts) = body.emit(&roots, "closure_margin");
    let (n, k) = (unsuffixed(model.joints.len()), unsuffixed(roots.len()));
    let s = scalar.tokens();
    let names: Vec<String> = closures.loops.iter().map(|l| format!("`{}`", l.name)).collect();
    let doc = if closures.spatial.is_some() {
        " The loops' margins, each 1 at best and 0 where the loops are singular: first the platform's, `det² U / Π b_k²` (`U` the rows of the three shins' reaches, 0 with the shins parallel to one plane), then each knee's, `1 − (a₁·w)² / b_k²` (the squared sine of the angle between the shin and its knee's first axis, 0 where the universal joint locks); NaN where the loops cannot close. Guard the workspace with it: the dynamics grow without bound as it approaches 0.".to_string()
    } else {
        format!(
        " Assembly margin of each closure ({}): the squared sine of the angle between its two distal links; 1 with the links square to each other, 0 where the loop is singular (the links aligned, at the workspace boundary or with the passive joints' axes coincident), negative where the loop cannot close. Guard the workspace with it: the dynamics grow without bound as it approaches 0.",
        names.join(", ")
    )
    };
    let tokens = quote! {
        #[doc = #doc]
        #[inline]
        #[must_use]
        pub fn closure_margin(&self, q: &[#s; #n]) -> [#s; #k] {
            #statements
            [#(#values),*]
        }
    };
    Some((tokens, counts))
}

/// A spatial closed chain's `closure_margin`: the runtime's loop solver measures it
/// ([`hapticgen_runtime::loops::ClosedLoops::margin`]); its arithmetic is the solver's.
fn spatial_loop_margin_function(model: &Model, scalar: Scalar) -> (TokenStream, OpCounts) {
    let n = unsuffixed(model.joints.len());
    let s = scalar.tokens();
    let tokens = quote! {
        /// How far the loops are from singular at `q`: the reciprocal condition estimate of
        /// `Φ_p = ∂Φ/∂q_p` at the solution (smallest over largest pivot of its LU factors), 1 at
        /// best, 0 where the passive joints are no longer determined, NaN where the loops cannot
        /// be solved. Guard the workspace with it: the dynamics grow without bound as it
        /// approaches 0.
        #[inline]
        #[must_use]
        pub fn closure_margin(&self, q: &[#s; #n]) -> [#s; 1] {
            [::hapticgen_runtime::loops::close_loops(
                self,
                q,
                ::hapticgen_runtime::loops::LoopLevel::Position,
                ::core::option::Option::None,
            )
            .margin]
        }
    };
    (tokens, OpCounts::default())
}

/// The identification regressor `regressor(q, q̇, q̈)`, its base parameters' names,
/// combinations and nominal values (`crate::dynamics::regressor`); returns them with the
/// regressor's operation counts.
pub(crate) fn regressor_function(
    model: &Model,
    mech: &Mechanics,
    scalar: Scalar,
    options: EmitOptions,
    names: &SharedNames,
) -> (TokenStream, OpCounts) {
    use crate::dynamics::regressor::{Regressor, COULOMB_BAND};
    let regressor = Regressor::new(model, mech.closures.as_ref());
    let mut body = BodyEmitter::new(model, mech, scalar, options);
    body.share_names(names);
    let roots = regressor.build(&mut body.dag, model);
    let (n, p) = (regressor.joints, regressor.base.len());
    let shape = Shape::Matrix(n, p);
    let (statements, outputs, counts) =
        body.emit_named(&roots, "regressor", &output_names("regressor", shape));
    let value = shape_value(shape, &outputs);
    let ret = shape_tokens(shape, scalar);
    let s = scalar.tokens();
    let (q_used, qd_used) = arguments_used(&body, &roots);
    let q = if q_used { quote!(q) } else { quote!(_q) };
    let qd = if qd_used { quote!(qd) } else { quote!(_qd) };
    let qdd =
        if uses_atom(&body.dag, &roots, |a| matches!(a, Atom::Qdd(_))) { quote!(qdd) } else { quote!(_qdd) };
    let (n_tokens, p_tokens) = (unsuffixed(n), unsuffixed(p));
    let frames = if regressor.joint_frames {
        "each body's joint frame (after its joint, before a Denavit–Hartenberg tail)"
    } else {
        "each body's own frame"
    };
    let mut doc: Vec<String> = vec![
        " The dynamic-identification regressor: `τ = Y(q, q̇, q̈) β` with `β` the base parameters".into(),
        " [`Self::BASE_PARAMETERS`] (identifiable combinations of the standard ones; nominal values".into(),
        " [`Self::base_parameters`]), `τ` the inverse dynamics plus viscous friction `fv q̇`, Coulomb".into(),
        format!(
            " friction `fc q̇/√(q̇² + δ²)` (δ = [`Self::COULOMB_BAND`] = {COULOMB_BAND}) and an offset `off`."
        ),
        format!(" Standard parameters: per body `m`, `m c` and the inertia about the origin of {frames};"),
        " per joint the reflected rotor inertia `ia = N² J_m`, `fv`, `fc`, `off`. Columns:".into(),
        String::new(),
    ];
    for (k, b) in regressor.base.iter().enumerate() {
        let unit = regressor.standard[b.combination[0].0].unit;
        doc.push(format!(" {k}. `{}` = {} ({unit})", b.name, b.describe(&regressor.standard)));
    }
    let names_list = regressor.base.iter().map(|b| b.name.as_str());
    let combinations = regressor.base.iter().map(|b| b.describe(&regressor.standard));
    let values = regressor.base.iter().map(|b| scalar.literal(b.nominal));
    let band = scalar.literal(COULOMB_BAND);
    let tokens = quote! {
        /// The base parameters' names, in the order of the regressor's columns.
        pub const BASE_PARAMETERS: [&'static str; #p_tokens] = [#(#names_list),*];
        /// The standard parameters each base parameter combines, in the order of
        /// [`Self::BASE_PARAMETERS`].
        pub const BASE_PARAMETER_COMBINATIONS: [&'static str; #p_tokens] = [#(#combinations),*];
        /// The velocity band `δ` of the regressor's Coulomb columns `q̇/√(q̇² + δ²)`, rad/s (m/s
        /// for a prismatic joint).
        pub const COULOMB_BAND: #s = #band;

        /// The base parameters at the model's nominal values (viscous friction from the
        /// damping, Coulomb friction from the drives, offsets 0), in the order of
        /// [`Self::BASE_PARAMETERS`].
        #[inline]
        #[must_use]
        pub fn base_parameters(&self) -> [#s; #p_tokens] {
            [#(#values),*]
        }

        #(#[doc = #doc])*
        #[inline]
        #[must_use]
        pub fn regressor(&self, #q: &[#s; #n_tokens], #qd: &[#s; #n_tokens], #qdd: &[#s; #n_tokens]) -> #ret {
            #statements
            #value
        }
    };
    (tokens, counts)
}
