//! Shading normals from vertex normals, as loaded: what the PLY and OBJ
//! readers make of them, how a transform moves them, the located errors of
//! bad ones, the normals luz computes, and what the Mitsuba importer does.
//! Their effect on images is in `shading_normals_render.rs`.

mod common;

use common::meshes::{close, icosphere, load_scene, mesh_of, mesh_scene, obj, ply};
use luz::geometry::Mesh;
use luz::math::{PackedVec3, Vec3};

#[test]
fn ply_normals_are_read_and_moved_by_the_inverse_transpose() {
    let dir = common::temp_dir("ply-normals");
    let text = ply(
        &[
            ([0.0, 0.0, 0.0], [1.0, 1.0, 0.0]),
            ([1.0, 0.0, 0.0], [0.0, 0.0, 2.0]),
            ([0.0, 1.0, 0.0], [0.0, 0.0, 1.0]),
        ],
        &[[0, 1, 2]],
    );
    std::fs::write(dir.join("tri.ply"), &text).unwrap();
    let plain = load_scene(&dir, "a.toml", &mesh_scene("tri.ply", "", 4, 1)).unwrap();
    let n = mesh_of(&plain, 0).normals.clone().expect("normals read");
    assert!(close(n[0], Vec3::new(1.0, 1.0, 0.0).normalize()), "{n:?}");
    assert!(close(n[1], Vec3::Z) && close(n[2], Vec3::Z), "{n:?}");

    // Scaling x by 2 halves the x of a normal (inverse transpose), then
    // the normal is made unit again; positions are scaled as given.
    let scaled = load_scene(
        &dir,
        "b.toml",
        &mesh_scene("tri.ply", "scale = [2, 1, 1]", 4, 1),
    )
    .unwrap();
    let m = mesh_of(&scaled, 0);
    let n = m.normals.as_ref().unwrap();
    assert!(close(n[0], Vec3::new(0.5, 1.0, 0.0).normalize()), "{n:?}");
    assert!(close(n[1], Vec3::Z), "{n:?}");
    assert_eq!(m.positions[1], PackedVec3::new(2.0, 0.0, 0.0));

    // `normals = "flat"` drops them; a file without normals has none.
    let flat = load_scene(
        &dir,
        "c.toml",
        &mesh_scene("tri.ply", "normals = \"flat\"", 4, 1),
    )
    .unwrap();
    assert!(mesh_of(&flat, 0).normals.is_none());
}

#[test]
fn obj_normals_split_vertices_and_follow_negative_indices() {
    let dir = common::temp_dir("obj-normals");
    // Two triangles share the edge 1-3 but give its vertices different
    // normals: four positions become six vertices. The second face uses
    // negative indices (relative to the last `v` and `vn`).
    let obj = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n\
               vn 0 0 1\nvn 0 1 1\n\
               vt 0 0\n\
               f 1//1 2//1 3//1\n\
               f -4/-1/-1 -2/1/2 -1//2\n";
    std::fs::write(dir.join("two.obj"), obj).unwrap();
    let scene = load_scene(&dir, "a.toml", &mesh_scene("two.obj", "", 4, 1)).unwrap();
    let m = mesh_of(&scene, 0);
    let n = m.normals.as_ref().expect("normals read");
    assert_eq!(m.positions.len(), 6, "{:?}", m.positions);
    let tilted = Vec3::new(0.0, 1.0, 1.0).normalize();
    for (t, want) in m.indices.iter().zip([Vec3::Z, tilted]) {
        for &i in t {
            assert!(close(n[i as usize], want), "{:?} {n:?}", m.indices);
        }
    }
    // The corner at position 1 (0, 0, 0) appears with either normal.
    let at_origin: Vec<PackedVec3> = (0..6)
        .filter(|&i| m.positions[i] == PackedVec3::ZERO)
        .map(|i| n[i])
        .collect();
    assert_eq!(at_origin.len(), 2, "{at_origin:?}");

    // A face without normals among faces with: shaded flat, said once.
    std::fs::write(
        dir.join("mixed.obj"),
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1\nf 1 3 2\n",
    )
    .unwrap();
    let scene = load_scene(&dir, "b.toml", &mesh_scene("mixed.obj", "", 4, 1)).unwrap();
    assert!(mesh_of(&scene, 0).normals.is_none());
}

#[test]
fn bad_normals_are_located_errors() {
    let dir = common::temp_dir("bad-normals");
    let ply_text = ply(
        &[
            ([0.0, 0.0, 0.0], [0.0, 0.0, 1.0]),
            ([1.0, 0.0, 0.0], [0.0, f32::NAN, 1.0]),
            ([0.0, 1.0, 0.0], [0.0, 0.0, 1.0]),
        ],
        &[[0, 1, 2]],
    );
    std::fs::write(dir.join("bad.ply"), ply_text).unwrap();
    let err = load_scene(&dir, "a.toml", &mesh_scene("bad.ply", "", 4, 1)).unwrap_err();
    // The vertex is the second record, on line 14 after 12 header lines.
    assert!(
        err.contains("bad.ply:14:") && err.contains("vertex 1") && err.contains("nx ny nz"),
        "{err}"
    );

    std::fs::write(
        dir.join("bad.obj"),
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 inf 1\nf 1//1 2//1 3//1\n",
    )
    .unwrap();
    let err = load_scene(&dir, "b.toml", &mesh_scene("bad.obj", "", 4, 1)).unwrap_err();
    assert!(
        err.contains("bad.obj:4:") && err.contains("vertex normal"),
        "{err}"
    );

    let err = load_scene(
        &dir,
        "c.toml",
        &mesh_scene("bad.obj", "normals = \"bumpy\"", 4, 1),
    )
    .unwrap_err();
    assert!(err.contains("normals") && err.contains("bumpy"), "{err}");
}

