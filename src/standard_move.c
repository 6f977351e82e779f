/* Dynamic error of the standard bang-bang move at a frozen pose (MODEL.md §5).
 *
 * y = x - x_static obeys M y'' + C y' + K y = a(t) G with G the inertial
 * load of a unit platform acceleration along the move (zero velocity) and
 * a(t) = +amax, -amax, 0. Each retained mode is advanced exactly with a
 * fixed step (a 2x2 transition per mode, from dm_sdof_step); the dropped
 * modes contribute their static response a(t) r (quasi-static correction). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "dm_integrate.h"
#include "dm_kinematics.h"
#include "dm_loads.h"
#include "dm_static.h"
#include "dm_vec3.h"

void dm_move_opts_default(dm_move_opts *o)
{
    o->amax_ms2 = 50.0;
    o->tau_s = 0.05;
    o->tol_m = 10e-6;
    o->window_s = 1.0;
    o->quasi_static = 1;
}

/* Directions done in one pass: they share each mode's transitions. */
#define MAXDIR 3

struct dm_move_ws {
    int n, kmax;
    double *G, *r;                       /* n */
    double *g, *q, *v;                   /* MAXDIR x kmax: modal forces, state */
    double *a11, *a12, *a21, *a22, *b1, *b2, *zw, *wd; /* kmax: transitions, decay */
    double *phiP, *normP;                /* 3 x kmax platform shapes, their norms */
};

dm_move_ws *dm_move_alloc(int n, int kmax, dm_error *err)
{
    dm_move_ws *w = calloc(1, sizeof *w);
    if (w) {
        w->n = n;
        w->kmax = kmax;
        w->G = malloc(sizeof(double) * n * MAXDIR);
        w->r = malloc(sizeof(double) * n);
        double **kd[] = {&w->g, &w->q, &w->v};
        for (size_t i = 0; i < sizeof kd / sizeof kd[0]; i++)
            *kd[i] = malloc(sizeof(double) * kmax * MAXDIR);
        double **k1[] = {&w->a11, &w->a12, &w->a21, &w->a22, &w->b1, &w->b2, &w->zw, &w->wd,
                         &w->normP};
        for (size_t i = 0; i < sizeof k1 / sizeof k1[0]; i++)
            *k1[i] = malloc(sizeof(double) * kmax);
        w->phiP = malloc(sizeof(double) * 3 * kmax);
    }
    if (!w || !w->G || !w->r || !w->g || !w->q || !w->v || !w->a11 || !w->a12 || !w->a21 ||
        !w->a22 || !w->b1 || !w->b2 || !w->zw || !w->wd || !w->normP || !w->phiP) {
        dm_move_free(w);
        dm_fail(err, DM_ENOMEM, "out of memory for the standard move");
        return NULL;
    }
    return w;
}

void dm_move_free(dm_move_ws *w)
{
    if (!w)
        return;
    double *p[] = {w->G,  w->r,  w->g,  w->q,  w->v,  w->a11,   w->a12, w->a21,
                   w->a22, w->b1, w->b2, w->zw, w->wd, w->normP, w->phiP};
    for (size_t i = 0; i < sizeof p / sizeof p[0]; i++)
        free(p[i]);
    free(w);
}

/* Load of a unit acceleration along each direction, the modal forces, the
 * platform shapes and the static residual of the dropped modes. */
