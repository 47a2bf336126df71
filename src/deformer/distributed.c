/* distributed — one mesh partitioned over processes (docs/mpi.md). The
 * library knows no MPI: the caller's ffd_comm gives two collectives
 * (allreduce, allgatherv) and every global step goes through them.
 *
 * The design: a deformer reads the whole mesh only in a few places when it
 * is built (the extent of an auto box, the vertices a rig names by id, a
 * fitted frame's farthest point, and the boundary surface of the methods
 * that read one: PB-FFD placement, the T-spline's occupancy). So every rank
 * gathers exactly those points (and that surface) into a small
 * "construction mesh" — the same on every rank, its vertices in global-id
 * order, its faces in a canonical order — builds the deformer on it with
 * ffd_deformer_create, adopts rank 0's controls, and binds its own points.
 * Binding is per point, so each point deforms as it would as a vertex of
 * the whole mesh: the ranks' outputs together are the one-process result.
 * Each collective phase ends with ffd_comm_agree, so an error on one rank
 * is every rank's error and no rank waits in a collective the others left. */
#include "deformer/method.h"
#include "mesh/mesh_cells.h"
#include "rig/rig.h"
#include "rig/rig_json.h"

#include <cjson/cJSON.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ======================================================================
 * The communicator: one process when the caller gives none
 * ====================================================================== */

static int solo_allreduce(void *user, void *data, size_t count, ffd_reduce_type type,
                          ffd_reduce_op op)
{
    (void)user, (void)data, (void)count, (void)type, (void)op;
    return 0;
}

static int solo_allgatherv(void *user, const void *mine, size_t bytes, void *all,
                           const size_t *sizes)
{
    (void)user, (void)sizes;
    if (bytes)
        memcpy(all, mine, bytes);
    return 0;
}

static const ffd_comm solo_comm = {0, 1, solo_allreduce, solo_allgatherv, NULL};

static ffd_status check_comm(const ffd_comm *c, ffd_error *err)
{
    if (!c->allreduce || !c->allgatherv || c->size < 1 || c->rank < 0 || c->rank >= c->size)
        return ffd_fail(err, FFD_ERR_INVALID,
                        "ffd_comm: rank %d of size %d, or a NULL callback: expected 0 <= rank "
                        "< size and both callbacks",
                        c->rank, c->size);
    return FFD_OK;
}

static ffd_status reduce(const ffd_comm *c, void *data, size_t count, ffd_reduce_type type,
                         ffd_reduce_op op, ffd_error *err)
{
    if (c->allreduce(c->user, data, count, type, op))
        return ffd_fail(err, FFD_ERR_IO, "rank %d: the communicator's allreduce failed", c->rank);
    return FFD_OK;
}

/* Every rank's bytes to every rank: *all (ffd_free) holds them in rank
 * order, sizes[r] (size entries, ffd_free) how many came from rank r. */
static ffd_status gather(const ffd_comm *c, const void *mine, size_t bytes, unsigned char **all,
                         size_t **sizes_out, size_t *total_out, ffd_error *err)
{
    *all = NULL;
    *sizes_out = NULL;
    size_t p = (size_t)c->size;
    uint64_t *counts = ffd_calloc(p, sizeof *counts);
    size_t *sizes = ffd_malloc_array(p, sizeof *sizes);
    if (!counts || !sizes) {
        ffd_free(counts);
        ffd_free(sizes);
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory for %zu ranks", p);
    }
    counts[c->rank] = bytes;
    ffd_status st = reduce(c, counts, p, FFD_REDUCE_UINT64, FFD_REDUCE_SUM, err);
    size_t total = 0;
    for (size_t r = 0; !st && r < p; r++) {
        sizes[r] = (size_t)counts[r];
        if (counts[r] > SIZE_MAX - total)
            st = ffd_fail(err, FFD_ERR_INVALID, "the ranks' gathered data overflows memory");
        else
            total += sizes[r];
    }
    ffd_free(counts);
    unsigned char *buf = st ? NULL : ffd_malloc(total ? total : 1);
    if (!st && !buf)
        st = ffd_fail(err, FFD_ERR_NOMEM, "out of memory for %zu gathered bytes", total);
    if (!st && c->allgatherv(c->user, mine, bytes, buf, sizes))
        st = ffd_fail(err, FFD_ERR_IO, "rank %d: the communicator's allgatherv failed", c->rank);
    if (st) {
        ffd_free(buf);
        ffd_free(sizes);
        return st;
    }
    *all = buf;
    *sizes_out = sizes;
    *total_out = total;
    return FFD_OK;
}

