//! The shared Mitsuba scenes, loaded as they are, and the Cornell box's
//! brightness against Mitsuba 3's render.

use super::*;

/// The folder of the shared Mitsuba scenes, or `None` (and a note).
fn shared_scenes() -> Option<PathBuf> {
    let dir = std::env::var_os("LUZ_MITSUBA_SCENES")
        .map_or_else(|| PathBuf::from("../shared/scenes-mitsuba"), PathBuf::from);
    if dir.join("cbox/scene.xml").is_file() {
        return Some(dir);
    }
    eprintln!(
        "skipped: no Mitsuba scenes in {} (set LUZ_MITSUBA_SCENES)",
        dir.display()
    );
    None
}

#[test]
fn the_shared_scenes_load_as_they_are() {
    let Some(dir) = shared_scenes() else { return };
    for name in [
        "cbox",
        "cbox-spheres",
        "cbox-point-light",
        "veach_mi",
        "veach-mis-old",
        "staircase2",
        "living-room",
    ] {
        let path = dir.join(name).join("scene.xml");
        let s = load_with(&path, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
        assert!(!s.shapes.is_empty(), "{name}");
        assert!(!s.lights.is_empty() || !s.point_lights.is_empty() || s.environment.is_some());
    }
}

/// Mitsuba 3.9.1 (llvm_ad_rgb) rendered cbox/scene.xml at 64×64, 4096 spp,
/// with a box filter; these are its image's channel means. luz at 32×32
/// and 64 spp lands within 0.2% of them (measured); the test allows 1.5%.
const MITSUBA_CBOX_MEAN: [f64; 3] = [0.22617, 0.11604, 0.02651];

#[test]
fn cbox_is_as_bright_as_mitsuba_renders_it() {
    let Some(dir) = shared_scenes() else { return };
    let path: &Path = &dir.join("cbox/scene.xml");
    let mut s = load_with(path, &LoadOptions::default()).unwrap();
    s.camera.width = 32;
    s.camera.height = 32;
    let m = mean(&s, 64);
    eprintln!("cbox 32x32, 64 spp: luz {m:?}, Mitsuba {MITSUBA_CBOX_MEAN:?}");
    for c in 0..3 {
        let rel = (m[c] - MITSUBA_CBOX_MEAN[c]).abs() / MITSUBA_CBOX_MEAN[c];
        assert!(
            rel < 0.015,
            "channel {c}: luz {} vs Mitsuba {}",
            m[c],
            MITSUBA_CBOX_MEAN[c]
        );
    }
}
