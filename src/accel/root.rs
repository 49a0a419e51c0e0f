//! The shapes `Accel` tests itself, beside the root of either backend's
//! tree: a scene's infinite planes, its quads when there are few, and its
//! few large spheres and cuboids.
//!
//! Why here and not in a tree: infinite planes have no finite bounds
//! (Embree drops user geometry bounds beyond ~1.8e18, and a huge box would
//! be entered by every ray). The few large analytic shapes of a typical
//! scene (a Cornell box's walls and light) are hit by almost every ray, so
//! walking a tree of their boxes only adds node visits: a callgrind profile
//! of the bunny counted 2.3 node visits and 0.9 out-of-line quad tests per
//! closest-hit query in the walls' tree. Tested here instead, they took the
//! bunny from 7,649 to 6,933 instructions per sample (docs/performance.md),
//! they are bit for bit the same for both backends, and Embree calls back
//! into Rust for none of them.
//!
//! Quads are tested eight at a time with AVX where the CPU has it (chosen
//! at run time, so one binary serves every x86_64 CPU), four at a time with
//! SSE elsewhere (`QuadPack`), with the very operations of
//! `Quad::intersect`, so a hit is the one the scalar routine finds at
//! either width. Spheres are turned away four at a time (`SpherePack`).
//! Cuboids are copied (they are small) and tested one by one.

use super::sphere_pack::SpherePack;
use crate::geometry::{Geometry, PreliminaryHit, PrimHit};
use crate::math::{Aabb, Ray};
#[cfg(target_arch = "x86_64")]
use crate::simd::F8;
use crate::simd::{has_avx, Lanes, F4};

/// Quads go to the root when a scene has at most this many (two packs),
/// else all of them into the trees. Measured on floors and walls tiled into
/// n quads (docs/performance.md), instructions per sample at the root
/// against the native tree, with AVX: 1,330 / 1,524 at 5 quads, 1,515 /
/// 1,601 at 17, 1,719 / 1,635 at 33; Embree's tree, which calls back into
/// Rust per quad, costs more still. Four lanes of SSE alone were level with
/// the native tree at 9 quads.
const ROOT_QUADS: usize = 16;
/// Spheres and cuboids, tested one by one, go to the root only when they
/// are large, at most this many: a big sphere in a Cornell box is entered
/// by as many rays as its box, a small one by few (measured: five spheres
/// of radius 0.25 in a 2-unit box cost 19% more at the root than in a tree).
const ROOT_OTHERS: usize = 4;
/// "Large": a bounding box with at least this fraction of the surface
/// area of the scene's bounds.
const LARGE_AREA: f32 = 0.1;

/// Quads in one pack: eight, which AVX tests at once and SSE in two halves.
const PACK: usize = 8;

/// `PACK` quads as structure of arrays: `p0[c][k]` is coordinate `c` of
/// quad `k`'s corner; `n` its unit normal, `du`/`dv` its dual basis
/// (`Quad::dual`). Padding lanes are NaN and never hit.
#[repr(C, align(64))]
#[derive(Clone, Copy, Debug)]
struct QuadPack {
    p0: [[f32; PACK]; 3],
    n: [[f32; PACK]; 3],
    du: [[f32; PACK]; 3],
    dv: [[f32; PACK]; 3],
    geom: [u32; PACK],
}

impl QuadPack {
    const EMPTY: QuadPack = QuadPack {
        p0: [[f32::NAN; PACK]; 3],
        n: [[f32::NAN; PACK]; 3],
        du: [[f32::NAN; PACK]; 3],
        dv: [[f32::NAN; PACK]; 3],
        geom: [u32::MAX; PACK],
    };

    /// Lanes `first..first + L::N` hit in `(ray.t_min, t_max)` (bit mask),
    /// with their `t, u, v`: `Quad::intersect`, operation for operation.
    #[inline(always)]
    fn intersect<L: Lanes>(&self, first: usize, r: &SplatRay<L>, t_max: f32) -> (u32, L, L, L) {
        let load = |a: &[[f32; PACK]; 3]| a.map(|row| L::load(&row[first..]));
        let dot = |a: [L; 3], b: [L; 3]| a[0].mul(b[0]).add(a[1].mul(b[1])).add(a[2].mul(b[2]));
        let (p0, n) = (load(&self.p0), load(&self.n));
        let denom = dot(n, r.dir);
        let to_p0 = [0, 1, 2].map(|c| p0[c].sub(r.origin[c]));
        let t = dot(to_p0, n).div(denom);
        let in_range = L::bits(L::and(t.gt(r.t_min), t.lt(L::splat(t_max))));
        if in_range == 0 {
            return (0, t, t, t);
        }
        let from_p0 = [0, 1, 2].map(|c| r.origin[c].sub(p0[c]));
        let (du, dv) = (load(&self.du), load(&self.dv));
        let u = dot(from_p0, du).add(t.mul(dot(r.dir, du)));
        let v = dot(from_p0, dv).add(t.mul(dot(r.dir, dv)));
        let (zero, one) = (L::splat(0.0), L::splat(1.0));
        let inside = L::and(L::and(u.ge(zero), u.le(one)), L::and(v.ge(zero), v.le(one)));
        (in_range & L::bits(inside), t, u, v)
    }
}

