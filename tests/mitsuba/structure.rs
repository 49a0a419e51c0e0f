//! The scene's structure: defaults, parameters, includes and references,
//! transforms, shapes, the sensor, upgrades of old files, and what is
//! warned about or refused.

use super::*;

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
        <string name="fov_axis" value="x"/><float name="focus_distance" value="3"/>
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
    // Mitsuba's pinhole ignores the focus distance too; a clipping plane,
    // which Mitsuba's uses, is warned about.
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    let clipped = text.replace(
        "<string name=\"fov_axis\"",
        "<float name=\"near_clip\" value=\"2\"/><string name=\"fov_axis\"",
    );
    let s = load("clip", &[("s.xml", &clipped)], &LoadOptions::default()).unwrap();
    assert!(
        s.warnings.len() == 1 && s.warnings[0].contains("near_clip"),
        "{:?}",
        s.warnings
    );
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

/// Mitsuba's own Cornell box names its meshes relative to the scene from an
/// included fragment, and refers to a top-level area emitter; `<path>` adds
/// a folder to look in.
#[test]
fn file_names_resolve_as_mitsuba_resolves_them() {
    let dir = temp_dir("resolver");
    for sub in ["fragments", "meshes", "common"] {
        std::fs::create_dir_all(dir.join(sub)).unwrap();
    }
    let quad = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n";
    std::fs::write(dir.join("meshes/quad.obj"), quad).unwrap();
    std::fs::write(dir.join("common/other.obj"), quad).unwrap();
    let fragment = r#"<scene version="3.0.0">
        <shape type="obj"><string name="filename" value="meshes/quad.obj"/><ref id="lamp"/></shape>
        <shape type="obj"><string name="filename" value="other.obj"/></shape></scene>"#;
    std::fs::write(dir.join("fragments/shapes.xml"), fragment).unwrap();
    let write_scene = |body: &str| {
        let path = dir.join("scene.xml");
        std::fs::write(&path, scene(body)).unwrap();
        load_with(&path, &LoadOptions::default())
    };
    let s = write_scene(
        r#"<path value="common"/>
        <emitter type="area" id="lamp"><rgb name="radiance" value="2, 2, 2"/></emitter>
        <include filename="fragments/shapes.xml"/>"#,
    )
    .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s.shapes.len(), 2);
    let emission = |i: usize| s.materials[s.shapes[i].material as usize].emission;
    assert!(close(emission(0), Vec3::splat(2.0)), "{:?}", emission(0));
    assert!(close(emission(1), Vec3::ZERO), "{:?}", emission(1));
    for file in ["meshes/quad.obj", "common/other.obj"] {
        assert!(
            s.files.iter().any(|f| f.ends_with(file)),
            "{file}: {:?}",
            s.files
        );
    }

    // Without the <path>, other.obj is found nowhere, and the message says
    // where luz looked.
    let err = write_scene(
        r#"<emitter type="area" id="lamp"><rgb name="radiance" value="2, 2, 2"/></emitter>
        <include filename="fragments/shapes.xml"/>"#,
    )
    .unwrap_err()
    .to_string();
    assert!(
        err.contains("shapes.xml:3:") && err.contains("other.obj") && err.contains("looked in"),
        "{err}"
    );
    let err = write_scene(r#"<path value="nowhere"/>"#)
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("scene.xml:") && err.contains("<path>") && err.contains("nowhere"),
        "{err}"
    );
    let err = write_scene(r#"<shape type="sphere"><path value="common"/></shape>"#)
        .unwrap_err()
        .to_string();
    assert!(err.contains("must be a child of <scene>"), "{err}");
}
