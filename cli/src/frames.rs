//! Frame-by-frame rendering from the command line (`cmlt render --frames
//! N --orbit`): the core's frame loop ([`cmlt::renderer`]) with one worker
//! per thread — [`crate::render`]'s preparation and render loop, once per
//! frame — the camera orbiting the point it looks at, every frame written
//! as a numbered file.

use std::path::{Path, PathBuf};
use std::time::Instant;

use cmlt::accel::Intersector;
use cmlt::accel::backend::Accel;
use cmlt::math::{Rgb, Vec2, Vec3};
use cmlt::renderer::{Accumulation, Budget, PixelBlock, RenderWorker, Renderer, RendererConfig};
use cmlt::scene::{Camera, Scene};

use crate::image_io::Image;
use crate::render;

/// The point `camera` looks at: the first surface along its central ray,
/// or the focus distance along the axis when that ray leaves the scene.
pub fn look_at_point<I: Intersector>(camera: &Camera, accel: &I) -> Vec3 {
    let centre = Vec2::new(camera.width() as f32, camera.height() as f32) * 0.5;
    let ray = camera.generate_ray(centre, Vec2::splat(0.5));
    match accel.intersect(&ray) {
        Some(hit) => ray.at(hit.t),
        None => camera.position() + camera.forward() * camera.focus_distance(),
    }
}

/// The camera of frame `f` of `frames` on an orbit of `degrees` in total
/// about the vertical (the camera's up axis) through `pivot`.
pub fn orbit_camera(start: &Camera, pivot: Vec3, degrees: f32, f: usize, frames: usize) -> Camera {
    let angle = (degrees.to_radians()) * f as f32 / frames.max(1) as f32;
    start.orbited(pivot, start.up(), angle)
}

/// `out.exr` → `out-0007.exr` (same folder and extension).
pub fn frame_path(output: &Path, f: usize) -> PathBuf {
    let stem = output
        .file_stem()
        .map_or("frame".into(), |s| s.to_string_lossy().into_owned());
    let name = match output.extension() {
        Some(e) => format!("{stem}-{f:04}.{}", e.to_string_lossy()),
        None => format!("{stem}-{f:04}"),
    };
    output.with_file_name(name)
}

/// What one frame produced.
pub struct FrameResult {
    /// The image.
    pub image: Image,
    /// The normalisation used (MLT; 0 otherwise).
    pub b: f64,
    /// Wall time of the frame (prepare + render + resolve).
    pub seconds: f64,
}

/// Renders `frames` frames with `cfg` (one worker per `cfg.workers`
/// thread, the bootstrap spread over them), each of `per_pixel` samples or
/// mutations per pixel over all workers ([`Renderer::steps_for`]), carried
/// from frame to frame by `accumulation`, at the pixel block `pixel_block`
/// ([`Renderer::set_pixel_block`]), the camera of frame `f` given by
/// `camera_at(f)`, handing each finished frame to `on_frame`.
#[allow(clippy::too_many_arguments)]
pub fn render_frames(
    scene: &Scene,
    accel: &Accel,
    cfg: RendererConfig,
    frames: usize,
    per_pixel: u64,
    accumulation: Accumulation,
    pixel_block: PixelBlock,
    camera_at: impl Fn(usize) -> Camera,
    mut on_frame: impl FnMut(usize, FrameResult) -> Result<(), String>,
) -> Result<(), String> {
    let first = camera_at(0);
    // One film per worker, the resolved frame and the renderer's own.
    render::check_film_memory(first.width(), first.height(), cfg.workers as usize + 2)?;
    let mut renderer = Renderer::new(cfg, first).map_err(|e| e.to_string())?;
    renderer
        .set_accumulation(accumulation)
        .map_err(|e| e.to_string())?;
    renderer
        .set_pixel_block(pixel_block)
        .map_err(|e| e.to_string())?;
    let mut workers: Vec<RenderWorker> = (0..cfg.workers)
        .map(|i| RenderWorker::new(&renderer, i))
        .collect::<Result<_, _>>()
        .map_err(|e| e.to_string())?;
    let (w, h) = (
        renderer.camera().width() as usize,
        renderer.camera().height() as usize,
    );
    let mut pixels = vec![Rgb::ZERO; w * h];
    for f in 0..frames {
        let t0 = Instant::now();
        renderer
            .set_camera(camera_at(f))
            .map_err(|e| e.to_string())?;
        render::prepare(&mut renderer, &mut workers, scene, accel)?;
        render::render_workers(
            &renderer,
            &mut workers,
            scene,
            accel,
            Budget::PerPixel(per_pixel),
            None,
            &|_| {},
        )?;
        let refs: Vec<&RenderWorker> = workers.iter().collect();
        renderer
            .resolve(&refs, |i, c| pixels[i] = c)
            .map_err(|e| e.to_string())?;
        on_frame(
            f,
            FrameResult {
                image: Image {
                    width: w,
                    height: h,
                    pixels: pixels.clone(),
                },
                b: renderer.b(),
                seconds: t0.elapsed().as_secs_f64(),
            },
        )?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_paths_are_numbered_next_to_the_output() {
        assert_eq!(
            frame_path(Path::new("out/a.exr"), 7),
            PathBuf::from("out/a-0007.exr")
        );
        assert_eq!(frame_path(Path::new("b"), 12), PathBuf::from("b-0012"));
    }
}
