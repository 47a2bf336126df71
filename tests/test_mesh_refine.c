/* Tests of ffd_mesh_refine: every format (exact expected output for small
 * meshes, interpolated attributes, re-reading), identity plans reproducing
 * the source byte for byte, bad plans, failing allocations, and a red/green
 * refinement of the bunny that stays closed. */
#include "check.h"
#include "ffd.h"
#include "mesh/mesh.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define FIX FFD_SOURCE_DIR "/tests/data/mesh/"
#define SHARED FFD_DATA_DIR "/"

/* ---------------------------------------------------------------------- */
/* A tetrahedron, faces (0 2 1) (0 1 3) (0 3 2) (1 2 3), refined by: new
 * vertex 4 = midpoint of 1 and 2, new vertex 5 = midpoint of 4 and 3; face 0
 * split in two at 4, face 3 in four, faces 1 and 2 unchanged. */

static const ffd_refine_vertex tet_new[2] = {
    {2, {1, 2, 0, 0}, {0.5, 0.5, 0, 0}},
    {2, {4, 3, 0, 0}, {0.5, 0.5, 0, 0}},
};
static const uint32_t tet_off[9] = {0, 3, 6, 9, 12, 15, 18, 21, 24};
static const uint32_t tet_idx[24] = {0, 2, 4, 0, 4, 1, 0, 1, 3, 0, 3, 2,
                                     1, 4, 5, 1, 5, 3, 4, 2, 5, 5, 2, 3};
static const uint32_t tet_par[8] = {0, 0, 1, 2, 3, 3, 3, 3};
static const ffd_refine_plan tet_plan = {2, tet_new, 8, tet_off, tet_idx, tet_par};
static const double tet_pos[12] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
static const uint32_t tet_src_off[5] = {0, 3, 6, 9, 12};
static const uint32_t tet_src_idx[12] = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3};

static const char tet_obj[] =
    "# tetra with everything\n"
    "mtllib t.mtl\n"
    "o tetra\n"
    "v 0 0 0 1 0 0\n"
    "v 1 0 0 0 1 0\n"
    "v 0 1 0 0 0 1\n"
    "v 0 0 1 1 1 1\n"
    "vt 0 0\n"
    "vt 1 0\n"
    "vt 0 1\n"
    "vt 1 1\n"
    "vn 0 0 -1\n"
    "vn 0 -1 0\n"
    "vn -1 0 0\n"
    "vn 1 1 1\n"
    "g base\n"
    "usemtl red\n"
    "s off\n"
    "f 1/1/1 3/3/1 2/2/1   # bottom\n"
    "g sides\n"
    "usemtl blue\n"
    "s 1\n"
    "f 1/1/2 2/2/2 4/4/2\n"
    "f 1/1/3 4/4/3 3/3/3\n"
    "f -3/-3/-1 -2/-2/-1 -1/-1/-1\n"
    "l 1 -1\n"
    "# end\n";

static const char tet_obj_refined[] =
    "# tetra with everything\n"
    "mtllib t.mtl\n"
    "o tetra\n"
    "v 0 0 0 1 0 0\n"
    "v 1 0 0 0 1 0\n"
    "v 0 1 0 0 0 1\n"
    "v 0 0 1 1 1 1\n"
    "v 0.5 0.5 0 0 0.5 0.5\n"
    "v 0.25 0.25 0.5 0.5 0.75 0.75\n"
    "vt 0 0\n"
    "vt 1 0\n"
    "vt 0 1\n"
    "vt 1 1\n"
    "vt 0.5 0.5\n"
    "vt 0.75 0.75\n"
    "vn 0 0 -1\n"
    "vn 0 -1 0\n"
    "vn -1 0 0\n"
    "vn 1 1 1\n"
    "vn 0 0 -1\n"
    "vn 1 1 1\n"
    "g base\n"
    "usemtl red\n"
    "s off\n"
    "f 1/1/1 3/3/1 5/5/5 # bottom\n"
    "f 1/1/1 5/5/5 2/2/1\n"
    "g sides\n"
    "usemtl blue\n"
    "s 1\n"
    "f 1/1/2 2/2/2 4/4/2\n"
    "f 1/1/3 4/4/3 3/3/3\n"
    "f 2/2/4 5/5/6 6/6/6\n"
    "f 2/2/4 6/6/6 4/4/4\n"
    "f 5/5/6 3/3/4 6/6/6\n"
    "f 6/6/6 3/3/4 4/4/4\n"
    "l 1 4\n"
    "# end\n";

#define PLY_HEADER(nv, nf)                                                                         \
    "ply\n"                                                                                        \
    "format ascii 1.0\n"                                                                           \
    "comment refine fixture\n"                                                                     \
    "element vertex " nv "\n"                                                                      \
    "property float x\n"                                                                           \
    "property float y\n"                                                                           \
    "property float z\n"                                                                           \
    "property float nx\n"                                                                          \
    "property float ny\n"                                                                          \
    "property float nz\n"                                                                          \
    "property uchar red\n"                                                                         \
    "property uchar green\n"                                                                       \
    "property uchar blue\n"                                                                        \
    "property float u\n"                                                                           \
    "property float v\n"                                                                           \
    "property short quality\n"                                                                     \
    "element face " nf "\n"                                                                        \
    "property list uchar int vertex_indices\n"                                                     \
    "property uchar flags\n"                                                                       \
    "property float area\n"                                                                        \
    "element material 1\n"                                                                         \
    "property uchar ambient\n"                                                                     \
    "end_header\n"

static const char tet_ply[] = PLY_HEADER("4", "4")
    "0 0 0 0 0 -1 255 0 0 0 0 -5\n"
    "1 0 0 0 0 -1 0 255 0 1 0 7\n"
    "0 1 0 0 0 -1 0 0 255 0 1 100\n"
    "0 0 1 0 0 1 10 20 31 1 1 -32768\n"
    "3 0 2 1 1 0.5\n"
    "3 0 1 3 2 0.5\n"
    "3 0 3 2 3 0.5\n"
    "3 1 2 3 4 0.866\n"
    "7\n";

static const char tet_ply_refined[] = PLY_HEADER("6", "8")
    "0 0 0 0 0 -1 255 0 0 0 0 -5\n"
    "1 0 0 0 0 -1 0 255 0 1 0 7\n"
    "0 1 0 0 0 -1 0 0 255 0 1 100\n"
    "0 0 1 0 0 1 10 20 31 1 1 -32768\n"
    "0.5 0.5 0 0 0 -1 0 128 128 0.5 0.5 54\n"
    "0.25 0.25 0.5 0 0 0 5 74 79 0.75 0.75 -16357\n"
    "3 0 2 4 1 0.5\n"
    "3 0 4 1 1 0.5\n"
    "3 0 1 3 2 0.5\n"
    "3 0 3 2 3 0.5\n"
    "3 1 4 5 4 0.866\n"
    "3 1 5 3 4 0.866\n"
    "3 4 2 5 4 0.866\n"
    "3 5 2 3 4 0.866\n"
    "7\n";

