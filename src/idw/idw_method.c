/* idw_method — the IDW method's descriptor in the method registry
 * (deformer/method.h). */
#include "idw/idw_method.h"

/* The rig keys of the editor's "create" body (docs/editor.md). */
static const char *const idw_create_keys[] = {"control_points", "power", "weighting", NULL};

const ffd_method ffd_method_idw = {
    .name = "idw",
    .rig_keys = ffd_rig_keys_idw,
    .section_size = sizeof(ffd_rig_idw),
    .parse = ffd_rig_parse_idw,
    .write = ffd_rig_write_idw,
    .apply = ffd_rig_apply_idw,
    .load = ffd_sess_idw_load,
    .create_keys = idw_create_keys,
    .create_body = ffd_sess_idw_create_body,
    .release = ffd_rig_release_idw,
    .prm_section = "Inverse Distance Weighting",
    .parse_prm = ffd_rig_parse_prm_idw,
    .write_prm = ffd_rig_write_prm_idw,
};
