/*
 * C-level interfaces between the compiled kernels (the standard CPython way to share C
 * functions between extension modules: each module exports a PyCapsule "_C_API" holding a
 * struct of function pointers; another module imports it with PyCapsule_Import).  Used by
 * native/fused.c, which composes the tilt-rotor law's per-sample path from the kernels of
 * rnea.c, forces.c and bls.c without going through Python objects.
 *
 * Every function computes exactly what the module's Python entry computes (the entries call
 * the same code), on contiguous double arrays.  The version numbers guard against a stale
 * build of one module: fused.c refuses an interface whose version it does not know.
 */
#ifndef SOBOLEV_DRAKE_NATIVE_CAPI_H
#define SOBOLEV_DRAKE_NATIVE_CAPI_H

#include <Python.h>

/* ------------------------------------------------------------------ _rnea._C_API ---- */
#define RNEA_CAPI_NAME "sobolev_drake.native._rnea._C_API"
#define RNEA_CAPI_VERSION 1

typedef struct {
    int version;
    /* the tree model held by a make_model capsule (NULL with an exception otherwise) */
    const void *(*model)(PyObject *capsule);
    int (*model_size)(const void *model);
    /* M(q) vdot + C(q, v) v - tau_g(q), as _rnea.inverse_dynamics (not reentrant per model) */
    void (*inverse_dynamics)(const void *model, const double *q, const double *v,
                             const double *vdot, double *tau);
    /* the gains held by a make_desired_acceleration capsule (NULL with an exception) */
    const void *(*qdd_law)(PyObject *capsule);
    /* sizes n, nc, n_ref of that law and the doubles of scratch desired_acceleration needs */
    void (*qdd_sizes)(const void *law, int *n, int *nc, int *n_ref, int *work);
    /* q_des'' as _rnea.desired_acceleration: q, qdot (n), e_int (nc), reference (3 n_ref) */
    void (*desired_acceleration)(const void *law, const double *q, const double *qdot,
                                 const double *e_int, const double *reference, double *work,
                                 double *acc);
} RneaCAPI;

/* ------------------------------------------------------------------- _bls._C_API ---- */
#define BLS_CAPI_NAME "sobolev_drake.native._bls._C_API"
#define BLS_CAPI_VERSION 1

/* results of solve: what _bls.solve returns (tuple / None / NotImplemented), or out of memory */
#define BLS_OK 0
#define BLS_NONE 1
#define BLS_DECLINE 2
#define BLS_NOMEM (-1)

typedef struct {
    int version;
    /* _bls.solve on contiguous row-major B (n x m), u (n), lo, hi (m); warm: the active set
     * guess (sign of each entry; NULL = none, the cold start); on BLS_OK tau (m), active (m:
     * -1 lower, +1 upper, 0 free), the PDAS iteration count and ||u - B tau||. */
    int (*solve)(int n, int m, const double *B, const double *u, const double *lo,
                 const double *hi, double reg, const double *warm, int max_iter, double *tau,
                 signed char *active, int *iterations, double *residual);
} BlsCAPI;

/* ---------------------------------------------------------------- _forces._C_API ---- */
#define FORCES_CAPI_NAME "sobolev_drake.native._forces._C_API"
#define FORCES_CAPI_VERSION 1

typedef struct {
    int version;
    /* the force model held by a make_model capsule (NULL with an exception otherwise) */
    const void *(*model)(PyObject *capsule);
    /* _forces.affine_terms: B (64, row-major), ϑ_passive (8), V (6), V_xz (2), φ (2); -1 with
     * a Python exception set where the entry raises */
    int (*affine_terms)(const void *model, const double *q, const double *qdot,
                        const double *zeta, const double *n, int through_thrust, double *B,
                        double *passive, double *V6, double *vxz, double *phi);
    /* _forces.newton_speed: 0 and n_out (2) on convergence, 1 where the entry returns None */
    int (*newton_speed)(const void *model, const double *f, const double *vxz,
                        const double *phi, const double *n_guess, long iterations, double rtol,
                        double *n_out);
    /* _forces.surface_bounds with k = (s, c, f_lo, f_hi, t_lo, t_hi, d_lo, d_hi): 0, or -1
     * (no exception set) where the entry raises ValueError (an air speed < 0 or not finite) */
    int (*surface_bounds)(const double *v_air4, const double *k, double *lo8, double *hi8);
    /* _forces.saturation_flags on 8 entries */
    void (*saturation_flags)(const double *tau, const double *lo, const double *up,
                             double rel_tol, double min_width, double *out8);
} ForcesCAPI;

/* module.attr = capsule of api (0, or -1 with an exception) */
static inline int export_c_api(PyObject *module, void *api, const char *name)
{
    PyObject *cap = PyCapsule_New(api, name, NULL);
    if (cap == NULL)
        return -1;
    if (PyModule_AddObject(module, "_C_API", cap) < 0) {
        Py_DECREF(cap);
        return -1;
    }
    return 0;
}

#endif
