//! PLY files through a hand-written parser: the header, the plan of what to
//! read, then the body in ascii or binary.

mod ascii;
mod binary;
mod builder;
mod header;
mod numbers;
mod plan;
mod stream;
mod stream_ascii;
#[cfg(test)]
mod stream_tests;
mod triangles;
mod window;

pub(super) use header::{parse_header, Format, Header, Kind, Ty};
pub(super) use numbers::parse_float;
pub(super) use stream::{parse_ply_stream, Stop};

use super::checks::{drop_degenerate, dropped_note, summarize, zero_normals_note};
use super::fail::{fail_byte, no_triangles, short, Fail};
use super::Noted;
use crate::echo::echo;
use crate::geometry::Mesh;
use builder::Builder;
use header::Element;
use plan::{plan, Plan, Role};

pub(super) fn parse_ply(data: &[u8]) -> Result<Noted, Fail> {
    let header = parse_header(data)?;
    let plan = plan(&header.elements, header.body_line - 1)?;
    let body = &data[header.body..];
    let Plan {
        ref roles,
        vertex,
        face,
        ..
    } = plan;
    let (nv, nf) = (header.elements[vertex].count, header.elements[face].count);
    let mut out = Builder::new(nv, nf, &plan, body.len());
    match header.format {
        Format::Ascii => {
            ascii::ascii_body(body, header.body_line, &header.elements, roles, &mut out)?
        }
        Format::BinaryLe => {
            binary::binary_body::<false>(data, header.body, &header.elements, roles, &mut out)?
        }
        Format::BinaryBe => {
            binary::binary_body::<true>(data, header.body, &header.elements, roles, &mut out)?
        }
    }
    finish(&header, &plan, out)
}

/// The mesh and notes of a body read into `out`, or the failure of a body
/// with no triangle left.
fn finish(header: &Header, plan: &Plan, mut out: Builder) -> Result<Noted, Fail> {
    let Plan {
        ref roles,
        vertex,
        face,
        ..
    } = *plan;
    let face_line = header.elements[face].line;
    let triangles = out.indices.len();
    let dropped = drop_degenerate(&out.positions, &mut out.indices);
    if out.indices.is_empty() {
        return Err(no_triangles(face_line, 1, triangles));
    }
    let unused = unused(&header.elements, roles, vertex, face);
    let mut notes = Vec::new();
    if !unused.is_empty() {
        notes.push(format!("not used: {}", summarize(&unused)));
    }
    if dropped > 0 {
        notes.push(dropped_note(dropped, triangles));
    }
    notes.extend(zero_normals_note(out.normals.as_deref()));
    let mesh = Mesh {
        positions: out.positions,
        indices: out.indices,
        uvs: out.uvs,
        normals: out.normals,
    };
    Ok((mesh, notes))
}

/// What of the file luz leaves unread: the elements other than `vertex` and
/// `face`, and their properties of no role.
fn unused(elements: &[Element], roles: &[Vec<Role>], vertex: usize, face: usize) -> Vec<String> {
    let mut unused = Vec::new();
    for (i, (el, roles)) in elements.iter().zip(roles).enumerate() {
        if i != vertex && i != face {
            unused.push(format!("element {} ({})", echo(&el.name), el.count));
            continue;
        }
        for (p, role) in el.props.iter().zip(roles) {
            if *role == Role::Skip {
                unused.push(format!("{} property {}", short(&el.name), echo(&p.name)));
            }
        }
    }
    unused
}

/// The error of data after the last element the header declares, at byte
/// `at` (of the decompressed data when `inflated`).
pub(super) fn trailing(at: usize, elements: &[Element], inflated: bool) -> Fail {
    let declared: Vec<String> = elements
        .iter()
        .map(|e| format!("{} {}", e.count, echo(&e.name)))
        .collect();
    let why = if inflated {
        " (decompression stopped here: the counts allow no more)"
    } else {
        ""
    };
    fail_byte(
        at,
        format!(
            "the data goes on after the last element the header declares ({}){why}",
            declared.join(", ")
        ),
    )
}

#[cfg(test)]
mod tests {
    use super::builder::push_polygon;
    use super::parse_ply;
    use crate::math::PackedVec3;
    use crate::scene::mesh_io::load_mesh;
    use crate::scene::mesh_io::test_support::{assets, corruptions, examples};

    /// Every truncation and many byte corruptions give a result or an
    /// error, never a panic.
    #[test]
    fn damaged_files_never_panic() {
        for data in &examples() {
            for n in 0..data.len() {
                let _ = parse_ply(&data[..n]);
            }
            for d in corruptions(data, 5000) {
                let _ = parse_ply(&d);
            }
        }
    }

    /// The hand-written parser against `ply-rs-bw` on the full bunny: same
    /// numbers, and the timings that justify not using the crate.
    #[test]
    fn bunny_matches_ply_rs_bw() {
        use ply_rs_bw::{parser::Parser, ply::DefaultElement, ply::Property};
        let path = assets().join("stanford/bunny/bun_zipper.ply");
        if !path.exists() {
            eprintln!("skipping: {} not present", path.display());
            return;
        }
        let t = std::time::Instant::now();
        let mesh = load_mesh(&path).unwrap();
        let ours = t.elapsed();
        assert_eq!(mesh.positions.len(), 35_947);
        assert_eq!(mesh.indices.len(), 69_451);

        let t = std::time::Instant::now();
        let mut f = std::io::BufReader::new(std::fs::File::open(&path).unwrap());
        let ply = Parser::<DefaultElement>::new().read_ply(&mut f).unwrap();
        let theirs = t.elapsed();
        eprintln!(
            "bunny: luz {:.1} ms, ply-rs-bw {:.1} ms",
            ours.as_secs_f64() * 1e3,
            theirs.as_secs_f64() * 1e3
        );
        let num = |p: &Property| match p {
            Property::Float(x) => *x,
            other => panic!("unexpected {other:?}"),
        };
        for (v, p) in ply.payload["vertex"].iter().zip(&mesh.positions) {
            assert_eq!(
                PackedVec3::new(num(&v["x"]), num(&v["y"]), num(&v["z"])),
                *p
            );
        }
        let mut tris = Vec::new();
        for f in &ply.payload["face"] {
            let Property::ListInt(l) = &f["vertex_indices"] else {
                panic!("unexpected {:?}", f["vertex_indices"]);
            };
            let l: Vec<u32> = l.iter().map(|&i| i as u32).collect();
            push_polygon(&l, 0, &mut tris).unwrap();
        }
        assert_eq!(tris, mesh.indices);
    }
}
