//! rover-power board firmware: RTIC 2 on the STM32F411CEU6 "Black Pill".
//!
//! Only the hardware glue lives here: clocks, TIM2 monotonic, I²C1, USB CDC-ACM. The logic
//! (`Board`, `Sampler`, `Link`) is in the library and tested on the host.
#![cfg_attr(target_os = "none", no_std, no_main)]

/// Host build: the firmware only runs on the board; this keeps `cargo test --workspace` green.
#[cfg(not(target_os = "none"))]
fn main() {
    eprintln!("the firmware runs on the STM32F411: build it with `cargo fw` (see README)");
}

#[cfg(target_os = "none")]
#[rtic::app(device = stm32f4xx_hal::pac, peripherals = true, dispatchers = [SPI1])]
mod app {
    use defmt_rtt as _;
    use panic_probe as _;

    use firmware::board::{Board, LinkAccess};
    use firmware::link::Link;
    use firmware::sampler::SamplerConfig;
    use rtic::Mutex;
    use rtic_time::Monotonic;
    use stm32f4xx_hal::{
        i2c::I2c,
        otg_fs::{UsbBus, UsbBusType, USB},
        pac,
        prelude::*,
        rcc::Config,
        timer::MonoTimerUs,
        watchdog::IndependentWatchdog,
    };
    use usb_device::{bus::UsbBusAllocator, prelude::*};
    use usbd_serial::SerialPort;

    /// TIM2 at 1 MHz with u64 ticks: board time in µs, wraps after 584 000 years.
    pub type Mono = MonoTimerUs<pac::TIM2>;
    type Instant = <Mono as Monotonic>::Instant;
    type Duration = <Mono as Monotonic>::Duration;

    /// USB full-speed bulk packet size.
    const USB_PACKET: usize = 64;
    /// The sample task feeds the watchdog every period (≤ 1 s, `wire::MAX_SAMPLE_PERIOD_US`); the
    /// HAL's I²C busy-waits without a timeout, so a bus stuck without an error flag would hang
    /// sampling for good. The reset restarts the stream (a new hello, `seq` from 0).
    const WATCHDOG_MS: u32 = 2_000;

    defmt::timestamp!("{=u64:us}", Mono::now().ticks());

    #[shared]
    struct Shared {
        link: Link,
    }

    #[local]
    struct Local {
        i2c: I2c<pac::I2C1>,
        board: Board,
        watchdog: IndependentWatchdog,
        usb_dev: UsbDevice<'static, UsbBusType>,
        serial: SerialPort<'static, UsbBusType>,
    }

    #[init]
    fn init(cx: init::Context) -> (Shared, Local) {
        let mut core = cx.core;
        let dp = cx.device;

        // 25 MHz crystal → 96 MHz system clock; the PLL's 48 MHz output clocks USB.
        let mut rcc = dp
            .RCC
            .freeze(Config::hse(25.MHz()).sysclk(96.MHz()).require_pll48clk());
        let _mono: Mono = dp.TIM2.monotonic_us(&mut core.NVIC, &mut rcc);

        let gpioa = dp.GPIOA.split(&mut rcc);
        let gpiob = dp.GPIOB.split(&mut rcc);
        // I²C1 at 400 kHz on PB8 (SCL) / PB9 (SDA); both INA226 on this bus.
        let i2c = I2c::new(dp.I2C1, (gpiob.pb8, gpiob.pb9), 400.kHz(), &mut rcc);

        let usb = USB {
            usb_global: dp.OTG_FS_GLOBAL,
            usb_device: dp.OTG_FS_DEVICE,
            usb_pwrclk: dp.OTG_FS_PWRCLK,
            pin_dm: gpioa.pa11.into(),
            pin_dp: gpioa.pa12.into(),
            hclk: rcc.clocks.hclk(),
        };
        // 'static storage handed out exactly once; init runs once, so these cannot fail.
        // Buffers for received (OUT) packets, sized like the F411's 1.25 KiB USB FIFO.
        let ep_memory =
            cortex_m::singleton!(EP_MEMORY: [u32; 320] = [0; 320]).expect("init runs once");
        let usb_bus: &'static UsbBusAllocator<UsbBusType> =
            cortex_m::singleton!(USB_BUS: UsbBusAllocator<UsbBusType> = UsbBus::new(usb, ep_memory))
                .expect("init runs once");
        // The class allocates its endpoints before the device is built.
        let serial = SerialPort::new(usb_bus);
        let usb_dev = UsbDeviceBuilder::new(usb_bus, UsbVidPid(0x16c0, 0x27dd))
            .device_class(usbd_serial::USB_CLASS_CDC)
            .strings(&[StringDescriptors::default()
                .manufacturer("rover-power")
                .product("rover-power INA226 board")
                .serial_number("RP-0001")])
            .expect("one language of string descriptors")
            .build();

        let mut watchdog = IndependentWatchdog::new(dp.IWDG);
        // Halted at a breakpoint, the debugger must not be reset under us.
        watchdog.stop_on_debug(&dp.DBGMCU, true);
        watchdog.start(WATCHDOG_MS.millis());

        let board = Board::new(SamplerConfig::BOARD);
        defmt::info!(
            "rover-power firmware {=str}: sysclk {=u32} Hz, sampling every {=u32} us",
            env!("CARGO_PKG_VERSION"),
            rcc.clocks.sysclk().raw(),
            board.sample_period_us()
        );
        sample::spawn().ok();
        (
            Shared { link: Link::new() },
            Local {
                i2c,
                board,
                watchdog,
                usb_dev,
                serial,
            },
        )
    }

