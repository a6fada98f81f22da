//! On-target test of `model-core` under QEMU (`qemu-system-arm -machine netduinoplus2`, a
//! Cortex-M4F STM32F405 whose flash and RAM contain our F411 `memory.x`), run by
//! `firmware/qemu-model-core.sh`.
//!
//! 1. Checks model-core's f32/libm kinematics, exact integer energy and the wire format on the
//!    Cortex-M4 (hard-float FPU, 32-bit target) against values derived independently by hand from
//!    the documented equations; prints one line per check over semihosting and exits QEMU with
//!    failure if any check fails.
//! 2. Runs the per-sample board work K times between `#[no_mangle]` markers, so the script can
//!    count executed instructions in an instruction trace; and the I²C interrupt handler's work
//!    for one chip's reads of a sample (`firmware::i2c_master` against a replay of I2C1's
//!    events), checked for the right bytes first.
#![cfg_attr(target_os = "none", no_std, no_main)]

/// Host build: nothing to do; this keeps `cargo test/clippy --workspace --all-targets` green.
#[cfg(not(target_os = "none"))]
fn main() {}

#[cfg(target_os = "none")]
mod target {
    use core::hint::black_box;
    use core::panic::PanicInfo;

    // cortex-m provides the critical-section implementation that semihosting's `hprintln!` uses;
    // the PAC provides the interrupt vectors that cortex-m-rt's `device` feature links against.
    use cortex_m as _;
    use stm32f4xx_hal as _;

    use cortex_m_rt::{entry, exception, ExceptionFrame};
    use cortex_m_semihosting::{debug, hprintln};
    use embedded_hal::i2c::Operation;
    use firmware::i2c_master as i2c;

    use model_core::energy::{EnergyAccumulator, RunningMeasurements};
    use model_core::ina226::{
        BusVoltageRaw, CalibrationRaw, CurrentRaw, PowerRaw, Registers, Scale, ShuntVoltageRaw,
    };
    use model_core::kinematics::{
        side_speeds_for, slip_angles, slip_track_from_measured_radius_m, turning_radius_m,
    };
    use model_core::wire::{self, BoardFrame, ChipReading, FrameDecoder, Sample, MAX_FRAME};
    use model_core::{Rover, SideSpeeds, Sides, TurnDirection};

    /// Iterations of each bench loop (printed; the script divides its instruction counts by it).
    const K: u32 = 1000;

    /// Counts and reports check outcomes.
    struct Checks {
        failed: u32,
        total: u32,
    }

    impl Checks {
        fn check(&mut self, name: &str, ok: bool, detail: core::fmt::Arguments<'_>) {
            self.total += 1;
            if ok {
                hprintln!("ok   {}: {}", name, detail);
            } else {
                self.failed += 1;
                hprintln!("FAIL {}: {}", name, detail);
            }
        }
    }

    fn close(a: f32, b: f32, tol: f32) -> bool {
        (a - b).abs() <= tol
    }

    fn speeds_close(got: SideSpeeds, left: f32, right: f32) -> bool {
        close(got.left_mps, left, 1e-6) && close(got.right_mps, right, 1e-6)
    }

    fn regs(current: i16, power: u16) -> Registers {
        Registers {
            current: CurrentRaw(current),
            power: PowerRaw(power),
            ..Default::default()
        }
    }

