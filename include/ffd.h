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
 *     except the optional allocator and progress hooks (ffd_set_allocator,
 *     ffd_set_progress).
 *   - One thread per handle at a time; evaluation is parallel inside (OpenMP)
 *     and bitwise identical for any thread count.
 *   - BLAS/LAPACK run on one thread: the library's first call into them sets
 *     OpenBLAS to one thread for the process (openblas_set_num_threads(1)),
 *     so its pool does not spin against the OpenMP threads; results are then
 *     also independent of the core count.
 *   - Each method's own API (handle, options, operations, and what it puts in
 *     the generic structures) is in its header include/ffd_<method>.h; ffd.h
 *     includes them all at its end (ffd_methods.h, the list of them).
 */
#ifndef FFD_H
#define FFD_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* FFD_API marks the library's public functions: the shared library is built
 * with hidden visibility and exports exactly these (tests/install/check_exports.sh). */
#ifndef FFD_API
#if defined(__GNUC__) || defined(__clang__)
#define FFD_API __attribute__((visibility("default")))
#else
#define FFD_API
#endif
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
FFD_API const char *ffd_status_string(ffd_status status);

/* Optional allocator. All library allocation goes through these (tests use
 * it to fail the N-th allocation). Pass NULL to restore malloc/realloc/free.
 * Not thread-safe with respect to concurrent library calls: set it first.
 * While one is set, cJSON's process-wide hooks (cJSON_InitHooks) point at it
 * too (NULL restores cJSON's defaults); CHOLMOD allocates through it once a
 * method's first CHOLMOD factorisation has started (the method's header says
 * which of its operations factor). Qhull and LAPACK/OpenBLAS allocate with
 * their own allocators. Memory must be freed under the allocator that
 * allocated it. */
typedef struct ffd_allocator {
    void *(*malloc_fn)(size_t size, void *user);
    void *(*realloc_fn)(void *ptr, size_t size, void *user);
    void (*free_fn)(void *ptr, void *user);
    void *user;
} ffd_allocator;
FFD_API void ffd_set_allocator(const ffd_allocator *allocator);

/* Frees memory the library returned to the caller (e.g. ffd_mesh_write_memory). */
FFD_API void ffd_free(void *ptr);

/* Optional progress hook, for hosts that show progress (the ffd command draws
 * it on stderr). Long operations call fn(user, stage, fraction) for each of
 * their stages: fraction 0 first, then larger fractions below 1 at most about
 * 20 times a second, and 1 exactly once when the stage is done (a stage that
 * fails stops without its 1). Stages: "reading" and "writing" (a mesh),
 * "placement" (ffd_pbffd_place), "binding" (a lattice or PB-FFD binding),
 * "tracking" (GFFD), "T-spline set-up" (ffd_tsv_create, ffd_tsv_refine) and
 * "ARAP" (ffd_tsv_arap_begin's factorisation); stage is a static string. fn
 * is called on the thread that called the library, never from OpenMP worker
 * threads, and must not call the library. Pass NULL to remove it. Like
 * ffd_set_allocator, set it before other library calls; it is global. */
typedef void (*ffd_progress_fn)(void *user, const char *stage, double fraction);
FFD_API void ffd_set_progress(ffd_progress_fn fn, void *user);

/* ======================================================================
 * Meshes
 * ====================================================================== */

typedef struct ffd_mesh ffd_mesh;

typedef enum ffd_format {
    FFD_FORMAT_AUTO = 0, /* from the file extension (.obj .ply .off .stl .gltf .glb, any case) */
    FFD_FORMAT_OBJ,
    FFD_FORMAT_PLY,
    FFD_FORMAT_OFF,
    FFD_FORMAT_STL,
    FFD_FORMAT_GLTF, /* glTF 2.0: .gltf (ASCII encoding) and .glb (BINARY_LE); docs/mesh-formats.md */
    /* Volume formats (cells, point and cell data; docs/volume.md): */
    FFD_FORMAT_VTK,  /* legacy VTK .vtk: ASCII or BINARY_BE; unstructured grid or polydata */
    FFD_FORMAT_VTU,  /* VTK XML unstructured grid .vtu: ASCII, BASE64 or RAW (appended) */
    FFD_FORMAT_MSH,  /* Gmsh .msh 2.2 and 4.1: ASCII or BINARY_LE; written from data as 2.2 */
    FFD_FORMAT_SU2,  /* SU2 native .su2 (ASCII), with its boundary markers */
    FFD_FORMAT_XYZ,  /* a point set, one point per line: .xyz (blanks) or .csv (commas) */
    FFD_FORMAT_NPY   /* a point set as a NumPy (N, 3) float array, .npy */
} ffd_format;

typedef enum ffd_encoding {
    FFD_ENCODING_SAME = 0,     /* as the source file; ascii when the source had another format
                                  (NPY, binary only: little-endian) */
    FFD_ENCODING_ASCII,
    FFD_ENCODING_BINARY_LE,    /* PLY binary_little_endian, STL binary */
    FFD_ENCODING_BINARY_BE,    /* PLY binary_big_endian, legacy VTK BINARY */
    FFD_ENCODING_BASE64,       /* VTU: inline base64 data arrays (format="binary") */
    FFD_ENCODING_RAW           /* VTU: raw appended data (<AppendedData encoding="raw">) */
} ffd_encoding;

/* Zero means default for every field. */
typedef struct ffd_write_options {
    ffd_format format;     /* FFD_FORMAT_AUTO: from the path's extension */
    ffd_encoding encoding; /* PLY, STL, VTK, VTU, MSH and NPY (docs/volume.md) */
    int compress;          /* VTU: 1 = zlib-compressed data arrays (when built with zlib);
                              0 = as the source when writing a .vtu back to its own
                              encoding, else none; -1 = none (docs/volume.md, "VTU") */
} ffd_write_options;

/* Format implied by a path's extension, or FFD_FORMAT_AUTO when unknown. */
FFD_API ffd_format ffd_format_from_path(const char *path);

/* Reads a mesh. Format from the extension. Everything the file holds is kept
 * so that writing it back in the same format without changes reproduces it
 * byte for byte (a UTF-8 byte order mark before the first line of a text
 * file or PLY header is read past and kept). Errors: FFD_ERR_IO (missing
 * file, directory, unreadable), FFD_ERR_PARSE (message "path:line: ..." for text, "path: byte N: ..." for
 * binary), FFD_ERR_NONFINITE (NaN/Inf coordinate), FFD_ERR_RANGE (bad face
 * index), FFD_ERR_NOMEM. glTF (.gltf, .glb): the triangles of the default
 * scene in world space, external buffers read next to path; FFD_ERR_PARSE /
 * FFD_ERR_UNSUPPORTED name the JSON path ("$.accessors[3]: ...") or byte
 * offset of what cannot be written back losslessly (docs/mesh-formats.md). */
