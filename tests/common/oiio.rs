//! Statistical image checks through OpenImageIO's command-line tools.
//!
//! [`ImageCheck::run`] compares a test image with a reference image, each with its
//! variance image (the estimated variance of every pixel mean, as `stokes render
//! --variance` writes it), and decides whether they differ by more than their noise:
//!
//! 1. **Per pixel** (OpenImageIO). `oiiotool` forms the difference image
//!    D = test − reference and the Z image z = D / √(var_test + var_ref + floor) (for
//!    var_test see [`TestVariance`]; for the floor, "Pixels without variance"), then
//!    compares the Z image with a black image (`--diff`, the comparison `idiff` makes, with
//!    `idiff`'s report): the check fails when more than an allowed share of the pixels have
//!    |z| > [`ImageCheck::z_fail`] in some channel, or when any pixel has
//!    |z| > [`ImageCheck::z_hard`]. The allowed share is derived from the number of pixels
//!    ([`ImageCheck::allowed_fail_share`]), so the thresholds follow each pixel's own
//!    noise rather than a fixed tolerance that noise passes or fails by luck.
//! 2. **Blocks**, up to the whole image. A bug seldom biases every pixel by several
//!    standard errors; it biases a region (a fluorescent patch, the glow of a volume) by
//!    less, or the whole image by a little (a light 10 % too bright). Per channel and per
//!    block of b×b pixels, z = Σ D / √(Σ var): a bias of δ standard errors in every pixel
//!    of a block gives z ≈ b·δ. Blocks of [`ImageCheck::min_block`] = 4, 8, 16, …
//!    pixels, the last scale being the whole image (the "image-mean z"); at each scale the
//!    largest |z| over blocks and channels must stay within the Bonferroni bound
//!    Q⁻¹(α / (2·C·blocks)) ([`ImageCheck::block_z_bound`]: 5.97 for the 144 4×4 blocks of
//!    a 48×48 image, 5.10 for the whole image). A block sums hundreds of samples or more,
//!    so its z is much closer to normal than a pixel's.
//!
//! On failure the difference images stay next to the test image, as `<test>.diff.exr`
//! (test − reference) and `<test>.zdiff.exr` (the Z image), and the error message holds
//! every statistic with `ok`/`FAIL` per criterion, the paths, and the comparison report.
//! On success the temporaries are removed. A missing `oiiotool` gives an error naming
//! [`INSTALL_HINT`].
//!
//! ## Pixels without variance
//!
//! A pixel whose samples were all equal in both images (the black void outside a scene,
//! say) has no variance to scale by. Its denominator gets a floor,
//! (ε·(|test| + |reference|))² + 10⁻³⁰ with ε = [`ImageCheck::rel_eps`], so two zeros give
//! z = 0 and two equal values z ≈ 0, while any real difference there gives an enormous z
//! and fails through `z_hard`: such pixels must agree exactly (up to float rounding).
//! They tell nothing about noise, so the allowed share of failing pixels counts only the
//! pixels with variance in some channel ("informative" pixels), and a check with too few
//! of them to detect a [`ImageCheck::detect_bias`] bias is refused as vacuous.
//!
//! ## Where the per-pixel thresholds come from
//!
//! For an unbiased pair with enough samples per pixel, each channel's z is close to a
//! standard normal, so P(|z| > z_fail) = 2Q(z_fail), Q the upper normal tail. A pixel
//! fails when any of its C = 3 channels does; the channels of a pixel are correlated (the
//! same paths), and by Šidák's inequality (which holds for any correlation of a normal
//! vector) a pixel fails with probability at most p₀ = 1 − (1 − 2Q(z_fail))^C. z is a
//! ratio with an estimated denominator, so its tails are heavier than normal at tens of
//! samples per pixel; the model rate is taken as q₀ = κ·p₀ ([`ImageCheck::tail_slack`]
//! κ = 1.5; measured on the scene families: 4–13 % of the pixels, up to 16 % = 1.2 p₀
//! for HWSS against mono in the fluorescent slab, whose sparse glow skews z). The number
//! of failing pixels among n informative ones is then at most Binomial(n, q₀), and the
//! allowed share f is the smallest with the Chernoff bound
//! P(K ≥ f·n) ≤ exp(−n·KL(f‖q₀)) ≤ α ([`ImageCheck::alpha`] = 10⁻⁶).
//!
//! A bias of δ standard errors in every pixel moves z to z + δ: at least one channel then
//! fails with probability p₁ ≥ Q(z_fail − δ) (0.84 for z_fail = 2, δ = 3), and the check
//! misses the bias with probability at most exp(−n·KL(f‖p₁)); the check refuses to run
//! when that bound exceeds α. With 2304 informative pixels (48×48) f ≈ 24 %, while a
//! 3-standard-error bias makes about 84 % of the pixels fail.
//!
//! z_fail = 2 rather than 4: the normal approximation of a studentised mean is good in the
//! bulk and poor in the far tail, so a moderate threshold with a derived share is more
//! robust than "no pixel beyond 4", and more powerful. [`ImageCheck::z_hard`] = 8 catches
//! single grossly wrong pixels (P(|z| > 8) ≈ 10⁻¹⁵ per channel for a normal z).
//!
//! **Samples per pixel.** The z of a pixel is only near normal when each image's samples
//! represent the pixel's distribution. A render with one wavelength per sample (mono)
//! misses a band holding 15 % of the spectrum with probability 0.85ⁿ over n samples
//! (0.5 % at n = 32, 10⁻⁹ at n = 128); a pixel that missed its dominant band has a small
//! mean *and* a small variance, and |z| of 12 was seen for mono against HWSS at 32 spp.
//! Give such renders a few times the samples of an HWSS render. The same holds for rare
//! bright contributions against a reference with far more samples: see
//! [`TestVariance::FromReference`].

