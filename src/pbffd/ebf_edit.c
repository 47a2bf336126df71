/* pbffd — control-set edits on level 0 (PB-FFD §5: "the user could manually
 * add or remove" control points; §3.1: re-parameterisation), made in the
 * current, possibly deformed, state:
 *   1. the bound points are evaluated; that becomes their base, together with
 *      every level's current state (a rebase: eq. 7 is affine in P and A, so
 *      the rows still describe the same deformation relative to the new base);
 *   2. the points whose normalised weights (eq. 5) the edit changes, those
 *      whose row names the control and those inside its new ROI, are
 *      re-parameterised at their current positions against the new control
 *      set; no others are touched.
 * The level-0 point itself is (re-)parameterised in level 1 (eq. 10). The
 * coarser levels are not rebuilt. Each re-parameterisation is recorded
 * against a snapshot of level 0 (a version) so that the Jacobian stays the
 * derivative with respect to the original points. */
#include "pbffd/pbffd.h"

#include <math.h>
#include <string.h>

typedef enum edit_kind {
    EDIT_ADD,
    EDIT_REMOVE,
    EDIT_ENABLE,
    EDIT_DISABLE,
    EDIT_REDEFINE
} edit_kind;

/* Everything an edit allocates, so that it either commits whole or changes nothing. */
typedef struct edit_state {
    double *x_cur;      /* n by 3 current positions: the new base */
    unsigned char *hit; /* n flags: re-parameterised */
    size_t *which;      /* affected point indices */
    size_t na;
    double *J_pre;       /* na by 9: Jacobians before the edit */
    int need_J;          /* some J_pre is not the identity */
    ffd_ebf *cur, *base; /* level 0 after the edit */
    unsigned char *changed;
    size_t count;
    ffd_ebf_rows level_rows;  /* level 0 over level 1 after the edit (when levels > 1) */
    ffd_ebf_rows *rows_base;  /* level_count copies: the new base rows */
    ffd_ebf_rows mesh;        /* the bound points' rows after the edit */
    ffd_ebf *snapshot;        /* the new version */
    ffd_pb_version *versions; /* grown array (or NULL: the old one has a free slot) */
    uint32_t *version;        /* allocated when pb->version was NULL */
    double *J_ref;            /* allocated when needed and pb->J_ref was NULL */
} edit_state;

static void edit_state_free(const ffd_pbffd *pb, edit_state *s)
{
    ffd_free(s->x_cur);
    ffd_free(s->hit);
    ffd_free(s->which);
    ffd_free(s->J_pre);
    ffd_free(s->cur);
    ffd_free(s->base);
    ffd_free(s->changed);
    ffd_ebf_rows_free(&s->level_rows);
    if (s->rows_base)
        for (size_t l = 0; l < pb->level_count; l++)
            ffd_ebf_rows_free(&s->rows_base[l]);
    ffd_free(s->rows_base);
    ffd_ebf_rows_free(&s->mesh);
    ffd_free(s->snapshot);
    ffd_free(s->versions);
    ffd_free(s->version);
    ffd_free(s->J_ref);
}

static int is_identity(const double J[9])
{
    for (int k = 0; k < 9; k++)
        if (J[k] != (k % 4 == 0 ? 1.0 : 0.0))
            return 0;
    return 1;
}

