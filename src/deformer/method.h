/* method — the method registry: one descriptor per deformation method
 * (registry.c lists them). Everything generic — ffd_rig_apply, the
 * public ffd_deformer, the editor session, the server's list of methods —
 * looks a method up here instead of switching on it. Adding a method is its
 * folder, one descriptor file (src/<method>/<method>_method.c) and one line
 * in registry.c; docs/architecture.md walks through it. */
#ifndef FFD_METHOD_H
#define FFD_METHOD_H

#include "rig/rig.h"
#include "session/session.h"

/* A visitor of the mesh vertex ids a rig holds (ffd_method.vertex_ids):
 * path names the key ("constraints[2].vertex"). */
typedef ffd_status (*ffd_vertex_visit)(void *user, uint32_t *id, const char *path);

typedef struct ffd_method {
    const char *name;               /* the rig's "deformer" and the editor's "method" */
    /* The method's own top-level rig keys besides "version" and "deformer"
     * (NULL-terminated): the rig reader names the method of a key a rig of
     * another method must not have. */
    const char *const *rig_keys;
    /* The size of the method's rig section (rig->section: zeroed before its
     * parse, freed after its release); 0: the method has none. */
    size_t section_size;
    /* The method's schema: reads a rig's root object whose "deformer" names
     * it into rig (rig_json_<method>.c; ffd_rig_parse_json dispatches here,
     * the editor's "create" reads its body with it). */
    ffd_status (*parse)(const ffd_rig_parser *p, const cJSON *root, ffd_rig *rig);
    /* The method's writer, in the same file as parse: the section (and the
     * keys of rig it owns) as parse reads them, added to root; 0 when out of
     * memory. The editor's saved rigs are written with it. */
    int (*write)(const ffd_rig *rig, cJSON *root);
    /* Applies a parsed rig of this method to mesh (ffd_rig_apply). */
    ffd_status (*apply)(const ffd_rig *rig, ffd_mesh *mesh, ffd_rig_report *report,
                        ffd_budget *budget, ffd_error *err);
    /* The method's deformer from a rig of this method, replayed on ctx's
     * mesh (ffd_deformer_create, the session's load_rig and undo). */
    ffd_status (*load)(const sess_ctx *ctx, const ffd_rig *rig, sess_method **out,
                       ffd_error *err);
    /* The editor's "create" body is the creation part of a rig of this
     * method (ffd_method_create): create_keys are the rig keys it may hold
     * besides "version" and "deformer" (NULL-terminated); create_body, when
     * not NULL, prepares the body (the session's copy) before the rig
     * reader reads it: the editor's defaults for absent keys, the old forms
     * of keys turned into the rig's, and what an editing session refuses
     * (messages through p). */
    const char *const *create_keys;
    ffd_status (*create_body)(const sess_ctx *ctx, cJSON *body, const ffd_rig_parser *p);
    /* Frees what the method's section of a rig holds (not the section
     * itself); called when rig->section is not NULL. */
    void (*release)(ffd_rig *rig);
    /* The editor operations of the method's own (sess_vtable.op), NULL-terminated. */
    const char *const *ops;
    /* PyGeM parameter files (.prm) of the method, other than the lattice's
     * (rig/rig_prm.c): the section whose header marks them, their reader
     * (ffd_rig_parse_prm dispatches here) and writer (ffd_rig_write_prm);
     * NULL for none. */
    const char *prm_section;
    ffd_status (*parse_prm)(const char *text, size_t size, const char *name, ffd_rig **out,
                            ffd_error *err);
    ffd_status (*write_prm)(const ffd_rig *rig, char **text, ffd_error *err);
    /* Distributed runs (distributed.c, docs/mpi.md): what the method's
     * deformer reads of the whole mesh besides its extent and the vertices
     * the rig names. global_reads: FFD_GLOBAL_SURFACE (its boundary surface:
     * placement, occupancy, distance fields), or FFD_GLOBAL_REFUSED with the
     * reason written to why (size bytes); NULL: nothing more. */
    unsigned (*global_reads)(const ffd_rig *rig, char *why, size_t size);
    /* Marks in keep the points of this rank (n by 3) that a fit of the
     * method reads besides the whole mesh's extent lo..hi; NULL: none. */
    void (*global_points)(const ffd_rig *rig, const double lo[3], const double hi[3],
                          const double *points, size_t n, unsigned char *keep);
    /* Calls visit on every mesh vertex id the method's section holds, with
     * its key path; visit may rewrite the id. Returns the first failing
     * visit's status. NULL: the section holds none. */
    ffd_status (*vertex_ids)(ffd_rig *rig, ffd_vertex_visit visit, void *user);
} ffd_method;

