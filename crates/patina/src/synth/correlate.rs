//! Masked sums of squared differences between a small template and every
//! placement of it in a source image, by FFT cross-correlation:
//!
//! E(s) = sum_m M(m) sum_c w_c (T_c(m) - S_c(s + m))^2
//!      = sum_m M sum_c w_c T_c^2  -  2 sum_c w_c corr(M T_c, S_c)(s)  +  corr(M, Q)(s)
//!
//! with Q = sum_c w_c S_c^2. The source's spectra are computed once; each
//! template then costs one forward transform per channel (only its few
//! non-zero rows are transformed) and one inverse transform for all terms
//! together. This is what makes quilting's exhaustive candidate search fast.

use crate::image::summed::SummedArea;
use crate::image::Image;
use realfft::num_complex::Complex;
use realfft::{ComplexToReal, RealFftPlanner, RealToComplex};
use rustfft::{Fft, FftPlanner};
use std::sync::Arc;

type C32 = Complex<f32>;

/// Smallest n' >= n whose only prime factors are 2, 3 and 5 (fast FFT sizes).
fn fast_size(n: usize) -> usize {
    (n..)
        .find(|&m| {
            let mut k = m;
            for p in [2, 3, 5] {
                while k % p == 0 {
                    k /= p;
                }
            }
            k == 1
        })
        .expect("a 5-smooth number exists above any n")
}

/// FFT plans for one transform size; spectra are stored column-major
/// (`fw/2+1` columns of `fh` values each).
struct Plans {
    fw: usize,
    fh: usize,
    row_fwd: Arc<dyn RealToComplex<f32>>,
    row_inv: Arc<dyn ComplexToReal<f32>>,
    col_fwd: Arc<dyn Fft<f32>>,
    col_inv: Arc<dyn Fft<f32>>,
}

impl Plans {
    fn new(fw: usize, fh: usize) -> Self {
        let mut rp = RealFftPlanner::<f32>::new();
        let mut cp = FftPlanner::<f32>::new();
        Plans {
            fw,
            fh,
            row_fwd: rp.plan_fft_forward(fw),
            row_inv: rp.plan_fft_inverse(fw),
            col_fwd: cp.plan_fft_forward(fh),
            col_inv: cp.plan_fft_inverse(fh),
        }
    }
    fn cols(&self) -> usize {
        self.fw / 2 + 1
    }
    fn spectrum_len(&self) -> usize {
        self.cols() * self.fh
    }

    /// Spectrum of a kw x kh real array (row-major, stride `kw`) placed at the
    /// origin of an fw x fh zero image.
    fn forward(&self, values: &[f32], kw: usize, kh: usize, out: &mut [C32], scratch: &mut Scratch) {
        let cols = self.cols();
        // Rows from kh on stay zero; the others are all written below.
        for column in out.chunks_exact_mut(self.fh) {
            column[kh.min(self.fh)..].iter_mut().for_each(|v| *v = C32::new(0.0, 0.0));
        }
        for y in 0..kh {
            scratch.row.iter_mut().for_each(|v| *v = 0.0);
            scratch.row[..kw].copy_from_slice(&values[y * kw..(y + 1) * kw]);
            self.row_fwd
                .process_with_scratch(&mut scratch.row, &mut scratch.row_spec, &mut scratch.fft)
                .expect("buffer sizes come from the plan");
            for (u, v) in scratch.row_spec.iter().enumerate() {
                out[u * self.fh + y] = *v;
            }
        }
        for u in 0..cols {
            self.col_fwd.process_with_scratch(&mut out[u * self.fh..(u + 1) * self.fh], &mut scratch.fft);
        }
    }

