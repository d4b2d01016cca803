/*
 * outputs.c — what a host reads out per frame, split over its threads by
 * rows: the image (cmlt_renderer_resolve_rows, RGBA8 sRGB and RGBA16F
 * half floats) and the auxiliary outputs a denoiser or a temporal
 * upscaler reads (cmlt_renderer_aov_rows: albedo, shading normal, depth,
 * motion vectors), each on two host threads, one band of rows each.
 *
 * The scene is example_scene.h's floor, area light and mirror sphere. A
 * first frame, then a second in which the camera moves and the sphere
 * slides (cmlt_scene_begin_frame, then cmlt_scene_update_mesh): the
 * motion vectors of the second frame carry both. Prints whether the
 * banded reads equal one call, then the outputs at a floor pixel and a
 * sphere pixel (see the lines below).
 *
 * Usage: outputs
 */
/* pthreads are POSIX, not C99. */
#define _POSIX_C_SOURCE 200112L

#include <pthread.h>

#include "example_scene.h"

enum { W = 64, H = 48, WORKERS = 2, BANDS = 2 };

/* One band of rows read by one host thread. */
typedef struct band {
    const cmlt_renderer *renderer;
    const cmlt_camera *previous;
    uint32_t y0, y1;
    uint8_t *rgba8;       /* the band's rows of the sRGB image */
    uint16_t *rgba16;     /* ... of the half-float image */
    float *albedo, *normal, *depth, *motion;
    cmlt_status status;
} band;

static cmlt_aov_layer layer(float *rows, uint32_t count, uint32_t channels) {
    cmlt_aov_layer l;
    l.data = rows;
    l.row_stride = 0; /* packed */
    l.buffer_size = (size_t)count * W * channels * sizeof(float);
    l.format = CMLT_AOV_F32;
    return l;
}

static void *read_band(void *arg) {
    band *b = (band *)arg;
    uint32_t n = b->y1 - b->y0;
    cmlt_aov_buffers out;
    b->status = cmlt_renderer_resolve_rows(b->renderer, CMLT_FORMAT_RGBA8_SRGB, b->y0, b->y1, b->rgba8, 0,
                                           (size_t)n * W * 4);
    if (b->status != CMLT_OK) return NULL;
    b->status = cmlt_renderer_resolve_rows(b->renderer, CMLT_FORMAT_RGBA16F, b->y0, b->y1,
                                           (uint8_t *)b->rgba16, 0, (size_t)n * W * 8);
    if (b->status != CMLT_OK) return NULL;
    out.albedo = layer(b->albedo, n, 3);
    out.normal = layer(b->normal, n, 3);
    out.depth = layer(b->depth, n, 1);
    out.motion = layer(b->motion, n, 2);
    b->status = cmlt_renderer_aov_rows(b->renderer, b->previous, b->y0, b->y1, &out);
    return NULL;
}

static uint8_t rgba8[W * H * 4], whole8[W * H * 4];
static uint16_t rgba16[W * H * 4], whole16[W * H * 4];
static float albedo[W * H * 3], normal[W * H * 3], depth[W * H], motion[W * H * 2];

/* Reads the frame out in BANDS bands of rows on as many threads, and once
 * more the image in one call; returns whether the bands' bytes are one
 * call's. */
static int read_frame(const cmlt_renderer *r, const cmlt_camera *previous) {
    pthread_t threads[BANDS];
    band bands[BANDS];
    int i;
    for (i = 0; i < BANDS; ++i) {
        uint32_t y0 = (uint32_t)(H * i / BANDS), y1 = (uint32_t)(H * (i + 1) / BANDS);
        band *b = &bands[i];
        b->renderer = r;
        b->previous = previous;
        b->y0 = y0;
        b->y1 = y1;
        b->rgba8 = &rgba8[(size_t)y0 * W * 4];
        b->rgba16 = &rgba16[(size_t)y0 * W * 4];
        b->albedo = &albedo[(size_t)y0 * W * 3];
        b->normal = &normal[(size_t)y0 * W * 3];
        b->depth = &depth[(size_t)y0 * W];
        b->motion = &motion[(size_t)y0 * W * 2];
        if (pthread_create(&threads[i], NULL, read_band, b) != 0) exit(1);
    }
    for (i = 0; i < BANDS; ++i) {
        pthread_join(threads[i], NULL);
        check(bands[i].status, "a band's read-out");
    }
    check(cmlt_renderer_resolve(r, CMLT_FORMAT_RGBA8_SRGB, whole8, 0, sizeof whole8), "cmlt_renderer_resolve");
    check(cmlt_renderer_resolve(r, CMLT_FORMAT_RGBA16F, (uint8_t *)whole16, 0, sizeof whole16),
          "cmlt_renderer_resolve");
    return memcmp(rgba8, whole8, sizeof rgba8) == 0 && memcmp(rgba16, whole16, sizeof rgba16) == 0;
}

