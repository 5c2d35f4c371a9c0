//! A simulated board to try `mil param`, `mil daq record` and `mil filter upload` without
//! QEMU or hardware: the board's XCP slave over `mil_xcp::mock::MockEcu` behind SLCAN over
//! TCP on 127.0.0.1, and the A2L file for the mock's memory layout (written by `mil_a2l`).
//!
//! ```sh
//! cargo run -p mil-xcp-master --example sim_board -- [A2L_OUT] [SECONDS]
//! ```
//!
//! It prints the `--port` to use and runs for SECONDS (default 600). The mock's secret is
//! the public test secret of `mil_xcp::mock` (for this simulation only). Each control step
//! (500 µs, in wall time) writes `position` = 1 mm · sin(2π · 2 Hz ·
//! t), `road` = 0.5 · position, `demand` = 2.5e5 N/m · position and counts `steps`.

use std::time::Duration;

use mil_a2l::{Block, Layout};
use mil_xcp::mock::{self, MockEcu, MockPlatform, TEST_SECRET};
use mil_xcp::Slave;
use mil_xcp_master::loopback::{SimBoard, SlcanTcpBoard};
use mil_xcp_master::CanIds;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let a2l_out = args
        .next()
        .unwrap_or_else(|| "out/sim-board/mil.a2l".to_string());
    let seconds: u64 = args.next().map_or(Ok(600), |s| s.parse())?;
    let layout = Layout {
        calibration: Block {
            address: mock::CAL_START,
            size: mil_firmware::calibration::PAGE_BYTES as u32,
        },
        measurement: Block {
            address: mock::MEAS_START,
            size: mil_firmware::calibration::MEASUREMENT_BYTES as u32,
        },
    };
    let path = std::path::Path::new(&a2l_out);
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)?;
    }
    std::fs::write(path, mil_a2l::generate(&layout, "simulated board"))?;
    let mut sim = SimBoard::new(
        Slave::new(mock::config()).map_err(|e| format!("{e:?}"))?,
        MockEcu::new(),
        MockPlatform::default(),
        CanIds::default(),
    );
    sim.step_hook = Some(Box::new(|ecu: &mut MockEcu, time_us: u32| {
        let t = f64::from(time_us) * 1e-6;
        let position = 1e-3 * (2.0 * std::f64::consts::PI * 2.0 * t).sin();
        let m = ecu.measurement_mut();
        m[0..4].copy_from_slice(&(position as f32).to_le_bytes());
        m[4..8].copy_from_slice(&((0.5 * position) as f32).to_le_bytes());
        m[8..12].copy_from_slice(&((2.5e5 * position) as f32).to_le_bytes());
        m[12..16].copy_from_slice(&1u32.to_le_bytes());
        m[20..24].copy_from_slice(&(time_us / mock::EVENT_PERIOD_US).to_le_bytes());
    }));
    let board = SlcanTcpBoard::start(sim)?;
    println!(
        "simulated board: --port tcp:{} --a2l {a2l_out}",
        board.addr()
    );
    println!(
        "secret (the mock's public test secret): export MIL_XCP_SECRET={}",
        String::from_utf8_lossy(TEST_SECRET)
    );
    std::thread::sleep(Duration::from_secs(seconds));
    Ok(())
}
