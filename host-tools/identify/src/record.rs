//! Reading time-series test records from CSV.

use std::io::Read;
use std::path::Path;

use crate::error::{path_origin, IdentifyError, Result};

/// The name used in error messages for a record read from a stream.
const STREAM_ORIGIN: &str = "time-series record";

/// Reads a time-series CSV file and returns `(sample_rate_hz, input, output)`: the sample
/// rate (Hz) and the two named columns, in file order.
///
/// The file has a header; the first column is `time` (s), uniformly sampled; the other
/// columns are named (e.g. `out/run.csv` of the `mil` tool). The workspace's one reader
/// (`mil_numerics::record`: comma, semicolon or tab; units in the header; decimal commas;
/// `#` comment lines) and time-base rule: every step within 0.2–1.8 of the median step (a
/// dropped or repeated sample is reported on its own line) and every time within 0.4 sample
/// intervals of the least-squares uniform grid (timing jitter and rounded times pass). The
/// sample period is `(t_last - t_first) / (rows - 1)`.
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
    let table = mil_numerics::record::parse(reader, origin).map_err(|e| {
        IdentifyError::format(origin, e.line.unwrap_or(1) as u64, e.message.clone())
    })?;
    table
        .require_time_first()
        .map_err(|why| IdentifyError::format(origin, 1, why))?;
    let find = |name: &str| {
        table
            .index(name)
            .ok_or_else(|| IdentifyError::MissingColumn {
                origin: origin.to_string(),
                column: name.to_string(),
                available: table.names.join(", "),
            })
    };
    let (ci, co) = (find(input_column)?, find(output_column)?);
    let n = table.rows();
    if n < 2 {
        return Err(IdentifyError::format(
            origin,
            1 + n as u64,
            format!("the record ends after {n} data row(s); at least 2 are needed"),
        ));
    }
    // The workspace's one time-base rule: a dropped, repeated or reversed sample is
    // reported on its own line; timing jitter up to 0.4 of a sample passes.
    let base = table
        .time_base()
        .map_err(|(line, e)| IdentifyError::NonUniformTime {
            origin: origin.to_string(),
            line: line as u64,
            time_s: e.time_s,
            expected_s: e.expected_s,
        })?;
    let mut columns = table.columns;
    let output = std::mem::take(&mut columns[co]);
    let input = std::mem::take(&mut columns[ci]);
    Ok((1.0 / base.dt, input, output))
}
