/* tspline_method — the tspline method's descriptor in the method registry
 * (deformer/method.h): its rig application, and its deformer from a rig or
 * from the editor's "create" body. */
#include "tspline/tspline_method.h"

static const char *const tspline_ops[] = {"refine", "freeze", NULL};

/* The rig keys of the editor's "create" body (docs/editor.md). */
static const char *const tspline_create_keys[] = {"resolution", "padding", NULL};

const ffd_method ffd_method_tspline = {
    .name = "tspline",
    .rig_keys = ffd_rig_keys_tspline,
    .section_size = sizeof(ffd_rig_tspline),
    .parse = ffd_rig_parse_tspline,
    .apply = ffd_rig_apply_tspline,
    .load = ffd_sess_tspline_load,
    .create_keys = tspline_create_keys,
    .release = ffd_rig_release_tspline,
    .write = ffd_rig_write_tspline,
    .ops = tspline_ops,
};
