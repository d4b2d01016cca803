//! Pearson χ² goodness-of-fit test of a direction sampler against its
//! claimed density, in the manner of Mitsuba's `chi2` test suite.
//!
//! The sphere is binned in (cos θ, φ), which is area-preserving
//! (dω = dcos θ dφ), so each bin's expected count is N·∫∫ pdf dcos θ dφ. The
//! integrals are computed by adaptive Gauss–Legendre cubature, accurate far
//! beyond the statistical noise, so a rejection means the sampler and the
//! density disagree. Bins with small expected counts are pooled (the χ²
//! approximation needs ≳ 5 per bin) and the p-value comes from the χ²
//! distribution's survival function.

use glam::{Vec2, Vec3};
use rand_core::Rng;
use rand_pcg::Pcg32;

use super::{Bsdf, TransportMode};

/// Bins in cos θ over [−1, 1] (both hemispheres: samples on the wrong side
/// land in bins whose expected count is 0 and fail the test outright).
const N_COS: usize = 48;
/// Bins in φ over [−π, π).
const N_PHI: usize = 96;
/// Smallest expected count of a bin before pooling.
const MIN_EXPECTED: f64 = 5.0;

/// Outcome of [`run`].
#[derive(Debug)]
pub(crate) struct Chi2Outcome {
    /// Pearson statistic.
    pub chi2: f64,
    /// Degrees of freedom (pooled bins − 1).
    pub dof: usize,
    /// P(χ²_dof ≥ chi2).
    pub p_value: f64,
    /// ∫ pdf over the sphere, by the same cubature.
    pub integral: f64,
    /// Number of directions the sampler returned (of `samples` attempts).
    pub returned: usize,
    /// Set when a sample fell where the density is zero, or was not finite.
    pub impossible: Option<&'static str>,
}

impl core::fmt::Display for Chi2Outcome {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(
            f,
            "χ² = {:.1} with {} dof, p = {:.3e}; ∫pdf = {:.6}; {} samples returned",
            self.chi2, self.dof, self.p_value, self.integral, self.returned
        )?;
        if let Some(why) = self.impossible {
            write!(f, "; {why}")?;
        }
        Ok(())
    }
}

impl Chi2Outcome {
    /// True when the sampler is consistent with the density at
    /// significance `alpha`.
    pub fn passes(&self, alpha: f64) -> bool {
        self.impossible.is_none() && self.p_value >= alpha
    }
}

