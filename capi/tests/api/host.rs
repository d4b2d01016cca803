//! The host's intersector: garbage hits rejected, host shapes checked
//! and rendered through the callbacks.

use super::*;

/// A host intersector returning garbage: out-of-range primitives and NaN
/// distances are rejected and counted, never crash, and the image stays
/// finite.
#[test]
fn bad_host_hits_are_rejected() {
    unsafe extern "C" fn garbage(_: *mut c_void, ray: *const cmlt_ray, hit: *mut cmlt_hit) {
        // SAFETY: valid for the call.
        let (ray, hit) = unsafe { (&*ray, &mut *hit) };
        let odd = ray.dir[0] > 0.0;
        *hit = cmlt_hit {
            t: if odd { f32::NAN } else { 0.5 },
            u: 0.2,
            v: 0.2,
            prim_id: if odd { 3 } else { 1_000_000 },
        };
    }
    unsafe extern "C" fn never(_: *mut c_void, _: *const cmlt_ray) -> u32 {
        0
    }
    let host = cmlt_intersector {
        user: null_mut(),
        intersect: Some(garbage),
        occluded: Some(never),
        intersect_packet: None,
        occluded_packet: None,
    };
    let s = scene(Some(&host));
    let r = renderer(s, &config(CMLT_ESTIMATOR_PT, 1));
    let stats = prepare_render_stats(r, 16 * 12 * 2);
    assert!(stats.rejected_host_hits > 0);
    assert!(image(r).iter().all(|v| v.is_finite()));
    // SAFETY: handles from this test.
    unsafe {
        cmlt_renderer_release(r);
        cmlt_scene_release(s);
    }
}

/// The host's world for the shape tests: the floor and light of [`scene`]
/// as triangles, and one analytic sphere of radius 0.25 at (0, 0.25, 0)
/// resting on the floor, reported as host shape 0.
struct ShapeHost {
    /// Non-zero: the surface callback answers with a NaN normal.
    broken: bool,
    surface_calls: std::sync::atomic::AtomicU64,
}

const SPHERE_C: [f32; 3] = [0.0, 0.25, 0.0];
const SPHERE_R: f32 = 0.25;

/// Möller–Trumbore on triangle `tri` of the shared vertex array.
fn hit_triangle(tri: [u32; 3], o: [f32; 3], d: [f32; 3]) -> Option<(f32, f32, f32)> {
    use cmlt_core::math::Vec3;
    let p = |i: u32| Vec3::from_slice(&POSITIONS[3 * i as usize..]);
    let (a, b, c) = (p(tri[0]), p(tri[1]), p(tri[2]));
    let (o, d) = (Vec3::from_array(o), Vec3::from_array(d));
    let (e1, e2) = (b - a, c - a);
    let pv = d.cross(e2);
    let det = e1.dot(pv);
    if det.abs() < 1e-12 {
        return None;
    }
    let tv = o - a;
    let u = tv.dot(pv) / det;
    let qv = tv.cross(e1);
    let v = d.dot(qv) / det;
    let t = e2.dot(qv) / det;
    (u >= 0.0 && v >= 0.0 && u + v <= 1.0 && t > 1e-5).then_some((t, u, v))
}

/// The nearest sphere crossing in (0, tfar), in f64 (rays leave its
/// surface offset by the point's error bound only).
fn hit_sphere(o: [f32; 3], d: [f32; 3], tfar: f32) -> Option<(f32, f32, f32)> {
    let oc: Vec<f64> = (0..3).map(|i| (o[i] - SPHERE_C[i]) as f64).collect();
    let dd: Vec<f64> = d.iter().map(|&x| x as f64).collect();
    let a: f64 = dd.iter().map(|x| x * x).sum();
    let hb: f64 = (0..3).map(|i| oc[i] * dd[i]).sum();
    let c: f64 = oc.iter().map(|x| x * x).sum::<f64>() - (SPHERE_R as f64).powi(2);
    let disc = hb * hb - a * c;
    if disc.is_nan() || disc < 0.0 {
        return None;
    }
    let t = [(-hb - disc.sqrt()) / a, (-hb + disc.sqrt()) / a]
        .into_iter()
        .map(|t| t as f32)
        .find(|&t| t > 0.0 && t < tfar)?;
    let n: Vec<f32> = (0..3)
        .map(|i| (o[i] + t * d[i] - SPHERE_C[i]) / SPHERE_R)
        .collect();
    Some((t, n[1].clamp(-1.0, 1.0).acos(), n[2].atan2(n[0])))
}

unsafe extern "C" fn shape_host_intersect(
    _: *mut c_void,
    ray: *const cmlt_ray,
    hit: *mut cmlt_hit,
) {
    // SAFETY: valid for the call.
    let (ray, hit) = unsafe { (&*ray, &mut *hit) };
    hit.prim_id = cmlt_capi::host::CMLT_INVALID_ID;
    hit.t = ray.tfar;
    for (k, tri) in [[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]]
        .into_iter()
        .enumerate()
    {
        if let Some((t, u, v)) = hit_triangle(tri, ray.org, ray.dir).filter(|h| h.0 < hit.t) {
            *hit = cmlt_hit {
                t,
                u,
                v,
                prim_id: k as u32,
            };
        }
    }
    if let Some((t, u, v)) = hit_sphere(ray.org, ray.dir, hit.t) {
        *hit = cmlt_hit {
            t,
            u,
            v,
            prim_id: cmlt_capi::host::CMLT_SHAPE_BIT,
        };
    }
}

