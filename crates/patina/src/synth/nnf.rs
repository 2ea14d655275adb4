//! Nearest-neighbour fields: for each target pixel, the centre of the source
//! patch it maps to and that match's cost.

use crate::error::{Error, Result};
use crate::image::Mask;
use crate::rng::{self, Rng};

/// One target pixel's match: source patch centre and its cost.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Match {
    pub x: u32,
    pub y: u32,
    pub cost: f32,
}

/// A nearest-neighbour field over a target of `width` x `height` pixels.
#[derive(Clone, Debug, PartialEq)]
pub struct Nnf {
    width: usize,
    height: usize,
    matches: Vec<Match>,
}

impl Nnf {
    pub fn from_matches(width: usize, height: usize, matches: Vec<Match>) -> Self {
        assert_eq!(matches.len(), width * height);
        Nnf { width, height, matches }
    }
    pub fn width(&self) -> usize {
        self.width
    }
    pub fn height(&self) -> usize {
        self.height
    }
    pub fn get(&self, x: usize, y: usize) -> Match {
        self.matches[y * self.width + x]
    }
    pub fn matches(&self) -> &[Match] {
        &self.matches
    }
    pub fn matches_mut(&mut self) -> &mut [Match] {
        &mut self.matches
    }
    /// Mean cost over all pixels (or those in `mask`).
    pub fn mean_cost(&self, mask: Option<&Mask>) -> f32 {
        let (mut sum, mut n) = (0f64, 0usize);
        for (i, m) in self.matches.iter().enumerate() {
            if mask.is_none_or(|k| k.bits()[i]) {
                sum += m.cost as f64;
                n += 1;
            }
        }
        if n == 0 {
            0.0
        } else {
            (sum / n as f64) as f32
        }
    }
}

/// Where source patch centres may lie: inside the source with the whole
/// patch in bounds, and (with a mask) with every pixel of the patch allowed.
#[derive(Clone, Debug)]
pub struct SourceDomain {
    width: usize,
    height: usize,
    radius: usize,
    valid: Vec<bool>,
    list: Vec<u32>,
}

impl SourceDomain {
    /// The usable centres of a `width` x `height` source for patches of
    /// radius `radius`; `allowed` marks the source pixels patches may use.
    pub fn new(width: usize, height: usize, radius: usize, allowed: Option<&Mask>) -> Result<Self> {
        if width < 2 * radius + 1 || height < 2 * radius + 1 {
            return Err(Error::invalid(format!("the source ({width}x{height}) is smaller than one {0}x{0} patch", 2 * radius + 1)));
        }
        let valid: Vec<bool> = match allowed {
            Some(m) => {
                if m.size() != (width, height) {
                    return Err(Error::invalid(format!("source mask is {}x{} but the source is {width}x{height}", m.width(), m.height())));
                }
                m.erode(radius).bits().to_vec()
            }
            None => (0..width * height)
                .map(|i| {
                    let (x, y) = (i % width, i / width);
                    x >= radius && y >= radius && x + radius < width && y + radius < height
                })
                .collect(),
        };
        let list: Vec<u32> = valid.iter().enumerate().filter(|(_, &v)| v).map(|(i, _)| i as u32).collect();
        if list.is_empty() {
            return Err(Error::invalid("the source mask leaves no whole patch to copy from"));
        }
        Ok(SourceDomain { width, height, radius, valid, list })
    }
    pub fn radius(&self) -> usize {
        self.radius
    }
    pub fn width(&self) -> usize {
        self.width
    }
    pub fn height(&self) -> usize {
        self.height
    }
    /// Number of usable centres.
    pub fn len(&self) -> usize {
        self.list.len()
    }
    pub fn is_empty(&self) -> bool {
        self.list.is_empty()
    }
    #[inline]
    pub fn contains(&self, x: i64, y: i64) -> bool {
        x >= 0 && y >= 0 && (x as usize) < self.width && (y as usize) < self.height && self.valid[y as usize * self.width + x as usize]
    }
    /// A uniformly random usable centre.
    pub fn random(&self, g: &mut impl Rng) -> (u32, u32) {
        let i = self.list[g.gen_range(0..self.list.len())] as usize;
        ((i % self.width) as u32, (i / self.width) as u32)
    }
    /// Clamp a point into the rectangle of in-bounds centres.
    #[inline]
    pub fn clamp(&self, x: i64, y: i64) -> (i64, i64) {
        let r = self.radius as i64;
        (x.clamp(r, (self.width - 1) as i64 - r), y.clamp(r, (self.height - 1) as i64 - r))
    }
}

