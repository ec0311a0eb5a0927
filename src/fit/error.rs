//! The errors of the fits, one enum for all of them.

/// Errors of the fits.
#[derive(Debug, Clone, thiserror::Error, PartialEq)]
pub enum FitError {
    /// Too few points.
    #[error("{what} needs at least {needed} points, got {got}")]
    TooFewPoints {
        /// The fit.
        what: &'static str,
        /// Minimum.
        needed: usize,
        /// Given.
        got: usize,
    },
    /// Points all at the same place, or non-finite.
    #[error("{what}: points are degenerate ({why})")]
    Degenerate {
        /// The fit.
        what: &'static str,
        /// Why.
        why: &'static str,
    },
    /// The power law needs positive pressures.
    #[error("power law y = a x^b + c needs x > 0 (got {x}): leave out zero or negative pressures")]
    NonPositiveX {
        /// The offending value.
        x: f64,
    },
    /// Too few distinct x values for the power law's three parameters: with one x (every
    /// video at one pressure) or two, any number of curves pass through the points, and
    /// a "fit" would be one of them, with a meaningless R^2.
    #[error("y = a x^b + c has 3 parameters and needs points at {needed} or more distinct x values (pressures), got {distinct} ({values}): measure at more pressures")]
    TooFewDistinctX {
        /// Distinct x values given.
        distinct: usize,
        /// Distinct x values needed.
        needed: usize,
        /// Those values, for the message.
        values: String,
    },
    /// x and y differ in length.
    #[error("x has {x} values and y has {y}")]
    LengthMismatch {
        /// Length of x.
        x: usize,
        /// Length of y.
        y: usize,
    },
}
