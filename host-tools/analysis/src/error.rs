//! Errors of the analysis.

/// Everything that can go wrong while describing or analysing a MiL set-up.
#[derive(Debug, thiserror::Error)]
pub enum AnalysisError {
    /// A set-up is inconsistent or incomplete; the message names the field.
    #[error("invalid set-up: {0}")]
    Setup(String),
    /// A matrix that must be inverted is singular at the given frequency.
    #[error("singular {what} at {frequency_hz} Hz")]
    Singular {
        /// Which matrix.
        what: &'static str,
        /// Frequency (Hz).
        frequency_hz: f64,
    },
    /// A frequency response table could not be read or evaluated.
    #[error(transparent)]
    Table(#[from] mil_identify::IdentifyError),
    /// Discretisation of a continuous model failed.
    #[error(transparent)]
    Discretise(#[from] mil_discretise::DiscretiseError),
    /// A filter design failed or produced a filter that may not be exported.
    #[error("filter design: {0}")]
    Design(String),
    /// A command-filter file is not one model-core can run.
    #[error("command-filter file: {0}")]
    FilterFile(String),
    /// Writing a file failed (the message names it).
    #[error(transparent)]
    Write(std::io::Error),
    /// Reading a set-up file failed.
    #[error("reading {path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The cause.
        source: std::io::Error,
    },
    /// A set-up file is not valid TOML or does not match the schema.
    #[error("parsing {path}: {message}")]
    Parse {
        /// The file.
        path: String,
        /// What is wrong.
        message: String,
    },
}

impl From<mil_params::ParamError> for AnalysisError {
    fn from(e: mil_params::ParamError) -> Self {
        Self::Setup(e.0)
    }
}

/// Result with [`AnalysisError`].
pub type Result<T> = std::result::Result<T, AnalysisError>;

/// Shorthand for a set-up error.
pub(crate) fn setup_error(message: impl Into<String>) -> AnalysisError {
    AnalysisError::Setup(message.into())
}
