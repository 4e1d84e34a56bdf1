/*
 * Compiled inverse dynamics of a tree of 1-DOF joints: sobolev_drake.native._rnea.
 *
 * The standard recursive Newton–Euler algorithm in spatial-vector form (Featherstone, "Rigid
 * Body Dynamics Algorithms", Springer 2008, §5.3; Luh, Walker & Paul 1980), body-frame variant:
 * velocities, accelerations and forces of body B are 6-vectors [angular; linear] expressed in B
 * at its origin Bo.  The accelerations are the conventional ones [α; a_Bo] (as Drake's) rather
 * than Featherstone's spatial accelerations, whose linear part a_Bo − ω × v_Bo makes the
 * force of a fast-moving body a difference of large ω × v terms (≈ 30× larger rounding errors
 * at 30 m/s, 30 rad/s).  Gravity enters as a fictitious base acceleration −g, so the result is
 *
 *     tau = M(q) vdot + C(q, v) v − tau_g(q),
 *
 * what MultibodyPlant.CalcInverseDynamics returns with the force elements' contribution (a
 * uniform gravity field and nothing else) as applied forces.  The constants (tree, joint frames,
 * axes, inertias, gravity) come from Python (native/rnea.py), which reads them from the plant
 * and refuses the plants this kernel does not cover.
 *
 * Joint of body B with parent body P: frame F fixed in P (pose X_PF), frame M fixed in B (pose
 * X_BM), X_FM(q) a rotation by q about the unit axis a (revolute) or the translation a q
 * (prismatic), a expressed in F (equal in M).  Equal to Drake to rounding (different operation
 * order); tests/native/test_native_rnea.py compares both.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

#include "capi.h"
#include "pyconvert.h"

#define CAPSULE_NAME "sobolev_drake.native.rnea.Model"
#define MAX_BODIES 100000
#define REVOLUTE 0
#define PRISMATIC 1

typedef struct {
    int parent;              /* index of the parent body in this model, -1 for the world */
    int joint_type;          /* REVOLUTE or PRISMATIC */
    int dof;                 /* index of the joint's coordinate in q, v, vdot and tau */
    double axis[3];          /* joint axis, unit, in F (and M) */
    double R_PF[9], p_PF[3]; /* pose of F in the parent body frame (row-major rotation) */
    double R_MB[9], p_MB[3]; /* pose of the body frame B in M (inverse of X_BM) */
    double R_PB_fixed[9];    /* R_PF R_MB: the body's orientation in P for a prismatic joint */
    double s[6];             /* joint motion subspace in B at Bo, [angular; linear] */
    double sw_x_sv[3];       /* s_angular × s_linear (centripetal term of a revolute joint) */
    double mass;
    double moment[3];        /* mass × p_BoBcm_B (first mass moment about Bo) */
    double inertia[9];       /* rotational inertia about Bo, in B (row-major) */
} Body;

typedef struct {
    int n;                   /* bodies = degrees of freedom */
    double gravity[3];       /* in the world frame */
    Body *bodies;            /* topological order: parent before child */
    double *work;            /* per call: R_PB (9n), p_PB (3n), V (6n), A (6n), F (6n) */
} Model;

/* ------------------------------------- 3-vector and 3×3 helpers (out never aliases an input) */

static void cross(const double *a, const double *b, double *out)
{
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}

/* out = R v (R row-major 3×3) */
static void mat_vec(const double *R, const double *v, double *out)
{
    for (int i = 0; i < 3; i++)
        out[i] = R[3 * i] * v[0] + R[3 * i + 1] * v[1] + R[3 * i + 2] * v[2];
}

/* out = Rᵀ v */
static void mat_t_vec(const double *R, const double *v, double *out)
{
    for (int i = 0; i < 3; i++)
        out[i] = R[i] * v[0] + R[3 + i] * v[1] + R[6 + i] * v[2];
}

/* out = A B (3×3, row-major; out may not alias A or B) */
static void mat_mat(const double *A, const double *B, double *out)
{
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            out[3 * i + j] = A[3 * i] * B[j] + A[3 * i + 1] * B[3 + j] + A[3 * i + 2] * B[6 + j];
}

/* rotation by angle about the unit axis a (Rodrigues: I + sin θ [a]× + (1 − cos θ)[a]×²) */
static void axis_rotation(const double *a, double angle, double *R)
{
    double s = sin(angle), c = cos(angle), t = 1.0 - c;
    double sx = s * a[0], sy = s * a[1], sz = s * a[2];
    double tx = t * a[0], ty = t * a[1], tz = t * a[2];
    R[0] = tx * a[0] + c;
    R[4] = ty * a[1] + c;
    R[8] = tz * a[2] + c;
    R[1] = tx * a[1] - sz;
    R[3] = tx * a[1] + sz;
    R[2] = tx * a[2] + sy;
    R[6] = tx * a[2] - sy;
    R[5] = ty * a[2] - sx;
    R[7] = ty * a[2] + sx;
}

