//! Small linear algebra and rotations, once for the whole generator: 3 × 3 and small dynamic
//! matrices over numbers, polynomials or expression-DAG nodes ([`matrix`]), rotation matrices
//! from axes and roll–pitch–yaw angles ([`rotation`]), and eigenvalues of symmetric matrices
//! ([`eigen`]). The lowest layer: it depends on nothing else of the crate.

pub mod eigen;
pub mod matrix;
pub mod rotation;
