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
 * Not thread-safe with respect to concurrent library calls: set it first.
 * While one is set, cJSON's process-wide hooks (cJSON_InitHooks) point at it
 * too (NULL restores cJSON's defaults); CHOLMOD allocates through it once a
 * T-spline ARAP solve has started. Qhull and LAPACK/OpenBLAS allocate with
 * their own allocators. Memory must be freed under the allocator that
 * allocated it. */
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
 * byte for byte (a UTF-8 byte order mark before the first line of a text
 * file or PLY header is read past and kept). Errors: FFD_ERR_IO (missing
 * file, directory, unreadable), FFD_ERR_PARSE (message "path:line: ..." for text, "path: byte N: ..." for
 * binary), FFD_ERR_NONFINITE (NaN/Inf coordinate), FFD_ERR_RANGE (bad face
 * index), FFD_ERR_NOMEM. */
ffd_status ffd_mesh_read(const char *path, ffd_mesh **out, ffd_error *err);

/* Same from memory; name is used in messages (may be NULL). format must not be AUTO. */
ffd_status ffd_mesh_read_memory(const void *data, size_t size, ffd_format format,
                                const char *name, ffd_mesh **out, ffd_error *err);

/* Writes atomically: on failure, or when the process is killed, an existing
 * file at path is untouched and no partial file is left (an unnamed O_TMPFILE
 * file linked in when complete; where the file system lacks O_TMPFILE, a
 * temporary "<path>.tmp<PID>.<N>" renamed over path, and such leftovers of
 * dead processes are deleted by the next write to path; docs/cli.md). Every
 * library function that writes a file does it this way. Same format as the source:
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
 * the anchor (area-weighted). STL facet normals are recomputed from their
 * deformed triangle. Identity is kept exactly, so that a write keeps the
 * file's bytes: a coordinate whose new value == the stored one (-0.0 and
 * +0.0 are equal) keeps the stored value; a normal is left as it is where
 * its Jacobian is exactly the identity or neither its anchor nor any corner
 * of a face around the anchor moved; a facet normal, where no corner of its
 * facet moved. */
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
 * a single point). margin >= 0. FFD_ERR_INVALID when n == 0 or when the
 * largest extent of the points is above 1e100 or nonzero and below 1e-100
 * (the message gives the extents), FFD_ERR_NONFINITE. */
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

/* Deformed positions of the bound points, n by 3 (paper eq. 1, evaluated as
 * the point plus sum_j B_j (P_j - P_rest,j): a point whose support holds no
 * moved control point keeps its bits). */
ffd_status ffd_lattice_eval(const ffd_lattice *lattice, const ffd_lattice_binding *binding,
                            double *out, ffd_error *err);
/* Jacobians d(x')/d(x) of the deformation at the bound points, n by 9
 * row-major (I plus the displacement's derivative: exactly I where nothing
 * moved; a clamped outside point does not vary along its clamped axes). */
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
 * PB-FFD: point-based FFD with ellipsoidal basis functions
 * (McDonnell & Qin, "PB-FFD: A Point-based Technique for Free-Form Deformation")
 * ====================================================================== */

/* One control point: an ellipsoidal basis function (EBF, eq. 1) centred at
 * center, with the reference frame (a, b, c) = frame[0], frame[1], frame[2]
 * (any lengths; linearly independent, else FFD_ERR_INVALID "degenerate
 * frame") and its region of influence (ROI): the ellipsoid
 * {center + G t : |t| < 1}, G's columns g_k = radius[k] a_k / |a_k|, whose
 * conjugate semi-diameters are the g_k (its principal semi-axes when the
 * frame is orthogonal): center + g_k lies on the boundary. Parameters
 * u = (alpha, beta, gamma) solve v - center = alpha a + beta b + gamma c,
 * which is eq. 3 for orthogonal frames and keeps rest reproduction exact
 * for oblique ones. */
typedef struct ffd_ebf {
    double center[3];
    double frame[3][3];
    double radius[3];
    int disabled; /* 1: takes no part in the deformation (its index is kept): the
                     result is bitwise the same as without it (it is not in the
                     master's bounding box or sphere, not merged into level 1,
                     never in a weight row, FFD_TIE_FIXED in the linear map) */
} ffd_ebf;

/* The kernel (eq. 1 made continuous): with rho the ROI-normalised distance,
 * rho^2 = sum_k (u_k |a_k| / radius[k])^2 = |G^-1 (x - center)|^2 (u the
 * parameters above, G as above; rho = 1 on the ROI boundary), which is eq. 1's
 * (x-mu)^T R S^-2 R^T (x-mu) for an orthogonal frame (R^T (x-mu) =
 * (u_k |a_k|)_k by eq. 3) and, for an oblique one, eq. 1 applied in the
 * frame's parameter domain, as eq. 5 writes phi_j(u_ij) (pbffd.md, "The
 * kernel"); phi(rho) = exp(-rho^2 / (2 sigma^2)) * (1 - rho^2)^3
 * for rho < 1 and 0 beyond. The first factor is eq. 1 divided by tau, so
 * phi(0) = 1. Cut off literally, eq. 1 with sigma = 3 is still 0.95 on the
 * boundary: the normalised weights (eq. 5) would jump there and the mesh
 * would crack when a control point moves. The window (1 - rho^2)^3 makes phi
 * and its first two derivatives vanish on the boundary, so the weights are
 * C2 everywhere. */

/* Zero means default for every field. */
typedef struct ffd_pbffd_options {
    double sigma;          /* eq. 1 standard deviation; default 3 */
    int no_master;         /* 1: no master control point (default: one per level, §3.2.2) */
    double master_radius;  /* master ROI radius, multiple of the bounding-sphere radius R:
                              the largest distance from the master's centre (the centre of
                              the bounding box of the bound points and the enabled
                              controls' centres) to any bound point or enabled control
                              centre; default 2 (>= 1) */
    double master_weight;  /* factor on the master's kernel value; default 1 */
    uint32_t levels;       /* control-set levels (§3.4), 1 = no hierarchy; default 1 */
} ffd_pbffd_options;

typedef struct ffd_pbffd ffd_pbffd;

/* Creates a PB-FFD deformer: the control set (copied) becomes level 0, the
 * finest; levels 1..levels-1 are built by pairwise merging of the closest
 * points (each half the size of the level below, §3.4), and each level's
 * points are parameterised in the next coarser level (eq. 10). The n points
 * (#n by 3, usually the mesh vertices) are bound to level 0 (W and D of
 * eq. 7, sparse). Every level has an immovable master control point at the
 * centre of the bounding box of the points and the enabled controls' centres
 * (a sphere of options->master_radius times R, above; fixed at creation:
 * later control-set edits do not move it), unless options->no_master. Level 1 merges the enabled controls of level 0 (the
 * disabled ones are still parameterised in level 1); a merged point gets a
 * spherical ROI about the midpoint that encloses both ROIs, with an
 * axis-aligned frame of that radius. A point under no kernel at all (no
 * control, outside the master) stays where it is. n may be 0 (points NULL).
 * Errors name the control ("controls[3]: radius 0: expected > 0"):
 * FFD_ERR_INVALID (count == 0, zero or negative radius, degenerate frame,
 * levels such that a level would have fewer than one control: each level
 * holds ceil(half) of the one below and a level of one control cannot be
 * halved; options: sigma < 0, master_radius in (0, 1), master_weight < 0),
 * FFD_ERR_NONFINITE, FFD_ERR_NOMEM. */
ffd_status ffd_pbffd_create(const ffd_ebf *controls, size_t count, const double *points, size_t n,
                            const ffd_pbffd_options *options, ffd_pbffd **out, ffd_error *err);
void ffd_pbffd_destroy(ffd_pbffd *pb);

size_t ffd_pbffd_point_count(const ffd_pbffd *pb);     /* bound points n */
size_t ffd_pbffd_level_count(const ffd_pbffd *pb);
/* Controls at level (0 = finest); 0 for a level out of range. */
size_t ffd_pbffd_control_count(const ffd_pbffd *pb, size_t level);
/* The current state of control index at level. FFD_ERR_RANGE. */
ffd_status ffd_pbffd_control(const ffd_pbffd *pb, size_t level, size_t index, ffd_ebf *out,
                             ffd_error *err);
