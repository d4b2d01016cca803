/*
 * media.c — a participating medium through the C API.
 *
 * Shows: a homogeneous medium (cmlt_scene_add_medium) inside a box whose
 * surface is an index-matched boundary (CMLT_MATERIAL_NULL, the medium
 * named by cmlt_scene_set_mesh_media), in front of a glowing wall; a bad
 * medium and a bad medium id being refused; the image's centre checked
 * against Beer–Lambert. The medium only absorbs (albedo 0), so the wall
 * seen through the box's depth d keeps exp(-sigma_t d) of its radiance,
 * per channel, and cmlt passes such a medium with that transmittance as
 * the path's weight (nothing to sample: no noise from the medium). The
 * camera looks straight through the box, so the rays of
 * the central 8 x 8 pixels cross it within 2.5 degrees of normal
 * incidence (their depth at most 0.1 % above d).
 *
 * Prints "centre R G B expected R G B" (the mean of the central 8 x 8
 * pixels and Beer–Lambert's value).
 *
 * Usage: media [pt|bdpt|mlt|cmlt] [SAMPLES_OR_MUTATIONS_PER_PIXEL]
 */
#include <math.h>
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

static uint32_t estimator(const char *name) {
    if (strcmp(name, "bdpt") == 0) return CMLT_ESTIMATOR_BDPT;
    if (strcmp(name, "mlt") == 0) return CMLT_ESTIMATOR_MLT;
    if (strcmp(name, "cmlt") == 0) return CMLT_ESTIMATOR_CMLT;
    return CMLT_ESTIMATOR_PT;
}

