/*
 * example_scene.h — shared by host_geometry.c, embree_host.c and
 * frame_loop.c: a scene the host owns (a floor under an area light, plus
 * tessellated spheres), in one vertex array with a 16-byte stride, handed
 * to cmlt with or without the host's own intersector, and a small render.
 * The helpers are static inline: each program uses only some of them.
 */
#ifndef CMLT_EXAMPLE_SCENE_H
#define CMLT_EXAMPLE_SCENE_H

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cmlt.h"

static inline void check(cmlt_status s, const char *what) {
    if (s != CMLT_OK) {
        fprintf(stderr, "%s failed: %s (%s)\n", what, cmlt_status_name((uint32_t)s), cmlt_last_error());
        exit(1);
    }
}

/* ---- The host's geometry: one vertex array (x, y, z, pad), one index array. ---- */

enum { MAX_VERTS = 8192, MAX_TRIS = 16384 };

typedef struct host_scene {
    float verts[MAX_VERTS][4]; /* stride 16 bytes: the 4th float is unused */
    uint32_t tris[MAX_TRIS][3];
    uint32_t nverts, ntris;
    unsigned long single_calls, packet_calls, packet_lanes;
} host_scene;

static inline uint32_t add_vertex(host_scene *s, float x, float y, float z) {
    s->verts[s->nverts][0] = x;
    s->verts[s->nverts][1] = y;
    s->verts[s->nverts][2] = z;
    s->verts[s->nverts][3] = 0.0f;
    return s->nverts++;
}

static inline void add_tri(host_scene *s, uint32_t a, uint32_t b, uint32_t c) {
    s->tris[s->ntris][0] = a;
    s->tris[s->ntris][1] = b;
    s->tris[s->ntris][2] = c;
    s->ntris++;
}

/* A quad a-b-c-d (counter-clockwise seen from its front). */
static inline void add_quad(host_scene *s, const float q[4][3]) {
    uint32_t i0 = add_vertex(s, q[0][0], q[0][1], q[0][2]);
    uint32_t i1 = add_vertex(s, q[1][0], q[1][1], q[1][2]);
    uint32_t i2 = add_vertex(s, q[2][0], q[2][1], q[2][2]);
    uint32_t i3 = add_vertex(s, q[3][0], q[3][1], q[3][2]);
    add_tri(s, i0, i1, i2);
    add_tri(s, i0, i2, i3);
}

/* A UV sphere of `rings` × `segments` quads, outward-facing triangles. */
static inline void add_sphere(host_scene *s, float cx, float cy, float cz, float r, int rings, int segments) {
    uint32_t first = s->nverts;
    int i, j;
    for (i = 0; i <= rings; ++i) {
        float th = 3.14159265f * (float)i / (float)rings;
        for (j = 0; j < segments; ++j) {
            float ph = 6.2831853f * (float)j / (float)segments;
            add_vertex(s, cx + r * sinf(th) * cosf(ph), cy + r * cosf(th), cz + r * sinf(th) * sinf(ph));
        }
    }
    for (i = 0; i < rings; ++i) {
        for (j = 0; j < segments; ++j) {
            uint32_t a = first + (uint32_t)(i * segments + j);
            uint32_t b = first + (uint32_t)(i * segments + (j + 1) % segments);
            uint32_t c = a + (uint32_t)segments, d = b + (uint32_t)segments;
            add_tri(s, a, b, d);
            add_tri(s, a, d, c);
        }
    }
}

/* The floor (triangles 0–1) and the light (2–3). */
static inline void build_floor_and_light(host_scene *hs) {
    const float floor_q[4][3] = {{-3, 0, -3}, {-3, 0, 3}, {3, 0, 3}, {3, 0, -3}};
    const float light_q[4][3] = {{-0.5f, 2.5f, -0.5f}, {0.5f, 2.5f, -0.5f}, {0.5f, 2.5f, 0.5f}, {-0.5f, 2.5f, 0.5f}};
    add_quad(hs, floor_q); /* faces +y */
    add_quad(hs, light_q); /* faces −y, down onto the sphere */
}

