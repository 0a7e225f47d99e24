//! `hapticgen connect` (docs/link-device.md): the host's end of a running device's link, the way an
//! application drives a haptic device (OpenHaptics' scheduler, Force Dimension's
//! `dhdGet…`/`dhdSet…`): open the link, set the impedance, load a scene, enable the bridges
//! and keep them enabled with heartbeats, read the 1 kHz state stream (a live status line, a
//! CSV log), disable at the end.
//!
//! * [`Port`]: `tcp:HOST:PORT` (QEMU's `-serial tcp:…,server=on,wait=off`, or a serial-to-TCP
//!   bridge), `unix:PATH` (QEMU's `-serial unix:…`) or a device path (a serial port or a pty; set a real port's speed beforehand,
//!   e.g. `stty -F /dev/ttyACM0 1000000 raw`).
//! * [`load_scene`]: a scene file ([`crate::scene`]; the device takes `sphere`, `box`, `half_space`), each
//!   error at its file, line and column; [`Session::send_scene`] sends it and waits for the
//!   device's answer to each object (protocol version 5): an object the device does not
//!   render is an error at its line and column ([`refusal`]).
//! * [`device_reset`]: the state stream says the device started again (its tick went back,
//!   or it dropped its bridges without a fault): `hapticgen connect` then sends `Hello`, the
//!   settings and the scene again.
//! * [`Session`]: the link itself. A reader thread decodes the device's frames (corrupt ones
//!   are counted by the frame decoder and dropped); a heartbeat thread sends a heartbeat every
//!   [`HEARTBEAT_PERIOD`] while heartbeats are on, from its own thread so that the main
//!   thread's work (logging, printing) never delays one.
//! * [`safety_check`]: the link's safety rules, tried on the device (`--check-safety`):
//!   heartbeat loss → safe state within 10 ms; `Enable` alone refused after it; `ResetFault`
//!   then `Enable` recovers; garbage and corrupted frames at full rate never stall the state
//!   stream nor disable the bridges.

use std::io::{Read, Write};
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use hapticgen_protocol::{
    encode, DeviceInfo, DeviceMessage, FrameDecoder, HostMessage, ImpedanceSettings, LinkCounters,
    LinkEffect, SceneAnswer, SceneObject as LinkObject, SceneOutcome, StateFrame, MAX_FRAME_BYTES, MAX_TASK,
    PROTOCOL_VERSION, SCENE_SLOTS,
};
use rand::rngs::SmallRng;
use rand::{Rng, SeedableRng};

use crate::scene::SceneShape;

/// How often the heartbeat thread sends a heartbeat: three to a device timeout of 6 ms, and few
/// enough bytes (3.5 kB/s) that QEMU's emulated UART, which takes about 12 kB/s and less on a
/// busy machine, keeps no queue of them (a queued heartbeat arrives late, and the loss of the
/// heartbeat then seems slower than it is).
pub const HEARTBEAT_PERIOD: Duration = Duration::from_millis(2);

/// How long the host waits for the device's answer to `Hello`, and for the TCP port to accept.
pub const HELLO_TIMEOUT: Duration = Duration::from_secs(10);

/// Random bytes per burst of [`safety_check`]'s garbage (and a zero after them).
pub const GARBAGE_BURST_BYTES: usize = 15;

/// Seed of [`safety_check`]'s random bytes (the same bytes every run).
pub const GARBAGE_SEED: u64 = 0x9e37_79b9_7f4a_7c15;

/// Time between two bursts of [`safety_check`]'s garbage.
pub const GARBAGE_PERIOD: Duration = Duration::from_millis(4);

/// How long [`safety_check`] floods the link with garbage.
pub const FLOOD_TIME: Duration = Duration::from_millis(300);

/// How long [`safety_check`] waits for the device to take the flood (QEMU's UART carries
/// about 12 kB/s, less when the machine is busy).
pub const RECOVERY_TIMEOUT: Duration = Duration::from_secs(60);

/// How long [`safety_check`] waits for the device to answer a sync, or to advance by the
/// ticks a step watches.
pub const SYNC_TIMEOUT: Duration = Duration::from_secs(10);

/// The link's safe-state bound (docs/link.md): the bridges are off within this long of the last
/// heartbeat.
pub const SAFE_STATE_BOUND_MS: f64 = 10.0;

/// Where the device is.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Port {
    /// A TCP address, `HOST:PORT`.
    Tcp(String),
    /// A Unix-domain socket (QEMU's `-serial unix:PATH,server=on,wait=off`).
    Unix(PathBuf),
    /// A serial port or pty.
    Path(PathBuf),
}

impl std::str::FromStr for Port {
    type Err = String;

    fn from_str(text: &str) -> Result<Self, String> {
        match text.strip_prefix("tcp:") {
            Some(address)
                if address
                    .rsplit_once(':')
                    .is_some_and(|(h, p)| !h.is_empty() && p.parse::<u16>().is_ok()) =>
            {
                Ok(Port::Tcp(address.to_string()))
            }
            Some(address) => Err(format!("`tcp:{address}`: expected tcp:HOST:PORT, e.g. tcp:127.0.0.1:4500")),
            None if text.starts_with("unix:") => match &text[5..] {
                "" => Err("`unix:`: expected unix:PATH".into()),
                path => Ok(Port::Unix(PathBuf::from(path))),
            },
            None if text.is_empty() => Err("the port is empty: give tcp:HOST:PORT or a device path".into()),
            None => Ok(Port::Path(PathBuf::from(text))),
        }
    }
}

/// A scene as the link carries it: the objects for the device's slots, the free-space effect,
/// and the objects that move.
#[derive(Clone, Debug, PartialEq)]
pub struct DeviceScene {
    /// The objects, in the file's order (`SetObject`), where they are at time 0.
    pub objects: Vec<LinkObject>,
    /// The effect (`SetEffect`; [`LinkEffect::None`] when the file names none).
    pub effect: LinkEffect,
    /// The objects with a `motion`: the device's slots hold still objects, so the host sends
    /// each one's slot again as it moves ([`DeviceScene::moved_objects`]).
    pub moving: Vec<MovingObject>,
    /// Where each object is written (`file:line:column`), in the order of `objects`.
    pub locations: Vec<String>,
}

/// How long [`Session::send_scene`] waits for the device's answers to a scene's objects.
pub const SCENE_ANSWER_TIMEOUT: Duration = Duration::from_secs(10);

/// The error for the device's `answer` to a slot of `scene` ([`Session::send_scene`]), at the
/// object's line and column; `None` when the device renders it.
pub fn refusal(scene: &DeviceScene, answer: &SceneAnswer) -> Option<String> {
    let slot = usize::from(answer.slot);
    let object = scene.objects.get(slot).copied().unwrap_or(LinkObject::Empty);
    let kind = match object {
        LinkObject::Empty => "empty slot",
        LinkObject::Sphere { cavity: true, .. } => "spherical cavity",
        LinkObject::Sphere { .. } => "sphere",
        LinkObject::HalfSpace { .. } => "half-space",
        LinkObject::Box { .. } => "box",
    };
    let why = match answer.outcome {
        SceneOutcome::Rendered => return None,
        SceneOutcome::NotRendered => {
            "the device does not render this kind of object in its task's dimension (a 1-D device renders none; \
             a 2-D device draws spheres and boxes in the plane z = 0, not half-spaces; a 3-D device spheres, \
             boxes and half-spaces)"
        }
        SceneOutcome::BadValues => "the device refused its values (not finite, a size not positive, a negative gain)",
        SceneOutcome::NoSlot => "the device has no such slot",
    };
    Some(match scene.locations.get(slot) {
        Some(location) => format!("error: {location}: the device refused this {kind}: {why}"),
        None => format!("error: scene slot {slot}: the device refused this {kind}: {why}"),
    })
}