FFD_API ffd_status ffd_mesh_read(const char *path, ffd_mesh **out, ffd_error *err);

/* Same from memory; name is used in messages (may be NULL). format must not
 * be AUTO. A glTF read from memory may not name external buffer files
 * (FFD_ERR_UNSUPPORTED). */
FFD_API ffd_status ffd_mesh_read_memory(const void *data, size_t size, ffd_format format,
                                        const char *name, ffd_mesh **out, ffd_error *err);

/* Writes atomically: on failure, or when the process is killed, an existing
 * file at path is untouched and no partial file is left (an unnamed O_TMPFILE
 * file linked in when complete; where the file system lacks O_TMPFILE, a
 * temporary "<path>.tmp<PID>.<N>" renamed over path, and such leftovers of
 * dead processes are deleted by the next write to path; docs/cli.md). Every
 * library function that writes a file does it this way. Same format as the source:
 * every non-position byte is kept; changed positions (and their normals) are
 * rewritten with 17 significant digits (text) or in the file's own binary
 * type. Another format: written from the mesh's geometry and attributes.
 * glTF: only POSITION/NORMAL data and POSITION min/max change; a .gltf's
 * external buffers are written next to path (refused, FFD_ERR_UNSUPPORTED,
 * where that would replace the source's own buffer file); .gltf and .glb
 * are not converted into each other. */
FFD_API ffd_status ffd_mesh_write(const ffd_mesh *mesh, const char *path,
                                  const ffd_write_options *options, ffd_error *err);

/* Same into a buffer the caller frees with ffd_free. options->format must not
 * be AUTO. A .gltf's external buffers are embedded as base64 data: URIs. */
FFD_API ffd_status ffd_mesh_write_memory(const ffd_mesh *mesh, const ffd_write_options *options,
                                         unsigned char **data, size_t *size, ffd_error *err);

/* Builds a mesh from arrays (copied). face_offsets has face_count+1 entries,
 * face_offsets[0]==0; face_indices has face_offsets[face_count] entries.
 * positions may be NULL only when vertex_count==0; faces may be NULL when face_count==0. */
FFD_API ffd_status ffd_mesh_create(const double *positions, size_t vertex_count,
                                   const uint32_t *face_offsets, const uint32_t *face_indices,
                                   size_t face_count, ffd_mesh **out, ffd_error *err);

FFD_API void ffd_mesh_destroy(ffd_mesh *mesh);

FFD_API ffd_format ffd_mesh_source_format(const ffd_mesh *mesh);
FFD_API size_t ffd_mesh_vertex_count(const ffd_mesh *mesh);
FFD_API size_t ffd_mesh_face_count(const ffd_mesh *mesh);
/* #V by 3, current positions. Valid until the mesh changes or is destroyed. */
FFD_API const double *ffd_mesh_positions(const ffd_mesh *mesh);
/* #F+1 offsets into face_indices; face f has vertices face_indices[off[f] .. off[f+1]). */
FFD_API const uint32_t *ffd_mesh_face_offsets(const ffd_mesh *mesh);
FFD_API const uint32_t *ffd_mesh_face_indices(const ffd_mesh *mesh);

/* Normals stored in the file (OBJ vn, PLY nx/ny/nz, STL facet normals):
 * #N by 3. normal_anchor[i] is the vertex whose deformation carries normal i
 * (OBJ: the first vertex that uses it in a face; PLY: its vertex; STL: the
 * first corner of its facet), or UINT32_MAX for an OBJ normal no face uses
 * (left unchanged by ffd_mesh_set_positions). NULL when the mesh has none. */
FFD_API size_t ffd_mesh_normal_count(const ffd_mesh *mesh);
FFD_API const double *ffd_mesh_normals(const ffd_mesh *mesh);
FFD_API const uint32_t *ffd_mesh_normal_anchors(const ffd_mesh *mesh);

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
 * facet moved. Tangents (glTF TANGENT: x y z and the handedness w) follow
 * at each vertex whose normal would: t' = J t (a tangent is carried by the
 * Jacobian itself, not its inverse transpose), made orthogonal to the
 * vertex's updated normal (Gram-Schmidt) and rescaled to unit length, w
 * kept; with jacobians NULL the fallback is the old tangent projected onto
 * the plane of the recomputed normal and renormalised. A tangent whose
 * result degenerates (J t ~ 0, or along the normal) is left as it was. */
FFD_API ffd_status ffd_mesh_set_positions(ffd_mesh *mesh, const double *positions,
                                          const double *jacobians, ffd_error *err);

/* ---- Cells: volume meshes (docs/volume.md) -------------------------------
 * A mesh read from a volume format (VTK, VTU, MSH, SU2) keeps its cells with
 * VTK's cell types and node order (other formats' readers map theirs). A
 * mesh with a 3D cell is a volume mesh: its faces (ffd_mesh_face_*) are the
 * boundary surface of its 3D cells (faces of one 3D cell only, oriented
 * outwards for a positive cell), its vertices are all its nodes. Without 3D
 * cells the 2D cells are the faces. */
enum {
    FFD_CELL_VERTEX = 1, FFD_CELL_POLY_VERTEX = 2, FFD_CELL_LINE = 3, FFD_CELL_POLY_LINE = 4,
    FFD_CELL_TRIANGLE = 5, FFD_CELL_TRIANGLE_STRIP = 6, FFD_CELL_POLYGON = 7, FFD_CELL_PIXEL = 8,
    FFD_CELL_QUAD = 9, FFD_CELL_TETRA = 10, FFD_CELL_VOXEL = 11, FFD_CELL_HEXAHEDRON = 12,
    FFD_CELL_WEDGE = 13, FFD_CELL_PYRAMID = 14, FFD_CELL_QUADRATIC_EDGE = 21,
    FFD_CELL_QUADRATIC_TRIANGLE = 22, FFD_CELL_QUADRATIC_QUAD = 23, FFD_CELL_QUADRATIC_TETRA = 24,
    FFD_CELL_QUADRATIC_HEXAHEDRON = 25, FFD_CELL_QUADRATIC_WEDGE = 26,
    FFD_CELL_QUADRATIC_PYRAMID = 27, FFD_CELL_BIQUADRATIC_QUAD = 28,
    FFD_CELL_TRIQUADRATIC_HEXAHEDRON = 29
};
/* The cell type's name ("tetra", "hexahedron", "wedge", ..., meshio's names), or NULL. */
FFD_API const char *ffd_cell_type_name(unsigned vtk_id);
/* 0..3, or -1 for a type the library does not know. */
FFD_API int ffd_cell_type_dimension(unsigned vtk_id);

FFD_API size_t ffd_mesh_cell_count(const ffd_mesh *mesh);
/* Per cell its VTK type; cell c's nodes are indices[offsets[c] .. offsets[c+1]).
 * NULL when the mesh has no cells. */