    fn kinematics_checks(c: &mut Checks) {
        // Husky A200: B_s = 1.1 m, so R' = B_s / 2 = 0.55 m (Eq 2.5); v_c = 0.3 m/s.
        // Appendix A (Eq A.13–A.14), inner side of a left turn:
        //   R < R':  V_in = v_c (R − R') / R'   → R = 0:     V_in = −v_c = −0.3
        //   R = R':  V_in = 0
        //   R > R':  V_in = v_c (R − R') / R    → R = 2R':   V_in = v_c / 2 = 0.15
        //   (literal A.12: 2 v_c / ((R+R')/(R−R') + 1) = 0.6 / (3 + 1) = 0.15, the same)
        // Outer side: V_out = 2 v_c − |V_in| → 0.3, 0.6, 0.45. A right turn swaps the sides.
        let husky = Rover::HUSKY_A200;
        let rp = husky.r_prime_m();
        c.check(
            "R' of the Husky",
            close(rp, 0.55, 1e-7),
            format_args!("{rp} m (want 0.55)"),
        );
        let v_c = 0.3;
        let cases = [
            ("R=0", 0.0, -0.3, 0.3),
            ("R=R'", rp, 0.0, 0.6),
            ("R=2R'", 2.0 * rp, 0.15, 0.45),
        ];
        for (name, r, inner, outer) in cases {
            let left = side_speeds_for(v_c, r, rp, TurnDirection::Left);
            let right = side_speeds_for(v_c, r, rp, TurnDirection::Right);
            c.check(
                "side_speeds_for",
                speeds_close(left, inner, outer) && speeds_close(right, outer, inner),
                format_args!(
                    "{name} left turn ({}, {}) want ({inner}, {outer}); right turn ({}, {})",
                    left.left_mps, left.right_mps, right.left_mps, right.right_mps
                ),
            );
            // Eq 2.4 inverts it: R = B_s/2 |(V_l + V_r) / (V_l − V_r)|:
            //   (−0.3, 0.3) → 0;  (0, 0.6) → 0.55 · 0.6/0.6 = 0.55;
            //   (0.15, 0.45) → 0.55 · 0.6/0.3 = 1.1.
            let back = turning_radius_m(left, husky.slip_track_m).unwrap_or(f32::NAN);
            c.check(
                "turning_radius_m round trip",
                close(back, r, 1e-6),
                format_args!("{name}: {back} m (want {r})"),
            );
        }
        let at_r_prime = side_speeds_for(v_c, rp, rp, TurnDirection::Left);
        c.check(
            "inner side exactly still at R'",
            at_r_prime.left_mps == 0.0,
            format_args!("{}", at_r_prime.left_mps),
        );

        // Appendix D: B_s = 2 R_act |V_l − V_r| / |V_l + V_r| = 2 · 0.645 · 0.6 / 0.6 = 1.29 m.
        // Exact: IEEE f32 (no FMA contraction in Rust) rounds 2 · 0.645 · 0.6 / 0.6 to 1.29f32
        // on the host and on the M4's FPU alike.
        let bs = slip_track_from_measured_radius_m(0.645, SideSpeeds::new(0.0, 0.6));
        c.check(
            "slip_track_from_measured_radius_m",
            bs == Some(1.29),
            format_args!("{bs:?} m (want 1.29)"),
        );

        // libm atanf on the target, Eq 5.1–5.2 with B = 0.545, L = 0.52 and R'_act = 0.605:
        // at R = (B + L)/2 = 0.5325, |2R − B|/L = 1 so the dragged inner wheel (B/2 < R < R'_act)
        // is at 90° + atan(1) = 135°; the outer wheel is at 90° − atan(1.61/0.52)
        // = 17.89948983735748° (python: 90 - math.degrees(math.atan(1.61/0.52))).
        let angles = slip_angles(0.5325, 0.605, &husky);
        c.check(
            "slip_angles (libm atanf)",
            close(angles.inner_deg, 135.0, 1e-3) && close(angles.outer_deg, 17.899_49, 1e-3),
            format_args!(
                "inner {}° (want 135), outer {}° (want 17.89949)",
                angles.inner_deg, angles.outer_deg
            ),
        );
    }

