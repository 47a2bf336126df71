/* session_frame — delta frames for drag steps (docs/editor.md "Delta frames").
 *
 * A drag step changes only the vertices in the support of what moved, so the
 * editor's page asks for the changes since the frame it holds (its revision,
 * the "base") instead of every position. The session keeps the float32
 * positions of the last frame it sent to such a request (only a frame it
 * sent: a client holding a frame of another session or of an earlier run of
 * the server gets the full frame) and compares: a vertex is in the delta
 * when any of its three float32 coordinates differs in its bits from what
 * the client holds, so the
 * client's copy after applying the delta equals the full frame bit for bit.
 * The normals of the vertices around a changed one (the corners of every
 * triangle touching a changed vertex) come with it, area-weighted over the
 * fan triangulation the topology reply sends, computed from the float32
 * positions the client draws, so the page recomputes nothing on its main
 * thread. When the delta would not be smaller than the full frame (most of
 * the mesh moved) the client gets the full frame instead. */
#include "session/session.h"

#include "mesh/mesh.h"

#include <math.h>
#include <string.h>

struct sess_frames {
    const ffd_mesh *mesh;  /* the mesh the adjacency was built for */
    size_t n;
    float *sent;           /* n by 3: the positions of the last frame sent */
    uint32_t revision;     /* its revision */
    int held;              /* a frame was sent: sent and revision hold it */
    /* triangles (the topology reply's fan triangulation) around each vertex */
    uint32_t *tri;         /* 3 per triangle */
    uint32_t *vt_off;      /* n + 1 */
    uint32_t *vt_tri;      /* triangle ids, ascending per vertex */
    size_t tri_count;
    /* per-step scratch */
    uint32_t *changed;     /* n */
    uint32_t *ring;        /* n */
    unsigned char *mark;   /* n */
    uint32_t *faces;       /* tri_count: the triangles around the ring */
    unsigned char *fmark;  /* tri_count */
    double *cross;         /* tri_count by 3: their cross products (twice the area vector) */
};

enum { DELTA_HEAD = 36 };

void ffd_sess_frames_free(sess_frames *f)
{
    if (!f)
        return;
    ffd_free(f->sent);
    ffd_free(f->tri);
    ffd_free(f->vt_off);
    ffd_free(f->vt_tri);
    ffd_free(f->changed);
    ffd_free(f->ring);
    ffd_free(f->mark);
    ffd_free(f->faces);
    ffd_free(f->fmark);
    ffd_free(f->cross);
    ffd_free(f);
}

/* The fan triangulation and the triangles around each vertex (counting sort
 * by vertex, so each list is in ascending triangle order). */
static int build_adjacency(sess_frames *f, const ffd_mesh *mesh, size_t n)
{
    size_t nf = ffd_mesh_face_count(mesh);
    const uint32_t *off = ffd_mesh_face_offsets(mesh), *idx = ffd_mesh_face_indices(mesh);
    size_t t = 0;
    for (size_t i = 0; i < nf; i++)
        t += off[i + 1] - off[i] >= 3 ? off[i + 1] - off[i] - 2 : 0;
    if (3 * t > UINT32_MAX)
        return 0;
    f->tri = ffd_malloc_array(t ? 3 * t : 1, sizeof *f->tri);
    f->vt_off = ffd_calloc(n + 1, sizeof *f->vt_off);
    f->vt_tri = ffd_malloc_array(t ? 3 * t : 1, sizeof *f->vt_tri);
    f->tri_count = t;
    f->faces = ffd_malloc_array(t ? t : 1, sizeof *f->faces);
    f->fmark = ffd_calloc(t ? t : 1, 1);
    f->cross = ffd_malloc_array(t ? t : 1, 3 * sizeof *f->cross);
    if (!f->tri || !f->vt_off || !f->vt_tri || !f->faces || !f->fmark || !f->cross)
        return 0;
    size_t w = 0;
    for (size_t i = 0; i < nf; i++)
        for (uint32_t c = off[i] + 1; c + 1 < off[i + 1]; c++) {
            f->tri[w++] = idx[off[i]];
            f->tri[w++] = idx[c];
            f->tri[w++] = idx[c + 1];
        }
    for (size_t k = 0; k < 3 * t; k++)
        f->vt_off[f->tri[k] + 1]++;
    for (size_t v = 0; v < n; v++)
        f->vt_off[v + 1] += f->vt_off[v];
    /* fill with a moving cursor per vertex (vt_off shifted back afterwards) */
    for (size_t k = 0; k < 3 * t; k++)
        f->vt_tri[f->vt_off[f->tri[k]]++] = (uint32_t)(k / 3);
    for (size_t v = n; v > 0; v--)
        f->vt_off[v] = f->vt_off[v - 1];
    f->vt_off[0] = 0;
    return 1;
}

