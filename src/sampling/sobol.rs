//! Owen-scrambled Sobol' points in two dimensions, with the order of the
//! points shuffled too (Burley 2020, "Practical Hash-based Owen
//! Scrambling", JCGT 9(4)).
//!
//! The first two Sobol' dimensions form a (0,2)-sequence: every aligned
//! block of 2^m consecutive points, the first 2^m included, has exactly one
//! point in each elementary interval of area 2^-m. A nested uniform (Owen)
//! scramble keeps that and makes each point uniformly distributed; shuffling
//! the index with the same kind of scramble maps the first 2^m indices to
//! some aligned block of 2^m, so every power-of-two prefix stays a net,
//! while each seed gives another order. That is what lets pairs of
//! dimensions with different seeds be combined ("padded") without the
//! correlation identical orders would bring.
//!
//! Dimension 0 is the van der Corput sequence, whose generator matrix is the
//! bit reversal. Dimension 1's generator matrix is derived here from its
//! primitive polynomial and initial direction numbers as Joe and Kuo give
//! them (S. Joe, F. Y. Kuo, "Constructing Sobol sequences with better
//! two-dimensional projections", SIAM J. Sci. Comput. 30, 2008; the file
//! new-joe-kuo-6.21201 at https://web.maths.unsw.edu.au/~fkuo/sobol/, its
//! first line `2 1 0 1`). Padding needs no other dimension.

// The Laine–Karras style hash that pbrt-v4's `FastOwenScrambler` uses is
// `premix` followed by `laine_karras_seeded`: a bijection on u32 in which
// output bit j is input bit j flipped by a function of the bits below it
// and of the seed. On bit-reversed values that is a nested uniform (Owen)
// scramble: each digit is flipped depending on the digits before it. The
// index shuffles use it as it is; the points' scrambles take its first step
// without carries (`linear_premix`), which `MATRIX_BYTES` applies for free.

/// The hash's first step, the one that does not depend on the seed: the
/// index shuffles of all of a sample's dimensions take the same reversed
/// index, so they share it ([`Index`]).
#[inline(always)]
fn premix(v: u32) -> u32 {
    v ^ v.wrapping_mul(PREMIX)
}

const PREMIX: u32 = 0x3d20_adea;

/// `premix` with its multiply carry-less: still bit j flipped by bits below
/// it (the constant is even), and linear over XOR, so that it commutes with
/// the table lookups of `both_reversed` and costs nothing there.
const fn linear_premix(v: u32) -> u32 {
    let mut r = v;
    let mut k = 1;
    while k < 32 {
        if (PREMIX >> k) & 1 == 1 {
            r ^= v << k;
        }
        k += 1;
    }
    r
}

/// The rest of the hash, on a value that went through `premix` or
/// `linear_premix`.
#[inline(always)]
fn laine_karras_seeded(mut v: u32, s: Scramble) -> u32 {
    v = v.wrapping_add(s.seed);
    v = v.wrapping_mul(s.odd);
    v ^= v.wrapping_mul(0x0552_6c56);
    v ^= v.wrapping_mul(0x53a2_2864);
    v
}

/// One Laine–Karras hash's seed, with its odd multiplier.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Scramble {
    seed: u32,
    odd: u32,
}

/// The odd multiplier pbrt-v4 derives from a seed: its high bits, so that
/// it does not depend on the bits the seed adds at the bottom.
#[inline(always)]
const fn odd_of(seed: u32) -> u32 {
    (seed >> 16) | 1
}

impl Scramble {
    /// pbrt-v4's: the multiplier derived from the seed itself.
    #[cfg(test)]
    const fn new(seed: u32) -> Self {
        Self {
            seed,
            odd: odd_of(seed),
        }
    }
}

/// A sample index as the pairs of dimensions take it: bit-reversed, and for
/// the shuffles also through their hash's seed-independent first step.
/// Computed once per sample, not once per dimension.
#[derive(Clone, Copy, Debug)]
pub struct Index {
    reversed: u32,
    premixed: u32,
}

impl Index {
    #[inline]
    pub fn new(index: u32) -> Self {
        let reversed = index.reverse_bits();
        Self {
            reversed,
            premixed: premix(reversed),
        }
    }
}