/* The master control point of level; 0 when there is none. */
int ffd_pbffd_master(const ffd_pbffd *pb, size_t level, ffd_ebf *out);
/* Bound points under no control point but the master (they move only
 * through the master, i.e. not at all), and under fewer than two. */
size_t ffd_pbffd_uncovered_count(const ffd_pbffd *pb);
size_t ffd_pbffd_single_covered_count(const ffd_pbffd *pb);
/* Number of control points (master excluded) whose ROI holds bound point i. */
size_t ffd_pbffd_point_support(const ffd_pbffd *pb, size_t i);

/* Moves control index of level by delta (an edit at that level, §3.4): the
 * finer levels and the bound points follow (eq. 9-10); the coarser levels
 * do not move: the point is re-parameterised in the next coarser level at
 * its new position (against that level's current state, which reproduces
 * it). The cascade moves the centres of the finer control points whose rows
 * name a changed point; their frames are kept. A point moved outside every
 * ROI of the next coarser level no longer follows it (§3.4). FFD_ERR_RANGE,
 * FFD_ERR_NONFINITE. */
ffd_status ffd_pbffd_move(ffd_pbffd *pb, size_t level, size_t index, const double delta[3],
                          ffd_error *err);
/* Replaces the frame (the matrix A of eq. 7) of control index of level:
 * rotating it twists, scaling it stretches the space around the point.
 * The parameterisation is kept (no re-binding). FFD_ERR_RANGE,
 * FFD_ERR_NONFINITE, FFD_ERR_INVALID (degenerate frame). */
ffd_status ffd_pbffd_set_frame(ffd_pbffd *pb, size_t level, size_t index,
                               const double frame[3][3], ffd_error *err);
/* Puts every control point of every level back where it was created
 * (or where the last control-set edit left it), and undoes the
 * re-parameterisations made by moves since. */
void ffd_pbffd_reset(ffd_pbffd *pb);

/* Control-set edits on level 0, made in the current (possibly deformed)
 * state: the bound points whose parameterisation the edit changes (those
 * whose weights name the control, i.e. in its old ROI when they were bound,
 * and those inside its new ROI at their current positions) are
 * re-parameterised at their current positions, no others; the deformation
 * seen so far is kept (eval returns the same positions bitwise), and it
 * becomes the state ffd_pbffd_reset returns to. The level-0 point itself is
 * (re-)parameterised in level 1; the coarser levels are not rebuilt. add
 * returns the new index; remove shifts the later indices down by one (the
 * only control cannot be removed: FFD_ERR_INVALID); set_enabled(0) keeps the
 * index. An edit of a control that is disabled before and after it (add
 * with control->disabled, remove or redefine of a disabled one) changes no
 * position and does not rebase: reset still returns where it did and later
 * results are bitwise those without the edit. Errors: FFD_ERR_RANGE,
 * FFD_ERR_INVALID and FFD_ERR_NONFINITE for a bad control ("control[4]:
 * ..."), FFD_ERR_NOMEM; on error nothing changes. */
ffd_status ffd_pbffd_add(ffd_pbffd *pb, const ffd_ebf *control, size_t *index, ffd_error *err);
ffd_status ffd_pbffd_remove(ffd_pbffd *pb, size_t index, ffd_error *err);
ffd_status ffd_pbffd_set_enabled(ffd_pbffd *pb, size_t index, int enabled, ffd_error *err);
/* Redefines control index (centre, frame, radius) in the current state; its
 * enabled state is kept (control->disabled is ignored: use set_enabled). */
ffd_status ffd_pbffd_redefine(ffd_pbffd *pb, size_t index, const ffd_ebf *control,
                              ffd_error *err);

/* Deformed positions of the bound points, n by 3: V = W P + D A (eq. 7),
 * evaluated as rest + W dP + D dA, so that at rest it is exact (bitwise). */
ffd_status ffd_pbffd_eval(const ffd_pbffd *pb, double *out, ffd_error *err);
/* Jacobians d(x')/d(x) of the deformation at the bound points, n by 9
 * row-major, with respect to the points as bound (after a control-set edit,
 * a re-parameterised point's Jacobian composes with the one it had then). */
ffd_status ffd_pbffd_jacobian(const ffd_pbffd *pb, double *out, ffd_error *err);

/* The bound points as a linear map of the control points of level (0 =
 * finest; coarser levels compose eq. 10), for ffd_manip_solve (§3.3): the
 * master is not a column (it is fixed), disabled controls are tied
 * FFD_TIE_FIXED. Apply the solution with ffd_pbffd_move per control (moves
 * at one level keep the map exact). The map borrows pb and owns scratch
 * inside it (composed rows): it is not thread-safe; a control-set edit, or a
 * new map of the same level, invalidates it. */
ffd_status ffd_pbffd_linear_map(ffd_pbffd *pb, size_t level, ffd_linear_map *map, ffd_error *err);

/* --- Automatic placement (§3.2.1, Figure 2) --- */

typedef enum ffd_surface_kind {
    FFD_SURFACE_AUTO = 0, /* closed when the mesh has no boundary and no non-manifold edge */
    FFD_SURFACE_CLOSED,   /* interior (Voronoi) and exterior points */
    FFD_SURFACE_OPEN      /* §3.2.3: offsets along both normal directions only */
} ffd_surface_kind;

/* Zero means default for every field. */
typedef struct ffd_placement_options {
    size_t interior_count;  /* interior (medial) points; default 60 */
    size_t exterior_count;  /* exterior points (open surfaces: all points); default 60 */
    double offset;          /* exterior offset along the normal, as a fraction of the
                               bounding-box diagonal; default 0.1 x 0.5 = 5% of the diagonal
                               (the paper's 10%, of the bounding sphere's radius) */
    double radius_factor;   /* radius and frame lengths = factor x nearest-neighbour
                               distance; default 1.5 */
    ffd_surface_kind surface;
    size_t voronoi_sites;   /* at most this many mesh vertices (an even subsample) go into
                               the Voronoi diagram; default 8000; SIZE_MAX: all */
    int no_cover;           /* 1: do not grow radii so that every vertex is under two points */
} ffd_placement_options;

typedef struct ffd_placement_report {
    int open;                  /* 1: the open-surface path was taken */
    int fell_back;             /* 1: CLOSED was asked or AUTO found defects: took the open path */
    size_t interior_count;     /* placed interior points (fewer than asked when the medial
                                  axis is degenerate, see note) */
    size_t exterior_count;     /* placed exterior points */
    size_t voronoi_sites;      /* vertices given to Qhull */
    size_t voronoi_vertices;   /* Voronoi vertices Qhull returned */
    size_t inside_vertices;    /* of those, kept as inside the mesh */
    size_t grown_radii;        /* controls whose radius grew to cover vertices */
    double seconds_voronoi;    /* Qhull */
    double seconds_total;
    char note[256];            /* why the open path was taken, or why fewer interior points
                                  than asked were placed, or "" */
} ffd_placement_report;

/* Places control points for the mesh (Figure 2): the requested counts of
 * interior points (Voronoi vertices inside the mesh, octree decimation by
 * merging closest pairs) and exterior points (vertices offset along their
 * normals, decimated), each an EBF with an axis-aligned frame and radius =
 * radius_factor x nearest-neighbour distance. The Voronoi sites are the
 * vertices moved by a fixed hash of their index (1e-9 of the bounding-box
 * diagonal; deterministic), so that cospherical or cocircular vertices
 * (spheres, cylinders, boxes) are in general position; interior points
 * within 1e-3 of the diagonal of each other are one point, so a degenerate
 * medial axis (a sphere's is its centre) gives fewer interior points than
 * asked for: report->interior_count and *count say how many, report->note
 * says why. The master is not included
 * (ffd_pbffd_create adds it). *controls is freed with ffd_free. Errors:
 * FFD_ERR_INVALID (no faces; more points requested than candidates exist:
 * the message says how many there are), FFD_ERR_NUMERIC (Qhull failed: its
 * message is captured, never printed), FFD_ERR_NOMEM. */
