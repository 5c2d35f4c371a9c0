//! The crate's error type.

use std::path::Path;

/// Everything that can go wrong in identification, table handling and record reading.
///
/// Messages name the file (or stream), the line and the value where there is one.
#[derive(Debug, thiserror::Error)]
pub enum IdentifyError {
    /// Reading or writing a file or stream failed.
    #[error("{origin}: {source}")]
    Io {
        /// The file (or a description of the stream) involved.
        origin: String,
        /// The underlying I/O error.
        #[source]
        source: std::io::Error,
    },
    /// A line of a CSV file (frequency-response table or time-series record) is invalid.
    #[error("{origin}: line {line}: {message}")]
    Format {
        /// The file (or a description of the stream) involved.
        origin: String,
        /// The 1-based line number in the file (the header is line 1).
        line: u64,
        /// What is wrong with that line.
        message: String,
    },
    /// A time-series CSV file lacks a requested column.
    #[error("{origin}: no column `{column}` (columns: {available})")]
    MissingColumn {
        /// The file (or a description of the stream) involved.
        origin: String,
        /// The requested column name.
        column: String,
        /// The columns that the header does have, comma-separated.
        available: String,
    },
    /// The `time` column of a time-series CSV file is not uniformly sampled.
    #[error(
        "{origin}: line {line}: time {time_s} s, expected {expected_s} s \
         (the `time` column must be uniformly sampled)"
    )]
    NonUniformTime {
        /// The file (or a description of the stream) involved.
        origin: String,
        /// The 1-based line number in the file (the header is line 1).
        line: u64,
        /// The time found on that line (s).
        time_s: f64,
        /// The time expected for uniform sampling (s).
        expected_s: f64,
    },
    /// A point given to [`crate::FrfTable::new`] is invalid.
    #[error("frequency-response point {index}: {message}")]
    InvalidPoint {
        /// The 0-based index of the point.
        index: usize,
        /// What is wrong with it.
        message: String,
    },
    /// A frequency-response table needs at least two points.
    #[error("a frequency-response table needs at least 2 points, got {count}")]
    TooFewPoints {
        /// The number of points given.
        count: usize,
    },
    /// Too few points of an estimate pass the frequency band and coherence selection of
    /// [`crate::FrfEstimate::to_table`].
    #[error(
        "only {count} estimate point(s) in [{f_min_hz}, {f_max_hz}] Hz have a finite response \
         and coherence >= {min_coherence} (at least 2 needed)"
    )]
    TooFewEstimatePoints {
        /// The number of points that passed.
        count: usize,
        /// Lower end of the band (Hz).
        f_min_hz: f64,
        /// Upper end of the band (Hz).
        f_max_hz: f64,
        /// The coherence threshold.
        min_coherence: f64,
    },
    /// A frequency outside a table's range was queried.
    #[error("{frequency_hz} Hz is outside the table's frequency range [{min}, {max}] Hz")]
    OutOfRange {
        /// The queried frequency (Hz).
        frequency_hz: f64,
        /// The table's first frequency (Hz).
        min: f64,
        /// The table's last frequency (Hz).
        max: f64,
    },
    /// A record's input and output have different lengths.
    #[error("record {record}: input has {input} samples but output has {output}")]
    LengthMismatch {
        /// The 0-based index of the record.
        record: usize,
        /// Number of input samples.
        input: usize,
        /// Number of output samples.
        output: usize,
    },
    /// A record is shorter than one Welch segment.
    #[error(
        "record {record}: {samples} samples is shorter than one segment of {segment_length} samples"
    )]
    RecordTooShort {
        /// The 0-based index of the record.
        record: usize,
        /// Number of samples in the record.
        samples: usize,
        /// The segment length asked for.
        segment_length: usize,
    },
    /// A record contains a NaN or infinite sample.
    #[error("record {record}: {signal} sample {index} is not finite ({value})")]
    NonFinite {
        /// The 0-based index of the record.
        record: usize,
        /// `"input"` or `"output"`.
        signal: &'static str,
        /// The 0-based sample index.
        index: usize,
        /// The offending value.
        value: f64,
    },
    /// An argument or option is outside its valid range.
    #[error("invalid argument: {0}")]
    InvalidArgument(String),
}

impl IdentifyError {
    pub(crate) fn io(origin: &str, source: std::io::Error) -> Self {
        Self::Io {
            origin: origin.to_string(),
            source,
        }
    }

    pub(crate) fn format(origin: &str, line: u64, message: impl Into<String>) -> Self {
        Self::Format {
            origin: origin.to_string(),
            line,
            message: message.into(),
        }
    }
}

/// The name used for a file in error messages.
pub(crate) fn path_origin(path: &Path) -> String {
    path.display().to_string()
}

/// Shorthand for results of this crate.
pub type Result<T, E = IdentifyError> = std::result::Result<T, E>;
