/* Diagnosis of model-vs-measurement discrepancies (see dm_diagnose.h). */
#include "dm_diagnose.h"

#include <cminpack.h>
#include <lapacke.h>
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define K_MODAL (1u << DM_DATA_MODAL)
#define K_STATIC (1u << DM_DATA_STATIC)
#define K_TRACK (1u << DM_DATA_TRACKER)

/* Ranges: springs from very soft to far stiffer than the structure. Masses
 * seen by statics cannot be: a deflection survey is relative to the same
 * pose without the force. */
#define ALL (K_MODAL | K_STATIC | K_TRACK)
static const dm_candidate CANDIDATES[] = {
    {"actuator_stiffness", "N*m/rad", 2.0, 8.0, ALL, 1, 0},
    {"joint_stiffness", "N/m", 4.0, 10.0, ALL, 1, 0},
    {"base_stiffness", "N/m", 4.0, 10.0, ALL, 1, 0},
    {"base_stiffness_0", "N/m", 4.0, 10.0, ALL, 1, 0},
    {"base_stiffness_1", "N/m", 4.0, 10.0, ALL, 1, 0},
    {"base_stiffness_2", "N/m", 4.0, 10.0, ALL, 1, 0},
    {"payload_mass", "kg", -2.0, 1.5, K_MODAL | K_TRACK, 1, 0},
    {"elbow_mass", "kg", -2.0, 1.0, K_MODAL | K_TRACK, 1, 0},
    {"geometric_stiffness", "", 0, 0, ALL, 0, 0},
    /* joint clearance: jumps when a force flips a rod's load */
    {"clearance", "m", -7.0, -3.0, K_STATIC | K_TRACK, 1, 0},
    /* axial play of the actuator joints; their radial play shifts each arm
     * along the rods' pull, which to first order is rod-end clearance of
     * half its size: `clearance` stands for both */
    {"actuator_clearance_axial", "m", -7.0, -3.0, K_STATIC | K_TRACK, 1, 0},
    /* geometry errors move the platform: only a tracker sees them */
    {"error_arm_length", "m", 0, 1, K_TRACK, 3, 1},
    {"error_rod_length", "m", 0, 1, K_TRACK, 3, 1},
    {"error_base_radius", "m", 0, 1, K_TRACK, 3, 1},
    {"error_platform_radius", "m", 0, 1, K_TRACK, 3, 1},
    {"error_theta_deg", "deg", 0, 1, K_TRACK, 3, 1},
    {"error_alpha0_deg", "deg", 0, 1, K_TRACK, 3, 1},
    /* Rayleigh C = alpha M + beta K: the decay of the vibration a tracker
     * sees. Two candidates, so that each fit is one-dimensional and a pair
     * finds both; the ranges span modal damping ratios 1e-4 to 1 at the
     * presets' first modes (50-200 Hz). */
    {"damping_alpha", "1/s", -1.0, 3.0, K_TRACK, 1, 0},
    {"damping_beta", "s", -6.0, -2.0, K_TRACK, 1, 0},
};
#define NCAND ((int)(sizeof CANDIDATES / sizeof CANDIDATES[0]))
_Static_assert(NCAND <= DM_DIAG_MAXCAND, "dm_diagnosis.rank holds every candidate");

const dm_candidate *dm_candidates(int *count)
{
    *count = NCAND;
    return CANDIDATES;
}

const dm_candidate *dm_candidate_find(const char *name)
{
    for (int i = 0; i < NCAND; i++)
        if (!strcmp(CANDIDATES[i].name, name))
            return &CANDIDATES[i];
    return NULL;
}


