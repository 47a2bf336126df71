/* SU2 codec (src/mesh/mesh_su2.c, docs/volume.md "SU2"): the samples of
 * data/volume read with their cells, boundary faces and markers; untouched
 * writes byte-identical, deformed ones differ only in point lines; 2D files
 * stay 2D; writes from data (a created mixed mesh, a surface, a field of
 * tags) read back with the same nodes, cells and tags; every bad input
 * refused with its message; every truncated prefix fails cleanly. */
#include "check.h"

#include <stdbool.h>
#include <string.h>

#include <ffd.h>

#include "mesh/mesh_cells.h"
#include "check_volume.h"

#define VOL FFD_DATA_DIR "/volume/"

static ffd_mesh *read_mem(const unsigned char *b, size_t n, ffd_format f)
{
    ffd_mesh *m = NULL;
    ffd_error err = {{0}};
    if (ffd_mesh_read_memory(b, n, f, "mem.su2", &m, &err) != FFD_OK)
        fprintf(stderr, "read back: %s\n", err.message);
    CHECK(m != NULL);
    return m;
}

static size_t count_type(const ffd_mesh *m, uint8_t t)
{
    size_t n = 0;
    for (size_t c = 0; c < ffd_mesh_cell_count(m); c++)
        n += ffd_mesh_cell_types(m)[c] == t;
    return n;
}

static bool same_cells(const ffd_mesh *a, const ffd_mesh *b)
{
    size_t n = ffd_mesh_cell_count(a);
    if (n != ffd_mesh_cell_count(b))
        return false;
    if (n == 0)
        return true;
    if (memcmp(ffd_mesh_cell_types(a), ffd_mesh_cell_types(b), n) ||
        memcmp(ffd_mesh_cell_offsets(a), ffd_mesh_cell_offsets(b), (n + 1) * sizeof(uint64_t)))
        return false;
    return memcmp(ffd_mesh_cell_indices(a), ffd_mesh_cell_indices(b),
                  ffd_mesh_cell_offsets(a)[n] * sizeof(uint32_t)) == 0;
}

/* Signed volume enclosed by the faces: positive for outward boundary faces. */
static void test_read_samples(void)
{
    ffd_mesh *m = read_ok(VOL "mixed.su2");
    if (m) {
        CHECK(ffd_mesh_vertex_count(m) == 14);
        CHECK(ffd_mesh_cell_count(m) == 4);
        CHECK(count_type(m, FFD_CELL_HEXAHEDRON) == 1 && count_type(m, FFD_CELL_WEDGE) == 1 &&
              count_type(m, FFD_CELL_PYRAMID) == 1 && count_type(m, FFD_CELL_TETRA) == 1);
        CHECK(ffd_mesh_is_volume(m));
        CHECK(ffd_mesh_face_count(m) == 16); /* 20 cell faces, 2 shared pairs */
        /* every cell positive (the wedge in VTK order): the boundary encloses 1 + 1/2 + 1/3 + 1/6 */
        CHECK_NEAR(enclosed_volume(m), 2.0, 1e-12);
        const double *tag = field(m, "su2:tag");
        CHECK(tag && tag[0] == 0 && tag[3] == 0);
    }
    ffd_mesh_destroy(m);

    m = read_ok(VOL "box_markers.su2");
    if (m) {
        CHECK(ffd_mesh_vertex_count(m) == 12);
        CHECK(count_type(m, FFD_CELL_HEXAHEDRON) == 2 && count_type(m, FFD_CELL_QUAD) == 10);
        CHECK(ffd_mesh_face_count(m) == 10);
        CHECK_NEAR(enclosed_volume(m), 2.0, 1e-12);
        const double *tag = field(m, "su2:tag");
        CHECK(tag != NULL);
        if (tag) { /* meshio's numbering: inlet 1, outlet 2, walls 3 */
            CHECK(tag[0] == 0 && tag[1] == 0 && tag[2] == 1 && tag[3] == 2);
            for (int c = 4; c < 12; c++)
                CHECK(tag[c] == 3);
        }
        CHECK(ffd_mesh_cell_indices(m)[ffd_mesh_cell_offsets(m)[2]] == 0); /* inlet's first node */
    }
    ffd_mesh_destroy(m);

    m = read_ok(VOL "square_2d.su2");
    if (m) {
        CHECK(ffd_mesh_vertex_count(m) == 8);
        CHECK(!ffd_mesh_is_volume(m));
        CHECK(count_type(m, FFD_CELL_QUAD) == 2 && count_type(m, FFD_CELL_TRIANGLE) == 2 &&
              count_type(m, FFD_CELL_LINE) == 4);
        CHECK(ffd_mesh_face_count(m) == 4); /* the 2D cells */
        for (size_t i = 0; i < 8; i++)
            CHECK(ffd_mesh_positions(m)[3 * i + 2] == 0);
        CHECK(ffd_mesh_positions(m)[3 * 7] == 1.0 && ffd_mesh_positions(m)[3 * 7 + 1] == 1.0);
        const double *tag = field(m, "su2:tag");
        CHECK(tag && tag[3] == 0 && tag[4] == 1 && tag[5] == 1 && tag[6] == 2 && tag[7] == 2);
    }
    ffd_mesh_destroy(m);
}

