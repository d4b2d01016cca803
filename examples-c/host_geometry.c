/*
 * host_geometry.c — the host traces the rays.
 *
 * Shows: a scene built from the host's own arrays (a tessellated sphere on
 * a floor under an area light, positions with a stride of 4 floats), and
 * the host's own ray tracer plugged in through callbacks — single rays and
 * SoA packets of 4/8/16 lanes with an active mask — as an engine would
 * route cmlt's bundles into its packet tracer. The host tracer here is a
 * plain Möller–Trumbore loop over its triangles. The same frame is then
 * rendered with cmlt's own BVH; both means are printed (they agree to
 * within noise) with the number of callback calls.
 *
 * Usage: host_geometry [pt|bdpt|mlt|cmlt] [BUDGET_PER_PIXEL]
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cmlt.h"

static void check(cmlt_status s, const char *what) {
    if (s != CMLT_OK) {
        fprintf(stderr, "%s failed: %s (%s)\n", what, cmlt_status_name((uint32_t)s), cmlt_last_error());
        exit(1);
    }
}

/* ---- The host's geometry: one vertex array (x, y, z, pad), one index array. ---- */

enum { RINGS = 12, SEGMENTS = 24, MAX_VERTS = 1024, MAX_TRIS = 1024 };

typedef struct host_scene {
    float verts[MAX_VERTS][4]; /* stride 16 bytes: the 4th float is unused */
    uint32_t tris[MAX_TRIS][3];
    uint32_t nverts, ntris;
    unsigned long single_calls, packet_calls, packet_lanes;
} host_scene;

static uint32_t add_vertex(host_scene *s, float x, float y, float z) {
    s->verts[s->nverts][0] = x;
    s->verts[s->nverts][1] = y;
    s->verts[s->nverts][2] = z;
    s->verts[s->nverts][3] = 0.0f;
    return s->nverts++;
}

static void add_tri(host_scene *s, uint32_t a, uint32_t b, uint32_t c) {
    s->tris[s->ntris][0] = a;
    s->tris[s->ntris][1] = b;
    s->tris[s->ntris][2] = c;
    s->ntris++;
}

/* A quad a-b-c-d (counter-clockwise seen from its front). */
static void add_quad(host_scene *s, const float q[4][3]) {
    uint32_t i0 = add_vertex(s, q[0][0], q[0][1], q[0][2]);
    uint32_t i1 = add_vertex(s, q[1][0], q[1][1], q[1][2]);
    uint32_t i2 = add_vertex(s, q[2][0], q[2][1], q[2][2]);
    uint32_t i3 = add_vertex(s, q[3][0], q[3][1], q[3][2]);
    add_tri(s, i0, i1, i2);
    add_tri(s, i0, i2, i3);
}

/* A UV sphere, outward-facing triangles. */
static void add_sphere(host_scene *s, float cx, float cy, float cz, float r) {
    uint32_t first = s->nverts;
    int i, j;
    for (i = 0; i <= RINGS; ++i) {
        float th = 3.14159265f * (float)i / RINGS;
        for (j = 0; j < SEGMENTS; ++j) {
            float ph = 6.2831853f * (float)j / SEGMENTS;
            add_vertex(s, cx + r * sinf(th) * cosf(ph), cy + r * cosf(th), cz + r * sinf(th) * sinf(ph));
        }
    }
    for (i = 0; i < RINGS; ++i) {
        for (j = 0; j < SEGMENTS; ++j) {
            uint32_t a = first + (uint32_t)(i * SEGMENTS + j);
            uint32_t b = first + (uint32_t)(i * SEGMENTS + (j + 1) % SEGMENTS);
            uint32_t c = a + SEGMENTS, d = b + SEGMENTS;
            add_tri(s, a, b, d);
            add_tri(s, a, d, c);
        }
    }
}

/* ---- The host's ray tracer. ---- */

/* Möller–Trumbore; returns 1 and t, u, v for a hit in (0, tfar). */
static int hit_triangle(const host_scene *s, uint32_t t, const float o[3], const float d[3], float tfar,
                        float *out_t, float *out_u, float *out_v) {
    const float *a = s->verts[s->tris[t][0]], *b = s->verts[s->tris[t][1]], *c = s->verts[s->tris[t][2]];
    float e1[3], e2[3], p[3], q[3], tv[3], det, inv, u, v, dist;
    int k;
    for (k = 0; k < 3; ++k) {
        e1[k] = b[k] - a[k];
        e2[k] = c[k] - a[k];
        tv[k] = o[k] - a[k];
    }
    p[0] = d[1] * e2[2] - d[2] * e2[1];
    p[1] = d[2] * e2[0] - d[0] * e2[2];
    p[2] = d[0] * e2[1] - d[1] * e2[0];
    det = e1[0] * p[0] + e1[1] * p[1] + e1[2] * p[2];
    if (fabsf(det) < 1e-12f) return 0;
    inv = 1.0f / det;
    u = (tv[0] * p[0] + tv[1] * p[1] + tv[2] * p[2]) * inv;
    if (u < 0.0f || u > 1.0f) return 0;
    q[0] = tv[1] * e1[2] - tv[2] * e1[1];
    q[1] = tv[2] * e1[0] - tv[0] * e1[2];
    q[2] = tv[0] * e1[1] - tv[1] * e1[0];
    v = (d[0] * q[0] + d[1] * q[1] + d[2] * q[2]) * inv;
    if (v < 0.0f || u + v > 1.0f) return 0;
    dist = (e2[0] * q[0] + e2[1] * q[1] + e2[2] * q[2]) * inv;
    /* cmlt offsets ray origins off their surface; the small absolute
     * epsilon (this scene is of size ~1) guards Möller–Trumbore's own
     * rounding. */
    if (!(dist > 1e-6f) || !(dist < tfar)) return 0;
    *out_t = dist;
    *out_u = u;
    *out_v = v;
    return 1;
}

