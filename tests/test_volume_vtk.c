/* Legacy VTK codec (src/mesh/mesh_vtk.c): the samples of data/volume/ read
 * with their cells, faces and fields; untouched writes byte-identical,
 * deformed ones differing only in coordinates; every encoding transcoded and
 * read back; surfaces and meshes made from arrays written as .vtk; every bad
 * input refused with its message. */
#include "check.h"
#include "ffd.h"
#include "mesh/mesh.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define VOL FFD_DATA_DIR "/volume/"

static const char *const samples[] = {
    "mixed_51_ascii.vtk", "mixed_51_binary.vtk", "mixed_42_ascii.vtk", "mixed_42_binary.vtk",
    "box_tet_binary.vtk", "polydata_ascii.vtk",  "polydata_binary.vtk",
};
#define SAMPLE_COUNT (sizeof samples / sizeof samples[0])

static ffd_mesh *read_sample(const char *file)
{
    char path[512];
    snprintf(path, sizeof path, "%s%s", VOL, file);
    ffd_mesh *m = NULL;
    ffd_error err = {{0}};
    if (ffd_mesh_read(path, &m, &err) != FFD_OK)
        fprintf(stderr, "%s: %s\n", path, err.message);
    return m;
}

static ffd_status last_status; /* of the last read_buffer */

static ffd_mesh *read_buffer(const unsigned char *d, size_t n, ffd_error *err)
{
    ffd_mesh *m = NULL;
    last_status = ffd_mesh_read_memory(d, n, FFD_FORMAT_VTK, "m.vtk", &m, err);
    return m;
}

static unsigned char *write_mesh(const ffd_mesh *m, ffd_encoding enc, size_t *n)
{
    ffd_write_options o = {FFD_FORMAT_VTK, enc, 0};
    unsigned char *d = NULL;
    ffd_error err = {{0}};
    if (ffd_mesh_write_memory(m, &o, &d, n, &err) != FFD_OK) {
        fprintf(stderr, "write: %s\n", err.message);
        return NULL;
    }
    return d;
}

static size_t count_type(const ffd_mesh *m, uint8_t type)
{
    size_t k = 0;
    for (size_t c = 0; c < ffd_mesh_cell_count(m); c++)
        k += ffd_mesh_cell_types(m)[c] == type;
    return k;
}

static const ffd_field_info *field_named(const ffd_mesh *m, const char *name, ffd_field_info *f)
{
    for (size_t i = 0; i < ffd_mesh_field_count(m); i++)
        if (ffd_mesh_field_get(m, i, f, NULL) == FFD_OK && !strcmp(f->name, name))
            return f;
    return NULL;
}

/* Same nodes (exactly), cells, and fields (by name). */
static bool same_mesh(const ffd_mesh *a, const ffd_mesh *b)
{
    size_t nv = ffd_mesh_vertex_count(a), nc = ffd_mesh_cell_count(a);
    if (nv != ffd_mesh_vertex_count(b) || nc != ffd_mesh_cell_count(b) ||
        ffd_mesh_face_count(a) != ffd_mesh_face_count(b) ||
        ffd_mesh_field_count(a) != ffd_mesh_field_count(b))
        return false;
    if (memcmp(ffd_mesh_positions(a), ffd_mesh_positions(b), 3 * nv * sizeof(double)))
        return false;
    if (nc && (memcmp(ffd_mesh_cell_types(a), ffd_mesh_cell_types(b), nc) ||
               memcmp(ffd_mesh_cell_offsets(a), ffd_mesh_cell_offsets(b), (nc + 1) * 8) ||
               memcmp(ffd_mesh_cell_indices(a), ffd_mesh_cell_indices(b),
                      ffd_mesh_cell_offsets(a)[nc] * sizeof(uint32_t))))
        return false;
    for (size_t i = 0; i < ffd_mesh_field_count(a); i++) {
        ffd_field_info fa, fb;
        if (ffd_mesh_field_get(a, i, &fa, NULL) || !field_named(b, fa.name, &fb) ||
            fa.association != fb.association || fa.components != fb.components ||
            fa.count != fb.count ||
            memcmp(fa.values, fb.values, fa.count * fa.components * sizeof(double)))
            return false;
    }
    return true;
}

/* ---- reading the samples ------------------------------------------------ */

