//! `hapticgen connect`: drives a running device over its link as an application does (the
//! link itself, the session and the safety checks are [`crate::connect`]): the settings and
//! the scene sent after each handshake, heartbeats, a live status line, the state stream
//! logged to CSV, a device that starts again handled.

use std::path::Path;

use hapticgen_protocol::HostMessage;

use super::args::ConnectArgs;
use super::CliError;
use crate::connect::{self as link, Event, Session};

/// `hapticgen connect`: opens the link, configures the device, stays connected for
/// `--duration` and prints what it saw; fails if one of the safety checks fails.
pub fn connect(args: ConnectArgs) -> Result<(), CliError> {
    if !(args.duration.is_finite() && args.duration >= 0.0) {
        return Err(CliError::Usage(format!(
            "--duration must be a finite, non-negative time, got {}",
            args.duration
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
    let deadline = start + std::time::Duration::from_secs_f64(args.duration);
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
        args.duration,
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