use std::path::{Path, PathBuf};
use std::process::Command;

/// The Debian/Ubuntu package holding `oiiotool` and `idiff`.
pub const INSTALL_HINT: &str = "apt-get install openimageio-tools";

/// An image and its variance image.
#[derive(Debug, Clone)]
pub struct Exr {
    /// The image (pixel means).
    pub image: PathBuf,
    /// The estimated variance of every pixel mean.
    pub variance: PathBuf,
}

impl Exr {
    /// An image and its variance image at explicit paths.
    pub fn new(image: impl Into<PathBuf>, variance: impl Into<PathBuf>) -> Exr {
        Exr {
            image: image.into(),
            variance: variance.into(),
        }
    }

    /// `x.exr` with its variance at `x.variance.exr`, as `stokes render --variance` writes.
    pub fn stokes(image: impl Into<PathBuf>) -> Exr {
        let image = image.into();
        let variance = image.with_extension("variance.exr");
        Exr { image, variance }
    }
}

/// Where the variance of the test image comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TestVariance {
    /// The test's own variance image: for two renders of similar sample counts, or of
    /// different estimators.
    Own,
    /// For a reference rendered with the same estimator and many more samples: the
    /// larger of the test's own variance and the reference's scaled to the test's sample
    /// count, var_ref · spp_ref / spp_test (from the `stokes:spp` header attributes).
    /// Either alone fails on rare bright contributions (a few samples on the edge of a
    /// light, a firefly): a test pixel that missed them has a small mean *and* a small
    /// own variance, and looks many standard errors dark by its own variance (|z| of 14
    /// was seen on the Cornell box at 256 spp); a test pixel that caught one looks many
    /// standard errors bright by the reference's (|z| of 8), while its own variance
    /// holds the firefly. Taking the larger is slightly conservative for pixels without
    /// such contributions.
    FromReference,
}

/// The thresholds of an image check (see the module documentation for their derivation).
#[derive(Debug, Clone)]
pub struct ImageCheck {
    /// A pixel "fails" when some channel's |z| exceeds this.
    pub z_fail: f64,
    /// Any pixel beyond this |z| fails the check on its own.
    pub z_hard: f64,
    /// Factor on the normal-model rate of failing pixels, for the heavier tails of z.
    pub tail_slack: f64,
    /// Accepted probability of failing an unbiased pair (per criterion and scale, under
    /// the normal model), and of missing a bias of `detect_bias` standard errors.
    pub alpha: f64,
    /// The per-pixel bias (in standard errors) the per-pixel test must be able to detect.
    pub detect_bias: f64,
    /// Side of the smallest block of the block test (blocks double up to the image).
    pub min_block: u32,
    /// Relative tolerance of pixels without variance (see the module documentation).
    pub rel_eps: f64,
    /// Channels per pixel.
    pub channels: u32,
    /// Where the test's variance comes from.
    pub test_variance: TestVariance,
    /// The `oiiotool` executable.
    pub oiiotool: String,
}

