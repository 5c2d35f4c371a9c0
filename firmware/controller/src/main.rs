//! The RTIC v2 application of the MiL rig controller board. The design (tasks, frame flow,
//! watchdog, safe state, fault bits, defaults, flashing) is documented in the library
//! crate, `mil_firmware`; this binary wires it to the hardware ([`port`]), times the
//! control path ([`clock`]) and handles panics and HardFaults ([`fatal`]).
#![no_std]
#![no_main]
// `unsafe` is denied crate-wide; the exceptions (HardFault handler, stack scan, the fatal
// path's register access) carry a local `allow` with their justification.
#![deny(unsafe_code)]
#![deny(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

#[cfg(not(feature = "qemu"))]
use defmt_rtt as _;

mod clock;
mod fatal;
mod port;

/// Logs through defmt on the board; nothing in the QEMU build (its report goes to
/// semihosting at the end of the run, see `report`).
macro_rules! log {
    ($($arg:tt)*) => {{
        #[cfg(not(feature = "qemu"))]
        defmt::info!($($arg)*);
    }};
}
pub(crate) use log;

#[rtic::app(device = stm32f4xx_hal::pac, peripherals = true, dispatchers = [EXTI0])]
mod app {
    use mil_firmware::application::{prepare_change, Application, Command};
    use mil_firmware::calibration;
    use mil_firmware::link::{self, Request, Transport, COUNTER_MODULUS};
    use mil_firmware::params::{code, target, Target};
    use rtic_sync::channel::{Receiver, Sender};
    use rtic_sync::make_channel;

    use crate::clock::{self, Timings};
    use crate::port::{self, Port};

    /// Commands waiting for the configuration task.
    const QUEUE: usize = 4;

    #[shared]
    struct Shared {
        /// The application state (controller, counters, watchdog).
        app: Application,
        /// The transmit half of the transport.
        tx: port::Tx,
    }

    #[local]
    struct Local {
        tick: port::Tick,
        #[cfg(not(feature = "qemu"))]
        can: Receive,
        #[cfg(feature = "qemu")]
        uart: Receive,
    }

    /// What the receive task owns.
    pub struct Receive {
        rx: port::Rx,
        sender: Sender<'static, Request, QUEUE>,
        clock: clock::Clock,
        timings: Timings,
        #[cfg(feature = "qemu")]
        qemu: Qemu,
    }

    /// The QEMU build's SLCAN receive state and start-up figures.
    #[cfg(feature = "qemu")]
    pub struct Qemu {
        lines: mil_frames::slcan::LineBuffer<32>,
        session: link::SlcanSession,
        calibration: clock::Calibration,
        tick_info: port::TickInfo,
    }

    #[init]
    fn init(cx: init::Context) -> (Shared, Local) {
        // The control-path clock: SysTick on the board, TIM5 in QEMU (`clock` module).
        #[cfg(not(feature = "qemu"))]
        let clock = clock::Clock::start(cx.core.SYST);
        let Some(hw) = port::init(cx.device) else {
            crate::fatal::stop(format_args!("peripheral set-up refused"));
        };
        #[cfg(feature = "qemu")]
        let clock = hw.clock;
        #[cfg(feature = "qemu")]
        let calibration = clock::Calibration::measure(&clock);
        let app = match Application::new(COUNTER_MODULUS) {
            Ok(app) => app,
            Err(_) => crate::fatal::stop(format_args!("default parameters rejected")),
        };
        calibration::mirror_application(&app);
        let (sender, receiver) = make_channel!(Request, QUEUE);
        if configure::spawn(receiver).is_err() {
            crate::fatal::stop(format_args!("configuration task not spawned"));
        }
        crate::log!("mil-firmware up: tyre x1 at 2 kHz, Idle");
        (
            Shared { app, tx: hw.tx },
            Local {
                tick: hw.tick,
                #[cfg(not(feature = "qemu"))]
                can: Receive {
                    rx: hw.rx,
                    sender,
                    clock,
                    timings: Timings::default(),
                },
                #[cfg(feature = "qemu")]
                uart: Receive {
                    rx: hw.rx,
                    sender,
                    clock,
                    timings: Timings::default(),
                    qemu: Qemu {
                        lines: mil_frames::slcan::LineBuffer::new(),
                        session: link::SlcanSession::new(),
                        calibration,
                        tick_info: hw.tick_info,
                    },
                },
            },
        )
    }

