//! The content hash that tells whether two parts of a render come from the
//! same scene.
//!
//! It feeds xxh3 the bytes of the loaded data: vertex, index and uv arrays,
//! texels, and the `Debug` text of the small parameters (camera, materials,
//! lights, shape parameters). Arrays go in as little-endian bytes, so the
//! hash is the same on every platform; formatting a 17.8M-triangle mesh as
//! decimal text instead took 13% of its load (issue 18).

use crate::geometry::Geometry;
use crate::math::Rgb;
use crate::scene::{Environment, Material, Scene, Texture};
use std::fmt::Write as _;
use xxhash_rust::xxh3::Xxh3;

/// A hash of everything in `scene` that changes the value of a sample:
/// camera (resolution included), shapes, meshes, textures, materials,
/// lights, environment, maximum depth, Russian roulette and the sampler
/// (whose samples of one index differ), but not the
/// seed (recorded on its own) nor the sample count (parts of one render
/// differ in it). It hashes the loaded scene, so meshes and textures count
/// by content and the scene file's comments and formatting do not count at
/// all. Light samplers and shading flags are derived from what it hashes.
pub fn scene_hash(scene: &Scene) -> u64 {
    let mut h = Hasher(Xxh3::new());
    let r = &scene.render;
    // A material's name is how the scene file refers to it, not a value.
    let materials: Vec<Material> = scene
        .materials
        .iter()
        .map(|m| Material {
            name: String::new(),
            ..m.clone()
        })
        .collect();
    h.text(format_args!(
        "{:?} {:?} {:?} max_depth {} rr {} sampler {}",
        scene.camera,
        materials,
        scene.point_lights,
        r.max_depth,
        r.russian_roulette,
        r.sampler.name()
    ));
    match &scene.environment {
        None => h.text(format_args!("no environment")),
        Some(Environment::Constant(c)) => h.text(format_args!("environment {c:?}")),
        Some(Environment::Map(m)) => {
            h.text(format_args!(
                "environment map {}x{} scale {:?} to_world {:?}",
                m.width, m.height, m.scale, m.to_world
            ));
            h.colours(&m.texels);
        }
    }
    for texture in &scene.textures {
        match texture {
            Texture::Image {
                width,
                height,
                texels,
            } => {
                h.text(format_args!("image {width}x{height}"));
                h.colours(texels);
            }
            checker => h.text(format_args!("{checker:?}")),
        }
    }
    for shape in &scene.shapes {
        h.text(format_args!(
            "shape {} {} {:?}",
            shape.material, shape.nee, shape.uv_transform
        ));
        match &shape.geometry {
            Geometry::Mesh(m) => {
                h.text(format_args!(
                    "mesh {} {} {} {}",
                    m.positions.len(),
                    m.indices.len(),
                    m.uvs.is_some(),
                    m.normals.is_some()
                ));
                h.floats(bytemuck::cast_slice(&m.positions));
                h.words(bytemuck::cast_slice(&m.indices));
                if let Some(uvs) = &m.uvs {
                    h.floats(bytemuck::cast_slice(uvs));
                }
                if let Some(normals) = &m.normals {
                    h.floats(bytemuck::cast_slice(normals));
                }
            }
            other => h.text(format_args!("{other:?}")),
        }
    }
    h.0.digest()
}

struct Hasher(Xxh3);

impl Hasher {
    fn text(&mut self, args: std::fmt::Arguments) {
        self.write_fmt(args).expect("hashing cannot fail");
        // A separator, so that consecutive fields cannot run together.
        self.0.update(&[0]);
    }

    fn floats(&mut self, values: &[f32]) {
        self.words(bytemuck::cast_slice(values));
    }

    /// The colours' r, g, b in turn, as `floats` hashes them, a block at a
    /// time: `Rgb` has a fourth, padding lane that is not hashed.
    fn colours(&mut self, values: &[Rgb]) {
        let mut rgb = Vec::with_capacity(3 * 1024.min(values.len()));
        for block in values.chunks(1024) {
            rgb.clear();
            rgb.extend(block.iter().flat_map(|c| c.to_array()));
            self.floats(&rgb);
        }
    }

    fn words(&mut self, values: &[u32]) {
        if cfg!(target_endian = "little") {
            self.0.update(bytemuck::cast_slice(values));
        } else {
            for v in values {
                self.0.update(&v.to_le_bytes());
            }
        }
    }
}

impl std::fmt::Write for Hasher {
    fn write_str(&mut self, s: &str) -> std::fmt::Result {
        self.0.update(s.as_bytes());
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Mesh, Sphere};
    use crate::math::Mat3;
    use crate::math::{PackedVec3, Vec2, Vec3};
    use crate::sampling::SamplerKind;
    use crate::scene::{Camera, EnvMap, Shape};
    use std::sync::Arc;

