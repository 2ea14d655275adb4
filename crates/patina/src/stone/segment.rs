//! Patches, the unit of editing: Felzenszwalb-Huttenlocher graph
//! segmentation of the weathering tendency, small regions merged, oversized
//! ones bisected (Xue et al. 2011, section 3.1).

use crate::image::{Image, Mask};

/// One patch: its pixels (row-major indices, ascending) and centroid.
#[derive(Clone, Debug)]
pub struct Patch {
    pub pixels: Vec<u32>,
    pub centroid: (f32, f32),
}

/// Segmentation settings.
#[derive(Clone, Copy, Debug)]
pub struct SegmentParams {
    /// FH scale K: larger gives larger regions. The edge weights are
    /// tendency differences in 0..255 units, the scale FH's K refers to.
    pub k: f32,
    /// Minimum region size Omega = N(I) / n.
    pub n: f32,
    /// Regions larger than `max_factor` x Omega are bisected.
    pub max_factor: f32,
}

impl Default for SegmentParams {
    fn default() -> Self {
        SegmentParams { k: 100.0, n: 3200.0, max_factor: 4.0 }
    }
}

/// Union-find with FH's internal difference per component.
struct Forest {
    parent: Vec<u32>,
    size: Vec<u32>,
    internal: Vec<f32>,
}

impl Forest {
    fn new(n: usize) -> Self {
        Forest { parent: (0..n as u32).collect(), size: vec![1; n], internal: vec![0.0; n] }
    }
    fn find(&mut self, mut a: u32) -> u32 {
        while self.parent[a as usize] != a {
            let p = self.parent[a as usize];
            self.parent[a as usize] = self.parent[p as usize];
            a = p;
        }
        a
    }
    fn join(&mut self, a: u32, b: u32, weight: f32) {
        let (big, small) = if self.size[a as usize] >= self.size[b as usize] { (a, b) } else { (b, a) };
        self.parent[small as usize] = big;
        self.size[big as usize] += self.size[small as usize];
        self.internal[big as usize] = weight;
    }
}

/// Segment the object into patches. `tendency` is d(x) in [0, 1].
///
/// 1. FH on the 8-connected grid of object pixels, weight |d(p) - d(q)| x 255:
///    merge across an edge when its weight is at most both components'
///    Int(C) + K / |C|.
/// 2. Components under Omega = N / n pixels are merged into a neighbour
///    along the lightest edges (FH's post-processing).
/// 3. Components over `max_factor` x Omega are cut in two along a wavy
///    line across the longer side of their bounding box ([`bisect`]),
///    until none is.
pub fn segment(tendency: &Image, mask: &Mask, params: &SegmentParams) -> Vec<Patch> {
    let (w, h) = tendency.size();
    let object = mask.count();
    let omega = ((object as f32 / params.n.max(1.0)).round() as u32).max(1);
    let d = tendency.data();
    let mut edges: Vec<(f32, u32, u32)> = Vec::with_capacity(4 * object);
    for y in 0..h {
        for x in 0..w {
            if !mask.get(x, y) {
                continue;
            }
            let p = y * w + x;
            for (dx, dy) in [(1isize, 0isize), (0, 1), (1, 1), (-1, 1)] {
                let (qx, qy) = (x as isize + dx, y as isize + dy);
                if qx < 0 || qx >= w as isize || qy >= h as isize || !mask.get(qx as usize, qy as usize) {
                    continue;
                }
                let q = qy as usize * w + qx as usize;
                edges.push(((d[p] - d[q]).abs() * 255.0, p as u32, q as u32));
            }
        }
    }
    // The pixel indices make every key unique, so the order is deterministic.
    edges.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));
    let mut forest = Forest::new(w * h);
    for &(wt, p, q) in &edges {
        let (a, b) = (forest.find(p), forest.find(q));
        if a == b {
            continue;
        }
        let ta = forest.internal[a as usize] + params.k / forest.size[a as usize] as f32;
        let tb = forest.internal[b as usize] + params.k / forest.size[b as usize] as f32;
        if wt <= ta.min(tb) {
            forest.join(a, b, wt);
        }
    }
    for &(wt, p, q) in &edges {
        let (a, b) = (forest.find(p), forest.find(q));
        if a != b && (forest.size[a as usize] < omega || forest.size[b as usize] < omega) {
            forest.join(a, b, wt.max(forest.internal[a as usize]).max(forest.internal[b as usize]));
        }
    }
    // Gather components in order of their first pixel.
    let mut slot = vec![u32::MAX; w * h];
    let mut groups: Vec<Vec<u32>> = Vec::new();
    for p in 0..(w * h) as u32 {
        if !mask.bits()[p as usize] {
            continue;
        }
        let root = forest.find(p) as usize;
        if slot[root] == u32::MAX {
            slot[root] = groups.len() as u32;
            groups.push(Vec::new());
        }
        groups[slot[root] as usize].push(p);
    }
    let limit = ((omega as f32 * params.max_factor).ceil() as usize).max(2);
    let mut patches = Vec::with_capacity(groups.len());
    let mut stack: Vec<Vec<u32>> = groups.into_iter().rev().collect();
    while let Some(pixels) = stack.pop() {
        if pixels.len() > limit {
            let (a, b) = bisect(pixels, w);
            stack.push(b);
            stack.push(a);
        } else {
            patches.push(make_patch(pixels, w));
        }
    }
    patches
}