ffd_status ffd_sess_frames_make(sess_frames **fp, const ffd_mesh *mesh, size_t n, ffd_error *err)
{
    sess_frames *f = *fp;
    if (f && f->mesh == mesh && f->n == n)
        return FFD_OK;
    ffd_sess_frames_free(f);
    *fp = NULL;
    f = ffd_calloc(1, sizeof *f);
    if (!f)
        return ffd_fail(err, FFD_ERR_NOMEM, "delta frame: out of memory");
    f->mesh = mesh;
    f->n = n;
    f->sent = ffd_malloc_array(n, 3 * sizeof *f->sent);
    f->changed = ffd_malloc_array(n, sizeof *f->changed);
    f->ring = ffd_malloc_array(n, sizeof *f->ring);
    f->mark = ffd_calloc(n, 1);
    if (!f->sent || !f->changed || !f->ring || !f->mark || !build_adjacency(f, mesh, n)) {
        ffd_sess_frames_free(f);
        return ffd_fail(err, FFD_ERR_NOMEM, "delta frame: out of memory for %zu vertices", n);
    }
    *fp = f;
    return FFD_OK;
}

/* The cross product of triangle t's edges from the float32 positions p. */
static void triangle_cross(const sess_frames *f, const float *p, uint32_t t, double *out)
{
    const uint32_t *c = f->tri + 3 * (size_t)t;
    const float *a = p + 3 * (size_t)c[0], *b = p + 3 * (size_t)c[1], *d = p + 3 * (size_t)c[2];
    double e1[3] = {(double)b[0] - a[0], (double)b[1] - a[1], (double)b[2] - a[2]};
    double e2[3] = {(double)d[0] - a[0], (double)d[1] - a[1], (double)d[2] - a[2]};
    out[0] = e1[1] * e2[2] - e1[2] * e2[1];
    out[1] = e1[2] * e2[0] - e1[0] * e2[2];
    out[2] = e1[0] * e2[1] - e1[1] * e2[0];
}

/* Area-weighted normal of vertex v: the sum of its triangles' cross products
 * (f->cross, in ascending triangle order), normalised; (0, 1, 0) where it
 * vanishes. */
static void vertex_normal(const sess_frames *f, uint32_t v, float out[3])
{
    double n[3] = {0, 0, 0};
    for (uint32_t k = f->vt_off[v]; k < f->vt_off[v + 1]; k++) {
        const double *x = f->cross + 3 * (size_t)f->vt_tri[k];
        n[0] += x[0];
        n[1] += x[1];
        n[2] += x[2];
    }
    double l = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    if (l > 0) {
        out[0] = (float)(n[0] / l);
        out[1] = (float)(n[1] / l);
        out[2] = (float)(n[2] / l);
    } else {
        out[0] = 0;
        out[1] = 1;
        out[2] = 0;
    }
}