ffd_status ffd_pbffd_place(const ffd_mesh *mesh, const ffd_placement_options *options,
                           ffd_ebf **controls, size_t *count, ffd_placement_report *report,
                           ffd_error *err);

/* --- Curve-based deformation (§3.5) --- */

typedef struct ffd_pbffd_curve ffd_pbffd_curve;

/* A Catmull-Rom spline (centripetal, interpolating) through count >= 2
 * control points, discretised into samples EBFs (0: one per radius/4 of
 * arc length, at least 8) with ROI radius radius and rotation-minimising
 * frames; the n points inside the union of the ROIs are parameterised in
 * them; a master of weight options->master_weight (default here 0.05)
 * fades the motion to zero at the ROI boundary, so points outside never
 * move. Samples are even in arc length on the curve as created and keep
 * their curve parameter when it moves; options->levels is ignored (one
 * level). FFD_ERR_INVALID (count < 2, radius <= 0, samples 1 or above
 * 100000, coincident consecutive control points), FFD_ERR_NONFINITE. */
ffd_status ffd_pbffd_curve_create(const double *control_points, size_t count, double radius,
                                  size_t samples, const double *points, size_t n,
                                  const ffd_pbffd_options *options, ffd_pbffd_curve **out,
                                  ffd_error *err);
void ffd_pbffd_curve_destroy(ffd_pbffd_curve *curve);
size_t ffd_pbffd_curve_control_count(const ffd_pbffd_curve *curve);
/* Current curve control points, count by 3. */
const double *ffd_pbffd_curve_control_points(const ffd_pbffd_curve *curve);
/* Moves curve control point index by delta: the samples and their frames
 * (rotation-minimising from the first sample's, turned with its tangent; the
 * tangent axis scaled by the local stretch) follow the new curve.
 * FFD_ERR_RANGE, FFD_ERR_NONFINITE, FFD_ERR_INVALID (consecutive control
 * points would coincide); on error nothing changes. */
ffd_status ffd_pbffd_curve_move(ffd_pbffd_curve *curve, size_t index, const double delta[3],
                                ffd_error *err);
/* Deformed positions of the n points (points outside every ROI unchanged, bitwise). */
ffd_status ffd_pbffd_curve_eval(const ffd_pbffd_curve *curve, double *out, ffd_error *err);
/* 1 when point i lies in the curve's ROI. */
int ffd_pbffd_curve_point_inside(const ffd_pbffd_curve *curve, size_t i);

/* ======================================================================
 * GFFD: generalized FFD with skeleton scalar fields
 * (Qin, Hua, Fang, Bao, Peng, "GFFD: Generalized free-form deformation with
 * scalar fields", 2003)
 * ====================================================================== */

/* A skeleton primitive (§2): geometry and an influence radius r_s. */
typedef enum ffd_gffd_kind {
    FFD_GFFD_POINT = 0,  /* one vertex */
    FFD_GFFD_POLYLINE,   /* >= 2 vertices joined in order; no zero-length segment */
    FFD_GFFD_PATCH,      /* an open polygon mesh (faces of >= 3 vertices) */
    FFD_GFFD_POLYHEDRON  /* a closed polygon mesh: every edge in exactly two faces */
} ffd_gffd_kind;

/* Geometry is borrowed for the call and copied. faces as in ffd_mesh_create
 * (face_offsets has face_count+1 entries); NULL for points and polylines. */
typedef struct ffd_gffd_primitive {
    ffd_gffd_kind kind;
    const double *vertices;        /* vertex_count by 3 */
    size_t vertex_count;
    const uint32_t *face_offsets;  /* PATCH, POLYHEDRON */
    const uint32_t *face_indices;
    size_t face_count;
    double radius;                 /* r_s > 0, model units */
} ffd_gffd_primitive;

/* Each primitive's distance field f_i is a variational interpolant (Turk &
 * O'Brien 1999: phi(r) = r^3 plus a linear polynomial) of the exact distance
 * to the primitive, signed for a polyhedron (negative inside), at samples
 * placed by these rules (r = r_s, shells at r/3, 2r/3, r and 4r/3):
 *   POINT       the point, and 14 directions (6 axes, 8 cube diagonals) per shell;
 *   POLYLINE    stations at every vertex and evenly along each segment, at
 *               most r/2 apart: the station, and 6 directions per shell in
 *               the plane normal to the curve there; at each end 5 directions
 *               per shell (the outward tangent and 4 at 45 degrees to it);
 *   PATCH       stations at every vertex and at the centroid of each face
 *               wider than r/2: the station, and both normal directions per
 *               shell; at boundary vertices also the outward direction in the
 *               tangent plane per shell;
 *   POLYHEDRON  as PATCH (no boundary): the vertices and the points along
 *               their normals, inside and outside, as the paper says.
 * Coincident samples are merged. The fields are merged by eq. 1-2:
 *   E(P) = sum_i E_i(P),  E_i = exp(-f_i/u) - exp(-r_i/u) where f_i < r_i, else 0,
 * with u the deformer's distance unit, so that a rig gives the same shape at
 * any scale (see ffd_gffd_options). E has an analytic gradient. */

typedef enum ffd_gffd_tracking {
    FFD_GFFD_TRACK_GRADIENT = 0, /* along the normalised field gradient (eq. 3) */
    FFD_GFFD_TRACK_WARP          /* along the warp direction (eq. 4-6) */
} ffd_gffd_tracking;

/* Zero means default for every field. */
typedef struct ffd_gffd_options {
    double unit;            /* u: distances are measured in units of u in eq. 2 and in the
                               tolerance; default 1/10 of the bounding-box diagonal of the
                               bound points and the rest skeleton together */
    double tolerance;       /* epsilon of Fig. 5, in units of u: |ln E(P) - ln e_0| < eps;
                               default 1e-6 */
    uint32_t max_iterations;/* tracking steps per point; default 100 */
    ffd_gffd_tracking tracking;
    size_t max_samples;     /* per primitive; default 4000 */
} ffd_gffd_options;

typedef struct ffd_gffd ffd_gffd;

/* Builds the rest skeleton's fields and binds the n points: records each
 * point's field value e_0 = E(P) (§3). Points with e_0 = 0 are outside every
 * influence region and never move. Errors name the primitive
 * ("skeleton[2]: ..."): FFD_ERR_INVALID (count == 0; radius <= 0; a point
 * with other than one vertex; a polyline with fewer than 2 vertices or a
 * zero-length segment; a face with fewer than 3 vertices or a repeated
 * vertex or zero area; a polyhedron that is not closed; too many samples;
 * options out of range), FFD_ERR_RANGE (face index), FFD_ERR_NONFINITE,
 * FFD_ERR_NOMEM. n may be 0 (points NULL). */
ffd_status ffd_gffd_create(const ffd_gffd_primitive *skeleton, size_t count, const double *points,
                           size_t n, const ffd_gffd_options *options, ffd_gffd **out,
                           ffd_error *err);
void ffd_gffd_destroy(ffd_gffd *g);

size_t ffd_gffd_point_count(const ffd_gffd *g);
/* Bound points with e_0 > 0 (the ones tracking may move). */
size_t ffd_gffd_influenced_count(const ffd_gffd *g);
double ffd_gffd_unit(const ffd_gffd *g);
/* Primitives of the current skeleton, and their current geometry (borrowed,
 * valid until the skeleton changes). */
size_t ffd_gffd_primitive_count(const ffd_gffd *g);
ffd_status ffd_gffd_get_primitive(const ffd_gffd *g, size_t index, ffd_gffd_primitive *out,
                                  ffd_error *err);
/* 1 when some primitive's field solve was singular and fell back to least
 * squares (coincident or coplanar samples). */
int ffd_gffd_regularised(const ffd_gffd *g);

