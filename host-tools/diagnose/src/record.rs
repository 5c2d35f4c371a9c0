//! The measured record: CSV with a header row, `time` (s, uniform) first, SI units.

use crate::{Error, Result};
use std::io::Read;
use std::path::Path;

/// A validated record: uniform time base and named, finite columns.
#[derive(Clone, Debug, PartialEq)]
pub struct Record {
    /// Sample interval (s).
    pub dt: f64,
    /// Time of the first sample (s).
    pub t0: f64,
    /// Column names after `time`.
    pub names: Vec<String>,
    /// Columns after `time`, each one value per sample (column's own SI unit).
    pub columns: Vec<Vec<f64>>,
}

impl Record {
    /// Reads a CSV file (the workspace's one reader, `mil_numerics::record`: comma,
    /// semicolon or tab; units in the header; decimal commas; `#` comment lines).
    ///
    /// # Errors
    /// Unreadable file, or see [`Record::from_reader`].
    pub fn read(path: &Path) -> Result<Self> {
        if let Err(source) = std::fs::metadata(path) {
            return Err(Error::Io {
                path: path.display().to_string(),
                source,
            });
        }
        let table = mil_numerics::record::read(path).map_err(|e| Error::Record(e.to_string()))?;
        Self::from_table(table).map_err(|e| Error::Record(format!("{}: {e}", path.display())))
    }

    /// Parses CSV text from a reader: header with `time` first (unit, if given, `s`), at
    /// least one more column, at least 16 rows, finite numbers, a uniform time base
    /// (`mil_numerics::record::uniform_time_base`: increasing, every sample within 0.4
    /// intervals of the uniform grid).
    ///
    /// # Errors
    /// The first problem, with its line and column.
    pub fn from_reader<R: Read>(reader: R) -> Result<Self> {
        let table = mil_numerics::record::parse(reader, "record")
            .map_err(|e| Error::Record(e.to_string()))?;
        Self::from_table(table)
    }

    /// The record a table holds (see [`Record::from_reader`]).
    fn from_table(table: mil_numerics::record::Table) -> Result<Self> {
        table.require_time_first().map_err(Error::Record)?;
        let mil_numerics::record::Table {
            mut names,
            mut columns,
            ..
        } = table;
        let time = columns.remove(0);
        names.remove(0);
        if names.is_empty() {
            return Err(Error::Record("no columns after `time`".into()));
        }
        Self::new(&time, names, columns)
    }

    /// Builds a record from a time vector (s) and named columns.
    ///
    /// # Errors
    /// As [`Record::from_reader`].
    pub fn new(time: &[f64], names: Vec<String>, columns: Vec<Vec<f64>>) -> Result<Self> {
        let n = time.len();
        if n < 16 {
            return Err(Error::Record(format!("{n} samples, at least 16 needed")));
        }
        if names.len() != columns.len() || columns.iter().any(|c| c.len() != n) {
            return Err(Error::Record("columns of unequal length".into()));
        }
        if let Some((j, _)) = columns
            .iter()
            .enumerate()
            .find(|(_, c)| c.iter().any(|v| !v.is_finite()))
        {
            return Err(Error::Record(format!(
                "column {:?}: non-finite value",
                names[j]
            )));
        }
        let base = mil_numerics::record::uniform_time_base(time)
            .map_err(|e| Error::Record(format!("sample {} (from 0): {}", e.index, e.message)))?;
        let dt = base.dt;
        Ok(Self {
            dt,
            t0: time[0],
            names,
            columns,
        })
    }

    /// The record averaged over blocks of `factor` samples (a partial last block dropped),
    /// each mean stamped at its block's centre: white measurement noise stays white (block
    /// means of independent samples are independent), with its variance over `factor`; a
    /// signal at frequency `f` keeps `sinc(f / f_s')` of its amplitude (`f_s'` the new
    /// rate: 99.6 % at `f_s' / 20`).
    pub fn block_mean(&self, factor: usize) -> Record {
        let factor = factor.max(1);
        let blocks = self.len() / factor;
        let mean = |c: &[f64]| -> Vec<f64> {
            c.chunks_exact(factor)
                .take(blocks)
                .map(|b| b.iter().sum::<f64>() / factor as f64)
                .collect()
        };
        Record {
            dt: self.dt * factor as f64,
            t0: self.t0 + 0.5 * (factor - 1) as f64 * self.dt,
            names: self.names.clone(),
            columns: self.columns.iter().map(|c| mean(c)).collect(),
        }
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.columns.first().map_or(0, Vec::len)
    }

    /// Whether the record has no samples.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The column called `name`.
    ///
    /// # Errors
    /// No such column (the message lists the columns there are).
    pub fn column(&self, name: &str) -> Result<&[f64]> {
        self.names
            .iter()
            .position(|n| n == name)
            .map(|i| self.columns[i].as_slice())
            .ok_or_else(|| {
                Error::Record(format!(
                    "no column {name:?} (columns: {})",
                    self.names.join(", ")
                ))
            })
    }

    /// Samples `range` of the record as a new record.
    pub fn slice(&self, range: std::ops::Range<usize>) -> Self {
        Self {
            dt: self.dt,
            t0: self.t0 + range.start as f64 * self.dt,
            names: self.names.clone(),
            columns: self
                .columns
                .iter()
                .map(|c| c[range.clone()].to_vec())
                .collect(),
        }
    }

