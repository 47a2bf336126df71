/* math — 3D Voronoi vertices through Qhull (the one file that includes it).
 *
 * PB-FFD (McDonnell & Qin) §3.2.1 step 1 approximates the medial axis by the
 * Voronoi vertices of the surface samples. Qhull reports errors by printing
 * and longjmp'ing back to a setjmp of its caller; here its error stream is a
 * memory stream (never the terminal), every Qhull call runs under a setjmp,
 * and its exit codes become FFD_ERR_NUMERIC with Qhull's own first error line. */
#include "math/voronoi.h"

#include <libqhull_r/qhull_ra.h>

#include <ctype.h>
#include <limits.h>
#include <math.h>
#include <setjmp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The line of Qhull's captured output that says what went wrong: the first
 * one mentioning an error, else the first non-blank one; trimmed. */
static void first_error_line(const char *text, char *line, size_t cap)
{
    const char *pick = NULL, *pick_end = NULL, *p = text ? text : "";
    while (*p) {
        const char *e = strchr(p, '\n');
        if (!e)
            e = p + strlen(p);
        const char *b = p;
        while (b < e && isspace((unsigned char)*b))
            b++;
        const char *t = e;
        while (t > b && isspace((unsigned char)t[-1]))
            t--;
        if (t > b) {
            int mentions_error = 0;
            for (const char *q = b; q + 5 <= t && !mentions_error; q++)
                mentions_error = strncmp(q, "error", 5) == 0 || strncmp(q, "Error", 5) == 0;
            if (!pick || mentions_error) {
                pick = b;
                pick_end = t;
            }
            if (mentions_error)
                break;
        }
        p = *e ? e + 1 : e;
    }
    if (!pick) {
        snprintf(line, cap, "no message");
        return;
    }
    size_t len = (size_t)(pick_end - pick);
    if (len >= cap)
        len = cap - 1;
    memcpy(line, pick, len);
    line[len] = '\0';
}

/* qh_setvoronoi_all under its own setjmp: Qhull errors after qh_new_qhull
 * would otherwise exit the process. Returns 0 on success. */
static int set_centres(qhT *qh)
{
    if (setjmp(qh->errexit) != 0) {
        qh->NOerrexit = True;
        return 1;
    }
    qh->NOerrexit = False;
    qh_setvoronoi_all(qh);
    qh->NOerrexit = True;
    return 0;
}

/* Qhull marks a centre it could not compute (a flat cell) with qh_INFINITE. */
static int finite_centre(const coordT *c)
{
    if (!c)
        return 0;
    if (c[0] == qh_INFINITE && c[1] == qh_INFINITE && c[2] == qh_INFINITE)
        return 0;
    return isfinite(c[0]) && isfinite(c[1]) && isfinite(c[2]);
}

/* Shape quality of a simplicial Delaunay cell: 6 |volume| / (longest edge)^3
 * (sqrt(2)/2 for a regular tetrahedron, 0 for a flat one); 1 for a cell of
 * more than four cospherical sites (its centre is that of their sphere). */
static double cell_quality(qhT *qh, const facetT *facet)
{
    if (qh_setsize(qh, facet->vertices) != 4)
        return 1.0;
    const coordT *p[4];
    int i = 0;
    vertexT *vertex, **vertexp;
    FOREACHvertex_(facet->vertices) p[i++] = vertex->point;
    double e[3][3], longest = 0;
    for (int k = 0; k < 3; k++)
        for (int c = 0; c < 3; c++)
            e[k][c] = p[k + 1][c] - p[0][c];
    for (int a = 0; a < 4; a++)
        for (int b = a + 1; b < 4; b++) {
            double d2 = 0;
            for (int c = 0; c < 3; c++)
                d2 += (p[a][c] - p[b][c]) * (p[a][c] - p[b][c]);
            longest = fmax(longest, d2);
        }
    double vol6 = e[0][0] * (e[1][1] * e[2][2] - e[1][2] * e[2][1]) -
                  e[0][1] * (e[1][0] * e[2][2] - e[1][2] * e[2][0]) +
                  e[0][2] * (e[1][0] * e[2][1] - e[1][1] * e[2][0]);
    longest = sqrt(longest);
    return longest > 0 ? fabs(vol6) / (longest * longest * longest) : 0.0;
}

