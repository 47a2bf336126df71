/* gffd_skeleton.c — skeleton primitives checked, copied and fitted with
 * their variational distance fields, and the merged field of GFFD eq. 1-2
 * (Qin et al. 2003, §2). */
#include "gffd/gffd.h"
#include "math/dense.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Coordinates must lie within this magnitude, so that cubed distances
 * neither overflow nor lose all precision. */
#define GFFD_MAX_COORD 1e100
/* A segment or face smaller than this fraction of the primitive's box is degenerate. */
#define GFFD_TOL_DEGENERATE 1e-12
/* An edit is rigid when a rotation and a shift reproduce it to this fraction of the box. */
#define GFFD_TOL_RIGID 1e-12

static const char *kind_name(int kind)
{
    switch (kind) {
    case FFD_GFFD_POINT: return "point";
    case FFD_GFFD_POLYLINE: return "polyline";
    case FFD_GFFD_PATCH: return "patch";
    case FFD_GFFD_POLYHEDRON: return "polyhedron";
    default: return "primitive";
    }
}



static void bounds_of(const double *v, size_t n, double lo[3], double hi[3])
{
    for (int k = 0; k < 3; k++) {
        lo[k] = v[k];
        hi[k] = v[k];
    }
    for (size_t i = 1; i < n; i++)
        for (int k = 0; k < 3; k++) {
            lo[k] = fmin(lo[k], v[3 * i + k]);
            hi[k] = fmax(hi[k], v[3 * i + k]);
        }
}

static double diagonal_of(const double *v, size_t n)
{
    double lo[3], hi[3], d[3];
    bounds_of(v, n, lo, hi);
    sub3(hi, lo, d);
    return norm3(d);
}

/* Every edge of a polyhedron in exactly two faces, traversed once each way. */
typedef struct edge_use {
    uint32_t a, b; /* a < b */
    uint32_t face;
    int forward;   /* 1 when the face runs a -> b */
} edge_use;

static int edge_cmp(const void *x, const void *y)
{
    const edge_use *p = x, *q = y;
    if (p->a != q->a)
        return p->a < q->a ? -1 : 1;
    if (p->b != q->b)
        return p->b < q->b ? -1 : 1;
    return (p->face > q->face) - (p->face < q->face);
}

static ffd_status check_closed(const ffd_gffd_primitive *p, size_t index, ffd_error *err)
{
    size_t corners = p->face_offsets[p->face_count];
    edge_use *e = ffd_malloc_array(corners, sizeof *e);
    if (!e)
        return ffd_fail(err, FFD_ERR_NOMEM, "skeleton[%zu]: out of memory", index);
    size_t k = 0;
    for (size_t f = 0; f < p->face_count; f++) {
        uint32_t s = p->face_offsets[f], t = p->face_offsets[f + 1];
        for (uint32_t c = s; c < t; c++) {
            uint32_t u = p->face_indices[c], v = p->face_indices[c + 1 < t ? c + 1 : s];
            e[k].a = u < v ? u : v;
            e[k].b = u < v ? v : u;
            e[k].face = (uint32_t)f;
            e[k].forward = u < v;
            k++;
        }
    }
    qsort(e, k, sizeof *e, edge_cmp);
    ffd_status st = FFD_OK;
    for (size_t i = 0; i < k;) {
        size_t j = i;
        while (j < k && e[j].a == e[i].a && e[j].b == e[i].b)
            j++;
        if (j - i != 2) {
            st = ffd_fail(err, FFD_ERR_INVALID,
                          "skeleton[%zu]: polyhedron is not closed: edge (%u, %u) is used by %zu "
                          "face%s, expected 2 (an open mesh is a \"patch\")",
                          index, e[i].a, e[i].b, j - i, j - i == 1 ? "" : "s");
            break;
        }
        i = j;
    }
    ffd_free(e);
    return st;
}

