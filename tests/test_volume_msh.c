/* Gmsh MSH codec (src/mesh/mesh_msh.c): the samples in data/volume (2.2 and
 * 4.1, ascii and binary, linear and quadratic, sparse node tags), cells per
 * type in VTK order with positive volumes (Gmsh's prism is reversed), tags
 * as fields, byte-identical untouched writes, deformed writes that change
 * only the $Nodes section, MSH 2.2 writes from data read back identically,
 * surfaces and ffd_mesh_create_cells meshes written as .msh, bad inputs. */
#include "check.h"

#include <stdbool.h>
#include <stdint.h>

#include <ffd.h>
#include "check_volume.h"

#define VOL FFD_DATA_DIR "/volume/"

/* Signed volume enclosed by the mesh's faces (fans): positive when they are
 * closed and oriented outwards (the boundary of positive cells). */
static size_t count_type(const ffd_mesh *m, unsigned type)
{
    size_t n = 0;
    for (size_t c = 0; c < ffd_mesh_cell_count(m); c++)
        n += ffd_mesh_cell_types(m)[c] == type;
    return n;
}

static ffd_mesh *read_mesh(const char *path)
{
    ffd_mesh *m = NULL;
    ffd_error e = {{0}};
    if (ffd_mesh_read(path, &m, &e) != FFD_OK) {
        fprintf(stderr, "%s: %s\n", path, e.message);
        CHECK(!"read failed");
    }
    return m;
}

static unsigned char *read_file(const char *path, size_t *size)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    unsigned char *d = malloc((size_t)n + 1);
    *size = fread(d, 1, (size_t)n, f);
    fclose(f);
    return d;
}

typedef struct sample {
    const char *file;
    bool binary;
    size_t nodes, faces;
    unsigned type[4];
    size_t count[4];
    double volume;
} sample;

static const sample samples[] = {
    {"mixed_22.msh", false, 13, 18,
     {FFD_CELL_HEXAHEDRON, FFD_CELL_WEDGE, FFD_CELL_PYRAMID, FFD_CELL_TETRA}, {1, 1, 1, 1},
     1 + 0.5 + 1.0 / 6 + 1.0 / 6},
    {"mixed_22_bin.msh", true, 13, 18,
     {FFD_CELL_HEXAHEDRON, FFD_CELL_WEDGE, FFD_CELL_PYRAMID, FFD_CELL_TETRA}, {1, 1, 1, 1},
     1 + 0.5 + 1.0 / 6 + 1.0 / 6},
    {"prism_41.msh", false, 24, 28, {FFD_CELL_WEDGE, FFD_CELL_TRIANGLE}, {14, 7}, 0.5},
    {"prism_41_bin.msh", true, 24, 28, {FFD_CELL_WEDGE, FFD_CELL_TRIANGLE}, {14, 7}, 0.5},
    {"prism15_41.msh", false, 82, 28, {FFD_CELL_QUADRATIC_WEDGE, FFD_CELL_QUADRATIC_TRIANGLE},
     {14, 7}, 0.5},
    {"box_tet10_41.msh", false, 0, 0, {FFD_CELL_QUADRATIC_TETRA, FFD_CELL_QUADRATIC_TRIANGLE},
     {0, 0}, 1},
};
#define SAMPLE_COUNT (sizeof samples / sizeof samples[0])

static void test_read_samples(void)
{
    for (size_t i = 0; i < SAMPLE_COUNT; i++) {
        const sample *s = &samples[i];
        char path[512];
        snprintf(path, sizeof path, VOL "%s", s->file);
        ffd_mesh *m = read_mesh(path);
        if (!m)
            continue;
        CHECK(ffd_mesh_is_volume(m));
        if (s->nodes)
            CHECK(ffd_mesh_vertex_count(m) == s->nodes);
        if (s->faces)
            CHECK(ffd_mesh_face_count(m) == s->faces);
        for (int k = 0; k < 4 && s->type[k]; k++) {
            if (s->count[k])
                CHECK(count_type(m, s->type[k]) == s->count[k]);
            else
                CHECK(count_type(m, s->type[k]) > 0);
        }
        /* every cell positive: the boundary encloses the solid's volume */
        CHECK_NEAR(enclosed_volume(m), s->volume, 1e-9);
        CHECK(field(m, "gmsh:physical") != NULL);
        CHECK(field(m, "gmsh:geometrical") != NULL);
        ffd_mesh_destroy(m);
    }
}

/* mixed_22.msh: sparse node tags (10, 20, ...) mapped to indices; the tags of
 * each element; Gmsh's prism (5 6 8 10 11 12) is VTK's wedge (5 8 6 10 12 11). */