/// A ray splatted across the lanes.
struct SplatRay<L> {
    origin: [L; 3],
    dir: [L; 3],
    t_min: L,
}

impl<L: Lanes> SplatRay<L> {
    #[inline(always)]
    fn new(ray: &Ray) -> Self {
        Self {
            origin: ray.origin.to_array().map(L::splat),
            dir: ray.dir.to_array().map(L::splat),
            t_min: L::splat(ray.t_min),
        }
    }
}

/// A root cuboid's (or another shape's) test below `t_max`.
fn intersect(g: &Geometry, ray: &Ray, t_max: f32) -> Option<PrimHit> {
    g.intersect(0, &Ray { t_max, ..*ray })
}

#[derive(Clone, Debug, Default)]
pub struct RootShapes {
    quads: Vec<QuadPack>,
    spheres: SpherePack,
    /// Scene id and a copy of every other root shape.
    others: Vec<(u32, Geometry)>,
    /// Whether `spheres` or `others` hold any: one test for the scenes
    /// whose root holds only quads (or nothing).
    beyond_quads: bool,
}

impl RootShapes {
    /// The root shapes of `shapes`, and per shape whether it is one of them
    /// (the backends' trees take the others).
    pub fn of(shapes: &[Geometry]) -> (Self, Vec<bool>) {
        let bounds = |g: &Geometry| g.bounds().unwrap_or(Aabb::EMPTY);
        let count = |f: &dyn Fn(&Geometry) -> bool| shapes.iter().filter(|g| f(g)).count();
        let is_quad = |g: &Geometry| matches!(g, Geometry::Quad(_));
        let is_other = |g: &Geometry| matches!(g, Geometry::Sphere(_) | Geometry::Cuboid(_));
        // The scene's bounds pass over every mesh vertex: only for scenes
        // that have spheres or cuboids to judge by them.
        let scene_area = if count(&is_other) > 0 {
            shapes
                .iter()
                .fold(Aabb::EMPTY, |a, g| a.union(bounds(g)))
                .half_area()
        } else {
            0.0
        };
        let large = |g: &Geometry| bounds(g).half_area() >= LARGE_AREA * scene_area;
        let quads_at_root = count(&is_quad) <= ROOT_QUADS;
        let others_at_root = count(&|g| is_other(g) && large(g)) <= ROOT_OTHERS;
        let at_root = |g: &Geometry| match g {
            Geometry::Plane(_) => true,
            Geometry::Mesh(_) => false,
            Geometry::Quad(_) => quads_at_root,
            g => others_at_root && large(g),
        };
        let mut root = RootShapes::default();
        let mut quads = 0;
        let mut in_root = Vec::with_capacity(shapes.len());
        for (geom, shape) in shapes.iter().enumerate() {
            let geom = geom as u32;
            let here = at_root(shape);
            in_root.push(here);
            match shape {
                _ if !here => {}
                Geometry::Quad(q) => {
                    if quads % PACK == 0 {
                        root.quads.push(QuadPack::EMPTY);
                    }
                    let pack = root.quads.last_mut().expect("pushed above");
                    let k = quads % PACK;
                    let (du, dv) = q.dual();
                    for c in 0..3 {
                        pack.p0[c][k] = q.p0[c];
                        pack.n[c][k] = q.normal()[c];
                        pack.du[c][k] = du[c];
                        pack.dv[c][k] = dv[c];
                    }
                    pack.geom[k] = geom;
                    quads += 1;
                }
                Geometry::Sphere(s) if root.spheres.push(geom, s) => {}
                g => root.others.push((geom, g.clone())),
            }
        }
        root.beyond_quads = !root.spheres.is_empty() || !root.others.is_empty();
        (root, in_root)
    }

