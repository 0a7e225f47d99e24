//! Expression DAG with hash-consing: the optimised form of a set of polynomials.
//!
//! Each node is one arithmetic operation; identical subexpressions are one node, so common
//! subexpressions are shared across every output of a function (and across the functions
//! fused into one control tick). Polynomials enter through a greedy multivariate Horner
//! scheme ([`Dag::polynomial`]) that factors out the atom shared by most terms, and a common
//! coefficient where all terms have the same magnitude; constants are folded on the way.

use std::collections::BTreeMap;

use rustc_hash::FxHashMap as HashMap;

use super::poly::{Atom, Monomial, Poly};

/// Index of a node.
pub type NodeId = usize;

/// One operation.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Node {
    /// A constant (the bits of an `f64`).
    Const(u64),
    /// An input: joint sine/cosine/coordinate/velocity or a tunable parameter.
    Input(Atom),
    /// `a + b`.
    Add(NodeId, NodeId),
    /// `a − b`.
    Sub(NodeId, NodeId),
    /// `a · b`.
    Mul(NodeId, NodeId),
    /// `−a`.
    Neg(NodeId),
    /// `a / b`.
    Div(NodeId, NodeId),
    /// `√a` (closed-chain position level: the two-circle intersection).
    Sqrt(NodeId),
}

/// Operation counts of a set of outputs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct OpCounts {
    /// Additions and subtractions.
    pub additions: usize,
    /// Multiplications.
    pub multiplications: usize,
    /// Divisions.
    pub divisions: usize,
    /// Square roots.
    pub square_roots: usize,
    /// Sine and cosine evaluations.
    pub trigonometric: usize,
    /// Negations.
    pub negations: usize,
    /// Fused multiply-adds `±a·b ± c` (only with fused multiply-add emission, see
    /// [`Dag::fusions`]): one operation and one rounding each, but two floating-point
    /// operations (flops).
    pub fused: usize,
}

impl OpCounts {
    /// Arithmetic operations (additions, multiplications, divisions, square roots, negations,
    /// fused multiply-adds each counted once).
    pub fn arithmetic(&self) -> usize {
        self.additions
            + self.multiplications
            + self.divisions
            + self.square_roots
            + self.negations
            + self.fused
    }
}

/// How a node is emitted when multiplications are fused into the additions that consume them
/// (see [`Dag::fusions`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Fused {
    /// `(±a·b) ± c`, rounded once: an `Add` or `Sub` with its single-use product operand, or a
    /// `Neg` of such a sum.
    MulAdd {
        /// First factor.
        a: NodeId,
        /// Second factor.
        b: NodeId,
        /// Addend.
        c: NodeId,
        /// The product enters negated: `−a·b ± c`.
        negate_product: bool,
        /// The addend enters negated: `±a·b − c`.
        negate_addend: bool,
    },
    /// `−(a·b)` of a single-use product: one instruction on ARM (`vnmul.f32`), so counted as
    /// one multiplication.
    NegMul {
        /// First factor.
        a: NodeId,
        /// Second factor.
        b: NodeId,
    },
}

/// A hash-consed expression DAG.
#[derive(Clone, Debug, Default)]
pub struct Dag {
    nodes: Vec<Node>,
    index: HashMap<Node, NodeId>,
    /// Linear combinations built by [`Dag::merged_sums`], keyed by their terms with the
    /// coefficients divided by the first one: a later combination proportional to an earlier
    /// one is one multiplication of it.
    linear_index: HashMap<Vec<(NodeId, i64)>, (NodeId, f64)>,
    /// Atoms that stand for nodes built from other inputs (a closed chain's passive
    /// coordinates, see `crate::dynamics::closure`): [`Dag::input`] returns the node instead.
    substitutions: HashMap<Atom, NodeId>,
    /// Names of nodes given where they were built (e.g. `link3_angular_velocity_z` by the
    /// recursive Newton–Euler pass), for the emitted code: the first name a node gets is kept.
    hints: HashMap<NodeId, String>,
}

/// A node id with a pending sign, used while building sums.
#[derive(Clone, Copy)]
struct Signed {
    id: NodeId,
    negative: bool,
}

impl Dag {
    /// An empty DAG.
    pub fn new() -> Self {
        Self::default()
    }

    /// All nodes; children always precede parents.
    pub fn nodes(&self) -> &[Node] {
        &self.nodes
    }

    pub(crate) fn intern(&mut self, node: Node) -> NodeId {
        if let Some(&id) = self.index.get(&node) {
            return id;
        }
        let id = self.nodes.len();
        self.nodes.push(node);
        self.index.insert(node, id);
        id
    }

    /// Names the value `id` for the emitted code, unless it has a name already or is an input
    /// or a constant (those are named by what they are).
    pub fn hint(&mut self, id: NodeId, name: impl FnOnce() -> String) {
        if !matches!(self.nodes[id], Node::Input(_) | Node::Const(_)) {
            self.hints.entry(id).or_insert_with(name);
        }
    }

    /// Forgets the names given with [`Dag::hint`] that `keep` rejects.
    pub(crate) fn retain_hints(&mut self, keep: impl Fn(&str) -> bool) {
        self.hints.retain(|_, name| keep(name));
    }

    /// The names given with [`Dag::hint`].
    pub fn hints(&self) -> &HashMap<NodeId, String> {
        &self.hints
    }

    /// The constant value of a node, if it is one.
    pub fn constant_value(&self, id: NodeId) -> Option<f64> {
        match self.nodes[id] {
            Node::Const(bits) => Some(f64::from_bits(bits)),
            _ => None,
        }
    }

    /// A constant node (`-0.0` is stored as `0.0`).
    pub fn constant(&mut self, value: f64) -> NodeId {
        let value = if value == 0.0 { 0.0 } else { value };
        self.intern(Node::Const(value.to_bits()))
    }

    /// An input node, or the node an atom was [substituted](Dag::substitute) by.
    pub fn input(&mut self, atom: Atom) -> NodeId {
        match self.substitutions.get(&atom) {
            Some(&id) => id,
            None => self.intern(Node::Input(atom)),
        }
    }

    /// From now on, `atom` stands for the node `id` in every polynomial added.
    pub fn substitute(&mut self, atom: Atom, id: NodeId) {
        self.substitutions.insert(atom, id);
    }

    /// `√a`, folded for constants.
    pub fn sqrt(&mut self, a: NodeId) -> NodeId {
        match self.constant_value(a) {
            Some(x) => self.constant(x.sqrt()),
            None => self.intern(Node::Sqrt(a)),
        }
    }

    /// `a + b`, folded.
    pub fn add(&mut self, a: NodeId, b: NodeId) -> NodeId {
        match (self.constant_value(a), self.constant_value(b)) {
            (Some(x), Some(y)) => self.constant(x + y),
            (Some(0.0), _) => b,
            (_, Some(0.0)) => a,
            // Negations are absorbed: `x + (−y) = x − y`, `(−x) + (−y) = −(x + y)`.
            _ => match (self.nodes[a], self.nodes[b]) {
                (Node::Neg(x), Node::Neg(y)) => {
                    let sum = self.add(x, y);
                    self.neg(sum)
                }
                (_, Node::Neg(y)) => self.sub(a, y),
                (Node::Neg(x), _) => self.sub(b, x),
                _ => {
                    let (lo, hi) = if a <= b { (a, b) } else { (b, a) };
                    self.intern(Node::Add(lo, hi))
                }
            },
        }
    }

    /// `a − b`, folded.
    pub fn sub(&mut self, a: NodeId, b: NodeId) -> NodeId {
        match (self.constant_value(a), self.constant_value(b)) {
            (Some(x), Some(y)) => self.constant(x - y),
            (_, Some(0.0)) => a,
            (Some(0.0), _) => self.neg(b),
            _ if a == b => self.constant(0.0),
            // `x − (−y) = x + y`, `(−x) − y = −(x + y)`.
            _ => match (self.nodes[a], self.nodes[b]) {
                (_, Node::Neg(y)) => self.add(a, y),
                (Node::Neg(x), _) => {
                    let sum = self.add(x, b);
                    self.neg(sum)
                }
                _ => self.intern(Node::Sub(a, b)),
            },
        }
    }

