/* lattice_nested_rig — applying a lattice rig with "children" (nested
 * lattices, lattice_nested.h): the tree over the mesh, the root's moves
 * and each child's own moves, then direct manipulation (Hsu et al. 1992,
 * eq. 2-7) over the composed map, whose variables are the root's control
 * points and the children's own displacements. The mesh changes only by
 * the final ffd_mesh_set_positions (all or nothing). */
#include "lattice/lattice_nested.h"

#include <stdio.h>
#include <string.h>

/* Terms of one row of a lattice (its basis's support). */
static double row_terms(ffd_basis basis, const uint32_t r[3])
{
    return basis == FFD_BASIS_BERNSTEIN ? (double)r[0] * r[1] * r[2] : 64.0;
}

/* The rows of the tree before it is built: each child's control points
 * composed through its parent (their row length, its ancestors' terms). */
static void estimate_tree(const ffd_rig_lattice_child *c, size_t k, double above, double *controls,
                          double *terms, double *row)
{
    for (size_t i = 0; i < k; i++) {
        double count = (double)c[i].resolution[0] * c[i].resolution[1] * c[i].resolution[2];
        double mine = above + row_terms(c[i].basis, c[i].resolution);
        *controls += count;
        *terms += count * above;
        if (2 * above + mine > *row)
            *row = 2 * above + mine;
        estimate_tree(c[i].children, c[i].child_count, mine, controls, terms, row);
    }
}

/* Bind and evaluate n points under the tree, before it is built: the
 * children's composed rows (their control points through their parents)
 * and every point's row. */
static ffd_status charge(const ffd_rig *rig, size_t n, ffd_budget *budget, ffd_error *err)
{
    const ffd_rig_lattice *section = ffd_rig_lattice_of(rig);
    double root = row_terms(rig->basis, rig->resolution);
    double controls = (double)rig->resolution[0] * rig->resolution[1] * rig->resolution[2];
    double terms = 0, row = root;
    estimate_tree(section->children, section->child_count, root, &controls, &terms, &row);
    double bytes = 200.0 * (double)n + 48.0 * controls + 12.0 * terms;
    double work = 30.0 * row * (double)n * (1 + (rig->constraint_count > 0)) + 30.0 * terms;
    char ns[32], cs[32];
    return ffd_budget_charge(budget, bytes, work, err,
                             "children: %s vertices under nested lattices of %s control points",
                             ffd_format_count((double)n, ns, sizeof ns),
                             ffd_format_count(controls, cs, sizeof cs));
}

/* The grid lines of every lattice of the tree, over the controls' ids
 * (2 per edge, allocated), for --lattice-out and the editor. */
uint32_t *ffd_nested_edges(const ffd_nested *nest, size_t *count)
{
    size_t total = 0;
    for (size_t x = 0; x < nest->node_count; x++) {
        const uint32_t *r = nest->nodes[x].lat->res;
        total += (size_t)(r[0] - 1) * r[1] * r[2] + (size_t)r[0] * (r[1] - 1) * r[2] +
                 (size_t)r[0] * r[1] * (r[2] - 1);
    }
    uint32_t *e = ffd_malloc_array(total ? total : 1, 2 * sizeof *e);
    if (!e)
        return NULL;
    size_t k = 0;
    for (size_t x = 0; x < nest->node_count; x++) {
        const uint32_t *r = nest->nodes[x].lat->res;
        const uint32_t f = (uint32_t)nest->nodes[x].first;
        for (uint32_t i = 0; i < r[0]; i++)
            for (uint32_t j = 0; j < r[1]; j++)
                for (uint32_t l = 0; l < r[2]; l++) {
                    uint32_t id = f + (i * r[1] + j) * r[2] + l;
                    if (i + 1 < r[0])
                        e[2 * k] = id, e[2 * k + 1] = id + r[1] * r[2], k++;
                    if (j + 1 < r[1])
                        e[2 * k] = id, e[2 * k + 1] = id + r[2], k++;
                    if (l + 1 < r[2])
                        e[2 * k] = id, e[2 * k + 1] = id + 1, k++;
                }
    }
    *count = k;
    return e;
}

/* The children's own moves, depth-first like the nodes. */
static ffd_status child_moves(ffd_nested *nest, const ffd_rig_lattice_child *c, size_t k,
                              size_t *x, const char *name, const char *path, ffd_error *err)
{
    for (size_t i = 0; i < k; i++) {
        size_t node = (*x)++;
        char sub[160];
        if (snprintf(sub, sizeof sub, "%s[%zu]", path, i) < 0)
            sub[0] = 0;
        for (size_t m = 0; m < c[i].move_count; m++) {
            ffd_error inner = {{0}};
            ffd_status st = ffd_nested_move(nest, node, c[i].moves[m].index, c[i].moves[m].delta,
                                            &inner);
            if (st)
                return ffd_fail(err, st, "%s: %s.moves[%zu]: %s", name, sub, m, inner.message);
        }
        char deeper[176];
        if (snprintf(deeper, sizeof deeper, "%s.children", sub) < 0)
            deeper[0] = 0;
        ffd_status st = child_moves(nest, c[i].children, c[i].child_count, x, name, deeper, err);
        if (st)
            return st;
    }
    return FFD_OK;
}

