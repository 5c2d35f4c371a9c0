//! The hardware of each build behind one small interface: clocks, the frame transport
//! (transmit half [`Tx`], receive half [`Rx`]), the watchdog tick timer [`Tick`] and, in the
//! QEMU build, the control-path clock.
//!
//! | | board (default) | QEMU (`--features qemu`) |
//! | --- | --- | --- |
//! | clocks | HSE 8 MHz → PLL → 168 MHz (APB1 42 MHz) | HSI 16 MHz (QEMU emulates no PLL) |
//! | frames | CAN1 (bxCAN, PB9 TX / PB8 RX) and CAN2 (PB13 TX / PB12 RX), 1 Mbit/s, FIFO0 interrupts `CAN1_RX0` and `CAN2_RX0`; a configuration one bus cannot carry within its budget puts channel `c` on CAN `c mod 2` (`mil_frames::bus_load::Schedule::fitting`, `mil_firmware::link::bus_of_frame`), everything else and XCP on CAN1 | SLCAN lines over USART1 (PA9/PA10, QEMU `-serial` 0), RXNE interrupt `USART1`, blocking writes; XCP also on USART2 (PA2/PA3, QEMU `-serial` 1, interrupt `USART2`) |
//! | tick | TIM2 at the sample rate (2 kHz) | TIM2 every [`QEMU_TICK_US`](mil_firmware::config::QEMU_TICK_US) of QEMU time; stopped for good once the watchdog is switched off |
//! | control-path clock ([`crate::clock::Clock`]) | SysTick, core cycles (started by `main`) | TIM5, prescaler 0: 1 GHz of QEMU virtual time, one count per instruction at `-icount shift=0` (started here) |

use mil_firmware::link::Transport;

/// What the tasks need from a transmit half besides [`Transport::queue`].
pub trait Port: Transport {
    /// Sends what was queued (QEMU: blocking USART writes; board: nothing, bxCAN's mailboxes
    /// send by themselves).
    fn flush(&mut self);
}

#[cfg(not(feature = "qemu"))]
pub use board::*;
#[cfg(feature = "qemu")]
pub use qemu::*;

/// The board: bxCAN on CAN1 and CAN2, TIM2 at the sample rate.
#[cfg(not(feature = "qemu"))]
mod board {
    use core::sync::atomic::{AtomicU32, Ordering};

    use bxcan::filter::Mask32;
    use bxcan::{Fifo, Interrupt, StandardId};
    use mil_firmware::config::{SAMPLE_RATE_HZ, XCP_COMMAND_ID};
    use mil_firmware::link::{bus_of_frame, Transport, LAYOUT};
    use mil_frames::RawFrame;
    use stm32f4xx_hal::can::Can;
    use stm32f4xx_hal::pac::{self, CAN1, CAN2, TIM2};
    use stm32f4xx_hal::prelude::*;
    use stm32f4xx_hal::rcc::Config;
    use stm32f4xx_hal::timer::{CounterHz, Event, Flag};

    use super::Port;

    /// The board's crystal (HSE).
    pub const HSE_HZ: u32 = 8_000_000;
    /// Core clock.
    pub const SYSCLK_HZ: u32 = 168_000_000;
    /// APB1 clock (bxCAN's clock).
    pub const PCLK1_HZ: u32 = 42_000_000;
    /// bxCAN bit timing for 1 Mbit/s at 42 MHz: prescaler 3 (14 MHz time quanta), 14 quanta
    /// per bit = sync 1 + BS1 11 + BS2 2 (sample point 85.7 %), SJW 1:
    /// `BTR = (SJW-1) << 24 | (BS2-1) << 20 | (BS1-1) << 16 | (BRP-1)`.
    pub const CAN_BTR: u32 = (1 << 20) | (10 << 16) | 2;

    /// The first of CAN2's filter banks (CAN1 keeps 0..14 of the 28).
    const CAN2_FIRST_BANK: u8 = 14;

    /// Frames of lower priority replaced in a busy mailbox by a higher-priority one (lost).
    pub static TX_DISPLACED: AtomicU32 = AtomicU32::new(0);

