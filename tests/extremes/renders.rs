//! Render-level extremes: a scene far from the origin, extreme settings, a
//! 4096×4096 film, and non-finite samples kept out of written images.

use super::*;

fn floor_and_sphere(offset: Vec3, intensity: f32, extra: &str) -> String {
    let p = |x: f32, y: f32, z: f32| {
        let v = Vec3::new(x, y, z) + offset;
        format!("[{}, {}, {}]", v.x, v.y, v.z)
    };
    format!(
        r#"
[camera]
eye = {eye}
target = {target}
fov = 40
resolution = [12, 12]
{extra}
[materials.floor]
kd = 0.6
[materials.ball]
kd = 0.3
ks = 0.5
[[shapes]]
type = "quad"
corners = [{c0}, {c1}, {c2}, {c3}]
material = "floor"
[[shapes]]
type = "sphere"
center = {sc}
radius = 2
material = "ball"
[[lights]]
type = "point"
position = {lp}
intensity = {intensity}
"#,
        eye = p(0.0, 6.0, 14.0),
        target = p(0.0, 1.0, 0.0),
        c0 = p(-10.0, -1.0, 10.0),
        c1 = p(10.0, 1.0, 10.0),
        c2 = p(10.0, 1.0, -10.0),
        c3 = p(-10.0, -1.0, -10.0),
        sc = p(0.0, 2.5, 0.0),
        lp = p(3.0, 8.0, 4.0),
    )
}

/// A quad floor (20 units, tilted ~5.7° about z so one-ulp rounding of an
/// axis-aligned origin cannot hide a missing offset), a diffuse+mirror
/// sphere (radius 2) and a point
/// light, rendered at the origin and translated by (1e5, 1e5, -1e5)
/// (|offset| ≈ 1.7e5, where an f32 ulp is 0.0156): 12×12 pixels, 16 spp,
/// max_depth 6. The two image means must agree within 5 combined standard
/// errors plus 2% (geometry itself is only representable to ~1e-3 of the
/// scene size there); shadow acne from self-intersection would darken the
/// floor by far more (a zero offset drops the mean at 1e5 from ~0.33 to
/// ~0.19, checked by mutation). Both films finite with no non-finite samples.
#[test]
fn scene_translated_to_1e5_renders_the_same_mean() {
    let _table = Table;
    let settings = "[render]\nspp = 16\nmax_depth = 6\nseed = 3\n";
    let near = scene(&floor_and_sphere(Vec3::ZERO, 100.0, settings));
    let far = scene(&floor_and_sphere(
        Vec3::new(1e5, 1e5, -1e5),
        100.0,
        settings,
    ));
    for (name, kind, options) in configs() {
        let a = render_checked(&near, kind, &options, "floor+sphere at origin", name);
        let b = render_checked(&far, kind, &options, "floor+sphere at 1e5", name);
        let (ma, sa) = mean_and_se(&a);
        let (mb, sb) = mean_and_se(&b);
        let bound = 5.0 * (sa * sa + sb * sb).sqrt() + 0.02 * ma;
        eprintln!("  {name}: mean at origin {ma:.5} ± {sa:.5}, at 1e5 {mb:.5} ± {sb:.5}, bound {bound:.5}");
        assert!(ma > 0.1, "{name}: the scene must be lit ({ma})");
        assert!(
            (ma - mb).abs() < bound,
            "{name}: {ma} vs {mb} (bound {bound})"
        );
    }
}

