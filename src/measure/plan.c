/* Experiment design for the diagnosis (see dm_plan.h). */
#include "dm_plan.h"

#include <assert.h>
#include <lapacke.h>
#include <limits.h>
#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "dm_grid.h"
#include "dm_kinematics.h"
#include "dm_predict.h"
#include "dm_rng.h"
#include "dm_synth.h"
#include "dm_threads.h"
#include "dm_trajectory.h"
#include "dm_work.h"

#define DETECT 5.0     /* "seen": the effect moves the data by 5 sigma (norm over samples) */
#define RANDOM_DRAWS 64
#define NPATH 22 /* the tracker paths of the family (path_spec) */
#define NPICK 2  /* with the tracker's nuisances, pick cycles join it (path_spec) */
#define NPATH_ALL (NPATH + NPICK)
#define FD_STEP 1e-3   /* scaled units: 0.1 % of a spring, far below any 1-sigma that matters */
#define RIDGE 1e-6     /* added to F's diagonal while choosing: a 1-sigma of 1000 scaled units */
#define BISECTIONS 30  /* steps of a detectable magnitude's bisection in log10 */

/* ---- effects ------------------------------------------------------------------- */

/* The effect specs of dm_effects.h, each a candidate these data can see. */
int dm_plan_parse_effects(const char *spec, dm_data_kind kind, dm_plan_effect *eff, int *count,
                          dm_error *err)
{
    dm_effects_spec s[DM_PLAN_MAXEFF];
    int n = 0, rc = dm_effects_parse_spec(spec, s, DM_PLAN_MAXEFF, &n, err);
    for (int i = 0; i < n && !rc; i++) {
        const dm_effect *c = s[i].effect;
        if (!c->kinds)
            return dm_fail(err, DM_EINVAL, "effects '%s': '%s' is not a candidate effect "
                           "(see deltamap diagnose --help)", spec, c->name);
        if (!(c->kinds & (1u << kind)))
            return dm_fail(err, DM_EINVAL, "effects '%s': %s data cannot see %s", spec,
                           dm_data_kind_name(kind), c->name);
        eff[i].cand = c;
        memcpy(eff[i].value, s[i].value, sizeof eff[i].value);
    }
    if (!rc)
        *count = n;
    return rc;
}

/* The named effects' parameters in fitted units (log10, or as they are
 * for linear candidates), with their scales. */
typedef struct {
    const dm_robot *rb;
    const dm_plan_effect *eff;
    int neff, p;
    double x0[DM_DIAG_MAXP], sc[DM_DIAG_MAXP];
    const dm_plan_opts *o;
    const struct nuisance_basis *nb; /* the assessment's, NULL: none (signature()) */
} model;

static void model_init(model *m, const dm_robot *rb, const dm_plan_effect *eff, int neff,
                       const dm_plan_opts *o)
{
    memset(m, 0, sizeof *m);
    m->rb = rb, m->eff = eff, m->neff = neff, m->o = o;
    for (int e = 0; e < neff; e++)
        for (int k = 0; k < eff[e].cand->nparam; k++, m->p++) {
            m->x0[m->p] = eff[e].cand->linear ? eff[e].value[k] : log10(eff[e].value[k]);
            m->sc[m->p] = dm_effects_param_scale(eff[e].cand, k);
        }
}

/* The robot with the effects of `only` (-1: all) at parameters x. */
static int robot_at(const model *m, const double *x, int only, dm_robot *rb, dm_error *err)
{
    *rb = *m->rb;
    for (int e = 0, j = 0; e < m->neff; e++) {
        const dm_effect *c = m->eff[e].cand;
        double v[DM_DIAG_MAXV];
        for (int k = 0; k < DM_DIAG_MAXV; k++)
            v[k] = k >= c->nparam ? 1.0 : c->linear ? x[j + k] : pow(10.0, x[j + k]);
        j += c->nparam;
        if (only >= 0 && e != only)
            continue;
        int rc = dm_effects_apply(rb, c->name, v, err);
        if (rc)
            return rc;
    }
    return DM_OK;
}

/* Predictions at parameters x with the workspace pw (made for the data). */
static int predict_at(const model *m, dm_predictor *pw, const double *x, int only, double *pred,
                      dm_error *err)
{
    dm_robot rb;
    int rc = robot_at(m, x, only, &rb, err);
    return rc ? rc : dm_predictor_run(pw, &rb, pred, err);
}

static int thread_count(const dm_plan_opts *o)
{
    return o->threads > 0 ? o->threads : omp_get_max_threads();
}

/* A pose analysed: one unit of the survey's sensitivities (from the
 * predictor's thread). */
static void pose_done(void *meter) { dm_progress_add(meter, 1); }

/* Sensitivities J (d->n x p, column-major) of the predictions to the
 * scaled parameters at the magnitudes, in units of the noise; pred0: the
 * predictions there. The p + 1 predictions run in parallel, each thread
 * with one prediction workspace for all of its predictions. Progress: each
 * pose analysed (per_pose) or each prediction is a unit of pm's stage. */
static int sensitivities(const model *m, const dm_dataset *d, double noise, double *pred0,
                         double *J, dm_progress_meter *pm, int per_pose, dm_error *err)
{
    int p = m->p, rc = DM_OK;
#pragma omp parallel num_threads(thread_count(m->o))
    {
        dm_error e;
        dm_predictor *pw = dm_predictor_new(m->rb, d, m->o->na, m->o->nb, &e);
        if (pw && per_pose && pm->fn)
            dm_predictor_on_work(pw, pose_done, pm);
#pragma omp for schedule(dynamic, 1)
        for (int j = -1; j < p; j++) {
            double x[DM_DIAG_MAXP];
            memcpy(x, m->x0, sizeof x);
            if (j >= 0)
                x[j] += FD_STEP * m->sc[j];
            double *out = j < 0 ? pred0 : J + (size_t)j * d->n;
            int r = pw ? predict_at(m, pw, x, -1, out, &e) : DM_ENOMEM;
            if (!per_pose)
                dm_progress_add(pm, 1);
#pragma omp critical(dm_plan_error)
            if (r && !rc) {
                rc = r;
                if (err)
                    *err = e;
            }
        }
        dm_predictor_free(pw);
    }
    for (int j = 0; !rc && j < p; j++)
        for (int i = 0; i < d->n; i++)
            J[(size_t)j * d->n + i] = (J[(size_t)j * d->n + i] - pred0[i]) / (FD_STEP * noise);
    return rc;
}

/* ---- information and its determinant ------------------------------------------- */

/* log det of the p x p matrix F (+ ridge), by Cholesky; -inf if singular.
 * With inv, its inverse too. */
static double logdet(const double *F, int p, double ridge, double *inv)
{
    assert(p >= 0 && p <= DM_DIAG_MAXP);
    double A[DM_DIAG_MAXP * DM_DIAG_MAXP];
    memcpy(A, F, sizeof(double) * p * p);
    for (int j = 0; j < p; j++)
        A[j * p + j] += ridge;
    if (p == 0)
        return 0;
    if (LAPACKE_dpotrf(LAPACK_COL_MAJOR, 'U', p, A, p))
        return -INFINITY;
    double s = 0;
    for (int j = 0; j < p; j++)
        s += 2 * log(A[j * p + j]);
    if (inv) {
        memcpy(inv, A, sizeof(double) * p * p);
        if (LAPACKE_dpotri(LAPACK_COL_MAJOR, 'U', p, inv, p))
            return -INFINITY;
        for (int a = 0; a < p; a++) /* dpotri fills the upper triangle */
            for (int b = a + 1; b < p; b++)
                inv[a * p + b] = inv[b * p + a];
    }
    return s;
}

