/*
 * The tilt-rotor W∞ law's whole per-sample update in one call: sobolev_drake.native._fused.
 *
 * TiltrotorWInfController._update with the default ("thesis") law of tiltrotor/law.py
 * (make_law) computes, per sample, from x = [q; q̇] (16, thesis order), the reference (12), the
 * measured wind (3) and the old record [∫e_c | τ̄ | n | u* | residual | saturation] (30):
 *
 *   tilt reference      _regulated_values: U, U̇ of the reference (forward_air_speed), α(U)
 *                       by the schedule (the plant-trim cubic spline or the data polynomial)
 *   q̈_des               _rnea's desired_acceleration (Sobolev gains, (7.81)), or the law's
 *                       Python desired_acceleration (another weighting, e.g. the envelope
 *                       gain schedule) called with the lists the Python path gives it
 *   B, ϑ_passive, V     _forces' affine_terms at the last propeller speeds (through thrust)
 *   u*                  _rnea's inverse dynamics at q̈_des minus ϑ_passive
 *   lo, up              _forces' surface_bounds of V[1..4] (7.85)-(7.89)
 *   τ̄                   _bls's solve (PDAS + polish), warm-started from an active set
 *   n                   _forces' newton_speed from the last speeds (7.90)
 *   the record          ‖u* − Bτ̄‖, saturation flags, forward-Euler ∫e_c
 *
 * calling the same C code as the Python path (through the modules' _C_API capsules, capi.h),
 * in the same order on the same floats.  So the record equals the Python path's bit for bit,
 * except the residual, which numpy computes with BLAS (equal to rounding).
 *
 * sample() returns False ("declined", nothing written) wherever the Python path would take a
 * decision this code does not: a non-finite input, no positive last speed (the bracketing
 * solver), an exception of a kernel (the Python path raises its descriptive error), the
 * allocation kernel returning None / NotImplemented (the general solver), Newton failing (the
 * bracketing solver), a non-finite result, a q̈_des callback result that is not 8 numbers.  The
 * caller then runs the Python path (which calls a q̈_des callback again).  An exception raised
 * by the callback propagates, as it would from the Python path.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "capi.h"
#include "pyconvert.h"

#define CAPSULE_NAME "sobolev_drake.native.fused.Sample"
#define SCHEDULE_SPLINE 0
#define SCHEDULE_POLYNOMIAL 1
#define MAX_PIECES 100000
#define N_RECORD 30
#define N_ACTIVE 8

static const RneaCAPI *rnea_api;
static const ForcesCAPI *forces_api;
static const BlsCAPI *bls_api;

typedef struct {
    PyObject *owned[3];          /* the kernels' capsules, kept alive */
    PyObject *qdd_callback;      /* NULL, or the law's Python desired_acceleration (owned) */
    const void *rnea, *qdd, *forces;
    int kind;                    /* SCHEDULE_SPLINE or SCHEDULE_POLYNOMIAL */
    int npieces;                 /* spline: intervals (knots npieces + 1) */
    int np0, np1, np2;           /* polynomial: coefficient counts of p, p', p'' */
    double *data;                /* knots + 4 npieces coefficients, or p, p', p'' */
    double lo, hi;               /* schedule range of U */
    double bounds[8];            /* s, c, f_lo, f_hi, t_lo, t_hi, δ_lo, δ_hi */
    double reg, newton_rtol, period, rel_tol, min_width;
    long max_iter, newton_iterations;
    double qdd_work[64];
} Sample;

static void free_sample(PyObject *capsule)
{
    Sample *S = (Sample *)PyCapsule_GetPointer(capsule, CAPSULE_NAME);
    if (S) {
        for (int i = 0; i < 3; i++)
            Py_XDECREF(S->owned[i]);
        Py_XDECREF(S->qdd_callback);
        free(S->data);
        free(S);
    }
}

/* dict[key] as a float / an int in [lo, hi] */
static int get_double(PyObject *d, const char *key, double *out)
{
    return dict_double(d, "make_sample", key, out);
}

static int get_long(PyObject *d, const char *key, long lo, long hi, long *out)
{
    return dict_long(d, "make_sample", key, lo, hi, out);
}