ffd_status ffd_sess_frames_delta(sess_frames *f, uint32_t base, const void *frame, size_t size,
                                 void **delta, size_t *delta_size, ffd_error *err)
{
    *delta = NULL;
    *delta_size = 0;
    uint32_t head[5];
    if (size < 20 || (memcpy(head, frame, 20), memcmp(head, "FFDF", 4) != 0))
        return ffd_fail(err, FFD_ERR_INVALID, "delta frame: not a frame");
    size_t n = head[2], c = head[3], r = head[4];
    if (size != 20 + 4 * (3 * n + 3 * c + r))
        return ffd_fail(err, FFD_ERR_INVALID, "delta frame: frame of %zu bytes, expected %zu", size,
                        20 + 4 * (3 * n + 3 * c + r));
    const float *x = (const float *)(const void *)((const unsigned char *)frame + 20);
    if (!f || f->n != n)
        return FFD_OK; /* nothing held: the full frame */
    if (!f->held || base == UINT32_MAX || f->revision != base) {
        /* the client holds another frame (or none the session sent): it gets
         * this full one, the base of the next */
        memcpy(f->sent, x, 12 * n);
        f->revision = head[1];
        f->held = 1;
        return FFD_OK;
    }
    /* the vertices whose float32 bits changed */
    size_t k = 0;
    for (size_t v = 0; v < n; v++)
        if (memcmp(f->sent + 3 * v, x + 3 * v, 12) != 0)
            f->changed[k++] = (uint32_t)v;
    /* their normals' ring: every corner of every triangle at a changed vertex */
    for (size_t i = 0; i < k; i++) {
        uint32_t v = f->changed[i];
        for (uint32_t j = f->vt_off[v]; j < f->vt_off[v + 1]; j++) {
            const uint32_t *t = f->tri + 3 * (size_t)f->vt_tri[j];
            f->mark[t[0]] = f->mark[t[1]] = f->mark[t[2]] = 1;
        }
    }
    size_t m = 0;
    for (size_t v = 0; v < n; v++)
        if (f->mark[v]) {
            f->mark[v] = 0;
            f->ring[m++] = (uint32_t)v;
        }
    size_t bytes = DELTA_HEAD + 16 * k + 16 * m + 4 * (3 * c + r);
    if (bytes >= size) {
        /* the delta would be larger: the full frame, which the client will hold */
        for (size_t i = 0; i < k; i++)
            memcpy(f->sent + 3 * (size_t)f->changed[i], x + 3 * (size_t)f->changed[i], 12);
        f->revision = head[1];
        return FFD_OK;
    }
    unsigned char *buf = ffd_malloc(bytes);
    if (!buf) /* nothing held changed: a client given the full frame instead resyncs */
        return ffd_fail(err, FFD_ERR_NOMEM, "delta frame: out of memory (%zu bytes)", bytes);
    uint32_t dh[9] = {0, head[1], base, (uint32_t)n, (uint32_t)k, (uint32_t)m, (uint32_t)c,
                      (uint32_t)r, 0};
    memcpy(dh, "FFDD", 4);
    memcpy(buf, dh, sizeof dh);
    unsigned char *w = buf + DELTA_HEAD;
    memcpy(w, f->changed, 4 * k);
    w += 4 * k;
    float *p = (float *)(void *)w;
    for (size_t i = 0; i < k; i++)
        memcpy(p + 3 * i, x + 3 * (size_t)f->changed[i], 12);
    w += 12 * k;
    /* the client's positions are now the frame's */
    for (size_t i = 0; i < k; i++)
        memcpy(f->sent + 3 * (size_t)f->changed[i], x + 3 * (size_t)f->changed[i], 12);
    f->revision = head[1];
    memcpy(w, f->ring, 4 * m);
    w += 4 * m;
    float *nrm = (float *)(void *)w;
    w += 12 * m;
    /* the cross product of every triangle around the ring, once each */
    size_t nfaces = 0;
    for (size_t i = 0; i < m; i++) {
        uint32_t v = f->ring[i];
        for (uint32_t j = f->vt_off[v]; j < f->vt_off[v + 1]; j++)
            if (!f->fmark[f->vt_tri[j]]) {
                f->fmark[f->vt_tri[j]] = 1;
                f->faces[nfaces++] = f->vt_tri[j];
            }
    }
    for (size_t i = 0; i < nfaces; i++)
        f->fmark[f->faces[i]] = 0;
    const sess_frames *cf = f;
    const float *sent = f->sent;
    const uint32_t *ring = f->ring, *faces = f->faces;
    double *cross = f->cross;
    ptrdiff_t nf = (ptrdiff_t)nfaces, count = (ptrdiff_t)m;
    /* each value is one fixed sequence of operations: the same bits for any thread count */
#pragma omp parallel if (count > 65536)
    {
#pragma omp for schedule(static)
        for (ptrdiff_t i = 0; i < nf; i++)
            triangle_cross(cf, sent, faces[i], cross + 3 * (size_t)faces[i]);
#pragma omp for schedule(static)
        for (ptrdiff_t i = 0; i < count; i++)
            vertex_normal(cf, ring[i], nrm + 3 * i);
    }
    memcpy(w, x + 3 * n, 4 * (3 * c + r)); /* controls, residuals as in the full frame */
    *delta = buf;
    *delta_size = bytes;
    return FFD_OK;
}
