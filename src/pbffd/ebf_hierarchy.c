/* pbffd — multiresolution editing (PB-FFD §3.4, eq. 9-10): building the
 * coarser levels by pairwise merging of the closest points, parameterising
 * each level in the next coarser one, and edits at any level: the edited
 * point is re-parameterised in the next coarser level at its new position
 * (the paper's re-parameterisation approach: the coarser levels stay where
 * they are and reproduce the point exactly), and the finer levels follow
 * through their rows (eq. 10). The cascade moves the centres of finer
 * points only: their frames stay as they are. */
#include "pbffd/pbffd.h"

#include <math.h>
#include <string.h>

/* ---- building a coarser level (§3.4): merge the two closest points until half remain ---- */

typedef struct merge_node {
    ffd_ebf ebf;   /* the control itself while unmerged, the enclosing sphere after */
    double radius; /* bounding-sphere radius of its ROI */
    size_t nn;     /* nearest alive neighbour */
    double nnd;    /* squared distance to it */
    int alive;
} merge_node;

static double dist2(const double a[3], const double b[3])
{
    double d0 = a[0] - b[0], d1 = a[1] - b[1], d2 = a[2] - b[2];
    return d0 * d0 + d1 * d1 + d2 * d2;
}

static void find_nn(merge_node *v, size_t m, size_t i)
{
    v[i].nn = SIZE_MAX;
    v[i].nnd = INFINITY;
    for (size_t j = 0; j < m; j++) {
        if (j == i || !v[j].alive)
            continue;
        double d = dist2(v[i].ebf.center, v[j].ebf.center);
        if (d < v[i].nnd || v[i].nn == SIZE_MAX) { /* an overflowed distance still names a point */
            v[i].nnd = d;
            v[i].nn = j;
        }
    }
}

/* Coarser level from the enabled controls of src: ceil(m/2) controls. */
static ffd_status decimate(const ffd_ebf *src, size_t count, ffd_ebf **out, size_t *out_count)
{
    size_t m = 0;
    for (size_t j = 0; j < count; j++)
        m += !src[j].disabled;
    merge_node *v = ffd_malloc_array(m ? m : 1, sizeof *v);
    if (!v)
        return FFD_ERR_NOMEM;
    size_t k = 0;
    for (size_t j = 0; j < count; j++) {
        if (src[j].disabled)
            continue;
        v[k].ebf = src[j];
        v[k].radius = ffd_ebf_bounding_radius(&src[j]);
        v[k].alive = 1;
        k++;
    }
    for (size_t i = 0; i < m; i++)
        find_nn(v, m, i);
    size_t alive = m, target = (m + 1) / 2;
    while (alive > target) {
        size_t a = SIZE_MAX;
        for (size_t i = 0; i < m; i++)
            if (v[i].alive && (a == SIZE_MAX || v[i].nnd < v[a].nnd))
                a = i;
        size_t b = v[a].nn;
        if (b < a) {
            size_t t = a;
            a = b;
            b = t;
        }
        /* the new point sits at the midpoint; its ROI is the sphere about the
         * midpoint that encloses both bounding spheres (the paper: "an
         * ellipsoid (or a sphere, as in our implementation) that completely
         * encloses" both), with an axis-aligned frame of that radius */
        double d = sqrt(dist2(v[a].ebf.center, v[b].ebf.center));
        double R = 0.5 * d + fmax(v[a].radius, v[b].radius);
        ffd_ebf e;
        memset(&e, 0, sizeof e);
        for (int c = 0; c < 3; c++) {
            e.center[c] = 0.5 * (v[a].ebf.center[c] + v[b].ebf.center[c]);
            e.frame[c][c] = R;
            e.radius[c] = R;
        }
        v[a].ebf = e;
        v[a].radius = R;
        v[b].alive = 0;
        alive--;
        find_nn(v, m, a);
        for (size_t i = 0; i < m; i++) {
            if (!v[i].alive || i == a)
                continue;
            if (v[i].nn == a || v[i].nn == b) {
                find_nn(v, m, i);
            } else {
                double dd = dist2(v[i].ebf.center, v[a].ebf.center);
                if (dd < v[i].nnd) {
                    v[i].nnd = dd;
                    v[i].nn = a;
                }
            }
        }
    }
    ffd_ebf *res = ffd_malloc_array(alive ? alive : 1, sizeof *res);
    if (!res) {
        ffd_free(v);
        return FFD_ERR_NOMEM;
    }
    k = 0;
    for (size_t i = 0; i < m; i++)
        if (v[i].alive) {
            res[k] = v[i].ebf;
            res[k].disabled = 0;
            k++;
        }
    ffd_free(v);
    *out = res;
    *out_count = alive;
    return FFD_OK;
}

