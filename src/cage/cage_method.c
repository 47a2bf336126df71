/* cage_method — the cage method's descriptor in the method registry
 * (deformer/method.h): its rig application, and its deformer from a rig or
 * from the editor's "create" body. */
#include "cage/cage_method.h"

/* The rig keys of the editor's "create" body (docs/editor.md). */
static const char *const cage_create_keys[] = {"cage", "margin", "coordinates", "resolution",
                                               "outside", NULL};

/* The editor's default cage: "auto" (the rig has no default). */
static ffd_status cage_create_body(const sess_ctx *ctx, cJSON *body, const ffd_rig_parser *p)
{
    (void)ctx;
    if (!cJSON_GetObjectItemCaseSensitive(body, "cage") &&
        !cJSON_AddStringToObject(body, "cage", "auto"))
        return ffd_fail(p->err, FFD_ERR_NOMEM, "%s: out of memory", p->name);
    return FFD_OK;
}

const ffd_method ffd_method_cage = {
    .name = "cage",
    .rig_keys = ffd_rig_keys_cage,
    .section_size = sizeof(ffd_rig_cage),
    .parse = ffd_rig_parse_cage,
    .apply = ffd_rig_apply_cage,
    .load = ffd_sess_cage_load,
    .create_keys = cage_create_keys,
    .create_body = cage_create_body,
    .release = ffd_rig_release_cage,
    .write = ffd_rig_write_cage,
};