FFD_API const uint8_t *ffd_mesh_cell_types(const ffd_mesh *mesh);
FFD_API const uint64_t *ffd_mesh_cell_offsets(const ffd_mesh *mesh);
FFD_API const uint32_t *ffd_mesh_cell_indices(const ffd_mesh *mesh);
/* 1 when the mesh has a 3D cell. */
FFD_API int ffd_mesh_is_volume(const ffd_mesh *mesh);
/* Per face, the cell it is a face of (NULL for a mesh without cells). */
FFD_API const uint32_t *ffd_mesh_face_cells(const ffd_mesh *mesh);

/* Builds a mesh from nodes and cells (copied; VTK types and node order;
 * offsets has cell_count + 1 entries, offsets[0] == 0). The faces are
 * derived as for a file. FFD_ERR_INVALID, FFD_ERR_RANGE (a node id),
 * FFD_ERR_PARSE (a cell's node count), FFD_ERR_UNSUPPORTED (a type). */
FFD_API ffd_status ffd_mesh_create_cells(const double *positions, size_t vertex_count,
                                         const uint8_t *types, const uint64_t *offsets,
                                         const uint32_t *indices, size_t cell_count,
                                         ffd_mesh **out, ffd_error *err);

/* Point and cell data the file holds (VTK point/cell data, Gmsh tags,
 * SU2 markers), kept in the mesh so that another volume format can write
 * them; writing back to the source format keeps their bytes. */
enum { FFD_FIELD_POINT = 0, FFD_FIELD_CELL = 1 };
typedef struct ffd_field_info {
    const char *name;
    int association;       /* FFD_FIELD_POINT or FFD_FIELD_CELL */
    uint32_t components;
    size_t count;          /* vertex_count or cell_count */
    const double *values;  /* count * components */
} ffd_field_info;
FFD_API size_t ffd_mesh_field_count(const ffd_mesh *mesh);
FFD_API ffd_status ffd_mesh_field_get(const ffd_mesh *mesh, size_t i, ffd_field_info *info,
                                      ffd_error *err);
/* Per vertex its Gmsh node tag (#V values, each >= 1, distinct), for a mesh
 * read from MSH; NULL for any other mesh. The tags of a piece of a
 * partitioned mesh (`gmsh -part N -part_split`) are its nodes' numbers in the
 * whole mesh (docs/mpi.md). Valid until the mesh is destroyed. */
FFD_API const uint64_t *ffd_mesh_node_tags(const ffd_mesh *mesh);

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
FFD_API ffd_status ffd_mesh_compute_info(const ffd_mesh *mesh, ffd_mesh_info *info, ffd_error *err);

/* ---- Cell quality and inversions (docs/volume.md "Inverted cells and fold-overs") ----
 * The Jacobian determinant of a 3D cell at a corner is det[e1 e2 e3] of the
 * corner's three edges, taken in the order that is positive for a valid cell
 * in VTK's node order (tetra, voxel, hexahedron, wedge: every corner;
 * pyramid: the four base corners, each with its two base edges and the edge
 * to the apex: the four base-corner tetrahedra, as VTK's verdict does; the
 * apex has four edges and no frame of its own). Quadratic cells: the same at
 * their corners (from the corner nodes), and at the centre the
 * isoparametric Jacobian of the quadratic shape functions (tetra10,
 * hexahedron20, hexahedron27, wedge15; pyramid13's rational basis is not
 * sampled at its centre). The scaled Jacobian is the minimum over the corners
 * of det / (|e1| |e2| |e3|), times sqrt(2) (tetra, pyramid) or 2/sqrt(3)
 * (wedge) as verdict does, so that a regular cell scores 1; <= 0 means
 * inverted or degenerate. Volumes are exact for linear cells: tetra by its
 * determinant, hexahedron and voxel by 2x2x2 Gauss quadrature of the
 * trilinear map's determinant, wedge by a 3-point triangle rule times 2-point
 * Gauss (both exact for those polynomial degrees), pyramid by the mean of
 * its two diagonal splits into tetrahedra (exact for a bilinear base);
 * quadratic cells by their corners' linear cell (exact with straight edges). */
#define FFD_CELL_SAMPLES_MAX 9 /* 8 corners and the centre */
typedef struct ffd_cell_quality {
    size_t sample_count;                 /* corners (4 base corners for a pyramid),
                                            then the centre for a quadratic cell */
    double det[FFD_CELL_SAMPLES_MAX];    /* det J per sample */
    double min_det;                      /* the smallest of them */
    double scaled_jacobian;              /* min over corners, normalised (above) */
    double volume;                       /* signed: negative for an inverted cell */
} ffd_cell_quality;

/* The quality of one 3D cell of VTK type vtk_type given its node_count
 * nodes' positions (node_count by 3, VTK order). FFD_ERR_UNSUPPORTED for a
 * type that is not 3D (or unknown), FFD_ERR_INVALID for a wrong node count. */
FFD_API ffd_status ffd_cell_quality_compute(unsigned vtk_type, const double *nodes,
                                            size_t node_count, ffd_cell_quality *q,
                                            ffd_error *err);

/* A volume mesh's summary (ffd info): cells per type, boundary faces, the
 * total volume of the 3D cells and the worst scaled Jacobian. */
typedef struct ffd_mesh_quality {
    size_t cells_of_type[32];      /* indexed by VTK id (FFD_CELL_*) */
    size_t cell_count;
    size_t volume_cell_count;      /* 3D cells */
    size_t boundary_face_count;    /* the mesh's faces (the boundary of its 3D cells) */
    double volume;                 /* sum of the 3D cells' signed volumes */
    double min_scaled_jacobian;    /* over the 3D cells (NaN when there is none) */
    size_t min_scaled_cell;        /* the cell that has it (SIZE_MAX when none) */
    size_t inverted_count;         /* 3D cells with det J <= 0 at some sample */
} ffd_mesh_quality;
FFD_API ffd_status ffd_mesh_quality_compute(const ffd_mesh *mesh, ffd_mesh_quality *q,
                                            ffd_error *err);

/* The inversion check of a deformed mesh against its rest state. */
#define FFD_INVERSION_IDS_DEFAULT 1000
typedef struct ffd_inversion_report {
    size_t cells_checked;          /* 3D cells */
    size_t inverted;               /* cells with det J <= 0 at a sample, or whose sign there
                                      changed from the rest */
    double worst_det;              /* smallest det J over the checked cells' samples
                                      (NaN when none was checked) */
    double worst_scaled_jacobian;  /* smallest scaled Jacobian (NaN when none) */
    size_t worst_cell;             /* the cell of worst_det (SIZE_MAX when none) */
    uint32_t *cell_ids;            /* the first cell_id_count inverted cells, ascending */
    size_t cell_id_count;          /* <= max_ids; inverted - cell_id_count were left out */
    size_t faces_checked;          /* the mesh's faces (a volume mesh: its boundary) */
    size_t flipped_faces;          /* faces whose deformed normal has dot < 0 with the rest one */
    uint32_t *face_ids;            /* the first face_id_count of them, ascending */
    size_t face_id_count;          /* <= max_ids */
} ffd_inversion_report;