    /// Inverse of a column-major spectrum into the first `rows` rows of an
    /// fw x fh real image (scaled so that inverse(forward(x)) = x; the
    /// other rows are left as they were). Destroys `spec`.
    fn inverse(&self, spec: &mut [C32], out: &mut [f32], rows: usize, scratch: &mut Scratch) {
        let cols = self.cols();
        for u in 0..cols {
            self.col_inv.process_with_scratch(&mut spec[u * self.fh..(u + 1) * self.fh], &mut scratch.fft);
        }
        let scale = 1.0 / (self.fw * self.fh) as f32;
        for y in 0..rows.min(self.fh) {
            for u in 0..cols {
                scratch.row_spec[u] = spec[u * self.fh + y];
            }
            // The DC (and Nyquist) bins of a real signal's spectrum are real;
            // round-off must not make the inverse refuse them.
            scratch.row_spec[0].im = 0.0;
            if self.fw.is_multiple_of(2) {
                scratch.row_spec[cols - 1].im = 0.0;
            }
            self.row_inv
                .process_with_scratch(&mut scratch.row_spec, &mut scratch.row, &mut scratch.fft)
                .expect("buffer sizes come from the plan");
            for (o, v) in out[y * self.fw..(y + 1) * self.fw].iter_mut().zip(&scratch.row) {
                *o = v * scale;
            }
        }
    }
}

/// Per-thread working buffers for [`Plans`].
struct Scratch {
    row: Vec<f32>,
    row_spec: Vec<C32>,
    fft: Vec<C32>,
}

/// A source image prepared for masked-SSD queries: the spectra of its
/// weighted channels and of Q = sum_c w_c S_c^2.
pub struct SpectralSource {
    plans: Plans,
    width: usize,
    height: usize,
    channels: usize,
    weights: Vec<f32>,
    spectra: Vec<Vec<C32>>,
    squares: Vec<C32>,
    /// Summed-area table of Q: the squares term of an unmasked (box)
    /// template without a transform.
    squares_sat: SummedArea,
}

/// The squares term of a masked SSD for one mask ([`SpectralSource::mask_term`]).
pub struct MaskTerm {
    spectrum: Vec<C32>,
    kw: usize,
    kh: usize,
}

/// Accumulates the terms of one query (see [`SpectralSource::add_term`]).
pub struct Query {
    acc: Vec<C32>,
    kernel: Vec<C32>,
    values: Vec<f32>,
    constant: f64,
    /// Weight of the box sum of Q (from [`SpectralSource::add_box_term`]).
    box_scale: f64,
    /// The inverse transform's rows of valid placements.
    full: Vec<f32>,
    scratch: Scratch,
    kw: usize,
    kh: usize,
}

impl SpectralSource {
    /// Prepare `source` with one weight per channel.
    pub fn new(source: &Image, weights: &[f32]) -> Self {
        assert_eq!(weights.len(), source.channels());
        let (w, h, n) = (source.width(), source.height(), source.channels());
        let plans = Plans::new(fast_size(w), fast_size(h));
        let mut scratch = Self::scratch(&plans);
        let mut plane = vec![0f32; w * h];
        let mut spectra = Vec::with_capacity(n);
        for c in 0..n {
            for (p, v) in plane.iter_mut().enumerate() {
                *v = source.data()[p * n + c];
            }
            let mut s = vec![C32::new(0.0, 0.0); plans.spectrum_len()];
            plans.forward(&plane, w, h, &mut s, &mut scratch);
            spectra.push(s);
        }
        for (p, v) in plane.iter_mut().enumerate() {
            *v = (0..n).map(|c| weights[c] * source.data()[p * n + c].powi(2)).sum();
        }
        let mut squares = vec![C32::new(0.0, 0.0); plans.spectrum_len()];
        plans.forward(&plane, w, h, &mut squares, &mut scratch);
        let squares_sat = SummedArea::new(w, h, |x, y| plane[y * w + x] as f64);
        SpectralSource { plans, width: w, height: h, channels: n, weights: weights.to_vec(), spectra, squares, squares_sat }
    }

    fn scratch(plans: &Plans) -> Scratch {
        let len = plans.row_fwd.get_scratch_len().max(plans.row_inv.get_scratch_len());
        let len = len.max(plans.col_fwd.get_inplace_scratch_len()).max(plans.col_inv.get_inplace_scratch_len());
        Scratch { row: vec![0.0; plans.fw], row_spec: vec![C32::new(0.0, 0.0); plans.cols()], fft: vec![C32::new(0.0, 0.0); len] }
    }

    pub fn width(&self) -> usize {
        self.width
    }
    pub fn height(&self) -> usize {
        self.height
    }
    pub fn channels(&self) -> usize {
        self.channels
    }

