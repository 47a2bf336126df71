/* rig_json_lattice — "deformer": "lattice" rigs (docs/rig.md, "Lattice
 * rigs"; also rigs without "deformer"): a Sederberg-Parry / B-spline lattice
 * (basis, resolution, box), control-point moves, and the constraints of
 * direct manipulation (Hsu et al. 1992). The lattice's section reader in the
 * method registry (ffd_method_lattice.parse). */
#include "lattice/lattice.h"
#include "lattice/lattice_method.h"
#include "rig/rig_json.h"

#include <math.h>
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

/* ---- lattice variants (docs/lattice-variants.md): "basis" per axis,
 * "tension", "continuity", "coordinates", "frame" ---- */

#define TWO_PI 6.283185307179586476925286766559

static const char *const interp_names[] = {"default", "linear", "cardinal", "catmull-rom",
                                           "bspline", "bernstein", NULL};
#define INTERP_TEXT "\"linear\", \"cardinal\", \"catmull-rom\", \"bspline\" or \"bernstein\""

/* "basis": a string for every axis, or an array of three. */
static ffd_status read_basis(const ffd_rig_parser *p, const cJSON *item, ffd_rig *rig)
{
    ffd_status s;
    int it = 0;
    if (!cJSON_IsArray(item)) {
        if ((s = ffd_rig_read_enum(p, item, "basis", interp_names + 1,
                                   INTERP_TEXT " (or an array of three)", &it)))
            return s;
        it += 1;
        if (it == FFD_INTERP_BSPLINE || it == FFD_INTERP_BERNSTEIN) {
            rig->basis = it == FFD_INTERP_BERNSTEIN ? FFD_BASIS_BERNSTEIN : FFD_BASIS_BSPLINE;
            return FFD_OK; /* the fast path's lattice, as before */
        }
        for (int a = 0; a < 3; a++)
            rig->shape.interp[a] = (ffd_interp)it;
        return FFD_OK;
    }
    if (cJSON_GetArraySize(item) != 3)
        return ffd_rig_expected(p, "basis", "a string or an array of 3 of " INTERP_TEXT);
    int a = 0;
    const cJSON *e;
    cJSON_ArrayForEach(e, item)
    {
        char path[32];
        snprintf(path, sizeof path, "basis[%d]", a);
        if ((s = ffd_rig_read_enum(p, e, path, interp_names + 1, INTERP_TEXT, &it)))
            return s;
        rig->shape.interp[a++] = (ffd_interp)(it + 1);
    }
    return FFD_OK;
}

/* "tension" / "continuity": a number for every axis or an array of three. */
static ffd_status read_per_axis(const ffd_rig_parser *p, const cJSON *item, const char *key,
                                double out[3])
{
    if (cJSON_IsArray(item))
        return ffd_rig_read_vec3(p, item, key, out);
    ffd_status s = ffd_rig_read_number(p, item, key, &out[0]);
    out[1] = out[2] = out[0];
    return s;
}

static ffd_status read_range(const ffd_rig_parser *p, const cJSON *obj, const char *key,
                             double out[2])
{
    char path[32];
    snprintf(path, sizeof path, "frame.%s", key);
    const cJSON *r = cJSON_GetObjectItemCaseSensitive(obj, key);
    if (!r)
        return ffd_rig_expected(p, path, "an array [lo, hi] of 2 finite numbers (missing)");
    if (!cJSON_IsArray(r) || cJSON_GetArraySize(r) != 2 || !cJSON_IsNumber(r->child) ||
        !cJSON_IsNumber(r->child->next) || !isfinite(r->child->valuedouble) ||
        !isfinite(r->child->next->valuedouble))
        return ffd_rig_expected(p, path, "an array [lo, hi] of 2 finite numbers");
    out[0] = r->child->valuedouble;
    out[1] = r->child->next->valuedouble;
    if (!(out[1] > out[0]))
        return ffd_rig_expected(p, path, "an array [lo, hi] with lo < hi");
    return FFD_OK;
}