/* Skeleton edit (§5, first way): gives primitive index of the current
 * skeleton new vertex positions (same count, same faces); only that
 * primitive's field is refitted. The rest skeleton's vertices and the new
 * ones give the warp's correspondences P_j0 -> P_j1 (eq. 4) unless
 * ffd_gffd_set_correspondences gave others. FFD_ERR_RANGE,
 * FFD_ERR_NONFINITE, FFD_ERR_INVALID (the edit makes the primitive
 * degenerate); on error nothing changes. */
ffd_status ffd_gffd_set_vertices(ffd_gffd *g, size_t index, const double *vertices,
                                 ffd_error *err);
/* Rigid skeleton edit: moves primitive index of the current skeleton by
 * x -> rotation x + translation (rotation: 3 by 3, row-major, a proper
 * rotation to 1e-12), and its field with it, exactly (no refit). Unlike new
 * vertex positions it carries a turn that the vertices cannot show: a point
 * or a straight polyline turned about itself. When every primitive has moved
 * by one and the same rigid motion (and neither a replacement nor user
 * correspondences intervened), tracking moves every influenced point by it
 * in either mode (then blended in the influence band, see ffd_gffd_track).
 * FFD_ERR_RANGE, FFD_ERR_NONFINITE, FFD_ERR_INVALID (not a rotation; a
 * moved coordinate beyond 1e100 or too far for the unit), FFD_ERR_NOMEM; on
 * error nothing changes. */
ffd_status ffd_gffd_transform(ffd_gffd *g, size_t index, const double rotation[9],
                              const double translation[3], ffd_error *err);
/* Skeleton replacement (§5, second way): the current skeleton becomes
 * another one (any primitives, any count). There are no automatic
 * correspondences then: warp tracking needs ffd_gffd_set_correspondences
 * (ffd_gffd_track fails with FFD_ERR_INVALID without them). Errors as
 * ffd_gffd_create; on error nothing changes. */
ffd_status ffd_gffd_replace(ffd_gffd *g, const ffd_gffd_primitive *skeleton, size_t count,
                            ffd_error *err);
/* Back to the rest skeleton (and the automatic correspondences). */
ffd_status ffd_gffd_reset(ffd_gffd *g, ffd_error *err);
/* User correspondences for the warp (eq. 4): from[j] on the rest skeleton
 * goes to to[j] (k by 3 each); k == 0 returns to the automatic ones.
 * FFD_ERR_NONFINITE, FFD_ERR_NOMEM. */
ffd_status ffd_gffd_set_correspondences(ffd_gffd *g, const double *from, const double *to,
                                        size_t k, ffd_error *err);

/* What a tracking pass did. */
typedef struct ffd_gffd_track_report {
    size_t tracked;            /* influenced points whose field value changed */
    size_t converged;          /* of those, within the tolerance */
    size_t failed_count;       /* not converged (left at their best position) */
    uint32_t *failed;          /* their ids, ascending (free with ffd_free; NULL when none) */
    size_t fallback_count;     /* points that needed a fallback start: gradient tracking that met a
                                  zero gradient and used the warp, or any tracking that started
                                  from the motion of the nearest, rigidly moved primitive */
    size_t iterations;         /* total steps over all points */
    double max_error;          /* max |ln E(P) - ln e_0| over tracked points, units of u */
} ffd_gffd_track_report;

/* Repositions the bound points in the current field (§3, Fig. 5): each
 * influenced point starts where it was bound and moves until it regains
 * e_0: dV = delta V / (grad(-ln E) . V) (the paper's delta V with
 * delta = ln E(P) - ln e_0 in units of u; the same step when the field is a
 * true distance); a step that would cross the iso-surface is tried at the
 * secant point of the bracket, then halved; one that does not improve is
 * reversed, then halved; until |delta| < tolerance or max_iterations.
 * Gradient tracking takes V along grad(-ln E) (eq. 3); a point whose field
 * value did not change is copied unchanged (bitwise); where the gradient
 * vanishes it uses the warp (counted in fallback_count) or gives up. Warp
 * tracking moves every influenced point along V = (W(P) - P)/|W(P) - P|
 * (eq. 6) to W(P) (eq. 5) and restores its value there along the gradient
 * (then, failing that, along the line through P in direction V, then along
 * the gradient from P), so a rigid motion of the skeleton moves the points
 * rigidly; points the warp moves are moved even where the field did not
 * change. When every primitive moved by one and the same rigid motion
 * (ffd_gffd_transform) every influenced point moves by it, in both modes.
 * Points outside every influence region at bind time are copied
 * unchanged (bitwise) in both modes. The influence band (a departure from
 * the paper): each point's displacement is then scaled by its blend weight
 * b = max_i S((r_i - f_i) / (r_i / 3)) over the primitives whose rest
 * field f_i is below r_i, S the quintic smoothstep clamped to [0, 1], so
 * that the deformation is continuous (C^2 in the field) where an influence
 * region ends; points deeper than the outer third of a radius (b = 1) keep
 * their tracked positions bitwise, and points that did not converge are
 * blended the same way (and reported). out: n by 3. report may be NULL; free
 * it with ffd_gffd_track_report_free. Parallel over points, bitwise
 * identical for any thread count. FFD_ERR_INVALID (warp tracking without
 * correspondences), FFD_ERR_NOMEM. */
ffd_status ffd_gffd_track(const ffd_gffd *g, double *out, ffd_gffd_track_report *report,
                          ffd_error *err);
void ffd_gffd_track_report_free(ffd_gffd_track_report *report);

/* The merged field E (eq. 1-2) of the rest (current == 0) or current
 * (current == 1) skeleton at n points: values (n) and gradients (n by 3,
 * may be NULL). */
ffd_status ffd_gffd_field(const ffd_gffd *g, int current, const double *points, size_t n,
                          double *values, double *gradients, ffd_error *err);
/* The recorded field values e_0 of the bound points (n). */
const double *ffd_gffd_bound_values(const ffd_gffd *g);
/* The blend weights b of the bound points (n, in [0, 1]; see ffd_gffd_track). */
const double *ffd_gffd_bound_weights(const ffd_gffd *g);

/* Zero means default for every field. */
typedef struct ffd_gffd_resample_options {
    double ratio;        /* split an edge when its length grows by >= ratio; default 1.8 */
    uint32_t max_rounds; /* rounds of splitting; default 8 */
    size_t max_vertices; /* stop adding vertices beyond this total; default 16 x the input's */
} ffd_gffd_resample_options;

typedef struct ffd_gffd_resample_report {
    size_t rounds;
    size_t added_vertices;
    size_t split_edges;
    size_t long_edges;         /* edges still >= ratio x their reference when it stopped */
    int capped;                /* 1: stopped by max_rounds or max_vertices */
    ffd_gffd_track_report track; /* over the original and added points together */
} ffd_gffd_resample_report;

/* Adaptive resampling (§4, Fig. 6). mesh must be the mesh whose vertices
 * were bound (same count, positions as bound). Tracks the bound points,
 * then, round by round, splits every edge whose deformed length is >= ratio
 * x its reference length (an original edge's rest length; a half inherits
 * its parent's; an edge drawn inside a cell inherits the mean edge length
 * of the original face): the midpoint of the rest edge gets the average of
 * its ends' recorded field values and is tracked too; each edge is split
 * once for all the faces that share it, so closed stays closed and no
 * T-junction appears. Cells are re-polygonised: a triangle with 1, 2 or 3
 * split edges becomes 2, 3 or 4 triangles; a quad with two opposite split
 * edges 2 quads, with four 4 quads about its centre; other polygons take
 * the midpoints into their boundary. *out is a new mesh in the input's
 * format whose new vertices interpolate every vertex attribute (texture
 * coordinates, colours, normals) and whose new faces keep their parent's
 * attributes; its positions are the deformed ones. report may be NULL;
 * free it with ffd_gffd_resample_report_free. FFD_ERR_INVALID (vertex count
 * differs from the bound points), FFD_ERR_NOMEM. */
ffd_status ffd_gffd_resample(const ffd_gffd *g, const ffd_mesh *mesh,
                             const ffd_gffd_resample_options *options, ffd_mesh **out,
                             ffd_gffd_resample_report *report, ffd_error *err);
void ffd_gffd_resample_report_free(ffd_gffd_resample_report *report);

