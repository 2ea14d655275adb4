//! Polynomials in time (Meister, Pospisil, Sato, Bittner, "Spatio-temporal
//! BRDF: modeling and synthesis", 2021): every material parameter of a
//! texel is p(t) = sum_{k=0..d} a_k t^k on t in [0, 1] (eq. 8).
//!
//! - Fitting: all texels share one Vandermonde matrix V (N samples x d + 1),
//!   so its pseudo-inverse V+ is computed once and the least-squares
//!   coefficients of every texel are V+ times its samples.
//! - Evaluation: Horner's rule.
//! - Distance (eqs. 11-14): the integral over [0, 1] of (p1 - p2)^2 dt is
//!   b^T H b with b = a1 - a2 and H_jk = 1 / (j + k + 1), in closed form.
//!
//! Coefficient layout in an image: parameter channel c, coefficient k is
//! image channel c (d + 1) + k, so one parameter's polynomial is contiguous.

use crate::error::{Error, Result};
use crate::synth::TexelDistance;
use nalgebra::DMatrix;

/// Highest supported degree.
pub const MAX_DEGREE: usize = 6;

/// p(t) by Horner's rule; `a` = (a_0, ..., a_d).
pub fn evaluate(a: &[f32], t: f32) -> f32 {
    a.iter().rev().fold(0.0, |acc, &c| acc * t + c)
}

/// Least-squares fitting of degree-d polynomials at fixed sample times.
#[derive(Clone, Debug)]
pub struct Fitter {
    degree: usize,
    /// V+, (d + 1) x N, row-major.
    pinv: Vec<f64>,
    samples: usize,
}

impl Fitter {
    /// A fitter for samples at `times` (in [0, 1]).
    pub fn new(times: &[f32], degree: usize) -> Result<Self> {
        if !(1..=MAX_DEGREE).contains(&degree) {
            return Err(Error::invalid(format!("the polynomial degree must be 1..={MAX_DEGREE}, got {degree}")));
        }
        if times.len() <= degree {
            return Err(Error::invalid(format!("a degree-{degree} fit needs more than {degree} time steps, got {}", times.len())));
        }
        if times.iter().any(|t| !t.is_finite()) {
            return Err(Error::invalid("sample times must be finite"));
        }
        let n = times.len();
        let v = DMatrix::<f64>::from_fn(n, degree + 1, |i, k| f64::from(times[i]).powi(k as i32));
        let pinv = v.pseudo_inverse(1e-12).map_err(|e| Error::Internal(format!("pseudo-inverse: {e}")))?;
        let distinct = {
            let mut t: Vec<f32> = times.to_vec();
            t.sort_by(f32::total_cmp);
            t.dedup();
            t.len()
        };
        if distinct <= degree {
            return Err(Error::invalid(format!("a degree-{degree} fit needs at least {} distinct times, got {distinct}", degree + 1)));
        }
        let pinv: Vec<f64> = (0..degree + 1).flat_map(|k| (0..n).map(move |i| (k, i))).map(|(k, i)| pinv[(k, i)]).collect();
        Ok(Fitter { degree, pinv, samples: n })
    }

    /// A fitter whose polynomials vanish at `t0`: least squares in the
    /// basis (t - t0)^j, j = 1..=d, expanded to monomials (binomially), so
    /// that samples of q(t) = v(t) - v(t0) give q(t0) = 0 up to rounding,
    /// and all-zero samples give all-zero coefficients exactly.
    pub fn anchored(times: &[f32], degree: usize, t0: f32) -> Result<Self> {
        Self::new(times, degree)?;
        let n = times.len();
        let t0 = f64::from(t0);
        let v = DMatrix::<f64>::from_fn(n, degree, |i, j| (f64::from(times[i]) - t0).powi(j as i32 + 1));
        let pinv = v.pseudo_inverse(1e-12).map_err(|e| Error::Internal(format!("pseudo-inverse: {e}")))?;
        let binomial = |j: usize, k: usize| (0..k).fold(1.0f64, |acc, i| acc * (j - i) as f64 / (i + 1) as f64);
        // a_k = sum_j b_j C(j, k) (-t0)^(j - k), for j = 1..=d and k <= j.
        let expand = DMatrix::<f64>::from_fn(degree + 1, degree, |k, j| {
            let j = j + 1;
            if k > j {
                0.0
            } else {
                binomial(j, k) * (-t0).powi((j - k) as i32)
            }
        });
        let m = expand * pinv;
        let pinv: Vec<f64> = (0..degree + 1).flat_map(|k| (0..n).map(move |i| (k, i))).map(|(k, i)| m[(k, i)]).collect();
        Ok(Fitter { degree, pinv, samples: n })
    }

