//! Lowering an expression DAG to Rust: after [`Dag::optimised`], every node used more than
//! once (and every input) becomes a named `let`, in input-then-node-id order; each output is
//! then one expression over those names. Sines and cosines of one angle are one `sin_cos`
//! call; with [`EmitOptions::fused_multiply_add`], products feeding one sum become
//! `mul_add`-family calls ([`Dag::fusions`]).

use rustc_hash::FxHashMap as HashMap;

use proc_macro2::TokenStream;
use quote::{format_ident, quote};

use crate::dynamics::mechanics::Mechanics;
use crate::model::Model;
use crate::sym::dag::{Dag, Fused, Node, NodeId, OpCounts};
use crate::sym::poly::Atom;

use super::literal::{unsuffixed, Scalar};
use super::naming::{LoopInputs, LoopRead, Naming, SharedNames};

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
    /// Also emit the dynamic-identification regressor `regressor(q, q̇, q̈)` with its base
    /// parameters (`BASE_PARAMETERS`, `base_parameters()`; `crate::dynamics::regressor`).
    pub regressor: bool,
}

/// Emits the body of one or more outputs sharing one DAG.
pub(crate) struct BodyEmitter<'m> {
    /// The DAG the outputs are built in.
    pub(crate) dag: Dag,
    /// Names of the inputs.
    pub(crate) naming: Naming<'m>,
    scalar: Scalar,
    /// Names for nodes with a known role (e.g. `jacobian_determinant`).
    pub(crate) hints: HashMap<NodeId, String>,
    /// Emission options.
    options: EmitOptions,
    /// Nodes emitted as fused multiply-adds (with [`EmitOptions::fused_multiply_add`]), set by
    /// [`BodyEmitter::emit`].
    fusions: HashMap<NodeId, Fused>,
}

/// How tightly an emitted expression binds, to decide where parentheses are needed.
#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Precedence {
    Sum,
    Product,
    Unary,
    Atomic,
}

impl<'m> BodyEmitter<'m> {
    /// An emitter with an empty DAG, except for a closed chain's passive coordinates.
    pub(crate) fn new(model: &'m Model, mech: &Mechanics, scalar: Scalar, options: EmitOptions) -> Self {
        // A closed chain's passive coordinates enter every polynomial as nodes computed from
        // the actuated ones (`crate::dynamics::closure`), named after their role.
        let (dag, installed) = crate::dynamics::closure::graph_with(mech.closures.as_ref());
        let hints = installed.hints.into_iter().collect();
        // A spatial chain's without a closed form are solved at run time instead, at the top of
        // each function.
        let loops = mech.closures.as_ref().and_then(|c| c.solved_at_run_time()).map(|spatial| LoopInputs {
            actuated: spatial.actuated,
            passive: spatial.passive,
            solved: true,
        });
        Self {
            dag,
            naming: Naming { model, externals: Vec::new(), shared: None, loops },
            scalar,
            hints,
            options,
            fusions: HashMap::default(),
        }
    }