/// `true` when a state frame with tick `next` after one with tick `previous` says the device
/// started again: its tick went back (more than half the 16-bit range ahead, as a wrapping
/// difference), or the bridges went off while they were on (`was_enabled`), with no fault,
/// although the host did not disable them (a device that lost the heartbeat says so with the
/// link fault).
pub fn device_reset(previous: &StateFrame, next: &StateFrame, was_enabled: bool) -> bool {
    let went_back = next.tick.wrapping_sub(previous.tick) > u16::MAX / 2;
    let dropped = was_enabled && next.status & StateFrame::ENABLED == 0 && next.fault == 0;
    went_back || dropped
}

/// An object of a device scene that moves: its slot, the object as the file writes it, and how
/// it moves.
#[derive(Clone, Debug, PartialEq)]
pub struct MovingObject {
    /// The device's slot.
    pub slot: u8,
    /// The object at time 0.
    pub object: crate::scene::SceneObject,
    /// Its motion.
    pub motion: crate::scene::SceneMotion,
}

impl DeviceScene {
    /// The moving objects where they are `time` seconds after the scene was loaded, as the
    /// link's `SetObject` carries them: a sphere's centre and a box's centre carried along, a
    /// half-space's point carried and its normal turned.
    pub fn moved_objects(&self, time: f64) -> Vec<(u8, LinkObject)> {
        self.moving
            .iter()
            .map(|moving| {
                let mut object = moving.object.clone();
                object.shape = moved_shape(&object.shape, &moving.motion, time);
                // Checked when the scene was loaded: what moves is a sphere, a box or a
                // half-space, which `link_object` takes.
                (moving.slot, link_object(&object).unwrap_or(LinkObject::Empty))
            })
            .collect()
    }
}

/// `shape` moved by `motion` at `time` (spheres, boxes without a turn, half-spaces: what a
/// device's slot holds; any other shape as it is).
fn moved_shape(shape: &SceneShape, motion: &crate::scene::SceneMotion, time: f64) -> SceneShape {
    let mut moved = shape.clone();
    match &mut moved {
        SceneShape::Sphere { center, .. } | SceneShape::Box { center, .. } => {
            *center = motion.carried(time, center);
        }
        SceneShape::HalfSpace { point, normal } => {
            *point = motion.carried(time, point);
            *normal = motion.turned(time, normal);
        }
        _ => {}
    }
    moved
}

/// Reads a scene file ([`crate::scene`]) for a device: up to [`SCENE_SLOTS`] spheres, boxes
/// and half-spaces without friction (what the link's `SetObject` carries), and its effect,
/// vectors of 1 to 3 coordinates (the missing ones zero). Every error names the file, line and
/// column.
pub fn load_scene(path: &Path) -> Result<DeviceScene, String> {
    device_scene(&crate::scene::load(path)?)
}

/// [`load_scene`] of `text`, named `name` in the errors (meshes read relative to the current
/// directory).
pub fn parse_scene(name: &str, text: &str) -> Result<DeviceScene, String> {
    device_scene(&crate::scene::parse(name, text, Path::new("."))?)
}

fn device_scene(scene: &crate::scene::Scene) -> Result<DeviceScene, String> {
    let objects = device_objects(scene)?;
    let mut moving = Vec::new();
    for (slot, object) in scene.objects.iter().enumerate() {
        let Some(motion) = &object.motion else { continue };
        if matches!(object.shape, SceneShape::Box { .. }) && motion.turns() {
            return Err(format!(
                "error: {}: a device's scene slots hold axis-aligned boxes; a turning box (`motion.angular_velocity`) \
                 is rendered by `hapticgen simulate --scene`",
                object.location
            ));
        }
        // `device_objects` holds at most SCENE_SLOTS objects, far below `u8::MAX`.
        moving.push(MovingObject { slot: slot as u8, object: object.clone(), motion: motion.clone() });
    }
    let locations = scene.objects.iter().map(|object| object.location.clone()).collect();
    Ok(DeviceScene { objects, effect: device_effect(scene.effect.as_ref()), moving, locations })
}

/// A scene file's effect as the link carries it (vectors padded with zeros to [`MAX_TASK`]).
fn device_effect(effect: Option<&crate::scene::SceneEffect>) -> LinkEffect {
    use crate::scene::SceneEffect;
    match effect {
        None => LinkEffect::None,
        Some(SceneEffect::Spring { anchor, stiffness }) => {
            LinkEffect::Spring { anchor: padded(anchor), stiffness: *stiffness as f32 }
        }
        Some(SceneEffect::Viscous { damping }) => LinkEffect::Viscous { damping: *damping as f32 },
        Some(SceneEffect::Force { force }) => LinkEffect::Force { force: padded(force) },
        Some(SceneEffect::Vibration { direction, amplitude, frequency }) => LinkEffect::Vibration {
            direction: padded(direction),
            amplitude: *amplitude as f32,
            frequency: *frequency as f32,
        },
    }
}

/// A task vector in `f32`, padded with zeros to [`MAX_TASK`] (a scene's vectors have 1 to 3).
fn padded(values: &[f64]) -> [f32; MAX_TASK] {
    let mut out = [0.0; MAX_TASK];
    for (slot, value) in out.iter_mut().zip(values) {
        *slot = *value as f32;
    }
    out
}

/// A scene's objects as the link carries them.
fn device_objects(scene: &crate::scene::Scene) -> Result<Vec<LinkObject>, String> {
    if scene.objects.len() > SCENE_SLOTS {
        let extra = &scene.objects[SCENE_SLOTS];
        return Err(format!(
            "error: {}: a device holds {SCENE_SLOTS} objects, the file has {}",
            extra.location,
            scene.objects.len()
        ));
    }
    scene.objects.iter().map(link_object).collect()
}

