//! Connected regions of a binary mask: components, the subject among them,
//! hole filling, majority smoothing. Used to clean up automatic object
//! masks ([`super::grabcut::cut_out`], `stone::select`).

/// The in-image 4-neighbours of (x, y) in a `w` x `h` image.
pub fn neighbours(x: usize, y: usize, w: usize, h: usize) -> impl Iterator<Item = (usize, usize)> {
    [(x.wrapping_sub(1), y), (x + 1, y), (x, y.wrapping_sub(1)), (x, y + 1)].into_iter().filter(move |&(a, b)| a < w && b < h)
}

/// 4-connected components of set pixels, as a label per pixel (u32::MAX
/// unset) and their count.
pub fn components(bits: &[bool], w: usize, h: usize) -> (Vec<u32>, usize) {
    let mut label = vec![u32::MAX; w * h];
    let mut count = 0;
    let mut stack = Vec::new();
    for start in 0..w * h {
        if !bits[start] || label[start] != u32::MAX {
            continue;
        }
        label[start] = count as u32;
        stack.push(start);
        while let Some(i) = stack.pop() {
            for (nx, ny) in neighbours(i % w, i / w, w, h) {
                let j = ny * w + nx;
                if bits[j] && label[j] == u32::MAX {
                    label[j] = count as u32;
                    stack.push(j);
                }
            }
        }
        count += 1;
    }
    (label, count)
}

/// The subject among the set components. With a `focus` point (in this
/// grid's pixels) it is the component under the point, or the nearest one
/// to it. Without, it is the component with the most pixels, each weighted
/// by how central it is (a Gaussian of a third of the picture around its
/// centre). All unset if nothing is set.
pub fn subject(bits: &[bool], w: usize, h: usize, focus: Option<(usize, usize)>) -> Vec<bool> {
    let (label, count) = components(bits, w, h);
    let mut score = vec![0f64; count];
    for (i, &l) in label.iter().enumerate() {
        if l == u32::MAX {
            continue;
        }
        let (x, y) = (i % w, i / w);
        score[l as usize] += match focus {
            // Nearer is better; the tie-break by size is negligible.
            Some((fx, fy)) => 1.0 / (1.0 + (x as f64 - fx as f64).powi(2) + (y as f64 - fy as f64).powi(2)).powi(2),
            None => centrality(x, y, w, h),
        };
    }
    let best = match focus {
        Some((fx, fy)) if label[fy.min(h - 1) * w + fx.min(w - 1)] != u32::MAX => Some(label[fy.min(h - 1) * w + fx.min(w - 1)] as usize),
        _ => (0..count).max_by(|&a, &b| score[a].total_cmp(&score[b])),
    };
    match best {
        Some(best) => label.iter().map(|&l| l == best as u32).collect(),
        None => vec![false; w * h],
    }
}

/// A Gaussian weight of a third of the picture around its centre.
pub fn centrality(x: usize, y: usize, w: usize, h: usize) -> f64 {
    let (dx, dy) = (x as f64 / w as f64 - 0.5, y as f64 / h as f64 - 0.5);
    (-(dx * dx + dy * dy) / (2.0 * 0.33f64.powi(2))).exp()
}

/// Set every unset region that does not touch the image border.
pub fn fill_holes(bits: &[bool], w: usize, h: usize) -> Vec<bool> {
    let background: Vec<bool> = bits.iter().map(|b| !b).collect();
    let (label, count) = components(&background, w, h);
    let mut open = vec![false; count];
    for (i, &l) in label.iter().enumerate() {
        let (x, y) = (i % w, i / w);
        if l != u32::MAX && (x == 0 || y == 0 || x + 1 == w || y + 1 == h) {
            open[l as usize] = true;
        }
    }
    label.iter().zip(bits).map(|(&l, &b)| b || (l != u32::MAX && !open[l as usize])).collect()
}

/// Each pixel takes the majority of its 3 x 3 neighbourhood (ties keep it).
pub fn majority(bits: &[bool], w: usize, h: usize) -> Vec<bool> {
    let mut out = bits.to_vec();
    for y in 0..h {
        for x in 0..w {
            let (mut on, mut n) = (0, 0);
            for yy in y.saturating_sub(1)..(y + 2).min(h) {
                for xx in x.saturating_sub(1)..(x + 2).min(w) {
                    on += bits[yy * w + xx] as usize;
                    n += 1;
                }
            }
            if 2 * on != n {
                out[y * w + x] = 2 * on > n;
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_subject_is_the_central_or_the_focused_component_with_its_holes_filled() {
        let (w, h) = (40, 30);
        // A ring in the middle and a larger block in a corner.
        let bits: Vec<bool> = (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f32, (i / w) as f32);
                let r = ((x - 20.0).powi(2) + (y - 15.0).powi(2)).sqrt();
                (3.0..7.0).contains(&r) || (x < 12.0 && y < 10.0)
            })
            .collect();
        let central = fill_holes(&subject(&bits, w, h, None), w, h);
        assert!(central[15 * w + 20], "the ring's hole is filled");
        assert!(!central[2 * w + 2], "the corner block is not the subject");
        let focused = subject(&bits, w, h, Some((3, 3)));
        assert!(focused[2 * w + 2] && !focused[15 * w + 25]);
    }
}
