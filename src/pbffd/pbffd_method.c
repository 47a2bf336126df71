/* pbffd_method — the pbffd method's descriptor in the method registry
 * (deformer/method.h): its rig application, and its deformer from a rig or
 * from the editor's "create" body. */
#include "pbffd/pbffd_method.h"

static const char *const pbffd_ops[] = {"level", "frame", "curve", NULL};

/* The rig keys of the editor's "create" body (docs/editor.md). */
static const char *const pbffd_create_keys[] = {"controls", "sigma", "master", "levels", NULL};

/* Distributed runs: automatic placement reads the boundary surface. */
static unsigned pbffd_global_reads(const ffd_rig *rig, char *why, size_t size)
{
    (void)why, (void)size;
    return ffd_rig_pbffd_of(rig) && ffd_rig_pbffd_of(rig)->controls_auto ? FFD_GLOBAL_SURFACE : 0;
}

const ffd_method ffd_method_pbffd = {
    .name = "pbffd",
    .rig_keys = ffd_rig_keys_pbffd,
    .section_size = sizeof(ffd_rig_pbffd),
    .parse = ffd_rig_parse_pbffd,
    .apply = ffd_rig_apply_pbffd,
    .load = ffd_sess_pbffd_load,
    .create_keys = pbffd_create_keys,
    .create_body = ffd_sess_pbffd_create_body,
    .release = ffd_rig_release_pbffd,
    .write = ffd_rig_write_pbffd,
    .ops = pbffd_ops,
    .global_reads = pbffd_global_reads,
};