static void test_mixed_details(void)
{
    ffd_mesh *m = read_mesh(VOL "mixed_22.msh");
    if (!m)
        return;
    CHECK(ffd_mesh_cell_count(m) == 7);
    static const uint8_t types[] = {FFD_CELL_VERTEX,     FFD_CELL_LINE,    FFD_CELL_QUAD,
                                    FFD_CELL_HEXAHEDRON, FFD_CELL_PYRAMID, FFD_CELL_WEDGE,
                                    FFD_CELL_TETRA};
    CHECK(memcmp(ffd_mesh_cell_types(m), types, sizeof types) == 0);
    const uint32_t *ix = ffd_mesh_cell_indices(m) + ffd_mesh_cell_offsets(m)[5];
    static const uint32_t wedge[] = {4, 7, 5, 9, 11, 10};
    CHECK(memcmp(ix, wedge, sizeof wedge) == 0);
    CHECK_NEAR(ffd_mesh_positions(m)[3 * 8], 1.5, 0);
    const double *ph = field(m, "gmsh:physical"), *el = field(m, "gmsh:geometrical");
    if (ph && el) {
        static const double want_ph[] = {20, 21, 10, 1, 1, 2, 2}, want_el[] = {7, 6, 5, 1, 2, 3, 4};
        CHECK(memcmp(ph, want_ph, sizeof want_ph) == 0);
        CHECK(memcmp(el, want_el, sizeof want_el) == 0);
    }
    ffd_mesh_destroy(m);
}

/* ffd_mesh_node_tags: each vertex's tag as the file gives it (sparse in
 * mixed_22.msh, in 4.1 entity blocks in prism_41.msh: tags 1..n), kept after
 * a deformation; NULL for a mesh of another format. */
static void test_node_tags(void)
{
    ffd_mesh *m = read_mesh(VOL "mixed_22.msh");
    if (m) {
        const uint64_t *tags = ffd_mesh_node_tags(m);
        CHECK(tags != NULL);
        for (size_t i = 0; tags && i < ffd_mesh_vertex_count(m); i++)
            CHECK(tags[i] == 10 * (i + 1));
        ffd_mesh_destroy(m);
    }
    m = read_mesh(VOL "prism_41_bin.msh");
    if (m) {
        const uint64_t *tags = ffd_mesh_node_tags(m);
        CHECK(tags != NULL);
        for (size_t i = 0; tags && i < ffd_mesh_vertex_count(m); i++)
            CHECK(tags[i] == i + 1);
        ffd_mesh_destroy(m);
    }
    m = read_mesh(VOL "mixed_ascii.vtu");
    if (m) {
        CHECK(ffd_mesh_node_tags(m) == NULL);
        ffd_mesh_destroy(m);
    }
    CHECK(ffd_mesh_node_tags(NULL) == NULL);
}

/* The pieces of a partitioned mesh as Gmsh 4.8 splits them (`-part N
 * -part_split`, MSH 4.1 with $PartitionedEntities, ascii and binary): each
 * node has the coordinates and tag it has in the whole mesh, every node of
 * the whole mesh is on a piece, and the cells' elementary tags are the
 * piece's partitioned entities. */
static void test_partitioned_pieces(void)
{
    ffd_mesh *whole = read_mesh(VOL "mpi/mpi_box.msh");
    if (!whole)
        return;
    static const char *const pieces[] = {
        VOL "mpi/mpi_box_41_p3_1.msh", VOL "mpi/mpi_box_41_p3_2.msh", VOL "mpi/mpi_box_41_p3_3.msh",
        NULL, VOL "mpi/mpi_box_41bin_p2_1.msh", VOL "mpi/mpi_box_41bin_p2_2.msh", NULL};
    size_t n = ffd_mesh_vertex_count(whole);
    unsigned char *seen = calloc(n, 1);
    for (size_t k = 0; k < sizeof pieces / sizeof *pieces; k++) {
        if (!pieces[k]) { /* the end of a partition: every node was on a piece */
            for (size_t i = 0; i < n; i++)
                CHECK(seen[i]);
            memset(seen, 0, n);
            continue;
        }
        ffd_mesh *m = read_mesh(pieces[k]);
        if (!m)
            continue;
        const uint64_t *tags = ffd_mesh_node_tags(m);
        CHECK(tags != NULL);
        for (size_t i = 0; tags && i < ffd_mesh_vertex_count(m); i++) {
            CHECK(tags[i] >= 1 && tags[i] <= n);
            if (tags[i] < 1 || tags[i] > n)
                continue;
            seen[tags[i] - 1] = 1;
            CHECK(memcmp(ffd_mesh_positions(m) + 3 * i,
                         ffd_mesh_positions(whole) + 3 * (tags[i] - 1), 3 * sizeof(double)) == 0);
        }
        CHECK(ffd_mesh_is_volume(m));
        /* each block's entity is a partitioned one: its elementary tag */
        const double *el = field(m, "gmsh:geometrical");
        CHECK(el != NULL);
        for (size_t c = 0; el && c < ffd_mesh_cell_count(m); c++)
            if (el[c] < 1 && check_failures < 5)
                CHECK(el[c] >= 1);
        ffd_mesh_destroy(m);
    }
    free(seen);
    ffd_mesh_destroy(whole);
}