ffd_status ffd_comm_agree(const ffd_comm *comm, ffd_status local, ffd_error *err)
{
    const ffd_comm *c = comm ? comm : &solo_comm;
    ffd_error scratch = {{0}};
    ffd_status st = check_comm(c, err ? err : &scratch);
    if (st)
        return st;
    if (c->size == 1)
        return local;
    size_t p = (size_t)c->size;
    uint64_t *status = ffd_calloc(p, sizeof *status);
    if (!status) /* still take part, or the others wait: a status of our own */
        local = local ? local : FFD_ERR_NOMEM;
    uint64_t one = local ? (uint64_t)local : 0;
    ffd_error inner = {{0}};
    if (status) {
        status[c->rank] = one;
        st = reduce(c, status, p, FFD_REDUCE_UINT64, FFD_REDUCE_SUM, &inner);
    } else {
        st = reduce(c, &one, 1, FFD_REDUCE_UINT64, FFD_REDUCE_MAX, &inner);
    }
    if (st || !status) {
        ffd_free(status);
        return ffd_fail(err, st ? st : FFD_ERR_NOMEM, "%s",
                        st ? inner.message : "out of memory agreeing on the ranks' status");
    }
    size_t failed = p;
    for (size_t r = 0; r < p && failed == p; r++)
        if (status[r])
            failed = r;
    ffd_status result = failed < p ? (ffd_status)status[failed] : FFD_OK;
    ffd_free(status);
    if (result == FFD_OK)
        return FFD_OK;
    /* the lowest failing rank's message to every rank */
    const char *msg = local && err ? err->message : "";
    size_t len = (size_t)c->rank == failed ? strlen(msg) + 1 : 0;
    unsigned char *all = NULL;
    size_t *sizes = NULL, total = 0;
    st = gather(c, msg, len, &all, &sizes, &total, &inner);
    if (st)
        return ffd_fail(err, result, "rank %zu failed (its message was lost: %s)", failed,
                        inner.message);
    char text[sizeof inner.message];
    snprintf(text, sizeof text, "%s", total ? (const char *)all : "");
    ffd_free(all);
    ffd_free(sizes);
    return ffd_fail(err, result, "rank %zu: %s", failed, text);
}

/* A phase's end: every rank's status agreed (a one-process run keeps its
 * message as it is). */
static ffd_status agree(const ffd_comm *c, ffd_status st, ffd_error *err)
{
    return c->size == 1 ? st : ffd_comm_agree(c, st, err);
}

/* ======================================================================
 * What the rig reads of the whole mesh
 * ====================================================================== */

typedef struct id_list {
    uint64_t *ids;
    size_t count, cap;
} id_list;

static ffd_status collect_id(void *user, uint32_t *id, const char *path)
{
    (void)path;
    id_list *l = user;
    if (!ffd_grow((void **)&l->ids, &l->cap, l->count + 1, sizeof *l->ids))
        return FFD_ERR_NOMEM;
    l->ids[l->count++] = *id;
    return FFD_OK;
}

/* The vertex ids the rig holds: its constraints and pins, and the method's own. */
static ffd_status visit_vertex_ids(ffd_rig *rig, ffd_vertex_visit visit, void *user)
{
    char path[96];
    ffd_status st = FFD_OK;
    for (size_t c = 0; !st && c < rig->constraint_count; c++)
        if (rig->constraints[c].kind == FFD_RIG_CONSTRAINT_VERTEX) {
            snprintf(path, sizeof path, "constraints[%zu].vertex", c);
            st = visit(user, &rig->constraints[c].vertex, path);
        }
    for (size_t i = 0; !st && i < rig->pin_count; i++) {
        snprintf(path, sizeof path, "pins[%zu].vertex", i);
        st = visit(user, &rig->pins[i].vertex, path);
    }
    if (!st && rig->method->vertex_ids)
        st = rig->method->vertex_ids(rig, visit, user);
    return st;
}

static int compare_u64(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return x < y ? -1 : x > y;
}

/* The generic layers that read per-vertex data of the whole mesh. */
static const char *refused_layer(const ffd_rig_layers *layers)
{
    if (!layers)
        return NULL;
    if (layers->weights_kind != FFD_WEIGHTS_NONE)
        return "\"weights\" (per-vertex weights are indexed by the whole mesh's vertex order)";
    if (layers->preserve)
        return "\"preserve\" (the volume and barycentre are integrals over the whole mesh)";
    for (size_t i = 0; i < layers->linear_count; i++)
        if (layers->linear[i].over == FFD_LINEAR_OVER_POINTS)
            return "\"linear_constraints\" over points (they sum deformed points of the whole "
                   "mesh)";
    return NULL;
}