/// Render extremes on every backend, each film finite with `non_finite ==
/// 0`: (a) point-light intensities 1e-6, 1e-3, 1e3, 1e6, 1e9 against 1:
/// with the same
/// seed the paths are identical, so mean/intensity must match the
/// intensity-1 mean within 1e-4 relative (f32 rounding); (b) `max_depth = 0`
/// (documented: renders black) gives an all-zero image although
/// `max_depth = 1` of the same scene (environment visible) does not;
/// (c) `max_depth = 1000` inside a closed box of albedo 0.95 with a glass
/// ball, Russian roulette on and off: terminates, and the two means agree
/// within 6 combined standard errors; (d) 1 spp on a 1×1 image.
#[test]
fn render_extremes_stay_finite() {
    let _table = Table;
    // (a) intensity sweep.
    for (name, kind, options) in configs() {
        let settings = "[render]\nspp = 4\nmax_depth = 4\nseed = 9\n";
        let base = render_checked(
            &scene(&floor_and_sphere(Vec3::ZERO, 1.0, settings)),
            kind,
            &options,
            "point light I=1",
            name,
        );
        let (m1, _) = mean_and_se(&base);
        assert!(m1 > 0.0);
        for intensity in [1e-6f32, 1e-3, 1e3, 1e6, 1e9] {
            let film = render_checked(
                &scene(&floor_and_sphere(Vec3::ZERO, intensity, settings)),
                kind,
                &options,
                &format!("point light I={intensity:e}"),
                name,
            );
            let (m, _) = mean_and_se(&film);
            let ratio = m / intensity as f64 / m1;
            eprintln!("  {name}: I={intensity:e} mean/I over mean(I=1) = {ratio}");
            assert!(
                (ratio - 1.0).abs() < 1e-4,
                "{name} I={intensity:e}: ratio {ratio}"
            );
        }
    }

    // (b) max_depth 0 and 1.
    let sky = |depth: u32| {
        format!(
            r#"
[camera]
eye = [0, 0, 5]
target = [0, 0, 0]
fov = 40
resolution = [8, 8]
[render]
spp = 2
max_depth = {depth}
[materials.light]
emission = 3
[[shapes]]
type = "sphere"
center = [0, 0, 0]
radius = 1
material = "light"
[environment]
radiance = [1, 2, 3]
"#
        )
    };
    for (name, kind, options) in configs() {
        let zero = render_checked(&scene(&sky(0)), kind, &options, "max_depth 0", name);
        assert!(
            zero.sum.iter().all(|p| *p == [0.0; 3]),
            "{name}: max_depth 0 must render black"
        );
        let one = render_checked(&scene(&sky(1)), kind, &options, "max_depth 1", name);
        assert!(
            mean_and_se(&one).0 > 1.0,
            "{name}: max_depth 1 sees the sky"
        );
    }

    // (c) max_depth 1000 in a closed box.
    let deep = |rr: bool| {
        format!(
            r#"
[camera]
eye = [0, 0, 3]
target = [0, 0, 0]
fov = 60
resolution = [8, 8]
[render]
spp = 8
max_depth = 1000
russian_roulette = {rr}
seed = 5
[materials.wall]
kd = 0.95
[materials.glass]
type = "glass"
[[shapes]]
type = "cuboid"
min = [-4, -4, -4]
max = [4, 4, 4]
material = "wall"
[[shapes]]
type = "sphere"
center = [0, 0, 0]
radius = 1
material = "glass"
[[lights]]
type = "point"
position = [1, 2, 2]
intensity = 10
"#
        )
    };
    for (name, kind, options) in configs() {
        let on = render_checked(
            &scene(&deep(true)),
            kind,
            &options,
            "max_depth 1000 RR on",
            name,
        );
        let off = render_checked(
            &scene(&deep(false)),
            kind,
            &options,
            "max_depth 1000 RR off",
            name,
        );
        let (a, sa) = mean_and_se(&on);
        let (b, sb) = mean_and_se(&off);
        eprintln!("  {name}: depth 1000 RR on {a:.4} ± {sa:.4}, off {b:.4} ± {sb:.4}");
        assert!(a > 0.0 && b > 0.0);
        assert!(
            (a - b).abs() < 6.0 * (sa * sa + sb * sb).sqrt(),
            "{name}: {a} vs {b}"
        );
    }

    // (d) 1 spp, 1x1.
    let tiny = floor_and_sphere(Vec3::ZERO, 100.0, "[render]\nspp = 1\n")
        .replace("resolution = [12, 12]", "resolution = [1, 1]");
    for (name, kind, options) in configs() {
        let film = render_checked(&scene(&tiny), kind, &options, "1 spp, 1x1", name);
        assert_eq!((film.width, film.height, film.samples), (1, 1, 1));
    }
}

/// VmHWM (peak resident memory) of this process, in bytes.
fn peak_rss() -> u64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    status
        .lines()
        .find_map(|l| l.strip_prefix("VmHWM:"))
        .and_then(|v| v.trim().strip_suffix("kB"))
        .and_then(|v| v.trim().parse::<u64>().ok())
        .map_or(0, |kb| kb * 1024)
}

