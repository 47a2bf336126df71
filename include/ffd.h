/*
 * ffd.h — the public API of libffd, the ffdkit free-form deformation library.
 *
 * This header is the manual. Conventions:
 *   - Fallible functions return ffd_status (FFD_OK == 0) and take an optional
 *     caller-owned ffd_error* that receives a message naming the file and
 *     line or byte offset and what was expected. On failure outputs stay NULL.
 *   - Positions are contiguous double[3*n] (x0,y0,z0,x1,...); indices uint32_t;
 *     sizes size_t; angles radians.
 *   - Whoever creates destroys; destroy functions accept NULL.
 *   - The library never prints, never exits, keeps no mutable global state
 *     except the optional allocator hook (ffd_set_allocator).
 *   - One thread per handle at a time; evaluation is parallel inside (OpenMP)
 *     and bitwise identical for any thread count.
 */
#ifndef FFD_H
#define FFD_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define FFD_VERSION_MAJOR 0
#define FFD_VERSION_MINOR 1
#define FFD_VERSION_PATCH 0

/* ======================================================================
 * Status, errors, allocation
 * ====================================================================== */

typedef enum ffd_status {
    FFD_OK = 0,
    FFD_ERR_IO,          /* a file could not be opened, read, written or renamed */
    FFD_ERR_PARSE,       /* malformed input file (message names file and line/offset) */
    FFD_ERR_INVALID,     /* an argument or rig value is invalid */
    FFD_ERR_RANGE,       /* an index is out of range */
    FFD_ERR_NONFINITE,   /* NaN or Inf where a finite number is required */
    FFD_ERR_NOMEM,       /* an allocation failed or a size overflowed */
    FFD_ERR_NUMERIC,     /* a numerical routine failed (e.g. SVD did not converge) */
    FFD_ERR_UNSUPPORTED  /* a valid request this build cannot do */
} ffd_status;

/* Message buffer filled on failure. Zero-initialise; message is always NUL-terminated. */
typedef struct ffd_error {
    char message[512];
} ffd_error;

/* A static, human-readable name for a status ("ok", "parse error", ...). */
const char *ffd_status_string(ffd_status status);

/* Optional allocator. All library allocation goes through these (tests use
 * it to fail the N-th allocation). Pass NULL to restore malloc/realloc/free.
 * Not thread-safe with respect to concurrent library calls: set it first. */
typedef struct ffd_allocator {
    void *(*malloc_fn)(size_t size, void *user);
    void *(*realloc_fn)(void *ptr, size_t size, void *user);
    void (*free_fn)(void *ptr, void *user);
    void *user;
} ffd_allocator;
void ffd_set_allocator(const ffd_allocator *allocator);

/* Frees memory the library returned to the caller (e.g. ffd_mesh_write_memory). */
void ffd_free(void *ptr);

/* ======================================================================
 * Meshes
 * ====================================================================== */

typedef struct ffd_mesh ffd_mesh;

typedef enum ffd_format {
    FFD_FORMAT_AUTO = 0, /* from the file extension (.obj .ply .off .stl, case-insensitive) */
    FFD_FORMAT_OBJ,
    FFD_FORMAT_PLY,
    FFD_FORMAT_OFF,
    FFD_FORMAT_STL
} ffd_format;

typedef enum ffd_encoding {
    FFD_ENCODING_SAME = 0,     /* as the source file; ascii when the source had another format */
    FFD_ENCODING_ASCII,
    FFD_ENCODING_BINARY_LE,    /* PLY binary_little_endian, STL binary */
    FFD_ENCODING_BINARY_BE     /* PLY binary_big_endian */
} ffd_encoding;

/* Zero means default for every field. */
typedef struct ffd_write_options {
    ffd_format format;     /* FFD_FORMAT_AUTO: from the path's extension */
    ffd_encoding encoding; /* PLY and STL only */
} ffd_write_options;

/* Format implied by a path's extension, or FFD_FORMAT_AUTO when unknown. */
ffd_format ffd_format_from_path(const char *path);