/* Information of each unit (a pose with its modes, a pose with one force
 * direction, or a path): rows [first[u], first[u + 1]) of J. */
static void unit_information(const double *J, int nrow, int p, const int *first, int nunit,
                             double *info)
{
    assert(p >= 0 && p <= DM_DIAG_MAXP && nunit >= 0 && first[nunit] <= nrow);
    for (int u = 0; u < nunit; u++)
        for (int a = 0; a < p; a++)
            for (int b = 0; b < p; b++) {
                double v = 0;
                for (int i = first[u]; i < first[u + 1]; i++)
                    v += J[(size_t)a * nrow + i] * J[(size_t)b * nrow + i];
                info[(size_t)u * p * p + b * p + a] = v;
            }
}

static void add_unit(double *F, const double *info, int u, int p, double sign)
{
    assert(u >= 0 && p >= 0 && p <= DM_DIAG_MAXP);
    for (int q = 0; q < p * p; q++)
        F[q] += sign * info[(size_t)u * p * p + q];
}

/* D-optimal choice of n distinct units: greedy, then exchanges (each
 * chosen unit against every other) while the determinant grows. Scans in
 * unit order and keeps the first of equals, so it is deterministic. */
static void choose_units(const double *info, int nunit, int p, int n, int *sel,
                         dm_progress_meter *pm)
{
    assert(n >= 0 && n <= nunit && p <= DM_DIAG_MAXP);
    double F[DM_DIAG_MAXP * DM_DIAG_MAXP] = {0}, G[DM_DIAG_MAXP * DM_DIAG_MAXP];
    char *used = calloc(nunit, 1);
    if (!used)
        return;
    dm_progress_begin(pm, "choosing poses", "scans", n);
    for (int i = 0; i < n; i++) {
        int best = -1;
        double bv = -INFINITY;
        for (int u = 0; u < nunit; u++) {
            if (used[u])
                continue;
            memcpy(G, F, sizeof(double) * p * p);
            add_unit(G, info, u, p, 1);
            double v = logdet(G, p, RIDGE, NULL);
            if (best < 0 || v > bv)
                best = u, bv = v;
        }
        sel[i] = best;
        used[best] = 1;
        add_unit(F, info, best, p, 1);
        dm_progress_add(pm, 1);
    }
    dm_progress_end(pm);
    for (int pass = 0, changed = 1; changed && pass < 50; pass++) {
        changed = 0;
        dm_progress_begin(pm, "exchanging poses", "scans", n);
        for (int i = 0; i < n; i++) {
            double cur = logdet(F, p, RIDGE, NULL), bv = cur;
            int best = -1;
            for (int u = 0; u < nunit; u++) {
                if (used[u])
                    continue;
                memcpy(G, F, sizeof(double) * p * p);
                add_unit(G, info, sel[i], p, -1);
                add_unit(G, info, u, p, 1);
                double v = logdet(G, p, RIDGE, NULL);
                if (v > bv + 1e-9 * fabs(bv) + 1e-12)
                    best = u, bv = v;
            }
            if (best >= 0) {
                add_unit(F, info, sel[i], p, -1);
                add_unit(F, info, best, p, 1);
                used[sel[i]] = 0;
                used[best] = 1;
                sel[i] = best;
                changed = 1;
            }
            dm_progress_add(pm, 1);
        }
        dm_progress_end(pm);
    }
    free(used);
}

/* 1-sigma of each scaled parameter for the units sel[0..n-1]; log det. */
static double design_sigma(const double *info, const int *sel, int n, int p, double *sig)
{
    assert(n >= 0 && p >= 0 && p <= DM_DIAG_MAXP);
    double F[DM_DIAG_MAXP * DM_DIAG_MAXP] = {0}, inv[DM_DIAG_MAXP * DM_DIAG_MAXP];
    for (int i = 0; i < n; i++)
        add_unit(F, info, sel[i], p, 1);
    double ld = logdet(F, p, 0, inv);
    for (int j = 0; j < p; j++)
        sig[j] = isfinite(ld) && inv[j * p + j] > 0 ? sqrt(inv[j * p + j]) : INFINITY;
    return ld;
}