enum { FFD_GLOBAL_SURFACE = 1u, FFD_GLOBAL_REFUSED = 2u };

/* The method a "create" body names by "deformer" or by "method" (the old
 * name of the key; both given must agree): FFD_ERR_PARSE naming the key. */
ffd_status ffd_method_of_body(const ffd_rig_parser *p, const cJSON *body, const ffd_method **out);
/* The method's deformer from the editor's "create" body (docs/editor.md):
 * the body (a JSON object; its "deformer" or "method", if any, names this
 * method) is read by the rig reader as a rig of the method, after
 * method->create_body, and built by method->load; a key outside
 * create_keys is refused by name. Messages start with "create: ". */
ffd_status ffd_method_create(const ffd_method *method, const sess_ctx *ctx, const cJSON *body,
                             sess_method **out, ffd_error *err);

/* The registered methods, in registry order (i < ffd_method_count()). */
size_t ffd_method_count(void);
const ffd_method *ffd_method_at(size_t i);
/* The method a rig without "deformer" (and a .prm file) uses. */
const ffd_method *ffd_method_default(void);
/* The method named name, NULL when none is. */
const ffd_method *ffd_method_find(const char *name);
/* The method of a parsed rig (never NULL for a rig the parser made). */
const ffd_method *ffd_method_of_rig(const ffd_rig *rig);
/* The method whose prm_section is a section of the .prm text (rig_prm.c);
 * NULL: none (a lattice file). */
const ffd_method *ffd_method_of_prm(const char *text, size_t size);
/* 1 when op is one of some registered method's own editor operations. */
int ffd_method_op_known(const char *op);
/* Writes the names quoted, as a list for messages ("\"a\", \"b\" or
 * \"c\"", registry order) into buf (truncated to size); returns buf. */
const char *ffd_method_names(char *buf, size_t size);

/* The method's deformer from a rig (method->load), wrapped in the generic
 * layers when the rig has any (layers.c: weights, strength, constraints,
 * fold policy; docs/constraints.md): every load goes through it. */
ffd_status ffd_method_load(const ffd_method *method, const sess_ctx *ctx, const ffd_rig *rig,
                           sess_method **out, ffd_error *err);
/* Adds "layers" (strength, weights, the constraints' residual and change,
 * the fold policy's fraction) to details when m is wrapped (layers.c);
 * FFD_ERR_NOMEM. */
ffd_status ffd_layers_outcome(const sess_method *m, cJSON *details);
/* The editor's vertex-group weights (the session's "weights" op;
 * docs/editor.md). ffd_layers_weights: m's weights into out (ctx->n values,
 * before the strength; 1 everywhere when m has none); an attribute's are read
 * from the mesh (its status). ffd_layers_set_weights: gives *m the weights
 * w (ctx->n finite values, copied; NULL: none), saved in its rig as
 * "values"; a method without the layers is wrapped in them (*m becomes the
 * wrapper, which owns the old handle). The controls are projected onto the
 * rig's constraints again, as a replay of the rig would; that failing
 * (FFD_ERR_NUMERIC) leaves *m with the new weights: the caller rolls back.
 * FFD_ERR_NOMEM leaves *m as it was. */
ffd_status ffd_layers_weights(const sess_method *m, double *out, ffd_error *err);
ffd_status ffd_layers_set_weights(sess_method **m, const double *w, ffd_error *err);

/* The method behind a public deformer and its binding of the bound points
 * (deformer.c; for the generic operations in other files: sensitivities.c). */
sess_method *ffd_deformer_session_method(ffd_deformer *d, const sess_binding **binding);


#endif