/// One scene object as the link carries it (where it is at time 0).
fn link_object(object: &crate::scene::SceneObject) -> Result<LinkObject, String> {
    if object.static_friction != 0.0 || object.dynamic_friction != 0.0 {
        return Err(format!(
            "error: {}: the link carries no friction (a device's scene slots are frictionless); remove `friction`",
            object.location
        ));
    }
    let (stiffness, damping) = (object.stiffness as f32, object.damping as f32);
    Ok(match &object.shape {
        SceneShape::Sphere { center, radius } => LinkObject::Sphere {
            centre: padded(center),
            radius: *radius as f32,
            cavity: object.cavity,
            stiffness,
            damping,
        },
        SceneShape::Box { center, half_extents, .. } if object.shape.is_axis_aligned() => {
            LinkObject::Box { centre: padded(center), half_extents: padded(half_extents), stiffness, damping }
        }
        SceneShape::Box { .. } => {
            return Err(format!(
                "error: {}: a device's scene slots hold axis-aligned boxes; a turned box (`rotation`) is rendered \
                 by `hapticgen simulate --scene` and by firmware images built with the scene",
                object.location
            ))
        }
        SceneShape::HalfSpace { point, normal } => {
            LinkObject::HalfSpace { point: padded(point), normal: padded(normal), stiffness, damping }
        }
        SceneShape::Capsule { .. } | SceneShape::Cylinder { .. } | SceneShape::Polytope { .. } | SceneShape::Mesh { .. } => {
            return Err(format!(
                "error: {}: a device's scene slots hold spheres, boxes and half-spaces; capsules, cylinders, \
                 polytopes and meshes are rendered by `hapticgen simulate --scene` and by firmware images built \
                 with the scene",
                object.location
            ))
        }
    })
}

/// A state frame as the host received it.
#[derive(Clone, Copy, Debug)]
pub struct ArrivedState {
    /// The frame.
    pub frame: StateFrame,
    /// When it arrived.
    pub at: Instant,
}

/// What the reader thread passes on.
enum Incoming {
    Hello(DeviceInfo),
    State(ArrivedState),
    Link(LinkCounters),
    Scene(SceneAnswer),
    Closed(String),
}

/// An open link to a device.
pub struct Session {
    writer: Arc<Mutex<Writer>>,
    incoming: Receiver<Incoming>,
    heartbeats_on: Arc<AtomicBool>,
    heartbeats_sent: Arc<AtomicU64>,
    last_heartbeat_ns: Arc<AtomicU64>,
    stop: Arc<AtomicBool>,
    heartbeat_thread: Option<JoinHandle<()>>,
    epoch: Instant,
    /// The device's answer to `Hello`.
    pub info: DeviceInfo,
    /// The device's latest receive counters (it sends them about once a second).
    pub device_counters: Option<LinkCounters>,
    host_dropped: Arc<AtomicU64>,
}

/// The link's receiving half.
type Reader = Box<dyn Read + Send>;
/// The link's sending half.
type Writer = Box<dyn Write + Send>;

/// `connect` retried every 50 ms for [`HELLO_TIMEOUT`] (the device, e.g. QEMU, may still be
/// starting); the last error if it never succeeds.
fn retry<T>(mut connect: impl FnMut() -> std::io::Result<T>) -> std::io::Result<T> {
    let start = Instant::now();
    loop {
        match connect() {
            Ok(stream) => return Ok(stream),
            Err(e) if start.elapsed() >= HELLO_TIMEOUT => return Err(e),
            Err(_) => std::thread::sleep(Duration::from_millis(50)),
        }
    }
}

fn open(port: &Port) -> Result<(Reader, Writer), String> {
    match port {
        Port::Tcp(address) => {
            let stream = retry(|| TcpStream::connect(address))
                .map_err(|e| format!("error: cannot connect to tcp:{address}: {e}"))?;
            stream.set_nodelay(true).map_err(|e| format!("error: tcp:{address}: {e}"))?;
            let reader = stream.try_clone().map_err(|e| format!("error: tcp:{address}: {e}"))?;
            Ok((Box::new(reader), Box::new(stream)))
        }
        Port::Unix(path) => {
            let stream = retry(|| std::os::unix::net::UnixStream::connect(path))
                .map_err(|e| format!("error: cannot connect to unix:{}: {e}", path.display()))?;
            let reader = stream.try_clone().map_err(|e| format!("error: unix:{}: {e}", path.display()))?;
            Ok((Box::new(reader), Box::new(stream)))
        }
        Port::Path(path) => {
            let file = std::fs::OpenOptions::new()
                .read(true)
                .write(true)
                .open(path)
                .map_err(|e| format!("error: cannot open {}: {e}", path.display()))?;
            let reader = file.try_clone().map_err(|e| format!("error: {}: {e}", path.display()))?;
            Ok((Box::new(reader), Box::new(file)))
        }
    }
}

fn send_on(writer: &Mutex<Writer>, message: &HostMessage) -> Result<(), String> {
    let mut frame = [0u8; MAX_FRAME_BYTES];
    let length = encode(message, &mut frame).map_err(|e| format!("error: framing {message:?}: {e:?}"))?;
    let mut writer = writer.lock().map_err(|_| "error: the link's writer failed".to_string())?;
    writer
        .write_all(&frame[..length])
        .and_then(|()| writer.flush())
        .map_err(|e| format!("error: writing to the device: {e}"))
}

impl Session {
    /// Opens `port`, sends `Hello` and waits for the device's [`DeviceInfo`] (its protocol
    /// version must be this host's).
    pub fn open(port: &Port) -> Result<Self, String> {
        let (mut reader, writer) = open(port)?;
        let writer = Arc::new(Mutex::new(writer));
        let (sender, incoming) = mpsc::channel();
        let stop = Arc::new(AtomicBool::new(false));
        let host_dropped = Arc::new(AtomicU64::new(0));
        // The reader thread is not joined: it may be blocked in a read, and ends with the link
        // or the process.
        {
            let stop = Arc::clone(&stop);
            let host_dropped = Arc::clone(&host_dropped);
            std::thread::spawn(move || {
                let mut decoder = FrameDecoder::new();
                let mut chunk = [0u8; 4096];
                while !stop.load(Ordering::Relaxed) {
                    let n = match reader.read(&mut chunk) {
                        Ok(0) => {
                            let _ = sender.send(Incoming::Closed("the device closed the link".into()));
                            return;
                        }
                        Ok(n) => n,
                        Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
                        Err(e) => {
                            let _ = sender.send(Incoming::Closed(format!("reading from the device: {e}")));
                            return;
                        }
                    };
                    for &byte in &chunk[..n] {
                        let message = match decoder.push::<DeviceMessage>(byte) {
                            Some(DeviceMessage::Hello(info)) => Incoming::Hello(info),
                            Some(DeviceMessage::State(frame)) => {
                                Incoming::State(ArrivedState { frame, at: Instant::now() })
                            }
                            Some(DeviceMessage::Link(counters)) => Incoming::Link(counters),
                            Some(DeviceMessage::Scene(answer)) => Incoming::Scene(answer),
                            Some(DeviceMessage::Actuators(_)) | None => continue,
                        };
                        if sender.send(message).is_err() {
                            return;
                        }
                    }
                    host_dropped.store(u64::from(decoder.counters().dropped()), Ordering::Relaxed);
                }
            });
        }
        let heartbeats_on = Arc::new(AtomicBool::new(false));
        let heartbeats_sent = Arc::new(AtomicU64::new(0));
        let last_heartbeat_ns = Arc::new(AtomicU64::new(0));
        let epoch = Instant::now();
        let heartbeat_thread = {
            let (writer, stop, on, sent, last) = (
                Arc::clone(&writer),
                Arc::clone(&stop),
                Arc::clone(&heartbeats_on),
                Arc::clone(&heartbeats_sent),
                Arc::clone(&last_heartbeat_ns),
            );
            std::thread::spawn(move || {
                let mut sequence = 0u16;
                let mut next = Instant::now();
                while !stop.load(Ordering::Relaxed) {
                    if on.load(Ordering::Relaxed) {
                        if send_on(&writer, &HostMessage::Heartbeat { sequence }).is_err() {
                            return;
                        }
                        last.store(epoch.elapsed().as_nanos() as u64, Ordering::Relaxed);
                        sent.fetch_add(1, Ordering::Relaxed);
                        sequence = sequence.wrapping_add(1);
                    }
                    next += HEARTBEAT_PERIOD;
                    let now = Instant::now();
                    if next > now {
                        std::thread::sleep(next - now);
                    } else {
                        next = now;
                    }
                }
            })
        };
        let mut session = Session {
            writer,
            incoming,
            heartbeats_on,
            heartbeats_sent,
            last_heartbeat_ns,
            stop,
            heartbeat_thread: Some(heartbeat_thread),
            epoch,
            info: DeviceInfo {
                version: 0,
                rig_name_hash: 0,
                joints: 0,
                task_dim: 0,
                impedance_loop_hz: 0,
                scales: hapticgen_protocol::ChannelScales::DESKTOP,
            },
            device_counters: None,
            host_dropped,
        };
        session.send(&HostMessage::Hello { version: PROTOCOL_VERSION })?;
        let deadline = Instant::now() + HELLO_TIMEOUT;
        loop {
            match session.next(deadline.saturating_duration_since(Instant::now()))? {
                Some(Event::Hello(info)) => {
                    if info.version != PROTOCOL_VERSION {
                        return Err(format!(
                            "error: the device speaks protocol version {}, this host {PROTOCOL_VERSION}",
                            info.version
                        ));
                    }
                    session.info = info;
                    return Ok(session);
                }
                Some(_) => {}
                None => {
                    return Err(format!(
                        "error: no answer to Hello from the device in {} s (is it running, on this port?)",
                        HELLO_TIMEOUT.as_secs()
                    ))
                }
            }
        }
    }

