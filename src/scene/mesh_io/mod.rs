//! Triangle-mesh files: PLY (ascii, binary little/big endian, optionally
//! gzipped) through a hand-written parser, and Wavefront OBJ through `tobj`,
//! with the materials its faces ask for (`usemtl`, [`MaterialGroups`]) and
//! the MTL libraries that define them ([`read_mtl`]).
//!
//! The PLY parser walks the whole file, mapped, once. On the ascii Stanford
//! bunny it takes about 6 ms where `ply-rs-bw` takes about 160 ms
//! (release; the cross-check test prints both), and it reports errors with
//! the line (ascii) or the record (binary) where they happen. Large ascii
//! PLY bodies and OBJ files are read in parallel chunks cut at line ends
//! (`ply::ascii`, `obj_chunks`), with the serial reader deciding whatever a
//! chunk cannot: the mesh and every error are the serial reader's.
//!
//! Polygons are fan-triangulated. Vertex normals (PLY `nx ny nz`, OBJ `vn`)
//! are read as unit vectors; a non-finite one is an error at its line or
//! record. Elements and properties the renderer does not use (colours,
//! confidence, ...) are skipped, and so are
//! degenerate triangles; both are summed up in one note per file (see
//! [`read_mesh`]). A file that contradicts its header or the format (data
//! after the declared elements, a face of two vertices, an index of 0) is an
//! error with its line or byte offset.
//!
//! A gzipped PLY is parsed as it inflates (`ply::stream`): its body passes
//! through a window of a few megabytes, read record by record on one
//! thread, so it is never held whole; the mesh, the notes and every error
//! (offsets in the inflated data, lines) are those of the same file parsed
//! whole. It is inflated no further than the largest body its header's
//! counts allow. A gzipped OBJ is inflated whole, then parsed.

mod checks;
mod chunks;
mod fail;
mod groups;
mod gzip;
mod mtl;
mod obj;
mod obj_chunks;
mod obj_merge;
mod obj_scan;
mod ply;
mod serialized;
#[cfg(test)]
mod test_support;

pub(crate) use checks::{drop_degenerate_grouped, is_degenerate};
pub use groups::{MaterialGroups, Named};
pub use mtl::{read_mtl, MtlLibrary, MtlMaterial};

use crate::geometry::Mesh;
use crate::meter::{unmetered, Step, StepKind};
use fail::Fail;
use std::path::{Path, PathBuf};

/// Why a mesh file could not be loaded. Every message starts with the path,
/// then the place: line and column in text (`bunny.ply:12:7: ...`), the byte
/// offset in a binary body (`bunny.ply: byte 4096: ...`; of the decompressed
/// data for a gzipped file).
#[derive(Debug, thiserror::Error)]
pub enum MeshError {
    #[error("{}: {source}", .path.display())]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{}:{line}:{column}: {msg}", .path.display())]
    AtLine {
        path: PathBuf,
        line: usize,
        column: usize,
        msg: String,
    },
    #[error("{}: byte {offset}: {msg}", .path.display())]
    AtByte {
        path: PathBuf,
        offset: usize,
        msg: String,
    },
    #[error("{}: {msg}", .path.display())]
    Invalid { path: PathBuf, msg: String },
    /// Every triangle of the file is degenerate: nothing to render, which
    /// scenes skip rather than refuse.
    /// No triangle of the mesh has any area; `place` is where the faces
    /// were expected (`line:column`, or the mesh in a file of several).
    #[error("{}:{place}: {msg}", .path.display())]
    NoArea {
        path: PathBuf,
        place: String,
        msg: String,
    },
}

/// A mesh file as read: the mesh, the notes on what of the file luz did
/// not use (data it does not read, triangles it dropped, and why; empty for
/// a file read whole), and the materials an OBJ file's faces ask for.
#[derive(Debug, Default)]
pub struct MeshFile {
    pub mesh: Mesh,
    pub notes: Vec<String>,
    pub groups: MaterialGroups,
}

/// Loads a `.ply`, `.ply.gz`, `.obj` or `.obj.gz` file (gzip is recognised by
/// its magic bytes, whatever the name).
pub fn load_mesh(path: &Path) -> Result<Mesh, MeshError> {
    read_mesh(path).map(|read| read.mesh)
}

/// [`load_mesh`], with the notes and material groups of [`MeshFile`]. The
/// path must be a regular file.
pub fn read_mesh(path: &Path) -> Result<MeshFile, MeshError> {
    read_mapped(path, |data| parse_mesh_noted(data, path))
}

/// Mesh `shape_index` of a Mitsuba `.serialized` file.
pub fn read_serialized(path: &Path, shape_index: u32) -> Result<MeshFile, MeshError> {
    read_mapped(path, |data| {
        serialized::parse_serialized(data, path, shape_index)
    })
}

