//! The files a job reads and writes, and the guards that keep it from
//! destroying any of them. Before the first sample: every output is a file
//! (not a folder) in a folder that exists and takes new files, and no output
//! is the same file as an input or as another output. Sameness is decided
//! by (device, inode) for files that exist and by canonical path for files
//! still to be made, never by comparing the strings the user typed, so
//! `./out.exr`, a symbolic link and a hard link are all caught.
//!
//! A checkpoint is written under [`Checkpoint`]'s rules: created
//! exclusively, replaced only while it is still the file this run wrote, and
//! removed at the end only then.

use crate::image::ImageError;
use std::fmt;
use std::io;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// What a file is to a job; errors say which one they are about.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Role {
    Scene,
    /// A mesh or texture the scene names.
    SceneInput,
    Output,
    Checkpoint,
    Resume,
    /// A part given to `luz merge`.
    Part,
    /// The image `luz tonemap` reads.
    Image,
}

impl fmt::Display for Role {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Role::Scene => "the scene file",
            Role::SceneInput => "a file the scene reads",
            Role::Output => "the output",
            Role::Checkpoint => "the checkpoint",
            Role::Resume => "the --resume checkpoint",
            Role::Part => "a part to merge",
            Role::Image => "the input image",
        })
    }
}

#[derive(Debug, thiserror::Error)]
pub enum FileError {
    #[error("{}: {role} is a folder, not a file", path.display())]
    IsFolder { role: Role, path: PathBuf },
    #[error("{}: {role} exists and is not a regular file", path.display())]
    NotRegular { role: Role, path: PathBuf },
    #[error("{}: {role}'s folder {} does not exist", path.display(), folder.display())]
    MissingFolder {
        role: Role,
        path: PathBuf,
        folder: PathBuf,
    },
    #[error("{}: {role} cannot be written: its folder {} does not take new files ({source})", path.display(), folder.display())]
    Unwritable {
        role: Role,
        path: PathBuf,
        folder: PathBuf,
        source: io::Error,
    },
    #[error("{}: {role} would overwrite {other_role} {}; refused before rendering", path.display(), other.display())]
    SameFile {
        role: Role,
        path: PathBuf,
        other_role: Role,
        other: PathBuf,
    },
    #[error("{}: {role} already exists and was not written by this render; resume from it with --resume, choose another --checkpoint, or remove it", path.display())]
    CheckpointExists { role: Role, path: PathBuf },
    #[error("{}: {role} was replaced by another file while rendering; it was left as it is", path.display())]
    CheckpointReplaced { role: Role, path: PathBuf },
}

/// Who a path is: the file it names, or, for a file still to be made, the
/// canonical path it will have.
#[derive(Clone, Debug, PartialEq, Eq)]
enum Identity {
    #[cfg(unix)]
    File {
        device: u64,
        inode: u64,
    },
    Path(PathBuf),
}

fn identity(path: &Path) -> io::Result<Identity> {
    match std::fs::metadata(path) {
        #[cfg(unix)]
        Ok(meta) => {
            use std::os::unix::fs::MetadataExt;
            Ok(Identity::File {
                device: meta.dev(),
                inode: meta.ino(),
            })
        }
        #[cfg(not(unix))]
        Ok(_) => Ok(Identity::Path(path.canonicalize()?)),
        Err(e) if e.kind() == io::ErrorKind::NotFound => {
            let name = path
                .file_name()
                .ok_or_else(|| io::Error::new(io::ErrorKind::InvalidInput, "no file name"))?;
            Ok(Identity::Path(folder_of(path).canonicalize()?.join(name)))
        }
        Err(e) => Err(e),
    }
}

fn folder_of(path: &Path) -> &Path {
    match path.parent() {
        Some(dir) if !dir.as_os_str().is_empty() => dir,
        _ => Path::new("."),
    }
}

/// Whether `a` and `b` name the same file (or, not existing yet, would).
pub fn same_file(a: &Path, b: &Path) -> bool {
    match (identity(a), identity(b)) {
        (Ok(a), Ok(b)) => a == b,
        _ => false,
    }
}

