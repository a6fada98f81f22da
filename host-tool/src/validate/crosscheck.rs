//! The board's on-device model against the host's recomputation: a run's wire frames are replayed
//! through [`StreamDecoder`] (the same model-core code the board runs), and at every `Model`
//! frame the board's snapshot (energy and latest power per side, τ ∝ P/ω per side) is compared
//! with the host's state at that point of the stream.
//!
//! A model frame *differs* by the one definition `decode` and `record` use
//! ([`crate::decode::ModelCheck::differs`]: energy gained since the segment's first model frame,
//! latest power or τ not exactly equal); [`CrossCheck::model_mismatches`] counts those frames.
//! The largest differences below locate them.
//!
//! Energy and power compare exactly (integers: power LSB × µs, power LSB); any difference means
//! samples the board integrated but the host never received (lost frames), a board restart the
//! host missed, or a bug. τ ∝ P/ω needs the commanded wheel rates the board used (side speed /
//! wheel radius). In a recording by our recorder the forwarded commands are logged in order and
//! the board acks (or rejects) each in the stream, so the host applies each command's rates at
//! its ack, exactly where the board did (a later `Status` frame, the board's own report of its
//! rates, overrides them until the next ack). Without acks (another recorder) the host takes the
//! latest of the board's own report (a `Status` frame) and the forwarded commands; a command
//! forwarded just before a model frame may not have reached the board yet, so τ can differ right
//! after a command change; the time of the largest difference is reported to check.

use crate::decode::StreamDecoder;
use crate::log::commands::CommandRow;
use model_core::wire::{BoardFrame, Model};
use model_core::{Rover, Sides};
use serde::Serialize;

/// The largest difference of one quantity and where it happened.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct MaxDiff {
    /// Comparisons made (both sides of the comparison defined).
    pub compared: usize,
    /// Largest |host − board| per side, in the quantity's unit.
    pub max_abs: Sides<f64>,
    /// Run time of the model frame with the largest difference (either side) [s].
    pub at_t_s: Option<f64>,
}

impl MaxDiff {
    fn record(&mut self, t_s: f64, diff: Sides<Option<f64>>) {
        let mut any = false;
        let mut worst = self.max_abs.left.max(self.max_abs.right);
        for (slot, d) in [
            (&mut self.max_abs.left, diff.left),
            (&mut self.max_abs.right, diff.right),
        ] {
            if let Some(d) = d {
                any = true;
                let d = d.abs();
                if d > *slot {
                    *slot = d;
                }
                if d > worst {
                    worst = d;
                    self.at_t_s = Some(t_s);
                }
            }
        }
        if any {
            self.compared += 1;
        }
    }
}

/// The cross-check of one run's frames.
#[derive(Debug, Clone, PartialEq, Default, Serialize)]
pub struct CrossCheck {
    /// Frames replayed.
    pub frames: usize,
    /// `Model` frames found (each one comparison).
    pub model_frames: usize,
    /// Energy per side, host − board [power LSB × µs] (exact integers).
    pub energy_lsb_us: MaxDiff,
    /// The largest energy difference in joules at the run's scale, per side [J].
    pub energy_max_abs_j: Sides<f64>,
    /// Latest power per side, host − board [power LSB].
    pub power_lsb: MaxDiff,
    /// τ ∝ P/ω per side, host − board [W·s/rad].
    pub torque_proportional: MaxDiff,
    /// Model frames where one of board and host had a value (power or τ) the other had not.
    pub definedness_mismatches: usize,
    /// Model frames that differ from the host's recomputation (the one definition,
    /// [`crate::decode::ModelCheck::differs`], as `decode` and `record` count them).
    pub model_mismatches: u64,
    /// Samples the decoder knows were lost (sequence gaps): the board integrated them, the
    /// host could not.
    pub lost_samples: u64,
    /// Board restarts (sample sequence going back): the host's recomputation starts over.
    pub board_restarts: usize,
}

impl CrossCheck {
    /// Whether no model frame differs from the host's recomputation.
    pub fn agrees(&self) -> bool {
        self.model_mismatches == 0
    }
}

/// Replays `frames` (run time [s], frame) and compares every `Model` frame with the host's
/// recomputation. `commands` supply the wheel rates (side speed / the rover's wheel radius).
/// `None` when there are no frames (a run CSV holds physical samples only).
pub fn cross_check(
    frames: &[(f64, BoardFrame)],
    commands: &[CommandRow],
    rover: &Rover,
) -> Option<CrossCheck> {
    let acked_mode = frames.iter().any(|(_, f)| acknowledges(f));
    let mut checker = CrossChecker::new(commands, rover, acked_mode);
    for (t_s, frame) in frames {
        checker.feed(*t_s, frame);
    }
    checker.finish()
}

