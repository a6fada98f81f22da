//! What a recording holds, independent of its file format: the interface between the recorder
//! (which produces it live), the log formats (run CSV, MCAP) and the commands that read runs
//! (`validate`, `convert`, `replay`, `plot`).

use super::commands::CommandRow;
use super::run_csv::RunSample;
use model_core::wire::{BoardFrame, Sample};
use std::io;

/// Something that happened to the stream, marked in the log at the run time it happened.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
/// Kinds are kebab-case (`wall-clock`), as every enum value in JSON; logs written before that
/// spelt them snake_case (`wall_clock`), still read.
#[serde(tag = "kind", rename_all = "kebab-case")]
pub enum LogEvent {
    /// The recording started on `port`.
    Started { port: String },
    /// The device vanished (unplugged, port closed): nothing arrives until [`LogEvent::Reconnected`].
    #[serde(alias = "device_vanished")]
    DeviceVanished { port: String },
    /// The device is back on `port` after `offline_s` seconds of wall time.
    Reconnected { port: String, offline_s: f64 },
    /// `missing` samples after sequence number `after_seq` never arrived (a gap in `seq`).
    #[serde(alias = "samples_lost")]
    SamplesLost { after_seq: u32, missing: u32 },
    /// Frames that failed to decode (corrupted or truncated bytes) since the previous event.
    #[serde(alias = "bad_frames")]
    BadFrames { count: u64 },
    /// The board restarted (a hello, or `seq` back to 0): its time and energy start over; the
    /// run's time base continues from here.
    #[serde(alias = "board_reset")]
    BoardReset,
    /// The recording stopped (`reason`: Ctrl-C, duration, sample count, device gone, stream ended).
    Stopped { reason: String },
    /// The host's wall clock when the sample at this run time arrived (Unix time [ns]): run
    /// time + (`unix_ns` − this event's run time) is wall time, to the board crystal's drift.
    #[serde(alias = "wall_clock")]
    WallClock { unix_ns: u64 },
}

impl LogEvent {
    /// A one-word name of the event's kind (`started`, `vanished`, `reconnected`, `lost`, `bad`,
    /// `reset`, `stopped`, `clock`), for summaries and checks of a run's event sequence.
    pub fn short_name(&self) -> &'static str {
        match self {
            LogEvent::Started { .. } => "started",
            LogEvent::DeviceVanished { .. } => "vanished",
            LogEvent::Reconnected { .. } => "reconnected",
            LogEvent::SamplesLost { .. } => "lost",
            LogEvent::BadFrames { .. } => "bad",
            LogEvent::BoardReset => "reset",
            LogEvent::Stopped { .. } => "stopped",
            LogEvent::WallClock { .. } => "clock",
        }
    }
}

/// A whole recorded run in memory, as read back from any log format.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RunLog {
    /// Samples on the run's time base (`t_s` strictly increasing across board resets).
    pub samples: Vec<RunSample>,
    /// Every wire frame the board sent and the host decoded, with the run time it arrived at
    /// (empty for a run CSV, which holds physical samples only).
    pub frames: Vec<(f64, BoardFrame)>,
    /// The commands forwarded during the run (empty if none).
    pub commands: Vec<CommandRow>,
    /// Events at their run time [s].
    pub events: Vec<(f64, LogEvent)>,
}