int dm_effect_apply(dm_robot *rb, const char *name, const double *v, dm_error *err)
{
    char set[256];
    const dm_candidate *c = dm_candidate_find(name);
    if (!strcmp(name, "geometric_stiffness"))
        snprintf(set, sizeof set, "effects.geometric_stiffness=on");
    else if (!strncmp(name, "damping_", 8))
        snprintf(set, sizeof set, "damping.%s=%.17g", name + 8, v[0]);
    else if (!strncmp(name, "base_stiffness", 14))
        snprintf(set, sizeof set, "effects.%s=%.17g,%.17g,%.17g", name, v[0], v[0], v[0]);
    else if (c && c->nparam == 3)
        snprintf(set, sizeof set, "effects.%s=%.17g,%.17g,%.17g", name, v[0], v[1], v[2]);
    else
        snprintf(set, sizeof set, "effects.%s=%.17g", name, v[0]);
    return dm_robot_set(rb, set, err);
}

int dm_fit_apply(const dm_robot *rb, const dm_fit *f, dm_robot *out, dm_error *err)
{
    *out = *rb;
    for (int i = 0; i < f->ncand; i++) {
        int rc = dm_effect_apply(out, f->cand[i]->name, f->value[i], err);
        if (rc)
            return rc;
    }
    return DM_OK;
}

/* ---- evaluation ---------------------------------------------------------------- */

/* What every fit reads and no fit writes: shared by the worker threads. */
typedef struct {
    const dm_robot *rb;
    const dm_dataset *d;
    const dm_diagnose_opts *o;
    const char *held;        /* per sample: 1 = held out */
    const double *w;         /* weights 1/sigma */
    double train_end_s;      /* tracker: time of the last training sample */
    int *nomem;              /* set when a fit ran out of memory (the result is void) */
} shared;

/* A fit that fails for want of memory must not pass for one that does
 * not fit: the diagnosis is then an out-of-memory error. */
static void out_of_memory(const shared *s)
{
#pragma omp atomic write
    *s->nomem = 1;
}

/* One fit: its effects, the leading `nfixed` of them held at `fixed`, and
 * its own prediction buffer. */
typedef struct {
    const shared *s;
    dm_dataset view;         /* the data fitted: all, or a tracker run's first part */
    double *pred;
    int ncand, nfixed;
    const dm_candidate *cand[2];
    double fixed[2][3];
} problem;

static void split_samples(const dm_dataset *d, char *held)
{
    double T = d->kind == DM_DATA_TRACKER ? d->s[d->n - 1].t : 0;
    for (int i = 0; i < d->n; i++)
        held[i] = d->kind == DM_DATA_TRACKER ? d->s[i].t > 2.0 * T / 3.0 : d->s[i].pose_id % 3 == 2;
}

/* Predictions with the given effect values (physical units). */
static int predict_with(problem *p, double value[2][3], dm_error *err)
{
    dm_robot rb = *p->s->rb;
    int rc = DM_OK;
    for (int i = 0; i < p->ncand && !rc; i++)
        rc = dm_effect_apply(&rb, p->cand[i]->name, value[i], err);
    if (!rc)
        rc = dm_predict(&rb, &p->view, p->s->o->na, p->s->o->nb, p->pred, err);
    return rc;
}

static double chi2(const shared *s, const double *pred, int want_held)
{
    double sum = 0;
    for (int i = 0; i < s->d->n; i++)
        if (s->held[i] == want_held) {
            double r = (s->d->s[i].value - pred[i]) * s->w[i];
            sum += r * r;
        }
    return sum;
}

/* log10 parameters stay within two decades of their search range: beyond
 * it the data cannot see them and the search would only wander. */
static double from_log(const dm_candidate *c, double x)
{
    return pow(10.0, fmin(c->hi + 2, fmax(c->lo - 2, x)));
}

/* Free parameters x (log10, or as they are for linear candidates) to the
 * values of all effects. */
static void to_values(const problem *p, const double *x, double value[2][3])
{
    for (int i = 0, j = 0; i < p->ncand; i++) {
        const dm_candidate *c = p->cand[i];
        for (int k = 0; k < 3; k++)
            value[i][k] = i < p->nfixed   ? p->fixed[i][k]
                          : k >= c->nparam ? 1.0
                          : c->linear      ? x[j++]
                                           : from_log(c, x[j++]);
    }
}

