/* Normal-coordinate integration with frozen configurations (docs/model.md §4). */
#include "dm_integrate.h"

#include <cblas.h>
#include <cvode/cvode.h>
#include <lapacke.h>
#include <math.h>
#include <nvector/nvector_serial.h>
#include <stdlib.h>
#include <string.h>
#include <sundials/sundials_context.h>
#include <sunlinsol/sunlinsol_dense.h>
#include <sunmatrix/sunmatrix_dense.h>

#include "dm_kinematics.h"
#include "dm_loads.h"
#include "dm_static.h"
#include "dm_vec3.h"

/* ---- one degree of freedom, exact -------------------------------------- */

double dm_rayleigh_zeta(double alpha, double beta, double omega)
{
    return alpha / (2 * omega) + beta * omega / 2;
}

void dm_sdof_step(double w, double z, double f0, double f1, double h, double *q, double *qd)
{
    /* particular solution A + B t for the load f0 + s t */
    double s = (f1 - f0) / h, B = s / (w * w), A = (f0 - 2 * z * w * B) / (w * w);
    double y0 = *q - A, v0 = *qd - B, y, v;
    if (z < 1 - 1e-6) {
        double wd = w * sqrt(1 - z * z), e = exp(-z * w * h), c = cos(wd * h), sn = sin(wd * h);
        double c2 = (v0 + z * w * y0) / wd;
        y = e * (y0 * c + c2 * sn);
        v = e * ((-z * w * y0 + wd * c2) * c + (-z * w * c2 - wd * y0) * sn);
    } else if (z > 1 + 1e-6) {
        double r = w * sqrt(z * z - 1), r1 = -z * w + r, r2 = -z * w - r;
        double c1 = (v0 - r2 * y0) / (r1 - r2), c2 = y0 - c1;
        double e1 = exp(r1 * h), e2 = exp(r2 * h);
        y = c1 * e1 + c2 * e2;
        v = r1 * c1 * e1 + r2 * c2 * e2;
    } else { /* critically damped */
        double e = exp(-w * h), c2 = v0 + w * y0;
        y = (y0 + c2 * h) * e;
        v = (c2 - w * (y0 + c2 * h)) * e;
    }
    *q = A + B * h + y;
    *qd = B + v;
}

/* ---- the stepper --------------------------------------------------------- */

struct dm_stepper {
    int n, kmax;
    dm_ode_method method;
    double rtol, atol;
    double *Mx;        /* n x 4: M x (then M xd, F0, F1 for a spectrum's projections) */
    double *q, *qd, *f0, *f1, *omega, *zeta;      /* modal buffers */
    double *Minv_K, *b0, *b1, *Mfac;              /* full-model buffers */
    double alpha, beta, h;                        /* current step */
    int own_damping;                              /* alpha, beta set, not the robot's */
    SUNContext ctx;
    void *cvode;
    N_Vector y;
    SUNMatrix J;
    SUNLinearSolver LS;
    int ode_size;
};

static void free_cvode(dm_stepper *st)
{
    if (st->cvode)
        CVodeFree(&st->cvode);
    if (st->LS)
        SUNLinSolFree(st->LS);
    if (st->J)
        SUNMatDestroy(st->J);
    if (st->y)
        N_VDestroy(st->y);
    st->LS = NULL;
    st->J = NULL;
    st->y = NULL;
    st->ode_size = 0;
}

