/* tsv — local refinement of the tailored cubic T-spline volume (Zhang, Zheng
 * & Cai 2020, §3.2-3.3) by the blending-function refinement of Sederberg et
 * al. 2004 ("T-spline simplification and local refinement"), carried over to
 * volumes (design §3). Every old blending function W_v B_v is rewritten
 * exactly as a sum of new ones through "pieces" (a centre, knot vectors and
 * homogeneous coefficients (W P, W) for every position channel); the closure
 * resolves the violations V1 (a missing knot: knot insertion into the piece,
 * Boehm 1980), V2 (an extra knot: add lattice structure) and orphans (a
 * piece centred where there is no vertex) innermost first (design §3.3).
 *
 * Batches: all insertions name elements by their ids before the edit. A
 * split keeps the id for the part below the split value, so an element named
 * after an earlier insertion of the same batch split it refers to that lower
 * part, and the insertion applies to it (at its own midpoint). */
#include "tspline/tsv.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

typedef struct piece {
    double p[3][5];         /* knot vectors in sigma; p[d][2] is the centre */
    double X[TSV_NCH][3];   /* W P per channel */
    double W;
    uint32_t owner;         /* vertex at the centre, UINT32_MAX: orphan */
    uint32_t next;          /* next piece of the same owner */
    uint8_t dead, orig;     /* orig: the untouched initial piece of its owner */
} piece;

typedef struct v2req {
    uint32_t v;
    int d;
    double y;
} v2req;

typedef struct closure {
    tsv_lattice *L;
    piece *pc;
    size_t npc, cap_pc;
    uint32_t *head;         /* per vertex: first piece */
    size_t cap_head;
    double (*K)[3][5];      /* inferred knots per vertex */
    size_t cap_K;
    v2req *v2;
    size_t nv2, cap_v2;
} closure;

static void closure_free(closure *Z)
{
    ffd_free(Z->pc);
    ffd_free(Z->head);
    ffd_free(Z->K);
    ffd_free(Z->v2);
}

static bool grow_heads(closure *Z)
{
    size_t old = Z->cap_head;
    if (!ffd_grow((void **)&Z->head, &Z->cap_head, Z->L->nv, sizeof *Z->head))
        return false;
    for (size_t i = old; i < Z->cap_head; i++)
        Z->head[i] = UINT32_MAX;
    return true;
}

static bool same_knots(const double *a, const double *b)
{
    for (int i = 0; i < 15; i++)
        if (a[i] != b[i])
            return false;
    return true;
}

/* Links piece i to vertex v, or merges it into a live piece there with the same knots. */
static void attach(closure *Z, uint32_t i, uint32_t v)
{
    piece *P = &Z->pc[i];
    for (uint32_t j = Z->head[v]; j != UINT32_MAX; j = Z->pc[j].next) {
        piece *Q = &Z->pc[j];
        if (!Q->dead && same_knots(&Q->p[0][0], &P->p[0][0])) {
            for (int ch = 0; ch < TSV_NCH; ch++)
                for (int k = 0; k < 3; k++)
                    Q->X[ch][k] += P->X[ch][k];
            Q->W += P->W;
            Q->orig = 0;
            P->dead = 1;
            return;
        }
    }
    P->owner = v;
    P->next = Z->head[v];
    Z->head[v] = i;
}

/* Appends a piece (copied from *src, scaled by c) and attaches it when its centre is a vertex. */
static bool add_piece(closure *Z, const piece *src, double c)
{
    if (!ffd_grow((void **)&Z->pc, &Z->cap_pc, Z->npc + 1, sizeof *Z->pc))
        return false;
    uint32_t i = (uint32_t)Z->npc++;
    piece *P = &Z->pc[i];
    *P = *src;
    for (int ch = 0; ch < TSV_NCH; ch++)
        for (int k = 0; k < 3; k++)
            P->X[ch][k] *= c;
    P->W *= c;
    P->dead = 0;
    P->orig = 0;
    P->owner = UINT32_MAX;
    P->next = UINT32_MAX;
    double q[3] = {P->p[0][2], P->p[1][2], P->p[2][2]};
    uint32_t v = ffd_tsv_vertex_find(Z->L, q);
    if (v != UINT32_MAX)
        attach(Z, i, v);
    return true;
}

