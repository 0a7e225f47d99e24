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

    fn intern(&mut self, node: Node) -> NodeId {
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
            _ => {
                let (lo, hi) = if a <= b { (a, b) } else { (b, a) };
                self.intern(Node::Add(lo, hi))
            }
        }
    }

    /// `a − b`, folded.
    pub fn sub(&mut self, a: NodeId, b: NodeId) -> NodeId {
        match (self.constant_value(a), self.constant_value(b)) {
            (Some(x), Some(y)) => self.constant(x - y),
            (_, Some(0.0)) => a,
            (Some(0.0), _) => self.neg(b),
            _ => self.intern(Node::Sub(a, b)),
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
            _ => {
                let (lo, hi) = if a <= b { (a, b) } else { (b, a) };
                self.intern(Node::Mul(lo, hi))
            }
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
