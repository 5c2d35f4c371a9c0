//! The one reader of CSV records and tables for every command (diagnosis records, road and
//! speed profiles of `mil sim`), and the one time-base rule.
//!
//! Accepted as real DAQ exports write them:
//! - a comma, semicolon or tab between fields (whichever the header line uses); with a
//!   semicolon or a tab, a decimal comma in numbers (`0,25`) too;
//! - lines starting with `#` before or between rows (metadata, comments) are skipped;
//! - a unit after a column name in brackets or parentheses (`time [s]`, `force (N)`): the
//!   name is `time`, the unit `s`;
//! - spaces around fields.
//!
//! Refused, with the file, line and column: a row with another number of fields than the
//! header, a field that is not a finite number, an empty or repeated column name.
//!
//! The time base ([`uniform_time_base`]): strictly increasing times whose every sample lies
//! within [`JITTER_TOLERANCE`] (0.4) sample intervals of the least-squares uniform grid, so
//! timing jitter of a fraction of a sample and times rounded to a few decimals pass, while a
//! dropped or repeated sample (half an interval off and more) does not. The interval is the
//! span over the number of intervals, the start the first sample's time.

use std::fmt;
use std::io::Read;
use std::path::Path;

/// How far (in sample intervals) a sample time may lie from the uniform grid.
pub const JITTER_TOLERANCE: f64 = 0.4;

/// A problem with a record: where (file or origin, line, column) and what.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RecordError {
    /// The file (or another name of the source).
    pub origin: String,
    /// The line (1-based, the header is line 1 of the data part), where one applies.
    pub line: Option<usize>,
    /// The column (1-based), where one applies.
    pub column: Option<usize>,
    /// What is wrong.
    pub message: String,
}

impl fmt::Display for RecordError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.origin)?;
        if let Some(l) = self.line {
            write!(f, ": line {l}")?;
        }
        if let Some(c) = self.column {
            write!(f, ", column {c}")?;
        }
        write!(f, ": {}", self.message)
    }
}

impl std::error::Error for RecordError {}

/// A table of numbers with named columns.
#[derive(Clone, Debug, PartialEq)]
pub struct Table {
    /// Column names, units stripped (`time [s]` → `time`).
    pub names: Vec<String>,
    /// The unit each header gives (`s` for `time [s]`), `None` where it gives none.
    pub units: Vec<Option<String>>,
    /// The columns, one value per row.
    pub columns: Vec<Vec<f64>>,
    /// The file line of each row (1-based; comment lines counted).
    pub lines: Vec<usize>,
}

impl Table {
    /// Number of rows.
    #[must_use]
    pub fn rows(&self) -> usize {
        self.columns.first().map_or(0, Vec::len)
    }

    /// The index of the column called `name`.
    #[must_use]
    pub fn index(&self, name: &str) -> Option<usize> {
        self.names.iter().position(|n| n == name)
    }

    /// Checks that the first column is `time` and, where the header gives a unit, that it is
    /// `s`; the message names what is wrong (header line 1).
    ///
    /// # Errors
    /// Another first column, or `time` in another unit (e.g. `ms`).
    pub fn require_time_first(&self) -> Result<(), String> {
        if self.names.first().map(String::as_str) != Some("time") {
            return Err(format!(
                "the first column must be `time` (s); the header is `{}`",
                self.names.join(",")
            ));
        }
        match self.units.first() {
            Some(Some(unit)) if unit != "s" => Err(format!(
                "column `time` is in {unit:?}: give it in s (seconds)"
            )),
            _ => Ok(()),
        }
    }

    /// The uniform time base of the first column ([`uniform_time_base`]); an error carries
    /// the file line of the sample it is at.
    ///
    /// # Errors
    /// As [`uniform_time_base`], with the line.
    pub fn time_base(&self) -> Result<TimeBase, (usize, TimeBaseError)> {
        let time = self.columns.first().map_or(&[][..], Vec::as_slice);
        uniform_time_base(time).map_err(|e| (self.lines.get(e.index).copied().unwrap_or(1), e))
    }
}

/// A header field split into name and unit: `time [s]` → (`time`, `s`).
fn name_and_unit(field: &str) -> (String, Option<String>) {
    let field = field.trim();
    for (open, close) in [('[', ']'), ('(', ')')] {
        if let (Some(a), true) = (field.rfind(open), field.ends_with(close)) {
            let name = field[..a].trim();
            let unit = field[a + 1..field.len() - 1].trim();
            if !name.is_empty() {
                return (name.to_string(), Some(unit.to_string()));
            }
        }
    }
    (field.to_string(), None)
}

/// Reads the table in file `path`.
///
/// # Errors
/// An unreadable file, or see [`parse`].
pub fn read(path: &Path) -> Result<Table, RecordError> {
    let origin = path.display().to_string();
    let file = std::fs::File::open(path).map_err(|e| RecordError {
        origin: origin.clone(),
        line: None,
        column: None,
        message: format!("cannot open: {e}"),
    })?;
    parse(file, &origin)
}