    /// Sleeps between interrupts. On the board, about once a second (every 4096 wake-ups)
    /// it refreshes the stack high-water mark, preemptible by every task; the QEMU build
    /// measures it once, for the final report.
    #[idle]
    fn idle(_cx: idle::Context) -> ! {
        let mut wakes = 0u32;
        loop {
            #[cfg(not(feature = "qemu"))]
            if wakes % 4096 == 0 {
                clock::refresh_stack_used();
            }
            wakes = wakes.wrapping_add(1);
            cortex_m::asm::wfi();
        }
    }

    /// After a received frame was handled: forward a command to the configuration task (or
    /// refuse it when the queue is full). Runs inside the receive task.
    fn dispatch(
        handled: link::Handled,
        sender: &mut Sender<'static, Request, QUEUE>,
        app: &mut impl rtic::Mutex<T = Application>,
        tx: &mut impl rtic::Mutex<T = port::Tx>,
    ) {
        match handled {
            link::Handled::Stepped | link::Handled::Done => {}
            link::Handled::Command(request) => {
                if sender.try_send(request).is_err() {
                    // Queue full: refused at once, nothing changed.
                    let mode = app.lock(|a| {
                        a.count_rejected();
                        a.controller().mode()
                    });
                    let ack =
                        link::ack_frame(request.command_raw, request.index_raw, code::BUSY, mode);
                    tx.lock(|tx| {
                        tx.queue(&ack);
                    });
                }
            }
        }
    }

    /// Board: CAN1 FIFO 0 holds frames (highest priority: the sample clock of the loop).
    #[cfg(not(feature = "qemu"))]
    #[task(binds = CAN1_RX0, priority = 3, shared = [app, tx], local = [can])]
    fn can_rx(cx: can_rx::Context) {
        let Receive {
            rx,
            sender,
            clock,
            timings,
            ..
        } = cx.local.can;
        let can_rx::SharedResources {
            mut app, mut tx, ..
        } = cx.shared;
        let mut t0 = clock.now();
        // At most the FIFO's depth per interrupt, plus one (a frame arriving meanwhile).
        for _ in 0..4 {
            match rx.0.receive() {
                Ok(frame) => {
                    let received = clock.now();
                    let mut stamps = [received; 4];
                    let handled = app.lock(|a| {
                        tx.lock(|t| {
                            link::on_any_frame(a, &frame, t, &mut |k| {
                                if let Some(s) = stamps.get_mut(k) {
                                    *s = clock.now();
                                }
                            })
                        })
                    });
                    if handled == link::Handled::Stepped {
                        timings.record(t0, received, stamps);
                        // After the demand frame is queued: never delays it.
                        app.lock(|a| calibration::record_step(a));
                    }
                    dispatch(handled, sender, &mut app, &mut tx);
                    if timings.path.count % 20_000 == 1 {
                        let used = clock::stack_used_cached();
                        crate::log!(
                            "control path: max {} mean {} cycles ({} samples), stack {} B",
                            timings.path.max,
                            timings.path.mean() as u32,
                            timings.path.count,
                            used
                        );
                    }
                    t0 = clock.now();
                }
                Err(nb::Error::WouldBlock) => break,
                // FIFO overrun: frames were lost; the measurement counter counts them.
                Err(nb::Error::Other(_)) => {}
            }
        }
    }

