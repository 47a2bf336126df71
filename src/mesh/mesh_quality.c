/* mesh_quality — the quality of 3D cells (Jacobian determinants at the
 * corners and, for quadratic cells, at the centre; the scaled Jacobian;
 * the volume), a volume mesh's summary, and the inversion check of a
 * deformed mesh against its rest state (cells and surface faces).
 *
 * The corner frames follow VTK's node order (src/mesh/mesh_cells.c) and the
 * normalisations of VTK's verdict library (Knupp, "Achieving finite element
 * mesh quality via optimization of the Jacobian matrix norm and associated
 * quantities", 2000; Stimpson et al., "The Verdict geometric quality
 * library", 2007): a regular cell scores 1. The choices are documented in
 * include/ffd.h ("Cell quality and inversions") and docs/volume.md. */
#include "mesh/mesh_cells.h"
#include "mesh/mesh_quality.h"

#include <math.h>
#include <string.h>

/* ---- small vector helpers -------------------------------------------- */

static void sub3(const double *a, const double *b, double out[3])
{
    out[0] = a[0] - b[0];
    out[1] = a[1] - b[1];
    out[2] = a[2] - b[2];
}

static double norm3(const double v[3])
{
    return sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
}

/* det [a b c] = a . (b x c) */
static double triple(const double a[3], const double b[3], const double c[3])
{
    return a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) +
           a[2] * (b[0] * c[1] - b[1] * c[0]);
}

/* ---- corner frames ----------------------------------------------------- */

/* Per corner, its three edge neighbours in the order whose determinant is
 * positive for a valid cell in VTK's node order. */
static const uint8_t tet_frames[4][4] = {{0, 1, 2, 3}, {1, 2, 0, 3}, {2, 0, 1, 3}, {3, 0, 2, 1}};
static const uint8_t hex_frames[8][4] = {{0, 1, 3, 4}, {1, 2, 0, 5}, {2, 3, 1, 6}, {3, 0, 2, 7},
                                         {4, 7, 5, 0}, {5, 4, 6, 1}, {6, 5, 7, 2}, {7, 6, 4, 3}};
/* the wedge's triangle (0,1,2) turns clockwise seen from (3,4,5): its
 * outward normal points away from the top (mesh_cells.c, VTK's vtkWedge) */
static const uint8_t wedge_frames[6][4] = {{0, 2, 1, 3}, {1, 0, 2, 4}, {2, 1, 0, 5},
                                           {3, 4, 5, 0}, {4, 5, 3, 1}, {5, 3, 4, 2}};
/* the pyramid's four base corners with the apex (verdict's pyramid) */
static const uint8_t pyramid_frames[4][4] = {{0, 1, 3, 4}, {1, 2, 0, 4}, {2, 3, 1, 4}, {3, 0, 2, 4}};
/* voxel -> hexahedron node order */
static const uint8_t voxel_as_hex[8] = {0, 1, 3, 2, 4, 5, 7, 6};

/* The determinant and scaled value (det / edge lengths) of one corner frame. */
static void corner_frame(const double *x, const uint8_t f[4], double *det, double *scaled)
{
    double e[3][3];
    for (int k = 0; k < 3; k++)
        sub3(x + 3 * f[k + 1], x + 3 * f[0], e[k]);
    *det = triple(e[0], e[1], e[2]);
    double len = norm3(e[0]) * norm3(e[1]) * norm3(e[2]);
    *scaled = len > 0 ? *det / len : 0.0; /* a collapsed edge: degenerate */
}

/* ---- volumes ------------------------------------------------------------ */

static double tet_volume(const double *a, const double *b, const double *c, const double *d)
{
    double u[3], v[3], w[3];
    sub3(b, a, u);
    sub3(c, a, v);
    sub3(d, a, w);
    return triple(u, v, w) / 6.0;
}

/* Hexahedron (VTK order, x as 8 nodes): 2x2x2 Gauss quadrature of the
 * trilinear map's determinant, a polynomial of degree <= 2 in each
 * parameter, so the rule is exact. */
