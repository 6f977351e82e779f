/* Dynamic error of the standard bang-bang move at a frozen pose (docs/model.md §5).
 *
 * y = x - x_static obeys M y'' + C y' + K y = a(t) G with G the inertial
 * load of a unit platform acceleration along the move (zero velocity) and
 * a(t) = +amax, -amax, 0. Each carried mode is advanced exactly with a
 * fixed step (a 2x2 transition per mode, from dm_sdof_step).
 *
 * What the k retained modes leave out of G's response: its static part is
 * r = K^-1 G - Phi Omega^-2 Phi' G (the quasi-static correction), but a move
 * that starts and stops also rings in the dropped modes, stiff ones above
 * all (zheng2017's axial mode along Z). Load-dependent Ritz vectors
 * (Wilson): r, A r, A^2 r, ... (A = K^-1 M) are M- and K-orthogonal to the
 * retained modes, so a Rayleigh-Ritz on them adds a few modes that carry
 * exactly r in the static limit and the dominant dropped dynamics besides;
 * their static remainder (zero to round-off) is added quasi-statically. */
#include <math.h>
#include <lapacke.h>
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
    o->ritz_vectors = DM_MOVE_RITZ;
}

/* Directions done in one pass; Ritz vectors per direction at most. */
#define MAXDIR 3
#define MAXRITZ 4

/* The modes one direction carries: the k retained ones, then its Ritz
 * modes, with their transitions for the current step. */
typedef struct {
    int nm;
    double *om, *zw, *wd, *g, *q, *v, *normP;        /* nm each */
    double *px, *py, *pz;                            /* platform translation of each mode */
    double *a11, *a12, *a21, *a22, *b1, *b2;
    double rP[3];                                   /* static remainder on the platform */
} carried;

struct dm_move_ws {
    int n, kmax;
    double *G, *r, *R, *MR, *t;          /* n; Krylov block n x MAXRITZ and M times it; n */
    carried dir[MAXDIR];
    double *pool;
};

static size_t carried_len(int kmax) { return (size_t)(kmax + MAXRITZ) * 17; }

dm_move_ws *dm_move_alloc(int n, int kmax, dm_error *err)
{
    dm_move_ws *w = calloc(1, sizeof *w);
    if (w) {
        w->n = n;
        w->kmax = kmax;
        w->G = malloc(sizeof(double) * n * MAXDIR);
        w->r = malloc(sizeof(double) * n);
        w->t = malloc(sizeof(double) * n);
        w->R = malloc(sizeof(double) * n * MAXRITZ);
        w->MR = malloc(sizeof(double) * n * MAXRITZ);
        w->pool = malloc(sizeof(double) * carried_len(kmax) * MAXDIR);
    }
    if (!w || !w->G || !w->r || !w->t || !w->R || !w->MR || !w->pool) {
        dm_move_free(w);
        dm_fail(err, DM_ENOMEM, "out of memory for the standard move");
        return NULL;
    }
    for (int d = 0; d < MAXDIR; d++) {
        carried *c = &w->dir[d];
        double *p = w->pool + carried_len(kmax) * d;
        size_t m = (size_t)kmax + MAXRITZ;
        double **arr[] = {&c->om, &c->zw,  &c->wd,  &c->g,   &c->q,   &c->v,  &c->normP, &c->px,
                          &c->py, &c->pz, &c->a11, &c->a12, &c->a21, &c->a22, &c->b1,   &c->b2};
        for (size_t i = 0; i < sizeof arr / sizeof arr[0]; i++, p += m)
            *arr[i] = p; /* 16 <= 17 arrays of kmax + MAXRITZ */
    }
    return w;
}

void dm_move_free(dm_move_ws *w)
{
    if (!w)
        return;
    free(w->G);
    free(w->r);
    free(w->t);
    free(w->R);
    free(w->MR);
    free(w->pool);
    free(w);
}

static void add_mode(carried *c, double om, double g, const double phiP[3])
{
    int j = c->nm++;
    c->om[j] = om;
    c->g[j] = g;
    c->px[j] = phiP[0];
    c->py[j] = phiP[1];
    c->pz[j] = phiP[2];
    c->normP[j] = dm_norm3(phiP);
}

/* M-orthonormalise w->R[:, m] against the retained modes and R[:, 0..m);
 * returns 0 when nothing of it is left (r already in their span). */
