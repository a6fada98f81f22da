//! A sample frame carried inside its physical sample's message: what the frame says that the
//! sample does not, so the frame is rebuilt bit for bit on reading instead of being stored a
//! second time (it was half of an hour's log: 768 k frame messages beside 727 k samples, each
//! with its own MCAP record and index entry).
//!
//! The message is `rover_power.BoardSample`, the sample's field `board` ([`super::proto`]).
//!
//! The bus register is the sample's `bus_v` over its 1.25 mV LSB, the current register its
//! shunt register unless said (they are equal at our board's CAL of 2048), and the power
//! register the chip's Eq 4 on both; `stale` holds a bit per side (1 left, 2 right) whose chip
//! sent no new result. The writer embeds a frame only where this rebuilds it exactly (and keeps
//! it on the frame channel otherwise), so the reader's frames are the board's.

use super::proto::{self, Value};
use crate::log::run_csv::RunSample;
use model_core::ina226::{BusVoltageRaw, CurrentRaw, Registers, ShuntVoltageRaw, BUS_LSB_UV};
use model_core::wire::{ChipReading, Sample};
use model_core::Sides;

/// The bus register (a count of 1.25 mV steps) nearest `bus_v`; `None` outside its range.
pub(super) fn bus_register(bus_v: f64) -> Option<u16> {
    let bus = (bus_v * 1e6 / f64::from(BUS_LSB_UV)).round();
    (0.0..=f64::from(u16::MAX))
        .contains(&bus)
        .then_some(bus as u16)
}

/// One chip's registers in a sample frame, and whether they are a stale read.
#[derive(Debug, Clone, Copy)]
pub(super) struct Chip {
    pub(super) shunt: i16,
    pub(super) bus: u16,
    pub(super) current: i16,
    pub(super) stale: bool,
}

/// The sample frame taken at board time `t_us` as sample `seq` with these chips' registers
/// (the power register is the chip's Eq 4 on current and bus); `None` for a bus register out of
/// the chip's range.
pub(super) fn sample_frame(t_us: u64, seq: u32, chips: Sides<Chip>) -> Option<Sample> {
    let chip = |c: Chip| {
        let (bus, current) = (BusVoltageRaw(c.bus), CurrentRaw(c.current));
        let registers = Registers {
            shunt: ShuntVoltageRaw(c.shunt),
            bus,
            current,
            power: Registers::power_of(current, bus)?,
        };
        Some(match c.stale {
            true => ChipReading::Stale(registers),
            false => ChipReading::Fresh(registers),
        })
    };
    Some(Sample {
        t_us,
        seq,
        chips: Sides::new(chip(chips.left)?, chip(chips.right)?),
    })
}

/// The frame's part beyond the physical sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct BoardSample {
    pub(super) t_us: u64,
    pub(super) seq: u32,
    pub(super) shunt: Sides<i16>,
    /// The current register where it is not the shunt register's value.
    current: Sides<Option<i16>>,
    pub(super) stale: Sides<bool>,
}

impl BoardSample {
    /// The part of a frame with these registers (tests build batches with it).
    #[cfg(test)]
    pub(super) fn new(
        t_us: u64,
        seq: u32,
        shunt: Sides<i16>,
        current: Sides<i16>,
        stale: Sides<bool>,
    ) -> Self {
        let differs = |current: i16, shunt: i16| (current != shunt).then_some(current);
        BoardSample {
            t_us,
            seq,
            shunt,
            current: Sides::new(
                differs(current.left, shunt.left),
                differs(current.right, shunt.right),
            ),
            stale,
        }
    }

    /// The current register of each side.
    pub(super) fn current_register(&self) -> Sides<i16> {
        Sides::new(
            self.current.left.unwrap_or(self.shunt.left),
            self.current.right.unwrap_or(self.shunt.right),
        )
    }

