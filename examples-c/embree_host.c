/*
 * embree_host.c — the host owns an Embree scene and traces cmlt's rays.
 *
 * Shows: an engine that already uses Embree 3 keeps its RTCScene and serves
 * cmlt's callbacks with rtcIntersect1/rtcOccluded1 for single rays and
 * rtcIntersect4/8/16 and rtcOccluded4/8/16 for packets (SoA copies into
 * 16/32/64-byte aligned RTCRayHitN, valid masks of -1/0, ray masks of -1,
 * coherent context flags for the bundles). Embree's primID is cmlt's
 * triangle number because the host put all triangles into one geometry
 * in cmlt's order. The same frame is rendered with cmlt's own BVH; both
 * means are printed. Built only when Embree is present.
 *
 * Usage: embree_host [pt|bdpt|mlt|cmlt] [BUDGET_PER_PIXEL]
 */
#include <embree3/rtcore.h>
#include <float.h>

#include "example_scene.h"

/* ---- The scene: floor, light and a tessellated mirror sphere. ---- */

/* The floor (triangles 0–1), the light (2–3), the sphere (4–). */
static void build_host_scene(host_scene *hs) {
    build_floor_and_light(hs);
    add_sphere(hs, 0.0f, 0.7f, 0.0f, 0.6f, 12, 24);
}

/* Builds the cmlt scene from the host arrays; with `isect` given, cmlt
 * traces through the callbacks instead of its own BVH. */
static cmlt_scene *make_scene(host_scene *hs, const cmlt_intersector *isect) {
    uint32_t m_white, m_mirror, first;
    cmlt_mesh mesh;
    /* Three meshes over the one host vertex array: floor (2 triangles),
     * light (2), sphere (the rest). Triangle numbers are the host's. */
    cmlt_scene *scene = begin_scene(hs, &m_white, &m_mirror, &mesh);
    mesh.indices = &hs->tris[4][0];
    mesh.triangle_count = hs->ntris - 4;
    mesh.material = m_mirror;
    check(cmlt_scene_add_mesh(scene, &mesh, &first), "add_mesh sphere");
    if (first != 4) {
        fprintf(stderr, "unexpected triangle numbering\n");
        exit(1);
    }
    if (isect) check(cmlt_scene_set_intersector(scene, isect), "cmlt_scene_set_intersector");
    check(cmlt_scene_commit(scene), "cmlt_scene_commit");
    return scene;
}

/* Renders the host's scene traced by `isect` and by cmlt's own BVH and
 * prints both means, the callback counts and the rejected hits (the tests
 * read these lines). */
static void compare_with_our_bvh(host_scene *hs, const cmlt_intersector *isect, uint32_t estimator,
                                 uint64_t per_pixel) {
    cmlt_scene *host_traced = make_scene(hs, isect);
    cmlt_scene *bvh_traced = make_scene(hs, NULL);
    cmlt_stats host_stats, bvh_stats;
    double host_mean = render_mean(host_traced, estimator, per_pixel, &host_stats);
    double bvh_mean = render_mean(bvh_traced, estimator, per_pixel, &bvh_stats);
    printf("host mean %.6f\n", host_mean);
    printf("bvh mean %.6f\n", bvh_mean);
    printf("callbacks %lu %lu %lu\n", hs->single_calls, hs->packet_calls, hs->packet_lanes);
    printf("rejected %llu nonfinite %llu %llu\n", (unsigned long long)host_stats.rejected_host_hits,
           (unsigned long long)host_stats.nonfinite, (unsigned long long)bvh_stats.nonfinite);
    cmlt_scene_release(host_traced);
    cmlt_scene_release(bvh_traced);
}


/* cmlt wants hits in the open interval (0, tfar); Embree's [tnear, tfar]
 * is closed and with tnear = 0 reports t = 0 for rays leaving a surface. */
static float near_bound(void) { return FLT_MIN; }
static float far_bound(float tfar) { return isinf(tfar) ? tfar : nextafterf(tfar, 0.0f); }

typedef struct embree_host {
    host_scene *geometry;
    RTCScene scene;
} embree_host;

