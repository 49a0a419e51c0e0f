//! Where a relative file name in a scene is looked for, as Mitsuba's file
//! resolver does it: `<path value="..."/>` adds a folder, and a name is
//! searched in the folders in turn, the first that holds it winning.
//!
//! Mitsuba resolves a mesh's or a texture's name when it builds the
//! plugin, against its global list: the `<path>` folders (the latest first)
//! and the folder of the scene file it was asked to load, so a name
//! written in an included file is relative to the including scene (its
//! own Cornell box includes `fragments/shapes.xml`, which names
//! `meshes/cbox_floor.obj` next to the scene). luz looks in the folder of
//! the file that names it first, as it always has, then where Mitsuba
//! looks.

use super::xml::Loc;
use crate::echo::echo;
use std::path::{Path, PathBuf};

#[derive(Clone, Debug, Default)]
pub(super) struct Resolver {
    /// The `<path>` folders, in the order the scene gives them.
    paths: Vec<PathBuf>,
    /// The folder of the scene file luz was asked to load.
    root: PathBuf,
}

impl Resolver {
    pub fn new(scene_file: &Path) -> Self {
        Self {
            paths: Vec::new(),
            root: folder_of(scene_file).to_path_buf(),
        }
    }

    /// `<path value>`: a folder relative to the file that gives it, or
    /// else found as a file name is; it must exist.
    pub fn add(&mut self, loc: &Loc, value: &str) -> Result<(), crate::scene::SceneError> {
        let folder = self
            .candidates(loc, value)
            .find(|p| p.is_dir())
            .ok_or_else(|| {
                loc.error(format!(
                    "<path>: no folder {} in {}",
                    echo(value),
                    self.places(loc)
                ))
            })?;
        self.paths.push(folder);
        Ok(())
    }

    /// The file `name` as written at `loc`: the first candidate that exists,
    /// else the one in the folder of `loc`'s file.
    pub fn resolve(&self, loc: &Loc, name: &str) -> PathBuf {
        self.candidates(loc, name)
            .find(|p| p.exists())
            .unwrap_or_else(|| loc.dir().join(name))
    }

    /// The folders `name` is looked for in, for a message, quoted.
    pub fn places(&self, loc: &Loc) -> String {
        let folders: Vec<String> = self
            .folders(loc)
            .iter()
            .map(|p| echo(&p.display().to_string()))
            .collect();
        folders.join(", ")
    }

    fn candidates<'a>(&self, loc: &Loc, name: &'a str) -> impl Iterator<Item = PathBuf> + 'a {
        self.folders(loc).into_iter().map(move |dir| dir.join(name))
    }

    /// The own folder, the `<path>` folders from the latest, the scene's
    /// folder; each once.
    fn folders(&self, loc: &Loc) -> Vec<PathBuf> {
        let mut out = vec![loc.dir().to_path_buf()];
        for dir in self.paths.iter().rev().chain([&self.root]) {
            if !out.contains(dir) {
                out.push(dir.clone());
            }
        }
        out
    }
}

fn folder_of(file: &Path) -> &Path {
    file.parent().unwrap_or(Path::new("."))
}
