/* lattice — parallelepiped lattices: Bernstein (Sederberg & Parry 1986) and
 * uniform cubic B-spline with tripled border control points (Hsu, Hughes &
 * Kaufman 1992, §2). */
#ifndef FFD_LATTICE_H
#define FFD_LATTICE_H

#include "core/core.h"

#define FFD_LATTICE_MAX_RES 1024u
#define FFD_BERNSTEIN_MAX_RES 64u /* degree 63: beyond this binomials lose precision */

struct ffd_lattice {
    ffd_basis basis;
    uint32_t res[3];     /* l, m, n distinct control points */
    ffd_box box;
    double dual[3][3];   /* rows of the inverse of [a b c]: local = dual (x - origin) */
    double *P;           /* l*m*n by 3, current control points */
    double *P_rest;      /* l*m*n by 3, rest positions */
    uint32_t ext[3];     /* B-spline: l+4, m+4, n+4 (tripled-border net); Bernstein: l, m, n */
    double *P_ext;       /* B-spline: ext net by 3, kept equal to P through tie; Bernstein: == P */
    double *D_ext;       /* displacements P - P_rest on the same net as P_ext. Evaluation adds
                          * sum B D to the bound point instead of re-summing B P: the same
                          * map (the rest lattice reproduces every point), but the identity
                          * is exact and points whose control points did not move stay
                          * bitwise unchanged */
    uint32_t *tie;       /* ext net -> distinct index (the compressed selection matrix S, eq. 6) */
    /* B-spline rest map per axis: segment boundary values f(sigma), sigma = 0..res+1,
     * then segment coefficients and inversion tables (ffd_bspline_rest_knots) */
    double *knots_value[3];
    struct ffd_lattice_general *gen; /* NULL: the fast path above; else lattice_general.c */
};

/* One block of bound points that share a cell, in sorted order. */
typedef struct ffd_lattice_block {
    uint32_t cell[3]; /* segment (B-spline) or 0 (Bernstein) */
    uint32_t begin, end;
} ffd_lattice_block;

struct ffd_lattice_binding {
    size_t n;
    size_t inside_count;
    ffd_outside outside;
    ffd_basis basis;
    uint32_t res[3];
    double *params;        /* n by 3 global spline parameters (original order) */
    unsigned char *inside; /* n flags */
    /* evaluation order: inside points sorted by cell, in blocks */
    uint32_t *order;       /* inside_count original indices */
    double *local;         /* 3 * inside_count, SoA: s[...], t[...], u[...] in [0,1] within the cell */
    double *rest;          /* inside_count by 3: the bound points themselves, in sorted order */
    ffd_lattice_block *blocks;
    size_t block_count;
    /* outside points */
    uint32_t *out_index;   /* n - inside_count original indices */
    double *out_params;    /* 3 per outside point: parameters evaluated (clamped or raw) */
    double *out_point;     /* 3 per outside point: the point itself */
    /* FFD_OUTSIDE_FALLOFF (lattice_falloff.c): the factor f of every point
     * (1 inside), and grad f (3 per outside point, in out_index order) */
    double *falloff;
    double *falloff_grad;
    /* made by ffd_lattice_general_bind for the lattice holding this (borrowed):
     * params (clamped) and out_point (every point, n by 3) only, no blocks */
    const struct ffd_lattice_general *general;
};

/* ---- uniform cubic B-spline (bspline_basis.c) ---- */

/* B_0..B_3 at local t (and derivatives when d != NULL). */
void ffd_bspline_basis(double t, double b[4], double d[4]);

/* Distinct index followed by slot e of the tripled-border net of res points. */
static inline uint32_t ffd_bspline_tie(uint32_t e, uint32_t res)
{
    return e < 2 ? 0 : (e - 2 >= res - 1 ? res - 1 : e - 2);
}

/* Segment 0..res of a global B-spline parameter (the last segment is closed). */
static inline uint32_t ffd_bspline_segment(double S, uint32_t res)
{
    uint32_t sigma = S <= 0 ? 0 : (uint32_t)S;
    return sigma > res ? res : sigma;
}

/* Precomputes f(sigma) for sigma = 0..res+1 of the rest map (values in [0,1]),
 * followed by the data ffd_bspline_invert needs (layout private to bspline_basis.c). */
ffd_status ffd_bspline_rest_knots(uint32_t res, double **values);

/* Rest map of one axis: the normalised position f(S) in [0,1] of global parameter S. */
double ffd_bspline_rest_map(uint32_t res, double S, double *dfdS);

/* Inverts the rest map of one axis: S with f(S) = x, for x in [0,1] (paper §2,
 * footnote 5: direct in the inner segments, cubic root solve in the outer two:
 * closed form on the border segments, tabulated start + one Newton step next to them). */
