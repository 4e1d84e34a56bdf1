/*
 * Compiled kernel of the bounded least-squares fast path: sobolev_drake.native._bls.
 *
 * Mirrors sobolev_drake.systems.bounded_ls._bls_fast_python (the default path of
 * bounded_least_squares: PDAS on the scaled, Tikhonov-regularized box QP, then the
 * minimum-norm polish of the free block) step by step, with the same scalar expressions in the
 * same order (built with -ffp-contract=off).  Where the Python code calls BLAS / LAPACK the
 * kernel has its own loops, so results agree with Python to rounding, not to the last bit:
 *   matrix products             plain dot products (BLAS gemv / syrk / dot in Python);
 *   H x = rhs                   LU with partial pivoting (LAPACK dgesv);
 *   minimum-norm least squares  QR with column pivoting + one-sided Jacobi SVD (LAPACK dgelsd
 *                               in Python), same cutoff: singular values <= 1e-10 sigma_max
 *                               count as zero, the rank is the number of the others.
 * Python's own scalar steps (sum() of the diagonal, min/max, the PDAS tests, the polish
 * checks, the final tau) are reproduced exactly.  On well-conditioned problems tau agrees to
 * ~1e-14; where the regularized free block is nearly singular (condition up to 1/reg) both
 * are only determined to its forward-error bound and may differ by that much.
 *
 * solve() returns what _bls_fast_python returns ((tau, info) or None), or NotImplemented when
 * it leaves the decision to the Python tier: inputs it does not read directly (warm
 * starts that are not plain numeric ndarrays, float64 arrays not exported as format "d"),
 * values that may overflow (the Python code then computes with inf/nan or raises), an exactly
 * singular pivot (dgesv fails: Python raises LinAlgError) or a Jacobi sweep limit.  All of
 * these are outside the controller's normal operation.  tests/native/test_native_bls.py
 * compares the kernel with the Python tier.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <float.h>
#include <math.h>
#include <stdint.h>
#include <string.h>

#include "capi.h"

/* Work arrays live in a stack buffer up to n, m = 16 (the controller: 8 x 8), on the heap beyond. */
#define STACK_BYTES 32768
#define JACOBI_MAX_SWEEPS 60
/* Inputs whose sum of |B_ij| or |u_i| reaches this may overflow somewhere (numpy's B.sum(),
 * the products): the Python reference decides those. */
#define SAFE_MAX 1e300

static PyObject *ndarray_type;      /* numpy.ndarray: the Python code requires exact ndarrays */
static PyObject *np_empty;          /* numpy.empty: builds the returned arrays */
static PyObject *key_method, *key_iterations, *key_residual, *key_active, *str_pdas;

/* Python's max(a, b) / min(a, b) on floats: the first argument unless the second is strictly
 * larger / smaller (so signed zeros come out as in Python). */
static inline double py_max(double a, double b) { return b > a ? b : a; }
static inline double py_min(double a, double b) { return b < a ? b : a; }

/* Python's sum() of a list of floats (start 0): plain left-to-right addition up to 3.11,
 * Neumaier-compensated from 3.12 on. */
static double py_sum(const double *x, int k)
{
    if (k == 0)
        return 0.0;
    double f = 0.0 + x[0];            /* int 0 + float */
#if PY_VERSION_HEX >= 0x030C0000
    double c = 0.0;
    for (int i = 1; i < k; i++) {
        double t = f + x[i];
        if (fabs(f) >= fabs(x[i]))
            c += (f - t) + x[i];
        else
            c += (x[i] - t) + f;
        f = t;
    }
    if (c != 0.0 && isfinite(c))
        f += c;
#else
    for (int i = 1; i < k; i++)
        f += x[i];
#endif
    return f;
}

static inline double dot(const double *a, const double *b, int k)
{
    double acc = 0.0;
    for (int i = 0; i < k; i++)
        acc += a[i] * b[i];
    return acc;
}

static inline double rd(const char *p)
{
    double v;
    memcpy(&v, p, sizeof v);           /* numpy arrays need not be aligned */
    return v;
}

/* Solve M x = b by LU with partial pivoting (first largest |pivot|, as LAPACK's idamax); x
 * holds b on entry and the solution on return, M (k x k, row-major) is overwritten.  -1 on an
 * exactly zero pivot (dgesv's info > 0). */
static int lu_solve(double *M, int k, double *x)
{
    for (int c = 0; c < k; c++) {
        int p = c;
        double best = fabs(M[c * k + c]);
        for (int r = c + 1; r < k; r++) {
            double v = fabs(M[r * k + c]);
            if (v > best) {
                best = v;
                p = r;
            }
        }
        if (M[p * k + c] == 0.0)
            return -1;
        if (p != c) {
            for (int j = 0; j < k; j++) {
                double t = M[c * k + j];
                M[c * k + j] = M[p * k + j];
                M[p * k + j] = t;
            }
            double t = x[c];
            x[c] = x[p];
            x[p] = t;
        }
        const double piv = M[c * k + c];
        for (int r = c + 1; r < k; r++) {
            double f = M[r * k + c] / piv;
            if (f == 0.0)
                continue;
            for (int j = c + 1; j < k; j++)
                M[r * k + j] -= f * M[c * k + j];
            x[r] -= f * x[c];
        }
    }
    for (int r = k - 1; r >= 0; r--) {
        double acc = x[r];
        for (int j = r + 1; j < k; j++)
            acc -= M[r * k + j] * x[j];
        x[r] = acc / M[r * k + r];
    }
    return 0;
}

