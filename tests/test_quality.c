/* Cell quality, inversions and fold-overs: determinants and scaled
 * Jacobians of reference cells against hand formulas, every type's
 * inverted cell found, exact volumes, quadratic cells with straight edges
 * equal to their linear cells, the inversion check of a deformed mesh,
 * flipped surface faces, the fold check of every method, step limiting. */
#include "check.h"

#include <stdint.h>

#include <ffd.h>

#ifndef FFD_DATA_DIR
#define FFD_DATA_DIR "data"
#endif

#include "check_cells.h"

#define NREFS (sizeof refs / sizeof refs[0])

static ffd_cell_quality quality(uint8_t type, const double *p, size_t n)
{
    ffd_cell_quality q;
    memset(&q, 0, sizeof q);
    CHECK_OK(ffd_cell_quality_compute(type, p, n, &q, NULL));
    return q;
}

/* x -> A x + b with det A = 1.5 (a shear, a stretch and a rotation). */
static const double affine_A[9] = {1.2, 0.3, 0.0, -0.1, 1.1, 0.2, 0.05, 0.0, 1.0};
static double affine_det(void)
{
    const double *m = affine_A;
    return m[0] * (m[4] * m[8] - m[5] * m[7]) - m[1] * (m[3] * m[8] - m[5] * m[6]) +
           m[2] * (m[3] * m[7] - m[4] * m[6]);
}
static void affine(const double *x, double *y, size_t n)
{
    for (size_t i = 0; i < n; i++)
        for (int r = 0; r < 3; r++)
            y[3 * i + r] = affine_A[3 * r] * x[3 * i] + affine_A[3 * r + 1] * x[3 * i + 1] +
                           affine_A[3 * r + 2] * x[3 * i + 2] + 0.5 * r;
}

static void test_reference_cells(void)
{
    /* unit tetrahedron: det 1 at every corner (6 V); scaled: sqrt(2) * 1 / (1 sqrt2 sqrt2) */
    ffd_cell_quality q = quality(FFD_CELL_TETRA, &refs[0].p[0][0], 4);
    CHECK(q.sample_count == 4);
    for (int c = 0; c < 4; c++)
        CHECK_NEAR(q.det[c], 1.0, 1e-15);
    CHECK_NEAR(q.scaled_jacobian, sqrt(2.0) / 2, 1e-15);
    CHECK_NEAR(q.volume, 1.0 / 6, 1e-15);
    /* a regular tetrahedron scores 1 */
    double reg[4][3] = {{1, 1, 1}, {1, -1, -1}, {-1, 1, -1}, {-1, -1, 1}};
    q = quality(FFD_CELL_TETRA, &reg[0][0], 4);
    if (q.det[0] < 0) { /* pick the positive order */
        double t[3];
        memcpy(t, reg[1], sizeof t), memcpy(reg[1], reg[2], sizeof t), memcpy(reg[2], t, sizeof t);
        q = quality(FFD_CELL_TETRA, &reg[0][0], 4);
    }
    CHECK_NEAR(q.scaled_jacobian, 1.0, 1e-14);
    CHECK_NEAR(q.volume, 8.0 / 3, 1e-14); /* edge 2 sqrt 2: a^3 / (6 sqrt 2) */
    /* unit cube (hexahedron and voxel): 8 corners of det 1, scaled 1, volume 1 */
    for (int r = 1; r <= 2; r++) {
        q = quality(refs[r].type, &refs[r].p[0][0], 8);
        CHECK(q.sample_count == 8);
        for (int c = 0; c < 8; c++)
            CHECK_NEAR(q.det[c], 1.0, 1e-15);
        CHECK_NEAR(q.scaled_jacobian, 1.0, 1e-15);
        CHECK_NEAR(q.volume, 1.0, 1e-15);
    }
    /* a box a x b x c: det a b c at every corner, scaled 1 */
    double box[8][3] = {{0, 0, 0}, {2, 0, 0}, {2, 3, 0}, {0, 3, 0},
                        {0, 0, 5}, {2, 0, 5}, {2, 3, 5}, {0, 3, 5}};
    q = quality(FFD_CELL_HEXAHEDRON, &box[0][0], 8);
    CHECK_NEAR(q.min_det, 30.0, 1e-13);
    CHECK_NEAR(q.scaled_jacobian, 1.0, 1e-15);
    CHECK_NEAR(q.volume, 30.0, 1e-13);
    /* regular wedge (unit equilateral triangle, height 1): det sin 60, scaled 1 */
    double h = sqrt(3.0) / 2;
    double wedge[6][3] = {{0, 0, 0}, {0.5, h, 0}, {1, 0, 0}, {0, 0, 1}, {0.5, h, 1}, {1, 0, 1}};
    q = quality(FFD_CELL_WEDGE, &wedge[0][0], 6);
    CHECK(q.sample_count == 6);
    for (int c = 0; c < 6; c++)
        CHECK_NEAR(q.det[c], h, 1e-15);
    CHECK_NEAR(q.scaled_jacobian, 1.0, 1e-15);
    CHECK_NEAR(q.volume, h / 2, 1e-15);
    /* equilateral pyramid (all edges 1): base corners det 1/sqrt2, scaled 1, volume sqrt2/6 */
    double pyr[5][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0.5, 0.5, sqrt(0.5)}};
    q = quality(FFD_CELL_PYRAMID, &pyr[0][0], 5);
    CHECK(q.sample_count == 4);
    for (int c = 0; c < 4; c++)
        CHECK_NEAR(q.det[c], sqrt(0.5), 1e-15);
    CHECK_NEAR(q.scaled_jacobian, 1.0, 1e-15);
    CHECK_NEAR(q.volume, sqrt(2.0) / 6, 1e-15);
    /* a sheared hexahedron: top moved by (1, 0, 0): det 1, edges 1, 1, sqrt 2 */
    double sh[8][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0},
                       {1, 0, 1}, {2, 0, 1}, {2, 1, 1}, {1, 1, 1}};
    q = quality(FFD_CELL_HEXAHEDRON, &sh[0][0], 8);
    CHECK_NEAR(q.min_det, 1.0, 1e-15);
    CHECK_NEAR(q.scaled_jacobian, 1.0 / sqrt(2.0), 1e-15);
    CHECK_NEAR(q.volume, 1.0, 1e-15);
    /* not a 3D cell */
    ffd_error err = {{0}};
    CHECK(ffd_cell_quality_compute(FFD_CELL_TRIANGLE, &refs[0].p[0][0], 3, &q, &err) ==
          FFD_ERR_UNSUPPORTED);
    CHECK(strstr(err.message, "3D cells only"));
    CHECK(ffd_cell_quality_compute(FFD_CELL_TETRA, &refs[0].p[0][0], 5, &q, &err) ==
          FFD_ERR_INVALID);
}

