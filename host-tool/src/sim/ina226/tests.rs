use super::*;

/// AVG 1, 140 µs + 140 µs, continuous shunt and bus: a result every 280 µs.
const FAST: u16 = 0x4007;
/// AVG 16, 140 µs + 140 µs, continuous: the board's setting, a result every 4.48 ms.
const BOARD: u16 = 0x4407;

fn write(chip: &mut SimIna226, t_us: u64, register: u8, value: u16) {
    let [hi, lo] = value.to_be_bytes();
    chip.write_frame(t_us, &[register, hi, lo]);
}

fn read(chip: &mut SimIna226, t_us: u64, register: u8) -> u16 {
    chip.write_frame(t_us, &[register]);
    let mut buf = [0u8; 2];
    chip.read_frame(t_us, &mut buf);
    u16::from_be_bytes(buf)
}

fn chip_with(shunt_ohm: f64) -> SimIna226 {
    SimIna226::new(Analog {
        shunt_ohm,
        ..Analog::IDEAL
    })
}

/// One result of a constant input with AVG 1 (fast conversions), CAL 2048, 5 mΩ.
fn one_result(current_a: f64, bus_v: f64) -> SimIna226 {
    let mut chip = SimIna226::default();
    chip.set_input(0, current_a, bus_v);
    write(&mut chip, 0, reg::CONFIG, FAST);
    write(&mut chip, 0, reg::CALIBRATION, 2048);
    chip.advance_to(280);
    chip
}

#[test]
fn power_on_defaults_and_ids() {
    let mut chip = SimIna226::default();
    let expected = [
        (reg::CONFIG, 0x4127),
        (reg::SHUNT, 0),
        (reg::BUS, 0),
        (reg::POWER, 0),
        (reg::CURRENT, 0),
        (reg::CALIBRATION, 0),
        (reg::MASK_ENABLE, 0),
        (reg::ALERT_LIMIT, 0),
        (reg::MANUFACTURER_ID, 0x5449),
        (reg::DIE_ID, 0x2260),
    ];
    for (register, value) in expected {
        assert_eq!(
            read(&mut chip, 0, register),
            value,
            "register {register:#04x}"
        );
    }
}

#[test]
fn datasheet_worked_example() {
    // Section 7.5.1 / Table 1: 10 A through 2 mΩ, CAL 0x0A00 (1 mA LSB); the table's bus
    // reading is 11.98 V (0x2570).
    let mut chip = chip_with(0.002);
    chip.set_input(0, 10.0, 11.98);
    write(&mut chip, 0, reg::CALIBRATION, 0x0A00);
    // Power-on configuration: AVG 1, 1.1 ms + 1.1 ms → first result at 2.2 ms.
    assert_eq!(read(&mut chip, 2_199, reg::MASK_ENABLE) & MASK_CVRF, 0);
    assert_eq!(
        read(&mut chip, 2_200, reg::MASK_ENABLE) & MASK_CVRF,
        MASK_CVRF
    );
    assert_eq!(read(&mut chip, 2_200, reg::SHUNT), 0x1F40);
    assert_eq!(read(&mut chip, 2_200, reg::BUS), 0x2570);
    assert_eq!(read(&mut chip, 2_200, reg::CURRENT), 0x2710);
    assert_eq!(read(&mut chip, 2_200, reg::POWER), 0x12B8);
}

