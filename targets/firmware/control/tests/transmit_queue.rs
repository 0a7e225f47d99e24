//! The transmit ring of device mode (`hapticgen_fw_control::device::TransmitQueue`): bytes come
//! out in the order they went in, across the ring's wrap, and a frame that does not fit is
//! refused whole.

use hapticgen_fw_control::device::TransmitQueue;

#[test]
fn frames_come_out_in_order_across_the_wrap_and_whole_or_not_at_all() {
    let mut queue = TransmitQueue::new();
    let mut sent: Vec<u8> = Vec::new();
    let mut expected: Vec<u8> = Vec::new();
    let mut next = 0u8;
    // 49-byte frames (a 3-joint state frame) against a slower drain: the ring wraps many times
    // and fills up.
    for round in 0..200 {
        let frame: Vec<u8> = (0..49)
            .map(|_| {
                next = next.wrapping_add(1);
                next
            })
            .collect();
        let room = 255 - queue.len();
        let queued = queue.push_frame(&frame);
        assert_eq!(queued, frame.len() <= room, "round {round}: {} queued, {room} free", queue.len());
        if queued {
            expected.extend_from_slice(&frame);
        }
        for _ in 0..40 {
            if let Some(byte) = queue.pop() {
                sent.push(byte);
            }
        }
    }
    while let Some(byte) = queue.pop() {
        sent.push(byte);
    }
    assert!(queue.is_empty());
    assert_eq!(sent, expected);
    // The ring did fill: some frames were refused.
    assert!(expected.len() < 200 * 49);
}

#[test]
fn a_full_ring_holds_255_bytes() {
    let mut queue = TransmitQueue::new();
    assert!(queue.push_frame(&[7; 255]));
    assert_eq!(queue.len(), 255);
    assert!(!queue.push_frame(&[8]));
    assert_eq!(queue.pop(), Some(7));
    assert!(queue.push_frame(&[8]));
    assert_eq!(queue.len(), 255);
}