static void test_mixed_samples(void)
{
    ffd_mesh *first = NULL;
    for (size_t s = 0; s < 4; s++) {
        ffd_mesh *m = read_sample(samples[s]);
        CHECK(m != NULL);
        if (!m)
            continue;
        CHECK(ffd_mesh_vertex_count(m) == 12);
        CHECK(ffd_mesh_cell_count(m) == 4);
        CHECK(count_type(m, FFD_CELL_HEXAHEDRON) == 1 && count_type(m, FFD_CELL_WEDGE) == 1 &&
              count_type(m, FFD_CELL_PYRAMID) == 1 && count_type(m, FFD_CELL_TETRA) == 1);
        CHECK(ffd_mesh_is_volume(m));
        CHECK(ffd_mesh_face_count(m) == 16); /* 4 + 4 + 4 + 4: hex-wedge and hex-pyramid shared */
        CHECK(ffd_mesh_field_count(m) == 3);
        ffd_field_info f;
        CHECK(field_named(m, "temperature", &f) && f.association == FFD_FIELD_POINT &&
              f.components == 1 && f.values[11] == 6.0);
        CHECK(field_named(m, "velocity", &f) && f.components == 3 && f.values[3 * 4 + 1] == 1.0);
        CHECK(field_named(m, "material", &f) && f.association == FFD_FIELD_CELL &&
              f.count == 4 && f.values[3] == 4.0);
        CHECK(ffd_mesh_positions(m)[3 * 11 + 2] == -1.0);
        /* the four encodings and layouts hold the same mesh */
        if (!first)
            first = m;
        else {
            CHECK(same_mesh(first, m));
            ffd_mesh_destroy(m);
        }
    }
    ffd_mesh_destroy(first);
}

static void test_box_and_polydata_samples(void)
{
    ffd_mesh *m = read_sample("box_tet_binary.vtk");
    CHECK(m && ffd_mesh_vertex_count(m) == 354 && count_type(m, FFD_CELL_TETRA) == 1151 &&
          ffd_mesh_cell_count(m) == 1151 && ffd_mesh_face_count(m) == 580 && ffd_mesh_is_volume(m));
    CHECK(m && ffd_mesh_source_format(m) == FFD_FORMAT_VTK && m->encoding == FFD_ENCODING_BINARY_BE);
    ffd_mesh_destroy(m);

    /* vertex, poly line, triangle, quad, pentagon (polygon), strip: VTK's cell order */
    m = read_sample("polydata_ascii.vtk");
    CHECK(m != NULL);
    if (m) {
        static const uint8_t want[6] = {FFD_CELL_VERTEX,  FFD_CELL_POLY_LINE, FFD_CELL_TRIANGLE,
                                        FFD_CELL_QUAD,    FFD_CELL_POLYGON,   FFD_CELL_TRIANGLE_STRIP};
        CHECK(ffd_mesh_cell_count(m) == 6 && !memcmp(ffd_mesh_cell_types(m), want, 6));
        CHECK(!ffd_mesh_is_volume(m));
        CHECK(ffd_mesh_face_count(m) == 5); /* triangle, quad, pentagon, the strip's 2 triangles */
        /* height, normals, uv, rgb, "region id"; the string array and dataset FIELD skipped */
        CHECK(ffd_mesh_field_count(m) == 5);
        ffd_field_info f;
        CHECK(field_named(m, "uv", &f) && f.components == 2 && f.values[17] == 0.5);
        CHECK(field_named(m, "normals", &f) && f.components == 3 && f.values[29] == (double)0.577f);
        CHECK(field_named(m, "rgb", &f) && f.association == FFD_FIELD_CELL && f.components == 3);
        CHECK(field_named(m, "region id", &f) && f.values[5] == 4.0);
        CHECK(!field_named(m, "label", &f) && !field_named(m, "TimeValue", &f));
    }
    ffd_mesh_destroy(m);

    m = read_sample("polydata_binary.vtk");
    CHECK(m != NULL);
    if (m) {
        static const uint8_t want[4] = {FFD_CELL_VERTEX, FFD_CELL_TRIANGLE, FFD_CELL_QUAD,
                                        FFD_CELL_POLYGON};
        CHECK(ffd_mesh_cell_count(m) == 4 && !memcmp(ffd_mesh_cell_types(m), want, 4));
        CHECK(ffd_mesh_face_count(m) == 3);
        ffd_field_info f;
        CHECK(field_named(m, "flag", &f) && f.values[0] == 1 && f.values[1] == 0 &&
              f.values[2] == 1 && f.values[3] == 0);
        CHECK(field_named(m, "weight", &f) && f.values[3] == 2.0);
        CHECK(field_named(m, "displacement", &f) && f.association == FFD_FIELD_POINT &&
              f.values[27] == (double)(float)0.2);
        CHECK(!field_named(m, "name", &f));
        CHECK(ffd_mesh_field_count(m) == 3);
    }
    ffd_mesh_destroy(m);
}

