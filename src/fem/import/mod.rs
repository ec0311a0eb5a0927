//! Actuators drawn in CAD: gmsh meshes ([`msh`]) read into an [`ImportedMesh`], a
//! checked mesh of 10-node tetrahedra with its parts named, and CAD files meshed by
//! the `gmsh` program ([`gmsh`]).
//!
//! The parts are gmsh physical groups, found by name:
//!
//! | dimension | name | part |
//! | --- | --- | --- |
//! | volume | any | a material (`silicone`, `paper`, ...) |
//! | surface | `cavity`, `cavity.NAME` | a pressurised cavity's inner surface (closed) |
//! | surface | `clamp` | clamped nodes |
//! | surface | `symmetry.x`, `symmetry.y`, `symmetry.z` | a symmetry plane of a half model |
//! | surface | `layer.NAME` | a sheet embedded in the volume |
//! | curve | `thread.NAME` | a fibre or cable along tetrahedron edges |
//! | curve or point | `markers` | the tracked points |
//!
//! A file may leave parts unnamed ([`complete`]): its cavity (the solid's closed inner
//! surfaces), its clamp and markers (given in the config). A file without any physical
//! group (a bare CAD file meshed by gmsh) is one volume of silicone.
//!
//! [`assemble`] turns the file's elements into the [`ImportedMesh`], whatever the file
//! format: 4-node tetrahedra get shared mid-edge nodes, every face and line gets the
//! mid-nodes of the tetrahedra's edges, and the checks refuse what a solver could not
//! use (inverted elements, an open cavity, a surface that does not match the volume
//! mesh) with one line naming the element or the place.

mod assemble;
mod complete;
pub mod gmsh;
pub mod msh;
#[cfg(test)]
mod tests;

use nalgebra::Vector3;

pub(crate) use assemble::{assemble, RawElement, RawGroup, RawMesh};
pub use complete::Completion;

/// A tetrahedral mesh of an actuator with its parts, read from a gmsh mesh. Plain data:
/// the solver's model is made from it elsewhere.
#[derive(Debug, Clone, PartialEq)]
pub struct ImportedMesh {
    /// Node positions (mm); only the nodes of the tetrahedra, in file order, then the
    /// mid-edge nodes added to 4-node tetrahedra.
    pub nodes: Vec<Vector3<f64>>,
    /// 10-node tetrahedra in the C3D10 node order of [`crate::fem::tet10::EDGES`], each
    /// of positive volume.
    pub tets: Vec<[usize; 10]>,
    /// The material of each tetrahedron: an index into `materials`.
    pub tet_material: Vec<usize>,
    /// The physical volumes' names, in the order of their first tetrahedron.
    pub materials: Vec<String>,
    /// Each cavity (`cavity` or `cavity.NAME`) with its faces: 6-node triangles in the
    /// order of [`crate::fem::pressure_tri6`], normal out of the cavity into the wall.
    pub cavities: Vec<(String, Vec<[usize; 6]>)>,
    /// The nodes of the `clamp` surfaces and of the `clamp` volume (a clamped block, its
    /// material that of the silicone; all three displacements fixed), ascending.
    pub clamp: Vec<usize>,
    /// Each symmetry plane (axis 0, 1, 2 for `symmetry.x`, `.y`, `.z`) with its nodes,
    /// whose displacement along the axis is fixed, ascending.
    pub symmetry: Vec<(usize, Vec<usize>)>,
    /// Each `layer.NAME` surface (named NAME) as 6-node triangles: corners as in the
    /// file, then the mid-nodes of edges 01, 12, 20.
    pub layers: Vec<(String, Vec<[usize; 6]>)>,
    /// Each `thread.NAME` curve (named NAME) as 3-node lines: ends, then the mid-node.
    pub threads: Vec<(String, Vec<[usize; 3]>)>,
    /// The `markers` nodes, ordered by their distance from the clamp's centroid (from
    /// the clamp outward).
    pub markers: Vec<usize>,
    /// The `tip` point, where the tip's position is read (None: not given).
    pub tip: Option<usize>,
}

/// Most nodes a mesh file may declare (the files are read whole: this bounds memory).
pub const MAX_NODES: usize = 2_000_000;
/// Most elements (of all dimensions) a mesh file may declare.
pub const MAX_ELEMENTS: usize = 4_000_000;

/// What a physical group's name makes it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) enum Part {
    Material(String),
    Cavity(String),
    Clamp,
    Symmetry(usize),
    Layer(String),
    Thread(String),
    Markers,
    Tip,
}

/// The names known for groups of each dimension (0 points .. 3 volumes), for messages.
pub(crate) fn known_names(dim: usize) -> &'static str {
    match dim {
        0 => "`markers`, `tip`",
        1 => "`thread.NAME`, `markers`",
        2 => "`cavity`, `cavity.NAME`, `clamp`, `symmetry.x`, `symmetry.y`, `symmetry.z`, `layer.NAME`",
        _ => "any name (a material; `clamp`: a clamped block)",
    }
}

/// The part a physical group of dimension `dim` named `name` is, if the name is known.
pub(crate) fn part_of(dim: usize, name: &str) -> Option<Part> {
    let suffix = |prefix: &str| {
        name.strip_prefix(prefix)
            .filter(|s| !s.is_empty())
            .map(str::to_string)
    };
    match dim {
        3 if !name.trim().is_empty() => Some(Part::Material(name.to_string())),
        2 => match name {
            "cavity" => Some(Part::Cavity(name.to_string())),
            "clamp" => Some(Part::Clamp),
            "symmetry.x" => Some(Part::Symmetry(0)),
            "symmetry.y" => Some(Part::Symmetry(1)),
            "symmetry.z" => Some(Part::Symmetry(2)),
            _ => suffix("cavity.")
                .map(|_| Part::Cavity(name.to_string()))
                .or_else(|| suffix("layer.").map(Part::Layer)),
        },
        1 if name == "markers" => Some(Part::Markers),
        1 => suffix("thread.").map(Part::Thread),
        0 if name == "markers" => Some(Part::Markers),
        0 if name == "tip" => Some(Part::Tip),
        _ => None,
    }
}

/// The word gmsh uses for a physical group of dimension `dim`.
pub(crate) fn dim_word(dim: usize) -> &'static str {
    ["Point", "Curve", "Surface", "Volume"][dim.min(3)]
}
