//! What a host reads out per frame: `Renderer::resolve_rows` in every
//! pixel format (the values `resolve` gives, bit for bit, for any split of
//! the rows) and the auxiliary outputs of `cmlt::aov` with exact answers on
//! analytic scenes (a wall at a known depth and albedo, a camera moved by a
//! known amount, a mesh moved by `update_mesh`); all of it allocates
//! nothing.

use crate::common;
use crate::renderer::allocations;

use cmlt::accel::bvh::Bvh;
use cmlt::aov::{self, AovBuffers, AovFormat, AovLayer};
use cmlt::film::PixelFormat;
use cmlt::integrator::Settings;
use cmlt::math::spectrum::linear_to_srgb;
use cmlt::math::{Mat4, Rgb, Vec3};
use cmlt::renderer::{Estimator, RenderError, RenderWorker, Renderer, RendererConfig};
use cmlt::scene::{Camera, FovAxis, Material, Mesh, Scene, SceneBuilder};

/// Image size of every test here.
const W: u32 = 16;
const H: u32 = 12;
/// How close a motion vector comes to the analytic one, in pixels: the
/// hit point carries the rounding of the ray's intersection (measured
/// 1.6·10⁻⁴ px at this image's corners), far below a half float's
/// resolution at a pixel (4.9·10⁻⁴).
const TOL: f32 = 1e-3;
/// The wall's depth and albedo.
const DEPTH: f32 = 4.0;
const ALBEDO: Rgb = Rgb {
    r: 0.25,
    g: 0.5,
    b: 0.75,
};

/// A pinhole at `at` looking down +z with a 90° horizontal field of view
/// (tan of the half angle 1): camera x is world +x, the image's left.
fn camera(at: Vec3) -> Camera {
    Camera::perspective(Mat4::from_translation(at), 90.0, FovAxis::X, W, H, 0.0, 1.0).unwrap()
}

/// A square at z = `DEPTH` facing the camera, `half` wide either way.
fn wall(half: f32, material: cmlt::scene::MaterialId) -> Mesh {
    Mesh {
        positions: vec![
            Vec3::new(-half, -half, DEPTH),
            Vec3::new(half, -half, DEPTH),
            Vec3::new(half, half, DEPTH),
            Vec3::new(-half, half, DEPTH),
        ],
        normals: vec![],
        uvs: vec![],
        indices: vec![[0, 1, 2], [0, 2, 3]],
        material,
        emission: None,
    }
}

/// The wall (mesh 0, diffuse of albedo `ALBEDO`, `half` wide either way)
/// lit by a small emitter behind the camera facing it (mesh 1), and the
/// camera at the origin.
fn wall_scene(half: f32) -> Scene {
    let mut b = SceneBuilder::new();
    let m = b.add_material(Material::diffuse(ALBEDO));
    b.add_mesh(wall(half, m));
    let mut light = wall(0.2, m);
    for p in &mut light.positions {
        p.z = -1.0;
    }
    light.emission = Some(Rgb::splat(5.0));
    b.add_mesh(light);
    b.set_camera(camera(Vec3::ZERO));
    b.build().unwrap()
}

/// Every output of rows `rows` as f32 (albedo, normal, depth, motion).
type Outputs = (Vec<f32>, Vec<f32>, Vec<f32>, Vec<f32>);

fn floats(b: &[u8]) -> Vec<f32> {
    b.chunks_exact(4)
        .map(|c| f32::from_ne_bytes(c.try_into().unwrap()))
        .collect()
}

/// The four outputs of rows `rows` in `format`, as raw bytes.
fn aov_bytes(
    scene: &Scene,
    bvh: &Bvh,
    camera: &Camera,
    previous: &Camera,
    rows: std::ops::Range<u32>,
    format: AovFormat,
) -> [Vec<u8>; 4] {
    let n = rows.len() * W as usize * format.bytes();
    let mut bytes = [vec![0; 3 * n], vec![0; 3 * n], vec![0; n], vec![0; 2 * n]];
    let [a, nn, d, m] = &mut bytes;
    let mut out = AovBuffers {
        albedo: Some(AovLayer::packed(a, format)),
        normal: Some(AovLayer::packed(nn, format)),
        depth: Some(AovLayer::packed(d, format)),
        motion: Some(AovLayer::packed(m, format)),
    };
    aov::render_rows(scene, bvh, camera, previous, rows, &mut out).unwrap();
    bytes
}

