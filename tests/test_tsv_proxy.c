/* Tests of tsv_proxy.c (design §5, §6 "Neighbourhoods"): occupancy against
 * an independent clipping test, the outside flood fill (cavities, a torus
 * hole), closed outward proxies that enclose the object exactly (their
 * volume is the volume of the inside cells), proxies with hanging points
 * after splits, point sets, the ARAP graph arrays, failing allocations and
 * the timing on a ~100K-triangle mesh. */
#include "check.h"
#include "ffd.h"
#include "tspline/tsv.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define SHARED FFD_DATA_DIR "/"

/* CHECK_OK that prints the error message; expr uses &e_ */
#define CHECK_E(expr)                                                                     \
    do {                                                                                  \
        ffd_error e_ = {{0}};                                                             \
        ffd_status s_ = (expr);                                                           \
        if (s_ != FFD_OK) {                                                               \
            fprintf(stderr, "%s:%d: %s: %s returned %d: %s\n", __FILE__, __LINE__,        \
                    check_current, #expr, (int)s_, e_.message);                           \
            check_failures++;                                                             \
        }                                                                                 \
    } while (0)

static const double PI = 3.14159265358979323846;

/* ---------------------------------------------------------------------- */
/* Objects                                                                 */
/* ---------------------------------------------------------------------- */

typedef struct obj {
    double *pos;      /* n by 3 world positions */
    double *params;   /* n by 3 normalised to the bounding box */
    size_t n;
    uint32_t *off, *idx;
    size_t nf;
} obj;

static void obj_free(obj *o)
{
    free(o->pos);
    free(o->params);
    free(o->off);
    free(o->idx);
    memset(o, 0, sizeof *o);
}

/* params = (x - min) / (max - min) per axis (design §1.4). */
static void obj_params(obj *o)
{
    double mn[3], mx[3];
    for (int a = 0; a < 3; a++)
        mn[a] = mx[a] = o->pos[a];
    for (size_t i = 0; i < o->n; i++)
        for (int a = 0; a < 3; a++) {
            double x = o->pos[3 * i + a];
            mn[a] = x < mn[a] ? x : mn[a];
            mx[a] = x > mx[a] ? x : mx[a];
        }
    o->params = malloc(3 * o->n * sizeof *o->params);
    for (size_t i = 0; i < o->n; i++)
        for (int a = 0; a < 3; a++) {
            double p = (o->pos[3 * i + a] - mn[a]) / (mx[a] - mn[a]);
            o->params[3 * i + a] = p < 0 ? 0 : (p > 1 ? 1 : p);
        }
}

static tsv_object obj_view(const obj *o)
{
    tsv_object t = {o->params, o->n, o->off, o->idx, o->nf};
    return t;
}

/* UV sphere: poles, nlat-1 rings of nlon points; triangles at the poles,
 * quads elsewhere (polygons exercise the fan triangulation). */
static obj make_sphere(int nlat, int nlon)
{
    obj o;
    memset(&o, 0, sizeof o);
    o.n = 2 + (size_t)(nlat - 1) * (size_t)nlon;
    o.pos = malloc(3 * o.n * sizeof *o.pos);
    o.pos[0] = 0, o.pos[1] = 0, o.pos[2] = 1;
    size_t k = 1;
    for (int i = 1; i < nlat; i++)
        for (int j = 0; j < nlon; j++, k++) {
            double th = PI * i / nlat, ph = 2 * PI * j / nlon;
            o.pos[3 * k] = sin(th) * cos(ph);
            o.pos[3 * k + 1] = sin(th) * sin(ph);
            o.pos[3 * k + 2] = cos(th);
        }
    o.pos[3 * k] = 0, o.pos[3 * k + 1] = 0, o.pos[3 * k + 2] = -1;
    uint32_t south = (uint32_t)k;
    o.nf = (size_t)nlat * (size_t)nlon;
    o.off = malloc((o.nf + 1) * sizeof *o.off);
    o.idx = malloc(4 * o.nf * sizeof *o.idx);
    size_t f = 0, q = 0;
    o.off[0] = 0;
#define RING(i, j) ((uint32_t)(1 + (size_t)(i) * (size_t)nlon + (size_t)((j) % nlon)))
    for (int j = 0; j < nlon; j++) {
        o.idx[q++] = 0, o.idx[q++] = RING(0, j), o.idx[q++] = RING(0, j + 1);
        o.off[++f] = (uint32_t)q;
    }
    for (int i = 0; i + 1 < nlat - 1; i++)
        for (int j = 0; j < nlon; j++) {
            o.idx[q++] = RING(i, j), o.idx[q++] = RING(i + 1, j);
            o.idx[q++] = RING(i + 1, j + 1), o.idx[q++] = RING(i, j + 1);
            o.off[++f] = (uint32_t)q;
        }
    for (int j = 0; j < nlon; j++) {
        o.idx[q++] = RING(nlat - 2, j), o.idx[q++] = south, o.idx[q++] = RING(nlat - 2, j + 1);
        o.off[++f] = (uint32_t)q;
    }
#undef RING
    o.nf = f;
    obj_params(&o);
    return o;
}

/* Torus of quads: major radius R about z, tube radius r. */
static obj make_torus(double R, double r, int nu, int nv)
{
    obj o;
    memset(&o, 0, sizeof o);
    o.n = (size_t)nu * (size_t)nv;
    o.pos = malloc(3 * o.n * sizeof *o.pos);
    for (int i = 0; i < nu; i++)
        for (int j = 0; j < nv; j++) {
            double u = 2 * PI * i / nu, v = 2 * PI * j / nv;
            double *p = o.pos + 3 * ((size_t)i * (size_t)nv + (size_t)j);
            p[0] = (R + r * cos(v)) * cos(u);
            p[1] = (R + r * cos(v)) * sin(u);
            p[2] = r * sin(v);
        }
    o.nf = o.n;
    o.off = malloc((o.nf + 1) * sizeof *o.off);
    o.idx = malloc(4 * o.nf * sizeof *o.idx);
    o.off[0] = 0;
    size_t f = 0, q = 0;
    for (int i = 0; i < nu; i++)
        for (int j = 0; j < nv; j++) {
            uint32_t a = (uint32_t)(i * nv + j), b = (uint32_t)(((i + 1) % nu) * nv + j);
            uint32_t c = (uint32_t)(((i + 1) % nu) * nv + (j + 1) % nv);
            uint32_t d = (uint32_t)(i * nv + (j + 1) % nv);
            o.idx[q++] = a, o.idx[q++] = b, o.idx[q++] = c, o.idx[q++] = d;
            o.off[++f] = (uint32_t)q;
        }
    obj_params(&o);
    return o;
}

static obj make_ball_points(size_t n)
{
    obj o;
    memset(&o, 0, sizeof o);
    o.n = n;
    o.pos = malloc(3 * n * sizeof *o.pos);
    for (size_t i = 0; i < n;) {
        double p[3] = {2 * check_rand01() - 1, 2 * check_rand01() - 1, 2 * check_rand01() - 1};
        if (p[0] * p[0] + p[1] * p[1] + p[2] * p[2] > 1)
            continue;
        memcpy(o.pos + 3 * i, p, sizeof p);
        i++;
    }
    obj_params(&o);
    return o;
}

static int read_mesh(const char *path, obj *o)
{
    memset(o, 0, sizeof *o);
    ffd_mesh *m = NULL;
    ffd_error err = {{0}};
    if (ffd_mesh_read(path, &m, &err) != FFD_OK) {
        fprintf(stderr, "cannot read %s: %s\n", path, err.message);
        return 0;
    }
    o->n = ffd_mesh_vertex_count(m);
    o->nf = ffd_mesh_face_count(m);
    const uint32_t *off = ffd_mesh_face_offsets(m);
    o->pos = malloc(3 * o->n * sizeof *o->pos);
    memcpy(o->pos, ffd_mesh_positions(m), 3 * o->n * sizeof *o->pos);
    o->off = malloc((o->nf + 1) * sizeof *o->off);
    memcpy(o->off, off, (o->nf + 1) * sizeof *o->off);
    o->idx = malloc((size_t)off[o->nf] * sizeof *o->idx + 1);
    memcpy(o->idx, ffd_mesh_face_indices(m), (size_t)off[o->nf] * sizeof *o->idx);
    ffd_mesh_destroy(m);
    obj_params(o);
    return 1;
}

/* ---------------------------------------------------------------------- */
/* Lattice helpers                                                         */
/* ---------------------------------------------------------------------- */

static const double BOX_MIN[3] = {-2.0, 1.0, 0.5}, BOX_MAX[3] = {3.0, 4.0, 2.5};

static tsv_lattice *make_lattice(uint32_t r0, uint32_t r1, uint32_t r2)
{
    uint32_t res[3] = {r0, r1, r2};
    tsv_lattice *L = NULL;
    CHECK_E(ffd_tsv_lattice_create(BOX_MIN, BOX_MAX, res, &L, &e_));
    return L;
}

/* Vertex v in gamma coordinates (the occupancy space, design §5.1). */
static void gamma_pos(const tsv_lattice *L, uint32_t v, double g[3])
{
    for (int a = 0; a < 3; a++)
        g[a] = ffd_tsv_gamma(L, a, L->verts[v].sg[a]);
}

static void cell_gbox(const tsv_lattice *L, size_t c, double lo[3], double hi[3])
{
    for (int a = 0; a < 3; a++) {
        lo[a] = ffd_tsv_gamma(L, a, L->cells[c].lo[a]);
        hi[a] = ffd_tsv_gamma(L, a, L->cells[c].hi[a]);
    }
}

/* Octree split of cell c by raw splits (design §3.1), skipping zero knot
 * intervals; then every vertex's channels are put at its gamma point mapped
 * into the box (a stand-in for the closure; only the topology matters here). */
static void octree_split(tsv_lattice *L, uint32_t c)
{
    uint32_t parts[8] = {c};
    size_t np = 1;
    for (int a = 0; a < 3; a++) {
        double klo = tsv_kappa(L->cells[c].lo[a]), khi = tsv_kappa(L->cells[c].hi[a]);
        if (!(khi > klo))
            continue;
        double x;
        CHECK_E(ffd_tsv_registry_get(L, a, 0.5 * (klo + khi), &x, &e_));
        size_t cur = np;
        for (size_t i = 0; i < cur; i++) {
            size_t before = L->nc;
            CHECK_E(ffd_tsv_split_cell(L, parts[i], a, x, &e_));
            CHECK(L->nc == before + 1);
            parts[np++] = (uint32_t)before;
        }
    }
}

static void positions_at_gamma(tsv_lattice *L)
{
    for (size_t v = 0; v < L->nv; v++) {
        double g[3];
        gamma_pos(L, (uint32_t)v, g);
        for (int ch = 0; ch < TSV_NCH; ch++)
            for (int a = 0; a < 3; a++)
                L->verts[v].P[ch][a] = BOX_MIN[a] + g[a] * (BOX_MAX[a] - BOX_MIN[a]);
    }
}

/* ---------------------------------------------------------------------- */
/* Independent checks                                                      */
/* ---------------------------------------------------------------------- */

/* Triangle meets the closed box grown by eps: clip it by the six planes
 * (Sutherland-Hodgman) and see whether anything is left. */
static int clip_meets(const double *t0, const double *t1, const double *t2, const double lo[3],
                      const double hi[3], double eps)
{
    double poly[16][3], tmp[16][3];
    int n = 3;
    memcpy(poly[0], t0, sizeof poly[0]);
    memcpy(poly[1], t1, sizeof poly[1]);
    memcpy(poly[2], t2, sizeof poly[2]);
    for (int pl = 0; pl < 6 && n > 0; pl++) {
        int a = pl / 2;
        double sgn = pl % 2 ? -1.0 : 1.0, lim = pl % 2 ? hi[a] + eps : lo[a] - eps;
        int m = 0;
        for (int i = 0; i < n; i++) {
            const double *p = poly[i], *q = poly[(i + 1) % n];
            double dp = sgn * (p[a] - lim), dq = sgn * (q[a] - lim);
            if (dp >= 0)
                memcpy(tmp[m++], p, sizeof tmp[0]);
            if ((dp >= 0) != (dq >= 0)) {
                double s = dp / (dp - dq);
                for (int k = 0; k < 3; k++)
                    tmp[m][k] = p[k] + s * (q[k] - p[k]);
                m++;
            }
        }
        n = m;
        memcpy(poly, tmp, (size_t)m * sizeof poly[0]);
    }
    return n > 0;
}

/* Occupancy by brute force: every fan triangle (or point) against every cell. */
static size_t occupancy_mismatches(const tsv_lattice *L, const obj *o)
{
    size_t bad = 0;
    for (size_t c = 0; c < L->nc; c++) {
        double lo[3], hi[3];
        cell_gbox(L, c, lo, hi);
        int occ = 0;
        for (size_t f = 0; f < o->nf && !occ; f++) {
            const uint32_t *ix = o->idx + o->off[f];
            uint32_t m = o->off[f + 1] - o->off[f];
            for (uint32_t j = 1; j + 1 < m && !occ; j++)
                occ = clip_meets(o->params + 3 * ix[0], o->params + 3 * ix[j],
                                 o->params + 3 * ix[j + 1], lo, hi, 1e-12);
        }
        if (o->nf == 0)
            for (size_t i = 0; i < o->n && !occ; i++) {
                const double *p = o->params + 3 * i;
                occ = p[0] >= lo[0] && p[0] <= hi[0] && p[1] >= lo[1] && p[1] <= hi[1] &&
                      p[2] >= lo[2] && p[2] <= hi[2];
            }
        bad += occ != (L->cells[c].occupied != 0);
    }
    return bad;
}

static int cmp_u64(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return (x > y) - (x < y);
}

/* Solid angle of triangle (a,b,c) seen from the origin (Van Oosterom-Strackee). */
static double solid_angle(const double a[3], const double b[3], const double c[3])
{
    double la = sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
    double lb = sqrt(b[0] * b[0] + b[1] * b[1] + b[2] * b[2]);
    double lc = sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
    double det = a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) +
                 a[2] * (b[0] * c[1] - b[1] * c[0]);
    double ab = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    double bc = b[0] * c[0] + b[1] * c[1] + b[2] * c[2];
    double ca = c[0] * a[0] + c[1] * a[1] + c[2] * a[2];
    return 2.0 * atan2(det, la * lb * lc + ab * lc + bc * la + ca * lb);
}

