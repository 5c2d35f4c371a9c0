//! The mock board the `mil` XCP tests talk to: `mil-xcp`'s slave over a mock ECU behind
//! SLCAN over TCP (as QEMU exposes the board), and the A2L of the firmware's tables at the
//! mock's memory regions.

use std::path::{Path, PathBuf};

use mil_a2l::{Block, Layout};
use mil_xcp::mock::{self, MockEcu, MockPlatform};
use mil_xcp::Slave;
use mil_xcp_master::loopback::{SimBoard, SlcanTcpBoard};
use mil_xcp_master::CanIds;

/// The board behind SLCAN over TCP.
pub type Board = SlcanTcpBoard<MockEcu, MockPlatform>;

/// The A2L of the firmware's tables at the mock's regions, written into `dir`.
pub fn a2l_fixture(dir: &Path) -> PathBuf {
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
    let path = dir.join("mil.a2l");
    std::fs::write(&path, mil_a2l::generate(&layout, "test")).unwrap();
    path
}

/// Each step k writes position = 1e-3·k (m) and mode = k into the measurement block.
pub fn board() -> Board {
    let mut sim = SimBoard::new(
        Slave::new(mock::config()).unwrap(),
        MockEcu::new(),
        MockPlatform::default(),
        CanIds::default(),
    );
    sim.step_hook = Some(Box::new(|ecu: &mut MockEcu, time_us: u32| {
        let k = time_us / mock::EVENT_PERIOD_US;
        let m = ecu.measurement_mut();
        m[0..4].copy_from_slice(&(1e-3 * k as f32).to_le_bytes());
        m[12..16].copy_from_slice(&k.to_le_bytes());
    }));
    SlcanTcpBoard::start(sim).unwrap()
}
