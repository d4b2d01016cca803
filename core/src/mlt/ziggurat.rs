//! Standard normal deviates by the ziggurat method (Marsaglia and Tsang
//! 2000, "The Ziggurat Method for Generating Random Variables", 128
//! layers), for the small steps of [`super::primary`].
//!
//! The half density f(x) = exp(−x²/2), x ≥ 0, is covered by 128 layers of
//! equal area v: a base layer, the rectangle [0, r] × [0, f(r)] plus the
//! tail beyond r, and above it rectangles [0, x_i] × [f(x_i), f(x_{i+1})],
//! with x_0 = v/f(r), x_1 = r and x_{i+1} = √(−2 ln(v/x_i + f(x_i))); r
//! and v are the paper's constants, for which x_128 comes out 0 (the tests
//! recompute the tables from this recurrence). A draw picks a layer and a
//! point z = u·x_i in it: where z < x_{i+1} the point is under the curve
//! (about 98.8 % of draws, one random word and one multiplication);
//! otherwise the wedge between the rectangle's corner and the curve is
//! accepted by f(z), and the base layer's overhang samples the tail
//! (Marsaglia 1964). Retried draws start afresh.
//!
//! The sign is a separate random bit, so the deviate is exactly symmetric
//! (z and −z equally likely), which the small step's acceptance ratio
//! relies on: Box–Muller's r·cos(2πu) was symmetric only up to the
//! rounding of the cosine. It replaced Box–Muller for speed
//! (`docs/accuracy.md`, "Level 1 against Tungsten's MMLT").

use rand_core::Rng;
use rand_pcg::Pcg32;

/// The paper's r: where the tail starts.
const R: f32 = X[1];

