/* rig_json_pbffd — "deformer": "pbffd" rigs (docs/rig.md, "PB-FFD rigs";
 * docs/pbffd.md): point-based FFD (Jin et al.) with ellipsoidal basis
 * functions as controls — placed ("auto" or placement options) or given —
 * the kernel's sigma, the master control, hierarchy levels, moves and frame
 * edits of controls, curve handles, and the constraints of direct
 * manipulation. The PB-FFD section reader in the method registry
 * (ffd_method_pbffd.parse), and its writer for an explicit control set (the
 * output of `ffd pbffd place`: one control per line, numbers with 17
 * significant digits, so that they read back exactly). */
#include "pbffd/pbffd_method.h"
#include "rig/rig_json.h"

#include <math.h>
#include <stdio.h>
#include <string.h>


/* Three vectors [[..],[..],[..]]. */
static ffd_status read_frame(const ffd_rig_parser *p, const cJSON *item, const char *path,
                             double frame[3][3])
{
    if (!cJSON_IsArray(item) || cJSON_GetArraySize(item) != 3)
        return ffd_rig_expected(p, path, "an array of 3 axes, each an array of 3 finite numbers");
    int i = 0;
    const cJSON *axis;
    cJSON_ArrayForEach(axis, item)
    {
        char sub[RIG_PATH_MAX + 8];
        snprintf(sub, sizeof sub, "%s[%d]", path, i);
        ffd_status s = ffd_rig_read_vec3(p, axis, sub, frame[i]);
        if (s)
            return s;
        i++;
    }
    return FFD_OK;
}

static ffd_status read_placement(const ffd_rig_parser *p, const cJSON *item, ffd_rig_pbffd *pb)
{
    static const char *const keys[] = {"interior", "exterior", "offset", "radius_factor",
                                       "surface",  "voronoi_sites", "cover", NULL};
    static const char *const surfaces[] = {"auto", "closed", "open", NULL};
    ffd_status s = ffd_rig_check_keys(p, item, "controls", keys,
                              "\"interior\", \"exterior\", \"offset\", \"radius_factor\", "
                              "\"surface\", \"voronoi_sites\", \"cover\"");
    if (s)
        return s;
    ffd_placement_options *o = &pb->placement;
    const cJSON *v;
    uint32_t count = 0;
    if ((v = cJSON_GetObjectItemCaseSensitive(item, "interior"))) {
        if ((s = ffd_rig_read_index(p, v, "controls.interior", "a positive integer", &count)))
            return s;
        if (count == 0)
            return ffd_rig_expected(p, "controls.interior", "a positive integer");
        o->interior_count = count;
    }
    if ((v = cJSON_GetObjectItemCaseSensitive(item, "exterior"))) {
        if ((s = ffd_rig_read_index(p, v, "controls.exterior", "a positive integer", &count)))
            return s;
        if (count == 0)
            return ffd_rig_expected(p, "controls.exterior", "a positive integer");
        o->exterior_count = count;
    }
    if ((v = cJSON_GetObjectItemCaseSensitive(item, "offset"))) {
        if ((s = ffd_rig_read_positive(p, v, "controls.offset", &o->offset)))
            return s;
        if (o->offset > 1)
            return ffd_fail(p->err, FFD_ERR_INVALID,
                            "%s: controls.offset: %g: expected a fraction of the bounding-box "
                            "diagonal in (0, 1]",
                            p->name, o->offset);
    }
    if ((v = cJSON_GetObjectItemCaseSensitive(item, "radius_factor"))) {
        if ((s = ffd_rig_read_positive(p, v, "controls.radius_factor", &o->radius_factor)))
            return s;
        if (o->radius_factor > 100)
            return ffd_fail(p->err, FFD_ERR_INVALID,
                            "%s: controls.radius_factor: %g: expected a number in (0, 100]",
                            p->name, o->radius_factor);
    }
    if ((v = cJSON_GetObjectItemCaseSensitive(item, "surface"))) {
        int k = 0;
        if ((s = ffd_rig_read_enum(p, v, "controls.surface", surfaces,
                           "\"auto\", \"closed\" or \"open\"", &k)))
            return s;
        o->surface = k == 0 ? FFD_SURFACE_AUTO : k == 1 ? FFD_SURFACE_CLOSED : FFD_SURFACE_OPEN;
    }
    if ((v = cJSON_GetObjectItemCaseSensitive(item, "voronoi_sites"))) {
        if ((s = ffd_rig_read_index(p, v, "controls.voronoi_sites", "a positive integer", &count)))
            return s;
        if (count < 5)
            return ffd_fail(p->err, FFD_ERR_INVALID,
                            "%s: controls.voronoi_sites: %u: expected at least 5", p->name, count);
        o->voronoi_sites = count;
    }
    if ((v = cJSON_GetObjectItemCaseSensitive(item, "cover"))) {
        if (!cJSON_IsBool(v))
            return ffd_rig_expected(p, "controls.cover", "true or false");
        o->no_cover = cJSON_IsFalse(v);
    }
    pb->controls_auto = 1;
    return FFD_OK;
}