/* ======================================================================
 * The construction mesh
 * ====================================================================== */

/* A gathered point: global id and rest position (32 bytes on the wire). */
typedef struct wire_point {
    uint64_t id;
    double x[3];
} wire_point;

typedef struct dist_build {
    const ffd_comm *c;
    const ffd_rig *rig;
    const char *name;
    const ffd_mesh *piece;
    size_t n;                 /* the piece's vertices */
    const double *x;          /* their rest positions */
    uint64_t *own_ids;        /* when the caller gave none: rank-major */
    const uint64_t *ids;      /* the piece's global ids */
    uint64_t total;           /* vertices of the whole mesh (with the pieces' shared ones) */
    double lo[3], hi[3];      /* the whole mesh's extent */
    int volume;               /* some piece has 3D cells */
    unsigned reads;           /* the method's global_reads */
    ffd_rig *copy;            /* the rig with its vertex ids made construction indices */
    wire_point *points;       /* the construction mesh's vertices, by global id */
    size_t point_count;
    uint32_t *face_offsets, *face_indices;
    size_t face_count;
    ffd_mesh *mesh;           /* the construction mesh */
} dist_build;

static void build_free(dist_build *b)
{
    ffd_free(b->own_ids);
    ffd_rig_destroy(b->copy);
    ffd_free(b->points);
    ffd_free(b->face_offsets);
    ffd_free(b->face_indices);
    ffd_mesh_destroy(b->mesh);
}

/* Phase 1 (local): the rig is one every rank can run. */
static ffd_status check_local(dist_build *b, ffd_error *err)
{
    const ffd_rig *rig = b->rig;
    const char *layer = refused_layer(rig->layers);
    if (layer)
        return ffd_fail(err, FFD_ERR_UNSUPPORTED,
                        "%s: %s is not supported in a distributed run", b->name, layer);
    char why[512] = "";
    b->reads = rig->method->global_reads ? rig->method->global_reads(rig, why, sizeof why) : 0;
    if (b->reads & FFD_GLOBAL_REFUSED)
        return ffd_fail(err, FFD_ERR_UNSUPPORTED, "%s: not in a distributed run: %s", b->name,
                        why);
    for (size_t i = 0; i < 3 * b->n; i++)
        if (!isfinite(b->x[i]))
            return ffd_fail(err, FFD_ERR_NONFINITE, "%s: vertex %zu of this rank's piece: "
                                                    "coordinate %zu is not finite",
                            b->name, i / 3, i % 3);
    /* the rig's copy, whose vertex ids become construction indices */
    char *text = NULL;
    ffd_status st = ffd_rig_write_json(rig, &text, err);
    if (!st)
        st = ffd_rig_parse_json(text, strlen(text), rig->name, &b->copy, err);
    ffd_free(text);
    return st;
}

/* Phase 2: counts, global ids, extent, volume. */
static ffd_status reduce_extent(dist_build *b, const uint64_t *given_ids, ffd_error *err)
{
    const ffd_comm *c = b->c;
    size_t p = (size_t)c->size;
    uint64_t *counts = ffd_calloc(p + 1, sizeof *counts);
    if (!counts)
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", b->name);
    counts[c->rank] = b->n;
    counts[p] = ffd_mesh_is_volume(b->piece) ? 1 : 0;
    ffd_status st = reduce(c, counts, p + 1, FFD_REDUCE_UINT64, FFD_REDUCE_SUM, err);
    uint64_t offset = 0;
    for (size_t r = 0; !st && r < p; r++) {
        if ((int)r < c->rank)
            offset += counts[r];
        b->total += counts[r];
    }
    b->volume = !st && counts[p] > 0;
    ffd_free(counts);
    if (st)
        return st;
    if (b->total == 0)
        return ffd_fail(err, FFD_ERR_INVALID, "%s: the distributed mesh has no vertices on any "
                                              "rank",
                        b->name);
    b->ids = given_ids;
    if (!given_ids) {
        if (!(b->own_ids = ffd_malloc_array(b->n ? b->n : 1, sizeof *b->own_ids)))
            return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", b->name);
        for (size_t i = 0; i < b->n; i++)
            b->own_ids[i] = offset + i;
        b->ids = b->own_ids;
    }
    double ext[6]; /* -lo, hi: one MAX reduction */
    for (int a = 0; a < 6; a++)
        ext[a] = -INFINITY;
    for (size_t i = 0; i < b->n; i++)
        for (int a = 0; a < 3; a++) {
            ext[a] = fmax(ext[a], -b->x[3 * i + a]);
            ext[3 + a] = fmax(ext[3 + a], b->x[3 * i + a]);
        }
    if ((st = reduce(c, ext, 6, FFD_REDUCE_DOUBLE, FFD_REDUCE_MAX, err)))
        return st;
    for (int a = 0; a < 3; a++) {
        b->lo[a] = -ext[a];
        b->hi[a] = ext[3 + a];
    }
    return FFD_OK;
}

