/* Tests of the VTU codec (src/mesh/mesh_vtu.c): every sample of
 * data/volume/ read (cell types, boundary faces, fields), untouched writes
 * byte-identical, deformed writes changing only coordinates, every encoding
 * and compression transcoded and read back, surface and created meshes
 * written as VTU, bad inputs one message each, every truncated prefix. */
#include "check.h"
#include "ffd.h"
#include "mesh/mesh.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define VOL FFD_DATA_DIR "/volume/"

typedef struct sample {
    const char *file;
    bool compressed;
    bool float32; /* Points stored as Float32 */
    size_t point_fields, cell_fields;
} sample;

static const sample samples[] = {
    {"mixed_ascii.vtu", false, false, 2, 1},
    {"mixed_base64.vtu", false, false, 2, 1},
    {"mixed_zlib.vtu", true, false, 2, 1},
    {"mixed_raw.vtu", false, true, 1, 1},
    {"mixed_raw_be32.vtu", false, true, 1, 1},
    {"mixed_raw_zlib.vtu", true, true, 1, 1},
    {"mixed_appended_base64.vtu", false, true, 1, 1},
};
#define NSAMPLES (sizeof samples / sizeof samples[0])

static unsigned char *load(const char *path, size_t *size)
{
    unsigned char *d = NULL;
    ffd_error err = {{0}};
    if (ffd_read_file(path, &d, size, &err) != FFD_OK) {
        fprintf(stderr, "cannot load %s: %s\n", path, err.message);
        return NULL;
    }
    return d;
}

static ffd_mesh *read_path(const char *path)
{
    ffd_mesh *m = NULL;
    ffd_error err = {{0}};
    if (ffd_mesh_read(path, &m, &err) != FFD_OK)
        fprintf(stderr, "read %s: %s\n", path, err.message);
    return m;
}

static unsigned char *write_vtu(const ffd_mesh *m, ffd_encoding e, int compress, size_t *size)
{
    ffd_write_options o = {FFD_FORMAT_VTU, e, compress};
    unsigned char *d = NULL;
    ffd_error err = {{0}};
    if (ffd_mesh_write_memory(m, &o, &d, size, &err) != FFD_OK) {
        fprintf(stderr, "write: %s\n", err.message);
        return NULL;
    }
    return d;
}

static ffd_mesh *read_mem(const unsigned char *d, size_t n)
{
    ffd_mesh *m = NULL;
    ffd_error err = {{0}};
    if (ffd_mesh_read_memory(d, n, FFD_FORMAT_VTU, "mem.vtu", &m, &err) != FFD_OK)
        fprintf(stderr, "read back: %s\n", err.message);
    return m;
}

/* Same nodes (to tol), cells and fields. */
static void check_same(const ffd_mesh *a, const ffd_mesh *b, double tol)
{
    CHECK(a && b);
    if (!a || !b)
        return;
    CHECK(ffd_mesh_vertex_count(a) == ffd_mesh_vertex_count(b));
    CHECK(ffd_mesh_cell_count(a) == ffd_mesh_cell_count(b));
    if (ffd_mesh_vertex_count(a) != ffd_mesh_vertex_count(b) ||
        ffd_mesh_cell_count(a) != ffd_mesh_cell_count(b))
        return;
    for (size_t i = 0; i < 3 * ffd_mesh_vertex_count(a); i++)
        CHECK_NEAR(ffd_mesh_positions(a)[i], ffd_mesh_positions(b)[i], tol);
    size_t nc = ffd_mesh_cell_count(a);
    if (nc) {
        CHECK(memcmp(ffd_mesh_cell_types(a), ffd_mesh_cell_types(b), nc) == 0);
        CHECK(memcmp(ffd_mesh_cell_offsets(a), ffd_mesh_cell_offsets(b), (nc + 1) * 8) == 0);
        CHECK(memcmp(ffd_mesh_cell_indices(a), ffd_mesh_cell_indices(b),
                     ffd_mesh_cell_offsets(a)[nc] * 4) == 0);
    }
    CHECK(ffd_mesh_face_count(a) == ffd_mesh_face_count(b));
    CHECK(ffd_mesh_field_count(a) == ffd_mesh_field_count(b));
    for (size_t f = 0; f < ffd_mesh_field_count(a) && f < ffd_mesh_field_count(b); f++) {
        ffd_field_info x, y;
        CHECK_OK(ffd_mesh_field_get(a, f, &x, NULL));
        CHECK_OK(ffd_mesh_field_get(b, f, &y, NULL));
        CHECK(strcmp(x.name, y.name) == 0);
        CHECK(x.association == y.association && x.components == y.components && x.count == y.count);
        if (x.count == y.count && x.components == y.components)
            CHECK(memcmp(x.values, y.values, x.count * x.components * sizeof(double)) == 0);
    }
}

