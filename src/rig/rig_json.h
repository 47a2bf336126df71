/* rig_json — the JSON value readers shared by the rig readers (rig_json.c)
 * and the section reader of each method (rig_json_<method>.c: one schema per
 * method, named in the method registry, deformer/method.h). Each names the
 * JSON path of what it rejects: "rig.json: steps[1].deform.handles[0].delta:
 * expected an array of 3 finite numbers". */
#ifndef FFD_RIG_JSON_H
#define FFD_RIG_JSON_H

#include "rig/rig.h"

#include <cjson/cJSON.h>

#define RIG_PATH_MAX 96

/* Which files a rig may read besides itself (the "file" of a skeleton
 * primitive): with no policy (NULL), any; with one, only files under root,
 * and none when root is NULL (a rig uploaded to the editor's server). */
typedef struct ffd_rig_files {
    const char *root;
} ffd_rig_files;

/* Where messages go: "NAME: PATH: expected WHAT" (name: the rig file, or
 * the editor's op); files: what the rig may read (NULL: anything). */
typedef struct ffd_rig_parser {
    const char *name;
    ffd_error *err;
    const ffd_rig_files *files;
} ffd_rig_parser;

/* A rig's "file" (as written) under the list key, resolved to path: refused
 * (FFD_ERR_INVALID, naming key and file) when p->files does not allow it. */
ffd_status ffd_rig_check_input(const ffd_rig_parser *p, const char *key, const char *file,
                               const char *path);
/* A rig on the caller's stack, for a method's writer or steps: zeroed, of
 * method, with section zeroed (size bytes; NULL, 0 for none) as its
 * section. Never ffd_rig_destroy'd: what it points to is the caller's. */
void ffd_rig_view(ffd_rig *rig, const struct ffd_method *method, void *section, size_t size);
/* The rig as JSON text its reader reads back to the same rig: "version",
 * "deformer", the method's writer (ffd_method.write), then "rcond" and
 * "constraints" when set (*text ffd_free'd by the caller). */
ffd_status ffd_rig_write_json(const ffd_rig *rig, char **text, ffd_error *err);
/* ffd_rig_parse_json with a file policy (files may be NULL: any). */
ffd_status ffd_rig_parse_json_files(const char *text, size_t size, const char *name,
                                    const ffd_rig_files *files, ffd_rig **out, ffd_error *err);

ffd_status ffd_rig_expected(const ffd_rig_parser *p, const char *path, const char *what);
ffd_status ffd_rig_read_number(const ffd_rig_parser *p, const cJSON *item, const char *path, double *out);
/* An array of exactly 3 finite numbers. */
ffd_status ffd_rig_read_vec3(const ffd_rig_parser *p, const cJSON *item, const char *path, double out[3]);
int ffd_rig_is_uint32(const cJSON *item);
/* An array of exactly 3 non-negative integers. */
ffd_status ffd_rig_read_uint3(const ffd_rig_parser *p, const cJSON *item, const char *path, uint32_t out[3]);
/* Index of s in the NULL-terminated list, or -1. */
int ffd_rig_lookup(const char *s, const char *const *names);
/* One of a fixed set of strings; what describes the set for the message. */
ffd_status ffd_rig_read_enum(const ffd_rig_parser *p, const cJSON *item, const char *path,
                         const char *const *names, const char *what, int *out);
/* Rejects keys outside allowed (NULL-terminated) and keys given twice. */
ffd_status ffd_rig_check_keys(const ffd_rig_parser *p, const cJSON *object, const char *path,
                          const char *const *allowed, const char *allowed_text);
/* A non-negative integer that fits uint32_t. */
ffd_status ffd_rig_read_index(const ffd_rig_parser *p, const cJSON *item, const char *path, const char *what,
                          uint32_t *out);
ffd_status ffd_rig_read_positive(const ffd_rig_parser *p, const cJSON *item, const char *path, double *out);
/* {"axis": [x,y,z], "angle": radians} and, when center is not NULL, an
 * optional "center": [x,y,z] (*has_center set when given). */
ffd_status ffd_rig_read_rotation(const ffd_rig_parser *p, const cJSON *item, const char *path,
                             double axis[3], double *angle, double center[3], int *has_center);
/* Reads one element of an array (ffd_rig_read_array): item is the element,
 * path its JSON path ("key[i]"), element its zeroed slot; ctx is the
 * caller's. */