    /// Sends one message.
    pub fn send(&self, message: &HostMessage) -> Result<(), String> {
        send_on(&self.writer, message)
    }

    /// Writes raw bytes (the fault tests' garbage and corrupted frames).
    pub fn send_raw(&self, bytes: &[u8]) -> Result<(), String> {
        let mut writer = self.writer.lock().map_err(|_| "error: the link's writer failed".to_string())?;
        writer
            .write_all(bytes)
            .and_then(|()| writer.flush())
            .map_err(|e| format!("error: writing to the device: {e}"))
    }

    /// Turns the heartbeat thread's heartbeats on or off.
    pub fn heartbeats(&self, on: bool) {
        self.heartbeats_on.store(on, Ordering::Relaxed);
    }

    /// Frames the host's decoder dropped so far (corrupt, or not a device message).
    pub fn host_dropped(&self) -> u64 {
        self.host_dropped.load(Ordering::Relaxed)
    }

    /// Heartbeats sent so far.
    pub fn heartbeats_sent(&self) -> u64 {
        self.heartbeats_sent.load(Ordering::Relaxed)
    }

    /// When the last heartbeat was written.
    pub fn last_heartbeat(&self) -> Instant {
        self.epoch + Duration::from_nanos(self.last_heartbeat_ns.load(Ordering::Relaxed))
    }

    /// The next event within `timeout`; `None` when none came.
    pub fn next(&mut self, timeout: Duration) -> Result<Option<Event>, String> {
        match self.incoming.recv_timeout(timeout) {
            Ok(Incoming::Hello(info)) => Ok(Some(Event::Hello(info))),
            Ok(Incoming::Scene(answer)) => Ok(Some(Event::Scene(answer))),
            Ok(Incoming::State(received)) => Ok(Some(Event::State(received))),
            Ok(Incoming::Link(counters)) => {
                self.device_counters = Some(counters);
                Ok(Some(Event::Counters(counters)))
            }
            Ok(Incoming::Closed(why)) => Err(format!("error: {why}")),
            Err(RecvTimeoutError::Timeout) => Ok(None),
            Err(RecvTimeoutError::Disconnected) => Err("error: the link's reader stopped".into()),
        }
    }

    /// Every state frame that arrives within `duration`, in order.
    pub fn states_for(&mut self, duration: Duration) -> Result<Vec<ArrivedState>, String> {
        let deadline = Instant::now() + duration;
        let mut states = Vec::new();
        while let Some(left) = deadline.checked_duration_since(Instant::now()) {
            match self.next(left)? {
                Some(Event::State(received)) => states.push(received),
                Some(_) => {}
                None => break,
            }
        }
        Ok(states)
    }

    /// Every state frame until the device's tick has advanced by `ticks` from the first one
    /// (the device's time, which runs slower than the host's when the device, e.g. QEMU, is
    /// short of CPU), or `limit` of the host's time has passed.
    pub fn states_for_ticks(&mut self, ticks: u16, limit: Duration) -> Result<Vec<ArrivedState>, String> {
        let deadline = Instant::now() + limit;
        let mut states: Vec<ArrivedState> = Vec::new();
        while let Some(left) = deadline.checked_duration_since(Instant::now()) {
            match self.next(left)? {
                Some(Event::State(received)) => {
                    let first = states.first().map_or(received.frame.tick, |s| s.frame.tick);
                    states.push(received);
                    if received.frame.tick.wrapping_sub(first) >= ticks {
                        break;
                    }
                }
                Some(_) => {}
                None => break,
            }
        }
        Ok(states)
    }

    /// Waits until the device has taken every byte sent so far: sends `Hello` and waits for
    /// its answer (the device answers in order, so everything before it has been received and
    /// acted on). Returns the state frames that arrived meanwhile; an error after `limit`.
    pub fn sync(&mut self, limit: Duration) -> Result<Vec<ArrivedState>, String> {
        self.send(&HostMessage::Hello { version: PROTOCOL_VERSION })?;
        let deadline = Instant::now() + limit;
        let mut states = Vec::new();
        while let Some(left) = deadline.checked_duration_since(Instant::now()) {
            match self.next(left)? {
                Some(Event::State(received)) => states.push(received),
                Some(Event::Hello(_)) => return Ok(states),
                Some(Event::Counters(_) | Event::Scene(_)) => {}
                None => break,
            }
        }
        Err(format!("error: the device did not answer Hello within {} s", limit.as_secs()))
    }

