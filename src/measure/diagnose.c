/* Diagnosis of model-vs-measurement discrepancies (see dm_diagnose.h). */
#include "dm_diagnose.h"

#include "dm_nuisance.h"
#include "dm_predict.h"
#include "dm_threads.h"
#include "dm_work.h"

#include <assert.h>
#include <cminpack.h>
#include <lapacke.h>
#include <math.h>
#include <omp.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define K_MODAL (1u << DM_DATA_MODAL)
#define K_STATIC (1u << DM_DATA_STATIC)
#define K_TRACK (1u << DM_DATA_TRACKER)

_Static_assert(K_MODAL == DM_EFFECTS_MODAL && K_STATIC == DM_EFFECTS_STATIC &&
                   K_TRACK == DM_EFFECTS_TRACKER,
               "the effect table's data-kind bits are dm_data_kind's");

/* The candidates are the effect table's rows that some data can see
 * (dm_effects.h); the union of the geometry families is one of them. */
#define UNION (dm_effects_union())

/* One geometry family (three per-chain parameters)? */
static int is_family(const dm_effect *c)
{
    return c->scope == DM_EFFECTS_EACH_CHAIN && c->nparam == 3;
}

int dm_fit_apply(const dm_robot *rb, const dm_fit *f, dm_robot *out, dm_error *err)
{
    *out = *rb;
    for (int i = 0; i < f->ncand; i++) {
        int rc = dm_effects_apply(out, f->cand[i]->name, f->value[i], err);
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
    int sigma_known;         /* else w is 1/RMS of the baseline's residuals */
    double train_end_s;      /* tracker: time of the last training sample */
    int *nomem;              /* set when a fit ran out of memory (the result is void) */
    struct memo *memo;       /* predictions made so far (NULL: none kept) */
    dm_progress_meter *pm;   /* the diagnosis's progress (fn NULL: none) */
    /* a tracker run's nuisances (NULL: none, or not compared): the
     * baseline's fit and their design about its prediction, d->n x q
     * column-major, against which each model's are measured (dm_nuisance_shift) */
    const dm_nuisance_fit *base_nuisance;
    const double *nuisance_design;
} shared;

/* ---- predictions made once ---------------------------------------------------
 *
 * A prediction is a function of the robot and the window alone (every run
 * starts cold, dm_predictor_run), so a repeat is looked up instead of made
 * again: every linear candidate's fit starts at the file's robot, and each
 * fit ends by predicting its best point, which its last step evaluated
 * (the docs' 0.1 s tracker case repeats 150 of 1 009). Robots are found by
 * their bytes: equal bytes are equal robots (padding that differs only
 * costs a miss). Shared by the fits' threads; what is found is what would
 * have been computed, bit for bit, so the result does not depend on which
 * thread made it first. */

typedef struct {
    uint64_t hash;
    int n;          /* samples predicted (the window) */
    dm_robot robot;
    double *pred;   /* n */
} memo_entry;

typedef struct memo {
    memo_entry *e;
    int count, cap;
    size_t bytes;
} memo;

/* Most bytes the predictions kept may take. */
#define MEMO_MAX_BYTES ((size_t)64 << 20)

static uint64_t memo_hash(const dm_robot *rb, int n)
{
    const unsigned char *b = (const unsigned char *)rb;
    uint64_t h = 1469598103934665603u ^ (uint64_t)n; /* FNV-1a */
    for (size_t i = 0; i < sizeof *rb; i++)
        h = (h ^ b[i]) * 1099511628211u;
    return h;
}

static int memo_get(memo *m, const dm_robot *rb, int n, double *pred)
{
    if (!m)
        return 0;
    uint64_t h = memo_hash(rb, n);
    int found = 0;
#pragma omp critical(dm_diag_memo)
    for (int i = 0; i < m->count && !found; i++) {
        const memo_entry *e = &m->e[i];
        if (e->hash == h && e->n == n && !memcmp(&e->robot, rb, sizeof *rb)) {
            memcpy(pred, e->pred, sizeof(double) * n);
            found = 1;
        }
    }
    return found;
}

/* Keep a prediction (silently not, beyond MEMO_MAX_BYTES or memory). */
static void memo_put(memo *m, const dm_robot *rb, int n, const double *pred)
{
    if (!m)
        return;
    uint64_t h = memo_hash(rb, n);
#pragma omp critical(dm_diag_memo)
    {
        size_t more = sizeof(memo_entry) + sizeof(double) * n;
        if (m->count == m->cap && m->bytes + more <= MEMO_MAX_BYTES) {
            int cap = m->cap ? 2 * m->cap : 64;
            memo_entry *e = realloc(m->e, sizeof *e * cap);
            if (e)
                m->e = e, m->cap = cap;
        }
        double *copy = m->count < m->cap && m->bytes + more <= MEMO_MAX_BYTES
                           ? malloc(sizeof(double) * n)
                           : NULL;
        if (copy) {
            memo_entry *e = &m->e[m->count++];
            memcpy(copy, pred, sizeof(double) * n);
            memcpy(&e->robot, rb, sizeof *rb); /* padding too: compared by bytes */
            e->hash = h, e->n = n, e->pred = copy;
            m->bytes += more;
        }
    }
}

static void memo_free(memo *m)
{
    for (int i = 0; i < m->count; i++)
        free(m->e[i].pred);
    free(m->e);
}

/* A fit that fails for want of memory must not pass for one that does
 * not fit: the diagnosis is then an out-of-memory error. */
static void out_of_memory(const shared *s)
{
#pragma omp atomic write
    *s->nomem = 1;
}

/* One fit: its effects, the leading `nfixed` of them held at `fixed`, and
 * its own prediction workspace and buffer. */
typedef struct {
    const shared *s;
    dm_dataset view;         /* the data fitted: all, or a tracker run's first part */
    dm_predictor *predictor; /* made once per fit, run by every evaluation */
    dm_predictor *scanner;   /* the scan's, at its mesh (NULL: the predictor) */
    int scanning;            /* evaluations are the scan's (scan_start) */
    double *pred;
    int ncand, nfixed;
    const dm_effect *cand[2];
    double fixed[2][DM_DIAG_MAXV];
} problem;

static void split_samples(const dm_dataset *d, char *held)
{
    assert(d->n > 0);
    double T = d->kind == DM_DATA_TRACKER ? d->s[d->n - 1].t : 0;
    for (int i = 0; i < d->n; i++)
        held[i] = d->kind == DM_DATA_TRACKER ? d->s[i].t > 2.0 * T / 3.0 : d->s[i].pose_id % 3 == 2;
}

/* The fit's robot with its effects at the given values (physical units). */
static int robot_with(const problem *p, double value[2][DM_DIAG_MAXV], dm_robot *rb,
                      dm_error *err)
{
    *rb = *p->s->rb;
    int rc = DM_OK;
    for (int i = 0; i < p->ncand && !rc; i++)
        rc = dm_effects_apply(rb, p->cand[i]->name, value[i], err);
    return rc;
}

/* The model's predictions for rb into p->pred, without the nuisances:
 * looked up when made before, else made (and kept). */
static int predict_model(problem *p, const dm_robot *rb, dm_error *err)
{
    /* the scan's coarser predictions are not kept: they would pass for
     * the mesh's, and no other fit scans the same robots */
    int coarse = p->scanning && p->scanner, rc = DM_OK;
    dm_predictor *pr = coarse ? p->scanner : p->predictor;
    memo *m = coarse ? NULL : p->s->memo;
    if (!memo_get(m, rb, p->view.n, p->pred)) {
        dm_predictor_window(pr, p->view.n);
        rc = dm_predictor_run(pr, rb, p->pred, err);
        if (!rc)
            memo_put(m, rb, p->view.n, p->pred);
        dm_progress_add(p->s->pm, 0); /* the same count, later: the clock moves */
    }
    return rc;
}

/* A tracker run's nuisances, fitted with every model (dm_nuisance.h), to
 * the prediction in p->pred (into nf unless NULL). */
static int fit_nuisances(problem *p, dm_nuisance_fit *nf)
{
    return dm_nuisance_apply(p->s->d, p->view.n, p->s->held, p->s->w, p->pred, 1.0, nf);
}

/* Predictions with the given effect values (physical units), the
 * nuisances fitted with them (into nf unless NULL); the model's before
 * them into raw (p->view.n) unless NULL. */
static int predict_keeping(problem *p, double value[2][DM_DIAG_MAXV], dm_nuisance_fit *nf,
                           double *raw, dm_error *err)
{
    dm_robot rb;
    int rc = robot_with(p, value, &rb, err);
    if (!rc)
        rc = predict_model(p, &rb, err);
    if (!rc && raw)
        memcpy(raw, p->pred, sizeof(double) * p->view.n);
    return rc ? rc : fit_nuisances(p, nf);
}

static int predict_with(problem *p, double value[2][DM_DIAG_MAXV], dm_nuisance_fit *nf,
                        dm_error *err)
{
    return predict_keeping(p, value, nf, NULL, err);
}

static double chi2(const shared *s, const double *pred, int want_held)
{
    assert(s->d->n >= 0 && pred);
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
static double from_log(const dm_effect *c, double x)
{
    return pow(10.0, fmin(c->hi + 2, fmax(c->lo - 2, x)));
}

/* Free parameters x (log10, or as they are for linear candidates) to the
 * values of all effects. */
static void to_values(const problem *p, const double *x, double value[2][DM_DIAG_MAXV])
{
    assert(p->ncand >= 1 && p->ncand <= 2 && p->nfixed <= p->ncand);
    for (int i = 0, j = 0; i < p->ncand; i++) {
        const dm_effect *c = p->cand[i];
        for (int k = 0; k < DM_DIAG_MAXV; k++)
            value[i][k] = i < p->nfixed   ? p->fixed[i][k]
                          : k >= c->nparam ? 1.0
                          : c->linear      ? x[j++]
                                           : from_log(c, x[j++]);
    }
}

/* The values of effects first..ncand-1 as free parameters (inverse of
 * to_values). Returns their count. */
static int to_params(const problem *p, int first, double value[2][DM_DIAG_MAXV], double *x)
{
    assert(first >= 0 && p->ncand <= 2);
    int n = 0;
    for (int i = first; i < p->ncand; i++)
        for (int k = 0; k < p->cand[i]->nparam; k++)
            x[n++] = p->cand[i]->linear ? value[i][k] : log10(value[i][k]);
    return n;
}

/* Fitted units per scaled unit of the parameters of effects first.. */
static void param_scales(const problem *p, int first, double *sc)
{
    assert(first >= 0 && p->ncand <= 2);
    for (int i = first, j = 0; i < p->ncand; i++)
        for (int k = 0; k < p->cand[i]->nparam; k++)
            sc[j++] = dm_effects_param_scale(p->cand[i], k);
}

/* The weighted training residuals of p->pred (m of them), or where the
 * prediction failed (rc), values that steer a search away. */
static void fill_residuals(const problem *p, int rc, int m, double *fvec)
{
    const shared *s = p->s;
    if (rc == DM_ENOMEM)
        out_of_memory(s);
    if (rc) {
        for (int i = 0; i < m; i++)
            fvec[i] = 1e3; /* unphysical region: steer the search away */
        return;
    }
    for (int i = 0, k = 0; i < p->view.n; i++)
        if (!s->held[i])
            fvec[k++] = (s->d->s[i].value - p->pred[i]) * s->w[i];
}

/* The weighted training residuals at x (m), and the model's prediction
 * there before the nuisances into raw (p->view.n) unless NULL. */
static int residuals_keeping_model(problem *p, const double *x, int m, double *f, double *raw)
{
    double value[2][DM_DIAG_MAXV];
    to_values(p, x, value);
    int rc = predict_keeping(p, value, NULL, raw, NULL);
    fill_residuals(p, rc, m, f);
    return rc;
}

/* cminpack callback */
static int residuals(void *user, int m, int n, const double *x, double *fvec, int iflag)
{
    assert(m >= 0 && n >= 0 && n <= DM_DIAG_MAXP);
    (void)iflag;
    (void)n;
    residuals_keeping_model(user, x, m, fvec, NULL);
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
static void scan_start(problem *p, double *x, const dm_effect *c, int m, double *fvec,
                       int steps)
{
    double best = INFINITY, bx = 0.5 * (c->lo + c->hi);
    p->scanning = 1;
    for (int s = 0; s <= steps; s++) {
        x[0] = c->lo + (c->hi - c->lo) * s / steps;
        residuals(p, m, 1, x, fvec, 1);
        double q = sum_squares(fvec, m);
        if (q < best) {
            best = q;
            bx = x[0];
        }
    }
    p->scanning = 0;
    x[0] = bx;
}

/* Elements of the scan's mesh for the mesh m (dm_diagnose_opts.scan_na). */
static int scan_elements(int m, int asked)
{
    int half = (m + 1) / 2 > 2 ? (m + 1) / 2 : 2;
    return asked > 0 ? asked : half < m ? half : m;
}

/* The scan's tracker predictions integrate at twice the step of the fit's
 * (where the samples are that far apart): their error, 6e-8 m on the
 * bench's circle (0.03 of its noise), shifts every grid point's misfit
 * alike (by 0.17 in chi-square there, against 0.05 to 1e9 between
 * neighbouring points), and halves the scan's cost. */
#define SCAN_STEP_S (2 * DM_PREDICT_STEP_S)

/* The scan's predictor (scan_elements), or NULL where that is the mesh
 * itself, or memory is short (the scan then runs at the mesh). */
static dm_predictor *scan_predictor(const problem *p)
{
    const shared *s = p->s;
    int na = s->o->na > 0 ? s->o->na : s->rb->na, nb = s->o->nb > 0 ? s->o->nb : s->rb->nb;
    int sa = scan_elements(na, s->o->scan_na), sb = scan_elements(nb, s->o->scan_nb);
    dm_predictor *scan = sa == na && sb == nb ? NULL : dm_predictor_new(s->rb, s->d, sa, sb, NULL);
    if (scan)
        dm_predictor_step(scan, SCAN_STEP_S);
    return scan;
}

/* Residuals at x into f (m): `residuals`, or another way of making them. */
typedef int (*residual_fn)(problem *p, const double *x, int m, double *f, const void *how);

/* Forward-difference Jacobian J (m x n, column-major) at x of the residuals
 * made by `eval`, whose residuals at x are f0. Returns eval's first failure. */
static int jacobian_of(problem *p, residual_fn eval, const void *how, const double *x, int n,
                       int m, const double *f0, double *f1, double *J)
{
    assert(n >= 0 && n <= DM_DIAG_MAXP && m >= 0);
    double xx[DM_DIAG_MAXP];
    memcpy(xx, x, sizeof(double) * n);
    int rc = DM_OK;
    for (int j = 0; j < n && !rc; j++) {
        double h = 1e-4 * fmax(1e-3, fabs(x[j]));
        xx[j] = x[j] + h;
        rc = eval(p, xx, m, f1, how);
        xx[j] = x[j];
        for (int i = 0; i < m; i++)
            J[(size_t)j * m + i] = (f1[i] - f0[i]) / h;
    }
    return rc;
}

static int true_residuals(problem *p, const double *x, int m, double *f, const void *how)
{
    (void)how;
    residuals(p, m, 0, x, f, 1);
    return DM_OK; /* a failed prediction's residuals steer the search away */
}

/* A tracker run's model prediction at x0 (raw, before the nuisances) and
 * the real platform's offsets there (dm_predictor_offsets), p->view.n each. */
typedef struct {
    const double *raw, *offset;
    double *moved; /* scratch: the offsets at x */
} offset_shift;

/* The real platform's offsets at x (dm_predictor_offsets) into out
 * (p->view.n; the predictor's window must be the view's). */
static int offsets_at(problem *p, const double *x, double *out)
{
    double value[2][DM_DIAG_MAXV];
    dm_robot rb;
    to_values(p, x, value);
    int rc = robot_with(p, value, &rb, NULL);
    return rc ? rc : dm_predictor_offsets(p->predictor, &rb, out, NULL);
}

/* The residuals at x of the prediction at x0 moved by the change of the
 * real platform's offsets alone, the nuisances fitted to it as to every
 * prediction. */
static int shifted_residuals(problem *p, const double *x, int m, double *f, const void *how)
{
    const offset_shift *o = how;
    int rc = offsets_at(p, x, o->moved);
    for (int i = 0; i < p->view.n && !rc; i++)
        p->pred[i] = o->raw[i] + (o->moved[i] - o->offset[i]);
    if (!rc)
        rc = fit_nuisances(p, NULL);
    fill_residuals(p, rc, m, f);
    return rc;
}

/* Residuals f (m) and their Jacobian J at x for geometry errors. On a
 * tracker run the Jacobian's predictions are the model's at x moved by the
 * change of the real platform's offsets alone (shifted_residuals): a few
 * kinematic solves a sample instead of a prediction a parameter (3 for a
 * family; their union's 18 were the families' own, looked up). What that
 * leaves out is how the elastic error changes with the geometry (the
 * deflection's relative change with the pose and the members' lengths,
 * about the error over the arm's length): 0.9-5.4e-4 of a column's norm
 * on the bench's circle (zheng2017, docs/model-choices.md). The chord's
 * steps are each checked with a true prediction; the 1-sigma come from
 * this Jacobian. Other data (and a failed prediction) take the forward
 * differences of true predictions. */
static void geometry_jacobian(problem *p, const double *x, int n, int m, double *f, double *f1,
                              double *J)
{
    int nv = p->view.n, done = 0;
    double *raw = malloc(sizeof(double) * 3 * (nv ? nv : 1));
    if (raw && p->s->d->kind == DM_DATA_TRACKER) {
        offset_shift o = {raw, raw + nv, raw + 2 * nv};
        dm_predictor_window(p->predictor, nv); /* a prediction looked up does not set it */
        done = !residuals_keeping_model(p, x, m, f, raw) && !offsets_at(p, x, raw + nv) &&
               !jacobian_of(p, shifted_residuals, &o, x, n, m, f, f1, J);
    }
    free(raw);
    if (!done) {
        residuals(p, m, n, x, f, 1);
        jacobian_of(p, true_residuals, NULL, x, n, m, f, f1, J);
    }
}

/* Scale of the covariance: the reduced chi-square when above 1 (the model
 * misfits beyond the noise), else 1; without sigma the reduced chi-square
 * itself (the noise variance estimated from the residuals, in units of the
 * weights' baseline mean square). */
static double misfit_scale(const shared *s, double c2, int m, int n)
{
    double reduced = c2 / (m > n ? m - n : 1);
    return s->sigma_known ? fmax(1.0, reduced) : reduced;
}

/* Singular values s (descending, min(m, n) of them), left vectors U (m x
 * min(m, n)) and right vectors VT (n x n, row k = combination k) of the
 * m x n column-major A, which is destroyed. */
static int svd(double *A, int m, int n, double *s, double *U, double *VT)
{
    assert(n >= 1 && n <= DM_DIAG_MAXP && m >= 1); /* superb holds min(m, n) - 1 */
    double superb[DM_DIAG_MAXP];
    return LAPACKE_dgesvd(LAPACK_COL_MAJOR, 'S', 'A', m, n, A, m, s, U, m, VT, n, superb);
}

/* The relative error of a prediction, which sets lmdif's forward-difference
 * step (sqrt of it, relative to x): second differences of the docs' 0.1 s
 * tracker predictions in the payload mass level off at 5e-12 of the
 * largest value below steps of 1e-5 (the eigen solves' convergence
 * tolerances), so the default step (sqrt of machine epsilon, 1.5e-8)
 * carried up to 0.3 % of noise into the Jacobian and cost searches extra
 * evaluations (8-20 % of a tracker diagnosis). 1e-10 (steps of 1e-5)
 * keeps that noise at 1e-6 and the truncation error at 1e-5. */
#define PREDICTION_EPS 1e-10

/* Levenberg-Marquardt (cminpack lmdif) from x; uncertainties from the
 * R factor of its last Jacobian (covar), so they cost no predictions.
 * Tolerances 1e-6 on log10 values are far below any uncertainty; the
 * evaluation cap stops a search on a plateau the data cannot see. */
static void lm_fit(problem *p, double *x, int n, int m, double *sig)
{
    assert(n >= 1 && n <= DM_DIAG_MAXP && m >= 0);
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
        int info = lmdif(residuals, p, m, n, x, fvec, 1e-6, 1e-6, 0.0, 25 * (n + 1),
                         PREDICTION_EPS, diag, 1, 100.0, 0, &nfev, fjac, m, ipvt, qtf, wa1, wa2,
                         wa3, wa4);
        if (info > 0) {
            double scale = misfit_scale(p->s, sum_squares(fvec, m), m, n);
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

/* Combinations the data see: singular values of the scaled Jacobian of at
 * least 1, i.e. a 1-sigma of at most one scaled unit (an error of the size
 * worth knowing). The others are left at zero (the least-norm solution). */
#define SEEN 1.0

/* Geometry errors move the data almost linearly: one Jacobian, then
 * Gauss-Newton steps with it (chord method) until the step is below a
 * thousandth of the uncertainty: about 7 predictions where LM takes 30.
 * Steps are taken in the combinations the data see (truncated SVD of the
 * Jacobian in scaled units), so that look-alike parameters (base and
 * platform radius; the union of the families) do not run off along what
 * the data cannot tell. *nseen: the combinations fitted. */
static void chord_fit(problem *p, double *x, int n, int m, const double *sc, double *sig,
                      int *nseen)
{
    assert(n >= 1 && n <= DM_DIAG_MAXP && m >= 0);
    int r = m < n ? m : n;
    double *f = malloc(sizeof(double) * m), *f1 = malloc(sizeof(double) * m);
    double *J = calloc((size_t)m * n, sizeof(double)), *U = malloc(sizeof(double) * m * r);
    double s[DM_DIAG_MAXP], VT[DM_DIAG_MAXP * DM_DIAG_MAXP];
    for (int j = 0; j < n; j++)
        sig[j] = INFINITY;
    *nseen = 0;
    if (!f || !f1 || !J || !U || r < 1) {
        free(f), free(f1), free(J), free(U);
        if (r >= 1)
            out_of_memory(p->s);
        return;
    }
    geometry_jacobian(p, x, n, m, f, f1, J);
    for (int j = 0; j < n; j++)
        for (int i = 0; i < m; i++)
            J[(size_t)j * m + i] *= sc[j];
    int ok = !svd(J, m, n, s, U, VT);
    int q = 0;
    while (ok && q < r && s[q] >= SEEN)
        q++;
    double best = sum_squares(f, m);
    for (int it = 0; ok && it < 8; it++) {
        double c[DM_DIAG_MAXP], xn[DM_DIAG_MAXP], big = 0;
        for (int k = 0; k < q; k++) { /* step along combination k: -u_k'f / s_k */
            double uf = 0;
            for (int i = 0; i < m; i++)
                uf += U[(size_t)k * m + i] * f[i];
            c[k] = -uf / s[k];
            big = fmax(big, fabs(uf)); /* the step in units of its 1-sigma 1/s_k */
        }
        for (int j = 0; j < n; j++) {
            double dz = 0;
            for (int k = 0; k < q; k++)
                dz += VT[k + j * n] * c[k];
            xn[j] = x[j] + sc[j] * dz;
        }
        residuals(p, m, n, xn, f1, 1);
        double qq = sum_squares(f1, m);
        if (!(qq <= best)) /* no better: the chord has done what it can */
            break;
        best = qq;
        memcpy(x, xn, sizeof(double) * n);
        memcpy(f, f1, sizeof(double) * m);
        if (big < 1e-3)
            break;
    }
    /* 1-sigma of each parameter over every combination: one the data do
     * not see (tiny s_k) makes it as uncertain as that combination */
    for (int j = 0; ok && j < n; j++) {
        double v = 0, null = 0;
        for (int k = 0; k < n; k++) {
            double w2 = VT[k + j * n] * VT[k + j * n];
            if (k < r && s[k] > 0)
                v += w2 / (s[k] * s[k]);
            else
                null += w2;
        }
        sig[j] = null > 1e-12 ? INFINITY : sc[j] * sqrt(misfit_scale(p->s, best, m, n) * v);
    }
    *nseen = ok ? q : 0;
    free(f);
    free(f1);
    free(J);
    free(U);
}

/* Held-out misfit on the scale of a log-likelihood: the chi-square when
 * sigma is known; otherwise N ln(chi2/N), the Gaussian likelihood with the
 * variance profiled out (chi2 is then in units of the baseline's RMS). */
static double held_score(const dm_diagnosis *dg, double held_chi2)
{
    double n = dg->n_held;
    return dg->sigma_known ? held_chi2 : n * log(fmax(held_chi2, 1e-300) / n);
}

/* Gain in amplitude: the share of the held-out misfit beyond the noise
 * (without sigma: of the held-out RMS) that a fit removes. */
static double gain_against(const dm_diagnosis *dg, double before_chi2, double held_chi2)
{
    double n = dg->n_held;
    if (!dg->sigma_known)
        return before_chi2 > 0 ? 100.0 * (1.0 - sqrt(held_chi2 / before_chi2)) : 0;
    double before = fmax(before_chi2 / n - 1.0, 0), after = fmax(held_chi2 / n - 1.0, 0);
    return before > 0 ? 100.0 * (1.0 - sqrt(after / before)) : 0.0;
}

static double gain_percent(const dm_diagnosis *dg, double held_chi2)
{
    return gain_against(dg, dg->base_held_chi2, held_chi2);
}

static void score_fit(const problem *p, const dm_diagnosis *dg, dm_fit *f)
{
    const shared *s = p->s;
    f->train_chi2 = chi2(s, p->pred, 0);
    if (dg->n_held == 0) /* dm_fit_effects: everything is training */
        return;
    f->held_chi2 = chi2(s, p->pred, 1);
    double ms = 0;
    for (int i = 0; i < s->d->n; i++)
        if (s->held[i]) {
            double r = s->d->s[i].value - p->pred[i];
            ms += r * r;
        }
    f->held_rms = sqrt(ms / dg->n_held);
    f->gain_percent = gain_percent(dg, f->held_chi2);
    f->score = held_score(dg, f->held_chi2) + f->nfree * log((double)dg->n_held);
}

/* How far the nuisances nf fitted with a model (prediction pred, with
 * them) moved from the baseline's, and whether the model compensates
 * (dm_nuisance_shift): with them held at the baseline's, its training
 * chi-square is |r + N delta|^2, r its weighted residual. */
static void measure_shift(const shared *s, const dm_diagnosis *dg, const double *pred,
                          const dm_nuisance_fit *nf, dm_fit *f)
{
    const dm_dataset *d = s->d;
    const dm_nuisance_fit *b = s->base_nuisance;
    dm_nuisance_shift *sh = &f->shift;
    memset(sh, 0, sizeof *sh);
    if (!b || !s->nuisance_design || !nf->n)
        return;
    assert(nf->n == b->n && nf->n <= DM_NUISANCE_MAX);
    sh->n = nf->n;
    for (int k = 0; k < nf->n; k++)
        sh->delta[k] = nf->value[k] - b->value[k];
    double ww = 0, uu = 0;
    int m = 0;
    for (int i = 0; i < d->n; i++) {
        if (s->held[i])
            continue;
        double move = 0; /* what the move does to sample i's fitted position */
        for (int k = 0; k < nf->n; k++)
            move += s->nuisance_design[(size_t)k * d->n + i] * sh->delta[k];
        double r = (d->s[i].value - pred[i]) * s->w[i];
        ww += move * move * s->w[i] * s->w[i];
        uu += move * move;
        sh->at_baseline_chi2 += (r + move * s->w[i]) * (r + move * s->w[i]);
        m++;
    }
    sh->rms_m = sqrt(uu / (m ? m : 1));
    sh->sigmas = sqrt(ww / misfit_scale(s, dg->base_train_chi2, m, b->nseen));
    sh->compensating = sh->rms_m > dg->compensating_m &&
                       sh->at_baseline_chi2 >= dg->base_train_chi2;
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
static void fit(problem *p, const dm_diagnosis *dg, double start[2][DM_DIAG_MAXV], dm_fit *f)
{
    int n = 0, ntotal = 0, linear = 1, nseen = 0;
    double x[DM_DIAG_MAXP], sc[DM_DIAG_MAXP], value[2][DM_DIAG_MAXV] = {{0}};
    double sig[DM_DIAG_MAXP] = {0};
    for (int i = 0; i < p->ncand; i++) {
        const dm_effect *c = p->cand[i];
        ntotal += c->nparam;
        linear &= i < p->nfixed || c->linear;
        for (int k = 0; i >= p->nfixed && k < c->nparam; k++)
            x[n++] = start    ? (c->linear ? start[i][k] : log10(start[i][k]))
                     : c->linear ? 0.0
                                 : 0.5 * (c->lo + c->hi);
    }
    param_scales(p, p->nfixed, sc);
    memset(f, 0, sizeof *f);
    f->ncand = p->ncand;
    memcpy(f->cand, p->cand, sizeof f->cand);
    set_window(p, 1.0);
    double *fvec = malloc(sizeof(double) * count_train(p));
    p->pred = malloc(sizeof(double) * p->s->d->n);
    p->predictor = dm_predictor_new(p->s->rb, p->s->d, p->s->o->na, p->s->o->nb, NULL);
    if (!fvec || !p->pred || !p->predictor) {
        f->held_chi2 = f->score = INFINITY;
        free(fvec), free(p->pred);
        dm_predictor_free(p->predictor);
        p->predictor = NULL;
        out_of_memory(p->s);
        return;
    }
    const dm_effect *lone = n == 1 && !linear && !start ? p->cand[p->ncand - 1] : NULL;
    p->scanner = lone ? scan_predictor(p) : NULL;
    int staged = p->s->d->kind == DM_DATA_TRACKER && !linear && !start && n > 0;
    for (int w = staged ? 0 : NWINDOWS - 1; w < NWINDOWS && n > 0; w++) {
        set_window(p, WINDOWS[w]);
        int m = count_train(p);
        if (lone && w == (staged ? 0 : NWINDOWS - 1)) /* a short window affords a finer scan */
            scan_start(p, x, lone, m, fvec, staged ? 24 : 12);
        if (linear)
            chord_fit(p, x, n, m, sc, sig, &nseen);
        else
            lm_fit(p, x, n, m, sig);
    }
    set_window(p, 1.0);
    to_values(p, x, value);
    for (int i = p->nfixed, j = 0; i < p->ncand; i++)
        for (int k = 0; k < p->cand[i]->nparam; k++, j++)
            f->sigma[i][k] = p->cand[i]->linear ? sig[j] : value[i][k] * log(10.0) * sig[j];
    memcpy(f->value, value, sizeof value);
    f->nfree = linear && n > 0 ? ntotal - n + nseen : ntotal;
    dm_nuisance_fit nf;
    int rc = predict_with(p, value, &nf, NULL);
    if (rc == DM_ENOMEM)
        out_of_memory(p->s);
    f->ok = rc == DM_OK;
    if (f->ok) {
        score_fit(p, dg, f);
        measure_shift(p->s, dg, p->pred, &nf, f);
    } else {
        f->held_chi2 = f->score = INFINITY;
    }
    free(fvec);
    free(p->pred);
    p->pred = NULL;
    dm_predictor_free(p->predictor);
    dm_predictor_free(p->scanner);
    p->predictor = p->scanner = NULL;
}

/* Best score first; equal scores in candidate-table order, so the ranking
 * does not depend on the thread count. */
static int by_score(const void *a, const void *b)
{
    const dm_fit *x = a, *y = b;
    if (x->score != y->score)
        return (x->score > y->score) - (x->score < y->score);
    for (int i = 0; i < 2; i++) {
        const dm_effect *cx = i < x->ncand ? x->cand[i] : NULL;
        const dm_effect *cy = i < y->ncand ? y->cand[i] : NULL;
        if (cx != cy)
            return (cx > cy) - (cx < cy);
    }
    return 0;
}

static int thread_count(const dm_diagnose_opts *o)
{
    return o->threads > 0 ? o->threads : omp_get_max_threads();
}

static double chi2_upper(double n, double p);

/* Is the union of the geometry families worth fitting? When two or more
 * families each explain part of the data and the best of them leaves more
 * than noise (or the noise is unknown): several may be present at once. */
static int union_wanted(const dm_diagnosis *dg, const dm_fit *fits, int n, double need)
{
    int significant = 0, best = -1;
    for (int j = 0; j < n; j++)
        if (fits[j].ok && is_family(fits[j].cand[0]) && dg->base_score - fits[j].score > need) {
            significant++;
            if (best < 0 || fits[j].score < fits[best].score)
                best = j;
        }
    return significant >= 2 &&
           (!dg->sigma_known ||
            fits[best].held_chi2 > chi2_upper(dg->n_held, 0.5 * DM_DIAG_BAND));
}

/* Single effects: every candidate the data can see, fitted on its own;
 * the union of the geometry families only when wanted (it costs as much
 * as the six families together). */
static void rank_singles(const shared *s, dm_diagnosis *dg, double need)
{
    int ntab, idx[DM_EFFECTS_MAXROWS], nc = 0;
    const dm_effect *tab = dm_effects_table(&ntab);
    for (int c = 0; c < ntab; c++)
        if (tab[c].kinds & (1u << s->d->kind) && &tab[c] != UNION)
            idx[nc++] = c;
    dm_progress_begin(s->pm, "single effects", "fits", nc);
#pragma omp parallel for schedule(dynamic, 1) num_threads(thread_count(s->o))
    for (int j = 0; j < nc; j++) {
        problem p = {.s = s, .ncand = 1, .cand = {&tab[idx[j]], NULL}};
        fit(&p, dg, NULL, &dg->rank[j]);
        dm_progress_add(s->pm, 1);
    }
    dm_progress_end(s->pm);
    if ((UNION->kinds & (1u << s->d->kind)) && union_wanted(dg, dg->rank, nc, need)) {
        problem p = {.s = s, .ncand = 1, .cand = {UNION, NULL}};
        dm_progress_begin(s->pm, "geometry union", "fits", 1);
        fit(&p, dg, NULL, &dg->rank[nc++]);
        dm_progress_end(s->pm);
    }
    dg->nrank = nc;
    qsort(dg->rank, nc, sizeof dg->rank[0], by_score);
}

/* ---- parsimony -------------------------------------------------------------- */

/* Does a contain b, or b a (a geometry family and the union of all)? */
static int nested(const dm_effect *a, const dm_effect *b)
{
    return (a == UNION && is_family(b)) || (b == UNION && is_family(a));
}

/* A fit that may be the verdict: it did not fail, and it explains rather
 * than compensates (dm_nuisance_shift). */
static int usable(const dm_fit *f) { return f->ok && !f->shift.compensating; }
static int fitted(const dm_fit *f) { return f->ok; }

/* Keep f, which would have been the verdict but compensates, to report. */
static void set_aside(dm_diagnosis *dg, const dm_fit *f)
{
    assert(f->shift.compensating && dg->nset_aside < 2);
    dg->set_aside[dg->nset_aside++] = *f;
}

/* The rank of the best single fit that `may` accepts of a candidate that
 * `want` accepts, or -1. */
static int rank_where(const dm_diagnosis *dg, int (*may)(const dm_fit *),
                      int (*want)(const dm_effect *, const void *), const void *arg)
{
    for (int r = 0; r < dg->nrank; r++)
        if (may(&dg->rank[r]) && want(dg->rank[r].cand[0], arg))
            return r;
    return -1;
}

static int named(const dm_effect *c, const void *name) { return !strcmp(c->name, name); }
static int family(const dm_effect *c, const void *arg) { return (void)arg, is_family(c); }
static int any(const dm_effect *c, const void *arg) { return (void)c, (void)arg, 1; }

/* The rank of the single effect of the verdict among the fits that `may`
 * accepts (-1: none): the best scoring, unless a simpler one is close
 * enough. A per-chain variant must beat its global effect by
 * DM_DIAG_CLEAR (one symmetric effect is the simpler hypothesis: the
 * variant also picks one chain of three); the union of the geometry
 * families must beat the best single family by `need`, as a second effect
 * must. *passed: the rank it was preferred to, or -1. */
static int pick_single(const dm_diagnosis *dg, double need, int (*may)(const dm_fit *),
                       int *passed)
{
    int t = rank_where(dg, may, any, NULL), r = -1;
    double margin = 0;
    *passed = -1;
    if (t < 0)
        return -1;
    const dm_fit *top = &dg->rank[t];
    if (top->cand[0]->global) {
        r = rank_where(dg, may, named, top->cand[0]->global);
        margin = DM_DIAG_CLEAR;
    } else if (top->cand[0] == UNION) {
        r = rank_where(dg, may, family, NULL);
        margin = need;
    }
    if (r > t && dg->rank[r].score < top->score + margin) {
        *passed = t;
        return r;
    }
    return t;
}

/* The single effect of the verdict (pick_single) among the fits that
 * explain; the one chosen among all fits is set aside when it
 * compensates and would have been found. With none that explains, the
 * best fit stands in, not found (usable() fails). */
static void choose_single(dm_diagnosis *dg, double need)
{
    int passed, ignored, r = pick_single(dg, need, usable, &passed);
    int first = pick_single(dg, need, fitted, &ignored); /* as if none compensated */
    if (first >= 0 && dg->rank[first].shift.compensating && dg->significant &&
        dg->base_score - dg->rank[first].score > need)
        set_aside(dg, &dg->rank[first]);
    dg->best = dg->rank[r >= 0 ? r : 0];
    dg->has_simpler_choice = passed >= 0;
    if (passed >= 0)
        dg->passed_over = dg->rank[passed];
}

/* Candidates whose single-effect score is within DM_DIAG_TIE of the
 * verdict's: the data cannot tell them apart. (A family and the union
 * that contains it are not alternatives.) */
static void find_ties(dm_diagnosis *dg)
{
    const dm_effect *b = dg->best.cand[0];
    dg->ntie = 0;
    for (int r = 0; r < dg->nrank; r++) {
        const dm_fit *f = &dg->rank[r];
        if (usable(f) && f->cand[0] != b && !nested(f->cand[0], b) &&
            f->score - dg->best.score < DM_DIAG_TIE)
            dg->tie[dg->ntie++] = r;
    }
}

/* The pair with the per-chain member of `f` replaced by its global effect
 * (0 when f has none, or when its other member is that effect or another
 * of its chains). */
static int global_twin(const dm_fit *f, const dm_effect *cand[2])
{
    for (int i = 0; i < 2; i++) {
        const dm_effect *c = f->cand[i], *o = f->cand[1 - i];
        if (c->global && !named(o, c->global) && !(o->global && !strcmp(o->global, c->global))) {
            cand[0] = o;
            cand[1] = dm_effects_find(c->global);
            return 1;
        }
    }
    return 0;
}

static const dm_fit *single_fit(const dm_diagnosis *dg, const dm_effect *c)
{
    int r = rank_where(dg, fitted, named, c->name);
    return r < 0 ? NULL : &dg->rank[r];
}

/* The joint fit in fits[0..n-1] of the pair {a, b}, or -1. */
static int find_pair(const dm_fit *fits, int n, const dm_effect *a, const dm_effect *b)
{
    for (int j = 0; j < n; j++)
        if (fits[j].ok && ((fits[j].cand[0] == a && fits[j].cand[1] == b) ||
                           (fits[j].cand[0] == b && fits[j].cand[1] == a)))
            return j;
    return -1;
}

/* The group of look-alikes a candidate belongs to: a global effect and its
 * per-chain variants are one. */
static const char *lookalike_group(const dm_effect *c) { return c->global ? c->global : c->name; }

/* Can a and b form a pair? */
static int pairable(const dm_effect *a, const dm_effect *b)
{
    return a != b && !nested(a, b) && a->nparam + b->nparam <= DM_DIAG_MAXP;
}

/* Up to HEADS best single fits, one per look-alike group. */
#define HEADS 4
static int heads(const dm_diagnosis *dg, int *head)
{
    int n = 0;
    for (int r = 0; r < dg->nrank && n < HEADS; r++) {
        int dup = !dg->rank[r].ok;
        for (int k = 0; k < n && !dup; k++)
            dup = !strcmp(lookalike_group(dg->rank[head[k]].cand[0]),
                          lookalike_group(dg->rank[r].cand[0]));
        if (!dup)
            head[n++] = r;
    }
    return n;
}

/* Two effects. Every other candidate is fitted on top of the verdict's
 * single effect held fixed (a screen as cheap as a single fit) and the two
 * best screened are refitted jointly from the screen's values; and every
 * pair of the best singles (one per look-alike group) is fitted jointly
 * from their single values: held fixed, a first effect that has absorbed
 * part of the second's signature steers the screen to a wrong partner,
 * and the two true effects need not include the best single one. The best
 * pair replaces the single effect when it lowers the score by more than
 * `need`; a pair with a per-chain member must beat its global twin (the
 * global effect in its place) by DM_DIAG_CLEAR. */
#define PAIR_REFITS 2
#define MAXJOINT (PAIR_REFITS + HEADS * (HEADS - 1) / 2 + 1)
static void add_second_effect(const shared *s, dm_diagnosis *dg, double need)
{
    dm_fit screen[DM_DIAG_MAXCAND], joint[MAXJOINT];
    problem pj[MAXJOINT];
    double start[MAXJOINT][2][DM_DIAG_MAXV];
    const dm_fit one = dg->best;
    int ns = 0, idx[DM_DIAG_MAXCAND], head[HEADS], nh = heads(dg, head), nj = 0;
    for (int r = 0; r < dg->nrank; r++)
        if (dg->rank[r].ok && pairable(one.cand[0], dg->rank[r].cand[0]))
            idx[ns++] = r;
    dm_progress_begin(s->pm, "second effect screen", "fits", ns);
#pragma omp parallel for schedule(dynamic, 1) num_threads(thread_count(s->o))
    for (int j = 0; j < ns; j++) {
        problem p = {.s = s, .ncand = 2, .nfixed = 1, .cand = {one.cand[0], dg->rank[idx[j]].cand[0]}};
        memcpy(p.fixed[0], one.value[0], sizeof p.fixed[0]);
        fit(&p, dg, NULL, &screen[j]);
        dm_progress_add(s->pm, 1);
    }
    dm_progress_end(s->pm);
    qsort(screen, ns, sizeof screen[0], by_score);
    for (int j = 0; j < ns && j < PAIR_REFITS; j++, nj++) { /* from the screen */
        pj[nj] = (problem){.s = s, .ncand = 2, .cand = {screen[j].cand[0], screen[j].cand[1]}};
        memcpy(start[nj], screen[j].value, sizeof start[nj]);
    }
    for (int a = 0; a < nh; a++) /* pairs of the best singles, from their values */
        for (int b = a + 1; b < nh; b++) {
            const dm_fit *fa = &dg->rank[head[a]], *fb = &dg->rank[head[b]];
            if (!pairable(fa->cand[0], fb->cand[0]))
                continue;
            pj[nj] = (problem){.s = s, .ncand = 2, .cand = {fa->cand[0], fb->cand[0]}};
            memcpy(start[nj][0], fa->value[0], sizeof start[nj][0]);
            memcpy(start[nj][1], fb->value[0], sizeof start[nj][1]);
            nj++;
        }
    dm_progress_begin(s->pm, "pair fits", "fits", nj);
#pragma omp parallel for schedule(dynamic, 1) num_threads(thread_count(s->o))
    for (int j = 0; j < nj; j++) {
        fit(&pj[j], dg, start[j], &joint[j]);
        dm_progress_add(s->pm, 1);
    }
    dm_progress_end(s->pm);
    int pick = -1, aside = -1; /* the best usable pair, and the best compensating one */
    for (int j = 0; j < nj; j++) {
        int *to = usable(&joint[j])                          ? &pick
                  : joint[j].ok && joint[j].shift.compensating ? &aside
                                                               : NULL;
        if (to && (*to < 0 || by_score(&joint[j], &joint[*to]) < 0))
            *to = j;
    }
    if (aside >= 0 && joint[aside].score < one.score - need &&
        (pick < 0 || joint[aside].score < joint[pick].score))
        set_aside(dg, &joint[aside]); /* it would have replaced the single effect */
    const dm_effect *c[2];
    int passed = -1;
    if (pick >= 0 && global_twin(&joint[pick], c)) {
        int t = find_pair(joint, nj, c[0], c[1]);
        const dm_fit *g = single_fit(dg, c[1]);
        if (t < 0 && g) { /* not fitted yet: from the pair's other value and the global's own */
            t = nj++;
            int keep = joint[pick].cand[0] == c[0] ? 0 : 1;
            pj[t] = (problem){.s = s, .ncand = 2, .cand = {c[0], c[1]}};
            memcpy(start[t][0], joint[pick].value[keep], sizeof start[t][0]);
            memcpy(start[t][1], g->value[0], sizeof start[t][1]);
            dm_progress_begin(s->pm, "pair with the global effect", "fits", 1);
            fit(&pj[t], dg, start[t], &joint[t]);
            dm_progress_end(s->pm);
        }
        if (t >= 0 && usable(&joint[t]) && joint[t].score < joint[pick].score + DM_DIAG_CLEAR) {
            passed = pick;
            pick = t;
        }
    }
    if (pick < 0 || !(joint[pick].score < one.score - need))
        return; /* the single effect stays, and so does what it was preferred to */
    dg->best = joint[pick];
    dg->has_simpler_choice = passed >= 0;
    if (passed >= 0)
        dg->passed_over = joint[passed];
}

/* ---- is it explained? --------------------------------------------------------- */

/* z with P(Z > z) = p for a standard normal Z: bisection on erfc, which
 * is monotone (60 halvings of [-10, 10] are below round-off). */
static double normal_upper(double p)
{
    double lo = -10, hi = 10;
    for (int i = 0; i < 60; i++) {
        double mid = 0.5 * (lo + hi);
        if (0.5 * erfc(mid / sqrt(2.0)) > p)
            lo = mid;
        else
            hi = mid;
    }
    return 0.5 * (lo + hi);
}

/* q with P(chi2_n > q) = p (Wilson-Hilferty: (chi2/n)^(1/3) is nearly
 * normal with mean 1 - 2/9n and variance 2/9n). */
static double chi2_upper(double n, double p)
{
    double a = 2.0 / (9.0 * n), c = 1.0 - a + normal_upper(p) * sqrt(a);
    return n * c * c * c;
}

static int group_of(const dm_dataset *d, const dm_sample *s)
{
    assert(d->kind == DM_DATA_MODAL ? s->mode >= 1 && s->mode <= DM_DIAG_MAXGROUP
                                     : s->comp >= 0 && s->comp < 3);
    return d->kind == DM_DATA_MODAL ? s->mode : s->comp;
}

/* Where the excess sits: the held-out poses (tracker: sample times) with
 * the largest chi2 beyond their sample count that together carry half of
 * the excess, and their bounding box. */
static void locate_excess(const shared *s, const double *r, dm_noise_test *t)
{
    const dm_dataset *d = s->d;
    double *ex = calloc(d->npose, sizeof(double));
    int *order = malloc(sizeof(int) * d->npose), n = 0;
    if (!ex || !order) {
        free(ex), free(order);
        out_of_memory(s);
        return;
    }
    for (int i = 0; i < d->n; i++)
        if (s->held[i])
            ex[d->s[i].pose_id] += r[i] * r[i] - 1.0; /* each sample's chi2 beyond its mean */
    double total = 0;
    for (int k = 0; k < d->npose; k++)
        if (ex[k] > 0) {
            order[n++] = k;
            total += ex[k];
        }
    for (int a = 1; a < n; a++) /* largest first; insertion sort keeps ties in pose order */
        for (int b = a; b > 0 && ex[order[b]] > ex[order[b - 1]]; b--) {
            int tmp = order[b];
            order[b] = order[b - 1];
            order[b - 1] = tmp;
        }
    for (int k = 0; k < 3; k++)
        t->lo[k] = INFINITY, t->hi[k] = -INFINITY;
    t->t_lo = INFINITY, t->t_hi = -INFINITY;
    double sum = 0;
    for (int a = 0; a < n && sum < 0.5 * total; a++) {
        sum += ex[order[a]];
        t->nregion++;
        for (int i = 0; i < d->n; i++) /* the samples of that pose */
            if (d->s[i].pose_id == order[a]) {
                for (int k = 0; k < 3; k++) {
                    t->lo[k] = fmin(t->lo[k], d->s[i].P[k]);
                    t->hi[k] = fmax(t->hi[k], d->s[i].P[k]);
                }
                t->t_lo = fmin(t->t_lo, d->s[i].t);
                t->t_hi = fmax(t->t_hi, d->s[i].t);
            }
    }
    free(ex);
    free(order);
}

/* The verdict's linearisation: weighted residuals r (all samples) and
 * their Jacobian in scaled parameters, J (d->n x n, column-major), and the
 * training rows' SVD: singular values s (descending) and right vectors VT
 * (n x n). */
typedef struct {
    int n, q, m;             /* parameters; combinations the training data see (s > 0);
                                training samples */
    double *r, *J;
    double s[DM_DIAG_MAXP], VT[DM_DIAG_MAXP * DM_DIAG_MAXP];
    /* a tracker run's nuisances, fitted with the model: their weighted
     * design N (d->n x nq) and the training rows' N'N = U diag(lam) U',
     * lam descending, qn of them seen. The effect columns of J are
     * orthogonal to N on the training rows (the nuisances are projected
     * out of every prediction), so the two parts of the prediction
     * covariance add. */
    int nq, qn;
    double *N;
    double lam[DM_NUISANCE_MAX], UN[DM_NUISANCE_MAX * DM_NUISANCE_MAX];
} linearisation;

/* Predictions of the fit's values perturbed in scaled parameter j (-1:
 * none) into pred. */
static int predict_scaled(problem *p, const double *x, int n, const double *sc, int j, double h,
                          double *pred)
{
    double xx[DM_DIAG_MAXP], value[2][DM_DIAG_MAXV];
    memcpy(xx, x, sizeof(double) * n);
    if (j >= 0)
        xx[j] += h * sc[j];
    to_values(p, xx, value);
    p->pred = pred;
    return predict_with(p, value, NULL, NULL);
}

/* The nuisances' part of the linearisation about the prediction pred. */
static int linearise_nuisances(const shared *s, const double *pred, linearisation *L)
{
    const dm_dataset *d = s->d;
    int q = L->nq = dm_nuisance_count(d);
    if (!q)
        return DM_OK;
    L->N = malloc(sizeof(double) * d->n * q);
    if (!L->N)
        return DM_ENOMEM;
    dm_nuisance_design(d, d->n, pred, L->N);
    double A[DM_NUISANCE_MAX * DM_NUISANCE_MAX] = {0}, lam[DM_NUISANCE_MAX];
    for (int i = 0; i < d->n; i++)
        for (int k = 0; k < q; k++) {
            L->N[(size_t)k * d->n + i] *= s->w[i];
            for (int l = 0; !s->held[i] && l <= k; l++)
                A[l + k * q] += L->N[(size_t)k * d->n + i] * L->N[(size_t)l * d->n + i];
        }
    if (LAPACKE_dsyev(LAPACK_COL_MAJOR, 'V', 'U', q, A, q, lam))
        return DM_ENOMEM;
    for (int e = 0; e < q; e++) { /* descending, as the SVD's */
        L->lam[e] = lam[q - 1 - e];
        memcpy(&L->UN[e * q], &A[(q - 1 - e) * q], sizeof(double) * q);
    }
    /* every combination the training rows see at all, those the fit leaves
     * at zero (dm_nuisance_seen) too: the check allows for more than was
     * fitted, the lenient side */
    while (L->qn < q && L->lam[L->qn] > 1e-12 * L->lam[0])
        L->qn++;
    return DM_OK;
}

static int linearise(const shared *s, const dm_fit *f, linearisation *L)
{
    const dm_dataset *d = s->d;
    problem p = {.s = s, .ncand = f->ncand, .cand = {f->cand[0], f->cand[1]}};
    double x[DM_DIAG_MAXP], sc[DM_DIAG_MAXP], value[2][DM_DIAG_MAXV];
    memcpy(value, f->value, sizeof value);
    memset(L, 0, sizeof *L);
    L->n = to_params(&p, 0, value, x);
    param_scales(&p, 0, sc);
    set_window(&p, 1.0);
    int m = 0, n = L->n;
    for (int i = 0; i < d->n; i++)
        m += !s->held[i];
    L->m = m;
    double *pred = malloc(sizeof(double) * d->n), *p1 = malloc(sizeof(double) * d->n);
    double *Jt = malloc(sizeof(double) * m * (n ? n : 1)), *U = malloc(sizeof(double) * m * (n ? n : 1));
    L->r = malloc(sizeof(double) * d->n);
    L->J = malloc(sizeof(double) * d->n * (n ? n : 1));
    p.predictor = dm_predictor_new(s->rb, d, s->o->na, s->o->nb, NULL);
    dm_progress_begin(s->pm, "verdict checks", "predictions", n + 1);
    int rc = !pred || !p1 || !Jt || !U || !L->r || !L->J || !p.predictor
                 ? DM_ENOMEM
                 : predict_scaled(&p, x, n, sc, -1, 0, pred);
    dm_progress_add(s->pm, 1);
    for (int i = 0; !rc && i < d->n; i++)
        L->r[i] = (d->s[i].value - pred[i]) * s->w[i];
    /* forward differences of 1e-4 scaled units: far below any uncertainty
     * that matters, far above round-off */
    for (int j = 0; !rc && j < n; j++) {
        rc = predict_scaled(&p, x, n, sc, j, 1e-4, p1);
        dm_progress_add(s->pm, 1);
        for (int i = 0; !rc && i < d->n; i++)
            L->J[(size_t)j * d->n + i] = (p1[i] - pred[i]) * s->w[i] / 1e-4;
    }
    for (int j = 0; !rc && j < n; j++)
        for (int i = 0, k = 0; i < d->n; i++)
            if (!s->held[i])
                Jt[(size_t)j * m + k++] = L->J[(size_t)j * d->n + i];
    if (!rc && n > 0 && m >= 1 && !svd(Jt, m, n, L->s, U, L->VT))
        while (L->q < (m < n ? m : n) && L->s[L->q] > 1e-9 * L->s[0])
            L->q++;
    if (!rc)
        rc = linearise_nuisances(s, pred, L);
    free(pred), free(p1), free(Jt), free(U);
    dm_predictor_free(p.predictor);
    if (!rc)
        dm_progress_end(s->pm);
    return rc;
}

static void linearisation_free(linearisation *L)
{
    free(L->r);
    free(L->J);
    free(L->N);
}

/* The prediction chi-square of the held-out samples i with keep(i): held
 * out, a residual is noise plus the error of the fitted parameters, whose
 * covariance the training data give: r = e - J_h dx with cov(dx) =
 * (J_t'J_t)^-1, so cov(r) = I + J_h (J_t'J_t)^-1 J_h', and r' cov(r)^-1 r
 * is chi2_N for an exact model. By Woodbury, in the combinations the
 * training data see (coordinates z = V'x, J_t'J_t = diag s^2):
 * r'r - b'(diag s^2 + Z_h'Z_h)^-1 b with Z_h = J_h V, b = Z_h'r. */
static double predictive_chi2(const shared *s, const linearisation *L, int group, int *count)
{
    assert(L->q >= 0 && L->q <= L->n && L->n <= DM_DIAG_MAXP && group <= DM_DIAG_MAXGROUP &&
           L->qn <= L->nq && L->nq <= DM_NUISANCE_MAX);
    const dm_dataset *d = s->d;
    enum { MAXZ = DM_DIAG_MAXP + DM_NUISANCE_MAX };
    int qe = L->q, q = qe + L->qn; /* the effects' coordinates, then the nuisances' */
    double M[MAXZ * MAXZ] = {0}, b[MAXZ] = {0}, rr = 0;
    for (int k = 0; k < q; k++)
        M[k * q + k] = k < qe ? L->s[k] * L->s[k] : L->lam[k - qe];
    *count = 0;
    for (int i = 0; i < d->n; i++) {
        if (!s->held[i] || (group >= 0 && group_of(d, &d->s[i]) != group))
            continue;
        double z[MAXZ];
        for (int k = 0; k < q; k++) {
            z[k] = 0;
            for (int j = 0; j < L->n && k < qe; j++)
                z[k] += L->J[(size_t)j * d->n + i] * L->VT[k + j * L->n];
            for (int j = 0; j < L->nq && k >= qe; j++)
                z[k] += L->N[(size_t)j * d->n + i] * L->UN[(k - qe) * L->nq + j];
            b[k] += z[k] * L->r[i];
        }
        for (int k = 0; k < q; k++)
            for (int l = 0; l < q; l++)
                M[l * q + k] += z[k] * z[l];
        rr += L->r[i] * L->r[i];
        (*count)++;
    }
    double x[MAXZ];
    memcpy(x, b, sizeof b);
    if (q == 0 || LAPACKE_dposv(LAPACK_COL_MAJOR, 'U', q, 1, M, q, x, q))
        return rr;
    double bx = 0;
    for (int k = 0; k < q; k++)
        bx += b[k] * x[k];
    return rr - bx;
}

/* The noise test of dm_noise_test on the verdict's held-out residuals. */
static void noise_test(const shared *s, const dm_diagnosis *dg, const linearisation *L,
                       dm_noise_test *t)
{
    const dm_dataset *d = s->d;
    int present[DM_DIAG_MAXGROUP + 1] = {0}, last = -1;
    memset(t, 0, sizeof *t);
    for (int i = 0; i < d->n; i++)
        if (s->held[i]) {
            present[group_of(d, &d->s[i])] = 1;
            t->nposes += d->s[i].pose_id != last;
            last = d->s[i].pose_id;
        }
    t->chi2 = predictive_chi2(s, L, -1, &t->n);
    t->limit = chi2_upper(t->n, 0.5 * DM_DIAG_BAND);
    t->sigmas = (t->chi2 - t->n) / sqrt(2.0 * t->n);
    for (int g = 0; g <= DM_DIAG_MAXGROUP; g++)
        if (present[g] && t->ngroup < DM_DIAG_MAXGROUP) {
            t->group[t->ngroup].group = g;
            t->group[t->ngroup].chi2 = predictive_chi2(s, L, g, &t->group[t->ngroup].n);
            t->ngroup++;
        }
    t->consistent = dg->sigma_known && t->chi2 <= t->limit;
    for (int k = 0; k < t->ngroup; k++) {
        t->group[k].limit = chi2_upper(t->group[k].n, 0.5 * DM_DIAG_BAND / t->ngroup);
        t->consistent &= t->group[k].chi2 <= t->group[k].limit;
    }
    locate_excess(s, L->r, t);
}

/* What the data determine: the training Jacobian's SVD. Each
 * combination's sign makes its largest weight positive; the 1-sigma is
 * scaled by the reduced chi-square when the fit misfits. */
static void identify(const shared *s, const dm_fit *f, const linearisation *L, dm_ident *id)
{
    memset(id, 0, sizeof *id);
    id->n = L->n;
    double scale = sqrt(misfit_scale(s, f->train_chi2, L->m, L->n));
    for (int k = 0; k < L->n; k++) {
        id->sigma[k] = k < L->q ? scale / L->s[k] : INFINITY;
        int big = 0;
        for (int j = 0; j < L->n; j++)
            if (fabs(L->VT[k + j * L->n]) > fabs(L->VT[k + big * L->n]))
                big = j;
        for (int j = 0; j < L->n; j++)
            id->weight[k][j] = L->VT[k + big * L->n] < 0 ? -L->VT[k + j * L->n] : L->VT[k + j * L->n];
        id->ndetermined += id->sigma[k] <= DM_DIAG_DETERMINED;
    }
}

/* The verdict's checks: its held-out residual against the noise, and what
 * the data determine of its parameters. */
static void check_verdict(const shared *s, dm_diagnosis *dg)
{
    linearisation L;
    int rc = linearise(s, &dg->best, &L);
    if (rc == DM_ENOMEM)
        out_of_memory(s);
    if (!rc) {
        noise_test(s, dg, &L, &dg->noise);
        dg->explained = dg->noise.consistent;
        identify(s, &dg->best, &L, &dg->ident);
    }
    linearisation_free(&L);
}

/* ---- entry points ------------------------------------------------------------- */

/* Predictions a diagnosis makes, as measured on the CLI tests' data: a
 * candidate takes about 25 on a survey and the equivalent of 13 whole
 * predictions on a tracker run (its first fits are on parts of the
 * record), the second-effect search about twice as many again, and the
 * verdict's checks one per parameter. */
#define PREDICTIONS_PER_FIT(kind) ((kind) == DM_DATA_TRACKER ? 13.0 : 25.0)
#define PAIR_FACTOR 3.0

/* Refused before any work when the whole diagnosis is estimated beyond
 * DM_WORK_LIMIT on its threads (dm_work_check). */
static int check_work(const dm_robot *rb, const dm_dataset *d, const dm_diagnose_opts *o,
                      dm_error *err)
{
    int ntab, nc = 0;
    const dm_effect *tab = dm_effects_table(&ntab);
    for (int c = 0; c < ntab; c++)
        nc += (tab[c].kinds & (1u << d->kind)) && &tab[c] != UNION;
    double bytes, one = dm_predict_estimate_s(rb, d, o->na, o->nb, &bytes);
    double fits = nc * PREDICTIONS_PER_FIT(d->kind) * (o->pairs ? PAIR_FACTOR : 1) + DM_DIAG_MAXP;
    int threads = thread_count(o);
    char what[sizeof d->source + 160];
    snprintf(what, sizeof what, "diagnose: %s: %d samples, %d candidates, about %.3g "
             "predictions of %.3g s each on %d thread%s", d->source, d->n, nc, fits, one,
             threads, threads > 1 ? "s" : "");
    return dm_work_check(what, (dm_work){fits * one / threads, bytes * threads, 0},
                         DM_WORK_LIMIT,
                         d->kind == DM_DATA_TRACKER ? "a shorter stretch of the record or mesh 2,2"
                                                    : "fewer poses or a coarser mesh",
                         o->force_long, err);
}

/* Weights 1/sigma, or without sigma the baseline's RMS residual (pred):
 * chi2 is then in units of its mean square. Returns whether sigma is known. */
static int weights(const dm_dataset *d, const double *pred, double *w)
{
    int known = 1;
    double ms = 0;
    for (int i = 0; i < d->n; i++) {
        known &= d->s[i].sigma > 0;
        ms += (d->s[i].value - pred[i]) * (d->s[i].value - pred[i]);
    }
    for (int i = 0; i < d->n; i++)
        w[i] = known ? 1.0 / d->s[i].sigma : 1.0 / sqrt(ms / d->n + 1e-300);
    return known;
}

static int diagnose(const dm_robot *rb, const dm_dataset *d, const dm_diagnose_opts *o,
                    dm_diagnosis *dg, dm_error *err);
static int fit_effects(const dm_robot *rb, const dm_dataset *d, const char *const *names, int n,
                       const double start[][DM_DIAG_MAXV], const dm_diagnose_opts *o,
                       dm_fit *f, dm_error *err);

/* The fits' thread count resolved, and BLAS on one thread while they run:
 * OpenBLAS's OpenMP build threads its kernels outside active parallel
 * regions (one fit thread is not an active region), and threaded kernels
 * round differently, so without this one thread and three gave different
 * fits on a Zen 3 machine. */
static dm_threads_saved serial_stage(const dm_diagnose_opts *o, dm_diagnose_opts *resolved)
{
    *resolved = *o;
    resolved->threads = dm_threads_count(o->threads);
    return dm_threads_serial_blas();
}

int dm_diagnose(const dm_robot *rb, const dm_dataset *d, const dm_diagnose_opts *o,
                dm_diagnosis *dg, dm_error *err)
{
    dm_pairing pg = {0};
    dm_dataset paired;
    if (d->kind == DM_DATA_MODAL && d->pair) { /* pair once, with the robot given */
        int rc = dm_pairing_make(rb, d, o->na, o->nb, &pg, err);
        if (!rc && (rc = dm_pairing_apply(d, &pg, &paired, err)))
            dm_pairing_free(&pg);
        if (rc)
            return rc;
    }
    dm_diagnose_opts resolved;
    dm_threads_saved saved = serial_stage(o, &resolved);
    int rc = diagnose(rb, pg.pair ? &paired : d, &resolved, dg, err);
    dm_threads_restore(saved);
    if (pg.pair)
        dm_dataset_free(&paired);
    dg->pairing = pg;
    if (rc)
        dm_pairing_free(&dg->pairing);
    return rc;
}

int dm_fit_effects(const dm_robot *rb, const dm_dataset *d, const char *const *names, int n,
                   const double start[][DM_DIAG_MAXV], const dm_diagnose_opts *o, dm_fit *f,
                   dm_error *err)
{
    dm_diagnose_opts resolved;
    dm_threads_saved saved = serial_stage(o, &resolved);
    int rc = fit_effects(rb, d, names, n, start, &resolved, f, err);
    dm_threads_restore(saved);
    return rc;
}

/* The baseline's held-out misfit before the nuisances: what they alone
 * gain is reported apart from any effect's gain. Held-out samples are
 * fitted by nothing, the frame's placement included: a '# frame: tracker'
 * run is placed again on the training samples (the reader placed it on
 * all of them), so that the figure without nuisances and the one with
 * them (fitted on the training samples, applied unchanged to the held-out
 * ones) are judged alike. DM_ENOMEM or DM_OK. */
static int baseline_without_nuisances(const shared *s, dm_diagnosis *dg, const double *pred)
{
    const dm_dataset *d = s->d;
    dg->nnuisance = dm_nuisance_count(d);
    double *value = malloc(sizeof(double) * d->n), hs = 0, hc = 0, ts = 0;
    if (!value)
        return DM_ENOMEM;
    dm_nuisance_place_on(d, s->held, value);
    for (int i = 0; i < d->n; i++) {
        double r = value[i] - pred[i];
        hs += s->held[i] ? r * r : 0;
        hc += s->held[i] ? r * r * s->w[i] * s->w[i] : 0;
        ts += s->held[i] ? 0 : r * r;
    }
    dg->raw_held_chi2 = hc;
    dg->raw_held_rms = sqrt(hs / dg->n_held);
    dg->raw_train_rms = sqrt(ts / dg->n_train);
    /* the nuisance move beyond which a model compensates (dm_nuisance_shift):
     * where the data show an effect's rigid part (a base-frame run) their
     * misfit before the nuisances bounds what a genuine effect needs; where
     * the reader's placement took that part, DM_DIAG_NUISANCE_MOVE_M does */
    dg->compensating_m = fmax(DM_DIAG_NUISANCE_MOVE_M, dg->raw_train_rms);
    free(value);
    return DM_OK;
}

/* The nuisances of the verdict's model (the baseline's when no effect is
 * found), with their 1-sigma (scaled by the reduced chi-square when the
 * model misfits), and what they gain against the baseline without them. */
static int report_nuisances(const shared *s, dm_diagnosis *dg, dm_error *err)
{
    const dm_dataset *d = s->d;
    dm_robot rb = *s->rb;
    double *pred = malloc(sizeof(double) * d->n);
    int rc = pred ? DM_OK : dm_fail(err, DM_ENOMEM, "out of memory");
    if (!rc && dg->found)
        rc = dm_fit_apply(s->rb, &dg->best, &rb, err);
    if (!rc)
        rc = dm_predict(&rb, d, s->o->na, s->o->nb, pred, err);
    if (!rc)
        rc = dm_nuisance_apply(d, d->n, s->held, s->w, pred, 1.0, &dg->nuisance);
    if (!rc) {
        int m = dg->n_train, p = dg->nnuisance + (dg->found ? dg->best.nfree : 0);
        double scale = sqrt(misfit_scale(s, chi2(s, pred, 0), m, p));
        dm_nuisance_fit_scale(&dg->nuisance, scale);
        dg->nuisance_gain_percent = gain_against(dg, dg->raw_held_chi2, dg->base_held_chi2);
    }
    free(pred);
    return rc;
}

static int diagnose(const dm_robot *rb, const dm_dataset *d, const dm_diagnose_opts *o,
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
    memo made = {0};
    dm_progress_meter pm;
    dm_progress_meter_init(&pm, o->progress, o->progress_user);
    shared s = {.rb = rb, .d = d, .o = o, .held = held, .w = w, .nomem = &nomem, .memo = &made,
                .pm = &pm};
    split_samples(d, held);
    for (int i = 0; i < d->n; i++) {
        dg->n_held += held[i];
        if (!held[i])
            s.train_end_s = fmax(s.train_end_s, d->s[i].t);
    }
    dg->n_train = d->n - dg->n_held;
    int rc = (dg->n_held < 3 || dg->n_train < 3)
                 ? dm_fail(err, DM_EINVAL, "%s: too little data to hold a third out", d->source)
                 : check_work(rb, d, o, err);
    if (!rc)
        rc = dm_predict(rb, d, o->na, o->nb, pred, err);
    dm_nuisance_fit base_nuisance;
    double *design = NULL;
    if (!rc) {
        dg->sigma_known = s.sigma_known = weights(d, pred, w);
        rc = baseline_without_nuisances(&s, dg, pred);
        if (!rc && dg->nnuisance && !(design = malloc(sizeof(double) * d->n * dg->nnuisance)))
            rc = DM_ENOMEM;
        if (design)
            dm_nuisance_design(d, d->n, pred, design);
        if (!rc)
            rc = dm_nuisance_apply(d, d->n, held, w, pred, 1.0, &base_nuisance);
        if (rc)
            rc = dm_fail(err, rc, "out of memory");
        s.base_nuisance = design ? &base_nuisance : NULL;
        s.nuisance_design = design;
    }
    if (!rc) {
        double hs = 0;
        for (int i = 0; i < d->n; i++)
            hs += held[i] ? (d->s[i].value - pred[i]) * (d->s[i].value - pred[i]) : 0;
        dg->base_train_chi2 = chi2(&s, pred, 0);
        dg->base_held_chi2 = chi2(&s, pred, 1);
        dg->base_held_rms = sqrt(hs / dg->n_held);
        dg->significant = dg->sigma_known
                              ? dg->base_held_chi2 > dg->n_held + 4 * sqrt(2.0 * dg->n_held)
                              : 1;
        double need = 9 + log((double)dg->n_held);
        dg->base_score = held_score(dg, dg->base_held_chi2); /* no parameters */
        rank_singles(&s, dg, need);
        choose_single(dg, need);
        dg->found = dg->significant && usable(&dg->best) && dg->base_score - dg->best.score > need;
        if (dg->found) {
            find_ties(dg);
            if (o->pairs)
                add_second_effect(&s, dg, need);
            check_verdict(&s, dg);
        } else {
            dg->has_simpler_choice = 0;
        }
        if (dg->nnuisance && !nomem)
            rc = report_nuisances(&s, dg, err);
        if (nomem)
            rc = dm_fail(err, DM_ENOMEM, "%s: out of memory while fitting the effects",
                         d->source);
    }
    memo_free(&made);
    free(design);
    free(held);
    free(pred);
    free(w);
    return rc;
}

static int fit_effects(const dm_robot *rb, const dm_dataset *d, const char *const *names, int n,
                       const double start[][DM_DIAG_MAXV], const dm_diagnose_opts *o,
                       dm_fit *f, dm_error *err)
{
    problem p = {.ncand = n};
    int np = 0;
    if (n < 1 || n > 2)
        return dm_fail(err, DM_EINVAL, "fit one or two effects, not %d", n);
    for (int i = 0; i < n; i++) {
        if (!(p.cand[i] = dm_effects_find(names[i])))
            return dm_fail(err, DM_EINVAL, "'%s' is not a candidate effect", names[i]);
        np += p.cand[i]->nparam;
    }
    if (np > DM_DIAG_MAXP)
        return dm_fail(err, DM_EINVAL, "%d parameters: at most %d", np, DM_DIAG_MAXP);
    char *held = calloc(d->n, 1); /* nothing held out */
    double *pred = malloc(sizeof(double) * d->n), *w = malloc(sizeof(double) * d->n);
    int rc = !held || !pred || !w ? dm_fail(err, DM_ENOMEM, "out of memory")
                                  : dm_predict(rb, d, o->na, o->nb, pred, err);
    if (!rc) {
        dm_diagnosis dg = {.n_train = d->n};
        int nomem = 0;
        dm_progress_meter none; /* one fit: nothing to report */
        dm_progress_meter_init(&none, NULL, NULL);
        shared s = {.rb = rb, .d = d, .o = o, .held = held, .w = w, .nomem = &nomem, .pm = &none};
        dg.sigma_known = s.sigma_known = weights(d, pred, w);
        for (int i = 0; i < d->n; i++)
            s.train_end_s = fmax(s.train_end_s, d->s[i].t);
        double st[2][DM_DIAG_MAXV];
        if (start)
            memcpy(st, start, sizeof st);
        p.s = &s;
        fit(&p, &dg, start ? st : NULL, f);
        if (nomem)
            rc = dm_fail(err, DM_ENOMEM, "%s: out of memory while fitting %s", d->source,
                         names[0]);
        else if (!f->ok)
            rc = dm_fail(err, DM_ENUMERIC, "the fit of %s failed", names[0]);
    }
    free(held);
    free(pred);
    free(w);
    return rc;
}
