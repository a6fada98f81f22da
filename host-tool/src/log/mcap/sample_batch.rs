//! The sample channel of a run log: samples in batches (`rover_power.SampleBatch` on
//! [`super::TOPIC_SAMPLE_BATCH`]), one value per sample in packed columns.
//!
//! One message a sample cost 85 B a sample (an hour: 67.6 MB), 26 B of it the MCAP record
//! header and message index entry alone; a batch of about 20 (one model period) pays those once.
//! The electrical readings are the chips' registers (bus in 1.25 mV steps, current in the
//! batch's `current_lsb_na`), from which the reader rebuilds each double bit for bit with the
//! recorder's own [`Scale`] functions; a sample whose values are not a register's (a foreign
//! rig's converted CSV) goes in a batch of exact doubles instead. `power_w` is a `float` for
//! viewers only (bus × current). An optional value a sample lacks (yaw, pitch, a tracker fix) is
//! NaN in its column, and a column no sample of the batch has is left out. The board's sample
//! frame rides in `board` when it rebuilds from the registers exactly ([`BoardSample`]).
//!
//! A batch holds samples of one kind (registers or doubles, with or without board frames) that
//! came one after the other with nothing else between: the writer closes it at any other record
//! (a model or status frame, a command, an event, a flush), so the file keeps the run's order.
//! The message's MCAP `sequence` is the number of samples written before it, so a reader that
//! loses a batch to damage knows exactly how many samples it lost.

use super::board_sample::{bus_register, sample_frame, BoardSample, Chip};
use super::prepare::{Decoded, Span};
use super::proto::{self, Value};
use super::read::{check_reading, no_frame};
use crate::log::run_csv::{Column, RigRange, RunSample};
use model_core::ina226::{BusVoltageRaw, CurrentRaw, Scale};
use model_core::wire::Sample;
use model_core::Sides;
use std::ops::Range;

/// Most samples in one batch: a run without model frames (a converted CSV) still gets
/// messages of a bounded size, a few per second.
pub(super) const BATCH_MAX: usize = 64;

/// One sample of a batch.
#[derive(Debug, Clone, Copy)]
struct Entry {
    sample: RunSample,
    /// Its bus and current registers at the batch's scale, when they rebuild it exactly.
    registers: Option<Sides<(u16, i16)>>,
    board: Option<BoardSample>,
}

/// The samples of the batch being gathered.
#[derive(Debug)]
pub(super) struct Batch {
    /// The scale of the registers.
    scale: Scale,
    entries: Vec<Entry>,
}

/// The registers that rebuild `sample`'s bus voltages and currents bit for bit at `scale`.
pub(super) fn registers_of(sample: &RunSample, scale: Scale) -> Option<Sides<(u16, i16)>> {
    let side = |bus_v: f64, current_a: f64| {
        let bus = bus_register(bus_v)?;
        let current = (current_a * 1e9 / f64::from(scale.current_lsb_na)).round();
        if !(f64::from(i16::MIN)..=f64::from(i16::MAX)).contains(&current) {
            return None;
        }
        let current = current as i16;
        let exact = scale.bus_v(BusVoltageRaw(bus)).to_bits() == bus_v.to_bits()
            && scale.current_a(CurrentRaw(current)).to_bits() == current_a.to_bits();
        exact.then_some((bus, current))
    };
    Some(Sides::new(
        side(sample.bus_v.left, sample.current_a.left)?,
        side(sample.bus_v.right, sample.current_a.right)?,
    ))
}

impl Batch {
    pub(super) fn new(scale: Scale) -> Self {
        Batch {
            scale,
            entries: Vec::with_capacity(BATCH_MAX),
        }
    }

    /// Samples in the batch.
    pub(super) fn len(&self) -> usize {
        self.entries.len()
    }

    /// The first sample's run time.
    pub(super) fn first_t_s(&self) -> Option<f64> {
        self.entries.first().map(|e| e.sample.t_s)
    }

    /// Adds `sample` (with its registers at `scale` from [`registers_of`], and its frame's part)
    /// if it is of the batch's kind and there is room; `false` if the batch must be written
    /// first.
    pub(super) fn push(
        &mut self,
        sample: &RunSample,
        registers: Option<Sides<(u16, i16)>>,
        board: Option<BoardSample>,
        scale: Scale,
    ) -> bool {
        if let Some(first) = self.entries.first() {
            let same_kind = first.registers.is_some() == registers.is_some()
                && first.board.is_some() == board.is_some()
                && (registers.is_none() || self.scale == scale);
            if !same_kind || self.entries.len() == BATCH_MAX {
                return false;
            }
        }
        self.scale = scale;
        self.entries.push(Entry {
            sample: *sample,
            registers,
            board,
        });
        true
    }

