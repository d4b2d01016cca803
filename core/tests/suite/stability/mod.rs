//! Hard cases stay numerically stable: small scenes built in
//! code, each rendered with every method — PT, BDPT, MLT and CMLT through
//! the host's frame loop (`cmlt::renderer`) — at a small budget. Every
//! render must give finite pixels and count no non-finite contribution;
//! where the answer is known (furnace scenes: a closed box of albedo a
//! emitting Le has radiance Le / (1 − a) everywhere, and anything of
//! albedo 1 that emits nothing is invisible in it), the image must give it,
//! otherwise the methods must agree with each other.
//!
//! The cases, by theme (the list is in `README.md` next to this file):
//! - [`geometry`]: grazing and edge-on surfaces, watertight closed meshes,
//!   self-intersection at scales 1e-4 and 1e6 and 1e5 from the origin;
//! - [`degenerate`]: zero-area and sliver triangles, duplicate vertices,
//!   zero-length normals;
//! - [`lights`]: lights touching walls and corners, grazing lights, tiny
//!   and huge lights, black scenes, lights the camera cannot see;
//! - [`materials`]: GGX α → 1e-4, total internal reflection, IOR 1 and < 1;
//! - [`parameters`]: extreme k, m, σ, image sizes; chains started on
//!   zero-contribution paths; multiple-try steps whose candidates are all
//!   zero;
//! - [`host_input`]: NaN/Inf/out-of-range values through the Rust API are
//!   rejected before rendering and leave everything usable.
//!
//! Renders are deterministic (fixed seeds, one worker), so the tolerances
//! below are margins around one fixed outcome, not flaky statistics.

mod degenerate;
mod geometry;
mod host_input;
mod lights;
mod materials;
mod parameters;

use crate::common;

use cmlt::accel::bvh::Bvh;
use cmlt::integrator::Settings;
use cmlt::math::{Mat4, Rgb, Vec3};
use cmlt::mlt::{CmltSettings, Level2Settings, MltSettings};
use cmlt::renderer::{
    Estimator, EstimatorKind, RenderStats, RenderWorker, Renderer, RendererConfig,
};
use cmlt::scene::{Camera, FovAxis, Material, MaterialId, Mesh, Scene, SceneBuilder};

/// Every estimator (CMLT is MLT with level 2).
pub const ALL: [EstimatorKind; 4] = EstimatorKind::ALL;

/// Small MLT settings: a few hundred bootstrap samples, two normalisation
/// passes, 32 chains.
pub fn small_mlt() -> MltSettings {
    MltSettings {
        n_bootstrap: 256,
        b_passes: 2,
        b_min_samples: 0,
        n_chains: 32,
        ..MltSettings::default()
    }
}

/// The configuration of `method` at path depth `max_depth` (None: the
/// renderer's cap of 32 segments): MLT with [`small_mlt`], CMLT adding
/// k = 4, m = 2, lens σ = 2 px and side chains on every path.
pub fn config(method: EstimatorKind, max_depth: Option<u32>) -> RendererConfig {
    let estimator = match method {
        EstimatorKind::Path => Estimator::Path,
        EstimatorKind::Bdpt => Estimator::Bdpt,
        EstimatorKind::Mlt => Estimator::Mlt(small_mlt()),
        EstimatorKind::Cmlt => Estimator::Cmlt(CmltSettings {
            mlt: small_mlt(),
            level2: Level2Settings {
                k: 4,
                m: 2,
                lens_sigma: 2.0,
                side_chain_min_depth: 0,
                ..Level2Settings::default()
            },
        }),
    };
    RendererConfig {
        estimator,
        settings: Settings {
            max_depth,
            ..Settings::default()
        },
        seed: 3,
        ..RendererConfig::default()
    }
}

/// `cfg` with its level-1 settings (MLT's, CMLT's level 1) changed by `f`.
pub fn with_mlt(mut cfg: RendererConfig, f: impl FnOnce(&mut MltSettings)) -> RendererConfig {
    f(cfg.estimator.mlt_mut().expect("MLT or CMLT"));
    cfg
}

/// `cfg` (CMLT) with its level-2 settings changed by `f`.
pub fn with_level2(mut cfg: RendererConfig, f: impl FnOnce(&mut Level2Settings)) -> RendererConfig {
    match &mut cfg.estimator {
        Estimator::Cmlt(c) => f(&mut c.level2),
        other => panic!("{other:?} has no level 2"),
    }
    cfg
}

