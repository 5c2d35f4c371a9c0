//! A board without hardware, for tests and demonstrations: the board's own XCP slave
//! (`mil_xcp::Slave`) over any target ([`mil_xcp::Memory`] + [`mil_xcp::Calibration`]), e.g.
//! `mil_xcp::mock::MockEcu`.
//!
//! - [`Loopback`]: an in-process [`Transport`]. Each frame sent on the command ID goes to the
//!   slave, its responses come back on the response ID; frames on other IDs reach nothing.
//!   While DAQ runs, a receive with nothing queued runs control steps until one samples
//!   something: the step hook may change the target's measurements, then the slave samples
//!   event 0 with the step's timestamp (the clock advances by the event period each step).
//! - [`SlcanTcpBoard`]: the same slave behind SLCAN over TCP on 127.0.0.1, as QEMU exposes
//!   the board's serial port: the `mil` subcommands run against it end to end. It answers
//!   the SLCAN handshake with OK and runs the control steps in wall time (one per event
//!   period, several at once where the loop was late).

use std::collections::VecDeque;
use std::io::{self, Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use mil_can::Transport;
use mil_frames::slcan::{self, LineBuffer, SlcanLine};
use mil_frames::RawFrame;
use mil_xcp::{Calibration, Memory, Platform, Responses, Slave};

use crate::master::CanIds;

/// Called once per control step with the target and the step's timestamp (µs).
pub type StepHook<M> = Box<dyn FnMut(&mut M, u32) + Send>;

/// The slave, its target and its clock: what both loopbacks share.
pub struct SimBoard<M, P> {
    /// The XCP slave.
    pub slave: Slave,
    /// The slave's target (memory and calibration).
    pub target: M,
    /// Seed entropy and DAQ clock of the slave.
    pub platform: P,
    /// The CAN IDs the slave listens and answers on.
    pub ids: CanIds,
    /// The DAQ clock (µs), advanced by the event period each step.
    pub time_us: u32,
    /// Called once per step before sampling.
    pub step_hook: Option<StepHook<M>>,
    /// Calibration stores done (SET_REQUEST STORE_CAL_REQ).
    pub stores: u32,
    responses: Responses,
}

impl<M: Memory + Calibration, P: Platform> SimBoard<M, P> {
    /// A board with `slave` over `target`.
    pub fn new(slave: Slave, target: M, platform: P, ids: CanIds) -> Self {
        Self {
            slave,
            target,
            platform,
            ids,
            time_us: 0,
            step_hook: None,
            stores: 0,
            responses: Responses::new(),
        }
    }

    /// The frames answering `frame` (none for another ID or an unanswered command).
    pub fn handle(&mut self, frame: &RawFrame, mut out: impl FnMut(RawFrame)) {
        if frame.id != self.ids.command {
            return;
        }
        self.slave.handle(
            frame.payload(),
            &mut self.target,
            &mut self.platform,
            &mut self.responses,
        );
        for r in self.responses.iter() {
            if let Some(f) = RawFrame::from_parts(self.ids.response, r) {
                out(f);
            }
        }
        // A calibration store the command asked for: done at once (a simulated board has no
        // flash to wait for), which sends EV_STORE_CAL.
        if self.slave.store_pending() {
            self.stores += 1;
            self.slave.store_finished(true, &mut self.responses);
            for r in self.responses.iter() {
                if let Some(f) = RawFrame::from_parts(self.ids.response, r) {
                    out(f);
                }
            }
        }
    }

    /// One control step: the hook, then the DTOs of event 0 with the step's timestamp.
    pub fn step(&mut self, mut out: impl FnMut(RawFrame)) {
        let period = self.slave.config().event_period_us.max(1);
        self.time_us = self.time_us.wrapping_add(period);
        if let Some(hook) = self.step_hook.as_mut() {
            hook(&mut self.target, self.time_us);
        }
        let id = self.ids.response;
        self.slave.sample_daq(0, self.time_us, &self.target, |dto| {
            if let Some(f) = RawFrame::from_parts(id, dto) {
                out(f);
            }
        });
    }
}

/// An in-process transport to a [`SimBoard`] (see the module documentation).
pub struct Loopback<M, P> {
    /// The simulated board.
    pub board: SimBoard<M, P>,
    queue: VecDeque<RawFrame>,
    /// Every frame the master sent, in order.
    pub sent: Vec<RawFrame>,
    /// Pad every response to 8 bytes (as a CAN driver with a fixed DLC may).
    pub pad_responses: bool,
    /// Put a frame on another ID (a MiL status frame) before every response.
    pub foreign_traffic: bool,
    /// Drop every DTO whose running count (from 1) is a multiple of this (a lossy bus).
    pub drop_every_dto: Option<u64>,
    dto_count: u64,
}

impl<M: Memory + Calibration, P: Platform> Loopback<M, P> {
    /// A loopback to `board`.
    pub fn new(board: SimBoard<M, P>) -> Self {
        Self {
            board,
            queue: VecDeque::new(),
            sent: Vec::new(),
            pad_responses: false,
            foreign_traffic: false,
            drop_every_dto: None,
            dto_count: 0,
        }
    }

    /// DTOs the board produced so far (dropped ones included).
    pub fn dtos(&self) -> u64 {
        self.dto_count
    }

    fn push(&mut self, mut f: RawFrame) {
        if self.pad_responses {
            f.len = 8;
        }
        self.queue.push_back(f);
    }
}

impl<M: Memory + Calibration, P: Platform> Transport for Loopback<M, P> {
    fn send(&mut self, frame: &RawFrame) -> io::Result<()> {
        self.sent.push(*frame);
        let mut out = Vec::new();
        self.board.handle(frame, |f| out.push(f));
        for f in out {
            if self.foreign_traffic {
                self.queue
                    .push_back(RawFrame::from_parts(0x101, &[1, 2, 3, 4, 5, 6, 7, 8]).unwrap_or(f));
            }
            self.push(f);
        }
        Ok(())
    }

    fn recv(&mut self, timeout: Duration) -> io::Result<Option<RawFrame>> {
        // Control steps until one samples something (a prescaler skips steps), at most 2^16.
        let mut steps = 0;
        while self.queue.is_empty() && self.board.slave.daq_running() && steps < 1 << 16 {
            steps += 1;
            let mut out = Vec::new();
            self.board.step(|f| out.push(f));
            for f in out {
                self.dto_count += 1;
                if self
                    .drop_every_dto
                    .is_some_and(|n| n > 0 && self.dto_count % n == 0)
                {
                    continue;
                }
                self.queue.push_back(f);
            }
        }
        match self.queue.pop_front() {
            Some(f) => Ok(Some(f)),
            None => {
                // A silent bus: the full wait, as a real transport.
                std::thread::sleep(timeout);
                Ok(None)
            }
        }
    }
}

/// A [`SimBoard`] behind SLCAN over TCP on 127.0.0.1 (see the module documentation). The
/// server thread serves one connection after another and ends when the handle is dropped.
pub struct SlcanTcpBoard<M, P> {
    addr: SocketAddr,
    stop: Arc<AtomicBool>,
    board: Arc<Mutex<SimBoard<M, P>>>,
    thread: Option<JoinHandle<()>>,
}

impl<M, P> SlcanTcpBoard<M, P>
where
    M: Memory + Calibration + Send + 'static,
    P: Platform + Send + 'static,
{
    /// Starts serving `board` on a free port of 127.0.0.1.
    ///
    /// # Errors
    /// The socket could not be bound.
    pub fn start(board: SimBoard<M, P>) -> io::Result<Self> {
        let listener = TcpListener::bind("127.0.0.1:0")?;
        listener.set_nonblocking(true)?;
        let addr = listener.local_addr()?;
        let stop = Arc::new(AtomicBool::new(false));
        let board = Arc::new(Mutex::new(board));
        let thread = {
            let stop = Arc::clone(&stop);
            let board = Arc::clone(&board);
            std::thread::spawn(move || {
                while !stop.load(Ordering::Relaxed) {
                    match listener.accept() {
                        Ok((stream, _)) => {
                            let _ = serve(stream, &board, &stop);
                        }
                        Err(_) => std::thread::sleep(Duration::from_millis(5)),
                    }
                }
            })
        };
        Ok(Self {
            addr,
            stop,
            board,
            thread: Some(thread),
        })
    }

    /// The address to connect to (`--port tcp:127.0.0.1:PORT`).
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }

    /// Runs `f` on the board (e.g. to inspect the target after a command-line run).
    pub fn with_board<R>(&self, f: impl FnOnce(&mut SimBoard<M, P>) -> R) -> R {
        let mut guard = self
            .board
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        f(&mut guard)
    }
}