    /// `a · b`, folded.
    pub fn mul(&mut self, a: NodeId, b: NodeId) -> NodeId {
        match (self.constant_value(a), self.constant_value(b)) {
            (Some(x), Some(y)) => self.constant(x * y),
            (Some(0.0), _) => a,
            (_, Some(0.0)) => b,
            (Some(1.0), _) => b,
            (_, Some(1.0)) => a,
            (Some(-1.0), _) => self.neg(b),
            (_, Some(-1.0)) => self.neg(a),
            // A sign moves out of a product, to be absorbed by a sum or a constant above it.
            _ => match (self.nodes[a], self.nodes[b]) {
                (Node::Neg(x), Node::Neg(y)) => self.mul(x, y),
                (Node::Neg(x), _) => {
                    let product = self.mul(x, b);
                    self.neg(product)
                }
                (_, Node::Neg(y)) => {
                    let product = self.mul(a, y);
                    self.neg(product)
                }
                _ => {
                    let (lo, hi) = if a <= b { (a, b) } else { (b, a) };
                    self.intern(Node::Mul(lo, hi))
                }
            },
        }
    }

    /// `a / b`, folded (only constant over constant; a division by a constant stays a
    /// division so that results round exactly as a hand-written division would).
    pub fn div(&mut self, a: NodeId, b: NodeId) -> NodeId {
        match (self.constant_value(a), self.constant_value(b)) {
            (Some(x), Some(y)) => self.constant(x / y),
            (Some(0.0), _) => a,
            (_, Some(1.0)) => a,
            _ => self.intern(Node::Div(a, b)),
        }
    }

    /// `−a`, folded (a negated product with a constant factor absorbs the sign).
    pub fn neg(&mut self, a: NodeId) -> NodeId {
        match self.nodes[a] {
            Node::Const(bits) => self.constant(-f64::from_bits(bits)),
            Node::Neg(inner) => inner,
            Node::Mul(x, y) => {
                if let Some(k) = self.constant_value(x) {
                    let c = self.constant(-k);
                    self.mul(c, y)
                } else if let Some(k) = self.constant_value(y) {
                    let c = self.constant(-k);
                    self.mul(x, c)
                } else {
                    self.intern(Node::Neg(a))
                }
            }
            Node::Sub(x, y) => self.intern(Node::Sub(y, x)),
            _ => self.intern(Node::Neg(a)),
        }
    }

    /// The product of a monomial's atoms, built in canonical order so equal monomials and
    /// their common prefixes are shared.
    fn monomial(&mut self, monomial: &[(Atom, u32)]) -> NodeId {
        let mut acc: Option<NodeId> = None;
        for &(atom, exponent) in monomial {
            let x = self.input(atom);
            let power = self.power(x, exponent);
            acc = Some(match acc {
                None => power,
                Some(a) => self.mul(a, power),
            });
        }
        match acc {
            Some(id) => id,
            None => self.constant(1.0),
        }
    }

    fn power(&mut self, x: NodeId, exponent: u32) -> NodeId {
        match exponent {
            0 => self.constant(1.0),
            1 => x,
            e => {
                let half = self.power(x, e / 2);
                let square = self.mul(half, half);
                if e % 2 == 1 {
                    self.mul(square, x)
                } else {
                    square
                }
            }
        }
    }

    /// Adds a polynomial; returns the node of its value.
    pub fn polynomial(&mut self, poly: &Poly) -> NodeId {
        let terms: Vec<(Monomial, f64)> = poly.terms().map(|(m, c)| (m.clone(), c)).collect();
        let signed = self.horner(terms);
        self.resolve(signed)
    }

    fn resolve(&mut self, s: Signed) -> NodeId {
        if s.negative {
            self.neg(s.id)
        } else {
            s.id
        }
    }

    fn horner(&mut self, terms: Vec<(Monomial, f64)>) -> Signed {
        match terms.len() {
            0 => return Signed { id: self.constant(0.0), negative: false },
            1 => {
                // `(c · position part) · velocity part`: the scaled position part (e.g.
                // `0.15 cos q1`) is what `J`, `D` and `g` contain too, so it is shared.
                let (m, c) = &terms[0];
                let (velocity, position): (Monomial, Monomial) =
                    m.iter().partition(|(a, _)| matches!(a, Atom::Qd(_)));
                let k = self.constant(c.abs());
                let position = self.monomial(&position);
                let scaled = self.mul(k, position);
                let velocity = self.monomial(&velocity);
                return Signed { id: self.mul(scaled, velocity), negative: *c < 0.0 };
            }
            _ => {}
        }
        // A coefficient common to all terms (up to sign) is factored out once.
        let first = terms[0].1.abs();
        if first != 1.0 && terms.iter().all(|(_, c)| c.abs() == first) {
            let unit: Vec<(Monomial, f64)> = terms.iter().map(|(m, c)| (m.clone(), c.signum())).collect();
            let inner = self.horner(unit);
            let k = self.constant(first);
            return Signed { id: self.mul(k, inner.id), negative: inner.negative };
        }
        // The atom shared by most terms.
        let mut counts: BTreeMap<Atom, usize> = BTreeMap::new();
        for (m, _) in &terms {
            for (a, _) in m {
                *counts.entry(*a).or_default() += 1;
            }
        }
        // Velocities are factored out first, so that what remains inside is a function of the
        // position only, shared with the position-dependent outputs.
        let is_velocity = |a: &Atom| matches!(a, Atom::Qd(_));
        let best = counts
            .iter()
            .filter(|(_, &n)| n >= 2)
            .max_by(|(a, n), (b, m)| is_velocity(a).cmp(&is_velocity(b)).then(n.cmp(m)).then(b.cmp(a)))
            .map(|(a, _)| *a);
        let Some(atom) = best else {
            let parts: Vec<Signed> = terms.into_iter().map(|t| self.horner(vec![t])).collect();
            return self.signed_sum(parts);
        };
        let with_min = terms
            .iter()
            .filter_map(|(m, _)| m.iter().find(|(a, _)| *a == atom).map(|(_, e)| *e))
            .min()
            .unwrap_or(1);
        let with_power = |k: &u32| *k;
        let mut with = Vec::new();
        let mut without = Vec::new();
        for (m, c) in terms {
            match m.iter().position(|(a, _)| *a == atom) {
                Some(i) => {
                    let mut lowered = m.clone();
                    lowered[i].1 -= with_min;
                    if lowered[i].1 == 0 {
                        lowered.remove(i);
                    }
                    with.push((lowered, c));
                }
                None => without.push((m, c)),
            }
        }
        // Factor out the largest power of the atom common to those terms (so that
        // `q̇²` is one shared square rather than two nested products).
        let common_power = with_power(&with_min);
        let input = self.input(atom);
        let factor = self.power(input, common_power);
        let inner = self.horner(with);
        let product = Signed { id: self.mul(factor, inner.id), negative: inner.negative };
        if without.is_empty() {
            return product;
        }
        let rest = self.horner(without);
        self.signed_sum(vec![product, rest])
    }

    fn signed_sum(&mut self, parts: Vec<Signed>) -> Signed {
        // A difference of two parts is oriented canonically (lower node id first), so that
        // `a − b` and `b − a` share one node and differ only in a sign, which the parent
        // absorbs into a constant factor.
        if let [x, y] = parts[..] {
            if x.negative != y.negative {
                let (positive, negative) = if x.negative { (y, x) } else { (x, y) };
                let (first, second, flipped) = if positive.id <= negative.id {
                    (positive.id, negative.id, false)
                } else {
                    (negative.id, positive.id, true)
                };
                return Signed { id: self.sub(first, second), negative: flipped };
            }
        }
        let all_negative = parts.iter().all(|p| p.negative);
        let mut ordered = parts;
        // Start from a positive part so that the rest become subtractions.
        ordered.sort_by_key(|p| p.negative);
        let mut acc = ordered[0].id;
        for p in &ordered[1..] {
            acc = if p.negative == all_negative { self.add(acc, p.id) } else { self.sub(acc, p.id) };
        }
        Signed { id: acc, negative: all_negative }
    }

    /// Nodes reachable from `roots`, in topological order.
    pub fn reachable(&self, roots: &[NodeId]) -> Vec<NodeId> {
        let mut seen = vec![false; self.nodes.len()];
        let mut stack: Vec<NodeId> = roots.to_vec();
        while let Some(id) = stack.pop() {
            if seen[id] {
                continue;
            }
            seen[id] = true;
            match self.nodes[id] {
                Node::Add(a, b) | Node::Sub(a, b) | Node::Mul(a, b) | Node::Div(a, b) => {
                    stack.push(a);
                    stack.push(b);
                }
                Node::Neg(a) | Node::Sqrt(a) => stack.push(a),
                _ => {}
            }
        }
        (0..self.nodes.len()).filter(|&i| seen[i]).collect()
    }