static ffd_status check_primitive(const ffd_gffd_primitive *p, size_t index, ffd_error *err)
{
    if ((int)p->kind < FFD_GFFD_POINT || (int)p->kind > FFD_GFFD_POLYHEDRON)
        return ffd_fail(err, FFD_ERR_INVALID, "skeleton[%zu]: unknown primitive kind %d", index,
                        (int)p->kind);
    const char *name = kind_name(p->kind);
    if (!isfinite(p->radius))
        return ffd_fail(err, FFD_ERR_NONFINITE, "skeleton[%zu]: radius is not finite", index);
    if (!(p->radius > 0) || p->radius > GFFD_MAX_COORD)
        return ffd_fail(err, FFD_ERR_INVALID, "skeleton[%zu]: radius %g: expected > 0 (and <= 1e100)",
                        index, p->radius);
    if (p->vertex_count > 0 && !p->vertices)
        return ffd_fail(err, FFD_ERR_INVALID, "skeleton[%zu]: vertices missing", index);
    if (p->vertex_count > UINT32_MAX)
        return ffd_fail(err, FFD_ERR_INVALID, "skeleton[%zu]: too many vertices", index);
    for (size_t i = 0; i < 3 * p->vertex_count; i++) {
        if (!isfinite(p->vertices[i]))
            return ffd_fail(err, FFD_ERR_NONFINITE, "skeleton[%zu]: vertex %zu is not finite",
                            index, i / 3);
        if (fabs(p->vertices[i]) > GFFD_MAX_COORD)
            return ffd_fail(err, FFD_ERR_INVALID,
                            "skeleton[%zu]: vertex %zu: coordinate %g beyond 1e100", index, i / 3,
                            p->vertices[i]);
    }
    double diag = p->vertex_count ? diagonal_of(p->vertices, p->vertex_count) : 0;
    double tol = GFFD_TOL_DEGENERATE * diag;
    switch (p->kind) {
    case FFD_GFFD_POINT:
        if (p->vertex_count != 1)
            return ffd_fail(err, FFD_ERR_INVALID, "skeleton[%zu]: a point has 1 vertex, not %zu",
                            index, p->vertex_count);
        return FFD_OK;
    case FFD_GFFD_POLYLINE:
        if (p->vertex_count < 2)
            return ffd_fail(err, FFD_ERR_INVALID,
                            "skeleton[%zu]: a polyline needs at least 2 vertices, got %zu", index,
                            p->vertex_count);
        for (size_t i = 0; i + 1 < p->vertex_count; i++) {
            double d[3];
            sub3(p->vertices + 3 * i + 3, p->vertices + 3 * i, d);
            if (norm3(d) <= tol)
                return ffd_fail(err, FFD_ERR_INVALID,
                                "skeleton[%zu]: zero-length segment between vertices %zu and %zu",
                                index, i, i + 1);
        }
        return FFD_OK;
    default:
        break;
    }
    /* patch, polyhedron */
    if (p->face_count == 0 || !p->face_offsets || !p->face_indices)
        return ffd_fail(err, FFD_ERR_INVALID, "skeleton[%zu]: a %s needs faces", index, name);
    if (p->face_count > UINT32_MAX / 8 || p->face_offsets[0] != 0)
        return ffd_fail(err, FFD_ERR_INVALID, "skeleton[%zu]: bad face offsets", index);
    for (size_t f = 0; f < p->face_count; f++) {
        uint32_t s = p->face_offsets[f], t = p->face_offsets[f + 1];
        if (t < s || t - s < 3)
            return ffd_fail(err, FFD_ERR_INVALID,
                            "skeleton[%zu]: face %zu has %d vertices, expected >= 3", index, f,
                            t < s ? -1 : (int)(t - s));
        for (uint32_t c = s; c < t; c++) {
            if (p->face_indices[c] >= p->vertex_count)
                return ffd_fail(err, FFD_ERR_RANGE,
                                "skeleton[%zu]: face %zu: vertex index %u out of range (%zu "
                                "vertices)",
                                index, f, p->face_indices[c], p->vertex_count);
            for (uint32_t c2 = s; c2 < c; c2++)
                if (p->face_indices[c2] == p->face_indices[c])
                    return ffd_fail(err, FFD_ERR_INVALID,
                                    "skeleton[%zu]: face %zu repeats vertex %u", index, f,
                                    p->face_indices[c]);
        }
        /* area by the polygon's vector area (Newell) */
        double area[3] = {0, 0, 0};
        const double *o = p->vertices + 3 * p->face_indices[s];
        for (uint32_t c = s + 1; c + 1 < t; c++) {
            double u[3], v[3];
            sub3(p->vertices + 3 * p->face_indices[c], o, u);
            sub3(p->vertices + 3 * p->face_indices[c + 1], o, v);
            area[0] += u[1] * v[2] - u[2] * v[1];
            area[1] += u[2] * v[0] - u[0] * v[2];
            area[2] += u[0] * v[1] - u[1] * v[0];
        }
        if (0.5 * norm3(area) <= tol * diag)
            return ffd_fail(err, FFD_ERR_INVALID, "skeleton[%zu]: face %zu has zero area", index, f);
    }
    if (p->kind == FFD_GFFD_POLYHEDRON)
        return check_closed(p, index, err);
    return FFD_OK;
}

static void part_free(ffd_gffd_part *q)
{
    ffd_free(q->geom.vertices);
    ffd_free(q->geom.tris);
    ffd_free(q->face_offsets);
    ffd_free(q->face_indices);
    ffd_free(q->fit_vertices);
    ffd_rbf_free(&q->field);
    memset(q, 0, sizeof *q);
}

/* 1 when every vertex lies on the line through the first and the farthest one. */
static int is_collinear(const double *v, size_t n)
{
    size_t far = 0;
    double best = 0;
    for (size_t i = 1; i < n; i++) {
        double d[3];
        sub3(v + 3 * i, v, d);
        if (norm3(d) > best) {
            best = norm3(d);
            far = i;
        }
    }
    if (far == 0)
        return 1;
    double a[3];
    sub3(v + 3 * far, v, a);
    for (size_t i = 1; i < n; i++) {
        double d[3];
        sub3(v + 3 * i, v, d);
        double c[3] = {a[1] * d[2] - a[2] * d[1], a[2] * d[0] - a[0] * d[2], a[0] * d[1] - a[1] * d[0]};
        if (norm3(c) > GFFD_TOL_DEGENERATE * best * best)
            return 0;
    }
    return 1;
}

void ffd_gffd_skeleton_align(ffd_gffd_skeleton *cur, const ffd_gffd_skeleton *rest,
                             double *scratch)
{
    if (!ffd_gffd_skeleton_same_structure(cur, rest))
        return;
    size_t n = ffd_gffd_skeleton_vertex_count(rest);
    double *from = scratch;
    double *to = scratch + 3 * n;
    double rot[3][3], shift[3];
    {
        ffd_gffd_skeleton_gather_vertices(rest, from);
        ffd_gffd_skeleton_gather_vertices(cur, to);
        /* a collinear skeleton does not determine a turn about its line: its
         * parts keep the turn they were given (ffd_gffd_skeleton_transform) */
        if (!is_collinear(from, n) && ffd_gffd_rigid_motion(from, to, n, rot, shift))
            for (size_t i = 0; i < cur->count; i++) {
                ffd_gffd_part *q = &cur->parts[i];
                const ffd_gffd_part *r = &rest->parts[i];
                if (!q->collinear || q->turned ||
                    memcmp(q->fit_vertices, r->geom.vertices,
                           q->geom.vertex_count * 3 * sizeof(double)) != 0 ||
                    memcmp(q->geom.vertices, r->geom.vertices,
                           q->geom.vertex_count * 3 * sizeof(double)) == 0)
                    continue;
                memcpy(q->rot, rot, sizeof rot);
                memcpy(q->shift, shift, sizeof shift);
                q->rigid = 1;
            }
    }
}

