/* NumPy point sets (src/mesh/mesh_npy.c, docs/volume.md "Point sets"): the
 * '<f8' and '>f4' samples read as the bunny's vertices; untouched writes
 * byte-identical, deformed ones differ only in the moved coordinates' bytes
 * (in the file's own type and byte order); each encoding written and read
 * back; Fortran order, versions 2.0/3.0; surfaces and volumes written as
 * points; bad headers and data refused with their messages (byte offsets). */
#include "check.h"

#include <stdbool.h>
#include <stdint.h>
#include <string.h>

#include <ffd.h>
#include "check_volume.h"

#define VOL FFD_DATA_DIR "/volume/"

static unsigned char *write_enc(const ffd_mesh *m, ffd_encoding enc, size_t *size)
{
    ffd_write_options o = {FFD_FORMAT_NPY, enc, 0};
    unsigned char *out = NULL;
    ffd_error err = {{0}};
    if (ffd_mesh_write_memory(m, &o, &out, size, &err) != FFD_OK)
        fprintf(stderr, "write: %s\n", err.message);
    CHECK(out != NULL);
    return out;
}

static bool contains(const unsigned char *b, const char *s, size_t n)
{
    for (size_t i = 0; i + n <= 128; i++)
        if (memcmp(b + i, s, n) == 0)
            return true;
    return false;
}

/* The bunny's vertices rounded to float, for the '>f4' sample. */
static bool same_as_float(const ffd_mesh *a, const ffd_mesh *f)
{
    size_t n = ffd_mesh_vertex_count(a);
    if (n != ffd_mesh_vertex_count(f))
        return false;
    for (size_t i = 0; i < 3 * n; i++)
        if ((double)(float)ffd_mesh_positions(a)[i] != ffd_mesh_positions(f)[i])
            return false;
    return true;
}

static void test_read_samples(void)
{
    ffd_mesh *obj = read_ok(FFD_DATA_DIR "/bunny.obj");
    ffd_mesh *d = read_ok(VOL "bunny_points.npy");
    ffd_mesh *f = read_ok(VOL "bunny_points_f4be.npy");
    if (obj && d && f) {
        CHECK(same_nodes(obj, d));
        CHECK(same_as_float(obj, f));
        CHECK(ffd_mesh_face_count(d) == 0 && ffd_mesh_cell_count(d) == 0);
        CHECK(ffd_mesh_source_format(d) == FFD_FORMAT_NPY);
    }
    ffd_mesh_destroy(obj);
    ffd_mesh_destroy(d);
    ffd_mesh_destroy(f);
}

static void test_untouched_and_deformed(void)
{
    const char *files[] = {VOL "bunny_points.npy", VOL "bunny_points_f4be.npy"};
    const size_t size[] = {8, 4};
    for (int s = 0; s < 2; s++) {
        size_t n, k;
        unsigned char *src = slurp(files[s], &n);
        ffd_mesh *m = read_ok(files[s]);
        if (!m || !src) {
            free(src);
            continue;
        }
        unsigned char *out = write_enc(m, FFD_ENCODING_SAME, &k);
        CHECK(out && k == n && memcmp(out, src, n) == 0);
        ffd_free(out);
        size_t nv = ffd_mesh_vertex_count(m);
        double *p = malloc(3 * nv * sizeof(double));
        memcpy(p, ffd_mesh_positions(m), 3 * nv * sizeof(double));
        p[3 * 10 + 2] = 0.5; /* point 10's z */
        CHECK_OK(ffd_mesh_set_positions(m, p, NULL, NULL));
        out = write_enc(m, FFD_ENCODING_SAME, &k);
        CHECK(out && k == n);
        size_t data = n - 3 * nv * size[s], at = data + (3 * 10 + 2) * size[s];
        for (size_t i = 0; out && i < n && k == n; i++)
            if (i < at || i >= at + size[s])
                CHECK(out[i] == src[i]);
        ffd_mesh *back = NULL;
        CHECK_OK(ffd_mesh_read_memory(out, k, FFD_FORMAT_NPY, "back", &back, NULL));
        CHECK(back && ffd_mesh_positions(back)[32] == 0.5);
        ffd_mesh_destroy(back);
        ffd_free(out);
        free(p);
        ffd_mesh_destroy(m);
        free(src);
    }
}

