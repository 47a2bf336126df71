/* idw_session — the IDW method's deformer (sess_vtable: the editor and
 * ffd_deformer): the scattered-control-point deformer (session_points.c)
 * over the normalised weights, with the IDW's options in its state and rig. */
#include "idw/idw.h"
#include "idw/idw_method.h"
#include "session/session_points.h"

extern const ffd_point_morph_ops ffd_idw_point_ops; /* idw_rig.c */

static const void *options_of(const ffd_rig *rig)
{
    return &ffd_rig_idw_of(rig)->options;
}

static int describe(const void *options, cJSON *params, cJSON *controls)
{
    const ffd_idw_options *o = options;
    (void)controls;
    return ffd_sess_add_item(params, "power", ffd_sess_number(o->power)) &&
           cJSON_AddStringToObject(params, "weighting", ffd_rig_idw_weighting_name(o->weighting));
}

static int write_rig(const void *options, const ffd_rig_points *points, cJSON *root)
{
    ffd_rig_idw section = {.options = *(const ffd_idw_options *)options, .points = *points};
    ffd_rig rig;
    ffd_rig_view(&rig, &ffd_method_idw, NULL, 0);
    rig.section = &section;
    return ffd_method_idw.write(&rig, root);
}

static const sess_vtable idw_vtable = {FFD_SESS_POINTS_VTABLE("idw")};

static const sess_points_kind idw_kind = {
    .ops = &ffd_idw_point_ops,
    .vtable = &idw_vtable,
    .options_size = sizeof(ffd_idw_options),
    .options_of = options_of,
    .describe = describe,
    .write_rig = write_rig,
};

ffd_status ffd_sess_idw_load(const sess_ctx *ctx, const ffd_rig *rig, sess_method **out,
                             ffd_error *err)
{
    return ffd_sess_points_load(&idw_kind, ctx, rig, out, err);
}

/* The editor's defaults (ffd_method.create_body): without "control_points",
 * the 27 points of a 3 x 3 x 3 grid over the mesh's bounding box grown by a
 * tenth of its diagonal. */
ffd_status ffd_sess_idw_create_body(const sess_ctx *ctx, cJSON *body, const ffd_rig_parser *p)
{
    return ffd_sess_points_default_body(ctx, body, p);
}
