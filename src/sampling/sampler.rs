//! The numbers one sample of one pixel consumes, from either sampler.
//!
//! Both are pure functions of (seed, pixel, sample index, dimension), so an
//! image does not depend on threads, parts merge exactly and checkpoints
//! resume bit for bit. The integrator asks for its numbers by what they
//! decide, at which path vertex ([`Dimension`]); the Sobol' sampler turns
//! that into a fixed pair of dimensions, so the camera and the first
//! vertices, whose decisions matter most, get the stratified ones.

use super::sobol::{self, SPREAD};
use super::{splitmix64, Rng};
use crate::math::Vec2;

/// Which numbers samples draw.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum SamplerKind {
    /// Independent uniform numbers (PCG32), one stream per sample.
    Independent,
    /// Owen-scrambled, shuffled Sobol' (0,2)-sequences per pixel, one per
    /// pair of dimensions (padded); independent numbers past
    /// [`SOBOL_VERTICES`].
    #[default]
    Sobol,
}

impl SamplerKind {
    pub const ALL: [SamplerKind; 2] = [Self::Independent, Self::Sobol];

    pub fn name(self) -> &'static str {
        match self {
            Self::Independent => "independent",
            Self::Sobol => "sobol",
        }
    }
}

impl std::str::FromStr for SamplerKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        crate::names::parse(s, &Self::ALL, Self::name, "sampler")
    }
}

/// What a path vertex's numbers decide, in the order of their dimensions.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Dimension {
    /// Which lobe to follow (or absorption): 1D.
    Lobe = 0,
    /// Which emitter next-event estimation samples: 1D.
    LightPick = 1,
    /// The point on that emitter: 2D.
    LightPoint = 2,
    /// The direction the path continues in: 2D.
    Direction = 3,
}

const PER_VERTEX: u32 = 4;

/// Path vertices whose numbers come from Sobol' points; the later ones
/// draw hashed independent numbers. Beyond a few bounces Russian roulette
/// and the earlier choices leave little structure for stratification to
/// exploit, and the limit keeps a dimension's id small.
pub const SOBOL_VERTICES: u32 = 16;

/// The numbers of one sample of one pixel.
#[derive(Clone, Debug)]
pub enum Sampler {
    /// One PCG32 stream, read in the order the integrator asks: the
    /// dimension is ignored, which keeps the images of before samplers
    /// existed.
    Independent(Rng),
    Sobol(SobolSample),
}

/// No vertex: in u64, so that every u32 vertex differs from it.
const NONE_AHEAD: u64 = u64::MAX;

/// Sample `index` of the pixel whose hash is `pixel`.
#[derive(Clone, Debug)]
pub struct SobolSample {
    pixel: u64,
    index: u32,
    /// `index` as every dimension's shuffle takes it, computed once.
    shuffle_input: sobol::Index,
    /// The light point and the direction `draw_ahead` computed, each with
    /// its vertex (`NONE_AHEAD`: none).
    light_ahead: (u64, Vec2),
    direction_ahead: (u64, Vec2),
}

impl Sampler {
    pub fn for_sample(kind: SamplerKind, seed: u64, x: u32, y: u32, sample: u32) -> Self {
        match kind {
            SamplerKind::Independent => Self::Independent(Rng::for_sample(seed, x, y, sample)),
            SamplerKind::Sobol => Self::Sobol(SobolSample {
                pixel: pixel_key(seed, x, y),
                index: sample,
                shuffle_input: sobol::Index::new(sample),
                light_ahead: (NONE_AHEAD, Vec2::ZERO),
                direction_ahead: (NONE_AHEAD, Vec2::ZERO),
            }),
        }
    }

    /// The position within the pixel.
    #[inline]
    pub fn camera(&mut self) -> Vec2 {
        match self {
            Self::Independent(rng) => rng.next_2d(),
            Self::Sobol(s) => s.camera(),
        }
    }

    /// A number in [0, 1) for a 1D decision at path vertex `vertex` (0: the
    /// camera ray's hit).
    #[inline]
    pub fn get_1d(&mut self, vertex: u32, dim: Dimension) -> f32 {
        match self {
            Self::Independent(rng) => rng.next_f32(),
            Self::Sobol(s) => s.get_1d(vertex, dim),
        }
    }

    /// A 1D decision the integrator does not need here (one lobe, one
    /// emitter). The independent stream still takes its number, so its
    /// order, and its images, stay those of before; Sobol' dimensions are
    /// addressed, not read in order, so nothing is computed.
    #[inline]
    pub fn skip_1d(&mut self) {
        if let Self::Independent(rng) = self {
            rng.next_f32();
        }
    }

