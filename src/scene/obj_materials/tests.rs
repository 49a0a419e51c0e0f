//! OBJ files with their own materials, read alone and through the TOML
//! and Mitsuba loaders; meshes of no area; scenes without light.

use super::*;
use crate::bsdf::Bsdf;
use crate::geometry::Geometry;
use crate::scene::mesh_io::read_mesh;
use crate::scene::{load_with, LoadOptions, Scene, SceneError, UNLIT_WARNING};

/// A fresh folder holding `files` (name, contents).
fn folder(test: &str, files: &[(&str, &[u8])]) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("luz-obj-mtl-{}-{test}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    for (name, data) in files {
        std::fs::write(dir.join(name), data).unwrap();
    }
    dir
}

/// Five quads, each with texture coordinates: one before any `usemtl`,
/// then red, glossy, lamp, wood (textured), over (Kd past 1) and ghost
/// (in no library).
const OBJ: &str = "mtllib m.mtl\nvt 0 0\nvt 1 0\nvt 1 1\n\
    v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1/1 2/2 3/3\n\
    usemtl red\nf 1/1 2/2 3/3\nusemtl glossy\nf 1/1 2/2 3/3\nusemtl lamp\nf 1/1 2/2 3/3\n\
    usemtl wood\nf 1/1 2/2 3/3\nusemtl over\nf 1/1 2/2 3/3\nusemtl ghost\nf 1/1 2/2 3/3\n";

const MTL: &str = "newmtl red\nKd 0.6 0.1 0.1\nKs 0 0 0\nNs 10\n\
    newmtl glossy\nKd 0.5\nKs 0.3 0.3 0.2\nNs 98\n\
    newmtl lamp\nKe 17 12 4\n\
    newmtl wood\nKd 0.2\nmap_Kd tex/w.ppm\n\
    newmtl over\nKd 1.5 0.75 0.3\n";

/// A 2×1 texture, red and green (sRGB maxima: linear 1).
const PPM: &[u8] = b"P3\n2 1\n255\n255 0 0 0 255 0\n";

fn materials_folder(test: &str) -> PathBuf {
    let dir = folder(
        test,
        &[("m.obj", OBJ.as_bytes()), ("m.mtl", MTL.as_bytes())],
    );
    std::fs::create_dir_all(dir.join("tex")).unwrap();
    std::fs::write(dir.join("tex/w.ppm"), PPM).unwrap();
    dir
}

#[test]
fn mtl_materials_become_luz_materials() {
    let dir = materials_folder("map");
    let obj = dir.join("m.obj");
    let read = read_mesh(&obj).unwrap();
    let out = obj_parts(&obj, read.mesh, &read.groups).unwrap();
    let names: Vec<&str> = out
        .parts
        .iter()
        .map(|(_, m)| out.materials[*m as usize].name.as_str())
        .collect();
    let d = "(default)";
    assert_eq!(names, [d, "red", "glossy", "lamp", "wood", "over", d]);
    assert!(out.parts.iter().all(|(mesh, _)| mesh.indices.len() == 1));
    let material = |k: usize| &out.materials[out.parts[k].1 as usize];
    assert_eq!(
        *material(0),
        Material {
            name: d.into(),
            ..Material::default()
        }
    );
    let red = material(1);
    assert_eq!(
        (red.kd, red.bsdf.is_none()),
        (Rgb::new(0.6, 0.1, 0.1), true)
    );
    let Some(Bsdf::RoughPlastic(p)) = &material(2).bsdf else {
        panic!("glossy: {:?}", material(2));
    };
    assert_eq!(p.microfacet.distribution, Distribution::Beckmann);
    assert!((p.microfacet.alpha - 0.02f32.sqrt()).abs() < 1e-6);
    assert_eq!(
        (p.tint, p.eta, material(2).kd),
        (Rgb::new(0.3, 0.3, 0.2), 1.49, Rgb::splat(0.5))
    );
    let lamp = material(3);
    assert_eq!(
        (lamp.emission, lamp.kd),
        (Rgb::new(17.0, 12.0, 4.0), Rgb::ZERO)
    );
    let wood = material(4);
    assert_eq!((wood.kd, wood.texture), (Rgb::ONE, Some(0)));
    let Texture::Image { width, texels, .. } = &out.textures[0] else {
        panic!("not an image");
    };
    assert_eq!((*width, texels[0], texels[1]), (2, Rgb::X, Rgb::Y));
    assert_eq!(material(5).kd, Rgb::new(1.0, 0.5, 0.2));
    assert_eq!(out.files, [dir.join("m.mtl"), dir.join("tex/w.ppm")]);
    let warned = |needles: &[&str]| {
        out.warnings
            .iter()
            .any(|w| needles.iter().all(|n| w.contains(n)))
    };
    assert!(
        warned(&["m.obj", "`ghost` (line 19)", "default grey"]),
        "{:#?}",
        out.warnings
    );
    assert!(warned(&[
        "m.mtl:14: material `over`",
        "`Kd`",
        "scaled down"
    ]));
    assert!(warned(&["`glossy`", "rough plastic"]));
    assert_eq!(out.warnings.len(), 3, "{:#?}", out.warnings);
}

