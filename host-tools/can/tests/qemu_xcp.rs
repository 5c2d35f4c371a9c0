//! XCP on the MiL link against the firmware in QEMU (its QEMU build, on USART1: the same
//! bus as the lockstep, as on the board's CAN1), and the A2L file of that very ELF.
//!
//! - The A2L generated from the ELF parses strictly (`a2lfile`) and every characteristic and
//!   measurement sits at its symbol's address + 4 × slot, with the firmware table's limits;
//!   uploads at those addresses read the running values.
//! - A write reaches the running model at a step boundary: the demand changes by exactly
//!   what the new tyre stiffness gives, from the first step after the positive response.
//! - Refused writes (NaN, out of range, inconsistent, outside the page) answer their XCP
//!   error and change neither the page nor the demand; a wrong key is refused and ends the
//!   session.
//! - A DAQ list on the control-step event delivers one sample per step, in step with the
//!   demand frames.
//!
//! Needs the QEMU build (`cargo build -p mil-firmware --target thumbv7em-none-eabihf
//! --release --features qemu`, whose XCP secret is the public test secret) and QEMU.

use std::path::PathBuf;
use std::time::{Duration, Instant};

use mil_a2l::{generate, layout, symbols, MEASUREMENT_SYMBOL, WORKING_SYMBOL};
use mil_can::{
    find_firmware_elf, Qemu, QemuOptions, SlcanTcp, Transport, FIRMWARE_BUILD_COMMAND, LAYOUT,
};
use mil_firmware::calibration::{item, reference_words, MEAS_ITEMS, SLOTS};
use mil_firmware::config::{TYRE, XCP_COMMAND_ID, XCP_RESPONSE_ID};
use mil_frames::{
    decode, encode_command, encode_measurement, Command, CommandKind, Message, RawFrame,
};
use mil_xcp::compute_key;
use mil_xcp::mock::TEST_SECRET;

const TIMEOUT: Duration = Duration::from_secs(5);

fn elf() -> PathBuf {
    find_firmware_elf().unwrap_or_else(|| {
        panic!("firmware ELF not found: build it with `{FIRMWARE_BUILD_COMMAND}`")
    })
}

/// The board over SLCAN: lockstep measurements and raw XCP commands on one link.
struct Rig {
    link: SlcanTcp,
    counter: u8,
    /// Demand frames seen (counter, N).
    demands: Vec<(u8, f32)>,
    /// XCP packets seen while waiting for demands (DAQ DTOs).
    dtos: Vec<Vec<u8>>,
}

impl Rig {
    /// One measurement; returns its demand (N).
    fn step(&mut self, position_m: f32, road_m: f32) -> f32 {
        let counter = self.counter;
        self.counter = self.counter.wrapping_add(1);
        let m = mil_frames::Measurement {
            channel: 0,
            position_m,
            road_m,
            counter,
        };
        self.link
            .send(&encode_measurement(&LAYOUT, &m).unwrap())
            .unwrap();
        loop {
            let f = self
                .link
                .recv(TIMEOUT)
                .unwrap()
                .expect("no demand within 5 s");
            if f.id == XCP_RESPONSE_ID {
                self.dtos.push(f.payload().to_vec());
                continue;
            }
            if let Ok(Message::Demand(d)) = decode(&LAYOUT, &f) {
                self.demands.push((d.counter, d.demand_n));
                if d.counter == counter {
                    return d.demand_n;
                }
            }
        }
    }

    /// One XCP command; the first response packet (`None`: no answer within 1 s).
    fn xcp(&mut self, cto: &[u8]) -> Option<Vec<u8>> {
        self.link
            .send(&RawFrame::from_parts(XCP_COMMAND_ID, cto).unwrap())
            .unwrap();
        let deadline = Instant::now() + Duration::from_secs(1);
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            let f = self.link.recv(left).unwrap()?;
            if f.id == XCP_RESPONSE_ID {
                let p = f.payload().to_vec();
                // DTOs carry a PID below 0xFC; responses start with 0xFF / 0xFE.
                if p.first().is_some_and(|&b| b >= 0xFC) {
                    return Some(p);
                }
                self.dtos.push(p);
            }
        }
    }

    fn ok(&mut self, cto: &[u8]) -> Vec<u8> {
        let r = self.xcp(cto).expect("no XCP answer");
        assert_eq!(r[0], 0xFF, "command {cto:02X?} answered {r:02X?}");
        r
    }

    fn unlock(&mut self, resource: u8, secret: &[u8]) -> Vec<u8> {
        let seed = self.ok(&[0xF8, 0x00, resource]);
        assert_eq!(seed[1], 6, "{seed:02X?}");
        let key = compute_key(secret, resource, seed[2..8].try_into().unwrap());
        let mut unlock = vec![0xF7, 6];
        unlock.extend_from_slice(&key);
        self.xcp(&unlock).expect("no UNLOCK answer")
    }

    fn upload_f32(&mut self, address: u32) -> f32 {
        let a = address.to_le_bytes();
        let r = self.ok(&[0xF4, 4, 0, 0, a[0], a[1], a[2], a[3]]);
        f32::from_le_bytes(r[1..5].try_into().unwrap())
    }

    fn upload_u32(&mut self, address: u32) -> u32 {
        let a = address.to_le_bytes();
        let r = self.ok(&[0xF4, 4, 0, 0, a[0], a[1], a[2], a[3]]);
        u32::from_le_bytes(r[1..5].try_into().unwrap())
    }

    fn download_f32(&mut self, address: u32, value: f32) -> Vec<u8> {
        let a = address.to_le_bytes();
        self.ok(&[0xF6, 0, 0, 0, a[0], a[1], a[2], a[3]]);
        let v = value.to_le_bytes();
        self.xcp(&[0xF0, 4, v[0], v[1], v[2], v[3]])
            .expect("no DOWNLOAD answer")
    }
}

