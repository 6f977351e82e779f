/* Diagnosis of model-vs-measurement discrepancies (see dm_diagnose.h). */
#include "dm_diagnose.h"

#include <cminpack.h>
#include <lapacke.h>
#include <math.h>
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
    /* geometry errors move the platform: only a tracker sees them */
    {"error_arm_length", "m", 0, 1, K_TRACK, 3, 1},
    {"error_rod_length", "m", 0, 1, K_TRACK, 3, 1},
    {"error_base_radius", "m", 0, 1, K_TRACK, 3, 1},
    {"error_platform_radius", "m", 0, 1, K_TRACK, 3, 1},
    {"error_theta_deg", "deg", 0, 1, K_TRACK, 3, 1},
    {"error_alpha0_deg", "deg", 0, 1, K_TRACK, 3, 1},
    /* Rayleigh alpha (1/s), beta (s): decay of the vibration a tracker sees */
    {"damping", "1/s, s", -6.0, -2.0, K_TRACK, 2, 0},
};
#define NCAND ((int)(sizeof CANDIDATES / sizeof CANDIDATES[0]))

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
    if (!c)
        return dm_fail(err, DM_EINVAL, "'%s' is not a candidate effect", name);
    if (!strcmp(name, "geometric_stiffness"))
        snprintf(set, sizeof set, "effects.geometric_stiffness=on");
    else if (!strcmp(name, "damping")) {
        snprintf(set, sizeof set, "damping.alpha=%.17g", v[0]);
        int rc = dm_robot_set(rb, set, err);
        if (rc)
            return rc;
        snprintf(set, sizeof set, "damping.beta=%.17g", v[1]);
    } else if (!strncmp(name, "base_stiffness", 14))
        snprintf(set, sizeof set, "effects.%s=%.17g,%.17g,%.17g", name, v[0], v[0], v[0]);
    else if (c->nparam == 3)
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

typedef struct {
    const dm_robot *rb;
    const dm_dataset *d;
    const dm_diagnose_opts *o;
    const char *held;        /* per sample: 1 = held out */
    double *pred, *w;        /* predictions; weights 1/sigma */
    int ncand;
    const dm_candidate *cand[2];
    int failed;
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
    dm_robot rb = *p->rb;
    int rc = DM_OK;
    for (int i = 0; i < p->ncand && !rc; i++)
        rc = dm_effect_apply(&rb, p->cand[i]->name, value[i], err);
    if (!rc)
        rc = dm_predict(&rb, p->d, p->o->na, p->o->nb, p->pred, err);
    return rc;
}

static double chi2(const problem *p, int want_held)
{
    double s = 0;
    for (int i = 0; i < p->d->n; i++)
        if (p->held[i] == want_held) {
            double r = (p->d->s[i].value - p->pred[i]) * p->w[i];
            s += r * r;
        }
    return s;
}

/* Parameters x (log10, or as they are for linear candidates) to values.
 * log10 parameters stay within two decades of their search range: beyond
 * it the data cannot see them and the search would only wander. */
static void to_values(const problem *p, const double *x, double value[2][3])
{
    for (int i = 0, j = 0; i < p->ncand; i++) {
        const dm_candidate *c = p->cand[i];
        double lo = c->lo - 2, hi = c->hi + 2;
        if (c->nparam == 2) /* damping: alpha and beta share one wide band */
            lo = -8, hi = 3;
        for (int k = 0; k < 3; k++)
            value[i][k] = k >= c->nparam ? 1.0
                          : c->linear    ? x[j++]
                                         : pow(10.0, fmin(hi, fmax(lo, x[j++])));
    }
}

/* cminpack callback */
static int residuals(void *user, int m, int n, const double *x, double *fvec, int iflag)
{
    (void)iflag;
    (void)n;
    problem *p = user;
    double value[2][3];
    to_values(p, x, value);
    if (predict_with(p, value, NULL)) {
        p->failed = 1;
        for (int i = 0; i < m; i++)
            fvec[i] = 1e3; /* unphysical region: steer the search away */
        return 0;
    }
    for (int i = 0, k = 0; i < p->d->n; i++)
        if (!p->held[i])
            fvec[k++] = (p->d->s[i].value - p->pred[i]) * p->w[i];
    return 0;
}

static int count_train(const problem *p)
{
    int m = 0;
    for (int i = 0; i < p->d->n; i++)
        m += !p->held[i];
    return m;
}

/* Coarse scan of log10 values of one parameter: a start for LM that is
 * not trapped where the data cannot see the parameter (a spring far too
 * stiff). */