fn aovs(scene: &Scene, bvh: &Bvh, camera: &Camera, previous: &Camera) -> Outputs {
    let [a, n, d, m] = aov_bytes(scene, bvh, camera, previous, 0..H, AovFormat::F32);
    (floats(&a), floats(&n), floats(&d), floats(&m))
}

fn close(a: f32, b: f32, tol: f32) -> bool {
    (a - b).abs() <= tol * b.abs().max(1.0)
}

#[test]
fn a_wall_gives_its_depth_normal_and_albedo() {
    let scene = wall_scene(20.0);
    let bvh = Bvh::build(&scene.triangles().collect::<Vec<_>>());
    let cam = camera(Vec3::ZERO);
    let (albedo, normal, depth, motion) = aovs(&scene, &bvh, &cam, &cam);
    for i in 0..(W * H) as usize {
        // Depth is camera-space z: the wall's z for every pixel, not the
        // distance along the ray (up to 8 at the corners here).
        assert!(close(depth[i], DEPTH, 4e-7), "depth {}", depth[i]);
        // The face normal of an axis-aligned square is exact, and faces
        // the camera.
        assert_eq!(&normal[3 * i..3 * i + 3], &[0.0, 0.0, -1.0]);
        // Lambertian: every cosine-weighted sample weighs the albedo.
        for (c, want) in albedo[3 * i..3 * i + 3].iter().zip([0.25, 0.5, 0.75]) {
            assert!(close(*c, want, 1e-6), "albedo {c} for {want}");
        }
        // A still camera: the point projects back onto its pixel's centre.
        assert!(motion[2 * i].abs() < TOL && motion[2 * i + 1].abs() < TOL);
    }
}

/// A one-sided Lambertian wall has its albedo on its front only, as its
/// BSDF scatters (a triangle shaded once for all its pixels keeps that):
/// of the wall and the same wall wound the other way, exactly one is
/// black in albedo everywhere, and both give the normal facing the camera.
#[test]
fn a_one_sided_wall_has_its_albedo_on_its_front_only() {
    let mut lit = Vec::new();
    for flip in [false, true] {
        let mut b = SceneBuilder::new();
        let m = b.add_material(Material {
            two_sided: false,
            ..Material::diffuse(ALBEDO)
        });
        let mut w = wall(20.0, m);
        if flip {
            for t in &mut w.indices {
                t.swap(1, 2);
            }
        }
        b.add_mesh(w);
        let mut light = wall(0.2, b.add_material(Material::diffuse(ALBEDO)));
        for p in &mut light.positions {
            p.z = -1.0;
        }
        light.emission = Some(Rgb::splat(5.0));
        b.add_mesh(light);
        b.set_camera(camera(Vec3::ZERO));
        let scene = b.build().unwrap();
        let bvh = Bvh::build(&scene.triangles().collect::<Vec<_>>());
        let cam = camera(Vec3::ZERO);
        let (albedo, normal, _, _) = aovs(&scene, &bvh, &cam, &cam);
        for n in normal.chunks_exact(3) {
            assert_eq!(n, &[0.0, 0.0, -1.0]);
        }
        let front = albedo.chunks_exact(3).filter(|a| a[0] > 0.0).count();
        for a in albedo.chunks_exact(3).filter(|a| a[0] > 0.0) {
            assert!(close(a[1], 0.5, 1e-6), "albedo {a:?}");
        }
        lit.push(front);
    }
    lit.sort();
    assert_eq!(lit, vec![0, (W * H) as usize], "pixels with albedo");
}

