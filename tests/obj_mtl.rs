//! Morgan McGuire's `CornellBox-Original.obj`, given as one mesh with its
//! `.mtl` and no material (skipped when the asset is missing): it becomes
//! one shape per material, through TOML and Mitsuba XML alike, and it
//! renders lit. Under direct lighting alone, the light's own pixels hold
//! its `Ke` and each floor pixel the radiance `Kd/π · E` that quadrature
//! of the light's irradiance `E` predicts, checked by z-tests.

mod common;

use common::temp_dir;
use luz::accel::{Accel, Backend, BackendKind, BuildOptions};
use luz::geometry::{Geometry, Mesh};
use luz::math::{Ray, Rgb, Vec2, Vec3};
use luz::render::{build_accel, render_with, RenderOptions};
use luz::scene::{load, Scene};
use std::path::PathBuf;
use std::sync::Arc;

fn the_box() -> Option<PathBuf> {
    let assets = std::env::var_os("LUZ_ASSETS")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/assets"));
    let obj = assets.join("cornell-box/CornellBox-Original.obj");
    if obj.is_file() {
        Some(obj)
    } else {
        eprintln!("skipped: {} is not present", obj.display());
        None
    }
}

/// The box seen from the front, as in McGuire's archive, direct lighting
/// only (2 path segments), with independent samples so that each pixel's
/// estimated variance is unbiased.
fn toml_scene(obj: &std::path::Path) -> String {
    format!(
        "[camera]\neye = [0, 1, 3.9]\ntarget = [0, 1, 0]\nfov = 39.3\nresolution = [64, 64]\n\
         [render]\nspp = 256\nmax_depth = 2\nseed = 3\nsampler = \"independent\"\n\
         [[shapes]]\ntype = \"mesh\"\nfile = \"{}\"\n",
        obj.display()
    )
}

/// The shape whose material is `name`.
fn shape_of(scene: &Scene, name: &str) -> u32 {
    let found = scene
        .shapes
        .iter()
        .position(|s| scene.materials[s.material as usize].name == name);
    found.unwrap_or_else(|| panic!("no shape of material {name}")) as u32
}

fn mesh(scene: &Scene, shape: u32) -> &Mesh {
    match &scene.shapes[shape as usize].geometry {
        Geometry::Mesh(m) => m,
        g => panic!("not a mesh: {g:?}"),
    }
}

#[test]
fn the_mcguire_box_takes_its_materials_from_its_mtl() {
    let Some(obj) = the_box() else { return };
    let dir = temp_dir("parts");
    let path = dir.join("box.toml");
    std::fs::write(&path, toml_scene(&obj)).unwrap();
    let s = load(&path).unwrap();
    let mut names: Vec<&str> = s
        .shapes
        .iter()
        .map(|sh| s.materials[sh.material as usize].name.as_str())
        .collect();
    names.sort();
    let want = [
        "backWall",
        "ceiling",
        "floor",
        "leftWall",
        "light",
        "rightWall",
        "shortBox",
        "tallBox",
    ];
    assert_eq!(names, want);
    let triangles: usize = (0..s.shapes.len() as u32)
        .map(|i| mesh(&s, i).indices.len())
        .sum();
    assert_eq!(triangles, 36);
    let light = shape_of(&s, "light");
    let lamp = &s.materials[s.shapes[light as usize].material as usize];
    assert_eq!(lamp.emission, Rgb::new(17.0, 12.0, 4.0));
    assert_eq!(lamp.kd, Rgb::splat(0.78));
    let area = s.shapes[light as usize].geometry.area().unwrap();
    assert!((area - 0.47 * 0.38).abs() < 1e-5, "{area}");
    assert!(s.shapes[light as usize].nee && s.lights.is_sampled(light));
    assert_eq!(s.shapes.iter().filter(|sh| sh.nee).count(), 1);
    let floor = &s.materials[s.shapes[shape_of(&s, "floor") as usize].material as usize];
    assert_eq!(floor.kd, Rgb::new(0.725, 0.71, 0.68));
    assert!(floor.bsdf.is_none() && floor.texture.is_none());
    // A note each on what of the .obj and the .mtl luz does not read.
    assert_eq!(s.warnings.len(), 2, "{:?}", s.warnings);
    assert!(
        s.warnings[0].ends_with(".obj: not used: `g` (8)"),
        "{:?}",
        s.warnings
    );
    assert!(s.warnings[1].contains(".mtl: not used: `Ni` (8), `illum` (8), `Ka` (8)"));

    // Mitsuba XML: an `obj` shape without a BSDF, the same materials.
    let xml = format!(
        "<scene version=\"3.0.0\"><sensor type=\"perspective\"/>\
         <shape type=\"obj\"><string name=\"filename\" value=\"{}\"/></shape></scene>",
        obj.display()
    );
    let path = dir.join("box.xml");
    std::fs::write(&path, xml).unwrap();
    let x = load(&path).unwrap();
    assert_eq!(x.shapes.len(), s.shapes.len());
    for (a, b) in s.shapes.iter().zip(&x.shapes) {
        assert_eq!(
            s.materials[a.material as usize],
            x.materials[b.material as usize]
        );
        assert_eq!(a.nee, b.nee);
    }
}