/* tet10: Gmsh's nodes 8 and 9 swap into VTK's order: VTK's node 8 is the
 * middle of corners 1 and 3. */
static void test_quadratic_order(void)
{
    ffd_mesh *m = read_mesh(VOL "box_tet10_41.msh");
    if (!m)
        return;
    const double *p = ffd_mesh_positions(m);
    size_t bad = 0, tets = 0;
    for (size_t c = 0; c < ffd_mesh_cell_count(m); c++) {
        if (ffd_mesh_cell_types(m)[c] != FFD_CELL_QUADRATIC_TETRA)
            continue;
        const uint32_t *n = ffd_mesh_cell_indices(m) + ffd_mesh_cell_offsets(m)[c];
        static const int edge[6][2] = {{0, 1}, {1, 2}, {2, 0}, {0, 3}, {1, 3}, {2, 3}};
        for (int e = 0; e < 6; e++)
            for (int k = 0; k < 3; k++)
                bad += fabs(p[3 * n[4 + e] + k] -
                            (p[3 * n[edge[e][0]] + k] + p[3 * n[edge[e][1]] + k]) / 2) > 1e-9;
        tets++;
    }
    CHECK(tets > 0);
    CHECK(bad == 0);
    ffd_mesh_destroy(m);
    /* prism15: VTK's edge nodes 6..14 are the middles of (0,1) (1,2) (2,0)
     * (3,4) (4,5) (5,3) (0,3) (1,4) (2,5) */
    m = read_mesh(VOL "prism15_41.msh");
    if (!m)
        return;
    p = ffd_mesh_positions(m);
    bad = 0;
    for (size_t c = 0; c < ffd_mesh_cell_count(m); c++) {
        if (ffd_mesh_cell_types(m)[c] != FFD_CELL_QUADRATIC_WEDGE)
            continue;
        const uint32_t *n = ffd_mesh_cell_indices(m) + ffd_mesh_cell_offsets(m)[c];
        static const int edge[9][2] = {{0, 1}, {1, 2}, {2, 0}, {3, 4}, {4, 5},
                                       {5, 3}, {0, 3}, {1, 4}, {2, 5}};
        for (int e = 0; e < 9; e++)
            for (int k = 0; k < 3; k++)
                bad += fabs(p[3 * n[6 + e] + k] -
                            (p[3 * n[edge[e][0]] + k] + p[3 * n[edge[e][1]] + k]) / 2) > 1e-9;
    }
    CHECK(bad == 0);
    ffd_mesh_destroy(m);
}

static void test_untouched_identical(void)
{
    for (size_t i = 0; i < SAMPLE_COUNT; i++) {
        char path[512];
        snprintf(path, sizeof path, VOL "%s", samples[i].file);
        size_t n = 0;
        unsigned char *src = read_file(path, &n);
        ffd_mesh *m = read_mesh(path);
        unsigned char *out = NULL;
        size_t size = 0;
        ffd_write_options o = {.format = FFD_FORMAT_MSH};
        if (m && src) {
            CHECK_OK(ffd_mesh_write_memory(m, &o, &out, &size, NULL));
            CHECK(size == n && out && memcmp(out, src, n) == 0);
        }
        ffd_free(out);
        ffd_mesh_destroy(m);
        free(src);
    }
}

/* Where "$Nodes" starts and "$EndNodes" ends in a file. */
static void nodes_section(const unsigned char *d, size_t n, size_t *from, size_t *to)
{
    *from = *to = 0;
    for (size_t i = 0; i + 9 <= n; i++) {
        if (!*from && memcmp(d + i, "$Nodes", 6) == 0)
            *from = i;
        if (memcmp(d + i, "$EndNodes", 9) == 0)
            *to = i + 9;
    }
}