/* Volumes against the exact values, also after an affine map (volumes and
 * determinants scale by det A), and a non-planar hexahedron against its
 * trilinear volume summed independently (a fine midpoint rule). */
static void test_volumes(void)
{
    for (size_t r = 0; r < NREFS; r++) {
        ffd_cell_quality q = quality(refs[r].type, &refs[r].p[0][0], refs[r].n);
        CHECK_NEAR(q.volume, refs[r].volume, 1e-15);
        double y[8 * 3];
        affine(&refs[r].p[0][0], y, refs[r].n);
        ffd_cell_quality qa = quality(refs[r].type, y, refs[r].n);
        CHECK_NEAR(qa.volume, affine_det() * refs[r].volume, 1e-14);
        for (size_t k = 0; k < q.sample_count; k++)
            CHECK_NEAR(qa.det[k], affine_det() * q.det[k], 1e-14);
    }
    /* a warped hexahedron: corner 6 raised, top face not planar */
    double w[8][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0},
                      {0, 0, 1}, {1, 0, 1}, {1.3, 1.2, 1.7}, {0, 1, 1}};
    ffd_cell_quality q = quality(FFD_CELL_HEXAHEDRON, &w[0][0], 8);
    int n = 60;
    double sum = 0;
    for (int i = 0; i < n; i++)
        for (int j = 0; j < n; j++)
            for (int k = 0; k < n; k++) {
                double r = (i + 0.5) / n, s = (j + 0.5) / n, t = (k + 0.5) / n;
                double d[3][3] = {{0}};
                double dN[3][8] = {
                    {-(1 - s) * (1 - t), (1 - s) * (1 - t), s * (1 - t), -s * (1 - t),
                     -(1 - s) * t, (1 - s) * t, s * t, -s * t},
                    {-(1 - r) * (1 - t), -r * (1 - t), r * (1 - t), (1 - r) * (1 - t),
                     -(1 - r) * t, -r * t, r * t, (1 - r) * t},
                    {-(1 - r) * (1 - s), -r * (1 - s), -r * s, -(1 - r) * s, (1 - r) * (1 - s),
                     r * (1 - s), r * s, (1 - r) * s}};
                for (int a = 0; a < 3; a++)
                    for (int c = 0; c < 8; c++)
                        for (int x = 0; x < 3; x++)
                            d[a][x] += dN[a][c] * w[c][x];
                sum += (d[0][0] * (d[1][1] * d[2][2] - d[1][2] * d[2][1]) -
                        d[0][1] * (d[1][0] * d[2][2] - d[1][2] * d[2][0]) +
                        d[0][2] * (d[1][0] * d[2][1] - d[1][1] * d[2][0])) /
                       (n * n * n);
            }
    CHECK_NEAR(q.volume, sum, 1e-4);
    /* a pyramid with a non-planar base: the mean of the two splits */
    double p[5][3] = {{0, 0, 0}, {1, 0, 0.2}, {1, 1, 0}, {0, 1, 0.2}, {0.5, 0.5, 1}};
    q = quality(FFD_CELL_PYRAMID, &p[0][0], 5);
    CHECK(q.volume > 0.2 && q.volume < 1.0 / 3);
}

