//! Processor in the loop (docs/link-pil.md): the image's rig and control path on the emulated
//! Cortex-M4F, the plant on the host (`hapticgen pil`), lock-step over UART0 (the CMSDK UART of
//! the MPS2-AN386; QEMU connects it to a TCP socket the host listens on).
//!
//! The session (protocol version 2, docs/link.md):
//!
//! 1. host `Hello` → device `Hello(DeviceInfo)`; host `SetImpedance`, `PilSetup` (law,
//!    estimator, zero offset, initial counts, fixed reference, force calibration), `Heartbeat`,
//!    `Enable`. The device builds its [`Controller`] from them, with the image's own
//!    model-derived current-loop gains.
//! 2. One exchange per current-loop period: host `Sensors` (encoder counts, filtered motor
//!    currents, force readings) → [`Controller::on_current_tick`], the interrupt body the
//!    self-contained image runs (current loop every period, impedance tick when the runtime's
//!    scheduler says so, fused law, safety monitor), on a board whose sensors are the frame's
//!    and whose bridges the link may hold off ([`Gated`]) → device `Actuators` (voltages,
//!    current setpoints, the impedance tick's torques, status, latched fault).
//! 3. Host `Disable`: the device prints its counts and costs over semihosting and exits 0.
//!
//! **Identification runs.** Before `PilSetup`, the host may send an excitation, one
//! `SetExcitation` per joint (a Fourier series, its period, blend and tracking bandwidth);
//! a `PilSetup` with `PilLaw::Excitation` then makes every impedance tick play it with the
//! runtime's joint-space tracking law (`hapticgen_fw_control::excitation`, `hapticgen pil --scenario excite`)
//! instead of an impedance law. The host logs what the device measured and commanded
//! for `hapticgen identify`.
//!
//! **Missing or corrupt frames.** Every byte goes through [`DeviceLink::receive`] (constant
//! time per byte, one bounded decoding per zero byte; corrupt frames are counted and dropped).
//! Once the run has started, a period waits for its sensor frame at most [`WAIT_TICKS`] of the
//! board's timer (virtual time); a period without one is *missed*: the bridges are off for it
//! and the controller does not run. A sensor frame counts as a heartbeat, so after
//! `LinkSettings::with_timeout_ms(5, …)` periods without one (37 at 7.5 kHz, 4.9 ms) the link
//! latches `HeartbeatLost`: the safe state. The image then prints
//! `PIL_SAFE missed_periods=… ms=…` and ends its run (exit status 0): the plant is on the host,
//! so there is nothing left to control.
//!
//! Output (semihosting): `CAL`, `PIL_READY`, then at the end `PIL_DONE` (periods, impedance
//! ticks, missed periods, the link's counters) and `PIL_COST part=…` in instructions
//! (`-icount shift=10`): `receive` (the sensor frame's bytes through the link), `control`
//! (`on_current_tick`: current loop, and the impedance tick when due), `encode` (framing the
//! answer), `write` (writing it to the UART: this waits on QEMU's socket, so it depends on
//! the host), `period` (receive, control and encode: the link's overhead included), and the
//! controller's own `current` and `impedance` costs.
#![no_std]
#![no_main]

// The board support of the images (timer, semihosting, exit, panic handler), shared as source.
#[allow(dead_code)]
#[path = "../qemu.rs"]
mod qemu;
// The polled UART the link talks through.
#[allow(dead_code)]
#[path = "../uart.rs"]
mod uart;

use cortex_m_rt::entry;
use hapticgen_fw_control::board::{CurrentSense, CycleCounter, Encoders, ForceSense, VoltageOutput};
use hapticgen_fw_control::excitation::{Excitation, ExcitationParts};
use hapticgen_fw_control::link::{DeviceLink, Gated, LinkEvent, LinkSettings};
use hapticgen_fw_control::link_scene::{device_info, first, LinkSource, SCENE_OBJECTS};
use hapticgen_fw_control::report::Line;
use hapticgen_fw_control::{Controller, CostStats};
use hapticgen_protocol::{
    encode, ActuatorFrame, DeviceMessage, PilLaw, PilSetup, SceneObject, SensorFrame, MAX_FRAME_BYTES,
    MAX_TASK,
};
use hapticgen_runtime::control::{
    ControlOptions, ControlStatus, ImpedanceController, ImpedanceLaw, ImpedanceParameters,
};
use hapticgen_runtime::estimation::{EstimatorSettings, ForceSensorCalibration, JointState};
use hapticgen_runtime::tick::HapticLoopSettings;
use uart::Uart0;

