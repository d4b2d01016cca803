//! Degenerate geometry a host may hand in. Decision: the core accepts it
//! and renders it safely — zero-area triangles scatter nothing and are
//! never sampled as lights, slivers are ordinary triangles, and a
//! zero-length (or zero interpolated) shading normal falls back to the face
//! normal (`Scene::surface_point`). The C API additionally rejects
//! zero-length normals at `cmlt_scene_add_mesh` (see `capi/tests`), where a
//! host is more likely to have sent garbage than a deliberate zero.

use cmlt::math::{Rgb, Vec3};
use cmlt::scene::{Mesh, SceneBuilder};

use super::*;

/// Zero-area (a point, a segment, a repeated index), sliver and
/// zero-normal white triangles in the furnace change nothing: the radiance
/// stays 2. A zero-area emitter adds no light (and no NaN pdf).
#[test]
fn degenerate_triangles_in_the_furnace_change_nothing() {
    let scene = furnace_with(1.0, Vec3::ZERO, |_, white, b| {
        let p = Vec3::new(0.1, 0.0, 0.3);
        let mesh = |positions: Vec<Vec3>, indices: Vec<[u32; 3]>, normals: Vec<Vec3>| Mesh {
            positions,
            normals,
            uvs: vec![],
            indices,
            material: white,
            emission: None,
        };
        // A point, a segment and a triangle with a repeated index.
        b.add_mesh(mesh(
            vec![p, p, p, p + Vec3::X * 0.5, p + Vec3::X],
            vec![[0, 1, 2], [0, 3, 4], [3, 3, 4], [4, 4, 4]],
            vec![],
        ));
        // Slivers: 1 long, 10⁻⁶ and 10⁻³⁰ wide, across the view.
        for (i, w) in [1e-6f32, 1e-30].into_iter().enumerate() {
            let o = Vec3::new(-0.5, -0.3 + 0.3 * i as f32, 0.2);
            b.add_mesh(mesh(
                vec![o, o + Vec3::X, o + Vec3::X * 0.5 + Vec3::Y * w],
                vec![[0, 1, 2], [0, 2, 1]],
                vec![],
            ));
        }
        // A quad with zero-length normals, and one whose normals cancel
        // in its middle (opposite at opposite corners).
        let o = Vec3::new(-0.4, -0.5, 0.5);
        b.add_mesh(mesh(
            vec![
                o,
                o + Vec3::X * 0.5,
                o + Vec3::new(0.5, 0.5, 0.0),
                o + Vec3::Y * 0.5,
            ],
            vec![[0, 1, 2], [0, 2, 3]],
            vec![Vec3::ZERO; 4],
        ));
        let o = Vec3::new(0.1, 0.1, 0.5);
        b.add_mesh(mesh(
            vec![
                o,
                o + Vec3::X * 0.5,
                o + Vec3::new(0.5, 0.5, 0.0),
                o + Vec3::Y * 0.5,
            ],
            vec![[0, 1, 2], [0, 2, 3]],
            vec![Vec3::Z, Vec3::Z, -Vec3::Z, -Vec3::Z],
        ));
        // Duplicate vertices: the same quad twice over, as two meshes with
        // coincident positions (co-planar twins, both white).
        let o = Vec3::new(-0.8, 0.3, 0.6);
        for _ in 0..2 {
            b.add_mesh(mesh(
                vec![
                    o,
                    o + Vec3::X * 0.4,
                    o + Vec3::new(0.4, 0.4, 0.1),
                    o + Vec3::Y * 0.4,
                ],
                vec![[0, 1, 2], [0, 2, 3]],
                vec![],
            ));
        }
        // A zero-area emitter: never sampled, adds nothing.
        let mut e = mesh(
            vec![p, p + Vec3::Y, p + Vec3::Y * 2.0],
            vec![[0, 1, 2]],
            vec![],
        );
        e.emission = Some(Rgb::splat(7.0));
        b.add_mesh(e);
    });
    for m in ALL {
        render("degenerate", &scene, m, None, 16)
            .assert_finite()
            .assert_mean(2.0, furnace_tol(m));
    }
}

/// A scene whose only emitters have zero area has no light: black, b = 0.
#[test]
fn only_zero_area_emitters_render_black() {
    let mut b = SceneBuilder::new();
    let grey = b.add_material(Material::diffuse(Rgb::splat(0.5)));
    b.add_mesh(cuboid(Vec3::splat(-1.0), Vec3::splat(1.0), grey, true));
    let p = Vec3::new(0.0, 0.5, 0.5);
    b.add_mesh(Mesh {
        positions: vec![p, p, p, p + Vec3::X],
        normals: vec![],
        uvs: vec![],
        indices: vec![[0, 1, 2], [0, 1, 3]],
        material: grey,
        emission: Some(Rgb::splat(100.0)),
    });
    b.set_camera(look_at(Vec3::new(0.0, 0.0, -0.8), Vec3::ZERO, 70.0, 8, 6));
    let scene = b.build().unwrap();
    assert!(scene.lights.is_empty());
    for m in ALL {
        let r = render("zero-area emitters", &scene, m, None, 4);
        r.assert_finite().assert_black();
        assert_eq!(r.stats.b, 0.0);
    }
}