/* ======================================================================
 * Proxy-driven FFD on a tailored cubic T-spline volume
 * (Zhang, Zheng & Cai 2020, "Proxy-driven free-form deformation by
 * topology-adjustable control lattice"; docs/tspline.md)
 * ====================================================================== */

/* The T-spline volume (§3.1, eq. 1): F(s,t,u) = sum_v W_v P_v B_v(s,t,u),
 * B_v = N[s_v](s) N[t_v](t) N[u_v](u), cubic B-splines on local knot
 * vectors found by casting rays in the T-lattice. The initial lattice is a
 * clamped uniform cubic B-spline volume of res[0] x res[1] x res[2] control
 * points over the bounding box of the object (knots 0,0,0,0,k,2k,...,1,1,1,1,
 * k = 1/(n-3)) with the control points at the Greville abscissae (eq. 2), so
 * every point x of the box has the parameters (x - min) / (max - min) (the
 * linear parameterisation of §3.2) and the rest map is the identity.
 * Refinement (§3.2-3.3) rewrites the map exactly: it never changes the
 * deformation and never re-parameterises the object.
 *
 * Elements have ids: control points 0 .. control_count-1 (never removed or
 * renumbered; refinement appends), edges, faces and cells 0 .. count-1
 * (a split keeps the element's id for its lower half along the split axis and
 * appends the other parts, so ids stay dense; initial cell (i,j,k) of the
 * (n_s-1)(n_t-1)(n_u-1) cells has id (i*(n_t-1) + j)*(n_u-1) + k). */

typedef struct ffd_tsv ffd_tsv;

/* Zero means default for every field. */
typedef struct ffd_tsv_options {
    double padding;  /* grows the bounding box by padding x its extent on each side
                        (an axis of zero extent gets padding x the diagonal, or
                        1e-9 x the diagonal when padding is 0); default 0 (the paper) */
} ffd_tsv_options;

/* Builds the initial lattice over the n points' bounding box and binds the
 * points (their parameters never change afterwards). The object's faces
 * (as in ffd_mesh_create; NULL, NULL, 0 for a point set) decide which cells
 * the object occupies, for the proxy: a cell is occupied when a face (or a
 * point) meets it. Errors: FFD_ERR_INVALID (res below 4 or above 256 on an
 * axis, n == 0, more than 2^31 control points, an extent of the points above
 * 1e100), FFD_ERR_RANGE (face index),
 * FFD_ERR_NONFINITE, FFD_ERR_NOMEM. */
ffd_status ffd_tsv_create(const double *points, size_t n, const uint32_t *face_offsets,
                          const uint32_t *face_indices, size_t face_count, const uint32_t res[3],
                          const ffd_tsv_options *options, ffd_tsv **out, ffd_error *err);
void ffd_tsv_destroy(ffd_tsv *t);

size_t ffd_tsv_point_count(const ffd_tsv *t);
/* The parameter box: min and max corners (the padded bounding box). */
void ffd_tsv_box(const ffd_tsv *t, double min[3], double max[3]);
/* Parameters (s,t,u) in [0,1]^3 of bound point i. */
void ffd_tsv_point_params(const ffd_tsv *t, size_t i, double stu[3]);

size_t ffd_tsv_control_count(const ffd_tsv *t);
/* Current control points P_v, control_count by 3 (borrowed; valid until the
 * next edit). */
const double *ffd_tsv_control_points(const ffd_tsv *t);
/* Rest position of control point v (where it sits in the identity map). */
ffd_status ffd_tsv_rest_point(const ffd_tsv *t, uint32_t v, double out[3], ffd_error *err);
/* Weight W_v (1 on analysis-suitable lattices; kept exactly as refinement
 * leaves it) and the topological coordinates of control point v (its knot
 * line on each axis, in the lattice's index space sigma, where -1 and 2 are
 * the doubled end layers and (0,1) the parameter values). */
ffd_status ffd_tsv_control_info(const ffd_tsv *t, uint32_t v, double *weight, double sigma[3],
                                ffd_error *err);
/* Local knot vectors of control point v (eq. 1), parameter values, 3 by 5. */
ffd_status ffd_tsv_knots(const ffd_tsv *t, uint32_t v, double knots[3][5], ffd_error *err);
/* max |W_v - 1| over the control points (a diagnostic). */
double ffd_tsv_max_weight_deviation(const ffd_tsv *t);

/* Replaces all control points (count by 3, finite). */
ffd_status ffd_tsv_set_control_points(ffd_tsv *t, const double *points, ffd_error *err);
/* Adds delta to control point v. FFD_ERR_RANGE, FFD_ERR_NONFINITE. */
ffd_status ffd_tsv_move(ffd_tsv *t, uint32_t v, const double delta[3], ffd_error *err);
/* All control points back at rest. */
void ffd_tsv_reset(ffd_tsv *t);

/* Frozen control points stay where they are in ARAP solves and are not
 * variables of direct manipulation. */
ffd_status ffd_tsv_set_frozen(ffd_tsv *t, uint32_t v, int frozen, ffd_error *err);
int ffd_tsv_frozen(const ffd_tsv *t, uint32_t v);

/* --- Lattice elements (current topology) --- */

typedef enum ffd_tsv_element {
    FFD_TSV_EDGE = 0,
    FFD_TSV_FACE,
    FFD_TSV_CELL
} ffd_tsv_element;

size_t ffd_tsv_element_count(const ffd_tsv *t, ffd_tsv_element kind);
/* Edge e's two control points (lower end first) and its axis (0 s, 1 t, 2 u). */
ffd_status ffd_tsv_edge(const ffd_tsv *t, uint32_t e, uint32_t ends[2], int *axis, ffd_error *err);
/* Element's box in parameter space: lo, hi in [0,1]^3 (zero thickness across
 * a face's normal, along all but an edge's axis; the end layers have zero
 * knot interval). */
ffd_status ffd_tsv_element_box(const ffd_tsv *t, ffd_tsv_element kind, uint32_t id, double lo[3],
                               double hi[3], ffd_error *err);
/* Control points on element id's closed boundary, in order: a face's ring
 * (corners and the hanging points on its sides, counter-clockwise about its
 * normal axis), a cell's corners and hanging points (ascending ids), an
 * edge's two ends. *ids freed with ffd_free. */
ffd_status ffd_tsv_element_points(const ffd_tsv *t, ffd_tsv_element kind, uint32_t id,
                                  uint32_t **ids, size_t *count, ffd_error *err);
/* The element of kind nearest to a point given in rest world coordinates
 * (for a cell: the cell that contains its parameters, clamped into the box;
 * for a face or edge: the nearest one in parameter space scaled by the box,
 * lowest id on ties). FFD_ERR_NONFINITE. */
ffd_status ffd_tsv_locate(const ffd_tsv *t, ffd_tsv_element kind, const double point[3],
                          uint32_t *id, ffd_error *err);

/* --- Local refinement (§3.2-3.3) --- */

/* One insertion: FFD_TSV_EDGE inserts a point into edge id at ratio of its
 * knot interval (0: the midpoint; else in (0,1)); FFD_TSV_FACE splits face
 * id 1 -> 4 at its centre (1 -> 2 across an end layer); FFD_TSV_CELL splits
 * cell id 1 -> 8 (octree; 1 -> 4 or 1 -> 2 in the end layers). */
typedef struct ffd_tsv_insertion {
    ffd_tsv_element kind;
    uint32_t id;
    double ratio;
} ffd_tsv_insertion;

typedef struct ffd_tsv_refine_report {
    size_t added_points;    /* control points added (requested and extra) */
    size_t moved_points;    /* existing control points the closure moved */
    size_t topology_steps;  /* element splits, the requested ones included */
    double max_weight_deviation; /* max |W - 1| after the edit */
    double seconds;
} ffd_tsv_refine_report;