    /// The forward-mode derivative of `root` along some direction, built on this graph: each
    /// input's derivative is `input(dag, atom)`, and `known` holds derivatives already fixed
    /// (a node whose derivative comes from elsewhere, such as an implicit relation; the walk
    /// does not descend below it). Every derivative computed is added to `known`, so that
    /// derivatives of further roots along the same direction share it.
    pub fn derivative(
        &mut self,
        root: NodeId,
        known: &mut HashMap<NodeId, NodeId>,
        input: &mut dyn FnMut(&mut Dag, Atom) -> NodeId,
    ) -> NodeId {
        if let Some(&d) = known.get(&root) {
            return d;
        }
        // Children precede parents, so one ascending pass over what the root reaches (not
        // below a known node) sees each operand's derivative before it is needed.
        let mut order = Vec::new();
        let mut seen = std::collections::HashSet::new();
        let mut stack = vec![root];
        while let Some(id) = stack.pop() {
            if known.contains_key(&id) || !seen.insert(id) {
                continue;
            }
            order.push(id);
            match self.nodes[id] {
                Node::Add(a, b) | Node::Sub(a, b) | Node::Mul(a, b) | Node::Div(a, b) => {
                    stack.push(a);
                    stack.push(b);
                }
                Node::Neg(a) | Node::Sqrt(a) => stack.push(a),
                Node::Const(_) | Node::Input(_) => {}
            }
        }
        order.sort_unstable();
        for id in order {
            let d = |known: &HashMap<NodeId, NodeId>, x: NodeId| known[&x];
            let derivative = match self.nodes[id] {
                Node::Const(_) => self.constant(0.0),
                Node::Input(atom) => input(self, atom),
                Node::Add(a, b) => {
                    let (da, db) = (d(known, a), d(known, b));
                    self.add(da, db)
                }
                Node::Sub(a, b) => {
                    let (da, db) = (d(known, a), d(known, b));
                    self.sub(da, db)
                }
                Node::Mul(a, b) => {
                    let (da, db) = (d(known, a), d(known, b));
                    let left = self.mul(da, b);
                    let right = self.mul(a, db);
                    self.add(left, right)
                }
                Node::Neg(a) => {
                    let da = d(known, a);
                    self.neg(da)
                }
                // (a / b)' = (a' − (a / b) b') / b.
                Node::Div(a, b) => {
                    let (da, db) = (d(known, a), d(known, b));
                    let scaled = self.mul(id, db);
                    let numerator = self.sub(da, scaled);
                    self.div(numerator, b)
                }
                // (√a)' = a' / (2 √a).
                Node::Sqrt(a) => {
                    let da = d(known, a);
                    let two = self.constant(2.0);
                    let twice = self.mul(two, id);
                    self.div(da, twice)
                }
            };
            known.insert(id, derivative);
        }
        known[&root]
    }

    /// Operation counts of everything needed for `roots` (each shared node once).
    pub fn count(&self, roots: &[NodeId]) -> OpCounts {
        let mut counts = OpCounts::default();
        for id in self.reachable(roots) {
            match self.nodes[id] {
                Node::Add(..) | Node::Sub(..) => counts.additions += 1,
                Node::Mul(..) => counts.multiplications += 1,
                Node::Neg(..) => counts.negations += 1,
                Node::Div(..) => counts.divisions += 1,
                Node::Sqrt(..) => counts.square_roots += 1,
                Node::Input(Atom::Sin(_) | Atom::Cos(_)) => counts.trigonometric += 1,
                _ => {}
            }
        }
        counts
    }

    /// Evaluates a node given input values.
    pub fn eval(&self, id: NodeId, input: &dyn Fn(Atom) -> f64) -> f64 {
        self.eval_prefix(id + 1, input)[id]
    }

    /// Evaluates every node given input values.
    pub fn eval_all(&self, input: &dyn Fn(Atom) -> f64) -> Vec<f64> {
        self.eval_prefix(self.nodes.len(), input)
    }

    fn eval_prefix(&self, len: usize, input: &dyn Fn(Atom) -> f64) -> Vec<f64> {
        let mut values = vec![0.0; len];
        for (i, node) in self.nodes[..len].iter().enumerate() {
            values[i] = match *node {
                Node::Const(bits) => f64::from_bits(bits),
                Node::Input(a) => input(a),
                Node::Add(a, b) => values[a] + values[b],
                Node::Sub(a, b) => values[a] - values[b],
                Node::Mul(a, b) => values[a] * values[b],
                Node::Neg(a) => -values[a],
                Node::Div(a, b) => values[a] / values[b],
                Node::Sqrt(a) => values[a].sqrt(),
            };
        }
        values
    }
}

/// A linear combination of nodes (of the rebuilt DAG) plus a constant, used while merging sums.
#[derive(Clone, Default)]
struct Linear {
    terms: Vec<(NodeId, f64)>,
    constant: f64,
}

impl Linear {
    fn atom(id: NodeId) -> Self {
        Self { terms: vec![(id, 1.0)], constant: 0.0 }
    }

    fn scaled(mut self, k: f64) -> Self {
        for t in &mut self.terms {
            t.1 *= k;
        }
        self.constant *= k;
        self
    }

    fn plus(mut self, other: Linear) -> Self {
        self.terms.extend(other.terms);
        self.constant += other.constant;
        self
    }
}

impl Dag {
    /// How often each node of `order` (the nodes reachable from `roots`) is used; a root counts
    /// as used more than once, so that no rewrite folds it into a parent.
    fn use_counts(&self, order: &[NodeId], roots: &[NodeId]) -> Vec<usize> {
        let mut uses = vec![0usize; self.nodes.len()];
        for &id in order {
            match self.nodes[id] {
                Node::Add(a, b) | Node::Sub(a, b) | Node::Mul(a, b) | Node::Div(a, b) => {
                    uses[a] += 1;
                    uses[b] += 1;
                }
                Node::Neg(a) | Node::Sqrt(a) => uses[a] += 1,
                _ => {}
            }
        }
        for &r in roots {
            uses[r] += 2;
        }
        uses
    }

