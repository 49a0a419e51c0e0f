//! Four triangles tested at once: their vertices in lanes, and the ray in
//! the watertight test's frame, splatted.

use crate::accel::bvh::PADDING;
use crate::geometry::{exact_zeros, ShearedRay};
use crate::math::{Ray, Vec3};
use crate::simd::F4;

/// Four triangles: `p[v][c][k]` is coordinate `c` of vertex `v` of
/// triangle `k`; then their triangle numbers (`Triangles`), read only for
/// the final hit, from a cache line the test has already loaded. 160 bytes
/// on a 32-byte boundary: every pack spans three cache lines, as a 192-byte
/// pack on a line's boundary would, in a sixth less memory.
#[repr(C, align(32))]
#[derive(Clone, Copy, Debug)]
pub(super) struct TriPack {
    p: [[[f32; 4]; 3]; 3],
    pub(super) triangle: [u32; 4],
}

impl TriPack {
    /// NaN in every lane: no ray hits it, and no edge function of it is
    /// zero, so it never takes the f64 path.
    pub(super) const EMPTY: TriPack = TriPack {
        p: [[[f32::NAN; 4]; 3]; 3],
        triangle: [PADDING; 4],
    };

    /// Coordinate `c` of vertex `v` of the four, in lanes.
    #[inline(always)]
    pub(super) fn coord(&self, v: usize, c: usize) -> F4 {
        F4::load(&self.p[v][c])
    }

    pub(super) fn set(&mut self, k: usize, p: [Vec3; 3], triangle: u32) {
        self.triangle[k] = triangle;
        for (v, p) in p.iter().enumerate() {
            for c in 0..3 {
                self.p[v][c][k] = p[c];
            }
        }
    }
}

/// A ray in the watertight test's frame, splatted for pack tests.
pub struct PackRay {
    sheared: ShearedRay,
    origin: [F4; 3],
    dir: [F4; 3],
    s: [F4; 2],
    t_min: f32,
}

impl PackRay {
    #[inline(always)]
    pub(super) fn new(ray: &Ray) -> Self {
        let sheared = ShearedRay::new(ray);
        Self {
            origin: sheared.origin.to_array().map(F4::splat),
            dir: sheared.dir.to_array().map(F4::splat),
            s: sheared.s.map(F4::splat),
            sheared,
            t_min: ray.t_min,
        }
    }
}

/// `intersect_triangle` on four triangles, whose vertex `v` has coordinate
/// `c` in the lanes of `coord(v, c)`, with the same values: lane mask of
/// hits in `(t_min, t_max)` and their `t, u, v`.
#[inline(always)]
pub(super) fn intersect_pack(
    coord: impl Fn(usize, usize) -> F4,
    r: &PackRay,
    t_max: f32,
) -> (u32, F4, F4, F4) {
    let [kx, ky, kz] = r.sheared.k;
    let [sx, sy] = r.s;
    let frame = |v: usize| {
        let d = |c: usize| coord(v, c).sub(r.origin[c]);
        let (dx, dy, dz) = (d(kx), d(ky), d(kz));
        (dx.sub(sx.mul(dz)), dy.sub(sy.mul(dz)))
    };
    let (ax, ay) = frame(0);
    let (bx, by) = frame(1);
    let (cx, cy) = frame(2);
    let mut e0 = cx.mul(by).sub(cy.mul(bx));
    let mut e1 = ax.mul(cy).sub(ay.mul(cx));
    let mut e2 = bx.mul(ay).sub(by.mul(ax));
    let zero = F4::splat(0.0);
    // Lanes whose edge functions have both signs miss, whatever their zeros
    // (only zeros change in f64), and so do NaN (padding) lanes: most packs
    // end here.
    let one_sign_of = |e0: F4, e1: F4, e2: F4| {
        e0.min(e1).min(e2).ge(zero).bits() | e0.max(e1).max(e2).le(zero).bits()
    };
    let mut one_sign = one_sign_of(e0, e1, e2);
    if one_sign == 0 {
        return (0, zero, zero, zero);
    }
    let on_edge = one_sign & (e0.eq(zero).bits() | e1.eq(zero).bits() | e2.eq(zero).bits());
    if on_edge != 0 {
        let (mut f0, mut f1, mut f2) = (e0.to_array(), e1.to_array(), e2.to_array());
        let (ax, ay, bx, by, cx, cy) = (
            ax.to_array(),
            ay.to_array(),
            bx.to_array(),
            by.to_array(),
            cx.to_array(),
            cy.to_array(),
        );
        for k in (0..4).filter(|k| on_edge & (1 << k) != 0) {
            (f0[k], f1[k], f2[k]) = exact_zeros(
                (f0[k], f1[k], f2[k]),
                [ax[k], ay[k], bx[k], by[k], cx[k], cy[k]],
            );
        }
        (e0, e1, e2) = (F4::load(&f0), F4::load(&f1), F4::load(&f2));
        one_sign &= one_sign_of(e0, e1, e2);
    }
    let det = e0.add(e1).add(e2);
    let det_ok = det.ne(zero).and(det.abs().lt(F4::splat(f32::INFINITY)));
    // `plane_distance`, operation for operation.
    let vertex = |v: usize| [coord(v, 0), coord(v, 1), coord(v, 2)];
    let (p0, p1, p2) = (vertex(0), vertex(1), vertex(2));
    let u = [0, 1, 2].map(|c| p1[c].sub(p0[c]));
    let v = [0, 1, 2].map(|c| p2[c].sub(p0[c]));
    let n = [
        u[1].mul(v[2]).sub(u[2].mul(v[1])),
        u[2].mul(v[0]).sub(u[0].mul(v[2])),
        u[0].mul(v[1]).sub(u[1].mul(v[0])),
    ];
    let w = [0, 1, 2].map(|c| p0[c].sub(r.origin[c]));
    let dot = |a: [F4; 3]| a[0].mul(n[0]).add(a[1].mul(n[1])).add(a[2].mul(n[2]));
    let t = dot(w).div(dot(r.dir));
    let inv_det = F4::splat(1.0).div(det);
    let in_range = t.gt(F4::splat(r.t_min)).and(t.lt(F4::splat(t_max)));
    let mask = one_sign & det_ok.and(in_range).bits();
    (mask, t, e1.mul(inv_det), e2.mul(inv_det))
}

/// A triangle hit: its `t`, and its triangle number, `u` and `v`.
pub type Hit = (f32, (u32, f32, f32));

/// The nearest pack hit so far.
pub(super) struct Nearest {
    t_max: f32,
    pub(super) best: Option<Hit>,
}

impl Nearest {
    #[inline(always)]
    pub(super) fn below(t_max: f32) -> Self {
        Self { t_max, best: None }
    }

    #[inline(always)]
    pub(super) fn test(
        &mut self,
        coord: impl Fn(usize, usize) -> F4,
        triangle: &[u32; 4],
        r: &PackRay,
    ) {
        let (mask, t, u, v) = intersect_pack(coord, r, self.t_max);
        if mask == 0 {
            return;
        }
        let (t, u, v) = (t.to_array(), u.to_array(), v.to_array());
        // The first of the nearest lanes, as a scalar loop finds it.
        for k in 0..4 {
            if mask & (1 << k) != 0 && t[k] < self.t_max {
                self.t_max = t[k];
                self.best = Some((t[k], (triangle[k], u[k], v[k])));
            }
        }
    }
}
