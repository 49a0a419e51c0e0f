//! The body of a binary PLY, either endianness: fixed-size records read at
//! offsets, records with lists walked value by value; errors at the byte.

use super::builder::Builder;
use super::header::{Element, Kind, Property, Ty};
use super::plan::{Role, Vertex};
use super::trailing;
use super::triangles::bulk_triangles;
use crate::scene::mesh_io::fail::{fail_byte, short, Fail};

/// The `N` bytes at the start of `b` in little-endian order.
#[inline(always)]
pub(super) fn bytes<const N: usize, const BE: bool>(b: &[u8]) -> [u8; N] {
    let mut a: [u8; N] = b[..N].try_into().unwrap();
    if BE {
        a.reverse();
    }
    a
}

/// Reads a scalar as f64 from the start of `b` (which holds at least its size).
#[inline(always)]
fn get<const BE: bool>(b: &[u8], ty: Ty) -> f64 {
    match ty {
        Ty::I8 => b[0] as i8 as f64,
        Ty::U8 => b[0] as f64,
        Ty::I16 => i16::from_le_bytes(bytes::<2, BE>(b)) as f64,
        Ty::U16 => u16::from_le_bytes(bytes::<2, BE>(b)) as f64,
        Ty::I32 => i32::from_le_bytes(bytes::<4, BE>(b)) as f64,
        Ty::U32 => u32::from_le_bytes(bytes::<4, BE>(b)) as f64,
        Ty::F32 => f32::from_le_bytes(bytes::<4, BE>(b)) as f64,
        Ty::F64 => f64::from_le_bytes(bytes::<8, BE>(b)),
    }
}

/// Reads an integer scalar from the start of `b`.
#[inline(always)]
pub(super) fn get_int<const BE: bool>(b: &[u8], ty: Ty) -> i64 {
    match ty {
        Ty::I8 => b[0] as i8 as i64,
        Ty::U8 => b[0] as i64,
        Ty::I16 => i16::from_le_bytes(bytes::<2, BE>(b)) as i64,
        Ty::U16 => u16::from_le_bytes(bytes::<2, BE>(b)) as i64,
        Ty::I32 => i32::from_le_bytes(bytes::<4, BE>(b)) as i64,
        Ty::U32 => u32::from_le_bytes(bytes::<4, BE>(b)) as i64,
        Ty::F32 | Ty::F64 => unreachable!("integer types are checked by the header"),
    }
}

/// Reads the binary body of `data`, which starts at offset `body`.
pub(super) fn binary_body<const BE: bool>(
    data: &[u8],
    body: usize,
    elements: &[Element],
    roles: &[Vec<Role>],
    out: &mut Builder,
) -> Result<(), Fail> {
    let mut pos = body;
    for (el, roles) in elements.iter().zip(roles) {
        let stride = el.props.iter().try_fold(0usize, |s, p| match p.kind {
            Kind::Scalar(ty) => Some(s + ty.size()),
            Kind::List(..) => None,
        });
        pos = match stride {
            Some(stride) => fixed_records::<BE>(data, pos, stride, el, roles, out)?,
            None => {
                let vertices = out.vertex_count();
                match bulk_triangles::<BE>(data, pos, el, roles, vertices, &mut out.indices) {
                    Some(end) => end,
                    None => list_records::<BE>(data, 0, pos, el, roles, 0..el.count, out)?,
                }
            }
        };
    }
    if pos < data.len() {
        return Err(trailing_bytes(pos, data.len(), elements));
    }
    Ok(())
}

/// The failure of the bytes from `pos` to `total`, the end of the file,
/// after the last element.
pub(super) fn trailing_bytes(pos: usize, total: usize, elements: &[Element]) -> Fail {
    let mut f = trailing(pos, elements, false);
    f.msg = format!("{} bytes: {}", total - pos, f.msg);
    f
}

/// The failure of record `r` of `el`, cut off at byte `pos` of a file of
/// `total` bytes.
pub(super) fn truncated(total: usize, el: &Element, r: usize, pos: usize) -> Fail {
    fail_byte(
        pos,
        format!(
            "file ends early: {} {r} of {} is cut off ({total} bytes in all)",
            short(&el.name),
            el.count,
        ),
    )
}

/// The failure of `el`, whose records are `stride` bytes from `pos` on,
/// when a file of `total` bytes cannot hold them all.
pub(super) fn cut_element(total: usize, pos: usize, stride: usize, el: &Element) -> Option<Fail> {
    let left = total - pos;
    let need = stride.checked_mul(el.count);
    need.is_none_or(|n| n > left).then(|| {
        let r = left / stride.max(1);
        truncated(total, el, r, pos + r * stride)
    })
}

