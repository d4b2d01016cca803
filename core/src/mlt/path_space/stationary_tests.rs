//! The chain's stationary distribution against path tracing: a Pearson χ²
//! test of where the path-space chains are, and of where they record, on
//! the mirror-sphere furnace.
//!
//! Method (as the multiple-try tests', `mlt/multiple_try/tests.rs`): many
//! independent short chains, each started from an exact sample of the
//! target Y(f(x̄))/b over paths of 1 … 4 segments, each binned once at its
//! end. A kernel that leaves the target invariant keeps every chain's end
//! state exactly target-distributed, and independent chains make the
//! binned values i.i.d., so Pearson's χ² applies without any
//! autocorrelation correction; a kernel with another stationary
//! distribution drifts from the start towards it.
//!
//! The exact samples: on the furnace every surface emits 1 and reflects ½
//! (diffuse walls, the mirror sphere), so a camera random walk by BSDF
//! sampling — path tracing without next-event estimation — has the same
//! weight Y(f)/p for every path of one depth d, and its paths are
//! distributed as Y(f) among those of depth d; a depth drawn with
//! probability b_d/b = 2^{1−d}/1.875 completes the sample (the test checks
//! the constant weights on every path it draws). The expected histogram
//! comes from independent samples of the same walk: a two-sample χ² test.
//!
//! The records of a chain's last mutation (the proposal with weight a,
//! the current path with 1 − a, as the renderer records them) are the
//! expectation of its next state given the proposal: their histogram has
//! the end states' mean and no more variance, so Pearson's statistic with
//! the multinomial variance is conservative for them (it rejects a correct
//! chain no more often than the end states' test).
//!
//! Bins: depth × 4×4-pixel block × the perturbation the path's class
//! admits (none, lens, caustic, multi-chain), which decides the mutations
//! chosen at it (`selection.rs`).

use glam::Vec2;

use super::bidirectional::{Broken, lens_vertex, scatter_ray, surface_vertex};
use super::chain::{Mutations, PathChain};
use super::selection::Mutation;
use super::state::PathState;
use crate::accel::Intersector;
use crate::accel::bvh::Bvh;
use crate::bsdf::TransportMode;
use crate::bsdf::chi2::chi2_survival;
use crate::integrator::Tracer;
use crate::integrator::bdpt::path_densities;
use crate::mlt::PathMutations;
use crate::mlt::perturbation::classify;
use crate::mlt::tests::scenes;
use crate::sampler::SampleStream;

/// Longest path of the test, in segments.
const DEPTH: usize = 4;
/// Bins: depth × 12 blocks of the 16×12 image × 4 classes.
const BINS: usize = DEPTH * 12 * 4;

/// The path a camera random walk of `depth` segments makes from the
/// uniforms of `rng` (module docs), with its weight Y(f)/p; `None` when
/// the walk leaves the scene (never on the closed furnace).
fn random_walk<I: Intersector>(
    tr: &mut Tracer<'_, I>,
    depth: usize,
    rng: &mut SampleStream,
) -> Option<(PathState, f64)> {
    let camera = tr.camera;
    let mut x = PathState::with_capacity(DEPTH as u32);
    let p0 = camera.lens_point(rng.next_2d());
    x.path.push(lens_vertex(p0, camera.forward()));
    let u = rng.next_2d();
    let raster = Vec2::new(u.x * camera.width() as f32, u.y * camera.height() as f32);
    let mut ray = camera.ray_from_lens(raster, p0);
    loop {
        x.path.push(surface_vertex(tr.trace(&ray)?));
        let n = x.path.len();
        if n == depth + 1 {
            break;
        }
        let (u_lobe, u) = (rng.next_f32(), rng.next_2d());
        let (v, from) = (&x.path[n - 1], &x.path[n - 2]);
        ray = scatter_ray(tr, v, from, u_lobe, u, TransportMode::Radiance)?;
    }
    x.evaluate(tr);
    let (mut fwd, mut rev) = ([0.0f32; DEPTH + 1], [0.0f32; DEPTH + 1]);
    path_densities(tr.scene, &camera, &x.path, &mut fwd, &mut rev);
    let p: f64 = fwd[1..=depth].iter().map(|&v| v as f64).product();
    let w = x.target() as f64 / p;
    Some((x, w))
}