    fn energy_checks(c: &mut Checks) {
        // Samples every 5 ms at t_k = 5000 k µs, k = 0..=10.
        // Left: P_k = 3000 + 10k LSB (current positive); its read fails at k = 4, so P_5 covers
        //   the 10 ms gap: E_l = 5000 (3010+3020+3030) + 10000 · 3050 + 5000 (3060+…+3100)
        //   = 45 300 000 + 30 500 000 + 77 000 000 = 152 800 000 LSB·µs (= 1.91 J at 12.5 mW).
        // Right: regenerating, current −2000 with |P| = 1000 LSB: E_r = −1000 · 50 000
        //   = −50 000 000 LSB·µs (= −0.625 J). Total 102 800 000.
        let mut m = RunningMeasurements::new(Scale::BOARD);
        for k in 0..=10u16 {
            let left = (k != 4).then(|| regs(4000, 3000 + 10 * k));
            let right = Some(regs(-2000, 1000));
            m.update(u64::from(k) * 5_000, Sides::new(left, right));
        }
        let s = m.snapshot();
        c.check(
            "energy per side (exact i64)",
            s.energy_lsb_us == Sides::new(152_800_000, -50_000_000),
            format_args!(
                "{} / {} LSB·us (want 152800000 / -50000000)",
                s.energy_lsb_us.left, s.energy_lsb_us.right
            ),
        );
        c.check(
            "total energy",
            m.total_energy_lsb_us() == 102_800_000,
            format_args!("{} LSB·us (want 102800000)", m.total_energy_lsb_us()),
        );
        c.check(
            "signed power",
            s.power_lsb == Sides::new(Some(3100), Some(-1000)),
            format_args!("{:?} (want Some(3100), Some(-1000))", s.power_lsb),
        );
        let joules = Sides::new(
            Scale::BOARD.energy_j(s.energy_lsb_us.left),
            Scale::BOARD.energy_j(s.energy_lsb_us.right),
        );
        c.check(
            "energy in joules (soft f64)",
            (joules.left - 1.91).abs() < 1e-12 && (joules.right + 0.625).abs() < 1e-12,
            format_args!("{} / {} J (want 1.91 / -0.625)", joules.left, joules.right),
        );

        // Eq 5.14, τ ∝ P/ω: an R' turn at v_c = 0.3 commands ω = (0, 0.6/0.165) rad/s; the still
        // inner side has no τ, the right side's −12.5 W gives −12.5 · 0.165/0.6 = −3.4375.
        m.set_wheel_rates(Some(Sides::new(0.0, 0.6 / 0.165)));
        let tau = m.snapshot().torque_proportional;
        c.check(
            "torque_proportional",
            tau.left.is_none() && tau.right.is_some_and(|t| close(t, -3.4375, 1e-4)),
            format_args!("{:?} (want None, Some(-3.4375))", tau),
        );

        // Datasheet Eq 3–4 on the M4, worked example (7.5.1): CAL 0x0A00, shunt 0x1F40 (20 mV),
        // bus 0x2570 (11.98 V) → current 0x2710 (10 A), power 0x12B8 (119.8 W); −1 × 2047 /
        // 2048 truncates to 0; full scale clamps to −32768 with power 32768 × 32767 / 20000.
        let derived = |shunt: i16, bus: u16, cal: u16| {
            Registers::derived(
                ShuntVoltageRaw(shunt),
                BusVoltageRaw(bus),
                CalibrationRaw(cal),
            )
            .map(|r| (r.current.0, r.power.0))
        };
        let example = derived(0x1F40, 0x2570, 0x0A00);
        let truncated = derived(-1, 19_200, 2047).map(|(current, _)| current);
        let clamped = derived(i16::MIN, 0x7FFF, 0x7FFF);
        c.check(
            "derived current and power (Eq 3-4)",
            example == Some((0x2710, 0x12B8))
                && truncated == Some(0)
                && clamped == Some((i16::MIN, 53_685)),
            format_args!(
                "{:?}, {:?}, {:?} (want Some((10000, 4792)), Some(0), Some((-32768, 53685)))",
                example, truncated, clamped
            ),
        );
        // Bit 15 of the bus register is always 0: 0xFFFF at 12 A is no reading, not a power
        // wrapped to 13 106.
        let bad_bus = derived(24_000, 0xFFFF, 2048);
        c.check(
            "bus voltage with bit 15 set rejected",
            bad_bus.is_none(),
            format_args!("{:?} (want None)", bad_bus),
        );

        // u64 µs counter wrapping on a 32-bit core: (u64::MAX − 999) → 1000 is 2000 µs at 10 LSB.
        let mut acc = EnergyAccumulator::default();
        acc.add(u64::MAX - 999, 10);
        acc.add(1_000, 10);
        c.check(
            "u64 time wrap",
            acc.energy_lsb_us() == 20_000,
            format_args!("{} (want 20000)", acc.energy_lsb_us()),
        );
    }