static const char tet_coff[] = "COFF\n"
                               "# tetra with colours\n"
                               "4 4 6\n"
                               "0 0 0 255 0 0 255\n"
                               "1 0 0 0 255 0 255\n"
                               "0 1 0 0 0 255 255\n"
                               "0 0 1 10 20 31 128 # apex\n"
                               "\n"
                               "3 0 2 1 0.5 0.5 0.5 # bottom\n"
                               "3 0 1 3\n"
                               "3 0 3 2 1 0 0\n"
                               "  3 1 2 3 0 1 0\n";

static const char tet_coff_refined[] = "COFF\n"
                                       "# tetra with colours\n"
                                       "6 8 12\n"
                                       "0 0 0 255 0 0 255\n"
                                       "1 0 0 0 255 0 255\n"
                                       "0 1 0 0 0 255 255\n"
                                       "0 0 1 10 20 31 128 # apex\n"
                                       "0.5 0.5 0 0 128 128 255\n"
                                       "0.25 0.25 0.5 5 74 79 192\n"
                                       "\n"
                                       "3 0 2 4 0.5 0.5 0.5 # bottom\n"
                                       "3 0 4 1 0.5 0.5 0.5\n"
                                       "3 0 1 3\n"
                                       "3 0 3 2 1 0 0\n"
                                       "  3 1 4 5 0 1 0\n"
                                       "  3 1 5 3 0 1 0\n"
                                       "  3 4 2 5 0 1 0\n"
                                       "  3 5 2 3 0 1 0\n";

static const char tet_plain_off[] = "OFF 4 4 0\n"
                              "0 0 0\n"
                              "1 0 0\n"
                              "0 1 0\n"
                              "0 0 1\n"
                              "3 0 2 1\n"
                              "3 0 1 3\n"
                              "3 0 3 2\n"
                              "3 1 2 3";

static const char tet_plain_off_refined[] = "OFF 6 8 0\n"
                                      "0 0 0\n"
                                      "1 0 0\n"
                                      "0 1 0\n"
                                      "0 0 1\n"
                                      "0.5 0.5 0\n"
                                      "0.25 0.25 0.5\n"
                                      "3 0 2 4\n"
                                      "3 0 4 1\n"
                                      "3 0 1 3\n"
                                      "3 0 3 2\n"
                                      "3 1 4 5\n"
                                      "3 1 5 3\n"
                                      "3 4 2 5\n"
                                      "3 5 2 3";

#define FACET(n, a, b, c)                                                                          \
    " facet normal " n "\n  outer loop\n   vertex " a "\n   vertex " b "\n   vertex " c            \
    "\n  endloop\n endfacet\n"

static const char tet_stl[] = "solid tet\n" FACET("0 0 -1", "0 0 0", "0 1 0", "1 0 0")
    FACET("0 -1 0", "0 0 0", "1 0 0", "0 0 1") FACET("-1 0 0", "0 0 0", "0 0 1", "0 1 0")
    "endsolid tet\nsolid second\n" FACET("0.5 0.5 0.5", "1 0 0", "0 1 0", "0 0 1")
    "endsolid second\n";

/* The refined STL: facet 0 and the last facet split in two (the normals of
 * the last facet's children, 1/sqrt(3) each, are filled in at run time). */
static const char tet_stl_refined_fmt[] =
    "solid tet\n" FACET("0 0 -1", "0 0 0", "0 1 0", "0.5 0.5 0")
    FACET("0 0 -1", "0 0 0", "0.5 0.5 0", "1 0 0") FACET("0 -1 0", "0 0 0", "1 0 0", "0 0 1")
    FACET("-1 0 0", "0 0 0", "0 0 1", "0 1 0") "endsolid tet\nsolid second\n"
    FACET("%s %s %s", "1 0 0", "0.5 0.5 0", "0 0 1") FACET("%s %s %s", "0.5 0.5 0", "0 1 0", "0 0 1")
    "endsolid second\n";

/* STL: the 12 unwelded corners; facets 0 and 3 split at the midpoints of
 * their shared edge's two copies (corners 1, 2 and 9, 10). */
static const ffd_refine_vertex stl_new[2] = {{2, {1, 2, 0, 0}, {0.5, 0.5, 0, 0}},
                                             {2, {9, 10, 0, 0}, {0.5, 0.5, 0, 0}}};
static const uint32_t stl_off[7] = {0, 3, 6, 9, 12, 15, 18};
static const uint32_t stl_idx[18] = {0, 1, 12, 0, 12, 2, 3, 4, 5, 6, 7, 8, 9, 13, 11, 13, 10, 11};
static const uint32_t stl_par[6] = {0, 0, 1, 2, 3, 3};
static const ffd_refine_plan stl_plan = {2, stl_new, 6, stl_off, stl_idx, stl_par};

/* ---------------------------------------------------------------------- */

static ffd_mesh *from_mem(const void *data, size_t size, ffd_format f)
{
    ffd_mesh *m = NULL;
    ffd_error err = {{0}};
    if (ffd_mesh_read_memory(data, size, f, "<test>", &m, &err) != FFD_OK)
        fprintf(stderr, "read: %s\n", err.message);
    return m;
}

static unsigned char *bytes_of(const ffd_mesh *m, ffd_format f, ffd_encoding e, size_t *size)
{
    ffd_write_options o = {f, e, 0};
    unsigned char *d = NULL;
    ffd_error err = {{0}};
    *size = 0;
    if (ffd_mesh_write_memory(m, &o, &d, size, &err) != FFD_OK)
        fprintf(stderr, "write: %s\n", err.message);
    return d;
}

static ffd_mesh *refine(const ffd_mesh *m, const ffd_refine_plan *p)
{
    ffd_mesh *out = NULL;
    ffd_error err = {{0}};
    ffd_status s = ffd_mesh_refine(m, p, &out, &err);
    if (s != FFD_OK)
        fprintf(stderr, "refine: %s\n", err.message);
    CHECK(s == FFD_OK && out);
    return out;
}

/* The refined mesh's file equals want (text), and it reads back. */
static void check_text(const ffd_mesh *out, const char *want)
{
    if (!out)
        return;
    size_t size;
    unsigned char *got = bytes_of(out, ffd_mesh_source_format(out), FFD_ENCODING_SAME, &size);
    bool same = got && size == strlen(want) && memcmp(got, want, size) == 0;
    CHECK(same);
    if (!same)
        fprintf(stderr, "--- got:\n%.*s--- want:\n%s---\n", (int)size, got ? (const char *)got : "",
                want);
    ffd_mesh *again = got ? from_mem(got, size, ffd_mesh_source_format(out)) : NULL;
    CHECK(again);
    if (again)
        CHECK(ffd_mesh_vertex_count(again) == ffd_mesh_vertex_count(out) &&
              ffd_mesh_face_count(again) == ffd_mesh_face_count(out));
    ffd_mesh_destroy(again);
    ffd_free(got);
}

