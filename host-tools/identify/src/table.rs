//! The frequency-response table ([`FrfTable`]) and its CSV format.
//!
//! The format is defined in the crate documentation ([`crate`], "Frequency-response table
//! (CSV)").

use std::io::{Read, Write};
use std::path::Path;

use num_complex::Complex64;

use crate::error::{path_origin, IdentifyError, Result};

/// The CSV header's column names, in order; the fourth is optional.
pub const CSV_COLUMNS: [&str; 4] = ["frequency_hz", "magnitude", "phase_deg", "coherence"];

/// The name used in error messages for a table read from a stream.
const STREAM_ORIGIN: &str = "frequency-response table";

/// One row of a frequency-response table.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrfPoint {
    /// Frequency (Hz), finite and > 0.
    pub frequency_hz: f64,
    /// Magnitude, linear (not dB), in the response's own units (dimensionless for a tracking
    /// response, N/m for a force-per-displacement response); finite and >= 0.
    pub magnitude: f64,
    /// Phase (degrees), finite. [`FrfTable`] stores it unwrapped.
    pub phase_deg: f64,
    /// Ordinary coherence of the estimate at this frequency (dimensionless, 0..=1), if known.
    pub coherence: Option<f64>,
}

impl FrfPoint {
    /// The response as a complex number `magnitude · e^{j·phase}`.
    pub fn complex(&self) -> Complex64 {
        Complex64::from_polar(self.magnitude, self.phase_deg.to_radians())
    }
}

/// A validated frequency-response table.
///
/// Invariants: at least 2 points; frequencies finite, > 0 and strictly increasing; magnitudes
/// finite and >= 0; phases finite and unwrapped (consecutive phases differ by at most
/// 180°, see [`FrfTable::new`]); coherences, if present, on every point, finite and in
/// `[0, 1]`.
#[derive(Debug, Clone, PartialEq)]
pub struct FrfTable {
    points: Vec<FrfPoint>,
}

/// Shifts each phase (degrees) by a multiple of 360° so that consecutive phases differ by a
/// value in `(-180°, 180°]`. The first phase is kept; a phase that already satisfies this
/// is kept bit for bit.
pub fn unwrap_phase_deg(phase_deg: &mut [f64]) {
    for i in 1..phase_deg.len() {
        let prev = phase_deg[i - 1];
        let d = phase_deg[i] - prev;
        // k such that d + 360 k lies in (-180, 180].
        let k = -((d - 180.0) / 360.0).ceil();
        if k != 0.0 {
            phase_deg[i] += 360.0 * k;
        }
    }
}

fn check_finite(index: usize, what: &str, value: f64) -> Result<()> {
    if value.is_finite() {
        Ok(())
    } else {
        Err(IdentifyError::InvalidPoint {
            index,
            message: format!("{what} is not finite ({value})"),
        })
    }
}

impl FrfTable {
    /// Validates the points and builds a table; the phases are unwrapped (each shifted by a
    /// multiple of 360° so that consecutive phases differ by a value in `(-180°, 180°]`; the
    /// first point's phase is kept).
    ///
    /// Errors: fewer than 2 points; a non-finite value; a frequency that is not > 0 or not
    /// greater than the previous one; a negative magnitude; a coherence outside `[0, 1]`;
    /// coherence given on some points but not on others.
    pub fn new(mut points: Vec<FrfPoint>) -> Result<Self> {
        if points.len() < 2 {
            return Err(IdentifyError::TooFewPoints {
                count: points.len(),
            });
        }
        let with_coherence = points[0].coherence.is_some();
        for (i, p) in points.iter().enumerate() {
            check_finite(i, "frequency", p.frequency_hz)?;
            check_finite(i, "magnitude", p.magnitude)?;
            check_finite(i, "phase", p.phase_deg)?;
            if p.frequency_hz <= 0.0 {
                return Err(IdentifyError::InvalidPoint {
                    index: i,
                    message: format!("frequency {} Hz is not positive", p.frequency_hz),
                });
            }
            if i > 0 && p.frequency_hz <= points[i - 1].frequency_hz {
                return Err(IdentifyError::InvalidPoint {
                    index: i,
                    message: format!(
                        "frequency {} Hz is not greater than the previous point's {} Hz \
                         (frequencies must be strictly increasing)",
                        p.frequency_hz,
                        points[i - 1].frequency_hz
                    ),
                });
            }
            if p.magnitude < 0.0 {
                return Err(IdentifyError::InvalidPoint {
                    index: i,
                    message: format!("magnitude {} is negative", p.magnitude),
                });
            }
            match p.coherence {
                Some(c) => {
                    check_finite(i, "coherence", c)?;
                    if !(0.0..=1.0).contains(&c) {
                        return Err(IdentifyError::InvalidPoint {
                            index: i,
                            message: format!("coherence {c} is outside [0, 1]"),
                        });
                    }
                    if !with_coherence {
                        return Err(IdentifyError::InvalidPoint {
                            index: i,
                            message: "has a coherence but point 0 has none \
                                      (give it on all points or on none)"
                                .to_string(),
                        });
                    }
                }
                None if with_coherence => {
                    return Err(IdentifyError::InvalidPoint {
                        index: i,
                        message: "has no coherence but point 0 has one \
                                  (give it on all points or on none)"
                            .to_string(),
                    });
                }
                None => {}
            }
        }
        let mut phase: Vec<f64> = points.iter().map(|p| p.phase_deg).collect();
        unwrap_phase_deg(&mut phase);
        for (p, ph) in points.iter_mut().zip(phase) {
            p.phase_deg = ph;
        }
        Ok(Self { points })
    }

