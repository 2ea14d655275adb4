//! Coordinate noise: gradient (Perlin) noise, fractal sums of it, domain
//! warping and cellular (Worley) noise. Decay's procedural textures and
//! degree maps and stone's chipped wear use it.
//!
//! Every function here is a pure function of a seed and absolute pixel
//! coordinates, with no image-level state, so a texture generated in parts
//! has exactly the pixels of the texture generated at once (the paper's
//! synthesis-by-part property) and nothing repeats at any size.

/// The 16 unit gradients of [`Layer::perlin`], at multiples of 22.5 degrees.
const GRADIENTS: [[f32; 2]; 16] = {
    let mut g = [[0.0; 2]; 16];
    // cos and sin of k * 22.5 degrees for k = 0..4; the rest by symmetry.
    let quarter = [
        [1.0, 0.0],
        [0.923_879_5, 0.382_683_43],
        [std::f32::consts::FRAC_1_SQRT_2, std::f32::consts::FRAC_1_SQRT_2],
        [0.382_683_43, 0.923_879_5],
    ];
    let mut k = 0;
    while k < 16 {
        let [c, s] = quarter[k % 4];
        g[k] = match k / 4 {
            0 => [c, s],
            1 => [-s, c],
            2 => [-c, -s],
            _ => [s, -c],
        };
        k += 1;
    }
    g
};

/// One noise layer: a 32-bit seed for the lattice hash, and optionally a
/// period in pixels ([`Layer::tiling`]).
#[derive(Clone, Copy, Debug)]
pub struct Layer {
    key: u32,
    /// The layer repeats every (width, height) pixels; `None`: never.
    period: Option<(f32, f32)>,
}

impl Layer {
    /// The layer `index` of a texture with seed `seed`.
    pub fn new(seed: u64, index: u64) -> Self {
        Layer { key: (crate::rng::derive(seed, &[0xdeca, index]) >> 32) as u32, period: None }
    }

    /// This layer made to repeat every `width` x `height` pixels, so a
    /// texture drawn from it over that size tiles seamlessly: every
    /// lattice wraps around (its hash is taken modulo the number of
    /// lattice cells that fit the period). A feature scale is rounded so a
    /// whole number of cells fits each side (at least one), which
    /// stretches cells by up to half a cell over the period (a few percent
    /// on a texture many cells wide), and [`Layer::fbm`]'s octaves are
    /// offset instead of rotated against each other (a rotated lattice
    /// cannot repeat on the axes).
    /// The period need not be a whole number of pixels (a texture read in
    /// squeezed coordinates repeats every squeezed width); [`Layer::white`]
    /// rounds it.
    pub fn tiling(self, width: f32, height: f32) -> Self {
        Layer { period: Some((width.max(1.0), height.max(1.0))), ..self }
    }

    /// This layer's period with another hash key.
    fn keyed(self, key: u32) -> Self {
        Layer { key, ..self }
    }

    /// For features of `scale` pixels repeating every `(w, h)` pixels: the
    /// lattice cells per period on each axis and the factors from pixels to
    /// lattice units.
    #[inline]
    fn lattice(scale: f32, (w, h): (f32, f32)) -> ((i32, i32), (f32, f32)) {
        let cells = |side: f32| ((side / scale).round() as i32).max(1);
        let (cx, cy) = (cells(w), cells(h));
        ((cx, cy), (cx as f32 / w, cy as f32 / h))
    }

    /// Pixel (x, y) in the lattice units of cells of `cell` pixels, the
    /// lattice's period in cells (0: none) and the side of a cell in
    /// pixels (the mean of the two axes' when tiling stretched them).
    #[inline]
    fn cells(self, x: f32, y: f32, cell: f32) -> ((f32, f32), (i32, i32), f32) {
        match self.period {
            None => ((x / cell, y / cell), (0, 0), cell),
            Some(period) => {
                let (cells, (kx, ky)) = Self::lattice(cell, period);
                ((x * kx, y * ky), cells, 2.0 / (kx + ky))
            }
        }
    }

