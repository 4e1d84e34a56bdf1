/*
 * Compiled kernel of the tilt-rotor force model: sobolev_drake.native._forces.
 *
 * Mirrors, operation for operation, the Python scalar tier it replaces:
 *   body_kinematics_scalar, body_wrench_scalar   (tiltrotor/propulsion.py)
 *   PropulsionModel.rotors_scalar / propeller_force_scalar, PropellerCoefficients.ct_cq_scalar
 *   AeroModel.loads_scalar (with the deflection columns)   (tiltrotor/aerodynamics.py)
 *   TiltrotorForces.thesis_force                          (tiltrotor/plant.py)
 *   affine_terms_scalar_python                            (tiltrotor/input_affine.py)
 * Same expressions in the same order (and -ffp-contract=off), so results agree with Python to
 * the last bit except where Python's math.hypot and libm's hypot round differently.
 * tests/native/test_native_forces.py compares both.  Constants come from Python (make_model),
 * so the parameter handling, the tables and their validation stay in one place.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "capi.h"
#include "pyconvert.h"

#define HALF_PI 1.5707963267948966
#define MAX_TERMS 32

typedef struct {
    /* aerodynamics */
    double pts[6][3], hrs[6];
    double *atab, *btab;            /* [6][N][3] each */
    int samples;
    double start, step, nmax, chord, span, cda, cde, cdr;
    int indep, mirror;
    /* propellers and servos */
    double sb, cb, cosb_servo, cosb_B, nu, dAP[3], dBA[2][3], lam[2], kf, kt, d, Jmax, rho;
    int nterms, ti[MAX_TERMS], tj[MAX_TERMS];
    double ta[MAX_TERMS], tb[MAX_TERMS];
    double dC1[3];
    int perm16[16], perm8_inv[8];
} Model;

typedef struct {
    double sf, cf, st, ct;
    double r[9];
    double w[3], vb[3];
} Kin;

typedef struct {
    double dx, dy, dz, rx, ry, rz, zx, zy, zz, u, w;
} Rotor;

/* ---------------------------------------------------------------- model construction ---- */

static void free_model(PyObject *capsule)
{
    Model *m = (Model *)PyCapsule_GetPointer(capsule, "sobolev_drake.native.forces.Model");
    if (m) {
        free(m->atab);
        free(m->btab);
        free(m);
    }
}

static int get_double(PyObject *dict, const char *key, double *out)
{
    return dict_double(dict, "make_model", key, out);
}

static PyObject *make_model(PyObject *self, PyObject *args)
{
    PyObject *d;
    if (!PyArg_ParseTuple(args, "O!", &PyDict_Type, &d))
        return NULL;
    Model *m = (Model *)calloc(1, sizeof(Model));
    if (!m)
        return PyErr_NoMemory();
    double tmp[16], samples, indep, mirror, nterms;
    if (get_double(d, "samples", &samples))
        goto fail;
    if (!(samples >= 2 && samples <= 100000 && samples == floor(samples))) {   /* NaN too */
        PyErr_Format(PyExc_ValueError, "make_model: samples must be an integer in [2, 100000], "
                     "got %R", PyDict_GetItemString(d, "samples"));
        goto fail;
    }
    m->samples = (int)samples;
    m->atab = (double *)malloc(sizeof(double) * 18 * m->samples);
    m->btab = (double *)malloc(sizeof(double) * 18 * m->samples);
    if (!m->atab || !m->btab) {
        PyErr_NoMemory();
        goto fail;
    }
    if (dict_doubles(d, "points", 18, &m->pts[0][0]) || dict_doubles(d, "half_rho_s", 6, m->hrs)
        || dict_doubles(d, "alpha_tab", 18 * m->samples, m->atab)
        || dict_doubles(d, "beta_tab", 18 * m->samples, m->btab)
        || get_double(d, "start", &m->start) || get_double(d, "step", &m->step)
        || get_double(d, "nmax", &m->nmax) || get_double(d, "chord", &m->chord)
        || get_double(d, "span", &m->span) || get_double(d, "c_delta_a", &m->cda)
        || get_double(d, "c_delta_e", &m->cde) || get_double(d, "c_delta_r", &m->cdr)
        || get_double(d, "independence", &indep) || get_double(d, "mirrored", &mirror)
        || get_double(d, "sin_beta", &m->sb)
        || get_double(d, "cos_beta", &m->cb) || get_double(d, "cos_beta_servo", &m->cosb_servo)
        || get_double(d, "cos_beta_B", &m->cosb_B) || get_double(d, "nu", &m->nu)
        || dict_doubles(d, "d_A_P", 3, m->dAP) || dict_doubles(d, "d_B_A", 6, &m->dBA[0][0])
        || dict_doubles(d, "lam", 2, m->lam) || get_double(d, "kf", &m->kf)
        || get_double(d, "kt", &m->kt) || get_double(d, "diameter", &m->d)
        || get_double(d, "J_max", &m->Jmax) || get_double(d, "rho", &m->rho)
        || get_double(d, "nterms", &nterms) || dict_doubles(d, "d_B_C1", 3, m->dC1))
        goto fail;
    m->indep = indep != 0.0;
    m->mirror = mirror != 0.0;
    if (m->nmax != (double)(m->samples - 1) || !(m->step > 0.0)) {
        PyErr_SetString(PyExc_ValueError, "make_model: need nmax = samples - 1 and step > 0");
        goto fail;
    }
    if (!(nterms >= 0 && nterms <= MAX_TERMS)) {   /* NaN too: never cast to int */
        PyErr_SetString(PyExc_ValueError, "make_model: too many Ct/Cq terms");
        goto fail;
    }
    m->nterms = (int)nterms;
    double terms[4 * MAX_TERMS];
    if (dict_doubles(d, "terms", 4 * m->nterms, terms))
        goto fail;
    for (int k = 0; k < m->nterms; k++) {
        m->ti[k] = (int)terms[4 * k];
        m->tj[k] = (int)terms[4 * k + 1];
        m->ta[k] = terms[4 * k + 2];
        m->tb[k] = terms[4 * k + 3];
        if (m->ti[k] < 0 || m->ti[k] > 4 || m->tj[k] < 0 || m->tj[k] > 4) {
            PyErr_SetString(PyExc_ValueError, "make_model: Ct/Cq powers must be 0..4");
            goto fail;
        }
    }
    if (dict_doubles(d, "perm16", 16, tmp))
        goto fail;
    for (int i = 0; i < 16; i++)
        m->perm16[i] = (int)tmp[i];
    if (dict_doubles(d, "perm8_inv", 8, tmp))
        goto fail;
    for (int i = 0; i < 8; i++)
        m->perm8_inv[i] = (int)tmp[i];
    for (int i = 0; i < 16; i++)
        if (m->perm16[i] < 0 || m->perm16[i] > 15 || (i < 8 && (m->perm8_inv[i] < 0 || m->perm8_inv[i] > 7))) {
            PyErr_SetString(PyExc_ValueError, "make_model: permutation index out of range");
            goto fail;
        }
    PyObject *cap = PyCapsule_New(m, "sobolev_drake.native.forces.Model", free_model);
    if (!cap)
        goto fail;
    return cap;
fail:
    free(m->atab);
    free(m->btab);
    free(m);
    return NULL;
}

