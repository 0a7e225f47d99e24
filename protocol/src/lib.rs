//! The link between a host application and a hapticgen device: typed, versioned
//! messages shared by the firmware and the host, without allocation.
//!
//! * [`message`]: what travels. Device → host: [`DeviceMessage`] (the handshake's
//!   [`DeviceInfo`], the 1 kHz state stream [`StateFrame`], processor-in-the-loop actuator
//!   frames, link counters). Host → device: [`HostMessage`] (handshake, heartbeat, enable,
//!   disable, fault reset, impedance settings, scene objects, processor-in-the-loop sensor
//!   frames).
//! * [`frame`]: how it travels. A message is serialised with postcard, followed by its
//!   CRC-16 (CRC-16/IBM-SDLC, the X.25 CRC, little-endian), COBS-encoded so that the frame holds no zero
//!   byte, and terminated by one zero byte: `COBS(postcard(message) ‖ crc16) 0x00`. The
//!   receiver's [`FrameDecoder`] takes one byte at a time in bounded time, resynchronises at
//!   the next zero byte after garbage or a truncated frame, and counts and drops every frame
//!   that is oversized, badly stuffed, fails its CRC or is not a message of this version;
//!   none of them is acted on.
//!
//! The state stream is sized for a 1 Mbit/s UART: its channels are 16-bit fixed point, in
//! units the device announces once in [`DeviceInfo::scales`], so that a 3-joint, 3-axis
//! device's frame with every field is at most 50 bytes (0.5 Mbit/s at 1 kHz, 8N1).
#![no_std]
#![deny(missing_docs)]

pub mod frame;
pub mod message;

pub use frame::{
    encode, EncodeError, FrameDecoder, LinkCounters, Received, MAX_FRAME_BYTES, MAX_MESSAGE_BYTES,
};
pub use message::rig_name_hash;
pub use message::{
    ActuatorFrame, ChannelScales, CountUnwrapper, DeviceInfo, DeviceMessage, ExcitationJoint, HostKind,
    HostMessage, ImpedanceSettings, LinkEffect, PilLaw, PilSetup, SceneAnswer, SceneObject, SceneOutcome,
    SensorFrame, StateFrame, StateSample, CHANNEL_CODES, CHANNEL_LIMIT, EXCITATION_HARMONICS, MAX_JOINTS,
    MAX_TASK, PROTOCOL_VERSION, SCENE_SLOTS,
};