/* Knot insertion of sigma k into direction d of piece i (design §3.2, Boehm 1980). */
static bool split_piece(closure *Z, uint32_t i, int d, double k)
{
    piece base = Z->pc[i];
    const double *p = base.p[d];
    double q[6];
    int m = 0;
    for (int j = 0; j < 5; j++) {
        if (m == j && k < p[j])
            q[m++] = k;
        q[m++] = p[j];
    }
    if (m == 5)
        q[m++] = k;
    double kk = tsv_kappa(k), k0 = tsv_kappa(p[0]), k1 = tsv_kappa(p[1]), k3 = tsv_kappa(p[3]),
           k4 = tsv_kappa(p[4]);
    /* the zero-interval rule keeps these denominators nonzero when reached */
    double cL = k >= p[3] ? 1.0 : (kk - k0) / (k3 - k0);
    double cR = k <= p[1] ? 1.0 : (k4 - kk) / (k4 - k1);
    Z->pc[i].dead = 1;
    piece child = base;
    if (cL != 0.0) {
        memcpy(child.p[d], q, 5 * sizeof *q);
        if (!add_piece(Z, &child, cL))
            return false;
    }
    if (cR != 0.0) {
        memcpy(child.p[d], q + 1, 5 * sizeof *q);
        if (!add_piece(Z, &child, cR))
            return false;
    }
    return true;
}

/* Innermost-first rule (design §3.3): the first V1 of piece P against the
 * inferred knots r, directions s, t, u; returns 1 with (*dd, *kk) or 0. */
static int first_v1(const piece *P, const double *r, int *dd, double *kk)
{
    for (int d = 0; d < 3; d++) {
        const double *p = P->p[d], *q = r + 5 * d;
        /* lower side: positions 1 then 0; nearer = larger */
        for (int j = 1; j >= 0; j--)
            if (p[j] != q[j]) {
                if (q[j] > p[j]) {
                    *dd = d;
                    *kk = q[j];
                    return 1;
                }
                break;
            }
        for (int j = 3; j <= 4; j++)
            if (p[j] != q[j]) {
                if (q[j] < p[j]) {
                    *dd = d;
                    *kk = q[j];
                    return 1;
                }
                break;
            }
    }
    return 0;
}

static bool push_v2(closure *Z, uint32_t v, int d, double y)
{
    if (!ffd_grow((void **)&Z->v2, &Z->cap_v2, Z->nv2 + 1, sizeof *Z->v2))
        return false;
    Z->v2[Z->nv2].v = v;
    Z->v2[Z->nv2].d = d;
    Z->v2[Z->nv2].y = y;
    Z->nv2++;
    return true;
}

static bool collect_v2(closure *Z, const piece *P, uint32_t v, const double *r)
{
    for (int d = 0; d < 3; d++) {
        const double *p = P->p[d], *q = r + 5 * d;
        for (int j = 1; j >= 0; j--)
            if (p[j] != q[j]) {
                if (p[j] > q[j] && !push_v2(Z, v, d, p[j]))
                    return false;
                break;
            }
        for (int j = 3; j <= 4; j++)
            if (p[j] != q[j]) {
                if (p[j] < q[j] && !push_v2(Z, v, d, p[j]))
                    return false;
                break;
            }
    }
    return true;
}

static int cmp_v2(const void *a, const void *b)
{
    const v2req *x = a, *y = b;
    if (x->v != y->v)
        return x->v < y->v ? -1 : 1;
    if (x->d != y->d)
        return x->d < y->d ? -1 : 1;
    return x->y < y->y ? -1 : (x->y > y->y);
}