/* Minimum-norm least squares x = argmin ||F x - y|| (F: rows x cols, row-major) with singular
 * values <= rcond * sigma_max treated as zero (LAPACK dgelsd semantics; rcond must exceed
 * ~1e-13, below which rounding noise is cut instead, see thr); *rank counts the others.
 *
 * Tall F (rows >= cols): Householder QR with column pivoting F P = Q R, then one-sided Jacobi
 * on the rows of R (Drmac & Veselic's preconditioned Jacobi SVD: few sweeps on the graded R);
 * the rotations G (G^T R has orthogonal rows, norms sigma_i) are applied to c = Q^T y as well,
 * so no singular vectors are stored: x = P sum_i r_i c_i / sigma_i^2 over the kept rows.  Wide
 * F: the same Jacobi directly on the rows of F with y.
 *
 * work: rows*cols + rows + cols*cols + 2*cols doubles; perm: cols ints.  Returns -1 if the
 * sweeps do not converge. */
static int min_norm_lstsq(const double *F, int rows, int cols, const double *y, double rcond,
                          double *x, int *rank, double *work, int *perm)
{
    double *M = work;                          /* scaled F, row-major rows x cols */
    double *v = M + (size_t)rows * cols;       /* rotated right-hand side */
    double *R = v + rows;                      /* k x k, row-major */
    double *cn = R + (size_t)cols * cols;      /* column norms^2 (pivoting) */
    double *z = cn + cols;
    double amax = 0.0;
    for (int i = 0; i < rows * cols; i++)
        if (fabs(F[i]) > amax)
            amax = fabs(F[i]);
    for (int j = 0; j < cols; j++)
        x[j] = 0.0;
    *rank = 0;
    if (amax == 0.0)                    /* dgelsd: zero matrix, zero solution, rank 0 */
        return 0;
    /* Power-of-two scaling M = scl F (exact) so that squared norms neither overflow nor
     * underflow; F^+ = scl M^+ undoes it in the solution. */
    int e;
    frexp(amax, &e);
    const double scl = ldexp(1.0, -e);
    for (int i = 0; i < rows * cols; i++)
        M[i] = F[i] * scl;
    for (int i = 0; i < rows; i++)
        v[i] = y[i];

    double *J;                          /* the rows Jacobi orthogonalizes: k x cols */
    int k;
    if (rows >= cols) {
        k = cols;
        for (int j = 0; j < cols; j++)
            perm[j] = j;
        for (int j = 0; j < cols; j++) {
            /* pivot: the remaining column of largest norm (recomputed: sizes are small) */
            int p = j;
            double best = -1.0;
            for (int c = j; c < cols; c++) {
                double ss = 0.0;
                for (int r = j; r < rows; r++)
                    ss += M[r * cols + c] * M[r * cols + c];
                cn[c] = ss;
                if (ss > best) {
                    best = ss;
                    p = c;
                }
            }
            if (p != j) {
                for (int r = 0; r < rows; r++) {
                    double t = M[r * cols + j];
                    M[r * cols + j] = M[r * cols + p];
                    M[r * cols + p] = t;
                }
                int t = perm[j];
                perm[j] = perm[p];
                perm[p] = t;
            }
            /* Householder reflector H = I - tau w w^T (w_j = 1) with H M[j:, j] = beta e_1 */
            double alpha = M[j * cols + j], xs = 0.0;
            for (int r = j + 1; r < rows; r++)
                xs += M[r * cols + j] * M[r * cols + j];
            if (xs == 0.0)
                continue;               /* already triangular in this column (tau = 0) */
            double beta = -copysign(sqrt(alpha * alpha + xs), alpha);
            double tau = (beta - alpha) / beta, inv = 1.0 / (alpha - beta);
            for (int r = j + 1; r < rows; r++)
                M[r * cols + j] *= inv;
            M[j * cols + j] = beta;
            for (int c = j + 1; c < cols; c++) {
                double w = M[j * cols + c];
                for (int r = j + 1; r < rows; r++)
                    w += M[r * cols + j] * M[r * cols + c];
                w *= tau;
                M[j * cols + c] -= w;
                for (int r = j + 1; r < rows; r++)
                    M[r * cols + c] -= w * M[r * cols + j];
            }
            double w = v[j];
            for (int r = j + 1; r < rows; r++)
                w += M[r * cols + j] * v[r];
            w *= tau;
            v[j] -= w;
            for (int r = j + 1; r < rows; r++)
                v[r] -= w * M[r * cols + j];
        }
        for (int i = 0; i < k; i++)
            for (int j = 0; j < k; j++)
                R[i * k + j] = j >= i ? M[i * cols + j] : 0.0;
        J = R;
    } else {
        k = rows;
        J = M;
    }

    /* One-sided Jacobi on the k rows of J (length cols), rotating v alongside.  The squared
     * row norms are recomputed at the start of every sweep and updated after each rotation
     * (alpha - t gamma, beta + t gamma), recomputed too when an update cancels.  Rows below
     * thr = 64 cols eps ||M||_F are rounding noise of a rank-deficient matrix (they cannot be
     * made orthogonal to the others beyond that noise, and end up underflowing): they are not
     * rotated and count as zero (thr is far below the 1e-10 relative cutoff used here). */
    double *nr = z;                     /* squared row norms (z is free until the end) */
    const double tol = DBL_EPSILON * cols;
    double fro2 = 0.0;
    for (int i = 0; i < k; i++)
        fro2 += dot(J + (size_t)i * cols, J + (size_t)i * cols, cols);
    const double thr = 64.0 * cols * DBL_EPSILON * sqrt(fro2), thr2 = thr * thr;
    int sweep;
    for (sweep = 0; sweep < JACOBI_MAX_SWEEPS; sweep++) {
        int rotated = 0;
        for (int i = 0; i < k; i++)
            nr[i] = dot(J + (size_t)i * cols, J + (size_t)i * cols, cols);
        for (int i = 0; i < k - 1; i++) {
            double *ri = J + (size_t)i * cols;
            for (int j = i + 1; j < k; j++) {
                double *rj = J + (size_t)j * cols;
                double alpha = nr[i], beta = nr[j];
                if (alpha <= thr2 || beta <= thr2)
                    continue;
                double gamma = dot(ri, rj, cols);
                if (gamma == 0.0 || fabs(gamma) <= tol * sqrt(alpha) * sqrt(beta))
                    continue;
                rotated = 1;
                /* Rutishauser's rotation making r_i . r_j zero (the small root t of
                 * t^2 + 2 zeta t - 1 = 0; |zeta| capped so zeta^2 cannot overflow) */
                double zeta = (beta - alpha) / (2.0 * gamma), az = fabs(zeta);
                double t = (zeta >= 0.0 ? 1.0 : -1.0) / (az + (az < 1e150 ? sqrt(1.0 + az * az) : az));
                double cs = 1.0 / sqrt(1.0 + t * t), sn = cs * t;
                for (int c = 0; c < cols; c++) {
                    double a = ri[c], b = rj[c];
                    ri[c] = cs * a - sn * b;
                    rj[c] = sn * a + cs * b;
                }
                double a = v[i], b = v[j];
                v[i] = cs * a - sn * b;
                v[j] = sn * a + cs * b;
                double ai = alpha - t * gamma, bj = beta + t * gamma;
                nr[i] = ai >= 0.0625 * alpha ? ai : dot(ri, ri, cols);
                nr[j] = bj >= 0.0625 * beta ? bj : dot(rj, rj, cols);
            }
        }
        if (!rotated)
            break;
    }
    if (sweep == JACOBI_MAX_SWEEPS)
        return -1;
    double smax = 0.0;
    for (int i = 0; i < k; i++) {
        const double *ri = J + (size_t)i * cols;
        double ss = 0.0;
        for (int c = 0; c < cols; c++)
            ss += ri[c] * ri[c];
        cn[i] = sqrt(ss);               /* sigma_i (of the scaled matrix) */
        if (cn[i] > smax)
            smax = cn[i];
    }
    const double cut = rcond * smax > thr ? rcond * smax : thr;
    for (int c = 0; c < cols; c++)
        z[c] = 0.0;
    for (int i = 0; i < k; i++) {
        if (!(cn[i] > cut))
            continue;
        ++*rank;
        const double *ri = J + (size_t)i * cols;
        double coef = v[i] / cn[i] / cn[i] * scl;
        for (int c = 0; c < cols; c++)
            z[c] += coef * ri[c];
    }
    for (int c = 0; c < cols; c++)
        x[rows >= cols ? perm[c] : c] = z[c];
    return 0;
}

