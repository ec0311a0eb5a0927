//! What a plot's error bars show: the spread of the values (one standard deviation) or
//! the 95 % confidence interval of their mean, t_{0.975, n-1} s / sqrt(n) (Student's t,
//! since n is small: a few frames or sessions).

use serde::{Deserialize, Serialize};

/// Level of the confidence interval [`ErrorBars::Ci95`] draws.
pub const CI_LEVEL: f64 = 0.95;

/// The spread an error bar shows (`--error-bars`, `error_bars` in the settings).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ErrorBars {
    /// ± one sample standard deviation (n - 1).
    #[default]
    Std,
    /// ± the half-width of the 95 % confidence interval of the mean; no bar for n = 1.
    Ci95,
}

impl ErrorBars {
    /// The half-height of the bar of a mean of `n` values with sample standard deviation
    /// `std` (NaN: no bar).
    pub fn half_height(self, std: f64, n: usize) -> f64 {
        match self {
            ErrorBars::Std => std,
            ErrorBars::Ci95 if n < 2 => f64::NAN,
            ErrorBars::Ci95 => crate::fit::t_two_sided(CI_LEVEL, n - 1) * std / (n as f64).sqrt(),
        }
    }

    /// What the bars are, for a legend: `std` or `95 % CI`.
    pub fn label(self) -> &'static str {
        match self {
            ErrorBars::Std => "std",
            ErrorBars::Ci95 => "95 % CI",
        }
    }

    /// The setting's value: `std` or `ci95`.
    pub fn name(self) -> &'static str {
        match self {
            ErrorBars::Std => "std",
            ErrorBars::Ci95 => "ci95",
        }
    }

    /// True for the default (left out when the settings are written).
    pub fn is_default(&self) -> bool {
        *self == ErrorBars::default()
    }
}

impl std::str::FromStr for ErrorBars {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "std" => Ok(ErrorBars::Std),
            "ci95" => Ok(ErrorBars::Ci95),
            _ => Err(format!(
                "error bars `{s}`: give std (one standard deviation) or ci95 (95 % confidence interval of the mean)"
            )),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Half-heights against hand computations: t_{0.975} is 4.303 for 2 degrees of
    /// freedom and 2.776 for 4 (any t table).
    #[test]
    fn ci95_half_heights_match_a_hand_computation() {
        for (std, n, expected) in [
            (1.5, 3, 4.3027 * 1.5 / 3f64.sqrt()),
            (2.0, 5, 2.7764 * 2.0 / 5f64.sqrt()),
        ] {
            let got = ErrorBars::Ci95.half_height(std, n);
            assert!((got - expected).abs() < 1e-3, "n {n}: {got} vs {expected}");
        }
        assert!((ErrorBars::Ci95.half_height(1.5, 3) - 3.726).abs() < 1e-3);
        assert!(
            ErrorBars::Ci95.half_height(1.5, 1).is_nan(),
            "no bar for n = 1"
        );
        assert_eq!(ErrorBars::Std.half_height(1.5, 3), 1.5);
        assert_eq!("ci95".parse::<ErrorBars>(), Ok(ErrorBars::Ci95));
        assert_eq!("std".parse::<ErrorBars>(), Ok(ErrorBars::Std));
        assert!("sem".parse::<ErrorBars>().is_err());
    }
}