#[test]
fn xcp_calibration_and_daq_on_the_running_firmware() {
    let elf = elf();
    let image = std::fs::read(&elf).unwrap();

    // The A2L of this ELF, parsed by an independent parser, against the ELF's symbols.
    let l = layout(&image).expect("the firmware ELF holds the calibration statics");
    let syms = symbols(&image).unwrap();
    assert_eq!(u64::from(l.calibration.address), syms[WORKING_SYMBOL].0);
    assert_eq!(u64::from(l.measurement.address), syms[MEASUREMENT_SYMBOL].0);
    let text = generate(&l, "qemu test");
    let (a2l, log) = a2lfile::load_from_string(&text, None, true).expect("strict A2L parse");
    assert!(log.is_empty(), "{log:?}");
    let module = &a2l.project.module[0];
    assert!(module.if_data[0].ifdata_valid);
    let cal_address = |name: &str| module.characteristic.get(name).unwrap().address;
    let meas_address = |name: &str| {
        module
            .measurement
            .get(name)
            .unwrap()
            .ecu_address
            .as_ref()
            .unwrap()
            .address
    };
    let items: Vec<(usize, String, mil_firmware::calibration::CalItem)> = (0..SLOTS)
        .map(|s| {
            let i = item(s).unwrap();
            (s, i.to_string(), i)
        })
        .collect();
    for (slot, name, item) in &items {
        let c = module.characteristic.get(name).unwrap();
        assert_eq!(c.address, l.calibration.address + 4 * *slot as u32);
        assert_eq!(
            (c.lower_limit, c.upper_limit),
            (f64::from(item.min), f64::from(item.max))
        );
    }
    for (slot, item) in MEAS_ITEMS.iter().enumerate() {
        assert_eq!(
            meas_address(item.name),
            l.measurement.address + 4 * slot as u32
        );
    }

    let (qemu, link) = Qemu::spawn(&elf, &QemuOptions::default()).unwrap_or_else(|e| {
        panic!("QEMU: {e} (install QEMU: `apt-get install -y qemu-system-arm`)")
    });
    let mut rig = Rig {
        link,
        counter: 0,
        demands: Vec::new(),
        dtos: Vec::new(),
    };
    // Not connected: silence. CONNECT, then a wrong key: access locked, session ended.
    // (Before the first measurement: the watchdog is not armed yet.)
    assert_eq!(rig.xcp(&[0xFD]), None);
    let connect = rig.ok(&[0xFF, 0x00]);
    assert_eq!(
        connect[1] & 0x05,
        0x05,
        "CAL/PAG and DAQ offered: {connect:02X?}"
    );
    assert_eq!(
        rig.unlock(0x01, b"not-the-secret-of-this-build"),
        vec![0xFE, 0x25]
    );
    assert_eq!(rig.xcp(&[0xFD]), None, "a wrong key disconnects");
    rig.ok(&[0xFF, 0x00]);
    // Locked: a download is refused.
    let k = cal_address("tyre_stiffness_0");
    assert_eq!(rig.download_f32(k, 3.0e5), vec![0xFE, 0x25]);
    assert_eq!(rig.unlock(0x01, TEST_SECRET)[0], 0xFF);
    assert_eq!(rig.unlock(0x04, TEST_SECRET)[0], 0xFF);
    // XCP round trips take QEMU time between lockstep samples: a long watchdog (10 000
    // ticks of 50 ms QEMU time), set through XCP like any parameter.
    assert_eq!(
        rig.download_f32(cal_address("watchdog_limit"), 10_000.0),
        vec![0xFF]
    );

    let start = encode_command(
        &LAYOUT,
        &Command {
            command: CommandKind::Start,
            index: 0,
            value: 0.0,
        },
    )
    .unwrap();
    rig.link.send(&start).unwrap();
    // Road 0, hub 1 mm down: the tyre is compressed 1 mm more than at rest.
    let (position, road) = (-1.0e-3_f32, 0.0_f32);
    for _ in 0..20 {
        rig.step(position, road);
    }
    let before = rig.step(position, road);

    // Uploads at the A2L addresses read the running values: the reference page's, but
    // for the watchdog limit just written.
    let reference = reference_words();
    for (slot, name, _) in &items {
        let v = rig.upload_f32(cal_address(name));
        if name == "watchdog_limit" {
            assert_eq!(v, 10_000.0);
        } else {
            assert_eq!(v.to_bits(), reference[*slot], "{name}");
        }
    }

    // A write reaches the model at a step boundary, bumpless: 2.5e5 → 3.0e5 N/m asks for
    // +50 N at 1 mm; the first step holds the demand, then it fades in over 200 steps (0.1 s,
    // model-core's BUMPLESS_FADE_S), never by more than 50 N / 200 a step (plus the frame's
    // 0.1 N resolution).
    assert_eq!(TYRE.stiffness, 2.5e5);
    assert_eq!(rig.download_f32(k, 3.0e5), vec![0xFF]);
    let first = rig.step(position, road);
    assert!(
        (first - before).abs() < 0.15,
        "demand {before} N → {first} N at the swap"
    );
    let mut last = first;
    for _ in 0..210 {
        let d = rig.step(position, road);
        assert!(
            (d - last).abs() <= 50.0 / 200.0 + 0.15,
            "step {last} → {d} N"
        );
        last = d;
    }
    let after = last;
    assert!(
        (after - before - 50.0).abs() < 0.2,
        "demand {before} N → {after} N, expected +50 N"
    );
    assert_eq!(rig.upload_f32(k), 3.0e5);
    let changes = rig.upload_u32(meas_address("calibration_changes"));
    assert!(changes >= 1);

    // Refusals: the XCP error, nothing changes.
    let cases: [(&str, f32, [u8; 2], u32); 3] = [
        ("tyre_stiffness_0", f32::NAN, [0xFE, 0x22], 129),
        ("tyre_stiffness_0", 1.0e12, [0xFE, 0x22], 130),
        ("limits_demand_min_0", 20_000.0, [0xFE, 0x31], 132),
    ];
    for (name, value, error, reason) in cases {
        assert_eq!(
            rig.download_f32(cal_address(name), value),
            error.to_vec(),
            "{name} = {value}"
        );
        assert_eq!(
            rig.upload_u32(meas_address("calibration_last_rejection")),
            reason
        );
        assert_eq!(rig.upload_f32(k), 3.0e5);
        assert_eq!(rig.step(position, road), after);
    }
    let outside = l.calibration.address + l.calibration.size;
    assert_eq!(rig.download_f32(outside, 1.0), vec![0xFE, 0x24]);
    assert_eq!(
        rig.download_f32(l.measurement.address, 1.0),
        vec![0xFE, 0x24]
    );
    assert_eq!(rig.upload_u32(meas_address("calibration_changes")), changes);

    // ECU on the reference page: the defaults run; back on the working page: 3e5 again
    // (each after its 200-step fade).
    let settle = |rig: &mut Rig| {
        for _ in 0..210 {
            rig.step(position, road);
        }
        rig.step(position, road)
    };
    rig.ok(&[0xEB, 0x01, 0x00, 0x01]);
    assert!((settle(&mut rig) - before).abs() < 0.01);
    rig.ok(&[0xEB, 0x01, 0x00, 0x00]);
    assert!((settle(&mut rig) - after).abs() < 0.01);

    // DAQ: demand and steps on the control-step event, with timestamps.
    // ODT 0: the timestamp only (3 data bytes left); ODT 1: demand; ODT 2: steps (one
    // 4-byte entry each: a DTO carries 7 data bytes after its PID).
    rig.ok(&[0xD6]); // FREE_DAQ
    rig.ok(&[0xD5, 0, 1, 0]); // ALLOC_DAQ 1
    rig.ok(&[0xD4, 0, 0, 0, 3]); // ALLOC_ODT list 0: 3 ODTs
    rig.ok(&[0xD3, 0, 0, 0, 0, 0]);
    rig.ok(&[0xD3, 0, 0, 0, 1, 1]);
    rig.ok(&[0xD3, 0, 0, 0, 2, 1]);
    for (odt, name) in [(1u8, "demand"), (2, "steps")] {
        rig.ok(&[0xE2, 0, 0, 0, odt, 0]); // SET_DAQ_PTR list 0, ODT, entry 0
        let a = meas_address(name).to_le_bytes();
        rig.ok(&[0xE1, 0xFF, 4, 0, a[0], a[1], a[2], a[3]]);
    }
    rig.ok(&[0xE0, 0x10, 0, 0, 0, 0, 1, 0]); // timestamps, event 0, prescaler 1
    rig.ok(&[0xDE, 0x02, 0, 0]); // select
    rig.dtos.clear();
    rig.ok(&[0xDD, 0x01]); // start selected
    let mut stepped = Vec::new();
    for _ in 0..60 {
        stepped.push(rig.step(position, road));
    }
    rig.ok(&[0xDD, 0x00]); // stop all

    // PID 0: timestamp; PID 1: demand; PID 2: steps; in this order for every sample.
    let of_pid = |pid: u8| -> Vec<[u8; 4]> {
        rig.dtos
            .iter()
            .filter(|p| p[0] == pid)
            .map(|p| p[1..5].try_into().unwrap())
            .collect()
    };
    let samples: Vec<(f32, u32)> = of_pid(1)
        .into_iter()
        .zip(of_pid(2))
        .map(|(d, s)| (f32::from_le_bytes(d), u32::from_le_bytes(s)))
        .collect();
    let order: Vec<u8> = rig.dtos.iter().map(|p| p[0]).collect();
    assert!(
        order.chunks(3).all(|c| c == [0, 1, 2] || c.len() < 3),
        "DTO order {order:?}"
    );
    let stamps: Vec<u32> = of_pid(0).into_iter().map(u32::from_le_bytes).collect();
    // Consecutive steps; a sample the firmware could not queue (DAQ task behind by more than
    // its queue, which QEMU's blocking serial writes can cause) must be counted.
    let dropped = rig.upload_u32(meas_address("daq_dropped"));
    let mut lost = 0;
    for w in samples.windows(2) {
        assert!(w[1].1 > w[0].1, "steps not increasing: {samples:?}");
        lost += w[1].1 - w[0].1 - 1;
    }
    assert!(
        lost <= dropped && lost <= 2,
        "{lost} samples lost, {dropped} counted"
    );
    assert!(
        samples.len() >= 55,
        "{} DAQ samples for 60 steps",
        samples.len()
    );
    for (stamp, (_, steps)) in stamps.iter().zip(&samples) {
        assert_eq!(*stamp, steps * 500);
    }
    // Each sample's demand is its step's demand frame (which carries it in 0.1 N counts).
    let last = samples.last().unwrap();
    assert!((last.0 - stepped.last().unwrap()).abs() <= 0.05, "{last:?}");
    assert!(samples.iter().all(|s| (s.0 - after).abs() <= 0.05));
    rig.ok(&[0xFE]); // DISCONNECT

    rig.link.close().unwrap();
    let out = qemu.finish(Duration::from_secs(20)).unwrap();
    assert!(
        out.status.is_some_and(|s| s.success()),
        "{:?} {}",
        out.status,
        out.stderr
    );
    eprintln!("{}", out.stdout.trim());
}