/* Quadratic cells whose mid-edge (and face, body) nodes sit at the
 * midpoints: the corners' determinants, the volume and the centre's
 * determinant equal the linear cell's (centre: the linear map's Jacobian
 * there, det A times the reference value 1). */
static void test_quadratic_straight(void)
{
    static const uint8_t tet_e[6][2] = {{0, 1}, {1, 2}, {2, 0}, {0, 3}, {1, 3}, {2, 3}};
    static const uint8_t hex_e[12][2] = {{0, 1}, {1, 2}, {2, 3}, {3, 0}, {4, 5}, {5, 6},
                                         {6, 7}, {7, 4}, {0, 4}, {1, 5}, {2, 6}, {3, 7}};
    static const uint8_t hex_f[6][4] = {{0, 4, 7, 3}, {1, 2, 6, 5}, {0, 1, 5, 4},
                                        {3, 2, 6, 7}, {0, 1, 2, 3}, {4, 5, 6, 7}};
    static const uint8_t wedge_e[9][2] = {{0, 1}, {1, 2}, {2, 0}, {3, 4}, {4, 5},
                                          {5, 3}, {0, 3}, {1, 4}, {2, 5}};
    static const uint8_t pyr_e[8][2] = {{0, 1}, {1, 2}, {2, 3}, {3, 0},
                                        {0, 4}, {1, 4}, {2, 4}, {3, 4}};
    struct {
        uint8_t type;
        int ref;
        size_t edges;
        const uint8_t (*e)[2];
        int faces;
        size_t n;
        int centre;
    } cases[] = {
        {FFD_CELL_QUADRATIC_TETRA, 0, 6, tet_e, 0, 10, 1},
        {FFD_CELL_QUADRATIC_HEXAHEDRON, 1, 12, hex_e, 0, 20, 1},
        {FFD_CELL_TRIQUADRATIC_HEXAHEDRON, 1, 12, hex_e, 1, 27, 1},
        {FFD_CELL_QUADRATIC_WEDGE, 3, 9, wedge_e, 0, 15, 1},
        {FFD_CELL_QUADRATIC_PYRAMID, 4, 8, pyr_e, 0, 13, 0},
    };
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++) {
        const ref_cell *r = &refs[cases[k].ref];
        double x[27 * 3], y[27 * 3];
        memcpy(x, r->p, r->n * 3 * sizeof(double));
        size_t m = r->n;
        for (size_t e = 0; e < cases[k].edges; e++, m++)
            for (int a = 0; a < 3; a++)
                x[3 * m + a] = 0.5 * (r->p[cases[k].e[e][0]][a] + r->p[cases[k].e[e][1]][a]);
        if (cases[k].faces) {
            for (int f = 0; f < 6; f++, m++)
                for (int a = 0; a < 3; a++)
                    x[3 * m + a] = 0.25 * (r->p[hex_f[f][0]][a] + r->p[hex_f[f][1]][a] +
                                           r->p[hex_f[f][2]][a] + r->p[hex_f[f][3]][a]);
            for (int a = 0; a < 3; a++)
                x[3 * m + a] = 0.5;
            m++;
        }
        CHECK(m == cases[k].n);
        affine(x, y, m);
        ffd_cell_quality lin = quality(r->type, y, r->n), q = quality(cases[k].type, y, m);
        CHECK(q.sample_count == lin.sample_count + (size_t)cases[k].centre);
        for (size_t s = 0; s < lin.sample_count; s++)
            CHECK_NEAR(q.det[s], lin.det[s], 1e-14);
        CHECK_NEAR(q.volume, lin.volume, 1e-14);
        CHECK_NEAR(q.scaled_jacobian, lin.scaled_jacobian, 1e-14);
        if (cases[k].centre) {
            CHECK_NEAR(q.det[lin.sample_count], affine_det(), 1e-13);
            /* a mid-edge node (hexahedron27: a face centre, the nodes its
             * centre Jacobian reads) pulled across the cell changes the centre */
            double z[27 * 3];
            memcpy(z, y, sizeof z);
            size_t mid = cases[k].faces ? 20 : r->n;
            for (int a = 0; a < 3; a++)
                z[3 * mid + a] += 4.0 * (y[3 * (r->n - 1) + a] - y[3 * mid + a]);
            ffd_cell_quality bent = quality(cases[k].type, z, m);
            CHECK(bent.det[lin.sample_count] != q.det[lin.sample_count]);
        }
    }
}