/// Whether `frame` answers a forwarded command (an ack, or a rejection naming it): a run with
/// any is replayed in acked mode (see the module docs).
pub fn acknowledges(frame: &BoardFrame) -> bool {
    matches!(
        frame,
        BoardFrame::Ack { .. } | BoardFrame::Rejected { id: Some(_), .. }
    )
}

/// [`cross_check`] frame by frame, for a run read as a stream: whether the run is in acked
/// mode (any frame [`acknowledges`] a command) must be known before its first frame. The
/// commands are given whole, or as they are read ([`CrossChecker::command`]; then
/// [`CrossChecker::in_order`] says whether each came before the frames it governs).
#[derive(Debug)]
pub struct CrossChecker<'a> {
    rover: &'a Rover,
    commands: Vec<CommandRow>,
    /// The first command not acked (or rejected) yet.
    pending: usize,
    acked_mode: bool,
    /// Latest run time of a model frame compared (commands before it set its wheel rates).
    last_model_t_s: Option<f64>,
    /// A command came after a frame it governs, or an ack before its command: fed as read,
    /// the check is not the one the whole list gives.
    out_of_order: bool,
    out: CrossCheck,
    dec: StreamDecoder,
    last_hello: Option<BoardFrame>,
    last_seq: Option<u32>,
    status_rates: Option<(f64, Option<Sides<f32>>)>,
    max_energy_lsb: Sides<i64>,
}

impl<'a> CrossChecker<'a> {
    /// A checker for a run with `commands`; `acked_mode`: whether any of its frames
    /// [`acknowledges`] a command.
    pub fn new(commands: &[CommandRow], rover: &'a Rover, acked_mode: bool) -> Self {
        Self {
            rover,
            commands: commands.to_vec(),
            pending: 0,
            acked_mode,
            last_model_t_s: None,
            out_of_order: false,
            out: CrossCheck::default(),
            dec: StreamDecoder::new(),
            last_hello: None,
            last_seq: None,
            status_rates: None,
            max_energy_lsb: Sides::new(0, 0),
        }
    }

    /// The run's next command, read after the frames fed so far.
    pub fn command(&mut self, row: &CommandRow) {
        // Without acks a command is in force from its time: it governed any model frame after
        // it that was compared already.
        if !self.acked_mode && self.last_model_t_s.is_some_and(|t_s| row.t_s < t_s) {
            self.out_of_order = true;
        }
        self.commands.push(*row);
    }

    /// Whether every command fed by [`CrossChecker::command`] came before the frames it
    /// governs (then the check is the one the whole list gives, to the bit).
    pub fn in_order(&self) -> bool {
        !self.out_of_order
    }

    /// The command the next ack (or rejection) answers, if it has been fed.
    fn answered(&mut self) -> Option<CommandRow> {
        let command = self.commands.get(self.pending).copied();
        match command {
            Some(_) => self.pending += 1,
            // Its command comes later in the log (fed as read), or never.
            None => self.out_of_order = true,
        }
        command
    }

    fn rates_of(&self, c: &CommandRow) -> Sides<f32> {
        c.cmd_mps
            .map(|v| (v / f64::from(self.rover.wheel_radius_m)) as f32)
    }

    /// A frame of the log, into the host's decoder as if from the wire.
    fn replay(dec: &mut StreamDecoder, frame: &BoardFrame) {
        dec.feed_frame(frame, |_| {});
    }

    /// The next frame of the run, received at run time `t_s`.
    pub fn feed(&mut self, t_s: f64, frame: &BoardFrame) {
        self.out.frames += 1;
        match frame {
            BoardFrame::Hello(_) => self.last_hello = Some(*frame),
            BoardFrame::Sample(s) => {
                if self.last_seq.is_some_and(|last| s.seq < last) {
                    self.out.lost_samples += self.dec.stats().lost_samples;
                    self.out.model_mismatches += self.dec.stats().model_mismatches;
                    self.out.board_restarts += 1;
                    self.dec = StreamDecoder::new();
                    if let Some(h) = &self.last_hello {
                        Self::replay(&mut self.dec, h);
                    }
                }
                self.last_seq = Some(s.seq);
            }
            BoardFrame::Status(st) => {
                // The board's own report of the rates it uses wins until the next ack (the
                // decoder applies it too).
                self.status_rates = Some((t_s, st.wheel_rates_rad_s));
            }
            BoardFrame::Ack { .. } => {
                if let Some(c) = self.answered() {
                    let rates = self.rates_of(&c);
                    self.dec.set_wheel_rates(Some(rates));
                }
            }
            BoardFrame::Rejected { id: Some(_), .. } => {
                self.answered();
            }
            _ => {}
        }
        if !self.acked_mode && matches!(frame, BoardFrame::Model(_)) {
            self.dec.set_wheel_rates(wheel_rates_at(
                t_s,
                self.status_rates,
                &self.commands,
                self.rover,
            ));
            self.last_model_t_s = Some(self.last_model_t_s.map_or(t_s, |last| last.max(t_s)));
        }
        Self::replay(&mut self.dec, frame);
        if let BoardFrame::Model(model) = frame {
            self.compare(t_s, model);
        }
    }

