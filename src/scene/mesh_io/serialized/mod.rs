//! Mitsuba's `.serialized` meshes, in the versions 3 and 4 that Mitsuba 0.5
//! to 3 write and that its scenes ship (the material preview's included).
//!
//! A file is a sequence of meshes, each a little-endian header (`0x041C`,
//! the version) and a zlib stream: a flag word, in version 4 a
//! null-terminated name, the vertex and triangle counts (u64), then whole
//! arrays: positions, normals (flag `0x1`), texture coordinates (`0x2`) and
//! colours (`0x8`), in f32 or, with flag `0x2000`, f64; then three u32
//! indices per triangle. Flag `0x10` asks for face normals. A dictionary at
//! the end gives each mesh's offset: the count (u32) last, before it one
//! offset per mesh (u64 in version 4, u32 in version 3).

use super::checks::{
    check_finite, check_finite_normal, drop_degenerate, dropped_note, no_faces, zero_normals_note,
};
use super::{MeshError, MeshFile};
use crate::geometry::Mesh;
use crate::math::{PackedVec3, Vec2};
use flate2::read::ZlibDecoder;
use std::io::Read;
use std::path::Path;

const MAGIC: u16 = 0x041c;
const HAS_NORMALS: u32 = 0x1;
const HAS_TEXCOORDS: u32 = 0x2;
const HAS_COLORS: u32 = 0x8;
const FACE_NORMALS: u32 = 0x10;
const DOUBLE_PRECISION: u32 = 0x2000;

/// How long a version 4 mesh name may be: a name, not a payload.
const MAX_NAME: usize = 4096;

/// Mesh `shape_index` of the `.serialized` file `data` (read from `path`).
pub(super) fn parse_serialized(
    data: &[u8],
    path: &Path,
    shape_index: u32,
) -> Result<MeshFile, MeshError> {
    let invalid = |msg: String| MeshError::Invalid {
        path: path.to_path_buf(),
        msg: format!("mesh {shape_index}: {msg}"),
    };
    let version = header(data, 0).map_err(&invalid)?;
    let start = offset_of(data, version, shape_index).map_err(&invalid)?;
    if header(data, start).map_err(&invalid)? != version {
        return Err(invalid(format!(
            "the mesh at byte {start} has another version"
        )));
    }
    let stream = &data[start + 4..];
    // Deflate expands at most about 1032 to 1: larger counts are a broken
    // header, refused before anything that large is allocated.
    let most = (stream.len() as u64).saturating_mul(1032);
    let mut z = Reader {
        inner: ZlibDecoder::new(stream),
    };
    let raw = read_mesh(&mut z, version, most).map_err(&invalid)?;
    finish(raw).map_err(|(no_area, msg)| match no_area {
        true => MeshError::NoArea {
            path: path.to_path_buf(),
            place: format!("mesh {shape_index}"),
            msg,
        },
        false => invalid(msg),
    })
}

/// The version of the mesh header at `at`.
fn header(data: &[u8], at: usize) -> Result<u16, String> {
    let bytes = data.get(at..at + 4).ok_or_else(|| {
        format!(
            "no mesh header at byte {at} (the file has {} bytes)",
            data.len()
        )
    })?;
    let magic = u16::from_le_bytes([bytes[0], bytes[1]]);
    let version = u16::from_le_bytes([bytes[2], bytes[3]]);
    if magic != MAGIC {
        return Err(format!(
            "not a Mitsuba .serialized mesh (byte {at} holds {magic:#06x}, not {MAGIC:#06x})"
        ));
    }
    match version {
        3 | 4 => Ok(version),
        v => Err(format!(
            "version {v}: luz reads versions 3 and 4 (re-save it as PLY, e.g. with Mitsuba's `mesh.write_ply`)"
        )),
    }
}

/// Where mesh `index` starts, from the dictionary at the end of the file.
fn offset_of(data: &[u8], version: u16, index: u32) -> Result<usize, String> {
    if index == 0 {
        return Ok(0);
    }
    let word = |at: usize, len: usize| -> Option<u64> {
        let b = data.get(at..at + len)?;
        Some(match len {
            4 => u32::from_le_bytes(b.try_into().ok()?) as u64,
            _ => u64::from_le_bytes(b.try_into().ok()?),
        })
    };
    let broken = || "the dictionary at the end of the file is cut short".to_string();
    let count = word(data.len().checked_sub(4).ok_or_else(broken)?, 4).ok_or_else(broken)?;
    if index as u64 >= count {
        return Err(format!(
            "`shape_index` {index} is past the file's {count} meshes"
        ));
    }
    let len = if version >= 4 { 8 } else { 4 };
    let from_end = (count - index as u64) as usize * len + 4;
    let at = data.len().checked_sub(from_end).ok_or_else(broken)?;
    let offset = word(at, len).ok_or_else(broken)?;
    usize::try_from(offset)
        .ok()
        .filter(|&o| o < data.len())
        .ok_or_else(|| {
            format!("the dictionary gives mesh {index} an offset past the end ({offset})")
        })
}

/// Little-endian values from the inflated stream.
struct Reader<R: Read> {
    inner: R,
}

impl<R: Read> Reader<R> {
    fn bytes<const N: usize>(&mut self, what: &str) -> Result<[u8; N], String> {
        let mut b = [0; N];
        self.inner
            .read_exact(&mut b)
            .map_err(|e| format!("{what}: the compressed data ends early ({e})"))?;
        Ok(b)
    }

    fn u32(&mut self, what: &str) -> Result<u32, String> {
        self.bytes::<4>(what).map(u32::from_le_bytes)
    }

