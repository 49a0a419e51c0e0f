//! Mitsuba XML import: each feature on a small inline scene, the shared
//! Bitterli scenes (skipped when `LUZ_MITSUBA_SCENES` is absent), and the
//! Cornell box's brightness against Mitsuba 3's own render.

mod common;

use common::{luz, temp_dir};
use luz::accel::{Accel, BackendKind, BuildOptions};
use luz::geometry::Geometry;
use luz::math::Vec3;
use luz::render::{render_with, RenderOptions};
use luz::scene::{load_with, LoadOptions, Opacity, Scene, SceneError};
use std::path::{Path, PathBuf};
use std::sync::Arc;

const SENSOR: &str = r#"<sensor type="perspective"><float name="fov" value="40"/>
  <transform name="to_world"><lookat origin="0,0,5" target="0,0,0" up="0,1,0"/></transform>
  <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/>
  <rfilter type="box"/></film></sensor>"#;

/// Writes `files` (name, text) into a fresh folder and loads the first.
fn load(test: &str, files: &[(&str, &str)], options: &LoadOptions) -> Result<Scene, SceneError> {
    let dir = temp_dir(test);
    for (name, text) in files {
        std::fs::write(dir.join(name), text).unwrap();
    }
    load_with(&dir.join(files[0].0), options)
}

/// A light, so that scenes meant to load without warnings earn none for
/// rendering black.
const LIGHT: &str = r#"<emitter type="point"><point name="position" value="0,0,3"/></emitter>"#;

fn scene(body: &str) -> String {
    format!("<scene version=\"3.0.0\">\n{SENSOR}\n{body}\n</scene>\n")
}

fn ok(test: &str, body: &str) -> Scene {
    load(test, &[("s.xml", &scene(body))], &LoadOptions::default())
        .unwrap_or_else(|e| panic!("{test}: {e}"))
}

fn close(a: Vec3, b: Vec3) -> bool {
    (a - b).length() < 1e-4
}

#[test]
fn defaults_params_and_defines() {
    let body = r#"<default name="spp" value="4"/>
        <sensor type="perspective"><sampler type="independent">
        <integer name="sample_count" value="$spp"/></sampler></sensor>"#;
    let text = format!("<scene version=\"3.0.0\">{body}</scene>");
    let files = [("s.xml", text.as_str())];
    let s = load("defaults", &files, &LoadOptions::default()).unwrap();
    assert_eq!(s.render.spp, 4);
    let defined = LoadOptions {
        defines: vec![("spp".into(), "9".into())],
        strict: false,
    };
    assert_eq!(load("defines", &files, &defined).unwrap().render.spp, 9);
}

