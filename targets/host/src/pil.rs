//! Processor in the loop (docs/link-pil.md): the firmware image on the emulated Cortex-M4F (QEMU,
//! MPS2-AN386) closes the loop around the host's plant, lock-step over the board's UART.
//!
//! [`Pil::start`] binds a TCP socket on the loopback interface, starts QEMU with the image's
//! UART0 connected to it (`-serial tcp:…`, `-icount shift=10`), and opens the link: `Hello`
//! (protocol version and the image's shape are checked), then `SetImpedance`, `PilSetup`,
//! `Heartbeat`, `Enable`. [`Pil`] is then a [`DeviceController`]: each current-loop period
//! of [`crate::closed_loop::run_with`] sends one `Sensors` frame (encoder counts, measured currents,
//! force readings) and waits for the `Actuators` frame that answers it. The plant, the
//! operator, the sensors and the trace are those of `hapticgen simulate`, the same code.
//! [`Pil::finish`] sends `Disable`, waits for QEMU to exit and returns the image's report
//! (`PIL_DONE`, `PIL_COST` lines: counts and instructions per period).
//!
//! Where the image and QEMU are found: [`locate_image`], [`locate_qemu`].

use std::io::{Read, Write};
use std::net::{TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use hapticgen_protocol::{
    encode, ActuatorFrame, DeviceMessage, ExcitationJoint, FrameDecoder, HostMessage, ImpedanceSettings,
    PilLaw, PilSetup, SceneObject, SensorFrame, MAX_FRAME_BYTES, MAX_JOINTS, MAX_TASK, PROTOCOL_VERSION,
};
use hapticgen_runtime::control::ImpedanceLaw;
use hapticgen_runtime::tick::HapticLoopSettings;

use crate::closed_loop::{DeviceController, ImpedanceOutcome, PeriodCommand, PeriodSensors};

/// How long the host waits for QEMU to connect, and for any one answer of the firmware.
pub const ANSWER_TIMEOUT: Duration = Duration::from_secs(20);

/// How long the host waits, once silent (fault test), for the image to reach its safe state
/// and exit.
pub const SAFE_STATE_TIMEOUT: Duration = Duration::from_secs(300);

/// The firmware workspace's table of images (`targets/firmware/variants.txt`).
pub fn variants_file() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../firmware/variants.txt")
}

/// A line of `variants.txt` that holds an image: its number (1-based) and its fields.
type TableLine = (usize, Vec<String>);

/// The lines of `variants.txt` that hold an image, comments dropped; and the table's path, for
/// messages.
fn table_lines() -> Result<(PathBuf, Vec<TableLine>), String> {
    let table = variants_file();
    let text = std::fs::read_to_string(&table)
        .map_err(|e| format!("error: cannot read the firmware's table of images {}: {e}", table.display()))?;
    let lines = text
        .lines()
        .enumerate()
        .map(|(index, line)| {
            (index + 1, line.split('#').next().unwrap_or("").split_whitespace().map(str::to_string).collect())
        })
        .filter(|(_, fields): &TableLine| !fields.is_empty())
        .collect();
    Ok((table, lines))
}

/// The image name (a line of `variants.txt`) for `model` and `variant`: the line whose model
/// file has the same name and whose variant is `variant` (`-` for none).
pub fn image_name(model: &Path, variant: Option<&str>) -> Result<String, String> {
    let (table, lines) = table_lines()?;
    let file = model.file_name().map(|f| f.to_string_lossy().into_owned()).unwrap_or_default();
    let wanted = variant.unwrap_or("-");
    let mut candidates = Vec::new();
    for (_, fields) in &lines {
        if fields.len() < 3 {
            continue;
        }
        let (name, model_path, line_variant) = (&fields[0], &fields[1], &fields[2]);
        if Path::new(model_path).file_name().map(|f| f.to_string_lossy().into_owned()) == Some(file.clone()) {
            if line_variant == wanted {
                return Ok(name.to_string());
            }
            candidates.push(format!("{name} (variant {line_variant})"));
        }
    }
    Err(if candidates.is_empty() {
        format!("error: no firmware image in {} is built from {file}", table.display())
    } else {
        format!(
            "error: no firmware image of {file} with variant {wanted}; images of it: {} (choose with --variant)",
            candidates.join(", ")
        )
    })
}

