//! Voting (Wexler et al. 2007; Kwatra et al. 2005): each target pixel
//! becomes the average of the values that the overlapping patches of the
//! nearest-neighbour field propose for it.

use super::nnf::Nnf;
use crate::image::{Image, Mask};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// How overlapping proposals are combined.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum VoteWeights {
    /// Every proposal weighs the same (EbSynth).
    Mean,
    /// Kwatra et al. 2005's robust weights w = (E / P^2 + eps)^((rho - 2) / 2)
    /// with rho = 0.8: proposals from well-matching patches dominate, which
    /// keeps edges sharp where plain averaging blurs them.
    Robust,
}

/// Robust-voting exponent (rho - 2) / 2 with Kwatra's rho = 0.8.
const ROBUST_EXPONENT: f32 = -0.6;
/// Mean squared error per texel below which patches count as exact.
const ROBUST_EPS: f32 = 1e-4;

/// Write the vote of `nnf` (patches of radius `r` from `source`) into
/// `target`, at every pixel or only those set in `only`.
pub fn vote(nnf: &Nnf, source: &Image, r: usize, target: &mut Image, only: Option<&Mask>, weights: VoteWeights) {
    let (w, h, n) = (target.width(), target.height(), target.channels());
    assert_eq!(source.channels(), n, "vote: source and target channels differ");
    assert_eq!((nnf.width(), nnf.height()), (w, h), "vote: field and target sizes differ");
    let (sw, sd) = (source.width(), source.data());
    let ri = r as isize;
    let texels = ((2 * r + 1) * (2 * r + 1)) as f32;
    let weight = |cost: f32| match weights {
        VoteWeights::Mean => 1.0,
        VoteWeights::Robust if cost.is_finite() => (cost.max(0.0) / texels + ROBUST_EPS).powf(ROBUST_EXPONENT),
        VoteWeights::Robust => 1.0,
    };
    target.data_mut().par_chunks_mut(w * n).enumerate().for_each(|(y, row)| {
        let mut acc = vec![0f32; n];
        for x in 0..w {
            if only.is_some_and(|m| !m.get(x, y)) {
                continue;
            }
            acc.iter_mut().for_each(|a| *a = 0.0);
            let mut total = 0f32;
            for dy in -ri..=ri {
                let qy = y as isize + dy;
                if qy < 0 || qy >= h as isize {
                    continue;
                }
                for dx in -ri..=ri {
                    let qx = x as isize + dx;
                    if qx < 0 || qx >= w as isize {
                        continue;
                    }
                    let m = nnf.get(qx as usize, qy as usize);
                    // The pixel sits at offset (-dx, -dy) from the neighbour's centre.
                    let sx = (m.x as isize - dx) as usize;
                    let sy = (m.y as isize - dy) as usize;
                    let s = &sd[(sy * sw + sx) * n..(sy * sw + sx + 1) * n];
                    let wt = weight(m.cost);
                    acc.iter_mut().zip(s).for_each(|(a, v)| *a += wt * v);
                    total += wt;
                }
            }
            let inv = 1.0 / total;
            row[x * n..(x + 1) * n].iter_mut().zip(&acc).for_each(|(o, a)| *o = a * inv);
        }
    });
}