impl<M, P> Drop for SlcanTcpBoard<M, P> {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// Serves one SLCAN connection until the peer closes it or `stop` is set.
fn serve<M: Memory + Calibration, P: Platform>(
    mut stream: TcpStream,
    board: &Mutex<SimBoard<M, P>>,
    stop: &AtomicBool,
) -> io::Result<()> {
    stream.set_nodelay(true)?;
    stream.set_read_timeout(Some(Duration::from_millis(1)))?;
    let mut lines = LineBuffer::<{ slcan::MAX_LINE + 1 }>::new();
    let mut open = false;
    let start = Instant::now();
    let mut done: u128 = 0;
    let mut chunk = [0u8; 512];
    let lock = || {
        board
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
    };
    while !stop.load(Ordering::Relaxed) {
        let mut out: Vec<u8> = Vec::new();
        match stream.read(&mut chunk) {
            Ok(0) => return Ok(()),
            Ok(n) => {
                for &byte in &chunk[..n] {
                    let Ok(Some(line)) = lines.push(byte) else {
                        continue;
                    };
                    match slcan::parse_line(line) {
                        Ok(SlcanLine::Frame(f)) if open => {
                            if let Ok(raw) = RawFrame::try_from_frame(&f) {
                                lock().handle(&raw, |r| append_frame(&mut out, &r));
                            }
                        }
                        Ok(SlcanLine::Open) => {
                            open = true;
                            out.extend_from_slice(slcan::OK);
                        }
                        Ok(SlcanLine::Close) => {
                            open = false;
                            out.extend_from_slice(slcan::OK);
                        }
                        Ok(SlcanLine::Frame(_)) => out.extend_from_slice(slcan::ERROR),
                        Ok(_) => out.extend_from_slice(slcan::OK),
                        Err(_) => out.extend_from_slice(slcan::ERROR),
                    }
                }
            }
            Err(e)
                if matches!(
                    e.kind(),
                    io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut
                ) => {}
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
        // Board time follows wall time: the steps due since the last pass (the socket's
        // read timeout is coarse, a few ms), at most 100 at once.
        {
            let mut b = lock();
            let period = u128::from(b.slave.config().event_period_us.max(1));
            let due = start.elapsed().as_micros() / period;
            let n = due.saturating_sub(done).min(100);
            done = due;
            if b.slave.daq_running() {
                for _ in 0..n {
                    b.step(|r| append_frame(&mut out, &r));
                }
            }
        }
        if !out.is_empty() {
            stream.write_all(&out)?;
        }
    }
    Ok(())
}

fn append_frame(out: &mut Vec<u8>, frame: &RawFrame) {
    let mut line = [0u8; slcan::MAX_LINE + 1];
    if let Ok(n) = slcan::format_frame(frame, &mut line) {
        out.extend_from_slice(&line[..n]);
    }
}