/* ensure_hit(v, d, y) of design §3.3: make plane sigma_d = y a hit at v's projection. */
static ffd_status ensure_hit(tsv_lattice *L, uint32_t v, int d, double y, ffd_error *err)
{
    if (y < TSV_SIGMA_MIN || y > TSV_SIGMA_MAX)
        return ffd_fail(err, FFD_ERR_NUMERIC, "tsv refine: frame knot %g in a closure request", y);
    double q[3] = {L->verts[v].sg[0], L->verts[v].sg[1], L->verts[v].sg[2]};
    q[d] = y;
    int dim;
    uint32_t id;
    ffd_tsv_lattice_locate(L, q, &dim, &id);
    switch (dim) {
    case 1:
        return L->edges[id].axis == d ? ffd_tsv_split_edge(L, id, y, NULL, err) : FFD_OK;
    case 2:
        return L->faces[id].normal != d ? ffd_tsv_split_face(L, id, d, y, err) : FFD_OK;
    case 3:
        return ffd_tsv_split_cell(L, id, d, y, err);
    case 0:
        return FFD_OK;
    default:
        return ffd_fail(err, FFD_ERR_NUMERIC, "tsv refine: point outside the lattice");
    }
}

/* ensure_vertex(q) of design §3.3. */
static ffd_status ensure_vertex(tsv_lattice *L, const double q[3], ffd_error *err)
{
    for (int step = 0; step < 2; step++) {
        int dim;
        uint32_t id;
        ffd_tsv_lattice_locate(L, q, &dim, &id);
        if (dim == 0)
            return FFD_OK;
        if (dim == 1)
            return ffd_tsv_split_edge(L, id, q[L->edges[id].axis], NULL, err);
        if (dim == 2) {
            int a = L->faces[id].normal == 0 ? 1 : 0;
            ffd_status st = ffd_tsv_split_face(L, id, a, q[a], err);
            if (st != FFD_OK)
                return st;
            continue;
        }
        break;
    }
    return ffd_fail(err, FFD_ERR_NUMERIC,
                    "tsv refine: orphan blending function inside a cell at (%g, %g, %g)", q[0], q[1],
                    q[2]);
}

static bool infer_all(closure *Z)
{
    tsv_lattice *L = Z->L;
    if (!ffd_grow((void **)&Z->K, &Z->cap_K, L->nv, sizeof *Z->K))
        return false;
    for (size_t v = 0; v < L->nv; v++)
        ffd_tsv_infer_knots(L, (uint32_t)v, Z->K[v]);
    return true;
}

/* The resolution loop of design §3.3. */
static ffd_status run_closure(closure *Z, uint64_t guard, ffd_error *err)
{
    tsv_lattice *L = Z->L;
    uint64_t version0 = L->version;
    for (;;) {
        if (!grow_heads(Z) || !infer_all(Z))
            return ffd_fail(err, FFD_ERR_NOMEM, "tsv refine: out of memory");
        Z->nv2 = 0;
        /* phase A: V1 only (pure spline algebra) */
        for (size_t i = 0; i < Z->npc; i++) {
            piece *P = &Z->pc[i];
            if (P->dead)
                continue;
            if (P->owner == UINT32_MAX) {
                double q[3] = {P->p[0][2], P->p[1][2], P->p[2][2]};
                uint32_t v = ffd_tsv_vertex_find(L, q);
                if (v == UINT32_MAX)
                    continue; /* still an orphan */
                attach(Z, (uint32_t)i, v);
                if (Z->pc[i].dead)
                    continue; /* merged into a piece checked on its own */
            }
            P = &Z->pc[i];
            int d;
            double k;
            if (first_v1(P, &Z->K[P->owner][0][0], &d, &k)) {
                /* unlink from its owner before splitting */
                uint32_t *link = &Z->head[P->owner];
                while (*link != (uint32_t)i)
                    link = &Z->pc[*link].next;
                *link = P->next;
                if (!split_piece(Z, (uint32_t)i, d, k))
                    return ffd_fail(err, FFD_ERR_NOMEM, "tsv refine: out of memory");
                continue;
            }
            if (!collect_v2(Z, P, P->owner, &Z->K[P->owner][0][0]))
                return ffd_fail(err, FFD_ERR_NOMEM, "tsv refine: out of memory");
        }
        uint64_t before = L->version;
        /* orphans: add their vertices */
        for (size_t i = 0; i < Z->npc; i++) {
            const piece *P = &Z->pc[i];
            if (P->dead || P->owner != UINT32_MAX)
                continue;
            double q[3] = {P->p[0][2], P->p[1][2], P->p[2][2]};
            ffd_status st = ensure_vertex(L, q, err);
            if (st != FFD_OK)
                return st;
        }
        /* V2: add lattice structure, in vertex id order */
        if (Z->nv2)
            qsort(Z->v2, Z->nv2, sizeof *Z->v2, cmp_v2);
        for (size_t i = 0; i < Z->nv2; i++) {
            if (i > 0 && cmp_v2(&Z->v2[i - 1], &Z->v2[i]) == 0)
                continue;
            ffd_status st = ensure_hit(L, Z->v2[i].v, Z->v2[i].d, Z->v2[i].y, err);
            if (st != FFD_OK)
                return st;
        }
        if (L->version - version0 > guard)
            return ffd_fail(err, FFD_ERR_INVALID,
                            "tsv refine: the closure exceeded its guard of %llu topology steps",
                            (unsigned long long)guard);
        if (L->version == before)
            return FFD_OK;
    }
}