/// Split in two halves across the longer side of the bounding box, along a
/// wavy line: pixels are ordered by their coordinate along that side plus a
/// smooth noise of a third of its length, and split at the median. A
/// straight cut at the median coordinate (the paper's) turns an even
/// tendency into a grid of rectangles.
fn bisect(pixels: Vec<u32>, w: usize) -> (Vec<u32>, Vec<u32>) {
    let xy = |p: u32| ((p as usize % w) as f32, (p as usize / w) as f32);
    let (x0, y0, x1, y1) = super::bounds(pixels.iter().map(|&p| p as usize), w).expect("only oversized patches are bisected");
    let along_x = x1 - x0 >= y1 - y0;
    let extent = ((x1 - x0).max(y1 - y0) + 1) as f32;
    let wave = extent / 2.0;
    let seed = crate::rng::derive(0xb15ec7, &[pixels[0] as u64, pixels.len() as u64]);
    let mut keyed: Vec<(f32, u32)> = pixels
        .iter()
        .map(|&p| {
            let (x, y) = xy(p);
            let noise = crate::samples::value_noise(seed, x / wave, y / wave) - 0.5;
            ((if along_x { x } else { y }) + extent / 3.0 * noise, p)
        })
        .collect();
    keyed.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    let half = keyed.len() / 2;
    let mut a: Vec<u32> = keyed[..half].iter().map(|k| k.1).collect();
    let mut b: Vec<u32> = keyed[half..].iter().map(|k| k.1).collect();
    a.sort_unstable();
    b.sort_unstable();
    (a, b)
}

fn make_patch(pixels: Vec<u32>, w: usize) -> Patch {
    let n = pixels.len() as f64;
    let (sx, sy) = pixels.iter().fold((0f64, 0f64), |(sx, sy), &p| (sx + (p as usize % w) as f64, sy + (p as usize / w) as f64));
    Patch { centroid: ((sx / n) as f32, (sy / n) as f32), pixels }
}

/// Patch labels as a false-colour RGB image (background black).
pub fn false_colour(patches: &[Patch], (w, h): (usize, usize)) -> Image {
    let mut img = Image::new(w, h, 3);
    for (i, patch) in patches.iter().enumerate() {
        let hash = crate::rng::derive(0x5e9, &[i as u64]);
        let rgb = [0, 8, 16].map(|s| 0.25 + 0.75 * ((hash >> s) & 0xff) as f32 / 255.0);
        for &p in &patch.pixels {
            img.pixel_mut(p as usize % w, p as usize / w).copy_from_slice(&rgb);
        }
    }
    img
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn patches_cover_the_object_once_and_respect_the_size_limits() {
        let (w, h) = (90, 70);
        let d = Image::from_fn(w, h, 1, |x, y, p| p[0] = if (x / 15 + y / 20) % 2 == 0 { 0.1 } else { 0.9 });
        let mask = Mask::from_fn(w, h, |x, y| (x as f32 - 45.0).powi(2) + (y as f32 - 35.0).powi(2) < 900.0);
        let params = SegmentParams { n: 100.0, ..Default::default() };
        let patches = segment(&d, &mask, &params);
        let omega = (mask.count() as f32 / 100.0).round() as usize;
        let mut seen = vec![0u8; w * h];
        for p in &patches {
            assert!(p.pixels.len() <= 4 * omega, "patch of {} px over the limit {}", p.pixels.len(), 4 * omega);
            for &i in &p.pixels {
                seen[i as usize] += 1;
            }
        }
        for (i, &s) in seen.iter().enumerate() {
            assert_eq!(s as usize, mask.bits()[i] as usize, "pixel {i}");
        }
        // Regions follow the tendency: no patch straddles the step much.
        let mixed = patches
            .iter()
            .filter(|p| {
                let hi = p.pixels.iter().filter(|&&i| d.data()[i as usize] > 0.5).count();
                hi > 0 && hi < p.pixels.len() / 5 || hi > p.pixels.len() * 4 / 5 && hi < p.pixels.len()
            })
            .count();
        assert!(mixed * 10 <= patches.len(), "{mixed} of {} patches straddle a tendency step", patches.len());
    }
}
