/* rbf_prm — PyGeM's RBF parameter files (pygem/rbf.py, read_parameters and
 * write_parameters): [Radial Basis Functions] with "basis function",
 * "radius" and the kernel's extra parameter "k" (the power), and [Control
 * points] with "original control points" and "deformed control points",
 * one point "x y z" a line. Syntax: rig/rig_prm.c. */
#include "rbf/rbf_method.h"
#include "rig/rig_prm.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#define SEC_RBF "Radial Basis Functions"
#define SEC_POINTS "Control points"

static ffd_status read_rbf(const ffd_prm *prm, ffd_rig_rbf *r, ffd_error *err)
{
    const ffd_prm_entry *e;
    ffd_status s = ffd_prm_required(prm, SEC_RBF, "basis function", &e, err);
    if (s)
        return s;
    int kernel = -1;
    for (int k = 0; k < FFD_RBF_KERNEL_COUNT; k++) {
        const char *n = ffd_rbf_kernel_name((ffd_rbf_kernel)k);
        if (e->count == 1 && prm->lines[e->first].size == strlen(n) &&
            !memcmp(prm->lines[e->first].text, n, strlen(n)))
            kernel = k;
    }
    if (kernel < 0)
        return ffd_fail(err, FFD_ERR_INVALID,
                        "%s:%zu: basis function: unknown kernel '%.*s' (expected gaussian_spline, "
                        "multi_quadratic_biharmonic_spline, inv_multi_quadratic_biharmonic_spline, "
                        "thin_plate_spline, beckert_wendland_c2_basis or polyharmonic_spline)",
                        prm->name, e->line, e->count ? (int)prm->lines[e->first].size : 0,
                        e->count ? prm->lines[e->first].text : "");
    r->options.kernel = (ffd_rbf_kernel)kernel;
    if ((s = ffd_prm_required(prm, SEC_RBF, "radius", &e, err)) ||
        (s = ffd_prm_number(prm, e, &r->options.radius, err)))
        return s;
    if (!(r->options.radius > 0))
        return ffd_fail(err, FFD_ERR_INVALID, "%s:%zu: radius: %g: expected a number > 0",
                        prm->name, e->line, r->options.radius);
    r->options.power = 2;
    for (size_t i = 0; i < prm->entry_count; i++) { /* PyGeM eval()s the rest as kernel arguments */
        e = &prm->entries[i];
        if (e->section_size != strlen(SEC_RBF) || memcmp(e->section, SEC_RBF, e->section_size))
            continue;
        char key[64];
        snprintf(key, sizeof key, "%.*s", (int)e->key_size, e->key);
        if (!strcmp(key, "basis function") || !strcmp(key, "radius"))
            continue;
        double k;
        if (strcmp(key, "k") != 0)
            return ffd_fail(err, FFD_ERR_UNSUPPORTED,
                            "%s:%zu: '%s': not a kernel parameter (the kernels take 'k', the "
                            "power of thin_plate_spline and polyharmonic_spline)",
                            prm->name, e->line, key);
        if ((s = ffd_prm_number(prm, e, &k, err)))
            return s;
        if (k != floor(k) || k < 1 || k > 64)
            return ffd_fail(err, FFD_ERR_INVALID, "%s:%zu: k: %g: expected an integer from 1 to 64",
                            prm->name, e->line, k);
        r->options.power = (unsigned)k;
    }
    return ffd_prm_control_points(prm, &r->points.control_points, &r->points.count,
                                  &r->points.deformed, err);
}

ffd_status ffd_rig_parse_prm_rbf(const char *text, size_t size, const char *name, ffd_rig **out,
                                 ffd_error *err)
{
    ffd_prm prm;
    *out = NULL;
    ffd_status s = ffd_prm_read(text, size, name, &prm, err);
    if (s)
        return s;
    ffd_rig *rig = ffd_rig_new(name);
    if (rig) {
        rig->method = &ffd_method_rbf;
        rig->section = ffd_calloc(1, sizeof(ffd_rig_rbf));
    }
    if (!rig || !rig->section)
        s = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", name);
    else
        s = read_rbf(&prm, ffd_rig_rbf_of(rig), err);
    ffd_prm_free(&prm);
    if (s) {
        ffd_rig_destroy(rig);
        return s;
    }
    *out = rig;
    return FFD_OK;
}

ffd_status ffd_rig_write_prm_rbf(const ffd_rig *rig, char **text, ffd_error *err)
{
    const ffd_rig_rbf *r = ffd_rig_rbf_of(rig);
    double *moved = ffd_rig_points_moved(&r->points);
    char *t = NULL;
    size_t size = 0, cap = 0;
    int ok = moved &&
             ffd_prm_append(&t, &size, &cap,
                            "\n[" SEC_RBF "]\n"
                            "# This section describes the radial basis functions shape.\n\n"
                            "# basis function is the name of the basis functions to use in the "
                            "transformation.\n"
                            "basis function: %s\n\n"
                            "# radius is the scaling parameter r that affects the shape of the "
                            "basis functions.\n"
                            "radius: %.17g\n",
                            ffd_rbf_kernel_name(r->options.kernel), r->options.radius) &&
             ((r->options.kernel != FFD_RBF_THIN_PLATE && r->options.kernel != FFD_RBF_POLYHARMONIC) ||
              ffd_prm_append(&t, &size, &cap, "\n# k is the power of the kernel.\nk: %u\n",
                             r->options.power)) &&
             ffd_prm_append(&t, &size, &cap,
                            "\n\n[" SEC_POINTS "]\n"
                            "# This section describes the RBF control points.\n\n"
                            "# original control points collects the coordinates of the "
                            "interpolation control points before the deformation.\n") &&
             ffd_prm_append_points(&t, &size, &cap, "original control points", r->points.control_points,
                                   r->points.count) &&
             ffd_prm_append(&t, &size, &cap,
                            "\n# deformed control points collects the coordinates of the "
                            "interpolation control points after the deformation.\n") &&
             ffd_prm_append_points(&t, &size, &cap, "deformed control points", moved, r->points.count);
    ffd_free(moved);
    if (!ok) {
        ffd_free(t);
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory writing the .prm", rig->name);
    }
    *text = t;
    return FFD_OK;
}