    /// Sends `scene` (every slot, the objects beyond the file's emptied, then its effect) and
    /// waits for the device's answer to each slot: an error at the object's line and column
    /// for the first the device refuses ([`refusal`]), or if the answers do not come within
    /// [`SCENE_ANSWER_TIMEOUT`]. Returns the state frames that arrived meanwhile.
    pub fn send_scene(&mut self, scene: &DeviceScene) -> Result<Vec<ArrivedState>, String> {
        for slot in 0..SCENE_SLOTS {
            let object = scene.objects.get(slot).copied().unwrap_or(LinkObject::Empty);
            self.send(&HostMessage::SetObject { slot: slot as u8, object })?;
        }
        self.send(&HostMessage::SetEffect(scene.effect))?;
        let deadline = Instant::now() + SCENE_ANSWER_TIMEOUT;
        let mut answered = [false; SCENE_SLOTS];
        let mut states = Vec::new();
        let mut refused = Vec::new();
        while answered.iter().any(|a| !a) {
            let Some(left) = deadline.checked_duration_since(Instant::now()) else { break };
            match self.next(left)? {
                Some(Event::Scene(answer)) => {
                    if let Some(done) = answered.get_mut(usize::from(answer.slot)) {
                        *done = true;
                    }
                    refused.extend(refusal(scene, &answer));
                }
                Some(Event::State(received)) => states.push(received),
                Some(_) => {}
                None => break,
            }
        }
        if !refused.is_empty() {
            return Err(refused.join("\n"));
        }
        if let Some(slot) = answered.iter().position(|a| !a) {
            return Err(format!(
                "error: the device did not answer the scene's slot {slot} within {} s",
                SCENE_ANSWER_TIMEOUT.as_secs()
            ));
        }
        Ok(states)
    }

    /// Disables the bridges, stops the heartbeats and closes the link.
    pub fn close(mut self) -> Result<(), String> {
        self.heartbeats(false);
        let result = self.send(&HostMessage::Disable);
        self.stop.store(true, Ordering::Relaxed);
        if let Some(heartbeat) = self.heartbeat_thread.take() {
            let _ = heartbeat.join();
        }
        // The reader thread may be blocked in a read; it ends with the link or the process.
        result
    }
}

/// What [`Session::next`] returns.
#[derive(Clone, Copy, Debug)]
pub enum Event {
    /// The device's identity (an answer to `Hello`).
    Hello(DeviceInfo),
    /// One state frame.
    State(ArrivedState),
    /// The device's receive counters.
    Counters(LinkCounters),
    /// The device's answer to one scene object.
    Scene(SceneAnswer),
}

/// The header of the state log (`--log`): the columns of [`csv_row`].
pub fn csv_header(info: &DeviceInfo) -> Vec<String> {
    let mut header = vec![
        "host_s".to_string(),
        "tick".into(),
        "enabled".into(),
        "safety_fault".into(),
        "link_fault".into(),
    ];
    let joints = usize::from(info.joints);
    let task = usize::from(info.task_dim);
    header.extend((0..joints).map(|j| format!("counts{j}")));
    header.extend((0..joints).map(|j| format!("qd{j}")));
    header.extend((0..task).map(|k| format!("x{k}")));
    header.extend((0..task).map(|k| format!("xd{k}")));
    header.extend((0..joints).map(|j| format!("tau{j}")));
    header.extend((0..joints).map(|j| format!("current{j}")));
    header.push("tick_cost".into());
    header
}

/// The row of `frame`: its channels in SI units (decoded with the device's channel scales),
/// NaN where a channel is missing.
pub fn csv_row(info: &DeviceInfo, frame: &StateFrame, host_seconds: f64) -> Vec<String> {
    let scales = &info.scales;
    let value =
        |v: Option<f32>| v.map_or("NaN".to_string(), |v| format!("{}", crate::output::unsigned_zero(v)));
    let joints = usize::from(info.joints);
    let task = usize::from(info.task_dim);
    let mut row = vec![
        format!("{host_seconds:.6}"),
        frame.tick.to_string(),
        u8::from(frame.status & StateFrame::ENABLED != 0).to_string(),
        (frame.fault & !StateFrame::LINK_FAULT).to_string(),
        u8::from(frame.fault & StateFrame::LINK_FAULT != 0).to_string(),
    ];
    row.extend((0..joints).map(|j| frame.encoder_count_wrapped(j).map_or("NaN".into(), |c| c.to_string())));
    row.extend((0..joints).map(|j| value(frame.joint_velocity(j, scales))));
    row.extend((0..task).map(|k| value(frame.task_position(k, scales))));
    row.extend((0..task).map(|k| value(frame.task_velocity(k, scales))));
    row.extend((0..joints).map(|j| value(frame.joint_torque(j, scales))));
    row.extend((0..joints).map(|j| value(frame.motor_current(j, scales))));
    row.push(frame.tick_instructions.to_string());
    row
}

/// A one-line summary of `frame` for the live status line.
pub fn status_line(info: &DeviceInfo, frame: &StateFrame, frames: u64, gaps: u64) -> String {
    let task: Vec<String> = (0..usize::from(info.task_dim))
        .map(|k| frame.task_position(k, &info.scales).map_or("NaN".into(), |x| format!("{:+8.2}", x * 1e3)))
        .collect();
    let state = if frame.fault & StateFrame::LINK_FAULT != 0 {
        "SAFE (heartbeat lost; reset needed)"
    } else if frame.status & StateFrame::ENABLED != 0 {
        "enabled"
    } else {
        "disabled"
    };
    let safety = frame.fault & !StateFrame::LINK_FAULT;
    format!(
        "tick {:5}  x [{}] mm  {state}{}  frames {frames}  missing {gaps}",
        frame.tick,
        task.join(" "),
        if safety != 0 { format!("  safety fault {safety}") } else { String::new() }
    )
}

/// Ticks between two frames' ticks (mod 2¹⁶), minus one: frames missing in between.
pub fn missing_between(previous: u16, next: u16) -> u64 {
    u64::from(next.wrapping_sub(previous).wrapping_sub(1))
}

/// One row of [`safety_check`]'s report.
#[derive(Clone, Debug)]
pub struct CheckRow {
    /// What was checked.
    pub what: String,
    /// What was measured.
    pub measured: String,
    /// Whether it holds.
    pub pass: bool,
}

fn enabled(frame: &StateFrame) -> bool {
    frame.status & StateFrame::ENABLED != 0
}

fn link_fault(frame: &StateFrame) -> bool {
    frame.fault & StateFrame::LINK_FAULT != 0
}

/// The impedance tick (1/`impedance_loop_hz`) in ms.
fn tick_ms(info: &DeviceInfo) -> f64 {
    1e3 / f64::from(info.impedance_loop_hz.max(1))
}

