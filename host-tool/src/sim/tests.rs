use super::ina226::{reg, MASK_CVRF};
use super::*;
use firmware::ina226::{Ina226, BOARD_CALIBRATION};
use firmware::sampler::{Sampler, SamplerConfig};
use model_core::ina226::{AdcConfig, Registers};
use model_core::wire::{ChipFault, ChipReading};
use model_core::Sides;
use proptest::prelude::*;

const LEFT: u8 = 0x40;
const RIGHT: u8 = 0x45;
const ADDRESS_NACK: ErrorKind = ErrorKind::NoAcknowledge(NoAcknowledgeSource::Address);
const DATA_NACK: ErrorKind = ErrorKind::NoAcknowledge(NoAcknowledgeSource::Data);

fn read(bus: &mut SimBus, address: u8, register: u8) -> Result<u16, ErrorKind> {
    let mut buf = [0u8; 2];
    bus.write_read(address, &[register], &mut buf)?;
    Ok(u16::from_be_bytes(buf))
}

/// Writes CAL = 2048 to the left chip with pointer and data in two write buffers of one
/// transaction (one frame on the bus).
fn write_calibration_split(bus: &mut SimBus) {
    bus.transaction(
        LEFT,
        &mut [
            Operation::Write(&[reg::CALIBRATION]),
            Operation::Write(&[0x08, 0x00]),
        ],
    )
    .expect("acked");
}

fn write(bus: &mut SimBus, address: u8, register: u8, value: u16) -> Result<(), ErrorKind> {
    let [hi, lo] = value.to_be_bytes();
    bus.write(address, &[register, hi, lo])
}

/// The registers of `amps` at `volts` on the board (5 mΩ, CAL 2048, 0.5 mA LSB).
fn board_registers(amps: f64, volts: f64) -> Registers {
    let lsb = (amps / 0.0005).round() as i16;
    let bus = (volts / 1.25e-3).round() as u16;
    Registers {
        shunt: model_core::ina226::ShuntVoltageRaw(lsb),
        bus: model_core::ina226::BusVoltageRaw(bus),
        current: model_core::ina226::CurrentRaw(lsb),
        power: model_core::ina226::PowerRaw(
            (i32::from(lsb).unsigned_abs() * u32::from(bus) / 20_000) as u16,
        ),
    }
}

#[test]
fn missing_chip_nacks_its_address_and_is_counted() {
    let mut bus = SimBus::board();
    assert_eq!(read(&mut bus, 0x41, reg::DIE_ID), Err(ADDRESS_NACK));
    assert_eq!(read(&mut bus, LEFT, reg::DIE_ID), Ok(0x2260));
    assert_eq!(read(&mut bus, RIGHT, reg::MANUFACTURER_ID), Ok(0x5449));
    assert_eq!(
        bus.counts(0x41),
        TransactionCounts {
            transactions: 1,
            failed: 1
        }
    );
    assert_eq!(
        bus.counts(LEFT),
        TransactionCounts {
            transactions: 1,
            failed: 0
        }
    );
}

#[test]
fn bus_time_follows_the_timing_model() {
    let mut bus = SimBus::board();
    assert_eq!(bus.timing(), I2cTiming::FAST_MODE);
    // Register read: START, addr+W, pointer, Sr, addr+R, 2 data bytes, STOP = 48 periods.
    read(&mut bus, LEFT, reg::DIE_ID).expect("acked");
    assert_eq!(bus.bus_bits(), 48);
    assert_eq!(bus.bus_time_ns(), 120_000, "48 × 2.5 µs");
    // Register write: START, addr+W, pointer, 2 data bytes, STOP = 38 periods.
    write(&mut bus, LEFT, reg::CALIBRATION, 2048).expect("acked");
    assert_eq!(bus.bus_bits(), 48 + 38);
    // Split write buffers are still one frame.
    write_calibration_split(&mut bus);
    assert_eq!(bus.bus_bits(), 48 + 2 * 38);
    // A NACKed address costs START, address byte, STOP; so does an injected fault.
    assert!(read(&mut bus, 0x41, reg::DIE_ID).is_err());
    bus.fail_next(RIGHT, 1, DATA_NACK);
    assert!(read(&mut bus, RIGHT, reg::DIE_ID).is_err());
    assert_eq!(bus.bus_bits(), 48 + 2 * 38 + 2 * 11);
    // An empty transaction puts nothing on the bus.
    bus.transaction(LEFT, &mut []).expect("acked");
    assert_eq!(bus.bus_bits(), 48 + 2 * 38 + 2 * 11);
    // Standard mode: four times as long for the same traffic.
    let bits = bus.bus_bits();
    bus.set_timing(I2cTiming { scl_hz: 100_000 });
    assert_eq!(bus.bus_time_ns(), bits * 10_000);
    assert_eq!(I2cTiming { scl_hz: 0 }.bits_to_ns(1), 1_000_000_000);
}

