/* Delta frames (ffd_session_delta_frame, docs/editor.md "Delta frames"): a
 * delta lists exactly the vertices whose float32 position bits changed since
 * the client's frame (an identity step: none; one lattice control moved:
 * only vertices in its support), applying it to the client's copy gives the
 * full frame bit for bit, its normals are those of the triangles around the
 * changed vertices recomputed from scratch; a client holding another frame,
 * or one the session did not send, gets the full frame, as does a step
 * whose delta would be larger. */
#include "check.h"
#include "ffd.h"

#include <stdint.h>
#include <stdlib.h>

#define BUNNY FFD_SOURCE_DIR "/examples/lattice/bunny.obj"

typedef struct delta {
    uint32_t revision, base, V, K, M, C, R, flags;
    const uint32_t *idx;   /* K */
    const float *pos;      /* K by 3 */
    const uint32_t *nidx;  /* M */
    const float *nrm;      /* M by 3 */
    const float *controls; /* C by 3 */
    const float *residuals;
} delta;

/* Parses a delta frame; 0 when the layout does not add up to size. */
static int parse_delta(const void *data, size_t size, delta *d)
{
    const unsigned char *b = data;
    uint32_t h[9];
    if (size < 36 || memcmp(b, "FFDD", 4) != 0)
        return 0;
    memcpy(h, b, 36);
    d->revision = h[1], d->base = h[2], d->V = h[3], d->K = h[4], d->M = h[5], d->C = h[6];
    d->R = h[7], d->flags = h[8];
    size_t off = 36;
    d->idx = (const uint32_t *)(const void *)(b + off);
    off += 4 * (size_t)d->K;
    d->pos = (const float *)(const void *)(b + off);
    off += 12 * (size_t)d->K;
    d->nidx = (const uint32_t *)(const void *)(b + off);
    off += 4 * (size_t)d->M;
    d->nrm = (const float *)(const void *)(b + off);
    off += 12 * (size_t)d->M;
    d->controls = (const float *)(const void *)(b + off);
    off += 12 * (size_t)d->C;
    d->residuals = (const float *)(const void *)(b + off);
    off += 4 * (size_t)d->R;
    return off == size && d->flags == 0;
}

static ffd_session *open_session(const char *path)
{
    ffd_mesh *mesh = NULL;
    ffd_session *s = NULL;
    CHECK_OK(ffd_mesh_read(path, &mesh, NULL));
    if (!mesh)
        return NULL;
    CHECK_OK(ffd_session_create(mesh, "mesh", NULL, &s, NULL));
    return s;
}

static void *command(ffd_session *s, const char *op, const char *body, size_t *size)
{
    void *reply = NULL;
    int binary = 0;
    ffd_error err = {{0}};
    ffd_status st = ffd_session_command(s, op, body, strlen(body), &reply, size, &binary, &err);
    if (st)
        fprintf(stderr, "  %s %s: %s\n", op, body, err.message);
    CHECK(st == FFD_OK);
    return reply;
}

static uint32_t frame_revision(const void *frame)
{
    uint32_t r;
    memcpy(&r, (const char *)frame + 4, 4);
    return r;
}

/* The triangles of the topology reply (the fan triangulation the page draws). */
static uint32_t *topology_triangles(ffd_session *s, size_t *t)
{
    void *data = NULL;
    size_t size = 0;
    CHECK_OK(ffd_session_topology(s, &data, &size, NULL));
    uint32_t h[4];
    memcpy(h, data, 16);
    *t = h[3];
    uint32_t *tri = malloc(12 * (size_t)h[3]);
    memcpy(tri, (char *)data + 16 + 12 * (size_t)h[2], 12 * (size_t)h[3]);
    ffd_free(data);
    return tri;
}

/* Area-weighted vertex normals of all vertices, from scratch (double sums). */
static double *all_normals(const float *p, size_t n, const uint32_t *tri, size_t t)
{
    double *nrm = calloc(3 * n, sizeof *nrm);
    for (size_t f = 0; f < t; f++) {
        const float *a = p + 3 * tri[3 * f], *b = p + 3 * tri[3 * f + 1], *c = p + 3 * tri[3 * f + 2];
        double e1[3] = {(double)b[0] - a[0], (double)b[1] - a[1], (double)b[2] - a[2]};
        double e2[3] = {(double)c[0] - a[0], (double)c[1] - a[1], (double)c[2] - a[2]};
        double x[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                       e1[0] * e2[1] - e1[1] * e2[0]};
        for (int k = 0; k < 3; k++)
            for (int a3 = 0; a3 < 3; a3++)
                nrm[3 * tri[3 * f + k] + a3] += x[a3];
    }
    for (size_t v = 0; v < n; v++) {
        double *q = nrm + 3 * v, l = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2]);
        if (l > 0)
            q[0] /= l, q[1] /= l, q[2] /= l;
        else
            q[0] = 0, q[1] = 1, q[2] = 0;
    }
    return nrm;
}