/// The link's safety rules, tried on a connected device whose bridges the session has just
/// enabled (heartbeats on). Windows are counted in the device's ticks (its clock runs slower
/// than the host's when it is short of CPU, as QEMU on a busy machine), and each step that
/// sends something first waits until the device has taken it ([`Session::sync`]). In order:
///
/// 1. *Garbage*: for 0.3 s, a burst of [`GARBAGE_BURST_BYTES`] random bytes every
///    [`GARBAGE_PERIOD`] and a corrupted heartbeat every ten bursts, beside the heartbeats: the
///    state stream goes on without a missing tick and the bridges stay enabled. (The rate is
///    what QEMU's emulated UART carries beside the heartbeats: it takes one byte at a time,
///    each a round trip between the emulator's threads; bytes sent faster queue up in the
///    socket and delay the heartbeats behind them, which would test the emulator, not the
///    firmware.)
/// 2. *Heartbeat loss*: heartbeats stop; the first state frame with the link fault must come
///    within [`SAFE_STATE_BOUND_MS`] of device time of the last heartbeat, measured from the
///    tick of the last frame received before that heartbeat was written (an upper bound: it
///    includes the link's latency both ways).
/// 3. *No recovery without a reset*: heartbeats on again and `Enable`: still disabled 50 ticks
///    after the device took it.
/// 4. *Reset*: `ResetFault` then `Enable`: enabled, the link fault cleared, 50 ticks after.
/// 5. *Flood*: random bytes as fast as the link takes them for [`FLOOD_TIME`]: the state
///    stream goes on without a missing tick until the device has taken them all (the control
///    tick never stalls) and never shows the bridges enabled with the link fault latched; the
///    heartbeats queued behind the flood may come too late, so the device may be in its safe
///    state. Then `ResetFault` and `Enable` must bring it back.
pub fn safety_check(session: &mut Session) -> Result<Vec<CheckRow>, String> {
    let info = session.info;
    let mut rows = Vec::new();
    // Let the stream settle: the device must be enabled to start.
    let settle = session.states_for(Duration::from_millis(100))?;
    let Some(last) = settle.last() else {
        return Err("error: no state frame from the device in 0.1 s".into());
    };
    if !enabled(&last.frame) {
        return Err("error: the device did not enable its bridges (is a fault latched? try --reset)".into());
    }
    // 1. Garbage beside the heartbeats, then a sync: every byte taken.
    let mut random = SmallRng::seed_from_u64(GARBAGE_SEED);
    let (mut corrupted, mut bursts) = (0u64, 0u64);
    let mut states = Vec::new();
    let until = Instant::now() + Duration::from_millis(300);
    while Instant::now() < until {
        let mut burst = [0u8; GARBAGE_BURST_BYTES + 1];
        // The last byte stays a zero: the next frame starts clean.
        random.fill(&mut burst[..GARBAGE_BURST_BYTES]);
        session.send_raw(&burst)?;
        bursts += 1;
        if bursts % 10 == 0 {
            let mut frame = [0u8; MAX_FRAME_BYTES];
            let length = encode(&HostMessage::Heartbeat { sequence: 0 }, &mut frame)
                .map_err(|e| format!("error: {e:?}"))?;
            frame[length / 2] ^= if frame[length / 2] == 1 { 2 } else { 1 };
            session.send_raw(&frame[..length])?;
            corrupted += 1;
        }
        states.extend(session.states_for(GARBAGE_PERIOD)?);
    }
    states.extend(session.sync(SYNC_TIMEOUT)?);
    let missing: u64 = states.windows(2).map(|w| missing_between(w[0].frame.tick, w[1].frame.tick)).sum();
    let all_enabled = !states.is_empty() && states.iter().all(|s| enabled(&s.frame));
    rows.push(CheckRow {
        what: "garbage and corrupted frames: no tick missing, bridges stay enabled".into(),
        measured: format!(
            "{bursts} bursts of {GARBAGE_BURST_BYTES} random bytes and {corrupted} corrupted heartbeats in 0.3 s; {} \
             state frames, {missing} missing, enabled throughout: {all_enabled}",
            states.len()
        ),
        pass: !states.is_empty() && missing == 0 && all_enabled,
    });
    // 2. Heartbeat loss (the garbage is taken: a heartbeat queued behind it would arrive late
    // and the loss would seem slower).
    let before = session.states_for_ticks(100, SYNC_TIMEOUT)?;
    session.heartbeats(false);
    // The heartbeat thread may be writing one right now: wait a period, then read its time.
    std::thread::sleep(HEARTBEAT_PERIOD * 2);
    let last_heartbeat = session.last_heartbeat();
    let mut after = session.states_for_ticks(100, SYNC_TIMEOUT)?;
    let mut all: Vec<ArrivedState> = before;
    all.append(&mut after);
    let reference = all.iter().rev().find(|s| s.at <= last_heartbeat).map(|s| s.frame.tick);
    let first_fault =
        all.iter().find(|s| s.at > last_heartbeat && link_fault(&s.frame)).map(|s| s.frame.tick);
    let off_after_fault =
        all.iter().filter(|s| s.at > last_heartbeat && link_fault(&s.frame)).all(|s| !enabled(&s.frame));
    let (measured, pass) = match (reference, first_fault) {
        (Some(from), Some(to)) => {
            let ms = f64::from(to.wrapping_sub(from)) * tick_ms(&info);
            (
                format!(
                    "link fault {ms:.1} ms of device time after the last heartbeat; bridges off with it: {off_after_fault}"
                ),
                ms <= SAFE_STATE_BOUND_MS && off_after_fault,
            )
        }
        (None, _) => ("no state frame before the last heartbeat".into(), false),
        (_, None) => ("no link fault within 100 ticks".into(), false),
    };
    rows.push(CheckRow {
        what: format!("heartbeat loss: safe state within {SAFE_STATE_BOUND_MS} ms"),
        measured,
        pass,
    });
    // 3. Enable without a reset is refused.
    session.heartbeats(true);
    std::thread::sleep(HEARTBEAT_PERIOD * 3);
    session.send(&HostMessage::Enable)?;
    session.sync(SYNC_TIMEOUT)?;
    let refused = session.states_for_ticks(50, SYNC_TIMEOUT)?;
    let still_off = refused.last().is_some_and(|s| !enabled(&s.frame) && link_fault(&s.frame));
    rows.push(CheckRow {
        what: "after it, Enable alone does not turn the bridges on".into(),
        measured: format!(
            "{} frames over 50 ticks, last: {}",
            refused.len(),
            refused.last().map_or("none".into(), |s| describe(&s.frame))
        ),
        pass: still_off,
    });
    // 4. ResetFault, then Enable.
    session.send(&HostMessage::ResetFault)?;
    session.send(&HostMessage::Enable)?;
    session.sync(SYNC_TIMEOUT)?;
    let recovered = session.states_for_ticks(50, SYNC_TIMEOUT)?;
    let back = recovered.last().is_some_and(|s| enabled(&s.frame) && !link_fault(&s.frame));
    rows.push(CheckRow {
        what: "ResetFault then Enable turns them on again".into(),
        measured: format!(
            "{} frames over 50 ticks, last: {}",
            recovered.len(),
            recovered.last().map_or("none".into(), |s| describe(&s.frame))
        ),
        pass: back,
    });
    // 5. A flood of garbage, as fast as the link takes it.
    let flood_start = Instant::now();
    let mut flooded = 0usize;
    let mut flood_states = Vec::new();
    while flood_start.elapsed() < FLOOD_TIME {
        let mut chunk = [0u8; 256];
        random.fill(&mut chunk[..]);
        session.send_raw(&chunk)?;
        flooded += chunk.len();
        flood_states.extend(session.states_for(Duration::ZERO)?);
    }
    session.send_raw(&[0])?;
    let flood_seconds = flood_start.elapsed().as_secs_f64();
    // Back to work: the heartbeats queued behind the flood may have come too late (the safe
    // state is then right), so reset and enable once the flood is taken.
    let waiting = Instant::now();
    flood_states.extend(session.sync(RECOVERY_TIMEOUT)?);
    let drained = waiting.elapsed().as_secs_f64();
    let flood_missing: u64 =
        flood_states.windows(2).map(|w| missing_between(w[0].frame.tick, w[1].frame.tick)).sum();
    let ticks = flood_states
        .last()
        .zip(flood_states.first())
        .map_or(0, |(l, f)| l.frame.tick.wrapping_sub(f.frame.tick));
    let consistent = flood_states.iter().all(|s| !(enabled(&s.frame) && link_fault(&s.frame)));
    rows.push(CheckRow {
        what: "a flood of garbage as fast as the link takes it: the control tick never stalls".into(),
        measured: format!(
            "{flooded} random bytes written in {flood_seconds:.2} s, taken by the device {drained:.2} s later; {} state \
             frames over {ticks} ticks, {flood_missing} missing; never enabled with the link fault latched: {consistent}",
            flood_states.len()
        ),
        pass: flood_states.len() > 100 && flood_missing == 0 && consistent,
    });
    session.send(&HostMessage::ResetFault)?;
    session.send(&HostMessage::Enable)?;
    session.sync(SYNC_TIMEOUT)?;
    let back = session.states_for_ticks(20, SYNC_TIMEOUT)?;
    let enabled_again = back.last().is_some_and(|s| enabled(&s.frame) && !link_fault(&s.frame));
    rows.push(CheckRow {
        what: "after the flood, ResetFault and Enable bring the device back".into(),
        measured: format!("last frame: {}", back.last().map_or("none".into(), |s| describe(&s.frame))),
        pass: enabled_again,
    });
    Ok(rows)
}

