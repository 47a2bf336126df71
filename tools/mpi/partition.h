/* partition — the partitioned-mesh formats of ffd-mpi (docs/mpi.md): which
 * file is a rank's piece, where its deformed piece goes, and the global ids of
 * its vertices. No MPI here: the compare tool of the tests (tests/mpi) uses
 * it too. */
#ifndef FFD_MPI_PARTITION_H
#define FFD_MPI_PARTITION_H

#include "ffd.h"

#include <stdint.h>

typedef enum part_kind {
    PART_PVTU,   /* a .pvtu naming its .vtu pieces (<Piece Source="..."/>, piece r is rank r's) */
    PART_MSH,    /* mesh.msh: Gmsh's split pieces mesh_1.msh .. mesh_N.msh next to it */
    PART_PATTERN /* a name with one %d (or %0Nd): rank r's piece is the name with r for it */
} part_kind;

/* One rank's part of a run: its piece, its output, and (PVTU) the index file
 * rank 0 writes. Strings are malloc'd; part_plan_free frees them. */
typedef struct part_plan {
    part_kind kind;
    size_t piece_count; /* the pieces PARTS names (PVTU, MSH) or the ranks (PATTERN) */
    char *piece;        /* this rank's input piece */
    char *out_piece;    /* this rank's output piece */
    char *out_index;    /* PVTU: the output .pvtu; else NULL */
    char *index_text;   /* PVTU: its text (the input's, Source names replaced) */
    size_t index_size;
} part_plan;

/* The plan of rank `rank` of `size` ranks for input PARTS and output OUT.
 * FFD_ERR_INVALID naming what is wrong (OUT's kind differs from PARTS', a
 * pattern without %d, pieces count != ranks naming both), FFD_ERR_PARSE
 * ("x.pvtu:LINE: ...") for a .pvtu that cannot be read, FFD_ERR_IO. */
ffd_status part_plan_make(const char *parts, const char *out, int rank, int size, part_plan *plan,
                          ffd_error *err);
void part_plan_free(part_plan *plan);

/* The global id of each of the piece's vertices (*ids, malloc'd, vertex
 * count entries; NULL when the piece names none: rank-major numbering):
 * Gmsh node tags minus one, or the point field / PLY vertex property / OBJ
 * "#NAME" lines named GlobalNodeID, GlobalNodeIds or vtkGlobalIds (the
 * first found; each value a whole number in 0 .. 2^53). *source is what
 * they came from, for messages ("node tags", "GlobalNodeID", "none").
 * Errors name path (the piece). */
ffd_status part_global_ids(const ffd_mesh *piece, const char *path, uint64_t **ids,
                           const char **source, ffd_error *err);

#endif
