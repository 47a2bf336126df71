/* pbffd — automatic placement of control points (PB-FFD, McDonnell & Qin,
 * §3.2.1 and Figure 2; open surfaces §3.2.3).
 *
 * Closed meshes: the Voronoi vertices of (a subsample of) the mesh vertices
 * approximate the medial axis; those on the inner side of the surface (the
 * paper's test against the nearest vertex r and its normal n: outside when
 * n.(q - r) > 0, confirmed by ray parity against the faces, since on its own
 * the test passes ~3% outside points on the cow) are decimated to the
 * interior points, and a merged midpoint that lands outside moves to the
 * nearest inside candidate; the vertices pushed out along their normals are
 * decimated to the exterior points. Open meshes
 * have no inside: the vertices pushed both ways are decimated together.
 * Every point becomes an EBF with an axis-aligned frame whose lengths equal
 * its ROI radius, radius_factor times the distance to the nearest other
 * point. Then the radii grow where a vertex lies under fewer than two ROIs,
 * so the deformation has no seams (§3.2.2 keeps the master for the rest). */
#include "math/spatial.h"
#include "math/tolerance.h"
#include "math/voronoi.h"
#include "mesh/mesh.h"
#include "mesh/mesh_cells.h"
#include "pbffd/placement.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#define DEFAULT_INTERIOR 60
#define DEFAULT_EXTERIOR 60
/* of the bounding-box diagonal: the paper's 10% of the bounding-sphere radius */
#define DEFAULT_OFFSET 0.05
#define DEFAULT_RADIUS_FACTOR 1.5
#define DEFAULT_VORONOI_SITES 8000
/* Voronoi vertices this far (times the diagonal) outside the bounding box are dropped. */
#define BBOX_SLACK 1e-3
/* A vertex whose summed face normals are this short relative to the sum of
 * their lengths has none (they cancel). */
#define NORMAL_CANCEL 1e-9
/* A vertex is made to lie strictly inside a grown ROI: rho = 1/1.0001. */
#define COVER_MARGIN 1.0001

static double dot3(const double *a, const double *b)
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static double dist2(const double *a, const double *b)
{
    double dx = a[0] - b[0], dy = a[1] - b[1], dz = a[2] - b[2];
    return dx * dx + dy * dy + dz * dz;
}

/* Area-weighted vertex normals (unit, or zero for a vertex without one: no
 * face with area uses it, or its faces' normals cancel, as on both sides of
 * a sheet): faces are fanned from their first corner, and each fan
 * triangle's cross product (twice its area times its normal) is added to
 * the face's corners. *volume receives the signed volume the faces enclose.
 * weight is #V scratch. */
/* The faces in their canonical order (mesh/mesh_cells.h): the sums over
 * faces below run in it, so the placement depends on the set of faces, not
 * on their order in the file: a distributed run, which gathers the surface
 * from the ranks in another order (deformer/distributed.c), places the same
 * bits. NULL when out of memory. */
static uint32_t *canonical_faces(const ffd_mesh *mesh)
{
    uint32_t *order = NULL;
    return ffd_faces_canonical_order(mesh->face_offsets, mesh->face_indices, mesh->face_count,
                                     &order, NULL)
               ? order
               : NULL;
}