static ffd_status read_control(const ffd_rig_parser *p, const cJSON *c, const char *path,
                               void *element, void *ctx)
{
    ffd_ebf *ebf = element;
    (void)ctx;
    static const char *const keys[] = {"center", "radius", "frame", "enabled", NULL};
    char sub[RIG_PATH_MAX + 16];
    if (!cJSON_IsObject(c))
        return ffd_rig_expected(p, path, "an object {\"center\": [x,y,z], \"radius\": r}");
    ffd_status s = ffd_rig_check_keys(p, c, path, keys,
                              "\"center\", \"radius\", \"frame\", \"enabled\"");
    if (s)
        return s;
    const cJSON *center = cJSON_GetObjectItemCaseSensitive(c, "center");
    const cJSON *radius = cJSON_GetObjectItemCaseSensitive(c, "radius");
    const cJSON *frame = cJSON_GetObjectItemCaseSensitive(c, "frame");
    const cJSON *enabled = cJSON_GetObjectItemCaseSensitive(c, "enabled");
    snprintf(sub, sizeof sub, "%s.center", path);
    if (!center)
        return ffd_rig_expected(p, sub, "an array of 3 finite numbers (missing)");
    if ((s = ffd_rig_read_vec3(p, center, sub, ebf->center)))
        return s;
    snprintf(sub, sizeof sub, "%s.radius", path);
    if (!radius)
        return ffd_rig_expected(p, sub, "a number > 0 or an array of 3 (missing)");
    if (cJSON_IsArray(radius)) {
        if ((s = ffd_rig_read_vec3(p, radius, sub, ebf->radius)))
            return s;
    } else {
        if ((s = ffd_rig_read_number(p, radius, sub, &ebf->radius[0])))
            return s;
        ebf->radius[1] = ebf->radius[2] = ebf->radius[0];
    }
    for (int a = 0; a < 3; a++)
        if (!(ebf->radius[a] > 0))
            return ffd_fail(p->err, FFD_ERR_INVALID, "%s: %s: %g: expected a radius > 0",
                            p->name, sub, ebf->radius[a]);
    if (frame) {
        snprintf(sub, sizeof sub, "%s.frame", path);
        if ((s = read_frame(p, frame, sub, ebf->frame)))
            return s;
    } else {
        /* axis-aligned, lengths = the ROI semi-axes (§3.2.1: frame lengths = radius) */
        memset(ebf->frame, 0, sizeof ebf->frame);
        for (int a = 0; a < 3; a++)
            ebf->frame[a][a] = ebf->radius[a];
    }
    if (enabled) {
        snprintf(sub, sizeof sub, "%s.enabled", path);
        if (!cJSON_IsBool(enabled))
            return ffd_rig_expected(p, sub, "true or false");
        ebf->disabled = cJSON_IsFalse(enabled);
    }
    return FFD_OK;
}

static ffd_status read_controls(const ffd_rig_parser *p, const cJSON *item, ffd_rig_pbffd *pb)
{
    static const char what[] =
        "\"auto\", an object of placement options, or an array of "
        "{\"center\": [x,y,z], \"radius\": r, \"frame\": [[..],[..],[..]]}";
    if (cJSON_IsString(item)) {
        if (strcmp(item->valuestring, "auto") != 0)
            return ffd_rig_expected(p, "controls", what);
        pb->controls_auto = 1;
        return FFD_OK;
    }
    if (cJSON_IsObject(item))
        return read_placement(p, item, pb);
    if (!cJSON_IsArray(item))
        return ffd_rig_expected(p, "controls", what);
    if (cJSON_GetArraySize(item) == 0)
        return ffd_rig_expected(p, "controls", "at least one control point (or \"auto\")");
    void *controls;
    ffd_status s = ffd_rig_read_array(p, item, "controls", what, sizeof *pb->controls,
                                      read_control, NULL, NULL, &controls, &pb->control_count);
    pb->controls = controls;
    if (s)
        return s;
    pb->controls_auto = 0;
    return FFD_OK;
}