/* Level 0's rows over level 1 after the edit. */
static ffd_status edit_level_rows(const ffd_pbffd *pb, edit_kind kind, size_t j, edit_state *s)
{
    const ffd_pb_level *L = &pb->levels[0];
    if (pb->level_count < 2)
        return FFD_OK;
    const int fresh = kind == EDIT_ADD ||
                      (kind == EDIT_REDEFINE &&
                       memcmp(s->cur[j].center, L->cur[j].center, sizeof L->cur[j].center) != 0);
    ffd_ebf_rows one;
    memset(&one, 0, sizeof one);
    ffd_status st = FFD_OK;
    if (fresh) {
        ffd_ebf_space sp;
        if ((st = ffd_pb_space(pb, 1, 0, &sp)) != FFD_OK)
            return st;
        st = ffd_ebf_rows_bind(&sp, s->cur[j].center, 1, 1, 0, &one);
        ffd_ebf_space_free(&sp);
        if (st != FFD_OK)
            return st;
    }
    size_t *pick = ffd_malloc_array(s->count ? s->count : 1, sizeof *pick);
    if (!pick) {
        ffd_ebf_rows_free(&one);
        return FFD_ERR_NOMEM;
    }
    for (size_t r = 0; r < s->count; r++) {
        size_t old = kind == EDIT_REMOVE && r >= j ? r + 1 : r;
        pick[r] = fresh && r == j ? L->rows.n : old;
    }
    st = ffd_ebf_rows_splice(&L->rows, &one, pick, s->count, NULL, 0, &s->level_rows);
    ffd_free(pick);
    ffd_ebf_rows_free(&one);
    return st;
}

