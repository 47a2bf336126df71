/* mesh_msh.c — MSH codec: placeholder until V3 lands it (issue 19). */
#include "mesh_cells.h"
#include "mesh_codec.h"

static ffd_status read_msh(ffd_mesh *m, const char *name, ffd_error *err)
{
    (void)m;
    return ffd_fail(err, FFD_ERR_UNSUPPORTED, "%s: MSH reading is not built yet", name);
}

static ffd_status write_msh(const ffd_mesh *m, ffd_encoding enc, ffd_buf *b, ffd_error *err)
{
    (void)m;
    (void)enc;
    (void)b;
    return ffd_fail(err, FFD_ERR_UNSUPPORTED, "MSH writing is not built yet");
}

static const char *const msh_extensions[] = {"msh", NULL};

const ffd_mesh_codec ffd_mesh_codec_msh = {
    .format = FFD_FORMAT_MSH,
    .name = "MSH",
    .extensions = msh_extensions,
    .encodings = FFD_CODEC_ENCODING(FFD_ENCODING_ASCII) | FFD_CODEC_ENCODING(FFD_ENCODING_BINARY_LE),
    .read = read_msh,
    .patch = ffd_mesh_patch_spans,
    .write = write_msh,
};