static int orthonormalise(dm_move_ws *w, const dm_model *md, const dm_modes *mo, int k, int m)
{
    int n = w->n;
    double *x = w->R + (size_t)m * n, *mx = w->MR + (size_t)m * n;
    /* one pass: the Krylov vectors are orthogonal to the retained modes in
     * exact arithmetic already (A keeps the complement of an invariant
     * subspace); the projection removes the round-off of their shapes */
    for (int pass = 0; pass < 1; pass++) {
        dm_model_mult_M(md, x, 1, mx);
        double before = 0;
        for (int i = 0; i < n; i++)
            before += x[i] * mx[i];
        for (int j = 0; j < k; j++) {
            const double *ph = mo->phi + (size_t)j * n;
            double c = 0;
            for (int i = 0; i < n; i++)
                c += ph[i] * mx[i];
            for (int i = 0; i < n; i++)
                x[i] -= c * ph[i];
        }
        for (int l = 0; l < m; l++) {
            const double *y = w->R + (size_t)l * n;
            double c = 0;
            for (int i = 0; i < n; i++)
                c += y[i] * mx[i];
            for (int i = 0; i < n; i++)
                x[i] -= c * y[i];
        }
        dm_model_mult_M(md, x, 1, mx);
        double after = 0;
        for (int i = 0; i < n; i++)
            after += x[i] * mx[i];
        if (!(after > 1e-20 * before) || !(after > 0))
            return 0;
        double s = 1 / sqrt(after);
        for (int i = 0; i < n; i++) {
            x[i] *= s;
            mx[i] *= s;
        }
    }
    return 1;
}

/* The Ritz modes of span(r, A r, ...) for one direction (r in w->r). */
static void ritz_modes(dm_move_ws *w, const dm_model *md, const dm_modes *mo, int k,
                       const dm_static *st, const double *G, int nritz, carried *c)
{
    int n = w->n, pd = md->platform_dof, m = 0;
    memcpy(w->R, w->r, sizeof(double) * n);
    while (m < nritz && orthonormalise(w, md, mo, k, m)) {
        if (++m < nritz) { /* the next Krylov vector: A times the last */
            memcpy(w->R + (size_t)m * n, w->MR + (size_t)(m - 1) * n, sizeof(double) * n);
            dm_static_solve(st, w->R + (size_t)m * n, 1, NULL);
        }
    }
    if (!m)
        return;
    double KR[MAXRITZ * MAXRITZ], ev[MAXRITZ], work[64];
    for (int j = 0; j < m; j++) {
        dm_model_mult_K(md, w->R + (size_t)j * n, 1, w->t);
        for (int i = 0; i < m; i++) {
            double s = 0;
            for (int l = 0; l < n; l++)
                s += w->R[(size_t)i * n + l] * w->t[l];
            KR[j * m + i] = s;
        }
    }
    for (int j = 0; j < m; j++) /* symmetric */
        for (int i = 0; i < j; i++)
            KR[j * m + i] = KR[i * m + j] = 0.5 * (KR[j * m + i] + KR[i * m + j]);
    if (LAPACKE_dsyev_work(LAPACK_COL_MAJOR, 'V', 'U', m, KR, m, ev, work, 64))
        return;
    for (int i = 0; i < m; i++) {
        if (!(ev[i] > 0))
            continue;
        double g = 0, phiP[3] = {0, 0, 0};
        for (int j = 0; j < m; j++) {
            const double *x = w->R + (size_t)j * n;
            double z = KR[i * m + j], xg = 0;
            for (int l = 0; l < n; l++)
                xg += x[l] * G[l];
            g += z * xg;
            for (int c3 = 0; c3 < 3; c3++)
                phiP[c3] += z * x[pd + c3];
        }
        add_mode(c, sqrt(ev[i]), g, phiP);
    }
}

/* Load of a unit acceleration along each direction; the modes each
 * carries (retained, then Ritz) with their modal forces and platform
 * shapes; what stays static of the dropped modes' response. */