/* Winding number of the proxy (gamma coordinates of its vertices) at q. */
static double winding(const tsv_lattice *L, const tsv_proxy *P, const double q[3])
{
    double w = 0.0;
    for (size_t f = 0; f < P->face_count; f++) {
        uint32_t b0 = P->face_offsets[f], b1 = P->face_offsets[f + 1];
        double p0[3], pa[3], pb[3];
        gamma_pos(L, P->face_indices[b0], p0);
        for (int k = 0; k < 3; k++)
            p0[k] -= q[k];
        for (uint32_t j = b0 + 1; j + 1 < b1; j++) {
            gamma_pos(L, P->face_indices[j], pa);
            gamma_pos(L, P->face_indices[j + 1], pb);
            for (int k = 0; k < 3; k++)
                pa[k] -= q[k], pb[k] -= q[k];
            w += solid_angle(p0, pa, pb);
        }
    }
    return w / (4.0 * PI);
}

/* Signed volume of the proxy with positions from channel ch (ch < 0: gamma). */
static double proxy_volume(const tsv_lattice *L, const tsv_proxy *P, int ch)
{
    double vol = 0.0;
    for (size_t f = 0; f < P->face_count; f++) {
        uint32_t b0 = P->face_offsets[f], b1 = P->face_offsets[f + 1];
        double p[3][3];
        for (uint32_t j = b0 + 1; j + 1 < b1; j++) {
            uint32_t id[3] = {P->face_indices[b0], P->face_indices[j], P->face_indices[j + 1]};
            for (int k = 0; k < 3; k++) {
                if (ch < 0)
                    gamma_pos(L, id[k], p[k]);
                else
                    memcpy(p[k], L->verts[id[k]].P[ch], sizeof p[k]);
            }
            vol += (p[0][0] * (p[1][1] * p[2][2] - p[1][2] * p[2][1]) -
                    p[0][1] * (p[1][0] * p[2][2] - p[1][2] * p[2][0]) +
                    p[0][2] * (p[1][0] * p[2][1] - p[1][1] * p[2][0])) /
                   6.0;
        }
    }
    return vol;
}

typedef struct manifold_stats {
    size_t points, edges, components;
    long euler; /* V - E + F of the manifold proxy */
} manifold_stats;
static manifold_stats check_manifold(const tsv_lattice *L, const tsv_proxy *P);

typedef struct proxy_stats {
    size_t ngons;          /* faces with more than four points */
    size_t enclosed;       /* inside cells that are not occupied */
    double volume;         /* in gamma space */
} proxy_stats;