#[test]
fn firmware_sample_bus_time() {
    // A steady-state sample reads shunt and bus per chip, one of them without its pointer:
    // 2 × (29 + 48) = 154 SCL periods = 385 µs at 400 kHz; a calibration read-back adds
    // one read with pointer (48) to one chip, every 32nd sample.
    let mut bus = SimBus::board();
    let mut sampler = Sampler::new(SamplerConfig::BOARD);
    let mut t = 0;
    let mut per_sample = Vec::new();
    for _ in 0..600 {
        bus.set_time_us(t);
        let before = bus.bus_bits();
        sampler.sample(&mut bus, t).expect("running");
        per_sample.push(bus.bus_bits() - before);
        t += 5_000;
    }
    // Sample 0 initialises (IDs, config, calibration) and reads nothing: no result yet.
    assert_eq!(per_sample[0], 2 * (2 * 48 + 2 * 38));
    // Sample 1: the chips point at CAL after set-up, so both reads send their pointer.
    assert_eq!(per_sample[1], 2 * 2 * 48);
    assert!(per_sample[2..].iter().all(|&b| b == 154 || b == 202));
    assert_eq!(per_sample[32], 202, "right chip's read-back");
    assert_eq!(per_sample[64], 202, "left chip's read-back");
    assert_eq!(per_sample[2..].iter().filter(|&&b| b == 202).count(), 18);
}

#[test]
fn adjacent_operations_form_one_frame() {
    let mut bus = SimBus::board();
    // Pointer and data split over two write buffers: still one 3-byte write frame.
    write_calibration_split(&mut bus);
    assert_eq!(bus.peek(LEFT, reg::CALIBRATION), Some(2048));
    // A one-byte write sets the pointer for a later, separate read.
    bus.write(LEFT, &[reg::DIE_ID]).expect("acked");
    let (mut hi, mut lo) = ([0u8; 1], [0u8; 1]);
    bus.transaction(
        LEFT,
        &mut [Operation::Read(&mut hi), Operation::Read(&mut lo)],
    )
    .expect("acked");
    assert_eq!(u16::from_be_bytes([hi[0], lo[0]]), 0x2260);
    assert_eq!(bus.counts(LEFT).transactions, 3);
}