static const char *const samples[] = {"mixed.su2", "box_markers.su2", "square_2d.su2"};

static void test_untouched_identical(void)
{
    for (size_t s = 0; s < sizeof samples / sizeof *samples; s++) {
        char path[512];
        snprintf(path, sizeof path, VOL "%s", samples[s]);
        size_t n, k;
        unsigned char *src = slurp(path, &n);
        ffd_mesh *m = read_ok(path);
        if (!m || !src) {
            free(src);
            continue;
        }
        unsigned char *out = write_mem(m, FFD_FORMAT_SU2, &k);
        CHECK(out && k == n && memcmp(out, src, n) == 0);
        free(out);
        ffd_mesh_destroy(m);
        free(src);
    }
}

/* Lines of text: [start offsets], count. */
static size_t split_lines(const unsigned char *b, size_t n, size_t *starts, size_t cap)
{
    size_t k = 0;
    for (size_t i = 0; i < n && k < cap; i++)
        if (i == 0 || b[i - 1] == '\n')
            starts[k++] = i;
    return k;
}

static void test_deformed_only_coordinates(void)
{
    for (size_t s = 0; s < sizeof samples / sizeof *samples; s++) {
        char path[512];
        snprintf(path, sizeof path, VOL "%s", samples[s]);
        size_t n, k;
        unsigned char *src = slurp(path, &n);
        ffd_mesh *m = read_ok(path);
        if (!m || !src) {
            free(src);
            continue;
        }
        bool flat = strstr(samples[s], "2d") != NULL;
        size_t nv = ffd_mesh_vertex_count(m);
        double *p = malloc(3 * nv * sizeof(double));
        for (size_t i = 0; i < nv; i++) {
            const double *q = ffd_mesh_positions(m) + 3 * i;
            p[3 * i] = 1.5 * q[0] + 0.25 * q[1] + 0.125;
            p[3 * i + 1] = q[1] - 0.3 * q[0];
            p[3 * i + 2] = flat ? 0 : q[2] * 0.7 + 0.01 * q[0];
        }
        CHECK_OK(ffd_mesh_set_positions(m, p, NULL, NULL));
        unsigned char *out = write_mem(m, FFD_FORMAT_SU2, &k);
        ffd_mesh *back = out ? read_mem(out, k, FFD_FORMAT_SU2) : NULL;
        if (back) {
            CHECK(memcmp(ffd_mesh_positions(back), p, 3 * nv * sizeof(double)) == 0);
            CHECK(same_cells(m, back));
        }
        /* Line by line: the same lines, and those that differ are point lines
         * (after NPOIN=) whose non-coordinate words are unchanged. */
        size_t a[256], b[256];
        size_t la = split_lines(src, n, a, 256), lb = out ? split_lines(out, k, b, 256) : 0;
        CHECK(la == lb);
        size_t npoin = 0, changed = 0;
        for (size_t i = 0; i < la && i < lb; i++) {
            const char *x = (const char *)src + a[i], *y = (const char *)out + b[i];
            size_t xl = (i + 1 < la ? a[i + 1] : n) - a[i], yl = (i + 1 < lb ? b[i + 1] : k) - b[i];
            if (strncmp(x, "NPOIN=", 6) == 0)
                npoin = i;
            if (xl == yl && memcmp(x, y, xl) == 0)
                continue;
            changed++;
            CHECK(npoin && i > npoin && i <= npoin + nv);
            double vx[6], vy[6];
            char lx[256], ly[256];
            snprintf(lx, sizeof lx, "%.*s", (int)xl, x);
            snprintf(ly, sizeof ly, "%.*s", (int)yl, y);
            int cx = sscanf(lx, "%lf %lf %lf %lf %lf", &vx[0], &vx[1], &vx[2], &vx[3], &vx[4]);
            int cy = sscanf(ly, "%lf %lf %lf %lf %lf", &vy[0], &vy[1], &vy[2], &vy[3], &vy[4]);
            CHECK(cx == cy);
            int dim = flat ? 2 : 3;
            for (int j = dim; j < cx && j < cy; j++)
                CHECK(vx[j] == vy[j]); /* the point index */
        }
        CHECK(changed > 0);
        ffd_mesh_destroy(back);
        free(out);
        free(p);
        ffd_mesh_destroy(m);
        free(src);
    }
}