/// Irradiance at `p` (normal `n`) from the emitter `light` of radiance `ke`:
/// the midpoint rule over each triangle cut into `K`² similar ones; `None`
/// where any of those points is hidden from `p`.
fn irradiance(accel: &Accel, light: &Mesh, ke: Rgb, p: Vec3, n: Vec3) -> Option<Rgb> {
    const K: u32 = 12;
    let mut e = Rgb::ZERO;
    for t in 0..light.indices.len() as u32 {
        let [a, b, c] = light.vertices(t);
        let normal = (b - a).cross(c - a);
        let area = 0.5 * normal.length() / (K * K) as f32;
        let normal = normal.normalize();
        assert!(normal.y < -0.99, "the light faces down");
        // Centroids of the K² sub-triangles, upright and upside down.
        for i in 0..K {
            for j in 0..K - i {
                let mut centroids = vec![Vec2::new(i as f32 + 1.0 / 3.0, j as f32 + 1.0 / 3.0)];
                if i + j + 1 < K {
                    centroids.push(Vec2::new(i as f32 + 2.0 / 3.0, j as f32 + 2.0 / 3.0));
                }
                for uv in centroids {
                    let uv = uv / K as f32;
                    let q = a + uv.x * (b - a) + uv.y * (c - a);
                    let d = q - p;
                    let r2 = d.length_squared();
                    let dir = d / r2.sqrt();
                    let shadow = Ray::segment(p + 1e-4 * n, dir, r2.sqrt() * (1.0 - 1e-4));
                    if accel.occluded(&shadow) {
                        return None;
                    }
                    let cos_p = n.dot(dir).max(0.0);
                    let cos_l = normal.dot(-dir).max(0.0);
                    e += ke * (cos_p * cos_l / r2 * area);
                }
            }
        }
    }
    Some(e)
}

#[test]
fn the_mcguire_box_renders_lit_as_its_light_predicts() {
    let Some(obj) = the_box() else { return };
    let dir = temp_dir("render");
    let path = dir.join("box.toml");
    std::fs::write(&path, toml_scene(&obj)).unwrap();
    let scene = Arc::new(load(&path).unwrap());
    let accel = build_accel(&scene, BackendKind::Rust, &BuildOptions::default()).unwrap();
    let (film, _) = render_with(&scene, &accel, &RenderOptions::from_scene(&scene), &());
    assert_eq!(film.non_finite, 0);
    let (light, floor) = (shape_of(&scene, "light"), shape_of(&scene, "floor"));
    let ke = Rgb::new(17.0, 12.0, 4.0);
    let kd = Rgb::new(0.725, 0.71, 0.68);
    let (camera, basis) = (&scene.camera, scene.camera.basis());
    let width = camera.width;
    // |z| above which one of the few hundred values below fails: under
    // 1e-4 false alarms in all if Gaussian.
    const LIMIT: f64 = 5.5;
    let (mut lamp_pixels, mut floor_pixels) = (0, 0);
    let (mut sum_d, mut sum_var) = ([0.0f64; 3], [0.0f64; 3]);
    for y in 0..camera.height {
        for x in 0..width {
            // A 3×3 grid over the pixel: where each point's ray lands.
            let hits: Vec<Option<(u32, Vec3)>> = (0..9)
                .map(|k| {
                    let at = Vec2::new(
                        x as f32 + (k % 3) as f32 / 3.0 + 1.0 / 6.0,
                        y as f32 + (k / 3) as f32 / 3.0 + 1.0 / 6.0,
                    );
                    let ray = camera.ray(&basis, at);
                    accel
                        .intersect(&ray)
                        .map(|h| (h.geom, ray.origin + h.t * ray.dir))
                })
                .collect();
            let all_on = |g: u32| hits.iter().all(|h| h.is_some_and(|h| h.0 == g));
            let i = (y * width + x) as usize;
            let (mean, var) = (film.pixel_mean(i), film.pixel_variance_of_mean(i));
            if all_on(light) {
                // Seen directly, and lit by nothing it can see.
                lamp_pixels += 1;
                for c in 0..3 {
                    let want = ke[c] as f64;
                    assert!((mean[c] - want).abs() < 1e-4 * want, "({x}, {y}): {mean:?}");
                }
                continue;
            }
            if !all_on(floor) {
                continue;
            }
            let mut want = Rgb::ZERO;
            let mut lit = true;
            for h in &hits {
                let p = h.expect("on the floor").1;
                match irradiance(&accel, mesh(&scene, light), ke, p, Vec3::Y) {
                    Some(e) => want += kd * e / std::f32::consts::PI / 9.0,
                    None => lit = false,
                }
            }
            if !lit {
                continue; // in a penumbra: quadrature would not be exact enough
            }
            floor_pixels += 1;
            for c in 0..3 {
                let w = want[c] as f64;
                // The variance of the estimate, and 2e-3 of the value for
                // the quadrature and the pixel's 3×3 points.
                let v = var[c] + (2e-3 * w).powi(2);
                let z = (mean[c] - w) / v.sqrt();
                assert!(
                    z.abs() < LIMIT,
                    "({x}, {y}) channel {c}: {} vs {w}, z = {z:.2}",
                    mean[c]
                );
                sum_d[c] += mean[c] - w;
                sum_var[c] += v;
            }
        }
    }
    eprintln!("{lamp_pixels} pixels of the light, {floor_pixels} of the lit floor");
    assert!(lamp_pixels >= 5 && floor_pixels >= 50);
    for c in 0..3 {
        let z = sum_d[c] / sum_var[c].sqrt();
        eprintln!("channel {c}: floor mean off by z = {z:.2}");
        assert!(
            z.abs() < LIMIT,
            "channel {c}: the floor's mean is off by z = {z:.2}"
        );
    }
}