static ffd_status read_master(const ffd_rig_parser *p, const cJSON *item, ffd_pbffd_options *o)
{
    if (cJSON_IsBool(item)) {
        o->no_master = cJSON_IsFalse(item);
        return FFD_OK;
    }
    if (!cJSON_IsObject(item))
        return ffd_rig_expected(p, "master", "true, false or {\"radius\": r, \"weight\": w}");
    static const char *const keys[] = {"radius", "weight", NULL};
    ffd_status s = ffd_rig_check_keys(p, item, "master", keys, "\"radius\", \"weight\"");
    if (s)
        return s;
    const cJSON *v;
    if ((v = cJSON_GetObjectItemCaseSensitive(item, "radius"))) {
        if ((s = ffd_rig_read_number(p, v, "master.radius", &o->master_radius)))
            return s;
        if (o->master_radius < 1)
            return ffd_fail(p->err, FFD_ERR_INVALID,
                            "%s: master.radius: %g: expected a number >= 1 (a multiple of the "
                            "bounding sphere's radius)",
                            p->name, o->master_radius);
    }
    if ((v = cJSON_GetObjectItemCaseSensitive(item, "weight")) &&
        (s = ffd_rig_read_positive(p, v, "master.weight", &o->master_weight)))
        return s;
    return FFD_OK;
}

static const char pb_move_what[] = "an array of {\"control\": i, \"level\": l, \"delta\": "
                                   "[dx,dy,dz]}";
static const char pb_frame_what[] = "an array of {\"control\": i, \"level\": l, \"frame\": "
                                    "[[..],[..],[..]]} or {\"control\": i, \"rotate\": "
                                    "{\"axis\": [x,y,z], \"angle\": a}, \"scale\": [sx,sy,sz]}";

/* One entry of "moves" ({"control", "level", "delta"}) or, when *(int *)ctx,
 * of "frames" ({"control", "level", "frame"} or {"control", "level",
 * "rotate": {"axis", "angle"}, "scale"}); "near" for "control" in both. */
static ffd_status read_pb_edit(const ffd_rig_parser *p, const cJSON *m, const char *path,
                               void *element, void *ctx)
{
    static const char *const move_keys[] = {"control", "near", "level", "delta", NULL};
    static const char *const frame_keys[] = {"control", "near",   "level", "frame",
                                             "rotate",  "scale",  NULL};
    int frames = *(const int *)ctx;
    ffd_rig_pb_edit *e = element;
    char sub[RIG_PATH_MAX + 88];
    if (!cJSON_IsObject(m))
        return ffd_rig_expected(p, path, frames ? pb_frame_what + 12 : pb_move_what + 12);
    ffd_status s = frames ? ffd_rig_check_keys(p, m, path, frame_keys,
                                       "\"control\", \"near\", \"level\", \"frame\", "
                                       "\"rotate\", \"scale\"")
                          : ffd_rig_check_keys(p, m, path, move_keys,
                                       "\"control\", \"near\", \"level\", \"delta\"");
    if (s)
        return s;
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(m, "control");
    const cJSON *near = cJSON_GetObjectItemCaseSensitive(m, "near");
    if ((v != NULL) == (near != NULL))
        return ffd_rig_expected(p, path, v ? "either \"control\" or \"near\", not both"
                                           : "a \"control\" index or a \"near\" point");
    if (v) {
        snprintf(sub, sizeof sub, "%s.control", path);
        if ((s = ffd_rig_read_index(p, v, sub, "a control index (a non-negative integer)",
                                    &e->control)))
            return s;
    } else {
        snprintf(sub, sizeof sub, "%s.near", path);
        if ((s = ffd_rig_read_vec3(p, near, sub, e->near)))
            return s;
        e->by_near = 1;
    }
    if ((v = cJSON_GetObjectItemCaseSensitive(m, "level"))) {
        snprintf(sub, sizeof sub, "%s.level", path);
        if ((s = ffd_rig_read_index(p, v, sub, "a level (0 = finest)", &e->level)))
            return s;
    }
    if (!frames) {
        snprintf(sub, sizeof sub, "%s.delta", path);
        if (!(v = cJSON_GetObjectItemCaseSensitive(m, "delta")))
            return ffd_rig_expected(p, sub, "an array of 3 finite numbers (missing)");
        if ((s = ffd_rig_read_vec3(p, v, sub, e->delta)))
            return s;
        e->has_delta = 1;
        return FFD_OK;
    }
    const cJSON *frame = cJSON_GetObjectItemCaseSensitive(m, "frame");
    const cJSON *rotate = cJSON_GetObjectItemCaseSensitive(m, "rotate");
    const cJSON *scale = cJSON_GetObjectItemCaseSensitive(m, "scale");
    if (frame && (rotate || scale))
        return ffd_rig_expected(p, path, "either \"frame\" or \"rotate\"/\"scale\", not both");
    if (!frame && !rotate && !scale)
        return ffd_rig_expected(p, path, "a \"frame\", \"rotate\" or \"scale\" key");
    if (frame) {
        snprintf(sub, sizeof sub, "%s.frame", path);
        if ((s = read_frame(p, frame, sub, e->frame)))
            return s;
        e->frame_kind = 1;
        return FFD_OK;
    }
    e->frame_kind = 2;
    e->scale[0] = e->scale[1] = e->scale[2] = 1;
    e->axis[2] = 1;
    if (rotate) {
        snprintf(sub, sizeof sub, "%s.rotate", path);
        if ((s = ffd_rig_read_rotation(p, rotate, sub, e->axis, &e->angle, NULL, NULL)))
            return s;
    }
    if (scale) {
        snprintf(sub, sizeof sub, "%s.scale", path);
        if ((s = ffd_rig_read_vec3(p, scale, sub, e->scale)))
            return s;
        for (int a = 0; a < 3; a++)
            if (e->scale[a] == 0)
                return ffd_fail(p->err, FFD_ERR_INVALID,
                                "%s: %s[%d]: a zero scale flattens the frame", p->name, sub, a);
    }
    return FFD_OK;
}