dm_stepper *dm_stepper_alloc(int n, int kmax, dm_ode_method method, double rtol, double atol,
                             dm_error *err)
{
    dm_stepper *st = calloc(1, sizeof *st);
    int full = method == DM_ODE_FULL;
    size_t m = (size_t)(kmax > n ? kmax : n);
    if (st) {
        st->n = n;
        st->kmax = kmax;
        st->method = method;
        st->rtol = rtol;
        st->atol = atol;
        st->Mx = malloc(sizeof(double) * n * DM_SPECTRUM_QMAX);
        st->q = malloc(sizeof(double) * m);
        st->qd = malloc(sizeof(double) * m);
        st->f0 = malloc(sizeof(double) * m);
        st->f1 = malloc(sizeof(double) * m);
        st->omega = malloc(sizeof(double) * m);
        st->zeta = malloc(sizeof(double) * m);
        if (full) {
            st->Minv_K = malloc(sizeof(double) * n * n);
            st->Mfac = malloc(sizeof(double) * n * n);
            st->b0 = malloc(sizeof(double) * n);
            st->b1 = malloc(sizeof(double) * n);
        }
    }
    if (!st || !st->Mx || !st->q || !st->qd || !st->f0 || !st->f1 || !st->omega || !st->zeta ||
        (full && (!st->Minv_K || !st->Mfac || !st->b0 || !st->b1))) {
        dm_stepper_free(st);
        dm_fail(err, DM_ENOMEM, "out of memory for the integrator");
        return NULL;
    }
    if (method != DM_ODE_CLOSED_FORM && SUNContext_Create(NULL, &st->ctx)) {
        dm_stepper_free(st);
        dm_fail(err, DM_ENUMERIC, "SUNDIALS context could not be created");
        return NULL;
    }
    return st;
}

void dm_stepper_free(dm_stepper *st)
{
    if (!st)
        return;
    free_cvode(st);
    if (st->ctx)
        SUNContext_Free(&st->ctx);
    free(st->Mx);
    free(st->q);
    free(st->qd);
    free(st->f0);
    free(st->f1);
    free(st->omega);
    free(st->zeta);
    free(st->Minv_K);
    free(st->Mfac);
    free(st->b0);
    free(st->b1);
    free(st);
}

/* modal ODE: y = [q_0, qd_0, q_1, qd_1, ...], t measured from the step start */
static int modal_rhs(realtype t, N_Vector yv, N_Vector ydv, void *user)
{
    const dm_stepper *st = user;
    const double *y = N_VGetArrayPointer(yv);
    double *yd = N_VGetArrayPointer(ydv), r = t / st->h;
    for (int j = 0; j < st->ode_size / 2; j++) {
        double w = st->omega[j], f = st->f0[j] + (st->f1[j] - st->f0[j]) * r;
        yd[2 * j] = y[2 * j + 1];
        yd[2 * j + 1] = f - 2 * st->zeta[j] * w * y[2 * j + 1] - w * w * y[2 * j];
    }
    return 0;
}

/* full ODE: y = [x; v], v' = M^-1 F(t) - alpha v - M^-1 K (beta v + x) */
static int full_rhs(realtype t, N_Vector yv, N_Vector ydv, void *user)
{
    dm_stepper *st = user;
    int n = st->n;
    const double *x = N_VGetArrayPointer(yv), *v = x + n;
    double *xd = N_VGetArrayPointer(ydv), *vd = xd + n, r = t / st->h;
    for (int i = 0; i < n; i++) {
        xd[i] = v[i];
        st->Mx[i] = st->beta * v[i] + x[i];
    }
    for (int i = 0; i < n; i++)
        vd[i] = st->b0[i] + (st->b1[i] - st->b0[i]) * r - st->alpha * v[i];
    cblas_dgemv(CblasColMajor, CblasNoTrans, n, n, -1.0, st->Minv_K, n, st->Mx, 1, 1.0, vd, 1);
    return 0;
}

static int full_jac(realtype t, N_Vector y, N_Vector fy, SUNMatrix J, void *user, N_Vector t1,
                    N_Vector t2, N_Vector t3)
{
    (void)t, (void)y, (void)fy, (void)t1, (void)t2, (void)t3;
    const dm_stepper *st = user;
    int n = st->n;
    SUNMatZero(J);
    for (int i = 0; i < n; i++) {
        SM_ELEMENT_D(J, i, n + i) = 1.0;
        SM_ELEMENT_D(J, n + i, n + i) = -st->alpha;
        for (int c = 0; c < n; c++) {
            double a = st->Minv_K[(size_t)c * n + i];
            SM_ELEMENT_D(J, n + i, c) = -a;
            SM_ELEMENT_D(J, n + i, n + c) -= st->beta * a;
        }
    }
    return 0;
}

