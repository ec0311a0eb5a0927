//! Reading gmsh's MSH 4.1 files, ASCII or binary: nodes, entities and elements parsed
//! by the mshio crate; the `$PhysicalNames` section (ASCII in both encodings), which
//! mshio skips, and the declared node and element counts, read here before anything
//! is parsed so that a file cannot make the reader allocate beyond [`MAX_NODES`] and
//! [`MAX_ELEMENTS`].
//!
//! Node tags: mshio keeps a block's tags only when the file's tags are sparse; when
//! they run without a gap from the smallest to the largest, they are taken in file
//! order, as gmsh writes them.

use std::collections::HashMap;
use std::path::Path;

use mshio::ElementType;
use nalgebra::Vector3;

use super::complete::complete;
use super::{assemble, dim_word, Completion, ImportedMesh, RawElement, RawGroup, RawMesh};
use super::{MAX_ELEMENTS, MAX_NODES};
use crate::fem::FemError;

/// Largest mesh file read (bytes): beyond what [`MAX_NODES`] and [`MAX_ELEMENTS`]
/// take in either encoding.
pub const MAX_FILE_BYTES: u64 = 1 << 30;

/// The group tag and name the tetrahedra of a file without physical groups take.
const BARE_VOLUME: i32 = -1;
const BARE_VOLUME_NAME: &str = "silicone";

/// gmsh's 10-node tetrahedron lists the mid-nodes of edges 01, 12, 20, 03, 23, 13;
/// C3D10 (and [`crate::fem::tet10`]) those of 01, 12, 20, 03, 13, 23: entry k is the
/// gmsh position of C3D10 node k.
pub const GMSH_TET10: [usize; 10] = [0, 1, 2, 3, 4, 5, 6, 7, 9, 8];

/// Reads a gmsh MSH 4.1 mesh file (ASCII or binary) into a checked [`ImportedMesh`].
pub fn read(path: &Path) -> Result<ImportedMesh, FemError> {
    read_completed(path, &Completion::default())
}

/// [`read`], with the parts the file leaves unnamed supplied ([`Completion`]).
pub fn read_completed(path: &Path, completion: &Completion) -> Result<ImportedMesh, FemError> {
    let file = path.display().to_string();
    let fail = |why: String| FemError::Input {
        why: format!("{file}: {why}"),
    };
    let len = std::fs::metadata(path)
        .map_err(|e| fail(format!("cannot read it: {e}")))?
        .len();
    if len > MAX_FILE_BYTES {
        return Err(fail(format!(
            "{len} bytes, more than the {MAX_FILE_BYTES} read: mesh coarser"
        )));
    }
    let bytes = std::fs::read(path).map_err(|e| fail(format!("cannot read it: {e}")))?;
    read_bytes(&file, &bytes, completion)
}

/// Reads a mesh from the bytes of a MSH 4.1 file; `file` names it in messages.
pub fn read_bytes(
    file: &str,
    bytes: &[u8],
    completion: &Completion,
) -> Result<ImportedMesh, FemError> {
    let mut raw = parse(file, bytes)?;
    complete(file, &mut raw, completion)?;
    assemble(file, &raw)
}

/// What the `$MeshFormat` section says.
struct Format {
    binary: bool,
    size_t: usize,
    little_endian: bool,
}

/// The lines of `bytes` from `start`, without line ends (for the ASCII sections).
fn lines_from(bytes: &[u8], start: usize) -> impl Iterator<Item = &str> {
    bytes[start.min(bytes.len())..]
        .split(|&b| b == b'\n')
        .map(|l| std::str::from_utf8(l).unwrap_or("").trim_end_matches('\r'))
}

/// The offset just after the line `$NAME` (a section's start), if the file has one.
fn section(bytes: &[u8], name: &str) -> Option<usize> {
    let tag = format!("\n{name}");
    let tag = tag.as_bytes();
    let mut from = 0;
    while let Some(k) = bytes[from..].windows(tag.len()).position(|w| w == tag) {
        let end = from + k + tag.len();
        match bytes.get(end..end + 2) {
            Some([b'\n', ..]) => return Some(end + 1),
            Some(b"\r\n") => return Some(end + 2),
            _ => from = end,
        }
    }
    None
}

fn format(bytes: &[u8]) -> Result<Format, String> {
    let mut lines = lines_from(bytes, 0);
    if lines.next().map(str::trim) != Some("$MeshFormat") {
        return Err("not a gmsh mesh: it does not start with $MeshFormat (save it from gmsh as MSH 4.1: -format msh41)".into());
    }
    let head = lines.next().unwrap_or("");
    let words: Vec<&str> = head.split_whitespace().collect();
    match words.as_slice() {
        ["4.1", kind @ ("0" | "1"), size @ ("4" | "8")] => {
            let binary = *kind == "1";
            let mut little_endian = true;
            if binary {
                // The integer 1, written in the file's byte order, follows the line.
                let at = bytes.iter().position(|&b| b == b'\n').unwrap_or(0) + 1 + head.len() + 1;
                let one = bytes
                    .get(at..at + 4)
                    .ok_or("the $MeshFormat section is cut short")?;
                little_endian = one == [1, 0, 0, 0];
            }
            Ok(Format {
                binary,
                size_t: size.parse().unwrap_or(8),
                little_endian,
            })
        }
        [version, ..] if *version != "4.1" => Err(format!(
            "MSH version {version}, not 4.1: save it as MSH 4.1 (gmsh: -format msh41)"
        )),
        _ => Err(format!(
            "unreadable $MeshFormat line `{head}`: save it from gmsh as MSH 4.1"
        )),
    }
}

