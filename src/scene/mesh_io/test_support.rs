//! Files and examples shared by the loaders' unit tests.

use super::{load_mesh, MeshError};
use crate::geometry::Mesh;
use crate::math::{PackedVec3, Vec2};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

pub(super) fn assets() -> PathBuf {
    std::env::var_os("LUZ_ASSETS")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/assets"))
}

pub(super) fn temp_path(name: &str) -> PathBuf {
    static N: AtomicUsize = AtomicUsize::new(0);
    let dir = std::env::temp_dir().join(format!(
        "luz-mesh-io-{}-{}",
        std::process::id(),
        N.fetch_add(1, Ordering::Relaxed)
    ));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

pub(super) fn write(name: &str, data: &[u8]) -> PathBuf {
    let path = temp_path(name);
    std::fs::write(&path, data).unwrap();
    path
}

pub(super) fn load_str(name: &str, text: &str) -> Result<Mesh, MeshError> {
    load_mesh(&write(name, text.as_bytes()))
}

/// The error message, checked to start with the file's path.
pub(super) fn err(name: &str, data: &[u8]) -> String {
    let path = write(name, data);
    let e = load_mesh(&path).expect_err("should fail").to_string();
    let prefix = path.display().to_string();
    assert!(e.starts_with(&prefix), "{e}");
    e[prefix.len()..].to_string()
}

pub(super) const ASCII: &str = "ply\r
format ascii 1.0\r
comment made by hand\r
element vertex 5\r
property float x\r
property double y\r
property int z\r
property list uchar float extra\r
property float s\r
property float t\r
element face 2\r
property uchar flags\r
property list uchar int vertex_indices\r
property list int float weights\r
element edge 1\r
property list uchar int ends\r
end_header\r
0 0 0 2 7 8 0 0\r
1 0 0 0 1 0\r
1 1.5 0 1 9 1 1\r
0 1 -2 0 0 1\r
0.5e1 2.5e-1 7 3 1 2 3 0.5 0.5\r
1 4 0 1 2 3 1 0.5\r
0 3 0 2 4 0\r
2 1 2\r
";

pub(super) fn check_example(m: &Mesh) {
    assert_eq!(m.positions.len(), 5);
    assert_eq!(m.positions[2], PackedVec3::new(1.0, 1.5, 0.0));
    assert_eq!(m.positions[3], PackedVec3::new(0.0, 1.0, -2.0));
    assert_eq!(m.positions[4], PackedVec3::new(5.0, 0.25, 7.0));
    assert_eq!(m.indices, vec![[0, 1, 2], [0, 2, 3], [0, 2, 4]]);
    let uvs = m.uvs.as_ref().expect("uvs");
    assert_eq!(uvs[1], Vec2::new(1.0, 0.0));
    assert_eq!(uvs[4], Vec2::new(0.5, 0.5));
}

/// Appends a value given as little-endian bytes in the file's byte order.
pub(super) fn push_ordered(out: &mut Vec<u8>, little_endian: &[u8], be: bool) {
    let at = out.len();
    out.extend_from_slice(little_endian);
    if be {
        out[at..].reverse();
    }
}

/// The small example in its three formats: ascii, then binary little and
/// big endian.
pub(super) fn examples() -> [Vec<u8>; 3] {
    [
        ASCII.as_bytes().to_vec(),
        binary_example(false, 0),
        binary_example(true, 0),
    ]
}

/// `count` copies of `data`, each with one byte overwritten at a place of
/// a fixed pseudo-random sequence (xorshift).
pub(super) fn corruptions(data: &[u8], count: usize) -> impl Iterator<Item = Vec<u8>> + '_ {
    let mut x = 0x9e37_79b9_7f4a_7c15u64;
    (0..count).map(move |_| {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        let mut d = data.to_vec();
        let i = (x % d.len() as u64) as usize;
        d[i] = (x >> 32) as u8;
        d
    })
}

/// The ASCII example as binary, with the same types.
pub(super) fn binary_example(be: bool, cut: usize) -> Vec<u8> {
    let format = if be {
        "binary_big_endian"
    } else {
        "binary_little_endian"
    };
    let header = ASCII.replace("format ascii", &format!("format {format}"));
    let header = &header[..header.find("end_header").unwrap() + 12];
    let mut out = header.as_bytes().to_vec();
    let mut put = |b: &[u8]| push_ordered(&mut out, b, be);
    let verts: [([f32; 3], &[f32], [f32; 2]); 5] = [
        ([0.0, 0.0, 0.0], &[7.0, 8.0], [0.0, 0.0]),
        ([1.0, 0.0, 0.0], &[], [1.0, 0.0]),
        ([1.0, 1.5, 0.0], &[9.0], [1.0, 1.0]),
        ([0.0, 1.0, -2.0], &[], [0.0, 1.0]),
        ([5.0, 0.25, 7.0], &[1.0, 2.0, 3.0], [0.5, 0.5]),
    ];
    for (p, extra, uv) in verts {
        put(&p[0].to_le_bytes());
        put(&(p[1] as f64).to_le_bytes());
        put(&(p[2] as i32).to_le_bytes());
        put(&[extra.len() as u8]);
        for e in extra {
            put(&e.to_le_bytes());
        }
        put(&uv[0].to_le_bytes());
        put(&uv[1].to_le_bytes());
    }
    let faces: [(&[i32], &[f32]); 2] = [(&[0, 1, 2, 3], &[0.5]), (&[0, 2, 4], &[])];
    for (idx, w) in faces {
        put(&[1]);
        put(&[idx.len() as u8]);
        for i in idx {
            put(&i.to_le_bytes());
        }
        put(&(w.len() as i32).to_le_bytes());
        for x in w {
            put(&x.to_le_bytes());
        }
    }
    put(&[2]);
    put(&1i32.to_le_bytes());
    put(&2i32.to_le_bytes());
    out.truncate(out.len() - cut);
    out
}

/// `data` gzipped.
pub(super) fn gz(data: &[u8]) -> Vec<u8> {
    use std::io::Write;
    let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    e.write_all(data).unwrap();
    e.finish().unwrap()
}

pub(super) fn ply(body: &str) -> String {
    format!(
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
         property float z\nelement face 1\nproperty list uchar int vertex_indices\n\
         end_header\n{body}"
    )
}