#[test]
fn includes_and_refs() {
    let part = r#"<scene version="3.0.0"><bsdf type="diffuse" id="red">
        <rgb name="reflectance" value="0.8, 0.1, 0.1"/></bsdf></scene>"#;
    let main = scene(
        r#"<include filename="part.xml"/>
        <shape type="sphere"><ref id="red"/></shape>
        <shape type="sphere"><point name="center" x="3" y="0" z="0"/><ref id="red"/></shape>"#,
    );
    let s = load(
        "include",
        &[("s.xml", &main), ("part.xml", part)],
        &LoadOptions::default(),
    )
    .unwrap();
    assert_eq!(s.shapes.len(), 2);
    assert_eq!(s.shapes[0].material, s.shapes[1].material);
    let m = &s.materials[s.shapes[0].material as usize];
    assert!(close(m.kd, Vec3::new(0.8, 0.1, 0.1)), "{:?}", m.kd);
    assert!(s.files.iter().any(|f| f.ends_with("part.xml")));
    let err = ok_err("badref", r#"<shape type="sphere"><ref id="nope"/></shape>"#);
    assert!(err.contains("s.xml:") && err.contains("nope"), "{err}");
}

fn ok_err(test: &str, body: &str) -> String {
    load(test, &[("s.xml", &scene(body))], &LoadOptions::default())
        .unwrap_err()
        .to_string()
}

#[test]
fn every_transform_places_a_rectangle() {
    let quad = |steps: &str| {
        let s = ok(
            "transform",
            &format!(
                r#"<shape type="rectangle"><transform name="to_world">{steps}</transform></shape>"#
            ),
        );
        match &s.shapes[0].geometry {
            Geometry::Quad(q) => (q.p0, q.e1, q.e2),
            g => panic!("not a quad: {g:?}"),
        }
    };
    let (p0, e1, e2) = quad(r#"<scale x="2" y="3"/><translate value="1 0 0"/>"#);
    assert!(close(p0, Vec3::new(-1.0, -3.0, 0.0)) && close(e1, Vec3::new(4.0, 0.0, 0.0)));
    assert!(close(e2, Vec3::new(0.0, 6.0, 0.0)));
    let (_, e1, _) = quad(r#"<rotate z="1" angle="90"/>"#);
    assert!(close(e1, Vec3::new(0.0, 2.0, 0.0)), "{e1}");
    let (p0, ..) = quad(r#"<matrix value="1 0 0 0 0 1 0 0 0 0 1 7 0 0 0 1"/>"#);
    assert!(close(p0, Vec3::new(-1.0, -1.0, 7.0)));
    let (p0, e1, e2) = quad(r#"<lookat origin="0,0,0" target="0,-1,0" up="0,0,1"/>"#);
    // Front (+z) now faces -y.
    assert!(
        e1.cross(e2).normalize().dot(-Vec3::Y) > 0.999,
        "{p0} {e1} {e2}"
    );
}

#[test]
fn each_shape() {
    let dir = temp_dir("shapes-files");
    let obj = dir.join("tri.obj");
    std::fs::write(&obj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let ply = dir.join("tri.ply");
    std::fs::write(
        &ply,
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
    )
    .unwrap();
    let body = format!(
        r#"<shape type="obj"><string name="filename" value="{}"/></shape>
        <shape type="ply"><string name="filename" value="{}"/><boolean name="flip_normals" value="true"/></shape>
        <shape type="cube"/>
        <shape type="disk"/>
        <shape type="sphere"><float name="radius" value="2"/>
          <transform name="to_world"><translate x="1"/></transform></shape>"#,
        obj.display(),
        ply.display()
    );
    let s = ok("shapes", &body);
    let mesh = |i: usize| match &s.shapes[i].geometry {
        Geometry::Mesh(m) => m.clone(),
        g => panic!("shape {i} is not a mesh: {g:?}"),
    };
    assert_eq!(mesh(0).indices, vec![[0, 1, 2]]);
    assert_eq!(
        mesh(1).indices,
        vec![[0, 2, 1]],
        "flip_normals reverses the winding"
    );
    let cube = mesh(2);
    assert_eq!(cube.indices.len(), 12);
    let area: f32 = (0..12).map(|t| cube.triangle_area(t)).sum();
    assert!((area - 24.0).abs() < 1e-4, "{area}");
    let disk = mesh(3);
    let area: f32 = (0..disk.indices.len() as u32)
        .map(|t| disk.triangle_area(t))
        .sum();
    assert!((area - std::f32::consts::PI).abs() < 1e-4, "{area}");
    assert!(
        s.warnings.iter().any(|w| w.contains("disk")),
        "{:?}",
        s.warnings
    );
    match &s.shapes[4].geometry {
        Geometry::Sphere(sp) => assert!(close(sp.center, Vec3::X) && sp.radius == 2.0),
        g => panic!("{g:?}"),
    }
}

#[test]
fn sensor_fov_axis_film_and_integrator() {
    let text = r#"<scene version="3.0.0"><integrator type="path">
        <integer name="max_depth" value="5"/><integer name="rr_depth" value="10"/></integrator>
        <sensor type="perspective"><float name="fov" value="90"/>
        <string name="fov_axis" value="x"/>
        <film type="hdrfilm"><integer name="width" value="200"/><integer name="height" value="100"/>
        <rfilter type="box"/></film></sensor></scene>"#;
    let text = text.replace("</scene>", &format!("{LIGHT}</scene>"));
    let s = load("sensor", &[("s.xml", &text)], &LoadOptions::default()).unwrap();
    let expect = 2.0 * 0.5f32.atan().to_degrees();
    assert!((s.camera.fov_y - expect).abs() < 1e-4, "{}", s.camera.fov_y);
    assert_eq!((s.camera.width, s.camera.height), (200, 100));
    assert_eq!(s.render.max_depth, 5);
    assert!(
        !s.render.russian_roulette,
        "rr_depth past max_depth: no roulette"
    );
    assert_eq!(s.render.spp, 4, "Mitsuba's default sampler");
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
}

#[test]
fn old_files_are_upgraded() {
    let text = r#"<scene version="0.5.0">
      <integrator type="path"><integer name="maxDepth" value="3"/></integrator>
      <sensor type="perspective"><float name="fov" value="40"/><string name="fovAxis" value="y"/>
        <transform name="toWorld"><lookAt origin="0,0,5" target="0,0,0" up="0,1,0"/></transform>
        <sampler type="independent"><integer name="sampleCount" value="7"/></sampler>
        <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/>
        <rfilter type="box"/></film></sensor>
      <shape type="rectangle"><bsdf type="diffuse">
        <texture name="diffuseReflectance" type="checkerboard">
          <float name="uscale" value="4"/><float name="voffset" value="0.5"/></texture></bsdf></shape>
      <shape type="sphere"><bsdf type="dielectric"><float name="intIOR" value="1.33"/>
        <float name="extIOR" value="1.0"/></bsdf></shape>
    </scene>"#;
    let text = text.replace("</scene>", &format!("{LIGHT}</scene>"));
    let s = load("upgrade", &[("s.xml", &text)], &LoadOptions::default()).unwrap();
    assert_eq!((s.render.max_depth, s.render.spp), (3, 7));
    assert!(close(s.camera.eye, Vec3::new(0.0, 0.0, 5.0)));
    assert!((s.camera.fov_y - 40.0).abs() < 1e-4);
    let textured = &s.materials[s.shapes[0].material as usize];
    assert!(
        textured.texture.is_some(),
        "diffuseReflectance became reflectance"
    );
    let uv = s.shapes[0].uv_transform;
    // to_uv = scale(4, 1) · translate(0, 0.5).
    assert_eq!(
        (uv.scale.x, uv.scale.y, uv.offset.x, uv.offset.y),
        (4.0, 1.0, 0.0, 0.5)
    );
    let glass = &s.materials[s.shapes[1].material as usize];
    assert!(glass.dielectric && (glass.ior - 1.33).abs() < 1e-6);
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
}

#[test]
fn unsupported_features_warn_with_their_place_and_strict_refuses() {
    let body =
        "<shape type=\"sphere\">\n<bsdf type=\"hair\"/></shape>\n<emitter type=\"directional\"/>";
    let text = scene(body);
    let line = 1 + text.lines().position(|l| l.contains("hair")).unwrap();
    let s = load("warn", &[("s.xml", &text)], &LoadOptions::default()).unwrap();
    let hair = s
        .warnings
        .iter()
        .find(|w| w.contains("hair"))
        .expect("a warning");
    assert!(hair.contains(&format!("s.xml:{line}:1")), "{hair}");
    assert!(hair.contains("substituted"), "{hair}");
    assert!(s
        .warnings
        .iter()
        .any(|w| w.contains("directional") && w.contains("left out")));
    let strict = LoadOptions {
        strict: true,
        ..LoadOptions::default()
    };
    let err = load("strict", &[("s.xml", &text)], &strict).unwrap_err();
    assert_eq!(err.location, Some((line, 1)), "{err}");
    assert!(err.message.contains("--strict"), "{err}");
}

#[test]
fn malformed_xml_and_strict_exit_with_status_2() {
    let dir = temp_dir("cli");
    let bad = dir.join("bad.xml");
    std::fs::write(
        &bad,
        "<scene version=\"3.0.0\">\n  <shape type=\"obj\">\n</scene>\n",
    )
    .unwrap();
    let out = luz(&[
        "render",
        bad.to_str().unwrap(),
        "-o",
        dir.join("b.png").to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("bad.xml:3:"), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    let warned = dir.join("warned.xml");
    std::fs::write(&warned, scene(r#"<shape type="cylinder"/>"#)).unwrap();
    let png = dir.join("w.png");
    let args = [
        "render",
        warned.to_str().unwrap(),
        "-o",
        png.to_str().unwrap(),
        "--quiet",
    ];
    let out = luz(&[&args[..], &["--strict"]].concat());
    assert_eq!(out.status.code(), Some(2));
    assert!(!png.exists());
    let out = luz(&[&args[..], &["-D", "unused=1", "--threads", "1"]].concat());
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(String::from_utf8_lossy(&out.stderr).contains("cylinder"));
    // Parameters belong to XML scenes: on a TOML scene -D is refused.
    let toml = dir.join("s.toml");
    std::fs::write(&toml, "[camera]\neye = [0, 0, 1]\ntarget = [0, 0, 0]\n").unwrap();
    let out = luz(&[
        "render",
        toml.to_str().unwrap(),
        "-D",
        "a=1",
        "-o",
        png.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("-D"));
}

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

fn mean(scene: &Scene, spp: u32) -> [f64; 3] {
    let scene = Arc::new(scene.clone());
    let accel = Accel::build(&scene, BackendKind::Rust, &BuildOptions::default()).unwrap();
    let mut options = RenderOptions::from_scene(&scene);
    options.samples = 0..spp;
    let (film, _) = render_with(&scene, &accel, &options, &());
    let img = film.image();
    let n = img.pixels.len() as f64;
    let mut sum = [0.0; 3];
    for p in &img.pixels {
        for c in 0..3 {
            sum[c] += p[c] as f64 / n;
        }
    }
    sum
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

#[test]
fn ref_cycles_and_include_cycles_are_errors_not_overflows() {
    let err = ok_err(
        "cycle",
        r#"<bsdf type="twosided" id="a"><ref id="a"/></bsdf>
        <shape type="sphere"><ref id="a"/></shape>"#,
    );
    assert!(err.contains("nest deeper"), "{err}");
    let main = scene(r#"<include filename="s.xml"/>"#);
    let err = load(
        "include-cycle",
        &[("s.xml", &main)],
        &LoadOptions::default(),
    )
    .unwrap_err();
    assert!(err.message.contains("cycle"), "{err}");
    let err = ok_err(
        "dup",
        r#"<bsdf type="diffuse" id="x"/><bsdf type="diffuse" id="x"/>"#,
    );
    assert!(err.contains("given twice"), "{err}");
}

#[test]
fn conductors_and_rough_plastic_become_luz_models() {
    use luz::bsdf::{Bsdf, Distribution};
    let body = r#"<shape type="sphere"><bsdf type="roughconductor">
          <string name="material" value="Au"/><float name="alpha" value="0.2"/>
          <string name="distribution" value="ggx"/></bsdf></shape>
        <shape type="sphere"><bsdf type="conductor">
          <rgb name="eta" value="0.2, 0.9, 1.1"/><rgb name="k" value="3.9, 2.4, 2.1"/>
          <float name="ext_eta" value="2"/></bsdf></shape>
        <shape type="sphere"><bsdf type="roughplastic">
          <rgb name="diffuse_reflectance" value="0.1, 0.2, 0.3"/>
          <float name="int_ior" value="2"/><float name="alpha" value="0.05"/></bsdf></shape>
        <shape type="sphere"><bsdf type="roughconductor">
          <float name="alpha_u" value="0.1"/><float name="alpha_v" value="0.4"/></bsdf></shape>"#;
    let s = ok("models", &format!("{body}{LIGHT}"));
    let model = |i: usize| s.material_of(i as u32).bsdf.clone().expect("a model");
    let Bsdf::Conductor(gold) = model(0) else {
        panic!("{:?}", model(0))
    };
    let rough = gold.roughness.expect("rough");
    assert_eq!((rough.distribution, rough.alpha), (Distribution::Ggx, 0.2));
    assert!(
        close(gold.eta, Vec3::new(0.143036, 0.375307, 1.44205)),
        "{:?}",
        gold.eta
    );
    let Bsdf::Conductor(smooth) = model(1) else {
        panic!("{:?}", model(1))
    };
    assert!(smooth.roughness.is_none());
    assert!(
        close(smooth.eta, Vec3::new(0.1, 0.45, 0.55))
            && close(smooth.k, Vec3::new(1.95, 1.2, 1.05))
    );
    let Bsdf::RoughPlastic(plastic) = model(2) else {
        panic!("{:?}", model(2))
    };
    assert!(
        (plastic.eta - 2.0 / 1.000277).abs() < 1e-5,
        "{}",
        plastic.eta
    );
    assert_eq!(plastic.microfacet.distribution, Distribution::Beckmann);
    assert!(close(s.material_of(2).kd, Vec3::new(0.1, 0.2, 0.3)));
    let Bsdf::Conductor(aniso) = model(3) else {
        panic!("{:?}", model(3))
    };
    assert!((aniso.roughness.unwrap().alpha - 0.2).abs() < 1e-6);
    assert!(
        s.warnings.iter().any(|w| w.contains("isotropic")),
        "{:?}",
        s.warnings
    );
    assert_eq!(s.warnings.len(), 1, "{:?}", s.warnings);
}

#[test]
fn an_unknown_metal_or_distribution_is_an_error_at_its_line() {
    for (bad, what) in [
        (
            r#"<string name="material" value="Unobtainium"/>"#,
            "Unobtainium",
        ),
        (r#"<string name="distribution" value="phong"/>"#, "phong"),
    ] {
        let body =
            format!("<shape type=\"sphere\"><bsdf type=\"roughconductor\">\n{bad}</bsdf></shape>");
        let text = scene(&body);
        let line = 1 + text.lines().position(|l| l.contains(what)).unwrap();
        let err = load("bad-metal", &[("s.xml", &text)], &LoadOptions::default()).unwrap_err();
        assert_eq!(err.location.map(|l| l.0), Some(line), "{err}");
        assert!(err.message.contains(what), "{err}");
    }
}

/// Mitsuba's rectangle faces along the normal transform of +z; a mirroring
/// `to_world` must not turn an area light's emitting side away.
#[test]
fn a_mirrored_rectangle_faces_as_in_mitsuba() {
    for (scale, flip) in [
        ("1 1 1", false),
        ("-1 1 1", false),
        ("1 1 -1", false),
        ("-1 1 1", true),
    ] {
        let body = format!(
            r#"<shape type="rectangle"><transform name="to_world"><scale value="{scale}"/></transform>
               <boolean name="flip_normals" value="{flip}"/></shape>"#
        );
        let s = ok("mirrored", &body);
        let Geometry::Quad(q) = &s.shapes[0].geometry else {
            panic!("a quad")
        };
        let normal = q.e1.cross(q.e2).normalize();
        // The normal transform of +z under a diagonal scale keeps z's sign
        // of the z factor; flip_normals turns it.
        let z_sign: f32 = if scale.ends_with("-1") { -1.0 } else { 1.0 };
        let want = Vec3::Z * if flip { -z_sign } else { z_sign };
        assert!(close(normal, want), "scale {scale} flip {flip}: {normal}");
    }
}

#[test]
fn rough_and_thin_dielectrics_become_luz_models() {
    use luz::bsdf::{Bsdf, Distribution};
    let body = r#"<shape type="sphere"><bsdf type="roughdielectric">
          <string name="int_ior" value="diamond"/><float name="alpha" value="0.3"/></bsdf></shape>
        <shape type="sphere"><bsdf type="thindielectric">
          <float name="int_ior" value="1.5"/><float name="ext_ior" value="1"/></bsdf></shape>"#;
    let s = ok("dielectrics", &format!("{body}{LIGHT}"));
    let model = |i: u32| s.material_of(i).bsdf.clone().expect("a model");
    let Bsdf::RoughDielectric(rough) = model(0) else {
        panic!("{:?}", model(0))
    };
    assert!((rough.eta - 2.419 / 1.000277).abs() < 1e-4, "{}", rough.eta);
    assert_eq!(rough.microfacet.distribution, Distribution::Beckmann);
    let Bsdf::ThinDielectric(thin) = model(1) else {
        panic!("{:?}", model(1))
    };
    assert_eq!(thin.eta, 1.5);
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
}

#[test]
fn a_spot_light_sits_at_its_to_world_origin_and_aims_along_z() {
    let body = r#"<emitter type="spot">
            <transform name="to_world"><lookat origin="1, 4, 0" target="1, 0, 0" up="0, 0, 1"/></transform>
            <rgb name="intensity" value="2, 3, 4"/>
            <float name="cutoff_angle" value="30"/>
        </emitter>"#;
    let s = ok("spot", body);
    let light = &s.point_lights[0];
    let cone = light.spot.as_ref().expect("a spot cone");
    assert!(close(light.position, Vec3::new(1.0, 4.0, 0.0)), "{light:?}");
    assert!(
        close(light.intensity, Vec3::new(2.0, 3.0, 4.0)),
        "{light:?}"
    );
    // Mitsuba's default beam is three quarters of the cutoff: 22.5°.
    let off = |deg: f32| Vec3::new(deg.to_radians().sin(), -deg.to_radians().cos(), 0.0);
    assert_eq!(cone.falloff(off(22.0)), 1.0);
    assert!((cone.falloff(off(26.25)) - 0.5).abs() < 1e-5);
    assert_eq!(cone.falloff(off(30.5)), 0.0);
    assert_eq!(cone.falloff(-off(0.0)), 0.0, "it shines one way");
    let message = ok_err(
        "spot-beam",
        r#"<emitter type="spot"><float name="cutoff_angle" value="10"/><float name="beam_width" value="12"/></emitter>"#,
    );
    assert!(
        message.contains("s.xml:") && message.contains("`beam_width`"),
        "{message}"
    );
}

#[test]
fn a_mask_keeps_its_nested_bsdf_and_gains_an_opacity() {
    let body = r#"<bsdf type="mask" id="constant"><float name="opacity" value="0.3"/>
            <bsdf type="diffuse"><rgb name="reflectance" value="0.2, 0.4, 0.6"/></bsdf></bsdf>
        <bsdf type="mask" id="default"><bsdf type="roughplastic"/></bsdf>
        <bsdf type="mask" id="textured">
            <texture name="opacity" type="checkerboard"/><bsdf type="diffuse"/></bsdf>
        <emitter type="constant"/>
        <shape type="sphere"><ref id="constant"/></shape>
        <shape type="sphere"><ref id="default"/></shape>
        <shape type="rectangle"><ref id="textured"/></shape>
        <shape type="sphere"><ref id="textured"/></shape>"#;
    let s = ok("mask", body);
    // The one warning: a textured sphere's texture lies otherwise in luz.
    assert_eq!(s.warnings.len(), 1, "{:?}", s.warnings);
    assert!(
        s.warnings[0].contains("a textured sphere"),
        "{:?}",
        s.warnings
    );
    let material = |i: usize| &s.materials[s.shapes[i].material as usize];
    assert_eq!(material(0).opacity, Some(Opacity::Constant(0.3)));
    assert!(close(material(0).kd, Vec3::new(0.2, 0.4, 0.6)));
    // Mitsuba's default opacity is one half.
    assert_eq!(material(1).opacity, Some(Opacity::Constant(0.5)));
    assert!(material(1).bsdf.is_some(), "the nested rough plastic stays");
    assert!(matches!(material(2).opacity, Some(Opacity::Texture(_))));
    let message = ok_err(
        "mask-two",
        r#"<shape type="sphere"><bsdf type="mask"><bsdf type="diffuse"/><bsdf type="diffuse"/></bsdf></shape>"#,
    );
    assert!(
        message.contains("exactly one nested <bsdf>, found 2"),
        "{message}"
    );
}

fn image(scene: &Scene, spp: u32) -> luz::image::Image {
    let scene = Arc::new(scene.clone());
    let accel = Accel::build(&scene, BackendKind::Rust, &BuildOptions::default()).unwrap();
    let mut options = RenderOptions::from_scene(&scene);
    options.samples = 0..spp;
    render_with(&scene, &accel, &options, &()).0.image()
}

/// Mitsuba's reflecting BSDFs are black from behind unless `twosided`.
#[test]
fn a_bare_bsdf_is_one_sided_and_twosided_makes_it_two() {
    let sky = r#"<emitter type="constant"><rgb name="radiance" value="1, 1, 1"/></emitter>"#;
    for (flip, bsdf, want) in [
        (false, r#"<bsdf type="diffuse"/>"#, 0.5),
        (true, r#"<bsdf type="diffuse"/>"#, 0.0),
        (
            true,
            r#"<bsdf type="twosided"><bsdf type="diffuse"/></bsdf>"#,
            0.5,
        ),
        (true, r#"<bsdf type="roughplastic"/>"#, 0.0),
        (true, "", 0.0),
    ] {
        let body = format!(
            r#"{sky}<shape type="rectangle"><transform name="to_world"><scale value="3"/></transform>
               <boolean name="flip_normals" value="{flip}"/>{bsdf}</shape>"#
        );
        let m = mean(&ok("sides", &body), 64);
        // A grey diffuse under a white sky reflects 0.5 exactly in
        // expectation; 64 × 64 samples put the mean well within 0.02.
        assert!((m[1] - want).abs() < 0.02, "flip {flip} {bsdf}: {m:?}");
    }
}

/// A 1×2 image, red on top, blue below: Mitsuba reads its top row at v = 0,
/// which is the bottom edge of a rectangle and, since its OBJ reader turns
/// v over, the top edge of an OBJ quad whose `vt` put v = 0 at the bottom.
#[test]
fn textures_stand_the_way_mitsuba_stands_them() {
    let ppm = "P3\n1 2\n255\n255 0 0\n0 0 255\n";
    let obj = "v -3 -3 0\nv 3 -3 0\nv 3 3 0\nv -3 3 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/1 2/2 3/3 4/4\n";
    let sky = r#"<emitter type="constant"><rgb name="radiance" value="1, 1, 1"/></emitter>"#;
    let bsdf = r#"<bsdf type="diffuse"><texture name="reflectance" type="bitmap">
        <string name="filename" value="t.ppm"/></texture></bsdf>"#;
    for (shape, red_at_bottom) in [
        (
            r#"<shape type="rectangle"><transform name="to_world"><scale value="3"/></transform>"#,
            true,
        ),
        (
            r#"<shape type="obj"><string name="filename" value="q.obj"/>"#,
            false,
        ),
        // The same quad with its image from its own .mtl (`map_Kd`).
        (
            r#"<shape type="obj"><string name="filename" value="qm.obj"/>"#,
            false,
        ),
    ] {
        let bsdf = if shape.contains("qm.obj") { "" } else { bsdf };
        let xml = scene(&format!("{sky}{shape}{bsdf}</shape>"));
        let with_mtl = format!("mtllib q.mtl\nusemtl t\n{obj}");
        let files = [
            ("s.xml", xml.as_str()),
            ("t.ppm", ppm),
            ("q.obj", obj),
            ("qm.obj", &with_mtl),
            ("q.mtl", "newmtl t\nKd 1 1 1\nmap_Kd t.ppm\n"),
        ];
        let s = load("stand", &files, &LoadOptions::default()).unwrap();
        let img = image(&s, 4);
        let (top, bottom) = (img.pixels[0], img.pixels[img.pixels.len() - 1]);
        let (red, blue) = if red_at_bottom {
            (bottom, top)
        } else {
            (top, bottom)
        };
        assert!(red.x > 0.3 && red.z < 0.01, "{shape}: {red} should be red");
        assert!(
            blue.z > 0.3 && blue.x < 0.01,
            "{shape}: {blue} should be blue"
        );
    }
}
