//! `<sensor>` (with its `<film>` and `<sampler>`) to luz's camera and
//! sample count, and `<integrator>` to its depth and Russian roulette.

use super::props::{Ids, Props};
use super::xml::Elem;
use super::Problems;
use crate::geometry::within_bounds;
use crate::render::film::check_resolution;
use crate::scene::{Camera, FovAxis, RenderSettings, SceneError};
use glam::{DMat4, DVec3};

/// Mitsuba's `max_depth = -1` (unbounded), as luz counts: deep enough that
/// Russian roulette, not the bound, ends paths.
pub(super) const UNBOUNDED_DEPTH: u32 = 1024;

/// What the sensor sets: the camera, and the sampler's count and seed.
pub(super) struct Sensor {
    pub camera: Camera,
    pub spp: Option<u32>,
    pub seed: Option<u64>,
}

pub(super) fn sensor(e: &Elem, ids: &Ids, problems: &mut Problems) -> Result<Sensor, SceneError> {
    let props = Props::new(e, ids);
    match e.kind() {
        "perspective" => {}
        "thinlens" => problems.warn(
            &e.loc,
            "<sensor type=\"thinlens\">: luz has a pinhole camera; the depth of field is left out",
        )?,
        other => problems.warn(
            &e.loc,
            format!("<sensor type=\"{other}\">: luz has only a perspective pinhole camera; substituted one"),
        )?,
    }
    let to_world = props.transform("to_world")?.unwrap_or(DMat4::IDENTITY);
    let (width, height) = film(&props, ids, problems)?;
    let fov_x = match (props.float("fov")?, props.string("focal_length")?) {
        (Some(fov), _) => fov,
        (None, Some(f)) => focal_length_fov(e, f)?,
        (None, None) => focal_length_fov(e, "50mm")?,
    };
    let axis = props.string("fov_axis")?.unwrap_or("x");
    if !(fov_x > 0.0 && fov_x < 180.0) {
        return Err(e
            .loc
            .error(format!("`fov`: must be in (0, 180) degrees, got {fov_x}")));
    }
    let fov_axis = FovAxis::parse(axis).ok_or_else(|| {
        e.loc.error(format!(
            "`fov_axis`: unknown axis {:?} (known: x, y, diagonal, smaller, larger)",
            axis
        ))
    })?;
    let fov_y = fov_axis.vertical_fov(fov_x, width, height);
    let mut camera = camera(e, &to_world, fov_y as f32, width, height, problems)?;
    camera.fov_axis = fov_axis;
    let (spp, seed) = sampler(&props, ids, problems)?;
    if e.kind() == "perspective" {
        // Mitsuba's pinhole takes the focus distance of the lens cameras
        // and does nothing with it either.
        props.accept("focus_distance");
    }
    props.finish(problems)?;
    Ok(Sensor { camera, spp, seed })
}

/// The horizontal field of view of a lens on 36 mm wide film.
fn focal_length_fov(e: &Elem, f: &str) -> Result<f64, SceneError> {
    let mm = f.trim().trim_end_matches("mm").trim().parse::<f64>();
    match mm {
        Ok(mm) if mm > 0.0 && mm.is_finite() => Ok(2.0 * (18.0 / mm).atan().to_degrees()),
        _ => Err(e.loc.error(format!(
            "`focal_length`: expected e.g. \"50mm\", found {f:?}"
        ))),
    }
}

fn film(props: &Props, ids: &Ids, problems: &mut Problems) -> Result<(u32, u32), SceneError> {
    let Some(f) = props.objects("film")?.into_iter().next() else {
        return Ok((768, 576));
    };
    let fp = Props::new(f, ids);
    let size = |name: &str, default: u32| -> Result<u32, SceneError> {
        match fp.integer(name)? {
            None => Ok(default),
            Some(v) => u32::try_from(v)
                .map_err(|_| f.loc.error(format!("`{name}`: must be positive, got {v}"))),
        }
    };
    let (width, height) = (size("width", 768)?, size("height", 576)?);
    check_resolution(width, height).map_err(|m| f.loc.error(format!("<film>: {m}")))?;
    // What the film writes is chosen by luz's output name and tone mapping.
    for name in [
        "file_format",
        "pixel_format",
        "component_format",
        "banner",
        "gamma",
    ] {
        fp.accept(name);
    }
    if let Some(r) = fp
        .get("rfilter")
        .or_else(|| fp.objects("rfilter").ok()?.into_iter().next())
    {
        if r.kind() != "box" {
            problems.warn(
                &r.loc,
                format!(
                    "<rfilter type=\"{}\">: luz filters with a one-pixel box; substituted it",
                    r.kind()
                ),
            )?;
        }
    }
    fp.finish(problems)?;
    Ok((width, height))
}