static void print_pixel(const char *what, int x, int y) {
    size_t i = (size_t)y * W + (size_t)x;
    printf("%s depth %.4f normal %.4f %.4f %.4f albedo %.4f %.4f %.4f motion %.4f %.4f\n", what, depth[i],
           normal[3 * i], normal[3 * i + 1], normal[3 * i + 2], albedo[3 * i], albedo[3 * i + 1],
           albedo[3 * i + 2], motion[2 * i], motion[2 * i + 1]);
}

static void render_frame(cmlt_renderer *r) {
    uint32_t w;
    check(cmlt_renderer_prepare(r), "cmlt_renderer_prepare");
    for (w = 0; w < WORKERS; ++w) check(cmlt_renderer_render(r, w, (uint64_t)W * H, NULL), "cmlt_renderer_render");
}

int main(void) {
    static host_scene hs;
    cmlt_scene *scene = NULL;
    cmlt_renderer *renderer = NULL;
    cmlt_mesh mesh;
    cmlt_renderer_config config;
    uint32_t m_white, m_mirror, sphere_first, v;
    cmlt_camera first = {{0.0f, 1.0f, -3.0f}, {0.0f, 0.5f, 0.0f}, {0.0f, 1.0f, 0.0f}, 50.0f, 0.0f, 1.0f};
    cmlt_camera second = first;

    /* Floor (mesh 0), light (mesh 1), mirror sphere (mesh 2) over one host
     * vertex array. */
    build_floor_and_light(&hs);
    sphere_first = hs.nverts;
    add_sphere(&hs, 0.0f, 0.7f, 0.0f, 0.6f, 12, 24);
    scene = begin_scene(&hs, &m_white, &m_mirror, &mesh);
    mesh.vertex_count = hs.nverts;
    mesh.indices = &hs.tris[4][0];
    mesh.triangle_count = hs.ntris - 4;
    mesh.material = m_mirror;
    check(cmlt_scene_add_mesh(scene, &mesh, NULL), "add_mesh sphere");
    check(cmlt_scene_commit(scene), "cmlt_scene_commit");
    check(cmlt_renderer_config_default(CMLT_ESTIMATOR_BDPT, &config), "cmlt_renderer_config_default");
    config.width = W;
    config.height = H;
    config.workers = WORKERS;
    check(cmlt_renderer_new(scene, &config, &first, &renderer), "cmlt_renderer_new");

    /* Frame 1: a still camera (previous = NULL). */
    render_frame(renderer);
    printf("frame 1 bands identical %d\n", read_frame(renderer, NULL));
    print_pixel("frame 1 floor", 8, 44);
    print_pixel("frame 1 sphere", 32, 20);

    /* Frame 2: the camera steps 0.1 to the side and the sphere slides 0.2
     * along +x. Motion measures from where the meshes were when the frame
     * began. */
    check(cmlt_scene_begin_frame(scene), "cmlt_scene_begin_frame");
    for (v = sphere_first; v < hs.nverts; ++v) hs.verts[v][0] += 0.2f;
    check(cmlt_scene_update_mesh(scene, 2, &hs.verts[0][0], hs.nverts, sizeof hs.verts[0], NULL, 0),
          "cmlt_scene_update_mesh");
    second.position[0] += 0.1f;
    second.target[0] += 0.1f;
    check(cmlt_renderer_set_camera(renderer, &second), "cmlt_renderer_set_camera");
    render_frame(renderer);
    printf("frame 2 bands identical %d\n", read_frame(renderer, &first));
    print_pixel("frame 2 floor", 8, 44);
    print_pixel("frame 2 sphere", 32, 20);

    cmlt_renderer_release(renderer);
    cmlt_scene_release(scene);
    return 0;
}
