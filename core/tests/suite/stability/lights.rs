//! Lights touching walls and corners (the G-term singularity), lights at
//! grazing angles, tiny and huge lights, black scenes, and a light the
//! camera cannot see.

use cmlt::integrator::Settings;
use cmlt::math::{Rgb, Vec2, Vec3};
use cmlt::renderer::RendererConfig;
use cmlt::scene::{Material, SceneBuilder};

use super::*;

/// Emitting furnace-like blocks (albedo ½, Le = 1, outward normals) lying
/// flush against the walls and in a corner: the radiance is still 2, also
/// on the walls right next to the blocks' faces, where the distance to the
/// light goes to zero.
#[test]
fn lights_touching_walls_and_corners_keep_the_furnace_at_two() {
    let scene = furnace_with(1.0, Vec3::ZERO, |wall, _, b| {
        for (lo, hi) in [
            // In the far corner x = y = z = 1 ... well, x = 1, y = −1, z = 1.
            (Vec3::new(0.3, -1.0, 0.3), Vec3::new(1.0, -0.3, 1.0)),
            // A thin slab lying on the floor.
            (Vec3::new(-1.0, -1.0, -0.2), Vec3::new(0.0, -0.9, 0.5)),
            // A thin plate on the ceiling, touching the x = −1 wall.
            (Vec3::new(-1.0, 0.99, 0.0), Vec3::new(-0.4, 1.0, 0.8)),
        ] {
            let mut m = cuboid(lo, hi, wall, false);
            m.emission = Some(Rgb::ONE);
            b.add_mesh(m);
        }
    });
    for m in ALL {
        render("touching lights", &scene, m, None, 16)
            .assert_finite()
            .assert_mean(2.0, furnace_tol(m));
    }
}

/// Checks that every method's mean agrees with the first's (BDPT at a
/// larger budget) to `tol`.
fn assert_methods_agree(what: &str, scene: &Scene, max_depth: Option<u32>, upp: u64, tol: f64) {
    let reference = render(what, scene, EstimatorKind::Bdpt, max_depth, 4 * upp);
    reference.assert_finite();
    let m0 = reference.mean();
    assert!(m0 > 0.0, "{what}: the reference is black");
    for m in ALL {
        let r = render(what, scene, m, max_depth, upp);
        r.assert_finite();
        let t = if matches!(m, EstimatorKind::Mlt | EstimatorKind::Cmlt) {
            2.0 * tol
        } else {
            tol
        };
        r.assert_mean(m0, t);
    }
}

/// A light standing on a floor (its plane meets the floor's: light leaves
/// it at grazing angles to the floor), and one whose plane contains the
/// camera (seen exactly edge-on). The methods agree.
#[test]
fn grazing_lights_agree_across_methods() {
    let mut b = SceneBuilder::new();
    let grey = b.add_material(Material::diffuse(Rgb::splat(0.5)));
    b.add_mesh(quad(
        Vec3::new(-2.0, 0.0, -2.0),
        Vec3::new(0.0, 0.0, 4.0),
        Vec3::new(4.0, 0.0, 0.0),
        grey,
        None,
    ));
    // Standing on the floor, facing −z (towards the camera side).
    b.add_mesh(quad(
        Vec3::new(-0.5, 0.0, 0.5),
        Vec3::new(0.0, 0.6, 0.0),
        Vec3::new(1.0, 0.0, 0.0),
        grey,
        Some(4.0),
    ));
    // Edge-on to the camera: the plane x = 0.8 contains the camera.
    b.add_mesh(quad(
        Vec3::new(0.8, 0.0, -0.5),
        Vec3::new(0.0, 0.0, 1.0),
        Vec3::new(0.0, 0.8, 0.0),
        grey,
        Some(2.0),
    ));
    b.set_camera(look_at(
        Vec3::new(0.8, 0.5, -2.0),
        Vec3::new(0.8, 0.3, 0.0),
        60.0,
        16,
        12,
    ));
    let scene = b.build().unwrap();
    assert_methods_agree("grazing lights", &scene, Some(4), 16, 0.05);
}