/// Parses a table from `reader` (see the module documentation); `origin` names it in
/// errors.
///
/// # Errors
/// The first problem, with its line and column.
pub fn parse<R: Read>(mut reader: R, origin: &str) -> Result<Table, RecordError> {
    let err = |line: Option<usize>, column: Option<usize>, message: String| RecordError {
        origin: origin.to_string(),
        line,
        column,
        message,
    };
    let mut text = String::new();
    reader
        .read_to_string(&mut text)
        .map_err(|e| err(None, None, format!("cannot read: {e}")))?;
    let header_line = text
        .lines()
        .find(|l| !l.trim().is_empty() && !l.trim_start().starts_with('#'))
        .ok_or_else(|| err(None, None, "no header line".into()))?;
    let delimiter = if header_line.contains(';') {
        b';'
    } else if header_line.contains('\t') {
        b'\t'
    } else {
        b','
    };
    let decimal_comma = delimiter != b',';
    let mut rdr = csv::ReaderBuilder::new()
        .delimiter(delimiter)
        .comment(Some(b'#'))
        .trim(csv::Trim::All)
        .flexible(true)
        .from_reader(text.as_bytes());
    let header = rdr
        .headers()
        .map_err(|e| err(Some(1), None, e.to_string()))?
        .clone();
    let (names, units): (Vec<String>, Vec<Option<String>>) =
        header.iter().map(name_and_unit).unzip();
    for (i, n) in names.iter().enumerate() {
        if n.is_empty() || names[..i].contains(n) {
            return Err(err(
                Some(1),
                Some(i + 1),
                format!("column name {n:?} empty or repeated"),
            ));
        }
    }
    let mut columns = vec![Vec::new(); names.len()];
    let mut lines = Vec::new();
    for rec in rdr.records() {
        let rec = rec.map_err(|e| err(None, None, e.to_string()))?;
        let line = rec.position().map_or(0, |p| p.line() as usize);
        if rec.len() != names.len() {
            return Err(err(
                Some(line),
                None,
                format!("{} fields, the header has {}", rec.len(), names.len()),
            ));
        }
        for (j, field) in rec.iter().enumerate() {
            let parsed = if decimal_comma {
                field.replace(',', ".").parse::<f64>()
            } else {
                field.parse::<f64>()
            };
            let column = &names[j];
            let v = parsed.map_err(|_| {
                err(
                    Some(line),
                    Some(j + 1),
                    format!("column `{column}`: `{field}` is not a number"),
                )
            })?;
            if !v.is_finite() {
                return Err(err(
                    Some(line),
                    Some(j + 1),
                    format!("column `{column}`: {v} is not finite"),
                ));
            }
            columns[j].push(v);
        }
        lines.push(line);
    }
    Ok(Table {
        names,
        units,
        columns,
        lines,
    })
}

/// A uniform time base: first sample time and interval (s).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TimeBase {
    /// Time of the first sample (s).
    pub t0: f64,
    /// Sample interval (s): the span over the number of intervals.
    pub dt: f64,
}

/// Why sample times are not a uniform time base, and where.
#[derive(Clone, Debug, PartialEq)]
pub struct TimeBaseError {
    /// The sample (0-based) the problem is at.
    pub index: usize,
    /// Its time (s).
    pub time_s: f64,
    /// The time a uniform time base would have there (s).
    pub expected_s: f64,
    /// What is wrong.
    pub message: String,
}

impl fmt::Display for TimeBaseError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)
    }
}

/// Largest and smallest step, in median steps, that is not a dropped or repeated sample.
const STEP_RANGE: (f64, f64) = (0.2, 1.8);

