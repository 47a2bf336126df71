/* sensitivities — dX/dP of a deformer's bound points (ffd.h "Sensitivities",
 * docs/sensitivities.md). For a linear method the deformed points are
 * x'_i = x_i + sum_c w_ic (p_tie(c) - p0_tie(c)) (Hsu et al. 1992, eq. 2 in
 * the displacement form of docs/architecture.md), so with the slots' weights
 * added onto the control each slot follows (the selection matrix S of eq. 5,
 * W = B S) the derivative is d x'_ia / d p_jb = W_ij delta_ab: the same
 * for the three coordinates, exact, and independent of where the controls
 * are. Everything here goes through the method's linear map (map_points),
 * so every linear method gets it without a copy; a method may provide the
 * two products itself (sess_vtable.sensitivity_product, _transpose_product)
 * and then, without a linear map, forming W goes through them, one control
 * at a time. The lattice gives both products block by block over its
 * binding, as its evaluation (lattice_eval.c, lattice_sensitivity.c).
 *
 * One thread, rows in order: a method's row function may use scratch of
 * its map's own (PB-FFD's composed levels do), so the generic path never
 * calls it from two threads; every result is then the same for any thread
 * count. The methods' own products run in parallel where they can. */
#include "deformer/method.h"

#include <stdlib.h>
#include <string.h>

/* One entry of a row on its way to CSR: the control it lands on and the
 * entry's position in the method's row (ties summed in that order). */
typedef struct row_entry {
    uint32_t var;
    uint32_t pos;
    double w;
} row_entry;

/* Scratch for one row: the method's entries and the merged ones. */
typedef struct row_scratch {
    uint32_t *columns;
    double *weights;
    row_entry *entries;
} row_scratch;

static int scratch_init(row_scratch *s, size_t max_nnz)
{
    size_t n = max_nnz ? max_nnz : 1;
    s->columns = ffd_malloc_array(n, sizeof *s->columns);
    s->weights = ffd_malloc_array(n, sizeof *s->weights);
    s->entries = ffd_malloc_array(n, sizeof *s->entries);
    return s->columns && s->weights && s->entries;
}

static void scratch_free(row_scratch *s)
{
    ffd_free(s->columns);
    ffd_free(s->weights);
    ffd_free(s->entries);
}

static int entry_order(const void *pa, const void *pb)
{
    const row_entry *a = pa, *b = pb;
    if (a->var != b->var)
        return a->var < b->var ? -1 : 1;
    return a->pos < b->pos ? -1 : a->pos > b->pos;
}

/* Row i of W = B S: the method's row, slots mapped to their controls
 * (fixed slots dropped), sorted by control, duplicates summed in the
 * order they came, exact zeros left out. Returns the merged count;
 * entries in s->entries. */
static size_t merged_row(const ffd_linear_map *map, size_t i, row_scratch *s)
{
    size_t k = map->row(map->self, i, s->columns, s->weights), n = 0;
    for (size_t e = 0; e < k; e++) {
        uint32_t var = map->tie ? map->tie[s->columns[e]] : s->columns[e];
        if (var == FFD_TIE_FIXED)
            continue;
        s->entries[n++] = (row_entry){var, (uint32_t)e, s->weights[e]};
    }
    size_t unsorted = 0;
    for (size_t e = 1; e < n && !unsorted; e++)
        unsorted = s->entries[e].var < s->entries[e - 1].var;
    if (!unsorted) {
        /* a Bernstein row, or no ties: already in order */
    } else if (n > 64) {
        qsort(s->entries, n, sizeof *s->entries, entry_order);
    } else { /* rows arrive nearly sorted; insertion sort is stable */
        for (size_t a = 1; a < n; a++) {
            row_entry x = s->entries[a];
            size_t b = a;
            for (; b > 0 && s->entries[b - 1].var > x.var; b--)
                s->entries[b] = s->entries[b - 1];
            s->entries[b] = x;
        }
    }
    size_t m = 0;
    for (size_t e = 0; e < n; e++) {
        if (m && s->entries[m - 1].var == s->entries[e].var)
            s->entries[m - 1].w += s->entries[e].w;
        else
            s->entries[m++] = s->entries[e];
    }
    /* a basis function that vanishes at the point (a cubic B-spline at the
     * end of its support) is not an entry of W */
    size_t kept = 0;
    for (size_t e = 0; e < m; e++)
        if (s->entries[e].w != 0)
            s->entries[kept++] = s->entries[e];
    return kept;
}

static ffd_status no_linear_map(const char *what, const char *method, ffd_error *err)
{
    return ffd_fail(err, FFD_ERR_UNSUPPORTED,
                    "%s: the %s method has no sensitivities: its deformed points are not a "
                    "linear map of its controls (docs/sensitivities.md)",
                    what, method);
}

