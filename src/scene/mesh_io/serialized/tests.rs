//! The reader against files written here as Mitsuba writes them.

use super::*;
use flate2::write::ZlibEncoder;
use std::io::Write;

/// One mesh as Mitsuba writes it: header, then the zlib stream.
fn mesh_bytes(
    version: u16,
    flags: u32,
    vertices: &[[f64; 3]],
    extra: &[f64],
    tris: &[u32],
) -> Vec<u8> {
    let mut z = ZlibEncoder::new(Vec::new(), flate2::Compression::fast());
    z.write_all(&flags.to_le_bytes()).unwrap();
    if version == 4 {
        z.write_all(b"a name\0").unwrap();
    }
    z.write_all(&(vertices.len() as u64).to_le_bytes()).unwrap();
    z.write_all(&(tris.len() as u64 / 3).to_le_bytes()).unwrap();
    let double = flags & DOUBLE_PRECISION != 0;
    for x in vertices.iter().flatten().chain(extra) {
        match double {
            true => z.write_all(&x.to_le_bytes()).unwrap(),
            false => z.write_all(&(*x as f32).to_le_bytes()).unwrap(),
        }
    }
    for i in tris {
        z.write_all(&i.to_le_bytes()).unwrap();
    }
    let mut out = MAGIC.to_le_bytes().to_vec();
    out.extend(version.to_le_bytes());
    out.extend(z.finish().unwrap());
    out
}

/// Meshes concatenated, with the dictionary of their offsets.
fn file(version: u16, meshes: &[Vec<u8>]) -> Vec<u8> {
    let mut out = Vec::new();
    let mut offsets = Vec::new();
    for m in meshes {
        offsets.push(out.len() as u64);
        out.extend(m);
    }
    for o in offsets {
        match version {
            4 => out.extend(o.to_le_bytes()),
            _ => out.extend((o as u32).to_le_bytes()),
        }
    }
    out.extend((meshes.len() as u32).to_le_bytes());
    out
}

const QUAD: [[f64; 3]; 4] = [[0., 0., 0.], [1., 0., 0.], [1., 1., 0.], [0., 1., 0.]];
const TRIANGLE: [[f64; 3]; 3] = [[0., 0., 1.], [2., 0., 1.], [0., 2., 1.]];

fn read(data: &[u8], index: u32) -> Result<MeshFile, MeshError> {
    parse_serialized(data, Path::new("m.serialized"), index)
}

fn message(data: &[u8], index: u32) -> String {
    read(data, index).expect_err("an error").to_string()
}

#[test]
fn meshes_of_both_versions_read_by_index() {
    // Normals (not of unit length in the file) then uvs, in f32; a
    // second mesh in f64 without either.
    let normals_uvs: Vec<f64> = [[0., 0., 2.]; 4]
        .iter()
        .flatten()
        .copied()
        .chain([0., 0., 1., 0., 1., 1., 0., 1.])
        .collect();
    for version in [3, 4] {
        let data = file(
            version,
            &[
                mesh_bytes(
                    version,
                    HAS_NORMALS | HAS_TEXCOORDS | 0x1000,
                    &QUAD,
                    &normals_uvs,
                    &[0, 1, 2, 0, 2, 3],
                ),
                mesh_bytes(version, DOUBLE_PRECISION, &TRIANGLE, &[], &[0, 1, 2]),
            ],
        );
        let quad = read(&data, 0).unwrap().mesh;
        assert_eq!(quad.indices, vec![[0, 1, 2], [0, 2, 3]]);
        assert_eq!(quad.positions[2], PackedVec3::new(1.0, 1.0, 0.0));
        assert_eq!(quad.normals.as_deref(), Some(&[PackedVec3::Z; 4][..]));
        assert_eq!(quad.uvs.as_ref().unwrap()[2], Vec2::new(1.0, 1.0));
        let tri = read(&data, 1).unwrap().mesh;
        assert_eq!(tri.positions[1], PackedVec3::new(2.0, 0.0, 1.0));
        assert!(tri.normals.is_none() && tri.uvs.is_none());
        let past = message(&data, 2);
        assert!(
            past.contains("m.serialized")
                && past.contains("`shape_index` 2 is past the file's 2 meshes"),
            "{past}"
        );
    }
}

#[test]
fn face_normals_drop_the_normals_and_colours_are_noted() {
    let extra: Vec<f64> = [[0., 0., 1.]; 3]
        .iter()
        .flatten()
        .chain([[1., 0., 0.]; 3].iter().flatten())
        .copied()
        .collect();
    let data = file(
        3,
        &[mesh_bytes(
            3,
            HAS_NORMALS | HAS_COLORS | FACE_NORMALS,
            &TRIANGLE,
            &extra,
            &[0, 1, 2],
        )],
    );
    let read = read(&data, 0).unwrap();
    assert!(read.mesh.normals.is_none());
    assert_eq!(read.notes, vec!["not used: vertex colours".to_string()]);
}

