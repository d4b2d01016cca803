//! Near-specular roughness, total internal reflection, index-matched glass
//! and IOR < 1, all in furnaces with the exact answer 2.

use cmlt::math::{Rgb, Vec3};
use cmlt::scene::{ConductorFresnel, Distribution, Material, MaterialKind, Texture};

use super::*;

fn rough(distribution: Distribution, alpha: f32, reflectance: f32) -> Material {
    Material {
        kind: MaterialKind::RoughConductor {
            distribution,
            alpha,
            fresnel: ConductorFresnel::Perfect,
            specular_reflectance: Texture::Constant(Rgb::splat(reflectance)),
        },
        two_sided: true,
        detail: Default::default(),
    }
}

/// Walls of a near-mirror rough conductor (α = 10⁻⁴ and 10⁻³, GGX and
/// Beckmann) reflecting ½ and emitting 1: radiance 2 (microfacet energy
/// loss is negligible this smooth). The peak of D is ~1/(πα²) ≈ 3·10⁷.
#[test]
fn near_specular_walls_keep_the_furnace_at_two() {
    for distribution in [Distribution::Ggx, Distribution::Beckmann] {
        for alpha in [1e-4f32, 1e-3] {
            let scene = furnace_with(1.0, Vec3::ZERO, |_, _, b| {
                let id = b.add_material(rough(distribution, alpha, 0.5));
                let mut m = cuboid(Vec3::splat(-1.0), Vec3::splat(1.0), id, true);
                // Just inside the diffuse walls, which it hides.
                for p in &mut m.positions {
                    *p *= 0.999;
                }
                m.emission = Some(Rgb::ONE);
                b.add_mesh(m);
            });
            let what = format!("{distribution:?} walls α = {alpha}");
            for m in ALL {
                render(&what, &scene, m, Some(24), 16)
                    .assert_finite()
                    .assert_mean(2.0, furnace_tol(m));
            }
        }
    }
}

/// A GGX sphere of α = 10⁻⁴ and reflectance 1 in the diffuse furnace is
/// invisible.
#[test]
fn near_specular_sphere_is_invisible_in_the_furnace() {
    let scene = furnace_with(1.0, Vec3::ZERO, |_, _, b| {
        let id = b.add_material(rough(Distribution::Ggx, 1e-4, 1.0));
        b.add_mesh(common::sphere(Vec3::new(0.0, 0.0, 0.4), 0.35, id));
    });
    for m in ALL {
        render("GGX α 1e-4 sphere", &scene, m, None, 16)
            .assert_finite()
            .assert_mean(2.0, furnace_tol(m));
    }
}

/// Lossless glass is invisible in the furnace: a sphere and a slab (light
/// entering a face meets the side faces beyond the critical angle: total
/// internal reflection) with η = 1.5, index-matched η = 1 (no reflection,
/// no bending), and η = 0.7 < 1 (total internal reflection from outside).
#[test]
fn glass_is_invisible_in_the_furnace_for_any_ior() {
    for eta in [1.5f32, 1.0, 0.7] {
        let scene = furnace_with(1.0, Vec3::ZERO, |_, _, b| {
            let glass = b.add_material(Material {
                kind: MaterialKind::Dielectric { eta },
                two_sided: false,
                detail: Default::default(),
            });
            b.add_mesh(common::sphere(Vec3::new(-0.3, 0.0, 0.4), 0.3, glass));
            b.add_mesh(cuboid(
                Vec3::new(0.1, -0.6, 0.0),
                Vec3::new(0.6, 0.5, 0.3),
                glass,
                false,
            ));
        });
        let what = format!("glass η = {eta}");
        for m in ALL {
            render(&what, &scene, m, None, 16)
                .assert_finite()
                .assert_mean(2.0, furnace_tol(m));
        }
    }
}
