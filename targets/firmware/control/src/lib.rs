//! The board-independent part of every hapticgen firmware image.
//!
//! * [`board`]: the board layer, one trait per peripheral role (encoder counters, current
//!   ADC, force sensor, PWM voltage output, periodic timer, cycle counter). A real board's
//!   support crate implements these; the control code never names a register.
//! * [`app`]: [`app::Controller`], the interrupt body: one call per current-loop period
//!   runs the runtime's current loop and, when the runtime's `Scheduler` says so, the
//!   impedance tick (estimation → rig terms → reference/rendering → impedance law → safety).
//!   It times both with the board's cycle counter, and optionally times the sub-steps of
//!   the impedance tick on a copy of the state ([`app::Profile`]).
//! * [`device`]: device mode, the part every board does the same: the host's settings and
//!   scene applied to the controller, the state stream framed.
//! * [`excitation`]: an identification excitation as the host sends it, joint by joint,
//!   assembled and checked ([`excitation::ExcitationParts`]) before the PIL image or device
//!   mode plays it.
//! * [`link`]: the device's end of the host link (`hapticgen-protocol`): handshake,
//!   heartbeat watchdog that disables the bridges ([`link::Gated`]), commands, counters.
//! * [`link_scene`]: what a linked image's controller follows: a fixed reference or the
//!   planar scene the host sends ([`link_scene::LinkSource`]), and the image's `DeviceInfo`.
//! * [`stylus`]: [`stylus::Stylus`], the stylus's orientation from its gimbal's encoders
//!   (measured passive joints) and the rig's generated frame function, read each impedance
//!   tick.
//! * [`setup`]: [`Setup`], what an image takes from its model file (each joint's current-loop
//!   gains, the start pose, the rendering parameters), as the build script computes it.
//! * [`probe`]: the parts of a control-path probe, a binary linked (never run) to show that no
//!   panic is reachable from an image's interrupt body (`scripts/firmware.sh` checks each).
//! * [`report`]: integer-only text output (no `core::fmt`, no float formatting: it costs
//!   ~29 KB of flash), shared by the target and the host reference so both print the same
//!   lines.
#![no_std]
#![deny(missing_docs)]

pub mod app;
pub mod board;
pub mod device;
pub mod excitation;
pub mod link;
pub mod link_scene;
pub mod probe;
pub mod report;
pub mod setup;
pub mod stylus;

pub use app::{Controller, CostStats, Profile};
pub use board::{
    Board, CurrentSense, CycleCounter, Encoders, ForceSense, MeasuredEncoders, TickTimer, VoltageOutput,
};
pub use setup::Setup;
