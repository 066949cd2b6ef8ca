//! The order in which the memory replay takes the jobs' log segments: by the scheduler's
//! issue key (group, key, then job and segment, so every key is unique and there is one
//! order whatever the sort).

use rayon::prelude::*;

/// A log segment's issue key: (group, scheduler key, job, segment).
pub type IssueKey = (u8, [u64; 4], usize, usize);

/// The (job, segment) pairs of `keys` in key order.
///
/// Sorted as one `u128` each where the fields' ranges fit (every scheduler's do on real
/// frames: a few bits each): a key's fields side by side, each as wide as its largest
/// value, compare as the tuple does, and move 16 bytes a key instead of the tuple's 56. They
/// sort by radix (`radsort`: a linear pass per byte on which keys differ, 6 to 10 of them)
/// instead of a comparison sort's 15 to 17 levels (3x10^4 to 10^5 keys a frame at 1280x1440
/// per eye on the real scenes).
/// Otherwise the tuples themselves.
pub fn issue_order(mut keys: Vec<IssueKey>) -> Vec<(usize, usize)> {
    // A scheduler that issues jobs in turn (tile-pair's rows) lists its keys in order.
    if !keys.is_sorted() {
        match Packing::fit(&keys) {
            Some(packing) => {
                let mut packed: Vec<u128> = keys.par_iter().map(|key| packing.pack(key)).collect();
                radsort::sort(&mut packed);
                return packed.par_iter().map(|&p| packing.job_segment(p)).collect();
            }
            None => keys.par_sort_unstable(),
        }
    }
    keys.par_iter().map(|&(_, _, job, segment)| (job, segment)).collect()
}

/// The bit widths of a key's seven fields (group, the scheduler key's four, job, segment).
struct Packing {
    widths: [u32; 7],
}

impl Packing {
    /// The widths that hold every key's fields, if they sum to at most 128 bits.
    fn fit(keys: &[IssueKey]) -> Option<Packing> {
        let largest = keys
            .par_iter()
            .map(Self::fields)
            .reduce(|| [0; 7], |a, b| std::array::from_fn(|i| a[i].max(b[i])));
        let widths = largest.map(|v| u64::BITS - v.leading_zeros());
        (widths.iter().sum::<u32>() <= u128::BITS).then_some(Packing { widths })
    }

    fn fields(&(group, key, job, segment): &IssueKey) -> [u64; 7] {
        [
            u64::from(group),
            key[0],
            key[1],
            key[2],
            key[3],
            job as u64,
            segment as u64,
        ]
    }

    /// The fields side by side, the first in the highest bits.
    fn pack(&self, key: &IssueKey) -> u128 {
        Self::fields(key)
            .into_iter()
            .zip(self.widths)
            .fold(0u128, |packed, (field, width)| packed << width | u128::from(field))
    }

    /// The job and segment of a packed key: its two lowest fields.
    fn job_segment(&self, packed: u128) -> (usize, usize) {
        let [.., job_bits, segment_bits] = self.widths;
        let low = |p: u128, bits: u32| (p & ((1u128 << bits) - 1)) as usize;
        (low(packed >> segment_bits, job_bits), low(packed, segment_bits))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Keys with fields from a few bits to all 64 (those force the tuples' sort), unique as
    /// the memory pass's are (job and segment differ).
    fn keys() -> impl Strategy<Value = Vec<IssueKey>> {
        let field = prop_oneof![0u64..4, 0u64..70_000, any::<u64>()];
        let wide = prop::bool::weighted(0.1);
        prop::collection::vec((0u8..3, prop::array::uniform4(field), wide), 0..300).prop_map(|rows| {
            rows.into_iter()
                .enumerate()
                .map(|(i, (group, key, wide))| {
                    let key = match wide {
                        true => key,
                        false => key.map(|k| k % 70_000),
                    };
                    (group, key, i / 7, i % 7)
                })
                .collect()
        })
    }

    proptest! {
        /// The order is the tuples' order, packed or not, and keys listed in order keep it.
        #[test]
        fn the_order_is_the_keys_order(keys in keys()) {
            let mut sorted = keys.clone();
            sorted.sort_unstable();
            let expected: Vec<(usize, usize)> = sorted.iter().map(|&(_, _, j, s)| (j, s)).collect();
            prop_assert_eq!(issue_order(keys), expected.clone());
            prop_assert_eq!(issue_order(sorted), expected);
        }
    }

    #[test]
    fn narrow_keys_pack_and_wide_ones_do_not() {
        let narrow = vec![(1, [0, 1, 40_000, 3], 2, 9), (0, [1, 0, 5, 2000], 17, 0)];
        assert_eq!(Packing::fit(&narrow).map(|p| p.widths), Some([1, 1, 1, 16, 11, 5, 4]));
        let wide = vec![(0, [u64::MAX, u64::MAX, 1, 1], 1, 1)];
        assert!(Packing::fit(&wide).is_none());
        assert_eq!(issue_order(Vec::new()), Vec::new());
    }
}