/* "frame": "auto" or {"centre", "axis", "reference", "r", "theta", "z" | "phi"}. */
static ffd_status read_frame(const ffd_rig_parser *p, const cJSON *item, ffd_rig *rig)
{
    const int sph = rig->shape.coordinates == FFD_COORDINATES_SPHERICAL;
    const char *what = sph ? "\"auto\" or an object {\"centre\", \"axis\", \"reference\", \"r\", "
                             "\"theta\", \"phi\"}"
                           : "\"auto\" or an object {\"centre\", \"axis\", \"reference\", \"r\", "
                             "\"theta\", \"z\"}";
    if (cJSON_IsString(item) && strcmp(item->valuestring, "auto") == 0) {
        rig->frame_auto = 1;
        return FFD_OK;
    }
    if (!cJSON_IsObject(item))
        return ffd_rig_expected(p, "frame", what);
    static const char *const cyl_keys[] = {"centre", "axis", "reference", "r", "theta", "z", NULL};
    static const char *const sph_keys[] = {"centre", "axis", "reference", "r", "theta", "phi", NULL};
    ffd_status s = ffd_rig_check_keys(p, item, "frame", sph ? sph_keys : cyl_keys,
                                      sph ? "\"centre\", \"axis\", \"reference\", \"r\", \"theta\", "
                                            "\"phi\""
                                          : "\"centre\", \"axis\", \"reference\", \"r\", \"theta\", "
                                            "\"z\"");
    if (s)
        return s;
    ffd_lattice_frame *f = &rig->shape.frame;
    static const char *const vecs[] = {"centre", "axis", "reference"};
    double *dst[] = {f->centre, f->axis, f->reference};
    for (int v = 0; v < 3; v++) {
        char path[32];
        snprintf(path, sizeof path, "frame.%s", vecs[v]);
        const cJSON *e = cJSON_GetObjectItemCaseSensitive(item, vecs[v]);
        if (!e)
            return ffd_rig_expected(p, path, "an array of 3 finite numbers (missing)");
        if ((s = ffd_rig_read_vec3(p, e, path, dst[v])))
            return s;
    }
    if ((s = read_range(p, item, "r", f->range[0])) || (s = read_range(p, item, "theta", f->range[1])) ||
        (s = read_range(p, item, sph ? "phi" : "z", f->range[2])))
        return s;
    if (f->range[0][0] < 0)
        return ffd_rig_expected(p, "frame.r", "[r0, r1] with 0 <= r0 < r1");
    if (f->range[1][1] - f->range[1][0] > TWO_PI * (1 + 1e-12))
        return ffd_rig_expected(p, "frame.theta", "[t0, t1] with t0 < t1 <= t0 + 2 pi");
    if (sph && (f->range[2][0] < 0 || f->range[2][1] > 3.14159265358979323846 * (1 + 1e-15)))
        return ffd_rig_expected(p, "frame.phi", "[p0, p1] with 0 <= p0 < p1 <= pi");
    rig->frame_auto = 0;
    return FFD_OK;
}

