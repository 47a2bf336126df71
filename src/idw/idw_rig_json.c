/* idw_rig_json — "deformer": "idw" rigs (docs/idw-idw.md): PyGeM's IDW
 * (pygem/idw.py) as a rig: the control points, the power and weighting
 * of the distances, where the control points went ("deformed_control_points" and/or
 * "moves"), and the constraints of direct manipulation shared by the linear
 * methods. The method's section reader and writer (ffd_method_idw). */
#include "idw/idw_method.h"
#include "rig/rig_json.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

const char *const ffd_rig_keys_idw[] = {"control_points", "deformed_control_points", "moves",
                                        "power", "weighting", NULL};

const char *ffd_rig_idw_weighting_name(ffd_idw_weighting w)
{
    return w == FFD_IDW_SHEPARD ? "shepard" : "pygem";
}

ffd_status ffd_rig_parse_idw(const ffd_rig_parser *p, const cJSON *root, ffd_rig *rig)
{
    static const char *const weightings[] = {"pygem", "shepard", NULL};
    ffd_rig_idw *r = ffd_rig_idw_of(rig);
    const cJSON *item;
    ffd_status s = ffd_rig_read_linear_root(p, root, rig);
    if (s)
        return s;
    if ((s = ffd_rig_read_control_points(p, root, &r->points)))
        return s;
    if ((item = cJSON_GetObjectItemCaseSensitive(root, "weighting"))) {
        int w = 0;
        if ((s = ffd_rig_read_enum(p, item, "weighting", weightings, "\"pygem\" or \"shepard\"", &w)))
            return s;
        r->options.weighting = w ? FFD_IDW_SHEPARD : FFD_IDW_PYGEM;
    }
    r->options.power = 2;
    if ((item = cJSON_GetObjectItemCaseSensitive(root, "power")) &&
        (s = ffd_rig_read_positive(p, item, "power", &r->options.power)))
        return s;
    return FFD_OK;
}

int ffd_rig_write_idw(const ffd_rig *rig, cJSON *root)
{
    const ffd_rig_idw *r = ffd_rig_idw_of(rig);
    return ffd_rig_points_write_rest(&r->points, root) &&
           ffd_sess_add_item(root, "power", ffd_sess_number(r->options.power)) &&
           cJSON_AddStringToObject(root, "weighting", ffd_rig_idw_weighting_name(r->options.weighting)) &&
           ffd_rig_points_write_moves(&r->points, root);
}

void ffd_rig_release_idw(ffd_rig *rig)
{
    ffd_rig_idw *r = ffd_rig_idw_of(rig);
    if (!r) /* the section's allocation failed */
        return;
    ffd_rig_points_release(&r->points);
}
