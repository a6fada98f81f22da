//! The science and the wire format of rover-power, shared by the board and the host.
//!
//! `#![no_std]`, no allocation, `f32` so the same code runs on the STM32F411 (with its FPU) and on
//! the host. The models and post-processing the host evaluates (simulator, validation,
//! diagnosis, planner) use `f64`, still without `std` or allocation: [`power`], [`soil`],
//! [`paths`], [`fit`] (least squares and the seed's power fits) and [`tracking`] (the
//! total-station track, Section 5.1). [`rng`] holds the seeded generators of the simulator,
//! the benchmarks and the tests. Equation numbers refer to the seed thesis
//! (`shared/seeds/000_…`): chapters are "Eq 2.4"; the appended paper's equations are "paper Eq 20".
//!
//! Why the board does not pay for the host-only `f64` modules, and why they are not behind a
//! `host` feature: the firmware calls only [`board_id`], [`energy`], [`ina226`], [`kinematics`]
//! and [`wire`], and the linker keeps only what is reachable from its entry points (each function
//! in its own section, `--gc-sections`), so nothing of `soil`, `tracking`, `fit`, `paths` or
//! `power` (nor the `f64` libm routines they call) reaches the image. Measured with
//! `firmware/build-image.sh` and `llvm-nm` on the ELF: 42 640 bytes of flash, the same before and
//! after those modules were split into folders, and `model_core` symbols only from `energy`,
//! `ina226`, `wire` and `Sides`. A feature gate would add a build configuration to test for no
//! flash saved; keeping them here keeps one crate for the science both ends share.
#![cfg_attr(not(test), no_std)]

pub mod board_id;
pub mod energy;
pub mod fit;
pub mod geometry;
pub mod ina226;
pub mod kinematics;
pub mod paths;
pub mod power;
pub mod rate;
pub mod rng;
pub mod search;
pub mod soil;
pub mod tracking;
pub mod wire;

pub use geometry::Rover;
pub use kinematics::{Regime, SideSpeeds, TurnDirection};

/// A value per drive side (left and right motor driver).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
pub struct Sides<T> {
    pub left: T,
    pub right: T,
}

impl<T> Sides<T> {
    pub const fn new(left: T, right: T) -> Self {
        Self { left, right }
    }

    /// Applies `f` to each side.
    pub fn map<U>(self, mut f: impl FnMut(T) -> U) -> Sides<U> {
        Sides {
            left: f(self.left),
            right: f(self.right),
        }
    }

    /// Swaps left and right (the mirror image of a manoeuvre).
    pub fn mirrored(self) -> Self {
        Self {
            left: self.right,
            right: self.left,
        }
    }
}
