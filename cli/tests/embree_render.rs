//! Renders through the Embree backend match renders through our BVH: the
//! same scene, seed and sample count give the same image statistics. The
//! backends differ only in the rounding of hit distances, so paths mostly
//! follow the same sample streams and the means agree to well within the
//! noise (pixels are not bit-identical: the last bits of hit points differ).
#![cfg(feature = "embree")]

mod common;

use cmlt::accel::bvh::Bvh;
use cmlt::accel::embree::EmbreeScene;
use cmlt::integrator::Method;
use cmlt_cli::image_io::Image;
use cmlt_cli::render::{Budget, render};

#[test]
fn embree_render_matches_bvh_render() {
    let (loaded, _) = common::load_reduced("cornell-box", 8);
    let tris: Vec<_> = loaded.scene.triangles().collect();
    let bvh = Bvh::build(&tris);
    let embree = EmbreeScene::new(&tris).expect("Embree device");
    let cam = &loaded.scene.camera;
    let image = |film: cmlt::film::Film| Image {
        width: cam.width() as usize,
        height: cam.height() as usize,
        pixels: film.resolve(),
    };
    for method in [Method::Path, Method::Bdpt] {
        let ours = render(
            &loaded.scene,
            &bvh,
            &loaded.settings,
            method,
            Budget::Spp(16),
            2,
            3,
            &|| {},
        );
        let theirs = render(
            &loaded.scene,
            &embree,
            &loaded.settings,
            method,
            Budget::Spp(16),
            2,
            3,
            &|| {},
        );
        let (a, b) = (image(ours.film), image(theirs.film));
        let (ma, mb) = (a.mean(), b.mean());
        for (x, y) in [(ma.r, mb.r), (ma.g, mb.g), (ma.b, mb.b)] {
            assert!(
                x > 0.0 && (x - y).abs() <= 0.01 * x,
                "{method:?}: mean {ma:?} vs {mb:?}"
            );
        }
    }
}
