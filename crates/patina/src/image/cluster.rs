//! k-means clustering of 3-vectors (colours, or any three features): the
//! seeding of GrabCut's colour mixtures ([`super::grabcut`]) and the
//! material families the synthesis engine balances ([`crate::synth::families`]).

use crate::rng::Generator;
use nalgebra::Vector3;
use rand::Rng;

/// Index of the centre nearest to `p` (the first on ties).
pub(crate) fn nearest(p: &Vector3<f64>, centres: &[Vector3<f64>]) -> usize {
    (0..centres.len()).map(|k| (k, (p - centres[k]).norm_squared())).fold((0, f64::INFINITY), |a, b| if b.1 < a.1 { b } else { a }).0
}

/// k-means++ seeding and ten Lloyd rounds. Fewer than `k` centres come
/// back when the points hold fewer distinct values.
pub(crate) fn kmeans(points: &[Vector3<f64>], k: usize, g: &mut Generator) -> Vec<Vector3<f64>> {
    let mut centres = vec![points[g.gen_range(0..points.len())]];
    let mut d2: Vec<f64> = points.iter().map(|p| (p - centres[0]).norm_squared()).collect();
    while centres.len() < k {
        let total: f64 = d2.iter().sum();
        if total <= 0.0 {
            break;
        }
        let mut r = g.gen_range(0.0..total);
        let mut pick = points.len() - 1;
        for (i, &v) in d2.iter().enumerate() {
            if r < v {
                pick = i;
                break;
            }
            r -= v;
        }
        centres.push(points[pick]);
        for (d, p) in d2.iter_mut().zip(points) {
            *d = d.min((p - points[pick]).norm_squared());
        }
    }
    for _ in 0..10 {
        let mut sum = vec![Vector3::zeros(); centres.len()];
        let mut n = vec![0usize; centres.len()];
        for p in points {
            let c = nearest(p, &centres);
            sum[c] += p;
            n[c] += 1;
        }
        for c in 0..centres.len() {
            if n[c] > 0 {
                centres[c] = sum[c] / n[c] as f64;
            }
        }
    }
    centres
}
