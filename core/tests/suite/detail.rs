//! Surface detail (`cmlt::scene::detail`): normal maps, bump maps and alpha
//! masks, checked against what they stand for: a flat normal map is no
//! normal map, a constant tilted one is a tilted shading normal, a height
//! ramp tilts the normal by its slope's angle, a mask of opacity 0 is an
//! absent surface and of opacity 1 an unmasked one (for camera rays and
//! shadows alike), and a fractional opacity lets that fraction through.

use crate::common;

use cmlt::accel::bvh::Bvh;
use cmlt::geometry::Ray;
use cmlt::integrator::Tracer;
use cmlt::math::{Rgb, Vec2, Vec3};
use cmlt::renderer::{Estimator, RenderWorker, Renderer, RendererConfig};
use cmlt::scene::{
    Bitmap, Detail, Effect, Material, MaterialId, Mesh, Scene, SceneBuilder, Texture,
};

/// The quad `centre ± u ± v` (front normal along u × v), uv (0,0) at
/// `centre − u − v` and (1,1) at `centre + u + v`.
fn quad(centre: Vec3, u: Vec3, v: Vec3, material: MaterialId, emission: Option<Rgb>) -> Mesh {
    Mesh {
        positions: vec![
            centre - u - v,
            centre + u - v,
            centre + u + v,
            centre - u + v,
        ],
        normals: vec![],
        uvs: vec![
            Vec2::new(0.0, 0.0),
            Vec2::new(1.0, 0.0),
            Vec2::new(1.0, 1.0),
            Vec2::new(0.0, 1.0),
        ],
        indices: vec![[0, 1, 2], [0, 2, 3]],
        material,
        emission,
    }
}

fn with_detail(albedo: f32, two_sided: bool, detail: Detail) -> Material {
    Material {
        two_sided,
        detail,
        ..Material::diffuse(Rgb::splat(albedo))
    }
}

/// The furnace camera (looking down +z from the origin) in front of a
/// diffuse wall at z = 2 facing it, lit by a quad light above the camera
/// facing the wall; `subject` is added in between when given.
fn stage(subject: Option<(Mesh, Material)>, bitmaps: Vec<Bitmap>) -> Scene {
    let mut b = SceneBuilder::new();
    for bm in bitmaps {
        b.add_bitmap(bm);
    }
    let wall = b.add_material(with_detail(0.8, false, Detail::NONE));
    let black = b.add_material(Material::diffuse(Rgb::ZERO));
    b.add_mesh(quad(
        Vec3::new(0.0, 0.0, 2.0),
        Vec3::Y * 1.5,
        Vec3::X * 1.5,
        wall,
        None,
    ));
    b.add_mesh(quad(
        Vec3::new(0.0, 0.9, 0.6),
        Vec3::X * 0.3,
        Vec3::Y * 0.3,
        black,
        Some(Rgb::splat(10.0)),
    ));
    if let Some((mut mesh, m)) = subject {
        mesh.material = b.add_material(m);
        b.add_mesh(mesh);
    }
    b.set_camera(common::furnace_camera(Vec3::ZERO, 0.0));
    b.build().unwrap()
}

/// The occluder: a quad between the light and the wall, in view, facing
/// the camera.
fn occluder() -> Mesh {
    quad(
        Vec3::new(0.2, 0.3, 1.3),
        Vec3::Y * 0.35,
        Vec3::X * 0.35,
        MaterialId(0),
        None,
    )
}

fn render(scene: &Scene, estimator: Estimator, spp: u64, seed: u64) -> Vec<Rgb> {
    let bvh = Bvh::build(&scene.triangles().collect::<Vec<_>>());
    let config = RendererConfig {
        estimator,
        seed,
        ..RendererConfig::default()
    };
    let mut r = Renderer::new(config, scene.camera).unwrap();
    let mut w = RenderWorker::new(&r, 0).unwrap();
    common::prepare(&mut r, std::slice::from_mut(&mut w), scene, &bvh);
    let pixels = (scene.camera.width() * scene.camera.height()) as u64;
    r.render(&mut w, scene, &bvh, spp * pixels).unwrap();
    let mut img = vec![Rgb::ZERO; pixels as usize];
    r.resolve(&[&w], |i, c| img[i] = c).unwrap();
    assert_eq!(r.stats(&[&w]).nonfinite, 0);
    img
}

fn mean(img: &[Rgb], pixels: Option<&[usize]>) -> f32 {
    match pixels {
        None => img.iter().map(|c| c.luminance()).sum::<f32>() / img.len() as f32,
        Some(ps) => ps.iter().map(|&i| img[i].luminance()).sum::<f32>() / ps.len() as f32,
    }
}

/// Asserts two images' means (whole image, and over `region`) agree within
/// `tol` relative.
fn assert_same(what: &str, a: &[Rgb], b: &[Rgb], region: &[usize], tol: f32) {
    for (name, px) in [("image", None), ("region", Some(region))] {
        let (ma, mb) = (mean(a, px), mean(b, px));
        assert!(
            (ma - mb).abs() <= tol * ma.max(mb),
            "{what}: {name} mean {ma} vs {mb}"
        );
    }
}