    /// The batch as a `rover_power.SampleBatch` message; the batch is left empty.
    pub(super) fn take_protobuf(&mut self) -> Vec<u8> {
        let e = &self.entries;
        let mut w = proto::Writer::new();
        w.packed_doubles(1, e.iter().map(|e| e.sample.t_s));
        let registers = e.iter().all(|e| e.registers.is_some());
        for (field, pick) in [(2, Side::Left), (3, Side::Right)] {
            w.message(field, |m| {
                m.packed_floats(
                    1,
                    e.iter()
                        .map(|e| (pick.of(e.sample.bus_v) * pick.of(e.sample.current_a)) as f32),
                );
                if registers {
                    let regs = || e.iter().filter_map(|e| e.registers).map(|r| pick.of(r));
                    m.packed_varints(5, regs().map(|(bus, _)| u64::from(bus)));
                    m.packed_varints(6, regs().map(|(_, cur)| proto::zigzag(i64::from(cur))));
                } else {
                    m.packed_doubles(2, e.iter().map(|e| pick.of(e.sample.bus_v)));
                    m.packed_doubles(3, e.iter().map(|e| pick.of(e.sample.current_a)));
                }
                m.packed_doubles(4, e.iter().map(|e| pick.of(e.sample.cmd_mps)));
            });
        }
        let optional: [fn(&RunSample) -> Option<f64>; 4] =
            [|s| s.yaw_rad, |s| s.pitch_deg, |s| s.x_m, |s| s.y_m];
        for (field, value) in (4..).zip(optional) {
            if e.iter().any(|e| value(&e.sample).is_some()) {
                w.packed_doubles(
                    field,
                    e.iter().map(|e| value(&e.sample).unwrap_or(f64::NAN)),
                );
            }
        }
        if e.iter().all(|e| e.board.is_some()) && !e.is_empty() {
            let boards = || e.iter().filter_map(|e| e.board);
            w.message(8, |m| {
                // Board time and sample number as columns only where they do not follow from
                // the first sample's (the board samples on a steady clock, one number each).
                let first = e[0].board.map_or((0, 0), |b| (b.t_us, b.seq));
                let t0_s = e[0].sample.t_s;
                if e.iter().all(|e| {
                    e.board.map(|b| b.t_us) == Some(board_time(first.0, t0_s, e.sample.t_s))
                }) {
                    m.varint(8, first.0);
                } else {
                    m.packed_varints(1, boards().map(|b| b.t_us));
                }
                if boards()
                    .enumerate()
                    .all(|(i, b)| b.seq == first.1.wrapping_add(i as u32))
                {
                    m.varint(9, u64::from(first.1));
                } else {
                    m.packed_varints(2, boards().map(|b| u64::from(b.seq)));
                }
                // A register is written only where the batch's columns do not say it: the
                // current register where it is not the reading's, the shunt register where it
                // is not the current register (at our board's CAL they are equal).
                for (shunt_field, current_field, pick) in [(3, 6, Side::Left), (4, 7, Side::Right)]
                {
                    let current = |b: &BoardSample| pick.of(b.current_register());
                    let said = e.iter().all(|e| match (e.registers, e.board) {
                        (Some(r), Some(b)) => pick.of(r).1 == current(&b),
                        _ => false,
                    });
                    if !said {
                        m.packed_varints(
                            current_field,
                            boards().map(|b| proto::zigzag(i64::from(current(&b)))),
                        );
                    }
                    if boards().any(|b| pick.of(b.shunt) != current(&b)) {
                        m.packed_varints(
                            shunt_field,
                            boards().map(|b| proto::zigzag(i64::from(pick.of(b.shunt)))),
                        );
                    }
                }
                if boards().any(|b| b.stale.left || b.stale.right) {
                    m.packed_varints(
                        5,
                        boards().map(|b| u64::from(b.stale.left) | u64::from(b.stale.right) << 1),
                    );
                }
            });
        }
        if registers {
            w.varint(9, u64::from(self.scale.current_lsb_na));
        }
        self.entries.clear();
        w.into_bytes()
    }
}

/// Which side of a [`Sides`] a column holds.
#[derive(Debug, Clone, Copy)]
enum Side {
    Left,
    Right,
}

impl Side {
    fn of<T: Copy>(self, sides: Sides<T>) -> T {
        match self {
            Side::Left => sides.left,
            Side::Right => sides.right,
        }
    }
}

/// The columns of a decoded batch, kept between messages so that reading allocates nothing
/// once they have grown.
#[derive(Debug, Default)]
pub(super) struct Columns {
    t_s: Doubles,
    sides: [SideColumns; 2],
    /// yaw, pitch, x, y.
    optional: [Doubles; 4],
    t_us: Vec<u64>,
    seq: Vec<u32>,
    shunt: [Vec<i16>; 2],
    /// The frames' current registers, where the readings' are not theirs.
    current: [Vec<i16>; 2],
    stale: Vec<u64>,
    /// The first sample's board time and number, when the others follow from them.
    t_us_first: Option<u64>,
    seq_first: Option<u32>,
    has_board: bool,
    current_lsb_na: Option<u32>,
}

#[derive(Debug, Default)]
struct SideColumns {
    bus_v: Doubles,
    current_a: Doubles,
    cmd_mps: Doubles,
    bus_raw: Vec<u16>,
    current_raw: Vec<i16>,
}