impl Default for ImageCheck {
    fn default() -> Self {
        ImageCheck {
            z_fail: 2.0,
            z_hard: 8.0,
            tail_slack: 1.5,
            alpha: 1e-6,
            detect_bias: 3.0,
            min_block: 4,
            rel_eps: 1e-5,
            channels: 3,
            test_variance: TestVariance::Own,
            oiiotool: "oiiotool".into(),
        }
    }
}

/// One scale of the block test.
#[derive(Debug, Clone)]
pub struct BlockLevel {
    /// Block side in pixels (blocks at the right and bottom edges may be smaller).
    pub size: u32,
    /// Number of blocks.
    pub count: usize,
    /// The largest block |z|.
    pub max_z: f64,
    /// Where: block column, row and channel.
    pub at: (u32, u32, usize),
    /// The bound on |z| at this scale.
    pub allowed: f64,
}

impl BlockLevel {
    /// Whether the scale passes.
    pub fn ok(&self) -> bool {
        self.max_z <= self.allowed
    }
}

/// What a check measured.
#[derive(Debug, Clone)]
pub struct Report {
    /// Image width and height.
    pub size: (u32, u32),
    /// Pixels with nonzero variance (test + reference) in some channel.
    pub informative: usize,
    /// Pixels with |z| > z_fail in some channel (from the comparison report).
    pub failing: usize,
    /// `failing` as a share of `informative`.
    pub fail_share: f64,
    /// The largest allowed `fail_share`.
    pub allowed_share: f64,
    /// The largest pixel |z|.
    pub max_z: f64,
    /// Where `max_z` is ("x, y, channel").
    pub max_at: String,
    /// The block test, one entry per block size; the last one is the whole image.
    pub blocks: Vec<BlockLevel>,
    /// Per channel, (mean of test − mean of reference) / its standard error.
    pub mean_z: [f64; 3],
    /// Per-channel means of the test image.
    pub test_mean: [f64; 3],
    /// Per-channel means of the reference image.
    pub ref_mean: [f64; 3],
    /// The comparison report of `oiiotool --diff` (idiff's format).
    pub diff_report: String,
}

impl Report {
    /// Whether the images have something in them: in each image, some channel's mean of
    /// magnitude above `min` (a check only runs with enough pixels with variance to
    /// detect its bias, see [`ImageCheck::min_informative`]).
    pub fn nontrivial(&self, min: f64) -> bool {
        let big = |m: &[f64; 3]| m.iter().any(|v| v.abs() > min);
        big(&self.test_mean) && big(&self.ref_mean)
    }
}

/// The upper tail of the standard normal, Q(z) = P(Z > z) (relative error < 1.2·10⁻⁷;
/// Numerical Recipes' Chebyshev fit of erfc).
pub fn normal_tail(z: f64) -> f64 {
    let x = z / std::f64::consts::SQRT_2;
    let a = x.abs();
    let t = 1.0 / (1.0 + 0.5 * a);
    let poly = -a * a - 1.265_512_23
        + t * (1.000_023_68
            + t * (0.374_091_96
                + t * (0.096_784_18
                    + t * (-0.186_288_06
                        + t * (0.278_868_07
                            + t * (-1.135_203_98
                                + t * (1.488_515_87 + t * (-0.822_152_23 + t * 0.170_872_77))))))));
    let erfc = t * poly.exp();
    0.5 * if x >= 0.0 { erfc } else { 2.0 - erfc }
}