/// A uniform f32 in [0, 1) with 24 random bits, like the renderer's streams.
pub(crate) fn uniform(rng: &mut Pcg32) -> f32 {
    (rng.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// The significance of each of `count` tests that keeps the family-wise
/// false-rejection rate at `alpha` (Šidák correction).
pub(crate) fn sidak(alpha: f64, count: usize) -> f64 {
    1.0 - (1.0 - alpha).powf(1.0 / count as f64)
}

fn bin_of(w: Vec3) -> usize {
    let z = w.z.clamp(-1.0, 1.0);
    let i = (((z + 1.0) * 0.5 * N_COS as f32) as usize).min(N_COS - 1);
    let phi = libm::atan2f(w.y, w.x);
    let j = (((phi + core::f32::consts::PI) / core::f32::consts::TAU * N_PHI as f32) as usize)
        .min(N_PHI - 1);
    i * N_PHI + j
}

/// Draws `samples` directions with `sample` (given an RNG seeded with
/// `seed`) and tests their histogram against `pdf` (per solid angle).
pub(crate) fn run(
    samples: usize,
    seed: u64,
    mut sample: impl FnMut(&mut Pcg32) -> Option<Vec3>,
    pdf: impl Fn(Vec3) -> f64,
) -> Chi2Outcome {
    let mut rng = Pcg32::new(seed, 0xda3e_39cb_94b9_5bdb);
    let mut observed = vec![0.0f64; N_COS * N_PHI];
    let mut returned = 0;
    let mut impossible = None;
    for _ in 0..samples {
        if let Some(w) = sample(&mut rng) {
            if !w.is_finite() || (w.length() - 1.0).abs() > 1e-4 {
                impossible = Some("sampled direction is not a unit vector");
                continue;
            }
            observed[bin_of(w)] += 1.0;
            returned += 1;
        }
    }

    let expected = integrate_bins(&pdf, COUNT_TOL);
    let integral: f64 = expected.iter().sum();

    let mut cells: Vec<(f64, f64)> = Vec::with_capacity(expected.len());
    for (e, o) in expected.iter().zip(&observed) {
        let e = e * samples as f64;
        if e <= 0.0 {
            if *o > 0.0 {
                impossible = Some("samples in a bin of zero density");
            }
            continue;
        }
        cells.push((e, *o));
    }
    cells.sort_by(|a, b| a.0.total_cmp(&b.0));
    // Pool the smallest bins until each pooled bin expects ≥ MIN_EXPECTED.
    let (mut chi2, mut bins) = (0.0, 0usize);
    let (mut pe, mut po) = (0.0, 0.0);
    for (e, o) in cells {
        if e < MIN_EXPECTED || pe > 0.0 {
            pe += e;
            po += o;
            if pe < MIN_EXPECTED {
                continue;
            }
            chi2 += (po - pe) * (po - pe) / pe;
            (pe, po) = (0.0, 0.0);
        } else {
            chi2 += (o - e) * (o - e) / e;
        }
        bins += 1;
    }
    if pe > 0.0 {
        chi2 += (po - pe) * (po - pe) / pe;
        bins += 1;
    }
    let dof = bins.saturating_sub(1).max(1);
    let p_value = chi2_survival(chi2, dof);
    Chi2Outcome {
        chi2,
        dof,
        p_value,
        integral,
        returned,
        impossible,
    }
}

/// The χ² fit of a BSDF's sampler against its density for one `wo`, as
/// every model's tests run it: `samples` attempts of `bsdf.sample` (random
/// lobe choice, radiance transport), whose non-delta directions are tested
/// against `bsdf.pdf` at significance `alpha`. A Dirac sample (a mixed
/// model's coating) counts as not returned: `pdf` describes the smooth
/// part only. Two checks ride along: ∫pdf ≤ 1, and the fraction of
/// attempts that return a smooth direction equals ∫pdf (within 5σ of
/// binomial noise). Panics naming `name` on failure; returns the outcome
/// for further checks.
pub(super) fn fit_bsdf(
    name: &str,
    bsdf: &Bsdf,
    wo: Vec3,
    samples: usize,
    seed: u64,
    alpha: f64,
) -> Chi2Outcome {
    let out = run(
        samples,
        seed,
        |rng| {
            let u_lobe = uniform(rng);
            let u = Vec2::new(uniform(rng), uniform(rng));
            bsdf.sample(wo, u_lobe, u, TransportMode::Radiance)
                .filter(|s| !s.delta)
                .map(|s| s.wi)
        },
        |wi| bsdf.pdf(wo, wi) as f64,
    );
    assert!(
        out.passes(alpha),
        "{name}: χ² rejected at {alpha:.2e}: {out}"
    );
    assert!(
        out.integral <= 1.0 + 1e-4,
        "{name}: ∫pdf = {}",
        out.integral
    );
    let frac = out.returned as f64 / samples as f64;
    let p = out.integral.clamp(0.0, 1.0);
    let sigma = (p * (1.0 - p) / samples as f64).sqrt();
    assert!(
        (frac - out.integral).abs() <= 5.0 * sigma + 1e-4,
        "{name}: returned {frac}, ∫pdf {}",
        out.integral
    );
    out
}

/// Absolute tolerance per bin of the expected counts' integrals (and of
/// the albedo bounds): at most 0.1 expected counts per million samples,
/// 20× below the noise of the smallest pooled bin (√5 counts), and at most
/// 5e-4 over the 4 608 bins of the sphere. The models evaluate in f32,
/// whose rounding makes the cubature's error estimate noisy near this
/// level in bright bins: 1e-8 refined them to the depth limit and took 3×
/// the time of the principled tests (53 s against 17.5 s of CPU) for no
/// accuracy the tests use.
pub(crate) const COUNT_TOL: f64 = 1e-7;

/// Absolute tolerance per bin for identities checked to 1e-5 of the whole
/// sphere (the microfacet normalisations, evaluated cheaply).
pub(crate) const FINE_TOL: f64 = 1e-8;

/// ∫ f dω over each (cos θ, φ) bin of the sphere, each to the absolute
/// tolerance `tol` ([`COUNT_TOL`] or [`FINE_TOL`]).
///
/// Adaptive cubature can only refine where its nodes see structure, so two
/// precautions keep narrow lobes from slipping between nodes: it starts
/// from the bins rather than one big rectangle, and inside each bin it
/// integrates over θ (with dω = sin θ dθ dφ) instead of cos θ, because a
/// cos θ interval next to a pole spans a wide range of θ: the bin
/// cos θ ∈ [1 − 1/24, 1] covers θ up to 16°, while a lobe of α = 0.05 lies
/// within 3° and its nodes in cos θ would all fall outside it.
pub(crate) fn integrate_bins(f: &impl Fn(Vec3) -> f64, tol: f64) -> Vec<f64> {
    let g = |theta: f64, phi: f64| {
        let (s, c) = theta.sin_cos();
        s * f(Vec3::new(
            (s * phi.cos()) as f32,
            (s * phi.sin()) as f32,
            c as f32,
        ))
    };
    let mut out = vec![0.0f64; N_COS * N_PHI];
    for i in 0..N_COS {
        let z0 = -1.0 + 2.0 * i as f64 / N_COS as f64;
        let z1 = -1.0 + 2.0 * (i + 1) as f64 / N_COS as f64;
        let (t0, t1) = (z1.clamp(-1.0, 1.0).acos(), z0.clamp(-1.0, 1.0).acos());
        for j in 0..N_PHI {
            let p0 = -core::f64::consts::PI + core::f64::consts::TAU * j as f64 / N_PHI as f64;
            let p1 =
                -core::f64::consts::PI + core::f64::consts::TAU * (j + 1) as f64 / N_PHI as f64;
            out[i * N_PHI + j] = integrate_rect(&g, [t0, t1, p0, p1], tol);
        }
    }
    out
}

/// ∫ f dω over the sphere, each bin to the absolute tolerance `tol`.
pub(crate) fn integrate_sphere(f: &impl Fn(Vec3) -> f64, tol: f64) -> f64 {
    integrate_bins(f, tol).iter().sum()
}

/// 4-point Gauss–Legendre nodes and weights on [−1, 1].
const GL_X: [f64; 4] = [
    -0.861_136_311_594_052_6,
    -0.339_981_043_584_856_3,
    0.339_981_043_584_856_3,
    0.861_136_311_594_052_6,
];
const GL_W: [f64; 4] = [
    0.347_854_845_137_453_9,
    0.652_145_154_862_546_1,
    0.652_145_154_862_546_1,
    0.347_854_845_137_453_9,
];

/// Tensor-product Gauss–Legendre rule on `[x0, x1] × [y0, y1]`.
fn gauss_rect(f: &impl Fn(f64, f64) -> f64, [x0, x1, y0, y1]: [f64; 4]) -> f64 {
    let (cx, hx) = (0.5 * (x0 + x1), 0.5 * (x1 - x0));
    let (cy, hy) = (0.5 * (y0 + y1), 0.5 * (y1 - y0));
    let mut s = 0.0;
    for (xi, wx) in GL_X.iter().zip(&GL_W) {
        for (yi, wy) in GL_X.iter().zip(&GL_W) {
            s += wx * wy * f(cx + hx * xi, cy + hy * yi);
        }
    }
    s * hx * hy
}

/// Adaptive cubature: accept a rectangle when the rule on it agrees with
/// the sum over its four quadrants, otherwise recurse into the quadrants.
pub(crate) fn integrate_rect(f: &impl Fn(f64, f64) -> f64, rect: [f64; 4], tol: f64) -> f64 {
    fn rec(
        f: &impl Fn(f64, f64) -> f64,
        [x0, x1, y0, y1]: [f64; 4],
        whole: f64,
        tol: f64,
        depth: u32,
    ) -> f64 {
        let (xm, ym) = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
        let quads = [
            [x0, xm, y0, ym],
            [xm, x1, y0, ym],
            [x0, xm, ym, y1],
            [xm, x1, ym, y1],
        ];
        let parts = quads.map(|q| gauss_rect(f, q));
        let sum: f64 = parts.iter().sum();
        if depth == 0 || (sum - whole).abs() <= tol {
            return sum;
        }
        quads
            .iter()
            .zip(parts)
            .map(|(q, p)| rec(f, *q, p, 0.5 * tol, depth - 1))
            .sum()
    }
    rec(f, rect, gauss_rect(f, rect), tol, 14)
}

/// Survival function of the χ² distribution with `dof` degrees of freedom:
/// the regularised upper incomplete gamma function Q(dof/2, x/2).
pub(crate) fn chi2_survival(x: f64, dof: usize) -> f64 {
    gamma_q(0.5 * dof as f64, 0.5 * x)
}

/// Q(a, x) = Γ(a, x)/Γ(a): the power series of P = 1 − Q for x < a + 1,
/// otherwise the continued fraction of Q (Abramowitz & Stegun §6.5),
/// evaluated with the modified Lentz method.
fn gamma_q(a: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 1.0;
    }
    // x^a e^{−x} / Γ(a), in logs to avoid overflow for large dof.
    let prefactor = (a * x.ln() - x - libm::lgamma(a)).exp();
    if x < a + 1.0 {
        // γ(a, x)/Γ(a) = x^a e^{−x}/Γ(a) · Σ xⁿ / (a (a+1) … (a+n)).
        let (mut term, mut sum, mut n) = (1.0 / a, 1.0 / a, a);
        while term.abs() > sum.abs() * 1e-16 {
            n += 1.0;
            term *= x / n;
            sum += term;
        }
        (1.0 - prefactor * sum).max(0.0)
    } else {
        // Γ(a, x)/Γ(a) =
        //   prefactor · 1/(x+1−a− 1(1−a)/(x+3−a− 2(2−a)/(x+5−a− …))).
        let tiny = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / tiny;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..10_000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < tiny {
                d = tiny;
            }
            c = b + an / c;
            if c.abs() < tiny {
                c = tiny;
            }
            d = 1.0 / d;
            let delta = d * c;
            h *= delta;
            if (delta - 1.0).abs() < 1e-15 {
                break;
            }
        }
        prefactor * h
    }
}