/* Everything design §5 promises about a proxy, checked independently. */
static proxy_stats check_proxy(const tsv_lattice *L, const tsv_proxy *P, const obj *o)
{
    proxy_stats s = {0, 0, 0.0};
    /* counts */
    size_t occ = 0, inside = 0;
    double inside_vol = 0.0;
    for (size_t c = 0; c < L->nc; c++) {
        occ += L->cells[c].occupied != 0;
        if (!L->cells[c].outside) {
            double lo[3], hi[3];
            cell_gbox(L, c, lo, hi);
            inside++;
            inside_vol += (hi[0] - lo[0]) * (hi[1] - lo[1]) * (hi[2] - lo[2]);
            s.enclosed += !L->cells[c].occupied;
        }
        /* occupied cells are never outside */
        CHECK(!(L->cells[c].occupied && L->cells[c].outside));
    }
    CHECK(P->occupied_cells == occ);
    /* outside = the closure of the free boundary cells under adjacency (by relaxation) */
    uint8_t *reach = calloc(L->nc + 1, 1);
    for (int changed = 1; changed;) {
        changed = 0;
        for (size_t f = 0; f < L->nf; f++) {
            const tsv_face *F = &L->faces[f];
            int32_t c[2] = {F->cell_neg, F->cell_pos};
            for (int k = 0; k < 2; k++) {
                if (c[k] < 0 || reach[c[k]] || L->cells[c[k]].occupied)
                    continue;
                if (c[1 - k] < 0 || reach[c[1 - k]]) {
                    reach[c[k]] = 1;
                    changed = 1;
                }
            }
        }
    }
    for (size_t c = 0; c < L->nc; c++)
        CHECK(reach[c] == L->cells[c].outside);
    free(reach);
    CHECK(P->inside_cells == inside);
    /* outside = non-occupied and connected to the domain boundary: every
     * non-occupied neighbour of an outside cell is outside, and every outside
     * cell is ... reached (checked by the cavity tests) */
    for (size_t f = 0; f < L->nf; f++) {
        const tsv_face *F = &L->faces[f];
        if (F->cell_neg >= 0 && F->cell_pos >= 0) {
            const tsv_cell *A = &L->cells[F->cell_neg], *B = &L->cells[F->cell_pos];
            if (A->outside && !B->occupied)
                CHECK(B->outside);
            if (B->outside && !A->occupied)
                CHECK(A->outside);
        } else {
            const tsv_cell *A = &L->cells[F->cell_neg >= 0 ? F->cell_neg : F->cell_pos];
            if (!A->occupied)
                CHECK(A->outside);
        }
    }
    /* faces: between an inside cell and an outside cell or the domain's end;
     * every such lattice face is there once */
    size_t expect = 0;
    for (size_t f = 0; f < L->nf; f++) {
        const tsv_face *F = &L->faces[f];
        int on = F->cell_neg < 0 || L->cells[F->cell_neg].outside;
        int op = F->cell_pos < 0 || L->cells[F->cell_pos].outside;
        expect += on != op;
    }
    CHECK(P->face_count == expect);
    size_t nidx = P->face_count ? P->face_offsets[P->face_count] : 0;
    uint64_t *dir = malloc((nidx + 1) * sizeof *dir), *rev = malloc((nidx + 1) * sizeof *rev);
    size_t ne = 0;
    for (size_t f = 0; f < P->face_count; f++) {
        uint32_t b0 = P->face_offsets[f], b1 = P->face_offsets[f + 1];
        CHECK(b1 >= b0 + 4);
        s.ngons += b1 - b0 > 4;
        const tsv_face *F = &L->faces[P->lattice_face[f]];
        uint32_t in = P->face_cells[f];
        CHECK(!L->cells[in].outside);
        int32_t other = F->cell_neg == (int32_t)in ? F->cell_pos : F->cell_neg;
        CHECK(F->cell_neg == (int32_t)in || F->cell_pos == (int32_t)in);
        CHECK(other < 0 || L->cells[other].outside);
        /* Newell normal in gamma space points to the outside side */
        double nrm[3] = {0, 0, 0};
        for (uint32_t j = b0; j < b1; j++) {
            double p[3], q[3];
            gamma_pos(L, P->face_indices[j], p);
            gamma_pos(L, P->face_indices[j + 1 < b1 ? j + 1 : b0], q);
            nrm[0] += (p[1] - q[1]) * (p[2] + q[2]);
            nrm[1] += (p[2] - q[2]) * (p[0] + q[0]);
            nrm[2] += (p[0] - q[0]) * (p[1] + q[1]);
            /* every point lies on the face's closed rectangle */
            const double *sg = L->verts[P->face_indices[j]].sg;
            CHECK(sg[F->normal] == F->c);
        }
        double want = F->cell_neg == (int32_t)in ? 1.0 : -1.0;
        CHECK(nrm[F->normal] * want > 0);
        for (int a = 0; a < 3; a++)
            if (a != F->normal)
                CHECK(fabs(nrm[a]) < 1e-12);
        for (uint32_t j = b0; j < b1; j++) {
            uint64_t x = P->face_indices[j], y = P->face_indices[j + 1 < b1 ? j + 1 : b0];
            CHECK(x != y);
            dir[ne] = x << 32 | y;
            rev[ne++] = y << 32 | x;
        }
    }
    /* closed: every directed edge is matched by its reverse (with multiplicity) */
    qsort(dir, ne, sizeof *dir, cmp_u64);
    qsort(rev, ne, sizeof *rev, cmp_u64);
    size_t unmatched = 0;
    for (size_t i = 0; i < ne; i++)
        unmatched += dir[i] != rev[i];
    CHECK(unmatched == 0);
    free(dir);
    free(rev);
    /* vertices: the distinct face points, ascending */
    for (size_t i = 1; i < P->vertex_count; i++)
        CHECK(P->vertices[i - 1] < P->vertices[i]);
    uint8_t *on = calloc(L->nv + 1, 1);
    for (size_t j = 0; j < nidx; j++)
        on[P->face_indices[j]] = 1;
    size_t distinct = 0;
    for (size_t v = 0; v < L->nv; v++)
        distinct += on[v];
    CHECK(distinct == P->vertex_count);
    for (size_t i = 0; i < P->vertex_count; i++)
        CHECK(on[P->vertices[i]]);
    free(on);
    /* outward and exact: the proxy bounds the inside cells */
    s.volume = proxy_volume(L, P, -1);
    CHECK_NEAR(s.volume, inside_vol, 1e-12);
    if (o && o->n > 0)
        CHECK(s.volume > 0);
    /* encloses the object: winding number 1 at every point (nudged off the domain's end) */
    if (o) {
        size_t step = o->n > 400 ? o->n / 400 : 1, outside_pts = 0;
        for (size_t i = 0; i < o->n; i += step) {
            double q[3];
            for (int a = 0; a < 3; a++) {
                q[a] = o->params[3 * i + a];
                q[a] = q[a] < 1e-9 ? 1e-9 : (q[a] > 1 - 1e-9 ? 1 - 1e-9 : q[a]);
            }
            outside_pts += fabs(winding(L, P, q) - 1.0) > 1e-6;
        }
        CHECK(outside_pts == 0);
        /* every cell whose closed box holds an object point is occupied */
        size_t missed = 0;
        for (size_t c = 0; c < L->nc; c++) {
            if (L->cells[c].occupied)
                continue;
            double lo[3], hi[3];
            cell_gbox(L, c, lo, hi);
            for (size_t i = 0; i < o->n; i++) {
                const double *p = o->params + 3 * i;
                missed += p[0] >= lo[0] && p[0] <= hi[0] && p[1] >= lo[1] && p[1] <= hi[1] &&
                          p[2] >= lo[2] && p[2] <= hi[2];
            }
        }
        CHECK(missed == 0);
    }
    /* and it is a closed, outward 2-manifold (face_points) */
    check_manifold(L, P);
    return s;
}

static void check_graph_common(const tsv_lattice *L, const tsv_proxy *P, const tsv_arap_graph *g);

/* ---------------------------------------------------------------------- */
/* Tests                                                                   */
/* ---------------------------------------------------------------------- */

static void test_sphere(void)
{
    obj o = make_sphere(24, 48);
    tsv_lattice *L = make_lattice(6, 6, 6);
    tsv_object ob = obj_view(&o);
    tsv_proxy P;
    memset(&P, 0, sizeof P);
    CHECK_E(ffd_tsv_proxy_build(L, &ob, &P, &e_));
    proxy_stats s = check_proxy(L, &P, &o);
    CHECK(occupancy_mismatches(L, &o) == 0);
    /* the centre cell lies inside the sphere: not met, enclosed, not outside */
    size_t centre = (2 * 5 + 2) * 5 + 2;
    CHECK(!L->cells[centre].occupied);
    CHECK(!L->cells[centre].outside);
    CHECK(s.enclosed >= 1);
    CHECK(s.ngons == 0);
    /* at rest (identity map) the proxy is outward in world coordinates too */
    CHECK(proxy_volume(L, &P, TSV_REST) > 0);
    CHECK_NEAR(proxy_volume(L, &P, TSV_REST),
               s.volume * (BOX_MAX[0] - BOX_MIN[0]) * (BOX_MAX[1] - BOX_MIN[1]) *
                   (BOX_MAX[2] - BOX_MIN[2]),
               1e-9);
    /* no proxy face inside the object: none touches the enclosed centre cell */
    for (size_t f = 0; f < P.face_count; f++)
        CHECK(P.face_cells[f] != centre);
    /* rebuilding replaces the contents and gives the same proxy */
    tsv_proxy Q;
    memset(&Q, 0, sizeof Q);
    CHECK_E(ffd_tsv_proxy_build(L, &ob, &Q, &e_));
    CHECK_E(ffd_tsv_proxy_build(L, &ob, &Q, &e_));
    CHECK(Q.face_count == P.face_count && Q.vertex_count == P.vertex_count);
    if (Q.face_count == P.face_count)
        CHECK(memcmp(Q.face_indices, P.face_indices,
                     P.face_offsets[P.face_count] * sizeof *P.face_indices) == 0);
    ffd_tsv_proxy_free(&Q);
    ffd_tsv_proxy_free(&P);
    ffd_tsv_lattice_destroy(L);
    obj_free(&o);
}

