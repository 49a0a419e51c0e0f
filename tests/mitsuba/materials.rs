//! Mitsuba's BSDFs, lights, masks and textures as luz models them.

use super::*;

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