/// One finished render.
pub struct Render {
    pub what: String,
    pub img: Vec<Rgb>,
    pub stats: RenderStats,
    pub width: usize,
}

impl Render {
    /// Mean of the green channel (the scenes are grey).
    pub fn mean(&self) -> f64 {
        self.img.iter().map(|c| c.g as f64).sum::<f64>() / self.img.len() as f64
    }

    /// Mean of the pixels whose column is in `cols` and row in `rows`.
    pub fn region_mean(&self, cols: core::ops::Range<usize>, rows: core::ops::Range<usize>) -> f64 {
        let mut s = 0.0;
        let mut n = 0;
        for y in rows {
            for x in cols.clone() {
                s += self.img[y * self.width + x].g as f64;
                n += 1;
            }
        }
        s / n as f64
    }

    /// Every pixel finite and non-negative, and no non-finite contribution
    /// dropped by the film.
    pub fn assert_finite(&self) -> &Self {
        assert_eq!(self.stats.nonfinite, 0, "{}: non-finite samples", self.what);
        if let Some((i, c)) = self
            .img
            .iter()
            .enumerate()
            .find(|(_, c)| !(c.is_finite() && c.r >= 0.0 && c.g >= 0.0 && c.b >= 0.0))
        {
            panic!("{}: pixel {i} is {c:?}", self.what);
        }
        self
    }

    /// The mean is `expected` to a relative `tol`.
    pub fn assert_mean(&self, expected: f64, tol: f64) -> &Self {
        let m = self.mean();
        assert!(
            (m - expected).abs() <= tol * expected.abs().max(1e-30),
            "{}: mean {m}, expected {expected} ± {:.1}%",
            self.what,
            100.0 * tol
        );
        self
    }

    /// Every pixel is exactly zero.
    pub fn assert_black(&self) -> &Self {
        assert!(
            self.img.iter().all(|c| *c == Rgb::ZERO),
            "{}: not black, mean {}",
            self.what,
            self.mean()
        );
        self
    }
}

/// Renders `scene` with `cfg` (camera: the scene's) for `units_per_pixel`
/// samples or mutations per pixel, through the renderer API with one
/// worker, tracing with our BVH.
pub fn render_cfg(what: &str, scene: &Scene, cfg: RendererConfig, units_per_pixel: u64) -> Render {
    let bvh = Bvh::build(&scene.triangles().collect::<Vec<_>>());
    let cam = scene.camera;
    let mut r = Renderer::new(cfg, cam).unwrap_or_else(|e| panic!("{what}: {e}"));
    let mut w = RenderWorker::new(&r, 0).unwrap();
    crate::common::prepare(&mut r, std::slice::from_mut(&mut w), scene, &bvh);
    let pixels = cam.width() as u64 * cam.height() as u64;
    r.render(&mut w, scene, &bvh, units_per_pixel * pixels)
        .unwrap();
    let mut img = vec![Rgb::ZERO; pixels as usize];
    r.resolve(&[&w], |i, c| img[i] = c).unwrap();
    Render {
        what: format!(
            "{what} [{:?}, m {}]",
            cfg.estimator.kind(),
            cfg.estimator.level2().map_or(0, |l| l.m)
        ),
        img,
        stats: r.stats(&[&w]),
        width: cam.width() as usize,
    }
}

/// Renders `scene` with `method`'s small configuration.
pub fn render(
    what: &str,
    scene: &Scene,
    method: EstimatorKind,
    max_depth: Option<u32>,
    units_per_pixel: u64,
) -> Render {
    let mut r = render_cfg(what, scene, config(method, max_depth), units_per_pixel);
    r.what = format!("{what} [{method:?}]");
    r
}

/// Relative tolerance of a furnace mean for each method at the budgets used
/// here (MLT's mean is its normalisation b, from two BDPT passes).
pub fn furnace_tol(method: EstimatorKind) -> f64 {
    if method.is_metropolis() { 0.05 } else { 0.03 }
}

