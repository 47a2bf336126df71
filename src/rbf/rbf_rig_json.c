/* rbf_rig_json — "deformer": "rbf" rigs (docs/rbf-idw.md): PyGeM's RBF
 * (pygem/rbf.py) as a rig: the control points, the kernel, its radius and
 * power, where the control points went ("deformed_control_points" and/or
 * "moves"), and the constraints of direct manipulation shared by the linear
 * methods. The method's section reader and writer (ffd_method_rbf). */
#include "rbf/rbf_method.h"
#include "rig/rig_json.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

const char *const ffd_rig_keys_rbf[] = {"control_points", "deformed_control_points", "moves",
                                        "kernel", "radius", "power", "solver", NULL};

static const char *const kernel_list =
    "\"gaussian_spline\", \"multi_quadratic_biharmonic_spline\", "
    "\"inv_multi_quadratic_biharmonic_spline\", \"thin_plate_spline\", "
    "\"beckert_wendland_c2_basis\" or \"polyharmonic_spline\"";

ffd_status ffd_rig_parse_rbf(const ffd_rig_parser *p, const cJSON *root, ffd_rig *rig)
{
    static const char *const kernels[] = {
        "gaussian_spline",   "multi_quadratic_biharmonic_spline", "inv_multi_quadratic_biharmonic_spline",
        "thin_plate_spline", "beckert_wendland_c2_basis",         "polyharmonic_spline", NULL};
    ffd_rig_rbf *r = ffd_rig_rbf_of(rig);
    const cJSON *item;
    ffd_status s = ffd_rig_read_linear_root(p, root, rig);
    if (s)
        return s;
    if ((s = ffd_rig_read_control_points(p, root, &r->points)))
        return s;
    if ((item = cJSON_GetObjectItemCaseSensitive(root, "kernel"))) {
        int k = 0;
        if ((s = ffd_rig_read_enum(p, item, "kernel", kernels, kernel_list, &k)))
            return s;
        r->options.kernel = (ffd_rbf_kernel)k;
    }
    r->options.radius = 0.5;
    if ((item = cJSON_GetObjectItemCaseSensitive(root, "radius")) &&
        (s = ffd_rig_read_positive(p, item, "radius", &r->options.radius)))
        return s;
    r->options.power = 2;
    if ((item = cJSON_GetObjectItemCaseSensitive(root, "power"))) {
        uint32_t k = 0;
        if ((s = ffd_rig_read_index(p, item, "power", "an integer >= 1", &k)))
            return s;
        if (k < 1 || k > 64)
            return ffd_rig_expected(p, "power", "an integer from 1 to 64");
        r->options.power = k;
    }
    if ((item = cJSON_GetObjectItemCaseSensitive(root, "solver"))) {
        static const char *const solvers[] = {"auto", "dense", "sparse", NULL};
        int sv = 0;
        if ((s = ffd_rig_read_enum(p, item, "solver", solvers, "\"auto\", \"dense\" or \"sparse\"", &sv)))
            return s;
        r->options.solver = (ffd_rbf_solver)sv;
        if (r->options.solver == FFD_RBF_SOLVER_SPARSE && r->options.kernel != FFD_RBF_WENDLAND_C2)
            return ffd_fail(p->err, FFD_ERR_INVALID,
                            "%s: solver: \"sparse\" needs \"kernel\": \"beckert_wendland_c2_basis\" "
                            "(the compactly supported kernel)",
                            p->name);
    }
    return FFD_OK;
}

int ffd_rig_write_rbf(const ffd_rig *rig, cJSON *root)
{
    const ffd_rig_rbf *r = ffd_rig_rbf_of(rig);
    return ffd_rig_points_write_rest(&r->points, root) &&
           cJSON_AddStringToObject(root, "kernel", ffd_rbf_kernel_name(r->options.kernel)) &&
           ffd_sess_add_item(root, "radius", ffd_sess_number(r->options.radius)) &&
           cJSON_AddNumberToObject(root, "power", r->options.power) &&
           (r->options.solver == FFD_RBF_SOLVER_AUTO ||
            cJSON_AddStringToObject(root, "solver",
                                    r->options.solver == FFD_RBF_SOLVER_SPARSE ? "sparse" : "dense")) &&
           ffd_rig_points_write_moves(&r->points, root);
}

void ffd_rig_release_rbf(ffd_rig *rig)
{
    ffd_rig_rbf *r = ffd_rig_rbf_of(rig);
    if (!r) /* the section's allocation failed */
        return;
    ffd_rig_points_release(&r->points);
}
