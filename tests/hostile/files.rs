//! Mesh and texture files: malformed PLY (ASCII and binary), OBJ and PPM
//! files each get one located error, and `luz tonemap` of a broken PPM
//! writes nothing.

use super::*;

#[test]
fn malformed_ply_files() {
    let dir = temp_dir("ply");
    let verts = triangle_vertices();
    let mut face = vec![3u8];
    for i in [0i32, 1, 7] {
        face.extend(i.to_le_bytes());
    }
    let out_of_range = [verts.clone(), face].concat();
    let cases = [
        with_file("ply-empty", "m.ply", b"".to_vec()).needle("end_header"),
        with_file(
            "ply-not-ply",
            "m.ply",
            b"solid cube\nfacet normal 0 0 1\n".to_vec(),
        )
        .needle("not a PLY file"),
        with_file(
            "ply-bad-keyword",
            "m.ply",
            PLY_HEADER.replace("element face 1", "elephant face 1"),
        )
        .needle("elephant"),
        with_file(
            "ply-bad-count",
            "m.ply",
            PLY_HEADER.replace("vertex 3", "vertex three"),
        )
        .needle("element `vertex`"),
        with_file(
            "ply-non-utf8-header",
            "m.ply",
            b"ply\nformat ascii 1.0\nelement vert\xffex 3\n".to_vec(),
        )
        .needle("not text"),
        with_file(
            "ply-ascii-truncated",
            "m.ply",
            format!("{PLY_HEADER}0 0 0\n1 0 0\n0 1"),
        )
        .needle("property `z`"),
        with_file(
            "ply-ascii-garbage",
            "m.ply",
            format!("{PLY_HEADER}0 0 0\n1 0 0\n0 1 zero\n3 0 1 2\n"),
        )
        .needle("property `z`"),
        with_file(
            "ply-ascii-nan",
            "m.ply",
            format!("{PLY_HEADER}0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n"),
        )
        .needle("vertex 1: coordinates must be finite"),
        with_file(
            "ply-ascii-index",
            "m.ply",
            format!("{PLY_HEADER}0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n"),
        )
        .needle("vertex index 3 is out of range"),
        with_file(
            "ply-ascii-negative-index",
            "m.ply",
            format!("{PLY_HEADER}0 0 0\n1 0 0\n0 1 0\n3 0 -1 2\n"),
        )
        .needle("vertex index -1 is out of range"),
        with_file(
            "ply-ascii-huge-counts",
            "m.ply",
            PLY_HEADER
                .replace("vertex 3", "vertex 4000000000")
                .replace("face 1", "face 4000000000")
                + "0 0 0\n",
        )
        .needle("file ends early"),
        with_file(
            "ply-binary-truncated",
            "m.ply",
            binary_ply("3", "1", "uchar", &verts[..20]),
        )
        .needle("vertex 1 of 3"),
        with_file(
            "ply-binary-index",
            "m.ply",
            binary_ply("3", "1", "uchar", &out_of_range),
        )
        .needle("vertex index 7 is out of range"),
        with_file(
            "ply-binary-huge-vertices",
            "m.ply",
            binary_ply("4000000000", "1", "uchar", b"0123456789"),
        )
        .needle("file ends early"),
        with_file(
            "ply-binary-huge-list",
            "m.ply",
            binary_ply(
                "3",
                "1",
                "uint",
                &[verts.clone(), 4_000_000_000u32.to_le_bytes().to_vec()].concat(),
            ),
        )
        .needle("face 0 of 1 is cut off"),
        with_file(
            "ply-binary-huge-faces",
            "m.ply",
            binary_ply("3", "4000000000", "uchar", &[verts, vec![3, 0]].concat()),
        )
        .needle("file ends early"),
    ];
    run_all(&dir, &cases);
}

