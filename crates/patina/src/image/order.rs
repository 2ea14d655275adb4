//! Order statistics of samples: the medians and quantiles the methods take
//! of ages, distances, times and coefficients, in one place. Each reorders
//! its slice by selection (O(n), no allocation) and is `None` when it is
//! empty.

/// The upper median: the value at index len / 2 in sorted order.
pub fn median(values: &mut [f32]) -> Option<f32> {
    let mid = values.len() / 2;
    if values.is_empty() {
        return None;
    }
    Some(*values.select_nth_unstable_by(mid, f32::total_cmp).1)
}

/// The `q` quantile: the value at index floor((len - 1) q) in sorted order.
pub fn quantile(values: &mut [f32], q: f32) -> Option<f32> {
    let k = ((values.len().checked_sub(1)?) as f32 * q) as usize;
    Some(*values.select_nth_unstable_by(k, f32::total_cmp).1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn medians_and_quantiles_pick_by_sorted_index() {
        let mut v = [5.0, 1.0, 4.0, 2.0, 3.0, 6.0];
        assert_eq!(median(&mut v), Some(4.0), "the upper of the two middle values");
        assert_eq!(quantile(&mut v, 0.0), Some(1.0));
        assert_eq!(quantile(&mut v, 0.5), Some(3.0), "index floor(5 x 0.5) = 2");
        assert_eq!(quantile(&mut v, 1.0), Some(6.0));
        assert_eq!(median(&mut []), None);
        assert_eq!(quantile(&mut [], 0.5), None);
    }
}