    /// Builds a table from complex response values at the given frequencies (Hz), with an
    /// optional coherence per frequency. Magnitude is `|H|`, phase `arg H` in degrees,
    /// unwrapped as in [`FrfTable::new`].
    ///
    /// Errors: slices of different lengths, a non-finite response, and everything that
    /// [`FrfTable::new`] rejects.
    pub fn from_response(
        frequency_hz: &[f64],
        response: &[Complex64],
        coherence: Option<&[f64]>,
    ) -> Result<Self> {
        if response.len() != frequency_hz.len() {
            return Err(IdentifyError::InvalidArgument(format!(
                "{} frequencies but {} response values",
                frequency_hz.len(),
                response.len()
            )));
        }
        if let Some(c) = coherence {
            if c.len() != frequency_hz.len() {
                return Err(IdentifyError::InvalidArgument(format!(
                    "{} frequencies but {} coherence values",
                    frequency_hz.len(),
                    c.len()
                )));
            }
        }
        let points = frequency_hz
            .iter()
            .zip(response)
            .enumerate()
            .map(|(i, (&f, h))| {
                if !(h.re.is_finite() && h.im.is_finite()) {
                    return Err(IdentifyError::InvalidPoint {
                        index: i,
                        message: format!("response {h} is not finite"),
                    });
                }
                Ok(FrfPoint {
                    frequency_hz: f,
                    magnitude: h.norm(),
                    phase_deg: h.arg().to_degrees(),
                    coherence: coherence.map(|c| c[i]),
                })
            })
            .collect::<Result<Vec<_>>>()?;
        Self::new(points)
    }

    /// The table's points, in increasing frequency, phases unwrapped.
    pub fn points(&self) -> &[FrfPoint] {
        &self.points
    }

    /// Whether the points carry a coherence (then all of them do).
    pub fn has_coherence(&self) -> bool {
        self.points[0].coherence.is_some()
    }

    /// The first and last frequency (Hz).
    pub fn frequency_range(&self) -> (f64, f64) {
        (
            self.points[0].frequency_hz,
            self.points[self.points.len() - 1].frequency_hz,
        )
    }

    /// The interpolated complex response at `frequency_hz` (Hz).
    ///
    /// Between two points the interpolation is linear in `log10(frequency)` of
    /// `ln(magnitude)` and of the unwrapped phase (degrees); where either of the two
    /// magnitudes is 0 the magnitude is interpolated linearly instead. At a table frequency
    /// the result is that point's `magnitude · e^{j·phase}` exactly.
    ///
    /// Errors: [`IdentifyError::OutOfRange`] outside `[first, last]` frequency (also for NaN).
    pub fn response(&self, frequency_hz: f64) -> Result<Complex64> {
        let (min, max) = self.frequency_range();
        if !(frequency_hz >= min && frequency_hz <= max) {
            return Err(IdentifyError::OutOfRange {
                frequency_hz,
                min,
                max,
            });
        }
        // First point with frequency >= the query; exists because the query is <= max.
        let i = self
            .points
            .partition_point(|p| p.frequency_hz < frequency_hz);
        let hi = self.points[i];
        if hi.frequency_hz == frequency_hz {
            return Ok(hi.complex());
        }
        // The query is > min, so i >= 1.
        let lo = self.points[i - 1];
        let u = (frequency_hz / lo.frequency_hz).ln() / (hi.frequency_hz / lo.frequency_hz).ln();
        let magnitude = if lo.magnitude > 0.0 && hi.magnitude > 0.0 {
            let (a, b) = (lo.magnitude.ln(), hi.magnitude.ln());
            (a + u * (b - a)).exp()
        } else {
            lo.magnitude + u * (hi.magnitude - lo.magnitude)
        };
        let phase_deg = lo.phase_deg + u * (hi.phase_deg - lo.phase_deg);
        Ok(Complex64::from_polar(magnitude, phase_deg.to_radians()))
    }

    /// Reads a table from a CSV file (format in the crate documentation). Accepts 3 or 4
    /// columns and a wrapped phase column (it is unwrapped). Errors name the file and line.
    pub fn read_csv(path: &Path) -> Result<Self> {
        let origin = path_origin(path);
        let file = std::fs::File::open(path).map_err(|e| IdentifyError::io(&origin, e))?;
        parse_csv(std::io::BufReader::new(file), &origin)
    }

