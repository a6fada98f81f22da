//! The run's time base: the board's 64-bit µs timestamps turned into one strictly increasing run
//! time, across counter wraps, board resets and reconnections.

/// A jump of the board's clock this large (modulo 2⁶⁴) is backwards, not elapsed time.
const MAX_STEP_US: u64 = 1 << 62;

/// Run time [µs] of each sample: 0 at the first sample, then the board's own intervals
/// (`t_us` differences modulo 2⁶⁴, so a counter wrapping past `u64::MAX` changes nothing). After
/// [`RunClock::restart`] (the board rebooted and its clock started over) the run continues the
/// given gap after the last sample. Never repeats or goes back: a board timestamp that does not
/// move forward advances the run by 1 µs.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct RunClock {
    last_t_us: Option<u64>,
    run_us: u64,
    restart_gap_us: Option<u64>,
}

impl RunClock {
    /// A clock before the first sample.
    pub fn new() -> Self {
        Self::default()
    }

    /// The run time [µs] of the next sample, stamped `t_us` by the board.
    pub fn at(&mut self, t_us: u64) -> u64 {
        if let Some(last) = self.last_t_us {
            let step_us = match self.restart_gap_us.take() {
                Some(gap_us) => gap_us,
                None => t_us.wrapping_sub(last),
            };
            let step_us = if step_us == 0 || step_us >= MAX_STEP_US {
                1
            } else {
                step_us
            };
            self.run_us = self.run_us.saturating_add(step_us);
        }
        self.last_t_us = Some(t_us);
        self.run_us
    }

    /// The board's clock started over: the next sample comes `gap_us` after the last one (at
    /// least 1 µs later). No effect before the first sample.
    pub fn restart(&mut self, gap_us: u64) {
        if self.last_t_us.is_some() {
            self.restart_gap_us = Some(gap_us);
        }
    }

    /// The latest sample's run time [µs] (0 before the first).
    pub fn run_us(&self) -> u64 {
        self.run_us
    }

    /// Run time [µs] in seconds, as written to logs.
    pub fn seconds(run_us: u64) -> f64 {
        run_us as f64 / 1e6
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn board_intervals_become_run_time_from_zero() {
        let mut clock = RunClock::new();
        assert_eq!(clock.at(1_000_000), 0);
        assert_eq!(clock.at(1_005_000), 5_000);
        assert_eq!(clock.at(1_012_000), 12_000);
        assert_eq!(RunClock::seconds(clock.run_us()), 0.012);
    }

    #[test]
    fn the_64_bit_counter_wrapping_is_seamless() {
        let mut clock = RunClock::new();
        let t0 = u64::MAX - 7_000;
        let times: Vec<u64> = (0..5)
            .map(|k| clock.at(t0.wrapping_add(k * 5_000)))
            .collect();
        assert_eq!(times, [0, 5_000, 10_000, 15_000, 20_000]);
    }

    #[test]
    fn a_restart_continues_after_the_gap_and_time_never_repeats() {
        let mut clock = RunClock::new();
        clock.restart(99); // before the first sample: nothing to continue
        assert_eq!(clock.at(50_000), 0);
        assert_eq!(clock.at(55_000), 5_000);
        clock.restart(2_000_000);
        assert_eq!(clock.at(0), 2_005_000);
        assert_eq!(clock.at(5_000), 2_010_000);
        clock.restart(0);
        assert_eq!(clock.at(0), 2_010_001, "a zero gap still moves on");
        assert_eq!(clock.at(0), 2_010_002, "a repeated stamp moves on by 1 µs");
        assert_eq!(clock.at(1), 2_010_003);
        assert_eq!(clock.at(2), 2_010_004, "backwards to 1 then on to 2");
    }

    #[test]
    fn a_backwards_jump_without_a_restart_moves_on_by_one_microsecond() {
        let mut clock = RunClock::new();
        clock.at(10_000);
        assert_eq!(clock.at(4_000), 1);
        assert_eq!(clock.at(9_000), 5_001);
    }
}