static void check_tet_geometry(const ffd_mesh *out)
{
    if (!out)
        return;
    CHECK(ffd_mesh_vertex_count(out) == 6 && ffd_mesh_face_count(out) == 8);
    const double *p = ffd_mesh_positions(out);
    CHECK(p[12] == 0.5 && p[13] == 0.5 && p[14] == 0);
    CHECK(p[15] == 0.25 && p[16] == 0.25 && p[17] == 0.5);
    CHECK(memcmp(ffd_mesh_face_offsets(out), tet_off, sizeof tet_off) == 0);
    CHECK(memcmp(ffd_mesh_face_indices(out), tet_idx, sizeof tet_idx) == 0);
    ffd_mesh_info info;
    CHECK_OK(ffd_mesh_compute_info(out, &info, NULL));
    CHECK(info.closed && info.boundary_edge_count == 0 && info.edge_count == 12);
}

/* A plan that keeps every face as it is. */
static void identity_plan(const ffd_mesh *m, ffd_refine_plan *p, uint32_t **parent)
{
    size_t nf = ffd_mesh_face_count(m);
    *parent = malloc((nf ? nf : 1) * sizeof **parent);
    for (size_t f = 0; f < nf; f++)
        (*parent)[f] = (uint32_t)f;
    p->new_vertex_count = 0;
    p->new_vertices = NULL;
    p->face_count = nf;
    p->face_offsets = ffd_mesh_face_offsets(m);
    p->face_indices = ffd_mesh_face_indices(m);
    p->face_parent = *parent;
}

/* ---------------------------------------------------------------------- */

static void test_obj(void)
{
    ffd_mesh *m = from_mem(tet_obj, strlen(tet_obj), FFD_FORMAT_OBJ);
    CHECK(m);
    if (!m)
        return;
    ffd_mesh *out = refine(m, &tet_plan);
    check_tet_geometry(out);
    check_text(out, tet_obj_refined);
    if (out) {
        ffd_mesh_info info;
        CHECK_OK(ffd_mesh_compute_info(out, &info, NULL));
        CHECK(info.texcoord_count == 6 && info.normal_count == 6);
    }
    ffd_mesh_destroy(out);
    ffd_mesh_destroy(m);
}

static void test_obj_deformed(void)
{
    /* new vertices average the current positions; originals keep theirs */
    ffd_mesh *m = from_mem(tet_obj, strlen(tet_obj), FFD_FORMAT_OBJ);
    CHECK(m);
    if (!m)
        return;
    double p[12];
    memcpy(p, ffd_mesh_positions(m), sizeof p);
    p[3] = 2;   /* vertex 1 to (2, 0, 0) */
    p[11] = 3;  /* vertex 3 to (0, 0, 3) */
    CHECK_OK(ffd_mesh_set_positions(m, p, NULL, NULL));
    ffd_mesh *out = refine(m, &tet_plan);
    if (out) {
        const double *q = ffd_mesh_positions(out);
        CHECK(memcmp(q, p, sizeof p) == 0);
        CHECK(q[12] == 1 && q[13] == 0.5 && q[14] == 0);
        CHECK(q[15] == 0.5 && q[16] == 0.25 && q[17] == 1.5);
        size_t size;
        unsigned char *txt = bytes_of(out, FFD_FORMAT_OBJ, FFD_ENCODING_SAME, &size);
        CHECK(txt && strstr((const char *)txt, "v 2 0 0 0 1 0\n") &&
              strstr((const char *)txt, "v 1 0.5 0 0 0.5 0.5\n"));
        ffd_free(txt);
    }
    ffd_mesh_destroy(out);
    ffd_mesh_destroy(m);
}

static void test_obj_line_ends_and_styles(void)
{
    /* CRLF lines, no final line end, v and v//vn corners, a quad split in
     * four around a centre vertex, a trailing p with a negative index */
    static const char src[] = "v 0 0 0\r\nv 1 0 0\r\nv 1 1 0\r\nv 0 1 0\r\n"
                              "vn 0 0 1\r\n"
                              "f 1//1 2//1 3//1 4//1\r\n"
                              "p -1";
    static const char want[] = "v 0 0 0\r\nv 1 0 0\r\nv 1 1 0\r\nv 0 1 0\r\n"
                               "v 0.5 0 0\r\nv 1 0.5 0\r\nv 0.5 1 0\r\nv 0 0.5 0\r\n"
                               "v 0.5 0.5 0\r\n"
                               "vn 0 0 1\r\n"
                               "vn 0 0 1\r\n"
                               "f 1//1 5//2 9//2 8//2\r\n"
                               "f 5//2 2//1 6//2 9//2\r\n"
                               "f 9//2 6//2 3//1 7//2\r\n"
                               "f 8//2 9//2 7//2 4//1\r\n"
                               "p 4";
    static const ffd_refine_vertex nv[5] = {
        {2, {0, 1, 0, 0}, {0.5, 0.5, 0, 0}}, {2, {1, 2, 0, 0}, {0.5, 0.5, 0, 0}},
        {2, {2, 3, 0, 0}, {0.5, 0.5, 0, 0}}, {2, {3, 0, 0, 0}, {0.5, 0.5, 0, 0}},
        {4, {0, 1, 2, 3}, {0.25, 0.25, 0.25, 0.25}},
    };
    static const uint32_t off[5] = {0, 4, 8, 12, 16};
    static const uint32_t idx[16] = {0, 4, 8, 7, 4, 1, 5, 8, 8, 5, 2, 6, 7, 8, 6, 3};
    static const uint32_t par[4] = {0, 0, 0, 0};
    ffd_refine_plan plan = {5, nv, 4, off, idx, par};
    ffd_mesh *m = from_mem(src, strlen(src), FFD_FORMAT_OBJ);
    CHECK(m);
    ffd_mesh *out = m ? refine(m, &plan) : NULL;
    check_text(out, want);
    ffd_mesh_destroy(out);
    ffd_mesh_destroy(m);
}

static void test_obj_fallbacks(void)
{
    /* a line whose corners do not all have a vt gives children without vt;
     * a new vertex whose parent is not a corner of the parent face takes
     * that vertex's first corner elsewhere (vt 4 of face 1) */
    static const char src[] = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\n"
                              "vt 0 0\nvt 1 0\nvt 0 1\nvt 1 1\n"
                              "f 1/1 2 3/3\n"
                              "f 2/2 4/4 3/3\n";
    static const char want[] = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\n"
                               "v 0.5 0 0\nv 0.5 0.5 0\n"
                               "vt 0 0\nvt 1 0\nvt 0 1\nvt 1 1\n"
                               "vt 0.5 0.5\n"
                               "f 1 5 3\n"
                               "f 5 2 3\n"
                               "f 2/2 4/4 6/5\n"
                               "f 6/5 4/4 3/3\n";
    static const ffd_refine_vertex nv[2] = {{2, {0, 1, 0, 0}, {0.5, 0.5, 0, 0}},
                                            {2, {0, 3, 0, 0}, {0.5, 0.5, 0, 0}}};
    static const uint32_t off[5] = {0, 3, 6, 9, 12};
    static const uint32_t idx[12] = {0, 4, 2, 4, 1, 2, 1, 3, 5, 5, 3, 2};
    static const uint32_t par[4] = {0, 0, 1, 1};
    ffd_refine_plan plan = {2, nv, 4, off, idx, par};
    ffd_mesh *m = from_mem(src, strlen(src), FFD_FORMAT_OBJ);
    CHECK(m);
    ffd_mesh *out = m ? refine(m, &plan) : NULL;
    check_text(out, want);
    ffd_mesh_destroy(out);
    ffd_mesh_destroy(m);
}