fn describe(frame: &StateFrame) -> String {
    format!(
        "tick {} {}{}",
        frame.tick,
        if enabled(frame) { "enabled" } else { "disabled" },
        if link_fault(frame) { ", link fault latched" } else { "" }
    )
}

/// The `ImpedanceSettings` of `K,B[,M]` on every axis.
pub fn parse_impedance(text: &str) -> Result<ImpedanceSettings, String> {
    let values: Vec<f32> = text
        .split(',')
        .map(|v| v.trim().parse::<f32>().map_err(|e| format!("error: --impedance {text}: `{v}`: {e}")))
        .collect::<Result<_, _>>()?;
    let (stiffness, damping, mass) = match values.as_slice() {
        [k, b] => (*k, *b, 1.0),
        [k, b, m] => (*k, *b, *m),
        _ => return Err(format!("error: --impedance {text}: expected K,B or K,B,M (N/m, N·s/m, kg)")),
    };
    if !(stiffness.is_finite() && stiffness >= 0.0 && damping.is_finite() && damping >= 0.0) {
        return Err(format!(
            "error: --impedance {text}: stiffness and damping must be finite and not negative"
        ));
    }
    if !(mass.is_finite() && mass > 0.0) {
        return Err(format!("error: --impedance {text}: the mass must be finite and positive"));
    }
    Ok(ImpedanceSettings {
        stiffness: [stiffness; MAX_TASK],
        damping: [damping; MAX_TASK],
        mass: [mass; MAX_TASK],
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ports_are_tcp_addresses_or_paths() {
        assert_eq!("tcp:127.0.0.1:4500".parse::<Port>(), Ok(Port::Tcp("127.0.0.1:4500".into())));
        assert_eq!("/dev/ttyACM0".parse::<Port>(), Ok(Port::Path("/dev/ttyACM0".into())));
        assert_eq!("unix:/tmp/device.sock".parse::<Port>(), Ok(Port::Unix("/tmp/device.sock".into())));
        assert!("unix:".parse::<Port>().is_err());
        assert!("tcp:4500".parse::<Port>().is_err());
        assert!("tcp:host:port".parse::<Port>().is_err());
        assert!("".parse::<Port>().is_err());
    }

    #[test]
    fn a_scene_s_effect_goes_to_the_device_padded_to_three_axes() {
        let text = "objects: []\neffect: {vibration: {direction: [0, 2], amplitude: 0.5, frequency: 80}}\n";
        assert_eq!(
            parse_scene("s.yaml", text).unwrap().effect,
            LinkEffect::Vibration { direction: [0.0, 1.0, 0.0], amplitude: 0.5, frequency: 80.0 }
        );
        let spring = "objects: []\neffect: {spring: {anchor: [0.01, 0.2], stiffness: 300}}\n";
        assert_eq!(
            parse_scene("s.yaml", spring).unwrap().effect,
            LinkEffect::Spring { anchor: [0.01, 0.2, 0.0], stiffness: 300.0 }
        );
        assert_eq!(parse_scene("s.yaml", "objects: []\n").unwrap().effect, LinkEffect::None);
    }

    #[test]
    fn scene_files_give_objects_and_located_errors() {
        let text =
            "objects:\n  - sphere: {centre: [0.01, 0.2], radius: 0.02, stiffness: 1500, damping: 5}\n  \
                    - half_space: {point: [0, 0, 0], normal: [0, 0, 2], stiffness: 1000, damping: 2}\n";
        let objects = parse_scene("s.yaml", text).unwrap().objects;
        assert_eq!(objects.len(), 2);
        assert!(
            matches!(objects[0], LinkObject::Sphere { centre: [0.01, 0.2, 0.0], radius, cavity: false, .. } if radius == 0.02)
        );
        assert!(matches!(objects[1], LinkObject::HalfSpace { normal: [0.0, 0.0, 1.0], .. }));
        let bad = "objects:\n  - sphere: {centre: [0, 0], radius: -1, stiffness: 1, damping: 0}\n";
        let error = parse_scene("s.yaml", bad).unwrap_err();
        assert!(error.starts_with("error: s.yaml:2:"), "{error}");
        assert!(error.contains("objects[0].sphere.radius: must be finite and positive, got -1"), "{error}");
        let unknown = "objects:\n  - cone: {centre: [0, 0]}\n";
        assert!(parse_scene("s.yaml", unknown).unwrap_err().starts_with("error: s.yaml:2:"));
        let five = format!(
            "objects:\n{}",
            "  - sphere: {centre: [0], radius: 1, stiffness: 1, damping: 0}\n".repeat(5)
        );
        let error = parse_scene("s.yaml", &five).unwrap_err();
        assert!(error.contains("objects[4].sphere: a device holds 4 objects, the file has 5"), "{error}");
        assert!(error.starts_with("error: s.yaml:6:"), "{error}");
        // What the link cannot carry is refused where it is written.
        let rough = "objects:\n  - sphere: {centre: [0], radius: 1, stiffness: 1, damping: 0,\n      \
                     friction: {static: 0.3, dynamic: 0.2}}\n";
        let error = parse_scene("s.yaml", rough).unwrap_err();
        assert!(error.starts_with("error: s.yaml:2:") && error.contains("carries no friction"), "{error}");
        let turned = "objects:\n  - box: {centre: [0, 0], half_extents: [1, 1], rotation: [0.5], stiffness: 1, damping: 0}\n";
        let error = parse_scene("s.yaml", turned).unwrap_err();
        assert!(error.starts_with("error: s.yaml:2:") && error.contains("axis-aligned boxes"), "{error}");
        let level = "objects:\n  - box: {centre: [0, 0], half_extents: [1, 1], stiffness: 1, damping: 0}\n";
        assert!(matches!(parse_scene("s.yaml", level).unwrap().objects[0], LinkObject::Box { .. }));
    }

    /// A scene's moving objects are sent where they are at the time asked: a sphere carried
    /// along its velocity, a half-space's point carried and its normal turned about the pivot,
    /// a lifted box; a turning box is refused where it is written (the device's boxes are
    /// axis-aligned), a still object is not among them.
    #[test]
    fn a_scene_s_moving_objects_are_sent_where_they_are() {
        let text = "objects:\n\
                    \x20 - sphere: {centre: [0.01, 0.2], radius: 0.02, stiffness: 1500, damping: 5,\n\
                    \x20           motion: {velocity: [0.1, 0]}}\n\
                    \x20 - half_space: {point: [0, 0.1], normal: [0, 1], stiffness: 1000, damping: 2,\n\
                    \x20               motion: {angular_velocity: [2], pivot: [0, 0]}}\n\
                    \x20 - box: {centre: [0, 0], half_extents: [0.01, 0.01], stiffness: 1, damping: 0}\n\
                    \x20 - box: {centre: [0, 0], half_extents: [0.01, 0.01], stiffness: 1, damping: 0,\n\
                    \x20         motion: {velocity: [0, -0.05]}}\n";
        let scene = parse_scene("s.yaml", text).unwrap();
        assert_eq!(scene.moving.iter().map(|m| m.slot).collect::<Vec<_>>(), vec![0, 1, 3]);
        // At time 0 where the file puts them.
        assert_eq!(
            scene.moved_objects(0.0).into_iter().map(|(_, o)| o).collect::<Vec<_>>(),
            vec![scene.objects[0], scene.objects[1], scene.objects[3]]
        );
        let close = |a: [f32; 3], b: [f32; 3]| a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-6);
        let quarter = std::f64::consts::FRAC_PI_4; // 2 rad/s: a quarter turn
        let moved = scene.moved_objects(quarter);
        let LinkObject::Sphere { centre, .. } = moved[0].1 else { panic!("{:?}", moved[0]) };
        assert!(close(centre, [0.01 + 0.1 * quarter as f32, 0.2, 0.0]), "{centre:?}");
        let LinkObject::HalfSpace { point, normal, .. } = moved[1].1 else { panic!("{:?}", moved[1]) };
        assert!(close(point, [-0.1, 0.0, 0.0]) && close(normal, [-1.0, 0.0, 0.0]), "{point:?} {normal:?}");
        let LinkObject::Box { centre, .. } = moved[2].1 else { panic!("{:?}", moved[2]) };
        assert!(close(centre, [0.0, -0.05 * quarter as f32, 0.0]), "{centre:?}");
        let turning =
            "objects:\n  - box: {centre: [0, 0], half_extents: [1, 1], stiffness: 1, damping: 0,\n      \
                       motion: {angular_velocity: [1], pivot: [0, 0]}}\n";
        let error = parse_scene("s.yaml", turning).unwrap_err();
        assert!(error.starts_with("error: s.yaml:2:") && error.contains("a turning box"), "{error}");
    }

    #[test]
    fn impedance_settings_are_checked() {
        let settings = parse_impedance("800, 2").unwrap();
        assert_eq!(settings.stiffness, [800.0; 3]);
        assert_eq!(settings.mass, [1.0; 3]);
        assert!(parse_impedance("800").is_err());
        assert!(parse_impedance("-1,2").is_err());
        assert!(parse_impedance("1,2,0").is_err());
        assert!(parse_impedance("1,NaN").is_err());
    }

    #[test]
    fn missing_ticks_wrap_around() {
        assert_eq!(missing_between(10, 11), 0);
        assert_eq!(missing_between(10, 13), 2);
        assert_eq!(missing_between(u16::MAX, 0), 0);
    }

    /// A refusal names the object's line and column in the scene file and why; a rendered
    /// object is no error (seen failing with the answers ignored: "scene: 1 objects loaded"
    /// for a half-space a 2-D device does not draw).
    #[test]
    fn a_refused_object_is_an_error_at_its_line() {
        let text =
            "objects:\n  - sphere: {centre: [0.01, 0.2], radius: 0.02, stiffness: 1500, damping: 5}\n  \
                    - half_space: {point: [0, 0, 0], normal: [0, 0, 1], stiffness: 1000, damping: 2}\n";
        let scene = parse_scene("s.yaml", text).unwrap();
        let answer = |slot, outcome| SceneAnswer { slot, outcome };
        assert_eq!(refusal(&scene, &answer(0, SceneOutcome::Rendered)), None);
        let error = refusal(&scene, &answer(1, SceneOutcome::NotRendered)).unwrap();
        assert!(error.starts_with("error: s.yaml:3:"), "{error}");
        assert!(error.contains("refused this half-space: the device does not render this kind"), "{error}");
        let error = refusal(&scene, &answer(0, SceneOutcome::BadValues)).unwrap();
        assert!(
            error.starts_with("error: s.yaml:2:") && error.contains("sphere: the device refused its values")
        );
        let error = refusal(&scene, &answer(3, SceneOutcome::NoSlot)).unwrap();
        assert!(error.starts_with("error: scene slot 3: the device refused this empty slot"), "{error}");
    }

    /// A device that starts again shows it in its state stream: the tick goes back, or the
    /// bridges drop without a fault; a gap of lost frames, a link fault or a device never
    /// enabled is no reset.
    #[test]
    fn a_device_reset_is_seen_in_the_state_stream() {
        let frame = |tick: u16, status: u8, fault: u8| {
            let mut frame = StateFrame::quantise(
                &hapticgen_protocol::StateSample {
                    tick: u32::from(tick),
                    enabled: status & StateFrame::ENABLED != 0,
                    exciting: false,
                    fault,
                    encoder_counts: &[0],
                    joint_velocity: &[0.0],
                    task_position: &[0.0],
                    task_velocity: &[0.0],
                    joint_torque: &[0.0],
                    motor_current: &[0.0],
                    tick_instructions: 0,
                },
                &hapticgen_protocol::ChannelScales::DESKTOP,
            )
            .unwrap();
            frame.status = status;
            frame
        };
        let on = StateFrame::ENABLED;
        assert!(device_reset(&frame(5000, on, 0), &frame(1, 0, 0), true));
        assert!(device_reset(&frame(5000, 0, 0), &frame(3, 0, 0), false));
        assert!(device_reset(&frame(60_000, on, 0), &frame(3, 0, 0), true));
        assert!(!device_reset(&frame(5000, on, 0), &frame(5001, on, 0), true));
        assert!(!device_reset(&frame(65_535, on, 0), &frame(2, on, 0), true));
        assert!(!device_reset(&frame(5000, on, 0), &frame(5040, 0, StateFrame::LINK_FAULT), true));
        assert!(!device_reset(&frame(5000, 0, 0), &frame(5001, 0, 0), false));
    }
}