    /// Rebuilds the nodes needed for `roots` with every chain of additions, subtractions,
    /// negations and constant multiples that is used once flattened into one linear
    /// combination: equal terms merge (`c₁ x + c₂ x = (c₁ + c₂) x`, and exact cancellations
    /// vanish), and terms with the same coefficient magnitude share one multiplication
    /// (`c x − c y = c (x − y)`). Nodes used more than once stay shared. Returns the new DAG, the
    /// new roots and, for every node that still exists, its new id.
    pub fn merged_sums(&self, roots: &[NodeId]) -> (Dag, Vec<NodeId>, HashMap<NodeId, NodeId>) {
        let order = self.reachable(roots);
        let uses = self.use_counts(&order, roots);
        let mut out = Dag::new();
        let mut linear: HashMap<NodeId, Linear> = HashMap::default();
        let mut built: HashMap<NodeId, NodeId> = HashMap::default();
        // The linear form of a child: its own (if used once and linear) or the child as a term.
        fn form(
            id: NodeId,
            uses: &[usize],
            linear: &HashMap<NodeId, Linear>,
            built: &mut HashMap<NodeId, NodeId>,
            out: &mut Dag,
        ) -> Linear {
            if uses[id] == 1 {
                if let Some(l) = linear.get(&id) {
                    return l.clone();
                }
            }
            Linear::atom(materialize(id, linear, built, out))
        }
        fn materialize(
            id: NodeId,
            linear: &HashMap<NodeId, Linear>,
            built: &mut HashMap<NodeId, NodeId>,
            out: &mut Dag,
        ) -> NodeId {
            if let Some(&b) = built.get(&id) {
                return b;
            }
            let l = linear.get(&id).cloned().unwrap_or_default();
            let node = out.linear_combination(&l);
            built.insert(id, node);
            node
        }
        for &id in &order {
            match self.nodes[id] {
                Node::Const(bits) => {
                    let c = out.constant(f64::from_bits(bits));
                    built.insert(id, c);
                    linear.insert(id, Linear { terms: Vec::new(), constant: f64::from_bits(bits) });
                }
                Node::Input(atom) => {
                    let x = out.input(atom);
                    built.insert(id, x);
                }
                Node::Add(a, b) | Node::Sub(a, b) => {
                    let x = form(a, &uses, &linear, &mut built, &mut out);
                    let y = form(b, &uses, &linear, &mut built, &mut out);
                    let y = if matches!(self.nodes[id], Node::Sub(..)) { y.scaled(-1.0) } else { y };
                    linear.insert(id, x.plus(y));
                }
                Node::Neg(a) => {
                    let x = form(a, &uses, &linear, &mut built, &mut out);
                    linear.insert(id, x.scaled(-1.0));
                }
                Node::Mul(a, b) => match (self.constant_value(a), self.constant_value(b)) {
                    (Some(k), _) => {
                        let x = form(b, &uses, &linear, &mut built, &mut out);
                        linear.insert(id, x.scaled(k));
                    }
                    (_, Some(k)) => {
                        let x = form(a, &uses, &linear, &mut built, &mut out);
                        linear.insert(id, x.scaled(k));
                    }
                    _ => {
                        let x = materialize(a, &linear, &mut built, &mut out);
                        let y = materialize(b, &linear, &mut built, &mut out);
                        let p = out.mul(x, y);
                        built.insert(id, p);
                    }
                },
                Node::Div(a, b) => {
                    let x = materialize(a, &linear, &mut built, &mut out);
                    let y = materialize(b, &linear, &mut built, &mut out);
                    let q = out.div(x, y);
                    built.insert(id, q);
                }
                Node::Sqrt(a) => {
                    let x = materialize(a, &linear, &mut built, &mut out);
                    let r = out.sqrt(x);
                    built.insert(id, r);
                }
            }
        }
        let new_roots = roots.iter().map(|&r| materialize(r, &linear, &mut built, &mut out)).collect();
        (out, new_roots, built)
    }

    /// Builds `Σ c_i x_i + c₀`: equal terms merged, terms grouped by coefficient magnitude.
    fn linear_combination(&mut self, l: &Linear) -> NodeId {
        let mut merged: Vec<(NodeId, f64, f64)> = Vec::new(); // (node, sum, magnitude)
        for &(id, c) in &l.terms {
            match merged.iter_mut().find(|m| m.0 == id) {
                Some(m) => {
                    m.1 += c;
                    m.2 += c.abs();
                }
                None => merged.push((id, c, c.abs())),
            }
        }
        // Exact symbolic cancellation, up to rounding of the constants.
        merged.retain(|m| m.1.abs() > 1e-12 * m.2);
        // A combination proportional to one built before is a multiple of it.
        let mut key: Vec<(NodeId, i64)> = Vec::new();
        let mut scale = 0.0;
        if merged.len() >= 2 {
            let mut sorted: Vec<(NodeId, f64)> = merged.iter().map(|m| (m.0, m.1)).collect();
            sorted.sort_by_key(|t| t.0);
            scale = sorted[0].1;
            // Ratios rounded to 12 significant digits, so that rounding of the constants
            // does not hide a proportionality.
            key = sorted.iter().map(|&(id, c)| (id, ((c / scale) * 1e12).round() as i64)).collect();
            if let Some(&(base, base_scale)) = self.linear_index.get(&key) {
                let k = self.constant(scale / base_scale);
                let multiple = self.mul(k, base);
                let c = self.constant(l.constant);
                return self.add(multiple, c);
            }
        }
        let constant = l.constant;
        let variable = self.variable_part(merged);
        if !key.is_empty() {
            self.linear_index.insert(key, (variable, scale));
        }
        let c = self.constant(constant);
        self.add(variable, c)
    }

    /// `Σ c_i x_i` with equal coefficient magnitudes sharing one multiplication.
    fn variable_part(&mut self, merged: Vec<(NodeId, f64, f64)>) -> NodeId {
        // Groups of equal coefficient magnitude, in order of first appearance.
        let mut groups: Vec<(f64, Vec<Signed>)> = Vec::new();
        for (id, c, _) in merged {
            let s = Signed { id, negative: c < 0.0 };
            match groups.iter_mut().find(|g| g.0 == c.abs()) {
                Some(g) => g.1.push(s),
                None => groups.push((c.abs(), vec![s])),
            }
        }
        let mut parts: Vec<Signed> = Vec::new();
        for (k, members) in groups {
            let inner = self.signed_sum(members);
            let k = self.constant(k);
            parts.push(Signed { id: self.mul(k, inner.id), negative: inner.negative });
        }
        if parts.is_empty() {
            return self.constant(0.0);
        }
        let total = self.signed_sum(parts);
        self.resolve(total)
    }
}

impl Dag {
    /// Rebuilds the nodes needed for `roots`, removing negations of products whose other
    /// factor is a difference used nowhere else: `−(x (a − b)) = x (b − a)`. Returns the new
    /// DAG, the new roots and, for every node that still exists, its new id.
    pub fn pushed_negations(&self, roots: &[NodeId]) -> (Dag, Vec<NodeId>, HashMap<NodeId, NodeId>) {
        let order = self.reachable(roots);
        let uses = self.use_counts(&order, roots);
        let mut out = Dag::new();
        let mut map: HashMap<NodeId, NodeId> =
            HashMap::with_capacity_and_hasher(order.len(), Default::default());
        for &id in &order {
            let new = match self.nodes[id] {
                Node::Const(bits) => out.constant(f64::from_bits(bits)),
                Node::Input(atom) => out.input(atom),
                Node::Add(a, b) => out.add(map[&a], map[&b]),
                Node::Sub(a, b) => out.sub(map[&a], map[&b]),
                Node::Mul(a, b) => out.mul(map[&a], map[&b]),
                Node::Div(a, b) => out.div(map[&a], map[&b]),
                Node::Sqrt(a) => out.sqrt(map[&a]),
                Node::Neg(m) => match self.free_negation(m, &uses, &map, &mut out) {
                    Some(flipped) => flipped,
                    None => out.neg(map[&m]),
                },
            };
            map.insert(id, new);
        }
        let new_roots = roots.iter().map(|r| map[r]).collect();
        (out, new_roots, map)
    }

    /// `−x` for an old node `x` used only once, built in `out` without a negation when the sign
    /// can be absorbed: `−(a − b) = b − a`, `−(c x) = (−c) x`, `−(x y) = x (−y)`,
    /// `−(a + b) = (−a) − b`.
    fn free_negation(
        &self,
        id: NodeId,
        uses: &[usize],
        map: &HashMap<NodeId, NodeId>,
        out: &mut Dag,
    ) -> Option<NodeId> {
        if uses[id] != 1 {
            return None;
        }
        match self.nodes[id] {
            Node::Const(bits) => Some(out.constant(-f64::from_bits(bits))),
            Node::Neg(x) => Some(map[&x]),
            Node::Sub(a, b) => Some(out.sub(map[&b], map[&a])),
            Node::Mul(x, y) => {
                for (x, y) in [(x, y), (y, x)] {
                    if let Some(k) = self.constant_value(x) {
                        let k = out.constant(-k);
                        return Some(out.mul(k, map[&y]));
                    }
                    if let Some(negated) = self.free_negation(y, uses, map, out) {
                        return Some(out.mul(map[&x], negated));
                    }
                }
                None
            }
            Node::Add(a, b) => {
                for (a, b) in [(a, b), (b, a)] {
                    if let Some(negated) = self.free_negation(a, uses, map, out) {
                        return Some(out.sub(negated, map[&b]));
                    }
                }
                None
            }
            _ => None,
        }
    }