/// The QEMU build's second SLCAN port (USART2) carries XCP for a master of its own, while
/// USART1 stays the rig's: CONNECT there is answered there, and nothing XCP appears on
/// USART1.
#[test]
fn the_xcp_port_answers_on_its_own_link() {
    let options = QemuOptions {
        xcp_port: true,
        ..QemuOptions::default()
    };
    let (qemu, mut link) = Qemu::spawn(&elf(), &options).expect("QEMU");
    let port = qemu.xcp_port().expect("the XCP port");
    let addr = std::net::SocketAddr::from((std::net::Ipv4Addr::LOCALHOST, port));
    let mut aux = SlcanTcp::connect(addr, TIMEOUT).expect("connect to the XCP port");
    aux.open(TIMEOUT).expect("SLCAN on the XCP port");
    aux.send(&RawFrame::from_parts(XCP_COMMAND_ID, &[0xFF, 0x00]).unwrap())
        .unwrap();
    let answer = aux.recv(TIMEOUT).unwrap().expect("CONNECT answered");
    assert_eq!(answer.id, XCP_RESPONSE_ID);
    assert_eq!(answer.payload()[0], 0xFF);
    assert!(link.recv(Duration::from_millis(300)).unwrap().is_none());
    aux.send(&RawFrame::from_parts(XCP_COMMAND_ID, &[0xFE]).unwrap())
        .unwrap();
    assert_eq!(
        aux.recv(TIMEOUT).unwrap().expect("DISCONNECT").payload(),
        [0xFF]
    );
    link.close().unwrap();
    let out = qemu.finish(Duration::from_secs(20)).unwrap();
    assert!(out.status.is_some_and(|s| s.success()), "{}", out.stderr);
}