    /// QEMU: one byte (or more) of SLCAN on USART1.
    #[cfg(feature = "qemu")]
    #[task(binds = USART1, priority = 3, shared = [app, tx], local = [uart])]
    fn usart_rx(cx: usart_rx::Context) {
        use embedded_hal_nb::serial::Read as _;
        let Receive {
            rx,
            sender,
            clock,
            timings,
            qemu,
        } = cx.local.uart;
        let usart_rx::SharedResources {
            mut app, mut tx, ..
        } = cx.shared;
        for _ in 0..64 {
            let byte = match rx.0.read() {
                Ok(b) => b,
                Err(nb::Error::WouldBlock) => break,
                Err(nb::Error::Other(_)) => {
                    qemu.lines.clear();
                    continue;
                }
            };
            let t0 = clock.now();
            let line = match qemu.lines.push(byte) {
                Ok(Some(line)) => line,
                Ok(None) => continue,
                Err(_) => {
                    tx.lock(|t| {
                        t.write(mil_frames::slcan::ERROR);
                        t.flush();
                    });
                    continue;
                }
            };
            match qemu.session.on_line(line) {
                link::LineAction::Frame(frame) => {
                    let received = clock.now();
                    let mut stamps = [received; 4];
                    let handled = app.lock(|a| {
                        tx.lock(|t| {
                            link::on_frame_probed(a, &frame, t, &mut |k| {
                                if let Some(s) = stamps.get_mut(k) {
                                    *s = clock.now();
                                }
                            })
                        })
                    });
                    if handled == link::Handled::Stepped {
                        timings.record(t0, received, stamps);
                        // After the demand frame is queued: never delays it.
                        app.lock(|a| calibration::record_step(a));
                    }
                    dispatch(handled, sender, &mut app, &mut tx);
                }
                link::LineAction::Other(e) => app.lock(|a| link::on_other_frame(a, e)),
                link::LineAction::Reply { bytes, len } => {
                    tx.lock(|t| t.write(bytes.get(..len).unwrap_or(&[])));
                }
                link::LineAction::Closed => {
                    tx.lock(|t| {
                        t.write(mil_frames::slcan::OK);
                        t.flush();
                    });
                    let app = app.lock(|a| a.clone());
                    crate::report::qemu_report(&app, timings, &qemu.calibration, &qemu.tick_info);
                }
            }
            tx.lock(|t| t.flush());
        }
    }

    /// The watchdog tick (board: every sample period; QEMU: see `config::QEMU_TICK_US`).
    /// QEMU build: once the watchdog is switched off (`config::WATCHDOG_OFF`) the tick stops
    /// its timer for good.
    #[task(binds = TIM2, priority = 2, shared = [app, tx], local = [tick])]
    fn watchdog(cx: watchdog::Context) {
        cx.local.tick.clear();
        let watchdog::SharedResources {
            mut app, mut tx, ..
        } = cx.shared;
        #[cfg(feature = "qemu")]
        if app.lock(|a| a.watchdog().is_off()) {
            cx.local.tick.stop();
            return;
        }
        app.lock(|a| {
            let trips = a.counters().comm_timeouts;
            if let Some(out) = a.on_tick() {
                tx.lock(|t| {
                    link::transmit(a, &out, t);
                    t.flush();
                });
            }
            if a.counters().comm_timeouts != trips {
                crate::log!("communication timeout: fault latched, demand ramps to safe");
            }
        });
    }

    /// Configuration changes, one at a time, between control steps (lowest priority):
    /// parameter sets are validated here, outside any lock, and swapped in under a short one.
    #[task(priority = 1, shared = [app, tx])]
    async fn configure(cx: configure::Context, mut receiver: Receiver<'static, Request, QUEUE>) {
        let configure::SharedResources {
            mut app, mut tx, ..
        } = cx.shared;
        while let Ok(request) = receiver.recv().await {
            let result = match request.command {
                Err(decode_error) => {
                    app.lock(|a| a.count_rejected());
                    decode_error
                }
                Ok(Command::SetParam { index, value })
                    if target(index) == Some(Target::Controller) =>
                {
                    let current = app.lock(|a| *a.params());
                    match prepare_change(&current, index, value) {
                        Ok(prepared) => app.lock(|a| {
                            let result = a.swap(prepared);
                            calibration::mirror_application(a);
                            result
                        }),
                        Err(c) => {
                            app.lock(|a| a.count_rejected());
                            c
                        }
                    }
                }
                Ok(command) => app.lock(|a| {
                    let result = a.command(&command);
                    calibration::mirror_application(a);
                    result
                }),
            };
            let mode = app.lock(|a| a.controller().mode());
            crate::log!(
                "command {} index {}: result {}",
                request.command_raw,
                request.index_raw,
                result
            );
            let ack = link::ack_frame(request.command_raw, request.index_raw, result, mode);
            let queued = tx.lock(|t| {
                let ok = t.queue(&ack);
                t.flush();
                ok
            });
            if !queued {
                app.lock(|a| a.count_tx_dropped());
            }
        }
    }
}

/// The QEMU build's final report (semihosting stdout) and exit.
#[cfg(feature = "qemu")]
mod report {
    use cortex_m_semihosting::{debug, hprintln};
    use mil_firmware::application::Application;

