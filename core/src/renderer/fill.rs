//! Full MLT and CMLT frames far below one mutation per pixel: the *block
//! fill*, BDPT samples at the pixel-block resolution
//! ([`super::PixelBlock`]) rendered beside the chains and combined with
//! their splats pixel by pixel, by weights fixed before any sample is
//! drawn.
//!
//! A frame of a game's budget holds a few hundredths of a level-1
//! mutation per pixel (the frame trial: 0.08 at 320 × 180 in 30 ms), so
//! the chains' splats alone leave 80–98 % of a reset frame black. What an
//! engine does at such budgets is dynamic resolution, so the fill is the
//! PT/BDPT dynamic-resolution pass itself (`pixel_block.rs`): BDPT samples,
//! one per k × k block, the block size fitted to the fill's measured
//! samples ([`super::PixelBlock::Fit`]) with a reset frame's guard pass —
//! every frame a full image, as a fitted BDPT frame is — or fixed by the
//! host. Two other sources were weighed and left: the chains' large steps
//! (independent primary-sample points, a share `large_step_prob` of the
//! mutations, so even fewer per pixel, each one strategy of one depth;
//! already weighed against the chains by Kelemen's MIS when
//! `large_step_mis` is on), and the normalisation passes' image
//! (`mlt/pass_image.rs`), which with kept chains is evaluated across the
//! frames of a moving view and joins none of them.
//!
//! **Work.** The fill takes [`FILL_SHARE`] of a frame's work, counting a
//! fill sample as [`crate::mlt::MltSettings::pass_records`] (ρ) level-1
//! mutations (ρ is a pass sample's cost in mutations): after m mutations a
//! worker owes `max(⌈m · f / ((1 − f) · ρ)⌉, minimum)` fill samples (f the
//! share), and it renders them before the mutations they pair with, so a
//! frame begins with its minimum (its guard pass first) and a frame cut
//! short at any later point holds both in proportion. The minimum is a
//! piece ([`super::PIECE`]), or the worker's W-th of a pass at
//! [`super::MAX_PIXEL_BLOCK`] if that is more (640 × 360: 60 blocks): the
//! fill then completes its coarsest pass in every frame the clock allows
//! that much, as fitted BDPT does, however few mutations the frame holds.
//! At [`super::PixelBlock::Fit`] each worker fits its fill's passes to
//! its own forecast (not to the W workers' together, as PT and BDPT do:
//! workers whose few fill samples give them different block sizes do not
//! complement one another's passes, and left about a quarter of a frame
//! to the guard pass), and renders its first fitted pass of a reset frame
//! whole (after its share of the guard pass) before any further mutation:
//! that pass is sized to about 0.7 of the worker's last frame's fill, so
//! a frame slower than the last still completes it and no pixel is left
//! to the guard pass alone, whose samples weigh 10⁻³ of a pass sample's
//! and so next to nothing against the chains' records (exactly black
//! where its one coarse sample was 0 and no chain splatted: the frame
//! trial's black MLT frames under load were such regions). The fill's
//! share of a frame is then at least that pass and otherwise
//! [`FILL_SHARE`]; a frame cut short spends more of its work on the fill.
//! The weights do not depend on how much work the fill got.
//!
//! **Weights.** A fill sample weighs ρ′ = ρ(1 + s) records (s CMLT's
//! level-2 share), as a normalisation-pass sample does, spread over its
//! block as its pixel weight is (1/m in each of its m pixels): a pixel
//! with fill weight W(i) (`accumulation::Weights`) and chain records R
//! over P pixels is
//!
//! ```text
//!   ( b·P·h(i)  +  ρ′·P·W(i)·Î_b(i) )  /  ( R  +  ρ′·P·W(i) )
//!   Î_b(i) = S(i) / W(i) + T(i) · P / N
//! ```
//!
//! h the chains' splats, S the fill's camera-side sums, T its
//! light-tracing (t = 1) splats at full resolution, N the fill's total
//! weight (kept and decayed frames add to the numerator and R as in
//! `accumulation.rs`). With W(i) = n passes everywhere this is the pass
//! image's weighting exactly (`mlt/pass_image.rs`: w = ρ′·n·P / R); here
//! W(i) may differ from pixel to pixel. The weights depend on the counts
//! only (how many mutations and fill samples the clock allowed), never on
//! a sample's value, so given the counts the pixel's expectation is
//! `w(i) · B_k I(i) + (1 − w(i)) · I(i)` with w(i) = ρ′PW(i) / (R +
//! ρ′PW(i)): the chains' unbiased image mixed with the fill's
//! block-filtered one (`pixel_block.rs`). Within a frame at one block size
//! W is constant over each block, so the image's mean is I's. A pixel no
//! mutation reached shows the fill's value; one the fill has not reached
//! (W = 0), the chains' alone — the image of a render without the fill.
//!
//! Off at [`super::PixelBlock::Fixed`]`(1)`, the default: offline MLT and
//! CMLT images stay the chains' (and the passes') alone.