static void cb_intersect(void *user, const cmlt_ray *ray, cmlt_hit *hit) {
    embree_host *h = (embree_host *)user;
    struct RTCIntersectContext ctx;
    struct RTCRayHit rh;
    h->geometry->single_calls++;
    rtcInitIntersectContext(&ctx);
    rh.ray.org_x = ray->org[0], rh.ray.org_y = ray->org[1], rh.ray.org_z = ray->org[2];
    rh.ray.dir_x = ray->dir[0], rh.ray.dir_y = ray->dir[1], rh.ray.dir_z = ray->dir[2];
    rh.ray.tnear = near_bound();
    rh.ray.tfar = far_bound(ray->tfar);
    rh.ray.time = 0.0f;
    rh.ray.mask = 0xFFFFFFFFu; /* Debian's Embree has ray masks on: 0 would hit nothing */
    rh.ray.id = 0;
    rh.ray.flags = 0;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(h->scene, &ctx, &rh);
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) {
        hit->prim_id = CMLT_INVALID_ID;
        return;
    }
    hit->t = rh.ray.tfar;
    hit->u = rh.hit.u;
    hit->v = rh.hit.v;
    hit->prim_id = rh.hit.primID;
}

static uint32_t cb_occluded(void *user, const cmlt_ray *ray) {
    embree_host *h = (embree_host *)user;
    struct RTCIntersectContext ctx;
    struct RTCRay r;
    h->geometry->single_calls++;
    rtcInitIntersectContext(&ctx);
    r.org_x = ray->org[0], r.org_y = ray->org[1], r.org_z = ray->org[2];
    r.dir_x = ray->dir[0], r.dir_y = ray->dir[1], r.dir_z = ray->dir[2];
    r.tnear = near_bound();
    r.tfar = far_bound(ray->tfar);
    r.time = 0.0f;
    r.mask = 0xFFFFFFFFu;
    r.id = 0;
    r.flags = 0;
    rtcOccluded1(h->scene, &ctx, &r);
    /* Embree marks an occluded ray with tfar = -inf. */
    return r.tfar < 0.0f;
}

/* One macro body per packet width: copy the active lanes into an aligned
 * RTCRayHitN, trace, copy the hits back. */
#define DEFINE_PACKET(N)                                                                               \
    static void intersect##N(embree_host *h, uint32_t active, const cmlt_ray_packet *rays,           \
                             cmlt_hit_packet *hits) {                                                  \
        struct RTCIntersectContext ctx;                                                               \
        struct RTCRayHit##N rh;                                                                       \
        int valid[N];                                                                                 \
        int i;                                                                                        \
        rtcInitIntersectContext(&ctx);                                                                \
        ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;                                              \
        for (i = 0; i < N; ++i) {                                                                     \
            valid[i] = (active >> i & 1u) ? -1 : 0;                                                   \
            rh.ray.org_x[i] = rays->org_x[i], rh.ray.org_y[i] = rays->org_y[i];                        \
            rh.ray.org_z[i] = rays->org_z[i];                                                         \
            rh.ray.dir_x[i] = rays->dir_x[i], rh.ray.dir_y[i] = rays->dir_y[i];                        \
            rh.ray.dir_z[i] = rays->dir_z[i];                                                         \
            rh.ray.tnear[i] = near_bound(), rh.ray.tfar[i] = far_bound(rays->tfar[i]);                \
            rh.ray.time[i] = 0.0f;                                                                    \
            rh.ray.mask[i] = 0xFFFFFFFFu, rh.ray.id[i] = 0, rh.ray.flags[i] = 0;                      \
            rh.hit.geomID[i] = RTC_INVALID_GEOMETRY_ID;                                               \
        }                                                                                             \
        rtcIntersect##N(valid, h->scene, &ctx, &rh);                                                  \
        for (i = 0; i < N; ++i) {                                                                     \
            if (!valid[i]) continue;                                                                  \
            if (rh.hit.geomID[i] == RTC_INVALID_GEOMETRY_ID) {                                        \
                hits->prim_id[i] = CMLT_INVALID_ID;                                                   \
            } else {                                                                                  \
                hits->t[i] = rh.ray.tfar[i];                                                          \
                hits->u[i] = rh.hit.u[i];                                                             \
                hits->v[i] = rh.hit.v[i];                                                             \
                hits->prim_id[i] = rh.hit.primID[i];                                                  \
            }                                                                                         \
        }                                                                                             \
    }                                                                                                 \
    static uint32_t occluded##N(embree_host *h, uint32_t active, const cmlt_ray_packet *rays) {       \
        struct RTCIntersectContext ctx;                                                               \
        struct RTCRay##N r;                                                                           \
        int valid[N];                                                                                 \
        int i;                                                                                        \
        uint32_t out = 0;                                                                             \
        rtcInitIntersectContext(&ctx);                                                                \
        ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;                                              \
        for (i = 0; i < N; ++i) {                                                                     \
            valid[i] = (active >> i & 1u) ? -1 : 0;                                                   \
            r.org_x[i] = rays->org_x[i], r.org_y[i] = rays->org_y[i], r.org_z[i] = rays->org_z[i];    \
            r.dir_x[i] = rays->dir_x[i], r.dir_y[i] = rays->dir_y[i], r.dir_z[i] = rays->dir_z[i];    \
            r.tnear[i] = near_bound(), r.tfar[i] = far_bound(rays->tfar[i]), r.time[i] = 0.0f;     \
            r.mask[i] = 0xFFFFFFFFu, r.id[i] = 0, r.flags[i] = 0;                                     \
        }                                                                                             \
        rtcOccluded##N(valid, h->scene, &ctx, &r);                                                    \
        for (i = 0; i < N; ++i)                                                                       \
            if (valid[i] && r.tfar[i] < 0.0f) out |= 1u << i;                                         \
        return out;                                                                                   \
    }

