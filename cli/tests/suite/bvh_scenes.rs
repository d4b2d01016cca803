//! The default BVH agrees with brute-force intersection on every shared
//! scene: 10,000 random rays each (origins inside the scene bounds, uniform
//! directions), same hit or miss, same primitive (or the same distance when
//! coplanar triangles tie), and the same occlusion answer. The same rays
//! as an interleaved stream give each ray's own answer bit for bit.

use crate::common;

use cmlt::accel::bvh::Bvh;
use cmlt::accel::{BruteForce, Intersector};
use cmlt::geometry::Ray;
use cmlt::math::Vec3;
use cmlt::sampler::SampleStream;
use cmlt_cli::mitsuba::load_scene;

/// Compares the BVH with brute force on [`RAYS`] rays in the scene.
fn check(name: &str) {
    let dir = common::scenes_dir().join(name);
    let loaded = load_scene(&dir.join("scene.xml"), &[]).expect("scene loads");
    let tris: Vec<[Vec3; 3]> = loaded.scene.triangles().collect();
    let bvh = Bvh::build(&tris);
    let brute = BruteForce::new(tris.iter().copied());
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for t in &tris {
        for p in t {
            lo = lo.min(*p);
            hi = hi.max(*p);
        }
    }
    let mut rng = SampleStream::new(42, 0, name.len() as u64);
    let mut hits = 0;
    let mut all = Vec::with_capacity(RAYS);
    for i in 0..RAYS {
        let o = lo + (hi - lo) * Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
        let d = cmlt::math::warp::square_to_uniform_sphere(rng.next_2d());
        let t_max = if i % 3 == 0 {
            (hi - lo).length() * rng.next_f32()
        } else {
            f32::INFINITY
        };
        let ray = Ray { o, d, t_max };
        all.push(ray);
        let a = bvh.intersect(&ray);
        let b = brute.intersect(&ray);
        match (a, b) {
            (None, None) => {}
            (Some(a), Some(b)) => {
                hits += 1;
                assert!(
                    a.prim == b.prim || (a.t - b.t).abs() <= 1e-5 * b.t.max(1.0),
                    "{name}: ray {i}: bvh {a:?} vs brute {b:?}"
                );
                assert!(
                    (a.t - b.t).abs() <= 1e-5 * b.t.max(1.0),
                    "{name}: ray {i}: t {} vs {}",
                    a.t,
                    b.t
                );
            }
            _ => panic!("{name}: ray {i}: bvh {a:?} vs brute {b:?}"),
        }
        // Any hit in (0, t_max) is an occluder: the brute-force closest hit
        // decides occlusion too.
        assert_eq!(
            bvh.occluded(&ray),
            b.is_some(),
            "{name}: ray {i}: occlusion differs"
        );
    }
    // Interleaving forced: these trees are below the default size for it.
    let stream = bvh.view().with_interleave_from(0);
    let mut got = vec![None; all.len()];
    let mut occ = vec![false; all.len()];
    stream.intersect_stream(&all, &mut got);
    stream.occluded_stream(&all, &mut occ);
    for (i, ray) in all.iter().enumerate() {
        assert_eq!(
            got[i],
            bvh.intersect(ray),
            "{name}: ray {i}: stream differs"
        );
        assert_eq!(
            occ[i],
            bvh.occluded(ray),
            "{name}: ray {i}: stream occlusion differs"
        );
    }
    assert!(
        hits > RAYS / 10,
        "{name}: too few hits ({hits}) for a meaningful comparison"
    );
}

/// Rays per scene. Brute force is the oracle and costs up to 1.6 ms a ray
/// on these scenes (veach-mis, veach-bidir); the core's `bvh` tests cover
/// the tree's corner cases (soups, identical triangles, spheres, fans).
const RAYS: usize = 10_000;

#[test]
fn cornell_box() {
    check("cornell-box");
}

#[test]
fn veach_mis() {
    check("veach-mis");
}

#[test]
fn veach_bidir() {
    check("veach-bidir");
}

#[test]
fn veach_ajar() {
    check("veach-ajar");
}