#[test]
fn conversion_timing_and_averaging_of_a_ramp() {
    let mut chip = SimIna226::default();
    // Ramps in 1 µs steps: I = 2 mA/µs (4 shunt LSB/µs on 5 mΩ), V = 10 V + 1 mV/µs.
    let current = |t: u64| t as f64 * 0.002;
    let volts = |t: u64| 10.0 + t as f64 * 0.001;
    for t in 0..=5_000 {
        chip.set_input(t, current(t), volts(t));
    }
    write(&mut chip, 0, reg::CONFIG, BOARD);
    write(&mut chip, 0, reg::CALIBRATION, 2048);
    for t in [0, 280, 4_000, 4_479] {
        assert_eq!(
            read(&mut chip, t, reg::MASK_ENABLE) & MASK_CVRF,
            0,
            "t = {t}"
        );
        assert_eq!(
            read(&mut chip, t, reg::SHUNT),
            0,
            "no result before 4.48 ms"
        );
    }
    assert_eq!(
        read(&mut chip, 4_480, reg::MASK_ENABLE) & MASK_CVRF,
        MASK_CVRF
    );
    // Each of the 16 conversions samples shunt at the middle of its 140 µs shunt window and
    // bus at the middle of the following 140 µs bus window.
    let shunt_mean: f64 = (0..16)
        .map(|j| current(280 * j + 70) * 0.005 / 2.5e-6)
        .sum::<f64>()
        / 16.0;
    let bus_mean: f64 = (0..16).map(|j| volts(280 * j + 210) / 1.25e-3).sum::<f64>() / 16.0;
    let shunt = read(&mut chip, 4_480, reg::SHUNT) as i16;
    let bus = read(&mut chip, 4_480, reg::BUS);
    assert_eq!(f64::from(shunt), shunt_mean.round());
    assert_eq!(f64::from(bus), bus_mean.round());
    // Within half a conversion (70 µs of ramp) of the mean over the whole 4.48 ms window.
    let window_shunt = current(2_240) * 0.005 / 2.5e-6;
    let window_bus = volts(2_240) / 1.25e-3;
    assert!((f64::from(shunt) - window_shunt).abs() <= 70.0 * 4.0 + 0.5);
    assert!((f64::from(bus) - window_bus).abs() <= 70.0 * 0.8 + 0.5);
    assert_eq!(read(&mut chip, 4_480, reg::CURRENT) as i16, shunt);
    // Reading mask/enable cleared CVRF; the next result comes at 8.96 ms.
    assert_eq!(read(&mut chip, 8_959, reg::MASK_ENABLE) & MASK_CVRF, 0);
    assert_eq!(
        read(&mut chip, 8_960, reg::MASK_ENABLE) & MASK_CVRF,
        MASK_CVRF
    );
}

#[test]
fn configuration_write_restarts_the_cycle_and_clears_cvrf() {
    let mut chip = one_result(1.0, 12.0);
    assert_eq!(chip.peek(reg::MASK_ENABLE) & MASK_CVRF, MASK_CVRF);
    write(&mut chip, 400, reg::CONFIG, FAST);
    assert_eq!(chip.peek(reg::MASK_ENABLE) & MASK_CVRF, 0);
    // Registers keep the old result until the new cycle's first result at 400 + 280.
    assert_eq!(chip.peek(reg::SHUNT), 2_000);
    chip.advance_to(679);
    assert_eq!(chip.peek(reg::MASK_ENABLE) & MASK_CVRF, 0);
    chip.advance_to(680);
    assert_eq!(chip.peek(reg::MASK_ENABLE) & MASK_CVRF, MASK_CVRF);
}

#[test]
fn quantisation_and_clamping() {
    let shunt = |volts: f64| one_result(volts / 0.005, 12.0).peek(reg::SHUNT) as i16;
    assert_eq!(shunt(0.0), 0);
    assert_eq!(shunt(1.24e-6), 0);
    assert_eq!(shunt(1.26e-6), 1);
    assert_eq!(shunt(-1.26e-6), -1);
    assert_eq!(shunt(0.02), 8_000);
    assert_eq!(shunt(0.081_917_5), 32_767);
    assert_eq!(
        shunt(0.081_92),
        32_767,
        "+81.92 mV is one LSB beyond full scale"
    );
    assert_eq!(shunt(0.2), 32_767);
    assert_eq!(shunt(-0.081_92), -32_768);
    assert_eq!(shunt(-0.2), -32_768);
    assert_eq!(shunt(f64::NAN), 0);
    let bus = |volts: f64| one_result(0.0, volts).peek(reg::BUS);
    assert_eq!(bus(0.0), 0);
    assert_eq!(bus(0.000_6), 0);
    assert_eq!(bus(0.000_7), 1);
    assert_eq!(bus(12.0), 9_600);
    assert_eq!(bus(40.958_75), 0x7FFF);
    assert_eq!(bus(40.96), 0x7FFF);
    assert_eq!(bus(60.0), 0x7FFF);
    assert_eq!(bus(-3.0), 0);
    assert_eq!(bus(f64::INFINITY), 0x7FFF);
}

