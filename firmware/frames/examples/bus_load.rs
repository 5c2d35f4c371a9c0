//! Prints the bus-load budget of the MiL frame schedule (the README's figures):
//! `cargo run -p mil-frames --example bus_load`.

use mil_frames::bus_load::{self, Schedule, BUDGET};
use mil_frames::MessageKind;

fn main() {
    const BIT_PER_S: f64 = 1e6;
    println!(
        "Classic CAN, standard IDs, 1 Mbit/s; frame bits = 47 + 8n (incl. 3-bit intermission)"
    );
    println!(
        "+ worst-case stuff bits floor((34 + 8n - 1)/4) (Davis et al., Real-Time Systems 2007)."
    );
    println!();
    println!("| frame | DLC | bits nominal | bits worst case |");
    println!("|---|---|---|---|");
    for kind in MessageKind::ALL {
        let dlc = kind.dlc();
        println!(
            "| {kind:?} | {dlc} | {} | {} |",
            bus_load::frame_bits(dlc),
            bus_load::frame_bits_worst(dlc)
        );
    }
    println!();
    println!(
        "| schedule | load at 2 kHz (worst / nominal) | highest sample rate within {:.0} % |",
        100.0 * BUDGET
    );
    println!("|---|---|---|");
    for (name, s) in [
        ("tyre x1", Schedule::tyre(1, 2000.0)),
        ("tyre x2", Schedule::tyre(2, 2000.0)),
        ("tyre x4", Schedule::tyre(4, 2000.0)),
        ("aero x2, speed on one channel", Schedule::aero(2000.0)),
    ] {
        println!(
            "| {name} | {:.1} % / {:.1} % | {:.0} Hz |",
            100.0 * s.load(BIT_PER_S),
            100.0 * s.load_nominal(BIT_PER_S),
            s.max_sample_rate_hz(BIT_PER_S, BUDGET)
        );
    }
    println!();
    println!(
        "Per sample and channel: Measurement + Demand = {} bits worst case; heartbeat {} bit/s.",
        Schedule::tyre(1, 0.0).bits_per_sample_worst(),
        f64::from(bus_load::frame_bits_worst(MessageKind::Status.dlc())) * bus_load::HEARTBEAT_HZ
    );
}
