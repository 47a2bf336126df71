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
    if ((s = ffd_rig_read_control_points(p, root, &r->control_points, &r->count, &r->deformed,
                                         &r->moves, &r->move_count)))
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

double *ffd_rig_idw_moved(const ffd_rig_idw *r)
{
    double *p = ffd_malloc_array(r->count, 3 * sizeof *p);
    if (!p)
        return NULL;
    memcpy(p, r->deformed ? r->deformed : r->control_points, r->count * 3 * sizeof *p);
    for (size_t i = 0; i < r->move_count; i++)
        for (int a = 0; a < 3; a++)
            p[3 * r->moves[i].index + a] += r->moves[i].delta[a];
    return p;
}

static cJSON *points_json(const double *p, size_t n)
{
    cJSON *a = cJSON_CreateArray();
    for (size_t i = 0; a && i < n; i++)
        if (!ffd_sess_add_to_array(a, ffd_sess_vec3(p + 3 * i))) {
            cJSON_Delete(a);
            return NULL;
        }
    return a;
}

int ffd_rig_write_idw(const ffd_rig *rig, cJSON *root)
{
    const ffd_rig_idw *r = ffd_rig_idw_of(rig);
    cJSON *moves = NULL;
    int ok = ffd_sess_add_item(root, "control_points", points_json(r->control_points, r->count)) &&
             ffd_sess_add_item(root, "power", ffd_sess_number(r->options.power)) &&
             cJSON_AddStringToObject(root, "weighting", ffd_rig_idw_weighting_name(r->options.weighting)) &&
             (!r->deformed || ffd_sess_add_item(root, "deformed_control_points",
                                                points_json(r->deformed, r->count))) &&
             (moves = cJSON_AddArrayToObject(root, "moves"));
    for (size_t i = 0; ok && i < r->move_count; i++) {
        cJSON *move = cJSON_CreateObject();
        ok = ffd_sess_add_to_array(moves, move) &&
             cJSON_AddNumberToObject(move, "index", r->moves[i].index) &&
             ffd_sess_add_item(move, "delta", ffd_sess_vec3(r->moves[i].delta));
    }
    return ok;
}

void ffd_rig_release_idw(ffd_rig *rig)
{
    ffd_rig_idw *r = ffd_rig_idw_of(rig);
    if (!r) /* the section's allocation failed */
        return;
    ffd_free(r->control_points);
    ffd_free(r->deformed);
    ffd_free(r->moves);
}