/// One record of a [`RunLog`], borrowed (see [`RunLog::in_time_order`]).
#[derive(Debug, Clone, Copy)]
pub enum Record<'a> {
    /// A wire frame.
    Frame(&'a BoardFrame),
    /// A physical sample.
    Sample(&'a RunSample),
    /// A forwarded command.
    Command(&'a CommandRow),
    /// An event.
    Event(&'a LogEvent),
}

impl RunLog {
    /// The first wall-clock anchor: (run time [s], Unix time [ns] of the sample then).
    pub fn wall_clock(&self) -> Option<(f64, u64)> {
        self.events.iter().find_map(|(t, e)| match e {
            LogEvent::WallClock { unix_ns } => Some((*t, *unix_ns)),
            _ => None,
        })
    }

    /// Every record with its run time [s], in the order a recorder writes them: by time;
    /// at equal times events first (the wall-clock anchor comes before the first sample, as the
    /// recorder writes it), then frames, samples, commands, except that a sample follows its
    /// sample frame at once (the recorder writes the two together; a model frame stamped with
    /// the same time came after them); within one kind the log's order.
    pub fn in_time_order(&self) -> Vec<(f64, Record<'_>)> {
        let mut items: Vec<(f64, Record<'_>)> = Vec::with_capacity(
            self.frames.len() + self.samples.len() + self.commands.len() + self.events.len(),
        );
        items.extend(self.events.iter().map(|(t, e)| (*t, Record::Event(e))));
        items.extend(self.frames.iter().map(|(t, f)| (*t, Record::Frame(f))));
        items.extend(self.samples.iter().map(|s| (s.t_s, Record::Sample(s))));
        items.extend(self.commands.iter().map(|c| (c.t_s, Record::Command(c))));
        // Stable: within one kind the order is the log's.
        items.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut start = 0;
        while start < items.len() {
            let t = items[start].0;
            let len = items[start..].partition_point(|(u, _)| u.total_cmp(&t).is_eq());
            let group = &mut items[start..start + len];
            let sample = group
                .iter()
                .position(|(_, r)| matches!(r, Record::Sample(_)));
            let frame = group
                .iter()
                .rposition(|(_, r)| matches!(r, Record::Frame(BoardFrame::Sample(_))));
            if let (Some(sample), Some(frame)) = (sample, frame) {
                if frame + 1 < sample {
                    group[frame + 1..=sample].rotate_right(1);
                }
            }
            start += len;
        }
        items
    }
}

impl Record<'_> {
    /// Writes this record (at run time `t_s`) into `sink`.
    pub fn write_to(&self, t_s: f64, sink: &mut (impl RunLogSink + ?Sized)) -> io::Result<()> {
        match *self {
            Record::Frame(f) => sink.frame(t_s, f),
            Record::Sample(s) => sink.sample(s),
            Record::Command(c) => sink.command(c),
            Record::Event(e) => sink.event(t_s, e),
        }
    }
}

/// Where a recording goes as it happens. Implementations write through (or buffer at most until
/// [`RunLogSink::flush`]), so a killed process leaves a readable file up to the last flush.
///
/// Every record kind has a default that ignores it, for sinks that take only some (a scan of
/// the samples, a replay of the frames); a log writer implements them all.
pub trait RunLogSink {
    /// A decoded wire frame (hello, sample, model, status, ack, rejected) received at run time `t_s`.
    fn frame(&mut self, _t_s: f64, _frame: &BoardFrame) -> io::Result<()> {
        Ok(())
    }
    /// A physical sample on the run's time base.
    fn sample(&mut self, _sample: &RunSample) -> io::Result<()> {
        Ok(())
    }
    /// Samples one after the other, each after its board frame when `frames` holds one for
    /// each (empty: none has one): [`RunLogSink::frame`] then [`RunLogSink::sample`] for each,
    /// unless a sink takes a stretch faster whole (a log's sample batches come so).
    fn samples(&mut self, samples: &[RunSample], frames: &[Sample]) -> io::Result<()> {
        for (i, sample) in samples.iter().enumerate() {
            if let Some(frame) = frames.get(i) {
                self.frame(sample.t_s, &BoardFrame::Sample(*frame))?;
            }
            self.sample(sample)?;
        }
        Ok(())
    }
    /// A command row, logged when it was forwarded to the board.
    fn command(&mut self, _row: &CommandRow) -> io::Result<()> {
        Ok(())
    }
    /// An event at run time `t_s`.
    fn event(&mut self, _t_s: f64, _event: &LogEvent) -> io::Result<()> {
        Ok(())
    }
    /// Pushes everything written so far to the file (and the OS).
    fn flush(&mut self) -> io::Result<()> {
        Ok(())
    }
    /// Ends the recording: flushes, writes any closing structure (an index, a footer) and syncs
    /// the file to disk. Nothing is written after it.
    fn finish(&mut self) -> io::Result<()> {
        self.flush()
    }
}

/// A recording kept in memory (tests, and tools that record then process).
impl RunLogSink for RunLog {
    fn frame(&mut self, t_s: f64, frame: &BoardFrame) -> io::Result<()> {
        self.frames.push((t_s, *frame));
        Ok(())
    }

    fn sample(&mut self, sample: &RunSample) -> io::Result<()> {
        self.samples.push(*sample);
        Ok(())
    }

    fn command(&mut self, row: &CommandRow) -> io::Result<()> {
        self.commands.push(*row);
        Ok(())
    }

    fn event(&mut self, t_s: f64, event: &LogEvent) -> io::Result<()> {
        self.events.push((t_s, event.clone()));
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::{LogEvent, Record, RunLog};
    use crate::log::run_csv::RunSample;
    use model_core::wire::{BoardFrame, ChipReading, Sample};
    use model_core::Sides;

    /// At one time: the event, the frames in their order with the sample right after its
    /// sample frame, then the command.
    #[test]
    fn a_sample_follows_its_sample_frame_and_frames_keep_their_order() {
        let sample = RunSample {
            t_s: 1.0,
            bus_v: Sides::new(24.0, 24.0),
            current_a: Sides::new(1.0, 1.0),
            cmd_mps: Sides::new(0.0, 0.0),
            yaw_rad: None,
            pitch_deg: None,
            x_m: None,
            y_m: None,
        };
        let chip = ChipReading::Fresh(Default::default());
        let frame = BoardFrame::Sample(Sample {
            t_us: 0,
            seq: 0,
            chips: Sides::new(chip, chip),
        });
        let ack = BoardFrame::Ack { id: 1 };
        let run = RunLog {
            samples: vec![sample],
            frames: vec![(1.0, ack), (1.0, frame), (1.0, BoardFrame::Ack { id: 2 })],
            commands: Vec::new(),
            events: vec![(1.0, LogEvent::BoardReset)],
        };
        let kinds: Vec<String> = run
            .in_time_order()
            .iter()
            .map(|(_, r)| match r {
                Record::Event(_) => "event".into(),
                Record::Frame(BoardFrame::Ack { id }) => format!("ack {id}"),
                Record::Frame(_) => "sample frame".into(),
                Record::Sample(_) => "sample".into(),
                Record::Command(_) => "command".into(),
            })
            .collect();
        assert_eq!(kinds, ["event", "ack 1", "sample frame", "sample", "ack 2"]);
    }

    #[test]
    fn event_kinds_are_kebab_case_and_the_old_spelling_still_reads() {
        let clock = LogEvent::WallClock { unix_ns: 7 };
        let json = serde_json::to_string(&clock).expect("serialises");
        assert_eq!(json, r#"{"kind":"wall-clock","unix_ns":7}"#);
        let old: LogEvent =
            serde_json::from_str(r#"{"kind":"wall_clock","unix_ns":7}"#).expect("old spelling");
        assert_eq!(old, clock);
        for (old, new) in [
            (
                r#"{"kind":"device_vanished","port":"p"}"#,
                "device-vanished",
            ),
            (
                r#"{"kind":"samples_lost","after_seq":1,"missing":2}"#,
                "samples-lost",
            ),
            (r#"{"kind":"bad_frames","count":3}"#, "bad-frames"),
            (r#"{"kind":"board_reset"}"#, "board-reset"),
            (r#"{"kind":"started","port":"p"}"#, "started"),
        ] {
            let event: LogEvent = serde_json::from_str(old).expect(old);
            let again = serde_json::to_value(&event).expect("serialises");
            assert_eq!(again["kind"], new);
            assert_eq!(serde_json::from_value::<LogEvent>(again).ok(), Some(event));
        }
    }
}