/// Reads the records of `el`, all `stride` bytes long, from offset `pos`;
/// returns the offset after them.
fn fixed_records<const BE: bool>(
    data: &[u8],
    pos: usize,
    stride: usize,
    el: &Element,
    roles: &[Role],
    out: &mut Builder,
) -> Result<usize, Fail> {
    // Check the length once, then read at offsets.
    if let Some(f) = cut_element(data.len(), pos, stride, el) {
        return Err(f);
    }
    let need = stride * el.count;
    if roles.contains(&Role::Value(0)) && stride > 0 {
        fixed_vertices::<BE>(&data[pos..pos + need], pos, stride, el, roles, out)?;
    }
    Ok(pos + need)
}

/// Reads the vertices of `records`, which start at offset `pos` of the
/// file and are `stride` bytes each.
pub(super) fn fixed_vertices<const BE: bool>(
    records: &[u8],
    pos: usize,
    stride: usize,
    el: &Element,
    roles: &[Role],
    out: &mut Builder,
) -> Result<(), Fail> {
    // (offset in the record, type, component) of each value read.
    let mut fields = Vec::new();
    let mut off = 0;
    for (p, &role) in el.props.iter().zip(roles) {
        let Kind::Scalar(ty) = p.kind else {
            unreachable!()
        };
        if let Role::Value(c) = role {
            fields.push((off, ty, c));
        }
        off += ty.size();
    }
    // The common layout: one copy into the positions instead of a read per
    // value, on a little-endian machine.
    let packed_xyz = [(0, Ty::F32, 0), (4, Ty::F32, 1), (8, Ty::F32, 2)];
    if !BE && cfg!(target_endian = "little") && stride == 12 && fields == packed_xyz {
        return out
            .packed_positions(records)
            .map_err(|(k, m)| fail_byte(pos + k * stride, m));
    }
    let all_f32 = fields.iter().all(|f| f.1 == Ty::F32);
    for (k, rec) in records.chunks_exact(stride).enumerate() {
        let mut v = Vertex::default();
        if all_f32 {
            for &(o, _, c) in &fields {
                v[c] = f32::from_le_bytes(bytes::<4, BE>(&rec[o..]));
            }
        } else {
            for &(o, ty, c) in &fields {
                v[c] = get::<BE>(&rec[o..], ty) as f32;
            }
        }
        out.vertex(v).map_err(|m| fail_byte(pos + k * stride, m))?;
    }
    Ok(())
}

/// The records of one element that has lists, read from offset `pos` of
/// the file on, of which `data` holds the bytes from offset `base` on: to
/// the end, or (streamed) at least through the records read.
struct Cursor<'a> {
    data: &'a [u8],
    base: usize,
    pos: usize,
    el: &'a Element,
}

impl<'a> Cursor<'a> {
    /// The next `len` bytes, in record `r`; `None` is a length past any file.
    fn take(&mut self, len: Option<usize>, r: usize) -> Result<&'a [u8], Fail> {
        let (data, at) = (self.data, self.pos - self.base);
        let b = len
            .and_then(|len| data.get(at..at.checked_add(len)?))
            .ok_or_else(|| truncated(self.base + data.len(), self.el, r, self.pos))?;
        self.pos += b.len();
        Ok(b)
    }
}

/// Reads `records` of `el`, which has lists, from offset `pos` of the file,
/// whose bytes from offset `base` on are `data` (as for [`Cursor`]);
/// returns the offset after them.
pub(super) fn list_records<const BE: bool>(
    data: &[u8],
    base: usize,
    pos: usize,
    el: &Element,
    roles: &[Role],
    records: std::ops::Range<usize>,
    out: &mut Builder,
) -> Result<usize, Fail> {
    let is_vertex = roles.contains(&Role::Value(0));
    let mut cur = Cursor {
        data,
        base,
        pos,
        el,
    };
    for r in records {
        let record = cur.pos;
        let mut v = Vertex::default();
        for (p, &role) in el.props.iter().zip(roles) {
            match p.kind {
                Kind::Scalar(ty) => {
                    let b = cur.take(Some(ty.size()), r)?;
                    if let Role::Value(c) = role {
                        v[c] = get::<BE>(b, ty) as f32;
                    }
                }
                Kind::List(ct, it) => {
                    let items = list_items::<BE>(&mut cur, p, ct, it, r)?;
                    if role == Role::Indices {
                        let at = cur.pos - items.len();
                        face_indices::<BE>(items, at, it, r, out)?;
                        out.end_face(r).map_err(|m| fail_byte(record, m))?;
                    }
                }
            }
        }
        if is_vertex {
            out.vertex(v).map_err(|m| fail_byte(record, m))?;
        }
    }
    Ok(cur.pos)
}

