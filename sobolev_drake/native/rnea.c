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
    PyObject *d, *nobj;
    if (!PyArg_ParseTuple(args, "O!", &PyDict_Type, &d))
        return NULL;
    if (!(nobj = PyDict_GetItemString(d, "n"))) {
        PyErr_SetString(PyExc_KeyError, "make_model: missing n");
        return NULL;
    }
    long n = PyLong_AsLong(nobj);
    if (n == -1 && PyErr_Occurred())
        return NULL;
    if (n < 1 || n > MAX_BODIES) {
        PyErr_Format(PyExc_ValueError, "make_model: n must be in [1, %d], got %ld", MAX_BODIES, n);
        return NULL;
    }
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
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef moduledef = {
    PyModuleDef_HEAD_INIT, "_rnea",
    "Compiled recursive Newton-Euler inverse dynamics of a tree of revolute/prismatic joints.",
    -1, methods, NULL, NULL, NULL, NULL,
};

PyMODINIT_FUNC PyInit__rnea(void)
{
    return PyModule_Create(&moduledef);
}