static void test_2d_refuses_z(void)
{
    ffd_mesh *m = read_ok(VOL "square_2d.su2");
    if (!m)
        return;
    double p[24];
    memcpy(p, ffd_mesh_positions(m), sizeof p);
    p[3 * 5 + 2] = 0.5;
    CHECK_OK(ffd_mesh_set_positions(m, p, NULL, NULL));
    ffd_write_options o = {FFD_FORMAT_SU2, FFD_ENCODING_SAME, 0};
    unsigned char *out = NULL;
    size_t k = 0;
    ffd_error err = {{0}};
    CHECK(ffd_mesh_write_memory(m, &o, &out, &k, &err) == FFD_ERR_UNSUPPORTED);
    CHECK(strstr(err.message, "point 5 has z = 0.5") && strstr(err.message, "NDIME= 2"));
    CHECK(out == NULL);
    ffd_mesh_destroy(m);
}

/* A mixed hex/wedge/pyramid/tet mesh with boundary triangles and quads. */
static ffd_mesh *mixed_created(void)
{
    static const double pts[14 * 3] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 0, 0, 1, 1, 0, 1,
                                       1, 1, 1, 0, 1, 1, 2, 0, 0, 2, 1, 0, 2, 0, 1, 2, 1, 1,
                                       0.5, 0.5, 2, 0.5, 0.5, -1};
    static const uint8_t types[] = {FFD_CELL_HEXAHEDRON, FFD_CELL_WEDGE, FFD_CELL_PYRAMID,
                                    FFD_CELL_TETRA, FFD_CELL_QUAD, FFD_CELL_TRIANGLE,
                                    FFD_CELL_TRIANGLE};
    static const uint64_t off[] = {0, 8, 14, 19, 23, 27, 30, 33};
    static const uint32_t idx[] = {0, 1, 2, 3, 4, 5, 6, 7, 1, 2, 8, 5, 6, 10, 4, 5, 6,
                                   7, 12, 0, 2, 1, 13, 0, 4, 7, 3, 1, 8, 2, 4, 12, 5};
    ffd_mesh *m = NULL;
    CHECK_OK(ffd_mesh_create_cells(pts, 14, types, off, idx, 7, &m, NULL));
    return m;
}

