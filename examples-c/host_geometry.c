/*
 * host_geometry.c — the host traces the rays and owns analytic shapes.
 *
 * Shows: a scene built from the host's own arrays (a floor and an area
 * light as triangles, positions with a stride of 4 floats) plus two
 * analytic spheres the host defines itself (cmlt_scene_add_shapes: a
 * mirror sphere and a white diffuse one), and the host's own ray tracer
 * plugged in through callbacks — single rays and SoA packets of 4/8/16
 * lanes with an active mask — as an engine would route cmlt's bundles into
 * its packet tracer. The host tracer is a Möller–Trumbore loop over its
 * triangles and an exact ray–sphere test; a sphere hit is reported as
 * CMLT_SHAPE_BIT | shape with its polar angles as (u, v), from which the
 * surface callback rebuilds the point cmlt shades. The same frame is then
 * rendered by cmlt's own BVH over finely tessellated spheres; both means
 * are printed (they agree to within noise and tessellation) with the
 * number of callback calls and any rejected host answers.
 *
 * Usage: host_geometry [pt|bdpt|mlt|cmlt] [BUDGET_PER_PIXEL]
 */
#include "example_scene.h"

/* ---- The host's world: its triangles and its analytic spheres. ---- */

typedef struct sphere {
    float c[3], r;
} sphere;

/* Sphere 0 is the mirror, sphere 1 the white one: one per material, so
 * each is its own shape group; a group's `user` points at its first
 * sphere. */
static const sphere spheres[2] = {{{-0.6f, 0.55f, 0.1f}, 0.55f}, {{0.75f, 0.4f, -0.3f}, 0.4f}};

enum { HOST_TRIANGLES = 4 }; /* floor and light: triangles 0–3 of the host arrays */

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

/* The nearest crossing of sphere `k` in (0, tfar), solved in double so
 * rays leaving its surface (cmlt offsets them past the point's error
 * bound) do not find it again; (u, v) are the hit's polar angles. */
static int hit_sphere(int k, const float o[3], const float d[3], float tfar, float *out_t, float *out_u,
                      float *out_v) {
    const sphere *s = &spheres[k];
    double oc[3], a = 0.0, hb = 0.0, c = 0.0, disc, root, t0, t1, t, n[3];
    int i;
    for (i = 0; i < 3; ++i) {
        oc[i] = (double)o[i] - s->c[i];
        a += (double)d[i] * d[i];
        hb += oc[i] * d[i];
        c += oc[i] * oc[i];
    }
    c -= (double)s->r * s->r;
    disc = hb * hb - a * c;
    if (!(disc >= 0.0)) return 0;
    root = sqrt(disc);
    t0 = (-hb - root) / a;
    t1 = (-hb + root) / a;
    t = (float)t0 > 0.0f ? t0 : t1;
    if (!((float)t > 0.0f) || !((float)t < tfar)) return 0;
    for (i = 0; i < 3; ++i) n[i] = (oc[i] + t * d[i]) / s->r;
    *out_t = (float)t;
    *out_u = (float)acos(n[1] < -1.0 ? -1.0 : n[1] > 1.0 ? 1.0 : n[1]);
    *out_v = (float)atan2(n[2], n[0]);
    return 1;
}

static void trace(const host_scene *s, const float o[3], const float d[3], float tfar, int any, cmlt_hit *hit) {
    uint32_t t;
    int k;
    hit->prim_id = CMLT_INVALID_ID;
    hit->t = tfar;
    for (t = 0; t < HOST_TRIANGLES; ++t) {
        float dist, u, v;
        if (hit_triangle(s, t, o, d, hit->t, &dist, &u, &v)) {
            hit->t = dist;
            hit->u = u;
            hit->v = v;
            hit->prim_id = t;
            if (any) return;
        }
    }
    for (k = 0; k < 2; ++k) {
        float dist, u, v;
        if (hit_sphere(k, o, d, hit->t, &dist, &u, &v)) {
            hit->t = dist;
            hit->u = u;
            hit->v = v;
            /* Shape numbers follow cmlt_scene_add_shapes: one per group. */
            hit->prim_id = CMLT_SHAPE_BIT | (uint32_t)k;
            if (any) return;
        }
    }
}

/* The point of shape `shape` of a group at polar angles (u, v): on the
 * sphere exactly, with the error bound of a point computed on it. */