static int prepare(dm_move_ws *w, const dm_model *md, const dm_modes *mo, int k,
                   const dm_static *st, const double (*dir)[3], int ndir, int quasi_static,
                   double (*rP)[3], dm_error *err)
{
    int n = md->n, pd = md->platform_dof;
    const double v0[3] = {0, 0, 0};
    for (int j = 0; j < k; j++) {
        const double *ph = mo->phi + (size_t)j * n;
        for (int c = 0; c < 3; c++)
            w->phiP[3 * j + c] = ph[pd + c];
        w->normP[j] = dm_norm3(w->phiP + 3 * j);
    }
    for (int d = 0; d < ndir; d++) {
        double *G = w->G + (size_t)d * n;
        dm_rigid_motion m = {{0, 0, 0}, {0, 0, 0}, {dir[d][0], dir[d][1], dir[d][2]}};
        int rc = dm_kin_accelerations(md->robot, &md->pose, v0, dir[d], m.alpha_ddot, err);
        if (rc)
            return rc;
        memset(G, 0, sizeof(double) * n);
        dm_loads_add_inertial(md, &m, G);
        memcpy(w->r, G, sizeof(double) * n);
        if (quasi_static && (rc = dm_static_solve(st, w->r, 1, err)))
            return rc;
        for (int j = 0; j < k; j++) {
            const double *ph = mo->phi + (size_t)j * n;
            double g = 0;
            for (int i = 0; i < n; i++)
                g += ph[i] * G[i];
            w->g[d * k + j] = g;
        }
        for (int c = 0; c < 3; c++) {
            double s = w->r[pd + c];
            for (int j = 0; j < k; j++)
                s -= w->phiP[3 * j + c] * w->g[d * k + j] / (mo->omega_rad_s[j] * mo->omega_rad_s[j]);
            rP[d][c] = quasi_static ? s : 0.0;
        }
    }
    return DM_OK;
}

/* Exact one-step transition of each mode for step h (load constant);
 * returns whether any mode is damped and, in *under, whether all are
 * underdamped (their free vibration then has the envelope e^-zwt). */
static int transitions(dm_move_ws *w, const dm_modes *mo, int k, double alpha, double beta,
                       double h, int *under)
{
    int damped = 0;
    *under = 1;
    for (int j = 0; j < k; j++) {
        double om = mo->omega_rad_s[j], z = alpha / (2 * om) + beta * om / 2;
        double q = 1, v = 0;
        dm_sdof_step(om, z, 0, 0, h, &q, &v);
        w->a11[j] = q, w->a21[j] = v;
        q = 0, v = 1;
        dm_sdof_step(om, z, 0, 0, h, &q, &v);
        w->a12[j] = q, w->a22[j] = v;
        q = 0, v = 0;
        dm_sdof_step(om, z, 1, 1, h, &q, &v);
        w->b1[j] = q, w->b2[j] = v;
        damped |= z > 0;
        *under &= z < 1 - 1e-6;
        w->zw[j] = z * om;
        w->wd[j] = z < 1 ? om * sqrt(1 - z * z) : om;
    }
    return damped;
}

/* |dynamic platform translation + a * rP| of direction d */
static double deviation(const dm_move_ws *w, int k, int d, double a, const double rP[3])
{
    double y[3] = {a * rP[0], a * rP[1], a * rP[2]};
    const double *q = w->q + d * k;
    for (int j = 0; j < k; j++)
        for (int c = 0; c < 3; c++)
            y[c] += w->phiP[3 * j + c] * q[j];
    return dm_norm3(y);
}

static void advance(dm_move_ws *w, int k, int ndir, double a)
{
    for (int d = 0; d < ndir; d++) {
        double *q = w->q + d * k, *v = w->v + d * k;
        const double *g = w->g + d * k;
        for (int j = 0; j < k; j++) {
            double f = a * g[j], qj = q[j], vj = v[j];
            q[j] = w->a11[j] * qj + w->a12[j] * vj + w->b1[j] * f;
            v[j] = w->a21[j] * qj + w->a22[j] * vj + w->b2[j] * f;
        }
    }
}

/* After the move (no load) every underdamped mode rings inside its
 * envelope: |q_j(t + s)| <= e^-zw s sqrt(q^2 + ((v + zw q) / wd)^2), so the
 * deviation of direction d stays below sum_j |phiP_j| (that) from now on. */
static double envelope(const dm_move_ws *w, int k, int d)
{
    const double *q = w->q + d * k, *v = w->v + d * k;
    double b = 0;
    for (int j = 0; j < k; j++) {
        double c2 = (v[j] + w->zw[j] * q[j]) / w->wd[j];
        b += w->normP[j] * sqrt(q[j] * q[j] + c2 * c2);
    }
    return b;
}

