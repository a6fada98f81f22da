//! [`LiveSink`]: a run log's records as live messages, encoded as the MCAP file's channels
//! (`crate::log::mcap`: protobuf samples, model and status, JSON commands and events), stamped with wall-clock time; [`LiveTee`]: a file sink and a live sink
//! together, the file first and never held back by the viewers.

use super::channels::LiveChannel;
use super::hub::{Hub, Outgoing};
use super::server::unix_now_ns;
use crate::log::commands::CommandRow;
use crate::log::mcap::{CommandMsg, EventMsg, ModelMsg, SampleMsg, StatusMsg};
use crate::log::run_csv::RunSample;
use crate::log::run_log::{LogEvent, RunLogSink};
use model_core::ina226::Scale;
use model_core::wire::BoardFrame;
use std::fmt;
use std::io;
use std::sync::Arc;

/// How a message's wall-clock time stamp is found from its run time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LiveClock {
    /// A recording: Unix time of run time 0 from the log's wall-clock event (the MCAP file's
    /// `log_time`); the host's clock until it comes.
    Recording {
        /// Unix time of run time 0 [ns], once known.
        zero_unix_ns: Option<i128>,
    },
    /// A paced replay: run time `t0_s` was Unix time `zero_unix_ns`; run time passes `speed`
    /// times faster than wall time. The log's own wall-clock events are not used: the viewer
    /// sees the replay as happening now.
    Replay {
        /// Unix time of run time `t0_s` [ns].
        zero_unix_ns: i128,
        /// The run time the replay starts at [s].
        t0_s: f64,
        /// Playback speed factor.
        speed: f64,
    },
}

impl LiveClock {
    /// The time stamp [Unix ns] of run time `t_s`.
    pub fn stamp(&self, t_s: f64) -> u64 {
        let ns = match *self {
            LiveClock::Recording {
                zero_unix_ns: Some(zero),
            } => zero + (t_s * 1e9).round() as i128,
            LiveClock::Recording { zero_unix_ns: None } => return unix_now_ns(),
            LiveClock::Replay {
                zero_unix_ns,
                t0_s,
                speed,
            } => zero_unix_ns + ((t_s - t0_s) / speed * 1e9).round() as i128,
        };
        ns.clamp(0, i128::from(u64::MAX)) as u64
    }
}

/// Publishes a run's records to the live view's viewers (see [`super::LiveServer`]). It never
/// fails and never waits: a record with no subscriber is not even serialised.
pub struct LiveSink {
    hub: Arc<Hub>,
    clock: LiveClock,
    /// The latest hello's scale (the board's until one arrives), for the model channel.
    scale: Scale,
}

impl fmt::Debug for LiveSink {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("LiveSink")
            .field("clock", &self.clock)
            .finish_non_exhaustive()
    }
}

impl LiveSink {
    pub(super) fn new(hub: Arc<Hub>, clock: LiveClock) -> Self {
        Self {
            hub,
            clock,
            scale: Scale::BOARD,
        }
    }

    /// Serialises `message` and offers it to the channel's subscribers, if it has any.
    fn publish(&self, channel: LiveChannel, t_s: f64, message: impl FnOnce() -> Vec<u8>) {
        // Nobody would read it; a latched channel's message is kept for later viewers.
        if !channel.latched() && self.hub.subscribed() & channel.bit() == 0 {
            return;
        }
        self.hub.publish(Outgoing {
            channel,
            timestamp_ns: self.clock.stamp(t_s),
            payload: Arc::from(message()),
        });
    }
}

/// JSON of a message the MCAP writer also writes (serialising these types cannot fail:
/// plain numbers, strings and options; an empty object if it ever did).
fn json(message: &impl serde::Serialize) -> Vec<u8> {
    serde_json::to_vec(message).unwrap_or_else(|_| b"{}".to_vec())
}

impl RunLogSink for LiveSink {
    fn frame(&mut self, t_s: f64, frame: &BoardFrame) -> io::Result<()> {
        match frame {
            BoardFrame::Hello(hello) => self.scale = hello.scale,
            BoardFrame::Model(model) => {
                let scale = self.scale;
                self.publish(LiveChannel::Model, t_s, || {
                    ModelMsg::of(t_s, model, scale).protobuf()
                });
            }
            BoardFrame::Status(status) => {
                self.publish(LiveChannel::Status, t_s, || {
                    StatusMsg::of(t_s, status).protobuf()
                });
            }
            _ => {}
        }
        Ok(())
    }

    fn sample(&mut self, sample: &RunSample) -> io::Result<()> {
        self.publish(LiveChannel::Sample, sample.t_s, || {
            SampleMsg::of(sample).protobuf(None)
        });
        Ok(())
    }

    fn command(&mut self, row: &CommandRow) -> io::Result<()> {
        self.publish(LiveChannel::Command, row.t_s, || json(&CommandMsg::of(row)));
        Ok(())
    }

    fn event(&mut self, t_s: f64, event: &LogEvent) -> io::Result<()> {
        if let (LogEvent::WallClock { unix_ns }, LiveClock::Recording { zero_unix_ns }) =
            (event, &mut self.clock)
        {
            // One clock per run, as in the MCAP file: the first anchor.
            if zero_unix_ns.is_none() {
                *zero_unix_ns = Some(i128::from(*unix_ns) - (t_s * 1e9).round() as i128);
            }
        }
        let stamp = self.clock.stamp(t_s);
        self.publish(LiveChannel::Event, t_s, || {
            json(&EventMsg::of(t_s, stamp, event))
        });
        Ok(())
    }

    fn flush(&mut self) -> io::Result<()> {
        Ok(())
    }
}

/// A recording's file sink with the live view beside it (if one is served): every record goes
/// to the file first (its errors are the recording's), then to the viewers (which cannot fail
/// or wait).
pub struct LiveTee<'a> {
    file: &'a mut dyn RunLogSink,
    live: Option<LiveSink>,
}

impl fmt::Debug for LiveTee<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("LiveTee")
            .field("live", &self.live)
            .finish_non_exhaustive()
    }
}

impl<'a> LiveTee<'a> {
    /// `file`, and `live` beside it.
    pub fn new(file: &'a mut dyn RunLogSink, live: Option<LiveSink>) -> Self {
        Self { file, live }
    }

    fn live(&mut self, publish: impl FnOnce(&mut LiveSink) -> io::Result<()>) -> io::Result<()> {
        match &mut self.live {
            Some(live) => publish(live),
            None => Ok(()),
        }
    }
}

impl RunLogSink for LiveTee<'_> {
    fn frame(&mut self, t_s: f64, frame: &BoardFrame) -> io::Result<()> {
        self.file.frame(t_s, frame)?;
        self.live(|l| l.frame(t_s, frame))
    }

    fn sample(&mut self, sample: &RunSample) -> io::Result<()> {
        self.file.sample(sample)?;
        self.live(|l| l.sample(sample))
    }

    fn command(&mut self, row: &CommandRow) -> io::Result<()> {
        self.file.command(row)?;
        self.live(|l| l.command(row))
    }

    fn event(&mut self, t_s: f64, event: &LogEvent) -> io::Result<()> {
        self.file.event(t_s, event)?;
        self.live(|l| l.event(t_s, event))
    }

    fn flush(&mut self) -> io::Result<()> {
        self.file.flush()
    }

    fn finish(&mut self) -> io::Result<()> {
        self.file.finish()
    }
}
