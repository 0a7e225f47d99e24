//! Flat evaluation tapes for the symbolic mechanics of any model file.
//!
//! The simulator needs the rigid-body terms of the paper's eq. (1)–(2) (`D(q)`, `C(q, q̇) q̇`,
//! `g(q)`, `p(q)`, `J(q)`, `J̇ q̇`) for model files that were not compiled into the binary, and
//! for perturbed copies of the shipped ones (a plant whose masses differ from the
//! controller's model). The polynomials of `hapticgen_codegen::derive` are lowered
//! once, at load time, into the same hash-consed expression DAG the code generator uses
//! (`hapticgen_codegen::sym::dag::Dag`, with its Horner factoring and common-subexpression
//! elimination), and the nodes reachable from the requested outputs are flattened into a
//! register tape: constants and inputs are registers filled before the run, every other node
//! is one `Add`/`Sub`/`Mul`/`Div`/`Neg`/`Sqrt` instruction writing its own register. Evaluating a tape is a
//! single pass over a `Vec<f64>`, with one `sin`/`cos` per joint.

use hapticgen_codegen::dynamics::closure::Closures;
use hapticgen_codegen::dynamics::spatial_loops::SpatialLoops;
use hapticgen_codegen::sym::dag::{Dag, Node, NodeId};
use hapticgen_codegen::sym::poly::{Atom, Poly};

/// One instruction: destination register, operands.
#[derive(Clone, Copy, Debug)]
enum Op {
    Add(u32, u32, u32),
    Sub(u32, u32, u32),
    Mul(u32, u32, u32),
    Div(u32, u32, u32),
    Neg(u32, u32),
    Sqrt(u32, u32),
}

/// Where an input register takes its value from.
#[derive(Clone, Copy, Debug)]
enum Source {
    Sin(usize),
    Cos(usize),
    Q(usize),
    Qd(usize),
    /// A joint acceleration (only tapes evaluated with [`Tape::eval_with_accelerations`]).
    Qdd(usize),
    Param(usize),
    /// A spatial closed chain's loop value (a passive coordinate's sine, cosine, angle or
    /// rate, or an entry of `A` or `Ȧ`): entry `k` of `SpatialLoops::atoms`.
    Loop(usize),
    /// An atom the mechanics never contains (inputs of fused control laws): zero.
    Zero,
}

/// A spatial closed chain's loops, solved before each evaluation (warm-started from the
/// previous one's passive coordinates, kept in the scratch registers after the tape's own).
#[derive(Clone, Debug)]
struct TapeLoops {
    loops: SpatialLoops,
    /// The first scratch register of the previous solution.
    guess_register: usize,
}

/// A compiled list of outputs over the inputs `sin q_j`, `cos q_j`, `q_j`, `q̇_j` and the
/// model's tunable parameters.
#[derive(Clone, Debug)]
pub struct Tape {
    /// Initial register file: constants in place, zeros elsewhere.
    registers: Vec<f64>,
    inputs: Vec<(u32, Source)>,
    ops: Vec<Op>,
    outputs: Vec<u32>,
    joints: usize,
    loops: Option<TapeLoops>,
}

impl Tape {
    /// Compiles `outputs` (polynomials of one model with `joints` joints).
    pub fn compile(outputs: &[&Poly], joints: usize) -> Tape {
        Tape::compile_closed(outputs, joints, None)
    }

    /// Compiles `outputs` of a model whose closed chains `closures` eliminates (the
    /// elimination's nodes are computed on the tape in front of the outputs).
    pub fn compile_closed(outputs: &[&Poly], joints: usize, closures: Option<&Closures>) -> Tape {
        Tape::compile_built(joints, closures, |dag| outputs.iter().map(|p| dag.polynomial(p)).collect())
    }