/* cminpack callback */
static int residuals(void *user, int m, int n, const double *x, double *fvec, int iflag)
{
    (void)iflag;
    (void)n;
    problem *p = user;
    const shared *s = p->s;
    double value[2][3];
    to_values(p, x, value);
    int rc = predict_with(p, value, NULL);
    if (rc == DM_ENOMEM)
        out_of_memory(s);
    if (rc) {
        for (int i = 0; i < m; i++)
            fvec[i] = 1e3; /* unphysical region: steer the search away */
        return 0;
    }
    for (int i = 0, k = 0; i < p->view.n; i++)
        if (!s->held[i])
            fvec[k++] = (s->d->s[i].value - p->pred[i]) * s->w[i];
    return 0;
}

static double sum_squares(const double *f, int m)
{
    double q = 0;
    for (int i = 0; i < m; i++)
        q += f[i] * f[i];
    return q;
}

/* Coarse scan of the log10 values of a free parameter: a start for LM
 * that is not trapped where the data cannot see it (a spring far too
 * stiff, damping far too light). */
static void scan_start(problem *p, double *x, const dm_candidate *c, int m, double *fvec,
                       int steps)
{
    double best = INFINITY, bx = 0.5 * (c->lo + c->hi);
    for (int s = 0; s <= steps; s++) {
        x[0] = c->lo + (c->hi - c->lo) * s / steps;
        residuals(p, m, 1, x, fvec, 1);
        double q = sum_squares(fvec, m);
        if (q < best) {
            best = q;
            bx = x[0];
        }
    }
    x[0] = bx;
}

/* Forward-difference Jacobian J (m x n, column-major) of the residuals at
 * x, whose residuals are f0. */
static void jacobian(problem *p, const double *x, int n, int m, const double *f0, double *f1,
                     double *J)
{
    double xx[DM_DIAG_MAXP];
    memcpy(xx, x, sizeof(double) * n);
    for (int j = 0; j < n; j++) {
        double h = 1e-4 * fmax(1e-3, fabs(x[j]));
        xx[j] = x[j] + h;
        residuals(p, m, n, xx, f1, 1);
        xx[j] = x[j];
        for (int i = 0; i < m; i++)
            J[(size_t)j * m + i] = (f1[i] - f0[i]) / h;
    }
}

/* A = J'J (n x n) */
static void normal_matrix(const double *J, int m, int n, double *A)
{
    for (int a = 0; a < n; a++)
        for (int b = 0; b < n; b++) {
            double v = 0;
            for (int i = 0; i < m; i++)
                v += J[(size_t)a * m + i] * J[(size_t)b * m + i];
            A[b * n + a] = v;
        }
}

/* Scale of the covariance: the reduced chi-square when above 1 (the model
 * misfits beyond the noise), else 1. */
static double misfit_scale(double c2, int m, int n)
{
    return fmax(1.0, c2 / (m > n ? m - n : 1));
}

/* Levenberg-Marquardt (cminpack lmdif) from x; uncertainties from the
 * R factor of its last Jacobian (covar), so they cost no predictions.
 * Tolerances 1e-6 on log10 values are far below any uncertainty; the
 * evaluation cap stops a search on a plateau the data cannot see. */
