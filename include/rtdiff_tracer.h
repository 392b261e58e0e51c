/*
 * rtdiff_tracer.h: the C ABI of a tracer under test (rtdiff --tracer plugin:PATH).
 *
 * A plugin is a shared library (.so, .dylib, .dll) that exports the functions
 * below with C linkage. rtdiff loads it at run time, checks
 * rtdiff_tracer_abi_version() against RTDIFF_TRACER_ABI_VERSION, builds one
 * scene per set of primitives and calls the queries from many threads at once.
 * Documentation and the verdicts rtdiff gives: docs/plugins.md.
 *
 * Conventions (the same as rtdiff's and Embree's):
 *  - A ray is org + t * dir, t in the closed interval [tnear, tfar]; dir is not
 *    normalised (t is in units of |dir|); tfar may be +infinity.
 *  - Primitive ids: triangle i of the index buffer is primitive i; sphere j is
 *    primitive triangle_count + j. Ids rtdiff reports for a mesh file are the
 *    triangle's position in the file (faces in file order, polygons fanned from
 *    their first vertex; zero-area triangles keep their place).
 *  - u, v: the barycentric weights of the triangle's vertices 1 and 2 (the hit
 *    point is (1-u-v) v0 + u v1 + v v2); for spheres any finite value.
 *  - Closest hit: the hit with the smallest t; rtdiff's own tie rule takes the
 *    lowest id, a plugin may return any primitive of a tie.
 *  - A miss is prim == RTDIFF_INVALID_ID (t, u, v are then ignored).
 *
 * Thread safety: rtdiff calls rtdiff_tracer_intersect*, rtdiff_tracer_occluded*
 * concurrently from several threads on one scene; they must only read it.
 * rtdiff_tracer_scene_new and rtdiff_tracer_scene_free are not called
 * concurrently on the same scene.
 *
 * The buffers given to rtdiff_tracer_scene_new are valid only during the call:
 * copy what you keep.
 */
#ifndef RTDIFF_TRACER_H
#define RTDIFF_TRACER_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* The ABI version this header describes; rtdiff refuses a plugin reporting another one. */
#define RTDIFF_TRACER_ABI_VERSION 1u

/* The primitive id of a miss. */
#define RTDIFF_INVALID_ID 0xFFFFFFFFu

/* Bits of rtdiff_tracer_features(). */
#define RTDIFF_FEATURE_SPHERES 1u /* rtdiff_tracer_scene_new accepts spheres */

/* A ray: 32 bytes, no padding. */
typedef struct rtdiff_ray {
    float org_x, org_y, org_z;
    float dir_x, dir_y, dir_z;
    float tnear, tfar;
} rtdiff_ray;

/* A hit: 16 bytes, no padding. */
typedef struct rtdiff_hit {
    float t;
    uint32_t prim; /* RTDIFF_INVALID_ID: a miss */
    float u, v;
} rtdiff_hit;

/* The plugin's scene: opaque to rtdiff. */
typedef struct rtdiff_scene rtdiff_scene;

/* Must return RTDIFF_TRACER_ABI_VERSION (the value of the header it was built with). */
uint32_t rtdiff_tracer_abi_version(void);

/* A static, NUL-terminated name and version, e.g. "tinybvh 1.6.8 (BVH, SAH)". */
const char *rtdiff_tracer_name(void);

/* RTDIFF_FEATURE_* bits. */
uint32_t rtdiff_tracer_features(void);

/*
 * Build a scene: vertex_count vertices (x, y, z floats each), triangle_count
 * triangles (three u32 vertex indices each, all < vertex_count), and, when the
 * plugin has RTDIFF_FEATURE_SPHERES, sphere_count spheres (centre x, y, z and
 * radius: four floats each; NULL when sphere_count is 0). Returns NULL on
 * failure after writing a NUL-terminated message of at most error_len bytes
 * into error.
 */
rtdiff_scene *rtdiff_tracer_scene_new(const float *vertices, uint32_t vertex_count, const uint32_t *indices,
                                      uint32_t triangle_count, const float *spheres, uint32_t sphere_count,
                                      char *error, size_t error_len);

/* Release a scene made by rtdiff_tracer_scene_new. */
void rtdiff_tracer_scene_free(rtdiff_scene *scene);

/* The closest hit of one ray. */
void rtdiff_tracer_intersect1(const rtdiff_scene *scene, const rtdiff_ray *ray, rtdiff_hit *hit);

/* Whether any primitive is hit in [tnear, tfar]: 1 or 0. */
int32_t rtdiff_tracer_occluded1(const rtdiff_scene *scene, const rtdiff_ray *ray);

/* The closest hits of count rays (hits[i] for rays[i]). */
void rtdiff_tracer_intersect_n(const rtdiff_scene *scene, const rtdiff_ray *rays, rtdiff_hit *hits, size_t count);

/* Any-hit answers of count rays (occluded[i]: 1 or 0). */
void rtdiff_tracer_occluded_n(const rtdiff_scene *scene, const rtdiff_ray *rays, uint8_t *occluded, size_t count);

#ifdef __cplusplus
}
#endif

#endif /* RTDIFF_TRACER_H */