/* ---------------------------------------------------------------- the algorithm ---- */

/* pose of B in its parent P at joint coordinate q: R_PB (row-major) and p_PB (Bo in P) */
static void body_pose(const Body *b, double q, double *R_PB, double *p_PB)
{
    double r[3];
    if (b->joint_type == REVOLUTE) {
        double R_FM[9], R_FB[9];
        axis_rotation(b->axis, q, R_FM);
        mat_mat(R_FM, b->R_MB, R_FB);
        mat_mat(b->R_PF, R_FB, R_PB);
        mat_vec(R_FM, b->p_MB, r);                     /* p_FoBo_F (Mo = Fo) */
    } else {
        memcpy(R_PB, b->R_PB_fixed, sizeof(double) * 9);
        for (int k = 0; k < 3; k++)
            r[k] = b->axis[k] * q + b->p_MB[k];       /* R_FM = I, p_FoMo = a q */
    }
    mat_vec(b->R_PF, r, p_PB);
    for (int k = 0; k < 3; k++)
        p_PB[k] += b->p_PF[k];
}

/* velocity [ω; v] and conventional acceleration [α; a] of P at Po (in P) → those of the point
 * of P coincident with Bo, in B: v + ω × p and a + α × p + ω × (ω × p), p = p_PoBo */
static void shift_to_child(const double *R_PB, const double *p_PB, const double *V_P,
                           const double *A_P, double *V, double *A)
{
    double wxp[3], axp[3], wwxp[3], v[3], a[3];
    cross(V_P, p_PB, wxp);
    cross(A_P, p_PB, axp);
    cross(V_P, wxp, wwxp);
    for (int k = 0; k < 3; k++) {
        v[k] = V_P[3 + k] + wxp[k];
        a[k] = A_P[3 + k] + (axp[k] + wwxp[k]);
    }
    mat_t_vec(R_PB, V_P, V);
    mat_t_vec(R_PB, v, V + 3);
    mat_t_vec(R_PB, A_P, A);
    mat_t_vec(R_PB, a, A + 3);
}

/* Newton–Euler force on a body about Bo, in B, for velocity V = [ω; v] and conventional
 * acceleration A = [α; a] of Bo: [I_o α + ω × I_o ω + h × a; m a + α × h + ω × (ω × h)],
 * h = m p_BoBcm */
static void body_force(const Body *b, const double *V, const double *A, double *F)
{
    double Iw[3], Ia[3], wIw[3], hxa[3], axh[3], wxh[3], wwxh[3];
    mat_vec(b->inertia, V, Iw);
    mat_vec(b->inertia, A, Ia);
    cross(V, Iw, wIw);
    cross(b->moment, A + 3, hxa);
    cross(A, b->moment, axh);
    cross(V, b->moment, wxh);
    cross(V, wxh, wwxh);
    for (int k = 0; k < 3; k++) {
        F[k] = Ia[k] + wIw[k] + hxa[k];
        F[3 + k] = b->mass * A[3 + k] + (axh[k] + wwxh[k]);
    }
}