    /// The link behind RTIC's lock: held only while frames are queued, never during I²C.
    struct Locked<'a, M>(&'a mut M);

    impl<M: Mutex<T = Link>> LinkAccess for Locked<'_, M> {
        fn with_link<R>(&mut self, f: impl FnOnce(&mut Link) -> R) -> R {
            self.0.lock(f)
        }
    }

    /// Drift-free sampling on absolute deadlines; the period can change at every tick.
    #[task(priority = 1, local = [i2c, board, watchdog], shared = [link])]
    async fn sample(mut cx: sample::Context) {
        let mut next: Instant = Mono::now();
        let mut faults = model_core::Sides::new(None, None);
        loop {
            let period = Duration::micros(u64::from(cx.local.board.sample_period_us()));
            next += period;
            let now = Mono::now();
            if now > next + period {
                // Fell behind by more than a period (debugger halt, stuck bus): skip ahead
                // rather than burst; the sequence counter stays continuous, the time gap shows.
                defmt::warn!("sampling fell behind; re-anchoring");
                next = now;
            }
            Mono::delay_until(next).await;
            let t_us = Mono::now().ticks();
            cx.local
                .board
                .tick(cx.local.i2c, &mut Locked(&mut cx.shared.link), t_us);

            let now_faults = cx.local.board.sampler().last_faults();
            if now_faults != faults {
                defmt::warn!(
                    "chip faults: left {=str} right {=str}",
                    fault_name(now_faults.left),
                    fault_name(now_faults.right)
                );
                faults = now_faults;
            }
            // The OTG_FS interrupt only fires on bus events: kick it to start sending.
            rtic::pend(pac::Interrupt::OTG_FS);
        }
    }

    /// USB CDC-ACM: enumerate, take host bytes, send queued frames while DTR is held.
    #[task(binds = OTG_FS, priority = 2, local = [usb_dev, serial], shared = [link])]
    fn usb(mut cx: usb::Context) {
        let (usb_dev, serial) = (cx.local.usb_dev, cx.local.serial);
        if usb_dev.poll(&mut [&mut *serial]) {
            let mut buf = [0u8; USB_PACKET];
            while let Ok(n @ 1..) = serial.read(&mut buf) {
                cx.shared.link.lock(|link| link.receive(&buf[..n]));
            }
        }
        let dtr = usb_dev.state() == UsbDeviceState::Configured && serial.dtr();
        cx.shared.link.lock(|link| {
            if dtr != link.connected() {
                defmt::info!(
                    "host {=str}",
                    if dtr {
                        "connected (DTR)"
                    } else {
                        "disconnected"
                    }
                );
            }
            link.set_connected(dtr);
            while dtr && !link.pending().is_empty() {
                let chunk = &link.pending()[..link.pending().len().min(USB_PACKET)];
                match serial.write(chunk) {
                    Ok(n) if n > 0 => link.consume(n),
                    // Endpoint busy: the transfer-complete interrupt brings us back.
                    _ => break,
                }
            }
        });
    }

    fn fault_name(fault: Option<model_core::wire::ChipFault>) -> &'static str {
        use model_core::wire::ChipFault::*;
        match fault {
            None => "ok",
            Some(AddressNack) => "address NACK",
            Some(DataNack) => "data NACK",
            Some(ArbitrationLoss) => "arbitration loss",
            Some(Bus) => "bus error",
            Some(Overrun) => "overrun",
            Some(Other) => "I2C error",
            Some(WrongId) => "not an INA226",
            Some(ResetDetected) => "reset, re-initialising",
            Some(AwaitingConversion) => "waiting for its first conversion",
        }
    }
}