/// The items of list `p` (count type `ct`, item type `it`) in record `r`.
fn list_items<'a, const BE: bool>(
    cur: &mut Cursor<'a>,
    p: &Property,
    ct: Ty,
    it: Ty,
    r: usize,
) -> Result<&'a [u8], Fail> {
    let at = cur.pos;
    let n = get_int::<BE>(cur.take(Some(ct.size()), r)?, ct);
    if n < 0 {
        return Err(fail_byte(
            at,
            format!(
                "{} {r}: property `{}` has negative length {n}",
                short(&cur.el.name),
                short(&p.name)
            ),
        ));
    }
    cur.take((n as usize).checked_mul(it.size()), r)
}

/// Adds the vertex indices `items` of type `it` of face `r`, which start at
/// offset `at`, to the face `out` is building.
fn face_indices<const BE: bool>(
    items: &[u8],
    at: usize,
    it: Ty,
    r: usize,
    out: &mut Builder,
) -> Result<(), Fail> {
    let size = it.size();
    let bad = |k: usize| move |m| fail_byte(at + k * size, m);
    if it == Ty::I32 || it == Ty::U32 {
        for (k, c) in items.chunks_exact(4).enumerate() {
            let b = bytes::<4, BE>(c);
            let i = if it == Ty::I32 {
                i32::from_le_bytes(b) as i64
            } else {
                u32::from_le_bytes(b) as i64
            };
            out.index(i, r).map_err(bad(k))?;
        }
    } else {
        for (k, c) in items.chunks_exact(size).enumerate() {
            out.index(get_int::<BE>(c, it), r).map_err(bad(k))?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use crate::math::PackedVec3;
    use crate::scene::mesh_io::load_mesh;
    use crate::scene::mesh_io::test_support::{binary_example, check_example, err, write};

    #[test]
    fn binary_ply_both_endians() {
        for be in [false, true] {
            let path = write("b.ply", &binary_example(be, 0));
            check_example(&load_mesh(&path).unwrap());
        }
    }

    #[test]
    fn fast_path_layout_and_index_types() {
        // float xyz + uchar/uint lists (the common layout), and ushort/short
        // indices through the general path, big endian.
        for (ct, it, be) in [
            ("uchar", "uint", false),
            ("uchar", "int", true),
            ("ushort", "short", true),
            ("uint", "uchar", false),
        ] {
            let fmt = if be { "big" } else { "little" };
            let mut data = format!(
                "ply\nformat binary_{fmt}_endian 1.0\nelement vertex 4\nproperty float x\n\
                 property float y\nproperty float z\nelement face 1\n\
                 property list {ct} {it} vertex_index\nend_header\n"
            )
            .into_bytes();
            let mut put = |b: &[u8]| {
                let mut b = b.to_vec();
                if be {
                    b.reverse();
                }
                data.extend_from_slice(&b);
            };
            for p in [[0f32, 0., 0.], [1., 0., 0.], [1., 1., 0.], [0., 1., 0.]] {
                for c in p {
                    put(&c.to_le_bytes());
                }
            }
            let sized = |ty: &str, v: u32| -> Vec<u8> {
                match ty {
                    "uchar" => vec![v as u8],
                    "ushort" | "short" => (v as u16).to_le_bytes().to_vec(),
                    _ => v.to_le_bytes().to_vec(),
                }
            };
            put(&sized(ct, 4));
            for i in [3, 2, 1, 0] {
                put(&sized(it, i));
            }
            let m = load_mesh(&write("f.ply", &data)).unwrap();
            assert_eq!(m.indices, vec![[3, 2, 1], [3, 1, 0]], "{ct} {it} {fmt}");
            assert_eq!(m.positions[2], PackedVec3::new(1.0, 1.0, 0.0));
            assert!(m.uvs.is_none());
        }
    }

    /// The packed little-endian x y z layout, read by one copy, reports a
    /// non-finite vertex as the per-value path does for big endian.
    #[test]
    fn packed_positions_name_the_vertex() {
        for be in [false, true] {
            let fmt = if be { "big" } else { "little" };
            let mut data = format!(
                "ply\nformat binary_{fmt}_endian 1.0\nelement vertex 3\nproperty float x\n\
                 property float y\nproperty float z\nelement face 1\n\
                 property list uchar int vertex_indices\nend_header\n"
            )
            .into_bytes();
            let body = data.len();
            let mut put = |b: &[u8]| {
                let mut b = b.to_vec();
                if be {
                    b.reverse();
                }
                data.extend_from_slice(&b);
            };
            for p in [[0f32, 0., 0.], [1., 0., 0.], [f32::NAN, 1., 0.]] {
                for c in p {
                    put(&c.to_le_bytes());
                }
            }
            put(&[3]);
            for i in [0i32, 1, 2] {
                put(&i.to_le_bytes());
            }
            let e = err("p.ply", &data);
            assert_eq!(
                e,
                format!(
                    ": byte {}: vertex 2: coordinates must be finite, got (NaN, 1, 0)",
                    body + 24
                ),
                "{fmt}"
            );
        }
    }

    /// A body large enough to be mapped and copied in many parallel chunks
    /// reads back exactly, and of two bad vertices in different chunks the
    /// error names the first, wherever the chunks finish.
    #[test]
    fn large_packed_positions_name_the_first_bad_vertex() {
        use crate::meter::test_support::{steps, Recorder};
        let n = 700_000usize;
        let mut data = format!(
            "ply\nformat binary_little_endian 1.0\nelement vertex {n}\nproperty float x\n\
             property float y\nproperty float z\nelement face 1\n\
             property list uchar int vertex_indices\nend_header\n"
        )
        .into_bytes();
        let body = data.len();
        let vertex = |k: usize| [k as f32, (k % 7) as f32, -(k as f32)];
        for k in 0..n {
            for c in vertex(k) {
                data.extend_from_slice(&c.to_le_bytes());
            }
        }
        data.push(3);
        for i in [0i32, 1, n as i32 - 1] {
            data.extend_from_slice(&i.to_le_bytes());
        }
        assert!(
            data.len() > 8 << 20,
            "the file must be large enough to be mapped"
        );
        let path = write("big.ply", &data);
        let (m, events) = Recorder::record(|| load_mesh(&path).unwrap());
        // The bulk paths count every byte of the body as they read it.
        let file = path.display().to_string();
        let steps = steps(&events);
        assert_eq!(steps.len(), 1, "{events:?}");
        let (what, total, done, reports) = &steps[0];
        assert_eq!((what, *total), (&file, data.len() as u64));
        assert_eq!(*done, (data.len() - body) as u64);
        assert!(*reports > 2, "{reports}");
        assert_eq!(m.positions.len(), n);
        assert!((0..n).all(|k| m.positions[k].to_array() == vertex(k)));
        assert_eq!(m.indices, vec![[0, 1, n as u32 - 1]]);

        for (k, c) in [(650_001usize, f32::NAN), (400_003, f32::INFINITY)] {
            data[body + 12 * k + 4..body + 12 * k + 8].copy_from_slice(&c.to_le_bytes());
        }
        let e = err("big-bad.ply", &data);
        assert_eq!(
            e,
            format!(
                ": byte {}: vertex 400003: coordinates must be finite, got (400003, inf, -400003)",
                body + 12 * 400_003
            )
        );
    }

    #[test]
    fn binary_errors() {
        for be in [false, true] {
            for cut in [1, 5, 20, 60, 150, 200] {
                let e = err("t.ply", &binary_example(be, cut));
                assert!(
                    e.starts_with(": byte ") && e.contains(": file ends early"),
                    "{e}"
                );
            }
        }
        let e = err("t.ply", &binary_example(false, 60));
        assert!(e.contains("vertex 4 of 5"), "{e}");
        // Index 4 -> 9 in the last face.
        let mut data = binary_example(false, 0);
        let at = data.len() - 9 - 4 - 4;
        data[at..at + 4].copy_from_slice(&9i32.to_le_bytes());
        let e = err("t.ply", &data);
        assert_eq!(
            e,
            format!(": byte {at}: face 1: vertex index 9 is out of range (5 vertices)")
        );
        // A NaN x in vertex 1.
        let mut data = binary_example(false, 0);
        let body = data.windows(10).position(|w| w == b"end_header").unwrap() + 12;
        let record = body + 4 + 8 + 4 + 1 + 8 + 8;
        data[record..record + 4].copy_from_slice(&f32::NAN.to_le_bytes());
        let e = err("t.ply", &data);
        assert!(
            e.starts_with(&format!(
                ": byte {record}: vertex 1: coordinates must be finite"
            )),
            "{e}"
        );
    }
}
