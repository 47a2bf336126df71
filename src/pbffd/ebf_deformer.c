/* pbffd — the PB-FFD deformer (McDonnell & Qin): creation (the control set,
 * its master, §3.2.2, its hierarchy, §3.4, and the binding of the points,
 * §3.1), destruction and accessors. */
#include "pbffd/pbffd.h"

#include <math.h>
#include <string.h>

#define DEFAULT_SIGMA 3.0
#define DEFAULT_MASTER_RADIUS 2.0
#define DEFAULT_MASTER_WEIGHT 1.0
#define MAX_LEVELS 64u

ffd_status ffd_pb_space(const ffd_pbffd *pb, size_t level, int grid, ffd_ebf_space *s)
{
    const ffd_pb_level *L = &pb->levels[level];
    return ffd_ebf_space_init(s, L->cur, L->count, pb->has_master ? &pb->master : NULL,
                              pb->master_weight, pb->sigma, grid);
}

static void level_free(ffd_pb_level *L)
{
    ffd_free(L->cur);
    ffd_free(L->base);
    ffd_free(L->changed);
    ffd_ebf_rows_free(&L->rows);
    ffd_ebf_rows_free(&L->rows_base);
}

void ffd_pbffd_destroy(ffd_pbffd *pb)
{
    if (!pb)
        return;
    for (size_t l = 0; l < pb->level_count; l++) {
        level_free(&pb->levels[l]);
        if (pb->maps)
            ffd_pb_map_state_free(pb->maps[l]);
    }
    ffd_free(pb->levels);
    ffd_free(pb->maps);
    ffd_free(pb->x_base);
    ffd_free(pb->x_ref);
    ffd_ebf_rows_free(&pb->mesh);
    ffd_free(pb->version);
    ffd_free(pb->J_ref);
    for (size_t v = 0; v < pb->version_count; v++)
        ffd_free(pb->versions[v].ctl);
    ffd_free(pb->versions);
    ffd_free(pb);
}

static ffd_status check_options(const ffd_pbffd_options *o, ffd_error *err)
{
    if (!o)
        return FFD_OK;
    if (isnan(o->sigma) || isnan(o->master_radius) || isnan(o->master_weight) || isinf(o->sigma) ||
        isinf(o->master_radius) || isinf(o->master_weight))
        return ffd_fail(err, FFD_ERR_NONFINITE,
                        "options: sigma, master_radius and master_weight "
                        "must be finite");
    /* below 0.05 the Gaussian underflows inside the ROI: points would lose every weight */
    if (o->sigma < 0 || (o->sigma > 0 && o->sigma < 0.05) || o->sigma > 1e6)
        return ffd_fail(err, FFD_ERR_INVALID, "options: sigma %g: expected a number in [0.05, 1e6]",
                        o->sigma);
    if (o->master_radius != 0 && o->master_radius < 1)
        return ffd_fail(err, FFD_ERR_INVALID, "options: master_radius %g: expected >= 1",
                        o->master_radius);
    if (o->master_weight < 0)
        return ffd_fail(err, FFD_ERR_INVALID, "options: master_weight %g: expected > 0",
                        o->master_weight);
    return FFD_OK;
}

/* The master (§3.2.2): centred in the bounding box of the points and the
 * enabled controls' centres, a sphere master_radius times the bounding-sphere
 * radius R: the largest distance from that centre to any point or enabled
 * control centre. A disabled control takes no part (it would move the master
 * and change every weight). When everything lies at one point, R is the
 * largest radius of an enabled control, or 1 without one (nothing can move
 * then: any R > 0 gives the same result). */