static int ascending(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* The median of v[0 .. n-1] (n >= 1; v is sorted in place). */
static double median(double *v, int n)
{
    assert(n >= 1);
    qsort(v, (size_t)n, sizeof *v, ascending);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/* The random candidates' figures: the median log det over the ok designs
 * (ld[d]) and, per parameter, the median 1-sigma (sig[d][j]); medians, not
 * means: a random design that barely determines the parameters has a near
 * singular information matrix whose smallest eigenvalue, set by the
 * predictions' round-off, would sway a mean (docs/diagnosis.md). */
static double random_medians(double *ld, double (*sig)[DM_DIAG_MAXP], int ok, int p,
                             double *sig_median)
{
    double col[RANDOM_DRAWS > NPATH_ALL ? RANDOM_DRAWS : NPATH_ALL];
    assert(ok <= (int)(sizeof col / sizeof col[0]));
    for (int j = 0; j < p; j++) {
        for (int d = 0; d < ok; d++)
            col[d] = sig[d][j];
        sig_median[j] = ok ? median(col, ok) : INFINITY;
    }
    return ok ? median(ld, ok) : -INFINITY;
}

/* The same for random designs: n distinct units drawn RANDOM_DRAWS times;
 * median 1-sigma and log det over the draws that determine everything. */
static double random_sigma(const double *info, int nunit, int p, int n, uint64_t seed,
                           double *sig)
{
    assert(n >= 0 && n <= nunit && p <= DM_DIAG_MAXP);
    dm_rng rng = {seed * 0x9E3779B97F4A7C15ull + 7};
    int *sel = malloc(sizeof(int) * nunit), ok = 0;
    double lds[RANDOM_DRAWS], sigs[RANDOM_DRAWS][DM_DIAG_MAXP];
    for (int d = 0; sel && d < RANDOM_DRAWS; d++) {
        for (int u = 0; u < nunit; u++)
            sel[u] = u;
        for (int i = 0; i < n; i++) { /* partial Fisher-Yates */
            int k = i + (int)(dm_rng_uniform(&rng) * (nunit - i));
            int t = sel[i];
            sel[i] = sel[k];
            sel[k] = t;
        }
        double l = design_sigma(info, sel, n, p, sigs[ok]);
        if (isfinite(l))
            lds[ok++] = l;
    }
    free(sel);
    return random_medians(lds, sigs, ok, p, sig);
}

/* ---- a tracker run's nuisances -------------------------------------------------- */

/* A combination of the nuisances is seen when its singular value of the
 * column-normalised design is above this share of the largest (the
 * eigenvalue share 1e-12 of dm_nuisance_apply). */
#define NUIS_SEEN 1e-6

/* The nuisances' design at a run's samples, N = U S V' with its columns
 * scaled to unit norm (norm), and the orthonormal basis U of the
 * combinations the run sees (rank columns). */
typedef struct nuisance_basis {
    int n, q, rank;
    double *U;
    double s[DM_NUISANCE_MAX], VT[DM_NUISANCE_MAX * DM_NUISANCE_MAX], norm[DM_NUISANCE_MAX];
} nuisance_basis;

/* The run's nuisances as the plan asks for them (dm_plan_opts.nuisance). */
static void mark_nuisances(const dm_plan_opts *o, dm_dataset *d)
{
    d->nuisance.on = o->nuisance > 0;
    d->nuisance.tracker_frame = o->nuisance > 0 && o->frame_tracker;
    d->nuisance.clock_rate = o->nuisance > 1;
}

/* The basis about the model's prediction pred (elastic error of the
 * samples); DM_ENOMEM or DM_OK. */
static int nuisance_basis_make(const dm_dataset *d, const double *pred, nuisance_basis *b)
{
    memset(b, 0, sizeof *b);
    int n = b->n = d->n, q = b->q = dm_nuisance_count(d);
    assert(q > 0 && q <= DM_NUISANCE_MAX);
    double *N = malloc(sizeof(double) * n * q), superb[DM_NUISANCE_MAX];
    b->U = malloc(sizeof(double) * n * q);
    if (!N || !b->U || n < q) {
        free(N);
        return DM_ENOMEM;
    }
    dm_nuisance_design(d, n, pred, N);
    for (int k = 0; k < q; k++) {
        double ss = 0;
        for (int i = 0; i < n; i++)
            ss += N[(size_t)k * n + i] * N[(size_t)k * n + i];
        b->norm[k] = ss > 0 ? sqrt(ss) : 1;
        for (int i = 0; i < n; i++)
            N[(size_t)k * n + i] /= b->norm[k];
    }
    int rc = LAPACKE_dgesvd(LAPACK_COL_MAJOR, 'S', 'S', n, q, N, n, b->s, b->U, n, b->VT, q,
                            superb);
    free(N);
    if (rc)
        return DM_ENOMEM; /* dgesvd fails only without workspace */
    while (b->rank < q && b->s[b->rank] > NUIS_SEEN * b->s[0])
        b->rank++;
    return DM_OK;
}

static void nuisance_basis_free(nuisance_basis *b) { free(b->U); }

/* J's ncol columns projected orthogonal to the nuisances: J'J becomes the
 * Schur complement of the nuisances' block in the joint information, the
 * effects' information after the nuisances are marginalised. */
static void project_out(const nuisance_basis *b, double *J, int ncol)
{
    for (int j = 0; j < ncol; j++) {
        double *c = J + (size_t)j * b->n;
        for (int k = 0; k < b->rank; k++) {
            const double *u = b->U + (size_t)k * b->n;
            double uc = 0;
            for (int i = 0; i < b->n; i++)
                uc += u[i] * c[i];
            for (int i = 0; i < b->n; i++)
                c[i] -= uc * u[i];
        }
    }
}

/* ---- candidates -------------------------------------------------------------------- */

static int well_placed(const dm_robot *rb, const double P[3])
{
    dm_pose pose;
    return !dm_kin_inverse(rb, P, &pose, NULL) && pose.cond <= rb->singular_cond;
}

/* Candidate poses: the region's grid points that qualify, or poses drawn. */
static int candidate_poses(const dm_robot *rb, const dm_plan_opts *o, double **out, int *count,
                           dm_error *err)
{
    dm_grid g;
    long total = o->ncandidates > 0 ? o->ncandidates : 256;
    int rc = o->region ? dm_grid_parse(o->region, &g, err) : DM_OK;
    if (rc)
        return rc;
    if (o->region && (total = dm_grid_points(&g)) > 100000)
        return dm_fail(err, DM_EINVAL, "region '%s': %ld points, at most 100000", o->region,
                       total);
    double *P = malloc(sizeof(double) * 3 * total);
    if (!P)
        return dm_fail(err, DM_ENOMEM, "out of memory");
    int n = 0;
    dm_rng rng = {o->seed * 0x2545F4914F6CDD1Dull + 3};
    for (long k = 0; k < total; k++) {
        if (!o->region) {
            if (dm_synth_draw_pose(rb, &rng, P + 3 * n))
                break;
            n++;
            continue;
        }
        int idx[3] = {(int)(k % g.axis[0].count), (int)(k / g.axis[0].count % g.axis[1].count),
                      (int)(k / g.axis[0].count / g.axis[1].count)};
        dm_grid_position(&g, idx, P + 3 * n);
        n += well_placed(rb, P + 3 * n);
    }
    if (!n) {
        free(P);
        return o->region ? dm_fail(err, DM_EINVAL,
                                   "region '%s': no reachable pose with cond(J) <= %g in it",
                                   o->region, rb->singular_cond)
                         : dm_fail(err, DM_EUNREACHABLE, "no reachable pose found near home");
    }
    *out = P;
    *count = n;
    return DM_OK;
}

/* ---- what a plan costs, judged before its predictions -------------------------- */

/* Predictions of the assessment: the design's sensitivities and, per
 * effect, a bisection of 30 steps on its signature. */
#define ASSESS_PREDICTIONS(m) ((m)->p + 1 + (2.0 + BISECTIONS) * (m)->neff)
/* One log det of a p x p information (Cholesky through LAPACKE, its
 * overhead included) and the exchange passes a design takes as a rule. */
#define LOGDET_S(p) (2e-7 + 2e-9 * (double)(p) * (p) * (p))
#define EXCHANGE_PASSES 4

/* Survey: p + 1 predictions of the candidates' poses, the greedy choice
 * and the exchanges (n x units log dets each), the assessment; memory:
 * the units' information and the candidates' sensitivities. */
static int check_survey(const model *m, const dm_dataset *cand, int nunit, dm_error *err)
{
    const dm_plan_opts *o = m->o;
    int p = m->p, n = o->npose, threads = thread_count(o);
    double per_pose = dm_predict_cost_s(m->rb, o->kind, 1, o->na, o->nb);
    double est = (p + 1.0) * cand->npose * per_pose / fmin(threads, p + 1.0) +
                 (1.0 + EXCHANGE_PASSES) * n * (double)nunit * LOGDET_S(p) +
                 ASSESS_PREDICTIONS(m) * n * per_pose;
    double bytes = (double)nunit * p * p * sizeof(double) +
                   (double)cand->n * (p + 1) * sizeof(double);
    char what[160];
    snprintf(what, sizeof what, "plan: %d of %d candidate%s for %d parameter%s", n, nunit,
             nunit == 1 ? "" : "s", p, p == 1 ? "" : "s");
    return dm_work_check(what, (dm_work){est, bytes, 0}, DM_WORK_LIMIT,
                         "fewer poses or a smaller region", o->force_long, err);
}

/* The tracker paths the plan chooses from: the option's, or the family
 * (with the nuisances, the pick cycles too). */
static int path_count(const dm_plan_opts *o) { return o->path ? 1 : o->nuisance ? NPATH_ALL : NPATH; }

/* Tracker: p + 1 predictions of each of the paths of n samples (in
 * parallel over the parameters), the assessment of the chosen one. */
static int check_tracker(const model *m, dm_error *err)
{
    const dm_plan_opts *o = m->o;
    int p = m->p, n = o->npose, threads = thread_count(o), npath = path_count(o);
    double run = dm_predict_cost_s(m->rb, o->kind, n, o->na, o->nb);
    double est = npath * (p + 1.0) * run / threads + ASSESS_PREDICTIONS(m) * run;
    double bytes = fmin(threads, npath) * 3.0 * n * (p + 2) * sizeof(double) +
                   3.0 * n * sizeof(dm_sample) + 4.0 * n * sizeof(double);
    char what[160];
    snprintf(what, sizeof what, "plan: a tracker run of %d samples, %d paths, %d parameter%s",
             n, npath, p, p == 1 ? "" : "s");
    int rc = dm_work_check(what, (dm_work){est, bytes, 0}, DM_WORK_LIMIT, "fewer samples",
                           o->force_long, err);
    if (!rc && n > INT_MAX / 3) /* the samples are counted in int */
        rc = dm_fail(err, DM_EINVAL, "%s: %.3g samples, at most %d", what, 3.0 * n, INT_MAX);
    return rc;
}

static const double DIRS[7][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1},           {1, 1, 1},
                                  {1, -1, 1}, {-1, 1, 1}, {-1, -1, 1}};

/* ---- tracker paths -------------------------------------------------------------- */

/* The family of paths about home lasting n samples at 1 ms, no faster
 * than the standard move's 50 m/s^2 (docs/model.md §5): circles in the three
 * planes (two radii, centripetal 20 and 50 m/s^2) and bang-bang moves (two
 * lengths, five directions, 50 m/s^2, within half the record, shortened to
 * fit), then a dwell in which the structure rings down; with the tracker's
 * nuisances also the pick cycle (25 mm up, 305 across, 25 down: heights and
 * reach that a rigid motion of the frame cannot mimic) along x and along
 * y, centred on home, at 50 m/s^2 (cycloidal: 2 pi wsum^2 / T^2 with wsum
 * the sum of the segments' sqrt(length), 0.308 s), then a dwell. 0, or -1
 * when the record is too short for the path. */
#define AMAX 50.0
static int path_spec(const dm_robot *rb, int k, int n, char *spec, size_t len)
{
    assert(k >= 0 && k < NPATH_ALL);
    static const char *const PLANES[3] = {"xy", "xz", "yz"};
    static const double MOVE[5][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 1, 1}, {1, -1, 0.5}};
    const double *h = rb->home_m, la = rb->arm_length_m, T = (n - 1) * 1e-3;
    if (k < 12) {
        double r = (k % 2 ? 0.25 : 0.1) * la * (k / 4 == 0 ? 1.0 : 0.5);
        double a = k / 2 % 2 ? AMAX : 0.4 * AMAX;
        snprintf(spec, len, "circle:centre=%.6g,%.6g,%.6g;radius=%.6g;rate=%.9g;duration=%.9g;plane=%s",
                 h[0], h[1], h[2], r, sqrt(a / r), T, PLANES[k / 4]);
        return 0;
    }
    if (k >= NPATH) {
        int ax = k - NPATH;
        double wsum = 2 * sqrt(0.025) + sqrt(0.305), tp = sqrt(2 * M_PI * wsum * wsum / AMAX);
        snprintf(spec, len, "pick:start=%.6g,%.6g,%.6g;duration=%.9g;axis=%s;dwell=%.9g",
                 h[0] - (ax ? 0 : 0.1525), h[1] - (ax ? 0.1525 : 0), h[2], tp, ax ? "y" : "x",
                 fmax(T - tp, 0));
        return tp <= T ? 0 : -1;
    }
    k -= 12;
    const double *u = MOVE[k / 2];
    double nu = sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
    double d = (k % 2 ? 0.25 : 0.1) * la, tau = fmin(0.5 * T, sqrt(4 * d / AMAX));
    d = fmin(d, AMAX * tau * tau / 4) / nu; /* bang-bang: d = a tau^2 / 4 */
    snprintf(spec, len,
             "p2p:from=%.6g,%.6g,%.6g;to=%.6g,%.6g,%.6g;duration=%.9g;law=bangbang;dwell=%.9g",
             h[0] - d * u[0] / 2, h[1] - d * u[1] / 2, h[2] - d * u[2] / 2, h[0] + d * u[0] / 2,
             h[1] + d * u[1] / 2, h[2] + d * u[2] / 2, tau, T - tau);
    return 0;
}

