/* pbffd — the bound points as a linear map of the control points of one level,
 * for direct manipulation (PB-FFD §3.3, eq. 8: the rows of W without the
 * master, which never moves). A coarser level composes the rows of eq. 10:
 * moving control j of level k by delta moves level k-1 point i by
 * W^{k-1}_ij delta (the moved point itself is re-parameterised in level k+1,
 * which moves nothing finer), and so on down to the bound points, so the map
 * is the product W_mesh W^0 ... W^{k-1}. Rows of a coarse map are composed on
 * request in a dense scratch owned by the map: a map is not thread-safe. */
#include "pbffd/pbffd.h"

#include <string.h>

struct ffd_pb_map_state {
    const ffd_pbffd *pb;
    size_t level;
    const ffd_ebf_rows *rows; /* the bound points' rows over level 0 */
    uint32_t *tie; /* level 0: disabled controls fixed */
    double *acc;   /* dense scratch over the widest level */
    unsigned char *seen;
    uint32_t *list[2];
    double *val[2];
};

void ffd_pb_map_state_free(ffd_pb_map_state *m)
{
    if (!m)
        return;
    ffd_free(m->tie);
    ffd_free(m->acc);
    ffd_free(m->seen);
    ffd_free(m->list[0]);
    ffd_free(m->list[1]);
    ffd_free(m->val[0]);
    ffd_free(m->val[1]);
    ffd_free(m);
}

static size_t map_row(const void *self, size_t i, uint32_t *cols, double *w)
{
    const ffd_pb_map_state *m = self; /* the scratch it points to is the map's own */
    const ffd_pbffd *pb = m->pb;
    const ffd_ebf_rows *R = m->rows;
    size_t nnz = 0;
    if (m->level == 0) {
        for (size_t k = R->start[i]; k < R->start[i + 1]; k++) {
            cols[nnz] = R->col[k];
            w[nnz] = R->w[k];
            nnz++;
        }
        return nnz;
    }
    /* x' = W_mesh P^0 and P^l = W^l P^{l+1} + (terms that do not move) (eq. 9-10):
     * push the row up one level at a time */
    uint32_t *cur = m->list[0], *next = m->list[1];
    double *cv = m->val[0], *nv = m->val[1];
    for (size_t k = R->start[i]; k < R->start[i + 1]; k++) {
        cur[nnz] = R->col[k];
        cv[nnz] = R->w[k];
        nnz++;
    }
    for (size_t l = 0; l < m->level; l++) {
        const ffd_ebf_rows *W = &pb->levels[l].rows;
        size_t nn = 0;
        for (size_t e = 0; e < nnz; e++) {
            const uint32_t p = cur[e];
            const double a = cv[e];
            for (size_t k = W->start[p]; k < W->start[p + 1]; k++) {
                uint32_t q = W->col[k];
                if (!m->seen[q]) {
                    m->seen[q] = 1;
                    m->acc[q] = 0.0;
                    next[nn++] = q;
                }
                m->acc[q] += a * W->w[k];
            }
        }
        for (size_t e = 0; e < nn; e++) {
            nv[e] = m->acc[next[e]];
            m->seen[next[e]] = 0;
        }
        nnz = nn;
        uint32_t *t = cur;
        cur = next;
        next = t;
        double *tv = cv;
        cv = nv;
        nv = tv;
    }
    memcpy(cols, cur, nnz * sizeof *cols);
    memcpy(w, cv, nnz * sizeof *w);
    return nnz;
}

/* The map's state over rows; tie: level 0's disabled controls FFD_TIE_FIXED. */
static ffd_status map_state(const ffd_pbffd *pb, size_t level, const ffd_ebf_rows *rows, int tie,
                            ffd_pb_map_state **out, ffd_error *err)
{
    if (level >= pb->level_count)
        return ffd_fail(err, FFD_ERR_RANGE, "level %zu out of range (%zu levels)", level,
                        pb->level_count);
    size_t widest = 1;
    for (size_t l = 0; l < pb->level_count; l++)
        if (pb->levels[l].count > widest)
            widest = pb->levels[l].count;
    ffd_pb_map_state *m = ffd_calloc(1, sizeof *m);
    if (!m)
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory building the linear map");
    m->pb = pb;
    m->level = level;
    m->rows = rows;
    const ffd_pb_level *L = &pb->levels[level];
    if (level == 0 && tie) {
        m->tie = ffd_malloc_array(L->count, sizeof *m->tie);
        if (m->tie)
            for (size_t j = 0; j < L->count; j++)
                m->tie[j] = L->cur[j].disabled ? FFD_TIE_FIXED : (uint32_t)j;
    }
    m->acc = ffd_malloc_array(widest, sizeof *m->acc);
    m->seen = ffd_calloc(widest, 1);
    m->list[0] = ffd_malloc_array(widest, sizeof *m->list[0]);
    m->list[1] = ffd_malloc_array(widest, sizeof *m->list[1]);
    m->val[0] = ffd_malloc_array(widest, sizeof *m->val[0]);
    m->val[1] = ffd_malloc_array(widest, sizeof *m->val[1]);
    if ((level == 0 && tie && !m->tie) || !m->acc || !m->seen || !m->list[0] || !m->list[1] ||
        !m->val[0] || !m->val[1]) {
        ffd_pb_map_state_free(m);
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory building the linear map");
    }
    *out = m;
    return FFD_OK;
}

static void map_init(const ffd_pb_map_state *m, ffd_linear_map *map)
{
    const size_t count = m->pb->levels[m->level].count;
    memset(map, 0, sizeof *map);
    map->self = m;
    map->point_count = m->rows->n;
    map->column_count = count;
    map->variable_count = count;
    map->tie = m->tie;
    /* a level-0 row has at most rows.max_nnz entries; a composed one at most the level's count */
    size_t mx = m->level == 0 ? m->rows->max_nnz : count;
    map->max_row_nnz = mx ? mx : 1;
    map->row = map_row;
}

ffd_status ffd_pbffd_linear_map(ffd_pbffd *pb, size_t level, ffd_linear_map *map, ffd_error *err)
{
    ffd_pb_map_state *m = NULL;
    ffd_status st = map_state(pb, level, &pb->mesh, 1, &m, err);
    if (st)
        return st;
    ffd_pb_map_state_free(pb->maps[level]);
    pb->maps[level] = m;
    map_init(m, map);
    return FFD_OK;
}

ffd_status ffd_pb_rows_linear_map(const ffd_pbffd *pb, size_t level, const ffd_ebf_rows *rows,
                                  ffd_linear_map *map, ffd_pb_map_state **state, ffd_error *err)
{
    ffd_status st = map_state(pb, level, rows, 0, state, err);
    if (!st)
        map_init(*state, map);
    return st;
}