static double hex_volume(const double *x)
{
    const double g[2] = {0.5 - 0.5 / sqrt(3.0), 0.5 + 0.5 / sqrt(3.0)};
    double v = 0;
    for (int i = 0; i < 2; i++)
        for (int j = 0; j < 2; j++)
            for (int k = 0; k < 2; k++) {
                double r = g[i], s = g[j], t = g[k];
                double dr[3], ds[3], dt[3];
                for (int a = 0; a < 3; a++) {
#define X(n) x[3 * (n) + a]
                    dr[a] = (1 - s) * (1 - t) * (X(1) - X(0)) + s * (1 - t) * (X(2) - X(3)) +
                            (1 - s) * t * (X(5) - X(4)) + s * t * (X(6) - X(7));
                    ds[a] = (1 - r) * (1 - t) * (X(3) - X(0)) + r * (1 - t) * (X(2) - X(1)) +
                            (1 - r) * t * (X(7) - X(4)) + r * t * (X(6) - X(5));
                    dt[a] = (1 - r) * (1 - s) * (X(4) - X(0)) + r * (1 - s) * (X(5) - X(1)) +
                            r * s * (X(6) - X(2)) + (1 - r) * s * (X(7) - X(3));
#undef X
                }
                v += triple(dr, ds, dt) / 8.0;
            }
    return v;
}

/* Wedge: x(r, s, t) = sum_i L_i ((1-t) x_i + t x_{i+3}); the determinant is
 * linear in (r, s) and quadratic in t: a 3-point triangle rule (degree 2)
 * times 2-point Gauss is exact. r and s are swapped in the determinant
 * because (0,1,2) turns clockwise seen from the top. */
static double wedge_volume(const double *x)
{
    static const double tri[3][2] = {{1.0 / 6, 1.0 / 6}, {2.0 / 3, 1.0 / 6}, {1.0 / 6, 2.0 / 3}};
    const double g[2] = {0.5 - 0.5 / sqrt(3.0), 0.5 + 0.5 / sqrt(3.0)};
    double v = 0;
    for (int q = 0; q < 3; q++)
        for (int k = 0; k < 2; k++) {
            double r = tri[q][0], s = tri[q][1], t = g[k];
            double L[3] = {1 - r - s, r, s};
            double dr[3], ds[3], dt[3];
            for (int a = 0; a < 3; a++) {
#define X(n) x[3 * (n) + a]
                dr[a] = (1 - t) * (X(1) - X(0)) + t * (X(4) - X(3));
                ds[a] = (1 - t) * (X(2) - X(0)) + t * (X(5) - X(3));
                dt[a] = L[0] * (X(3) - X(0)) + L[1] * (X(4) - X(1)) + L[2] * (X(5) - X(2));
#undef X
            }
            v += triple(ds, dr, dt) * (1.0 / 6) * 0.5;
        }
    return v;
}

/* Pyramid: the mean of the two diagonal splits of the base into two
 * tetrahedra with the apex (exact for a bilinear base; for a planar base
 * both splits agree). */
static double pyramid_volume(const double *x)
{
    const double *a = x + 12;
    double v02 = tet_volume(x, x + 3, x + 6, a) + tet_volume(x, x + 6, x + 9, a);
    double v13 = tet_volume(x, x + 3, x + 9, a) + tet_volume(x + 3, x + 6, x + 9, a);
    return 0.5 * (v02 + v13);
}

/* ---- centre Jacobians of quadratic cells -------------------------------- */

/* The columns d x / d(parameter) at the centre, in parameters on [0, 1]
 * (so that a straight-edged cell gives the linear cell's centre Jacobian);
 * the determinant is taken in the order that is positive for a valid cell. */

/* tetra10 (VTK: 4..9 on edges 01 12 20 03 13 23), barycentric L1 = xi,
 * L2 = eta, L3 = zeta: at the centre the corner shape functions L(2L-1)
 * have zero derivative and each edge function 4 La Lb contributes
 * (dLa + dLb). */
static double tetra10_centre(const double *x)
{
    double c[3][3];
    for (int a = 0; a < 3; a++) {
#define X(n) x[3 * (n) + a]
        c[0][a] = X(5) - X(6) - X(7) + X(8);
        c[1][a] = X(5) - X(4) - X(7) + X(9);
        c[2][a] = X(8) + X(9) - X(4) - X(6);
#undef X
    }
    return triple(c[0], c[1], c[2]);
}

/* The parametric coordinates (in {-1, 0, 1}) of the hexahedron's corners
 * and of hexahedron20's edge nodes (VTK: 8..19 on edges 01 12 23 30 45 56
 * 67 74 04 15 26 37). */
static const signed char hex_corner_xi[8][3] = {{-1, -1, -1}, {1, -1, -1}, {1, 1, -1}, {-1, 1, -1},
                                                {-1, -1, 1},  {1, -1, 1},  {1, 1, 1},  {-1, 1, 1}};
static const uint8_t hex_edges[12][2] = {{0, 1}, {1, 2}, {2, 3}, {3, 0}, {4, 5}, {5, 6},
                                         {6, 7}, {7, 4}, {0, 4}, {1, 5}, {2, 6}, {3, 7}};

