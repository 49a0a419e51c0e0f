//! Meshes the shading-normal tests write (PLY with normals, icospheres)
//! and the scenes they load them in.

use luz::geometry::{Geometry, Mesh};
use luz::math::{PackedVec3, Vec3};
use luz::scene::{load, Scene};
use std::path::Path;

pub fn mesh_of(scene: &Scene, shape: usize) -> &Mesh {
    match &scene.shapes[shape].geometry {
        Geometry::Mesh(m) => m,
        other => panic!("shape {shape} is a {}", other.name()),
    }
}

pub fn load_scene(dir: &Path, name: &str, text: &str) -> Result<Scene, String> {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    load(&path).map_err(|e| e.to_string())
}

/// A scene of one mesh shape (`file`, with extra `keys`) under a point
/// light, seen from above.
pub fn mesh_scene(file: &str, keys: &str, resolution: u32, spp: u32) -> String {
    format!(
        r#"
[camera]
eye = [0, 0, 6]
target = [0, 0, 0]
up = [0, 1, 0]
fov = 25
resolution = [{resolution}, {resolution}]

[render]
spp = {spp}
max_depth = 2
russian_roulette = false
sampler = "independent"
seed = 7

[materials.grey]
kd = 0.7

[[shapes]]
type = "mesh"
file = "{file}"
material = "grey"
{keys}

[[lights]]
type = "point"
position = [1, 2, 5]
intensity = [30, 30, 30]
"#
    )
}

pub fn ply(vertices: &[([f32; 3], [f32; 3])], faces: &[[u32; 3]]) -> String {
    let mut s = format!(
        "ply\nformat ascii 1.0\nelement vertex {}\nproperty float x\nproperty float y\n\
         property float z\nproperty float nx\nproperty float ny\nproperty float nz\n\
         element face {}\nproperty list uchar int vertex_indices\nend_header\n",
        vertices.len(),
        faces.len()
    );
    for (p, n) in vertices {
        s += &format!("{} {} {} {} {} {}\n", p[0], p[1], p[2], n[0], n[1], n[2]);
    }
    for f in faces {
        s += &format!("3 {} {} {}\n", f[0], f[1], f[2]);
    }
    s
}

/// An OBJ of the mesh's positions and faces, with no normals.
pub fn obj(positions: &[PackedVec3], faces: &[[u32; 3]]) -> String {
    let mut s: String = positions
        .iter()
        .map(|q| format!("v {} {} {}\n", q.x, q.y, q.z))
        .collect();
    for t in faces {
        s += &format!("f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    s
}

/// A quad of two triangles in the z = 0 plane, facing +z, every vertex
/// with the normal `n`.
pub fn quad_ply(n: [f32; 3]) -> String {
    let c = [
        [-1.0, -1.0, 0.0],
        [1.0, -1.0, 0.0],
        [1.0, 1.0, 0.0],
        [-1.0, 1.0, 0.0],
    ];
    let v: Vec<_> = c.iter().map(|&p| (p, n)).collect();
    ply(&v, &[[0, 1, 2], [0, 2, 3]])
}

pub fn close(a: impl Into<Vec3>, b: impl Into<Vec3>) -> bool {
    (a.into() - b.into()).length() < 1e-5
}

/// An icosphere of unit radius, `subdivisions` times subdivided, with its
/// exact (radial) normals.
pub fn icosphere(subdivisions: u32) -> (Vec<PackedVec3>, Vec<[u32; 3]>) {
    let t = (1.0 + 5f32.sqrt()) / 2.0;
    let mut p: Vec<PackedVec3> = [
        (-1.0, t, 0.0),
        (1.0, t, 0.0),
        (-1.0, -t, 0.0),
        (1.0, -t, 0.0),
        (0.0, -1.0, t),
        (0.0, 1.0, t),
        (0.0, -1.0, -t),
        (0.0, 1.0, -t),
        (t, 0.0, -1.0),
        (t, 0.0, 1.0),
        (-t, 0.0, -1.0),
        (-t, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| PackedVec3::new(x, y, z).normalize())
    .collect();
    let mut f: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..subdivisions {
        let mut mid = std::collections::HashMap::new();
        let mut next = Vec::new();
        for [a, b, c] in f {
            let mut m = |i: u32, j: u32| {
                *mid.entry((i.min(j), i.max(j))).or_insert_with(|| {
                    p.push((p[i as usize] + p[j as usize]).normalize());
                    p.len() as u32 - 1
                })
            };
            let (ab, bc, ca) = (m(a, b), m(b, c), m(c, a));
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        f = next;
    }
    (p, f)
}