/// luz's camera from Mitsuba's camera-to-world matrix (+z forward, +y up,
/// +x to the left of the image).
fn camera(
    e: &Elem,
    m: &DMat4,
    fov_y: f32,
    width: u32,
    height: u32,
    problems: &mut Problems,
) -> Result<Camera, SceneError> {
    let eye = m.transform_point3(DVec3::ZERO);
    let forward = m.transform_vector3(DVec3::Z).normalize_or_zero();
    let up = m.transform_vector3(DVec3::Y).normalize_or_zero();
    let left = m.transform_vector3(DVec3::X);
    if forward == DVec3::ZERO || up == DVec3::ZERO || forward.cross(up).length() < 1e-6 {
        return Err(e.loc.error("`to_world`: the camera's axes are degenerate"));
    }
    if forward.cross(up).dot(-left) < 0.0 {
        problems.warn(
            &e.loc,
            "`to_world` mirrors the image (a negative scale); luz renders it unmirrored",
        )?;
    }
    // A target one unit (or a thousandth of the distance to the origin)
    // ahead stays distinct from the eye in f32.
    let target = eye + forward * eye.length().mul_add(1e-3, 1.0);
    let (eye, target) = (eye.as_vec3a(), target.as_vec3a());
    if !within_bounds(eye) || !within_bounds(target) {
        return Err(e.loc.error("`to_world`: the camera lies beyond ±1e12"));
    }
    Ok(Camera {
        eye,
        target,
        up: up.as_vec3a(),
        fov_y,
        fov_axis: FovAxis::X,
        width,
        height,
    })
}

fn sampler(
    props: &Props,
    ids: &Ids,
    problems: &mut Problems,
) -> Result<(Option<u32>, Option<u64>), SceneError> {
    let Some(s) = props.objects("sampler")?.into_iter().next() else {
        return Ok((None, None));
    };
    // luz draws its own sample sequence; the type changes the noise, not
    // the image it converges to.
    let sp = Props::new(s, ids);
    let spp = match sp.integer("sample_count")? {
        None => None,
        Some(n) if n >= 1 && n <= u32::MAX as i64 => Some(n as u32),
        Some(n) => {
            return Err(s
                .loc
                .error(format!("`sample_count`: must be at least 1, got {n}")))
        }
    };
    let seed = match sp.integer("seed")? {
        None => None,
        Some(n) => Some(u64::try_from(n).map_err(|_| s.loc.error("`seed`: must not be negative"))?),
    };
    sp.accept("dimension");
    sp.finish(problems)?;
    Ok((spp, seed))
}

/// `<integrator>`: `path` (and what luz substitutes by it), `max_depth`
/// and `rr_depth`.
pub(super) fn integrator(
    e: &Elem,
    ids: &Ids,
    problems: &mut Problems,
    settings: &mut RenderSettings,
) -> Result<(), SceneError> {
    let props = Props::new(e, ids);
    let default_depth = match e.kind() {
        "path" | "volpath" | "volpathmis" => -1,
        // Direct lighting with emitters seen directly: two segments.
        "direct" => 2,
        other => {
            problems.warn(
                &e.loc,
                format!("<integrator type=\"{other}\">: luz has one path tracer; substituted it"),
            )?;
            -1
        }
    };
    if e.kind() == "direct" {
        for name in ["emitter_samples", "bsdf_samples", "shading_samples"] {
            props.accept(name);
        }
    }
    let depth = props.integer("max_depth")?.unwrap_or(default_depth);
    settings.max_depth = match depth {
        -1 => UNBOUNDED_DEPTH,
        d if d >= 0 => u32::try_from(d).unwrap_or(u32::MAX).min(UNBOUNDED_DEPTH),
        d => {
            return Err(e
                .loc
                .error(format!("`max_depth`: must be -1 or at least 0, got {d}")))
        }
    };
    // Mitsuba's roulette starts at `rr_depth` (5); luz's picks lobes from
    // the first bounce, with the same expectation. A roulette that never
    // starts is none.
    let rr_depth = props.integer("rr_depth")?.unwrap_or(5);
    if rr_depth >= settings.max_depth as i64 {
        settings.russian_roulette = false;
    }
    props.finish(problems)
}