    /// A point in [0, 1)² for a 2D decision at path vertex `vertex`.
    #[inline(always)]
    pub fn get_2d(&mut self, vertex: u32, dim: Dimension) -> Vec2 {
        match self {
            Self::Independent(rng) => rng.next_2d(),
            Self::Sobol(s) => {
                let ahead = match dim {
                    Dimension::LightPoint => s.light_ahead,
                    Dimension::Direction => s.direction_ahead,
                    Dimension::Lobe | Dimension::LightPick => (NONE_AHEAD, Vec2::ZERO),
                };
                if ahead.0 == vertex as u64 {
                    ahead.1
                } else {
                    s.point_2d_late(vertex, dim)
                }
            }
        }
    }

    /// Computes vertex `vertex`'s direction, and its light point if
    /// `light`, before the integrator asks for them, so that their chains
    /// of multiplies run while the ray to the vertex is traced: a Sobol'
    /// point does not depend on the path. The independent stream is read
    /// in order and draws nothing here.
    #[inline]
    pub fn draw_ahead(&mut self, vertex: u32, light: bool) {
        if let Self::Sobol(s) = self {
            if vertex < SOBOL_VERTICES {
                s.draw_ahead(vertex, light);
            }
        }
    }
}

/// The id of a decision's dimensions: 0 is the camera, then four per
/// vertex. In u64, since a path may have up to 2^32 vertices.
#[inline]
fn slot(vertex: u32, dim: Dimension) -> u64 {
    1 + vertex as u64 * PER_VERTEX as u64 + dim as u64
}

// The covered vertices' slots are the Sobol' pairs, one each.
const _: () = assert!(1 + SOBOL_VERTICES as usize * PER_VERTEX as usize == sobol::PAIRS);

#[inline]
fn pixel_key(seed: u64, x: u32, y: u32) -> u64 {
    // One hash of the pixel and the seed's multiple, rather than one of the
    // pixel and another of that and the seed. Two (seed, pixel) pairs share
    // a key only where the seeds' multiples differ in the pixel
    // coordinates' bits alone (0-15 and 32-47 below 65,536 pixels a side):
    // about one pair of seeds in 2^32.
    let pixel = ((y as u64) << 32) | x as u64;
    splitmix64(pixel ^ seed.wrapping_mul(SPREAD))
}

impl SobolSample {
    /// The hash of this pixel's dimensions `slot`: the same for every
    /// sample, so all samples of the pixel are points of one sequence.
    #[inline]
    fn slot_hash(&self, slot: u64) -> u64 {
        splitmix64(self.pixel ^ (slot + 1).wrapping_mul(SPREAD))
    }

    /// Independent numbers of this sample for `slot`, past the covered
    /// ones.
    #[inline]
    fn hashed(&self, slot: u64) -> u64 {
        let key = self.slot_hash(slot) ^ (self.index as u64 + 1).wrapping_mul(SPREAD);
        splitmix64(key)
    }

    /// Past the covered vertices (rare): out of line, so that the Sobol'
    /// points can be inlined where the integrator asks for them.
    #[cold]
    #[inline(never)]
    fn hashed_1d(&self, slot: u64) -> f32 {
        sobol::to_unit(self.hashed(slot) as u32)
    }

    #[cold]
    #[inline(never)]
    fn hashed_2d(&self, slot: u64) -> Vec2 {
        let h = self.hashed(slot);
        Vec2::new(sobol::to_unit(h as u32), sobol::to_unit((h >> 32) as u32))
    }

    /// Out of line: inlined, it made the integrator's loop compile worse
    /// for both samplers. The caller checks the vertex is covered: past
    /// those, the hashed numbers are rare and out of line. (The check made
    /// here instead counted 32 more instructions per cornell-area sample.)
    #[inline(never)]
    fn draw_ahead(&mut self, vertex: u32, light: bool) {
        if light {
            self.light_ahead = (vertex as u64, self.point_2d(vertex, Dimension::LightPoint));
        }
        self.direction_ahead = (vertex as u64, self.point_2d(vertex, Dimension::Direction));
    }

    /// A point not drawn ahead (rare: past the covered vertices, or a
    /// light point where `draw_ahead` was told no light is sampled).
    #[cold]
    #[inline(never)]
    fn point_2d_late(&self, vertex: u32, dim: Dimension) -> Vec2 {
        self.point_2d(vertex, dim)
    }

    /// The seeds of a decision at a covered vertex. The callers check the
    /// vertex rather than the slot: that bounds the slot's table index too,
    /// and the index folds into the lookup's address.
    #[inline(always)]
    fn seeds(&self, vertex: u32, dim: Dimension) -> sobol::Seeds {
        debug_assert!(vertex < SOBOL_VERTICES);
        sobol::seeds(self.pixel, slot(vertex, dim) as usize)
    }

