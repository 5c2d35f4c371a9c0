//! Reading time-series test records from CSV.

use std::io::Read;
use std::path::Path;

use crate::error::{path_origin, IdentifyError, Result};
use crate::table::{csv_with_header, parse_field, record_line};

/// The name used in error messages for a record read from a stream.
const STREAM_ORIGIN: &str = "time-series record";

/// Reads a time-series CSV file and returns `(sample_rate_hz, input, output)`: the sample
/// rate (Hz) and the two named columns, in file order.
///
/// The file has a header; the first column is `time` (s), uniformly sampled; the other
/// columns are named (e.g. `out/run.csv` of the `mil` tool). Only `time` and the two requested
/// columns are parsed; they must hold finite numbers. The sample period is fitted from the
/// first and last time, `dt = (t_last - t_first) / (rows - 1)`; every time must lie within
/// `1e-6 · max(|t|, 1 s) + 1e-9 s` of `t_first + i·dt` (this allows times written with
/// microsecond resolution), and every step must lie between 1/2 and 3/2 of the median step
/// (so a dropped or repeated sample is reported on its own line, anywhere in the file).
///
/// Errors: I/O, a missing column (the message lists the columns there are), a non-numeric
/// value, fewer than 2 rows, a non-uniform or non-increasing time; each names the line.
pub fn read_record_csv(
    path: &Path,
    input_column: &str,
    output_column: &str,
) -> Result<(f64, Vec<f64>, Vec<f64>)> {
    let origin = path_origin(path);
    let file = std::fs::File::open(path).map_err(|e| IdentifyError::io(&origin, e))?;
    parse_record(
        std::io::BufReader::new(file),
        &origin,
        input_column,
        output_column,
    )
}

/// As [`read_record_csv`], from any reader.
pub fn read_record_from_reader<R: Read>(
    reader: R,
    input_column: &str,
    output_column: &str,
) -> Result<(f64, Vec<f64>, Vec<f64>)> {
    parse_record(reader, STREAM_ORIGIN, input_column, output_column)
}

fn parse_record<R: Read>(
    reader: R,
    origin: &str,
    input_column: &str,
    output_column: &str,
) -> Result<(f64, Vec<f64>, Vec<f64>)> {
    let (mut rdr, header) = csv_with_header(reader, origin)?;
    if header.get(0) != Some("time") {
        return Err(IdentifyError::format(
            origin,
            1,
            format!(
                "the first column must be `time` (s); the header is `{}`",
                header.iter().collect::<Vec<_>>().join(",")
            ),
        ));
    }
    let find = |name: &str| {
        header
            .iter()
            .position(|h| h == name)
            .ok_or_else(|| IdentifyError::MissingColumn {
                origin: origin.to_string(),
                column: name.to_string(),
                available: header.iter().collect::<Vec<_>>().join(", "),
            })
    };
    let (ci, co) = (find(input_column)?, find(output_column)?);

    let mut time = Vec::new();
    let mut lines = Vec::new();
    let mut input = Vec::new();
    let mut output = Vec::new();
    for (row, record) in rdr.records().enumerate() {
        let record = record.map_err(|e| IdentifyError::csv(origin, e))?;
        let line = record_line(&record, row as u64 + 2);
        if record.len() != header.len() {
            return Err(IdentifyError::format(
                origin,
                line,
                format!(
                    "{} fields, but the header has {} columns",
                    record.len(),
                    header.len()
                ),
            ));
        }
        time.push(parse_field(origin, line, "time", &record[0])?);
        input.push(parse_field(origin, line, input_column, &record[ci])?);
        output.push(parse_field(origin, line, output_column, &record[co])?);
        lines.push(line);
    }
    let n = time.len();
    if n < 2 {
        return Err(IdentifyError::format(
            origin,
            1 + n as u64,
            format!("the record ends after {n} data row(s); at least 2 are needed"),
        ));
    }
    // First the steps against the median step: a dropped, repeated or reversed sample is
    // reported on its own line (the fitted period below would blame an earlier line).
    let mut steps: Vec<f64> = time.windows(2).map(|w| w[1] - w[0]).collect();
    steps.sort_by(f64::total_cmp);
    let typical = steps[steps.len() / 2];
    if !(typical.is_finite() && typical > 0.0) {
        return Err(IdentifyError::format(
            origin,
            lines[1],
            "the `time` column does not increase",
        ));
    }
    for i in 1..n {
        let step = time[i] - time[i - 1];
        if !(step > 0.5 * typical && step < 1.5 * typical) {
            return Err(IdentifyError::NonUniformTime {
                origin: origin.to_string(),
                line: lines[i],
                time_s: time[i],
                expected_s: time[i - 1] + typical,
            });
        }
    }
    // Then every time against the period fitted from the ends.
    let dt = (time[n - 1] - time[0]) / (n - 1) as f64;
    for i in 1..n {
        let expected = time[0] + i as f64 * dt;
        if (time[i] - expected).abs() > 1e-6 * expected.abs().max(1.0) + 1e-9 {
            return Err(IdentifyError::NonUniformTime {
                origin: origin.to_string(),
                line: lines[i],
                time_s: time[i],
                expected_s: expected,
            });
        }
    }
    Ok((1.0 / dt, input, output))
}
