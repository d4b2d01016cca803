//! `cmlt-bench outputs`: what a host's per-frame outputs cost — the
//! resolve of the rendered image in each pixel format, against the resolve
//! the C API did before [`Renderer::resolve_rows`] (accumulate worker by
//! worker, then one callback per pixel, sRGB encoded with `powf`), and the
//! auxiliary outputs for a denoiser ([`cmlt::aov`]).
//!
//! Every variant runs in turns (one of each, then again, `repeats` times)
//! in one process, so a change in the machine's load hits all alike; the
//! table gives each one's median and its ratio to the baseline of the same
//! pixel format. The new resolve's bytes are checked against the baseline's
//! (identical for the formats that existed).

use std::time::Instant;

use cmlt::aov::{AovBuffers, AovFormat, AovLayer};
use cmlt::film::PixelFormat;
use cmlt::math::Rgb;
use cmlt::math::spectrum::linear_to_srgb;
use cmlt::renderer::{Accumulator, RenderWorker, Renderer, RendererConfig};
use cmlt::scene::Scene;
use cmlt_cli::accel::Accel;

use crate::prepare::median;

/// One measured variant: its name, the format it writes, its times (s).
#[derive(Clone, Debug)]
pub struct Measured {
    /// What ran.
    pub name: &'static str,
    /// The baseline it is compared with (its own name for a baseline).
    pub baseline: &'static str,
    /// Seconds per call, one entry per turn.
    pub times: Vec<f64>,
}

/// The resolve the C API did before `resolve_rows` (its code, kept here as
/// the baseline): every worker accumulated into f64 sums, then one callback
/// per pixel writing the format, sRGB through `linear_to_srgb`'s `powf`.
fn resolve_before(
    r: &Renderer,
    workers: &[RenderWorker],
    acc: &mut Accumulator,
    format: PixelFormat,
    out: &mut [u8],
) {
    for w in workers {
        r.accumulate(acc, w).expect("own workers");
    }
    let px = format.bytes();
    r.finish(acc, |i, c: Rgb| {
        let p = &mut out[i * px..(i + 1) * px];
        if format == PixelFormat::Rgb32F {
            p[0..4].copy_from_slice(&c.r.to_ne_bytes());
            p[4..8].copy_from_slice(&c.g.to_ne_bytes());
            p[8..12].copy_from_slice(&c.b.to_ne_bytes());
        } else {
            let enc = |v: f32| (linear_to_srgb(v.clamp(0.0, 1.0)) * 255.0 + 0.5) as u8;
            p[0] = enc(c.r);
            p[1] = enc(c.g);
            p[2] = enc(c.b);
            p[3] = 255;
        }
    })
    .expect("own accumulator");
}

/// `resolve_rows` over the whole image, split into `bands` bands of rows
/// each resolved on its own scoped thread (1: on the calling thread).
fn resolve_split(
    r: &Renderer,
    workers: &[RenderWorker],
    format: PixelFormat,
    out: &mut [u8],
    bands: u32,
) {
    let h = r.camera().height();
    let row = r.camera().width() as usize * format.bytes();
    if bands <= 1 {
        r.resolve_rows(workers, 0..h, format, out, 0)
            .expect("valid rows");
        return;
    }
    let per = h.div_ceil(bands);
    let image = &mut out[..h as usize * row];
    std::thread::scope(|s| {
        for (i, band) in image.chunks_mut(per as usize * row).enumerate() {
            let y0 = i as u32 * per;
            let y1 = (y0 + per).min(h);
            s.spawn(move || {
                r.resolve_rows(workers, y0..y1, format, band, 0)
                    .expect("valid rows")
            });
        }
    });
}

/// A renderer of `config` over `scene` with its workers, each having
/// rendered `passes` passes (an image to resolve).
pub fn rendered(
    scene: &Scene,
    accel: &Accel,
    config: RendererConfig,
    passes: u64,
) -> Result<(Renderer, Vec<RenderWorker>), String> {
    let mut r = Renderer::new(config, scene.camera).map_err(|e| e.to_string())?;
    let mut workers = (0..config.workers)
        .map(|i| RenderWorker::new(&r, i))
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| e.to_string())?;
    cmlt_cli::render::prepare(&mut r, &mut workers, scene, accel)?;
    for w in &mut workers {
        r.render_steps(w, scene, accel, passes)
            .map_err(|e| e.to_string())?;
    }
    Ok((r, workers))
}

