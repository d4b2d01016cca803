//! The perturbations through media on a real scene: a side chain's start
//! value, taken from the level-1 path's own vertices (their medium
//! indices, the transmittance of their segments), against a retrace that
//! finds the moving medium vertex at the kept free-flight distance and
//! tracks the media across null boundaries itself.

use glam::Vec3;

use super::media::{caustic_value, lens_value, medium_factor, multi_chain_value, walk_media};
use super::{
    Applicable, CausticAnchor, LensEnd, LensState, LensTarget, MultiChainAnchor, classify,
    is_reflection,
};
use crate::accel::bvh::Bvh;
use crate::bsdf::TransportMode;
use crate::integrator::bdpt::{PathStorage, sample_strategy, strategy_path};
use crate::integrator::bdpt::{PathVertex, scatter, shading_correction};
use crate::integrator::{Settings, Tracer};
use crate::math::Rgb;
use crate::mlt::multiple_try::Target;
use crate::mlt::tests::scenes;
use crate::sampler::SampleStream;
use crate::scene::{Material, MaterialKind, Medium, MediumInterface, Phase, Scene, SceneBuilder};

/// The furnace box (walls of albedo ½ emitting ½) in a forward-scattering
/// haze that the camera is in, with a null-bounded ball of a denser
/// isotropic medium and a mirror sphere: paths with medium vertices at
/// either end of the lens connection, through null boundaries, and
/// through the mirror.
pub(crate) fn fog_box() -> Scene {
    let mut b = SceneBuilder::new();
    let wall = b.add_material(Material::diffuse(Rgb::splat(0.5)));
    let boundary = b.add_material(Material {
        kind: MaterialKind::Null,
        two_sided: false,
        detail: Default::default(),
    });
    let mirror = b.add_material(scenes::perfect_mirror(0.9));
    let haze = b.add_medium(
        Medium::homogeneous(
            Rgb::new(0.6, 0.8, 1.0),
            Rgb::splat(0.9),
            1.0,
            Phase::HenyeyGreenstein { g: 0.5 },
        )
        .unwrap(),
    );
    let inner = b.add_medium(
        Medium::homogeneous(
            Rgb::new(1.5, 1.0, 0.8),
            Rgb::new(0.9, 0.8, 0.7),
            1.0,
            Phase::Isotropic,
        )
        .unwrap(),
    );
    let walls = b.add_mesh(scenes::inward_box(wall, 0.5));
    b.set_mesh_media(
        walls,
        MediumInterface {
            interior: Some(haze),
            exterior: Some(haze),
        },
    );
    let ball = b.add_mesh(scenes::sphere(Vec3::new(0.2, 0.0, 0.4), 0.35, boundary));
    b.set_mesh_media(
        ball,
        MediumInterface {
            interior: Some(inner),
            exterior: Some(haze),
        },
    );
    b.add_mesh(scenes::sphere(Vec3::new(-0.45, 0.1, 0.5), 0.45, mirror));
    b.set_camera(scenes::furnace_camera(Vec3::new(0.1, -0.2, -0.6), 0.0));
    b.set_camera_medium(Some(haze));
    b.build().unwrap()
}