/* Where f_i can be below r_i: the geometry's box grown by the outer sample shell. */
static void set_box(ffd_gffd_part *q)
{
    double r = 4.0 / 3.0 * q->geom.radius;
    bounds_of(q->geom.vertices, q->geom.vertex_count, q->lo, q->hi);
    for (int k = 0; k < 3; k++) {
        q->lo[k] -= r;
        q->hi[k] += r;
    }
}

/* The least rotation taking unit a to unit b (Rodrigues about a x b). The
 * singular vectors of sigma u v^T come with signs that make sigma >= 0, so
 * u -> v keeps the line's orientation. Opposite directions cannot occur;
 * equal ones give the identity. */
static void minimal_rotation(const double a[3], const double b[3], double rot[3][3])
{
    double k[3] = {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
    double sn = sqrt(k[0] * k[0] + k[1] * k[1] + k[2] * k[2]);
    double cs = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    memset(rot, 0, 9 * sizeof(double));
    rot[0][0] = rot[1][1] = rot[2][2] = 1;
    if (!(sn > 0))
        return;
    for (int i = 0; i < 3; i++)
        k[i] /= sn;
    double kx[3][3] = {{0, -k[2], k[1]}, {k[2], 0, -k[0]}, {-k[1], k[0], 0}};
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            double kk = 0;
            for (int l = 0; l < 3; l++)
                kk += kx[i][l] * kx[l][j];
            rot[i][j] += sn * kx[i][j] + (1 - cs) * kk;
        }
}

/* 1 when rot from + shift == to within the rigid-motion tolerance. */
static int reproduces(double rot[3][3], const double shift[3], const double *from,
                      const double *to, size_t n)
{
    double size = n > 1 ? diagonal_of(from, n) : 1, worst = 0;
    for (size_t i = 0; i < n; i++)
        for (int k = 0; k < 3; k++) {
            double y = rot[k][0] * from[3 * i] + rot[k][1] * from[3 * i + 1] +
                       rot[k][2] * from[3 * i + 2] + shift[k];
            worst = fmax(worst, fabs(y - to[3 * i + k]));
        }
    return worst <= GFFD_TOL_RIGID * fmax(size, 1e-300) * 16;
}

/* 1 when to = rot * from + shift for a rotation rot (Kabsch: the SVD of the
 * cross-covariance), within GFFD_TOL_RIGID of the geometry's size. */
int ffd_gffd_rigid_motion(const double *from, const double *to, size_t n, double rot[3][3],
                          double shift[3])
{
    double cf[3] = {0, 0, 0}, ct[3] = {0, 0, 0};
    for (size_t i = 0; i < n; i++)
        for (int k = 0; k < 3; k++) {
            cf[k] += from[3 * i + k] / (double)n;
            ct[k] += to[3 * i + k] / (double)n;
        }
    double h[9] = {0}; /* column-major H = sum (from - cf)(to - ct)^T */
    for (size_t i = 0; i < n; i++)
        for (int a = 0; a < 3; a++)
            for (int b = 0; b < 3; b++)
                h[a + 3 * b] += (from[3 * i + a] - cf[a]) * (to[3 * i + b] - ct[b]);
    double u[9], s[3], vt[9];
    memset(rot, 0, 9 * sizeof(double));
    rot[0][0] = rot[1][1] = rot[2][2] = 1;
    if (n > 1) {
        if (ffd_dense_svd3(h, u, s, vt) != FFD_OK)
            return 0;
        if (!(s[1] > 1e-9 * s[0])) {
            /* collinear: the turn about the line is free; take the least
             * rotation taking its direction (U's first column) to the new
             * one (V's first column) */
            double a[3] = {u[0], u[1], u[2]}, b[3] = {vt[0], vt[3], vt[6]};
            if (s[0] > 0)
                minimal_rotation(a, b, rot);
            goto shifted;
        }
        /* R = V diag(1, 1, d) U^T, d = sign det(V U^T) */
        double m[3][3];
        for (int a = 0; a < 3; a++)
            for (int b = 0; b < 3; b++)
                m[a][b] = vt[0 + 3 * a] * u[b + 0] + vt[1 + 3 * a] * u[b + 3] + vt[2 + 3 * a] * u[b + 6];
        double det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
                     m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
                     m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
        double d = det < 0 ? -1 : 1;
        for (int a = 0; a < 3; a++)
            for (int b = 0; b < 3; b++)
                rot[a][b] = vt[0 + 3 * a] * u[b + 0] + vt[1 + 3 * a] * u[b + 3] +
                            d * vt[2 + 3 * a] * u[b + 6];
    }
shifted:
    for (int k = 0; k < 3; k++)
        shift[k] = ct[k] - (rot[k][0] * cf[0] + rot[k][1] * cf[1] + rot[k][2] * cf[2]);
    return reproduces(rot, shift, from, to, n);
}

/* (r2, t2) = (r, t) after (r1, t1): x -> r (r1 x + t1) + t. */
static void compose(double r[3][3], const double t[3], double r1[3][3], const double t1[3],
                    double r2[3][3], double t2[3])
{
    for (int a = 0; a < 3; a++) {
        for (int b = 0; b < 3; b++)
            r2[a][b] = r[a][0] * r1[0][b] + r[a][1] * r1[1][b] + r[a][2] * r1[2][b];
        t2[a] = r[a][0] * t1[0] + r[a][1] * t1[1] + r[a][2] * t1[2] + t[a];
    }
}