DEFINE_PACKET(4)
DEFINE_PACKET(8)
DEFINE_PACKET(16)

static void cb_intersect_packet(void *user, uint32_t width, uint32_t active, const cmlt_ray_packet *rays,
                                cmlt_hit_packet *hits) {
    embree_host *h = (embree_host *)user;
    uint32_t i;
    h->geometry->packet_calls++;
    for (i = 0; i < width; ++i) h->geometry->packet_lanes += active >> i & 1u;
    if (width == 4) intersect4(h, active, rays, hits);
    else if (width == 8) intersect8(h, active, rays, hits);
    else intersect16(h, active, rays, hits);
}

static uint32_t cb_occluded_packet(void *user, uint32_t width, uint32_t active, const cmlt_ray_packet *rays) {
    embree_host *h = (embree_host *)user;
    uint32_t i;
    h->geometry->packet_calls++;
    for (i = 0; i < width; ++i) h->geometry->packet_lanes += active >> i & 1u;
    if (width == 4) return occluded4(h, active, rays);
    if (width == 8) return occluded8(h, active, rays);
    return occluded16(h, active, rays);
}

int main(int argc, char **argv) {
    static host_scene hs;
    const char *method = argc > 1 ? argv[1] : "cmlt";
    uint64_t per_pixel = argc > 2 ? strtoull(argv[2], NULL, 10) : 16;
    uint32_t estimator = parse_estimator(method);
    embree_host host;
    RTCDevice device;
    RTCGeometry geom;
    float *vb;
    unsigned *ib;
    cmlt_intersector isect;

    build_host_scene(&hs);

    /* The host's Embree scene: all triangles in one geometry, in cmlt's
     * triangle order, so primID is cmlt's prim_id. */
    device = rtcNewDevice(NULL);
    host.geometry = &hs;
    host.scene = rtcNewScene(device);
    rtcSetSceneFlags(host.scene, RTC_SCENE_FLAG_ROBUST);
    geom = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
    vb = (float *)rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 4 * sizeof(float),
                                          hs.nverts);
    ib = (unsigned *)rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned),
                                             hs.ntris);
    if (!vb || !ib) {
        fprintf(stderr, "Embree: %d\n", (int)rtcGetDeviceError(device));
        return 1;
    }
    memcpy(vb, hs.verts, sizeof(float) * 4 * hs.nverts);
    memcpy(ib, hs.tris, sizeof(unsigned) * 3 * hs.ntris);
    rtcCommitGeometry(geom);
    rtcAttachGeometry(host.scene, geom);
    rtcReleaseGeometry(geom);
    rtcCommitScene(host.scene);

    isect.user = &host;
    isect.intersect = cb_intersect;
    isect.occluded = cb_occluded;
    isect.intersect_packet = cb_intersect_packet;
    isect.occluded_packet = cb_occluded_packet;
    compare_with_our_bvh(&hs, &isect, estimator, per_pixel);
    rtcReleaseScene(host.scene);
    rtcReleaseDevice(device);
    return 0;
}