    /// The closest root hit in `(ray.t_min, ray.t_max)`; of hits at the
    /// same distance, the first found (quads, spheres, then the others,
    /// each in scene order).
    /// Always inlined: rustc kept it out of line, and inlining it saved
    /// 33 (bunny) to 59 (cornell-area) instructions per sample.
    #[inline(always)]
    pub fn closest(&self, ray: &Ray) -> Option<PreliminaryHit> {
        let mut best = self.closest_quad(ray);
        if !self.beyond_quads {
            return best;
        }
        let mut t_max = best.map_or(ray.t_max, |h| h.t);
        if let Some((geom, h)) = self.spheres.closest(ray, t_max) {
            t_max = h.t;
            best = Some(h.of_shape(geom));
        }
        for (geom, g) in &self.others {
            if let Some(h) = intersect(g, ray, t_max) {
                t_max = h.t;
                best = Some(h.of_shape(*geom));
            }
        }
        best
    }

    /// Whether any root shape is hit in `(ray.t_min, ray.t_max)`.
    #[inline]
    pub fn any_hit(&self, ray: &Ray) -> bool {
        self.any_quad(ray)
            || self.beyond_quads
                && (self.spheres.any_hit(ray)
                    || self
                        .others
                        .iter()
                        .any(|(_, g)| intersect(g, ray, ray.t_max).is_some()))
    }

