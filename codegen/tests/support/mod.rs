//! Helpers shared by the closed-chain tests (a module of each test crate that declares it,
//! not a test of its own).

use hapticgen_codegen::sym::poly::{Atom, AtomValues};

/// The open tree's coordinates at rest, as polynomial atoms: `q_j`, `sin q_j`, `cos q_j`, and
/// zero for everything else (velocities, loop values); enough to evaluate a loop's residual.
pub struct TreePositions<'a>(pub &'a [f64]);

impl AtomValues for TreePositions<'_> {
    fn value(&self, atom: Atom) -> f64 {
        match atom {
            Atom::Sin(j) => self.0[usize::from(j)].sin(),
            Atom::Cos(j) => self.0[usize::from(j)].cos(),
            Atom::Q(j) => self.0[usize::from(j)],
            _ => 0.0,
        }
    }
}