/// The image name to run: `given` (`--image-name`, for a model file no line of `variants.txt`
/// is built from, such as an identified one: the line the image was built from with
/// `HAPTICGEN_FW_MODEL`), which must be a line of the table; else [`image_name`] of `model`.
pub fn chosen_image_name(given: Option<&str>, model: &Path, variant: Option<&str>) -> Result<String, String> {
    let Some(name) = given else { return image_name(model, variant) };
    let (table, lines) = table_lines()?;
    let names: Vec<&str> = lines.iter().map(|(_, fields)| fields[0].as_str()).collect();
    if names.contains(&name) {
        Ok(name.to_string())
    } else {
        Err(format!(
            "error: --image-name {name}: no such line in {} (known: {})",
            table.display(),
            names.join(", ")
        ))
    }
}

/// The start pose of the firmware image `name` (its line of `variants.txt`, degrees or mm) in
/// `model`'s units (rad, m): where a device image is homed (its encoders read 0 there).
pub fn image_pose(name: &str, model: &hapticgen_codegen::CheckedModel) -> Result<Vec<f64>, String> {
    let (table, lines) = table_lines()?;
    for (number, fields) in &lines {
        if fields[0] != name {
            continue;
        }
        let at = format!("{}:{number}", table.display());
        let values = fields
            .get(4)
            .ok_or_else(|| format!("error: {at}: no pose column"))?
            .split(',')
            .map(|v| v.parse::<f64>().map_err(|_| format!("error: {at}: pose value `{v}` is not a number")))
            .collect::<Result<Vec<f64>, String>>()?;
        if values.len() != model.joints.len() {
            return Err(format!(
                "error: {at}: the pose has {} values, the model {} joints",
                values.len(),
                model.joints.len()
            ));
        }
        return Ok(values
            .iter()
            .zip(&model.joints)
            .map(|(&x, joint)| match joint.kind {
                hapticgen_codegen::model::JointKind::Revolute => x / 180.0 * std::f64::consts::PI,
                hapticgen_codegen::model::JointKind::Prismatic => x / 1000.0,
            })
            .collect());
    }
    Err(format!("error: no image `{name}` in {}", table.display()))
}

/// The PIL image of `name`: `explicit` if given, else `$HAPTICGEN_PIL_IMAGE`, else
/// `<target dir>/images/<name>.pil.elf` where `scripts/firmware.sh --only pil` puts it
/// (`$CARGO_TARGET_DIR`, else the firmware workspace's `target/`). A clear error names every
/// place looked at and how to build it.
pub fn locate_image(name: &str, explicit: Option<&Path>) -> Result<PathBuf, String> {
    let mut tried = Vec::new();
    let mut candidates: Vec<PathBuf> = Vec::new();
    if let Some(path) = explicit {
        candidates.push(path.to_path_buf());
    } else {
        if let Some(path) = std::env::var_os("HAPTICGEN_PIL_IMAGE") {
            candidates.push(PathBuf::from(path));
        }
        let file = format!("images/{name}.pil.elf");
        if let Some(dir) = std::env::var_os("CARGO_TARGET_DIR") {
            candidates.push(PathBuf::from(dir).join(&file));
        }
        candidates.push(Path::new(env!("CARGO_MANIFEST_DIR")).join("../firmware/target").join(&file));
    }
    for path in candidates {
        if path.is_file() {
            return Ok(path);
        }
        tried.push(path.display().to_string());
    }
    Err(format!(
        "error: no PIL firmware image for `{name}`; looked at: {}. Build it with `scripts/firmware.sh --only pil` \
         (same CARGO_TARGET_DIR), or name it with --image",
        tried.join(", ")
    ))
}