#[test]
fn unplug_replug_and_brown_out() {
    let mut bus = SimBus::board();
    bus.set_input(LEFT, 0, 2.0, 24.0);
    write(&mut bus, LEFT, reg::CALIBRATION, 2048).expect("acked");
    write(&mut bus, LEFT, reg::CONFIG, 0x4407).expect("acked");
    bus.set_time_us(4_480);
    assert_eq!(read(&mut bus, LEFT, reg::CURRENT), Ok(4_000));

    assert!(bus.unplug(LEFT));
    assert!(!bus.is_plugged(LEFT));
    bus.set_time_us(10_000);
    assert_eq!(read(&mut bus, LEFT, reg::CURRENT), Err(ADDRESS_NACK));
    assert_eq!(
        write(&mut bus, LEFT, reg::CALIBRATION, 1),
        Err(ADDRESS_NACK)
    );
    assert_eq!(bus.peek(LEFT, reg::CALIBRATION), None);
    assert!(bus.plug(LEFT));
    // Powered up with its defaults at 10 ms: CAL 0, default config, first result 2.2 ms on.
    assert_eq!(read(&mut bus, LEFT, reg::CALIBRATION), Ok(0));
    assert_eq!(read(&mut bus, LEFT, reg::CONFIG), Ok(0x4127));
    assert_eq!(read(&mut bus, LEFT, reg::SHUNT), Ok(0));
    bus.set_time_us(12_200);
    assert_eq!(read(&mut bus, LEFT, reg::MASK_ENABLE), Ok(MASK_CVRF));
    assert_eq!(
        read(&mut bus, LEFT, reg::SHUNT),
        Ok(4_000),
        "input kept flowing"
    );
    assert_eq!(read(&mut bus, LEFT, reg::CURRENT), Ok(0), "no calibration");

    write(&mut bus, LEFT, reg::CALIBRATION, 2048).expect("acked");
    bus.set_time_us(20_000);
    assert_eq!(read(&mut bus, LEFT, reg::CURRENT), Ok(4_000));
    assert!(bus.brown_out(LEFT));
    assert!(bus.is_plugged(LEFT), "a brown-out does not unplug");
    assert_eq!(read(&mut bus, LEFT, reg::CALIBRATION), Ok(0));
    assert_eq!(read(&mut bus, LEFT, reg::SHUNT), Ok(0));
    bus.set_time_us(22_200);
    assert_eq!(read(&mut bus, LEFT, reg::SHUNT), Ok(4_000));
    assert!(!bus.brown_out(0x41) && !bus.unplug(0x41) && !bus.plug(0x41));
    // The other chip never noticed.
    assert_eq!(read(&mut bus, RIGHT, reg::DIE_ID), Ok(0x2260));
}

#[test]
fn injected_faults_fail_exactly_the_next_transactions() {
    let mut bus = SimBus::board();
    bus.fail_next(LEFT, 2, DATA_NACK);
    bus.fail_next(RIGHT, 1, ErrorKind::ArbitrationLoss);
    assert_eq!(
        write(&mut bus, LEFT, reg::CALIBRATION, 2048),
        Err(DATA_NACK)
    );
    assert_eq!(read(&mut bus, LEFT, reg::CALIBRATION), Err(DATA_NACK));
    assert_eq!(
        read(&mut bus, LEFT, reg::CALIBRATION),
        Ok(0),
        "faults do not reach the chip"
    );
    assert_eq!(
        read(&mut bus, RIGHT, reg::DIE_ID),
        Err(ErrorKind::ArbitrationLoss)
    );
    assert_eq!(read(&mut bus, RIGHT, reg::DIE_ID), Ok(0x2260));
    bus.fail_next(RIGHT, 1, ErrorKind::Bus);
    bus.fail_next(RIGHT, 0, ErrorKind::Bus); // cancels
    assert_eq!(read(&mut bus, RIGHT, reg::DIE_ID), Ok(0x2260));
    assert_eq!(
        bus.counts(LEFT),
        TransactionCounts {
            transactions: 3,
            failed: 2
        }
    );
    assert_eq!(
        bus.counts(RIGHT),
        TransactionCounts {
            transactions: 3,
            failed: 1
        }
    );
}

#[test]
fn firmware_driver_runs_against_the_model() {
    let mut bus = SimBus::board();
    bus.set_input(LEFT, 0, -7.3, 25.2);
    let mut driver = Ina226::new(LEFT, BOARD_CALIBRATION, AdcConfig::BOARD_DEFAULT);
    driver.init(&mut bus).expect("an INA226 answers");
    assert_eq!(bus.peek(LEFT, reg::CONFIG), Some(0x4407));
    assert_eq!(driver.calibration_lost(&mut bus), Ok(false));
    bus.set_time_us(4_479);
    assert_eq!(driver.conversion_ready(&mut bus), Ok(false));
    bus.set_time_us(4_480);
    assert_eq!(driver.conversion_ready(&mut bus), Ok(true));
    assert_eq!(
        driver.conversion_ready(&mut bus),
        Ok(false),
        "read clears it"
    );
    let regs = driver.read_registers(&mut bus).expect("acked");
    assert_eq!(regs, board_registers(-7.3, 25.2));
    assert_eq!(regs.signed_power_lsb(), -(14_600 * 20_160 / 20_000));
    driver.reset(&mut bus).expect("acked");
    assert_eq!(driver.calibration_lost(&mut bus), Ok(true));
}