/* The estimator named on the command line (CMLT by default). */
static inline uint32_t parse_estimator(const char *method) {
    if (strcmp(method, "pt") == 0) return CMLT_ESTIMATOR_PT;
    if (strcmp(method, "bdpt") == 0) return CMLT_ESTIMATOR_BDPT;
    if (strcmp(method, "mlt") == 0) return CMLT_ESTIMATOR_MLT;
    return CMLT_ESTIMATOR_CMLT;
}

/* Starts a cmlt scene over the host arrays: a white and a mirror material
 * (ids in *m_white, *m_mirror), then the floor and the light (triangles
 * 0–3 of the host, the first two meshes). `mesh` is left describing the
 * host vertex array, ready for further meshes over it. */
static inline cmlt_scene *begin_scene(host_scene *hs, uint32_t *m_white, uint32_t *m_mirror, cmlt_mesh *mesh) {
    cmlt_scene *scene = NULL;
    /* Designated initialisers: the fields not named are zero, which is
       CMLT_NO_TEXTURE for the texture fields. */
    cmlt_material white = {.type_ = CMLT_MATERIAL_DIFFUSE, .color = {0.7f, 0.7f, 0.7f}, .ior = 1.0f,
                           .bump_scale = 1.0f, .specular_color = {1.0f, 1.0f, 1.0f},
                           .transmission_color = {1.0f, 1.0f, 1.0f}, .distribution = CMLT_DISTRIBUTION_GGX};
    cmlt_material mirror = white;
    mirror.type_ = CMLT_MATERIAL_MIRROR;
    mirror.color[0] = mirror.color[1] = mirror.color[2] = 0.9f;
    check(cmlt_scene_new(&scene), "cmlt_scene_new");
    check(cmlt_scene_add_material(scene, &white, m_white), "add_material");
    check(cmlt_scene_add_material(scene, &mirror, m_mirror), "add_material");
    memset(mesh, 0, sizeof *mesh);
    mesh->positions = &hs->verts[0][0];
    mesh->vertex_count = hs->nverts;
    mesh->position_stride = sizeof hs->verts[0];
    mesh->material = *m_white;
    mesh->indices = &hs->tris[0][0];
    mesh->triangle_count = 2;
    check(cmlt_scene_add_mesh(scene, mesh, NULL), "add_mesh floor");
    mesh->indices = &hs->tris[2][0];
    mesh->emission[0] = mesh->emission[1] = mesh->emission[2] = 8.0f;
    check(cmlt_scene_add_mesh(scene, mesh, NULL), "add_mesh light");
    mesh->emission[0] = mesh->emission[1] = mesh->emission[2] = 0.0f;
    return scene;
}

/* Renders a small frame of `scene` and returns its mean (all channels). */
static inline double render_mean(cmlt_scene *scene, uint32_t estimator, uint64_t per_pixel, cmlt_stats *stats) {
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
    /* A field the estimator does not read must keep its default (or the
       config is refused): the Metropolis fields for MLT and CMLT only, the
       level-2 fields for CMLT only. */
    if (estimator == CMLT_ESTIMATOR_MLT || estimator == CMLT_ESTIMATOR_CMLT) {
        config.chains = 64;
        config.bootstrap_samples = 200;
    }
    if (estimator == CMLT_ESTIMATOR_CMLT) {
        config.k = 8; /* bundles of 8: from 5 live rays on they go as packets */
        config.m = 2;
        config.lens_sigma = 2.0f;
        /* Side chains on every path: the defaults keep them for paths of 6
           or more segments, and this scene's are at most 6. */
        config.side_chain_min_depth = 0;
    }
    check(cmlt_renderer_new(scene, &config, &cam, &r), "cmlt_renderer_new");
    check(cmlt_renderer_prepare(r), "cmlt_renderer_prepare");
    check(cmlt_renderer_render(r, 0, per_pixel * W * H, NULL), "cmlt_renderer_render");
    check(cmlt_renderer_resolve(r, CMLT_FORMAT_RGB32F, (uint8_t *)px, 0, sizeof px), "cmlt_renderer_resolve");
    check(cmlt_renderer_get_stats(r, stats), "cmlt_renderer_get_stats");
    for (i = 0; i < W * H * 3; ++i) sum += px[i];
    cmlt_renderer_release(r);
    return sum / (W * H * 3);
}

#endif
