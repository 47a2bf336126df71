/* gffd_method — the gffd method's descriptor in the method registry
 * (deformer/method.h): its rig application, and its deformer from a rig or
 * from the editor's "create" body. */
#include "gffd/gffd_method.h"

static const char *const gffd_ops[] = {"primitive", NULL};

/* The rig keys of the editor's "create" body (docs/editor.md). */
static const char *const gffd_create_keys[] = {"skeleton", "unit", "tolerance", "max_iterations", "tracking", "max_samples", NULL};

#include <stdio.h>

/* Distributed runs: resampling replaces the mesh, so the partition. */
static unsigned gffd_global_reads(const ffd_rig *rig, char *why, size_t size)
{
    if (!ffd_rig_gffd_of(rig) || !ffd_rig_gffd_of(rig)->resample)
        return 0;
    snprintf(why, size,
             "\"resample\" adds vertices and faces, which changes the partition: resample on "
             "one process (ffd deform), then partition the result");
    return FFD_GLOBAL_REFUSED;
}

const ffd_method ffd_method_gffd = {
    .name = "gffd",
    .rig_keys = ffd_rig_keys_gffd,
    .section_size = sizeof(ffd_rig_gffd),
    .parse = ffd_rig_parse_gffd,
    .apply = ffd_rig_apply_gffd,
    .load = ffd_sess_gffd_load,
    .create_keys = gffd_create_keys,
    .create_body = ffd_sess_gffd_create_body,
    .release = ffd_rig_release_gffd,
    .write = ffd_rig_write_gffd,
    .ops = gffd_ops,
    .global_reads = gffd_global_reads,
};