    /// Transmit half: the three mailboxes of each bxCAN.
    pub struct Tx {
        can1: bxcan::Tx<Can<CAN1>>,
        can2: bxcan::Tx<Can<CAN2>>,
    }
    /// Receive half of CAN1: FIFO 0.
    pub struct Rx(pub bxcan::Rx0<Can<CAN1>>);
    /// Receive half of CAN2: FIFO 0.
    pub struct Rx2(pub bxcan::Rx0<Can<CAN2>>);
    /// The watchdog tick timer.
    pub struct Tick(CounterHz<TIM2>);

    impl Transport for Tx {
        /// Queues on the frame's bus ([`bus_of_frame`] for the running configuration) into
        /// a free mailbox. When all three are busy, bxCAN replaces a pending frame of lower
        /// priority (higher ID: a Status, CommandAck or XCP packet behind a Demand): the new
        /// frame is queued, the replaced one is lost and counted in [`TX_DISPLACED`];
        /// otherwise a full queue refuses the frame (`false`).
        fn queue(&mut self, f: &RawFrame) -> bool {
            let Some(id) = StandardId::new(f.id) else {
                return false;
            };
            let Some(data) = bxcan::Data::new(f.payload()) else {
                return false;
            };
            let frame = bxcan::Frame::new_data(id, data);
            let sent = match bus_of_frame(f.id, mil_firmware::calibration::running_buses()) {
                0 => self.can1.transmit(&frame),
                _ => self.can2.transmit(&frame),
            };
            match sent {
                Ok(status) => {
                    if status.dequeued_frame().is_some() {
                        TX_DISPLACED.fetch_add(1, Ordering::Relaxed);
                    }
                    true
                }
                Err(_) => false,
            }
        }
    }

    impl Port for Tx {
        fn flush(&mut self) {}
    }

    /// The board has no second link (XCP shares CAN1): a transmit half that refuses every
    /// frame, so that both builds share one task layout.
    pub struct AuxTx;

    impl Transport for AuxTx {
        fn queue(&mut self, _: &RawFrame) -> bool {
            false
        }
    }

    impl Port for AuxTx {
        fn flush(&mut self) {}
    }

    impl Tick {
        /// Clears the update interrupt flag.
        pub fn clear(&mut self) {
            self.0.clear_flags(Flag::Update);
        }
    }

    /// The flash range of the stored calibrations (offsets from the flash's start): sectors
    /// 10 and 11, 2 × 128 KB at 0x080C_0000, outside the program (`memory.x` gives the
    /// program the first 768 KB).
    pub const STORE_RANGE: core::ops::Range<u32> = 0xC_0000..0x10_0000;

    /// The STM32F405's own flash for the stored calibrations, behind
    /// `embedded-storage-async`. Every operation completes before it returns: a program or
    /// an erase (a 128 KB sector: typically 1-2 s) stalls the processor, interrupts
    /// included, until it is done, which is why a store is refused while the controller
    /// runs.
    pub struct StoreFlash(stm32f4xx_hal::flash::LockedFlash);

    impl embedded_storage_async::nor_flash::ErrorType for StoreFlash {
        type Error = stm32f4xx_hal::flash::Error;
    }

    impl embedded_storage_async::nor_flash::ReadNorFlash for StoreFlash {
        const READ_SIZE: usize = 1;

        async fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), Self::Error> {
            embedded_storage::nor_flash::ReadNorFlash::read(&mut self.0, offset, bytes)
        }