static void lm_fit(problem *p, double *x, int n, int m, double *sig)
{
    double *fvec = malloc(sizeof(double) * m), *fjac = malloc(sizeof(double) * m * n);
    double *wa4 = malloc(sizeof(double) * m);
    double diag[DM_DIAG_MAXP], qtf[DM_DIAG_MAXP], wa1[DM_DIAG_MAXP], wa2[DM_DIAG_MAXP],
        wa3[DM_DIAG_MAXP];
    int ipvt[DM_DIAG_MAXP], nfev = 0;
    for (int j = 0; j < n; j++)
        sig[j] = INFINITY;
    if (!fvec || !fjac || !wa4)
        out_of_memory(p->s);
    else {
        int info = lmdif(residuals, p, m, n, x, fvec, 1e-6, 1e-6, 0.0, 25 * (n + 1), 0.0, diag,
                         1, 100.0, 0, &nfev, fjac, m, ipvt, qtf, wa1, wa2, wa3, wa4);
        if (info > 0) {
            double scale = misfit_scale(sum_squares(fvec, m), m, n);
            covar(n, fjac, m, ipvt, 1e-12, wa1);
            for (int j = 0; j < n; j++) {
                double c = fjac[(size_t)j * m + j];
                sig[j] = c > 0 ? sqrt(scale * c) : INFINITY; /* 0: not determined */
            }
        }
    }
    free(fvec);
    free(fjac);
    free(wa4);
}

/* Geometry errors move the data almost linearly: one Jacobian, then
 * Gauss-Newton steps with it (chord method) until the step is below a
 * thousandth of the uncertainty: about 7 predictions where LM takes 30. */
static void chord_fit(problem *p, double *x, int n, int m, double *sig)
{
    double *f = malloc(sizeof(double) * m), *f1 = malloc(sizeof(double) * m);
    double *J = calloc((size_t)m * n, sizeof(double)), A[DM_DIAG_MAXP * DM_DIAG_MAXP];
    for (int j = 0; j < n; j++)
        sig[j] = INFINITY;
    if (!f || !f1 || !J) {
        free(f), free(f1), free(J);
        out_of_memory(p->s);
        return;
    }
    residuals(p, m, n, x, f, 1);
    jacobian(p, x, n, m, f, f1, J);
    normal_matrix(J, m, n, A);
    double inv_sigma[DM_DIAG_MAXP]; /* rough: sqrt of J'J's diagonal */
    for (int j = 0; j < n; j++)
        inv_sigma[j] = sqrt(A[j * n + j]);
    int ok = !LAPACKE_dpotrf(LAPACK_COL_MAJOR, 'U', n, A, n);
    double best = sum_squares(f, m);
    for (int it = 0; ok && it < 8; it++) {
        double g[DM_DIAG_MAXP], xn[DM_DIAG_MAXP], big = 0;
        for (int j = 0; j < n; j++) { /* g = -J'f, then (J'J) dx = g */
            g[j] = 0;
            for (int i = 0; i < m; i++)
                g[j] -= J[(size_t)j * m + i] * f[i];
        }
        LAPACKE_dpotrs(LAPACK_COL_MAJOR, 'U', n, 1, A, n, g, n);
        for (int j = 0; j < n; j++) {
            xn[j] = x[j] + g[j];
            big = fmax(big, fabs(g[j]) * inv_sigma[j]); /* step / sigma */
        }
        residuals(p, m, n, xn, f1, 1);
        double q = sum_squares(f1, m);
        if (!(q <= best)) /* no better: the chord has done what it can */
            break;
        best = q;
        memcpy(x, xn, sizeof(double) * n);
        memcpy(f, f1, sizeof(double) * m);
        if (big < 1e-3)
            break;
    }
    /* 1-sigma uncertainties: cov = scale (J'J)^-1, from the factor in A */
    if (ok && !LAPACKE_dpotri(LAPACK_COL_MAJOR, 'U', n, A, n))
        for (int j = 0; j < n; j++)
            sig[j] = A[j * n + j] > 0 ? sqrt(misfit_scale(best, m, n) * A[j * n + j]) : INFINITY;
    free(f);
    free(f1);
    free(J);
}

/* Held-out misfit on the scale of a log-likelihood: the chi-square when
 * sigma is known; otherwise N ln(chi2/N), the Gaussian likelihood with the
 * variance profiled out (chi2 is then in units of the baseline's RMS). */
static double held_score(const dm_diagnosis *dg, double held_chi2)
{
    double n = dg->n_held;
    return dg->sigma_known ? held_chi2 : n * log(fmax(held_chi2, 1e-300) / n);
}

