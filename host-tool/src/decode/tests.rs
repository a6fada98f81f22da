use super::*;
use model_core::energy::RunningMeasurements;
use model_core::ina226::{BusVoltageRaw, CurrentRaw, PowerRaw, Registers, ShuntVoltageRaw};
use model_core::wire::{encode, ChipReading, MAX_FRAME};
use model_core::Sides;
use proptest::prelude::*;

fn sample(seq: u32) -> BoardFrame {
    let regs = Registers {
        shunt: ShuntVoltageRaw(1000),
        bus: BusVoltageRaw(19_200),
        current: CurrentRaw(1000),
        power: PowerRaw(960),
    };
    BoardFrame::Sample(Sample {
        t_us: u64::from(seq) * 5_000,
        seq,
        chips: Sides::new(
            ChipReading::Fresh(regs),
            ChipReading::Failed(model_core::wire::ChipFault::AddressNack),
        ),
    })
}

fn bytes_of(frames: impl IntoIterator<Item = BoardFrame>) -> Vec<Vec<u8>> {
    frames
        .into_iter()
        .map(|f| {
            let mut buf = [0u8; MAX_FRAME];
            let n = encode(&f, &mut buf).expect("fits");
            buf[..n].to_vec()
        })
        .collect()
}

#[test]
fn gaps_are_counted_exactly() {
    let frames = bytes_of((0..10).map(sample));
    let mut stream = Vec::new();
    for (i, f) in frames.iter().enumerate() {
        if i != 3 && i != 6 && i != 7 {
            stream.extend(f);
        }
    }
    let mut dec = StreamDecoder::new();
    let mut gaps = Vec::new();
    dec.feed(&stream, |e| {
        if let Event::SampleGap { after_seq, missing } = e {
            gaps.push((after_seq, missing));
        }
    });
    assert_eq!(gaps, vec![(2, 1), (5, 2)]);
    assert_eq!(dec.stats().lost_samples, 3);
    assert_eq!(dec.stats().samples, 7);
}

fn sample_at(seq: u32, t_us: u64, power: u16) -> BoardFrame {
    let regs = Registers {
        shunt: ShuntVoltageRaw(1000),
        bus: BusVoltageRaw(19_200),
        current: CurrentRaw(1000),
        power: PowerRaw(power),
    };
    BoardFrame::Sample(Sample {
        t_us,
        seq,
        chips: Sides::new(ChipReading::Fresh(regs), ChipReading::Stale(regs)),
    })
}

fn decode_all(frames: impl IntoIterator<Item = BoardFrame>) -> (StreamDecoder, Vec<Event>) {
    let mut dec = StreamDecoder::new();
    let mut events = Vec::new();
    dec.feed(&bytes_of(frames).concat(), |e| events.push(e));
    (dec, events)
}

#[test]
fn seq_going_back_is_a_board_reset_and_host_energy_starts_over() {
    let first = (0..10).map(|k| sample_at(k, u64::from(k) * 5_000, 100));
    let second = (0..4).map(|k| sample_at(k, 1_000 + u64::from(k) * 5_000, 200));
    let (dec, events) = decode_all(first.chain(second));
    let resets: Vec<&Segment> = events
        .iter()
        .filter_map(|e| match e {
            Event::BoardReset { previous } => Some(previous),
            _ => None,
        })
        .collect();
    assert_eq!(resets.len(), 1);
    assert_eq!(resets[0].samples, 10);
    assert_eq!(resets[0].host_energy_lsb_us, [100 * 45_000, 100 * 45_000]);
    // The reset comes right before the new segment's first sample.
    let at = events
        .iter()
        .position(|e| matches!(e, Event::BoardReset { .. }))
        .expect("reset");
    assert!(matches!(
        events[at + 1],
        Event::Frame(BoardFrame::Sample(Sample { seq: 0, .. }))
    ));
    let stats = dec.stats();
    assert_eq!(
        (stats.board_resets, stats.gaps, stats.lost_samples),
        (1, 0, 0)
    );
    let seg = dec.current_segment();
    assert_eq!(seg.samples, 4);
    assert_eq!(seg.host_energy_lsb_us, [200 * 15_000, 200 * 15_000]);
    // Backwards but not to 0 (the host connected late to a rebooted board) is a reset too.
    let (dec, _) = decode_all([sample_at(50, 0, 1), sample_at(7, 10, 1)]);
    assert_eq!((dec.stats().board_resets, dec.stats().gaps), (1, 0));
}