        fn capacity(&self) -> usize {
            embedded_storage::nor_flash::ReadNorFlash::capacity(&self.0)
        }
    }

    impl embedded_storage_async::nor_flash::NorFlash for StoreFlash {
        const WRITE_SIZE: usize = 1;
        const ERASE_SIZE: usize = 128 * 1024;

        async fn erase(&mut self, from: u32, to: u32) -> Result<(), Self::Error> {
            use stm32f4xx_hal::flash::FlashExt as _;
            embedded_storage::nor_flash::NorFlash::erase(&mut self.0.unlocked(), from, to)
        }

        async fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), Self::Error> {
            use stm32f4xx_hal::flash::FlashExt as _;
            embedded_storage::nor_flash::NorFlash::write(&mut self.0.unlocked(), offset, bytes)
        }
    }

    /// The hardware after set-up.
    pub struct Hardware {
        /// Transmit half.
        pub tx: Tx,
        /// Receive half of CAN1.
        pub rx: Rx,
        /// Receive half of CAN2.
        pub rx2: Rx2,
        /// Tick timer, running, interrupt enabled.
        pub tick: Tick,
        /// No second link on the board.
        pub aux_tx: AuxTx,
        /// The flash of the stored calibrations.
        pub store_flash: StoreFlash,
    }

    /// Clocks, CAN1, CAN2 and TIM2. `None` if a peripheral refuses its configuration.
    pub fn init(dp: pac::Peripherals) -> Option<Hardware> {
        let mut rcc = dp.RCC.freeze(
            Config::hse(HSE_HZ.Hz())
                .sysclk(SYSCLK_HZ.Hz())
                .pclk1(PCLK1_HZ.Hz())
                .pclk2((SYSCLK_HZ / 2).Hz()),
        );
        let gpiob = dp.GPIOB.split(&mut rcc);
        let can = dp.CAN1.can((gpiob.pb9, gpiob.pb8), &mut rcc);
        let mut can = bxcan::Can::builder(can)
            .set_bit_timing(CAN_BTR)
            .set_automatic_retransmit(true)
            .leave_disabled();
        // CAN2 is bxCAN's slave: it runs on CAN1's clock (enabled above) and its filter
        // banks are set through CAN1.
        let can2 = dp.CAN2.can((gpiob.pb13, gpiob.pb12), &mut rcc);
        let mut can2 = bxcan::Can::builder(can2)
            .set_bit_timing(CAN_BTR)
            .set_automatic_retransmit(true)
            .leave_disabled();
        // Hardware filter, bank 0: the MiL range (base .. base + 0x3F); everything else but
        // XCP never reaches the CPU. Frames inside it that are not ours are counted by the decoder.
        let (first, _) = LAYOUT.id_range();
        let id = StandardId::new(first)?;
        let mask = StandardId::new(0x7C0)?;
        // Bank 1: the XCP command ID exactly.
        let xcp = StandardId::new(XCP_COMMAND_ID)?;
        let exact = StandardId::new(0x7FF)?;
        // CAN2 (banks from 14 on): the MiL range only (XCP stays on CAN1).
        can.modify_filters()
            .enable_bank(0, Fifo::Fifo0, Mask32::frames_with_std_id(id, mask))
            .enable_bank(1, Fifo::Fifo0, Mask32::frames_with_std_id(xcp, exact))
            .set_split(CAN2_FIRST_BANK)
            .slave_filters()
            // Bank indices are absolute: CAN2's first is the split.
            .enable_bank(
                CAN2_FIRST_BANK,
                Fifo::Fifo0,
                Mask32::frames_with_std_id(id, mask),
            );
        can.enable_interrupt(Interrupt::Fifo0MessagePending);
        can2.enable_interrupt(Interrupt::Fifo0MessagePending);
        nb::block!(can.enable_non_blocking()).ok()?;
        nb::block!(can2.enable_non_blocking()).ok()?;
        let (tx, rx0, _rx1) = can.split();
        let (tx2, rx2, _rx2_1) = can2.split();
        let mut tick = dp.TIM2.counter_hz(&mut rcc);
        tick.start(SAMPLE_RATE_HZ.Hz()).ok()?;
        tick.listen(Event::Update);
        Some(Hardware {
            tx: Tx {
                can1: tx,
                can2: tx2,
            },
            rx: Rx(rx0),
            rx2: Rx2(rx2),
            tick: Tick(tick),
            aux_tx: AuxTx,
            store_flash: StoreFlash(stm32f4xx_hal::flash::LockedFlash::new(dp.FLASH)),
        })
    }
}

/// QEMU: SLCAN over USART1 (the MiL link) and USART2 (the XCP port), TIM2 measured against
/// the clock (TIM5).
#[cfg(feature = "qemu")]
mod qemu {
    use mil_firmware::config::QEMU_TICK_US;
    use mil_firmware::link::{slcan_line, Transport};
    use mil_frames::RawFrame;
    use stm32f4xx_hal::pac::{self, TIM2, USART1, USART2};
    use stm32f4xx_hal::prelude::*;
    use stm32f4xx_hal::rcc::Config;
    use stm32f4xx_hal::serial::{self, Serial};
    use stm32f4xx_hal::timer::{Counter, Event, Flag};