/// An axis-aligned box `lo..hi` of 12 triangles over 8 shared vertices,
/// wound so its normals point inwards (`inward`) or outwards.
pub fn cuboid(lo: Vec3, hi: Vec3, material: MaterialId, inward: bool) -> Mesh {
    let p = |i: u32| {
        Vec3::new(
            if i & 1 == 0 { lo.x } else { hi.x },
            if i & 2 == 0 { lo.y } else { hi.y },
            if i & 4 == 0 { lo.z } else { hi.z },
        )
    };
    let positions: Vec<Vec3> = (0..8).map(p).collect();
    let centre = (lo + hi) * 0.5;
    // Two triangles per face (axis, side), each a quad's diagonal split.
    let faces: [[u32; 4]; 6] = [
        [0, 2, 6, 4], // x = lo
        [1, 3, 7, 5], // x = hi
        [0, 1, 5, 4], // y = lo
        [2, 3, 7, 6], // y = hi
        [0, 1, 3, 2], // z = lo
        [4, 5, 7, 6], // z = hi
    ];
    let mut indices = Vec::new();
    for f in faces {
        for t in [[f[0], f[1], f[2]], [f[0], f[2], f[3]]] {
            let [a, b, c] = t.map(|i| positions[i as usize]);
            let n = (b - a).cross(c - a);
            let outward = n.dot(a - centre) > 0.0;
            indices.push(if outward != inward {
                t
            } else {
                [t[0], t[2], t[1]]
            });
        }
    }
    Mesh {
        positions,
        normals: vec![],
        uvs: vec![],
        indices,
        material,
        emission: None,
    }
}

/// A quad `o + s·u + t·v`, s, t ∈ [0, 1], facing `u × v`.
pub fn quad(o: Vec3, u: Vec3, v: Vec3, material: MaterialId, emission: Option<f32>) -> Mesh {
    Mesh {
        positions: vec![o, o + u, o + u + v, o + v],
        normals: vec![],
        uvs: vec![],
        indices: vec![[0, 1, 2], [0, 2, 3]],
        material,
        emission: emission.map(Rgb::splat),
    }
}

/// A pinhole camera at `pos` looking at `target` (up +y), `fov` degrees
/// horizontally, `w × h` pixels.
pub fn look_at(pos: Vec3, target: Vec3, fov: f32, w: u32, h: u32) -> Camera {
    // Mitsuba's look_at: local +z forward, +x = up × forward (image left).
    let z = (target - pos).normalize();
    let x = Vec3::Y.cross(z).normalize();
    let y = z.cross(x);
    let to_world = Mat4::from_cols(x.extend(0.0), y.extend(0.0), z.extend(0.0), pos.extend(1.0));
    Camera::perspective(to_world, fov, FovAxis::X, w, h, 0.0, 1.0).unwrap()
}

/// The furnace: the box [-1, 1]³ (times `scale`, moved by `offset`) of
/// diffuse albedo ½ emitting 1 inwards, with `extra` meshes (made by the
/// closure from the wall's material id and an albedo-1 white's id, in the
/// same scaled frame), seen by a 16×12 camera inside. Radiance 2
/// everywhere as long as the extras are white and dark or furnace-like.
pub fn furnace_with(
    scale: f32,
    offset: Vec3,
    extra: impl FnOnce(MaterialId, MaterialId, &mut SceneBuilder),
) -> Scene {
    let mut b = SceneBuilder::new();
    let wall = b.add_material(Material::diffuse(Rgb::splat(0.5)));
    let white = b.add_material(Material::diffuse(Rgb::splat(1.0)));
    let mut mesh = cuboid(Vec3::splat(-1.0), Vec3::splat(1.0), wall, true);
    mesh.emission = Some(Rgb::ONE);
    b.add_mesh(mesh);
    extra(wall, white, &mut b);
    let cam_pos = Vec3::new(0.1, -0.2, -0.6) * scale + offset;
    b.set_camera(look_at(
        cam_pos,
        cam_pos + Vec3::new(0.0, 0.0, scale),
        70.0,
        16,
        12,
    ));
    // Built at unit scale, then every vertex scaled and moved (the camera
    // above is already in the scaled frame).
    transformed(b.build().unwrap(), |p| p * scale + offset)
}

/// `scene` with every vertex moved by `f` (camera unchanged).
pub fn transformed(scene: Scene, f: impl Fn(Vec3) -> Vec3) -> Scene {
    let mut b = SceneBuilder::new();
    for m in &scene.materials {
        b.add_material(*m);
    }
    for m in &scene.meshes {
        let mut m = m.clone();
        for p in &mut m.positions {
            *p = f(*p);
        }
        b.add_mesh(m);
    }
    b.set_camera(scene.camera);
    b.build().unwrap()
}

/// The plain furnace at unit scale.
pub fn furnace() -> Scene {
    furnace_with(1.0, Vec3::ZERO, |_, _, _| {})
}