/* Every type: a node moved through the opposite face makes det <= 0 at a
 * corner, and the cell's min_det is <= 0. */
static void test_inverted_each_type(void)
{
    for (size_t r = 0; r < NREFS; r++) {
        double x[8 * 3];
        memcpy(x, refs[r].p, refs[r].n * 3 * sizeof(double));
        ffd_cell_quality q = quality(refs[r].type, x, refs[r].n);
        CHECK(q.min_det > 0 && q.scaled_jacobian > 0);
        /* the last node (a top node or the apex) pushed below the bottom */
        x[3 * (refs[r].n - 1) + 2] = -1.0;
        q = quality(refs[r].type, x, refs[r].n);
        CHECK(q.min_det <= 0);
        CHECK(q.scaled_jacobian <= 0);
        /* a flat cell (every z = 0) is degenerate: det 0 */
        for (size_t i = 0; i < refs[r].n; i++)
            x[3 * i + 2] = 0;
        q = quality(refs[r].type, x, refs[r].n);
        CHECK(q.min_det <= 0);
    }
}

/* A mixed mesh (a hexahedron, a wedge, a pyramid and a tetrahedron on one
 * box column): summary counts, volume, and the inversion check after one
 * node is pulled through the mesh. */
static ffd_mesh *mixed_mesh(void)
{
    /* the hexahedron [0,1]^3, a wedge on its +x face, a pyramid on its top */
    static const double p[][3] = {
        {0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1},
        {2, 0, 0}, {2, 0, 1},                 /* 8, 9: the wedge's far edge */
        {0.5, 0.5, 2},                        /* 10: the pyramid's apex */
        {1.5, 0.5, 1.5},                      /* 11: the tet's apex */
        {2, 1, 0},                            /* 12: the wedge's far corner at y = 1 */
    };
    uint8_t types[4] = {FFD_CELL_HEXAHEDRON, FFD_CELL_WEDGE, FFD_CELL_PYRAMID, FFD_CELL_TETRA};
    /* the wedge: triangles (1, 8, 5) at y = 0 and (2, 12, 6) at y = 1, the
     * first clockwise seen from the second; the pyramid on the hex's top;
     * the tetrahedron across the wedge's slanted face (sharing edge 5-8) */
    uint32_t idx[] = {0, 1, 2, 3, 4, 5, 6, 7,   /* hexahedron */
                      1, 8, 5, 2, 12, 6,        /* wedge */
                      4, 5, 6, 7, 10,           /* pyramid on the top face */
                      5, 9, 8, 11};             /* a tetrahedron */
    uint64_t off[5] = {0, 8, 14, 19, 23};
    ffd_mesh *m = NULL;
    CHECK_OK(ffd_mesh_create_cells(&p[0][0], 13, types, off, idx, 4, &m, NULL));
    return m;
}

