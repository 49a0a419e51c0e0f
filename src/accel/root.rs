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
//! closest-hit query in the walls' tree, about 300 instructions, where one
//! 4-wide test of the six quads costs under 100. Tested once here, they are
//! also bit for bit the same for both backends, and Embree calls back into
//! Rust for none of them.
//!
//! Quads are tested four at a time (`QuadPack`), with the very operations of
//! `Quad::intersect`, so a hit is the one the scalar routine finds. The
//! other shapes are copied (they are small) and tested one by one.

use crate::geometry::Geometry;
use crate::geometry::PreliminaryHit;
use crate::math::{Aabb, Ray};
use crate::scene::Shape;
use crate::simd::F4;

/// Quads go to the root when a scene has at most this many (two packs),
/// else all of them into the trees. Measured on floors and walls tiled into
/// n quads (docs/performance.md): the root's linear test beats the native
/// tree up to 5 quads and is level with it at 9; Embree's tree, which
/// calls back into Rust per quad, only from 17 on.
pub const ROOT_QUADS: usize = 8;
/// Spheres and cuboids, tested one by one, go to the root only when they
/// are large, at most this many: a big sphere in a Cornell box is entered
/// by as many rays as its box, a small one by few (measured: five spheres
/// of radius 0.25 in a 2-unit box cost 19% more at the root than in a tree).
pub const ROOT_OTHERS: usize = 4;
/// "Large": a bounding box with at least this fraction of the surface
/// area of the scene's bounds.
pub const LARGE_AREA: f32 = 0.1;

/// Four quads as structure of arrays: `p0[c][k]` is coordinate `c` of
/// quad `k`'s corner; `n` its unit normal, `du`/`dv` its dual basis
/// (`Quad::dual`). Padding lanes are NaN and never hit.
#[repr(C, align(64))]
#[derive(Clone, Copy, Debug)]
struct QuadPack {
    p0: [[f32; 4]; 3],
    n: [[f32; 4]; 3],
    du: [[f32; 4]; 3],
    dv: [[f32; 4]; 3],
    geom: [u32; 4],
}

impl QuadPack {
    const EMPTY: QuadPack = QuadPack {
        p0: [[f32::NAN; 4]; 3],
        n: [[f32::NAN; 4]; 3],
        du: [[f32::NAN; 4]; 3],
        dv: [[f32::NAN; 4]; 3],
        geom: [u32::MAX; 4],
    };

    /// Lane mask of the quads hit in `(ray.t_min, t_max)`, with `t, u, v`.
    #[inline(always)]
    fn intersect(&self, r: &SplatRay, t_max: f32) -> (u32, F4, F4, F4) {
        let load = |a: &[[f32; 4]; 3]| [F4::load(&a[0]), F4::load(&a[1]), F4::load(&a[2])];
        let dot = |a: [F4; 3], b: [F4; 3]| a[0].mul(b[0]).add(a[1].mul(b[1])).add(a[2].mul(b[2]));
        let (p0, n) = (load(&self.p0), load(&self.n));
        let denom = dot(n, r.dir);
        let to_p0 = [0, 1, 2].map(|c| p0[c].sub(r.origin[c]));
        let t = dot(to_p0, n).div(denom);
        let in_range = t.gt(r.t_min).and(t.lt(F4::splat(t_max))).bits();
        if in_range == 0 {
            return (0, t, t, t);
        }
        let rel = [0, 1, 2].map(|c| r.origin[c].add(t.mul(r.dir[c])).sub(p0[c]));
        let u = dot(rel, load(&self.du));
        let v = dot(rel, load(&self.dv));
        let (zero, one) = (F4::splat(0.0), F4::splat(1.0));
        let inside = u.ge(zero).and(u.le(one)).and(v.ge(zero)).and(v.le(one));
        (in_range & inside.bits(), t, u, v)
    }
}

/// A ray splatted across four lanes.
struct SplatRay {
    origin: [F4; 3],
    dir: [F4; 3],
    t_min: F4,
}

impl SplatRay {
    #[inline(always)]
    fn new(ray: &Ray) -> Self {
        let o = ray.origin;
        let d = ray.dir;
        Self {
            origin: [F4::splat(o.x), F4::splat(o.y), F4::splat(o.z)],
            dir: [F4::splat(d.x), F4::splat(d.y), F4::splat(d.z)],
            t_min: F4::splat(ray.t_min),
        }
    }
}

#[derive(Clone, Debug, Default)]
pub struct RootShapes {
    quads: Vec<QuadPack>,
    /// Scene id and a copy of every other root shape.
    others: Vec<(u32, Geometry)>,
}

