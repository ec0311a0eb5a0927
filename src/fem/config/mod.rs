//! The actuator's configuration types: what a config file's sections hold
//! (`[geometry]`, `[material]`, `[mesh]`, `[load]`, `[solver]`, `[[layer]]`, `[contact]`,
//! `[tube]`, `[finger]`, `[cavities]`, `[threads]`), their defaults and the checks each section makes on its own.
//!
//! A level below everything that builds or reads a model: this module imports no builder;
//! reading a document over a family's defaults and the checks across sections are
//! [`super::actuator`]'s.

pub mod cavities;
pub mod finger;
pub mod source;
pub mod threads;
pub mod tube;

use serde::{Deserialize, Serialize};

use super::contact::ContactConfig;
use super::layer::LayerConfig;
use super::material::{MaterialPreset, Yeoh, DEFAULT_BULK_TO_SHEAR};
use super::solve::NewtonSettings;
use super::FemError;
pub use source::{ClampPlane, MarkerLine};
pub use tube::TubeConfig;

/// An actuator family (`[geometry] family`): a published design, a preset of one of the
/// shapes ([`super::shapes`], where each family's name, defaults and mesh are; reading a
/// name checks it against them).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Family(&'static str);

impl Family {
    /// The family called `name` (a shape's preset: [`super::shapes::Shape::families`]).
    pub(crate) const fn named(name: &'static str) -> Family {
        Family(name)
    }

    /// The name in configs and on the command line.
    pub fn name(self) -> &'static str {
        self.0
    }
}

/// The reference actuator's (method.md §4), a config without a family's; the registry's
/// first ([`super::shapes::REGISTRY`]).
impl Default for Family {
    fn default() -> Self {
        Family("pneunets")
    }
}

impl std::fmt::Display for Family {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl Serialize for Family {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.name())
    }
}

/// Geometry of the actuator, mm; field names are those of method.md §4.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Geometry {
    /// The actuator family ([`super::family`]): its defaults fill what a config leaves out.
    pub family: Family,
    /// Number of chambers (blocks along x).
    pub chambers: usize,
    /// Length (x).
    pub b: f64,
    /// Width (y).
    pub i: f64,
    /// Bottom thickness: solid below the channel.
    pub f: f64,
    /// Channel height.
    pub m: f64,
    /// Channel width (y).
    pub p: f64,
    /// Channel length (x), centred.
    pub r: f64,
    /// Profile length of the first and last chamber.
    pub c: f64,
    /// Profile length of the other chambers.
    pub g: f64,
    /// Gap between chambers.
    pub d: f64,
    /// Chamber cavity length (x).
    pub e: f64,
    /// Chamber cavity width (y).
    pub l: f64,
    /// Chamber cavity height (z), from the channel top.
    pub n: f64,
    /// Top wall above the cavities (a = f + m + n + top_wall).
    pub top_wall: f64,
    /// Material between the channel top and the bottom of a gap.
    pub roof: f64,
    /// The mesh or CAD file of an imported actuator (`family = "mesh"`): a gmsh mesh
    /// (.msh) or a file gmsh meshes (.geo, .step, .stp, .iges, .igs, .brep); a relative
    /// path is relative to the config file.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub file: Option<std::path::PathBuf>,
    /// A .geo file's numbers (its `DefineConstant`s), passed to gmsh as `-setnumber`.
    #[serde(skip_serializing_if = "std::collections::BTreeMap::is_empty")]
    pub parameters: std::collections::BTreeMap<String, f64>,
    /// Where a file without a `clamp` group is clamped: its face on that side.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub clamp: Option<ClampPlane>,
    /// Markers of a file without a `markers` group: points on a line.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub markers: Option<MarkerLine>,
}

impl Default for Geometry {
    fn default() -> Self {
        Self {
            family: Family::default(),
            chambers: 9,
            b: 116.0,
            i: 15.0,
            f: 6.0,
            m: 2.0,
            p: 7.0,
            r: 105.0,
            c: 13.75,
            g: 11.5,
            d: 1.0,
            e: 5.0,
            l: 11.0,
            n: 12.0,
            top_wall: 3.5,
            roof: 1.0,
            file: None,
            parameters: Default::default(),
            clamp: None,
            markers: None,
        }
    }
}

/// Most chambers a geometry may have (each is a block of the mesh).
pub const MAX_CHAMBERS: usize = 1000;

