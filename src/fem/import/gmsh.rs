//! Meshing a CAD file with the `gmsh` program (installed by scripts/setup.sh): 10-node
//! tetrahedra, MSH 4.1, written atomically (a temporary file in the destination folder,
//! renamed when gmsh has succeeded).

use std::path::Path;
use std::process::{Command, Stdio};

use crate::fem::FemError;

/// The CAD formats gmsh reads (lower-case extensions): its own script and the OpenCASCADE
/// exchange formats.
pub const CAD_EXTENSIONS: [&str; 6] = ["geo", "step", "stp", "iges", "igs", "brep"];

/// Meshes `cad` with gmsh into `out` (MSH 4.1, ASCII): 10-node tetrahedra of at most
/// `size_mm`, `set_numbers` passed as `-setnumber NAME VALUE` (a .geo's
/// `DefineConstant`s).
pub fn mesh(
    cad: &Path,
    size_mm: f64,
    set_numbers: &[(String, f64)],
    out: &Path,
) -> Result<(), FemError> {
    mesh_with("gmsh", cad, size_mm, set_numbers, out)
}

/// [`mesh`] with the gmsh program named (tests: a missing one).
pub(crate) fn mesh_with(
    program: &str,
    cad: &Path,
    size_mm: f64,
    set_numbers: &[(String, f64)],
    out: &Path,
) -> Result<(), FemError> {
    let input = |why: String| FemError::Input {
        why: format!("{}: {why}", cad.display()),
    };
    let ext = cad
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .unwrap_or_default();
    if !CAD_EXTENSIONS.contains(&ext.as_str()) {
        return Err(input(format!(
            "gmsh meshes .geo, .step, .stp, .iges, .igs and .brep files, not `.{ext}`: export the CAD as STEP"
        )));
    }
    if !(size_mm.is_finite() && size_mm > 0.0) {
        return Err(FemError::Parameter {
            name: "mesh size".into(),
            why: format!("{size_mm} mm: give a positive size in mm"),
        });
    }
    for (name, value) in set_numbers {
        let plain = !name.is_empty()
            && name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || matches!(c, '_' | '.' | '/'));
        if !plain || !value.is_finite() {
            return Err(FemError::Parameter {
                name: format!("gmsh number `{name}`"),
                why: format!(
                    "{value}: give a name of letters, digits and _ (a DefineConstant of the .geo) and a finite value"
                ),
            });
        }
    }
    std::fs::metadata(cad).map_err(|e| input(format!("cannot read it: {e}")))?;

    let output = |why: String| FemError::Output {
        why: format!("{}: {why}", out.display()),
    };
    let dir = match out.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let mut builder = tempfile::Builder::new();
    builder
        .prefix(crate::io::TEMP_PREFIX)
        .suffix(crate::io::TEMP_SUFFIX);
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        // As every result file: mode 0666 less the umask, not tempfile's 0600.
        builder.permissions(std::fs::Permissions::from_mode(crate::io::OUTPUT_MODE));
    }
    let tmp = builder
        .tempfile_in(dir)
        .map_err(|e| output(e.to_string()))?;

    let mut command = Command::new(program);
    command
        .arg(cad)
        .args(["-3", "-order", "2", "-format", "msh41", "-clmax"])
        .arg(size_mm.to_string());
    for (name, value) in set_numbers {
        command.arg("-setnumber").arg(name).arg(value.to_string());
    }
    command
        .arg("-o")
        .arg(tmp.path())
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    let run = crate::child::die_with_parent(&mut command, libc::SIGKILL)
        .output()
        .map_err(|e| {
            input(if e.kind() == std::io::ErrorKind::NotFound {
                "cannot mesh it: gmsh is not installed (or not on PATH): run scripts/setup.sh"
                    .to_string()
            } else {
                format!("cannot run gmsh: {e}")
            })
        })?;
    // gmsh reports an error on stderr and may still write a mesh.
    let log =
        String::from_utf8_lossy(&run.stderr).into_owned() + &String::from_utf8_lossy(&run.stdout);
    let error = log.lines().rev().find(|l| l.starts_with("Error")).map(|l| {
        l.trim_start_matches("Error")
            .trim_start_matches([' ', ':'])
            .trim()
    });
    let empty = std::fs::metadata(tmp.path()).map_or(true, |m| m.len() == 0);
    if let Some(line) = error {
        return Err(input(format!("gmsh failed: {line}")));
    }
    if !run.status.success() || empty {
        let last = log
            .lines()
            .rev()
            .find(|l| !l.trim().is_empty())
            .unwrap_or("no message");
        return Err(input(format!(
            "gmsh failed ({}): {}",
            run.status,
            last.trim()
        )));
    }
    tmp.persist(out).map_err(|e| output(e.error.to_string()))?;
    Ok(())
}
