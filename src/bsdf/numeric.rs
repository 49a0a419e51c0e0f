//! Special functions and quadrature that the microfacet models need: the
//! error function and its inverse (Beckmann's visible normals) and
//! Gauss–Legendre nodes (the rough plastic's precomputed transmittance).

/// The error function, by Abramowitz and Stegun 7.1.26 (absolute error 1.5e-7,
/// below 5e-7 with f32 rounding, asserted in the tests against a series).
pub fn erf(x: f32) -> f32 {
    let t = 1.0 / (1.0 + 0.327_591_1 * x.abs());
    let poly = t
        * (0.254_829_6
            + t * (-0.284_496_74 + t * (1.421_413_8 + t * (-1.453_152_1 + t * 1.061_405_4))));
    (1.0 - poly * (-x * x).exp()).copysign(x)
}

/// The inverse error function on (−1, 1), by M. Giles, "Approximating the
/// erfinv function" (GPU Computing Gems, 2011): single-precision accuracy
/// without a Newton step.
pub fn erfinv(x: f32) -> f32 {
    let w = -((1.0 - x) * (1.0 + x)).ln();
    let p = if w < 5.0 {
        let w = w - 2.5;
        [
            3.432_739_4e-7,
            -3.523_387_7e-6,
            -4.391_506_5e-6,
            2.185_808_7e-4,
            -1.253_725e-3,
            -4.177_681_6e-3,
            2.466_407_3e-1,
            1.501_409_4,
        ]
        .iter()
        .fold(2.810_226_4e-8, |p, c| c + p * w)
    } else {
        let w = w.sqrt() - 3.0;
        [
            1.009_505_6e-4,
            1.349_343_2e-3,
            -3.673_428_4e-3,
            5.739_507_7e-3,
            -7.622_461_3e-3,
            9.438_870_5e-3,
            1.001_674,
            2.832_976_8,
        ]
        .iter()
        .fold(-2.002_142_6e-4, |p, c| c + p * w)
    };
    p * x
}

/// The `n` nodes on [−1, 1] and weights of Gauss–Legendre quadrature,
/// found by Newton's method on the Legendre polynomial in f64.
pub fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    (0..n)
        .map(|i| {
            let mut x = (std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
            let mut derivative = 1.0;
            for _ in 0..100 {
                let (p, dp) = legendre(n, x);
                derivative = dp;
                let step = p / dp;
                x -= step;
                if step.abs() < 1e-15 {
                    break;
                }
            }
            (x, 2.0 / ((1.0 - x * x) * derivative * derivative))
        })
        .collect()
}

/// P_n(x) and its derivative, by the three-term recurrence.
fn legendre(n: usize, x: f64) -> (f64, f64) {
    let (mut p0, mut p1) = (1.0, x);
    for k in 2..=n {
        let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
        p0 = p1;
        p1 = p2;
    }
    (p1, n as f64 * (x * p1 - p0) / (x * x - 1.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// erf by its Maclaurin series, exact to f64 rounding for |x| ≤ 3.
    fn erf_series(x: f64) -> f64 {
        let (mut term, mut sum) = (x, x);
        for n in 1..200 {
            term *= -x * x / n as f64;
            sum += term / (2 * n + 1) as f64;
        }
        sum * 2.0 / std::f64::consts::PI.sqrt()
    }

    #[test]
    fn erf_is_within_its_stated_error() {
        for i in -3000..=3000 {
            let x = i as f64 / 1000.0;
            let err = (erf(x as f32) as f64 - erf_series(x)).abs();
            assert!(err < 5e-7, "erf({x}) off by {err}");
        }
    }

    #[test]
    fn erfinv_inverts_erf() {
        for i in -999..=999 {
            let y = i as f64 / 1000.0;
            let x = erfinv(y as f32) as f64;
            let err = (erf_series(x) - y).abs();
            assert!(
                err < 1e-6 * (1.0 + y.abs() / (1.0 - y.abs())),
                "erf(erfinv({y})) off by {err}"
            );
        }
    }

    #[test]
    fn gauss_legendre_integrates_polynomials_exactly() {
        for n in [4, 32, 128] {
            let rule = gauss_legendre(n);
            assert!((rule.iter().map(|(_, w)| w).sum::<f64>() - 2.0).abs() < 1e-12);
            // Degree 2n − 1 is integrated exactly; x^(2k) integrates to 2/(2k + 1).
            for k in 0..n {
                let exact = 2.0 / (2 * k + 1) as f64;
                let got: f64 = rule.iter().map(|(x, w)| w * x.powi(2 * k as i32)).sum();
                assert!(
                    (got - exact).abs() < 1e-11,
                    "n = {n}, x^{}: {got} vs {exact}",
                    2 * k
                );
            }
        }
    }
}