static PROBE_COUNTER: AtomicU64 = AtomicU64::new(0);

/// Refuses an output path before any work is done on it: a folder, a
/// special file (FIFO, device), a missing folder, or a folder that does not
/// take new files (read-only, no permission), which a probe file tests.
pub fn check_output(role: Role, path: &Path) -> Result<(), FileError> {
    let owned = || path.to_path_buf();
    match std::fs::metadata(path) {
        Ok(meta) if meta.is_dir() => {
            return Err(FileError::IsFolder {
                role,
                path: owned(),
            })
        }
        Ok(meta) if !meta.is_file() => {
            return Err(FileError::NotRegular {
                role,
                path: owned(),
            })
        }
        _ => {}
    }
    let folder = folder_of(path);
    if !folder.is_dir() {
        return Err(FileError::MissingFolder {
            role,
            path: owned(),
            folder: folder.to_path_buf(),
        });
    }
    let probe = folder.join(format!(
        ".luz-probe-{}-{}",
        std::process::id(),
        PROBE_COUNTER.fetch_add(1, Ordering::Relaxed)
    ));
    match std::fs::File::options()
        .write(true)
        .create_new(true)
        .open(&probe)
    {
        Ok(_) => {
            let _ = std::fs::remove_file(&probe);
            Ok(())
        }
        Err(source) => Err(FileError::Unwritable {
            role,
            path: owned(),
            folder: folder.to_path_buf(),
            source,
        }),
    }
}

/// Refuses any output that is the same file as an input or as an earlier
/// output. Inputs that cannot be identified (missing) cannot be overwritten
/// either, so they are skipped; their own readers report them.
pub fn refuse_overlaps(
    outputs: &[(Role, &Path)],
    inputs: &[(Role, &Path)],
) -> Result<(), FileError> {
    for (i, &(role, path)) in outputs.iter().enumerate() {
        let others = inputs.iter().chain(&outputs[..i]);
        if let Some(&(other_role, other)) = others.into_iter().find(|(_, o)| same_file(path, o)) {
            return Err(FileError::SameFile {
                role,
                path: path.to_path_buf(),
                other_role,
                other: other.to_path_buf(),
            });
        }
    }
    Ok(())
}

/// A checkpoint file this run may write, replace and remove: created
/// exclusively, so a file that was there before is never overwritten (unless
/// it is the checkpoint being resumed, which holds this very render), and
/// replaced or removed only while it is still the file this run last wrote.
#[derive(Debug)]
pub struct Checkpoint {
    path: PathBuf,
    /// The file at `path` that is this run's to replace: the one it last
    /// wrote, or the resumed checkpoint; `None` until then.
    owned: Option<Fingerprint>,
}

/// A file as it was when last seen: (device, inode) alone cannot tell a
/// file from one made after it was removed, which may get its inode.
#[derive(Clone, Debug, PartialEq, Eq)]
struct Fingerprint {
    identity: Identity,
    len: u64,
    modified: Option<std::time::SystemTime>,
}

fn fingerprint(path: &Path) -> Option<Fingerprint> {
    let meta = std::fs::metadata(path).ok()?;
    Some(Fingerprint {
        identity: identity(path).ok()?,
        len: meta.len(),
        modified: meta.modified().ok(),
    })
}