impl Columns {
    /// Decodes a `rover_power.SampleBatch` message into `out`: each sample with its board frame
    /// rebuilt when the batch carries them, checked as a sample message of ours is (in the
    /// board's measuring range, times increasing within the batch; whether the first comes
    /// after the previous batch's last is the reader's to check). Unknown fields are skipped (a
    /// later writer may add some); columns of different lengths, a value that is not a register,
    /// a missing column or a sample that fails its check are errors saying so (and `out` is
    /// left as it was). The batch's part of `out`.
    pub(super) fn decode(&mut self, data: &[u8], out: &mut Decoded) -> Result<Span, String> {
        self.clear();
        for item in proto::Fields::of(data) {
            let (field, value) = item?;
            match field {
                1 => self.t_s.add(value, data)?,
                2 | 3 => self.sides[field as usize - 2].decode(message(field, value)?, data)?,
                4..=7 => self.optional[field as usize - 4].add(value, data)?,
                8 => {
                    self.has_board = true;
                    for item in proto::Fields::of(message(field, value)?) {
                        let (field, value) = item?;
                        match field {
                            1 => varints(value, &mut self.t_us, Ok)?,
                            2 => varints(value, &mut self.seq, |v| sequence(v, "seq"))?,
                            3 | 4 => varints(value, &mut self.shunt[field as usize - 3], register)?,
                            5 => varints(value, &mut self.stale, Ok)?,
                            6 | 7 => {
                                varints(value, &mut self.current[field as usize - 6], register)?
                            }
                            8 => self.t_us_first = Some(single(value, "t_us_first")?),
                            9 => {
                                let first = single(value, "seq_first")?;
                                self.seq_first = Some(sequence(first, "seq_first")?);
                            }
                            _ => {}
                        }
                    }
                }
                9 => {
                    match value {
                        Value::Varint(v) => {
                            self.current_lsb_na =
                                Some(u32::try_from(v).ok().filter(|&v| v > 0).ok_or_else(
                                    || format!("current_lsb_na {v} is out of range"),
                                )?);
                        }
                        other => {
                            return Err(format!(
                                "current_lsb_na: expected a varint, found {other:?}"
                            ))
                        }
                    }
                }
                _ => {}
            }
        }
        let start = out.end();
        match self.samples(data, out) {
            Ok(()) => Ok(out.grown(start)),
            Err(e) => {
                out.cut(start);
                Err(e)
            }
        }
    }

    fn clear(&mut self) {
        self.t_s.clear();
        for side in &mut self.sides {
            side.clear();
        }
        for column in &mut self.optional {
            column.clear();
        }
        self.t_us.clear();
        self.seq.clear();
        self.stale.clear();
        for column in self.shunt.iter_mut().chain(&mut self.current) {
            column.clear();
        }
        self.has_board = false;
        self.t_us_first = None;
        self.seq_first = None;
        self.current_lsb_na = None;
    }

    /// The samples the decoded columns of `message` hold, checked (and their frames, if the
    /// batch carries them), appended to `out`; on an error `out` may hold some of them.
    fn samples(&self, message: &[u8], out: &mut Decoded) -> Result<(), String> {
        let n = self.t_s.len();
        // `name` is built only for the error.
        let check = |len: usize, needed: bool, name: &dyn Fn() -> String| match (len, needed) {
            (0, false) => Ok(()),
            (len, _) if len == n => Ok(()),
            (len, _) => Err(format!(
                "column {} holds {len} values for {n} samples",
                name()
            )),
        };
        let scale = self.current_lsb_na.map(|current_lsb_na| Scale {
            current_lsb_na,
            ..Scale::BOARD
        });
        let registers = scale.is_some();
        for (side, name) in self.sides.iter().zip(["left", "right"]) {
            let columns = [
                (side.bus_raw.len(), registers, "bus_raw"),
                (side.current_raw.len(), registers, "current_raw"),
                (side.bus_v.len(), !registers, "bus_v"),
                (side.current_a.len(), !registers, "current_a"),
                (side.cmd_mps.len(), true, "cmd_mps"),
            ];
            for (len, needed, field) in columns {
                check(len, needed, &|| format!("{name}.{field}"))?;
            }
        }
        for (column, name) in self
            .optional
            .iter()
            .zip(["yaw_rad", "pitch_deg", "x_m", "y_m"])
        {
            check(column.len(), false, &|| name.to_owned())?;
        }
        if self.has_board {
            // Without the readings' registers, the frames' current registers are needed.
            let columns = [
                (self.t_us.len(), self.t_us_first.is_none(), "t_us"),
                (self.seq.len(), self.seq_first.is_none(), "seq"),
                (self.shunt[0].len(), false, "shunt_left"),
                (self.shunt[1].len(), false, "shunt_right"),
                (self.stale.len(), false, "stale"),
                (self.current[0].len(), !registers, "current_left"),
                (self.current[1].len(), !registers, "current_right"),
            ];
            for (len, needed, field) in columns {
                check(len, needed, &|| format!("board.{field}"))?;
            }
        }
        // One pass, each sample built whole from its columns (the registers were checked as
        // they were read); then the samples are checked as a whole, and only a batch that may
        // hold a failing one sample by sample, to say which and why.
        let start = out.samples.len();
        out.samples.reserve(n);
        if self.has_board {
            out.frames.reserve(n);
        }
        let readings = self.sides.each_ref().map(|side| match scale {
            Some(scale) => Readings::Registers(&side.bus_raw, &side.current_raw, scale),
            None => Readings::Doubles(side.bus_v.bytes(message), side.current_a.bytes(message)),
        });
        let cmd_mps = self
            .sides
            .each_ref()
            .map(|side| side.cmd_mps.bytes(message));
        let optional = self.optional.each_ref().map(|column| column.bytes(message));
        let t = self.t_s.bytes(message);
        let t0_s = le_double(t, 0).unwrap_or(0.0);
        let mut summary = Summary::new();
        // The first sample whose frame does not rebuild.
        let mut no_frame_at = None;
        for i in 0..n {
            let ([bus_l, bus_r], [current_l, current_r]) = (
                readings.map(|r| r.bus_v(i)),
                readings.map(|r| r.current_a(i)),
            );
            // A sample without an optional value holds NaN.
            let [yaw_rad, pitch_deg, x_m, y_m] =
                optional.map(|c| le_double(c, i).filter(|v| !v.is_nan()));
            let sample = RunSample {
                t_s: le_double(t, i).unwrap_or_default(),
                bus_v: Sides::new(bus_l, bus_r),
                current_a: Sides::new(current_l, current_r),
                cmd_mps: Sides::new(
                    le_double(cmd_mps[0], i).unwrap_or_default(),
                    le_double(cmd_mps[1], i).unwrap_or_default(),
                ),
                yaw_rad,
                pitch_deg,
                x_m,
                y_m,
            };
            summary.add(&sample);
            if self.has_board {
                match self.frame(i, &sample, t0_s, &readings) {
                    Some(frame) => out.frames.push(frame),
                    None => _ = no_frame_at.get_or_insert(i),
                }
            }
            out.samples.push(sample);
        }
        if no_frame_at.is_none() && summary.passes(RigRange::Board) {
            return Ok(());
        }
        // The first sample that fails, and why.
        let mut last_t_s = None;
        for (i, sample) in out.samples[start..].iter().enumerate() {
            if no_frame_at == Some(i) {
                return Err(no_frame());
            }
            check_reading(sample, RigRange::Board, last_t_s)?;
            last_t_s = Some(sample.t_s);
        }
        Ok(())
    }