static void test_mesh_summary_and_inversions(void)
{
    ffd_mesh *m = mixed_mesh();
    if (!m)
        return;
    ffd_mesh_quality mq;
    CHECK_OK(ffd_mesh_quality_compute(m, &mq, NULL));
    CHECK(mq.cell_count == 4 && mq.volume_cell_count == 4);
    CHECK(mq.cells_of_type[FFD_CELL_HEXAHEDRON] == 1 && mq.cells_of_type[FFD_CELL_WEDGE] == 1 &&
          mq.cells_of_type[FFD_CELL_PYRAMID] == 1 && mq.cells_of_type[FFD_CELL_TETRA] == 1);
    CHECK(mq.boundary_face_count == ffd_mesh_face_count(m));
    CHECK(mq.inverted_count == 0);
    /* per cell, to see the orientation of each */
    const double *x = ffd_mesh_positions(m);
    const uint64_t *off = ffd_mesh_cell_offsets(m);
    const uint32_t *ix = ffd_mesh_cell_indices(m);
    double expect = 0;
    for (size_t c = 0; c < 4; c++) {
        double nodes[8 * 3];
        size_t n = (size_t)(off[c + 1] - off[c]);
        for (size_t k = 0; k < n; k++)
            memcpy(nodes + 3 * k, x + 3 * ix[off[c] + k], 3 * sizeof(double));
        ffd_cell_quality q = quality(ffd_mesh_cell_types(m)[c], nodes, n);
        CHECK(q.min_det > 0);
        expect += q.volume;
    }
    /* hex 1, wedge 1/2, pyramid 1/3, tet: |det[(1,0,0),(1,0,-1),(.5,.5,.5)]|/6 = 1/12 */
    CHECK_NEAR(mq.volume, 1 + 0.5 + 1.0 / 3 + 1.0 / 12, 1e-14);
    CHECK_NEAR(mq.volume, expect, 1e-14);
    CHECK(mq.min_scaled_cell < 4 && mq.min_scaled_jacobian > 0 && mq.min_scaled_jacobian <= 1);

    /* untouched: nothing inverted, nothing flipped */
    size_t nv = ffd_mesh_vertex_count(m);
    double rest[13 * 3], moved[13 * 3];
    memcpy(rest, x, nv * 3 * sizeof(double));
    ffd_inversion_report r;
    CHECK_OK(ffd_mesh_check_inversions(m, rest, 0, &r, NULL));
    CHECK(r.cells_checked == 4 && r.inverted == 0 && r.cell_id_count == 0);
    CHECK(r.faces_checked == ffd_mesh_face_count(m) && r.flipped_faces == 0);
    CHECK(r.worst_det > 0);
    ffd_inversion_report_free(&r);
    /* node 6 (shared by the hex, the wedge and the pyramid) pulled down
     * through the hex's bottom: the hex (corner 6) and the wedge (its
     * corner 5: det -1 by hand) invert; the pyramid's base corners keep
     * det 1, 2, 2 (by hand) and the tetrahedron does not hold node 6 */
    memcpy(moved, rest, sizeof moved);
    moved[3 * 6 + 2] = -1.0;
    CHECK_OK(ffd_mesh_set_positions(m, moved, NULL, NULL));
    CHECK_OK(ffd_mesh_check_inversions(m, rest, 0, &r, NULL));
    CHECK(r.inverted == 2 && r.cell_id_count == 2);
    CHECK(r.cell_ids && r.cell_ids[0] == 0 && r.cell_ids[1] == 1);
    CHECK(r.worst_det < 0 && r.worst_cell < 2);
    CHECK(r.worst_scaled_jacobian < 0);
    CHECK(r.flipped_faces > 0);
    ffd_inversion_report_free(&r);
    /* the id cap: one id listed, the count still 2 */
    CHECK_OK(ffd_mesh_check_inversions(m, rest, 1, &r, NULL));
    CHECK(r.inverted == 2 && r.cell_id_count == 1 && r.cell_ids[0] == 0);
    ffd_inversion_report_free(&r);
    ffd_error err = {{0}};
    CHECK(ffd_mesh_check_inversions(m, NULL, 0, &r, &err) == FFD_ERR_INVALID);
    ffd_mesh_destroy(m);
}

/* A hexahedral grid of [0,1]^3 with n nodes per axis. */
static ffd_mesh *hex_grid(int n)
{
    size_t nv = (size_t)n * n * n, nc = (size_t)(n - 1) * (n - 1) * (n - 1);
    double *p = malloc(nv * 3 * sizeof *p);
    uint8_t *types = malloc(nc);
    uint64_t *off = malloc((nc + 1) * sizeof *off);
    uint32_t *ix = malloc(nc * 8 * sizeof *ix);
#define NODE(i, j, k) ((uint32_t)((i) + n * ((j) + n * (k))))
    for (int k = 0; k < n; k++)
        for (int j = 0; j < n; j++)
            for (int i = 0; i < n; i++) {
                double *q = p + 3 * NODE(i, j, k);
                q[0] = (double)i / (n - 1), q[1] = (double)j / (n - 1), q[2] = (double)k / (n - 1);
            }
    size_t c = 0;
    off[0] = 0;
    for (int k = 0; k + 1 < n; k++)
        for (int j = 0; j + 1 < n; j++)
            for (int i = 0; i + 1 < n; i++, c++) {
                uint32_t h[8] = {NODE(i, j, k),         NODE(i + 1, j, k),
                                 NODE(i + 1, j + 1, k), NODE(i, j + 1, k),
                                 NODE(i, j, k + 1),     NODE(i + 1, j, k + 1),
                                 NODE(i + 1, j + 1, k + 1), NODE(i, j + 1, k + 1)};
                memcpy(ix + 8 * c, h, sizeof h);
                types[c] = FFD_CELL_HEXAHEDRON;
                off[c + 1] = 8 * (c + 1);
            }
#undef NODE
    ffd_mesh *m = NULL;
    CHECK_OK(ffd_mesh_create_cells(p, nv, types, off, ix, nc, &m, NULL));
    free(p), free(types), free(off), free(ix);
    return m;
}

/* A B-spline lattice whose middle control point is pulled through its +x
 * neighbour (and beyond): the fold check finds lattice cells with det <= 0
 * and the inversion check finds the volume mesh's inverted cells; at rest
 * neither finds anything. */
