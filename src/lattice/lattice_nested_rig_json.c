/* lattice_nested_rig_json — the "children" of a lattice rig: nested
 * lattices (SU2's parent/child FFD boxes, pyGeo's child FFDs), each a
 * lattice section of its own (box or "auto" over a vertex selection,
 * resolution, basis, moves, children), any depth up to
 * FFD_LATTICE_MAX_DEPTH, with at most FFD_LATTICE_MAX_NESTED_CONTROLS
 * control points in all (docs/lattice-variants.md, "Nested lattices"). */
#include "lattice/lattice_method.h"
#include "lattice/lattice_nested.h"
#include "rig/rig_json.h"

#include <stdio.h>
#include <string.h>

typedef struct child_ctx {
    const ffd_rig *rig;
    ffd_basis parent_basis;
    unsigned depth;   /* of the children being read: 1 for the root's */
    double *controls; /* control points counted so far, all lattices */
} child_ctx;

static const char *const basis_names[] = {"bspline", "bernstein", NULL};

static ffd_status read_child(const ffd_rig_parser *p, const cJSON *item, const char *path,
                             void *element, void *ctx);

static void release_child(void *element)
{
    ffd_rig_lattice_child *c = element;
    ffd_free(c->vertices);
    ffd_free(c->moves);
    ffd_rig_release_lattice_children(c->children, c->child_count);
}

void ffd_rig_release_lattice_children(ffd_rig_lattice_child *children, size_t count)
{
    for (size_t i = 0; i < count; i++)
        release_child(children + i);
    ffd_free(children);
}

/* "children" at path (of a lattice at depth - 1) into *out. */
static ffd_status read_children(const ffd_rig_parser *p, const cJSON *item, const char *path,
                                child_ctx *ctx, ffd_rig_lattice_child **out, size_t *count)
{
    if (ctx->depth > FFD_LATTICE_MAX_DEPTH)
        return ffd_fail(p->err, FFD_ERR_INVALID,
                        "%s: %s: nested lattices deeper than the limit of %u levels below the "
                        "root lattice",
                        p->name, path, FFD_LATTICE_MAX_DEPTH);
    void *children = NULL;
    ffd_status s = ffd_rig_read_array(p, item, path,
                                      "an array of child lattices {\"box\", \"resolution\", "
                                      "\"basis\", \"moves\", \"children\", ...}",
                                      sizeof(ffd_rig_lattice_child), read_child, release_child,
                                      ctx, &children, count);
    *out = children;
    return s;
}

static ffd_status read_child_box(const ffd_rig_parser *p, const cJSON *item, const char *path,
                                 ffd_rig_lattice_child *c)
{
    static const char *const keys[] = {"origin", "axes", NULL};
    const char *what = "\"auto\" or an object {\"origin\": [x,y,z], \"axes\": [[..],[..],[..]]}";
    char sub[RIG_PATH_MAX + 32];
    if (cJSON_IsString(item) && strcmp(item->valuestring, "auto") == 0) {
        c->box_auto = 1;
        return FFD_OK;
    }
    if (!cJSON_IsObject(item))
        return ffd_rig_expected(p, path, what);
    ffd_status s = ffd_rig_check_keys(p, item, path, keys, "\"origin\", \"axes\"");
    if (s)
        return s;
    const cJSON *origin = cJSON_GetObjectItemCaseSensitive(item, "origin");
    const cJSON *axes = cJSON_GetObjectItemCaseSensitive(item, "axes");
    if (snprintf(sub, sizeof sub, "%s.origin", path) < 0)
        sub[0] = 0;
    if (!origin)
        return ffd_rig_expected(p, sub, "an array of 3 finite numbers (missing)");
    if ((s = ffd_rig_read_vec3(p, origin, sub, c->box.origin)))
        return s;
    if (snprintf(sub, sizeof sub, "%s.axes", path) < 0)
        sub[0] = 0;
    if (!axes || !cJSON_IsArray(axes) || cJSON_GetArraySize(axes) != 3)
        return ffd_rig_expected(p, sub, "an array of 3 axes, each an array of 3 finite numbers");
    for (int i = 0; i < 3; i++) {
        if (snprintf(sub, sizeof sub, "%s.axes[%d]", path, i) < 0)
            sub[0] = 0;
        if ((s = ffd_rig_read_vec3(p, cJSON_GetArrayItem(axes, i), sub, c->box.axes[i])))
            return s;
    }
    c->box_auto = 0;
    return FFD_OK;
}