/* ----------------------------------------------------------------------- solve() -------- */

typedef struct {
    Py_buffer v;
    int held;
} Buf;

static void release(Buf *b, int k)
{
    for (int i = 0; i < k; i++)
        if (b[i].held)
            PyBuffer_Release(&b[i].v);
}

/* Element i of a 1-d numeric buffer as a double (sign is all that is used), or -1 if the
 * format is not a plain numeric one. */
static int ws_value(const Py_buffer *v, Py_ssize_t i, double *out)
{
    const char *f = v->format;
    if (f == NULL || f[0] == '\0' || f[1] != '\0')
        return -1;
    const char *p = (const char *)v->buf + i * v->strides[0];
    switch (f[0]) {
#define CASE(ch, T)                                                                       \
    case ch: {                                                                            \
        T t;                                                                              \
        if (v->itemsize != (Py_ssize_t)sizeof(T))                                         \
            return -1;                                                                    \
        memcpy(&t, p, sizeof t);                                                          \
        *out = (double)t;                                                                 \
        return 0;                                                                         \
    }
        CASE('d', double)
        CASE('f', float)
        CASE('b', signed char)
        CASE('B', unsigned char)
        CASE('h', short)
        CASE('H', unsigned short)
        CASE('i', int)
        CASE('I', unsigned int)
        CASE('l', long)
        CASE('L', unsigned long)
        CASE('q', long long)
        CASE('Q', unsigned long long)
#undef CASE
    case '?': {
        unsigned char t;
        if (v->itemsize != 1)
            return -1;
        memcpy(&t, p, 1);
        *out = t ? 1.0 : 0.0;
        return 0;
    }
    default:
        return -1;
    }
}

/* leave bls_core with this result (releasing its heap work space) */
#define FINISH(r)                                                                         \
    do {                                                                                  \
        result = (r);                                                                     \
        goto done;                                                                        \
    } while (0)
#define DECLINE() FINISH(BLS_DECLINE)   /* the Python reference decides */
#define NONE() FINISH(BLS_NONE)         /* what the reference returns */