    /// Sample `i`'s board frame, rebuilt from it and the board columns (`None` where they make
    /// no frame; the batch's first sample was at `t0_s`): from the bus registers if the
    /// readings are registers (the volts are theirs).
    fn frame(
        &self,
        i: usize,
        sample: &RunSample,
        t0_s: f64,
        readings: &[Readings; 2],
    ) -> Option<Sample> {
        let stale = self.stale.get(i).copied().unwrap_or(0);
        let chip = |k: usize| {
            // The reading's current register, unless the frame's own is given (for doubles it
            // must be).
            let current = self.current[k]
                .get(i)
                .copied()
                .or_else(|| readings[k].current_raw(i))?;
            Some(Chip {
                shunt: *self.shunt[k].get(i).unwrap_or(&current),
                // Doubles: the volts' register.
                bus: match readings[k].bus_raw(i) {
                    Some(bus) => bus,
                    None => bus_register([sample.bus_v.left, sample.bus_v.right][k])?,
                },
                current,
                stale: stale & (1 << k) != 0,
            })
        };
        sample_frame(
            match self.t_us_first {
                Some(first) => board_time(first, t0_s, sample.t_s),
                None => *self.t_us.get(i)?,
            },
            match self.seq_first {
                Some(first) => first.wrapping_add(i as u32),
                None => *self.seq.get(i)?,
            },
            Sides::new(chip(0)?, chip(1)?),
        )
    }
}

/// One side's readings in a batch: the chips' registers at a scale, or exact doubles (packed
/// little-endian). Every column holds a value for each sample (checked before).
#[derive(Debug, Clone, Copy)]
enum Readings<'a> {
    Registers(&'a [u16], &'a [i16], Scale),
    Doubles(&'a [u8], &'a [u8]),
}

impl Readings<'_> {
    fn bus_v(&self, i: usize) -> f64 {
        match *self {
            Readings::Registers(bus, _, scale) => {
                bus.get(i).map_or(0.0, |&b| scale.bus_v(BusVoltageRaw(b)))
            }
            Readings::Doubles(bus, _) => le_double(bus, i).unwrap_or_default(),
        }
    }

    fn current_a(&self, i: usize) -> f64 {
        match *self {
            Readings::Registers(_, current, scale) => current
                .get(i)
                .map_or(0.0, |&c| scale.current_a(CurrentRaw(c))),
            Readings::Doubles(_, current) => le_double(current, i).unwrap_or_default(),
        }
    }

    fn bus_raw(&self, i: usize) -> Option<u16> {
        match *self {
            Readings::Registers(bus, _, _) => bus.get(i).copied(),
            Readings::Doubles(..) => None,
        }
    }

    fn current_raw(&self, i: usize) -> Option<i16> {
        match *self {
            Readings::Registers(_, current, _) => current.get(i).copied(),
            Readings::Doubles(..) => None,
        }
    }
}

