/* fuzz_mesh — libFuzzer target for one mesh reader (FUZZ_FORMAT: OBJ, PLY,
 * VTK, VTU, MSH, SU2, XYZ, NPY,
 * OFF, STL or GLTF, set by the build: one binary per format). A mesh that reads
 * is written back in its own format and read again: the writer and the
 * lossless round trip are fuzzed too. */
#include "ffd.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#ifndef FUZZ_FORMAT
#define FUZZ_FORMAT FFD_FORMAT_OBJ
#endif

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    ffd_mesh *mesh = NULL;
    ffd_error err = {{0}};
    if (ffd_mesh_read_memory(data, size, FUZZ_FORMAT, "fuzz", &mesh, &err) != FFD_OK) {
        if (!err.message[0])
            abort(); /* every error has a message */
        return 0;
    }
    ffd_mesh_info info;
    (void)ffd_mesh_compute_info(mesh, &info, &err);
    unsigned char *out = NULL;
    size_t out_size = 0;
    ffd_write_options o = {FUZZ_FORMAT, FFD_ENCODING_SAME, 0};
    if (ffd_mesh_write_memory(mesh, &o, &out, &out_size, &err) == FFD_OK) {
        ffd_mesh *again = NULL;
        /* what we write we must read back */
        if (ffd_mesh_read_memory(out, out_size, FUZZ_FORMAT, "fuzz-rewritten", &again, &err) != FFD_OK)
            abort();
        if (ffd_mesh_vertex_count(again) != ffd_mesh_vertex_count(mesh))
            abort();
        ffd_mesh_destroy(again);
    }
    ffd_free(out);
    ffd_mesh_destroy(mesh);
    return 0;
}
