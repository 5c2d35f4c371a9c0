//! The measured record: CSV with a header row, `time` (s, uniform) first, SI units.

use crate::{Error, Result};
use std::io::Read;
use std::path::Path;

/// Relative tolerance on the sample interval: every step must be within this fraction of
/// the mean step (timestamps printed with few digits still pass).
pub const STEP_TOLERANCE: f64 = 0.01;

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
    /// Reads a CSV file.
    ///
    /// # Errors
    /// Unreadable file, or see [`Record::from_reader`].
    pub fn read(path: &Path) -> Result<Self> {
        let file = std::fs::File::open(path).map_err(|source| Error::Io {
            path: path.display().to_string(),
            source,
        })?;
        Self::from_reader(file).map_err(|e| Error::Record(format!("{}: {e}", path.display())))
    }

    /// Parses CSV text from a reader: header with `time` first, at least one more column,
    /// at least 16 rows, finite numbers, strictly increasing uniform time (every step within
    /// [`STEP_TOLERANCE`] of the mean step).
    ///
    /// # Errors
    /// The first problem, with its row and column.
    pub fn from_reader<R: Read>(reader: R) -> Result<Self> {
        let mut rdr = csv::ReaderBuilder::new()
            .trim(csv::Trim::All)
            .from_reader(reader);
        let header = rdr
            .headers()
            .map_err(|e| Error::Record(e.to_string()))?
            .clone();
        if header.get(0) != Some("time") {
            return Err(Error::Record(format!(
                "the first column must be `time`, got {:?}",
                header.get(0).unwrap_or("")
            )));
        }
        let names: Vec<String> = header.iter().skip(1).map(str::to_string).collect();
        if names.is_empty() {
            return Err(Error::Record("no columns after `time`".into()));
        }
        for (i, n) in names.iter().enumerate() {
            if n.is_empty() || names[..i].contains(n) || n == "time" {
                return Err(Error::Record(format!(
                    "column {}: name {n:?} empty or repeated",
                    i + 2
                )));
            }
        }
        let mut time = Vec::new();
        let mut columns = vec![Vec::new(); names.len()];
        for (row, rec) in rdr.records().enumerate() {
            let rec = rec.map_err(|e| Error::Record(e.to_string()))?;
            let line = row + 2;
            if rec.len() != names.len() + 1 {
                return Err(Error::Record(format!(
                    "line {line}: {} fields, header has {}",
                    rec.len(),
                    names.len() + 1
                )));
            }
            for (j, field) in rec.iter().enumerate() {
                let v: f64 = field.parse().map_err(|_| {
                    Error::Record(format!(
                        "line {line}, column {}: {field:?} is not a number",
                        j + 1
                    ))
                })?;
                if !v.is_finite() {
                    return Err(Error::Record(format!(
                        "line {line}, column {}: {v} is not finite",
                        j + 1
                    )));
                }
                if j == 0 {
                    time.push(v);
                } else {
                    columns[j - 1].push(v);
                }
            }
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
        let dt = (time[n - 1] - time[0]) / (n - 1) as f64;
        if !(dt.is_finite() && dt > 0.0) {
            return Err(Error::Record("time must increase".into()));
        }
        for (i, w) in time.windows(2).enumerate() {
            let step = w[1] - w[0];
            if (step - dt).abs() > STEP_TOLERANCE * dt {
                return Err(Error::Record(format!(
                    "time step {step} s at sample {} differs from the mean step {dt} s by more than {} %",
                    i + 1,
                    STEP_TOLERANCE * 100.0
                )));
            }
        }
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