static void test_read_samples(void)
{
    for (size_t s = 0; s < NSAMPLES; s++) {
        char path[512];
        snprintf(path, sizeof path, VOL "%s", samples[s].file);
        ffd_mesh *m = read_path(path);
        CHECK(m);
        if (!m)
            continue;
        CHECK(ffd_mesh_vertex_count(m) == 14);
        CHECK(ffd_mesh_cell_count(m) == 5);
        CHECK(ffd_mesh_is_volume(m));
        static const uint8_t want[5] = {FFD_CELL_HEXAHEDRON, FFD_CELL_WEDGE, FFD_CELL_WEDGE,
                                        FFD_CELL_PYRAMID, FFD_CELL_TETRA};
        if (ffd_mesh_cell_count(m) == 5)
            CHECK(memcmp(ffd_mesh_cell_types(m), want, 5) == 0);
        /* 6+5+5+5+4 = 25 cell faces, 4 shared interior pairs */
        CHECK(ffd_mesh_face_count(m) == 21);
        CHECK(ffd_mesh_positions(m)[3 * 13 + 2] == (samples[s].float32 ? (double)1.9f : 1.9));
        size_t pf = 0, cf = 0;
        for (size_t f = 0; f < ffd_mesh_field_count(m); f++) {
            ffd_field_info fi;
            CHECK_OK(ffd_mesh_field_get(m, f, &fi, NULL));
            if (fi.association == FFD_FIELD_POINT)
                pf++;
            else
                cf++;
            if (strcmp(fi.name, "material") == 0) {
                CHECK(fi.count == 5 && fi.components == 1);
                CHECK(fi.values[1] == 2 && fi.values[4] == 4);
            }
            if (strcmp(fi.name, "temperature") == 0)
                CHECK(fi.values[0] == 0.25 && fi.values[13] == 3.5);
            if (strcmp(fi.name, "velocity") == 0)
                CHECK(fi.components == 3 && fi.values[41] == 41.0 / 8);
        }
        CHECK(pf == samples[s].point_fields);
        CHECK(cf == samples[s].cell_fields);
        ffd_mesh_destroy(m);
    }
}

static void test_untouched_round_trip_identical(void)
{
    for (size_t s = 0; s < NSAMPLES; s++) {
        char path[512];
        snprintf(path, sizeof path, VOL "%s", samples[s].file);
        size_t n = 0, w = 0;
        unsigned char *src = load(path, &n);
        ffd_mesh *m = read_path(path);
        unsigned char *out = m ? write_vtu(m, FFD_ENCODING_SAME, samples[s].compressed, &w) : NULL;
        CHECK(out && w == n && memcmp(out, src, n) == 0);
        ffd_free(out);
        /* compress 0: as the source (what ffd deform/convert pass by default) */
        out = m ? write_vtu(m, FFD_ENCODING_SAME, 0, &w) : NULL;
        CHECK(out && w == n && memcmp(out, src, n) == 0);
        ffd_free(out);
        /* compress -1: never compressed, so a compressed source is rewritten */
        out = m ? write_vtu(m, FFD_ENCODING_SAME, -1, &w) : NULL;
        CHECK(out && (samples[s].compressed ? w != n : w == n && memcmp(out, src, n) == 0));
        ffd_mesh *back = out ? read_mem(out, w) : NULL;
        check_same(m, back, 0);
        ffd_mesh_destroy(back);
        ffd_free(out);
        ffd_free(src);
        ffd_mesh_destroy(m);
    }
}

