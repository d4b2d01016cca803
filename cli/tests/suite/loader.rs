//! Tests of the Mitsuba 3 XML loader: the four shared test scenes, Mitsuba's
//! transform and sidedness conventions, mesh and image files, and a corpus
//! of malformed scenes that must each give a located, telling error.

use std::collections::HashSet;
use std::path::{Path, PathBuf};

use cmlt::math::{Rgb, Vec2, Vec3};
use cmlt::scene::{
    ConductorFresnel, Distribution, Effect, Material, MaterialKind, Mesh, RoughCoating, Scene,
    Texture,
};
use cmlt_cli::mitsuba::{
    BUILTIN_SCENES, LoadError, LoadedScene, builtin_scene, load_scene, load_scene_str,
};

// ---------------------------------------------------------------- helpers

/// The test scenes committed under `tests/scenes` (or `$CMLT_SCENES_DIR`).
/// They are part of the repository, so their absence is a failure, not a
/// skip.
fn shared_scenes() -> Option<PathBuf> {
    let dir = std::env::var_os("CMLT_SCENES_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../tests/scenes")));
    assert!(dir.is_dir(), "test scenes not found at {}", dir.display());
    Some(dir)
}

fn load_shared(name: &str) -> Option<LoadedScene> {
    let path = shared_scenes()?.join(name).join("scene.xml");
    Some(load_scene(&path, &[]).unwrap_or_else(|e| panic!("{name} failed to load: {e}")))
}

fn corpus(sub: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/corpus")
        .join(sub)
}

/// A scene with a small camera around `body`, resolved against the valid
/// corpus folder.
fn load_body(body: &str) -> Result<LoadedScene, LoadError> {
    let xml = format!(
        r#"<scene version="3.0.0">
    <sensor type="perspective">
        <float name="fov" value="40"/>
        <film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="8"/><rfilter type="box"/></film>
    </sensor>
    {body}
</scene>"#
    );
    load_scene_str(&xml, &corpus("valid"), "inline.xml", &[])
}

fn ok(body: &str) -> LoadedScene {
    load_body(body).unwrap_or_else(|e| panic!("{e}"))
}

fn bbox(m: &Mesh) -> (Vec3, Vec3) {
    m.positions.iter().fold(
        (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)),
        |(lo, hi), p| (lo.min(*p), hi.max(*p)),
    )
}

fn centroid(m: &Mesh) -> Vec3 {
    m.positions.iter().copied().sum::<Vec3>() / m.positions.len() as f32
}

/// Geometric normal of triangle `t`: cross(p1 − p0, p2 − p0), unit length.
fn tri_normal(m: &Mesh, t: usize) -> Vec3 {
    let [a, b, c] = m.indices[t].map(|i| m.positions[i as usize]);
    (b - a).cross(c - a).normalize()
}

fn area(m: &Mesh) -> f64 {
    m.indices
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| m.positions[i as usize].as_dvec3());
            0.5 * (b - a).cross(c - a).length()
        })
        .sum()
}

fn close(a: Vec3, b: Vec3, tol: f32) -> bool {
    (a - b).abs().max_element() <= tol
}

fn material(s: &Scene, mesh: usize) -> &Material {
    &s.materials[s.meshes[mesh].material.0 as usize]
}

fn lights(s: &Scene) -> Vec<usize> {
    (0..s.meshes.len())
        .filter(|&i| s.meshes[i].emission.is_some())
        .collect()
}