/* Checks mesh (deformed) against rest (the rest positions, vertex_count
 * by 3): every 3D cell at every sample (ffd_cell_quality_compute) and every
 * face (Newell normals of the rest and deformed polygon, flipped when their
 * dot product is < 0). max_ids caps each id list (0: FFD_INVERSION_IDS_DEFAULT).
 * Free with ffd_inversion_report_free. FFD_ERR_INVALID (NULL), FFD_ERR_NOMEM. */
FFD_API ffd_status ffd_mesh_check_inversions(const ffd_mesh *mesh, const double *rest,
                                             size_t max_ids, ffd_inversion_report *out,
                                             ffd_error *err);
FFD_API void ffd_inversion_report_free(ffd_inversion_report *report);

/* ======================================================================
 * Linear deformers: the interface direct manipulation needs
 * ====================================================================== */

#define FFD_TIE_FIXED UINT32_MAX

/* A linear map from control points to bound points: x_i = sum_j w_ij p_j.
 * Implemented by each linear method (see its header) and by
 * ffd_deformer_linear_map. Columns are
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
    /* The first hard_count constraints are hard (pins): held exactly
     * whenever they can all be met together; the others are soft (a drag),
     * met in the least-squares sense by what freedom the hard ones leave.
     * Default 0: every constraint soft (one least-squares problem). */
    size_t hard_count;
} ffd_manip_options;

typedef struct ffd_manip_result {
    size_t rank;            /* numerical rank of B S */
    size_t variables_used;  /* distinct free variables touched by the constraints */
    double max_residual;    /* max over constraints of |reached - target| */
    /* With hard constraints (options->hard_count > 0): 1 when they are all
     * met (each within 1e-9 times the largest coordinate involved, at least 1), 0 when they
     * contradict each other and were met in the least-squares sense instead;
     * hard_residual and soft_residual are the largest residual of each kind. */
    int hard_met;
    double hard_residual;
    double soft_residual;
} ffd_manip_result;

/* Direct manipulation (Hsu et al. 1992, eq. 2-7): finds the minimum-norm
 * change dV of the free variables so that the constrained points reach their
 * targets in the least-squares sense: dV = (B S)^+ (targets - current).
 * With options->hard_count = h > 0 the first h constraints (pins) are
 * equality constraints: dV = dV_h + dV_s, dV_h = A_h^+ dq_h the
 * minimum-norm change meeting them, dV_s = (A_s N N^T)^+ (dq_s - A_s dV_h)
 * the minimum-norm change in the null space N of their rows that brings the
 * others closest (A_h, A_s: the rows of B S of each kind). When everything
 * can be met this is the same dV as without hard constraints; when the hard
 * ones contradict each other dV_h is their least-squares solution
 * (result->hard_met = 0).
 * points: k row indices of map; current: k by 3 positions those points have
 * now; targets: k by 3 (finite, else FFD_ERR_NONFINITE). delta receives
 * map->variable_count by 3 (zero where untouched). residuals (k, may be NULL)
 * receives |current + B S dV - target| per constraint. Rank deficiency and
 * over-determination are normal (SVD, LAPACK gelsd). k == 0 gives delta 0. */
FFD_API ffd_status ffd_manip_solve(const ffd_linear_map *map, const size_t *points, size_t k,
                                   const double *current, const double *targets,
                                   const ffd_manip_options *options, double *delta,
                                   double *residuals, ffd_manip_result *result, ffd_error *err);

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
FFD_API ffd_status ffd_rig_read(const char *path, ffd_rig **out, ffd_error *err);
FFD_API ffd_status ffd_rig_parse_json(const char *text, size_t size, const char *name,
                                      ffd_rig **out, ffd_error *err);
FFD_API ffd_status ffd_rig_parse_prm(const char *text, size_t size, const char *name,
                                     ffd_rig **out, ffd_error *err);
/* PyGeM parameter files of RBF and IDW rigs (sections [Radial Basis
 * Functions] or [Inverse Distance Weighting] and [Control points]; read by
 * ffd_rig_parse_prm, which dispatches on those names) written back in
 * PyGeM's layout (*text ffd_free'd): FFD_ERR_UNSUPPORTED for other methods
 * and for rigs with constraints; FFD_ERR_NOMEM. */
FFD_API ffd_status ffd_rig_write_prm(const ffd_rig *rig, char **text, ffd_error *err);
FFD_API void ffd_rig_destroy(ffd_rig *rig);
/* The files a rig read besides itself (files its method section names), each as
 * resolved against the rig's directory, for tools that must never write over
 * an input: i < ffd_rig_input_count(rig); NULL past the end. Borrowed. */
FFD_API size_t ffd_rig_input_count(const ffd_rig *rig);
FFD_API const char *ffd_rig_input_path(const ffd_rig *rig, size_t i);

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
    const char *method;       /* the method's name, as the rig's "deformer" key
                                 spells it; static, not freed */
    size_t constraint_count;
    double *residuals;        /* constraint_count entries: |reached - target| */
    double *reached;          /* constraint_count by 3 */
    size_t rank;
    double max_residual;
    size_t outside_count;     /* vertices the controls cannot move (which ones:
                                 the method's header) */
    ffd_timings timings;
    /* The control structure, deformed: the method's control points, in the
     * order its header gives. */
    double *control_points;   /* control_count by 3 */
    size_t control_count;
    uint32_t resolution[3];   /* the controls' grid l, m, n (0, 0, 0: no grid) */
    uint32_t *control_edges;  /* control_edge_count pairs of control ids (the method's
                                 own edges); NULL: the grid's lines, if any */
    size_t control_edge_count;
    /* A control mesh: polygons whose corners are control points (NULL and 0
     * for methods without one). Its points are
     * control points, a control point on several sheets once per sheet. */
    size_t control_face_count;
    uint32_t *control_face_offsets;   /* control_face_count + 1 */
    uint32_t *control_face_points;    /* per corner, a point of the control mesh;
                                         faces oriented outwards */
    uint32_t *control_mesh_points;    /* control_mesh_point_count: each point's control id */
    size_t control_mesh_point_count;
    const char *control_label; /* what the control points are, for file headers
                                  (the method's words); static, may be NULL */
    /* Lines for the user, each "note: ..." or "warning: ..." and '\n'
     * terminated (the method's notes and warnings; its header says which);
     * NULL when none. */
    char *notes;
    /* The method's own outcome as the text of one JSON object (NULL only when
     * the apply failed); keys per method in docs/rig.md ("The report") and
     * in the method's header. */
    char *details;
} ffd_rig_report;
FFD_API void ffd_rig_report_free(ffd_rig_report *report);

