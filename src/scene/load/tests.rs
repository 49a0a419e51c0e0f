use super::*;
use crate::scene::Opacity;

const MINIMAL: &str = "[camera]\neye = [0, 1, 3]\ntarget = [0, 1, 0]\n";

fn err(text: &str) -> SceneError {
    load_str(text, Path::new("test.toml")).expect_err("must fail")
}

#[test]
fn minimal_scene_gets_defaults() {
    let s = load_str(MINIMAL, Path::new("m.toml")).unwrap();
    assert_eq!((s.camera.width, s.camera.height), (512, 512));
    assert_eq!(s.camera.fov_y, 40.0);
    assert_eq!(s.render, RenderSettings::default());
    assert!(s.shapes.is_empty() && s.lights.is_empty());
}

#[test]
fn unknown_key_names_line_column_and_suggests() {
    let e = err(&format!(
        "{MINIMAL}[[shapes]]\ntype = \"sphere\"\ncenter = [0,0,0]\nradus = 1\n"
    ));
    assert_eq!(e.location.map(|l| l.0), Some(7), "{e}");
    assert!(
        e.message.contains("radus") && e.message.contains("did you mean `radius`"),
        "{e}"
    );
}

#[test]
fn empty_keys_are_unknown_fields() {
    for text in ["\"\" = 1\n", "[camera]\n\"\" = \"\"\n"] {
        let e = err(text);
        assert!(e.message.contains("unknown field ``"), "{e}");
    }
}

#[test]
fn wrong_type_is_located() {
    let e = err("[camera]\neye = [0, 1, 3]\ntarget = \"up\"\n");
    assert_eq!(e.location.map(|l| l.0), Some(3), "{e}");
}

#[test]
fn semantic_errors_name_the_field_line() {
    let cases = [
        (
            "[[shapes]]\ntype = \"sphere\"\ncenter = [0,0,0]\nradius = -1\n",
            7,
            "radius",
        ),
        (
            "[[shapes]]\ntype = \"sphere\"\ncenter = [0,nan,0]\nradius = 1\n",
            6,
            "center",
        ),
        ("[materials.m]\nkd = 0.6\nks = 0.5\n", 6, "ks"),
        (
            "[[shapes]]\ntype = \"cuboid\"\nmin = [0,0,0]\nmax = [1,1,1]\nmaterial = \"nope\"\n",
            8,
            "material",
        ),
        (
            "[[lights]]\ntype = \"point\"\nposition = [0,0,0]\nintensity = inf\n",
            7,
            "intensity",
        ),
    ];
    for (body, line, field) in cases {
        let e = err(&format!("{MINIMAL}{body}"));
        assert_eq!(e.location.map(|l| l.0), Some(line), "{e}");
        assert!(e.message.contains(field), "{e}");
    }
}

#[test]
fn the_render_table_names_the_sampler() {
    for kind in SamplerKind::ALL {
        let text = format!("{MINIMAL}[render]\nsampler = \"{}\"\n", kind.name());
        let s = load_str(&text, Path::new("s.toml")).unwrap();
        assert_eq!(s.render.sampler, kind);
    }
    let e = err(&format!(
        "{MINIMAL}[render]\nspp = 4\nsampler = \"halton\"\n"
    ));
    assert_eq!(e.location.map(|l| l.0), Some(6), "{e}");
    assert!(
        e.message
            .contains("unknown sampler `halton` (known: independent, sobol)"),
        "{e}"
    );
}

#[test]
fn missing_mesh_file_says_where_it_looked() {
    let e = err(&format!(
        "{MINIMAL}[[shapes]]\ntype = \"mesh\"\nfile = \"nothing-here.ply\"\n"
    ));
    assert!(
        e.message.contains("nothing-here.ply") && e.message.contains("looked for"),
        "{e}"
    );
    assert_eq!(e.location.map(|l| l.0), Some(6));
}

#[test]
fn collinear_triangle_is_rejected() {
    let e = err(&format!(
        "{MINIMAL}[[shapes]]\ntype = \"triangle\"\nvertices = [[0,0,0],[1,1,1],[2,2,2]]\n"
    ));
    assert_eq!(e.location.map(|l| l.0), Some(6), "{e}");
    assert!(
        e.message.contains("`vertices`: the triangle has no area"),
        "{e}"
    );
}