static int prepare(dm_move_ws *w, const dm_model *md, const dm_modes *mo, int k,
                   const dm_static *st, const double (*dir)[3], int ndir,
                   const dm_move_opts *o, dm_error *err)
{
    int n = md->n, pd = md->platform_dof;
    const double v0[3] = {0, 0, 0};
    for (int d = 0; d < ndir; d++) {
        carried *c = &w->dir[d];
        double *G = w->G + (size_t)d * n;
        dm_rigid_motion m = {{0, 0, 0}, {0, 0, 0}, {dir[d][0], dir[d][1], dir[d][2]}};
        int rc = dm_kin_accelerations(md->robot, &md->pose, v0, dir[d], m.alpha_ddot, err);
        if (rc)
            return rc;
        memset(G, 0, sizeof(double) * n);
        dm_loads_add_inertial(md, &m, G);
        c->nm = 0;
        for (int j = 0; j < k; j++) {
            const double *ph = mo->phi + (size_t)j * n;
            double g = 0;
            for (int i = 0; i < n; i++)
                g += ph[i] * G[i];
            add_mode(c, mo->omega_rad_s[j], g, ph + pd);
        }
        memset(c->rP, 0, sizeof c->rP);
        if (!o->quasi_static)
            continue;
        /* r = K^-1 G - sum_j phi_j g_j / omega_j^2 */
        memcpy(w->r, G, sizeof(double) * n);
        if ((rc = dm_static_solve(st, w->r, 1, err)))
            return rc;
        for (int j = 0; j < k; j++) {
            const double *ph = mo->phi + (size_t)j * n;
            double f = c->g[j] / (c->om[j] * c->om[j]);
            for (int i = 0; i < n; i++)
                w->r[i] -= f * ph[i];
        }
        for (int c3 = 0; c3 < 3; c3++)
            c->rP[c3] = w->r[pd + c3];
        /* Ritz vectors only where the dropped modes matter: their dynamic
         * response cannot exceed ~4 |rP| (a bang-bang reverses its load),
         * so below 5e-4 of the retained modes' static response they would
         * change nothing beyond 0.2 % (han2011: 1e-5..1e-4) */
        double sr[3] = {0, 0, 0};
        for (int j = 0; j < k; j++) {
            double f = c->g[j] / (c->om[j] * c->om[j]);
            sr[0] += c->px[j] * f, sr[1] += c->py[j] * f, sr[2] += c->pz[j] * f;
        }
        int nritz = dm_norm3(c->rP) > 5e-4 * dm_norm3(sr) ? o->ritz_vectors : 0;
        if (nritz > 0)
            ritz_modes(w, md, mo, k, st, G, nritz < MAXRITZ ? nritz : MAXRITZ, c);
        for (int j = k; j < c->nm; j++) { /* what the Ritz modes carry statically */
            double s = c->g[j] / (c->om[j] * c->om[j]);
            c->rP[0] -= c->px[j] * s;
            c->rP[1] -= c->py[j] * s;
            c->rP[2] -= c->pz[j] * s;
        }
    }
    return DM_OK;
}

/* Exact one-step transition of each carried mode for step h (load
 * constant); returns whether any mode is damped. */
static int transitions(carried *c, double alpha, double beta, double h)
{
    int damped = 0;
    for (int j = 0; j < c->nm; j++) {
        double om = c->om[j], z = alpha / (2 * om) + beta * om / 2;
        double q = 1, v = 0;
        dm_sdof_step(om, z, 0, 0, h, &q, &v);
        c->a11[j] = q, c->a21[j] = v;
        q = 0, v = 1;
        dm_sdof_step(om, z, 0, 0, h, &q, &v);
        c->a12[j] = q, c->a22[j] = v;
        q = 0, v = 0;
        dm_sdof_step(om, z, 1, 1, h, &q, &v);
        c->b1[j] = q, c->b2[j] = v;
        damped |= z > 0;
        c->zw[j] = z * om;
        c->wd[j] = z < 1 ? om * sqrt(1 - z * z) : om;
    }
    return damped;
}

/* |dynamic platform translation + a * rP| */
static double deviation(const carried *c, double a)
{
    const double *restrict px = c->px, *restrict py = c->py, *restrict pz = c->pz;
    const double *restrict q = c->q;
    double y0 = a * c->rP[0], y1 = a * c->rP[1], y2 = a * c->rP[2];
#pragma omp simd reduction(+ : y0, y1, y2)
    for (int j = 0; j < c->nm; j++) {
        y0 += px[j] * q[j];
        y1 += py[j] * q[j];
        y2 += pz[j] * q[j];
    }
    return sqrt(y0 * y0 + y1 * y1 + y2 * y2);
}

static void advance(carried *c, double a)
{
    double *restrict q = c->q, *restrict v = c->v;
    const double *restrict g = c->g, *restrict a11 = c->a11, *restrict a12 = c->a12;
    const double *restrict a21 = c->a21, *restrict a22 = c->a22, *restrict b1 = c->b1;
    const double *restrict b2 = c->b2;
#pragma omp simd
    for (int j = 0; j < c->nm; j++) {
        double f = a * g[j], qj = q[j], vj = v[j];
        q[j] = a11[j] * qj + a12[j] * vj + b1[j] * f;
        v[j] = a21[j] * qj + a22[j] * vj + b2[j] * f;
    }
}

/* After the move (no load) each mode's free response stays below a bound
 * that does not grow with time: underdamped, e^-zw s sqrt(q^2 + ((v + zw
 * q) / wd)^2); overdamped, (|c1| + |c2|) e^(r1 s) with its two decay rates
 * r1 > r2; critical (|q| + 2 |v + w q| / (e w)) e^(-w s / 2). So the
 * deviation stays below sum_j |phiP_j| (bound_j) from now on. */