    /// The cheapest of the DAG as built, after [`Dag::merged_sums`], after that and
    /// [`Dag::pushed_negations`], and after those and [`Dag::regrouped_products`] (with and
    /// without sinking negations), each of the two cheapest also with signs chosen
    /// ([`Dag::negations_after_signs`]), by arithmetic plus trigonometric operations — counted
    /// with fused multiply-adds ([`Dag::count_fused`]) when `fused_multiply_add` is set — with
    /// the maps from old node ids to new ones (`None`: the DAG as built is the cheapest).
    pub fn optimised(&self, roots: &[NodeId], fused_multiply_add: bool) -> Option<Optimised> {
        let cost = |dag: &Dag, roots: &[NodeId]| {
            let c = if fused_multiply_add { dag.count_fused(roots) } else { dag.count(roots) };
            c.arithmetic() + c.trigonometric
        };
        let compose =
            |first: &HashMap<NodeId, NodeId>, second: &HashMap<NodeId, NodeId>| -> HashMap<NodeId, NodeId> {
                first.iter().filter_map(|(old, mid)| Some((*old, *second.get(mid)?))).collect()
            };
        let original = cost(self, roots);
        let (merged, merged_roots, merged_map) = self.merged_sums(roots);
        let (pushed, pushed_roots, pushed_map) = merged.pushed_negations(&merged_roots);
        let pushed_composed = compose(&merged_map, &pushed_map);
        let none = HashMap::default;
        let mut candidates = vec![(merged_roots, merged, merged_map, none())];
        let mut regrouped = Vec::new();
        for sink in [false, true] {
            let (dag, new_roots, map) = pushed.regrouped_products(&pushed_roots, sink);
            regrouped.push((new_roots, dag, compose(&pushed_composed, &map), none()));
        }
        candidates.push((pushed_roots, pushed, pushed_composed, none()));
        candidates.extend(regrouped);
        // Signs chosen on top of the two cheapest (see `crate::sym::signs`).
        candidates.sort_by_key(|(r, d, ..)| cost(d, r));
        let signed: Vec<_> = candidates
            .iter()
            .take(2)
            .map(|(roots, dag, map, _)| {
                let signed = dag.negations_after_signs(roots);
                (signed.roots, signed.dag, compose(map, &signed.kept), compose(map, &signed.negated))
            })
            .collect();
        candidates.extend(signed);
        // The first of equally cheap candidates wins, so that a pass is only taken when it saves.
        let mut best = original;
        let mut chosen = None;
        for (r, d, kept, negated) in candidates {
            let c = cost(&d, &r);
            if c < best {
                best = c;
                chosen = Some(Optimised { dag: d, roots: r, kept, negated });
            }
        }
        chosen
    }

    /// Operation counts of `roots` in the cheapest form [`Dag::optimised`] finds.
    pub fn optimised_count(&self, roots: &[NodeId]) -> OpCounts {
        self.optimised_count_with(roots, false)
    }

    /// Operation counts of `roots` in the cheapest form [`Dag::optimised`] finds, counted with
    /// fused multiply-adds if `fused_multiply_add` is set.
    pub fn optimised_count_with(&self, roots: &[NodeId], fused_multiply_add: bool) -> OpCounts {
        let (dag, roots) = match self.optimised(roots, fused_multiply_add) {
            Some(optimised) => (optimised.dag, optimised.roots),
            None => (self.clone(), roots.to_vec()),
        };
        if fused_multiply_add {
            dag.count_fused(&roots)
        } else {
            dag.count(&roots)
        }
    }
}

/// The result of [`Dag::optimised`].
pub struct Optimised {
    /// The optimised DAG.
    pub dag: Dag,
    /// The new roots (the same values as the old).
    pub roots: Vec<NodeId>,
    /// Old node → new node with the same value (for the nodes that survive).
    pub kept: HashMap<NodeId, NodeId>,
    /// Old node → new node holding its negation (the sign choice computes some values negated).
    pub negated: HashMap<NodeId, NodeId>,
}

/// A factor of a flattened product in [`Dag::regrouped_products`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
enum Factor {
    /// A constant magnitude other than 1 (its bits).
    Constant(u64),
    /// A node of the DAG being rebuilt.
    Node(NodeId),
    /// A product of two factors shared by several products.
    Pair(usize),
}

/// A flattened product: a sign and its factors, sorted.
#[derive(Clone, Debug)]
struct Product {
    negative: bool,
    factors: Vec<Factor>,
}

impl Product {
    /// Replaces one occurrence of `x` and of `y` by `pair`; false if `x` or `y` is missing.
    fn replace(&mut self, x: Factor, y: Factor, pair: Factor) -> bool {
        let Some(i) = self.factors.iter().position(|f| *f == x) else { return false };
        let Some(j) = self.factors.iter().enumerate().position(|(k, f)| *f == y && k != i) else {
            return false;
        };
        let (hi, lo) = if i > j { (i, j) } else { (j, i) };
        self.factors.remove(hi);
        self.factors.remove(lo);
        self.factors.push(pair);
        self.factors.sort();
        true
    }
}

/// The distinct pairs of factors of a sorted product, each with its smaller factor first.
fn distinct_pairs(factors: &[Factor]) -> Vec<(Factor, Factor)> {
    let mut pairs = Vec::with_capacity(factors.len() * factors.len().saturating_sub(1) / 2);
    for (i, &x) in factors.iter().enumerate() {
        for &y in &factors[i + 1..] {
            pairs.push((x, y));
        }
    }
    pairs.sort_unstable();
    pairs.dedup();
    pairs
}

/// Greedy sharing of the most frequent pair of factors among `products`: the pair found in
/// the most products (ties: the smallest pair) becomes a [`Factor::Pair`] in every product
/// holding it, until no pair is in two products. Returns the pairs, indexed by
/// [`Factor::Pair`].
///
/// The counts are kept up to date instead of recounted per pair chosen: only the products
/// holding both factors of the chosen pair change, found through the index of the products
/// each factor is in, and a max-heap of (count, pair) entries, checked against the current
/// count when popped, yields the next pair.
fn share_frequent_pairs(products: &mut [Product]) -> Vec<(Factor, Factor)> {
    use std::cmp::Reverse;
    use std::collections::BinaryHeap;
    let mut counts: HashMap<(Factor, Factor), usize> = HashMap::default();
    let mut holders: HashMap<Factor, Vec<usize>> = HashMap::default();
    for (k, p) in products.iter().enumerate() {
        for key in distinct_pairs(&p.factors) {
            *counts.entry(key).or_default() += 1;
        }
        for f in &p.factors {
            let list = holders.entry(*f).or_default();
            if list.last() != Some(&k) {
                list.push(k);
            }
        }
    }
    let mut heap: BinaryHeap<(usize, Reverse<(Factor, Factor)>)> =
        counts.iter().filter(|(_, &n)| n >= 2).map(|(&key, &n)| (n, Reverse(key))).collect();
    let mut pairs: Vec<(Factor, Factor)> = Vec::new();
    while let Some((n, Reverse((x, y)))) = heap.pop() {
        if counts.get(&(x, y)) != Some(&n) {
            continue; // a stale entry: the count has changed since
        }
        let pair = Factor::Pair(pairs.len());
        pairs.push((x, y));
        let candidates = holders.get(&x).cloned().unwrap_or_default();
        let mut pair_holders = Vec::new();
        for k in candidates {
            let p = &mut products[k];
            if !(p.factors.contains(&x) && p.factors.contains(&y)) {
                continue;
            }
            let before = distinct_pairs(&p.factors);
            let mut replaced = false;
            while p.replace(x, y, pair) {
                replaced = true;
            }
            if !replaced {
                continue; // x == y held once only
            }
            let after = distinct_pairs(&p.factors);
            for key in &before {
                if after.binary_search(key).is_err() {
                    // Every pair of a product was counted when the product was, or since.
                    if let Some(count) = counts.get_mut(key) {
                        *count -= 1;
                        if *count >= 2 {
                            heap.push((*count, Reverse(*key)));
                        }
                    }
                }
            }
            for key in &after {
                if before.binary_search(key).is_err() {
                    let count = counts.entry(*key).or_default();
                    *count += 1;
                    if *count >= 2 {
                        heap.push((*count, Reverse(*key)));
                    }
                }
            }
            pair_holders.push(k);
        }
        holders.insert(pair, pair_holders);
    }
    pairs
}

impl Dag {
    /// A `Mul` interned as is, without moving negations out of it.
    fn raw_mul(&mut self, a: NodeId, b: NodeId) -> NodeId {
        match (self.constant_value(a), self.constant_value(b)) {
            (Some(_), _) | (_, Some(_)) => self.mul(a, b),
            _ => {
                let (lo, hi) = if a <= b { (a, b) } else { (b, a) };
                self.intern(Node::Mul(lo, hi))
            }
        }
    }