static void test_ply_encodings(void)
{
    ffd_mesh *m = from_mem(tet_ply, strlen(tet_ply), FFD_FORMAT_PLY);
    CHECK(m);
    if (!m)
        return;
    ffd_mesh *out = refine(m, &tet_plan);
    check_tet_geometry(out);
    check_text(out, tet_ply_refined);
    if (out) {
        const double *n = ffd_mesh_normals(out);
        CHECK(ffd_mesh_normal_count(out) == 6 && n && n[14] == -1 && n[17] == 0);
    }
    ffd_mesh_destroy(out);
    static const ffd_encoding encs[2] = {FFD_ENCODING_BINARY_LE, FFD_ENCODING_BINARY_BE};
    for (int e = 0; e < 2; e++) {
        size_t bsize;
        unsigned char *bin = bytes_of(m, FFD_FORMAT_PLY, encs[e], &bsize);
        ffd_mesh *mb = bin ? from_mem(bin, bsize, FFD_FORMAT_PLY) : NULL;
        CHECK(mb);
        out = mb ? refine(mb, &tet_plan) : NULL;
        check_tet_geometry(out);
        if (out) {
            /* back to ascii: the same values as the ascii refinement */
            size_t size;
            unsigned char *txt = bytes_of(out, FFD_FORMAT_PLY, FFD_ENCODING_ASCII, &size);
            CHECK(txt && size == strlen(tet_ply_refined) &&
                  memcmp(txt, tet_ply_refined, size) == 0);
            ffd_free(txt);
            /* and the original records are the source's bytes */
            unsigned char *raw = bytes_of(out, FFD_FORMAT_PLY, FFD_ENCODING_SAME, &size);
            const char *hdr_end = strstr((const char *)bin, "end_header\n");
            size_t data = hdr_end ? (size_t)(hdr_end - (const char *)bin) + 11 : 0;
            const char *rhdr = raw ? strstr((const char *)raw, "end_header\n") : NULL;
            size_t rdata = rhdr ? (size_t)(rhdr - (const char *)raw) + 11 : 0;
            size_t rec = 4 * 6 + 3 + 4 * 2 + 2; /* vertex record size */
            CHECK(raw && data && rdata && rdata + 4 * rec <= size &&
                  memcmp(raw + rdata, bin + data, 4 * rec) == 0);
            ffd_free(raw);
        }
        ffd_mesh_destroy(out);
        ffd_mesh_destroy(mb);
        ffd_free(bin);
    }
    ffd_mesh_destroy(m);
}

static void test_ply_vertex_list_and_ranges(void)
{
    /* a list property of the vertex element is taken from the heaviest
     * parent (the first on a tie); CRLF lines; integers rounded */
    static const char src[] = "ply\r\nformat ascii 1.0\r\nelement vertex 4\r\n"
                              "property double x\r\nproperty double y\r\nproperty double z\r\n"
                              "property list uchar ushort tags\r\nproperty int id\r\n"
                              "element face 4\r\nproperty list uchar uint vertex_index\r\n"
                              "end_header\r\n"
                              "0 0 0 1 10 -1\r\n1 0 0 2 20 21 2000000000\r\n0 1 0 0 -2000000000\r\n"
                              "0 0 1 3 30 31 32 4\r\n"
                              "3 0 2 1\r\n3 0 1 3\r\n3 0 3 2\r\n3 1 2 3\r\n";
    static const char want[] = "ply\r\nformat ascii 1.0\r\nelement vertex 6\r\n"
                               "property double x\r\nproperty double y\r\nproperty double z\r\n"
                               "property list uchar ushort tags\r\nproperty int id\r\n"
                               "element face 8\r\nproperty list uchar uint vertex_index\r\n"
                               "end_header\r\n"
                               "0 0 0 1 10 -1\r\n1 0 0 2 20 21 2000000000\r\n0 1 0 0 -2000000000\r\n"
                               "0 0 1 3 30 31 32 4\r\n"
                               "0.5 0.5 0 2 20 21 0\r\n"
                               "0.25 0.25 0.5 3 30 31 32 2\r\n"
                               "3 0 2 4\r\n3 0 4 1\r\n3 0 1 3\r\n3 0 3 2\r\n"
                               "3 1 4 5\r\n3 1 5 3\r\n3 4 2 5\r\n3 5 2 3\r\n";
    ffd_mesh *m = from_mem(src, strlen(src), FFD_FORMAT_PLY);
    CHECK(m);
    ffd_mesh *out = m ? refine(m, &tet_plan) : NULL;
    check_tet_geometry(out);
    check_text(out, want);
    ffd_mesh_destroy(out);
    ffd_mesh_destroy(m);

    /* an index that does not fit the file's index type: FFD_ERR_RANGE */
    char big[8192];
    size_t n = (size_t)snprintf(big, sizeof big,
                                "ply\nformat ascii 1.0\nelement vertex 128\nproperty float x\n"
                                "property float y\nproperty float z\nelement face 1\n"
                                "property list uchar char vertex_indices\nend_header\n");
    for (int i = 0; i < 128; i++)
        n += (size_t)snprintf(big + n, sizeof big - n, "%d 0 %d\n", i % 2, i / 2);
    n += (size_t)snprintf(big + n, sizeof big - n, "3 0 1 127\n");
    m = from_mem(big, n, FFD_FORMAT_PLY);
    CHECK(m);
    static const ffd_refine_vertex nv[1] = {{2, {0, 1, 0, 0}, {0.5, 0.5, 0, 0}}};
    static const uint32_t off[3] = {0, 3, 6};
    static const uint32_t idx[6] = {0, 128, 127, 128, 1, 127};
    static const uint32_t par[2] = {0, 0};
    ffd_refine_plan plan = {1, nv, 2, off, idx, par};
    out = (ffd_mesh *)&out;
    ffd_error err = {{0}};
    CHECK(m && ffd_mesh_refine(m, &plan, &out, &err) == FFD_ERR_RANGE && out == NULL);
    ffd_mesh_destroy(m);
}