static Model *get_model(PyObject *cap)
{
    return (Model *)PyCapsule_GetPointer(cap, "sobolev_drake.native.forces.Model");
}

/* ---------------------------------------------------------------- argument helpers ---- */

/* n doubles from a float64 buffer or a sequence of numbers; None -> zeros when allow_none */
static int read_vec(PyObject *obj, Py_ssize_t n, double *out, int allow_none, const char *name)
{
    if (obj == Py_None) {
        if (!allow_none) {
            PyErr_Format(PyExc_TypeError, "%s must not be None", name);
            return -1;
        }
        memset(out, 0, sizeof(double) * n);
        return 0;
    }
    return read_doubles(obj, n, out, name);
}

/* ---------------------------------------------------------------- the force model ---- */

static void body_kinematics(const double *q, const double *qd, const double *z, Kin *k)
{
    double sf = sin(q[2]), cf = cos(q[2]), st = sin(q[3]), ct = cos(q[3]);
    double sp = sin(q[4]), cp = cos(q[4]);
    double *r = k->r;
    r[0] = cp * ct;
    r[1] = cp * st * sf - sp * cf;
    r[2] = cp * st * cf + sp * sf;
    r[3] = sp * ct;
    r[4] = sp * st * sf + cp * cf;
    r[5] = sp * st * cf - cp * sf;
    r[6] = -st;
    r[7] = ct * sf;
    r[8] = ct * cf;
    double dphi = qd[2], dth = qd[3], dpsi = qd[4];
    k->w[0] = dphi - st * dpsi;
    k->w[1] = cf * dth + ct * sf * dpsi;
    k->w[2] = -sf * dth + cf * ct * dpsi;
    double vix = qd[5] - z[0], viy = qd[6] - z[1], viz = qd[7] - z[2];
    k->vb[0] = r[0] * vix + r[3] * viy + r[6] * viz;
    k->vb[1] = r[1] * vix + r[4] * viy + r[7] * viz;
    k->vb[2] = r[2] * vix + r[5] * viy + r[8] * viz;
    k->sf = sf;
    k->cf = cf;
    k->st = st;
    k->ct = ct;
}

/* rows 2..7 of the generalized force of a body-axes force and torque (body_wrench_scalar) */
static void body_wrench(const Kin *k, const double *F, const double *T, double *out6)
{
    const double *r = k->r;
    double sf = k->sf, cf = k->cf, st = k->st, ct = k->ct;
    out6[0] = T[0];
    out6[1] = cf * T[1] - sf * T[2];
    out6[2] = -st * T[0] + ct * sf * T[1] + cf * ct * T[2];
    out6[3] = r[0] * F[0] + r[1] * F[1] + r[2] * F[2];
    out6[4] = r[3] * F[0] + r[4] * F[1] + r[5] * F[2];
    out6[5] = r[6] * F[0] + r[7] * F[1] + r[8] * F[2];
}

