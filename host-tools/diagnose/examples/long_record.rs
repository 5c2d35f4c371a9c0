//! Writes a long record and its model, to check that `mil diagnose` handles records past
//! its sample budget (`mil_diagnose::diagnose::MAX_SAMPLES`) by averaging them down, or
//! refuses them with one line.
//!
//! ```text
//! cargo run --release -p mil-diagnose --example long_record -- DIR [SAMPLES] [RATE_HZ]
//! mil diagnose --model DIR/model.toml --data DIR/record.csv --out DIR/out
//! ```
//!
//! Default 20 000 000 samples at 10 kHz (33 min, about 1 GB of CSV): a 20 kg mass on a
//! 20 kN/m spring (5 Hz) with 10 N of Coulomb friction, driven by a multisine force
//! (0.2–8 Hz), 1 % noise on both columns; semi-implicit Euler at the record's rate.

use std::io::Write;

fn main() -> std::io::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let dir = std::path::PathBuf::from(args.first().map_or("out/long_record", String::as_str));
    let samples: usize = args
        .get(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(20_000_000);
    let fs: f64 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(10_000.0);
    std::fs::create_dir_all(&dir)?;
    std::fs::write(
        dir.join("model.toml"),
        "name = \"long record\"\n\n[[dof]]\nname = \"x\"\nmass = 20.0\n\n\
         [[element]]\nname = \"spring\"\nupper = \"x\"\nlower = \"ground\"\n\
         stiffness_n_per_m = 2.0e4\ndamping_n_s_per_m = 60.0\n\n\
         [[input]]\nname = \"force\"\nkind = \"force\"\ncolumn = \"force\"\nat = \"x\"\n\n\
         [[output]]\ncolumn = \"x\"\nkind = \"displacement\"\nof = \"x\"\n",
    )?;
    let (m, k, c, friction) = (20.0, 2.0e4, 60.0, 10.0);
    let dt = 1.0 / fs;
    let mut rng = mil_numerics::rng::SplitMix64::new(7);
    let tones: Vec<(f64, f64)> = (0..24)
        .map(|i| {
            let f = 0.2 * (40f64).powf(f64::from(i) / 23.0);
            (f, std::f64::consts::TAU * rng.uniform())
        })
        .collect();
    let force = |t: f64| -> f64 {
        tones
            .iter()
            .map(|(f, p)| 40.0 * (std::f64::consts::TAU * f * t + p).sin())
            .sum()
    };
    let mut out = std::io::BufWriter::new(std::fs::File::create(dir.join("record.csv"))?);
    writeln!(out, "time,force,x")?;
    let (mut x, mut v) = (0.0_f64, 0.0_f64);
    let (f_rms, x_rms) = (40.0 * 12f64.sqrt(), 4e-3);
    for i in 0..samples {
        let t = i as f64 * dt;
        let f = force(t);
        let fr = friction * (v / 1e-4).clamp(-1.0, 1.0);
        v += dt * (f - k * x - c * v - fr) / m;
        x += dt * v;
        writeln!(
            out,
            "{t:.6},{:.5},{:.8}",
            f + 0.01 * f_rms * rng.normal(),
            x + 0.01 * x_rms * rng.normal()
        )?;
    }
    out.flush()?;
    println!(
        "{} samples at {fs} Hz written to {}",
        samples,
        dir.display()
    );
    Ok(())
}
