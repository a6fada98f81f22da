//! The board's sample rate as the status line shows it: samples per second of board time, from
//! the samples' own `seq` and `t_us`. A stream that arrives faster or slower than real time (a
//! replay at `--speed 10`, a burst after a stall) still shows the board's rate, not its pace.

/// A step of `seq` this large (modulo 2³²) goes backwards: a rebooted board, not samples.
const MAX_SEQ_STEP: u32 = 1 << 31;

/// A step of `t_us` this large (modulo 2⁶⁴) goes backwards, as in [`super::RunClock`].
const MAX_STEP_US: u64 = 1 << 62;

/// Board samples and board time counted since the last [`BoardRate::take_hz`].
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct BoardRate {
    /// The latest sample's `seq` and `t_us`.
    last: Option<(u32, u64)>,
    samples: u64,
    board_us: u64,
}

impl BoardRate {
    /// Nothing counted yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// Counts a sample received: the board samples and board time since the previous one
    /// (samples lost between them included, as the board took them).
    pub fn sample(&mut self, seq: u32, t_us: u64) {
        if let Some((last_seq, last_t_us)) = self.last {
            let steps = seq.wrapping_sub(last_seq);
            let step_us = t_us.wrapping_sub(last_t_us);
            if (1..MAX_SEQ_STEP).contains(&steps) && (1..MAX_STEP_US).contains(&step_us) {
                self.samples += u64::from(steps);
                self.board_us += step_us;
            }
        }
        self.last = Some((seq, t_us));
    }

    /// The board restarted: its `seq` and clock start over, no interval spans the reboot.
    pub fn restart(&mut self) {
        self.last = None;
    }

    /// Board samples per second of board time since the previous call [Hz] (0 without an
    /// interval between two samples), and starts counting again.
    pub fn take_hz(&mut self) -> f64 {
        let hz = if self.board_us > 0 {
            self.samples as f64 * 1e6 / self.board_us as f64
        } else {
            0.0
        };
        self.samples = 0;
        self.board_us = 0;
        hz
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_rate_is_the_boards_across_losses_wraps_and_reboots() {
        let mut rate = BoardRate::new();
        assert_eq!(rate.take_hz(), 0.0, "nothing yet");
        rate.sample(u32::MAX - 1, u64::MAX - 3_999);
        rate.sample(u32::MAX, 1_000); // both counters wrap
        rate.sample(2, 16_000); // two lost, taken by the board every 5 ms all the same
        assert_eq!(rate.take_hz(), 200.0);
        assert_eq!(rate.take_hz(), 0.0, "no sample since");
        rate.sample(3, 21_000);
        assert_eq!(
            rate.take_hz(),
            200.0,
            "the interval spans the previous reading"
        );
        rate.restart();
        rate.sample(0, 0);
        rate.sample(1, 500);
        assert_eq!(rate.take_hz(), 2_000.0, "the rebooted board's own rate");
        rate.sample(0, 100); // a reboot without a word: seq and time went back
        rate.sample(1, 600);
        assert_eq!(rate.take_hz(), 2_000.0);
    }
}