/// The pixels whose whole footprint sees the occluder.
fn occluder_pixels(scene: &Scene) -> Vec<usize> {
    let bvh = Bvh::build(
        &[occluder()]
            .iter()
            .flat_map(|m| {
                m.indices
                    .iter()
                    .map(|t| t.map(|i| m.positions[i as usize]))
                    .collect::<Vec<_>>()
            })
            .collect::<Vec<_>>(),
    );
    let px = common::covered_pixels(&scene.camera, |r| {
        cmlt::accel::Intersector::intersect(&bvh, r).is_some()
    });
    assert!(px.len() >= 10, "the occluder covers {} pixels", px.len());
    px
}

#[test]
fn masks_of_opacity_zero_and_one_are_absent_and_opaque_surfaces() {
    let mask = |o: f32| Detail {
        opacity: Some(Texture::Constant(Rgb::splat(o))),
        ..Detail::NONE
    };
    let absent = stage(None, vec![]);
    let plain = stage(
        Some((occluder(), with_detail(0.1, true, Detail::NONE))),
        vec![],
    );
    let clear = stage(
        Some((occluder(), with_detail(0.1, true, mask(0.0)))),
        vec![],
    );
    let solid = stage(
        Some((occluder(), with_detail(0.1, true, mask(1.0)))),
        vec![],
    );
    assert!(
        clear
            .analysis(&clear.camera)
            .effects
            .contains(Effect::AlphaMasks)
    );
    assert!(
        !plain
            .analysis(&plain.camera)
            .effects
            .contains(Effect::AlphaMasks)
    );
    let region = occluder_pixels(&plain);
    for (estimator, spp) in [(Estimator::Path, 256), (Estimator::Bdpt, 128)] {
        let img = |s: &Scene| render(s, estimator, spp, 5);
        let (a, p, c, s) = (img(&absent), img(&plain), img(&clear), img(&solid));
        // The occluder matters (in view and in the shadow it casts), so
        // the comparisons below can fail.
        assert!(
            (mean(&a, None) - mean(&p, None)).abs() > 0.1 * mean(&a, None),
            "{estimator:?}: the occluder changes the image ({} vs {})",
            mean(&a, None),
            mean(&p, None)
        );
        assert_same(&format!("{estimator:?} opacity 0"), &a, &c, &region, 0.03);
        assert_same(&format!("{estimator:?} opacity 1"), &p, &s, &region, 0.03);
    }
}

#[test]
fn fractional_opacity_lets_that_fraction_of_rays_through() {
    let alpha = 0.3;
    let detail = Detail {
        opacity: Some(Texture::Constant(Rgb::splat(alpha))),
        ..Detail::NONE
    };
    let scene = stage(Some((occluder(), with_detail(0.5, true, detail))), vec![]);
    let bvh = Bvh::build(&scene.triangles().collect::<Vec<_>>());
    let mut t = Tracer::new(&scene, &bvh).with_analysis(scene.analysis(&scene.camera));
    // Rays from spread-out origins through the occluder's centre region
    // towards the wall: each stops at the occluder with probability α
    // (closest hit) and is blocked with probability α (occlusion).
    let n = 40_000;
    let (mut stopped, mut blocked) = (0u32, 0u32);
    for i in 0..n {
        let a = i as f32 * 0.618_034;
        let o = Vec3::new(
            0.2 + 0.1 * a.sin(),
            0.3 + 0.1 * a.cos(),
            0.1 + (i % 101) as f32 * 1e-3,
        );
        let target = Vec3::new(
            0.2 + 0.05 * (a * 1.7).cos(),
            0.3 + 0.05 * (a * 2.3).sin(),
            2.0,
        );
        let d = target - o;
        let sh = t.trace(&Ray::new(o, d)).expect("the wall is behind");
        stopped += (sh.sp.p.z < 1.5) as u32;
        let seg = Ray {
            t_max: 0.99,
            ..Ray::new(o, d)
        };
        blocked += t.occluded_segment(Some(cmlt::geometry::offset::SegmentRays {
            main: seg,
            tail: None,
        })) as u32;
    }
    // Binomial σ ≈ 0.0023; 5σ.
    for (what, k) in [("closest hit", stopped), ("occlusion", blocked)] {
        let rate = k as f64 / n as f64;
        assert!(
            (rate - alpha as f64).abs() < 0.012,
            "{what}: stopped {rate}, opacity {alpha}"
        );
    }
}

/// The shading at the centre of the subject quad, seen from the camera.
fn shade_centre(scene: &Scene, centre: Vec3) -> cmlt::integrator::tracer::Shading {
    let bvh = Bvh::build(&scene.triangles().collect::<Vec<_>>());
    let mut t = Tracer::new(scene, &bvh).with_analysis(scene.analysis(&scene.camera));
    let sh = t.trace(&Ray::new(Vec3::ZERO, centre)).unwrap();
    assert!((sh.sp.p - centre).length() < 1e-3, "hit the subject");
    sh
}

