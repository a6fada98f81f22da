//! What a recording tells the user: the live status line, why it stopped and its summary.

use super::*;

/// Why a recording stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StopReason {
    /// The stop flag was raised (Ctrl-C).
    Interrupted,
    /// [`RecordOptions::duration`] passed.
    Duration,
    /// [`RecordOptions::max_samples`] samples arrived.
    Samples,
    /// The device vanished and did not come back within the reconnect timeout.
    DeviceGone,
    /// A pseudo-terminal's writer (a replay, the simulated board) closed it: the stream's end,
    /// not waited for, as a pty never comes back.
    StreamEnded,
}

impl fmt::Display for StopReason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            StopReason::Interrupted => "interrupted",
            StopReason::Duration => "duration reached",
            StopReason::Samples => "sample count reached",
            StopReason::DeviceGone => "device gone (not back within the reconnect timeout)",
            StopReason::StreamEnded => "the stream ended (its writer closed the pseudo-terminal)",
        })
    }
}

/// The live status line's content.
#[derive(Debug, Clone, PartialEq)]
pub struct RecordStatus {
    /// Wall time since the start.
    pub elapsed: Duration,
    /// Run time of the latest sample [s].
    pub run_s: f64,
    /// Whether the port is open (false while waiting for a vanished device).
    pub connected: bool,
    /// While waiting for a vanished device: how much longer the recorder waits for it.
    pub reconnect_left: Option<Duration>,
    /// Samples received.
    pub samples: u64,
    /// The board's sample rate since the previous status [Hz]: samples per second of board
    /// time, from the samples' `seq` and `t_us` (lost ones included), whatever the pace they
    /// arrive at (a replay at `--speed 10` delivers them ten times faster); 0 when none arrived.
    pub rate_hz: f64,
    /// The decoder's counters (lost samples, bad frames, CRC errors, resets).
    pub stream: StreamStats,
    /// Frames the board dropped because its USB queue was full (its latest status frame).
    pub board_queue_drops: u32,
    /// Latest power per side [W] (host recomputation; `None` until read).
    pub power_w: Sides<Option<f64>>,
    /// Energy per side over the whole run [J] (host recomputation, all segments).
    pub energy_j: Sides<f64>,
    /// The chips' I²C addresses (from the hello).
    pub addresses: Sides<u8>,
    /// Why each chip gave no reading in the latest sample (`None`: it read fine).
    pub chip_faults: Sides<Option<ChipFault>>,
    /// Samples without a reading, per chip.
    pub chip_failed_samples: Sides<u64>,
    /// Commands sent and acknowledged.
    pub commands_sent: u64,
    /// Commands acknowledged by the board.
    pub commands_acked: u64,
    /// Why the recording stopped: the final status (`None` while it runs).
    pub stopped: Option<StopReason>,
}

impl fmt::Display for RecordStatus {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let s = &self.stream;
        let watts = |p: Option<f64>| p.map_or("-".to_owned(), |p| format!("{p:.1}"));
        write!(
            f,
            "{:>7.1} s  {:>6.1} Hz  lost {}  bad {} (CRC {})  drops {}  P {} / {} W  E {:.1} / {:.1} J",
            self.run_s,
            self.rate_hz,
            s.lost_samples,
            s.bad_frames,
            s.crc_errors,
            self.board_queue_drops,
            watts(self.power_w.left),
            watts(self.power_w.right),
            self.energy_j.left,
            self.energy_j.right,
        )?;
        if s.board_resets > 0 {
            write!(f, "  resets {}", s.board_resets)?;
        }
        if s.stale_frames > 0 {
            // Frames before the connection's hello, ignored; a count that keeps growing means
            // no hello arrives (another protocol version?).
            write!(f, "  stale {}", s.stale_frames)?;
        }
        if self.commands_sent > 0 {
            write!(
                f,
                "  cmd {}/{} acked",
                self.commands_acked, self.commands_sent
            )?;
        }
        for (side, address, fault) in [
            ("left", self.addresses.left, self.chip_faults.left),
            ("right", self.addresses.right, self.chip_faults.right),
        ] {
            if let Some(fault) = fault {
                write!(f, "  {side} chip {address:#04x}: {fault:?}")?;
            }
        }
        if self.stopped.is_some() {
            // Why is the summary's first line; no wait or key is on offer any more.
            f.write_str("  [stopped]")?;
        } else if !self.connected {
            match self.reconnect_left {
                Some(left) => write!(
                    f,
                    "  [device vanished: waiting {:.0} s more for it (--reconnect-timeout-s); Ctrl-C stops and keeps the log]",
                    left.as_secs_f64().ceil()
                )?,
                None => f.write_str("  [device vanished; Ctrl-C stops and keeps the log]")?,
            }
        }
        Ok(())
    }
}