/* Reads a mesh. Format from the extension. Everything the file holds is kept
 * so that writing it back in the same format without changes reproduces it
 * byte for byte. Errors: FFD_ERR_IO (missing file, directory, unreadable),
 * FFD_ERR_PARSE (message "path:line: ..." for text, "path: byte N: ..." for
 * binary), FFD_ERR_NONFINITE (NaN/Inf coordinate), FFD_ERR_RANGE (bad face
 * index), FFD_ERR_NOMEM. */
ffd_status ffd_mesh_read(const char *path, ffd_mesh **out, ffd_error *err);

/* Same from memory; name is used in messages (may be NULL). format must not be AUTO. */
ffd_status ffd_mesh_read_memory(const void *data, size_t size, ffd_format format,
                                const char *name, ffd_mesh **out, ffd_error *err);

/* Writes atomically (temporary file in the same directory, then rename): on
 * failure an existing file at path is untouched. Same format as the source:
 * every non-position byte is kept; changed positions (and their normals) are
 * rewritten with 17 significant digits (text) or in the file's own binary
 * type. Another format: written from the mesh's geometry and attributes. */
ffd_status ffd_mesh_write(const ffd_mesh *mesh, const char *path,
                          const ffd_write_options *options, ffd_error *err);

/* Same into a buffer the caller frees with ffd_free. options->format must not be AUTO. */
ffd_status ffd_mesh_write_memory(const ffd_mesh *mesh, const ffd_write_options *options,
                                 unsigned char **data, size_t *size, ffd_error *err);

/* Builds a mesh from arrays (copied). face_offsets has face_count+1 entries,
 * face_offsets[0]==0; face_indices has face_offsets[face_count] entries.
 * positions may be NULL only when vertex_count==0; faces may be NULL when face_count==0. */
ffd_status ffd_mesh_create(const double *positions, size_t vertex_count,
                           const uint32_t *face_offsets, const uint32_t *face_indices,
                           size_t face_count, ffd_mesh **out, ffd_error *err);

void ffd_mesh_destroy(ffd_mesh *mesh);

ffd_format ffd_mesh_source_format(const ffd_mesh *mesh);
size_t ffd_mesh_vertex_count(const ffd_mesh *mesh);
size_t ffd_mesh_face_count(const ffd_mesh *mesh);
/* #V by 3, current positions. Valid until the mesh changes or is destroyed. */
const double *ffd_mesh_positions(const ffd_mesh *mesh);
/* #F+1 offsets into face_indices; face f has vertices face_indices[off[f] .. off[f+1]). */
const uint32_t *ffd_mesh_face_offsets(const ffd_mesh *mesh);
const uint32_t *ffd_mesh_face_indices(const ffd_mesh *mesh);

/* Normals stored in the file (OBJ vn, PLY nx/ny/nz, STL facet normals):
 * #N by 3. normal_anchor[i] is the vertex whose deformation carries normal i
 * (OBJ: the first vertex that uses it in a face; PLY: its vertex; STL: the
 * first corner of its facet), or UINT32_MAX for an OBJ normal no face uses
 * (left unchanged by ffd_mesh_set_positions). NULL when the mesh has none. */
size_t ffd_mesh_normal_count(const ffd_mesh *mesh);
const double *ffd_mesh_normals(const ffd_mesh *mesh);
const uint32_t *ffd_mesh_normal_anchors(const ffd_mesh *mesh);

/* Replaces the positions (#V by 3, all finite, else FFD_ERR_NONFINITE and no
 * change). Normals are updated: with jacobians (#V by 9, row-major
 * d(x')/d(x) per vertex) each normal is mapped by the inverse transpose of
 * the Jacobian at its anchor vertex and renormalised to its previous length;
 * with jacobians NULL they are recomputed from the deformed faces around
 * the anchor (area-weighted). STL facet normals are always recomputed from
 * their deformed triangle. */