#[test]
fn a_bad_normal_in_a_binary_ply_names_its_byte_and_fields() {
    let dir = common::temp_dir("binary");
    let header = "ply\nformat binary_little_endian 1.0\nelement vertex 3\n\
                  property float x\nproperty float y\nproperty float z\n\
                  property float nx\nproperty float ny\nproperty float nz\n\
                  element face 1\nproperty list uchar int vertex_indices\nend_header\n";
    let mut data = header.as_bytes().to_vec();
    let vertices = [
        [0.0, 0.0, 0.0, 0.0, 0.0, 1.0],
        [1.0, 0.0, 0.0, 0.0, 0.0, 1.0],
        [0.0, 1.0, 0.0, f32::INFINITY, 0.0, 1.0],
    ];
    for v in vertices {
        for x in v {
            data.extend_from_slice(&f32::to_le_bytes(x));
        }
    }
    data.push(3);
    for i in [0i32, 1, 2] {
        data.extend_from_slice(&i.to_le_bytes());
    }
    std::fs::write(dir.join("bad.ply"), data).unwrap();
    let err = load_scene(&dir, "a.toml", &mesh_scene("bad.ply", "", 4, 1)).unwrap_err();
    // The third record starts 2 × 24 bytes into the body.
    let at = format!("bad.ply: byte {}: vertex 2", header.len() + 48);
    assert!(err.contains(&at) && err.contains("nx ny nz"), "{err}");
}

#[test]
fn computed_normals_of_an_icosphere_are_nearly_radial() {
    let (positions, indices) = icosphere(2);
    let mut mesh = Mesh {
        positions,
        indices,
        uvs: None,
        normals: None,
    };
    mesh.compute_vertex_normals();
    let normals = mesh.normals.as_ref().unwrap();
    let worst = mesh
        .positions
        .iter()
        .zip(normals)
        .map(|(p, n)| p.normalize().dot(*n).clamp(-1.0, 1.0).acos().to_degrees())
        .fold(0.0f32, f32::max);
    // The icosphere is symmetric about each vertex up to the slight
    // unevenness of subdivided triangles: a degree or two at most.
    assert!(worst < 2.0, "worst {worst}°");
}

#[test]
fn the_shading_normal_stays_on_the_side_of_the_winding() {
    use luz::geometry::PrimHit;
    // Facing +z by its winding; the file's normals point to -z, tilted.
    let mesh = Mesh {
        positions: vec![PackedVec3::ZERO, PackedVec3::X, PackedVec3::Y],
        indices: vec![[0, 1, 2]],
        uvs: None,
        normals: Some(vec![PackedVec3::new(0.6, 0.0, -0.8); 3]),
    };
    let sp = mesh.surface(
        0,
        &PrimHit {
            t: 1.0,
            u: 0.2,
            v: 0.3,
        },
    );
    assert_eq!(sp.n, Vec3::Z);
    assert!(close(sp.ns, Vec3::new(-0.6, 0.0, 0.8)), "{:?}", sp.ns);
}

#[test]
fn mitsuba_meshes_use_file_normals_else_computed_ones_unless_face_normals() {
    let dir = common::temp_dir("mitsuba");
    let (p, f) = icosphere(1);
    let obj = obj(&p, &f);
    std::fs::write(dir.join("ico.obj"), obj).unwrap();
    std::fs::write(
        dir.join("tri.obj"),
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 1 1\nf 1//1 2//1 3//1\n",
    )
    .unwrap();
    let shape = |file: &str, extra: &str| {
        format!(r#"<shape type="obj"><string name="filename" value="{file}"/>{extra}</shape>"#)
    };
    let xml = format!(
        r#"<scene version="3.0.0">
<sensor type="perspective"><float name="fov" value="40"/>
  <transform name="to_world"><lookat origin="0,0,5" target="0,0,0" up="0,1,0"/></transform>
  <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/>
  <rfilter type="box"/></film></sensor>
<emitter type="point"><point name="position" value="0,0,3"/></emitter>
{}
{}
{}
</scene>"#,
        shape("ico.obj", ""),
        shape("ico.obj", r#"<boolean name="face_normals" value="true"/>"#),
        shape("tri.obj", ""),
    );
    let scene = load_scene(&dir, "s.xml", &xml).unwrap();
    let computed = mesh_of(&scene, 0);
    let normals = computed.normals.as_ref().expect("computed normals");
    for (q, n) in computed.positions.iter().zip(normals) {
        assert!(q.normalize().dot(*n) > 0.999, "{q} {n}");
    }
    assert!(mesh_of(&scene, 1).normals.is_none(), "face_normals");
    let file = mesh_of(&scene, 2).normals.as_ref().expect("file normals");
    assert!(
        file.iter()
            .all(|n| close(*n, Vec3::new(0.0, 1.0, 1.0).normalize())),
        "{file:?}"
    );
}
