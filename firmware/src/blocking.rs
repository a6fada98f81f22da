//! A blocking bus under the async driver. The driver, sampler and board are written once, async
//! over `embedded_hal_async::i2c::I2c`: on the board each transfer is interrupt-driven and the
//! sample task awaits it (`stm32_i2c`). The simulated board and the host tests keep a blocking
//! `embedded_hal::i2c::I2c`; [`Blocking`] presents it as an async bus whose futures complete at
//! their first poll, and [`run`] drives such a future to its end. The `*_async` methods have
//! blocking twins of the old names ([`blocking_twins!`]) so host code reads as before.

use core::future::Future;
use core::pin::pin;
use core::task::{Context, Poll, Waker};
use embedded_hal::i2c::{ErrorType, I2c, Operation};

/// A blocking bus as an async one: every transaction completes when first polled.
#[derive(Debug)]
pub struct Blocking<'a, I>(pub &'a mut I);

impl<I: ErrorType> ErrorType for Blocking<'_, I> {
    type Error = I::Error;
}

/// Each method forwards to its blocking namesake (a bus may implement `write_read` apart from
/// `transaction`, as embedded-hal-mock does).
impl<I: I2c> embedded_hal_async::i2c::I2c for Blocking<'_, I> {
    async fn read(&mut self, address: u8, read: &mut [u8]) -> Result<(), Self::Error> {
        self.0.read(address, read)
    }

    async fn write(&mut self, address: u8, write: &[u8]) -> Result<(), Self::Error> {
        self.0.write(address, write)
    }

    async fn write_read(
        &mut self,
        address: u8,
        write: &[u8],
        read: &mut [u8],
    ) -> Result<(), Self::Error> {
        self.0.write_read(address, write, read)
    }

    async fn transaction(
        &mut self,
        address: u8,
        operations: &mut [Operation<'_>],
    ) -> Result<(), Self::Error> {
        self.0.transaction(address, operations)
    }
}

/// Runs a future over a [`Blocking`] bus to completion. Such a future never waits for a wake-up
/// (nothing in it is pending on an interrupt), so it is polled until ready with a no-op waker.
pub fn run<F: Future>(future: F) -> F::Output {
    let mut future = pin!(future);
    let mut cx = Context::from_waker(Waker::noop());
    loop {
        if let Poll::Ready(output) = future.as_mut().poll(&mut cx) {
            return output;
        }
    }
}

/// Blocking twins of `async` bus methods: `fn name => name_async(args) -> Ret;` defines
/// `pub fn name<I: I2c>(&mut self, i2c: &mut I, args) -> Ret` running `name_async` over
/// [`Blocking`]. `Ret` may name `I::Error`.
macro_rules! blocking_twins {
    ($( $(#[$doc:meta])* fn $name:ident => $async_name:ident ( $($arg:ident : $ty:ty),* ) -> $ret:ty; )*) => {
        $(
            $(#[$doc])*
            pub fn $name<I: embedded_hal::i2c::I2c>(&mut self, i2c: &mut I $(, $arg: $ty)*) -> $ret {
                $crate::blocking::run(self.$async_name(&mut $crate::blocking::Blocking(i2c) $(, $arg)*))
            }
        )*
    };
}
pub(crate) use blocking_twins;

#[cfg(test)]
mod tests {
    use super::*;
    use embedded_hal::i2c::ErrorKind;
    use embedded_hal_async::i2c::I2c as AsyncI2c;

    /// Answers every read with its address and counts transactions.
    #[derive(Debug, Default)]
    struct Echo(u32);

    impl ErrorType for Echo {
        type Error = ErrorKind;
    }

    impl I2c for Echo {
        fn transaction(&mut self, address: u8, ops: &mut [Operation<'_>]) -> Result<(), ErrorKind> {
            self.0 += 1;
            for op in ops {
                if let Operation::Read(buf) = op {
                    buf.fill(address);
                }
            }
            if address == 0 {
                return Err(ErrorKind::Bus);
            }
            Ok(())
        }
    }

    #[test]
    fn a_blocking_bus_runs_under_async_code() {
        let mut echo = Echo::default();
        let mut buf = [0u8; 2];
        let out = run(Blocking(&mut echo).write_read(0x40, &[1], &mut buf));
        assert_eq!((out, buf), (Ok(()), [0x40, 0x40]));
        assert_eq!(run(Blocking(&mut echo).write(0, &[1])), Err(ErrorKind::Bus));
        assert_eq!(echo.0, 2);
    }
}