static void test_from_created_mesh(void)
{
    ffd_mesh *m = mixed_created();
    if (!m)
        return;
    size_t k;
    /* without a su2:tag field: the 2D cells are one marker, marker_1 */
    unsigned char *out = write_mem(m, FFD_FORMAT_SU2, &k);
    CHECK(out && strstr((char *)out, "NDIME= 3\nNELEM= 4\n") &&
          strstr((char *)out, "NMARK= 1\nMARKER_TAG= marker_1\nMARKER_ELEMS= 3\n"));
    ffd_mesh *back = out ? read_mem(out, k, FFD_FORMAT_SU2) : NULL;
    if (back) {
        CHECK(same_nodes(m, back));
        CHECK(same_cells(m, back));
        const double *tag = field(back, "su2:tag");
        CHECK(tag && tag[3] == 0 && tag[4] == 1 && tag[6] == 1);
    }
    ffd_mesh_destroy(back);
    free(out);

    /* with tags: grouped by tag, ascending (the quad's tag 7 after the triangles' 2) */
    double tags[7] = {0, 0, 0, 0, 7, 2, 2};
    CHECK(ffd_mesh_add_field(m, "su2:tag", FFD_FIELD_CELL, 1, FFD_SPAN_I32, tags, 7));
    out = write_mem(m, FFD_FORMAT_SU2, &k);
    CHECK(out && strstr((char *)out, "NMARK= 2\nMARKER_TAG= marker_2\nMARKER_ELEMS= 2\n5 1 8 2\n"
                                     "5 4 12 5\nMARKER_TAG= marker_7\nMARKER_ELEMS= 1\n9 0 4 7 3\n"));
    back = out ? read_mem(out, k, FFD_FORMAT_SU2) : NULL;
    if (back) {
        CHECK(same_nodes(m, back));
        CHECK(ffd_mesh_cell_count(back) == 7 && count_type(back, FFD_CELL_TRIANGLE) == 2);
        const double *tag = field(back, "su2:tag");
        /* names are not integers: meshio's rule numbers them 1, 2 */
        CHECK(tag && tag[4] == 1 && tag[5] == 1 && tag[6] == 2);
        CHECK_NEAR(enclosed_volume(back), enclosed_volume(m), 1e-12);
    }
    ffd_mesh_destroy(back);
    free(out);
    ffd_mesh_destroy(m);
}

static void test_from_surface(void)
{
    ffd_mesh *m = read_ok(FFD_DATA_DIR "/bunny.obj");
    if (!m)
        return;
    size_t k;
    unsigned char *out = write_mem(m, FFD_FORMAT_SU2, &k);
    ffd_mesh *back = out ? read_mem(out, k, FFD_FORMAT_SU2) : NULL;
    if (back) {
        CHECK(same_nodes(m, back));
        CHECK(ffd_mesh_cell_count(back) == ffd_mesh_face_count(m));
        CHECK(count_type(back, FFD_CELL_TRIANGLE) == ffd_mesh_face_count(m));
        CHECK(ffd_mesh_face_count(back) == ffd_mesh_face_count(m));
        CHECK(memcmp(ffd_mesh_face_indices(back), ffd_mesh_face_indices(m),
                     ffd_mesh_face_offsets(m)[ffd_mesh_face_count(m)] * sizeof(uint32_t)) == 0);
        CHECK(strstr((char *)out, "NMARK= 0\n") != NULL);
    }
    ffd_mesh_destroy(back);
    free(out);
    ffd_mesh_destroy(m);

    /* a 2D sample written from data (through a created copy) stays 2D */
    m = read_ok(VOL "square_2d.su2");
    if (!m)
        return;
    ffd_mesh *c = NULL;
    CHECK_OK(ffd_mesh_create_cells(ffd_mesh_positions(m), ffd_mesh_vertex_count(m),
                                   ffd_mesh_cell_types(m), ffd_mesh_cell_offsets(m),
                                   ffd_mesh_cell_indices(m), ffd_mesh_cell_count(m), &c, NULL));
    out = c ? write_mem(c, FFD_FORMAT_SU2, &k) : NULL;
    CHECK(out && strncmp((char *)out, "NDIME= 2\n", 9) == 0 && strstr((char *)out, "\n0.5 0.5\n"));
    back = out ? read_mem(out, k, FFD_FORMAT_SU2) : NULL;
    if (back) {
        CHECK(same_nodes(m, back));
        CHECK(same_cells(m, back));
    }
    ffd_mesh_destroy(back);
    free(out);
    ffd_mesh_destroy(c);
    ffd_mesh_destroy(m);
}

