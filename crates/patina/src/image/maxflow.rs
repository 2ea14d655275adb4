//! Minimum s-t cut on an 8-connected pixel grid: the Boykov-Kolmogorov
//! max-flow algorithm ("An Experimental Comparison of Min-Cut/Max-Flow
//! Algorithms for Energy Minimization in Vision", PAMI 2004), with its two
//! search trees grown from the terminals, re-used after every augmentation,
//! and the distance/timestamp heuristic for adopting orphans.
//!
//! It minimises a binary labelling energy
//! E(L) = sum_p D_p(L_p) + sum_{p,q} V_pq [L_p != L_q]
//! where a pixel on the source side is labelled `true`. Capacities are
//! integers (the caller's energies times [`GridCut::SCALE`]), so the cut is
//! exact and the result depends on nothing but the inputs: no thread count,
//! no float rounding order.
//!
//! No crate on crates.io provides a maintained grid max-flow, so it is
//! written here; it is single-threaded and allocation-free in its loop.

use std::collections::VecDeque;

/// The eight neighbour offsets; direction `d` and `(d + 4) % 8` are opposite.
const STEPS: [(isize, isize); 8] = [(1, 0), (1, 1), (0, 1), (-1, 1), (-1, 0), (-1, -1), (0, -1), (1, -1)];
const FREE: u8 = 0;
const SOURCE: u8 = 1;
const SINK: u8 = 2;
/// `parent` values beyond the eight directions.
const TERMINAL: u8 = 8;
const ORPHAN: u8 = 9;
const NONE: u8 = 10;

fn opposite(d: u8) -> u8 {
    (d + 4) % 8
}

/// A grid graph: terminal links per pixel and a capacity per pixel and
/// direction to each of its eight neighbours.
pub struct GridCut {
    width: usize,
    height: usize,
    /// Residual terminal capacity: > 0 from the source, < 0 to the sink.
    terminal: Vec<i64>,
    /// Residual capacity of the edge from pixel `i` in direction `d`, at `i * 8 + d`.
    cap: Vec<i32>,
}

impl GridCut {
    /// Energies are multiplied by this before rounding to integer capacities.
    pub const SCALE: f32 = 64.0;

    /// A grid with no links.
    pub fn new(width: usize, height: usize) -> Self {
        GridCut { width, height, terminal: vec![0; width * height], cap: vec![0; width * height * 8] }
    }

    /// The costs of labelling pixel `i` source (`to_source`) and sink
    /// (`to_sink`): D_p(true) and D_p(false). Only their difference matters
    /// to the cut.
    pub fn set_costs(&mut self, i: usize, to_source: f32, to_sink: f32) {
        // Cutting the source link labels the pixel sink, so it costs D(false).
        self.terminal[i] = capacity(to_sink) as i64 - capacity(to_source) as i64;
    }

    /// Pixel `i` is held on the source (`true`) or sink side whatever its
    /// neighbours.
    pub fn fix(&mut self, i: usize, source: bool) {
        self.terminal[i] = if source { i64::MAX / 4 } else { -(i64::MAX / 4) };
    }

    /// The cost V of separating pixel `i` from its neighbour in direction
    /// `d` (both ways). Directions 0-3 cover every pair once.
    pub fn set_pair(&mut self, i: usize, d: usize, cost: f32) {
        let Some(j) = self.neighbour(i, d as u8) else { return };
        let c = capacity(cost);
        self.cap[i * 8 + d] = c;
        self.cap[j * 8 + opposite(d as u8) as usize] = c;
    }

    /// The neighbour of pixel `i` in direction `d`, if inside the grid.
    pub fn neighbour(&self, i: usize, d: u8) -> Option<usize> {
        neighbour(self.width, self.height, i, d)
    }

    /// Solve; `true` where a pixel ends on the source side of a minimum cut.
    /// Pixels reachable from neither terminal (a tie) go to the sink.
    pub fn solve(self) -> Vec<bool> {
        let mut flow = Flow::new(self);
        flow.run();
        flow.tree.iter().map(|&t| t == SOURCE).collect()
    }
}