static ffd_status read_pb_edits(const ffd_rig_parser *p, const cJSON *item, const char *key,
                                int frames, ffd_rig_pb_edit **out, size_t *count)
{
    void *edits;
    ffd_status s = ffd_rig_read_array(p, item, key, frames ? pb_frame_what : pb_move_what,
                                      sizeof **out, read_pb_edit, NULL, &frames, &edits, count);
    *out = edits;
    return s;
}

/* One entry of a curve's "moves": ctx is the curve's point count. */
static ffd_status read_curve_move(const ffd_rig_parser *p, const cJSON *m, const char *path,
                                  void *element, void *ctx)
{
    static const char *const keys[] = {"index", "delta", NULL};
    size_t n = *(const size_t *)ctx;
    ffd_rig_curve_move *move = element;
    char leaf[RIG_PATH_MAX + 88];
    if (!cJSON_IsObject(m))
        return ffd_rig_expected(p, path, "an object {\"index\": i, \"delta\": [dx,dy,dz]}");
    ffd_status s = ffd_rig_check_keys(p, m, path, keys, "\"index\", \"delta\"");
    if (s)
        return s;
    const cJSON *ix = cJSON_GetObjectItemCaseSensitive(m, "index");
    const cJSON *d = cJSON_GetObjectItemCaseSensitive(m, "delta");
    snprintf(leaf, sizeof leaf, "%s.index", path);
    if (!ix)
        return ffd_rig_expected(p, leaf, "a curve point index (missing)");
    if ((s = ffd_rig_read_index(p, ix, leaf, "a curve point index", &move->index)))
        return s;
    if (move->index >= n)
        return ffd_fail(p->err, FFD_ERR_RANGE,
                        "%s: %s: %u out of range (the curve has %zu points)", p->name, leaf,
                        move->index, n);
    snprintf(leaf, sizeof leaf, "%s.delta", path);
    if (!d)
        return ffd_rig_expected(p, leaf, "an array of 3 finite numbers (missing)");
    return ffd_rig_read_vec3(p, d, leaf, move->delta);
}

static void curve_free(void *element)
{
    ffd_rig_curve *curve = element;
    ffd_free(curve->points);
    ffd_free(curve->moves);
}