int main(int argc, char **argv) {
    const char *method = argc > 1 ? argv[1] : "pt";
    unsigned long per_pixel = argc > 2 ? strtoul(argv[2], NULL, 10) : 16;
    const float depth = 1.0f;
    /* The wall at z = 2, facing the camera (-z), 8 x 8. */
    static const float wall_xyz[4][3] = {{-4, -4, 2}, {4, -4, 2}, {4, 4, 2}, {-4, 4, 2}};
    static const uint32_t wall_tris[2][3] = {{0, 2, 1}, {0, 3, 2}};
    /* The box [-3, 3] x [-3, 3] x [0, 1], wound counter-clockwise seen
     * from outside, so its normals point out and `interior` is inside. */
    static const float box_xyz[8][3] = {{-3, -3, 0}, {3, -3, 0}, {3, 3, 0}, {-3, 3, 0},
                                        {-3, -3, 1}, {3, -3, 1}, {3, 3, 1}, {-3, 3, 1}};
    static const uint32_t box_tris[12][3] = {{0, 2, 1}, {0, 3, 2}, {4, 5, 6}, {4, 6, 7}, {0, 1, 5}, {0, 5, 4},
                                             {1, 2, 6}, {1, 6, 5}, {2, 3, 7}, {2, 7, 6}, {3, 0, 4}, {3, 4, 7}};
    const cmlt_medium absorber = {.sigma_t = {0.5f, 1.0f, 2.0f}, .albedo = {0.0f, 0.0f, 0.0f},
                                  .phase = CMLT_PHASE_ISOTROPIC};
    cmlt_medium bad = absorber;
    cmlt_material black = {.type_ = CMLT_MATERIAL_DIFFUSE, .ior = 1.0f, .bump_scale = 1.0f,
                           .specular_color = {1.0f, 1.0f, 1.0f}, .transmission_color = {1.0f, 1.0f, 1.0f},
                           .distribution = CMLT_DISTRIBUTION_GGX};
    cmlt_material boundary = black;
    /* From 3 in front of the box, looking down +z, a narrow view. */
    cmlt_camera camera = {{0.0f, 0.0f, -3.0f}, {0.0f, 0.0f, 0.0f}, {0.0f, 1.0f, 0.0f}, 10.0f, 0.0f, 1.0f};
    cmlt_scene *scene = NULL;
    cmlt_renderer *renderer = NULL;
    cmlt_renderer_config config;
    cmlt_mesh mesh;
    uint32_t wall_material, null_material, medium = 99;
    float pixels[SIZE * SIZE * 3];
    double centre[3] = {0.0, 0.0, 0.0};
    int c, x, y;

    check(cmlt_scene_new(&scene), "cmlt_scene_new");
    /* An albedo above 1 is refused and takes no id. */
    bad.albedo[0] = 1.5f;
    if (cmlt_scene_add_medium(scene, &bad, &medium) != CMLT_ERROR_INVALID_ARGUMENT || medium != 99) {
        fprintf(stderr, "an albedo above 1 was not refused\n");
        return 1;
    }
    check(cmlt_scene_add_medium(scene, &absorber, &medium), "cmlt_scene_add_medium");
    check(cmlt_scene_add_material(scene, &black, &wall_material), "cmlt_scene_add_material");
    boundary.type_ = CMLT_MATERIAL_NULL;
    check(cmlt_scene_add_material(scene, &boundary, &null_material), "cmlt_scene_add_material");

    memset(&mesh, 0, sizeof mesh);
    mesh.positions = &wall_xyz[0][0];
    mesh.vertex_count = 4;
    mesh.indices = &wall_tris[0][0];
    mesh.triangle_count = 2;
    mesh.material = wall_material;
    mesh.emission[0] = mesh.emission[1] = mesh.emission[2] = 1.0f;
    check(cmlt_scene_add_mesh(scene, &mesh, NULL), "cmlt_scene_add_mesh (wall)");
    mesh.positions = &box_xyz[0][0];
    mesh.vertex_count = 8;
    mesh.indices = &box_tris[0][0];
    mesh.triangle_count = 12;
    mesh.material = null_material;
    mesh.emission[0] = mesh.emission[1] = mesh.emission[2] = 0.0f;
    check(cmlt_scene_add_mesh(scene, &mesh, NULL), "cmlt_scene_add_mesh (box)");
    /* Mesh 1 is the box; medium 1 does not exist. */
    if (cmlt_scene_set_mesh_media(scene, 1, medium + 1, CMLT_MEDIUM_NONE) != CMLT_ERROR_INVALID_ARGUMENT) {
        fprintf(stderr, "a medium id that does not exist was not refused\n");
        return 1;
    }
    check(cmlt_scene_set_mesh_media(scene, 1, medium, CMLT_MEDIUM_NONE), "cmlt_scene_set_mesh_media");
    check(cmlt_scene_commit(scene), "cmlt_scene_commit");

    check(cmlt_renderer_config_default(estimator(method), &config), "cmlt_renderer_config_default");
    config.width = SIZE;
    config.height = SIZE;
    config.seed = 3;
    check(cmlt_renderer_new(scene, &config, &camera, &renderer), "cmlt_renderer_new");
    cmlt_scene_release(scene);
    check(cmlt_renderer_prepare(renderer), "cmlt_renderer_prepare");
    check(cmlt_renderer_render(renderer, 0, (uint64_t)per_pixel * SIZE * SIZE, NULL), "cmlt_renderer_render");
    check(cmlt_renderer_resolve(renderer, CMLT_FORMAT_RGB32F, (uint8_t *)pixels, 0, sizeof pixels),
          "cmlt_renderer_resolve");
    cmlt_renderer_release(renderer);

    for (y = SIZE / 4; y < 3 * SIZE / 4; ++y) {
        for (x = SIZE / 4; x < 3 * SIZE / 4; ++x) {
            for (c = 0; c < 3; ++c) centre[c] += pixels[3 * (y * SIZE + x) + c] / (SIZE * SIZE / 4.0);
        }
    }
    printf("centre %.6f %.6f %.6f expected %.6f %.6f %.6f\n", centre[0], centre[1], centre[2],
           exp(-absorber.sigma_t[0] * depth), exp(-absorber.sigma_t[1] * depth),
           exp(-absorber.sigma_t[2] * depth));
    return 0;
}