    /// Start a query for templates of `kw` x `kh`.
    pub fn query(&self, kw: usize, kh: usize) -> Query {
        assert!(kw <= self.width && kh <= self.height, "template larger than the source");
        let len = self.plans.spectrum_len();
        Query {
            acc: vec![C32::new(0.0, 0.0); len],
            kernel: vec![C32::new(0.0, 0.0); len],
            values: vec![0.0; kw * kh],
            constant: 0.0,
            box_scale: 0.0,
            full: vec![0.0; self.plans.fw * (self.height - kh + 1)],
            scratch: Self::scratch(&self.plans),
            kw,
            kh,
        }
    }

    /// Add `scale` x the masked SSD between `template` (kw x kh, this
    /// source's channels, interleaved) under `mask` (kw x kh weights) and
    /// every placement in the source.
    pub fn add_term(&self, q: &mut Query, template: &[f32], mask: &[f32], scale: f32) {
        self.add_cross_terms(q, template, Some(mask), scale);
        // The squares term goes through the query's own kernel buffer.
        let mut kernel = std::mem::take(&mut q.kernel);
        self.squares_spectrum(mask, q.kw, q.kh, &mut kernel, &mut q.scratch);
        add_scaled(&mut q.acc, &kernel, scale);
        q.kernel = kernel;
    }

    /// The squares term of a masked SSD, corr(M, Q), as a spectrum: it
    /// depends on the mask alone, so a caller querying many templates under
    /// a few masks (quilting's strip shapes) computes it once per mask.
    pub fn mask_term(&self, mask: &[f32], kw: usize, kh: usize) -> MaskTerm {
        let mut spectrum = vec![C32::new(0.0, 0.0); self.plans.spectrum_len()];
        self.squares_spectrum(mask, kw, kh, &mut spectrum, &mut Self::scratch(&self.plans));
        MaskTerm { spectrum, kw, kh }
    }

    /// [`Self::add_term`] with the mask's squares term from [`Self::mask_term`].
    pub fn add_masked_term(&self, q: &mut Query, template: &[f32], mask: &[f32], squares: &MaskTerm, scale: f32) {
        assert!((squares.kw, squares.kh) == (q.kw, q.kh) && squares.spectrum.len() == q.acc.len(), "mask term of another size");
        self.add_cross_terms(q, template, Some(mask), scale);
        add_scaled(&mut q.acc, &squares.spectrum, scale);
    }

    /// corr(M, Q)'s spectrum for a kw x kh `mask`, into `out`.
    fn squares_spectrum(&self, mask: &[f32], kw: usize, kh: usize, out: &mut [C32], scratch: &mut Scratch) {
        assert_eq!(mask.len(), kw * kh);
        self.plans.forward(mask, kw, kh, out, scratch);
        out.iter_mut().zip(&self.squares).for_each(|(k, s)| *k = k.conj() * s);
    }

    /// Add `scale` x the plain (unmasked) SSD between `template` and every
    /// placement: like [`Self::add_term`] with a mask of ones, but the
    /// squares term comes from a summed-area table instead of a transform.
    pub fn add_box_term(&self, q: &mut Query, template: &[f32], scale: f32) {
        self.add_cross_terms(q, template, None, scale);
        q.box_scale += scale as f64;
    }

    /// The template-only and cross-correlation terms of a masked SSD.
    fn add_cross_terms(&self, q: &mut Query, template: &[f32], mask: Option<&[f32]>, scale: f32) {
        let n = self.channels;
        assert_eq!(template.len(), q.kw * q.kh * n);
        assert!(mask.is_none_or(|m| m.len() == q.kw * q.kh));
        for c in 0..n {
            let wc = self.weights[c];
            if wc == 0.0 {
                continue;
            }
            for (i, v) in q.values.iter_mut().enumerate() {
                let t = template[i * n + c];
                let m = mask.map_or(1.0, |m| m[i]);
                *v = m * t;
                // A zero weight adds exactly 0 to the constant.
                if m != 0.0 {
                    q.constant += (scale * wc * m * t * t) as f64;
                }
            }
            self.plans.forward(&q.values, q.kw, q.kh, &mut q.kernel, &mut q.scratch);
            let f = -2.0 * scale * wc;
            for ((a, k), s) in q.acc.iter_mut().zip(&q.kernel).zip(&self.spectra[c]) {
                *a += k.conj() * s * f;
            }
        }
    }

