//! The shapes `Accel` tests itself, beside the root of either backend's
//! tree: a scene's infinite planes, and its analytic shapes (quads,
//! spheres, cuboids) when there are few of them.
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

use super::Hit;
use crate::math::Ray;
use crate::scene::{Geometry, Shape};
use crate::simd::F4;

/// Analytic shapes beyond this many go into the backends' trees instead.
/// Measured on grids of quads (docs/performance.md): the root's linear
/// test of ⌈n/4⌉ packs beats a tree walk up to about this size.
pub const ROOT_LIMIT: usize = 16;

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
        let analytic = shapes
            .iter()
            .filter(|s| !matches!(s.geometry, Geometry::Mesh(_) | Geometry::Plane(_)))
            .count();
        let at_root = |g: &Geometry| match g {
            Geometry::Plane(_) => true,
            Geometry::Mesh(_) => false,
            _ => analytic <= ROOT_LIMIT,
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
    pub fn closest(&self, ray: &Ray) -> Option<Hit> {
        let mut best: Option<Hit> = None;
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
                        best = Some(Hit {
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
                best = Some(Hit {
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