    /// Compares the board's model frame at `t_s` with the host's state.
    fn compare(&mut self, t_s: f64, model: &Model) {
        let out = &mut self.out;
        out.model_frames += 1;
        let host = self.dec.measurements().snapshot();
        let board = model.snapshot;
        let de = Sides::new(
            host.energy_lsb_us
                .left
                .saturating_sub(board.energy_lsb_us.left),
            host.energy_lsb_us
                .right
                .saturating_sub(board.energy_lsb_us.right),
        );
        for (m, d) in [
            (&mut self.max_energy_lsb.left, de.left),
            (&mut self.max_energy_lsb.right, de.right),
        ] {
            *m = (*m).max(d.saturating_abs());
        }
        out.energy_lsb_us.record(t_s, de.map(|d| Some(d as f64)));
        let mut mismatch = false;
        let mut diff = |h: Option<f64>, b: Option<f64>| match (h, b) {
            (Some(h), Some(b)) => Some(h - b),
            (None, None) => None,
            _ => {
                mismatch = true;
                None
            }
        };
        let mut diff_sides = |h: Sides<Option<f64>>, b: Sides<Option<f64>>| {
            Sides::new(diff(h.left, b.left), diff(h.right, b.right))
        };
        let dp = diff_sides(
            host.power_lsb.map(|p| p.map(f64::from)),
            board.power_lsb.map(|p| p.map(f64::from)),
        );
        let dt = diff_sides(
            host.torque_proportional.map(|t| t.map(f64::from)),
            board.torque_proportional.map(|t| t.map(f64::from)),
        );
        if mismatch {
            out.definedness_mismatches += 1;
        }
        out.power_lsb.record(t_s, dp);
        out.torque_proportional.record(t_s, dt);
    }

    /// The cross-check of the frames fed; `None` if there were none.
    pub fn finish(self) -> Option<CrossCheck> {
        if self.out.frames == 0 {
            return None;
        }
        let mut out = self.out;
        out.lost_samples += self.dec.stats().lost_samples;
        out.model_mismatches += self.dec.stats().model_mismatches;
        let scale = self.dec.scale();
        out.energy_max_abs_j = self.max_energy_lsb.map(|e| scale.energy_j(e));
        Some(out)
    }
}

