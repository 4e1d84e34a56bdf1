/*
 * Python <-> C conversions shared by the compiled kernels (included by native/<name>.c; each
 * kernel is its own extension module, so these are static functions compiled into each).
 * Errors name the argument; the caller returns NULL / -1 with the exception set.
 */
#ifndef SOBOLEV_DRAKE_NATIVE_PYCONVERT_H
#define SOBOLEV_DRAKE_NATIVE_PYCONVERT_H

#include <Python.h>
#include <string.h>

/* n doubles from a sequence of numbers */
static int seq_to_doubles(PyObject *obj, Py_ssize_t n, double *out, const char *name)
{
    PyObject *fast = PySequence_Fast(obj, "expected a sequence of floats");
    if (!fast)
        return -1;
    if (PySequence_Fast_GET_SIZE(fast) != n) {
        PyErr_Format(PyExc_ValueError, "%s must have %zd entries, got %zd", name, n,
                     PySequence_Fast_GET_SIZE(fast));
        Py_DECREF(fast);
        return -1;
    }
    PyObject **items = PySequence_Fast_ITEMS(fast);
    for (Py_ssize_t i = 0; i < n; i++) {
        out[i] = PyFloat_AsDouble(items[i]);
        if (out[i] == -1.0 && PyErr_Occurred()) {
            Py_DECREF(fast);
            return -1;
        }
    }
    Py_DECREF(fast);
    return 0;
}

/* dict[key] (borrowed), or NULL with a KeyError "<who>: missing <key>" (who: the constructor
 * whose constants dict it is) */
static PyObject *dict_item(PyObject *dict, const char *who, const char *key)
{
    PyObject *v = PyDict_GetItemString(dict, key);   /* borrowed */
    if (!v)
        PyErr_Format(PyExc_KeyError, "%s: missing %s", who, key);
    return v;
}

/* dict[key] as a float */
static int dict_double(PyObject *dict, const char *who, const char *key, double *out)
{
    PyObject *v = dict_item(dict, who, key);
    if (!v)
        return -1;
    *out = PyFloat_AsDouble(v);
    return (*out == -1.0 && PyErr_Occurred()) ? -1 : 0;
}

/* dict[key] as an integer in [lo, hi] (ValueError naming who, the key, the range and the value) */
static int dict_long(PyObject *dict, const char *who, const char *key, long lo, long hi,
                     long *out)
{
    PyObject *v = dict_item(dict, who, key);
    if (!v)
        return -1;
    long x = PyLong_AsLong(v);
    if (x == -1 && PyErr_Occurred())
        return -1;
    if (x < lo || x > hi) {
        PyErr_Format(PyExc_ValueError, "%s: %s must be in [%ld, %ld], got %ld", who, key, lo, hi,
                     x);
        return -1;
    }
    *out = x;
    return 0;
}

/* dict[key] as n doubles (KeyError naming the key when it is missing) */
static int dict_doubles(PyObject *dict, const char *key, Py_ssize_t n, double *out)
{
    PyObject *seq = dict_item(dict, "make_model", key);
    if (!seq)
        return -1;
    return seq_to_doubles(seq, n, out, key);
}

/* n doubles from a C-contiguous float64 buffer (one memcpy: the per-call fast path for numpy
 * arrays) or else from a sequence of numbers */
static int read_doubles(PyObject *obj, Py_ssize_t n, double *out, const char *name)
{
    if (PyObject_CheckBuffer(obj)) {
        Py_buffer view;
        if (PyObject_GetBuffer(obj, &view, PyBUF_C_CONTIGUOUS | PyBUF_FORMAT) == 0) {
            int is_f64 = view.format && strcmp(view.format, "d") == 0 && view.itemsize == 8;
            int ok = is_f64 && view.len == (Py_ssize_t)(8 * n);
            if (ok)
                memcpy(out, view.buf, sizeof(double) * n);
            PyBuffer_Release(&view);
            if (ok)
                return 0;
            if (is_f64) {
                PyErr_Format(PyExc_ValueError, "%s must have %zd entries, got %zd", name, n,
                             view.len / 8);
                return -1;
            }
        } else {
            PyErr_Clear();
        }
    }
    if (!PySequence_Check(obj)) {
        PyErr_Format(PyExc_TypeError, "%s must be a sequence of %zd floats, got %s", name, n,
                     Py_TYPE(obj)->tp_name);
        return -1;
    }
    return seq_to_doubles(obj, n, out, name);
}

/* a new list of n floats */
static PyObject *list_of(const double *v, Py_ssize_t n)
{
    PyObject *lst = PyList_New(n);
    if (!lst)
        return NULL;
    for (Py_ssize_t i = 0; i < n; i++) {
        PyObject *f = PyFloat_FromDouble(v[i]);
        if (!f) {
            Py_DECREF(lst);
            return NULL;
        }
        PyList_SET_ITEM(lst, i, f);
    }
    return lst;
}

/* n doubles into a writable C-contiguous float64 buffer (TypeError when obj is not one,
 * ValueError naming the size when it is not float64 or not n long) */
static int write_doubles(PyObject *obj, Py_ssize_t n, const double *src, const char *name)
{
    Py_buffer view;
    if (PyObject_GetBuffer(obj, &view, PyBUF_C_CONTIGUOUS | PyBUF_FORMAT | PyBUF_WRITABLE)) {
        PyErr_Clear();
        PyErr_Format(PyExc_TypeError, "%s must be a writable float64 array", name);
        return -1;
    }
    int ok = view.format && strcmp(view.format, "d") == 0 && view.len == (Py_ssize_t)(8 * n);
    if (ok)
        memcpy(view.buf, src, sizeof(double) * n);
    PyBuffer_Release(&view);
    if (!ok) {
        PyErr_Format(PyExc_ValueError, "%s must be a float64 array of %zd entries", name, n);
        return -1;
    }
    return 0;
}

#endif