/// The share of an MLT or CMLT frame's work the block fill takes (module
/// docs): its weight in the image, when ρ is a fill sample's true cost in
/// mutations. Small, because the fill only has to cover the pixels the
/// chains miss: the chains' image has the mean b whatever the frame's
/// noise, the fill's mean is a Monte Carlo estimate whose frame-to-frame
/// change (flicker) its share scales.
pub const FILL_SHARE: f64 = 0.125;

/// The fill samples a worker owes after `mutations` level-1 mutations of
/// its frame at `pass_records` (ρ) mutations per fill sample, at least
/// `minimum`, beyond the `rendered` it has rendered (0 for ρ = 0: a fill
/// that weighs nothing is not rendered).
pub(crate) fn owed(mutations: u64, pass_records: f32, minimum: u64, rendered: u64) -> u64 {
    if !(pass_records > 0.0) {
        return 0;
    }
    let due =
        libm::ceil(mutations as f64 * FILL_SHARE / ((1.0 - FILL_SHARE) * f64::from(pass_records)));
    (due as u64).max(minimum).saturating_sub(rendered)
}

/// One merged pixel of a Metropolis frame with a fill (module docs):
/// `chain` = the kept frames' sums plus b·P·h(i), `records` = the kept
/// and current records, the fill's camera-side sums `samples`, its
/// light-tracing splats `splats`, its pixel weight `weight`, its total
/// weight `total` (N) and the weight of a fill sample's pixel weight in
/// records, `rho_pixels` = ρ′·P. 0 when nothing weighs.
pub(crate) fn mix(
    chain: [f64; 3],
    records: f64,
    (samples, splats, weight): ([f64; 3], [f64; 3], f64),
    total: f64,
    rho_pixels: f64,
    pixels: f64,
) -> [f64; 3] {
    let denominator = records + rho_pixels * weight;
    if !(denominator > 0.0) {
        return [0.0; 3];
    }
    // W(i) · T(i) · P / N: the splats of a block-filtered BDPT pixel at
    // its weight (`accumulation.rs`).
    let splat = if total > 0.0 {
        weight * pixels / total
    } else {
        0.0
    };
    let inv = 1.0 / denominator;
    core::array::from_fn(|c| (chain[c] + rho_pixels * (samples[c] + splats[c] * splat)) * inv)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_fill_owes_its_share_of_the_work() {
        // f = 1/8, ρ = 5: one sample per 35 mutations, the first 16 (the
        // minimum) before any mutation.
        assert_eq!(owed(0, 5.0, 16, 0), 16);
        assert_eq!(owed(1, 5.0, 16, 0), 16);
        assert_eq!(owed(560, 5.0, 16, 16), 0);
        assert_eq!(owed(561, 5.0, 16, 16), 1);
        assert_eq!(owed(3500, 5.0, 16, 40), 60);
        assert_eq!(owed(3500, 5.0, 16, 200), 0);
        assert_eq!(owed(3500, 0.0, 16, 0), 0);
    }

    #[test]
    fn a_pixel_with_no_fill_is_the_chains_and_one_with_no_chain_the_fills() {
        let chain = [6.0, 3.0, 0.0];
        let none = ([0.0; 3], [0.0; 3], 0.0);
        assert_eq!(mix(chain, 3.0, none, 0.0, 50.0, 10.0), [2.0, 1.0, 0.0]);
        // The fill alone: S / W + T · P / N, whatever ρ′P.
        let fill = ([1.0, 2.0, 4.0], [0.5, 0.0, 0.0], 0.5);
        let v = mix([0.0; 3], 0.0, fill, 20.0, 50.0, 10.0);
        assert_eq!(v, [2.0 + 0.25, 4.0, 8.0]);
        assert_eq!(mix([0.0; 3], 0.0, none, 0.0, 50.0, 10.0), [0.0; 3]);
    }

    /// Kept-chain MLT frames of the white furnace to depth 4 (1 000
    /// bootstrap samples, 32 chains, `b_passes` normalisation passes), one
    /// worker: the fill tests' renderer.
    #[cfg(feature = "std")]
    fn furnace_frames(b_passes: u32, seed: u64) -> crate::renderer::RendererConfig {
        use crate::integrator::Settings;
        use crate::mlt::MltSettings;
        use crate::renderer::{Estimator, RendererConfig, Temporal};
        RendererConfig {
            estimator: Estimator::Mlt(MltSettings {
                n_bootstrap: 1_000,
                b_passes,
                b_min_samples: 0,
                n_chains: 32,
                ..MltSettings::default()
            }),
            settings: Settings {
                max_depth: Some(4),
                ..Settings::default()
            },
            seed,
            temporal: Temporal {
                keep_chains: true,
                ..Temporal::default()
            },
            ..RendererConfig::default()
        }
    }

    /// A reset frame slower than the last (a tenth of its pieces) still
    /// completes the fill's fitted pass, and so does one after a frame in
    /// which the two workers rendered unequal shares (their fitted block
    /// sizes then differ): every pixel is covered by a fitted pass's
    /// sample, not by the guard pass alone (whose weight, 10⁻³ of a
    /// sample's, is next to nothing against the chains' records: such a
    /// pixel is black where no chain splatted). Two workers, a camera that
    /// moves every frame, frames of 400 pieces (250 for worker 1) and 30
    /// in turn. Fails with the fill's samples paired with the mutations
    /// only, and with passes fitted to the workers' joint forecast.
    #[cfg(feature = "std")]
    #[test]
    fn a_short_frame_completes_the_fills_fitted_pass() {
        use crate::accel::bvh::Bvh;
        use crate::math::Rgb;
        use crate::mlt::tests::scenes;
        use crate::renderer::pixel_block::GUARD_WEIGHT;
        use crate::renderer::{PixelBlock, RenderWorker, Renderer, RendererConfig};
        use crate::scene::{Camera, FovAxis, Material};
        use glam::{Mat4, Vec3};

        let scene = scenes::furnace_scene(Material::diffuse(Rgb::splat(0.5)), 1.0);
        let bvh = Bvh::build(&scene.triangles().collect::<alloc::vec::Vec<_>>());
        let camera = |x: f32| {
            let to_world = Mat4::from_translation(Vec3::new(x, -0.2, -0.6));
            Camera::perspective(to_world, 70.0, FovAxis::X, 64, 48, 0.0, 1.0).unwrap()
        };
        let config = RendererConfig {
            workers: 2,
            ..furnace_frames(1, 3)
        };
        let mut r = Renderer::new(config, camera(0.0)).unwrap();
        r.set_pixel_block(PixelBlock::Fit).unwrap();
        let mut ws = [
            RenderWorker::new(&r, 0).unwrap(),
            RenderWorker::new(&r, 1).unwrap(),
        ];
        for f in 0..6 {
            if f > 0 {
                r.set_camera(camera(0.01 * f as f32)).unwrap();
            }
            if r.begin_prepare(&scene) && f == 0 {
                for w in &mut ws {
                    r.prepare_worker(w, &scene, &bvh).unwrap();
                }
                r.finish_prepare([&ws[0], &ws[1]]).unwrap();
            }
            for (i, w) in ws.iter_mut().enumerate() {
                let pieces = match (f % 2, i) {
                    (0, 0) => 400,
                    (0, _) => 250,
                    _ => 30,
                };
                let mut n = 0;
                r.render_while(w, &scene, &bvh, u64::MAX, &mut |_| {
                    n += 1;
                    n < pieces
                })
                .unwrap();
            }
            if f == 0 {
                continue;
            }
            let blocks = [ws[0].block, ws[1].block];
            let uncovered = (0..r.pixels() as usize)
                .filter(|&i| {
                    ws.iter().map(|w| w.weights.at(i)).sum::<f64>() <= f64::from(GUARD_WEIGHT)
                })
                .count();
            assert_eq!(uncovered, 0, "frame {f} (blocks {blocks:?})");
        }
    }

    /// The white furnace (closed box, albedo ½, Le = 1) to depth 4: every
    /// pixel is 1 + ½ + ¼ + ⅛ = 1.875, for the chains and for the fill
    /// alike, so any mixture of the two whose weights sum to one converges
    /// to it. Reset MLT frames of a quarter of a mutation per pixel with a
    /// fill at 2 × 2 blocks, averaged over the frames: 1.875 in the mean.
    /// The negative control, the
    /// same frames with the fill's weight ρ′PW(i) left out of the
    /// normalisation, is far off.
    #[cfg(feature = "std")]
    #[test]
    fn furnace_frames_with_a_fill_converge_and_without_its_weight_do_not() {
        use crate::accel::bvh::Bvh;
        use crate::math::Rgb;
        use crate::mlt::tests::scenes;
        use crate::renderer::{Layers, PixelBlock, RenderWorker, Renderer, Totals};
        use crate::scene::Material;

        let scene = scenes::furnace_scene(Material::diffuse(Rgb::splat(0.5)), 1.0);
        let bvh = Bvh::build(&scene.triangles().collect::<alloc::vec::Vec<_>>());
        let config = furnace_frames(4, 5);
        let mut r = Renderer::new(config, scene.camera).unwrap();
        r.set_pixel_block(PixelBlock::Fixed(2)).unwrap();
        let mut w = RenderWorker::new(&r, 0).unwrap();
        let pixels = 16 * 12;
        let (mut right, mut wrong) = (alloc::vec![0.0f64; pixels], alloc::vec![0.0f64; pixels]);
        let (mut mutations, mut fill_samples) = (0, 0);
        let frames = 300;
        for f in 0..=frames {
            if f > 0 {
                r.set_camera(scene.camera).unwrap();
            }
            // Kept chains go on with the first bootstrap's b; the later
            // bootstraps are left pending, so that no frame after the
            // first holds a normalisation-pass image: the chains and the
            // fill alone.
            if r.begin_prepare(&scene) && f == 0 {
                r.prepare_worker(&mut w, &scene, &bvh).unwrap();
                r.finish_prepare([&w]).unwrap();
            }
            let mut pieces = 0;
            r.render_while(&mut w, &scene, &bvh, u64::MAX, &mut |_| {
                pieces += 1;
                pieces < 4
            })
            .unwrap();
            let stats = r.stats(&[&w]);
            if f == 0 {
                continue;
            }
            assert_eq!(stats.mlt.pass_records, 0);
            mutations += stats.mlt.mutations;
            fill_samples += w.frame_samples;
            r.resolve(&[&w], |i, c| right[i] += c.luminance() as f64)
                .unwrap();
            let mut t = Totals::default();
            t.add(&r, &w);
            let b_pixels = r.b() * pixels as f64;
            for (i, sum) in wrong.iter_mut().enumerate() {
                let mut l = Layers::default();
                l.add(&w, i);
                let chain = l.total();
                let v: [f64; 3] = core::array::from_fn(|c| {
                    let fill = l.fill_samples[c] + l.fill_splats[c] * l.weight * 192.0 / t.samples;
                    let chain = l.kept[c] + chain[c] * b_pixels;
                    (chain + r.fill_rho_pixels() * fill) / (t.kept_records + t.records as f64)
                });
                *sum += Rgb::new(v[0] as f32, v[1] as f32, v[2] as f32).luminance() as f64;
            }
        }
        let per_pixel = mutations as f64 / (frames * pixels) as f64;
        assert!(per_pixel < 0.5, "{per_pixel} mutations per pixel");
        assert!(fill_samples > frames as u64, "{fill_samples} fill samples");
        let mean = |img: &[f64]| img.iter().sum::<f64>() / (frames * pixels) as f64;
        let (a, b) = (mean(&right), mean(&wrong));
        eprintln!(
            "{per_pixel:.3} mutations/px, fill {fill_samples}: mean {a:.4}, without the fill's weight {b:.4}"
        );
        assert!((a / 1.875 - 1.0).abs() < 0.02, "mean {a}");
        assert!((b / 1.875 - 1.0).abs() > 0.2, "negative control: mean {b}");
    }
}
