//! Seed derivation: the one way every seed in bycoms is derived from another.
//!
//! Why one function: the sweep derives terrain and run seeds from its seed,
//! and every robot derives its noise stream from the run seed and its id.
//! With one mixing function, a seed printed anywhere (a sweep row, a launch
//! summary) reproduces the same streams everywhere, and there is one place
//! to read how.

/// SplitMix64 mixing of two values: unrelated outputs for neighbouring
/// inputs (`mix(s, 1)` and `mix(s, 2)` share no structure).
pub fn mix(a: u64, b: u64) -> u64 {
    let mut z = a ^ b.wrapping_mul(0x9E37_79B9_7F4A_7C15).wrapping_add(0x632B_E59B_D9B4_E019);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

#[cfg(test)]
mod tests {
    use super::mix;

    #[test]
    fn pinned_values_and_no_neighbour_structure() {
        // Pinned: sweep terrains and noise streams depend on these bits.
        assert_eq!(mix(0, 0), 0x6DB6_CA64_564D_AEAA);
        assert_ne!(mix(7, 1), mix(7, 2));
        assert_ne!(mix(7, 1), mix(1, 7));
        let flipped = (mix(7, 1) ^ mix(7, 2)).count_ones();
        assert!((16..=48).contains(&flipped), "{flipped} bits differ");
    }
}