static double envelope(const carried *c)
{
    double b = 0;
    for (int j = 0; j < c->nm; j++) {
        double om = c->om[j], z = c->zw[j] / om, q = c->q[j], v = c->v[j], amp;
        if (z < 1 - 1e-6) {
            double c2 = (v + c->zw[j] * q) / c->wd[j];
            amp = sqrt(q * q + c2 * c2);
        } else if (z > 1 + 1e-6) {
            double rt = om * sqrt(z * z - 1), r1 = -z * om + rt, r2 = -z * om - rt;
            double c1 = (v - r2 * q) / (r1 - r2);
            amp = fabs(c1) + fabs(q - c1);
        } else {
            amp = fabs(q) + 2 * fabs(v + om * q) / (M_E * om);
        }
        b += c->normP[j] * amp;
    }
    return b;
}

/* The highest frequency a direction carries with a static platform
 * amplitude above 1e-3 of the largest: what the time step must resolve. */
static double top_frequency(const carried *c)
{
    double big = 0, top = 0;
    for (int j = 0; j < c->nm; j++)
        big = fmax(big, c->normP[j] * fabs(c->g[j]) / (c->om[j] * c->om[j]));
    for (int j = 0; j < c->nm; j++)
        if (c->normP[j] * fabs(c->g[j]) / (c->om[j] * c->om[j]) >= 1e-3 * big)
            top = fmax(top, c->om[j] / (2 * M_PI));
    return top;
}

/* One direction's move and ring-down, sampled 200 times per move and 20
 * times per period of the highest mode that matters (at least fk: the
 * highest retained one); after the move 20 times per such period, a whole
 * number of move steps. */
static void one_move(carried *c, double fk, double alpha, double beta, const dm_move_opts *o,
                     dm_move_result *res)
{
    fk = fmax(fk, top_frequency(c));
    double hmax = fmin(o->tau_s / 200, 1.0 / (20 * fk));
    long nhalf = (long)ceil(0.5 * o->tau_s / hmax);
    double h = 0.5 * o->tau_s / nhalf, A = o->amax_ms2, peak = 0;
    long stride = (long)floor(1.0 / (20 * fk) / h);
    if (stride < 1)
        stride = 1;
    int damped = transitions(c, alpha, beta, h);
    memset(c->q, 0, sizeof(double) * c->nm);
    memset(c->v, 0, sizeof(double) * c->nm);
    for (long s = 0; s < 2 * nhalf; s++) {
        double a = s < nhalf ? A : -A;
        peak = fmax(peak, deviation(c, a)); /* right limit at the step start */
        advance(c, a);
        peak = fmax(peak, deviation(c, a)); /* left limit at its end */
    }
    double hw = stride * h;
    if (stride > 1)
        transitions(c, alpha, beta, hw);
    long nwin = (long)ceil(o->window_s / hw);
    double resid = 0, last_above = -1, dev = 0;
    for (long s = 1; s <= nwin; s++) {
        advance(c, 0.0);
        dev = deviation(c, 0.0);
        resid = fmax(resid, dev);
        if (dev > o->tol_m)
            last_above = s * hw;
        /* damped: stop once no later sample can reach the maximum or the
         * band (the margin covers the bound's own round-off) */
        if (damped && (s & 15) == 0 && envelope(c) < 0.999 * fmin(o->tol_m, resid)) {
            dev = 0;
            break;
        }
    }
    res->peak_m = peak;
    res->residual_m = resid;
    if (!damped || dev > o->tol_m)
        res->settling_s = INFINITY;
    else
        res->settling_s = last_above < 0 ? 0.0 : last_above;
}

int dm_standard_moves(dm_move_ws *w, const dm_model *md, const dm_modes *mo, int k,
                      const dm_static *st, const double (*dir)[3], int ndir,
                      const dm_move_opts *o, dm_move_result *res, dm_error *err)
{
    if (k > w->kmax || k > mo->k || ndir < 1 || ndir > MAXDIR)
        return dm_fail(err, DM_EINVAL, "standard move: %d modes, workspace holds %d", k, w->kmax);
    int rc = prepare(w, md, mo, k, st, dir, ndir, o, err);
    if (rc)
        return rc;
    for (int d = 0; d < ndir; d++)
        one_move(&w->dir[d], mo->freq_hz[k - 1], md->robot->rayleigh_alpha,
                 md->robot->rayleigh_beta, o, &res[d]);
    return DM_OK;
}

int dm_standard_move(dm_move_ws *w, const dm_model *md, const dm_modes *mo, int k,
                     const dm_static *st, const double dir[3], const dm_move_opts *o,
                     dm_move_result *res, dm_error *err)
{
    const double one[1][3] = {{dir[0], dir[1], dir[2]}};
    return dm_standard_moves(w, md, mo, k, st, one, 1, o, res, err);
}