    /// Like [`Self::add_term`], for a query started on another source of
    /// the same size (e.g. a guide image beside the exemplar).
    pub fn add_term_into(&self, q: &mut Query, template: &[f32], mask: &[f32], scale: f32) {
        assert_eq!(q.acc.len(), self.plans.spectrum_len(), "query and source transform sizes differ");
        self.add_term(q, template, mask, scale);
    }

    /// Finish: the summed cost of every valid placement, row-major over
    /// (width - kw + 1) x (height - kh + 1), clamped at 0. The query is
    /// emptied for the next template of its size: a caller querying many
    /// (quilting's blocks) keeps one per thread instead of allocating its
    /// transform buffers each time.
    pub fn finish(&self, q: &mut Query) -> Vec<f32> {
        let fw = self.plans.fw;
        let (vw, vh) = (self.width - q.kw + 1, self.height - q.kh + 1);
        // Only the rows of valid placements are transformed back.
        self.plans.inverse(&mut q.acc, &mut q.full, vh, &mut q.scratch);
        let mut out = Vec::with_capacity(vw * vh);
        let k = q.constant as f32;
        for y in 0..vh {
            out.extend(q.full[y * fw..y * fw + vw].iter().enumerate().map(|(x, v)| {
                let boxed = if q.box_scale != 0.0 { (q.box_scale * self.squares_sat.sum(x, y, q.kw, q.kh)) as f32 } else { 0.0 };
                (v + k + boxed).max(0.0)
            }));
        }
        q.acc.iter_mut().for_each(|a| *a = C32::new(0.0, 0.0));
        q.constant = 0.0;
        q.box_scale = 0.0;
        out
    }
}

/// `acc` += `scale` x `terms`.
fn add_scaled(acc: &mut [C32], terms: &[C32], scale: f32) {
    acc.iter_mut().zip(terms).for_each(|(a, k)| *a += k * scale);
}

/// Weighted linear autocorrelation of an image's channels,
/// sum_c w_c sum_p S_c(p) S_c(p + d), for every shift d: an fw x fh array
/// (fw >= 2 w, fh >= 2 h, so nothing wraps) indexed at
/// (d_y mod fh) fw + (d_x mod fw). Returns it with (fw, fh).
pub fn autocorrelation(source: &Image, weights: &[f32]) -> (Vec<f32>, usize, usize) {
    assert_eq!(weights.len(), source.channels());
    let (w, h, n) = (source.width(), source.height(), source.channels());
    let plans = Plans::new(fast_size(2 * w), fast_size(2 * h));
    let mut scratch = SpectralSource::scratch(&plans);
    let mut plane = vec![0f32; w * h];
    let mut spectrum = vec![C32::new(0.0, 0.0); plans.spectrum_len()];
    let mut power = vec![C32::new(0.0, 0.0); plans.spectrum_len()];
    for c in (0..n).filter(|&c| weights[c] != 0.0) {
        for (p, v) in plane.iter_mut().enumerate() {
            *v = source.data()[p * n + c];
        }
        plans.forward(&plane, w, h, &mut spectrum, &mut scratch);
        for (a, s) in power.iter_mut().zip(&spectrum) {
            *a += C32::new(weights[c] * s.norm_sqr(), 0.0);
        }
    }
    let mut out = vec![0f32; plans.fw * plans.fh];
    plans.inverse(&mut power, &mut out, plans.fh, &mut scratch);
    (out, plans.fw, plans.fh)
}

/// Exact masked weighted SSD of `template` (kw x kh) at source position (sx, sy).
pub fn masked_ssd(source: &Image, weights: &[f32], template: &[f32], mask: &[f32], kw: usize, kh: usize, sx: usize, sy: usize) -> f32 {
    // The common channel counts as constants: the body is inlined into
    // each arm, so its inner sum unrolls. The summation order is the same
    // for every count.
    match source.channels() {
        1 => masked_ssd_of(1, source, weights, template, mask, kw, kh, sx, sy),
        3 => masked_ssd_of(3, source, weights, template, mask, kw, kh, sx, sy),
        4 => masked_ssd_of(4, source, weights, template, mask, kw, kh, sx, sy),
        n => masked_ssd_of(n, source, weights, template, mask, kw, kh, sx, sy),
    }
}