static ffd_status read_curve(const ffd_rig_parser *p, const cJSON *c, const char *path,
                             void *element, void *ctx)
{
    static const char *const keys[] = {"points", "radius", "samples", "moves", NULL};
    ffd_rig_curve *curve = element;
    char sub[RIG_PATH_MAX + 80];
    (void)ctx;
    if (!cJSON_IsObject(c))
        return ffd_rig_expected(p, path, "an object {\"points\": [[x,y,z], ...], \"radius\": r, "
                                 "\"moves\": [...]}");
    ffd_status s = ffd_rig_check_keys(p, c, path, keys, "\"points\", \"radius\", \"samples\", \"moves\"");
    if (s)
        return s;
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(c, "points");
    snprintf(sub, sizeof sub, "%s.points", path);
    if ((s = ffd_rig_read_points(p, v, sub, 2, &curve->points, &curve->point_count)))
        return s;
    snprintf(sub, sizeof sub, "%s.radius", path);
    if (!(v = cJSON_GetObjectItemCaseSensitive(c, "radius")))
        return ffd_rig_expected(p, sub, "a number > 0 (missing)");
    if ((s = ffd_rig_read_positive(p, v, sub, &curve->radius)))
        return s;
    if ((v = cJSON_GetObjectItemCaseSensitive(c, "samples"))) {
        snprintf(sub, sizeof sub, "%s.samples", path);
        if ((s = ffd_rig_read_index(p, v, sub, "a non-negative integer (0: automatic)", &curve->samples)))
            return s;
    }
    if ((v = cJSON_GetObjectItemCaseSensitive(c, "moves"))) {
        void *moves;
        snprintf(sub, sizeof sub, "%s.moves", path);
        s = ffd_rig_read_array(p, v, sub, "an array of {\"index\": i, \"delta\": [dx,dy,dz]}",
                               sizeof *curve->moves, read_curve_move, NULL, &curve->point_count,
                               &moves, &curve->move_count);
        curve->moves = moves;
    }
    return s;
}

static ffd_status read_curves(const ffd_rig_parser *p, const cJSON *item, ffd_rig_pbffd *pb)
{
    void *curves;
    ffd_status s = ffd_rig_read_array(p, item, "curves",
                                      "an array of {\"points\": [[x,y,z], ...], \"radius\": r, "
                                      "\"moves\": [...]}",
                                      sizeof *pb->curves, read_curve, curve_free, NULL, &curves,
                                      &pb->curve_count);
    pb->curves = curves;
    return s;
}

static ffd_status validate_pbffd(const ffd_rig_parser *p, const ffd_rig_pbffd *pb)
{
    uint32_t levels = pb->options.levels ? pb->options.levels : 1;
    const ffd_rig_pb_edit *lists[2] = {pb->moves, pb->frames};
    size_t counts[2] = {pb->move_count, pb->frame_count};
    const char *keys[2] = {"moves", "frames"};
    for (int l = 0; l < 2; l++)
        for (size_t i = 0; i < counts[l]; i++)
            if (lists[l][i].level >= levels)
                return ffd_fail(p->err, FFD_ERR_RANGE,
                                "%s: %s[%zu].level: %u out of range (the rig has %u level%s; "
                                "0 is the finest)",
                                p->name, keys[l], i, lists[l][i].level, levels,
                                levels == 1 ? "" : "s");
    if (pb->constraint_level >= levels)
        return ffd_fail(p->err, FFD_ERR_RANGE,
                        "%s: constraint_level: %u out of range (the rig has %u level%s)", p->name,
                        pb->constraint_level, levels, levels == 1 ? "" : "s");
    /* explicit controls: indices are known now (placed ones are checked at apply time) */
    if (!pb->controls_auto)
        for (int l = 0; l < 2; l++)
            for (size_t i = 0; i < counts[l]; i++)
                if (lists[l][i].level == 0 && !lists[l][i].by_near &&
                    lists[l][i].control >= pb->control_count)
                    return ffd_fail(p->err, FFD_ERR_RANGE,
                                    "%s: %s[%zu].control: %u out of range (%zu controls)",
                                    p->name, keys[l], i, lists[l][i].control, pb->control_count);
    return FFD_OK;
}

