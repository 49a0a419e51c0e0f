//! A `mesh` shape: its file read and placed by `scale`, `rotate` and
//! `translate`, with the material groups of an OBJ file's faces.

use super::*;
use crate::geometry::first_outside_bounds;
use crate::scene::mesh_io::{
    drop_degenerate_grouped, read_mesh, MaterialGroups, MeshError, MeshFile,
};

/// What a shape table builds.
pub(super) enum Built {
    /// The geometry of a shape that is not a mesh file.
    Geometry(Geometry),
    /// A mesh file, read and placed in the world, with the material groups
    /// of its faces.
    MeshFile {
        path: PathBuf,
        mesh: Mesh,
        groups: MaterialGroups,
    },
    /// A mesh file with no triangle of any area, once placed: left out.
    NoArea(PathBuf),
}

impl Ctx<'_> {
    pub(super) fn mesh(
        &self,
        span: &Range<usize>,
        sd: &ShapeDesc,
        warnings: &mut Vec<String>,
    ) -> Result<Built, SceneError> {
        let file = sd
            .file
            .as_ref()
            .ok_or_else(|| self.error_at(span.start, "a mesh needs `file`"))?;
        let path = self.resolve_file(span, file)?;
        let MeshFile {
            mut mesh,
            mut notes,
            mut groups,
        } = match read_mesh(&path) {
            Ok(read) => read,
            Err(MeshError::NoArea { .. }) => return Ok(Built::NoArea(path)),
            Err(e) => return Err(self.field_error(span, "file", e.to_string())),
        };
        let scale = match sd.scale {
            None => Vec3::ONE,
            Some(Scale::Uniform(s)) => Vec3::splat(s),
            Some(Scale::PerAxis(s)) => Vec3::from(s),
        };
        if !scale.is_finite() || scale.cmpeq(Vec3::ZERO).any() {
            return Err(self.field_error(span, "scale", "must be finite and non-zero"));
        }
        let r = self.finite3(span, "rotate", sd.rotate.unwrap_or([0.0; 3]))?;
        let t = self.point3(span, "translate", sd.translate.unwrap_or([0.0; 3]))?;
        let rotation = Quat::from_rotation_z(r.z.to_radians())
            * Quat::from_rotation_y(r.y.to_radians())
            * Quat::from_rotation_x(r.x.to_radians());
        let transformed = sd.scale.is_some() || sd.rotate.is_some() || sd.translate.is_some();
        if transformed {
            mesh.transform(&Mat4::from_scale_rotation_translation(
                scale.into(),
                rotation,
                t.into(),
            ));
        }
        // Every vertex where it lands in the world, the file's own
        // or transformed, within the coordinates luz can intersect.
        if let Some((i, p)) = first_outside_bounds(&mesh.positions) {
            let field = ["scale", "translate", "rotate"]
                .into_iter()
                .zip([
                    sd.scale.is_some(),
                    sd.translate.is_some(),
                    sd.rotate.is_some(),
                ])
                .find_map(|(f, given)| given.then_some(f))
                .unwrap_or("file");
            let how = if transformed { " once transformed" } else { "" };
            return Err(self.field_error(
                span,
                field,
                format!("vertex {i} of the mesh{how}: {}", outside(p)),
            ));
        }
        if transformed {
            // A very uneven scale can flatten triangles to lines.
            let before = mesh.indices.len();
            let dropped = drop_degenerate_grouped(&mesh.positions, &mut mesh.indices, &mut groups);
            if mesh.indices.is_empty() {
                return Ok(Built::NoArea(path));
            }
            if dropped > 0 {
                notes.push(format!(
                    "dropped {dropped} of {before} triangles, degenerate once transformed"
                ));
            }
        }
        match sd.normals.unwrap_or_default() {
            MeshNormals::File => {}
            MeshNormals::Flat => mesh.normals = None,
            MeshNormals::Smooth if mesh.normals.is_none() => mesh.compute_vertex_normals(),
            MeshNormals::Smooth => {}
        }
        if sd.material.is_some() && !groups.is_empty() {
            notes.push(format!(
                "the materials its faces ask for (`usemtl`, {}) are not used: the shape's `material` applies to every face",
                groups.names.len()
            ));
        }
        if !notes.is_empty() {
            warnings.push(format!("{}: {}", path.display(), notes.join("; ")));
        }
        // Spare room after the last vertex lets Embree read luz's
        // own array instead of copying it (its loads are 16 bytes).
        mesh.positions.reserve_exact(1);
        Ok(Built::MeshFile { path, mesh, groups })
    }
}