double ffd_bspline_invert(uint32_t res, const double *knot_values, double x);

/* ---- Bernstein (bernstein_basis.c) ---- */

/* B_{i,deg}(s), i = 0..deg, and derivatives when d != NULL. Valid for any real s. */
void ffd_bernstein_basis(uint32_t deg, double s, double *b, double *d);

/* ---- internal evaluation helpers (lattice_eval.c) ---- */

/* Basis values (and derivatives when d != NULL) of one axis with res control
 * points at global parameter S; *first is the first slot they weigh. */
void ffd_axis_basis(ffd_basis basis, uint32_t res, double S, uint32_t *first, double *b, double *d);

/* FFD_ERR_INVALID when the binding was made for another basis or resolution. */
ffd_status ffd_lattice_check_binding(const ffd_lattice *lat, const ffd_lattice_binding *b,
                                     ffd_error *err);

/* Evaluates position (and the three partial derivatives d/dS, d/dT, d/dU when dq != NULL)
 * at global parameters. */
void ffd_lattice_eval_at(const ffd_lattice *lat, const double stu[3], double q[3], double dq[3][3]);

/* The displacement sum B D at global parameters (see D_ext), and its partial
 * derivatives d/dS, d/dT, d/dU when dd != NULL. */
void ffd_lattice_displacement_at(const ffd_lattice *lat, const double stu[3], double d[3],
                                 double dd[3][3]);

/* Rest position at global parameters (the box map of the rest normalised coordinates). */
void ffd_lattice_rest_at(const ffd_lattice *lat, const double stu[3], double x[3]);

/* The instruction set of the evaluation kernels (lattice_kernels.h), chosen
 * per call from the CPU's features: AVX-512 when cpuid reports AVX-512F (with
 * AVX2 and FMA, and the OS saves the zmm state), else AVX2 when it reports
 * AVX2 and FMA, else the baseline (SSE2 on x86-64). Builds other than GCC or
 * Clang on x86-64, or with FFD_NO_CLONES defined, always use the baseline. */
#if (defined(__GNUC__) || defined(__clang__)) && defined(__x86_64__) && !defined(FFD_NO_CLONES)
#define FFD_SIMD_DISPATCH 1
#else
#define FFD_SIMD_DISPATCH 0
#endif
typedef enum ffd_simd_path { FFD_SIMD_DEFAULT, FFD_SIMD_AVX2, FFD_SIMD_AVX512 } ffd_simd_path;
ffd_simd_path ffd_lattice_simd_path(void);
/* "default", "avx2" or "avx512". */
const char *ffd_simd_path_name(ffd_simd_path path);

/* The sensitivity product out = W v (lattice_eval.c: the evaluation's
 * blocks with v, spread onto the slots, in place of the displacements): v is
 * the l*m*n controls by 3, out bind->n by 3. FFD_ERR_INVALID, FFD_ERR_NOMEM. */
ffd_status ffd_lattice_sensitivity_product(const ffd_lattice *lat, const ffd_lattice_binding *bind,
                                           const double *v, double *out, ffd_error *err);
/* The adjoint sensitivity product out = W^T w (lattice_sensitivity.c):
 * w is bind->n by 3, out the l*m*n controls by 3 (ties of the B-spline
 * border summed onto their control); bitwise the same for any thread
 * count. FFD_ERR_INVALID (binding of another lattice), FFD_ERR_NOMEM. */
ffd_status ffd_lattice_sensitivity_transpose(const ffd_lattice *lat, const ffd_lattice_binding *bind,
                                             const double *w, double *out, ffd_error *err);
/* The fold-over check (ffd_deformer_fold_check, ffd.h): det J of the map
 * on a 5x5x5 grid in every lattice cell (lattice_map.c). */
ffd_status ffd_lattice_fold_check(const ffd_lattice *lat, ffd_fold_report *out, ffd_error *err);

/* FFD_OUTSIDE_FALLOFF's Jacobian (lattice_falloff.c): J of the clamped
 * displacement turned into J = I + f (J - I) + d grad f^T at the outside points. */
void ffd_lattice_falloff_jacobian(const ffd_lattice *lat, const ffd_lattice_binding *bind,
                                  double *out);
/* ---- per-axis interpolation (lattice_axis.c) and the general path
 * (lattice_general.c): mixed interpolation, cylindrical and spherical
 * lattices. Every public lattice function hands a lattice with gen != NULL
 * to its ffd_lattice_general_* counterpart. ---- */

#define FFD_AXIS_MAX_SUPPORT FFD_BERNSTEIN_MAX_RES

