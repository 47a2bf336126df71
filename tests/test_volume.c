/* Volume-mesh core: cell types, boundary extraction (outward, shared faces
 * dropped), 2D cells as faces, refused cells, copies keep the cells. The
 * codecs have their own tests (test_volume_<format>.c). */
#include "check.h"

#include <stdbool.h>

#include <ffd.h>

#include "check_cells.h"
#include "check_volume.h"

static void test_single_cells_outward(void)
{
    for (size_t r = 0; r < sizeof refs / sizeof refs[0]; r++) {
        uint32_t ids[8] = {0, 1, 2, 3, 4, 5, 6, 7};
        uint64_t off[2] = {0, refs[r].n};
        ffd_mesh *m = NULL;
        CHECK_OK(ffd_mesh_create_cells(&refs[r].p[0][0], refs[r].n, &refs[r].type, off, ids, 1, &m,
                                       NULL));
        if (!m)
            continue;
        CHECK(ffd_mesh_is_volume(m));
        CHECK(ffd_cell_type_dimension(refs[r].type) == 3);
        CHECK_NEAR(enclosed_volume(m), refs[r].volume, 1e-15);
        ffd_mesh_destroy(m);
    }
}

/* An n^3 grid of hexahedra: 6 n^2 boundary quads, interior faces dropped,
 * enclosed volume 1; split into 5 tetrahedra per cube it is closed too. */
static ffd_mesh *grid(int n, bool tets)
{
    size_t np = (size_t)(n + 1) * (n + 1) * (n + 1);
    double *p = malloc(3 * np * sizeof(double));
    for (int k = 0, i = 0; k <= n; k++)
        for (int j = 0; j <= n; j++)
            for (int a = 0; a <= n; a++, i++) {
                p[3 * i] = (double)a / n;
                p[3 * i + 1] = (double)j / n;
                p[3 * i + 2] = (double)k / n;
            }
    size_t nc = (size_t)n * n * n * (tets ? 5 : 1);
    uint8_t *types = malloc(nc);
    uint64_t *off = malloc((nc + 1) * sizeof(uint64_t));
    uint32_t *ix = malloc(nc * 8 * sizeof(uint32_t));
    size_t c = 0, at = 0;
    off[0] = 0;
#define ID(a, j, k) (uint32_t)((a) + (n + 1) * ((j) + (n + 1) * (k)))
    for (int k = 0; k < n; k++)
        for (int j = 0; j < n; j++)
            for (int a = 0; a < n; a++) {
                uint32_t h[8] = {ID(a, j, k),         ID(a + 1, j, k),     ID(a + 1, j + 1, k),
                                 ID(a, j + 1, k),     ID(a, j, k + 1),     ID(a + 1, j, k + 1),
                                 ID(a + 1, j + 1, k + 1), ID(a, j + 1, k + 1)};
                if (!tets) {
                    memcpy(ix + at, h, sizeof h);
                    at += 8;
                    types[c] = FFD_CELL_HEXAHEDRON;
                    off[++c] = at;
                    continue;
                }
                /* five tetrahedra, mirrored on alternate cubes so faces match */
                static const int even[5][4] = {{0, 1, 3, 4}, {1, 2, 3, 6}, {1, 4, 5, 6},
                                               {3, 6, 7, 4}, {1, 3, 4, 6}};
                static const int odd[5][4] = {{0, 1, 2, 5}, {0, 2, 3, 7}, {0, 5, 7, 4},
                                              {2, 7, 5, 6}, {0, 2, 7, 5}};
                const int(*t)[4] = (a + j + k) % 2 ? odd : even;
                for (int q = 0; q < 5; q++) {
                    uint32_t v[4] = {h[t[q][0]], h[t[q][1]], h[t[q][2]], h[t[q][3]]};
                    /* orient positively */
                    const double *A = p + 3 * v[0], *B = p + 3 * v[1], *C = p + 3 * v[2],
                                 *D = p + 3 * v[3];
                    double u[3] = {B[0] - A[0], B[1] - A[1], B[2] - A[2]};
                    double w[3] = {C[0] - A[0], C[1] - A[1], C[2] - A[2]};
                    double z[3] = {D[0] - A[0], D[1] - A[1], D[2] - A[2]};
                    double det = u[0] * (w[1] * z[2] - w[2] * z[1]) -
                                 u[1] * (w[0] * z[2] - w[2] * z[0]) +
                                 u[2] * (w[0] * z[1] - w[1] * z[0]);
                    if (det < 0) {
                        uint32_t x = v[1];
                        v[1] = v[2];
                        v[2] = x;
                    }
                    memcpy(ix + at, v, sizeof v);
                    at += 4;
                    types[c] = FFD_CELL_TETRA;
                    off[++c] = at;
                }
            }
#undef ID
    ffd_mesh *m = NULL;
    CHECK_OK(ffd_mesh_create_cells(p, np, types, off, ix, nc, &m, NULL));
    free(p);
    free(types);
    free(off);
    free(ix);
    return m;
}