/// Direction numbers of a Sobol' dimension as 32-bit fractions, column k
/// being m_(k+1) / 2^(k+1): the dimension's primitive polynomial has degree
/// `degree` and inner coefficients `a` (a_1 … a_(degree-1), a_1 the most
/// significant bit), `m` holds its initial direction numbers. Bratley and
/// Fox's recurrence gives the rest: m_k = 2 a_1 m_(k-1) ⊕ 4 a_2 m_(k-2) ⊕ …
/// ⊕ 2^s m_(k-s) ⊕ m_(k-s).
const fn generator_columns(degree: usize, a: u32, m: &[u32]) -> [u32; 32] {
    let mut mk = [0u32; 32];
    let mut k = 0;
    while k < 32 {
        mk[k] = if k < degree {
            m[k]
        } else {
            let mut v = mk[k - degree] ^ (mk[k - degree] << degree);
            let mut i = 1;
            while i < degree {
                if (a >> (degree - 1 - i)) & 1 == 1 {
                    v ^= mk[k - i] << i;
                }
                i += 1;
            }
            v
        };
        k += 1;
    }
    let mut columns = [0u32; 32];
    let mut k = 0;
    while k < 32 {
        columns[k] = mk[k] << (31 - k);
        k += 1;
    }
    columns
}

/// Dimension 1: the polynomial x + 1 (degree 1, no inner coefficient),
/// m_1 = 1.
const DIMENSION_1: [u32; 32] = generator_columns(1, 0, &[1]);

/// Both dimensions' matrices times the shuffled index `i`, read from the
/// bits of `reverse_bits(i)` (what the shuffle's hash puts out) eight at a
/// time, with the results bit-reversed (what the scrambles' hash takes in):
/// entry `[k][b]` is what byte `k + 1` of the reversed index contributes,
/// dimension 0 in the low 32 bits, dimension 1 in the high 32, each through
/// `linear_premix`, the scrambles' first step. Dimension 0's reversed value
/// is `i` itself, so this table is also the reversal between the two
/// hashes, and both dimensions cost the same three lookups.
///
/// Byte 0 of the reversed index, bits 24–31 of `i`, is left out. Those bits
/// reach dimension 0 only below the 24 bits its float keeps (each hash
/// flips a bit by the bits below it in the reversed domain). In dimension
/// 1 they flip digits throughout, but the shuffle maps the sample indices
/// below 2^24 into one aligned block of 2^24, where they are the same for
/// every sample: leaving them out is one digital shift (an XOR common to
/// all of the pixel's points) before the scramble, which keeps the net and
/// is as random. Past 2^24 samples a pixel's points repeat, as its floats
/// in dimension 0 already do.
const MATRIX_BYTES: [[u64; 256]; 3] = matrix_bytes(&DIMENSION_1);

const fn matrix_bytes(dimension_1: &[u32; 32]) -> [[u64; 256]; 3] {
    let mut t = [[0u64; 256]; 3];
    let mut k = 0;
    while k < 3 {
        let byte = k + 1;
        let mut b = 0;
        while b < 256 {
            let mut v = 0u64;
            let mut bit = 0;
            while bit < 8 {
                if (b >> bit) & 1 == 1 {
                    // Bit 8 byte + bit of the reversed index is bit q of i.
                    let q = 31 - (8 * byte + bit);
                    let x = linear_premix(1 << q) as u64;
                    let y = linear_premix(dimension_1[q].reverse_bits()) as u64;
                    v ^= x | (y << 32);
                }
                bit += 1;
            }
            t[k][b] = v;
            b += 1;
        }
        k += 1;
    }
    t
}

/// Dimensions 0 (low 32 bits) and 1 (high 32 bits) of the shuffled index
/// whose bits, reversed, are `reversed_index`, its bits 24–31 left out
/// (`MATRIX_BYTES`), each bit-reversed and through `linear_premix`.
#[inline]
fn both_reversed(reversed_index: u32) -> u64 {
    let [_, b1, b2, b3] = reversed_index.to_le_bytes();
    let t = &TABLES.matrix;
    t[0][b1 as usize] ^ t[1][b2 as usize] ^ t[2][b3 as usize]
}

/// `UNIT_BYTES[k][b]` is byte `k` of a bit-reversed 32-bit fraction, put
/// back in order, as an f32: the three low bytes are the fraction's top 24
/// bits, and their three values have no bit in common, so their sum is
/// exact and equals `to_unit` of the reversal. Three lookups and two
/// additions instead of a bit reversal, which x86-64 has no instruction
/// for.
const UNIT_BYTES: [[f32; 256]; 3] = unit_bytes();