/* Deformed: read back equal to the new positions; raw and base64 outputs
 * keep the size and differ only inside the Points data; everything else of
 * the file (cells, fields) reads back identical. */
static void test_deformed_round_trip(void)
{
    for (size_t s = 0; s < NSAMPLES; s++) {
        char path[512];
        snprintf(path, sizeof path, VOL "%s", samples[s].file);
        size_t n = 0, w = 0;
        unsigned char *src = load(path, &n);
        ffd_mesh *m = read_path(path);
        if (!m || !src) {
            CHECK(0);
            ffd_free(src);
            ffd_mesh_destroy(m);
            continue;
        }
        size_t nv = ffd_mesh_vertex_count(m);
        double *p = malloc(3 * nv * sizeof(double));
        memcpy(p, ffd_mesh_positions(m), 3 * nv * sizeof(double));
        for (size_t i = 0; i < 3 * nv; i += 2)
            p[i] = p[i] * 1.25 + 0.125; /* every other coordinate moves */
        CHECK_OK(ffd_mesh_set_positions(m, p, NULL, NULL));
        unsigned char *out = write_vtu(m, FFD_ENCODING_SAME, samples[s].compressed, &w);
        ffd_mesh *back = out ? read_mem(out, w) : NULL;
        check_same(m, back, samples[s].float32 ? 1e-6 : 0);
        if (out) { /* a C string for the searches below */
            unsigned char *t = realloc(out, w + 1);
            if (t) {
                out = t;
                out[w] = 0;
            }
        }
        CHECK(out && (w != n || memcmp(out, src, n) != 0));
        if (out && !samples[s].compressed && strstr(samples[s].file, "ascii") == NULL) {
            /* fixed-size encodings: same size, changes only within the Points bytes */
            CHECK(w == n);
            size_t first = n, last = 0;
            for (size_t i = 0; i < n && i < w; i++)
                if (out[i] != src[i]) {
                    if (first == n)
                        first = i;
                    last = i;
                }
            const char *pts = strstr((const char *)src, "Points");
            CHECK(first < n && pts);
            if (strstr(samples[s].file, "mixed_base64")) {
                /* inline: the changes lie between the Points DataArray's tags */
                const char *b = strstr(pts, "format=\"binary\">"), *e = b ? strstr(b, "</DataArray>") : NULL;
                CHECK(b && e && first > (size_t)(b - (const char *)src) &&
                      last < (size_t)(e - (const char *)src));
            } else {
                /* appended: all changes after the '_' marker, before the next array */
                const char *us = strstr((const char *)src, "_");
                CHECK(us && first > (size_t)(us - (const char *)src));
                CHECK(last < first + 16 + 14 * 3 * 4 * 4 / 3 + 16);
            }
        }
        if (out && strcmp(samples[s].file, "mixed_zlib.vtu") == 0) {
            /* meshio's compressed arrays encode the block header apart (padded):
             * the re-encoded Points keep that split, which meshio needs */
            const char *a = strstr((const char *)src, "Name=\"Points\"");
            const char *b = strstr((const char *)out, "Name=\"Points\"");
            a = a ? strchr(a, '>') : NULL;
            b = b ? strchr(b, '>') : NULL;
            while (a && (a[1] == '\n' || a[1] == ' '))
                a++;
            while (b && (b[1] == '\n' || b[1] == ' '))
                b++;
            const char *pad = a ? strchr(a, '=') : NULL;
            CHECK(a && b && pad && pad - a < 64 && b[pad - a] == '=');
        }
        if (out && strstr(samples[s].file, "ascii")) {
            /* text: the file without its Points content is unchanged */
            const char *a = strstr((const char *)src, "NumberOfComponents=\"3\" format=\"ascii\">");
            const char *b = a ? strstr((const char *)out, "NumberOfComponents=\"3\" format=\"ascii\">") : NULL;
            CHECK(a && b && a - (const char *)src == b - (const char *)out);
            const char *ea = a ? strstr(a, "</DataArray>") : NULL, *eb = b ? strstr(b, "</DataArray>") : NULL;
            CHECK(ea && eb && strcmp(ea, eb) == 0);
        }
        free(p);
        free(out);
        ffd_free(src);
        ffd_mesh_destroy(back);
        ffd_mesh_destroy(m);
    }
}

