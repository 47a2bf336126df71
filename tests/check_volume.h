/* Helpers the volume codecs' tests share (tests/test_volume*.c): reading
 * files and meshes, comparing nodes, fields, the volume a surface encloses. */
#ifndef FFD_TEST_CHECK_VOLUME_H
#define FFD_TEST_CHECK_VOLUME_H

#include "check.h"

#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <ffd.h>

static inline unsigned char *slurp(const char *path, size_t *size)
{
    *size = 0;
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    unsigned char *b = malloc((size_t)n + 1);
    *size = fread(b, 1, (size_t)n, f);
    b[*size] = 0;
    fclose(f);
    return b;
}

static inline ffd_mesh *read_ok(const char *path)
{
    ffd_mesh *m = NULL;
    ffd_error err = {{0}};
    if (ffd_mesh_read(path, &m, &err) != FFD_OK)
        fprintf(stderr, "%s: %s\n", path, err.message);
    CHECK(m != NULL);
    return m;
}

static inline unsigned char *write_mem(const ffd_mesh *m, ffd_format f, size_t *size)
{
    ffd_write_options o = {f, FFD_ENCODING_SAME, 0};
    unsigned char *out = NULL;
    ffd_error err = {{0}};
    if (ffd_mesh_write_memory(m, &o, &out, size, &err) != FFD_OK)
        fprintf(stderr, "write: %s\n", err.message);
    CHECK(out != NULL);
    if (!out)
        return NULL;
    unsigned char *text = malloc(*size + 1); /* NUL-terminated, for strstr */
    memcpy(text, out, *size);
    text[*size] = 0;
    ffd_free(out);
    return text;
}

static inline const double *field(const ffd_mesh *m, const char *name)
{
    for (size_t i = 0; i < ffd_mesh_field_count(m); i++) {
        ffd_field_info fi;
        if (ffd_mesh_field_get(m, i, &fi, NULL) == FFD_OK && strcmp(fi.name, name) == 0)
            return fi.values;
    }
    return NULL;
}

static inline bool same_nodes(const ffd_mesh *a, const ffd_mesh *b)
{
    size_t n = ffd_mesh_vertex_count(a);
    return n == ffd_mesh_vertex_count(b) &&
           (n == 0 || memcmp(ffd_mesh_positions(a), ffd_mesh_positions(b), 3 * n * sizeof(double)) == 0);
}

/* Signed volume enclosed by the mesh's faces (fans), by the divergence
 * theorem: positive when they are closed and oriented outwards. */
static inline double enclosed_volume(const ffd_mesh *m)
{
    const double *p = ffd_mesh_positions(m);
    const uint32_t *off = ffd_mesh_face_offsets(m), *ix = ffd_mesh_face_indices(m);
    double v = 0;
    for (size_t f = 0; f < ffd_mesh_face_count(m); f++)
        for (uint32_t k = off[f] + 1; k + 1 < off[f + 1]; k++) {
            const double *a = p + 3 * ix[off[f]], *b = p + 3 * ix[k], *c = p + 3 * ix[k + 1];
            v += (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) +
                  a[2] * (b[0] * c[1] - b[1] * c[0])) / 6;
        }
    return v;
}

#endif