/* Applies the insertions as one edit (all topology first, ids as they are
 * before the edit, then one closure) with the T-spline local refinement
 * algorithm, so the map is unchanged (to rounding) for every point, and
 * updates the proxy. All or nothing. Allowed at any time, before or after
 * deformation; an ARAP drag in progress becomes stale. Errors:
 * FFD_ERR_RANGE (no such element: "cell 40: there are 36 cells"),
 * FFD_ERR_INVALID (an edge or face in an end layer whose knot interval is 0
 * in every direction the rule would split: "edge 3: zero knot interval";
 * ratio outside (0,1); the closure exceeded its guard), FFD_ERR_NOMEM. */
ffd_status ffd_tsv_refine(ffd_tsv *t, const ffd_tsv_insertion *insertions, size_t count,
                          ffd_tsv_refine_report *report, ffd_error *err);

/* --- Evaluation --- */

/* Deformed positions of the bound points, n by 3 (eq. 1, evaluated as the
 * point plus the displacement Phi (P - P_rest): the rest lattice gives every
 * point back bitwise, and points no moved control point reaches keep their
 * bits). */
ffd_status ffd_tsv_eval(const ffd_tsv *t, double *out, ffd_error *err);
/* Jacobians d(x')/d(x) at the bound points, n by 9 row-major (I plus the
 * displacement's derivative: exactly I where nothing moved). */
ffd_status ffd_tsv_jacobian(const ffd_tsv *t, double *out, ffd_error *err);
/* The map at parameters (clamped into [0,1]^3), 3 doubles; jacobian (9,
 * d(x')/d(x), may be NULL). */
void ffd_tsv_eval_params(const ffd_tsv *t, const double stu[3], double out[3], double *jacobian);
/* Sum over v of W_v B_v at stu (1 everywhere: partition of unity). */
double ffd_tsv_weight_sum(const ffd_tsv *t, const double stu[3]);
/* The bound points as a linear map of the control points (x_i = sum_v
 * W_v B_v(s_i) P_v) for ffd_manip_solve: columns are control ids, frozen
 * ones tied FFD_TIE_FIXED. The map borrows t (and owns a tie vector in it):
 * refinement or a change of the frozen set invalidates it. */
ffd_status ffd_tsv_linear_map(ffd_tsv *t, ffd_linear_map *map, ffd_error *err);

/* --- The proxy (§3.2-3.3) --- */

/* The boundary faces of the union of cells that the object meets (cells
 * enclosed by them count as inside), as a closed polygon mesh over control
 * point ids: quads, or n-gons where hanging points lie on a face's sides.
 * Faces are oriented outwards. Updated after every refinement. Borrowed;
 * valid until the next refinement.
 * Where inside cells touch only along an edge or at a vertex, four faces
 * meet at that edge (two fans at that vertex) over the same control ids;
 * face_points gives the same faces as a closed, outward 2-manifold: such a
 * control point is one point per sheet through it (faces of one inside cell
 * stay connected), and every point maps back to its control id, so all
 * copies of a control point always sit where it is and moving the control
 * point moves them all (docs/tspline.md, "The proxy"). */
typedef struct ffd_tsv_proxy {
    size_t face_count;
    const uint32_t *face_offsets;  /* face_count + 1 */
    const uint32_t *face_indices;  /* control point ids */
    const uint32_t *face_cells;    /* face_count: the inside cell behind each face */
    size_t vertex_count;
    const uint32_t *vertices;      /* distinct control ids on the proxy, ascending */
    size_t occupied_cells;         /* cells the object meets */
    size_t inside_cells;           /* cells inside the proxy (occupied or enclosed) */
    size_t point_count;            /* the manifold proxy's points (>= vertex_count) */
    const uint32_t *point_controls; /* point_count: each point's control id, ascending */
    const uint32_t *face_points;   /* face_offsets layout: the point at each corner */
} ffd_tsv_proxy;
void ffd_tsv_get_proxy(const ffd_tsv *t, ffd_tsv_proxy *out);

/* --- Proxy-driven ARAP deformation (§3.4, eq. 3-8) --- */

/* Zero means default for every field. The energy is
 * w_one_form E_1F + w_proxy E_M + w_volume E_V (+ w_target E_C when soft). */
typedef struct ffd_tsv_arap_options {
    double w_one_form;   /* eq. 7; default 1   (the paper: w_1F = 1.5 w_M = 2 w_V = w_C) */
    double w_proxy;      /* eq. 5; default 2/3 */
    double w_volume;     /* eq. 6; default 1/2 */
    double w_target;     /* eq. 4 (soft mode); default 1 */
    uint32_t iterations; /* local/global iterations per solve; default 5 */
    int soft;            /* 1: handles are soft targets (E_C); default: hard */
    int only_target;     /* 1: w_1F = w_M = w_V = 0 apart from a 1e-9 regulariser (tests) */
} ffd_tsv_arap_options;

typedef struct ffd_tsv_arap ffd_tsv_arap;

/* Starts a drag: takes the current lattice as the reference, builds the
 * graphs (lattice edges; the 26-neighbour volumetric graph of each cell's
 * corners and hanging points; the proxy with cotangent weights), and
 * factorises the normal equations once (CHOLMOD) for this set of handles
 * (k control ids; with the frozen points they are the constrained set).
 * Errors: FFD_ERR_RANGE (id), FFD_ERR_INVALID (a handle is frozen: "handle
 * 12 is frozen"; nothing constrained: the system would be singular; a
 * repeated handle), FFD_ERR_NUMERIC (the factorisation failed), FFD_ERR_NOMEM. */
ffd_status ffd_tsv_arap_begin(ffd_tsv *t, const uint32_t *handles, size_t k,
                              const ffd_tsv_arap_options *options, ffd_tsv_arap **out,
                              ffd_error *err);
void ffd_tsv_arap_destroy(ffd_tsv_arap *arap);

typedef struct ffd_tsv_arap_report {
    uint32_t iterations;
    double max_handle_error;  /* max |P_h - target_h| (0 in hard mode) */
    double seconds;
} ffd_tsv_arap_report;

/* One drag step: handle targets (k by 3, finite); runs the iterations
 * (assemble the rotated right-hand side, solve with the cached factor,
 * refit the rotations; warm-started from the previous step) and sets the
 * lattice's control points. FFD_ERR_INVALID when the lattice was refined
 * or the frozen set changed since begin; FFD_ERR_NONFINITE. */
ffd_status ffd_tsv_arap_solve(ffd_tsv_arap *arap, const double *targets,
                              ffd_tsv_arap_report *report, ffd_error *err);

/* --- Fold-over check (beyond the paper: its stated limitation) --- */

typedef struct ffd_tsv_fold_report {
    size_t cells_checked;
    size_t folded_cell_count;   /* cells with det J <= 0 at some sample */
    uint32_t *folded_cells;     /* their ids, ascending (ffd_free; NULL when none) */
    double min_det;             /* min det J over all samples (1 at rest) */
    size_t inverted_face_count; /* object faces whose deformed normal opposes J^-T n, the
                                   normal an orientation-preserving map gives their rest
                                   normal n (at the face's centre): folded or flipped faces */
    uint32_t *inverted_faces;   /* their ids, ascending (ffd_free; NULL when none) */
} ffd_tsv_fold_report;

/* Samples det J on a samples^3 grid in each cell (0: 3) that has nonzero
 * volume in parameter space, and checks the object's faces. */
ffd_status ffd_tsv_check_folds(const ffd_tsv *t, uint32_t samples, ffd_tsv_fold_report *report,
                               ffd_error *err);
void ffd_tsv_fold_report_free(ffd_tsv_fold_report *report);

/* ======================================================================
 * Rigs: a recorded deformation (JSON, or a PyGeM .prm parameter file)
 * ====================================================================== */

typedef struct ffd_rig ffd_rig;

/* Reads a rig; .prm (PyGeM FFD parameters) by extension, JSON otherwise.
 * Unknown keys and wrong types are FFD_ERR_PARSE naming the key's path
 * (e.g. "rig.json: moves[1].delta: expected an array of 3 numbers"). A
 * leading UTF-8 byte order mark is read past; a NUL in JSON text (a \u0000
 * escape in a key or string, or a raw NUL byte) is FFD_ERR_PARSE with
 * "name:line:column". */
