//! Sign choice: which nodes of an expression DAG to compute negated, so that as few negations
//! as possible remain (an optimisation pass behind [`Dag::optimised`]).
//!
//! Every intermediate value `x` can be computed as `x` or as `−x` at no cost when its operands'
//! signs allow it: `a + b` gives `−(a + b)` free as `(−b) − a` if one operand is at hand
//! negated, a product's sign is the product of its factors' signs, a constant takes any sign.
//! A negation is needed only where an operation cannot give the sign its users want, and at
//! an output held negated. [`Dag::negations_after_signs`] chooses the signs by local search
//! from "everything as written": greedy descent (flip a node's sign, alone or together with
//! the products it feeds, while that removes negations), then a random walk with a fixed seed
//! (reproducible output) that may cross plateaus and step up by one to leave a local minimum,
//! keeping the best signs seen, so it never adds a negation. Negations are exact in floating
//! point, so the values do not change by a single bit. Where
//! [`Dag::pushed_negations`] absorbs a negation into a value used once, this also moves signs
//! through shared values: e.g. in the parallel link's `C q̇` and `J̇ q̇`, both of which need
//! `−q̇₁²`, or in a Jacobian whose entries come out as `−(cos q₁ · x)` and `−(sin q₁ · x)`.

use rustc_hash::FxHashMap as HashMap;

use super::dag::{Dag, Node, NodeId};

/// The result of [`Dag::negations_after_signs`].
pub struct Signed {
    /// The rebuilt DAG.
    pub dag: Dag,
    /// The new roots (the same values as the old).
    pub roots: Vec<NodeId>,
    /// Old node → new node with the same value.
    pub kept: HashMap<NodeId, NodeId>,
    /// Old node → new node holding its negation.
    pub negated: HashMap<NodeId, NodeId>,
}

/// The most nodes one move flips together.
const MAX_GROUP: usize = 8;

/// `+1` or `−1`: the sign a node is computed with.
type Sign = i8;

impl Dag {
    /// Rebuilds the nodes needed for `roots` with signs chosen to minimise negations (see the
    /// module documentation). Returns the new DAG, the new roots, for every node kept with its
    /// sign its new id, and for every node now held negated the new id of its negation.
    pub fn negations_after_signs(&self, roots: &[NodeId]) -> Signed {
        let order = self.reachable(roots);
        let search = Search::new(self, &order, roots);
        let chosen = search.run();
        let sign: HashMap<NodeId, Sign> = order.iter().zip(&chosen).map(|(&id, &s)| (id, s)).collect();
        self.rebuilt_with_signs(&order, roots, &sign)
    }

    /// `a ∘ b` interned as is (the folding constructors would move the chosen signs again),
    /// with commutative operands in canonical order.
    fn raw(&mut self, node: Node) -> NodeId {
        let node = match node {
            Node::Add(a, b) if a > b => Node::Add(b, a),
            Node::Mul(a, b) if a > b => Node::Mul(b, a),
            other => other,
        };
        self.intern(node)
    }

    /// `−x` with the free cases folded: a constant, a negation, a difference used for this.
    fn negated(&mut self, x: NodeId) -> NodeId {
        match self.nodes()[x] {
            Node::Const(bits) => self.constant(-f64::from_bits(bits)),
            Node::Neg(inner) => inner,
            _ => self.raw(Node::Neg(x)),
        }
    }