void ffd_gffd_skeleton_transform(ffd_gffd_skeleton *s, size_t index, const double rot[3][3],
                                 const double shift[3])
{
    ffd_gffd_part *q = &s->parts[index];
    double r1[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}, t1[3] = {0, 0, 0};
    if (q->rigid) {
        memcpy(r1, q->rot, sizeof r1);
        memcpy(t1, q->shift, sizeof t1);
    }
    double r[3][3];
    memcpy(r, rot, sizeof r);
    compose(r, shift, r1, t1, q->rot, q->shift);
    for (size_t i = 0; i < q->geom.vertex_count; i++) {
        double *x = q->geom.vertices + 3 * i, y[3];
        for (int k = 0; k < 3; k++)
            y[k] = rot[k][0] * x[0] + rot[k][1] * x[1] + rot[k][2] * x[2] + shift[k];
        memcpy(x, y, sizeof y);
    }
    q->rigid = 1;
    q->turned = 1;
    set_box(q);
}

int ffd_gffd_skeleton_motion(const ffd_gffd_skeleton *cur, const ffd_gffd_skeleton *rest,
                             double rot[3][3], double shift[3])
{
    if (!ffd_gffd_skeleton_same_structure(cur, rest))
        return 0;
    double lo[3], hi[3], d[3];
    ffd_gffd_skeleton_bounds(rest, lo, hi);
    sub3(hi, lo, d);
    double size = fmax(norm3(d), rest->max_radius);
    int moved = 0;
    for (size_t i = 0; i < cur->count; i++) {
        const ffd_gffd_part *q = &cur->parts[i], *r = &rest->parts[i];
        /* the field must be the rest one, moved */
        if (memcmp(q->fit_vertices, r->geom.vertices, q->geom.vertex_count * 3 * sizeof(double)))
            return 0;
        double r1[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}, t1[3] = {0, 0, 0};
        if (q->rigid) {
            memcpy(r1, q->rot, sizeof r1);
            memcpy(t1, q->shift, sizeof t1);
        }
        if (i == 0) {
            memcpy(rot, r1, sizeof r1);
            memcpy(shift, t1, sizeof t1);
        } else {
            for (int a = 0; a < 3; a++) {
                for (int b = 0; b < 3; b++)
                    if (!(fabs(rot[a][b] - r1[a][b]) <= GFFD_TOL_RIGID))
                        return 0;
                if (!(fabs(shift[a] - t1[a]) <= GFFD_TOL_RIGID * size))
                    return 0;
            }
        }
    }
    for (int a = 0; a < 3; a++) {
        moved |= shift[a] != 0;
        for (int b = 0; b < 3; b++)
            moved |= rot[a][b] != (a == b);
    }
    return moved;
}

int ffd_gffd_skeleton_nearest(const ffd_gffd_skeleton *s, const double x[3], double *f,
                              double grad[3], double *radius)
{
    int found = 0;
    double best = INFINITY;
    for (size_t i = 0; i < s->count; i++) {
        const ffd_gffd_part *q = &s->parts[i];
        if (x[0] < q->lo[0] || x[0] > q->hi[0] || x[1] < q->lo[1] || x[1] > q->hi[1] ||
            x[2] < q->lo[2] || x[2] > q->hi[2])
            continue;
        double fi, df[3];
        if (q->rigid) {
            double d[3] = {x[0] - q->shift[0], x[1] - q->shift[1], x[2] - q->shift[2]}, y[3], dy[3];
            for (int k = 0; k < 3; k++)
                y[k] = q->rot[0][k] * d[0] + q->rot[1][k] * d[1] + q->rot[2][k] * d[2];
            ffd_rbf_eval(&q->field, y, &fi, dy);
            for (int k = 0; k < 3; k++)
                df[k] = q->rot[k][0] * dy[0] + q->rot[k][1] * dy[1] + q->rot[k][2] * dy[2];
        } else {
            ffd_rbf_eval(&q->field, x, &fi, df);
        }
        if (fi / q->geom.radius < best) {
            best = fi / q->geom.radius;
            *f = fi;
            memcpy(grad, df, sizeof df);
            *radius = q->geom.radius;
            found = 1;
        }
    }
    return found;
}

int ffd_gffd_skeleton_own_motion(const ffd_gffd_skeleton *rest, const ffd_gffd_skeleton *cur,
                                 const double x[3], double rot[3][3], double shift[3])
{
    if (!ffd_gffd_skeleton_same_structure(cur, rest))
        return 0;
    size_t best = SIZE_MAX;
    double best_f = INFINITY;
    for (size_t i = 0; i < rest->count; i++) {
        const ffd_gffd_part *q = &rest->parts[i];
        if (x[0] < q->lo[0] || x[0] > q->hi[0] || x[1] < q->lo[1] || x[1] > q->hi[1] ||
            x[2] < q->lo[2] || x[2] > q->hi[2])
            continue;
        double f;
        ffd_rbf_eval(&q->field, x, &f, NULL); /* the rest fields are at their fit */
        if (f < q->geom.radius && f / q->geom.radius < best_f) {
            best_f = f / q->geom.radius;
            best = i;
        }
    }
    if (best == SIZE_MAX)
        return 0;
    const ffd_gffd_part *c = &cur->parts[best];
    if (!c->rigid || memcmp(c->fit_vertices, rest->parts[best].geom.vertices,
                            c->geom.vertex_count * 3 * sizeof(double)) != 0)
        return 0;
    memcpy(rot, c->rot, sizeof c->rot);
    memcpy(shift, c->shift, sizeof c->shift);
    return 1;
}

