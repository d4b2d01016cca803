/*
 * frame_loop.c — a game-engine style loop over cmlt.
 *
 * Shows: the host's allocator handed to cmlt (cmlt_set_allocator), all
 * setup first (the scene from the host's own arrays — example_scene.h's
 * floor, area light and mirror sphere, traced by cmlt's BVH — the
 * renderer, two workers), then frames of a camera
 * orbiting the scene with a fixed per-frame budget (chains kept from frame
 * to frame), each worker prepared (its share of the MLT bootstrap) and
 * rendered on its own host thread, the image resolved into the host's RGBA8
 * buffer. After setup the allocator aborts on any allocation: the frames
 * must not allocate, refused calls included (each frame tries two bad
 * cmlt_scene_update_mesh calls). Prints one line per frame (mean luminance and the
 * frame's wall time in milliseconds) and the number of allocations made
 * during the frames (0).
 *
 * Usage: frame_loop [FRAMES] [pt|bdpt|mlt|cmlt]
 */
/* posix_memalign and pthreads are POSIX, not C99. */
#define _POSIX_C_SOURCE 200112L

#include <pthread.h>
#include <time.h>

#include "example_scene.h"

/* ---- The host's allocator: counts, and aborts once frames start. ---- */

typedef struct host_heap {
    unsigned long allocations;
    int frozen; /* set after setup: any allocation is a bug */
} host_heap;

static void *heap_alloc(void *user, size_t size, size_t align) {
    host_heap *heap = (host_heap *)user;
    void *p = NULL;
    heap->allocations++;
    if (heap->frozen) {
        fprintf(stderr, "allocation of %zu bytes during a frame\n", size);
        abort();
    }
    if (align < sizeof(void *)) align = sizeof(void *);
    if (posix_memalign(&p, align, size) != 0) return NULL;
    return p;
}

static void heap_free(void *user, void *ptr, size_t size, size_t align) {
    (void)user;
    (void)size;
    (void)align;
    free(ptr);
}

/* ---- One host thread per worker. ---- */

typedef struct job {
    cmlt_renderer *renderer;
    uint32_t worker;
    uint64_t budget;
    cmlt_status status;
} job;

static void *prepare_job(void *arg) {
    job *j = (job *)arg;
    j->status = cmlt_renderer_prepare_worker(j->renderer, j->worker);
    return NULL;
}

static void *render_job(void *arg) {
    job *j = (job *)arg;
    j->status = cmlt_renderer_render(j->renderer, j->worker, j->budget, NULL);
    return NULL;
}

/* Runs `fn` for every worker, one host thread each; returns the first
 * failure. */
static cmlt_status on_workers(void *(*fn)(void *), job *jobs, int workers) {
    pthread_t threads[16];
    cmlt_status status = CMLT_OK;
    int w;
    for (w = 0; w < workers; ++w)
        if (pthread_create(&threads[w], NULL, fn, &jobs[w]) != 0) exit(1);
    for (w = 0; w < workers; ++w) {
        pthread_join(threads[w], NULL);
        if (status == CMLT_OK) status = jobs[w].status;
    }
    return status;
}

static double now_ms(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec * 1e3 + (double)t.tv_nsec * 1e-6;
}