/* The tracker samples of a path (n times at 1 ms); DM_EUNREACHABLE if it
 * leaves the well-conditioned workspace. */
static int path_samples(const dm_robot *rb, const char *spec, int n, double noise, dm_dataset *d,
                        dm_error *err)
{
    dm_trajectory tr;
    memset(d, 0, sizeof *d);
    int rc = dm_traj_make(spec, rb, &tr, err);
    if (rc)
        return rc;
    d->kind = DM_DATA_TRACKER;
    snprintf(d->source, sizeof d->source, "%s", spec);
    rc = dm_synth_path_samples(&tr, n, noise, d, err);
    for (int i = 0; i < d->n && !rc; i += 3) /* each time once */
        if (!well_placed(rb, d->s[i].P))
            rc = dm_fail(err, DM_EUNREACHABLE, "%s leaves the workspace at t = %g s", spec,
                         d->s[i].t);
    dm_traj_free(&tr);
    if (rc)
        dm_dataset_free(d);
    return rc;
}

/* ---- planning -------------------------------------------------------------------- */

static double default_noise(dm_data_kind kind)
{
    return kind == DM_DATA_MODAL ? 0.02 : kind == DM_DATA_STATIC ? 5e-8 : 2e-6;
}

/* Without clearance a deflection is linear in the force, so the seven
 * directions of a pose can share its analysis (one pose id); with it the
 * loaded pose depends on the force. */
static int share_analysis(const model *m)
{
    if (dm_effects_clearance(&m->rb->effects))
        return 0;
    for (int e = 0; e < m->neff; e++)
        if (strstr(m->eff[e].cand->name, "clearance"))
            return 0;
    return 1;
}

/* The candidate units of a survey: a dataset of all of them, and where
 * each unit's rows start (first[nunit] = d->n). */
static int survey_units(const model *m, double noise, dm_dataset *d, int **first, int *nunit,
                        dm_error *err)
{
    const dm_plan_opts *o = m->o;
    double *P;
    int np, rc = candidate_poses(m->rb, o, &P, &np, err);
    if (rc)
        return rc;
    int per = o->kind == DM_DATA_STATIC ? 7 : 1, share = share_analysis(m);
    memset(d, 0, sizeof *d);
    d->kind = o->kind;
    *nunit = np * per;
    *first = malloc(sizeof(int) * (*nunit + 1));
    if (!*first)
        rc = dm_fail(err, DM_ENOMEM, "out of memory");
    for (int c = 0, u = 0; c < np && !rc; c++)
        for (int k = 0; k < per && !rc; k++, u++) {
            (*first)[u] = d->n;
            int id = per == 1 || share ? c : u;
            if (dm_synth_pose_samples(d, P + 3 * c, id, noise, o->modes, o->force_n, DIRS[k],
                                      NULL))
                rc = dm_fail(err, DM_ENOMEM, "out of memory");
            d->npose = id + 1;
        }
    if (!rc)
        (*first)[*nunit] = d->n;
    free(P);
    return rc;
}

static int by_int(const void *a, const void *b) { return *(const int *)a - *(const int *)b; }

/* The design: the chosen units' samples, each unit its own pose id. */
static int design_of(const dm_dataset *cand, const int *first, int *sel, int n, dm_dataset *d)
{
    assert(n >= 0);
    qsort(sel, n, sizeof *sel, by_int);
    memset(d, 0, sizeof *d);
    d->kind = cand->kind;
    snprintf(d->source, sizeof d->source, "planned %s survey", dm_data_kind_name(cand->kind));
    for (int i = 0; i < n; i++)
        for (int r = first[sel[i]]; r < first[sel[i] + 1]; r++) {
            dm_sample s = cand->s[r];
            s.pose_id = i;
            if (dm_dataset_push(d, &s, NULL))
                return DM_ENOMEM;
        }
    d->npose = n;
    return DM_OK;
}