    /// 10 minutes into a run, 2 A at 24.6 V on each side.
    fn wire_checks(c: &mut Checks) {
        let frame = wire::typical_sample();
        let mut buf = [0u8; MAX_FRAME];
        let n = wire::encode(&frame, &mut buf).unwrap_or(0);
        // Length by hand: postcard varints — variant Sample 1 byte, t_us 6e8 < 2^35 5 bytes,
        // seq 120 000 < 2^21 3 bytes, per chip: variant 1 + shunt zigzag(4000) = 8000 < 2^14 2
        // + bus 19 680 ≥ 2^14 3 + current zigzag 8000 2 + power 3936 2 = 10; message 29 bytes.
        // Body = version 1 + 29 + CRC 4 = 34; COBS adds 1 byte below 254; delimiter 1 → 36.
        c.check(
            "encode length",
            n == 36 && buf[n - 1] == 0 && !buf[..n - 1].contains(&0),
            format_args!("{n} bytes, only the last one 0x00 (want 36)"),
        );

        let mut decoder = FrameDecoder::new();
        let mut got = None;
        let mut frames = 0;
        decoder.feed::<BoardFrame>(&buf[..n], |r| {
            frames += 1;
            got = Some(r);
        });
        c.check(
            "FrameDecoder round trip",
            frames == 1 && got == Some(Ok(frame)),
            format_args!(
                "{frames} frame(s), same Sample back: {}",
                got == Some(Ok(frame))
            ),
        );

        // Flip one bit of a data byte in the middle: COBS still decodes, the CRC must not match.
        let mut bad = buf;
        bad[n / 2] ^= 0x10;
        let mut outcomes = [None, None];
        let mut k = 0;
        let mut stream = [0u8; 2 * MAX_FRAME];
        stream[..n].copy_from_slice(&bad[..n]);
        stream[n..2 * n].copy_from_slice(&buf[..n]);
        decoder.feed::<BoardFrame>(&stream[..2 * n], |r| {
            if k < outcomes.len() {
                outcomes[k] = Some(r);
            }
            k += 1;
        });
        c.check(
            "corrupted frame rejected, next frame decodes",
            k == 2
                && matches!(outcomes[0], Some(Err(_)))
                && outcomes[1] == Some(Ok(wire::typical_sample())),
            format_args!(
                "{k} outcome(s): first {:?}, second ok: {}",
                outcomes[0].and_then(|r| r.err()),
                outcomes[1] == Some(Ok(wire::typical_sample()))
            ),
        );
    }

    // Markers for the instruction trace: distinct bodies so no pass can fold them into one symbol.
    #[allow(unsafe_code)]
    #[inline(never)]
    #[no_mangle]
    pub extern "C" fn bench_begin() {
        black_box(1u32);
    }

    #[allow(unsafe_code)]
    #[inline(never)]
    #[no_mangle]
    pub extern "C" fn bench_end() {
        black_box(2u32);
    }

    #[allow(unsafe_code)]
    #[inline(never)]
    #[no_mangle]
    pub extern "C" fn bench_update_begin() {
        black_box(3u32);
    }

    #[allow(unsafe_code)]
    #[inline(never)]
    #[no_mangle]
    pub extern "C" fn bench_update_end() {
        black_box(4u32);
    }

    #[allow(unsafe_code)]
    #[inline(never)]
    #[no_mangle]
    pub extern "C" fn bench_inputs_begin() {
        black_box(5u32);
    }

    #[allow(unsafe_code)]
    #[inline(never)]
    #[no_mangle]
    pub extern "C" fn bench_inputs_end() {
        black_box(6u32);
    }

    /// One sample's reads: shunt and bus per chip (all the board reads), values that change
    /// every sample, with both current signs. Made in the loop (a few dozen instructions, in
    /// registers): copying them from a precomputed table costs more, a `__aeabi_memcpy` per
    /// sample.
    #[inline(always)]
    fn reads(k: u32) -> Sides<(ShuntVoltageRaw, BusVoltageRaw)> {
        let k16 = k as u16;
        Sides::new(
            (
                ShuntVoltageRaw(((k16 * 7) & 0x3FFF) as i16),
                BusVoltageRaw(19_000 + (k16 & 0x3FF)),
            ),
            (
                ShuntVoltageRaw(-(((k16 * 5) & 0x3FFF) as i16)),
                BusVoltageRaw(19_500 - (k16 & 0x1FF)),
            ),
        )
    }

    /// The board's own current and power from the reads (datasheet Eq 3–4, the chip's integer
    /// arithmetic), as the sampler computes them every sample.
    #[inline(always)]
    fn varying(k: u32) -> Sides<Option<Registers>> {
        reads(k).map(|(shunt, bus)| Registers::derived(shunt, bus, BOARD_CAL))
    }