impl RootShapes {
    /// The root shapes of `shapes`, and per shape whether it is one of them
    /// (the backends' trees take the others).
    pub fn of(shapes: &[Shape]) -> (Self, Vec<bool>) {
        let bounds = |g: &Geometry| match g {
            Geometry::Mesh(m) => m.bounds(),
            g => g.primitive_bounds(0).unwrap_or(Aabb::EMPTY),
        };
        let scene_area = shapes
            .iter()
            .fold(Aabb::EMPTY, |a, s| a.union(bounds(&s.geometry)))
            .half_area();
        let large = |g: &Geometry| bounds(g).half_area() >= LARGE_AREA * scene_area;
        let count =
            |f: &dyn Fn(&Geometry) -> bool| shapes.iter().filter(|s| f(&s.geometry)).count();
        let is_quad = |g: &Geometry| matches!(g, Geometry::Quad(_));
        let is_other = |g: &Geometry| matches!(g, Geometry::Sphere(_) | Geometry::Cuboid(_));
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
            let here = at_root(&shape.geometry);
            in_root.push(here);
            match &shape.geometry {
                _ if !here => {}
                Geometry::Quad(q) => {
                    if quads % 4 == 0 {
                        root.quads.push(QuadPack::EMPTY);
                    }
                    let pack = root.quads.last_mut().expect("pushed above");
                    let k = quads % 4;
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
                g => root.others.push((geom, g.clone())),
            }
        }
        (root, in_root)
    }

    /// The closest root hit in `(ray.t_min, ray.t_max)`; of hits at the
    /// same distance, the first found (quads first, then in scene order).
    #[inline]
    pub fn closest(&self, ray: &Ray) -> Option<PreliminaryHit> {
        let mut best: Option<PreliminaryHit> = None;
        let mut t_max = ray.t_max;
        if !self.quads.is_empty() {
            let r = SplatRay::new(ray);
            for pack in &self.quads {
                let (mask, t, u, v) = pack.intersect(&r, t_max);
                if mask == 0 {
                    continue;
                }
                let (t, u, v) = (t.to_array(), u.to_array(), v.to_array());
                for k in 0..4 {
                    if mask & (1 << k) != 0 && t[k] < t_max {
                        t_max = t[k];
                        best = Some(PreliminaryHit {
                            t: t[k],
                            geom: pack.geom[k],
                            prim: 0,
                            u: u[k],
                            v: v[k],
                        });
                    }
                }
            }
        }
        let mut r = *ray;
        for (geom, g) in &self.others {
            r.t_max = t_max;
            if let Some(h) = g.intersect(0, &r) {
                t_max = h.t;
                best = Some(PreliminaryHit {
                    t: h.t,
                    geom: *geom,
                    prim: 0,
                    u: h.u,
                    v: h.v,
                });
            }
        }
        best
    }

    /// Whether any root shape is hit in `(ray.t_min, ray.t_max)`.
    #[inline]
    pub fn any_hit(&self, ray: &Ray) -> bool {
        if !self.quads.is_empty() {
            let r = SplatRay::new(ray);
            if self.quads.iter().any(|p| p.intersect(&r, ray.t_max).0 != 0) {
                return true;
            }
        }
        self.others
            .iter()
            .any(|(_, g)| g.intersect(0, ray).is_some())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Quad, Sphere};
    use crate::math::Vec3;
    use crate::sampling::{uniform_sphere, Rng};

    fn quad(p0: Vec3, e1: Vec3, e2: Vec3) -> Shape {
        Shape::new(Geometry::Quad(Quad::new(p0, e1, e2).unwrap()), 0)
    }

    fn sphere(center: Vec3, radius: f32) -> Shape {
        Shape::new(Geometry::Sphere(Sphere { center, radius }), 0)
    }

    /// A closed box of six quads with two large spheres inside.
    fn cornell() -> Vec<Shape> {
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
    fn brute(shapes: &[Shape], ray: &Ray) -> Option<(f32, u32)> {
        let mut r = *ray;
        let mut best = None;
        for (geom, s) in shapes.iter().enumerate() {
            if let Some(h) = s.geometry.intersect(0, &r) {
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

    #[test]
    fn many_quads_and_small_spheres_go_into_the_trees() {
        let mut shapes = cornell();
        let (_, in_root) = RootShapes::of(&shapes);
        assert_eq!(in_root.iter().filter(|&&r| r).count(), 8);
        // Three more quads: nine in all, beyond two packs.
        for k in 0..3 {
            let p = Vec3::new(-0.9 + 0.5 * k as f32, 0.01, -0.9);
            shapes.push(quad(p, 0.1 * Vec3::Z, 0.1 * Vec3::X));
        }
        shapes.push(sphere(Vec3::new(0.0, 1.5, 0.0), 0.05));
        let (_, in_root) = RootShapes::of(&shapes);
        let kinds: Vec<_> = shapes
            .iter()
            .map(|s| s.geometry.name())
            .zip(in_root)
            .collect();
        for (name, at_root) in &kinds[..6] {
            assert_eq!((*name, *at_root), ("quad", false));
        }
        assert_eq!(kinds[6..8], [("sphere", true), ("sphere", true)]);
        assert_eq!(kinds[11], ("sphere", false), "a small sphere");
    }
}