/// What checking a batch's samples needs, gathered as they are built: the extremes of each
/// reading, the sum of every value (finite only if each is) and whether the times increase.
/// A reading's range is an interval, so its extremes decide it for all.
#[derive(Debug)]
struct Summary {
    /// Lowest and highest bus voltage and current, per side.
    bus_v: Sides<(f64, f64)>,
    current_a: Sides<(f64, f64)>,
    sum: f64,
    increasing: bool,
    last_t_s: f64,
}

impl Summary {
    fn new() -> Self {
        let none = Sides::new(
            (f64::INFINITY, f64::NEG_INFINITY),
            (f64::INFINITY, f64::NEG_INFINITY),
        );
        Summary {
            bus_v: none,
            current_a: none,
            sum: 0.0,
            increasing: true,
            last_t_s: f64::NEG_INFINITY,
        }
    }

    fn add(&mut self, sample: &RunSample) {
        let extremes = |(lo, hi): &mut (f64, f64), v: f64| {
            *lo = v.min(*lo);
            *hi = v.max(*hi);
        };
        extremes(&mut self.bus_v.left, sample.bus_v.left);
        extremes(&mut self.bus_v.right, sample.bus_v.right);
        extremes(&mut self.current_a.left, sample.current_a.left);
        extremes(&mut self.current_a.right, sample.current_a.right);
        // An absent optional value adds nothing.
        let optional = [sample.yaw_rad, sample.pitch_deg, sample.x_m, sample.y_m];
        self.sum += sample.t_s
            + sample.bus_v.left
            + sample.bus_v.right
            + sample.current_a.left
            + sample.current_a.right
            + sample.cmd_mps.left
            + sample.cmd_mps.right
            + optional.iter().map(|v| v.unwrap_or(0.0)).sum::<f64>();
        self.increasing &= sample.t_s > self.last_t_s;
        self.last_t_s = sample.t_s;
    }

    /// Whether every sample added passes [`check_reading`] in `range` (after none); `false`
    /// where one may not (a sum that overflows is `false` too: the samples then tell).
    fn passes(&self, range: RigRange) -> bool {
        // `lo > hi`: no finite value was added (none at all, or NaN, which the sum holds).
        let within = |column: Column, (lo, hi): (f64, f64)| {
            lo > hi || (range.admits(column, lo) && range.admits(column, hi))
        };
        self.increasing
            && self.sum.is_finite()
            && within(Column::LeftBusV, self.bus_v.left)
            && within(Column::RightBusV, self.bus_v.right)
            && within(Column::LeftCurrentA, self.current_a.left)
            && within(Column::RightCurrentA, self.current_a.right)
    }
}

impl SideColumns {
    fn clear(&mut self) {
        for column in [&mut self.bus_v, &mut self.current_a, &mut self.cmd_mps] {
            column.clear();
        }
        self.bus_raw.clear();
        self.current_raw.clear();
    }

    /// Decodes the side's columns in `data`, part of `message`.
    fn decode(&mut self, data: &[u8], message: &[u8]) -> Result<(), String> {
        for item in proto::Fields::of(data) {
            let (field, value) = item?;
            match field {
                2 => self.bus_v.add(value, message)?,
                3 => self.current_a.add(value, message)?,
                4 => self.cmd_mps.add(value, message)?,
                5 => varints(value, &mut self.bus_raw, |v| {
                    u16::try_from(v).map_err(|_| format!("bus register {v} is out of range"))
                })?,
                6 => varints(value, &mut self.current_raw, register)?,
                // 1: power_w, for viewers (bus × current is the reading).
                _ => {}
            }
        }
        Ok(())
    }
}

/// A `repeated double` column of the message being decoded: its packed run read in place
/// (bytes `packed` of the message: no copy), or the values of a column written unpacked or in
/// several runs, copied (little-endian, as packed).
#[derive(Debug, Default)]
struct Doubles {
    packed: Option<Range<usize>>,
    copied: Vec<u8>,
}

impl Doubles {
    fn clear(&mut self) {
        self.packed = None;
        self.copied.clear();
    }

    /// Adds a field's value, found in `message`.
    fn add(&mut self, value: Value<'_>, message: &[u8]) -> Result<(), String> {
        if let Value::Len(bytes) = value {
            if self.packed.is_none() && self.copied.is_empty() && bytes.len() % 8 == 0 {
                // Where the run lies in the message (it is part of it: `Fields` of its bytes).
                let start = (bytes.as_ptr() as usize).wrapping_sub(message.as_ptr() as usize);
                let run = start..start.saturating_add(bytes.len());
                if message.get(run.clone()).is_some() {
                    self.packed = Some(run);
                    return Ok(());
                }
            }
        }
        // Anything else is copied, after the run read in place so far.
        if let Some(run) = self.packed.take() {
            self.copied.extend_from_slice(&message[run]);
        }
        match value {
            Value::Len(bytes) if bytes.len() % 8 == 0 => self.copied.extend_from_slice(bytes),
            Value::Len(bytes) => return Err(format!("packed doubles of {} bytes", bytes.len())),
            Value::Fixed64(bits) => self.copied.extend_from_slice(&bits.to_le_bytes()),
            other => return Err(format!("expected doubles, found {other:?}")),
        }
        Ok(())
    }