/* a list's length (for the schedule's arrays) */
static Py_ssize_t list_size(PyObject *d, const char *key)
{
    PyObject *v = dict_item(d, "make_sample", key);
    return v ? PySequence_Size(v) : -1;
}

PyDoc_STRVAR(make_doc,
"make_sample(constants: dict) -> capsule of one law's per-sample constants: the kernels'\n"
"capsules (rnea_model, qdd_law, forces_model), the tilt schedule (schedule 0: knots,\n"
"coefficients (4 per interval, highest power first); schedule 1: poly, poly_d1, poly_d2;\n"
"both lo, hi), bounds (8), reg, max_iter, newton_iterations, newton_rtol, period, rel_tol,\n"
"min_width, and optionally qdd_callback: a callable f(q, qdot, e_int, tracked, reference,\n"
"wind) -> 8 floats that replaces the compiled q̈_des (see tiltrotor/compiled_sample.py).");

static PyObject *make_sample(PyObject *self, PyObject *args)
{
    PyObject *d;
    if (!PyArg_ParseTuple(args, "O!", &PyDict_Type, &d))
        return NULL;
    Sample *S = (Sample *)calloc(1, sizeof(Sample));
    if (!S)
        return PyErr_NoMemory();
    static const char *caps[3] = {"rnea_model", "qdd_law", "forces_model"};
    for (int i = 0; i < 3; i++) {
        PyObject *c = dict_item(d, "make_sample", caps[i]);
        if (!c)
            goto fail;
        Py_INCREF(c);
        S->owned[i] = c;
    }
    S->rnea = rnea_api->model(S->owned[0]);
    S->qdd = S->rnea ? rnea_api->qdd_law(S->owned[1]) : NULL;
    S->forces = S->qdd ? forces_api->model(S->owned[2]) : NULL;
    if (!S->forces)
        goto fail;
    int n, nc, n_ref, work;
    rnea_api->qdd_sizes(S->qdd, &n, &nc, &n_ref, &work);
    if (rnea_api->model_size(S->rnea) != 8 || n != 8 || nc != 3 || n_ref != 6
        || work > (int)(sizeof(S->qdd_work) / sizeof(double))) {
        PyErr_SetString(PyExc_ValueError, "make_sample: the kernels are not those of the "
                        "tilt-rotor (8 coordinates, 3 controlled, 6 tracked)");
        goto fail;
    }
    long kind;
    if (get_long(d, "schedule", 0, 1, &kind) || get_double(d, "lo", &S->lo)
        || get_double(d, "hi", &S->hi))
        goto fail;
    S->kind = (int)kind;
    if (!(S->lo <= S->hi)) {
        PyErr_SetString(PyExc_ValueError, "make_sample: the schedule needs lo <= hi");
        goto fail;
    }
    if (kind == SCHEDULE_SPLINE) {
        Py_ssize_t nk = list_size(d, "knots");
        if (nk < 0)
            goto fail;
        if (nk < 2 || nk > MAX_PIECES) {
            PyErr_SetString(PyExc_ValueError, "make_sample: knots needs 2 or more entries");
            goto fail;
        }
        S->npieces = (int)nk - 1;
        S->data = (double *)malloc(sizeof(double) * (size_t)(nk + 4 * S->npieces));
        if (!S->data) {
            PyErr_NoMemory();
            goto fail;
        }
        if (dict_doubles(d, "knots", nk, S->data)
            || dict_doubles(d, "coefficients", 4 * (Py_ssize_t)S->npieces, S->data + nk))
            goto fail;
    } else {
        Py_ssize_t a = list_size(d, "poly"), b = list_size(d, "poly_d1"),
                   c = list_size(d, "poly_d2");
        if (a < 0 || b < 0 || c < 0)
            goto fail;
        /* np.polyder of a linear or constant schedule is empty: polyval of none is 0 */
        if (a > 64 || b > 64 || c > 64) {
            PyErr_SetString(PyExc_ValueError, "make_sample: polynomials need at most 64 coefficients");
            goto fail;
        }
        S->np0 = (int)a, S->np1 = (int)b, S->np2 = (int)c;
        S->data = (double *)malloc(sizeof(double) * (size_t)(a + b + c + 1));
        if (!S->data) {
            PyErr_NoMemory();
            goto fail;
        }
        if (dict_doubles(d, "poly", a, S->data) || dict_doubles(d, "poly_d1", b, S->data + a)
            || dict_doubles(d, "poly_d2", c, S->data + a + b))
            goto fail;
    }
    PyObject *callback = PyDict_GetItemString(d, "qdd_callback");      /* borrowed */
    if (callback && callback != Py_None) {
        if (!PyCallable_Check(callback)) {
            PyErr_Format(PyExc_TypeError, "make_sample: qdd_callback must be callable or None, "
                         "got %s", Py_TYPE(callback)->tp_name);
            goto fail;
        }
        Py_INCREF(callback);
        S->qdd_callback = callback;
    }
    if (dict_doubles(d, "bounds", 8, S->bounds) || get_double(d, "reg", &S->reg)
        || get_long(d, "max_iter", 1, 1000000, &S->max_iter)
        || get_long(d, "newton_iterations", 0, 1000000, &S->newton_iterations)
        || get_double(d, "newton_rtol", &S->newton_rtol) || get_double(d, "period", &S->period)
        || get_double(d, "rel_tol", &S->rel_tol) || get_double(d, "min_width", &S->min_width))
        goto fail;
    PyObject *cap = PyCapsule_New(S, CAPSULE_NAME, free_sample);
    if (!cap)
        goto fail;
    return cap;
fail:
    for (int i = 0; i < 3; i++)
        Py_XDECREF(S->owned[i]);
    Py_XDECREF(S->qdd_callback);
    free(S->data);
    free(S);
    return NULL;
}

