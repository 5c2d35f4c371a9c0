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
        "Kept free on the busiest bus: status {} Hz, XCP and commands {:.0} kbit/s; the speed at {} Hz where a model takes it.",
        bus_load::HEARTBEAT_HZ,
        bus_load::XCP_HEADROOM_BIT_PER_S / 1e3,
        bus_load::SPEED_HZ
    );
    println!();
    println!(
        "| configuration | buses | rate | load of the busiest bus (worst / nominal) | highest rate within {:.0} % |",
        100.0 * BUDGET
    );
    println!("|---|---|---|---|---|");
    for (name, s) in [
        ("tyre x1", Schedule::tyre(1, 2000.0)),
        ("tyre x2", Schedule::tyre(2, 1000.0)),
        ("tyre x4", Schedule::tyre(4, 1000.0)),
        ("tyre x4", Schedule::tyre(4, 1000.0).on_buses(2)),
        ("aero x2 (ride heights, speed)", Schedule::aero(1000.0)),
        (
            "substructure x2, positions in",
            Schedule::substructure(2, false, 1000.0),
        ),
        (
            "substructure x2, forces in",
            Schedule::substructure(2, true, 1000.0),
        ),
        (
            "substructure x4, forces in",
            Schedule::substructure(4, true, 1000.0).on_buses(2),
        ),
    ] {
        let verdict = match s.check(BIT_PER_S) {
            Ok(()) => "",
            Err(_) => " (over budget: refused)",
        };
        println!(
            "| {name} | {} | {:.0} Hz | {:.1} % / {:.1} %{verdict} | {:.0} Hz |",
            s.buses,
            s.sample_rate_hz,
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