    /// Rebuilds the nodes needed for `roots` with products regrouped and signs shared:
    ///
    /// * every product whose factors are used once is flattened into a sign, a constant
    ///   magnitude and its factors, so that `c·y` and `(−c)·y` are one product up to sign;
    /// * pairs of factors common to several products become one shared product (greedily, the
    ///   most frequent pair first: `k·s·a` and `−k·s·b` share `k·s`), a pair with a constant
    ///   taking the sign with which it is an output by itself;
    /// * signs travel with the values and are absorbed by the sums and products that consume
    ///   them; only an output that is negative needs a negation, and with `sink_negations` a
    ///   factor common to several negative outputs is negated once for all of them
    ///   (`−(k·x)` and `−(a·x + b·y)` become `k·(−x)` and `(−x)·a − b·y`).
    ///
    /// Returns the new DAG, the new roots and, for every node that still exists with the same
    /// sign, its new id.
    pub fn regrouped_products(
        &self,
        roots: &[NodeId],
        sink_negations: bool,
    ) -> (Dag, Vec<NodeId>, HashMap<NodeId, NodeId>) {
        let order = self.reachable(roots);
        let uses = self.use_counts(&order, roots);
        let is_product = |id: NodeId| matches!(self.nodes[id], Node::Mul(..) | Node::Neg(..));
        let mut product_parent = vec![false; self.nodes.len()];
        for &id in &order {
            match self.nodes[id] {
                Node::Mul(a, b) => {
                    product_parent[a] = true;
                    product_parent[b] = true;
                }
                Node::Neg(a) => product_parent[a] = true,
                _ => {}
            }
        }
        // A product used once, by a product: flattened into its parent.
        let internal = |id: NodeId| is_product(id) && uses[id] == 1 && product_parent[id];
        let mut products: Vec<Product> = Vec::new();
        let mut product_of: HashMap<NodeId, usize> = HashMap::default();
        for &id in &order {
            if !is_product(id) || internal(id) {
                continue;
            }
            let mut coefficient = 1.0;
            let mut factors = Vec::new();
            let mut stack = vec![id];
            while let Some(x) = stack.pop() {
                match self.nodes[x] {
                    Node::Const(bits) => coefficient *= f64::from_bits(bits),
                    Node::Mul(a, b) if x == id || internal(x) => {
                        stack.push(a);
                        stack.push(b);
                    }
                    Node::Neg(a) if x == id || internal(x) => {
                        coefficient = -coefficient;
                        stack.push(a);
                    }
                    _ => factors.push(Factor::Node(x)),
                }
            }
            let magnitude = coefficient.abs();
            if magnitude != 1.0 {
                factors.push(Factor::Constant(magnitude.to_bits()));
            }
            factors.sort();
            product_of.insert(id, products.len());
            products.push(Product { negative: coefficient < 0.0, factors });
        }
        let pairs = share_frequent_pairs(&mut products);
        // A pair with a constant takes the sign with which it is an output by itself.
        let mut flip = vec![false; pairs.len()];
        for (k, &(x, y)) in pairs.iter().enumerate() {
            if !matches!(x, Factor::Constant(_)) && !matches!(y, Factor::Constant(_)) {
                continue;
            }
            let vote: i64 = products
                .iter()
                .filter(|p| p.factors == [Factor::Pair(k)])
                .map(|p| if p.negative { -1 } else { 1 })
                .sum();
            flip[k] = vote < 0;
        }
        let mut out = Dag::new();
        let mut built: HashMap<NodeId, Signed> =
            HashMap::with_capacity_and_hasher(order.len(), Default::default());
        let mut pair_built: Vec<Option<Signed>> = vec![None; pairs.len()];
        fn factor_value(
            f: Factor,
            pairs: &[(Factor, Factor)],
            flip: &[bool],
            built: &HashMap<NodeId, Signed>,
            pair_built: &mut Vec<Option<Signed>>,
            out: &mut Dag,
        ) -> Signed {
            match f {
                Factor::Constant(bits) => Signed { id: out.constant(f64::from_bits(bits)), negative: false },
                Factor::Node(x) => built[&x],
                Factor::Pair(k) => {
                    if let Some(s) = pair_built[k] {
                        return s;
                    }
                    let (x, y) = pairs[k];
                    let a = factor_value(x, pairs, flip, built, pair_built, out);
                    let b = factor_value(y, pairs, flip, built, pair_built, out);
                    let negative = a.negative != b.negative;
                    // A pair holds at most one constant, and it sorts first.
                    let s = match out.constant_value(a.id) {
                        Some(v) if flip[k] => {
                            let c = out.constant(-v);
                            Signed { id: out.raw_mul(c, b.id), negative: !negative }
                        }
                        _ => Signed { id: out.raw_mul(a.id, b.id), negative },
                    };
                    pair_built[k] = Some(s);
                    s
                }
            }
        }
        for &id in &order {
            let value = match self.nodes[id] {
                Node::Const(bits) => Signed { id: out.constant(f64::from_bits(bits)), negative: false },
                Node::Input(atom) => Signed { id: out.input(atom), negative: false },
                Node::Mul(..) | Node::Neg(..) => {
                    let Some(&k) = product_of.get(&id) else { continue };
                    let p = products[k].clone();
                    let mut negative = p.negative;
                    let mut acc: Option<NodeId> = None;
                    for f in &p.factors {
                        let v = factor_value(*f, &pairs, &flip, &built, &mut pair_built, &mut out);
                        negative ^= v.negative;
                        acc = Some(match acc {
                            None => v.id,
                            Some(a) => out.raw_mul(a, v.id),
                        });
                    }
                    match acc {
                        Some(id) => Signed { id, negative },
                        // Every factor was a constant of magnitude 1 (or there was none).
                        None => Signed { id: out.constant(1.0), negative },
                    }
                }
                Node::Add(a, b) | Node::Sub(a, b) => {
                    let (x, mut y) = (built[&a], built[&b]);
                    if matches!(self.nodes[id], Node::Sub(..)) {
                        y.negative = !y.negative;
                    }
                    match (x.negative, y.negative) {
                        (false, false) => Signed { id: out.add(x.id, y.id), negative: false },
                        (false, true) => Signed { id: out.sub(x.id, y.id), negative: false },
                        (true, false) => Signed { id: out.sub(y.id, x.id), negative: false },
                        (true, true) => Signed { id: out.add(x.id, y.id), negative: true },
                    }
                }
                Node::Div(a, b) => {
                    let (x, y) = (built[&a], built[&b]);
                    Signed { id: out.div(x.id, y.id), negative: x.negative != y.negative }
                }
                Node::Sqrt(a) => {
                    let x = built[&a];
                    let x = out.resolve(x);
                    Signed { id: out.sqrt(x), negative: false }
                }
            };
            built.insert(id, value);
        }
        let mut new_roots: Vec<Option<NodeId>> = Vec::with_capacity(roots.len());
        let mut pending: Vec<(usize, NodeId)> = Vec::new();
        for (i, r) in roots.iter().enumerate() {
            let s = built[r];
            if !s.negative {
                new_roots.push(Some(s.id));
            } else if sink_negations && !out.free_to_negate(s.id) {
                new_roots.push(None);
                pending.push((i, s.id));
            } else {
                new_roots.push(Some(out.neg(s.id)));
            }
        }
        // Negated outputs: a factor common to several of them is negated once.
        loop {
            let mut counts: BTreeMap<NodeId, usize> = BTreeMap::new();
            for &(_, id) in &pending {
                let mut leaves = out.sinkable_factors(id);
                leaves.sort_unstable();
                leaves.dedup();
                for l in leaves {
                    *counts.entry(l).or_default() += 1;
                }
            }
            let Some((leaf, _)) =
                counts.into_iter().filter(|(_, n)| *n >= 2).max_by(|a, b| a.1.cmp(&b.1).then(b.0.cmp(&a.0)))
            else {
                break;
            };
            let negated = out.neg(leaf);
            let mut rest = Vec::new();
            for (i, id) in pending {
                match out.with_negated_factor(id, leaf, negated) {
                    Some(new) => new_roots[i] = Some(new),
                    None => rest.push((i, id)),
                }
            }
            pending = rest;
        }
        for (i, id) in pending {
            new_roots[i] = Some(out.neg(id));
        }
        let new_roots: Vec<NodeId> = new_roots.into_iter().map(|r| r.unwrap_or_default()).collect();
        let map = built.into_iter().filter(|(_, s)| !s.negative).map(|(old, s)| (old, s.id)).collect();
        (out, new_roots, map)
    }