static int plan_survey(const model *m, double noise, dm_plan_result *r, dm_progress_meter *pm,
                       dm_error *err)
{
    dm_dataset cand;
    int *first = NULL, nunit = 0, p = m->p, n = m->o->npose;
    int rc = survey_units(m, noise, &cand, &first, &nunit, err);
    if (!rc && nunit < n)
        rc = dm_fail(err, DM_EINVAL, "%d poses: the region has only %d candidate%s", n, nunit,
                     nunit == 1 ? "" : "s");
    if (!rc && (rc = check_survey(m, &cand, nunit, err)))
        dm_dataset_free(&cand), nunit = 0;
    double *pred = rc ? NULL : malloc(sizeof(double) * cand.n);
    double *J = rc ? NULL : malloc(sizeof(double) * cand.n * p);
    double *info = rc ? NULL : malloc(sizeof(double) * nunit * p * p);
    int *sel = rc ? NULL : malloc(sizeof(int) * n);
    if (!rc && (!pred || !J || !info || !sel))
        rc = dm_fail(err, DM_ENOMEM, "out of memory");
    if (!rc) {
        dm_progress_begin(pm, "sensitivities", "pose analyses", (p + 1L) * cand.npose);
        rc = sensitivities(m, &cand, noise, pred, J, pm, 1, err);
    }
    if (!rc) {
        dm_progress_end(pm);
        r->ncandidates = m->o->kind == DM_DATA_STATIC ? nunit / 7 : nunit;
        unit_information(J, cand.n, p, first, nunit, info);
        choose_units(info, nunit, p, n, sel, pm);
        r->logdet = design_sigma(info, sel, n, p, r->sigma);
        r->logdet_random = random_sigma(info, nunit, p, n, m->o->seed, r->sigma_random);
        if (design_of(&cand, first, sel, n, &r->design))
            rc = dm_fail(err, DM_ENOMEM, "out of memory");
    }
    free(pred), free(J), free(info), free(sel), free(first);
    if (nunit)
        dm_dataset_free(&cand);
    return rc;
}

/* A path's information: the sensitivities of its samples d, projected
 * orthogonal to the nuisances when the plan has them; log det and sig. */
static int path_information(const model *m, dm_dataset *d, double noise, dm_progress_meter *pm,
                            double *sig, double *ld, dm_error *err)
{
    int p = m->p;
    double *pred = malloc(sizeof(double) * d->n), *J = malloc(sizeof(double) * d->n * p);
    double F[DM_DIAG_MAXP * DM_DIAG_MAXP];
    int first[2] = {0, d->n}, all = 0;
    int rc = !pred || !J ? dm_fail(err, DM_ENOMEM, "out of memory")
                         : sensitivities(m, d, noise, pred, J, pm, 0, err);
    if (!rc && m->o->nuisance) {
        nuisance_basis b;
        mark_nuisances(m->o, d);
        rc = nuisance_basis_make(d, pred, &b);
        if (!rc)
            project_out(&b, J, p);
        nuisance_basis_free(&b);
        if (rc)
            rc = dm_fail(err, DM_ENOMEM, "out of memory");
    }
    if (!rc) {
        unit_information(J, d->n, p, first, 1, F);
        *ld = design_sigma(F, &all, 1, p, sig);
    }
    free(pred), free(J);
    return rc;
}

/* The tracker path k of the plan: the option's, or the family's k-th;
 * DM_EUNREACHABLE when the record is too short for it. */
static int plan_path(const model *m, int k, char *spec, size_t len, dm_error *err)
{
    if (m->o->path)
        snprintf(spec, len, "%s", m->o->path);
    else if (path_spec(m->rb, k, m->o->npose, spec, len))
        return dm_fail(err, DM_EUNREACHABLE, "%s: longer than %d samples", spec, m->o->npose);
    return DM_OK;
}

/* Tracker: the path of the family with the largest determinant. */
static int plan_tracker(const model *m, double noise, dm_plan_result *r, dm_progress_meter *pm,
                        dm_error *err)
{
    int p = m->p, n = m->o->npose, status[NPATH_ALL], npath = path_count(m->o);
    double ld[NPATH_ALL], sig[NPATH_ALL][DM_DIAG_MAXP];
    dm_error perr[NPATH_ALL];
    int rc0 = check_tracker(m, err);
    if (rc0)
        return rc0;
    if (m->o->path && strlen(m->o->path) >= sizeof r->path)
        return dm_fail(err, DM_EINVAL, "path '%.40s...': at most %zu characters", m->o->path,
                       sizeof r->path - 1);
    dm_progress_begin(pm, "sensitivities", "predictions", npath * (p + 1L));
#pragma omp parallel for schedule(dynamic, 1) num_threads(thread_count(m->o))
    for (int k = 0; k < npath; k++) {
        char spec[256];
        dm_dataset d;
        status[k] = plan_path(m, k, spec, sizeof spec, &perr[k]);
        if (!status[k])
            status[k] = path_samples(m->rb, spec, n, noise, &d, &perr[k]);
        ld[k] = -INFINITY;
        if (status[k]) {
            dm_progress_add(pm, p + 1); /* a path not taken: its predictions are done */
            continue;
        }
        status[k] = path_information(m, &d, noise, pm, sig[k], &ld[k], &perr[k]);
        dm_dataset_free(&d);
    }
    int best = -1, ok = 0;
    double lds[NPATH_ALL], sigs[NPATH_ALL][DM_DIAG_MAXP];
    for (int k = 0; k < npath; k++)
        if (status[k] && (status[k] != DM_EUNREACHABLE || m->o->path))
            return err ? (*err = perr[k], perr[k].code) : status[k];
    dm_progress_end(pm);
    for (int k = 0; k < npath; k++) {
        if (status[k])
            continue;
        r->ncandidates++;
        if (!isfinite(ld[k]))
            continue;
        lds[ok] = ld[k];
        memcpy(sigs[ok++], sig[k], sizeof sig[k]);
        if (best < 0 || ld[k] > ld[best])
            best = k;
    }
    if (!r->ncandidates)
        return dm_fail(err, DM_EUNREACHABLE, "no path of the family stays in the workspace");
    if (best < 0 && m->o->path) /* assessed all the same: what it leaves undetermined */
        best = 0, lds[ok] = ld[0], memcpy(sigs[ok++], sig[0], sizeof sig[0]);
    if (best < 0)
        return dm_fail(err, DM_EINVAL, "no path of the family determines these effects%s",
                       m->o->nuisance ? " beyond the tracker's nuisances" : "");
    r->logdet = ld[best];
    r->logdet_random = random_medians(lds, sigs, ok, p, r->sigma_random);
    for (int j = 0; j < p; j++)
        r->sigma[j] = sig[best][j];
    int rc = plan_path(m, best, r->path, sizeof r->path, err);
    if (!rc)
        rc = path_samples(m->rb, r->path, n, noise, &r->design, err);
    snprintf(r->design.source, sizeof r->design.source, "planned tracker run");
    if (!rc)
        mark_nuisances(m->o, &r->design);
    return rc;
}

/* ---- what the planned experiment will see ---------------------------------------- */

/* How far (in sigmas, norm over the design) effect e alone at parameters
 * x[e's] moves the predictions from base. */