impl Checkpoint {
    /// Claims `path` as the checkpoint. It must not exist, unless it is the
    /// file `resume` names (already verified to be of this render).
    pub fn claim(path: &Path, resume: Option<&Path>) -> Result<Self, FileError> {
        let owned = match resume {
            Some(resume) if same_file(path, resume) => fingerprint(path),
            _ => None,
        };
        if owned.is_none() && path.symlink_metadata().is_ok() {
            return Err(FileError::CheckpointExists {
                role: Role::Checkpoint,
                path: path.to_path_buf(),
            });
        }
        Ok(Self {
            path: path.to_path_buf(),
            owned,
        })
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Whether the file at the path is (still) this run's.
    fn is_ours(&self) -> bool {
        self.owned.is_some() && fingerprint(&self.path) == self.owned
    }

    /// Writes the checkpoint through `write` (which writes a complete file
    /// at the path it is given, atomically): the first time into a new file
    /// that must not exist, later over the file this run wrote.
    pub fn write<E: From<FileError> + From<ImageError>>(
        &mut self,
        write: impl FnOnce(&Path) -> Result<(), E>,
    ) -> Result<(), E> {
        if self.owned.is_some() {
            if !self.is_ours() {
                return Err(FileError::CheckpointReplaced {
                    role: Role::Checkpoint,
                    path: self.path.clone(),
                }
                .into());
            }
            write(&self.path)?;
        } else {
            write_new(&self.path, write)?;
        }
        self.owned = fingerprint(&self.path);
        Ok(())
    }

    /// Removes the checkpoint if it is still the file this run wrote or
    /// resumed; anything else at its path is left alone. Returns whether a
    /// file was removed.
    pub fn remove(&self) -> io::Result<bool> {
        if !self.is_ours() {
            return Ok(false);
        }
        std::fs::remove_file(&self.path)?;
        Ok(true)
    }
}

/// Makes a new file at `path` through `write`, which writes a complete file
/// at the path it is given: into a staging file first, then hard-linked to
/// `path`, which never replaces a file that is there. Where the file system
/// has no hard links, the staging file is renamed after a last check.
fn write_new<E: From<FileError> + From<ImageError>>(
    path: &Path,
    write: impl FnOnce(&Path) -> Result<(), E>,
) -> Result<(), E> {
    let exists = || FileError::CheckpointExists {
        role: Role::Checkpoint,
        path: path.to_path_buf(),
    };
    let name = path.file_name().ok_or_else(exists)?;
    let staging = folder_of(path).join(format!(
        ".{}.luz-new-{}-{}",
        name.to_string_lossy(),
        std::process::id(),
        PROBE_COUNTER.fetch_add(1, Ordering::Relaxed)
    ));
    write(&staging)?;
    let published = match std::fs::hard_link(&staging, path) {
        Err(e) if e.kind() == io::ErrorKind::AlreadyExists => Err(exists().into()),
        Err(_) if path.symlink_metadata().is_ok() => Err(exists().into()),
        Err(_) => std::fs::rename(&staging, path).map_err(|source| {
            ImageError::Io {
                path: path.to_path_buf(),
                source,
            }
            .into()
        }),
        Ok(()) => Ok(()),
    };
    let _ = std::fs::remove_file(&staging);
    published
}

#[cfg(test)]
mod tests {
    use super::*;