    /// Lattice point (x, y) folded into a period of `cells` (0: unfolded).
    #[inline]
    fn fold((x, y): (i32, i32), (cx, cy): (i32, i32)) -> (i32, i32) {
        (if cx > 0 { x.rem_euclid(cx) } else { x }, if cy > 0 { y.rem_euclid(cy) } else { y })
    }

    /// A well-mixed 32-bit hash of lattice point (x, y).
    #[inline]
    fn hash(self, x: i32, y: i32) -> u32 {
        let mut h = self.key ^ (x as u32).wrapping_mul(0x8da6_b343) ^ (y as u32).wrapping_mul(0xd816_3841);
        h = (h ^ (h >> 16)).wrapping_mul(0x7feb_352d);
        h = (h ^ (h >> 15)).wrapping_mul(0x846c_a68b);
        h ^ (h >> 16)
    }

    /// Uniform in [0, 1) at lattice point (x, y) (a pixel; folded into the period).
    #[inline]
    pub fn white(self, x: i32, y: i32) -> f32 {
        let (x, y) = match self.period {
            Some((w, h)) => Self::fold((x, y), ((w.round() as i32).max(1), (h.round() as i32).max(1))),
            None => (x, y),
        };
        self.unit(x, y)
    }

    /// Uniform in [0, 1) from the hash of (x, y), unfolded.
    #[inline]
    fn unit(self, x: i32, y: i32) -> f32 {
        (self.hash(x, y) >> 8) as f32 * (1.0 / 16_777_216.0)
    }

    /// Perlin gradient noise at (x, y), lattice spacing 1, in about [-1, 1]
    /// (quintic fade, 16 unit gradient directions).
    #[inline]
    pub fn perlin(self, x: f32, y: f32) -> f32 {
        self.perlin_folded(x, y, (0, 0))
    }

    /// [`Layer::perlin`] on a lattice that repeats every `cells` (0: never).
    #[inline]
    fn perlin_folded(self, x: f32, y: f32, cells: (i32, i32)) -> f32 {
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let (ix, iy) = (x0 as i32, y0 as i32);
        let grad = |i: i32, j: i32, dx: f32, dy: f32| {
            let (i, j) = Self::fold((i, j), cells);
            let [gx, gy] = GRADIENTS[(self.hash(i, j) >> 28) as usize];
            dx * gx + dy * gy
        };
        let fade = |t: f32| t * t * t * (t * (t * 6.0 - 15.0) + 10.0);
        let (u, v) = (fade(fx), fade(fy));
        let a = grad(ix, iy, fx, fy) + u * (grad(ix + 1, iy, fx - 1.0, fy) - grad(ix, iy, fx, fy));
        let b = grad(ix, iy + 1, fx, fy - 1.0) + u * (grad(ix + 1, iy + 1, fx - 1.0, fy - 1.0) - grad(ix, iy + 1, fx, fy - 1.0));
        1.41 * (a + v * (b - a))
    }

    /// Fractal Brownian motion: `octaves` octaves of Perlin noise from
    /// wavelength `scale` pixels down, each `gain` times the amplitude of
    /// the one before at twice the frequency, normalised to about [-1, 1].
    /// Octaves are rotated against each other so lattice axes do not show.
    pub fn fbm(self, x: f32, y: f32, scale: f32, octaves: usize, gain: f32) -> f32 {
        let (mut sum, mut amp, mut norm) = (0.0, 1.0, 0.0);
        if let Some(period) = self.period {
            // Tiling: each octave on its own wrapped lattice, offset.
            let mut s = scale;
            for o in 0..octaves {
                let layer = self.keyed(self.key.wrapping_add((o as u32).wrapping_mul(0x9e37_79b9)));
                let (cells, (kx, ky)) = Self::lattice(s, period);
                let shift = o as f32;
                sum += amp * layer.perlin_folded(x * kx + 17.3 * shift, y * ky - 9.1 * shift, cells);
                norm += amp;
                amp *= gain;
                s *= 0.5;
            }
            return sum / norm;
        }
        let (mut px, mut py) = (x / scale, y / scale);
        for o in 0..octaves {
            let layer = self.keyed(self.key.wrapping_add((o as u32).wrapping_mul(0x9e37_79b9)));
            sum += amp * layer.perlin(px, py);
            norm += amp;
            amp *= gain;
            // Rotate by about 37 degrees and double.
            (px, py) = (1.6 * px - 1.2 * py + 17.3, 1.2 * px + 1.6 * py - 9.1);
        }
        sum / norm
    }