#[test]
fn seq_wrapping_past_u32_max_is_neither_a_gap_nor_a_reset() {
    let (dec, _) = decode_all([
        sample_at(u32::MAX - 1, 0, 1),
        sample_at(u32::MAX, 5_000, 1),
        sample_at(0, 10_000, 1),
        sample_at(2, 20_000, 1),
    ]);
    let stats = dec.stats();
    assert_eq!(
        (stats.board_resets, stats.gaps, stats.lost_samples),
        (0, 1, 1)
    );
}

#[test]
fn energy_integrates_across_the_u64_microsecond_wrap() {
    let t0 = u64::MAX - 12_000;
    let (dec, _) =
        decode_all((0..6).map(|k| sample_at(k, t0.wrapping_add(u64::from(k) * 5_000), 40)));
    assert_eq!(dec.current_segment().host_energy_lsb_us, [40 * 25_000; 2]);
}

#[test]
fn an_acked_command_is_mirrored_so_the_model_matches() {
    let mut board = RunningMeasurements::new(Scale::BOARD);
    let rates = Sides::new(2.0f32, -3.0);
    let mut frames = Vec::new();
    for k in 0..20u32 {
        if k == 5 {
            board.set_wheel_rates(Some(rates));
            frames.push(BoardFrame::Ack { id: 9 });
        }
        if k == 12 {
            board.reset_energy();
            frames.push(BoardFrame::Ack { id: 10 });
        }
        let s = sample_at(k, u64::from(k) * 5_000, 100 + k as u16);
        if let BoardFrame::Sample(s) = &s {
            board.update(s.t_us, s.chips.map(|c| c.registers()));
        }
        frames.push(s);
        frames.push(BoardFrame::Model(Model {
            t_us: u64::from(k) * 5_000,
            seq: k,
            snapshot: board.snapshot(),
        }));
    }
    let mut dec = StreamDecoder::new();
    dec.expect_ack(HostFrame {
        id: 9,
        command: Command::SetWheelRates(rates),
    });
    dec.expect_ack(HostFrame {
        id: 10,
        command: Command::ResetEnergy,
    });
    dec.feed(&bytes_of(frames.clone()).concat(), |_| {});
    assert_eq!(dec.stats().models, 20);
    assert_eq!(dec.stats().model_mismatches, 0);
    let check = dec.board_vs_host_model().expect("model");
    assert_eq!(check.board.snapshot, check.host);
    assert!(check.host.torque_proportional.left.is_some());
    // Without mirroring, τ differs from the ack on.
    let mut blind = StreamDecoder::new();
    blind.feed(&bytes_of(frames.clone()).concat(), |_| {});
    assert_eq!(blind.stats().model_mismatches, 15);

    // A log's frames fed as frames (validate's cross-check): the same events, stats and model
    // as their bytes, with a gap and a board reset among them.
    frames.truncate(30);
    frames.extend((0..5).map(|k| sample_at(k, u64::from(k) * 5_000, 7)));
    frames.push(sample_at(9, 45_000, 7));
    let (mut from_bytes, mut from_frames) = (StreamDecoder::new(), StreamDecoder::new());
    let (mut bytes_events, mut frame_events) = (Vec::new(), Vec::new());
    for d in [&mut from_bytes, &mut from_frames] {
        d.expect_ack(HostFrame {
            id: 9,
            command: Command::SetWheelRates(rates),
        });
    }
    from_bytes.feed(&bytes_of(frames.clone()).concat(), |e| bytes_events.push(e));
    for f in &frames {
        from_frames.feed_frame(f, |e| frame_events.push(e));
    }
    assert_eq!(frame_events, bytes_events);
    let stats = |d: &StreamDecoder| {
        let s = d.stats();
        (
            s.frames,
            s.samples,
            s.models,
            s.model_mismatches,
            s.lost_samples,
            s.gaps,
        )
    };
    assert_eq!(stats(&from_frames), stats(&from_bytes));
    assert!(stats(&from_bytes).4 > 0, "a gap among them");
    assert_eq!(
        from_frames.board_vs_host_model(),
        from_bytes.board_vs_host_model()
    );
}