/// An exact sample of the target over paths of 1 … [`DEPTH`] segments
/// (module docs); checks that its weight, scaled by 2^{d−1}, is `unit`
/// (set by the first sample).
fn exact_sample<I: Intersector>(
    tr: &mut Tracer<'_, I>,
    rng: &mut SampleStream,
    unit: &mut Option<f64>,
) -> PathState {
    // d with probability 2^{1−d} / Σ_{j ≤ DEPTH} 2^{1−j}.
    let total: f32 = (0..DEPTH).map(|j| libm::powf(0.5, j as f32)).sum();
    let u = rng.next_f32() * total;
    let (mut depth, mut acc) = (1, 0.0);
    while depth < DEPTH {
        acc += libm::powf(0.5, (depth - 1) as f32);
        if u < acc {
            break;
        }
        depth += 1;
    }
    let (x, w) = random_walk(tr, depth, rng).expect("the furnace is closed");
    let scaled = w * libm::pow(2.0, (depth - 1) as f64);
    let unit = *unit.get_or_insert(scaled);
    assert!(
        (scaled / unit - 1.0).abs() < 1e-3,
        "depth {depth}: weight {scaled} against {unit}: not a furnace's random walk"
    );
    x
}

/// The bin of a path of `depth` segments recorded at `raster`, whose
/// class admits `perturbation`.
fn bin(depth: usize, raster: Vec2, perturbation: Option<Mutation>) -> usize {
    let (bx, by) = ((raster.x / 4.0) as usize, (raster.y / 4.0) as usize);
    let block = by.min(2) * 4 + bx.min(3);
    let class = match perturbation {
        None => 0,
        Some(Mutation::Lens) => 1,
        Some(Mutation::Caustic) => 2,
        _ => 3,
    };
    ((depth - 1) * 12 + block) * 4 + class
}

/// The bin of state `x`.
fn state_bin<I: Intersector>(tr: &Tracer<'_, I>, x: &PathState, raster: Vec2) -> usize {
    bin(
        x.depth(),
        raster,
        Mutation::perturbation(&classify(tr, &x.path)),
    )
}

/// How a negative control breaks the chain.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Control {
    /// The chain as it is.
    Correct,
    /// A bidirectional-mutation T as [`Broken`] says.
    Bidirectional(Broken),
    /// The perturbations' ratio without their Jacobians.
    NoJacobian,
}

/// Two-sample Pearson χ² of histogram `a` (total `na`) against `b` (total
/// `nb`), bins pooled (in order of `b`'s counts) until each expects at
/// least 5 of `a`'s: (χ², degrees of freedom, p-value).
fn two_sample(a: &[f64; BINS], b: &[f64; BINS], na: f64, nb: f64) -> (f64, usize, f64) {
    let mut order: Vec<usize> = (0..BINS).collect();
    order.sort_by(|&i, &j| b[i].total_cmp(&b[j]));
    let (ka, kb) = ((nb / na).sqrt(), (na / nb).sqrt());
    let (mut chi2, mut cells) = (0.0, 0usize);
    let (mut pa, mut pb) = (0.0, 0.0);
    for (n, &i) in order.iter().enumerate() {
        pa += a[i];
        pb += b[i];
        let last = n + 1 == order.len();
        if pb * na / nb < 5.0 && !last {
            continue;
        }
        if pa + pb > 0.0 {
            chi2 += (ka * pa - kb * pb).powi(2) / (pa + pb);
            cells += 1;
        }
        (pa, pb) = (0.0, 0.0);
    }
    let dof = cells.saturating_sub(1).max(1);
    (chi2, dof, chi2_survival(chi2, dof))
}

