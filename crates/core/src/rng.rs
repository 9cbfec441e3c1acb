//! One seeding scheme for every random draw in rperc.
//!
//! A run, particle or landmark `index` of an experiment seeded with `seed` draws from
//! ChaCha8 keyed by `seed` on stream `index`: streams are independent (ChaCha's 64-bit
//! stream id), and the draws of index `i` do not depend on how many other indices
//! exist or which thread runs them, so results are bit-identical on any number of
//! threads or processes.

use rand::SeedableRng;
pub use rand_chacha::ChaCha8Rng as RngStream;
use rand_distr::{Distribution, StandardNormal};

/// The generator of stream `index` of the experiment seeded with `seed`.
///
/// # Examples
/// ```
/// use rand::Rng;
/// use rperc_core::rng::stream;
///
/// let a: u64 = stream(7, 3).random();
/// let b: u64 = stream(7, 3).random();
/// let c: u64 = stream(7, 4).random();
/// assert_eq!(a, b);
/// assert_ne!(a, c);
/// ```
pub fn stream(seed: u64, index: u64) -> RngStream {
    let mut rng = RngStream::seed_from_u64(seed);
    rng.set_stream(index);
    rng
}

/// Stream 0 of `seed`: the generator of a single-stream experiment.
pub fn seeded(seed: u64) -> RngStream {
    stream(seed, 0)
}

/// One standard normal draw.
pub fn normal<R: rand::Rng + ?Sized>(rng: &mut R) -> f64 {
    StandardNormal.sample(rng)
}

#[cfg(test)]
mod tests {
    use rand::Rng;

    use super::*;

    #[test]
    fn streams_are_reproducible_and_distinct() {
        let draws = |seed, index| -> Vec<u64> {
            let mut r = stream(seed, index);
            (0..8).map(|_| r.random()).collect()
        };
        assert_eq!(draws(1, 0), draws(1, 0));
        assert_ne!(draws(1, 0), draws(1, 1));
        assert_ne!(draws(1, 0), draws(2, 0));
    }

    #[test]
    fn normal_draws_have_unit_variance() {
        let mut r = seeded(3);
        let n = 200_000;
        let (mut s, mut s2) = (0.0, 0.0);
        for _ in 0..n {
            let v = normal(&mut r);
            s += v;
            s2 += v * v;
        }
        let mean = s / n as f64;
        let var = s2 / n as f64 - mean * mean;
        // Standard errors: 1/sqrt(n) for the mean, sqrt(2/n) for the variance.
        assert!(mean.abs() < 5.0 / (n as f64).sqrt());
        assert!((var - 1.0).abs() < 5.0 * (2.0 / n as f64).sqrt());
    }
}