/* How many of the piece's faces are the whole mesh's surface: in a volume
 * run none of a piece without 3D cells (the whole mesh's faces are the
 * boundary of its 3D cells, not its 2D cells: a file's surface triangles). */
static size_t surface_faces(const dist_build *b)
{
    return b->volume && !ffd_mesh_is_volume(b->piece) ? 0 : ffd_mesh_face_count(b->piece);
}

/* The piece's surface faces as (count, ids...) records of uint64. */
static ffd_status local_faces(const dist_build *b, uint64_t **out, size_t *words, ffd_error *err)
{
    size_t nf = surface_faces(b);
    const uint32_t *off = ffd_mesh_face_offsets(b->piece), *idx = ffd_mesh_face_indices(b->piece);
    size_t corners = nf ? off[nf] : 0;
    *words = nf + corners;
    *out = ffd_malloc_array(*words ? *words : 1, sizeof **out);
    if (!*out)
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory for the surface", b->name);
    size_t w = 0;
    for (size_t f = 0; f < nf; f++) {
        (*out)[w++] = off[f + 1] - off[f];
        for (uint32_t k = off[f]; k < off[f + 1]; k++)
            (*out)[w++] = b->ids[idx[k]];
    }
    return FFD_OK;
}

/* Phase 3 (local): the points this rank gives to the construction mesh. */
static ffd_status select_points(dist_build *b, wire_point **out, size_t *count, ffd_error *err)
{
    *out = NULL;
    *count = 0;
    unsigned char *keep = ffd_calloc(b->n ? b->n : 1, 1);
    id_list refs = {0};
    ffd_status st = keep ? FFD_OK : ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", b->name);
    if (!st && visit_vertex_ids(b->copy, collect_id, &refs))
        st = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", b->name);
    if (st) {
        ffd_free(keep);
        ffd_free(refs.ids);
        return st;
    }
    if (refs.count)
        qsort(refs.ids, refs.count, sizeof *refs.ids, compare_u64);
    /* the first point at each end of the extent on each axis */
    for (int a = 0; a < 3; a++) {
        int got_lo = 0, got_hi = 0;
        for (size_t i = 0; i < b->n && !(got_lo && got_hi); i++) {
            if (!got_lo && b->x[3 * i + a] == b->lo[a])
                keep[i] = 1, got_lo = 1;
            if (!got_hi && b->x[3 * i + a] == b->hi[a])
                keep[i] = 1, got_hi = 1;
        }
    }
    if (b->rig->method->global_points)
        b->rig->method->global_points(b->copy, b->lo, b->hi, b->x, b->n, keep);
    for (size_t i = 0; i < b->n; i++)
        if (!keep[i] && refs.count &&
            bsearch(&b->ids[i], refs.ids, refs.count, sizeof *refs.ids, compare_u64))
            keep[i] = 1;
    if (b->reads & FFD_GLOBAL_SURFACE) {
        size_t nf = surface_faces(b);
        const uint32_t *off = ffd_mesh_face_offsets(b->piece);
        const uint32_t *idx = ffd_mesh_face_indices(b->piece);
        for (size_t k = 0; nf && k < off[nf]; k++)
            keep[idx[k]] = 1;
    }
    ffd_free(refs.ids);
    size_t m = 0;
    for (size_t i = 0; i < b->n; i++)
        m += keep[i];
    wire_point *pts = ffd_malloc_array(m ? m : 1, sizeof *pts);
    if (!pts) {
        ffd_free(keep);
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", b->name);
    }
    for (size_t i = 0, k = 0; i < b->n; i++)
        if (keep[i]) {
            pts[k].id = b->ids[i];
            memcpy(pts[k].x, b->x + 3 * i, sizeof pts[k].x);
            k++;
        }
    ffd_free(keep);
    *out = pts;
    *count = m;
    return FFD_OK;
}

static int compare_points(const void *a, const void *b)
{
    const wire_point *p = a, *q = b;
    if (p->id != q->id)
        return p->id < q->id ? -1 : 1;
    return memcmp(p->x, q->x, sizeof p->x);
}