/// `chains` chains of `steps` mutations (all five mutations) from exact
/// samples on the mirror furnace, broken as `control` says: the p-values of
/// the χ² tests of their end states and of their last mutation's records
/// (the proposal with weight a, the current path with 1 − a, as the
/// renderer records them) against `chains` × 4 exact samples.
fn stationary_p_values(chains: u64, steps: u32, control: Control, seed: u64) -> (f64, f64) {
    let scene = scenes::mirror_sphere_furnace();
    let tris: Vec<_> = scene.triangles().collect();
    let accel = Bvh::build(&tris);
    let mut tr = Tracer::new(&scene, &accel);
    let camera = tr.camera;
    let mut m = Mutations::new(
        &PathMutations::default(),
        DEPTH as u32,
        camera.width(),
        camera.height(),
        camera.pixel_angle(),
    );
    match control {
        Control::Correct => {}
        Control::Bidirectional(b) => m.bidirectional.broken = Some(b),
        Control::NoJacobian => m.perturbations.broken = true,
    }
    let mut unit = None;
    let mut reference = [0.0f64; BINS];
    let refs = chains * 4;
    for i in 0..refs {
        let mut rng = SampleStream::new(seed, i, 11);
        let x = exact_sample(&mut tr, &mut rng, &mut unit);
        reference[state_bin(&tr, &x, x.raster)] += 1.0;
    }
    let (mut ends, mut records) = ([0.0f64; BINS], [0.0f64; BINS]);
    let mut chain = PathChain::with_capacity(DEPTH as u32);
    for c in 0..chains {
        let mut rng = SampleStream::new(seed, c, 12);
        *chain.current_mut() = exact_sample(&mut tr, &mut rng, &mut unit);
        chain.start(seed ^ (0xC4A1 + c));
        for s in 1..=steps {
            let from = chain.current().depth();
            let st = chain.step(&mut tr, &mut m);
            if s < steps {
                continue;
            }
            // The proposal is the current path if it was accepted, the
            // other one if not; the path it would replace the reverse.
            let (proposed, kept) = if st.accepted {
                (chain.current(), chain.other())
            } else {
                (chain.other(), chain.current())
            };
            if let Some(sp) = st.proposal {
                let b = bin(
                    st.proposal_depth,
                    sp.raster,
                    Mutation::perturbation(&classify(&tr, &proposed.path)),
                );
                records[b] += sp.value.luminance() as f64;
            }
            if let Some(sp) = st.current {
                let b = bin(
                    from,
                    sp.raster,
                    Mutation::perturbation(&classify(&tr, &kept.path)),
                );
                records[b] += sp.value.luminance() as f64;
            }
        }
        let x = chain.current();
        ends[state_bin(&tr, x, x.raster)] += 1.0;
    }
    let n = chains as f64;
    let end = two_sample(&ends, &reference, n, refs as f64);
    let rec = two_sample(&records, &reference, n, refs as f64);
    eprintln!(
        "{control:?}: end states χ² {:.1} ({} dof, p {:.2e}); records χ² {:.1} ({} dof, p {:.2e})",
        end.0, end.1, end.2, rec.0, rec.1, rec.2
    );
    (end.2, rec.2)
}

/// The chains' end states and their last records fit the target (p ≥
/// 10⁻³ each, a fixed seed); negative controls: a bidirectional mutation
/// whose ratio leaves out the mutations' selection probabilities, and
/// perturbations whose ratio leaves out their Jacobians, both fail (p <
/// 10⁻⁴). (A T of one split in place of Veach's sum keeps the furnace's
/// distribution, whose splits' densities are alike: `tests.rs` catches it
/// on proposals.)
#[test]
fn chains_keep_the_target_stationary() {
    const SEED: u64 = 0x5EED;
    let (end, records) = stationary_p_values(30_000, 16, Control::Correct, SEED);
    assert!(
        end >= 1e-3 && records >= 1e-3,
        "end states p {end:.2e}, records p {records:.2e}"
    );
    for control in [
        Control::Bidirectional(Broken::NoSelection),
        Control::NoJacobian,
    ] {
        let (end, records) = stationary_p_values(30_000, 16, control, SEED);
        assert!(
            end < 1e-4 && records < 1e-4,
            "{control:?} went unnoticed: end states p {end:.2e}, records p {records:.2e}"
        );
    }
}
