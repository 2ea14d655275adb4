//! Tileable (wrap-around) synthesis: texture optimization on a torus.
//!
//! The target of one pyramid level and its nearest-neighbour field are
//! worked on padded by the patch radius `r` on every side, the ring holding
//! the opposite edges' pixels and matches. Patch distances at the border
//! then compare the patch as it continues across the tile's edge, votes at
//! the border count the patches that wrap over it, and PatchMatch
//! propagates matches across it; only the interior is searched and voted,
//! and the ring is refreshed from it after each step. The output's left
//! edge then continues its right edge and its top its bottom, so the
//! texture repeats without a seam.

use super::nnf::Nnf;
use crate::image::{Image, Mask};

/// The wrap-around padding of one `w` x `h` level for patches of radius `r`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Torus {
    w: usize,
    h: usize,
    r: usize,
}

impl Torus {
    pub fn new(w: usize, h: usize, r: usize) -> Self {
        Torus { w, h, r }
    }

    /// The padded size.
    fn padded(&self) -> (usize, usize) {
        (self.w + 2 * self.r, self.h + 2 * self.r)
    }

    /// The tile position a padded position wraps to.
    fn wrap(&self, px: usize, py: usize) -> (usize, usize) {
        let r = self.r as isize;
        ((px as isize - r).rem_euclid(self.w as isize) as usize, (py as isize - r).rem_euclid(self.h as isize) as usize)
    }

    /// `img` (the tile) padded with its own opposite edges.
    pub fn pad_image(&self, img: &Image) -> Image {
        debug_assert_eq!(img.size(), (self.w, self.h));
        let (pw, ph) = self.padded();
        Image::from_fn(pw, ph, img.channels(), |x, y, p| {
            let (sx, sy) = self.wrap(x, y);
            p.copy_from_slice(img.pixel(sx, sy));
        })
    }

    /// The tile inside a padded image.
    pub fn crop_image(&self, padded: &Image) -> Image {
        let mut out = padded.crop(self.r, self.r, self.w, self.h).expect("the tile lies inside its padding");
        out.set_groups(padded.groups().to_vec()).expect("same channels");
        out
    }

    /// The ring's positions in the padded level, each with the padded
    /// position of the interior pixel it holds.
    fn ring(&self) -> impl Iterator<Item = ((usize, usize), (usize, usize))> + '_ {
        let (pw, ph) = self.padded();
        let r = self.r;
        (0..ph)
            .flat_map(move |y| (0..pw).map(move |x| (x, y)))
            .filter(move |&(x, y)| x < r || y < r || x >= r + self.w || y >= r + self.h)
            .map(move |(x, y)| {
                let (sx, sy) = self.wrap(x, y);
                ((x, y), (sx + r, sy + r))
            })
    }

    /// A padded image's ring set again from its interior, in place (once
    /// per search and vote step, so no whole-level copies).
    pub fn refresh_image(&self, padded: &mut Image) {
        let (pw, c) = (padded.width(), padded.channels());
        let data = padded.data_mut();
        for ((x, y), (sx, sy)) in self.ring() {
            let from = (sy * pw + sx) * c;
            data.copy_within(from..from + c, (y * pw + x) * c);
        }
    }

    /// `field` (over the tile) padded with its own opposite edges' matches.
    pub fn pad_nnf(&self, field: &Nnf) -> Nnf {
        debug_assert_eq!((field.width(), field.height()), (self.w, self.h));
        let (pw, ph) = self.padded();
        let matches = (0..pw * ph)
            .map(|i| {
                let (sx, sy) = self.wrap(i % pw, i / pw);
                field.get(sx, sy)
            })
            .collect();
        Nnf::from_matches(pw, ph, matches)
    }

    /// The tile's part of a padded field.
    pub fn crop_nnf(&self, padded: &Nnf) -> Nnf {
        let matches = (0..self.w * self.h).map(|i| padded.get(i % self.w + self.r, i / self.w + self.r)).collect();
        Nnf::from_matches(self.w, self.h, matches)
    }

    /// A padded field's ring set again from its interior, in place.
    pub fn refresh_nnf(&self, padded: &mut Nnf) {
        let pw = padded.width();
        let matches = padded.matches_mut();
        for ((x, y), (sx, sy)) in self.ring() {
            matches[y * pw + x] = matches[sy * pw + sx];
        }
    }

    /// The interior of the padded level (where pixels are searched and voted).
    pub fn interior(&self) -> Mask {
        let (pw, ph) = self.padded();
        let r = self.r;
        Mask::from_fn(pw, ph, |x, y| x >= r && y >= r && x < r + self.w && y < r + self.h)
    }

    /// A mask over the tile, padded with its opposite edges and limited to
    /// the interior: pixels flagged near one edge also flag the pixels
    /// across it once dilated.
    pub fn pad_mask(&self, mask: &Mask) -> Mask {
        let (pw, ph) = self.padded();
        Mask::from_fn(pw, ph, |x, y| {
            let (sx, sy) = self.wrap(x, y);
            mask.get(sx, sy)
        })
    }

    /// `mask` (over the tile) dilated by the padding radius, wrapping
    /// around the tile's edges.
    pub fn dilate(&self, mask: &Mask) -> Mask {
        let grown = self.pad_mask(mask).dilate(self.r);
        Mask::from_fn(self.w, self.h, |x, y| grown.get(x + self.r, y + self.r))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth::nnf::Match;

    #[test]
    fn the_ring_holds_the_opposite_edges_and_crops_back() {
        let img = Image::from_fn(7, 5, 2, |x, y, p| {
            p[0] = x as f32;
            p[1] = y as f32;
        });
        let t = Torus::new(7, 5, 2);
        let p = t.pad_image(&img);
        assert_eq!(p.size(), (11, 9));
        assert_eq!(p.pixel(0, 0), &[5.0, 3.0], "top-left ring pixel is the tile's bottom-right");
        assert_eq!(p.pixel(10, 8), &[1.0, 1.0]);
        assert_eq!(p.pixel(2, 2), &[0.0, 0.0]);
        assert_eq!(t.crop_image(&p).data(), img.data());
        let field = Nnf::from_matches(7, 5, (0..35).map(|i| Match { x: i, y: 0, cost: 0.0 }).collect());
        let pf = t.pad_nnf(&field);
        assert_eq!(pf.get(1, 2).x, 6, "left ring column 1 is the tile's last column");
        assert_eq!(t.crop_nnf(&pf), field);
        assert_eq!(t.interior().count(), 35);
        // Refreshing the ring after the interior changed is padding anew.
        let mut changed = p.clone();
        changed.pixel_mut(2, 2)[0] = 9.0;
        let want = t.pad_image(&t.crop_image(&changed));
        t.refresh_image(&mut changed);
        assert_eq!(changed.data(), want.data());
        let mut moved = pf.clone();
        moved.matches_mut()[2 * 11 + 8].x = 99;
        let want = t.pad_nnf(&t.crop_nnf(&moved));
        t.refresh_nnf(&mut moved);
        assert_eq!(moved, want);
        // A tile smaller than the padding still wraps (several times).
        let tiny = Torus::new(2, 2, 3);
        let q = tiny.pad_image(&Image::from_fn(2, 2, 1, |x, y, p| p[0] = (x + 2 * y) as f32));
        assert_eq!(q.size(), (8, 8));
        assert_eq!(q.pixel(0, 0), &[3.0]);
    }
}