/// Level 2 values a lens side chain's start from the level-1 path's
/// vertices (`LensTarget::evaluate_path`: the stored medium vertices, the
/// transmittance of the stored segments, σ_s of the stored medium); every
/// candidate is valued by a retrace (`media::lens_value`: x′_t at the kept
/// distance along the retraced ray, its medium found by crossing the null
/// boundaries). The two must agree on the level-1 path itself, for medium
/// vertices at x_t and at x_{t+1}, through the mirror and through the
/// ball's null boundary; a missing or doubled factor (σ_s, a phase value,
/// a transmittance), a wrong distance or a medium tracked wrongly in
/// either would make them differ. The negative control: the same
/// comparison with the retrace's free-flight distance moved by 10 %
/// disagrees on almost every path with a medium x_t. Caustic paths get
/// the same comparison ([`caustic_agrees`]); multi-chain paths, rare
/// here, must at least retrace to a positive value.
#[test]
fn perturbation_starts_through_media_equal_their_retraces() {
    let scene = fog_box();
    let tris: Vec<_> = scene.triangles().collect();
    let accel = Bvh::build(&tris);
    let mut tracer = Tracer::new(&scene, &accel);
    let s = Settings {
        max_depth: Some(8),
        ..Settings::default()
    };
    let mut ws = PathStorage::with_capacity(8);
    let mut path = Vec::new();
    let (mut compared, mut agree, mut control_agree) = (0u32, 0u32, 0u32);
    let (mut caustic, mut multi) = (Tally::default(), Tally::default());
    let (mut medium_t, mut medium_next, mut mirror, mut inner) = (0u32, 0u32, 0u32, 0u32);
    for i in 0..120_000u64 {
        let depth = 1 + (i % 5) as usize;
        let mut rng = SampleStream::new(5, depth as u64, i);
        let st = sample_strategy(&mut tracer, &s, &mut ws, depth, &mut rng);
        if st.l.is_black() || !strategy_path(&ws, &mut path) {
            continue;
        }
        let mut class = classify(&tracer, &path);
        if !class.complete_media(&mut tracer, &path) {
            continue;
        }
        let anchor = match class {
            Applicable::Lens(anchor) => anchor,
            Applicable::Caustic(anchor) => {
                caustic.add(caustic_agrees(&mut tracer, &anchor, &path), &path, 1);
                continue;
            }
            Applicable::MultiChain(anchor) => {
                let t = anchor.first.len() + 1;
                multi.add(multi_chain_positive(&mut tracer, &anchor, &path), &path, t);
                continue;
            }
            Applicable::Neither => continue,
        };
        let media = anchor.media.expect("a scene with media");
        let camera = tracer.camera;
        let Some((_, raster)) =
            camera.importance(anchor.p_lens, (path[1].sp.p - anchor.p_lens).normalize())
        else {
            continue;
        };
        let mut target = LensTarget {
            tracer: &mut tracer,
            anchor: &anchor,
        };
        let stored = target
            .evaluate_path(&path, raster)
            .expect("the path fits its own anchor")
            .value;
        let mut one = [Some(LensState {
            raster,
            value: Rgb::ZERO,
        })];
        let mut p = [0.0f32];
        target.evaluate(&mut one, &mut p);
        let traced = one[0].unwrap().value;
        let t = anchor.chain.len() + 1;
        compared += 1;
        mirror += (t > 1) as u32;
        if path[t].is_medium() {
            medium_t += 1;
            inner += (path[t].sp.prim == 1) as u32;
            let mut moved = media;
            moved.scatter_at = moved.scatter_at.map(|s| 1.1 * s);
            let control = lens_value(&mut tracer, &anchor, &moved, raster);
            control_agree += close(stored, control) as u32;
        }
        if let LensEnd::Connect { next, .. } = &anchor.end {
            medium_next += next.is_medium() as u32;
        }
        if close(stored, traced) {
            agree += 1;
        } else if compared - agree <= 5 {
            eprintln!("sample {i}: stored {stored:?} vs retraced {traced:?}");
        }
    }
    eprintln!(
        "{agree} of {compared} agree ({medium_t} with a medium x_t, {inner} of them in the ball, \
         {medium_next} with a medium x_t+1, {mirror} through the mirror); \
         control: {control_agree} of {medium_t}"
    );
    assert!(
        compared > 20_000
            && medium_t > 10_000
            && medium_next > 5_000
            && mirror > 1_000
            && inner > 1_000,
        "{compared} {medium_t} {medium_next} {mirror} {inner}"
    );
    // Retracing may land on another triangle or miss at an edge (rounding);
    // anything else is a wrong factor in one of the two.
    assert!(
        agree as f64 >= 0.999 * compared as f64,
        "{agree} of {compared}"
    );
    assert!(
        (control_agree as f64) < 0.05 * medium_t as f64,
        "{control_agree} of {medium_t}"
    );
    eprintln!("caustic: {caustic:?}; multi-chain: {multi:?}");
    // Multi-chain paths (E S D S …) are rare here: a few dozen.
    for (name, c, min) in [("caustic", caustic, 500), ("multi-chain", multi, 20)] {
        assert!(c.seen > min && c.medium > min / 4, "{name}: {c:?}");
        assert!(c.ok as f64 >= 0.99 * c.seen as f64, "{name}: {c:?}");
    }
}

/// Paths of one class: how many, how many with a medium vertex at the
/// end of the moving chain, how many passed the check.
#[derive(Clone, Copy, Debug, Default)]
struct Tally {
    seen: u32,
    medium: u32,
    ok: u32,
}