/* The variant keys of one rig, read after "basis" and "resolution". */
static ffd_status read_shape(const ffd_rig_parser *p, const cJSON *root, ffd_rig *rig)
{
    static const char *const coordinate_names[] = {"cartesian", "cylindrical", "spherical", NULL};
    const cJSON *item;
    ffd_status s;
    int c = 0;
    if ((item = cJSON_GetObjectItemCaseSensitive(root, "coordinates")) &&
        (s = ffd_rig_read_enum(p, item, "coordinates", coordinate_names,
                               "\"cartesian\", \"cylindrical\" or \"spherical\"", &c)))
        return s;
    rig->shape.coordinates = (ffd_coordinates)c;
    const cJSON *frame = cJSON_GetObjectItemCaseSensitive(root, "frame");
    if (c == FFD_COORDINATES_CARTESIAN && frame)
        return ffd_rig_expected(p, "frame", "no frame for a cartesian lattice (it has a \"box\"; "
                                            "\"coordinates\": \"cylindrical\" or \"spherical\" "
                                            "take a frame)");
    if (c != FFD_COORDINATES_CARTESIAN) {
        if (cJSON_GetObjectItemCaseSensitive(root, "box"))
            return ffd_rig_expected(p, "box", "no box for a cylindrical or spherical lattice (it "
                                              "has a \"frame\")");
        rig->frame_auto = 1;
        if (frame && (s = read_frame(p, frame, rig)))
            return s;
    }
    int cardinal = 0;
    for (int a = 0; a < 3; a++)
        cardinal |= rig->shape.interp[a] == FFD_INTERP_CARDINAL;
    static const char *const keys[] = {"tension", "continuity"};
    double *dst[] = {rig->shape.tension, rig->shape.continuity};
    for (int k = 0; k < 2; k++) {
        if (!(item = cJSON_GetObjectItemCaseSensitive(root, keys[k])))
            continue;
        if (!cardinal)
            return ffd_rig_expected(p, keys[k], "no tension or continuity without an axis of "
                                                "\"cardinal\" interpolation (catmull-rom is "
                                                "cardinal with tension 0)");
        if ((s = read_per_axis(p, item, keys[k], dst[k])))
            return s;
        for (int a = 0; a < 3; a++) {
            double v = dst[k][a];
            if (rig->shape.interp[a] != FFD_INTERP_CARDINAL)
                dst[k][a] = 0; /* not used by this axis */
            else if (k == 0 ? !(v >= -1 && v < 1) : !(v >= -1 && v <= 1))
                return ffd_fail(p->err, FFD_ERR_INVALID,
                                "%s: %s: %g on axis %d is outside %s (the cardinal rest map is "
                                "a monotone cubic, invertible, for tension in [-1, 1); "
                                "continuity in [-1, 1])",
                                p->name, keys[k], v, a, k == 0 ? "[-1, 1)" : "[-1, 1]");
        }
    }
    /* Bernstein cannot close a full turn of theta */
    ffd_interp theta = rig->shape.interp[1];
    if (c != FFD_COORDINATES_CARTESIAN &&
        (theta == FFD_INTERP_BERNSTEIN ||
         (theta == FFD_INTERP_DEFAULT && rig->basis == FFD_BASIS_BERNSTEIN)) &&
        (rig->frame_auto ||
         rig->shape.frame.range[1][1] - rig->shape.frame.range[1][0] >= TWO_PI * (1 - 1e-12)))
        return ffd_fail(p->err, FFD_ERR_INVALID,
                        "%s: basis[1]: bernstein cannot be periodic (theta spans 2 pi); use "
                        "linear, cardinal, catmull-rom or bspline on the theta axis",
                        p->name);
    return FFD_OK;
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
                                            "tension", "continuity", "coordinates", "frame",
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
    static const char *const outsides[] = {"fixed", "clamp", "extrapolate", "falloff", NULL};
    ffd_rig_lattice *section = rig->section;
    const cJSON *item;
    ffd_status s = ffd_rig_read_linear_root(p, root, rig);
    if (s)
        return s;
    if ((item = cJSON_GetObjectItemCaseSensitive(root, "basis")) && (s = read_basis(p, item, rig)))
        return s;
    if ((s = read_shape(p, root, rig)))
        return s;
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
    /* the falloff and nested lattices are built on the box lattices' path */
    const int general = ffd_lattice_shape_is_general(rig->basis, &rig->shape);
    if (general && rig->outside == FFD_OUTSIDE_FALLOFF)
        return ffd_rig_expected(p, "outside", "\"fixed\", \"clamp\" or \"extrapolate\" on a "
                                              "cylindrical, spherical or mixed-interpolation "
                                              "lattice (\"falloff\" needs a box lattice with one "
                                              "B-spline or Bernstein basis)");
    if ((item = cJSON_GetObjectItemCaseSensitive(root, "children"))) {
        if (general)
            return ffd_rig_expected(p, "children", "a box lattice with one B-spline or Bernstein "
                                                   "basis as the parent (not a cylindrical, "
                                                   "spherical or mixed-interpolation lattice)");
        if (rig->limit_step)
            return ffd_rig_expected(p, "limit_step", "false with \"children\" (step limiting "
                                                     "checks one lattice)");
        return ffd_rig_parse_lattice_children(p, item, rig, section);
    }
    return FFD_OK;
}

