/* lattice_method — what the lattice method gives the generic layers (the
 * registry's descriptor in lattice_method.c): its rig section reader and
 * release (lattice_rig_json.c), its rig application, its editor deformer
 * (lattice_session.c), and the helpers its files share. */
#ifndef FFD_LATTICE_METHOD_H
#define FFD_LATTICE_METHOD_H

#include "deformer/method.h"
#include "rig/rig_json.h"

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