static ffd_status read_pbffd_key(const ffd_rig_parser *p, const cJSON *item, ffd_rig *rig)
{
    ffd_rig_pbffd *pb = ffd_rig_pbffd_of(rig);
    const char *key = item->string;
    ffd_status s;
    if (strcmp(key, "controls") == 0)
        return read_controls(p, item, pb);
    if (strcmp(key, "sigma") == 0) {
        if ((s = ffd_rig_read_positive(p, item, "sigma", &pb->options.sigma)))
            return s;
        if (pb->options.sigma < 0.05 || pb->options.sigma > 1e6)
            return ffd_fail(p->err, FFD_ERR_INVALID,
                            "%s: sigma: %g: expected a number in [0.05, 1e6] (below 0.05 the "
                            "kernel underflows inside its region of influence)",
                            p->name, pb->options.sigma);
        return FFD_OK;
    }
    if (strcmp(key, "master") == 0)
        return read_master(p, item, &pb->options);
    if (strcmp(key, "levels") == 0) {
        if ((s = ffd_rig_read_index(p, item, "levels", "a positive integer", &pb->options.levels)))
            return s;
        if (pb->options.levels < 1 || pb->options.levels > 32)
            return ffd_fail(p->err, FFD_ERR_INVALID, "%s: levels: %u: expected 1 to 32", p->name,
                            pb->options.levels);
        return FFD_OK;
    }
    if (strcmp(key, "constraint_level") == 0)
        return ffd_rig_read_index(p, item, "constraint_level", "a level (0 = finest)",
                          &pb->constraint_level);
    if (strcmp(key, "moves") == 0)
        return read_pb_edits(p, item, "moves", 0, &pb->moves, &pb->move_count);
    if (strcmp(key, "frames") == 0)
        return read_pb_edits(p, item, "frames", 1, &pb->frames, &pb->frame_count);
    if (strcmp(key, "curves") == 0)
        return read_curves(p, item, pb);
    return FFD_OK;
}

const char *const ffd_rig_keys_pbffd[] = {"controls", "sigma", "master", "levels", "moves", "frames", "curves", "constraint_level", NULL};

ffd_status ffd_rig_parse_pbffd(const ffd_rig_parser *p, const cJSON *root, ffd_rig *rig)
{
    const cJSON *item;
    ffd_status s = ffd_rig_read_linear_root(p, root, rig);
    if (s)
        return s;
    ffd_rig_pbffd_of(rig)->controls_auto = 1;
    cJSON_ArrayForEach(item, root)
    {
        if ((s = read_pbffd_key(p, item, rig)))
            return s;
    }
    return validate_pbffd(p, ffd_rig_pbffd_of(rig));
}

/* ======================================================================
 * Writer: the section as the reader above reads it (ffd_method.write)
 * ====================================================================== */

static cJSON *placement_json(const ffd_placement_options *o)
{
    static const char *const surfaces[] = {"auto", "closed", "open"};
    cJSON *c = cJSON_CreateObject();
    int ok = c && (!o->interior_count || cJSON_AddNumberToObject(c, "interior", (double)o->interior_count)) &&
             (!o->exterior_count || cJSON_AddNumberToObject(c, "exterior", (double)o->exterior_count)) &&
             (!(o->offset > 0) || ffd_sess_add_item(c, "offset", ffd_sess_number(o->offset))) &&
             (!(o->radius_factor > 0) ||
              ffd_sess_add_item(c, "radius_factor", ffd_sess_number(o->radius_factor))) &&
             (o->surface == FFD_SURFACE_AUTO ||
              cJSON_AddStringToObject(c, "surface", surfaces[o->surface == FFD_SURFACE_CLOSED ? 1 : 2])) &&
             (!o->voronoi_sites || cJSON_AddNumberToObject(c, "voronoi_sites", (double)o->voronoi_sites)) &&
             (!o->no_cover || cJSON_AddFalseToObject(c, "cover"));
    if (!ok) {
        cJSON_Delete(c);
        return NULL;
    }
    return c;
}

/* An explicit control: centre, radius, frame (as given), "enabled": false
 * when disabled. */
static cJSON *control_json(const ffd_ebf *e)
{
    cJSON *o = cJSON_CreateObject();
    int ok = o && ffd_sess_add_item(o, "center", ffd_sess_array(e->center, 3)) &&
             ffd_sess_add_item(o, "radius", ffd_sess_array(e->radius, 3)) &&
             ffd_sess_add_item(o, "frame", ffd_sess_matrix3((const double(*)[3])e->frame)) &&
             (!e->disabled || cJSON_AddBoolToObject(o, "enabled", 0));
    if (!ok) {
        cJSON_Delete(o);
        return NULL;
    }
    return o;
}