/* Samples the geometry and fits its distance field (§2, Fig. 1). */
static ffd_status fit_part(ffd_gffd_part *q, size_t index, size_t max_samples, ffd_error *err)
{
    double *samples = NULL, *values = NULL;
    size_t count = 0;
    ffd_rbf_factor factor;
    memset(&factor, 0, sizeof factor);
    ffd_rbf field;
    memset(&field, 0, sizeof field);
    ffd_error sub = {{0}};
    ffd_status st = ffd_gffd_samples(&q->geom, max_samples, &samples, &values, &count, &sub);
    if (st == FFD_OK)
        st = ffd_rbf_factor_create(samples, count, &factor, &sub);
    if (st == FFD_OK)
        st = ffd_rbf_fit(&factor, values, 1, &field, &sub);
    double *fit = NULL;
    if (st == FFD_OK && !(fit = ffd_malloc_array(q->geom.vertex_count, 3 * sizeof(double))))
        st = ffd_fail(&sub, FFD_ERR_NOMEM, "out of memory");
    if (st != FFD_OK) {
        ffd_fail(err, st, "skeleton[%zu]: %s", index, sub.message);
        ffd_rbf_free(&field);
    } else {
        ffd_rbf_free(&q->field);
        q->field = field;
        q->regularised = factor.regularised;
        memcpy(fit, q->geom.vertices, q->geom.vertex_count * 3 * sizeof(double));
        ffd_free(q->fit_vertices);
        q->fit_vertices = fit;
        memset(q->rot, 0, sizeof q->rot);
        q->rot[0][0] = q->rot[1][1] = q->rot[2][2] = 1;
        memset(q->shift, 0, sizeof q->shift);
        q->rigid = 0;
        q->turned = 0;
        set_box(q);
    }
    ffd_rbf_factor_free(&factor);
    ffd_free(samples);
    ffd_free(values);
    return st;
}

static ffd_status part_init(ffd_gffd_part *q, const ffd_gffd_primitive *p, size_t index,
                            size_t max_samples, ffd_error *err)
{
    memset(q, 0, sizeof *q);
    q->geom.kind = (int)p->kind;
    q->geom.radius = p->radius;
    q->geom.vertex_count = p->vertex_count;
    q->geom.vertices = ffd_malloc_array(p->vertex_count, 3 * sizeof(double));
    if (!q->geom.vertices)
        goto oom;
    memcpy(q->geom.vertices, p->vertices, p->vertex_count * 3 * sizeof(double));
    if (p->kind == FFD_GFFD_PATCH || p->kind == FFD_GFFD_POLYHEDRON) {
        size_t corners = p->face_offsets[p->face_count];
        q->face_count = p->face_count;
        q->face_offsets = ffd_malloc_array(p->face_count + 1, sizeof(uint32_t));
        q->face_indices = ffd_malloc_array(corners, sizeof(uint32_t));
        q->geom.tris = ffd_malloc_array(corners, 3 * sizeof(uint32_t));
        if (!q->face_offsets || !q->face_indices || !q->geom.tris)
            goto oom;
        memcpy(q->face_offsets, p->face_offsets, (p->face_count + 1) * sizeof(uint32_t));
        memcpy(q->face_indices, p->face_indices, corners * sizeof(uint32_t));
        size_t t = 0;
        for (size_t f = 0; f < p->face_count; f++) /* fan triangulation */
            for (uint32_t c = p->face_offsets[f] + 1; c + 1 < p->face_offsets[f + 1]; c++) {
                q->geom.tris[3 * t] = p->face_indices[p->face_offsets[f]];
                q->geom.tris[3 * t + 1] = p->face_indices[c];
                q->geom.tris[3 * t + 2] = p->face_indices[c + 1];
                t++;
            }
        q->geom.tri_count = t;
    }
    ffd_status st = fit_part(q, index, max_samples, err);
    if (st != FFD_OK)
        part_free(q);
    else
        q->collinear = is_collinear(q->geom.vertices, q->geom.vertex_count);
    return st;
oom:
    part_free(q);
    return ffd_fail(err, FFD_ERR_NOMEM, "skeleton[%zu]: out of memory", index);
}

void ffd_gffd_skeleton_destroy(ffd_gffd_skeleton *s)
{
    if (!s)
        return;
    for (size_t i = 0; i < s->count; i++)
        part_free(&s->parts[i]);
    ffd_free(s->parts);
    ffd_free(s);
}

ffd_status ffd_gffd_skeleton_create(const ffd_gffd_primitive *prims, size_t count,
                                    size_t max_samples, ffd_gffd_skeleton **out, ffd_error *err)
{
    *out = NULL;
    if (count == 0 || !prims)
        return ffd_fail(err, FFD_ERR_INVALID, "skeleton: expected at least one primitive");
    for (size_t i = 0; i < count; i++) {
        ffd_status st = check_primitive(&prims[i], i, err);
        if (st != FFD_OK)
            return st;
    }
    ffd_gffd_skeleton *s = ffd_calloc(1, sizeof *s);
    if (!s || !(s->parts = ffd_calloc(count, sizeof *s->parts))) {
        ffd_free(s);
        return ffd_fail(err, FFD_ERR_NOMEM, "skeleton: out of memory");
    }
    s->inv_unit = 1.0;
    for (size_t i = 0; i < count; i++) {
        ffd_status st = part_init(&s->parts[i], &prims[i], i, max_samples, err);
        if (st != FFD_OK) {
            ffd_gffd_skeleton_destroy(s);
            return st;
        }
        s->count = i + 1;
        s->max_radius = fmax(s->max_radius, prims[i].radius);
    }
    ffd_gffd_skeleton_set_unit(s, 1.0);
    *out = s;
    return FFD_OK;
}

void ffd_gffd_skeleton_set_unit(ffd_gffd_skeleton *s, double unit)
{
    s->inv_unit = 1.0 / unit;
    for (size_t i = 0; i < s->count; i++)
        s->parts[i].cutoff = exp(-s->parts[i].geom.radius * s->inv_unit);
}

