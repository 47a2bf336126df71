/* tspline_method — the tspline method's descriptor in the method registry
 * (deformer/method.h): its rig application, and its deformer from a rig or
 * from the editor's "create" body. */
#include "tspline/tspline_method.h"

static const char *const tspline_ops[] = {"refine", "freeze", NULL};

/* The rig keys of the editor's "create" body (docs/editor.md). */
static const char *const tspline_create_keys[] = {"resolution", "padding", NULL};

#include <stdio.h>

/* Distributed runs: the proxy's occupancy reads the boundary surface. */
static unsigned tspline_global_reads(const ffd_rig *rig, char *why, size_t size)
{
    (void)rig, (void)why, (void)size;
    return FFD_GLOBAL_SURFACE;
}

/* The vertex ids of the rig's "constrain" steps. */
static ffd_status tspline_vertex_ids(ffd_rig *rig, ffd_vertex_visit visit, void *user)
{
    ffd_rig_tspline *t = ffd_rig_tspline_of(rig);
    for (size_t s = 0; t && s < t->step_count; s++)
        for (size_t c = 0; c < t->steps[s].constraint_count; c++) {
            ffd_rig_constraint *con = &t->steps[s].constraints[c];
            if (con->kind != FFD_RIG_CONSTRAINT_VERTEX)
                continue;
            char path[96];
            snprintf(path, sizeof path, "steps[%zu].constraints[%zu].vertex", s, c);
            ffd_status st = visit(user, &con->vertex, path);
            if (st)
                return st;
        }
    return FFD_OK;
}

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
    .global_reads = tspline_global_reads,
    .vertex_ids = tspline_vertex_ids,
};