static void score_fit(const problem *p, const dm_diagnosis *dg, dm_fit *f, int nparam)
{
    const shared *s = p->s;
    f->held_chi2 = chi2(s, p->pred, 1);
    f->train_chi2 = chi2(s, p->pred, 0);
    double ms = 0;
    for (int i = 0; i < s->d->n; i++)
        if (s->held[i]) {
            double r = s->d->s[i].value - p->pred[i];
            ms += r * r;
        }
    f->held_rms = sqrt(ms / dg->n_held);
    double excess = dg->sigma_known ? dg->base_held_chi2 - dg->n_held : dg->base_held_chi2;
    double drop = dg->base_held_chi2 - f->held_chi2;
    f->gain_percent = excess > 0 ? 100.0 * drop / excess : 0.0;
    f->score = held_score(dg, f->held_chi2) + nparam * log((double)dg->n_held);
}

static int count_train(const problem *p)
{
    int m = 0;
    for (int i = 0; i < p->view.n; i++)
        m += !p->s->held[i];
    return m;
}

/* The data up to `share` of the training time (tracker samples are in
 * time order, three components per time), or all of it (share 1). */
static void set_window(problem *p, double share)
{
    const dm_dataset *d = p->s->d;
    p->view = *d;
    if (share >= 1)
        return;
    int n = 0;
    while (n < d->n && d->s[n].t <= share * p->s->train_end_s)
        n++;
    p->view.n = n;
    p->view.npose = n / 3;
}

/* A ringing response is a phase-wrapped function of a stiffness or a
 * mass: over a whole tracker run the misfit has wells narrower than any
 * affordable scan. Fitted first on the run's first quarter (where the
 * phase has had no time to wrap), then on half, then on all of it, each
 * stage starts in the right well, and the short stages are cheap. */
static const double WINDOWS[] = {0.25, 0.5, 1.0};
#define NWINDOWS (int)(sizeof WINDOWS / sizeof WINDOWS[0])

/* Fit the free effects of p (those after the first nfixed): a coarse scan
 * for a lone log parameter, then Levenberg-Marquardt (tracker data: on
 * growing windows), or the chord method for geometry errors. start:
 * values of the free effects to start from (NULL: scan / defaults). Every
 * fit owns its buffers, so fits run in parallel. */
static void fit(problem *p, const dm_diagnosis *dg, double start[2][3], dm_fit *f)
{
    int n = 0, ntotal = 0, linear = 1;
    double x[DM_DIAG_MAXP], value[2][3] = {{0}}, sig[DM_DIAG_MAXP] = {0};
    for (int i = 0; i < p->ncand; i++) {
        const dm_candidate *c = p->cand[i];
        ntotal += c->nparam;
        linear &= i < p->nfixed || c->linear;
        for (int k = 0; i >= p->nfixed && k < c->nparam; k++)
            x[n++] = start    ? (c->linear ? start[i][k] : log10(start[i][k]))
                     : c->linear ? 0.0
                                 : 0.5 * (c->lo + c->hi);
    }
    memset(f, 0, sizeof *f);
    f->ncand = p->ncand;
    memcpy(f->cand, p->cand, sizeof f->cand);
    set_window(p, 1.0);
    double *fvec = malloc(sizeof(double) * count_train(p));
    p->pred = malloc(sizeof(double) * p->s->d->n);
    if (!fvec || !p->pred) {
        f->held_chi2 = f->score = INFINITY;
        free(fvec), free(p->pred);
        out_of_memory(p->s);
        return;
    }
    const dm_candidate *lone = n == 1 && !linear && !start ? p->cand[p->ncand - 1] : NULL;
    int staged = p->s->d->kind == DM_DATA_TRACKER && !linear && !start && n > 0;
    for (int w = staged ? 0 : NWINDOWS - 1; w < NWINDOWS && n > 0; w++) {
        set_window(p, WINDOWS[w]);
        int m = count_train(p);
        if (lone && w == (staged ? 0 : NWINDOWS - 1)) /* a short window affords a finer scan */
            scan_start(p, x, lone, m, fvec, staged ? 24 : 12);
        if (linear)
            chord_fit(p, x, n, m, sig);
        else
            lm_fit(p, x, n, m, sig);
    }
    set_window(p, 1.0);
    to_values(p, x, value);
    for (int i = p->nfixed, j = 0; i < p->ncand; i++)
        for (int k = 0; k < p->cand[i]->nparam; k++, j++)
            f->sigma[i][k] = p->cand[i]->linear ? sig[j] : value[i][k] * log(10.0) * sig[j];
    memcpy(f->value, value, sizeof value);
    int rc = predict_with(p, value, NULL);
    if (rc == DM_ENOMEM)
        out_of_memory(p->s);
    f->ok = rc == DM_OK;
    if (f->ok)
        score_fit(p, dg, f, ntotal);
    else
        f->held_chi2 = f->score = INFINITY;
    free(fvec);
    free(p->pred);
    p->pred = NULL;
}

