//! The descriptions serde reads a TOML scene into, each table keeping its
//! byte span for located errors.

use crate::math::Rgb;
use serde::Deserialize;
use std::collections::BTreeMap;
use std::marker::PhantomData;
use toml::Spanned;

/// A TOML table, read only as a table. serde's derived structs also accept
/// a sequence, their fields by position, and drop what is left over:
/// `environment = [0.25, 99, "junk"]` was read as `radiance = 0.25`. Every
/// table of the format is read through this wrapper, which asks the
/// deserializer for a map and refuses anything else.
pub(super) struct Table<T>(T);

impl<T> std::ops::Deref for Table<T> {
    type Target = T;
    fn deref(&self) -> &T {
        &self.0
    }
}

impl<'de, T: Deserialize<'de>> Deserialize<'de> for Table<T> {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct MapOnly<T>(PhantomData<T>);
        impl<'de, T: Deserialize<'de>> serde::de::Visitor<'de> for MapOnly<T> {
            type Value = T;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a table (`[name]` or `{ key = value, ... }`)")
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(self, map: A) -> Result<T, A::Error> {
                T::deserialize(serde::de::value::MapAccessDeserializer::new(map))
            }
        }
        d.deserialize_map(MapOnly(PhantomData)).map(Table)
    }
}

/// A table with the byte span it was written at.
pub(super) type Sp<T> = Spanned<Table<T>>;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct SceneDesc {
    pub(super) camera: Sp<CameraDesc>,
    pub(super) render: Option<Sp<RenderDesc>>,
    #[serde(default)]
    pub(super) materials: BTreeMap<String, Sp<MaterialDesc>>,
    #[serde(default)]
    pub(super) textures: BTreeMap<String, Sp<TextureDesc>>,
    #[serde(default)]
    pub(super) shapes: Vec<Sp<ShapeDesc>>,
    #[serde(default)]
    pub(super) lights: Vec<Sp<LightDesc>>,
    pub(super) environment: Option<Sp<EnvironmentDesc>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct CameraDesc {
    pub(super) eye: [f32; 3],
    pub(super) target: [f32; 3],
    pub(super) up: Option<[f32; 3]>,
    pub(super) fov: Option<f32>,
    pub(super) resolution: Option<[u32; 2]>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RenderDesc {
    pub(super) spp: Option<u32>,
    pub(super) max_depth: Option<u32>,
    pub(super) seed: Option<u64>,
    pub(super) russian_roulette: Option<bool>,
    pub(super) sampler: Option<String>,
}

/// A colour: `[r, g, b]`, or one number for grey.
#[derive(Deserialize, Clone, Copy)]
#[serde(untagged)]
pub(super) enum Color {
    Grey(f32),
    Rgb([f32; 3]),
}

impl Color {
    pub(super) fn rgb(self) -> Rgb {
        match self {
            Color::Grey(g) => Rgb::splat(g),
            Color::Rgb(c) => Rgb::from(c),
        }
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct MaterialDesc {
    #[serde(rename = "type")]
    pub(super) kind: Option<String>,
    pub(super) kd: Option<Color>,
    pub(super) ks: Option<Color>,
    pub(super) kt: Option<Color>,
    pub(super) ior: Option<f32>,
    pub(super) emission: Option<Color>,
    pub(super) texture: Option<String>,
    /// Conductors: the complex index of refraction η + ik per channel.
    pub(super) eta: Option<Color>,
    pub(super) k: Option<Color>,
    /// Rough models: the microfacet roughness α and its distribution.
    pub(super) roughness: Option<f32>,
    pub(super) distribution: Option<String>,
    pub(super) opacity: Option<OpacityDesc>,
}

#[derive(Deserialize)]
#[serde(untagged)]
pub(super) enum OpacityDesc {
    Constant(f32),
    Texture(String),
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct TextureDesc {
    pub(super) file: Option<String>,
    pub(super) checker: Option<[Color; 2]>,
    pub(super) squares: Option<f32>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct ShapeDesc {
    #[serde(rename = "type")]
    pub(super) kind: String,
    pub(super) material: Option<String>,
    pub(super) nee: Option<bool>,
    // sphere
    pub(super) center: Option<[f32; 3]>,
    pub(super) radius: Option<f32>,
    // plane
    pub(super) point: Option<[f32; 3]>,
    pub(super) normal: Option<[f32; 3]>,
    // quad
    pub(super) corners: Option<Vec<[f32; 3]>>,
    // cuboid
    pub(super) min: Option<[f32; 3]>,
    pub(super) max: Option<[f32; 3]>,
    // triangle
    pub(super) vertices: Option<Vec<[f32; 3]>>,
    pub(super) uvs: Option<Vec<[f32; 2]>>,
    // mesh
    pub(super) file: Option<String>,
    pub(super) scale: Option<Scale>,
    pub(super) rotate: Option<[f32; 3]>,
    pub(super) translate: Option<[f32; 3]>,
    pub(super) normals: Option<MeshNormals>,
    // texture mapping
    pub(super) texture_scale: Option<[f32; 2]>,
    pub(super) texture_offset: Option<[f32; 2]>,
}

/// A mesh's shading normals.
#[derive(Deserialize, Clone, Copy, Debug, Default, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub(super) enum MeshNormals {
    /// The file's vertex normals where it has them, else flat.
    #[default]
    File,
    /// The face normals, whatever the file holds.
    Flat,
    /// The file's vertex normals, else normals computed from the faces as
    /// Mitsuba computes them ([`Mesh::compute_vertex_normals`]).
    Smooth,
}

#[derive(Deserialize, Clone, Copy)]
#[serde(untagged)]
pub(super) enum Scale {
    Uniform(f32),
    PerAxis([f32; 3]),
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct LightDesc {
    #[serde(rename = "type")]
    pub(super) kind: String,
    pub(super) position: [f32; 3],
    pub(super) intensity: Color,
    /// A spot light's aim, and its cone's angles in degrees.
    pub(super) target: Option<[f32; 3]>,
    pub(super) cutoff_angle: Option<f32>,
    pub(super) beam_width: Option<f32>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct EnvironmentDesc {
    pub(super) radiance: Option<Color>,
    /// A latitude-longitude map (EXR, HDR, PFM... any image luz reads).
    pub(super) map: Option<String>,
    pub(super) scale: Option<f32>,
    /// Degrees about x, then y, then z, as a mesh's `rotate`.
    pub(super) rotate: Option<[f32; 3]>,
}
