/* gffd — exact distances from a point to a primitive's geometry: point,
 * segment, triangle, polyline, polygon mesh (unsigned), closed polygon mesh
 * (signed: negative inside, by ray parity). */
#include "gffd/gffd.h"

#include <assert.h>
#include <math.h>

/* A triangle whose height over its longest edge is below this times that
 * edge is measured as its edges (the longest one when exactly collinear). */
#define TRI_DEGENERATE 1e-10

/* A ray that meets a triangle within this barycentric distance of its
 * boundary grazes an edge or a vertex: the vote discards it. */
#define RAY_GRAZE 1e-9

/* A ray within this relative angle of a triangle's plane (relative to the
 * product of two edges) from a point within RAY_INPLANE (relative to the
 * distances involved) of the plane may run along the triangle. */
#define RAY_PARALLEL 1e-12
#define RAY_INPLANE 1e-9




double ffd_dist2_point_segment(const double p[3], const double a[3], const double b[3])
{
    double ab[3], ap[3];
    sub3(b, a, ab);
    sub3(p, a, ap);
    double t = dot3(ap, ab), l2 = dot3(ab, ab);
    if (t <= 0 || l2 == 0)
        return dot3(ap, ap);
    if (t >= l2) {
        double bp[3];
        sub3(p, b, bp);
        return dot3(bp, bp);
    }
    /* interior: the distance to the line, |ap x ab|^2 / |ab|^2 (no cancellation) */
    double c[3];
    cross3(ap, ab, c);
    return dot3(c, c) / l2;
}

double ffd_dist2_point_triangle(const double p[3], const double a[3], const double b[3],
                                const double c[3])
{
    /* relabel so that v[0] is opposite the longest edge: the normal is the
     * cross product of the two shorter edges, the most accurate one */
    const double *v[3] = {a, b, c};
    double e[3][3], l2[3];
    sub3(c, b, e[0]); /* opposite a */
    sub3(a, c, e[1]); /* opposite b */
    sub3(b, a, e[2]); /* opposite c */
    for (int k = 0; k < 3; k++)
        l2[k] = dot3(e[k], e[k]);
    int o = 0;
    if (l2[1] > l2[o])
        o = 1;
    if (l2[2] > l2[o])
        o = 2;
    const double *A = v[o], *B = v[(o + 1) % 3], *C = v[(o + 2) % 3];
    double ab[3], ac[3], n[3];
    sub3(B, A, ab);
    sub3(C, A, ac);
    cross3(ab, ac, n);
    double nn = dot3(n, n), lmax2 = l2[o];
    /* height over the longest edge = |n| / lmax */
    if (!(nn > TRI_DEGENERATE * TRI_DEGENERATE * lmax2 * lmax2)) {
        double d0 = ffd_dist2_point_segment(p, a, b), d1 = ffd_dist2_point_segment(p, b, c),
               d2 = ffd_dist2_point_segment(p, c, a);
        double d = d0 < d1 ? d0 : d1;
        return d < d2 ? d : d2;
    }
    /* scaled barycentric coordinates of p's projection: n . (edge-wise cross products) */
    double ap[3], bp[3], cp[3], t[3];
    sub3(p, A, ap);
    sub3(p, B, bp);
    sub3(p, C, cp);
    cross3(bp, cp, t);
    double wa = dot3(n, t);
    cross3(cp, ap, t);
    double wb = dot3(n, t);
    cross3(ap, bp, t);
    double wc = dot3(n, t);
    if (wa >= 0 && wb >= 0 && wc >= 0) {
        double h = dot3(ap, n);
        return h * h / nn;
    }
    /* outside: the closest point is on an edge whose line separates p's
     * projection from the triangle (a negative coordinate) */
    double best = INFINITY;
    if (wa < 0) {
        double d = ffd_dist2_point_segment(p, B, C);
        best = d < best ? d : best;
    }
    if (wb < 0) {
        double d = ffd_dist2_point_segment(p, C, A);
        best = d < best ? d : best;
    }
    if (wc < 0) {
        double d = ffd_dist2_point_segment(p, A, B);
        best = d < best ? d : best;
    }
    return best;
}

static const double *vtx(const ffd_gffd_geometry *g, uint32_t i)
{
    return g->vertices + 3 * (size_t)i;
}

static double tris_dist2(const ffd_gffd_geometry *g, const double x[3])
{
    double best = INFINITY;
    for (size_t t = 0; t < g->tri_count; t++) {
        const uint32_t *tri = g->tris + 3 * t;
        double d = ffd_dist2_point_triangle(x, vtx(g, tri[0]), vtx(g, tri[1]), vtx(g, tri[2]));
        if (d < best)
            best = d;
    }
    return best;
}