/* The variant keys as read_shape reads them; nothing for the plain lattice. */
static int write_shape(const ffd_rig *rig, cJSON *root)
{
    const ffd_lattice_shape *sh = &rig->shape;
    int per_axis = 0, cardinal = 0;
    for (int a = 0; a < 3; a++) {
        per_axis |= sh->interp[a] != FFD_INTERP_DEFAULT;
        cardinal |= sh->interp[a] == FFD_INTERP_CARDINAL;
    }
    int ok = 1;
    if (per_axis) {
        cJSON *b = cJSON_CreateArray();
        ok = ffd_sess_add_item(root, "basis", b);
        for (int a = 0; ok && a < 3; a++) {
            ffd_interp it = sh->interp[a];
            if (it == FFD_INTERP_DEFAULT)
                it = rig->basis == FFD_BASIS_BERNSTEIN ? FFD_INTERP_BERNSTEIN : FFD_INTERP_BSPLINE;
            ok = ffd_sess_add_to_array(b, cJSON_CreateString(interp_names[it]));
        }
    }
    if (ok && cardinal)
        ok = ffd_sess_add_item(root, "tension", ffd_sess_vec3(sh->tension)) &&
             ffd_sess_add_item(root, "continuity", ffd_sess_vec3(sh->continuity));
    if (!ok || sh->coordinates == FFD_COORDINATES_CARTESIAN)
        return ok;
    const int sph = sh->coordinates == FFD_COORDINATES_SPHERICAL;
    ok = cJSON_AddStringToObject(root, "coordinates", sph ? "spherical" : "cylindrical") != NULL;
    if (!ok || rig->frame_auto)
        return ok && cJSON_AddStringToObject(root, "frame", "auto");
    cJSON *f = cJSON_AddObjectToObject(root, "frame");
    static const char *const ranges[2][3] = {{"r", "theta", "z"}, {"r", "theta", "phi"}};
    ok = f && ffd_sess_add_item(f, "centre", ffd_sess_vec3(sh->frame.centre)) &&
         ffd_sess_add_item(f, "axis", ffd_sess_vec3(sh->frame.axis)) &&
         ffd_sess_add_item(f, "reference", ffd_sess_vec3(sh->frame.reference));
    for (int a = 0; ok && a < 3; a++) {
        cJSON *r = cJSON_CreateArray();
        ok = ffd_sess_add_item(f, ranges[sph][a], r) &&
             ffd_sess_add_to_array(r, ffd_sess_number(sh->frame.range[a][0])) &&
             ffd_sess_add_to_array(r, ffd_sess_number(sh->frame.range[a][1]));
    }
    return ok;
}

/* The writer (ffd_method.write): the lattice keys as the reader above reads
 * them. */
int ffd_rig_write_lattice(const ffd_rig *rig, cJSON *root)
{
    static const char *const bases[] = {"bspline", "bernstein"};
    static const char *const outsides[] = {"fixed", "clamp", "extrapolate", "falloff"};
    const ffd_rig_lattice *section = ffd_rig_lattice_of(rig);
    cJSON *box = NULL, *moves = NULL;
    const int framed = rig->shape.coordinates != FFD_COORDINATES_CARTESIAN;
    int ok = rig->box_auto || (framed && rig->frame_auto)
                 ? ffd_sess_add_item(root, "margin", ffd_sess_number(rig->margin))
             : framed ? 1
                      : (box = cJSON_AddObjectToObject(root, "box")) &&
                                 ffd_sess_add_item(box, "origin", ffd_sess_vec3(rig->box.origin)) &&
                                 ffd_sess_add_item(box, "axes", ffd_sess_matrix3(
                                                                    (const double(*)[3])rig->box.axes));
    int per_axis = 0;
    for (int a = 0; a < 3; a++)
        per_axis |= rig->shape.interp[a] != FFD_INTERP_DEFAULT;
    ok = ok && (moves = cJSON_AddArrayToObject(root, "moves")) && write_shape(rig, root) &&
         (per_axis ||
          cJSON_AddStringToObject(root, "basis", bases[rig->basis == FFD_BASIS_BERNSTEIN])) &&
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
