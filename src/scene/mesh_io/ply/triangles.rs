//! Binary faces in bulk: the layout nearly every binary PLY writer uses
//! (a `face` element of one `list uchar int|uint` property, every face a
//! triangle), read as whole arrays in parallel instead of value by value.
//! Anything else, and any record that would be an error, leaves the body to
//! the general reader, so the mesh and every error message are its own.

use super::binary::bytes;
use super::header::{Element, Kind, Ty};
use super::plan::Role;
use crate::meter::Step;
use rayon::prelude::*;
use std::mem::MaybeUninit;

/// A face record of the bulk layout: the count (3) and three 4-byte indices.
const RECORD: usize = 1 + 3 * 4;

/// Records per parallel chunk: large enough that a chunk's setup is
/// noise, small enough that two threads share the work evenly.
const CHUNK: usize = 1 << 16;

/// Reads the triangles of `el` (a face element of `roles`) from `data` at
/// `pos`, with indices below `vertices`, into `indices` (empty: the one
/// face element's), and returns the offset after them; `None`, with
/// `indices` still empty, when the element is not in the bulk layout, the
/// file is too short, or a record has another count or an index out of
/// range.
pub(super) fn bulk_triangles<const BE: bool>(
    data: &[u8],
    pos: usize,
    el: &Element,
    roles: &[Role],
    vertices: usize,
    indices: &mut Vec<[u32; 3]>,
) -> Option<usize> {
    let [p] = el.props.as_slice() else {
        return None;
    };
    let (Kind::List(Ty::U8, item @ (Ty::I32 | Ty::U32)), [Role::Indices]) = (p.kind, roles) else {
        return None;
    };
    let end = el.count.checked_mul(RECORD)?.checked_add(pos)?;
    let records = data.get(pos..end)?;
    // An `int` index reads as u32: a negative one is then at least 2^31,
    // which the limit puts out of range.
    let limit = match item {
        Ty::I32 => vertices.min(1 << 31),
        _ => vertices,
    } as u64;
    debug_assert!(indices.is_empty());
    // The builder reserved the header's face count already.
    indices.reserve_exact(el.count);
    let progress = Step::current();
    let all_good = indices.spare_capacity_mut()[..el.count]
        .par_chunks_mut(CHUNK)
        .zip(records.par_chunks(CHUNK * RECORD))
        .map(|(out, records)| {
            progress.advance(records.len());
            read_chunk::<BE>(out, records, limit)
        })
        .reduce(|| true, |a, b| a & b);
    if !all_good {
        return None;
    }
    // SAFETY: `read_chunk` wrote every one of the `el.count` slots.
    unsafe { indices.set_len(el.count) };
    Some(end)
}

/// Writes the triangle of each record of `records` into `out` (one slot
/// per record, every slot written); whether every record is a triangle
/// with indices below `limit`. Branch-free per record, so it vectorises.
#[inline]
fn read_chunk<const BE: bool>(
    out: &mut [MaybeUninit<[u32; 3]>],
    records: &[u8],
    limit: u64,
) -> bool {
    let mut good = true;
    for (slot, r) in out.iter_mut().zip(records.chunks_exact(RECORD)) {
        let index = |k: usize| u32::from_le_bytes(bytes::<4, BE>(&r[1 + 4 * k..]));
        let t = [index(0), index(1), index(2)];
        good &= (r[0] == 3)
            & ((t[0] as u64) < limit)
            & ((t[1] as u64) < limit)
            & ((t[2] as u64) < limit);
        slot.write(t);
    }
    good
}

#[cfg(test)]
mod tests {
    use crate::scene::mesh_io::load_mesh;
    use crate::scene::mesh_io::test_support::{err, push_ordered, write};

    /// A binary PLY of a 3×3 vertex grid and its 8 triangles, whose face
    /// records are `count` then the indices as `item` (`int` or `uint`).
    fn grid(be: bool, item: &str, faces: &[(u8, [i32; 3])]) -> (Vec<u8>, usize) {
        let fmt = if be { "big" } else { "little" };
        let mut data = format!(
            "ply\nformat binary_{fmt}_endian 1.0\nelement vertex 9\nproperty float x\n\
             property float y\nproperty float z\nelement face {}\n\
             property list uchar {item} vertex_indices\nend_header\n",
            faces.len()
        )
        .into_bytes();
        for k in 0..9 {
            for c in [(k % 3) as f32, (k / 3) as f32, 0.0] {
                push_ordered(&mut data, &c.to_le_bytes(), be);
            }
        }
        let faces_at = data.len();
        for (count, t) in faces {
            data.push(*count);
            for i in t {
                push_ordered(&mut data, &i.to_le_bytes(), be);
            }
        }
        (data, faces_at)
    }

    fn triangles() -> Vec<(u8, [i32; 3])> {
        (0..4)
            .flat_map(|q| {
                let a = q % 2 + 3 * (q / 2);
                [(3, [a, a + 1, a + 4]), (3, [a, a + 4, a + 3])]
            })
            .collect()
    }

    /// The bulk path reads what the record-by-record path reads, in both
    /// byte orders and both index types.
    #[test]
    fn bulk_faces_are_the_records() {
        for be in [false, true] {
            for item in ["int", "uint"] {
                let m = load_mesh(&write("bulk.ply", &grid(be, item, &triangles()).0)).unwrap();
                let want: Vec<[u32; 3]> = triangles()
                    .iter()
                    .map(|(_, t)| t.map(|i| i as u32))
                    .collect();
                assert_eq!(m.indices, want, "{be} {item}");
            }
        }
    }

    /// A bad record leaves the body to the general reader: its error, at
    /// the byte of the bad value.
    #[test]
    fn bad_records_get_the_general_error() {
        let mut faces = triangles();
        faces[5].1[2] = 9;
        let (data, at) = grid(false, "uint", &faces);
        let e = err("bulk-range.ply", &data);
        let byte = at + 5 * 13 + 1 + 2 * 4;
        assert_eq!(
            e,
            format!(": byte {byte}: face 5: vertex index 9 is out of range (9 vertices)")
        );
        faces[5].1[2] = -1;
        let e = err("bulk-negative.ply", &grid(true, "int", &faces).0);
        assert!(e.contains("face 5: vertex index -1 is out of range"), "{e}");
        // A file cut short in its faces: the general reader's message.
        let mut data = grid(false, "int", &triangles()[..7]).0;
        let at = data
            .windows(14)
            .position(|w| w == b"element face 7")
            .unwrap();
        data[at + 13] = b'8';
        let e = err("bulk-short.ply", &data);
        assert!(e.contains("file ends early"), "{e}");
    }
}