static void test_off(void)
{
    ffd_mesh *m = from_mem(tet_coff, strlen(tet_coff), FFD_FORMAT_OFF);
    CHECK(m);
    ffd_mesh *out = m ? refine(m, &tet_plan) : NULL;
    check_tet_geometry(out);
    check_text(out, tet_coff_refined);
    ffd_mesh_destroy(out);
    ffd_mesh_destroy(m);

    m = from_mem(tet_plain_off, strlen(tet_plain_off), FFD_FORMAT_OFF);
    CHECK(m);
    out = m ? refine(m, &tet_plan) : NULL;
    check_tet_geometry(out);
    check_text(out, tet_plain_off_refined);
    ffd_mesh_destroy(out);
    ffd_mesh_destroy(m);
}

static void test_noff_normals(void)
{
    /* normals.off: a square of two triangles, normals 0 0 1; split the diagonal */
    ffd_mesh *m = NULL;
    CHECK_OK(ffd_mesh_read(FIX "normals.off", &m, NULL));
    if (!m)
        return;
    static const ffd_refine_vertex nv[1] = {{2, {0, 2, 0, 0}, {0.5, 0.5, 0, 0}}};
    static const uint32_t off[5] = {0, 3, 6, 9, 12};
    static const uint32_t idx[12] = {0, 1, 4, 4, 1, 2, 0, 4, 3, 4, 2, 3};
    static const uint32_t par[4] = {0, 0, 1, 1};
    ffd_refine_plan plan = {1, nv, 4, off, idx, par};
    ffd_mesh *out = refine(m, &plan);
    check_text(out, "NOFF\n5 4 0\n0 0 0 0 0 1\n1 0 0 0 0 1\n1 1 0 0 0 1\n0 1 0 0 0 1\n"
                    "0.5 0.5 0 0 0 1\n3 0 1 4\n3 4 1 2\n3 0 4 3\n3 4 2 3\n");
    if (out) {
        CHECK(ffd_mesh_normal_count(out) == 5);
        CHECK(ffd_mesh_normals(out)[14] == 1);
    }
    ffd_mesh_destroy(out);
    ffd_mesh_destroy(m);
}

static void test_stl_ascii(void)
{
    ffd_mesh *m = from_mem(tet_stl, strlen(tet_stl), FFD_FORMAT_STL);
    CHECK(m);
    ffd_mesh *out = m ? refine(m, &stl_plan) : NULL;
    double d[3] = {0.5, 0.5, 0}, n[3];
    ffd_triangle_normal(tet_pos + 3, d, tet_pos + 9, n); /* (1 0 0) (.5 .5 0) (0 0 1) */
    char s[32], want[2048];
    ffd_format_double(s, n[0]);
    CHECK(n[0] == n[1] && n[1] == n[2]);
    snprintf(want, sizeof want, tet_stl_refined_fmt, s, s, s, s, s, s);
    check_text(out, want);
    if (out) {
        CHECK(ffd_mesh_vertex_count(out) == 18 && ffd_mesh_face_count(out) == 6);
        ffd_mesh_info info;
        CHECK_OK(ffd_mesh_compute_info(out, &info, NULL));
        CHECK(info.closed);
    }
    ffd_mesh_destroy(out);
    ffd_mesh_destroy(m);
}

static void test_stl_binary(void)
{
    ffd_mesh *a = from_mem(tet_stl, strlen(tet_stl), FFD_FORMAT_STL);
    size_t size = 0;
    unsigned char *bin = a ? bytes_of(a, FFD_FORMAT_STL, FFD_ENCODING_BINARY_LE, &size) : NULL;
    ffd_mesh_destroy(a);
    CHECK(bin && size == 84 + 4 * 50);
    if (!bin)
        return;
    for (int f = 0; f < 4; f++) { /* attribute bytes to carry over */
        bin[84 + 50 * f + 48] = (unsigned char)(0x10 + f);
        bin[84 + 50 * f + 49] = 0xab;
    }
    ffd_mesh *m = from_mem(bin, size, FFD_FORMAT_STL);
    CHECK(m);
    ffd_mesh *out = m ? refine(m, &stl_plan) : NULL;
    if (out) {
        size_t osize;
        unsigned char *o = bytes_of(out, FFD_FORMAT_STL, FFD_ENCODING_SAME, &osize);
        CHECK(o && osize == 84 + 6 * 50);
        if (o && osize == 84 + 6 * 50) {
            CHECK(memcmp(o, bin, 80) == 0);
            CHECK(ffd_read_scalar(o + 80, FFD_SPAN_U32, false) == 6);
            /* children: computed normal, parent's attribute bytes */
            for (int c = 0; c < 2; c++) {
                const unsigned char *r = o + 84 + 50 * c;
                CHECK(ffd_read_scalar(r, FFD_SPAN_F32, false) == 0);
                CHECK(ffd_read_scalar(r + 8, FFD_SPAN_F32, false) == -1);
                CHECK(r[48] == 0x10 && r[49] == 0xab);
                r = o + 84 + 200 + 50 * c;
                CHECK_NEAR(ffd_read_scalar(r, FFD_SPAN_F32, false), sqrt(1.0 / 3), 1e-7);
                CHECK(r[48] == 0x13 && r[49] == 0xab);
            }
            const unsigned char *r = o + 84;
            CHECK(ffd_read_scalar(r + 36, FFD_SPAN_F32, false) == 0.5 &&
                  ffd_read_scalar(r + 40, FFD_SPAN_F32, false) == 0.5);
            /* unchanged facets: the source's bytes */
            CHECK(memcmp(o + 84 + 100, bin + 84 + 50, 100) == 0);
        }
        ffd_free(o);
        ffd_mesh_info info;
        CHECK_OK(ffd_mesh_compute_info(out, &info, NULL));
        CHECK(info.closed && ffd_mesh_face_count(out) == 6);
    }
    ffd_mesh_destroy(out);
    ffd_mesh_destroy(m);
    ffd_free(bin);
}


static void test_created(void)
{
    ffd_mesh *m = NULL;
    CHECK_OK(ffd_mesh_create(tet_pos, 4, tet_src_off, tet_src_idx, 4, &m, NULL));
    ffd_mesh *out = m ? refine(m, &tet_plan) : NULL;
    check_tet_geometry(out);
    if (out)
        CHECK(ffd_mesh_source_format(out) == FFD_FORMAT_AUTO);
    ffd_mesh_destroy(out);
    ffd_mesh_destroy(m);
}

/* ---------------------------------------------------------------------- */

static void check_identity(ffd_mesh *m, const unsigned char *src, size_t size, const char *name)
{
    ffd_refine_plan p;
    uint32_t *parent;
    identity_plan(m, &p, &parent);
    ffd_mesh *out = refine(m, &p);
    if (out) {
        size_t osize;
        unsigned char *o = bytes_of(out, ffd_mesh_source_format(out), FFD_ENCODING_SAME, &osize);
        bool same = o && osize == size && memcmp(o, src, size) == 0;
        CHECK(same);
        if (!same)
            fprintf(stderr, "  identity refinement differs: %s\n", name);
        ffd_free(o);
    }
    ffd_mesh_destroy(out);
    free(parent);
}