    fn rebuilt_with_signs(&self, order: &[NodeId], roots: &[NodeId], sign: &HashMap<NodeId, Sign>) -> Signed {
        let nodes = self.nodes();
        let mut out = Dag::new();
        // The new id holding `sign[id] · value(id)`.
        let mut held: HashMap<NodeId, NodeId> =
            HashMap::with_capacity_and_hasher(order.len(), Default::default());
        for &id in order {
            let s = sign[&id];
            // An operand as held, with its sign; a constant comes with the sign `want`.
            let operand =
                |out: &mut Dag, held: &HashMap<NodeId, NodeId>, x: NodeId, want: Sign| match nodes[x] {
                    Node::Const(bits) => (out.constant(f64::from(want) * f64::from_bits(bits)), want),
                    _ => (held[&x], sign[&x]),
                };
            let fix =
                |out: &mut Dag, value: NodeId, got: Sign| if got == s { value } else { out.negated(value) };
            let new = match nodes[id] {
                Node::Const(bits) => out.constant(f64::from(s) * f64::from_bits(bits)),
                Node::Input(atom) => {
                    let x = out.input(atom);
                    fix(&mut out, x, 1)
                }
                Node::Neg(a) => {
                    let (x, sa) = operand(&mut out, &held, a, -s);
                    fix(&mut out, x, -sa)
                }
                Node::Add(a, b) | Node::Sub(a, b) => {
                    // s · (a ± b) from x = sa·a and y = sb·b.
                    let sign_b = if matches!(nodes[id], Node::Sub(..)) { -1 } else { 1 };
                    let (x, sa) = operand(&mut out, &held, a, s);
                    let (y, sb) = operand(&mut out, &held, b, s * sign_b);
                    // Signs relative to the wanted terms s·a and s·(±b).
                    let (ra, rb) = (sa * s, sb * s * sign_b);
                    match (ra, rb) {
                        (1, 1) => out.raw(Node::Add(x, y)),
                        (1, _) => out.raw(Node::Sub(x, y)),
                        (_, 1) => out.raw(Node::Sub(y, x)),
                        _ => {
                            let sum = out.raw(Node::Add(x, y));
                            out.negated(sum)
                        }
                    }
                }
                Node::Mul(a, b) | Node::Div(a, b) => {
                    let divide = matches!(nodes[id], Node::Div(..));
                    let (x, y, got) = match (nodes[a], nodes[b]) {
                        (Node::Const(_), _) => {
                            let sb = sign[&b];
                            let (x, _) = operand(&mut out, &held, a, s * sb);
                            (x, held[&b], s)
                        }
                        (_, Node::Const(_)) => {
                            let sa = sign[&a];
                            let (y, _) = operand(&mut out, &held, b, s * sa);
                            (held[&a], y, s)
                        }
                        _ => (held[&a], held[&b], sign[&a] * sign[&b]),
                    };
                    let value = out.raw(if divide { Node::Div(x, y) } else { Node::Mul(x, y) });
                    fix(&mut out, value, got)
                }
                Node::Sqrt(a) => {
                    let x = held[&a];
                    let x = if sign[&a] < 0 { out.negated(x) } else { x };
                    out.raw(Node::Sqrt(x))
                }
            };
            held.insert(id, new);
        }
        let new_roots =
            roots.iter().map(|r| if sign[r] < 0 { out.negated(held[r]) } else { held[r] }).collect();
        let (kept, negated) = held.into_iter().partition(|(old, _)| sign[old] > 0);
        Signed { dag: out, roots: new_roots, kept, negated }
    }
}

/// What the sign of one node costs, in terms of its operands (dense indices into the search's
/// node order); constants take any sign and are left out.
#[derive(Clone, Copy)]
enum Rule {
    /// Never costs a negation (a constant, or an operation with a constant operand).
    Free,
    /// An input: a negation if computed negated.
    Input,
    /// `−a`: free when `a` is held with the opposite sign.
    Neg(usize),
    /// `a + b` (`flip_b`: `a − b`): a negation only if both are held with the wrong sign.
    Sum(usize, usize, bool),
    /// `a · b` or `a / b`: the signs multiply.
    Product(usize, usize),
    /// `√a`: needs `a` held positive.
    Sqrt(usize),
}

