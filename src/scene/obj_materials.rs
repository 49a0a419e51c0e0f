//! An OBJ mesh's own materials, for a mesh the scene gives none: the `.mtl`
//! libraries its `mtllib` statements name, read into luz materials, and the
//! mesh cut into one part per material its faces ask for (`usemtl`), so
//! that each part is a shape of one material, as every other shape is.
//!
//! The mapping, documented in docs/scene-format.md ("OBJ materials"):
//! `Kd` is the diffuse reflectance, read as linear RGB (Mitsuba 0.6's
//! importer decoded it as sRGB; Mitsuba 3 reads no MTL); `map_Kd` replaces
//! it, as in Mitsuba 0.6; `Ke` is the emitted radiance; a material with
//! `Ks` above zero becomes a rough plastic, Ks tinting the coating, with
//! the usual Phong-to-Beckmann roughness α = √(2 / (Ns + 2)). What luz
//! cannot follow (a missing library, material or texture, a value above 1)
//! is said in a warning naming the file and line.

use super::mesh_io::{read_mtl, MaterialGroups, MeshError, MtlLibrary, MtlMaterial};
use super::{Material, Texture};
use crate::bsdf::{Bsdf, Distribution, Microfacet, RoughPlastic};
use crate::echo::echo;
use crate::geometry::Mesh;
use crate::math::Rgb;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// The coating's index of refraction: Mitsuba's plastic default.
const COATING_IOR: f32 = 1.49;

/// An OBJ mesh as shapes of one material each.
#[derive(Debug, Default)]
pub(crate) struct ObjParts {
    /// Each part's mesh and its index in `materials`.
    pub parts: Vec<(Mesh, u32)>,
    /// Their `texture`s are indices in `textures`.
    pub materials: Vec<Material>,
    pub textures: Vec<Texture>,
    /// The libraries and textures read.
    pub files: Vec<PathBuf>,
    pub warnings: Vec<String>,
}

/// Cuts `mesh`, read from `obj` with its material `groups`, into one part
/// per material. A malformed library is an error; one that cannot be read,
/// a material it lacks or a texture that cannot be read is a warning, and
/// the faces concerned take luz's default grey diffuse (or `Kd`).
pub(crate) fn obj_parts(
    obj: &Path,
    mesh: Mesh,
    groups: &MaterialGroups,
) -> Result<ObjParts, MeshError> {
    let mut out = ObjParts::default();
    let libraries = read_libraries(obj, groups, &mut out)?;
    let mut known: HashMap<&str, (&MtlMaterial, &Path)> = HashMap::new();
    for (path, library) in &libraries {
        for m in &library.materials {
            known.entry(m.name.as_str()).or_insert((m, path));
        }
    }
    let missing: Vec<String> = groups
        .names
        .iter()
        .filter(|n| !known.contains_key(n.name.as_str()))
        .map(|n| format!("{} (line {})", echo(&n.name), n.line))
        .collect();
    if !missing.is_empty() && !libraries.is_empty() {
        let read: Vec<String> = libraries.iter().map(|(p, _)| show(p)).collect();
        out.warnings.push(format!(
            "{}: no material of these names in {}: {}; their faces take the default grey diffuse",
            obj.display(),
            read.join(", "),
            missing.join(", ")
        ));
    }
    let mut textures = TextureCache::default();
    let mut plastics = Vec::new();
    let mut default = None;
    for (id, part) in groups.split(mesh) {
        let found = id.and_then(|id| known.get(groups.names[id as usize].name.as_str()));
        let material = match found {
            Some(&(m, library)) => {
                let has_uv = part.uvs.is_some();
                let material = convert(m, library, has_uv, &mut textures, &mut out);
                if material.bsdf.is_some() {
                    plastics.push(echo(&m.name));
                }
                out.materials.push(material);
                out.materials.len() as u32 - 1
            }
            None => *default.get_or_insert_with(|| {
                out.materials.push(Material {
                    name: "(default)".into(),
                    ..Material::default()
                });
                out.materials.len() as u32 - 1
            }),
        };
        out.parts.push((part, material));
    }
    if !plastics.is_empty() {
        out.warnings.push(format!(
            "{}: `Ks` of {} rendered as a rough plastic (Beckmann α = √(2/(Ns+2)), η = {COATING_IOR}, \
             `Ks` tinting the coating's reflection): MTL's Phong lobe has no luz counterpart",
            obj.display(),
            plastics.join(", ")
        ));
    }
    out.textures = textures.textures;
    out.files.extend(textures.files);
    Ok(out)
}