static void vertex_normals(const ffd_mesh *mesh, const uint32_t *order, double *normals,
                           double *weight, double *volume)
{
    const double *x = mesh->positions;
    size_t nv = mesh->vertex_count;
    memset(normals, 0, 3 * nv * sizeof *normals);
    memset(weight, 0, nv * sizeof *weight);
    double vol6 = 0;
    for (size_t i = 0; i < mesh->face_count; i++) {
        size_t f = order[i];
        uint32_t b = mesh->face_offsets[f], e = mesh->face_offsets[f + 1];
        if (e - b < 3)
            continue;
        double fn[3] = {0, 0, 0};
        const double *a = x + 3 * (size_t)mesh->face_indices[b];
        for (uint32_t k = b + 1; k + 1 < e; k++) {
            const double *p = x + 3 * (size_t)mesh->face_indices[k];
            const double *q = x + 3 * (size_t)mesh->face_indices[k + 1];
            double u[3] = {p[0] - a[0], p[1] - a[1], p[2] - a[2]};
            double v[3] = {q[0] - a[0], q[1] - a[1], q[2] - a[2]};
            double c[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2],
                           u[0] * v[1] - u[1] * v[0]};
            for (int d = 0; d < 3; d++)
                fn[d] += c[d];
            /* a . (p x q) is 6 times the signed volume of (origin, a, p, q) */
            vol6 += a[0] * (p[1] * q[2] - p[2] * q[1]) - a[1] * (p[0] * q[2] - p[2] * q[0]) +
                    a[2] * (p[0] * q[1] - p[1] * q[0]);
        }
        double area2 = sqrt(dot3(fn, fn));
        for (uint32_t k = b; k < e; k++) {
            size_t v = mesh->face_indices[k];
            for (int d = 0; d < 3; d++)
                normals[3 * v + d] += fn[d];
            weight[v] += area2;
        }
    }
    for (size_t i = 0; i < nv; i++) {
        double *n = normals + 3 * i;
        double len = sqrt(dot3(n, n));
        if (len > NORMAL_CANCEL * weight[i] && isfinite(len))
            for (int d = 0; d < 3; d++)
                n[d] /= len;
        else
            n[0] = n[1] = n[2] = 0;
    }
    *volume = vol6 / 6.0;
}

/* Step 2 of Figure 2 for each Voronoi vertex q: inside the slightly grown
 * bounding box, on the inner side of its nearest surface vertex r,
 * n.(q - r) < 0 (the paper discards n.(q - r)/|q - r| > 0; q == r is
 * discarded too), and, since that test is a heuristic that lets through a
 * few percent of outside points near thin or concave parts (which closest-
 * pair decimation then keeps, being isolated), confirmed by ray parity
 * against the faces. Compacts the kept ones to the front; returns how many. */
static size_t keep_inside(double *q, size_t count, const ffd_kdtree *tree, const size_t *surface,
                          const double *x, const double *normals, const ffd_inside_index *solid,
                          const double lo[3], const double hi[3], unsigned char *keep)
{
    long long m = (long long)count;
#pragma omp parallel for schedule(dynamic, 256)
    for (long long ii = 0; ii < m; ii++) {
        size_t i = (size_t)ii;
        const double *p = q + 3 * i;
        keep[i] = 0;
        if (p[0] < lo[0] || p[1] < lo[1] || p[2] < lo[2] || p[0] > hi[0] || p[1] > hi[1] ||
            p[2] > hi[2])
            continue;
        if (!ffd_inside_index_test(solid, p)) /* the cheaper test first */
            continue;
        size_t r = surface[ffd_kdtree_nearest(tree, p, NULL)];
        double d[3] = {p[0] - x[3 * r], p[1] - x[3 * r + 1], p[2] - x[3 * r + 2]};
        keep[i] = dot3(normals + 3 * r, d) < 0;
    }
    size_t kept = 0;
    for (size_t i = 0; i < count; i++)
        if (keep[i]) {
            memmove(q + 3 * kept, q + 3 * i, 3 * sizeof *q);
            kept++;
        }
    return kept;
}

/* The faces fanned into triangles (3 indices each); *nt receives the count. */
static uint32_t *fan_triangles(const ffd_mesh *mesh, const uint32_t *order, size_t *nt)
{
    size_t n = 0;
    for (size_t f = 0; f < mesh->face_count; f++) {
        uint32_t k = mesh->face_offsets[f + 1] - mesh->face_offsets[f];
        n += k >= 3 ? k - 2 : 0;
    }
    uint32_t *t = ffd_malloc_array(n ? 3 * n : 1, sizeof *t);
    if (!t)
        return NULL;
    size_t at = 0;
    for (size_t i = 0; i < mesh->face_count; i++) {
        uint32_t b = mesh->face_offsets[order[i]], e = mesh->face_offsets[order[i] + 1];
        for (uint32_t k = b + 1; k + 1 < e; k++) {
            t[at++] = mesh->face_indices[b];
            t[at++] = mesh->face_indices[k];
            t[at++] = mesh->face_indices[k + 1];
        }
    }
    *nt = n;
    return t;
}

