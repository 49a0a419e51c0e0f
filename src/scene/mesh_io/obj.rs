//! Wavefront OBJ through `tobj`, its objects merged into one mesh, with
//! the errors `tobj` reports without a line located by [`scan_obj`].

use super::checks::{check_finite, drop_degenerate_grouped};
use super::chunks::CHUNK_BYTES;
use super::fail::{fail, fail_at, no_triangles, Fail};
use super::obj_chunks::parse_obj_chunks;
use super::obj_merge::Uses;
use super::obj_scan::{scan_obj, Seen};
use super::MeshFile;
use crate::geometry::Mesh;
use crate::location::line_column;
use crate::math::{PackedVec3, Vec2};

/// Reads an OBJ file: in parallel chunks ([`parse_obj_chunks`]) when its
/// statements allow, else serially.
pub(super) fn parse_obj(data: &[u8]) -> Result<MeshFile, Fail> {
    match parse_obj_chunks(data, CHUNK_BYTES) {
        Some(noted) => Ok(noted),
        None => parse_obj_serial(data),
    }
}

/// Reads an OBJ file through [`scan_obj`] and `tobj`, serially.
fn parse_obj_serial(data: &[u8]) -> Result<MeshFile, Fail> {
    let text = std::str::from_utf8(data).map_err(|e| {
        let (line, column) = line_column(data, e.valid_up_to());
        fail_at(line, column, "the file is not UTF-8 text")
    })?;
    // tobj drops faces of two vertices and reports bad indices without a
    // line: one linear pass over the statements first, numbers unparsed.
    let mut seen = Seen::default();
    if let Some(f) = scan_obj(text, false, &mut seen) {
        return Err(f);
    }
    // Single index, fan-triangulated, points and lines dropped.
    let opts = tobj::GPU_LOAD_OPTIONS;
    // Materials are not used; don't go looking for the .mtl file.
    let (models, _) = tobj::load_obj_buf(&mut text.as_bytes(), &opts, |_| {
        Ok((Vec::new(), Default::default()))
    })
    .map_err(|e| located(text, || fail(format!("OBJ: {e}"))))?;
    let any_uv = models.iter().any(|m| !m.mesh.texcoords.is_empty());
    let with_uv = any_uv
        && models
            .iter()
            .all(|m| m.mesh.texcoords.len() / 2 == m.mesh.positions.len() / 3);
    let any_normal = models.iter().any(|m| !m.mesh.normals.is_empty());
    let with_normals = any_normal
        && models
            .iter()
            .all(|m| m.mesh.normals.len() == m.mesh.positions.len());
    let mut mesh = merge(text, &models, with_uv, with_normals)?;
    check_all_finite(text, &mesh)?;
    let triangles = mesh.indices.len();
    // The scan counts the faces `tobj` triangulates, one by one.
    debug_assert_eq!(triangles, seen.triangles);
    let mut groups = seen.groups.finish(triangles);
    let dropped = drop_degenerate_grouped(&mesh.positions, &mut mesh.indices, &mut groups);
    if mesh.indices.is_empty() {
        // tobj drops malformed faces silently: name the first one if any,
        // else point at the end of the file, where faces were still expected.
        let (line, column) = line_column(text.as_bytes(), text.len());
        let at_end = no_triangles(line, column, triangles);
        return Err(match triangles {
            0 => scan_obj(text, true, &mut Seen::default()).unwrap_or(at_end),
            _ => at_end,
        });
    }
    let uses = Uses {
        unused: &seen.unused,
        any_uv,
        with_uv,
        any_normal,
        with_normals,
    };
    let notes = uses.notes(&mesh, dropped, triangles);
    Ok(MeshFile {
        mesh,
        notes,
        groups,
    })
}

/// The failure at the first malformed statement of `text` that
/// [`scan_obj`] finds with its numbers parsed, or `otherwise`'s when none.
fn located(text: &str, otherwise: impl FnOnce() -> Fail) -> Fail {
    scan_obj(text, true, &mut Seen::default()).unwrap_or_else(otherwise)
}

/// One mesh of `tobj`'s models, each indexing its own vertices, with
/// texture coordinates when `with_uv` and unit normals when `with_normals`.
fn merge(
    text: &str,
    models: &[tobj::Model],
    with_uv: bool,
    with_normals: bool,
) -> Result<Mesh, Fail> {
    let mut mesh = Mesh {
        uvs: with_uv.then(Vec::new),
        normals: with_normals.then(Vec::new),
        ..Default::default()
    };
    for m in models {
        let m = &m.mesh;
        if m.normals.iter().any(|x| !x.is_finite()) {
            return Err(located(text, || fail("OBJ: a vertex normal is not finite")));
        }
        let base = mesh.positions.len();
        let n = m.positions.len() / 3;
        if base + n > u32::MAX as usize {
            return Err(fail("too many vertices for 32-bit indices"));
        }
        mesh.positions.extend(
            m.positions
                .chunks_exact(3)
                .map(|p| PackedVec3::new(p[0], p[1], p[2])),
        );
        if let Some(uvs) = &mut mesh.uvs {
            uvs.extend(m.texcoords.chunks_exact(2).map(|t| Vec2::new(t[0], t[1])));
        }
        if let Some(normals) = &mut mesh.normals {
            normals.extend(
                m.normals
                    .chunks_exact(3)
                    .map(|n| PackedVec3::new(n[0], n[1], n[2]).normalize_or_zero()),
            );
        }
        for t in m.indices.chunks_exact(3) {
            let tri = [t[0], t[1], t[2]];
            if tri.iter().any(|&i| i as usize >= n) {
                return Err(located(text, || {
                    fail("OBJ: face vertex index out of range")
                }));
            }
            mesh.indices.push(tri.map(|i| i + base as u32));
        }
    }
    Ok(mesh)
}