/* ---- the modal ODE's Newton systems -------------------------------------
 *
 * Each BDF step of CVODE solves (I - gamma J) x = b, J the modal ODE's
 * Jacobian: one 2 x 2 block per mode, [0 1; -w^2 -2 zeta w], so
 * I - gamma J = [1 -gamma; gamma w^2 1 + 2 gamma zeta w], whose inverse
 * is [1 + 2 gamma zeta w, gamma; -gamma w^2, 1] / det, det = 1 +
 * 2 gamma zeta w + gamma^2 w^2 >= 1. A matrix-embedded SUNLinearSolver
 * solves them so, with CVODE's current gamma: the exact Newton matrix at
 * every solve, where the band matrix and its LU (SUNLinSol_Band) were
 * built, copied, scaled and factored anew at each setup and reused, with
 * a correction for gamma's change, between them. */
static SUNLinearSolver_Type modal_ls_type(SUNLinearSolver S)
{
    (void)S;
    return SUNLINEARSOLVER_MATRIX_EMBEDDED;
}

static int modal_ls_solve(SUNLinearSolver S, SUNMatrix A, N_Vector x, N_Vector b, realtype tol)
{
    (void)A, (void)tol;
    const dm_stepper *st = S->content;
    realtype g;
    if (CVodeGetCurrentGamma(st->cvode, &g))
        return SUNLS_MEM_NULL;
    const double *bv = N_VGetArrayPointer(b);
    double *xv = N_VGetArrayPointer(x);
    for (int j = 0; j < st->ode_size / 2; j++) {
        double w = st->omega[j], c = 1 + 2 * g * st->zeta[j] * w, gw2 = g * w * w;
        double det = c + g * gw2, b0 = bv[2 * j], b1 = bv[2 * j + 1];
        xv[2 * j] = (c * b0 + g * b1) / det;
        xv[2 * j + 1] = (b1 - gw2 * b0) / det;
    }
    return SUNLS_SUCCESS;
}

/* the weights are CVODE's business: the solve is exact */
static int modal_ls_scaling(SUNLinearSolver S, N_Vector s1, N_Vector s2)
{
    (void)S, (void)s1, (void)s2;
    return SUNLS_SUCCESS;
}

static int modal_ls_free(SUNLinearSolver S)
{
    S->content = NULL; /* the stepper's */
    SUNLinSolFreeEmpty(S);
    return SUNLS_SUCCESS;
}

static SUNLinearSolver modal_ls(dm_stepper *st)
{
    SUNLinearSolver S = SUNLinSolNewEmpty(st->ctx);
    if (!S)
        return NULL;
    S->content = st;
    S->ops->gettype = modal_ls_type;
    S->ops->solve = modal_ls_solve;
    S->ops->setscalingvectors = modal_ls_scaling;
    S->ops->free = modal_ls_free;
    return S;
}

static void quiet(int code, const char *module, const char *function, char *msg, void *user)
{
    (void)code, (void)module, (void)function, (void)msg, (void)user;
}

/* A CVODE call's flag: negative is failure, named with the call and
 * SUNDIALS' name for the flag (linear-solver calls have their own). */
static int cv_check(int flag, const char *call, int linear, dm_error *err)
{
    if (flag >= 0)
        return DM_OK;
    char *name = linear ? CVodeGetLinReturnFlagName(flag) : CVodeGetReturnFlagName(flag);
    int rc = dm_fail(err, DM_ENUMERIC, "CVODE: %s failed: %s (flag %d)", call,
                     name ? name : "?", flag);
    free(name);
    return rc;
}

static int ensure_cvode(dm_stepper *st, int size, dm_error *err)
{
    if (st->ode_size == size)
        return DM_OK;
    free_cvode(st);
    int full = st->method == DM_ODE_FULL;
    st->y = N_VNew_Serial(size, st->ctx);
    st->J = full ? SUNDenseMatrix(size, size, st->ctx) : NULL;
    st->LS = full ? (st->J ? SUNLinSol_Dense(st->y, st->J, st->ctx) : NULL) : modal_ls(st);
    st->cvode = CVodeCreate(CV_BDF, st->ctx);
    if (!st->y || (full && !st->J) || !st->LS || !st->cvode) {
        free_cvode(st);
        return dm_fail(err, DM_ENOMEM, "out of memory for CVODE");
    }
    N_VConst(0.0, st->y);
    /* CVODE's own handler prints to stderr; our errors say the same */
    int rc = cv_check(CVodeSetErrHandlerFn(st->cvode, quiet, NULL), "CVodeSetErrHandlerFn", 0, err);
    if (!rc)
        rc = cv_check(CVodeInit(st->cvode, full ? full_rhs : modal_rhs, 0.0, st->y), "CVodeInit",
                      0, err);
    if (!rc)
        rc = cv_check(CVodeSStolerances(st->cvode, st->rtol, st->atol), "CVodeSStolerances", 0,
                      err);
    if (!rc)
        rc = cv_check(CVodeSetUserData(st->cvode, st), "CVodeSetUserData", 0, err);
    if (!rc)
        rc = cv_check(CVodeSetLinearSolver(st->cvode, st->LS, st->J), "CVodeSetLinearSolver", 1,
                      err);
    if (!rc && full)
        rc = cv_check(CVodeSetJacFn(st->cvode, full_jac), "CVodeSetJacFn", 1, err);
    if (!rc)
        rc = cv_check(CVodeSetMaxNumSteps(st->cvode, 1000000), "CVodeSetMaxNumSteps", 0, err);
    if (rc) {
        free_cvode(st);
        return rc;
    }
    st->ode_size = size;
    return DM_OK;
}