pub(crate) fn bad(name: &str, why: String) -> FemError {
    FemError::Parameter {
        name: name.to_string(),
        why,
    }
}

impl Geometry {
    /// Total height a.
    pub fn height(&self) -> f64 {
        self.f + self.m + self.n + self.top_wall
    }

    /// Length taken by the chambers and gaps: 2c + (N-2) g + (N-1) d.
    pub fn chambers_length(&self) -> f64 {
        let n = self.chambers as f64;
        2.0 * self.c + (n - 2.0) * self.g + (n - 1.0) * self.d
    }

    /// x extent of every chamber block.
    pub fn blocks(&self) -> Vec<(f64, f64)> {
        let mut x = 0.0;
        (0..self.chambers)
            .map(|k| {
                let len = if k == 0 || k + 1 == self.chambers {
                    self.c
                } else {
                    self.g
                };
                let span = (x, x + len);
                x += len + self.d;
                span
            })
            .collect()
    }

    /// x extent of every chamber's cavity (length e, centred in its block).
    pub fn cavities(&self) -> Vec<(f64, f64)> {
        self.blocks()
            .iter()
            .map(|(a, b)| (0.5 * (a + b) - 0.5 * self.e, 0.5 * (a + b) + 0.5 * self.e))
            .collect()
    }

    /// x of the marker lines: centres of chambers 2..N.
    pub fn marker_x(&self) -> Vec<f64> {
        self.blocks()
            .iter()
            .skip(1)
            .map(|(a, b)| 0.5 * (a + b))
            .collect()
    }

    /// z of the markers: mid cavity height.
    pub fn marker_z(&self) -> f64 {
        self.f + self.m + 0.5 * self.n
    }

    /// Checks that the numbers describe a buildable actuator.
    pub fn validate(&self) -> Result<(), FemError> {
        source::validate(&self.parameters, self.markers.as_ref())?;
        let sizes = [
            ("b", self.b),
            ("i", self.i),
            ("f", self.f),
            ("m", self.m),
            ("p", self.p),
            ("r", self.r),
            ("c", self.c),
            ("g", self.g),
            ("d", self.d),
            ("e", self.e),
            ("l", self.l),
            ("n", self.n),
            ("top_wall", self.top_wall),
        ];
        for (name, v) in sizes {
            if !(v.is_finite() && v > 0.0) {
                return Err(bad(name, format!("{v} mm: sizes must be positive")));
            }
        }
        if !(self.roof.is_finite() && self.roof >= 0.0) {
            return Err(bad("roof", format!("{} mm: must be >= 0", self.roof)));
        }
        if self.chambers > MAX_CHAMBERS {
            return Err(bad(
                "chambers",
                format!("{}: use at most {MAX_CHAMBERS}", self.chambers),
            ));
        }
        if self.chambers < 2 {
            return Err(bad(
                "chambers",
                format!("{}: need at least 2 (the first is clamped)", self.chambers),
            ));
        }
        for (name, cavity, body) in [("l", self.l, self.i), ("p", self.p, self.i)] {
            if cavity >= body {
                return Err(bad(
                    name,
                    format!("{cavity} mm is not narrower than the body width i = {body} mm: the side walls would vanish"),
                ));
            }
        }
        let inner = if self.chambers > 2 { self.g } else { self.c };
        if self.e >= inner.min(self.c) {
            return Err(bad(
                "e",
                format!(
                    "cavity length {} mm does not fit in a chamber of {} mm: walls would vanish",
                    self.e,
                    inner.min(self.c)
                ),
            ));
        }
        let needed = self.chambers_length();
        if needed > self.b + 1e-9 {
            return Err(bad(
                "chambers",
                format!(
                    "{} chambers need 2c + (N-2)g + (N-1)d = {needed} mm but the length b is {} mm: lower the count or the sizes, or raise b",
                    self.chambers, self.b
                ),
            ));
        }
        if self.r >= self.b {
            return Err(bad(
                "r",
                format!(
                    "channel length {} mm must be shorter than b = {} mm",
                    self.r, self.b
                ),
            ));
        }
        let x0 = 0.5 * (self.b - self.r);
        let cavity_ends = self.blocks().into_iter().map(|(a, b)| {
            let mid = 0.5 * (a + b);
            (mid - 0.5 * self.e, mid + 0.5 * self.e)
        });
        if let Some((k, _)) = cavity_ends
            .enumerate()
            .find(|(_, (lo, hi))| *hi < x0 || *lo > x0 + self.r)
        {
            return Err(bad(
                "r",
                format!(
                    "the channel ({} mm long, centred) does not reach chamber {}: raise r",
                    self.r,
                    k + 1
                ),
            ));
        }
        if self.roof >= self.n + self.top_wall {
            return Err(bad(
                "roof",
                format!("{} mm leaves no gap between the chambers", self.roof),
            ));
        }
        Ok(())
    }
}