#[test]
fn rays_that_leave_the_scene_get_no_surface() {
    // A wall 1 wide at depth 4 covers the middle 2 × 2 pixels' centres
    // (pixel centres at ±0.5, ±1.5 … px of 0.5 per unit at depth 4: x =
    // ±0.25, ±0.75, …); the others miss.
    let scene = wall_scene(0.5);
    let bvh = Bvh::build(&scene.triangles().collect::<Vec<_>>());
    let cam = camera(Vec3::ZERO);
    let (albedo, normal, depth, _) = aovs(&scene, &bvh, &cam, &cam);
    let hit = |x: u32, y: u32| (7..=8).contains(&x) && (5..=6).contains(&y);
    for y in 0..H {
        for x in 0..W {
            let i = (y * W + x) as usize;
            if hit(x, y) {
                assert!(close(depth[i], DEPTH, 4e-7));
            } else {
                assert_eq!(depth[i], f32::INFINITY);
                assert_eq!(&normal[3 * i..3 * i + 3], &[0.0; 3]);
                assert_eq!(&albedo[3 * i..3 * i + 3], &[0.0; 3]);
            }
        }
    }
}

#[test]
fn a_translated_camera_gives_the_analytic_motion() {
    // The camera moved by Δ = 0.5 along its x axis (image-left) since the
    // previous frame: a point at depth Z moved on the image by
    // W/2 · Δ / (Z · tan) = 8 · 0.5 / 4 = 1 pixel to the right, so it was
    // 1 pixel to the left: motion (−1, 0). Moved up by 0.5 (camera y is
    // image-up), the point moved down on the image by H/2 · Δ / (Z · tan_y)
    // = 6 · 0.5 / (4 · 0.75) = 1 pixel: it was 1 pixel higher, motion
    // (0, −1). Moved back by 4 (twice as far), it was halfway to the
    // image centre.
    let scene = wall_scene(20.0);
    let bvh = Bvh::build(&scene.triangles().collect::<Vec<_>>());
    let cam = camera(Vec3::ZERO);
    for (previous, want) in [
        (camera(Vec3::new(-0.5, 0.0, 0.0)), [-1.0, 0.0]),
        (camera(Vec3::new(0.0, -0.5, 0.0)), [0.0, -1.0]),
        (camera(Vec3::new(0.0, 0.0, -4.0)), [f32::NAN, f32::NAN]),
    ] {
        let (_, _, _, motion) = aovs(&scene, &bvh, &cam, &previous);
        for y in 0..H {
            for x in 0..W {
                let i = (y * W + x) as usize;
                let m = [motion[2 * i], motion[2 * i + 1]];
                let want = if want[0].is_nan() {
                    // Twice as far: halfway to the centre (8, 6).
                    [
                        (8.0 - (x as f32 + 0.5)) / 2.0,
                        (6.0 - (y as f32 + 0.5)) / 2.0,
                    ]
                } else {
                    want
                };
                assert!(
                    (m[0] - want[0]).abs() < TOL && (m[1] - want[1]).abs() < TOL,
                    "pixel ({x}, {y}): {m:?}, want {want:?}"
                );
            }
        }
    }
}

#[test]
fn a_mesh_moved_by_update_mesh_gives_its_motion() {
    let mut scene = wall_scene(20.0);
    let mut bvh = Bvh::build(&scene.triangles().collect::<Vec<_>>());
    let cam = camera(Vec3::ZERO);
    let moved: Vec<Vec3> = scene.meshes[0]
        .positions
        .iter()
        .map(|p| *p + Vec3::new(0.5, 0.0, 0.0))
        .collect();
    scene.begin_frame();
    let (_, n) = allocations(|| scene.update_mesh(0, &moved, None).unwrap());
    assert_eq!(n, 0, "update_mesh allocated");
    bvh.refit(|t| scene.triangle(t));
    // The wall moved 0.5 along +x (image-left) at depth 4: a point now at
    // the pixel's centre was 1 pixel to its right.
    let (_, _, depth, motion) = aovs(&scene, &bvh, &cam, &cam);
    for i in 0..(W * H) as usize {
        assert!(close(depth[i], DEPTH, 4e-7));
        assert!(
            (motion[2 * i] - 1.0).abs() < TOL && motion[2 * i + 1].abs() < TOL,
            "{:?}",
            &motion[2 * i..2 * i + 2]
        );
    }
    // A second update in the same frame moves it from the frame's start.
    let further: Vec<Vec3> = moved
        .iter()
        .map(|p| *p + Vec3::new(0.5, 0.0, 0.0))
        .collect();
    scene.update_mesh(0, &further, None).unwrap();
    bvh.refit(|t| scene.triangle(t));
    let (_, _, _, motion) = aovs(&scene, &bvh, &cam, &cam);
    assert!(motion.chunks(2).all(|m| (m[0] - 2.0).abs() < TOL));
    // The next frame, not updated, has not moved; a moving camera still
    // gives its own motion.
    scene.begin_frame();
    let (_, _, _, motion) = aovs(&scene, &bvh, &cam, &cam);
    assert!(motion.iter().all(|m| m.abs() < TOL));
}