#[test]
fn sampler_readings_follow_the_firmware_logic() {
    let mut bus = SimBus::board();
    bus.set_input(LEFT, 0, 2.0, 24.0);
    bus.set_input(RIGHT, 0, -1.0, 24.0);
    let mut s = Sampler::new(SamplerConfig::BOARD);
    let mut at = |bus: &mut SimBus, t_us: u64| {
        bus.set_time_us(t_us);
        s.sample(bus, t_us).expect("running").chips
    };
    let awaiting = ChipReading::Failed(ChipFault::AwaitingConversion);
    assert_eq!(at(&mut bus, 0), Sides::new(awaiting, awaiting));
    let fresh = Sides::new(
        ChipReading::Fresh(board_registers(2.0, 24.0)),
        ChipReading::Fresh(board_registers(-1.0, 24.0)),
    );
    assert_eq!(at(&mut bus, 5_000), fresh);
    assert_eq!(at(&mut bus, 10_000), fresh);
    assert_eq!(at(&mut bus, 12_000), fresh);

    bus.unplug(RIGHT);
    let right = at(&mut bus, 17_000).right;
    assert_eq!(right, ChipReading::Failed(ChipFault::AddressNack));
    bus.plug(RIGHT);
    assert_eq!(at(&mut bus, 22_000).right, awaiting, "set up again");
    assert_eq!(at(&mut bus, 27_000), fresh);

    // Brown-out: the chip points at its configuration register again; the short read
    // returns the power-on value, and CAL reads 0.
    bus.brown_out(LEFT);
    assert_eq!(
        at(&mut bus, 32_000).left,
        ChipReading::Failed(ChipFault::ResetDetected)
    );
    assert_eq!(at(&mut bus, 37_000).left, awaiting);
    assert_eq!(at(&mut bus, 42_000), fresh);

    // A data NACK fails one reading; the result that was ready is still there next period.
    bus.fail_next(LEFT, 1, DATA_NACK);
    assert_eq!(
        at(&mut bus, 47_000).left,
        ChipReading::Failed(ChipFault::DataNack)
    );
    assert_eq!(at(&mut bus, 52_000), fresh);
    bus.fail_next(RIGHT, 1, ErrorKind::Bus);
    assert_eq!(
        at(&mut bus, 57_000).right,
        ChipReading::Failed(ChipFault::Bus)
    );
    assert_eq!(at(&mut bus, 62_000), fresh);

    assert_eq!(s.i2c_errors(), Sides::new(1, 2));
    assert_eq!(s.reinits(), Sides::new(1, 1));
    assert!(bus.counts(LEFT).transactions > 25);
    assert_eq!(bus.counts(RIGHT).failed, 2);
}