/// The second number of a section's header: the node or element count it declares.
fn declared_count(bytes: &[u8], name: &str, f: &Format) -> Option<u64> {
    let at = section(bytes, name)?;
    if f.binary {
        let raw = bytes.get(at + f.size_t..at + 2 * f.size_t)?;
        let mut v: u64 = 0;
        for k in 0..f.size_t {
            let byte = if f.little_endian {
                raw[f.size_t - 1 - k]
            } else {
                raw[k]
            };
            v = (v << 8) | u64::from(byte);
        }
        Some(v)
    } else {
        let line = lines_from(bytes, at).next()?;
        line.split_whitespace().nth(1)?.parse().ok()
    }
}

/// `$PhysicalNames`: (dimension, tag) -> name.
fn physical_names(bytes: &[u8]) -> Result<HashMap<(i32, i32), String>, String> {
    let mut names = HashMap::new();
    let Some(at) = section(bytes, "$PhysicalNames") else {
        return Ok(names);
    };
    for line in lines_from(bytes, at).skip(1) {
        let line = line.trim();
        if line == "$EndPhysicalNames" {
            return Ok(names);
        }
        let bad =
            || format!("unreadable $PhysicalNames line `{line}`: expected `DIM TAG \"NAME\"`");
        let mut words = line.splitn(3, char::is_whitespace);
        let dim: i32 = words.next().and_then(|w| w.parse().ok()).ok_or_else(bad)?;
        let tag: i32 = words.next().and_then(|w| w.parse().ok()).ok_or_else(bad)?;
        let name = words
            .next()
            .map(str::trim)
            .and_then(|n| n.strip_prefix('"')?.strip_suffix('"'))
            .ok_or_else(bad)?;
        names.insert((dim, tag), name.to_string());
    }
    Err("the $PhysicalNames section has no end ($EndPhysicalNames)".into())
}

/// mshio's error as one line: where in the file, in which part, and what.
fn parse_error(bytes: &[u8], f: &Format, e: &mshio::MshParserError<&[u8]>) -> String {
    let trace = e.filtered_backtrace();
    let Some((at, _)) = trace.first() else {
        return "not a readable MSH 4.1 file".into();
    };
    let offset = (at.as_ptr() as usize).saturating_sub(bytes.as_ptr() as usize);
    let place = if f.binary {
        format!("byte {offset}")
    } else {
        let line = bytes[..offset.min(bytes.len())]
            .iter()
            .filter(|&&b| b == b'\n')
            .count()
            + 1;
        format!("line {line}")
    };
    // Outermost first: the sections, then what was wrong.
    let (mut within, mut what) = (Vec::new(), Vec::new());
    for (_, kind) in trace.iter().rev() {
        match kind.context() {
            Some(c) => within.push(c.to_string()),
            None => what.push(kind.to_string().trim_end_matches('.').to_lowercase()),
        }
    }
    format!(
        "not a readable MSH 4.1 file: {place}, {}: {}",
        within.join(" > "),
        what.join("; ")
    )
}

/// The dimension and node count of the element types read, `None` for the others.
fn element_shape(t: ElementType) -> Option<(i32, usize)> {
    Some(match t {
        ElementType::Tet4 => (3, 4),
        ElementType::Tet10 => (3, 10),
        ElementType::Tri3 => (2, 3),
        ElementType::Tri6 => (2, 6),
        ElementType::Lin2 => (1, 2),
        ElementType::Lin3 => (1, 3),
        ElementType::Pnt => (0, 1),
        _ => return None,
    })
}

