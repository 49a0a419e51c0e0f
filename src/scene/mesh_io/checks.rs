//! The checks every mesh passes whatever its format (finite coordinates,
//! degenerate triangles dropped, at least one face left) and the notes on
//! what of a file luz did not use.

use super::groups::MaterialGroups;
use crate::math::{PackedVec3, Vec2};

pub(super) fn check_finite(p: PackedVec3, uv: Option<Vec2>, vertex: usize) -> Result<(), String> {
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

/// Fails for a vertex normal that is not finite; `fields` names them as
/// the file does.
pub(super) fn check_finite_normal(
    n: PackedVec3,
    vertex: usize,
    fields: &str,
) -> Result<(), String> {
    if n.is_finite() {
        return Ok(());
    }
    Err(format!(
        "vertex {vertex}: normal ({fields}) must be finite, got ({}, {}, {})",
        n.x, n.y, n.z
    ))
}

/// The note on an OBJ file whose faces give normals at some corners only:
/// the mesh is shaded flat.
pub(super) const NORMALS_DROPPED: &str = "vertex normals dropped: not every face has them";

/// The note on a mesh's vertex normals of zero length, if it has any:
/// shading takes the face normal at such a vertex's corners.
pub(super) fn zero_normals_note(normals: Option<&[PackedVec3]>) -> Option<String> {
    let zero = normals?.iter().filter(|n| **n == PackedVec3::ZERO).count();
    (zero > 0).then(|| {
        format!("{zero} vertex normals of zero length: the face normal stands in at their corners")
    })
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
pub(crate) fn is_degenerate(p @ [a, b, c]: [PackedVec3; 3]) -> bool {
    if crate::geometry::has_zero_area(p.map(Into::into)) {
        return true;
    }
    // In f64, so no finite f32 coordinates overflow.
    let (a, b, c) = (a.as_dvec3(), b.as_dvec3(), c.as_dvec3());
    let (e1, e2) = (b - a, c - a);
    e1.cross(e2).length() <= 1e-6 * e1.length() * e2.length()
}

/// How [`is_degenerate`] answers for `p`: `SURE_NO` straight from the f32
/// test where that is sure ([`surely_not_degenerate`], most triangles),
/// else from squared f64 lengths (no square roots, no branches):
/// `SURE_NO`, `SURE_YES`, or `UNSURE` within a relative 1e-6 of the
/// threshold, where only [`is_degenerate`] itself decides. Every finite f32
/// triangle's squared f64 lengths and products stay inside f64's normal
/// range (≤ 1e156, ≥ 1e-180), and the rounding of either form is a few
/// ulps (1e-15 relative), far inside the margin, so a sure answer is
/// [`is_degenerate`]'s.
#[inline(always)]
fn classify(p @ [a, b, c]: [PackedVec3; 3]) -> u8 {
    if surely_not_degenerate(p) {
        return SURE_NO;
    }
    let zero = crate::geometry::has_zero_area(p.map(Into::into));
    let (a, b, c) = (a.as_dvec3(), b.as_dvec3(), c.as_dvec3());
    let (e1, e2) = (b - a, c - a);
    let x = e1.cross(e2).length_squared();
    let t = 1e-12 * e1.length_squared() * e2.length_squared();
    let above = x > t * (1.0 + 1e-6);
    let below = x < t * (1.0 - 1e-6);
    // NaN (not from a validated file) fails both and goes to the exact test.
    let yes = zero | below;
    let no = !zero & above;
    (yes as u8) * SURE_YES + (no as u8) * SURE_NO + (!yes & !no) as u8 * UNSURE
}

/// Whether the triangle is surely not degenerate, from f32 arithmetic
/// alone (a fifth of [`classify`]'s time on large meshes): its angle at
/// `a` is at least 2e-6 rad, twice the threshold. With both squared edge
/// lengths within [`F32_SAFE`], nothing overflows and no product or sum
/// that matters reaches the subnormals, so the computed cross product is
/// within about 5.5 · 2^-24 |e1| |e2| < 4e-7 |e1| |e2| of the exact one
/// (edges rounded once, then two products and a difference per
/// component), and the squared lengths within about 11 ulps: an answer of
/// `true` is [`is_degenerate`]'s `false`. `false` means not sure.
#[inline(always)]
fn surely_not_degenerate([a, b, c]: [PackedVec3; 3]) -> bool {
    let (e1, e2) = (b - a, c - a);
    let (l1, l2) = (e1.length_squared(), e2.length_squared());
    let x = e1.cross(e2).length_squared();
    F32_SAFE.contains(&l1) & F32_SAFE.contains(&l2) & (x >= 4e-12 * (l1 * l2))
}

/// Squared edge lengths for which [`surely_not_degenerate`]'s bound holds:
/// 2^-40 to 2^60.
const F32_SAFE: std::ops::RangeInclusive<f32> = 9.094_947e-13..=1.152_921_5e18;

const SURE_NO: u8 = 0;
const SURE_YES: u8 = 1;
const UNSURE: u8 = 2;

/// Whether triangle `t` of `positions` is degenerate: [`is_degenerate`],
/// through [`classify`].
#[inline(always)]
fn degenerate_at(positions: &[PackedVec3], t: &[u32; 3]) -> bool {
    let p = t.map(|i| positions[i as usize]);
    match classify(p) {
        SURE_NO => false,
        SURE_YES => true,
        _ => is_degenerate(p),
    }
}

/// Whether any triangle of `block` is degenerate: one pass of
/// [`classify`], then the exact test only for the unsure ones.
fn any_degenerate(positions: &[PackedVec3], block: &[[u32; 3]]) -> bool {
    let mut seen = 0u8;
    for t in block {
        seen |= 1 << classify(t.map(|i| positions[i as usize]));
    }
    seen & (1 << SURE_YES) != 0
        || seen & (1 << UNSURE) != 0 && block.iter().any(|t| degenerate_at(positions, t))
}

/// Drops the degenerate triangles (see [`is_degenerate`]). Most meshes have
/// none, so a parallel search comes first (blocks of the f32 test, then
/// [`classify`] where it is not sure, the exact test only near the
/// threshold); when it finds one, the triangles
/// are marked in parallel and the marks drive one serial compaction.
/// Returns how many it dropped.
pub(crate) fn drop_degenerate(positions: &[PackedVec3], indices: &mut Vec<[u32; 3]>) -> usize {
    drop_degenerate_grouped(positions, indices, &mut MaterialGroups::default())
}

/// [`drop_degenerate`], keeping the material runs of an OBJ mesh in step.
pub(crate) fn drop_degenerate_grouped(
    positions: &[PackedVec3],
    indices: &mut Vec<[u32; 3]>,
    groups: &mut MaterialGroups,
) -> usize {
    use rayon::prelude::*;
    const BLOCK: usize = 1 << 13;
    if !indices
        .par_chunks(BLOCK)
        .any(|block| any_degenerate(positions, block))
    {
        return 0;
    }
    let drop: Vec<bool> = indices
        .par_iter()
        .with_min_len(BLOCK)
        .map(|t| degenerate_at(positions, t))
        .collect();
    let before = indices.len();
    let mut marks = drop.iter();
    indices.retain(|_| !marks.next().copied().unwrap_or(false));
    groups.drop_triangles(&drop);
    before - indices.len()
}

#[cfg(test)]
mod tests {
    use super::super::test_support::{err, ply};
    use super::{degenerate_at, drop_degenerate, is_degenerate, surely_not_degenerate};
    use crate::math::PackedVec3;

    fn xorshift(x: &mut u64) -> u64 {
        *x ^= *x << 13;
        *x ^= *x >> 7;
        *x ^= *x << 17;
        *x
    }

    /// The cheap test answers as [`is_degenerate`] does: on random
    /// triangles at many scales, on triangles whose angle straddles the
    /// threshold by a few ulps, on repeated vertices and on underflow.
    #[test]
    fn cheap_test_matches_the_exact_one() {
        fn unit(x: &mut u64) -> f32 {
            (xorshift(x) >> 40) as f32 / (1u64 << 24) as f32 - 0.5
        }
        let mut x = 0x9e37_79b9_7f4a_7c15u64;
        let mut tris = Vec::new();
        for k in 0..200_000 {
            // Every case meets every scale.
            let scale = [1e-30f32, 1e-20, 1e-6, 1.0, 1e6, 1e30][(k / 4) % 6];
            let v = |x: &mut u64| PackedVec3::new(unit(x), unit(x), unit(x)) * scale;
            let a = v(&mut x);
            let mut b = v(&mut x);
            let c = match k % 4 {
                0 => v(&mut x),
                1 => a,
                2 => a + (b - a) * unit(&mut x),
                _ => {
                    // Angle at `a` near the threshold of 1e-6 rad (within
                    // ±1.5e-7 once `c` is nudged by a few ulps), on both
                    // sides of it.
                    b = a + PackedVec3::X * scale;
                    let h = 1e-6 * (1.0 + 1e-5 * unit(&mut x));
                    let c = a + PackedVec3::new(1.0, h, 0.0) * scale;
                    PackedVec3::from_array(c.to_array().map(|f| {
                        f32::from_bits(f.to_bits().wrapping_add((xorshift(&mut x) % 5) as u32))
                    }))
                }
            };
            tris.push([a, b, c]);
        }
        let positions: Vec<PackedVec3> = tris.iter().flatten().copied().collect();
        let indices: Vec<[u32; 3]> = (0..tris.len() as u32)
            .map(|i| [3 * i, 3 * i + 1, 3 * i + 2])
            .collect();
        let (mut want, mut sure) = (0, 0);
        for (t, p) in indices.iter().zip(&tris) {
            let exact = is_degenerate(*p);
            want += exact as usize;
            assert_eq!(degenerate_at(&positions, t), exact, "{p:?}");
            if surely_not_degenerate(*p) {
                assert!(!exact, "f32 sure of {p:?}");
                sure += 1;
            }
        }
        assert!(want > 1000 && want < tris.len() - 1000, "{want}");
        // The f32 test decides the plain random triangles (a quarter of
        // all) at the scales within its range (1 and 1e6, a third), and
        // leaves the others to the f64 one, the near-threshold ones among
        // them.
        let random = tris.len() / 4;
        assert!(sure > random / 4 && sure <= random / 2, "{sure}");
        // Both sides of the threshold are met there.
        let near = tris.iter().skip(3).step_by(4);
        let near_degenerate = near.clone().filter(|p| is_degenerate(**p)).count();
        assert!(
            near_degenerate > 1000 && near_degenerate < near.count() - 1000,
            "{near_degenerate}"
        );
        let mut kept = indices.clone();
        let dropped = drop_degenerate(&positions, &mut kept);
        let mut old = indices.clone();
        old.retain(|t| !is_degenerate(t.map(|i| positions[i as usize])));
        assert_eq!((dropped, &kept), (want, &old));
        // One bad triangle at the very end of a long clean list.
        let good = tris.iter().position(|p| !is_degenerate(*p)).unwrap();
        let bad = tris.iter().position(|p| is_degenerate(*p)).unwrap();
        let mut clean = vec![indices[good]; 100_000];
        clean.push(indices[bad]);
        assert_eq!(drop_degenerate(&positions, &mut clean), 1);
        assert_eq!(clean.len(), 100_000);
    }

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
