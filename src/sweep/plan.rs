//! The plan file of a sweep, checked once, and the actuator config of each point.
//!
//! ```toml
//! base = "actuator.toml"        # optional: an actuator config (relative to the plan)
//! pressures_kpa = [50, 100]     # pressures whose results are kept per point
//! mesh_size_mm = 3              # optional override of the base's mesh
//! ramp_kpa = "10:100:10"        # optional ramp (default: the kept pressures)
//! blocked = false               # also the blocked-tip force (blocked_force_n@P)
//! analytic = false              # also the analytic chamber model's columns
//! [design]
//! kind = "factorial"            # or "lhs" with n = 16 and seed = 1
//! [[factor]]
//! name = "geometry.f"           # section.field of the actuator config
//! levels = [4, 6]               # factorial; lhs: range = [2.0, 8.0]
//! [cluster]                     # optional: resources of --emit slurm
//! cpus_per_task = 1
//! memory_mb = 2000
//! time_limit = "02:00:00"
//! ```
//!
//! A factor may name any field of the actuator config (`geometry.*`, `material.*`,
//! `mesh.size_mm`, `load.gravity`, `solver.*`, `layer.NAME.*`, or a bare field of one
//! section), as every command names one ([`crate::fem::params`]): the base config is
//! turned into a TOML table, the field set, and the table read back as a config, so a
//! misspelt field is refused by the config's own checks. Integer fields
//! (`geometry.chambers`, `layer.N.strips`) stay integers; a Latin-hypercube value for one
//! is rounded.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::design::{DesignKind, Factor, FactorLevels};
use super::SweepError;
use crate::fem::actuator::{parse_range, ActuatorConfig};
use crate::fem::params;

/// Resources of one point on a cluster (`--emit slurm`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ClusterSettings {
    /// Job name.
    pub job_name: String,
    /// CPUs per point (threads of its solver).
    pub cpus_per_task: usize,
    /// Memory per point, MB.
    pub memory_mb: u64,
    /// Wall-clock limit per point, Slurm's `[D-]HH:MM:SS`.
    pub time_limit: String,
    /// Partition, when the cluster wants one.
    pub partition: Option<String>,
    /// Account, when the cluster wants one.
    pub account: Option<String>,
    /// Most points running at once (the `%N` of the job array).
    pub max_concurrent: Option<usize>,
}

/// Default memory of a point on a cluster, MB: a default-mesh ramp peaks well below it.
pub const DEFAULT_CLUSTER_MEMORY_MB: u64 = 2000;

impl Default for ClusterSettings {
    fn default() -> Self {
        Self {
            job_name: "bendscope-sweep".into(),
            cpus_per_task: 1,
            memory_mb: DEFAULT_CLUSTER_MEMORY_MB,
            time_limit: "02:00:00".into(),
            partition: None,
            account: None,
            max_concurrent: None,
        }
    }
}

