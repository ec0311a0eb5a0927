//! The pressure log of a ramp session: `pressure_log.csv`, (time, pressure) rows.

use std::path::Path;

use super::{pressure_column, split_csv, PressureUnit, SessionError};

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
/// strictly increasing, pressures >= 0, at least two rows.
pub fn read_pressure_log(path: &Path) -> Result<PressureLog, SessionError> {
    let bad = |why: String| SessionError::Manifest {
        path: path.to_path_buf(),
        why,
    };
    let text = std::fs::read_to_string(path).map_err(|e| bad(e.to_string()))?;
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty());
    let (_, header) = lines.next().ok_or_else(|| {
        bad("empty pressure log: write `time_s,pressure_kpa` and one row per sample".into())
    })?;
    let cols: Vec<String> = split_csv(header)
        .iter()
        .map(|c| c.to_ascii_lowercase())
        .collect();
    let t_col = cols
        .iter()
        .position(|c| c == "time_s")
        .ok_or_else(|| bad(format!("no `time_s` column in `{header}`")))?;
    let (p_col, unit) = pressure_column(&cols)
        .ok_or_else(|| bad(format!("no pressure column with a unit in `{header}`: name it pressure_bar, pressure_kpa or pressure_psi")))?;
    let mut log = PressureLog {
        unit,
        times_s: vec![],
        pressures_kpa: vec![],
    };
    for (i, line) in lines {
        let cells = split_csv(line);
        let num = |c: usize| {
            cells
                .get(c)
                .and_then(|v| v.parse::<f64>().ok())
                .filter(|v| v.is_finite())
        };
        let (Some(t), Some(p)) = (num(t_col), num(p_col)) else {
            return Err(bad(format!("line {}: `{line}` is not two numbers", i + 1)));
        };
        if p < 0.0 {
            return Err(bad(format!("line {}: negative pressure {p}", i + 1)));
        }
        if log.times_s.last().is_some_and(|&last| t <= last) {
            return Err(bad(format!("line {}: time {t} s does not increase", i + 1)));
        }
        log.times_s.push(t);
        log.pressures_kpa.push(p * unit.to_kpa());
    }
    if log.times_s.len() < 2 {
        return Err(bad("a pressure log needs at least two rows".into()));
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
}
