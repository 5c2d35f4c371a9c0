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

#[rtic::app(device = stm32f4xx_hal::pac, peripherals = true, dispatchers = [EXTI0, EXTI1])]
mod app {
    use core::sync::atomic::{AtomicBool, AtomicU32, AtomicU8, Ordering};

    use mil_firmware::application::{Application, Command};
    use mil_firmware::calibration::{self, meas};
    use mil_firmware::config::{XCP_QUEUE, XCP_SECRET};
    use mil_firmware::link::{self, Request, Transport, COUNTER_MODULUS};
    use mil_firmware::params::code;
    use mil_firmware::store::{self, Store};
    use mil_firmware::xcp::{
        response_frame, slave_config, AppAccess, Link, StepPlatform, StepSample, XcpRequest,
    };
    use mil_xcp::{Responses, Slave};
    use rtic_sync::channel::{Receiver, Sender};
    use rtic_sync::make_channel;

    use crate::clock::{self, Timings};
    use crate::port::{self, Port};

    /// Commands waiting for the configuration task.
    const QUEUE: usize = 4;
    /// Step samples waiting for the DAQ task.
    const DAQ_QUEUE: usize = 16;

    /// Whether a DAQ list runs (set by the XCP task after each command): the receive task
    /// copies the measurement block for the DAQ task only then.
    pub(crate) static DAQ_RUNNING: AtomicBool = AtomicBool::new(false);
    /// The link of the last CONNECT: where DAQ packets go (`Link as u8`).
    static DAQ_LINK: AtomicU8 = AtomicU8::new(0);
    /// Step samples the receive task could not queue for the DAQ task (written by the
    /// receive task only).
    static DAQ_SAMPLES_DROPPED: AtomicU32 = AtomicU32::new(0);

    #[shared]
    struct Shared {
        /// The application state (controller, counters, watchdog): kilobytes, built in
        /// place in a static by `init` (not moved through its frame).
        app: App,
        /// The transmit half of the transport.
        tx: port::Tx,
        /// The XCP slave; `None` when the build has no XCP secret.
        xcp: Option<Slave>,
        /// The transmit half of the QEMU build's XCP port (USART2); nothing on the board.
        aux_tx: port::AuxTx,
        /// Where the configuration tasks (XCP and Command frames, one priority: never both
        /// at once) validate and prepare a change: kilobytes, in a static, not on a stack.
        candidate: &'static mut calibration::Candidate,
    }

    #[local]
    struct Local {
        tick: port::Tick,
        /// The stored calibration (flash), for the XCP task's stores.
        store: Store<port::StoreFlash>,
        #[cfg(not(feature = "qemu"))]
        can: Receive,
        #[cfg(not(feature = "qemu"))]
        can2: Receive<port::Rx2>,
        #[cfg(feature = "qemu")]
        uart: Receive,
        #[cfg(feature = "qemu")]
        aux: Aux,
    }

    /// What a receive task owns (the board's CAN2 task: its own FIFO, `R`).
    pub struct Receive<R = port::Rx> {
        rx: R,
        sender: Sender<'static, Request, QUEUE>,
        xcp: Sender<'static, XcpRequest, XCP_QUEUE>,
        daq: Sender<'static, StepSample, DAQ_QUEUE>,
        clock: clock::Clock,
        timings: Timings,
        #[cfg(feature = "qemu")]
        qemu: Qemu,
    }

    /// What the QEMU build's XCP port task owns (nothing on the board).
    pub struct Aux {
        #[cfg(feature = "qemu")]
        rx: port::AuxRx,
        #[cfg(feature = "qemu")]
        xcp: Sender<'static, XcpRequest, XCP_QUEUE>,
        #[cfg(feature = "qemu")]
        lines: mil_frames::slcan::LineBuffer<32>,
        #[cfg(feature = "qemu")]
        session: link::SlcanSession,
    }