static double signature(const model *m, dm_predictor *pw, int e, const double *x,
                        const dm_dataset *d, const double *base, double noise, double *buf,
                        dm_progress_meter *pm)
{
    assert(e >= 0 && e < m->neff);
    int rc = predict_at(m, pw, x, e, buf, NULL);
    dm_progress_add(pm, 1);
    if (rc)
        return NAN;
    for (int i = 0; i < d->n; i++)
        buf[i] -= base[i];
    if (m->nb) /* what the nuisances cannot take */
        project_out(m->nb, buf, 1);
    double q = 0;
    for (int i = 0; i < d->n; i++)
        q += buf[i] * buf[i];
    return sqrt(q) / noise;
}

static int first_param(const model *m, int e)
{
    assert(e >= 0 && e <= m->neff);
    int j = 0;
    for (int k = 0; k < e; k++)
        j += m->eff[k].cand->nparam;
    return j;
}

/* The predictions detectable() makes for effect e at most (the units of
 * the assessment's progress). */
static int detect_predictions(const model *m, int e)
{
    const dm_effect *c = m->eff[e].cand;
    if (c->nparam == 0 || c->linear)
        return 1;
    return strncmp(c->name, "damping_", 8) ? 2 + BISECTIONS : 0;
}

/* The smallest magnitude seen at DETECT sigma (see dm_plan_result). */
static double detectable(const model *m, dm_predictor *pw, int e, const double *F,
                         const dm_dataset *d, const double *base, double noise, double *buf,
                         dm_progress_meter *pm)
{
    assert(e >= 0 && e < m->neff);
    const dm_effect *c = m->eff[e].cand;
    int j0 = first_param(m, e);
    double x[DM_DIAG_MAXP];
    memcpy(x, m->x0, sizeof x);
    if (c->nparam == 0)
        return signature(m, pw, e, x, d, base, noise, buf, pm);
    if (!strncmp(c->name, "damping_", 8)) /* a change of the file's damping */
        return F[j0 * m->p + j0] > 0 ? DETECT / sqrt(F[j0 * m->p + j0]) : INFINITY;
    if (c->linear) { /* linear: scale the assumed errors */
        double s = signature(m, pw, e, x, d, base, noise, buf, pm), big = 0;
        for (int k = 0; k < c->nparam; k++)
            big = fmax(big, fabs(m->eff[e].value[k]));
        return s > 0 ? DETECT / s * big : INFINITY;
    }
    double lo = c->lo - 2, hi = c->hi + 2; /* bisection in log10 on the signature */
    x[j0] = lo;
    double slo = signature(m, pw, e, x, d, base, noise, buf, pm);
    x[j0] = hi;
    double shi = signature(m, pw, e, x, d, base, noise, buf, pm);
    int strong_low = slo > shi; /* springs: soft is strong */
    int never = (strong_low ? slo : shi) < DETECT, always = (strong_low ? shi : slo) >= DETECT;
    if (never || always)
        dm_progress_add(pm, BISECTIONS); /* no bisection: its predictions are done */
    if (never)
        return strong_low ? 0 : INFINITY; /* never seen */
    if (always)
        return pow(10.0, strong_low ? hi : lo); /* seen over the whole range */
    for (int it = 0; it < BISECTIONS; it++) {
        x[j0] = 0.5 * (lo + hi);
        double s = signature(m, pw, e, x, d, base, noise, buf, pm);
        if ((s >= DETECT) == strong_low)
            lo = x[j0];
        else
            hi = x[j0];
    }
    return pow(10.0, 0.5 * (lo + hi));
}

/* Pairs of effects: the smallest angle between their sensitivity spans
 * (cosines: singular values of La^-1 Fab Lb^-T, F = L L') and their least
 * determined joint combination (smallest eigenvalue of their block). */
static void compare_pair(const model *m, const double *F, int a, int b, dm_plan_pair *pr)
{
    assert(a >= 0 && a < b && b < m->neff && m->p <= DM_DIAG_MAXP);
    int ja = first_param(m, a), jb = first_param(m, b), pa = m->eff[a].cand->nparam,
        pb = m->eff[b].cand->nparam, p = m->p, q = pa + pb;
    double Fab[DM_DIAG_MAXP * DM_DIAG_MAXP], La[DM_DIAG_MAXP * DM_DIAG_MAXP],
        Lb[DM_DIAG_MAXP * DM_DIAG_MAXP], B[DM_DIAG_MAXP * DM_DIAG_MAXP], w[DM_DIAG_MAXP];
    int idx[DM_DIAG_MAXP];
    memset(pr, 0, sizeof *pr);
    pr->a = a, pr->b = b, pr->angle_deg = NAN, pr->sigma = INFINITY, pr->alike = 1;
    for (int k = 0; k < pa; k++)
        idx[k] = ja + k;
    for (int k = 0; k < pb; k++)
        idx[pa + k] = jb + k;
    for (int u = 0; u < q; u++)
        for (int v = 0; v < q; v++)
            B[v * q + u] = F[idx[v] * p + idx[u]];
    memcpy(Fab, B, sizeof(double) * q * q);
    if (!LAPACKE_dsyev(LAPACK_COL_MAJOR, 'V', 'U', q, Fab, q, w) && w[0] > 0) {
        double wa = 0; /* the weakest combination's share on a */
        for (int k = 0; k < pa; k++)
            wa += Fab[k] * Fab[k];
        pr->sigma = 1 / sqrt(w[0]);
        pr->alike = pr->sigma > DM_DIAG_DETERMINED && wa >= 0.09 && 1 - wa >= 0.09;
    }
    for (int u = 0; u < pa; u++)
        for (int v = 0; v < pa; v++)
            La[v * pa + u] = B[v * q + u];
    for (int u = 0; u < pb; u++)
        for (int v = 0; v < pb; v++)
            Lb[v * pb + u] = B[(pa + v) * q + pa + u];
    double M[DM_DIAG_MAXP * DM_DIAG_MAXP], sv[DM_DIAG_MAXP], superb[DM_DIAG_MAXP];
    for (int u = 0; u < pa; u++) /* M = Fab (pa x pb) */
        for (int v = 0; v < pb; v++)
            M[v * pa + u] = B[(pa + v) * q + u];
    if (LAPACKE_dpotrf(LAPACK_COL_MAJOR, 'L', pa, La, pa) ||
        LAPACKE_dpotrf(LAPACK_COL_MAJOR, 'L', pb, Lb, pb))
        return;
    LAPACKE_dtrtrs(LAPACK_COL_MAJOR, 'L', 'N', 'N', pa, pb, La, pa, M, pa); /* La^-1 Fab */
    double MT[DM_DIAG_MAXP * DM_DIAG_MAXP]; /* (M Lb^-T)' = Lb^-1 M' */
    for (int u = 0; u < pa; u++)
        for (int v = 0; v < pb; v++)
            MT[u * pb + v] = M[v * pa + u];
    LAPACKE_dtrtrs(LAPACK_COL_MAJOR, 'L', 'N', 'N', pb, pa, Lb, pb, MT, pb);
    if (!LAPACKE_dgesvd(LAPACK_COL_MAJOR, 'N', 'N', pb, pa, MT, pb, sv, NULL, 1, NULL, 1, superb))
        pr->angle_deg = acos(fmin(1.0, sv[0])) * 180 / M_PI;
}

/* Effect e against the nuisances: J0 its sensitivities as they are, J
 * projected orthogonal to the nuisances (both d->n rows, the model's p
 * columns). The combination least determined beyond the nuisances (the
 * smallest eigenvalue of e's block of J'J) and the nuisance combination
 * closest to it (least squares on the unit-norm design: V S^-1 U' J0 v). */