#[test]
fn survival_function_matches_closed_forms() {
    // dof = 2: Q(1, x/2) = e^{−x/2}.
    for x in [0.1, 1.0, 3.0, 10.0, 40.0] {
        assert!(
            (chi2_survival(x, 2) - (-0.5 * x).exp()).abs() < 1e-12,
            "{x}"
        );
    }
    // dof = 1: P(χ²₁ ≥ x) = erfc(√(x/2)).
    for x in [0.01, 0.5, 2.0, 9.0] {
        assert!(
            (chi2_survival(x, 1) - libm::erfc((0.5 * x).sqrt())).abs() < 1e-10,
            "{x}"
        );
    }
    // Large dof: the median is ≈ k(1 − 2/(9k))³ (Wilson–Hilferty).
    let k = 2000.0f64;
    let median = k * (1.0 - 2.0 / (9.0 * k)).powi(3);
    assert!((chi2_survival(median, 2000) - 0.5).abs() < 1e-3);
}

#[test]
fn cubature_integrates_peaks() {
    // A narrow Gaussian bump fully inside the domain integrates to 1.
    let s = 0.01f64;
    let f = |x: f64, y: f64| {
        (-(x * x + y * y) / (2.0 * s * s)).exp() / (2.0 * core::f64::consts::PI * s * s)
    };
    let v = integrate_rect(&f, [-0.3, 0.5, -0.2, 0.4], 1e-9);
    assert!((v - 1.0).abs() < 1e-7, "{v}");
}
