//! Flat midpoint subdivision of a triangle mesh, and a binary PLY writer:
//! the meshes of the scale benchmark and of the scale test. Each triangle is
//! split into four on its own plane, so the surface, and hence the image,
//! is the same at every level while the triangle count grows fourfold.

use luz::geometry::Mesh;
use luz::math::PackedVec3;
use std::collections::HashMap;
use std::io::Write;
use std::path::Path;

/// One level of midpoint subdivision; a midpoint shared by two triangles is
/// one vertex, so the result is as connected as the input.
pub fn subdivide(mesh: &Mesh) -> Mesh {
    let mut positions = mesh.positions.clone();
    let mut midpoints: HashMap<(u32, u32), u32> = HashMap::with_capacity(mesh.indices.len() * 2);
    let mut midpoint = |a: u32, b: u32, positions: &mut Vec<PackedVec3>| {
        let key = (a.min(b), a.max(b));
        *midpoints.entry(key).or_insert_with(|| {
            let p = 0.5 * (positions[a as usize] + positions[b as usize]);
            positions.push(p);
            (positions.len() - 1) as u32
        })
    };
    let mut indices = Vec::with_capacity(mesh.indices.len() * 4);
    for &[a, b, c] in &mesh.indices {
        let ab = midpoint(a, b, &mut positions);
        let bc = midpoint(b, c, &mut positions);
        let ca = midpoint(c, a, &mut positions);
        indices.extend([[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]);
    }
    Mesh {
        positions,
        indices,
        uvs: None,
        normals: None,
    }
}

/// Writes `mesh` as a binary little-endian PLY (float x y z; uchar/int
/// faces), the layout scanned meshes usually come in.
pub fn write_ply(mesh: &Mesh, path: &Path) -> std::io::Result<()> {
    let mut out = std::io::BufWriter::new(std::fs::File::create(path)?);
    write!(
        out,
        "ply\nformat binary_little_endian 1.0\nelement vertex {}\n\
         property float x\nproperty float y\nproperty float z\n\
         element face {}\nproperty list uchar int vertex_indices\nend_header\n",
        mesh.positions.len(),
        mesh.indices.len()
    )?;
    for p in &mesh.positions {
        for c in [p.x, p.y, p.z] {
            out.write_all(&c.to_le_bytes())?;
        }
    }
    for t in &mesh.indices {
        out.write_all(&[3])?;
        for i in t {
            out.write_all(&i.to_le_bytes())?;
        }
    }
    out.flush()
}
