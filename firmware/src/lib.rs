//! The board's logic, independent of the STM32: the INA226 driver, the sampler that reads both
//! chips on a timed schedule and feeds model-core's running measurements, the link that frames
//! everything for USB and takes host commands (DTR edges included), the LED pattern, and the
//! interrupt-driven I²C master transfer with its bus recovery. Driver, sampler and board are async
//! over `embedded_hal_async`: on the board the sample task awaits each transfer (`stm32_i2c`,
//! target only, maps `i2c_master` onto I2C1); the simulated board of the host tool runs the same
//! code on a blocking simulated I²C bus (`blocking`). `main.rs` only wires these to the HAL.
#![cfg_attr(not(test), no_std)]

pub mod blocking;
pub mod board;
pub mod bus_recovery;
pub mod i2c_master;
pub mod ina226;
pub mod led;
pub mod link;
pub mod sampler;
#[cfg(target_os = "none")]
pub mod stm32_i2c;