/// A field of uniformly random matches (cost unknown: +inf).
pub fn random_nnf(width: usize, height: usize, domain: &SourceDomain, seed: u64) -> Nnf {
    let mut matches = Vec::with_capacity(width * height);
    for y in 0..height {
        let mut g = rng::generator(seed, &[0x494e_4954, y as u64]);
        for _ in 0..width {
            let (x, yy) = domain.random(&mut g);
            matches.push(Match { x, y: yy, cost: f32::INFINITY });
        }
    }
    Nnf { width, height, matches }
}

/// A field made of coherent blocks: the target is cut into `block` x
/// `block` squares, each copying one random region of the source (offsets
/// constant inside a block). Voting it gives a patchwork of real texture
/// rather than the grey average a pixel-random field votes to, which is the
/// initialisation Kwatra et al. (2005) use for texture optimization.
pub fn block_nnf(width: usize, height: usize, domain: &SourceDomain, block: usize, seed: u64) -> Nnf {
    let block = block.max(1);
    let (bx, by) = (width.div_ceil(block), height.div_ceil(block));
    let offsets: Vec<(i64, i64)> = (0..bx * by)
        .map(|b| {
            let mut g = rng::generator(seed, &[0x424c, b as u64]);
            let (sx, sy) = domain.random(&mut g);
            let (cx, cy) = ((b % bx * block) as i64, (b / bx * block) as i64);
            // Centre the block's copy on the drawn centre.
            (sx as i64 - cx - block as i64 / 2, sy as i64 - cy - block as i64 / 2)
        })
        .collect();
    let mut matches = Vec::with_capacity(width * height);
    for y in 0..height {
        let mut g = rng::generator(seed, &[0x424d, y as u64]);
        for x in 0..width {
            let (ox, oy) = offsets[(y / block) * bx + x / block];
            let (sx, sy) = domain.clamp(x as i64 + ox, y as i64 + oy);
            let (sx, sy) = if domain.contains(sx, sy) { (sx as u32, sy as u32) } else { domain.random(&mut g) };
            matches.push(Match { x: sx, y: sy, cost: f32::INFINITY });
        }
    }
    Nnf { width, height, matches }
}

/// A field for a target twice as large (`width` x `height`), keeping each
/// coarse match's offset (the coarse-to-fine step of texture optimization).
/// Matches that fall outside `domain` are moved to the nearest usable centre
/// in bounds, or a random one.
pub fn upsample_nnf(coarse: &Nnf, width: usize, height: usize, domain: &SourceDomain, seed: u64) -> Nnf {
    let mut matches = Vec::with_capacity(width * height);
    for y in 0..height {
        let mut g = rng::generator(seed, &[0x5550, y as u64]);
        for x in 0..width {
            let (cx, cy) = ((x / 2).min(coarse.width - 1), (y / 2).min(coarse.height - 1));
            let m = coarse.get(cx, cy);
            let (sx, sy) = (2 * m.x as i64 + (x % 2) as i64, 2 * m.y as i64 + (y % 2) as i64);
            let (sx, sy) = domain.clamp(sx, sy);
            let (sx, sy) = if domain.contains(sx, sy) { (sx as u32, sy as u32) } else { domain.random(&mut g) };
            matches.push(Match { x: sx, y: sy, cost: f32::INFINITY });
        }
    }
    Nnf { width, height, matches }
}