/* Both encodings of the '>f4' sample: little-endian is written from data
 * ('<f8'), big-endian is the source's own encoding (patched, '>f4'). */
static void test_encodings(void)
{
    ffd_mesh *m = read_ok(VOL "bunny_points_f4be.npy");
    const ffd_encoding encs[] = {FFD_ENCODING_BINARY_LE, FFD_ENCODING_BINARY_BE};
    const char *descr[] = {"'<f8'", "'>f4'"};
    const size_t vsize[] = {8, 4};
    for (int e = 0; m && e < 2; e++) {
        size_t k;
        unsigned char *out = write_enc(m, encs[e], &k);
        CHECK(out && (k - 1839 * 3 * vsize[e]) % 64 == 0 && memcmp(out + 6, "\x01\x00", 2) == 0);
        CHECK(out && contains(out, descr[e], 5) && contains(out, "(1839, 3)", 9));
        ffd_mesh *back = NULL;
        CHECK_OK(ffd_mesh_read_memory(out, k, FFD_FORMAT_NPY, "enc", &back, NULL));
        CHECK(back && same_nodes(m, back));
        /* and back to big-endian from the '<f8' copy: '>f8' from data */
        if (back && e == 0) {
            size_t k2;
            unsigned char *be = write_enc(back, FFD_ENCODING_BINARY_BE, &k2);
            CHECK(be && contains(be, "'>f8'", 5) && k2 == k);
            ffd_mesh *again = NULL;
            CHECK_OK(ffd_mesh_read_memory(be, k2, FFD_FORMAT_NPY, "be", &again, NULL));
            CHECK(again && same_nodes(m, again));
            ffd_mesh_destroy(again);
            ffd_free(be);
        }
        ffd_mesh_destroy(back);
        ffd_free(out);
    }
    ffd_write_options o = {FFD_FORMAT_NPY, FFD_ENCODING_ASCII, 0};
    unsigned char *out = NULL;
    size_t k;
    ffd_error err = {{0}};
    CHECK(ffd_mesh_write_memory(m, &o, &out, &k, &err) == FFD_ERR_UNSUPPORTED);
    CHECK(strstr(err.message, "NPY has no ascii encoding") != NULL);
    ffd_mesh_destroy(m);
}

/* A surface (OBJ) and a volume mesh written to .npy with the default
 * encoding: '<f8' with every node. */
static void test_meshes_to_points(void)
{
    static const double pts[] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 1, 1, 1};
    static const uint8_t types[] = {FFD_CELL_TETRA, FFD_CELL_TETRA};
    static const uint64_t off[] = {0, 4, 8};
    static const uint32_t idx[] = {0, 1, 2, 3, 1, 4, 2, 3};
    ffd_mesh *v = NULL, *obj = read_ok(FFD_DATA_DIR "/bunny.obj");
    CHECK_OK(ffd_mesh_create_cells(pts, 5, types, off, idx, 2, &v, NULL));
    ffd_mesh *ms[] = {obj, v};
    for (int i = 0; i < 2; i++) {
        if (!ms[i])
            continue;
        size_t k;
        unsigned char *out = write_enc(ms[i], FFD_ENCODING_SAME, &k);
        CHECK(out && contains(out, "'<f8'", 5));
        ffd_mesh *back = NULL;
        CHECK_OK(ffd_mesh_read_memory(out, k, FFD_FORMAT_NPY, "points", &back, NULL));
        CHECK(back && same_nodes(ms[i], back));
        ffd_mesh_destroy(back);
        ffd_free(out);
    }
    ffd_mesh_destroy(v);
    ffd_mesh_destroy(obj);
}

