//! The checks every mesh passes whatever its format (finite coordinates,
//! degenerate triangles dropped, at least one face left) and the notes on
//! what of a file luz did not use.

use crate::math::{Vec2, Vec3};

pub(super) fn check_finite(p: Vec3, uv: Option<Vec2>, vertex: usize) -> Result<(), String> {
    if !p.is_finite() {
        return Err(format!(
            "vertex {vertex}: coordinates must be finite, got ({}, {}, {})",
            p.x, p.y, p.z
        ));
    }
    if let Some(uv) = uv {
        if !uv.is_finite() {
            return Err(format!(
                "vertex {vertex}: texture coordinates must be finite, got ({}, {})",
                uv.x, uv.y
            ));
        }
    }
    Ok(())
}

/// A list for a note, cut after the first few items.
pub(super) fn summarize(items: &[String]) -> String {
    const SHOWN: usize = 8;
    let mut s = items[..items.len().min(SHOWN)].join(", ");
    if items.len() > SHOWN {
        s.push_str(&format!(" and {} more", items.len() - SHOWN));
    }
    s
}

pub(super) fn dropped_note(dropped: usize, triangles: usize) -> String {
    format!("dropped {dropped} of {triangles} triangles, degenerate (no area)")
}

pub(super) fn no_faces(triangles: usize) -> String {
    match triangles {
        0 => "the file has no faces".into(),
        n => format!("all {n} triangles are degenerate (collinear vertices)"),
    }
}

/// Whether the triangle's vertices are collinear to f32 precision: a
/// repeated vertex, or |e1 × e2| ≤ 1e-6 |e1| |e2| (an angle under 1e-6 rad
/// at `a`). Such a triangle has no area to render and no reliable normal,
/// yet intersection tests still report hits on it: the extremes suite
/// measured zero or random normals and self-hits on both backends when a
/// mesh kept them.
///
/// A triangle whose f32 cross product underflows to zero (edges of 1e-20)
/// is degenerate too, whatever its shape: its normal would be zero and the
/// intersection tests never hit it ([`crate::geometry::has_zero_area`]).
pub(crate) fn is_degenerate(p @ [a, b, c]: [Vec3; 3]) -> bool {
    if crate::geometry::has_zero_area(p) {
        return true;
    }
    // In f64, so no finite f32 coordinates overflow.
    let (a, b, c) = (a.as_dvec3(), b.as_dvec3(), c.as_dvec3());
    let (e1, e2) = (b - a, c - a);
    e1.cross(e2).length() <= 1e-6 * e1.length() * e2.length()
}

/// Drops the degenerate triangles (see [`is_degenerate`]). Most meshes have
/// none, so a parallel search comes first and the (serial) removal runs
/// only when it finds one. Returns how many it dropped.
pub(crate) fn drop_degenerate(positions: &[Vec3], indices: &mut Vec<[u32; 3]>) -> usize {
    use rayon::prelude::*;
    let degenerate = |t: &[u32; 3]| is_degenerate(t.map(|i| positions[i as usize]));
    let before = indices.len();
    if indices.par_iter().with_min_len(4096).any(degenerate) {
        indices.retain(|t| !degenerate(t));
    }
    before - indices.len()
}

#[cfg(test)]
mod tests {
    use super::super::test_support::{err, ply};

    #[test]
    fn zero_faces_is_an_error() {
        let text = ply("0 0 0\n1 0 0\n0 1 0\n").replace("face 1", "face 0");
        let e = err("z.ply", text.as_bytes());
        assert_eq!(e, ":7:1: the file has no faces");
        let e = err("z.obj", b"v 0 0 0\nv 1 0 0\n");
        assert_eq!(e, ":3:1: the file has no faces");
        let e = err("d.ply", ply("0 0 0\n1 0 0\n2 0 0\n3 0 1 2\n").as_bytes());
        assert_eq!(
            e,
            ":7:1: all 1 triangles are degenerate (collinear vertices)"
        );
    }
}
