/* lattice_method — the lattice method's descriptor in the method registry
 * (deformer/method.h): its rig application, and its deformer from a rig or
 * from the editor's "create" body. */
#include "lattice/lattice_method.h"

/* The rig keys of the editor's "create" body (docs/editor.md). */
static const char *const lattice_create_keys[] = {"resolution", "basis", "box", "margin", "outside",
                                                  "tension", "continuity", "coordinates", "frame",
                                                  "falloff", "falloff_curve", NULL};

#include "lattice/lattice.h"

#include <stdint.h>
#include <stdio.h>

/* Distributed runs: a cylindrical or spherical frame fitted to the mesh
 * reads, besides the extent, the point farthest from its axis. */
static void lattice_global_points(const ffd_rig *rig, const double lo[3], const double hi[3],
                                  const double *points, size_t n, unsigned char *keep)
{
    if (rig->shape.coordinates == FFD_COORDINATES_CARTESIAN || !rig->frame_auto)
        return;
    size_t far = ffd_lattice_frame_farthest(rig->shape.coordinates, lo, hi, points, n);
    if (far != SIZE_MAX)
        keep[far] = 1;
}

/* The vertex selections of nested lattices with "box": "auto". */
static ffd_status child_vertex_ids(ffd_rig_lattice_child *children, size_t count,
                                   const char *prefix, ffd_vertex_visit visit, void *user)
{
    for (size_t c = 0; c < count; c++) {
        char path[256];
        for (size_t v = 0; v < children[c].vertex_count; v++) {
            snprintf(path, sizeof path, "%schildren[%zu].vertices[%zu]", prefix, c, v);
            ffd_status st = visit(user, &children[c].vertices[v], path);
            if (st)
                return st;
        }
        snprintf(path, sizeof path, "%schildren[%zu].", prefix, c);
        ffd_status st = child_vertex_ids(children[c].children, children[c].child_count, path,
                                         visit, user);
        if (st)
            return st;
    }
    return FFD_OK;
}

static ffd_status lattice_vertex_ids(ffd_rig *rig, ffd_vertex_visit visit, void *user)
{
    ffd_rig_lattice *section = rig->section;
    return section ? child_vertex_ids(section->children, section->child_count, "", visit, user)
                   : FFD_OK;
}

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
    .global_points = lattice_global_points,
    .vertex_ids = lattice_vertex_ids,
};