/// A 4096×4096 film at 1 spp (a sphere on a bright sky: one camera ray per
/// sample) on every backend. The film holds exactly two `[f64; 3]` per pixel
/// (sum and sum of squares, 48 bytes: 805 MB); the peak resident memory of
/// the whole test process, reported, must stay under the film plus its
/// 12-byte-per-pixel image plus 512 MiB (a second copy of the film would
/// exceed it). Every pixel finite, no non-finite sample.
#[test]
fn film_4096_squared_memory_is_bounded() {
    let _table = Table;
    let scene = scene(
        r#"
[camera]
eye = [0, 0, 5]
target = [0, 0, 0]
fov = 40
resolution = [4096, 4096]
[render]
spp = 1
max_depth = 2
[materials.ball]
kd = 0.5
[[shapes]]
type = "sphere"
center = [0, 0, 0]
radius = 1
material = "ball"
[environment]
radiance = [1, 2, 3]
"#,
    );
    let pixels = 4096u64 * 4096;
    let film_bytes = 2 * pixels * std::mem::size_of::<[f64; 3]>() as u64;
    let image_bytes = pixels * std::mem::size_of::<Vec3>() as u64;
    for (name, kind, options) in configs() {
        let film = render_checked(&scene, kind, &options, "4096x4096 film, 1 spp", name);
        let held = (film.sum.capacity() + film.sum_sq.capacity()) as u64
            * std::mem::size_of::<[f64; 3]>() as u64;
        let peak = peak_rss();
        eprintln!(
            "  {name}: film {:.1} MB ({} bytes/pixel), peak RSS of the test process {:.1} MB",
            held as f64 / 1e6,
            held / pixels,
            peak as f64 / 1e6
        );
        assert_eq!(
            held, film_bytes,
            "{name}: the film holds 48 bytes per pixel"
        );
        assert!(
            peak < film_bytes + image_bytes + (512 << 20),
            "{name}: peak RSS {peak} bytes"
        );
    }
}

/// Non-finite samples (NaN, +∞, -∞) fed to the film's pixel accumulator
/// are counted and left out; the film's image and every image file written
/// from it (EXR, HDR, PPM, PNG) are finite and read back finite, with each
/// pixel the mean of its finite samples over all samples taken.
#[test]
fn non_finite_samples_are_counted_and_never_written() {
    let _table = Table;
    let (w, h, spp) = (4u32, 3u32, 4u64);
    let bad = [f32::NAN, f32::INFINITY, f32::NEG_INFINITY];
    let mut film = Film::new(w, h);
    film.samples = spp;
    let mut injected = 0;
    for (i, (sum, sq)) in film.sum.iter_mut().zip(&mut film.sum_sq).enumerate() {
        let mut px = PixelSum::default();
        for s in 0..spp as usize {
            if (i + s) % 3 == 0 {
                let mut l = Rgb::splat(0.5);
                l[s % 3] = bad[(i + s) % 3];
                px.add(l);
                injected += 1;
            } else {
                px.add(Rgb::new(1.0, 2.0, 3.0));
            }
        }
        film.non_finite += px.non_finite;
        *sum = px.sum;
        *sq = px.sum_sq;
    }
    row(
        "injected NaN/Inf samples",
        "film",
        0,
        0,
        0,
        0,
        film.non_finite,
    );
    assert_eq!(film.non_finite, injected);
    let img = film.image();
    for (i, p) in img.pixels.iter().enumerate() {
        let good = (0..spp as usize).filter(|s| (i + s) % 3 != 0).count() as f32;
        let want = Rgb::new(1.0, 2.0, 3.0) * good / spp as f32;
        assert_eq!(*p, want, "pixel {i}");
    }
    let dir = std::env::temp_dir().join(format!("luz-extremes-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for ext in ["exr", "hdr", "ppm", "png"] {
        let path = dir.join(format!("injected.{ext}"));
        write(&path, &img, &WriteOptions::default()).unwrap();
        let back = read(&path).unwrap();
        assert!(back.pixels.iter().all(|p| p.is_finite()), "{ext}");
        assert_eq!((back.width, back.height), (w, h));
    }
    let _ = std::fs::remove_dir_all(&dir);
}