/// The local search over signs, on dense indices (one per reachable node, children first).
struct Search {
    rules: Vec<Rule>,
    is_root: Vec<bool>,
    flippable: Vec<bool>,
    /// Each node's two moves (flip itself; flip itself and the products it feeds,
    /// transitively), as ranges of `arena`: the group flipped and the nodes whose cost the
    /// move can change. One arena instead of four vectors a node: building the moves was the
    /// search's largest cost.
    moves: Vec<[Move; 2]>,
    arena: Vec<usize>,
}

/// One move of [`Search`]: where its group and the nodes around it lie in the arena.
#[derive(Clone, Copy)]
struct Move {
    group: (usize, usize),
    around: (usize, usize),
}

impl Search {
    fn new(dag: &Dag, order: &[NodeId], roots: &[NodeId]) -> Self {
        let nodes = dag.nodes();
        // Dense index of each reachable node (node ids index the DAG's node list).
        let mut index = vec![usize::MAX; nodes.len()];
        for (i, &id) in order.iter().enumerate() {
            index[id] = i;
        }
        let is_const = |x: NodeId| matches!(nodes[x], Node::Const(_));
        let rules: Vec<Rule> = order
            .iter()
            .map(|&id| match nodes[id] {
                Node::Const(_) => Rule::Free,
                Node::Input(_) => Rule::Input,
                Node::Neg(a) if is_const(a) => Rule::Free,
                Node::Neg(a) => Rule::Neg(index[a]),
                Node::Add(a, b) | Node::Sub(a, b) | Node::Mul(a, b) | Node::Div(a, b)
                    if is_const(a) || is_const(b) =>
                {
                    Rule::Free
                }
                Node::Add(a, b) => Rule::Sum(index[a], index[b], false),
                Node::Sub(a, b) => Rule::Sum(index[a], index[b], true),
                Node::Mul(a, b) | Node::Div(a, b) => Rule::Product(index[a], index[b]),
                Node::Sqrt(a) => Rule::Sqrt(index[a]),
            })
            .collect();
        let mut parents: Vec<Vec<usize>> = vec![Vec::new(); order.len()];
        for (i, &id) in order.iter().enumerate() {
            let (children, count) = match nodes[id] {
                Node::Add(a, b) | Node::Sub(a, b) | Node::Mul(a, b) | Node::Div(a, b) => ([a, b], 2),
                Node::Neg(a) | Node::Sqrt(a) => ([a, a], 1),
                Node::Const(_) | Node::Input(_) => ([0, 0], 0),
            };
            for &c in &children[..count] {
                let c = index[c];
                if !parents[c].contains(&i) {
                    parents[c].push(i);
                }
            }
        }
        let mut is_root = vec![false; order.len()];
        for &r in roots {
            is_root[index[r]] = true;
        }
        let flippable: Vec<bool> =
            order.iter().map(|&id| !matches!(nodes[id], Node::Const(_) | Node::Sqrt(_))).collect();
        let is_product = |i: usize| matches!(nodes[order[i]], Node::Mul(..) | Node::Div(..));
        let mut arena: Vec<usize> = Vec::with_capacity(8 * order.len());
        let mut around: Vec<usize> = Vec::new();
        // Appends a group and the nodes around it (the group and its parents, each once).
        let mut push_move = |arena: &mut Vec<usize>, group: &[usize]| {
            around.clear();
            around.extend_from_slice(group);
            for &g in group {
                around.extend_from_slice(&parents[g]);
            }
            around.sort_unstable();
            around.dedup();
            let group_start = arena.len();
            arena.extend_from_slice(group);
            let around_start = arena.len();
            arena.extend_from_slice(&around);
            Move { group: (group_start, around_start), around: (around_start, arena.len()) }
        };
        let mut group: Vec<usize> = Vec::with_capacity(MAX_GROUP);
        let moves = (0..order.len())
            .map(|i| {
                group.clear();
                group.push(i);
                let mut k = 0;
                // Small groups only: a sign that would travel through a long chain of products
                // is better left to the walk, step by step (and keeps each move cheap).
                while k < group.len() && group.len() < MAX_GROUP {
                    for &p in &parents[group[k]] {
                        if is_product(p) && !group.contains(&p) {
                            group.push(p);
                        }
                    }
                    k += 1;
                }
                let single = push_move(&mut arena, &[i]);
                let grouped = push_move(&mut arena, &group);
                [single, grouped]
            })
            .collect();
        Self { rules, is_root, flippable, moves, arena }
    }