/* The construction index of global id, or SIZE_MAX. */
static size_t index_of(const dist_build *b, uint64_t id)
{
    size_t lo = 0, hi = b->point_count;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        if (b->points[mid].id < id)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo < b->point_count && b->points[lo].id == id ? lo : SIZE_MAX;
}

typedef struct remap_ctx {
    const dist_build *b;
    ffd_error *err;
} remap_ctx;

static ffd_status remap_id(void *user, uint32_t *id, const char *path)
{
    remap_ctx *r = user;
    size_t k = index_of(r->b, *id);
    if (k == SIZE_MAX)
        return ffd_fail(r->err, FFD_ERR_RANGE,
                        "%s: %s: vertex %u is on no rank's piece (the pieces hold %llu vertices, "
                        "a shared one once per piece%s)",
                        r->b->name, path, *id, (unsigned long long)r->b->total,
                        r->b->ids == r->b->own_ids ? ", numbered rank by rank"
                                                    : ", by their global ids");
    *id = (uint32_t)k;
    return FFD_OK;
}

/* Sorted, duplicates (shared vertices) merged; positions must agree. */
static ffd_status merge_points(dist_build *b, unsigned char *all, size_t bytes, ffd_error *err)
{
    size_t m = bytes / sizeof(wire_point);
    b->points = (wire_point *)all;
    qsort(b->points, m, sizeof *b->points, compare_points);
    size_t k = 0;
    for (size_t i = 0; i < m; i++) {
        if (k && b->points[k - 1].id == b->points[i].id) {
            if (memcmp(b->points[k - 1].x, b->points[i].x, sizeof b->points[i].x))
                return ffd_fail(err, FFD_ERR_INVALID,
                                "%s: global vertex %llu has different positions on two ranks' "
                                "pieces ([%.17g, %.17g, %.17g] and [%.17g, %.17g, %.17g])",
                                b->name, (unsigned long long)b->points[i].id,
                                b->points[k - 1].x[0], b->points[k - 1].x[1],
                                b->points[k - 1].x[2], b->points[i].x[0], b->points[i].x[1],
                                b->points[i].x[2]);
            continue;
        }
        b->points[k++] = b->points[i];
    }
    b->point_count = k;
    if (k > UINT32_MAX)
        return ffd_fail(err, FFD_ERR_INVALID,
                        "%s: the global steps gathered %zu points (at most %u)", b->name, k,
                        UINT32_MAX);
    return FFD_OK;
}

/* The boundary surface from every rank's faces (count, ids...), as
 * construction indices in the canonical order (ffd_faces_canonical_order),
 * where faces on the same corners are neighbours: such a pair from two
 * pieces of a volume mesh is their interface, inside, and cancelled. */