static void test_identity_byte_for_byte(void)
{
    static const char *const files[] = {
        FIX "all_forms.obj", FIX "cube_ascii.ply", FIX "cube_ble.ply", FIX "cube_bbe.ply",
        FIX "comments.off",  FIX "normals.off",    FIX "tri_ascii.stl", FIX "tri_binary.stl",
        SHARED "bunny.obj",  SHARED "teapot.obj",  SHARED "hinge.stl",  SHARED "cow.off",
        SHARED "double-torus-example.off",
    };
    for (size_t i = 0; i < sizeof files / sizeof *files; i++) {
        unsigned char *src = NULL;
        size_t size = 0;
        ffd_mesh *m = NULL;
        CHECK_OK(ffd_read_file(files[i], &src, &size, NULL));
        CHECK_OK(ffd_mesh_read(files[i], &m, NULL));
        if (!src || !m)
            fprintf(stderr, "%s: cannot read the test mesh %s\n", check_current, files[i]);
        if (src && m)
            check_identity(m, src, size, files[i]);
        ffd_mesh_destroy(m);
        ffd_free(src);
    }
    static const struct {
        const char *text;
        ffd_format f;
    } mem[] = {{tet_obj, FFD_FORMAT_OBJ}, {tet_ply, FFD_FORMAT_PLY}, {tet_coff, FFD_FORMAT_OFF},
               {tet_plain_off, FFD_FORMAT_OFF}, {tet_stl, FFD_FORMAT_STL}};
    for (size_t i = 0; i < sizeof mem / sizeof *mem; i++) {
        ffd_mesh *m = from_mem(mem[i].text, strlen(mem[i].text), mem[i].f);
        CHECK(m);
        if (m)
            check_identity(m, (const unsigned char *)mem[i].text, strlen(mem[i].text), "tet");
        ffd_mesh_destroy(m);
    }
}

static void test_bad_plans(void)
{
    ffd_mesh *m = from_mem(tet_obj, strlen(tet_obj), FFD_FORMAT_OBJ);
    ffd_mesh *stl = from_mem(tet_stl, strlen(tet_stl), FFD_FORMAT_STL);
    CHECK(m && stl);
    if (!m || !stl) {
        ffd_mesh_destroy(m);
        ffd_mesh_destroy(stl);
        return;
    }
    for (int t = 0;; t++) {
        ffd_refine_vertex nv[2];
        uint32_t off[9], idx[24], par[8];
        memcpy(nv, tet_new, sizeof nv);
        memcpy(off, tet_off, sizeof off);
        memcpy(idx, tet_idx, sizeof idx);
        memcpy(par, tet_par, sizeof par);
        ffd_refine_plan p = {2, nv, 8, off, idx, par};
        const ffd_mesh *target = m;
        switch (t) {
        case 0: nv[0].parent_count = 0; break;
        case 1: nv[1].parent_count = 5; break;
        case 2: nv[0].parent[1] = 4; break;             /* itself */
        case 3: nv[0].parent[0] = 5; break;             /* a later vertex */
        case 4: nv[1].weight[0] = NAN; break;
        case 5: nv[1].weight[0] = 0.4; break;           /* sum 0.9 */
        case 6: nv[0].weight[0] = 0.5 + 1e-8; break;    /* sum off by 1e-8 */
        case 7: idx[5] = 6; break;                       /* out of range */
        case 8: off[1] = 2; break;                       /* a 2-gon */
        case 9: par[3] = 1; break;                       /* face 2 uncovered */
        case 10: par[1] = 1; par[2] = 0; break;          /* decreasing */
        case 11: p.face_count = 7; break;                /* face 3's last children gone: ok? */
        case 12: par[7] = 4; break;                      /* parent out of range */
        case 13: off[0] = 1; break;
        case 14: p.face_count = 0; break;
        case 15: p.new_vertices = NULL; break;
        case 16: p.face_parent = NULL; break;
        case 17: par[0] = 1; par[1] = 1; break;          /* face 0 uncovered */
        case 18: p.face_count = 2; break;                /* faces 2, 3 uncovered */
        case 19: target = stl; break;                    /* faces do not match STL... */
        default: break;
        }
        if (t > 19)
            break;
        if (t == 19) {
            /* a quad in an STL plan */
            static const uint32_t qoff[5] = {0, 4, 7, 10, 13};
            static const uint32_t qidx[13] = {0, 1, 2, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11};
            static const uint32_t qpar[4] = {0, 1, 2, 3};
            p = (ffd_refine_plan){0, NULL, 4, qoff, qidx, qpar};
        }
        ffd_mesh *out = (ffd_mesh *)&out; /* must be reset to NULL */
        ffd_error err = {{0}};
        ffd_status s = ffd_mesh_refine(target, &p, &out, &err);
        if (t == 11) {
            /* dropping the last children of face 3 still covers it: valid */
            CHECK(s == FFD_OK && out && ffd_mesh_face_count(out) == 7);
            ffd_mesh_destroy(out);
            continue;
        }
        if (s != FFD_ERR_INVALID)
            fprintf(stderr, "  bad plan %d: status %d (%s)\n", t, (int)s, err.message);
        CHECK(s == FFD_ERR_INVALID && out == NULL && err.message[0]);
    }
    ffd_mesh *out = NULL;
    CHECK(ffd_mesh_refine(NULL, &tet_plan, &out, NULL) == FFD_ERR_INVALID && !out);
    CHECK(ffd_mesh_refine(m, NULL, &out, NULL) == FFD_ERR_INVALID && !out);
    CHECK(ffd_mesh_refine(m, &tet_plan, NULL, NULL) == FFD_ERR_INVALID);
    ffd_mesh_destroy(m);
    ffd_mesh_destroy(stl);
}

static void test_chained_weights(void)
{
    /* a chain of new vertices flattens onto the originals (duplicates merged) */
    ffd_mesh *m = NULL;
    CHECK_OK(ffd_mesh_create(tet_pos, 4, tet_src_off, tet_src_idx, 4, &m, NULL));
    if (!m)
        return;
    ffd_refine_vertex nv[6];
    nv[0] = (ffd_refine_vertex){2, {1, 2, 0, 0}, {0.5, 0.5, 0, 0}};
    for (uint32_t j = 1; j < 6; j++)
        nv[j] = (ffd_refine_vertex){3, {3 + j, 1, 1, 0}, {0.5, 0.25, 0.25, 0}};
    ffd_refine_plan p;
    uint32_t *parent;
    identity_plan(m, &p, &parent);
    p.new_vertex_count = 6;
    p.new_vertices = nv;
    ffd_mesh *out = refine(m, &p);
    if (out) {
        const double *q = ffd_mesh_positions(out);
        double x = 0.5, y = 0.5; /* vertex 4 */
        for (int j = 1; j < 6; j++) {
            x = 0.5 * x + 0.5;
            y = 0.5 * y;
        }
        CHECK_NEAR(q[3 * 9], x, 1e-15);
        CHECK_NEAR(q[3 * 9 + 1], y, 1e-15);
    }
    ffd_mesh_destroy(out);
    free(parent);
    ffd_mesh_destroy(m);
}