#[test]
fn aov_rows_split_anyhow_give_the_same_bytes_and_halves_round_the_floats() {
    let scene = wall_scene(1.5);
    let bvh = Bvh::build(&scene.triangles().collect::<Vec<_>>());
    let cam = camera(Vec3::ZERO);
    let previous = camera(Vec3::new(0.1, 0.2, -0.3));
    for format in [AovFormat::F32, AovFormat::F16] {
        let whole = aov_bytes(&scene, &bvh, &cam, &previous, 0..H, format);
        for split in [
            vec![0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12],
            vec![0, 5, 12],
            vec![0, 0, 11, 12],
        ] {
            let mut joined: [Vec<u8>; 4] = Default::default();
            for band in split.windows(2) {
                let part = aov_bytes(&scene, &bvh, &cam, &previous, band[0]..band[1], format);
                for (j, p) in joined.iter_mut().zip(part) {
                    j.extend(p);
                }
            }
            assert_eq!(joined, whole, "{format:?} split {split:?}");
        }
    }
    let f = aov_bytes(&scene, &bvh, &cam, &previous, 0..H, AovFormat::F32);
    let h = aov_bytes(&scene, &bvh, &cam, &previous, 0..H, AovFormat::F16);
    for (f, h) in f.iter().zip(&h) {
        for (v, b) in floats(f).iter().zip(h.chunks_exact(2)) {
            let want = half::f16::from_f32(*v).to_bits();
            assert_eq!(u16::from_ne_bytes([b[0], b[1]]), want);
        }
    }
}

#[test]
fn depth_and_motion_alone_equal_their_values_among_all_outputs() {
    // Without albedo and normal the hit points are traced without their
    // BSDFs; the points, and so depth and motion, are the same.
    let scene = wall_scene(1.5);
    let bvh = Bvh::build(&scene.triangles().collect::<Vec<_>>());
    let cam = camera(Vec3::ZERO);
    let previous = camera(Vec3::new(0.1, 0.2, -0.3));
    let [_, _, depth, motion] = aov_bytes(&scene, &bvh, &cam, &previous, 0..H, AovFormat::F32);
    let n = (W * H) as usize * 4;
    let (mut d, mut m) = (vec![0u8; n], vec![0u8; 2 * n]);
    let mut out = AovBuffers {
        depth: Some(AovLayer::packed(&mut d, AovFormat::F32)),
        motion: Some(AovLayer::packed(&mut m, AovFormat::F32)),
        ..AovBuffers::default()
    };
    aov::render_rows(&scene, &bvh, &cam, &previous, 0..H, &mut out).unwrap();
    assert_eq!((d, m), (depth, motion));
}

