/* fuzz_rig — libFuzzer target for the rig loaders: JSON (FUZZ_PRM unset)
 * or PyGeM .prm parameter files (FUZZ_PRM). A rig that parses is applied to
 * a small cube when its deformer is cheap enough to build (resolutions and
 * counts are bounded here, not by the parser, so that each input stays
 * fast). */
#include "ffd.h"
#include "gffd/gffd_method.h"
#include "pbffd/pbffd_method.h"
#include "tspline/tspline_method.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static ffd_mesh *cube(void)
{
    static const double p[8][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0},
                                   {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
    static const uint32_t idx[24] = {0, 3, 2, 1, 4, 5, 6, 7, 0, 1, 5, 4,
                                     1, 2, 6, 5, 2, 3, 7, 6, 3, 0, 4, 7};
    static const uint32_t off[7] = {0, 4, 8, 12, 16, 20, 24};
    ffd_mesh *m = NULL;
    ffd_mesh_create(&p[0][0], 8, off, idx, 6, &m, NULL);
    return m;
}

/* Only rigs whose deformer is small: the fuzzer looks for crashes, not for
 * the (documented) cost of a 1024^3 lattice. */
static int cheap(const ffd_rig *rig)
{
    const uint32_t *r = rig->method == &ffd_method_tspline ? ffd_rig_tspline_of(rig)->resolution : rig->resolution;
    if ((double)r[0] * r[1] * r[2] > 4096)
        return 0;
    if (rig->method == &ffd_method_pbffd)
        return ffd_rig_pbffd_of(rig)->controls_auto ? 0 : ffd_rig_pbffd_of(rig)->control_count <= 64;
    if (rig->method == &ffd_method_gffd)
        return ffd_rig_gffd_of(rig)->options.max_samples != 0 && ffd_rig_gffd_of(rig)->options.max_samples <= 200 &&
               ffd_rig_gffd_of(rig)->options.max_iterations <= 100 && ffd_rig_gffd_of(rig)->resample == 0 &&
               ffd_rig_gffd_of(rig)->skeleton_count + ffd_rig_gffd_of(rig)->replace_count <= 4;
    if (rig->method == &ffd_method_tspline)
        return ffd_rig_tspline_of(rig)->step_count <= 4;
    return 1;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    ffd_rig *rig = NULL;
    ffd_error err = {{0}};
#ifdef FUZZ_PRM
    ffd_status st = ffd_rig_parse_prm((const char *)data, size, "fuzz.prm", &rig, &err);
#else
    ffd_status st = ffd_rig_parse_json((const char *)data, size, "fuzz.json", &rig, &err);
#endif
    if (st != FFD_OK) {
        if (!err.message[0] || rig)
            abort();
        return 0;
    }
    if (cheap(rig)) {
        ffd_mesh *m = cube();
        ffd_rig_report report = {0};
        if (m && ffd_rig_apply(rig, m, &report, &err) != FFD_OK && !err.message[0])
            abort();
        ffd_rig_report_free(&report);
        ffd_mesh_destroy(m);
    }
    ffd_rig_destroy(rig);
    return 0;
}