static int add_options(cJSON *root, const ffd_pbffd_options *o)
{
    if (o->sigma > 0 && !ffd_sess_add_item(root, "sigma", ffd_sess_number(o->sigma)))
        return 0;
    if (o->levels > 1 && !cJSON_AddNumberToObject(root, "levels", o->levels))
        return 0;
    if (o->no_master)
        return cJSON_AddFalseToObject(root, "master") != NULL;
    if (o->master_radius > 0 || o->master_weight > 0) {
        cJSON *ms = cJSON_CreateObject();
        return ffd_sess_add_item(root, "master", ms) &&
               (!(o->master_radius > 0) || ffd_sess_add_item(ms, "radius", ffd_sess_number(o->master_radius))) &&
               (!(o->master_weight > 0) || ffd_sess_add_item(ms, "weight", ffd_sess_number(o->master_weight)));
    }
    return 1;
}

/* A move (frames == 0) or a frame edit. */
static cJSON *pb_edit_json(const ffd_rig_pb_edit *e, int frames)
{
    cJSON *o = cJSON_CreateObject(), *r = NULL;
    int ok = o && (e->by_near ? ffd_sess_add_item(o, "near", ffd_sess_array(e->near, 3))
                              : cJSON_AddNumberToObject(o, "control", e->control) != NULL) &&
             cJSON_AddNumberToObject(o, "level", e->level);
    if (ok && !frames)
        ok = ffd_sess_add_item(o, "delta", ffd_sess_array(e->delta, 3));
    else if (ok && e->frame_kind == 1)
        ok = ffd_sess_add_item(o, "frame", ffd_sess_matrix3((const double(*)[3])e->frame));
    else if (ok)
        ok = (r = cJSON_AddObjectToObject(o, "rotate")) &&
             ffd_sess_add_item(r, "axis", ffd_sess_array(e->axis, 3)) &&
             ffd_sess_add_item(r, "angle", ffd_sess_number(e->angle)) &&
             ffd_sess_add_item(o, "scale", ffd_sess_array(e->scale, 3));
    if (!ok) {
        cJSON_Delete(o);
        return NULL;
    }
    return o;
}

static cJSON *curve_json(const ffd_rig_curve *cv)
{
    cJSON *o = cJSON_CreateObject();
    cJSON *pts = cJSON_AddArrayToObject(o, "points"), *mv = cJSON_AddArrayToObject(o, "moves");
    int ok = pts && mv && ffd_sess_add_item(o, "radius", ffd_sess_number(cv->radius)) &&
             (!cv->samples || cJSON_AddNumberToObject(o, "samples", cv->samples));
    for (size_t i = 0; ok && i < cv->point_count; i++)
        ok = ffd_sess_add_to_array(pts, ffd_sess_array(cv->points + 3 * i, 3));
    for (size_t k = 0; ok && k < cv->move_count; k++) {
        cJSON *e = cJSON_CreateObject();
        ok = ffd_sess_add_to_array(mv, e) && cJSON_AddNumberToObject(e, "index", cv->moves[k].index) &&
             ffd_sess_add_item(e, "delta", ffd_sess_array(cv->moves[k].delta, 3));
    }
    if (!ok) {
        cJSON_Delete(o);
        return NULL;
    }
    return o;
}

int ffd_rig_write_pbffd(const ffd_rig *rig, cJSON *root)
{
    const ffd_rig_pbffd *pb = ffd_rig_pbffd_of(rig);
    cJSON *controls = pb->controls_auto ? placement_json(&pb->placement) : cJSON_CreateArray();
    int ok = ffd_sess_add_item(root, "controls", controls) && add_options(root, &pb->options);
    for (size_t j = 0; ok && !pb->controls_auto && j < pb->control_count; j++)
        ok = ffd_sess_add_to_array(controls, control_json(&pb->controls[j]));
    cJSON *moves = ok ? cJSON_AddArrayToObject(root, "moves") : NULL;
    cJSON *frames = moves ? cJSON_AddArrayToObject(root, "frames") : NULL;
    cJSON *curves = frames ? cJSON_AddArrayToObject(root, "curves") : NULL;
    ok = curves && (!pb->constraint_level ||
                    cJSON_AddNumberToObject(root, "constraint_level", pb->constraint_level));
    for (size_t i = 0; ok && i < pb->move_count; i++)
        ok = ffd_sess_add_to_array(moves, pb_edit_json(&pb->moves[i], 0));
    for (size_t i = 0; ok && i < pb->frame_count; i++)
        ok = ffd_sess_add_to_array(frames, pb_edit_json(&pb->frames[i], 1));
    for (size_t c = 0; ok && c < pb->curve_count; c++)
        ok = ffd_sess_add_to_array(curves, curve_json(&pb->curves[c]));
    return ok;
}

