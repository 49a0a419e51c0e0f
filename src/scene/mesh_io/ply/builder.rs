//! The mesh a PLY body's records are read into.

use super::plan::{Plan, Vertex};
use crate::math::{PackedVec3, Vec2};
use crate::memory;
use crate::meter::Step;
use crate::scene::mesh_io::checks::{check_finite, check_finite_normal};
use rayon::prelude::*;
use std::mem::MaybeUninit;

pub(super) struct Builder {
    pub(super) positions: Vec<PackedVec3>,
    pub(super) uvs: Option<Vec<Vec2>>,
    pub(super) normals: Option<Vec<PackedVec3>>,
    pub(super) indices: Vec<[u32; 3]>,
    nv: u32,
    poly: Vec<u32>,
    /// The number of the first vertex this builder holds: 0, or where a
    /// chunk of the body starts.
    base: usize,
}

impl Builder {
    /// A builder for `nv` vertices (`nv` ≤ `u32::MAX`, checked by the plan)
    /// and `nf` faces from a body of `body_len` bytes.
    pub(super) fn new(nv: usize, nf: usize, plan: &Plan, body_len: usize) -> Builder {
        // Counts come from the file; never reserve more than the body could hold.
        Builder {
            positions: memory::vec_with_capacity(nv.min(body_len / 3)),
            uvs: plan
                .has_uv
                .then(|| memory::vec_with_capacity(nv.min(body_len / 5))),
            normals: plan
                .has_normals
                .then(|| memory::vec_with_capacity(nv.min(body_len / 6))),
            indices: memory::vec_with_capacity(nf.min(body_len / 4)),
            nv: nv as u32,
            poly: Vec::new(),
            base: 0,
        }
    }

    /// A builder for a chunk of the body, whose first vertex (if any) is
    /// vertex `base`, with room for `vertices` vertices and `faces`
    /// triangles; the same counts to check indices against.
    pub(super) fn part(&self, base: usize, vertices: usize, faces: usize) -> Builder {
        Builder {
            positions: Vec::with_capacity(vertices),
            uvs: self.uvs.as_ref().map(|_| Vec::with_capacity(vertices)),
            normals: self.normals.as_ref().map(|_| Vec::with_capacity(vertices)),
            indices: Vec::with_capacity(faces),
            nv: self.nv,
            poly: Vec::new(),
            base,
        }
    }

    /// Appends what `part`, the builder of the next chunk, read.
    pub(super) fn append(&mut self, part: Builder) {
        self.positions.extend_from_slice(&part.positions);
        if let (Some(uvs), Some(more)) = (&mut self.uvs, &part.uvs) {
            uvs.extend_from_slice(more);
        }
        if let (Some(normals), Some(more)) = (&mut self.normals, &part.normals) {
            normals.extend_from_slice(more);
        }
        self.indices.extend_from_slice(&part.indices);
    }

    pub(super) fn vertex(&mut self, v: Vertex) -> Result<(), String> {
        let p = PackedVec3::new(v[0], v[1], v[2]);
        let uv = Vec2::new(v[3], v[4]);
        let normal = PackedVec3::new(v[5], v[6], v[7]);
        let n = self.base + self.positions.len();
        check_finite(p, self.uvs.is_some().then_some(uv), n)?;
        self.positions.push(p);
        if let Some(uvs) = &mut self.uvs {
            uvs.push(uv);
        }
        if let Some(normals) = &mut self.normals {
            check_finite_normal(normal, n, "nx ny nz")?;
            normals.push(normal.normalize_or_zero());
        }
        Ok(())
    }

