//! The panic and HardFault paths: leave the demand output in the safe state.
//!
//! Both builds: interrupts off (no task runs again), then one Demand frame per running
//! channel with its safe demand (`calibration::SAFE_DEMAND`, default 1667.7 N; mode Fault,
//! fault flag set) and one Status frame saying why (mode
//! Fault, fault bit 5 `FIRMWARE_STOPPED` with the bits latched before) are sent best effort
//! straight through the peripheral registers, bypassing the drivers the tasks own.
//! - Board: the frame goes into a free bxCAN mailbox (a pending frame is aborted if all three
//!   are busy) and the CPU halts, logging the cause over defmt-rtt first. No demand frames
//!   follow, so the servo controller's own watchdog (missing demands) takes the actuator to
//!   its safe state; the last demand it got is the safe one. Only a reset (or power cycle)
//!   restarts the board, Idle with the demand at the safe value.
//! - QEMU: the frame is written as an SLCAN line on USART1, the cause is printed on
//!   semihosting stderr (`mil-firmware FAILED: ...`) and QEMU exits with status 1.

use core::panic::PanicInfo;

use cortex_m_rt::{exception, ExceptionFrame};
use mil_firmware::calibration::running_channels;
use mil_firmware::link::{fatal_status_frame, safe_demand_frame};

/// Sends the safe demand, reports `cause` and stops for good.
pub fn stop(cause: core::fmt::Arguments) -> ! {
    cortex_m::interrupt::disable();
    for ch in 0..running_channels().clamp(1, mil_firmware::config::CHANNELS) {
        send_frame(&safe_demand_frame(ch, 0));
    }
    send_frame(&fatal_status_frame());
    report(cause);
    halt()
}

#[cfg(not(feature = "qemu"))]
fn report(cause: core::fmt::Arguments) {
    defmt::error!("mil-firmware stopped: {}", defmt::Display2Format(&cause));
}

#[cfg(feature = "qemu")]
fn report(cause: core::fmt::Arguments) {
    use core::fmt::Write as _;
    if let Ok(mut stderr) = cortex_m_semihosting::hio::hstderr() {
        let _ = writeln!(stderr, "mil-firmware FAILED: {cause}");
    }
}

#[cfg(not(feature = "qemu"))]
fn halt() -> ! {
    loop {
        cortex_m::asm::wfi();
    }
}

#[cfg(feature = "qemu")]
fn halt() -> ! {
    cortex_m_semihosting::debug::exit(cortex_m_semihosting::debug::EXIT_FAILURE);
    loop {
        cortex_m::asm::wfi();
    }
}

/// Board: one frame into a bxCAN transmit mailbox, waiting a bounded time for it to leave.
// `unsafe` (two kinds, both confined to this function): `CAN1::steal` takes the registers
// away from the driver that owns them, which is sound because interrupts are disabled and
// this path never returns, so no other code touches CAN1 again (no concurrent access); and
// the raw field writes (`bits`) the PAC marks unsafe, which are sound because every value is
// in its field's range: the DLC is at most 8 (`min(8)`), the ID an 11-bit standard ID from
// `mil_frames` (masked to 0x7FF), the data are bytes.
#[cfg(not(feature = "qemu"))]
#[allow(unsafe_code)]
fn send_frame(frame: &mil_frames::RawFrame) {
    let can = unsafe { stm32f4xx_hal::pac::CAN1::steal() };
    let free = |can: &stm32f4xx_hal::pac::CAN1| {
        let tsr = can.tsr().read();
        [
            tsr.tme0().bit_is_set(),
            tsr.tme1().bit_is_set(),
            tsr.tme2().bit_is_set(),
        ]
        .iter()
        .position(|empty| *empty)
    };
    let mailbox = match free(&can) {
        Some(m) => m,
        None => {
            // All three busy: abort them (pending demands are superseded by the safe one).
            can.tsr()
                .write(|w| w.abrq0().set_bit().abrq1().set_bit().abrq2().set_bit());
            let mut found = None;
            for _ in 0..100_000 {
                found = free(&can);
                if found.is_some() {
                    break;
                }
            }
            match found {
                Some(m) => m,
                None => return,
            }
        }
    };
    let [d0, d1, d2, d3, d4, d5, d6, d7] = frame.data;
    let low = u32::from_le_bytes([d0, d1, d2, d3]);
    let high = u32::from_le_bytes([d4, d5, d6, d7]);
    let tx = can.tx(mailbox);
    tx.tdtr()
        .write(|w| unsafe { w.dlc().bits(frame.len.min(8)) });
    tx.tdlr().write(|w| unsafe { w.bits(low) });
    tx.tdhr().write(|w| unsafe { w.bits(high) });
    tx.tir().write(|w| unsafe {
        w.stid()
            .bits(frame.id & 0x7FF)
            .ide()
            .standard()
            .rtr()
            .data()
            .txrq()
            .set_bit()
    });
    // Up to a few ms at 168 MHz for the frame to win arbitration and leave.
    for _ in 0..300_000 {
        if can.tsr().read().tme(mailbox as u8).bit_is_set() {
            break;
        }
    }
}

/// QEMU: the frame as one SLCAN line on USART1, polled writes.
// `unsafe` (confined to this function): `USART1::steal` takes the registers away from the
// driver that owns them, sound because interrupts are disabled and this path never returns
// (no other code touches USART1 again); the raw data-register write (`bits`) is sound for
// any byte value (the field is 9 bits wide).
#[cfg(feature = "qemu")]
#[allow(unsafe_code)]
fn send_frame(frame: &mil_frames::RawFrame) {
    let usart = unsafe { stm32f4xx_hal::pac::USART1::steal() };
    let mut line = [0u8; 32];
    let n = mil_firmware::link::slcan_line(frame, &mut line).unwrap_or(0);
    for &b in line.get(..n).unwrap_or(&[]) {
        let mut spins = 0u32;
        while usart.sr().read().txe().bit_is_clear() && spins < 1_000_000 {
            spins += 1;
        }
        usart.dr().write(|w| unsafe { w.dr().bits(u16::from(b)) });
    }
}

#[panic_handler]
fn panic(info: &PanicInfo) -> ! {
    stop(format_args!("panic: {info}"))
}

// `unsafe`: cortex-m-rt only accepts the HardFault handler as an `unsafe fn` (running it is
// only sound as the exception handler). It does nothing unsafe itself beyond `stop`'s
// documented register access.
#[allow(unsafe_code)]
#[exception]
unsafe fn HardFault(frame: &ExceptionFrame) -> ! {
    stop(format_args!("HardFault at pc {:#010x}", frame.pc()))
}