/* ---- lossless writes ---------------------------------------------------- */

static void test_untouched_byte_identical(void)
{
    for (size_t s = 0; s < SAMPLE_COUNT; s++) {
        ffd_mesh *m = read_sample(samples[s]);
        if (!m) {
            CHECK(m != NULL);
            continue;
        }
        size_t n = 0;
        unsigned char *d = write_mesh(m, FFD_ENCODING_SAME, &n);
        CHECK(d && n == m->src_size && !memcmp(d, m->src, n));
        ffd_free(d);
        ffd_mesh_destroy(m);
    }
}

/* Outside the coordinates, the written file is the source: walks both with
 * the source's spans (file order), skipping one number in each. */
static bool differs_only_in_coordinates(const ffd_mesh *m, const unsigned char *d, size_t n)
{
    size_t p = 0, q = 0;
    bool binary = m->encoding != FFD_ENCODING_ASCII;
    for (size_t i = 0; i < 3 * m->vertex_count; i++) {
        const ffd_span *s = &m->position_spans[i];
        size_t len = (size_t)s->offset - p;
        if (q + len > n || memcmp(m->src + p, d + q, len))
            return false;
        p = (size_t)s->offset + ffd_span_length(m, s);
        q += len;
        if (binary) {
            q += ffd_span_length(m, s);
        } else {
            char *e;
            strtod((const char *)d + q, &e);
            if (e == (const char *)d + q)
                return false;
            q = (size_t)((const unsigned char *)e - d);
        }
    }
    return n - q == m->src_size - p && !memcmp(m->src + p, d + q, n - q);
}

static void test_deformed_differs_only_in_coordinates(void)
{
    for (size_t s = 0; s < SAMPLE_COUNT; s++) {
        ffd_mesh *m = read_sample(samples[s]);
        if (!m) {
            CHECK(m != NULL);
            continue;
        }
        size_t nv = ffd_mesh_vertex_count(m);
        double *p = malloc(3 * nv * sizeof(double));
        memcpy(p, ffd_mesh_positions(m), 3 * nv * sizeof(double));
        for (size_t i = 0; i < nv; i += 2) /* every other node moves */
            p[3 * i] += 0.1 + 0.5 * p[3 * i + 2];
        CHECK_OK(ffd_mesh_set_positions(m, p, NULL, NULL));
        size_t n = 0;
        unsigned char *d = write_mesh(m, FFD_ENCODING_SAME, &n);
        CHECK(d && differs_only_in_coordinates(m, d, n));
        CHECK(d && (n != m->src_size || memcmp(d, m->src, n)));
        ffd_error err = {{0}};
        ffd_mesh *back = d ? read_buffer(d, n, &err) : NULL;
        CHECK(back != NULL);
        if (back) {
            bool f32 = m->position_spans[0].kind == FFD_SPAN_F32;
            bool same = true;
            for (size_t i = 0; i < 3 * nv; i++)
                same = same && ffd_mesh_positions(back)[i] == (f32 ? (double)(float)p[i] : p[i]);
            CHECK(same);
            CHECK(ffd_mesh_cell_count(back) == ffd_mesh_cell_count(m) &&
                  ffd_mesh_field_count(back) == ffd_mesh_field_count(m));
        }
        ffd_mesh_destroy(back);
        ffd_free(d);
        free(p);
        ffd_mesh_destroy(m);
    }
}

/* ---- other encodings and formats --------------------------------------- */

