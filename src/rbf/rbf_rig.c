/* rbf_rig — applying an RBF rig to a mesh (ffd_method_rbf.apply): the RBF's
 * operations for the scattered-control-point rig application (rig_points.c):
 * the RBF on the rig's control points (rbf_map.c), moved, then direct
 * manipulation over the cardinal functions. */
#include "rbf/rbf.h"
#include "rbf/rbf_method.h"

#include <cjson/cJSON.h>

/* Bytes and operations: the (N+4)^2 factor and its N^3/3 factorisation,
 * then N kernel terms per point. */
static ffd_status charge(const ffd_rig *rig, size_t n, ffd_budget *budget, ffd_error *err)
{
    const double N = (double)ffd_rig_rbf_of(rig)->points.count + 4;
    char ns[32], cs[32];
    return ffd_budget_charge(budget, 8.0 * N * N + 100.0 * (double)n, N * N * N / 3 + 30.0 * N * (double)n,
                             err, "rbf: %s vertices under %s control points",
                             ffd_format_count((double)n, ns, sizeof ns),
                             ffd_format_count(N - 4, cs, sizeof cs));
}

static void details(const ffd_rig *rig, const void *morph, cJSON *d)
{
    const ffd_rbf_options *o = &ffd_rig_rbf_of(rig)->options;
    cJSON_AddStringToObject(d, "kernel", ffd_rbf_kernel_name(o->kernel));
    cJSON_AddNumberToObject(d, "radius", o->radius);
    cJSON_AddNumberToObject(d, "power", o->power);
    cJSON_AddNumberToObject(d, "rcond", ((const ffd_rbf_morph *)morph)->rcond);
}

static const ffd_rig_points *points_of(const ffd_rig *rig)
{
    return &ffd_rig_rbf_of(rig)->points;
}

static ffd_status create(const ffd_rig *rig, void **morph, ffd_error *err)
{
    const ffd_rig_rbf *r = ffd_rig_rbf_of(rig);
    ffd_rbf_morph *rbf = NULL;
    ffd_status s = ffd_rbf_morph_create(r->points.control_points, r->points.count, &r->options, &rbf, err);
    *morph = rbf;
    return s;
}

/* The RBF behind the ops' void pointers. */
static void destroy(void *m) { ffd_rbf_morph_destroy(m); }
static size_t count(const void *m) { return ffd_rbf_morph_control_count(m); }
static const double *points(const void *m) { return ffd_rbf_morph_control_points(m); }
static const double *rest(const void *m) { return ffd_rbf_morph_rest_points(m); }
static ffd_status set_points(void *m, const double *p, ffd_error *err)
{
    return ffd_rbf_morph_set_control_points(m, p, err);
}
static ffd_status eval(const void *m, const double *x, size_t n, double *out, ffd_error *err)
{
    return ffd_rbf_morph_eval(m, x, n, out, err);
}
static ffd_status jacobian(const void *m, const double *x, size_t n, double *out, ffd_error *err)
{
    return ffd_rbf_morph_jacobian(m, x, n, out, err);
}
static ffd_status product(const void *m, const double *x, size_t n, const double *v, double *out,
                          ffd_error *err)
{
    return ffd_rbf_morph_product(m, x, n, v, out, err);
}
static ffd_status transpose_product(const void *m, const double *x, size_t n, const double *w,
                                    double *out, ffd_error *err)
{
    return ffd_rbf_morph_transpose_product(m, x, n, w, out, err);
}

const ffd_point_morph_ops ffd_rbf_point_ops = {
    .label = "RBF",
    .control_label = "RBF control points",
    .points_of = points_of,
    .create = create,
    .destroy = destroy,
    .count = count,
    .points = points,
    .rest = rest,
    .set_points = set_points,
    .eval = eval,
    .jacobian = jacobian,
    .linear_map = ffd_rbf_morph_linear_map,
    .product = product,
    .transpose_product = transpose_product,
    .charge = charge,
    .details = details,
};

ffd_status ffd_rig_apply_rbf(const ffd_rig *rig, ffd_mesh *mesh, ffd_rig_report *report,
                             ffd_budget *budget, ffd_error *err)
{
    return ffd_rig_apply_points(&ffd_rbf_point_ops, rig, mesh, report, budget, err);
}