/* Midpoint of the knot interval [lo, hi] through the registry (design §3.1). */
static ffd_status mid_sigma(tsv_lattice *L, int axis, double lo, double hi, double r, double *x,
                            ffd_error *err)
{
    double a = tsv_kappa(lo), b = tsv_kappa(hi);
    return ffd_tsv_registry_get(L, axis, a + r * (b - a), x, err);
}

static void face_axes(int normal, int ax[2])
{
    ax[0] = normal == 0 ? 1 : 0;
    ax[1] = normal == 2 ? 1 : 2;
}

static ffd_status check_insertion(const tsv_lattice *L, const ffd_tsv_insertion *in, ffd_error *err)
{
    switch (in->kind) {
    case FFD_TSV_EDGE: {
        if (in->id >= L->ne)
            return ffd_fail(err, FFD_ERR_RANGE, "edge %u: there are %zu edges", in->id, L->ne);
        if (!(in->ratio == 0.0 || (in->ratio > 0.0 && in->ratio < 1.0)))
            return ffd_fail(err, FFD_ERR_INVALID, "edge %u: ratio %g outside (0,1)", in->id,
                            in->ratio);
        const tsv_edge *E = &L->edges[in->id];
        if (tsv_kappa(E->lo) == tsv_kappa(E->hi))
            return ffd_fail(err, FFD_ERR_INVALID, "edge %u: zero knot interval", in->id);
        return FFD_OK;
    }
    case FFD_TSV_FACE: {
        if (in->id >= L->nf)
            return ffd_fail(err, FFD_ERR_RANGE, "face %u: there are %zu faces", in->id, L->nf);
        const tsv_face *F = &L->faces[in->id];
        if (tsv_kappa(F->lo[0]) == tsv_kappa(F->hi[0]) && tsv_kappa(F->lo[1]) == tsv_kappa(F->hi[1]))
            return ffd_fail(err, FFD_ERR_INVALID, "face %u: zero knot interval", in->id);
        return FFD_OK;
    }
    case FFD_TSV_CELL: {
        if (in->id >= L->nc)
            return ffd_fail(err, FFD_ERR_RANGE, "cell %u: there are %zu cells", in->id, L->nc);
        const tsv_cell *C = &L->cells[in->id];
        int nz = 0;
        for (int a = 0; a < 3; a++)
            nz += tsv_kappa(C->lo[a]) != tsv_kappa(C->hi[a]);
        if (!nz)
            return ffd_fail(err, FFD_ERR_INVALID, "cell %u: zero knot interval", in->id);
        return FFD_OK;
    }
    default:
        return ffd_fail(err, FFD_ERR_INVALID, "insertion kind %d", (int)in->kind);
    }
}