static void rotors(const Model *m, const double *q, const double *qd, const Kin *k, Rotor *out)
{
    double wx = k->w[0], wy = k->w[1], wz = k->w[2];
    double vbx = k->vb[0], vby = k->vb[1], vbz = k->vb[2];
    double sb = m->sb, cb = m->cb, px = m->dAP[0], py = m->dAP[1], pz = m->dAP[2];
    for (int i = 0; i < 2; i++) {
        double a = q[i], s = i == 0 ? -sb : sb;
        const double *A = m->dBA[i];
        double sa = sin(a), ca = cos(a);
        double m00 = ca, m01 = sa * s, m02 = sa * cb, m11 = cb, m12 = -s;
        double m20 = -sa, m21 = ca * s, m22 = ca * cb;
        double dx = m00 * px + m01 * py + m02 * pz;
        double dy = m11 * py + m12 * pz;
        double dz = m20 * px + m21 * py + m22 * pz;
        double rx = A[0] + dx, ry = A[1] + dy, rz = A[2] + dz;
        double ad = qd[i];
        double ux = vbx + wy * rz - wz * ry + ad * dz;
        double uy = vby + wz * rx - wx * rz;
        double uz = vbz + wx * ry - wy * rx - ad * dx;
        Rotor *o = &out[i];
        o->dx = dx;
        o->dy = dy;
        o->dz = dz;
        o->rx = rx;
        o->ry = ry;
        o->rz = rz;
        o->zx = m02;
        o->zy = m12;
        o->zz = m22;
        o->u = m00 * ux + m20 * uz;
        o->w = m02 * ux + m12 * uy + m22 * uz;
    }
}

static void ct_cq(const Model *m, double J, double phi, double *ct, double *cq)
{
    double J2 = J * J, J3 = J2 * J, J4 = J3 * J, P2 = phi * phi, P3 = P2 * phi, P4 = P3 * phi;
    double Jp[5] = {1.0, J, J2, J3, J4}, Pp[5] = {1.0, phi, P2, P3, P4};
    double a = 0.0, b = 0.0;
    for (int k = 0; k < m->nterms; k++) {
        double f = Jp[m->ti[k]] * Pp[m->tj[k]];
        a = a + m->ta[k] * f;
        b = b + m->tb[k] * f;
    }
    *ct = a;
    *cq = b;
}

static double clip_phi(double phi)
{
    phi = phi > HALF_PI ? HALF_PI : (phi < -HALF_PI ? -HALF_PI : phi);
    return fabs(phi);
}

static void propeller_force(const Model *m, const Kin *k, const Rotor *rot, const double *n,
                            double *out8)
{
    double F[3] = {0.0, 0.0, 0.0}, T[3] = {0.0, 0.0, 0.0};
    memset(out8, 0, sizeof(double) * 8);
    for (int i = 0; i < 2; i++) {
        const Rotor *r = &rot[i];
        double nk = n[i], nd = nk * m->d;
        double J = nd > 0 ? sqrt(r->u * r->u + r->w * r->w) / nd : m->Jmax;
        J = J > m->Jmax ? m->Jmax : J;
        double phi = clip_phi(atan2(r->u, r->w)), cT, cQ;
        ct_cq(m, J, phi, &cT, &cQ);
        double f = m->kf * nk * nk * cT;
        double t = m->lam[i] * m->kt * nk * nk * cQ;
        double bx = f * r->zx, by = f * r->zy, bz = f * r->zz;
        out8[i] = r->dz * bx - r->dx * bz + t * r->zy;
        F[0] += bx;
        F[1] += by;
        F[2] += bz;
        T[0] += r->ry * bz - r->rz * by + t * r->zx;
        T[1] += r->rz * bx - r->rx * bz + t * r->zy;
        T[2] += r->rx * by - r->ry * bx + t * r->zz;
    }
    body_wrench(k, F, T, out8 + 2);
}

/* loads_scalar: out8 (ϑ_aero), V6 (surface air speeds), cols (4 × 6, rows 2..7) if not NULL.
 * Returns -1 with a ValueError set on NaN air data (Python's int(NaN) raises there too): the
 * table index must never come from a NaN. */