/* M vdot + C v − tau_g; q, v, vdot, tau indexed by the bodies' dof */
static void inverse_dynamics(const Model *m, const double *q, const double *v, const double *vd,
                             double *tau)
{
    int n = m->n;
    double *R_all = m->work, *p_all = R_all + 9 * n, *V_all = p_all + 3 * n;
    double *A_all = V_all + 6 * n, *F_all = A_all + 6 * n;
    static const double zero6[6] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
    double base_acc[6] = {0.0, 0.0, 0.0, -m->gravity[0], -m->gravity[1], -m->gravity[2]};

    /* outward pass: velocities, accelerations (gravity as base acceleration) and body forces */
    for (int i = 0; i < n; i++) {
        const Body *b = &m->bodies[i];
        double *R = R_all + 9 * i, *p = p_all + 3 * i;
        double *V = V_all + 6 * i, *A = A_all + 6 * i;
        double qd = v[b->dof], qdd = vd[b->dof];
        const double *s_w = b->s, *s_v = b->s + 3;
        body_pose(b, q[b->dof], R, p);
        shift_to_child(R, p, b->parent < 0 ? zero6 : V_all + 6 * b->parent,
                       b->parent < 0 ? base_acc : A_all + 6 * b->parent, V, A);
        /* the joint's motion relative to P; ω (= V[0..2] here) is P's angular velocity:
         * α += s_w q̈ + ω × s_w q̇,  a += s_v q̈ + q̇² s_w × s_v + 2 ω × s_v q̇ (Coriolis) */
        double rel_w[3], rel_v[3], wxw[3], wxv[3];
        for (int k = 0; k < 3; k++) {
            rel_w[k] = s_w[k] * qd;
            rel_v[k] = s_v[k] * qd;
        }
        cross(V, rel_w, wxw);
        cross(V, rel_v, wxv);
        for (int k = 0; k < 3; k++) {
            A[k] += s_w[k] * qdd + wxw[k];
            A[3 + k] += s_v[k] * qdd + (qd * qd * b->sw_x_sv[k] + 2.0 * wxv[k]);
            V[k] += rel_w[k];
            V[3 + k] += rel_v[k];
        }
        body_force(b, V, A, F_all + 6 * i);
    }
    /* inward pass: joint forces, and each body's force added to its parent's */
    for (int i = n - 1; i >= 0; i--) {
        const Body *b = &m->bodies[i];
        const double *F = F_all + 6 * i, *s = b->s;
        tau[b->dof] = (s[0] * F[0] + s[1] * F[1] + s[2] * F[2])
                      + (s[3] * F[3] + s[4] * F[4] + s[5] * F[5]);
        if (b->parent >= 0) {
            const double *R = R_all + 9 * i, *p = p_all + 3 * i;
            double *Fp = F_all + 6 * b->parent, f[3], nP[3], pxf[3];
            mat_vec(R, F + 3, f);
            mat_vec(R, F, nP);
            cross(p, f, pxf);
            for (int k = 0; k < 3; k++) {
                Fp[k] += nP[k] + pxf[k];
                Fp[3 + k] += f[k];
            }
        }
    }
}

/* ---------------------------------------------------------------- model construction ---- */

static void free_model(PyObject *capsule)
{
    Model *m = (Model *)PyCapsule_GetPointer(capsule, CAPSULE_NAME);
    if (m) {
        free(m->bodies);
        free(m->work);
        free(m);
    }
}

/* dict[key] as n finite doubles */
static int get_doubles(PyObject *dict, const char *key, Py_ssize_t n, double *out)
{
    if (dict_doubles(dict, key, n, out))
        return -1;
    for (Py_ssize_t i = 0; i < n; i++)
        if (!isfinite(out[i])) {
            PyErr_Format(PyExc_ValueError, "make_model: %s must be finite", key);
            return -1;
        }
    return 0;
}

/* dict[key] as n integers in [lo, hi], written at byte offset `offset` of each body */
static int get_ints(PyObject *dict, const char *key, long n, int lo, int hi, size_t offset,
                    Body *bodies, double *scratch)
{
    if (get_doubles(dict, key, n, scratch))
        return -1;
    for (long i = 0; i < n; i++) {
        double x = scratch[i];
        if (x != floor(x) || x < lo || x > hi) {
            PyErr_Format(PyExc_ValueError, "make_model: %s[%ld] must be an integer in [%d, %d]",
                         key, i, lo, hi);
            return -1;
        }
        *(int *)((char *)&bodies[i] + offset) = (int)x;
    }
    return 0;
}

/* the per-body constants derived from the pose X_BM (held in R_MB, p_MB on entry) and the axis */
static void derive_body_constants(Body *b)
{
    double R_BM[9], p_BM[3], a_B[3], r[3];
    memcpy(R_BM, b->R_MB, sizeof(R_BM));
    memcpy(p_BM, b->p_MB, sizeof(p_BM));
    for (int i = 0; i < 3; i++)                        /* R_MB = R_BMᵀ */
        for (int j = 0; j < 3; j++)
            b->R_MB[3 * i + j] = R_BM[3 * j + i];
    mat_vec(b->R_MB, p_BM, r);                         /* p_MoBo_M = −R_MB p_BoMo_B */
    for (int k = 0; k < 3; k++) {
        b->p_MB[k] = -r[k];
        b->moment[k] *= b->mass;                       /* centre of mass → first moment */
    }
    mat_mat(b->R_PF, b->R_MB, b->R_PB_fixed);
    mat_vec(R_BM, b->axis, a_B);
    if (b->joint_type == REVOLUTE) {                   /* rotation about the line through Mo */
        memcpy(b->s, a_B, sizeof(a_B));
        cross(p_BM, a_B, b->s + 3);                   /* velocity of Bo: ω × p_MoBo */
        cross(b->s, b->s + 3, b->sw_x_sv);
    } else {
        memcpy(b->s + 3, a_B, sizeof(a_B));
    }
}