/* Best score first; equal scores in candidate-table order, so the ranking
 * does not depend on the thread count. */
static int by_score(const void *a, const void *b)
{
    const dm_fit *x = a, *y = b;
    if (x->score != y->score)
        return (x->score > y->score) - (x->score < y->score);
    for (int i = 0; i < 2; i++) {
        const dm_candidate *cx = i < x->ncand ? x->cand[i] : NULL;
        const dm_candidate *cy = i < y->ncand ? y->cand[i] : NULL;
        if (cx != cy)
            return (cx > cy) - (cx < cy);
    }
    return 0;
}

static int thread_count(const dm_diagnose_opts *o)
{
    return o->threads > 0 ? o->threads : omp_get_max_threads();
}

/* Single effects: every candidate the data can see, fitted on its own. */
static void rank_singles(const shared *s, dm_diagnosis *dg)
{
    int idx[NCAND], nc = 0;
    for (int c = 0; c < NCAND; c++)
        if (CANDIDATES[c].kinds & (1u << s->d->kind))
            idx[nc++] = c;
#pragma omp parallel for schedule(dynamic, 1) num_threads(thread_count(s->o))
    for (int j = 0; j < nc; j++) {
        problem p = {.s = s, .ncand = 1, .cand = {&CANDIDATES[idx[j]], NULL}};
        fit(&p, dg, NULL, &dg->rank[j]);
    }
    dg->nrank = nc;
    qsort(dg->rank, nc, sizeof dg->rank[0], by_score);
}

/* Forward selection of a second effect: every other candidate is fitted on
 * top of the best one held fixed (a screen as cheap as a single fit); the
 * two best screened are refitted jointly, and a pair replaces the single
 * effect when it lowers the score by more than `need`. */
#define PAIR_REFITS 2
static void add_second_effect(const shared *s, dm_diagnosis *dg, double need)
{
    dm_fit screen[DM_DIAG_MAXCAND], joint[PAIR_REFITS];
    const dm_fit *one = &dg->rank[0];
    int ns = 0, idx[DM_DIAG_MAXCAND];
    for (int r = 1; r < dg->nrank; r++)
        if (dg->rank[r].ok && one->cand[0]->nparam + dg->rank[r].cand[0]->nparam <= DM_DIAG_MAXP)
            idx[ns++] = r;
#pragma omp parallel for schedule(dynamic, 1) num_threads(thread_count(s->o))
    for (int j = 0; j < ns; j++) {
        problem p = {.s = s, .ncand = 2, .nfixed = 1, .cand = {one->cand[0], dg->rank[idx[j]].cand[0]}};
        memcpy(p.fixed[0], one->value[0], sizeof p.fixed[0]);
        fit(&p, dg, NULL, &screen[j]);
    }
    qsort(screen, ns, sizeof screen[0], by_score);
    int nj = ns < PAIR_REFITS ? ns : PAIR_REFITS;
#pragma omp parallel for schedule(dynamic, 1) num_threads(thread_count(s->o))
    for (int j = 0; j < nj; j++) {
        problem p = {.s = s, .ncand = 2, .cand = {screen[j].cand[0], screen[j].cand[1]}};
        fit(&p, dg, screen[j].value, &joint[j]);
    }
    for (int j = 0; j < nj; j++)
        if (joint[j].ok && joint[j].score < dg->best.score - (dg->best.ncand == 1 ? need : 0))
            dg->best = joint[j];
}