/* Parameterises every point of level l in level l + 1 (eq. 10). */
static ffd_status bind_level(ffd_pbffd *pb, size_t l)
{
    ffd_pb_level *L = &pb->levels[l];
    double *centers = ffd_malloc_array(L->count, 3 * sizeof *centers);
    if (!centers)
        return FFD_ERR_NOMEM;
    for (size_t i = 0; i < L->count; i++)
        memcpy(centers + 3 * i, L->cur[i].center, 3 * sizeof *centers);
    ffd_ebf_space s;
    ffd_status st = ffd_pb_space(pb, l + 1, L->count > 64, &s);
    if (st == FFD_OK) {
        st = ffd_ebf_rows_bind(&s, centers, L->count, 1, 0, &L->rows);
        ffd_ebf_space_free(&s);
    }
    if (st == FFD_OK)
        st = ffd_ebf_rows_copy(&L->rows, 0, &L->rows_base);
    ffd_free(centers);
    return st;
}

ffd_status ffd_pb_build_hierarchy(ffd_pbffd *pb, uint32_t levels, ffd_error *err)
{
    for (uint32_t l = 1; l < levels; l++) {
        ffd_pb_level *below = &pb->levels[l - 1], *L = &pb->levels[l];
        ffd_status st = decimate(below->cur, below->count, &L->cur, &L->count);
        pb->level_count = l + 1;
        if (st == FFD_OK) {
            L->base = ffd_malloc_array(L->count, sizeof *L->base);
            L->changed = ffd_calloc(L->count, 1);
            if (!L->base || !L->changed)
                st = FFD_ERR_NOMEM;
            else
                memcpy(L->base, L->cur, L->count * sizeof *L->base);
        }
        if (st == FFD_OK)
            st = bind_level(pb, l - 1);
        if (st != FFD_OK)
            return ffd_fail(err, st, "out of memory building level %u", l);
    }
    return FFD_OK;
}

/* ---- edits ---- */

/* Re-parameterises point index of level in level + 1 at center; the new rows go to *out. */
static ffd_status reparam(const ffd_pbffd *pb, size_t level, size_t index, const double center[3],
                          ffd_ebf_rows *out)
{
    const ffd_pb_level *L = &pb->levels[level];
    ffd_ebf_space s;
    ffd_ebf_rows one;
    size_t *pick = ffd_malloc_array(L->rows.n, sizeof *pick);
    ffd_status st = pick ? ffd_pb_space(pb, level + 1, 0, &s) : FFD_ERR_NOMEM;
    if (st != FFD_OK) {
        ffd_free(pick);
        return st;
    }
    st = ffd_ebf_rows_bind(&s, center, 1, 1, 0, &one);
    ffd_ebf_space_free(&s);
    if (st == FFD_OK) {
        for (size_t i = 0; i < L->rows.n; i++)
            pick[i] = i == index ? L->rows.n : i;
        size_t min_cap = L->rows_base.start ? L->rows_base.start[L->rows_base.n] : 0;
        st = ffd_ebf_rows_splice(&L->rows, &one, pick, L->rows.n, NULL, min_cap, out);
        ffd_ebf_rows_free(&one);
    }
    ffd_free(pick);
    return st;
}

/* The finer levels follow (eq. 10): a point whose row names a changed control
 * of the level above is re-evaluated; the others are not touched. */
