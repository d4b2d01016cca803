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
#include "example_scene.h"

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

int main(int argc, char **argv) {
    static host_scene hs;
    const char *method = argc > 1 ? argv[1] : "cmlt";
    uint64_t per_pixel = argc > 2 ? strtoull(argv[2], NULL, 10) : 16;
    uint32_t estimator = parse_estimator(method);
    cmlt_intersector isect;

    build_host_scene(&hs);
    isect.user = &hs;
    isect.intersect = cb_intersect;
    isect.occluded = cb_occluded;
    isect.intersect_packet = cb_intersect_packet;
    isect.occluded_packet = cb_occluded_packet;
    compare_with_our_bvh(&hs, &isect, estimator, per_pixel);
    return 0;
}