    fn len(&self) -> usize {
        self.packed
            .as_ref()
            .map_or(self.copied.len(), |run| run.len())
            / 8
    }

    /// The column's values in `message`, packed little-endian.
    fn bytes<'a>(&'a self, message: &'a [u8]) -> &'a [u8] {
        match &self.packed {
            Some(run) => message.get(run.clone()).unwrap_or_default(),
            None => &self.copied,
        }
    }
}

/// Value `i` of packed little-endian doubles, if there.
fn le_double(bytes: &[u8], i: usize) -> Option<f64> {
    let at = i.checked_mul(8)?;
    let value = bytes.get(at..at.checked_add(8)?)?;
    Some(f64::from_le_bytes(value.try_into().ok()?))
}

/// The board time of a sample at run time `t_s` in a batch whose first sample, at `t0_s`, was
/// taken at board time `first_us` (µs, rounded; the writer keeps a column where this is not
/// exact).
fn board_time(first_us: u64, t0_s: f64, t_s: f64) -> u64 {
    first_us.wrapping_add(((t_s - t0_s) * 1e6).round() as u64)
}

/// A single varint field's value.
fn single(value: Value<'_>, name: &str) -> Result<u64, String> {
    match value {
        Value::Varint(v) => Ok(v),
        other => Err(format!("{name}: expected a varint, found {other:?}")),
    }
}

/// A `uint32` sample number.
fn sequence(v: u64, name: &str) -> Result<u32, String> {
    u32::try_from(v).map_err(|_| format!("{name} {v} is out of range"))
}

/// A `sint32` register value.
fn register(zigzagged: u64) -> Result<i16, String> {
    let v = proto::unzigzag(zigzagged);
    i16::try_from(v).map_err(|_| format!("{v} is no register value"))
}

fn message(field: u32, value: Value<'_>) -> Result<&[u8], String> {
    match value {
        Value::Len(m) => Ok(m),
        other => Err(format!(
            "field {field}: expected a message, found {other:?}"
        )),
    }
}