static void test_bunny(void)
{
    obj o;
    if (!read_mesh(SHARED "bunny.obj", &o)) {
        CHECK(0);
        return;
    }
    const uint32_t R[][3] = {{6, 6, 6}, {4, 5, 7}, {9, 9, 9}};
    for (size_t r = 0; r < sizeof R / sizeof R[0]; r++) {
        tsv_lattice *L = make_lattice(R[r][0], R[r][1], R[r][2]);
        tsv_object ob = obj_view(&o);
        tsv_proxy P;
        memset(&P, 0, sizeof P);
        CHECK_E(ffd_tsv_proxy_build(L, &ob, &P, &e_));
        check_proxy(L, &P, &o);
        CHECK(occupancy_mismatches(L, &o) == 0);
        ffd_tsv_proxy_free(&P);
        ffd_tsv_lattice_destroy(L);
    }
    obj_free(&o);
}

/* (2) after octree splits of proxy cells and of one enclosed cell: still
 * closed and enclosing, now with n-gons at the hanging points. */
static void test_refined(void)
{
    obj o;
    if (!read_mesh(SHARED "bunny.obj", &o)) {
        CHECK(0);
        return;
    }
    tsv_lattice *L = make_lattice(6, 6, 6);
    tsv_object ob = obj_view(&o);
    tsv_proxy P;
    memset(&P, 0, sizeof P);
    CHECK_E(ffd_tsv_proxy_build(L, &ob, &P, &e_));
    /* split a few occupied cells, an end-layer cell among them when occupied */
    uint32_t todo[6];
    size_t nt = 0;
    for (size_t c = 0; c < L->nc && nt < 4; c += 7)
        if (L->cells[c].occupied)
            todo[nt++] = (uint32_t)c;
    for (size_t c = 0; c < L->nc && nt < 5; c++)
        if (L->cells[c].occupied && L->cells[c].lo[0] == -1.0)
            todo[nt++] = (uint32_t)c;
    CHECK(nt >= 3);
    for (size_t i = 0; i < nt; i++)
        octree_split(L, todo[i]);
    CHECK_E(ffd_tsv_lattice_validate(L, &e_));
    positions_at_gamma(L);
    CHECK_E(ffd_tsv_proxy_build(L, &ob, &P, &e_));
    proxy_stats s = check_proxy(L, &P, &o);
    CHECK(s.ngons > 0);
    CHECK(occupancy_mismatches(L, &o) == 0);
    /* a second round on new cells */
    nt = 0;
    for (size_t c = L->nc; c-- > 0 && nt < 3;)
        if (L->cells[c].occupied)
            todo[nt++] = (uint32_t)c;
    for (size_t i = 0; i < nt; i++)
        octree_split(L, todo[i]);
    CHECK_E(ffd_tsv_lattice_validate(L, &e_));
    CHECK_E(ffd_tsv_proxy_build(L, &ob, &P, &e_));
    s = check_proxy(L, &P, &o);
    CHECK(s.ngons > 0);
    CHECK(occupancy_mismatches(L, &o) == 0);
    ffd_tsv_proxy_free(&P);
    ffd_tsv_lattice_destroy(L);
    obj_free(&o);
}

/* (2b) the same through ffd_tsv_lattice_refine (the closure moves and adds points):
 * cell octrees, a face 1->4 and an edge point on the proxy. */
static void test_refined_closure(void)
{
    obj o;
    if (!read_mesh(SHARED "bunny.obj", &o)) {
        CHECK(0);
        return;
    }
    tsv_lattice *L = make_lattice(6, 6, 6);
    tsv_object ob = obj_view(&o);
    tsv_proxy P;
    memset(&P, 0, sizeof P);
    CHECK_E(ffd_tsv_proxy_build(L, &ob, &P, &e_));
    ffd_tsv_insertion ins[8];
    size_t ni = 0;
    for (size_t c = 3; c < L->nc && ni < 4; c += 11)
        if (L->cells[c].occupied)
            ins[ni++] = (ffd_tsv_insertion){FFD_TSV_CELL, (uint32_t)c, 0.0};
    /* a proxy face of an interior plane and an edge of another proxy face */
    for (size_t f = 0; f < P.face_count && ni < 6; f += P.face_count / 3 + 1) {
        const tsv_face *F = &L->faces[P.lattice_face[f]];
        if (F->c > 0.0 && F->c < 1.0 && F->lo[0] >= 0.0 && F->hi[0] <= 1.0 && F->lo[1] >= 0.0 &&
            F->hi[1] <= 1.0)
            ins[ni++] = (ffd_tsv_insertion){FFD_TSV_FACE, P.lattice_face[f], 0.0};
    }
    for (size_t e = 0; e < L->ne && ni < 7; e++) {
        const tsv_edge *E = &L->edges[e];
        if (E->lo >= 0.0 && E->hi <= 1.0 && E->c[0] > 0.0 && E->c[0] < 1.0 && E->c[1] > 0.0 &&
            E->c[1] < 1.0) {
            ins[ni++] = (ffd_tsv_insertion){FFD_TSV_EDGE, (uint32_t)e, 0.25};
            break;
        }
    }
    CHECK(ni >= 5);
    size_t nv0 = L->nv;
    tsv_refine_stats rs;
    memset(&rs, 0, sizeof rs);
    CHECK_E(ffd_tsv_lattice_refine(L, ins, ni, &rs, &e_));
    CHECK(L->nv > nv0);
    CHECK_E(ffd_tsv_lattice_validate(L, &e_));
    CHECK_E(ffd_tsv_proxy_build(L, &ob, &P, &e_));
    proxy_stats s = check_proxy(L, &P, &o);
    CHECK(s.ngons > 0);
    CHECK(occupancy_mismatches(L, &o) == 0);
    /* at rest the proxy stays outward (rest points near their gamma points) */
    CHECK(proxy_volume(L, &P, TSV_REST) > 0);
    tsv_arap_graph g;
    CHECK_E(ffd_tsv_arap_graph_build(L, &P, &g, &e_));
    check_graph_common(L, &P, &g);
    ffd_tsv_arap_graph_free(&g);
    ffd_tsv_proxy_free(&P);
    ffd_tsv_lattice_destroy(L);
    obj_free(&o);
}

/* (3) a point set: points in closed boxes. */
static void test_points(void)
{
    obj o = make_ball_points(3000);
    tsv_lattice *L = make_lattice(8, 7, 6);
    tsv_object ob = obj_view(&o);
    tsv_proxy P;
    memset(&P, 0, sizeof P);
    CHECK_E(ffd_tsv_proxy_build(L, &ob, &P, &e_));
    check_proxy(L, &P, &o);
    CHECK(occupancy_mismatches(L, &o) == 0);
    /* a point on a shared face or corner occupies every cell around it */
    double q[3] = {ffd_tsv_gamma(L, 0, L->cells[0].hi[0]), ffd_tsv_gamma(L, 1, L->cells[0].hi[1]),
                   ffd_tsv_gamma(L, 2, L->cells[0].hi[2])};
    tsv_object one = {q, 1, NULL, NULL, 0};
    CHECK_E(ffd_tsv_proxy_build(L, &one, &P, &e_));
    CHECK(P.occupied_cells == 8);
    CHECK(P.inside_cells == 8);
    check_proxy(L, &P, NULL);
    /* nothing at all: an empty proxy */
    tsv_object none = {NULL, 0, NULL, NULL, 0};
    CHECK_E(ffd_tsv_proxy_build(L, &none, &P, &e_));
    CHECK(P.face_count == 0 && P.vertex_count == 0 && P.occupied_cells == 0 &&
          P.inside_cells == 0);
    for (size_t c = 0; c < L->nc; c++)
        CHECK(L->cells[c].outside);
    /* bad face indices */
    uint32_t off[2] = {0, 3}, idx[3] = {0, 1, 7};
    tsv_object bad = {o.params, 3, off, idx, 1};
    ffd_error err = {{0}};
    CHECK(ffd_tsv_proxy_build(L, &bad, &P, &err) == FFD_ERR_RANGE);
    CHECK(strlen(err.message) > 0);
    ffd_tsv_proxy_free(&P);
    ffd_tsv_lattice_destroy(L);
    obj_free(&o);
}

/* (4) a torus: its hole is outside (reached through the flood fill), the
 * tube's interior is enclosed; a hollow box shell keeps its cavity inside. */