ffd_status ffd_rig_read(const char *path, ffd_rig **out, ffd_error *err);
ffd_status ffd_rig_parse_json(const char *text, size_t size, const char *name,
                              ffd_rig **out, ffd_error *err);
ffd_status ffd_rig_parse_prm(const char *text, size_t size, const char *name,
                             ffd_rig **out, ffd_error *err);
void ffd_rig_destroy(ffd_rig *rig);
/* The files a rig read besides itself (GFFD skeleton "file"s), each as
 * resolved against the rig's directory, for tools that must never write over
 * an input: i < ffd_rig_input_count(rig); NULL past the end. Borrowed. */
size_t ffd_rig_input_count(const ffd_rig *rig);
const char *ffd_rig_input_path(const ffd_rig *rig, size_t i);

/* Seconds spent in each phase of ffd_rig_apply. */
typedef struct ffd_timings {
    double bind;
    double solve;
    double evaluate;
} ffd_timings;

/* What applying a rig reports: a shared part, the same for every method, as
 * fields, and the method's own outcome as a JSON object (details). Tools
 * print it without knowing the method. Free with ffd_rig_report_free. */
typedef struct ffd_rig_report {
    const char *method;       /* the method's name ("lattice", "pbffd", "gffd",
                                 "tspline"; the rig's "deformer"); static, not freed */
    size_t constraint_count;
    double *residuals;        /* constraint_count entries: |reached - target| */
    double *reached;          /* constraint_count by 3 */
    size_t rank;
    double max_residual;
    size_t outside_count;     /* vertices the controls cannot move (outside the
                                 lattice; PB-FFD: under no control point but the master) */
    ffd_timings timings;
    /* The control structure, deformed: lattice: its points, index (i*m + j)*n + k;
     * PB-FFD: the finest level's centres; GFFD: the current skeleton's
     * vertices; T-spline: the T-lattice's control points, by id. */
    double *control_points;   /* control_count by 3 */
    size_t control_count;
    uint32_t resolution[3];   /* the controls' grid l, m, n (0, 0, 0: no grid) */
    uint32_t *control_edges;  /* control_edge_count pairs of control ids (T-spline: the
                                 T-lattice's edges); NULL: the grid's lines, if any */
    size_t control_edge_count;
    /* A control mesh: polygons whose corners are control points (T-spline:
     * the manifold proxy; NULL and 0 for methods without one). Its points are
     * control points, a control point on several sheets once per sheet. */
    size_t control_face_count;
    uint32_t *control_face_offsets;   /* control_face_count + 1 */
    uint32_t *control_face_points;    /* per corner, a point of the control mesh;
                                         faces oriented outwards */
    uint32_t *control_mesh_points;    /* control_mesh_point_count: each point's control id */
    size_t control_mesh_point_count;
    const char *control_label; /* what the control points are, for file headers
                                  ("GFFD skeleton vertices"); static, may be NULL */
    /* Lines for the user, each "note: ..." or "warning: ..." and '\n'
     * terminated (PB-FFD placement notes, GFFD vertices that tracking lost,
     * T-spline fold-overs); NULL when none. */
    char *notes;
    /* The method's own outcome as the text of one JSON object (NULL only when
     * the apply failed); keys per method in docs/rig.md ("The report"):
     * PB-FFD levels, uncovered, placement; GFFD influenced, unit, tracking
     * and resampling; T-spline cells, proxy counts, refinements, ARAP solves,
     * folds. */
    char *details;
} ffd_rig_report;
void ffd_rig_report_free(ffd_rig_report *report);

/* Writes the report's deformed control structure as an OBJ file (one 'v' per
 * control point; one 'l' per control edge, or along the three directions of
 * the resolution grid; PB-FFD: the points only; GFFD: the skeleton's
 * vertices; T-spline: every control point and one 'l' per T-lattice edge),
 * atomically. */
ffd_status ffd_rig_report_write_lattice(const ffd_rig_report *report, const char *path,
                                        ffd_error *err);
/* Writes the report's control mesh (T-spline rigs: the proxy; its control
 * points, deformed, and its polygons) as an OBJ file, atomically;
 * FFD_ERR_INVALID for reports without one. The file is the manifold proxy:
 * one 'v' per point (control_mesh_points order: by control id, a control
 * point on several sheets once per sheet). */
ffd_status ffd_rig_report_write_proxy(const ffd_rig_report *report, const char *path,
                                      ffd_error *err);

/* Writes a PB-FFD rig holding this explicit control set (and nothing else)
 * as JSON, atomically: what `ffd pbffd place` writes, ready to edit and to
 * replay with ffd_rig_read. options (may be NULL) adds "sigma", "master" and
 * "levels" when they differ from the defaults. */
ffd_status ffd_rig_write_pbffd_controls(const char *path, const ffd_ebf *controls, size_t count,
                                        const ffd_pbffd_options *options, ffd_error *err);

/* Bounds on the work of one request (a rig applied, an editor operation).
 * Before each large step the library estimates its peak memory (the bytes of
 * its largest allocations: the T-spline lattice after a refinement, the
 * ARAP factor, a GFFD field's dense (m+4)^2 matrix, the dense matrix of a
 * direct-manipulation solve, ...) and its work (estimated operations, about
 * one per nanosecond of one laptop core; dense LAPACK factorisations count
 * 1/10 of their flops), and refuses a step whose memory exceeds max_memory
 * or that would take the request's total work past max_work, with
 * FFD_ERR_INVALID and a message naming the rig key, the estimate and the
 * limit. The estimates and their calibration are in docs/rig.md ("Limits").
 * Zero means default for every field. */
typedef struct ffd_limits {
    size_t max_memory;  /* bytes; default 2 GiB */
    double max_work;    /* estimated operations per request; default 3e10 (about 30 s of
                           one laptop core; what the editor allows) */
    int unlimited;      /* 1: no limits at all (ffd deform --no-limits) */
} ffd_limits;

/* As ffd_rig_apply, under limits (NULL: the defaults). */
ffd_status ffd_rig_apply_limited(const ffd_rig *rig, ffd_mesh *mesh, const ffd_limits *limits,
                                 ffd_rig_report *report, ffd_error *err);

/* Applies the rig to the mesh: builds the deformer, binds the vertices,
 * applies moves, then solves the constraints, evaluates, and sets the mesh's
 * positions (normals transformed by the Jacobian). A GFFD rig edits or
 * replaces its skeleton and tracks the vertices (normals recomputed from
 * the deformed faces); with "resample" the mesh gains vertices and faces
 * (it is replaced by the refined mesh). report may be NULL.
 * Errors: FFD_ERR_RANGE (vertex id), FFD_ERR_INVALID (also: a step over
 * the default ffd_limits), FFD_ERR_NONFINITE; on error the mesh is unchanged. */
ffd_status ffd_rig_apply(const ffd_rig *rig, ffd_mesh *mesh, ffd_rig_report *report,
                         ffd_error *err);


/* ======================================================================
 * Deformers: every method behind one interface
 * ====================================================================== */

/* A deformer of any method (lattice, pbffd, gffd, tspline, ...), built from
 * a rig and bound to any point set. The operations are the same for every
 * method; one a method cannot offer is FFD_ERR_UNSUPPORTED (GFFD has no
 * linear map). Method-specific operations stay on the method's own handle
 * (ffd_deformer_handle). docs/api.md ("Deformers") and docs/architecture.md
 * say how the methods are registered. Not thread-safe. */
typedef struct ffd_deformer ffd_deformer;

/* Builds the rig's deformer for mesh and replays the rig (moves, solves,
 * edits, refinements) exactly as ffd_rig_apply does, without changing mesh:
 * mesh is what the rig was made for ("box" "auto", vertex constraints,
 * PB-FFD placement, the T-spline proxy and GFFD tracking read it) and is
 * only read during the call. The bound points are then mesh's vertices.
 * limits: NULL for the defaults (ffd_limits). Errors as ffd_rig_apply. */
ffd_status ffd_deformer_create(const ffd_rig *rig, const ffd_mesh *mesh, const ffd_limits *limits,
                               ffd_deformer **out, ffd_error *err);