static void test_deformed_changes_only_nodes(void)
{
    for (size_t i = 0; i < SAMPLE_COUNT; i++) {
        char path[512];
        snprintf(path, sizeof path, VOL "%s", samples[i].file);
        size_t n = 0;
        unsigned char *src = read_file(path, &n);
        ffd_mesh *m = read_mesh(path);
        if (!m || !src) {
            free(src);
            ffd_mesh_destroy(m);
            continue;
        }
        size_t nv = ffd_mesh_vertex_count(m);
        double *p = malloc(3 * nv * sizeof(double));
        memcpy(p, ffd_mesh_positions(m), 3 * nv * sizeof(double));
        for (size_t k = 0; k < 3 * nv; k++)
            p[k] = p[k] * 1.25 + 0.125 * (double)(k % 3);
        CHECK_OK(ffd_mesh_set_positions(m, p, NULL, NULL));
        unsigned char *out = NULL;
        size_t size = 0;
        ffd_write_options o = {.format = FFD_FORMAT_MSH};
        CHECK_OK(ffd_mesh_write_memory(m, &o, &out, &size, NULL));
        size_t a0, a1, b0, b1;
        nodes_section(src, n, &a0, &a1);
        nodes_section(out, size, &b0, &b1);
        CHECK(a0 == b0 && a0 > 0);
        CHECK(memcmp(src, out, a0) == 0);
        CHECK(n - a1 == size - b1 && memcmp(src + a1, out + b1, n - a1) == 0);
        if (samples[i].binary)
            CHECK(size == n);
        CHECK(size != n || memcmp(src, out, n) != 0);
        /* read back: the deformed nodes, the same cells */
        ffd_mesh *r = NULL;
        CHECK_OK(ffd_mesh_read_memory(out, size, FFD_FORMAT_MSH, "deformed", &r, NULL));
        if (r) {
            CHECK(memcmp(ffd_mesh_positions(r), p, 3 * nv * sizeof(double)) == 0);
            CHECK(ffd_mesh_cell_count(r) == ffd_mesh_cell_count(m));
        }
        ffd_mesh_destroy(r);
        ffd_free(out);
        free(p);
        ffd_mesh_destroy(m);
        free(src);
    }
}

/* Same nodes, cells (types and indices) and fields. */
static void check_same_mesh(const ffd_mesh *a, const ffd_mesh *b)
{
    size_t nv = ffd_mesh_vertex_count(a), nc = ffd_mesh_cell_count(a);
    CHECK(ffd_mesh_vertex_count(b) == nv);
    CHECK(ffd_mesh_cell_count(b) == nc);
    if (ffd_mesh_vertex_count(b) != nv || ffd_mesh_cell_count(b) != nc)
        return;
    CHECK(memcmp(ffd_mesh_positions(a), ffd_mesh_positions(b), 3 * nv * sizeof(double)) == 0);
    CHECK(memcmp(ffd_mesh_cell_types(a), ffd_mesh_cell_types(b), nc) == 0);
    CHECK(memcmp(ffd_mesh_cell_offsets(a), ffd_mesh_cell_offsets(b), (nc + 1) * 8) == 0);
    CHECK(memcmp(ffd_mesh_cell_indices(a), ffd_mesh_cell_indices(b),
                 ffd_mesh_cell_offsets(a)[nc] * sizeof(uint32_t)) == 0);
    CHECK(ffd_mesh_face_count(a) == ffd_mesh_face_count(b));
    static const char *const tags[] = {"gmsh:physical", "gmsh:geometrical"};
    for (int t = 0; t < 2; t++) {
        const double *fa = field(a, tags[t]), *fb = field(b, tags[t]);
        CHECK((fa == NULL) == (fb == NULL));
        if (fa && fb)
            CHECK(memcmp(fa, fb, nc * sizeof(double)) == 0);
    }
}

