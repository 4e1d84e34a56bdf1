/*
 * Compiled evaluation of a piecewise reference trajectory: sobolev_drake.native._reference.
 *
 * The float fast path of PiecewiseTrajectory.evaluate_scalar (systems/references.py) for the
 * coordinate kinds built by const(), sine() and poly(): the same operations in the same order,
 * so the result is equal to the bit (tests/native/test_native_reference.py).  Piece k applies
 * on (b_{k-1}, b_k]: the piece index is Python's bisect_left over the breakpoints.
 *
 *   const  f = c                                  (c, 0, 0)
 *   sine   arg = w (t - s) + ph                   (c + A sin arg, A w cos arg, -A w w sin arg)
 *   poly   x = t - s, Horner with the coefficients of P, P' and P'' (highest power first)
 *
 * A trajectory with any other kind of coordinate is not compiled (the caller keeps Python).
 * evaluate() returns False when a value is not finite (an infinite time, an overflowing sine
 * argument): the caller then takes the Python path, whose checks name the input.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "pyconvert.h"

#define CAPSULE_NAME "sobolev_drake.native.reference.Program"
#define KIND_CONST 0
#define KIND_SINE 1
#define KIND_POLY 2
#define MAX_COEFFICIENTS 64          /* per polynomial; far above any reference's degree */

typedef struct {
    int kind;
    double a[5];                     /* const: c; sine: A, w, ph, c, s; poly: s */
    int n[3];                        /* poly: number of coefficients of P, P', P'' */
    double *coef;                    /* poly: n[0] + n[1] + n[2] coefficients, highest first */
} Coordinate;

typedef struct {
    Py_ssize_t m, pieces, nbreak;
    double *breakpoints;             /* nbreak = pieces - 1, strictly increasing */
    Coordinate *coords;              /* pieces x m, row-major */
    double *values;                  /* 3m: one evaluation, copied out by write_doubles */
} Program;

static void destroy_program(Program *p)
{
    if (p->coords)
        for (Py_ssize_t i = 0; i < p->pieces * p->m; i++)
            free(p->coords[i].coef);
    free(p->coords);
    free(p->values);
    free(p->breakpoints);
    free(p);
}

static void free_program(PyObject *capsule)
{
    Program *p = (Program *)PyCapsule_GetPointer(capsule, CAPSULE_NAME);
    if (p)
        destroy_program(p);
}

/* spec[i] as a double, spec being a tuple; errors name the piece and the coordinate */
static int spec_double(PyObject *spec, Py_ssize_t i, double *out, Py_ssize_t k, Py_ssize_t j)
{
    *out = PyFloat_AsDouble(PyTuple_GET_ITEM(spec, i));
    if (*out == -1.0 && PyErr_Occurred()) {
        PyErr_Format(PyExc_TypeError, "make_program: pieces[%zd][%zd] entry %zd must be a float",
                     k, j, i);
        return -1;
    }
    return 0;
}

/* one coordinate from its spec tuple: (0, c) | (1, A, w, ph, c, s) |
 * (2, s, n0, n1, n2, coefficients...) */