    pub fn degree(&self) -> usize {
        self.degree
    }

    /// Coefficients of one series of `samples` values into `out` (d + 1).
    pub fn fit_into(&self, samples: &[f32], out: &mut [f32]) {
        for (k, o) in out.iter_mut().enumerate() {
            let row = &self.pinv[k * self.samples..(k + 1) * self.samples];
            *o = row.iter().zip(samples).map(|(p, s)| p * f64::from(*s)).sum::<f64>() as f32;
        }
    }
}

/// H_jk = 1 / (j + k + 1), (d + 1) x (d + 1), row-major.
pub fn gram(degree: usize) -> Vec<f32> {
    let m = degree + 1;
    (0..m * m).map(|i| 1.0 / ((i / m + i % m + 1) as f32)).collect()
}

/// The closed-form distance between polynomial texels (eq. 14), summed over
/// the parameter channels of a group: sum_c b_c^T H b_c.
#[derive(Clone, Debug)]
pub struct PolyDistance {
    terms: usize,
    h: Vec<f32>,
}

impl PolyDistance {
    pub fn new(degree: usize) -> Self {
        PolyDistance { terms: degree + 1, h: gram(degree) }
    }
}

impl TexelDistance for PolyDistance {
    fn cost(&self, a: &[f32], b: &[f32]) -> f32 {
        let m = self.terms;
        let mut diff = [0.0f32; MAX_DEGREE + 1];
        let mut total = 0.0;
        for (pa, pb) in a.chunks_exact(m).zip(b.chunks_exact(m)) {
            for k in 0..m {
                diff[k] = pa[k] - pb[k];
            }
            for j in 0..m {
                let row = &self.h[j * m..(j + 1) * m];
                let hb: f32 = row.iter().zip(&diff[..m]).map(|(h, d)| h * d).sum();
                total += diff[j] * hb;
            }
        }
        total.max(0.0)
    }
}

/// The orthonormal change of basis for eq. (14): with H = L L^T
/// (Cholesky), the coefficients c = L^T a are those of the polynomial in an
/// orthonormal basis on [0, 1] (shifted Legendre polynomials), so
/// ||c1 - c2||^2 = b^T H b exactly: the closed-form distance becomes a
/// plain SSD, which the engine's fast paths (row SSD, FFT quilting) use.
/// Linear, so averaging (voting) commutes with it.
#[derive(Clone, Debug)]
pub struct Orthonormal {
    terms: usize,
    /// L^T, row-major (upper triangular).
    forward: Vec<f32>,
    /// (L^T)^-1, row-major.
    inverse: Vec<f32>,
}

impl Orthonormal {
    pub fn new(degree: usize) -> Self {
        let m = degree + 1;
        let h = DMatrix::<f64>::from_fn(m, m, |j, k| 1.0 / (j + k + 1) as f64);
        let l = h.cholesky().expect("the Hilbert matrix is positive definite").l();
        let lt = l.transpose();
        let inv = lt.clone().try_inverse().expect("triangular with a positive diagonal");
        let flat = |a: &DMatrix<f64>| (0..m * m).map(|i| a[(i / m, i % m)] as f32).collect();
        Orthonormal { terms: m, forward: flat(&lt), inverse: flat(&inv) }
    }

    /// Map every run of d + 1 coefficients in `values` through L^T (`true`)
    /// or back (`false`), in place.
    pub fn apply(&self, values: &mut [f32], forward: bool) {
        let m = self.terms;
        let mat = if forward { &self.forward } else { &self.inverse };
        let mut tmp = [0.0f32; MAX_DEGREE + 1];
        for chunk in values.chunks_exact_mut(m) {
            for (j, t) in tmp[..m].iter_mut().enumerate() {
                *t = mat[j * m..(j + 1) * m].iter().zip(chunk.iter()).map(|(a, b)| a * b).sum();
            }
            chunk.copy_from_slice(&tmp[..m]);
        }
    }
}