/* the warm start of bls_core: none (cold start), given (warm), or a verdict the Python entry
 * reached while reading it, returned at the point where the reference reads it */
#define WARM_COLD 0
#define WARM_GIVEN 1
#define WARM_DECLINE 2
#define WARM_NONE 3

/* _bls_fast_python on contiguous arrays: B (n x m, row-major), u (n), lo, hi (m); warm (m
 * signs) when warm_mode is WARM_GIVEN.  BLS_OK with tau_out, active_out, *iterations and
 * *residual, or BLS_NONE / BLS_DECLINE (what solve() returns as None / NotImplemented), or
 * BLS_NOMEM.  Both solve() and the C interface (fused.c) call this. */
static int bls_core(int n, int m, const double *Bin, const double *uin, const double *loin,
                    const double *hiin, double reg, int warm_mode, const double *warm,
                    long max_iter, double *tau_out, signed char *active_out, int *iterations,
                    double *residual)
{
    int result = BLS_OK;
    void *heap = NULL;
    double stackbuf[STACK_BYTES / sizeof(double)];

    /* ---- work space */
    size_t nd = (size_t)n * m * 3          /* Bm, A, F (free block) */
                + (size_t)m * m * 2        /* H, LU copy */
                + (size_t)n * m + (size_t)m * m + n + 2 * (size_t)m + 4   /* least squares */
                + (size_t)m * 15 + (size_t)n * 5 + 8;
    size_t bytes = nd * sizeof(double) + (size_t)m * (3 * sizeof(int) + 4);
    char *mem = (char *)stackbuf;
    if (bytes > sizeof stackbuf) {
        heap = PyMem_Malloc(bytes);
        if (heap == NULL)
            return BLS_NOMEM;
        mem = heap;
    }
    double *Bm = (double *)mem, *A = Bm + (size_t)n * m, *F = A + (size_t)n * m;
    double *H = F + (size_t)n * m, *LU = H + (size_t)m * m, *jw = LU + (size_t)m * m;
    double *vm = jw + (size_t)n * m + (size_t)m * m + n + 2 * (size_t)m + 4;
    double *lo = vm, *hi = lo + m, *tp = hi + m, *sc = tp + m, *l = sc + m, *h = l + m;
    double *g = h + m, *s = g + m, *sv = s + m, *lam = sv + m, *x = lam + m, *snew = x + m;
    double *tau = snew + m, *hdiag = tau + m, *jx = hdiag + m;
    double *u = jx + m, *b = u + n, *r = b + n, *yv = r + n, *r2 = yv + n;
    int *fi = (int *)(r2 + n), *ai = fi + m, *perm = ai + m;
    char *low = (char *)(perm + m), *up = low + m, *nlow = up + m, *nup = nlow + m;

    /* ---- the Python checks, in order: bounds, then u and B */
    for (int i = 0; i < m; i++) {
        double a = loin[i], c = hiin[i];
        if (!(isfinite(a) && isfinite(c) && a < c))
            NONE();
        lo[i] = a;
        hi[i] = c;
    }
    for (int i = 0; i < m; i++) {
        double a = lo[i], c = hi[i];
        double t = py_min(py_max(0.0, a), c);            /* tau_p = clip(0, lo, hi) */
        double d = 0.5 * (c - a);                         /* D = (hi - lo)/2 */
        if (d == 0.0 || !isfinite(d))   /* Python: ZeroDivisionError / inf-nan arithmetic */
            DECLINE();
        tp[i] = t;
        sc[i] = d;
        l[i] = (a - t) / d;
        h[i] = (c - t) / d;
    }
    double asum = 0.0;
    for (int i = 0; i < n; i++) {
        double v = uin[i];
        if (!isfinite(v))
            NONE();
        u[i] = v;
        asum += fabs(v);
    }
    if (!(asum < SAFE_MAX))
        DECLINE();
    int nonfinite = 0;
    asum = 0.0;
    for (int i = 0; i < n; i++) {
        for (int j = 0; j < m; j++) {
            double v = Bin[(size_t)i * m + j];
            Bm[i * m + j] = v;
            if (!isfinite(v))
                nonfinite = 1;
            else
                asum += fabs(v);
        }
    }
    if (nonfinite)                       /* B.sum() is inf or nan */
        NONE();
    if (!(asum < SAFE_MAX))              /* numpy's sum might overflow: Python decides */
        DECLINE();

    /* ---- scaled problem: A = B D, b = u - B tau_p, H = A^T A + eps I, g = A^T b */
    for (int i = 0; i < n; i++)
        for (int j = 0; j < m; j++)
            A[i * m + j] = Bm[i * m + j] * sc[j];
    for (int i = 0; i < n; i++) {
        double acc = 0.0;
        for (int j = 0; j < m; j++)
            acc += Bm[i * m + j] * tp[j];
        b[i] = u[i] - acc;
    }
    for (int i = 0; i < m; i++)
        for (int j = i; j < m; j++) {
            double acc = 0.0;
            for (int k = 0; k < n; k++)
                acc += A[k * m + i] * A[k * m + j];
            H[i * m + j] = H[j * m + i] = acc;
        }
    for (int i = 0; i < m; i++)
        hdiag[i] = H[i * m + i];
    const double fro2 = py_sum(hdiag, m);                 /* ||A||_F^2 = trace A^T A */
    const double eps = reg * py_max(fro2, 1e-300);
    for (int i = 0; i < m; i++)
        H[i * m + i] += eps;
    for (int j = 0; j < m; j++) {
        double acc = 0.0;
        for (int k = 0; k < n; k++)
            acc += A[k * m + j] * b[k];
        g[j] = acc;
    }
    const double cpen = (fro2 + (double)m * eps) / m;     /* trace(H) / m */
    {
        int bad = !(isfinite(fro2) && isfinite(eps) && isfinite(cpen));
        for (int i = 0; i < n && !bad; i++)
            bad = !isfinite(b[i]);
        for (int i = 0; i < m * m && !bad; i++)
            bad = !isfinite(H[i]);
        for (int i = 0; i < m && !bad; i++)
            bad = !isfinite(g[i]);
        if (bad)                          /* overflow: Python computes with inf/nan */
            DECLINE();
    }

    /* ---- initial active-set guess */
    if (warm_mode == WARM_DECLINE)
        DECLINE();                        /* not a plain numeric ndarray: np.asarray in Python */
    if (warm_mode == WARM_NONE)
        NONE();                           /* ws.shape != (m,) */
    if (warm_mode == WARM_GIVEN) {
        for (int i = 0; i < m; i++) {
            low[i] = warm[i] < 0;
            up[i] = warm[i] > 0;
        }
    } else {
        memcpy(LU, H, sizeof(double) * m * m);
        memcpy(x, g, sizeof(double) * m);
        if (lu_solve(LU, m, x) < 0)
            DECLINE();                    /* dgesv: singular -> LinAlgError in Python */
        for (int i = 0; i < m; i++) {
            if (!isfinite(x[i]))
                DECLINE();
            low[i] = x[i] < l[i];
            up[i] = x[i] > h[i];
        }
    }

    /* ---- PDAS (Hintermueller-Ito-Kunisch), as _box_qp_pdas */
    int it, nf = 0, na = 0, settled = 0;
    for (it = 0; it < max_iter; it++) {
        nf = na = 0;
        for (int i = 0; i < m; i++) {
            if (up[i]) {
                ai[na++] = i;
                s[i] = h[i];
            } else if (low[i]) {
                ai[na++] = i;
                s[i] = l[i];
            } else {
                fi[nf++] = i;
                s[i] = 0.0;
            }
        }
        if (nf) {
            /* H_ff x = g_f - H_fa s_a */
            for (int p = 0; p < nf; p++) {
                const double *Hr = H + (size_t)fi[p] * m;
                for (int q = 0; q < nf; q++)
                    LU[p * nf + q] = Hr[fi[q]];
                double acc = 0.0;
                for (int q = 0; q < na; q++)
                    acc += Hr[ai[q]] * s[ai[q]];
                x[p] = g[fi[p]] - acc;
            }
            if (lu_solve(LU, nf, x) < 0)
                DECLINE();
            for (int p = 0; p < nf; p++) {
                if (!isfinite(x[p]))
                    DECLINE();
                s[fi[p]] = x[p];
            }
        }
        for (int i = 0; i < m; i++) {
            double acc = 0.0;
            for (int j = 0; j < m; j++)
                acc += H[i * m + j] * s[j];
            lam[i] = g[i] - acc;
            sv[i] = s[i];
        }
        for (int p = 0; p < nf; p++)
            lam[fi[p]] = 0.0;
        int same = 1;
        for (int i = 0; i < m; i++) {
            char nu = lam[i] + cpen * (s[i] - h[i]) > 0;
            nup[i] = nu;
            nlow[i] = (lam[i] + cpen * (s[i] - l[i]) < 0) && !nu;
            if (nup[i] != up[i] || nlow[i] != low[i])
                same = 0;
        }
        if (same) {
            settled = 1;
            break;
        }
        memcpy(low, nlow, m);
        memcpy(up, nup, m);
    }
    if (!settled)
        NONE();

    /* ---- polish: minimum-norm LS of the free block on the final active set */
    if (nf) {
        int rank;
        for (int i = 0; i < n; i++) {
            double acc = 0.0;
            for (int q = 0; q < na; q++)
                acc += A[i * m + ai[q]] * sv[ai[q]];
            yv[i] = b[i] - acc;
            for (int p = 0; p < nf; p++)
                F[i * nf + p] = A[i * m + fi[p]];
        }
        if (min_norm_lstsq(F, n, nf, yv, 1e-10, jx, &rank, jw, perm) < 0)
            DECLINE();
        int ok = 1;
        for (int p = 0; p < nf; p++) {
            int i = fi[p];
            double xi = jx[p];
            if (!isfinite(xi))
                DECLINE();
            double slack = 1e-12 * (h[i] - l[i]);
            if (!(xi >= l[i] - slack && xi <= h[i] + slack)) {
                ok = 0;
                break;
            }
        }
        if (ok) {
            memcpy(snew, s, sizeof(double) * m);
            for (int p = 0; p < nf; p++)
                snew[fi[p]] = py_min(py_max(jx[p], l[fi[p]]), h[fi[p]]);
            if (rank == nf && nf <= n) {
                /* full column rank: the unique LS minimizer on this active set */
                memcpy(s, snew, sizeof(double) * m);
            } else {
                double rn = 0.0, ro = 0.0;
                for (int i = 0; i < n; i++) {
                    double an = 0.0, ao = 0.0;
                    for (int j = 0; j < m; j++) {
                        an += A[i * m + j] * snew[j];
                        ao += A[i * m + j] * sv[j];
                    }
                    r[i] = b[i] - an;
                    r2[i] = b[i] - ao;
                }
                for (int i = 0; i < n; i++) {
                    rn += r[i] * r[i];
                    ro += r2[i] * r2[i];
                }
                if (sqrt(rn) <= sqrt(ro) * (1 + 1e-12) + 1e-300)
                    memcpy(s, snew, sizeof(double) * m);
            }
        }
    }

    /* ---- tau, bounds set exactly; residual ||u - B tau|| */
    for (int i = 0; i < m; i++) {
        if (low[i])
            tau[i] = lo[i];
        else if (up[i])
            tau[i] = hi[i];
        else {
            double t = tp[i] + sc[i] * py_min(py_max(s[i], l[i]), h[i]);
            tau[i] = py_min(py_max(t, lo[i]), hi[i]);
        }
    }
    double rr = 0.0;
    for (int i = 0; i < n; i++) {
        double acc = 0.0;
        for (int j = 0; j < m; j++)
            acc += Bm[i * m + j] * tau[j];
        double ri = u[i] - acc;
        rr += ri * ri;
    }

    for (int i = 0; i < m; i++) {
        tau_out[i] = tau[i];
        active_out[i] = low[i] ? -1 : (up[i] ? 1 : 0);
    }
    *iterations = it + 1;
    *residual = sqrt(rr);
done:
    if (heap)
        PyMem_Free(heap);
    return result;
}
#undef FINISH
#undef DECLINE
#undef NONE