static void test_torus_and_cavity(void)
{
    obj o = make_torus(0.35, 0.15, 96, 48);
    tsv_lattice *L = make_lattice(14, 14, 14);
    tsv_object ob = obj_view(&o);
    tsv_proxy P;
    memset(&P, 0, sizeof P);
    CHECK_E(ffd_tsv_proxy_build(L, &ob, &P, &e_));
    proxy_stats s = check_proxy(L, &P, &o);
    CHECK(s.enclosed > 0);
    /* the hole's axis is outside; the proxy does not wind around it */
    double hole[3] = {0.5, 0.5, 0.5}, tube[3] = {0.85, 0.5, 0.5};
    size_t hole_cells = 0, tube_cells = 0;
    for (size_t c = 0; c < L->nc; c++) {
        double lo[3], hi[3];
        cell_gbox(L, c, lo, hi);
        int in_h = 1, in_t = 1;
        for (int a = 0; a < 3; a++) {
            in_h &= hole[a] >= lo[a] && hole[a] <= hi[a];
            in_t &= tube[a] >= lo[a] && tube[a] <= hi[a];
        }
        if (in_h) {
            hole_cells++;
            CHECK(L->cells[c].outside);
        }
        if (in_t) {
            tube_cells++;
            CHECK(!L->cells[c].outside);
        }
    }
    CHECK(hole_cells >= 1 && tube_cells >= 1);
    CHECK(fabs(winding(L, &P, hole)) < 1e-9);
    CHECK(fabs(winding(L, &P, tube) - 1.0) < 1e-9);
    ffd_tsv_proxy_free(&P);
    ffd_tsv_lattice_destroy(L);
    obj_free(&o);

    /* a closed box shell (outer quads outwards, no inner surface) whose
     * cavity holds several cells: they stay inside; and a point set shell
     * with a gap: the flood fill enters through it */
    L = make_lattice(9, 9, 9);
    obj shell;
    memset(&shell, 0, sizeof shell);
    /* points on the six faces of the cube [0.1,0.9]^3 plus the far corners to span [0,1]^3 */
    int g = 60;
    shell.n = 6 * (size_t)(g + 1) * (size_t)(g + 1) + 2;
    shell.params = malloc(3 * shell.n * sizeof *shell.params);
    size_t k = 0;
    for (int face = 0; face < 6; face++)
        for (int i = 0; i <= g; i++)
            for (int j = 0; j <= g; j++) {
                double *p = shell.params + 3 * k++;
                int a = face / 2;
                p[a] = face % 2 ? 0.9 : 0.1;
                p[(a + 1) % 3] = 0.1 + 0.8 * i / g;
                p[(a + 2) % 3] = 0.1 + 0.8 * j / g;
            }
    double *p = shell.params + 3 * k++;
    p[0] = p[1] = p[2] = 0.0;
    p = shell.params + 3 * k++;
    p[0] = p[1] = p[2] = 1.0;
    ob = obj_view(&shell);
    memset(&P, 0, sizeof P);
    CHECK_E(ffd_tsv_proxy_build(L, &ob, &P, &e_));
    s = check_proxy(L, &P, &shell);
    CHECK(s.enclosed > 0);
    size_t centre_inside = 0;
    for (size_t c = 0; c < L->nc; c++) {
        double lo[3], hi[3];
        cell_gbox(L, c, lo, hi);
        if (lo[0] <= 0.5 && hi[0] >= 0.5 && lo[1] <= 0.5 && hi[1] >= 0.5 && lo[2] <= 0.5 &&
            hi[2] >= 0.5) {
            CHECK(!L->cells[c].occupied && !L->cells[c].outside);
            centre_inside++;
        }
    }
    CHECK(centre_inside >= 1);
    /* the proxy has two components: the shell and the two corner cells */
    CHECK(s.volume > 0);
    /* open a window in the face at s = 0.1: remove the points in its middle */
    size_t m = 0;
    for (size_t i = 0; i < shell.n; i++) {
        const double *q = shell.params + 3 * i;
        int window = q[0] == 0.1 && q[1] > 0.3 && q[1] < 0.7 && q[2] > 0.3 && q[2] < 0.7;
        if (!window) {
            memmove(shell.params + 3 * m, q, 3 * sizeof *q);
            m++;
        }
    }
    shell.n = m;
    ob = obj_view(&shell);
    CHECK_E(ffd_tsv_proxy_build(L, &ob, &P, &e_));
    s = check_proxy(L, &P, &shell);
    for (size_t c = 0; c < L->nc; c++) {
        double lo[3], hi[3];
        cell_gbox(L, c, lo, hi);
        if (lo[0] <= 0.5 && hi[0] >= 0.5 && lo[1] <= 0.5 && hi[1] >= 0.5 && lo[2] <= 0.5 &&
            hi[2] >= 0.5)
            CHECK(L->cells[c].outside);
    }
    ffd_tsv_proxy_free(&P);
    ffd_tsv_lattice_destroy(L);
    obj_free(&shell);
}

/* Is the undirected pair (i,j) in the sorted graph keys? */
static int has_pair(const uint64_t *keys, size_t n, uint32_t i, uint32_t j)
{
    uint64_t k = i < j ? (uint64_t)i << 32 | j : (uint64_t)j << 32 | i;
    return bsearch(&k, keys, n, sizeof *keys, cmp_u64) != NULL;
}

static uint64_t *graph_keys(const tsv_arap_graph *g)
{
    uint64_t *keys = malloc((g->vol_count + 1) * sizeof *keys);
    for (size_t q = 0; q < g->vol_count; q++) {
        CHECK(g->vol[2 * q] < g->vol[2 * q + 1]);
        keys[q] = (uint64_t)g->vol[2 * q] << 32 | g->vol[2 * q + 1];
        if (q > 0)
            CHECK(keys[q - 1] < keys[q]); /* ascending: no duplicates */
    }
    return keys;
}

static void check_graph_common(const tsv_lattice *L, const tsv_proxy *P, const tsv_arap_graph *g)
{
    CHECK(g->n == L->nv);
    for (size_t v = 0; v < L->nv; v++)
        for (int a = 0; a < 3; a++)
            CHECK(g->ref[3 * v + a] == L->verts[v].P[TSV_REFERENCE][a]);
    CHECK(g->edge_count == L->ne);
    uint64_t *keys = graph_keys(g);
    /* lattice edges are graph pairs */
    for (size_t e = 0; e < g->edge_count; e++)
        CHECK(has_pair(keys, g->vol_count, g->edges[2 * e], g->edges[2 * e + 1]));
    /* every cell: corner pairs and hanging-to-corner pairs */
    for (size_t c = 0; c < L->nc; c++) {
        uint32_t *pts = NULL;
        size_t m = 0;
        CHECK_E(ffd_tsv_cell_points(L, (uint32_t)c, &pts, &m, &e_));
        uint32_t corner[8];
        int nk = 0;
        for (size_t i = 0; i < m; i++) {
            const double *sg = L->verts[pts[i]].sg;
            int is = 1;
            for (int a = 0; a < 3; a++)
                is &= sg[a] == L->cells[c].lo[a] || sg[a] == L->cells[c].hi[a];
            if (is)
                corner[nk++] = pts[i];
        }
        CHECK(nk == 8);
        for (size_t i = 0; i < m; i++)
            for (int j = 0; j < nk; j++)
                if (pts[i] != corner[j])
                    CHECK(has_pair(keys, g->vol_count, pts[i], corner[j]));
        free(pts);
    }
    /* proxy polygons copied; uv = in-plane gammas, counter-clockwise */
    CHECK(g->proxy_face_count == P->face_count);
    for (size_t f = 0; f < P->face_count; f++) {
        uint32_t b0 = P->face_offsets[f], b1 = P->face_offsets[f + 1];
        CHECK(g->proxy_offsets[f] == b0 && g->proxy_offsets[f + 1] == b1);
        int n = L->faces[P->lattice_face[f]].normal, a = n == 0 ? 1 : 0, b = n == 2 ? 1 : 2;
        double area = 0;
        int swapped = -1;
        for (uint32_t q = b0; q < b1; q++) {
            uint32_t v = P->face_indices[q];
            CHECK(g->proxy_indices[q] == v);
            double ga = ffd_tsv_gamma(L, a, L->verts[v].sg[a]), gb = ffd_tsv_gamma(L, b, L->verts[v].sg[b]);
            int sw = g->proxy_uv[2 * q] == gb && g->proxy_uv[2 * q + 1] == ga;
            int st = g->proxy_uv[2 * q] == ga && g->proxy_uv[2 * q + 1] == gb;
            CHECK(sw || st);
            if (ga != gb) { /* one order for the whole face */
                CHECK(swapped != (sw ? 0 : 1));
                swapped = sw;
            }
            uint32_t r = q + 1 < b1 ? q + 1 : b0;
            area += g->proxy_uv[2 * q] * g->proxy_uv[2 * r + 1] -
                    g->proxy_uv[2 * r] * g->proxy_uv[2 * q + 1];
        }
        CHECK(area > 1e-12);
    }
    free(keys);
}