static PyObject *make_model(PyObject *self, PyObject *args)
{
    PyObject *d;
    long n;
    if (!PyArg_ParseTuple(args, "O!", &PyDict_Type, &d)
        || dict_long(d, "make_model", "n", 1, MAX_BODIES, &n))
        return NULL;
    Model *m = (Model *)calloc(1, sizeof(Model));
    double *buf = (double *)malloc(sizeof(double) * 9 * (size_t)n);
    if (m) {
        m->n = (int)n;
        m->bodies = (Body *)calloc((size_t)n, sizeof(Body));
        m->work = (double *)malloc(sizeof(double) * 30 * (size_t)n);
    }
    if (!m || !buf || !m->bodies || !m->work) {
        PyErr_NoMemory();
        goto fail;
    }
    Body *bodies = m->bodies;
    int top = (int)n - 1;
    if (get_ints(d, "parent", n, -1, top, offsetof(Body, parent), bodies, buf)
        || get_ints(d, "joint_type", n, REVOLUTE, PRISMATIC, offsetof(Body, joint_type), bodies,
                    buf)
        || get_ints(d, "dof", n, 0, top, offsetof(Body, dof), bodies, buf)
        || get_doubles(d, "gravity", 3, m->gravity))
        goto fail;
    /* tree order and one joint per coordinate (buf: which coordinates are taken) */
    memset(buf, 0, sizeof(double) * n);
    for (long i = 0; i < n; i++) {
        if (bodies[i].parent >= i) {
            PyErr_Format(PyExc_ValueError, "make_model: parent[%ld] = %d must precede body %ld "
                         "(topological order)", i, bodies[i].parent, i);
            goto fail;
        }
        if (buf[bodies[i].dof] != 0.0) {
            PyErr_Format(PyExc_ValueError, "make_model: dof must be a permutation of 0..%ld "
                         "(%d repeats)", n - 1, bodies[i].dof);
            goto fail;
        }
        buf[bodies[i].dof] = 1.0;
    }
    /* per-body vectors, one quantity at a time (X_BM into R_MB, p_MB until derived) */
    struct { const char *key; int size; size_t offset; } fields[] = {
        {"axis", 3, offsetof(Body, axis)},    {"R_PF", 9, offsetof(Body, R_PF)},
        {"p_PF", 3, offsetof(Body, p_PF)},    {"R_BM", 9, offsetof(Body, R_MB)},
        {"p_BM", 3, offsetof(Body, p_MB)},    {"mass", 1, offsetof(Body, mass)},
        {"com", 3, offsetof(Body, moment)},   {"inertia_Bo", 9, offsetof(Body, inertia)},
    };
    for (size_t f = 0; f < sizeof(fields) / sizeof(fields[0]); f++) {
        int size = fields[f].size;
        if (get_doubles(d, fields[f].key, size * n, buf))
            goto fail;
        for (long i = 0; i < n; i++)
            memcpy((char *)&bodies[i] + fields[f].offset, buf + size * i, sizeof(double) * size);
    }
    for (long i = 0; i < n; i++) {
        const double *a = bodies[i].axis;
        if (fabs(sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]) - 1.0) > 1e-12) {
            PyErr_Format(PyExc_ValueError, "make_model: axis of body %ld must be a unit vector", i);
            goto fail;
        }
        derive_body_constants(&bodies[i]);
    }
    PyObject *cap = PyCapsule_New(m, CAPSULE_NAME, free_model);
    if (!cap)
        goto fail;
    free(buf);
    return cap;
fail:
    if (m) {
        free(m->bodies);
        free(m->work);
    }
    free(m);
    free(buf);
    return NULL;
}

/* ------------------------------------------- the W2/W∞ tracking law's per-sample path ---- */
/*
 * One sample of the Sobolev law on a fully actuated or input-coupled plant (thesis (5.26),
 * (5.84)): q̈_des = S q̈_r − K z with z = [x[err_index] − desired; ∫e; x[qdot_s]] (the gain
 * matrix K and the index lists from systems/mechanical_sample.py), then
 * u* = M q̈_des + C q̇ − τ_g + D q̇ by the pass above, and d∫e/dt = z[0 .. n_c).  The Python
 * FloatSample computes the same numbers in numpy (tested equal to rounding).
 */
#define LAW_CAPSULE_NAME "sobolev_drake.native.rnea.TrackingLaw"

typedef struct {
    int n, n_ref, nc, ns, m;     /* m = 2 n_ref + nc + ns columns of the gain */
    int *err_index;              /* 2 n_ref indices into x = [q; q̇] */
    int *qdot_s;                 /* ns indices into x */
    int *tracked;                /* n_ref: the coordinate of each q̈_r entry */
    double *gain;                /* n × m, row-major */
    double *damping;             /* n */
    double *z;                   /* work: m, then acc (n), tau (n) */
} TrackingLaw;