    /// Appends the vertices `records`, x y z as little-endian f32 and nothing
    /// else, when there are no texture coordinates; a failure names the
    /// first bad vertex by its place in `records`. Chunks are copied and
    /// checked in parallel, each while it is in cache, straight into the
    /// reserved positions: no serial clearing, copy and scan of hundreds of
    /// megabytes.
    pub(super) fn packed_positions(&mut self, records: &[u8]) -> Result<(), (usize, String)> {
        debug_assert!(
            self.uvs.is_none() && self.normals.is_none() && records.len().is_multiple_of(12)
        );
        let first = self.positions.len();
        let count = records.len() / 12;
        self.positions.reserve_exact(count);
        let progress = Step::current();
        let bad = self.positions.spare_capacity_mut()[..count]
            .par_chunks_mut(VERTEX_CHUNK)
            .zip(records.par_chunks(VERTEX_CHUNK * 12))
            .enumerate()
            .filter_map(|(c, (out, records))| {
                progress.advance(records.len());
                copy_positions(out, records)
                    .iter()
                    .position(|p| !p.is_finite())
                    .map(|k| c * VERTEX_CHUNK + k)
            })
            .min();
        // SAFETY: `copy_positions` wrote every one of the `count` slots.
        unsafe { self.positions.set_len(first + count) };
        match bad {
            Some(k) => Err((
                k,
                check_finite(self.positions[first + k], None, first + k).unwrap_err(),
            )),
            None => Ok(()),
        }
    }

    /// What the builder holds, for [`rollback`](Self::rollback).
    pub(super) fn mark(&self) -> (usize, usize) {
        (self.positions.len(), self.indices.len())
    }

    /// Forgets what was read after `mark`, and the face being read.
    pub(super) fn rollback(&mut self, (vertices, triangles): (usize, usize)) {
        self.positions.truncate(vertices);
        if let Some(uvs) = &mut self.uvs {
            uvs.truncate(vertices);
        }
        if let Some(normals) = &mut self.normals {
            normals.truncate(vertices);
        }
        self.indices.truncate(triangles);
        self.poly.clear();
    }

    /// The number of vertices indices must stay below.
    pub(super) fn vertex_count(&self) -> usize {
        self.nv as usize
    }

    #[inline]
    pub(super) fn index(&mut self, i: i64, face: usize) -> Result<(), String> {
        if i < 0 || i >= self.nv as i64 {
            return Err(format!(
                "face {face}: vertex index {i} is out of range ({} vertices)",
                self.nv
            ));
        }
        self.poly.push(i as u32);
        Ok(())
    }

    pub(super) fn end_face(&mut self, face: usize) -> Result<(), String> {
        let r = push_polygon(&self.poly, face, &mut self.indices);
        self.poly.clear();
        r
    }
}

/// Vertices per parallel chunk of [`Builder::packed_positions`]: 384 KiB,
/// which stays in a core's cache between the copy and the check.
const VERTEX_CHUNK: usize = 1 << 15;

/// Writes the packed x y z `records` into `out`, one slot per 12 bytes, and
/// returns the written slots.
fn copy_positions<'a>(out: &'a mut [MaybeUninit<PackedVec3>], records: &[u8]) -> &'a [PackedVec3] {
    assert_eq!(out.len() * size_of::<PackedVec3>(), records.len());
    // SAFETY: `PackedVec3` is three f32 without padding (it is `Pod`), so any 12
    // bytes are one; the lengths match (checked above) and the slices are
    // distinct allocations. Every slot of `out` is written before it is
    // read back as `PackedVec3`.
    unsafe {
        std::ptr::copy_nonoverlapping(
            records.as_ptr(),
            out.as_mut_ptr().cast::<u8>(),
            records.len(),
        );
        std::slice::from_raw_parts(out.as_ptr().cast::<PackedVec3>(), out.len())
    }
}

/// Appends the fan triangulation of `poly`, face number `face`.
pub(super) fn push_polygon(
    poly: &[u32],
    face: usize,
    out: &mut Vec<[u32; 3]>,
) -> Result<(), String> {
    if poly.len() < 3 {
        return Err(format!(
            "face {face} has {} vertices; a face needs at least 3",
            poly.len()
        ));
    }
    for i in 1..poly.len() - 1 {
        out.push([poly[0], poly[i], poly[i + 1]]);
    }
    Ok(())
}