/// Layer widths x_i (module docs); x_0 = v/f(r), x_1 = r, x_128 = 0.
const X: [f32; 129] = [
    3.7130861e+00,
    3.4426198e+00,
    3.223085e+00,
    3.0832288e+00,
    2.9786963e+00,
    2.894344e+00,
    2.8231254e+00,
    2.7611694e+00,
    2.7061136e+00,
    2.6564064e+00,
    2.6109722e+00,
    2.5690336e+00,
    2.5300097e+00,
    2.4934545e+00,
    2.4590182e+00,
    2.4264207e+00,
    2.3954344e+00,
    2.3658714e+00,
    2.3375752e+00,
    2.3104136e+00,
    2.284274e+00,
    2.2590597e+00,
    2.2346864e+00,
    2.2110815e+00,
    2.1881804e+00,
    2.1659267e+00,
    2.1442702e+00,
    2.1231656e+00,
    2.1025732e+00,
    2.0824564e+00,
    2.0627823e+00,
    2.0435216e+00,
    2.024647e+00,
    2.0061338e+00,
    1.9879596e+00,
    1.9701033e+00,
    1.9525458e+00,
    1.9352692e+00,
    1.9182574e+00,
    1.9014946e+00,
    1.8849671e+00,
    1.8686612e+00,
    1.8525645e+00,
    1.8366655e+00,
    1.820953e+00,
    1.8054168e+00,
    1.7900469e+00,
    1.7748344e+00,
    1.7597703e+00,
    1.7448461e+00,
    1.7300541e+00,
    1.7153867e+00,
    1.7008367e+00,
    1.6863968e+00,
    1.6720607e+00,
    1.6578219e+00,
    1.6436741e+00,
    1.6296115e+00,
    1.6156281e+00,
    1.6017184e+00,
    1.5878769e+00,
    1.5740982e+00,
    1.5603772e+00,
    1.5467088e+00,
    1.5330878e+00,
    1.5195096e+00,
    1.505969e+00,
    1.4924614e+00,
    1.478982e+00,
    1.465526e+00,
    1.4520886e+00,
    1.4386653e+00,
    1.4252512e+00,
    1.4118418e+00,
    1.3984319e+00,
    1.385017e+00,
    1.3715922e+00,
    1.3581525e+00,
    1.3446927e+00,
    1.331208e+00,
    1.3176928e+00,
    1.3041419e+00,
    1.2905496e+00,
    1.2769103e+00,
    1.2632179e+00,
    1.2494665e+00,
    1.2356495e+00,
    1.2217603e+00,
    1.2077918e+00,
    1.1937367e+00,
    1.1795874e+00,
    1.1653357e+00,
    1.1509728e+00,
    1.1364899e+00,
    1.121877e+00,
    1.1071236e+00,
    1.0922189e+00,
    1.0771506e+00,
    1.061906e+00,
    1.0464709e+00,
    1.0308303e+00,
    1.0149674e+00,
    9.9886423e-01,
    9.825008e-01,
    9.6585506e-01,
    9.489026e-01,
    9.316162e-01,
    9.139652e-01,
    8.959153e-01,
    8.7742746e-01,
    8.5845685e-01,
    8.3895224e-01,
    8.188539e-01,
    7.9809207e-01,
    7.7658397e-01,
    7.542307e-01,
    7.309119e-01,
    7.064796e-01,
    6.807479e-01,
    6.534786e-01,
    6.243586e-01,
    5.929629e-01,
    5.5869216e-01,
    5.2065605e-01,
    4.7743782e-01,
    4.2654797e-01,
    3.6287144e-01,
    2.7232087e-01,
    0.000000e+00,
];
/// f(x_i) = exp(−x_i²/2); f_0 = f(r), the base layer's top.
const F: [f32; 129] = [
    2.6696292e-03,
    2.6696292e-03,
    5.548995e-03,
    8.624485e-03,
    1.1839478e-02,
    1.5167298e-02,
    1.8592102e-02,
    2.2103304e-02,
    2.5693292e-02,
    2.9356318e-02,
    3.3087887e-02,
    3.688439e-02,
    4.0742867e-02,
    4.4660863e-02,
    4.8636295e-02,
    5.266740e-02,
    5.6752663e-02,
    6.089077e-02,
    6.508058e-02,
    6.932112e-02,
    7.3611505e-02,
    7.7950984e-02,
    8.233890e-02,
    8.677467e-02,
    9.125780e-02,
    9.5787846e-02,
    1.0036444e-01,
    1.04987256e-01,
    1.0965602e-01,
    1.1437051e-01,
    1.19130544e-01,
    1.2393598e-01,
    1.2878671e-01,
    1.3368265e-01,
    1.3862377e-01,
    1.4361008e-01,
    1.4864157e-01,
    1.5371831e-01,
    1.5884037e-01,
    1.6400786e-01,
    1.692209e-01,
    1.7447963e-01,
    1.7978427e-01,
    1.8513499e-01,
    1.9053204e-01,
    1.9597565e-01,
    2.0146611e-01,
    2.0700371e-01,
    2.1258877e-01,
    2.1822165e-01,
    2.239027e-01,
    2.2963232e-01,
    2.3541094e-01,
    2.412390e-01,
    2.4711695e-01,
    2.530453e-01,
    2.5902456e-01,
    2.650553e-01,
    2.7113807e-01,
    2.772735e-01,
    2.834622e-01,
    2.8970486e-01,
    2.9600215e-01,
    3.0235484e-01,
    3.0876362e-01,
    3.152294e-01,
    3.217529e-01,
    3.283351e-01,
    3.3497685e-01,
    3.4167916e-01,
    3.4844297e-01,
    3.5526937e-01,
    3.621595e-01,
    3.6911446e-01,
    3.7613547e-01,
    3.832238e-01,
    3.903808e-01,
    3.9760786e-01,
    4.0490642e-01,
    4.1227803e-01,
    4.1972435e-01,
    4.272470e-01,
    4.3484783e-01,
    4.4252872e-01,
    4.5029163e-01,
    4.581387e-01,
    4.6607214e-01,
    4.740943e-01,
    4.8220766e-01,
    4.9041483e-01,
    4.9871865e-01,
    5.0712204e-01,
    5.156282e-01,
    5.2424055e-01,
    5.329627e-01,
    5.4179835e-01,
    5.507518e-01,
    5.598274e-01,
    5.690300e-01,
    5.783647e-01,
    5.8783704e-01,
    5.974532e-01,
    6.072195e-01,
    6.171434e-01,
    6.272325e-01,
    6.3749546e-01,
    6.479418e-01,
    6.585820e-01,
    6.694277e-01,
    6.8049186e-01,
    6.9178915e-01,
    7.033361e-01,
    7.151515e-01,
    7.272569e-01,
    7.3967725e-01,
    7.524416e-01,
    7.655842e-01,
    7.791461e-01,
    7.931770e-01,
    8.077383e-01,
    8.229072e-01,
    8.387836e-01,
    8.555006e-01,
    8.7324303e-01,
    8.9228165e-01,
    9.130436e-01,
    9.362827e-01,
    9.635997e-01,
    1.000000e+00,
];

/// A standard normal deviate from `rng`.
#[inline]
pub(crate) fn normal(rng: &mut Pcg32) -> f32 {
    normal_with(rng, &X, &F)
}

/// [`normal`] over the tables `x` and `f` (tests corrupt them).
#[inline]
fn normal_with(rng: &mut Pcg32, x: &[f32; 129], f: &[f32; 129]) -> f32 {
    loop {
        let bits = rng.next_u32();
        let i = (bits & 0x7F) as usize;
        let sign = if bits & 0x80 == 0 { 1.0 } else { -1.0 };
        let z = (bits >> 8) as f32 * (1.0 / 16_777_216.0) * x[i];
        if z < x[i + 1] {
            return sign * z;
        }
        if i == 0 {
            return sign * tail(rng);
        }
        let y = f[i] + uniform(rng) * (f[i + 1] - f[i]);
        if y < libm::expf(-0.5 * z * z) {
            return sign * z;
        }
    }
}

/// A deviate of the normal density beyond r (Marsaglia 1964): r + a with
/// a exponential of rate r, accepted with probability exp(−a²/2).
#[cold]
fn tail(rng: &mut Pcg32) -> f32 {
    loop {
        // 1 − u ∈ (0, 1]: the logarithms stay finite.
        let a = -libm::logf(1.0 - uniform(rng)) / R;
        let b = -libm::logf(1.0 - uniform(rng));
        if 2.0 * b > a * a {
            return R + a;
        }
    }
}