static void describe_into(const ffd_gffd_part *q, ffd_gffd_primitive *p)
{
    memset(p, 0, sizeof *p);
    p->kind = (ffd_gffd_kind)q->geom.kind;
    p->vertices = q->geom.vertices;
    p->vertex_count = q->geom.vertex_count;
    p->face_offsets = q->face_offsets;
    p->face_indices = q->face_indices;
    p->face_count = q->face_count;
    p->radius = q->geom.radius;
}

void ffd_gffd_skeleton_describe(const ffd_gffd_skeleton *s, size_t index, ffd_gffd_primitive *out)
{
    describe_into(&s->parts[index], out);
}

static ffd_status copy_rbf(const ffd_rbf *a, ffd_rbf *b)
{
    *b = *a;
    b->centres = ffd_malloc_array(a->count, 3 * sizeof(double));
    b->weights = ffd_malloc_array(a->count, (size_t)a->dim * sizeof(double));
    if (!b->centres || !b->weights) {
        ffd_free(b->centres);
        ffd_free(b->weights);
        memset(b, 0, sizeof *b);
        return FFD_ERR_NOMEM;
    }
    memcpy(b->centres, a->centres, a->count * 3 * sizeof(double));
    memcpy(b->weights, a->weights, a->count * (size_t)a->dim * sizeof(double));
    return FFD_OK;
}

ffd_status ffd_gffd_skeleton_copy(const ffd_gffd_skeleton *s, ffd_gffd_skeleton **out,
                                  ffd_error *err)
{
    *out = NULL;
    ffd_gffd_skeleton *c = ffd_calloc(1, sizeof *c);
    if (!c || !(c->parts = ffd_calloc(s->count, sizeof *c->parts)))
        goto oom;
    c->inv_unit = s->inv_unit;
    c->max_radius = s->max_radius;
    for (size_t i = 0; i < s->count; i++) {
        const ffd_gffd_part *a = &s->parts[i];
        ffd_gffd_part *b = &c->parts[i];
        c->count = i + 1;
        *b = *a;
        b->geom.vertices = NULL;
        b->geom.tris = NULL;
        b->face_offsets = NULL;
        b->face_indices = NULL;
        b->fit_vertices = NULL;
        memset(&b->field, 0, sizeof b->field);
        b->fit_vertices = ffd_malloc_array(a->geom.vertex_count, 3 * sizeof(double));
        if (!b->fit_vertices)
            goto oom;
        memcpy(b->fit_vertices, a->fit_vertices, a->geom.vertex_count * 3 * sizeof(double));
        b->geom.vertices = ffd_malloc_array(a->geom.vertex_count, 3 * sizeof(double));
        if (!b->geom.vertices)
            goto oom;
        memcpy(b->geom.vertices, a->geom.vertices, a->geom.vertex_count * 3 * sizeof(double));
        if (a->geom.tris) {
            size_t corners = a->face_offsets[a->face_count];
            b->geom.tris = ffd_malloc_array(a->geom.tri_count, 3 * sizeof(uint32_t));
            b->face_offsets = ffd_malloc_array(a->face_count + 1, sizeof(uint32_t));
            b->face_indices = ffd_malloc_array(corners, sizeof(uint32_t));
            if (!b->geom.tris || !b->face_offsets || !b->face_indices)
                goto oom;
            memcpy(b->geom.tris, a->geom.tris, a->geom.tri_count * 3 * sizeof(uint32_t));
            memcpy(b->face_offsets, a->face_offsets, (a->face_count + 1) * sizeof(uint32_t));
            memcpy(b->face_indices, a->face_indices, corners * sizeof(uint32_t));
        }
        if (copy_rbf(&a->field, &b->field) != FFD_OK)
            goto oom;
    }
    *out = c;
    return FFD_OK;
oom:
    ffd_gffd_skeleton_destroy(c);
    return ffd_fail(err, FFD_ERR_NOMEM, "skeleton: out of memory");
}

ffd_status ffd_gffd_skeleton_set_vertices(ffd_gffd_skeleton *s, size_t index,
                                          const double *vertices, size_t max_samples,
                                          ffd_error *err)
{
    ffd_gffd_part *q = &s->parts[index];
    ffd_gffd_primitive p;
    describe_into(q, &p);
    p.vertices = vertices;
    ffd_status st = check_primitive(&p, index, err);
    if (st != FFD_OK)
        return st;
    double *v = ffd_malloc_array(q->geom.vertex_count, 3 * sizeof(double));
    if (!v)
        return ffd_fail(err, FFD_ERR_NOMEM, "skeleton[%zu]: out of memory", index);
    memcpy(v, vertices, q->geom.vertex_count * 3 * sizeof(double));
    double *old = q->geom.vertices;
    double lo[3], hi[3];
    memcpy(lo, q->lo, sizeof lo);
    memcpy(hi, q->hi, sizeof hi);
    q->geom.vertices = v;
    double rot[3][3], shift[3];
    if (memcmp(v, q->fit_vertices, q->geom.vertex_count * 3 * sizeof(double)) == 0) {
        q->rigid = 0; /* back where it was fitted */
        q->turned = 0;
        set_box(q);
        ffd_free(old);
        return FFD_OK;
    }
    if (q->collinear && q->rigid &&
        ffd_gffd_rigid_motion(old, v, q->geom.vertex_count, rot, shift)) {
        /* a point or a straight polyline: its vertices do not show its turn
         * about its line, so the new motion is composed with the one it had
         * (a turn given by ffd_gffd_skeleton_transform is kept), as long as
         * the composition still reproduces the vertices */
        double r2[3][3], t2[3];
        compose(rot, shift, q->rot, q->shift, r2, t2);
        if (reproduces(r2, t2, q->fit_vertices, v, q->geom.vertex_count)) {
            memcpy(q->rot, r2, sizeof r2);
            memcpy(q->shift, t2, sizeof t2);
            set_box(q);
            ffd_free(old);
            return FFD_OK;
        }
    }
    if (ffd_gffd_rigid_motion(q->fit_vertices, v, q->geom.vertex_count, rot, shift)) {
        /* a rigid edit moves the fitted field: exact, and no refit */
        memcpy(q->rot, rot, sizeof rot);
        memcpy(q->shift, shift, sizeof shift);
        q->rigid = 1;
        q->turned = 0;
        set_box(q);
        ffd_free(old);
        return FFD_OK;
    }
    st = fit_part(q, index, max_samples, err); /* keeps the old field on failure */
    if (st != FFD_OK) {
        q->geom.vertices = old;
        memcpy(q->lo, lo, sizeof lo);
        memcpy(q->hi, hi, sizeof hi);
        ffd_free(v);
        return st;
    }
    ffd_free(old);
    return FFD_OK;
}

