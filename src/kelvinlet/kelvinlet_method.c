/* kelvinlet_method — the Kelvinlet method's descriptor in the method
 * registry (deformer/method.h): its rig schema and application, and its
 * deformer from a rig or from the editor's "create" body. */
#include "kelvinlet/kelvinlet_method.h"

/* The rig keys of the editor's "create" body (docs/editor.md). */
static const char *const kelvinlet_create_keys[] = {"brushes", "poisson_ratio", "combine", "steps",
                                                    "multiscale", "ratio", NULL};

/* Its own editor operations (kelvinlet_session.c, docs/kelvinlet.md). */
static const char *const kelvinlet_ops[] = {"brush", NULL};

const ffd_method ffd_method_kelvinlet = {
    .name = "kelvinlet",
    .rig_keys = ffd_rig_keys_kelvinlet,
    .section_size = sizeof(ffd_rig_kelvinlet),
    .parse = ffd_rig_parse_kelvinlet,
    .write = ffd_rig_write_kelvinlet,
    .apply = ffd_rig_apply_kelvinlet,
    .load = ffd_sess_kelvinlet_load,
    .create_keys = kelvinlet_create_keys,
    .release = ffd_rig_release_kelvinlet,
    .ops = kelvinlet_ops,
};