    /// `frame`'s part beyond `sample`, if the two rebuild `frame` exactly.
    pub(crate) fn of(frame: &Sample, sample: &RunSample) -> Option<Self> {
        let registers = |c: ChipReading| match c {
            ChipReading::Fresh(r) => Some((r, false)),
            ChipReading::Stale(r) => Some((r, true)),
            ChipReading::Failed(_) => None,
        };
        let (left, left_stale) = registers(frame.chips.left)?;
        let (right, right_stale) = registers(frame.chips.right)?;
        let differs = |r: Registers| (r.current.0 != r.shunt.0).then_some(r.current.0);
        let part = BoardSample {
            t_us: frame.t_us,
            seq: frame.seq,
            shunt: Sides::new(left.shunt.0, right.shunt.0),
            current: Sides::new(differs(left), differs(right)),
            stale: Sides::new(left_stale, right_stale),
        };
        (part.frame(sample)? == *frame).then_some(part)
    }

    /// The sample frame this part and `sample` make.
    pub(crate) fn frame(&self, sample: &RunSample) -> Option<Sample> {
        // The writer checks the volts are the register's.
        self.frame_at(Sides::new(
            bus_register(sample.bus_v.left)?,
            bus_register(sample.bus_v.right)?,
        ))
    }

    /// The sample frame this part makes with these bus registers.
    pub(crate) fn frame_at(&self, bus: Sides<u16>) -> Option<Sample> {
        let chip = |bus, shunt: i16, current: Option<i16>, stale| Chip {
            shunt,
            bus,
            current: current.unwrap_or(shunt),
            stale,
        };
        sample_frame(
            self.t_us,
            self.seq,
            Sides::new(
                chip(
                    bus.left,
                    self.shunt.left,
                    self.current.left,
                    self.stale.left,
                ),
                chip(
                    bus.right,
                    self.shunt.right,
                    self.current.right,
                    self.stale.right,
                ),
            ),
        )
    }

    /// Writes the part's fields into a `BoardSample` message.
    pub(crate) fn write(&self, w: &mut proto::Writer) {
        w.varint(1, self.t_us);
        w.varint(2, u64::from(self.seq));
        w.sint(3, i64::from(self.shunt.left));
        w.sint(4, i64::from(self.shunt.right));
        if let Some(c) = self.current.left {
            w.sint(5, i64::from(c));
        }
        if let Some(c) = self.current.right {
            w.sint(6, i64::from(c));
        }
        let stale = u64::from(self.stale.left) | u64::from(self.stale.right) << 1;
        if stale != 0 {
            w.varint(7, stale);
        }
    }