ffd_status ffd_mesh_set_positions(ffd_mesh *mesh, const double *positions,
                                  const double *jacobians, ffd_error *err);

typedef struct ffd_mesh_info {
    size_t vertex_count;
    size_t face_count;
    size_t corner_count;           /* sum of face sizes */
    size_t welded_vertex_count;    /* distinct positions (exactly equal coordinates merged) */
    size_t edge_count;             /* undirected edges between the file's vertex indices
                                      (STL: between welded positions, since STL has no indices) */
    size_t boundary_edge_count;    /* edges used by one face */
    size_t nonmanifold_edge_count; /* edges used by three or more faces */
    size_t normal_count;
    size_t texcoord_count;
    int closed;                    /* 1 when there is no boundary edge and at least one face */
    double bbox_min[3];
    double bbox_max[3];
} ffd_mesh_info;

/* Counts, bounding box and edge topology. Edges join the file's own vertex
 * indices, so unwelded patches (the teapot) show their boundaries; STL facets
 * are joined through welded positions. */
ffd_status ffd_mesh_compute_info(const ffd_mesh *mesh, ffd_mesh_info *info, ffd_error *err);

/* ======================================================================
 * Linear deformers: the interface direct manipulation needs
 * ====================================================================== */

#define FFD_TIE_FIXED UINT32_MAX

/* A linear map from control points to bound points: x_i = sum_j w_ij p_j.
 * Implemented by the lattice (and the other linear deformers). Columns are
 * the deformer's raw control slots; tie (the paper's selection matrix S,
 * compressed to a vector) maps each slot to the free variable it follows,
 * or FFD_TIE_FIXED for a slot that must not move; NULL tie = identity. */
typedef struct ffd_linear_map {
    const void *self;
    size_t point_count;     /* rows available */
    size_t column_count;    /* control slots */
    size_t variable_count;  /* free variables after tying */
    size_t max_row_nnz;     /* upper bound on one row's entries */
    const uint32_t *tie;    /* column_count entries, or NULL */
    /* Writes row i's entries (column, weight) and returns their count (<= max_row_nnz). */
    size_t (*row)(const void *self, size_t i, uint32_t *columns, double *weights);
} ffd_linear_map;

/* Zero means default. */
typedef struct ffd_manip_options {
    double rcond; /* relative singular-value threshold for the rank; default 1e-10 */
} ffd_manip_options;

typedef struct ffd_manip_result {
    size_t rank;            /* numerical rank of B S */
    size_t variables_used;  /* distinct free variables touched by the constraints */
    double max_residual;    /* max over constraints of |reached - target| */
} ffd_manip_result;

/* Direct manipulation (Hsu et al. 1992, eq. 2-7): finds the minimum-norm
 * change dV of the free variables so that the constrained points reach their
 * targets in the least-squares sense: dV = (B S)^+ (targets - current).
 * points: k row indices of map; current: k by 3 positions those points have
 * now; targets: k by 3 (finite, else FFD_ERR_NONFINITE). delta receives
 * map->variable_count by 3 (zero where untouched). residuals (k, may be NULL)
 * receives |current + B S dV - target| per constraint. Rank deficiency and
 * over-determination are normal (SVD, LAPACK gelsd). k == 0 gives delta 0. */
ffd_status ffd_manip_solve(const ffd_linear_map *map, const size_t *points, size_t k,
                           const double *current, const double *targets,
                           const ffd_manip_options *options, double *delta,
                           double *residuals, ffd_manip_result *result, ffd_error *err);

/* ======================================================================
 * Lattice FFD: Bernstein (Sederberg-Parry) and uniform cubic B-spline (Hsu et al.)
 * ====================================================================== */

typedef struct ffd_lattice ffd_lattice;
typedef struct ffd_lattice_binding ffd_lattice_binding;

typedef enum ffd_basis {
    FFD_BASIS_BSPLINE = 0, /* uniform cubic B-spline, outer control points of multiplicity three */
    FFD_BASIS_BERNSTEIN    /* one Bezier volume of degree (l-1, m-1, n-1) */
} ffd_basis;