/* As ffd_deformer_create from rig JSON text (name names it in errors; a GFFD
 * skeleton "file" is resolved relative to name's directory). */
ffd_status ffd_deformer_create_json(const char *text, size_t size, const char *name,
                                    const ffd_mesh *mesh, const ffd_limits *limits,
                                    ffd_deformer **out, ffd_error *err);
void ffd_deformer_destroy(ffd_deformer *d);
/* The method's name, as the rig's "deformer" key spells it. */
const char *ffd_deformer_method(const ffd_deformer *d);
/* The method's own handle when the deformer is of that method (ffd_lattice
 * for "lattice", ffd_pbffd for "pbffd", ffd_gffd for "gffd", ffd_tsv for
 * "tspline"), NULL otherwise. Borrowed; method-specific edits made through
 * it are seen by the next evaluation. */
void *ffd_deformer_handle(ffd_deformer *d, const char *method);

/* Binds n points given at rest (n by 3, copied): a second surface, a volume
 * mesh's nodes, one partition of a distributed mesh. Replaces the previous
 * binding; a point bound here deforms exactly as the same point would as a
 * vertex of the mesh. FFD_ERR_NONFINITE; on error the binding is unchanged. */
ffd_status ffd_deformer_bind(ffd_deformer *d, const double *points, size_t n, ffd_error *err);
size_t ffd_deformer_point_count(const ffd_deformer *d);
/* Deformed positions of the bound points, point_count by 3. */
ffd_status ffd_deformer_eval(ffd_deformer *d, double *out, ffd_error *err);
/* Jacobians d(x')/d(x) of the map at the bound points, point_count by 9
 * row-major. FFD_ERR_UNSUPPORTED for a method without one. */
ffd_status ffd_deformer_jacobian(ffd_deformer *d, double *out, ffd_error *err);
/* The bound points' deformed positions as a linear map of the control
 * variables: rows are the bound points, and the tie maps every column to
 * the control it moves (variable j is control j, variable_count ==
 * ffd_deformer_control_count): x'_i = sum_c w_ic p_tie(c) plus what does not
 * depend on the controls. Borrows d until the next bind, control change,
 * method operation (a T-spline refinement) or destroy. FFD_ERR_UNSUPPORTED where the map is not linear in the controls. */
ffd_status ffd_deformer_linear_map(ffd_deformer *d, ffd_linear_map *map, ffd_error *err);

/* The control variables: count, current positions (count by 3), positions
 * set (ids NULL: all count, in order) or moved by deltas (k by 3), and every
 * control back at rest. Setting goes through the method's own edit (a GFFD
 * skeleton vertex moves its primitive and re-tracks). FFD_ERR_RANGE for an
 * id, FFD_ERR_NONFINITE; on error nothing changed. */
size_t ffd_deformer_control_count(const ffd_deformer *d);
void ffd_deformer_controls(const ffd_deformer *d, double *out);
ffd_status ffd_deformer_set_controls(ffd_deformer *d, const uint32_t *ids, size_t k,
                                     const double *positions, ffd_error *err);
ffd_status ffd_deformer_move_controls(ffd_deformer *d, const uint32_t *ids, size_t k,
                                      const double *deltas, ffd_error *err);
ffd_status ffd_deformer_reset(ffd_deformer *d, ffd_error *err);

/* The method's report as JSON (ffd_free the text): {"method", "points",
 * "controls": {"count", ...the method's structure...}, "params": {...}};
 * the keys under "controls" and "params" are the method's (docs/api.md). */
ffd_status ffd_deformer_report(const ffd_deformer *d, char **json, size_t *size, ffd_error *err);

/* ======================================================================
 * Editing sessions: the editor's model (ffd serve is HTTP around it)
 * ====================================================================== */

/* A session holds one rest mesh, at most one deformer of any method, the
 * direct-manipulation pins, an undo/redo history and the drag in progress.
 * Its state is always expressible as a rig (ffd_session_rig): replaying that
 * rig with ffd_rig_apply on the same mesh gives the session's positions.
 * Not thread-safe: callers serialise access (ffd serve holds one lock).
 * Commands are JSON objects; the operations and their bodies are listed in
 * docs/editor.md ("The session API"). */
typedef struct ffd_session ffd_session;

/* Zero means default for every field. */
typedef struct ffd_session_options {
    size_t max_undo;           /* undo entries kept; default 200 */
    size_t max_controls;       /* refuse deformers with more control points; default 2,000,000 */
    ffd_limits limits;         /* bounds on each operation's memory and work (ffd_limits;
                                  default: its defaults); a refused operation changes nothing */
} ffd_session_options;

/* Creates a session on mesh, which it takes over on success (destroyed with
 * the session; untouched on error). name labels the mesh (the file name). */
ffd_status ffd_session_create(ffd_mesh *mesh, const char *name, const ffd_session_options *options,
                              ffd_session **out, ffd_error *err);
void ffd_session_destroy(ffd_session *s);
/* The rest mesh (positions as loaded) and its label. */
const ffd_mesh *ffd_session_mesh(const ffd_session *s);
const char *ffd_session_name(const ffd_session *s);

/* Runs one operation (op: "create", "drag_begin", "drag", "undo", ...) with
 * its JSON body (may be empty for operations without parameters). On
 * success *reply (ffd_free) holds *reply_size bytes: a binary frame when
 * *binary is set (drag steps, influence), else a JSON text. On error the
 * session is exactly as before the call and err says why: FFD_ERR_PARSE
 * (malformed JSON, wrong key or type: the message names the key; a NUL,
 * \u0000 or raw, anywhere in the body: "op:line:column: ..."),
 * FFD_ERR_INVALID (a well-formed request the state refuses: no deformer,
 * wrong method, no drag in progress), FFD_ERR_RANGE (an id), FFD_ERR_UNSUPPORTED
 * (unknown op), FFD_ERR_NONFINITE, FFD_ERR_NOMEM. */
ffd_status ffd_session_command(ffd_session *s, const char *op, const char *body, size_t size,
                               void **reply, size_t *reply_size, int *binary, ffd_error *err);
/* The names of the operations ffd_session_command knows: the session's own,
 * then each method's (refine, frame, ...); NULL for i past the end. */
const char *ffd_session_op_name(size_t i);

/* The state as JSON (mesh, method, parameters, control structure, pins,
 * undo/redo depth, revision): see docs/editor.md. ffd_free the text. */
ffd_status ffd_session_state(const ffd_session *s, char **json, size_t *size, ffd_error *err);
/* The current frame (binary, little-endian, docs/editor.md): deformed vertex
 * positions, control positions and pin residuals as float32. */
ffd_status ffd_session_frame(const ffd_session *s, void **data, size_t *size, ffd_error *err);
/* The rest mesh's triangles (polygons fanned) and rest positions (binary). */
ffd_status ffd_session_topology(const ffd_session *s, void **data, size_t *size, ffd_error *err);
/* The session's state as a rig (JSON text, ffd_free): replays with
 * ffd_rig_apply / ffd deform to the session's positions. FFD_ERR_INVALID
 * without a deformer. */
ffd_status ffd_session_rig(const ffd_session *s, char **json, size_t *size, ffd_error *err);
/* Replaces the deformer by the one a rig builds (an undoable step). name
 * names the rig in errors; files a GFFD rig refers to are resolved
 * relative to name's directory and must lie under root (NULL: a rig that
 * refers to files is refused). On error nothing changes. */
ffd_status ffd_session_load_rig(ffd_session *s, const char *text, size_t size, const char *name,
                                const char *root, ffd_error *err);
/* The deformed mesh in memory, in options->format (FFD_FORMAT_AUTO: the
 * format it was read in); ffd_free the data. */
ffd_status ffd_session_export(const ffd_session *s, const ffd_write_options *options,
                              void **data, size_t *size, ffd_error *err);
/* The deformed mesh (a new mesh, ffd_mesh_destroy it): the rest mesh with
 * the session's rig applied, exactly what ffd deform writes. */
ffd_status ffd_session_deformed(const ffd_session *s, ffd_mesh **out, ffd_error *err);

#ifdef __cplusplus
}
#endif
#endif /* FFD_H */
