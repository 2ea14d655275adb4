//! Summed-area tables: the sum of any axis-aligned box in O(1).

/// Prefix sums of a `width` x `height` grid of values, in f64.
#[derive(Clone, Debug)]
pub struct SummedArea {
    stride: usize,
    table: Vec<f64>,
}

impl SummedArea {
    /// The table of `value(x, y)` over a `width` x `height` grid.
    pub fn new(width: usize, height: usize, value: impl Fn(usize, usize) -> f64) -> Self {
        let stride = width + 1;
        let mut table = vec![0f64; stride * (height + 1)];
        for y in 0..height {
            let mut row = 0f64;
            for x in 0..width {
                row += value(x, y);
                table[(y + 1) * stride + x + 1] = table[y * stride + x + 1] + row;
            }
        }
        SummedArea { stride, table }
    }

    /// Sum of the values in the `w` x `h` box whose top-left corner is (x, y).
    #[inline]
    pub fn sum(&self, x: usize, y: usize, w: usize, h: usize) -> f64 {
        let at = |xx: usize, yy: usize| self.table[yy * self.stride + xx];
        at(x + w, y + h) - at(x + w, y) - at(x, y + h) + at(x, y)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn box_sums_match_direct_sums() {
        let v = |x: usize, y: usize| ((x * 7 + y * 3) % 5) as f64;
        let t = SummedArea::new(9, 6, v);
        for (x, y, w, h) in [(0, 0, 9, 6), (2, 1, 3, 4), (8, 5, 1, 1), (4, 0, 0, 3)] {
            let direct: f64 = (y..y + h).flat_map(|yy| (x..x + w).map(move |xx| v(xx, yy))).sum();
            assert_eq!(t.sum(x, y, w, h), direct, "box {x},{y} {w}x{h}");
        }
    }
}