    /// The closest quad hit, eight quads at a time where the CPU has AVX.
    #[inline(always)]
    fn closest_quad(&self, ray: &Ray) -> Option<PreliminaryHit> {
        if self.quads.is_empty() {
            return None;
        }
        #[cfg(target_arch = "x86_64")]
        if has_avx() {
            // SAFETY: the CPU has AVX.
            return unsafe { self.closest_quad_avx(ray) };
        }
        self.closest_quad_in::<F4>(ray)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    fn closest_quad_avx(&self, ray: &Ray) -> Option<PreliminaryHit> {
        self.closest_quad_in::<F8>(ray)
    }

    /// The first of the nearest lanes, as a scalar loop over the quads in
    /// scene order finds it.
    #[inline(always)]
    fn closest_quad_in<L: Lanes>(&self, ray: &Ray) -> Option<PreliminaryHit> {
        let r = SplatRay::<L>::new(ray);
        let mut t_max = ray.t_max;
        let mut best = None;
        for pack in &self.quads {
            for first in (0..PACK).step_by(L::N) {
                let (mask, t, u, v) = pack.intersect(first, &r, t_max);
                if mask == 0 {
                    continue;
                }
                let (mut ts, mut us, mut vs) = ([0.0; PACK], [0.0; PACK], [0.0; PACK]);
                t.store(&mut ts);
                u.store(&mut us);
                v.store(&mut vs);
                let lane_hit = |k: usize| PreliminaryHit {
                    t: ts[k],
                    geom: pack.geom[first + k],
                    prim: 0,
                    u: us[k],
                    v: vs[k],
                };
                if mask & (mask - 1) == 0 {
                    // One lane, the common case (a ray meets one wall of a
                    // box), and below `t_max` already: taken without a
                    // test per lane, whose branches follow the wall hit.
                    let k = mask.trailing_zeros() as usize;
                    t_max = ts[k];
                    best = Some(lane_hit(k));
                    continue;
                }
                for (k, &t) in ts.iter().enumerate().take(L::N) {
                    if mask & (1 << k) != 0 && t < t_max {
                        t_max = t;
                        best = Some(lane_hit(k));
                    }
                }
            }
        }
        best
    }

    /// Whether any quad is hit, eight at a time where the CPU has AVX.
    #[inline(always)]
    fn any_quad(&self, ray: &Ray) -> bool {
        if self.quads.is_empty() {
            return false;
        }
        #[cfg(target_arch = "x86_64")]
        if has_avx() {
            // SAFETY: the CPU has AVX.
            return unsafe { self.any_quad_avx(ray) };
        }
        self.any_quad_in::<F4>(ray)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    fn any_quad_avx(&self, ray: &Ray) -> bool {
        self.any_quad_in::<F8>(ray)
    }

    #[inline(always)]
    fn any_quad_in<L: Lanes>(&self, ray: &Ray) -> bool {
        let r = SplatRay::<L>::new(ray);
        self.quads.iter().any(|pack| {
            (0..PACK)
                .step_by(L::N)
                .any(|first| pack.intersect(first, &r, ray.t_max).0 != 0)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Quad, Sphere};
    use crate::math::Vec3;
    use crate::sampling::{uniform_sphere, Rng};

    fn quad(p0: Vec3, e1: Vec3, e2: Vec3) -> Geometry {
        Geometry::Quad(Quad::new(p0, e1, e2).unwrap())
    }

    fn sphere(center: Vec3, radius: f32) -> Geometry {
        Geometry::Sphere(Sphere { center, radius })
    }

    /// A closed box of six quads with two large spheres inside.
    fn cornell() -> Vec<Geometry> {
        let (x, y, z) = (2.0 * Vec3::X, 2.0 * Vec3::Y, 2.0 * Vec3::Z);
        let o = Vec3::new(-1.0, 0.0, -1.0);
        let far = o + x + y + z;
        vec![
            quad(o, z, x),
            quad(o, x, y),
            quad(o, y, z),
            quad(far, -y, -x),
            quad(far, -z, -y),
            quad(far, -x, -z),
            sphere(Vec3::new(-0.4, 0.4, -0.3), 0.4),
            sphere(Vec3::new(0.4, 0.4, 0.3), 0.4),
        ]
    }

    /// The closest hit and any hit, shape by shape with the scalar routines.
    fn brute(shapes: &[Geometry], ray: &Ray) -> Option<(f32, u32)> {
        let mut r = *ray;
        let mut best = None;
        for (geom, g) in shapes.iter().enumerate() {
            if let Some(h) = g.intersect(0, &r) {
                r.t_max = h.t;
                best = Some((h.t, geom as u32));
            }
        }
        best
    }

    #[test]
    fn root_hits_are_the_scalar_routines_hits() {
        let shapes = cornell();
        let (root, in_root) = RootShapes::of(&shapes);
        assert!(in_root.iter().all(|&r| r), "{in_root:?}");
        let mut rng = Rng::new(7, 7);
        for i in 0..20_000 {
            let o = Vec3::new(0.0, 1.0, 0.0) + 0.9 * uniform_sphere(rng.next_2d());
            let mut ray = Ray::new(o, uniform_sphere(rng.next_2d()));
            if i % 2 == 1 {
                ray.t_max = 2.0 * rng.next_f32();
            }
            let expected = brute(&shapes, &ray);
            let got = root.closest(&ray).map(|h| (h.t, h.geom));
            assert_eq!(got, expected, "{ray:?}");
            assert_eq!(root.any_hit(&ray), expected.is_some(), "{ray:?}");
        }
    }

    /// Both widths compute the same operations per lane, so they agree bit
    /// for bit, on twelve quads (two packs, the second one half empty).
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn avx_and_sse_quad_tests_agree_bit_for_bit() {
        if !has_avx() {
            eprintln!("no AVX on this CPU: only the SSE width runs");
            return;
        }
        let mut shapes = cornell()[..6].to_vec();
        for k in 0..6 {
            let p = Vec3::new(-0.9 + 0.3 * k as f32, 0.2 + 0.1 * k as f32, -0.9);
            shapes.push(quad(p, 0.4 * Vec3::Z, 0.3 * Vec3::X + 0.1 * Vec3::Y));
        }
        let root = RootShapes::of(&shapes).0;
        assert_eq!(root.quads.len(), 2);
        let mut rng = Rng::new(9, 9);
        let mut hits = 0;
        for _ in 0..20_000 {
            let o = Vec3::new(0.0, 1.0, 0.0) + 0.9 * uniform_sphere(rng.next_2d());
            let mut ray = Ray::new(o, uniform_sphere(rng.next_2d()));
            ray.t_max = 3.0 * rng.next_f32();
            let sse = root.closest_quad_in::<F4>(&ray);
            // SAFETY: the CPU has AVX.
            let avx = unsafe { root.closest_quad_avx(&ray) };
            assert_eq!(sse, avx, "{ray:?}");
            assert_eq!(root.any_quad_in::<F4>(&ray), unsafe {
                root.any_quad_avx(&ray)
            });
            hits += sse.is_some() as u32;
        }
        assert!(hits > 10_000, "{hits} hits");
    }

    #[test]
    fn many_quads_and_small_spheres_go_into_the_trees() {
        let mut shapes = cornell();
        let (_, in_root) = RootShapes::of(&shapes);
        assert_eq!(in_root.iter().filter(|&&r| r).count(), 8);
        // Eleven more quads: seventeen in all, beyond two packs.
        for k in 0..11 {
            let p = Vec3::new(-0.9 + 0.15 * k as f32, 0.01, -0.9);
            shapes.push(quad(p, 0.1 * Vec3::Z, 0.1 * Vec3::X));
        }
        shapes.push(sphere(Vec3::new(0.0, 1.5, 0.0), 0.05));
        let (_, in_root) = RootShapes::of(&shapes);
        let kinds: Vec<_> = shapes.iter().map(|g| g.name()).zip(in_root).collect();
        for (name, at_root) in &kinds[..6] {
            assert_eq!((*name, *at_root), ("quad", false));
        }
        assert_eq!(kinds[6..8], [("sphere", true), ("sphere", true)]);
        assert_eq!(kinds[19], ("sphere", false), "a small sphere");
    }
}
