//! rover-power board firmware: RTIC 2 on the STM32F411CEU6 "Black Pill".
//!
//! Only the hardware glue lives here: watchdog, core voltage, clocks, TIM2 monotonic, I²C1, USB
//! CDC-ACM, the PC13 LED. The logic (`Board`, `Sampler`, `Link` with its DTR edges, bus recovery,
//! the LED pattern, the interrupt-driven I²C transfer) is in the library and tested on the host;
//! its I2C1 register glue is the library's target-only `stm32_i2c`. The sample task awaits each
//! I²C transfer (I2C1_EV/I2C1_ER handlers at priority 3, above USB): no task spins on the bus.
//! defmt `info` logs tell the bring-up story: clocks, each chip found or failing and why, USB
//! configured, DTR, the sampling rate.
//!
//! Crystal: 25 MHz (WeAct Black Pill v3.x) by default; build with `--features hse-8mhz` for the
//! boards that carry 8 MHz (docs/board.md, "Flashing").
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

    use firmware::board::{Board, LinkAccess, Watchdog};
    use firmware::bus_recovery::Recovery;
    use firmware::led::LedPattern;
    use firmware::link::{CdcPort, DtrEdge, Link, UsbState};
    use firmware::sampler::SamplerConfig;
    use firmware::stm32_i2c::{BusControl, I2c1};
    use model_core::board_id::{BoardIdentity, SERIAL_LEN, UID_LEN};
    use rtic::Mutex;
    use rtic_time::Monotonic;
    use stm32f4xx_hal::{
        gpio::{Output, Pin, PushPull},
        i2c::I2c,
        otg_fs::{UsbBus, UsbBusType, USB},
        pac,
        prelude::*,
        rcc::Config,
        signature::Uid,
        timer::MonoTimerUs,
        watchdog::IndependentWatchdog,
    };
    use usb_device::{bus::UsbBusAllocator, class::UsbClass, prelude::*};
    use usbd_serial::SerialPort;

    /// TIM2 at 1 MHz with u64 ticks: board time in µs, wraps after 584 000 years.
    pub type Mono = MonoTimerUs<pac::TIM2>;
    type Instant = <Mono as Monotonic>::Instant;
    type Duration = <Mono as Monotonic>::Duration;

    /// `Board::tick` feeds the watchdog once per completed tick, i.e. every period (at most 1 s,
    /// `wire::MAX_SAMPLE_PERIOD_US`) plus the tick's own few ms. The HAL sizes the IWDG for a
    /// 32 kHz LSI (PR ÷256, RL 374); the F411's LSI spans 17–47 kHz (datasheet), so 3 s nominal
    /// is 2.04 s at the fast corner (2× the longest period) and 5.6 s at the slow one. A hung
    /// tick resets the board, which restarts the stream (a new hello, `seq` from 0).
    const WATCHDOG_MS: u32 = 3_000;
    /// HSE crystal [MHz] (cargo feature `hse-8mhz` for the 8 MHz boards).
    const HSE_MHZ: u32 = if cfg!(feature = "hse-8mhz") { 8 } else { 25 };
    const SYSCLK_HZ: u32 = 96_000_000;
    const USB_CLK_HZ: u32 = 48_000_000;

    defmt::timestamp!("{=u64:us}", Mono::now().ticks());

    /// The Black Pill's user LED: PC13, lit when driven low.
    type Led = Pin<'C', 13, Output<PushPull>>;
    /// How often the LED task redraws the pattern [ms].
    const LED_TICK_MS: u64 = 25;

    #[shared]
    struct Shared {
        link: Link,
        /// Chosen by the sample task after each tick, shown by the LED task.
        led_pattern: LedPattern,
        /// I2C1 and the transfer in flight: the interrupt handlers drive it, the sample task
        /// starts and awaits it.
        i2c: I2c1,
    }

    /// The HAL's IWDG as the board logic's watchdog.
    #[derive(Debug)]
    pub struct Iwdg(IndependentWatchdog);

    impl Watchdog for Iwdg {
        fn feed(&mut self) {
            self.0.feed();
        }
    }

    #[local]
    struct Local {
        bus_control: BusControl,
        board: Board,
        watchdog: Iwdg,
        usb_dev: UsbDevice<'static, UsbBusType>,
        serial: SerialPort<'static, UsbBusType>,
        led: Led,
    }

    #[init]
    fn init(cx: init::Context) -> (Shared, Local) {
        let mut core = cx.core;
        let dp = cx.device;

        // The watchdog first: `freeze` spins on HSERDY with no timeout, so a board without a
        // (working) crystal would otherwise hang here for good; now it resets and tries again.
        let mut watchdog = IndependentWatchdog::new(dp.IWDG);
        // Halted at a breakpoint, the debugger must not be reset under us.
        watchdog.stop_on_debug(&dp.DBGMCU, true);
        watchdog.start(WATCHDOG_MS.millis());

        voltage_scale_1(&dp.RCC, &dp.PWR);
        // HSE → PLL: 96 MHz system clock, 48 MHz for USB. The HAL computes M/N/P/Q itself (no
        // API to force them); for 25 MHz it picks M=25 N=384 P=4 Q=8, for 8 MHz M=4 N=192 P=4
        // Q=8, both exact. Checked below from the registers.
        let mut rcc = dp.RCC.freeze(
            Config::hse(HSE_MHZ.MHz())
                .sysclk(SYSCLK_HZ.Hz())
                .require_pll48clk(),
        );
        log_clocks(&rcc, &dp.PWR);
        let _mono: Mono = dp.TIM2.monotonic_us(&mut core.NVIC, &mut rcc);

        let gpioa = dp.GPIOA.split(&mut rcc);
        let gpiob = dp.GPIOB.split(&mut rcc);
        let gpioc = dp.GPIOC.split(&mut rcc);
        // The LED starts dark (active low) until the heartbeat task draws its pattern.
        let mut led: Led = gpioc.pc13.into_push_pull_output();
        led.set_high();
        // I²C1 at 400 kHz on PB8 (SCL) / PB9 (SDA), both INA226 on it; external 2.2–4.7 kΩ
        // pull-ups to 3V3 (the pins are open-drain without pulls). The HAL sets up peripheral and
        // pins; `BusControl` clocks the bus free, and every transfer is interrupt-driven with a
        // deadline on the monotonic.
        let hal_i2c = I2c::new(dp.I2C1, (gpiob.pb8, gpiob.pb9), 400.kHz(), &mut rcc);
        let (i2c, bus_control) = BusControl::new(hal_i2c, rcc.clocks.sysclk().raw());
        log_recovery(bus_control.last_recovery());

        let identity = BoardIdentity {
            uid: unique_id(),
            hse_mhz: HSE_MHZ as u8,
        };
        // usb-device keeps the serial as &'static str: formatted once into static storage.
        let serial_buf = cortex_m::singleton!(SERIAL: [u8; SERIAL_LEN] = [0; SERIAL_LEN])
            .expect("init runs once");
        let serial_number: &'static str = identity.usb_serial(serial_buf);

        // VBUS sensing stays off: the WeAct Black Pill leaves PA9 (OTG_FS_VBUS) unconnected to
        // the USB connector's VBUS, and with sensing on the core keeps D+'s pull-up off until
        // PA9 sees VBUS, so the board would not enumerate. (synopsys-usb-otg 0.4.0 sets
        // GCCFG.NOVBUSSENS for this core in `enable`, with no option; stm32f4xx-hal's `USB`
        // takes no VBUS pin.) A pulled cable therefore reads as a suspend: the link keeps the
        // port open and queues (dropping once full) until the next host's bus reset and DTR
        // start a fresh connection (`Link::set_connected`).
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
                .serial_number(serial_number)])
            .expect("one language of string descriptors")
            .build();

        let board = Board::new(SamplerConfig {
            identity,
            ..SamplerConfig::BOARD
        });
        defmt::info!(
            "rover-power firmware {=str}: {=u32} MHz crystal, sysclk {=u32} Hz, serial {=str}, sampling every {=u32} us",
            env!("CARGO_PKG_VERSION"),
            HSE_MHZ,
            rcc.clocks.sysclk().raw(),
            serial_number,
            board.sample_period_us()
        );
        sample::spawn().ok();
        heartbeat::spawn().ok();
        (
            Shared {
                link: Link::new(),
                led_pattern: LedPattern::NoHost,
                i2c,
            },
            Local {
                bus_control,
                board,
                watchdog: Iwdg(watchdog),
                usb_dev,
                serial,
                led,
            },
        )
    }

    /// 96 MHz needs regulator scale 1 (≤ 100 MHz; the reset value is scale 2, ≤ 84 MHz), and
    /// the HAL leaves PWR_CR.VOS alone. VOS may only change while the PLL is off, i.e. before
    /// `freeze`; it takes effect when the PLL locks (VOSRDY, checked in `log_clocks`).
    fn voltage_scale_1(rcc: &pac::RCC, pwr: &pac::PWR) {
        rcc.apb1enr().modify(|_, w| w.pwren().set_bit());
        // Read back: the clock must be running before the PWR write (RCC enable delay).
        let _ = rcc.apb1enr().read();
        pwr.cr().modify(|_, w| w.vos().scale1());
    }

    /// Logs the PLL as programmed and complains if USB or the core are off their exact clocks
    /// (a crystal other than the build's: `hse-8mhz`).
    fn log_clocks(rcc: &stm32f4xx_hal::rcc::Rcc, pwr: &pac::PWR) {
        let pll = rcc.pllcfgr().read();
        let p = 2 * (u32::from(pll.pllp().bits()) + 1);
        defmt::info!(
            "PLL M={=u8} N={=u16} P={=u32} Q={=u8}, voltage scale 1 ready: {=bool}",
            pll.pllm().bits(),
            pll.plln().bits(),
            p,
            pll.pllq().bits(),
            pwr.csr().read().vosrdy().bit_is_set()
        );
        let usb_exact = rcc.clocks.pll48clk().map(|f| f.raw()) == Some(USB_CLK_HZ);
        if rcc.clocks.sysclk().raw() != SYSCLK_HZ || !usb_exact {
            defmt::error!(
                "clocks are not exactly 96/48 MHz for a {=u32} MHz crystal: USB will fail",
                HSE_MHZ
            );
        }
    }

    /// The 96-bit unique ID in memory order (RM0383, "Unique device ID register"): X, Y (little-endian), wafer, lot.
    fn unique_id() -> [u8; UID_LEN] {
        let uid = Uid::get();
        let mut bytes = [0u8; UID_LEN];
        bytes[0..2].copy_from_slice(&uid.x().to_le_bytes());
        bytes[2..4].copy_from_slice(&uid.y().to_le_bytes());
        bytes[4] = uid.waf_num();
        for (dst, src) in bytes[5..].iter_mut().zip(uid.lot_num().as_bytes()) {
            *dst = *src;
        }
        bytes
    }

    fn log_recovery(recovery: Option<Recovery>) {
        match recovery {
            Some(Recovery::WasFree) | None => {}
            Some(Recovery::Freed { pulses }) => {
                defmt::warn!("I2C: a chip held SDA low; freed after {=u8} clocks", pulses)
            }
            Some(Recovery::Stuck) => {
                defmt::error!("I2C: SDA or SCL stays low (short, missing pull-up, latched chip)")
            }
        }
    }

    /// The link behind RTIC's lock: held only while frames are queued, never during I²C.
    struct Locked<'a, M>(&'a mut M);

    impl<M: Mutex<T = Link>> LinkAccess for Locked<'_, M> {
        fn with_link<R>(&mut self, f: impl FnOnce(&mut Link) -> R) -> R {
            self.0.lock(f)
        }
    }

    /// Drift-free sampling on absolute deadlines; the period can change at every tick.
    #[task(priority = 1, local = [bus_control, board, watchdog], shared = [link, led_pattern, i2c])]
    async fn sample(mut cx: sample::Context) {
        let mut next: Instant = Mono::now();
        // `Some(None)`: "ok" was logged; `None`: nothing logged yet for that chip.
        let mut logged_faults = model_core::Sides::new(None, None);
        let mut logged_period_us = cx.local.board.sample_period_us();
        let mut logged_bus_errors = 0;
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
            let timeouts = cx.local.bus_control.timeouts();
            let mut bus = cx.local.bus_control.bus(&mut cx.shared.i2c);
            // Suspended while the bus works: USB and the LED task run meanwhile.
            cx.local
                .board
                .tick_async(
                    &mut bus,
                    &mut Locked(&mut cx.shared.link),
                    cx.local.watchdog,
                    t_us,
                )
                .await;
            if cx.local.bus_control.timeouts() != timeouts {
                defmt::warn!("I2C transfer timed out or stalled; bus reset");
                log_recovery(cx.local.bus_control.last_recovery());
            }
            let bus_errors = cx.shared.i2c.lock(|i2c| i2c.bus_errors());
            if bus_errors != logged_bus_errors && bus_errors.is_power_of_two() {
                // 1, 2, 4, …: a noisy bus shows without flooding the log.
                defmt::info!(
                    "I2C: {=u32} BERR flags cleared (spurious in master mode: errata)",
                    bus_errors
                );
                logged_bus_errors = bus_errors;
            }

            let sampler = cx.local.board.sampler();
            let faults = sampler.last_faults();
            let addresses = firmware::sampler::BOARD_ADDRESSES;
            log_chip("left", addresses.left, faults.left, &mut logged_faults.left);
            log_chip(
                "right",
                addresses.right,
                faults.right,
                &mut logged_faults.right,
            );
            let period_us = cx.local.board.sample_period_us();
            if period_us != logged_period_us {
                defmt::info!(
                    "sampling every {=u32} us ({=u32} Hz), set by the host",
                    period_us,
                    1_000_000 / period_us.max(1)
                );
                logged_period_us = period_us;
            }
            let running = sampler.running();
            let connected = cx.shared.link.lock(|link| link.connected());
            let pattern = LedPattern::choose(connected, running, faults);
            cx.shared.led_pattern.lock(|p| *p = pattern);
            // The OTG_FS interrupt only fires on bus events: kick it to start sending.
            rtic::pend(pac::Interrupt::OTG_FS);
        }
    }

    /// Logs a chip's state when it changes: found (its IDs checked, configured and calibrated)
    /// or failing, and why.
    fn log_chip(
        side: &str,
        address: u8,
        fault: Option<model_core::wire::ChipFault>,
        logged: &mut Option<Option<model_core::wire::ChipFault>>,
    ) {
        use model_core::wire::ChipFault::{AwaitingConversion, ResetDetected};
        if *logged == Some(fault) {
            return;
        }
        match fault {
            None => defmt::info!(
                "{=str} INA226 at {=u8:#x}: found (ID 0x5449/0x2260), configured, CAL written; reading",
                side,
                address
            ),
            Some(AwaitingConversion) if logged.is_none() => return,
            Some(f @ (AwaitingConversion | ResetDetected)) => defmt::info!(
                "{=str} INA226 at {=u8:#x}: {} ({=str})",
                side,
                address,
                f,
                f.explain()
            ),
            Some(f) => defmt::warn!(
                "{=str} INA226 at {=u8:#x}: {} ({=str})",
                side,
                address,
                f,
                f.explain()
            ),
        }
        *logged = Some(fault);
    }

    /// I2C1 events (SB, ADDR, BTF, TXE, RXNE): the next step of the transfer. Above USB, so no
    /// step is split (RM0383's 1-byte read needs ADDR cleared and STOP set back to back).
    #[task(binds = I2C1_EV, priority = 3, shared = [i2c])]
    fn i2c_event(mut cx: i2c_event::Context) {
        cx.shared.i2c.lock(I2c1::on_interrupt);
    }

    /// I2C1 errors (AF, ARLO, BERR, OVR): the same handler sorts them out.
    #[task(binds = I2C1_ER, priority = 3, shared = [i2c])]
    fn i2c_error(mut cx: i2c_error::Context) {
        cx.shared.i2c.lock(I2c1::on_interrupt);
    }

    /// The LED on PC13: the pattern the sample task chose, redrawn every `LED_TICK_MS`.
    #[task(priority = 1, local = [led], shared = [led_pattern])]
    async fn heartbeat(mut cx: heartbeat::Context) {
        loop {
            let pattern = cx.shared.led_pattern.lock(|p| *p);
            let t_ms = Mono::now().ticks() / 1_000;
            if pattern.is_on(t_ms) {
                cx.local.led.set_low();
            } else {
                cx.local.led.set_high();
            }
            Mono::delay(Duration::millis(LED_TICK_MS)).await;
        }
    }

    /// usbd-serial's port as the link drives it ([`Link::service_usb`]).
    struct Cdc<'a>(&'a mut SerialPort<'static, UsbBusType>);

    impl CdcPort for Cdc<'_> {
        fn dtr(&self) -> bool {
            self.0.dtr()
        }

        fn reset(&mut self) {
            UsbClass::reset(&mut *self.0);
        }

        /// `WouldBlock` (nothing received) and any other error read as nothing.
        fn read(&mut self, buf: &mut [u8]) -> usize {
            self.0.read(buf).unwrap_or(0)
        }

        /// `WouldBlock` (endpoint busy, write buffer full) and any other error take nothing.
        fn write(&mut self, bytes: &[u8]) -> usize {
            self.0.write(bytes).unwrap_or(0)
        }
    }

    /// USB CDC-ACM: enumerate, then the link takes host bytes and sends queued frames while DTR
    /// is held.
    #[task(binds = OTG_FS, priority = 2, local = [usb_dev, serial, usb_state: UsbState = UsbState::Unconfigured], shared = [link])]
    fn usb(mut cx: usb::Context) {
        let (usb_dev, serial) = (cx.local.usb_dev, cx.local.serial);
        usb_dev.poll(&mut [&mut *serial]);
        // usb-device 0.3.2: `Suspend` on the bus's suspend, the state before it back on resume
        // (or `Default` if the bus was reset meanwhile); a bus reset also resets the class.
        let usb = match usb_dev.state() {
            UsbDeviceState::Default | UsbDeviceState::Addressed => UsbState::Unconfigured,
            UsbDeviceState::Configured => UsbState::Configured,
            UsbDeviceState::Suspend => UsbState::Suspended,
        };
        if usb != *cx.local.usb_state {
            match usb {
                UsbState::Configured => {
                    defmt::info!("USB configured by the host (enumerated as a CDC-ACM port)")
                }
                UsbState::Unconfigured => {
                    defmt::info!("USB reset by the host (not configured yet)")
                }
                UsbState::Suspended => {
                    defmt::info!("USB suspended (host asleep or unplugged): the port stays open")
                }
            }
            *cx.local.usb_state = usb;
        }
        match cx
            .shared
            .link
            .lock(|link| link.service_usb(usb, &mut Cdc(serial)))
        {
            Some(DtrEdge::Rising) => {
                defmt::info!("host connected (DTR raised): hello, then the stream")
            }
            Some(DtrEdge::Falling) => {
                defmt::info!("host disconnected (DTR dropped): sending stops")
            }
            None => {}
        }
    }
}