/// Material of the actuator: a preset, optionally with coefficients overridden.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MaterialConfig {
    /// Named Yeoh set of method.md §4.
    pub preset: MaterialPreset,
    /// Overrides C1, MPa.
    pub c1: Option<f64>,
    /// Overrides C2, MPa.
    pub c2: Option<f64>,
    /// Overrides C3, MPa.
    pub c3: Option<f64>,
    /// Bulk modulus, MPa; default 1000 μ0 = 2000 C1.
    pub bulk_modulus_mpa: Option<f64>,
    /// Density, g/cm³ (gravity load).
    pub density_g_cm3: f64,
    /// Tensile strength, MPa (safety factor).
    pub tensile_strength_mpa: f64,
    /// Factor on every coefficient (C1, C2, C3 and the bulk modulus): the whole strain
    /// energy scaled, the stiffness fitted by `bendscope fit-model` (`material.scale`).
    pub scale: f64,
    /// The materials of an imported mesh's named volumes (`[material.NAME]`, each a table
    /// as this one over the defaults, not over `[material]`); a volume without its own
    /// table takes this one. Read and written beside the derive, by
    /// [`super::actuator`] and [`ActuatorConfig`]'s `Serialize`.
    #[serde(skip)]
    pub named: std::collections::BTreeMap<String, MaterialConfig>,
}

impl Default for MaterialConfig {
    fn default() -> Self {
        Self {
            preset: MaterialPreset::Proposed,
            c1: None,
            c2: None,
            c3: None,
            bulk_modulus_mpa: None,
            density_g_cm3: 1.08,
            tensile_strength_mpa: 3.447,
            scale: 1.0,
            named: std::collections::BTreeMap::new(),
        }
    }
}

impl MaterialConfig {
    /// Warnings about values that are valid but implausible: a C1 (times `scale`) far
    /// softer or stiffer than every preset ([`super::material::c1_warning`]).
    pub fn warnings(&self) -> Vec<String> {
        let c1 = self.c1.unwrap_or(self.preset.yeoh().c1);
        let given = match self.c1 {
            Some(v) => format!("[material] c1 = {v}"),
            None => format!("[material] preset = \"{}\"", self.preset.name()),
        };
        let what = if self.scale == 1.0 {
            given
        } else {
            format!("{given} with scale = {}", self.scale)
        };
        super::material::c1_warning(self.scale * c1, &what)
            .into_iter()
            .collect()
    }

    /// The Yeoh material (coefficients times `scale`), checked.
    pub fn yeoh(&self) -> Result<Yeoh, FemError> {
        if !(self.scale.is_finite() && self.scale > 0.0) {
            return Err(bad(
                "scale",
                format!("{}: the material scale must be positive", self.scale),
            ));
        }
        let base = self.preset.yeoh();
        let c1 = self.c1.unwrap_or(base.c1);
        let s = self.scale;
        let m = Yeoh {
            c1: s * c1,
            c2: s * self.c2.unwrap_or(base.c2),
            c3: s * self.c3.unwrap_or(base.c3),
            bulk_modulus: s * self
                .bulk_modulus_mpa
                .unwrap_or(DEFAULT_BULK_TO_SHEAR * 2.0 * c1),
        };
        if !(m.c1.is_finite() && m.c1 > 0.0) {
            return Err(bad("c1", format!("{} MPa: must be positive", m.c1)));
        }
        if !(m.c2.is_finite() && m.c3.is_finite() && m.c3 >= 0.0) {
            let (name, v) = if m.c2.is_finite() {
                ("c3", m.c3)
            } else {
                ("c2", m.c2)
            };
            return Err(bad(name, format!("{v} MPa: must be a number >= 0")));
        }
        // A negative C2 (a fitted set's S-shaped curve) is taken while the shear response
        // dW/dI1 = C1 + 2 C2 x + 3 C3 x^2 (x = I1 - 3) stays positive at every strain.
        if m.c2 < 0.0 && m.c2 * m.c2 >= 3.0 * m.c1 * m.c3 {
            let x = if m.c3 > 0.0 {
                -m.c2 / (3.0 * m.c3)
            } else {
                -m.c1 / (2.0 * m.c2)
            };
            return Err(bad(
                "c2",
                format!(
                    "{} MPa: with this C1 and C3 the shear response C1 + 2 C2 (I1 - 3) + 3 C3 (I1 - 3)^2 turns negative near I1 - 3 = {x:.3} (unstable): a negative C2 needs C2^2 < 3 C1 C3",
                    m.c2
                ),
            ));
        }
        if !(m.bulk_modulus.is_finite() && m.bulk_modulus > 0.0) {
            return Err(bad(
                "bulk_modulus_mpa",
                format!(
                    "{} MPa: must be positive (silicone: ~1000 x the shear modulus)",
                    m.bulk_modulus
                ),
            ));
        }
        for (name, v) in [
            ("density_g_cm3", self.density_g_cm3),
            ("tensile_strength_mpa", self.tensile_strength_mpa),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(bad(name, format!("{v}: must be positive")));
            }
        }
        if self.density_g_cm3 > MAX_DENSITY_G_CM3 {
            return Err(bad(
                "density_g_cm3",
                format!(
                    "{}: no material is denser than {MAX_DENSITY_G_CM3} g/cm3 (silicones are 1.0-1.5): give g/cm3",
                    number_text(self.density_g_cm3)
                ),
            ));
        }
        Ok(m)
    }
}