    #[allow(unsafe_code)]
    #[inline(never)]
    #[no_mangle]
    pub extern "C" fn bench_i2c_begin() {
        black_box(7u32);
    }

    #[allow(unsafe_code)]
    #[inline(never)]
    #[no_mangle]
    pub extern "C" fn bench_i2c_end() {
        black_box(8u32);
    }

    /// I2C1 as the interrupt handler meets it in a register read: each handler run reads the
    /// next SR1 of the script; DR gives `rx` in turn. Writes are counted, not checked (the host
    /// tests check the sequence against a model of the bus).
    struct Replay {
        sr1: &'static [u16],
        next: usize,
        rx: [u8; 2],
        rx_next: usize,
        dr_writes: u32,
    }

    impl Replay {
        fn new(sr1: &'static [u16], rx: [u8; 2]) -> Self {
            Self {
                sr1,
                next: 0,
                rx,
                rx_next: 0,
                dr_writes: 0,
            }
        }
    }

    impl i2c::Registers for Replay {
        fn sr1(&mut self) -> i2c::Sr1 {
            let flags = self.sr1.get(self.next).copied().unwrap_or(0);
            self.next += 1;
            i2c::Sr1(flags)
        }
        fn read_sr2(&mut self) {}
        fn clear_sr1(&mut self, _: u16) {}
        fn write_dr(&mut self, byte: u8) {
            self.dr_writes += u32::from(black_box(byte) != 0xFF);
        }
        fn read_dr(&mut self) -> u8 {
            let byte = self.rx[self.rx_next % 2];
            self.rx_next += 1;
            byte
        }
        fn start(&mut self) {}
        fn stop(&mut self) {}
        fn stop_pending(&mut self) -> bool {
            false
        }
        fn set_ack_pos(&mut self, _: bool, _: bool) {}
        fn set_interrupts(&mut self, _: bool, _: bool) {}
    }

    /// SR1 at each interrupt of a register read with its pointer: SB, ADDR, BTF after the
    /// pointer, SB of the repeated START, ADDR, BTF with both bytes in.
    const POINTED_READ: [u16; 6] = [
        i2c::Sr1::SB,
        i2c::Sr1::ADDR | i2c::Sr1::TXE,
        i2c::Sr1::BTF | i2c::Sr1::TXE,
        i2c::Sr1::SB,
        i2c::Sr1::ADDR,
        i2c::Sr1::BTF | i2c::Sr1::RXNE,
    ];
    /// The short read (no pointer byte): SB, ADDR, BTF.
    const SHORT_READ: [u16; 3] = [i2c::Sr1::SB, i2c::Sr1::ADDR, i2c::Sr1::BTF | i2c::Sr1::RXNE];

    /// One transfer through the handler: begin, one handler run per scripted event, the end.
    fn replay_read(
        master: &mut i2c::Master,
        transfer: i2c::Transfer,
        sr1: &'static [u16],
        rx: [u8; 2],
    ) -> Option<[u8; 2]> {
        let mut regs = Replay::new(sr1, rx);
        master.begin(&mut regs, transfer).ok()?;
        for _ in 0..sr1.len() {
            master.on_interrupt(&mut regs);
        }
        match master.poll(core::task::Waker::noop()) {
            core::task::Poll::Ready(Ok(received)) => {
                let mut out = [0u8; 2];
                out.copy_from_slice(received.bytes());
                Some(out)
            }
            _ => None,
        }
    }

    /// A chip's reads in one sample: the short read, then the other register with its pointer.
    fn chip_reads(master: &mut i2c::Master, k: u32) -> Option<([u8; 2], [u8; 2])> {
        let mut buf = [0u8; 2];
        let short = i2c::Transfer::new(0x40, &[Operation::Read(&mut buf)]).ok()?;
        let pointed = i2c::Transfer::new(
            0x40,
            &[Operation::Write(&[0x02]), Operation::Read(&mut buf)],
        )
        .ok()?;
        let [hi, lo] = (k as u16).to_be_bytes();
        let first = replay_read(master, short, &SHORT_READ, [hi, lo])?;
        let second = replay_read(master, pointed, &POINTED_READ, [lo, hi])?;
        Some((first, second))
    }