    /// Domain-warped fBm (Quilez): the field sampled at a point displaced
    /// by two more fBm fields of wavelength `scale`, times `warp` pixels.
    /// Gives the swirled, flowing shapes of corrosion and lichen.
    pub fn warped(self, x: f32, y: f32, scale: f32, octaves: usize, warp: f32) -> f32 {
        let qx = self.keyed(self.key ^ 0x5bd1_e995).fbm(x, y, scale, 4, 0.5);
        let qy = self.keyed(self.key ^ 0x1b87_3593).fbm(x + 5.2 * scale, y + 1.3 * scale, scale, 4, 0.5);
        self.fbm(x + warp * qx, y + warp * qy, scale, octaves, 0.5)
    }

    /// Cellular noise over jittered cells of side `cell` pixels: distances
    /// to the nearest and second-nearest feature point (in pixels) and a
    /// hash of the nearest point's cell, uniform in [0, 1).
    pub fn worley(self, x: f32, y: f32, cell: f32) -> Cellular {
        // Distances in pixels: lattice units times the cell side.
        let ((cx, cy), cells, side) = self.cells(x, y, cell);
        let (ix, iy) = (cx.floor() as i32, cy.floor() as i32);
        let mut best = Cellular { f1: f32::MAX, f2: f32::MAX, id: 0.0 };
        for j in iy - 1..=iy + 1 {
            for i in ix - 1..=ix + 1 {
                let (px, py) = self.feature_point(i, j, cells);
                let (dx, dy) = (px - cx, py - cy);
                let d = (dx * dx + dy * dy).sqrt() * side;
                if d < best.f1 {
                    best = Cellular { f2: best.f1, f1: d, id: self.cell_id((i, j), cells) };
                } else if d < best.f2 {
                    best.f2 = d;
                }
            }
        }
        best
    }

    /// The jittered feature point of lattice cell (i, j), in cell units
    /// (its jitter folded into the period of `cells`).
    #[inline]
    fn feature_point(self, i: i32, j: i32, cells: (i32, i32)) -> (f32, f32) {
        let (fi, fj) = Self::fold((i, j), cells);
        let h = self.hash(fi, fj);
        (i as f32 + (h & 0xffff) as f32 / 65536.0, j as f32 + (h >> 16) as f32 / 65536.0)
    }

    /// A hash of lattice cell (i, j) (folded), uniform in [0, 1).
    #[inline]
    fn cell_id(self, at: (i32, i32), cells: (i32, i32)) -> f32 {
        let (i, j) = Self::fold(at, cells);
        self.keyed(self.key ^ 0xc2b2_ae35).unit(i, j)
    }

    /// The exact distance (pixels) from (x, y) to the nearest border of
    /// [`Layer::worley`]'s cells, and the hash of the cell it lies in
    /// (Quilez, "Voronoi edges", 2012: the nearest feature point, then the
    /// distance to its bisectors with every point of the 5 x 5 cells
    /// around it). Half the F2 - F1 gap ([`Cellular::border`]) falls short
    /// of it near a junction of three cells, which drew cracks with black
    /// wedges where they meet. Also the hash of the cell across that
    /// border, so a border segment can be told by its two cells.
    pub fn voronoi_edge(self, x: f32, y: f32, cell: f32) -> VoronoiEdge {
        let ((cx, cy), cells, side) = self.cells(x, y, cell);
        self.edge_of(&self.nearest_border((cx, cy), cells), cells, side)
    }