static void free_law(PyObject *capsule)
{
    TrackingLaw *L = (TrackingLaw *)PyCapsule_GetPointer(capsule, LAW_CAPSULE_NAME);
    if (L) {
        free(L->err_index);
        free(L->gain);
        free(L);
    }
}

static int law_ints(PyObject *d, const char *key, int count, int hi, int *out, double *scratch)
{
    if (get_doubles(d, key, count, scratch))
        return -1;
    for (int i = 0; i < count; i++) {
        double x = scratch[i];
        if (x != floor(x) || x < 0 || x >= hi) {
            PyErr_Format(PyExc_ValueError, "make_tracking_law: %s[%d] must be an integer in "
                         "[0, %d)", key, i, hi);
            return -1;
        }
        out[i] = (int)x;
    }
    return 0;
}

static int law_size(PyObject *d, const char *key, long lo, long hi, int *out)
{
    long v;
    if (dict_long(d, "make_tracking_law", key, lo, hi, &v))
        return -1;
    *out = (int)v;
    return 0;
}

static PyObject *make_tracking_law(PyObject *self, PyObject *args)
{
    PyObject *d;
    if (!PyArg_ParseTuple(args, "O!", &PyDict_Type, &d))
        return NULL;
    int n, n_ref, nc, ns;
    if (law_size(d, "n", 1, MAX_BODIES, &n) || law_size(d, "n_ref", 0, n, &n_ref)
        || law_size(d, "nc", 0, n_ref, &nc) || law_size(d, "ns", 0, n, &ns))
        return NULL;
    int m = 2 * n_ref + nc + ns;
    TrackingLaw *L = (TrackingLaw *)calloc(1, sizeof(TrackingLaw));
    double *scratch = (double *)malloc(sizeof(double) * ((size_t)n * m + 2 * (size_t)n + 1));
    if (L) {
        L->err_index = (int *)malloc(sizeof(int) * (2 * (size_t)n_ref + ns + n_ref + 1));
        L->gain = (double *)malloc(sizeof(double) * ((size_t)n * m + n + m + 2 * (size_t)n + 1));
    }
    if (!L || !scratch || !L->err_index || !L->gain) {
        PyErr_NoMemory();
        goto fail;
    }
    L->n = n, L->n_ref = n_ref, L->nc = nc, L->ns = ns, L->m = m;
    L->qdot_s = L->err_index + 2 * n_ref;
    L->tracked = L->qdot_s + ns;
    L->damping = L->gain + (size_t)n * m;
    L->z = L->damping + n;
    if (law_ints(d, "err_index", 2 * n_ref, 2 * n, L->err_index, scratch)
        || law_ints(d, "qdot_s", ns, 2 * n, L->qdot_s, scratch)
        || law_ints(d, "tracked", n_ref, n, L->tracked, scratch)
        || get_doubles(d, "gain", (Py_ssize_t)n * m, L->gain)
        || get_doubles(d, "damping", n, L->damping))
        goto fail;
    PyObject *cap = PyCapsule_New(L, LAW_CAPSULE_NAME, free_law);
    if (!cap)
        goto fail;
    free(scratch);
    return cap;
fail:
    if (L) {
        free(L->err_index);
        free(L->gain);
    }
    free(L);
    free(scratch);
    return NULL;
}