/* The requested topology of one insertion (design §3.1 types 1-3). */
static ffd_status apply_insertion(tsv_lattice *L, const ffd_tsv_insertion *in, ffd_error *err)
{
    ffd_status st;
    double x;
    if (in->kind == FFD_TSV_EDGE) {
        tsv_edge E = L->edges[in->id];
        if (tsv_kappa(E.lo) == tsv_kappa(E.hi))
            return ffd_fail(err, FFD_ERR_INVALID, "edge %u: zero knot interval", in->id);
        st = mid_sigma(L, E.axis, E.lo, E.hi, in->ratio == 0.0 ? 0.5 : in->ratio, &x, err);
        if (st != FFD_OK)
            return st;
        if (!(E.lo < x && x < E.hi))
            return FFD_OK; /* snapped onto an end: the point exists */
        return ffd_tsv_split_edge(L, in->id, x, NULL, err);
    }
    if (in->kind == FFD_TSV_FACE) {
        tsv_face F = L->faces[in->id];
        int ax[2];
        face_axes(F.normal, ax);
        uint32_t parts[2] = {in->id, UINT32_MAX};
        size_t np = 1;
        for (int i = 0; i < 2; i++) {
            if (tsv_kappa(F.lo[i]) == tsv_kappa(F.hi[i]))
                continue; /* zero interval: never split */
            st = mid_sigma(L, ax[i], F.lo[i], F.hi[i], 0.5, &x, err);
            if (st != FFD_OK)
                return st;
            size_t n0 = np;
            for (size_t j = 0; j < n0; j++) {
                st = ffd_tsv_split_face(L, parts[j], ax[i], x, err);
                if (st != FFD_OK)
                    return st;
                if (np < 2)
                    parts[np++] = (uint32_t)(L->nf - 1);
            }
        }
        return FFD_OK;
    }
    /* cell 1 -> 8: mid-s, both halves mid-t, the quarters mid-u */
    tsv_cell C = L->cells[in->id];
    uint32_t parts[8] = {in->id};
    size_t np = 1;
    for (int a = 0; a < 3; a++) {
        if (tsv_kappa(C.lo[a]) == tsv_kappa(C.hi[a]))
            continue;
        st = mid_sigma(L, a, C.lo[a], C.hi[a], 0.5, &x, err);
        if (st != FFD_OK)
            return st;
        size_t n0 = np;
        for (size_t j = 0; j < n0; j++) {
            st = ffd_tsv_split_cell(L, parts[j], a, x, err);
            if (st != FFD_OK)
                return st;
            parts[np++] = (uint32_t)(L->nc - 1);
        }
    }
    return FFD_OK;
}

static ffd_status refine_body(tsv_lattice *L, const ffd_tsv_insertion *ins, size_t count,
                              closure *Z, ffd_error *err)
{
    size_t nv0 = L->nv;
    /* pieces = the blending functions of the old lattice */
    if (!grow_heads(Z) || !infer_all(Z) ||
        !ffd_grow((void **)&Z->pc, &Z->cap_pc, nv0 ? nv0 : 1, sizeof *Z->pc))
        return ffd_fail(err, FFD_ERR_NOMEM, "tsv refine: out of memory");
    for (size_t v = 0; v < nv0; v++) {
        piece *P = &Z->pc[Z->npc++];
        const tsv_vertex *V = &L->verts[v];
        memcpy(P->p, Z->K[v], sizeof P->p);
        for (int ch = 0; ch < TSV_NCH; ch++)
            for (int k = 0; k < 3; k++)
                P->X[ch][k] = V->W * V->P[ch][k];
        P->W = V->W;
        P->dead = 0;
        P->orig = 1;
        P->owner = (uint32_t)v;
        P->next = UINT32_MAX;
        Z->head[v] = (uint32_t)v;
    }
    /* all the topology first (ids as before the edit) */
    for (size_t i = 0; i < count; i++) {
        ffd_status st = apply_insertion(L, &ins[i], err);
        if (st != FFD_OK)
            return st;
    }
    uint64_t guard = 100u * (uint64_t)nv0 + 1000u;
    ffd_status st = run_closure(Z, guard, err);
    if (st != FFD_OK)
        return st;
    /* finalize: W_v = sum W, P = sum X / W_v (design §3.4) */
    if (!grow_heads(Z))
        return ffd_fail(err, FFD_ERR_NOMEM, "tsv refine: out of memory");
    for (size_t v = 0; v < L->nv; v++) {
        uint32_t i = Z->head[v];
        if (i == UINT32_MAX)
            return ffd_fail(err, FFD_ERR_NUMERIC, "tsv refine: control point %zu has no blending "
                                                  "function", v);
        if (Z->pc[i].next != UINT32_MAX)
            return ffd_fail(err, FFD_ERR_NUMERIC,
                            "tsv refine: control point %zu has several blending functions", v);
        const piece *P = &Z->pc[i];
        if (!same_knots(&P->p[0][0], &Z->K[v][0][0]))
            return ffd_fail(err, FFD_ERR_NUMERIC,
                            "tsv refine: control point %zu: knots differ from the lattice's", v);
        if (!(P->W >= TSV_MIN_WEIGHT))
            return ffd_fail(err, FFD_ERR_NUMERIC, "tsv refine: control point %zu: weight %g", v,
                            P->W);
        if (P->orig)
            continue; /* never split: keeps its coordinates bit for bit */
        tsv_vertex *V = &L->verts[v];
        V->W = P->W;
        for (int ch = 0; ch < TSV_NCH; ch++)
            for (int k = 0; k < 3; k++)
                V->P[ch][k] = P->X[ch][k] / P->W;
    }
    return FFD_OK;
}

