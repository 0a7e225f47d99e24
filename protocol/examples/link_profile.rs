//! Encodes state frames and decodes command frames in a loop, for a profiler (callgrind).
use hapticgen_protocol::*;
fn main() {
    let settings = ImpedanceSettings { stiffness: [300.0, 250.0, 200.0], damping: [2.0; 3], mass: [0.1; 3] };
    let mut command = [0u8; MAX_FRAME_BYTES];
    let n = encode(&HostMessage::SetImpedance(settings), &mut command).unwrap();
    let mut decoder = FrameDecoder::new();
    let mut total = 0usize;
    for tick in 0..10_000u32 {
        let t = tick as f32 * 1e-3;
        let counts = [tick as i32; 3];
        let v = [t, -t, 2.0 * t];
        let sample = StateSample {
            tick,
            enabled: true,
            exciting: false,
            fault: 0,
            encoder_counts: &counts,
            joint_velocity: &v,
            task_position: &v,
            task_velocity: &v,
            joint_torque: &v,
            motor_current: &v,
            tick_instructions: 1000,
        };
        let frame = StateFrame::quantise(std::hint::black_box(&sample), &ChannelScales::DESKTOP).unwrap();
        let mut buffer = [0u8; MAX_FRAME_BYTES];
        total += encode(&DeviceMessage::State(frame), &mut buffer).unwrap();
        for &b in std::hint::black_box(&command[..n]) {
            if decoder.push::<HostMessage>(b).is_some() {
                total += 1;
            }
        }
    }
    println!("{total}");
}