    /// The [`VoronoiEdge`] of `border`, in pixels of a cell `side` long.
    #[inline]
    fn edge_of(self, border: &Border, cells: (i32, i32), side: f32) -> VoronoiEdge {
        VoronoiEdge { distance: border.distance * side, id: self.cell_id(border.at, cells), across: self.cell_id(border.across, cells) }
    }

    /// The nearest feature point to (cx, cy) (cell units), its nearest
    /// bisector and the cell across it (see [`Layer::voronoi_edge`]).
    #[inline]
    fn nearest_border(self, (cx, cy): (f32, f32), cells: (i32, i32)) -> Border {
        let (ix, iy) = (cx.floor() as i32, cy.floor() as i32);
        let (mut best, mut near, mut at) = (f32::MAX, (0.0, 0.0), (0, 0));
        for j in iy - 1..=iy + 1 {
            for i in ix - 1..=ix + 1 {
                let (px, py) = self.feature_point(i, j, cells);
                let d = (px - cx).powi(2) + (py - cy).powi(2);
                if d < best {
                    (best, near, at) = (d, (px - cx, py - cy), (i, j));
                }
            }
        }
        let (mut distance, mut across, mut far) = (f32::MAX, at, near);
        for j in at.1 - 2..=at.1 + 2 {
            for i in at.0 - 2..=at.0 + 2 {
                if (i, j) == at {
                    continue;
                }
                let (px, py) = self.feature_point(i, j, cells);
                let (rx, ry) = (px - cx, py - cy);
                let (dx, dy) = (rx - near.0, ry - near.1);
                let len = (dx * dx + dy * dy).sqrt();
                let d = (0.5 * (near.0 + rx) * dx + 0.5 * (near.1 + ry) * dy) / len.max(1e-6);
                if len > 1e-6 && d < distance {
                    (distance, across, far) = (d, (i, j), (rx, ry));
                }
            }
        }
        Border { distance, near, at, far, across }
    }

    /// [`Layer::voronoi_edge`] and where (x, y) lies along its nearest
    /// border segment: the segment is the part of the bisector of the two
    /// cells' feature points N and A that is nearer to them than to any
    /// other point K (each K bounds the line's parameter t on one side,
    /// since |Q(t) - N|^2 - |Q(t) - K|^2 is linear in t), and the point's
    /// projection onto it is measured from both ends. Each end is a
    /// junction with a third cell, whose hash is given, so the two other
    /// segments that meet there can be told ([`segment_hash`]).
    pub fn voronoi_span(self, x: f32, y: f32, cell: f32) -> (VoronoiEdge, Span) {
        let ((cx, cy), cells, side) = self.cells(x, y, cell);
        let border = self.nearest_border((cx, cy), cells);
        let edge = self.edge_of(&border, cells, side);
        let Border { near, at, far, across, .. } = border;
        // The bisector Q(t) = M + t u, with the point itself at the origin.
        let (mx, my) = (0.5 * (near.0 + far.0), 0.5 * (near.1 + far.1));
        let (nx, ny) = (far.0 - near.0, far.1 - near.1);
        let len = (nx * nx + ny * ny).sqrt().max(1e-6);
        let (ux, uy) = (-ny / len, nx / len);
        let here = -(mx * ux + my * uy);
        let near_sq = near.0 * near.0 + near.1 * near.1;
        // Clipped to at most 3 cells either way (a border is never longer).
        let (mut lo, mut hi) = ((here - 3.0, 0.0f32), (here + 3.0, 0.0f32));
        for j in at.1 - 2..=at.1 + 2 {
            for i in at.0 - 2..=at.0 + 2 {
                if (i, j) == at || (i, j) == across {
                    continue;
                }
                let (px, py) = self.feature_point(i, j, cells);
                let (kx, ky) = (px - cx, py - cy);
                // a t + b <= 0 keeps Q(t) nearer N than K.
                let (ex, ey) = (kx - near.0, ky - near.1);
                let a = 2.0 * (ux * ex + uy * ey);
                let b = 2.0 * (mx * ex + my * ey) + near_sq - (kx * kx + ky * ky);
                if a.abs() < 1e-9 {
                    continue;
                }
                let t = -b / a;
                if a > 0.0 && t < hi.0 {
                    hi = (t, self.cell_id((i, j), cells));
                } else if a < 0.0 && t > lo.0 {
                    lo = (t, self.cell_id((i, j), cells));
                }
            }
        }
        let span = Span { before: ((here - lo.0) * side).max(0.0), after: ((hi.0 - here) * side).max(0.0), ends: [lo.1, hi.1] };
        (edge, span)
    }
}