#[test]
fn what_cannot_be_read_is_warned_about() {
    let obj = "mtllib gone.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nusemtl a\nf 1 2 3\n";
    let dir = folder("missing", &[("m.obj", obj.as_bytes())]);
    let path = dir.join("m.obj");
    let read = read_mesh(&path).unwrap();
    let out = obj_parts(&path, read.mesh, &read.groups).unwrap();
    assert_eq!(
        out.materials,
        [Material {
            name: "(default)".into(),
            ..Material::default()
        }]
    );
    assert_eq!(out.warnings.len(), 1, "{:?}", out.warnings);
    assert!(
        out.warnings[0].contains("m.obj:1: `mtllib`: cannot read"),
        "{:?}",
        out.warnings
    );
    // A texture that is not there, and one on faces without uvs.
    let mtl = "newmtl a\nKd 0.25\nmap_Kd nope.png\n";
    let dir = folder(
        "no-texture",
        &[("m.obj", obj.as_bytes()), ("gone.mtl", mtl.as_bytes())],
    );
    let path = dir.join("m.obj");
    let read = read_mesh(&path).unwrap();
    let out = obj_parts(&path, read.mesh, &read.groups).unwrap();
    assert_eq!(
        (out.materials[0].kd, out.materials[0].texture),
        (Rgb::splat(0.25), None)
    );
    assert!(
        out.warnings[0].contains("gone.mtl:3: `map_Kd` `nope.png`"),
        "{:?}",
        out.warnings
    );
    assert!(
        out.warnings[0].ends_with("`Kd` used instead"),
        "{:?}",
        out.warnings
    );
    // Without `mtllib`.
    let dir = folder("no-library", &[("m.obj", &obj.as_bytes()[16..])]);
    let path = dir.join("m.obj");
    let read = read_mesh(&path).unwrap();
    let out = obj_parts(&path, read.mesh, &read.groups).unwrap();
    assert!(
        out.warnings[0].contains("m.obj:4: faces ask for materials"),
        "{:?}",
        out.warnings
    );
}

#[test]
fn one_mtllib_may_name_several_libraries_or_none() {
    let obj = "mtllib a.mtl b.mtl\nmtllib\nv 0 0 0\nv 1 0 0\nv 1 1 0\n\
               usemtl x\nf 1 2 3\nusemtl y\nf 1 2 3\n";
    let files: [(&str, &[u8]); 3] = [
        ("m.obj", obj.as_bytes()),
        ("a.mtl", b"newmtl x\nKd 0.1\n"),
        ("b.mtl", b"newmtl y\nKd 0.2\n"),
    ];
    let dir = folder("two-libraries", &files);
    let path = dir.join("m.obj");
    let read = read_mesh(&path).unwrap();
    let out = obj_parts(&path, read.mesh, &read.groups).unwrap();
    let kd: Vec<Rgb> = out
        .parts
        .iter()
        .map(|(_, m)| out.materials[*m as usize].kd)
        .collect();
    assert_eq!(kd, [Rgb::splat(0.1), Rgb::splat(0.2)]);
    assert_eq!(out.warnings.len(), 1, "{:?}", out.warnings);
    assert!(
        out.warnings[0].ends_with("m.obj:2: `mtllib` names no file"),
        "{:?}",
        out.warnings
    );
}

const CAMERA: &str = "[camera]\neye = [0, 0, 5]\ntarget = [0, 0, 0]\nresolution = [8, 8]\n";

fn load(dir: &Path, name: &str, text: &str, strict: bool) -> Result<Scene, SceneError> {
    std::fs::write(dir.join(name), text).unwrap();
    let options = LoadOptions {
        strict,
        ..LoadOptions::default()
    };
    load_with(&dir.join(name), &options)
}