/// The file's nodes and its physical groups' elements.
pub(crate) fn parse(file: &str, bytes: &[u8]) -> Result<RawMesh, FemError> {
    let fail = |why: String| FemError::Input {
        why: format!("{file}: {why}"),
    };
    let f = format(bytes).map_err(&fail)?;
    for (name, what, max) in [
        ("$Nodes", "nodes", MAX_NODES),
        ("$Elements", "elements", MAX_ELEMENTS),
    ] {
        if let Some(n) = declared_count(bytes, name, &f).filter(|&n| n > max as u64) {
            return Err(fail(format!(
                "declares {n} {what}, more than the {max} read: mesh coarser"
            )));
        }
    }
    let names = physical_names(bytes).map_err(&fail)?;
    let msh = mshio::parse_msh_bytes(bytes).map_err(|e| fail(parse_error(bytes, &f, &e)))?;

    // Entity -> its physical groups.
    let mut physical: HashMap<(i32, i32), Vec<i32>> = HashMap::new();
    if let Some(ent) = &msh.data.entities {
        let mut add = |dim: i32, tag: i32, tags: &[i32]| {
            physical.insert((dim, tag), tags.iter().map(|t| t.abs()).collect());
        };
        ent.points
            .iter()
            .for_each(|e| add(0, e.tag, &e.physical_tags));
        ent.curves
            .iter()
            .for_each(|e| add(1, e.tag, &e.physical_tags));
        ent.surfaces
            .iter()
            .for_each(|e| add(2, e.tag, &e.physical_tags));
        ent.volumes
            .iter()
            .for_each(|e| add(3, e.tag, &e.physical_tags));
    }

    let mut raw = RawMesh::default();
    let mut index_of: HashMap<u64, usize> = HashMap::new();
    if let Some(nodes) = &msh.data.nodes {
        let count: usize = nodes.node_blocks.iter().map(|b| b.nodes.len()).sum();
        if count > MAX_NODES {
            return Err(fail(format!(
                "{count} nodes, more than the {MAX_NODES} read: mesh coarser"
            )));
        }
        let mut next = nodes.min_node_tag;
        for block in &nodes.node_blocks {
            let mut tags = vec![0; block.nodes.len()];
            match &block.node_tags {
                Some(map) => map.iter().for_each(|(&t, &k)| tags[k] = t),
                None => tags.iter_mut().for_each(|t| {
                    *t = next;
                    next += 1;
                }),
            }
            for (n, tag) in block.nodes.iter().zip(tags) {
                if index_of.insert(tag, raw.nodes.len()).is_some() {
                    return Err(fail(format!("node {tag} is defined twice")));
                }
                raw.nodes.push(Vector3::new(n.x, n.y, n.z));
                raw.node_tags.push(tag);
            }
        }
    }

    let count: usize = msh
        .data
        .elements
        .iter()
        .flat_map(|e| &e.element_blocks)
        .map(|b| b.elements.len())
        .sum();
    if count > MAX_ELEMENTS {
        return Err(fail(format!(
            "{count} elements, more than the {MAX_ELEMENTS} read: mesh coarser"
        )));
    }
    let bare = physical.values().all(Vec::is_empty);
    let mut group_of: HashMap<(i32, i32), usize> = HashMap::new();
    for block in msh.data.elements.iter().flat_map(|e| &e.element_blocks) {
        let dim = block.entity_dim;
        let shape = element_shape(block.element_type).filter(|(d, _)| *d == dim);
        // A file without any physical group (gmsh then saves every element): its
        // tetrahedra are one silicone, the rest is found from them ([`super::complete`]).
        let bare_volume = bare && shape.is_some_and(|(d, _)| d == 3);
        let groups = match physical.get(&(dim, block.entity_tag)) {
            Some(g) if !g.is_empty() => g.as_slice(),
            _ if bare_volume => &[BARE_VOLUME],
            _ => &[],
        };
        if groups.is_empty() {
            if shape.is_some_and(|(d, _)| d == 3) {
                raw.unnamed_tets += block.elements.len();
            }
            continue;
        }
        let mut members = Vec::with_capacity(groups.len());
        for &g in groups {
            let word = dim_word(dim as usize).to_lowercase();
            let unnamed = (g == BARE_VOLUME).then(|| BARE_VOLUME_NAME.to_string());
            let name = unnamed.as_ref().or_else(|| names.get(&(dim, g))).ok_or_else(|| {
                fail(format!(
                    "physical {word} {g} has no name: name it (gmsh: Physical {}(\"NAME\") = {{...}})",
                    dim_word(dim as usize)
                ))
            })?;
            let Some((_, n)) = shape else {
                return Err(fail(format!(
                    "physical {word} `{name}` holds elements of gmsh type {} ({:?}): only tetrahedra, triangles, lines and points are read (mesh with gmsh -3, without recombining)",
                    block.element_type as u8,
                    block.element_type
                )));
            };
            let k = *group_of.entry((dim, g)).or_insert_with(|| {
                raw.groups.push(RawGroup {
                    dim: dim as usize,
                    name: name.clone(),
                    elements: Vec::new(),
                });
                raw.groups.len() - 1
            });
            members.push((k, n));
        }
        for e in &block.elements {
            let Some(&(_, n)) = members.first() else {
                break;
            };
            if e.nodes.len() != n {
                return Err(fail(format!(
                    "element {} has {} nodes, not {n}",
                    e.element_tag,
                    e.nodes.len()
                )));
            }
            let mut nodes = Vec::with_capacity(n);
            for &t in &e.nodes {
                nodes.push(*index_of.get(&t).ok_or_else(|| {
                    fail(format!(
                        "element {} names node {t}, which the file does not define",
                        e.element_tag
                    ))
                })?);
            }
            if n == 10 {
                nodes = GMSH_TET10.iter().map(|&k| nodes[k]).collect();
            }
            for &(k, _) in &members {
                raw.groups[k].elements.push(RawElement {
                    tag: e.element_tag,
                    nodes: nodes.clone(),
                });
            }
        }
    }
    Ok(raw)
}