#[test]
fn masked_scenes_see_through_transparent_surfaces_and_move_with_them() {
    // A masked square at depth 2 in front of the wall: of opacity 0 the
    // outputs see the wall (depth 4), of opacity 1 the square (depth 2,
    // its own motion when moved: 0.25 along +x at depth 2 is 1 pixel).
    for (opacity, depth_seen) in [(0.0, DEPTH), (1.0, 2.0)] {
        let mut b = SceneBuilder::new();
        let m = b.add_material(Material::diffuse(ALBEDO));
        let masked = b.add_material(Material {
            detail: cmlt::scene::Detail {
                opacity: Some(cmlt::scene::Texture::Constant(Rgb::splat(opacity))),
                ..Default::default()
            },
            ..Material::diffuse(ALBEDO)
        });
        b.add_mesh(wall(20.0, m));
        let mut front = wall(20.0, masked);
        for p in &mut front.positions {
            p.z = 2.0;
        }
        b.add_mesh(front);
        b.set_camera(camera(Vec3::ZERO));
        let mut scene = b.build().unwrap();
        let mut bvh = Bvh::build(&scene.triangles().collect::<Vec<_>>());
        let cam = camera(Vec3::ZERO);
        scene.begin_frame();
        let moved: Vec<Vec3> = scene.meshes[1]
            .positions
            .iter()
            .map(|p| *p + Vec3::new(0.25, 0.0, 0.0))
            .collect();
        scene.update_mesh(1, &moved, None).unwrap();
        bvh.refit(|t| scene.triangle(t));
        let (albedo, _, depth, motion) = aovs(&scene, &bvh, &cam, &cam);
        let want_motion = if opacity > 0.5 { 1.0 } else { 0.0 };
        for i in 0..(W * H) as usize {
            assert!(close(depth[i], depth_seen, 4e-7), "{}", depth[i]);
            assert!(close(albedo[3 * i], 0.25, 1e-6));
            assert!(
                (motion[2 * i] - want_motion).abs() < TOL && motion[2 * i + 1].abs() < TOL,
                "opacity {opacity}: {:?}",
                &motion[2 * i..2 * i + 2]
            );
        }
    }
}

/// A null boundary (an index-matched surface that only changes the
/// medium) is invisible in the image, so the outputs see through it: a
/// null square at depth 2 holding a fog before the wall gives the wall's
/// depth, normal and albedo; the same square diffuse (the control) gives
/// its own depth.
#[test]
#[cfg(feature = "media")]
fn null_boundaries_are_seen_through() {
    use cmlt::scene::{Medium, MediumInterface, Phase};
    for (null, depth_seen) in [(true, DEPTH), (false, 2.0)] {
        let mut b = SceneBuilder::new();
        let m = b.add_material(Material::diffuse(ALBEDO));
        let boundary = if null {
            b.add_material(Material {
                kind: cmlt::scene::MaterialKind::Null,
                ..Material::diffuse(Rgb::ZERO)
            })
        } else {
            b.add_material(Material::diffuse(Rgb::splat(0.9)))
        };
        b.add_mesh(wall(20.0, m));
        let mut front = wall(20.0, boundary);
        for p in &mut front.positions {
            p.z = 2.0;
        }
        let front = b.add_mesh(front);
        let fog = b.add_medium(
            Medium::homogeneous(Rgb::splat(0.5), Rgb::splat(0.8), 1.0, Phase::Isotropic).unwrap(),
        );
        b.set_mesh_media(
            front,
            MediumInterface {
                interior: Some(fog),
                exterior: None,
            },
        );
        b.set_camera(camera(Vec3::ZERO));
        let scene = b.build().unwrap();
        let bvh = Bvh::build(&scene.triangles().collect::<Vec<_>>());
        let cam = camera(Vec3::ZERO);
        let (albedo, normal, depth, _) = aovs(&scene, &bvh, &cam, &cam);
        let want_albedo = if null { 0.25 } else { 0.9 };
        for i in 0..(W * H) as usize {
            assert!(
                close(depth[i], depth_seen, 4e-7),
                "null {null}: depth {}",
                depth[i]
            );
            assert!(
                close(albedo[3 * i], want_albedo, 1e-6),
                "null {null}: albedo {}",
                albedo[3 * i]
            );
            assert_eq!(&normal[3 * i..3 * i + 3], &[0.0, 0.0, -1.0]);
        }
    }
}