/* Writes the report's deformed control structure as an OBJ file (one 'v' per
 * control point; one 'l' per control edge, or along the three directions of
 * the resolution grid; the points only for a method with neither; the
 * method's header says which), atomically. */
FFD_API ffd_status ffd_rig_report_write_lattice(const ffd_rig_report *report, const char *path,
                                                ffd_error *err);
/* Writes the report's control mesh (its control points, deformed, and its
 * polygons) as an OBJ file, atomically; FFD_ERR_INVALID for reports without
 * one (the method's header says which have one). The file is the manifold
 * control mesh: one 'v' per point (control_mesh_points order: by control id, a control
 * point on several sheets once per sheet). */
FFD_API ffd_status ffd_rig_report_write_proxy(const ffd_rig_report *report, const char *path,
                                              ffd_error *err);

/* Bounds on the work of one request (a rig applied, an editor operation).
 * Before each large step the library estimates its peak memory (the bytes of
 * its largest allocations: a refined control structure, a sparse or dense
 * factor, the dense matrix of a direct-manipulation solve, ...; the method's
 * header names its own) and its work (estimated operations, about one per
 * nanosecond of one laptop core; dense LAPACK factorisations count
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
FFD_API ffd_status ffd_rig_apply_limited(const ffd_rig *rig, ffd_mesh *mesh, const ffd_limits *limits,
                                         ffd_rig_report *report, ffd_error *err);

/* Applies the rig to the mesh: builds the deformer, binds the vertices,
 * applies moves, then solves the constraints, evaluates, and sets the mesh's
 * positions (normals transformed by the Jacobian). A method may apply
 * otherwise (its header says how: normals recomputed from the deformed
 * faces, or the mesh replaced by a refined one with more vertices and
 * faces). report may be NULL.
 * Errors: FFD_ERR_RANGE (vertex id), FFD_ERR_INVALID (also: a step over
 * the default ffd_limits), FFD_ERR_NONFINITE; on error the mesh is unchanged. */
FFD_API ffd_status ffd_rig_apply(const ffd_rig *rig, ffd_mesh *mesh, ffd_rig_report *report,
                                 ffd_error *err);


/* ======================================================================
 * Deformers: every method behind one interface
 * ====================================================================== */

/* A deformer of any method, built from a rig and bound to any point set.
 * The operations are the same for every method; one a method cannot offer
 * is FFD_ERR_UNSUPPORTED (a method whose map is not linear in its controls
 * has no linear map). Method-specific operations stay on the method's own
 * handle (ffd_deformer_handle). docs/api.md ("Deformers") and docs/architecture.md
 * say how the methods are registered. Not thread-safe. */
typedef struct ffd_deformer ffd_deformer;

/* Builds the rig's deformer for mesh and replays the rig (moves, solves,
 * edits, refinements) exactly as ffd_rig_apply does, without changing mesh:
 * mesh is what the rig was made for ("box" "auto", vertex constraints and
 * the method's own construction read it: its header says how) and is
 * only read during the call. The bound points are then mesh's vertices.
 * limits: NULL for the defaults (ffd_limits). Errors as ffd_rig_apply. */
FFD_API ffd_status ffd_deformer_create(const ffd_rig *rig, const ffd_mesh *mesh, const ffd_limits *limits,
                                       ffd_deformer **out, ffd_error *err);
/* As ffd_deformer_create from rig JSON text (name names it in errors; a file
 * the rig refers to is resolved relative to name's directory). */
FFD_API ffd_status ffd_deformer_create_json(const char *text, size_t size, const char *name,
                                            const ffd_mesh *mesh, const ffd_limits *limits,
                                            ffd_deformer **out, ffd_error *err);
FFD_API void ffd_deformer_destroy(ffd_deformer *d);
/* The method's name, as the rig's "deformer" key spells it. */
FFD_API const char *ffd_deformer_method(const ffd_deformer *d);
/* The method's own handle when the deformer is of that method (the handle
 * type the method's header names for ffd_deformer_handle), NULL otherwise.
 * Borrowed; method-specific edits made through it are seen by the next
 * evaluation. */
FFD_API void *ffd_deformer_handle(ffd_deformer *d, const char *method);

/* Binds n points given at rest (n by 3, copied): a second surface, a volume
 * mesh's nodes, one partition of a distributed mesh. Replaces the previous
 * binding; a point bound here deforms exactly as the same point would as a
 * vertex of the mesh. FFD_ERR_NONFINITE; on error the binding is unchanged. */
FFD_API ffd_status ffd_deformer_bind(ffd_deformer *d, const double *points, size_t n, ffd_error *err);
FFD_API size_t ffd_deformer_point_count(const ffd_deformer *d);
/* Deformed positions of the bound points, point_count by 3. */
FFD_API ffd_status ffd_deformer_eval(ffd_deformer *d, double *out, ffd_error *err);
/* Jacobians d(x')/d(x) of the map at the bound points, point_count by 9
 * row-major. FFD_ERR_UNSUPPORTED for a method without one. With the rig's
 * "weights" w_i and "strength" s (docs/constraints.md: x' = x + s w_i
 * (f(x) - x), for every method) it is I + s w_i (J_f - I) per point, and
 * linear-map rows and sensitivities are s w_i times the method's; a rig
 * with weights binds only point sets of the mesh's vertex count
 * (FFD_ERR_INVALID). "preserve"/"linear_constraints" and "fold_policy"
 * act on every control move of ffd_deformer_set_controls/_move_controls. */
FFD_API ffd_status ffd_deformer_jacobian(ffd_deformer *d, double *out, ffd_error *err);
/* The bound points' deformed positions as a linear map of the control
 * variables: rows are the bound points, and the tie maps every column to
 * the control it moves (variable j is control j, variable_count ==
 * ffd_deformer_control_count): x'_i = sum_c w_ic p_tie(c) plus what does not
 * depend on the controls. Borrows d until the next bind, control change,
 * method operation (e.g. a refinement) or destroy. FFD_ERR_UNSUPPORTED where the map is not linear in the controls. */
FFD_API ffd_status ffd_deformer_linear_map(ffd_deformer *d, ffd_linear_map *map, ffd_error *err);

/* The control variables: count, current positions (count by 3), positions
 * set (ids NULL: all count, in order) or moved by deltas (k by 3), and every
 * control back at rest. Setting goes through the method's own edit (with
 * whatever else that edit does, e.g. re-tracking: the method's header).
 * Moving adds the deltas to the linear map's variables: the controls'
 * positions, except a nested lattice's children, whose variables are their
 * own displacements (a root move in the same call carries them along as
 * well; ffd_lattice.h). FFD_ERR_RANGE for an id, FFD_ERR_NONFINITE; on
 * error nothing changed. */
FFD_API size_t ffd_deformer_control_count(const ffd_deformer *d);
FFD_API void ffd_deformer_controls(const ffd_deformer *d, double *out);
FFD_API ffd_status ffd_deformer_set_controls(ffd_deformer *d, const uint32_t *ids, size_t k,
                                             const double *positions, ffd_error *err);
