//! One period of the board, independent of the HAL: apply pending host commands, take a sample,
//! and queue the sample plus the periodic model and status frames. The RTIC app calls
//! [`Board::tick_async`] from its sample task (awaiting each interrupt-driven I²C transfer); the
//! host's simulated board runs the same code on its blocking bus through [`Board::tick`].

use crate::link::Link;
use crate::sampler::{Sampler, SamplerConfig};
use embedded_hal_async::i2c::I2c;
use model_core::wire::{BoardFrame, Command, Status};

/// Model frames (power, energy, τ per side) every 100 ms.
pub const MODEL_PERIOD_US: u64 = 100_000;
/// Status frames every second.
pub const STATUS_PERIOD_US: u64 = 1_000_000;
/// Host commands applied per tick at most; the rest wait in the link's queue for the next tick.
/// The USB interrupt refills the queue while the tick awaits the bus, so without a bound a
/// flooding host would keep the tick from ending until the watchdog reset the board. One full
/// queue: a burst the queue accepted is still answered within one tick.
pub const COMMANDS_PER_TICK: usize = crate::link::COMMAND_CAPACITY;

/// Access to the link, which the USB interrupt shares: on the board a short RTIC lock, on the
/// host a plain `&mut Link`.
pub trait LinkAccess {
    fn with_link<R>(&mut self, f: impl FnOnce(&mut Link) -> R) -> R;
}

impl LinkAccess for Link {
    fn with_link<R>(&mut self, f: impl FnOnce(&mut Link) -> R) -> R {
        f(self)
    }
}

/// The independent watchdog, fed once per completed tick: a tick that hangs (a bus the I²C driver
/// cannot get out of, a runaway loop) is never fed and the board resets. On the board the HAL's
/// IWDG; on the host a counter.
pub trait Watchdog {
    fn feed(&mut self);
}

/// The sampler plus the schedule of periodic frames.
#[derive(Debug, Clone)]
pub struct Board {
    sampler: Sampler,
    last_model_us: Option<u64>,
    last_status_us: Option<u64>,
}

impl Board {
    pub fn new(config: SamplerConfig) -> Self {
        Self {
            sampler: Sampler::new(config),
            last_model_us: None,
            last_status_us: None,
        }
    }

    pub fn sampler(&self) -> &Sampler {
        &self.sampler
    }

    /// The period until the next tick [µs] (host-configurable).
    pub fn sample_period_us(&self) -> u32 {
        self.sampler.sample_period_us()
    }

    /// One sampling period at board time `now_us`; feeds `watchdog` when it completes (failed
    /// chip reads included: they are reported, not hung). I²C time is spent outside the link, so
    /// the USB interrupt is held off only while frames are queued.
    pub async fn tick_async<I: I2c, L: LinkAccess, W: Watchdog>(
        &mut self,
        i2c: &mut I,
        link: &mut L,
        watchdog: &mut W,
        now_us: u64,
    ) {
        self.run_tick(i2c, link, now_us).await;
        watchdog.feed();
    }

    /// [`Self::tick_async`] on a blocking bus (the simulated board).
    pub fn tick<I: embedded_hal::i2c::I2c, L: LinkAccess, W: Watchdog>(
        &mut self,
        i2c: &mut I,
        link: &mut L,
        watchdog: &mut W,
        now_us: u64,
    ) {
        let bus = &mut crate::blocking::Blocking(i2c);
        crate::blocking::run(self.tick_async(bus, link, watchdog, now_us));
    }

    async fn run_tick<I: I2c, L: LinkAccess>(&mut self, i2c: &mut I, link: &mut L, now_us: u64) {
        if link.with_link(|l| l.take_hello_due()) {
            // No bus time at connect (a sampler at the I²C limit has none to spare): the chips'
            // registers are read back only for an explicit `GetHello`.
            let hello = self.sampler.hello();
            link.with_link(|l| l.send(&BoardFrame::Hello(hello)));
        }
        for _ in 0..COMMANDS_PER_TICK {
            let Some(frame) = link.with_link(|l| l.next_command()) else {
                break;
            };
            let outcome = self.sampler.apply_async(i2c, &frame.command).await;
            // Read outside the link's lock: I²C time must not hold off the USB interrupt.
            let hello = if outcome.is_ok() && matches!(frame.command, Command::GetHello) {
                Some(self.sampler.hello_read_back_async(i2c).await)
            } else {
                None
            };
            let reply = match outcome {
                Ok(()) => BoardFrame::Ack { id: frame.id },
                Err(reason) => BoardFrame::Rejected {
                    id: Some(frame.id),
                    reason,
                },
            };
            link.with_link(|l| {
                // Requested frames go before the acknowledgement; the status carries the link's
                // own counters, so it is built under the lock.
                if let Some(hello) = hello {
                    l.send(&BoardFrame::Hello(hello));
                }
                if let (Ok(()), Command::GetStatus) = (outcome, frame.command) {
                    let status = self.status(l, now_us);
                    l.send(&BoardFrame::Status(status));
                }
                l.send(&reply);
            });
        }
        let sample = self.sampler.sample_async(i2c, now_us).await;
        let model_due = due(&mut self.last_model_us, now_us, MODEL_PERIOD_US);
        let status_due = due(&mut self.last_status_us, now_us, STATUS_PERIOD_US);
        link.with_link(|l| {
            if let Some(sample) = sample {
                l.send(&BoardFrame::Sample(sample));
            }
            if model_due && sample.is_some() {
                if let Some(model) = self.sampler.model() {
                    l.send(&BoardFrame::Model(model));
                }
            }
            if status_due {
                let status = self.status(l, now_us);
                l.send(&BoardFrame::Status(status));
            }
        });
    }

    /// Health counters of sampler and link.
    pub fn status(&self, link: &Link, now_us: u64) -> Status {
        let s = &self.sampler;
        Status {
            uptime_us: now_us,
            samples: s.samples(),
            running: s.running(),
            i2c_errors: s.i2c_errors(),
            reinits: s.reinits(),
            skipped_results: s.skipped_results(),
            last_fault: s.last_faults(),
            queue_drops: link.queue_drops(),
            rx_errors: link.rx_errors(),
            adc: s.adc(),
            sample_period_us: s.sample_period_us(),
            wheel_rates_rad_s: s.measurements().wheel_rates(),
        }
    }
}

/// Whether a periodic frame is due at `now_us`; records the time when it is.
fn due(last_us: &mut Option<u64>, now_us: u64, period_us: u64) -> bool {
    let is_due = last_us.is_none_or(|last| now_us.wrapping_sub(last) >= period_us);
    if is_due {
        *last_us = Some(now_us);
    }
    is_due
}

#[cfg(test)]
mod tests;
