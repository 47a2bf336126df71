/* lattice_method — the lattice method's descriptor in the method registry
 * (deformer/method.h): its rig application, and its deformer from a rig or
 * from the editor's "create" body. */
#include "lattice/lattice_method.h"

/* The rig keys of the editor's "create" body (docs/editor.md). */
static const char *const lattice_create_keys[] = {"resolution", "basis", "box", "margin", "outside",
                                                  "tension", "continuity", "coordinates", "frame",
                                                  "falloff", "falloff_curve", NULL};

const ffd_method ffd_method_lattice = {
    .name = "lattice",
    .rig_keys = ffd_rig_keys_lattice,
    .section_size = sizeof(ffd_rig_lattice),
    .parse = ffd_rig_parse_lattice,
    .apply = ffd_rig_apply_lattice,
    .load = ffd_sess_lattice_load,
    .create_keys = lattice_create_keys,
    .release = ffd_rig_release_lattice,
    .write = ffd_rig_write_lattice,
};