static int read_coordinate(PyObject *spec, Coordinate *c, Py_ssize_t k, Py_ssize_t j)
{
    if (!PyTuple_Check(spec) || PyTuple_GET_SIZE(spec) < 2) {
        PyErr_Format(PyExc_TypeError, "make_program: pieces[%zd][%zd] must be a tuple "
                     "(kind, parameters...)", k, j);
        return -1;
    }
    long kind = PyLong_AsLong(PyTuple_GET_ITEM(spec, 0));
    if (kind == -1 && PyErr_Occurred()) {
        PyErr_Format(PyExc_TypeError, "make_program: pieces[%zd][%zd] kind must be an int", k, j);
        return -1;
    }
    Py_ssize_t size = PyTuple_GET_SIZE(spec);
    c->kind = (int)kind;
    c->coef = NULL;
    if (kind == KIND_CONST && size == 2)
        return spec_double(spec, 1, &c->a[0], k, j);
    if (kind == KIND_SINE && size == 6) {
        for (int i = 0; i < 5; i++)
            if (spec_double(spec, i + 1, &c->a[i], k, j) < 0)
                return -1;
        return 0;
    }
    if (kind == KIND_POLY && size >= 5) {
        if (spec_double(spec, 1, &c->a[0], k, j) < 0)
            return -1;
        Py_ssize_t total = 0;
        for (int i = 0; i < 3; i++) {
            long n = PyLong_AsLong(PyTuple_GET_ITEM(spec, i + 2));
            if (n == -1 && PyErr_Occurred()) {
                PyErr_Format(PyExc_TypeError, "make_program: pieces[%zd][%zd] coefficient count "
                             "%d must be an int", k, j, i);
                return -1;
            }
            if (n < 1 || n > MAX_COEFFICIENTS) {
                PyErr_Format(PyExc_ValueError, "make_program: pieces[%zd][%zd] polynomial %d "
                             "must have 1 to %d coefficients, got %ld", k, j, i,
                             MAX_COEFFICIENTS, n);
                return -1;
            }
            c->n[i] = (int)n;
            total += n;
        }
        if (size != 5 + total) {
            PyErr_Format(PyExc_ValueError, "make_program: pieces[%zd][%zd] announces %zd "
                         "coefficients but holds %zd", k, j, total, size - 5);
            return -1;
        }
        c->coef = malloc((size_t)total * sizeof(double));
        if (!c->coef) {
            PyErr_NoMemory();
            return -1;
        }
        for (Py_ssize_t i = 0; i < total; i++)
            if (spec_double(spec, 5 + i, &c->coef[i], k, j) < 0)
                return -1;
        return 0;
    }
    PyErr_Format(PyExc_ValueError, "make_program: pieces[%zd][%zd] has kind %ld with %zd "
                 "entries; expected (0, c), (1, A, w, phase, offset, t0) or "
                 "(2, t0, n0, n1, n2, coefficients...)", k, j, kind, size);
    return -1;
}

static PyObject *make_program(PyObject *self, PyObject *args)
{
    PyObject *bp_obj, *pieces_obj;
    if (!PyArg_ParseTuple(args, "OO:make_program", &bp_obj, &pieces_obj))
        return NULL;
    PyObject *bp = PySequence_Fast(bp_obj, "make_program: breakpoints must be a sequence");
    if (!bp)
        return NULL;
    PyObject *pieces = PySequence_Fast(pieces_obj, "make_program: pieces must be a sequence");
    if (!pieces) {
        Py_DECREF(bp);
        return NULL;
    }
    Program *p = calloc(1, sizeof(Program));
    PyObject *capsule = NULL;
    if (!p) {
        PyErr_NoMemory();
        goto done;
    }
    p->pieces = PySequence_Fast_GET_SIZE(pieces);
    p->nbreak = PySequence_Fast_GET_SIZE(bp);
    if (p->pieces < 1 || p->nbreak != p->pieces - 1) {
        PyErr_Format(PyExc_ValueError, "make_program: %zd pieces need %zd breakpoints, got %zd",
                     p->pieces, p->pieces - 1, p->nbreak);
        goto fail;
    }
    p->breakpoints = malloc((size_t)(p->nbreak + 1) * sizeof(double));
    if (!p->breakpoints) {
        PyErr_NoMemory();
        goto fail;
    }
    for (Py_ssize_t i = 0; i < p->nbreak; i++) {
        p->breakpoints[i] = PyFloat_AsDouble(PySequence_Fast_GET_ITEM(bp, i));
        if (p->breakpoints[i] == -1.0 && PyErr_Occurred()) {
            PyErr_Format(PyExc_TypeError, "make_program: breakpoints[%zd] must be a float", i);
            goto fail;
        }
        if (!isfinite(p->breakpoints[i])) {
            PyErr_Format(PyExc_ValueError, "make_program: breakpoints[%zd] must be finite, got %R",
                         i, PySequence_Fast_GET_ITEM(bp, i));
            goto fail;
        }
        if (i > 0 && !(p->breakpoints[i] > p->breakpoints[i - 1])) {
            PyErr_SetString(PyExc_ValueError, "make_program: breakpoints must be strictly "
                            "increasing");
            goto fail;
        }
    }
    for (Py_ssize_t k = 0; k < p->pieces; k++) {
        PyObject *piece = PySequence_Fast(PySequence_Fast_GET_ITEM(pieces, k), "");
        if (!piece) {
            PyErr_Format(PyExc_TypeError, "make_program: pieces[%zd] must be a sequence", k);
            goto fail;
        }
        Py_ssize_t m = PySequence_Fast_GET_SIZE(piece);
        if (k == 0) {
            p->m = m;
            p->coords = calloc((size_t)(p->pieces * (m > 0 ? m : 1)), sizeof(Coordinate));
            p->values = malloc((size_t)(3 * (m > 0 ? m : 1)) * sizeof(double));
            if (!p->coords || !p->values) {
                Py_DECREF(piece);
                PyErr_NoMemory();
                goto fail;
            }
        }
        if (m != p->m || m < 1) {
            PyErr_Format(PyExc_ValueError, "make_program: pieces[%zd] has %zd coordinates, "
                         "expected %zd (at least one)", k, m, p->m);
            Py_DECREF(piece);
            goto fail;
        }
        for (Py_ssize_t j = 0; j < m; j++)
            if (read_coordinate(PySequence_Fast_GET_ITEM(piece, j), &p->coords[k * m + j], k,
                                j) < 0) {
                Py_DECREF(piece);
                goto fail;
            }
        Py_DECREF(piece);
    }
    capsule = PyCapsule_New(p, CAPSULE_NAME, free_program);
    if (!capsule)
        goto fail;
    goto done;
fail:
    if (p)
        destroy_program(p);
done:
    Py_DECREF(bp);
    Py_DECREF(pieces);
    return capsule;
}