unsafe extern "C" fn shape_host_occluded(user: *mut c_void, ray: *const cmlt_ray) -> u32 {
    let mut hit = cmlt_hit {
        t: 0.0,
        u: 0.0,
        v: 0.0,
        prim_id: 0,
    };
    // SAFETY: forwarded from our caller.
    unsafe { shape_host_intersect(user, ray, &mut hit) };
    (hit.prim_id != cmlt_capi::host::CMLT_INVALID_ID) as u32
}

unsafe extern "C" fn shape_host_surface(
    user: *mut c_void,
    shape: u32,
    theta: f32,
    phi: f32,
    out: *mut cmlt_capi::host::cmlt_surface,
) -> u32 {
    // SAFETY: `user` is the test's ShapeHost; `out` is valid for the call.
    let (host, out) = unsafe { (&*(user as *const ShapeHost), &mut *out) };
    host.surface_calls
        .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    assert_eq!(shape, 0);
    let n = [
        theta.sin() * phi.cos(),
        theta.cos(),
        theta.sin() * phi.sin(),
    ];
    out.p = [0, 1, 2].map(|i| SPHERE_C[i] + SPHERE_R * n[i]);
    out.p_error = out.p.map(|x| x.abs() * 5.0 * f32::EPSILON);
    out.ng = if host.broken { [f32::NAN; 3] } else { n };
    out.ns = n;
    out.uv = [0.0, 0.0];
    1
}

/// Host shapes: argument checks of `cmlt_scene_add_shapes`, commit refused
/// without a host intersector (the scene stays editable), an analytic
/// sphere rendered through the callbacks (it changes the picture, and no
/// answer is rejected), and broken surface answers counted, never drawn.
#[test]
fn host_shapes_are_checked_and_rendered() {
    use cmlt_capi::host::cmlt_shapes;
    let make = |host: &ShapeHost, with_sphere: bool| -> *mut cmlt_scene {
        let s = floor_and_light();
        let shapes = cmlt_shapes {
            count: 1,
            material: 0,
            user: host as *const ShapeHost as *mut c_void,
            surface: Some(shape_host_surface),
        };
        let isect = cmlt_intersector {
            user: null_mut(),
            intersect: Some(shape_host_intersect),
            occluded: Some(shape_host_occluded),
            intersect_packet: None,
            occluded_packet: None,
        };
        // SAFETY: valid or deliberately invalid pointers.
        unsafe {
            if with_sphere {
                let f = "cmlt_scene_add_shapes";
                let mut first = 99;
                expect(
                    cmlt_scene_add_shapes(s, null(), &mut first),
                    CMLT_ERROR_NULL_POINTER,
                    f,
                );
                let bad = [
                    cmlt_shapes {
                        surface: None,
                        ..shapes
                    },
                    cmlt_shapes { count: 0, ..shapes },
                    cmlt_shapes {
                        material: 9,
                        ..shapes
                    },
                ];
                let want = [
                    CMLT_ERROR_NULL_POINTER,
                    CMLT_ERROR_INVALID_ARGUMENT,
                    CMLT_ERROR_INVALID_ARGUMENT,
                ];
                for (b, w) in bad.iter().zip(want) {
                    expect(cmlt_scene_add_shapes(s, b, &mut first), w, f);
                }
                assert_eq!(first, 99, "rejected shapes wrote an index");
                expect(cmlt_scene_add_shapes(s, &shapes, &mut first), CMLT_OK, f);
                assert_eq!(first, 0, "rejected groups took shape numbers");
                expect(
                    cmlt_scene_commit(s),
                    CMLT_ERROR_INVALID_OPERATION,
                    "cmlt_scene_commit",
                );
            }
            expect(
                cmlt_scene_set_intersector(s, &isect),
                CMLT_OK,
                "set_intersector",
            );
            expect(cmlt_scene_commit(s), CMLT_OK, "commit");
        }
        s
    };
    let render = |s: *mut cmlt_scene| {
        let r = renderer(s, &config(CMLT_ESTIMATOR_PT, 1));
        let stats = prepare_render_stats(r, 16 * 12 * 8);
        let img = image(r);
        // SAFETY: handles from this test.
        unsafe {
            cmlt_renderer_release(r);
            cmlt_scene_release(s);
        }
        (img, stats)
    };
    let host = ShapeHost {
        broken: false,
        surface_calls: Default::default(),
    };
    let (without, _) = render(make(&host, false));
    let (with, stats) = render(make(&host, true));
    assert!(
        host.surface_calls
            .load(std::sync::atomic::Ordering::Relaxed)
            > 0
    );
    assert_eq!(
        (stats.rejected_host_hits, stats.rejected_host_surfaces),
        (0, 0)
    );
    assert_eq!(stats.nonfinite, 0);
    let changed = with.iter().zip(&without).filter(|(a, b)| a != b).count();
    assert!(changed > 16, "the sphere changed {changed} pixel values");

    let broken = ShapeHost {
        broken: true,
        surface_calls: Default::default(),
    };
    let (img, stats) = render(make(&broken, true));
    assert!(stats.rejected_host_surfaces > 0);
    assert_eq!(stats.nonfinite, 0);
    assert!(img.iter().all(|v| v.is_finite()));
}
