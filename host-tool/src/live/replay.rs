//! `replay --serve`: a run log's records published to the live view at real time (or `speed`
//! times it), as if the run were happening now.

use super::server::LiveServer;
use crate::log::run_log::{Record, RunLog, RunLogSink};
use crate::replay::synthesise_frames;
use model_core::Rover;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// Longest single sleep, so a stop request is seen within it.
const STOP_POLL: Duration = Duration::from_millis(50);

/// What a live replay did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LiveReplayStats {
    /// Records published (samples, frames, commands, events).
    pub records: u64,
    /// Run time covered [s].
    pub run_s: f64,
    /// True if `stop` ended it before the log's end.
    pub stopped: bool,
}

/// Publishes `run` to `server`'s viewers, paced at `speed` × real time from its first record.
/// A log without wire frames (a run CSV) gets the frames the board would have sent
/// ([`synthesise_frames`], commanded speeds as `rover`'s wheel rates), so its model channel
/// shows power, energy and τ as a recording's does.
pub fn serve_run(
    server: &LiveServer,
    run: &RunLog,
    rover: &Rover,
    speed: f64,
    stop: &AtomicBool,
) -> LiveReplayStats {
    let synthesised = if run.frames.is_empty() {
        synthesise_frames(&run.samples, Some(rover))
    } else {
        Vec::new()
    };
    let mut items = run.in_time_order();
    if !synthesised.is_empty() {
        items.extend(synthesised.iter().map(|(t, f)| (*t, Record::Frame(f))));
        items.sort_by(|a, b| a.0.total_cmp(&b.0));
    }
    let Some(&(t0_s, _)) = items.first() else {
        return LiveReplayStats {
            records: 0,
            run_s: 0.0,
            stopped: false,
        };
    };
    let start = Instant::now();
    let mut sink = server.replay_sink(t0_s, speed);
    let mut stats = LiveReplayStats {
        records: 0,
        run_s: 0.0,
        stopped: false,
    };
    for (t_s, record) in items {
        let due = Duration::from_secs_f64(((t_s - t0_s) / speed).max(0.0));
        loop {
            if stop.load(Ordering::Relaxed) {
                stats.stopped = true;
                return stats;
            }
            let now = start.elapsed();
            if now >= due {
                break;
            }
            std::thread::sleep((due - now).min(STOP_POLL));
        }
        // The live sink never fails.
        let _ = record.write_to(t_s, &mut sink);
        let _ = sink.flush();
        stats.records += 1;
        stats.run_s = t_s - t0_s;
    }
    stats
}
