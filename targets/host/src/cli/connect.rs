//! `hapticgen connect`: drives a running device over its link as an application does (the
//! link itself, the session and the safety checks are [`crate::connect`]): the settings and
//! the scene sent after each handshake, heartbeats, a live status line, the state stream
//! logged to CSV, a device that starts again handled. With `--excite`, an identification run
//! on the device instead (`connect_excite`).

use std::path::Path;
use std::time::Duration;

use hapticgen_protocol::{CountUnwrapper, HostMessage, StateFrame};

use super::args::ConnectArgs;
use super::CliError;
use crate::connect::{self as link, ArrivedState, Event, Session};
use crate::identify::experiment::{excitation_messages, tracking_errors, DeviceSample, TRACKING_HZ};
use crate::simulation::Simulation;

/// `hapticgen connect`: opens the link, configures the device, stays connected for
/// `--duration` and prints what it saw; fails if one of the safety checks fails.
pub fn connect(args: ConnectArgs) -> Result<(), CliError> {
    if let Some(trajectory) = &args.excite {
        return connect_excite(&args, trajectory);
    }
    let duration = args.duration.unwrap_or(5.0);
    if !(duration.is_finite() && duration >= 0.0) {
        return Err(CliError::Usage(format!(
            "--duration must be a finite, non-negative time, got {duration}"
        )));
    }
    if !(args.motion_period.is_finite() && args.motion_period >= 1.0) {
        return Err(CliError::Usage(format!(
            "--motion-period must be at least 1 ms, got {}",
            args.motion_period
        )));
    }
    let motion_period = std::time::Duration::from_secs_f64(args.motion_period * 1e-3);
    let impedance =
        args.impedance.as_deref().map(link::parse_impedance).transpose().map_err(CliError::Input)?;
    let scene = args.scene.as_deref().map(link::load_scene).transpose().map_err(CliError::Input)?;
    let mut session = Session::open(&args.port).map_err(CliError::Link)?;
    let info = session.info;
    println!(
        "connected: protocol {}, {} joints, {} task axes, impedance loop {} Hz, rig name hash {:08x}",
        info.version, info.joints, info.task_dim, info.impedance_loop_hz, info.rig_name_hash
    );
    // The settings and the scene, sent after each Hello (again if the device starts afresh).
    let configure = |session: &mut Session| -> Result<(), CliError> {
        if let Some(settings) = impedance {
            session.send(&HostMessage::SetImpedance(settings)).map_err(CliError::Link)?;
        }
        if let Some(scene) = &scene {
            session.send_scene(scene).map_err(CliError::Link)?;
        }
        Ok(())
    };
    configure(&mut session)?;
    if let Some(scene) = &scene {
        println!(
            "scene: {} objects rendered by the device (each answered), effect {:?}",
            scene.objects.len(),
            scene.effect
        );
        if !scene.moving.is_empty() {
            println!("scene: {} moving, sent again every {} ms", scene.moving.len(), args.motion_period);
        }
    }
    session.heartbeats(true);
    std::thread::sleep(link::HEARTBEAT_PERIOD * 3);
    if args.reset {
        session.send(&HostMessage::ResetFault).map_err(CliError::Link)?;
    }
    if args.enable || args.check_safety {
        session.send(&HostMessage::Enable).map_err(CliError::Link)?;
    }
    let mut failed = 0;
    if args.check_safety {
        for row in link::safety_check(&mut session).map_err(CliError::Link)? {
            println!("{} {}: {}", if row.pass { "PASS" } else { "FAIL" }, row.what, row.measured);
            failed += usize::from(!row.pass);
        }
    }
    let mut log = match &args.log {
        Some(path) => {
            let mut writer = csv::Writer::from_path(path).map_err(log_error(path))?;
            writer.write_record(link::csv_header(&info)).map_err(log_error(path))?;
            Some(writer)
        }
        None => None,
    };
    let start = std::time::Instant::now();
    let deadline = start + std::time::Duration::from_secs_f64(duration);
    // The moving objects' time 0 (they were sent where they are then, and wait there through
    // the safety checks).
    let moving = scene.as_ref().filter(|scene| !scene.moving.is_empty());
    let mut next_motion = start + motion_period;
    let (mut frames, mut missing, mut resets) = (0u64, 0u64, 0u64);
    let mut first_tick = None;
    let mut last: Option<hapticgen_protocol::StateFrame> = None;
    let mut shown = start;
    while let Some(left) = deadline.checked_duration_since(std::time::Instant::now()) {
        let now = std::time::Instant::now();
        if let Some(scene) = moving {
            if now >= next_motion {
                let time = now.duration_since(start).as_secs_f64();
                for (slot, object) in scene.moved_objects(time) {
                    session.send(&HostMessage::SetObject { slot, object }).map_err(CliError::Link)?;
                }
                // The next update on the period's grid (updates the link could not send in
                // time are skipped, not queued).
                while next_motion <= now {
                    next_motion += motion_period;
                }
            }
        }
        let wait = match moving {
            Some(_) => left.min(next_motion.saturating_duration_since(now)),
            None => left,
        };
        let event = match session.next(wait).map_err(CliError::Link)? {
            Some(event) => event,
            None if moving.is_some() => continue,
            None => break,
        };
        let received = match event {
            Event::State(received) => received,
            // The answers to the moving objects' updates.
            Event::Scene(answer) => match scene.as_ref().and_then(|scene| link::refusal(scene, &answer)) {
                Some(error) => return Err(CliError::Link(error)),
                None => continue,
            },
            _ => continue,
        };
        let frame = received.frame;
        if let Some(previous) = &last {
            let was_enabled = previous.status & hapticgen_protocol::StateFrame::ENABLED != 0;
            if link::device_reset(previous, &frame, was_enabled) {
                // The device started again: it has forgotten the handshake, the settings and
                // the scene, and its bridges are off.
                println!(
                    "device reset (tick {} after {}): sending Hello, the settings and the scene again",
                    frame.tick, previous.tick
                );
                session.sync(link::HELLO_TIMEOUT).map_err(CliError::Link)?;
                configure(&mut session)?;
                if args.enable || args.check_safety {
                    session.send(&HostMessage::Enable).map_err(CliError::Link)?;
                }
                resets += 1;
                last = None;
                continue;
            }
            missing += link::missing_between(previous.tick, frame.tick);
        }
        first_tick.get_or_insert(frame.tick);
        frames += 1;
        if let (Some(writer), Some(path)) = (log.as_mut(), args.log.as_ref()) {
            let seconds = received.at.duration_since(start).as_secs_f64();
            writer.write_record(link::csv_row(&info, &frame, seconds)).map_err(log_error(path))?;
        }
        if !args.quiet && received.at.duration_since(shown) >= std::time::Duration::from_millis(100) {
            eprint!("\r{}   ", link::status_line(&info, &frame, frames, missing));
            shown = received.at;
        }
        last = Some(frame);
    }
    if !args.quiet {
        eprintln!();
    }
    if let (Some(mut writer), Some(path)) = (log, args.log.as_ref()) {
        writer.flush().map_err(|e| log_error(path)(e.into()))?;
        println!("wrote {} ({frames} rows)", path.display());
    }
    let device_counters = session.device_counters;
    let host_dropped = session.host_dropped();
    let heartbeats = session.heartbeats_sent();
    session.close().map_err(CliError::Link)?;
    println!(
        "{frames} state frames in {:.2} s (ticks {} to {}), {missing} missing; {heartbeats} heartbeats sent; host dropped \
         {host_dropped} frames{}",
        duration,
        first_tick.map_or("-".into(), |t| t.to_string()),
        last.map_or("-".into(), |f| f.tick.to_string()),
        device_counters.map_or(String::new(), |c| format!(
            "; device: {} frames received, {} dropped",
            c.frames,
            c.dropped()
        ))
    );
    if let Some(frame) = &last {
        println!("last: {}", link::status_line(&info, frame, frames, missing));
    }
    if resets > 0 {
        println!("the device started again {resets} times; each time it was sent Hello, the settings and the scene");
    }
    if failed > 0 {
        return Err(CliError::Verdict(format!("error: {failed} of the link's safety checks failed")));
    }
    Ok(())
}

