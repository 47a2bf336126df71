/* mesh_vtk.c — VTK codec: placeholder until V1 lands it (issue 19). */
#include "mesh_cells.h"
#include "mesh_codec.h"

static ffd_status read_vtk(ffd_mesh *m, const char *name, ffd_error *err)
{
    (void)m;
    return ffd_fail(err, FFD_ERR_UNSUPPORTED, "%s: VTK reading is not built yet", name);
}

static ffd_status write_vtk(const ffd_mesh *m, ffd_encoding enc, ffd_buf *b, ffd_error *err)
{
    (void)m;
    (void)enc;
    (void)b;
    return ffd_fail(err, FFD_ERR_UNSUPPORTED, "VTK writing is not built yet");
}

static const char *const vtk_extensions[] = {"vtk", NULL};

const ffd_mesh_codec ffd_mesh_codec_vtk = {
    .format = FFD_FORMAT_VTK,
    .name = "VTK",
    .extensions = vtk_extensions,
    .encodings = FFD_CODEC_ENCODING(FFD_ENCODING_ASCII) | FFD_CODEC_ENCODING(FFD_ENCODING_BINARY_BE),
    .read = read_vtk,
    .patch = ffd_mesh_patch_spans,
    .write = write_vtk,
};