    /// Whether `−x` costs no operation: a constant, a negation, a difference, a constant multiple.
    fn free_to_negate(&self, id: NodeId) -> bool {
        match self.nodes[id] {
            Node::Const(_) | Node::Neg(_) | Node::Sub(..) => true,
            Node::Mul(a, b) => self.constant_value(a).is_some() || self.constant_value(b).is_some(),
            _ => false,
        }
    }

    /// The factors of `id` (a product) or of its terms (a sum of products) that can carry its
    /// negation: `−(x·y) = (−x)·y`, `−(x·y + z) = (−x)·y − z`.
    fn sinkable_factors(&self, id: NodeId) -> Vec<NodeId> {
        let factors = |p: NodeId| -> Vec<NodeId> {
            match self.nodes[p] {
                Node::Mul(a, b) => [a, b].into_iter().filter(|&x| self.constant_value(x).is_none()).collect(),
                _ => Vec::new(),
            }
        };
        match self.nodes[id] {
            Node::Mul(..) => factors(id),
            Node::Add(a, b) => {
                let mut all = factors(a);
                all.extend(factors(b));
                all
            }
            _ => Vec::new(),
        }
    }

    /// `−id` built with `negated` (the node of `−leaf`) in place of the factor `leaf`, if `leaf`
    /// is one of [`Dag::sinkable_factors`].
    fn with_negated_factor(&mut self, id: NodeId, leaf: NodeId, negated: NodeId) -> Option<NodeId> {
        let replaced = |dag: &mut Dag, p: NodeId| -> Option<NodeId> {
            match dag.nodes[p] {
                Node::Mul(a, b) if a == leaf => Some(dag.raw_mul(negated, b)),
                Node::Mul(a, b) if b == leaf => Some(dag.raw_mul(a, negated)),
                _ => None,
            }
        };
        match self.nodes[id] {
            Node::Mul(..) => replaced(self, id),
            Node::Add(a, b) => {
                for (x, y) in [(a, b), (b, a)] {
                    if let Some(negated_x) = replaced(self, x) {
                        return Some(self.intern(Node::Sub(negated_x, y)));
                    }
                }
                None
            }
            _ => None,
        }
    }
}

impl Dag {
    /// Which nodes fuse with the multiplication they consume, for fused multiply-add emission:
    /// an addition or subtraction with an operand that is a product used nowhere else becomes
    /// one `(±a·b) ± c` (the first such operand; a negation of such a sum, used nowhere else,
    /// folds its sign in), and a negation of a product used nowhere else becomes `−(a·b)` (one
    /// `vnmul` on ARM). Keys are the fused nodes; the products (and sums) they absorb are
    /// emitted as part of them.
    pub fn fusions(&self, roots: &[NodeId]) -> HashMap<NodeId, Fused> {
        let order = self.reachable(roots);
        let uses = self.use_counts(&order, roots);
        let single_product = |m: NodeId| match self.nodes[m] {
            Node::Mul(a, b) if uses[m] == 1 => Some((a, b)),
            _ => None,
        };
        let mut fused: HashMap<NodeId, Fused> = HashMap::default();
        for &id in &order {
            match self.nodes[id] {
                Node::Add(x, y) | Node::Sub(x, y) => {
                    let subtract = matches!(self.nodes[id], Node::Sub(..));
                    // (product, addend, product negated, addend negated)
                    let options = [(x, y, false, subtract), (y, x, subtract, false)];
                    for (m, c, negate_product, negate_addend) in options {
                        if let Some((a, b)) = single_product(m) {
                            fused.insert(id, Fused::MulAdd { a, b, c, negate_product, negate_addend });
                            break;
                        }
                    }
                }
                Node::Neg(s) if uses[s] == 1 => match (fused.get(&s).copied(), self.nodes[s]) {
                    (Some(Fused::MulAdd { a, b, c, negate_product, negate_addend }), _) => {
                        fused.remove(&s);
                        fused.insert(
                            id,
                            Fused::MulAdd {
                                a,
                                b,
                                c,
                                negate_product: !negate_product,
                                negate_addend: !negate_addend,
                            },
                        );
                    }
                    (None, Node::Mul(a, b)) => {
                        fused.insert(id, Fused::NegMul { a, b });
                    }
                    _ => {}
                },
                _ => {}
            }
        }
        fused
    }

    /// Operation counts of `roots` with the fusions of [`Dag::fusions`]: a fused multiply-add
    /// counts once (in [`OpCounts::fused`]) instead of a multiplication and an addition (and a
    /// negation), a negated product once as a multiplication.
    pub fn count_fused(&self, roots: &[NodeId]) -> OpCounts {
        let mut counts = self.count(roots);
        for (id, f) in self.fusions(roots) {
            match f {
                Fused::MulAdd { .. } => {
                    counts.additions -= 1;
                    counts.multiplications -= 1;
                    counts.fused += 1;
                    if matches!(self.nodes[id], Node::Neg(_)) {
                        counts.negations -= 1;
                    }
                }
                Fused::NegMul { .. } => counts.negations -= 1,
            }
        }
        counts
    }
}

/// DAG arithmetic for the matrix helpers of `crate::math::matrix`: `Σ a_k b_k` is a left fold
/// from the constant 0, each product followed by its addition (the node order the emitted
/// names follow).
impl crate::math::matrix::Arithmetic for Dag {
    type Value = NodeId;

    fn add(&mut self, a: &NodeId, b: &NodeId) -> NodeId {
        Dag::add(self, *a, *b)
    }

    fn dot<'v>(&mut self, pairs: impl Iterator<Item = (&'v NodeId, &'v NodeId)>) -> NodeId {
        let mut sum = self.constant(0.0);
        for (&a, &b) in pairs {
            let product = self.mul(a, b);
            sum = Dag::add(self, sum, product);
        }
        sum
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Values of `roots` at inputs `q_j = 0.3 + 0.7 j`.
    fn values(dag: &Dag, roots: &[NodeId]) -> Vec<f64> {
        let all = dag.eval_all(&|a| match a {
            Atom::Q(j) => 0.3 + 0.7 * f64::from(j),
            _ => 1.0,
        });
        roots.iter().map(|&r| all[r]).collect()
    }

    fn cost(c: OpCounts) -> usize {
        c.arithmetic() + c.trigonometric
    }

    /// The greedy pair sharing as first written: every pair's count recomputed from all
    /// products each time a pair is chosen. The incremental [`share_frequent_pairs`] must
    /// choose the same pairs in the same order.
    fn share_frequent_pairs_by_recounting(products: &mut [Product]) -> Vec<(Factor, Factor)> {
        let mut pairs: Vec<(Factor, Factor)> = Vec::new();
        loop {
            let mut counts: HashMap<(Factor, Factor), usize> = HashMap::default();
            for p in products.iter() {
                let mut seen: Vec<(Factor, Factor)> = Vec::new();
                for i in 0..p.factors.len() {
                    for j in i + 1..p.factors.len() {
                        let key = (p.factors[i], p.factors[j]);
                        if !seen.contains(&key) {
                            seen.push(key);
                            *counts.entry(key).or_default() += 1;
                        }
                    }
                }
            }
            let best = counts
                .into_iter()
                .filter(|(_, n)| *n >= 2)
                .max_by(|(k1, n1), (k2, n2)| n1.cmp(n2).then(k2.cmp(k1)))
                .map(|(k, _)| k);
            let Some((x, y)) = best else { break };
            let pair = Factor::Pair(pairs.len());
            pairs.push((x, y));
            for p in products.iter_mut() {
                while p.replace(x, y, pair) {}
            }
        }
        pairs
    }