static void check_write_read(const ffd_mesh *m, const char *what)
{
    static const ffd_encoding encs[2] = {FFD_ENCODING_ASCII, FFD_ENCODING_BINARY_BE};
    unsigned char *first = NULL;
    size_t first_n = 0;
    for (int e = 0; e < 2; e++) {
        size_t n = 0;
        unsigned char *d = write_mesh(m, encs[e], &n);
        ffd_error err = {{0}};
        ffd_mesh *back = d ? read_buffer(d, n, &err) : NULL;
        if (!back)
            fprintf(stderr, "%s: %s\n", what, err.message);
        CHECK(back != NULL);
        if (back) {
            if (!same_mesh(m, back))
                fprintf(stderr, "%s, encoding %d: not the same mesh\n", what, (int)encs[e]);
            CHECK(same_mesh(m, back));
            CHECK(back->encoding == encs[e]);
            /* written again in the other encoding: the same bytes as straight from m */
            size_t n2 = 0;
            unsigned char *d2 = write_mesh(back, encs[1 - e], &n2);
            /* (an ascii source written as ascii is its copy, not from data) */
            bool from_data = !m->src || m->encoding != FFD_ENCODING_ASCII;
            if (from_data && e == 1 && !(d2 && n2 == first_n && !memcmp(d2, first, n2)))
                fprintf(stderr, "%s: binary then ascii differs from ascii\n", what);
            if (from_data && e == 1)
                CHECK(d2 && n2 == first_n && !memcmp(d2, first, n2));
            ffd_free(d2);
        }
        ffd_mesh_destroy(back);
        if (e == 0) {
            first = d;
            first_n = n;
        } else {
            ffd_free(d);
        }
    }
    ffd_free(first);
}

static void test_transcode_every_encoding(void)
{
    for (size_t s = 0; s < SAMPLE_COUNT; s++) {
        ffd_mesh *m = read_sample(samples[s]);
        CHECK(m != NULL);
        if (m)
            check_write_read(m, samples[s]);
        ffd_mesh_destroy(m);
    }
}

static void test_surface_as_cells(void)
{
    ffd_mesh *m = NULL;
    CHECK_OK(ffd_mesh_read(FFD_DATA_DIR "/bunny.obj", &m, NULL));
    if (!m)
        return;
    static const ffd_encoding encs[2] = {FFD_ENCODING_ASCII, FFD_ENCODING_BINARY_BE};
    for (int e = 0; e < 2; e++) {
        size_t n = 0;
        unsigned char *d = write_mesh(m, encs[e], &n);
        ffd_error err = {{0}};
        ffd_mesh *back = d ? read_buffer(d, n, &err) : NULL;
        CHECK(back != NULL);
        if (back) {
            CHECK(ffd_mesh_vertex_count(back) == ffd_mesh_vertex_count(m));
            CHECK(ffd_mesh_cell_count(back) == 3674 && count_type(back, FFD_CELL_TRIANGLE) == 3674);
            CHECK(!memcmp(ffd_mesh_positions(back), ffd_mesh_positions(m),
                          3 * ffd_mesh_vertex_count(m) * sizeof(double)));
            CHECK(!memcmp(ffd_mesh_cell_indices(back), ffd_mesh_face_indices(m),
                          3 * 3674 * sizeof(uint32_t)));
            CHECK(ffd_mesh_face_count(back) == 3674);
        }
        ffd_mesh_destroy(back);
        ffd_free(d);
    }
    ffd_mesh_destroy(m);
}

static void test_cells_from_arrays(void)
{
    /* two hexahedra, a wedge on top, a pyramid at the side, a tetrahedron below */
    static const double p[] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 0, 0, 1, 1, 0, 1, 1, 1, 1, 0, 1, 1,
                               2, 0, 0, 2, 1, 0, 2, 0, 1, 2, 1, 1, 0.5, 0, 1.8, 0.5, 1, 1.8,
                               3, 0.5, 0.5, 0.5, 0.5, -1};
    static const uint8_t types[] = {FFD_CELL_HEXAHEDRON, FFD_CELL_HEXAHEDRON, FFD_CELL_WEDGE,
                                    FFD_CELL_PYRAMID, FFD_CELL_TETRA};
    static const uint64_t off[] = {0, 8, 16, 22, 27, 31};
    static const uint32_t ix[] = {0, 1, 2, 3, 4, 5, 6, 7, 1, 8, 9, 2, 5, 10, 11, 6,
                                  4, 5, 12, 7, 6, 13, 8, 9, 11, 10, 14, 0, 2, 1, 15};
    ffd_mesh *m = NULL;
    CHECK_OK(ffd_mesh_create_cells(p, 16, types, off, ix, 5, &m, NULL));
    if (!m)
        return;
    CHECK(ffd_mesh_is_volume(m));
    check_write_read(m, "ffd_mesh_create_cells");
    ffd_mesh_destroy(m);
}

/* ---- bad input ---------------------------------------------------------- */