static void cascade(ffd_pbffd *pb, size_t level)
{
    for (size_t l = level; l-- > 0;) {
        ffd_pb_level *L = &pb->levels[l];
        const ffd_pb_level *U = &pb->levels[l + 1];
        memset(L->changed, 0, L->count);
        for (size_t i = 0; i < L->count; i++) {
            int hit = 0;
            for (size_t k = L->rows.start[i]; k < L->rows.start[i + 1] && !hit; k++)
                hit = U->changed[L->rows.col[k]];
            if (!hit)
                continue;
            ffd_ebf_rows_eval_abs(&L->rows, i, U->cur, L->cur[i].center);
            L->changed[i] = 1;
        }
    }
    for (size_t l = 0; l <= level; l++)
        memset(pb->levels[l].changed, 0, pb->levels[l].count);
}

ffd_status ffd_pb_place(ffd_pbffd *pb, size_t level, size_t index, const double center[3],
                        const double frame[3][3], ffd_error *err)
{
    ffd_pb_level *L = &pb->levels[level];
    int moved = center && memcmp(center, L->cur[index].center, 3 * sizeof(double)) != 0;
    int turned = frame && memcmp(frame, L->cur[index].frame, 9 * sizeof(double)) != 0;
    if (!moved && !turned)
        return FFD_OK; /* nothing changes: the finer levels are not re-evaluated */
    if (moved && level + 1 < pb->level_count) {
        ffd_ebf_rows nr;
        if (reparam(pb, level, index, center, &nr) != FFD_OK)
            return ffd_fail(err, FFD_ERR_NOMEM,
                            "out of memory re-parameterising level %zu control %zu", level, index);
        ffd_ebf_rows_free(&L->rows);
        L->rows = nr;
    }
    if (center)
        memcpy(L->cur[index].center, center, 3 * sizeof(double));
    if (frame)
        memcpy(L->cur[index].frame, frame, 9 * sizeof(double));
    L->changed[index] = 1;
    cascade(pb, level);
    return FFD_OK;
}

ffd_status ffd_pb_check_index(const ffd_pbffd *pb, size_t level, size_t index, ffd_error *err)
{
    if (level >= pb->level_count)
        return ffd_fail(err, FFD_ERR_RANGE, "level %zu out of range (%zu levels)", level,
                        pb->level_count);
    if (index >= pb->levels[level].count)
        return ffd_fail(err, FFD_ERR_RANGE, "control %zu out of range (%zu at level %zu)", index,
                        pb->levels[level].count, level);
    return FFD_OK;
}

ffd_status ffd_pbffd_move(ffd_pbffd *pb, size_t level, size_t index, const double delta[3],
                          ffd_error *err)
{
    ffd_status st = ffd_pb_check_index(pb, level, index, err);
    if (st != FFD_OK)
        return st;
    double c[3];
    for (int k = 0; k < 3; k++) {
        c[k] = pb->levels[level].cur[index].center[k] + delta[k];
        if (!isfinite(delta[k]) || !isfinite(c[k]))
            return ffd_fail(err, FFD_ERR_NONFINITE,
                            "move of level %zu control %zu: delta is not finite", level, index);
    }
    return ffd_pb_place(pb, level, index, c, NULL, err);
}

ffd_status ffd_pbffd_set_frame(ffd_pbffd *pb, size_t level, size_t index, const double frame[3][3],
                               ffd_error *err)
{
    ffd_status st = ffd_pb_check_index(pb, level, index, err);
    if (st != FFD_OK)
        return st;
    for (int a = 0; a < 3; a++)
        for (int c = 0; c < 3; c++)
            if (!isfinite(frame[a][c]))
                return ffd_fail(err, FFD_ERR_NONFINITE,
                                "level %zu control %zu: frame is not finite", level, index);
    if (ffd_ebf_frame_degenerate(frame))
        return ffd_fail(err, FFD_ERR_INVALID,
                        "level %zu control %zu: degenerate frame (parallel axes)", level, index);
    return ffd_pb_place(pb, level, index, NULL, frame, err);
}

void ffd_pbffd_reset(ffd_pbffd *pb)
{
    for (size_t l = 0; l < pb->level_count; l++) {
        ffd_pb_level *L = &pb->levels[l];
        memcpy(L->cur, L->base, L->count * sizeof *L->cur);
        if (L->rows.start) /* rows.cap >= the base rows' entries: no allocation */
            ffd_ebf_rows_assign(&L->rows, &L->rows_base);
    }
}
