//! `<shape>`: obj, ply, rectangle, cube, disk and sphere, placed by
//! `to_world`, with `flip_normals`, their BSDF and an area emitter; an
//! `obj` without a BSDF takes the materials of its own `.mtl`, one shape
//! per material.

use super::props::Props;
use super::xml::Elem;
use super::Builder;
use crate::echo::echo;
use crate::geometry::{first_outside_bounds, within_bounds, Geometry, Mesh, Quad, Sphere};
use crate::math::Vec2;
use crate::scene::mesh_io::{
    drop_degenerate_grouped, read_mesh, read_serialized, MaterialGroups, MeshError, MeshFile,
};
use crate::scene::obj_materials::obj_parts;
use crate::scene::{Opacity, SceneError, Shape, Texture, UvTransform};
use glam::{DMat4, DVec3};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Segments of the polygon that stands in for a disk.
const DISK_SEGMENTS: u32 = 64;

impl<'e> Builder<'e, '_> {
    pub(super) fn shape(&mut self, e: &'e Elem) -> Result<(), SceneError> {
        let props = Props::new(e, self.ids);
        let m = props.transform("to_world")?.unwrap_or(DMat4::IDENTITY);
        let flip = props.boolean("flip_normals")?.unwrap_or(false);
        // Mitsuba's cube and disk are flat-shaded whatever it says, as
        // luz's are; obj and ply read it in `mesh_file`.
        props.accept("face_normals");
        // An OBJ file's own materials, used when the shape gives no BSDF.
        let mut own_materials = None;
        let geometry = match e.kind() {
            "obj" | "ply" | "serialized" => match self.mesh_file(&props, &m)? {
                Some((mesh, path, groups)) => {
                    own_materials = (!groups.is_empty()).then_some((path, groups));
                    Geometry::from(mesh)
                }
                None => {
                    props.objects("bsdf")?;
                    props.objects("emitter")?;
                    return props.finish(&mut self.problems);
                }
            },
            "rectangle" => rectangle(e, &m)?,
            "cube" => Geometry::from(checked(e, cube(&m))?),
            "disk" => {
                self.problems.warn(
                    &e.loc,
                    format!("<shape type=\"disk\">: substituted a {DISK_SEGMENTS}-sided polygon of the same area"),
                )?;
                Geometry::from(checked(e, disk(&m))?)
            }
            "sphere" => self.sphere(&props, &m, flip)?,
            other => {
                props.finish(&mut self.problems).ok();
                return self.problems.warn(
                    &e.loc,
                    format!("<shape type=\"{other}\"> is not supported; left out of the scene"),
                );
            }
        };
        // Mitsuba's rectangle and disk face along to_world's normal
        // transform (its inverse transpose) applied to +z; the cross
        // product of the transformed edges points the other way when
        // to_world mirrors.
        let mirrored = matches!(e.kind(), "rectangle" | "disk") && m.determinant() < 0.0;
        let pieces = match (props.objects("bsdf")?.first(), own_materials) {
            (Some(b), _) => {
                let (material, uv) = self.material_of(b)?;
                vec![(geometry, material, uv)]
            }
            (None, Some((path, groups))) => self.obj_parts(e, &path, geometry, &groups)?,
            (None, None) => vec![(geometry, self.default_material(), None)],
        };
        let emitters = props.objects("emitter")?;
        for (geometry, material, uv) in pieces {
            let geometry = if flip != mirrored {
                flipped(geometry)
            } else {
                geometry
            };
            let m = &self.materials[material as usize];
            let textured = m.texture.is_some() || matches!(m.opacity, Some(Opacity::Texture(_)));
            if textured && e.kind() == "sphere" {
                self.problems.warn(
                    &e.loc,
                    "a textured sphere: luz wraps textures around the world's y axis, Mitsuba around the sphere's local z; the texture lies differently",
                )?;
            }
            let mut shape = Shape::new(geometry, material);
            if let Some(uv) = uv {
                shape.uv_transform = uv;
            }
            // The emitters of an OBJ file's own materials (`Ke`) are area
            // lights, sampled as Mitsuba samples its own.
            shape.nee = self.materials[material as usize].is_emissive();
            for emitter in &emitters {
                self.area_emitter(emitter, &mut shape)?;
            }
            self.shapes.push(shape);
        }
        props.finish(&mut self.problems)
    }

    /// The mesh of an `obj` or `ply` shape placed by `m`, its path and the
    /// material groups of its faces; `None` when no triangle has any area
    /// (the scene leaves it out, and says so once for all such meshes).
    fn mesh_file(
        &mut self,
        props: &Props,
        m: &DMat4,
    ) -> Result<Option<(Mesh, PathBuf, MaterialGroups)>, SceneError> {
        let e = props.elem;
        let name = props
            .string("filename")?
            .ok_or_else(|| e.loc.error(format!("{} needs `filename`", e.describe())))?;
        let path = self.file(e, name)?;
        let MeshFile {
            mut mesh,
            mut notes,
            mut groups,
        } = match read_shape_mesh(props, &path)? {
            Ok(read) => read,
            Err(MeshError::NoArea { .. }) => {
                self.no_area.push(echo(name));
                return Ok(None);
            }
            Err(err) => return Err(e.loc.error(format!("`filename`: {err}"))),
        };
        // Mitsuba's OBJ reader turns v over (its images have v = 0 on top,
        // as `bitmap` keeps them): so does luz's import, which stores
        // images upside down for luz's v-up lookup.
        if let (Some(uvs), "obj") = (&mut mesh.uvs, e.kind()) {
            uvs.iter_mut().for_each(|uv| uv.y = 1.0 - uv.y);
        }
        if *m != DMat4::IDENTITY {
            mesh.transform(&m.as_mat4());
            let before = mesh.indices.len();
            let dropped = drop_degenerate_grouped(&mesh.positions, &mut mesh.indices, &mut groups);
            if mesh.indices.is_empty() {
                self.no_area.push(echo(name));
                return Ok(None);
            }
            if dropped > 0 {
                notes.push(format!(
                    "dropped {dropped} of {before} triangles, degenerate once transformed"
                ));
            }
        }
        // As Mitsuba: the file's vertex normals, else normals computed from
        // the faces once placed, unless `face_normals` asks for flat shading.
        if props.boolean("face_normals")?.unwrap_or(false) {
            mesh.normals = None;
        } else if mesh.normals.is_none() {
            mesh.compute_vertex_normals();
        }
        if !groups.is_empty() && !props.objects("bsdf")?.is_empty() {
            notes.push(format!(
                "the materials its faces ask for (`usemtl`, {}) are not used: the shape's <bsdf> applies to every face",
                groups.names.len()
            ));
        }
        if !notes.is_empty() {
            self.problems
                .warn(&e.loc, format!("{}: {}", path.display(), notes.join("; ")))?;
        }
        mesh.positions.reserve_exact(1);
        Ok(Some((checked(e, mesh)?, path, groups)))
    }

    /// The pieces of an OBJ mesh cut by the materials of its own `.mtl`.
    fn obj_parts(
        &mut self,
        e: &Elem,
        path: &Path,
        geometry: Geometry,
        groups: &MaterialGroups,
    ) -> Result<Vec<Piece>, SceneError> {
        let Geometry::Mesh(mesh) = geometry else {
            unreachable!("only mesh files have material groups")
        };
        let parts = obj_parts(path, Arc::unwrap_or_clone(mesh), groups)
            .map_err(|err| e.loc.error(format!("`filename`: {err}")))?;
        self.files.extend(parts.files);
        for w in parts.warnings {
            self.problems.warn(&e.loc, w)?;
        }
        let texture_base = self.textures.len() as u32;
        let material_base = self.materials.len() as u32;
        // Stored upside down, as every image of a Mitsuba scene is.
        self.textures
            .extend(parts.textures.into_iter().map(Texture::upside_down));
        self.materials
            .extend(parts.materials.into_iter().map(|mut m| {
                m.texture = m.texture.map(|t| t + texture_base);
                m
            }));
        let mut pieces = Vec::with_capacity(parts.parts.len());
        for (mut mesh, m) in parts.parts {
            mesh.positions.reserve_exact(1);
            let geometry = Geometry::from(mesh);
            let material = &self.materials[(material_base + m) as usize];
            let power = material.emission.max_element() * geometry.area().unwrap_or(0.0);
            if !power.is_finite() {
                return Err(e.loc.error(format!(
                    "the emitted power of material {} (`Ke` times the area) overflows f32",
                    echo(&material.name)
                )));
            }
            pieces.push((geometry, material_base + m, None));
        }
        Ok(pieces)
    }

    fn sphere(&mut self, props: &Props, m: &DMat4, flip: bool) -> Result<Geometry, SceneError> {
        let e = props.elem;
        let center = props.point("center")?.unwrap_or(DVec3::ZERO);
        let radius = props.float("radius")?.unwrap_or(1.0);
        let scales = [m.x_axis, m.y_axis, m.z_axis].map(|a| a.truncate().length());
        let (lo, hi) = (
            scales.iter().cloned().fold(f64::MAX, f64::min),
            scales.iter().cloned().fold(0.0, f64::max),
        );
        if hi - lo > 1e-6 * hi {
            self.problems.warn(
                &e.loc,
                "`to_world` scales the sphere unevenly; luz's spheres are round: substituted the mean scale",
            )?;
        }
        if flip && !props.objects("emitter")?.is_empty() {
            self.problems.warn(
                &e.loc,
                "`flip_normals`: luz's spheres emit outwards only; the flip is left out",
            )?;
        }
        let center = m.transform_point3(center).as_vec3a();
        let radius = (radius * scales.iter().sum::<f64>() / 3.0) as f32;
        if !(radius > 0.0 && radius.is_finite()) {
            return Err(e
                .loc
                .error(format!("`radius`: must be positive, got {radius}")));
        }
        let sphere = Sphere { center, radius };
        let b = sphere.bounds();
        if !within_bounds(b.min) || !within_bounds(b.max) {
            return Err(e.loc.error("the sphere reaches beyond ±1e12"));
        }
        Ok(Geometry::Sphere(sphere))
    }
}