impl Tally {
    fn add(&mut self, ok: bool, path: &[PathVertex], i: usize) {
        self.seen += 1;
        self.medium += path[i].is_medium() as u32;
        self.ok += ok as u32;
    }
}

/// The caustic target of the level-1 path's own direction at x_j, retraced
/// (`media::caustic_value`: x′₁ at the kept distance, the media tracked by
/// the retrace), against the same product evaluated from the stored
/// vertices with the transmittance [`walk_media`] measures along the
/// stored segments: x_j's factor, the tail, the specular lobes in
/// importance transport (with the shading correction), every segment's
/// transmittance, σ_s and the phase function at a medium x₁, and the lens
/// connection. They must land on the same pixel with the same value.
fn caustic_agrees<I: crate::accel::Intersector>(
    tr: &mut Tracer<'_, I>,
    a: &CausticAnchor,
    path: &[PathVertex],
) -> bool {
    let media = a.media.expect("completed");
    let j = a.chain.len() + 2;
    let dir = (a.toward - a.origin.sp.p).normalize();
    let Some((traced, raster)) = caustic_value(tr, a, &media, dir) else {
        return false;
    };
    let mut trans = Rgb::ONE;
    if !walk_media(
        tr,
        path,
        |i, t| {
            if i < j {
                trans *= t
            }
        },
        |_, _| {},
    ) {
        return false;
    }
    let scene = tr.scene;
    let o = &path[j];
    let f_j = if o.is_medium() {
        medium_factor(tr, o, path[j + 1].sp.p, path[j - 1].sp.p)
    } else if j == path.len() - 1 {
        scene.emitted(&o.sp, dir) * o.sp.ng.dot(dir).abs()
    } else {
        let sh = o.shading.unwrap();
        scatter(
            &sh,
            path[j + 1].sp.p,
            path[j - 1].sp.p,
            TransportMode::Importance,
        ) * o.sp.ns.dot(dir).abs()
    };
    let mut beta = f_j * a.tail * trans;
    for i in (2..j).rev() {
        let sh = path[i].shading.unwrap();
        let wo = (path[i + 1].sp.p - path[i].sp.p).normalize();
        let wi = (path[i - 1].sp.p - path[i].sp.p).normalize();
        let Some((_, w)) = sh.bsdf.specular(
            sh.frame.to_local(wo),
            is_reflection(path, i),
            TransportMode::Importance,
        ) else {
            return false;
        };
        beta *= w * shading_correction(&sh.sp, wo, wi);
    }
    let x1 = &path[1];
    let Some(conn) = tr.camera.connect_at(x1.sp.p, a.p_lens) else {
        return false;
    };
    let to_cam = conn.p_lens - x1.sp.p;
    let d2 = to_cam.length_squared();
    let w = to_cam / d2.sqrt();
    let (f1, cos1) = if x1.is_medium() {
        (medium_factor(tr, x1, path[2].sp.p, conn.p_lens), 1.0)
    } else {
        let sh = x1.shading.unwrap();
        (
            scatter(&sh, path[2].sp.p, conn.p_lens, TransportMode::Importance),
            x1.sp.ns.dot(w).abs(),
        )
    };
    let stored = beta * f1 * (cos1 * conn.we * conn.cos_theta / (d2 * conn.pdf_lens_area));
    (raster - conn.raster).length() < 1e-2 && close(stored, traced)
}

/// The multi-chain target of the level-1 path's own raster position and
/// direction at x_t, retraced through both chains: positive (the retrace
/// reproduces the path, medium vertices at their kept distances).
fn multi_chain_positive<I: crate::accel::Intersector>(
    tr: &mut Tracer<'_, I>,
    a: &MultiChainAnchor,
    path: &[PathVertex],
) -> bool {
    let media = a.media.expect("completed");
    let t = a.first.len() + 1;
    let Some((_, raster)) = tr
        .camera
        .importance(a.p_lens, (path[1].sp.p - a.p_lens).normalize())
    else {
        return false;
    };
    let dir = (path[t + 1].sp.p - path[t].sp.p).normalize();
    multi_chain_value(tr, a, &media, raster, dir).luminance() > 0.0
}

/// Every channel within 10⁻³ of the larger luminance, which is positive.
fn close(a: Rgb, b: Rgb) -> bool {
    let scale = a.luminance().max(b.luminance());
    scale > 0.0 && (0..3).all(|c| (a[c] - b[c]).abs() <= 1e-3 * scale)
}