#[test]
fn negative_current_gives_negative_registers_and_positive_power() {
    let mut chip = chip_with(0.002);
    chip.set_input(0, -10.0, 11.98);
    write(&mut chip, 0, reg::CALIBRATION, 0x0A00);
    chip.advance_to(2_200);
    assert_eq!(chip.peek(reg::SHUNT) as i16, -8_000);
    assert_eq!(chip.peek(reg::CURRENT) as i16, -10_000);
    assert_eq!(chip.peek(reg::POWER), 0x12B8);
}

#[test]
fn current_truncates_toward_zero_and_overflow_sets_ovf() {
    // 5 mΩ: 1 shunt LSB = 0.5 mA.
    let current = |shunt_lsb: f64, cal: u16| {
        let mut chip = one_result(shunt_lsb * 0.0005, 12.0);
        write(&mut chip, 300, reg::CALIBRATION, cal);
        write(&mut chip, 300, reg::CONFIG, FAST);
        chip.advance_to(580);
        (
            chip.peek(reg::CURRENT) as i16,
            chip.peek(reg::MASK_ENABLE) & MASK_OVF,
        )
    };
    assert_eq!(current(-1.0, 2047), (0, 0));
    assert_eq!(current(3.0, 1000), (1, 0));
    assert_eq!(current(-3.0, 1000), (-1, 0));
    assert_eq!(current(30_000.0, 0x7FFF), (i16::MAX, MASK_OVF));
    assert_eq!(current(-30_000.0, 0x7FFF), (i16::MIN, MASK_OVF));
}

#[test]
fn writable_registers_and_reset() {
    let mut chip = SimIna226::default();
    write(&mut chip, 0, reg::CALIBRATION, 0xFFFF);
    assert_eq!(
        chip.peek(reg::CALIBRATION),
        0x7FFF,
        "CAL bit 15 is not implemented"
    );
    write(&mut chip, 0, reg::CONFIG, 0x0527);
    assert_eq!(chip.peek(reg::CONFIG), 0x4527, "bits 14–12 read 100b");
    write(&mut chip, 0, reg::MASK_ENABLE, 0xFFFF);
    assert_eq!(chip.peek(reg::MASK_ENABLE), 0xFC03, "flags are read-only");
    write(&mut chip, 0, reg::ALERT_LIMIT, 0xBEEF);
    assert_eq!(chip.peek(reg::ALERT_LIMIT), 0xBEEF);
    for register in [
        reg::SHUNT,
        reg::BUS,
        reg::POWER,
        reg::CURRENT,
        reg::MANUFACTURER_ID,
        reg::DIE_ID,
        0x08,
        0x80,
    ] {
        let before = chip.peek(register);
        write(&mut chip, 0, register, 0x1234);
        assert_eq!(chip.peek(register), before, "register {register:#04x}");
    }
    // A two-byte frame only sets the pointer (the register is written with its LSB).
    chip.write_frame(0, &[reg::ALERT_LIMIT, 0x00]);
    assert_eq!(chip.peek(reg::ALERT_LIMIT), 0xBEEF);
    assert_eq!(chip.pointer(), reg::ALERT_LIMIT);
    let mut one = [0u8; 1];
    chip.read_frame(0, &mut one);
    assert_eq!(one, [0xBE]);

    chip.set_input(0, 2.0, 24.0);
    chip.advance_to(100_000); // AVG 16 × 2.2 ms = 35.2 ms per result
    assert_ne!(chip.peek(reg::SHUNT), 0);
    write(&mut chip, 100_000, reg::CONFIG, 0x8000 | FAST);
    for register in [
        reg::CONFIG,
        reg::SHUNT,
        reg::BUS,
        reg::POWER,
        reg::CURRENT,
        reg::CALIBRATION,
        reg::MASK_ENABLE,
        reg::ALERT_LIMIT,
    ] {
        let default = SimIna226::default().peek(register);
        assert_eq!(chip.peek(register), default, "register {register:#04x}");
    }
    // The reset also restarted conversions with the default configuration (2.2 ms).
    chip.advance_to(102_199);
    assert_eq!(chip.peek(reg::MASK_ENABLE), 0);
    chip.advance_to(102_200);
    assert_eq!(chip.peek(reg::MASK_ENABLE), MASK_CVRF);
    assert_eq!(chip.peek(reg::SHUNT), 4_000);
}