/* Python's max(a, b) / min(a, b) on floats (the first argument unless the second is strictly
 * larger / smaller) */
static inline double py_max(double a, double b) { return b > a ? b : a; }
static inline double py_min(double a, double b) { return b < a ? b : a; }

/* np.polyval(p, x): y = 0; y = y x + p_k for each coefficient, highest power first */
static double polyval(const double *p, int k, double x)
{
    double y = 0.0;
    for (int i = 0; i < k; i++)
        y = y * x + p[i];
    return y;
}

/* the tilt schedule U -> (α, α', α''): plant_trim_schedule's sched or
 * tilt_schedule_polynomial's schedule (tiltrotor/law.py, tiltrotor/controller.py) */
static void schedule(const Sample *S, double U, double *a, double *da, double *dda)
{
    int inside = S->lo <= U && U <= S->hi;
    double Uc = py_min(py_max(U, S->lo), S->hi);
    if (S->kind == SCHEDULE_POLYNOMIAL) {
        const double *p = S->data, *p1 = p + S->np0, *p2 = p1 + S->np1;
        *a = polyval(p, S->np0, Uc);
        *da = inside ? polyval(p1, S->np1, Uc) : 0.0;
        *dda = inside ? polyval(p2, S->np2, Uc) : 0.0;
        return;
    }
    const double *xs = S->data, *coefs = xs + S->npieces + 1;
    int lo = 0, hi = S->npieces + 1;          /* bisect_right(xs, Uc) */
    while (lo < hi) {
        int mid = (lo + hi) / 2;
        if (Uc < xs[mid])
            hi = mid;
        else
            lo = mid + 1;
    }
    int i = lo - 1;
    i = i < 0 ? 0 : (i > S->npieces - 1 ? S->npieces - 1 : i);
    const double *c = coefs + 4 * (size_t)i;
    double x = Uc - xs[i];
    *a = ((c[0] * x + c[1]) * x + c[2]) * x + c[3];
    if (!inside) {
        *da = *dda = 0.0;
        return;
    }
    *da = (3.0 * c[0] * x + 2.0 * c[1]) * x + c[2];
    *dda = 6.0 * c[0] * x + 2.0 * c[1];
}

/* q̈_des by the law's Python callback, called as TiltrotorWInfLaw.step calls it (lists of
 * floats q, q̇, ∫e_c, tracked, reference, wind): 0, -1 with the callback's exception set, or 1
 * when its result is not 8 numbers (declined: the Python path decides) */