/// A uniform number in [0, 1) (24 bits).
#[inline]
fn uniform(rng: &mut Pcg32) -> f32 {
    (rng.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The tables are the recurrence of the module docs, from the paper's
    /// r and v, rounded to f32; and the top layer closes at x_128 = 0 with
    /// area v.
    #[test]
    fn tables_follow_the_recurrence() {
        let (r, v) = (3.442_619_855_899_f64, 9.912_563_035_262_17e-3_f64);
        let f = |x: f64| libm::exp(-x * x / 2.0);
        let mut x = [0.0f64; 129];
        x[0] = v / f(r);
        x[1] = r;
        for i in 1..127 {
            x[i + 1] = libm::sqrt(-2.0 * libm::log(v / x[i] + f(x[i])));
        }
        for i in 0..129 {
            let fi = if i == 0 { f(r) } else { f(x[i]) };
            assert_eq!(X[i], x[i] as f32, "x_{i}");
            assert_eq!(F[i], fi as f32, "f_{i}");
        }
        let top = x[127] * (1.0 - f(x[127]));
        assert!((top / v - 1.0).abs() < 1e-6, "top layer's area {top}");
    }

    /// χ² of 8 000 000 deviates in 80 bins over [−4, 4] and two tail bins
    /// against the normal distribution, sign balance, and the fourth
    /// moment. The statistic has 81 degrees of freedom: a mean of 81 and a
    /// standard deviation of 12.7, so 140 is 4.6 σ.
    fn chi2(x: &[f32; 129], f: &[f32; 129], seed: u64) -> (f64, f64) {
        let n = 8_000_000u32;
        let mut rng = Pcg32::new(seed, 11);
        let mut bins = [0u32; 82];
        let mut positive = 0u32;
        for _ in 0..n {
            let z = normal_with(&mut rng, x, f);
            positive += u32::from(z > 0.0);
            let k = if z < -4.0 {
                0
            } else if z >= 4.0 {
                81
            } else {
                1 + ((z + 4.0) * 10.0) as usize
            };
            bins[k.min(81)] += 1;
        }
        let cdf = |z: f64| 0.5 * libm::erfc(-z / core::f64::consts::SQRT_2);
        let mut chi2 = 0.0;
        for (k, &count) in bins.iter().enumerate() {
            let (lo, hi) = match k {
                0 => (f64::NEG_INFINITY, -4.0),
                81 => (4.0, f64::INFINITY),
                _ => (-4.0 + (k - 1) as f64 / 10.0, -4.0 + k as f64 / 10.0),
            };
            let expected = n as f64 * (cdf(hi) - cdf(lo));
            chi2 += (count as f64 - expected).powi(2) / expected;
        }
        (chi2, positive as f64 / n as f64)
    }

    #[test]
    fn deviates_are_standard_normal_and_symmetric() {
        for seed in [1, 2] {
            let (c, positive) = chi2(&X, &F, seed);
            assert!(c < 140.0, "seed {seed}: chi2 {c}");
            assert!(
                (positive - 0.5).abs() < 0.002,
                "seed {seed}: {positive} positive"
            );
        }
        // Negative controls: layer 40 10 % too narrow (its outer part
        // never drawn; a layer too wide would be caught by its wedge
        // test), and the wedges accepted without their test (a table whose
        // f is 0 everywhere).
        let mut narrow = X;
        narrow[40] *= 0.9;
        let (c, _) = chi2(&narrow, &F, 1);
        assert!(c > 140.0, "a layer too narrow went unnoticed: chi2 {c}");
        let (c, _) = chi2(&X, &[0.0; 129], 1);
        assert!(c > 140.0, "unchecked wedges went unnoticed: chi2 {c}");
    }

    /// The tail beyond r: its share of the deviates and its mean excess.
    #[test]
    fn the_tail_beyond_r_has_its_mass() {
        let n = 20_000_000u32;
        let mut rng = Pcg32::new(5, 7);
        let (mut count, mut excess) = (0u32, 0.0f64);
        for _ in 0..n {
            let z = normal(&mut rng).abs();
            if z > R {
                count += 1;
                excess += (z - R) as f64;
            }
        }
        // P(|z| > r) = erfc(r/√2) = 5.762e-4; E[|z| − r | |z| > r] =
        // f(r)/(√(2π)·P(z > r)) − r = 0.2636 for the normal's tail.
        let r = R as f64;
        let p = libm::erfc(r / core::f64::consts::SQRT_2);
        let share = count as f64 / n as f64;
        assert!((share / p - 1.0).abs() < 0.03, "tail share {share} vs {p}");
        let mean = excess / count as f64;
        let expected =
            libm::exp(-r * r / 2.0) / (2.0 * core::f64::consts::PI).sqrt() / (p / 2.0) - r;
        assert!(
            (mean / expected - 1.0).abs() < 0.03,
            "tail excess {mean} vs {expected}"
        );
    }
}