static int aero_loads(const Model *m, const Kin *k, const double *delta, double *out8,
                       double *V6, double *cols)
{
    double wx = k->w[0], wy = k->w[1], wz = k->w[2];
    double vbx = k->vb[0], vby = k->vb[1], vbz = k->vb[2];
    double start = m->start, step = m->step, nmax = m->nmax;
    int imax = (int)nmax - 1, N = m->samples;
    double de = 0.5 * (delta[2] + delta[3]), dr = 0.5 * (delta[2] - delta[3]);
    double dlift[6] = {0.0, m->cda * delta[0], m->cda * delta[1], m->cde * de, m->cde * de, 0.0};
    double dside[6] = {0.0, 0.0, 0.0, m->cdr * dr, m->cdr * dr, 0.0};
    double Fx = 0.0, Fy = 0.0, Fz = 0.0, Tx = 0.0, Ty = 0.0, Tz = 0.0;
    double unit[6][5];
    int have[6] = {0, 0, 0, 0, 0, 0};
    for (int s = 0; s < 6; s++) {
        double rx = m->pts[s][0], ry = m->pts[s][1], rz = m->pts[s][2], hk = m->hrs[s];
        double u = vbx + wy * rz - wz * ry;
        double v = vby + wz * rx - wx * rz;
        double w = vbz + wx * ry - wy * rx;
        double V2 = u * u + v * v + w * w;
        double V = V6[s] = sqrt(V2);
        if (V2 < 1e-24)
            continue;
        /* mirrored: tables at atan2(w, |u|), wind axes along the flow; clipped: u⁺ = max(u, 0) */
        double ux = m->mirror ? u : (u > 0.0 ? u : 0.0);
        double h = sqrt(ux * ux + w * w);
        double alpha = atan2(w, fabs(ux));
        double sa, ca;
        if (h > 0.0) {
            sa = w / h;
            ca = ux / h;
        } else {
            sa = 0.0;
            ca = 1.0;
        }
        double sb = v / V;
        sb = sb > 1.0 ? 1.0 : (sb < -1.0 ? -1.0 : sb);
        double cb = sqrt(u * u + w * w) / V;
        double beta = asin(sb);
        /* table look-ups at α_NED = −α, β_NED = −β, index clamped to the table ends */
        double x = (-alpha - start) / step, xb = (-beta - start) / step;
        if (isnan(x) || isnan(xb)) {
            PyErr_SetString(PyExc_ValueError,
                            "aerodynamic loads: NaN angle of attack or sideslip (NaN state or wind)");
            return -1;
        }
        x = x < 0.0 ? 0.0 : (x > nmax ? nmax : x);
        int i = (int)x;
        i = i <= imax ? i : imax;
        double fr = x - i;
        const double *r0 = m->atab + 3 * (s * N + i), *r1 = r0 + 3;
        double cl = r0[0] + fr * (r1[0] - r0[0]), cda_ = r0[1] + fr * (r1[1] - r0[1]);
        double cm = r0[2] + fr * (r1[2] - r0[2]);
        x = xb < 0.0 ? 0.0 : (xb > nmax ? nmax : xb);
        i = (int)x;
        i = i <= imax ? i : imax;
        fr = x - i;
        r0 = m->btab + 3 * (s * N + i);
        r1 = r0 + 3;
        double cy = r0[0] + fr * (r1[0] - r0[0]), cdb = r0[1] + fr * (r1[1] - r0[1]);
        double cn = r0[2] + fr * (r1[2] - r0[2]);
        double ks = hk * V2;
        double ksa = m->indep ? hk * (u * u + w * w) : ks;   /* κ cos²β s (crossflow model) */
        double fd = -(ks * cdb + ksa * cda_);
        double fy = ks * (cy + dside[s]);
        double fl = ksa * (cl + dlift[s]);
        double cacb = ca * cb, sasb = sa * sb;
        double bx = cacb * fd - ca * sb * fy - sa * fl;
        double by = sb * fd + cb * fy;
        double bz = sa * cb * fd - sasb * fy + ca * fl;
        Fx += bx;
        Fy += by;
        Fz += bz;
        Tx += ry * bz - rz * by;
        Ty += rz * bx - rx * bz - ksa * m->chord * cm;
        Tz += rx * by - ry * bx - ks * m->span * cn;
        if (cols && s >= 1 && s <= 4) {
            have[s] = 1;
            unit[s][0] = -sa * ksa;
            unit[s][1] = ca * ksa;
            unit[s][2] = -ca * sb * ks;
            unit[s][3] = cb * ks;
            unit[s][4] = -sa * sb * ks;
        }
    }
    double F[3] = {Fx, Fy, Fz}, T[3] = {Tx, Ty, Tz};
    out8[0] = out8[1] = 0.0;
    body_wrench(k, F, T, out8 + 2);
    if (!cols)
        return 0;
    /* deflection columns [δWR δWL δTR δTL]: aileron lift at WR / WL, ruddervator ±½ δe, δr */
    for (int j = 0; j < 4; j++) {
        double G[3] = {0.0, 0.0, 0.0}, M[3] = {0.0, 0.0, 0.0};
        int items[2], nitems;
        double se = 1.0, sr = 0.0;
        if (j < 2) {
            items[0] = j + 1;
            nitems = 1;
        } else {
            sr = j == 2 ? 0.5 : -0.5;
            se = 0.5;
            items[0] = 3;
            items[1] = 4;
            nitems = 2;
        }
        for (int t = 0; t < nitems; t++) {
            int s = items[t];
            if (!have[s])
                continue;
            double lx = unit[s][0], lz = unit[s][1], yx = unit[s][2], yy = unit[s][3];
            double yz = unit[s][4], bx, by, bz;
            if (j < 2) {
                bx = m->cda * lx;
                by = 0.0;
                bz = m->cda * lz;
            } else {
                double ex = m->cde * lx, ez = m->cde * lz;
                double qx = m->cdr * yx, qy = m->cdr * yy, qz = m->cdr * yz;
                bx = se * ex + sr * qx;
                by = sr * qy;
                bz = se * ez + sr * qz;
            }
            double rx = m->pts[s][0], ry = m->pts[s][1], rz = m->pts[s][2];
            G[0] += bx;
            G[1] += by;
            G[2] += bz;
            M[0] += ry * bz - rz * by;
            M[1] += rz * bx - rx * bz;
            M[2] += rx * by - ry * bx;
        }
        body_wrench(k, G, M, cols + 6 * j);
    }
    return 0;
}