proptest! {
    /// The board reads shunt and bus and computes current and power: bit-identical to the
    /// chip's own registers for any input, calibration and averaging.
    #[test]
    fn derived_current_and_power_are_the_chips(
        amps in -20.0f64..20.0,
        volts in 0.0f64..40.0,
        current_lsb_ua in 80u32..4_000,
        averaging in 0usize..3,
        noise in 0.0f64..3.0,
        at_us in 300u64..3_000,
    ) {
        let mut bus = SimBus::new();
        let analog = Analog { shunt_noise_lsb: noise, bus_noise_lsb: noise, ..Analog::IDEAL };
        bus.insert(LEFT, SimIna226::new(analog));
        bus.set_input(LEFT, 0, amps, volts);
        let scale = model_core::ina226::Scale {
            current_lsb_na: current_lsb_ua * 1_000,
            shunt_micro_ohm: 5_000,
        };
        let cal = firmware::ina226::Calibration::new(scale).expect("fits 15 bits");
        let adc = AdcConfig {
            averaging: model_core::ina226::Averaging::ALL[averaging],
            ..crate::sim::throughput::FASTEST_ADC
        };
        let mut driver = Ina226::new(LEFT, cal, adc);
        driver.init(&mut bus).expect("answers");
        bus.set_time_us(at_us * 4);
        let chip = driver.read_registers(&mut bus).expect("acked");
        let read = driver.read_measurement(&mut bus, false).expect("acked");
        prop_assert_eq!(read.registers, Some(chip));
    }
}

#[test]
fn derived_current_and_power_at_the_edges() {
    // Overflow (the chip clamps), truncation of negative currents, zero bus.
    let cases = [
        (41.0, 36.0, 100),
        (-41.0, 36.0, 100),
        (-0.0004, 12.0, 500),
        (5.0, 0.0, 500),
    ];
    for (amps, volts, current_lsb_ua) in cases {
        let mut bus = SimBus::board();
        bus.set_input(LEFT, 0, amps, volts);
        let scale = model_core::ina226::Scale {
            current_lsb_na: current_lsb_ua * 1_000,
            shunt_micro_ohm: 5_000,
        };
        let cal = firmware::ina226::Calibration::new(scale).expect("fits");
        let mut driver = Ina226::new(LEFT, cal, AdcConfig::BOARD_DEFAULT);
        driver.init(&mut bus).expect("answers");
        bus.set_time_us(5_000);
        let chip = driver.read_registers(&mut bus).expect("acked");
        let read = driver.read_measurement(&mut bus, false).expect("acked");
        assert_eq!(read.registers, Some(chip), "{amps} A at {volts} V");
    }
}

#[test]
fn sampler_energy_matches_the_integral_of_v_i() {
    let mut bus = SimBus::board();
    let mut s = Sampler::new(SamplerConfig::BOARD);
    // Loads that step every 100 ms, with values that do not fall on register LSBs.
    let load = |k: u64| {
        let step = (k / 20) as f64;
        Sides::new(
            (1.2345 + 0.77 * (step * 0.9).sin(), 23.456 - 0.01 * step),
            (-0.6543 + 0.41 * step, 24.321 + 0.02 * step),
        )
    };
    let ticks = 400u64;
    let mut exact_j = 0.0;
    for k in 0..ticks {
        let t_us = k * 5_000;
        let l = load(k);
        bus.set_input(LEFT, t_us, l.left.0, l.left.1);
        bus.set_input(RIGHT, t_us, l.right.0, l.right.1);
        bus.set_time_us(t_us);
        s.sample(&mut bus, t_us);
        // The board's energy runs from its first good reading (t = 5 ms) to the last one;
        // the input set at tick k flows until tick k + 1.
        if (1..ticks - 1).contains(&k) {
            exact_j += (l.left.0 * l.left.1 + l.right.0 * l.right.1) * 0.005;
        }
    }
    let scale = model_core::ina226::Scale::BOARD;
    let board_j = scale.energy_j(s.measurements().total_energy_lsb_us());
    // Quantisation: ≤ 2 power LSB per side and reading; plus, at each load step, the one
    // reading whose 4.48 ms window straddles it (at most |ΔP| over one period).
    let power_w = |k: u64| {
        let l = load(k);
        l.left.0 * l.left.1 + l.right.0 * l.right.1
    };
    let steps_j: f64 = (20..ticks)
        .step_by(20)
        .map(|k| (power_w(k) - power_w(k - 1)).abs() * 0.005)
        .sum();
    let tolerance_j = ticks as f64 * 2.0 * 2.0 * scale.power_w(1) * 0.005 + steps_j;
    assert!(
        (board_j - exact_j).abs() < tolerance_j,
        "{board_j} J vs ∫VI dt = {exact_j} J (± {tolerance_j} J)"
    );
    assert!(
        exact_j.abs() > 10.0 * tolerance_j,
        "the check means something"
    );
}

