/* lattice_method — what the lattice method gives the generic layers (the
 * registry's descriptor in lattice_method.c): its rig section reader and
 * release (lattice_rig_json.c), its rig application, its editor deformer
 * (lattice_session.c), and the helpers its files share. */
#ifndef FFD_LATTICE_METHOD_H
#define FFD_LATTICE_METHOD_H

#include "deformer/method.h"
#include "rig/rig_json.h"

/* ---- the lattice's rig section (rig->section; NULL in rigs made without
 * the reader, e.g. from a .prm file: ffd_rig_lattice_of gives the defaults) ---- */

/* A child lattice of a nested rig (docs/lattice-variants.md, "Nested
 * lattices"; lattice_nested_rig_json.c). */
typedef struct ffd_rig_lattice_child {
    ffd_basis basis;            /* default: the parent's */
    uint32_t resolution[3];     /* default 4 x 4 x 4 */
    int box_auto;               /* 1: fit the vertices' bounding box grown by margin */
    double margin;              /* default 0.05 */
    ffd_box box;                /* when box_auto == 0 */
    uint32_t *vertices;         /* box "auto": the vertex selection */
    size_t vertex_count;
    ffd_rig_move *moves;        /* the child's own moves, on top of the parent's map */
    size_t move_count;
    struct ffd_rig_lattice_child *children;
    size_t child_count;
} ffd_rig_lattice_child;

typedef struct ffd_rig_lattice {
    double falloff;                  /* "outside": "falloff": the distance D (world units) */
    ffd_falloff_curve falloff_curve; /* "falloff_curve", default "smooth" */
    ffd_rig_lattice_child *children; /* "children": nested lattices */
    size_t child_count;
} ffd_rig_lattice;

/* The rig's lattice section, or the defaults (no falloff, no children). */
const ffd_rig_lattice *ffd_rig_lattice_of(const ffd_rig *rig);

/* Reads one {"index": [i,j,k], "delta": [dx,dy,dz]} (lattice_rig_json.c). */
ffd_status ffd_rig_read_lattice_move(const ffd_rig_parser *p, const cJSON *m, const char *path,
                                     void *element, void *ctx);

/* Nested lattices' rig keys (lattice_nested_rig_json.c): "children" read
 * into section (recursively, with the depth and control-point limits),
 * written back, released. */
ffd_status ffd_rig_parse_lattice_children(const ffd_rig_parser *p, const cJSON *item,
                                          const ffd_rig *rig, ffd_rig_lattice *section);
int ffd_rig_write_lattice_children(const ffd_rig_lattice_child *children, size_t count,
                                   cJSON *root);
void ffd_rig_release_lattice_children(ffd_rig_lattice_child *children, size_t count);

/* A nested rig applied (lattice_nested_rig.c) and its deformer
 * (lattice_nested_session.c): what ffd_rig_apply_lattice and
 * ffd_sess_lattice_load hand a rig with children to. */
ffd_status ffd_rig_apply_lattice_nested(const ffd_rig *rig, ffd_mesh *mesh, ffd_rig_report *report,
                                        ffd_budget *budget, ffd_error *err);
ffd_status ffd_sess_lattice_nested_load(const sess_ctx *ctx, const ffd_rig *rig, sess_method **out,
                                        ffd_error *err);

/* Binds points to a lattice with the rig's outside rule (with its falloff). */
ffd_status ffd_lattice_bind_rig(const ffd_lattice *lattice, const double *points, size_t n,
                                const ffd_rig *rig, ffd_lattice_binding **out, ffd_error *err);

/* The method's descriptor (lattice_method.c; listed in deformer/registry.c). */
extern const ffd_method ffd_method_lattice;

/* The writer (ffd_method.write; lattice_rig_json.c): 0 when out of memory. */
int ffd_rig_write_lattice(const ffd_rig *rig, cJSON *root);

/* The method's top-level rig keys (ffd_method.rig_keys; lattice_rig_json.c). */
extern const char *const ffd_rig_keys_lattice[];

void ffd_rig_release_lattice(ffd_rig *rig);

ffd_status ffd_sess_lattice_create(const sess_ctx *ctx, const cJSON *body, sess_method **out,
                               ffd_error *err);

ffd_status ffd_sess_lattice_load(const sess_ctx *ctx, const ffd_rig *rig, sess_method **out,
                             ffd_error *err);

/* Lattice application (rig_apply.c): moves, then direct manipulation. */
ffd_status ffd_rig_apply_lattice(const ffd_rig *rig, ffd_mesh *mesh, ffd_rig_report *report,
                                 ffd_budget *budget, ffd_error *err);

/* The lattice shape of a rig (lattice_rig.c): rig->shape, its frame fitted
 * to the n points when the rig's frame is "auto". */
ffd_status ffd_rig_lattice_shape(const ffd_rig *rig, const double *points, size_t n,
                                 ffd_lattice_shape *shape, ffd_error *err);

ffd_status ffd_rig_parse_lattice(const ffd_rig_parser *p, const cJSON *root, ffd_rig *rig);

#endif
