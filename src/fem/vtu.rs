//! VTK XML output for ParaView: one unstructured grid (.vtu) per step and a collection
//! (.pvd) that orders them by pressure.
//!
//! Written by hand: the format is a few lines of XML with ASCII arrays, and no crate of
//! the project's dependency set writes it. Points are the deformed positions; the
//! displacement is a point field (warp back with "Warp By Vector", scale -1), the Cauchy
//! stress, its largest principal value and the von Mises stress are cell fields.

use std::fmt::Write as _;
use std::path::Path;

use nalgebra::{Matrix3, Vector3};

use super::simulate::max_principal;
use crate::io::write_atomic;

/// VTK cell type of an 8-node hexahedron.
const VTK_HEXAHEDRON: u8 = 12;
/// VTK cell type of a 10-node tetrahedron (its node order is C3D10's).
const VTK_QUADRATIC_TETRA: u8 = 24;

/// von Mises equivalent stress.
pub fn von_mises(s: &Matrix3<f64>) -> f64 {
    let dev = s - Matrix3::identity() * (s.trace() / 3.0);
    (1.5 * dev.component_mul(&dev).sum()).sqrt()
}

/// Writes the deformed mesh with its fields to `path` (atomically): the cells are the
/// hexahedra then the tetrahedra, as `stresses` is ordered.
pub fn write_vtu(
    path: &Path,
    nodes: &[Vector3<f64>],
    hexes: &[[usize; 8]],
    tets: &[[usize; 10]],
    displacement: &[f64],
    stresses: &[Matrix3<f64>],
) -> std::io::Result<()> {
    let elements: Vec<&[usize]> = hexes
        .iter()
        .map(|h| &h[..])
        .chain(tets.iter().map(|t| &t[..]))
        .collect();
    let mut s = String::with_capacity(nodes.len() * 80 + elements.len() * 200);
    let _ = writeln!(s, "<?xml version=\"1.0\"?>");
    let _ = writeln!(
        s,
        "<VTKFile type=\"UnstructuredGrid\" version=\"0.1\" byte_order=\"LittleEndian\">\n<UnstructuredGrid>\n<Piece NumberOfPoints=\"{}\" NumberOfCells=\"{}\">",
        nodes.len(),
        elements.len()
    );
    s.push_str(
        "<Points>\n<DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"ascii\">\n",
    );
    for (a, x) in nodes.iter().enumerate() {
        let _ = writeln!(
            s,
            "{} {} {}",
            x.x + displacement[3 * a],
            x.y + displacement[3 * a + 1],
            x.z + displacement[3 * a + 2]
        );
    }
    s.push_str("</DataArray>\n</Points>\n<Cells>\n");
    s.push_str("<DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">\n");
    for el in &elements {
        let line: Vec<String> = el.iter().map(|n| n.to_string()).collect();
        let _ = writeln!(s, "{}", line.join(" "));
    }
    s.push_str("</DataArray>\n<DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">\n");
    let mut offset = 0;
    for el in &elements {
        offset += el.len();
        let _ = writeln!(s, "{offset}");
    }
    s.push_str("</DataArray>\n<DataArray type=\"UInt8\" Name=\"types\" format=\"ascii\">\n");
    for el in &elements {
        let kind = if el.len() == 8 {
            VTK_HEXAHEDRON
        } else {
            VTK_QUADRATIC_TETRA
        };
        let _ = writeln!(s, "{kind}");
    }
    s.push_str("</DataArray>\n</Cells>\n<PointData Vectors=\"displacement_mm\">\n");
    s.push_str("<DataArray type=\"Float64\" Name=\"displacement_mm\" NumberOfComponents=\"3\" format=\"ascii\">\n");
    for u in displacement.chunks(3) {
        let _ = writeln!(s, "{} {} {}", u[0], u[1], u[2]);
    }
    s.push_str("</DataArray>\n</PointData>\n<CellData Tensors=\"cauchy_stress_mpa\" Scalars=\"max_principal_stress_mpa\">\n");
    s.push_str("<DataArray type=\"Float64\" Name=\"cauchy_stress_mpa\" NumberOfComponents=\"9\" format=\"ascii\">\n");
    for t in stresses {
        let v: Vec<String> = (0..3)
            .flat_map(|i| (0..3).map(move |j| (i, j)))
            .map(|(i, j)| format!("{:.6e}", t[(i, j)]))
            .collect();
        let _ = writeln!(s, "{}", v.join(" "));
    }
    s.push_str("</DataArray>\n<DataArray type=\"Float64\" Name=\"max_principal_stress_mpa\" format=\"ascii\">\n");
    for t in stresses {
        let _ = writeln!(s, "{:.6e}", max_principal(t));
    }
    s.push_str("</DataArray>\n<DataArray type=\"Float64\" Name=\"von_mises_stress_mpa\" format=\"ascii\">\n");
    for t in stresses {
        let _ = writeln!(s, "{:.6e}", von_mises(t));
    }
    s.push_str("</DataArray>\n</CellData>\n</Piece>\n</UnstructuredGrid>\n</VTKFile>\n");
    write_atomic(path, s.as_bytes())
}

/// Writes a ParaView collection listing `(pressure_kpa, file name)` as time steps.
pub fn write_pvd(path: &Path, steps: &[(f64, String)]) -> std::io::Result<()> {
    let mut s = String::from(
        "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\">\n<Collection>\n",
    );
    for (p, file) in steps {
        let _ = writeln!(s, "<DataSet timestep=\"{p}\" file=\"{file}\"/>");
    }
    s.push_str("</Collection>\n</VTKFile>\n");
    write_atomic(path, s.as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn von_mises_of_uniaxial_and_hydrostatic_stress() {
        let uni = Matrix3::from_diagonal(&Vector3::new(2.0, 0.0, 0.0));
        assert!((von_mises(&uni) - 2.0).abs() < 1e-12);
        assert!(von_mises(&Matrix3::identity()).abs() < 1e-12);
        let shear = Matrix3::new(0.0, 1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0);
        assert!((von_mises(&shear) - 3f64.sqrt()).abs() < 1e-12);
        assert!((max_principal(&shear) - 1.0).abs() < 1e-12);
    }

    /// A hexahedron and a tetrahedron: their cells, offsets and types in that order.
    #[test]
    fn one_hexahedron_file_lists_its_points_cells_and_fields() {
        let dir = tempfile::tempdir().unwrap();
        let nodes: Vec<Vector3<f64>> = (0..8)
            .map(|a| Vector3::new((a & 1) as f64, ((a >> 1) & 1) as f64, (a >> 2) as f64))
            .collect();
        let path = dir.path().join("one.vtu");
        write_vtu(
            &path,
            &nodes,
            &[[0, 1, 3, 2, 4, 5, 7, 6]],
            &[[0, 1, 2, 4, 5, 6, 7, 3, 0, 1]],
            &[0.5; 24],
            &[Matrix3::identity(); 2],
        )
        .unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(text.contains("NumberOfPoints=\"8\" NumberOfCells=\"2\""));
        assert!(text.contains("0 1 2 4 5 6 7 3 0 1"));
        assert!(text.contains("format=\"ascii\">\n8\n18\n</DataArray>"));
        assert!(text.contains("format=\"ascii\">\n12\n24\n</DataArray>"));
        assert!(text.contains("0 1 3 2 4 5 7 6"));
        assert!(text.contains("1.5 1.5 1.5"));
        assert!(text.contains("Name=\"von_mises_stress_mpa\""));
    }
}
