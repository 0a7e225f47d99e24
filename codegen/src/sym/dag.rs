//! Expression DAG with hash-consing: the optimised form of a set of polynomials.
//!
//! Each node is one arithmetic operation; identical subexpressions are one node, so common
//! subexpressions are shared across every output of a function (and across the functions
//! fused into one control tick). Polynomials enter through a greedy multivariate Horner
//! scheme ([`Dag::polynomial`]) that factors out the atom shared by most terms, and a common
//! coefficient where all terms have the same magnitude; constants are folded on the way.

use std::collections::{BTreeMap, HashMap};
use std::hash::{BuildHasherDefault, Hasher};

use super::poly::{Atom, Monomial, Poly};

/// A fast, non-cryptographic hasher for the hash-consing table (multiply–rotate over the
/// node's words, as rustc's FxHasher): nodes are small integers and float bits, and the table's
/// lookups dominate building large expressions, where SipHash cost a tenth of the time.
#[derive(Default)]
pub struct NodeHasher(u64);

impl Hasher for NodeHasher {
    fn finish(&self) -> u64 {
        self.0
    }

    fn write(&mut self, bytes: &[u8]) {
        for chunk in bytes.chunks(8) {
            let mut word = [0u8; 8];
            word[..chunk.len()].copy_from_slice(chunk);
            self.write_u64(u64::from_le_bytes(word));
        }
    }

    fn write_u64(&mut self, value: u64) {
        self.0 = (self.0.rotate_left(5) ^ value).wrapping_mul(0x51_7c_c1_b7_27_22_0a_95);
    }

    fn write_usize(&mut self, value: usize) {
        self.write_u64(value as u64);
    }

    fn write_u32(&mut self, value: u32) {
        self.write_u64(u64::from(value));
    }

    fn write_u16(&mut self, value: u16) {
        self.write_u64(u64::from(value));
    }

    fn write_u8(&mut self, value: u8) {
        self.write_u64(u64::from(value));
    }
}

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
}

impl OpCounts {
    /// Arithmetic operations (additions, multiplications, divisions, square roots, negations).
    pub fn arithmetic(&self) -> usize {
        self.additions + self.multiplications + self.divisions + self.square_roots + self.negations
    }
}

/// A hash-consed expression DAG.
#[derive(Clone, Debug, Default)]
pub struct Dag {
    nodes: Vec<Node>,
    index: HashMap<Node, NodeId, BuildHasherDefault<NodeHasher>>,
    /// Linear combinations built by [`Dag::merged_sums`], keyed by their terms with the
    /// coefficients divided by the first one: a later combination proportional to an earlier
    /// one is one multiplication of it.
    linear_index: HashMap<Vec<(NodeId, i64)>, (NodeId, f64)>,
    /// Atoms that stand for nodes built from other inputs (a closed chain's passive
    /// coordinates, see `crate::closure`): [`Dag::input`] returns the node instead.
    substitutions: HashMap<Atom, NodeId>,
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

    /// Operation counts of `roots` in the cheapest form [`Dag::optimised`] finds.
    pub fn optimised_count(&self, roots: &[NodeId]) -> OpCounts {
        match self.optimised(roots) {
            Some((dag, new_roots, _)) => dag.count(&new_roots),
            None => self.count(roots),
        }
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
        let mut linear: HashMap<NodeId, Linear> = HashMap::new();
        let mut built: HashMap<NodeId, NodeId> = HashMap::new();
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
        let mut map: HashMap<NodeId, NodeId> = HashMap::with_capacity(order.len());
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

    /// The cheapest of the DAG as built, after [`Dag::merged_sums`], and after that and
    /// [`Dag::pushed_negations`] (arithmetic plus trigonometric operations), with the map from
    /// old node ids to new ones (`None`: unchanged).
    pub fn optimised(&self, roots: &[NodeId]) -> Option<(Dag, Vec<NodeId>, HashMap<NodeId, NodeId>)> {
        let cost = |dag: &Dag, roots: &[NodeId]| {
            let c = dag.count(roots);
            c.arithmetic() + c.trigonometric
        };
        let original = cost(self, roots);
        let (merged, merged_roots, merged_map) = self.merged_sums(roots);
        let (pushed, pushed_roots, pushed_map) = merged.pushed_negations(&merged_roots);
        let composed: HashMap<NodeId, NodeId> =
            merged_map.iter().filter_map(|(old, mid)| Some((*old, *pushed_map.get(mid)?))).collect();
        let mut candidates =
            vec![(merged_roots.clone(), merged, merged_map), (pushed_roots, pushed, composed)];
        // Signs chosen on top of either (see `crate::sym::signs`).
        for k in 0..2 {
            let (roots, dag, map) = &candidates[k];
            let (signed, signed_roots, signed_map) = dag.negations_after_signs(roots);
            let composed = map.iter().filter_map(|(old, mid)| Some((*old, *signed_map.get(mid)?))).collect();
            candidates.push((signed_roots, signed, composed));
        }
        let best = candidates.into_iter().map(|(r, d, m)| (cost(&d, &r), d, r, m)).min_by_key(|c| c.0)?;
        (best.0 < original).then_some((best.1, best.2, best.3))
    }
}