#[test]
fn bad_aov_calls_are_refused_and_write_nothing() {
    let scene = wall_scene(20.0);
    let bvh = Bvh::build(&scene.triangles().collect::<Vec<_>>());
    let cam = camera(Vec3::ZERO);
    let mut depth = vec![7u8; (W * H) as usize * 4];
    let other = Camera::perspective(Mat4::IDENTITY, 90.0, FovAxis::X, W + 1, H, 0.0, 1.0).unwrap();
    let cases: [(&Camera, std::ops::Range<u32>, usize, RenderError); 4] = [
        (
            &cam,
            0..H + 1,
            0,
            RenderError::Output("the rows leave the image"),
        ),
        (
            &cam,
            0..H,
            0,
            RenderError::Output("the buffer is shorter than the rows need"),
        ),
        (
            &cam,
            0..1,
            4 * W as usize - 1,
            RenderError::Output("the row stride is shorter than a row"),
        ),
        (&other, 0..H, 0, RenderError::Resolution),
    ];
    for (i, (previous, rows, stride, want)) in cases.into_iter().enumerate() {
        // Case 1 has one byte too few.
        let len = if i == 1 { depth.len() - 1 } else { depth.len() };
        let mut out = AovBuffers {
            depth: Some(AovLayer {
                data: &mut depth[..len],
                row_stride: stride,
                format: AovFormat::F32,
            }),
            ..AovBuffers::default()
        };
        let got = aov::render_rows(&scene, &bvh, &cam, previous, rows, &mut out);
        assert_eq!(got, Err(want));
        assert!(depth.iter().all(|&b| b == 7), "case {i} wrote");
    }
}

/// A wall scene rendered by two BDPT workers, a few passes each, the
/// first ending inside a pass (three pieces of `render_while`), so that
/// pixels carry different sample weights.
fn rendered() -> (Scene, Renderer, Vec<RenderWorker>) {
    let scene = wall_scene(1.5);
    let bvh = Bvh::build(&scene.triangles().collect::<Vec<_>>());
    let cfg = RendererConfig {
        estimator: Estimator::Bdpt,
        settings: Settings {
            max_depth: Some(4),
            ..Settings::default()
        },
        workers: 2,
        ..RendererConfig::default()
    };
    let mut r = Renderer::new(cfg, scene.camera).unwrap();
    let mut ws: Vec<_> = (0..2).map(|i| RenderWorker::new(&r, i).unwrap()).collect();
    common::prepare(&mut r, &mut ws, &scene, &bvh);
    for (w, passes) in ws.iter_mut().zip([3, 2]) {
        r.render_steps(w, &scene, &bvh, passes).unwrap();
    }
    let mut pieces = 0;
    let done = r
        .render_while(&mut ws[0], &scene, &bvh, 1 << 40, &mut |_| {
            pieces += 1;
            pieces < 3
        })
        .unwrap();
    assert!(
        done > 0 && done < u64::from(W * H),
        "a partial pass: {done}"
    );
    (scene, r, ws)
}