#define HEAD "# vtk DataFile Version 3.0\nt\nASCII\nDATASET UNSTRUCTURED_GRID\n"
#define TRI "POINTS 3 float\n0 0 0 1 0 0 0 1 0\n"

typedef struct {
    const char *text;
    ffd_status status;
    const char *message;
} bad_case;

static const bad_case bad[] = {
    {"hello\n", FFD_ERR_PARSE, "m.vtk:1: expected '# vtk DataFile Version <x.y>'"},
    {"# vtk DataFile Version 3.0\n", FFD_ERR_PARSE, "m.vtk:2: expected a title line, found end of file"},
    {"# vtk DataFile Version 3.0\nt\nUTF8\n", FFD_ERR_PARSE, "m.vtk:3: expected ASCII or BINARY, found 'UTF8'"},
    {"# vtk DataFile Version 3.0\nt\nASCII\nPOINTS 1 float\n", FFD_ERR_PARSE,
     "m.vtk:4: expected 'DATASET UNSTRUCTURED_GRID' or 'DATASET POLYDATA'"},
    {"# vtk DataFile Version 3.0\nt\nASCII\nDATASET STRUCTURED_POINTS\n", FFD_ERR_UNSUPPORTED,
     "m.vtk:4: DATASET STRUCTURED_POINTS is not supported"},
    {HEAD "POINTS 100000000 float\n0 0 0\n", FFD_ERR_PARSE,
     "m.vtk:6: 300000000 values of POINTS cannot fit in the 6 bytes left"},
    {HEAD "POINTS 100000000000 float\n", FFD_ERR_UNSUPPORTED,
     "m.vtk:5: 100000000000 points, more than the 4294967295"},
    {HEAD "POINTS 2 int\n0 0 0 1 1 1\n", FFD_ERR_UNSUPPORTED, "m.vtk:5: POINTS of type 'int'"},
    {HEAD "POINTS 2 quaternion\n", FFD_ERR_UNSUPPORTED, "m.vtk:5: unknown data type 'quaternion'"},
    {HEAD "POINTS 2 float\n0 0 0 1 nan 1\n", FFD_ERR_NONFINITE,
     "m.vtk:6: coordinate 1 of point 1 is not finite (nan)"},
    {HEAD "POINTS 2 float\n0 0 0\n1 inf 1\n", FFD_ERR_NONFINITE,
     "m.vtk:7: coordinate 1 of point 1 is not finite (inf)"},
    {HEAD "POINTS 2 float\n0 0 0 1 x 1\n", FFD_ERR_PARSE,
     "m.vtk:6: expected value 4 of POINTS (a number), found 'x'"},
    {HEAD "POINTS 2 float\n0 0 0 1          \n", FFD_ERR_PARSE, "m.vtk:7: expected value 4 of POINTS, found end of file"},
    {HEAD TRI "CELLS 1 4\n3 0 1 7\nCELL_TYPES 1\n5\n", FFD_ERR_RANGE,
     "m.vtk:8: node 7 out of range (3 nodes)"},
    {HEAD TRI "CELLS 1 4\n3 0 -1 2\nCELL_TYPES 1\n5\n", FFD_ERR_RANGE,
     "m.vtk:8: node id -1 out of range (3 points)"},
    {HEAD TRI "CELLS 1 4\n3 0 1 2\nCELL_TYPES 1\n42\n", FFD_ERR_UNSUPPORTED,
     "m.vtk:10: cell 0 is a polyhedron (type 42): polyhedron cells are not supported"},
    {HEAD TRI "CELLS 1 4\n3 0 1 2\nCELL_TYPES 1\n99\n", FFD_ERR_UNSUPPORTED,
     "m.vtk:10: cell 0 has type 99, not one the library reads"},
    {HEAD TRI "CELLS 1 4\n3 0 1 2\nCELL_TYPES 1\n10\n", FFD_ERR_PARSE,
     "m.vtk:8: a tetra cell has 4 nodes, not 3"},
    {HEAD TRI "CELLS 1 4\n3 0 1 2\nCELL_TYPES 2\n5 5\n", FFD_ERR_PARSE,
     "m.vtk:9: CELL_TYPES lists 2 cells, CELLS 1"},
    {HEAD TRI "CELLS 1 5\n3 0 1 2 1\nCELL_TYPES 1\n5\n", FFD_ERR_PARSE,
     "m.vtk:8: CELLS declares 5 values but its 1 cells hold 4"},
    {HEAD TRI "CELLS 1 4\n7 0 1 2\n", FFD_ERR_PARSE,
     "m.vtk:8: cell 0 has 7 nodes, more than the 3 values CELLS has left"},
    {HEAD TRI "CELLS 1 4\n3 0 1 2\n", FFD_ERR_PARSE, "m.vtk:7: CELLS without CELL_TYPES"},
    {HEAD TRI "CELL_TYPES 1\n5\n", FFD_ERR_PARSE, "m.vtk:7: CELL_TYPES before CELLS"},
    {HEAD TRI "CELLS 2 3\nOFFSETS vtktypeint64\n1 3\nCONNECTIVITY vtktypeint64\n0 1 2\nCELL_TYPES 1\n5\n",
     FFD_ERR_PARSE, "m.vtk:9: offset 0 is 1, expected 0"},
    {HEAD TRI "CELLS 2 3\nOFFSETS vtktypeint64\n0 3\nCONNECT vtktypeint64\n0 1 2\n", FFD_ERR_PARSE,
     "m.vtk:10: expected 'CONNECTIVITY <type>' after the offsets"},
    {HEAD TRI "CELLS 1 4\n3 0 1 2\nCELL_TYPES 1\n5\nPOINT_DATA 5\n", FFD_ERR_PARSE,
     "m.vtk:11: POINT_DATA 5, but the file has 3 points"},
    {HEAD TRI "SCALARS s float 1\n0 0 0\n", FFD_ERR_PARSE, "m.vtk:7: SCALARS before POINT_DATA or CELL_DATA"},
    {HEAD TRI "POINT_DATA 3\nSCALARS s float 1\nLOOKUP_TABLE default\n0 1\n", FFD_ERR_PARSE,
     "m.vtk:11: expected value 2 of 's', found end of file"},
    {HEAD TRI "POINT_DATA 3\nFIELD f 1\na 0 3 float\n", FFD_ERR_PARSE,
     "m.vtk:9: array 'a' has 0 components"},
    {HEAD TRI "POINT_DATA 3\nGLOBAL_IDS g vtkIdType\n0 1\n", FFD_ERR_PARSE,
     "m.vtk:10: expected value 2 of 'g', found end of file"},
    {HEAD TRI "FOO 3\n", FFD_ERR_PARSE, "m.vtk:7: unknown keyword 'FOO' in a UNSTRUCTURED_GRID dataset"},
    {HEAD "CELLS 1 2\n1 0\nCELL_TYPES 1\n1\n", FFD_ERR_PARSE, "m.vtk:5: cells before POINTS"},
    {HEAD "\n", FFD_ERR_PARSE, "m.vtk:6: expected a POINTS section, found end of file"},
    {"# vtk DataFile Version 3.0\nt\nASCII\nDATASET POLYDATA\n" TRI "POLYGONS 1 4\n3 0 1 2\nLINES 1 3\n2 0 1\n",
     FFD_ERR_UNSUPPORTED, "m.vtk:9: LINES after a later or the same section"},
    {"# vtk DataFile Version 3.0\nt\nASCII\nDATASET POLYDATA\n" TRI "CELLS 1 4\n3 0 1 2\n",
     FFD_ERR_PARSE, "m.vtk:7: unknown keyword 'CELLS' in a POLYDATA dataset"},
    {"# vtk DataFile Version 3.0\nt\nASCII\nDATASET POLYDATA\n" TRI "POLYGONS 1 3\n2 0 1\n",
     FFD_ERR_PARSE, "m.vtk:8: a polygon cell needs at least 3 nodes, not 2"},
};