/// A [`CliError::Log`] on the CSV file `path`.
fn log_error(path: &Path) -> impl FnOnce(csv::Error) -> CliError + '_ {
    move |source| CliError::Log { path: path.to_path_buf(), source }
}

/// How long a device may go without a state frame during an excitation run before the run is
/// given up, host time (the device image under QEMU on a loaded machine is slow, not silent).
const EXCITE_STALL: Duration = Duration::from_secs(5);

/// `hapticgen connect --excite TRAJ.yaml --model MODEL.yaml --log RUN.csv`: plays the
/// trajectory on the device and writes the identification log of `simulate --scenario
/// excite` from its state stream. The device must be the model's (its joints and task axes;
/// without `--home`, the firmware image of the model, homed at its start pose); it is sent
/// the trajectory (one `SetExcitation` per joint), then enabled, and must then say in every
/// state frame that it plays it ([`StateFrame::EXCITING`]), else the run fails: a device that
/// refused it never claims it. The run lasts `--duration` of the device's ticks (not the
/// host's clock); the log's time is the device's tick count.
fn connect_excite(args: &ConnectArgs, trajectory_path: &Path) -> Result<(), CliError> {
    let (Some(model_path), Some(log_path)) = (args.model.as_deref(), args.log.as_deref()) else {
        return Err(CliError::Usage("--excite needs --model MODEL.yaml and --log RUN.csv".into()));
    };
    let sim = Simulation::load(model_path, args.variant.as_deref()).map_err(CliError::Simulation)?;
    let trajectory = crate::identify::commands::read_playable(&sim.model, trajectory_path)
        .map_err(CliError::Identification)?;
    let series = trajectory.series();
    let duration = args.duration.unwrap_or(trajectory.ramp + 4.0 * trajectory.period);
    if !(duration.is_finite() && duration > 0.0) {
        return Err(CliError::Usage(format!("--duration must be a positive time, got {duration}")));
    }
    let n = sim.joints();
    let (home, image) = match &args.home {
        Some(home) => {
            if home.len() != n || home.iter().any(|v| !v.is_finite()) {
                return Err(CliError::Usage(format!(
                    "--home takes {n} finite joint angles (rad, or m), one per joint of {}; got {home:?}",
                    model_path.display()
                )));
            }
            (home.clone(), None)
        }
        None => {
            let name = crate::pil::chosen_image_name(
                args.image_name.as_deref(),
                model_path,
                sim.model.variant.as_deref(),
            )
            .map_err(CliError::Simulation)?;
            (crate::pil::image_pose(&name, &sim.model).map_err(CliError::Simulation)?, Some(name))
        }
    };
    let mut session = Session::open(&args.port).map_err(CliError::Link)?;
    let info = session.info;
    println!(
        "connected: protocol {}, {} joints, {} task axes, impedance loop {} Hz, rig name hash {:08x}",
        info.version, info.joints, info.task_dim, info.impedance_loop_hz, info.rig_name_hash
    );
    if (usize::from(info.joints), usize::from(info.task_dim)) != (n, sim.task_dim()) {
        return Err(CliError::Link(format!(
            "error: the device has {} joints and {} task axes, {} has {n} and {}: not this device's model",
            info.joints,
            info.task_dim,
            model_path.display(),
            sim.task_dim()
        )));
    }
    if let Some(name) = &image {
        let expected = hapticgen_protocol::rig_name_hash(name);
        if info.rig_name_hash != expected {
            return Err(CliError::Link(format!(
                "error: the device is not the firmware image `{name}` of {} (rig name hash {:08x}, that image's \
                 {expected:08x}), so where its encoders read 0 is not known: give it with --home",
                model_path.display(),
                info.rig_name_hash
            )));
        }
    }
    let messages = excitation_messages(&series, n, u32::from(info.impedance_loop_hz), TRACKING_HZ)
        .map_err(|e| CliError::Identification(format!("{e} ({})", trajectory_path.display())))?;
    let rate = f64::from(info.impedance_loop_hz);
    let ticks = (duration * rate).round() as u64;
    session.heartbeats(true);
    std::thread::sleep(link::HEARTBEAT_PERIOD * 3);
    // The excitation first, the bridges off: each message takes QEMU's UART about 10 ms,
    // longer than an enabled device's heartbeat timeout. The device holds it and plays it from
    // the first tick its bridges are on.
    for message in &messages {
        session.send(&HostMessage::SetExcitation(*message)).map_err(CliError::Link)?;
    }
    if args.reset {
        session.send(&HostMessage::ResetFault).map_err(CliError::Link)?;
    }
    session.sync(link::HELLO_TIMEOUT).map_err(CliError::Link)?;
    session.send(&HostMessage::Enable).map_err(CliError::Link)?;
    // Everything the device sends after its answer to this Hello comes after it has taken
    // the Enable: from then on every frame must say that it plays the excitation.
    let mut pending: Vec<ArrivedState> = session
        .sync(link::HELLO_TIMEOUT)
        .map_err(CliError::Link)?
        .into_iter()
        .filter(|s| s.frame.status & StateFrame::EXCITING != 0)
        .collect();
    let after = next_state(&mut session)?;
    if after.frame.status & StateFrame::ENABLED == 0 {
        return Err(CliError::Link(format!(
            "error: the device did not enable its bridges ({}); a latched fault is cleared by --reset",
            fault_text(&after.frame)
        )));
    }
    if after.frame.status & StateFrame::EXCITING == 0 {
        return Err(CliError::Link(format!(
            "error: the device does not play the excitation of {} (it refuses one whose joints do not all \
             arrive, disagree, or whose period is not a whole number of its ticks; {})",
            trajectory_path.display(),
            fault_text(&after.frame)
        )));
    }
    pending.push(after);
    let mut unwrap = vec![CountUnwrapper::new(); n];
    let mut samples: Vec<DeviceSample> = Vec::new();
    let (mut elapsed, mut missing, mut previous, mut saturated) = (0u64, 0u64, None::<u16>, 0u64);
    let scales = info.scales;
    let mut pending = pending.into_iter();
    loop {
        let received = match pending.next() {
            Some(received) => received,
            None => next_state(&mut session)?,
        };
        let frame = received.frame;
        if frame.status & StateFrame::EXCITING == 0
            || frame.status & StateFrame::ENABLED == 0
            || frame.fault != 0
        {
            return Err(CliError::Link(format!(
                "error: the device stopped playing the excitation {:.3} s into it ({}); nothing written",
                elapsed as f64 / rate,
                fault_text(&frame)
            )));
        }
        if let Some(previous) = previous {
            elapsed += u64::from(frame.tick.wrapping_sub(previous));
            missing += link::missing_between(previous, frame.tick);
        }
        previous = Some(frame.tick);
        if elapsed >= ticks {
            break;
        }
        saturated += u64::from(frame.status & StateFrame::SATURATED != 0);
        let channel = |value: Option<f32>| value.map_or(f64::NAN, f64::from);
        samples.push(DeviceSample {
            time: elapsed as f64 / rate,
            counts: (0..n)
                .map(|j| frame.encoder_count_wrapped(j).map_or(0, |wrapped| unwrap[j].unwrap(wrapped)))
                .collect(),
            currents: (0..n).map(|j| channel(frame.motor_current(j, &scales))).collect(),
            torques: (0..n).map(|j| channel(frame.joint_torque(j, &scales))).collect(),
        });
    }
    let device_counters = session.device_counters;
    session.close().map_err(CliError::Link)?;
    let log = sim.device_log(&samples, &home).map_err(CliError::Identification)?;
    log.write(log_path).map_err(CliError::Identification)?;
    println!(
        "played {} on the device for {duration:.3} s of its ticks: wrote {} ({} samples, {missing} ticks missing){}",
        trajectory_path.display(),
        log_path.display(),
        log.len(),
        device_counters.map_or(String::new(), |c| format!(
            "; device: {} frames received, {} dropped",
            c.frames,
            c.dropped()
        ))
    );
    let worst = tracking_errors(&series, trajectory.ramp, &log, n);
    for (joint, error) in sim.model.joints.iter().zip(&worst) {
        println!("  joint {}: largest tracking error after the blend {error:.3e}", joint.name);
    }
    if saturated > 0 {
        println!(
            "warning: {saturated} of {} frames had a channel at its limit (StateFrame::SATURATED): those samples \
             hold the limit, not the value",
            log.len()
        );
    }
    Ok(())
}

/// The next state frame (other messages skipped); an error if none comes within
/// [`EXCITE_STALL`].
fn next_state(session: &mut Session) -> Result<ArrivedState, CliError> {
    let deadline = std::time::Instant::now() + EXCITE_STALL;
    while let Some(left) = deadline.checked_duration_since(std::time::Instant::now()) {
        if let Some(Event::State(received)) = session.next(left).map_err(CliError::Link)? {
            return Ok(received);
        }
    }
    Err(CliError::Link(format!("error: no state frame from the device for {} s", EXCITE_STALL.as_secs())))
}

/// What a frame says about the device's bridges and faults, for an error.
fn fault_text(frame: &StateFrame) -> String {
    let safety = frame.fault & !StateFrame::LINK_FAULT;
    format!(
        "bridges {}, link fault {}, safety fault {}",
        if frame.status & StateFrame::ENABLED != 0 { "on" } else { "off" },
        if frame.fault & StateFrame::LINK_FAULT != 0 { "latched" } else { "none" },
        if safety == 0 { "none".to_string() } else { format!("code {safety}") }
    )
}