size_t ffd_gffd_skeleton_vertex_count(const ffd_gffd_skeleton *s)
{
    size_t n = 0;
    for (size_t i = 0; i < s->count; i++)
        n += s->parts[i].geom.vertex_count;
    return n;
}

int ffd_gffd_skeleton_same_structure(const ffd_gffd_skeleton *a, const ffd_gffd_skeleton *b)
{
    if (a->count != b->count)
        return 0;
    for (size_t i = 0; i < a->count; i++) {
        const ffd_gffd_part *p = &a->parts[i], *q = &b->parts[i];
        if (p->geom.kind != q->geom.kind || p->geom.vertex_count != q->geom.vertex_count ||
            p->face_count != q->face_count)
            return 0;
        if (p->face_count &&
            (memcmp(p->face_offsets, q->face_offsets, (p->face_count + 1) * sizeof(uint32_t)) ||
             memcmp(p->face_indices, q->face_indices,
                    p->face_offsets[p->face_count] * sizeof(uint32_t))))
            return 0;
    }
    return 1;
}

void ffd_gffd_skeleton_gather_vertices(const ffd_gffd_skeleton *s, double *out)
{
    for (size_t i = 0; i < s->count; i++) {
        size_t n = s->parts[i].geom.vertex_count;
        memcpy(out, s->parts[i].geom.vertices, n * 3 * sizeof(double));
        out += 3 * n;
    }
}

void ffd_gffd_skeleton_bounds(const ffd_gffd_skeleton *s, double lo[3], double hi[3])
{
    bounds_of(s->parts[0].geom.vertices, s->parts[0].geom.vertex_count, lo, hi);
    for (size_t i = 1; i < s->count; i++) {
        double l[3], h[3];
        bounds_of(s->parts[i].geom.vertices, s->parts[i].geom.vertex_count, l, h);
        for (int k = 0; k < 3; k++) {
            lo[k] = fmin(lo[k], l[k]);
            hi[k] = fmax(hi[k], h[k]);
        }
    }
}

/* The blend weight of one primitive at field value f (see ffd_gffd_skeleton_weight):
 * the quintic smoothstep S(t) = t^3 (10 - 15 t + 6 t^2) of the depth
 * t = (r - f) / (band r) below the influence boundary, clamped to [0, 1]. S
 * and its first two derivatives vanish at t = 0 and S' and S'' at t = 1, so
 * the weight is C^2 wherever f is. */
static double band_weight(double f, double r)
{
    double t = (r - f) / (GFFD_BAND * r);
    if (!(t > 0))
        return 0;
    if (t >= 1)
        return 1;
    return t * t * t * (10 + t * (-15 + 6 * t));
}

/* Eq. 1-2: E = sum_i exp(-f_i/u) - exp(-r_i/u) where f_i < r_i; the
 * gradient is sum_i -(1/u) exp(-f_i/u) grad f_i over the same terms;
 * *weight (may be NULL): the largest band weight of the same terms. */
static double field_and_weight(const ffd_gffd_skeleton *s, const double x[3], double grad[3],
                               double *weight)
{
    double e = 0, g[3] = {0, 0, 0}, w = 0;
    for (size_t i = 0; i < s->count; i++) {
        const ffd_gffd_part *q = &s->parts[i];
        if (x[0] < q->lo[0] || x[0] > q->hi[0] || x[1] < q->lo[1] || x[1] > q->hi[1] ||
            x[2] < q->lo[2] || x[2] > q->hi[2])
            continue;
        double f, df[3];
        if (q->rigid) { /* the fitted field, moved: f(x) = f_fit(R^T (x - t)) */
            double d[3] = {x[0] - q->shift[0], x[1] - q->shift[1], x[2] - q->shift[2]}, y[3], dy[3];
            for (int k = 0; k < 3; k++)
                y[k] = q->rot[0][k] * d[0] + q->rot[1][k] * d[1] + q->rot[2][k] * d[2];
            ffd_rbf_eval(&q->field, y, &f, grad ? dy : NULL);
            if (grad)
                for (int k = 0; k < 3; k++)
                    df[k] = q->rot[k][0] * dy[0] + q->rot[k][1] * dy[1] + q->rot[k][2] * dy[2];
        } else {
            ffd_rbf_eval(&q->field, x, &f, grad ? df : NULL);
        }
        if (!(f < q->geom.radius))
            continue;
        double ex = exp(-f * s->inv_unit);
        e += ex - q->cutoff;
        if (weight)
            w = fmax(w, band_weight(f, q->geom.radius));
        if (grad) {
            double c = -s->inv_unit * ex;
            g[0] += c * df[0];
            g[1] += c * df[1];
            g[2] += c * df[2];
        }
    }
    if (grad) {
        grad[0] = g[0];
        grad[1] = g[1];
        grad[2] = g[2];
    }
    if (weight)
        *weight = w;
    return e;
}