/// A shape's geometry, its material and texture mapping.
type Piece = (Geometry, u32, Option<UvTransform>);

/// Every vertex within the coordinates luz can intersect.
fn checked(e: &Elem, mesh: Mesh) -> Result<Mesh, SceneError> {
    if let Some((i, p)) = first_outside_bounds(&mesh.positions) {
        return Err(e.loc.error(format!(
            "vertex {i} of the shape, at {p}, lies beyond ±1e12 (or is not finite) once transformed"
        )));
    }
    Ok(mesh)
}

/// The square [-1, 1]² at z = 0, front +z.
fn rectangle(e: &Elem, m: &DMat4) -> Result<Geometry, SceneError> {
    let p = |x: f64, y: f64| m.transform_point3(DVec3::new(x, y, 0.0)).as_vec3a();
    let (p0, p1, p3) = (p(-1.0, -1.0), p(1.0, -1.0), p(-1.0, 1.0));
    for c in [p0, p1, p3, p1 + p3 - p0] {
        if !within_bounds(c) {
            return Err(e
                .loc
                .error(format!("a corner of the rectangle, {c}, lies beyond ±1e12")));
        }
    }
    Quad::new(p0, p1 - p0, p3 - p0)
        .map(Geometry::Quad)
        .ok_or_else(|| e.loc.error("`to_world` flattens the rectangle to no area"))
}