/* ------------------------------------------------------------- per-sample cores ---- */
/*
 * The per-sample pieces of the tilt-rotor law on contiguous arrays, each computed only here:
 * the Python entries affine_terms, newton_speed, surface_bounds and saturation_flags below
 * are wrappers (arguments, errors, return values) around them, and the C interface (capi.h,
 * used by fused.c) hands out the same functions.
 */

/* affine_terms: B (64, row-major), ϑ_passive (8), V (6), V_xz (2), φ (2); -1 with a Python
 * exception set (NaN air data: ValueError; Ct = 0 through the thrust: ZeroDivisionError) */
static int affine_core(const void *model, const double *q, const double *qd, const double *z,
                       const double *n, int through_thrust, double *B, double *passive,
                       double *V6, double *vxz, double *phis)
{
    const Model *m = (const Model *)model;
    Kin k;
    Rotor rot[2];
    double cols[24];
    static const double zero4[4] = {0.0, 0.0, 0.0, 0.0};
    body_kinematics(q, qd, z, &k);
    rotors(m, q, qd, &k, rot);
    if (aero_loads(m, &k, zero4, passive, V6, cols))
        return -1;
    memset(B, 0, sizeof(double) * 64);
    B[0 * 8 + 2] = m->cosb_B;
    B[1 * 8 + 3] = m->cosb_B;
    for (int i = 0; i < 6; i++)
        for (int j = 0; j < 4; j++)
            B[(2 + i) * 8 + 4 + j] = cols[6 * j + i];
    for (int i = 0; i < 2; i++) {
        const Rotor *r = &rot[i];
        double v_xz = hypot(r->u, r->w);
        double phi = clip_phi(atan2(r->u, r->w));
        vxz[i] = v_xz;
        phis[i] = phi;
        double nd = n[i] * m->d;
        double J = v_xz / (nd > 1e-300 ? nd : 1e-300);
        J = J < m->Jmax ? J : m->Jmax;
        double ct_, cq_;
        ct_cq(m, J, phi, &ct_, &cq_);
        double gf[4] = {r->dz * r->zx - r->dx * r->zz, r->ry * r->zz - r->rz * r->zy,
                        r->rz * r->zx - r->rx * r->zz, r->rx * r->zy - r->ry * r->zx};
        double gt[4] = {r->zy, r->zx, r->zy, r->zz}, col[4];
        if (through_thrust) {
            if (ct_ == 0.0) {
                PyErr_SetString(PyExc_ZeroDivisionError, "float division by zero (Ct = 0)");
                return -1;
            }
            double ratio = m->lam[i] * (m->d * cq_ / ct_);
            for (int t = 0; t < 4; t++)
                col[t] = gf[t] + gt[t] * ratio;
        } else {
            memcpy(col, gf, sizeof(gf));
            double tq = m->lam[i] * (m->rho * pow(m->d, 5) * pow(n[i], 2) * cq_);
            double zero3[3] = {0.0, 0.0, 0.0}, zax[3] = {r->zx, r->zy, r->zz}, w6[6];
            passive[i] += tq * r->zy;
            body_wrench(&k, zero3, zax, w6);
            for (int t = 0; t < 3; t++)
                passive[2 + t] += tq * w6[t];
        }
        double zax[3] = {r->zx, r->zy, r->zz}, w6[6];
        B[i * 8 + i] = col[0];
        body_wrench(&k, zax, col + 1, w6);
        for (int t = 0; t < 6; t++)
            B[(2 + t) * 8 + i] = w6[t];
    }
    passive[0] -= m->nu * qd[0];
    passive[1] -= m->nu * qd[1];
    return 0;
}

/* thrust − f at speed nn for the Horner coefficients c (c4 … c0) of Ct(J) at fixed φ */
static double thrust_error(const Model *m, double kf4, const double *c, double vx, double f,
                           double nn)
{
    double J = vx / (nn * m->d);
    J = J < m->Jmax ? J : m->Jmax;
    return kf4 * nn * nn * ((((c[0] * J + c[1]) * J + c[2]) * J + c[3]) * J + c[4]) - f;
}

/* newton_speed_for_thrust (tiltrotor/law.py): 0 and n_out (2) on convergence, 1 where the
 * Python entry returns None (no exception set) */