const fn unit_bytes() -> [[f32; 256]; 3] {
    let mut t = [[0f32; 256]; 3];
    let mut byte = 0;
    while byte < 3 {
        let mut b = 0;
        while b < 256 {
            t[byte][b] = to_unit(((b as u32) << (8 * byte)).reverse_bits());
            b += 1;
        }
        byte += 1;
    }
    t
}

/// Both tables in one static: a position-independent executable reaches a
/// static through its address in the global offset table, one load per
/// static, so a point that reads both tables pays that load once.
struct Tables {
    matrix: [[u64; 256]; 3],
    unit: [[f32; 256]; 3],
    pair_keys: [u64; PAIRS],
}

static TABLES: Tables = Tables {
    matrix: MATRIX_BYTES,
    unit: UNIT_BYTES,
    pair_keys: pair_keys(),
};

/// `to_unit(reversed.reverse_bits())`.
#[inline]
fn unit_of_reversed(reversed: u32) -> f32 {
    let [b0, b1, b2, _] = reversed.to_le_bytes();
    let t = &TABLES.unit;
    t[0][b0 as usize] + (t[1][b1 as usize] + t[2][b2 as usize])
}

/// The seeds of one pair of dimensions: the index shuffle and one scramble
/// per dimension (a 1D decision uses `shuffle` and `x`).
#[derive(Clone, Copy, Debug, Default)]
pub struct Seeds {
    pub shuffle: Scramble,
    pub x: Scramble,
    pub y: Scramble,
}

/// Pairs of dimensions that draw Sobol' points ([`seeds`]): the sampler's
/// camera pair and four decisions at each of its first 16 path vertices.
pub const PAIRS: usize = 65;

/// Odd constant that spreads ids (pairs, sample indices, seeds) over 64
/// bits before they are mixed.
pub const SPREAD: u64 = 0x9e37_79b9_7f4a_7c15;

/// Odd constant of the seeds' multiply (Pelle Evensen's rrmxmx).
const MIX: u64 = 0x9fb2_1c65_1e98_df25;

/// `(pair + 1) · SPREAD`: each pair's key, looked up rather than
/// multiplied out per decision.
const fn pair_keys() -> [u64; PAIRS] {
    let mut keys = [0; PAIRS];
    let mut pair = 0;
    while pair < PAIRS {
        keys[pair] = (pair as u64 + 1).wrapping_mul(SPREAD);
        pair += 1;
    }
    keys
}

/// The seeds of pair `pair` (below [`PAIRS`]) of the pixel whose key is
/// `pixel`, a full 64-bit hash: the same for every sample, so that all
/// samples of the pixel are points of one sequence. One multiply and one
/// fold tell the pairs apart (the shuffles of two pairs must not be
/// related, or their points would be correlated); a second multiply by an
/// odd constant mixes every bit into the high half, a third seed. The
/// three hashes share `x`'s multiplier, derived as pbrt-v4 derives it:
/// each hash's multiplier still varies from pair to pair and pixel to
/// pixel, and is not its own seed's low bits. What a decision does not use
/// (the camera's shuffle, a 1D decision's `y`) the compiler leaves out.
#[inline(always)]
pub fn seeds(pixel: u64, pair: usize) -> Seeds {
    let product = (pixel ^ TABLES.pair_keys[pair]) as u128 * MIX as u128;
    let (high, low) = ((product >> 64) as u64, product as u64);
    let x = (high >> 32) as u32;
    let odd = odd_of(x);
    Seeds {
        shuffle: Scramble {
            seed: high as u32,
            odd,
        },
        x: Scramble { seed: x, odd },
        y: Scramble {
            seed: (low >> 32) as u32,
            odd,
        },
    }
}

/// The point of sample `index` in the shuffled, scrambled (0,2)-sequence,
/// in [0, 1)².
///
/// The whole way is in the bit-reversed domain: the shuffle's hash takes
/// the reversed index and gives the reversed shuffled index, one table
/// turns that into both dimensions' reversed values, the scrambles' hashes
/// take those, and the floats are read off the reversed results. No bit is
/// reversed but the sample index, once per sample ([`Index`]).
#[inline]
pub fn point_2d(index: Index, seeds: &Seeds) -> (f32, f32) {
    let shuffled = laine_karras_seeded(index.premixed, seeds.shuffle);
    scrambled_2d(both_reversed(shuffled), seeds.x, seeds.y)
}

