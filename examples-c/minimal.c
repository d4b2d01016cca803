/*
 * minimal.c — the smallest complete cmlt program.
 *
 * Shows: loading the built-in Cornell box, a renderer with one worker,
 * one prepare/render/resolve round, writing a binary PPM, checking every
 * status, and a few deliberately wrong calls being refused. Prints the image's mean RGB on stdout (the tests compare
 * it with a Rust-side render of the same scene).
 *
 * Needs a library built with the `loader` feature (the built-in scene is
 * Mitsuba XML, read by the scene loader); without it
 * cmlt_scene_new_builtin fails with CMLT_ERROR_UNSUPPORTED. The other
 * examples build their scenes from the host's arrays and need no loader.
 *
 * Usage: minimal OUT.ppm [pt|bdpt|mlt|cmlt] [BUDGET_PER_PIXEL] [SIZE]
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cmlt.h"

/* Prints the failing call and cmlt's message, then exits. */
static void check(cmlt_status s, const char *what) {
    if (s != CMLT_OK) {
        fprintf(stderr, "%s failed: %s (%s)\n", what, cmlt_status_name((uint32_t)s), cmlt_last_error());
        exit(1);
    }
}

/* Checks that a deliberately wrong call failed with `want`. */
static void expect_status(cmlt_status got, cmlt_status want, const char *what) {
    if (got != want) {
        fprintf(stderr, "%s: got %s, want %s\n", what, cmlt_status_name((uint32_t)got), cmlt_status_name((uint32_t)want));
        exit(1);
    }
}

int main(int argc, char **argv) {
    const char *out = argc > 1 ? argv[1] : "minimal.ppm";
    const char *method = argc > 2 ? argv[2] : "bdpt";
    unsigned long per_pixel = argc > 3 ? strtoul(argv[3], NULL, 10) : 16;
    uint32_t size = argc > 4 ? (uint32_t)strtoul(argv[4], NULL, 10) : 64;
    uint32_t estimator = CMLT_ESTIMATOR_BDPT;
    cmlt_scene *scene = NULL;
    cmlt_renderer *renderer = NULL;
    cmlt_camera camera;
    cmlt_renderer_config config;
    cmlt_stats stats;
    float *pixels;
    uint8_t *preview;
    double mean[3] = {0.0, 0.0, 0.0};
    size_t i;
    FILE *f;

    if (cmlt_version() / 100 != CMLT_VERSION / 100) {
        fprintf(stderr, "header and library versions differ\n");
        return 1;
    }
    if (strcmp(method, "pt") == 0) estimator = CMLT_ESTIMATOR_PT;
    else if (strcmp(method, "mlt") == 0) estimator = CMLT_ESTIMATOR_MLT;
    else if (strcmp(method, "cmlt") == 0) estimator = CMLT_ESTIMATOR_CMLT;

    check(cmlt_scene_new_builtin("cornell-box", size, size, &scene, &camera), "cmlt_scene_new_builtin");
    check(cmlt_renderer_config_default(estimator, &config), "cmlt_renderer_config_default");
    config.width = size;
    config.height = size;
    config.seed = 1;
    check(cmlt_renderer_new(scene, &config, &camera, &renderer), "cmlt_renderer_new");
    /* The renderer keeps what it needs of the scene. */
    cmlt_scene_release(scene);

    /* Deliberately wrong calls: each is refused with a status and changes
     * nothing. */
    expect_status(cmlt_renderer_render(renderer, 0, 1, NULL), CMLT_ERROR_INVALID_OPERATION, "render before prepare");
    expect_status(cmlt_renderer_render(renderer, 7, 1, NULL), CMLT_ERROR_INVALID_ARGUMENT, "no worker 7");
    expect_status(cmlt_renderer_new(NULL, &config, &camera, &renderer), CMLT_ERROR_NULL_POINTER, "NULL scene");
    {
        cmlt_camera bad = camera;
        bad.fov_degrees = 0.0f / 0.0f; /* NaN */
        expect_status(cmlt_renderer_set_camera(renderer, &bad), CMLT_ERROR_INVALID_ARGUMENT, "NaN field of view");
    }
    printf("bad calls refused\n");

    check(cmlt_renderer_prepare(renderer), "cmlt_renderer_prepare");
    check(cmlt_renderer_render(renderer, 0, (uint64_t)per_pixel * size * size, NULL), "cmlt_renderer_render");

    pixels = (float *)malloc(sizeof(float) * 3 * size * size);
    if (!pixels) return 1;
    check(cmlt_renderer_resolve(renderer, CMLT_FORMAT_RGB32F, (uint8_t *)pixels, 0,
                                sizeof(float) * 3 * size * size),
          "cmlt_renderer_resolve");
    check(cmlt_renderer_get_stats(renderer, &stats), "cmlt_renderer_get_stats");
    /* The Cornell box calls for diffuse reflection and area lights, and for
     * no environment: the renderer simulates only what the scene needs. */
    if ((stats.effects & (CMLT_EFFECT_DIFFUSE | CMLT_EFFECT_AREA_LIGHTS)) !=
            (CMLT_EFFECT_DIFFUSE | CMLT_EFFECT_AREA_LIGHTS) ||
        (stats.effects & CMLT_EFFECT_ENVIRONMENT) != 0) {
        fprintf(stderr, "unexpected effects 0x%x\n", (unsigned)stats.effects);
        return 1;
    }

    /* The same image as 8-bit sRGB for the preview. */
    preview = (uint8_t *)malloc((size_t)4 * size * size);
    if (!preview) return 1;
    check(cmlt_renderer_resolve(renderer, CMLT_FORMAT_RGBA8_SRGB, preview, (size_t)4 * size,
                                (size_t)4 * size * size),
          "cmlt_renderer_resolve");
    f = fopen(out, "wb");
    if (!f) {
        perror(out);
        return 1;
    }
    fprintf(f, "P6\n%u %u\n255\n", size, size);
    for (i = 0; i < (size_t)size * size; ++i) {
        int c;
        for (c = 0; c < 3; ++c) {
            mean[c] += pixels[3 * i + c];
            fputc(preview[4 * i + c], f);
        }
    }
    fclose(f);
    free(preview);
    printf("mean %.9g %.9g %.9g\n", mean[0] / (size * size), mean[1] / (size * size), mean[2] / (size * size));
    printf("rays %llu nonfinite %llu\n", (unsigned long long)(stats.rays + stats.shadow_rays),
           (unsigned long long)stats.nonfinite);
    free(pixels);
    cmlt_renderer_release(renderer);
    return 0;
}