    /// Reads a table in CSV format from any reader; as [`FrfTable::read_csv`].
    pub fn from_reader<R: Read>(reader: R) -> Result<Self> {
        parse_csv(reader, STREAM_ORIGIN)
    }

    /// Writes the table as a CSV file (format in the crate documentation); values are
    /// written in the shortest form that reads back to the same `f64`.
    pub fn write_csv(&self, path: &Path) -> Result<()> {
        let origin = path_origin(path);
        let file = std::fs::File::create(path).map_err(|e| IdentifyError::io(&origin, e))?;
        self.write_to(std::io::BufWriter::new(file), &origin)
    }

    /// Writes the table in CSV format to any writer; as [`FrfTable::write_csv`].
    pub fn to_writer<W: Write>(&self, writer: W) -> Result<()> {
        self.write_to(writer, STREAM_ORIGIN)
    }

    fn write_to<W: Write>(&self, mut writer: W, origin: &str) -> Result<()> {
        let with_coherence = self.has_coherence();
        let columns = if with_coherence { 4 } else { 3 };
        let mut text = CSV_COLUMNS[..columns].join(",");
        text.push('\n');
        for p in &self.points {
            text.push_str(&format_f64(p.frequency_hz));
            text.push(',');
            text.push_str(&format_f64(p.magnitude));
            text.push(',');
            text.push_str(&format_f64(p.phase_deg));
            if let Some(c) = p.coherence {
                text.push(',');
                text.push_str(&format_f64(c));
            }
            text.push('\n');
        }
        writer
            .write_all(text.as_bytes())
            .and_then(|()| writer.flush())
            .map_err(|e| IdentifyError::io(origin, e))
    }
}

/// Shortest representation that parses back to the same `f64`; plain decimal for ordinary
/// magnitudes, exponent notation for very small or large ones.
pub(crate) fn format_f64(x: f64) -> String {
    let a = x.abs();
    if a == 0.0 || (1e-4..1e15).contains(&a) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

fn parse_csv<R: Read>(reader: R, origin: &str) -> Result<FrfTable> {
    // The workspace's one reader (`mil_numerics::record`): separators, decimal commas,
    // comment lines and the errors' file, line and column as for every record.
    let table = mil_numerics::record::parse(reader, origin).map_err(|e| {
        IdentifyError::format(origin, e.line.unwrap_or(1) as u64, e.message.clone())
    })?;
    let names: Vec<&str> = table.names.iter().map(String::as_str).collect();
    let columns = names.len();
    if !(columns == 3 || columns == 4) || names[..] != CSV_COLUMNS[..columns] {
        return Err(IdentifyError::format(
            origin,
            1,
            format!(
                "header is `{}`; expected `frequency_hz,magnitude,phase_deg` \
                 with an optional fourth column `coherence`",
                names.join(",")
            ),
        ));
    }
    let mut points = Vec::new();
    let mut previous: Option<(f64, u64)> = None;
    for (row, &line) in table.lines.iter().enumerate() {
        let line = line as u64;
        let mut values = [0.0; 4];
        for (c, v) in values.iter_mut().zip(&table.columns) {
            *c = v[row];
        }
        let [frequency_hz, magnitude, phase_deg, coherence] = values;
        if frequency_hz <= 0.0 {
            return Err(IdentifyError::format(
                origin,
                line,
                format!("frequency {frequency_hz} Hz is not positive"),
            ));
        }
        if let Some((f_prev, line_prev)) = previous {
            if frequency_hz <= f_prev {
                let what = if frequency_hz == f_prev {
                    "duplicates"
                } else {
                    "is below"
                };
                return Err(IdentifyError::format(
                    origin,
                    line,
                    format!(
                        "frequency {frequency_hz} Hz {what} the frequency {f_prev} Hz on line \
                         {line_prev} (frequencies must be strictly increasing)"
                    ),
                ));
            }
        }
        previous = Some((frequency_hz, line));
        if magnitude < 0.0 {
            return Err(IdentifyError::format(
                origin,
                line,
                format!("magnitude {magnitude} is negative (magnitudes are linear, not dB)"),
            ));
        }
        if columns == 4 && !(0.0..=1.0).contains(&coherence) {
            return Err(IdentifyError::format(
                origin,
                line,
                format!("coherence {coherence} is outside [0, 1]"),
            ));
        }
        points.push(FrfPoint {
            frequency_hz,
            magnitude,
            phase_deg,
            coherence: (columns == 4).then_some(coherence),
        });
    }
    if points.len() < 2 {
        return Err(IdentifyError::format(
            origin,
            1 + points.len() as u64,
            format!(
                "the table ends after {} data row(s); at least 2 are needed",
                points.len()
            ),
        ));
    }
    FrfTable::new(points)
}