/* Points outside the parallelepiped. Points on its boundary are inside. */
typedef enum ffd_outside {
    FFD_OUTSIDE_FIXED = 0,   /* keep their position (default) */
    FFD_OUTSIDE_CLAMP,       /* move with the nearest boundary point: continuous across the boundary */
    FFD_OUTSIDE_EXTRAPOLATE  /* Bernstein: evaluate the polynomials outside [0,1];
                                B-spline: same as CLAMP. (PyGeM keeps outside points FIXED.) */
} ffd_outside;

/* Parallelepiped: x = origin + s*axes[0] + t*axes[1] + u*axes[2], (s,t,u) in [0,1]^3. */
typedef struct ffd_box {
    double origin[3];
    double axes[3][3];
} ffd_box;

/* Axis-aligned bounding box of n points grown by margin times its extent on
 * each side (an axis of zero extent gets margin times the diagonal, or 1 for
 * a single point). margin >= 0. FFD_ERR_INVALID when n == 0, FFD_ERR_NONFINITE. */
ffd_status ffd_box_fit(const double *points, size_t n, double margin, ffd_box *box, ffd_error *err);

/* Minimum control points per direction for a basis (2 for both). */
uint32_t ffd_basis_min_resolution(ffd_basis basis);

/* Creates a lattice of res[0] x res[1] x res[2] control points at rest,
 * evenly spaced on the box. Errors: FFD_ERR_INVALID (resolution below the
 * minimum or above 1024, zero or negative volume box), FFD_ERR_NONFINITE. */
ffd_status ffd_lattice_create(ffd_basis basis, const ffd_box *box, const uint32_t res[3],
                              ffd_lattice **out, ffd_error *err);
void ffd_lattice_destroy(ffd_lattice *lattice);

ffd_basis ffd_lattice_basis(const ffd_lattice *lattice);
void ffd_lattice_box(const ffd_lattice *lattice, ffd_box *box);
void ffd_lattice_resolution(const ffd_lattice *lattice, uint32_t res[3]);
/* l*m*n; control point (i,j,k) has index (i*m + j)*n + k. */
size_t ffd_lattice_control_count(const ffd_lattice *lattice);
/* Current control points, count by 3. */
const double *ffd_lattice_control_points(const ffd_lattice *lattice);
/* Rest position of control point (i,j,k). */
void ffd_lattice_rest_point(const ffd_lattice *lattice, uint32_t i, uint32_t j, uint32_t k,
                            double out[3]);
/* Replaces all control points (count by 3, finite). */
ffd_status ffd_lattice_set_control_points(ffd_lattice *lattice, const double *points, ffd_error *err);
/* Adds delta to control point (i,j,k). FFD_ERR_RANGE, FFD_ERR_NONFINITE. */
ffd_status ffd_lattice_move(ffd_lattice *lattice, const uint32_t index[3], const double delta[3],
                            ffd_error *err);
/* Adds delta (count by 3) to every control point. */
ffd_status ffd_lattice_add(ffd_lattice *lattice, const double *delta, ffd_error *err);
/* Puts every control point back at rest. */
void ffd_lattice_reset(ffd_lattice *lattice);

/* Local coordinates of n points (paper §2: inverting the rest map, directly
 * in the inner segments, by a cubic root solve in the two outer segments of
 * the B-spline). The binding is valid for this lattice's box, resolution and
 * basis; moving control points never re-binds. FFD_ERR_NONFINITE. */
ffd_status ffd_lattice_bind(const ffd_lattice *lattice, const double *points, size_t n,
                            ffd_outside outside, ffd_lattice_binding **out, ffd_error *err);
void ffd_lattice_binding_destroy(ffd_lattice_binding *binding);
size_t ffd_lattice_binding_count(const ffd_lattice_binding *binding);
size_t ffd_lattice_binding_inside_count(const ffd_lattice_binding *binding);
/* Spline parameters of point i: B-spline: in [0, l+1] x [0, m+1] x [0, n+1]
 * (integer part = segment); Bernstein: in [0,1]^3 (outside for outside points).
 * Returns 1 when the point is inside the box, 0 otherwise. */