/// A ceiling light 2·10⁶ wide above a floor as wide, camera looking at the
/// horizon between them, direct light only: the ceiling half of the image
/// is Le = 1, the floor half a·Le = ½ (the light covers the floor's whole
/// hemisphere but for 10⁻⁶ of it).
#[test]
fn huge_light_gives_the_analytic_radiance() {
    let mut b = SceneBuilder::new();
    let floor = b.add_material(Material::diffuse(Rgb::splat(0.5)));
    let black = b.add_material(Material::diffuse(Rgb::ZERO));
    let h = 1e6f32;
    b.add_mesh(quad(
        Vec3::new(-h, 0.0, -h),
        Vec3::new(0.0, 0.0, 2.0 * h),
        Vec3::new(2.0 * h, 0.0, 0.0),
        floor,
        None,
    ));
    // Facing −y, down at the floor.
    b.add_mesh(quad(
        Vec3::new(-h, 1.0, -h),
        Vec3::new(2.0 * h, 0.0, 0.0),
        Vec3::new(0.0, 0.0, 2.0 * h),
        black,
        Some(1.0),
    ));
    b.set_camera(look_at(
        Vec3::new(0.0, 0.5, 0.0),
        Vec3::new(0.0, 0.5, 1.0),
        60.0,
        16,
        12,
    ));
    let scene = b.build().unwrap();
    for m in ALL {
        let r = render("huge light", &scene, m, Some(2), 16);
        r.assert_finite();
        let (top, bottom) = (r.region_mean(0..16, 0..6), r.region_mean(0..16, 6..12));
        let tol = furnace_tol(m);
        assert!((top - 1.0).abs() < tol, "{}: ceiling {top}", r.what);
        assert!(
            (bottom - 0.5).abs() < 0.5 * tol * 2.0,
            "{}: floor {bottom}",
            r.what
        );
    }
}

/// A square light 10⁻⁴ across, Le = 10⁸, one unit above a floor of albedo
/// ½, direct light only: a floor point at horizontal distance r has
/// radiance a/π · Le · A / (1 + r²)², integrated over each pixel here
/// by the camera's own rays. A light 10⁻¹⁹ across (area near f32's
/// smallest normal numbers) must not turn into NaN densities either.
#[test]
fn tiny_lights_give_the_analytic_radiance() {
    let mut b = SceneBuilder::new();
    let floor = b.add_material(Material::diffuse(Rgb::splat(0.5)));
    let black = b.add_material(Material::diffuse(Rgb::ZERO));
    b.add_mesh(quad(
        Vec3::new(-4.0, 0.0, -4.0),
        Vec3::new(0.0, 0.0, 8.0),
        Vec3::new(8.0, 0.0, 0.0),
        floor,
        None,
    ));
    let s = 1e-4f32;
    let le = 1e8f32;
    b.add_mesh(quad(
        Vec3::new(-s / 2.0, 1.0, -s / 2.0),
        Vec3::new(s, 0.0, 0.0),
        Vec3::new(0.0, 0.0, s),
        black,
        Some(le),
    ));
    let cam = look_at(Vec3::new(0.0, 2.0, -2.5), Vec3::ZERO, 60.0, 16, 12);
    b.set_camera(cam);
    let scene = b.build().unwrap();
    // The analytic image: 8×8 rays per pixel onto the floor.
    let mut expected = 0.0f64;
    for py in 0..12 {
        for px in 0..16 {
            for sy in 0..8 {
                for sx in 0..8 {
                    let raster = Vec2::new(
                        px as f32 + (sx as f32 + 0.5) / 8.0,
                        py as f32 + (sy as f32 + 0.5) / 8.0,
                    );
                    let ray = cam.generate_ray(raster, Vec2::splat(0.5));
                    if ray.d.y < 0.0 {
                        let t = -ray.o.y / ray.d.y;
                        let p = ray.o + ray.d * t;
                        if p.x.abs() < 4.0 && p.z.abs() < 4.0 {
                            let r2 = (p.x * p.x + p.z * p.z) as f64;
                            expected += 0.5 / std::f64::consts::PI * (le * s * s) as f64
                                / ((1.0 + r2) * (1.0 + r2));
                        }
                    }
                }
            }
        }
    }
    expected /= (16 * 12 * 64) as f64;
    for m in ALL {
        render("tiny light", &scene, m, Some(2), 16)
            .assert_finite()
            .assert_mean(expected, furnace_tol(m));
    }

    // Area ~10⁻³⁸: finite images, whatever they show.
    let mut b = SceneBuilder::new();
    let floor = b.add_material(Material::diffuse(Rgb::splat(0.5)));
    b.add_mesh(quad(
        Vec3::new(-4.0, 0.0, -4.0),
        Vec3::new(0.0, 0.0, 8.0),
        Vec3::new(8.0, 0.0, 0.0),
        floor,
        None,
    ));
    let s = 1e-19f32;
    b.add_mesh(quad(
        Vec3::new(0.0, 1.0, 0.0),
        Vec3::new(s, 0.0, 0.0),
        Vec3::new(0.0, 0.0, s),
        floor,
        Some(1e30),
    ));
    b.set_camera(cam);
    let scene = b.build().unwrap();
    for m in ALL {
        render("vanishing light", &scene, m, Some(3), 4).assert_finite();
    }
}