static int callback_qdd(const Sample *S, const double *q, const double *qd, const double *eint,
                        const double *tracked, const double *r, const double *w, double *qdd)
{
    PyObject *args[6] = {list_of(q, 8), list_of(qd, 8), list_of(eint, 3), list_of(tracked, 18),
                         list_of(r, 12), list_of(w, 3)};
    PyObject *result = NULL;
    int ok = 1;
    for (int i = 0; i < 6; i++)
        ok &= args[i] != NULL;
    if (ok)
        result = PyObject_Vectorcall(S->qdd_callback, args, 6, NULL);
    for (int i = 0; i < 6; i++)
        Py_XDECREF(args[i]);
    if (!result)
        return -1;
    int status = read_doubles(result, 8, qdd, "qdd") ? 1 : 0;
    Py_DECREF(result);
    if (status)
        PyErr_Clear();
    return status;
}

static int all_finite(const double *v, int n)
{
    for (int i = 0; i < n; i++)
        if (!isfinite(v[i]))
            return 0;
    return 1;
}

PyDoc_STRVAR(sample_doc,
"sample(capsule, x, reference, wind, old_record, old_active, record_out, active_out) -> bool\n\n"
"One sample of the tilt-rotor law (module docstring): the new 30-entry record into\n"
"record_out and the allocation's active set (-1, 0, +1) into active_out; old_active is the\n"
"warm start (signs; any NaN: none, the cold start).  False: declined, nothing written (the\n"
"caller runs the Python path).");

static PyObject *py_sample(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 8) {
        PyErr_SetString(PyExc_TypeError, "sample takes (capsule, x, reference, wind, old_record, "
                        "old_active, record_out, active_out)");
        return NULL;
    }
    Sample *S = (Sample *)PyCapsule_GetPointer(args[0], CAPSULE_NAME);
    double x[16], r[12], w[3], old[N_RECORD], warm[N_ACTIVE];
    if (!S || read_doubles(args[1], 16, x, "x") || read_doubles(args[2], 12, r, "reference")
        || read_doubles(args[3], 3, w, "wind") || read_doubles(args[4], N_RECORD, old, "old_record")
        || read_doubles(args[5], N_ACTIVE, warm, "old_active"))
        return NULL;
    const double *q = x, *qd = x + 8, *eint = old, *n_prev = old + 11;
    /* the Python path checks these (and raises); no positive last speed: the bracketing
     * solver there */
    if (!(all_finite(x, 16) && all_finite(r, 12) && all_finite(w, 3) && all_finite(eint, 3)
          && all_finite(n_prev, 2) && n_prev[0] > 0 && n_prev[1] > 0))
        Py_RETURN_FALSE;

    /* regulated references (_regulated_values, forward_air_speed): tilt from the schedule */
    double psi = r[3], psid = r[7], psidd = r[11];
    double c = cos(psi), s = sin(psi);
    double vx = r[4] - w[0], vy = r[5] - w[1];
    double U = c * vx + s * vy;
    double Udot = c * r[8] + s * r[9] + psid * (-s * vx + c * vy);
    if (!(isfinite(U) && isfinite(Udot)))
        Py_RETURN_FALSE;
    double al, da, dda;
    schedule(S, U, &al, &da, &dda);
    double ald = da * Udot, aldd = dda * pow(Udot, 2.0);
    double tracked[18] = {r[0], r[1], r[2], al, al, psi, r[4], r[5], r[6], ald, ald, psid,
                          r[8], r[9], r[10], aldd, aldd, psidd};

    /* q̈_des, B and ϑ_passive, u* = ID(q, q̇, q̈_des) − ϑ_passive */
    double qdd[8], B[64], passive[8], V6[6], vxz[2], phi[2], u[8];
    if (S->qdd_callback) {
        int status = callback_qdd(S, q, qd, eint, tracked, r, w, qdd);
        if (status < 0)
            return NULL;
        if (status > 0)
            Py_RETURN_FALSE;
    } else {
        rnea_api->desired_acceleration(S->qdd, q, qd, eint, tracked, S->qdd_work, qdd);
    }
    if (forces_api->affine_terms(S->forces, q, qd, w, n_prev, 1, B, passive, V6, vxz, phi)) {
        PyErr_Clear();                    /* the Python path raises it */
        Py_RETURN_FALSE;
    }
    if (!all_finite(passive, 8))
        Py_RETURN_FALSE;
    rnea_api->inverse_dynamics(S->rnea, q, qd, qdd, u);
    for (int i = 0; i < 8; i++)
        u[i] -= passive[i];

    /* bounds, allocation (warm start: the last active set), thrust inversion */
    double lo[8], up[8], tau[8], n[2], res;
    signed char active[8];
    int iterations;
    if (forces_api->surface_bounds(V6 + 1, S->bounds, lo, up))
        Py_RETURN_FALSE;
    int cold = 0;                         /* NaN: no last active set, the cold start */
    for (int i = 0; i < N_ACTIVE; i++)
        cold |= isnan(warm[i]) != 0;
    int status = bls_api->solve(8, 8, B, u, lo, up, S->reg, cold ? NULL : warm, (int)S->max_iter,
                                tau, active, &iterations, &res);
    if (status == BLS_NOMEM)
        return PyErr_NoMemory();
    if (status != BLS_OK)
        Py_RETURN_FALSE;
    if (forces_api->newton_speed(S->forces, tau, vxz, phi, n_prev, S->newton_iterations,
                                 S->newton_rtol, n))
        Py_RETURN_FALSE;

    /* the record [∫e_c | τ̄ | n | u* | residual | saturation]; forward-Euler ∫e_c */
    double rec[N_RECORD], act[N_ACTIVE];
    for (int k = 0; k < 3; k++)
        rec[k] = eint[k] + S->period * (x[5 + k] - r[k]);
    memcpy(rec + 3, tau, sizeof tau);
    memcpy(rec + 11, n, sizeof n);
    memcpy(rec + 13, u, sizeof u);
    rec[21] = res;
    forces_api->saturation_flags(tau, lo, up, S->rel_tol, S->min_width, rec + 22);
    if (!all_finite(rec, N_RECORD))
        Py_RETURN_FALSE;
    for (int i = 0; i < N_ACTIVE; i++)
        act[i] = active[i];
    if (write_doubles(args[6], N_RECORD, rec, "record_out")
        || write_doubles(args[7], N_ACTIVE, act, "active_out"))
        return NULL;
    Py_RETURN_TRUE;
}