static ffd_status read_vertex(const ffd_rig_parser *p, const cJSON *item, const char *path,
                              void *element, void *ctx)
{
    (void)ctx;
    if (!ffd_rig_is_uint32(item))
        return ffd_rig_expected(p, path, "a vertex id (a non-negative integer)");
    *(uint32_t *)element = (uint32_t)item->valuedouble;
    return FFD_OK;
}

static ffd_status read_child(const ffd_rig_parser *p, const cJSON *item, const char *path,
                             void *element, void *vctx)
{
    static const char *const keys[] = {"box",   "margin", "vertices", "resolution",
                                       "basis", "moves",  "children", NULL};
    child_ctx *ctx = vctx;
    ffd_rig_lattice_child *c = element;
    char sub[RIG_PATH_MAX + 32];
    const cJSON *it;
    ffd_status s;
    if (!cJSON_IsObject(item))
        return ffd_rig_expected(p, path, "a child lattice: an object {\"box\", \"resolution\", ...}");
    if ((s = ffd_rig_check_keys(p, item, path, keys,
                                "\"box\", \"margin\", \"vertices\", \"resolution\", \"basis\", "
                                "\"moves\", \"children\"")))
        return s;
    c->basis = ctx->parent_basis;
    c->resolution[0] = c->resolution[1] = c->resolution[2] = 4;
    c->box_auto = 1;
    c->margin = 0.05;
#define SUB(key) (snprintf(sub, sizeof sub, "%s.%s", path, key) < 0 ? path : sub)
    if ((it = cJSON_GetObjectItemCaseSensitive(item, "basis"))) {
        int b = 0;
        if ((s = ffd_rig_read_enum(p, it, SUB("basis"), basis_names, "\"bspline\" or \"bernstein\"",
                                   &b)))
            return s;
        c->basis = b ? FFD_BASIS_BERNSTEIN : FFD_BASIS_BSPLINE;
    }
    if ((it = cJSON_GetObjectItemCaseSensitive(item, "resolution")) &&
        (s = ffd_rig_read_uint3(p, it, SUB("resolution"), c->resolution)))
        return s;
    uint32_t lo = ffd_basis_min_resolution(c->basis);
    uint32_t hi = c->basis == FFD_BASIS_BERNSTEIN ? 64u : 1024u;
    for (int a = 0; a < 3; a++)
        if (c->resolution[a] < lo || c->resolution[a] > hi)
            return ffd_fail(p->err, FFD_ERR_INVALID,
                            "%s: %s[%d]: %u control points: expected %u to %u for the %s basis",
                            p->name, SUB("resolution"), a, c->resolution[a], lo, hi,
                            basis_names[c->basis == FFD_BASIS_BERNSTEIN]);
    *ctx->controls += (double)c->resolution[0] * c->resolution[1] * c->resolution[2];
    if (*ctx->controls > FFD_LATTICE_MAX_NESTED_CONTROLS)
        return ffd_fail(p->err, FFD_ERR_INVALID,
                        "%s: %s: nested lattices with %.0f control points in all, above the "
                        "limit of %u",
                        p->name, path, *ctx->controls, FFD_LATTICE_MAX_NESTED_CONTROLS);
    if ((it = cJSON_GetObjectItemCaseSensitive(item, "box")) &&
        (s = read_child_box(p, it, SUB("box"), c)))
        return s;
    if ((it = cJSON_GetObjectItemCaseSensitive(item, "margin"))) {
        if ((s = ffd_rig_read_number(p, it, SUB("margin"), &c->margin)))
            return s;
        if (!(c->margin >= 0))
            return ffd_rig_expected(p, sub, "a number >= 0");
    }
    if ((it = cJSON_GetObjectItemCaseSensitive(item, "vertices"))) {
        void *v = NULL;
        s = ffd_rig_read_array(p, it, SUB("vertices"), "an array of vertex ids",
                               sizeof(uint32_t), read_vertex, NULL, NULL, &v, &c->vertex_count);
        c->vertices = v;
        if (s)
            return s;
    }
    if (c->box_auto && !c->vertex_count)
        return ffd_rig_expected(p, SUB("box"),
                                "an object {\"origin\", \"axes\"}, or \"auto\" with \"vertices\" "
                                "(the vertex selection the box is fitted to)");
    if ((it = cJSON_GetObjectItemCaseSensitive(item, "moves"))) {
        void *m = NULL;
        s = ffd_rig_read_array(p, it, SUB("moves"),
                               "an array of {\"index\": [i,j,k], \"delta\": [dx,dy,dz]}",
                               sizeof(ffd_rig_move), ffd_rig_read_lattice_move, NULL, NULL, &m,
                               &c->move_count);
        c->moves = m;
        if (s)
            return s;
        for (size_t i = 0; i < c->move_count; i++) {
            const uint32_t *ix = c->moves[i].index;
            if (ix[0] >= c->resolution[0] || ix[1] >= c->resolution[1] || ix[2] >= c->resolution[2])
                return ffd_fail(p->err, FFD_ERR_RANGE,
                                "%s: %s.moves[%zu].index: [%u, %u, %u] out of range for a "
                                "%u x %u x %u lattice (indices start at 0)",
                                p->name, path, i, ix[0], ix[1], ix[2], c->resolution[0],
                                c->resolution[1], c->resolution[2]);
        }
    }
    if ((it = cJSON_GetObjectItemCaseSensitive(item, "children"))) {
        child_ctx inner = *ctx;
        inner.parent_basis = c->basis;
        inner.depth = ctx->depth + 1;
        if ((s = read_children(p, it, SUB("children"), &inner, &c->children, &c->child_count)))
            return s;
    }
#undef SUB
    return FFD_OK;
}