/* One axis of a general lattice: its interpolation and parameter domain. */
typedef struct ffd_lattice_axis {
    ffd_interp interp;      /* never DEFAULT; CATMULL_ROM is CARDINAL with tension 0 */
    double tension, continuity;
    uint32_t res;
    int periodic;           /* closed axis (a full turn of theta) */
    double *knots;          /* B-spline, not periodic: ffd_bspline_rest_knots */
} ffd_lattice_axis;

/* Checks and sets up an axis (knots); name is "axis 0" etc. for messages. */
ffd_status ffd_lattice_axis_init(ffd_lattice_axis *ax, ffd_interp interp, double tension,
                                 double continuity, uint32_t res, int periodic, const char *name,
                                 ffd_error *err);
void ffd_lattice_axis_release(ffd_lattice_axis *ax);
/* The parameter domain [0, top] of the axis. */
double ffd_lattice_axis_top(const ffd_lattice_axis *ax);
/* Normalised rest coordinate f(S) in [0,1] of control index j (its node). */
double ffd_lattice_axis_node(const ffd_lattice_axis *ax, uint32_t j);
/* The rest map f(S) (normalised coordinate in [0,1]) and df/dS when dfdS. */
double ffd_lattice_axis_rest(const ffd_lattice_axis *ax, double S, double *dfdS);
/* Its exact inverse: S with f(S) = x, x in [0,1]. */
double ffd_lattice_axis_invert(const ffd_lattice_axis *ax, double x);
/* The nonzero-support weights of the axis at S over control indices (unique,
 * phantoms and tripled border folded in, periodic indices wrapped) and their
 * derivatives d/dS when dw != NULL. Returns the count (<= FFD_AXIS_MAX_SUPPORT). */
uint32_t ffd_lattice_axis_weights(const ffd_lattice_axis *ax, double S, uint32_t *idx, double *w,
                                  double *dw);
/* The cardinal rest map of one segment, g(t) = (1-T) t + T (3t^2 - 2t^3), and
 * its inverse on [0,1] (bracketed Newton, monotone for T in (-2, 1)). */
double ffd_cardinal_rest(double tension, double t, double *dg);
double ffd_cardinal_invert(double tension, double y);

/* 1 when ffd_lattice_create_shaped builds a general lattice for this shape
 * (cylindrical or spherical, or an interpolation other than one fast-path
 * basis on every axis): falloff and nested children are refused there. */
int ffd_lattice_shape_is_general(ffd_basis basis, const ffd_lattice_shape *shape);
ffd_status ffd_lattice_general_create(ffd_basis basis, const ffd_box *box, const uint32_t res[3],
                                      const ffd_lattice_shape *shape, ffd_lattice **out,
                                      ffd_error *err);
void ffd_lattice_general_free(struct ffd_lattice_general *gen);
void ffd_lattice_general_sync(ffd_lattice *lat);
/* The point (of n) farthest from the axis (cylindrical) or centre
 * (spherical) of the frame ffd_lattice_frame_fit fits to points whose
 * extent is lo..hi: the one point its radius reads (distributed runs).
 * SIZE_MAX when none or the extent is not a lattice box. */
size_t ffd_lattice_frame_farthest(ffd_coordinates coordinates, const double lo[3],
                                  const double hi[3], const double *points, size_t n);
void ffd_lattice_general_rest_point(const ffd_lattice *lat, uint32_t i, uint32_t j, uint32_t k,
                                    double out[3]);
/* Axis a (0..2) of a general lattice. */
const ffd_lattice_axis *ffd_lattice_general_axis(const ffd_lattice *lat, int a);
size_t ffd_lattice_general_representative(const ffd_lattice *lat, size_t index);
ffd_status ffd_lattice_general_bind(const ffd_lattice *lat, const double *points, size_t n,
                                    ffd_outside outside, ffd_lattice_binding **out, ffd_error *err);
ffd_status ffd_lattice_general_eval(const ffd_lattice *lat, const ffd_lattice_binding *bind,
                                    const double *v, double *out, ffd_error *err);
void ffd_lattice_general_eval_params(const ffd_lattice *lat, const double stu[3], double out[3]);
ffd_status ffd_lattice_general_jacobian(const ffd_lattice *lat, const ffd_lattice_binding *bind,
                                        double *out, ffd_error *err);
void ffd_lattice_general_linear_map(const ffd_lattice *lat, const ffd_lattice_binding *bind,
                                    ffd_linear_map *map);
ffd_status ffd_lattice_general_transpose(const ffd_lattice *lat, const ffd_lattice_binding *bind,
                                         const double *w, double *out, ffd_error *err);
ffd_status ffd_lattice_general_fold_check(const ffd_lattice *lat, ffd_fold_report *out,
                                          ffd_error *err);

/* Rebuilds P_ext from P (B-spline). */
void ffd_lattice_sync(ffd_lattice *lat);

#endif