/* A header of version major with the dict text, then the data bytes. */
static size_t make_npy(unsigned char *buf, unsigned major, const char *dict, const void *data,
                       size_t data_size)
{
    size_t hl = strlen(dict), at = 0;
    memcpy(buf, "\x93NUMPY", 6);
    buf[6] = (unsigned char)major;
    buf[7] = 0;
    at = 8;
    buf[at++] = (unsigned char)(hl & 0xff);
    buf[at++] = (unsigned char)(hl >> 8);
    if (major > 1) {
        buf[at++] = 0;
        buf[at++] = 0;
    }
    memcpy(buf + at, dict, hl);
    memcpy(buf + at + hl, data, data_size);
    return at + hl + data_size;
}

static void test_fortran_and_versions(void)
{
    const double rows[6] = {1, 2, 3, 4, 5, 6}; /* C order: (1,2,3), (4,5,6) */
    const double cols[6] = {1, 4, 2, 5, 3, 6}; /* the same points in Fortran order */
    unsigned char buf[512];
    ffd_mesh *a = NULL, *b = NULL, *c = NULL;
    size_t n = make_npy(buf, 1, "{'descr': '<f8', 'fortran_order': False, 'shape': (2, 3), }\n",
                        rows, sizeof rows);
    CHECK_OK(ffd_mesh_read_memory(buf, n, FFD_FORMAT_NPY, "c.npy", &a, NULL));
    n = make_npy(buf, 2, "{\"shape\": (2, 3), \"fortran_order\": True, \"descr\": \"<f8\"}   \n", cols,
                 sizeof cols);
    CHECK_OK(ffd_mesh_read_memory(buf, n, FFD_FORMAT_NPY, "f.npy", &b, NULL));
    n = make_npy(buf, 3, "{'descr': '<f8', 'fortran_order': False, 'shape': (2L, 3L)}\n", rows,
                 sizeof rows);
    CHECK_OK(ffd_mesh_read_memory(buf, n, FFD_FORMAT_NPY, "v3.npy", &c, NULL));
    CHECK(a && b && c && same_nodes(a, b) && same_nodes(a, c));
    if (b) {
        CHECK(ffd_mesh_positions(b)[1] == 2 && ffd_mesh_positions(b)[3] == 4);
        double p[6] = {1, 2, 3, 4, 5, 7};
        CHECK_OK(ffd_mesh_set_positions(b, p, NULL, NULL));
        size_t k;
        unsigned char *out = write_enc(b, FFD_ENCODING_SAME, &k);
        double last;
        memcpy(&last, out + k - 8, 8); /* Fortran order: the last value is point 1's z */
        CHECK(out && k == n && last == 7);
        ffd_free(out);
    }
    ffd_mesh_destroy(a);
    ffd_mesh_destroy(b);
    ffd_mesh_destroy(c);
}

typedef struct {
    unsigned major;
    const char *dict;
    size_t values; /* doubles of data after the header */
    ffd_status status;
    const char *message;
} bad_case;

static const bad_case bad[] = {
    {1, "{'descr': '<i8', 'fortran_order': False, 'shape': (2, 3), }\n", 6, FFD_ERR_UNSUPPORTED,
     "bad.npy: byte 10: dtype '<i8' is not a point set's"},
    {1, "{'descr': '<f8', 'fortran_order': False, 'shape': (3, 2), }\n", 6, FFD_ERR_UNSUPPORTED,
     "bad.npy: byte 10: shape (3, 2) is not (N, 3)"},
    {1, "{'descr': '<f8', 'fortran_order': False, 'shape': (6,), }\n", 6, FFD_ERR_UNSUPPORTED,
     "bad.npy: byte 10: shape (6,) is not (N, 3)"},
    {1, "{'descr': '<f8', 'fortran_order': False, 'shape': (1000000000000, 3), }\n", 6,
     FFD_ERR_PARSE, "shape (1000000000000, 3) needs more than the 48 data bytes the file has"},
    {1, "{'descr': '<f8', 'fortran_order': False, 'shape': (1, 3), }\n", 6, FFD_ERR_PARSE,
     "24 bytes after the (1, 3) array"},
    {1, "{'descr': '<f8', 'shape': (2, 3), }\n", 6, FFD_ERR_PARSE, "the header lacks 'fortran_order'"},
    {1, "{'descr': '<f8', 'fortran_order': 0, 'shape': (2, 3), }\n", 6, FFD_ERR_PARSE,
     "expected True or False for 'fortran_order'"},
    {1, "{'descr': '<f8', 'fortran_order': False, 'shape': (2, 3), 'x': 1}\n", 6, FFD_ERR_PARSE,
     "unknown header key 'x'"},
    {1, "{'descr': [('x', '<f8')], 'fortran_order': False, 'shape': (2,), }\n", 6,
     FFD_ERR_UNSUPPORTED, "'descr' is not a simple type string"},
    {1, "'descr': '<f8'\n", 6, FFD_ERR_PARSE, "bad.npy: byte 10: expected the header dict '{'"},
    {4, "{}\n", 0, FFD_ERR_UNSUPPORTED, "bad.npy: byte 6: NumPy format version 4.0"},
};

