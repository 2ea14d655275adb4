//! Two-dimensional discrete Fourier transforms of row-major complex arrays
//! (rustfft, rows then columns), shared by the power spectra of
//! [`crate::metrics`] and the phase correlation of [`super::register`].

pub use rustfft::num_complex::Complex;
pub use rustfft::FftDirection;
use rustfft::FftPlanner;

/// A complex sample in double precision.
pub type C64 = Complex<f64>;

/// Planned 2-D DFTs of one size and direction, for transforming many
/// arrays (planning costs more than a small transform).
pub struct Fft2 {
    w: usize,
    h: usize,
    row: std::sync::Arc<dyn rustfft::Fft<f64>>,
    col: std::sync::Arc<dyn rustfft::Fft<f64>>,
}

impl Fft2 {
    pub fn new(w: usize, h: usize, direction: FftDirection) -> Self {
        let mut planner = FftPlanner::new();
        Fft2 { w, h, row: planner.plan_fft(w, direction), col: planner.plan_fft(h, direction) }
    }

    /// The 2-D DFT of the `w` x `h` row-major array `data`, in place. The
    /// inverse is not scaled: forward then inverse multiplies by `w h`.
    pub fn process(&self, data: &mut [C64]) {
        let (w, h) = (self.w, self.h);
        assert_eq!(data.len(), w * h, "a {w}x{h} transform");
        data.chunks_exact_mut(w).for_each(|r| self.row.process(r));
        let mut column = vec![C64::new(0.0, 0.0); h];
        for x in 0..w {
            (0..h).for_each(|y| column[y] = data[y * w + x]);
            self.col.process(&mut column);
            (0..h).for_each(|y| data[y * w + x] = column[y]);
        }
    }
}

/// The 2-D DFT of the `w` x `h` row-major array `data`, in place
/// ([`Fft2::process`], planned for this one transform).
pub fn fft2(data: &mut [C64], w: usize, h: usize, direction: FftDirection) {
    Fft2::new(w, h, direction).process(data);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn forward_then_inverse_scales_by_the_size() {
        let (w, h) = (6, 5);
        let orig: Vec<C64> = (0..w * h).map(|i| C64::new(((i * 7) % 11) as f64, 0.0)).collect();
        let mut data = orig.clone();
        fft2(&mut data, w, h, FftDirection::Forward);
        // The DC bin is the sum.
        assert!((data[0].re - orig.iter().map(|c| c.re).sum::<f64>()).abs() < 1e-9);
        fft2(&mut data, w, h, FftDirection::Inverse);
        for (a, b) in data.iter().zip(&orig) {
            assert!((a.re / (w * h) as f64 - b.re).abs() < 1e-9 && (a.im / (w * h) as f64).abs() < 1e-9);
        }
    }
}