static void test_random_weights(void)
{
    /* random chains of new vertices: positions equal the plan's recursive
     * weighted averages */
    ffd_mesh *m = NULL;
    CHECK_OK(ffd_mesh_create(tet_pos, 4, tet_src_off, tet_src_idx, 4, &m, NULL));
    if (!m)
        return;
    enum { N = 40 };
    ffd_refine_vertex nv[N];
    double want[3 * (4 + N)];
    memcpy(want, tet_pos, sizeof tet_pos);
    for (uint32_t j = 0; j < N; j++) {
        ffd_refine_vertex *r = &nv[j];
        r->parent_count = 1 + (uint32_t)(check_rand01() * 4) % 4;
        double sum = 0;
        for (uint32_t k = 0; k < r->parent_count; k++) {
            r->parent[k] = (uint32_t)(check_rand01() * (4 + j)) % (4 + j);
            r->weight[k] = 0.1 + check_rand01();
            sum += r->weight[k];
        }
        for (uint32_t k = 0; k < r->parent_count; k++)
            r->weight[k] /= sum;
        double s = 0;
        for (uint32_t k = 0; k + 1 < r->parent_count; k++)
            s += r->weight[k];
        r->weight[r->parent_count - 1] = 1 - s;
        for (int d = 0; d < 3; d++) {
            double v = 0;
            for (uint32_t k = 0; k < r->parent_count; k++)
                v += r->weight[k] * want[3 * r->parent[k] + (uint32_t)d];
            want[3 * (4 + j) + (uint32_t)d] = v;
        }
    }
    ffd_refine_plan p;
    uint32_t *parent;
    identity_plan(m, &p, &parent);
    p.new_vertex_count = N;
    p.new_vertices = nv;
    ffd_mesh *out = refine(m, &p);
    if (out)
        for (size_t i = 0; i < 3 * (4 + N); i++)
            CHECK_NEAR(ffd_mesh_positions(out)[i], want[i], 1e-14);
    ffd_mesh_destroy(out);
    free(parent);
    ffd_mesh_destroy(m);
}

/* ---------------------------------------------------------------------- */

static void test_failing_allocations(void)
{
    static const struct {
        const char *text;
        ffd_format f;
        ffd_encoding e; /* re-encoded first when not ascii */
        int stl;
    } cases[] = {
        {tet_obj, FFD_FORMAT_OBJ, FFD_ENCODING_ASCII, 0},
        {tet_ply, FFD_FORMAT_PLY, FFD_ENCODING_ASCII, 0},
        {tet_ply, FFD_FORMAT_PLY, FFD_ENCODING_BINARY_BE, 0},
        {tet_coff, FFD_FORMAT_OFF, FFD_ENCODING_ASCII, 0},
        {tet_stl, FFD_FORMAT_STL, FFD_ENCODING_ASCII, 1},
        {tet_stl, FFD_FORMAT_STL, FFD_ENCODING_BINARY_LE, 1},
        {NULL, FFD_FORMAT_AUTO, FFD_ENCODING_ASCII, 0},
    };
    for (size_t i = 0; i < sizeof cases / sizeof *cases; i++) {
        ffd_mesh *m = NULL;
        if (cases[i].text) {
            m = from_mem(cases[i].text, strlen(cases[i].text), cases[i].f);
            if (m && cases[i].e != FFD_ENCODING_ASCII) {
                size_t size;
                unsigned char *bin = bytes_of(m, cases[i].f, cases[i].e, &size);
                ffd_mesh_destroy(m);
                m = bin ? from_mem(bin, size, cases[i].f) : NULL;
                ffd_free(bin);
            }
        } else {
            CHECK_OK(ffd_mesh_create(tet_pos, 4, tet_src_off, tet_src_idx, 4, &m, NULL));
        }
        CHECK(m);
        if (!m)
            continue;
        const ffd_refine_plan *plan = cases[i].stl ? &stl_plan : &tet_plan;
        long k;
        for (k = 0;; k += check_sweep_step()) {
            fail_alloc fa = {k, 0};
            ffd_allocator a = {fa_malloc, fa_realloc, fa_free, &fa};
            ffd_set_allocator(&a);
            ffd_mesh *out = (ffd_mesh *)&out;
            ffd_error err = {{0}};
            ffd_status s = ffd_mesh_refine(m, plan, &out, &err);
            ffd_mesh_destroy(s == FFD_OK ? out : NULL);
            ffd_set_allocator(NULL);
            CHECK(s == FFD_OK || (s == FFD_ERR_NOMEM && out == NULL));
            if (s != FFD_OK && s != FFD_ERR_NOMEM)
                fprintf(stderr, "  case %zu, allocation %ld: %s\n", i, k, err.message);
            if (s != FFD_ERR_NOMEM)
                break;
            if (k > 100000) {
                CHECK(!"allocation sweep did not finish");
                break;
            }
        }
        CHECK(k > 0); /* refinement allocates */
        ffd_mesh_destroy(m);
    }
}

/* ---------------------------------------------------------------------- */
/* Red/green refinement of the bunny: every edge of the first 10 faces split
 * at its midpoint, those faces in four, their neighbours in two or three. */

typedef struct {
    uint32_t a, b, mid;
} split_edge;

static uint32_t find_split(const split_edge *e, size_t n, uint32_t a, uint32_t b)
{
    if (a > b) {
        uint32_t t = a;
        a = b;
        b = t;
    }
    for (size_t i = 0; i < n; i++)
        if (e[i].a == a && e[i].b == b)
            return e[i].mid;
    return UINT32_MAX;
}