static void test_identity_step_is_empty(void)
{
    ffd_session *s = open_session(BUNNY);
    size_t size;
    ffd_free(command(s, "create", "{\"method\":\"lattice\",\"resolution\":[5,5,5]}", &size));
    void *f0 = NULL;
    size_t f0_size = 0;
    CHECK_OK(ffd_session_frame(s, &f0, &f0_size, NULL));
    uint32_t base = frame_revision(f0);
    void *dd = NULL;
    size_t dsize = 0;
    /* a client holding no frame gets the full one, which the session then holds */
    CHECK_OK(ffd_session_delta_frame(s, UINT32_MAX, f0, f0_size, &dd, &dsize, NULL));
    CHECK(dd == NULL);
    ffd_free(command(s, "drag_begin", "{\"points\":[62]}", &size));
    void *f1 = command(s, "drag", "{\"delta\":[0,0,0]}", &size);
    CHECK_OK(ffd_session_delta_frame(s, base, f1, size, &dd, &dsize, NULL));
    delta d;
    CHECK(dd && parse_delta(dd, dsize, &d));
    if (dd && parse_delta(dd, dsize, &d)) {
        CHECK(d.K == 0 && d.M == 0);
        CHECK(d.base == base && d.revision == frame_revision(f1) && d.V == 1839 && d.C == 125);
        /* controls and residuals as in the full frame */
        CHECK(memcmp(d.controls, (char *)f1 + 20 + 12 * 1839, 12 * 125) == 0);
        CHECK(dsize == 36 + 12 * 125 + 4 * (size_t)d.R);
    }
    ffd_free(dd);
    ffd_free(f1);
    ffd_free(f0);
    ffd_free(command(s, "drag_end", "{}", &size));
    ffd_session_destroy(s);
}

static void test_one_control_moves_its_support(void)
{
    ffd_session *s = open_session(BUNNY);
    size_t size;
    ffd_free(command(s, "create", "{\"method\":\"lattice\",\"resolution\":[8,8,8],\"basis\":\"bspline\"}",
                     &size));
    float *held = NULL; /* the client's copy */
    void *f0 = NULL;
    size_t f0_size = 0;
    CHECK_OK(ffd_session_frame(s, &f0, &f0_size, NULL));
    const size_t V = 1839;
    held = malloc(12 * V);
    memcpy(held, (char *)f0 + 20, 12 * V);
    uint32_t base = frame_revision(f0);
    void *none = NULL;
    size_t none_size = 0;
    CHECK_OK(ffd_session_delta_frame(s, UINT32_MAX, f0, f0_size, &none, &none_size, NULL));
    CHECK(none == NULL); /* the full frame: the client's copy above */
    ffd_free(f0);
    /* a control whose support holds a part of the bunny (its influence) */
    float *w = NULL;
    char body[64] = "";
    for (int id = 0; id < 512 && !w; id += 7) {
        snprintf(body, sizeof body, "{\"points\":[%d]}", id);
        w = command(s, "influence", body, &size);
        size_t in = 0;
        for (size_t v = 0; w && v < V; v++)
            in += ((const float *)((char *)w + 16))[v] > 0;
        if (in < 150 || in > V / 4) {
            ffd_free(w);
            w = NULL;
        }
    }
    CHECK(w && size == 16 + 4 * V);
    if (!w)
        return;
    size_t t = 0;
    uint32_t *tri = topology_triangles(s, &t);
    ffd_free(command(s, "drag_begin", body, &size));
    const char *steps[] = {"{\"delta\":[0.5,1,0]}", "{\"delta\":[1.5,2,-1]}", "{\"delta\":[1.5,2,-1]}"};
    for (int step = 0; step < 3; step++) {
        void *f = command(s, "drag", steps[step], &size);
        const float *x = (const float *)(const void *)((char *)f + 20);
        void *dd = NULL;
        size_t dsize = 0;
        CHECK_OK(ffd_session_delta_frame(s, base, f, size, &dd, &dsize, NULL));
        delta d;
        int ok = dd && parse_delta(dd, dsize, &d);
        CHECK(ok);
        if (!ok) {
            ffd_free(f);
            break;
        }
        CHECK(d.base == base && d.revision == frame_revision(f));
        /* exactly the vertices whose float32 bits changed, ascending */
        size_t k = 0, outside = 0;
        for (size_t v = 0; v < V; v++) {
            int changed = memcmp(held + 3 * v, x + 3 * v, 12) != 0;
            if (changed) {
                CHECK(k < d.K && d.idx[k] == v);
                k += k < d.K && d.idx[k] == v;
                outside += ((const float *)((char *)w + 16))[v] == 0.0f;
            }
        }
        CHECK(k == d.K);
        CHECK(outside == 0); /* nothing outside the control's support moved */
        if (step < 2) {
            CHECK(d.K > 50 && d.K < V / 4); /* a part of the bunny, not all of it */
        } else {
            CHECK(d.K == 0 && d.M == 0); /* the same step again: nothing changed */
        }
        /* applied to the client's copy: the full frame, bit for bit */
        for (size_t i = 0; i < d.K; i++)
            memcpy(held + 3 * (size_t)d.idx[i], d.pos + 3 * i, 12);
        CHECK(memcmp(held, x, 12 * V) == 0);
        /* normals: every corner of every triangle at a changed vertex, recomputed */
        unsigned char *ring = calloc(V, 1);
        for (size_t f3 = 0; f3 < t; f3++) {
            int touched = 0;
            for (int c = 0; c < 3; c++)
                for (size_t i = 0; i < d.K; i++)
                    touched |= d.idx[i] == tri[3 * f3 + c];
            if (touched)
                ring[tri[3 * f3]] = ring[tri[3 * f3 + 1]] = ring[tri[3 * f3 + 2]] = 1;
        }
        size_t m = 0;
        for (size_t v = 0; v < V; v++)
            m += ring[v];
        CHECK(m == d.M);
        double *nrm = all_normals(x, V, tri, t);
        double worst = 0;
        for (size_t i = 0; i < d.M; i++) {
            CHECK(ring[d.nidx[i]]);
            CHECK(i == 0 || d.nidx[i] > d.nidx[i - 1]);
            for (int a = 0; a < 3; a++) {
                double e = fabs(nrm[3 * (size_t)d.nidx[i] + a] - d.nrm[3 * i + a]);
                worst = e > worst ? e : worst;
            }
        }
        CHECK_NEAR(worst, 0, 1e-6);
        free(nrm);
        free(ring);
        base = d.revision;
        ffd_free(dd);
        ffd_free(f);
    }
    ffd_free(command(s, "drag_end", "{}", &size));
    ffd_free(w);
    free(tri);
    free(held);
    ffd_session_destroy(s);
}