static uint32_t cb_surface(void *user, uint32_t shape, float u, float v, cmlt_surface *out) {
    const sphere *s = (const sphere *)user + shape;
    float n[3];
    int i;
    n[0] = sinf(u) * cosf(v);
    n[1] = cosf(u);
    n[2] = sinf(u) * sinf(v);
    for (i = 0; i < 3; ++i) {
        out->p[i] = s->c[i] + s->r * n[i];
        out->p_error[i] = 5.0f * FLT_EPSILON * fabsf(out->p[i]);
        out->ng[i] = n[i];
        out->ns[i] = n[i];
    }
    out->uv[0] = v / 6.2831853f;
    out->uv[1] = u / 3.14159265f;
    return 1;
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

/* The cmlt scene: the host's floor and light, and either the analytic
 * spheres traced by `isect`, or (isect NULL) the same spheres finely
 * tessellated, traced by cmlt's BVH. */
static cmlt_scene *make_host_scene(host_scene *hs, const cmlt_intersector *isect) {
    uint32_t m_white, m_mirror, first, k;
    cmlt_mesh mesh;
    cmlt_scene *scene = begin_scene(hs, &m_white, &m_mirror, &mesh);
    for (k = 0; k < 2; ++k) {
        uint32_t material = k == 0 ? m_mirror : m_white;
        if (isect) {
            cmlt_shapes group;
            group.count = 1;
            group.material = material;
            group.user = (void *)&spheres[k];
            group.surface = cb_surface;
            check(cmlt_scene_add_shapes(scene, &group, &first), "cmlt_scene_add_shapes");
            if (first != k) {
                fprintf(stderr, "unexpected shape numbering\n");
                exit(1);
            }
        } else {
            /* Tessellated sphere k: its triangles follow the host's four. */
            uint32_t per_sphere = (hs->ntris - HOST_TRIANGLES) / 2;
            mesh.indices = &hs->tris[HOST_TRIANGLES + k * per_sphere][0];
            mesh.triangle_count = per_sphere;
            mesh.material = material;
            check(cmlt_scene_add_mesh(scene, &mesh, &first), "add_mesh sphere");
        }
    }
    if (isect) check(cmlt_scene_set_intersector(scene, isect), "cmlt_scene_set_intersector");
    check(cmlt_scene_commit(scene), "cmlt_scene_commit");
    return scene;
}

int main(int argc, char **argv) {
    static host_scene hs;
    const char *method = argc > 1 ? argv[1] : "cmlt";
    uint64_t per_pixel = argc > 2 ? strtoull(argv[2], NULL, 10) : 16;
    uint32_t estimator = parse_estimator(method);
    cmlt_intersector isect;
    cmlt_scene *host_traced, *bvh_traced;
    cmlt_stats host_stats, bvh_stats;
    double host_mean, bvh_mean;
    int k;

    build_floor_and_light(&hs);
    /* Only cmlt's reference scene uses these triangles. */
    for (k = 0; k < 2; ++k) add_sphere(&hs, spheres[k].c[0], spheres[k].c[1], spheres[k].c[2], spheres[k].r, 40, 80);
    isect.user = &hs;
    isect.intersect = cb_intersect;
    isect.occluded = cb_occluded;
    isect.intersect_packet = cb_intersect_packet;
    isect.occluded_packet = cb_occluded_packet;

    host_traced = make_host_scene(&hs, &isect);
    bvh_traced = make_host_scene(&hs, NULL);
    host_mean = render_mean(host_traced, estimator, per_pixel, &host_stats);
    bvh_mean = render_mean(bvh_traced, estimator, per_pixel, &bvh_stats);
    printf("host mean %.6f\n", host_mean);
    printf("bvh mean %.6f\n", bvh_mean);
    printf("callbacks %lu %lu %lu\n", hs.single_calls, hs.packet_calls, hs.packet_lanes);
    printf("rejected %llu nonfinite %llu %llu\n",
           (unsigned long long)(host_stats.rejected_host_hits + host_stats.rejected_host_surfaces),
           (unsigned long long)host_stats.nonfinite, (unsigned long long)bvh_stats.nonfinite);
    cmlt_scene_release(host_traced);
    cmlt_scene_release(bvh_traced);
    return 0;
}