double ffd_gffd_skeleton_field(const ffd_gffd_skeleton *s, const double x[3], double grad[3])
{
    return field_and_weight(s, x, grad, NULL);
}

double ffd_gffd_skeleton_field_weight(const ffd_gffd_skeleton *s, const double x[3],
                                      double *weight)
{
    return field_and_weight(s, x, NULL, weight);
}

/* ---- the warp's automatic correspondences ------------------------------ */

static size_t offsets_per_vertex(int kind)
{
    switch (kind) {
    case FFD_GFFD_POINT: return 6;
    case FFD_GFFD_POLYLINE: return 4;
    case FFD_GFFD_PATCH: return 2;
    default: return 0; /* a polyhedron's vertices span 3D already */
    }
}

size_t ffd_gffd_correspondence_count(const ffd_gffd_skeleton *rest)
{
    size_t n = 0;
    for (size_t i = 0; i < rest->count; i++)
        n += rest->parts[i].geom.vertex_count * (1 + offsets_per_vertex(rest->parts[i].geom.kind));
    return n;
}

static void normalise(double *a)
{
    double l = norm3(a);
    if (l > 0)
        for (int k = 0; k < 3; k++)
            a[k] /= l;
}

/* The direction that characterises vertex j of a part: a polyline's tangent,
 * a patch's area-weighted normal (zero when undefined). */
static void vertex_direction(const ffd_gffd_part *q, const double *v, size_t j, double dir[3])
{
    dir[0] = dir[1] = dir[2] = 0;
    if (q->geom.kind == FFD_GFFD_POLYLINE) {
        size_t a = j > 0 ? j - 1 : j, b = j + 1 < q->geom.vertex_count ? j + 1 : j;
        sub3(v + 3 * b, v + 3 * a, dir);
    } else if (q->geom.kind == FFD_GFFD_PATCH) {
        for (size_t t = 0; t < q->geom.tri_count; t++) {
            const uint32_t *c = q->geom.tris + 3 * t;
            if (c[0] != j && c[1] != j && c[2] != j)
                continue;
            double e1[3], e2[3];
            sub3(v + 3 * c[1], v + 3 * c[0], e1);
            sub3(v + 3 * c[2], v + 3 * c[0], e2);
            dir[0] += e1[1] * e2[2] - e1[2] * e2[1];
            dir[1] += e1[2] * e2[0] - e1[0] * e2[2];
            dir[2] += e1[0] * e2[1] - e1[1] * e2[0];
        }
    }
    normalise(dir);
}

/* Two unit vectors across the unit direction d. */
static void across(const double d[3], double u[3], double w[3])
{
    double a[3] = {1, 0, 0};
    if (fabs(d[0]) > 0.6) {
        a[0] = 0;
        a[1] = 1;
    }
    u[0] = d[1] * a[2] - d[2] * a[1];
    u[1] = d[2] * a[0] - d[0] * a[2];
    u[2] = d[0] * a[1] - d[1] * a[0];
    normalise(u);
    w[0] = d[1] * u[2] - d[2] * u[1];
    w[1] = d[2] * u[0] - d[0] * u[2];
    w[2] = d[0] * u[1] - d[1] * u[0];
}

void ffd_gffd_correspondences(const ffd_gffd_skeleton *rest, const ffd_gffd_skeleton *cur,
                              double *from, double *to)
{
    size_t k = 0;
    for (size_t i = 0; i < rest->count; i++) {
        const ffd_gffd_part *r = &rest->parts[i], *c = &cur->parts[i];
        size_t per = offsets_per_vertex(r->geom.kind);
        double h = 0.5 * r->geom.radius;
        for (size_t j = 0; j < r->geom.vertex_count; j++) {
            const double *a = r->geom.vertices + 3 * j, *b = c->geom.vertices + 3 * j;
            if (from)
                memcpy(from + 3 * k, a, 3 * sizeof(double));
            if (to)
                memcpy(to + 3 * k, b, 3 * sizeof(double));
            k++;
            if (per == 0)
                continue;
            /* the local turn: the part's own rigid motion, else the least
             * rotation of the vertex's direction (a point: none) */
            double rot[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
            double dr[3], dc[3], offs[6][3];
            vertex_direction(r, r->geom.vertices, j, dr);
            if (c->rigid && memcmp(c->fit_vertices, r->geom.vertices,
                                   r->geom.vertex_count * 3 * sizeof(double)) == 0) {
                memcpy(rot, c->rot, sizeof rot);
            } else if (per != 6) {
                vertex_direction(c, c->geom.vertices, j, dc);
                if (norm3(dr) > 0 && norm3(dc) > 0)
                    minimal_rotation(dr, dc, rot);
            }
            if (per == 6) {
                memset(offs, 0, sizeof offs);
                for (int m = 0; m < 3; m++) {
                    offs[2 * m][m] = h;
                    offs[2 * m + 1][m] = -h;
                }
            } else if (per == 4) {
                double u[3], w[3];
                if (!(norm3(dr) > 0))
                    dr[0] = 1;
                across(dr, u, w);
                for (int m = 0; m < 3; m++) {
                    offs[0][m] = h * u[m];
                    offs[1][m] = -h * u[m];
                    offs[2][m] = h * w[m];
                    offs[3][m] = -h * w[m];
                }
            } else {
                for (int m = 0; m < 3; m++) {
                    offs[0][m] = h * dr[m];
                    offs[1][m] = -h * dr[m];
                }
            }
            for (size_t o = 0; o < per; o++) {
                for (int m = 0; m < 3; m++) {
                    if (from)
                        from[3 * k + m] = a[m] + offs[o][m];
                    if (to)
                        to[3 * k + m] = b[m] + rot[m][0] * offs[o][0] + rot[m][1] * offs[o][1] +
                                    rot[m][2] * offs[o][2];
                }
                k++;
            }
        }
    }
}