static PyObject *py_tracking_sample(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    /* (model, law, x, desired, qddot_r or None, e_int, u_out, rate_out) -> bool finite */
    if (nargs != 8) {
        PyErr_SetString(PyExc_TypeError, "tracking_sample takes (model, law, x, desired, "
                        "qddot_r, e_int, u_out, rate_out)");
        return NULL;
    }
    Model *model = (Model *)PyCapsule_GetPointer(args[0], CAPSULE_NAME);
    TrackingLaw *L = model ? (TrackingLaw *)PyCapsule_GetPointer(args[1], LAW_CAPSULE_NAME) : NULL;
    if (!L)
        return NULL;
    int n = L->n, n_ref = L->n_ref, nc = L->nc, ns = L->ns, m = L->m;
    if (model->n != n) {
        PyErr_Format(PyExc_ValueError, "tracking_sample: model has %d coordinates, law %d",
                     model->n, n);
        return NULL;
    }
    double small[8 * 32], *buf = small;
    size_t need = 2 * (size_t)n + 2 * (size_t)n_ref + n_ref + nc;
    if (need > sizeof(small) / sizeof(double)) {
        buf = (double *)malloc(sizeof(double) * need);
        if (!buf)
            return PyErr_NoMemory();
    }
    double *x = buf, *des = x + 2 * n, *qddr = des + 2 * n_ref, *eint = qddr + n_ref;
    int has_acc = args[4] != Py_None;
    PyObject *out = NULL;
    if (read_doubles(args[2], 2 * n, x, "x") || read_doubles(args[3], 2 * n_ref, des, "desired")
        || (has_acc && read_doubles(args[4], n_ref, qddr, "qddot_r"))
        || read_doubles(args[5], nc, eint, "e_int"))
        goto done;
    double *z = L->z, *acc = z + m, *tau = acc + n;
    for (int k = 0; k < 2 * n_ref; k++)
        z[k] = x[L->err_index[k]] - des[k];
    for (int k = 0; k < nc; k++)
        z[2 * n_ref + k] = eint[k];
    for (int k = 0; k < ns; k++)
        z[2 * n_ref + nc + k] = x[L->qdot_s[k]];
    for (int i = 0; i < n; i++) {
        const double *K = L->gain + (size_t)i * m;
        double s = 0.0;
        for (int j = 0; j < m; j++)
            s += K[j] * z[j];
        acc[i] = -s;
    }
    if (has_acc)
        for (int k = 0; k < n_ref; k++)
            acc[L->tracked[k]] += qddr[k];
    inverse_dynamics(model, x, x + n, acc, tau);
    int finite = 1;
    for (int i = 0; i < n; i++) {
        tau[i] += L->damping[i] * x[n + i];
        finite &= isfinite(tau[i]) != 0;
    }
    if (write_doubles(args[6], n, tau, "u_out") || write_doubles(args[7], nc, z, "rate_out"))
        goto done;
    out = PyBool_FromLong(finite);
done:
    if (buf != small)
        free(buf);
    return out;
}

/* --------------------------- q̈_des of the Sobolev law in the operation order of Python ---- */
/*
 * MechanicalLaw.desired_acceleration_scalar (systems/mechanical_law.py) operation for
 * operation: the same differences, each row's products summed left to right from zero, so the
 * result equals the Python floats to the bit (Python < 3.12, whose sum() is not compensated).
 */
#define QDD_CAPSULE_NAME "sobolev_drake.native.rnea.DesiredAcceleration"

typedef struct {
    int n, nc, nr, ns, n_ref;
    int *index;                  /* tracked (n_ref), controlled (nc), regulated (nr), stabilized (ns) */
    double *K;                   /* Kc (nc × 3nc), Kr (nr × 2nr), Ks (ns × ns), row-major */
} DesiredAcceleration;

static void free_qdd(PyObject *capsule)
{
    DesiredAcceleration *D = (DesiredAcceleration *)PyCapsule_GetPointer(capsule, QDD_CAPSULE_NAME);
    if (D) {
        free(D->index);
        free(D->K);
        free(D);
    }
}

static PyObject *make_desired_acceleration(PyObject *self, PyObject *args)
{
    PyObject *d;
    if (!PyArg_ParseTuple(args, "O!", &PyDict_Type, &d))
        return NULL;
    int n, nc, nr, ns;
    if (law_size(d, "n", 1, MAX_BODIES, &n) || law_size(d, "nc", 1, n, &nc)
        || law_size(d, "nr", 0, n, &nr) || law_size(d, "ns", 0, n, &ns))
        return NULL;
    if (nc + nr + ns != n) {
        PyErr_Format(PyExc_ValueError, "make_desired_acceleration: nc + nr + ns = %d, n = %d",
                     nc + nr + ns, n);
        return NULL;
    }
    int n_ref = nc + nr;
    size_t nk = 3 * (size_t)nc * nc + 2 * (size_t)nr * nr + (size_t)ns * ns;
    DesiredAcceleration *D = (DesiredAcceleration *)calloc(1, sizeof(DesiredAcceleration));
    double *scratch = (double *)malloc(sizeof(double) * (nk + (size_t)n + n_ref + 1));
    if (D) {
        D->index = (int *)malloc(sizeof(int) * ((size_t)n + n_ref + 1));
        D->K = (double *)malloc(sizeof(double) * (nk + 1));
    }
    if (!D || !scratch || !D->index || !D->K) {
        PyErr_NoMemory();
        goto fail;
    }
    D->n = n, D->nc = nc, D->nr = nr, D->ns = ns, D->n_ref = n_ref;
    int *tr = D->index, *ic = tr + n_ref, *ir = ic + nc, *is = ir + nr;
    if (law_ints(d, "tracked", n_ref, n, tr, scratch) || law_ints(d, "controlled", nc, n, ic, scratch)
        || law_ints(d, "regulated", nr, n, ir, scratch)
        || law_ints(d, "stabilized", ns, n, is, scratch)
        || get_doubles(d, "K", (Py_ssize_t)nk, D->K))
        goto fail;
    PyObject *cap = PyCapsule_New(D, QDD_CAPSULE_NAME, free_qdd);
    if (!cap)
        goto fail;
    free(scratch);
    return cap;
fail:
    if (D) {
        free(D->index);
        free(D->K);
    }
    free(D);
    free(scratch);
    return NULL;
}