int ffd_lattice_binding_params(const ffd_lattice_binding *binding, size_t i, double stu[3]);

/* Deformed positions of the bound points, n by 3 (paper eq. 1). */
ffd_status ffd_lattice_eval(const ffd_lattice *lattice, const ffd_lattice_binding *binding,
                            double *out, ffd_error *err);
/* Jacobians d(x')/d(x) of the deformation at the bound points, n by 9 row-major. */
ffd_status ffd_lattice_jacobian(const ffd_lattice *lattice, const ffd_lattice_binding *binding,
                                double *out, ffd_error *err);
/* Evaluates the map at spline parameters directly (no binding), 3 doubles. */
void ffd_lattice_eval_params(const ffd_lattice *lattice, const double stu[3], double out[3]);

/* The binding as a linear map for ffd_manip_solve. Columns are the raw
 * control slots: for the B-spline the (l+4)(m+4)(n+4) tripled-border net,
 * tied by S to the l*m*n distinct control points; for Bernstein the l*m*n
 * control points. The map borrows lattice and binding. */
void ffd_lattice_linear_map(const ffd_lattice *lattice, const ffd_lattice_binding *binding,
                            ffd_linear_map *map);

/* ======================================================================
 * Rigs: a recorded deformation (JSON, or a PyGeM .prm parameter file)
 * ====================================================================== */

typedef struct ffd_rig ffd_rig;

/* Reads a rig; .prm (PyGeM FFD parameters) by extension, JSON otherwise.
 * Unknown keys and wrong types are FFD_ERR_PARSE naming the key's path
 * (e.g. "rig.json: moves[1].delta: expected an array of 3 numbers"). */
ffd_status ffd_rig_read(const char *path, ffd_rig **out, ffd_error *err);
ffd_status ffd_rig_parse_json(const char *text, size_t size, const char *name,
                              ffd_rig **out, ffd_error *err);
ffd_status ffd_rig_parse_prm(const char *text, size_t size, const char *name,
                             ffd_rig **out, ffd_error *err);
void ffd_rig_destroy(ffd_rig *rig);

/* Seconds spent in each phase of ffd_rig_apply. */
typedef struct ffd_timings {
    double bind;
    double solve;
    double evaluate;
} ffd_timings;

/* What applying a rig reports. Free with ffd_rig_report_free. */
typedef struct ffd_rig_report {
    size_t constraint_count;
    double *residuals;        /* constraint_count entries: |reached - target| */
    double *reached;          /* constraint_count by 3 */
    size_t rank;
    double max_residual;
    size_t outside_count;     /* vertices outside the lattice */
    ffd_timings timings;
    uint32_t resolution[3];   /* the lattice's l, m, n */
    double *control_points;   /* l*m*n by 3: the deformed lattice, index (i*m + j)*n + k */
} ffd_rig_report;
void ffd_rig_report_free(ffd_rig_report *report);

/* Writes the report's deformed lattice as an OBJ file (one 'v' per control
 * point, 'l' lines along the three lattice directions), atomically. */
ffd_status ffd_rig_report_write_lattice(const ffd_rig_report *report, const char *path,
                                        ffd_error *err);

/* Applies the rig to the mesh: builds the deformer, binds the vertices,
 * applies moves, then solves the constraints, evaluates, and sets the mesh's
 * positions (normals transformed by the Jacobian). report may be NULL.
 * Errors: FFD_ERR_RANGE (vertex id), FFD_ERR_INVALID, FFD_ERR_NONFINITE;
 * on error the mesh is unchanged. */
ffd_status ffd_rig_apply(const ffd_rig *rig, ffd_mesh *mesh, ffd_rig_report *report,
                         ffd_error *err);

#ifdef __cplusplus
}
#endif
#endif /* FFD_H */