/* The moves along ndir (<= 3) unit directions with the model built at the
 * pose, its first k modes and the Cholesky factor of K in `statics`. */
int dm_standard_moves(dm_move_ws *w, const dm_model *md, const dm_modes *mo, int k,
                      const dm_static *st, const double (*dir)[3], int ndir,
                      const dm_move_opts *o, dm_move_result *res, dm_error *err)
{
    double rP[MAXDIR][3];
    if (k > w->kmax || k > mo->k || ndir < 1 || ndir > MAXDIR)
        return dm_fail(err, DM_EINVAL, "standard move: %d modes, workspace holds %d", k, w->kmax);
    int rc = prepare(w, md, mo, k, st, dir, ndir, o->quasi_static, rP, err);
    if (rc)
        return rc;
    /* during the move: 200 steps per move and 20 per period of the highest
     * retained mode; after it (a = 0): 20 per period, a whole number of
     * move steps */
    double fk = mo->freq_hz[k - 1], hmax = fmin(o->tau_s / 200, 1.0 / (20 * fk));
    long nhalf = (long)ceil(0.5 * o->tau_s / hmax);
    double h = 0.5 * o->tau_s / nhalf, alpha = md->robot->rayleigh_alpha;
    double beta = md->robot->rayleigh_beta;
    long stride = (long)floor(1.0 / (20 * fk) / h);
    if (stride < 1)
        stride = 1;
    int under, damped = transitions(w, mo, k, alpha, beta, h, &under);
    memset(w->q, 0, sizeof(double) * k * ndir);
    memset(w->v, 0, sizeof(double) * k * ndir);
    double A = o->amax_ms2, peak[MAXDIR] = {0};
    for (long s = 0; s < 2 * nhalf; s++) {
        double a = s < nhalf ? A : -A;
        for (int d = 0; d < ndir; d++) /* right limit at the step start */
            peak[d] = fmax(peak[d], deviation(w, k, d, a, rP[d]));
        advance(w, k, ndir, a);
        for (int d = 0; d < ndir; d++) /* left limit at its end */
            peak[d] = fmax(peak[d], deviation(w, k, d, a, rP[d]));
    }
    double hw = stride * h;
    if (stride > 1)
        transitions(w, mo, k, alpha, beta, hw, &under);
    long nwin = (long)ceil(o->window_s / hw);
    double resid[MAXDIR] = {0}, last_above[MAXDIR] = {-1, -1, -1}, dev[MAXDIR] = {0};
    int ringing[MAXDIR] = {1, 1, 1}, live = ndir;
    for (long s = 1; s <= nwin && live; s++) {
        advance(w, k, ndir, 0.0);
        for (int d = 0; d < ndir; d++) {
            if (!ringing[d])
                continue;
            dev[d] = deviation(w, k, d, 0.0, rP[d]);
            resid[d] = fmax(resid[d], dev[d]);
            if (dev[d] > o->tol_m)
                last_above[d] = s * hw;
            /* damped: stop once no later sample can reach the maximum or
             * the band (the margin covers the bound's own round-off) */
            if (damped && under && (s & 15) == 0 &&
                envelope(w, k, d) < 0.999 * fmin(o->tol_m, resid[d])) {
                ringing[d] = 0;
                dev[d] = 0;
                live--;
            }
        }
    }
    for (int d = 0; d < ndir; d++) {
        res[d].peak_m = peak[d];
        res[d].residual_m = resid[d];
        if (!damped || dev[d] > o->tol_m)
            res[d].settling_s = INFINITY;
        else
            res[d].settling_s = last_above[d] < 0 ? 0.0 : last_above[d];
    }
    return DM_OK;
}

int dm_standard_move(dm_move_ws *w, const dm_model *md, const dm_modes *mo, int k,
                     const dm_static *st, const double dir[3], const dm_move_opts *o,
                     dm_move_result *res, dm_error *err)
{
    const double one[1][3] = {{dir[0], dir[1], dir[2]}};
    return dm_standard_moves(w, md, mo, k, st, one, 1, o, res, err);
}