/// Times every resolve variant and the auxiliary outputs `repeats` times
/// in turns over a rendered image; errors if a new resolve's bytes differ
/// from the baseline's for a format both write.
pub fn run(
    scene: &Scene,
    accel: &Accel,
    r: &Renderer,
    workers: &[RenderWorker],
    repeats: usize,
) -> Result<Vec<Measured>, String> {
    let cam = *r.camera();
    let pixels = cam.pixel_count() as usize;
    let mut acc = r.accumulator();
    let mut before = vec![0u8; pixels * 16];
    let mut after = vec![0u8; pixels * 16];
    for format in [PixelFormat::Rgb32F, PixelFormat::Rgba8Srgb] {
        let n = pixels * format.bytes();
        resolve_before(r, workers, &mut acc, format, &mut before[..n]);
        resolve_split(r, workers, format, &mut after[..n], 1);
        if before[..n] != after[..n] {
            return Err(format!(
                "{format:?}: resolve_rows differs from the old resolve"
            ));
        }
        resolve_split(r, workers, format, &mut after[..n], 2);
        if before[..n] != after[..n] {
            return Err(format!("{format:?}: two bands differ from one call"));
        }
    }
    let mut aov = AovStorage::new(pixels);
    let variants: [(&str, &str); 11] = [
        ("before rgb32f", "before rgb32f"),
        ("rows rgb32f", "before rgb32f"),
        ("rows rgba32f", "before rgb32f"),
        ("rows rgba16f", "before rgb32f"),
        ("before rgba8-srgb", "before rgba8-srgb"),
        ("rows rgba8-srgb", "before rgba8-srgb"),
        ("rows rgba8-srgb 2 bands", "before rgba8-srgb"),
        ("aov all f32", "aov all f32"),
        ("aov all f16", "aov all f32"),
        ("aov all f32 2 bands", "aov all f32"),
        ("aov depth+motion f32", "aov all f32"),
    ];
    let mut out: Vec<Measured> = variants
        .iter()
        .map(|&(name, baseline)| Measured {
            name,
            baseline,
            times: Vec::with_capacity(repeats),
        })
        .collect();
    let previous = cam; // a still camera: motion is measured, not its size
    for _ in 0..repeats {
        for m in out.iter_mut() {
            let t = Instant::now();
            match m.name {
                "before rgb32f" => {
                    resolve_before(r, workers, &mut acc, PixelFormat::Rgb32F, &mut before)
                }
                "rows rgb32f" => resolve_split(r, workers, PixelFormat::Rgb32F, &mut after, 1),
                "rows rgba32f" => resolve_split(r, workers, PixelFormat::Rgba32F, &mut after, 1),
                "rows rgba16f" => resolve_split(r, workers, PixelFormat::Rgba16F, &mut after, 1),
                "before rgba8-srgb" => {
                    resolve_before(r, workers, &mut acc, PixelFormat::Rgba8Srgb, &mut before)
                }
                "rows rgba8-srgb" => {
                    resolve_split(r, workers, PixelFormat::Rgba8Srgb, &mut after, 1)
                }
                "rows rgba8-srgb 2 bands" => {
                    resolve_split(r, workers, PixelFormat::Rgba8Srgb, &mut after, 2)
                }
                "aov all f32" => aov.run(scene, accel, &cam, &previous, AovFormat::F32, 1, true)?,
                "aov all f16" => aov.run(scene, accel, &cam, &previous, AovFormat::F16, 1, true)?,
                "aov all f32 2 bands" => {
                    aov.run(scene, accel, &cam, &previous, AovFormat::F32, 2, true)?
                }
                "aov depth+motion f32" => {
                    aov.run(scene, accel, &cam, &previous, AovFormat::F32, 1, false)?
                }
                other => unreachable!("{other}"),
            }
            m.times.push(t.elapsed().as_secs_f64());
        }
    }
    Ok(out)
}

/// Buffers for every auxiliary output of an image, big enough for f32.
struct AovStorage {
    albedo: Vec<u8>,
    normal: Vec<u8>,
    depth: Vec<u8>,
    motion: Vec<u8>,
}

impl AovStorage {
    fn new(pixels: usize) -> Self {
        AovStorage {
            albedo: vec![0; pixels * 12],
            normal: vec![0; pixels * 12],
            depth: vec![0; pixels * 4],
            motion: vec![0; pixels * 8],
        }
    }

    /// Every output (or only depth and motion, what a temporal upscaler
    /// reads) in `format`, split into `bands` bands of rows on scoped
    /// threads.
    #[allow(clippy::too_many_arguments)]
    fn run(
        &mut self,
        scene: &Scene,
        accel: &Accel,
        camera: &cmlt::scene::Camera,
        previous: &cmlt::scene::Camera,
        format: AovFormat,
        bands: u32,
        all: bool,
    ) -> Result<(), String> {
        let (w, h) = (camera.width() as usize, camera.height());
        let per = h.div_ceil(bands.max(1));
        let layer = |c: usize| w * c * format.bytes();
        let err = |e: cmlt::renderer::RenderError| e.to_string();
        std::thread::scope(|s| {
            let mut handles = Vec::new();
            let mut albedo = self.albedo.chunks_mut(per as usize * layer(3));
            let mut normal = self.normal.chunks_mut(per as usize * layer(3));
            let mut depth = self.depth.chunks_mut(per as usize * layer(1));
            let mut motion = self.motion.chunks_mut(per as usize * layer(2));
            for y0 in (0..h).step_by(per as usize) {
                let y1 = (y0 + per).min(h);
                let (a, n) = (albedo.next(), normal.next());
                let (d, m) = (depth.next(), motion.next());
                let buffers = AovBuffers {
                    albedo: a.filter(|_| all).map(|b| AovLayer::packed(b, format)),
                    normal: n.filter(|_| all).map(|b| AovLayer::packed(b, format)),
                    depth: d.map(|b| AovLayer::packed(b, format)),
                    motion: m.map(|b| AovLayer::packed(b, format)),
                };
                let job = move || {
                    let mut buffers = buffers;
                    cmlt::aov::render_rows(scene, accel, camera, previous, y0..y1, &mut buffers)
                        .map_err(err)
                };
                if bands <= 1 {
                    job()?;
                } else {
                    handles.push(s.spawn(job));
                }
            }
            handles
                .into_iter()
                .try_for_each(|h| h.join().expect("aov thread panicked"))
        })
    }
}

/// Prints the table: each variant's median in ms and the baseline's median
/// over its own (> 1 = faster than the baseline).
pub fn print(title: &str, rows: &[Measured]) {
    println!("{title}");
    println!("{:<26} {:>10} {:>10}", "variant", "median ms", "speed-up");
    let med = |name: &str| {
        rows.iter()
            .find(|m| m.name == name)
            .map_or(f64::NAN, |m| median(&m.times))
    };
    for m in rows {
        let own = median(&m.times);
        println!(
            "{:<26} {:>10.3} {:>9.2}x",
            m.name,
            1e3 * own,
            med(m.baseline) / own
        );
    }
}