/// The neighbour of pixel `i` of a `width` x `height` grid in direction
/// `d` (0-7, see [`GridCut::set_pair`]), if inside the grid.
pub fn neighbour(width: usize, height: usize, i: usize, d: u8) -> Option<usize> {
    let (dx, dy) = STEPS[d as usize];
    let (x, y) = ((i % width) as isize + dx, (i / width) as isize + dy);
    (x >= 0 && y >= 0 && (x as usize) < width && (y as usize) < height).then(|| y as usize * width + x as usize)
}

fn capacity(cost: f32) -> i32 {
    (cost.max(0.0) * GridCut::SCALE).round().min(i32::MAX as f32 / 16.0) as i32
}

/// The solver's state (the paper's S and T trees, active queue, orphans).
struct Flow {
    g: GridCut,
    tree: Vec<u8>,
    /// Direction from the pixel to its parent, or TERMINAL/ORPHAN/NONE.
    parent: Vec<u8>,
    dist: Vec<u32>,
    stamp: Vec<u32>,
    queued: Vec<bool>,
    active: VecDeque<u32>,
    orphans: VecDeque<u32>,
    time: u32,
}

impl Flow {
    fn new(g: GridCut) -> Self {
        let n = g.width * g.height;
        let mut f = Flow {
            tree: vec![FREE; n],
            parent: vec![NONE; n],
            dist: vec![0; n],
            stamp: vec![0; n],
            queued: vec![false; n],
            active: VecDeque::new(),
            orphans: VecDeque::new(),
            time: 1,
            g,
        };
        for i in 0..n {
            let t = f.g.terminal[i];
            if t != 0 {
                f.tree[i] = if t > 0 { SOURCE } else { SINK };
                f.parent[i] = TERMINAL;
                f.dist[i] = 1;
                f.stamp[i] = 1;
                f.activate(i);
            }
        }
        f
    }

    fn activate(&mut self, i: usize) {
        if !self.queued[i] {
            self.queued[i] = true;
            self.active.push_back(i as u32);
        }
    }

    /// Residual capacity along the tree's flow direction between a node `i`
    /// and its neighbour `j` in direction `d`: from `j` into `i` in the
    /// source tree, from `i` into `j` in the sink tree.
    fn open(&self, tree: u8, i: usize, j: usize, d: u8) -> bool {
        if tree == SOURCE {
            self.g.cap[j * 8 + opposite(d) as usize] > 0
        } else {
            self.g.cap[i * 8 + d as usize] > 0
        }
    }