static void test_bunny_red_green(void)
{
    ffd_mesh *m = NULL;
    CHECK_OK(ffd_mesh_read(SHARED "bunny.obj", &m, NULL));
    if (!m)
        return;
    size_t nv = ffd_mesh_vertex_count(m), nf = ffd_mesh_face_count(m);
    const uint32_t *fo = ffd_mesh_face_offsets(m), *fi = ffd_mesh_face_indices(m);
    split_edge edges[30];
    ffd_refine_vertex nvx[30];
    size_t ne = 0;
    for (size_t f = 0; f < 10; f++)
        for (int k = 0; k < 3; k++) {
            uint32_t a = fi[fo[f] + (uint32_t)k], b = fi[fo[f] + (uint32_t)(k + 1) % 3];
            if (find_split(edges, ne, a, b) != UINT32_MAX)
                continue;
            edges[ne] = (split_edge){a < b ? a : b, a < b ? b : a, (uint32_t)(nv + ne)};
            nvx[ne] = (ffd_refine_vertex){2, {a, b, 0, 0}, {0.5, 0.5, 0, 0}};
            ne++;
        }
    uint32_t *off = malloc((4 * nf + 1) * sizeof *off);
    uint32_t *idx = malloc(12 * nf * sizeof *idx);
    uint32_t *par = malloc(4 * nf * sizeof *par);
    size_t nfo = 0, ni = 0, counts[4] = {0, 0, 0, 0};
    off[0] = 0;
#define TRI(x, y, z)                                                                               \
    do {                                                                                           \
        idx[ni++] = (x);                                                                           \
        idx[ni++] = (y);                                                                           \
        idx[ni++] = (z);                                                                           \
        par[nfo] = (uint32_t)f;                                                                    \
        off[++nfo] = (uint32_t)ni;                                                                 \
    } while (0)
    for (size_t f = 0; f < nf; f++) {
        const uint32_t *v = fi + fo[f];
        uint32_t mid[3];
        int n = 0, first = -1;
        for (int k = 0; k < 3; k++) {
            mid[k] = find_split(edges, ne, v[k], v[(k + 1) % 3]);
            if (mid[k] != UINT32_MAX) {
                n++;
                if (first < 0)
                    first = k;
            }
        }
        counts[n]++;
        if (n == 0) {
            TRI(v[0], v[1], v[2]);
        } else if (n == 1) {
            int k = first; /* edge v[k] v[k+1] split, opposite corner v[k+2] */
            uint32_t a = v[k], b = v[(k + 1) % 3], c = v[(k + 2) % 3];
            TRI(a, mid[k], c);
            TRI(mid[k], b, c);
        } else if (n == 2) {
            int k = 0; /* rotate so that edges k and k+1 are split */
            while (!(mid[k] != UINT32_MAX && mid[(k + 1) % 3] != UINT32_MAX))
                k++;
            uint32_t a = v[k], b = v[(k + 1) % 3], c = v[(k + 2) % 3];
            uint32_t m1 = mid[k], m2 = mid[(k + 1) % 3];
            TRI(m1, b, m2);
            TRI(a, m1, m2);
            TRI(a, m2, c);
        } else {
            uint32_t a = v[0], b = v[1], c = v[2];
            TRI(a, mid[0], mid[2]);
            TRI(mid[0], b, mid[1]);
            TRI(mid[2], mid[1], c);
            TRI(mid[0], mid[1], mid[2]);
        }
    }
#undef TRI
    CHECK(counts[3] >= 10 && counts[1] + counts[2] > 0);
    ffd_refine_plan plan = {ne, nvx, nfo, off, idx, par};
    ffd_mesh *out = refine(m, &plan);
    if (out) {
        CHECK(ffd_mesh_vertex_count(out) == nv + ne);
        CHECK(ffd_mesh_face_count(out) == nfo);
        CHECK(ffd_mesh_face_count(out) == nf + counts[1] + 2 * counts[2] + 3 * counts[3]);
        ffd_mesh_info info;
        CHECK_OK(ffd_mesh_compute_info(out, &info, NULL));
        CHECK(info.boundary_edge_count == 0 && info.closed && info.nonmanifold_edge_count == 0);
        const double *p = ffd_mesh_positions(m), *q = ffd_mesh_positions(out);
        CHECK(memcmp(p, q, 3 * sizeof(double) * nv) == 0);
        for (size_t e = 0; e < ne; e++)
            for (int d = 0; d < 3; d++)
                CHECK_NEAR(q[3 * (nv + e) + (size_t)d],
                           0.5 * p[3 * edges[e].a + (size_t)d] + 0.5 * p[3 * edges[e].b + (size_t)d],
                           1e-15);
        /* the header comments are kept */
        size_t size;
        unsigned char *txt = bytes_of(out, FFD_FORMAT_OBJ, FFD_ENCODING_SAME, &size);
        CHECK(txt && strncmp((const char *)txt, "# Stanford bunny", 16) == 0);
        ffd_free(txt);
    }
    ffd_mesh_destroy(out);
    free(off);
    free(idx);
    free(par);
    ffd_mesh_destroy(m);
}

/* A UTF-8 byte order mark before the first line is read past and kept: the
 * refined file is the mark followed by the refined file without it (GFFD
 * resampling writes through here, issue 14). */
static void test_utf8_bom(void)
{
    static const struct {
        const char *src, *want;
        ffd_format format;
    } cases[] = {
        {tet_obj, tet_obj_refined, FFD_FORMAT_OBJ},
        {tet_ply, tet_ply_refined, FFD_FORMAT_PLY},
        {tet_coff, tet_coff_refined, FFD_FORMAT_OFF},
        {tet_plain_off, tet_plain_off_refined, FFD_FORMAT_OFF},
    };
    for (size_t i = 0; i < sizeof cases / sizeof *cases; i++) {
        char src[4096], want[4096];
        snprintf(src, sizeof src, "\xEF\xBB\xBF%s", cases[i].src);
        snprintf(want, sizeof want, "\xEF\xBB\xBF%s", cases[i].want);
        ffd_mesh *m = from_mem(src, strlen(src), cases[i].format);
        CHECK(m);
        ffd_mesh *out = m ? refine(m, &tet_plan) : NULL;
        CHECK(out);
        check_tet_geometry(out);
        check_text(out, want);
        ffd_mesh_destroy(out);
        ffd_mesh_destroy(m);
    }
    /* the mark straight before a 'v' line (the line the OBJ reader lost) */
    char src[4096], want[4096];
    snprintf(src, sizeof src, "\xEF\xBB\xBF%s", strstr(tet_obj, "\nv ") + 1);
    snprintf(want, sizeof want, "\xEF\xBB\xBF%s", strstr(tet_obj_refined, "\nv ") + 1);
    ffd_mesh *m = from_mem(src, strlen(src), FFD_FORMAT_OBJ);
    CHECK(m);
    ffd_mesh *out = m ? refine(m, &tet_plan) : NULL;
    CHECK(out);
    check_tet_geometry(out);
    check_text(out, want);
    ffd_mesh_destroy(out);
    ffd_mesh_destroy(m);
}

int main(int argc, char **argv)
{
    static const check_test tests[] = {
        {"obj", test_obj},
        {"obj_deformed", test_obj_deformed},
        {"obj_line_ends_and_styles", test_obj_line_ends_and_styles},
        {"obj_fallbacks", test_obj_fallbacks},
        {"ply_encodings", test_ply_encodings},
        {"ply_vertex_list_and_ranges", test_ply_vertex_list_and_ranges},
        {"off", test_off},
        {"noff_normals", test_noff_normals},
        {"stl_ascii", test_stl_ascii},
        {"stl_binary", test_stl_binary},
        {"created", test_created},
        {"identity_byte_for_byte", test_identity_byte_for_byte},
        {"bad_plans", test_bad_plans},
        {"chained_weights", test_chained_weights},
        {"random_weights", test_random_weights},
        {"failing_allocations", test_failing_allocations},
        {"bunny_red_green", test_bunny_red_green},
        {"utf8_bom", test_utf8_bom},
    };
    return check_run(tests, sizeof tests / sizeof *tests, argc, argv);
}