static ffd_status edit(ffd_pbffd *pb, edit_kind kind, size_t j, const ffd_ebf *ctl, ffd_error *err)
{
    ffd_pb_level *L0 = &pb->levels[0];
    const size_t n = pb->n, M = L0->count;
    edit_state s;
    memset(&s, 0, sizeof s);
    ffd_status st = FFD_OK;
    ffd_ebf_kernel **vk = NULL;

    /* the new control set */
    s.count = kind == EDIT_ADD ? M + 1 : (kind == EDIT_REMOVE ? M - 1 : M);
    s.cur = ffd_malloc_array(s.count, sizeof *s.cur);
    s.base = ffd_malloc_array(s.count, sizeof *s.base);
    s.changed = ffd_calloc(s.count, 1);
    s.snapshot = ffd_malloc_array(s.count, sizeof *s.snapshot);
    s.x_cur = ffd_malloc_array(n ? n : 1, 3 * sizeof *s.x_cur);
    s.hit = ffd_calloc(n ? n : 1, 1);
    s.rows_base = ffd_calloc(pb->level_count, sizeof *s.rows_base);
    if (!s.cur || !s.base || !s.changed || !s.snapshot || !s.x_cur || !s.hit || !s.rows_base)
        goto nomem;
    for (size_t r = 0; r < s.count; r++)
        s.cur[r] = L0->cur[kind == EDIT_REMOVE && r >= j ? r + 1 : (r < M ? r : 0)];
    if (kind == EDIT_ADD || kind == EDIT_REDEFINE) {
        int disabled = kind == EDIT_ADD ? (ctl->disabled ? 1 : 0) : L0->cur[j].disabled;
        s.cur[j] = *ctl;
        s.cur[j].disabled = disabled;
    } else if (kind == EDIT_ENABLE || kind == EDIT_DISABLE) {
        s.cur[j].disabled = kind == EDIT_DISABLE;
    }

    /* 1. the current positions become the base */
    if (ffd_pbffd_eval(pb, s.x_cur, NULL) != FFD_OK)
        goto nomem;

    /* 2. who is re-parameterised: rows naming j, points inside j's new ROI */
    if (kind != EDIT_ADD)
        for (size_t i = 0; i < n; i++)
            for (size_t k = pb->mesh.start[i]; k < pb->mesh.start[i + 1]; k++)
                if (pb->mesh.col[k] == j)
                    s.hit[i] = 1;
    if ((kind == EDIT_ADD || kind == EDIT_ENABLE || kind == EDIT_REDEFINE) && !s.cur[j].disabled) {
        ffd_ebf_kernel k;
        ffd_ebf_kernel_init(&s.cur[j], 1.0, &k);
        const double inv2s2 = 1.0 / (2.0 * pb->sigma * pb->sigma);
        for (size_t i = 0; i < n; i++)
            if (!s.hit[i] && ffd_ebf_phi(&k, inv2s2, s.x_cur + 3 * i, NULL, NULL) > 0.0)
                s.hit[i] = 1;
    }
    for (size_t i = 0; i < n; i++)
        s.na += s.hit[i];
    s.which = ffd_malloc_array(s.na ? s.na : 1, sizeof *s.which);
    s.J_pre = ffd_malloc_array(s.na ? s.na : 1, 9 * sizeof *s.J_pre);
    if (!s.which || !s.J_pre)
        goto nomem;
    for (size_t i = 0, a = 0; i < n; i++)
        if (s.hit[i])
            s.which[a++] = i;

    /* their Jacobians so far (they carry them into the new parameterisation) */
    if (s.na) {
        if (ffd_pb_version_kernels(pb, &vk) != FFD_OK)
            goto nomem;
        ffd_ebf_kernel master;
        ffd_ebf_kernel_init(&pb->master, pb->master_weight, &master);
        for (size_t a = 0; a < s.na; a++) {
            ffd_pb_jacobian_point(pb, vk, pb->has_master ? &master : NULL, s.which[a],
                                  s.J_pre + 9 * a);
            if (!is_identity(s.J_pre + 9 * a))
                s.need_J = 1;
        }
        ffd_pb_version_kernels_free(pb, vk);
        vk = NULL;
    }

    /* level 0 over level 1 (eq. 10) */
    if ((st = edit_level_rows(pb, kind, j, &s)) != FFD_OK)
        goto nomem;
    for (size_t l = 0; l < pb->level_count; l++) {
        const ffd_ebf_rows *src = l == 0 ? &s.level_rows : &pb->levels[l].rows;
        if (src->start && ffd_ebf_rows_copy(src, 0, &s.rows_base[l]) != FFD_OK)
            goto nomem;
    }

    /* 3. re-parameterise the affected points at their current positions (eq. 3-7) */
    {
        double *pts = ffd_malloc_array(s.na ? s.na : 1, 3 * sizeof *pts);
        size_t *pick = ffd_malloc_array(n ? n : 1, sizeof *pick);
        uint32_t *colmap = kind == EDIT_REMOVE ? ffd_malloc_array(M, sizeof *colmap) : NULL;
        ffd_ebf_rows sub;
        ffd_ebf_space sp;
        memset(&sub, 0, sizeof sub);
        st = pts && pick && (kind != EDIT_REMOVE || colmap) ? FFD_OK : FFD_ERR_NOMEM;
        if (st == FFD_OK) {
            for (size_t a = 0; a < s.na; a++)
                memcpy(pts + 3 * a, s.x_cur + 3 * s.which[a], 3 * sizeof *pts);
            st = ffd_ebf_space_init(&sp, s.cur, s.count, pb->has_master ? &pb->master : NULL,
                                    pb->master_weight, pb->sigma, s.na > 64);
            if (st == FFD_OK) {
                st = ffd_ebf_rows_bind(&sp, pts, s.na, 0, 0, &sub);
                ffd_ebf_space_free(&sp);
            }
        }
        if (st == FFD_OK) {
            for (size_t i = 0, a = 0; i < n; i++)
                pick[i] = s.hit[i] ? n + a++ : i;
            if (colmap)
                for (size_t c = 0; c < M; c++)
                    colmap[c] = c < j ? (uint32_t)c : (c == j ? UINT32_MAX : (uint32_t)(c - 1));
            st = ffd_ebf_rows_splice(&pb->mesh, &sub, pick, n, colmap, 0, &s.mesh);
        }
        ffd_ebf_rows_free(&sub);
        ffd_free(pts);
        ffd_free(pick);
        ffd_free(colmap);
        if (st != FFD_OK)
            goto nomem;
    }

    /* bookkeeping that must exist before the commit */
    size_t slot = pb->version_count;
    for (size_t v = 0; v < pb->version_count; v++)
        if (!pb->versions[v].ctl) {
            slot = v;
            break;
        }
    if (slot == pb->version_count) {
        s.versions = ffd_malloc_array(pb->version_count + 1, sizeof *s.versions);
        if (!s.versions)
            goto nomem;
    }
    if (!pb->version && s.na) {
        s.version = ffd_calloc(n ? n : 1, sizeof *s.version);
        if (!s.version)
            goto nomem;
    }
    if (!pb->J_ref && s.need_J) {
        s.J_ref = ffd_malloc_array(n ? n : 1, 9 * sizeof *s.J_ref);
        if (!s.J_ref)
            goto nomem;
        for (size_t i = 0; i < n; i++)
            for (int k = 0; k < 9; k++)
                s.J_ref[9 * i + k] = k % 4 == 0 ? 1.0 : 0.0;
    }

    /* ---- commit: nothing below fails ---- */
    if (kind == EDIT_REMOVE)
        for (size_t v = 0; v < pb->version_count; v++) {
            ffd_pb_version *V = &pb->versions[v];
            if (V->ctl && V->count > j) {
                memmove(V->ctl + j, V->ctl + j + 1, (V->count - j - 1) * sizeof *V->ctl);
                V->count--;
            }
        }
    if (s.versions) {
        memcpy(s.versions, pb->versions, pb->version_count * sizeof *s.versions);
        ffd_free(pb->versions);
        pb->versions = s.versions;
        s.versions = NULL;
        pb->versions[slot].ctl = NULL;
        pb->version_count++;
    }
    memcpy(s.snapshot, s.cur, s.count * sizeof *s.cur);
    pb->versions[slot].ctl = s.snapshot;
    pb->versions[slot].count = s.count;
    pb->versions[slot].refs = 0;
    s.snapshot = NULL;
    if (s.version) {
        pb->version = s.version;
        s.version = NULL;
    }
    if (s.J_ref) {
        pb->J_ref = s.J_ref;
        s.J_ref = NULL;
    }
    for (size_t a = 0; a < s.na; a++) {
        size_t i = s.which[a];
        pb->versions[pb->version[i]].refs--;
        pb->version[i] = (uint32_t)slot;
        pb->versions[slot].refs++;
        memcpy(pb->x_ref + 3 * i, s.x_cur + 3 * i, 3 * sizeof(double));
        if (pb->J_ref)
            memcpy(pb->J_ref + 9 * i, s.J_pre + 9 * a, 9 * sizeof(double));
    }
    pb->version_latest = (uint32_t)slot;
    for (size_t v = 0; v < pb->version_count; v++)
        if (v != slot && pb->versions[v].ctl && pb->versions[v].refs == 0) {
            ffd_free(pb->versions[v].ctl);
            pb->versions[v].ctl = NULL;
            pb->versions[v].count = 0;
        }
    ffd_free(pb->x_base);
    pb->x_base = s.x_cur;
    s.x_cur = NULL;
    ffd_ebf_rows_free(&pb->mesh);
    pb->mesh = s.mesh;
    memset(&s.mesh, 0, sizeof s.mesh);
    /* level 0's new control set; every level rebased */
    memcpy(s.base, s.cur, s.count * sizeof *s.cur);
    ffd_free(L0->cur);
    ffd_free(L0->base);
    ffd_free(L0->changed);
    L0->cur = s.cur;
    L0->base = s.base;
    L0->changed = s.changed;
    L0->count = s.count;
    s.cur = s.base = NULL;
    s.changed = NULL;
    if (pb->level_count > 1) {
        ffd_ebf_rows_free(&L0->rows);
        L0->rows = s.level_rows;
        memset(&s.level_rows, 0, sizeof s.level_rows);
    }
    for (size_t l = 0; l < pb->level_count; l++) {
        ffd_pb_level *L = &pb->levels[l];
        if (l > 0)
            memcpy(L->base, L->cur, L->count * sizeof *L->cur);
        if (s.rows_base[l].start) {
            ffd_ebf_rows_free(&L->rows_base);
            L->rows_base = s.rows_base[l];
            memset(&s.rows_base[l], 0, sizeof s.rows_base[l]);
        }
    }
    edit_state_free(pb, &s);
    pb->edit_count++;
    pb->rebase_count++;
    return FFD_OK;
nomem:
    ffd_pb_version_kernels_free(pb, vk);
    edit_state_free(pb, &s);
    return ffd_fail(err, FFD_ERR_NOMEM, "out of memory editing the control set");
}