/// The libraries the `mtllib` statements name, relative to the OBJ file,
/// with a warning for each that cannot be read.
fn read_libraries(
    obj: &Path,
    groups: &MaterialGroups,
    out: &mut ObjParts,
) -> Result<Vec<(PathBuf, MtlLibrary)>, MeshError> {
    let dir = obj.parent().unwrap_or(Path::new("."));
    let mut libraries = Vec::new();
    if groups.libraries.is_empty() {
        out.warnings.push(format!(
            "{}:{}: faces ask for materials (`usemtl`) but the file names no library (`mtllib`): they take the default grey diffuse",
            obj.display(),
            groups.names.first().map_or(0, |n| n.line)
        ));
    }
    for statement in &groups.libraries {
        if statement.name.is_empty() {
            out.warnings.push(format!(
                "{}:{}: `mtllib` names no file",
                obj.display(),
                statement.line
            ));
            continue;
        }
        let name = statement.name.replace('\\', "/");
        let whole = dir.join(&name);
        // `mtllib a.mtl b.mtl` names two files; a name may hold spaces too.
        let files: Vec<PathBuf> = if whole.is_file() || !name.contains(char::is_whitespace) {
            vec![whole]
        } else {
            name.split_whitespace().map(|n| dir.join(n)).collect()
        };
        for file in files {
            match read_mtl(&file) {
                Ok(library) => {
                    if !library.notes.is_empty() {
                        let notes = library.notes.join("; ");
                        out.warnings.push(format!("{}: {notes}", file.display()));
                    }
                    out.files.push(file.clone());
                    libraries.push((file, library));
                }
                Err(MeshError::Io { source, .. }) => out.warnings.push(format!(
                    "{}:{}: `mtllib`: cannot read {}: {source}; the faces of its materials take the default grey diffuse",
                    obj.display(),
                    statement.line,
                    show(&file)
                )),
                Err(e) => return Err(e),
            }
        }
    }
    Ok(libraries)
}

/// Textures read so far, by file, and the files read.
#[derive(Default)]
struct TextureCache {
    by_file: HashMap<PathBuf, Result<u32, String>>,
    textures: Vec<Texture>,
    files: Vec<PathBuf>,
}

impl TextureCache {
    fn load(&mut self, path: PathBuf) -> Result<u32, String> {
        if let Some(done) = self.by_file.get(&path) {
            return done.clone();
        }
        let done = match crate::image::io::read_texture(&path) {
            Ok(img) => {
                self.textures.push(Texture::Image {
                    width: img.width,
                    height: img.height,
                    texels: img.pixels,
                });
                self.files.push(path.clone());
                Ok(self.textures.len() as u32 - 1)
            }
            Err(e) => Err(e.to_string()),
        };
        self.by_file.insert(path, done.clone());
        done
    }
}

/// The luz material of MTL material `m` of `library`, for faces that have
/// texture coordinates or not.
fn convert(
    m: &MtlMaterial,
    library: &Path,
    has_uv: bool,
    textures: &mut TextureCache,
    out: &mut ObjParts,
) -> Material {
    let at = format!(
        "{}:{}: material {}",
        library.display(),
        m.line,
        echo(&m.name)
    );
    // As the TOML format's materials: grey unless something else is given.
    let kd_default = match (m.ks, m.ke) {
        (None, None) => Rgb::splat(0.5),
        _ => Rgb::ZERO,
    };
    let mut capped = |field: &str, c: Rgb| {
        let max = c.max_element();
        if max <= 1.0 {
            return c;
        }
        out.warnings.push(format!(
            "{at}: `{field}` {c} exceeds 1 (the surface would create energy): scaled down to {}",
            c / max
        ));
        c / max
    };
    let kd = capped("Kd", m.kd.unwrap_or(kd_default));
    let ks = capped("Ks", m.ks.unwrap_or(Rgb::ZERO));
    let texture = m.map_kd.as_ref().and_then(|(file, line)| {
        let why = if has_uv {
            let dir = library.parent().unwrap_or(Path::new("."));
            match textures.load(dir.join(file.replace('\\', "/"))) {
                Ok(t) => return Some(t),
                Err(e) => e,
            }
        } else {
            "the faces of the material have no texture coordinates".into()
        };
        out.warnings.push(format!(
            "{}:{line}: `map_Kd` {}: {why}; `Kd` used instead",
            library.display(),
            echo(file)
        ));
        None
    });
    // The texture replaces `Kd`, as in Mitsuba's importer.
    let kd = if texture.is_some() { Rgb::ONE } else { kd };
    let bsdf = (ks.max_element() > 0.0).then(|| {
        let alpha = (2.0 / (m.ns.unwrap_or(0.0) + 2.0)).sqrt();
        let coating = Microfacet::new(Distribution::Beckmann, alpha);
        let mean = (kd.x + kd.y + kd.z) / 3.0;
        Bsdf::RoughPlastic(RoughPlastic::new(coating, COATING_IOR, ks, mean, false))
    });
    Material {
        name: m.name.clone(),
        kd,
        emission: m.ke.unwrap_or(Rgb::ZERO),
        texture,
        bsdf,
        ..Material::default()
    }
}

/// A path for a message, shortened when long.
fn show(path: &Path) -> String {
    echo(&path.display().to_string())
}

#[cfg(test)]
mod tests;