#[test]
fn a_new_connection_ignores_and_counts_everything_before_its_hello() {
    let hello = BoardFrame::Hello(crate::replay::synthetic_hello(5_000));
    // What the board's USB buffers still held from the previous connection: the tail of a
    // frame cut mid-way, then whole frames.
    let cut = &bytes_of([sample(7)])[0][5..];
    let stale_frames = bytes_of((8..11).map(sample)).concat();
    let fresh = bytes_of([hello].into_iter().chain((500..510).map(sample))).concat();
    let stale_len = (cut.len() + stale_frames.len()) as u64;
    let stream = [cut, &stale_frames, &fresh].concat();

    let mut dec = StreamDecoder::for_port();
    let mut events = Vec::new();
    // In small pieces, as USB delivers them.
    for chunk in stream.chunks(7) {
        dec.feed(chunk, |e| events.push(e));
    }
    let stats = dec.stats();
    assert_eq!((stats.stale_bytes, stats.stale_frames), (stale_len, 4));
    assert_eq!((stats.samples, stats.bad_frames, stats.gaps), (10, 0, 0));
    assert!(matches!(events[0], Event::Frame(BoardFrame::Hello(_))));
    assert_eq!(dec.current_segment().samples, 10);

    // A re-opened port: the same again, counted on top.
    dec.new_connection();
    dec.feed(&stream, |_| {});
    assert_eq!(dec.stats().stale_bytes, 2 * stale_len);
    assert_eq!(dec.stats().stale_frames, 8);

    // A capture is decoded whole: nothing is stale.
    let mut capture = StreamDecoder::new();
    capture.feed(&stream, |_| {});
    assert_eq!(capture.stats().stale_bytes, 0);
    assert_eq!(capture.stats().bad_frames, 1, "the cut frame");
}

#[test]
fn a_stop_ack_pauses_the_host_energy_like_the_board() {
    // Ten samples, Stop (acked), a minute without samples, Start (acked), ten more.
    let mut board = RunningMeasurements::new(Scale::BOARD);
    let mut frames = Vec::new();
    let mut t_us = 0;
    for k in 0..20u32 {
        if k == 10 {
            board.pause();
            frames.push(BoardFrame::Ack { id: 1 });
            frames.push(BoardFrame::Ack { id: 2 });
            t_us += 60_000_000;
        }
        let s = sample_at(k, t_us, 400);
        if let BoardFrame::Sample(s) = &s {
            board.update(s.t_us, s.chips.map(|c| c.registers()));
        }
        frames.push(s);
        frames.push(BoardFrame::Model(Model {
            t_us,
            seq: k,
            snapshot: board.snapshot(),
        }));
        t_us += 5_000;
    }
    let mut dec = StreamDecoder::new();
    dec.expect_ack(HostFrame {
        id: 1,
        command: Command::Stop,
    });
    dec.expect_ack(HostFrame {
        id: 2,
        command: Command::Start,
    });
    dec.feed(&bytes_of(frames).concat(), |_| {});
    assert_eq!(dec.stats().model_mismatches, 0);
    // 18 intervals of 5 ms at 400 LSB: the minute of pause adds nothing.
    assert_eq!(dec.current_segment().host_energy_lsb_us, [400 * 90_000; 2]);
}

/// Corrupting frames (without touching delimiters) loses exactly those frames: each is
/// reported bad, and the sample gaps add up to the number corrupted.
fn check_corrupted_frames(
    corrupt: &std::collections::BTreeSet<usize>,
    byte: usize,
    flip: u8,
) -> Result<(), TestCaseError> {
    let frames = bytes_of((0..50).map(sample));
    let mut stream = Vec::new();
    for (i, f) in frames.iter().enumerate() {
        let mut f = f.clone();
        if corrupt.contains(&i) {
            let at = byte % (f.len() - 1);
            // Always change the byte, never into a 0x00: delimiters stay where they are.
            let mut corrupted = f[at] ^ flip;
            if corrupted == 0 {
                corrupted = if f[at] == 0xFF { 0x01 } else { 0xFF };
            }
            f[at] = corrupted;
        }
        stream.extend(f);
    }
    let mut dec = StreamDecoder::new();
    let mut good = 0u64;
    dec.feed(&stream, |e| {
        if matches!(e, Event::Frame(_)) {
            good += 1
        }
    });
    prop_assert_eq!(dec.stats().lost_samples, corrupt.len() as u64);
    prop_assert_eq!(good, 50 - corrupt.len() as u64);
    prop_assert!(dec.stats().bad_frames >= corrupt.len() as u64);
    Ok(())
}