static double horner(const double *c, int n, double x)
{
    double v = c[0];
    for (int i = 1; i < n; i++)
        v = v * x + c[i];
    return v;
}

/* [q; qdot; qddot] at t into out (3m doubles); whether every value is finite */
static int evaluate_program(const Program *p, double t, double *out)
{
    int finite = 1;
    Py_ssize_t lo = 0, hi = p->nbreak;          /* bisect_left: first breakpoint >= t */
    while (lo < hi) {
        Py_ssize_t mid = (lo + hi) / 2;
        if (p->breakpoints[mid] < t)
            lo = mid + 1;
        else
            hi = mid;
    }
    const Coordinate *row = p->coords + lo * p->m;
    Py_ssize_t m = p->m;
    for (Py_ssize_t j = 0; j < m; j++) {
        const Coordinate *c = row + j;
        double f, df, ddf;
        if (c->kind == KIND_CONST) {
            f = c->a[0];
            df = 0.0;
            ddf = 0.0;
        } else if (c->kind == KIND_SINE) {
            double A = c->a[0], w = c->a[1];
            double arg = w * (t - c->a[4]) + c->a[2];
            double sn = sin(arg);
            f = c->a[3] + A * sn;
            df = A * w * cos(arg);
            ddf = -A * w * w * sn;
        } else {
            double x = t - c->a[0];
            f = horner(c->coef, c->n[0], x);
            df = horner(c->coef + c->n[0], c->n[1], x);
            ddf = horner(c->coef + c->n[0] + c->n[1], c->n[2], x);
        }
        out[j] = f;
        out[m + j] = df;
        out[2 * m + j] = ddf;
        finite &= isfinite(f) && isfinite(df) && isfinite(ddf);
    }
    return finite;
}

static PyObject *py_evaluate(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 3) {
        PyErr_Format(PyExc_TypeError, "evaluate(program, t, out) takes 3 arguments, got %zd",
                     nargs);
        return NULL;
    }
    Program *p = (Program *)PyCapsule_GetPointer(args[0], CAPSULE_NAME);
    if (!p)
        return NULL;
    double t = PyFloat_AsDouble(args[1]);
    if (t == -1.0 && PyErr_Occurred())
        return NULL;
    int finite = evaluate_program(p, t, p->values);
    if (write_doubles(args[2], 3 * p->m, p->values, "out"))
        return NULL;
    return PyBool_FromLong(finite);
}

static PyObject *py_size(PyObject *self, PyObject *capsule)
{
    Program *p = (Program *)PyCapsule_GetPointer(capsule, CAPSULE_NAME);
    return p ? PyLong_FromSsize_t(p->m) : NULL;
}

static PyMethodDef methods[] = {
    {"make_program", (PyCFunction)make_program, METH_VARARGS,
     "make_program(breakpoints, pieces) -> capsule: pieces[k][j] is the spec tuple of\n"
     "coordinate j on piece k (see systems/references.py)."},
    {"evaluate", (PyCFunction)(void (*)(void))py_evaluate, METH_FASTCALL,
     "evaluate(program, t, out) -> bool: [q; qdot; qddot] at t into out (3m float64);\n"
     "False when a value is not finite (the caller then takes the Python path)."},
    {"coordinates", (PyCFunction)py_size, METH_O,
     "coordinates(program) -> m, the number of coordinates."},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef moduledef = {
    PyModuleDef_HEAD_INIT, "_reference",
    "Compiled evaluation of piecewise const/sine/poly reference trajectories.",
    -1, methods, NULL, NULL, NULL, NULL,
};

PyMODINIT_FUNC PyInit__reference(void)
{
    return PyModule_Create(&moduledef);
}