static ffd_status merge_faces(dist_build *b, const uint64_t *words, size_t nwords,
                              const size_t *sizes, ffd_error *err)
{
    /* every gathered face, and the rank it came from: a face is >= 4 words */
    size_t most = nwords / 4 + 1, nf = 0, corners = 0, w = 0;
    uint32_t *offsets = ffd_malloc_array(most + 1, sizeof *offsets);
    uint32_t *indices = ffd_malloc_array(nwords ? nwords : 1, sizeof *indices);
    int *rank = ffd_malloc_array(most, sizeof *rank);
    uint32_t *order = NULL, *sorted = NULL;
    unsigned char *drop = NULL;
    ffd_status st = offsets && indices && rank
                        ? FFD_OK
                        : ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory for the surface", b->name);
    if (!st && nwords > UINT32_MAX)
        st = ffd_fail(err, FFD_ERR_INVALID, "%s: the ranks' faces hold %zu corners (at most %u)",
                      b->name, nwords, UINT32_MAX);
    if (!st)
        offsets[0] = 0;
    for (int r = 0; r < b->c->size && !st; r++) {
        size_t end = w + sizes[r] / sizeof *words;
        while (w < end && !st) {
            size_t k = (size_t)words[w];
            if (k < 3 || k > end - w - 1) {
                st = ffd_fail(err, FFD_ERR_INVALID, "%s: rank %d sent a malformed face",
                              b->name, r);
                break;
            }
            for (size_t q = 1; q <= k && !st; q++) {
                size_t v = index_of(b, words[w + q]);
                if (v == SIZE_MAX)
                    st = ffd_fail(err, FFD_ERR_INVALID, "%s: a face's vertex was not gathered",
                                  b->name);
                indices[corners++] = (uint32_t)v;
            }
            rank[nf] = r;
            offsets[++nf] = (uint32_t)corners;
            w += k + 1;
        }
    }
    if (!st && !ffd_faces_canonical_order(offsets, indices, nf, &order, &sorted))
        st = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory for the surface", b->name);
    if (!st && !(drop = ffd_calloc(nf ? nf : 1, 1)))
        st = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory for the surface", b->name);
    size_t kept = 0, kept_corners = 0;
    for (size_t i = 0; !st && i < nf;) {
        uint32_t f = order[i], n = offsets[f + 1] - offsets[f];
        size_t j = i + 1;
        while (j < nf && offsets[order[j] + 1] - offsets[order[j]] == n &&
               !memcmp(sorted + offsets[order[j]], sorted + offsets[f], n * sizeof *sorted))
            j++;
        /* two pieces' faces on the same corners: their interface */
        if (b->volume && j - i == 2 && rank[f] != rank[order[i + 1]])
            drop[i] = drop[i + 1] = 1;
        for (size_t q = i; q < j; q++)
            if (!drop[q])
                kept++, kept_corners += n;
        i = j;
    }
    if (!st) {
        b->face_offsets = ffd_malloc_array(kept + 1, sizeof *b->face_offsets);
        b->face_indices = ffd_malloc_array(kept_corners ? kept_corners : 1,
                                           sizeof *b->face_indices);
        if (!b->face_offsets || !b->face_indices)
            st = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory for the surface", b->name);
    }
    if (!st) {
        size_t c = 0;
        b->face_offsets[0] = 0;
        for (size_t i = 0; i < nf; i++) {
            if (drop[i])
                continue;
            uint32_t f = order[i];
            memcpy(b->face_indices + c, indices + offsets[f],
                   (offsets[f + 1] - offsets[f]) * sizeof *indices);
            c += offsets[f + 1] - offsets[f];
            b->face_offsets[++b->face_count] = (uint32_t)c;
        }
    }
    ffd_free(offsets);
    ffd_free(indices);
    ffd_free(rank);
    ffd_free(order);
    ffd_free(sorted);
    ffd_free(drop);
    return st;
}

/* Phases 3-4: gather the points (and the surface), build the construction mesh. */
static ffd_status gather_construction(dist_build *b, ffd_error *err)
{
    wire_point *mine = NULL;
    size_t mine_count = 0;
    ffd_status st = select_points(b, &mine, &mine_count, err);
    if ((st = agree(b->c, st, err))) {
        ffd_free(mine);
        return st;
    }
    unsigned char *all = NULL;
    size_t *sizes = NULL, total = 0;
    st = gather(b->c, mine, mine_count * sizeof *mine, &all, &sizes, &total, err);
    ffd_free(mine);
    ffd_free(sizes);
    if (!st)
        st = merge_points(b, all, total, err);
    else
        ffd_free(all);
    if (!st) {
        remap_ctx r = {b, err};
        st = visit_vertex_ids(b->copy, remap_id, &r);
    }
    if ((st = agree(b->c, st, err)))
        return st;
    if (b->reads & FFD_GLOBAL_SURFACE) {
        uint64_t *faces = NULL;
        size_t words = 0;
        st = local_faces(b, &faces, &words, err);
        if ((st = agree(b->c, st, err))) {
            ffd_free(faces);
            return st;
        }
        st = gather(b->c, faces, words * sizeof *faces, &all, &sizes, &total, err);
        ffd_free(faces);
        if (!st)
            st = merge_faces(b, (const uint64_t *)all, total / sizeof(uint64_t), sizes, err);
        ffd_free(all);
        ffd_free(sizes);
        if ((st = agree(b->c, st, err)))
            return st;
    }
    double *xyz = ffd_malloc_array(b->point_count, 3 * sizeof *xyz);
    if (!xyz)
        st = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", b->name);
    for (size_t i = 0; !st && i < b->point_count; i++)
        memcpy(xyz + 3 * i, b->points[i].x, sizeof b->points[i].x);
    ffd_error inner = {{0}};
    if (!st && (st = ffd_mesh_create(xyz, b->point_count, b->face_offsets, b->face_indices,
                                     b->face_count, &b->mesh, &inner)))
        st = ffd_fail(err, st, "%s: the gathered surface: %s", b->name, inner.message);
    ffd_free(xyz);
    return agree(b->c, st, err);
}

/* Every rank takes rank 0's controls, so that a solve that rounded
 * otherwise on another machine cannot split the ranks. */