typedef ffd_status (*ffd_rig_element_reader)(const ffd_rig_parser *p, const cJSON *item,
                                             const char *path, void *element, void *ctx);
/* Frees what a reader left in an element (read or not; zeroed ones too). */
typedef void (*ffd_rig_element_free)(void *element);
/* "Read an array of X": item must be an array (else "key: expected what");
 * each element is read into a zeroed slot of size bytes by read, with the
 * path "key[i]". On success *out holds the *count elements (NULL when the
 * array is empty; ffd_free'd by the caller); on error every element is
 * released (release may be NULL), *out is NULL and *count 0. */
ffd_status ffd_rig_read_array(const ffd_rig_parser *p, const cJSON *item, const char *key,
                              const char *what, size_t size, ffd_rig_element_reader read,
                              ffd_rig_element_free release, void *ctx, void **out, size_t *count);
/* A move of one control point of a scattered-point method (RBF, IDW):
 * {"index": i, "delta": [dx,dy,dz]}. */
typedef struct ffd_rig_point_move {
    uint32_t index;
    double delta[3];
} ffd_rig_point_move;
/* ffd_rig_read_array's reader of one move; ctx: what the index names, e.g.
 * "a control point index" (in the messages). */
ffd_status ffd_rig_read_point_move(const ffd_rig_parser *p, const cJSON *m, const char *path,
                                   void *element, void *ctx);
/* An array of at least min points [x,y,z] (*count by 3). */
ffd_status ffd_rig_read_points(const ffd_rig_parser *p, const cJSON *item, const char *path,
                               size_t min, double **out, size_t *count);
/* An array of {"vertex": id, "target": [x,y,z]} or {"point": [x,y,z], "target": [..]}. */
ffd_status ffd_rig_read_constraints(const ffd_rig_parser *p, const cJSON *item, const char *where,
                                ffd_rig_constraint **out, size_t *count);


/* "version", if given, is 1. */
ffd_status ffd_rig_read_version(const ffd_rig_parser *p, const cJSON *root);
/* The top-level keys of a rig of one method: "version", "deformer" and the
 * method's rig keys (else "NAME: KEY: not a key of "deformer": "METHOD"
 * rigs, expected one of ..."), none twice; and the version. */
ffd_status ffd_rig_check_deformer_root(const ffd_rig_parser *p, const cJSON *root,
                                       const struct ffd_method *method);

/* The root of a rig of a method with direct manipulation (rig->method):
 * the keys such rigs share ("rcond", "constraints"), every key checked (a
 * key of another method named as such: "only for "deformer": "X" rigs"),
 * "deformer" and "version". */
ffd_status ffd_rig_read_linear_root(const ffd_rig_parser *p, const cJSON *root, ffd_rig *rig);


/* A rig from its parsed JSON tree (what ffd_rig_parse_json does after the
 * syntax checks; the editor's "create" body is read by it): name is used in
 * messages and for the files the rig refers to, files says which it may
 * read (NULL: any). *out NULL on error. */
ffd_status ffd_rig_parse_tree(const cJSON *root, const char *name, const ffd_rig_files *files,
                              ffd_rig **out, ffd_error *err);

/* The generic layers' keys of root (rig_layers.c): read into rig->layers
 * (left NULL when root has none); a file they name goes through
 * ffd_rig_check_input. */
ffd_status ffd_rig_read_layers(const ffd_rig_parser *p, const cJSON *root, ffd_rig *rig);
/* Adds the layers' keys to root as ffd_rig_read_layers reads them; 0 when
 * out of memory (1 for NULL layers). */
int ffd_rig_write_layers(const ffd_rig_layers *layers, cJSON *root);

/* "pins" (rig_pins.c): [{"vertex": id, "target": [x,y,z]}, ...], each
 * vertex once, into rig->pins. The vertex ids are checked against a mesh
 * by ffd_rig_check_pins (rig.h), when the rig is applied or loaded. */
ffd_status ffd_rig_read_pins(const ffd_rig_parser *p, const cJSON *item, ffd_rig *rig);
/* The pins as ffd_rig_read_pins reads them (NULL: out of memory). */
cJSON *ffd_rig_pins_json(const ffd_rig_pin *pins, size_t count);

/* The section reader of each method (ffd_method.parse, one file each): the
 * whole root object of a rig of that method, into rig (which it tags with
 * the method); what it read stays in rig for ffd_rig_destroy, on error too. */

#endif