#[test]
fn broken_files_are_errors_that_say_what_is_wrong() {
    let good = mesh_bytes(4, 0, &TRIANGLE, &[], &[0, 1, 2]);
    let mut bad_magic = good.clone();
    bad_magic[0] = 0;
    let mut version_5 = good.clone();
    version_5[2] = 5;
    // Cut inside the compressed triangles, not only the checksum.
    let cut = good[..good.len() / 2].to_vec();
    let out_of_range = mesh_bytes(4, 0, &TRIANGLE, &[], &[0, 1, 7]);
    let not_finite = mesh_bytes(
        4,
        0,
        &[[0., 0., 0.], [f64::NAN, 0., 0.], [0., 1., 0.]],
        &[],
        &[0, 1, 2],
    );
    let normal_not_finite = mesh_bytes(
        4,
        HAS_NORMALS,
        &TRIANGLE,
        &[0., 0., 1., 0., 0., 1., 0., f64::INFINITY, 1.],
        &[0, 1, 2],
    );
    let mut huge = good.clone();
    huge.truncate(4);
    let mut z = ZlibEncoder::new(Vec::new(), flate2::Compression::fast());
    z.write_all(&0u32.to_le_bytes()).unwrap();
    z.write_all(b"\0").unwrap();
    z.write_all(&(1u64 << 40).to_le_bytes()).unwrap();
    z.write_all(&1u64.to_le_bytes()).unwrap();
    huge.extend(z.finish().unwrap());
    for (data, expected) in [
        (bad_magic, "not a Mitsuba .serialized mesh"),
        (version_5, "version 5: luz reads versions 3 and 4"),
        (cut, "the compressed data ends early"),
        (out_of_range, "mesh 0: triangle 0: vertex 7 of 3"),
        (not_finite, "vertex 1: coordinates must be finite"),
        (
            normal_not_finite,
            "vertex 2: normal (normals) must be finite",
        ),
        (huge, "cannot fit in the compressed data"),
    ] {
        let m = message(&file(4, &[data]), 0);
        assert!(m.contains(expected), "{m}");
    }
    assert!(message(&[0x1c], 0).contains("no mesh header"));
}

#[test]
fn a_mesh_of_no_area_is_told_apart() {
    let flat = mesh_bytes(
        3,
        0,
        &[[0., 0., 0.], [1., 0., 0.], [2., 0., 0.]],
        &[],
        &[0, 1, 2],
    );
    match read(&file(3, &[flat]), 0) {
        Err(MeshError::NoArea { place, .. }) => assert_eq!(place, "mesh 0"),
        other => panic!("{other:?}"),
    }
}

/// A Mitsuba `serialized` shape takes the mesh its `shape_index` names,
/// and a `<ref name="bsdf">` its material, as Mitsuba's own material
/// preview writes them.
#[test]
fn a_mitsuba_shape_reads_the_mesh_of_its_index() {
    let dir = std::env::temp_dir().join(format!("luz-serialized-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let meshes = [
        mesh_bytes(3, 0, &QUAD, &[], &[0, 1, 2, 0, 2, 3]),
        mesh_bytes(3, 0, &TRIANGLE, &[], &[0, 1, 2]),
    ];
    std::fs::write(dir.join("m.serialized"), file(3, &meshes)).unwrap();
    let scene = r#"<scene version="3.0.0">
        <sensor type="perspective"><float name="fov" value="40"/></sensor>
        <bsdf type="diffuse" id="grey"><rgb name="reflectance" value="0.25"/></bsdf>
        <emitter type="point"><point name="position" value="0,0,3"/></emitter>
        <shape type="serialized"><string name="filename" value="m.serialized"/>
            <integer name="shape_index" value="1"/><ref name="bsdf" id="grey"/></shape>
        </scene>"#;
    std::fs::write(dir.join("s.xml"), scene).unwrap();
    let s = crate::scene::load_with(&dir.join("s.xml"), &Default::default()).unwrap();
    let crate::geometry::Geometry::Mesh(mesh) = &s.shapes[0].geometry else {
        panic!("not a mesh")
    };
    assert_eq!(
        mesh.positions,
        TRIANGLE.map(|p| PackedVec3::new(p[0] as f32, p[1] as f32, p[2] as f32))
    );
    let m = &s.materials[s.shapes[0].material as usize];
    assert_eq!(m.kd, crate::math::Rgb::splat(0.25));
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    let _ = std::fs::remove_dir_all(&dir);
}