    fn i2c_checks(c: &mut Checks) {
        let mut master = i2c::Master::new();
        let reads = chip_reads(&mut master, 0x4B00);
        c.check(
            "I2C handler: short read and pointed read end with the right bytes",
            reads == Some(([0x4B, 0x00], [0x00, 0x4B])) && !master.busy(),
            format_args!("{reads:?}"),
        );
    }

    /// The interrupt handler's work for one chip per sample (a short read and a pointed read:
    /// 9 handler runs), register accesses as plain memory.
    fn bench_i2c() -> u32 {
        let mut master = i2c::Master::new();
        let mut ok = 0;
        bench_i2c_begin();
        for k in 0..K {
            ok += u32::from(black_box(chip_reads(&mut master, k)).is_some());
        }
        bench_i2c_end();
        ok
    }

    /// The board's calibration register (5 mΩ, 0.5 mA LSB).
    const BOARD_CAL: CalibrationRaw = CalibrationRaw(2048);

    /// What the board does per sample: update the running measurements and frame the sample.
    fn bench_update_and_encode(m: &mut RunningMeasurements) -> usize {
        let mut buf = [0u8; MAX_FRAME];
        let mut bytes = 0;
        bench_begin();
        for k in 0..K {
            let t_us = black_box(u64::from(k) * 5_000);
            let readings = varying(k);
            m.update(t_us, readings);
            let frame = BoardFrame::Sample(Sample {
                t_us,
                seq: k,
                chips: readings.map(|r| {
                    r.map_or(
                        ChipReading::Failed(wire::ChipFault::Other),
                        ChipReading::Fresh,
                    )
                }),
            });
            bytes += black_box(wire::encode(&frame, &mut buf).unwrap_or(0));
            black_box(&buf);
        }
        bench_end();
        bytes
    }

    fn bench_update_only(m: &mut RunningMeasurements) {
        bench_update_begin();
        for k in 0..K {
            let t_us = black_box(u64::from(k) * 5_000);
            m.update(t_us, varying(k));
            black_box(&*m);
        }
        bench_update_end();
    }

    /// Baseline: the same loop making the same inputs, without model-core's work.
    fn bench_inputs_only() {
        bench_inputs_begin();
        for k in 0..K {
            black_box(u64::from(k) * 5_000);
            black_box(reads(k));
        }
        bench_inputs_end();
    }

    #[entry]
    fn main() -> ! {
        hprintln!("model-core on target: checks");
        let mut c = Checks {
            failed: 0,
            total: 0,
        };
        kinematics_checks(&mut c);
        energy_checks(&mut c);
        wire_checks(&mut c);
        i2c_checks(&mut c);
        hprintln!("{} of {} checks passed", c.total - c.failed, c.total);
        if c.failed != 0 {
            debug::exit(debug::EXIT_FAILURE);
        }

        let mut m = RunningMeasurements::new(Scale::BOARD);
        let bytes = bench_update_and_encode(&mut m);
        hprintln!(
            "bench update+encode: K = {}, {} frame bytes, energy {} LSB·us",
            K,
            bytes,
            m.total_energy_lsb_us()
        );
        let mut m = RunningMeasurements::new(Scale::BOARD);
        bench_update_only(&mut m);
        hprintln!(
            "bench update only:   K = {}, energy {} LSB·us",
            K,
            m.total_energy_lsb_us()
        );
        bench_inputs_only();
        let ok = bench_i2c();
        hprintln!("bench I2C handler:   K = {}, {} chip-samples read", K, ok);

        debug::exit(debug::EXIT_SUCCESS);
        loop {
            core::hint::spin_loop();
        }
    }

    /// A fault ends the run at once with failure instead of spinning until the script's timeout.
    #[allow(unsafe_code)]
    #[exception]
    unsafe fn HardFault(frame: &ExceptionFrame) -> ! {
        hprintln!("HARD FAULT at pc {:#010x}", frame.pc());
        debug::exit(debug::EXIT_FAILURE);
        loop {
            core::hint::spin_loop();
        }
    }

    #[panic_handler]
    fn panic(info: &PanicInfo<'_>) -> ! {
        hprintln!("PANIC: {}", info);
        debug::exit(debug::EXIT_FAILURE);
        loop {
            core::hint::spin_loop();
        }
    }
}