    use crate::clock::{self, Calibration, Timings};
    use crate::port::TickInfo;

    /// Prints the counters, the control-path instructions and the stack high-water mark,
    /// then exits QEMU with status 0.
    pub fn qemu_report(
        app: &Application,
        timings: &Timings,
        calibration: &Calibration,
        tick: &TickInfo,
    ) -> ! {
        // Before any formatting: core::fmt's float printing below is deeper than anything
        // the application does, and would otherwise be measured as well.
        let stack_used = clock::stack_used();
        let c = app.counters();
        let s = app.status();
        hprintln!(
            "mil-firmware report: mode {} fault {:#04x} measurements {} steps {} missed {} late {} malformed {} foreign {} comm_timeouts {} rejected {} tx_dropped {}",
            s.mode as u8,
            s.fault,
            c.measurements,
            c.steps,
            c.missed,
            c.late,
            c.malformed,
            c.foreign,
            c.comm_timeouts,
            c.rejected,
            c.tx_dropped
        );
        let c = &timings.core;
        hprintln!(
            "mil-firmware control path (CAN frame received -> demand frame encoded; decode, step, encode): mean {:.1} instructions, min {:.0}, max {:.0}, first {:.0} over {} samples ({:.4} instructions per TIM5 count)",
            calibration.instructions(c.mean()),
            calibration.instructions(f64::from(c.min)),
            calibration.instructions(f64::from(c.max)),
            calibration.instructions(f64::from(c.first)),
            c.count,
            calibration.instructions_per_count
        );
        let p = &timings.path;
        hprintln!(
            "mil-firmware with the QEMU SLCAN transport (last byte of the measurement line read -> demand line queued): mean {:.1} instructions, min {:.0}, max {:.0}",
            calibration.instructions(p.mean()),
            calibration.instructions(f64::from(p.min)),
            calibration.instructions(f64::from(p.max)),
        );
        let [parse, decode, step, encode, format] = timings
            .parts
            .map(|t| t.mean() * calibration.instructions_per_count);
        hprintln!(
            "mil-firmware parts (mean instructions, about 1 of window overhead each): SLCAN line parse {:.1}, decode {:.1}, step (controller + counters) {:.1}, demand encode {:.1}, SLCAN format {:.1}",
            parse,
            decode,
            step,
            encode,
            format
        );
        let (_, region) = clock::stack_region();
        hprintln!(
            "mil-firmware stack: {} bytes used of {} (high-water mark by stack painting, up to this report)",
            stack_used,
            region
        );
        let w = app.watchdog();
        hprintln!(
            "mil-firmware watchdog: tick {:.0} us of QEMU time ({} TIM2 counts, {:.4} TIM2 counts per TIM5 count), N = {}{}",
            tick.period_us,
            tick.timer_counts,
            tick.timer_per_count,
            w.limit,
            if w.is_off() { " (off: tick timer stopped)" } else { "" }
        );
        // The same figures once more as `key=value` pairs on one line, for tools
        // (`mil-can`'s `qemu_budget` example).
        let n = app.counters();
        hprintln!(
            "mil-firmware figures: measurements={} steps={} missed={} late={} malformed={} comm_timeouts={} core_count={} core_min={:.1} core_mean={:.2} core_max={:.1} core_first={:.1} path_min={:.1} path_mean={:.2} path_max={:.1} parse={:.2} decode={:.2} step={:.2} encode={:.2} format={:.2} instructions_per_count={:.6} empty_window={:.3} stack_used={} stack_region={} watchdog_limit={}",
            n.measurements,
            n.steps,
            n.missed,
            n.late,
            n.malformed,
            n.comm_timeouts,
            c.count,
            calibration.instructions(f64::from(c.min)),
            calibration.instructions(c.mean()),
            calibration.instructions(f64::from(c.max)),
            calibration.instructions(f64::from(c.first)),
            calibration.instructions(f64::from(p.min)),
            calibration.instructions(p.mean()),
            calibration.instructions(f64::from(p.max)),
            parse,
            decode,
            step,
            encode,
            format,
            calibration.instructions_per_count,
            calibration.empty_window,
            stack_used,
            region,
            w.limit
        );
        debug::exit(debug::EXIT_SUCCESS);
        loop {
            cortex_m::asm::wfi();
        }
    }
}