#[test]
fn a_toml_mesh_without_material_takes_its_own() {
    let dir = materials_folder("toml");
    let mesh = "[[shapes]]\ntype = \"mesh\"\nfile = \"m.obj\"\n";
    let s = load(&dir, "s.toml", &format!("{CAMERA}{mesh}"), false).unwrap();
    assert_eq!(s.shapes.len(), 7);
    let lamp = &s.shapes[3];
    assert_eq!(s.materials[lamp.material as usize].name, "lamp");
    assert!(lamp.nee && s.lights.is_sampled(3) && s.has_light());
    assert!(s.shapes.iter().filter(|s| s.nee).count() == 1);
    let wood = &s.materials[s.shapes[4].material as usize];
    assert!(matches!(
        s.textures[wood.texture.unwrap() as usize],
        Texture::Image { .. }
    ));
    assert!(s.files.contains(&dir.join("m.mtl")) && s.files.contains(&dir.join("tex/w.ppm")));
    assert!(
        !s.warnings.iter().any(|w| w.contains("no light")),
        "{:?}",
        s.warnings
    );
    // Not sampled when asked so; a scene material wins for every face.
    let s = load(
        &dir,
        "s.toml",
        &format!("{CAMERA}{mesh}nee = false\n"),
        false,
    )
    .unwrap();
    assert!(!s.shapes[3].nee && s.lights.is_empty() && s.has_light());
    let grey = format!("{CAMERA}[materials.g]\nkd = 0.3\n{mesh}material = \"g\"\n");
    let s = load(&dir, "s.toml", &grey, false).unwrap();
    assert_eq!(s.shapes.len(), 1);
    assert_eq!(s.warnings.len(), 2, "{:?}", s.warnings);
    assert!(
        s.warnings[0].contains("(`usemtl`, 6) are not used"),
        "{:?}",
        s.warnings
    );
    assert_eq!(s.warnings[1], UNLIT_WARNING);
    let e = load(&dir, "s.toml", &grey, true).unwrap_err();
    assert!(e.message.contains("are not used"), "{e}");
}

#[test]
fn a_bad_mtl_value_is_an_error_at_its_line() {
    let dir = materials_folder("bad-value");
    std::fs::write(dir.join("m.mtl"), "newmtl red\nKd 0.6 0,1 0.1\n").unwrap();
    let mesh = "[[shapes]]\ntype = \"mesh\"\nfile = \"m.obj\"\n";
    let e = load(&dir, "s.toml", &format!("{CAMERA}{mesh}"), false).unwrap_err();
    assert_eq!(e.location, Some((7, 1)), "{e}");
    let mtl = dir.join("m.mtl").display().to_string();
    let want = format!("{mtl}:2:8: `Kd`: expected a number, found `0,1`");
    assert!(e.message.ends_with(&want), "{e}");
}

#[test]
fn a_mitsuba_obj_without_bsdf_takes_its_own() {
    let dir = materials_folder("xml");
    let sensor = "<sensor type=\"perspective\"><transform name=\"to_world\">\
        <lookat origin=\"0,0,5\" target=\"0,0,0\" up=\"0,1,0\"/></transform></sensor>";
    let shape = "<shape type=\"obj\"><string name=\"filename\" value=\"m.obj\"/></shape>";
    let xml = format!("<scene version=\"3.0.0\">{sensor}{shape}</scene>");
    let s = load(&dir, "s.xml", &xml, false).unwrap();
    assert_eq!(s.shapes.len(), 7);
    assert!(s.shapes[3].nee && s.lights.is_sampled(3));
    assert_eq!(s.materials[s.shapes[2].material as usize].name, "glossy");
    assert!(s
        .warnings
        .iter()
        .all(|w| w.starts_with(&dir.join("s.xml").display().to_string())));
    assert_eq!(s.warnings.len(), 3, "{:#?}", s.warnings);
    // A BSDF wins; with it, nothing emits.
    let grey = shape.replace("</shape>", "<bsdf type=\"diffuse\"/></shape>");
    let xml = format!("<scene version=\"3.0.0\">{sensor}{grey}</scene>");
    let s = load(&dir, "s.xml", &xml, false).unwrap();
    assert_eq!(s.shapes.len(), 1);
    assert!(s
        .warnings
        .iter()
        .any(|w| w.contains("<bsdf> applies to every face")));
    assert!(
        s.warnings.last().unwrap().ends_with(UNLIT_WARNING),
        "{:?}",
        s.warnings
    );
    let e = load(&dir, "s.xml", &xml, true).unwrap_err();
    assert!(e.message.contains("--strict"), "{e}");
}