    use super::Port;
    use crate::clock::{elapsed, Clock, QEMU_COUNT_HZ};

    /// Longest SLCAN line with its `\r`.
    const LINE: usize = mil_frames::slcan::MAX_LINE + 1;

    /// A transmit half: lines are formatted into a buffer, [`Port::flush`] writes them.
    pub struct SlcanTx<W> {
        usart: W,
        buf: [u8; 4 * LINE],
        len: usize,
    }
    /// The transmit half of the MiL link (USART1).
    pub type Tx = SlcanTx<serial::Tx<USART1, u8>>;
    /// The transmit half of the XCP port (USART2).
    pub type AuxTx = SlcanTx<serial::Tx<USART2, u8>>;
    /// Receive half of the MiL link (USART1).
    pub struct Rx(pub serial::Rx<USART1, u8>);
    /// QEMU emulates no bxCAN: the board's CAN2 receive half exists here in name only
    /// (RTIC declares every local resource's type in both builds; nothing is made of it).
    pub struct Rx2;
    /// Receive half of the XCP port (USART2).
    pub struct AuxRx(pub serial::Rx<USART2, u8>);
    /// The watchdog tick timer (1 MHz nominal counter; QEMU clocks it faster).
    pub struct Tick(Counter<TIM2, 1_000_000>);

    impl<W> SlcanTx<W> {
        fn new(usart: W) -> Self {
            Self {
                usart,
                buf: [0; 4 * LINE],
                len: 0,
            }
        }
    }

    impl<W: embedded_hal_nb::serial::Write<u8>> SlcanTx<W> {
        /// Appends raw bytes (SLCAN replies); flushes first when the buffer is full.
        pub fn write(&mut self, bytes: &[u8]) {
            if self.len + bytes.len() > self.buf.len() {
                self.flush();
            }
            if let Some(dst) = self.buf.get_mut(self.len..self.len + bytes.len()) {
                dst.copy_from_slice(bytes);
                self.len += bytes.len();
            }
        }
    }

    impl<W: embedded_hal_nb::serial::Write<u8>> Transport for SlcanTx<W> {
        /// Formats the frame as an SLCAN line into the buffer (that is "queued"; the write
        /// follows in [`Port::flush`]).
        fn queue(&mut self, frame: &RawFrame) -> bool {
            if self.len + LINE > self.buf.len() {
                self.flush();
            }
            let Some(out) = self.buf.get_mut(self.len..) else {
                return false;
            };
            match slcan_line(frame, out) {
                Some(n) => {
                    self.len += n;
                    true
                }
                None => false,
            }
        }
    }

    impl<W: embedded_hal_nb::serial::Write<u8>> Port for SlcanTx<W> {
        /// Blocking writes (QEMU 7.2 never raises TXE interrupts).
        fn flush(&mut self) {
            let n = self.len;
            self.len = 0;
            for &b in self.buf.get(..n).unwrap_or(&[]) {
                // The only error QEMU's USART can return is none; on silicon a write error
                // drops the byte.
                let _ = nb::block!(self.usart.write(b));
            }
        }
    }

    impl Tick {
        /// Clears the update interrupt flag.
        pub fn clear(&mut self) {
            self.0.clear_flags(Flag::Update);
        }

        /// Stops the timer and its interrupt for good (the watchdog switched off): under
        /// `-icount ...,sleep=off` QEMU then has no timer of ours to jump to while the guest
        /// waits for the host.
        pub fn stop(&mut self) {
            self.0.unlisten(Event::Update);
            // Err only if already stopped.
            let _ = self.0.cancel();
            self.0.clear_flags(Flag::Update);
        }
    }

    /// How the tick timer was set up.
    #[derive(Clone, Copy, Debug)]
    pub struct TickInfo {
        /// TIM2 counts per clock (TIM5) count, measured at start-up.
        pub timer_per_count: f64,
        /// TIM2 counts per tick (auto-reload + 1).
        pub timer_counts: u32,
        /// The tick period this gives in QEMU's virtual time (µs).
        pub period_us: f64,
    }