#[allow(clippy::all, dead_code)]
mod generated {
    include!(concat!(env!("OUT_DIR"), "/image.rs"));
}
use generated::image;

const N: usize = image::JOINTS;
const M: usize = image::TASK_DIM;
type Rig = image::Rig;
type Control = Controller<Rig, LinkSource<M>, N, M>;

/// How long a period of a started run waits for its sensor frame, in ticks of the 25 MHz APB
/// timer: 2.5 × 10⁸ ticks = 10 s of virtual time. The host computes the plant between two
/// frames while QEMU's virtual clock runs on as the core polls the UART (measured: about 9 s
/// of virtual time per second of real time, so this is about 1.1 s of real time, far above the
/// host's latency of about 10 ms per period), so it bounds the host's latency in emulated time;
/// it is not the control's deadline: the control's time is the count of periods, and the
/// link's watchdog counts periods without a sensor frame.
const WAIT_TICKS: u32 = 250_000_000;

/// The heartbeat timeout of the link (the link's 10 ms safe-state bound, docs/link.md, with a
/// margin), ms.
const LINK_TIMEOUT_MS: u32 = 5;

/// The board of a PIL run: its sensors are the last sensor frame's, its voltages go back to
/// the host.
struct PilBoard {
    counts: [i32; N],
    currents: [f32; N],
    readings: [f32; M],
    volts: [f32; N],
    driven: bool,
}

impl PilBoard {
    fn load(&mut self, frame: &SensorFrame) {
        for j in 0..N {
            self.counts[j] = frame.encoder_counts.get(j).copied().unwrap_or(0);
            self.currents[j] = frame.motor_current.get(j).copied().unwrap_or(0.0);
        }
        for k in 0..M {
            self.readings[k] = frame.force_readings.get(k).copied().unwrap_or(0.0);
        }
    }
}

impl Encoders<N> for PilBoard {
    fn counts(&mut self) -> [i32; N] {
        self.counts
    }
}

impl CurrentSense<f32, N> for PilBoard {
    fn currents(&mut self) -> [f32; N] {
        self.currents
    }
}

impl ForceSense<f32, M> for PilBoard {
    fn force_readings(&mut self) -> [f32; M] {
        self.readings
    }
}

impl VoltageOutput<f32, N> for PilBoard {
    fn set_voltages(&mut self, volts: &[f32; N]) {
        self.volts = *volts;
        self.driven = true;
    }
    fn disable(&mut self) {
        self.volts = [0.0; N];
        self.driven = false;
    }
}