static int capi_solve(int n, int m, const double *B, const double *u, const double *lo,
                      const double *hi, double reg, const double *warm, int max_iter,
                      double *tau, signed char *active, int *iterations, double *residual)
{
    if (n < 1 || m < 1 || n > 4096 || m > 4096)
        return BLS_DECLINE;
    return bls_core(n, m, B, u, lo, hi, reg, warm ? WARM_GIVEN : WARM_COLD, warm, max_iter, tau,
                    active, iterations, residual);
}

static BlsCAPI c_api = {BLS_CAPI_VERSION, capi_solve};

/* ----------------------------------------------------------------------- solve() -------- */

PyDoc_STRVAR(solve_doc,
"solve(B, u, lo, hi, reg, warm_start, max_iter) -> (tau, info) | None | NotImplemented\n\n"
"bounded_ls._bls_fast_python compiled: min ||u - B tau|| s.t. lo <= tau <= hi by PDAS on the\n"
"scaled box QP with Tikhonov weight reg, then the minimum-norm polish.  Same arguments and\n"
"the same result: (tau, {'method': 'pdas', 'iterations', 'residual', 'active'}) or None.\n"
"NotImplemented: this case is left to the Python reference (see the module docstring).");

/* a 1-d (cols = 1) or 2-d strided float64 buffer into a contiguous row-major array */
static void copy_strided(const Py_buffer *v, int rows, int cols, double *out)
{
    for (int i = 0; i < rows; i++) {
        const char *row = (const char *)v->buf + i * v->strides[0];
        for (int j = 0; j < cols; j++)
            out[(size_t)i * cols + j] = rd(row + (v->ndim == 2 ? j * v->strides[1] : 0));
    }
}

