//! Seeded randomness. Every unit of work (a band of rows, a block, an
//! iteration) gets its own generator derived from the run's seed and the
//! unit's indices, never from thread identity, so results do not depend on
//! how rayon schedules the work.

pub use rand::Rng;
use rand::SeedableRng;

/// The generator used throughout patina (PCG-XSH-RR 64/32: fast, small
/// state, good statistical quality).
pub type Generator = rand_pcg::Pcg32;

/// A uniform integer in [-r, r] by one 32-bit draw and a multiply-shift
/// (Lemire's method without rejection; the bias, under 2^-20 for r < 2^11,
/// is irrelevant for search offsets). Much cheaper than `gen_range`.
#[inline]
pub fn offset(g: &mut Generator, r: i64) -> i64 {
    let span = (2 * r + 1) as u64;
    ((rand::RngCore::next_u32(g) as u64 * span) >> 32) as i64 - r
}

/// SplitMix64 finaliser: a bijective mix of 64 bits.
fn mix(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// A seed derived from `seed` and a path of unit indices.
pub fn derive(seed: u64, unit: &[u64]) -> u64 {
    unit.iter().fold(mix(seed ^ 0x9e37_79b9_7f4a_7c15), |h, &u| mix(h ^ mix(u.wrapping_add(0x632b_e59b_d9b4_e019))))
}

/// A generator for one unit of work.
pub fn generator(seed: u64, unit: &[u64]) -> Generator {
    Generator::seed_from_u64(derive(seed, unit))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn units_get_different_streams_and_same_unit_same_stream() {
        let a: u64 = generator(7, &[1, 2]).gen();
        let b: u64 = generator(7, &[1, 3]).gen();
        let c: u64 = generator(7, &[1, 2]).gen();
        let d: u64 = generator(8, &[1, 2]).gen();
        assert_ne!(a, b);
        assert_ne!(a, d);
        assert_eq!(a, c);
    }

    #[test]
    fn offsets_cover_the_range_evenly() {
        let mut g = generator(1, &[]);
        let mut counts = [0usize; 7];
        for _ in 0..70_000 {
            counts[(offset(&mut g, 3) + 3) as usize] += 1;
        }
        assert!(counts.iter().all(|&c| (9_000..11_000).contains(&c)), "{counts:?}");
    }
}
