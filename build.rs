//! Finds Embree 3 and links it; without it, luz builds the native backend
//! only (`--backend embree` then reports `AccelError::EmbreeMissing`).
//!
//! Where it looks, in order:
//! 1. `EMBREE_DIR`: `$EMBREE_DIR/include/embree3/rtcore.h` and
//!    `libembree3` in `$EMBREE_DIR/lib` (or `lib64`);
//! 2. the system paths Debian's `libembree-dev` installs to
//!    (`/usr/include/embree3`, `/usr/lib/<multiarch>/libembree3.so`), and
//!    `/usr/local`.
//!
//! Environment:
//! - `LUZ_NO_EMBREE=1`: build without Embree even when it is installed;
//! - `LUZ_REQUIRE_EMBREE=1`: fail the build when Embree is not found.
//!
//! When found, it emits `cfg(luz_embree)`. The FFI declarations are the
//! committed bindgen output `ffi/embree3.rs`, so a build needs no C compiler,
//! bindgen or libclang. Two settings of the installed `rtcore_config.h`
//! change the layout of Embree's structs (`RTC_MAX_INSTANCE_LEVEL_COUNT`,
//! `RTC_MIN_WIDTH`); an Embree whose settings differ from those the bindings
//! were generated with is refused, with a pointer to `ffi/generate.sh`.

use std::env;
use std::fs;
use std::path::{Path, PathBuf};

const BINDINGS: &str = "ffi/embree3.rs";

struct Found {
    lib_dir: PathBuf,
}

fn flag(name: &str) -> bool {
    env::var(name)
        .map(|v| !v.is_empty() && v != "0" && !v.eq_ignore_ascii_case("false"))
        .unwrap_or(false)
}

/// Library file names that let `-l embree3` link on this target.
fn lib_names() -> &'static [&'static str] {
    match env::var("CARGO_CFG_TARGET_OS").as_deref() {
        Ok("windows") => &["embree3.lib"],
        Ok("macos") => &["libembree3.dylib"],
        _ => &["libembree3.so"],
    }
}

fn find_lib(dirs: &[PathBuf]) -> Option<PathBuf> {
    dirs.iter()
        .find(|d| lib_names().iter().any(|n| d.join(n).is_file()))
        .cloned()
}

/// `#define NAME value` from a header, as text.
fn define<'a>(header: &'a str, name: &str) -> Option<&'a str> {
    header.lines().find_map(|l| {
        let mut it = l.split_whitespace();
        (it.next() == Some("#define") && it.next() == Some(name))
            .then(|| it.next())
            .flatten()
    })
}

fn read_config(include: &Path) -> Result<(String, u32, bool), String> {
    let path = include.join("embree3/rtcore_config.h");
    println!("cargo:rerun-if-changed={}", path.display());
    let text =
        fs::read_to_string(&path).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    let major = define(&text, "RTC_VERSION_MAJOR").unwrap_or("?");
    let version = define(&text, "RTC_VERSION_STRING")
        .unwrap_or("\"?\"")
        .trim_matches('"')
        .to_string();
    if major != "3" {
        return Err(format!(
            "{} is Embree {version}; luz's FFI layer supports Embree 3",
            path.display()
        ));
    }
    let levels = define(&text, "RTC_MAX_INSTANCE_LEVEL_COUNT")
        .and_then(|v| v.parse().ok())
        .unwrap_or(1);
    // `#define RTC_MIN_WIDTH EMBREE_MIN_WIDTH`, itself 0 or 1.
    let min_width = match define(&text, "RTC_MIN_WIDTH") {
        Some("EMBREE_MIN_WIDTH") => define(&text, "EMBREE_MIN_WIDTH") == Some("1"),
        Some(v) => v == "1",
        None => false,
    };
    Ok((version, levels, min_width))
}

fn locate() -> Result<Found, String> {
    let multiarch = match env::var("CARGO_CFG_TARGET_ARCH").as_deref() {
        Ok("x86_64") => "x86_64-linux-gnu",
        Ok("aarch64") => "aarch64-linux-gnu",
        _ => "",
    };
    let (includes, lib_dirs): (Vec<PathBuf>, Vec<PathBuf>) = match env::var_os("EMBREE_DIR") {
        Some(dir) => {
            let dir = PathBuf::from(dir);
            let mut libs = vec![dir.join("lib"), dir.join("lib64")];
            if !multiarch.is_empty() {
                libs.push(dir.join("lib").join(multiarch));
            }
            (vec![dir.join("include")], libs)
        }
        None => {
            let mut libs = Vec::new();
            for prefix in ["/usr", "/usr/local"] {
                if !multiarch.is_empty() {
                    libs.push(Path::new(prefix).join("lib").join(multiarch));
                }
                libs.push(Path::new(prefix).join("lib64"));
                libs.push(Path::new(prefix).join("lib"));
            }
            (
                vec!["/usr/include".into(), "/usr/local/include".into()],
                libs,
            )
        }
    };
    let where_ = if env::var_os("EMBREE_DIR").is_some() {
        "under EMBREE_DIR"
    } else {
        "in the system paths"
    };
    let include = includes
        .iter()
        .find(|i| i.join("embree3/rtcore.h").is_file())
        .cloned()
        .ok_or_else(|| {
            format!(
                "no embree3/rtcore.h {where_} (looked in {})",
                join(&includes)
            )
        })?;
    let lib_dir = find_lib(&lib_dirs).ok_or_else(|| {
        format!(
            "found {} but no {} {where_} (looked in {})",
            include.join("embree3/rtcore.h").display(),
            lib_names().join(" or "),
            join(&lib_dirs)
        )
    })?;
    let (version, levels, min_width) = read_config(&include)?;
    check_bindings_fit(&include, &version, levels, min_width)?;
    Ok(Found { lib_dir })
}