#[test]
fn resolve_rows_writes_resolves_values_in_every_format_for_any_split() {
    let (_scene, r, ws) = rendered();
    let workers: Vec<&RenderWorker> = ws.iter().collect();
    let mut img = vec![Rgb::ZERO; (W * H) as usize];
    r.resolve(&workers, |i, c| img[i] = c).unwrap();
    assert!(
        img.iter().any(|c| c.r > 0.0 && c.r < 1.0),
        "a lit, unsaturated image"
    );
    for format in [
        PixelFormat::Rgb32F,
        PixelFormat::Rgba32F,
        PixelFormat::Rgba16F,
        PixelFormat::Rgba8Srgb,
    ] {
        let px = format.bytes();
        let mut whole = vec![0u8; img.len() * px];
        let (res, n) =
            allocations(|| r.resolve_rows(workers.iter().copied(), 0..H, format, &mut whole, 0));
        res.unwrap();
        assert_eq!(n, 0, "{format:?}: resolve_rows allocated");
        // Each pixel: resolve's value, written as the format says.
        for (c, p) in img.iter().zip(whole.chunks_exact(px)) {
            let want: Vec<u8> = match format {
                PixelFormat::Rgb32F => [c.r, c.g, c.b]
                    .iter()
                    .flat_map(|v| v.to_ne_bytes())
                    .collect(),
                PixelFormat::Rgba32F => [c.r, c.g, c.b, 1.0]
                    .iter()
                    .flat_map(|v| v.to_ne_bytes())
                    .collect(),
                PixelFormat::Rgba16F => [c.r, c.g, c.b, 1.0]
                    .iter()
                    .flat_map(|v| half::f16::from_f32(*v).to_bits().to_ne_bytes())
                    .collect(),
                PixelFormat::Rgba8Srgb => {
                    let e = |v: f32| (linear_to_srgb(v.clamp(0.0, 1.0)) * 255.0 + 0.5) as u8;
                    vec![e(c.r), e(c.g), e(c.b), 255]
                }
            };
            assert_eq!(p, &want[..], "{format:?}");
        }
        // Any split, and a padded stride, give the same pixels.
        for split in [
            vec![0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12],
            vec![0, 7, 12],
            vec![0, 0, 12],
        ] {
            let mut joined = Vec::new();
            for band in split.windows(2) {
                let stride = W as usize * px + 5;
                let rows = (band[1] - band[0]) as usize;
                let mut buf = vec![0xAB; rows * stride];
                r.resolve_rows(
                    workers.iter().copied(),
                    band[0]..band[1],
                    format,
                    &mut buf,
                    stride,
                )
                .unwrap();
                for row in buf.chunks(stride) {
                    assert!(
                        row[W as usize * px..].iter().all(|&b| b == 0xAB),
                        "padding written"
                    );
                    joined.extend_from_slice(&row[..W as usize * px]);
                }
            }
            assert_eq!(joined, whole, "{format:?} split {split:?}");
        }
    }
}

#[test]
#[allow(clippy::reversed_empty_ranges)]
fn bad_resolve_rows_calls_are_refused_and_write_nothing() {
    let (_scene, r, ws) = rendered();
    let f = PixelFormat::Rgba8Srgb;
    let row = W as usize * 4;
    let mut buf = vec![9u8; row * H as usize];
    let len = buf.len();
    for (rows, stride, len, want) in [
        (0..H + 1, 0, len, "the rows leave the image"),
        (5..4, 0, len, "the rows leave the image"),
        (0..H, 0, len - 1, "the buffer is shorter than the rows need"),
        (0..2, row - 1, len, "the row stride is shorter than a row"),
        (
            0..3,
            usize::MAX / 2 + 1,
            len,
            "the rows at this stride overflow the address space",
        ),
    ] {
        assert_eq!(
            r.resolve_rows(&ws, rows, f, &mut buf[..len], stride),
            Err(RenderError::Output(want))
        );
        assert!(buf.iter().all(|&b| b == 9));
    }
    // A worker of another renderer.
    let (_s, other, ows) = rendered();
    let _ = other;
    assert_eq!(
        r.resolve_rows([&ws[0], &ows[1]], 0..H, f, &mut buf, 0),
        Err(RenderError::Worker)
    );
}

#[test]
fn aovs_allocate_nothing() {
    let scene = wall_scene(1.5);
    let bvh = Bvh::build(&scene.triangles().collect::<Vec<_>>());
    let cam = camera(Vec3::ZERO);
    let previous = camera(Vec3::new(0.1, 0.0, 0.0));
    let n = (W * H) as usize * 4;
    let (mut a, mut nn, mut d, mut m) =
        (vec![0; 3 * n], vec![0; 3 * n], vec![0; n], vec![0; 2 * n]);
    let mut out = AovBuffers {
        albedo: Some(AovLayer::packed(&mut a, AovFormat::F32)),
        normal: Some(AovLayer::packed(&mut nn, AovFormat::F32)),
        depth: Some(AovLayer::packed(&mut d, AovFormat::F32)),
        motion: Some(AovLayer::packed(&mut m, AovFormat::F32)),
    };
    let (res, count) =
        allocations(|| aov::render_rows(&scene, &bvh, &cam, &previous, 0..H, &mut out));
    res.unwrap();
    assert_eq!(count, 0);
}