/* An edit of a control that is disabled before and after it (adding a
 * disabled control, removing or redefining a disabled one) changes no weight
 * row and no position, so it does not rebase: the base state, the rows and
 * what reset returns to stay as they are, bitwise; only the control set and,
 * with levels, the control's own row in level 1 (eq. 10) change. That row is
 * bound against level 1's current state (rows) and its base (rows_base), as
 * if the control had been there from the start. */
static ffd_status edit_inert(ffd_pbffd *pb, edit_kind kind, size_t j, const ffd_ebf *ctl,
                             ffd_error *err)
{
    ffd_pb_level *L0 = &pb->levels[0];
    const size_t M = L0->count, n = pb->n;
    const size_t count = kind == EDIT_ADD ? M + 1 : (kind == EDIT_REMOVE ? M - 1 : M);
    ffd_ebf *cur = ffd_malloc_array(count, sizeof *cur);
    ffd_ebf *base = ffd_malloc_array(count, sizeof *base);
    unsigned char *changed = ffd_calloc(count, 1);
    uint32_t *colmap = kind == EDIT_REMOVE ? ffd_malloc_array(M, sizeof *colmap) : NULL;
    size_t *pick = ffd_malloc_array((n > count ? n : count) + 1, sizeof *pick);
    ffd_ebf_rows mesh, rows, rows_base, one_cur, one_base;
    memset(&mesh, 0, sizeof mesh);
    memset(&rows, 0, sizeof rows);
    memset(&rows_base, 0, sizeof rows_base);
    memset(&one_cur, 0, sizeof one_cur);
    memset(&one_base, 0, sizeof one_base);
    ffd_status st = cur && base && changed && pick && (kind != EDIT_REMOVE || colmap)
                        ? FFD_OK
                        : FFD_ERR_NOMEM;
    if (st == FFD_OK) {
        for (size_t r = 0; r < count; r++) {
            size_t old = kind == EDIT_REMOVE && r >= j ? r + 1 : r;
            if ((kind == EDIT_ADD || kind == EDIT_REDEFINE) && r == j) {
                cur[r] = *ctl;
                cur[r].disabled = 1;
                base[r] = cur[r];
            } else {
                cur[r] = L0->cur[old];
                base[r] = L0->base[old];
            }
        }
    }
    /* the bound points: the same rows (columns after j shift down on remove) */
    if (st == FFD_OK && colmap) {
        for (size_t c = 0; c < M; c++)
            colmap[c] = c < j ? (uint32_t)c : (c == j ? UINT32_MAX : (uint32_t)(c - 1));
        for (size_t i = 0; i < n; i++)
            pick[i] = i;
        st = ffd_ebf_rows_splice(&pb->mesh, &pb->mesh, pick, n, colmap, 0, &mesh);
    }
    /* level 0 over level 1: the control's own row */
    if (st == FFD_OK && pb->level_count > 1) {
        const ffd_pb_level *L1 = &pb->levels[1];
        if (kind != EDIT_REMOVE) {
            ffd_ebf_space sp;
            for (int b = 0; b < 2 && st == FFD_OK; b++) {
                st = ffd_ebf_space_init(&sp, b ? L1->base : L1->cur, L1->count,
                                        pb->has_master ? &pb->master : NULL, pb->master_weight,
                                        pb->sigma, 0);
                if (st == FFD_OK) {
                    st = ffd_ebf_rows_bind(&sp, cur[j].center, 1, 1, 0, b ? &one_base : &one_cur);
                    ffd_ebf_space_free(&sp);
                }
            }
        }
        for (size_t r = 0; r < count; r++) {
            size_t old = kind == EDIT_REMOVE && r >= j ? r + 1 : r;
            pick[r] = kind != EDIT_REMOVE && r == j ? L0->rows.n : old;
        }
        if (st == FFD_OK)
            st = ffd_ebf_rows_splice(&L0->rows_base, &one_base, pick, count, NULL, 0, &rows_base);
        if (st == FFD_OK) /* reset assigns rows_base to rows without allocating */
            st = ffd_ebf_rows_splice(&L0->rows, &one_cur, pick, count, NULL,
                                     rows_base.start[count], &rows);
    }
    ffd_ebf_rows_free(&one_cur);
    ffd_ebf_rows_free(&one_base);
    ffd_free(pick);
    ffd_free(colmap);
    if (st != FFD_OK) {
        ffd_free(cur);
        ffd_free(base);
        ffd_free(changed);
        ffd_ebf_rows_free(&mesh);
        ffd_ebf_rows_free(&rows);
        ffd_ebf_rows_free(&rows_base);
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory editing the control set");
    }
    /* ---- commit: nothing below fails ---- */
    if (kind == EDIT_REMOVE) {
        for (size_t v = 0; v < pb->version_count; v++) {
            ffd_pb_version *V = &pb->versions[v];
            if (V->ctl && V->count > j) {
                memmove(V->ctl + j, V->ctl + j + 1, (V->count - j - 1) * sizeof *V->ctl);
                V->count--;
            }
        }
        ffd_ebf_rows_free(&pb->mesh);
        pb->mesh = mesh;
    }
    ffd_free(L0->cur);
    ffd_free(L0->base);
    ffd_free(L0->changed);
    L0->cur = cur;
    L0->base = base;
    L0->changed = changed;
    L0->count = count;
    if (pb->level_count > 1) {
        ffd_ebf_rows_free(&L0->rows);
        ffd_ebf_rows_free(&L0->rows_base);
        L0->rows = rows;
        L0->rows_base = rows_base;
    }
    pb->edit_count++;
    return FFD_OK;
}