static void make_master(ffd_pbffd *pb, const ffd_ebf *controls, size_t count, const double *points,
                        size_t n, double factor)
{
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t i = 0; i < n + count; i++) {
        if (i >= n && controls[i - n].disabled)
            continue;
        const double *x = i < n ? points + 3 * i : controls[i - n].center;
        for (int c = 0; c < 3; c++) {
            lo[c] = fmin(lo[c], x[c]);
            hi[c] = fmax(hi[c], x[c]);
        }
    }
    double center[3] = {0, 0, 0}, r2 = 0, rmax = 0;
    if (lo[0] <= hi[0]) /* else no point and no enabled control: the origin */
        for (int c = 0; c < 3; c++)
            center[c] = 0.5 * (lo[c] + hi[c]);
    for (size_t i = 0; i < n + count; i++) {
        if (i >= n && controls[i - n].disabled)
            continue;
        const double *x = i < n ? points + 3 * i : controls[i - n].center;
        double d2 = 0;
        for (int c = 0; c < 3; c++)
            d2 += (x[c] - center[c]) * (x[c] - center[c]);
        r2 = fmax(r2, d2);
    }
    for (size_t j = 0; j < count; j++)
        if (!controls[j].disabled)
            for (int c = 0; c < 3; c++)
                rmax = fmax(rmax, controls[j].radius[c]);
    double R = sqrt(r2);
    if (!(R > 0))
        R = rmax > 0 ? rmax : 1.0; /* everything at one point */
    R *= factor;
    memset(&pb->master, 0, sizeof pb->master);
    memcpy(pb->master.center, center, sizeof center);
    for (int a = 0; a < 3; a++) {
        pb->master.frame[a][a] = R;
        pb->master.radius[a] = R;
    }
}

ffd_status ffd_pbffd_create(const ffd_ebf *controls, size_t count, const double *points, size_t n,
                            const ffd_pbffd_options *options, ffd_pbffd **out, ffd_error *err)
{
    if (!out)
        return ffd_fail(err, FFD_ERR_INVALID, "out is NULL");
    *out = NULL;
    if (count == 0)
        return ffd_fail(err, FFD_ERR_INVALID, "count 0: expected at least one control point");
    if (!controls)
        return ffd_fail(err, FFD_ERR_INVALID, "controls is NULL");
    if (n > 0 && !points)
        return ffd_fail(err, FFD_ERR_INVALID, "points is NULL (n = %zu)", n);
    if (count >= UINT32_MAX || n >= UINT32_MAX)
        return ffd_fail(err, FFD_ERR_INVALID, "too many controls or points");
    ffd_status st = check_options(options, err);
    if (st != FFD_OK)
        return st;
    for (size_t j = 0; j < count; j++)
        if ((st = ffd_ebf_check(&controls[j], "controls", j, err)) != FFD_OK)
            return st;
    for (size_t i = 0; i < n; i++)
        for (int c = 0; c < 3; c++)
            if (!isfinite(points[3 * i + c]))
                return ffd_fail(err, FFD_ERR_NONFINITE, "points[%zu]: not finite", i);
    uint32_t levels = options && options->levels ? options->levels : 1;
    {
        size_t m = 0;
        for (size_t j = 0; j < count; j++)
            m += !controls[j].disabled;
        if (levels > MAX_LEVELS)
            return ffd_fail(err, FFD_ERR_INVALID, "levels %u: expected at most %u", levels,
                            MAX_LEVELS);
        /* each level halves the enabled controls of the one below (§3.4) */
        for (uint32_t l = 1; l < levels; l++) {
            if (m < 2)
                return ffd_fail(err, FFD_ERR_INVALID,
                                "levels %u: level %u would have fewer than one control "
                                "(level %u has %zu enabled)",
                                levels, l, l - 1, m);
            m = (m + 1) / 2;
        }
    }

    ffd_pbffd *pb = ffd_calloc(1, sizeof *pb);
    if (!pb)
        return ffd_fail(err, FFD_ERR_NOMEM, "out of memory creating the deformer");
    pb->sigma = options && options->sigma > 0 ? options->sigma : DEFAULT_SIGMA;
    pb->master_weight =
        options && options->master_weight > 0 ? options->master_weight : DEFAULT_MASTER_WEIGHT;
    pb->has_master = !(options && options->no_master);
    double factor =
        options && options->master_radius > 0 ? options->master_radius : DEFAULT_MASTER_RADIUS;
    make_master(pb, controls, count, points, n, factor);
    pb->n = n;
    pb->levels = ffd_calloc(levels, sizeof *pb->levels);
    pb->maps = ffd_calloc(levels, sizeof *pb->maps);
    pb->x_base = ffd_malloc_array(n ? n : 1, 3 * sizeof(double));
    pb->x_ref = ffd_malloc_array(n ? n : 1, 3 * sizeof(double));
    pb->versions = ffd_calloc(1, sizeof *pb->versions);
    if (!pb->levels || !pb->maps || !pb->x_base || !pb->x_ref || !pb->versions)
        goto nomem;
    pb->level_count = 1;
    pb->version_count = 1;
    ffd_pb_level *L0 = &pb->levels[0];
    L0->count = count;
    L0->cur = ffd_malloc_array(count, sizeof *L0->cur);
    L0->base = ffd_malloc_array(count, sizeof *L0->base);
    L0->changed = ffd_calloc(count, 1);
    pb->versions[0].ctl = ffd_malloc_array(count, sizeof(ffd_ebf));
    if (!L0->cur || !L0->base || !L0->changed || !pb->versions[0].ctl)
        goto nomem;
    for (size_t j = 0; j < count; j++) {
        L0->cur[j] = controls[j];
        L0->cur[j].disabled = controls[j].disabled ? 1 : 0;
    }
    memcpy(L0->base, L0->cur, count * sizeof *L0->cur);
    memcpy(pb->versions[0].ctl, L0->cur, count * sizeof *L0->cur);
    pb->versions[0].count = count;
    pb->versions[0].refs = n;
    if (n) {
        memcpy(pb->x_base, points, 3 * n * sizeof(double));
        memcpy(pb->x_ref, points, 3 * n * sizeof(double));
    }
    if ((st = ffd_pb_build_hierarchy(pb, levels, err)) != FFD_OK) {
        ffd_pbffd_destroy(pb);
        return st;
    }
    /* the bound points over level 0: W and D of eq. 7 */
    ffd_ebf_space s;
    if (ffd_pb_space(pb, 0, 1, &s) != FFD_OK)
        goto nomem;
    st = ffd_ebf_rows_bind(&s, points, n, 0, 0, &pb->mesh);
    ffd_ebf_space_free(&s);
    if (st != FFD_OK)
        goto nomem;
    *out = pb;
    return FFD_OK;
nomem:
    ffd_pbffd_destroy(pb);
    return ffd_fail(err, FFD_ERR_NOMEM, "out of memory creating the deformer");
}