static void test_lattice_fold(void)
{
    ffd_mesh *m = hex_grid(9);
    if (!m)
        return;
    static const char rest_rig[] = "{\"version\": 1, \"deformer\": \"lattice\", \"basis\": \"bspline\","
        " \"resolution\": [5, 5, 5], \"box\": {\"origin\": [0, 0, 0], \"axes\": [[1, 0, 0], [0, 1, 0], [0, 0, 1]]}}";
    static const char fold_rig[] = "{\"version\": 1, \"deformer\": \"lattice\", \"basis\": \"bspline\","
        " \"resolution\": [5, 5, 5], \"box\": {\"origin\": [0, 0, 0], \"axes\": [[1, 0, 0], [0, 1, 0], [0, 0, 1]]},"
        " \"moves\": [{\"index\": [2, 2, 2], \"delta\": [1.5, 0, 0]}]}";
    ffd_deformer *d = NULL;
    ffd_fold_report f;
    CHECK_OK(ffd_deformer_create_json(rest_rig, sizeof rest_rig - 1, "rest.json", m, NULL, &d, NULL));
    if (d) {
        CHECK_OK(ffd_deformer_fold_check(d, &f, NULL));
        CHECK(f.cells_checked == 6 * 6 * 6 && f.samples == 125 * f.cells_checked);
        CHECK(f.folded == 0 && f.cell_ids == NULL);
        CHECK_NEAR(f.min_det, 1.0, 1e-9);
        CHECK(strcmp(f.cells, "lattice cell") == 0);
        ffd_fold_report_free(&f);
    }
    ffd_deformer_destroy(d);
    d = NULL;
    CHECK_OK(ffd_deformer_create_json(fold_rig, sizeof fold_rig - 1, "fold.json", m, NULL, &d, NULL));
    if (d) {
        CHECK_OK(ffd_deformer_fold_check(d, &f, NULL));
        CHECK(f.folded > 0 && f.min_det < 0);
        /* the folded cells are knot spans next to the moved control (segments 2..5 per axis) */
        for (size_t i = 0; i < f.folded && f.cell_ids; i++) {
            uint32_t c = f.cell_ids[i], a = c % 6, b = c / 6 % 6, e = c / 36;
            CHECK(a >= 1 && a <= 5 && b >= 1 && b <= 5 && e >= 1 && e <= 5);
        }
        ffd_fold_report_free(&f);
        /* the same map applied to the nodes inverts cells */
        size_t nv = ffd_mesh_vertex_count(m);
        double *x = malloc(nv * 3 * sizeof *x);
        CHECK_OK(ffd_deformer_eval(d, x, NULL));
        ffd_mesh *def = hex_grid(9);
        if (def) {
            CHECK_OK(ffd_mesh_set_positions(def, x, NULL, NULL));
            ffd_inversion_report r;
            CHECK_OK(ffd_mesh_check_inversions(def, ffd_mesh_positions(m), 0, &r, NULL));
            CHECK(r.inverted > 0 && r.worst_det < 0 && r.cell_id_count == r.inverted);
            ffd_inversion_report_free(&r);
            ffd_mesh_destroy(def);
        }
        free(x);
    }
    ffd_deformer_destroy(d);
    ffd_mesh_destroy(m);
}

/* The bunny under a mirror-like fold: a trilinear (Bernstein 2x2x2)
 * lattice whose two x layers of controls swap places maps x to its mirror
 * image (det J = -1 everywhere: the one lattice cell folded), and the faces
 * whose deformed normal opposes the rest one are found. */