static int run_cvode(dm_stepper *st, double h, dm_error *err)
{
    realtype tret;
    int rc = cv_check(CVodeReInit(st->cvode, 0.0, st->y), "CVodeReInit", 0, err);
    if (!rc)
        rc = cv_check(CVodeSetStopTime(st->cvode, h), "CVodeSetStopTime", 0, err);
    if (!rc)
        rc = cv_check(CVode(st->cvode, h, st->y, &tret, CV_NORMAL), "CVode (one frozen step)", 0,
                      err);
    return rc;
}

void dm_stepper_set_damping(dm_stepper *st, double alpha, double beta)
{
    st->alpha = alpha;
    st->beta = beta;
    st->own_damping = 1;
}

static void set_damping(dm_stepper *st, const dm_model *md)
{
    if (st->own_damping)
        return;
    st->alpha = md->robot->rayleigh_alpha;
    st->beta = md->robot->rayleigh_beta;
}

/* The modal state (q, qd: k) over h under the modal loads f0 -> f1. */
static int advance_q(dm_stepper *st, const double *omega, int k, double h, dm_error *err)
{
    for (int j = 0; j < k; j++) {
        double w = omega[j];
        st->omega[j] = w;
        st->zeta[j] = dm_rayleigh_zeta(st->alpha, st->beta, w);
    }
    if (st->method == DM_ODE_CLOSED_FORM) {
        for (int j = 0; j < k; j++)
            dm_sdof_step(st->omega[j], st->zeta[j], st->f0[j], st->f1[j], h, &st->q[j], &st->qd[j]);
    } else {
        int rc = ensure_cvode(st, 2 * k, err);
        if (rc)
            return rc;
        st->h = h;
        double *y = N_VGetArrayPointer(st->y);
        for (int j = 0; j < k; j++) {
            y[2 * j] = st->q[j];
            y[2 * j + 1] = st->qd[j];
        }
        if ((rc = run_cvode(st, h, err)))
            return rc;
        for (int j = 0; j < k; j++) {
            st->q[j] = y[2 * j];
            st->qd[j] = y[2 * j + 1];
        }
    }
    return DM_OK;
}

static int advance_modal(dm_stepper *st, const dm_model *md, const dm_modes *mo, int k,
                         const double *F0, const double *F1, double h, double *x, double *xd,
                         dm_error *err)
{
    int n = st->n;
    const double *Phi = mo->phi;
    set_damping(st, md);
    /* q = Phi' M x, qd = Phi' M xd, f = Phi' F */
    dm_model_mult_M(md, x, 1, st->Mx);
    cblas_dgemv(CblasColMajor, CblasTrans, n, k, 1.0, Phi, n, st->Mx, 1, 0.0, st->q, 1);
    dm_model_mult_M(md, xd, 1, st->Mx);
    cblas_dgemv(CblasColMajor, CblasTrans, n, k, 1.0, Phi, n, st->Mx, 1, 0.0, st->qd, 1);
    cblas_dgemv(CblasColMajor, CblasTrans, n, k, 1.0, Phi, n, F0, 1, 0.0, st->f0, 1);
    cblas_dgemv(CblasColMajor, CblasTrans, n, k, 1.0, Phi, n, F1, 1, 0.0, st->f1, 1);
    int rc = advance_q(st, mo->omega_rad_s, k, h, err);
    if (rc)
        return rc;
    cblas_dgemv(CblasColMajor, CblasNoTrans, n, k, 1.0, Phi, n, st->q, 1, 0.0, x, 1);
    cblas_dgemv(CblasColMajor, CblasNoTrans, n, k, 1.0, Phi, n, st->qd, 1, 0.0, xd, 1);
    return DM_OK;
}