size_t ffd_pbffd_point_count(const ffd_pbffd *pb) { return pb->n; }
size_t ffd_pbffd_level_count(const ffd_pbffd *pb) { return pb->level_count; }

size_t ffd_pbffd_control_count(const ffd_pbffd *pb, size_t level)
{
    return level < pb->level_count ? pb->levels[level].count : 0;
}

ffd_status ffd_pbffd_control(const ffd_pbffd *pb, size_t level, size_t index, ffd_ebf *out,
                             ffd_error *err)
{
    ffd_status s = ffd_pb_check_index(pb, level, index, err);
    if (s)
        return s;
    *out = pb->levels[level].cur[index];
    return FFD_OK;
}

int ffd_pbffd_master(const ffd_pbffd *pb, size_t level, ffd_ebf *out)
{
    if (!pb->has_master || level >= pb->level_count)
        return 0;
    if (out)
        *out = pb->master;
    return 1;
}

size_t ffd_pbffd_point_support(const ffd_pbffd *pb, size_t i)
{
    return i < pb->n ? pb->mesh.start[i + 1] - pb->mesh.start[i] : 0;
}

size_t ffd_pbffd_uncovered_count(const ffd_pbffd *pb)
{
    size_t k = 0;
    for (size_t i = 0; i < pb->n; i++)
        k += pb->mesh.start[i + 1] == pb->mesh.start[i];
    return k;
}

size_t ffd_pbffd_single_covered_count(const ffd_pbffd *pb)
{
    size_t k = 0;
    for (size_t i = 0; i < pb->n; i++)
        k += pb->mesh.start[i + 1] - pb->mesh.start[i] < 2;
    return k;
}