ffd_status ffd_rig_apply_lattice_nested(const ffd_rig *rig, ffd_mesh *mesh, ffd_rig_report *report,
                                        ffd_budget *budget, ffd_error *err)
{
    const char *name = rig->name;
    const size_t n = ffd_mesh_vertex_count(mesh), k = rig->constraint_count;
    const double *positions = ffd_mesh_positions(mesh);
    const ffd_rig_lattice *section = ffd_rig_lattice_of(rig);
    ffd_nested *nest = NULL;
    ffd_nested_binding *binding = NULL, *pins = NULL;
    double *rest = NULL, *current = NULL, *targets = NULL, *residuals = NULL, *delta = NULL;
    double *vars = NULL, *deformed = NULL, *jacobians = NULL, *controls = NULL;
    size_t *rows = NULL;
    ffd_manip_result result = {0};
    ffd_timings timings = {0};
    ffd_error inner = {{0}};
    ffd_status s;

    if ((s = charge(rig, n, budget, &inner))) {
        s = ffd_fail(err, s, "%s: %s", name, inner.message);
        goto fail;
    }
    if ((s = ffd_nested_create(rig, positions, n, &nest, err)))
        goto fail;
    double t0 = ffd_now();
    if ((s = ffd_nested_bind(nest, positions, n, &binding, &inner))) {
        s = ffd_rig_wrap(err, s, name, "binding the mesh", &inner);
        goto fail;
    }
    if (k) {
        rest = ffd_malloc_array(k, 3 * sizeof *rest);
        current = ffd_malloc_array(k, 3 * sizeof *current);
        targets = ffd_malloc_array(k, 3 * sizeof *targets);
        residuals = ffd_malloc_array(k, sizeof *residuals);
        rows = ffd_malloc_array(k, sizeof *rows);
        if (!rest || !current || !targets || !residuals || !rows) {
            s = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory for %zu constraints", name, k);
            goto fail;
        }
        for (size_t c = 0; c < k; c++) {
            const ffd_rig_constraint *con = &rig->constraints[c];
            if (con->kind == FFD_RIG_CONSTRAINT_VERTEX && con->vertex >= n) {
                s = ffd_fail(err, FFD_ERR_RANGE,
                             "%s: constraints[%zu].vertex: %u out of range (mesh has %zu "
                             "vertices)",
                             name, c, con->vertex, n);
                goto fail;
            }
            memcpy(rest + 3 * c,
                   con->kind == FFD_RIG_CONSTRAINT_VERTEX ? positions + 3 * (size_t)con->vertex
                                                          : con->point,
                   3 * sizeof *rest);
            memcpy(targets + 3 * c, con->target, 3 * sizeof *targets);
            rows[c] = c;
        }
        if ((s = ffd_nested_bind(nest, rest, k, &pins, &inner))) {
            s = ffd_rig_wrap(err, s, name, "binding the constraints", &inner);
            goto fail;
        }
        for (size_t c = 0; c < k; c++) {
            const ffd_rig_constraint *con = &rig->constraints[c];
            if (ffd_nested_inside(pins, c))
                continue;
            if (con->kind == FFD_RIG_CONSTRAINT_POINT) {
                s = ffd_fail(err, FFD_ERR_INVALID,
                             "%s: constraints[%zu].point: [%.17g, %.17g, %.17g] is outside the "
                             "lattice box",
                             name, c, con->point[0], con->point[1], con->point[2]);
                goto fail;
            }
            if (rig->outside == FFD_OUTSIDE_FIXED) {
                s = ffd_fail(err, FFD_ERR_INVALID,
                             "%s: constraints[%zu].vertex: vertex %u is outside the lattice box "
                             "and \"outside\" is \"fixed\", so it cannot move",
                             name, c, con->vertex);
                goto fail;
            }
        }
    }
    double t1 = ffd_now();
    timings.bind = t1 - t0;

    for (size_t i = 0; i < rig->move_count; i++)
        if ((s = ffd_nested_move(nest, 0, rig->moves[i].index, rig->moves[i].delta, &inner))) {
            char context[48];
            if (snprintf(context, sizeof context, "moves[%zu]", i) < 0)
                context[0] = 0;
            s = ffd_rig_wrap(err, s, name, context, &inner);
            goto fail;
        }
    size_t x = 1;
    if ((s = child_moves(nest, section->children, section->child_count, &x, name, "children",
                         err)))
        goto fail;
    if ((s = ffd_nested_sync(nest, &inner))) {
        s = ffd_rig_wrap(err, s, name, "children", &inner);
        goto fail;
    }

    if (k) {
        ffd_nested_map self = {nest, pins};
        ffd_linear_map map;
        ffd_nested_linear_map(&self, &map);
        const size_t nv = map.variable_count;
        if ((s = ffd_nested_eval(nest, pins, current, &inner)) ||
            (s = ffd_rig_charge_manip(&map, k, budget, &inner))) {
            s = ffd_rig_wrap(err, s, name, "constraints", &inner);
            goto fail;
        }
        delta = ffd_calloc(nv, 3 * sizeof *delta);
        vars = ffd_malloc_array(nv, 3 * sizeof *vars);
        if (!delta || !vars) {
            s = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory", name);
            goto fail;
        }
        ffd_manip_options options = {.rcond = rig->rcond};
        s = ffd_manip_solve(&map, rows, k, current, targets, &options, delta, NULL, &result,
                            &inner);
        if (!s) {
            ffd_nested_variables(nest, vars);
            for (size_t v = 0; v < 3 * nv; v++)
                vars[v] += delta[v];
            s = ffd_nested_set_variables(nest, vars, &inner);
        }
        if (!s)
            s = ffd_nested_eval(nest, pins, current, &inner);
        if (s) {
            s = ffd_rig_wrap(err, s, name, "constraints", &inner);
            goto fail;
        }
        result.max_residual = ffd_rig_residuals(k, current, targets, residuals);
    }
    double t2 = ffd_now();
    timings.solve = t2 - t1;

    deformed = ffd_malloc_array(n ? n : 1, 3 * sizeof *deformed);
    if (!deformed) {
        s = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory for %zu vertices", name, n);
        goto fail;
    }
    if ((s = ffd_nested_eval(nest, binding, deformed, &inner))) {
        s = ffd_rig_wrap(err, s, name, "evaluating", &inner);
        goto fail;
    }
    if (ffd_mesh_normal_count(mesh) > 0) {
        jacobians = ffd_malloc_array(n ? n : 1, 9 * sizeof *jacobians);
        if (!jacobians) {
            s = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory for %zu Jacobians", name, n);
            goto fail;
        }
        if ((s = ffd_nested_jacobian(nest, binding, jacobians, &inner))) {
            s = ffd_rig_wrap(err, s, name, "Jacobians", &inner);
            goto fail;
        }
    }
    size_t outside_count = 0;
    for (size_t i = 0; i < n; i++)
        outside_count += !ffd_nested_inside(binding, i);
    const size_t nc = nest->control_count;
    if (report) {
        controls = ffd_malloc_array(nc, 3 * sizeof *controls);
        if (!controls) {
            s = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory for the report", name);
            goto fail;
        }
        ffd_nested_controls(nest, controls);
        if (!(report->control_edges = ffd_nested_edges(nest, &report->control_edge_count))) {
            s = ffd_fail(err, FFD_ERR_NOMEM, "%s: out of memory for the report", name);
            goto fail;
        }
        report->control_label = "nested lattice control points (the root's, then each "
                                "child's, depth-first)";
        /* details: the lattices of the tree (controls in this order) */
        unsigned long mark;
        cJSON *details = ffd_rig_details_create(&mark);
        cJSON *lattices = details ? cJSON_AddArrayToObject(details, "lattices") : NULL;
        for (size_t y = 0; lattices && y < nest->node_count; y++) {
            const ffd_nested_node *node = &nest->nodes[y];
            cJSON *l = cJSON_CreateObject();
            if (!l || !cJSON_AddItemToArray(lattices, l))
                break;
            cJSON_AddNumberToObject(l, "first", (double)node->first);
            cJSON_AddNumberToObject(l, "count", (double)node->count);
            cJSON_AddNumberToObject(l, "depth", node->depth);
            cJSON_AddNumberToObject(l, "parent", node->parent);
            cJSON_AddItemToObject(l, "resolution", ffd_sess_uint_array(node->lat->res, 3));
        }
        if ((s = ffd_rig_report_set_details(report, details, mark, name, err)))
            goto fail;
    }
    if ((s = ffd_mesh_set_positions(mesh, deformed, jacobians, &inner))) {
        s = ffd_rig_wrap(err, s, name, "deformed positions", &inner);
        goto fail;
    }
    timings.evaluate = ffd_now() - t2;
    if (report) {
        report->constraint_count = k;
        report->residuals = residuals;
        report->reached = current;
        residuals = current = NULL;
        report->rank = result.rank;
        report->max_residual = result.max_residual;
        report->outside_count = outside_count;
        report->timings = timings;
        report->control_count = nc;
        report->control_points = controls;
        controls = NULL;
        ffd_lattice_resolution(nest->nodes[0].lat, report->resolution);
    }
fail:
    ffd_nested_binding_destroy(pins);
    ffd_nested_binding_destroy(binding);
    ffd_nested_destroy(nest);
    ffd_free(rest);
    ffd_free(current);
    ffd_free(targets);
    ffd_free(residuals);
    ffd_free(delta);
    ffd_free(vars);
    ffd_free(rows);
    ffd_free(deformed);
    ffd_free(jacobians);
    ffd_free(controls);
    return s;
}