/// A pressure whose results are kept: its label as written in the plan (the `P` of the
/// `radius_mm@P` columns) and its value.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct KeptPressure {
    /// As written in the plan (`50`, `62.5`).
    pub label: String,
    /// kPa.
    pub kpa: f64,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct PlanFile {
    base: Option<PathBuf>,
    pressures_kpa: Vec<toml::Value>,
    mesh_size_mm: Option<f64>,
    ramp_kpa: Option<String>,
    #[serde(default)]
    blocked: bool,
    #[serde(default)]
    analytic: bool,
    design: DesignFile,
    #[serde(default)]
    factor: Vec<FactorFile>,
    #[serde(default)]
    cluster: ClusterSettings,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct DesignFile {
    kind: String,
    n: Option<usize>,
    seed: Option<u64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct FactorFile {
    name: String,
    levels: Option<Vec<toml::Value>>,
    range: Option<[f64; 2]>,
}

/// A checked plan.
#[derive(Debug, Clone)]
pub struct Plan {
    /// The plan file.
    pub path: PathBuf,
    /// The base actuator with the plan's mesh and ramp applied.
    pub base: ActuatorConfig,
    /// Pressures whose results go into designs.csv.
    pub pressures: Vec<KeptPressure>,
    /// Also the blocked-tip force.
    pub blocked: bool,
    /// Also the analytic model's columns.
    pub analytic: bool,
    /// The design.
    pub design: DesignKind,
    /// The factors, in plan order.
    pub factors: Vec<Factor>,
    /// Cluster resources.
    pub cluster: ClusterSettings,
}

/// The text of a factor level or pressure as written in the plan: integers as integers,
/// floats in their shortest exact form, booleans and strings as they are.
pub fn value_text(v: &toml::Value) -> String {
    match v {
        toml::Value::String(s) => s.clone(),
        toml::Value::Integer(i) => i.to_string(),
        toml::Value::Float(f) => format!("{f}"),
        other => other.to_string(),
    }
}

/// `cfg` with the field `name` set to `value` ([`crate::fem::params::config_with`]: the
/// naming and type rules of every command that sets a config field by name).
pub fn config_with(
    cfg: &ActuatorConfig,
    name: &str,
    value: &toml::Value,
) -> Result<ActuatorConfig, String> {
    params::config_with(cfg, name, value).map_err(|e| format!("{}: {}", e.name, e.why))
}

fn plan_err(path: &Path, why: impl Into<String>) -> SweepError {
    SweepError::Plan {
        path: path.to_path_buf(),
        why: why.into(),
    }
}

impl Plan {
    /// Reads and checks a plan file.
    pub fn load(path: &Path) -> Result<Plan, SweepError> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| plan_err(path, format!("cannot read it: {e}")))?;
        Self::parse(&text, path)
    }

    /// Checks a plan's text (`path` locates `base` and names the plan in messages).
    pub fn parse(text: &str, path: &Path) -> Result<Plan, SweepError> {
        let file: PlanFile = toml::from_str(text).map_err(|e| {
            plan_err(
                path,
                format!(
                    "{} (see examples/plans/two-factor.toml)",
                    e.message().trim()
                ),
            )
        })?;
        let mut base = match &file.base {
            Some(b) => {
                let b = path.parent().unwrap_or(Path::new(".")).join(b);
                let t = std::fs::read_to_string(&b).map_err(|e| {
                    plan_err(path, format!("cannot read base {}: {e}", b.display()))
                })?;
                toml::from_str::<ActuatorConfig>(&t).map_err(|e| {
                    plan_err(
                        path,
                        format!(
                            "base {} is not an actuator config: {}",
                            b.display(),
                            e.message().trim()
                        ),
                    )
                })?
            }
            None => ActuatorConfig::default(),
        };
        if let Some(h) = file.mesh_size_mm {
            base.mesh.size_mm = h;
        }
        if file.pressures_kpa.is_empty() {
            return Err(plan_err(
                path,
                "pressures_kpa is empty: list the pressures to keep, e.g. [50, 100]",
            ));
        }
        let mut pressures = Vec::new();
        for v in &file.pressures_kpa {
            let kpa = v
                .as_float()
                .or_else(|| v.as_integer().map(|i| i as f64))
                .filter(|p| p.is_finite() && *p >= 0.0)
                .ok_or_else(|| {
                    plan_err(
                        path,
                        format!("pressures_kpa: {v} is not a pressure >= 0 kPa"),
                    )
                })?;
            if pressures.iter().any(|p: &KeptPressure| p.kpa == kpa) {
                return Err(plan_err(
                    path,
                    format!("pressures_kpa: {kpa} is listed twice"),
                ));
            }
            pressures.push(KeptPressure {
                label: value_text(v),
                kpa,
            });
        }
        base.load.pressures_kpa = match &file.ramp_kpa {
            Some(r) => {
                let ramp = parse_range(r, "ramp_kpa").map_err(|e| plan_err(path, e.to_string()))?;
                if let Some(p) = pressures
                    .iter()
                    .find(|p| !ramp.iter().any(|r| (r - p.kpa).abs() < 1e-9))
                {
                    return Err(plan_err(
                        path,
                        format!(
                            "kept pressure {} kPa is not a step of ramp_kpa '{r}': add it",
                            p.label
                        ),
                    ));
                }
                r.clone()
            }
            None => {
                let mut kpa: Vec<f64> = pressures.iter().map(|p| p.kpa).collect();
                kpa.sort_by(f64::total_cmp);
                kpa.iter()
                    .map(|p| format!("{p}"))
                    .collect::<Vec<_>>()
                    .join(",")
            }
        };
        base.validate()
            .map_err(|e| plan_err(path, format!("base config: {e}")))?;
        let design = match file.design.kind.to_ascii_lowercase().as_str() {
            "factorial" => DesignKind::Factorial,
            "lhs" => DesignKind::Lhs {
                n: file.design.n.filter(|n| *n > 0).ok_or_else(|| {
                    plan_err(
                        path,
                        "design kind \"lhs\" needs n = <points> (a positive count)",
                    )
                })?,
                seed: file.design.seed.unwrap_or(1),
            },
            other => {
                return Err(plan_err(
                    path,
                    format!("design kind '{other}': use \"factorial\" or \"lhs\""),
                ))
            }
        };
        if file.factor.is_empty() {
            return Err(plan_err(
                path,
                "no [[factor]]: name at least one config field to vary",
            ));
        }
        let mut factors = Vec::new();
        let mut fields = Vec::new();
        let doc = params::config_document(&base).map_err(|e| plan_err(path, e.why))?;
        for f in &file.factor {
            let field = params::resolve(&doc, &f.name)
                .map_err(|e| plan_err(path, format!("factor {}: {}", e.name, e.why)))?;
            // `f` and `geometry.f` are one field.
            if fields.contains(&field) {
                return Err(plan_err(path, format!("factor {} is listed twice", f.name)));
            }
            let integer = params::value_at(&doc, &field)
                .map_err(|e| plan_err(path, format!("factor {}: {}", e.name, e.why)))?
                .is_some_and(|v| v.is_integer());
            fields.push(field);
            let levels = match (&design, &f.levels, f.range) {
                (DesignKind::Factorial, Some(l), _) if !l.is_empty() => {
                    // A NaN or inf level is no design (the point would run something else).
                    if let Some(v) = l
                        .iter()
                        .find_map(|v| v.as_float().filter(|f| !f.is_finite()))
                    {
                        return Err(plan_err(
                            path,
                            format!(
                                "factor {}: level {} is not a finite number: give finite levels, e.g. levels = [2, 4]",
                                f.name,
                                if v.is_nan() { "nan".to_string() } else { v.to_string() }
                            ),
                        ));
                    }
                    FactorLevels::Levels(l.clone())
                }
                (DesignKind::Factorial, _, _) => {
                    return Err(plan_err(
                        path,
                        format!("factor {}: a factorial design needs levels = [...]", f.name),
                    ))
                }
                (DesignKind::Lhs { .. }, _, Some([lo, hi]))
                    if lo.is_finite() && hi.is_finite() && lo <= hi =>
                {
                    FactorLevels::Range { lo, hi, integer }
                }
                (DesignKind::Lhs { .. }, _, _) => {
                    return Err(plan_err(
                        path,
                        format!(
                            "factor {}: a Latin hypercube needs range = [low, high]",
                            f.name
                        ),
                    ))
                }
            };
            // Every level (or both range ends) must make a config: a misspelt field or a
            // wrong type is a mistake in the plan, not a failed point.
            let probes: Vec<toml::Value> = match &levels {
                FactorLevels::Levels(l) => l.clone(),
                FactorLevels::Range { lo, hi, integer } => [lo, hi]
                    .iter()
                    .map(|v| {
                        if *integer {
                            toml::Value::Integer(v.round() as i64)
                        } else {
                            toml::Value::Float(**v)
                        }
                    })
                    .collect(),
            };
            for v in &probes {
                config_with(&base, &f.name, v)
                    .map_err(|why| plan_err(path, format!("factor {why}")))?;
            }
            factors.push(Factor {
                name: f.name.clone(),
                levels,
            });
        }
        let c = &file.cluster;
        if c.cpus_per_task == 0 || c.memory_mb == 0 || c.time_limit.trim().is_empty() {
            return Err(plan_err(
                path,
                "[cluster]: cpus_per_task and memory_mb must be positive and time_limit set",
            ));
        }
        Ok(Plan {
            path: path.to_path_buf(),
            base,
            pressures,
            blocked: file.blocked,
            analytic: file.analytic,
            design,
            factors,
            cluster: file.cluster,
        })
    }

    /// The config of a point: the base with each factor set to its value.
    pub fn point_config(&self, values: &[toml::Value]) -> Result<ActuatorConfig, String> {
        let mut cfg = self.base.clone();
        for (f, v) in self.factors.iter().zip(values) {
            cfg = config_with(&cfg, &f.name, v)?;
        }
        cfg.validate().map_err(|e| e.to_string())?;
        Ok(cfg)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Plan, SweepError> {
        Plan::parse(text, Path::new("plan.toml"))
    }

    const TWO: &str = r#"
pressures_kpa = [50, 62.5]
mesh_size_mm = 5
[design]
kind = "factorial"
[[factor]]
name = "geometry.f"
levels = [4, 6.5]
[[factor]]
name = "geometry.chambers"
levels = [8, 9]
"#;

    #[test]
    fn a_factorial_plan_sets_the_named_fields_with_their_types() {
        let p = parse(TWO).unwrap();
        assert_eq!(p.base.mesh.size_mm, 5.0);
        assert_eq!(p.base.load.pressures_kpa, "50,62.5");
        let labels: Vec<&str> = p.pressures.iter().map(|p| p.label.as_str()).collect();
        assert_eq!(labels, ["50", "62.5"]);
        let cfg = p
            .point_config(&[toml::Value::Integer(4), toml::Value::Float(8.0)])
            .unwrap();
        assert_eq!(cfg.geometry.f, 4.0);
        assert_eq!(cfg.geometry.chambers, 8);
        let gravity = config_with(&cfg, "load.gravity", &toml::Value::Boolean(false)).unwrap();
        assert!(!gravity.load.gravity);
        let c1 = config_with(&cfg, "material.c1", &toml::Value::Float(0.2)).unwrap();
        assert_eq!(c1.material.c1, Some(0.2));
    }

    /// A family's layers are factors too: by name or number from 1.
    #[test]
    fn a_layer_of_a_family_is_named_by_its_name_or_number() {
        use crate::fem::family::{defaults, Family};
        let strap = defaults(Family::Strap);
        let t = config_with(
            &strap,
            "layer.fabric.thickness_mm",
            &toml::Value::Float(0.2),
        )
        .unwrap();
        assert_eq!(
            (t.layer[0].thickness_mm, t.layer[1].thickness_mm),
            (1.0, 0.2)
        );
        let e = config_with(
            &strap,
            "layer.1.youngs_modulus_mpa",
            &toml::Value::Float(3500.0),
        )
        .unwrap();
        assert_eq!(e.layer[0].youngs_modulus_mpa, 3500.0);
        let bad =
            config_with(&strap, "layer.3.thickness_mm", &toml::Value::Float(0.2)).unwrap_err();
        assert!(bad.contains("no entry '3' in 'layer' (2 there"), "{bad}");
        let bad = config_with(&strap, "layer.thickness_mm", &toml::Value::Float(0.2)).unwrap_err();
        assert!(bad.contains("'layer' is a list"), "{bad}");
        let fit =
            crate::fit_model::params::parse_free("layer.pla.youngs_modulus_mpa=2000:6000", &strap)
                .unwrap();
        assert_eq!((fit[0].initial, fit[0].lower), (4000.0, 2000.0));
        let c = crate::fit_model::params::with_values(&strap, &fit, &[3000.0]).unwrap();
        assert_eq!(c.layer[0].youngs_modulus_mpa, 3000.0);
    }

    /// A NaN or inf level, or a mesh size whose mesh would not fit, is refused when the
    /// plan is read, naming the factor or the size; a NaN set through a layer's dotted
    /// name is refused, never run as a default layer.
    #[test]
    fn a_non_finite_level_or_an_unbounded_mesh_is_refused_when_the_plan_is_read() {
        for (from, to, needle) in [
            (
                "[4, 6.5]",
                "[nan, 6.5]",
                "factor geometry.f: level nan is not a finite number",
            ),
            (
                "[4, 6.5]",
                "[4, -inf]",
                "factor geometry.f: level -inf is not a finite number",
            ),
            (
                "mesh_size_mm = 5",
                "mesh_size_mm = 1e-9",
                "mesh size: 1e-9 mm would make about",
            ),
            (
                "mesh_size_mm = 5",
                "mesh_size_mm = nan",
                "mesh size: NaN mm: must be positive",
            ),
        ] {
            let e = parse(&TWO.replace(from, to)).unwrap_err().to_string();
            assert!(e.contains(needle), "{to}: {e}");
        }
        use crate::fem::family::{defaults, Family};
        let glove = defaults(Family::Glove);
        let e = config_with(
            &glove,
            "layer.paper.youngs_modulus_mpa",
            &toml::Value::Float(f64::NAN),
        )
        .unwrap_err();
        assert!(
            e.contains("[layer.1] youngs_modulus_mpa = nan: not a finite number"),
            "{e}"
        );
    }

    #[test]
    fn mistakes_in_a_plan_are_refused_with_the_field_named() {
        let e = parse(&TWO.replace("geometry.f\"", "geometry.ff\"")).unwrap_err();
        assert!(e.to_string().contains("ff"), "{e}");
        // A bare field of one section is that field, once.
        let bare = parse(&TWO.replace("geometry.f\"", "f\"")).unwrap();
        let cfg = bare
            .point_config(&[toml::Value::Float(5.0), toml::Value::Integer(9)])
            .unwrap();
        assert_eq!((cfg.geometry.f, cfg.geometry.chambers), (5.0, 9));
        let twice = TWO.replace("geometry.chambers", "f");
        let e = parse(&twice).unwrap_err();
        assert!(e.to_string().contains("factor f is listed twice"), "{e}");
        let e = parse(&TWO.replace("geometry.f\"", "zz\"")).unwrap_err();
        assert!(
            e.to_string().contains("factor zz: no such parameter"),
            "{e}"
        );
        let e = parse(&TWO.replace("[8, 9]", "[8.5, 9]")).unwrap_err();
        assert!(e.to_string().contains("whole number"), "{e}");
        let e = parse(&TWO.replace("factorial", "grid")).unwrap_err();
        assert!(e.to_string().contains("lhs"), "{e}");
        let e = parse(&TWO.replace("[50, 62.5]", "[50, -1]")).unwrap_err();
        assert!(e.to_string().contains("-1"), "{e}");
        let e = parse(&format!("ramp_kpa = \"10:40:10\"\n{TWO}")).unwrap_err();
        assert!(e.to_string().contains("ramp_kpa"), "{e}");
    }
}
