/* rig_json_lattice — "deformer": "lattice" rigs (docs/rig.md, "Lattice
 * rigs"; also rigs without "deformer"): a Sederberg-Parry / B-spline lattice
 * (basis, resolution, box), control-point moves, and the constraints of
 * direct manipulation (Hsu et al. 1992). The lattice's section reader in the
 * method registry (ffd_method_lattice.parse). */
#include "lattice/lattice_method.h"
#include "rig/rig_json.h"

#include <stdio.h>
#include <string.h>

#define RIG_MAX_RESOLUTION 1024u

static ffd_status read_box(const ffd_rig_parser *p, const cJSON *item, ffd_rig *rig)
{
    if (cJSON_IsString(item)) {
        if (strcmp(item->valuestring, "auto") != 0)
            return ffd_rig_expected(p, "box", "\"auto\" or an object {\"origin\": [x,y,z], \"axes\": "
                                      "[[..],[..],[..]]}");
        rig->box_auto = 1;
        return FFD_OK;
    }
    if (!cJSON_IsObject(item))
        return ffd_rig_expected(p, "box",
                        "\"auto\" or an object {\"origin\": [x,y,z], \"axes\": [[..],[..],[..]]}");
    static const char *const keys[] = {"origin", "axes", NULL};
    ffd_status s = ffd_rig_check_keys(p, item, "box", keys, "\"origin\", \"axes\"");
    if (s)
        return s;
    const cJSON *origin = cJSON_GetObjectItemCaseSensitive(item, "origin");
    const cJSON *axes = cJSON_GetObjectItemCaseSensitive(item, "axes");
    if (!origin)
        return ffd_rig_expected(p, "box.origin", "an array of 3 finite numbers (missing)");
    if (!axes)
        return ffd_rig_expected(p, "box.axes", "an array of 3 axes (missing)");
    if ((s = ffd_rig_read_vec3(p, origin, "box.origin", rig->box.origin)))
        return s;
    if (!cJSON_IsArray(axes) || cJSON_GetArraySize(axes) != 3)
        return ffd_rig_expected(p, "box.axes", "an array of 3 axes, each an array of 3 finite numbers");
    int i = 0;
    const cJSON *axis;
    cJSON_ArrayForEach(axis, axes)
    {
        char path[RIG_PATH_MAX];
        snprintf(path, sizeof path, "box.axes[%d]", i);
        if ((s = ffd_rig_read_vec3(p, axis, path, rig->box.axes[i])))
            return s;
        i++;
    }
    rig->box_auto = 0;
    return FFD_OK;
}

ffd_status ffd_rig_read_lattice_move(const ffd_rig_parser *p, const cJSON *m, const char *path,
                                     void *element, void *ctx)
{
    static const char *const keys[] = {"index", "delta", NULL};
    ffd_rig_move *move = element;
    char sub[RIG_PATH_MAX + 80];
    (void)ctx;
    if (!cJSON_IsObject(m))
        return ffd_rig_expected(p, path, "an object {\"index\": [i,j,k], \"delta\": [dx,dy,dz]}");
    ffd_status s = ffd_rig_check_keys(p, m, path, keys, "\"index\", \"delta\"");
    if (s)
        return s;
    const cJSON *index = cJSON_GetObjectItemCaseSensitive(m, "index");
    const cJSON *delta = cJSON_GetObjectItemCaseSensitive(m, "delta");
    snprintf(sub, sizeof sub, "%s.index", path);
    if (!index)
        return ffd_rig_expected(p, sub, "an array of 3 non-negative integers (missing)");
    if ((s = ffd_rig_read_uint3(p, index, sub, move->index)))
        return s;
    snprintf(sub, sizeof sub, "%s.delta", path);
    if (!delta)
        return ffd_rig_expected(p, sub, "an array of 3 finite numbers (missing)");
    return ffd_rig_read_vec3(p, delta, sub, move->delta);
}

static ffd_status read_moves(const ffd_rig_parser *p, const cJSON *item, ffd_rig *rig)
{
    void *moves;
    ffd_status s = ffd_rig_read_array(p, item, "moves",
                                      "an array of {\"index\": [i,j,k], \"delta\": [dx,dy,dz]}",
                                      sizeof *rig->moves, ffd_rig_read_lattice_move, NULL, NULL, &moves,
                                      &rig->move_count);
    rig->moves = moves;
    return s;
}