    /// Writes the record as CSV (`time` first).
    ///
    /// # Errors
    /// The file cannot be written.
    pub fn write(&self, path: &Path) -> Result<()> {
        let io = |source| Error::Io {
            path: path.display().to_string(),
            source,
        };
        let mut w = csv::Writer::from_path(path).map_err(|e| io(std::io::Error::other(e)))?;
        let mut head = vec!["time".to_string()];
        head.extend(self.names.iter().cloned());
        w.write_record(&head)
            .map_err(|e| io(std::io::Error::other(e)))?;
        for i in 0..self.len() {
            let mut row = vec![format!("{}", self.t0 + i as f64 * self.dt)];
            row.extend(self.columns.iter().map(|c| format!("{}", c[i])));
            w.write_record(&row)
                .map_err(|e| io(std::io::Error::other(e)))?;
        }
        w.flush().map_err(io)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn block_means_keep_white_noise_white_and_stamp_the_block_centre() {
        let n = 40_000;
        let mut rng = mil_numerics::rng::SplitMix64::new(3u64);
        let mut rnd = move || rng.uniform() - 0.5;
        let t: Vec<f64> = (0..n).map(|i| 2.0 + i as f64 * 1e-3).collect();
        let noise: Vec<f64> = (0..n).map(|_| rnd()).collect();
        let slow: Vec<f64> = t
            .iter()
            .map(|t| (std::f64::consts::TAU * t).sin())
            .collect();
        let rec = Record::new(&t, vec!["w".into(), "s".into()], vec![noise, slow]).expect("rec");
        let r = rec.block_mean(8);
        assert_eq!(r.len(), n / 8);
        assert!((r.dt - 8e-3).abs() < 1e-15);
        assert!((r.t0 - (2.0 + 3.5e-3)).abs() < 1e-12, "{}", r.t0);
        // Uniform noise of variance 1/12, averaged over 8: variance 1/96, and white (the
        // estimate from the top of the band agrees).
        let w = r.column("w").expect("w");
        let var = crate::signal::std(w).powi(2);
        assert!((var * 96.0 - 1.0).abs() < 0.05, "{var}");
        let top = crate::signal::noise_std(w, r.dt).powi(2);
        assert!((top * 96.0 - 1.0).abs() < 0.15, "{top}");
        // A 1 Hz sine at its block centres, within sinc(8 / 1000) of its amplitude.
        let sl = r.column("s").expect("s");
        for (k, v) in sl.iter().enumerate() {
            let tc = r.t0 + k as f64 * r.dt;
            assert!((v - (std::f64::consts::TAU * tc).sin()).abs() < 1e-3, "{k}");
        }
    }

    fn csv(text: &str) -> Result<Record> {
        Record::from_reader(text.as_bytes())
    }

    fn rows(n: usize, f: impl Fn(usize) -> String) -> String {
        let mut s = String::from("time,u,y\n");
        for i in 0..n {
            s.push_str(&f(i));
            s.push('\n');
        }
        s
    }

    #[test]
    fn valid_record_reads() {
        let r = csv(&rows(20, |i| {
            format!("{},{},{}", i as f64 * 0.001, i, 2 * i)
        }))
        .unwrap();
        assert_eq!(r.len(), 20);
        assert!((r.dt - 0.001).abs() < 1e-15);
        assert_eq!(r.column("y").unwrap()[3], 6.0);
        assert!(r.column("z").unwrap_err().to_string().contains("u, y"));
    }

    /// A record as a DAQ exports it: metadata lines, `;` separators, decimal commas, units
    /// in the header, timing jitter and times rounded to 5 decimals.
    #[test]
    fn a_daq_export_reads_and_a_time_in_ms_is_refused() {
        let mut text = String::from("# rig 3, channel map v2\ntime [s];force [N];x [m]\n");
        for i in 0..40 {
            let jitter = if i % 2 == 0 { 0.12 } else { -0.08 };
            let t = ((i as f64 + jitter) * 0.001 * 1e5).round() / 1e5;
            text.push_str(&format!("{};{},5;0,00{}\n", t, i, i % 7).replace('.', ","));
        }
        let r = csv(&text).unwrap();
        assert_eq!(r.names, ["force", "x"]);
        assert_eq!(r.len(), 40);
        assert!((r.dt - 0.001).abs() < 1e-5, "{}", r.dt);
        assert_eq!(r.column("force").unwrap()[3], 3.5);
        let ms = text.replace("time [s]", "time [ms]");
        let e = csv(&ms).unwrap_err().to_string();
        assert!(e.contains("\"ms\"") && e.contains("give it in s"), "{e}");
    }

    #[test]
    fn problems_are_named() {
        let e = csv("t,u\n0,1\n").unwrap_err().to_string();
        assert!(e.contains("`time`"), "{e}");
        let text = rows(20, |i| {
            let t = if i == 10 { 0.0105 } else { i as f64 * 0.001 };
            format!("{t},{i},{i}")
        });
        let e = csv(&text).unwrap_err().to_string();
        assert!(e.contains("sample 10"), "{e}");
        let text = rows(20, |i| {
            format!(
                "{},{},{}",
                i as f64 * 0.001,
                if i == 5 { "NaN".into() } else { i.to_string() },
                i
            )
        });
        let e = csv(&text).unwrap_err().to_string();
        assert!(e.contains("line 7"), "{e}");
        let e = csv(&rows(20, |i| format!("{},{},x", i as f64, i)))
            .unwrap_err()
            .to_string();
        assert!(e.contains("not a number"), "{e}");
    }
}
