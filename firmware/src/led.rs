//! The Black Pill's LED on PC13: the only feedback a user without a debug probe gets. Which
//! pattern shows is chosen here, on the host-tested side; `main.rs` only drives the pin (active
//! low) from [`LedPattern::is_on`].
//!
//! | pattern | looks like | means |
//! |---|---|---|
//! | [`LedPattern::Sampling`] | a 50 ms blip every second | a host holds DTR, both chips read |
//! | [`LedPattern::NoHost`] | slow even blink, 1 s on / 1 s off | no host holds DTR (port closed) |
//! | [`LedPattern::ChipFault`] | 1, 2 or 3 quick flashes, then a pause | left, right or both chips give no readings |
//! | [`LedPattern::Paused`] | steady on | the host stopped sampling (`Stop`) |
//!
//! A chip fault wins over the others: it is what the user must fix on the bench, with or without
//! a host.

use model_core::wire::ChipFault;
use model_core::Sides;

/// Which chips give no readings.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FaultyChips {
    Left,
    Right,
    Both,
}

impl FaultyChips {
    /// Flashes per cycle: 1 left, 2 right, 3 both.
    pub const fn flashes(self) -> u64 {
        match self {
            FaultyChips::Left => 1,
            FaultyChips::Right => 2,
            FaultyChips::Both => 3,
        }
    }
}

/// What the LED shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LedPattern {
    /// Sampling for a host that holds DTR, both chips fine: a heartbeat.
    Sampling,
    /// No host holds DTR: the board samples but sends nothing.
    NoHost,
    /// A chip is missing or failing (anything but the transient reset/first-conversion states).
    ChipFault(FaultyChips),
    /// A host holds DTR but stopped sampling.
    Paused,
}

/// Heartbeat period and blip [ms].
const HEARTBEAT_MS: u64 = 1_000;
const BLIP_MS: u64 = 50;
/// Slow blink half-period [ms].
const SLOW_MS: u64 = 1_000;
/// Fault code: cycle, one flash's on time and flash pitch [ms].
const CODE_CYCLE_MS: u64 = 2_000;
const FLASH_ON_MS: u64 = 150;
const FLASH_PITCH_MS: u64 = 300;

/// Whether a chip's latest fault means it gives no readings. A detected reset and the wait for
/// the first conversion after a set-up last one period and are not shown.
fn is_failing(fault: Option<ChipFault>) -> bool {
    match fault {
        None | Some(ChipFault::ResetDetected) | Some(ChipFault::AwaitingConversion) => false,
        Some(
            ChipFault::AddressNack
            | ChipFault::DataNack
            | ChipFault::ArbitrationLoss
            | ChipFault::Bus
            | ChipFault::Overrun
            | ChipFault::Other
            | ChipFault::WrongId
            | ChipFault::InvalidReading,
        ) => true,
    }
}

impl LedPattern {
    /// The pattern for the board's state: DTR held by a host, sampling running, each chip's
    /// latest fault (`Sampler::last_faults`).
    pub fn choose(host_connected: bool, running: bool, faults: Sides<Option<ChipFault>>) -> Self {
        let faulty = match (is_failing(faults.left), is_failing(faults.right)) {
            (true, true) => Some(FaultyChips::Both),
            (true, false) => Some(FaultyChips::Left),
            (false, true) => Some(FaultyChips::Right),
            (false, false) => None,
        };
        match (faulty, host_connected, running) {
            (Some(chips), _, _) => LedPattern::ChipFault(chips),
            (None, false, _) => LedPattern::NoHost,
            (None, true, false) => LedPattern::Paused,
            (None, true, true) => LedPattern::Sampling,
        }
    }

    /// Whether the LED is lit at board time `t_ms` (patterns are periodic in board time).
    pub fn is_on(self, t_ms: u64) -> bool {
        match self {
            LedPattern::Sampling => t_ms % HEARTBEAT_MS < BLIP_MS,
            LedPattern::NoHost => t_ms % (2 * SLOW_MS) < SLOW_MS,
            LedPattern::ChipFault(chips) => {
                let phase = t_ms % CODE_CYCLE_MS;
                phase / FLASH_PITCH_MS < chips.flashes() && phase % FLASH_PITCH_MS < FLASH_ON_MS
            }
            LedPattern::Paused => true,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// On-time [ms] and the number of separate flashes over one 2 s window, sampled every ms.
    fn shape(pattern: LedPattern) -> (u64, u32) {
        let mut on_ms = 0;
        let mut flashes = 0;
        let mut was_on = pattern.is_on(1_999);
        for t in 2_000..4_000 {
            let on = pattern.is_on(t);
            on_ms += u64::from(on);
            flashes += u32::from(on && !was_on);
            was_on = on;
        }
        (on_ms, flashes)
    }

    #[test]
    fn the_patterns_tell_the_states_apart() {
        assert_eq!(shape(LedPattern::Sampling), (100, 2));
        assert_eq!(shape(LedPattern::NoHost), (1_000, 1));
        assert_eq!(shape(LedPattern::ChipFault(FaultyChips::Left)), (150, 1));
        assert_eq!(shape(LedPattern::ChipFault(FaultyChips::Right)), (300, 2));
        assert_eq!(shape(LedPattern::ChipFault(FaultyChips::Both)), (450, 3));
        assert_eq!(shape(LedPattern::Paused), (2_000, 0));
    }

    #[test]
    fn a_chip_fault_wins_and_transient_states_do_not_count() {
        let ok = Sides::new(None, None);
        assert_eq!(LedPattern::choose(true, true, ok), LedPattern::Sampling);
        assert_eq!(LedPattern::choose(false, true, ok), LedPattern::NoHost);
        assert_eq!(LedPattern::choose(true, false, ok), LedPattern::Paused);
        let right_missing = Sides::new(None, Some(ChipFault::AddressNack));
        for (host, running) in [(true, true), (false, true), (true, false)] {
            assert_eq!(
                LedPattern::choose(host, running, right_missing),
                LedPattern::ChipFault(FaultyChips::Right)
            );
        }
        assert_eq!(
            LedPattern::choose(
                true,
                true,
                Sides::new(Some(ChipFault::WrongId), Some(ChipFault::Bus))
            ),
            LedPattern::ChipFault(FaultyChips::Both)
        );
        assert_eq!(
            LedPattern::choose(
                true,
                true,
                Sides::new(
                    Some(ChipFault::ResetDetected),
                    Some(ChipFault::AwaitingConversion)
                )
            ),
            LedPattern::Sampling
        );
    }
}