#[test]
fn power_down_and_triggered_modes() {
    let mut chip = one_result(1.0, 12.0);
    write(&mut chip, 300, reg::CONFIG, 0x4000); // power-down
    chip.set_input(300, 3.0, 20.0);
    chip.advance_to(1_000_000);
    assert_eq!(chip.peek(reg::MASK_ENABLE) & MASK_CVRF, 0);
    assert_eq!(chip.peek(reg::SHUNT), 2_000, "registers hold in power-down");
    // Triggered shunt and bus (011): one result 280 µs after the write, then nothing.
    write(&mut chip, 1_000_000, reg::CONFIG, 0x4003);
    assert_eq!(
        read(&mut chip, 1_000_280, reg::MASK_ENABLE) & MASK_CVRF,
        MASK_CVRF
    );
    assert_eq!(chip.peek(reg::SHUNT), 6_000);
    assert_eq!(chip.peek(reg::BUS), 16_000);
    chip.advance_to(2_000_000);
    assert_eq!(chip.peek(reg::MASK_ENABLE) & MASK_CVRF, 0);
    // Continuous shunt only (101): the bus register keeps its value.
    chip.set_input(2_000_000, -1.0, 5.0);
    write(&mut chip, 2_000_000, reg::CONFIG, 0x4005);
    chip.advance_to(2_000_140);
    assert_eq!(chip.peek(reg::SHUNT) as i16, -2_000);
    assert_eq!(chip.peek(reg::BUS), 16_000);
    assert_eq!(chip.peek(reg::CURRENT) as i16, -2_000);
}

#[test]
fn noise_is_gaussian_seeded_and_averaged_down() {
    let results = |seed: u64, config: u16, period: u64| {
        let mut chip = SimIna226::new(Analog {
            shunt_noise_lsb: 8.0,
            shunt_offset_lsb: 3.0,
            seed,
            ..Analog::IDEAL
        });
        chip.set_input(0, 1.0, 12.0);
        write(&mut chip, 0, reg::CONFIG, config);
        (1..=2_000)
            .map(|k| {
                chip.advance_to(k * period);
                f64::from(chip.peek(reg::SHUNT) as i16) - 2_000.0
            })
            .collect::<Vec<f64>>()
    };
    let stats = |v: &[f64]| {
        let mean = v.iter().sum::<f64>() / v.len() as f64;
        let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (v.len() - 1) as f64;
        (mean, var.sqrt())
    };
    let single = results(7, FAST, 280);
    let (mean, sd) = stats(&single);
    assert!((mean - 3.0).abs() < 0.6, "offset: mean {mean}");
    assert!((sd - 8.0).abs() < 0.6, "sd {sd}");
    let (mean, sd) = stats(&results(7, BOARD, 4_480));
    assert!((mean - 3.0).abs() < 0.3, "mean {mean}");
    assert!((sd - 2.0).abs() < 0.3, "AVG 16 divides the sd by 4: {sd}");
    assert_eq!(results(7, FAST, 280), single, "same seed, same run");
    assert_ne!(results(8, FAST, 280), single);
}

#[test]
fn a_long_gap_costs_at_most_two_results() {
    let mut chip = SimIna226::default();
    chip.set_input(0, 1.0, 12.0);
    write(&mut chip, 0, reg::CONFIG, 0x4FFF); // AVG 1024, 8.244 ms + 8.244 ms
    chip.advance_to(u64::MAX);
    assert_eq!(chip.peek(reg::SHUNT), 2_000);
    assert_eq!(chip.peek(reg::MASK_ENABLE) & MASK_CVRF, MASK_CVRF);
    assert_eq!(chip.now_us(), u64::MAX);
    chip.advance_to(0); // time never goes backwards
    assert_eq!(chip.now_us(), u64::MAX);
}
