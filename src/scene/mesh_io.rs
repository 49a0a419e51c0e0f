//! Placeholder until the mesh loaders land.
use super::shape::Mesh;
use std::path::Path;
#[derive(Debug, thiserror::Error)]
#[error("{0}: mesh loading is not built yet")]
pub struct MeshError(String);
pub fn load_mesh(path: &Path) -> Result<Mesh, MeshError> {
    Err(MeshError(path.display().to_string()))
}