#[test]
fn flat_and_tilted_normal_maps_are_shading_normals() {
    let centre = Vec3::new(0.1, -0.2, 1.2);
    // Faces the camera: u along +y, v along +x (normal −z).
    let (u, v) = (Vec3::Y * 0.4, Vec3::X * 0.4);
    let subject = |detail: Detail, normals: Vec<Vec3>| {
        let mut m = quad(centre, u, v, MaterialId(0), None);
        m.normals = normals;
        (m, with_detail(0.9, false, detail))
    };
    let nmap = |c: Vec3| Detail {
        normal_map: Some(Texture::Constant(Rgb::new(c.x, c.y, c.z))),
        ..Detail::NONE
    };
    // Flat: (0.5, 0.5, 1) keeps the normal.
    let flat = stage(
        Some(subject(nmap(Vec3::new(0.5, 0.5, 1.0)), vec![])),
        vec![],
    );
    let none = stage(Some(subject(Detail::NONE, vec![])), vec![]);
    assert!(
        flat.analysis(&flat.camera)
            .effects
            .contains(Effect::NormalMapping)
    );
    let (a, b) = (shade_centre(&flat, centre), shade_centre(&none, centre));
    assert!((a.sp.ns - b.sp.ns).length() < 1e-5 && (a.frame.n - b.frame.n).length() < 1e-5);
    // Tilted 25° towards the u tangent (∂p/∂u = 2u: +y): the tangent-space
    // normal (sin θ, 0, cos θ) is the world normal cos θ·n + sin θ·ŷ.
    let th = 25f32.to_radians();
    let ts = Vec3::new(th.sin(), 0.0, th.cos());
    let tilted = stage(Some(subject(nmap((ts + Vec3::ONE) * 0.5), vec![])), vec![]);
    let n = -Vec3::Z;
    let want = (n * th.cos() + Vec3::Y * th.sin()).normalize();
    let s = shade_centre(&tilted, centre);
    assert!((s.sp.ns - want).length() < 1e-2, "{} vs {want}", s.sp.ns);
    assert!((s.frame.n - s.sp.ns).length() < 1e-6);
    // The same tilt as interpolated vertex normals renders the same image,
    // and differs from the untilted one.
    let by_normals = stage(Some(subject(Detail::NONE, vec![want; 4])), vec![]);
    let region = common::covered_pixels(&none.camera, |r| {
        let d = r.d.normalize();
        let p = r.o + d * ((centre.z - r.o.z) / d.z);
        (p - centre).abs().max_element() < 0.38
    });
    for (estimator, spp) in [(Estimator::Path, 256), (Estimator::Bdpt, 128)] {
        let img_map = render(&tilted, estimator, spp, 11);
        let img_normals = render(&by_normals, estimator, spp, 12);
        let img_flat_map = render(&flat, estimator, spp, 13);
        let img_none = render(&none, estimator, spp, 14);
        assert_same(
            &format!("{estimator:?} tilted map vs normals"),
            &img_map,
            &img_normals,
            &region,
            0.03,
        );
        assert_same(
            &format!("{estimator:?} flat map vs none"),
            &img_flat_map,
            &img_none,
            &region,
            0.03,
        );
        let (m_tilt, m_flat) = (
            mean(&img_map, Some(&region)),
            mean(&img_none, Some(&region)),
        );
        assert!(
            (m_tilt - m_flat).abs() > 0.05 * m_flat,
            "{estimator:?}: the tilt changes the subject ({m_tilt} vs {m_flat})"
        );
    }
}

#[test]
fn a_linear_height_ramp_tilts_the_bump_normal_by_its_slope() {
    let centre = Vec3::new(0.1, -0.2, 1.2);
    let half = 0.4;
    // A ramp of 8 texels rising by `step` each: slope 8·step per unit u
    // (inside the ramp, away from the repeat seam).
    let step = 0.05;
    let ramp = Bitmap::new(8, 1, (0..8).map(|i| Rgb::splat(i as f32 * step)).collect()).unwrap();
    let scale = 0.5;
    let detail = Detail {
        bump_map: Some(Texture::Bitmap {
            id: cmlt::scene::BitmapId(0),
            to_uv: glam::Affine2::IDENTITY,
        }),
        bump_scale: scale,
        ..Detail::NONE
    };
    let mesh = quad(centre, Vec3::Y * half, Vec3::X * half, MaterialId(0), None);
    let scene = stage(Some((mesh, with_detail(0.9, false, detail))), vec![ramp]);
    let s = shade_centre(&scene, centre);
    // |∂p/∂u| = 2·half; the height rises by scale·8·step per unit u, so the
    // surface tilts by atan(scale·8·step / (2·half)), away from +u (+y).
    let want = (scale * 8.0 * step / (2.0 * half)).atan();
    let got = s.sp.ns.dot(-Vec3::Z).clamp(-1.0, 1.0).acos();
    assert!((got - want).abs() < 1e-3, "tilt {got} rad, expected {want}");
    assert!(s.sp.ns.y < 0.0 && s.sp.ns.x.abs() < 1e-5, "{}", s.sp.ns);
}