/// sRGB decoding written out independently of the loader.
fn srgb_decode(v: f64) -> f64 {
    if v <= 0.04045 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

// ---------------------------------------------------------- shared scenes

#[test]
fn cornell_box_matches_its_xml() {
    let Some(l) = load_shared("cornell-box") else {
        return;
    };
    let s = &l.scene;
    // 5 walls + light (2 triangles each) and two 12-triangle cubes.
    assert_eq!(s.triangle_count(), 36);
    assert_eq!(s.meshes.len(), 8);
    assert_eq!(lights(s), vec![7]);
    assert_eq!((s.camera.width(), s.camera.height()), (256, 256));
    assert_eq!(l.settings.max_depth, Some(65));
    assert_eq!(l.settings.rr_depth, 5);
    assert_eq!(l.spp, Some(64));
    assert_eq!(l.integrator, "path");
    assert!(l.warnings.is_empty(), "{:?}", l.warnings);

    // Sensor matrix "-1 0 0 0 0 1 0 1 0 0 -1 6.8": at (0, 1, 6.8) looking down −z.
    assert!(close(s.camera.position(), Vec3::new(0.0, 1.0, 6.8), 1e-6));
    assert!(close(s.camera.forward(), Vec3::new(0.0, 0.0, -1.0), 1e-6));

    // Floor: [-1, 1]² in x/z at y = 0, facing up.
    let (lo, hi) = bbox(&s.meshes[0]);
    assert!(
        close(lo, Vec3::new(-1.0, 0.0, -1.0), 1e-5) && close(hi, Vec3::new(1.0, 0.0, 1.0), 1e-5),
        "{lo} {hi}"
    );
    assert!(tri_normal(&s.meshes[0], 0).y > 0.999);
    // Tall box: y = 0.6 − 0.6 z over z ∈ [−1, 1]; short box up to 0.6.
    let (lo, hi) = bbox(&s.meshes[6]);
    assert!(
        (lo.y - 0.0).abs() < 1e-5 && (hi.y - 1.2).abs() < 1e-5,
        "{lo} {hi}"
    );
    assert!((bbox(&s.meshes[5]).1.y - 0.6).abs() < 1e-5);
    // Light: corner (1, 1) → (0.235 − 0.005, 1.98, 0.19 − 0.03), facing down.
    let light = &s.meshes[7];
    let (lo, hi) = bbox(light);
    assert!(
        close(lo, Vec3::new(-0.24, 1.98, -0.22), 1e-5)
            && close(hi, Vec3::new(0.23, 1.98, 0.16), 1e-5),
        "{lo} {hi}"
    );
    assert!(light.normals.iter().all(|n| n.y < -0.999));
    assert_eq!(light.emission, Some(Rgb::new(17.0, 12.0, 4.0)));

    let floor = material(s, 0);
    assert!(floor.two_sided);
    assert_eq!(
        floor.kind,
        MaterialKind::Diffuse {
            reflectance: Texture::Constant(Rgb::new(0.725, 0.71, 0.68))
        }
    );
    assert_eq!(
        material(s, 4).kind,
        MaterialKind::Diffuse {
            reflectance: Texture::Constant(Rgb::new(0.63, 0.065, 0.05))
        },
        "left wall is red"
    );
    assert_eq!(
        material(s, 7).kind,
        MaterialKind::Diffuse {
            reflectance: Texture::Constant(Rgb::ZERO)
        }
    );
    // Only referenced materials are in the scene (8 BSDFs, all used).
    assert_eq!(s.materials.len(), 8);
}

#[test]
fn builtin_cornell_box_is_the_shared_scene() {
    assert_eq!(BUILTIN_SCENES, &["cornell-box"]);
    let b = builtin_scene("cornell-box", &[])
        .expect("known name")
        .expect("loads");
    assert!(builtin_scene("no-such-scene", &[]).is_none());
    assert_eq!(b.scene.triangle_count(), 36);
    assert_eq!(b.spp, Some(64));
    let Some(f) = load_shared("cornell-box") else {
        return;
    };
    assert_eq!(b.scene.meshes, f.scene.meshes);
    assert_eq!(b.scene.materials, f.scene.materials);
    assert_eq!(b.scene.camera, f.scene.camera);
}

#[test]
fn veach_mis_has_three_sphere_lights_of_the_right_size() {
    let Some(l) = load_shared("veach-mis") else {
        return;
    };
    let s = &l.scene;
    assert_eq!((s.camera.width(), s.camera.height()), (320, 180));
    assert_eq!(l.settings.max_depth, Some(3));
    assert_eq!(l.spp, Some(64));
    let lights = lights(s);
    assert_eq!(lights.len(), 3);
    assert_eq!(s.lights.len(), 3);
    let expected = [
        (Vec3::new(0.0, 6.5, -2.8), 1.0f32, 7.59909f32),
        (Vec3::new(0.0, 6.5, 0.0), 0.5, 30.3964),
        (Vec3::new(0.0, 6.5, 2.7), 0.05, 3039.64),
    ];
    let mut sphere_tris = 0;
    for (&mi, &(c, r, le)) in lights.iter().zip(&expected) {
        let m = &s.meshes[mi];
        sphere_tris += m.indices.len();
        assert!(
            m.indices.len() >= 2 * 128 * 64 - 2 * 128,
            "sphere tessellated finely"
        );
        let exact = 4.0 * std::f64::consts::PI * (r as f64).powi(2);
        let rel = (area(m) - exact).abs() / exact;
        assert!(rel < 1e-3, "sphere area off by {rel}");
        for (p, n) in m.positions.iter().zip(&m.normals) {
            let d = (*p - c).length();
            assert!(
                d > r * 0.999 && d < r * 1.001,
                "vertex at distance {d} from the centre, radius {r}"
            );
            assert!(
                n.dot((*p - c) / d) > 0.9999,
                "shading normals are the exact outward sphere normals"
            );
        }
        assert!((0..m.indices.len()).step_by(97).all(|t| {
            let [a, b, cc] = m.indices[t].map(|i| m.positions[i as usize]);
            tri_normal(m, t).dot((a + b + cc) / 3.0 - c) > 0.0
        }));
        assert_eq!(m.emission, Some(Rgb::splat(le)));
        assert_eq!(
            material(s, mi).kind,
            MaterialKind::Diffuse {
                reflectance: Texture::Constant(Rgb::ZERO)
            }
        );
    }
    // 4 plates (cubes) and 2 rectangles besides the spheres.
    assert_eq!(s.triangle_count() - sphere_tris, 4 * 12 + 2 * 2);
    let alphas: Vec<f32> = [0usize, 1, 2, 8]
        .iter()
        .map(|&i| match material(s, i).kind {
            MaterialKind::RoughConductor {
                distribution: Distribution::Beckmann,
                alpha,
                specular_reflectance,
                fresnel,
            } => {
                assert_eq!(specular_reflectance, Texture::Constant(Rgb::splat(0.3)));
                assert_eq!(
                    fresnel,
                    ConductorFresnel::Complex {
                        eta: Rgb::new(0.200438, 0.924033, 1.10221),
                        k: Rgb::new(3.91295, 2.45285, 2.14219)
                    }
                );
                alpha
            }
            ref k => panic!("plate {i} is {k:?}"),
        })
        .collect();
    assert_eq!(alphas, vec![0.01, 0.05, 0.1, 0.25]);
}

#[test]
fn veach_bidir_counts_and_materials() {
    let Some(l) = load_shared("veach-bidir") else {
        return;
    };
    let s = &l.scene;
    // Sum of the `f` lines of the twelve OBJ files plus two light rectangles.
    assert_eq!(s.triangle_count(), 11544);
    assert_eq!(s.meshes.len(), 14);
    assert_eq!(lights(s), vec![2, 3]);
    assert_eq!(s.meshes[2].emission, Some(Rgb::splat(523.258)));
    assert_eq!((s.camera.width(), s.camera.height()), (256, 256));
    assert_eq!(l.settings.max_depth, Some(7));
    // The glass egg: smooth dielectric 1.5 / 1, not two-sided.
    assert_eq!(
        *material(s, 7),
        Material {
            kind: MaterialKind::Dielectric { eta: 1.5 },
            two_sided: false,
            detail: Default::default(),
        }
    );
    // face_normals drops the file's normals; Lamp_0002 keeps them.
    assert!(s.meshes[0].normals.is_empty());
    assert_eq!(s.meshes[4].normals.len(), s.meshes[4].positions.len());
    let lamp = material(s, 0);
    assert!(lamp.two_sided);
    assert!(matches!(
        lamp.kind,
        MaterialKind::RoughConductor {
            distribution: Distribution::Beckmann,
            alpha: 0.25,
            ..
        }
    ));
}

#[test]
fn veach_ajar_textures_are_wired() {
    let Some(l) = load_shared("veach-ajar") else {
        return;
    };
    let s = &l.scene;
    assert_eq!(s.triangle_count(), 4546);
    assert_eq!(s.meshes.len(), 16);
    assert_eq!(lights(s), vec![0]);
    assert_eq!((s.camera.width(), s.camera.height()), (320, 180));
    assert_eq!(l.settings.max_depth, Some(13));
    // Unused BSDFs (the teapots' glass among them) are not in the scene.
    assert!(
        !s.materials
            .iter()
            .any(|m| matches!(m.kind, MaterialKind::Dielectric { .. }))
    );

    // Floor: GGX rough metal with a 20 × 80 checkerboard.
    match material(s, 3).kind {
        MaterialKind::RoughConductor {
            distribution: Distribution::Ggx,
            alpha,
            specular_reflectance,
            ..
        } => {
            assert_eq!(alpha, 0.1);
            let Texture::Checkerboard {
                color0,
                color1,
                to_uv,
            } = specular_reflectance
            else {
                panic!("{specular_reflectance:?}")
            };
            assert_eq!((color0, color1), (Rgb::splat(0.8), Rgb::splat(0.2)));
            assert!((to_uv.transform_point2(Vec2::ONE) - Vec2::new(20.0, 80.0)).length() < 1e-5);
        }
        ref k => panic!("floor is {k:?}"),
    }

    // Three distinct JPEGs, one with a space in its name, each loaded once
    // and decoded from sRGB.
    assert_eq!(s.bitmaps.len(), 3);
    let dir = shared_scenes().unwrap().join("veach-ajar/textures");
    let mut seen = HashSet::new();
    for (mesh, file) in [
        (1, "landscape-with-a-lake.jpg"),
        (14, "Good Textures_005844.jpg"),
        (8, "cherry-wood-texture.jpg"),
    ] {
        let m = material(s, mesh);
        assert!(m.two_sided);
        let MaterialKind::Diffuse {
            reflectance: Texture::Bitmap { id, .. },
        } = m.kind
        else {
            panic!("{:?}", m.kind)
        };
        assert!(seen.insert(id.0));
        let b = &s.bitmaps[id.0 as usize];
        let img = image::open(dir.join(file)).unwrap().to_rgb8();
        assert_eq!((b.width(), b.height()), img.dimensions());
        // Texel centres return the decoded texel; row 0 is the image's top.
        let (w, h) = img.dimensions();
        for k in 0..500u32 {
            let (x, y) = ((k * 7919) % w, (k * 104_729) % h);
            let got = b.eval(Vec2::new(
                (x as f32 + 0.5) / w as f32,
                (y as f32 + 0.5) / h as f32,
            ));
            let p = img.get_pixel(x, y);
            for (c, g) in [got.r, got.g, got.b].into_iter().enumerate() {
                let want = srgb_decode(p[c] as f64 / 255.0);
                assert!(
                    (g as f64 - want).abs() < 1e-3,
                    "{file} texel ({x}, {y}) channel {c}: {g} vs {want}"
                );
            }
        }
    }
}

#[test]
fn command_line_defaults_override_scene_defaults() {
    let Some(dir) = shared_scenes() else { return };
    let d = |k: &str, v: &str| (k.to_string(), v.to_string());
    let l = load_scene(
        &dir.join("cornell-box/scene.xml"),
        &[
            d("spp", "16"),
            d("resx", "128"),
            d("max_depth", "-1"),
            d("unused", "1"),
        ],
    )
    .unwrap();
    assert_eq!(l.spp, Some(16));
    assert_eq!(
        (l.scene.camera.width(), l.scene.camera.height()),
        (128, 256)
    );
    assert_eq!(l.settings.max_depth, None, "-1 means unbounded");
    assert!(
        l.warnings.iter().any(|w| w.contains("'unused'")),
        "{:?}",
        l.warnings
    );
    let e = load_scene(
        &dir.join("cornell-box/scene.xml"),
        &[d("integrator", "$loop")],
    )
    .unwrap_err();
    assert!(e.message.contains("undefined parameter '$loop'"), "{e}");
}

// ------------------------------------------------------------- transforms

#[test]
fn transform_composition_follows_mitsuba_order() {
    // Each element is applied after the ones before it: translate, then
    // rotate about the origin.
    let s = ok(r#"<shape type="rectangle"><transform name="to_world">
        <translate x="1"/><rotate z="1" angle="90"/></transform></shape>
      <shape type="rectangle"><transform name="to_world">
        <rotate z="1" angle="90"/><translate x="1"/></transform></shape>"#)
    .scene;
    assert!(
        close(centroid(&s.meshes[0]), Vec3::new(0.0, 1.0, 0.0), 1e-6),
        "{}",
        centroid(&s.meshes[0])
    );
    assert!(
        close(centroid(&s.meshes[1]), Vec3::new(1.0, 0.0, 0.0), 1e-6),
        "{}",
        centroid(&s.meshes[1])
    );
    // The rotation is right-handed: the corner (1, −1) (uv (1, 0)) turns
    // to (1, 1), then moves to (2, 1).
    let m = &s.meshes[1];
    let i = m
        .uvs
        .iter()
        .position(|uv| *uv == Vec2::new(1.0, 0.0))
        .unwrap();
    assert!(
        close(m.positions[i], Vec3::new(2.0, 1.0, 0.0), 1e-6),
        "{}",
        m.positions[i]
    );
}

#[test]
fn matrix_is_row_major_and_value_attributes_work() {
    let s = ok(r#"<shape type="rectangle"><transform name="to_world">
        <matrix value="1 0 0 5  0 1 0 6  0 0 1 7  0 0 0 1"/></transform></shape>
      <shape type="rectangle"><transform name="to_world"><scale value="2"/><translate value="0, 0, 3"/></transform></shape>
      <shape type="rectangle"><transform name="to_world"><scale x="3"/></transform></shape>"#)
    .scene;
    assert!(close(
        centroid(&s.meshes[0]),
        Vec3::new(5.0, 6.0, 7.0),
        1e-6
    ));
    assert_eq!(
        bbox(&s.meshes[1]),
        (Vec3::new(-2.0, -2.0, 3.0), Vec3::new(2.0, 2.0, 3.0))
    );
    assert_eq!(
        bbox(&s.meshes[2]),
        (Vec3::new(-3.0, -1.0, 0.0), Vec3::new(3.0, 1.0, 0.0))
    );
}

#[test]
fn lookat_orients_camera_and_shapes() {
    let xml = r#"<scene version="3.0.0">
      <sensor type="perspective">
        <float name="fov" value="90"/>
        <string name="fov_axis" value="y"/>
        <transform name="to_world"><lookat origin="1, 2, 3" target="1, 2, 0" up="0, 1, 0"/></transform>
        <film type="hdrfilm"><integer name="width" value="40"/><integer name="height" value="20"/><rfilter type="box"/></film>
      </sensor>
      <shape type="rectangle"><transform name="to_world"><lookat origin="0, 0, 0" target="0, -5, 0" up="0, 0, 1"/></transform></shape>
    </scene>"#;
    let l = load_scene_str(xml, Path::new("."), "lookat.xml", &[]).unwrap();
    let c = &l.scene.camera;
    assert!(close(c.position(), Vec3::new(1.0, 2.0, 3.0), 1e-6));
    assert!(close(c.forward(), Vec3::new(0.0, 0.0, -1.0), 1e-6));
    // Mitsuba: camera +x is "left" = up × dir = −x in the world, so the
    // image's left edge looks towards −x; fov_axis y: 45° up at the top.
    let left = c.generate_ray(Vec2::new(0.0, 10.0), Vec2::ZERO);
    assert!(left.d.x < 0.0);
    let top = c.generate_ray(Vec2::new(20.0, 0.0), Vec2::ZERO);
    assert!((top.d.y.atan2(-top.d.z).to_degrees() - 45.0).abs() < 1e-3);
    // A shape's local +z is the lookat direction.
    let m = &l.scene.meshes[0];
    assert!(
        m.normals
            .iter()
            .all(|n| close(*n, Vec3::new(0.0, -1.0, 0.0), 1e-6))
    );
    assert!(tri_normal(m, 0).y < -0.999);
}

/// A sensor transform with a scale (which Mitsuba 3 refuses and older
/// exporters write) renders its rigid part, with a warning; a mirror
/// (`scale x="-1"`, accepted by Mitsuba) flips the image left to right.
#[test]
fn scaled_and_mirrored_cameras() {
    let camera = |extra: &str| {
        let xml = format!(
            r#"<scene version="3.0.0">
      <sensor type="perspective">
        <float name="fov" value="60"/>
        <transform name="to_world">{extra}<lookat origin="1, 2, 3" target="0, 0, 0" up="0, 1, 0"/></transform>
        <film type="hdrfilm"><integer name="width" value="32"/><integer name="height" value="16"/><rfilter type="box"/></film>
      </sensor>
      <shape type="rectangle"/>
    </scene>"#
        );
        load_scene_str(&xml, Path::new("."), "camera.xml", &[]).unwrap()
    };
    let plain = camera("");
    assert!(plain.warnings.is_empty(), "{:?}", plain.warnings);
    let scaled = camera(r#"<scale x="2" y="0.5" z="3"/>"#);
    assert!(
        scaled.warnings.iter().any(|w| w.contains("scale or shear")),
        "{:?}",
        scaled.warnings
    );
    let mirrored = camera(r#"<scale x="-1"/>"#);
    assert!(mirrored.warnings.is_empty(), "{:?}", mirrored.warnings);
    let (p, s, m) = (
        &plain.scene.camera,
        &scaled.scene.camera,
        &mirrored.scene.camera,
    );
    for (x, y) in [(0.0, 0.0), (5.5, 3.25), (31.0, 15.0), (16.0, 8.0)] {
        let a = p.generate_ray(Vec2::new(x, y), Vec2::ZERO);
        let b = s.generate_ray(Vec2::new(x, y), Vec2::ZERO);
        assert!(close(a.o, b.o, 1e-6) && close(a.d, b.d, 1e-6), "({x}, {y})");
        // The mirror image of pixel position x is 32 − x.
        let c = m.generate_ray(Vec2::new(32.0 - x, y), Vec2::ZERO);
        assert!(
            close(a.o, c.o, 1e-6) && close(a.d, c.d, 1e-5),
            "mirror ({x}, {y}): {a:?} {c:?}"
        );
    }
}

#[test]
fn mirroring_transforms_keep_mitsubas_sides() {
    let s = ok(r#"
      <shape type="rectangle"><transform name="to_world"><scale x="-1"/></transform></shape>
      <shape type="cube"><transform name="to_world"><scale value="-1"/><translate x="5"/></transform></shape>
      <shape type="obj"><string name="filename" value="uv_quad.obj"/><boolean name="face_normals" value="true"/>
        <transform name="to_world"><scale x="-1"/></transform></shape>
      <shape type="obj"><string name="filename" value="uv_quad.obj"/>
        <transform name="to_world"><scale x="-1"/></transform></shape>"#)
    .scene;
    // Rectangle: Mitsuba's normal is the inverse transpose of +z, still +z;
    // the triangles are re-wound so the geometric normal agrees.
    let r = &s.meshes[0];
    assert!(r.normals.iter().all(|n| *n == Vec3::Z));
    assert!((0..2).all(|t| tri_normal(r, t).z > 0.999));
    // Cube: still closed with outward normals everywhere.
    let c = &s.meshes[1];
    let centre = Vec3::new(5.0, 0.0, 0.0);
    for t in 0..12 {
        let [a, b, cc] = c.indices[t].map(|i| c.positions[i as usize]);
        let out = ((a + b + cc) / 3.0 - centre).normalize();
        assert!(tri_normal(c, t).dot(out) > 0.5, "triangle {t}");
        assert!(c.normals[c.indices[t][0] as usize].dot(out) > 0.5);
    }
    // A file mesh without normals: Mitsuba's normal is cross(p1 − p0,
    // p2 − p0) of the mirrored vertices, which now faces −z.
    let f = &s.meshes[2];
    assert!(f.normals.is_empty());
    assert!((0..2).all(|t| tri_normal(f, t).z < -0.999));
    // With the file's normal (+z, transformed by the inverse transpose:
    // still +z), shading follows the normal and the surface point's
    // geometric normal is put on its side, as in Mitsuba's shading frame.
    let g = &s.meshes[3];
    assert!(g.normals.iter().all(|n| *n == Vec3::Z));
    let sp = s
        .surface_point(s.triangle_count() as u32 - 1, 0.2, 0.2)
        .unwrap();
    assert!(sp.ns.z > 0.999 && sp.ng.z > 0.999);
}

#[test]
fn flip_normals_turns_the_front_around() {
    let s = ok(
        r#"<shape type="rectangle"><boolean name="flip_normals" value="true"/>
        <emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>
      <shape type="sphere"><boolean name="flip_normals" value="true"/></shape>
      <shape type="sphere"><transform name="to_world"><scale value="-2"/></transform></shape>"#,
    )
    .scene;
    let r = &s.meshes[0];
    assert!(r.normals.iter().all(|n| *n == Vec3::NEG_Z));
    assert!(tri_normal(r, 0).z < -0.999);
    let sp = s.surface_point(0, 0.3, 0.3).unwrap();
    assert_eq!(s.emitted(&sp, Vec3::NEG_Z), Rgb::ONE);
    assert_eq!(s.emitted(&sp, Vec3::Z), Rgb::ZERO);
    // Inverted spheres (flip_normals, or a negative scale as Mitsuba
    // treats it): normals and windings point inwards.
    for m in &s.meshes[1..] {
        assert!(
            m.positions
                .iter()
                .zip(&m.normals)
                .all(|(p, n)| n.dot(*p) < 0.0)
        );
        assert!(tri_normal(m, 300).dot(m.positions[m.indices[300][0] as usize]) < 0.0);
    }
    assert!((bbox(&s.meshes[2]).1.x - 2.0).abs() < 1e-3);
}

// ------------------------------------------------------------ mesh files

#[test]
fn obj_uvs_are_flipped_like_mitsuba() {
    let s = ok(r#"<shape type="obj"><string name="filename" value="uv_quad.obj"/></shape>
      <shape type="obj"><string name="filename" value="uv_quad.obj"/><boolean name="flip_tex_coords" value="false"/></shape>"#)
    .scene;
    let (a, b) = (&s.meshes[0], &s.meshes[1]);
    assert_eq!(a.indices.len(), 2, "the quad is split into two triangles");
    let at = |m: &Mesh, p: Vec3| m.uvs[m.positions.iter().position(|q| *q == p).unwrap()];
    // vt (1, 0.25) of vertex (1, 1, 0) → (1, 0.75); without the flip it stays.
    assert_eq!(at(a, Vec3::new(1.0, 1.0, 0.0)), Vec2::new(1.0, 0.75));
    assert_eq!(at(a, Vec3::new(0.0, 0.0, 0.0)), Vec2::new(0.0, 1.0));
    assert_eq!(at(b, Vec3::new(1.0, 1.0, 0.0)), Vec2::new(1.0, 0.25));
    assert!(a.normals.iter().all(|n| *n == Vec3::Z));
    assert!((0..2).all(|t| tri_normal(a, t).z > 0.999));
}

#[test]
fn obj_without_normals_gets_angle_weighted_normals() {
    let s = ok(r#"<shape type="obj"><string name="filename" value="tent.obj"/></shape>
      <shape type="obj"><string name="filename" value="tent.obj"/><boolean name="face_normals" value="true"/></shape>"#)
    .scene;
    let m = &s.meshes[0];
    let n_at = |p: Vec3| m.normals[m.positions.iter().position(|q| *q == p).unwrap()];
    // Shared ridge vertices average the two faces (equal corner angles).
    assert!(close(n_at(Vec3::new(0.0, 0.0, 1.0)), Vec3::Z, 1e-6));
    assert!(close(n_at(Vec3::new(0.0, 1.0, 1.0)), Vec3::Z, 1e-6));
    let h = std::f32::consts::FRAC_1_SQRT_2;
    assert!(close(
        n_at(Vec3::new(-1.0, 0.0, 0.0)),
        Vec3::new(-h, 0.0, h),
        1e-6
    ));
    assert!(s.meshes[1].normals.is_empty());
}

#[test]
fn ply_ascii_and_binary() {
    let s = ok(
        r#"<shape type="ply"><string name="filename" value="pentagon_ascii.ply"/></shape>
      <shape type="ply"><string name="filename" value="pentagon_binary.ply"/>
        <transform name="to_world"><translate z="1"/></transform></shape>"#,
    )
    .scene;
    let (a, b) = (&s.meshes[0], &s.meshes[1]);
    // A pentagon as a fan of 3; a quad (2) plus a triangle in binary.
    assert_eq!(a.indices.len(), 3);
    assert_eq!(b.indices.len(), 3);
    assert_eq!(a.positions[2], Vec3::new(1.5, 1.0, 0.0));
    assert_eq!(b.positions[2], Vec3::new(1.5, 1.0, 1.0));
    // uv from s/t and u/v, not flipped (Mitsuba's PLY reader does not).
    assert_eq!(a.uvs[1], Vec2::new(0.25, 0.75));
    assert_eq!(b.uvs[3], Vec2::new(0.75, 0.25));
    assert!(a.normals.iter().all(|n| *n == Vec3::Z));
    // No normals in the binary file: smooth normals are computed.
    assert!(b.normals.iter().all(|n| close(*n, Vec3::Z, 1e-6)));
    assert!((area(a) - area(b)).abs() < 1e-9 && (area(a) - 2.5).abs() < 1e-6);
}

/// Mitsuba's `.serialized` meshes: each shape of a version-4 file by
/// `shape_index` (f32 with normals, uv and skipped colours; f64 without
/// normals, which are then computed), and a version-3 file, whose
/// dictionary holds u32 offsets (files written by make_serialized.py).
#[test]
fn serialized_shapes_by_index_and_version() {
    let s = ok(
        r#"<shape type="serialized"><string name="filename" value="two_shapes.serialized"/></shape>
      <shape type="serialized"><string name="filename" value="two_shapes.serialized"/>
        <integer name="shape_index" value="1"/>
        <transform name="to_world"><translate x="1"/></transform></shape>
      <shape type="serialized"><string name="filename" value="triangle_v3.serialized"/>
        <integer name="shape_index" value="1"/></shape>"#,
    )
    .scene;
    let (quad, tri, v3) = (&s.meshes[0], &s.meshes[1], &s.meshes[2]);
    assert_eq!(quad.indices.len(), 2);
    assert_eq!(quad.positions[2], Vec3::new(1.0, 1.0, 0.0));
    assert_eq!(quad.uvs[1], Vec2::new(1.0, 0.0));
    assert!(quad.normals.iter().all(|n| *n == Vec3::Z));
    assert!((area(quad) - 1.0).abs() < 1e-6);
    assert_eq!(tri.indices.len(), 1);
    assert_eq!(tri.positions[1], Vec3::new(3.0, 0.0, 2.0));
    assert!(tri.uvs.is_empty());
    assert!(tri.normals.iter().all(|n| close(*n, Vec3::Z, 1e-6)));
    assert!((area(tri) - 3.0).abs() < 1e-6);
    assert_eq!(
        v3.positions,
        s.meshes[1]
            .positions
            .iter()
            .map(|p| *p - Vec3::X)
            .collect::<Vec<_>>()
    );
}

#[test]
fn spheres_and_disks_are_tessellated_with_exact_area() {
    let s = ok(r#"<shape type="sphere"><float name="radius" value="2"/><point name="center" x="1" y="2" z="3"/></shape>
      <shape type="sphere"><transform name="to_world"><scale value="3"/><translate value="0 0 -4"/></transform></shape>
      <shape type="disk"><transform name="to_world"><scale value="0.5"/></transform></shape>"#)
    .scene;
    use std::f64::consts::PI;
    for (m, c, r) in [
        (&s.meshes[0], Vec3::new(1.0, 2.0, 3.0), 2.0f32),
        (&s.meshes[1], Vec3::new(0.0, 0.0, -4.0), 3.0),
    ] {
        let exact = 4.0 * PI * (r as f64).powi(2);
        assert!((area(m) / exact - 1.0).abs() < 1e-5);
        let (lo, hi) = bbox(m);
        assert!(((lo + hi) / 2.0 - c).length() < 1e-4 * r);
        assert!(
            m.positions
                .iter()
                .all(|p| ((*p - c).length() / r - 1.0).abs() < 1e-3)
        );
        // Mitsuba's sphere uv: (φ / 2π, θ / π) with θ from +z.
        let top = m
            .positions
            .iter()
            .position(|p| close(*p, c + Vec3::new(0.0, 0.0, r), 1e-2 * r))
            .unwrap();
        assert!(m.uvs[top].y.abs() < 1e-6);
    }
    let d = &s.meshes[2];
    assert!((area(d) / (PI * 0.25) - 1.0).abs() < 1e-5);
    assert!(d.normals.iter().all(|n| *n == Vec3::Z) && tri_normal(d, 5).z > 0.999);
}

// ------------------------------------------------------------- materials

/// Conductor presets are Mitsuba 3's own RGB (η, k): its `scalar_rgb`
/// variant gives gold η = (0.143036, 0.375307, 1.44205), k = (3.983,
/// 2.38556, 1.60336) (read with `mi.traverse` on Mitsuba 3.9.1), for
/// `conductor` and `roughconductor` alike; `none` is the ideal mirror.
#[test]
fn conductor_presets_are_mitsubas_rgb() {
    let s = ok(r#"
      <shape type="rectangle"><bsdf type="conductor"><string name="material" value="Au"/></bsdf></shape>
      <shape type="rectangle"><bsdf type="roughconductor"><string name="material" value="Cu"/></bsdf></shape>
      <shape type="rectangle"><bsdf type="conductor"><string name="material" value="none"/></bsdf></shape>"#)
    .scene;
    let fresnel = |i: usize| match &material(&s, i).kind {
        MaterialKind::Conductor { fresnel, .. } => *fresnel,
        MaterialKind::RoughConductor { fresnel, .. } => *fresnel,
        other => panic!("mesh {i}: {other:?}"),
    };
    let ConductorFresnel::Complex { eta, k } = fresnel(0) else {
        panic!("gold: {:?}", fresnel(0));
    };
    for (got, want) in [
        (eta, Rgb::new(0.143036, 0.375307, 1.44205)),
        (k, Rgb::new(3.983, 2.38556, 1.60336)),
    ] {
        assert!(
            got.to_array()
                .iter()
                .zip(want.to_array())
                .all(|(a, b)| (a - b).abs() < 1e-5),
            "{got:?} vs {want:?}"
        );
    }
    assert!(matches!(fresnel(1), ConductorFresnel::Complex { .. }));
    assert_eq!(fresnel(2), ConductorFresnel::Perfect);
}

#[test]
fn bsdf_defaults_and_parameters_follow_mitsuba() {
    let s = ok(r#"
      <bsdf type="dielectric" id="water"><string name="int_ior" value="water"/><string name="ext_ior" value="air"/></bsdf>
      <bsdf type="diffuse" id="unused"/>
      <shape type="rectangle"/>
      <shape type="rectangle"><emitter type="area"><rgb name="radiance" value="2"/></emitter></shape>
      <shape type="rectangle"><ref id="water"/></shape>
      <shape type="rectangle"><bsdf type="dielectric"/></shape>
      <shape type="rectangle"><bsdf type="conductor"/></shape>
      <shape type="rectangle"><bsdf type="roughconductor"><float name="alpha_u" value="0.2"/><float name="alpha_v" value="0.2"/>
        <rgb name="eta" value="0.2 0.9 1.1"/></bsdf></shape>
      <shape type="rectangle"><bsdf type="diffuse"><float name="reflectance" value="0.25"/></bsdf></shape>
      <shape type="rectangle"><ref id="water"/></shape>"#)
    .scene;
    // No BSDF: one-sided diffuse 0.5; on an emitter: black (Mitsuba's Shape).
    assert_eq!(
        *material(&s, 0),
        Material {
            kind: MaterialKind::Diffuse {
                reflectance: Texture::Constant(Rgb::splat(0.5))
            },
            two_sided: false,
            detail: Default::default(),
        }
    );
    assert_eq!(
        material(&s, 1).kind,
        MaterialKind::Diffuse {
            reflectance: Texture::Constant(Rgb::ZERO)
        }
    );
    assert_eq!(
        material(&s, 2).kind,
        MaterialKind::Dielectric {
            eta: 1.333 / 1.000277
        }
    );
    // Dielectric defaults: bk7 inside, air outside.
    assert_eq!(
        material(&s, 3).kind,
        MaterialKind::Dielectric {
            eta: 1.5046 / 1.000277
        }
    );
    // conductor without eta/k is Mitsuba's material="none": a perfect mirror.
    assert_eq!(
        material(&s, 4).kind,
        MaterialKind::Conductor {
            fresnel: ConductorFresnel::Perfect,
            specular_reflectance: Texture::Constant(Rgb::ONE)
        }
    );
    // Equal alpha_u/alpha_v are isotropic; k defaults to 1; Beckmann default.
    assert_eq!(
        material(&s, 5).kind,
        MaterialKind::RoughConductor {
            distribution: Distribution::Beckmann,
            alpha: 0.2,
            fresnel: ConductorFresnel::Complex {
                eta: Rgb::new(0.2, 0.9, 1.1),
                k: Rgb::ONE
            },
            specular_reflectance: Texture::Constant(Rgb::ONE),
        }
    );
    assert_eq!(
        material(&s, 6).kind,
        MaterialKind::Diffuse {
            reflectance: Texture::Constant(Rgb::splat(0.25))
        }
    );
    // A referenced BSDF is one material; the unused one is not added.
    assert_eq!(s.meshes[2].material, s.meshes[7].material);
    assert_eq!(s.materials.len(), 7);
}

#[test]
fn bitmaps_are_srgb_decoded_unless_raw_and_loaded_once() {
    let dir = std::env::temp_dir().join(format!("cmlt-loader-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let img = image::RgbImage::from_raw(2, 1, vec![0, 128, 255, 64, 64, 64]).unwrap();
    img.save(dir.join("two texels.png")).unwrap();
    let xml = r#"<scene version="3.0.0">
      <sensor type="perspective"><float name="fov" value="40"/><film type="hdrfilm"><rfilter type="box"/></film></sensor>
      <texture type="bitmap" id="t"><string name="filename" value="two texels.png"/></texture>
      <shape type="rectangle"><bsdf type="diffuse"><ref name="reflectance" id="t"/></bsdf></shape>
      <shape type="rectangle"><bsdf type="diffuse"><texture type="bitmap" name="reflectance">
        <string name="filename" value="two texels.png"/><boolean name="raw" value="true"/>
        <transform name="to_uv"><scale x="2"/><translate x="0.5"/></transform></texture></bsdf></shape>
      <shape type="rectangle"><bsdf type="diffuse"><texture type="bitmap" name="reflectance">
        <string name="filename" value="two texels.png"/><string name="filter_type" value="nearest"/></texture></bsdf></shape>
    </scene>"#;
    let l = load_scene_str(xml, &dir, "bitmap.xml", &[]).unwrap();
    std::fs::remove_dir_all(&dir).ok();
    let s = &l.scene;
    assert_eq!(s.bitmaps.len(), 2, "one decode per (file, raw)");
    let MaterialKind::Diffuse {
        reflectance: Texture::Bitmap { id, .. },
    } = material(s, 0).kind
    else {
        panic!()
    };
    let t0 = s.bitmaps[id.0 as usize].eval(Vec2::new(0.25, 0.5));
    assert_eq!(t0.r, 0.0);
    assert!((t0.g as f64 - srgb_decode(128.0 / 255.0)).abs() < 1e-6);
    assert_eq!(t0.b, 1.0);
    let MaterialKind::Diffuse {
        reflectance: Texture::Bitmap { id: raw_id, to_uv },
    } = material(s, 1).kind
    else {
        panic!()
    };
    let t1 = s.bitmaps[raw_id.0 as usize].eval(Vec2::new(0.75, 0.5));
    assert!((t1.r - 64.0 / 255.0).abs() < 1e-6);
    // to_uv from the 4×4: scale then translate → u' = 2u + 0.5.
    assert!((to_uv.transform_point2(Vec2::new(0.25, 0.5)) - Vec2::new(1.0, 0.5)).length() < 1e-6);
    assert!(
        l.warnings
            .iter()
            .any(|w| w.contains("nearest") && w.contains("bitmap.xml:")),
        "{:?}",
        l.warnings
    );
}

// -------------------------------------------------------- sensor and film

#[test]
fn approximations_are_never_silent() {
    let xml = |filter: &str| {
        format!(
            r#"<scene version="3.0.0"><sensor type="perspective"><float name="fov" value="40"/>
            <sampler type="stratified"><integer name="sample_count" value="9"/></sampler>
            <film type="hdrfilm">{filter}</film></sensor></scene>"#
        )
    };
    let g = load_scene_str(
        &xml(r#"<rfilter type="gaussian"/>"#),
        Path::new("."),
        "f.xml",
        &[],
    )
    .unwrap();
    assert_eq!(g.spp, Some(9));
    assert!(
        g.warnings
            .iter()
            .any(|w| w.contains("'gaussian'") && w.starts_with("f.xml:3:")),
        "{:?}",
        g.warnings
    );
    assert!(
        g.warnings.iter().any(|w| w.contains("'stratified'")),
        "{:?}",
        g.warnings
    );
    let none = load_scene_str(&xml(""), Path::new("."), "f.xml", &[]).unwrap();
    assert!(
        none.warnings
            .iter()
            .any(|w| w.contains("no <rfilter>") && w.contains("gaussian")),
        "{:?}",
        none.warnings
    );
    let boxed = load_scene_str(
        &xml(r#"<rfilter type="box"/>"#),
        Path::new("."),
        "f.xml",
        &[],
    )
    .unwrap();
    assert_eq!(
        boxed.warnings.len(),
        1,
        "only the sampler: {:?}",
        boxed.warnings
    );
}

#[test]
fn sensor_defaults_and_thin_lens() {
    let l = load_scene_str(
        r#"<scene version="3.0.0"><integrator type="bdpt"><integer name="rr_depth" value="3"/>
             <boolean name="hide_emitters" value="true"/><integer name="samples_per_pass" value="4"/></integrator>
           <sensor type="thinlens"><float name="aperture_radius" value="0.1"/><float name="focus_distance" value="5"/>
             <float name="fov" value="30"/></sensor></scene>"#,
        Path::new("."),
        "t.xml",
        &[],
    )
    .unwrap();
    assert_eq!(
        (l.scene.camera.width(), l.scene.camera.height()),
        (768, 576)
    );
    assert!(l.scene.camera.has_lens());
    assert_eq!(l.integrator, "bdpt");
    assert_eq!(l.settings.rr_depth, 3);
    assert!(l.settings.hide_emitters);
    assert_eq!(l.settings.max_depth, None);
    assert_eq!(l.spp, None);
    assert!(
        l.warnings.iter().any(|w| w.contains("samples_per_pass")),
        "{:?}",
        l.warnings
    );
    // No integrator at all: Mitsuba's `path` with its defaults.
    let p = load_scene_str(
        r#"<scene version="3.0.0"><sensor type="perspective"/></scene>"#,
        Path::new("."),
        "p.xml",
        &[],
    )
    .unwrap();
    assert_eq!(p.integrator, "path");
    assert_eq!(p.settings, cmlt::integrator::Settings::default());
}

/// `focus_distance` on a `perspective` sensor (five of Bitterli's scenes
/// carry one): Mitsuba reads it for every projective camera and a pinhole
/// ignores it, so the camera must be the one without it; a distance no
/// camera could focus at is still refused.
#[test]
fn perspective_accepts_focus_distance() {
    let load = |extra: &str| {
        load_scene_str(
            &format!(
                r#"<scene version="3.0.0"><sensor type="perspective"><float name="fov" value="40"/>{extra}
                     <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="6"/>
                     <rfilter type="box"/></film></sensor></scene>"#
            ),
            Path::new("."),
            "f.xml",
            &[],
        )
    };
    let plain = load("").unwrap();
    let focused = load(r#"<float name="focus_distance" value="2.5"/>"#).unwrap();
    assert!(!focused.scene.camera.has_lens());
    assert_eq!(focused.scene.camera, plain.scene.camera);
    assert!(focused.warnings.is_empty(), "{:?}", focused.warnings);
    for bad in ["0", "-1"] {
        let e = load(&format!(r#"<float name="focus_distance" value="{bad}"/>"#)).unwrap_err();
        assert!(e.message.contains("focus_distance must be > 0"), "{e}");
        assert_eq!(e.line, Some(1), "{e}");
    }
}

// ------------------------------------------------------- malformed input

/// Every file of the malformed corpus and a phrase its error must contain.
const MALFORMED: &[(&str, &str)] = &[
    ("anisotropic.xml", "anisotropic roughness"),
    ("bad_image.xml", "image file 'data/not_an_image.png'"),
    ("bad_integer.xml", "'3.5' is not an integer"),
    ("bad_max_depth.xml", "max_depth must be -1"),
    ("bad_rgb.xml", "'zero' is not a number"),
    ("binary_garbage.xml", "not UTF-8"),
    ("binary_mesh.xml", "mesh file 'data/binary.obj'"),
    ("camera_singular.xml", "singular"),
    ("deeply_nested_twosided.xml", "nested too deeply"),
    ("device_mesh.xml", "not a regular file"),
    ("dtd_entity.xml", "malformed XML"),
    ("duplicate_id.xml", "duplicate id 'A'"),
    ("empty.xml", "malformed XML"),
    ("fov_out_of_range.xml", "fov must be in (0, 180)"),
    ("garbage_mesh.xml", "no triangles"),
    ("garbage_ply.xml", "invalid PLY data"),
    ("inf_fov.xml", "'inf' is not a finite number"),
    ("missing_filename.xml", "lacks the 'filename' property"),
    (
        "missing_mesh_file.xml",
        "mesh file 'data/does_not_exist.obj': cannot open",
    ),
    ("missing_sensor.xml", "no <sensor>"),
    (
        "missing_texture_file.xml",
        "image file 'data/no such image.png': cannot open",
    ),
    (
        "misspelt_property.xml",
        "unsupported property 'reflectence'",
    ),
    ("nan_in_matrix.xml", "'nan' is not a finite number"),
    ("negative_radiance.xml", "radiance must be non-negative"),
    (
        "negative_reflectance.xml",
        "'reflectance' must be non-negative",
    ),
    ("nested_defaults.xml", "longer than 1048576 bytes"),
    ("obj_index_out_of_range.xml", "index out of bounds"),
    ("obj_nan_vertex.xml", "non-finite position"),
    ("old_version.xml", "Mitsuba 0.x"),
    ("overflow_float.xml", "'1e999' is out of range"),
    ("ply_count_exceeds_file.xml", "exceeds the file's 178 bytes"),
    ("ply_huge_count.xml", "bad element count"),
    ("ply_index_out_of_range.xml", "refers to vertex 7"),
    (
        "ply_long_header_line.xml",
        "header line longer than 4096 bytes",
    ),
    ("rgb_two_values.xml", "expected 1 or 3 values"),
    (
        "serialized_bad_index.xml",
        "shape 0: triangle 0 refers to vertex 7",
    ),
    ("serialized_huge_count.xml", "declares 2147483648 vertices"),
    (
        "serialized_index_out_of_range.xml",
        "shape_index 1 is out of range: the file holds 1 shape(s)",
    ),
    (
        "serialized_negative_index.xml",
        "shape_index must be non-negative, got -1",
    ),
    ("serialized_not_serialized.xml", "not a .serialized file"),
    (
        "serialized_truncated.xml",
        "shape 0: the stream ends inside",
    ),
    ("singular_transform.xml", "singular"),
    (
        "top_level_area_emitter.xml",
        "must be nested inside a <shape>",
    ),
    ("transform_outside.xml", "only appear inside a <transform>"),
    ("truncated.xml", "malformed XML"),
    (
        "truncated_jpg.xml",
        "image file 'data/truncated.jpg': truncated JPEG",
    ),
    (
        "truncated_png.xml",
        "image file 'data/truncated.png': cannot decode",
    ),
    ("twosided_dielectric.xml", "cannot wrap a transmissive"),
    ("unclosed_tag.xml", "malformed XML"),
    ("undefined_parameter.xml", "undefined parameter '$depth'"),
    ("unknown_bsdf.xml", "unsupported BSDF plugin 'pplastic'"),
    (
        "unknown_conductor_preset.xml",
        "unknown conductor material preset 'Gold'",
    ),
    (
        "unknown_emitter.xml",
        "unsupported emitter plugin 'projector'",
    ),
    ("unknown_ref.xml", "reference to unknown id 'NoSuchBSDF'"),
    ("unknown_shape.xml", "unsupported shape plugin 'cylinder'"),
    ("wrong_property_type.xml", "'fov' must be a float"),
    ("wrong_root.xml", "root element must be <scene>"),
    ("zero_radius_sphere.xml", "radius must not be zero"),
    ("zero_rotation_axis.xml", "non-zero axis"),
    ("zero_width.xml", "film width must be in"),
];

#[test]
fn malformed_corpus_gives_located_errors() {
    let dir = corpus("malformed");
    let mut files: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".xml"))
        .collect();
    files.sort();
    let listed: Vec<String> = MALFORMED.iter().map(|(f, _)| f.to_string()).collect();
    assert_eq!(
        files, listed,
        "every corpus file needs an expectation and vice versa"
    );
    assert!(files.len() >= 15);
    for (file, phrase) in MALFORMED {
        let path = dir.join(file);
        let err = match load_scene(&path, &[]) {
            Ok(_) => panic!("{file}: loaded although malformed"),
            Err(e) => e,
        };
        let text = err.to_string();
        assert!(
            text.contains(file),
            "{file}: message does not name the file: {text}"
        );
        assert!(
            text.contains(phrase),
            "{file}: expected '{phrase}' in: {text}"
        );
        let line = err
            .line
            .unwrap_or_else(|| panic!("{file}: no line number: {text}"));
        assert!(err.column.is_some());
        assert!(
            text.starts_with(&format!("{}:{line}:", path.display())),
            "{text}"
        );
        assert!(!text.contains('\n'), "{file}: one-line messages: {text}");
    }
}

#[test]
fn errors_point_at_the_offending_line() {
    let e =
        load_body("\n\n<shape type=\"cube\">\n  <bsdf type=\"pplastic\"/>\n</shape>").unwrap_err();
    // The body starts on line 6 of the generated document.
    assert_eq!((e.line, e.column), (Some(9), Some(3)), "{e}");
    assert_eq!(
        e.to_string(),
        "inline.xml:9:3: unsupported BSDF plugin 'pplastic'"
    );
    let e = load_scene_str("<scene version=\"3.0.0\">\n<sensor type=\"perspective\">\n<float name=\"fov\" value=\"nan\"/>", Path::new("."), "cut.xml", &[])
        .unwrap_err();
    assert_eq!(e.line, Some(3), "{e}");
}

#[test]
fn truncated_and_corrupted_scenes_never_panic() {
    let text = include_str!("../../../mitsuba/scenes/cornell-box.xml");
    for cut in (0..text.len()).step_by(23) {
        let _ = load_scene_str(&text[..cut], Path::new("."), "cut.xml", &[]);
    }
    // Replace single bytes with characters that break numbers and markup.
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let bytes = text.as_bytes();
    for _ in 0..400 {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        let i = (state % bytes.len() as u64) as usize;
        let c = b"<>/\"=-e.0$ nx"[(state >> 40) as usize % 13];
        let mut b = bytes.to_vec();
        b[i] = c;
        if let Ok(s) = std::str::from_utf8(&b) {
            let _ = load_scene_str(s, Path::new("."), "flip.xml", &[]);
        }
    }
}

// ------------------------------------------------------- surface detail

#[test]
fn surface_detail_scene_wires_normalmap_bumpmap_and_mask() {
    let dir = crate::common::scenes_dir().join("surface-detail");
    let l = cmlt_cli::mitsuba::load_scene(&dir.join("scene.xml"), &[]).unwrap();
    let s = &l.scene;
    let details: Vec<_> = s.materials.iter().map(|m| m.detail).collect();
    let normal = details.iter().find(|d| d.normal_map.is_some()).unwrap();
    let bump = details.iter().find(|d| d.bump_map.is_some()).unwrap();
    let mask = details.iter().find(|d| d.opacity.is_some()).unwrap();
    assert!(normal.bump_map.is_none() && normal.opacity.is_none());
    assert_eq!(bump.bump_scale, 0.05);
    // The mask wraps a twosided diffuse: the nested material keeps it.
    let masked = s
        .materials
        .iter()
        .find(|m| m.detail.opacity.is_some())
        .unwrap();
    assert!(masked.two_sided);
    // Raw bitmaps: the flat normal (128, 128, 255) is read linearly.
    let Some(Texture::Bitmap { id, .. }) = mask.opacity else {
        panic!("a bitmap opacity")
    };
    let o = s.bitmaps[id.0 as usize].eval(Vec2::new(1.0 / 32.0, 1.0 / 32.0));
    assert!((o.r - 1.0).abs() < 1e-6, "opaque corner texel, got {o:?}");
    // flip_invalid_normals/use_shadowing_function are false: no warning.
    assert!(l.warnings.is_empty(), "{:?}", l.warnings);
    let fx = s.analysis(&s.camera).effects;
    for e in [Effect::NormalMapping, Effect::AlphaMasks, Effect::Textures] {
        assert!(fx.contains(e), "{e:?}");
    }
}

#[test]
fn surface_detail_errors_name_file_and_line() {
    let err = |body: &str| match load_body(body) {
        Err(e) => e.to_string(),
        Ok(_) => panic!("must fail: {body}"),
    };
    let shape = |bsdf: &str| format!("<shape type=\"rectangle\">\n{bsdf}\n</shape>");
    let e = err(&shape(
        r#"<bsdf type="mask"><float name="opacity" value="1.5"/><bsdf type="diffuse"/></bsdf>"#,
    ));
    assert!(
        e.starts_with("inline.xml:7:") && e.contains("[0, 1]"),
        "{e}"
    );
    let e = err(&shape(
        r#"<bsdf type="mask"><float name="opacity" value="-0.1"/><bsdf type="diffuse"/></bsdf>"#,
    ));
    assert!(
        e.contains("opacity") && e.starts_with("inline.xml:7:"),
        "{e}"
    );
    let e = err(&shape(
        r#"<bsdf type="normalmap"><texture name="normalmap" type="bitmap"><string name="filename" value="missing.png"/></texture><bsdf type="diffuse"/></bsdf>"#,
    ));
    assert!(
        e.starts_with("inline.xml:7:") && e.contains("missing.png"),
        "{e}"
    );
    let e = err(&shape(
        r#"<bsdf type="bumpmap"><float name="scale" value="2"/><bsdf type="diffuse"/></bsdf>"#,
    ));
    assert!(e.contains("needs a nested <texture>"), "{e}");
    let e = err(&shape(r#"<bsdf type="mask"/>"#));
    assert!(e.contains("needs a nested <bsdf>"), "{e}");
    let e = err(&shape(
        r#"<bsdf type="twosided"><bsdf type="bumpmap"><texture type="checkerboard"/><bsdf type="diffuse"/></bsdf></bsdf>"#,
    ));
    assert!(e.contains("not supported"), "{e}");
    // Mitsuba's defaults for the frame flags are approximations: warned.
    let l = ok(&shape(
        r#"<bsdf type="bumpmap"><texture type="checkerboard"/><bsdf type="diffuse"/></bsdf>"#,
    ));
    assert!(
        l.warnings
            .iter()
            .any(|w| w.contains("flip_invalid_normals") && w.starts_with("inline.xml:7:")),
        "{:?}",
        l.warnings
    );
    // Opacity 0 and 1 are fine; a constant opacity is kept as given.
    let l = ok(&shape(
        r#"<bsdf type="mask"><float name="opacity" value="0.25"/><bsdf type="diffuse"/></bsdf>"#,
    ));
    assert_eq!(
        l.scene.materials[0].detail.opacity,
        Some(Texture::Constant(Rgb::splat(0.25)))
    );
}
#[test]
fn coatings_and_thin_glass_follow_mitsuba() {
    let s = ok(r#"
      <shape type="rectangle"><bsdf type="plastic"/></shape>
      <shape type="rectangle"><bsdf type="roughplastic">
        <string name="int_ior" value="bk7"/><float name="ext_ior" value="1.2"/>
        <boolean name="nonlinear" value="true"/><boolean name="sample_visible" value="false"/>
        <rgb name="diffuse_reflectance" value="0.1, 0.2, 0.3"/></bsdf></shape>
      <shape type="rectangle"><bsdf type="roughplastic"><string name="distribution" value="ggx"/>
        <float name="alpha" value="0.3"/><rgb name="specular_reflectance" value="0.5"/></bsdf></shape>
      <shape type="rectangle"><bsdf type="thindielectric"/></shape>
      <shape type="rectangle"><bsdf type="dielectric"><rgb name="specular_transmittance" value="0.9, 0.5, 0.2"/></bsdf></shape>
      <shape type="rectangle"><bsdf type="dielectric"><float name="specular_reflectance" value="1"/></bsdf></shape>
      <shape type="rectangle"><bsdf type="twosided"><bsdf type="plastic"/></bsdf></shape>"#)
    .scene;
    let c = |v: f32| Texture::Constant(Rgb::splat(v));
    // Mitsuba's defaults: polypropylene (1.49) in air, base 0.5, white
    // coating, linear; roughplastic: Beckmann, α = 0.1.
    let plastic = MaterialKind::Plastic {
        eta: 1.49 / 1.000277,
        diffuse_reflectance: c(0.5),
        specular_reflectance: c(1.0),
        nonlinear: false,
    };
    assert_eq!(material(&s, 0).kind, plastic);
    let eta = 1.5046 / 1.2;
    assert_eq!(
        material(&s, 1).kind,
        MaterialKind::RoughPlastic {
            distribution: Distribution::Beckmann,
            alpha: 0.1,
            eta,
            diffuse_reflectance: Texture::Constant(Rgb::new(0.1, 0.2, 0.3)),
            specular_reflectance: c(1.0),
            nonlinear: true,
            coating: RoughCoating::new(Distribution::Beckmann, 0.1, eta),
        }
    );
    assert!(matches!(
        material(&s, 2).kind,
        MaterialKind::RoughPlastic { distribution: Distribution::Ggx, alpha: 0.3, specular_reflectance, .. }
            if specular_reflectance == c(0.5)
    ));
    assert_eq!(
        material(&s, 3).kind,
        MaterialKind::ThinDielectric {
            eta: 1.5046 / 1.000277,
            specular_reflectance: c(1.0),
            specular_transmittance: c(1.0),
        }
    );
    assert_eq!(
        material(&s, 4).kind,
        MaterialKind::TintedDielectric {
            eta: 1.5046 / 1.000277,
            specular_reflectance: c(1.0),
            specular_transmittance: Texture::Constant(Rgb::new(0.9, 0.5, 0.2)),
        }
    );
    // Tints of 1 are the plain dielectric.
    assert!(matches!(
        material(&s, 5).kind,
        MaterialKind::Dielectric { .. }
    ));
    assert_eq!(
        *material(&s, 6),
        Material {
            kind: plastic,
            two_sided: true,
            detail: Default::default(),
        }
    );
}

#[test]
fn bad_coating_parameters_are_located_errors() {
    for (body, phrase) in [
        (
            r#"<bsdf type="roughplastic"><float name="int_ior" value="1.3"/><float name="ext_ior" value="1.3"/></bsdf>"#,
            "indices of refraction must differ",
        ),
        (
            r#"<bsdf type="plastic"><float name="int_ior" value="-1.5"/></bsdf>"#,
            "'int_ior' must be positive",
        ),
        (
            r#"<bsdf type="plastic"><rgb name="diffuse_reflectance" value="0.5, -0.1, 0.5"/></bsdf>"#,
            "'diffuse_reflectance' must be non-negative",
        ),
        (
            r#"<bsdf type="roughplastic"><float name="alpha" value="0"/></bsdf>"#,
            "roughness alpha must be > 0",
        ),
        (
            r#"<bsdf type="roughplastic"><string name="distribution" value="phong"/></bsdf>"#,
            "invalid distribution 'phong'",
        ),
        (
            r#"<bsdf type="thindielectric"><rgb name="specular_transmittance" value="-1"/></bsdf>"#,
            "'specular_transmittance' must be non-negative",
        ),
        (
            r#"<bsdf type="twosided"><bsdf type="thindielectric"/></bsdf>"#,
            "cannot wrap a transmissive",
        ),
        (
            r#"<bsdf type="plastic"><float name="diffuse_reflectanse" value="0.5"/></bsdf>"#,
            "unsupported property 'diffuse_reflectanse'",
        ),
    ] {
        let e = load_body(&format!("\n<shape type=\"cube\">\n{body}\n</shape>"))
            .err()
            .unwrap_or_else(|| panic!("{body}: loaded"));
        let text = e.to_string();
        assert!(text.contains(phrase), "{body}: {text}");
        assert!(
            text.starts_with("inline.xml:") && e.line.is_some_and(|l| l >= 8),
            "{body}: {text}"
        );
    }
}

/// `body` (a `<bsdf>`) inside a cube two lines below the camera fails to
/// load with an error at `inline.xml:line` that contains `phrase`.
fn assert_refused_at(body: &str, line: u32, phrase: &str) {
    let e = load_body(&format!("\n\n<shape type=\"cube\">\n{body}\n</shape>"))
        .err()
        .unwrap_or_else(|| panic!("accepted: {body}"));
    let text = e.to_string();
    assert!(text.contains(phrase), "{body}: {text}");
    assert!(
        text.starts_with(&format!("inline.xml:{line}:")),
        "{body}: {text}"
    );
}

#[test]
fn roughdielectric_parameters_and_defaults() {
    let s = ok(r#"
      <shape type="rectangle"><bsdf type="roughdielectric"/></shape>
      <shape type="rectangle"><bsdf type="roughdielectric">
        <string name="distribution" value="ggx"/><float name="alpha" value="0.3"/>
        <float name="int_ior" value="1.33"/><string name="ext_ior" value="vacuum"/>
        <rgb name="specular_reflectance" value="0.5 0.6 0.7"/>
        <rgb name="specular_transmittance" value="0.9 0.8 0.1"/>
        <boolean name="sample_visible" value="false"/></bsdf></shape>"#)
    .scene;
    // Mitsuba's defaults: Beckmann, α = 0.1, bk7 inside, air outside, white.
    assert_eq!(
        *material(&s, 0),
        Material {
            kind: MaterialKind::RoughDielectric {
                distribution: Distribution::Beckmann,
                alpha: 0.1,
                eta: 1.5046 / 1.000277,
                specular_reflectance: Texture::Constant(Rgb::ONE),
                specular_transmittance: Texture::Constant(Rgb::ONE),
            },
            two_sided: false,
            detail: Default::default(),
        }
    );
    assert_eq!(
        material(&s, 1).kind,
        MaterialKind::RoughDielectric {
            distribution: Distribution::Ggx,
            alpha: 0.3,
            eta: 1.33,
            specular_reflectance: Texture::Constant(Rgb::new(0.5, 0.6, 0.7)),
            specular_transmittance: Texture::Constant(Rgb::new(0.9, 0.8, 0.1)),
        }
    );
    // Bad values: refused with the line of the offending element.
    for (body, line, phrase) in [
        (
            r#"<bsdf type="roughdielectric"><float name="alpha" value="nan"/></bsdf>"#,
            9,
            "not a finite number",
        ),
        (
            r#"<bsdf type="roughdielectric"><float name="alpha" value="-0.2"/></bsdf>"#,
            9,
            "alpha must be > 0",
        ),
        (
            r#"<bsdf type="roughdielectric"><float name="int_ior" value="-1.5"/></bsdf>"#,
            9,
            "'int_ior' must be positive",
        ),
        (
            r#"<bsdf type="roughdielectric"><float name="int_ior" value="1"/><float name="ext_ior" value="1"/></bsdf>"#,
            9,
            "must differ",
        ),
        (
            r#"<bsdf type="roughdielectric"><rgb name="specular_transmittance" value="0.5 -1 0.5"/></bsdf>"#,
            9,
            "must be non-negative",
        ),
        (
            r#"<bsdf type="roughdielectric"><string name="distribution" value="phong"/></bsdf>"#,
            9,
            "invalid distribution",
        ),
        (
            r#"<bsdf type="roughdielectric"><float name="alpha_u" value="0.1"/><float name="alpha_v" value="0.3"/></bsdf>"#,
            9,
            "anisotropic roughness",
        ),
        (
            r#"<bsdf type="twosided"><bsdf type="roughdielectric"/></bsdf>"#,
            9,
            "cannot wrap a transmissive BSDF",
        ),
    ] {
        assert_refused_at(body, line, phrase);
    }
}

#[test]
fn roughdiffuse_follows_mitsuba_06() {
    let s = ok(r#"
      <shape type="rectangle"><bsdf type="roughdiffuse"/></shape>
      <shape type="rectangle"><bsdf type="twosided"><bsdf type="roughdiffuse">
        <rgb name="reflectance" value="0.1, 0.2, 0.3"/><float name="alpha" value="1"/>
      </bsdf></bsdf></shape>
      <shape type="rectangle"><bsdf type="roughdiffuse">
        <rgb name="diffuseReflectance" value="0.4"/><float name="alpha" value="0"/>
        <boolean name="useFastApprox" value="true"/></bsdf></shape>
      <shape type="rectangle"><bsdf type="roughdiffuse">
        <rgb name="diffuse_reflectance" value="0.4"/><float name="alpha" value="0"/>
        <boolean name="use_fast_approx" value="true"/></bsdf></shape>"#)
    .scene;
    // Mitsuba 0.6's defaults: reflectance 0.5, α = 0.2, the full model.
    assert_eq!(
        *material(&s, 0),
        Material {
            kind: MaterialKind::RoughDiffuse {
                reflectance: Texture::Constant(Rgb::splat(0.5)),
                alpha: 0.2,
                fast_approx: false,
            },
            two_sided: false,
            detail: Default::default(),
        }
    );
    assert_eq!(
        *material(&s, 1),
        Material {
            kind: MaterialKind::RoughDiffuse {
                reflectance: Texture::Constant(Rgb::new(0.1, 0.2, 0.3)),
                alpha: 1.0,
                fast_approx: false,
            },
            two_sided: true,
            detail: Default::default(),
        }
    );
    assert_eq!(
        material(&s, 2).kind,
        MaterialKind::RoughDiffuse {
            reflectance: Texture::Constant(Rgb::splat(0.4)),
            alpha: 0.0,
            fast_approx: true,
        }
    );
    // The names Mitsuba 3's upgrade of 0.x files gives them.
    assert_eq!(material(&s, 3).kind, material(&s, 2).kind);
    assert!(s.analysis(&s.camera).effects.contains(Effect::RoughDiffuse));
    for (body, line, phrase) in [
        (
            r#"<bsdf type="roughdiffuse"><float name="alpha" value="nan"/></bsdf>"#,
            9,
            "not a finite number",
        ),
        (
            r#"<bsdf type="roughdiffuse"><float name="alpha" value="-0.1"/></bsdf>"#,
            9,
            "'alpha' must be in [0, 1e4]",
        ),
        (
            r#"<bsdf type="roughdiffuse"><rgb name="reflectance" value="0.5 -1 0.5"/></bsdf>"#,
            9,
            "must be non-negative",
        ),
        (
            r#"<bsdf type="roughdiffuse"><rgb name="reflectance" value="0.5"/><rgb name="diffuseReflectance" value="0.5"/></bsdf>"#,
            9,
            "not both",
        ),
        (
            r#"<bsdf type="roughdiffuse"><boolean name="useFastApprox" value="true"/><boolean name="use_fast_approx" value="true"/></bsdf>"#,
            9,
            "not both",
        ),
        (
            r#"<bsdf type="roughdiffuse"><texture type="checkerboard" name="alpha"/></bsdf>"#,
            9,
            "alpha",
        ),
        (
            r#"<bsdf type="roughdiffuse"><string name="useFastApprox" value="maybe"/></bsdf>"#,
            9,
            "useFastApprox",
        ),
        (
            r#"<bsdf type="roughdiffuse"><float name="roughness" value="0.3"/></bsdf>"#,
            9,
            "roughness",
        ),
    ] {
        assert_refused_at(body, line, phrase);
    }
}

/// One rule per parameter, as the C API applies it: colours in [0, 1]
/// (a reflectance above 1 creates energy), microfacet α in (0, 1e4]
/// (Mitsuba's α > 1 is accepted); each refusal names the line.
#[test]
fn colours_and_roughness_follow_one_rule() {
    let s = ok(r#"<shape type="rectangle"><bsdf type="roughconductor">
        <float name="alpha" value="2"/><rgb name="specular_reflectance" value="1"/></bsdf></shape>"#)
    .scene;
    assert!(matches!(
        material(&s, 0).kind,
        MaterialKind::RoughConductor { alpha: 2.0, .. }
    ));
    for (body, phrase) in [
        (
            r#"<bsdf type="diffuse"><rgb name="reflectance" value="0.5 1.2 0.5"/></bsdf>"#,
            "'reflectance' must lie in [0, 1]",
        ),
        (
            r#"<bsdf type="conductor"><rgb name="specular_reflectance" value="1.5"/></bsdf>"#,
            "'specular_reflectance' must lie in [0, 1]",
        ),
        (
            r#"<bsdf type="plastic"><rgb name="diffuse_reflectance" value="2"/></bsdf>"#,
            "'diffuse_reflectance' must lie in [0, 1]",
        ),
        (
            r#"<bsdf type="diffuse"><texture type="checkerboard" name="reflectance"><rgb name="color0" value="1.1"/></texture></bsdf>"#,
            "'color0' must be at most 1",
        ),
        (
            r#"<bsdf type="roughconductor"><float name="alpha" value="20000"/></bsdf>"#,
            "at most 10000",
        ),
    ] {
        assert_refused_at(body, 9, phrase);
    }
}

// ---------------------------------------------------------------- lights

#[test]
fn scene_level_emitters_follow_mitsuba() {
    use cmlt::scene::Light;
    let s = ok(r#"<emitter type="point">
        <point name="position" x="1" y="2" z="3"/>
        <rgb name="intensity" value="4, 5, 6"/>
    </emitter>
    <emitter type="spot">
        <transform name="to_world"><lookat origin="0, 1, 0" target="0, 1, 5" up="0, 1, 0"/></transform>
        <float name="cutoff_angle" value="40"/>
    </emitter>
    <emitter type="directional">
        <vector name="direction" x="0" y="-2" z="0"/>
        <float name="irradiance" value="3"/>
    </emitter>
    <emitter type="point">
        <transform name="to_world"><translate x="7" y="8" z="9"/></transform>
    </emitter>
    <emitter type="constant"/>"#)
    .scene;
    let lights: Vec<Light> = s.lights.others().copied().collect();
    assert_eq!(s.lights.len(), 5);
    assert_eq!(
        lights[0],
        Light::Point {
            position: Vec3::new(1.0, 2.0, 3.0),
            intensity: Rgb::new(4.0, 5.0, 6.0)
        }
    );
    // Mitsuba's spot: to_world's +z, beam width 3/4 of the cutoff, intensity 1.
    match lights[1] {
        Light::Spot {
            position,
            direction,
            intensity,
            cutoff_angle,
            beam_width,
        } => {
            assert!(close(position, Vec3::new(0.0, 1.0, 0.0), 1e-6));
            assert!(close(direction.normalize(), Vec3::Z, 1e-6));
            assert_eq!(
                (intensity, cutoff_angle, beam_width),
                (Rgb::ONE, 40.0, 30.0)
            );
        }
        other => panic!("{other:?}"),
    }
    assert_eq!(
        lights[2],
        Light::Directional {
            direction: Vec3::new(0.0, -2.0, 0.0),
            irradiance: Rgb::splat(3.0)
        }
    );
    assert!(
        matches!(lights[3], Light::Point { position, .. } if position == Vec3::new(7.0, 8.0, 9.0))
    );
    assert_eq!(lights[4], Light::Constant { radiance: Rgb::ONE });
}

#[test]
fn bad_scene_level_emitters_are_located() {
    for (body, want) in [
        (
            r#"<emitter type="point"><float name="intensity" value="-1"/></emitter>"#,
            "intensity must be finite and non-negative",
        ),
        (
            r#"<emitter type="directional"><vector name="direction" x="0" y="0" z="0"/></emitter>"#,
            "direction must be finite and non-zero",
        ),
        (
            r#"<emitter type="spot"><float name="cutoff_angle" value="10"/><float name="beam_width" value="20"/></emitter>"#,
            "beam_width",
        ),
        (
            r#"<emitter type="point"><point name="position" x="0" y="0" z="0"/><transform name="to_world"><translate x="1"/></transform></emitter>"#,
            "not both",
        ),
        (
            r#"<emitter type="envmap"><string name="filename" value="sky.exr"/></emitter>"#,
            "image file 'sky.exr': cannot open",
        ),
        (
            r#"<emitter type="envmap"/>"#,
            "lacks the 'filename' property",
        ),
        (
            r#"<emitter type="envmap"><float name="scale" value="-2"/><string name="filename" value="sky.exr"/></emitter>"#,
            "'scale' must be finite and non-negative",
        ),
        (
            r#"<emitter type="envmap"><string name="filename" value="../../../../tests/scenes/cornell-box/reference.exr"/><transform name="to_world"><scale y="2"/></transform></emitter>"#,
            "to_world must be finite and a rotation",
        ),
        (
            r#"<emitter type="envmap"><string name="filename" value="tent.obj"/></emitter>"#,
            "cannot decode",
        ),
        (
            r#"<emitter type="spotlight"/>"#,
            "unsupported emitter plugin 'spotlight'",
        ),
        (
            r#"<emitter type="constant"><rgb name="radiance" value="1, 1"/></emitter>"#,
            "",
        ),
        (
            r#"<emitter type="constant"><float name="power" value="1"/></emitter>"#,
            "power",
        ),
    ] {
        let e = load_body(body).map(|_| ()).unwrap_err();
        let text = e.to_string();
        assert_eq!(e.line, Some(6), "{text}");
        assert!(text.starts_with("inline.xml:6:"), "{text}");
        assert!(text.contains(want), "{body}: {text}");
    }
}

// ---------------------------------------------------------------- principled

#[test]
fn principled_parameters_and_defaults() {
    use cmlt::scene::PrincipledParams;
    let s = ok(r#"
      <shape type="rectangle"><bsdf type="principled"/></shape>
      <shape type="rectangle"><bsdf type="principled">
        <rgb name="base_color" value="0.8 0.3 0.2"/>
        <float name="roughness" value="0.3"/><float name="anisotropic" value="0.5"/>
        <float name="metallic" value="0.25"/><float name="spec_trans" value="0.5"/>
        <float name="eta" value="1.33"/><float name="spec_tint" value="0.1"/>
        <float name="sheen" value="0.2"/><float name="sheen_tint" value="0.3"/>
        <float name="clearcoat" value="0.4"/><float name="clearcoat_gloss" value="0.6"/>
        <float name="flatness" value="0.7"/>
        <float name="main_specular_sampling_rate" value="2"/></bsdf></shape>
      <shape type="rectangle"><bsdf type="principled">
        <texture type="checkerboard" name="roughness"/>
        <float name="specular" value="0.8"/></bsdf></shape>
      <shape type="rectangle"><bsdf type="principled">
        <float name="spec_trans" value="1"/><float name="specular" value="0"/></bsdf></shape>
      <shape type="rectangle"><bsdf type="principled">
        <float name="spec_trans" value="1"/><float name="eta" value="1"/></bsdf></shape>"#)
    .scene;
    // Mitsuba's defaults: base colour 0.5, roughness 0.5, specular 0.5.
    let mut want = PrincipledParams::DEFAULT;
    want.eta = PrincipledParams::eta_from_specular(0.5);
    assert_eq!(material(&s, 0).kind, MaterialKind::Principled(want));
    assert!((want.eta - 1.5).abs() < 1e-6, "{}", want.eta);
    let c = |v: f32| Texture::Constant(Rgb::splat(v));
    let given = PrincipledParams {
        base_color: Texture::Constant(Rgb::new(0.8, 0.3, 0.2)),
        roughness: c(0.3),
        anisotropic: c(0.5),
        metallic: c(0.25),
        spec_trans: c(0.5),
        spec_tint: c(0.1),
        sheen: c(0.2),
        sheen_tint: c(0.3),
        clearcoat: c(0.4),
        clearcoat_gloss: c(0.6),
        flatness: c(0.7),
        eta: 1.33,
    };
    assert_eq!(material(&s, 1).kind, MaterialKind::Principled(given));
    let MaterialKind::Principled(p) = material(&s, 2).kind else {
        panic!("not principled");
    };
    assert!(matches!(p.roughness, Texture::Checkerboard { .. }));
    assert_eq!(p.eta, PrincipledParams::eta_from_specular(0.8));
    // A transmitting principled moves specular 0 and η = 1 off the
    // index-matched interface, as Mitsuba does.
    let MaterialKind::Principled(p) = material(&s, 3).kind else {
        panic!("not principled");
    };
    assert_eq!(p.eta, PrincipledParams::eta_from_specular(1e-3));
    let MaterialKind::Principled(p) = material(&s, 4).kind else {
        panic!("not principled");
    };
    assert_eq!(p.eta, 1.001);
    // Bad values: refused with the line of the offending element.
    for (body, phrase) in [
        (
            r#"<bsdf type="principled"><float name="roughness" value="nan"/></bsdf>"#,
            "not a finite number",
        ),
        (
            r#"<bsdf type="principled"><float name="metallic" value="-0.5"/></bsdf>"#,
            "must be non-negative",
        ),
        (
            r#"<bsdf type="principled"><float name="sheen" value="1.5"/></bsdf>"#,
            "'sheen' must lie in [0, 1]",
        ),
        (
            r#"<bsdf type="principled"><rgb name="base_color" value="0.5 1.2 0.5"/></bsdf>"#,
            "'base_color' must lie in [0, 1]",
        ),
        (
            r#"<bsdf type="principled"><texture type="checkerboard" name="clearcoat"><float name="color0" value="2"/></texture></bsdf>"#,
            "'color0' must be at most 1",
        ),
        (
            r#"<bsdf type="principled"><float name="eta" value="1.5"/><float name="specular" value="0.5"/></bsdf>"#,
            "either 'eta' or 'specular'",
        ),
        (
            r#"<bsdf type="principled"><float name="eta" value="-1.5"/></bsdf>"#,
            "'eta' must be > 0",
        ),
        (
            r#"<bsdf type="principled"><float name="specular" value="3"/></bsdf>"#,
            "'specular' must be in [0, 1]",
        ),
        (
            r#"<bsdf type="principled"><float name="clearcoat_glos" value="0.5"/></bsdf>"#,
            "unsupported property 'clearcoat_glos'",
        ),
        (
            r#"<bsdf type="twosided"><bsdf type="principled"><float name="spec_trans" value="0.3"/></bsdf></bsdf>"#,
            "cannot wrap a transmissive BSDF",
        ),
    ] {
        let e = load_body(&format!("\n\n<shape type=\"cube\">\n{body}\n</shape>"))
            .err()
            .unwrap_or_else(|| panic!("accepted: {body}"));
        let text = e.to_string();
        assert!(text.contains(phrase), "{body}: {text}");
        assert!(text.starts_with("inline.xml:9:"), "{body}: {text}");
    }
    // An opaque principled may be two-sided.
    let s = ok(
        r#"<shape type="rectangle"><bsdf type="twosided"><bsdf type="principled"/></bsdf></shape>"#,
    )
    .scene;
    assert!(material(&s, 0).two_sided);
}

/// `<emitter type="envmap">`: an OpenEXR image (linear, unchanged), `scale`
/// and the rotation of `to_world`, looked up with Mitsuba's mapping
/// (texel column x at u = (x + ½)/W, φ = 2πu from −z towards +x, row 0
/// along +y).
#[test]
fn envmap_emitter_loads_float_images() {
    use cmlt::scene::Light;
    use exr::prelude::*;
    let dir = std::env::temp_dir().join(format!("cmlt-envmap-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    // 4 × 3: texel (x, y) = (x + 1, 10·y, 100).
    Image::from_channels(
        (4, 3),
        SpecificChannels::rgb(|p: Vec2<usize>| (p.x() as f32 + 1.0, 10.0 * p.y() as f32, 100.0)),
    )
    .write()
    .to_file(dir.join("sky.exr"))
    .unwrap();
    let xml = r#"<scene version="3.0.0">
      <sensor type="perspective"><float name="fov" value="40"/><film type="hdrfilm"><rfilter type="box"/></film></sensor>
      <shape type="rectangle"/>
      <emitter type="envmap">
        <string name="filename" value="sky.exr"/>
        <float name="scale" value="0.5"/>
        <boolean name="mis_compensation" value="true"/>
        <transform name="to_world"><rotate y="1" angle="90"/><translate x="5"/></transform>
      </emitter>
    </scene>"#;
    let l = load_scene_str(xml, &dir, "envmap.xml", &[]).unwrap_or_else(|e| panic!("{e}"));
    std::fs::remove_dir_all(&dir).ok();
    let s = &l.scene;
    let lights: Vec<Light> = s.lights.others().copied().collect();
    let Light::Envmap {
        bitmap,
        scale,
        to_world,
    } = lights[0]
    else {
        panic!("{:?}", lights[0])
    };
    assert_eq!(scale, 0.5);
    let b = &s.bitmaps[bitmap.0 as usize];
    assert_eq!((b.width(), b.height()), (4, 3));
    assert_eq!(
        b.eval(cmlt::math::Vec2::new(1.5 / 4.0, 2.5 / 3.0)),
        Rgb::new(2.0, 20.0, 100.0)
    );
    // Rotating by 90° about +y takes the emitter's −z to world −x.
    assert!(close(
        to_world * Vec3::new(0.0, 0.0, -1.0),
        Vec3::new(-1.0, 0.0, 0.0),
        1e-6
    ));
    // Texel column 1 (u = 3/8, φ = 3π/4) on the horizon (row 1): the
    // emitter-space direction (sin φ, 0, −cos φ), seen in world space.
    let phi = 0.75 * std::f32::consts::PI;
    let d = to_world * Vec3::new(phi.sin(), 0.0, -phi.cos());
    let le = s.lights.radiance(0, d);
    assert!(
        (le.r - 1.0).abs() < 1e-4 && (le.g - 5.0).abs() < 1e-4,
        "{le:?}"
    );
    assert!((le.b - 50.0).abs() < 1e-3, "{le:?}");
}

/// Mitsuba 3's `sunsky`: a valid one becomes the baked sky (an envmap whose
/// zenith is the emitter's +z turned by `to_world`) and the sun disc
/// (direction, aperture, the sun's radiance scaled by `sun_scale`; with
/// `complex_sun` a profile over the disc); a sun below the horizon gives
/// no light (Mitsuba's emitter is black); and each bad parameter is
/// refused at its own line with what is wrong.
#[test]
fn sunsky_loads_and_refuses_bad_parameters() {
    use cmlt::scene::Light;
    let body = |params: &str| {
        format!("<shape type=\"rectangle\"/>\n<emitter type=\"sunsky\">\n{params}\n</emitter>")
    };
    let rot = "<transform name=\"to_world\"><rotate x=\"1\" angle=\"-90\"/></transform>";
    let l = ok(&body(&format!(
        "<vector name=\"sun_direction\" x=\"0.5\" y=\"0.6\" z=\"-0.4\"/><float name=\"sun_scale\" value=\"2\"/>{rot}"
    )));
    let lights: Vec<Light> = l.scene.lights.others().copied().collect();
    assert_eq!(lights.len(), 2, "{lights:?}");
    let Light::Envmap { to_world, .. } = lights[0] else {
        panic!("{:?}", lights[0])
    };
    // The map's zenith (+y) is the emitter's +z, which to_world takes to +y.
    assert!(close(to_world * Vec3::Y, Vec3::Y, 1e-6));
    let Light::Sun {
        direction,
        radiance,
        half_aperture,
        profile: None,
    } = lights[1]
    else {
        panic!("{:?}", lights[1])
    };
    assert!(close(
        -direction,
        Vec3::new(0.5, 0.6, -0.4).normalize(),
        1e-6
    ));
    assert!((half_aperture - 0.2679).abs() < 1e-6);
    let unscaled = ok(&body(&format!(
        "<vector name=\"sun_direction\" x=\"0.5\" y=\"0.6\" z=\"-0.4\"/>{rot}"
    )));
    let Some(Light::Sun { radiance: r1, .. }) = unscaled.scene.lights.others().nth(1).copied()
    else {
        panic!("no sun")
    };
    assert!((radiance.g / r1.g - 2.0).abs() < 1e-5);
    // Without to_world the same direction is below the z-up horizon.
    let below = ok(&body(
        "<vector name=\"sun_direction\" x=\"0.5\" y=\"0.6\" z=\"-0.4\"/>",
    ));
    assert_eq!(below.scene.lights.others().count(), 0);
    assert!(
        below
            .warnings
            .iter()
            .any(|w| w.contains("below the horizon")),
        "{:?}",
        below.warnings
    );
    assert!(l.warnings.is_empty(), "{:?}", l.warnings);
    // complex_sun: the same sun with a profile over its disc whose zenith
    // is the emitter's +z turned by to_world (world +y).
    let complex = ok(&body(&format!(
        "<vector name=\"sun_direction\" x=\"0.5\" y=\"0.6\" z=\"-0.4\"/><boolean name=\"complex_sun\" value=\"true\"/>{rot}"
    )));
    let Some(Light::Sun {
        profile: Some(p),
        direction: d2,
        ..
    }) = complex.scene.lights.others().nth(1).copied()
    else {
        panic!("no complex sun")
    };
    assert!(close(p.up, Vec3::Y, 1e-6) && close(d2, direction, 1e-6));
    // Time and place (Mitsuba's defaults: Tokyo, 10 July 2010, 15:00).
    let timed = ok(&body(
        "<float name=\"hour\" value=\"11\"/><integer name=\"month\" value=\"3\"/>",
    ));
    assert_eq!(timed.scene.lights.others().count(), 2);
    let bad = [
        (
            "<float name=\"turbidity\" value=\"11\"/>",
            "'turbidity' must be in [1, 10]",
        ),
        (
            "<float name=\"sun_scale\" value=\"-1\"/>",
            "'sun_scale' must be non-negative",
        ),
        (
            "<float name=\"sun_aperture\" value=\"180\"/>",
            "'sun_aperture' must be in (0, 180)",
        ),
        (
            "<rgb name=\"albedo\" value=\"0.5, 1.5, 0\"/>",
            "'albedo' must be in [0, 1]",
        ),
        (
            "<texture type=\"checkerboard\" name=\"albedo\"/>",
            "albedo cannot be a texture",
        ),
        (
            "<vector name=\"sun_direction\" x=\"0\" y=\"1\" z=\"0\"/>\n<float name=\"hour\" value=\"3\"/>",
            "either 'sun_direction' or the time and place ('hour')",
        ),
        (
            "<vector name=\"sun_direction\" x=\"0\" y=\"0\" z=\"0\"/>",
            "finite and non-zero",
        ),
        (
            "<integer name=\"month\" value=\"13\"/>",
            "'month' must be in [1, 12]",
        ),
        (
            "<vector name=\"sun_color\" x=\"1\" y=\"1\" z=\"1\"/>",
            "unsupported property 'sun_color'",
        ),
        (
            "<transform name=\"to_world\"><scale value=\"2\"/></transform>",
            "to_world must be a rotation",
        ),
    ];
    for (params, phrase) in bad {
        let e = match load_body(&body(params)) {
            Ok(_) => panic!("{params}: loaded"),
            Err(e) => e,
        };
        // The scene's line 7 opens the emitter; its parameters start on 8
        // (the last one on 9 where there are two).
        assert!(e.message.contains(phrase), "{params}: {e}");
        assert!(matches!(e.line, Some(8 | 9)), "{params}: {e}");
    }
}