    /// The hardware after set-up.
    pub struct Hardware {
        /// Transmit half.
        pub tx: Tx,
        /// Receive half, RXNE interrupt enabled.
        pub rx: Rx,
        /// XCP port transmit half (USART2).
        pub aux_tx: AuxTx,
        /// XCP port receive half, RXNE interrupt enabled.
        pub aux_rx: AuxRx,
        /// Tick timer, running, interrupt enabled.
        pub tick: Tick,
        /// The tick's calibration.
        pub tick_info: TickInfo,
        /// The control-path clock (TIM5), running.
        pub clock: Clock,
        /// The "flash" of the stored calibrations: RAM (QEMU emulates no flash controller),
        /// so a store lasts until reset.
        pub store_flash: StoreFlash,
    }

    /// The QEMU build's calibration storage: 2 pages of 4 KB in RAM, in a static (moved
    /// by reference: 8 KB by value through `init`'s frame would set the stack's
    /// high-water mark).
    pub type StoreFlash = &'static mut mil_firmware::store::RamFlash<2, 4096>;

    /// Its range: all of it.
    pub const STORE_RANGE: core::ops::Range<u32> = 0..8192;

    /// Clocks (HSI), the control-path clock (TIM5), USART1 and TIM2. `None` if a peripheral
    /// refuses its configuration.
    pub fn init(dp: pac::Peripherals) -> Option<Hardware> {
        let mut rcc = dp.RCC.freeze(Config::hsi());
        let clock = Clock::start(dp.TIM5, &mut rcc)?;
        let gpioa = dp.GPIOA.split(&mut rcc);
        let serial = Serial::new(
            dp.USART1,
            (gpioa.pa9, gpioa.pa10),
            serial::config::Config::default().baudrate(115_200.bps()),
            &mut rcc,
        )
        .ok()?;
        let (usart, mut rx) = serial.split();
        let aux = Serial::new(
            dp.USART2,
            (gpioa.pa2, gpioa.pa3),
            serial::config::Config::default().baudrate(115_200.bps()),
            &mut rcc,
        )
        .ok()?;
        let (aux_usart, mut aux_rx) = aux.split();
        // TIM2 runs at a rate of QEMU's choosing: measure it against the clock (TIM5, 1 GHz
        // of virtual time) over a busy wait, then program the tick for QEMU_TICK_US.
        let mut tick = dp.TIM2.counter::<1_000_000>(&mut rcc);
        tick.start(1_000_000_000.micros()).ok()?;
        let c0 = tick.now().ticks();
        let s0 = clock.now();
        cortex_m::asm::delay(200_000);
        let c1 = tick.now().ticks();
        let s1 = clock.now();
        let counts = f64::from(elapsed(s0, s1)).max(1.0);
        let measured = f64::from(c1.wrapping_sub(c0)) / counts;
        // QEMU 7.2 clocks its STM32 timers at 1 GHz before the prescaler (TIM2: 16 - 1).
        let timer_per_count = if measured > 0.0 { measured } else { 1.0 / 16.0 };
        let wanted = f64::from(QEMU_TICK_US) * 1.0e-6 * QEMU_COUNT_HZ * timer_per_count;
        let timer_counts = (wanted as u32).max(2);
        tick.start(timer_counts.micros()).ok()?;
        tick.listen(Event::Update);
        rx.listen();
        aux_rx.listen();
        Some(Hardware {
            tx: SlcanTx::new(usart),
            rx: Rx(rx),
            aux_tx: SlcanTx::new(aux_usart),
            aux_rx: AuxRx(aux_rx),
            tick: Tick(tick),
            tick_info: TickInfo {
                timer_per_count,
                timer_counts,
                period_us: f64::from(timer_counts) / timer_per_count / QEMU_COUNT_HZ * 1.0e6,
            },
            clock,
            store_flash: cortex_m::singleton!(
                : mil_firmware::store::RamFlash<2, 4096> = mil_firmware::store::RamFlash::new()
            )?,
        })
    }
}