/// Fails at the first vertex with a coordinate that is not finite.
fn check_all_finite(text: &str, mesh: &Mesh) -> Result<(), Fail> {
    let bad = mesh
        .positions
        .iter()
        .position(|p| !p.is_finite())
        .or_else(|| {
            mesh.uvs
                .as_ref()
                .and_then(|uvs| uvs.iter().position(|t| !t.is_finite()))
        });
    if let Some(i) = bad {
        let uv = mesh.uvs.as_ref().map(|u| u[i]);
        let msg = check_finite(mesh.positions[i], uv, i).unwrap_err();
        return Err(located(text, || fail(msg)));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::{parse_obj_chunks, parse_obj_serial};
    use crate::math::{PackedVec3, Vec2};
    use crate::scene::mesh_io::test_support::{assets, load_str};

    /// The chunked reader, where it decides, gives the serial reader's mesh
    /// and notes, with chunks cut everywhere; returns whether it decided
    /// at every cut.
    fn same_as_serial(text: &[u8]) -> bool {
        let want = format!("{:?}", parse_obj_serial(text).map_err(|f| f.msg));
        let mut decided = true;
        for chunk in 1..text.len().min(400) + 2 {
            match parse_obj_chunks(text, chunk) {
                Some(got) => assert_eq!(
                    format!("{:?}", Ok::<_, String>(got)),
                    want,
                    "{:?}, chunks of {chunk}",
                    String::from_utf8_lossy(text)
                ),
                None => decided = false,
            }
        }
        decided
    }

    #[test]
    fn chunks_read_as_tobj() {
        let decided = [
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
            "v 0 0 0\r\nv 1 0 0\r\nv 0 1 0\r\nf 1 2 3\r\n",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3",
            "# é comment\n\n  v 0 0 0 \nv\t1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3 4\nf -4 -2 -1\n",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nv 2 1 0\nf 1 2 3 4 5\ns 1\nf 5 4 3\n",
            "mtllib a.mtl\no a\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n\
             vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nusemtl m\nf 1/1 2/2 3/3 4/4\n\
             o b\ng c\nv 0 0 1\nv 1 0 1\nv 1 1 1\nvt 0.5 0.5 0\nf -3/1 -2/2 -1/5\nf 1/1 2/2 3/3\n",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nvn 0 0 -1\nvt 0 0\n\
             f 1//1 2//1 3//2\nf 1/1/1 2//2 3/1/1\ng\nf 1 2 3\nf 1//1 2//1 3//1\n",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 2 0\nf 1 2 3\nf 1 2 4\nf 1 3 4\n",
            "g x\ng y\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\no\nf 3 2 1\no z\n",
            MATERIALS,
            "mtllib  a b.mtl \r\nv 0 0 0\r\nv 1 0 0\r\nv 0 1 0\r\nusemtl x\r\nf 1 2 3\r\n\
             usemtl y\r\nusemtl x\r\nf 1 2 3\r\nusemtl  z z \r\nf 1 1 2\r\nf 3 2 1\r\nusemtl y",
        ];
        for t in decided {
            assert!(same_as_serial(t.as_bytes()), "{t:?}");
        }
        let serial = [
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n",
            "v 0 0 0\nv 1 x 0\nv 0 1 0\nf 1 2 3\n",
            "v 0 0 0\nv 1 0 nan\nv 0 1 0\nf 1 2 3\n",
            "v 0 0 0 1\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nl 1 2 3\n",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1/1/1 2 3\n",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl\nf 1 2 3\n",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -4 1 2\n",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 1 x 0\nf 1 2 3\n",
            "v 0 0 0\nv\u{a0}1 0 0\nv 0 1 0\nf 1 2 3\n",
            "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n",
            "v 0 0 0\n",
        ];
        for t in serial {
            same_as_serial(t.as_bytes());
        }
        // Many keywords, and invalid UTF-8.
        let mut many = String::from("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
        for k in 0..40 {
            many.push_str(&format!("k{k} x\nk{} y\n", k / 2));
        }
        same_as_serial(many.as_bytes());
        same_as_serial(b"v 0 0 0\nv 1 0 0\nv 0 1 0\n# \xff\nf 1 2 3\n");
    }

    /// Every OBJ asset, in chunks of 4 KiB and of 64 KiB.
    #[test]
    fn assets_read_in_chunks_as_tobj() {
        for file in [
            "stanford/bunny/stanford-bunny.obj",
            "stanford/armadillo/armadillo.obj",
            "spot/spot_triangulated.obj",
            "spot/spot_quadrangulated.obj",
            "spot/spot_control_mesh.obj",
            "teapot/teapot.obj",
            "cornell-box/CornellBox-Original.obj",
        ] {
            let path = assets().join(file);
            let Ok(data) = std::fs::read(&path) else {
                eprintln!("skipping {}: not present", path.display());
                continue;
            };
            let want = format!("{:?}", parse_obj_serial(&data).map_err(|f| f.msg));
            for chunk in [4096, 65536] {
                let got = parse_obj_chunks(&data, chunk).expect(file);
                assert_eq!(format!("{:?}", Ok::<_, String>(got)), want, "{file}");
            }
        }
    }

    /// Groups, materials switched within and across them, a material used
    /// twice, a degenerate face, relative indices.
    const MATERIALS: &str = "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n\
        f 1 2 3\ng one\nusemtl red\nf -4 -3 -2 -1\nusemtl blue\nf 1 2 2\nf 1 3 4\n\
        g two\nv 0 0 1\nv 1 0 1\nv 0 1 1\nusemtl red\nf -3 -2 -1\n";

    #[test]
    fn usemtl_groups_with_relative_indices() {
        let path = std::path::Path::new("m.obj");
        let read = crate::scene::mesh_io::parse_mesh_noted(MATERIALS.as_bytes(), path).unwrap();
        let g = &read.groups;
        let names: Vec<(&str, usize)> = g.names.iter().map(|n| (&*n.name, n.line)).collect();
        assert_eq!(names, [("red", 8), ("blue", 10)]);
        assert_eq!((&*g.libraries[0].name, g.libraries[0].line), ("m.mtl", 1));
        assert!(
            read.notes.iter().any(|n| n.contains("dropped 1 of 6")),
            "{:?}",
            read.notes
        );
        let parts = g.split(read.mesh);
        let ids: Vec<Option<u32>> = parts.iter().map(|p| p.0).collect();
        assert_eq!(ids, [None, Some(0), Some(1)]);
        let corners = |m: &crate::geometry::Mesh| -> Vec<[crate::math::Vec3; 3]> {
            (0..m.indices.len() as u32).map(|t| m.vertices(t)).collect()
        };
        let v = |x: f32, y: f32, z: f32| crate::math::Vec3::new(x, y, z);
        assert_eq!(
            corners(&parts[0].1),
            [[v(0., 0., 0.), v(1., 0., 0.), v(1., 1., 0.)]]
        );
        // The quad of `-4 -3 -2 -1` and the triangle of `two`.
        assert_eq!(
            corners(&parts[1].1),
            [
                [v(0., 0., 0.), v(1., 0., 0.), v(1., 1., 0.)],
                [v(0., 0., 0.), v(1., 1., 0.), v(0., 1., 0.)],
                [v(0., 0., 1.), v(1., 0., 1.), v(0., 1., 1.)],
            ]
        );
        // `f 1 2 2` had no area: blue keeps one triangle.
        assert_eq!(
            corners(&parts[2].1),
            [[v(0., 0., 0.), v(1., 1., 0.), v(0., 1., 0.)]]
        );
        let e = crate::scene::mesh_io::test_support::err("u.obj", b"v 0 0 0\nusemtl \t\nf 1 1 1\n");
        assert_eq!(e, ":2:1: `usemtl` needs a material name");
    }

    #[test]
    fn obj_with_uvs_merged_across_objects() {
        let text = "mtllib missing.mtl\no a\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n\
                    vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/1 2/2 3/3 4/4\n\
                    o b\nv 0 0 1\nv 1 0 1\nv 1 1 1\nvt 0.5 0.5\nf -3/1 -2/2 -1/5\n";
        let m = load_str("q.obj", text).unwrap();
        assert_eq!(m.indices.len(), 3);
        assert_eq!(m.positions.len(), 7);
        let uvs = m.uvs.as_ref().expect("uvs");
        assert_eq!(uvs.len(), 7);
        for t in &m.indices {
            for &i in t {
                assert!((i as usize) < m.positions.len());
            }
        }
        // The second object's triangle refers to its own vertices.
        let [a, b, c] = m.indices[2];
        assert_eq!(m.positions[a as usize], PackedVec3::new(0.0, 0.0, 1.0));
        assert_eq!(m.positions[b as usize], PackedVec3::new(1.0, 0.0, 1.0));
        assert_eq!(m.positions[c as usize], PackedVec3::new(1.0, 1.0, 1.0));
        assert_eq!(uvs[c as usize], Vec2::new(0.5, 0.5));
        // Fan triangulation of the quad keeps its area.
        let area: f32 = (0..2).map(|i| m.triangle_area(i)).sum();
        assert!((area - 1.0).abs() < 1e-6);
        // Without vt on every vertex there are no uvs.
        let m = load_str("n.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
        assert!(m.uvs.is_none());
    }
}