/* Every sample to every encoding and compression, read back identical. */
static void test_transcode_every_encoding(void)
{
    static const ffd_encoding encs[] = {FFD_ENCODING_ASCII, FFD_ENCODING_BASE64, FFD_ENCODING_RAW};
    for (size_t s = 0; s < NSAMPLES; s++) {
        char path[512];
        snprintf(path, sizeof path, VOL "%s", samples[s].file);
        ffd_mesh *m = read_path(path);
        for (size_t e = 0; m && e < 3; e++)
            for (int z = 0; z < 2; z++) {
                if (encs[e] == FFD_ENCODING_ASCII && z)
                    continue;
                size_t w = 0;
                unsigned char *out = write_vtu(m, encs[e], z, &w);
                ffd_mesh *back = out ? read_mem(out, w) : NULL;
                check_same(m, back, 0);
                /* and the result's own untouched round trip is byte-identical */
                size_t w2 = 0;
                unsigned char *again = back ? write_vtu(back, FFD_ENCODING_SAME, z, &w2) : NULL;
                CHECK(again && w2 == w && memcmp(again, out, w) == 0);
                ffd_free(again);
                ffd_free(out);
                ffd_mesh_destroy(back);
            }
        ffd_mesh_destroy(m);
    }
}

/* A deformed compressed appended file: the Points blocks change size and
 * the offsets of the arrays after them move. */
static void test_compressed_appended_offsets_follow(void)
{
    ffd_mesh *m = read_path(VOL "mixed_raw_zlib.vtu");
    CHECK(m);
    if (!m)
        return;
    size_t nv = ffd_mesh_vertex_count(m);
    double *p = malloc(3 * nv * sizeof(double));
    for (size_t i = 0; i < 3 * nv; i++)
        p[i] = sin((double)i) * 3.7; /* incompressible-ish */
    CHECK_OK(ffd_mesh_set_positions(m, p, NULL, NULL));
    size_t w = 0;
    unsigned char *out = write_vtu(m, FFD_ENCODING_SAME, 1, &w);
    ffd_mesh *back = out ? read_mem(out, w) : NULL;
    check_same(m, back, 1e-6); /* Float32 */
    ffd_free(out);
    ffd_mesh_destroy(back);
    free(p);
    ffd_mesh_destroy(m);
}

static void test_from_surface_mesh(void)
{
    ffd_mesh *s = read_path(FFD_DATA_DIR "/bunny.obj");
    CHECK(s);
    static const ffd_encoding encs[] = {FFD_ENCODING_ASCII, FFD_ENCODING_BASE64, FFD_ENCODING_RAW};
    for (size_t e = 0; s && e < 3; e++) {
        size_t w = 0;
        unsigned char *out = write_vtu(s, encs[e], encs[e] == FFD_ENCODING_RAW, &w);
        ffd_mesh *back = out ? read_mem(out, w) : NULL;
        CHECK(back);
        if (back) {
            CHECK(ffd_mesh_vertex_count(back) == ffd_mesh_vertex_count(s));
            CHECK(ffd_mesh_cell_count(back) == ffd_mesh_face_count(s));
            CHECK(!ffd_mesh_is_volume(back));
            CHECK(ffd_mesh_face_count(back) == ffd_mesh_face_count(s));
            CHECK(memcmp(ffd_mesh_face_indices(back), ffd_mesh_face_indices(s),
                         ffd_mesh_face_offsets(s)[ffd_mesh_face_count(s)] * 4) == 0);
            for (size_t i = 0; i < 3 * ffd_mesh_vertex_count(s); i++)
                CHECK(ffd_mesh_positions(back)[i] == ffd_mesh_positions(s)[i]);
        }
        ffd_free(out);
        ffd_mesh_destroy(back);
    }
    ffd_mesh_destroy(s);
}

