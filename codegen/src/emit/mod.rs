//! Emission of straight-line Rust from the derived mechanics.
//!
//! For each quantity of eq. (1)–(2) (`D`, `C`, `C q̇`, `g`, `B`, `p`, `J`, `J̇`, `J̇ q̇`) and
//! for the fused per-tick `terms` function, the polynomials go into one hash-consed DAG, and
//! each node used more than once becomes a named `let`. Sines and cosines of each angle are
//! computed once per function. The items implement `::hapticgen_runtime::RigModel`; everything
//! that is the same for every rig stays in the runtime.

pub mod laws;

use rustc_hash::FxHashMap as HashMap;

use proc_macro2::{Ident, Span, TokenStream};
use quote::{format_ident, quote};

use crate::dynamics::mechanics::{Choice, Derivation, Mechanics};
use crate::dynamics::recursive::{FrameQuantity, PointQuantity, Quantity};
use crate::model::{JointKind, Model};
use crate::sym::dag::{Dag, Fused, Node, NodeId, OpCounts};
use crate::sym::poly::{Atom, Poly};

/// The floating-point type of the generated code.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Scalar {
    /// Single precision (Cortex-M4F firmware).
    F32,
    /// Double precision (host).
    F64,
}

impl Scalar {
    /// `f32` or `f64`.
    pub fn name(self) -> &'static str {
        match self {
            Scalar::F32 => "f32",
            Scalar::F64 => "f64",
        }
    }

    fn tokens(self) -> TokenStream {
        match self {
            Scalar::F32 => quote!(f32),
            Scalar::F64 => quote!(f64),
        }
    }

    /// A literal of this type. A value that is exactly one of `core`'s mathematical constants
    /// (e.g. a joint limit of −45° = −π/4) is written as that constant, which is what clippy's
    /// `approx_constant` lint asks of the generated code.
    pub fn literal(self, value: f64) -> TokenStream {
        // A constant that is not finite in this type (a 0/0 folded in the DAG for a singular
        // model, or an f64 beyond f32's range) is spelled with the type's named constants:
        // the runtime's checks then see it, and no float literal is malformed.
        let rounded = match self {
            Scalar::F32 => f64::from(value as f32),
            Scalar::F64 => value,
        };
        if !rounded.is_finite() {
            let ty = self.tokens();
            return if rounded.is_nan() {
                quote!(#ty::NAN)
            } else if rounded > 0.0 {
                quote!(#ty::INFINITY)
            } else {
                quote!(#ty::NEG_INFINITY)
            };
        }
        let magnitude = value.abs();
        if let Some(name) = named_constant(magnitude) {
            let ident = syn::Ident::new(name, Span::call_site());
            let ty = self.tokens();
            let path = quote!(::core::#ty::consts::#ident);
            return if value < 0.0 { quote!(-#path) } else { path };
        }
        let text = match self {
            Scalar::F32 => format!("{:?}_f32", magnitude as f32),
            Scalar::F64 => format!("{magnitude:?}_f64"),
        };
        let lit = syn::LitFloat::new(&text, Span::call_site());
        if value < 0.0 {
            quote!(-#lit)
        } else {
            quote!(#lit)
        }
    }
}

/// The name of the `core::f64::consts` constant equal to `x`, if any.
fn named_constant(x: f64) -> Option<&'static str> {
    use std::f64::consts as c;
    const NAMES: [(f64, &str); 17] = [
        (c::PI, "PI"),
        (c::TAU, "TAU"),
        (c::FRAC_PI_2, "FRAC_PI_2"),
        (c::FRAC_PI_3, "FRAC_PI_3"),
        (c::FRAC_PI_4, "FRAC_PI_4"),
        (c::FRAC_PI_6, "FRAC_PI_6"),
        (c::FRAC_PI_8, "FRAC_PI_8"),
        (c::FRAC_1_PI, "FRAC_1_PI"),
        (c::FRAC_2_PI, "FRAC_2_PI"),
        (c::FRAC_2_SQRT_PI, "FRAC_2_SQRT_PI"),
        (c::SQRT_2, "SQRT_2"),
        (c::FRAC_1_SQRT_2, "FRAC_1_SQRT_2"),
        (c::E, "E"),
        (c::LN_2, "LN_2"),
        (c::LN_10, "LN_10"),
        (c::LOG2_E, "LOG2_E"),
        (c::LOG10_E, "LOG10_E"),
    ];
    NAMES.iter().find(|(v, _)| *v == x).map(|(_, name)| *name)
}

/// Options of the emitted code besides its scalar type. The default is what every front end
/// emits unless asked otherwise.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct EmitOptions {
    /// Fuse each multiplication used only by one addition or subtraction into it, emitted as a
    /// call of `::hapticgen_runtime::Real::mul_add` (`a·b + c`), `mul_sub` (`a·b − c`),
    /// `neg_mul_add` (`c − a·b`) or `neg_mul_sub` (`−a·b − c`): one correctly rounded
    /// operation each (`vfma`/`vfnms`/`vfms`/`vfnma` on ARM VFPv4, `vfmadd`/`vfmsub`/`vfnmadd`/
    /// `vfnmsub` on x86 FMA3, in that order), counted in [`OpCounts::fused`] (one operation, two flops). A
    /// negated product used once, `−(a·b)`, counts as one multiplication (`vnmul` on ARM). The
    /// optimiser then minimises that count. Results differ from unfused code by the rounding
    /// the fusion saves, and are the same on every target (the runtime's `mul_add` is exact).
    pub fused_multiply_add: bool,
}

/// The shape of a function's result.
#[derive(Clone, Copy, Debug)]
pub enum Shape {
    /// `S`.
    Scalar,
    /// `[S; n]`.
    Vector(usize),
    /// `[[S; cols]; rows]`.
    Matrix(usize, usize),
}

/// One emitted function: its name, documentation and output polynomials (row-major).
pub struct FunctionSpec<'a> {
    /// Rust name.
    pub name: String,
    /// Doc comment.
    pub doc: String,
    /// Result shape.
    pub shape: Shape,
    /// The outputs, row-major.
    pub outputs: Vec<Output<'a>>,
    /// Takes `qd` (the trait signature may require it even if unused).
    pub takes_qd: bool,
    /// Takes `qdd` (the inverse dynamics).
    pub takes_qdd: bool,
}

/// Where an output's expression comes from.
#[derive(Clone, Copy, Debug)]
pub enum Output<'a> {
    /// A polynomial of the mechanics.
    Poly(&'a Poly),
    /// Entry `k` (row-major) of a quantity built with the model's derivation
    /// ([`Mechanics::build`]): polynomial or recursive.
    Quantity(Quantity, usize),
}

/// The DAG nodes of `outputs` with the model's default derivations; each quantity is built
/// once per DAG.
fn output_roots(dag: &mut Dag, model: &Model, mech: &Mechanics, outputs: &[Output<'_>]) -> Vec<NodeId> {
    output_roots_with(dag, model, mech, outputs, mech.choice())
}

fn output_roots_with(
    dag: &mut Dag,
    model: &Model,
    mech: &Mechanics,
    outputs: &[Output<'_>],
    choice: Choice,
) -> Vec<NodeId> {
    let mut built: HashMap<Quantity, Vec<NodeId>> = HashMap::default();
    outputs
        .iter()
        .map(|output| match *output {
            Output::Poly(p) => dag.polynomial(p),
            Output::Quantity(q, k) => {
                built.entry(q).or_insert_with(|| mech.build_with(dag, model, q, choice))[k]
            }
        })
        .collect()
}

/// How a function's outputs were derived, for its doc comment (empty for the Lagrangian
/// polynomials, which the module documentation describes).
fn derivation_note(outputs: &[Output<'_>], choice: Choice) -> &'static str {
    let Some(Output::Quantity(quantity, _)) = outputs.iter().find(|o| matches!(o, Output::Quantity(..)))
    else {
        return "";
    };
    match (quantity, choice.dynamics, choice.kinematics) {
        (Quantity::Point(_, PointQuantity::JacobianDotTimesQdot), _, Derivation::Recursive) => {
            " Built by the Newton–Euler forward pass at `q̈ = 0`."
        }
        (Quantity::Point(_, PointQuantity::Jacobian), _, Derivation::Recursive) => {
            " Built by composing the joint frames (columns `z_k × (p − o_k)`)."
        }
        (Quantity::Point(..) | Quantity::Frame(..), _, Derivation::Recursive) => {
            " Built by composing the joint frames."
        }
        (Quantity::Point(..) | Quantity::Frame(..), _, Derivation::Polynomial) => "",
        (Quantity::InertiaMatrix, Derivation::Recursive, _) => {
            " Built by the composite-rigid-body algorithm."
        }
        (Quantity::CoriolisMatrix, Derivation::Recursive, _) => {
            " `D` from the composite-rigid-body algorithm, differentiated on the expression graph."
        }
        (_, Derivation::Recursive, _) => " Built by the recursive Newton–Euler algorithm.",
        (Quantity::CoriolisTimesQdot | Quantity::InverseDynamics, Derivation::Polynomial, _)
            if choice.structured_coriolis =>
        {
            " `C q̇` in the Christoffel form `Σ_{i≤j} Γ_kij q̇_i q̇_j` over shared partial derivatives of `D`."
        }
        _ => "",
    }
}

/// The derivation choice under which `outputs` take the fewest operations on their own.
fn cheapest_choice(model: &Model, mech: &Mechanics, outputs: &[Output<'_>], options: EmitOptions) -> Choice {
    if !outputs.iter().any(|o| matches!(o, Output::Quantity(..))) {
        return mech.choice();
    }
    let cost = |choice: Choice| {
        let mut dag = Dag::new();
        let roots = output_roots_with(&mut dag, model, mech, outputs, choice);
        let counts = dag.optimised_count_with(&roots, options.fused_multiply_add);
        counts.arithmetic() + counts.trigonometric
    };
    // The default first, so that a tie keeps it.
    let mut best = (cost(mech.choice()), mech.choice());
    for choice in mech.choices(model) {
        let c = cost(choice);
        if c < best.0 {
            best = (c, choice);
        }
    }
    best.1
}

fn quantity(q: Quantity, len: usize) -> Vec<Output<'static>> {
    (0..len).map(|k| Output::Quantity(q, k)).collect()
}

/// Names of inputs and how the generated code reads them.
#[derive(Clone)]
struct Naming<'m> {
    model: &'m Model,
    /// Inputs of fused control laws: binding name and how to read the value.
    externals: Vec<(String, TokenStream)>,
}

impl Naming<'_> {
    fn atom_name(&self, atom: Atom) -> String {
        let joint = |j: u16| self.model.joints[usize::from(j)].name.clone();
        match atom {
            Atom::Sin(j) => format!("sin_{}", joint(j)),
            Atom::Cos(j) => format!("cos_{}", joint(j)),
            // `q` and `qd` name the input arrays, so a joint called so gets a suffix.
            Atom::Q(j) => match joint(j).as_str() {
                "q" | "qd" => format!("{}_value", joint(j)),
                name => name.to_string(),
            },
            Atom::Qd(j) => format!("{}_dot", joint(j)),
            Atom::Qdd(j) => format!("{}_ddot", joint(j)),
            Atom::Param(k) => self.model.tunable[usize::from(k)].name.clone(),
            Atom::Closure(k) => format!("closure_{k}"),
            Atom::External(k) => self
                .externals
                .get(usize::from(k))
                .map(|e| e.0.clone())
                .unwrap_or_else(|| format!("input_{k}")),
        }
    }
}

/// Emits the body of one or more outputs sharing one DAG.
struct BodyEmitter<'m> {
    dag: Dag,
    naming: Naming<'m>,
    scalar: Scalar,
    /// Names for nodes with a known role (e.g. `jacobian_determinant`).
    hints: HashMap<NodeId, String>,
    /// Emission options.
    options: EmitOptions,
    /// Nodes emitted as fused multiply-adds (with [`EmitOptions::fused_multiply_add`]), set by
    /// [`BodyEmitter::emit`].
    fusions: HashMap<NodeId, Fused>,
}

#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Precedence {
    Sum,
    Product,
    Unary,
    Atomic,
}

impl<'m> BodyEmitter<'m> {
    fn new(model: &'m Model, mech: &Mechanics, scalar: Scalar, options: EmitOptions) -> Self {
        // A closed chain's passive coordinates enter every polynomial as nodes computed from
        // the actuated ones (`crate::dynamics::closure`), named after their role.
        let mut dag = Dag::new();
        let hints =
            crate::dynamics::closure::install(&mut dag, mech.closures.as_ref()).hints.into_iter().collect();
        Self {
            dag,
            naming: Naming { model, externals: Vec::new() },
            scalar,
            hints,
            options,
            fusions: HashMap::default(),
        }
    }

    /// A descriptive name for a node, if a short one exists.
    fn describe(&self, id: NodeId, names: &HashMap<NodeId, String>) -> Option<String> {
        let name_of = |x: NodeId| -> Option<String> {
            if let Some(n) = names.get(&x) {
                return Some(n.clone());
            }
            match self.dag.nodes()[x] {
                Node::Input(a) => Some(self.naming.atom_name(a)),
                // A square inside a product (`0.15 q̇1²` after regrouping): `scaled_q1_dot_sq`.
                Node::Mul(a, b) if a == b => self.describe(x, names),
                other => {
                    self.angle_identity(other, &|j| self.naming.model.joints[usize::from(j)].name.clone())
                }
            }
        };
        let node = self.dag.nodes()[id];
        let joint = |j: u16| self.naming.model.joints[usize::from(j)].name.clone();
        // Angle-sum identities get their mathematical names.
        if let Some(name) = self.angle_identity(node, &joint) {
            return Some(name);
        }
        let name = match node {
            Node::Mul(a, b) if a == b => format!("{}_sq", name_of(a)?),
            Node::Mul(a, b) => {
                let (ca, cb) = (self.dag.constant_value(a), self.dag.constant_value(b));
                match (ca, cb) {
                    (Some(_), None) => format!("scaled_{}", name_of(b)?),
                    (None, Some(_)) => format!("scaled_{}", name_of(a)?),
                    _ => format!("{}_{}", name_of(a)?, name_of(b)?),
                }
            }
            Node::Add(a, b) => format!("{}_plus_{}", name_of(a)?, name_of(b)?),
            Node::Sub(a, b) => format!("{}_minus_{}", name_of(a)?, name_of(b)?),
            Node::Neg(a) => format!("minus_{}", name_of(a)?),
            Node::Div(a, b) => format!("{}_over_{}", name_of(a)?, name_of(b)?),
            Node::Sqrt(a) => format!("sqrt_{}", name_of(a)?),
            _ => return None,
        };
        (name.len() <= 32).then_some(name)
    }

    /// `cos q_i cos q_j ± sin q_i sin q_j` and `sin q_i cos q_j ± cos q_i sin q_j`.
    fn angle_identity(&self, node: Node, joint: &dyn Fn(u16) -> String) -> Option<String> {
        let product = |x: NodeId| -> Option<(Atom, Atom)> {
            match self.dag.nodes()[x] {
                Node::Mul(a, b) => match (self.dag.nodes()[a], self.dag.nodes()[b]) {
                    (Node::Input(p), Node::Input(q)) => Some((p, q)),
                    _ => None,
                },
                _ => None,
            }
        };
        let (a, b, plus) = match node {
            Node::Add(a, b) => (a, b, true),
            Node::Sub(a, b) => (a, b, false),
            _ => return None,
        };
        let (p1, p2) = (product(a)?, product(b)?);
        let sort = |(x, y): (Atom, Atom)| if x <= y { (x, y) } else { (y, x) };
        let (p1, p2) = (sort(p1), sort(p2));
        use Atom::{Cos, Sin};
        match (p1, p2) {
            // c_i c_j ∓ s_i s_j = cos(q_i ± q_j)
            ((Cos(i), Cos(j)), (Sin(k), Sin(l))) if i == k && j == l && i != j => {
                Some(format!("cos_{}_{}_{}", joint(i), if plus { "minus" } else { "plus" }, joint(j)))
            }
            // s_i c_j − c_i s_j = sin(q_i − q_j); s_i c_j + c_i s_j = sin(q_i + q_j)
            ((Sin(i), Cos(j)), (Sin(k), Cos(l))) | ((Cos(j), Sin(i)), (Cos(l), Sin(k)))
                if i == l && j == k && i != j =>
            {
                Some(format!("sin_{}_{}_{}", joint(i), if plus { "plus" } else { "minus" }, joint(j)))
            }
            _ => None,
        }
    }

    /// Emits `let` statements for shared nodes and the expressions of `roots`, in the cheapest
    /// form [`Dag::optimised`] finds, with fused multiply-adds ([`Dag::fusions`]) if the options
    /// ask for them.
    fn emit(&self, roots: &[NodeId], context: &str) -> (TokenStream, Vec<TokenStream>, OpCounts) {
        let fma = self.options.fused_multiply_add;
        let (dag, roots, hints) = match self.dag.optimised(roots, fma) {
            Some(optimised) => {
                // A named value computed negated keeps its name, as `minus_…`.
                let kept =
                    self.hints.iter().filter_map(|(id, name)| Some((*optimised.kept.get(id)?, name.clone())));
                let negated = self
                    .hints
                    .iter()
                    .filter_map(|(id, name)| Some((*optimised.negated.get(id)?, format!("minus_{name}"))));
                let hints = kept.chain(negated).collect();
                (optimised.dag, optimised.roots, hints)
            }
            None => (self.dag.clone(), roots.to_vec(), self.hints.clone()),
        };
        let fusions = if fma { dag.fusions(&roots) } else { HashMap::default() };
        let optimised = BodyEmitter {
            dag,
            naming: self.naming.clone(),
            scalar: self.scalar,
            hints,
            options: self.options,
            fusions,
        };
        optimised.emit_dag(&roots, context)
    }

    fn emit_dag(&self, roots: &[NodeId], context: &str) -> (TokenStream, Vec<TokenStream>, OpCounts) {
        let order = self.dag.reachable(roots);
        let mut uses: HashMap<NodeId, usize> = HashMap::default();
        for &id in &order {
            match self.dag.nodes()[id] {
                Node::Add(a, b) | Node::Sub(a, b) | Node::Mul(a, b) | Node::Div(a, b) => {
                    *uses.entry(a).or_default() += 1;
                    *uses.entry(b).or_default() += 1;
                }
                Node::Neg(a) | Node::Sqrt(a) => *uses.entry(a).or_default() += 1,
                _ => {}
            }
        }
        for &r in roots {
            *uses.entry(r).or_default() += 1;
        }
        let mut names: HashMap<NodeId, String> = HashMap::default();
        let mut taken: HashMap<String, usize> = HashMap::default();
        let mut statements = TokenStream::new();
        let mut part = 0usize;
        // Inputs first (coordinates, sines and cosines, velocities), then intermediates.
        let mut order = order;
        // Sines and cosines of one joint, in that order, so that a pair is one `sin_cos` call.
        let input_rank = |a: Atom| match a {
            Atom::Q(j) => (0, j, 0),
            Atom::Sin(j) => (1, j, 0),
            Atom::Cos(j) => (1, j, 1),
            Atom::Qd(j) => (2, j, 0),
            Atom::Qdd(j) => (2, j, 1),
            Atom::Param(k) => (3, k, 0),
            Atom::External(k) => (4, k, 0),
            Atom::Closure(k) => (5, k, 0),
        };
        order.sort_by_key(|&id| match self.dag.nodes()[id] {
            Node::Input(a) => (0, Some(input_rank(a)), id),
            _ => (1, None, id),
        });
        let has_cos: Vec<u16> = order
            .iter()
            .filter_map(|&id| match self.dag.nodes()[id] {
                Node::Input(Atom::Cos(j)) => Some(j),
                _ => None,
            })
            .collect();
        let has_sin: Vec<u16> = order
            .iter()
            .filter_map(|&id| match self.dag.nodes()[id] {
                Node::Input(Atom::Sin(j)) => Some(j),
                _ => None,
            })
            .collect();
        for &id in &order {
            let node = self.dag.nodes()[id];
            match node {
                Node::Input(Atom::Sin(j)) if has_cos.contains(&j) => {
                    // One call for the pair; the cosine's node is named here too.
                    let cos_id = self
                        .dag
                        .reachable(roots)
                        .into_iter()
                        .find(|&c| self.dag.nodes()[c] == Node::Input(Atom::Cos(j)));
                    let (sin_name, cos_name) =
                        (self.naming.atom_name(Atom::Sin(j)), self.naming.atom_name(Atom::Cos(j)));
                    let (sin_ident, cos_ident) =
                        (format_ident!("{}", sin_name), format_ident!("{}", cos_name));
                    let jj = unsuffixed(usize::from(j));
                    statements.extend(
                        quote!(let (#sin_ident, #cos_ident) = ::hapticgen_runtime::Real::sin_cos(q[#jj]);),
                    );
                    names.insert(id, sin_name.clone());
                    taken.insert(sin_name, 1);
                    if let Some(c) = cos_id {
                        names.insert(c, cos_name.clone());
                        taken.insert(cos_name, 1);
                    }
                    continue;
                }
                Node::Input(Atom::Cos(j)) if has_sin.contains(&j) => continue,
                _ => {}
            }
            let bind = match node {
                Node::Const(_) => false,
                Node::Input(Atom::Param(_)) => false,
                Node::Input(_) => true,
                _ => uses.get(&id).copied().unwrap_or(0) >= 2,
            };
            if !bind {
                continue;
            }
            let base = match node {
                Node::Input(a) => self.naming.atom_name(a),
                _ => {
                    self.hints.get(&id).cloned().or_else(|| self.describe(id, &names)).unwrap_or_else(|| {
                        part += 1;
                        format!("{context}_part{part}")
                    })
                }
            };
            let count = taken.entry(base.clone()).or_default();
            *count += 1;
            let name = if *count == 1 { base } else { format!("{base}_{count}") };
            let ident = format_ident!("{}", name);
            let value = match node {
                Node::Input(Atom::Sin(j)) => {
                    let j = unsuffixed(usize::from(j));
                    quote!(::hapticgen_runtime::Real::sin(q[#j]))
                }
                Node::Input(Atom::Cos(j)) => {
                    let j = unsuffixed(usize::from(j));
                    quote!(::hapticgen_runtime::Real::cos(q[#j]))
                }
                Node::Input(Atom::Q(j)) => {
                    let j = unsuffixed(usize::from(j));
                    quote!(q[#j])
                }
                Node::Input(Atom::Qd(j)) => {
                    let j = unsuffixed(usize::from(j));
                    quote!(qd[#j])
                }
                Node::Input(Atom::Qdd(j)) => {
                    let j = unsuffixed(usize::from(j));
                    quote!(qdd[#j])
                }
                Node::Input(Atom::External(k)) => {
                    self.naming.externals.get(usize::from(k)).map(|e| e.1.clone()).unwrap_or_default()
                }
                _ => self.expression(id, &names, true).0,
            };
            statements.extend(quote!(let #ident = #value;));
            names.insert(id, name);
        }
        let outputs = roots.iter().map(|&r| self.expression(r, &names, false).0).collect();
        let counts =
            if self.options.fused_multiply_add { self.dag.count_fused(roots) } else { self.dag.count(roots) };
        (statements, outputs, counts)
    }

    /// For an unnamed `(−c)·y` with a constant `c > 0`, the tokens of `c·y`.
    fn negated_product(&self, id: NodeId, names: &HashMap<NodeId, String>) -> Option<TokenStream> {
        if names.contains_key(&id) {
            return None;
        }
        let Node::Mul(a, b) = self.dag.nodes()[id] else { return None };
        // `((−c)·x)·y` reads as `c·x·y` too.
        for (inner, other) in [(a, b), (b, a)] {
            if self.dag.constant_value(other).is_none() {
                if let Some(p) = self.negated_product(inner, names) {
                    let (y, prec) = self.expression(other, names, false);
                    let y = if prec < Precedence::Unary { quote!((#y)) } else { y };
                    return Some(quote!(#p * #y));
                }
            }
        }
        let (k, other) = match (self.dag.constant_value(a), self.dag.constant_value(b)) {
            (Some(k), None) => (k, b),
            (None, Some(k)) => (k, a),
            _ => return None,
        };
        if k >= 0.0 {
            return None;
        }
        let c = self.scalar.literal(-k);
        let (y, p) = self.expression(other, names, false);
        let y = if p < Precedence::Unary { quote!((#y)) } else { y };
        Some(quote!(#c * #y))
    }

    fn expression(
        &self,
        id: NodeId,
        names: &HashMap<NodeId, String>,
        top: bool,
    ) -> (TokenStream, Precedence) {
        if !top {
            if let Some(name) = names.get(&id) {
                let ident = format_ident!("{}", name);
                return (quote!(#ident), Precedence::Atomic);
            }
        }
        let wrap = |(t, p): (TokenStream, Precedence), need: Precedence| {
            if p < need {
                quote!((#t))
            } else {
                t
            }
        };
        if let Some(&Fused::MulAdd { a, b, c, negate_product, negate_addend }) = self.fusions.get(&id) {
            // Constants first, as in products.
            let (a, b) = if self.dag.constant_value(b).is_some() { (b, a) } else { (a, b) };
            let (x, y, z) = (
                self.expression(a, names, false).0,
                self.expression(b, names, false).0,
                self.expression(c, names, false).0,
            );
            let function = match (negate_product, negate_addend) {
                (false, false) => quote!(mul_add),
                (false, true) => quote!(mul_sub),
                (true, false) => quote!(neg_mul_add),
                (true, true) => quote!(neg_mul_sub),
            };
            return (quote!(::hapticgen_runtime::Real::#function(#x, #y, #z)), Precedence::Atomic);
        }
        match self.dag.nodes()[id] {
            Node::Const(bits) => {
                let v = f64::from_bits(bits);
                (self.scalar.literal(v), if v < 0.0 { Precedence::Unary } else { Precedence::Atomic })
            }
            Node::Input(Atom::Param(k)) => {
                let ident = format_ident!("{}", self.naming.model.tunable[usize::from(k)].name);
                (quote!(self.#ident), Precedence::Atomic)
            }
            Node::Input(a) => {
                let ident = format_ident!("{}", self.naming.atom_name(a));
                (quote!(#ident), Precedence::Atomic)
            }
            Node::Add(a, b) => {
                // `x + (−c)` reads as `x − c`.
                for (x, c) in [(a, b), (b, a)] {
                    if let Some(k) = self.dag.constant_value(c).filter(|k| *k < 0.0) {
                        let x = wrap(self.expression(x, names, false), Precedence::Sum);
                        let c = self.scalar.literal(-k);
                        return (quote!(#x - #c), Precedence::Sum);
                    }
                }
                // `x + (−c)·y` reads as `x − c·y`.
                if let Some(y) = self.negated_product(b, names) {
                    let x = wrap(self.expression(a, names, false), Precedence::Sum);
                    return (quote!(#x - #y), Precedence::Sum);
                }
                if let Some(x) = self.negated_product(a, names) {
                    let y = wrap(self.expression(b, names, false), Precedence::Sum);
                    return (quote!(#y - #x), Precedence::Sum);
                }
                let x = wrap(self.expression(a, names, false), Precedence::Sum);
                let y = wrap(self.expression(b, names, false), Precedence::Sum);
                (quote!(#x + #y), Precedence::Sum)
            }
            Node::Sub(a, b) => {
                let x = wrap(self.expression(a, names, false), Precedence::Sum);
                let y = wrap(self.expression(b, names, false), Precedence::Product);
                (quote!(#x - #y), Precedence::Sum)
            }
            Node::Mul(a, b) => {
                // Constants first reads naturally: `0.15_f64 * cos_q1`.
                let (a, b) = if self.dag.constant_value(b).is_some() { (b, a) } else { (a, b) };
                let x = wrap(self.expression(a, names, false), Precedence::Product);
                let y = wrap(self.expression(b, names, false), Precedence::Unary);
                (quote!(#x * #y), Precedence::Product)
            }
            Node::Neg(a) => {
                let x = wrap(self.expression(a, names, false), Precedence::Atomic);
                (quote!(-#x), Precedence::Unary)
            }
            Node::Div(a, b) => {
                let x = wrap(self.expression(a, names, false), Precedence::Product);
                let y = wrap(self.expression(b, names, false), Precedence::Atomic);
                (quote!(#x / #y), Precedence::Product)
            }
            Node::Sqrt(a) => {
                let (x, _) = self.expression(a, names, false);
                (quote!(::hapticgen_runtime::Real::sqrt(#x)), Precedence::Atomic)
            }
        }
    }
}

/// An integer literal without a type suffix (`2`, not `2usize`).
fn unsuffixed(n: usize) -> proc_macro2::Literal {
    proc_macro2::Literal::usize_unsuffixed(n)
}

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

fn uses_atom(dag: &Dag, roots: &[NodeId], pred: impl Fn(Atom) -> bool) -> bool {
    dag.reachable(roots).into_iter().any(|id| matches!(dag.nodes()[id], Node::Input(a) if pred(a)))
}

/// Emits one method; returns it with its operation counts.
pub fn function(
    model: &Model,
    mech: &Mechanics,
    scalar: Scalar,
    options: EmitOptions,
    spec: &FunctionSpec<'_>,
) -> (TokenStream, OpCounts) {
    let mut body = BodyEmitter::new(model, mech, scalar, options);
    let choice = cheapest_choice(model, mech, &spec.outputs, options);
    let roots = output_roots_with(&mut body.dag, model, mech, &spec.outputs, choice);
    let doc = format!("{}{}", spec.doc, derivation_note(&spec.outputs, choice));
    let (statements, outputs, counts) = body.emit(&roots, &spec.name);
    let value = shape_value(spec.shape, &outputs);
    let ret = shape_tokens(spec.shape, scalar);
    let n = unsuffixed(model.joints.len());
    let s = scalar.tokens();
    let q_used = uses_atom(&body.dag, &roots, |a| matches!(a, Atom::Sin(_) | Atom::Cos(_) | Atom::Q(_)));
    let qd_used = uses_atom(&body.dag, &roots, |a| matches!(a, Atom::Qd(_)));
    let q = if q_used { quote!(q) } else { quote!(_q) };
    let qd = if qd_used { quote!(qd) } else { quote!(_qd) };
    let name = format_ident!("{}", spec.name);
    let args = if spec.takes_qdd {
        let qdd_used = uses_atom(&body.dag, &roots, |a| matches!(a, Atom::Qdd(_)));
        let qdd = if qdd_used { quote!(qdd) } else { quote!(_qdd) };
        quote!(&self, #q: &[#s; #n], #qd: &[#s; #n], #qdd: &[#s; #n])
    } else if spec.takes_qd {
        quote!(&self, #q: &[#s; #n], #qd: &[#s; #n])
    } else {
        quote!(&self, #q: &[#s; #n])
    };
    let tokens = quote! {
        #[doc = #doc]
        #[inline]
        #[must_use]
        pub fn #name(#args) -> #ret {
            #statements
            #value
        }
    };
    (tokens, counts)
}

/// Operation counts of each emitted function and of the fused tick.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct Stats {
    /// Per function, in emission order.
    pub functions: Vec<(String, OpCounts)>,
}

fn camel_case(name: &str) -> String {
    name.split('_')
        .filter(|p| !p.is_empty())
        .map(|p| {
            let mut c = p.chars();
            match c.next() {
                Some(f) => f.to_ascii_uppercase().to_string() + c.as_str(),
                None => String::new(),
            }
        })
        .collect()
}

/// The Rust type name of a model's rig struct.
pub fn rig_type_name(model: &Model) -> String {
    camel_case(&model.name)
}

fn row_major(m: &[Vec<Poly>]) -> Vec<Output<'_>> {
    m.iter().flatten().map(Output::Poly).collect()
}

fn each(list: &[Poly]) -> Vec<Output<'_>> {
    list.iter().map(Output::Poly).collect()
}

/// The task's position, Jacobian or `J̇ q̇`: a point's quantity, or joint-coordinate polynomials.
fn task(mech: &Mechanics, what: PointQuantity) -> Vec<Output<'_>> {
    let (m, n) = (mech.task_dim, mech.joints);
    match (mech.task_point, what) {
        (Some(i), PointQuantity::Jacobian) => quantity(Quantity::Point(i, what), m * n),
        (Some(i), _) => quantity(Quantity::Point(i, what), m),
        (None, PointQuantity::Position) => each(&mech.task.position),
        (None, PointQuantity::Jacobian) => row_major(&mech.task.jacobian),
        (None, PointQuantity::JacobianDotTimesQdot) => each(&mech.task.jacobian_dot_times_qdot),
    }
}

/// The specs of every per-quantity function (shared by emission and statistics).
pub fn function_specs<'a>(model: &Model, mech: &'a Mechanics) -> Vec<FunctionSpec<'a>> {
    let n = mech.joints;
    let m = mech.task_dim;
    let task_doc = match &model.task {
        crate::model::TaskSpec::Point(i) => format!("the point `{}`", model.points[*i].name),
        crate::model::TaskSpec::Joints(j) => format!(
            "the joint coordinates {}",
            j.iter().map(|&k| format!("`{}`", model.joints[k].name)).collect::<Vec<_>>().join(", ")
        ),
    };
    let mut specs = vec![
        FunctionSpec {
            name: "inertia_matrix".into(),
            doc: " Inertia matrix `D(q)` of eq. (1), including the reflected rotor inertias `N² J_m`.".into(),
            shape: Shape::Matrix(n, n),
            outputs: quantity(Quantity::InertiaMatrix, n * n),
            takes_qd: false,
            takes_qdd: false,
        },
        FunctionSpec {
            name: "coriolis_matrix".into(),
            doc: " Coriolis/centrifugal matrix `C(q, q̇)` of eq. (1), from the Christoffel symbols of `D`."
                .into(),
            shape: Shape::Matrix(n, n),
            outputs: quantity(Quantity::CoriolisMatrix, n * n),
            takes_qd: true,
            takes_qdd: false,
        },
        FunctionSpec {
            name: "coriolis_times_qdot".into(),
            doc: " Coriolis and centrifugal torques `C(q, q̇) q̇`.".into(),
            shape: Shape::Vector(n),
            outputs: quantity(Quantity::CoriolisTimesQdot, n),
            takes_qd: true,
            takes_qdd: false,
        },
        FunctionSpec {
            name: "gravity".into(),
            doc: " Gravity torques `g(q) = ∂V/∂q` of eq. (1).".into(),
            shape: Shape::Vector(n),
            outputs: quantity(Quantity::Gravity, n),
            takes_qd: false,
            takes_qdd: false,
        },
        FunctionSpec {
            name: "inverse_dynamics".into(),
            doc:
                " Inverse dynamics of eq. (1) without damping and friction: `τ = D(q) q̈ + C(q, q̇) q̇ + g(q)`."
                    .into(),
            shape: Shape::Vector(n),
            outputs: quantity(Quantity::InverseDynamics, n),
            takes_qd: true,
            takes_qdd: true,
        },
        FunctionSpec {
            name: "potential_energy".into(),
            doc: " Gravitational potential energy `V(q)`, J (zero at the origin of the base frame).".into(),
            shape: Shape::Scalar,
            outputs: vec![Output::Poly(&mech.potential_energy)],
            takes_qd: false,
            takes_qdd: false,
        },
        FunctionSpec {
            name: "position".into(),
            doc: format!(" Task position `p(q)`: {task_doc}."),
            shape: Shape::Vector(m),
            outputs: task(mech, PointQuantity::Position),
            takes_qd: false,
            takes_qdd: false,
        },
        FunctionSpec {
            name: "jacobian".into(),
            doc: " Task Jacobian `J(q) = ∂p/∂q` (eq. (2), eq. (15) for the parallel link).".into(),
            shape: Shape::Matrix(m, n),
            outputs: task(mech, PointQuantity::Jacobian),
            takes_qd: false,
            takes_qdd: false,
        },
        FunctionSpec {
            name: "jacobian_dot".into(),
            doc: " Time derivative of the task Jacobian `J̇(q, q̇)`.".into(),
            shape: Shape::Matrix(m, n),
            outputs: row_major(&mech.task.jacobian_dot),
            takes_qd: true,
            takes_qdd: false,
        },
        FunctionSpec {
            name: "jacobian_dot_times_qdot".into(),
            doc: " `J̇(q, q̇) q̇`, the velocity term of eq. (2) and (4).".into(),
            shape: Shape::Vector(m),
            outputs: task(mech, PointQuantity::JacobianDotTimesQdot),
            takes_qd: true,
            takes_qdd: false,
        },
    ];
    for (index, (point, kin)) in model.points.iter().zip(&mech.points).enumerate() {
        let d = kin.position.len();
        let point_outputs = |what: PointQuantity, len: usize| quantity(Quantity::Point(index, what), len);
        let what = point.description.clone().unwrap_or_else(|| format!("point `{}`", point.name));
        specs.push(FunctionSpec {
            name: format!("{}_position", point.name),
            doc: format!(" Position of {what} in the base frame."),
            shape: Shape::Vector(d),
            outputs: point_outputs(PointQuantity::Position, d),
            takes_qd: false,
            takes_qdd: false,
        });
        specs.push(FunctionSpec {
            name: format!("{}_jacobian", point.name),
            doc: format!(" Jacobian of the position of {what}."),
            shape: Shape::Matrix(d, n),
            outputs: point_outputs(PointQuantity::Jacobian, d * n),
            takes_qd: false,
            takes_qdd: false,
        });
        specs.push(FunctionSpec {
            name: format!("{}_jacobian_dot_times_qdot", point.name),
            doc: format!(" `J̇ q̇` of {what}."),
            shape: Shape::Vector(d),
            outputs: point_outputs(PointQuantity::JacobianDotTimesQdot, d),
            takes_qd: true,
            takes_qdd: false,
        });
    }
    for (index, frame) in model.frames.iter().enumerate() {
        let what = frame.description.clone().unwrap_or_else(|| format!("frame `{}`", frame.name));
        specs.push(FunctionSpec {
            name: format!("{}_orientation", frame.name),
            doc: format!(" Orientation of {what}: the rotation matrix `R(q)` from the frame to the base frame (columns: its axes in base coordinates)."),
            shape: Shape::Matrix(3, 3),
            outputs: quantity(Quantity::Frame(index, FrameQuantity::Orientation), 9),
            takes_qd: false,
            takes_qdd: false,
        });
        specs.push(FunctionSpec {
            name: format!("{}_angular_jacobian", frame.name),
            doc: format!(" Angular-velocity Jacobian of {what}: `ω = J_ω(q) q̇` in base-frame coordinates (`Ṙ Rᵀ = [ω]×`)."),
            shape: Shape::Matrix(3, n),
            outputs: quantity(Quantity::Frame(index, FrameQuantity::AngularJacobian), 3 * n),
            takes_qd: false,
            takes_qdd: false,
        });
    }
    specs
}

/// The outputs of the fused per-tick function, in the order of `RigTerms`' fields.
fn tick_outputs(mech: &Mechanics, include_position: bool) -> Vec<Output<'_>> {
    let n = mech.joints;
    let mut outputs = quantity(Quantity::InertiaMatrix, n * n);
    outputs.extend(quantity(Quantity::CoriolisTimesQdot, n));
    outputs.extend(quantity(Quantity::Gravity, n));
    if include_position {
        outputs.extend(task(mech, PointQuantity::Position));
    }
    outputs.extend(task(mech, PointQuantity::Jacobian));
    outputs.extend(task(mech, PointQuantity::JacobianDotTimesQdot));
    outputs
}

/// Operation counts of the quantities one control tick needs (D, C q̇, g, p, J, J̇ q̇),
/// computed together with shared subexpressions.
pub fn tick_counts(model: &Model, mech: &Mechanics, include_position: bool) -> OpCounts {
    tick_counts_with(model, mech, include_position, EmitOptions::default())
}

/// [`tick_counts`] for code emitted with `options` (with fused multiply-adds, they count once
/// in [`OpCounts::fused`]).
pub fn tick_counts_with(
    model: &Model,
    mech: &Mechanics,
    include_position: bool,
    options: EmitOptions,
) -> OpCounts {
    let mut body = BodyEmitter::new(model, mech, Scalar::F64, options);
    let roots = output_roots(&mut body.dag, model, mech, &tick_outputs(mech, include_position));
    body.dag.optimised_count_with(&roots, options.fused_multiply_add)
}

fn terms_function(
    model: &Model,
    mech: &Mechanics,
    scalar: Scalar,
    options: EmitOptions,
) -> (TokenStream, OpCounts) {
    let mut body = BodyEmitter::new(model, mech, scalar, options);
    let roots = output_roots(&mut body.dag, model, mech, &tick_outputs(mech, true));
    let (statements, values, counts) = body.emit(&roots, "terms");
    let n = mech.joints;
    let m = mech.task_dim;
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
    let q_used = uses_atom(&body.dag, &roots, |a| matches!(a, Atom::Sin(_) | Atom::Cos(_) | Atom::Q(_)));
    let qd_used = uses_atom(&body.dag, &roots, |a| matches!(a, Atom::Qd(_)));
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
fn closure_margin_function(
    model: &Model,
    mech: &Mechanics,
    scalar: Scalar,
    options: EmitOptions,
) -> Option<(TokenStream, OpCounts)> {
    let closures = mech.closures.as_ref()?;
    let mut body = BodyEmitter::new(model, mech, scalar, options);
    // Installing again into the same DAG re-interns the same nodes: it only reports them.
    let roots = crate::dynamics::closure::install(&mut body.dag, Some(closures)).margins;
    let (statements, values, counts) = body.emit(&roots, "closure_margin");
    let (n, k) = (unsuffixed(model.joints.len()), unsuffixed(roots.len()));
    let s = scalar.tokens();
    let names: Vec<String> = closures.loops.iter().map(|l| format!("`{}`", l.name)).collect();
    let doc = format!(
        " Assembly margin of each closure ({}): the squared sine of the angle between the first distal link and the line joining the passive joints' axes; 1 with the link square to it, 0 at the singular boundary (links aligned), negative where the loop cannot close (NaN if the axes coincide). Guard the workspace with it: the dynamics grow without bound as it approaches 0.",
        names.join(", ")
    );
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

/// Emits every item of a rig: the struct, its methods and the `RigModel` implementation.
pub fn items(
    model: &crate::check::CheckedModel,
    mech: &Mechanics,
    scalar: Scalar,
    options: EmitOptions,
) -> (TokenStream, Stats) {
    let s = scalar.tokens();
    let n = unsuffixed(mech.joints);
    let m = unsuffixed(mech.task_dim);
    let type_name = Ident::new(&rig_type_name(model), Span::call_site());
    let rig_name = &model.name;
    let mut stats = Stats::default();

    let mut methods = TokenStream::new();
    for spec in function_specs(model, mech) {
        let (tokens, counts) = function(model, mech, scalar, options, &spec);
        methods.extend(tokens);
        stats.functions.push((spec.name.clone(), counts));
    }
    let (terms, tick) = terms_function(model, mech, scalar, options);
    stats.functions.push(("terms".into(), tick));
    methods.extend(terms);
    if let Some((margin, counts)) = closure_margin_function(model, mech, scalar, options) {
        stats.functions.push(("closure_margin".into(), counts));
        methods.extend(margin);
    }
    let fused = fused_impl(model, mech, scalar, options, &mut stats);

    // Damping depends on tunable parameters at most.
    let mut damping_body = BodyEmitter::new(model, mech, scalar, options);
    let damping_roots: Vec<NodeId> = mech.damping.iter().map(|p| damping_body.dag.polynomial(p)).collect();
    let (damping_statements, damping_values, _) = damping_body.emit(&damping_roots, "damping");

    // Tunable parameters become fields.
    let fields = model.tunable.iter().map(|p| {
        let ident = format_ident!("{}", p.name);
        let doc = format!(
            " {}{}",
            p.description.clone().unwrap_or_else(|| format!("Tunable parameter `{}`", p.name)),
            p.unit.as_ref().map(|u| format!(" ({u})")).unwrap_or_default()
        );
        quote!(#[doc = #doc] pub #ident: #s,)
    });
    let nominal_fields = model.tunable.iter().map(|p| {
        let ident = format_ident!("{}", p.name);
        let v = scalar.literal(p.value);
        quote!(#ident: #v,)
    });
    let struct_def = if model.tunable.is_empty() {
        quote!(pub struct #type_name;)
    } else {
        quote!(pub struct #type_name { #(#fields)* })
    };
    let nominal = if model.tunable.is_empty() {
        quote!(#type_name)
    } else {
        quote!(#type_name { #(#nominal_fields)* })
    };

    let drives = model.joints.iter().map(|j| {
        let d = &j.drive;
        let lit = |v: f64| scalar.literal(v);
        let (gr, eff, kt, r, l, jm, tl, cl, sv) = (
            lit(d.gear_ratio),
            lit(d.efficiency),
            lit(d.motor.torque_constant),
            lit(d.motor.resistance),
            lit(d.motor.inductance),
            lit(d.motor.rotor_inertia),
            lit(d.torque_limit),
            lit(d.current_limit),
            lit(d.supply_voltage),
        );
        let counts = proc_macro2::Literal::u32_unsuffixed(d.encoder.counts_per_turn);
        let (lo, hi) = (lit(j.lower), lit(j.upper));
        quote! {
            ::hapticgen_runtime::DriveTrain {
                gear_ratio: #gr,
                efficiency: #eff,
                torque_constant: #kt,
                resistance: #r,
                inductance: #l,
                rotor_inertia: #jm,
                torque_limit: #tl,
                current_limit: #cl,
                supply_voltage: #sv,
                encoder_counts_per_turn: #counts,
                position_lower: #lo,
                position_upper: #hi,
            }
        }
    });
    let gains = model.analyses.current_loop_designs.iter().map(|d| {
        let (kp, ki, t, beta) = (
            scalar.literal(d.kp),
            scalar.literal(d.ki),
            scalar.literal(d.sample_period),
            scalar.literal(d.proportional_setpoint_weight),
        );
        quote! {
            ::hapticgen_runtime::current_loop::CurrentLoopGains {
                kp: #kp,
                ki: #ki,
                sample_period: #t,
                proportional_setpoint_weight: #beta,
            }
        }
    });
    let gains_doc: Vec<String> = {
        let cl = &model.current_loop;
        let mut lines = vec![
            " Gains of each joint's PI current loop (section 2), designed by discrete pole placement"
                .to_string(),
            format!(
                " on `V = I (sL + R)` at {} Hz for a {} Hz bandwidth and damping ratio {}, taking the lag",
                model.rates.current_loop_hz, cl.bandwidth_hz, cl.damping_ratio
            ),
            format!(
                " of an order-{} Bessel anti-aliasing filter at {} Hz into account.",
                cl.anti_alias_filter_order, cl.anti_alias_cutoff_hz
            ),
        ];
        for (j, d) in model.joints.iter().zip(&model.analyses.current_loop_designs) {
            lines.push(String::new());
            lines.push(format!(
                " Joint `{}`: R = {} Ω, L = {:e} H; achieved bandwidth {:.1} Hz, dominant damping ratio {:.3}.",
                j.name, j.drive.motor.resistance, j.drive.motor.inductance, d.achieved_bandwidth_hz,
                d.achieved_damping_ratio
            ));
        }
        lines
    };
    let joint_names = model.joints.iter().map(|j| j.name.as_str());
    let joint_kinds = model.joints.iter().map(|j| match j.kind {
        JointKind::Revolute => "revolute",
        JointKind::Prismatic => "prismatic",
    });
    let current_hz = model.rates.current_loop_hz;
    let impedance_hz = model.rates.impedance_loop_hz;
    let description = format!(
        " The `{}` rig{}.",
        rig_name,
        model
            .description
            .as_ref()
            .map(|d| format!(": {}", d.trim().trim_end_matches('.')))
            .unwrap_or_default()
    );
    let closure_doc: Vec<String> = match &mech.closures {
        None => Vec::new(),
        Some(c) => {
            let loops: Vec<String> = c
                .loops
                .iter()
                .map(|l| {
                    format!(
                        "`{}` (passive `{}` and `{}`, branch {})",
                        l.name,
                        c.names[l.joints[0]],
                        c.names[l.joints[1]],
                        if l.branch_sign > 0.0 { "left" } else { "right" }
                    )
                })
                .collect();
            vec![
                String::new(),
                format!(
                    " A closed chain reduced to its actuated joints by the closures {}.",
                    loops.join(", ")
                ),
                " Where the loop cannot close, or at the aligned-links boundary, the functions return".into(),
                " non-finite values (they never panic), which the runtime's safety monitor latches as a"
                    .into(),
                " fault with zero torque.".into(),
            ]
        }
    };
    let variant_doc = format!(
        " Generated from `{}`{}; `{}` joints, `{}` task coordinates.",
        model.file,
        model.variant.as_ref().map(|v| format!(", variant `{v}`")).unwrap_or_default(),
        n,
        m
    );

    let tokens = quote! {
        #[doc = #description]
        ///
        #[doc = #variant_doc]
        #(#[doc = #closure_doc])*
        #[derive(Clone, Copy, Debug, PartialEq)]
        #struct_def

        impl Default for #type_name {
            fn default() -> Self {
                Self::NOMINAL
            }
        }

        impl #type_name {
            /// The rig with every tunable parameter at its nominal value.
            pub const NOMINAL: Self = #nominal;
            /// Number of joints.
            pub const JOINTS: usize = #n;
            /// Number of task coordinates.
            pub const TASK_DIM: usize = #m;
            /// Joint names, in the order of `q`.
            pub const JOINT_NAMES: [&'static str; #n] = [#(#joint_names),*];
            /// Joint kinds, in the order of `q`.
            pub const JOINT_KINDS: [&'static str; #n] = [#(#joint_kinds),*];
            /// The drive train of each joint, in the order of `q`.
            pub const DRIVES: [::hapticgen_runtime::DriveTrain<#s>; #n] = [#(#drives),*];
            #(#[doc = #gains_doc])*
            pub const CURRENT_LOOP_GAINS: [::hapticgen_runtime::current_loop::CurrentLoopGains<#s>; #n] =
                [#(#gains),*];

            /// Diagonal of the viscous damping matrix `B` of eq. (1).
            #[inline]
            #[must_use]
            pub fn damping(&self) -> [#s; #n] {
                #damping_statements
                [#(#damping_values),*]
            }

            #methods
        }

        impl ::hapticgen_runtime::RigModel<#n, #m> for #type_name {
            type Scalar = #s;
            const NAME: &'static str = #rig_name;
            const CURRENT_LOOP_HZ: u32 = #current_hz;
            const IMPEDANCE_LOOP_HZ: u32 = #impedance_hz;

            fn inertia_matrix(&self, q: &[#s; #n]) -> [[#s; #n]; #n] {
                Self::inertia_matrix(self, q)
            }
            fn coriolis_matrix(&self, q: &[#s; #n], qd: &[#s; #n]) -> [[#s; #n]; #n] {
                Self::coriolis_matrix(self, q, qd)
            }
            fn coriolis_times_qdot(&self, q: &[#s; #n], qd: &[#s; #n]) -> [#s; #n] {
                Self::coriolis_times_qdot(self, q, qd)
            }
            fn gravity(&self, q: &[#s; #n]) -> [#s; #n] {
                Self::gravity(self, q)
            }
            fn damping(&self) -> [#s; #n] {
                Self::damping(self)
            }
            fn position(&self, q: &[#s; #n]) -> [#s; #m] {
                Self::position(self, q)
            }
            fn jacobian(&self, q: &[#s; #n]) -> [[#s; #n]; #m] {
                Self::jacobian(self, q)
            }
            fn jacobian_dot(&self, q: &[#s; #n], qd: &[#s; #n]) -> [[#s; #n]; #m] {
                Self::jacobian_dot(self, q, qd)
            }
            fn jacobian_dot_times_qdot(&self, q: &[#s; #n], qd: &[#s; #n]) -> [#s; #m] {
                Self::jacobian_dot_times_qdot(self, q, qd)
            }
            fn terms(&self, q: &[#s; #n], qd: &[#s; #n]) -> ::hapticgen_runtime::RigTerms<#s, #n, #m> {
                Self::terms(self, q, qd)
            }
            fn drives(&self) -> [::hapticgen_runtime::DriveTrain<#s>; #n] {
                Self::DRIVES
            }
            fn inverse_dynamics(&self, q: &[#s; #n], qd: &[#s; #n], qdd: &[#s; #n]) -> [#s; #n] {
                Self::inverse_dynamics(self, q, qd, qdd)
            }
        }

        #fused
    };
    (tokens, stats)
}

/// Emits the `FusedImpedance` implementation: one straight-line function per law.
fn fused_impl(
    model: &Model,
    mech: &Mechanics,
    scalar: Scalar,
    options: EmitOptions,
    stats: &mut Stats,
) -> TokenStream {
    use laws::{build, External, Law};
    let s = scalar.tokens();
    let (n_usize, m_usize) = (mech.joints, mech.task_dim);
    let n = unsuffixed(n_usize);
    let m = unsuffixed(m_usize);
    let type_name = Ident::new(&rig_type_name(model), Span::call_site());
    let reference_ty = quote!(::hapticgen_runtime::control::TaskReference<#s, #m>);
    let parameters_ty = quote!(::hapticgen_runtime::control::ImpedanceParameters<#s, #m>);
    let fused_ty = quote!(::hapticgen_runtime::fused::FusedTorque<#s, #n>);
    let laws = [
        (Law::Controller3, "controller3_torque", None),
        (Law::Controller1, "controller1_torque", Some("operator_force")),
        (Law::Controller2Accel, "controller2_accel_torque", Some("task_acceleration")),
        (Law::Controller2Mobility, "controller2_mobility_torque", None),
    ];
    let mut methods = TokenStream::new();
    for (law, name, sensed) in laws {
        let mut body = BodyEmitter::new(model, mech, scalar, options);
        for kind in External::ALL {
            for k in 0..m_usize {
                let kk = unsuffixed(k);
                let (binding, access) = match kind {
                    External::ReferencePosition => {
                        (format!("reference_position_{k}"), quote!(reference.position[#kk]))
                    }
                    External::ReferenceVelocity => {
                        (format!("reference_velocity_{k}"), quote!(reference.velocity[#kk]))
                    }
                    External::ReferenceAcceleration => {
                        (format!("reference_acceleration_{k}"), quote!(reference.acceleration[#kk]))
                    }
                    External::Stiffness => (format!("stiffness_{k}"), quote!(parameters.stiffness[#kk])),
                    External::Damping => (format!("desired_damping_{k}"), quote!(parameters.damping[#kk])),
                    External::Mass => (format!("desired_mass_{k}"), quote!(parameters.mass[#kk])),
                    External::Sensed => {
                        let field = format_ident!("{}", sensed.unwrap_or("sensed"));
                        (format!("{}_{k}", sensed.unwrap_or("sensed")), quote!(#field[#kk]))
                    }
                };
                body.naming.externals.push((binding, access));
            }
        }
        let nodes = build(&mut body.dag, model, mech, law);
        if let Some(nodes) = &nodes {
            body.hints.extend(nodes.names.iter().cloned());
        }
        let fn_name = format_ident!("{}", name);
        let sensed_arg = sensed.map(|field| {
            let ident = format_ident!("{}{}", if nodes.is_some() { "" } else { "_" }, field);
            quote!(, #ident: &[#s; #m])
        });
        let prefix = |arg: &str| format_ident!("{}{}", if nodes.is_some() { "" } else { "_" }, arg);
        let (q, qd, reference, parameters) =
            (prefix("q"), prefix("qd"), prefix("reference"), prefix("parameters"));
        let args = quote!(&self, #q: &[#s; #n], #qd: &[#s; #n], #reference: &#reference_ty, #parameters: &#parameters_ty #sensed_arg);
        let tokens = match (law, nodes) {
            (Law::Controller3, Some(nodes)) => {
                let (statements, outputs, counts) = body.emit(&nodes.torque, name);
                stats.functions.push((name.to_string(), counts));
                quote! {
                    #[inline]
                    fn #fn_name(#args) -> [#s; #n] {
                        #statements
                        [#(#outputs),*]
                    }
                }
            }
            (_, Some(nodes)) => {
                let mut roots = nodes.torque.clone();
                roots.extend(nodes.jacobian_determinant);
                let (statements, outputs, counts) = body.emit(&roots, name);
                stats.functions.push((name.to_string(), counts));
                let (torque, det) = outputs.split_at(n_usize);
                let det = det.first().cloned().unwrap_or_else(|| scalar.literal(1.0));
                let det_field = if det.to_string() == "jacobian_determinant" {
                    quote!(jacobian_determinant)
                } else {
                    quote!(jacobian_determinant: #det)
                };
                quote! {
                    #[inline]
                    fn #fn_name(#args) -> Option<#fused_ty> {
                        #statements
                        Some(::hapticgen_runtime::fused::FusedTorque {
                            torque: [#(#torque),*],
                            #det_field,
                        })
                    }
                }
            }
            (_, None) => quote! {
                /// No closed form for this task: `J` is not square, or larger than 3 × 3.
                #[inline]
                fn #fn_name(#args) -> Option<#fused_ty> {
                    None
                }
            },
        };
        methods.extend(tokens);
    }
    quote! {
        impl ::hapticgen_runtime::fused::FusedImpedance<#n, #m> for #type_name {
            #methods
        }
    }
}