/// The wheel rates in force at `t_s`: the later of the board's last reported rates and the last
/// forwarded command.
fn wheel_rates_at(
    t_s: f64,
    status: Option<(f64, Option<Sides<f32>>)>,
    commands: &[CommandRow],
    rover: &Rover,
) -> Option<Sides<f32>> {
    // A command logged at the model frame's own time was sent after it: not yet in force.
    let upto = commands.partition_point(|c| c.t_s < t_s);
    let command = upto.checked_sub(1).map(|i| &commands[i]);
    let from_command = command.map(|c| {
        (
            c.t_s,
            Some(
                c.cmd_mps
                    .map(|v| (v / f64::from(rover.wheel_radius_m)) as f32),
            ),
        )
    });
    match (status, from_command) {
        (Some(s), Some(c)) => {
            if s.0 >= c.0 {
                s.1
            } else {
                c.1
            }
        }
        (Some(s), None) => s.1,
        (None, Some(c)) => c.1,
        (None, None) => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::board::{SideLoad, SimBoard};
    use firmware::sampler::SamplerConfig;
    use model_core::wire::{encode, Command, HostFrame, MAX_FRAME};

    /// A simulated board (the firmware's own code) running `steps` periods with the given load,
    /// wheel rates set by a host command first; returns the frames with their run time.
    fn board_frames(steps: usize, rates: Sides<f32>) -> Vec<(f64, BoardFrame)> {
        let mut board = SimBoard::new(SamplerConfig::BOARD);
        board.set_host_connected(true);
        board.set_load(|t_us: u64| {
            let wobble = ((t_us / 10_000) % 7) as f64 * 0.1;
            Sides::new(
                SideLoad {
                    current_a: 2.0 + wobble,
                    bus_v: 24.0,
                },
                SideLoad {
                    current_a: 3.0 - wobble,
                    bus_v: 24.1,
                },
            )
        });
        let mut cmd = [0u8; MAX_FRAME];
        let n = encode(
            &HostFrame {
                id: 1,
                command: Command::SetWheelRates(rates),
            },
            &mut cmd,
        )
        .expect("fits");
        board.receive(&cmd[..n]);
        let mut bytes = Vec::new();
        for _ in 0..steps {
            board.step();
            board.drain_into(&mut bytes).expect("vec");
        }
        let mut dec = StreamDecoder::new();
        let mut frames = Vec::new();
        dec.feed(&bytes, |e| {
            if let crate::decode::Event::Frame(f) = e {
                let t = match &f {
                    BoardFrame::Sample(s) => s.t_us as f64 * 1e-6,
                    BoardFrame::Model(m) => m.t_us as f64 * 1e-6,
                    _ => frames.last().map_or(0.0, |(t, _)| *t),
                };
                frames.push((t, f));
            }
        });
        frames
    }

    fn command(left: f64, right: f64) -> CommandRow {
        CommandRow::new(0.0, Sides::new(left, right))
    }

    #[test]
    fn board_and_host_agree_exactly_on_a_clean_stream() {
        let r = f64::from(Rover::HUSKY_A200.wheel_radius_m);
        let cmd = command(-0.3, 0.3);
        let rates = cmd.cmd_mps.map(|v| (v / r) as f32);
        let frames = board_frames(3000, rates);
        let c = cross_check(&frames, &[cmd], &Rover::HUSKY_A200).expect("frames");
        assert!(c.model_frames > 3, "{c:?}");
        assert_eq!(c.energy_lsb_us.compared, c.model_frames);
        assert!(c.torque_proportional.compared > 0, "{c:?}");
        assert!(c.agrees(), "{c:?}");
        assert_eq!(c.lost_samples, 0);
    }

    #[test]
    fn a_lost_sample_and_a_tampered_model_frame_show_up() {
        let r = f64::from(Rover::HUSKY_A200.wheel_radius_m);
        let cmd = command(0.3, 0.3);
        let mut frames = board_frames(3000, cmd.cmd_mps.map(|v| (v / r) as f32));
        // Tamper with the last model frame's left energy by 12345 LSB·µs.
        let last_model = frames
            .iter()
            .rposition(|(_, f)| matches!(f, BoardFrame::Model(_)))
            .expect("model frames");
        if let BoardFrame::Model(m) = &mut frames[last_model].1 {
            m.snapshot.energy_lsb_us.left += 12_345;
        }
        let c = cross_check(&frames, &[cmd], &Rover::HUSKY_A200).expect("frames");
        assert_eq!(c.energy_lsb_us.max_abs.left, 12_345.0, "{c:?}");
        assert_eq!(c.energy_lsb_us.max_abs.right, 0.0);
        assert_eq!(c.energy_lsb_us.at_t_s, Some(frames[last_model].0));
        // Drop one sample early on: the host misses its energy from then on.
        let first_sample = frames
            .iter()
            .position(|(_, f)| matches!(f, BoardFrame::Sample(s) if s.seq == 10))
            .expect("sample 10");
        frames.remove(first_sample);
        let c = cross_check(&frames, &[cmd], &Rover::HUSKY_A200).expect("frames");
        assert_eq!(c.lost_samples, 1);
        assert!(c.energy_lsb_us.max_abs.right > 0.0, "{c:?}");
        assert!(!c.agrees());
    }

    #[test]
    fn wheel_rates_come_from_the_later_of_status_and_commands() {
        let r = f64::from(Rover::HUSKY_A200.wheel_radius_m);
        let frames = board_frames(3000, Sides::new((0.3 / r) as f32, (0.3 / r) as f32));
        assert!(frames
            .iter()
            .any(|(_, f)| matches!(f, BoardFrame::Status(_))));
        // The log says the host commanded twice the speed, but the board's status frames report
        // the rates it really uses: those win, τ agrees.
        let wrong = [command(0.6, 0.6)];
        let c = cross_check(&frames, &wrong, &Rover::HUSKY_A200).expect("frames");
        assert!(c.agrees(), "{c:?}");
        // Without status frames only the (wrong) command is known: τ differs by half, energy and
        // power still agree exactly.
        let no_status: Vec<_> = frames
            .into_iter()
            .filter(|(_, f)| !matches!(f, BoardFrame::Status(_)))
            .collect();
        let c = cross_check(&no_status, &wrong, &Rover::HUSKY_A200).expect("frames");
        assert_eq!(c.energy_lsb_us.max_abs, Sides::new(0.0, 0.0));
        assert_eq!(c.power_lsb.max_abs, Sides::new(0.0, 0.0));
        assert!(c.torque_proportional.max_abs.left > 1.0, "{c:?}");
        assert!(c.torque_proportional.at_t_s.is_some());
        assert!(cross_check(&[], &[], &Rover::HUSKY_A200).is_none());
    }
}