#[test]
fn quad_must_be_a_parallelogram() {
    let e = err(&format!(
        "{MINIMAL}[[shapes]]\ntype = \"quad\"\ncorners = [[0,0,0],[1,0,0],[1,1,0.5],[0,1,0]]\n"
    ));
    assert!(e.message.contains("parallelogram"), "{e}");
}

#[test]
fn huge_and_tiny_directions_are_directions() {
    let s = load_str(
        "[camera]\neye = [0, 1, 3]\ntarget = [0, 1, 0]\nup = [0, 1e-30, 0]\n\
         [[shapes]]\ntype = \"plane\"\npoint = [0, 0, 0]\nnormal = [0, 3e38, 3e38]\n\
         [[shapes]]\ntype = \"plane\"\npoint = [0, 0, 0]\nnormal = [1e-40, 0, 0]\n",
        Path::new("d.toml"),
    )
    .unwrap();
    let b = s.camera.basis();
    assert!(b.up.is_finite() && b.right.is_finite() && b.up.y > 0.0);
    for (shape, n) in s
        .shapes
        .iter()
        .zip([Vec3::new(0.0, 1.0, 1.0).normalize(), Vec3::X])
    {
        let Geometry::Plane(p) = &shape.geometry else {
            panic!("a plane")
        };
        assert!((p.normal - n).length() < 1e-6, "{}", p.normal);
    }
}

#[test]
fn tables_are_never_read_by_position() {
    let e =
        err("environment = [0.25, 99, \"junk\"]\n[camera]\neye = [0, 1, 3]\ntarget = [0, 1, 0]\n");
    assert!(
        e.message.contains("`environment`") && e.message.contains("a table"),
        "{e}"
    );
    assert_eq!(e.location.map(|l| l.0), Some(1), "{e}");
    let e = err("camera = [[0, 1, 3], [0, 1, 0]]\n");
    assert!(
        e.message.contains("`camera`") && e.message.contains("a table"),
        "{e}"
    );
    // Inline tables are tables.
    load_str(
        "camera = { eye = [0, 1, 3], target = [0, 1, 0] }\nenvironment = { radiance = 0.5 }\n",
        Path::new("t.toml"),
    )
    .unwrap();
}

#[test]
fn long_values_are_echoed_short() {
    let long = "y".repeat(1 << 20);
    for text in [
        format!("{MINIMAL}{long} = 1\n"),
        format!("{MINIMAL}fov = \"{long}\"\n"),
        format!("{MINIMAL}[[shapes]]\ntype = \"{long}\"\n"),
    ] {
        let e = err(&text).to_string();
        assert!(e.len() < 1024, "{} bytes: {}", e.len(), &e[..1024]);
    }
}

#[test]
fn edit_distance_counts_edits() {
    assert_eq!(edit_distance("radus", "radius"), 1);
    assert_eq!(edit_distance("", "abc"), 3);
    assert_eq!(edit_distance("kitten", "sitting"), 3);
}

#[test]
fn conductor_and_roughplastic_materials() {
    use crate::bsdf::{Bsdf, Distribution};
    let text = format!(
        "{MINIMAL}[materials.gold]\ntype = \"conductor\"\neta = [0.14, 0.37, 1.44]\nk = [3.98, 2.38, 1.60]\nroughness = 0.2\ndistribution = \"beckmann\"\n\
         [materials.mirror]\ntype = \"conductor\"\n\
         [materials.coat]\ntype = \"roughplastic\"\nkd = [0.1, 0.2, 0.6]\nior = 1.6\n\
         [materials.frost]\ntype = \"dielectric\"\nroughness = 0.3\nkt = 0.9\n"
    );
    let s = load_str(&text, Path::new("m.toml")).unwrap();
    let by_name = |n: &str| s.materials.iter().find(|m| m.name == n).unwrap();
    let Some(Bsdf::Conductor(gold)) = &by_name("gold").bsdf else {
        panic!()
    };
    let rough = gold.roughness.unwrap();
    assert_eq!(
        (rough.distribution, rough.alpha),
        (Distribution::Beckmann, 0.2)
    );
    let Some(Bsdf::Conductor(mirror)) = &by_name("mirror").bsdf else {
        panic!()
    };
    assert_eq!(
        (mirror.eta, mirror.k, mirror.roughness),
        (Rgb::ZERO, Rgb::ONE, None)
    );
    let Some(Bsdf::RoughPlastic(coat)) = &by_name("coat").bsdf else {
        panic!()
    };
    assert_eq!((coat.eta, coat.microfacet.alpha), (1.6, 0.1));
    assert_eq!(by_name("coat").kd, Rgb::new(0.1, 0.2, 0.6));
    let Some(Bsdf::RoughDielectric(frost)) = &by_name("frost").bsdf else {
        panic!()
    };
    assert_eq!(
        (frost.eta, frost.tint_t, frost.microfacet.alpha),
        (1.5, Rgb::splat(0.9), 0.3)
    );
    // Without a roughness, a dielectric stays the smooth Fresnel glass.
    let smooth = format!("{MINIMAL}[materials.g]\ntype = \"dielectric\"\n");
    let s = load_str(&smooth, Path::new("m.toml")).unwrap();
    assert!(s
        .materials
        .iter()
        .any(|m| m.name == "g" && m.dielectric && m.bsdf.is_none()));
}