/// `qemu-system-arm`: `explicit` if given, else the first on `PATH`.
pub fn locate_qemu(explicit: Option<&Path>) -> Result<PathBuf, String> {
    if let Some(path) = explicit {
        return if path.is_file() {
            Ok(path.to_path_buf())
        } else {
            Err(format!("error: --qemu {}: no such file", path.display()))
        };
    }
    let path = std::env::var_os("PATH").unwrap_or_default();
    std::env::split_paths(&path).map(|dir| dir.join("qemu-system-arm")).find(|p| p.is_file()).ok_or_else(
        || {
            "error: qemu-system-arm is not on PATH (install it: apt-get install qemu-system-arm; \
         scripts/firmware.sh does), or name it with --qemu"
                .to_string()
        },
    )
}

/// A planar scene the device renders in a PIL run (`PilSetup::scene_grid_spacing`).
#[derive(Clone, Debug, PartialEq)]
pub struct PilScene {
    /// The objects, one slot each.
    pub objects: Vec<SceneObject>,
    /// Free-space stiffness (must equal the target impedance's: the device uses that).
    pub free_stiffness: f64,
    /// Free-space damping (likewise).
    pub free_damping: f64,
    /// Anti-drift grid spacing, m.
    pub grid_spacing: f64,
}

/// What the image plays in a PIL run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PilPlay<'a> {
    /// The impedance law of the settings, with a fixed reference or a planar scene the device
    /// renders.
    Impedance {
        /// The fixed task-space reference (a scene's starts there too).
        reference: [f64; MAX_TASK],
        /// The scene, if any.
        scene: Option<&'a PilScene>,
    },
    /// An identification excitation, one message per joint, played with the runtime's
    /// joint-space tracking law instead of an impedance law (`PilLaw::Excitation`).
    Excitation(&'a [ExcitationJoint]),
}

/// What the image reported at the end of a run.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PilReport {
    /// Sensor frames the host sent corrupted ([`Pil::corrupt_every`]).
    pub corrupted: u64,
    /// Non-empty zero-delimited runs of random bytes the host sent ([`Pil::garbage_every`]):
    /// each is one frame the image must drop.
    pub garbage_frames: u64,
    /// Every `PIL_…` line the image printed, in order.
    pub lines: Vec<String>,
    /// The image's whole semihosting output.
    pub output: String,
}

impl PilReport {
    /// The integer `key=` of the first line starting with `prefix` (and containing `part`).
    pub fn value(&self, prefix: &str, part: Option<&str>, key: &str) -> Option<i64> {
        let line = self.lines.iter().find(|l| {
            l.split_whitespace().next() == Some(prefix)
                && part.is_none_or(|p| l.split_whitespace().any(|w| w == format!("part={p}")))
        })?;
        line.split_whitespace().find_map(|w| w.strip_prefix(&format!("{key}=")).and_then(|v| v.parse().ok()))
    }
}

/// The firmware on QEMU as the controller of a run.
pub struct Pil<const N: usize, const M: usize> {
    qemu: Child,
    stream: TcpStream,
    decoder: FrameDecoder,
    pending: Vec<u8>,
    output: PathBuf,
    reference: [f64; M],
    torque: [f64; N],
    tick: u16,
    period: u64,
    /// Stop sending sensor frames after this many periods (a fault test: the firmware must
    /// reach its safe state); `None`: never.
    pub stop_after: Option<u64>,
    /// Fault test: before every `n`-th sensor frame, send a copy with one bit flipped (the
    /// device must count and drop it, and run the period on the good frame that follows).
    pub corrupt_every: Option<u64>,
    /// Sensor frames sent corrupted so far.
    pub corrupted: u64,
    /// Fault test: before every `n`-th sensor frame, send [`GARBAGE_BURST_BYTES`] random bytes
    /// (zeros among them, so several frames of garbage) and a closing zero; the device must
    /// drop every one and still answer the good frame in the same period.
    pub garbage_every: Option<u64>,
    /// Zero-delimited runs of garbage sent so far (the frames the device must drop).
    pub garbage_frames: u64,
    /// The garbage generator's state (xorshift64: the same bytes on every run).
    garbage_state: u64,
}