static void test_unwritable_cells(void)
{
    static const double pts[] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 0.5, 1.5, 0};
    static const uint8_t types[] = {FFD_CELL_POLYGON};
    static const uint64_t off[] = {0, 5};
    static const uint32_t idx[] = {0, 1, 2, 4, 3};
    ffd_mesh *m = NULL;
    CHECK_OK(ffd_mesh_create_cells(pts, 5, types, off, idx, 1, &m, NULL));
    ffd_write_options o = {FFD_FORMAT_SU2, FFD_ENCODING_SAME, 0};
    unsigned char *out = NULL;
    size_t k;
    ffd_error err = {{0}};
    CHECK(ffd_mesh_write_memory(m, &o, &out, &k, &err) == FFD_ERR_UNSUPPORTED);
    CHECK(strstr(err.message, "cell 0 is a polygon") != NULL);
    ffd_mesh_destroy(m);
}

typedef struct {
    const char *text;
    ffd_status status;
    const char *message;
} bad_case;

static const bad_case bad[] = {
    {"NDIME= 3\nNPOIN= 3\n0 0 0\n% room for a second point\n", FFD_ERR_PARSE,
     "bad.su2:5: expected point 2 of 3, found end of file"},
    {"NDIME= 3\nNPOIN= 1000000000000\n0 0 0\n", FFD_ERR_PARSE,
     "bad.su2:2: NPOIN= 1000000000000 cannot fit in the 6 bytes left"},
    {"NDIME= 3\nNELEM= 99999999\n", FFD_ERR_PARSE, "bad.su2:2: NELEM= 99999999 cannot fit"},
    {"NDIME= 2\nNELEM= 1\n5 0 1 7\nNPOIN= 3\n0 0\n1 0\n0 1\nNMARK= 0\n", FFD_ERR_RANGE,
     "bad.su2:3: node 7 out of range (3 nodes)"},
    {"NDIME= 2\nNELEM= 0\nNPOIN= 1\nnan 0\n", FFD_ERR_NONFINITE,
     "bad.su2:4: coordinate x of point 1 is not finite"},
    {"NDIME= 3\nNELEM= 0\nNPOIN= 1\n0 0 inf\n", FFD_ERR_NONFINITE,
     "bad.su2:4: coordinate z of point 1 is not finite"},
    {"NZONE= 2\nIZONE= 1\nNDIME= 3\n", FFD_ERR_UNSUPPORTED,
     "bad.su2:1: multi-zone SU2 files (NZONE= 2) are not supported"},
    {"NDIME= 3\nNELEM= 1\n42 0 1 2 3\n", FFD_ERR_UNSUPPORTED,
     "bad.su2:3: element type 42 is not an SU2 type"},
    {"NDIME= 3\nNELEM= 1\n10 0 1 2\n", FFD_ERR_PARSE,
     "bad.su2:3: a type-10 element has 4 node ids (and an optional index), found 3 numbers"},
    {"NDIME= 3\nNELEM= 1\n10 0 1 2 x\n", FFD_ERR_PARSE, "bad.su2:3: expected a number, found 'x'"},
    {"NDIME= 3\nNELEM= 1\n10 0 1 2 -4\n", FFD_ERR_RANGE, "bad.su2:3: node -4 out of range"},
    {"NDIME= 3\nNELEM= 1\n10 0 1 2 1.5\n", FFD_ERR_PARSE,
     "bad.su2:3: expected a node id (a non-negative integer), found '1.5'"},
    {"NDIME= 4\n", FFD_ERR_PARSE, "bad.su2:1: NDIME= 4, expected 2 or 3"},
    {"NDIME= 3\nNDIME= 3\n", FFD_ERR_PARSE, "bad.su2:2: a second NDIME= (the first on line 1)"},
    {"NPOIN= 1\n0 0 0\n", FFD_ERR_PARSE, "bad.su2:1: expected NDIME= before NPOIN="},
    {"NDIME= 3\n1 2 3\n", FFD_ERR_PARSE, "bad.su2:2: expected a keyword (NDIME="},
    {"NDIME= 3\nNFOO= 3\n", FFD_ERR_UNSUPPORTED, "bad.su2:2: keyword NFOO= is not one the SU2 reader knows"},
    {"NDIME= 3\nFFD_NBOX= 1\n", FFD_ERR_UNSUPPORTED, "bad.su2:2: SU2 FFD boxes in the mesh file (FFD_NBOX= 1)"},
    {"NDIME= 3\nNELEM= 0\nNPOIN= 0\nMARKER_TAG= a\n", FFD_ERR_PARSE, "bad.su2:4: MARKER_TAG= before NMARK="},
    {"NDIME= 3\nNELEM= 0\nNPOIN= 0\nNMARK= 2\nMARKER_TAG= a\nMARKER_ELEMS= 0\n", FFD_ERR_PARSE,
     "bad.su2:7: expected another MARKER_TAG= (NMARK= says more), found end of file"},
    {"NDIME= 3\nNELEM= 0\nNPOIN= 0\nNMARK= 1\nMARKER_ELEMS= 0\n", FFD_ERR_PARSE,
     "bad.su2:5: MARKER_ELEMS= without a MARKER_TAG= before it"},
    {"NDIME= 3\nNELEM= 0\n", FFD_ERR_PARSE, "bad.su2:3: expected NPOIN=, found end of file"},
    {"NDIME= 3\nNELEM= 0\nNPOIN= 2 3\n", FFD_ERR_PARSE, "bad.su2:3: NPOIN= 3 domain points, more than the 2 points"},
    {"NDIME= 3\nNELEM= -1\n", FFD_ERR_PARSE, "bad.su2:2: expected a non-negative integer after NELEM=, found -1"},
    {"NDIME= 3\nNELEM= 0\nNPOIN= 1\n0 0\n", FFD_ERR_PARSE,
     "bad.su2:4: expected 3 coordinates (and an optional index) for point 1, found 2 numbers"},
};