    /// Compiles the nodes that `build` adds to a DAG in which a closed chain's elimination
    /// (`closures`) is installed, e.g. the identification regressor's
    /// (`Regressor::build`), whose outputs are nodes rather than polynomials.
    pub fn compile_built(
        joints: usize,
        closures: Option<&Closures>,
        build: impl FnOnce(&mut Dag) -> Vec<NodeId>,
    ) -> Tape {
        let mut dag = Dag::new();
        hapticgen_codegen::dynamics::closure::install(&mut dag, closures);
        // Spatial loops in closed form (a Delta) are nodes of the tape like a planar loop's;
        // any other spatial chain's are solved by Newton's method before each evaluation.
        let spatial = closures.and_then(|c| c.solved_at_run_time());
        // A spatial chain's loop values are numbered after the planar loops' (it has none).
        let loop_atoms = spatial.map(|s| s.atoms(0)).unwrap_or_default();
        let roots = build(&mut dag);
        let reachable = dag.reachable(&roots);
        let mut register_of = vec![u32::MAX; dag.nodes().len()];
        let mut registers = Vec::with_capacity(reachable.len());
        let mut inputs = Vec::new();
        let mut ops = Vec::new();
        for (slot, &id) in reachable.iter().enumerate() {
            let slot = slot as u32;
            register_of[id] = slot;
            let r = |x: NodeId| register_of[x];
            match dag.nodes()[id] {
                Node::Const(bits) => registers.push(f64::from_bits(bits)),
                Node::Input(atom) => {
                    registers.push(0.0);
                    let source = match atom {
                        _ if loop_atoms.contains(&atom) => {
                            Source::Loop(loop_atoms.iter().position(|&a| a == atom).unwrap_or_default())
                        }
                        Atom::Sin(j) => Source::Sin(usize::from(j)),
                        Atom::Cos(j) => Source::Cos(usize::from(j)),
                        Atom::Q(j) => Source::Q(usize::from(j)),
                        Atom::Qd(j) => Source::Qd(usize::from(j)),
                        Atom::Qdd(j) => Source::Qdd(usize::from(j)),
                        Atom::Param(k) => Source::Param(usize::from(k)),
                        Atom::External(_) | Atom::Closure(_) => Source::Zero,
                    };
                    inputs.push((slot, source));
                }
                Node::Add(a, b) => {
                    registers.push(0.0);
                    ops.push(Op::Add(slot, r(a), r(b)));
                }
                Node::Sub(a, b) => {
                    registers.push(0.0);
                    ops.push(Op::Sub(slot, r(a), r(b)));
                }
                Node::Mul(a, b) => {
                    registers.push(0.0);
                    ops.push(Op::Mul(slot, r(a), r(b)));
                }
                Node::Div(a, b) => {
                    registers.push(0.0);
                    ops.push(Op::Div(slot, r(a), r(b)));
                }
                Node::Neg(a) => {
                    registers.push(0.0);
                    ops.push(Op::Neg(slot, r(a)));
                }
                Node::Sqrt(a) => {
                    registers.push(0.0);
                    ops.push(Op::Sqrt(slot, r(a)));
                }
            }
        }
        let outputs = roots.iter().map(|&id| register_of[id]).collect();
        let loops = spatial.map(|loops| {
            let guess_register = registers.len();
            registers.extend(&loops.assembly);
            TapeLoops { loops: loops.clone(), guess_register }
        });
        Tape { registers, inputs, ops, outputs, joints, loops }
    }

    /// Number of outputs.
    pub fn len(&self) -> usize {
        self.outputs.len()
    }

    /// `true` when the tape has no outputs.
    pub fn is_empty(&self) -> bool {
        self.outputs.is_empty()
    }

    /// Number of arithmetic instructions.
    pub fn instructions(&self) -> usize {
        self.ops.len()
    }

    /// A register file to evaluate this tape with (reuse it across calls).
    pub fn scratch(&self) -> Vec<f64> {
        self.registers.clone()
    }

    /// Evaluates every output at `(q, q̇)` into `out` (`out.len() == self.len()`); `scratch`
    /// must come from [`Tape::scratch`] of this tape. Missing inputs read as zero.
    pub fn eval(&self, scratch: &mut [f64], q: &[f64], qd: &[f64], parameters: &[f64], out: &mut [f64]) {
        self.eval_with_accelerations(scratch, q, qd, &[], parameters, out);
    }