static void test_transcode(void)
{
    static const ffd_encoding encs[] = {FFD_ENCODING_ASCII, FFD_ENCODING_BINARY_LE};
    for (size_t i = 0; i < SAMPLE_COUNT; i++) {
        char path[512];
        snprintf(path, sizeof path, VOL "%s", samples[i].file);
        ffd_mesh *m = read_mesh(path);
        if (!m)
            continue;
        for (int e = 0; e < 2; e++) {
            if ((encs[e] == FFD_ENCODING_BINARY_LE) == samples[i].binary)
                continue; /* the same encoding is the lossless copy */
            unsigned char *out = NULL;
            size_t size = 0;
            ffd_write_options o = {.format = FFD_FORMAT_MSH, .encoding = encs[e]};
            CHECK_OK(ffd_mesh_write_memory(m, &o, &out, &size, NULL));
            CHECK(size > 20 && memcmp(out, encs[e] == FFD_ENCODING_ASCII
                                               ? "$MeshFormat\n2.2 0 8\n"
                                               : "$MeshFormat\n2.2 1 8\n",
                                      20) == 0);
            ffd_mesh *r = NULL;
            ffd_error err = {{0}};
            if (ffd_mesh_read_memory(out, size, FFD_FORMAT_MSH, "transcoded", &r, &err)) {
                fprintf(stderr, "%s: %s\n", samples[i].file, err.message);
                CHECK(!"transcoded file unreadable");
            }
            if (r)
                check_same_mesh(m, r);
            ffd_mesh_destroy(r);
            ffd_free(out);
        }
        ffd_mesh_destroy(m);
    }
}

static void test_surface_to_msh(void)
{
    ffd_mesh *m = read_mesh(FFD_DATA_DIR "/bunny.obj");
    if (!m)
        return;
    static const ffd_encoding encs[] = {FFD_ENCODING_ASCII, FFD_ENCODING_BINARY_LE};
    for (int e = 0; e < 2; e++) {
        unsigned char *out = NULL;
        size_t size = 0;
        ffd_write_options o = {.format = FFD_FORMAT_MSH, .encoding = encs[e]};
        CHECK_OK(ffd_mesh_write_memory(m, &o, &out, &size, NULL));
        ffd_mesh *r = NULL;
        CHECK_OK(ffd_mesh_read_memory(out, size, FFD_FORMAT_MSH, "bunny.msh", &r, NULL));
        if (r) {
            CHECK(!ffd_mesh_is_volume(r));
            CHECK(ffd_mesh_vertex_count(r) == ffd_mesh_vertex_count(m));
            CHECK(memcmp(ffd_mesh_positions(r), ffd_mesh_positions(m),
                         3 * ffd_mesh_vertex_count(m) * sizeof(double)) == 0);
            CHECK(ffd_mesh_face_count(r) == ffd_mesh_face_count(m));
            CHECK(count_type(r, FFD_CELL_TRIANGLE) == ffd_mesh_face_count(m));
            size_t nf = ffd_mesh_face_count(m);
            CHECK(memcmp(ffd_mesh_face_indices(r), ffd_mesh_face_indices(m),
                         ffd_mesh_face_offsets(m)[nf] * sizeof(uint32_t)) == 0);
            CHECK(field(r, "gmsh:physical") == NULL); /* no tags invented */
        }
        ffd_mesh_destroy(r);
        ffd_free(out);
    }
    ffd_mesh_destroy(m);
}

/* A hexahedron, a wedge on its top, a pyramid on its side, a tetrahedron,
 * their quadratic cousins are covered by the samples. */
static void test_created_cells_to_msh(void)
{
    static const double p[] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 0, 0, 1, 1, 0, 1, 1, 1, 1,
                               0, 1, 1, 1.5, 0.5, 0.5, 0, 0, 2, 1, 0, 2, 0, 1, 2, 1, 1, 2};
    static const uint8_t types[] = {FFD_CELL_HEXAHEDRON, FFD_CELL_PYRAMID, FFD_CELL_WEDGE,
                                    FFD_CELL_TETRA, FFD_CELL_QUAD};
    static const uint64_t off[] = {0, 8, 13, 19, 23, 27};
    static const uint32_t ix[] = {0, 1, 2, 3, 4, 5, 6, 7, 1, 2, 6, 5, 8, 4, 7, 5,
                                  9, 11, 10, 5, 6, 7, 12, 0, 3, 2, 1};
    ffd_mesh *m = NULL;
    CHECK_OK(ffd_mesh_create_cells(p, 13, types, off, ix, 5, &m, NULL));
    if (!m)
        return;
    CHECK_NEAR(enclosed_volume(m), 1 + 0.5 + 1.0 / 6 + 1.0 / 6, 1e-12);
    static const ffd_encoding encs[] = {FFD_ENCODING_ASCII, FFD_ENCODING_BINARY_LE};
    for (int e = 0; e < 2; e++) {
        unsigned char *out = NULL;
        size_t size = 0;
        ffd_write_options o = {.format = FFD_FORMAT_MSH, .encoding = encs[e]};
        CHECK_OK(ffd_mesh_write_memory(m, &o, &out, &size, NULL));
        ffd_mesh *r = NULL;
        CHECK_OK(ffd_mesh_read_memory(out, size, FFD_FORMAT_MSH, "created.msh", &r, NULL));
        if (r) {
            check_same_mesh(m, r);
            CHECK_NEAR(enclosed_volume(r), enclosed_volume(m), 1e-12);
        }
        ffd_mesh_destroy(r);
        ffd_free(out);
    }
    ffd_mesh_destroy(m);
}