/* Candidates whose single-effect score is within DM_DIAG_TIE of the best:
 * the data cannot tell them apart. */
static void find_ties(dm_diagnosis *dg)
{
    dg->ntie = 0;
    for (int r = 1; r < dg->nrank && dg->ntie < DM_DIAG_MAXCAND; r++)
        if (dg->rank[r].ok && dg->rank[r].score - dg->rank[0].score < DM_DIAG_TIE)
            dg->tie[dg->ntie++] = r;
}

int dm_diagnose(const dm_robot *rb, const dm_dataset *d, const dm_diagnose_opts *o,
                dm_diagnosis *dg, dm_error *err)
{
    memset(dg, 0, sizeof *dg);
    char *held = malloc(d->n);
    double *pred = malloc(sizeof(double) * d->n), *w = malloc(sizeof(double) * d->n);
    if (!held || !pred || !w) {
        free(held), free(pred), free(w);
        return dm_fail(err, DM_ENOMEM, "out of memory");
    }
    int nomem = 0;
    shared s = {.rb = rb, .d = d, .o = o, .held = held, .w = w, .nomem = &nomem};
    split_samples(d, held);
    dg->sigma_known = 1;
    for (int i = 0; i < d->n; i++) {
        dg->n_held += held[i];
        dg->sigma_known &= d->s[i].sigma > 0;
        if (!held[i])
            s.train_end_s = fmax(s.train_end_s, d->s[i].t);
    }
    dg->n_train = d->n - dg->n_held;
    int rc = (dg->n_held < 3 || dg->n_train < 3)
                 ? dm_fail(err, DM_EINVAL, "%s: too little data to hold a third out", d->source)
                 : dm_predict(rb, d, o->na, o->nb, pred, err);
    if (!rc) {
        double ms = 0, hs = 0; /* without sigma: unit weights scaled by the baseline RMS */
        for (int i = 0; i < d->n; i++) {
            double r2 = (d->s[i].value - pred[i]) * (d->s[i].value - pred[i]);
            ms += r2;
            hs += held[i] ? r2 : 0;
        }
        for (int i = 0; i < d->n; i++)
            w[i] = dg->sigma_known ? 1.0 / d->s[i].sigma : 1.0 / sqrt(ms / d->n + 1e-300);
        dg->base_train_chi2 = chi2(&s, pred, 0);
        dg->base_held_chi2 = chi2(&s, pred, 1);
        dg->base_held_rms = sqrt(hs / dg->n_held);
        dg->significant = dg->sigma_known
                              ? dg->base_held_chi2 > dg->n_held + 4 * sqrt(2.0 * dg->n_held)
                              : 1;
        rank_singles(&s, dg);
        dg->best = dg->rank[0];
        double need = 9 + log((double)dg->n_held);
        dg->base_score = held_score(dg, dg->base_held_chi2); /* no parameters */
        dg->found = dg->significant && dg->best.ok && dg->base_score - dg->best.score > need;
        if (dg->found) {
            find_ties(dg);
            if (o->pairs)
                add_second_effect(&s, dg, need);
        }
        if (nomem)
            rc = dm_fail(err, DM_ENOMEM, "%s: out of memory while fitting the effects",
                         d->source);
    }
    free(held);
    free(pred);
    free(w);
    return rc;
}