/* ======================================================================
 * Writer: a PB-FFD rig holding an explicit control set
 * ====================================================================== */

static void write_vec3(char *buf, size_t cap, size_t *len, const double v[3])
{
    *len += (size_t)snprintf(buf + *len, cap - *len, "[%.17g, %.17g, %.17g]", v[0], v[1], v[2]);
}

ffd_status ffd_rig_write_pbffd_controls(const char *path, const ffd_ebf *controls, size_t count,
                                        const ffd_pbffd_options *options, ffd_error *err)
{
    if (!path || (!controls && count))
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_rig_write_pbffd_controls: NULL argument");
    for (size_t i = 0; i < count; i++) {
        const ffd_ebf *c = &controls[i];
        const double *v[3] = {c->center, c->radius, &c->frame[0][0]};
        size_t len[3] = {3, 3, 9};
        for (int a = 0; a < 3; a++)
            for (size_t j = 0; j < len[a]; j++)
                if (!isfinite(v[a][j]))
                    return ffd_fail(err, FFD_ERR_NONFINITE, "%s: controls[%zu]: not finite", path,
                                    i);
    }
    /* one control: 15 numbers of at most 25 characters plus the punctuation */
    size_t cap = 256 + count * (15 * 26 + 128);
    if (count && cap / count < 15 * 26)
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: too many controls", path);
    char *buf = ffd_malloc(cap);
    if (!buf)
        return ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", path);
    size_t len = (size_t)snprintf(buf, cap, "{\n  \"version\": 1,\n  \"deformer\": \"pbffd\",\n");
    if (options && options->sigma > 0 && options->sigma != 3)
        len += (size_t)snprintf(buf + len, cap - len, "  \"sigma\": %.17g,\n", options->sigma);
    if (options && options->no_master)
        len += (size_t)snprintf(buf + len, cap - len, "  \"master\": false,\n");
    else if (options && (options->master_radius > 0 || options->master_weight > 0))
        len += (size_t)snprintf(buf + len, cap - len,
                                "  \"master\": {\"radius\": %.17g, \"weight\": %.17g},\n",
                                options->master_radius > 0 ? options->master_radius : 2.0,
                                options->master_weight > 0 ? options->master_weight : 1.0);
    if (options && options->levels > 1)
        len += (size_t)snprintf(buf + len, cap - len, "  \"levels\": %u,\n", options->levels);
    len += (size_t)snprintf(buf + len, cap - len, "  \"controls\": [");
    for (size_t i = 0; i < count; i++) {
        const ffd_ebf *c = &controls[i];
        len += (size_t)snprintf(buf + len, cap - len, "%s\n    {\"center\": ", i ? "," : "");
        write_vec3(buf, cap, &len, c->center);
        len += (size_t)snprintf(buf + len, cap - len, ", \"radius\": ");
        write_vec3(buf, cap, &len, c->radius);
        len += (size_t)snprintf(buf + len, cap - len, ", \"frame\": [");
        for (int a = 0; a < 3; a++) {
            if (a)
                len += (size_t)snprintf(buf + len, cap - len, ", ");
            write_vec3(buf, cap, &len, c->frame[a]);
        }
        len += (size_t)snprintf(buf + len, cap - len, "]%s}", c->disabled ? ", \"enabled\": false"
                                                                          : "");
    }
    len += (size_t)snprintf(buf + len, cap - len, "\n  ],\n  \"moves\": []\n}\n");
    ffd_status s = ffd_write_file_atomic(path, buf, len, err);
    ffd_free(buf);
    return s;
}

void ffd_rig_release_pbffd(ffd_rig *rig)
{
    ffd_rig_pbffd *pb = ffd_rig_pbffd_of(rig);
    if (!pb)
        return;
    ffd_free(pb->controls);
    ffd_free(pb->moves);
    ffd_free(pb->frames);
    for (size_t i = 0; i < pb->curve_count; i++) {
        ffd_free(pb->curves[i].points);
        ffd_free(pb->curves[i].moves);
    }
    ffd_free(pb->curves);
}