FFD_API ffd_status ffd_deformer_move_controls(ffd_deformer *d, const uint32_t *ids, size_t k,
                                              const double *deltas, ffd_error *err);
FFD_API ffd_status ffd_deformer_reset(ffd_deformer *d, ffd_error *err);

/* Runs one of the method's own operations with its JSON body (size bytes;
 * 0: {}), exactly as the editor's operation of that name (docs/editor.md,
 * "Method operations"): "refine" and "freeze" (T-spline), "level", "frame"
 * and "curve" (PB-FFD), "primitive" (GFFD), "brush" (Kelvinlet). The binding is kept and the next
 * evaluation sees the change (a refinement may change the control count).
 * FFD_ERR_UNSUPPORTED for an op the method does not have (the message lists
 * its operations), FFD_ERR_PARSE for malformed JSON or a wrong key (named);
 * on error nothing changed. */
FFD_API ffd_status ffd_deformer_command(ffd_deformer *d, const char *op, const char *body,
                                        size_t size, ffd_error *err);
/* The deformer's state as a rig (JSON text, ffd_free): ffd_deformer_create
 * of it on the same mesh builds the same deformer (its controls where they
 * are now). */
FFD_API ffd_status ffd_deformer_rig(const ffd_deformer *d, char **json, size_t *size,
                                    ffd_error *err);

/* The method's report as JSON (ffd_free the text): {"method", "points",
 * "controls": {"count", ...the method's structure...}, "params": {...}};
 * the keys under "controls" and "params" are the method's (docs/api.md).
 * A rig with the generic layers adds "layers" (docs/constraints.md). */
FFD_API ffd_status ffd_deformer_report(const ffd_deformer *d, char **json, size_t *size, ffd_error *err);

/* The fold-over check of the deformer's map (docs/volume.md "Inverted
 * cells and fold-overs"): det J of the map sampled per cell of the method's
 * control structure, so a method can say "injective where you asked" or
 * where it is not. lattice: each lattice cell (B-spline: each knot span of
 * the tripled-border net, (l+1)(m+1)(n+1) cells; Bernstein: each cell of
 * the control grid, (l-1)(m-1)(n-1)) on a 5x5x5 grid at fractions 0,
 * 1/4, .., 1 of the cell (corners, edge and face midpoints, centre and
 * between: a cubic's derivative can turn negative between corners);
 * id = i + I (j + J k) with I, J the cells per axis. tspline: each T-mesh
 * cell of nonzero volume at 3^3 interior samples (ffd_tsv_check_folds).
 * pbffd and gffd: FFD_ERR_UNSUPPORTED (not done yet). */
typedef struct ffd_fold_report {
    const char *cells;      /* what a cell is ("lattice cell", "T-spline cell"); static */
    size_t cells_checked;
    size_t samples;         /* det J evaluations */
    size_t folded;          /* cells with det J <= 0 at a sample */
    double min_det;         /* smallest det J sampled (NaN when none) */
    uint32_t *cell_ids;     /* the folded cells, ascending (all of them); NULL when none */
} ffd_fold_report;
FFD_API ffd_status ffd_deformer_fold_check(ffd_deformer *d, ffd_fold_report *out, ffd_error *err);
FFD_API void ffd_fold_report_free(ffd_fold_report *report);

/* ======================================================================
 * Sensitivities: dX/dP of the bound points (docs/sensitivities.md)
 * ====================================================================== */

/* A sparse matrix in compressed rows (CSR), owned by the caller
 * (ffd_sparse_free): row r's entries are col[k], val[k] for k in
 * [row_ptr[r], row_ptr[r+1]); row_ptr has rows + 1 entries. */
typedef struct ffd_sparse {
    size_t rows, cols, nnz;
    size_t *row_ptr;
    uint32_t *col;
    double *val;
} ffd_sparse;
/* Frees the arrays and zeroes m (NULL-safe; a zeroed m is fine). */
FFD_API void ffd_sparse_free(ffd_sparse *m);

/* W = dX/dP of the bound points: rows are the bound points
 * (ffd_deformer_point_count), columns the control variables (column j is
 * control j of ffd_deformer_controls; ties merged as in direct
 * manipulation: a B-spline border slot's weight is added to the control it
 * follows; fixed slots dropped). The derivative of coordinate a of point i
 * with respect to coordinate b of control j is W_ij delta_ab
 * (dX/dP = W (x) I3). Duplicate entries merged, columns sorted in each row,
 * exact zeros left out (a basis function vanishing at the point).
 * out is overwritten (not freed first); on error it is zeroed.
 * Errors: FFD_ERR_UNSUPPORTED naming the method for one whose deformed
 * points are not linear in its controls (GFFD), FFD_ERR_NOMEM. */
FFD_API ffd_status ffd_deformer_sensitivities(ffd_deformer *d, ffd_sparse *out, ffd_error *err);
/* out (point_count by 3) = W v for v (control_count by 3): the change of the
 * deformed points for a change v of the controls, without forming W.
 * Errors as ffd_deformer_sensitivities, and FFD_ERR_INVALID for NULL. */
FFD_API ffd_status ffd_deformer_sensitivity_product(ffd_deformer *d, const double *v, double *out,
                                                    ffd_error *err);
/* out (control_count by 3) = W^T w for w (point_count by 3): the adjoint
 * product dJ/dP = (dX/dP)^T dJ/dX, without forming W. Bitwise identical for
 * any thread count. Errors as ffd_deformer_sensitivity_product. */
FFD_API ffd_status ffd_deformer_sensitivity_transpose_product(ffd_deformer *d, const double *w,
                                                              double *out, ffd_error *err);

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
    size_t autosave_max_bytes; /* rig text an autosave record keeps (ffd_session_autosave);
                                  default FFD_AUTOSAVE_MAX_BYTES */
} ffd_session_options;

/* Creates a session on mesh, which it takes over on success (destroyed with
 * the session; untouched on error). name labels the mesh (the file name). */
FFD_API ffd_status ffd_session_create(ffd_mesh *mesh, const char *name, const ffd_session_options *options,
                                      ffd_session **out, ffd_error *err);
FFD_API void ffd_session_destroy(ffd_session *s);
/* The rest mesh (positions as loaded) and its label. */
FFD_API const ffd_mesh *ffd_session_mesh(const ffd_session *s);
FFD_API const char *ffd_session_name(const ffd_session *s);

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
FFD_API ffd_status ffd_session_command(ffd_session *s, const char *op, const char *body, size_t size,
                                       void **reply, size_t *reply_size, int *binary, ffd_error *err);
/* The names of the operations ffd_session_command knows: the session's own,
 * then each method's (refine, frame, ...); NULL for i past the end. */
FFD_API const char *ffd_session_op_name(size_t i);