/// Two files of degenerate triangles only, and a mesh its scale flattens.
#[test]
fn meshes_of_no_area_are_left_out_with_one_warning() {
    let flat = "v 0 0 0\nv 1 1 1\nv 2 2 2\nf 1 2 3\n";
    let ply = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
               property float z\nelement face 1\nproperty list uchar int vertex_indices\n\
               end_header\n0 0 0\n1 1 1\n2 2 2\n3 0 1 2\n";
    let upright = "v 0 0 0\nv 1 0 1\nv 0 0 1\nf 1 2 3\n";
    let good = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    let files: [(&str, &[u8]); 4] = [
        ("flat.obj", flat.as_bytes()),
        ("flat.ply", ply.as_bytes()),
        ("upright.obj", upright.as_bytes()),
        ("good.obj", good.as_bytes()),
    ];
    let dir = folder("no-area", &files);
    let mesh = |file: &str| format!("[[shapes]]\ntype = \"mesh\"\nfile = \"{file}\"\n");
    let squash = "scale = [1, 1e-30, 1e-30]\n";
    let text = format!(
        "{CAMERA}[[lights]]\ntype = \"point\"\nposition = [0, 0, 3]\nintensity = 1\n{}{}{}{squash}{}",
        mesh("flat.obj"),
        mesh("flat.ply"),
        mesh("upright.obj"),
        mesh("good.obj")
    );
    let s = load(&dir, "s.toml", &text, false).unwrap();
    assert_eq!(s.shapes.len(), 1);
    assert!(matches!(&s.shapes[0].geometry, Geometry::Mesh(m) if m.indices.len() == 1));
    assert_eq!(s.warnings.len(), 1, "{:?}", s.warnings);
    let w = &s.warnings[0];
    assert!(
        w.starts_with("left out 3 meshes with no triangle of any area"),
        "{w}"
    );
    for name in ["flat.obj", "flat.ply", "upright.obj"] {
        assert!(w.contains(name), "{w}");
    }
    // The same through Mitsuba XML, scaled by `to_world`.
    let shape = |file: &str, inner: &str| {
        format!(
            "<shape type=\"{}\"><string name=\"filename\" value=\"{file}\"/>{inner}</shape>",
            &file[file.len() - 3..]
        )
    };
    let squash = "<transform name=\"to_world\"><scale value=\"1, 1e-30, 1e-30\"/></transform>";
    let xml = format!(
        "<scene version=\"3.0.0\"><sensor type=\"perspective\"/>{}{}{}{}\
         <emitter type=\"point\"><point name=\"position\" value=\"0,0,3\"/></emitter></scene>",
        shape("flat.obj", "<bsdf type=\"diffuse\"/>"),
        shape("flat.ply", ""),
        shape("upright.obj", squash),
        shape("good.obj", "")
    );
    let s = load(&dir, "s.xml", &xml, false).unwrap();
    assert_eq!(s.shapes.len(), 1);
    assert_eq!(s.warnings.len(), 1, "{:?}", s.warnings);
    assert!(
        s.warnings[0].contains("left out 3 meshes"),
        "{:?}",
        s.warnings
    );
}

#[test]
fn a_scene_without_light_is_warned_about() {
    let dir = folder("unlit", &[]);
    let sphere = "[[shapes]]\ntype = \"sphere\"\ncenter = [0, 0, 0]\nradius = 1\n";
    let s = load(&dir, "s.toml", &format!("{CAMERA}{sphere}"), false).unwrap();
    assert_eq!(s.warnings, [UNLIT_WARNING]);
    let lights = [
        "[[lights]]\ntype = \"point\"\nposition = [0, 0, 3]\nintensity = 1\n",
        "[environment]\nradiance = 0.5\n",
        "[materials.l]\nemission = 1\n[[shapes]]\ntype = \"sphere\"\ncenter = [0, 3, 0]\nradius = 1\nmaterial = \"l\"\n",
    ];
    for light in lights {
        let s = load(&dir, "s.toml", &format!("{CAMERA}{sphere}{light}"), false).unwrap();
        assert!(s.warnings.is_empty(), "{light}: {:?}", s.warnings);
    }
    // Lights that emit nothing are no light.
    let dark = "[[lights]]\ntype = \"point\"\nposition = [0, 0, 3]\nintensity = 0\n\
                [environment]\nradiance = 0\n";
    let s = load(&dir, "s.toml", &format!("{CAMERA}{sphere}{dark}"), false).unwrap();
    assert_eq!(s.warnings, [UNLIT_WARNING]);
}