static PyObject *bls_solve(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    (void)self;
    if (nargs != 7) {
        PyErr_SetString(PyExc_TypeError, "solve() takes 7 arguments (B, u, lo, hi, reg, warm_start, max_iter)");
        return NULL;
    }
    PyObject *oB = args[0], *ou = args[1], *olo = args[2], *ohi = args[3], *ows = args[5];
    /* bounded_least_squares passes a float reg and max_iter 25; anything else: Python */
    double reg = PyFloat_AsDouble(args[4]);
    long max_iter = PyLong_AsLong(args[6]);
    if (PyErr_Occurred()) {
        PyErr_Clear();
        Py_RETURN_NOTIMPLEMENTED;
    }
    if (!(Py_TYPE(oB) == (PyTypeObject *)ndarray_type && Py_TYPE(ou) == (PyTypeObject *)ndarray_type
          && Py_TYPE(olo) == (PyTypeObject *)ndarray_type && Py_TYPE(ohi) == (PyTypeObject *)ndarray_type))
        Py_RETURN_NONE;

    PyObject *result = NULL, *tau_arr = NULL, *act_arr = NULL;
    Buf in[5];
    memset(in, 0, sizeof in);
    double *mem = NULL;

    PyObject *objs[4] = {oB, ou, olo, ohi};
    for (int k = 0; k < 4; k++) {
        if (PyObject_GetBuffer(objs[k], &in[k].v, PyBUF_STRIDED_RO | PyBUF_FORMAT) < 0) {
            PyErr_Clear();
            result = Py_NewRef(Py_NotImplemented);
            goto done;
        }
        in[k].held = 1;
        /* float64 is exported as "d"; anything else is either not float64 (None in Python)
         * or an unusual spelling of it: let Python decide. */
        if (in[k].v.format == NULL || strcmp(in[k].v.format, "d") != 0) {
            result = Py_NewRef(Py_NotImplemented);
            goto done;
        }
    }
    if (in[0].v.ndim != 2) {
        result = Py_NewRef(Py_None);
        goto done;
    }
    const Py_ssize_t n_ = in[0].v.shape[0], m_ = in[0].v.shape[1];
    if (in[1].v.ndim != 1 || in[1].v.shape[0] != n_ || in[2].v.ndim != 1 || in[2].v.shape[0] != m_
        || in[3].v.ndim != 1 || in[3].v.shape[0] != m_ || n_ == 0 || m_ == 0) {
        result = Py_NewRef(Py_None);
        goto done;
    }
    if (n_ > 4096 || m_ > 4096) {         /* int indexing below */
        result = Py_NewRef(Py_NotImplemented);
        goto done;
    }
    const int n = (int)n_, m = (int)m_;
    /* contiguous copies of B, u, lo, hi; the warm start, tau and the active set */
    mem = PyMem_Malloc(sizeof(double) * ((size_t)n * m + n + 4 * (size_t)m) + (size_t)m);
    if (mem == NULL) {
        PyErr_NoMemory();
        goto done;
    }
    double *B = mem, *u = B + (size_t)n * m, *lo = u + n, *hi = lo + m, *ws = hi + m;
    double *tau = ws + m;
    signed char *active = (signed char *)(tau + m);
    copy_strided(&in[0].v, n, m, B);
    copy_strided(&in[1].v, n, 1, u);
    copy_strided(&in[2].v, m, 1, lo);
    copy_strided(&in[3].v, m, 1, hi);

    /* the warm start's verdicts, applied by bls_core where the reference reads it */
    int warm_mode = WARM_COLD;
    if (ows != Py_None) {
        if (Py_TYPE(ows) != (PyTypeObject *)ndarray_type) {
            warm_mode = WARM_DECLINE;     /* lists etc.: np.asarray in Python */
        } else if (PyObject_GetBuffer(ows, &in[4].v, PyBUF_STRIDED_RO | PyBUF_FORMAT) < 0) {
            PyErr_Clear();
            warm_mode = WARM_DECLINE;
        } else {
            in[4].held = 1;
            warm_mode = WARM_GIVEN;
            if (in[4].v.ndim != 1 || in[4].v.shape[0] != m)
                warm_mode = WARM_NONE;    /* ws.shape != (m,) */
            for (int i = 0; i < m && warm_mode == WARM_GIVEN; i++)
                if (ws_value(&in[4].v, i, &ws[i]) < 0)
                    warm_mode = WARM_DECLINE;
        }
    }
    int iterations;
    double residual;
    int status = bls_core(n, m, B, u, lo, hi, reg, warm_mode, ws, max_iter, tau, active,
                          &iterations, &residual);
    if (status == BLS_NOMEM) {
        PyErr_NoMemory();
        goto done;
    }
    if (status != BLS_OK) {
        result = Py_NewRef(status == BLS_NONE ? Py_None : Py_NotImplemented);
        goto done;
    }

    /* ---- results: float64 tau and default-int active, as np.array(list) in Python */
    {
        PyObject *mobj = PyLong_FromLong(m);
        if (mobj == NULL)
            goto done;
        PyObject *a1[1] = {mobj};
        tau_arr = PyObject_Vectorcall(np_empty, a1, 1, NULL);
        PyObject *a2[2] = {mobj, (PyObject *)&PyLong_Type};
        act_arr = tau_arr ? PyObject_Vectorcall(np_empty, a2, 2, NULL) : NULL;
        Py_DECREF(mobj);
        if (act_arr == NULL)
            goto done;
        Py_buffer ot, oa;
        if (PyObject_GetBuffer(tau_arr, &ot, PyBUF_WRITABLE | PyBUF_C_CONTIGUOUS) < 0)
            goto done;
        memcpy(ot.buf, tau, sizeof(double) * m);
        PyBuffer_Release(&ot);
        if (PyObject_GetBuffer(act_arr, &oa, PyBUF_WRITABLE | PyBUF_C_CONTIGUOUS) < 0)
            goto done;
        for (int i = 0; i < m; i++) {
            int v = active[i];
            if (oa.itemsize == 8) {
                int64_t t = v;
                memcpy((char *)oa.buf + 8 * i, &t, 8);
            } else if (oa.itemsize == 4) {
                int32_t t = v;
                memcpy((char *)oa.buf + 4 * i, &t, 4);
            } else {
                PyBuffer_Release(&oa);
                PyErr_SetString(PyExc_RuntimeError, "unexpected default integer size");
                goto done;
            }
        }
        PyBuffer_Release(&oa);
        PyObject *info = PyDict_New();
        if (info == NULL)
            goto done;
        PyObject *itv = PyLong_FromLong(iterations), *res = PyFloat_FromDouble(residual);
        if (itv == NULL || res == NULL || PyDict_SetItem(info, key_method, str_pdas) < 0
            || PyDict_SetItem(info, key_iterations, itv) < 0
            || PyDict_SetItem(info, key_residual, res) < 0
            || PyDict_SetItem(info, key_active, act_arr) < 0) {
            Py_XDECREF(itv);
            Py_XDECREF(res);
            Py_DECREF(info);
            goto done;
        }
        Py_DECREF(itv);
        Py_DECREF(res);
        result = PyTuple_Pack(2, tau_arr, info);
        Py_DECREF(info);
    }

done:
    Py_XDECREF(tau_arr);
    Py_XDECREF(act_arr);
    release(in, 5);
    PyMem_Free(mem);
    return result;
}

