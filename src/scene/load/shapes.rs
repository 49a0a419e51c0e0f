//! The `[[shapes]]` tables: each shape's geometry, validated after its
//! transform.

use super::*;

impl Ctx<'_> {
    pub(super) fn geometry(
        &self,
        span: &Range<usize>,
        sd: &ShapeDesc,
        warnings: &mut Vec<String>,
    ) -> Result<Built, SceneError> {
        let used: &[&str] = match sd.kind.as_str() {
            "sphere" => &["center", "radius"],
            "plane" => &["point", "normal"],
            "quad" => &["corners"],
            "cuboid" => &["min", "max"],
            "triangle" => &["vertices", "uvs"],
            "mesh" => &["file", "scale", "rotate", "translate", "normals"],
            other => {
                return Err(self.field_error(
                    span,
                    "type",
                    format!(
                    "unknown shape type {} (known: sphere, plane, quad, cuboid, triangle, mesh)",
                    echo(other)
                ),
                ))
            }
        };
        let present = [
            ("center", sd.center.is_some()),
            ("radius", sd.radius.is_some()),
            ("point", sd.point.is_some()),
            ("normal", sd.normal.is_some()),
            ("corners", sd.corners.is_some()),
            ("min", sd.min.is_some()),
            ("max", sd.max.is_some()),
            ("vertices", sd.vertices.is_some()),
            ("uvs", sd.uvs.is_some()),
            ("file", sd.file.is_some()),
            ("scale", sd.scale.is_some()),
            ("rotate", sd.rotate.is_some()),
            ("translate", sd.translate.is_some()),
            ("normals", sd.normals.is_some()),
        ];
        for (field, is_set) in present {
            if is_set && !used.contains(&field) {
                return Err(self.field_error(
                    span,
                    field,
                    format!(
                        "a {} has no `{field}` (it takes: {})",
                        sd.kind,
                        used.join(", ")
                    ),
                ));
            }
        }
        let need =
            |field: &str| self.error_at(span.start, format!("a {} needs `{field}`", sd.kind));
        Ok(Built::Geometry(match sd.kind.as_str() {
            "sphere" => {
                let center =
                    self.point3(span, "center", sd.center.ok_or_else(|| need("center"))?)?;
                let radius = sd.radius.ok_or_else(|| need("radius"))?;
                if !(radius > 0.0 && radius.is_finite()) {
                    return Err(self.field_error(
                        span,
                        "radius",
                        format!("must be positive and finite, got {radius}"),
                    ));
                }
                let sphere = Sphere { center, radius };
                let b = sphere.bounds();
                for corner in [b.min, b.max] {
                    if !within_bounds(corner) {
                        return Err(self.field_error(
                            span,
                            "radius",
                            format!(
                                "the sphere's bounds reach past the coordinates luz can use: {}",
                                outside(corner)
                            ),
                        ));
                    }
                }
                Geometry::Sphere(sphere)
            }
            "plane" => {
                let point = self.point3(span, "point", sd.point.ok_or_else(|| need("point"))?)?;
                let normal =
                    self.finite3(span, "normal", sd.normal.ok_or_else(|| need("normal"))?)?;
                // Compared, not squared: a normal of 1e-40 is a direction.
                if normal == Vec3::ZERO {
                    return Err(self.field_error(span, "normal", "must not be zero"));
                }
                Geometry::Plane(Plane::new(point, normal))
            }
            "quad" => {
                let corners = sd.corners.as_ref().ok_or_else(|| need("corners"))?;
                if corners.len() != 4 {
                    return Err(self.field_error(
                        span,
                        "corners",
                        format!("needs 4 points, got {}", corners.len()),
                    ));
                }
                let mut p = [Vec3::ZERO; 4];
                for (i, c) in corners.iter().enumerate() {
                    p[i] = self.point3(span, "corners", *c)?;
                }
                let (e1, e2) = (p[1] - p[0], p[3] - p[0]);
                let off = (p[2] - (p[0] + e1 + e2)).length();
                let size = e1.length().max(e2.length());
                if off > 1e-4 * size.max(f32::MIN_POSITIVE) {
                    return Err(self.field_error(
                        span,
                        "corners",
                        format!("not a parallelogram: p2 is {off} away from p1 + p3 - p0"),
                    ));
                }
                Geometry::Quad(
                    Quad::new(p[0], e1, e2)
                        .ok_or_else(|| self.field_error(span, "corners", "the quad has no area"))?,
                )
            }
            "cuboid" => {
                let min = self.point3(span, "min", sd.min.ok_or_else(|| need("min"))?)?;
                let max = self.point3(span, "max", sd.max.ok_or_else(|| need("max"))?)?;
                if !min.cmplt(max).all() {
                    return Err(self.field_error(span, "max", "must exceed `min` on every axis"));
                }
                Geometry::Cuboid(Cuboid { min, max })
            }
            "triangle" => {
                let vertices = sd.vertices.as_ref().ok_or_else(|| need("vertices"))?;
                if vertices.len() != 3 {
                    return Err(self.field_error(
                        span,
                        "vertices",
                        format!("needs 3 points, got {}", vertices.len()),
                    ));
                }
                let mut positions = Vec::with_capacity(3);
                for v in vertices {
                    positions.push(self.point3(span, "vertices", *v)?.into());
                }
                if crate::scene::mesh_io::is_degenerate([positions[0], positions[1], positions[2]])
                {
                    return Err(self.field_error(
                        span,
                        "vertices",
                        "the triangle has no area (collinear vertices)",
                    ));
                }
                let uvs = match &sd.uvs {
                    Some(uvs) if uvs.len() == 3 => {
                        let uvs: Vec<Vec2> = uvs.iter().map(|&u| Vec2::from(u)).collect();
                        if let Some(uv) = uvs.iter().find(|uv| !uv.is_finite()) {
                            return Err(self.field_error(
                                span,
                                "uvs",
                                format!("must be finite, got {uv}"),
                            ));
                        }
                        Some(uvs)
                    }
                    Some(uvs) => {
                        return Err(self.field_error(
                            span,
                            "uvs",
                            format!("needs 3 pairs, got {}", uvs.len()),
                        ))
                    }
                    None => None,
                };
                Geometry::from(Mesh {
                    positions,
                    indices: vec![[0, 1, 2]],
                    uvs,
                    normals: None,
                })
            }
            "mesh" => return self.mesh(span, sd, warnings),
            _ => unreachable!("shape kinds are checked above"),
        }))
    }
}

/// The largest magnitude of a shape's own texture coordinates: 1 for the
/// bounded shapes and for meshes without uvs (barycentrics), the largest uv
/// of a mesh that has them, and for a plane, whose coordinates are positions
/// on it, the farthest a point can lie.
pub(super) fn uv_extent(g: &Geometry) -> f32 {
    match g {
        Geometry::Plane(_) => 2.0 * MAX_COORDINATE,
        Geometry::Mesh(mesh) => mesh.uvs.as_ref().map_or(1.0, |uvs| {
            uvs.iter()
                .fold(1.0f32, |m, uv| m.max(uv.abs().max_element()))
        }),
        _ => 1.0,
    }
}