    fn scene() -> Scene {
        let mesh = Mesh {
            positions: vec![PackedVec3::ZERO, PackedVec3::X, PackedVec3::Y],
            indices: vec![[0, 1, 2]],
            uvs: Some(vec![Vec2::ZERO, Vec2::X, Vec2::Y]),
            normals: None,
        };
        let shapes = vec![
            Shape::new(Geometry::from(mesh), 0),
            Shape::new(Geometry::Sphere(sphere(0.5)), 0),
        ];
        let texture = Texture::Image {
            width: 1,
            height: 1,
            texels: vec![Vec3::splat(0.5)],
        };
        let camera = Camera {
            eye: Vec3::new(0.0, 0.0, 5.0),
            target: Vec3::ZERO,
            up: Vec3::Y,
            fov_y: 40.0,
            fov_axis: crate::scene::FovAxis::Y,
            width: 8,
            height: 8,
        };
        let material = Material {
            name: "white".into(),
            kd: Vec3::splat(0.8),
            ..Material::default()
        };
        Scene::new(
            camera,
            vec![material],
            vec![texture],
            shapes,
            Vec::new(),
            None,
            Default::default(),
        )
    }

    fn sphere(radius: f32) -> Sphere {
        Sphere {
            center: Vec3::Z,
            radius,
        }
    }

    fn mesh(s: &mut Scene) -> &mut Mesh {
        match &mut s.shapes[0].geometry {
            Geometry::Mesh(m) => Arc::make_mut(m),
            _ => unreachable!(),
        }
    }

    #[test]
    fn notices_every_change_of_a_samples_value() {
        let base = scene_hash(&scene());
        assert_eq!(base, scene_hash(&scene()), "the hash must be stable");
        type Change = (&'static str, fn(&mut Scene));
        let changes: [Change; 12] = [
            ("a vertex", |s| mesh(s).positions[1].x = 1.5),
            ("an index", |s| mesh(s).indices[0] = [0, 2, 1]),
            ("a uv", |s| mesh(s).uvs.as_mut().unwrap()[2].y = 0.5),
            ("dropped uvs", |s| mesh(s).uvs = None),
            ("vertex normals", |s| {
                mesh(s).normals = Some(vec![PackedVec3::Z; 3])
            }),
            ("a texel", |s| match &mut s.textures[0] {
                Texture::Image { texels, .. } => texels[0].z = 0.25,
                _ => unreachable!(),
            }),
            ("a sphere", |s| {
                s.shapes[1].geometry = Geometry::Sphere(sphere(0.6))
            }),
            ("a material", |s| s.materials[0].kd = Vec3::splat(0.7)),
            ("the resolution", |s| s.camera.width = 16),
            ("the maximum depth", |s| s.render.max_depth = 3),
            ("the sampler", |s| {
                s.render.sampler = match s.render.sampler {
                    SamplerKind::Sobol => SamplerKind::Independent,
                    SamplerKind::Independent => SamplerKind::Sobol,
                }
            }),
            ("the environment", |s| {
                s.environment = Some(Environment::Constant(Vec3::ONE))
            }),
        ];
        for (what, change) in changes {
            let mut s = scene();
            change(&mut s);
            assert_ne!(scene_hash(&s), base, "changing {what} must change the hash");
        }
    }

    #[test]
    fn ignores_seed_sample_count_and_names() {
        let base = scene_hash(&scene());
        let mut s = scene();
        s.render.seed = 7;
        s.render.spp = 1024;
        s.materials[0].name = "renamed".into();
        assert_eq!(scene_hash(&s), base);
    }

    fn with_map(texel: f32, scale: f32, to_world: Mat3) -> Scene {
        let mut s = scene();
        let texels = vec![Vec3::splat(0.25), Vec3::splat(texel), Vec3::ONE, Vec3::ZERO];
        s.environment = Some(Environment::Map(EnvMap::new(2, 2, texels, scale, to_world)));
        s
    }

    #[test]
    fn notices_every_change_of_an_environment_map() {
        let base = scene_hash(&with_map(0.5, 1.0, Mat3::IDENTITY));
        assert_eq!(base, scene_hash(&with_map(0.5, 1.0, Mat3::IDENTITY)));
        for (what, changed) in [
            ("a texel", with_map(0.6, 1.0, Mat3::IDENTITY)),
            ("the scale", with_map(0.5, 2.0, Mat3::IDENTITY)),
            (
                "the rotation",
                with_map(0.5, 1.0, Mat3::from_rotation_y(1.0)),
            ),
            ("a constant instead", scene()),
        ] {
            assert_ne!(base, scene_hash(&changed), "{what}");
        }
    }
}