proptest! {
    #[test]
    fn corrupted_frames_are_lost_exactly(corrupt in proptest::collection::btree_set(1usize..49, 0..12), byte in 0usize..20, flip in 1u8..=255) {
        check_corrupted_frames(&corrupt, byte, flip)?;
    }
}

/// A case the property found, kept as a test: the second frame's second byte flipped.
#[test]
fn corrupted_frames_regressions() {
    check_corrupted_frames(&[1].into(), 1, 1).expect("lost exactly");
}

#[test]
fn the_summary_names_the_board_by_its_usb_serial() {
    let mut hello = crate::replay::synthetic_hello(5_000);
    let synthetic = Summary::of(&bytes_of([BoardFrame::Hello(hello)]).concat());
    assert!(synthetic.to_string().contains("board identity: none"));
    hello.identity = model_core::board_id::BoardIdentity {
        uid: [0xA5; model_core::board_id::UID_LEN],
        hse_mhz: 8,
    };
    let board = Summary::of(&bytes_of([BoardFrame::Hello(hello)]).concat());
    let text = board.to_string();
    assert!(
        text.contains("board serial rover-power.github.io:a5a5a5a5a5a5a5a5a5a5a5a5, 8 MHz crystal"),
        "{text}"
    );
}

#[test]
fn mcap_and_csv_files_are_recognised_and_captures_are_not() {
    // Issue 11, bug 5: `decode run.mcap` counted 148 921 bad frames and exited 0.
    let mut mcap = b"\x89MCAP0\r\n".to_vec();
    mcap.extend([0u8; 100]);
    assert!(foreign_format(&mcap).is_some_and(|h| h.contains("MCAP")));
    let csv = b"t_s,left_bus_v,left_current_a,right_bus_v,right_current_a,cmd_left_mps,cmd_right_mps\n0,24,1,24,1,0,0\n";
    assert!(foreign_format(csv).is_some_and(|h| h.contains("CSV")));
    let hello = BoardFrame::Hello(crate::replay::synthetic_hello(5_000));
    let capture = crate::replay::encode_frame(&hello).expect("encode");
    assert_eq!(foreign_format(&capture), None);
    assert_eq!(foreign_format(b""), None);
}

#[test]
fn json_enum_values_are_kebab_case_and_old_names_still_read() {
    use model_core::ina226::{AdcConfig, Averaging};
    use model_core::kinematics::Regime;
    let json = |v: serde_json::Value| v.to_string();
    assert_eq!(
        json(serde_json::to_value(Regime::BelowHalfTrack).expect("json")),
        "\"below-half-track\""
    );
    let adc = serde_json::to_value(AdcConfig::BOARD_DEFAULT).expect("json");
    assert_eq!(adc["averaging"], "16");
    assert_eq!(adc["bus_conversion"], "140-us");
    let old: Averaging = serde_json::from_str("\"X16\"").expect("old name");
    assert_eq!(old, Averaging::X16);
    let old: Regime = serde_json::from_str("\"AboveRPrime\"").expect("old name");
    assert_eq!(old, Regime::AboveRPrime);
}

/// An input that never ends, or ends after `len` bytes: `fill` bytes made on demand, counting
/// what was read and the largest read asked for.
struct Lazy {
    fill: u8,
    len: Option<u64>,
    read: std::sync::Arc<std::sync::atomic::AtomicU64>,
    largest_ask: std::sync::Arc<std::sync::atomic::AtomicUsize>,
}

impl Lazy {
    fn new(fill: u8, len: Option<u64>) -> Self {
        Self {
            fill,
            len,
            read: Default::default(),
            largest_ask: Default::default(),
        }
    }
}

impl std::io::Read for Lazy {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        use std::sync::atomic::Ordering::Relaxed;
        self.largest_ask.fetch_max(buf.len(), Relaxed);
        let read = self.read.load(Relaxed);
        let left = self.len.map_or(u64::MAX, |len| len - read);
        let n = buf.len().min(usize::try_from(left).unwrap_or(usize::MAX));
        buf[..n].fill(self.fill);
        self.read.fetch_add(n as u64, Relaxed);
        Ok(n)
    }
}