static void test_from_created_cells(void)
{
    /* a hexahedron, a wedge and a pyramid on it, a tetrahedron: the mixed mesh */
    static const double p[] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 0, 0, 1, 1, 0, 1, 1, 1, 1,
                               0, 1, 1, 2, 0, 0, 2, 1, 0, 2, 0, 1, 2, 1, 1, 0.5, 0.5, 2, -1, 0, 0};
    static const uint8_t t[] = {FFD_CELL_HEXAHEDRON, FFD_CELL_WEDGE, FFD_CELL_PYRAMID, FFD_CELL_TETRA};
    static const uint64_t off[] = {0, 8, 14, 19, 23};
    static const uint32_t ix[] = {0, 1, 2, 3, 4, 5, 6, 7, 1, 8, 9, 5, 10, 11, 4, 5, 6, 7, 12, 0, 3, 4, 13};
    ffd_mesh *m = NULL;
    CHECK_OK(ffd_mesh_create_cells(p, 14, t, off, ix, 4, &m, NULL));
    static const ffd_encoding encs[] = {FFD_ENCODING_ASCII, FFD_ENCODING_BASE64, FFD_ENCODING_RAW};
    for (size_t e = 0; m && e < 3; e++)
        for (int z = 0; z < 2; z++) {
            if (encs[e] == FFD_ENCODING_ASCII && z)
                continue;
            size_t w = 0;
            unsigned char *out = write_vtu(m, encs[e], z, &w);
            ffd_mesh *back = out ? read_mem(out, w) : NULL;
            check_same(m, back, 0);
            ffd_free(out);
            ffd_mesh_destroy(back);
        }
    /* compression needs a binary encoding */
    ffd_write_options o = {FFD_FORMAT_VTU, FFD_ENCODING_ASCII, 1};
    unsigned char *d = NULL;
    size_t n = 0;
    ffd_error err = {{0}};
    CHECK(m && ffd_mesh_write_memory(m, &o, &d, &n, &err) == FFD_ERR_UNSUPPORTED);
    CHECK(strstr(err.message, "not ascii") != NULL);
    ffd_mesh_destroy(m);
}

/* ---- bad inputs ---------------------------------------------------------- */

#define HEAD "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt32\">\n<UnstructuredGrid>\n"
#define PIECE(np, nc) "<Piece NumberOfPoints=\"" np "\" NumberOfCells=\"" nc "\">\n"
#define POINTS(text) "<Points>\n<DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"ascii\">\n" text "\n</DataArray>\n</Points>\n"
#define CELLS(conn, offs, types) "<Cells>\n<DataArray type=\"Int32\" Name=\"connectivity\" format=\"ascii\">" conn "</DataArray>\n<DataArray type=\"Int32\" Name=\"offsets\" format=\"ascii\">" offs "</DataArray>\n<DataArray type=\"UInt8\" Name=\"types\" format=\"ascii\">" types "</DataArray>\n</Cells>\n"
#define TAIL "</Piece>\n</UnstructuredGrid>\n</VTKFile>\n"
#define TET_POINTS POINTS("0 0 0 1 0 0 0 1 0 0 0 1")
#define GOOD HEAD PIECE("4", "1") TET_POINTS CELLS("0 1 2 3", "4", "10") TAIL

typedef struct bad_case {
    const char *text;
    ffd_status status;
    const char *message;
} bad_case;

