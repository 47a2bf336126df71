/* rbf_method — the RBF method's descriptor in the method registry
 * (deformer/method.h). */
#include "rbf/rbf_method.h"

/* The rig keys of the editor's "create" body (docs/editor.md). */
static const char *const rbf_create_keys[] = {"control_points", "kernel", "radius", "power", "solver", NULL};

const ffd_method ffd_method_rbf = {
    .name = "rbf",
    .rig_keys = ffd_rig_keys_rbf,
    .section_size = sizeof(ffd_rig_rbf),
    .parse = ffd_rig_parse_rbf,
    .write = ffd_rig_write_rbf,
    .apply = ffd_rig_apply_rbf,
    .load = ffd_sess_rbf_load,
    .create_keys = rbf_create_keys,
    .create_body = ffd_sess_rbf_create_body,
    .release = ffd_rig_release_rbf,
    .prm_section = "Radial Basis Functions",
    .parse_prm = ffd_rig_parse_prm_rbf,
    .write_prm = ffd_rig_write_prm_rbf,
};