#[derive(Debug, Clone)]
enum Step {
    Time(u64),
    Advance(u64),
    Input(u8, u64, f64, f64),
    Tx(u8, Vec<(bool, Vec<u8>)>),
    Unplug(u8),
    Plug(u8),
    BrownOut(u8),
    Fail(u8, u32, u8),
    Insert(u8, f64, f64, u64),
}

fn address() -> impl Strategy<Value = u8> {
    prop_oneof![Just(LEFT), Just(RIGHT), any::<u8>()]
}

fn step() -> impl Strategy<Value = Step> {
    let op = (any::<bool>(), proptest::collection::vec(any::<u8>(), 0..5));
    prop_oneof![
        any::<u64>().prop_map(Step::Time),
        (0u64..200_000).prop_map(Step::Advance),
        (address(), any::<u64>(), any::<f64>(), any::<f64>())
            .prop_map(|(a, t, i, v)| Step::Input(a, t, i, v)),
        (address(), proptest::collection::vec(op, 0..4)).prop_map(|(a, o)| Step::Tx(a, o)),
        address().prop_map(Step::Unplug),
        address().prop_map(Step::Plug),
        address().prop_map(Step::BrownOut),
        (address(), 0u32..4, 0u8..4).prop_map(|(a, n, k)| Step::Fail(a, n, k)),
        (address(), any::<f64>(), any::<f64>(), any::<u64>())
            .prop_map(|(a, r, n, s)| Step::Insert(a, r, n, s)),
    ]
}

proptest! {
    #[test]
    fn arbitrary_operations_never_panic(steps in proptest::collection::vec(step(), 0..60)) {
        let mut bus = SimBus::board();
        for step in steps {
            match step {
                Step::Time(t) => bus.set_time_us(t),
                Step::Advance(dt) => bus.set_time_us(bus.now_us().saturating_add(dt)),
                Step::Input(a, t, i, v) => {
                    bus.set_input(a, t, i, v);
                }
                Step::Tx(a, ops) => {
                    let mut bufs: Vec<(bool, Vec<u8>)> = ops;
                    let mut operations: Vec<Operation<'_>> = bufs
                        .iter_mut()
                        .map(|(is_read, b)| {
                            if *is_read {
                                Operation::Read(b.as_mut_slice())
                            } else {
                                Operation::Write(b.as_slice())
                            }
                        })
                        .collect();
                    let _ = bus.transaction(a, &mut operations);
                }
                Step::Unplug(a) => {
                    bus.unplug(a);
                }
                Step::Plug(a) => {
                    bus.plug(a);
                }
                Step::BrownOut(a) => {
                    bus.brown_out(a);
                }
                Step::Fail(a, n, k) => {
                    let kind = [DATA_NACK, ADDRESS_NACK, ErrorKind::Bus, ErrorKind::ArbitrationLoss];
                    bus.fail_next(a, n, kind[usize::from(k)]);
                }
                Step::Insert(a, shunt_ohm, noise, seed) => {
                    bus.insert(a, SimIna226::new(Analog {
                        shunt_ohm,
                        shunt_noise_lsb: noise,
                        bus_noise_lsb: noise,
                        seed,
                        ..Analog::IDEAL
                    }));
                }
            }
            for a in [LEFT, RIGHT] {
                if let Some(bus_reg) = bus.peek(a, reg::BUS) {
                    prop_assert!(bus_reg <= 0x7FFF);
                }
                if let Some(cal) = bus.peek(a, reg::CALIBRATION) {
                    prop_assert!(cal <= 0x7FFF);
                }
                if bus.is_plugged(a) {
                    prop_assert_eq!(bus.peek(a, reg::DIE_ID), Some(0x2260));
                }
                let c = bus.counts(a);
                prop_assert!(c.failed <= c.transactions);
            }
        }
    }
}
