/* rbf_session — the RBF method's deformer (sess_vtable: the editor and
 * ffd_deformer): the scattered-control-point deformer (session_points.c)
 * over the cardinal functions, with the RBF's options in its state and rig. */
#include "rbf/rbf.h"
#include "rbf/rbf_method.h"
#include "session/session_points.h"

extern const ffd_point_morph_ops ffd_rbf_point_ops; /* rbf_rig.c */

static const void *options_of(const ffd_rig *rig)
{
    return &ffd_rig_rbf_of(rig)->options;
}

static int describe(const void *options, cJSON *params, cJSON *controls)
{
    const ffd_rbf_options *o = options;
    const char *kernel = ffd_rbf_kernel_name(o->kernel);
    return cJSON_AddStringToObject(params, "kernel", kernel) &&
           ffd_sess_add_item(params, "radius", ffd_sess_number(o->radius)) &&
           cJSON_AddNumberToObject(params, "power", o->power) &&
           cJSON_AddStringToObject(controls, "kernel", kernel);
}

static int write_rig(const void *options, const ffd_rig_points *points, cJSON *root)
{
    ffd_rig_rbf section = {.options = *(const ffd_rbf_options *)options, .points = *points};
    ffd_rig rig;
    ffd_rig_view(&rig, &ffd_method_rbf, NULL, 0);
    rig.section = &section;
    return ffd_method_rbf.write(&rig, root);
}

static const sess_vtable rbf_vtable = {
    FFD_SESS_POINTS_VTABLE("rbf"),
    .sensitivity_product = ffd_sess_points_sensitivity_product,
    .sensitivity_transpose_product = ffd_sess_points_sensitivity_transpose,
};

static const sess_points_kind rbf_kind = {
    .ops = &ffd_rbf_point_ops,
    .vtable = &rbf_vtable,
    .options_size = sizeof(ffd_rbf_options),
    .options_of = options_of,
    .describe = describe,
    .write_rig = write_rig,
};

ffd_status ffd_sess_rbf_load(const sess_ctx *ctx, const ffd_rig *rig, sess_method **out,
                             ffd_error *err)
{
    return ffd_sess_points_load(&rbf_kind, ctx, rig, out, err);
}

/* The editor's defaults (ffd_method.create_body): without "control_points",
 * the 27 points of a 3 x 3 x 3 grid over the mesh's bounding box grown by a
 * tenth of its diagonal, and a radius of half the diagonal (PyGeM's 0.5 is in
 * model units, too small for most meshes). */
ffd_status ffd_sess_rbf_create_body(const sess_ctx *ctx, cJSON *body, const ffd_rig_parser *p)
{
    if (!cJSON_GetObjectItemCaseSensitive(body, "radius") &&
        !cJSON_AddNumberToObject(body, "radius", 0.5 * ctx->diag))
        return ffd_fail(p->err, FFD_ERR_NOMEM, "%s: out of memory", p->name);
    return ffd_sess_points_default_body(ctx, body, p);
}