/* hexahedron20 (serendipity): at the centre d/dxi_a of a corner function
 * (1/8) prod(1 + xi xi_i) (sum xi xi_i - 2) is -xi_a,i / 8, of an edge
 * function (1/4)(1 - xi_b^2)(1 + ...)(1 + ...) it is xi_a,i / 4 when the
 * edge does not run along a (0 when it does). Columns doubled: [0, 1]. */
static double hex20_centre(const double *x)
{
    double c[3][3] = {{0}};
    for (int n = 0; n < 8; n++)
        for (int d = 0; d < 3; d++)
            for (int a = 0; a < 3; a++)
                c[d][a] += 2.0 * (-hex_corner_xi[n][d] / 8.0) * x[3 * n + a];
    for (int e = 0; e < 12; e++) {
        const signed char *p = hex_corner_xi[hex_edges[e][0]], *q = hex_corner_xi[hex_edges[e][1]];
        for (int d = 0; d < 3; d++) {
            int xi = (p[d] + q[d]) / 2; /* 0 along the edge's own axis */
            for (int a = 0; a < 3; a++)
                c[d][a] += 2.0 * (xi / 4.0) * x[3 * (8 + e) + a];
        }
    }
    return triple(c[0], c[1], c[2]);
}

/* hexahedron27 (triquadratic; VTK: 20..25 the centres of faces -x +x -y +y
 * -z +z): at the centre the 1D quadratic Lagrange derivatives are -1/2,
 * 0, 1/2, so each column is the difference of two opposite face centres. */
static double hex27_centre(const double *x)
{
    double c[3][3];
    for (int d = 0; d < 3; d++)
        sub3(x + 3 * (21 + 2 * d), x + 3 * (20 + 2 * d), c[d]);
    return triple(c[0], c[1], c[2]);
}

/* wedge15 (VTK: 6..8 on the bottom edges 01 12 20, 9..11 on the top edges
 * 34 45 53, 12..14 on the vertical edges 03 14 25), triangle coordinates
 * L0 = 1 - r - s, L1 = r, L2 = s and t in [-1, 1]: at the centre a corner
 * function contributes -dL/3 across and -t_i/18 along t, a triangle edge
 * function 2 La Lb (1 + t t_i) (2/3)(dLa + dLb) and 2 t_i / 9, a vertical
 * edge function L (1 - t^2) dL and 0. The t column doubled: [0, 1]. */
static double wedge15_centre(const double *x)
{
    static const uint8_t tri_edges[3][2] = {{0, 1}, {1, 2}, {2, 0}};
    const double dLr[3] = {-1, 1, 0}, dLs[3] = {-1, 0, 1};
    double cr[3] = {0}, cs[3] = {0}, ct[3] = {0};
    for (int n = 0; n < 6; n++) {
        int i = n % 3;
        double ti = n < 3 ? -1.0 : 1.0;
        for (int a = 0; a < 3; a++) {
            cr[a] += -dLr[i] / 3.0 * x[3 * n + a];
            cs[a] += -dLs[i] / 3.0 * x[3 * n + a];
            ct[a] += 2.0 * (-ti / 18.0) * x[3 * n + a];
        }
    }
    for (int level = 0; level < 2; level++)
        for (int e = 0; e < 3; e++) {
            int node = 6 + 3 * level + e, i = tri_edges[e][0], j = tri_edges[e][1];
            double ti = level ? 1.0 : -1.0;
            for (int a = 0; a < 3; a++) {
                cr[a] += (2.0 / 3.0) * (dLr[i] + dLr[j]) * x[3 * node + a];
                cs[a] += (2.0 / 3.0) * (dLs[i] + dLs[j]) * x[3 * node + a];
                ct[a] += 2.0 * (2.0 * ti / 9.0) * x[3 * node + a];
            }
        }
    for (int i = 0; i < 3; i++)
        for (int a = 0; a < 3; a++) {
            cr[a] += dLr[i] * x[3 * (12 + i) + a];
            cs[a] += dLs[i] * x[3 * (12 + i) + a];
        }
    return triple(cs, cr, ct); /* s before r: (0,1,2) is clockwise from the top */
}

/* ---- one cell ----------------------------------------------------------- */