/* The state as JSON (mesh, method, parameters, control structure, pins,
 * undo/redo depth, revision): see docs/editor.md. ffd_free the text. */
FFD_API ffd_status ffd_session_state(const ffd_session *s, char **json, size_t *size, ffd_error *err);
/* The current frame (binary, little-endian, docs/editor.md): deformed vertex
 * positions, control positions and pin residuals as float32. */
FFD_API ffd_status ffd_session_frame(const ffd_session *s, void **data, size_t *size, ffd_error *err);
/* A frame as a delta frame (binary, docs/editor.md "Delta frames"): the
 * vertices whose float32 position changed since the frame of revision base
 * that the client holds (indices and positions), the normals of the
 * vertices around them, the controls and the residuals. frame (size bytes)
 * is a full frame of s just made (a drag step's reply or ffd_session_frame).
 * The session keeps the positions of the last frame it answered through
 * this function: when that is not base (UINT32_MAX: the client holds no
 * frame), or the delta would not be smaller than frame, *delta is NULL and
 * the client gets the full frame, which becomes the base of the next call.
 * ffd_free *delta. FFD_ERR_INVALID when frame is not a full frame of s;
 * FFD_ERR_NOMEM (nothing held changes: send the full frame). */
FFD_API ffd_status ffd_session_delta_frame(ffd_session *s, uint32_t base, const void *frame,
                                           size_t size, void **delta, size_t *delta_size,
                                           ffd_error *err);
/* The rest mesh's triangles (polygons fanned) and rest positions (binary). */
FFD_API ffd_status ffd_session_topology(const ffd_session *s, void **data, size_t *size, ffd_error *err);
/* The session's state as a rig (JSON text, ffd_free): replays with
 * ffd_rig_apply / ffd deform to the session's positions. FFD_ERR_INVALID
 * without a deformer. */
FFD_API ffd_status ffd_session_rig(const ffd_session *s, char **json, size_t *size, ffd_error *err);
/* Replaces the deformer by the one a rig builds (an undoable step). name
 * names the rig in errors; files a rig refers to are resolved
 * relative to name's directory and must lie under root (NULL: a rig that
 * refers to files is refused). On error nothing changes. */
FFD_API ffd_status ffd_session_load_rig(ffd_session *s, const char *text, size_t size, const char *name,
                                        const char *root, ffd_error *err);
/* Gives the session's deformer the vertex-group weights of a weights file's
 * text (size bytes; docs/constraints.md: one number in [0, 1] per vertex, in
 * vertex order, blank and '#' lines skipped), as the "weights" op's
 * {"values": [...]} does: one undo step, saved in the rig. name names the
 * file in errors. FFD_ERR_PARSE or NONFINITE (naming the line), INVALID (a
 * count other than the vertex count; no deformer or a drag in progress:
 * "conflict: ..."), RANGE (a weight outside [0, 1]). On error nothing
 * changes. */
FFD_API ffd_status ffd_session_load_weights(ffd_session *s, const char *text, size_t size,
                                            const char *name, ffd_error *err);
/* The deformed mesh in memory, in options->format (FFD_FORMAT_AUTO: the
 * format it was read in); ffd_free the data. */
FFD_API ffd_status ffd_session_export(const ffd_session *s, const ffd_write_options *options,
                                      void **data, size_t *size, ffd_error *err);
/* The deformed mesh (a new mesh, ffd_mesh_destroy it): the rest mesh with
 * the session's rig applied, exactly what ffd deform writes. */
FFD_API ffd_status ffd_session_deformed(const ffd_session *s, ffd_mesh **out, ffd_error *err);

/* Several meshes in one session (a character and its clothes), deformed by
 * the one deformer: the session's point set is the concatenation of the
 * meshes' vertices, mesh i owning the range the state's "meshes" gives
 * (first, vertices); ffd_session_mesh is then that concatenation (made
 * from arrays) and ffd_session_name the first mesh's name. Adding or
 * removing a mesh rebinds the deformer (rebuilt from its rig), keeps the
 * pins of the meshes that stay, and clears the undo history (it refers to
 * the old point set). Volume meshes stay alone.
 * ffd_session_add_mesh appends mesh (taken over on success, untouched on
 * error) named name; FFD_ERR_INVALID (a drag in progress, a volume mesh, no
 * vertices, too many vertices), FFD_ERR_NOMEM; on error nothing changes. */
FFD_API ffd_status ffd_session_add_mesh(ffd_session *s, ffd_mesh *mesh, const char *name,
                                        ffd_error *err);
/* Removes mesh index (also the op "remove_mesh" {"mesh": index});
 * FFD_ERR_RANGE, FFD_ERR_INVALID for the session's only mesh. */
FFD_API ffd_status ffd_session_remove_mesh(ffd_session *s, size_t index, ffd_error *err);
/* How many meshes (1 for a session of one mesh) and mesh index's name (NULL past the end). */
FFD_API size_t ffd_session_mesh_count(const ffd_session *s);
FFD_API const char *ffd_session_mesh_name(const ffd_session *s, size_t index);
/* Mesh index as read with the session's rig replayed on it alone (a new
 * mesh): what ffd deform writes for that mesh's file, and for a deformer
 * that does not depend on the other meshes (docs/editor.md) the mesh's
 * range of the session's positions. FFD_ERR_RANGE for an index past the end. */
FFD_API ffd_status ffd_session_deformed_mesh(const ffd_session *s, size_t index, ffd_mesh **out,
                                             ffd_error *err);
/* ffd_session_deformed_mesh written in options->format (FFD_FORMAT_AUTO:
 * the format that mesh was read in); ffd_free the data. */
FFD_API ffd_status ffd_session_export_mesh(const ffd_session *s, size_t index,
                                           const ffd_write_options *options, void **data,
                                           size_t *size, ffd_error *err);
/* Work is never lost (docs/editor.md "Work is never lost"). The history:
 * {"current": i, "steps": ["Open bunny.obj", "Create lattice 5×5×5", ...]},
 * the named steps of undo/redo, the present one current (the "history_goto"
 * op jumps to any of them); the state carries it as "history" too. */
FFD_API ffd_status ffd_session_history(const ffd_session *s, char **json, size_t *size,
                                       ffd_error *err);
/* The steps an autosave keeps: the newest, the present one among them. */
#define FFD_AUTOSAVE_STEPS 100
/* ... and at most this much rig text (ffd_session_options.autosave_max_bytes),
 * the present step always. */
#define FFD_AUTOSAVE_MAX_BYTES ((size_t)64 << 20)
/* The session's record as JSON text (ffd_free): the mesh (name, mesh_path
 * when not NULL, vertex and face counts, a hash of its positions and
 * faces), the rig with pins, and the history, each step's name and rig.
 * A conflict (FFD_ERR_INVALID) during a drag: only whole steps are saved. */