/// `point_2d` without the shuffle: the points in sample order. One pair of
/// dimensions may keep that order, since every other pair's shuffle makes
/// its order unrelated to it; the camera's does, which saves a hash per
/// sample.
#[inline]
pub fn point_2d_in_order(index: Index, x: Scramble, y: Scramble) -> (f32, f32) {
    scrambled_2d(both_reversed(index.reversed), x, y)
}

#[inline(always)]
fn scrambled_2d(both: u64, x: Scramble, y: Scramble) -> (f32, f32) {
    let x = laine_karras_seeded(both as u32, x);
    let y = laine_karras_seeded((both >> 32) as u32, y);
    (unit_of_reversed(x), unit_of_reversed(y))
}

/// The point of sample `index` in the shuffled, scrambled van der Corput
/// sequence: a (0,1)-sequence, stratified in every power-of-two prefix.
#[inline]
pub fn point_1d(index: Index, seeds: &Seeds) -> f32 {
    let shuffled = laine_karras_seeded(index.premixed, seeds.shuffle);
    unit_of_reversed(laine_karras_seeded(both_reversed(shuffled) as u32, seeds.x))
}

/// A 32-bit fraction as an f32 in [0, 1), rounded down to 24 bits.
#[inline]
pub const fn to_unit(v: u32) -> f32 {
    (v >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Sobol' dimension 1 multiplied out bit by bit, as pbrt-v4's
    /// `SobolSample` does.
    fn dimension_1(mut index: u32) -> u32 {
        let mut v = 0;
        for column in DIMENSION_1 {
            if index & 1 == 1 {
                v ^= column;
            }
            index >>= 1;
        }
        v
    }

    #[test]
    fn dimension_1_matches_joe_kuo_as_pbrt_tabulates_it() {
        // pbrt-v4, src/pbrt/util/sobolmatrices.cpp, the second dimension.
        let pbrt = [
            0x8000_0000u32,
            0xc000_0000,
            0xa000_0000,
            0xf000_0000,
            0x8800_0000,
            0xcc00_0000,
            0xaa00_0000,
            0xff00_0000,
            0x8080_0000,
            0xc0c0_0000,
            0xa0a0_0000,
            0xf0f0_0000,
            0x8888_0000,
            0xcccc_0000,
            0xaaaa_0000,
            0xffff_0000,
        ];
        assert_eq!(DIMENSION_1[..16], pbrt);
        // Pascal's triangle mod 2: the last column is all ones.
        assert_eq!(DIMENSION_1[31], u32::MAX);
    }

    /// pbrt-v4's `FastOwenScrambler` in one piece, as `premix`,
    /// `Scramble::new` and `laine_karras_seeded` split it, but with the
    /// multiplier `odd` given (pbrt-v4's is `odd_of(seed)`); `carries:
    /// false` takes the first multiply without carries, as the points'
    /// scrambles do.
    fn whole_laine_karras(mut v: u32, seed: u32, odd: u32, carries: bool) -> u32 {
        v ^= if carries {
            v.wrapping_mul(0x3d20_adea)
        } else {
            (0..32)
                .filter(|k| (0x3d20_adea >> k) & 1 == 1)
                .fold(0, |r, k| r ^ (v << k))
        };
        v = v.wrapping_add(seed);
        v = v.wrapping_mul(odd);
        v ^= v.wrapping_mul(0x0552_6c56);
        v ^= v.wrapping_mul(0x53a2_2864);
        v
    }

    /// The shuffled index of the sample index whose bits, reversed, are
    /// `reversed`. In the index, bit j is flipped by a function of the bits
    /// above it, so the indices below 2^m go to one aligned block of 2^m.
    /// `point_2d` never forms it: its table reads the hash's output
    /// directly.
    fn shuffle(reversed: u32, seed: u32, odd: u32) -> u32 {
        whole_laine_karras(reversed, seed, odd, true).reverse_bits()
    }

    /// The points as they were computed before the tables: three bit
    /// reversals per pair, dimension 1 multiplied out bit by bit, each hash
    /// in one piece, all with the multiplier `odd`; `shuffled: false` as
    /// `point_2d_in_order`. Dimension 0 takes the whole shuffled index, to
    /// check that its bits 24–31 do not reach the float; dimension 1 leaves
    /// them out, as `MATRIX_BYTES` does.
    fn point_2d_by_reversals(
        reversed: u32,
        [shuffle_seed, x, y]: [u32; 3],
        odd: u32,
        shuffled: bool,
    ) -> (f32, f32) {
        let i = if shuffled {
            shuffle(reversed, shuffle_seed, odd)
        } else {
            reversed.reverse_bits()
        };
        let x = whole_laine_karras(i, x, odd, false).reverse_bits();
        let kept = i & 0x00ff_ffff;
        let y = whole_laine_karras(dimension_1(kept).reverse_bits(), y, odd, false);
        (to_unit(x), to_unit(y.reverse_bits()))
    }

    #[test]
    fn the_tables_compute_what_the_reversals_do() {
        let t = &MATRIX_BYTES;
        for index in [0u32, 1, 2, 3, 255, 256, 0x1234_5678, u32::MAX] {
            let v = both_reversed(index.reverse_bits());
            let kept = index & 0x00ff_ffff;
            assert_eq!(v as u32, linear_premix(kept), "{index:#x}");
            let y = linear_premix(dimension_1(kept).reverse_bits());
            assert_eq!((v >> 32) as u32, y);
            for x in [index, index.wrapping_mul(0x9e37_79b9)] {
                assert_eq!(unit_of_reversed(x), to_unit(x.reverse_bits()), "{x:#x}");
            }
        }
        // Index bit 0: both dimensions' reversed value 1, premixed.
        let one = linear_premix(1) as u64;
        assert_eq!(t[2][0x80], one | one << 32, "index bit 0");
        let mut h = 1u64;
        for k in 0..10_000u32 {
            h = h
                .wrapping_mul(0x5851_f42d_4c95_7f2d)
                .wrapping_add(1442695040888963407);
            let raw = [(h >> 32) as u32, h as u32, (h >> 16) as u32];
            let odd = odd_of(h.rotate_left(7) as u32);
            let scramble = |seed| Scramble { seed, odd };
            let seeds = Seeds {
                shuffle: scramble(raw[0]),
                x: scramble(raw[1]),
                y: scramble(raw[2]),
            };
            let index = k.wrapping_mul(0x2545_f491);
            let by_reversals = point_2d_by_reversals(index.reverse_bits(), raw, odd, true);
            assert_eq!(point_2d(Index::new(index), &seeds), by_reversals);
            assert_eq!(point_1d(Index::new(index), &seeds), by_reversals.0);
            let in_order = point_2d_by_reversals(index.reverse_bits(), raw, odd, false);
            let (x, y) = (seeds.x, seeds.y);
            assert_eq!(point_2d_in_order(Index::new(index), x, y), in_order);
        }
    }

    #[test]
    fn both_hashes_flip_each_bit_by_the_bits_below_only() {
        // Changing bit j of the input leaves every bit below j as it was.
        let shuffle = |v, s| laine_karras_seeded(premix(v), s);
        let scramble = |v, s| laine_karras_seeded(linear_premix(v), s);
        for seed in [0u32, 1, 0xdead_beef] {
            for v in [0u32, 0x1234_5678, u32::MAX] {
                let s = Scramble::new(seed);
                for (hash, carries) in [
                    (&shuffle as &dyn Fn(u32, Scramble) -> u32, true),
                    (&scramble, false),
                ] {
                    let out = hash(v, s);
                    assert_eq!(out, whole_laine_karras(v, seed, odd_of(seed), carries));
                    for j in 0..32 {
                        let changed = hash(v ^ (1 << j), s);
                        let below = (1u64 << j) as u32 - 1;
                        assert_eq!(out & below, changed & below);
                        assert_ne!(out & (1 << j), changed & (1 << j));
                    }
                }
            }
        }
    }

    #[test]
    fn the_shuffle_maps_power_of_two_prefixes_to_aligned_blocks() {
        for seed in [3u32, 0x9e37_79b9] {
            for m in 0..10 {
                let n = 1u32 << m;
                let mut shuffled: Vec<u32> = (0..n)
                    .map(|i| shuffle(i.reverse_bits(), seed, odd_of(seed)))
                    .collect();
                shuffled.sort_unstable();
                let start = shuffled[0];
                assert_eq!(start % n, 0, "aligned");
                assert!(shuffled
                    .iter()
                    .enumerate()
                    .all(|(k, &i)| i == start + k as u32));
            }
        }
    }
}