    /// Names values as the other functions of the rig `names` belongs to do.
    pub(crate) fn share_names(&mut self, names: &SharedNames) {
        self.naming.shared = Some(names.clone());
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
                other => self.angle_identity(other, &|j| {
                    self.naming.model.coordinate_name(usize::from(j)).to_string()
                }),
            }
        };
        let node = self.dag.nodes()[id];
        let joint = |j: u16| self.naming.model.coordinate_name(usize::from(j)).to_string();
        // Angle-sum identities get their mathematical names.
        if let Some(name) = self.angle_identity(node, &joint) {
            return Some(name);
        }
        let name = match node {
            Node::Mul(a, b) if a == b => format!("{}_sq", name_of(a)?),
            Node::Mul(a, b) => {
                let (ca, cb) = (self.dag.constant_value(a), self.dag.constant_value(b));
                // A multiple of a multiple is still `scaled_…`, not `scaled_scaled_…`.
                let scaled = |x: String| if x.starts_with("scaled_") { x } else { format!("scaled_{x}") };
                match (ca, cb) {
                    (Some(_), None) => scaled(name_of(b)?),
                    (None, Some(_)) => scaled(name_of(a)?),
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
        // `s_i s_j + c_i c_j` reads as `c_i c_j + s_i s_j`.
        let (p1, p2) = if plus && matches!(p1.0, Atom::Sin(_)) { (p2, p1) } else { (p1, p2) };
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
    pub(crate) fn emit(&self, roots: &[NodeId], context: &str) -> (TokenStream, Vec<TokenStream>, OpCounts) {
        self.emit_named(roots, context, &[])
    }

    /// [`BodyEmitter::emit`], naming a shared root after the output it is (`root_names[k]` for
    /// `roots[k]`, e.g. `inertia_01`) unless the value has a name already.
    pub(crate) fn emit_named(
        &self,
        roots: &[NodeId],
        context: &str,
        root_names: &[String],
    ) -> (TokenStream, Vec<TokenStream>, OpCounts) {
        let fma = self.options.fused_multiply_add;
        // Names given by the emitter's caller first, then those given where nodes were built.
        let mut all_hints = self.hints.clone();
        for (id, name) in self.dag.hints() {
            all_hints.entry(*id).or_insert_with(|| name.clone());
        }
        let (dag, roots, hints) = match self.dag.optimised(roots, fma) {
            Some(optimised) => {
                // A named value computed negated keeps its name, as `minus_…`.
                let kept =
                    all_hints.iter().filter_map(|(id, name)| Some((*optimised.kept.get(id)?, name.clone())));
                let negated = all_hints
                    .iter()
                    .filter_map(|(id, name)| Some((*optimised.negated.get(id)?, format!("minus_{name}"))));
                let hints: HashMap<NodeId, String> = kept.chain(negated).collect();
                (optimised.dag, optimised.roots, hints)
            }
            None => (self.dag.clone(), roots.to_vec(), all_hints),
        };
        let mut named_roots: HashMap<NodeId, String> = HashMap::default();
        for (&root, name) in roots.iter().zip(root_names) {
            if !hints.contains_key(&root) {
                named_roots.entry(root).or_insert_with(|| name.clone());
            }
        }
        let fusions = if fma { dag.fusions(&roots) } else { HashMap::default() };
        let optimised = BodyEmitter {
            dag,
            naming: self.naming.clone(),
            scalar: self.scalar,
            hints,
            options: self.options,
            fusions,
        };
        optimised.emit_dag(&roots, context, &named_roots)
    }

    /// The name of a shared intermediate value: the rig-wide name it got in an earlier
    /// function, else the name it was given (a hint), else the output it is, else one made
    /// from its operands, else a numbered part of `context`.
    fn value_name(
        &self,
        id: NodeId,
        key: &str,
        names: &HashMap<NodeId, String>,
        named_roots: &HashMap<NodeId, String>,
        context: &str,
        part: &mut usize,
    ) -> String {
        let is_fallback =
            |name: &str| name.rsplit_once("_part").is_some_and(|(_, n)| n.parse::<u32>().is_ok());
        let shared = self.naming.shared.as_ref();
        let registered = shared.and_then(|shared| shared.borrow().name(key).cloned());
        let hint = self.hints.get(&id).cloned();
        let (name, better) = match (registered, hint) {
            (Some(r), Some(h)) if is_fallback(&r) => (h, true),
            (Some(r), _) => (r, false),
            (None, Some(h)) => (h, false),
            (None, None) => {
                let base =
                    named_roots.get(&id).cloned().or_else(|| self.describe(id, names)).unwrap_or_else(|| {
                        *part += 1;
                        format!("{context}_part{part}")
                    });
                // A made-up name must not be one another value of the rig already has.
                let mut name = base.clone();
                if let Some(shared) = shared {
                    let mut n = 1;
                    while shared.borrow().taken_by_other(&name, key) {
                        n += 1;
                        name = format!("{base}_{n}");
                    }
                }
                (name, false)
            }
        };
        if let Some(shared) = shared {
            shared.borrow_mut().record(key, &name, better);
        }
        name
    }

    fn emit_dag(
        &self,
        roots: &[NodeId],
        context: &str,
        named_roots: &HashMap<NodeId, String>,
    ) -> (TokenStream, Vec<TokenStream>, OpCounts) {
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
        let mut statements = self.loop_preamble(&order);
        let mut bound_texts: HashMap<String, String> = HashMap::default();
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
                    statements.extend(match self.passive_sin_cos(j) {
                        Some(pair) => quote!(let (#sin_ident, #cos_ident) = #pair;),
                        None => {
                            let angle = self.angle_tokens(j);
                            quote!(let (#sin_ident, #cos_ident) = ::hapticgen_runtime::Real::sin_cos(#angle);)
                        }
                    });
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
            // An intermediate's expression first: its text identifies it across the rig.
            let expression = match node {
                Node::Input(_) => None,
                _ => Some(self.expression(id, &names, true).0),
            };
            // Two nodes can print the same (constants that differ beyond an `f32` literal's
            // digits): one binding serves both.
            let text = expression.as_ref().map(ToString::to_string);
            if let Some(bound) = text.as_ref().and_then(|t| bound_texts.get(t)) {
                names.insert(id, bound.clone());
                continue;
            }
            let base = match (node, &expression) {
                (Node::Input(a), _) => self.naming.atom_name(a),
                (_, expression) => {
                    let key = expression.as_ref().map(ToString::to_string).unwrap_or_default();
                    self.value_name(id, &key, &names, named_roots, context, &mut part)
                }
            };
            let count = taken.entry(base.clone()).or_default();
            *count += 1;
            let name = if *count == 1 { base } else { format!("{base}_{count}") };
            let ident = format_ident!("{}", name);
            let loop_read = match node {
                Node::Input(a @ (Atom::Q(_) | Atom::Qd(_) | Atom::Closure(_))) => {
                    self.naming.loops.and_then(|l| Some(l.tokens(l.read(a)?)))
                }
                _ => None,
            };
            let value = match (loop_read, node) {
                (Some(read), _) => read,
                (None, Node::Input(Atom::Sin(j))) => match self.passive_sin_cos(j) {
                    Some(pair) => quote!(#pair.0),
                    None => {
                        let angle = self.angle_tokens(j);
                        quote!(::hapticgen_runtime::Real::sin(#angle))
                    }
                },
                (None, Node::Input(Atom::Cos(j))) => match self.passive_sin_cos(j) {
                    Some(pair) => quote!(#pair.1),
                    None => {
                        let angle = self.angle_tokens(j);
                        quote!(::hapticgen_runtime::Real::cos(#angle))
                    }
                },
                (None, Node::Input(Atom::Q(j))) => self.coordinate_tokens(j),
                (None, Node::Input(Atom::Qd(j))) => {
                    let j = unsuffixed(usize::from(j));
                    quote!(qd[#j])
                }
                (None, Node::Input(Atom::Qdd(j))) => {
                    let j = unsuffixed(usize::from(j));
                    quote!(qdd[#j])
                }
                (None, Node::Input(Atom::External(k))) => {
                    self.naming.externals.get(usize::from(k)).map(|e| e.1.clone()).unwrap_or_default()
                }
                (None, _) => expression.unwrap_or_default(),
            };
            statements.extend(quote!(let #ident = #value;));
            if let Some(text) = text {
                bound_texts.insert(text, name.clone());
            }
            names.insert(id, name);
        }
        let outputs = roots.iter().map(|&r| self.expression(r, &names, false).0).collect();
        let mut counts =
            if self.options.fused_multiply_add { self.dag.count_fused(roots) } else { self.dag.count(roots) };
        // A spatial closed chain's passive sines and cosines are read from the loops' solution
        // (or the argument `passive_sin_cos`), not computed here.
        let read_trig = self
            .dag
            .reachable(roots)
            .into_iter()
            .filter(|&id| match self.dag.nodes()[id] {
                Node::Input(Atom::Sin(j) | Atom::Cos(j)) => self.passive_sin_cos(j).is_some(),
                _ => false,
            })
            .count();
        counts.trigonometric -= read_trig;
        (statements, outputs, counts)
    }

    /// A spatial closed chain's passive angle `j`: its sine and cosine, computed with the
    /// loops' solution (`None` for any other angle).
    fn passive_sin_cos(&self, j: u16) -> Option<TokenStream> {
        let loops = self.naming.loops?;
        match loops.read(Atom::Q(j))? {
            LoopRead::Passive(r) => Some(loops.sin_cos_tokens(r)),
            _ => None,
        }
    }

    /// The angle of coordinate `j`: `q[j]`, or a passive coordinate solved at run time.
    fn angle_tokens(&self, j: u16) -> TokenStream {
        match self.naming.loops.and_then(|l| Some(l.tokens(l.read(Atom::Q(j))?))) {
            Some(read) => read,
            None => self.coordinate_tokens(j),
        }
    }

    /// Where coordinate `j` is read: `q[j]`, or a measured joint's `measured[k]`.
    fn coordinate_tokens(&self, j: u16) -> TokenStream {
        let measured_from = self.naming.model.tree_coordinates();
        match usize::from(j).checked_sub(measured_from) {
            Some(k) => {
                let k = unsuffixed(k);
                quote!(measured[#k])
            }
            None => {
                let j = unsuffixed(usize::from(j));
                quote!(q[#j])
            }
        }
    }

    /// For a spatial closed chain whose loop values `nodes` read, the statement solving the
    /// loops first (`hapticgen_runtime::loops::close_loops`), at the velocity level only if a
    /// value read needs it; nothing otherwise.
    fn loop_preamble(&self, nodes: &[NodeId]) -> TokenStream {
        let Some(loops) = self.naming.loops.filter(|l| l.solved) else { return TokenStream::new() };
        let inputs = || {
            nodes.iter().filter_map(|&id| match self.dag.nodes()[id] {
                Node::Input(atom) => Some(atom),
                _ => None,
            })
        };
        if !inputs().any(|atom| loops.read(atom).is_some()) {
            return TokenStream::new();
        }
        let velocity = if inputs().any(|atom| loops.read(atom).is_some() && self.naming.reads_velocity(atom))
        {
            quote!(::core::option::Option::Some(qd))
        } else {
            quote!(::core::option::Option::None)
        };
        // `A` only where a value reads it (positions need the passive angles alone), `Ȧ` only
        // where `C` itself does (`C q̇` reads `Ȧ q̇_a`).
        let reads = |rate: bool| {
            inputs().any(
                |atom| matches!(loops.read(atom), Some(LoopRead::Sensitivity { rate: r, .. }) if r || !rate),
            )
        };
        let level = if reads(true) {
            quote!(SensitivityRate)
        } else if reads(false) {
            quote!(Sensitivity)
        } else {
            quote!(Position)
        };
        quote!(let loops = ::hapticgen_runtime::loops::close_loops(self, q, ::hapticgen_runtime::loops::LoopLevel::#level, #velocity);)
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
                // `x − (−c)` reads as `x + c` and `x − (−c)·y` as `x + c·y`, not `x - -c * y`
                // (negation is exact, so the value is the same bit for bit).
                if let Some(k) = self.dag.constant_value(b).filter(|k| *k < 0.0) {
                    let x = wrap(self.expression(a, names, false), Precedence::Sum);
                    let c = self.scalar.literal(-k);
                    return (quote!(#x + #c), Precedence::Sum);
                }
                if let Some(y) = self.negated_product(b, names) {
                    let x = wrap(self.expression(a, names, false), Precedence::Sum);
                    return (quote!(#x + #y), Precedence::Sum);
                }
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