/* (5) the ARAP graph arrays. */
static void test_arap_graph(void)
{
    obj o = make_sphere(16, 32);
    tsv_lattice *L = make_lattice(6, 6, 6);
    tsv_object ob = obj_view(&o);
    tsv_proxy P;
    memset(&P, 0, sizeof P);
    CHECK_E(ffd_tsv_proxy_build(L, &ob, &P, &e_));
    tsv_arap_graph g;
    CHECK_E(ffd_tsv_arap_graph_build(L, &P, &g, &e_));
    check_graph_common(L, &P, &g);
    size_t *dv = calloc(L->nv, sizeof *dv), *de = calloc(L->nv, sizeof *de);
    for (size_t q = 0; q < g.vol_count; q++)
        dv[g.vol[2 * q]]++, dv[g.vol[2 * q + 1]]++;
    for (size_t q = 0; q < g.edge_count; q++)
        de[g.edges[2 * q]]++, de[g.edges[2 * q + 1]]++;
    size_t interior = 0;
    for (size_t v = 0; v < L->nv; v++) {
        const double *sg = L->verts[v].sg;
        int in = 1;
        for (int a = 0; a < 3; a++)
            in &= sg[a] > -1.0 && sg[a] < 2.0;
        if (in) {
            interior++;
            CHECK(dv[v] == 26);
            CHECK(de[v] == 6);
        }
    }
    CHECK(interior == 4 * 4 * 4);
    /* a regular 6^3 grid: 3*5*36 edges, and pairs = 13 directions minus boundary losses */
    CHECK(g.edge_count == 3 * 5 * 36);
    size_t expect = 3 * (5 * 6 * 6) + 6 * (5 * 5 * 6) + 4 * (5 * 5 * 5);
    CHECK(g.vol_count == expect);
    free(dv);
    free(de);
    ffd_tsv_arap_graph_free(&g);
    ffd_tsv_arap_graph_free(&g); /* idempotent */

    /* after splits: hanging points joined to the corners of the cells whose
     * boundary holds them (checked in check_graph_common) */
    uint32_t centre = (2 * 5 + 2) * 5 + 2;
    octree_split(L, centre);
    octree_split(L, 0);
    positions_at_gamma(L);
    CHECK_E(ffd_tsv_proxy_build(L, &ob, &P, &e_));
    CHECK_E(ffd_tsv_arap_graph_build(L, &P, &g, &e_));
    check_graph_common(L, &P, &g);
    /* the split cells' neighbours now hold hanging points */
    size_t hanging_links = 0;
    for (size_t c = 0; c < L->nc; c++) {
        uint32_t *pts = NULL;
        size_t m = 0;
        CHECK_E(ffd_tsv_cell_points(L, (uint32_t)c, &pts, &m, &e_));
        hanging_links += m > 8 ? m - 8 : 0;
        free(pts);
    }
    CHECK(hanging_links > 0);
    ffd_tsv_arap_graph_free(&g);
    ffd_tsv_proxy_free(&P);
    ffd_tsv_lattice_destroy(L);
    obj_free(&o);
}

/* ---------------------------------------------------------------------- */
/* The proxy as a closed 2-manifold (inside cells touching along an edge   */
/* or at a vertex are split per sheet)                                     */
/* ---------------------------------------------------------------------- */

/* Initial cell (i,j,k) of an r^3 lattice (ffd.h: ids of the initial cells). */
static uint32_t cell_id(uint32_t r, uint32_t i, uint32_t j, uint32_t k)
{
    return (i * (r - 1) + j) * (r - 1) + k;
}

/* A point set with one point at the gamma centre of each listed cell: those
 * cells, and only those, are occupied. params: 3 * n, caller-owned. */
static tsv_object cells_object(const tsv_lattice *L, const uint32_t *cells, size_t n,
                               double *params)
{
    for (size_t i = 0; i < n; i++) {
        double lo[3], hi[3];
        cell_gbox(L, cells[i], lo, hi);
        for (int a = 0; a < 3; a++)
            params[3 * i + a] = 0.5 * (lo[a] + hi[a]);
    }
    tsv_object o = {params, n, NULL, NULL, 0};
    return o;
}

static int cmp_u64_pair(const void *a, const void *b)
{
    const uint64_t *x = a, *y = b;
    if (x[0] != y[0])
        return (x[0] > y[0]) - (x[0] < y[0]);
    return (x[1] > y[1]) - (x[1] < y[1]);
}

static uint32_t find_root(uint32_t *up, uint32_t x)
{
    while (up[x] != x)
        x = up[x] = up[up[x]];
    return x;
}

/* Everything "closed 2-manifold" means, checked on face_points alone:
 * each point maps to its corners' control id; every directed edge occurs
 * once and its reverse once (two faces per edge, consistently oriented,
 * closed); the corners at each point form one fan (a single cycle of
 * prev -> next links); and chi = V - E + F is 2 per component at most,
 * and even. */
static manifold_stats check_manifold(const tsv_lattice *L, const tsv_proxy *P)
{
    manifold_stats m = {0, 0, 0, 0};
    const size_t nf = P->face_count, nidx = nf ? P->face_offsets[nf] : 0;
    CHECK(P->point_controls != NULL && P->face_points != NULL);
    if (!P->point_controls || !P->face_points)
        return m;
    m.points = P->point_count;
    CHECK(P->point_count >= P->vertex_count);
    /* points ascending by control id; every proxy vertex has one at least */
    for (size_t k = 1; k < P->point_count; k++)
        CHECK(P->point_controls[k - 1] <= P->point_controls[k]);
    size_t distinct = 0;
    for (size_t k = 0; k < P->point_count; k++) {
        CHECK(P->point_controls[k] < L->nv);
        distinct += k == 0 || P->point_controls[k] != P->point_controls[k - 1];
    }
    CHECK(distinct == P->vertex_count);
    size_t *uses = calloc(P->point_count + 1, sizeof *uses);
    for (size_t q = 0; q < nidx; q++) {
        uint32_t p = P->face_points[q];
        CHECK(p < P->point_count);
        if (p >= P->point_count)
            continue;
        CHECK(P->point_controls[p] == P->face_indices[q]);
        uses[p]++;
    }
    for (size_t k = 0; k < P->point_count; k++)
        CHECK(uses[k] >= 2); /* no unused point (a hanging point on a convex edge has 2 faces) */
    free(uses);
    /* directed edges over points: each once, each with its reverse */
    uint64_t *dir = malloc((nidx + 1) * sizeof *dir);
    uint64_t *corner = malloc((nidx + 1) * 2 * sizeof *corner); /* (point, corner) */
    for (size_t f = 0; f < nf; f++) {
        uint32_t b0 = P->face_offsets[f], b1 = P->face_offsets[f + 1];
        for (uint32_t q = b0; q < b1; q++) {
            uint64_t a = P->face_points[q], b = P->face_points[q + 1 < b1 ? q + 1 : b0];
            CHECK(a != b);
            dir[q] = a << 32 | b;
            corner[2 * q] = a;
            corner[2 * q + 1] = q;
        }
    }
    qsort(dir, nidx, sizeof *dir, cmp_u64);
    size_t repeated = 0, unmatched = 0;
    for (size_t i = 0; i < nidx; i++) {
        repeated += i > 0 && dir[i] == dir[i - 1];
        uint64_t rev = (dir[i] & 0xffffffffu) << 32 | dir[i] >> 32;
        unmatched += bsearch(&rev, dir, nidx, sizeof *dir, cmp_u64) == NULL;
    }
    CHECK(repeated == 0);  /* at most one face per direction: two faces per edge */
    CHECK(unmatched == 0); /* closed and consistently oriented */
    m.edges = nidx / 2;
    /* one fan per point: the links prev -> next of its corners form a single cycle */
    qsort(corner, nidx, 2 * sizeof *corner, cmp_u64_pair);
    size_t not_fan = 0;
    for (size_t i = 0; i < nidx;) {
        size_t j = i;
        while (j < nidx && corner[2 * j] == corner[2 * i])
            j++;
        size_t k = j - i;
        uint32_t *prev = malloc(k * sizeof *prev), *next = malloc(k * sizeof *next);
        for (size_t c = 0; c < k; c++) {
            uint32_t q = (uint32_t)corner[2 * (i + c) + 1];
            size_t f = 0;
            while (P->face_offsets[f + 1] <= q)
                f++;
            uint32_t b0 = P->face_offsets[f], b1 = P->face_offsets[f + 1];
            prev[c] = P->face_points[q > b0 ? q - 1 : b1 - 1];
            next[c] = P->face_points[q + 1 < b1 ? q + 1 : b0];
        }
        /* walk: from corner 0 to the corner whose prev is this next */
        size_t at = 0, steps = 0;
        do {
            size_t to = k, hits = 0;
            for (size_t c = 0; c < k; c++)
                if (prev[c] == next[at])
                    to = c, hits++;
            if (hits != 1) {
                not_fan++;
                break;
            }
            at = to;
            steps++;
        } while (at != 0 && steps <= k);
        not_fan += steps != k;
        free(prev);
        free(next);
        i = j;
    }
    CHECK(not_fan == 0);
    /* components (faces joined through points) and the Euler characteristic */
    uint32_t *up = malloc((P->point_count + 1) * sizeof *up);
    for (size_t k = 0; k < P->point_count; k++)
        up[k] = (uint32_t)k;
    for (size_t f = 0; f < nf; f++)
        for (uint32_t q = P->face_offsets[f] + 1; q < P->face_offsets[f + 1]; q++) {
            uint32_t a = find_root(up, P->face_points[P->face_offsets[f]]);
            uint32_t b = find_root(up, P->face_points[q]);
            up[a > b ? a : b] = a < b ? a : b;
        }
    for (size_t k = 0; k < P->point_count; k++)
        m.components += find_root(up, (uint32_t)k) == k;
    free(up);
    m.euler = (long)m.points - (long)m.edges + (long)nf;
    CHECK(m.euler % 2 == 0);
    CHECK(m.euler <= 2 * (long)m.components);
    free(dir);
    free(corner);
    return m;
}

/* The proxy of exactly these occupied cells, checked as in check_proxy and
 * as a manifold. */