/* ---- bad input ---------------------------------------------------------- */

#define HEAD22 "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n"
#define NODES22 "$Nodes\n4\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n$EndNodes\n"
#define HEAD41 "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n"

typedef struct bad_case {
    const char *text;
    ffd_status status;
    const char *message;
} bad_case;

static const bad_case bad_cases[] = {
    {" \n", FFD_ERR_PARSE, "bad.msh:2: expected $MeshFormat, found an empty file"},
    {"$Nodes\n", FFD_ERR_PARSE, "bad.msh:1: expected $MeshFormat first"},
    {"$MeshFormat\n3.0 0 8\n$EndMeshFormat\n", FFD_ERR_UNSUPPORTED,
     "bad.msh:2: MSH version 3 is not supported (2.2 and 4.1 are)"},
    {"$MeshFormat\n4.0 0 8\n$EndMeshFormat\n", FFD_ERR_UNSUPPORTED, "MSH version 4 is not"},
    {"$MeshFormat\n2.2 1 8\n\0\0\0\1\n$EndMeshFormat\n", FFD_ERR_UNSUPPORTED,
     "bad.msh: byte 20: big-endian binary MSH is not supported"},
    {"$MeshFormat\n2.2 1 4\n", FFD_ERR_UNSUPPORTED, "data size 4 is not supported"},
    {HEAD22 "$Nodes\n1000000000000\n1 0 0 0\n$EndNodes\n", FFD_ERR_RANGE,
     "bad.msh:5: node count 1000000000000 is more than the"},
    {HEAD22 "$Nodes\n2\n1 0 0 0\n2 nan 0 0\n$EndNodes\n", FFD_ERR_NONFINITE,
     "bad.msh:7: the node's x is not finite"},
    {HEAD22 "$Nodes\n1\n1 0 0          ", FFD_ERR_PARSE,
     "bad.msh:6: expected the node's z, found the end of the file"},
    {HEAD22 "$Nodes\n2\n1 0 0 0\n1 1 0 0\n$EndNodes\n", FFD_ERR_PARSE,
     "node tag 1 is defined twice"},
    {HEAD22 NODES22 "$Elements\n1\n1 4 2 1 1 1 2 3 9\n$EndElements\n", FFD_ERR_RANGE,
     "bad.msh:13: node tag 9 of a tetrahedron is not in $Nodes"},
    {HEAD22 NODES22 "$Elements\n1\n1 13 2 1 1 1 2 3 4\n$EndElements\n", FFD_ERR_UNSUPPORTED,
     "bad.msh:13: element type 13 (prism18) is not supported: it has no VTK cell type"},
    {HEAD22 NODES22 "$Elements\n1\n1 99 2 1 1 1 2 3 4\n$EndElements\n", FFD_ERR_UNSUPPORTED,
     "element type 99 is not supported"},
    {HEAD22 NODES22 "$Elements\n1\n1 4 2 1 1 1 2 3 4\n", FFD_ERR_PARSE,
     "bad.msh:14: expected $EndElements"},
    {HEAD22 NODES22, FFD_ERR_PARSE, "no $Elements section"},
    {HEAD22 "$Elements\n0\n$EndElements\n", FFD_ERR_PARSE, "bad.msh:4: $Elements before $Nodes"},
    {HEAD22 "$ParametricNodes\n", FFD_ERR_UNSUPPORTED, "bad.msh:4: $ParametricNodes is not"},
    {HEAD22 "$Comments\nno end\n", FFD_ERR_PARSE, "bad.msh:4: section $Comments has no $EndComments"},
    {HEAD41 "$PartitionedEntities\n2\n0\n$EndPartitionedEntities\n", FFD_ERR_PARSE,
     "bad.msh:7: expected an entity count"},
    {HEAD41 "$PartitionedEntities\n2\n1\n", FFD_ERR_RANGE,
     "bad.msh:6: ghost entity count 1 is more than the 1 bytes left can hold"},
    {HEAD41 "$PartitionedEntities\n2\n0\n0 1 0 0\n5 0 1 99 1 0 0 0 0\n$EndPartitionedEntities\n",
     FFD_ERR_RANGE, "bad.msh:8: partition count 99 is more than"},
    {HEAD22 "$PartitionedEntities\n$EndPartitionedEntities\n", FFD_ERR_PARSE,
     "bad.msh:4: $PartitionedEntities in an MSH 2 file"},
    {HEAD41 "$Nodes\n1 1 1 1\n2 1 1 1\n1\n0 0 0 0.5\n$EndNodes\n", FFD_ERR_UNSUPPORTED,
     "bad.msh:6: parametric nodes (entity 1 of dimension 2) are not supported"},
    {HEAD41 "$Nodes\n1 2 1 2\n0 1 0 3\n1\n2\n3\n0 0 0\n0 0 0\n0 0 0\n$EndNodes\n", FFD_ERR_RANGE,
     "bad.msh:6: the block's 3 nodes exceed the section's node count 2"},
    {HEAD41 "$Nodes\n1 1 1 1\n0 1 0 1\n1\n0 0 0\n$EndNodes\n$Elements\n1 1 1 1\n3 1 4 1\n1 1 1 1 "
            "0\n$EndElements\n",
     FFD_ERR_RANGE, "bad.msh:13: node tag 0 of a tetrahedron is not in $Nodes"},
    {HEAD41 "$Entities\n99999999999 0 0 0\n$EndEntities\n", FFD_ERR_RANGE,
     "entity count 99999999999 is more than"},
};