/// Appends a `repeated` varint field's values, packed or one, each as `convert` makes it.
fn varints<T>(
    value: Value<'_>,
    into: &mut Vec<T>,
    convert: impl Fn(u64) -> Result<T, String>,
) -> Result<(), String> {
    match value {
        Value::Len(bytes) => {
            // Inline rather than through `proto::varint`: a third of a batch's decoding.
            let mut value = 0u64;
            let mut shift = 0;
            for &byte in bytes {
                value |= u64::from(byte & 0x7f) << shift;
                if byte < 0x80 {
                    into.push(convert(value)?);
                    value = 0;
                    shift = 0;
                } else {
                    shift += 7;
                    if shift > 63 {
                        return Err("a packed varint is longer than 64 bits".into());
                    }
                }
            }
            if shift != 0 {
                return Err("a packed varint is cut short".into());
            }
        }
        Value::Varint(v) => into.push(convert(v)?),
        other => return Err(format!("expected varints, found {other:?}")),
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::log::run_csv::{BUS_V_MAX, CURRENT_A_MAX};
    use proptest::prelude::*;

    /// Each sample of `batch` with its frame (the frames are one a sample, or none).
    fn through_a_message(batch: &mut Batch) -> Result<Vec<(RunSample, Option<Sample>)>, String> {
        let bytes = batch.take_protobuf();
        let mut out = Decoded::default();
        Columns::default().decode(&bytes, &mut out)?;
        assert!(out.frames.is_empty() || out.frames.len() == out.samples.len());
        let frames = out
            .frames
            .iter()
            .copied()
            .map(Some)
            .chain(std::iter::repeat(None));
        Ok(out.samples.iter().copied().zip(frames).collect())
    }

    /// A sample at `t_s` whose readings are the registers `bus` and `current` at `scale`.
    fn register_sample(t_s: f64, bus: u16, current: i16, scale: Scale) -> RunSample {
        RunSample {
            t_s,
            bus_v: Sides::new(
                scale.bus_v(BusVoltageRaw(bus)),
                scale.bus_v(BusVoltageRaw(bus / 2)),
            ),
            current_a: Sides::new(
                scale.current_a(CurrentRaw(current)),
                scale.current_a(CurrentRaw(current.wrapping_neg())),
            ),
            cmd_mps: Sides::new(0.25, -0.5),
            yaw_rad: None,
            pitch_deg: None,
            x_m: None,
            y_m: None,
        }
    }

    fn bits(s: &RunSample) -> Vec<Option<u64>> {
        let both = |v: Sides<f64>| [Some(v.left.to_bits()), Some(v.right.to_bits())];
        [Some(s.t_s.to_bits())]
            .into_iter()
            .chain(both(s.bus_v))
            .chain(both(s.current_a))
            .chain(both(s.cmd_mps))
            .chain([s.yaw_rad, s.pitch_deg, s.x_m, s.y_m].map(|v| v.map(f64::to_bits)))
            .collect()
    }

    /// Registers at our scale and at another, board parts (stale, a shunt register unlike the
    /// current register), absent values in some samples only: all come back bit for bit.
    #[test]
    fn a_batch_of_registers_comes_back_bit_for_bit_with_its_board_parts() {
        for scale in [
            Scale::BOARD,
            Scale {
                current_lsb_na: 61_035,
                ..Scale::BOARD
            },
        ] {
            let mut batch = Batch::new(scale);
            let mut want = Vec::new();
            for (i, (bus, current)) in [(0u16, i16::MIN), (19_200, -1), (32_767, i16::MAX)]
                .into_iter()
                .enumerate()
            {
                let mut sample = register_sample(0.005 * (i + 1) as f64, bus, current, scale);
                sample.yaw_rad = (i != 1).then_some(0.1 * i as f64);
                sample.x_m = (i == 2).then_some(-3.5);
                let registers = registers_of(&sample, scale).expect("registers");
                let shunt = Sides::new(current, if i == 0 { 7 } else { current.wrapping_neg() });
                let board = BoardSample::new(
                    1_000 + i as u64,
                    i as u32,
                    shunt,
                    registers.map(|(_, c)| c),
                    Sides::new(i == 1, false),
                );
                assert!(batch.push(&sample, Some(registers), Some(board), scale));
                want.push((sample, board.frame(&sample)));
            }
            let got = through_a_message(&mut batch).expect("decodes");
            assert_eq!(got.len(), want.len());
            for ((g, gb), (w, wb)) in got.iter().zip(&want) {
                assert_eq!(bits(g), bits(w));
                assert_eq!(gb, wb);
            }
            assert_eq!(batch.len(), 0, "taken");
        }
    }

    /// A foreign rig's readings (not a register's) go in a batch of doubles; a sample of the
    /// other kind, or of another scale, starts a new batch; a batch holds at most BATCH_MAX.
    #[test]
    fn batches_hold_one_kind_and_doubles_come_back_exactly() {
        let foreign = RunSample {
            bus_v: Sides::new(24.123_456_789, 0.1 + 0.2),
            current_a: Sides::new(-1e-9, 13.37),
            ..register_sample(1.0, 0, 0, Scale::BOARD)
        };
        assert_eq!(registers_of(&foreign, Scale::BOARD), None);
        let mut batch = Batch::new(Scale::BOARD);
        assert!(batch.push(&foreign, None, None, Scale::BOARD));
        let ours = register_sample(1.1, 100, 100, Scale::BOARD);
        let registers = registers_of(&ours, Scale::BOARD);
        assert!(!batch.push(&ours, registers, None, Scale::BOARD));
        let got = through_a_message(&mut batch).expect("decodes");
        assert_eq!(bits(&got[0].0), bits(&foreign));
        assert!(batch.push(&ours, registers, None, Scale::BOARD));
        let other = Scale {
            current_lsb_na: 1_000_000,
            ..Scale::BOARD
        };
        assert!(!batch.push(&ours, registers, None, other));
        let _ = batch.take_protobuf();
        for i in 0..BATCH_MAX {
            let s = RunSample {
                t_s: i as f64,
                ..ours
            };
            assert!(batch.push(&s, registers, None, Scale::BOARD));
        }
        assert!(!batch.push(&ours, registers, None, Scale::BOARD));
        assert_eq!(
            through_a_message(&mut batch).expect("decodes").len(),
            BATCH_MAX
        );
    }

    /// Frames whose current register is not the reading's (a foreign rig's CSV converted with
    /// frames quantised at our scale, or another CAL) ride in the batch with that register.
    #[test]
    fn frames_with_their_own_current_register_ride_in_the_batch() {
        let ours = register_sample(0.5, 19_200, 300, Scale::BOARD);
        let foreign = RunSample {
            t_s: 0.6,
            current_a: Sides::new(0.150_2, -2.000_04),
            ..ours
        };
        for (sample, registers) in [(ours, registers_of(&ours, Scale::BOARD)), (foreign, None)] {
            let board = BoardSample::new(
                77,
                3,
                Sides::new(-5, 9),
                Sides::new(301, -4_000),
                Sides::new(false, true),
            );
            let mut batch = Batch::new(Scale::BOARD);
            assert!(batch.push(&sample, registers, Some(board), Scale::BOARD));
            let got = through_a_message(&mut batch).expect("decodes");
            assert_eq!(bits(&got[0].0), bits(&sample));
            assert_eq!(got[0].1, board.frame(&sample));
            assert!(got[0].1.is_some());
        }
    }

    /// Columns written unpacked (one value a field) or in several packed runs, as any protobuf
    /// writer may, read as the packed ones do.
    #[test]
    fn unpacked_and_split_columns_read_as_packed_ones() {
        let mut w = proto::Writer::new();
        w.double(1, 0.1);
        w.double(1, 0.2);
        for side in [2, 3] {
            w.message(side, |m| {
                m.packed_doubles(2, [24.0].into_iter());
                m.packed_doubles(2, [24.5].into_iter());
                m.packed_doubles(3, [1.5, -2.5].into_iter());
                m.double(4, 0.3);
                m.packed_doubles(4, [0.4].into_iter());
            });
        }
        w.packed_doubles(4, [f64::NAN, 0.7].into_iter());
        let mut out = Decoded::default();
        Columns::default()
            .decode(&w.into_bytes(), &mut out)
            .expect("decodes");
        let got: Vec<_> = out
            .samples
            .iter()
            .map(|s| {
                (
                    s.t_s,
                    s.bus_v.left,
                    s.current_a.right,
                    s.cmd_mps.left,
                    s.yaw_rad,
                )
            })
            .collect();
        assert_eq!(
            got,
            [
                (0.1, 24.0, 1.5, 0.3, None),
                (0.2, 24.5, -2.5, 0.4, Some(0.7))
            ]
        );
    }

    #[test]
    fn a_batch_whose_columns_disagree_is_an_error() {
        let mut w = proto::Writer::new();
        w.packed_doubles(1, [0.1, 0.2].into_iter());
        for side in [2, 3] {
            w.message(side, |m| {
                m.packed_varints(5, [1u64, 2].into_iter());
                m.packed_varints(6, [0u64].into_iter()); // one current for two samples
                m.packed_doubles(4, [0.0, 0.0].into_iter());
            });
        }
        w.varint(9, 500_000);
        let e = Columns::default()
            .decode(&w.into_bytes(), &mut Decoded::default())
            .expect_err("columns disagree");
        assert!(
            e.contains("left.current_raw holds 1 values for 2 samples"),
            "{e}"
        );
    }

    /// A value for a summary's property: mostly in the board's range, sometimes at or past
    /// its edges, or not finite.
    fn value() -> impl Strategy<Value = f64> {
        prop_oneof![
            6 => -20.0..45.0f64,
            1 => prop::sample::select(vec![
                0.0, -0.0, BUS_V_MAX, CURRENT_A_MAX, -CURRENT_A_MAX, 1e308, -1e308,
                f64::NAN, f64::INFINITY, f64::NEG_INFINITY,
            ]),
        ]
    }

    proptest! {
        /// A batch's summary passes only samples that each pass the per-sample check, and
        /// passes them all unless a sum overflows.
        #[test]
        fn the_summary_passes_what_each_sample_check_passes(
            rows in proptest::collection::vec(
                (
                    value(),
                    proptest::array::uniform6(value()),
                    proptest::array::uniform4(proptest::option::of(value())),
                ),
                0..12,
            ),
        ) {
            let samples: Vec<RunSample> = rows
                .iter()
                .map(|&(t_s, [bl, br, cl, cr, ml, mr], [yaw, pitch, x, y])| RunSample {
                    t_s,
                    bus_v: Sides::new(bl, br),
                    current_a: Sides::new(cl, cr),
                    cmd_mps: Sides::new(ml, mr),
                    yaw_rad: yaw,
                    pitch_deg: pitch,
                    x_m: x,
                    y_m: y,
                })
                .collect();
            let mut summary = Summary::new();
            let mut last_t_s = None;
            let mut each = true;
            for sample in &samples {
                summary.add(sample);
                each &= check_reading(sample, RigRange::Board, last_t_s).is_ok();
                last_t_s = Some(sample.t_s);
            }
            if summary.passes(RigRange::Board) {
                prop_assert!(each);
            } else if each {
                prop_assert!(!summary.sum.is_finite());
            }
        }
    }

    proptest! {
        /// The inlined packed-varint reader reads what `proto::varint` reads, value by value,
        /// and fails where it fails.
        #[test]
        fn packed_varints_read_as_one_by_one(bytes in proptest::collection::vec(any::<u8>(), 0..40)) {
            let mut one_by_one = Vec::new();
            let mut rest = &bytes[..];
            let expected = loop {
                if rest.is_empty() {
                    break Ok(());
                }
                match proto::varint(rest) {
                    Some((v, tail)) => {
                        one_by_one.push(v);
                        rest = tail;
                    }
                    None => break Err(()),
                }
            };
            let mut packed = Vec::new();
            let got = varints(Value::Len(&bytes), &mut packed, Ok);
            prop_assert_eq!(got.is_ok(), expected.is_ok());
            if got.is_ok() {
                prop_assert_eq!(packed, one_by_one);
            }
        }

        /// Any register values round-trip; any bytes decode or fail, never panic.
        #[test]
        fn registers_round_trip_and_noise_never_panics(
            regs in proptest::collection::vec((0u16..=0x7FFF, any::<i16>()), 1..30),
            noise in proptest::collection::vec(any::<u8>(), 0..200),
        ) {
            let mut batch = Batch::new(Scale::BOARD);
            let mut want = Vec::new();
            for (i, (bus, current)) in regs.into_iter().enumerate() {
                let s = register_sample(i as f64, bus, current, Scale::BOARD);
                let r = registers_of(&s, Scale::BOARD);
                prop_assert!(r.is_some());
                prop_assert!(batch.push(&s, r, None, Scale::BOARD));
                want.push(s);
            }
            let got = through_a_message(&mut batch).expect("decodes");
            prop_assert_eq!(got.iter().map(|(s, _)| bits(s)).collect::<Vec<_>>(),
                            want.iter().map(bits).collect::<Vec<_>>());
            let _ = Columns::default().decode(&noise, &mut Decoded::default());
        }
    }
}
