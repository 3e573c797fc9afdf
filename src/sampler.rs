//! Random numbers for rendering: streams per (seed, pixel, sample).
//!
//! Each pixel sample gets its own streams derived by hashing the render seed, the pixel
//! index and the sample index, so an image does not depend on how work is split across
//! threads, and `--seed-offset` style splitting only needs disjoint sample indices.
//!
//! A path's decisions come from [`Streams`], xoshiro128+ kept word by word across the W
//! paths of a packet, so that one draw advances every path's generator in a handful of
//! SIMD instructions. [`Pcg32`] draws what is drawn lane by lane anyway (the wavelength
//! shifts at fluorescent events, [`LazyStream`]) and serves tests.

#[cfg(test)]
use crate::simd::Mask as _;
use crate::simd::{Float, Words};

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

/// The decision streams of W paths: xoshiro128+ (Blackman and Vigna 2018, 128 bits of
/// state in four 32-bit words), stored as four vectors of words, one word of every path
/// in each. A draw steps every path's state; the paths in its mask keep the new one. A
/// path's numbers are therefore the same at every width, and no lane waits on another.
///
/// xoshiro128+'s weak bits are its lowest; a draw keeps the top 24.
#[derive(Clone, Copy, Debug)]
pub struct Streams<F: Float> {
    s: [F::Words; 4],
}

impl Streams<f32> {
    /// One path's stream started from (`key`, `stream`).
    pub fn new(key: u64, stream: u64) -> Streams<f32> {
        let a = mix64(key ^ mix64(stream));
        Streams::from_bits(a, mix64(a))
    }

    /// The decision stream of one pixel sample: independent for every (seed, pixel,
    /// sample).
    pub fn for_sample(seed: u64, pixel: u64, sample: u64) -> Streams<f32> {
        let a = mix64(seed ^ mix64(pixel.wrapping_mul(0x2545F4914F6CDD1D)));
        let b = mix64(sample ^ a.rotate_left(17));
        Streams::from_bits(a ^ b, mix64(b))
    }

    /// The state (x, y), two well-mixed words, made non-zero if it is not (the one state
    /// xoshiro never leaves).
    fn from_bits(x: u64, y: u64) -> Streams<f32> {
        let words = [x as u32, (x >> 32) as u32, y as u32, (y >> 32) as u32];
        Streams {
            s: if words == [0; 4] { [1, 0, 0, 0] } else { words },
        }
    }

    /// The next 32 random bits.
    #[inline]
    pub fn next_u32(&mut self) -> u32 {
        self.next_words(true)
    }

    /// A uniform float in [0, 1).
    #[inline]
    pub fn next_f32(&mut self) -> f32 {
        self.draw(true)
    }

    /// Two uniform floats in [0, 1).
    #[inline]
    pub fn next_2d(&mut self) -> [f32; 2] {
        [self.next_f32(), self.next_f32()]
    }
}

impl<F: Float> Streams<F> {
    /// Lanes not yet given a stream (all-zero words: they draw only zeros).
    #[inline(always)]
    pub fn idle() -> Streams<F> {
        Streams {
            s: [F::Words::splat(0); 4],
        }
    }

    /// Path `i`'s stream.
    #[inline(always)]
    pub fn lane(&self, i: usize) -> Streams<f32> {
        Streams {
            s: self.s.map(|w| w.get(i)),
        }
    }

    /// Puts `one` in lane `i`.
    #[inline(always)]
    pub fn set_lane(&mut self, i: usize, one: Streams<f32>) {
        for (w, x) in self.s.iter_mut().zip(one.s) {
            w.set(i, x);
        }
    }

    /// The next 32 bits of the paths in `m` (the other lanes' output is not theirs to
    /// use, and their state stays).
    #[inline(always)]
    pub fn next_words(&mut self, m: F::Mask) -> F::Words {
        let (next, out) = step(self.s);
        self.keep(m, next);
        out
    }

    /// Uniforms in [0, 1) for the paths in `m`, 0 elsewhere.
    #[inline(always)]
    pub fn draw(&mut self, m: F::Mask) -> F {
        F::unit(self.next_words(m)).masked(m)
    }

    /// `N` uniforms for the paths in `m`: what `N` calls of [`Streams::draw`] give, with
    /// the mask applied to the state once.
    #[inline(always)]
    pub fn draws<const N: usize>(&mut self, m: F::Mask) -> [F; N] {
        let mut s = self.s;
        let u = std::array::from_fn(|_| {
            let (next, out) = step(s);
            s = next;
            F::unit(out).masked(m)
        });
        self.keep(m, s);
        u
    }

    /// The paths in `m` take the state `next`.
    #[inline(always)]
    fn keep(&mut self, m: F::Mask, next: [F::Words; 4]) {
        for (w, n) in self.s.iter_mut().zip(next) {
            *w = F::select_words(m, n, *w);
        }
    }
}

