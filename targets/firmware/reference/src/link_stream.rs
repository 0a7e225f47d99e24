//! `hapticgen-fw-reference link-stream <uart-file> <qemu-output>`: checks what the link-cost
//! image (`hapticgen-fw-qemu-link-cost`) wrote to UART0. Every byte must belong to a valid
//! frame, every frame must be a state frame, and for each rig shape its `LINK … part=state`
//! line announced there must be that many frames of that shape with consecutive ticks from 0.

use hapticgen_protocol::{DeviceMessage, FrameDecoder};

/// The per-shape frame counts found, or every problem.
pub fn check(uart: &[u8], qemu_output: &str) -> Result<Vec<(usize, usize, u32)>, Vec<String>> {
    let mut errors = Vec::new();
    // (joints, task, frames) announced by the image.
    let announced: Vec<(usize, usize, u32)> = qemu_output
        .lines()
        .filter(|l| l.starts_with("LINK ") && l.contains(" part=state"))
        .filter_map(|l| {
            let field =
                |key: &str| l.split_whitespace().find_map(|w| w.strip_prefix(key)?.parse::<u32>().ok());
            Some((field("joints=")? as usize, field("task=")? as usize, field("frames=")?))
        })
        .collect();
    if announced.is_empty() {
        errors.push("the image announced no state frames (no `LINK … part=state` line)".to_string());
    }
    let mut decoder = FrameDecoder::new();
    let mut received: Vec<(usize, usize, u32)> = Vec::new();
    for &byte in uart {
        let Some(message) = decoder.push::<DeviceMessage>(byte) else { continue };
        let DeviceMessage::State(frame) = message else {
            errors.push(format!("a frame that is not a state frame: {message:?}"));
            continue;
        };
        if !frame.is_consistent() {
            errors.push(format!("a state frame whose channels do not match its shape: {frame:?}"));
        }
        let shape = (frame.joints(), frame.task_dim());
        match received.last_mut() {
            Some((n, m, count)) if (*n, *m) == shape && u32::from(frame.tick) == *count => *count += 1,
            _ if frame.tick == 0 => received.push((shape.0, shape.1, 1)),
            _ => errors.push(format!("state frame {shape:?} with tick {} out of sequence", frame.tick)),
        }
    }
    let counters = decoder.counters();
    if counters.dropped() != 0 {
        errors.push(format!("frames dropped by the host's decoder: {counters:?}"));
    }
    if received != announced {
        errors.push(format!("frames received {received:?}, announced {announced:?}"));
    }
    if errors.len() > 10 {
        let more = errors.len() - 10;
        errors.truncate(10);
        errors.push(format!("… and {more} more"));
    }
    if errors.is_empty() {
        Ok(received)
    } else {
        Err(errors)
    }
}