static void test_bad_inputs(void)
{
    for (size_t i = 0; i < sizeof bad_cases / sizeof bad_cases[0]; i++) {
        const bad_case *b = &bad_cases[i];
        /* the big-endian case holds NULs: its length is the literal's */
        size_t n = strlen(b->text);
        if (strstr(b->message, "big-endian"))
            n = sizeof("$MeshFormat\n2.2 1 8\n\0\0\0\1\n$EndMeshFormat\n") - 1;
        ffd_mesh *m = NULL;
        ffd_error e = {{0}};
        ffd_status s = ffd_mesh_read_memory(b->text, n, FFD_FORMAT_MSH, "bad.msh", &m, &e);
        if (s != b->status || !strstr(e.message, b->message)) {
            fprintf(stderr, "case %zu: status %d, message '%s', want %d '%s'\n", i, (int)s,
                    e.message, (int)b->status, b->message);
            CHECK(!"bad input not refused as expected");
        }
        CHECK(m == NULL);
        ffd_mesh_destroy(m);
    }
}

/* A binary file claiming more elements than its bytes hold; every
 * truncated prefix of each sample fails cleanly (or reads, for prefixes
 * that end after the last section). */
static void test_truncated_prefixes(void)
{
    /* the samples, then pieces of a partitioned mesh ($PartitionedEntities) */
    static const char *const pieces[] = {"mpi/mpi_box_41_p3_1.msh", "mpi/mpi_box_41bin_p2_1.msh"};
    for (size_t i = 0; i < SAMPLE_COUNT + 2; i++) {
        const char *file = i < SAMPLE_COUNT ? samples[i].file : pieces[i - SAMPLE_COUNT];
        if (strstr(file, "box_tet10"))
            continue; /* large: the small samples cover every section */
        char path[512];
        snprintf(path, sizeof path, VOL "%s", file);
        size_t n = 0;
        unsigned char *src = read_file(path, &n);
        if (!src)
            continue;
        size_t step = n > 2000 ? 7 : 1;
        for (size_t k = 0; k < n; k += step) {
            ffd_mesh *m = NULL;
            ffd_error e = {{0}};
            ffd_status s = ffd_mesh_read_memory(src, k, FFD_FORMAT_MSH, "cut.msh", &m, &e);
            CHECK(s == FFD_OK || (m == NULL && e.message[0]));
            ffd_mesh_destroy(m);
        }
        free(src);
    }
}

static void test_binary_huge_block(void)
{
    size_t n = 0;
    unsigned char *src = read_file(VOL "mixed_22_bin.msh", &n);
    if (!src)
        return;
    /* the first element block header follows "$Elements\n13\n"... find it */
    unsigned char *at = NULL;
    for (size_t i = 0; i + 9 < n; i++)
        if (memcmp(src + i, "$Elements\n", 10) == 0) {
            at = src + i + 10;
            break;
        }
    CHECK(at != NULL);
    if (at) {
        while (*at != '\n')
            at++;
        at++;
        at[4] = 0x7f; /* the block's element count: 127 + ... */
        ffd_mesh *m = NULL;
        ffd_error e = {{0}};
        CHECK(ffd_mesh_read_memory(src, n, FFD_FORMAT_MSH, "huge.msh", &m, &e) == FFD_ERR_RANGE);
        CHECK(strstr(e.message, "huge.msh: byte ") && strstr(e.message, "element block of"));
    }
    free(src);
}