static void test_bunny_flipped_faces(void)
{
    ffd_mesh *m = NULL;
    CHECK_OK(ffd_mesh_read(FFD_DATA_DIR "/bunny.obj", &m, NULL));
    if (!m)
        return;
    ffd_mesh_info info;
    CHECK_OK(ffd_mesh_compute_info(m, &info, NULL));
    double lo[3], w[3];
    for (int a = 0; a < 3; a++) {
        w[a] = (info.bbox_max[a] - info.bbox_min[a]) * 1.2;
        lo[a] = info.bbox_min[a] - 0.1 * w[a] / 1.2;
    }
    char rig[1024];
    int len = snprintf(rig, sizeof rig,
                       "{\"version\": 1, \"deformer\": \"lattice\", \"basis\": \"bernstein\","
                       " \"resolution\": [2, 2, 2], \"box\": {\"origin\": [%.17g, %.17g, %.17g],"
                       " \"axes\": [[%.17g, 0, 0], [0, %.17g, 0], [0, 0, %.17g]]}, \"moves\": [",
                       lo[0], lo[1], lo[2], w[0], w[1], w[2]);
    for (int j = 0; j < 2; j++)
        for (int k = 0; k < 2; k++)
            len += snprintf(rig + len, sizeof rig - (size_t)len,
                            "%s{\"index\": [0, %d, %d], \"delta\": [%.17g, 0, 0]},"
                            " {\"index\": [1, %d, %d], \"delta\": [%.17g, 0, 0]}",
                            j || k ? ", " : "", j, k, w[0], j, k, -w[0]);
    len += snprintf(rig + len, sizeof rig - (size_t)len, "]}");
    size_t nv = ffd_mesh_vertex_count(m);
    double *rest = malloc(nv * 3 * sizeof *rest);
    memcpy(rest, ffd_mesh_positions(m), nv * 3 * sizeof *rest);
    ffd_rig *r = NULL;
    CHECK_OK(ffd_rig_parse_json(rig, (size_t)len, "mirror.json", &r, NULL));
    ffd_deformer *d = NULL;
    if (r)
        CHECK_OK(ffd_deformer_create(r, m, NULL, &d, NULL));
    if (d) {
        ffd_fold_report f;
        CHECK_OK(ffd_deformer_fold_check(d, &f, NULL));
        CHECK(f.cells_checked == 1 && f.folded == 1);
        CHECK_NEAR(f.min_det, -1.0, 1e-12);
        ffd_fold_report_free(&f);
    }
    ffd_deformer_destroy(d);
    if (r)
        CHECK_OK(ffd_rig_apply(r, m, NULL, NULL));
    ffd_inversion_report ir;
    CHECK_OK(ffd_mesh_check_inversions(m, rest, 0, &ir, NULL));
    CHECK(ir.cells_checked == 0);
    CHECK(ir.faces_checked == ffd_mesh_face_count(m));
    /* the mirror maps a rest normal (a, b, c) to (a, -b, -c): the face
     * counts as flipped when a^2 < b^2 + c^2 (triangles here) */
    const uint32_t *fo = ffd_mesh_face_offsets(m), *fi = ffd_mesh_face_indices(m);
    size_t expect = 0, first = SIZE_MAX;
    for (size_t f = 0; f < ffd_mesh_face_count(m); f++) {
        CHECK(fo[f + 1] - fo[f] == 3);
        const double *a = rest + 3 * fi[fo[f]], *b = rest + 3 * fi[fo[f] + 1],
                     *c = rest + 3 * fi[fo[f] + 2];
        double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
        double v[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
        double n[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2],
                       u[0] * v[1] - u[1] * v[0]};
        if (n[0] * n[0] < n[1] * n[1] + n[2] * n[2]) {
            expect++;
            if (first == SIZE_MAX)
                first = f;
        }
    }
    CHECK(expect > 100 && ir.flipped_faces == expect);
    CHECK(ir.face_id_count == (expect < 1000 ? expect : 1000));
    CHECK(ir.face_ids && ir.face_ids[0] == first);
    ffd_inversion_report_free(&ir);
    /* at rest: nothing flipped */
    CHECK_OK(ffd_mesh_set_positions(m, rest, NULL, NULL));
    CHECK_OK(ffd_mesh_check_inversions(m, rest, 0, &ir, NULL));
    CHECK(ir.flipped_faces == 0);
    ffd_inversion_report_free(&ir);
    ffd_rig_destroy(r);
    free(rest);
    ffd_mesh_destroy(m);
}

/* The hexahedral grid with each hexahedron split into six tetrahedra
 * around its diagonal 0-6 (all positive). */
static ffd_mesh *tet_grid(int n)
{
    ffd_mesh *h = hex_grid(n);
    if (!h)
        return NULL;
    static const uint8_t split[6][4] = {{0, 1, 2, 6}, {0, 2, 3, 6}, {0, 3, 7, 6},
                                        {0, 7, 4, 6}, {0, 4, 5, 6}, {0, 5, 1, 6}};
    size_t nh = ffd_mesh_cell_count(h), nc = 6 * nh;
    const uint32_t *hx = ffd_mesh_cell_indices(h);
    uint8_t *types = malloc(nc);
    uint64_t *off = malloc((nc + 1) * sizeof *off);
    uint32_t *ix = malloc(nc * 4 * sizeof *ix);
    off[0] = 0;
    for (size_t c = 0; c < nh; c++)
        for (int t = 0; t < 6; t++) {
            size_t k = 6 * c + (size_t)t;
            for (int v = 0; v < 4; v++)
                ix[4 * k + v] = hx[8 * c + split[t][v]];
            types[k] = FFD_CELL_TETRA;
            off[k + 1] = 4 * (k + 1);
        }
    ffd_mesh *m = NULL;
    CHECK_OK(ffd_mesh_create_cells(ffd_mesh_positions(h), ffd_mesh_vertex_count(h), types, off, ix,
                                   nc, &m, NULL));
    free(types), free(off), free(ix);
    ffd_mesh_destroy(h);
    return m;
}

