//! Small linear algebra and rotations, once for the whole generator: 3 × 3 and small dynamic
//! matrices over numbers, polynomials or expression-DAG nodes ([`matrix`]), rotation matrices
//! from axes and roll–pitch–yaw angles ([`rotation`]), eigenvalues of symmetric matrices
//! ([`eigen`]), and a pivoted linear solve and rank test for numerical analyses ([`dense`]). The lowest layer: it depends on nothing else of the crate.

pub mod dense;
pub mod eigen;
pub mod matrix;
pub mod rotation;