/// The uniform time base of sample times `time` (see the module documentation), or where
/// and why it is not one: first every step against the median step (so a dropped, repeated
/// or reversed sample is reported at its own sample), then every time against the
/// least-squares uniform grid (so that drift beyond [`JITTER_TOLERANCE`] is caught too).
///
/// # Errors
/// Fewer than 2 samples, times that do not increase, a step outside 0.2–1.8 median steps, or
/// a sample farther than [`JITTER_TOLERANCE`] sample intervals from the uniform grid.
pub fn uniform_time_base(time: &[f64]) -> Result<TimeBase, TimeBaseError> {
    let n = time.len();
    let fail = |index: usize, expected_s: f64, message: String| TimeBaseError {
        index,
        time_s: time.get(index).copied().unwrap_or(f64::NAN),
        expected_s,
        message,
    };
    if n < 2 {
        return Err(fail(
            0,
            f64::NAN,
            format!("{n} samples: a time base needs at least 2"),
        ));
    }
    let mut steps: Vec<f64> = time.windows(2).map(|w| w[1] - w[0]).collect();
    steps.sort_by(f64::total_cmp);
    let median = steps[steps.len() / 2];
    if !(median.is_finite() && median > 0.0) {
        return Err(fail(
            1,
            time[0],
            "the `time` column does not increase".into(),
        ));
    }
    for (k, w) in time.windows(2).enumerate() {
        let step = w[1] - w[0];
        if step <= 0.0 {
            return Err(fail(
                k + 1,
                w[0] + median,
                format!("time {} s does not increase (previous {} s)", w[1], w[0]),
            ));
        }
        if step > STEP_RANGE.1 * median || step < STEP_RANGE.0 * median {
            return Err(fail(
                k + 1,
                w[0] + median,
                format!(
                    "time {} s, expected about {} s: a step of {:.2} sample intervals (a dropped or repeated sample?)",
                    w[1],
                    w[0] + median,
                    step / median
                ),
            ));
        }
    }
    let dt = (time[n - 1] - time[0]) / (n - 1) as f64;
    // The grid the samples are checked against: the least-squares line through (k, t_k),
    // so that jitter of the first or last sample does not tilt it.
    let nf = n as f64;
    let k_mean = (nf - 1.0) / 2.0;
    let t_mean = time.iter().sum::<f64>() / nf;
    let (mut skt, mut skk) = (0.0, 0.0);
    for (k, &t) in time.iter().enumerate() {
        let dk = k as f64 - k_mean;
        skt += dk * (t - t_mean);
        skk += dk * dk;
    }
    let slope = skt / skk;
    for (k, &t) in time.iter().enumerate() {
        let expected = t_mean + (k as f64 - k_mean) * slope;
        let off = (t - expected) / slope;
        if off.abs() > JITTER_TOLERANCE {
            return Err(fail(
                k,
                expected,
                format!(
                    "time {t} s is {off:+.2} sample intervals off the uniform {slope} s grid (a dropped or repeated sample? at most ±{JITTER_TOLERANCE} is timing jitter)"
                ),
            ));
        }
    }
    Ok(TimeBase { t0: time[0], dt })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table(text: &str) -> Result<Table, RecordError> {
        parse(text.as_bytes(), "test.csv")
    }

    #[test]
    fn daq_exports_as_they_come() {
        let comma = table("time [s], force (N),x\n0,1.5,2\n0.001,2.5,3\n").unwrap();
        assert_eq!(comma.names, ["time", "force", "x"]);
        assert_eq!(
            comma.units,
            [Some("s".to_string()), Some("N".to_string()), None]
        );
        assert_eq!(comma.columns[1], [1.5, 2.5]);
        let semicolon =
            table("# exported by a DAQ\n# rate 1 kHz\ntime [s];force [N]\n0,000;1,5\n0,001;2,5\n")
                .unwrap();
        assert_eq!(semicolon.names, ["time", "force"]);
        assert_eq!(semicolon.columns[0], [0.0, 0.001]);
        assert_eq!(semicolon.columns[1], [1.5, 2.5]);
        let tab = table("time\tforce\n0\t1,5\n").unwrap();
        assert_eq!(tab.columns[1], [1.5]);
    }

    #[test]
    fn refusals_name_the_line_and_column() {
        let e = table("time,force\n0,1\n0.001,abc\n").unwrap_err();
        assert_eq!((e.line, e.column), (Some(3), Some(2)));
        assert!(
            e.to_string().starts_with("test.csv: line 3, column 2:"),
            "{e}"
        );
        let e = table("time,force\n0,1\n0.001\n").unwrap_err();
        assert_eq!(e.line, Some(3));
        let e = table("time,force\n0,NaN\n").unwrap_err();
        assert_eq!((e.line, e.column), (Some(2), Some(2)));
        let e = table("time,time\n0,1\n").unwrap_err();
        assert_eq!((e.line, e.column), (Some(1), Some(2)));
        assert!(table("").is_err());
    }

    #[test]
    fn jitter_and_rounding_pass_a_dropped_or_repeated_sample_does_not() {
        let dt = 1.0e-3;
        // Jitter of +20 % / -15 % of a sample, times rounded to 4 decimals (±5 %).
        let jittered: Vec<f64> = (0..1000)
            .map(|k| {
                let j = if k % 3 == 0 { 0.2 } else { -0.15 };
                ((k as f64 + j) * dt * 1e4).round() / 1e4
            })
            .collect();
        let base = uniform_time_base(&jittered).unwrap();
        assert!((base.dt - dt).abs() < 1e-6, "{base:?}");
        // A dropped sample anywhere: reported at the sample after the gap.
        for gap in [1, 10, 250, 500, 750, 990, 998] {
            let mut dropped: Vec<f64> = (0..1000).map(|k| k as f64 * dt).collect();
            dropped.remove(gap);
            let e = uniform_time_base(&dropped).unwrap_err();
            assert!(
                e.message.contains("dropped or repeated"),
                "gap {gap}: {e:?}"
            );
            assert_eq!(e.index, gap, "{e:?}");
        }
        // A clock whose rate changes by 1 % over the record: samples drift off the grid.
        let drifting: Vec<f64> = (0..1000)
            .map(|k| k as f64 * dt * (1.0 + 1e-5 * (k as f64 - 500.0).abs()))
            .collect();
        assert!(uniform_time_base(&drifting).is_err());
        // Repeated and decreasing times.
        assert!(uniform_time_base(&[0.0, 0.001, 0.001, 0.002]).is_err());
        assert!(uniform_time_base(&[0.0, 0.002, 0.001, 0.003]).is_err());
        assert!(uniform_time_base(&[0.0]).is_err());
    }
}