ffd_status ffd_tsv_lattice_refine(tsv_lattice *L, const ffd_tsv_insertion *ins, size_t count,
                      tsv_refine_stats *stats, ffd_error *err)
{
    return ffd_tsv_lattice_refine_undoable(L, ins, count, stats, NULL, err);
}

ffd_status ffd_tsv_lattice_refine_undoable(tsv_lattice *L, const ffd_tsv_insertion *ins, size_t count,
                               tsv_refine_stats *stats, tsv_lattice **undo, ffd_error *err)
{
    if (undo)
        *undo = NULL;
    if (stats)
        memset(stats, 0, sizeof *stats);
    if (count && !ins)
        return ffd_fail(err, FFD_ERR_INVALID, "tsv refine: NULL insertions");
    for (size_t i = 0; i < count; i++) {
        ffd_status st = check_insertion(L, &ins[i], err);
        if (st != FFD_OK)
            return st;
    }
    size_t nv0 = L->nv;
    uint64_t version0 = L->version;
    double *old = NULL;
    tsv_lattice *snap = NULL;
    closure Z;
    memset(&Z, 0, sizeof Z);
    Z.L = L;
    ffd_status st = FFD_OK;
    if (count) {
        snap = ffd_tsv_lattice_clone(L);
        old = ffd_malloc_array(nv0 ? 3 * nv0 : 1, sizeof *old);
        if (!snap || !old) {
            st = ffd_fail(err, FFD_ERR_NOMEM, "tsv refine: out of memory");
            goto done;
        }
        for (size_t v = 0; v < nv0; v++)
            memcpy(old + 3 * v, L->verts[v].P[TSV_CURRENT], 3 * sizeof *old);
        st = refine_body(L, ins, count, &Z, err);
        if (st != FFD_OK) {
            ffd_tsv_lattice_swap_in(L, snap); /* roll back */
            snap = NULL;
            goto done;
        }
    }
    if (stats) {
        stats->added_points = L->nv - nv0;
        stats->topology_steps = (size_t)(L->version - version0);
        for (size_t v = 0; v < nv0 && old; v++)
            if (memcmp(old + 3 * v, L->verts[v].P[TSV_CURRENT], 3 * sizeof *old) != 0)
                stats->moved_points++;
        stats->max_weight_deviation = ffd_tsv_lattice_max_weight_deviation(L);
    }
    if (undo) {
        *undo = snap; /* the lattice before the edit, for the caller's roll-back */
        snap = NULL;
    }
done:
    ffd_tsv_lattice_destroy(snap);
    ffd_free(old);
    closure_free(&Z);
    return st;
}