    fn temp_dir(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("luz-files-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    #[test]
    fn sameness_is_by_file_not_by_spelling() {
        let dir = temp_dir("same");
        let a = dir.join("a.exr");
        std::fs::write(&a, b"x").unwrap();
        let dotted = dir.join(".").join("a.exr");
        let up = dir.join("sub").join("..").join("a.exr");
        std::fs::create_dir(dir.join("sub")).unwrap();
        assert!(same_file(&a, &dotted));
        assert!(same_file(&a, &up));
        #[cfg(unix)]
        {
            let hard = dir.join("hard.exr");
            std::fs::hard_link(&a, &hard).unwrap();
            assert!(same_file(&a, &hard));
            let soft = dir.join("soft.exr");
            std::os::unix::fs::symlink(&a, &soft).unwrap();
            assert!(same_file(&a, &soft));
        }
        // Files still to be made are the same when their paths resolve alike.
        assert!(same_file(&dir.join("new.png"), &dir.join("sub/../new.png")));
        assert!(!same_file(&dir.join("new.png"), &dir.join("other.png")));
        assert!(!same_file(&a, &dir.join("new.png")));
    }

    #[test]
    fn outputs_overlapping_inputs_or_each_other_are_refused() {
        let dir = temp_dir("overlap");
        let scene = dir.join("s.toml");
        std::fs::write(&scene, b"").unwrap();
        let out = dir.join("out.exr");
        let dotted = dir.join(".").join("out.exr");
        let inputs = [(Role::Scene, scene.as_path())];
        assert!(refuse_overlaps(&[(Role::Output, &out)], &inputs).is_ok());
        let err = refuse_overlaps(&[(Role::Output, &dir.join("./s.toml"))], &inputs).unwrap_err();
        assert!(
            matches!(
                err,
                FileError::SameFile {
                    other_role: Role::Scene,
                    ..
                }
            ),
            "{err}"
        );
        let err = refuse_overlaps(
            &[(Role::Output, &out), (Role::Checkpoint, &dotted)],
            &inputs,
        )
        .unwrap_err();
        assert!(
            matches!(
                err,
                FileError::SameFile {
                    role: Role::Checkpoint,
                    other_role: Role::Output,
                    ..
                }
            ),
            "{err}"
        );
    }

    #[test]
    fn output_checks_refuse_folders_and_missing_folders() {
        let dir = temp_dir("check");
        assert!(matches!(
            check_output(Role::Output, &dir),
            Err(FileError::IsFolder { .. })
        ));
        let missing = dir.join("nope").join("out.png");
        assert!(matches!(
            check_output(Role::Output, &missing),
            Err(FileError::MissingFolder { .. })
        ));
        assert!(check_output(Role::Output, &dir.join("out.png")).is_ok());
        let left: Vec<_> = std::fs::read_dir(&dir).unwrap().collect();
        assert!(left.is_empty(), "the probe file was left behind");
    }

    #[test]
    fn a_checkpoint_never_takes_over_a_file_that_was_there() {
        let dir = temp_dir("claim");
        let precious = dir.join("precious.exr");
        std::fs::write(&precious, b"mine").unwrap();
        assert!(matches!(
            Checkpoint::claim(&precious, None),
            Err(FileError::CheckpointExists { .. })
        ));
        // Created after the claim by someone else: the first write refuses it.
        let late = dir.join("late.exr");
        let mut checkpoint = Checkpoint::claim(&late, None).unwrap();
        std::fs::write(&late, b"theirs").unwrap();
        let write = |p: &Path| std::fs::write(p, b"ours").map_err(|_| TestError);
        assert!(checkpoint.write::<TestError>(write).is_err());
        assert_eq!(std::fs::read(&late).unwrap(), b"theirs");
        assert!(!checkpoint.remove().unwrap());
        assert_eq!(std::fs::read(&late).unwrap(), b"theirs");
    }

    #[test]
    fn a_checkpoint_replaced_while_rendering_is_left_alone() {
        let dir = temp_dir("replaced");
        let path = dir.join("c.exr");
        let mut checkpoint = Checkpoint::claim(&path, None).unwrap();
        let write = |p: &Path| std::fs::write(p, b"ours").map_err(|_| TestError);
        checkpoint.write::<TestError>(write).unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"ours");
        // Someone puts their own file there.
        std::fs::remove_file(&path).unwrap();
        std::fs::write(&path, b"theirs").unwrap();
        assert!(checkpoint.write::<TestError>(write).is_err());
        assert!(!checkpoint.remove().unwrap());
        assert_eq!(std::fs::read(&path).unwrap(), b"theirs");
    }

    #[test]
    fn the_resumed_checkpoint_is_this_runs_to_replace_and_remove() {
        let dir = temp_dir("resumed");
        let path = dir.join("c.exr");
        std::fs::write(&path, b"earlier run").unwrap();
        let mut checkpoint = Checkpoint::claim(&path, Some(&dir.join("./c.exr"))).unwrap();
        let write = |p: &Path| std::fs::write(p, b"ours").map_err(|_| TestError);
        checkpoint.write::<TestError>(write).unwrap();
        assert!(checkpoint.remove().unwrap());
        assert!(!path.exists());
    }

    #[derive(Debug)]
    struct TestError;

    impl From<FileError> for TestError {
        fn from(_: FileError) -> Self {
            TestError
        }
    }

    impl From<ImageError> for TestError {
        fn from(_: ImageError) -> Self {
            TestError
        }
    }
}