/// A hash of the border segment between the cells with hashes `a` and
/// `b`, uniform-ish in [0, 1): the same either way round.
#[inline]
pub fn segment_hash(a: f32, b: f32) -> f32 {
    (13.7 * (a + b) + 31.1 * a * b).fract()
}

/// Where a point lies along its nearest Voronoi border segment
/// ([`Layer::voronoi_span`]).
#[derive(Clone, Copy, Debug)]
pub struct Span {
    /// Pixels from the segment's first end to the point's projection on it.
    pub before: f32,
    /// Pixels from the point's projection to the segment's other end.
    pub after: f32,
    /// The hash of the third cell that meets the segment at each end
    /// (`before`'s end first).
    pub ends: [f32; 2],
}

/// [`Layer::nearest_border`]'s answer, in cell units relative to the point.
struct Border {
    /// Distance to the nearest bisector.
    distance: f32,
    /// The nearest feature point, and its lattice cell.
    near: (f32, f32),
    at: (i32, i32),
    /// The feature point across that bisector, and its lattice cell.
    far: (f32, f32),
    across: (i32, i32),
}

/// The result of [`Layer::voronoi_edge`].
#[derive(Clone, Copy, Debug)]
pub struct VoronoiEdge {
    /// Distance to the nearest cell border, in pixels.
    pub distance: f32,
    /// A hash of the cell the point lies in, uniform in [0, 1) (as [`Cellular::id`]).
    pub id: f32,
    /// The hash of the cell across the nearest border.
    pub across: f32,
}

impl VoronoiEdge {
    /// A hash of the nearest border segment, uniform-ish in [0, 1): the
    /// same from both of its cells.
    pub fn segment(&self) -> f32 {
        segment_hash(self.id, self.across)
    }
}

/// The result of [`Layer::worley`].
#[derive(Clone, Copy, Debug)]
pub struct Cellular {
    /// Distance to the nearest feature point, in pixels.
    pub f1: f32,
    /// Distance to the second-nearest feature point, in pixels.
    pub f2: f32,
    /// A hash of the nearest feature point, uniform in [0, 1).
    pub id: f32,
}

impl Cellular {
    /// Approximate distance to the cell border (the crack line), in pixels:
    /// half the F2 - F1 gap.
    pub fn border(&self) -> f32 {
        0.5 * (self.f2 - self.f1)
    }
}