/// `parse` of the regular file `path`, mapped, while the load's progress
/// reports the file being read.
fn read_mapped(
    path: &Path,
    parse: impl FnOnce(&[u8]) -> Result<MeshFile, MeshError>,
) -> Result<MeshFile, MeshError> {
    let size = std::fs::metadata(path).map_or(0, |m| m.len());
    let _step = Step::begin(StepKind::ReadMesh { file: path }, size);
    let data = crate::location::map_regular_file(path).map_err(|source| MeshError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    parse(&data)
}

/// Parses the contents of a mesh file; `path` picks the format by its
/// extension, as in [`load_mesh`], and names the file in errors.
pub fn parse_mesh(data: &[u8], path: &Path) -> Result<Mesh, MeshError> {
    parse_mesh_noted(data, path).map(|read| read.mesh)
}

/// [`parse_mesh`] with the notes and groups of [`read_mesh`].
pub fn parse_mesh_noted(data: &[u8], path: &Path) -> Result<MeshFile, MeshError> {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    let name = name.strip_suffix(".gz").unwrap_or(&name);
    let is_ply = name.ends_with(".ply");
    let parse: fn(&[u8]) -> Result<MeshFile, Fail> = if is_ply {
        |data| ply::parse_ply(data).map(ply_file)
    } else if name.ends_with(".obj") {
        obj::parse_obj
    } else {
        return Err(MeshError::Invalid {
            path: path.to_path_buf(),
            msg: "unsupported mesh format: expected a .ply, .ply.gz or .obj file".into(),
        });
    };
    if !gzip::is_gzip(data) {
        return parse(data).map_err(|f| f.at(path));
    }
    if is_ply {
        return gzip::parse_ply(data, path).map(ply_file);
    }
    // The step counts the compressed bytes as they are inflated.
    let inflated = gzip::inflate(data, path)?;
    unmetered(|| parse(&inflated)).map_err(|f| f.at(path))
}

/// A PLY mesh with the notes on what of its file luz did not use.
type Noted = (Mesh, Vec<String>);

/// The file of a PLY mesh, which has no material groups.
fn ply_file((mesh, notes): Noted) -> MeshFile {
    MeshFile {
        mesh,
        notes,
        groups: MaterialGroups::default(),
    }
}

#[cfg(test)]
mod tests {
    use super::test_support::assets;
    use super::*;

    #[test]
    fn all_assets_load() {
        let dir = assets();
        let cases = [
            ("stanford/bunny/bun_zipper.ply", 35_947, 69_451),
            ("stanford/bunny/bun_zipper_res2.ply", 8_171, 16_301),
            ("stanford/bunny/bun_zipper_res3.ply", 1_889, 3_851),
            ("stanford/bunny/bun_zipper_res4.ply", 453, 948),
            ("stanford/bunny/stanford-bunny.obj", 0, 69_451),
            ("stanford/dragon/dragon_vrip_res2.ply.gz", 100_250, 202_520),
            ("stanford/dragon/dragon_vrip_res3.ply", 22_998, 47_794),
            ("stanford/dragon/dragon_vrip_res4.ply", 5_205, 11_102),
            ("stanford/armadillo/armadillo.obj", 0, 29_170),
            ("stanford/lucy/lucy.ply", 49_987, 99_970),
            ("spot/spot_triangulated.obj", 0, 5_856),
            ("spot/spot_quadrangulated.obj", 0, 5_856),
            ("spot/spot_control_mesh.obj", 0, 372),
            ("teapot/teapot.obj", 0, 6_320),
            ("cornell-box/CornellBox-Original.obj", 0, 36),
        ];
        for (file, verts, tris) in cases {
            let path = dir.join(file);
            if !path.exists() {
                eprintln!("skipping {}: not present", path.display());
                continue;
            }
            // Best of three, so the timing is not the page cache's.
            let mut best = f64::INFINITY;
            let mut mesh = Mesh::default();
            for _ in 0..3 {
                let t = std::time::Instant::now();
                mesh = load_mesh(&path).unwrap_or_else(|e| panic!("{e}"));
                best = best.min(t.elapsed().as_secs_f64() * 1e3);
            }
            eprintln!(
                "{file}: {} vertices, {} triangles, uv {}, {best:.2} ms",
                mesh.positions.len(),
                mesh.indices.len(),
                mesh.uvs.is_some(),
            );
            if verts > 0 {
                assert_eq!(mesh.positions.len(), verts, "{file}");
            }
            assert_eq!(mesh.indices.len(), tris, "{file}");
            if file.starts_with("spot") {
                assert!(mesh.uvs.is_some(), "{file}");
            }
        }
    }
}