static manifold_stats contact_case(tsv_lattice *L, const uint32_t *cells, size_t n,
                                   tsv_proxy *P)
{
    double *params = malloc(3 * n * sizeof *params);
    tsv_object ob = cells_object(L, cells, n, params);
    obj o;
    memset(&o, 0, sizeof o);
    o.params = params;
    o.n = n;
    CHECK_E(ffd_tsv_proxy_build(L, &ob, P, &e_));
    CHECK(P->occupied_cells == n);
    check_proxy(L, P, &o);
    manifold_stats m = check_manifold(L, P);
    free(params);
    return m;
}

/* Two cubes sharing only an edge, two sharing only a vertex, the complement
 * of a vertex contact, a ring closed by an edge contact, and the edge
 * contact again after an octree split puts a hanging point on that edge. */
static void test_manifold_contacts(void)
{
    const uint32_t r = 6;
    tsv_lattice *L = make_lattice(r, r, r);
    tsv_proxy P;
    memset(&P, 0, sizeof P);

    /* edge only: cells (1,1,1) and (2,2,1) share the edge x = y = 2 */
    uint32_t edge[2] = {cell_id(r, 1, 1, 1), cell_id(r, 2, 2, 1)};
    manifold_stats m = contact_case(L, edge, 2, &P);
    CHECK(P.face_count == 12 && P.vertex_count == 14);
    CHECK(m.points == 16);    /* the edge's two ends, once per cube */
    CHECK(m.components == 2); /* two cubes */
    CHECK(m.euler == 4);      /* two spheres */

    /* vertex only: cells (1,1,1) and (2,2,2) */
    uint32_t corner[2] = {cell_id(r, 1, 1, 1), cell_id(r, 2, 2, 2)};
    m = contact_case(L, corner, 2, &P);
    CHECK(P.face_count == 12 && P.vertex_count == 15);
    CHECK(m.points == 16 && m.components == 2 && m.euler == 4);

    /* the complement: the 2x2x2 block [1,3)^3 without (1,1,1) and (2,2,2);
     * the two notches meet at the block's centre: two fans there */
    uint32_t ring6[6];
    size_t k = 0;
    for (uint32_t i = 1; i <= 2; i++)
        for (uint32_t j = 1; j <= 2; j++)
            for (uint32_t l = 1; l <= 2; l++)
                if (!(i == j && j == l))
                    ring6[k++] = cell_id(r, i, j, l);
    m = contact_case(L, ring6, 6, &P);
    CHECK(P.face_count == 24 && P.vertex_count == 25);
    CHECK(m.points == 26 && m.components == 1 && m.euler == 2);

    /* a ring in the plane k = 1 around cell (2,2), closed only by the edge
     * contact of (1,2) and (2,1): a bent bar, not a torus */
    const uint32_t ij[7][2] = {{2, 1}, {3, 1}, {3, 2}, {3, 3}, {2, 3}, {1, 3}, {1, 2}};
    uint32_t bar[7];
    for (size_t i = 0; i < 7; i++)
        bar[i] = cell_id(r, ij[i][0], ij[i][1], 1);
    m = contact_case(L, bar, 7, &P);
    CHECK(m.points == P.vertex_count + 2 && m.components == 1 && m.euler == 2);

    /* an edge contact whose two cubes are also joined through faces around
     * both of its ends (an L of three cells below them and one above):
     * paired through the inside cells, each end would stay one point and the
     * edge would appear twice; paired through the outside cells (step 3 of
     * tsv_proxy_sheets) both ends split, and the proxy bounds the closed
     * union of the eight cells, whose V - E + F - C is 1: one sphere */
    const uint32_t pinch_ijk[8][3] = {{1, 1, 2}, {2, 2, 2}, {1, 1, 1}, {2, 1, 1},
                                      {2, 2, 1}, {1, 1, 3}, {2, 1, 3}, {2, 2, 3}};
    uint32_t pinch[8];
    for (size_t i = 0; i < 8; i++)
        pinch[i] = cell_id(r, pinch_ijk[i][0], pinch_ijk[i][1], pinch_ijk[i][2]);
    m = contact_case(L, pinch, 8, &P);
    CHECK(m.points == P.vertex_count + 2 && m.components == 1);
    CHECK(m.euler == 2);

    /* the edge contact with a hanging point on the shared edge: split (1,1,1)
     * (its id stays with one part, the other 7 are appended) */
    size_t nc0 = L->nc;
    octree_split(L, edge[0]);
    positions_at_gamma(L);
    CHECK(L->nc == nc0 + 7);
    uint32_t split[9] = {edge[0], edge[1]};
    for (uint32_t i = 0; i < 7; i++)
        split[2 + i] = (uint32_t)nc0 + i;
    m = contact_case(L, split, 9, &P);
    size_t ngons = 0;
    for (size_t f = 0; f < P.face_count; f++)
        ngons += P.face_offsets[f + 1] - P.face_offsets[f] > 4;
    CHECK(ngons > 0);
    CHECK(m.points == P.vertex_count + 3); /* the edge's ends and its hanging point */
    CHECK(m.components == 2 && m.euler == 4);
    ffd_tsv_proxy_free(&P);
    ffd_tsv_lattice_destroy(L);
}

/* Random sets of occupied cells (some after octree splits): the proxy is
 * always a closed 2-manifold; with no contact it is the old one, point for
 * point. */
static void test_manifold_random(void)
{
    for (int trial = 0; trial < (getenv("TRIALS") ? atoi(getenv("TRIALS")) : 60); trial++) {
        const uint32_t r = 6;
        tsv_lattice *L = make_lattice(r, r, r);
        if (trial % 3 == 2) { /* hanging points: three random cells split */
            for (int k = 0; k < 3; k++)
                octree_split(L, (uint32_t)(check_rand01() * (double)L->nc) % (uint32_t)L->nc);
            positions_at_gamma(L);
        }
        double prob = 0.15 + 0.5 * check_rand01();
        uint32_t *cells = malloc(L->nc * sizeof *cells);
        size_t n = 0;
        for (size_t c = 0; c < L->nc; c++)
            if (check_rand01() < prob)
                cells[n++] = (uint32_t)c;
        tsv_proxy P;
        memset(&P, 0, sizeof P);
        manifold_stats m = contact_case(L, cells, n, &P);
        if (m.points == P.vertex_count) /* nothing split: points are the vertices */
            for (size_t k = 0; k < P.point_count; k++)
                CHECK(P.point_controls[k] == P.vertices[k]);
        ffd_tsv_proxy_free(&P);
        free(cells);
        ffd_tsv_lattice_destroy(L);
    }
}

/* The proxy Laplacian (eq. 5) on the manifold proxy: one row per point.
 * On a proxy without contacts the solve is bitwise that of the lattice-id
 * polygons; with contacts the ARAP solve still reproduces rigid motions and
 * the identity, and a graph whose points do not match its corners is refused. */
static void arap_rigid_check(const tsv_arap_graph *g, size_t nv, int expect_same_as_ids)
{
    uint8_t *roles = calloc(nv, 1);
    double *tg = malloc(3 * nv * sizeof *tg), *x = malloc(3 * nv * sizeof *x);
    double *x2 = malloc(3 * nv * sizeof *x2);
    /* handles: every 5th point; target: a rotation about z by 0.4 and a shift */
    const double c = cos(0.4), s = sin(0.4);
    for (size_t v = 0; v < nv; v++) {
        const double *p = g->ref + 3 * v;
        roles[v] = v % 5 == 0 ? TSV_HARD : TSV_FREE;
        tg[3 * v] = c * p[0] - s * p[1] + 0.3;
        tg[3 * v + 1] = s * p[0] + c * p[1] - 0.2;
        tg[3 * v + 2] = p[2] + 0.1;
    }
    tsv_arap_weights w = {1.0, 2.0 / 3.0, 0.5, 1.0};
    tsv_arap *a = NULL;
    CHECK_E(ffd_tsv_arap_solver_create(g, roles, &w, &a, &e_));
    /* the identity at rest */
    memcpy(x, g->ref, 3 * nv * sizeof *x);
    CHECK_E(ffd_tsv_arap_solver_solve(a, g->ref, x, 3, &e_));
    double worst = 0.0;
    for (size_t i = 0; i < 3 * nv; i++)
        worst = fmax(worst, fabs(x[i] - g->ref[i]));
    CHECK(worst <= 1e-10);
    ffd_tsv_arap_solver_destroy(a);
    CHECK_E(ffd_tsv_arap_solver_create(g, roles, &w, &a, &e_));
    memcpy(x, g->ref, 3 * nv * sizeof *x);
    CHECK_E(ffd_tsv_arap_solver_solve(a, tg, x, 100, &e_));
    worst = 0.0;
    for (size_t i = 0; i < 3 * nv; i++)
        worst = fmax(worst, fabs(x[i] - tg[i]));
    CHECK(worst <= 1e-6); /* converged to the rigid motion */
    ffd_tsv_arap_solver_destroy(a);
    /* the same graph without its points (one row per lattice id) */
    tsv_arap_graph ids = *g;
    ids.proxy_points = NULL;
    ids.proxy_point_controls = NULL;
    ids.proxy_point_count = 0;
    for (size_t v = 0; v < nv; v++)
        tg[3 * v] += v % 5 == 0 ? 0.05 * sin((double)v) : 0.0; /* not rigid */
    CHECK_E(ffd_tsv_arap_solver_create(g, roles, &w, &a, &e_));
    memcpy(x, g->ref, 3 * nv * sizeof *x);
    CHECK_E(ffd_tsv_arap_solver_solve(a, tg, x, 5, &e_));
    ffd_tsv_arap_solver_destroy(a);
    CHECK_E(ffd_tsv_arap_solver_create(&ids, roles, &w, &a, &e_));
    memcpy(x2, g->ref, 3 * nv * sizeof *x2);
    CHECK_E(ffd_tsv_arap_solver_solve(a, tg, x2, 5, &e_));
    ffd_tsv_arap_solver_destroy(a);
    int same = memcmp(x, x2, 3 * nv * sizeof *x) == 0;
    CHECK(same == expect_same_as_ids);
    for (size_t i = 0; i < 3 * nv; i++)
        CHECK(isfinite(x[i]));
    free(roles);
    free(tg);
    free(x);
    free(x2);
}