/// Hermite smoothstep of `x` between `a` and `b`.
#[inline]
pub fn smoothstep(a: f32, b: f32, x: f32) -> f32 {
    let t = ((x - a) / (b - a)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// Linear interpolation of colours.
#[inline]
pub fn mix3(a: [f32; 3], b: [f32; 3], t: f32) -> [f32; 3] {
    [a[0] + (b[0] - a[0]) * t, a[1] + (b[1] - a[1]) * t, a[2] + (b[2] - a[2]) * t]
}

/// A colour ramp: piecewise-linear through `stops` (position, sRGB colour),
/// positions ascending; clamped outside.
pub fn ramp(stops: &[(f32, [f32; 3])], t: f32) -> [f32; 3] {
    let i = stops.iter().position(|s| s.0 >= t).unwrap_or(stops.len());
    match i {
        0 => stops[0].1,
        i if i == stops.len() => stops[i - 1].1,
        i => {
            let (a, b) = (stops[i - 1], stops[i]);
            mix3(a.1, b.1, (t - a.0) / (b.0 - a.0).max(1e-6))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The exact border distance agrees with a brute-force one (the
    /// nearest bisector among the feature points of 7 x 7 cells), is never
    /// below half the F2 - F1 gap, and a border segment has one hash from
    /// both sides.
    #[test]
    fn voronoi_edges_are_exact_and_segments_are_shared() {
        let layer = Layer::new(3, 9);
        let cell = 20.0;
        let mut short = 0;
        for k in 0..400 {
            let (x, y) = ((k % 20) as f32 * 7.3 + 0.4, (k / 20) as f32 * 6.1 + 0.7);
            let (cx, cy) = (x / cell, y / cell);
            let points: Vec<(f32, f32)> = (-3..=3)
                .flat_map(|j| (-3..=3).map(move |i| (i, j)))
                .map(|(i, j)| layer.feature_point(cx.floor() as i32 + i, cy.floor() as i32 + j, (0, 0)))
                .collect();
            let d2 = |p: &(f32, f32)| (p.0 - cx).powi(2) + (p.1 - cy).powi(2);
            let near = *points.iter().min_by(|a, b| d2(a).total_cmp(&d2(b))).unwrap();
            let truth = points
                .iter()
                .filter(|p| **p != near)
                .map(|p| {
                    let (dx, dy) = (p.0 - near.0, p.1 - near.1);
                    let (mx, my) = (0.5 * (p.0 + near.0) - cx, 0.5 * (p.1 + near.1) - cy);
                    (mx * dx + my * dy) / (dx * dx + dy * dy).sqrt()
                })
                .fold(f32::MAX, f32::min)
                * cell;
            let edge = layer.voronoi_edge(x, y, cell);
            assert!((edge.distance - truth).abs() < 1e-3, "({x}, {y}): {} vs {truth}", edge.distance);
            let gap = layer.worley(x, y, cell).border();
            assert!(gap <= edge.distance + 1e-3);
            short += (gap < edge.distance - 0.1 * cell) as usize;
        }
        assert!(short > 0, "the F2 - F1 gap should fall short somewhere near a junction");
        // Walk across a border: the segment hash is the same on both sides.
        let (mut x, y) = (5.0f32, 33.0f32);
        let first = layer.voronoi_edge(x, y, cell);
        while layer.voronoi_edge(x, y, cell).id == first.id {
            x += 0.25;
        }
        let (before, after) = (layer.voronoi_edge(x - 0.25, y, cell), layer.voronoi_edge(x, y, cell));
        assert_eq!(before.across, after.id);
        assert_eq!(before.segment(), after.segment());
    }

    /// A point's place along its border segment agrees with a march along
    /// the bisector of its two cells' feature points, from the point's
    /// projection both ways until a third feature point is nearer than
    /// the two: the march's lengths are the span's, and the point that
    /// takes over at each end is the third cell the span names.
    #[test]
    fn a_span_measures_the_segment_from_both_ends() {
        let layer = Layer::new(7, 2);
        let cell = 16.0;
        let step = 1e-3;
        for k in 0..60 {
            let (x, y) = ((k % 10) as f32 * 9.7 + 3.1, (k / 10) as f32 * 11.3 + 1.9);
            let (edge, span) = layer.voronoi_span(x, y, cell);
            let (cx, cy) = (x / cell, y / cell);
            let cells: Vec<((i32, i32), (f32, f32))> = (-4..=4)
                .flat_map(|j| (-4..=4).map(move |i| (cx.floor() as i32 + i, cy.floor() as i32 + j)))
                .map(|c| (c, layer.feature_point(c.0, c.1, (0, 0))))
                .collect();
            let d2 = |p: (f32, f32), q: (f32, f32)| (p.0 - q.0).powi(2) + (p.1 - q.1).powi(2);
            let (at, n) = *cells.iter().min_by(|a, b| d2(a.1, (cx, cy)).total_cmp(&d2(b.1, (cx, cy)))).unwrap();
            // The cell across: its hash, and its bisector at the border's distance
            // (two cells can share a hash).
            let bisector = |p: (f32, f32)| {
                let (dx, dy) = (p.0 - n.0, p.1 - n.1);
                ((0.5 * (p.0 + n.0) - cx) * dx + (0.5 * (p.1 + n.1) - cy) * dy) / (dx * dx + dy * dy).sqrt() * cell
            };
            let (across, a) = *cells
                .iter()
                .filter(|c| c.0 != at && layer.cell_id(c.0, (0, 0)) == edge.across)
                .find(|c| (bisector(c.1) - edge.distance).abs() < 1e-3)
                .expect("the cell across is among the neighbours");
            let (ux, uy) = {
                let (dx, dy) = (a.0 - n.0, a.1 - n.1);
                let len = (dx * dx + dy * dy).sqrt();
                (-dy / len, dx / len)
            };
            let (mx, my) = (0.5 * (n.0 + a.0), 0.5 * (n.1 + a.1));
            let here = (cx - mx) * ux + (cy - my) * uy;
            let march = |sign: f32| {
                let mut t = here;
                loop {
                    t += sign * step;
                    let q = (mx + t * ux, my + t * uy);
                    let dn = d2(n, q);
                    if let Some(k) = cells.iter().find(|c| c.0 != at && c.0 != across && d2(c.1, q) < dn) {
                        return ((t - here).abs() * cell, layer.cell_id(k.0, (0, 0)));
                    }
                }
            };
            let ((before, first), (after, second)) = (march(-1.0), march(1.0));
            assert!((span.before - before).abs() < 0.05 && (span.after - after).abs() < 0.05, "({x}, {y}): {span:?} vs {before} {after}");
            assert_eq!(span.ends, [first, second], "({x}, {y})");
        }
    }

    #[test]
    fn perlin_is_zero_mean_bounded_and_seeded() {
        let (a, b) = (Layer::new(1, 0), Layer::new(2, 0));
        let samples: Vec<f32> = (0..10_000).map(|i| a.perlin(i as f32 * 0.37, (i / 100) as f32 * 0.41)).collect();
        let mean = samples.iter().sum::<f32>() / samples.len() as f32;
        assert!(mean.abs() < 0.05, "mean {mean}");
        assert!(samples.iter().all(|v| v.abs() <= 1.05));
        assert!(samples.iter().map(|v| v.abs()).fold(0.0f32, f32::max) > 0.6);
        assert_ne!(a.perlin(3.3, 4.4), b.perlin(3.3, 4.4));
        assert_eq!(a.perlin(3.3, 4.4), Layer::new(1, 0).perlin(3.3, 4.4));
    }

    #[test]
    fn worley_distances_are_ordered_and_zero_at_feature_points() {
        let l = Layer::new(3, 1);
        let mut min_f1 = f32::MAX;
        for y in 0..64 {
            for x in 0..64 {
                let c = l.worley(x as f32, y as f32, 16.0);
                assert!(c.f1 <= c.f2 && c.f1 >= 0.0);
                assert!(c.f1 <= 16.0 * 1.5, "F1 {} beyond the cell diagonal", c.f1);
                min_f1 = min_f1.min(c.f1);
            }
        }
        assert!(min_f1 < 1.0);
    }
}
