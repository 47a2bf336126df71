/* Benchmark: PB-FFD automatic placement (ffd_pbffd_place, McDonnell & Qin §3.2.1) on the
 * cow (2.9K vertices) and the refined elephant (44K vertices), 100 interior + 100 exterior
 * points, with the Voronoi diagram built from all vertices, the default subsample (8000)
 * and every fourth vertex.
 * Usage: bench_placement [DATA_DIR] [--quick]   (DATA_DIR defaults to the repository's data/;
 * results go to docs/benchmarks.md by hand)
 *
 * Quality of a subsample, against the interior points placed with all vertices as sites:
 * "to ref" is the mean distance from each reference interior point to the nearest interior
 * point of the variant, "from ref" the same the other way, both relative to the bounding-box
 * diagonal (for scale, "spacing" is the mean distance between neighbouring reference interior
 * points, also relative to the diagonal); "inside" is the fraction of the Voronoi vertices
 * kept as interior candidates. */
#include "ffd.h"
#include "bench_util.h"

#include <math.h>
#include <omp.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static double mean_nearest(const ffd_ebf *from, size_t nf, const ffd_ebf *to, size_t nt)
{
    double sum = 0;
    for (size_t i = 0; i < nf; i++) {
        double best = INFINITY;
        for (size_t j = 0; j < nt; j++) {
            double d = 0;
            for (int a = 0; a < 3; a++)
                d += (from[i].center[a] - to[j].center[a]) * (from[i].center[a] - to[j].center[a]);
            best = fmin(best, d);
        }
        sum += sqrt(best);
    }
    return nf ? sum / (double)nf : 0;
}

typedef struct run {
    ffd_ebf *controls;
    size_t count;
    ffd_placement_report rep; /* of the median-time repetition */
    double seconds_voronoi, seconds_total; /* medians */
} run;

static int place(const ffd_mesh *m, size_t sites, int reps, run *r)
{
    ffd_placement_options o = {0};
    o.interior_count = 100;
    o.exterior_count = 100;
    o.voronoi_sites = sites;
    double tv[64], tt[64];
    memset(r, 0, sizeof *r);
    for (int k = 0; k < reps; k++) {
        ffd_ebf *c = NULL;
        size_t n = 0;
        ffd_error err = {{0}};
        if (ffd_pbffd_place(m, &o, &c, &n, &r->rep, &err) != FFD_OK) {
            fprintf(stderr, "placement failed: %s\n", err.message);
            return 1;
        }
        tv[k] = r->rep.seconds_voronoi;
        tt[k] = r->rep.seconds_total;
        ffd_free(r->controls);
        r->controls = c;
        r->count = n;
    }
    qsort(tv, (size_t)reps, sizeof *tv, bench_cmp_double);
    qsort(tt, (size_t)reps, sizeof *tt, bench_cmp_double);
    r->seconds_voronoi = tv[reps / 2];
    r->seconds_total = tt[reps / 2];
    return 0;
}

int main(int argc, char **argv)
{
    const char *dir = NULL;
    int quick = 0;
    for (int i = 1; i < argc; i++) {
        if (strcmp(argv[i], "--quick") == 0)
            quick = 1;
        else
            dir = argv[i];
    }
    char fallback[1024];
    if (!dir) {
        /* __FILE__ is <root>/bench/bench_placement.c; the data lives in <root>/data */
        snprintf(fallback, sizeof fallback, "%s", __FILE__);
        char *slash = strrchr(fallback, '/');
        if (slash)
            *slash = '\0';
        else
            snprintf(fallback, sizeof fallback, ".");
        strncat(fallback, "/../data", sizeof fallback - strlen(fallback) - 1);
        dir = fallback;
    }
    const char *meshes[] = {"cow.off", "refined_elephant.off"};
    int reps = quick ? 1 : 5;
    printf("threads: %d, 100 interior + 100 exterior points, median of %d\n",
           omp_get_max_threads(), reps);
    printf("| mesh | vertices | Voronoi sites | Voronoi vertices | inside | Qhull s | total s |"
           " to ref | from ref | spacing |\n");
    printf("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
    for (size_t mi = 0; mi < sizeof meshes / sizeof *meshes; mi++) {
        char path[1200];
        snprintf(path, sizeof path, "%s/%s", dir, meshes[mi]);
        ffd_mesh *m = NULL;
        ffd_error err = {{0}};
        if (ffd_mesh_read(path, &m, &err) != FFD_OK) {
            fprintf(stderr, "%s\n", err.message);
            return 1;
        }
        ffd_mesh_info info;
        ffd_mesh_compute_info(m, &info, NULL);
        double diag = 0;
        for (int a = 0; a < 3; a++)
            diag += (info.bbox_max[a] - info.bbox_min[a]) * (info.bbox_max[a] - info.bbox_min[a]);
        diag = sqrt(diag);
        size_t nv = ffd_mesh_vertex_count(m);
        const size_t variants[] = {SIZE_MAX, 0, (nv + 3) / 4};
        const char *names[] = {"all", "default", "every 4th"};
        run ref = {0};
        for (int v = 0; v < 3; v++) {
            run r;
            if (place(m, variants[v], reps, &r) != 0)
                return 1;
            double to = 0, from = 0, spacing = 0;
            if (v == 0) {
                ref = r;
                size_t ni = r.rep.interior_count;
                for (size_t i = 0; i < ni; i++) { /* nearest other interior point */
                    double best = INFINITY;
                    for (size_t j = 0; j < ni; j++)
                        if (j != i)
                            best = fmin(best, mean_nearest(r.controls + i, 1, r.controls + j, 1));
                    spacing += best;
                }
                spacing /= (double)ni * diag;
            } else {
                size_t ni = r.rep.interior_count, nr = ref.rep.interior_count;
                to = mean_nearest(ref.controls, nr, r.controls, ni) / diag;
                from = mean_nearest(r.controls, ni, ref.controls, nr) / diag;
            }
            char sites[64];
            snprintf(sites, sizeof sites, "%zu (%s)", r.rep.voronoi_sites, names[v]);
            char sp[32] = "";
            if (v == 0)
                snprintf(sp, sizeof sp, "%.4f", spacing);
            printf("| %s | %zu | %s | %zu | %.1f%% | %.3f | %.3f | %.4f | %.4f | %s |\n",
                   meshes[mi], nv, sites, r.rep.voronoi_vertices,
                   100.0 * (double)r.rep.inside_vertices / (double)r.rep.voronoi_vertices,
                   r.seconds_voronoi, r.seconds_total, to, from, sp);
            fflush(stdout);
            if (v != 0)
                ffd_free(r.controls);
        }
        ffd_free(ref.controls);
        ffd_mesh_destroy(m);
    }
    return 0;
}
