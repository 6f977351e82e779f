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

struct dm_move_ws {
    int n, kmax;
    double *G, *r;                       /* n */
    double *g, *q, *v, *a11, *a12, *a21, *a22, *b1, *b2, *phiP; /* kmax (phiP: 3 kmax) */
};

dm_move_ws *dm_move_alloc(int n, int kmax, dm_error *err)
{
    dm_move_ws *w = calloc(1, sizeof *w);
    if (w) {
        w->n = n;
        w->kmax = kmax;
        w->G = malloc(sizeof(double) * n);
        w->r = malloc(sizeof(double) * n);
        double **k1[] = {&w->g, &w->q, &w->v, &w->a11, &w->a12, &w->a21, &w->a22, &w->b1, &w->b2};
        for (size_t i = 0; i < sizeof k1 / sizeof k1[0]; i++)
            *k1[i] = malloc(sizeof(double) * kmax);
        w->phiP = malloc(sizeof(double) * 3 * kmax);
    }
    if (!w || !w->G || !w->r || !w->g || !w->q || !w->v || !w->a11 || !w->a12 || !w->a21 ||
        !w->a22 || !w->b1 || !w->b2 || !w->phiP) {
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
    double *p[] = {w->G, w->r, w->g, w->q, w->v, w->a11, w->a12, w->a21, w->a22, w->b1, w->b2, w->phiP};
    for (size_t i = 0; i < sizeof p / sizeof p[0]; i++)
        free(p[i]);
    free(w);
}

/* Load of a unit acceleration along dir, modal forces, platform shapes and
 * the static residual of the dropped modes. */
static int prepare(dm_move_ws *w, const dm_model *md, const dm_modes *mo, int k,
                   const dm_static *st, const double dir[3], int quasi_static, double rP[3],
                   dm_error *err)
{
    int n = md->n, pd = md->platform_dof;
    dm_rigid_motion m = {{0, 0, 0}, {0, 0, 0}, {dir[0], dir[1], dir[2]}};
    const double v0[3] = {0, 0, 0};
    int rc = dm_kin_accelerations(md->robot, &md->pose, v0, dir, m.alpha_ddot, err);
    if (rc)
        return rc;
    memset(w->G, 0, sizeof(double) * n);
    dm_loads_add_inertial(md, &m, w->G);
    memcpy(w->r, w->G, sizeof(double) * n);
    if (quasi_static && (rc = dm_static_solve(st, w->r, 1, err)))
        return rc;
    for (int j = 0; j < k; j++) {
        const double *ph = mo->phi + (size_t)j * n;
        double g = 0;
        for (int i = 0; i < n; i++)
            g += ph[i] * w->G[i];
        w->g[j] = g;
        for (int c = 0; c < 3; c++)
            w->phiP[3 * j + c] = ph[pd + c];
    }
    for (int c = 0; c < 3; c++) {
        double s = w->r[pd + c];
        for (int j = 0; j < k; j++)
            s -= w->phiP[3 * j + c] * w->g[j] / (mo->omega_rad_s[j] * mo->omega_rad_s[j]);
        rP[c] = quasi_static ? s : 0.0;
    }
    return DM_OK;
}

/* Exact one-step transition of each mode for step h (load constant). */
static void transitions(dm_move_ws *w, const dm_modes *mo, int k, double alpha, double beta,
                        double h, int *damped)
{
    *damped = 0;
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
        *damped |= z > 0;
    }
}

/* |dynamic platform translation + a * rP| */
static double deviation(const dm_move_ws *w, int k, double a, const double rP[3])
{
    double y[3] = {a * rP[0], a * rP[1], a * rP[2]};
    for (int j = 0; j < k; j++)
        for (int c = 0; c < 3; c++)
            y[c] += w->phiP[3 * j + c] * w->q[j];
    return dm_norm3(y);
}

static void advance(dm_move_ws *w, int k, double a)
{
    for (int j = 0; j < k; j++) {
        double f = a * w->g[j], q = w->q[j], v = w->v[j];
        w->q[j] = w->a11[j] * q + w->a12[j] * v + w->b1[j] * f;
        w->v[j] = w->a21[j] * q + w->a22[j] * v + w->b2[j] * f;
    }
}

int dm_standard_move(dm_move_ws *w, const dm_model *md, const dm_modes *mo, int k,
                     const dm_static *st, const double dir[3], const dm_move_opts *o,
                     dm_move_result *res, dm_error *err)
{
    double rP[3];
    if (k > w->kmax || k > mo->k)
        return dm_fail(err, DM_EINVAL, "standard move: %d modes, workspace holds %d", k, w->kmax);
    int rc = prepare(w, md, mo, k, st, dir, o->quasi_static, rP, err);
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
    int damped;
    transitions(w, mo, k, alpha, beta, h, &damped);
    memset(w->q, 0, sizeof(double) * k);
    memset(w->v, 0, sizeof(double) * k);
    double A = o->amax_ms2, peak = 0;
    for (long s = 0; s < 2 * nhalf; s++) {
        double a = s < nhalf ? A : -A;
        peak = fmax(peak, deviation(w, k, a, rP)); /* right limit at the step start */
        advance(w, k, a);
        peak = fmax(peak, deviation(w, k, a, rP)); /* left limit at its end */
    }
    double hw = stride * h;
    if (stride > 1)
        transitions(w, mo, k, alpha, beta, hw, &damped);
    long nwin = (long)ceil(o->window_s / hw);
    double resid = 0, last_above = -1, d = 0;
    for (long s = 1; s <= nwin; s++) {
        advance(w, k, 0.0);
        d = deviation(w, k, 0.0, rP);
        resid = fmax(resid, d);
        if (d > o->tol_m)
            last_above = s * hw;
    }
    res->peak_m = peak;
    res->residual_m = resid;
    if (!damped || d > o->tol_m)
        res->settling_s = INFINITY;
    else
        res->settling_s = last_above < 0 ? 0.0 : last_above;
    return DM_OK;
}