static void test_manifold_arap(void)
{
    const uint32_t r = 6;
    /* no contact: a sphere's proxy */
    obj o = make_sphere(16, 32);
    tsv_lattice *L = make_lattice(r, r, r);
    tsv_object ob = obj_view(&o);
    tsv_proxy P;
    memset(&P, 0, sizeof P);
    CHECK_E(ffd_tsv_proxy_build(L, &ob, &P, &e_));
    CHECK(P.point_count == P.vertex_count);
    tsv_arap_graph g;
    CHECK_E(ffd_tsv_arap_graph_build(L, &P, &g, &e_));
    CHECK(g.proxy_point_count == P.point_count);
    arap_rigid_check(&g, L->nv, 1);
    ffd_tsv_arap_graph_free(&g);
    /* an edge and a vertex contact */
    uint32_t cells[3] = {cell_id(r, 1, 1, 1), cell_id(r, 2, 2, 1), cell_id(r, 3, 3, 2)};
    manifold_stats m = contact_case(L, cells, 3, &P);
    CHECK(m.points == P.vertex_count + 3);
    CHECK_E(ffd_tsv_arap_graph_build(L, &P, &g, &e_));
    CHECK(g.proxy_point_count == P.point_count);
    size_t nidx = P.face_offsets[P.face_count];
    for (size_t q = 0; q < nidx; q++)
        CHECK(g.proxy_points[q] == P.face_points[q] &&
              g.proxy_point_controls[g.proxy_points[q]] == g.proxy_indices[q]);
    arap_rigid_check(&g, L->nv, 0); /* the split points have their own rows */
    /* a point that is not on its corner's vertex is refused */
    uint8_t *roles = calloc(L->nv, 1);
    roles[0] = TSV_HARD;
    uint32_t *bad = (uint32_t *)g.proxy_points;
    uint32_t keep = bad[0];
    bad[0] = (keep + 1) % (uint32_t)g.proxy_point_count;
    tsv_arap_weights w = {1.0, 2.0 / 3.0, 0.5, 1.0};
    tsv_arap *a = NULL;
    ffd_error err = {{0}};
    CHECK(ffd_tsv_arap_solver_create(&g, roles, &w, &a, &err) == FFD_ERR_INVALID && a == NULL);
    CHECK(strstr(err.message, "proxy corner 0") != NULL);
    bad[0] = keep;
    /* a point whose control id is out of range, even one no corner uses */
    uint32_t *ctl = (uint32_t *)g.proxy_point_controls;
    size_t last = g.proxy_point_count - 1;
    keep = ctl[last];
    ctl[last] = (uint32_t)L->nv;
    CHECK(ffd_tsv_arap_solver_create(&g, roles, &w, &a, &err) == FFD_ERR_RANGE && a == NULL);
    CHECK(strstr(err.message, "proxy point") != NULL);
    ctl[last] = keep;
    free(roles);
    ffd_tsv_arap_graph_free(&g);
    ffd_tsv_proxy_free(&P);
    ffd_tsv_lattice_destroy(L);
    obj_free(&o);
}

/* Failing allocations: NOMEM, no leak, the old proxy and cell flags kept. */
static void test_failing_allocations(void)
{
    obj o = make_sphere(12, 24), pts = make_ball_points(50);
    tsv_lattice *L = make_lattice(6, 6, 6);
    octree_split(L, 31);
    positions_at_gamma(L);
    tsv_object ob = obj_view(&o), old = obj_view(&pts);
    tsv_proxy P;
    memset(&P, 0, sizeof P);
    CHECK_E(ffd_tsv_proxy_build(L, &old, &P, &e_));
    size_t old_faces = P.face_count, old_occ = P.occupied_cells;
    uint8_t *flags = malloc(2 * L->nc);
    for (size_t c = 0; c < L->nc; c++)
        flags[2 * c] = L->cells[c].occupied, flags[2 * c + 1] = L->cells[c].outside;
    int done = 0;
    long failures = 0;
    for (long k = 0; k < 100000 && !done; k++) {
        fail_alloc fa = {k, 0};
        ffd_allocator al = {fa_malloc, fa_realloc, fa_free, &fa};
        ffd_set_allocator(&al);
        ffd_error err = {{0}};
        tsv_arap_graph g;
        memset(&g, 0, sizeof g);
        ffd_status st = ffd_tsv_arap_graph_build(L, &P, &g, &err);
        ffd_set_allocator(NULL);
        CHECK(st == FFD_OK || st == FFD_ERR_NOMEM);
        if (st == FFD_OK)
            check_graph_common(L, &P, &g);
        else
            CHECK(g.ref == NULL && g.vol == NULL && strlen(err.message) > 0);
        ffd_tsv_arap_graph_free(&g);
        ffd_set_allocator(&al);
        st = ffd_tsv_proxy_build(L, &ob, &P, &err);
        ffd_set_allocator(NULL);
        CHECK(st == FFD_OK || st == FFD_ERR_NOMEM);
        if (st == FFD_OK) {
            done = 1;
            check_proxy(L, &P, &o);
            CHECK(P.occupied_cells != old_occ);
        } else {
            failures++;
            CHECK(strlen(err.message) > 0);
            CHECK(P.face_count == old_faces && P.occupied_cells == old_occ);
            for (size_t c = 0; c < L->nc; c++)
                CHECK(flags[2 * c] == L->cells[c].occupied &&
                      flags[2 * c + 1] == L->cells[c].outside);
        }
    }
    CHECK(done && failures > 5);
    free(flags);
    ffd_tsv_proxy_free(&P);
    ffd_tsv_lattice_destroy(L);
    obj_free(&o);
    obj_free(&pts);
}

/* (6) timing on the largest mesh of data/ (~89K triangles). */
static void test_timing(void)
{
    obj o;
    if (!read_mesh(SHARED "refined_elephant.off", &o)) {
        CHECK(0);
        return;
    }
    const uint32_t R[] = {12, 18};
    for (size_t r = 0; r < 2; r++) {
        tsv_lattice *L = make_lattice(R[r], R[r], R[r]);
        tsv_object ob = obj_view(&o);
        tsv_proxy P;
        memset(&P, 0, sizeof P);
        double best = 1e30, gbest = 1e30;
        for (int rep = 0; rep < 3; rep++) {
            double t0 = ffd_now();
            CHECK_E(ffd_tsv_proxy_build(L, &ob, &P, &e_));
            double t1 = ffd_now();
            tsv_arap_graph g;
            CHECK_E(ffd_tsv_arap_graph_build(L, &P, &g, &e_));
            double t2 = ffd_now();
            ffd_tsv_arap_graph_free(&g);
            best = t1 - t0 < best ? t1 - t0 : best;
            gbest = t2 - t1 < gbest ? t2 - t1 : gbest;
        }
        printf("  %zu triangles (%zu faces), %u^3 lattice, %zu cells: proxy build %.2f ms "
               "(%zu occupied, %zu inside, %zu proxy faces, %zu proxy points); "
               "ARAP graph %.2f ms\n",
               (size_t)o.off[o.nf] - 2 * o.nf, o.nf, R[r], L->nc, 1e3 * best, P.occupied_cells,
               P.inside_cells, P.face_count, P.vertex_count, 1e3 * gbest);
        check_proxy(L, &P, &o);
        ffd_tsv_proxy_free(&P);
        ffd_tsv_lattice_destroy(L);
    }
    obj_free(&o);
}

int main(int argc, char **argv)
{
    static const check_test tests[] = {
        {"sphere", test_sphere},
        {"bunny", test_bunny},
        {"refined", test_refined},
        {"refined_closure", test_refined_closure},
        {"points", test_points},
        {"torus_and_cavity", test_torus_and_cavity},
        {"arap_graph", test_arap_graph},
        {"manifold_contacts", test_manifold_contacts},
        {"manifold_random", test_manifold_random},
        {"manifold_arap", test_manifold_arap},
        {"failing_allocations", test_failing_allocations},
        {"timing", test_timing},
    };
    return check_run(tests, sizeof tests / sizeof *tests, argc, argv);
}