/// The cube [-1, 1]³: four vertices per face, uvs in [0, 1]² on each.
fn cube(m: &DMat4) -> Mesh {
    let mut mesh = Mesh {
        uvs: Some(Vec::new()),
        normals: None,
        ..Mesh::default()
    };
    for axis in 0..3 {
        for sign in [1.0, -1.0] {
            let (b, c) = ((axis + 1) % 3, (axis + 2) % 3);
            let base = mesh.positions.len() as u32;
            for (u, v) in [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)] {
                let mut p = DVec3::ZERO;
                p[axis] = sign;
                p[b] = 2.0 * u - 1.0;
                p[c] = 2.0 * v - 1.0;
                mesh.positions.push(m.transform_point3(p).as_vec3());
                mesh.uvs
                    .as_mut()
                    .expect("uvs")
                    .push(Vec2::new(u as f32, v as f32));
            }
            // e_b × e_c = e_axis: counter-clockwise seen from outside.
            let tris = if sign > 0.0 {
                [[0, 1, 2], [0, 2, 3]]
            } else {
                [[0, 2, 1], [0, 3, 2]]
            };
            mesh.indices.extend(tris.map(|t| t.map(|i| base + i)));
        }
    }
    mesh
}

/// The unit disk at z = 0, front +z, as a polygon of the disk's area.
fn disk(m: &DMat4) -> Mesh {
    let n = DISK_SEGMENTS;
    let step = std::f64::consts::TAU / n as f64;
    let polygon_area = 0.5 * n as f64 * step.sin();
    let r = (std::f64::consts::PI / polygon_area).sqrt();
    let mut positions = vec![m.transform_point3(DVec3::ZERO).as_vec3()];
    let mut uvs = vec![Vec2::ZERO];
    for i in 0..n {
        let phi = i as f64 * step;
        let p = DVec3::new(r * phi.cos(), r * phi.sin(), 0.0);
        positions.push(m.transform_point3(p).as_vec3());
        uvs.push(Vec2::new(1.0, i as f32 / n as f32));
    }
    let indices = (0..n).map(|i| [0, 1 + i, 1 + (i + 1) % n]).collect();
    Mesh {
        positions,
        indices,
        uvs: Some(uvs),
        normals: None,
    }
}

/// The same surface facing the other way.
fn flipped(g: Geometry) -> Geometry {
    match g {
        Geometry::Mesh(mut mesh) => {
            for t in &mut Arc::make_mut(&mut mesh).indices {
                t.swap(1, 2);
            }
            Geometry::Mesh(mesh)
        }
        // The same edges swapped span the same area: never `None`.
        Geometry::Quad(q) => match Quad::new(q.p0, q.e2, q.e1) {
            Some(f) => Geometry::Quad(f),
            None => Geometry::Quad(q),
        },
        other => other,
    }
}

/// The mesh file of an `obj`, `ply` or `serialized` shape (of the latter,
/// mesh `shape_index`).
fn read_shape_mesh(props: &Props, path: &Path) -> Result<Result<MeshFile, MeshError>, SceneError> {
    if props.elem.kind() != "serialized" {
        return Ok(read_mesh(path));
    }
    let index = props.integer("shape_index")?.unwrap_or(0);
    let index = u32::try_from(index).map_err(|_| {
        props
            .elem
            .loc
            .error(format!("`shape_index`: must be 0 or more, got {index}"))
    })?;
    Ok(read_serialized(path, index))
}