static PyMethodDef methods[] = {
    {"make_sample", (PyCFunction)make_sample, METH_VARARGS, make_doc},
    {"sample", (PyCFunction)(void (*)(void))py_sample, METH_FASTCALL, sample_doc},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef moduledef = {
    PyModuleDef_HEAD_INIT, "_fused",
    "The tilt-rotor law's per-sample update in one call (see fused.c).", -1, methods, NULL,
    NULL, NULL, NULL,
};

/* an interface of another kernel module (module.attr = name), of the version this file was
 * written for; the module is imported first (PyCapsule_Import only looks attributes up below
 * the top-level package) */
static const void *import_api(const char *module, const char *name, int version)
{
    PyObject *mod = PyImport_ImportModule(module);
    if (!mod)
        return NULL;
    Py_DECREF(mod);
    const int *api = (const int *)PyCapsule_Import(name, 0);
    if (!api && !PyErr_ExceptionMatches(PyExc_ImportError)) {
        PyErr_Clear();                    /* a build without the interface: not importable */
        PyErr_Format(PyExc_ImportError, "%s is missing (stale build)", name);
        return NULL;
    }
    if (api && *api != version) {
        PyErr_Format(PyExc_ImportError, "%s has version %d, _fused needs %d (stale build)", name,
                     *api, version);
        return NULL;
    }
    return api;
}

PyMODINIT_FUNC PyInit__fused(void)
{
    rnea_api = (const RneaCAPI *)import_api("sobolev_drake.native._rnea", RNEA_CAPI_NAME,
                                            RNEA_CAPI_VERSION);
    forces_api = !rnea_api ? NULL : (const ForcesCAPI *)import_api(
        "sobolev_drake.native._forces", FORCES_CAPI_NAME, FORCES_CAPI_VERSION);
    bls_api = !forces_api ? NULL : (const BlsCAPI *)import_api(
        "sobolev_drake.native._bls", BLS_CAPI_NAME, BLS_CAPI_VERSION);
    if (!bls_api)
        return NULL;
    return PyModule_Create(&moduledef);
}