static void confound_of(const model *m, const nuisance_basis *b, const double *J0,
                        const double *J, int e, dm_plan_confound *c)
{
    int j0 = first_param(m, e), pe = m->eff[e].cand->nparam, n = b->n;
    assert(pe >= 1 && pe <= DM_DIAG_MAXV);
    double A[DM_DIAG_MAXV * DM_DIAG_MAXV], w[DM_DIAG_MAXV], g[DM_NUISANCE_MAX] = {0};
    memset(c, 0, sizeof *c);
    c->effect = e;
    for (int u = 0; u < pe; u++)
        for (int v = 0; v < pe; v++) {
            double s = 0;
            for (int i = 0; i < n; i++)
                s += J[(size_t)(j0 + u) * n + i] * J[(size_t)(j0 + v) * n + i];
            A[v * pe + u] = s;
        }
    if (LAPACKE_dsyev(LAPACK_COL_MAJOR, 'V', 'U', pe, A, pe, w))
        w[0] = 0, A[0] = 1; /* not reached: dsyev fails only without workspace */
    memcpy(c->combo, A, sizeof(double) * pe);
    double alone = 0, big = 0;
    for (int i = 0; i < n; i++) {
        double f = 0;
        for (int u = 0; u < pe; u++)
            f += J0[(size_t)(j0 + u) * n + i] * c->combo[u];
        alone += f * f;
        for (int k = 0; k < b->rank; k++)
            g[k] += b->U[(size_t)k * n + i] * f;
    }
    c->sigma = w[0] > 0 ? 1 / sqrt(w[0]) : INFINITY;
    c->sigma_alone = alone > 0 ? 1 / sqrt(alone) : INFINITY;
    c->lost_percent = alone > 0 ? 100 * (1 - fmax(w[0], 0) / alone) : 0;
    for (int l = 0; l < b->q; l++) {
        for (int k = 0; k < b->rank; k++)
            c->like[l] += b->VT[l * b->q + k] * g[k] / b->s[k];
        big = fmax(big, fabs(c->like[l]));
    }
    for (int l = 0; l < b->q && big > 0; l++)
        c->like[l] /= big;
    c->alike = c->sigma > DM_DIAG_DETERMINED && c->sigma_alone <= DM_DIAG_DETERMINED;
}

/* The assessment's sensitivities beyond the nuisances (J projected, J0
 * keeps them as they are) and each effect's confound. */
static int marginalise(const model *m, const dm_dataset *d, const double *pred, double *J,
                       nuisance_basis *b, dm_plan_result *r)
{
    int p = m->p, rc = nuisance_basis_make(d, pred, b);
    double *J0 = rc ? NULL : malloc(sizeof(double) * d->n * p);
    if (!J0)
        return DM_ENOMEM;
    memcpy(J0, J, sizeof(double) * d->n * p);
    project_out(b, J, p);
    r->nnuisance = b->q;
    for (int e = 0; e < m->neff; e++)
        if (m->eff[e].cand->nparam)
            confound_of(m, b, J0, J, e, &r->confound[r->nconfound++]);
    free(J0);
    return DM_OK;
}

static int assess(const model *m0, double noise, dm_plan_result *r, dm_progress_meter *pm,
                  dm_error *err)
{
    model mm = *m0, *m = &mm;
    nuisance_basis nb = {0};
    const dm_dataset *d = &r->design;
    int p = m->p, nrow = d->n;
    double *base = malloc(sizeof(double) * nrow), *buf = malloc(sizeof(double) * nrow);
    double *J = malloc(sizeof(double) * nrow * (p ? p : 1)), *pred = malloc(sizeof(double) * nrow);
    double F[DM_DIAG_MAXP * DM_DIAG_MAXP];
    /* one workspace for the baseline and every bisection step */
    dm_predictor *pw = dm_predictor_new(m->rb, d, m->o->na, m->o->nb, NULL);
    int first[2] = {0, nrow}, rc = !base || !buf || !J || !pred || !pw ? DM_ENOMEM : DM_OK;
    long units = 1 + (p + 1);
    for (int e = 0; e < m->neff; e++)
        units += detect_predictions(m, e);
    dm_progress_begin(pm, "assessment", "predictions", units);
    if (!rc) {
        rc = dm_predictor_run(pw, m->rb, base, err);
        dm_progress_add(pm, 1);
    }
    if (!rc)
        rc = sensitivities(m, d, noise, pred, J, pm, 0, err);
    if (!rc && dm_nuisance_count(d)) {
        rc = marginalise(m, d, pred, J, &nb, r);
        mm.nb = &nb;
    }
    if (!rc) {
        unit_information(J, nrow, p, first, 1, F);
        for (int e = 0; e < m->neff; e++)
            r->detect[e] = detectable(m, pw, e, F, d, base, noise, buf, pm);
        dm_progress_end(pm);
        for (int a = 0; a < m->neff; a++)
            for (int b = a + 1; b < m->neff; b++)
                if (m->eff[a].cand->nparam && m->eff[b].cand->nparam)
                    compare_pair(m, F, a, b, &r->pair[r->npair++]);
    }
    free(base), free(buf), free(J), free(pred);
    nuisance_basis_free(&nb);
    dm_predictor_free(pw);
    return rc == DM_ENOMEM ? dm_fail(err, rc, "out of memory") : rc;
}

/* Scaled 1-sigma to the parameter's unit: relative for log parameters. */
static void to_units(const model *m, double *sig)
{
    for (int e = 0, j = 0; e < m->neff; e++)
        for (int k = 0; k < m->eff[e].cand->nparam; k++, j++)
            sig[j] *= m->eff[e].cand->linear ? m->sc[j] : fabs(m->eff[e].value[k]);
}

static int plan(const dm_robot *rb, const dm_plan_effect *eff, int neff, const dm_plan_opts *o,
                dm_plan_result *r, dm_error *err);

/* The thread count resolved and BLAS on one thread while the plan runs
 * (as dm_diagnose: one thread and two must give the same plan). */
int dm_plan(const dm_robot *rb, const dm_plan_effect *eff, int neff, const dm_plan_opts *o,
            dm_plan_result *r, dm_error *err)
{
    dm_plan_opts resolved = *o;
    resolved.threads = dm_threads_count(o->threads);
    dm_threads_saved saved = dm_threads_serial_blas();
    int rc = plan(rb, eff, neff, &resolved, r, err);
    dm_threads_restore(saved);
    return rc;
}