/* The deformer's linear map, checked against its control count. */
static ffd_status deformer_map(ffd_deformer *d, const char *what, ffd_linear_map *map,
                               ffd_error *err)
{
    const sess_binding *b = NULL;
    sess_method *m = ffd_deformer_session_method(d, &b);
    if (!ffd_sess_caps(m)->map_points)
        return no_linear_map(what, ffd_sess_caps(m)->name, err);
    ffd_error inner = {{0}};
    ffd_status st = m->vt->map_points(m, b, map, &inner);
    if (st == FFD_ERR_UNSUPPORTED) /* e.g. PB-FFD with a frame at a coarser level */
        return ffd_fail(err, st, "%s: the %s method has no sensitivities here: %s", what,
                        ffd_sess_caps(m)->name, inner.message);
    if (st)
        return ffd_fail(err, st, "%s: %s", what, inner.message);
    if (map->point_count != ffd_deformer_point_count(d)
        || map->variable_count != ffd_deformer_control_count(d) || map->variable_count > UINT32_MAX)
        return ffd_fail(err, FFD_ERR_INVALID,
                        "%s: the %s method's linear map has %zu rows and %zu variables for %zu "
                        "points and %zu controls",
                        what, ffd_sess_caps(m)->name, map->point_count, map->variable_count,
                        ffd_deformer_point_count(d), ffd_deformer_control_count(d));
    return FFD_OK;
}

void ffd_sparse_free(ffd_sparse *m)
{
    if (!m)
        return;
    ffd_free(m->row_ptr);
    ffd_free(m->col);
    ffd_free(m->val);
    memset(m, 0, sizeof *m);
}

/* ---------------------------------------------------------------------
 * W from the linear map: count each row, then fill it (rows in parallel).
 * --------------------------------------------------------------------- */

static ffd_status sparse_alloc(ffd_sparse *out, size_t rows, size_t cols, ffd_error *err)
{
    memset(out, 0, sizeof *out);
    out->rows = rows;
    out->cols = cols;
    out->row_ptr = ffd_calloc(rows + 1, sizeof *out->row_ptr);
    if (!out->row_ptr || rows + 1 == 0)
        return ffd_fail(err, FFD_ERR_NOMEM, "sensitivities: out of memory for %zu rows", rows);
    return FFD_OK;
}

static ffd_status sparse_alloc_entries(ffd_sparse *out, ffd_error *err)
{
    out->nnz = out->row_ptr[out->rows];
    out->col = ffd_malloc_array(out->nnz ? out->nnz : 1, sizeof *out->col);
    out->val = ffd_malloc_array(out->nnz ? out->nnz : 1, sizeof *out->val);
    if (!out->col || !out->val)
        return ffd_fail(err, FFD_ERR_NOMEM, "sensitivities: out of memory for %zu entries",
                        out->nnz);
    return FFD_OK;
}

static ffd_status form_from_map(const ffd_linear_map *map, ffd_sparse *out, ffd_error *err)
{
    size_t rows = map->point_count;
    ffd_status st = sparse_alloc(out, rows, map->variable_count, err);
    if (st)
        return st;
    row_scratch s;
    if (!scratch_init(&s, map->max_row_nnz)) {
        scratch_free(&s);
        return ffd_fail(err, FFD_ERR_NOMEM, "sensitivities: out of memory for a row of %zu entries",
                        map->max_row_nnz);
    }
    for (int pass = 0; pass < 2 && !st; pass++) {
        for (size_t i = 0; i < rows; i++) {
            size_t m = merged_row(map, i, &s);
            if (pass == 0) {
                out->row_ptr[i + 1] = out->row_ptr[i] + m;
                continue;
            }
            size_t at = out->row_ptr[i];
            for (size_t e = 0; e < m; e++) {
                out->col[at + e] = s.entries[e].var;
                out->val[at + e] = s.entries[e].w;
            }
        }
        if (pass == 0)
            st = sparse_alloc_entries(out, err);
    }
    scratch_free(&s);
    return st;
}

/* W through a method's own product: column j is W e_j (coordinate x of
 * control j set to 1), its non-zeros gathered by row. */