    /// The part a `BoardSample` message holds.
    pub(crate) fn read(data: &[u8]) -> Result<Self, String> {
        let mut t_us = None;
        let mut seq = None;
        let mut shunt = [None; 2];
        let mut current = [None; 2];
        let mut stale = 0;
        for item in proto::Fields::of(data) {
            let (field, value) = item?;
            let Value::Varint(v) = value else {
                return Err(format!(
                    "BoardSample field {field}: expected a varint, found {value:?}"
                ));
            };
            let register = || {
                i16::try_from(proto::unzigzag(v))
                    .map_err(|_| format!("BoardSample field {field}: {v} is no register value"))
            };
            match field {
                1 => t_us = Some(v),
                2 => seq = Some(u32::try_from(v).map_err(|_| format!("seq {v} is out of range"))?),
                3 | 4 => shunt[field as usize - 3] = Some(register()?),
                5 | 6 => current[field as usize - 5] = Some(register()?),
                7 => stale = v,
                _ => {}
            }
        }
        let need = |v: Option<i16>, name: &str| v.ok_or_else(|| format!("BoardSample: no {name}"));
        Ok(BoardSample {
            t_us: t_us.ok_or("BoardSample: no t_us")?,
            seq: seq.ok_or("BoardSample: no seq")?,
            shunt: Sides::new(
                need(shunt[0], "shunt_left")?,
                need(shunt[1], "shunt_right")?,
            ),
            current: Sides::new(current[0], current[1]),
            stale: Sides::new(stale & 1 != 0, stale & 2 != 0),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use model_core::ina226::{PowerRaw, Scale};
    use model_core::wire::ChipFault;

    fn frame(left: ChipReading, right: ChipReading) -> Sample {
        Sample {
            t_us: 1_234_567,
            seq: 42,
            chips: Sides::new(left, right),
        }
    }

    fn registers(shunt: i16, bus: u16, current: i16) -> Registers {
        let (current, bus) = (CurrentRaw(current), BusVoltageRaw(bus));
        Registers {
            shunt: ShuntVoltageRaw(shunt),
            bus,
            current,
            power: Registers::power_of(current, bus).expect("valid bus"),
        }
    }

    /// The physical sample the recorder makes of `frame` (both chips read).
    fn physical(frame: &Sample) -> RunSample {
        let r = frame.chips.map(|c| c.registers().expect("read"));
        let scale = Scale::BOARD;
        RunSample {
            t_s: 0.5,
            bus_v: r.map(|r| scale.bus_v(r.bus)),
            current_a: r.map(|r| scale.current_a(r.current)),
            cmd_mps: Sides::new(0.2, 0.4),
            yaw_rad: None,
            pitch_deg: None,
            x_m: None,
            y_m: None,
        }
    }

    fn through_a_message(part: &BoardSample) -> BoardSample {
        let mut w = proto::Writer::new();
        part.write(&mut w);
        BoardSample::read(&w.into_bytes()).expect("reads")
    }

    #[test]
    fn a_sample_frame_rebuilds_bit_for_bit_at_every_register_extreme() {
        let mut cases = Vec::new();
        for bus in [0u16, 1, 19_200, 0x7FFF] {
            for current in [i16::MIN, -1, 0, 1, 4_000, i16::MAX] {
                let fresh = ChipReading::Fresh(registers(current, bus, current));
                // Another CAL than ours (current ≠ shunt), and a chip with no new result.
                let other = ChipReading::Stale(registers(current / 2, bus, current));
                cases.push(frame(fresh, other));
                cases.push(frame(other, fresh));
            }
        }
        for f in cases {
            let sample = physical(&f);
            let part = BoardSample::of(&f, &sample).unwrap_or_else(|| panic!("{f:?}"));
            let back = through_a_message(&part);
            assert_eq!(back, part);
            assert_eq!(back.frame(&sample), Some(f));
        }
    }

    #[test]
    fn a_frame_the_part_cannot_rebuild_is_not_folded() {
        let ok = ChipReading::Fresh(registers(100, 19_200, 100));
        // A failed chip: no physical sample to fold into.
        let failed = frame(ok, ChipReading::Failed(ChipFault::AddressNack));
        assert_eq!(BoardSample::of(&failed, &physical(&frame(ok, ok))), None);
        // A power register that is not Eq 4 of the others (not the chip's arithmetic).
        let mut odd = registers(100, 19_200, 100);
        odd.power = PowerRaw(odd.power.0 + 1);
        let f = frame(ok, ChipReading::Fresh(odd));
        assert_eq!(BoardSample::of(&f, &physical(&f)), None);
        // A bus voltage in the sample that is not the register's.
        let f = frame(ok, ok);
        let mut sample = physical(&f);
        sample.bus_v.left += 0.001;
        assert_eq!(BoardSample::of(&f, &sample), None);
    }

    #[test]
    fn a_damaged_part_is_an_error_not_a_panic() {
        for bad in [
            &[0x08][..],                                          // t_us cut short
            &[0x08, 1],                                           // no seq, no shunts
            &[0x08, 1, 0x10, 1, 0x18],                            // a shunt cut short
            &[0x09, 0, 0, 0, 0, 0, 0, 0, 0],                      // t_us as a double
            &[0x08, 1, 0x10, 1, 0x18, 0xff, 0xff, 0x07, 0x20, 0], // a shunt past i16
        ] {
            assert!(BoardSample::read(bad).is_err(), "{bad:?}");
        }
    }
}