/// Bytes in one burst of garbage ([`Pil::garbage_every`]): more than a sensor frame, less than
/// the device's largest frame, so that bursts test the parser and never its overflow.
pub const GARBAGE_BURST_BYTES: usize = 96;

fn law_of(law: ImpedanceLaw) -> PilLaw {
    match law {
        ImpedanceLaw::ForceFeedback => PilLaw::ForceFeedback,
        ImpedanceLaw::AccelerationFeedback => PilLaw::AccelerationFeedback,
        ImpedanceLaw::NaturalInertia => PilLaw::NaturalInertia,
        ImpedanceLaw::JacobianTranspose => PilLaw::JacobianTranspose,
    }
}

fn padded<const K: usize, T: Copy + Default, U: Copy>(values: &[U], f: impl Fn(U) -> T) -> [T; K] {
    let mut out = [T::default(); K];
    for (slot, &value) in out.iter_mut().zip(values) {
        *slot = f(value);
    }
    out
}

impl<const N: usize, const M: usize> Pil<N, M> {
    /// Starts QEMU with `image`, its semihosting output to `output`, and opens the link with
    /// the controller `settings` (the same settings `hapticgen simulate` gives the runtime) and
    /// what the run plays. `name` is the image's name (its hash is checked against the image's
    /// `DeviceInfo`).
    pub fn start(
        qemu: &Path,
        image: &Path,
        name: &str,
        output: &Path,
        settings: &HapticLoopSettings<f64, N, M>,
        play: PilPlay,
    ) -> Result<Self, String> {
        if N > MAX_JOINTS || M > MAX_TASK {
            return Err(format!(
                "error: the link carries at most {MAX_JOINTS} joints and {MAX_TASK} task axes"
            ));
        }
        let listener = TcpListener::bind("127.0.0.1:0")
            .map_err(|e| format!("error: cannot listen on 127.0.0.1: {e}"))?;
        let port = listener.local_addr().map_err(|e| format!("error: {e}"))?.port();
        let log = std::fs::File::create(output)
            .map_err(|e| format!("error: cannot create {}: {e}", output.display()))?;
        let errors = log.try_clone().map_err(|e| format!("error: {e}"))?;
        let mut child = Command::new(qemu)
            .args(["-machine", "mps2-an386", "-cpu", "cortex-m4", "-nographic", "-icount", "shift=10"])
            .args(["-semihosting-config", "enable=on,target=native", "-monitor", "none"])
            .arg("-serial")
            .arg(format!("tcp:127.0.0.1:{port},nodelay=on"))
            .arg("-kernel")
            .arg(image)
            .stdin(Stdio::null())
            .stdout(log)
            .stderr(errors)
            .spawn()
            .map_err(|e| format!("error: cannot start {}: {e}", qemu.display()))?;
        listener.set_nonblocking(true).map_err(|e| format!("error: {e}"))?;
        let started = Instant::now();
        let stream = loop {
            match listener.accept() {
                Ok((stream, _)) => break stream,
                Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {
                    if let Ok(Some(status)) = child.try_wait() {
                        let text = std::fs::read_to_string(output).unwrap_or_default();
                        return Err(format!(
                            "error: QEMU exited ({status}) before connecting its UART:\n{text}"
                        ));
                    }
                    if started.elapsed() > ANSWER_TIMEOUT {
                        let _ = child.kill();
                        let _ = child.wait();
                        return Err("error: QEMU did not connect its UART in time".into());
                    }
                    std::thread::sleep(Duration::from_millis(5));
                }
                Err(e) => {
                    let _ = child.kill();
                    let _ = child.wait();
                    return Err(format!("error: accepting QEMU's UART connection: {e}"));
                }
            }
        };
        let setup = |stream: TcpStream| -> Result<TcpStream, String> {
            stream.set_nonblocking(false).map_err(|e| format!("error: {e}"))?;
            stream.set_nodelay(true).map_err(|e| format!("error: {e}"))?;
            stream.set_read_timeout(Some(ANSWER_TIMEOUT)).map_err(|e| format!("error: {e}"))?;
            Ok(stream)
        };
        let stream = match setup(stream) {
            Ok(stream) => stream,
            Err(e) => {
                let _ = child.kill();
                let _ = child.wait();
                return Err(e);
            }
        };
        let mut pil = Pil {
            qemu: child,
            stream,
            decoder: FrameDecoder::new(),
            pending: Vec::new(),
            output: output.to_path_buf(),
            reference: match play {
                PilPlay::Impedance { reference, .. } => std::array::from_fn(|k| reference[k]),
                PilPlay::Excitation(_) => [f64::NAN; M],
            },
            torque: [0.0; N],
            tick: 0,
            period: 0,
            stop_after: None,
            corrupt_every: None,
            corrupted: 0,
            garbage_every: None,
            garbage_frames: 0,
            garbage_state: 0x9e37_79b9_7f4a_7c15,
        };
        if let Err(e) = pil.open(name, settings, play) {
            pil.abort();
            return Err(e);
        }
        Ok(pil)
    }

