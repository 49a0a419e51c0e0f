use super::*;
use crate::sampling::Rng;

/// A small map with smooth and sharp features, values in [0, 4).
fn test_map(to_world: Mat3) -> EnvMap {
    let (w, h) = (16, 8);
    let mut rng = Rng::new(21, 0);
    let texels = (0..w * h)
        .map(|i| {
            let hot = if i == 37 { 40.0 } else { 0.0 };
            Rgb::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 4.0 + Rgb::splat(hot)
        })
        .collect();
    EnvMap::new(w, h, texels, 1.5, to_world)
}

fn rotated() -> Mat3 {
    Mat3::from_rotation_y(0.7) * Mat3::from_rotation_x(-0.4)
}

/// ∫ f(ω) dω over the sphere by the midpoint rule in (cos θ, φ).
fn integrate(f: impl Fn(Vec3) -> f64) -> f64 {
    let (n_cos, n_phi) = (1000, 2000);
    let cell = 4.0 * std::f64::consts::PI / (n_cos * n_phi) as f64;
    let mut sum = 0.0;
    for i in 0..n_cos {
        let z = -1.0 + 2.0 * (i as f64 + 0.5) / n_cos as f64;
        let r = (1.0 - z * z).sqrt();
        for j in 0..n_phi {
            let phi = std::f64::consts::TAU * (j as f64 + 0.5) / n_phi as f64;
            sum += f(Vec3::new(
                (r * phi.cos()) as f32,
                (r * phi.sin()) as f32,
                z as f32,
            )) * cell;
        }
    }
    sum
}

#[test]
fn the_pdf_integrates_to_one() {
    let map = Environment::Map(test_map(rotated()));
    let total = integrate(|d| map.pdf(d) as f64);
    assert!((total - 1.0).abs() < 2e-3, "∫ pdf = {total}");
    let constant = Environment::Constant(Rgb::ONE);
    assert!((integrate(|d| constant.pdf(d) as f64) - 1.0).abs() < 1e-4);
    assert_eq!(constant.pdf(Vec3::X), 1.0 / (4.0 * PI));
}

/// Samples carry the pdf `pdf` gives their direction and the radiance
/// `eval` gives it, and L/pdf averages to ∫ L dω (so importance sampling is
/// unbiased), for a rotated map.
#[test]
fn samples_agree_with_eval_pdf_and_the_integral() {
    let env = Environment::Map(test_map(rotated()));
    let mut rng = Rng::new(4, 0);
    let n = 400_000;
    let (mut estimate, mut off) = (0.0f64, 0);
    for _ in 0..n {
        let Some(s) = env.sample(rng.next_2d()) else {
            continue;
        };
        let pdf = env.pdf(s.wi);
        // The round trip uv -> direction -> uv in f32 can move a sample on
        // a cell's edge into the neighbouring cell (whose density differs),
        // and near the poles, where u is ill-conditioned, along its row.
        let l = env.eval(s.wi);
        let scale = l.max_element().max(1.0);
        if (pdf - s.pdf).abs() > 1e-2 * pdf || (l - s.radiance).abs().max_element() > 1e-2 * scale {
            off += 1;
        }
        estimate += luminance(s.radiance) as f64 / s.pdf as f64 / n as f64;
    }
    assert!(
        off * 1000 < n,
        "{off} of {n} samples disagree with eval or pdf"
    );
    let exact = integrate(|d| luminance(env.eval(d)) as f64);
    assert!(
        (estimate - exact).abs() < 0.01 * exact,
        "E[L/pdf] {estimate} vs ∫ L {exact}"
    );
}

/// Mitsuba's convention: local −z is u = 0, +x is u = 1/4, +y is the top
/// row; a texel's value is returned at its centre (u = (x + ½)/W, v =
/// y/(H − 1)), times `scale`.
#[test]
fn directions_map_to_texels_as_in_mitsuba() {
    let close = |a: Vec2, b: Vec2| (a - b).length() < 1e-6;
    assert!(close(direction_to_uv(-Vec3::Z), Vec2::new(0.0, 0.5)));
    assert!(close(direction_to_uv(Vec3::X), Vec2::new(0.25, 0.5)));
    assert!(close(direction_to_uv(Vec3::Z), Vec2::new(0.5, 0.5)));
    assert!(direction_to_uv(Vec3::Y).y.abs() < 1e-6);
    let map = test_map(Mat3::IDENTITY);
    let (w, h) = (map.width, map.height);
    // Not the pole rows, where every u is the same direction.
    for (x, y) in [(5u32, 2u32), (0, 1), (15, 6), (8, 4)] {
        let uv = Vec2::new((x as f32 + 0.5) / w as f32, y as f32 / (h - 1) as f32);
        let (sin_t, cos_t) = (uv.y * PI).sin_cos();
        let (sin_p, cos_p) = (uv.x * 2.0 * PI).sin_cos();
        let d = Vec3::new(sin_p * sin_t, cos_t, -cos_p * sin_t);
        let want = map.texels[(y * w + x) as usize] * map.scale;
        let got = map.eval(d);
        assert!(
            (got - want).abs().max_element() < 1e-3 * want.max_element(),
            "texel ({x}, {y}): {got} vs {want}"
        );
    }
}

#[test]
fn to_world_rotates_the_map() {
    let r = rotated();
    let (plain, turned) = (test_map(Mat3::IDENTITY), test_map(r));
    let mut rng = Rng::new(8, 0);
    for _ in 0..1000 {
        let d = uniform_sphere(rng.next_2d());
        let (a, b) = (plain.eval(d), turned.eval(r * d));
        assert!(
            (a - b).abs().max_element() < 1e-3 * a.max_element().max(1.0),
            "{a} vs {b} at {d}"
        );
    }
}

#[test]
fn a_black_map_is_never_sampled() {
    let map = EnvMap::new(4, 2, vec![Rgb::ZERO; 8], 1.0, Mat3::IDENTITY);
    let env = Environment::Map(map);
    assert!(env.sample(Vec2::new(0.3, 0.6)).is_none());
    assert_eq!(env.pdf(Vec3::Y), 0.0);
    assert_eq!(
        Environment::Constant(Rgb::ZERO).sample(Vec2::splat(0.5)),
        None
    );
}