/* A hand-made binary 4.1 file: size_t counts and tags, entities with
 * physical tags, one node block per point entity. Its data starts right after
 * each section's line with a byte that looks like a blank (9: 0x09, a tab):
 * data, not space. */
static void put_u64(unsigned char **q, uint64_t v)
{
    for (int k = 0; k < 8; k++)
        *(*q)++ = (unsigned char)(v >> (8 * k));
}
static void put_i32le(unsigned char **q, int32_t v)
{
    for (int k = 0; k < 4; k++)
        *(*q)++ = (unsigned char)((uint32_t)v >> (8 * k));
}
static void put_f64(unsigned char **q, double v)
{
    uint64_t u;
    memcpy(&u, &v, 8);
    put_u64(q, u);
}
static void put_text(unsigned char **q, const char *t)
{
    memcpy(*q, t, strlen(t));
    *q += strlen(t);
}

static void test_binary_data_after_section_line(void)
{
    static unsigned char buf[4096];
    unsigned char *q = buf;
    put_text(&q, "$MeshFormat\n4.1 1 8\n");
    put_i32le(&q, 1);
    put_text(&q, "\n$EndMeshFormat\n$Entities\n");
    put_u64(&q, 9); /* points */
    for (int i = 0; i < 3; i++)
        put_u64(&q, 0);
    for (int i = 1; i <= 9; i++) {
        put_i32le(&q, i);
        for (int k = 0; k < 3; k++)
            put_f64(&q, i);
        put_u64(&q, 1); /* one physical tag: 100 + i */
        put_i32le(&q, 100 + i);
    }
    put_text(&q, "\n$EndEntities\n$Nodes\n");
    put_u64(&q, 9);  /* blocks: 0x09 again */
    put_u64(&q, 9);  /* nodes */
    put_u64(&q, 1);
    put_u64(&q, 9);
    for (int i = 1; i <= 9; i++) {
        put_i32le(&q, 0);
        put_i32le(&q, i);
        put_i32le(&q, 0);
        put_u64(&q, 1);
        put_u64(&q, (uint64_t)i);
        for (int k = 0; k < 3; k++)
            put_f64(&q, i + 0.5 * k);
    }
    put_text(&q, "\n$EndNodes\n$Elements\n");
    put_u64(&q, 9);
    put_u64(&q, 9);
    put_u64(&q, 1);
    put_u64(&q, 9);
    for (int i = 1; i <= 9; i++) {
        put_i32le(&q, 0);
        put_i32le(&q, i);
        put_i32le(&q, 15); /* point */
        put_u64(&q, 1);
        put_u64(&q, (uint64_t)i);
        put_u64(&q, (uint64_t)i);
    }
    put_text(&q, "\n$EndElements\n");
    ffd_mesh *m = NULL;
    ffd_error e = {{0}};
    ffd_status s = ffd_mesh_read_memory(buf, (size_t)(q - buf), FFD_FORMAT_MSH, "tab.msh", &m, &e);
    if (s)
        fprintf(stderr, "%s\n", e.message);
    CHECK(s == FFD_OK);
    if (!m)
        return;
    CHECK(ffd_mesh_vertex_count(m) == 9);
    CHECK(ffd_mesh_cell_count(m) == 9);
    CHECK_NEAR(ffd_mesh_positions(m)[3 * 8 + 2], 10, 0);
    const double *ph = field(m, "gmsh:physical");
    CHECK(ph && ph[8] == 109);
    ffd_mesh_destroy(m);
}

int main(int argc, char **argv)
{
    static const check_test tests[] = {
        {"read_samples", test_read_samples},
        {"mixed_details", test_mixed_details},
        {"quadratic_order", test_quadratic_order},
        {"node_tags", test_node_tags},
        {"partitioned_pieces", test_partitioned_pieces},
        {"untouched_identical", test_untouched_identical},
        {"deformed_changes_only_nodes", test_deformed_changes_only_nodes},
        {"transcode", test_transcode},
        {"surface_to_msh", test_surface_to_msh},
        {"created_cells_to_msh", test_created_cells_to_msh},
        {"bad_inputs", test_bad_inputs},
        {"truncated_prefixes", test_truncated_prefixes},
        {"binary_huge_block", test_binary_huge_block},
        {"binary_data_after_section_line", test_binary_data_after_section_line},
    };
    return check_run(tests, sizeof tests / sizeof tests[0], argc, argv);
}
