/*
 * A brute-force tracer in plain C against include/rtdiff_tracer.h: every triangle
 * against every ray, Moller-Trumbore in double precision from the float inputs.
 * It shows the ABI from C, and the tests build it with one bug switched on to
 * check that rtdiff parity and rtdiff judge catch each with the right class:
 *
 *   cc -O2 -shared -fPIC -Iinclude plugins/c/brute.c -o brute.so            correct
 *   ... -DBREAK_IDS       every primitive id one too high (off by one)
 *   ... -DBREAK_EDGE      the test of the second barycentric skipped (hits outside triangles)
 *   ... -DBREAK_T         every distance scaled by 1 + 1e-4
 *   ... -DBREAK_GARBAGE   NaN barycentrics on every hit
 *   ... -DBREAK_VERSION   reports ABI version 2
 *   ... -DBREAK_SYMBOLS   does not export rtdiff_tracer_occluded_n
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "rtdiff_tracer.h"

struct rtdiff_scene {
    uint32_t count;
    double *tri; /* 9 doubles per triangle: v0, v1, v2 */
};

uint32_t rtdiff_tracer_abi_version(void) {
#ifdef BREAK_VERSION
    return RTDIFF_TRACER_ABI_VERSION + 1;
#else
    return RTDIFF_TRACER_ABI_VERSION;
#endif
}

const char *rtdiff_tracer_name(void) { return "c-brute 1.0"; }

uint32_t rtdiff_tracer_features(void) { return 0; }

static void set_error(char *error, size_t len, const char *msg) {
    if (error && len > 0) {
        strncpy(error, msg, len - 1);
        error[len - 1] = 0;
    }
}

rtdiff_scene *rtdiff_tracer_scene_new(const float *vertices, uint32_t vertex_count, const uint32_t *indices,
                                      uint32_t triangle_count, const float *spheres, uint32_t sphere_count,
                                      char *error, size_t error_len) {
    (void)spheres;
    if (sphere_count > 0) {
        set_error(error, error_len, "c-brute traces triangles only");
        return NULL;
    }
    rtdiff_scene *s = calloc(1, sizeof *s);
    if (!s) {
        set_error(error, error_len, "out of memory");
        return NULL;
    }
    s->count = triangle_count;
    s->tri = malloc(sizeof(double) * 9 * (triangle_count ? triangle_count : 1));
    if (!s->tri) {
        free(s);
        set_error(error, error_len, "out of memory");
        return NULL;
    }
    for (uint32_t i = 0; i < 3 * triangle_count; i++) {
        if (indices[i] >= vertex_count) {
            free(s->tri);
            free(s);
            set_error(error, error_len, "vertex index out of range");
            return NULL;
        }
        for (int k = 0; k < 3; k++) s->tri[3 * i + k] = vertices[3 * indices[i] + k];
    }
    return s;
}

void rtdiff_tracer_scene_free(rtdiff_scene *scene) {
    if (scene) {
        free(scene->tri);
        free(scene);
    }
}

/* Moller-Trumbore in double precision: 1 and (t, u, v) on a hit inside [tnear, tfar]. */
static int hit_triangle(const double *v, const rtdiff_ray *r, double tfar, double *t, double *u, double *w) {
    double o[3] = {r->org_x, r->org_y, r->org_z}, d[3] = {r->dir_x, r->dir_y, r->dir_z};
    double e1[3], e2[3], p[3], s[3], q[3];
    for (int k = 0; k < 3; k++) {
        e1[k] = v[3 + k] - v[k];
        e2[k] = v[6 + k] - v[k];
        s[k] = o[k] - v[k];
    }
    p[0] = d[1] * e2[2] - d[2] * e2[1];
    p[1] = d[2] * e2[0] - d[0] * e2[2];
    p[2] = d[0] * e2[1] - d[1] * e2[0];
    double det = e1[0] * p[0] + e1[1] * p[1] + e1[2] * p[2];
    if (det == 0.0) return 0;
    double inv = 1.0 / det;
    double a = (s[0] * p[0] + s[1] * p[1] + s[2] * p[2]) * inv;
    if (a < 0.0 || a > 1.0) return 0;
    q[0] = s[1] * e1[2] - s[2] * e1[1];
    q[1] = s[2] * e1[0] - s[0] * e1[2];
    q[2] = s[0] * e1[1] - s[1] * e1[0];
    double b = (d[0] * q[0] + d[1] * q[1] + d[2] * q[2]) * inv;
#ifdef BREAK_EDGE
    if (a + b > 1.0) return 0; /* the test b >= 0 skipped */
#else
    if (b < 0.0 || a + b > 1.0) return 0;
#endif
    double tt = (e2[0] * q[0] + e2[1] * q[1] + e2[2] * q[2]) * inv;
    if (tt < r->tnear || tt > tfar) return 0;
    *t = tt;
    *u = a;
    *w = b;
    return 1;
}

static void closest(const rtdiff_scene *s, const rtdiff_ray *r, rtdiff_hit *h) {
    double best = r->tfar, t, u, v;
    h->prim = RTDIFF_INVALID_ID;
    for (uint32_t i = 0; i < s->count; i++) {
        if (hit_triangle(s->tri + 9 * i, r, best, &t, &u, &v) && (h->prim == RTDIFF_INVALID_ID || t < best)) {
            best = t;
            h->prim = i;
            h->t = (float)t;
            h->u = (float)u;
            h->v = (float)v;
        }
    }
    if (h->prim == RTDIFF_INVALID_ID) return;
#ifdef BREAK_IDS
    h->prim += 1;
#endif
#ifdef BREAK_T
    h->t = (float)(best * (1.0 + 1e-4));
#endif
#ifdef BREAK_GARBAGE
    h->u = NAN;
#endif
}

void rtdiff_tracer_intersect1(const rtdiff_scene *scene, const rtdiff_ray *ray, rtdiff_hit *hit) {
    closest(scene, ray, hit);
}

int32_t rtdiff_tracer_occluded1(const rtdiff_scene *scene, const rtdiff_ray *ray) {
    double t, u, v;
    for (uint32_t i = 0; i < scene->count; i++)
        if (hit_triangle(scene->tri + 9 * i, ray, ray->tfar, &t, &u, &v)) return 1;
    return 0;
}

void rtdiff_tracer_intersect_n(const rtdiff_scene *scene, const rtdiff_ray *rays, rtdiff_hit *hits, size_t count) {
    for (size_t i = 0; i < count; i++) closest(scene, rays + i, hits + i);
}

#ifndef BREAK_SYMBOLS
void rtdiff_tracer_occluded_n(const rtdiff_scene *scene, const rtdiff_ray *rays, uint8_t *occluded, size_t count) {
    for (size_t i = 0; i < count; i++) occluded[i] = (uint8_t)rtdiff_tracer_occluded1(scene, rays + i);
}
#endif