/// Largest density a material may have, g/cm³ (osmium, the densest element, is 22.6).
pub const MAX_DENSITY_G_CM3: f64 = 25.0;

/// Mesh settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MeshConfig {
    /// Largest element edge, mm.
    pub size_mm: f64,
    /// The solid element ([`crate::fem::hex`]).
    pub element: SolidElement,
}

/// The hexahedron the silicone is meshed with.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SolidElement {
    /// Trilinear, with the Q1/P0 mean dilatation.
    #[default]
    Q1p0,
    /// The same with three incompatible modes condensed per element (Wilson-Taylor, as
    /// CalculiX's C3D8I): it bends through one element without shear locking.
    IncompatibleModes,
    /// Each hexahedron cut into six 10-node tetrahedra, mixed u-P with a continuous
    /// linear pressure (Taylor-Hood, [`crate::fem::tet10::taylor_hood`], as C3D10H);
    /// solid parts only.
    Tet10,
}

impl SolidElement {
    /// Whether the element has incompatible modes.
    pub fn incompatible_modes(self) -> bool {
        self == Self::IncompatibleModes
    }
}

/// Default element size, mm: within 1% of the converged radius over the whole ramp
/// (+0.2..+0.7% against CalculiX C3D20R and bendscope at 1 mm, issue 11's configuration;
/// 2 mm was +3..+5%) in half the CPU time the 2 mm default took before the assembly and
/// element speed-ups (scripts/bench-simulate.sh).
pub const DEFAULT_MESH_SIZE_MM: f64 = 1.5;

/// Largest mesh accepted (elements, counted by [`super::actuator::element_estimate`] before anything is
/// built); a finer one would not fit a workstation's memory.
pub const MAX_ELEMENTS: usize = 400_000;

impl Default for MeshConfig {
    fn default() -> Self {
        Self {
            size_mm: DEFAULT_MESH_SIZE_MM,
            element: SolidElement::default(),
        }
    }
}

/// Newton settings of a simulation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SolverConfig {
    /// Newton iterations per load increment before the increment is halved.
    pub max_iterations: usize,
    /// Residual tolerance relative to the external forces.
    pub tolerance: f64,
}

impl Default for SolverConfig {
    fn default() -> Self {
        let n = NewtonSettings::default();
        Self {
            max_iterations: n.max_iterations,
            tolerance: n.tolerance,
        }
    }
}

impl SolverConfig {
    /// The Newton settings of a pressure step (each step starts with its whole increment).
    pub fn newton(&self) -> NewtonSettings {
        NewtonSettings {
            max_iterations: self.max_iterations,
            tolerance: self.tolerance,
            ..NewtonSettings::default()
        }
    }
}