static const bad_case bad_cases[] = {
    {HEAD PIECE("1000000000000", "1") TET_POINTS CELLS("0 1 2 3", "4", "10") TAIL, FFD_ERR_RANGE,
     "mem.vtu:4: NumberOfPoints 1000000000000: more than the library handles"},
    {HEAD PIECE("100000000", "1") TET_POINTS CELLS("0 1 2 3", "4", "10") TAIL, FFD_ERR_PARSE,
     "NumberOfPoints 100000000 needs more values than the"},
    {HEAD PIECE("4", "1") TET_POINTS CELLS("0 1 2 7", "4", "10") TAIL, FFD_ERR_RANGE,
     "mem.vtu:13: cell 0: node 7 out of range (4 nodes)"},
    {HEAD PIECE("4", "1") POINTS("0 0 0 1 0 nan 0 1 0 0 0 1") CELLS("0 1 2 3", "4", "10") TAIL,
     FFD_ERR_NONFINITE, "non-finite value 'nan'"},
    {HEAD PIECE("4", "1") TET_POINTS CELLS("0 1 2 3", "4", "42") TAIL, FFD_ERR_UNSUPPORTED,
     "cell type 42 is not one the library reads"},
    {HEAD PIECE("4", "1") TET_POINTS CELLS("0 1 2 3", "4", "12") TAIL, FFD_ERR_PARSE,
     "a hexahedron cell has 8 nodes, not 4"},
    {HEAD PIECE("4", "1") TET_POINTS CELLS("0 1 2 3", "5", "10") TAIL, FFD_ERR_PARSE,
     "offsets: cell 0 ends at 5"},
    {HEAD PIECE("4", "1") TET_POINTS CELLS("0 1 2 -3", "4", "10") TAIL, FFD_ERR_RANGE,
     "connectivity: cell 0 has node id -3"},
    {HEAD PIECE("4", "1") POINTS("0 0 0 1 0 0 0 1 0 0 0") CELLS("0 1 2 3", "4", "10") TAIL,
     FFD_ERR_PARSE, "expected 12 values, found 11"},
    {HEAD PIECE("4", "1") POINTS("0 0 0 1 0 0 0 1 0 0 0 1x") CELLS("0 1 2 3", "4", "10") TAIL,
     FFD_ERR_PARSE, "expected a number, found '1x'"},
    {"<?xml version=\"1.0\"?>\n<VTKFile type=\"PolyData\" version=\"1.0\">\n</VTKFile>\n",
     FFD_ERR_UNSUPPORTED, "mem.vtu:2: VTKFile type \"PolyData\": only UnstructuredGrid is read"},
    {"<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" compressor=\"vtkLZ4DataCompressor\">\n",
     FFD_ERR_UNSUPPORTED, "compressor \"vtkLZ4DataCompressor\": only vtkZLibDataCompressor"},
    {"<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" header_type=\"UInt16\">\n",
     FFD_ERR_UNSUPPORTED, "header_type \"UInt16\": expected UInt32 or UInt64"},
    {HEAD PIECE("4", "1") TET_POINTS CELLS("0 1 2 3", "4", "10") "</Piece>\n" PIECE("4", "1") TET_POINTS
         CELLS("0 1 2 3", "4", "10") TAIL,
     FFD_ERR_UNSUPPORTED, "a second <Piece>: files of several pieces are not read"},
    {HEAD PIECE("4", "1") TET_POINTS CELLS("0 1 2 3", "4", "10") "</Piece>\n</UnstructuredGrid>\n",
     FFD_ERR_PARSE, "unexpected end of file: expected </VTKFile>"},
    {HEAD "<![CDATA[x]]>" TAIL, FFD_ERR_UNSUPPORTED, "CDATA sections and DOCTYPE declarations"},
    {HEAD PIECE("4", "1") TET_POINTS "<Cells>\n</Piece>" TAIL, FFD_ERR_PARSE,
     "</Piece> does not close the open element"},
    {HEAD PIECE("4", "1") TET_POINTS "<CellData><DataArray type=\"String\" Name=\"s\" format=\"ascii\">a</DataArray></CellData>" CELLS("0 1 2 3", "4", "10") TAIL,
     FFD_ERR_UNSUPPORTED, "DataArray \"s\" of type String: only numeric arrays"},
    {HEAD PIECE("1", "0") "<Points>\n<DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"binary\">GAAAAAAAAAAAAAAAAAAAAAAAAAAA!AAAAAAAAAAA</DataArray>\n</Points>\n" TAIL,
     FFD_ERR_PARSE, "invalid base64"},
    {HEAD PIECE("1", "0") "<Points>\n<DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"binary\">YAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAA</DataArray>\n</Points>\n" TAIL,
     FFD_ERR_PARSE, "header says 96 bytes, only 26 follow"},
    {HEAD PIECE("4", "1") "<Points>\n<DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"appended\" offset=\"0\"/>\n</Points>\n" CELLS("0 1 2 3", "4", "10") TAIL,
     FFD_ERR_PARSE, "is appended but the file has no <AppendedData>"},
    {HEAD PIECE("4", "1") "<Points>\n<DataArray type=\"Int32\" NumberOfComponents=\"3\" format=\"ascii\">0 0 0 1 0 0 0 1 0 0 0 1</DataArray>\n</Points>\n" CELLS("0 1 2 3", "4", "10") TAIL,
     FFD_ERR_UNSUPPORTED, "Points of type Int32: expected Float32 or Float64"},
    {HEAD PIECE("4", "1") TET_POINTS "<Cells><DataArray type=\"Int32\" Name=\"faces\" format=\"ascii\">0</DataArray></Cells>" TAIL,
     FFD_ERR_UNSUPPORTED, "polyhedron cells (faces/faceoffsets arrays) are not read"},
    {HEAD PIECE("4", "1") TET_POINTS "<PointData><DataArray type=\"Float64\" Name=\"a&foo;\" format=\"ascii\">1 2 3 4</DataArray></PointData>" CELLS("0 1 2 3", "4", "10") TAIL,
     FFD_ERR_UNSUPPORTED, "entity reference other than &amp;"},
    {HEAD "text" TAIL, FFD_ERR_PARSE, "mem.vtu:4: unexpected text 'text' outside a DataArray"},
};

