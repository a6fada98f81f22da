//! A port closed and opened again: the packet the board's IN endpoint still held for the previous
//! connection arrives first, cut anywhere, and the new connection's hello is still found by
//! `StreamDecoder::for_port`, because the firmware's `Link` (the simulated board runs the same
//! one) starts every connection with a lone frame delimiter.

use host_tool::decode::StreamDecoder;
use host_tool::sim::board::{SimBoard, USB_PACKET};
use rover_power_tests::sim_board;

/// One connection: DTR raised, `steps` sample periods, every byte the board sent, DTR dropped.
fn connection(sim: &mut SimBoard, steps: u64) -> Vec<u8> {
    sim.set_host_connected(true);
    let mut bytes = Vec::new();
    for _ in 0..steps {
        sim.step();
        sim.drain_into(&mut bytes).expect("a Vec takes every byte");
    }
    sim.set_host_connected(false);
    bytes
}

#[test]
fn a_stale_packet_cut_anywhere_does_not_hide_the_next_connections_hello() {
    let mut sim = sim_board();
    // Hello, status, samples and model frames: every kind of frame can be the one cut.
    let first = connection(&mut sim, 40);
    let second = connection(&mut sim, 10);

    let mut clean = StreamDecoder::for_port();
    clean.feed(&second, |_| {});
    assert!(clean.hello().is_some());
    assert_eq!(clean.stats().samples, 10);
    assert_eq!(
        clean.stats().stale_bytes,
        0,
        "the connection's own delimiter is not stale"
    );

    // The first connection's own leading delimiter, then its hello.
    let hello_end = 1 + first[1..].iter().position(|&b| b == 0).expect("hello") + 1;
    let mut cut_mid_frame = 0;
    for end in 1..=first.len() {
        // The packet left in the endpoint: up to 64 bytes of the first connection's stream,
        // ending `end` bytes in, i.e. k bytes into a frame for every k of every frame.
        let start = end.saturating_sub(USB_PACKET);
        if start <= 1 && end >= hello_end - 1 {
            // A packet that still holds the previous connection's whole hello passes for this
            // one's (the same board; its own hello follows): not the case tested here.
            continue;
        }
        let stale = &first[start..end];
        let mut dec = StreamDecoder::for_port();
        dec.feed(stale, |_| {});
        dec.feed(&second, |_| {});
        let stats = dec.stats();
        assert!(dec.hello().is_some(), "stale packet ending at {end}");
        assert_eq!(
            (stats.samples, stats.bad_frames, stats.gaps),
            (10, 0, 0),
            "stale packet ending at {end}"
        );
        // A cut frame is ended by the new connection's delimiter, which is stale with it; a
        // packet that starts at a delimiter starts with an empty frame, which is not.
        let cut = first[end - 1] != 0;
        let empty = first[start] == 0;
        assert_eq!(
            stats.stale_bytes,
            stale.len() as u64 + u64::from(cut) - u64::from(empty),
            "stale packet ending at {end}"
        );
        cut_mid_frame += usize::from(cut);
    }
    assert!(cut_mid_frame > first.len() / 2, "{cut_mid_frame}");
    assert_eq!(second[0], 0, "the delimiter first");
}
