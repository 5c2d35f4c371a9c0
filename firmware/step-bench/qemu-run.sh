#!/bin/sh
# Cargo runner for `thumbv7em-none-eabihf` (see `.cargo/config.toml`): runs the ELF given as
# the last argument in QEMU's netduinoplus2 (STM32F405) with semihosting, deterministically,
# and under `timeout` so that a hung guest (e.g. a fault loop) cannot hang the build. The
# guest's semihosting exit status is QEMU's (124 when the time limit struck).
#
# `-icount shift=S,align=off,sleep=off`: virtual time advances by 2^S ns per executed
# instruction and by nothing else, so timer readings are the same on every run and host.
# QEMU clocks SysTick at the machine's 168 MHz in virtual time, so one instruction is
# 0.168 * 2^S SysTick counts: S = 3 gives 1.344 counts per instruction (single calls of a
# few hundred instructions resolve to one instruction) and a guest speed of 125 M
# instructions/s, close to the real 168 MHz Cortex-M4. S = 0 (1 instruction = 0.168 counts)
# works too, with about 6 instructions of resolution per timing window.
#
# Environment: QEMU_ICOUNT_SHIFT (default 3), QEMU_TIMEOUT in seconds (default 300).
set -eu
exec timeout --foreground --kill-after=10 "${QEMU_TIMEOUT:-300}" \
    qemu-system-arm -machine netduinoplus2 -nographic \
    -semihosting-config enable=on,target=native \
    -icount "shift=${QEMU_ICOUNT_SHIFT:-3},align=off,sleep=off" \
    -kernel "$@"