/* A piece of a partitioned mesh may hold no points and no cells (docs/mpi.md):
 * it reads as an empty mesh and writes back byte for byte. */
static void test_empty_piece(void)
{
    static const char text[] =
        "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" "
        "byte_order=\"LittleEndian\" header_type=\"UInt64\">\n  <UnstructuredGrid>\n"
        "    <Piece NumberOfPoints=\"0\" NumberOfCells=\"0\">\n"
        "      <Points>\n        <DataArray type=\"Float64\" NumberOfComponents=\"3\" "
        "format=\"ascii\">\n        </DataArray>\n      </Points>\n      <Cells>\n"
        "        <DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">\n"
        "        </DataArray>\n        <DataArray type=\"Int64\" Name=\"offsets\" "
        "format=\"ascii\">\n        </DataArray>\n        <DataArray type=\"UInt8\" "
        "Name=\"types\" format=\"ascii\">\n        </DataArray>\n      </Cells>\n"
        "    </Piece>\n  </UnstructuredGrid>\n</VTKFile>\n";
    ffd_mesh *m = NULL;
    ffd_error e = {{0}};
    CHECK(ffd_mesh_read_memory(text, sizeof text - 1, FFD_FORMAT_VTU, "empty.vtu", &m, &e) ==
          FFD_OK);
    if (!m) {
        fprintf(stderr, "%s\n", e.message);
        return;
    }
    CHECK(ffd_mesh_vertex_count(m) == 0);
    CHECK(ffd_mesh_cell_count(m) == 0);
    ffd_write_options o = {FFD_FORMAT_VTU, FFD_ENCODING_SAME, 0};
    unsigned char *bytes = NULL;
    size_t n = 0;
    CHECK(ffd_mesh_write_memory(m, &o, &bytes, &n, &e) == FFD_OK);
    CHECK(bytes && n == sizeof text - 1 && memcmp(bytes, text, n) == 0);
    ffd_free(bytes);
    ffd_mesh_destroy(m);
}