    fn u64(&mut self, what: &str) -> Result<u64, String> {
        self.bytes::<8>(what).map(u64::from_le_bytes)
    }

    /// `n` values, each `width` f32 or f64 numbers.
    fn floats(&mut self, n: usize, double: bool, what: &str) -> Result<Vec<f32>, String> {
        let size = if double { 8 } else { 4 };
        let mut raw = vec![0u8; n * size];
        self.inner
            .read_exact(&mut raw)
            .map_err(|e| format!("{what}: the compressed data ends early ({e})"))?;
        Ok(match double {
            false => raw
                .chunks_exact(4)
                .map(|c| f32::from_le_bytes(c.try_into().expect("4 bytes")))
                .collect(),
            true => raw
                .chunks_exact(8)
                .map(|c| f64::from_le_bytes(c.try_into().expect("8 bytes")) as f32)
                .collect(),
        })
    }
}

/// A mesh as the file stores it, before the checks.
struct Raw {
    positions: Vec<f32>,
    normals: Option<Vec<f32>>,
    uvs: Option<Vec<f32>>,
    colors: bool,
    indices: Vec<u32>,
}

fn read_mesh<R: Read>(z: &mut Reader<R>, version: u16, most: u64) -> Result<Raw, String> {
    let flags = z.u32("the flags")?;
    if version == 4 {
        let mut name = 0;
        while z.bytes::<1>("the name")?[0] != 0 {
            name += 1;
            if name > MAX_NAME {
                return Err(format!("the mesh's name runs past {MAX_NAME} bytes"));
            }
        }
    }
    let vertices = z.u64("the vertex count")?;
    let triangles = z.u64("the triangle count")?;
    let double = flags & DOUBLE_PRECISION != 0;
    let per_vertex = [
        (true, 3),
        (flags & HAS_NORMALS != 0, 3),
        (flags & HAS_TEXCOORDS != 0, 2),
        (flags & HAS_COLORS != 0, 3),
    ]
    .iter()
    .filter(|(on, _)| *on)
    .map(|(_, n)| n * if double { 8 } else { 4 })
    .sum::<u64>();
    let bytes = vertices
        .checked_mul(per_vertex)
        .and_then(|v| triangles.checked_mul(12).and_then(|t| v.checked_add(t)));
    if vertices > u32::MAX as u64 || bytes.is_none_or(|b| b > most) {
        return Err(format!(
            "{vertices} vertices and {triangles} triangles cannot fit in the compressed data"
        ));
    }
    let (nv, nt) = (vertices as usize, triangles as usize);
    let positions = z.floats(3 * nv, double, "positions")?;
    let normals = (flags & HAS_NORMALS != 0)
        .then(|| z.floats(3 * nv, double, "normals"))
        .transpose()?
        .filter(|_| flags & FACE_NORMALS == 0);
    let uvs = (flags & HAS_TEXCOORDS != 0)
        .then(|| z.floats(2 * nv, double, "texture coordinates"))
        .transpose()?;
    let colors = flags & HAS_COLORS != 0;
    if colors {
        z.floats(3 * nv, double, "vertex colours")?;
    }
    let mut raw = vec![0u8; 12 * nt];
    z.inner
        .read_exact(&mut raw)
        .map_err(|e| format!("triangles: the compressed data ends early ({e})"))?;
    let indices = raw
        .chunks_exact(4)
        .map(|c| u32::from_le_bytes(c.try_into().expect("4 bytes")))
        .collect();
    Ok(Raw {
        positions,
        normals,
        uvs,
        colors,
        indices,
    })
}

/// The checks every mesh passes; `Err((no_area, message))`.
fn finish(raw: Raw) -> Result<MeshFile, (bool, String)> {
    let v3 =
        |f: &[f32]| -> Vec<PackedVec3> { f.chunks_exact(3).map(PackedVec3::from_slice).collect() };
    let positions = v3(&raw.positions);
    let uvs: Option<Vec<Vec2>> = raw
        .uvs
        .map(|f| f.chunks_exact(2).map(Vec2::from_slice).collect());
    let normals = raw.normals.map(|f| v3(&f));
    for (i, p) in positions.iter().enumerate() {
        check_finite(*p, uvs.as_ref().map(|u| u[i]), i).map_err(|m| (false, m))?;
        if let Some(normals) = &normals {
            check_finite_normal(normals[i], i, "normals").map_err(|m| (false, m))?;
        }
    }
    // Unit length, as every reader keeps them for interpolation.
    let normals = normals.map(|ns| ns.into_iter().map(PackedVec3::normalize_or_zero).collect());
    let n = positions.len() as u32;
    let mut indices = Vec::with_capacity(raw.indices.len() / 3);
    for (f, t) in raw.indices.chunks_exact(3).enumerate() {
        if let Some(&i) = t.iter().find(|&&i| i >= n) {
            return Err((false, format!("triangle {f}: vertex {i} of {n}")));
        }
        indices.push([t[0], t[1], t[2]]);
    }
    let triangles = indices.len();
    let dropped = drop_degenerate(&positions, &mut indices);
    if indices.is_empty() {
        return Err((triangles > 0, no_faces(triangles)));
    }
    let mut notes = Vec::new();
    if dropped > 0 {
        notes.push(dropped_note(dropped, triangles));
    }
    if raw.colors {
        notes.push("not used: vertex colours".into());
    }
    notes.extend(zero_normals_note(normals.as_deref()));
    Ok(MeshFile {
        mesh: Mesh {
            positions,
            indices,
            uvs,
            normals,
        },
        notes,
        groups: Default::default(),
    })
}

#[cfg(test)]
mod tests;