static int plan(const dm_robot *rb, const dm_plan_effect *eff, int neff, const dm_plan_opts *o,
                dm_plan_result *r, dm_error *err)
{
    memset(r, 0, sizeof *r);
    if (neff < 1 || neff > DM_PLAN_MAXEFF)
        return dm_fail(err, DM_EINVAL, "plan for 1 to %d effects, not %d", DM_PLAN_MAXEFF, neff);
    model m;
    model_init(&m, rb, eff, neff, o);
    if (m.p > DM_DIAG_MAXP)
        return dm_fail(err, DM_EINVAL, "effects: %d parameters, at most %d", m.p, DM_DIAG_MAXP);
    if (m.p == 0)
        return dm_fail(err, DM_EINVAL, "effects: %s has no parameter to plan for",
                       eff[0].cand->name);
    if (o->npose < m.p)
        return dm_fail(err, DM_EINVAL,
                       "%d poses: fewer than the %d parameters of these effects", o->npose, m.p);
    if ((o->nuisance || o->path) && o->kind != DM_DATA_TRACKER)
        return dm_fail(err, DM_EINVAL, "%s: a path and the tracker's nuisances are for tracker "
                       "runs", o->path ? "path" : "nuisances");
    if (o->nuisance && o->npose < 2 + (m.p + 8) / 3)
        return dm_fail(err, DM_EINVAL, "%d samples: too few for the %d parameters and the "
                       "tracker's nuisances", o->npose, m.p);
    r->neffect = neff;
    memcpy(r->effect, eff, sizeof(dm_plan_effect) * neff);
    r->nparam = m.p;
    r->noise = o->noise > 0 ? o->noise : default_noise(o->kind);
    dm_progress_meter pm;
    dm_progress_meter_init(&pm, o->progress, o->progress_user);
    int rc = o->kind == DM_DATA_TRACKER ? plan_tracker(&m, r->noise, r, &pm, err)
                                        : plan_survey(&m, r->noise, r, &pm, err);
    if (!rc)
        rc = assess(&m, r->noise, r, &pm, err);
    if (rc) {
        dm_plan_free(r);
        return rc;
    }
    snprintf(r->design.robot, sizeof r->design.robot, "%s", rb->name);
    to_units(&m, r->sigma);
    to_units(&m, r->sigma_random);
    return DM_OK;
}

void dm_plan_free(dm_plan_result *r) { dm_dataset_free(&r->design); }

/* ---- the comparison and the template --------------------------------------------- */

int dm_plan_random(const dm_robot *rb, const dm_plan_opts *o, uint64_t seed, dm_dataset *d,
                   dm_error *err)
{
    dm_rng rng = {seed * 0xD1B54A32D192ED03ull + 11};
    double noise = o->noise > 0 ? o->noise : default_noise(o->kind);
    memset(d, 0, sizeof *d);
    if (o->kind == DM_DATA_TRACKER) {
        for (int tries = 0; tries < 100; tries++) {
            char spec[256];
            path_spec(rb, (int)(dm_rng_uniform(&rng) * NPATH), o->npose, spec, sizeof spec);
            int rc = path_samples(rb, spec, o->npose, noise, d, err);
            if (rc != DM_EUNREACHABLE)
                return rc;
        }
        return dm_fail(err, DM_EUNREACHABLE, "no path of the family stays in the workspace");
    }
    double *P = NULL;
    int np = 0, rc = o->region ? candidate_poses(rb, o, &P, &np, err) : DM_OK;
    if (rc)
        return rc;
    if (o->region && np < o->npose) {
        free(P);
        return dm_fail(err, DM_EINVAL, "%d poses: the region has only %d candidates", o->npose,
                       np);
    }
    d->kind = o->kind;
    snprintf(d->source, sizeof d->source, "random %s survey", dm_data_kind_name(o->kind));
    for (int i = 0; i < o->npose && !rc; i++) {
        double Q[3], u[3] = {dm_rng_normal(&rng), dm_rng_normal(&rng), dm_rng_normal(&rng)};
        if (o->region) { /* distinct grid points: partial Fisher-Yates */
            int k = i + (int)(dm_rng_uniform(&rng) * (np - i));
            for (int c = 0; c < 3; c++) {
                double t = P[3 * i + c];
                P[3 * i + c] = P[3 * k + c];
                P[3 * k + c] = t;
            }
            memcpy(Q, P + 3 * i, sizeof Q);
        } else if (dm_synth_draw_pose(rb, &rng, Q)) {
            rc = dm_fail(err, DM_EUNREACHABLE, "no reachable pose found near home");
            break;
        }
        if (dm_synth_pose_samples(d, Q, i, noise, o->modes, o->force_n, u, NULL))
            rc = dm_fail(err, DM_ENOMEM, "out of memory");
        d->npose = i + 1;
    }
    free(P);
    if (rc)
        dm_dataset_free(d);
    return rc;
}

int dm_plan_observe(const dm_robot *rb, const dm_dataset *design, double noise, uint64_t seed,
                    int na, int nb, dm_dataset *d, dm_error *err)
{
    *d = *design;
    d->s = malloc(sizeof(dm_sample) * (design->n ? design->n : 1));
    d->cap = design->n;
    double *pred = malloc(sizeof(double) * (design->n ? design->n : 1));
    int rc = !d->s || !pred ? dm_fail(err, DM_ENOMEM, "out of memory") : DM_OK;
    if (!rc) {
        memcpy(d->s, design->s, sizeof(dm_sample) * design->n);
        rc = dm_predict(rb, d, na, nb, pred, err);
    }
    dm_rng rng = {seed * 977 + 13};
    for (int i = 0; !rc && i < d->n; i++) {
        double s = noise > 0 ? noise : d->s[i].sigma;
        d->s[i].value = pred[i] + s * dm_rng_normal(&rng);
        d->s[i].sigma = s;
    }
    free(pred);
    if (rc) {
        free(d->s);
        d->s = NULL;
        d->n = d->cap = 0;
    }
    return rc;
}

int dm_plan_write_template(const dm_plan_result *r, const char *robot, FILE *out)
{
    const dm_dataset *d = &r->design;
    fprintf(out, "# robot: %s\n", robot);
    fprintf(out, "# planned by deltamap plan for");
    for (int e = 0; e < r->neffect; e++)
        fprintf(out, "%s %s", e ? "," : "", r->effect[e].cand->name);
    fprintf(out, "; fill in the measured values\n");
    if (d->kind == DM_DATA_MODAL) {
        fprintf(out, "x,y,z,mode,freq_hz,sigma_hz\n");
        for (int i = 0; i < d->n; i++)
            fprintf(out, "%.9g,%.9g,%.9g,%d,,%.6g\n", d->s[i].P[0], d->s[i].P[1], d->s[i].P[2],
                    d->s[i].mode, d->s[i].sigma);
    } else if (d->kind == DM_DATA_STATIC) {
        fprintf(out, "x,y,z,fx,fy,fz,dx,dy,dz,sigma_m\n");
        for (int i = 0; i + 2 < d->n; i += 3) {
            const dm_sample *s = &d->s[i];
            fprintf(out, "%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,,,,%.6g\n", s->P[0], s->P[1], s->P[2],
                    s->force[0], s->force[1], s->force[2], s->sigma);
        }
    } else {
        fprintf(out, "# path: %s\n# tracker files carry no sigma: diagnose with --sigma %g\n",
                r->path, r->noise);
        if (d->nuisance.on && d->nuisance.tracker_frame) /* read as a template it has no frame */
            fprintf(out, "# with the measured values in the tracker's frame, add '# frame: "
                    "tracker', '# reflector: X, Y, Z' and '# clock: %s' (docs/measured-data.md)\n",
                    d->nuisance.clock_rate ? "rate" : "offset");
        else if (d->nuisance.on)
            fprintf(out, "# frame: base\n# clock: %s\n", d->nuisance.clock_rate ? "rate" : "offset");
        fprintf(out, "t,x_cmd,y_cmd,z_cmd,x_meas,y_meas,z_meas\n");
        for (int i = 0; i + 2 < d->n; i += 3) {
            const dm_sample *s = &d->s[i];
            fprintf(out, "%.9g,%.12g,%.12g,%.12g,,,\n", s->t, s->P[0], s->P[1], s->P[2]);
        }
    }
    return ferror(out) ? DM_EIO : DM_OK;
}
