/* mesh_npy.c — NPY codec: placeholder until V4 lands it (issue 19). */
#include "mesh_cells.h"
#include "mesh_codec.h"

static ffd_status read_npy(ffd_mesh *m, const char *name, ffd_error *err)
{
    (void)m;
    return ffd_fail(err, FFD_ERR_UNSUPPORTED, "%s: NPY reading is not built yet", name);
}

static ffd_status write_npy(const ffd_mesh *m, ffd_encoding enc, ffd_buf *b, ffd_error *err)
{
    (void)m;
    (void)enc;
    (void)b;
    return ffd_fail(err, FFD_ERR_UNSUPPORTED, "NPY writing is not built yet");
}

static const char *const npy_extensions[] = {"npy", NULL};

const ffd_mesh_codec ffd_mesh_codec_npy = {
    .format = FFD_FORMAT_NPY,
    .name = "NPY",
    .extensions = npy_extensions,
    .encodings = FFD_CODEC_ENCODING(FFD_ENCODING_BINARY_LE) | FFD_CODEC_ENCODING(FFD_ENCODING_BINARY_BE),
    .read = read_npy,
    .patch = ffd_mesh_patch_spans,
    .write = write_npy,
};
