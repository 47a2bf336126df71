/* bench_mesh — big test meshes for the benchmarks: a triangle mesh
 * subdivided 1 -> 4 (refined_elephant.off: 44K -> 178K vertices), optionally
 * cut to its first `limit` vertices and the faces among them. */
#ifndef FFD_BENCH_MESH_H
#define FFD_BENCH_MESH_H

#include "ffd.h"

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The repository's data/ folder (see data/SOURCES.md), the benchmarks'
 * default DATA_DIR, found from this header's own path
 * (<root>/bench/bench_mesh.h) so that a benchmark runs from any directory. */
static inline const char *bench_data_dir(char *buf, size_t size)
{
    snprintf(buf, size, "%s", __FILE__);
    char *slash = strrchr(buf, '/');
    if (slash)
        *slash = '\0';
    else
        snprintf(buf, size, "bench");
    size_t len = strlen(buf);
    snprintf(buf + len, size - len, "/../data");
    return buf;
}

/* 1 -> 4 midpoint subdivision of a triangle mesh (edge midpoints shared). */
static inline void subdivide(const double *P, size_t nv, const uint32_t *off, const uint32_t *idx,
                      size_t nf, double **outP, size_t *out_nv, uint32_t **out_off,
                      uint32_t **out_idx, size_t *out_nf)
{
    size_t cap = 4 * nf * 3 + 1;
    uint64_t *keys = calloc(cap, sizeof *keys);
    uint32_t *vals = calloc(cap, sizeof *vals);
    double *Q = malloc((nv + 3 * nf) * 3 * sizeof *Q);
    memcpy(Q, P, nv * 3 * sizeof *Q);
    size_t n = nv;
    uint32_t *o = malloc((4 * nf + 1) * sizeof *o), *ix = malloc(12 * nf * sizeof *ix);
    size_t f4 = 0;
    o[0] = 0;
    for (size_t f = 0; f < nf; f++) {
        if (off[f + 1] - off[f] != 3)
            continue;
        uint32_t v[3] = {idx[off[f]], idx[off[f] + 1], idx[off[f] + 2]}, mid[3];
        for (int e = 0; e < 3; e++) {
            uint32_t a = v[e], b = v[(e + 1) % 3];
            uint64_t key = a < b ? ((uint64_t)a << 32 | b) : ((uint64_t)b << 32 | a);
            size_t hsh = (size_t)((key * 0x9E3779B97F4A7C15ull) % cap);
            while (keys[hsh] && keys[hsh] != key + 1)
                hsh = (hsh + 1) % cap;
            if (!keys[hsh]) {
                keys[hsh] = key + 1;
                vals[hsh] = (uint32_t)n;
                for (int d = 0; d < 3; d++)
                    Q[3 * n + d] = (P[3 * (size_t)a + d] + P[3 * (size_t)b + d]) / 2;
                n++;
            }
            mid[e] = vals[hsh];
        }
        uint32_t tris[4][3] = {{v[0], mid[0], mid[2]}, {v[1], mid[1], mid[0]},
                               {v[2], mid[2], mid[1]}, {mid[0], mid[1], mid[2]}};
        for (int t = 0; t < 4; t++) {
            memcpy(ix + 3 * f4, tris[t], sizeof tris[t]);
            f4++;
            o[f4] = (uint32_t)(3 * f4);
        }
    }
    free(keys);
    free(vals);
    *outP = Q;
    *out_nv = n;
    *out_off = o;
    *out_idx = ix;
    *out_nf = f4;
}

/* The mesh subdivided once, cut to limit vertices (0: all). Arrays malloc'd. */
static inline void bench_subdivided(const ffd_mesh *m, size_t limit, double **P, size_t *nv,
                                    uint32_t **off, uint32_t **idx, size_t *nf)
{
    subdivide(ffd_mesh_positions(m), ffd_mesh_vertex_count(m), ffd_mesh_face_offsets(m),
              ffd_mesh_face_indices(m), ffd_mesh_face_count(m), P, nv, off, idx, nf);
    if (limit && limit < *nv) {
        size_t kept = 0;
        for (size_t f = 0; f < *nf; f++) {
            const uint32_t *v = *idx + (*off)[f];
            if (v[0] < limit && v[1] < limit && v[2] < limit) {
                memmove(*idx + 3 * kept, v, 3 * sizeof(uint32_t));
                kept++;
                (*off)[kept] = (uint32_t)(3 * kept);
            }
        }
        *nf = kept;
        *nv = limit;
    }
}

/* dir/refined_elephant.off subdivided and cut (bench_subdivided); 0 on success. */
static inline int bench_elephant(const char *dir, size_t limit, double **P, size_t *nv,
                                 uint32_t **off, uint32_t **idx, size_t *nf)
{
    char path[1024];
    snprintf(path, sizeof path, "%s/refined_elephant.off", dir);
    ffd_mesh *m = NULL;
    ffd_error err = {{0}};
    if (ffd_mesh_read(path, &m, &err) != FFD_OK) {
        fprintf(stderr, "%s\n", err.message);
        return 1;
    }
    bench_subdivided(m, limit, P, nv, off, idx, nf);
    ffd_mesh_destroy(m);
    return 0;
}

#endif