static int newton_core(const void *model, const double *f, const double *vx,
                       const double *ph, const double *n_guess, long iterations, double rtol,
                       double *n_out)
{
    const Model *m = (const Model *)model;
    double n[2] = {n_guess[0], n_guess[1]}, c[2][5];
    for (int i = 0; i < 2; i++)
        if (f[i] <= 0 || n[i] <= 1.0)
            return 1;
    double kf4 = m->rho * pow(m->d, 4);
    for (int i = 0; i < 2; i++) {   /* PropellerCoefficients.ct_in_J */
        double P = ph[i], Pp[5] = {1.0, P, P * P, P * P * P, P * P * P * P}, a[5] = {0, 0, 0, 0, 0};
        for (int t = 0; t < m->nterms; t++)
            a[m->ti[t]] += m->ta[t] * Pp[m->tj[t]];
        for (int t = 0; t < 5; t++)
            c[i][t] = a[4 - t];
    }
    for (long it = 0; it < iterations; it++) {
        double g0[2], dg[2];
        int conv = 1;
        for (int i = 0; i < 2; i++) {
            g0[i] = thrust_error(m, kf4, c[i], vx[i], f[i], n[i]);
            conv = conv && fabs(g0[i]) <= rtol * (1.0 + f[i]);
        }
        if (conv) {
            n_out[0] = n[0];
            n_out[1] = n[1];
            return 0;
        }
        for (int i = 0; i < 2; i++) {
            double h = 1e-6 * n[i];
            dg[i] = (thrust_error(m, kf4, c[i], vx[i], f[i], n[i] + h) - g0[i]) / h;
        }
        if (dg[0] <= 0 || dg[1] <= 0)
            return 1;
        for (int i = 0; i < 2; i++)
            n[i] = n[i] - g0[i] / dg[i];
        if (n[0] <= 0 || n[1] <= 0)
            return 1;
    }
    for (int i = 0; i < 2; i++)
        if (!(fabs(thrust_error(m, kf4, c[i], vx[i], f[i], n[i])) <= 1e-6 * (1.0 + f[i])))
            return 1;
    n_out[0] = n[0];
    n_out[1] = n[1];
    return 0;
}

/* the per-surface branch of tiltrotor_bounds (tiltrotor/allocation.py), sigmf (7.89), with
 * k = (s, c, f_lo, f_hi, t_lo, t_hi, d_lo, d_hi): 0, or -1 (no exception set) on an air
 * speed that is negative or not finite */
static int bounds_core(const double *v, const double *k, double *lo, double *hi)
{
    lo[0] = lo[1] = k[2];
    lo[2] = lo[3] = k[4];
    hi[0] = hi[1] = k[3];
    hi[2] = hi[3] = k[5];
    double s = k[0], c = k[1];
    for (int i = 0; i < 4; i++) {
        double x = v[i];
        if (!(x >= 0 && isfinite(x)))
            return -1;
        double zz = -s * (x - c), e = exp(-fabs(zz));
        double g = zz >= 0 ? e / (1.0 + e) : 1.0 / (1.0 + e);
        lo[4 + i] = k[6] * g;
        hi[4 + i] = k[7] * g;
    }
    return 0;
}

/* the per-sample branch of saturation_flags (tiltrotor/controller.py): +1 at the upper bound,
 * -1 at the lower, 0 inside or where the bounds are no more than min_width apart */
static void flags_core(const double *t, const double *lo, const double *up, double rel_tol,
                       double min_width, double *out)
{
    for (int i = 0; i < 8; i++) {
        double w = up[i] - lo[i];
        if (w > min_width) {
            double tol = rel_tol * w;
            out[i] = t[i] >= up[i] - tol ? 1.0 : (t[i] <= lo[i] + tol ? -1.0 : 0.0);
        } else {
            out[i] = 0.0;
        }
    }
}

/* ---------------------------------------------------------------- Python entry points ---- */

static PyObject *py_plant_force(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    /* (model, drake_state[16], u[8], wind|None, force_disturbance|None, disturbance|None,
     *  out[8] writable float64, drake_order: bool) -> None */
    if (nargs != 8) {
        PyErr_SetString(PyExc_TypeError, "plant_force takes 8 arguments");
        return NULL;
    }
    Model *m = get_model(args[0]);
    if (!m)
        return NULL;
    double xs[16], x[16], u[8], z[3], fd[3], dist[8], tau[8];
    if (read_vec(args[1], 16, xs, 0, "plant_state") || read_vec(args[2], 8, u, 0, "u")
        || read_vec(args[3], 3, z, 1, "wind") || read_vec(args[4], 3, fd, 1, "force_disturbance")
        || read_vec(args[5], 8, dist, 1, "disturbance"))
        return NULL;
    for (int i = 0; i < 16; i++)
        x[i] = xs[m->perm16[i]];
    const double *q = x, *qd = x + 8;
    Kin k;
    Rotor rot[2];
    double tp[8], ta[8], V6[6];
    body_kinematics(q, qd, z, &k);
    rotors(m, q, qd, &k, rot);
    propeller_force(m, &k, rot, u, tp);
    if (aero_loads(m, &k, u + 4, ta, V6, NULL))
        return NULL;
    for (int i = 0; i < 8; i++)
        tau[i] = tp[i] + ta[i];
    tau[0] += m->cosb_servo * u[2] - m->nu * qd[0];   /* servos (7.33) */
    tau[1] += m->cosb_servo * u[3] - m->nu * qd[1];
    if (fd[0] != 0.0 || fd[1] != 0.0 || fd[2] != 0.0) {
        /* inertial force at C1: [0, 0, Wηᵀ (d × Rᵀ F), R Rᵀ F] */
        const double *r = k.r;
        double b[3], dc[3], w6[6];
        b[0] = r[0] * fd[0] + r[3] * fd[1] + r[6] * fd[2];
        b[1] = r[1] * fd[0] + r[4] * fd[1] + r[7] * fd[2];
        b[2] = r[2] * fd[0] + r[5] * fd[1] + r[8] * fd[2];
        double dx = m->dC1[0], dy = m->dC1[1], dz = m->dC1[2];
        dc[0] = dy * b[2] - dz * b[1];
        dc[1] = dz * b[0] - dx * b[2];
        dc[2] = dx * b[1] - dy * b[0];
        body_wrench(&k, b, dc, w6);
        for (int i = 0; i < 6; i++)
            tau[2 + i] += w6[i];
    }
    if (args[5] != Py_None)
        for (int i = 0; i < 8; i++)
            tau[i] += dist[i];
    Py_buffer view;
    if (PyObject_GetBuffer(args[6], &view, PyBUF_C_CONTIGUOUS | PyBUF_FORMAT | PyBUF_WRITABLE))
        return NULL;
    if (!view.format || strcmp(view.format, "d") != 0 || view.len != 64) {
        PyBuffer_Release(&view);
        PyErr_SetString(PyExc_ValueError, "out must be a writable contiguous float64 vector of 8");
        return NULL;
    }
    double *out = (double *)view.buf;
    if (PyObject_IsTrue(args[7]))
        for (int i = 0; i < 8; i++)
            out[i] = tau[m->perm8_inv[i]];
    else
        memcpy(out, tau, sizeof(tau));
    PyBuffer_Release(&view);
    Py_RETURN_NONE;
}