static void trace(const host_scene *s, const float o[3], const float d[3], float tfar, int any, cmlt_hit *hit) {
    uint32_t t;
    hit->prim_id = CMLT_INVALID_ID;
    hit->t = tfar;
    for (t = 0; t < s->ntris; ++t) {
        float dist, u, v;
        if (hit_triangle(s, t, o, d, hit->t, &dist, &u, &v)) {
            hit->t = dist;
            hit->u = u;
            hit->v = v;
            hit->prim_id = t;
            if (any) return;
        }
    }
}

static void cb_intersect(void *user, const cmlt_ray *ray, cmlt_hit *hit) {
    host_scene *s = (host_scene *)user;
    s->single_calls++;
    trace(s, ray->org, ray->dir, ray->tfar, 0, hit);
}

static uint32_t cb_occluded(void *user, const cmlt_ray *ray) {
    host_scene *s = (host_scene *)user;
    cmlt_hit hit;
    s->single_calls++;
    trace(s, ray->org, ray->dir, ray->tfar, 1, &hit);
    return hit.prim_id != CMLT_INVALID_ID;
}

/* Packets: lane i of the SoA arrays, only where bit i of `active` is set. */
static void cb_intersect_packet(void *user, uint32_t width, uint32_t active, const cmlt_ray_packet *rays,
                                cmlt_hit_packet *hits) {
    host_scene *s = (host_scene *)user;
    uint32_t i;
    s->packet_calls++;
    for (i = 0; i < width; ++i) {
        float o[3], d[3];
        cmlt_hit h;
        if (!(active >> i & 1u)) continue;
        s->packet_lanes++;
        o[0] = rays->org_x[i], o[1] = rays->org_y[i], o[2] = rays->org_z[i];
        d[0] = rays->dir_x[i], d[1] = rays->dir_y[i], d[2] = rays->dir_z[i];
        trace(s, o, d, rays->tfar[i], 0, &h);
        hits->t[i] = h.t;
        hits->u[i] = h.u;
        hits->v[i] = h.v;
        hits->prim_id[i] = h.prim_id;
    }
}

static uint32_t cb_occluded_packet(void *user, uint32_t width, uint32_t active, const cmlt_ray_packet *rays) {
    host_scene *s = (host_scene *)user;
    uint32_t i, occluded = 0;
    s->packet_calls++;
    for (i = 0; i < width; ++i) {
        float o[3], d[3];
        cmlt_hit h;
        if (!(active >> i & 1u)) continue;
        s->packet_lanes++;
        o[0] = rays->org_x[i], o[1] = rays->org_y[i], o[2] = rays->org_z[i];
        d[0] = rays->dir_x[i], d[1] = rays->dir_y[i], d[2] = rays->dir_z[i];
        trace(s, o, d, rays->tfar[i], 1, &h);
        if (h.prim_id != CMLT_INVALID_ID) occluded |= 1u << i;
    }
    return occluded;
}

/* Builds the cmlt scene from the host arrays; with `host` set, cmlt
 * traces through the callbacks instead of its own BVH. */