/* A midpoint of two inside points can fall outside (a merge across a
 * concave region): such an interior point moves to the nearest inside
 * candidate that is not already a point. */
static ffd_status snap_inside(double *points, size_t m, const double *cand, size_t nc,
                              const ffd_inside_index *solid, ffd_error *err)
{
    size_t out = 0;
    for (size_t j = 0; j < m; j++)
        out += !ffd_inside_index_test(solid, points + 3 * j);
    if (!out)
        return FFD_OK;
    ffd_kdtree *tree = NULL;
    ffd_status status = ffd_kdtree_create(cand, nc, &tree, err);
    if (status != FFD_OK)
        return status;
    enum { TRY = 16 };
    for (size_t j = 0; j < m; j++) {
        if (ffd_inside_index_test(solid, points + 3 * j))
            continue;
        size_t idx[TRY];
        double d2s[TRY];
        size_t k = ffd_kdtree_k_nearest(tree, points + 3 * j, TRY, idx, d2s);
        for (size_t t = 0; t < k; t++) {
            const double *c = cand + 3 * idx[t];
            int taken = 0;
            for (size_t i = 0; i < m && !taken; i++)
                taken = i != j && memcmp(points + 3 * i, c, 3 * sizeof *c) == 0;
            if (!taken) {
                memcpy(points + 3 * j, c, 3 * sizeof *c);
                break;
            }
        }
    }
    ffd_kdtree_destroy(tree);
    return FFD_OK;
}

/* A fixed value in [-1, 1) for (index, axis): splitmix64 of the pair. */
static double site_hash(size_t index, int axis)
{
    uint64_t z = (uint64_t)index * 3u + (uint64_t)axis + 0x9E3779B97F4A7C15ull;
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    z ^= z >> 31;
    return (double)(z >> 11) * (2.0 / 9007199254740992.0) - 1.0;
}

/* An interior point closer than tol to an earlier kept one is the same
 * medial point and goes (the kept one is inside). Compacts points[0..m) and
 * returns the count left. */
static size_t weld(double *points, size_t m, double tol)
{
    size_t kept = 0;
    for (size_t j = 0; j < m; j++) {
        int near = 0;
        for (size_t k = 0; k < kept && !near; k++)
            near = dist2(points + 3 * j, points + 3 * k) < tol * tol;
        if (!near)
            memmove(points + 3 * kept++, points + 3 * j, 3 * sizeof *points);
    }
    return kept;
}

/* Number of controls (capped at need) whose ROI holds x strictly. */
static size_t support(const ffd_ebf *c, size_t m, const double *x, size_t need)
{
    size_t s = 0;
    for (size_t j = 0; j < m && s < need; j++)
        if (dist2(x, c[j].center) < c[j].radius[0] * c[j].radius[0])
            s++;
    return s;
}

static void set_radius(ffd_ebf *c, double r)
{
    memset(c->frame, 0, sizeof c->frame);
    for (int a = 0; a < 3; a++) {
        c->frame[a][a] = r;
        c->radius[a] = r;
    }
}

/* Grows ROIs until every surface vertex (the ns vertices of surface: those
 * with a normal, in vertex order) lies in at least need of them: for each
 * under fewer, its nearest controls that miss it grow to reach it with a
 * small margin. Only the boundary counts, as for every step of the
 * placement: a volume mesh's interior nodes do not, so the placement is a
 * function of the boundary surface alone (what a distributed run gathers).
 * Returns the number of grown controls, or SIZE_MAX when out of memory. */
