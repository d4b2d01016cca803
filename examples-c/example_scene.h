/*
 * example_scene.h — shared by host_geometry.c and embree_host.c: a scene
 * the host owns (a tessellated mirror sphere on a floor under an area
 * light, in one vertex array with a 16-byte stride), handed to cmlt with
 * or without the host's own intersector, and a small render.
 */
#ifndef CMLT_EXAMPLE_SCENE_H
#define CMLT_EXAMPLE_SCENE_H

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

/* The floor (triangles 0–1), the light (2–3), the sphere (4–). */
static void build_host_scene(host_scene *hs) {
    const float floor_q[4][3] = {{-3, 0, -3}, {-3, 0, 3}, {3, 0, 3}, {3, 0, -3}};
    const float light_q[4][3] = {{-0.5f, 2.5f, -0.5f}, {0.5f, 2.5f, -0.5f}, {0.5f, 2.5f, 0.5f}, {-0.5f, 2.5f, 0.5f}};
    add_quad(hs, floor_q); /* faces +y */
    add_quad(hs, light_q); /* faces −y, down onto the sphere */
    add_sphere(hs, 0.0f, 0.7f, 0.0f, 0.6f);
}

/* The estimator named on the command line (CMLT by default). */
static uint32_t parse_estimator(const char *method) {
    if (strcmp(method, "pt") == 0) return CMLT_ESTIMATOR_PT;
    if (strcmp(method, "bdpt") == 0) return CMLT_ESTIMATOR_BDPT;
    if (strcmp(method, "mlt") == 0) return CMLT_ESTIMATOR_MLT;
    return CMLT_ESTIMATOR_CMLT;
}

/* Builds the cmlt scene from the host arrays; with `isect` given, cmlt
 * traces through the callbacks instead of its own BVH. */
static cmlt_scene *make_scene(host_scene *hs, const cmlt_intersector *isect) {
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
    if (isect) check(cmlt_scene_set_intersector(scene, isect), "cmlt_scene_set_intersector");
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

#endif