/* q̈_des into acc (n) from q, q̇ (n), ∫e (nc), reference (3 n_ref); work: 5 n_ref + nc doubles */
static void qdd_core(const DesiredAcceleration *D, const double *q, const double *qd,
                     const double *eint, const double *ref, double *work, double *acc)
{
    int nc = D->nc, nr = D->nr, ns = D->ns, n_ref = D->n_ref;
    double *e = work, *ed = e + n_ref, *z = ed + n_ref;
    const int *tr = D->index, *ic = tr + n_ref, *ir = ic + nc, *is = ir + nr;
    const double *Kc = D->K, *Kr = Kc + 3 * (size_t)nc * nc, *Ks = Kr + 2 * (size_t)nr * nr;
    const double *qddr = ref + 2 * n_ref;
    for (int k = 0; k < n_ref; k++) {
        e[k] = q[tr[k]] - ref[k];
        ed[k] = qd[tr[k]] - ref[n_ref + k];
    }
    for (int k = 0; k < nc; k++) {                  /* z = ė_c, e_c, ∫e */
        z[k] = ed[k];
        z[nc + k] = e[k];
        z[2 * nc + k] = eint[k];
    }
    for (int k = 0; k < nc; k++) {
        double s = 0.0;
        for (int j = 0; j < 3 * nc; j++)
            s += Kc[(size_t)k * 3 * nc + j] * z[j];
        acc[ic[k]] = qddr[k] - s;
    }
    for (int k = 0; k < nr; k++) {                  /* z = ė_r, e_r */
        z[k] = ed[nc + k];
        z[nr + k] = e[nc + k];
    }
    for (int k = 0; k < nr; k++) {
        double s = 0.0;
        for (int j = 0; j < 2 * nr; j++)
            s += Kr[(size_t)k * 2 * nr + j] * z[j];
        acc[ir[k]] = qddr[nc + k] - s;
    }
    for (int k = 0; k < ns; k++) {
        double s = 0.0;
        for (int j = 0; j < ns; j++)
            s += Ks[(size_t)k * ns + j] * qd[is[j]];
        acc[is[k]] = -s;
    }
}

static PyObject *py_desired_acceleration(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    /* (capsule, q, qdot, e_int, reference) -> list of n floats (NaN nowhere: no uncontrolled DOF) */
    if (nargs != 5) {
        PyErr_SetString(PyExc_TypeError, "desired_acceleration takes (law, q, qdot, e_int, reference)");
        return NULL;
    }
    DesiredAcceleration *D = (DesiredAcceleration *)PyCapsule_GetPointer(args[0], QDD_CAPSULE_NAME);
    if (!D)
        return NULL;
    int n = D->n, nc = D->nc, n_ref = D->n_ref;
    double small[16 * 32], *buf = small;
    /* q, q̇, a (n each), ∫e (nc), reference (3 n_ref), e, ė (n_ref each), z (3 n_ref + nc) */
    size_t need = 3 * (size_t)n + 2 * (size_t)nc + 8 * (size_t)n_ref;
    if (need > sizeof(small) / sizeof(double)) {
        buf = (double *)malloc(sizeof(double) * need);
        if (!buf)
            return PyErr_NoMemory();
    }
    double *q = buf, *qd = q + n, *eint = qd + n, *ref = eint + nc, *e = ref + 3 * n_ref;
    double *acc = e + 5 * (size_t)n_ref + nc;
    PyObject *out = NULL;
    if (read_doubles(args[1], n, q, "q") || read_doubles(args[2], n, qd, "qdot")
        || read_doubles(args[3], nc, eint, "e_int")
        || read_doubles(args[4], 3 * n_ref, ref, "reference"))
        goto done;
    qdd_core(D, q, qd, eint, ref, e, acc);
    out = list_of(acc, n);
done:
    if (buf != small)
        free(buf);
    return out;
}

/* ------------------------------------------------- C interface for other kernels ---- */

static const void *capi_model(PyObject *capsule)
{
    return PyCapsule_GetPointer(capsule, CAPSULE_NAME);
}

static int capi_model_size(const void *model)
{
    return ((const Model *)model)->n;
}

static void capi_inverse_dynamics(const void *model, const double *q, const double *v,
                                  const double *vd, double *tau)
{
    inverse_dynamics((const Model *)model, q, v, vd, tau);
}

