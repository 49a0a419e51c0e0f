//! Which of a PLY header's properties luz reads, and as what.

use super::header::{Element, Kind};
use crate::scene::mesh_io::fail::{fail_at, Fail};

/// What a property is used for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Role {
    Skip,
    /// Position component 0..3, texture coordinate 3..5 or normal
    /// component 5..8 (see [`Vertex`]).
    Value(usize),
    Indices,
}

/// How to read a PLY body.
pub(super) struct Plan {
    /// Per element, the role of each property.
    pub(super) roles: Vec<Vec<Role>>,
    pub(super) has_uv: bool,
    pub(super) has_normals: bool,
    /// The indices of the `vertex` and `face` elements.
    pub(super) vertex: usize,
    pub(super) face: usize,
}

/// The plan for a header's elements. `end_line` is the line of
/// `end_header`, where a missing element is reported.
pub(super) fn plan(elements: &[Element], end_line: usize) -> Result<Plan, Fail> {
    let mut roles: Vec<Vec<Role>> = elements
        .iter()
        .map(|e| vec![Role::Skip; e.props.len()])
        .collect();
    let vi = elements
        .iter()
        .position(|e| e.name == "vertex")
        .ok_or_else(|| fail_at(end_line, 1, "the header declares no `vertex` element"))?;
    let fi = elements
        .iter()
        .position(|e| e.name == "face")
        .ok_or_else(|| {
            fail_at(
                end_line,
                1,
                "the header declares no `face` element (a point cloud is not a mesh)",
            )
        })?;
    let (has_uv, has_normals) = vertex_roles(&elements[vi], &mut roles[vi])?;
    roles[fi][face_indices(&elements[fi])?] = Role::Indices;
    Ok(Plan {
        roles,
        has_uv,
        has_normals,
        vertex: vi,
        face: fi,
    })
}

/// The values a vertex record is read into: position, texture coordinates
/// and normal, by the component numbers of [`Role::Value`].
pub(super) type Vertex = [f32; 8];

/// Sets the roles of the `vertex` element's position, texture coordinates
/// and normal (`nx ny nz`, all three or none); returns whether it has the
/// texture coordinates and the normal.
fn vertex_roles(vertex: &Element, roles: &mut [Role]) -> Result<(bool, bool), Fail> {
    if vertex.count > u32::MAX as usize {
        return Err(fail_at(
            vertex.line,
            1,
            "too many vertices for 32-bit indices",
        ));
    }
    let find = |name: &str| -> Result<Option<usize>, Fail> {
        match vertex.props.iter().position(|p| p.name == name) {
            Some(i) if matches!(vertex.props[i].kind, Kind::List(..)) => Err(fail_at(
                vertex.props[i].line,
                1,
                format!("vertex property `{name}` must be a scalar, not a list"),
            )),
            other => Ok(other),
        }
    };
    for (c, name) in ["x", "y", "z"].into_iter().enumerate() {
        let i = find(name)?.ok_or_else(|| {
            fail_at(
                vertex.line,
                1,
                format!("the `vertex` element has no `{name}` property"),
            )
        })?;
        roles[i] = Role::Value(c);
    }
    let normal = [find("nx")?, find("ny")?, find("nz")?];
    let has_normals = normal.iter().all(Option::is_some);
    if has_normals {
        for (c, i) in normal.into_iter().flatten().enumerate() {
            roles[i] = Role::Value(5 + c);
        }
    }
    for (u, v) in [
        ("u", "v"),
        ("s", "t"),
        ("texture_u", "texture_v"),
        ("texture_s", "texture_t"),
    ] {
        if let (Some(iu), Some(iv)) = (find(u)?, find(v)?) {
            roles[iu] = Role::Value(3);
            roles[iv] = Role::Value(4);
            return Ok((true, has_normals));
        }
    }
    Ok((false, has_normals))
}

/// The index of the `face` element's list of vertex indices.
fn face_indices(face: &Element) -> Result<usize, Fail> {
    let i = face
        .props
        .iter()
        .position(|p| p.name == "vertex_indices" || p.name == "vertex_index")
        .ok_or_else(|| {
            fail_at(
                face.line,
                1,
                "the `face` element has no `vertex_indices` (or `vertex_index`) property",
            )
        })?;
    match face.props[i].kind {
        Kind::List(_, item) if !item.is_float() => Ok(i),
        _ => Err(fail_at(
            face.props[i].line,
            1,
            format!(
                "face property `{}` must be a list of integers",
                face.props[i].name
            ),
        )),
    }
}