FFD_API ffd_status ffd_session_autosave_text(const ffd_session *s, const char *mesh_path,
                                             char **json, size_t *size, ffd_error *err);
/* Writes it to path atomically (a temporary file renamed over path). */
FFD_API ffd_status ffd_session_autosave(const ffd_session *s, const char *path,
                                        const char *mesh_path, ffd_error *err);
/* Brings back a record ffd_session_autosave wrote (name names it in
 * messages) into a session just created on the same mesh: its state,
 * pins and history. A record of another version of the mesh (its hash
 * differs), a malformed one, or a session with changes already is refused
 * and nothing changes. Either way the state's "autosave" says what
 * happened ({"resumed": true, "saved": time, ...} or {"resumed": false,
 * "reason": message, where the server keeps the record: kept_as}). */
FFD_API ffd_status ffd_session_resume(ffd_session *s, const char *text, size_t size,
                                      const char *name, const char *kept_as, ffd_error *err);
/* Names the file the session is autosaved to (NULL: not autosaved) in the
 * state's "autosave" ("file"), so that the page can say where work goes. */
FFD_API void ffd_session_set_autosave_file(ffd_session *s, const char *file);
/* Sets key of the state's "autosave" to a JSON value (NULL: removes it);
 * the server's notes to the page ("previous": an earlier record kept). */
FFD_API void ffd_session_note_autosave(ffd_session *s, const char *key, const char *json);

/* ======================================================================
 * Distributed runs: one mesh partitioned over processes (docs/mpi.md)
 * ====================================================================== */

/* The library knows no MPI. A caller that runs one mesh as pieces on
 * several processes (ranks) gives it a communicator of two callbacks; the
 * few global steps of a deformation go through them: the extent of the
 * whole mesh (min/max), the vertices the rig names by id (gathered from the
 * ranks that hold them), the boundary surface where a method reads one
 * (PB-FFD placement, the T-spline's occupancy, GFFD's fields; gathered),
 * counts (sums), and agreeing on failure, so that an error on one rank is
 * every rank's error and no rank waits forever. */
typedef enum ffd_reduce_op {
    FFD_REDUCE_SUM = 0,
    FFD_REDUCE_MIN,
    FFD_REDUCE_MAX,
    FFD_REDUCE_OR /* bitwise, FFD_REDUCE_UINT64 only */
} ffd_reduce_op;
typedef enum ffd_reduce_type { FFD_REDUCE_DOUBLE = 0, FFD_REDUCE_UINT64 } ffd_reduce_type;

typedef struct ffd_comm {
    int rank; /* this process, 0 .. size-1 */
    int size; /* the processes of the run */
    /* Reduces count values of type (double or uint64_t) in data, in place,
     * over every rank (MPI_Allreduce with MPI_IN_PLACE): every rank calls it
     * with the same count, type and op. Returns 0 on success. */
    int (*allreduce)(void *user, void *data, size_t count, ffd_reduce_type type,
                     ffd_reduce_op op);
    /* Every rank's bytes to every rank (MPI_Allgatherv of MPI_BYTE): rank r
     * gives mine (bytes long; bytes == sizes[r]); all (sum of sizes bytes)
     * receives them in rank order. sizes (size entries) is the same on every
     * rank, found beforehand by the library with allreduce. Returns 0 on
     * success. */
    int (*allgatherv)(void *user, const void *mine, size_t bytes, void *all,
                      const size_t *sizes);
    void *user;
} ffd_comm;

/* One rank's piece of a distributed mesh. */
typedef struct ffd_partition {
    const ffd_comm *comm;       /* NULL: one process (the piece is the whole mesh) */
    const uint64_t *global_ids; /* each of the piece's vertices' id in the whole mesh (the
                                   numbering a rig's vertex ids use: a VTU's GlobalNodeID, Gmsh's
                                   node tags); a vertex on several pieces has one id and the same
                                   position on each. NULL: rank-major (rank r's vertices follow
                                   those of ranks 0 .. r-1, in order) */
    const ffd_limits *limits;   /* NULL: the defaults */
} ffd_partition;

/* Every rank learns whether any failed: local is this rank's status (err
 * its message). All ranks call it. Returns FFD_OK when every rank's status
 * was FFD_OK; otherwise the status of the lowest failing rank, with err set
 * on every rank to "rank R: <its message>". A failing callback is FFD_ERR_IO. */
FFD_API ffd_status ffd_comm_agree(const ffd_comm *comm, ffd_status local, ffd_error *err);

/* The rig's deformer over a distributed mesh, bound to this rank's piece:
 * the global steps read the whole mesh through part->comm, so every rank
 * gets the same controls (rank 0's bits) and each point deforms exactly as
 * it would as a vertex of the whole mesh with ffd_deformer_create (bitwise,
 * for every method). Collective: every rank calls it, with its
 * piece (which may have no vertices). Vertex ids in the rig are global ids.
 * Refused (FFD_ERR_UNSUPPORTED, the same on every rank, the reason named):
 * what changes the partition (GFFD resampling) and the generic layers that
 * read per-vertex data of the whole mesh (weights, "preserve", linear
 * constraints over points). Errors as ffd_deformer_create, and
 * FFD_ERR_RANGE for a vertex id no rank holds. */
FFD_API ffd_status ffd_deformer_create_distributed(const ffd_rig *rig, const ffd_mesh *piece,
                                                   const ffd_partition *part,
                                                   ffd_deformer **out, ffd_error *err);

/* ffd_rig_apply on a distributed mesh: every rank deforms its piece as
 * ffd_rig_apply deforms those vertices of the whole mesh (bitwise; normals
 * through the Jacobian where the piece has normals). Collective. The report
 * is the same on every rank and is one process's (the method's report of
 * the rig applied to the gathered points: constraints' residuals and rank,
 * controls, details), with outside_count 0 (not counted over the pieces),
 * the details' "distributed" (ranks, piece_vertices, gathered_points,
 * gathered_faces), a note, and this rank's timings (solve: the global steps
 * and the rig's replay). On error no piece changed. */
FFD_API ffd_status ffd_rig_apply_distributed(const ffd_rig *rig, ffd_mesh *piece,
                                             const ffd_partition *part, ffd_rig_report *report,
                                             ffd_error *err);

/* The inversion check (ffd_mesh_check_inversions) of every rank's piece,
 * summed: counts added, worst values the minimum, the id lists kept only on
 * the rank whose cells they are (ids are local to each piece). A face on a
 * partition interface is a boundary face of both its pieces and is checked
 * on both. Collective. */
FFD_API ffd_status ffd_inversion_report_reduce(const ffd_comm *comm, ffd_inversion_report *report,
                                               ffd_error *err);

#ifdef __cplusplus
}
#endif

/* Each method's own API (its handle, options and operations) is in its
 * header, include/ffd_<method>.h; this list of them is the registry. */
#include "ffd_methods.h"

#endif /* FFD_H */