    #[inline(always)]
    fn get_1d(&self, vertex: u32, dim: Dimension) -> f32 {
        if vertex >= SOBOL_VERTICES {
            return self.hashed_1d(slot(vertex, dim));
        }
        sobol::point_1d(self.shuffle_input, &self.seeds(vertex, dim))
    }

    /// The camera's pair, slot 0, in sample order: it needs no shuffle
    /// (`sobol::point_2d_in_order`).
    #[inline(always)]
    fn camera(&self) -> Vec2 {
        let seeds = sobol::seeds(self.pixel, 0);
        let (x, y) = sobol::point_2d_in_order(self.shuffle_input, seeds.x, seeds.y);
        Vec2::new(x, y)
    }

    #[inline(always)]
    fn point_2d(&self, vertex: u32, dim: Dimension) -> Vec2 {
        if vertex >= SOBOL_VERTICES {
            return self.hashed_2d(slot(vertex, dim));
        }
        let (x, y) = sobol::point_2d(self.shuffle_input, &self.seeds(vertex, dim));
        Vec2::new(x, y)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const SOBOL: SamplerKind = SamplerKind::Sobol;

    /// The 2D decisions of the camera and of vertices near and at the end of
    /// the covered ones, each as a function of the sample index.
    type TwoD = fn(&mut Sampler) -> Vec2;

    fn pairs() -> Vec<(&'static str, TwoD)> {
        vec![
            ("camera", |s| s.camera()),
            ("light point 0", |s| s.get_2d(0, Dimension::LightPoint)),
            ("direction 0", |s| s.get_2d(0, Dimension::Direction)),
            ("direction 3", |s| s.get_2d(3, Dimension::Direction)),
            ("light point 15", |s| {
                s.get_2d(SOBOL_VERTICES - 1, Dimension::LightPoint)
            }),
        ]
    }

    fn points(seed: u64, x: u32, y: u32, n: u32, f: TwoD) -> Vec<Vec2> {
        (0..n)
            .map(|i| f(&mut Sampler::for_sample(SOBOL, seed, x, y, i)))
            .collect()
    }

    /// Whether every elementary interval of area 1/len, of every shape
    /// 2^-a × 2^-(m-a), holds exactly one of `points`.
    fn is_02_net(points: &[Vec2]) -> bool {
        let m = points.len().trailing_zeros();
        (0..=m).all(|a| {
            let (nx, ny) = (1u32 << a, 1u32 << (m - a));
            let mut seen = vec![false; points.len()];
            points.iter().all(|p| {
                // Exact: the coordinates are multiples of 2^-24.
                let (i, j) = ((p.x * nx as f32) as u32, (p.y * ny as f32) as u32);
                let cell = (j * nx + i) as usize;
                !std::mem::replace(&mut seen[cell], true)
            })
        })
    }

    #[test]
    fn every_power_of_two_prefix_is_a_02_net_in_every_elementary_interval() {
        for (seed, x, y) in [(0, 0, 0), (7, 5, 3), (u64::MAX, 1023, 77)] {
            for (what, f) in pairs() {
                let all = points(seed, x, y, 1 << 10, f);
                for m in 0..=10 {
                    let prefix = &all[..1 << m];
                    assert!(is_02_net(prefix), "{what}, 2^{m} points, seed {seed}");
                }
            }
        }
    }

    #[test]
    fn one_dimensional_decisions_are_stratified() {
        type OneD = fn(&mut Sampler) -> f32;
        let decisions: [OneD; 3] = [
            |s| s.get_1d(0, Dimension::Lobe),
            |s| s.get_1d(0, Dimension::LightPick),
            |s| s.get_1d(9, Dimension::Lobe),
        ];
        for f in decisions {
            for m in [0, 3, 8] {
                let n = 1u32 << m;
                let mut seen = vec![false; n as usize];
                for i in 0..n {
                    let u = f(&mut Sampler::for_sample(SOBOL, 3, 2, 1, i));
                    let cell = (u * n as f32) as usize;
                    assert!(!std::mem::replace(&mut seen[cell], true), "2^{m} points");
                }
            }
        }
    }

    #[test]
    fn a_broken_net_is_noticed() {
        // The check itself: an unscrambled grid's 2^4 points fail it in the
        // 1 × 1/16 intervals.
        let grid: Vec<Vec2> = (0..16)
            .map(|i| Vec2::new((i % 4) as f32 / 4.0, (i / 4) as f32 / 4.0))
            .collect();
        assert!(!is_02_net(&grid));
    }

    #[test]
    fn pairs_of_dimensions_are_not_correlated() {
        // Without the shuffle, two pairs' points would come in the same
        // order and their first digits would agree or disagree together.
        let n = 1024;
        let (mut sxy, mut sx, mut sy, mut sxx, mut syy) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for i in 0..n {
            let mut s = Sampler::for_sample(SOBOL, 1, 2, 3, i);
            let a = s.get_1d(0, Dimension::Lobe) as f64;
            let b = s.get_2d(0, Dimension::Direction).x as f64;
            (sxy, sx, sy, sxx, syy) = (sxy + a * b, sx + a, sy + b, sxx + a * a, syy + b * b);
        }
        let n = n as f64;
        let cov = sxy / n - sx / n * sy / n;
        let r = cov / ((sxx / n - (sx / n).powi(2)) * (syy / n - (sy / n).powi(2))).sqrt();
        // Independent points: r has a standard deviation of 1/√n ≈ 0.03.
        assert!(r.abs() < 0.15, "correlation {r}");
    }

    #[test]
    fn points_are_a_pure_function_of_seed_pixel_sample_and_dimension() {
        let draw = |seed, x, sample| {
            let mut s = Sampler::for_sample(SOBOL, seed, x, 4, sample);
            let v = [
                s.camera(),
                s.get_2d(2, Dimension::Direction),
                s.get_2d(40, Dimension::Direction),
            ];
            (v, s.get_1d(0, Dimension::Lobe))
        };
        assert_eq!(draw(5, 3, 9), draw(5, 3, 9));
        for (seed, x, sample) in [(6, 3, 9), (5, 4, 9), (5, 3, 10)] {
            let (a, b) = (draw(5, 3, 9), draw(seed, x, sample));
            assert!((0..3).all(|k| a.0[k] != b.0[k]) && a.1 != b.1);
        }
        // Different seeds scramble differently: no point of 256 in common.
        for (_, f) in pairs() {
            let (a, b) = (points(1, 0, 0, 256, f), points(2, 0, 0, 256, f));
            assert!(a.iter().all(|p| !b.contains(p)));
        }
    }

    #[test]
    fn drawing_ahead_changes_no_number() {
        let fresh = |vertex, dim| Sampler::for_sample(SOBOL, 9, 4, 2, 6).get_2d(vertex, dim);
        let mut s = Sampler::for_sample(SOBOL, 9, 4, 2, 6);
        let last = SOBOL_VERTICES - 1;
        for (vertex, light) in [
            (0, true),
            (1, false),
            (last, true),
            (40, true),
            (u32::MAX, true),
        ] {
            s.draw_ahead(vertex, light);
            for v in [vertex, vertex.wrapping_add(1)] {
                for dim in [Dimension::LightPoint, Dimension::Direction] {
                    assert_eq!(s.get_2d(v, dim), fresh(v, dim), "vertex {v}, {dim:?}");
                }
            }
        }
        // The independent stream draws nothing ahead: its order is kept.
        let mut rng = Rng::for_sample(3, 1, 2, 5);
        let mut s = Sampler::for_sample(SamplerKind::Independent, 3, 1, 2, 5);
        s.draw_ahead(0, true);
        assert_eq!(s.get_2d(0, Dimension::Direction), rng.next_2d());
    }

    #[test]
    fn past_the_covered_vertices_numbers_are_hashed_per_dimension() {
        let mut s = Sampler::for_sample(SOBOL, 1, 1, 1, 1);
        let mut seen: Vec<f32> = Vec::new();
        for vertex in [SOBOL_VERTICES, SOBOL_VERTICES + 1, u32::MAX] {
            seen.push(s.get_1d(vertex, Dimension::Lobe));
            seen.push(s.get_1d(vertex, Dimension::LightPick));
            let p = s.get_2d(vertex, Dimension::Direction);
            seen.extend([p.x, p.y]);
        }
        assert!(seen.iter().all(|u| (0.0..1.0).contains(u)));
        for (i, u) in seen.iter().enumerate() {
            assert!(!seen[i + 1..].contains(u), "{seen:?}");
        }
    }

    #[test]
    fn the_independent_sampler_reads_the_stream_of_before() {
        let mut rng = Rng::for_sample(3, 1, 2, 5);
        let mut s = Sampler::for_sample(SamplerKind::Independent, 3, 1, 2, 5);
        assert_eq!(s.camera(), rng.next_2d());
        assert_eq!(s.get_1d(0, Dimension::Lobe), rng.next_f32());
        assert_eq!(s.get_2d(7, Dimension::Direction), rng.next_2d());
    }

    #[test]
    fn names_parse_back() {
        for k in SamplerKind::ALL {
            assert_eq!(k.name().parse::<SamplerKind>(), Ok(k));
        }
        assert!("halton".parse::<SamplerKind>().is_err());
    }
}