int main(int argc, char **argv) {
    enum { SIZE = 48, WORKERS = 2 };
    int frames = argc > 1 ? atoi(argv[1]) : 8;
    const char *method = argc > 2 ? argv[2] : "cmlt";
    uint32_t estimator = parse_estimator(method);
    static host_heap heap;
    static host_scene hs;
    cmlt_allocator allocator;
    cmlt_scene *scene = NULL;
    cmlt_renderer *renderer = NULL;
    cmlt_mesh mesh;
    uint32_t m_white, m_mirror;
    cmlt_camera start = {{0.0f, 1.0f, -3.0f}, {0.0f, 0.5f, 0.0f}, {0.0f, 1.0f, 0.0f}, 50.0f, 0.0f, 1.0f};
    cmlt_camera camera;
    cmlt_renderer_config config;
    size_t bytes = 0, alignment = 0;
    uint8_t *image;
    float radius, height;
    int frame, w;

    allocator.user = &heap;
    allocator.alloc = heap_alloc;
    allocator.free = heap_free;
    check(cmlt_set_allocator(&allocator), "cmlt_set_allocator");

    /* Setup: everything is allocated here. The scene: floor (triangles
     * 0–1), light (2–3) and a mirror sphere (4–) over one host vertex
     * array, the sphere a third mesh. */
    build_floor_and_light(&hs);
    add_sphere(&hs, 0.0f, 0.7f, 0.0f, 0.6f, 12, 24);
    scene = begin_scene(&hs, &m_white, &m_mirror, &mesh);
    mesh.indices = &hs.tris[4][0];
    mesh.triangle_count = hs.ntris - 4;
    mesh.material = m_mirror;
    check(cmlt_scene_add_mesh(scene, &mesh, NULL), "add_mesh sphere");
    check(cmlt_scene_commit(scene), "cmlt_scene_commit");
    check(cmlt_renderer_config_default(estimator, &config), "cmlt_renderer_config_default");
    config.width = SIZE;
    config.height = SIZE;
    config.workers = WORKERS;
    /* The Metropolis fields are read by MLT and CMLT only (PT and BDPT
     * refuse them changed from their defaults). */
    if (estimator == CMLT_ESTIMATOR_MLT || estimator == CMLT_ESTIMATOR_CMLT) {
        config.chains = 64;
        config.bootstrap_samples = 200;
        config.normalisation_passes = 1;
        /* Exactly one pass per frame: the b window below averages b over
         * frames, so the small-image floor (more passes) is not needed. */
        config.normalisation_min_samples = 0;
        /* Frame-to-frame coherence: keep the chains across frames
         * (re-evaluated as the camera moves) and average b while the
         * camera stays put. */
        config.keep_chains = 1;
        config.b_window = 8;
    }
    check(cmlt_renderer_memory_requirements(scene, &config, &bytes, &alignment),
          "cmlt_renderer_memory_requirements");
    printf("renderer needs %zu bytes, alignment %zu\n", bytes, alignment);
    check(cmlt_renderer_new(scene, &config, &start, &renderer), "cmlt_renderer_new");
    image = (uint8_t *)malloc((size_t)4 * SIZE * SIZE);
    if (!image) return 1;

    /* Frames: nothing may allocate from here on. */
    heap.frozen = 1;
    {
        unsigned long before = heap.allocations;
        float dx = start.position[0] - start.target[0];
        float dz = start.position[2] - start.target[2];
        radius = sqrtf(dx * dx + dz * dz);
        height = start.position[1];
        camera = start;
        for (frame = 0; frame < frames; ++frame) {
            job jobs[WORKERS];
            double sum = 0.0, t0 = now_ms();
            size_t i;
            uint32_t pending = 0;
            float angle = 0.05f * (float)frame;
            camera.position[0] = start.target[0] + radius * sinf(angle);
            camera.position[1] = height;
            camera.position[2] = start.target[2] + radius * cosf(angle) * (dz < 0.0f ? -1.0f : 1.0f);
            check(cmlt_renderer_set_camera(renderer, &camera), "cmlt_renderer_set_camera");
            for (w = 0; w < WORKERS; ++w) {
                jobs[w].renderer = renderer;
                jobs[w].worker = (uint32_t)w;
                jobs[w].budget = (uint64_t)2 * SIZE * SIZE;
                jobs[w].status = CMLT_OK;
            }
            /* The MLT bootstrap on the workers' threads (cmlt_renderer_prepare
             * would run it on this one). */
            check(cmlt_renderer_prepare_begin(renderer, &pending), "cmlt_renderer_prepare_begin");
            if (pending) {
                check(on_workers(prepare_job, jobs, WORKERS), "cmlt_renderer_prepare_worker");
                check(cmlt_renderer_prepare_finish(renderer), "cmlt_renderer_prepare_finish");
            }
            check(on_workers(render_job, jobs, WORKERS), "cmlt_renderer_render");
            check(cmlt_renderer_resolve(renderer, CMLT_FORMAT_RGBA8_SRGB, image, 0, (size_t)4 * SIZE * SIZE),
                  "cmlt_renderer_resolve");
            /* A refused scene update inside a frame (a wrong vertex count, an
             * unknown mesh) returns its status and message without allocating
             * either, and changes nothing. */
            {
                static const float nowhere[3] = {0.0f, 0.0f, 0.0f};
                if (cmlt_scene_update_mesh(scene, 0, nowhere, 1, 0, NULL, 0) != CMLT_ERROR_INVALID_ARGUMENT ||
                    cmlt_scene_update_mesh(scene, 1u << 30, nowhere, 1, 0, NULL, 0) !=
                        CMLT_ERROR_INVALID_ARGUMENT ||
                    strstr(cmlt_last_error(), "cmlt_scene_update_mesh") == NULL) {
                    fprintf(stderr, "a bad cmlt_scene_update_mesh was not refused: %s\n", cmlt_last_error());
                    return 1;
                }
            }
            for (i = 0; i < (size_t)SIZE * SIZE; ++i) sum += image[4 * i] + image[4 * i + 1] + image[4 * i + 2];
            printf("frame %d mean %.3f ms %.2f\n", frame, sum / (3.0 * SIZE * SIZE), now_ms() - t0);
        }
        printf("allocations during frames %lu\n", heap.allocations - before);
    }
    heap.frozen = 0;

    free(image);
    cmlt_renderer_release(renderer);
    cmlt_scene_release(scene);
    return 0;
}