PyDoc_STRVAR(lstsq_doc,
"min_norm_lstsq(F, y, rcond) -> (x, rank) | None\n\n"
"The kernel's minimum-norm least squares (one-sided Jacobi SVD, singular values <=\n"
"rcond * sigma_max treated as zero) on lists: F a list of rows, y a list; for tests.\n"
"None if the Jacobi sweeps did not converge.");

static PyObject *bls_lstsq(PyObject *self, PyObject *args)
{
    (void)self;
    PyObject *oF, *oy;
    double rcond;
    if (!PyArg_ParseTuple(args, "OOd", &oF, &oy, &rcond))
        return NULL;
    PyObject *Fs = PySequence_Fast(oF, "F must be a sequence of rows");
    if (Fs == NULL)
        return NULL;
    Py_ssize_t rows = PySequence_Fast_GET_SIZE(Fs), cols = -1;
    PyObject *result = NULL;
    double *mem = NULL;
    if (rows < 1 || rows > 4096) {
        PyErr_SetString(PyExc_ValueError, "F needs 1..4096 rows");
        goto out;
    }
    for (Py_ssize_t i = 0; i < rows; i++) {
        Py_ssize_t c = PySequence_Size(PySequence_Fast_GET_ITEM(Fs, i));
        if (c < 0)
            goto out;
        if (cols < 0)
            cols = c;
        if (c != cols || c < 1 || c > 4096) {
            PyErr_SetString(PyExc_ValueError, "F must be a non-empty rectangular list of rows");
            goto out;
        }
    }
    if (PySequence_Size(oy) != rows) {
        if (!PyErr_Occurred())
            PyErr_SetString(PyExc_ValueError, "y must have one entry per row of F");
        goto out;
    }
    {
        mem = PyMem_Malloc(sizeof(double) * (size_t)(rows * cols * 2 + cols * cols + rows * 2
                                                     + cols * 5 + 8));
        if (mem == NULL) {
            PyErr_NoMemory();
            goto out;
        }
        double *F = mem, *y = F + rows * cols, *x = y + rows, *work = x + cols;
        int *perm = (int *)(work + rows * cols + rows + cols * cols + 2 * cols);
        for (Py_ssize_t i = 0; i < rows; i++) {
            PyObject *row = PySequence_Fast(PySequence_Fast_GET_ITEM(Fs, i), "row");
            if (row == NULL)
                goto out;
            for (Py_ssize_t j = 0; j < cols; j++) {
                F[i * cols + j] = PyFloat_AsDouble(PySequence_Fast_GET_ITEM(row, j));
                if (PyErr_Occurred()) {
                    Py_DECREF(row);
                    goto out;
                }
            }
            Py_DECREF(row);
            PyObject *yi = PySequence_GetItem(oy, i);
            if (yi == NULL)
                goto out;
            y[i] = PyFloat_AsDouble(yi);
            Py_DECREF(yi);
            if (PyErr_Occurred())
                goto out;
        }
        int rank;
        if (min_norm_lstsq(F, (int)rows, (int)cols, y, rcond, x, &rank, work, perm) < 0) {
            result = Py_NewRef(Py_None);
            goto out;
        }
        PyObject *xl = PyList_New(cols);
        if (xl == NULL)
            goto out;
        for (Py_ssize_t j = 0; j < cols; j++) {
            PyObject *v = PyFloat_FromDouble(x[j]);
            if (v == NULL) {
                Py_DECREF(xl);
                goto out;
            }
            PyList_SET_ITEM(xl, j, v);
        }
        result = Py_BuildValue("(Ni)", xl, rank);
    }
out:
    PyMem_Free(mem);
    Py_DECREF(Fs);
    return result;
}