/// The z with Q(z) = p, for 0 < p < 1/2 (bisection).
pub fn normal_quantile_upper(p: f64) -> f64 {
    let (mut lo, mut hi) = (0.0, 40.0);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if normal_tail(mid) > p {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// Kullback–Leibler divergence of Bernoulli(f) from Bernoulli(q).
fn kl(f: f64, q: f64) -> f64 {
    let term = |a: f64, b: f64| if a <= 0.0 { 0.0 } else { a * (a / b).ln() };
    term(f, q) + term(1.0 - f, 1.0 - q)
}

impl ImageCheck {
    /// p₀: the normal-model probability that an unbiased pixel fails in some channel
    /// (Šidák bound over the channels).
    pub fn null_pixel_rate(&self) -> f64 {
        1.0 - (1.0 - 2.0 * normal_tail(self.z_fail)).powi(self.channels as i32)
    }

    /// p₁: a lower bound on the probability that a pixel biased by `detect_bias`
    /// standard errors fails (one channel pushed beyond z_fail).
    pub fn biased_pixel_rate(&self) -> f64 {
        normal_tail(self.z_fail - self.detect_bias)
    }

    /// The largest share of `n` informative pixels allowed beyond `z_fail`: the smallest
    /// f with exp(−n·KL(f‖κp₀)) ≤ α (1 when even f = 1 does not reach α).
    pub fn allowed_fail_share(&self, n: usize) -> f64 {
        let q0 = (self.tail_slack * self.null_pixel_rate()).min(1.0);
        let target = (1.0 / self.alpha).ln();
        let n = n as f64;
        if n * kl(1.0, q0) <= target {
            return 1.0;
        }
        let (mut lo, mut hi) = (q0, 1.0);
        for _ in 0..100 {
            let mid = 0.5 * (lo + hi);
            if n * kl(mid, q0) > target {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        hi
    }

    /// Chernoff bound on the probability that the per-pixel test misses a `detect_bias`
    /// bias with `n` informative pixels.
    pub fn miss_bound(&self, n: usize) -> f64 {
        let f = self.allowed_fail_share(n);
        let p1 = self.biased_pixel_rate();
        if f >= p1 {
            1.0
        } else {
            (-(n as f64) * kl(f, p1)).exp()
        }
    }

    /// The fewest informative pixels with which a `detect_bias` bias is missed with
    /// probability at most α.
    pub fn min_informative(&self) -> usize {
        (1..1_000_000)
            .find(|&n| self.miss_bound(n) <= self.alpha)
            .unwrap_or(usize::MAX)
    }

    /// The bound on the block |z| when the image is cut into `blocks` blocks: two-sided
    /// α over all blocks and channels (Bonferroni).
    pub fn block_z_bound(&self, blocks: usize) -> f64 {
        normal_quantile_upper(self.alpha / (2.0 * self.channels as f64 * blocks as f64))
    }

    /// Runs `oiiotool` with `args`: its output, or an error naming the package if it
    /// cannot be run.
    pub fn oiiotool(&self, args: &[String]) -> Result<std::process::Output, String> {
        Command::new(&self.oiiotool)
            .args(args)
            .output()
            .map_err(|e| format!("cannot run {} ({INSTALL_HINT}): {e}", self.oiiotool))
    }

    /// Compares `test` with `reference`. `Ok` with the measurements when every criterion
    /// passes; otherwise an error naming the failed criteria, with the statistics, the
    /// difference images kept beside the test image, and the comparison report.
    pub fn run(&self, test: &Exr, reference: &Exr) -> Result<Report, String> {
        let name = |p: &Path| p.display().to_string();
        let read = |p: &Path| {
            stokes::output::read_exr(p)
                .map(|(w, h, px, m)| ((w, h), px, m))
                .map_err(|e| e.to_string())
        };
        let (size, t, t_meta) = read(&test.image)?;
        let (size_tv, tv, _) = read(&test.variance)?;
        let (size_r, r, r_meta) = read(&reference.image)?;
        let (size_rv, rv, _) = read(&reference.variance)?;
        for (s, p) in [
            (size_tv, &test.variance),
            (size_r, &reference.image),
            (size_rv, &reference.variance),
        ] {
            if s != size {
                return Err(format!(
                    "{} is {}x{} but {} is {}x{}",
                    name(p),
                    s.0,
                    s.1,
                    name(&test.image),
                    size.0,
                    size.1
                ));
            }
        }
        for (px, p) in [
            (&t, &test.image),
            (&tv, &test.variance),
            (&r, &reference.image),
            (&rv, &reference.variance),
        ] {
            if let Some(i) = px.iter().position(|v| v.iter().any(|c| !c.is_finite())) {
                return Err(format!("{}: pixel {i} is not finite: {:?}", name(p), px[i]));
            }
        }
        for (px, p) in [(&tv, &test.variance), (&rv, &reference.variance)] {
            if let Some(i) = px.iter().position(|v| v.iter().any(|&c| c < 0.0)) {
                return Err(format!("{}: pixel {i} has a negative variance", name(p)));
            }
        }

        // The variance of the difference, per pixel and channel, and its oiiotool recipe.
        let (v, var_args): (Vec<[f64; 3]>, Vec<String>) = match self.test_variance {
            TestVariance::Own => (
                tv.iter()
                    .zip(&rv)
                    .map(|(a, b)| std::array::from_fn(|c| a[c] as f64 + b[c] as f64))
                    .collect(),
                vec![
                    name(&test.variance),
                    name(&reference.variance),
                    "--add".into(),
                ],
            ),
            TestVariance::FromReference => {
                let spp = |meta: &[(String, String)], p: &Path| {
                    meta.iter()
                        .find(|(k, _)| k == "spp")
                        .and_then(|(_, v)| v.parse::<f64>().ok())
                        .filter(|&n| n > 0.0)
                        .ok_or_else(|| format!("{}: no stokes:spp header attribute", name(p)))
                };
                let k = spp(&r_meta, &reference.image)? / spp(&t_meta, &test.image)?;
                (
                    tv.iter()
                        .zip(&rv)
                        .map(|(a, b)| {
                            std::array::from_fn(|c| {
                                (a[c] as f64).max(k * b[c] as f64) + b[c] as f64
                            })
                        })
                        .collect(),
                    vec![
                        name(&test.variance),
                        name(&reference.variance),
                        "--mulc".into(),
                        k.to_string(),
                        "--max".into(),
                        name(&reference.variance),
                        "--add".into(),
                    ],
                )
            }
        };

        // Informative pixels and the block test, in f64 (oiiotool prints its statistics
        // with six decimals, too few for variances of 10⁻⁸).
        let npx = t.len();
        let mut test_mean = [0.0f64; 3];
        let mut ref_mean = [0.0f64; 3];
        let mut informative = 0;
        for i in 0..npx {
            let mut any = false;
            for c in 0..3 {
                any |= v[i][c] > 0.0;
                test_mean[c] += t[i][c] as f64 / npx as f64;
                ref_mean[c] += r[i][c] as f64 / npx as f64;
            }
            informative += any as usize;
        }
        let need = self.min_informative();
        if informative < need {
            return Err(format!(
                "vacuous image check: only {informative} of {npx} pixels of {} and {} have \
                 variance; at least {need} are needed to detect a bias of {} standard errors",
                name(&test.image),
                name(&reference.image),
                self.detect_bias
            ));
        }
        let blocks = self.block_levels(size, &t, &r, &v);
        let whole = blocks.last().expect("the whole image is a level");
        let mean_z = {
            let sums = block_sums(size, whole.size, &t, &r, &v)[0];
            std::array::from_fn(|c| self.block_z(&sums, c))
        };

        // The difference and Z images, and the per-pixel comparison, in one oiiotool run.
        let allowed_share = self.allowed_fail_share(informative);
        let percent = format!(
            "{:.6}",
            100.0 * allowed_share * informative as f64 / npx as f64
        );
        let diff = test.image.with_extension("diff.exr");
        let z = test.image.with_extension("zdiff.exr");
        let remove = || {
            let _ = std::fs::remove_file(&diff);
            let _ = std::fs::remove_file(&z);
        };
        let z_fail = self.z_fail.to_string();
        let strings = |v: &[&str]| v.iter().map(|s| s.to_string()).collect::<Vec<_>>();
        #[rustfmt::skip]
        let args: Vec<String> = [
            strings(&[
                "-v", "-d", "float",
                "--fail", &z_fail, "--failpercent", &percent,
                "--hardfail", &self.z_hard.to_string(),
                "--warn", &z_fail, "--warnpercent", &percent,
                // D = T − R
                &name(&test.image), &name(&reference.image), "--sub", "-o", &name(&diff),
            ]),
            // V: VT + VR, or max(VT, VR·spp_ref/spp_test) + VR
            var_args,
            strings(&[
                // z = D / √(V + (ε(|T| + |R|))² + 10⁻³⁰)
                &name(&test.image), "--abs", &name(&reference.image), "--abs", "--add",
                "--mulc", &self.rel_eps.to_string(), "--dup", "--mul", "--addc", "1e-30",
                "--add", "--powc", "0.5", "--div", "-o", &name(&z),
                // z against black
                "--dup", "--mulc", "0", "--diff",
            ]),
        ]
        .concat();
        let out = self.oiiotool(&args)?;
        let stdout = String::from_utf8_lossy(&out.stdout);
        // The comparison report, without -v's "Reading ..." lines.
        let diff_report = stdout
            .lines()
            .skip_while(|l| !l.starts_with("Computing diff"))
            .collect::<Vec<_>>()
            .join("\n");
        // oiiotool --diff: 0 pass (or warn), 1 failure; an error also exits 1, without
        // the FAILURE line.
        let pixels_ok = out.status.success();
        if !pixels_ok && !diff_report.lines().any(|l| l.trim() == "FAILURE") {
            remove();
            return Err(format!(
                "oiiotool {} failed: {stdout}{}",
                args.join(" "),
                String::from_utf8_lossy(&out.stderr)
            ));
        }
        let (max_z, max_at) = parse_max_error(&diff_report);
        let failing = parse_failing(&diff_report);
        let report = Report {
            size,
            informative,
            failing,
            fail_share: failing as f64 / informative as f64,
            allowed_share,
            max_z,
            max_at,
            blocks,
            mean_z,
            test_mean,
            ref_mean,
            diff_report,
        };
        if pixels_ok && report.blocks.iter().all(BlockLevel::ok) {
            remove();
            return Ok(report);
        }
        Err(self.failure_message(test, reference, &report, pixels_ok, &diff, &z))
    }

    /// z of channel `c` of a block from its sums (Σ D, Σ var, Σ (|T| + |R|)).
    fn block_z(&self, s: &[[f64; 3]; 3], c: usize) -> f64 {
        s[0][c] / (s[1][c] + (self.rel_eps * s[2][c]).powi(2) + 1e-30).sqrt()
    }

    /// The block test at every scale: min_block, twice that, … and the whole image.
    fn block_levels(
        &self,
        size: (u32, u32),
        t: &[[f32; 3]],
        r: &[[f32; 3]],
        v: &[[f64; 3]],
    ) -> Vec<BlockLevel> {
        let side = size.0.max(size.1);
        let mut sizes = vec![];
        let mut b = self.min_block.max(2);
        while b < side {
            sizes.push(b);
            b *= 2;
        }
        sizes.push(side);
        sizes
            .into_iter()
            .map(|b| {
                let sums = block_sums(size, b, t, r, v);
                let columns = size.0.div_ceil(b);
                let mut level = BlockLevel {
                    size: b,
                    count: sums.len(),
                    max_z: 0.0,
                    at: (0, 0, 0),
                    allowed: self.block_z_bound(sums.len()),
                };
                for (k, s) in sums.iter().enumerate() {
                    for c in 0..3 {
                        let z = self.block_z(s, c).abs();
                        if z > level.max_z {
                            level.max_z = z;
                            level.at = (k as u32 % columns, k as u32 / columns, c);
                        }
                    }
                }
                level
            })
            .collect()
    }

    fn failure_message(
        &self,
        test: &Exr,
        reference: &Exr,
        report: &Report,
        pixels_ok: bool,
        diff: &Path,
        z: &Path,
    ) -> String {
        let name = |p: &Path| p.display().to_string();
        let verdict = |ok: bool| if ok { "ok  " } else { "FAIL" };
        let (whole, parts) = report.blocks.split_last().expect("at least one level");
        let channel = ["R", "G", "B"];
        let levels = parts
            .iter()
            .map(|l| {
                format!(
                    "{s}x{s}: {:.2} at block ({}, {}) {} (allowed {:.2})",
                    l.max_z,
                    l.at.0,
                    l.at.1,
                    channel[l.at.2],
                    l.allowed,
                    s = l.size
                )
            })
            .collect::<Vec<_>>()
            .join("; ");
        let mz = report.mean_z;
        [
            format!(
                "image check failed: {} vs {} ({}x{} pixels, {} with variance)",
                name(&test.image),
                name(&reference.image),
                report.size.0,
                report.size.1,
                report.informative
            ),
            format!(
                "{} per-pixel share: {} pixels ({:.2} %) beyond |z| > {}, allowed {:.2} %",
                verdict(report.fail_share <= report.allowed_share),
                report.failing,
                100.0 * report.fail_share,
                self.z_fail,
                100.0 * report.allowed_share
            ),
            format!(
                "{} max |z|: {:.3} at ({}), allowed {}",
                verdict(report.max_z <= self.z_hard),
                report.max_z,
                report.max_at,
                self.z_hard
            ),
            format!(
                "{} block |z|: {levels}",
                verdict(parts.iter().all(BlockLevel::ok))
            ),
            format!(
                "{} image-mean z (R, G, B): [{:.2}, {:.2}, {:.2}], allowed ±{:.2} \
                 (means {:.4?} vs {:.4?})",
                verdict(whole.ok()),
                mz[0],
                mz[1],
                mz[2],
                whole.allowed,
                report.test_mean,
                report.ref_mean
            ),
            format!(
                "difference images: {} (test − reference), {} ((test − reference)/σ)",
                name(diff),
                name(z)
            ),
            format!(
                "per-pixel comparison (oiiotool --diff, idiff's report): {}",
                if pixels_ok { "pass" } else { "FAILURE" }
            ),
            report.diff_report.clone(),
        ]
        .join("\n")
    }
}

/// Per block of `b`×`b` pixels (row-major) and channel: Σ D, Σ var, Σ (|T| + |R|), for
/// the test `t`, the reference `r` and the variance of their difference `v`.
fn block_sums(
    (w, h): (u32, u32),
    b: u32,
    t: &[[f32; 3]],
    r: &[[f32; 3]],
    v: &[[f64; 3]],
) -> Vec<[[f64; 3]; 3]> {
    let columns = w.div_ceil(b);
    let mut sums = vec![[[0.0f64; 3]; 3]; (columns * h.div_ceil(b)) as usize];
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            let s = &mut sums[((y / b) * columns + x / b) as usize];
            for c in 0..3 {
                s[0][c] += t[i][c] as f64 - r[i][c] as f64;
                s[1][c] += v[i][c];
                s[2][c] += (t[i][c] as f64).abs() + (r[i][c] as f64).abs();
            }
        }
    }
    sums
}

/// "Max error  = 5.3 @ (12, 40, G) ..." → (5.3, "12, 40, G"); (0, "") without the line.
fn parse_max_error(report: &str) -> (f64, String) {
    for line in report.lines() {
        if let Some(rest) = line.trim().strip_prefix("Max error") {
            let rest = rest.trim_start_matches([' ', '=']);
            let value = rest.split_whitespace().next().and_then(|v| v.parse().ok());
            let at = rest
                .split_once('(')
                .and_then(|(_, r)| r.split_once(')'))
                .map(|(a, _)| a.to_string())
                .unwrap_or_default();
            return (value.unwrap_or(f64::NAN), at);
        }
    }
    (0.0, String::new())
}

/// The largest count of the "K pixels (P%) over T" lines (one for the warning threshold
/// and one for the failure threshold, both z_fail here).
fn parse_failing(report: &str) -> usize {
    report
        .lines()
        .filter(|l| l.contains(" pixels (") && l.contains(" over "))
        .filter_map(|l| l.split_whitespace().next()?.parse().ok())
        .max()
        .unwrap_or(0)
}

/// Writes `src` shifted by `sigmas` standard errors of its difference with an image of
/// variance `other_variance` — src + sigmas·√(var_src + var_other), built by `oiiotool` —
/// to `out`, and returns it with `src`'s variance image: a negative control that an
/// [`ImageCheck`] against that other image must fail.
pub fn shifted_copy(
    src: &Exr,
    other_variance: &Path,
    sigmas: f64,
    out: &Path,
) -> Result<Exr, String> {
    let p = |x: &Path| x.display().to_string();
    #[rustfmt::skip]
    let args: Vec<String> = [
        "-d", "float",
        &p(&src.variance), &p(other_variance), "--add", "--powc", "0.5",
        "--mulc", &sigmas.to_string(), &p(&src.image), "--add", "-o", &p(out),
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    let o = ImageCheck::default().oiiotool(&args)?;
    if !o.status.success() {
        return Err(format!(
            "oiiotool {} failed: {}",
            args.join(" "),
            String::from_utf8_lossy(&o.stderr)
        ));
    }
    Ok(Exr::new(out, &src.variance))
}

/// `oiiotool --stats` of an image, as text.
pub fn stats(img: &Path) -> Result<String, String> {
    let args = [
        "--stats".to_string(),
        "-v".into(),
        img.display().to_string(),
    ];
    let out = ImageCheck::default().oiiotool(&args)?;
    if !out.status.success() {
        return Err(format!(
            "oiiotool --stats failed: {}",
            String::from_utf8_lossy(&out.stderr)
        ));
    }
    Ok(String::from_utf8_lossy(&out.stdout).into_owned())
}