static double scan_start(problem *p, double *x, int j, const dm_candidate *c, int m, double *fvec)
{
    double best = INFINITY, bx = 0.5 * (c->lo + c->hi);
    for (int s = 0; s <= 12; s++) {
        x[j] = c->lo + (c->hi - c->lo) * s / 12.0;
        residuals(p, m, 1, x, fvec, 1);
        double q = 0;
        for (int i = 0; i < m; i++)
            q += fvec[i] * fvec[i];
        if (q < best) {
            best = q;
            bx = x[j];
        }
    }
    x[j] = bx;
    return best;
}

/* Parameter uncertainties from the Jacobian at the optimum (forward
 * differences), scaled by the reduced chi-square when above 1:
 * cov = s (J'J)^-1. */
static void uncertainties(problem *p, const double *x, int n, int m, double *sig)
{
    double *f0 = malloc(sizeof(double) * m), *f1 = malloc(sizeof(double) * m);
    double *J = malloc(sizeof(double) * m * n), xx[DM_DIAG_MAXP], A[DM_DIAG_MAXP * DM_DIAG_MAXP];
    memcpy(xx, x, sizeof(double) * n);
    residuals(p, m, n, xx, f0, 1);
    double c2 = 0;
    for (int i = 0; i < m; i++)
        c2 += f0[i] * f0[i];
    for (int j = 0; j < n; j++) {
        double h = 1e-4 * fmax(1e-3, fabs(x[j]));
        xx[j] = x[j] + h;
        residuals(p, m, n, xx, f1, 1);
        xx[j] = x[j];
        for (int i = 0; i < m; i++)
            J[(size_t)j * m + i] = (f1[i] - f0[i]) / h;
    }
    for (int a = 0; a < n; a++)
        for (int b = 0; b < n; b++) {
            double v = 0;
            for (int i = 0; i < m; i++)
                v += J[(size_t)a * m + i] * J[(size_t)b * m + i];
            A[b * n + a] = v;
        }
    double scale = fmax(1.0, c2 / (m > n ? m - n : 1));
    int ok = !LAPACKE_dpotrf(LAPACK_COL_MAJOR, 'U', n, A, n) &&
             !LAPACKE_dpotri(LAPACK_COL_MAJOR, 'U', n, A, n);
    for (int j = 0; j < n; j++)
        sig[j] = ok && A[j * n + j] > 0 ? sqrt(scale * A[j * n + j]) : INFINITY;
    free(f0);
    free(f1);
    free(J);
}

static void score_fit(problem *p, const dm_diagnosis *dg, dm_fit *f, int nparam)
{
    f->held_chi2 = chi2(p, 1);
    f->train_chi2 = chi2(p, 0);
    double ms = 0;
    for (int i = 0; i < p->d->n; i++)
        if (p->held[i]) {
            double r = p->d->s[i].value - p->pred[i];
            ms += r * r;
        }
    f->held_rms = sqrt(ms / dg->n_held);
    double excess = dg->sigma_known ? dg->base_held_chi2 - dg->n_held : dg->base_held_chi2;
    double drop = dg->base_held_chi2 - f->held_chi2;
    f->gain_percent = excess > 0 ? 100.0 * drop / excess : 0.0;
    f->score = f->held_chi2 + nparam * log((double)dg->n_held);
}

/* Fit one or two effects: a coarse scan for one log parameter, then
 * Levenberg-Marquardt. start: values to start from (NULL: scan / defaults). */
static void fit(problem *p, const dm_diagnosis *dg, double start[2][3], dm_fit *f)
{
    int m = count_train(p), n = 0;
    double x[DM_DIAG_MAXP], value[2][3];
    for (int i = 0; i < p->ncand; i++)
        for (int k = 0; k < p->cand[i]->nparam; k++)
            x[n++] = start ? (p->cand[i]->linear ? start[i][k] : log10(start[i][k]))
                     : p->cand[i]->linear ? 0.0
                     : p->cand[i]->nparam == 2 ? (k ? -4.0 : -1.0) /* damping: beta 1e-4 */
                                               : 0.5 * (p->cand[i]->lo + p->cand[i]->hi);
    double *fvec = malloc(sizeof(double) * m);
    int *iwa = malloc(sizeof(int) * DM_DIAG_MAXP);
    int lwa = m * DM_DIAG_MAXP + 5 * DM_DIAG_MAXP + m;
    double *wa = malloc(sizeof(double) * lwa);
    memset(f, 0, sizeof *f);
    f->ncand = p->ncand;
    memcpy(f->cand, p->cand, sizeof f->cand);
    p->failed = 0;
    if (n == 1 && !start && !p->cand[0]->linear)
        scan_start(p, x, 0, p->cand[0], m, fvec);
    if (n > 0)
        lmdif1(residuals, p, m, n, x, fvec, 1e-8, iwa, wa, lwa);
    double sig[DM_DIAG_MAXP] = {0};
    if (n > 0)
        uncertainties(p, x, n, m, sig);
    to_values(p, x, value);
    for (int i = 0, j = 0; i < p->ncand; i++)
        for (int k = 0; k < p->cand[i]->nparam; k++, j++)
            f->sigma[i][k] = p->cand[i]->linear ? sig[j] : value[i][k] * log(10.0) * sig[j];
    memcpy(f->value, value, sizeof value);
    f->ok = predict_with(p, value, NULL) == DM_OK;
    if (f->ok)
        score_fit(p, dg, f, n);
    else
        f->held_chi2 = f->score = INFINITY;
    free(fvec);
    free(iwa);
    free(wa);
}

