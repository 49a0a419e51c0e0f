//! Ray-level extremes: re-intersection of spheres from 1e-4 to 1e6, grazing
//! rays, a closed mesh probed from inside, sliver and degenerate triangles.

use super::*;

/// Glass-like re-intersection of spheres of radius 1e-4, 1, 1e4 and 1e6,
/// centred at `r · (3, -1, 2)`: from 200 camera-side hit points per radius,
/// 1,000 uniformly random directions each (2e5 spawned rays, about 1e5
/// entering), spawned with `spawn_ray` from the scene's surface point.
/// Entering rays must hit the same sphere at `t > 0` no nearer than half
/// the exact chord `2r·cos θ` (closer is a self-hit, none is a missed exit);
/// for chords under 1e-4·r (cos θ < 5e-5) any hit at `t > 0` counts as the
/// exit. Leaving rays must hit nothing. Thresholds: 0 self-hits and 0 missed
/// exits on every backend and radius; at least 190 of 200 probes hit.
#[test]
fn sphere_reintersection_from_1e_minus4_to_1e6() {
    let _table = Table;
    let mut failures = Vec::new();
    for radius in [1e-4f32, 1.0, 1e4, 1e6] {
        let center = Vec3::new(3.0, -1.0, 2.0) * radius;
        let scene = scene_of(vec![Geometry::Sphere(Sphere { center, radius })]);
        for (name, kind, options) in configs() {
            let accel = build_accel(&scene, kind, &options).unwrap();
            let mut rng = Rng::new(7, radius.to_bits() as u64);
            let (mut probes, mut rays, mut self_hits, mut missed, mut nf) = (0, 0u64, 0, 0, 0);
            for _ in 0..200 {
                let target = center + 0.9 * radius * uniform_sphere(rng.next_2d());
                let eye = center + 10.0 * radius * uniform_sphere(rng.next_2d());
                let ray = Ray::new(eye, (target - eye).normalize());
                let Some(hit) = accel.intersect(&ray) else {
                    continue;
                };
                probes += 1;
                let sp = scene.surface(&ray, &hit);
                if !(sp.p.is_finite() && sp.n.is_finite() && sp.p_err.is_finite()) {
                    nf += 1;
                    continue;
                }
                for _ in 0..1000 {
                    let w = uniform_sphere(rng.next_2d());
                    let r = spawn_ray(sp.p, sp.p_err, sp.n, w);
                    rays += 1;
                    let again = accel.intersect(&r);
                    let cos = -w.dot(sp.n);
                    if cos <= 0.0 {
                        if again.is_some() {
                            self_hits += 1;
                        }
                        continue;
                    }
                    let chord = 2.0 * radius * cos;
                    match again {
                        None => missed += 1,
                        Some(h) if !h.t.is_finite() => nf += 1,
                        Some(h) if h.t <= 0.0 => self_hits += 1,
                        Some(h) if chord < 1e-4 * radius => {
                            let _ = h;
                        }
                        Some(h) if h.t < 0.5 * chord => self_hits += 1,
                        Some(_) => {}
                    }
                }
            }
            row(
                &format!("sphere r={radius:e} reintersection"),
                name,
                rays,
                self_hits,
                missed,
                0,
                nf,
            );
            if probes < 190 || self_hits + missed + nf > 0 {
                failures.push(format!(
                    "r={radius:e} {name}: {probes} probes, {self_hits} self-hits, {missed} missed exits, {nf} non-finite"
                ));
            }
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

fn orthonormal(n: Vec3) -> (Vec3, Vec3) {
    let f = luz::math::Frame::from_normal(n);
    (f.s, f.t)
}

/// Grazing rays on a quad and on a single triangle (both about 2 units, at
/// scales 1 and 1e4, random orientation): rays reach interior points (at
/// least 10% from every edge) at elevation angles 1e-1 .. 1e-6 rad from the
/// surface plane, 2,000 per angle. Then from each hit, three rays spawned
/// with `spawn_ray`: the mirror direction, the straight continuation and a
/// random direction. Thresholds: no NaN/Inf in t, u, v, p, n; 0 self-hits
/// (a flat shape can never be hit again by a ray leaving it); at least
/// 99.9% of the probes hit (a miss of an interior point is a lost hit).
#[test]
fn grazing_rays_down_to_1e_minus6_rad() {
    let _table = Table;
    let mut failures = Vec::new();
    for scale in [1.0f32, 1e4] {
        let mut rng = Rng::new(21, scale.to_bits() as u64);
        let n = uniform_sphere(rng.next_2d());
        let (s, t) = orthonormal(n);
        let origin = Vec3::new(0.7, -0.3, 0.2) * scale;
        let quad = Quad::new(origin, 2.0 * scale * s, 1.5 * scale * t).unwrap();
        let tri = Mesh {
            positions: [origin, origin + 2.0 * scale * s, origin + 2.0 * scale * t]
                .map(Into::into)
                .to_vec(),
            indices: vec![[0, 1, 2]],
            uvs: None,
            normals: None,
        };
        for (shape_name, g) in [
            ("quad", Geometry::Quad(quad)),
            ("triangle", Geometry::from(tri)),
        ] {
            let scene = scene_of(vec![g]);
            for (name, kind, options) in configs() {
                let accel = build_accel(&scene, kind, &options).unwrap();
                let (mut probes, mut hits, mut rays, mut self_hits, mut nf) =
                    (0u64, 0u64, 0u64, 0u64, 0u64);
                for k in 1..=6 {
                    let angle = 10f32.powi(-k);
                    for _ in 0..2000 {
                        // Interior point: barycentric-ish coordinates in [0.1, 0.4]
                        // (inside the triangle too, since a + b <= 0.8).
                        let (a, b) = (0.1 + 0.3 * rng.next_f32(), 0.1 + 0.3 * rng.next_f32());
                        let target = origin + 2.0 * scale * a * s + 1.5 * scale * b * t;
                        let phi = 2.0 * std::f32::consts::PI * rng.next_f32();
                        let side = if rng.next_f32() < 0.5 { 1.0 } else { -1.0 };
                        let along = phi.cos() * s + phi.sin() * t;
                        let d = (angle.cos() * along - side * angle.sin() * n).normalize();
                        let eye = target - 0.5 * scale * d;
                        let ray = Ray::new(eye, d);
                        probes += 1;
                        let Some(hit) = accel.intersect(&ray) else {
                            continue;
                        };
                        hits += 1;
                        if !(hit.t.is_finite() && hit.u.is_finite() && hit.v.is_finite()) {
                            nf += 1;
                            continue;
                        }
                        let sp = scene.surface(&ray, &hit);
                        if !(sp.p.is_finite() && sp.n.is_finite() && sp.p_err.is_finite()) {
                            nf += 1;
                            continue;
                        }
                        let mirror = reflect(-d, sp.n);
                        for w in [mirror, d, uniform_sphere(rng.next_2d())] {
                            let r = spawn_ray(sp.p, sp.p_err, sp.n, w.normalize());
                            rays += 1;
                            if !r.origin.is_finite() || !r.dir.is_finite() {
                                nf += 1;
                            } else if accel.intersect(&r).is_some() {
                                self_hits += 1;
                            }
                        }
                    }
                }
                let lost = probes - hits;
                row(
                    &format!("grazing {shape_name} scale {scale:e}"),
                    name,
                    rays,
                    self_hits,
                    lost,
                    0,
                    nf,
                );
                if nf > 0 || self_hits > 0 || lost * 1000 > probes {
                    failures.push(format!(
                        "{shape_name} scale {scale:e} {name}: {nf} non-finite, {self_hits} self-hits, {lost} of {probes} probes lost"
                    ));
                }
            }
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

/// Unit icosphere-like closed mesh: an octahedron subdivided `levels` times
/// with shared vertices (watertight by construction), projected onto the
/// sphere of `radius` around `center`.
fn octasphere(levels: u32, center: Vec3, radius: f32) -> Mesh {
    let mut positions = vec![Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z];
    let mut indices: Vec<[u32; 3]> = vec![
        [0, 2, 4],
        [2, 1, 4],
        [1, 3, 4],
        [3, 0, 4],
        [2, 0, 5],
        [1, 2, 5],
        [3, 1, 5],
        [0, 3, 5],
    ];
    for _ in 0..levels {
        let mut mid: HashMap<(u32, u32), u32> = HashMap::new();
        let mut next = Vec::with_capacity(indices.len() * 4);
        let mut midpoint = |a: u32, b: u32, positions: &mut Vec<Vec3>| {
            let key = (a.min(b), a.max(b));
            *mid.entry(key).or_insert_with(|| {
                positions.push((positions[a as usize] + positions[b as usize]).normalize());
                positions.len() as u32 - 1
            })
        };
        for [a, b, c] in indices {
            let ab = midpoint(a, b, &mut positions);
            let bc = midpoint(b, c, &mut positions);
            let ca = midpoint(c, a, &mut positions);
            next.extend([[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]);
        }
        indices = next;
    }
    Mesh {
        positions: positions
            .iter()
            .map(|&p| (center + radius * p).into())
            .collect(),
        indices,
        uvs: None,
        normals: None,
    }
}

/// A closed octasphere of 8,192 triangles (5 subdivisions), radius 1 at the
/// origin and radius 1e3 centred at (2e3, -1e3, 1e3), probed by 1e6 rays per
/// backend and placement from points uniform in the inner ball of half the
/// radius, in uniformly random directions (a tenth exactly axis-parallel).
/// An escape is a ray that hits nothing. Thresholds: 0 escapes on the
/// native backend and on Embree with `embree_robust`; Embree without it is
/// reported and must stay under 1e-4 of the rays.
#[test]
fn closed_mesh_probed_from_inside_never_leaks() {
    let _table = Table;
    let mut failures = Vec::new();
    for (center, radius) in [(Vec3::ZERO, 1.0f32), (Vec3::new(2e3, -1e3, 1e3), 1e3)] {
        let mesh = octasphere(5, center, radius);
        assert_eq!(mesh.indices.len(), 8192);
        let scene = scene_of(vec![Geometry::from(mesh)]);
        for (name, kind, options) in configs() {
            let accel = build_accel(&scene, kind, &options).unwrap();
            let mut rng = Rng::new(99, radius.to_bits() as u64);
            let n = 1_000_000u64;
            let mut escapes = 0u64;
            for _ in 0..n {
                let o =
                    center + 0.5 * radius * uniform_sphere(rng.next_2d()) * rng.next_f32().cbrt();
                let mut d = uniform_sphere(rng.next_2d());
                if rng.next_f32() < 0.1 {
                    let mut a = Vec3::ZERO;
                    a[(rng.next_u32() % 3) as usize] =
                        if rng.next_f32() < 0.5 { 1.0 } else { -1.0 };
                    d = a;
                }
                if accel.intersect(&Ray::new(o, d)).is_none() {
                    escapes += 1;
                }
            }
            row(
                &format!("closed mesh r={radius:e} from inside"),
                name,
                n,
                0,
                0,
                escapes,
                0,
            );
            let allowed = if name == "embree" { n / 10_000 } else { 0 };
            if escapes > allowed {
                failures.push(format!(
                    "r={radius:e} {name}: {escapes} of {n} rays escaped"
                ));
            }
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

/// A unit square in a random plane, cut into 2,048 vertical strips each
/// split along its diagonal (4,096 slivers of aspect ratio 2,048, sharing
/// vertices), plus 4,094 degenerate triangles on the strips' edges: one
/// with a repeated vertex and one with three collinear vertices per edge.
/// The mesh goes through the PLY loader, which must drop exactly the
/// degenerate ones (kept, they gave zero or random normals and hundreds of
/// self-hits on every backend). Probes: 50,000 rays from either side at
/// elevations 0.05 to 1.5 rad, half aimed exactly at points of the inner
/// strip edges (shared by two slivers, where a test that is not watertight
/// can let a ray through), half anywhere inside (at least 1% from the
/// border). From each hit, the mirror and a random direction are spawned
/// with `spawn_ray`. Thresholds: on every backend t, u, v, p, n finite,
/// |n| = 1 and 0 lost interior probes; 0 self-hits on the native backend
/// and Embree robust, under 1e-4 of the rays on Embree without
/// `embree_robust`; 0 lost edge probes on the native backend (watertight)
/// and Embree robust. Edge probes lost by Embree without `embree_robust`
/// are reported.
#[test]
fn sliver_and_degenerate_triangles() {
    let _table = Table;
    let strips = 2048u32;
    let mut rng = Rng::new(17, 5);
    let n = uniform_sphere(rng.next_2d());
    let (s, t) = orthonormal(n);
    let origin = Vec3::new(0.3, -0.2, 0.5);
    let at = |x: f32, y: f32| origin + x * s + y * t;
    // Vertices: bottom row 0..=strips, top row from `top`, and a midpoint
    // on each inner edge for the collinear triangles.
    let mut positions = Vec::new();
    for row in [0.0, 1.0] {
        for k in 0..=strips {
            positions.push(at(k as f32 / strips as f32, row));
        }
    }
    let top = strips + 1;
    let mid = positions.len() as u32;
    for k in 1..strips {
        positions.push(at(k as f32 / strips as f32, 0.5));
    }
    let mut indices = Vec::new();
    for k in 0..strips {
        indices.push([k, k + 1, top + k + 1]);
        indices.push([k, top + k + 1, top + k]);
    }
    let slivers = indices.len();
    for k in 1..strips {
        indices.push([k, k, top + k]);
        indices.push([k, mid + k - 1, top + k]);
    }
    let mut ply = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex {}\nproperty float x\n\
         property float y\nproperty float z\nelement face {}\n\
         property list uchar uint vertex_indices\nend_header\n",
        positions.len(),
        indices.len()
    )
    .into_bytes();
    ply.extend(
        positions
            .iter()
            .flat_map(|p| p.to_array())
            .flat_map(f32::to_le_bytes),
    );
    for tri in &indices {
        ply.push(3);
        ply.extend(tri.iter().flat_map(|i| i.to_le_bytes()));
    }
    let mesh = luz::scene::mesh_io::parse_mesh(&ply, Path::new("slivers.ply")).unwrap();
    assert_eq!(
        mesh.indices,
        indices[..slivers],
        "the loader drops exactly the degenerate triangles"
    );
    let scene = scene_of(vec![Geometry::from(mesh)]);
    let mut failures = Vec::new();
    for (name, kind, options) in configs() {
        let accel = build_accel(&scene, kind, &options).unwrap();
        let mut rng = Rng::new(23, 1);
        let (mut probes, mut rays, mut self_hits, mut nf) = (0u64, 0u64, 0u64, 0u64);
        let (mut lost_edge, mut lost_inside) = (0u64, 0u64);
        for i in 0..50_000 {
            let on_edge = i % 2 == 0;
            let y = 0.01 + 0.98 * rng.next_f32();
            let x = if on_edge {
                (1 + rng.next_u32() % (strips - 1)) as f32 / strips as f32
            } else {
                0.01 + 0.98 * rng.next_f32()
            };
            let target = at(x, y);
            let elevation = 0.05 + 1.45 * rng.next_f32();
            let phi = 2.0 * std::f32::consts::PI * rng.next_f32();
            let side = if rng.next_f32() < 0.5 { 1.0 } else { -1.0 };
            let along = phi.cos() * s + phi.sin() * t;
            let d = (elevation.cos() * along - side * elevation.sin() * n).normalize();
            let ray = Ray::new(target - 2.0 * d, d);
            probes += 1;
            let Some(hit) = accel.intersect(&ray) else {
                if on_edge {
                    lost_edge += 1;
                } else {
                    lost_inside += 1;
                }
                continue;
            };
            let sp = scene.surface(&ray, &hit);
            let finite = hit.t.is_finite() && hit.u.is_finite() && hit.v.is_finite();
            let unit = (sp.n.length() - 1.0).abs() < 1e-3;
            if !(finite && sp.p.is_finite() && sp.p_err.is_finite() && unit) {
                nf += 1;
                continue;
            }
            let mirror = reflect(-d, sp.n);
            for w in [mirror, uniform_sphere(rng.next_2d())] {
                rays += 1;
                if accel
                    .intersect(&spawn_ray(sp.p, sp.p_err, sp.n, w))
                    .is_some()
                {
                    self_hits += 1;
                }
            }
        }
        let lost = lost_edge + lost_inside;
        row(
            "slivers (degenerate dropped)",
            name,
            rays,
            self_hits,
            lost,
            0,
            nf,
        );
        eprintln!(
            "  {name}: {lost_edge} of {} edge probes and {lost_inside} of {} interior probes lost",
            probes / 2,
            probes / 2
        );
        // Embree's default triangle test is not watertight, and how much it
        // loses depends on the CPU's code path (an AVX-512 machine lost 1 of
        // 25,000 interior probes on these slivers): it may lose edges and
        // one interior probe in 10,000, as many as the self-hits it may
        // have; the robust mode and the native backend may lose nothing.
        let lenient = name == "embree";
        let edge_ok = lenient || lost_edge == 0;
        let allowed = |n: u64| if lenient { n / 10_000 } else { 0 };
        if nf > 0 || self_hits > allowed(rays) || lost_inside > allowed(probes / 2) || !edge_ok {
            failures.push(format!(
                "{name}: {nf} non-finite, {self_hits} self-hits, {lost_inside} interior and {lost_edge} edge probes lost"
            ));
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}
