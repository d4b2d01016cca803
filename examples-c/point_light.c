/*
 * point_light.c — a light that is not a mesh, added with cmlt_scene_add_light.
 *
 * Shows: a scene built from the host's arrays (one diffuse floor, no
 * emitting mesh) lit by a point light; a light with a negative intensity
 * being refused; a path-traced image checked against the analytic answer.
 * A point light of intensity I at height h over a diffuse floor of albedo
 * rho gives the floor radiance rho/pi * I cos(theta) / d^2: rho I / (pi h^2)
 * right below the light, less further out. The camera looks straight down
 * from above the light (point lights are invisible and cast no shadow of
 * themselves), so the image's centre sees the point below the light.
 *
 * Prints "centre C expected E" (the mean of the four central pixels and
 * the formula's value there) and "corners K" (the mean of the four corner
 * pixels, further from the light, so darker).
 *
 * Usage: point_light [pt|bdpt] [SAMPLES_PER_PIXEL]
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cmlt.h"

enum { SIZE = 16 };

static void check(cmlt_status s, const char *what) {
    if (s != CMLT_OK) {
        fprintf(stderr, "%s failed: %s (%s)\n", what, cmlt_status_name((uint32_t)s), cmlt_last_error());
        exit(1);
    }
}

int main(int argc, char **argv) {
    const char *method = argc > 1 ? argv[1] : "pt";
    unsigned long per_pixel = argc > 2 ? strtoul(argv[2], NULL, 10) : 64;
    const float rho = 0.5f, intensity = 2.0f, height = 1.0f;
    /* A 20 x 20 floor at y = 0, counter-clockwise seen from above (+y). */
    static const float floor_xyz[4][3] = {{-10, 0, -10}, {-10, 0, 10}, {10, 0, 10}, {10, 0, -10}};
    static const uint32_t floor_tris[2][3] = {{0, 1, 2}, {0, 2, 3}};
    cmlt_material floor_material = {.type_ = CMLT_MATERIAL_DIFFUSE, .color = {rho, rho, rho}, .ior = 1.0f,
                                    .bump_scale = 1.0f, .specular_color = {1.0f, 1.0f, 1.0f},
                                    .transmission_color = {1.0f, 1.0f, 1.0f},
                                    .distribution = CMLT_DISTRIBUTION_GGX};
    cmlt_light light = {.type_ = CMLT_LIGHT_POINT,
                        .color = {intensity, intensity, intensity},
                        .position = {0.0f, height, 0.0f}};
    cmlt_light bad = light;
    /* Looking down the -y axis from 3 above the floor, a narrow view. */
    cmlt_camera camera = {{0.0f, 3.0f, 0.0f}, {0.0f, 0.0f, 0.0f}, {0.0f, 0.0f, 1.0f}, 20.0f, 0.0f, 1.0f};
    cmlt_scene *scene = NULL;
    cmlt_renderer *renderer = NULL;
    cmlt_renderer_config config;
    cmlt_mesh mesh;
    uint32_t material, index = 99;
    float pixels[SIZE * SIZE * 3];
    double centre = 0.0, corners = 0.0;
    int c;

    check(cmlt_scene_new(&scene), "cmlt_scene_new");
    check(cmlt_scene_add_material(scene, &floor_material, &material), "cmlt_scene_add_material");
    memset(&mesh, 0, sizeof mesh);
    mesh.positions = &floor_xyz[0][0];
    mesh.vertex_count = 4;
    mesh.indices = &floor_tris[0][0];
    mesh.triangle_count = 2;
    mesh.material = material;
    check(cmlt_scene_add_mesh(scene, &mesh, NULL), "cmlt_scene_add_mesh");

    /* A negative intensity is refused and adds nothing. */
    bad.color[1] = -1.0f;
    if (cmlt_scene_add_light(scene, &bad, &index) != CMLT_ERROR_INVALID_ARGUMENT || index != 99) {
        fprintf(stderr, "a negative intensity was not refused\n");
        return 1;
    }
    check(cmlt_scene_add_light(scene, &light, &index), "cmlt_scene_add_light");
    if (index != 0) {
        fprintf(stderr, "the first light has index %u\n", index);
        return 1;
    }
    check(cmlt_scene_commit(scene), "cmlt_scene_commit");

    check(cmlt_renderer_config_default(strcmp(method, "bdpt") == 0 ? CMLT_ESTIMATOR_BDPT : CMLT_ESTIMATOR_PT,
                                       &config),
          "cmlt_renderer_config_default");
    config.width = SIZE;
    config.height = SIZE;
    config.seed = 7;
    check(cmlt_renderer_new(scene, &config, &camera, &renderer), "cmlt_renderer_new");
    cmlt_scene_release(scene);
    check(cmlt_renderer_prepare(renderer), "cmlt_renderer_prepare");
    check(cmlt_renderer_render(renderer, 0, (uint64_t)per_pixel * SIZE * SIZE, NULL), "cmlt_renderer_render");
    check(cmlt_renderer_resolve(renderer, CMLT_FORMAT_RGB32F, (uint8_t *)pixels, 0, sizeof pixels),
          "cmlt_renderer_resolve");
    cmlt_renderer_release(renderer);

    for (c = 0; c < 3; ++c) {
        int h = SIZE / 2, e = SIZE - 1;
        centre += pixels[3 * ((h - 1) * SIZE + h - 1) + c] + pixels[3 * ((h - 1) * SIZE + h) + c] +
                  pixels[3 * (h * SIZE + h - 1) + c] + pixels[3 * (h * SIZE + h) + c];
        corners += pixels[3 * 0 + c] + pixels[3 * e + c] + pixels[3 * (e * SIZE) + c] + pixels[3 * (e * SIZE + e) + c];
    }
    /* The four central pixels see the square |x|, |z| < 0.066 around the
     * point below the light, over which cos(theta)/d^2 = h/(h^2+r^2)^1.5
     * averages 0.44 % below its peak 1/h^2. */
    printf("centre %.6f expected %.6f\n", centre / 12.0, rho * intensity / (3.14159265358979 * height * height));
    printf("corners %.6f\n", corners / 12.0);
    return 0;
}