static int advance_full(dm_stepper *st, const dm_model *md, const double *F0, const double *F1,
                        double h, double *x, double *xd, dm_error *err)
{
    int n = st->n, rc;
    set_damping(st, md);
    dm_model_dense(md, st->Minv_K, st->Mfac);
    memcpy(st->b0, F0, sizeof(double) * n);
    memcpy(st->b1, F1, sizeof(double) * n);
    if (LAPACKE_dpotrf(LAPACK_COL_MAJOR, 'U', n, st->Mfac, n) ||
        LAPACKE_dpotrs(LAPACK_COL_MAJOR, 'U', n, n, st->Mfac, n, st->Minv_K, n) ||
        LAPACKE_dpotrs(LAPACK_COL_MAJOR, 'U', n, 1, st->Mfac, n, st->b0, n) ||
        LAPACKE_dpotrs(LAPACK_COL_MAJOR, 'U', n, 1, st->Mfac, n, st->b1, n))
        return dm_fail(err, DM_ENUMERIC, "mass matrix not positive definite");
    if ((rc = ensure_cvode(st, 2 * n, err)))
        return rc;
    st->h = h;
    double *y = N_VGetArrayPointer(st->y);
    memcpy(y, x, sizeof(double) * n);
    memcpy(y + n, xd, sizeof(double) * n);
    if ((rc = run_cvode(st, h, err)))
        return rc;
    memcpy(x, y, sizeof(double) * n);
    memcpy(xd, y + n, sizeof(double) * n);
    return DM_OK;
}

int dm_stepper_advance_all(dm_stepper *st, const dm_model *md, dm_spectrum *sp,
                           const double *F0, const double *F1, double h, double *x, double *xd,
                           dm_error *err)
{
    int n = st->n;
    if (st->method == DM_ODE_FULL || st->kmax < n || dm_spectrum_size(sp) != n)
        return dm_fail(err, DM_EINVAL, "integrator: a spectrum needs a modal stepper of every mode");
    set_damping(st, md);
    /* [q qd f0 f1] = Phi' [M x, M xd, F0, F1] in one pass over the factors */
    double *V = st->Mx;
    dm_model_mult_M(md, x, 1, V);
    dm_model_mult_M(md, xd, 1, V + n);
    memcpy(V + 2 * (size_t)n, F0, sizeof(double) * n);
    memcpy(V + 3 * (size_t)n, F1, sizeof(double) * n);
    dm_spectrum_project(sp, V, 4, V);
    memcpy(st->q, V, sizeof(double) * n);
    memcpy(st->qd, V + n, sizeof(double) * n);
    memcpy(st->f0, V + 2 * (size_t)n, sizeof(double) * n);
    memcpy(st->f1, V + 3 * (size_t)n, sizeof(double) * n);
    int rc = advance_q(st, dm_spectrum_omega(sp), n, h, err);
    if (rc)
        return rc;
    memcpy(V, st->q, sizeof(double) * n);
    memcpy(V + n, st->qd, sizeof(double) * n);
    dm_spectrum_expand(sp, V, 2, V);
    memcpy(x, V, sizeof(double) * n);
    memcpy(xd, V + n, sizeof(double) * n);
    return DM_OK;
}

int dm_stepper_advance(dm_stepper *st, const dm_model *md, const dm_modes *mo, int k,
                       const double *F0, const double *F1, double h, double *x, double *xd,
                       dm_error *err)
{
    if (st->method == DM_ODE_FULL)
        return advance_full(st, md, F0, F1, h, x, xd, err);
    if (k < 1 || k > st->kmax || k > mo->k)
        return dm_fail(err, DM_EINVAL, "integrator: %d modes requested, %d available", k, mo->k);
    return advance_modal(st, md, mo, k, F0, F1, h, x, xd, err);
}