static ffd_status form_from_products(sess_method *m, const sess_binding *b, size_t rows,
                                     size_t cols, ffd_sparse *out, ffd_error *err)
{
    ffd_status st = sparse_alloc(out, rows, cols, err);
    if (st)
        return st;
    double *v = ffd_calloc(cols ? cols : 1, 3 * sizeof *v);
    double *x = ffd_malloc_array(rows ? rows : 1, 3 * sizeof *x);
    size_t *fill = ffd_malloc_array(rows ? rows : 1, sizeof *fill);
    if (!v || !x || !fill) {
        st = ffd_fail(err, FFD_ERR_NOMEM, "sensitivities: out of memory for %zu points", rows);
        goto done;
    }
    for (int pass = 0; pass < 2 && !st; pass++) {
        for (size_t j = 0; j < cols && !st; j++) {
            v[3 * j] = 1;
            st = m->vt->sensitivity_product(m, b, v, x, err);
            v[3 * j] = 0;
            for (size_t i = 0; i < rows && !st; i++) {
                if (x[3 * i] == 0)
                    continue;
                if (pass == 0) {
                    out->row_ptr[i + 1]++;
                } else {
                    out->col[fill[i]] = (uint32_t)j;
                    out->val[fill[i]++] = x[3 * i];
                }
            }
        }
        if (pass == 0 && !st) {
            for (size_t i = 0; i < rows; i++) {
                out->row_ptr[i + 1] += out->row_ptr[i];
                fill[i] = out->row_ptr[i];
            }
            st = sparse_alloc_entries(out, err);
        }
    }
done:
    ffd_free(v);
    ffd_free(x);
    ffd_free(fill);
    return st;
}

ffd_status ffd_deformer_sensitivities(ffd_deformer *d, ffd_sparse *out, ffd_error *err)
{
    if (!d || !out)
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_deformer_sensitivities: NULL argument");
    memset(out, 0, sizeof *out);
    const sess_binding *b = NULL;
    sess_method *m = ffd_deformer_session_method(d, &b);
    ffd_status st;
    if (ffd_sess_caps(m)->map_points) {
        ffd_linear_map map;
        st = deformer_map(d, "sensitivities", &map, err);
        if (!st)
            st = form_from_map(&map, out, err);
    } else if (ffd_sess_caps(m)->sensitivity_product) {
        st = form_from_products(m, b, ffd_deformer_point_count(d), ffd_deformer_control_count(d),
                                out, err);
    } else {
        st = no_linear_map("sensitivities", ffd_sess_caps(m)->name, err);
    }
    if (st)
        ffd_sparse_free(out);
    return st;
}

/* ---------------------------------------------------------------------
 * Products without forming W.
 * --------------------------------------------------------------------- */

/* out = W v (transpose 0) or W^T w (transpose 1), row by row in order. */
static ffd_status products_from_map(const ffd_linear_map *map, const double *x, double *out,
                                    int transpose, const char *what, ffd_error *err)
{
    row_scratch s;
    if (!scratch_init(&s, map->max_row_nnz)) {
        scratch_free(&s);
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory for a row of %zu entries", what,
                        map->max_row_nnz);
    }
    if (transpose)
        memset(out, 0, map->variable_count * 3 * sizeof *out);
    for (size_t i = 0; i < map->point_count; i++) {
        size_t m = merged_row(map, i, &s);
        if (transpose) {
            for (size_t e = 0; e < m; e++)
                for (int a = 0; a < 3; a++)
                    out[3 * (size_t)s.entries[e].var + a] += s.entries[e].w * x[3 * i + a];
            continue;
        }
        double y[3] = {0, 0, 0};
        for (size_t e = 0; e < m; e++)
            for (int a = 0; a < 3; a++)
                y[a] += s.entries[e].w * x[3 * (size_t)s.entries[e].var + a];
        memcpy(out + 3 * i, y, sizeof y);
    }
    scratch_free(&s);
    return FFD_OK;
}

ffd_status ffd_deformer_sensitivity_product(ffd_deformer *d, const double *v, double *out,
                                            ffd_error *err)
{
    const char *what = "sensitivity product";
    if (!d || (!v && ffd_deformer_control_count(d)) || (!out && ffd_deformer_point_count(d)))
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_deformer_sensitivity_product: NULL argument");
    const sess_binding *b = NULL;
    sess_method *m = ffd_deformer_session_method(d, &b);
    if (ffd_sess_caps(m)->sensitivity_product)
        return m->vt->sensitivity_product(m, b, v, out, err);
    ffd_linear_map map;
    ffd_status st = deformer_map(d, what, &map, err);
    return st ? st : products_from_map(&map, v, out, 0, what, err);
}

ffd_status ffd_deformer_sensitivity_transpose_product(ffd_deformer *d, const double *w,
                                                      double *out, ffd_error *err)
{
    const char *what = "sensitivity transpose product";
    if (!d || (!w && ffd_deformer_point_count(d)) || (!out && ffd_deformer_control_count(d)))
        return ffd_fail(err, FFD_ERR_INVALID,
                        "ffd_deformer_sensitivity_transpose_product: NULL argument");
    const sess_binding *b = NULL;
    sess_method *m = ffd_deformer_session_method(d, &b);
    if (ffd_sess_caps(m)->sensitivity_transpose_product)
        return m->vt->sensitivity_transpose_product(m, b, w, out, err);
    ffd_linear_map map;
    ffd_status st = deformer_map(d, what, &map, err);
    return st ? st : products_from_map(&map, w, out, 1, what, err);
}
