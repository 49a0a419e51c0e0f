//! The shapes of the `[[shapes]]` tables with their materials: the named
//! one, luz's default, or for an OBJ mesh without `material` the ones its
//! faces ask for in its `.mtl` (one shape per material); meshes with no
//! triangle of any area are left out, with one warning for them all.

use super::*;
use crate::scene::obj_materials::obj_parts;

/// The scene's materials and textures, which shapes add to.
pub(super) struct Palette<'a> {
    pub(super) materials: &'a mut Vec<Material>,
    pub(super) material_ids: &'a BTreeMap<String, u32>,
    pub(super) textures: &'a mut Vec<Texture>,
}

impl Ctx<'_> {
    pub(super) fn shapes(
        &self,
        descs: &[Sp<ShapeDesc>],
        palette: Palette,
        warnings: &mut Vec<String>,
    ) -> Result<Vec<Shape>, SceneError> {
        let Palette {
            materials,
            material_ids,
            textures,
        } = palette;
        let mut default_material = None;
        let mut default = |materials: &mut Vec<Material>| {
            *default_material.get_or_insert_with(|| {
                materials.push(Material {
                    name: "(default)".into(),
                    ..Material::default()
                });
                materials.len() as u32 - 1
            })
        };
        let mut shapes = Vec::new();
        let mut no_area = Vec::new();
        for s in descs {
            let span = s.span();
            let sd = s.get_ref();
            let geometry = match self.geometry(&span, sd, warnings)? {
                Built::NoArea(path) => {
                    no_area.push(echo(&path.display().to_string()));
                    continue;
                }
                Built::MeshFile { path, mesh, groups }
                    if sd.material.is_none() && !groups.is_empty() =>
                {
                    let parts = obj_parts(&path, mesh, &groups)
                        .map_err(|e| self.field_error(&span, "file", e.to_string()))?;
                    let palette = Palette {
                        materials: &mut *materials,
                        material_ids,
                        textures: &mut *textures,
                    };
                    shapes.extend(self.obj_shapes(&span, sd, parts, palette, warnings)?);
                    continue;
                }
                Built::MeshFile { mesh, .. } => Geometry::from(mesh),
                Built::Geometry(g) => g,
            };
            let material = match &sd.material {
                Some(name) => *material_ids.get(name).ok_or_else(|| {
                    let known: Vec<&str> = material_ids.keys().map(|k| k.as_str()).collect();
                    self.field_error(
                        &span,
                        "material",
                        format!(
                            "no material named {} (defined: {})",
                            echo(name),
                            known.join(", ")
                        ),
                    )
                })?,
                None => default(materials),
            };
            let nee = sd.nee.unwrap_or(false);
            shapes.push(self.shape(&span, sd, geometry, material, nee, materials)?);
        }
        if !no_area.is_empty() {
            warnings.push(crate::scene::no_area_warning(&no_area));
        }
        Ok(shapes)
    }

    /// The shapes of an OBJ mesh cut by its own materials. Its emissive
    /// parts are sampled by next-event estimation unless `nee = false`.
    fn obj_shapes(
        &self,
        span: &Range<usize>,
        sd: &ShapeDesc,
        parts: crate::scene::obj_materials::ObjParts,
        palette: Palette,
        warnings: &mut Vec<String>,
    ) -> Result<Vec<Shape>, SceneError> {
        let Palette {
            materials,
            textures,
            ..
        } = palette;
        self.files.borrow_mut().extend(parts.files);
        warnings.extend(parts.warnings);
        let (texture_base, material_base) = (textures.len() as u32, materials.len() as u32);
        textures.extend(parts.textures);
        materials.extend(parts.materials.into_iter().map(|mut m| {
            m.texture = m.texture.map(|t| t + texture_base);
            m
        }));
        let emissive = |m: u32| materials[(material_base + m) as usize].is_emissive();
        if sd.nee == Some(true) && !parts.parts.iter().any(|(_, m)| emissive(*m)) {
            return Err(self.field_error(
                span,
                "nee",
                "no material of the mesh's `.mtl` emits (`Ke`): only emissive shapes can be sampled as lights",
            ));
        }
        let mut shapes = Vec::with_capacity(parts.parts.len());
        for (mut mesh, m) in parts.parts {
            let nee = sd.nee.unwrap_or(true) && emissive(m);
            mesh.positions.reserve_exact(1);
            let geometry = Geometry::from(mesh);
            shapes.push(self.shape(span, sd, geometry, material_base + m, nee, materials)?);
        }
        Ok(shapes)
    }

    /// A shape of `geometry` and `material`, sampled by next-event
    /// estimation when `nee`, with the texture mapping of `sd`; checked.
    fn shape(
        &self,
        span: &Range<usize>,
        sd: &ShapeDesc,
        geometry: Geometry,
        material: u32,
        nee: bool,
        materials: &[Material],
    ) -> Result<Shape, SceneError> {
        let mut shape = Shape::new(geometry, material);
        shape.nee = nee;
        let m = &materials[material as usize];
        if shape.nee && !m.is_emissive() {
            return Err(self.field_error(
                span,
                "nee",
                "only emissive shapes can be sampled as lights",
            ));
        }
        if shape.nee && matches!(shape.geometry, Geometry::Plane(_)) {
            return Err(self.field_error(span, "nee", "an infinite plane has no area to sample"));
        }
        if shape.nee {
            let power = m.emission.max_element() * shape.geometry.area().unwrap_or(0.0);
            if !power.is_finite() {
                return Err(self.field_error(
                    span,
                    "nee",
                    format!(
                        "the emitted power (`emission` {} of material {} times the area) overflows f32",
                        vec3(m.emission),
                        echo(&m.name)
                    ),
                ));
            }
        }
        shape.uv_transform = self.uv_transform(span, sd, &shape.geometry)?;
        Ok(shape)
    }

    /// The shape's `texture_scale` and `texture_offset`, checked to keep
    /// its texture coordinates finite.
    fn uv_transform(
        &self,
        span: &Range<usize>,
        sd: &ShapeDesc,
        geometry: &Geometry,
    ) -> Result<UvTransform, SceneError> {
        for (field, v) in [
            ("texture_scale", sd.texture_scale),
            ("texture_offset", sd.texture_offset),
        ] {
            if let Some(v) = v {
                if !Vec2::from(v).is_finite() {
                    return Err(self.field_error(span, field, "must be finite"));
                }
            }
        }
        let t = UvTransform {
            scale: sd.texture_scale.map_or(Vec2::ONE, Vec2::from),
            offset: sd.texture_offset.map_or(Vec2::ZERO, Vec2::from),
        };
        // The texture coordinates the transform makes of the shape's
        // own (at most `uv_extent` in magnitude) must stay finite.
        let extent = uv_extent(geometry);
        if !(t.scale.abs() * extent).is_finite() {
            return Err(self.field_error(
                span,
                "texture_scale",
                format!(
                    "scales this shape's texture coordinates (up to {extent:e}) past f32's range"
                ),
            ));
        }
        if !(t.scale.abs() * extent + t.offset.abs()).is_finite() {
            let field = if sd.texture_offset.is_some() {
                "texture_offset"
            } else {
                "texture_scale"
            };
            return Err(self.field_error(
                span,
                field,
                "moves this shape's texture coordinates past f32's range",
            ));
        }
        Ok(t)
    }
}