static size_t cover(ffd_ebf *c, size_t m, const double *x, const size_t *surface, size_t nv)
{
    size_t need = m < 2 ? m : 2;
    if (need == 0)
        return 0;
    unsigned char *low = ffd_malloc(nv ? nv : 1);
    unsigned char *grown = ffd_calloc(m, 1);
    double *centres = ffd_malloc_array(3 * m, sizeof *centres);
    ffd_kdtree *tree = NULL;
    size_t result = SIZE_MAX;
    if (!low || !grown || !centres)
        goto done;
    for (size_t j = 0; j < m; j++)
        memcpy(centres + 3 * j, c[j].center, sizeof c[j].center);
    if (ffd_kdtree_create(centres, m, &tree, NULL) != FFD_OK)
        goto done;
    long long n = (long long)nv;
#pragma omp parallel for schedule(static)
    for (long long ii = 0; ii < n; ii++)
        low[ii] = support(c, m, x + 3 * surface[ii], need) < need;
    for (size_t i = 0; i < nv; i++) {
        if (!low[i])
            continue;
        const double *v = x + 3 * surface[i];
        size_t have = support(c, m, v, need);
        size_t near[2];
        double d2[2];
        size_t k = ffd_kdtree_k_nearest(tree, v, need, near, d2);
        for (size_t t = 0; t < k && have < need; t++) {
            ffd_ebf *e = c + near[t];
            if (d2[t] < e->radius[0] * e->radius[0])
                continue; /* already holds v */
            set_radius(e, sqrt(d2[t]) * COVER_MARGIN);
            grown[near[t]] = 1;
            have++;
        }
    }
    result = 0;
    for (size_t j = 0; j < m; j++)
        result += grown[j];
done:
    ffd_kdtree_destroy(tree);
    ffd_free(low);
    ffd_free(grown);
    ffd_free(centres);
    return result;
}