/// The controller `setup` and `impedance` describe, with the image's own current-loop gains;
/// `None` if a value is unusable (non-finite, a cut-off not positive) or the rates are.
fn build(
    setup: &PilSetup,
    impedance: &ImpedanceParameters<f32, MAX_TASK>,
    objects: &[SceneObject; SCENE_OBJECTS],
) -> Option<Control> {
    let scalars = [
        setup.velocity_cutoff_hz,
        setup.acceleration_cutoff_hz,
        setup.min_abs_jacobian_determinant,
        setup.spring_lead_time,
    ];
    let finite = scalars.iter().chain(&setup.zero_offset).chain(&setup.reference).all(|v| v.is_finite())
        && setup.force_scale.iter().chain(&setup.force_offset).all(|v| v.is_finite());
    if !finite || setup.velocity_cutoff_hz <= 0.0 || setup.acceleration_cutoff_hz <= 0.0 {
        return None;
    }
    let law = match setup.law {
        PilLaw::ForceFeedback => ImpedanceLaw::ForceFeedback,
        PilLaw::AccelerationFeedback => ImpedanceLaw::AccelerationFeedback,
        PilLaw::NaturalInertia => ImpedanceLaw::NaturalInertia,
        PilLaw::JacobianTranspose => ImpedanceLaw::JacobianTranspose,
        // Never run: the excitation's joint-space law takes the impedance tick's place.
        PilLaw::Excitation => ImpedanceLaw::JacobianTranspose,
    };
    let settings = HapticLoopSettings {
        controller: ImpedanceController {
            law,
            parameters: ImpedanceParameters {
                stiffness: first(&impedance.stiffness),
                damping: first(&impedance.damping),
                mass: first(&impedance.mass),
            },
            options: ControlOptions {
                omit_damping_compensation: false,
                min_abs_jacobian_determinant: setup.min_abs_jacobian_determinant,
                spring_lead_time: setup.spring_lead_time,
                friction_compensation_band: None,
            },
        },
        estimator: EstimatorSettings {
            sample_period: 1.0 / image::IMPEDANCE_LOOP_HZ as f32,
            velocity_cutoff_hz: setup.velocity_cutoff_hz,
            acceleration_cutoff_hz: setup.acceleration_cutoff_hz,
        },
        zero_offset: first(&setup.zero_offset),
        initial_counts: first(&setup.initial_counts),
        force_calibration: ForceSensorCalibration {
            scale: first(&setup.force_scale),
            offset: first(&setup.force_offset),
        },
        current_gains: image::setup().current_gains,
        max_tick_gap: 1,
    };
    let source = LinkSource::new(first(&setup.reference), impedance, objects, setup.scene_grid_spacing)?;
    Controller::new(Rig::NOMINAL, source, &settings, false)
}

/// Counter ticks as instructions, from the ticks of [`qemu::KNOWN_INSTRUCTIONS`] instructions.
fn instructions(ticks: u32, cal_ticks: u32) -> i64 {
    (i64::from(ticks) * qemu::KNOWN_INSTRUCTIONS + i64::from(cal_ticks.max(1)) / 2)
        / i64::from(cal_ticks.max(1))
}

/// What a run counts besides the controller's own costs.
struct Tally {
    periods: u32,
    missed: u32,
    missed_in_a_row: u32,
    refused_setups: u32,
    uart_dropped: u32,
    receive: CostStats,
    control: CostStats,
    encode: CostStats,
    write: CostStats,
    period: CostStats,
}

fn report(
    out: &mut qemu::Semihosting,
    tally: &Tally,
    link: &DeviceLink,
    control: Option<&Control>,
    cal_ticks: u32,
) {
    let mut line = Line::new();
    let counters = link.counters();
    line.str("PIL_DONE").kv("periods", i64::from(tally.periods)).kv("missed", i64::from(tally.missed));
    line.kv("impedance_ticks", i64::from(control.map_or(0, |c| c.impedance_ticks())));
    line.kv("fault", i64::from(control.and_then(|c| c.first_fault).map_or(0, |(_, f)| f.number())));
    line.kv("frames", i64::from(counters.frames)).kv("dropped_frames", i64::from(counters.dropped()));
    line.kv("refused_setups", i64::from(tally.refused_setups))
        .kv("uart_dropped", i64::from(tally.uart_dropped));
    line.emit(out);
    let own = control.map(|c| (c.current_cost, c.impedance_cost));
    let (current, impedance) = own.unwrap_or((CostStats::EMPTY, CostStats::EMPTY));
    for (part, stats) in [
        ("receive", &tally.receive),
        ("control", &tally.control),
        ("encode", &tally.encode),
        ("write", &tally.write),
        ("period", &tally.period),
        ("current", &current),
        ("impedance", &impedance),
    ] {
        line.str("PIL_COST part=").str(part).kv("n", i64::from(stats.count));
        line.kv("min", instructions(if stats.count == 0 { 0 } else { stats.min }, cal_ticks));
        line.kv("mean", instructions(stats.mean(), cal_ticks)).kv("max", instructions(stats.max, cal_ticks));
        line.emit(out);
    }
}