#[test]
fn model_fields_are_checked_where_they_are_written() {
    for (body, line, field) in [
        ("type = \"conductor\"\nkd = 0.5\n", 6, "kd"),
        ("type = \"roughplastic\"\neta = 1.5\n", 6, "eta"),
        ("kd = 0.5\nroughness = 0.1\n", 6, "roughness"),
        ("type = \"conductor\"\nroughness = -1\n", 6, "roughness"),
        (
            "type = \"conductor\"\nroughness = 0.1\ndistribution = \"phong\"\n",
            7,
            "distribution",
        ),
        ("type = \"roughplastic\"\nior = 1\n", 6, "ior"),
        (
            "type = \"dielectric\"\nroughness = 0.1\nkd = 0.5\n",
            7,
            "kd",
        ),
    ] {
        let e = err(&format!("{MINIMAL}[materials.m]\n{body}"));
        assert!(e.message.contains(field), "{body}: {e}");
        assert_eq!(e.location.map(|l| l.0), Some(line), "{body}: {e}");
    }
}

#[test]
fn environment_maps_and_their_errors() {
    let dir = std::env::temp_dir().join(format!("luz-envmap-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mut ppm = b"P6\n4 2\n255\n".to_vec();
    ppm.extend((0..8).flat_map(|i| [i * 30, 255 - i * 30, 128]));
    std::fs::write(dir.join("sky.ppm"), ppm).unwrap();
    let scene = dir.join("s.toml");
    let text =
        format!("{MINIMAL}[environment]\nmap = \"sky.ppm\"\nscale = 2\nrotate = [0, 90, 0]\n");
    let s = load_str(&text, &scene).unwrap();
    let Some(crate::scene::Environment::Map(m)) = &s.environment else {
        panic!("a map")
    };
    assert_eq!((m.width, m.height, m.scale), (4, 2, 2.0));
    assert!(
        (m.to_world * Vec3::X - -Vec3::Z).length() < 1e-6,
        "{}",
        m.to_world
    );
    for (body, field) in [
        ("map = \"missing.exr\"\n", "map"),
        ("map = \"sky.ppm\"\nradiance = 1\n", "radiance"),
        ("radiance = 1\nscale = 2\n", "scale"),
        ("map = \"sky.ppm\"\nscale = -1\n", "scale"),
    ] {
        let e = load_str(&format!("{MINIMAL}[environment]\n{body}"), &scene).expect_err(body);
        assert!(e.message.contains(field), "{body}: {e}");
        assert!(e.location.is_some(), "{body}: {e}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn spot_lights_and_their_errors() {
    let head = "[camera]\neye = [0, 0, 5]\ntarget = [0, 0, 0]\n[[lights]]\nposition = [0, 2, 0]\nintensity = 3\n";
    let scene = load_str(
        &format!("{head}type = \"spot\"\ntarget = [0, 0, 0]\ncutoff_angle = 30\n"),
        Path::new("s.toml"),
    )
    .unwrap();
    let cone = scene.point_lights[0].spot.as_ref().expect("a spot cone");
    // Straight down is the axis, 25° off it is past the 22.5° beam, 31° off
    // is past the cutoff.
    let off = |deg: f32| Vec3::new(deg.to_radians().sin(), -deg.to_radians().cos(), 0.0);
    assert_eq!(cone.falloff(off(0.0)), 1.0);
    assert!((cone.falloff(off(25.0)) - 5.0 / 7.5).abs() < 1e-5);
    assert_eq!(cone.falloff(off(31.0)), 0.0);
    for (tail, field, line, says) in [
        ("type = \"spot\"\n", "type", 7, "needs a `target`"),
        (
            "type = \"spot\"\ntarget = [0, 2, 0]\n",
            "target",
            8,
            "must differ from `position`",
        ),
        (
            "type = \"spot\"\ntarget = [0, 0, 0]\ncutoff_angle = 0\n",
            "cutoff_angle",
            9,
            "(0, 180]",
        ),
        (
            "type = \"spot\"\ntarget = [0, 0, 0]\ncutoff_angle = 30\nbeam_width = 31\n",
            "beam_width",
            10,
            "[0, cutoff_angle = 30]",
        ),
        (
            "type = \"point\"\ncutoff_angle = 30\n",
            "cutoff_angle",
            8,
            "only a `spot` light",
        ),
        ("type = \"sun\"\n", "type", 7, "`point` or `spot`"),
    ] {
        let message = err(&format!("{head}{tail}")).to_string();
        assert!(message.contains(&format!("`{field}`")), "{message}");
        assert!(message.contains(says), "{message}");
        assert!(message.contains(&format!("test.toml:{line}:")), "{message}");
    }
}

#[test]
fn opacity_is_a_number_or_a_texture() {
    let head = "[camera]\neye = [0, 0, 5]\ntarget = [0, 0, 0]\n[textures.leaf]\nchecker = [0, 1]\n[materials.m]\n";
    let scene = |tail: &str| load_str(&format!("{head}{tail}"), Path::new("o.toml"));
    let half = scene("opacity = 0.5\n").unwrap();
    assert_eq!(half.materials[0].opacity, Some(Opacity::Constant(0.5)));
    let textured = scene("type = \"roughplastic\"\nopacity = \"leaf\"\n").unwrap();
    assert_eq!(textured.materials[0].opacity, Some(Opacity::Texture(0)));
    assert_eq!(scene("kd = 0.3\n").unwrap().materials[0].opacity, None);
    for (tail, says) in [
        ("opacity = 1.5\n", "must be in [0, 1]"),
        ("opacity = -0.1\n", "must be in [0, 1]"),
        ("opacity = \"fern\"\n", "no texture named `fern`"),
    ] {
        let message = err(&format!("{head}{tail}")).to_string();
        assert!(
            message.contains("test.toml:7:") && message.contains("`opacity`"),
            "{message}"
        );
        assert!(message.contains(says), "{message}");
    }
}

/// A mesh placed beyond ±1e12 is refused, naming the field that put it
/// there and its first vertex outside; the same mesh in range loads.
#[test]
fn mesh_vertices_beyond_the_bounds_name_the_first() {
    let dir = std::env::temp_dir().join(format!("luz-mesh-bounds-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let ply = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
               property float z\nelement face 1\nproperty list uchar int vertex_indices\n\
               end_header\n0 0 0\n1e11 0 0\n0 1 0\n3 0 1 2\n";
    std::fs::write(dir.join("t.ply"), ply).unwrap();
    let scene = dir.join("s.toml");
    let mesh =
        |extra: &str| format!("{MINIMAL}[[shapes]]\ntype = \"mesh\"\nfile = \"t.ply\"\n{extra}");
    let loaded = load_str(&mesh("scale = 10\n"), &scene).unwrap();
    assert_eq!(loaded.shapes.len(), 1);
    let e = load_str(&mesh("scale = 11\n"), &scene).expect_err("beyond");
    assert!(
        e.message.contains("`scale`")
            && e.message.contains("vertex 1 of the mesh once transformed"),
        "{e}"
    );
    let e = load_str(&mesh("translate = [9.5e11, 0, 0]\n"), &scene).expect_err("beyond");
    assert!(
        e.message.contains("`translate`")
            && e.message.contains("vertex 1 of the mesh once transformed"),
        "{e}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}