ffd_status ffd_cell_quality_compute(unsigned vtk_type, const double *nodes, size_t node_count,
                                    ffd_cell_quality *q, ffd_error *err)
{
    const ffd_cell_type *t = ffd_cell_type_of(vtk_type);
    if (!t || t->dimension != 3)
        return ffd_fail(err, FFD_ERR_UNSUPPORTED,
                        "cell type %u: the quality is defined for 3D cells only", vtk_type);
    if (!nodes || !q)
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_cell_quality_compute: NULL argument");
    if (!ffd_cell_node_count_ok(t, node_count))
        return ffd_fail(err, FFD_ERR_INVALID, "cell type %s: %zu nodes (expected %u)", t->name,
                        node_count, t->nodes);
    memset(q, 0, sizeof *q);
    const uint8_t(*frames)[4] = NULL;
    size_t corners = 0;
    double norm = 1.0, x[3 * 8];
    const double *cx = nodes;
    switch (t->corners) {
    case 4:
        frames = tet_frames, corners = 4, norm = sqrt(2.0);
        q->volume = tet_volume(nodes, nodes + 3, nodes + 6, nodes + 9);
        break;
    case 5:
        frames = pyramid_frames, corners = 4, norm = sqrt(2.0);
        q->volume = pyramid_volume(nodes);
        break;
    case 6:
        frames = wedge_frames, corners = 6, norm = 2.0 / sqrt(3.0);
        q->volume = wedge_volume(nodes);
        break;
    default: /* 8: hexahedra and the voxel */
        if (vtk_type == FFD_CELL_VOXEL) {
            for (int n = 0; n < 8; n++)
                memcpy(x + 3 * n, nodes + 3 * voxel_as_hex[n], 3 * sizeof(double));
            cx = x;
        }
        frames = hex_frames, corners = 8;
        q->volume = hex_volume(cx);
        break;
    }
    q->scaled_jacobian = INFINITY;
    for (size_t c = 0; c < corners; c++) {
        double det, scaled;
        corner_frame(cx, frames[c], &det, &scaled);
        q->det[c] = det;
        if (norm * scaled < q->scaled_jacobian)
            q->scaled_jacobian = norm * scaled;
    }
    if (q->scaled_jacobian > 1.0)
        q->scaled_jacobian = 1.0; /* rounding above a regular cell's 1 */
    q->sample_count = corners;
    switch (vtk_type) {
    case FFD_CELL_QUADRATIC_TETRA: q->det[q->sample_count++] = tetra10_centre(nodes); break;
    case FFD_CELL_QUADRATIC_HEXAHEDRON: q->det[q->sample_count++] = hex20_centre(nodes); break;
    case FFD_CELL_TRIQUADRATIC_HEXAHEDRON: q->det[q->sample_count++] = hex27_centre(nodes); break;
    case FFD_CELL_QUADRATIC_WEDGE: q->det[q->sample_count++] = wedge15_centre(nodes); break;
    default: break;
    }
    q->min_det = q->det[0];
    for (size_t k = 1; k < q->sample_count; k++)
        if (q->det[k] < q->min_det)
            q->min_det = q->det[k];
    return FFD_OK;
}

/* The quality of mesh cell c from positions x (vertex_count by 3); 0 when
 * the cell is not 3D. Node ids were checked when the cells were read. */
static int cell_quality(const ffd_mesh *m, const double *x, size_t c, ffd_cell_quality *q)
{
    const ffd_cell_type *t = ffd_cell_type_of(m->cell_types[c]);
    if (!t || t->dimension != 3)
        return 0;
    uint64_t b = m->cell_offsets[c], n = m->cell_offsets[c + 1] - b;
    double nodes[3 * 27];
    if (n > 27)
        return 0;
    for (uint64_t k = 0; k < n; k++)
        memcpy(nodes + 3 * k, x + 3 * (size_t)m->cell_indices[b + k], 3 * sizeof(double));
    return ffd_cell_quality_compute(m->cell_types[c], nodes, (size_t)n, q, NULL) == FFD_OK;
}

ffd_status ffd_mesh_quality_compute(const ffd_mesh *mesh, ffd_mesh_quality *q, ffd_error *err)
{
    if (!mesh || !q)
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_mesh_quality_compute: NULL argument");
    memset(q, 0, sizeof *q);
    q->cell_count = mesh->cell_count;
    q->boundary_face_count = mesh->face_count;
    q->min_scaled_jacobian = NAN;
    q->min_scaled_cell = SIZE_MAX;
    for (size_t c = 0; c < mesh->cell_count; c++) {
        uint8_t type = mesh->cell_types[c];
        if (type < 32)
            q->cells_of_type[type]++;
        ffd_cell_quality cq;
        if (!cell_quality(mesh, mesh->positions, c, &cq))
            continue;
        q->volume_cell_count++;
        q->volume += cq.volume;
        if (q->min_scaled_cell == SIZE_MAX || cq.scaled_jacobian < q->min_scaled_jacobian) {
            q->min_scaled_jacobian = cq.scaled_jacobian;
            q->min_scaled_cell = c;
        }
        if (!(cq.min_det > 0))
            q->inverted_count++;
    }
    return FFD_OK;
}