static ffd_status check_index(const ffd_pbffd *pb, size_t index, ffd_error *err)
{
    if (index >= pb->levels[0].count)
        return ffd_fail(err, FFD_ERR_RANGE, "control %zu out of range (%zu controls)", index,
                        pb->levels[0].count);
    return FFD_OK;
}

ffd_status ffd_pbffd_add(ffd_pbffd *pb, const ffd_ebf *control, size_t *index, ffd_error *err)
{
    if (!control)
        return ffd_fail(err, FFD_ERR_INVALID, "control is NULL");
    size_t j = pb->levels[0].count;
    if (j + 1 >= UINT32_MAX)
        return ffd_fail(err, FFD_ERR_INVALID, "too many controls");
    ffd_status st = ffd_ebf_check(control, "control", j, err);
    if (st != FFD_OK)
        return st;
    st = control->disabled ? edit_inert(pb, EDIT_ADD, j, control, err)
                           : edit(pb, EDIT_ADD, j, control, err);
    if (st == FFD_OK && index)
        *index = j;
    return st;
}

ffd_status ffd_pbffd_remove(ffd_pbffd *pb, size_t index, ffd_error *err)
{
    ffd_status st = check_index(pb, index, err);
    if (st != FFD_OK)
        return st;
    if (pb->levels[0].count == 1)
        return ffd_fail(err, FFD_ERR_INVALID, "control %zu: cannot remove the only control point",
                        index);
    if (pb->levels[0].cur[index].disabled)
        return edit_inert(pb, EDIT_REMOVE, index, NULL, err);
    return edit(pb, EDIT_REMOVE, index, NULL, err);
}

ffd_status ffd_pbffd_set_enabled(ffd_pbffd *pb, size_t index, int enabled, ffd_error *err)
{
    ffd_status st = check_index(pb, index, err);
    if (st != FFD_OK)
        return st;
    if (!pb->levels[0].cur[index].disabled == !!enabled)
        return FFD_OK;
    return edit(pb, enabled ? EDIT_ENABLE : EDIT_DISABLE, index, NULL, err);
}

ffd_status ffd_pbffd_redefine(ffd_pbffd *pb, size_t index, const ffd_ebf *control, ffd_error *err)
{
    ffd_status st = check_index(pb, index, err);
    if (st != FFD_OK)
        return st;
    if (!control)
        return ffd_fail(err, FFD_ERR_INVALID, "control is NULL");
    st = ffd_ebf_check(control, "control", index, err);
    if (st != FFD_OK)
        return st;
    if (pb->levels[0].cur[index].disabled)
        return edit_inert(pb, EDIT_REDEFINE, index, control, err);
    return edit(pb, EDIT_REDEFINE, index, control, err);
}