    fn run(&mut self) {
        while let Some(i) = self.active.pop_front() {
            let i = i as usize;
            self.queued[i] = false;
            // Grow from `i` until it has no free or opposite neighbour left.
            'grow: loop {
                let tree = self.tree[i];
                if tree == FREE {
                    break;
                }
                for d in 0..8u8 {
                    let Some(j) = self.g.neighbour(i, d) else { continue };
                    // Flow leaves a source-tree node and enters a sink-tree node.
                    let forward = if tree == SOURCE { self.g.cap[i * 8 + d as usize] } else { self.g.cap[j * 8 + opposite(d) as usize] };
                    if forward <= 0 {
                        continue;
                    }
                    match self.tree[j] {
                        FREE => {
                            self.tree[j] = tree;
                            self.parent[j] = opposite(d);
                            self.dist[j] = self.dist[i] + 1;
                            self.stamp[j] = self.stamp[i];
                            self.activate(j);
                        }
                        t if t == tree => {
                            // Shorter path heuristic (the paper's marking).
                            if self.stamp[j] <= self.stamp[i] && self.dist[j] > self.dist[i] {
                                self.parent[j] = opposite(d);
                                self.stamp[j] = self.stamp[i];
                                self.dist[j] = self.dist[i] + 1;
                            }
                        }
                        _ => {
                            let (s, t, dd) = if tree == SOURCE { (i, j, d) } else { (j, i, opposite(d)) };
                            self.augment(s, t, dd);
                            self.time += 1;
                            self.adopt();
                            continue 'grow;
                        }
                    }
                }
                break;
            }
        }
    }

    /// Push the bottleneck along source -> s -> t -> sink (s's edge in
    /// direction `d` reaches t) and collect the nodes cut off as orphans.
    fn augment(&mut self, s: usize, t: usize, d: u8) {
        let mut bottleneck = self.g.cap[s * 8 + d as usize] as i64;
        let mut x = s;
        while self.parent[x] != TERMINAL {
            let pd = self.parent[x];
            let p = self.g.neighbour(x, pd).expect("a parent inside the grid");
            bottleneck = bottleneck.min(self.g.cap[p * 8 + opposite(pd) as usize] as i64);
            x = p;
        }
        bottleneck = bottleneck.min(self.g.terminal[x]);
        let mut x = t;
        while self.parent[x] != TERMINAL {
            let pd = self.parent[x];
            bottleneck = bottleneck.min(self.g.cap[x * 8 + pd as usize] as i64);
            x = self.g.neighbour(x, pd).expect("a parent inside the grid");
        }
        bottleneck = bottleneck.min(-self.g.terminal[x]);
        let b = bottleneck as i32;
        self.g.cap[s * 8 + d as usize] -= b;
        self.g.cap[t * 8 + opposite(d) as usize] += b;
        let mut x = s;
        while self.parent[x] != TERMINAL {
            let pd = self.parent[x];
            let p = self.g.neighbour(x, pd).expect("a parent inside the grid");
            self.g.cap[p * 8 + opposite(pd) as usize] -= b;
            self.g.cap[x * 8 + pd as usize] += b;
            if self.g.cap[p * 8 + opposite(pd) as usize] == 0 {
                self.orphan(x);
            }
            x = p;
        }
        self.g.terminal[x] -= bottleneck;
        if self.g.terminal[x] == 0 {
            self.orphan(x);
        }
        let mut x = t;
        while self.parent[x] != TERMINAL {
            let pd = self.parent[x];
            let p = self.g.neighbour(x, pd).expect("a parent inside the grid");
            self.g.cap[x * 8 + pd as usize] -= b;
            self.g.cap[p * 8 + opposite(pd) as usize] += b;
            if self.g.cap[x * 8 + pd as usize] == 0 {
                self.orphan(x);
            }
            x = p;
        }
        self.g.terminal[x] += bottleneck;
        if self.g.terminal[x] == 0 {
            self.orphan(x);
        }
    }

    fn orphan(&mut self, x: usize) {
        self.parent[x] = ORPHAN;
        self.orphans.push_back(x as u32);
    }

    /// Give each orphan a new parent in its tree whose path reaches the
    /// terminal, or free it (the paper's adoption stage).
    fn adopt(&mut self) {
        while let Some(o) = self.orphans.pop_front() {
            let o = o as usize;
            let tree = self.tree[o];
            let mut best: Option<(u8, u32)> = None;
            for d in 0..8u8 {
                let Some(j) = self.g.neighbour(o, d) else { continue };
                if self.tree[j] != tree || !self.open(tree, o, j, d) {
                    continue;
                }
                if let Some(depth) = self.origin(j) {
                    if best.is_none_or(|(_, b)| depth < b) {
                        best = Some((d, depth));
                    }
                }
            }
            if let Some((d, depth)) = best {
                self.parent[o] = d;
                self.stamp[o] = self.time;
                self.dist[o] = depth + 1;
                continue;
            }
            // No valid parent: `o` leaves its tree; neighbours that could
            // regrow into it become active, its children become orphans.
            for d in 0..8u8 {
                let Some(j) = self.g.neighbour(o, d) else { continue };
                if self.tree[j] != tree {
                    continue;
                }
                if self.open(tree, o, j, d) {
                    self.activate(j);
                }
                let pj = self.parent[j];
                if pj < TERMINAL && self.g.neighbour(j, pj) == Some(o) {
                    self.orphan(j);
                }
            }
            self.tree[o] = FREE;
            self.parent[o] = NONE;
        }
    }

    /// The distance from `j` to its terminal if its parent chain reaches
    /// one without meeting an orphan; stamps the chain on success.
    fn origin(&mut self, j: usize) -> Option<u32> {
        let mut depth = 0u32;
        let mut x = j;
        loop {
            if self.stamp[x] == self.time {
                depth += self.dist[x];
                break;
            }
            match self.parent[x] {
                TERMINAL => {
                    depth += 1;
                    self.stamp[x] = self.time;
                    self.dist[x] = 1;
                    break;
                }
                ORPHAN | NONE => return None,
                pd => {
                    depth += 1;
                    x = self.g.neighbour(x, pd).expect("a parent inside the grid");
                }
            }
        }
        // Stamp the chain with its distances.
        let mut x = j;
        let mut dist = depth;
        while self.stamp[x] != self.time {
            self.stamp[x] = self.time;
            self.dist[x] = dist;
            dist -= 1;
            x = self.g.neighbour(x, self.parent[x]).expect("a parent inside the grid");
        }
        Some(depth)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Brute force over all labellings of a tiny grid.
    fn brute(w: usize, h: usize, unary: &[(f32, f32)], pair: &dyn Fn(usize, usize) -> f32) -> f32 {
        let n = w * h;
        let g = GridCut::new(w, h);
        (0..1u32 << n)
            .map(|bits| {
                let l = |i: usize| bits >> i & 1 == 1;
                let mut e: f32 = (0..n).map(|i| if l(i) { unary[i].0 } else { unary[i].1 }).sum();
                for i in 0..n {
                    for d in 0..4u8 {
                        if let Some(j) = g.neighbour(i, d) {
                            if l(i) != l(j) {
                                e += pair(i, d as usize);
                            }
                        }
                    }
                }
                e
            })
            .fold(f32::INFINITY, f32::min)
    }

    fn energy(w: usize, labels: &[bool], unary: &[(f32, f32)], pair: &dyn Fn(usize, usize) -> f32, h: usize) -> f32 {
        let g = GridCut::new(w, h);
        let mut e: f32 = labels.iter().zip(unary).map(|(&l, u)| if l { u.0 } else { u.1 }).sum();
        for i in 0..w * h {
            for d in 0..4u8 {
                if let Some(j) = g.neighbour(i, d) {
                    if labels[i] != labels[j] {
                        e += pair(i, d as usize);
                    }
                }
            }
        }
        e
    }

    #[test]
    fn the_cut_is_a_minimum_on_random_small_grids() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_pcg::Pcg32::seed_from_u64(7);
        for _ in 0..40 {
            let (w, h) = (rng.gen_range(2..5), rng.gen_range(2..4));
            let unary: Vec<(f32, f32)> =
                (0..w * h).map(|_| (rng.gen_range(0..20) as f32 / 4.0, rng.gen_range(0..20) as f32 / 4.0)).collect();
            let pairs: Vec<f32> = (0..w * h * 4).map(|_| rng.gen_range(0..12) as f32 / 4.0).collect();
            let pair = |i: usize, d: usize| pairs[i * 4 + d];
            let mut g = GridCut::new(w, h);
            for i in 0..w * h {
                g.set_costs(i, unary[i].0, unary[i].1);
                for d in 0..4 {
                    g.set_pair(i, d, pair(i, d));
                }
            }
            let labels = g.solve();
            let got = energy(w, &labels, &unary, &pair, h);
            let best = brute(w, h, &unary, &pair);
            assert!((got - best).abs() < 1e-3, "cut energy {got} but the minimum is {best}");
        }
    }

    #[test]
    fn a_noisy_disc_is_recovered_by_smoothing() {
        let (w, h) = (64, 48);
        let inside = |x: usize, y: usize| (x as f32 - 30.0).powi(2) + (y as f32 - 22.0).powi(2) < 15.0f32.powi(2);
        let mut g = GridCut::new(w, h);
        for i in 0..w * h {
            let (x, y) = (i % w, i / w);
            // One pixel in five votes the wrong way.
            let flip = (x * 7 + y * 13) % 5 == 0;
            let fg = inside(x, y) != flip;
            g.set_costs(i, if fg { 0.0 } else { 1.0 }, if fg { 1.0 } else { 0.0 });
            for d in 0..4 {
                g.set_pair(i, d, if d % 2 == 1 { 0.7 } else { 1.0 });
            }
        }
        let labels = g.solve();
        let wrong = (0..w * h).filter(|&i| labels[i] != inside(i % w, i / w)).count();
        assert!(wrong < 40, "{wrong} pixels wrong");
    }
}