/// The same integral by the midpoint rule with `samples` points (eq. 15),
/// for checking and for the benchmark.
pub fn sampled_distance(a: &[f32], b: &[f32], degree: usize, samples: usize) -> f32 {
    let m = degree + 1;
    let mut total = 0.0f32;
    for (pa, pb) in a.chunks_exact(m).zip(b.chunks_exact(m)) {
        for s in 0..samples {
            let t = (s as f32 + 0.5) / samples as f32;
            let d = evaluate(pa, t) - evaluate(pb, t);
            total += d * d;
        }
    }
    total / samples as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn anchored_fits_vanish_at_t0_and_follow_the_samples() {
        let times: Vec<f32> = (0..16).map(|i| i as f32 / 15.0).collect();
        let f = Fitter::anchored(&times, 3, 0.3).unwrap();
        // A cubic that vanishes at 0.3 is fitted exactly.
        let q = |t: f32| (t - 0.3) * (1.0 + 2.0 * t - t * t);
        let samples: Vec<f32> = times.iter().map(|&t| q(t)).collect();
        let mut a = [0.0f32; 4];
        f.fit_into(&samples, &mut a);
        assert!(evaluate(&a, 0.3).abs() < 1e-5, "{}", evaluate(&a, 0.3));
        for &t in &times {
            assert!((evaluate(&a, t) - q(t)).abs() < 1e-4);
        }
        f.fit_into(&[0.0; 16], &mut a);
        assert_eq!(a, [0.0; 4]);
    }

    #[test]
    fn fitting_recovers_known_polynomials_exactly() {
        let times: Vec<f32> = (0..11).map(|i| i as f32 / 10.0).collect();
        for degree in 1..=MAX_DEGREE {
            let fit = Fitter::new(&times, degree).unwrap();
            let want: Vec<f32> = (0..=degree).map(|k| ((k * 7 + 3) % 5) as f32 * 0.2 - 0.4).collect();
            let samples: Vec<f32> = times.iter().map(|&t| evaluate(&want, t)).collect();
            let mut got = vec![0.0; degree + 1];
            fit.fit_into(&samples, &mut got);
            for (g, w) in got.iter().zip(&want) {
                assert!((g - w).abs() < 1e-5, "degree {degree}: {got:?} vs {want:?}");
            }
        }
        assert!(Fitter::new(&times[..3], 3).is_err());
        assert!(Fitter::new(&[0.0, 0.0, 0.0, 0.0, 0.0], 3).is_err());
        assert!(Fitter::new(&times, 7).is_err());
    }

    #[test]
    fn the_closed_form_distance_is_the_integral() {
        let a = [0.3f32, -0.2, 0.5, 0.1, 0.9, 0.0, -0.4, 0.2];
        let b = [0.1f32, 0.4, -0.3, 0.2, 0.2, 0.3, 0.1, -0.5];
        let closed = PolyDistance::new(3).cost(&a, &b);
        // Simpson's rule on 2000 intervals is exact to ~1e-12 for cubics squared.
        let simpson = |pa: &[f32], pb: &[f32]| -> f64 {
            let n = 2000;
            let f = |t: f64| {
                let e = |p: &[f32]| p.iter().rev().fold(0.0f64, |acc, &c| acc * t + f64::from(c));
                (e(pa) - e(pb)).powi(2)
            };
            let h = 1.0 / n as f64;
            (0..=n)
                .map(|i| {
                    f(i as f64 * h)
                        * if i == 0 || i == n {
                            1.0
                        } else if i % 2 == 1 {
                            4.0
                        } else {
                            2.0
                        }
                })
                .sum::<f64>()
                * h
                / 3.0
        };
        let numeric = simpson(&a[..4], &b[..4]) + simpson(&a[4..], &b[4..]);
        assert!((f64::from(closed) - numeric).abs() < 1e-6, "{closed} vs {numeric}");
        assert!((sampled_distance(&a, &b, 3, 200) as f64 - numeric).abs() < 1e-4);
        assert_eq!(PolyDistance::new(3).cost(&a, &a), 0.0);
        // In the orthonormal basis the distance is a plain SSD, and the map inverts.
        let o = Orthonormal::new(3);
        let (mut ca, mut cb) = (a, b);
        o.apply(&mut ca, true);
        o.apply(&mut cb, true);
        let ssd: f32 = ca.iter().zip(&cb).map(|(p, q)| (p - q) * (p - q)).sum();
        assert!((ssd - closed).abs() < 1e-5 * closed.max(1.0), "{ssd} vs {closed}");
        o.apply(&mut ca, false);
        assert!(ca.iter().zip(&a).all(|(p, q)| (p - q).abs() < 1e-5));
    }
}