/* Checks that need several keys: resolution bounds for the basis, move indices. */
static ffd_status validate(const ffd_rig_parser *p, const ffd_rig *rig)
{
    static const char *const basis_names[] = {"bspline", "bernstein"};
    uint32_t lo = ffd_basis_min_resolution(rig->basis);
    for (int a = 0; a < 3; a++) {
        uint32_t r = rig->resolution[a];
        if (r < lo)
            return ffd_fail(p->err, FFD_ERR_INVALID,
                            "%s: resolution[%d]: %u is below the minimum %u control points of "
                            "the %s basis",
                            p->name, a, r, lo, basis_names[rig->basis]);
        if (r > RIG_MAX_RESOLUTION)
            return ffd_fail(p->err, FFD_ERR_INVALID,
                            "%s: resolution[%d]: %u is above the maximum %u control points",
                            p->name, a, r, RIG_MAX_RESOLUTION);
    }
    for (size_t i = 0; i < rig->move_count; i++) {
        const uint32_t *ix = rig->moves[i].index;
        for (int a = 0; a < 3; a++)
            if (ix[a] >= rig->resolution[a])
                return ffd_fail(p->err, FFD_ERR_RANGE,
                                "%s: moves[%zu].index: [%u, %u, %u] out of range for a "
                                "%u x %u x %u lattice (indices start at 0)",
                                p->name, i, ix[0], ix[1], ix[2], rig->resolution[0],
                                rig->resolution[1], rig->resolution[2]);
    }
    return FFD_OK;
}


const char *const ffd_rig_keys_lattice[] = {"basis", "resolution", "box", "margin", "outside", "moves",
                                            "falloff", "falloff_curve", "children", NULL};

static const char *const falloff_curves[] = {"smooth", "linear", "sphere", "sharp", NULL};

const ffd_rig_lattice *ffd_rig_lattice_of(const ffd_rig *rig)
{
    static const ffd_rig_lattice defaults = {0};
    return rig->section && rig->method == &ffd_method_lattice ? rig->section : &defaults;
}

/* "outside": "falloff" with "falloff": D and "falloff_curve" (lattice_falloff.c). */
static ffd_status read_falloff(const ffd_rig_parser *p, const cJSON *root, const ffd_rig *rig,
                               ffd_rig_lattice *section)
{
    const cJSON *distance = cJSON_GetObjectItemCaseSensitive(root, "falloff");
    const cJSON *curve = cJSON_GetObjectItemCaseSensitive(root, "falloff_curve");
    ffd_status s;
    if (rig->outside != FFD_OUTSIDE_FALLOFF) {
        if (distance || curve)
            return ffd_rig_expected(p, distance ? "falloff" : "falloff_curve",
                                    "no such key unless \"outside\" is \"falloff\"");
        return FFD_OK;
    }
    if (!distance)
        return ffd_rig_expected(p, "falloff", "a distance > 0 in world units (missing: \"outside\" "
                                              "is \"falloff\")");
    if ((s = ffd_rig_read_positive(p, distance, "falloff", &section->falloff)))
        return s;
    int c = 0;
    if (curve && (s = ffd_rig_read_enum(p, curve, "falloff_curve", falloff_curves,
                                        "\"smooth\", \"linear\", \"sphere\" or \"sharp\"", &c)))
        return s;
    section->falloff_curve = (ffd_falloff_curve)c;
    return FFD_OK;
}

ffd_status ffd_lattice_bind_rig(const ffd_lattice *lattice, const double *points, size_t n,
                                const ffd_rig *rig, ffd_lattice_binding **out, ffd_error *err)
{
    const ffd_rig_lattice *section = ffd_rig_lattice_of(rig);
    if (rig->outside == FFD_OUTSIDE_FALLOFF)
        return ffd_lattice_bind_falloff(lattice, points, n, section->falloff,
                                        section->falloff_curve, out, err);
    return ffd_lattice_bind(lattice, points, n, rig->outside, out, err);
}