ffd_status ffd_voronoi_vertices(const double *points, size_t n, double min_quality, double **out,
                                size_t *count, ffd_error *err)
{
    if (out)
        *out = NULL;
    if (count)
        *count = 0;
    if (!out || !count || (!points && n))
        return ffd_fail(err, FFD_ERR_INVALID, "ffd_voronoi_vertices: NULL argument");
    if (n < 5)
        return ffd_fail(err, FFD_ERR_INVALID,
                        "Voronoi diagram: %zu sites, need at least 5 (not all coplanar)", n);
    if (n > (size_t)INT_MAX / 4)
        return ffd_fail(err, FFD_ERR_INVALID, "Voronoi diagram: %zu sites, Qhull takes at most %d",
                        n, INT_MAX / 4);
    for (size_t i = 0; i < 3 * n; i++)
        if (!isfinite(points[i]))
            return ffd_fail(err, FFD_ERR_NONFINITE, "Voronoi diagram: site %zu is not finite",
                            i / 3);

    ffd_status status = FFD_OK;
    coordT *sites = ffd_malloc_array(3 * n, sizeof *sites);
    qhT *qh = ffd_malloc(sizeof *qh);
    double *centres = NULL;
    char *captured = NULL;
    size_t captured_size = 0;
    FILE *errfile = NULL;
    if (!sites || !qh) {
        status = ffd_fail(err, FFD_ERR_NOMEM, "Voronoi diagram: out of memory");
        goto done;
    }
    errfile = open_memstream(&captured, &captured_size);
    if (!errfile) {
        status = ffd_fail(err, FFD_ERR_NOMEM, "Voronoi diagram: cannot open a message stream");
        goto done;
    }
    memcpy(sites, points, 3 * n * sizeof *sites);

    /* v: Voronoi (Delaunay of the lifted sites); Qbb: scale the lifted
     * coordinate, which keeps large coordinates precise. */
    char command[] = "qhull v Qbb Qz";
    qh_zero(qh, errfile);
    int exitcode = qh_new_qhull(qh, 3, (int)n, sites, False, command, NULL, errfile);
    if (exitcode == 0 && set_centres(qh) != 0)
        exitcode = qh_ERRqhull;
    if (exitcode == 0) {
        size_t cap = 0, k = 0;
        facetT *facet;
        FORALLfacets {
            if (!facet->upperdelaunay)
                cap++;
        }
        centres = ffd_malloc_array(cap ? 3 * cap : 1, sizeof *centres);
        if (!centres) {
            status = ffd_fail(err, FFD_ERR_NOMEM, "Voronoi diagram: out of memory");
        } else {
            FORALLfacets {
                if (facet->upperdelaunay || !finite_centre(facet->center) ||
                    (min_quality > 0 && !(cell_quality(qh, facet) >= min_quality)))
                    continue;
                memcpy(centres + 3 * k, facet->center, 3 * sizeof *centres);
                k++;
            }
            *count = k;
        }
    }
    int curlong = 0, totlong = 0;
    qh_freeqhull(qh, !qh_ALL);
    qh_memfreeshort(qh, &curlong, &totlong);
    fclose(errfile);
    errfile = NULL;
    if (exitcode != 0) {
        char line[400];
        first_error_line(captured, line, sizeof line);
        status = ffd_fail(err, FFD_ERR_NUMERIC, "Voronoi diagram of %zu sites: Qhull failed: %s",
                          n, line);
    }

done:
    if (errfile)
        fclose(errfile);
    free(captured); /* open_memstream's buffer belongs to the C library */
    ffd_free(sites);
    ffd_free(qh);
    if (status != FFD_OK) {
        ffd_free(centres);
        *count = 0;
        return status;
    }
    *out = centres;
    return FFD_OK;
}
