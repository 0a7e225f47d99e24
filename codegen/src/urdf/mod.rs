//! URDF: export of serial models (for Pinocchio and other tools) and import of URDF robots as
//! model files.

mod export;
mod import;

pub use crate::math::rotation::rpy_of;
pub use export::{export, frame_link_name, point_link_name};
pub use import::{import, DEFAULT_DRIVE};
