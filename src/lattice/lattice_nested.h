/* lattice_nested — nested lattices (SU2's parent/child FFD boxes, pyGeo's
 * child FFDs): a tree of lattices in which a child's control points are the
 * parent's map of their rest positions plus the child's own displacement,
 * and a point is deformed by the deepest lattice whose box holds it.
 *
 * Variables (the linear map's columns, the controls' order): the root's
 * control points, then each child's control points depth-first (a child
 * before its own children, siblings in rig order). A root variable is the
 * control point's position; a child variable is its own displacement on top
 * of the parent's map (the control point's position is the parent map of
 * its rest position plus it), so that W composes:
 *   row_child(x) = sum_j w_j(x) (e_j + row_parent(rest_j)). */
#ifndef FFD_LATTICE_NESTED_H
#define FFD_LATTICE_NESTED_H

#include "lattice/lattice.h"
#include "lattice/lattice_method.h"

#define FFD_LATTICE_MAX_DEPTH 8u                  /* levels of children below the root */
#define FFD_LATTICE_MAX_NESTED_CONTROLS 1048576u  /* control points of all the lattices */

typedef struct ffd_nested_node {
    ffd_lattice *lat;            /* its control points: parent map of rest + own */
    int parent;                  /* node index; -1 for the root */
    unsigned depth;
    size_t first;                /* its first variable */
    size_t count;                /* its control points */
    double *own;                 /* children: count by 3, the own displacement */
    ffd_lattice_binding *anchor; /* children: the rest control points bound to the parent */
    /* children: control j's displacement as a row over the ancestors'
     * variables (sorted, CSR), and the size of the union of their columns */
    size_t *emb_start;
    uint32_t *emb_col;
    double *emb_w;
    size_t emb_union;
    size_t row_cap;              /* entries the composition of one row needs */
} ffd_nested_node;

typedef struct ffd_nested {
    ffd_nested_node *nodes;      /* depth-first: nodes[0] is the root */
    size_t node_count;
    size_t control_count;        /* variables of all nodes */
    size_t max_row;              /* the largest row_cap */
    ffd_outside outside;         /* the root's outside rule (a child holds its points) */
    double falloff;
    ffd_falloff_curve falloff_curve;
} ffd_nested;

typedef struct ffd_nested_binding {
    size_t n;
    size_t node_count;             /* of the tree it was made for */
    uint32_t *node_of;             /* n: the deepest node whose box holds the point */
    uint32_t *slot;                /* n: its index in that node's binding */
    ffd_lattice_binding **bind;    /* per node (NULL when it holds no point) */
    uint32_t **index;              /* per node: the original indices of its points */
    size_t *count;                 /* per node: how many */
} ffd_nested_binding;

/* The tree of the rig's lattices over the rest points (n by 3: boxes
 * "auto" and vertex selections refer to them). FFD_ERR_INVALID (a child box
 * not inside its parent's box, a box), FFD_ERR_RANGE (a vertex id),
 * FFD_ERR_NOMEM. The rig is not retained. */
ffd_status ffd_nested_create(const ffd_rig *rig, const double *rest, size_t n, ffd_nested **out,
                             ffd_error *err);
void ffd_nested_destroy(ffd_nested *nest);

/* Rebuilds every child's control points from its parent's (depth-first). */
ffd_status ffd_nested_sync(ffd_nested *nest, ffd_error *err);
/* The node holding variable id. */
size_t ffd_nested_node_of_control(const ffd_nested *nest, size_t id);
/* The control points' positions (control_count by 3). */
void ffd_nested_controls(const ffd_nested *nest, double *out);
/* The variables (root positions, children's own displacements), and setting them. */
void ffd_nested_variables(const ffd_nested *nest, double *out);
ffd_status ffd_nested_set_variables(ffd_nested *nest, const double *v, ffd_error *err);
/* Controls ids at positions targets (k by 3), the others' variables kept:
 * a child control point's own displacement becomes target - parent map of rest. */
ffd_status ffd_nested_set_controls(ffd_nested *nest, const uint32_t *ids, size_t k,
                                   const double *targets, ffd_error *err);
/* Adds delta to control (i,j,k) of node: the root's position, a child's own. */
ffd_status ffd_nested_move(ffd_nested *nest, size_t node, const uint32_t index[3],
                           const double delta[3], ffd_error *err);
void ffd_nested_reset(ffd_nested *nest);

ffd_status ffd_nested_bind(const ffd_nested *nest, const double *points, size_t n,
                           ffd_nested_binding **out, ffd_error *err);
void ffd_nested_binding_destroy(ffd_nested_binding *b);
/* 1 when point i is inside the root box (or in a child). */
int ffd_nested_inside(const ffd_nested_binding *b, size_t i);
ffd_status ffd_nested_eval(const ffd_nested *nest, const ffd_nested_binding *b, double *out,
                           ffd_error *err);
ffd_status ffd_nested_jacobian(const ffd_nested *nest, const ffd_nested_binding *b, double *out,
                               ffd_error *err);
/* The composed linear map over the variables (no ties); borrows both. */
typedef struct ffd_nested_map {
    const ffd_nested *nest;
    const ffd_nested_binding *bind;
} ffd_nested_map;
void ffd_nested_linear_map(const ffd_nested_map *self, ffd_linear_map *map);
/* The grid lines of all the lattices over the control ids: *count pairs,
 * allocated (NULL when out of memory; lattice_nested_rig.c). */
uint32_t *ffd_nested_edges(const ffd_nested *nest, size_t *count);

#endif