/// What a recording got.
#[derive(Debug, Clone, PartialEq)]
pub struct RecordSummary {
    /// Why it stopped.
    pub stop: StopReason,
    /// Samples received.
    pub samples: u64,
    /// Samples written to the log's samples (both chips read).
    pub rows: u64,
    /// Samples where a chip gave no reading (not in the log's samples).
    pub incomplete_samples: u64,
    /// The decoder's counters.
    pub stream: StreamStats,
    /// Times the device vanished.
    pub vanished: u64,
    /// Times it came back.
    pub reconnects: u64,
    /// Commands sent, acknowledged and rejected.
    pub commands_sent: u64,
    /// Commands acknowledged.
    pub commands_acked: u64,
    /// Commands rejected.
    pub commands_rejected: u64,
    /// Each segment of the stream (one per board boot) with its energy check.
    pub segments: Vec<Segment>,
    /// Run time of the last sample [s].
    pub run_s: f64,
    /// The scale the registers were read with.
    pub scale: Scale,
}

impl RecordSummary {
    /// Commands sent that the board neither acked nor rejected before the recording ended.
    pub fn unanswered_commands(&self) -> u64 {
        self.commands_sent
            .saturating_sub(self.commands_acked + self.commands_rejected)
    }
}

impl fmt::Display for RecordSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let s = &self.stream;
        writeln!(f, "stopped: {}", self.stop)?;
        writeln!(
            f,
            "{} samples over {:.3} s: {} rows, {} without both chips; lost {} in {} gaps, {} bad frames ({} CRC)",
            self.samples,
            self.run_s,
            self.rows,
            self.incomplete_samples,
            s.lost_samples,
            s.gaps,
            s.bad_frames,
            s.crc_errors
        )?;
        if self.vanished > 0 {
            writeln!(
                f,
                "device vanished {} times, reconnected {} times",
                self.vanished, self.reconnects
            )?;
        }
        if s.stale_bytes > 0 {
            writeln!(
                f,
                "ignored {} bytes ({} frames) queued for an earlier connection, before the board's hello",
                s.stale_bytes, s.stale_frames
            )?;
        }
        if self.commands_sent > 0 {
            writeln!(
                f,
                "commands: {} sent, {} acked, {} rejected",
                self.commands_sent, self.commands_acked, self.commands_rejected
            )?;
        }
        writeln!(
            f,
            "model frames: {}, differing from the host's recomputation: {}",
            s.models, s.model_mismatches
        )?;
        let j = |lsb_us: i64| self.scale.energy_j(lsb_us);
        for (i, seg) in self.segments.iter().enumerate() {
            let [l, r] = seg.host_energy_lsb_us;
            write!(
                f,
                "segment {}: {} samples, host energy {:.3} / {:.3} J",
                i + 1,
                seg.samples,
                j(l),
                j(r)
            )?;
            match (seg.board_gain_lsb_us(), seg.host_gain_lsb_us()) {
                (Some(board), Some(host)) => writeln!(
                    f,
                    "; between model frames board {:.3} / {:.3} J, host differs by {} / {} LSB·µs",
                    j(board[0]),
                    j(board[1]),
                    host[0].wrapping_sub(board[0]),
                    host[1].wrapping_sub(board[1])
                )?,
                _ => writeln!(f, "; no model frames")?,
            }
        }
        Ok(())
    }
}