/// `pub const NAME: u32 = value;` from the committed bindings.
fn binding_constant(bindings: &str, name: &str) -> Option<u32> {
    let prefix = format!("pub const {name}: u32 = ");
    bindings
        .lines()
        .find_map(|l| l.strip_prefix(&prefix)?.strip_suffix(';')?.parse().ok())
}

/// Whether the installed headers lay out Embree's structs as the bindings
/// in `ffi/embree3.rs` assume.
fn check_bindings_fit(
    include: &Path,
    version: &str,
    levels: u32,
    min_width: bool,
) -> Result<(), String> {
    println!("cargo:rerun-if-changed={BINDINGS}");
    let bindings =
        fs::read_to_string(BINDINGS).map_err(|e| format!("cannot read {BINDINGS}: {e}"))?;
    let expect =
        |name| binding_constant(&bindings, name).ok_or_else(|| format!("{BINDINGS} lacks {name}"));
    let (bound_levels, bound_min_width) = (
        expect("RTC_MAX_INSTANCE_LEVEL_COUNT")?,
        expect("RTC_MIN_WIDTH")? != 0,
    );
    if (levels, min_width) != (bound_levels, bound_min_width) {
        return Err(format!(
            "Embree {version} in {} was built with RTC_MAX_INSTANCE_LEVEL_COUNT={levels} and \
             RTC_MIN_WIDTH={}, but {BINDINGS} was generated for {bound_levels} and {}; \
             regenerate the bindings with ffi/generate.sh {}",
            include.display(),
            u8::from(min_width),
            u8::from(bound_min_width),
            include.display()
        ));
    }
    Ok(())
}

fn join(paths: &[PathBuf]) -> String {
    paths
        .iter()
        .map(|p| p.display().to_string())
        .collect::<Vec<_>>()
        .join(", ")
}

/// Stops the build with a message cargo shows as it is.
fn fail(message: &str) -> ! {
    eprintln!("error: {message}");
    std::process::exit(1);
}

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    for var in ["EMBREE_DIR", "LUZ_NO_EMBREE", "LUZ_REQUIRE_EMBREE"] {
        println!("cargo:rerun-if-env-changed={var}");
    }
    println!("cargo:rustc-check-cfg=cfg(luz_embree)");

    let require = flag("LUZ_REQUIRE_EMBREE");
    if flag("LUZ_NO_EMBREE") {
        if require {
            fail("LUZ_NO_EMBREE and LUZ_REQUIRE_EMBREE are both set; unset one of them");
        }
        println!(
            "cargo:warning=LUZ_NO_EMBREE is set: building without Embree (native backend only)"
        );
        return;
    }

    match locate() {
        Ok(found) => {
            println!("cargo:rustc-link-search=native={}", found.lib_dir.display());
            println!("cargo:rustc-link-lib=dylib=embree3");
            // An Embree outside the loader's default paths (EMBREE_DIR, or a
            // release tarball) is found at run time through an rpath.
            let system = ["/usr/lib", "/usr/lib64", "/lib", "/lib64"];
            let in_system = system.iter().any(|d| found.lib_dir == Path::new(d))
                || (found.lib_dir.starts_with("/usr/lib/")
                    && found.lib_dir.to_string_lossy().ends_with("-linux-gnu"));
            if !in_system && env::var("CARGO_CFG_TARGET_OS").as_deref() != Ok("windows") {
                println!(
                    "cargo:rustc-link-arg=-Wl,-rpath,{}",
                    found.lib_dir.display()
                );
            }
            println!("cargo:rustc-cfg=luz_embree");
        }
        Err(why) => {
            if require {
                fail(&format!(
                    "LUZ_REQUIRE_EMBREE is set but no usable Embree 3 was found: {why}.\n\
                     Install it (Debian/Ubuntu: `apt-get install libembree-dev`), or point \
                     EMBREE_DIR at an Embree 3 installation (with include/embree3/rtcore.h and \
                     lib/libembree3.so), or unset LUZ_REQUIRE_EMBREE to build the native backend only."
                ));
            }
            println!(
                "cargo:warning=no usable Embree 3 ({why}): building the native backend only. \
                 Install it with `apt-get install libembree-dev` (or set EMBREE_DIR) to enable --backend embree."
            );
        }
    }
}