static int read_qqz(PyObject *const *args, double *q, double *qd, double *z)
{
    return read_vec(args[1], 8, q, 0, "q") || read_vec(args[2], 8, qd, 0, "qdot")
           || read_vec(args[3], 3, z, 0, "zeta");
}

static PyObject *py_aero_loads(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    /* (model, q, qdot, zeta, delta[4], columns) -> (ϑ list 8, V list 6, cols | None) */
    if (nargs != 6) {
        PyErr_SetString(PyExc_TypeError, "aero_loads takes 6 arguments");
        return NULL;
    }
    Model *m = get_model(args[0]);
    double q[8], qd[8], z[3], delta[4], out[8], V6[6], cols[24];
    if (!m || read_qqz(args, q, qd, z) || read_vec(args[4], 4, delta, 0, "delta"))
        return NULL;
    int columns = PyObject_IsTrue(args[5]);
    Kin k;
    body_kinematics(q, qd, z, &k);
    if (aero_loads(m, &k, delta, out, V6, columns ? cols : NULL))
        return NULL;
    PyObject *c = Py_None;
    if (columns) {
        c = PyList_New(4);
        if (!c)
            return NULL;
        for (int j = 0; j < 4; j++) {
            PyObject *col = list_of(cols + 6 * j, 6);
            if (!col) {
                Py_DECREF(c);
                return NULL;
            }
            PyList_SET_ITEM(c, j, col);
        }
    } else {
        Py_INCREF(c);
    }
    return Py_BuildValue("(NNN)", list_of(out, 8), list_of(V6, 6), c);
}

static PyObject *py_propeller_force(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    /* (model, q, qdot, zeta, n[2]) -> ϑ_P list 8 */
    if (nargs != 5) {
        PyErr_SetString(PyExc_TypeError, "propeller_force takes 5 arguments");
        return NULL;
    }
    Model *m = get_model(args[0]);
    double q[8], qd[8], z[3], n[2], out[8];
    if (!m || read_qqz(args, q, qd, z) || read_vec(args[4], 2, n, 0, "n"))
        return NULL;
    Kin k;
    Rotor rot[2];
    body_kinematics(q, qd, z, &k);
    rotors(m, q, qd, &k, rot);
    propeller_force(m, &k, rot, n, out);
    return list_of(out, 8);
}

static PyObject *py_affine_terms(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    /* (model, q, qdot, zeta, n[2], through_thrust) ->
     * (B row-major list 64, ϑ_passive list 8, V list 6, V_xz list 2, φ list 2) */
    if (nargs != 6) {
        PyErr_SetString(PyExc_TypeError, "affine_terms takes 6 arguments");
        return NULL;
    }
    Model *m = get_model(args[0]);
    double q[8], qd[8], z[3], n[2];
    if (!m || read_qqz(args, q, qd, z) || read_vec(args[4], 2, n, 0, "n"))
        return NULL;
    int through_thrust = PyObject_IsTrue(args[5]);
    double B[64], passive[8], V6[6], vxz[2], phis[2];
    if (affine_core(m, q, qd, z, n, through_thrust, B, passive, V6, vxz, phis))
        return NULL;
    return Py_BuildValue("(NNNNN)", list_of(B, 64), list_of(passive, 8), list_of(V6, 6),
                         list_of(vxz, 2), list_of(phis, 2));
}