static const void *capi_qdd_law(PyObject *capsule)
{
    return PyCapsule_GetPointer(capsule, QDD_CAPSULE_NAME);
}

static void capi_qdd_sizes(const void *law, int *n, int *nc, int *n_ref, int *work)
{
    const DesiredAcceleration *D = (const DesiredAcceleration *)law;
    *n = D->n;
    *nc = D->nc;
    *n_ref = D->n_ref;
    *work = 5 * D->n_ref + D->nc;
}

static void capi_desired_acceleration(const void *law, const double *q, const double *qd,
                                      const double *eint, const double *ref, double *work,
                                      double *acc)
{
    qdd_core((const DesiredAcceleration *)law, q, qd, eint, ref, work, acc);
}

static RneaCAPI c_api = {RNEA_CAPI_VERSION, capi_model, capi_model_size, capi_inverse_dynamics,
                         capi_qdd_law, capi_qdd_sizes, capi_desired_acceleration};

/* ---------------------------------------------------------------- Python entry ---- */

static PyObject *py_inverse_dynamics(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    /* (model, x[2n], vdot[n]) or (model, q[n], v[n], vdot[n]) -> tau list n */
    if (nargs != 3 && nargs != 4) {
        PyErr_SetString(PyExc_TypeError,
                        "inverse_dynamics takes (model, x, vdot) or (model, q, v, vdot)");
        return NULL;
    }
    Model *m = (Model *)PyCapsule_GetPointer(args[0], CAPSULE_NAME);
    if (!m)
        return NULL;
    Py_ssize_t n = m->n;
    double small[4 * 16], *buf = small;
    if (n > 16) {
        buf = (double *)malloc(sizeof(double) * 4 * n);
        if (!buf)
            return PyErr_NoMemory();
    }
    double *q = buf, *v = buf + n, *vd = buf + 2 * n, *tau = buf + 3 * n;
    int err = nargs == 3
        ? (read_doubles(args[1], 2 * n, q, "x") || read_doubles(args[2], n, vd, "vdot"))
        : (read_doubles(args[1], n, q, "q") || read_doubles(args[2], n, v, "v")
           || read_doubles(args[3], n, vd, "vdot"));
    PyObject *out = NULL;
    if (!err) {
        inverse_dynamics(m, q, v, vd, tau);
        out = list_of(tau, n);
    }
    if (buf != small)
        free(buf);
    return out;
}

static PyMethodDef methods[] = {
    {"make_model", (PyCFunction)make_model, METH_VARARGS,
     "make_model(constants: dict) -> capsule holding the tree (see native/rnea.py)."},
    {"inverse_dynamics", (PyCFunction)(void (*)(void))py_inverse_dynamics, METH_FASTCALL,
     "inverse_dynamics(model, x, vdot) or inverse_dynamics(model, q, v, vdot) -> list of n\n"
     "floats M(q) vdot + C(q, v) v - tau_g(q), in the model's coordinate order."},
    {"make_tracking_law", (PyCFunction)make_tracking_law, METH_VARARGS,
     "make_tracking_law(constants: dict) -> capsule of the W2/W∞ law's per-sample constants\n"
     "(see systems/mechanical_sample.py)."},
    {"tracking_sample", (PyCFunction)(void (*)(void))py_tracking_sample, METH_FASTCALL,
     "tracking_sample(model, law, x, desired, qddot_r, e_int, u_out, rate_out) -> bool:\n"
     "u* = M q_des'' + C q' - tau_g + D q' and d(int e)/dt into u_out, rate_out; False when\n"
     "u* is not finite."},
    {"make_desired_acceleration", (PyCFunction)make_desired_acceleration, METH_VARARGS,
     "make_desired_acceleration(constants: dict) -> capsule of the Sobolev law's gains\n"
     "(see systems/mechanical_sample.py)."},
    {"desired_acceleration", (PyCFunction)(void (*)(void))py_desired_acceleration,
     METH_FASTCALL,
     "desired_acceleration(law, q, qdot, e_int, reference) -> list of n floats: q_des'' as\n"
     "MechanicalLaw.desired_acceleration_scalar computes it."},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef moduledef = {
    PyModuleDef_HEAD_INIT, "_rnea",
    "Compiled recursive Newton-Euler inverse dynamics of a tree of revolute/prismatic joints.",
    -1, methods, NULL, NULL, NULL, NULL,
};

PyMODINIT_FUNC PyInit__rnea(void)
{
    PyObject *module = PyModule_Create(&moduledef);
    if (module && export_c_api(module, &c_api, RNEA_CAPI_NAME) < 0)
        Py_CLEAR(module);
    return module;
}