static ffd_status adopt_rank0_controls(const dist_build *b, ffd_deformer *d, ffd_error *err)
{
    size_t count = ffd_deformer_control_count(d);
    double *mine = ffd_malloc_array(count ? count : 1, 3 * sizeof *mine);
    if (!mine)
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", b->name);
    ffd_deformer_controls(d, mine);
    unsigned char *all = NULL;
    size_t *sizes = NULL, total = 0;
    ffd_status st = gather(b->c, mine, b->c->rank == 0 ? 3 * count * sizeof *mine : 0, &all,
                           &sizes, &total, err);
    if (!st && total != 3 * count * sizeof *mine)
        st = ffd_fail(err, FFD_ERR_INVALID, "%s: rank 0 has %zu controls, this rank %zu",
                      b->name, total / (3 * sizeof *mine), count);
    if (!st && count && memcmp(all, mine, total))
        st = ffd_deformer_set_controls(d, NULL, count, (const double *)all, err);
    ffd_free(mine);
    ffd_free(all);
    ffd_free(sizes);
    return st;
}

/* Everything but the bind of the piece: the deformer on the construction mesh. */
static ffd_status build_deformer(dist_build *b, const ffd_rig *rig, const ffd_mesh *piece,
                                 const ffd_partition *part, ffd_deformer **out, ffd_error *err)
{
    *out = NULL;
    memset(b, 0, sizeof *b);
    b->c = part && part->comm ? part->comm : &solo_comm;
    if (!rig || !piece)
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_deformer_create_distributed: NULL argument");
    ffd_status st = check_comm(b->c, err);
    if (st)
        return st;
    b->rig = rig;
    b->name = rig->name ? rig->name : "<rig>";
    b->piece = piece;
    b->n = ffd_mesh_vertex_count(piece);
    b->x = ffd_mesh_positions(piece);
    st = check_local(b, err);
    if ((st = agree(b->c, st, err)))
        return st;
    if ((st = reduce_extent(b, part ? part->global_ids : NULL, err)) ||
        (st = agree(b->c, st, err)))
        return st;
    if ((st = gather_construction(b, err)))
        return st;
    st = ffd_deformer_create(b->copy, b->mesh, part ? part->limits : NULL, out, err);
    if ((st = agree(b->c, st, err)))
        return st;
    st = adopt_rank0_controls(b, *out, err);
    return agree(b->c, st, err);
}

ffd_status ffd_deformer_create_distributed(const ffd_rig *rig, const ffd_mesh *piece,
                                           const ffd_partition *part, ffd_deformer **out,
                                           ffd_error *err)
{
    if (!out)
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_deformer_create_distributed: NULL out");
    dist_build b;
    ffd_status st = build_deformer(&b, rig, piece, part, out, err);
    if (!st)
        st = ffd_deformer_bind(*out, b.x, b.n, err);
    st = agree(b.c, st, err);
    build_free(&b);
    if (st) {
        ffd_deformer_destroy(*out);
        *out = NULL;
    }
    return st;
}

/* ======================================================================
 * Applying a rig
 * ====================================================================== */

/* The report: the method's own, from the rig applied to the construction
 * mesh (it holds every point a report reads: the constrained vertices, the
 * extent, the surface; the deformer, built, needs it no more), so the
 * constraints' residuals and rank, the controls and the method's details
 * are one process's; then what the run gathered. outside_count would need
 * every rank's points: 0. */
static ffd_status fill_report(const dist_build *b, const ffd_limits *limits,
                              ffd_rig_report *report, ffd_error *err)
{
    ffd_status st = ffd_rig_apply_limited(b->copy, b->mesh, limits, report, err);
    if (st)
        return st;
    report->outside_count = 0;
    unsigned long mark = ffd_json_alloc_failures();
    cJSON *details = report->details ? cJSON_Parse(report->details) : cJSON_CreateObject();
    cJSON *dist = cJSON_CreateObject();
    int ok = details && dist && cJSON_AddNumberToObject(dist, "ranks", b->c->size) &&
             cJSON_AddNumberToObject(dist, "piece_vertices", (double)b->total) &&
             cJSON_AddNumberToObject(dist, "gathered_points", (double)b->point_count) &&
             cJSON_AddNumberToObject(dist, "gathered_faces", (double)b->face_count);
    if (ok && cJSON_AddItemToObject(details, "distributed", dist))
        dist = NULL;
    else
        ok = 0;
    cJSON_Delete(dist);
    if (!ok) {
        cJSON_Delete(details);
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory for the report", b->name);
    }
    st = ffd_rig_report_set_details(report, details, mark, b->name, err);
    if (!st)
        st = ffd_rig_report_note(report, b->name, err,
                                 "note: distributed over %d rank%s: %llu vertices in the pieces "
                                 "(shared ones once per piece); the global steps gathered %zu "
                                 "points and %zu surface faces",
                                 b->c->size, b->c->size == 1 ? "" : "s",
                                 (unsigned long long)b->total, b->point_count, b->face_count);
    return st;
}