ffd_status ffd_pbffd_place(const ffd_mesh *mesh, const ffd_placement_options *options,
                           ffd_ebf **controls, size_t *count, ffd_placement_report *report,
                           ffd_error *err)
{
    double t_start = ffd_now();
    ffd_placement_report rep;
    memset(&rep, 0, sizeof rep);
    if (controls)
        *controls = NULL;
    if (count)
        *count = 0;
    if (!mesh || !controls || !count)
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_pbffd_place: NULL argument");

    ffd_placement_options opt;
    memset(&opt, 0, sizeof opt);
    if (options)
        opt = *options;
    if (!opt.interior_count)
        opt.interior_count = DEFAULT_INTERIOR;
    if (!opt.exterior_count)
        opt.exterior_count = DEFAULT_EXTERIOR;
    if (!isfinite(opt.offset) || opt.offset < 0 || opt.offset > 1)
        return ffd_fail(err, FFD_ERR_INVALID,
                        "placement: offset %g: expected a fraction of the bounding-box diagonal "
                        "in (0, 1]",
                        opt.offset);
    if (opt.offset == 0)
        opt.offset = DEFAULT_OFFSET;
    if (!isfinite(opt.radius_factor) || opt.radius_factor < 0 || opt.radius_factor > 100)
        return ffd_fail(err, FFD_ERR_INVALID,
                        "placement: radius_factor %g: expected a number in (0, 100]",
                        opt.radius_factor);
    if (opt.radius_factor == 0)
        opt.radius_factor = DEFAULT_RADIUS_FACTOR;
    if (!opt.voronoi_sites)
        opt.voronoi_sites = DEFAULT_VORONOI_SITES;
    if (opt.surface != FFD_SURFACE_AUTO && opt.surface != FFD_SURFACE_CLOSED &&
        opt.surface != FFD_SURFACE_OPEN)
        return ffd_fail(err, FFD_ERR_INVALID, "placement: unknown surface kind %d",
                        (int)opt.surface);

    size_t nv = mesh->vertex_count;
    if (mesh->face_count == 0)
        return ffd_fail(err, FFD_ERR_INVALID, "placement: the mesh has no faces");
    ffd_mesh_info info;
    ffd_status status = ffd_mesh_compute_info(mesh, &info, err);
    if (status != FFD_OK)
        return status;
    const double *x = mesh->positions;
    for (size_t i = 0; i < 3 * nv; i++) {
        if (!isfinite(x[i]))
            return ffd_fail(err, FFD_ERR_NONFINITE, "placement: vertex %zu is not finite", i / 3);
        if (fabs(x[i]) > FFD_PB_MAX_COORD)
            return ffd_fail(err, FFD_ERR_INVALID,
                            "placement: vertex %zu: coordinate %g is beyond the supported range "
                            "(|x| <= 1e100)",
                            i / 3, x[i]);
    }
    double ext[3], diag = 0, largest = 0;
    for (int a = 0; a < 3; a++) {
        ext[a] = info.bbox_max[a] - info.bbox_min[a];
        largest = fmax(largest, ext[a]);
    }
    for (int a = 0; a < 3 && largest > 0; a++) /* scaled: a 1e-300 box does not underflow */
        diag += (ext[a] / largest) * (ext[a] / largest);
    diag = largest * sqrt(diag);
    if (!(diag > 0) || !isfinite(diag))
        return ffd_fail(err, FFD_ERR_INVALID, "placement: the mesh's vertices all coincide");
    if (diag < 1e-90)
        return ffd_fail(err, FFD_ERR_INVALID,
                        "placement: the mesh is too small (bounding-box diagonal %g < 1e-90)",
                        diag);

    /* the surface kind */
    int defects = !info.closed || info.nonmanifold_edge_count > 0;
    rep.open = opt.surface == FFD_SURFACE_OPEN || defects;
    if (rep.open && opt.surface != FFD_SURFACE_OPEN) {
        rep.fell_back = 1;
        snprintf(rep.note, sizeof rep.note,
                 "%s has %zu boundary and %zu non-manifold edges: placed as an open surface "
                 "(PB-FFD 3.2.3) without interior points",
                 opt.surface == FFD_SURFACE_CLOSED ? "a closed surface was asked for but the mesh"
                                                   : "the mesh",
                 info.boundary_edge_count, info.nonmanifold_edge_count);
    } else if (rep.open) {
        snprintf(rep.note, sizeof rep.note,
                 "placed as an open surface as asked (PB-FFD 3.2.3), without interior points");
    }

    /* progress: the steps' rough shares of the time (ffd_set_progress) */
    ffd_progress progress;
    ffd_progress_begin(&progress, "placement");
    double *normals = ffd_malloc_array(3 * (nv ? nv : 1), sizeof *normals);
    size_t *surface = ffd_malloc_array(nv ? nv : 1, sizeof *surface);
    double *candidates = NULL, *voronoi = NULL, *points = NULL, *spos = NULL;
    unsigned char *keep = NULL;
    ffd_kdtree *tree = NULL;
    ffd_inside_index *solid = NULL;
    uint32_t *tris = NULL, *order = canonical_faces(mesh);
    ffd_ebf *ebf = NULL;
    size_t interior = 0, exterior = 0;
    double *weight = ffd_malloc_array(nv ? nv : 1, sizeof *weight);
    if (!normals || !surface || !weight || !order) {
        ffd_free(weight);
        goto nomem;
    }
    double volume = 0;
    vertex_normals(mesh, order, normals, weight, &volume);
    ffd_free(weight);
    if (!rep.open && volume < 0)
        for (size_t i = 0; i < 3 * nv; i++)
            normals[i] = -normals[i];
    size_t ns = 0; /* vertices with a normal: the surface samples */
    for (size_t i = 0; i < nv; i++)
        if (normals[3 * i] != 0 || normals[3 * i + 1] != 0 || normals[3 * i + 2] != 0)
            surface[ns++] = i;
    if (ns == 0) {
        status = ffd_fail(err, FFD_ERR_INVALID,
                          "placement: no vertex has a normal (faces of zero area, or faces on "
                          "both sides of a sheet)");
        goto fail;
    }

    /* Steps 6-7 (or §3.2.3): offset copies of the vertices. */
    double off = opt.offset * diag;
    size_t copies = rep.open ? 2 : 1;
    size_t nc = copies * ns;
    exterior = opt.exterior_count;
    if (exterior > nc) {
        status = ffd_fail(err, FFD_ERR_INVALID,
                          "%zu exterior points asked for: only %zu candidate points (%s %zu mesh vertices "
                          "with a normal)",
                          exterior, nc, rep.open ? "offset both ways from the" : "offset from the",
                          ns);
        goto fail;
    }
    candidates = ffd_malloc_array(3 * nc, sizeof *candidates);
    if (!candidates)
        goto nomem;
    for (size_t k = 0; k < ns; k++) {
        const double *v = x + 3 * surface[k], *n = normals + 3 * surface[k];
        for (int a = 0; a < 3; a++) {
            candidates[3 * k + a] = v[a] + off * n[a];
            if (rep.open)
                candidates[3 * (ns + k) + a] = v[a] - off * n[a];
        }
    }

    ffd_progress_update(&progress, 0.1);
    if (!rep.open) {
        /* Steps 1-3: Voronoi vertices inside the mesh. */
        interior = opt.interior_count;
        size_t nsites = ns < opt.voronoi_sites ? ns : opt.voronoi_sites;
        double mid[3];
        for (int a = 0; a < 3; a++)
            mid[a] = 0.5 * (info.bbox_min[a] + info.bbox_max[a]);
        spos = ffd_malloc_array(3 * (ns > nsites ? ns : nsites), sizeof *spos);
        if (!spos)
            goto nomem;
        for (size_t k = 0; k < nsites; k++) {
            /* an even subsample in vertex order */
            size_t s = (size_t)((double)k * (double)ns / (double)nsites);
            if (s >= ns)
                s = ns - 1;
            /* jittered: cospherical and cocircular vertices (spheres, cylinders,
             * boxes) merge into Delaunay regions with one centre otherwise; and
             * about the box's centre: the lifting of Qhull's Delaunay squares the
             * coordinates, so a small mesh far from the origin loses precision;
             * keyed by the place among the surface vertices, not the vertex id:
             * a volume mesh's surface numbered alone (a distributed run's
             * gathered surface) gets the same jitter */
            for (int a = 0; a < 3; a++)
                spos[3 * k + a] = (x[3 * surface[s] + a] - mid[a]) +
                                  FFD_TOL_SITE_JITTER * diag * site_hash(s, a);
        }
        rep.voronoi_sites = nsites;
        size_t nvor = 0;
        double t0 = ffd_now();
        status = ffd_voronoi_vertices(spos, nsites, FFD_TOL_SLIVER, &voronoi, &nvor, err);
        rep.seconds_voronoi = ffd_now() - t0;
        if (status != FFD_OK) {
            if (err) {
                char why[sizeof err->message];
                memcpy(why, err->message, sizeof why);
                ffd_fail(err, status, "placement: interior points: %s", why);
            }
            goto fail;
        }
        rep.voronoi_vertices = nvor;
        for (size_t k = 0; k < nvor; k++)
            for (int a = 0; a < 3; a++)
                voronoi[3 * k + a] += mid[a];

        for (size_t k = 0; k < ns; k++)
            memcpy(spos + 3 * k, x + 3 * surface[k], 3 * sizeof *spos);
        status = ffd_kdtree_create(spos, ns, &tree, err);
        if (status != FFD_OK)
            goto fail;
        size_t ntri = 0;
        tris = fan_triangles(mesh, order, &ntri);
        if (!tris)
            goto nomem;
        status = ffd_inside_index_create(x, nv, tris, ntri, &solid, err);
        if (status != FFD_OK)
            goto fail;
        keep = ffd_malloc(nvor ? nvor : 1);
        if (!keep)
            goto nomem;
        double lo[3], hi[3];
        for (int a = 0; a < 3; a++) {
            lo[a] = info.bbox_min[a] - BBOX_SLACK * diag;
            hi[a] = info.bbox_max[a] + BBOX_SLACK * diag;
        }
        size_t inside =
            keep_inside(voronoi, nvor, tree, surface, x, normals, solid, lo, hi, keep);
        rep.inside_vertices = inside;
        if (interior > inside) {
            status = ffd_fail(err, FFD_ERR_INVALID,
                              "%zu interior points asked for: only %zu Voronoi vertices lie inside the mesh",
                              interior, inside);
            goto fail;
        }
    }

    points = ffd_malloc_array(3 * (interior + exterior), sizeof *points);
    if (!points)
        goto nomem;
    if (interior) {
        status = ffd_decimate_points(voronoi, rep.inside_vertices, interior, points, err);
        if (status != FFD_OK)
            goto fail;
        status = snap_inside(points, interior, voronoi, rep.inside_vertices, solid, err);
        if (status != FFD_OK)
            goto fail;
        /* a degenerate medial axis (a sphere's is its centre) has fewer
         * distinct points than asked for: place those, and say so */
        size_t distinct = weld(points, interior, FFD_TOL_MEDIAL_WELD * diag);
        if (distinct < interior)
            snprintf(rep.note, sizeof rep.note,
                     "the medial axis has only %zu distinct interior point%s (within %g of the "
                     "bounding-box diagonal): placed %zu interior point%s instead of %zu",
                     distinct, distinct == 1 ? "" : "s", FFD_TOL_MEDIAL_WELD, distinct,
                     distinct == 1 ? "" : "s", interior);
        interior = distinct;
    }
    ffd_progress_update(&progress, 0.6);
    status = ffd_decimate_points(candidates, nc, exterior, points + 3 * interior, err);
    if (status != FFD_OK)
        goto fail;
    ffd_progress_update(&progress, 0.8);

    /* Steps 5 and 8: one EBF per point, radius from the nearest other point. */
    size_t m = interior + exterior;
    ebf = ffd_calloc(m, sizeof *ebf);
    if (!ebf)
        goto nomem;
    ffd_kdtree_destroy(tree);
    tree = NULL;
    status = ffd_kdtree_create(points, m, &tree, err);
    if (status != FFD_OK)
        goto fail;
    for (size_t j = 0; j < m; j++) {
        memcpy(ebf[j].center, points + 3 * j, sizeof ebf[j].center);
        double d2 = INFINITY;
        size_t other = ffd_kdtree_nearest_distinct(tree, points + 3 * j, &d2);
        double r = other == SIZE_MAX ? diag : opt.radius_factor * sqrt(d2);
        set_radius(ebf + j, r);
    }
    if (!opt.no_cover) {
        size_t grown = cover(ebf, m, x, surface, ns);
        if (grown == SIZE_MAX)
            goto nomem;
        rep.grown_radii = grown;
    }
    for (size_t j = 0; j < m; j++)
        if (!(ebf[j].radius[0] > 0) || !isfinite(ebf[j].radius[0])) {
            status = ffd_fail(err, FFD_ERR_NUMERIC, "placement: control %zu got radius %g", j,
                              ebf[j].radius[0]);
            goto fail;
        }

    rep.interior_count = interior;
    rep.exterior_count = exterior;
    ffd_progress_end(&progress);
    *controls = ebf;
    *count = m;
    ebf = NULL;
    status = FFD_OK;
    goto done;

nomem:
    status = ffd_fail(err, FFD_ERR_NOMEM, "placement: out of memory");
fail:
done:
    rep.seconds_total = ffd_now() - t_start;
    if (report)
        *report = rep;
    ffd_kdtree_destroy(tree);
    ffd_inside_index_destroy(solid);
    ffd_free(tris);
    ffd_free(order);
    ffd_free(normals);
    ffd_free(surface);
    ffd_free(candidates);
    ffd_free(voronoi);
    ffd_free(points);
    ffd_free(spos);
    ffd_free(keep);
    ffd_free(ebf);
    return status;
}
