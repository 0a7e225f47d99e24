//! The CLI's and the simulator's tests as one test binary: each file of this folder is a module
//! of it, so the simulator, the plotting libraries and the generated rigs are linked once
//! rather than once per file. `cargo test -p hapticgen --test host MODULE::` runs one file's
//! tests, e.g. `faults::`.

mod check;
mod cli;
mod consistent;
mod current_gains;
mod design;
mod faults;
mod identify;
mod paper;
mod replay;
mod silent;
mod zwidth;