static PyObject *py_newton_speed(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    /* (model, f[2], v_xz[2], φ[2], n_guess[2], iterations, rtol) -> list 2 | None:
     * newton_speed_for_thrust (tiltrotor/law.py) */
    if (nargs != 7) {
        PyErr_SetString(PyExc_TypeError, "newton_speed takes 7 arguments");
        return NULL;
    }
    Model *m = get_model(args[0]);
    double f[2], vx[2], ph[2], n[2], n_out[2];
    if (!m || read_vec(args[1], 2, f, 0, "f") || read_vec(args[2], 2, vx, 0, "v_xz")
        || read_vec(args[3], 2, ph, 0, "phi") || read_vec(args[4], 2, n, 0, "n_guess"))
        return NULL;
    long iterations = PyLong_AsLong(args[5]);
    double rtol = PyFloat_AsDouble(args[6]);
    if (PyErr_Occurred())
        return NULL;
    if (newton_core(m, f, vx, ph, n, iterations, rtol, n_out))
        Py_RETURN_NONE;
    return list_of(n_out, 2);
}

static PyObject *py_surface_bounds(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    /* (v_air[4], s, c, f_lo, f_hi, t_lo, t_hi, d_lo, d_hi) -> (lo list 8, hi list 8) */
    if (nargs != 9) {
        PyErr_SetString(PyExc_TypeError, "surface_bounds takes 9 arguments");
        return NULL;
    }
    double v[4], k[8], lo[8], hi[8];
    if (read_vec(args[0], 4, v, 0, "v_air"))
        return NULL;
    for (int i = 0; i < 8; i++) {
        k[i] = PyFloat_AsDouble(args[1 + i]);
        if (k[i] == -1.0 && PyErr_Occurred())
            return NULL;
    }
    if (bounds_core(v, k, lo, hi)) {
        PyErr_Format(PyExc_ValueError, "v_air must be non-negative and finite, got %R", args[0]);
        return NULL;
    }
    return Py_BuildValue("(NN)", list_of(lo, 8), list_of(hi, 8));
}

static PyObject *py_saturation_flags(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    /* (tau[8], lo[8], up[8], rel_tol, min_width) -> list 8 of ±1/0 */
    if (nargs != 5) {
        PyErr_SetString(PyExc_TypeError, "saturation_flags takes 5 arguments");
        return NULL;
    }
    double t[8], lo[8], up[8], out[8];
    if (read_vec(args[0], 8, t, 0, "tau") || read_vec(args[1], 8, lo, 0, "lo")
        || read_vec(args[2], 8, up, 0, "up"))
        return NULL;
    double rel_tol = PyFloat_AsDouble(args[3]), min_width = PyFloat_AsDouble(args[4]);
    if (PyErr_Occurred())
        return NULL;
    flags_core(t, lo, up, rel_tol, min_width, out);
    return list_of(out, 8);
}

static PyMethodDef methods[] = {
    {"make_model", (PyCFunction)make_model, METH_VARARGS,
     "make_model(constants: dict) -> capsule holding the force model's constants."},
    {"plant_force", (PyCFunction)(void (*)(void))py_plant_force, METH_FASTCALL,
     "plant_force(model, drake_state, u, wind, force_disturbance, disturbance, out, drake_order)"
     " -> None: TiltrotorForces.thesis_force written into out (Drake or thesis order)."},
    {"aero_loads", (PyCFunction)(void (*)(void))py_aero_loads, METH_FASTCALL,
     "aero_loads(model, q, qdot, zeta, delta, columns) -> (ϑ_aero, V, cols | None)."},
    {"propeller_force", (PyCFunction)(void (*)(void))py_propeller_force, METH_FASTCALL,
     "propeller_force(model, q, qdot, zeta, n) -> ϑ_P (7.32)."},
    {"affine_terms", (PyCFunction)(void (*)(void))py_affine_terms, METH_FASTCALL,
     "affine_terms(model, q, qdot, zeta, n, through_thrust) -> (B, ϑ_passive, V, V_xz, φ)."},
    {"newton_speed", (PyCFunction)(void (*)(void))py_newton_speed, METH_FASTCALL,
     "newton_speed(model, f, v_xz, phi, n_guess, iterations, rtol) -> [n_R, n_L] | None."},
    {"surface_bounds", (PyCFunction)(void (*)(void))py_surface_bounds, METH_FASTCALL,
     "surface_bounds(v_air4, s, c, f_lo, f_hi, t_lo, t_hi, d_lo, d_hi) -> (lo, hi)."},
    {"saturation_flags", (PyCFunction)(void (*)(void))py_saturation_flags, METH_FASTCALL,
     "saturation_flags(tau, lo, up, rel_tol, min_width) -> list of 8 flags (+1 upper, -1 lower)."},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef moduledef = {
    PyModuleDef_HEAD_INIT, "_forces",
    "Compiled tilt-rotor force model (mirrors the Python scalar paths; see forces.c).", -1,
    methods, NULL, NULL, NULL, NULL,
};

/* ------------------------------------------------- C interface for other kernels ---- */

static const void *capi_forces_model(PyObject *capsule)
{
    return get_model(capsule);
}

static ForcesCAPI forces_c_api = {FORCES_CAPI_VERSION, capi_forces_model, affine_core,
                                  newton_core, bounds_core, flags_core};

PyMODINIT_FUNC PyInit__forces(void)
{
    PyObject *module = PyModule_Create(&moduledef);
    if (module && export_c_api(module, &forces_c_api, FORCES_CAPI_NAME) < 0)
        Py_CLEAR(module);
    return module;
}