#[entry]
fn main() -> ! {
    let counter = qemu::ApbCounter::start();
    let mut out = qemu::Semihosting::new();
    qemu::calibrate(&counter, &mut out);
    let overhead = {
        let mut best = u32::MAX;
        for _ in 0..16 {
            let a = counter.now();
            let b = counter.now();
            best = best.min(b.wrapping_sub(a));
        }
        best
    };
    let cal_ticks = {
        let a = counter.now();
        qemu::known_instructions();
        counter.now().wrapping_sub(a).saturating_sub(overhead)
    };
    let elapsed = |from: u32, to: u32| to.wrapping_sub(from).saturating_sub(overhead);
    let mut uart = Uart0::start();
    let mut link = DeviceLink::new(
        device_info(image::NAME, N, M, image::IMPEDANCE_LOOP_HZ),
        LinkSettings::with_timeout_ms(LINK_TIMEOUT_MS, image::CURRENT_LOOP_HZ),
    );
    let mut board =
        PilBoard { counts: [0; N], currents: [0.0; N], readings: [0.0; M], volts: [0.0; N], driven: false };
    let mut impedance: Option<ImpedanceParameters<f32, MAX_TASK>> = None;
    let mut objects = [SceneObject::Empty; SCENE_OBJECTS];
    let mut control: Option<Control> = None;
    let mut excitation_parts = ExcitationParts::<N>::EMPTY;
    let mut excitation: Option<Excitation<N>> = None;
    let mut torque = [0.0f32; N];
    let mut tally = Tally {
        periods: 0,
        missed: 0,
        missed_in_a_row: 0,
        refused_setups: 0,
        uart_dropped: 0,
        receive: CostStats::EMPTY,
        control: CostStats::EMPTY,
        encode: CostStats::EMPTY,
        write: CostStats::EMPTY,
        period: CostStats::EMPTY,
    };
    let mut running = false;
    let mut buffer = [0u8; MAX_FRAME_BYTES];
    let mut line = Line::new();
    line.str("PIL_READY variant=").str(image::NAME).kv("joints", N as i64).kv("task", M as i64);
    line.kv("current_loop_hz", i64::from(image::CURRENT_LOOP_HZ)).kv("wait_ticks", i64::from(WAIT_TICKS));
    line.emit(&mut out);
    loop {
        // One period of a started run (before the start: until the first sensor frame).
        let waiting_since = counter.now();
        let mut receive_ticks = 0u32;
        let mut sensors: Option<SensorFrame> = None;
        let mut ended = false;
        loop {
            match uart.read() {
                Some(byte) => {
                    let t0 = counter.now();
                    let event = link.receive::<f32>(byte);
                    receive_ticks = receive_ticks.saturating_add(elapsed(t0, counter.now()));
                    match event {
                        Some(LinkEvent::Hello) => {
                            if let Ok(length) = link.hello(&mut buffer) {
                                tally.uart_dropped += uart.write(buffer.get(..length).unwrap_or(&[]));
                            }
                        }
                        // Settings, setup and scene only before the run starts.
                        Some(LinkEvent::Impedance(parameters)) if !running => {
                            impedance = Some(parameters);
                        }
                        Some(LinkEvent::ExcitationJoint) if !running => {
                            if let Some(part) = link.excitation_joint() {
                                excitation_parts.add(part);
                            }
                        }
                        Some(LinkEvent::PilSetup) if !running => {
                            control = match (link.pil_setup(), impedance.as_ref()) {
                                (Some(setup), Some(p)) => build(setup, p, &objects),
                                _ => None,
                            };
                            excitation = None;
                            if link.pil_setup().map(|setup| setup.law) == Some(PilLaw::Excitation) {
                                // An excitation run needs a playable excitation.
                                excitation = excitation_parts.playable(image::IMPEDANCE_LOOP_HZ);
                                if excitation.is_none() {
                                    control = None;
                                }
                            }
                            if control.is_none() {
                                tally.refused_setups += 1;
                            }
                        }
                        Some(LinkEvent::Sensors) => {
                            sensors = link.sensors().copied();
                            break;
                        }
                        Some(LinkEvent::Disabled) if running => {
                            ended = true;
                            break;
                        }
                        Some(LinkEvent::Object { slot, object }) if !running => {
                            if let Some(entry) = objects.get_mut(usize::from(slot)) {
                                *entry = object;
                            }
                        }
                        _ => {}
                    }
                }
                None => {
                    if running && counter.now().wrapping_sub(waiting_since) > WAIT_TICKS {
                        break;
                    }
                }
            }
        }
        if ended {
            report(&mut out, &tally, &link, control.as_ref(), cal_ticks);
            qemu::exit(0);
        }
        if !running {
            if control.is_none() {
                // Sensors before a usable setup: not a run yet; the host is told with the
                // link's counters instead of an actuator frame.
                if sensors.is_some() {
                    if let Ok(length) = encode(&DeviceMessage::Link(link.counters()), &mut buffer) {
                        tally.uart_dropped += uart.write(buffer.get(..length).unwrap_or(&[]));
                    }
                }
                continue;
            }
            running = true;
        }
        let open = link.on_current_tick();
        tally.periods = tally.periods.wrapping_add(1);
        let frame = match (sensors, control.as_mut()) {
            (Some(frame), Some(control)) => {
                board.load(&frame);
                tally.missed_in_a_row = 0;
                let t0 = counter.now();
                let mut gated = Gated { board: &mut board, open };
                let outcome = match &excitation {
                    Some(play) => control.on_current_tick_joint(&mut gated, &counter, |tick| {
                        let reference = play.trajectory.reference(play.time(tick, image::IMPEDANCE_LOOP_HZ));
                        let tracking = play.tracking;
                        move |rig: &Rig, terms: &_, state: &JointState<f32, N>| {
                            tracking.torque(rig, terms, &state.position, &state.velocity, &reference)
                        }
                    }),
                    None => control.on_current_tick(&mut gated, &counter),
                };
                let t1 = counter.now();
                tally.control.record(elapsed(t0, t1));
                let mut status = 0u8;
                if let Some(report) = outcome.impedance {
                    torque = report.command.torque;
                    status |= ActuatorFrame::IMPEDANCE_TICK;
                    if report.command.any_clamped() {
                        status |= ActuatorFrame::CLAMPED;
                    }
                    if report.control_status == ControlStatus::SingularFallback {
                        status |= ActuatorFrame::FALLBACK;
                    }
                }
                if board.driven {
                    status |= ActuatorFrame::DRIVEN;
                }
                if link.fault().is_some() {
                    status |= ActuatorFrame::LINK_FAULT;
                }
                Some((
                    ActuatorFrame {
                        tick: frame.tick,
                        voltage: first(&board.volts),
                        current_setpoint: first(control.haptic.current_setpoints()),
                        torque: first(&torque),
                        reference: first(&control.haptic.source.last),
                        status,
                        fault: control.first_fault.map_or(0, |(_, f)| f.number()),
                        missed: tally.missed,
                    },
                    t0,
                ))
            }
            _ => {
                // No sensor frame in time: the bridges are off for this period.
                board.disable();
                tally.missed = tally.missed.saturating_add(1);
                tally.missed_in_a_row = tally.missed_in_a_row.saturating_add(1);
                None
            }
        };
        if let Some((answer, control_start)) = frame {
            let t2 = counter.now();
            let length = encode(&DeviceMessage::Actuators(answer), &mut buffer).unwrap_or(0);
            let t3 = counter.now();
            tally.uart_dropped += uart.write(buffer.get(..length).unwrap_or(&[]));
            let t4 = counter.now();
            tally.receive.record(receive_ticks);
            tally.encode.record(elapsed(t2, t3));
            tally.write.record(elapsed(t3, t4));
            // The period's own work: the link's receive, the control, the framing (the UART
            // write waits on QEMU's socket, whose speed is the host's, so it is left out).
            tally.period.record(receive_ticks.saturating_add(elapsed(control_start, t3)));
        }
        if link.fault().is_some() {
            // The safe state: report when it was reached (periods without a sensor frame, in
            // the control's time) and end the run.
            let missed_in_a_row = tally.missed_in_a_row;
            let mut line = Line::new();
            line.str("PIL_SAFE").kv("periods", i64::from(tally.periods));
            line.kv("missed_periods", i64::from(missed_in_a_row));
            line.kv("us", i64::from(missed_in_a_row) * 1_000_000 / i64::from(image::CURRENT_LOOP_HZ));
            line.emit(&mut out);
            report(&mut out, &tally, &link, control.as_ref(), cal_ticks);
            qemu::exit(0);
        }
    }
}