static void test_bad_inputs(void)
{
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        ffd_error err = {{0}};
        ffd_mesh *m = NULL;
        ffd_status s = ffd_mesh_read_memory(bad[i].text, strlen(bad[i].text), FFD_FORMAT_VTK, "m.vtk", &m, &err);
        if (s != bad[i].status || !strstr(err.message, bad[i].message)) {
            fprintf(stderr, "case %zu: status %d, message '%s'\n  expected %d, '%s'\n", i, (int)s,
                    err.message, (int)bad[i].status, bad[i].message);
            CHECK(s == bad[i].status && strstr(err.message, bad[i].message));
        }
        CHECK(m == NULL);
        ffd_mesh_destroy(m);
    }
}

/* Binary: counts checked against the bytes left, NaN, a bad node id, all
 * named by byte offset. */
static void test_bad_binary(void)
{
    static const char head[] = "# vtk DataFile Version 3.0\nt\nBINARY\nDATASET UNSTRUCTURED_GRID\n";
    unsigned char buf[512];
    size_t h = strlen(head);
    ffd_error err = {{0}};
    ffd_mesh *m;

    memcpy(buf, head, h);
    size_t n = h + (size_t)sprintf((char *)buf + h, "POINTS 1000000 float\n");
    memset(buf + n, 0, 24);
    m = read_buffer(buf, n + 24, &err);
    char want[128];
    snprintf(want, sizeof want, "m.vtk: byte %zu: 3000000 values of POINTS (float) need 12000000 bytes, only 24 are left", n);
    CHECK(!m && strstr(err.message, want));

    /* one point, y = NaN (float 0x7fc00000) */
    n = h + (size_t)sprintf((char *)buf + h, "POINTS 1 float\n");
    static const unsigned char pt[12] = {0, 0, 0, 0, 0x7f, 0xc0, 0, 0, 0, 0, 0, 0};
    memcpy(buf + n, pt, 12);
    m = read_buffer(buf, n + 12, &err);
    snprintf(want, sizeof want, "m.vtk: byte %zu: coordinate 1 of point 0 is not finite", n + 4);
    CHECK(!m && last_status == FFD_ERR_NONFINITE && strstr(err.message, want));

    /* a vertex cell on node 5 of 1 */
    n = h + (size_t)sprintf((char *)buf + h, "POINTS 1 float\n");
    memset(buf + n, 0, 12);
    n += 12;
    n += (size_t)sprintf((char *)buf + n, "\nCELLS 1 2\n");
    static const unsigned char cell[8] = {0, 0, 0, 1, 0, 0, 0, 5};
    memcpy(buf + n, cell, 8);
    size_t cell_at = n;
    n += 8;
    n += (size_t)sprintf((char *)buf + n, "\nCELL_TYPES 1\n");
    static const unsigned char one[4] = {0, 0, 0, 1};
    memcpy(buf + n, one, 4);
    n += 4;
    m = read_buffer(buf, n, &err);
    snprintf(want, sizeof want, "m.vtk: byte %zu: node 5 out of range (1 nodes)", cell_at);
    CHECK(!m && last_status == FFD_ERR_RANGE && strstr(err.message, want));

    /* a string whose length prefix runs past the end */
    n = h + (size_t)sprintf((char *)buf + h, "FIELD FieldData 1\ns 1 1 string\n");
    buf[n] = 0xC0 | 40;
    memcpy(buf + n + 1, "abc", 3);
    m = read_buffer(buf, n + 4, &err);
    CHECK(!m && strstr(err.message, "string 0 of 's': 40 bytes, only 3 are left"));
}