/// One xoshiro128+ step of every lane: the next state and the output.
#[inline(always)]
fn step<W: Words>([s0, s1, s2, s3]: [W; 4]) -> ([W; 4], W) {
    let out = s0.add_wrapping(s3);
    let t = s1.shl_by(9);
    let n2 = s2 ^ s0;
    let n3 = s3 ^ s1;
    let n1 = s1 ^ n2;
    let n0 = s0 ^ n3;
    let n2 = n2 ^ t;
    let n3 = n3.shl_by(11) | n3.shr_by(21);
    ([n0, n1, n2, n3], out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 64 equally likely cells' counts pass the chi-square test at the 0.999 level.
    fn assert_uniform_64(counts: &[u32]) {
        assert_eq!(counts.len(), 64);
        let e = counts.iter().sum::<u32>() as f64 / 64.0;
        let chi2: f64 = counts.iter().map(|&c| (c as f64 - e).powi(2) / e).sum();
        // 63 degrees of freedom: the 0.999 quantile is about 103.4.
        assert!(chi2 < 103.4, "chi2 = {chi2}");
    }

    /// 200,000 draws of `next` in [0, 1), uniform over 64 bins.
    fn assert_uniform_draws(mut next: impl FnMut() -> f32) {
        let mut counts = [0u32; 64];
        for _ in 0..200_000 {
            let x = next();
            assert!((0.0..1.0).contains(&x));
            counts[(x * 64.0) as usize] += 1;
        }
        assert_uniform_64(&counts);
    }

    #[test]
    fn uniform_in_unit_interval_chi_square() {
        let mut r = Pcg32::for_sample(7, 3, 1);
        assert_uniform_draws(|| r.next_f32());
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

    /// xoshiro128+ as its authors publish it, written the plain way.
    fn xoshiro128p(s: &mut [u32; 4]) -> u32 {
        let out = s[0].wrapping_add(s[3]);
        let t = s[1] << 9;
        s[2] ^= s[0];
        s[3] ^= s[1];
        s[1] ^= s[2];
        s[0] ^= s[3];
        s[2] ^= t;
        s[3] = s[3].rotate_left(11);
        out
    }

    #[test]
    fn streams_are_xoshiro128_plus() {
        let mut st = Streams::<f32>::for_sample(3, 5, 7);
        let mut plain = st.s;
        for _ in 0..100 {
            assert_eq!(st.next_u32(), xoshiro128p(&mut plain));
        }
    }

    /// Lane i of a 4- or 8-wide stream draws what lane i's stream draws alone, and a lane
    /// outside the mask neither moves nor gets a number.
    fn lanes_match_width_one<F: Float>() {
        let one = |i: usize| Streams::<f32>::for_sample(11, i as u64, 2);
        let mut wide = Streams::<F>::idle();
        let mut alone: Vec<_> = (0..F::WIDTH).map(one).collect();
        for (i, s) in alone.iter().enumerate() {
            wide.set_lane(i, *s);
        }
        for step in 0..64usize {
            let m = <F::Mask as crate::simd::Mask>::from_fn(|i| (step * 7 + i * 3) % 5 != 0);
            let u = wide.draw(m);
            for (i, s) in alone.iter_mut().enumerate() {
                let want = if crate::simd::Mask::get(m, i) {
                    s.next_f32()
                } else {
                    0.0
                };
                assert_eq!(u.get(i).to_bits(), want.to_bits(), "step {step}, lane {i}");
                assert_eq!(wide.lane(i).s, s.s);
            }
        }
    }

    #[test]
    fn draws_give_what_single_draws_give() {
        let m = crate::simd::M4::from_fn(|i| i != 2);
        let mut a = Streams::<crate::simd::F4>::idle();
        for i in 0..4 {
            a.set_lane(i, Streams::for_sample(4, 5, i as u64));
        }
        let mut b = a;
        let three = a.draws::<3>(m);
        for u in three {
            assert_eq!(u, b.draw(m));
        }
        for i in 0..4 {
            assert_eq!(a.lane(i).s, b.lane(i).s);
        }
    }

    #[test]
    fn every_width_draws_each_paths_own_numbers() {
        lanes_match_width_one::<crate::simd::F4>();
        lanes_match_width_one::<crate::simd::F8>();
    }

    #[test]
    fn streams_uniform_chi_square_and_distinct() {
        let mut r = Streams::<f32>::for_sample(7, 3, 1);
        assert_uniform_draws(|| r.next_f32());
        // Across streams: the first two draws of neighbouring pixels' streams, 8 × 8 cells
        // of (pixel p's first, pixel p + 1's first) and of (p's first, p's second).
        let mut across = [[0u32; 64]; 2];
        let n = 64_000u64;
        for p in 0..n {
            let mut a = Streams::<f32>::for_sample(9, p, 0);
            let [a0, a1] = a.next_2d();
            let b0 = Streams::<f32>::for_sample(9, p + 1, 0).next_f32();
            let cell = |x: f32, y: f32| (x * 8.0) as usize * 8 + (y * 8.0) as usize;
            across[0][cell(a0, b0)] += 1;
            across[1][cell(a0, a1)] += 1;
        }
        for counts in across {
            assert_uniform_64(&counts);
        }
        let first =
            |seed, pixel, sample| Streams::<f32>::for_sample(seed, pixel, sample).next_u32();
        let a = first(1, 0, 0);
        assert!(a != first(1, 1, 0) && a != first(1, 0, 1) && a != first(2, 0, 0));
        assert_eq!(a, first(1, 0, 0));
    }
}