static PyMethodDef methods[] = {
    {"solve", (PyCFunction)(void (*)(void))bls_solve, METH_FASTCALL, solve_doc},
    {"min_norm_lstsq", bls_lstsq, METH_VARARGS, lstsq_doc},
    {NULL, NULL, 0, NULL},
};

PyDoc_STRVAR(module_doc,
"Compiled bounded least squares: bounded_ls._bls_fast_python (PDAS + minimum-norm polish)\n"
"in C.  bounded_ls._bls_fast dispatches here when the kernel is built and enabled.");

static struct PyModuleDef moddef = {PyModuleDef_HEAD_INIT, "_bls", module_doc, -1, methods,
                                    NULL, NULL, NULL, NULL};

PyMODINIT_FUNC PyInit__bls(void)
{
    PyObject *np = PyImport_ImportModule("numpy");
    if (np == NULL)
        return NULL;
    ndarray_type = PyObject_GetAttrString(np, "ndarray");
    np_empty = PyObject_GetAttrString(np, "empty");
    Py_DECREF(np);
    if (ndarray_type == NULL || np_empty == NULL || !PyType_Check(ndarray_type))
        return NULL;
    key_method = PyUnicode_InternFromString("method");
    key_iterations = PyUnicode_InternFromString("iterations");
    key_residual = PyUnicode_InternFromString("residual");
    key_active = PyUnicode_InternFromString("active");
    str_pdas = PyUnicode_InternFromString("pdas");
    if (!key_method || !key_iterations || !key_residual || !key_active || !str_pdas)
        return NULL;
    PyObject *module = PyModule_Create(&moddef);
    if (module && export_c_api(module, &c_api, BLS_CAPI_NAME) < 0)
        Py_CLEAR(module);
    return module;
}