/* Step limiting: a constraint drags an inner node of a small tet mesh
 * through its +x neighbours. Without "limit_step" cells invert; with it the
 * applied fraction of the step is < 1, the lattice does not fold and no
 * cell inverts; the report says the fraction, and a deformer built from
 * the rig (the session's replay) gives the same positions. */
static void test_limit_step(void)
{
    ffd_mesh *m = tet_grid(5);
    if (!m)
        return;
    size_t nv = ffd_mesh_vertex_count(m);
    uint32_t v = 1 + 5 * (2 + 5 * 2); /* (0.25, 0.5, 0.5) */
    const double *x0 = ffd_mesh_positions(m);
    double *rest = malloc(nv * 3 * sizeof *rest);
    memcpy(rest, x0, nv * 3 * sizeof *rest);
    for (int limited = 0; limited < 2; limited++) {
        char rig[512];
        int len = snprintf(rig, sizeof rig,
                           "{\"version\": 1, \"deformer\": \"lattice\", \"resolution\": [4, 4, 4],"
                           " \"box\": \"auto\",%s \"constraints\": [{\"vertex\": %u, \"target\":"
                           " [%.17g, %.17g, %.17g]}]}",
                           limited ? " \"limit_step\": true," : "", v, rest[3 * v] + 0.7,
                           rest[3 * v + 1], rest[3 * v + 2]);
        ffd_rig *r = NULL;
        CHECK_OK(ffd_rig_parse_json(rig, (size_t)len, "drag.json", &r, NULL));
        if (!r)
            continue;
        ffd_mesh *def = tet_grid(5);
        ffd_rig_report report;
        memset(&report, 0, sizeof report);
        CHECK_OK(ffd_rig_apply(r, def, &report, NULL));
        ffd_inversion_report ir;
        CHECK_OK(ffd_mesh_check_inversions(def, rest, 0, &ir, NULL));
        ffd_deformer *d = NULL;
        CHECK_OK(ffd_deformer_create(r, m, NULL, &d, NULL));
        ffd_fold_report f;
        memset(&f, 0, sizeof f);
        if (d)
            CHECK_OK(ffd_deformer_fold_check(d, &f, NULL));
        if (!limited) {
            CHECK(ir.inverted > 0);
            CHECK(f.folded > 0);
            CHECK(!report.details || !strstr(report.details, "step_fraction"));
        } else {
            CHECK(ir.inverted == 0);
            CHECK(f.folded == 0);
            const char *sf = report.details ? strstr(report.details, "\"step_fraction\":") : NULL;
            CHECK(sf != NULL);
            double t = sf ? atof(sf + strlen("\"step_fraction\":")) : 1;
            CHECK(t > 0.05 && t < 1);
            CHECK(report.notes && strstr(report.notes, "limit_step"));
            /* the replay (a deformer, as the editor's session) lands on the same positions */
            double *y = malloc(nv * 3 * sizeof *y);
            if (d) {
                CHECK_OK(ffd_deformer_eval(d, y, NULL));
                CHECK(memcmp(y, ffd_mesh_positions(def), nv * 3 * sizeof *y) == 0);
            }
            free(y);
        }
        ffd_fold_report_free(&f);
        ffd_deformer_destroy(d);
        ffd_inversion_report_free(&ir);
        ffd_rig_report_free(&report);
        ffd_mesh_destroy(def);
        ffd_rig_destroy(r);
    }
    /* only the lattice limits the step so far */
    static const char pb[] = "{\"version\": 1, \"deformer\": \"pbffd\", \"limit_step\": true}";
    ffd_rig *r = NULL;
    ffd_error err = {{0}};
    CHECK(ffd_rig_parse_json(pb, sizeof pb - 1, "pb.json", &r, &err) == FFD_ERR_UNSUPPORTED);
    CHECK(strstr(err.message, "limit_step: only"));
    static const char bad[] = "{\"version\": 1, \"deformer\": \"lattice\", \"limit_step\": 1}";
    CHECK(ffd_rig_parse_json(bad, sizeof bad - 1, "bad.json", &r, &err) == FFD_ERR_PARSE);
    CHECK(strstr(err.message, "limit_step"));
    free(rest);
    ffd_mesh_destroy(m);
}

static const check_test tests[] = {
    {"reference_cells", test_reference_cells},
    {"volumes", test_volumes},
    {"quadratic_straight", test_quadratic_straight},
    {"inverted_each_type", test_inverted_each_type},
    {"mesh_summary_and_inversions", test_mesh_summary_and_inversions},
    {"lattice_fold", test_lattice_fold},
    {"bunny_flipped_faces", test_bunny_flipped_faces},
    {"limit_step", test_limit_step},
};

int main(int argc, char **argv)
{
    return check_run(tests, sizeof tests / sizeof tests[0], argc, argv);
}