    fn open(
        &mut self,
        name: &str,
        settings: &HapticLoopSettings<f64, N, M>,
        play: PilPlay,
    ) -> Result<(), String> {
        self.send(&HostMessage::Hello { version: PROTOCOL_VERSION })?;
        let info = loop {
            if let DeviceMessage::Hello(info) = self.receive()? {
                break info;
            }
        };
        if info.version != PROTOCOL_VERSION {
            return Err(format!(
                "error: the image speaks protocol version {}, this host {PROTOCOL_VERSION}: rebuild it",
                info.version
            ));
        }
        if (usize::from(info.joints), usize::from(info.task_dim)) != (N, M)
            || info.rig_name_hash != hapticgen_protocol::rig_name_hash(name)
        {
            return Err(format!(
                "error: the image is not `{name}` ({} joints, {} task axes, name hash {:#x}): rebuild it",
                info.joints, info.task_dim, info.rig_name_hash
            ));
        }
        let (reference, scene) = match play {
            PilPlay::Impedance { reference, scene } => (reference, scene),
            PilPlay::Excitation(joints) => {
                if joints.len() != N {
                    return Err(format!("error: an excitation of {} joints for a rig of {N}", joints.len()));
                }
                for joint in joints {
                    self.send(&HostMessage::SetExcitation(*joint))?;
                }
                ([0.0; MAX_TASK], None)
            }
        };
        if let Some(scene) = scene {
            if M != 2 {
                return Err("error: a scene needs a 2-D task".into());
            }
            let (k, b) =
                (settings.controller.parameters.stiffness[0], settings.controller.parameters.damping[0]);
            if (scene.free_stiffness, scene.free_damping) != (k, b) {
                return Err(format!(
                    "error: the device renders free space with the target impedance (K_d = {k}, B_d = {b}); \
                     this scene's free space has K = {}, B = {}",
                    scene.free_stiffness, scene.free_damping
                ));
            }
            for (slot, object) in scene.objects.iter().enumerate() {
                let slot = u8::try_from(slot).map_err(|_| "error: too many scene objects".to_string())?;
                self.send(&HostMessage::SetObject { slot, object: *object })?;
            }
        }
        let parameters = &settings.controller.parameters;
        let to_f32 = |v: f64| v as f32;
        self.send(&HostMessage::SetImpedance(ImpedanceSettings {
            stiffness: padded(&parameters.stiffness, to_f32),
            damping: padded(&parameters.damping, to_f32),
            // The axes the rig does not have get a unit mass: the device refuses a mass that
            // is not positive.
            mass: {
                let mut mass = [1.0f32; MAX_TASK];
                for (slot, &m) in mass.iter_mut().zip(&parameters.mass) {
                    *slot = m as f32;
                }
                mass
            },
        }))?;
        let options = &settings.controller.options;
        self.send(&HostMessage::PilSetup(PilSetup {
            law: match play {
                PilPlay::Impedance { .. } => law_of(settings.controller.law),
                PilPlay::Excitation(_) => PilLaw::Excitation,
            },
            velocity_cutoff_hz: settings.estimator.velocity_cutoff_hz as f32,
            acceleration_cutoff_hz: settings.estimator.acceleration_cutoff_hz as f32,
            zero_offset: padded(&settings.zero_offset, to_f32),
            initial_counts: padded(&settings.initial_counts, |c| c),
            reference: reference.map(to_f32),
            force_scale: padded(&settings.force_calibration.scale, to_f32),
            force_offset: padded(&settings.force_calibration.offset, to_f32),
            min_abs_jacobian_determinant: options.min_abs_jacobian_determinant as f32,
            spring_lead_time: options.spring_lead_time as f32,
            scene_grid_spacing: scene.map(|s| s.grid_spacing as f32),
        }))?;
        self.send(&HostMessage::Heartbeat { sequence: 0 })?;
        self.send(&HostMessage::Enable)
    }

