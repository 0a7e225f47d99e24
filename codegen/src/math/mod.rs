//! Small linear algebra and rotations, once for the whole generator: 3 × 3 and small dynamic
//! matrices over numbers, polynomials or expression-DAG nodes ([`matrix`]), rotation matrices
//! from axes and roll–pitch–yaw angles ([`rotation`]), eigenvalues of symmetric matrices
//! ([`eigen`]), a pivoted linear solve and rank test for numerical analyses ([`dense`]), the
//! small operations on 3-vectors (dot and cross products, difference, multiple, length:
//! [`vector`]), and the regular grid over a box of joint coordinates that every sampling
//! analysis shares ([`grid`]). The lowest layer: it depends on nothing else of the crate.

pub mod dense;
pub mod eigen;
pub mod grid;
pub mod matrix;
pub mod rotation;
pub mod vector;