    /// The application behind its RTIC lock, for `mil_firmware::xcp::Target`.
    struct Locked<'a, M>(&'a mut M);

    impl<M: rtic::Mutex<T = App>> AppAccess for Locked<'_, M> {
        fn with<R>(&mut self, f: impl FnOnce(&mut Application) -> R) -> R {
            self.0.lock(|a| f(a))
        }
    }

    /// The QEMU build's SLCAN receive state and start-up figures.
    #[cfg(feature = "qemu")]
    pub struct Qemu {
        lines: mil_frames::slcan::LineBuffer<32>,
        session: link::SlcanSession,
        calibration: clock::Calibration,
        tick_info: port::TickInfo,
    }

    /// The shared application: a reference to `init`'s static place.
    type App = &'static mut Application;

    #[init(local = [
        candidate: calibration::Candidate = calibration::Candidate::NEW,
        app: Application = Application::BLANK,
    ])]
    fn init(cx: init::Context) -> (Shared, Local) {
        let candidate = cx.local.candidate;
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
        let Some(app) = new_app(cx.local.app, candidate) else {
            crate::fatal::stop(format_args!("default parameters rejected"));
        };
        // The stored calibration, if one passes its checks; else the build's defaults (the
        // working page then mirrors what runs).
        let Some(mut store) = Store::new(hw.store_flash, port::STORE_RANGE) else {
            crate::fatal::stop(format_args!("calibration store range refused"));
        };
        // The flash answers at once (board: blocking; QEMU: RAM), so the boot completes here.
        let source = boot(app, &mut store, candidate);
        crate::log!("calibration at boot: {}", source as u8);
        let _ = source; // logged on the board only
        let (sender, receiver) = make_channel!(Request, QUEUE);
        if configure::spawn(receiver).is_err() {
            crate::fatal::stop(format_args!("configuration task not spawned"));
        }
        // XCP: only with a build-time secret. Without one the two tasks are not spawned, their
        // channels have no receiver, and XCP frames are counted as foreign.
        let (xcp_sender, xcp_receiver) = make_channel!(XcpRequest, XCP_QUEUE);
        let (daq_sender, daq_receiver) = make_channel!(StepSample, DAQ_QUEUE);
        let slave = XCP_SECRET.and_then(|secret| Slave::new(slave_config(secret)).ok());
        if slave.is_some() {
            if xcp::spawn(xcp_receiver).is_err() || daq::spawn(daq_receiver).is_err() {
                crate::fatal::stop(format_args!("XCP tasks not spawned"));
            }
            crate::log!(
                "XCP on CAN: commands {=u16:#x}, responses {=u16:#x}",
                mil_firmware::config::XCP_COMMAND_ID,
                mil_firmware::config::XCP_RESPONSE_ID
            );
        } else {
            crate::log!("XCP off: no secret in this build");
        }
        crate::log!("mil-firmware up: tyre x1 at 2 kHz, Idle");
        (
            Shared {
                app,
                tx: hw.tx,
                xcp: slave,
                aux_tx: hw.aux_tx,
                candidate,
            },
            Local {
                tick: hw.tick,
                store,
                #[cfg(not(feature = "qemu"))]
                can2: Receive {
                    rx: hw.rx2,
                    sender: sender.clone(),
                    xcp: xcp_sender.clone(),
                    daq: daq_sender.clone(),
                    clock: clock.another(),
                    timings: Timings::default(),
                },
                #[cfg(not(feature = "qemu"))]
                can: Receive {
                    rx: hw.rx,
                    sender,
                    xcp: xcp_sender,
                    daq: daq_sender,
                    clock,
                    timings: Timings::default(),
                },
                #[cfg(feature = "qemu")]
                aux: Aux {
                    rx: hw.aux_rx,
                    xcp: xcp_sender.clone(),
                    lines: mil_frames::slcan::LineBuffer::new(),
                    session: link::SlcanSession::new(),
                },
                #[cfg(feature = "qemu")]
                uart: Receive {
                    rx: hw.rx,
                    sender,
                    xcp: xcp_sender,
                    daq: daq_sender,
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

    /// The application with the build's defaults, written into `init`'s static `place`.
    /// Out of line, as [`boot`]: their frames (a kilobyte parameter set each) follow one
    /// another on the stack instead of adding up in `init`'s.
    #[inline(never)]
    fn new_app(place: App, candidate: &mut calibration::Candidate) -> Option<App> {
        place.init_in(COUNTER_MODULUS, candidate).ok()?;
        Some(place)
    }

    /// The stored calibration into `app` ([`store::boot`], its two halves one after the
    /// other: the load's buffers are off the stack before the page is prepared).
    fn boot(
        app: &mut Application,
        store: &mut Store<port::StoreFlash>,
        candidate: &mut calibration::Candidate,
    ) -> calibration::Source {
        let source = load_stored(store, &mut candidate.words);
        store::boot_loaded(app, source, candidate)
    }

    /// The stored page into `words` ([`Store::load_into`]); a flash that waits counts as
    /// unreadable (the flash answers at once: board blocking, QEMU RAM).
    #[inline(never)]
    fn load_stored(
        store: &mut Store<port::StoreFlash>,
        words: &mut [u32; calibration::SLOTS],
    ) -> calibration::Source {
        store::complete(store.load_into(words)).unwrap_or(calibration::Source::Unreadable)
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

    /// After a step: the step's signals into the measurement block and, while DAQ runs, a
    /// copy of it for the DAQ task (dropped and counted when the DAQ task is behind). Runs in
    /// the receive task after the demand frame was queued.
    fn after_step(
        app: &mut impl rtic::Mutex<T = App>,
        daq: &mut Sender<'static, StepSample, DAQ_QUEUE>,
    ) {
        app.lock(|a| a.record_step());
        if DAQ_RUNNING.load(Ordering::Relaxed) && daq.try_send(StepSample::take()).is_err() {
            DAQ_SAMPLES_DROPPED.fetch_add(1, Ordering::Relaxed);
        }
    }

    /// After a received frame was handled: forward a command to the configuration task (or
    /// refuse it when the queue is full), an XCP command to the XCP task. Runs inside the
    /// receive task.
    fn dispatch(
        handled: link::Handled,
        sender: &mut Sender<'static, Request, QUEUE>,
        xcp: &mut Sender<'static, XcpRequest, XCP_QUEUE>,
        app: &mut impl rtic::Mutex<T = App>,
        tx: &mut impl rtic::Mutex<T = port::Tx>,
    ) {
        match handled {
            link::Handled::Stepped | link::Handled::Done => {}
            link::Handled::Xcp(frame) => forward_xcp(xcp, frame, Link::Bus, app),
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

    /// Queues an XCP command for the XCP task. Without an XCP task (no secret) the frame is
    /// foreign; with a full queue it is dropped and counted as rejected (the master times
    /// out and repeats it).
    fn forward_xcp(
        xcp: &mut Sender<'static, XcpRequest, XCP_QUEUE>,
        frame: mil_frames::RawFrame,
        link: Link,
        app: &mut impl rtic::Mutex<T = App>,
    ) {
        match xcp.try_send(XcpRequest { frame, link }) {
            Ok(()) => {}
            Err(rtic_sync::channel::TrySendError::NoReceiver(_)) => app.lock(|a| a.count_foreign()),
            Err(_) => app.lock(|a| a.count_rejected()),
        }
    }

    /// Board: CAN1 FIFO 0 holds frames (highest priority: the sample clock of the loop).
    #[cfg(not(feature = "qemu"))]
    #[task(binds = CAN1_RX0, priority = 3, shared = [app, tx], local = [can])]
    fn can_rx(cx: can_rx::Context) {
        let can_rx::SharedResources {
            mut app, mut tx, ..
        } = cx.shared;
        receive_frames(cx.local.can, |rx| rx.0.receive(), &mut app, &mut tx);
    }

    /// Board: CAN2 FIFO 0 holds frames (the odd channels of a configuration on both buses;
    /// the same priority as CAN1's: never preempts it, nor it this).
    #[cfg(not(feature = "qemu"))]
    #[task(binds = CAN2_RX0, priority = 3, shared = [app, tx], local = [can2])]
    fn can2_rx(cx: can2_rx::Context) {
        let can2_rx::SharedResources {
            mut app, mut tx, ..
        } = cx.shared;
        receive_frames(cx.local.can2, |rx| rx.0.receive(), &mut app, &mut tx);
    }

    /// The frames one bus's FIFO 0 holds, through the link layer (a sample completed by
    /// the frame steps the controller and queues every channel's demand on its bus).
    #[cfg(not(feature = "qemu"))]
    #[inline(always)]
    fn receive_frames<R>(
        r: &mut Receive<R>,
        mut receive: impl FnMut(&mut R) -> nb::Result<bxcan::Frame, bxcan::OverrunError>,
        app: &mut impl rtic::Mutex<T = App>,
        tx: &mut impl rtic::Mutex<T = port::Tx>,
    ) {
        let Receive {
            rx,
            sender,
            xcp,
            daq,
            clock,
            timings,
            ..
        } = r;
        let mut t0 = clock.now();
        // At most the FIFO's depth per interrupt, plus one (a frame arriving meanwhile).
        for _ in 0..4 {
            match receive(rx) {
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
                        let [.., queued] = stamps;
                        after_step(app, daq);
                        timings.post.record(clock::elapsed(queued, clock.now()));
                    }
                    dispatch(handled, sender, xcp, app, tx);
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
            xcp,
            daq,
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
            if line == link::QEMU_FORCE_HARDFAULT {
                // The test build's deliberate HardFault (an undefined instruction), so that a
                // test can watch the fatal path (`fatal`).
                cortex_m::asm::udf();
            }
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
                        let [.., queued] = stamps;
                        after_step(&mut app, daq);
                        timings.post.record(clock::elapsed(queued, clock.now()));
                    }
                    dispatch(handled, sender, xcp, &mut app, &mut tx);
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
                    // Under the lock (the link is closed, nothing else runs): no copy of the
                    // application (kilobytes) on this task's stack.
                    app.lock(|a| {
                        crate::report::qemu_report(a, timings, &qemu.calibration, &qemu.tick_info)
                    });
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

    /// QEMU: one byte (or more) of SLCAN on USART2, the XCP port. XCP command frames go to
    /// the XCP task (answered on this port); other frames are ignored; `C` is only answered.
    #[cfg(feature = "qemu")]
    #[task(binds = USART2, priority = 2, shared = [app, aux_tx], local = [aux])]
    fn aux_rx(cx: aux_rx::Context) {
        use embedded_hal_nb::serial::Read as _;
        let Aux {
            rx,
            xcp,
            lines,
            session,
        } = cx.local.aux;
        let aux_rx::SharedResources {
            mut app,
            mut aux_tx,
            ..
        } = cx.shared;
        for _ in 0..64 {
            let byte = match rx.0.read() {
                Ok(b) => b,
                Err(nb::Error::WouldBlock) => break,
                Err(nb::Error::Other(_)) => {
                    lines.clear();
                    continue;
                }
            };
            let line = match lines.push(byte) {
                Ok(Some(line)) => line,
                Ok(None) => continue,
                Err(_) => {
                    aux_tx.lock(|t| {
                        t.write(mil_frames::slcan::ERROR);
                        t.flush();
                    });
                    continue;
                }
            };
            match session.on_line(line) {
                link::LineAction::Frame(frame)
                    if frame.id == mil_firmware::config::XCP_COMMAND_ID =>
                {
                    forward_xcp(xcp, frame, Link::Aux, &mut app);
                }
                link::LineAction::Frame(_) | link::LineAction::Other(_) => {}
                link::LineAction::Reply { bytes, len } => {
                    aux_tx.lock(|t| {
                        t.write(bytes.get(..len).unwrap_or(&[]));
                        t.flush();
                    });
                }
                link::LineAction::Closed => aux_tx.lock(|t| {
                    t.write(mil_frames::slcan::OK);
                    t.flush();
                }),
            }
        }
    }

    /// Sends XCP packets on `link`: the board's CAN1 or QEMU's USART1 (`Link::Bus`), QEMU's
    /// USART2 (`Link::Aux`); the number of packets that could not be queued.
    fn send_xcp<'p>(
        link: Link,
        packets: impl Iterator<Item = &'p [u8]>,
        tx: &mut impl rtic::Mutex<T = port::Tx>,
        aux_tx: &mut impl rtic::Mutex<T = port::AuxTx>,
    ) -> u32 {
        match link {
            Link::Bus => tx.lock(|t| {
                let lost = queue_packets(t, packets);
                t.flush();
                lost
            }),
            Link::Aux => aux_tx.lock(|t| {
                let lost = queue_packets(t, packets);
                t.flush();
                lost
            }),
        }
    }

    /// Queues the packets as frames on the XCP response ID; the number not queued.
    fn queue_packets<'p, T: Transport>(t: &mut T, packets: impl Iterator<Item = &'p [u8]>) -> u32 {
        let mut lost = 0;
        for p in packets {
            let queued = response_frame(p).is_some_and(|f| t.queue(&f));
            lost += u32::from(!queued);
        }
        lost
    }

    /// XCP commands, one at a time (priority 1, like `configure`: same-priority tasks never
    /// preempt each other, so a calibration write and a command-frame change never
    /// interleave). Holds the slave for the command (which blocks only the DAQ task and the
    /// watchdog tick, never the control step); a calibration change is validated on a copy
    /// and swapped in under the application's short lock (`mil_firmware::xcp::Target`).
    #[task(priority = 1, shared = [app, tx, xcp, aux_tx, candidate], local = [store])]
    async fn xcp(cx: xcp::Context, mut receiver: Receiver<'static, XcpRequest, XCP_QUEUE>) {
        let store = cx.local.store;
        let xcp::SharedResources {
            mut app,
            mut tx,
            xcp: mut slave,
            mut aux_tx,
            mut candidate,
            ..
        } = cx.shared;
        // Seed entropy: SysTick's count on the board (it runs, see `clock`); QEMU does not
        // start SysTick, so there the slave's seed counter alone varies the seed, which is
        // enough for a test build.
        #[cfg(not(feature = "qemu"))]
        let mut platform = StepPlatform::new(cortex_m::peripheral::SYST::get_current);
        #[cfg(feature = "qemu")]
        let mut platform = StepPlatform::new(|| 0);
        let mut out = Responses::new();
        while let Ok(request) = receiver.recv().await {
            candidate.lock(|candidate| {
                handle_xcp(
                    &request,
                    &mut slave,
                    &mut app,
                    candidate,
                    &mut platform,
                    &mut out,
                );
            });
            send_xcp(request.link, out.iter(), &mut tx, &mut aux_tx);
            // A calibration store the command asked for (SET_REQUEST STORE_CAL_REQ, taken only
            // while the controller does not run): the working page to flash, then the slave
            // clears its pending bit and sends EV_STORE_CAL.
            if slave.lock(|s| s.as_ref().is_some_and(Slave::store_pending)) {
                let result = candidate.lock(|c| {
                    let valid = working_valid(c);
                    store_now(store, &c.words, valid)
                });
                crate::log!(
                    "calibration store: {}",
                    result.map_or_else(|e| e as u8, |()| 0)
                );
                slave.lock(|s| {
                    if let Some(s) = s.as_mut() {
                        s.store_finished(result.is_ok(), &mut out);
                    }
                });
                send_xcp(request.link, out.iter(), &mut tx, &mut aux_tx);
            }
        }
    }

    /// Stores `words`, a copy of the working page (`valid`: it passed [`working_valid`]),
    /// to its end here ([`store::store_words`]): the flash answers at once (board:
    /// blocking; QEMU: RAM), and the store's kilobytes of buffers then live on the stack for
    /// the store only, not in the XCP task's future (a static, for good). A flash that
    /// waits counts as a flash error.
    #[inline(never)]
    fn store_now(
        store: &mut Store<port::StoreFlash>,
        words: &[u32; calibration::SLOTS],
        valid: bool,
    ) -> Result<(), store::StoreError> {
        store::complete(store::store_words(store, words, |_| valid))
            .unwrap_or(Err(store::StoreError::Flash))
    }

    /// The working page copied into the candidate and validated there as a whole (before
    /// the store, whose buffers then do not share the stack with the preparation's).
    #[inline(never)]
    fn working_valid(c: &mut calibration::Candidate) -> bool {
        calibration::load_page(calibration::Page::Working, &mut c.words);
        calibration::decode_page_into(&c.words, &mut c.prepared).is_ok()
    }

    /// One XCP command through the slave.
    fn handle_xcp<P: mil_xcp::Platform>(
        request: &XcpRequest,
        slave: &mut impl rtic::Mutex<T = Option<Slave>>,
        app: &mut impl rtic::Mutex<T = App>,
        candidate: &mut calibration::Candidate,
        platform: &mut P,
        out: &mut Responses,
    ) {
        let cto = request.frame.payload();
        // Event 0's cycle as the controller runs now (the rate changes only while Idle).
        let period = app.lock(|a| mil_firmware::xcp::event_period_us(a.sample_rate_hz()));
        slave.lock(|s| {
            let Some(s) = s.as_mut() else {
                return;
            };
            s.set_event_period_us(period);
            let mut target =
                mil_firmware::xcp::Target::with_page(Locked(app), s.ecu_page(), candidate);
            s.handle(cto, &mut target, platform, out);
            DAQ_RUNNING.store(s.daq_running(), Ordering::Relaxed);
        });
        if cto.first() == Some(&mil_xcp::protocol::cmd::CONNECT) {
            DAQ_LINK.store(request.link as u8, Ordering::Relaxed);
        }
    }

    /// The DTO packets of one step sample (at most one per ODT).
    struct Packets {
        data: [[u8; mil_xcp::MAX_DTO]; mil_xcp::MAX_ODTS],
        lens: [u8; mil_xcp::MAX_ODTS],
        n: usize,
    }

    impl Packets {
        /// Samples the running DAQ lists on `sample` (event 0, the control step), under the
        /// slave's lock; the packets are sent after it.
        fn sample(sample: &StepSample, slave: &mut impl rtic::Mutex<T = Option<Slave>>) -> Self {
            let mut p = Self {
                data: [[0; mil_xcp::MAX_DTO]; mil_xcp::MAX_ODTS],
                lens: [0; mil_xcp::MAX_ODTS],
                n: 0,
            };
            slave.lock(|s| {
                if let Some(s) = s.as_mut() {
                    s.sample_daq(0, sample.time_us, sample, |dto| {
                        let slot = (p.data.get_mut(p.n), p.lens.get_mut(p.n));
                        if let (Some(d), Some(l)) = slot {
                            if let Some(dst) = d.get_mut(..dto.len()) {
                                dst.copy_from_slice(dto);
                                *l = dto.len() as u8;
                                p.n += 1;
                            }
                        }
                    });
                }
            });
            p
        }

        fn iter(&self) -> impl Iterator<Item = &[u8]> {
            self.data
                .iter()
                .zip(self.lens.iter())
                .take(self.n)
                .map(|(d, &l)| d.get(..usize::from(l)).unwrap_or(&[]))
        }
    }

    /// Where DAQ packets go: the link of the last CONNECT.
    fn daq_link() -> Link {
        if DAQ_LINK.load(Ordering::Relaxed) == Link::Aux as u8 {
            Link::Aux
        } else {
            Link::Bus
        }
    }

    /// Publishes the DAQ losses (packets not queued + samples not queued) in the
    /// measurement block.
    fn store_daq_dropped(lost_packets: u32) {
        calibration::store_u32(
            meas::DAQ_DROPPED,
            lost_packets.wrapping_add(DAQ_SAMPLES_DROPPED.load(Ordering::Relaxed)),
        );
    }

    /// DAQ: samples the running lists for each step sample the receive task queued, and
    /// sends their packets to the master (priority 2: below the control step, above the
    /// calibration path). Packets that cannot be queued are dropped and counted.
    #[task(priority = 2, shared = [xcp, tx, aux_tx])]
    async fn daq(cx: daq::Context, mut receiver: Receiver<'static, StepSample, DAQ_QUEUE>) {
        let daq::SharedResources {
            xcp: mut slave,
            mut tx,
            mut aux_tx,
            ..
        } = cx.shared;
        let mut lost = 0u32;
        while let Ok(sample) = receiver.recv().await {
            let packets = Packets::sample(&sample, &mut slave);
            lost = lost.wrapping_add(send_xcp(daq_link(), packets.iter(), &mut tx, &mut aux_tx));
            store_daq_dropped(lost);
        }
    }

    /// Command frames, one at a time, between control steps (lowest priority, like `xcp`:
    /// the two never interleave). Operating commands go to the controller; parameter and
    /// setting writes go through the one calibration authority
    /// (`mil_firmware::xcp::Target::command_frame`): a write of one slot of the working
    /// page, validated as a whole page outside any lock and installed under a short one,
    /// refused while the controller runs the reference page, and, unless safe without it,
    /// only while an XCP session holds the calibration unlocked (seed & key).
    #[task(priority = 1, shared = [app, tx, xcp, candidate])]
    async fn configure(cx: configure::Context, mut receiver: Receiver<'static, Request, QUEUE>) {
        let configure::SharedResources {
            mut app,
            mut tx,
            xcp: mut slave,
            mut candidate,
            ..
        } = cx.shared;
        while let Ok(request) = receiver.recv().await {
            let result = match request.command {
                Err(decode_error) => {
                    app.lock(|a| a.count_rejected());
                    decode_error
                }
                Ok(command) => {
                    // No await until the change is made: the XCP task (same priority) cannot
                    // switch the page or lock the session in between.
                    let (page, unlocked) = slave.lock(|s| {
                        s.as_ref().map_or((mil_xcp::Page::Working, false), |s| {
                            (
                                s.ecu_page(),
                                s.unlocked(mil_xcp::protocol::resource::CAL_PAG),
                            )
                        })
                    });
                    candidate.lock(|candidate| {
                        mil_firmware::xcp::Target::with_page(Locked(&mut app), page, candidate)
                            .command_frame(&command, unlocked)
                    })
                }
            };
            if matches!(
                request.command,
                Ok(Command::SetParam { .. } | Command::SetWatchdog { .. })
            ) || (request.command.is_err() && matches!(request.command_raw, 4 | 5))
            {
                calibration::note_change(result);
            }
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
    use core::sync::atomic::Ordering;

    use cortex_m_semihosting::{debug, hprintln};
    use mil_firmware::application::Application;

    use crate::app::DAQ_RUNNING;
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
        let q = &timings.post;
        hprintln!(
            "mil-firmware after the demand (measurement block stored{}): mean {:.1} instructions, min {:.0}, max {:.0}",
            if DAQ_RUNNING.load(Ordering::Relaxed) { ", DAQ sample queued" } else { "; no DAQ running" },
            calibration.instructions(q.mean()),
            calibration.instructions(f64::from(q.min)),
            calibration.instructions(f64::from(q.max)),
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
            "mil-firmware figures: measurements={} steps={} missed={} late={} malformed={} comm_timeouts={} core_count={} core_min={:.1} core_mean={:.2} core_max={:.1} core_first={:.1} path_min={:.1} path_mean={:.2} path_max={:.1} parse={:.2} decode={:.2} step={:.2} encode={:.2} format={:.2} post_min={:.1} post_mean={:.2} post_max={:.1} daq_running={} daq_dropped={} instructions_per_count={:.6} empty_window={:.3} stack_used={} stack_region={} watchdog_limit={}",
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
            calibration.instructions(f64::from(q.min)),
            calibration.instructions(q.mean()),
            calibration.instructions(f64::from(q.max)),
            u8::from(DAQ_RUNNING.load(Ordering::Relaxed)),
            mil_firmware::calibration::measurement_words()
                .get(mil_firmware::calibration::meas::DAQ_DROPPED)
                .copied()
                .unwrap_or(0),
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