static cmlt_scene *make_scene(host_scene *hs, int host) {
    cmlt_scene *scene = NULL;
    cmlt_material white = {CMLT_MATERIAL_DIFFUSE, {0.7f, 0.7f, 0.7f}, 1.0f, 0.0f, 0};
    cmlt_material mirror = {CMLT_MATERIAL_MIRROR, {0.9f, 0.9f, 0.9f}, 1.0f, 0.0f, 0};
    uint32_t m_white, m_mirror, first;
    cmlt_mesh mesh;
    check(cmlt_scene_new(&scene), "cmlt_scene_new");
    check(cmlt_scene_add_material(scene, &white, &m_white), "add_material");
    check(cmlt_scene_add_material(scene, &mirror, &m_mirror), "add_material");
    /* Three meshes over the one host vertex array: floor (2 triangles),
     * light (2), sphere (the rest). Triangle numbers are the host's. */
    memset(&mesh, 0, sizeof mesh);
    mesh.positions = &hs->verts[0][0];
    mesh.vertex_count = hs->nverts;
    mesh.position_stride = sizeof hs->verts[0];
    mesh.index_stride = 0;
    mesh.material = m_white;
    mesh.indices = &hs->tris[0][0];
    mesh.triangle_count = 2;
    check(cmlt_scene_add_mesh(scene, &mesh, &first), "add_mesh floor");
    mesh.indices = &hs->tris[2][0];
    mesh.emission[0] = mesh.emission[1] = mesh.emission[2] = 8.0f;
    check(cmlt_scene_add_mesh(scene, &mesh, &first), "add_mesh light");
    mesh.indices = &hs->tris[4][0];
    mesh.triangle_count = hs->ntris - 4;
    mesh.material = m_mirror;
    mesh.emission[0] = mesh.emission[1] = mesh.emission[2] = 0.0f;
    check(cmlt_scene_add_mesh(scene, &mesh, &first), "add_mesh sphere");
    if (first != 4) {
        fprintf(stderr, "unexpected triangle numbering\n");
        exit(1);
    }
    if (host) {
        cmlt_intersector isect;
        isect.user = hs;
        isect.intersect = cb_intersect;
        isect.occluded = cb_occluded;
        isect.intersect_packet = cb_intersect_packet;
        isect.occluded_packet = cb_occluded_packet;
        check(cmlt_scene_set_intersector(scene, &isect), "cmlt_scene_set_intersector");
    }
    check(cmlt_scene_commit(scene), "cmlt_scene_commit");
    return scene;
}

static double render_mean(cmlt_scene *scene, uint32_t estimator, uint64_t per_pixel, cmlt_stats *stats) {
    enum { W = 32, H = 24 };
    cmlt_renderer *r = NULL;
    cmlt_renderer_config config;
    cmlt_camera cam = {{0.0f, 1.0f, -3.0f}, {0.0f, 0.5f, 0.0f}, {0.0f, 1.0f, 0.0f}, 50.0f, 0.0f, 1.0f};
    static float px[W * H * 3];
    double sum = 0.0;
    int i;
    check(cmlt_renderer_config_default(estimator, &config), "config_default");
    config.width = W;
    config.height = H;
    config.max_depth = 6;
    config.chains = 64;
    config.bootstrap_samples = 200;
    config.k = 4;
    config.m = 2;
    config.lens_sigma = 2.0f;
    check(cmlt_renderer_new(scene, &config, &cam, &r), "cmlt_renderer_new");
    check(cmlt_renderer_prepare(r), "cmlt_renderer_prepare");
    check(cmlt_renderer_render(r, 0, per_pixel * W * H, NULL), "cmlt_renderer_render");
    check(cmlt_renderer_resolve(r, CMLT_FORMAT_RGB32F, (uint8_t *)px, 0, sizeof px), "cmlt_renderer_resolve");
    check(cmlt_renderer_get_stats(r, stats), "cmlt_renderer_get_stats");
    for (i = 0; i < W * H * 3; ++i) sum += px[i];
    cmlt_renderer_release(r);
    return sum / (W * H * 3);
}

int main(int argc, char **argv) {
    static host_scene hs;
    const char *method = argc > 1 ? argv[1] : "cmlt";
    uint64_t per_pixel = argc > 2 ? strtoull(argv[2], NULL, 10) : 16;
    uint32_t estimator = CMLT_ESTIMATOR_CMLT;
    const float floor_q[4][3] = {{-3, 0, -3}, {-3, 0, 3}, {3, 0, 3}, {3, 0, -3}};
    const float light_q[4][3] = {{-0.5f, 2.5f, -0.5f}, {0.5f, 2.5f, -0.5f}, {0.5f, 2.5f, 0.5f}, {-0.5f, 2.5f, 0.5f}};
    cmlt_scene *host_traced, *bvh_traced;
    cmlt_stats host_stats, bvh_stats;
    double host_mean, bvh_mean;

    if (strcmp(method, "pt") == 0) estimator = CMLT_ESTIMATOR_PT;
    else if (strcmp(method, "bdpt") == 0) estimator = CMLT_ESTIMATOR_BDPT;
    else if (strcmp(method, "mlt") == 0) estimator = CMLT_ESTIMATOR_MLT;

    add_quad(&hs, floor_q); /* faces +y */
    add_quad(&hs, light_q); /* faces −y, down onto the sphere */
    add_sphere(&hs, 0.0f, 0.7f, 0.0f, 0.6f);

    host_traced = make_scene(&hs, 1);
    bvh_traced = make_scene(&hs, 0);
    host_mean = render_mean(host_traced, estimator, per_pixel, &host_stats);
    bvh_mean = render_mean(bvh_traced, estimator, per_pixel, &bvh_stats);
    printf("host mean %.6f\n", host_mean);
    printf("bvh mean %.6f\n", bvh_mean);
    printf("callbacks %lu %lu %lu\n", hs.single_calls, hs.packet_calls, hs.packet_lanes);
    printf("rejected %llu nonfinite %llu %llu\n", (unsigned long long)host_stats.rejected_host_hits,
           (unsigned long long)host_stats.nonfinite, (unsigned long long)bvh_stats.nonfinite);
    cmlt_scene_release(host_traced);
    cmlt_scene_release(bvh_traced);
    return 0;
}