ffd_status ffd_rig_apply_distributed(const ffd_rig *rig, ffd_mesh *piece,
                                     const ffd_partition *part, ffd_rig_report *report,
                                     ffd_error *err)
{
    if (report)
        memset(report, 0, sizeof *report);
    dist_build b;
    ffd_deformer *d = NULL;
    ffd_rig_report local;
    memset(&local, 0, sizeof local);
    double t0 = ffd_now();
    ffd_status st = build_deformer(&b, rig, piece, part, &d, err);
    if (st) {
        build_free(&b);
        return st;
    }
    double *x = NULL, *jac = NULL;
    double solve = ffd_now() - t0; /* the global steps and the deformer's replay */
    if (report)
        st = fill_report(&b, part ? part->limits : NULL, &local, err);
    double t1 = ffd_now();
    if (!st)
        st = ffd_deformer_bind(d, b.x, b.n, err);
    double t2 = ffd_now();
    local.timings.solve = solve;
    local.timings.bind = t2 - t1;
    if (!st && !(x = ffd_malloc_array(b.n ? b.n : 1, 3 * sizeof *x)))
        st = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", b.name);
    if (!st)
        st = ffd_deformer_eval(d, x, err);
    local.timings.evaluate = ffd_now() - t2;
    /* normals follow the Jacobian; a piece without them needs none */
    if (!st && ffd_mesh_normal_count(piece)) {
        jac = ffd_malloc_array(b.n ? b.n : 1, 9 * sizeof *jac);
        ffd_error inner = {{0}};
        ffd_status js = jac ? ffd_deformer_jacobian(d, jac, &inner) : FFD_ERR_NOMEM;
        if (js == FFD_ERR_UNSUPPORTED) {
            ffd_free(jac); /* normals from the deformed faces */
            jac = NULL;
        } else if (js) {
            st = ffd_fail(err, js, "%s", jac ? inner.message : "out of memory");
        }
    }
    for (size_t i = 0; !st && i < 3 * b.n; i++)
        if (!isfinite(x[i]))
            st = ffd_fail(err, FFD_ERR_NONFINITE, "%s: vertex %zu of this rank's piece deformed "
                                                  "to a non-finite position",
                          b.name, i / 3);
    /* every rank ready before any piece changes */
    if (!(st = agree(b.c, st, err)) && (st = ffd_mesh_set_positions(piece, x, jac, err)))
        st = agree(b.c, st, err);
    ffd_free(x);
    ffd_free(jac);
    ffd_deformer_destroy(d);
    build_free(&b);
    if (st)
        ffd_rig_report_free(&local);
    else if (report)
        *report = local;
    return st;
}

/* ======================================================================
 * Inversions of every piece
 * ====================================================================== */

ffd_status ffd_inversion_report_reduce(const ffd_comm *comm, ffd_inversion_report *report,
                                       ffd_error *err)
{
    const ffd_comm *c = comm ? comm : &solo_comm;
    if (!report)
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_inversion_report_reduce: NULL report");
    ffd_status st = check_comm(c, err);
    if (st)
        return st;
    uint64_t counts[4] = {report->cells_checked, report->inverted, report->faces_checked,
                          report->flipped_faces};
    double worst[2] = {isnan(report->worst_det) ? INFINITY : report->worst_det,
                       isnan(report->worst_scaled_jacobian) ? INFINITY
                                                            : report->worst_scaled_jacobian};
    double mine = worst[0];
    if ((st = reduce(c, counts, 4, FFD_REDUCE_UINT64, FFD_REDUCE_SUM, err)) ||
        (st = reduce(c, worst, 2, FFD_REDUCE_DOUBLE, FFD_REDUCE_MIN, err)))
        return st;
    report->cells_checked = (size_t)counts[0];
    report->inverted = (size_t)counts[1];
    report->faces_checked = (size_t)counts[2];
    report->flipped_faces = (size_t)counts[3];
    if (!(mine == worst[0] && isfinite(mine)))
        report->worst_cell = SIZE_MAX; /* the worst cell is another rank's */
    report->worst_det = isinf(worst[0]) && worst[0] > 0 ? NAN : worst[0];
    report->worst_scaled_jacobian = isinf(worst[1]) && worst[1] > 0 ? NAN : worst[1];
    return FFD_OK;
}
