//! SplitMix64 (Steele, Lea and Flood 2014, with Vigna's finaliser): the crate's one
//! pseudo-random generator, for fixed numbers per key and reproducible streams.

/// The generator's step: 2⁶⁴ / φ, rounded to odd.
const GOLDEN: u64 = 0x9E37_79B9_7F4A_7C15;

/// SplitMix64's output from state `x`: the state advanced by one step, then finalised (a
/// fixed pseudo-random number per key).
pub fn splitmix64(x: u64) -> u64 {
    let mut z = x.wrapping_add(GOLDEN);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The SplitMix64 stream from state `seed`: output i is [`splitmix64`] of seed + i steps.
pub fn splitmix64_stream(seed: u64) -> impl Iterator<Item = u64> {
    std::iter::successors(Some(seed), |&s| Some(s.wrapping_add(GOLDEN))).map(splitmix64)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Vigna's reference splitmix64.c from seed 1234567: its first outputs.
    #[test]
    fn stream_is_the_reference() {
        let got: Vec<u64> = splitmix64_stream(1234567).take(3).collect();
        assert_eq!(
            got,
            [
                6457827717110365317,
                3203168211198807973,
                9817491932198370423
            ]
        );
    }
}