#[test]
fn a_capture_far_larger_than_any_buffer_is_decoded_in_bounded_memory() {
    // Issue 34, item 4: `decode` held its whole input (12.3 GB of /dev/zero in 20 s).
    use std::sync::atomic::Ordering::Relaxed;
    const LEN: u64 = 200 << 20;
    let input = Lazy::new(0x01, Some(LEN)); // garbage, no delimiter: one endless frame
    let (read, largest_ask) = (input.read.clone(), input.largest_ask.clone());
    let stop = std::sync::atomic::AtomicBool::new(false);
    let mut most_held = 0u64;
    let (summary, end) = read_capture(input, &stop, std::time::Duration::ZERO, &mut |so_far| {
        // Read but not decoded yet: what the decoder holds beyond its counters.
        most_held = most_held.max(read.load(Relaxed) - so_far.bytes);
    })
    .expect("decoded");
    assert_eq!(end, CaptureEnd::Eof);
    assert_eq!(summary.bytes, LEN);
    assert!(most_held <= MAX_BUFFERED as u64, "{most_held} bytes held");
    assert!(largest_ask.load(Relaxed) <= CHUNK);
    // No delimiter in 200 MB: one overflowing frame at most, never a buffer growing with it.
    assert_eq!((summary.stats.frames, summary.stats.bad_frames), (0, 0));
}

#[test]
fn an_endless_capture_reports_as_it_goes_and_stops_on_request() {
    let stop = std::sync::atomic::AtomicBool::new(false);
    let mut reports = Vec::new();
    let (summary, end) = read_capture(
        Lazy::new(0, None),
        &stop,
        std::time::Duration::from_millis(10),
        &mut |so_far| {
            reports.push(so_far.bytes);
            if reports.len() == 3 {
                stop.store(true, std::sync::atomic::Ordering::Relaxed);
            }
        },
    )
    .expect("decoded");
    assert_eq!(end, CaptureEnd::Stopped);
    assert_eq!(reports.len(), 3);
    assert!(reports.windows(2).all(|w| w[0] <= w[1]), "{reports:?}");
    assert!(summary.bytes >= reports[2] && reports[2] > 0);
    assert!(summary
        .running_line()
        .starts_with(&format!("{} bytes", summary.bytes)));
}

#[test]
fn a_stop_is_seen_while_the_input_waits_for_its_writer() {
    /// A FIFO whose writer says nothing for a minute.
    struct Silent;
    impl std::io::Read for Silent {
        fn read(&mut self, _: &mut [u8]) -> std::io::Result<usize> {
            std::thread::sleep(std::time::Duration::from_secs(60));
            Ok(0)
        }
    }
    let stop = std::sync::atomic::AtomicBool::new(false);
    let started = std::time::Instant::now();
    let (summary, end) = std::thread::scope(|scope| {
        scope.spawn(|| {
            std::thread::sleep(std::time::Duration::from_millis(50));
            stop.store(true, std::sync::atomic::Ordering::Relaxed);
        });
        read_capture(
            Silent,
            &stop,
            std::time::Duration::from_secs(1),
            &mut |_| {},
        )
    })
    .expect("stopped");
    assert_eq!((end, summary.bytes), (CaptureEnd::Stopped, 0));
    assert!(started.elapsed() < std::time::Duration::from_secs(5));
}

#[test]
fn a_capture_read_in_chunks_sums_up_like_one_held_whole() {
    let hello = BoardFrame::Hello(crate::replay::synthetic_hello(5_000));
    let mut frames = vec![hello];
    frames.extend((0..10_000).map(sample));
    let bytes = bytes_of(frames).concat();
    assert!(bytes.len() > 2 * CHUNK, "spans chunks");
    let stop = std::sync::atomic::AtomicBool::new(false);
    let (summary, end) = read_capture(
        std::io::Cursor::new(bytes.clone()),
        &stop,
        std::time::Duration::from_secs(60),
        &mut |_| {},
    )
    .expect("decoded");
    assert_eq!(end, CaptureEnd::Eof);
    assert_eq!(summary, Summary::of(&bytes));
    assert_eq!(summary.stats.samples, 10_000);
    // A run log is still refused, from its first bytes.
    let mut mcap = b"\x89MCAP0\r\n".to_vec();
    mcap.extend([0u8; 100]);
    let refused = read_capture(
        std::io::Cursor::new(mcap),
        &stop,
        std::time::Duration::ZERO,
        &mut |_| {},
    );
    assert!(matches!(refused, Err(CaptureError::Foreign(hint)) if hint.contains("MCAP")));
}