static void test_bad_inputs(void)
{
    for (size_t i = 0; i < sizeof bad / sizeof *bad; i++) {
        ffd_mesh *m = NULL;
        ffd_error err = {{0}};
        ffd_status s = ffd_mesh_read_memory(bad[i].text, strlen(bad[i].text), FFD_FORMAT_SU2,
                                            "bad.su2", &m, &err);
        if (s != bad[i].status || !strstr(err.message, bad[i].message))
            fprintf(stderr, "case %zu: status %d, message '%s'\n", i, (int)s, err.message);
        CHECK(s == bad[i].status);
        CHECK(strstr(err.message, bad[i].message) != NULL);
        CHECK(m == NULL);
        ffd_mesh_destroy(m);
    }
}

/* Every prefix of a valid file is refused with a message or read (never a crash). */
static void test_truncated_prefixes(void)
{
    size_t n;
    unsigned char *src = slurp(VOL "box_markers.su2", &n);
    CHECK(src != NULL);
    size_t refused = 0;
    for (size_t len = 1; src && len < n; len++) {
        ffd_mesh *m = NULL;
        ffd_error err = {{0}};
        ffd_status s = ffd_mesh_read_memory(src, len, FFD_FORMAT_SU2, "cut.su2", &m, &err);
        if (s != FFD_OK) {
            refused++;
            CHECK(strncmp(err.message, "cut.su2", 7) == 0);
        }
        ffd_mesh_destroy(m);
    }
    CHECK(refused > n / 2);
    free(src);
}

int main(int argc, char **argv)
{
    static const check_test tests[] = {
        {"read_samples", test_read_samples},
        {"untouched_identical", test_untouched_identical},
        {"deformed_only_coordinates", test_deformed_only_coordinates},
        {"2d_refuses_z", test_2d_refuses_z},
        {"from_created_mesh", test_from_created_mesh},
        {"from_surface", test_from_surface},
        {"unwritable_cells", test_unwritable_cells},
        {"bad_inputs", test_bad_inputs},
        {"truncated_prefixes", test_truncated_prefixes},
    };
    return check_run(tests, sizeof tests / sizeof *tests, argc, argv);
}