    fn send(&mut self, message: &HostMessage) -> Result<(), String> {
        let mut frame = [0u8; MAX_FRAME_BYTES];
        let length = encode(message, &mut frame).map_err(|e| format!("error: framing {message:?}: {e:?}"))?;
        self.stream
            .write_all(&frame[..length])
            .map_err(|e| format!("error: writing to the firmware's UART: {e}"))
    }

    /// Sends `message` with one bit flipped in the middle of its frame (never making a zero
    /// byte, so it stays one frame): CRC-16 detects every one-bit error, so the device must
    /// drop it.
    fn send_corrupted(&mut self, message: &HostMessage) -> Result<(), String> {
        let mut frame = [0u8; MAX_FRAME_BYTES];
        let length = encode(message, &mut frame).map_err(|e| format!("error: framing {message:?}: {e:?}"))?;
        let middle = length / 2;
        frame[middle] ^= if frame[middle] == 1 { 2 } else { 1 };
        self.corrupted += 1;
        self.stream
            .write_all(&frame[..length])
            .map_err(|e| format!("error: writing to the firmware's UART: {e}"))
    }

    /// Sends a burst of random bytes, then a zero (so the next frame starts clean), and counts
    /// the frames of garbage it makes: its non-empty zero-delimited runs.
    fn send_garbage(&mut self) -> Result<(), String> {
        let mut burst = [0u8; GARBAGE_BURST_BYTES + 1];
        for byte in burst.iter_mut().take(GARBAGE_BURST_BYTES) {
            self.garbage_state ^= self.garbage_state << 13;
            self.garbage_state ^= self.garbage_state >> 7;
            self.garbage_state ^= self.garbage_state << 17;
            // One byte in eight a zero: several short frames of garbage per burst.
            let draw = (self.garbage_state >> 32) as u8;
            *byte = if draw.is_multiple_of(8) { 0 } else { draw };
        }
        self.garbage_frames += burst.split(|&b| b == 0).filter(|run| !run.is_empty()).count() as u64;
        self.stream.write_all(&burst).map_err(|e| format!("error: writing to the firmware's UART: {e}"))
    }

    /// The next valid message from the device (corrupt frames are counted by the decoder and
    /// skipped).
    fn receive(&mut self) -> Result<DeviceMessage, String> {
        loop {
            while !self.pending.is_empty() {
                let byte = self.pending.remove(0);
                if let Some(message) = self.decoder.push::<DeviceMessage>(byte) {
                    return Ok(message);
                }
            }
            let mut chunk = [0u8; 256];
            match self.stream.read(&mut chunk) {
                Ok(0) => return Err(self.died("the firmware closed its UART")),
                Ok(n) => self.pending.extend_from_slice(&chunk[..n]),
                Err(e)
                    if matches!(e.kind(), std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut) =>
                {
                    return Err(
                        self.died(&format!("no answer from the firmware in {} s", ANSWER_TIMEOUT.as_secs()))
                    )
                }
                Err(e) => return Err(self.died(&format!("reading the firmware's UART: {e}"))),
            }
        }
    }

