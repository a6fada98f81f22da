//! Small seeded random generators for the simulator, the benchmarks and the statistical tests:
//! SplitMix64 (Steele, Lea & Flood 2014), xorshift64* (Vigna 2016) and the Box–Muller normal.
//! Deterministic on every run and machine, no dependency, no allocation.
//!
//! Why one module: the host tool and model-core's tests each carried their own copy; the streams
//! here are bit for bit those copies' streams, so no seeded result moved when they were merged.
//! Not for anything that needs unpredictability.
//!
//! [`box_muller`] (and [`SplitMix64::normal`]) need the `std` feature (or model-core's own tests):
//! they use std's `ln` and `cos`, whose results differ from `libm`'s in the last bit for some
//! inputs (about 7 % and 3 % of uniform draws on glibc), so a `libm` version would move every
//! normal stream. The board never draws random numbers and builds without the feature.

// std's float methods for `box_muller` (the crate is otherwise `no_std`).
#[cfg(feature = "std")]
extern crate std;

/// SplitMix64's increment (2⁶⁴ / φ, odd).
const GAMMA: u64 = 0x9E37_79B9_7F4A_7C15;
/// 2⁵³: 53 random bits fill an `f64` mantissa.
const TWO_POW_53: f64 = (1u64 << 53) as f64;

/// SplitMix64's output for state `z` (the state advanced once, then mixed): a 64-bit hash, used
/// directly for counter-based draws (any index in any order).
pub fn splitmix64(z: u64) -> u64 {
    let mut z = z.wrapping_add(GAMMA);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Uniform in [0, 1) from the top 53 bits of `bits`.
pub fn unit(bits: u64) -> f64 {
    (bits >> 11) as f64 / TWO_POW_53
}

/// Uniform in (0, 1] from the top 53 bits of `bits`, half a step into each grid cell, so its
/// logarithm is finite (the top cell's centre, 1 − 2⁻⁵⁴, rounds to 1).
pub fn unit_open(bits: u64) -> f64 {
    ((bits >> 11) as f64 + 0.5) / TWO_POW_53
}

/// A standard normal deviate from two uniforms (Box–Muller, the cosine of the pair); `u1` in
/// (0, 1] keeps the logarithm finite.
#[cfg(any(test, feature = "std"))]
pub fn box_muller(u1: f64, u2: f64) -> f64 {
    (-2.0 * u1.ln()).sqrt() * (core::f64::consts::TAU * u2).cos()
}

/// The SplitMix64 generator: the next output is [`splitmix64`] of the state, which then
/// advances by the increment.
#[derive(Debug, Clone)]
pub struct SplitMix64(u64);

impl SplitMix64 {
    pub const fn new(seed: u64) -> Self {
        Self(seed)
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        let out = splitmix64(self.0);
        self.0 = self.0.wrapping_add(GAMMA);
        out
    }

    /// Uniform in [0, 1) with 53 random bits.
    pub fn uniform(&mut self) -> f64 {
        unit(self.next_u64())
    }

    /// Uniform in [lo, hi).
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.uniform()
    }

    /// Uniform in 0..n (n > 0; the modulo's bias is below n / 2⁶⁴).
    pub fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }

    /// True with probability `p`.
    pub fn chance(&mut self, p: f64) -> bool {
        self.uniform() < p
    }

    /// Standard normal ([`box_muller`] on 1 − u, which lies in (0, 1], and the next uniform).
    #[cfg(any(test, feature = "std"))]
    pub fn normal(&mut self) -> f64 {
        let u1 = 1.0 - self.uniform();
        let u2 = self.uniform();
        box_muller(u1, u2)
    }
}

/// The xorshift64* generator (the simulated INA226's noise and validate's synthetic runs).
#[derive(Debug, Clone)]
pub struct XorShift64Star(u64);

impl XorShift64Star {
    /// Seed 0 is replaced by SplitMix64's increment: the all-zero state is a fixed point of
    /// xorshift.
    pub const fn new(seed: u64) -> Self {
        Self(if seed == 0 { GAMMA } else { seed })
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        let mut x = self.0;
        x ^= x >> 12;
        x ^= x << 25;
        x ^= x >> 27;
        self.0 = x;
        x.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }

    /// Uniform in [0, 1) with 53 random bits.
    pub fn uniform(&mut self) -> f64 {
        unit(self.next_u64())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Reference outputs of SplitMix64 for seed 1234567 (Vigna's splitmix64.c, as quoted by the
    /// `rand_xoshiro` crate's tests).
    #[test]
    fn splitmix64_matches_the_reference() {
        let mut rng = SplitMix64::new(1_234_567);
        let expected = [
            6_457_827_717_110_365_317,
            3_203_168_211_198_807_973,
            9_817_491_932_198_370_423,
            4_593_380_528_125_082_431,
            16_408_922_859_458_223_821,
        ];
        for e in expected {
            assert_eq!(rng.next_u64(), e);
        }
        // The hash is one step of the generator.
        assert_eq!(splitmix64(1_234_567), expected[0]);
    }

    /// xorshift64* from state 1: the first output is the multiplier times the first xorshift
    /// state (1 ^ 1 << 25 = 0x0200_0001), worked by hand.
    #[test]
    fn xorshift64star_first_step() {
        let mut rng = XorShift64Star::new(1);
        assert_eq!(
            rng.next_u64(),
            0x0200_0001u64.wrapping_mul(0x2545_F491_4F6C_DD1D)
        );
        assert_eq!(XorShift64Star::new(0).0, GAMMA);
    }

    #[test]
    fn uniforms_stay_in_their_intervals() {
        assert_eq!(unit(0), 0.0);
        assert!(unit(u64::MAX) < 1.0);
        assert!(unit_open(0) > 0.0);
        assert_eq!(unit_open(u64::MAX), 1.0);
        assert!(unit_open(u64::MAX - (1 << 11)) < 1.0);
        let mut rng = SplitMix64::new(3);
        for _ in 0..1000 {
            let x = rng.range(-2.0, 5.0);
            assert!((-2.0..5.0).contains(&x));
            assert!(rng.below(7) < 7);
        }
    }

    /// Mean 0 and variance 1 over 100 000 draws (standard errors 0.003 and 0.0045).
    #[test]
    fn normal_has_unit_variance() {
        let mut rng = SplitMix64::new(11);
        let n = 100_000;
        let draws: Vec<f64> = (0..n).map(|_| rng.normal()).collect();
        let mean = draws.iter().sum::<f64>() / n as f64;
        let var = draws.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
        assert!(mean.abs() < 0.015, "mean {mean}");
        assert!((var - 1.0).abs() < 0.025, "variance {var}");
        assert!(box_muller(1.0, 0.3) == 0.0);
    }
}