    /// [`Tape::eval`] with the joint accelerations `q̈` as inputs too (missing ones read as
    /// zero, as in [`Tape::eval`]).
    pub fn eval_with_accelerations(
        &self,
        scratch: &mut [f64],
        q: &[f64],
        qd: &[f64],
        qdd: &[f64],
        parameters: &[f64],
        out: &mut [f64],
    ) {
        let mut trig = [(0.0_f64, 1.0_f64); 8];
        let mut trig_heap = Vec::new();
        let trig: &mut [(f64, f64)] = if self.joints <= trig.len() {
            &mut trig[..self.joints]
        } else {
            trig_heap.resize(self.joints, (0.0, 1.0));
            &mut trig_heap
        };
        for (j, slot) in trig.iter_mut().enumerate() {
            *slot = q.get(j).copied().unwrap_or(0.0).sin_cos();
        }
        let get = |v: &[f64], i: usize| v.get(i).copied().unwrap_or(0.0);
        let mut loop_values = Vec::new();
        if let Some(TapeLoops { loops, guess_register }) = &self.loops {
            let guess_range = *guess_register..guess_register + loops.passive;
            let (values, passive) = loops.values_from(q, qd, parameters, Some(&scratch[guess_range.clone()]));
            if let Some(passive) = passive {
                scratch[guess_range].copy_from_slice(&passive);
            }
            loop_values = values;
        }
        for &(slot, source) in &self.inputs {
            scratch[slot as usize] = match source {
                Source::Sin(j) => trig.get(j).map_or(0.0, |t| t.0),
                Source::Cos(j) => trig.get(j).map_or(1.0, |t| t.1),
                Source::Q(j) => get(q, j),
                Source::Qd(j) => get(qd, j),
                Source::Qdd(j) => get(qdd, j),
                Source::Param(k) => get(parameters, k),
                Source::Loop(k) => get(&loop_values, k),
                Source::Zero => 0.0,
            };
        }
        for op in &self.ops {
            match *op {
                Op::Add(d, a, b) => scratch[d as usize] = scratch[a as usize] + scratch[b as usize],
                Op::Sub(d, a, b) => scratch[d as usize] = scratch[a as usize] - scratch[b as usize],
                Op::Mul(d, a, b) => scratch[d as usize] = scratch[a as usize] * scratch[b as usize],
                Op::Div(d, a, b) => scratch[d as usize] = scratch[a as usize] / scratch[b as usize],
                Op::Neg(d, a) => scratch[d as usize] = -scratch[a as usize],
                Op::Sqrt(d, a) => scratch[d as usize] = scratch[a as usize].sqrt(),
            }
        }
        for (slot, &register) in out.iter_mut().zip(&self.outputs) {
            *slot = scratch[register as usize];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tape_matches_direct_polynomial_evaluation() {
        // p = 2 sin q0 cos q1 − q̇0² + 0.5, r = −p · cos q1
        let s0 = Poly::atom(Atom::Sin(0));
        let c1 = Poly::atom(Atom::Cos(1));
        let qd0 = Poly::atom(Atom::Qd(0));
        let p = s0.mul(&c1).scale(2.0).sub(&qd0.mul(&qd0)).add(&Poly::constant(0.5));
        let r = p.mul(&c1).scale(-1.0);
        let tape = Tape::compile(&[&p, &r], 2);
        let mut scratch = tape.scratch();
        let mut out = [0.0; 2];
        let (q, qd) = ([0.3, -1.1], [0.7, 2.0]);
        tape.eval(&mut scratch, &q, &qd, &[], &mut out);
        let expected = 2.0 * q[0].sin() * q[1].cos() - qd[0] * qd[0] + 0.5;
        assert!((out[0] - expected).abs() < 1e-12, "{} vs {expected}", out[0]);
        assert!((out[1] + expected * q[1].cos()).abs() < 1e-12);
    }

    #[test]
    fn closed_chain_tapes_match_the_evaluator() {
        use hapticgen_codegen::eval::{evaluate, State};
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
        for (file, variant, numerical) in [
            ("models/pantograph_5bar.yaml", Some("vertical"), false),
            ("codegen/tests/good-models/five_bar_2dof.yaml", None, false),
            // Spatial, in closed form on the tape (the evaluator solves it by Newton's method:
            // two computations, so to 1e-10, not to the last digits).
            ("models/falcon_delta.yaml", None, false),
            // Spatial, solved by Newton's method on each evaluation, warm-started from the
            // previous (what any spatial chain without a closed form gets).
            ("models/falcon_delta.yaml", None, true),
        ] {
            let tolerance = if file.contains("falcon") && !numerical { 1e-10 } else { 1e-12 };
            let model = hapticgen_codegen::load_file(&root.join(file), file, variant)
                .unwrap_or_else(|e| panic!("{e}"));
            let model = if numerical { model.with_loops_solved_numerically() } else { model };
            let mech = hapticgen_codegen::derive(&model);
            let mut outputs: Vec<&Poly> = mech.inertia_matrix.iter().flatten().collect();
            outputs.extend(&mech.coriolis_times_qdot);
            outputs.extend(&mech.gravity);
            outputs.extend(&mech.task.position);
            outputs.extend(mech.task.jacobian.iter().flatten());
            outputs.extend(&mech.task.jacobian_dot_times_qdot);
            let tape = Tape::compile_closed(&outputs, mech.joints, mech.closures.as_ref());
            let parameters = model.nominal_parameters();
            let mut scratch = tape.scratch();
            let mut out = vec![0.0; tape.len()];
            for (i, j) in [(0.2, 0.7), (0.5, 0.5), (0.9, 0.1)] {
                let q: Vec<f64> = model
                    .joints
                    .iter()
                    .zip([i, j, 0.5 * (i + j)])
                    .map(|(jt, t)| jt.lower + t * (jt.upper - jt.lower))
                    .collect();
                let qd = &[0.4, -0.9, 0.3][..q.len()];
                tape.eval(&mut scratch, &q, qd, &parameters, &mut out);
                let e = evaluate(&mech, &State { q: &q, qd, parameters: &parameters }, None);
                let mut want: Vec<f64> = e.inertia_matrix.concat();
                want.extend(&e.coriolis_times_qdot);
                want.extend(&e.g);
                want.extend(&e.p);
                want.extend(e.jacobian.concat());
                want.extend(&e.jacobian_dot_times_qdot);
                for (k, (a, b)) in out.iter().zip(&want).enumerate() {
                    assert!((a - b).abs() <= tolerance * b.abs().max(1e-3), "{file} output {k}: {a} vs {b}");
                }
            }
        }
    }
}