static void test_bad_inputs(void)
{
    const double nan_data[6] = {0, 1, 2, 3, 0.0 / 0.0, 5};
    unsigned char buf[512];
    for (size_t i = 0; i < sizeof bad / sizeof *bad; i++) {
        size_t n = make_npy(buf, bad[i].major, bad[i].dict, nan_data, 0);
        memset(buf + n, 0, bad[i].values * 8);
        n += bad[i].values * 8;
        ffd_mesh *m = NULL;
        ffd_error err = {{0}};
        ffd_status s = ffd_mesh_read_memory(buf, n, FFD_FORMAT_NPY, "bad.npy", &m, &err);
        if (s != bad[i].status || !strstr(err.message, bad[i].message))
            fprintf(stderr, "case %zu: status %d, message '%s'\n", i, (int)s, err.message);
        CHECK(s == bad[i].status);
        CHECK(strstr(err.message, bad[i].message) != NULL);
        CHECK(m == NULL);
    }
    /* NaN, with its byte offset */
    size_t n = make_npy(buf, 1, "{'descr': '<f8', 'fortran_order': False, 'shape': (2, 3), }\n",
                        nan_data, sizeof nan_data);
    ffd_mesh *m = NULL;
    ffd_error err = {{0}};
    CHECK(ffd_mesh_read_memory(buf, n, FFD_FORMAT_NPY, "nan.npy", &m, &err) == FFD_ERR_NONFINITE);
    CHECK(strstr(err.message, "nan.npy: byte 102: element [1, 1] (point 1's y, 0-based) is not finite") != NULL);
    /* not NumPy; a header length past the end */
    CHECK(ffd_mesh_read_memory("PK\x03\x04xxxxxxxx", 12, FFD_FORMAT_NPY, "zip.npy", &m, &err) ==
          FFD_ERR_PARSE);
    CHECK(strstr(err.message, "zip.npy: byte 0: expected the NumPy magic") != NULL);
    CHECK(ffd_mesh_read_memory("\x93NUMPY\x01\x00\xff\x00{", 11, FFD_FORMAT_NPY, "h.npy", &m, &err) ==
          FFD_ERR_PARSE);
    CHECK(strstr(err.message, "h.npy: byte 8: header length 255 exceeds the 1 bytes left") != NULL);
}

static void test_truncated_prefixes(void)
{
    size_t n;
    unsigned char *src = slurp(VOL "bunny_points_f4be.npy", &n);
    CHECK(src != NULL);
    for (size_t len = 1; src && len < n; len += len < 200 ? 1 : 97) {
        ffd_mesh *m = NULL;
        ffd_error err = {{0}};
        CHECK(ffd_mesh_read_memory(src, len, FFD_FORMAT_NPY, "cut.npy", &m, &err) != FFD_OK);
        CHECK(strncmp(err.message, "cut.npy", 7) == 0);
        CHECK(m == NULL);
    }
    free(src);
}

int main(int argc, char **argv)
{
    static const check_test tests[] = {
        {"read_samples", test_read_samples},
        {"untouched_and_deformed", test_untouched_and_deformed},
        {"encodings", test_encodings},
        {"meshes_to_points", test_meshes_to_points},
        {"fortran_and_versions", test_fortran_and_versions},
        {"bad_inputs", test_bad_inputs},
        {"truncated_prefixes", test_truncated_prefixes},
    };
    return check_run(tests, sizeof tests / sizeof *tests, argc, argv);
}
