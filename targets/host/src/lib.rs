//! The host side of hapticgen: a simulator of any rig model in closed loop with the runtime's
//! controllers, the paper's experiments, and the plots and report that reproduce them.
//!
//! Layers, from the bottom: [`tape`] (the symbolic mechanics of eq. (1)–(2) compiled into flat
//! evaluation tapes), [`rig`] (any model as a `RigModel`), [`generated`] (the shipped models'
//! generated code), [`plant`] (the simulated device: rigid bodies, motors, friction, backlash,
//! sensors), [`closed_loop`] (the closed loop of Fig. 1 with an operator), [`simulation`] (scenarios
//! and dispatch), [`analysis`] (fits of the responses), [`plot`] and [`output`] (figures;
//! CSV with its columns' sidecar; printed numbers without negative zeros) and [`paper`] (the
//! experiments of section 6 and the report). [`cli`] is the `hapticgen` command line's work:
//! its arguments, a function per command and their error; the binary only parses and
//! dispatches.
#![deny(missing_docs)]

pub mod analysis;
pub mod cli;
pub mod closed_loop;
pub mod connect;
pub mod contact;
pub mod contact_report;
pub mod design;
pub mod design_maps;
pub mod design_page;
pub mod design_published;
pub mod design_report;
pub mod faults;
pub mod generated;
pub mod identify;
pub mod output;
pub mod paper;
pub mod pil;
pub mod plant;
pub mod plot;
pub mod replay;
pub mod report;
pub mod rig;
pub mod scene;
pub mod simulation;
pub mod solids;
pub mod tape;
pub mod template;
pub mod vector;
pub mod zwidth;