/// Nothing emits (no emitters, or emission exactly zero): every method
/// renders exact black without dividing by b = 0, and MLT runs no chain.
#[test]
fn black_scenes_are_exactly_black() {
    for emission in [None, Some(0.0)] {
        let mut b = SceneBuilder::new();
        let grey = b.add_material(Material::diffuse(Rgb::splat(0.5)));
        let mut m = cuboid(Vec3::splat(-1.0), Vec3::splat(1.0), grey, true);
        m.emission = emission.map(Rgb::splat);
        b.add_mesh(m);
        b.set_camera(look_at(Vec3::new(0.0, 0.0, -0.5), Vec3::ZERO, 70.0, 8, 6));
        let scene = b.build().unwrap();
        for m in ALL {
            let r = render("black", &scene, m, None, 4);
            r.assert_finite().assert_black();
            assert_eq!(r.stats.b, 0.0);
            assert_eq!(r.stats.mlt.chains, 0);
        }
    }
}

/// The only light faces away from the camera (its back is black): the
/// room is lit indirectly, the light itself never seen. All methods agree,
/// also with `hide_emitters`.
#[test]
fn light_invisible_to_the_camera() {
    let mut b = SceneBuilder::new();
    let grey = b.add_material(Material::diffuse(Rgb::splat(0.6)));
    b.add_mesh(cuboid(Vec3::splat(-1.0), Vec3::splat(1.0), grey, true));
    // At z = 0.3 facing +z, away from the camera at z = −0.8.
    b.add_mesh(quad(
        Vec3::new(-0.3, -0.3, 0.3),
        Vec3::new(0.6, 0.0, 0.0),
        Vec3::new(0.0, 0.6, 0.0),
        grey,
        Some(10.0),
    ));
    b.set_camera(look_at(Vec3::new(0.0, 0.0, -0.8), Vec3::ZERO, 70.0, 16, 12));
    let scene = b.build().unwrap();
    assert_methods_agree("invisible light", &scene, Some(5), 16, 0.05);
    let hidden = RendererConfig {
        settings: Settings {
            max_depth: Some(5),
            hide_emitters: true,
            ..Settings::default()
        },
        ..config(EstimatorKind::Cmlt, None)
    };
    render_cfg("invisible light, hidden emitters", &scene, hidden, 16).assert_finite();
}