/// Everything that defines a simulated actuator.
///
/// Read from TOML or JSON over its family's defaults ([`super::family::defaults`] of
/// `geometry.family`): tables merge key by key, other values replace; a single
/// `[layer]` table updates the family's only layer.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(remote = "Self")]
#[serde(default, deny_unknown_fields)]
pub struct ActuatorConfig {
    /// Geometry, mm.
    pub geometry: Geometry,
    /// Material.
    pub material: MaterialConfig,
    /// Mesh.
    pub mesh: MeshConfig,
    /// Loads.
    pub load: LoadConfig,
    /// Newton settings.
    pub solver: SolverConfig,
    /// Strain-limiting layers in the base (`[layer]` for one, `[[layer]]` for several;
    /// none in the reference actuator).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub layer: Vec<LayerConfig>,
    /// Frictionless contact between the facing walls of neighbouring chambers
    /// (`[contact]`; off by default).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub contact: Option<ContactConfig>,
    /// The fibre-reinforced tube (`[tube]`; family `fibre-reinforced` only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tube: Option<TubeConfig>,
    /// The segmented finger's bellows and foot (its family only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub finger: Option<finger::FingerConfig>,
    /// Each named cavity's pressure as a factor of the ramp's (`[cavities] mcp = 1.0`;
    /// [`cavities`]): 1 for a cavity left out, 0 not pressurised.
    #[serde(skip_serializing_if = "std::collections::BTreeMap::is_empty")]
    pub cavities: cavities::CavityFactors,
    /// The section of each of an imported mesh's `thread.NAME` curves
    /// (`[threads.NAME]`; [`threads`]).
    #[serde(skip_serializing_if = "std::collections::BTreeMap::is_empty")]
    pub threads: threads::Threads,
}

impl Serialize for ActuatorConfig {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::Error;
        if self.material.named.is_empty() {
            return ActuatorConfig::serialize(self, s);
        }
        // `[material.NAME]` tables go inside `[material]`, where they are read.
        let mut doc = ActuatorConfig::serialize(self, serde_json::value::Serializer)
            .map_err(S::Error::custom)?;
        if let Some(serde_json::Value::Object(m)) = doc.get_mut("material") {
            for (name, table) in &self.material.named {
                m.insert(
                    name.clone(),
                    serde_json::to_value(table).map_err(S::Error::custom)?,
                );
            }
        }
        // An absent option is a JSON null, which TOML cannot write: leave it out.
        strip_nulls(&mut doc);
        doc.serialize(s)
    }
}

/// Loads of a simulation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LoadConfig {
    /// Pressure steps, kPa: "start:stop:step" or a comma-separated list (a list of
    /// numbers, `[20, 40]`, reads as "20,40").
    #[serde(deserialize_with = "pressures_text")]
    pub pressures_kpa: String,
    /// Gravity on.
    pub gravity: bool,
    /// Direction of gravity in the actuator's frame (x from the clamp to the tip, z up
    /// from the bottom face); [0, 0, -1]: lying bottom down; [1, 0, 0]: hanging from the
    /// clamp.
    pub gravity_direction: [f64; 3],
}

/// `pressures_kpa` as its text ("10:60:10", "20,40") or a list of numbers (`[20, 40]`,
/// as the acquire protocol writes pressures), which reads as "20,40".
fn pressures_text<'de, D: serde::Deserializer<'de>>(d: D) -> Result<String, D::Error> {
    struct Text;
    impl<'de> serde::de::Visitor<'de> for Text {
        type Value = String;
        fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
            f.write_str(
                "pressures as \"start:stop:step\" (\"10:60:10\"), \"a,b,c\" or a list [20, 40]",
            )
        }
        fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<String, E> {
            Ok(v.to_string())
        }
        fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut seq: A) -> Result<String, A::Error> {
            let mut out = Vec::new();
            while let Some(v) = seq.next_element::<f64>()? {
                out.push(format!("{v}"));
            }
            Ok(out.join(","))
        }
    }
    d.deserialize_any(Text)
}

impl Default for LoadConfig {
    fn default() -> Self {
        Self {
            pressures_kpa: "10:115:5".into(),
            gravity: true,
            gravity_direction: [0.0, 0.0, -1.0],
        }
    }
}

/// Removes null members (JSON's "not given", e.g. an unset `c1`).
pub(crate) fn strip_nulls(v: &mut serde_json::Value) {
    match v {
        serde_json::Value::Object(m) => {
            m.retain(|_, x| !x.is_null());
            m.values_mut().for_each(strip_nulls);
        }
        serde_json::Value::Array(a) => a.iter_mut().for_each(strip_nulls),
        _ => {}
    }
}

/// `v` as a message shows it: `1e300`, not three hundred digits.
pub(crate) fn number_text(v: f64) -> String {
    if v.abs() >= 1e6 {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}