#[test]
fn malformed_obj_files() {
    let dir = temp_dir("obj");
    let cases = [
        with_file("obj-empty", "m.obj", b"".to_vec()).needle("no faces"),
        with_file(
            "obj-garbage-number",
            "m.obj",
            b"v 0 0 0\nv 1 x 0\nv 0 1 0\nf 1 2 3\n".to_vec(),
        )
        .needle("vertex coordinate 1"),
        with_file(
            "obj-inf",
            "m.obj",
            b"v 0 0 0\nv 1 0 inf\nv 0 1 0\nf 1 2 3\n".to_vec(),
        )
        .needle("must be finite"),
        with_file(
            "obj-index",
            "m.obj",
            b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n".to_vec(),
        )
        .needle("vertex index `9` is out of range"),
        with_file(
            "obj-zero-index",
            "m.obj",
            b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n".to_vec(),
        )
        .needle("vertex index `0` is out of range"),
        with_file(
            "obj-truncated-face",
            "m.obj",
            b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2".to_vec(),
        )
        .needle("a face needs at least 3 vertices"),
        with_file(
            "obj-non-utf8",
            "m.obj",
            b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\xff\n".to_vec(),
        )
        .needle("not UTF-8"),
    ];
    run_all(&dir, &cases);
}

#[test]
fn malformed_ppm_textures() {
    let dir = temp_dir("ppm");
    let cases = [
        with_file(
            "ppm-bad-magic",
            "texture.ppm",
            b"P9\n1 1\n255\n0 0 0\n".to_vec(),
        )
        .needle("magic number"),
        with_file(
            "ppm-maxval-0",
            "texture.ppm",
            b"P3\n1 1\n0\n0 0 0\n".to_vec(),
        )
        .needle("maxval"),
        with_file(
            "ppm-width-text",
            "texture.ppm",
            b"P3\nwide 1\n255\n".to_vec(),
        )
        .needle("width"),
        with_file(
            "ppm-p6-absurd-width",
            "texture.ppm",
            b"P6\n4000000000 1\n255\n\x01\x02\x03".to_vec(),
        )
        .needle("truncated"),
        with_file(
            "ppm-p6-absurd-size",
            "texture.ppm",
            b"P6\n4000000000 4000000000\n255\n\x01\x02\x03".to_vec(),
        )
        .needle("too large"),
        with_file(
            "ppm-p3-absurd-width",
            "texture.ppm",
            b"P3\n100000 100000\n255\n1 2 3\n".to_vec(),
        )
        .needle("unexpected end of file"),
        with_file(
            "ppm-p6-truncated",
            "texture.ppm",
            b"P6\n2 2\n255\n\x01\x02\x03\x04\x05".to_vec(),
        )
        .needle("pixel data"),
        with_file(
            "ppm-p6-over-maxval",
            "texture.ppm",
            b"P6\n1 1\n15\n\x01\x10\x03".to_vec(),
        )
        .needle("16 exceeds maxval 15"),
        with_file(
            "ppm-p3-negative",
            "texture.ppm",
            b"P3\n1 1\n255\n0 -1 0\n".to_vec(),
        )
        .needle("green"),
        with_file(
            "ppm-hdr-nan-max",
            "texture.ppm",
            b"P3\n#MAX=nan\n1 1\n255\n0 0 0\n".to_vec(),
        )
        .needle("MAX"),
    ];
    run_all(&dir, &cases);
}

/// `luz tonemap` reading a broken PPM: the same located error, nothing
/// written.
#[test]
fn tonemap_of_a_truncated_ppm_writes_nothing() {
    let dir = temp_dir("tonemap");
    let input = dir.join("in.ppm");
    std::fs::write(&input, b"P3\n2 1\n255\n1 2 3\n4").unwrap();
    let output = dir.join("out.png");
    let out = luz_limited(&["tonemap", input.to_str().unwrap(), output.to_str().unwrap()]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("in.ppm:5:2: pixel (1, 0) green"),
        "{stderr}"
    );
    assert!(!output.exists());
}