static int by_score(const void *a, const void *b)
{
    const dm_fit *x = a, *y = b;
    return (x->score > y->score) - (x->score < y->score);
}

int dm_diagnose(const dm_robot *rb, const dm_dataset *d, const dm_diagnose_opts *o,
                dm_diagnosis *dg, dm_error *err)
{
    memset(dg, 0, sizeof *dg);
    problem p = {.rb = rb, .d = d, .o = o};
    char *held = malloc(d->n);
    p.pred = malloc(sizeof(double) * d->n);
    p.w = malloc(sizeof(double) * d->n);
    if (!held || !p.pred || !p.w) {
        free(held), free(p.pred), free(p.w);
        return dm_fail(err, DM_ENOMEM, "out of memory");
    }
    split_samples(d, held);
    p.held = held;
    dg->sigma_known = 1;
    for (int i = 0; i < d->n; i++) {
        dg->n_held += held[i];
        dg->sigma_known &= d->s[i].sigma > 0;
    }
    dg->n_train = d->n - dg->n_held;
    int rc = (dg->n_held < 3 || dg->n_train < 3)
                 ? dm_fail(err, DM_EINVAL, "%s: too little data to hold a third out", d->source)
                 : dm_predict(rb, d, o->na, o->nb, p.pred, err);
    if (!rc) {
        double ms = 0; /* without sigma: unit weights scaled by the baseline RMS */
        for (int i = 0; i < d->n; i++)
            ms += (d->s[i].value - p.pred[i]) * (d->s[i].value - p.pred[i]);
        for (int i = 0; i < d->n; i++)
            p.w[i] = dg->sigma_known ? 1.0 / d->s[i].sigma : 1.0 / sqrt(ms / d->n + 1e-300);
        dg->base_train_chi2 = chi2(&p, 0);
        dg->base_held_chi2 = chi2(&p, 1);
        double hs = 0;
        for (int i = 0; i < d->n; i++)
            if (held[i])
                hs += (d->s[i].value - p.pred[i]) * (d->s[i].value - p.pred[i]);
        dg->base_held_rms = sqrt(hs / dg->n_held);
        dg->significant = dg->sigma_known
                              ? dg->base_held_chi2 > dg->n_held + 4 * sqrt(2.0 * dg->n_held)
                              : 1;
        for (int c = 0; c < NCAND; c++) {
            if (!(CANDIDATES[c].kinds & (1u << d->kind)))
                continue;
            p.ncand = 1;
            p.cand[0] = &CANDIDATES[c];
            fit(&p, dg, NULL, &dg->rank[dg->nrank++]);
        }
        qsort(dg->rank, dg->nrank, sizeof dg->rank[0], by_score);
        dg->best = dg->rank[0];
        double need = 9 + log((double)dg->n_held);
        /* the baseline's score is its held-out chi-square (no parameters) */
        dg->found = dg->significant && dg->best.ok && dg->base_held_chi2 - dg->best.score > need;
        for (int c = 1; c < dg->nrank && o->pairs && dg->found; c++) {
            dm_fit pair;
            double start[2][3];
            memcpy(start[0], dg->best.value[0], sizeof start[0]);
            memcpy(start[1], dg->rank[c].value[0], sizeof start[1]);
            p.ncand = 2;
            p.cand[0] = dg->best.cand[0];
            p.cand[1] = dg->rank[c].cand[0];
            if (p.cand[0] == p.cand[1] || !dg->rank[c].ok ||
                p.cand[0]->nparam + p.cand[1]->nparam > DM_DIAG_MAXP)
                continue;
            fit(&p, dg, start, &pair);
            if (pair.ok && pair.score < dg->best.score - need && dg->best.ncand == 1)
                dg->best = pair;
            else if (pair.ok && dg->best.ncand == 2 && pair.score < dg->best.score)
                dg->best = pair;
        }
    }
    free(held);
    free(p.pred);
    free(p.w);
    return rc;
}