    fn died(&mut self, what: &str) -> String {
        let _ = self.qemu.kill();
        let _ = self.qemu.wait();
        let text = std::fs::read_to_string(&self.output).unwrap_or_default();
        format!("error: {what} (period {}); its output:\n{text}", self.period)
    }

    fn abort(&mut self) {
        let _ = self.qemu.kill();
        let _ = self.qemu.wait();
    }

    /// Ends the run: `Disable`, then waits (at most [`ANSWER_TIMEOUT`]) for QEMU to exit and
    /// reads the image's report. With [`Pil::stop_after`], the host has stopped sending and
    /// the image ends the run itself at its safe state.
    pub fn finish(mut self) -> Result<PilReport, String> {
        if self.stop_after.is_none() {
            self.send(&HostMessage::Disable)?;
        }
        // Silent host: the image first waits out its watchdog's periods (each a bounded wait for
        // a sensor frame, a fraction of a second of real time), then reports and exits.
        let patience = if self.stop_after.is_some() { SAFE_STATE_TIMEOUT } else { ANSWER_TIMEOUT };
        let started = Instant::now();
        let status = loop {
            match self.qemu.try_wait() {
                Ok(Some(status)) => break status,
                Ok(None) if started.elapsed() < patience => std::thread::sleep(Duration::from_millis(10)),
                _ => return Err(self.died("QEMU did not exit after the run")),
            }
        };
        let output = std::fs::read_to_string(&self.output).unwrap_or_default();
        if !status.success() {
            return Err(format!("error: QEMU exited with {status}; the image's output:\n{output}"));
        }
        let lines = output.lines().filter(|l| l.starts_with("PIL_")).map(str::to_string).collect();
        Ok(PilReport { corrupted: self.corrupted, garbage_frames: self.garbage_frames, lines, output })
    }
}

impl<const N: usize, const M: usize> DeviceController<N, M> for Pil<N, M> {
    fn period(&mut self, sensors: &PeriodSensors<N, M>) -> Result<PeriodCommand<N, M>, String> {
        if self.stop_after.is_some_and(|stop| self.period >= stop) {
            // The fault test: the host has gone silent; the plant coasts with no voltage.
            self.period += 1;
            return Ok(PeriodCommand {
                volts: [0.0; N],
                current_setpoints: [0.0; N],
                impedance: None,
                reference: self.reference,
                hip: [f64::NAN; M],
                rendered_at: f64::NAN,
            });
        }
        self.tick = self.tick.wrapping_add(1);
        let readings = sensors.force_readings.unwrap_or([0.0; M]);
        let frame = HostMessage::Sensors(SensorFrame {
            tick: self.tick,
            encoder_counts: padded(&sensors.encoder_counts, |c| c),
            motor_current: padded(&sensors.measured_current, |v: f64| v as f32),
            force_readings: padded(&readings, |v: f64| v as f32),
        });
        if self.corrupt_every.is_some_and(|n| n > 0 && (self.period + 1).is_multiple_of(n)) {
            self.send_corrupted(&frame)?;
        }
        if self.garbage_every.is_some_and(|n| n > 0 && (self.period + 1).is_multiple_of(n)) {
            self.send_garbage()?;
        }
        self.send(&frame)?;
        let answer: ActuatorFrame = loop {
            match self.receive()? {
                DeviceMessage::Actuators(frame) if frame.tick == self.tick => break frame,
                DeviceMessage::Link(counters) => {
                    return Err(self.died(&format!(
                        "the firmware refused the run's settings (not finite, or out of range) and answers \
                         the sensor frames with its link counters: {counters:?}"
                    )))
                }
                _ => {}
            }
        };
        let ran = answer.status & ActuatorFrame::IMPEDANCE_TICK != 0;
        if ran != sensors.force_readings.is_some() {
            return Err(self.died(&format!(
                "the firmware's impedance schedule differs from the host's (firmware ran a tick: {ran})"
            )));
        }
        if answer.missed != 0 {
            return Err(self.died(&format!("the firmware missed {} sensor frames", answer.missed)));
        }
        let widen =
            |values: &[f32; MAX_JOINTS]| -> [f64; N] { std::array::from_fn(|j| f64::from(values[j])) };
        let impedance = ran.then(|| {
            self.torque = widen(&answer.torque);
            ImpedanceOutcome {
                torque: self.torque,
                clamped: answer.status & ActuatorFrame::CLAMPED != 0,
                fallback: answer.status & ActuatorFrame::FALLBACK != 0,
                fault: (answer.fault != 0).then(|| format!("firmware fault code {}", answer.fault)),
            }
        });
        self.period += 1;
        self.reference = std::array::from_fn(|k| f64::from(answer.reference[k]));
        Ok(PeriodCommand {
            volts: widen(&answer.voltage),
            current_setpoints: widen(&answer.current_setpoint),
            impedance,
            reference: self.reference,
            // The firmware does not send the task position it measured.
            hip: [f64::NAN; M],
            rendered_at: f64::NAN,
        })
    }
}