#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn masked_ssd_of(
    n: usize,
    source: &Image,
    weights: &[f32],
    template: &[f32],
    mask: &[f32],
    kw: usize,
    kh: usize,
    sx: usize,
    sy: usize,
) -> f32 {
    let weights = &weights[..n];
    let sw = source.width();
    let mut sum = 0.0;
    for y in 0..kh {
        let s0 = ((sy + y) * sw + sx) * n;
        let srow = &source.data()[s0..s0 + kw * n];
        let trow = &template[y * kw * n..(y + 1) * kw * n];
        for ((m, s), t) in mask[y * kw..(y + 1) * kw].iter().zip(srow.chunks_exact(n)).zip(trow.chunks_exact(n)) {
            if *m == 0.0 {
                continue;
            }
            let mut d = 0.0f32;
            for ((w, t), s) in weights.iter().zip(t).zip(s) {
                let e = t - s;
                d += w * (e * e);
            }
            sum += m * d;
        }
    }
    sum
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn masked_ssd_is_the_weighted_sum_for_every_channel_count() {
        for n in 1..=5 {
            let src = Image::from_fn(13, 11, n, |x, y, p| {
                p.iter_mut().enumerate().for_each(|(c, v)| *v = ((x * 7 + y * 3 + c * 5) % 9) as f32 / 9.0)
            });
            let (kw, kh, sx, sy) = (5, 4, 6, 3);
            let template: Vec<f32> = (0..kw * kh * n).map(|i| ((i * 29) % 23) as f32 / 23.0).collect();
            let mask: Vec<f32> = (0..kw * kh).map(|i| [0.0, 1.0, 0.5][i % 3]).collect();
            let weights: Vec<f32> = (0..n).map(|c| 0.2 + 0.1 * c as f32).collect();
            let mut want = 0.0f64;
            for y in 0..kh {
                for x in 0..kw {
                    for c in 0..n {
                        let d = (template[(y * kw + x) * n + c] - src.pixel(sx + x, sy + y)[c]) as f64;
                        want += (mask[y * kw + x] * weights[c]) as f64 * d * d;
                    }
                }
            }
            let got = masked_ssd(&src, &weights, &template, &mask, kw, kh, sx, sy) as f64;
            assert!((got - want).abs() < 1e-5 * (1.0 + want), "{n} channels: {got} vs {want}");
        }
    }

    #[test]
    fn fft_costs_match_direct_sums_on_odd_sizes() {
        let src = Image::from_fn(37, 29, 2, |x, y, p| {
            p[0] = ((x * 13 + y * 7) % 11) as f32 / 11.0;
            p[1] = ((x * y + 3) % 5) as f32 / 5.0;
        });
        let (kw, kh) = (9, 6);
        let template: Vec<f32> = (0..kw * kh * 2).map(|i| ((i * 37) % 17) as f32 / 17.0).collect();
        let mask: Vec<f32> = (0..kw * kh).map(|i| if i % kw < 3 || i / kw < 2 { 1.0 } else { 0.0 }).collect();
        let weights = [0.7, 0.3];
        let spectral = SpectralSource::new(&src, &weights);
        let mut q = spectral.query(kw, kh);
        spectral.add_term(&mut q, &template, &mask, 2.0);
        let costs = spectral.finish(&mut q);
        let mut bq = spectral.query(kw, kh);
        spectral.add_box_term(&mut bq, &template, 0.5);
        let box_costs = spectral.finish(&mut bq);
        let ones = vec![1.0; kw * kh];
        assert_eq!(costs.len(), (37 - kw + 1) * (29 - kh + 1));
        for sy in 0..29 - kh + 1 {
            for sx in 0..37 - kw + 1 {
                let want = 2.0 * masked_ssd(&src, &weights, &template, &mask, kw, kh, sx, sy);
                let got = costs[sy * (37 - kw + 1) + sx];
                assert!((want - got).abs() < 1e-3 * (1.0 + want), "at {sx},{sy}: {want} vs {got}");
                let want = 0.5 * masked_ssd(&src, &weights, &template, &ones, kw, kh, sx, sy);
                let got = box_costs[sy * (37 - kw + 1) + sx];
                assert!((want - got).abs() < 1e-3 * (1.0 + want), "box at {sx},{sy}: {want} vs {got}");
            }
        }
    }
}