ffd_status ffd_rig_parse_lattice_children(const ffd_rig_parser *p, const cJSON *item,
                                          const ffd_rig *rig, ffd_rig_lattice *section)
{
    double controls = (double)rig->resolution[0] * rig->resolution[1] * rig->resolution[2];
    child_ctx ctx = {rig, rig->basis, 1, &controls};
    return read_children(p, item, "children", &ctx, &section->children, &section->child_count);
}

int ffd_rig_write_lattice_children(const ffd_rig_lattice_child *children, size_t count,
                                   cJSON *root)
{
    cJSON *array = cJSON_AddArrayToObject(root, "children");
    int ok = array != NULL;
    for (size_t i = 0; ok && i < count; i++) {
        const ffd_rig_lattice_child *c = &children[i];
        cJSON *child = cJSON_CreateObject(), *box = NULL, *moves = NULL;
        ok = ffd_sess_add_to_array(array, child) &&
             cJSON_AddStringToObject(child, "basis", basis_names[c->basis == FFD_BASIS_BERNSTEIN]) &&
             ffd_sess_add_item(child, "resolution", ffd_sess_uint_array(c->resolution, 3));
        if (ok && c->box_auto) {
            cJSON *v = cJSON_AddArrayToObject(child, "vertices");
            ok = v && cJSON_AddStringToObject(child, "box", "auto") &&
                 ffd_sess_add_item(child, "margin", ffd_sess_number(c->margin));
            for (size_t k = 0; ok && k < c->vertex_count; k++)
                ok = ffd_sess_add_to_array(v, cJSON_CreateNumber(c->vertices[k]));
        } else if (ok) {
            ok = (box = cJSON_AddObjectToObject(child, "box")) &&
                 ffd_sess_add_item(box, "origin", ffd_sess_vec3(c->box.origin)) &&
                 ffd_sess_add_item(box, "axes",
                                   ffd_sess_matrix3((const double(*)[3])c->box.axes));
        }
        ok = ok && (moves = cJSON_AddArrayToObject(child, "moves"));
        for (size_t k = 0; ok && k < c->move_count; k++) {
            cJSON *move = cJSON_CreateObject();
            ok = ffd_sess_add_to_array(moves, move) &&
                 ffd_sess_add_item(move, "index", ffd_sess_uint_array(c->moves[k].index, 3)) &&
                 ffd_sess_add_item(move, "delta", ffd_sess_vec3(c->moves[k].delta));
        }
        if (ok && c->child_count)
            ok = ffd_rig_write_lattice_children(c->children, c->child_count, child);
    }
    return ok;
}
