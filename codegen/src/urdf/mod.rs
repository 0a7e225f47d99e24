//! URDF: export of serial models and of a closed chain's open tree (for Pinocchio and other
//! tools) and import of URDF robots as model files.

mod export;
mod import;

pub use crate::math::rotation::rpy_of;
pub use export::{export, export_open_tree, frame_link_name, point_link_name, CutClosure, OpenTree};
pub use import::{import, DEFAULT_DRIVE};