static void test_other_base_gets_the_full_frame(void)
{
    ffd_session *s = open_session(BUNNY);
    size_t size;
    void *dd = NULL;
    size_t dsize = 0;
    ffd_free(command(s, "create", "{\"method\":\"lattice\",\"resolution\":[2,2,2]}", &size));
    /* a client naming a revision the session never sent it (a frame of
     * another session, or of an earlier run of the server, may carry the same
     * number) gets the full frame; then the session holds it, and a client
     * holding it gets an empty delta */
    void *f0 = NULL;
    size_t f0_size = 0;
    CHECK_OK(ffd_session_frame(s, &f0, &f0_size, NULL));
    CHECK_OK(ffd_session_delta_frame(s, frame_revision(f0), f0, f0_size, &dd, &dsize, NULL));
    CHECK(dd == NULL && dsize == 0);
    CHECK_OK(ffd_session_delta_frame(s, frame_revision(f0), f0, f0_size, &dd, &dsize, NULL));
    delta d;
    CHECK(dd && parse_delta(dd, dsize, &d) && d.K == 0 && d.M == 0);
    ffd_free(dd);
    dd = NULL;
    uint32_t base = frame_revision(f0);
    ffd_free(command(s, "drag_begin", "{\"points\":[0,1,2,3,4,5,6,7]}", &size));
    /* a client holding another frame: the full frame, which is the next base */
    void *f1 = command(s, "drag", "{\"delta\":[0.1,0,0]}", &size);
    CHECK_OK(ffd_session_delta_frame(s, base + 1000, f1, size, &dd, &dsize, NULL));
    CHECK(dd == NULL);
    /* every vertex moves: a delta would be larger than the full frame, which
     * the client then gets (and holds: the same step again is an empty delta) */
    void *f2 = command(s, "drag", "{\"delta\":[0.2,0,0]}", &size);
    CHECK_OK(ffd_session_delta_frame(s, frame_revision(f1), f2, size, &dd, &dsize, NULL));
    CHECK(dd == NULL);
    void *f3 = command(s, "drag", "{\"delta\":[0.2,0,0]}", &size);
    CHECK_OK(ffd_session_delta_frame(s, frame_revision(f2), f3, size, &dd, &dsize, NULL));
    CHECK(dd && parse_delta(dd, dsize, &d) && d.K == 0 && d.M == 0);
    ffd_free(dd);
    dd = NULL;
    CHECK_OK(ffd_session_delta_frame(s, UINT32_MAX, f3, size, &dd, &dsize, NULL));
    CHECK(dd == NULL); /* a client holding no frame */
    ffd_free(f3);
    /* not a frame of this session: an error, nothing made */
    ffd_error err = {{0}};
    CHECK(ffd_session_delta_frame(s, 0, "FFDF", 4, &dd, &dsize, &err) == FFD_ERR_INVALID);
    CHECK(strstr(err.message, "not a frame") != NULL && dd == NULL);
    CHECK(ffd_session_delta_frame(s, 0, f2, size - 4, &dd, &dsize, &err) == FFD_ERR_INVALID);
    CHECK(strstr(err.message, "expected") != NULL && dd == NULL);
    ffd_free(command(s, "drag_end", "{}", &size));
    ffd_free(f2);
    ffd_free(f1);
    ffd_free(f0);
    ffd_session_destroy(s);
}

int main(int argc, char **argv)
{
    static const check_test tests[] = {
        {"identity_step_is_empty", test_identity_step_is_empty},
        {"one_control_moves_its_support", test_one_control_moves_its_support},
        {"other_base_gets_the_full_frame", test_other_base_gets_the_full_frame},
    };
    return check_run(tests, sizeof tests / sizeof *tests, argc, argv);
}
