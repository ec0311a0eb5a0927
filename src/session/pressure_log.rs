//! The pressure log of a ramp session: `pressure_log.csv`, (time, pressure) rows.

use std::path::Path;

use super::{require_pressure_column, PressureUnit, SessionError};
use crate::table::{Table, TableError};

/// A regulator's pressure log for the ramp protocol: (time, pressure) rows, one video.
#[derive(Debug, Clone, PartialEq)]
pub struct PressureLog {
    /// Unit of the pressure column.
    pub unit: PressureUnit,
    /// Times, s, increasing.
    pub times_s: Vec<f64>,
    /// Pressures, kPa.
    pub pressures_kpa: Vec<f64>,
}

impl PressureLog {
    /// Pressure at `t` by linear interpolation; `None` outside the logged time span.
    pub fn pressure_at(&self, t: f64) -> Option<f64> {
        let (first, last) = (*self.times_s.first()?, *self.times_s.last()?);
        if !(t >= first && t <= last) {
            return None;
        }
        let i = self
            .times_s
            .partition_point(|&x| x <= t)
            .clamp(1, self.times_s.len() - 1);
        let (t0, t1) = (self.times_s[i - 1], self.times_s[i]);
        let (p0, p1) = (self.pressures_kpa[i - 1], self.pressures_kpa[i]);
        Some(if t1 > t0 {
            p0 + (p1 - p0) * (t - t0) / (t1 - t0)
        } else {
            p1
        })
    }
}

/// Reads a pressure log: header `time_s,pressure_<unit>` (bar, kpa or psi), times
/// strictly increasing, pressures >= 0, at least two rows. Errors in a row name its line
/// and column.
pub fn read_pressure_log(path: &Path) -> Result<PressureLog, SessionError> {
    let table = Table::read(path)?;
    if table.columns().is_empty() {
        return Err(SessionError::Manifest {
            path: path.to_path_buf(),
            why: "empty pressure log: write `time_s,pressure_kpa` and one row per sample".into(),
        });
    }
    let t_col = table.require(
        "time_s",
        "the header is `time_s,pressure_kpa` (or pressure_bar, pressure_psi)",
    )?;
    let (p_col, unit) = require_pressure_column(&table)?;
    let mut log = PressureLog {
        unit,
        times_s: vec![],
        pressures_kpa: vec![],
    };
    for row in 0..table.len() {
        let number = |col: usize| -> Result<f64, TableError> {
            let v = table.f64_at(row, col)?;
            if v.is_finite() {
                Ok(v)
            } else {
                Err(table.error_at(Some(row), Some(col), format!("{v} is not a finite number")))
            }
        };
        let t = number(t_col)?;
        let p = number(p_col)?;
        if p < 0.0 {
            return Err(table
                .error_at(
                    Some(row),
                    Some(p_col),
                    format!("negative pressure {p}: pressures are gauge pressures >= 0"),
                )
                .into());
        }
        if let Some(&last) = log.times_s.last() {
            if t <= last {
                return Err(table
                    .error_at(
                        Some(row),
                        Some(t_col),
                        format!(
                            "time {t} s does not increase (the row before is at {last} s): sort the log by time"
                        ),
                    )
                    .into());
            }
        }
        log.times_s.push(t);
        log.pressures_kpa.push(p * unit.to_kpa());
    }
    if log.times_s.len() < 2 {
        return Err(SessionError::Manifest {
            path: path.to_path_buf(),
            why: format!(
                "a pressure log needs at least two rows, this one has {}",
                log.times_s.len()
            ),
        });
    }
    Ok(log)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::session::PRESSURE_LOG;

    #[test]
    fn pressure_log_interpolates_and_checks() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join(PRESSURE_LOG);
        std::fs::write(&p, "time_s,pressure_kpa\n0,0\n10,2.5\n20,5\n").unwrap();
        let log = read_pressure_log(&p).unwrap();
        assert_eq!(log.pressure_at(5.0), Some(1.25));
        assert_eq!(log.pressure_at(20.0), Some(5.0));
        assert_eq!(log.pressure_at(20.5), None);
        std::fs::write(&p, "time_s,pressure_bar\n0,0\n1,0.1\n").unwrap();
        assert_eq!(read_pressure_log(&p).unwrap().pressure_at(1.0), Some(10.0));
        for bad in [
            "time_s,pressure\n0,1\n1,2\n",
            "time_s,pressure_kpa\n1,1\n0,2\n",
            "time_s,pressure_kpa\n0,x\n",
            "time_s,pressure_kpa\n0,1\n",
        ] {
            std::fs::write(&p, bad).unwrap();
            assert!(read_pressure_log(&p).is_err(), "{bad}");
        }
    }

    #[test]
    fn row_errors_name_the_line_and_column() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join(PRESSURE_LOG);
        for (text, needle) in [
            (
                "\u{feff}time_s,pressure_kpa\r\n0,1\r\n\r\n1,x\r\n",
                "pressure_log.csv: line 4, column pressure_kpa: `x` is not a number",
            ),
            (
                "time_s,pressure_kpa\n0,1\n1,-2\n",
                "pressure_log.csv: line 3, column pressure_kpa: negative pressure -2",
            ),
            (
                "time_s,pressure_kpa\n0,1\n0,2\n",
                "pressure_log.csv: line 3, column time_s: time 0 s does not increase",
            ),
            (
                "time_s,pressure_kpa\n0,1\ninf,2\n",
                "pressure_log.csv: line 3, column time_s: inf is not a finite number",
            ),
            (
                "t,pressure_kpa\n0,1\n1,2\n",
                "pressure_log.csv: line 1: no `time_s` column in the header `t,pressure_kpa`",
            ),
            (
                "time_s,p\n0,1\n1,2\n",
                "pressure_log.csv: line 1: no pressure column with a unit in the header `time_s,p`",
            ),
            ("\n \n", "empty pressure log"),
            (
                "time_s,pressure_kpa\n0,1\n",
                "at least two rows, this one has 1",
            ),
        ] {
            std::fs::write(&p, text).unwrap();
            let e = read_pressure_log(&p).unwrap_err().to_string();
            assert!(e.contains(needle), "{text:?}: {e}");
        }
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(128))]

        #[test]
        fn arbitrary_logs_parse_or_fail_without_panicking(
            bytes in proptest::collection::vec(
                proptest::sample::select(b"time_s,pressure_kpa\n\r\",0123.-e x\xff".to_vec()),
                0..200,
            )
        ) {
            let d = tempfile::tempdir().unwrap();
            let p = d.path().join(PRESSURE_LOG);
            for head in [&b""[..], b"time_s,pressure_kpa\n"] {
                std::fs::write(&p, [head, &bytes].concat()).unwrap();
                if let Ok(log) = read_pressure_log(&p) {
                    proptest::prop_assert!(log.times_s.len() >= 2);
                    proptest::prop_assert!(log.times_s.windows(2).all(|w| w[1] > w[0]));
                    proptest::prop_assert!(log.pressures_kpa.iter().all(|p| p.is_finite() && *p >= 0.0));
                }
            }
        }
    }
}