impl<const N: usize, const M: usize> Drop for Pil<N, M> {
    fn drop(&mut self) {
        // QEMU never outlives the run (it has exited already after `finish`).
        if let Ok(None) = self.qemu.try_wait() {
            let _ = self.qemu.kill();
            let _ = self.qemu.wait();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The image of a model is the line of `variants.txt` with its file and variant; a model
    /// whose lines all have variants needs one.
    #[test]
    fn image_names_come_from_the_table() {
        assert_eq!(image_name(Path::new("models/joystick_1dof.yaml"), None), Ok("joystick".to_string()));
        assert_eq!(
            image_name(Path::new("elsewhere/parallel_link_2dof.yaml"), Some("horizontal")),
            Ok("horizontal".to_string())
        );
        let missing = image_name(Path::new("models/parallel_link_2dof.yaml"), None).unwrap_err();
        assert!(
            missing.contains("vertical (variant vertical)") && missing.contains("--variant"),
            "{missing}"
        );
        let unknown = image_name(Path::new("models/nothing.yaml"), None).unwrap_err();
        assert!(unknown.contains("no firmware image"), "{unknown}");
        // An identified file is run as the line it was built from; a name that is no line is refused.
        let identified = Path::new("out/identified.yaml");
        assert!(image_name(identified, None).is_err());
        assert_eq!(chosen_image_name(Some("joystick"), identified, None), Ok("joystick".to_string()));
        assert_eq!(
            chosen_image_name(None, Path::new("models/joystick_1dof.yaml"), None),
            Ok("joystick".to_string())
        );
        let refused = chosen_image_name(Some("joystik"), identified, None).unwrap_err();
        assert!(
            refused.contains("--image-name joystik: no such line") && refused.contains("joystick,"),
            "{refused}"
        );
    }

    /// The report's `key=value` lines are read back.
    #[test]
    fn report_values_are_read_by_prefix_and_part() {
        let report = PilReport {
            lines: vec![
                "PIL_SAFE periods=1912 missed_periods=37 us=4933".into(),
                "PIL_COST part=receive n=3 min=1 mean=2 max=3".into(),
                "PIL_COST part=send n=3 min=4 mean=5 max=6".into(),
            ],
            output: String::new(),
            corrupted: 0,
            garbage_frames: 0,
        };
        assert_eq!(report.value("PIL_SAFE", None, "us"), Some(4933));
        assert_eq!(report.value("PIL_COST", Some("send"), "max"), Some(6));
        assert_eq!(report.value("PIL_DONE", None, "periods"), None);
    }
}