static void test_bad_inputs(void)
{
    for (size_t i = 0; i < sizeof bad_cases / sizeof bad_cases[0]; i++) {
        ffd_mesh *m = NULL;
        ffd_error err = {{0}};
        ffd_status s = ffd_mesh_read_memory(bad_cases[i].text, strlen(bad_cases[i].text),
                                            FFD_FORMAT_VTU, "mem.vtu", &m, &err);
        if (s != bad_cases[i].status || !strstr(err.message, bad_cases[i].message)) {
            fprintf(stderr, "bad case %zu: status %d, message '%s'\n  wanted %d '%s'\n", i, (int)s,
                    err.message, (int)bad_cases[i].status, bad_cases[i].message);
            CHECK(0);
        }
        CHECK(m == NULL);
    }
    /* the good base of the cases reads */
    ffd_mesh *m = NULL;
    CHECK_OK(ffd_mesh_read_memory(GOOD, strlen(GOOD), FFD_FORMAT_VTU, "mem.vtu", &m, NULL));
    CHECK(m && ffd_mesh_cell_count(m) == 1 && ffd_mesh_face_count(m) == 4);
    ffd_mesh_destroy(m);
}

/* A compressed array claiming far more bytes than deflate can make of its
 * blocks is refused before allocating. */
static void test_zip_bomb_refused(void)
{
    /* header (UInt32): 1 block of 2^31 bytes, last 2^31, compressed 8 */
    unsigned char h[16 + 8] = {1, 0, 0, 0, 0, 0, 0, 0x80, 0, 0, 0, 0x80, 8, 0, 0, 0};
    ffd_buf b = {0};
    ffd_buf_puts(&b, "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" header_type=\"UInt32\" "
                     "compressor=\"vtkZLibDataCompressor\">\n<UnstructuredGrid>\n" PIECE("4", "0")
                     "<Points><DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"binary\">");
    static const char abc[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    for (size_t i = 0; i < 24; i += 3) {
        unsigned v = (unsigned)h[i] << 16 | (unsigned)h[i + 1] << 8 | h[i + 2];
        char g[5] = {abc[v >> 18], abc[v >> 12 & 63], abc[v >> 6 & 63], abc[v & 63], 0};
        ffd_buf_puts(&b, g);
    }
    ffd_buf_puts(&b, "</DataArray></Points>" TAIL);
    ffd_mesh *m = NULL;
    ffd_error err = {{0}};
    ffd_status s = ffd_mesh_read_memory(b.data, b.size, FFD_FORMAT_VTU, "mem.vtu", &m, &err);
    /* without zlib the compressor itself is refused */
    CHECK((s == FFD_ERR_PARSE && strstr(err.message, "cannot come from")) ||
          (s == FFD_ERR_UNSUPPORTED && strstr(err.message, "without zlib")));
    CHECK(strstr(err.message, "mem.vtu") != NULL);
    ffd_buf_free(&b);
}

/* Every prefix of every sample fails cleanly or reads. */
static void test_truncated_prefixes(void)
{
    for (size_t s = 0; s < NSAMPLES; s++) {
        char path[512];
        snprintf(path, sizeof path, VOL "%s", samples[s].file);
        size_t n = 0;
        unsigned char *src = load(path, &n);
        for (size_t k = 1; src && k < n; k++) {
            ffd_mesh *m = NULL;
            ffd_error err = {{0}};
            ffd_status st = ffd_mesh_read_memory(src, k, FFD_FORMAT_VTU, "cut.vtu", &m, &err);
            if (st != FFD_OK)
                CHECK(err.message[0] != 0 && strncmp(err.message, "cut.vtu", 7) == 0);
            else
                CHECK(m != NULL);
            ffd_mesh_destroy(m);
        }
        ffd_free(src);
    }
}

static const check_test tests[] = {
    {"read_samples", test_read_samples},
    {"untouched_round_trip_identical", test_untouched_round_trip_identical},
    {"deformed_round_trip", test_deformed_round_trip},
    {"transcode_every_encoding", test_transcode_every_encoding},
    {"compressed_appended_offsets_follow", test_compressed_appended_offsets_follow},
    {"from_surface_mesh", test_from_surface_mesh},
    {"from_created_cells", test_from_created_cells},
    {"empty_piece", test_empty_piece},
    {"bad_inputs", test_bad_inputs},
    {"zip_bomb_refused", test_zip_bomb_refused},
    {"truncated_prefixes", test_truncated_prefixes},
};

int main(int argc, char **argv)
{
    return check_run(tests, sizeof tests / sizeof tests[0], argc, argv);
}
