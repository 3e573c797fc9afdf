//! Random numbers for rendering: a PCG32 stream per (seed, pixel, sample).
//!
//! Each pixel sample gets its own stream derived by hashing the render seed, the pixel
//! index and the sample index, so an image does not depend on how work is split across
//! threads, and `--seed-offset` style splitting only needs disjoint sample indices.

/// PCG32 (O'Neill 2014): 64-bit state, 32-bit output, selectable stream.
#[derive(Clone, Copy, Debug)]
pub struct Pcg32 {
    state: u64,
    inc: u64,
}

const MULT: u64 = 6364136223846793005;

/// SplitMix64 finaliser: a fast, well-mixed 64-bit hash.
#[inline]
pub fn mix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E3779B97F4A7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58476D1CE4E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D049BB133111EB);
    z ^ (z >> 31)
}

impl Pcg32 {
    /// A generator on stream `stream` started from `seed`.
    pub fn new(seed: u64, stream: u64) -> Pcg32 {
        let mut r = Pcg32 {
            state: 0,
            inc: (stream << 1) | 1,
        };
        r.next_u32();
        r.state = r.state.wrapping_add(seed);
        r.next_u32();
        r
    }

    /// The stream of one pixel sample: independent for every (seed, pixel, sample).
    pub fn for_sample(seed: u64, pixel: u64, sample: u64) -> Pcg32 {
        let a = mix64(seed ^ mix64(pixel.wrapping_mul(0x2545F4914F6CDD1D)));
        let b = mix64(sample ^ a.rotate_left(17));
        Pcg32::new(a ^ b, mix64(b))
    }

    /// The next 32 random bits.
    #[inline]
    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old.wrapping_mul(MULT).wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let rot = (old >> 59) as u32;
        xorshifted.rotate_right(rot)
    }

    /// A uniform float in [0, 1).
    #[inline]
    pub fn next_f32(&mut self) -> f32 {
        // 24 random bits: every value is exactly representable and < 1.
        (self.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0)
    }

    /// Two uniform floats in [0, 1).
    #[inline]
    pub fn next_2d(&mut self) -> [f32; 2] {
        [self.next_f32(), self.next_f32()]
    }
}

/// A second stream of one pixel sample, created on first use (only fluorescent vertices
/// draw from it, so scenes without fluorescence never pay for it).
#[derive(Clone, Copy, Debug)]
pub struct LazyStream {
    key: (u64, u64, u64),
    rng: Option<Pcg32>,
}

impl LazyStream {
    /// The stream of (seed, pixel, sample), salted apart from the main stream.
    pub fn new(seed: u64, pixel: u64, sample: u64) -> LazyStream {
        LazyStream {
            key: (seed ^ 0x5348_4946_5453_5452, pixel, sample),
            rng: None,
        }
    }

    /// The generator, created at the first call.
    #[inline]
    pub fn get(&mut self) -> &mut Pcg32 {
        let (a, b, c) = self.key;
        self.rng.get_or_insert_with(|| Pcg32::for_sample(a, b, c))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uniform_in_unit_interval_chi_square() {
        let mut r = Pcg32::for_sample(7, 3, 1);
        let bins = 64;
        let n = 200_000;
        let mut counts = vec![0u32; bins];
        for _ in 0..n {
            let x = r.next_f32();
            assert!((0.0..1.0).contains(&x));
            counts[(x * bins as f32) as usize] += 1;
        }
        let e = n as f64 / bins as f64;
        let chi2: f64 = counts.iter().map(|&c| (c as f64 - e).powi(2) / e).sum();
        // 63 degrees of freedom: the 0.999 quantile is about 103.4.
        assert!(chi2 < 103.4, "chi2 = {chi2}");
    }

    #[test]
    fn streams_differ_per_pixel_and_sample() {
        let a = Pcg32::for_sample(1, 0, 0).next_u32();
        let b = Pcg32::for_sample(1, 1, 0).next_u32();
        let c = Pcg32::for_sample(1, 0, 1).next_u32();
        let d = Pcg32::for_sample(2, 0, 0).next_u32();
        assert!(a != b && a != c && a != d && b != c);
        assert_eq!(a, Pcg32::for_sample(1, 0, 0).next_u32());
    }
}