/* Every prefix of the small samples fails cleanly or reads (no crash, a message). */
static void test_truncated_prefixes(void)
{
    for (size_t s = 0; s < SAMPLE_COUNT; s++) {
        if (!strcmp(samples[s], "box_tet_binary.vtk"))
            continue;
        ffd_mesh *full = read_sample(samples[s]);
        if (!full) {
            CHECK(full != NULL);
            continue;
        }
        bool ok = true;
        for (size_t k = 0; k < full->src_size; k++) {
            ffd_error err = {{0}};
            ffd_mesh *m = read_buffer(full->src, k, &err);
            if (!m && !err.message[0])
                ok = false;
            ffd_mesh_destroy(m);
        }
        CHECK(ok);
        ffd_mesh_destroy(full);
    }
}

int main(int argc, char **argv)
{
    static const check_test tests[] = {
        {"mixed_samples", test_mixed_samples},
        {"box_and_polydata_samples", test_box_and_polydata_samples},
        {"untouched_byte_identical", test_untouched_byte_identical},
        {"deformed_differs_only_in_coordinates", test_deformed_differs_only_in_coordinates},
        {"transcode_every_encoding", test_transcode_every_encoding},
        {"surface_as_cells", test_surface_as_cells},
        {"cells_from_arrays", test_cells_from_arrays},
        {"bad_inputs", test_bad_inputs},
        {"bad_binary", test_bad_binary},
        {"truncated_prefixes", test_truncated_prefixes},
    };
    return check_run(tests, sizeof tests / sizeof tests[0], argc, argv);
}
