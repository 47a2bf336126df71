/* idw_prm — PyGeM's IDW parameter files (pygem/idw.py, read_parameters
 * and write_parameters): [Inverse Distance Weighting] with "power" (an
 * integer, configparser's getint) and [Control points] with "original
 * control points" and "deformed control points", one point "x y z" a line.
 * The file cannot say "weighting": it is PyGeM's. Syntax: rig/rig_prm.c. */
#include "idw/idw_method.h"
#include "rig/rig_prm.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#define SEC_IDW "Inverse Distance Weighting"
#define SEC_POINTS "Control points"

static ffd_status read_idw(const ffd_prm *prm, ffd_rig_idw *r, ffd_error *err)
{
    const ffd_prm_entry *e;
    ffd_status s = ffd_prm_required(prm, SEC_IDW, "power", &e, err);
    if (s || (s = ffd_prm_number(prm, e, &r->options.power, err)))
        return s;
    if (r->options.power != floor(r->options.power) || r->options.power < 1)
        return ffd_fail(err, FFD_ERR_INVALID, "%s:%zu: power: %g: expected an integer >= 1",
                        prm->name, e->line, r->options.power);
    r->options.weighting = FFD_IDW_PYGEM;
    return ffd_prm_control_points(prm, &r->points.control_points, &r->points.count,
                                  &r->points.deformed, err);
}

ffd_status ffd_rig_parse_prm_idw(const char *text, size_t size, const char *name, ffd_rig **out,
                                 ffd_error *err)
{
    ffd_prm prm;
    *out = NULL;
    ffd_status s = ffd_prm_read(text, size, name, &prm, err);
    if (s)
        return s;
    ffd_rig *rig = ffd_rig_new(name);
    if (rig) {
        rig->method = &ffd_method_idw;
        rig->section = ffd_calloc(1, sizeof(ffd_rig_idw));
    }
    if (!rig || !rig->section)
        s = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", name);
    else
        s = read_idw(&prm, ffd_rig_idw_of(rig), err);
    ffd_prm_free(&prm);
    if (s) {
        ffd_rig_destroy(rig);
        return s;
    }
    *out = rig;
    return FFD_OK;
}

ffd_status ffd_rig_write_prm_idw(const ffd_rig *rig, char **text, ffd_error *err)
{
    const ffd_rig_idw *r = ffd_rig_idw_of(rig);
    if (r->options.weighting != FFD_IDW_PYGEM || r->options.power != floor(r->options.power))
        return ffd_fail(err, FFD_ERR_UNSUPPORTED,
                        "%s: a PyGeM IDW file holds an integer power with PyGeM's weighting "
                        "(this rig has \"weighting\": \"%s\", \"power\": %g)",
                        rig->name, ffd_rig_idw_weighting_name(r->options.weighting), r->options.power);
    double *moved = ffd_rig_points_moved(&r->points);
    char *t = NULL;
    size_t size = 0, cap = 0;
    int ok = moved &&
             ffd_prm_append(&t, &size, &cap,
                            "\n[" SEC_IDW "]\n"
                            "# This section describes the settings of idw.\n\n"
                            "# the power parameter\n"
                            "power = %.0f\n\n\n[" SEC_POINTS "]\n"
                            "# This section describes the IDW control points.\n\n"
                            "# original control points collects the coordinates\n"
                            "# of the interpolation control points before the\n# deformation.\n",
                            r->options.power) &&
             ffd_prm_append_points(&t, &size, &cap, "original control points", r->points.control_points,
                                   r->points.count) &&
             ffd_prm_append(&t, &size, &cap,
                            "\n# deformed control points collects the coordinates\n"
                            "# of the interpolation control points after the\n# deformation.\n") &&
             ffd_prm_append_points(&t, &size, &cap, "deformed control points", moved, r->points.count);
    ffd_free(moved);
    if (!ok) {
        ffd_free(t);
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory writing the .prm", rig->name);
    }
    *text = t;
    return FFD_OK;
}
