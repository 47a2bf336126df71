/* idw_rig — applying an IDW rig to a mesh (ffd_method_idw.apply): the IDW's
 * operations for the scattered-control-point rig application (rig_points.c):
 * the IDW on the rig's control points (idw_weights.c), moved, then direct
 * manipulation over the normalised weights. */
#include "idw/idw.h"
#include "idw/idw_method.h"

#include <cjson/cJSON.h>

/* Bytes and operations: N weights per point. */
static ffd_status charge(const ffd_rig *rig, size_t n, ffd_budget *budget, ffd_error *err)
{
    const double N = (double)ffd_rig_idw_of(rig)->points.count;
    char ns[32], cs[32];
    return ffd_budget_charge(budget, 24.0 * N + 100.0 * (double)n, 60.0 * N * (double)n,
                             err, "idw: %s vertices under %s control points",
                             ffd_format_count((double)n, ns, sizeof ns),
                             ffd_format_count(N, cs, sizeof cs));
}

static void details(const ffd_rig *rig, const void *morph, cJSON *d)
{
    const ffd_idw_options *o = &ffd_rig_idw_of(rig)->options;
    (void)morph;
    cJSON_AddNumberToObject(d, "power", o->power);
    cJSON_AddStringToObject(d, "weighting", ffd_rig_idw_weighting_name(o->weighting));
}

static const ffd_rig_points *points_of(const ffd_rig *rig)
{
    return &ffd_rig_idw_of(rig)->points;
}

static ffd_status create(const ffd_rig *rig, void **morph, ffd_error *err)
{
    const ffd_rig_idw *r = ffd_rig_idw_of(rig);
    ffd_idw *idw = NULL;
    ffd_status s = ffd_idw_create(r->points.control_points, r->points.count, &r->options, &idw, err);
    *morph = idw;
    return s;
}

/* The IDW behind the ops' void pointers. */
static void destroy(void *m) { ffd_idw_destroy(m); }
static size_t count(const void *m) { return ffd_idw_control_count(m); }
static const double *points(const void *m) { return ffd_idw_control_points(m); }
static const double *rest(const void *m) { return ffd_idw_rest_points(m); }
static ffd_status set_points(void *m, const double *p, ffd_error *err)
{
    return ffd_idw_set_control_points(m, p, err);
}
static ffd_status eval(const void *m, const double *x, size_t n, double *out, ffd_error *err)
{
    return ffd_idw_eval(m, x, n, out, err);
}
static ffd_status jacobian(const void *m, const double *x, size_t n, double *out, ffd_error *err)
{
    return ffd_idw_jacobian(m, x, n, out, err);
}

const ffd_point_morph_ops ffd_idw_point_ops = {
    .label = "IDW",
    .control_label = "IDW control points",
    .points_of = points_of,
    .create = create,
    .destroy = destroy,
    .count = count,
    .points = points,
    .rest = rest,
    .set_points = set_points,
    .eval = eval,
    .jacobian = jacobian,
    .linear_map = ffd_idw_linear_map,
    .charge = charge,
    .details = details,
};

ffd_status ffd_rig_apply_idw(const ffd_rig *rig, ffd_mesh *mesh, ffd_rig_report *report,
                             ffd_budget *budget, ffd_error *err)
{
    return ffd_rig_apply_points(&ffd_idw_point_ops, rig, mesh, report, budget, err);
}