    #[test]
    fn incremental_pair_sharing_matches_recounting() {
        // Random products of 1–7 factors drawn from a few nodes and constants, with repeats
        // (x·x), so that ties, squares and overlapping pairs all occur.
        let mut state: u64 = 0x2545_f491_4f6c_dd1d;
        let mut next = |bound: u64| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state % bound
        };
        let mut pairs_shared = 0;
        for _ in 0..300 {
            let count = 2 + next(40) as usize;
            let alphabet = 2 + next(10);
            let mut products: Vec<Product> = (0..count)
                .map(|_| {
                    let mut factors: Vec<Factor> = (0..1 + next(7))
                        .map(|_| match next(alphabet + 2) {
                            k if k < alphabet => Factor::Node(k as NodeId),
                            k => Factor::Constant((k as f64).to_bits()),
                        })
                        .collect();
                    factors.sort();
                    Product { negative: next(2) == 0, factors }
                })
                .collect();
            let mut expected_products = products.clone();
            let expected = share_frequent_pairs_by_recounting(&mut expected_products);
            let chosen = share_frequent_pairs(&mut products);
            assert_eq!(chosen, expected);
            for (p, e) in products.iter().zip(&expected_products) {
                assert_eq!(p.factors, e.factors);
            }
            pairs_shared += chosen.len();
        }
        assert!(pairs_shared > 1000, "the random products share too few pairs to test: {pairs_shared}");
    }

    #[test]
    fn derivatives_match_central_differences_and_stop_at_known_nodes() {
        // f = √(x² + y) / (x − y) + x·y, g = f·z with ∂z/∂x given as 3 (a known node).
        let mut dag = Dag::new();
        let [x, y, z] = [0, 1, 2].map(|j| dag.input(Atom::Q(j)));
        let xx = dag.mul(x, x);
        let radicand = dag.add(xx, y);
        let root = dag.sqrt(radicand);
        let gap = dag.sub(x, y);
        let ratio = dag.div(root, gap);
        let xy = dag.mul(x, y);
        let f = dag.add(ratio, xy);
        let minus_f = dag.neg(f);
        let g = dag.mul(minus_f, z);
        let value = |dag: &Dag, node: NodeId, at: [f64; 3]| {
            dag.eval(node, &|a| match a {
                Atom::Q(j) => at[usize::from(j)],
                _ => f64::NAN,
            })
        };
        let at = [0.7, 0.4, 1.9];
        let h = 1e-6;
        let difference = |dag: &Dag, node: NodeId, step: [f64; 3]| {
            let shifted = |sign: f64| std::array::from_fn(|i| at[i] + sign * h * step[i]);
            (value(dag, node, shifted(1.0)) - value(dag, node, shifted(-1.0))) / (2.0 * h)
        };
        let mut known = HashMap::default();
        let mut by_x = |dag: &mut Dag, atom: Atom| dag.constant(if atom == Atom::Q(0) { 1.0 } else { 0.0 });
        let df = dag.derivative(f, &mut known, &mut by_x);
        let expected = difference(&dag, f, [1.0, 0.0, 0.0]);
        assert!((value(&dag, df, at) - expected).abs() <= 1e-8 * expected.abs(), "{expected}");
        // z moves with x at rate 3 (given, not derived): dg/dx = −f' z − 3 f.
        let mut known = HashMap::default();
        let three = dag.constant(3.0);
        known.insert(z, three);
        let dg = dag.derivative(g, &mut known, &mut by_x);
        let expected = difference(&dag, g, [1.0, 0.0, 3.0]);
        assert!((value(&dag, dg, at) - expected).abs() <= 1e-8 * expected.abs(), "{expected}");
        // Along y only.
        let mut known = HashMap::default();
        let mut by_y = |dag: &mut Dag, atom: Atom| dag.constant(if atom == Atom::Q(1) { 1.0 } else { 0.0 });
        let dg = dag.derivative(g, &mut known, &mut by_y);
        let expected = difference(&dag, g, [0.0, 1.0, 0.0]);
        assert!((value(&dag, dg, at) - expected).abs() <= 1e-8 * expected.abs(), "{expected}");
    }

    #[test]
    fn products_share_a_pair_and_negated_outputs_share_a_negated_factor() {
        // k·s·a, −k·s·x, −(a·x + b·y) with every product built on its own.
        let mut dag = Dag::new();
        let [s, a, b, x, y] = [0, 1, 2, 3, 4].map(|j| dag.input(Atom::Q(j)));
        let k = dag.constant(0.25);
        let minus_k = dag.constant(-0.25);
        let sa = dag.mul(s, a);
        let first = dag.mul(k, sa);
        let sx = dag.mul(s, x);
        let second = dag.mul(minus_k, sx);
        let ax = dag.mul(a, x);
        let by = dag.mul(b, y);
        let sum = dag.add(ax, by);
        let third = dag.neg(sum);
        let roots = [first, second, third];
        // 2 + 2 + 3 + 1 (the negation).
        assert_eq!(cost(dag.count(&roots)), 8);
        let (plain, plain_roots, _) = dag.regrouped_products(&roots, false);
        let (sunk, sunk_roots, _) = dag.regrouped_products(&roots, true);
        // k·s once (1), k·s·a (1), k·s·x (1) now negated (1), the sum (3) and its negation (1).
        assert_eq!(cost(plain.count(&plain_roots)), 8);
        // `−(k s)·x` and `−(a x + b y)` share `−x`: 1 + 1 + 1 + 1 (−x) + 3.
        assert_eq!(cost(sunk.count(&sunk_roots)), 7);
        assert_eq!(sunk.count(&sunk_roots).negations, 1);
        let expected = values(&dag, &roots);
        for got in [values(&plain, &plain_roots), values(&sunk, &sunk_roots)] {
            for (g, e) in got.iter().zip(&expected) {
                assert!((g - e).abs() <= 1e-15 * e.abs().max(1.0), "{got:?} vs {expected:?}");
            }
        }
        // The optimiser keeps the cheapest.
        assert_eq!(cost(dag.optimised_count(&roots)), 7);
    }

    #[test]
    fn a_scaled_node_and_its_negation_are_one_product() {
        // J = −0.15·s (an output) and J̇q̇ = v·(0.15·s) + w: the product with 0.15 is J's, negated.
        let mut dag = Dag::new();
        let [s, v, w] = [0, 1, 2].map(|j| dag.input(Atom::Q(j)));
        let minus = dag.constant(-0.15);
        let plus = dag.constant(0.15);
        let j = dag.mul(minus, s);
        let scaled = dag.mul(plus, s);
        let product = dag.mul(v, scaled);
        let jdot = dag.add(product, w);
        let roots = [j, jdot];
        assert_eq!(cost(dag.count(&roots)), 4);
        let (out, out_roots, _) = dag.regrouped_products(&roots, false);
        // −0.15·s once; J̇q̇ = w − v·J.
        assert_eq!(cost(out.count(&out_roots)), 3);
        assert!(matches!(out.nodes()[out_roots[1]], Node::Sub(..)));
        let (got, expected) = (values(&out, &out_roots), values(&dag, &roots));
        for (g, e) in got.iter().zip(&expected) {
            assert!((g - e).abs() <= 1e-15 * e.abs().max(1.0));
        }
    }

    #[test]
    fn single_use_products_fuse_into_their_sums() {
        let mut dag = Dag::new();
        let [a, b, c, d] = [0, 1, 2, 3].map(|j| dag.input(Atom::Q(j)));
        let ab = dag.mul(a, b);
        let cd = dag.mul(c, d);
        // a·b − c·d: one multiplication and one fused multiply-subtract.
        let difference = dag.sub(ab, cd);
        // −(a·c + d), used once: a fused −a·c − d.
        let ac = dag.mul(a, c);
        let sum = dag.add(ac, d);
        let negated = dag.neg(sum);
        // −(b·d): one negated multiplication; c·c, used twice: not fused.
        let bd = dag.mul(b, d);
        let negated_product = dag.neg(bd);
        let cc = dag.mul(c, c);
        let shared = dag.add(cc, a);
        let shared_too = dag.sub(cc, b);
        let roots = [difference, negated, negated_product, shared, shared_too];
        let fusions = dag.fusions(&roots);
        assert_eq!(
            fusions[&difference],
            Fused::MulAdd { a, b, c: cd, negate_product: false, negate_addend: true }
        );
        assert_eq!(
            fusions[&negated],
            Fused::MulAdd { a, b: c, c: d, negate_product: true, negate_addend: true }
        );
        assert_eq!(fusions[&negated_product], Fused::NegMul { a: b, b: d });
        assert!(!fusions.contains_key(&shared) && !fusions.contains_key(&shared_too));
        let plain = dag.count(&roots);
        let fused = dag.count_fused(&roots);
        assert_eq!((plain.additions, plain.multiplications, plain.negations), (4, 5, 2));
        assert_eq!((fused.additions, fused.multiplications, fused.negations, fused.fused), (2, 3, 0, 2));
    }
}
