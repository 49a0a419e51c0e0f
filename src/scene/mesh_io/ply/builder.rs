//! The mesh a PLY body's records are read into.

use crate::math::{Vec2, Vec3};
use crate::memory;
use crate::scene::mesh_io::checks::check_finite;

pub(super) struct Builder {
    pub(super) positions: Vec<Vec3>,
    pub(super) uvs: Option<Vec<Vec2>>,
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
    pub(super) fn new(nv: usize, nf: usize, has_uv: bool, body_len: usize) -> Builder {
        // Counts come from the file; never reserve more than the body could hold.
        Builder {
            positions: memory::vec_with_capacity(nv.min(body_len / 3)),
            uvs: has_uv.then(|| memory::vec_with_capacity(nv.min(body_len / 5))),
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
        self.indices.extend_from_slice(&part.indices);
    }

    pub(super) fn vertex(&mut self, v: [f32; 5]) -> Result<(), String> {
        let p = Vec3::new(v[0], v[1], v[2]);
        let uv = Vec2::new(v[3], v[4]);
        let n = self.base + self.positions.len();
        check_finite(p, self.uvs.is_some().then_some(uv), n)?;
        self.positions.push(p);
        if let Some(uvs) = &mut self.uvs {
            uvs.push(uv);
        }
        Ok(())
    }

    /// Appends the vertices `records`, x y z as little-endian f32 and nothing
    /// else, when there are no texture coordinates; a failure names the
    /// vertex by its place in `records`.
    pub(super) fn packed_positions(&mut self, records: &[u8]) -> Result<(), (usize, String)> {
        debug_assert!(self.uvs.is_none() && records.len().is_multiple_of(12));
        let first = self.positions.len();
        self.positions
            .resize(first + records.len() / 12, Vec3::ZERO);
        let added: &mut [u8] = bytemuck::cast_slice_mut(&mut self.positions[first..]);
        added.copy_from_slice(records);
        match self.positions[first..].iter().position(|p| !p.is_finite()) {
            Some(k) => Err((
                k,
                check_finite(self.positions[first + k], None, first + k).unwrap_err(),
            )),
            None => Ok(()),
        }
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
