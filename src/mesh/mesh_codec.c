/* mesh_codec — the table of mesh codecs (one per file format) and its
 * look-ups. A new format adds its line here (see mesh_codec.h). */
#include "mesh_codec.h"

#include <stdio.h>
#include <strings.h>

/* In ffd_format order; messages list the formats in this order. */
static const ffd_mesh_codec *const codecs[] = {
    &ffd_mesh_codec_obj,
    &ffd_mesh_codec_ply,
    &ffd_mesh_codec_off,
    &ffd_mesh_codec_stl,
    &ffd_mesh_codec_gltf,
    &ffd_mesh_codec_vtk,
    &ffd_mesh_codec_vtu,
    &ffd_mesh_codec_msh,
    &ffd_mesh_codec_su2,
    &ffd_mesh_codec_xyz,
    &ffd_mesh_codec_npy,
};
#define CODEC_COUNT (sizeof codecs / sizeof codecs[0])

const ffd_mesh_codec *ffd_mesh_codec_find(ffd_format format)
{
    for (size_t i = 0; i < CODEC_COUNT; i++)
        if (codecs[i]->format == format)
            return codecs[i];
    return NULL;
}

const ffd_mesh_codec *ffd_mesh_codec_for_extension(const char *ext)
{
    for (size_t i = 0; i < CODEC_COUNT; i++)
        for (const char *const *e = codecs[i]->extensions; *e; e++)
            if (strcasecmp(ext, *e) == 0)
                return codecs[i];
    return NULL;
}

const char *ffd_mesh_codec_list(bool names, char *buf, size_t size)
{
    size_t at = 0;
    buf[0] = 0;
    for (size_t i = 0; i < CODEC_COUNT && at < size; i++) {
        const char *sep = i == 0 ? "" : i + 1 == CODEC_COUNT ? " or " : ", ";
        int n = names ? snprintf(buf + at, size - at, "%s%s", sep, codecs[i]->name)
                      : snprintf(buf + at, size - at, "%s.%s", sep, codecs[i]->extensions[0]);
        if (n < 0)
            break;
        at += (size_t)n;
    }
    return buf;
}
