//! The generator's version, written into every generated header and every exported file.

/// The generator's version (the crate's), written into every generated header.
pub const VERSION: &str = env!("CARGO_PKG_VERSION");