/* Crossings of the ray x + t dir (t > 0) with the triangles: 1 (odd), 0
 * (even), or -1 when the ray grazes an edge or a vertex or runs along a
 * triangle (the count would be unreliable). */
static int ray_parity(const ffd_gffd_geometry *g, const double x[3], const double dir[3])
{
    int crossings = 0;
    for (size_t t = 0; t < g->tri_count; t++) {
        const uint32_t *tri = g->tris + 3 * t;
        const double *a = vtx(g, tri[0]), *b = vtx(g, tri[1]), *c = vtx(g, tri[2]);
        double e1[3], e2[3], pv[3], tv[3], qv[3];
        sub3(b, a, e1);
        sub3(c, a, e2);
        cross3(dir, e2, pv);
        double det = dot3(e1, pv); /* = dir . (e2 x e1) */
        sub3(x, a, tv);
        if (fabs(det) <= RAY_PARALLEL * sqrt(dot3(e1, e1) * dot3(e2, e2))) {
            /* (nearly) parallel to the plane: harmless unless x lies in it */
            double n[3];
            cross3(e1, e2, n);
            double h = fabs(dot3(tv, n)) / sqrt(dot3(n, n));
            double reach = sqrt(dot3(tv, tv)) + sqrt(dot3(e1, e1)) + sqrt(dot3(e2, e2));
            if (!(h > RAY_INPLANE * reach))
                return -1;
            continue;
        }
        double inv = 1.0 / det;
        double u = dot3(tv, pv) * inv;
        if (u < -RAY_GRAZE || u > 1 + RAY_GRAZE)
            continue;
        cross3(tv, e1, qv);
        double v = dot3(dir, qv) * inv;
        if (v < -RAY_GRAZE || u + v > 1 + RAY_GRAZE)
            continue;
        double s = dot3(e2, qv) * inv;
        if (s <= 0)
            continue;
        if (u < RAY_GRAZE || v < RAY_GRAZE || u + v > 1 - RAY_GRAZE)
            return -1;
        crossings++;
    }
    return crossings & 1;
}

/* Unit directions with no simple relation to axes, diagonals or each other
 * (spherical Fibonacci points under an irrational rotation). */
static const double ray_dirs[][3] = {
    {-0.24932305613824055, -0.039399199811046726, 0.96761858019166669},
    {0.72149765635536223, -0.45780369040816116, 0.51947753841950506},
    {-0.79127019597248438, -0.57120189351076145, 0.21821978328141309},
    {0.32628476696361358, 0.73137300213911105, 0.59885873341675855},
    {0.38978036747620348, -0.82970930155934053, -0.39956694061950021},
    {-0.88673572132340817, 0.46163569891743778, -0.024336022971386262},
    {0.85232268389032417, 0.44124199471759407, -0.28080517200299765},
    {-0.36796409475598713, -0.29474853886826941, -0.88188759136605799},
    {-0.10235218433876422, 0.78799569799076696, -0.60711350694011712},
};

/* Inside a closed triangle mesh: the majority of three rays' parities,
 * skipping rays that graze an edge or a vertex. */
static int polyhedron_inside(const ffd_gffd_geometry *g, const double x[3])
{
    int votes = 0, in = 0;
    size_t nd = sizeof ray_dirs / sizeof ray_dirs[0];
    for (size_t k = 0; k < nd && votes < 3; k++) {
        int p = ray_parity(g, x, ray_dirs[k]);
        if (p < 0)
            continue;
        votes++;
        in += p;
    }
    /* no clean ray in nine directions: x lies on (or within rounding of) the surface */
    return votes > 0 && 2 * in > votes;
}

double ffd_gffd_geometry_distance(const ffd_gffd_geometry *g, const double x[3])
{
    switch (g->kind) {
    case FFD_GFFD_POINT: {
        double d[3];
        sub3(x, g->vertices, d);
        return sqrt(dot3(d, d));
    }
    case FFD_GFFD_POLYLINE: {
        double best = INFINITY;
        for (size_t i = 0; i + 1 < g->vertex_count; i++) {
            double d = ffd_dist2_point_segment(x, g->vertices + 3 * i, g->vertices + 3 * i + 3);
            if (d < best)
                best = d;
        }
        return sqrt(best);
    }
    case FFD_GFFD_PATCH:
        return sqrt(tris_dist2(g, x));
    case FFD_GFFD_POLYHEDRON: {
        double d = sqrt(tris_dist2(g, x));
        if (d == 0)
            return 0;
        return polyhedron_inside(g, x) ? -d : d;
    }
    default:
        assert(!"unknown primitive kind");
        return NAN;
    }
}