static void test_grid_boundary(void)
{
    for (int t = 0; t < 2; t++) {
        ffd_mesh *m = grid(4, t);
        if (!m)
            continue;
        CHECK(ffd_mesh_face_count(m) == (size_t)(t ? 2 : 1) * 6 * 16);
        CHECK_NEAR(enclosed_volume(m), 1.0, 1e-13);
        const uint32_t *fc = ffd_mesh_face_cells(m);
        CHECK(fc != NULL);
        for (size_t f = 0; fc && f < ffd_mesh_face_count(m); f++)
            CHECK(fc[f] < ffd_mesh_cell_count(m));
        ffd_mesh_info info;
        CHECK_OK(ffd_mesh_compute_info(m, &info, NULL));
        CHECK(info.closed == 1);
        CHECK(info.nonmanifold_edge_count == 0);
        ffd_mesh_destroy(m);
    }
}

/* Without 3D cells the 2D cells are the faces; lines and vertices are not. */
static void test_surface_cells(void)
{
    double p[5][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {2, 0, 0}};
    uint8_t types[4] = {FFD_CELL_QUAD, FFD_CELL_TRIANGLE, FFD_CELL_LINE, FFD_CELL_TRIANGLE_STRIP};
    uint32_t ix[] = {0, 1, 2, 3, 1, 4, 2, 0, 4, 0, 1, 3, 2};
    uint64_t off[5] = {0, 4, 7, 9, 13};
    ffd_mesh *m = NULL;
    CHECK_OK(ffd_mesh_create_cells(&p[0][0], 5, types, off, ix, 4, &m, NULL));
    if (!m)
        return;
    CHECK(!ffd_mesh_is_volume(m));
    CHECK(ffd_mesh_face_count(m) == 4); /* quad, triangle, the strip's two triangles */
    const uint32_t *fo = ffd_mesh_face_offsets(m), *fi = ffd_mesh_face_indices(m);
    CHECK(fo[1] == 4 && fo[2] == 7);
    /* the strip 0 1 3 2: triangles (0 1 3) and (3 1 2): every other one reversed */
    CHECK(fi[7] == 0 && fi[8] == 1 && fi[9] == 3);
    CHECK(fi[10] == 3 && fi[11] == 1 && fi[12] == 2);
    ffd_mesh_destroy(m);
}

static void test_bad_cells(void)
{
    double p[4][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    uint32_t ix[4] = {0, 1, 2, 7};
    uint64_t off[2] = {0, 4};
    uint8_t tet = FFD_CELL_TETRA, poly = 42;
    ffd_mesh *m = NULL;
    ffd_error err = {{0}};
    CHECK(ffd_mesh_create_cells(&p[0][0], 4, &tet, off, ix, 1, &m, &err) == FFD_ERR_RANGE);
    CHECK(m == NULL && strstr(err.message, "node 7 out of range"));
    ix[3] = 3;
    off[1] = 3;
    CHECK(ffd_mesh_create_cells(&p[0][0], 4, &tet, off, ix, 1, &m, &err) == FFD_ERR_PARSE);
    CHECK(strstr(err.message, "a tetra cell has 4 nodes, not 3") != NULL);
    off[1] = 4;
    CHECK(ffd_mesh_create_cells(&p[0][0], 4, &poly, off, ix, 1, &m, &err) == FFD_ERR_UNSUPPORTED);
    CHECK(strstr(err.message, "cell type 42") != NULL);
}

/* A rig deforms every node; resampling (refinement) refuses meshes with cells. */
static void test_deform_nodes(void)
{
    ffd_mesh *m = grid(3, false);
    if (!m)
        return;
    static const char rig[] = "{\"deformer\":\"lattice\",\"resolution\":[2,2,2],"
                              "\"box\":{\"origin\":[-0.5,-0.5,-0.5],\"axes\":[[2,0,0],[0,2,0],[0,0,2]]},"
                              "\"moves\":[{\"index\":[1,1,1],\"delta\":[0.1,0.2,0.3]}]}";
    ffd_rig *r = NULL;
    CHECK_OK(ffd_rig_parse_json(rig, sizeof rig - 1, "rig", &r, NULL));
    double before[3];
    memcpy(before, ffd_mesh_positions(m) + 3 * 21, sizeof before); /* an interior node */
    ffd_rig_report rep;
    CHECK_OK(ffd_rig_apply(r, m, &rep, NULL));
    CHECK(rep.notes && strstr(rep.notes, "note: volume mesh: all 64 nodes deformed") != NULL);
    CHECK(rep.notes && strstr(rep.notes, "54 faces of its 27 cells") != NULL);
    ffd_rig_report_free(&rep);
    CHECK(memcmp(before, ffd_mesh_positions(m) + 3 * 21, sizeof before) != 0);
    CHECK(ffd_mesh_cell_count(m) == 27);
    ffd_rig_destroy(r);
    ffd_mesh_destroy(m);
}

int main(int argc, char **argv)
{
    static const check_test tests[] = {
        {"single_cells_outward", test_single_cells_outward},
        {"grid_boundary", test_grid_boundary},
        {"surface_cells", test_surface_cells},
        {"bad_cells", test_bad_cells},
        {"deform_nodes", test_deform_nodes},
    };
    return check_run(tests, sizeof tests / sizeof tests[0], argc, argv);
}