/* ---- inversions ---------------------------------------------------------- */

/* Newell's normal of face f (area-weighted, any polygon). */
static void face_normal(const ffd_mesh *m, const double *x, size_t f, double n[3])
{
    uint32_t b = m->face_offsets[f], e = m->face_offsets[f + 1];
    n[0] = n[1] = n[2] = 0;
    for (uint32_t k = b; k < e; k++) {
        const double *p = x + 3 * (size_t)m->face_indices[k];
        const double *r = x + 3 * (size_t)m->face_indices[k + 1 < e ? k + 1 : b];
        n[0] += (p[1] - r[1]) * (p[2] + r[2]);
        n[1] += (p[2] - r[2]) * (p[0] + r[0]);
        n[2] += (p[0] - r[0]) * (p[1] + r[1]);
    }
}

/* A cell inverted between rest and now (ffd_mesh_check_inversions). */
static int inverted_between(const ffd_cell_quality *was, const ffd_cell_quality *now)
{
    for (size_t k = 0; k < now->sample_count; k++)
        if (!(now->det[k] > 0) || (was->det[k] < 0 && now->det[k] > 0))
            return 1;
    return 0;
}

size_t ffd_mesh_inverted_cells(const ffd_mesh *m, const double *x, const double *rest)
{
    size_t count = 0;
    for (size_t c = 0; c < m->cell_count; c++) {
        ffd_cell_quality now, was;
        if (cell_quality(m, x, c, &now) && cell_quality(m, rest, c, &was))
            count += (size_t)inverted_between(&was, &now);
    }
    return count;
}

void ffd_inversion_report_free(ffd_inversion_report *report)
{
    if (!report)
        return;
    ffd_free(report->cell_ids);
    ffd_free(report->face_ids);
    memset(report, 0, sizeof *report);
}

ffd_status ffd_mesh_check_inversions(const ffd_mesh *mesh, const double *rest, size_t max_ids,
                                     ffd_inversion_report *out, ffd_error *err)
{
    if (!out)
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_mesh_check_inversions: NULL argument");
    memset(out, 0, sizeof *out);
    out->worst_det = out->worst_scaled_jacobian = NAN;
    out->worst_cell = SIZE_MAX;
    if (!mesh || (!rest && mesh->vertex_count))
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_mesh_check_inversions: NULL argument");
    if (!max_ids)
        max_ids = FFD_INVERSION_IDS_DEFAULT;
    size_t cap = max_ids < mesh->cell_count ? max_ids : mesh->cell_count;
    size_t fcap = max_ids < mesh->face_count ? max_ids : mesh->face_count;
    out->cell_ids = ffd_malloc_array(cap ? cap : 1, sizeof(uint32_t));
    out->face_ids = ffd_malloc_array(fcap ? fcap : 1, sizeof(uint32_t));
    if (!out->cell_ids || !out->face_ids) {
        ffd_inversion_report_free(out);
        return ffd_fail(err, FFD_ERR_NOMEM, "inversion check: out of memory");
    }
    for (size_t c = 0; c < mesh->cell_count; c++) {
        ffd_cell_quality now, was;
        if (!cell_quality(mesh, mesh->positions, c, &now) || !cell_quality(mesh, rest, c, &was))
            continue;
        out->cells_checked++;
        if (out->worst_cell == SIZE_MAX || now.min_det < out->worst_det) {
            out->worst_det = now.min_det;
            out->worst_cell = c;
        }
        if (isnan(out->worst_scaled_jacobian) || now.scaled_jacobian < out->worst_scaled_jacobian)
            out->worst_scaled_jacobian = now.scaled_jacobian;
        if (inverted_between(&was, &now)) {
            if (out->cell_id_count < cap)
                out->cell_ids[out->cell_id_count++] = (uint32_t)c;
            out->inverted++;
        }
    }
    out->faces_checked = mesh->face_count;
    for (size_t f = 0; f < mesh->face_count; f++) {
        double a[3], b[3];
        face_normal(mesh, rest, f, a);
        face_normal(mesh, mesh->positions, f, b);
        if (a[0] * b[0] + a[1] * b[1] + a[2] * b[2] < 0) {
            if (out->face_id_count < fcap)
                out->face_ids[out->face_id_count++] = (uint32_t)f;
            out->flipped_faces++;
        }
    }
    return FFD_OK;
}