    /// A move's group and the nodes around it.
    fn parts(&self, m: Move) -> (&[usize], &[usize]) {
        (&self.arena[m.group.0..m.group.1], &self.arena[m.around.0..m.around.1])
    }

    /// Negations node `i` needs with the signs `sign` (its own and, at an output held
    /// negated, one more).
    fn cost(&self, sign: &[Sign], i: usize) -> usize {
        let s = sign[i];
        let own = match self.rules[i] {
            Rule::Free => false,
            Rule::Input => s < 0,
            Rule::Neg(a) => sign[a] != -s,
            Rule::Sum(a, b, flip_b) => {
                let sb = if flip_b { -sign[b] } else { sign[b] };
                sign[a] == sb && sign[a] != s
            }
            Rule::Product(a, b) => sign[a] * sign[b] != s,
            Rule::Sqrt(a) => sign[a] < 0,
        };
        usize::from(own) + usize::from(self.is_root[i] && s < 0)
    }

    /// Greedy descent, then a seeded random walk; the best signs seen.
    fn run(&self) -> Vec<Sign> {
        let n = self.rules.len();
        let mut sign: Vec<Sign> = vec![1; n];
        let candidates: Vec<usize> = (0..n).filter(|&i| self.flippable[i]).collect();
        // One move: flip a group; returns the change in negations (applied).
        let apply = |sign: &mut Vec<Sign>, group: &[usize], around: &[usize]| -> isize {
            let before: usize = around.iter().map(|&k| self.cost(sign, k)).sum();
            for &g in group {
                sign[g] = -sign[g];
            }
            let after: usize = around.iter().map(|&k| self.cost(sign, k)).sum();
            after as isize - before as isize
        };
        let undo = |sign: &mut Vec<Sign>, group: &[usize]| {
            for &g in group {
                sign[g] = -sign[g];
            }
        };
        // Flip a node's sign, alone or with the products it feeds, while that removes
        // negations (a strict decrease each time, so it ends).
        loop {
            let mut improved = false;
            for &i in &candidates {
                for &m in &self.moves[i] {
                    let (group, around) = self.parts(m);
                    if apply(&mut sign, group, around) < 0 {
                        improved = true;
                        break;
                    }
                    undo(&mut sign, group);
                }
            }
            if !improved {
                break;
            }
        }
        // Then a random walk (a fixed seed: the output is reproducible) that also takes moves
        // that keep the count and, now and then, one that raises it by one, to leave a local
        // minimum; the best signs seen are kept.
        let mut total: isize = (0..n).map(|k| self.cost(&sign, k) as isize).sum();
        let (mut best, mut best_total) = (sign.clone(), total);
        let mut state: u64 = 0x9e37_79b9_7f4a_7c15;
        let steps = if best_total == 0 { 0 } else { (40 * candidates.len()).min(20_000) };
        for _ in 0..steps {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            let i = candidates[(state % candidates.len() as u64) as usize];
            let (group, around) = self.parts(self.moves[i][usize::from(state & (1 << 40) != 0)]);
            let delta = apply(&mut sign, group, around);
            if delta <= 0 || (delta == 1 && (state >> 48) & 15 == 0) {
                total += delta;
                if total < best_total {
                    best_total = total;
                    best.clone_from(&sign);
                    if best_total == 0 {
                        break;
                    }
                }
            } else {
                undo(&mut sign, group);
            }
        }
        best
    }
}