ffd_status ffd_rig_parse_lattice(const ffd_rig_parser *p, const cJSON *root, ffd_rig *rig)
{
    static const char *const bases[] = {"bspline", "bernstein", NULL};
    static const char *const outsides[] = {"fixed", "clamp", "extrapolate", "falloff", NULL};
    ffd_rig_lattice *section = rig->section;
    const cJSON *item;
    ffd_status s = ffd_rig_read_linear_root(p, root, rig);
    if (s)
        return s;
    if ((item = cJSON_GetObjectItemCaseSensitive(root, "basis"))) {
        int b = 0;
        if ((s = ffd_rig_read_enum(p, item, "basis", bases, "\"bspline\" or \"bernstein\"", &b)))
            return s;
        rig->basis = b ? FFD_BASIS_BERNSTEIN : FFD_BASIS_BSPLINE;
    }
    if ((item = cJSON_GetObjectItemCaseSensitive(root, "resolution"))) {
        if ((s = ffd_rig_read_uint3(p, item, "resolution", rig->resolution)))
            return s;
    }
    if ((item = cJSON_GetObjectItemCaseSensitive(root, "box"))) {
        if ((s = read_box(p, item, rig)))
            return s;
    }
    if ((item = cJSON_GetObjectItemCaseSensitive(root, "margin"))) {
        if ((s = ffd_rig_read_number(p, item, "margin", &rig->margin)))
            return s;
        if (rig->margin < 0)
            return ffd_rig_expected(p, "margin", "a number >= 0");
    }
    if ((item = cJSON_GetObjectItemCaseSensitive(root, "outside"))) {
        int o = 0;
        if ((s = ffd_rig_read_enum(p, item, "outside", outsides,
                           "\"fixed\", \"clamp\", \"extrapolate\" or \"falloff\"", &o)))
            return s;
        rig->outside = (ffd_outside)o; /* the names in ffd_outside's order */
    }
    if ((s = read_falloff(p, root, rig, section)))
        return s;
    if ((item = cJSON_GetObjectItemCaseSensitive(root, "moves"))) {
        if ((s = read_moves(p, item, rig)))
            return s;
    }
    if ((s = validate(p, rig)))
        return s;
    if ((item = cJSON_GetObjectItemCaseSensitive(root, "children"))) {
        if (rig->limit_step)
            return ffd_rig_expected(p, "limit_step", "false with \"children\" (step limiting "
                                                     "checks one lattice)");
        return ffd_rig_parse_lattice_children(p, item, rig, section);
    }
    return FFD_OK;
}

/* The writer (ffd_method.write): the lattice keys as the reader above reads
 * them. */
int ffd_rig_write_lattice(const ffd_rig *rig, cJSON *root)
{
    static const char *const bases[] = {"bspline", "bernstein"};
    static const char *const outsides[] = {"fixed", "clamp", "extrapolate", "falloff"};
    const ffd_rig_lattice *section = ffd_rig_lattice_of(rig);
    cJSON *box = NULL, *moves = NULL;
    int ok = rig->box_auto ? ffd_sess_add_item(root, "margin", ffd_sess_number(rig->margin))
                           : (box = cJSON_AddObjectToObject(root, "box")) &&
                                 ffd_sess_add_item(box, "origin", ffd_sess_vec3(rig->box.origin)) &&
                                 ffd_sess_add_item(box, "axes", ffd_sess_matrix3(
                                                                    (const double(*)[3])rig->box.axes));
    ok = ok && (moves = cJSON_AddArrayToObject(root, "moves")) &&
         cJSON_AddStringToObject(root, "basis", bases[rig->basis == FFD_BASIS_BERNSTEIN]) &&
         ffd_sess_add_item(root, "resolution", ffd_sess_uint_array(rig->resolution, 3)) &&
         cJSON_AddStringToObject(root, "outside", outsides[rig->outside]);
    for (size_t i = 0; ok && i < rig->move_count; i++) {
        cJSON *move = cJSON_CreateObject();
        ok = ffd_sess_add_to_array(moves, move) &&
             ffd_sess_add_item(move, "index", ffd_sess_uint_array(rig->moves[i].index, 3)) &&
             ffd_sess_add_item(move, "delta", ffd_sess_vec3(rig->moves[i].delta));
    }
    if (ok && rig->outside == FFD_OUTSIDE_FALLOFF)
        ok = ffd_sess_add_item(root, "falloff", ffd_sess_number(section->falloff)) &&
             cJSON_AddStringToObject(root, "falloff_curve", falloff_curves[section->falloff_curve]);
    if (ok && section->child_count)
        ok = ffd_rig_write_lattice_children(section->children, section->child_count, root);
    return ok;
}

void ffd_rig_release_lattice(ffd_rig *rig)
{
    ffd_free(rig->moves);
    ffd_rig_lattice *section = rig->section;
    if (section)
        ffd_rig_release_lattice_children(section->children, section->child_count);
}
