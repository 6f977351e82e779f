/* Generalized symmetric-definite eigenproblem K phi = lambda M phi
 * (docs/model.md §4): subspace iteration on the block-arrow factor of K, and the
 * dense LAPACK paths (reference, cold start, small models). */
#include "dm_modal.h"

#include <assert.h>
#include <cblas.h>
#include <lapacke.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "dm_rng.h"
#include "dm_static.h"

struct dm_modal {
    int n, kmax, q;
    dm_eigen_method method;
    /* dense path */
    double *A, *B;           /* K and M expanded, overwritten by LAPACK */
    double *w, *Z;           /* eigenvalues (n), eigenvectors (n x kdense, or n x n) */
    double *work;
    lapack_int *iwork, *isuppz;
    lapack_int lwork, liwork;
    double *d, *e, *tau, *dd, *ee; /* small models: tridiagonal T = Q' C Q and a copy */
    lapack_int *iblock, *isplit, *ifail;
    int kdense;              /* most pairs the dense partial path computes */
    /* subspace path: blocks of q vectors, interleaved (see dm_arrow.h) */
    int qmax;                /* most vectors a subspace may hold */
    int nl;                  /* of the q, converged and locked */
    double *XL;              /* n x nl, column-major: the locked Ritz vectors */
    double *MXL;             /* M XL, from the products they were checked with */
    int mx_fresh, mxl_whole; /* MX is M X; MXL holds every locked vector's */
    double *C;               /* nl x q: their M-products with the active block */
    double *X, *MX, *T, *MT, *Y; /* active block, n x (q - nl): Ritz vectors, M X,
                                    A X, M A X, filter */
    double *Xs, *Ts, *MXs;   /* X, A X, M X at the start of a round (a retry) */
    double *Kt, *Mt, *theta, *res, *scale; /* projections, Ritz values, residuals */
    double *phi;             /* n x kmax, column-major: the modes handed out */
    double *mphi;            /* M phi, with them */
    double *swork;
    lapack_int *siwork, slwork, sliwork;
    dm_arrow_ldl ldl;        /* Sturm counts */
    dm_modal_count offer;    /* a count made ahead for the next solve (count -1: none) */
    dm_arrow_chol mchol;     /* the factor of M, where the dense path takes every
                                pair by the block-arrow reduction (arrow_all) */
    int follow;              /* poses along a path: extrapolate the start */
    int nhist;               /* earlier solutions in hist (0..2) */
    double *hist[2];         /* the blocks of the last solves but one and two */
    int kc, hist_kc[2];      /* the converged (leading) columns of X and of those */
    int ntoward;             /* seeds the start is interpolated toward (0..3) */
    double *toward[DM_MODAL_TOWARD]; /* their blocks */
    double tfrac[DM_MODAL_TOWARD];   /* how far toward each */
    int have_start;
    dm_cold_start cold;      /* how a cold solve starts */
    double warm_error;       /* how far off the last warm start was */
    double mix_floor;        /* how far toward the lowest modes a start's columns
                                are assumed (see BETWEEN_MIX) */
    dm_modal_stats stats;
    dm_modes modes;
};

/* ---- tuning (each measured with make bench; see docs/model-choices.md) --- */

/* Most vectors a subspace may hold for k wanted modes. */
static int subspace_max(int n, int k)
{
    int q = 2 * k + 4;
    return q < n - 1 ? q : n - 1;
}

/* Relative residual at which a Ritz pair counts as converged
 * (dm_modal.h). */
#define CONVERGED DM_MODAL_CONVERGED
/* ... and at a pose near a singularity, where the lowest mode falls to
 * 1e-6 of the last wanted one (han2011 near its workspace's edge), 1e-8
 * is not enough: the locked low modes' small errors along stiff modes
 * come back into the others, amplified by the spread (the deflation in
 * apply_A divides by their Ritz values), and an eigenvalue's error is that
 * contamination squared times lambda_stiff / lambda. Measured there (a
 * warm start 30 mm away): modes off by up to 3.7e-8 at 1e-8, 1e-14 at
 * 1e-9, in the same number of applications. Wanted spreads above
 * SPREAD_TIGHT converge to CONVERGED * TIGHTER; elsewhere (a spread of
 * 10-300) nothing changes. */
#define SPREAD_TIGHT 1e4
#define TIGHTER 0.1
/* Ritz values closer than this (relative) form a cluster that the wanted
 * set must not cut: the Sturm shift goes into the first wider gap. */
#define CLUSTER_GAP 1e-3
/* The subspace is sized at a cold start so that the first eigenvalue
 * outside it is at least this many times the last wanted one: the filter
 * then damps what is outside by T_d(1 + 2 gamma), gamma >= 7. */
#define SUBSPACE_RATIO 8.0
/* ... and along a path (dm_modal_follow_path), where each start is the
 * last solutions extrapolated (off by O(h^3)), this many: the filter needs
 * less of a gap there, and a narrower block costs less per application
 * and per projection. han2011's paper trajectory: 24 vectors instead of
 * 28, 7 % fewer instructions for the run (callgrind), its 2-thread steps,
 * bounded by the solve, 15 % faster; chen2018's and zheng2017's blocks
 * are the same at either ratio (measured 2026-12-04). */
#define PATH_RATIO 4.0
/* The block kernels walk the matrix once per slice of 4k columns (then at
 * most 3: arrow.c), so a block of 4k + 1..3 vectors costs about as much
 * per application as one of 4k + 4 (chen2018 at 210 DOF: M products of
 * 19 vectors 13 us, of 24 11 us). The subspace's size is rounded up to a
 * multiple of this, whose extra vectors widen the gap the filter works
 * with (64 x 64 sweeps at 210 DOF, one thread: chen2018, 19 -> 20
 * vectors, 8 % faster, han2011, 27 -> 28, 3 %; zheng2017's 16 unchanged),
 * and locking leaves the active block a multiple of it wide until the
 * last wanted pairs lock (a converged pair left in the block stays
 * converged; sweeps 1-5 % faster again). */
#define SUBSPACE_STEP 4
/* A warm start from a neighbouring pose is first assumed this far off;
 * then each warm solve measures how far off its start was and the next
 * one plans its first filter with that (poses along a path are spaced
 * alike: 1e-4 for a trajectory's steps, 1e-2 for a coarse grid). */
#define WARM_ERROR 1e-2
/* A start interpolated between seeds (a sweep's point between anchors
 * 20-40 mm apart) is assumed this far off for planning its first filter,
 * and its columns this far toward the lowest modes for the skew limit
 * (WARM_ERROR for a seed alone). Measured on chen2018 at mesh 4,4,
 * anchors 20 mm apart: after a first filter of degree 3 the residuals were
 * 4e-8 (median; 9e-8 at the 90th percentile) instead of 1.2e-6 from the
 * nearest seed alone, so the start was within ~1e-4 (the filter's
 * worst-case gain is 750); with these the first filter takes degree 4 and
 * most points converge in one round. */
#define BETWEEN_ERROR 3e-5
#define BETWEEN_MIX 3e-4
/* A filter is planned to bring the residuals this far below CONVERGED
 * (its gain is a worst case: most components are damped far more). */
#define TARGET 0.5
#define MAX_DEGREE 8
#define MAX_ROUNDS 8

/* Below this size LAPACK's tridiagonal stage for a few pairs (bisection
 * and inverse iteration inside dsyevr) costs more than the reduction; all
 * eigenvalues by the root-free QR (dsterf, O(n^2)) and inverse iteration
 * for the k wanted vectors (dstein) are measured 30 % faster at n = 48 and
 * slower beyond n ~ 100 (see make bench). */
#define DM_SMALL_MODEL 96

/* DM_EIGEN_PARTIAL iterates a subspace for up to this many modes, or n / 5:
 * beyond, its block of 2k + 4 vectors costs more than every pair by the
 * dense path (measured along zheng2017's trajectory at 210 DOF, per step:
 * 40 modes 2.0 ms, 60 modes 5.1, 80 modes 7.4, every pair 3.0). */
#define SUBSPACE_KMAX 24

static int uses_subspace(const dm_modal *ws)
{
    int kmax = ws->n / 5 > SUBSPACE_KMAX ? ws->n / 5 : SUBSPACE_KMAX;
    return ws->method == DM_EIGEN_SUBSPACE ||
           (ws->method == DM_EIGEN_PARTIAL && ws->n > DM_MODAL_DENSE_MAX && ws->kmax <= kmax &&
            ws->qmax > ws->kmax + 1);
}

static int all_pairs(const dm_modal *ws)
{
    return ws->method == DM_EIGEN_ALL || ws->method == DM_EIGEN_ALL_ARROW;
}

/* Selected pairs (dsyevr, or dsterf and dstein) cost more than every pair
 * by the block-arrow reduction (solve_all_arrow) beyond this many, or n / 8
 * (measured at 48-426 DOF: the two cross at 14-20 pairs up to 210 DOF,
 * near 55 at 426; at 426 DOF and all pairs selected it is 6x slower):
 * the dense path takes more pairs that way. */
#define DENSE_SELECT_MAX 20

static int select_max(int n) { return n / 8 > DENSE_SELECT_MAX ? n / 8 : DENSE_SELECT_MAX; }

/* The dense path for k pairs reduces with the block-arrow factor of M. */
static int arrow_all(const dm_modal *ws, int k)
{
    return ws->method == DM_EIGEN_ALL_ARROW ||
           (ws->method != DM_EIGEN_ALL && k > select_max(ws->n));
}

static int small_model(const dm_modal *ws)
{
    return !all_pairs(ws) && ws->n <= DM_SMALL_MODEL;
}

/* ---- allocation ------------------------------------------------------------ */

static int query_dense(dm_modal *ws)
{
    double wq;
    lapack_int iq, n = ws->n, m, k = ws->kdense;
    lapack_int info;
    if (ws->method == DM_EIGEN_ALL)
        info = LAPACKE_dsygvd_work(LAPACK_COL_MAJOR, 1, 'V', 'U', n, ws->A, n, ws->B, n,
                                   ws->w, &wq, -1, &iq, -1);
    else
        info = LAPACKE_dsyevr_work(LAPACK_COL_MAJOR, 'V', 'I', 'U', n, ws->A, n, 0, 0, 1, k,
                                   0.0, &m, ws->w, ws->Z, n, ws->isuppz, &wq, -1, &iq, -1);
    ws->lwork = (lapack_int)wq + 1;
    ws->liwork = iq;
    if (!info && arrow_all(ws, k)) { /* dsyevd's room too */
        info = LAPACKE_dsyevd_work(LAPACK_COL_MAJOR, 'V', 'L', n, ws->B, n, ws->w, &wq, -1, &iq,
                                   -1);
        ws->lwork = fmax(ws->lwork, wq + 1);
        ws->liwork = ws->liwork > iq ? ws->liwork : iq;
    }
    if (!info && small_model(ws)) { /* dsytrd, dormtr, dstein (5n, n) need room too */
        info = LAPACKE_dsytrd_work(LAPACK_COL_MAJOR, 'U', n, ws->A, n, ws->w, ws->w, ws->w, &wq, -1);
        ws->lwork = fmax(ws->lwork, wq + 1);
        if (!info)
            info = LAPACKE_dormtr_work(LAPACK_COL_MAJOR, 'L', 'U', 'N', n, k, ws->A, n, ws->w,
                                       ws->Z, n, &wq, -1);
        ws->lwork = fmax(fmax(ws->lwork, wq + 1), 5.0 * n);
        ws->liwork = ws->liwork > n ? ws->liwork : n;
    }
    return (int)info;
}

static int query_subspace(dm_modal *ws)
{
    double wq;
    lapack_int iq, q = ws->qmax;
    lapack_int info = LAPACKE_dsygvd_work(LAPACK_COL_MAJOR, 1, 'V', 'U', q, ws->Kt, q, ws->Mt, q,
                                          ws->theta, &wq, -1, &iq, -1);
    ws->slwork = (lapack_int)wq + 1;
    ws->sliwork = iq;
    return (int)info;
}

static int alloc_dense(dm_modal *ws)
{
    int n = ws->n;
    size_t nn = (size_t)n * n, nz = all_pairs(ws) ? nn : (size_t)n * ws->kdense;
    ws->A = malloc(nn * sizeof(double));
    ws->B = malloc(nn * sizeof(double));
    ws->Z = malloc(nz * sizeof(double));
    ws->w = malloc((size_t)n * sizeof(double));
    ws->isuppz = malloc(2 * (size_t)n * sizeof(lapack_int));
    ws->d = malloc(5 * (size_t)n * sizeof(double)); /* d, e, tau, dd, ee */
    ws->iblock = malloc(3 * (size_t)n * sizeof(lapack_int)); /* iblock, isplit, ifail */
    if (!ws->A || !ws->B || !ws->Z || !ws->w || !ws->isuppz || !ws->d || !ws->iblock ||
        query_dense(ws))
        return DM_ENOMEM;
    ws->e = ws->d + n, ws->tau = ws->e + n, ws->dd = ws->tau + n, ws->ee = ws->dd + n;
    ws->isplit = ws->iblock + n, ws->ifail = ws->isplit + n;
    ws->work = malloc((size_t)ws->lwork * sizeof(double));
    ws->iwork = malloc((size_t)ws->liwork * sizeof(lapack_int));
    return ws->work && ws->iwork ? DM_OK : DM_ENOMEM;
}

static int alloc_subspace(dm_modal *ws, const dm_model *md)
{
    size_t nq = (size_t)ws->n * ws->qmax, qq = (size_t)ws->qmax * ws->qmax;
    double **nbuf[] = {&ws->X,   &ws->MX,  &ws->T,      &ws->MT,        &ws->Y,
                       &ws->XL,  &ws->MXL, &ws->Xs,     &ws->Ts,        &ws->MXs,
                       &ws->hist[0], &ws->hist[1], &ws->toward[0], &ws->toward[1],
                       &ws->toward[2]};
    for (size_t i = 0; i < sizeof nbuf / sizeof nbuf[0]; i++)
        if (!(*nbuf[i] = malloc(nq * sizeof(double))))
            return DM_ENOMEM;
    ws->Kt = malloc(qq * sizeof(double));
    ws->Mt = malloc(qq * sizeof(double));
    ws->theta = malloc((size_t)ws->qmax * sizeof(double));
    ws->res = malloc((size_t)ws->qmax * sizeof(double));
    ws->scale = malloc((size_t)ws->qmax * sizeof(double));
    ws->C = malloc(qq * sizeof(double));
    ws->phi = malloc((size_t)ws->n * ws->kmax * sizeof(double));
    ws->mphi = malloc((size_t)ws->n * ws->kmax * sizeof(double));
    if (!ws->Kt || !ws->Mt || !ws->theta || !ws->res || !ws->scale || !ws->phi || !ws->mphi ||
        !ws->C || query_subspace(ws))
        return DM_ENOMEM;
    ws->swork = malloc((size_t)ws->slwork * sizeof(double));
    ws->siwork = malloc((size_t)ws->sliwork * sizeof(lapack_int));
    if (!ws->swork || !ws->siwork)
        return DM_ENOMEM;
    return dm_arrow_ldl_init(&ws->ldl, &md->layout, NULL);
}

dm_modal *dm_modal_alloc(const dm_model *md, int kmax, dm_eigen_method method, dm_error *err)
{
    int n = md->n;
    if (n < 1 || kmax < 1 || kmax > n) {
        dm_fail(err, DM_EINVAL, "modes: asked for %d modes of a %d-DOF model", kmax, n);
        return NULL;
    }
    dm_modal *ws = calloc(1, sizeof *ws);
    int rc = ws ? DM_OK : DM_ENOMEM;
    if (!rc) {
        ws->n = n;
        ws->kmax = kmax;
        ws->method = method;
        ws->warm_error = ws->mix_floor = WARM_ERROR;
        ws->qmax = subspace_max(n, kmax);
        ws->cold = DM_COLD_AUTO;
        ws->offer.count = -1;
        /* the dense partial path also starts the subspace iteration: it
         * computes one pair more than a subspace holds, to size it */
        ws->kdense = uses_subspace(ws) ? ws->qmax + 1 : kmax;
        ws->modes.freq_hz = malloc((size_t)kmax * sizeof(double));
        ws->modes.omega_rad_s = malloc((size_t)kmax * sizeof(double));
        ws->modes.platform_share = calloc((size_t)kmax, sizeof(double));
        ws->modes.direction = calloc((size_t)kmax, sizeof(int));
        rc = ws->modes.freq_hz && ws->modes.omega_rad_s && ws->modes.platform_share &&
                     ws->modes.direction
                 ? alloc_dense(ws)
                 : DM_ENOMEM;
        if (!rc && uses_subspace(ws))
            rc = alloc_subspace(ws, md);
        if (!rc && arrow_all(ws, ws->kdense))
            rc = dm_arrow_chol_init(&ws->mchol, &md->layout, NULL);
    }
    if (rc) {
        dm_modal_free(ws);
        dm_fail(err, DM_ENOMEM, "out of memory for a %d-DOF eigen workspace", n);
        return NULL;
    }
    return ws;
}

void dm_modal_free(dm_modal *ws)
{
    if (!ws)
        return;
    void *p[] = {ws->A,  ws->B,     ws->Z,   ws->w,     ws->work,   ws->iwork,
                 ws->isuppz, ws->d, ws->iblock, ws->X, ws->MX,    ws->T,
                 ws->MT, ws->Y,     ws->Kt,  ws->Mt,    ws->theta,  ws->res,
                 ws->scale, ws->phi, ws->mphi, ws->swork, ws->siwork, ws->XL, ws->MXL, ws->C,
                 ws->Xs, ws->Ts, ws->MXs, ws->hist[0], ws->hist[1], ws->toward[0], ws->toward[1],
                 ws->toward[2], ws->modes.freq_hz,
                 ws->modes.omega_rad_s, ws->modes.platform_share, ws->modes.direction};
    for (size_t i = 0; i < sizeof p / sizeof p[0]; i++)
        free(p[i]);
    dm_arrow_ldl_release(&ws->ldl);
    dm_arrow_chol_release(&ws->mchol);
    free(ws);
}

void dm_modal_forget(dm_modal *ws)
{
    ws->have_start = 0;
    ws->nhist = 0;
    ws->ntoward = 0;
    ws->warm_error = ws->mix_floor = WARM_ERROR; /* nothing carried over, not even this */
}

void dm_modal_last_stats(const dm_modal *ws, dm_modal_stats *stats) { *stats = ws->stats; }

void dm_modal_follow_path(dm_modal *ws, int on)
{
    ws->follow = on;
    ws->nhist = 0; /* a new path (or none) */
}

/* A seed: q, then q Ritz values (double), then the block (float: it is
 * only a start; half the memory of an anchor lattice). */
size_t dm_modal_seed_size(const dm_modal *ws)
{
    if (!uses_subspace(ws))
        return 0;
    return sizeof(double) * (1 + ws->qmax) + sizeof(float) * ws->n * ws->qmax;
}

int dm_modal_seed_save(const dm_modal *ws, void *seed)
{
    if (!uses_subspace(ws) || !ws->have_start)
        return 0;
    double *head = seed;
    float *X = (float *)(head + 1 + ws->qmax);
    head[0] = ws->q;
    memcpy(head + 1, ws->theta, sizeof(double) * ws->q);
    for (size_t i = 0; i < (size_t)ws->n * ws->q; i++)
        X[i] = (float)ws->X[i];
    return 1;
}

/* A seed's subspace size q; its block into X (n x q, interleaved). */
static int seed_unpack(const dm_modal *ws, const void *seed, double *X)
{
    const double *head = seed;
    int q = (int)head[0];
    assert(q >= 1 && q <= ws->qmax);
    const float *S = (const float *)(head + 1 + ws->qmax);
    for (size_t i = 0; i < (size_t)ws->n * q; i++)
        X[i] = S[i];
    return q;
}

void dm_modal_seed_load(dm_modal *ws, const void *seed)
{
    if (!uses_subspace(ws))
        return;
    ws->q = seed_unpack(ws, seed, ws->X);
    ws->nl = 0;
    memcpy(ws->theta, (const double *)seed + 1, sizeof(double) * ws->q);
    ws->have_start = 1;
    ws->nhist = 0;
    ws->ntoward = 0;
    ws->warm_error = ws->mix_floor = WARM_ERROR; /* nothing of the last solve carried over */
}

void dm_modal_seed_load_toward(dm_modal *ws, const void *seed, const void *const toward[],
                               const double frac[], int count)
{
    assert(count >= 0 && count <= DM_MODAL_TOWARD);
    dm_modal_seed_load(ws, seed);
    if (!uses_subspace(ws))
        return;
    for (int d = 0; d < count; d++) {
        /* another size of subspace (a seed left by a cold start) spans
         * other modes: no line between them */
        if ((int)((const double *)toward[d])[0] != ws->q || !(frac[d] > 0 && frac[d] <= 1))
            continue;
        seed_unpack(ws, toward[d], ws->toward[ws->ntoward]);
        ws->tfrac[ws->ntoward++] = frac[d];
    }
    if (ws->ntoward) {
        ws->warm_error = BETWEEN_ERROR;
        ws->mix_floor = BETWEEN_MIX;
    }
}

int dm_modal_set_start(dm_modal *ws, const double *X, int ncol, dm_error *err)
{
    if (!uses_subspace(ws) || ncol < ws->kmax + 2 || ncol > ws->qmax)
        return dm_fail(err, DM_EINVAL, "modal: a start needs the subspace method and %d..%d vectors",
                       ws->kmax + 2, ws->qmax);
    ws->q = ncol;
    ws->nl = 0;
    for (int j = 0; j < ncol; j++) /* column-major in, interleaved inside */
        for (int i = 0; i < ws->n; i++)
            ws->X[(size_t)i * ncol + j] = X[(size_t)j * ws->n + i];
    for (int j = 0; j < ncol; j++) /* nothing known of the spectrum: no Ritz values */
        ws->theta[j] = 0;
    ws->have_start = 1;
    ws->nhist = 0;
    return DM_OK;
}

/* ---- dense ------------------------------------------------------------------ */

static int solve_all(dm_modal *ws, dm_error *err)
{
    lapack_int n = ws->n;
    lapack_int info = LAPACKE_dsygvd_work(LAPACK_COL_MAJOR, 1, 'V', 'U', n, ws->A, n, ws->B, n,
                                          ws->w, ws->work, ws->lwork, ws->iwork, ws->liwork);
    if (info)
        return dm_fail(err, DM_ENUMERIC, "dsygvd failed (info %d): %s", (int)info,
                       info > n ? "mass matrix not positive definite" : "no convergence");
    ws->modes.phi = ws->A; /* eigenvectors overwrite A, B-orthonormal */
    ws->modes.mphi = NULL;
    return DM_OK;
}

/* Up to this size the reduction to standard form is two level-3
 * triangular solves; LAPACK's dsygst, blocked, wins beyond (measured on
 * one core: 38 against 12.5 us at 48, 122 against 71 at 96, 295 against
 * 253 at 150, 577 against 622 at 210: below its block size dsygst runs the
 * level-2 dsygs2). */
#define TRSM_REDUCTION_MAX 160

/* C = U^-T A U^-1 in place, for M = U'U (dpotrf 'U'), A stored whole (both
 * triangles): what dsygst (itype 1, 'U') computes. Its upper triangle is
 * set (both, when the triangular solves do it). */
static lapack_int reduce_to_standard(int n, const double *U, double *A)
{
    if (n > TRSM_REDUCTION_MAX)
        return LAPACKE_dsygst_work(LAPACK_COL_MAJOR, 1, 'U', n, A, n, U, n);
    cblas_dtrsm(CblasColMajor, CblasLeft, CblasUpper, CblasTrans, CblasNonUnit, n, n, 1.0, U, n,
                A, n);
    cblas_dtrsm(CblasColMajor, CblasRight, CblasUpper, CblasNoTrans, CblasNonUnit, n, n, 1.0, U,
                n, A, n);
    return 0;
}

/* The k lowest pairs of the standard problem C (in A, upper) of a small
 * model: C = Q T Q' (dsytrd), all eigenvalues of T (dsterf, ascending),
 * the k vectors of T by inverse iteration (dstein, T taken as one block:
 * valid for a split T too, only slower), then Q applied. */
static lapack_int small_eigen(dm_modal *ws, int k)
{
    lapack_int n = ws->n, info;
    info = LAPACKE_dsytrd_work(LAPACK_COL_MAJOR, 'U', n, ws->A, n, ws->d, ws->e, ws->tau,
                               ws->work, ws->lwork);
    if (info)
        return info;
    memcpy(ws->dd, ws->d, (size_t)n * sizeof(double));
    memcpy(ws->ee, ws->e, (size_t)(n - 1) * sizeof(double));
    if ((info = LAPACKE_dsterf_work(n, ws->dd, ws->ee)))
        return info;
    for (int j = 0; j < k; j++) {
        ws->w[j] = ws->dd[j];
        ws->iblock[j] = 1;
    }
    ws->isplit[0] = n;
    info = LAPACKE_dstein_work(LAPACK_COL_MAJOR, n, ws->d, ws->e, k, ws->w, ws->iblock,
                               ws->isplit, ws->Z, n, ws->work, ws->iwork, ws->ifail);
    if (!info)
        info = LAPACKE_dormtr_work(LAPACK_COL_MAJOR, 'L', 'U', 'N', n, k, ws->A, n, ws->tau,
                                   ws->Z, n, ws->work, ws->lwork);
    return info;
}

/* M = U'U; C = U^-T K U^-1; C y = lambda y; phi = U^-1 y (so Phi' M Phi = I). */
static int solve_partial(dm_modal *ws, int k, dm_error *err)
{
    lapack_int n = ws->n, m = k, info;
    assert(k <= ws->kdense);
    info = LAPACKE_dpotrf_work(LAPACK_COL_MAJOR, 'U', n, ws->B, n);
    if (info)
        return dm_fail(err, DM_ENUMERIC, "mass matrix not positive definite (dpotrf info %d)",
                       (int)info);
    info = reduce_to_standard(n, ws->B, ws->A);
    if (!info && small_model(ws))
        info = small_eigen(ws, k);
    else if (!info)
        info = LAPACKE_dsyevr_work(LAPACK_COL_MAJOR, 'V', 'I', 'U', n, ws->A, n, 0, 0, 1, k,
                                   0.0, &m, ws->w, ws->Z, n, ws->isuppz, ws->work, ws->lwork,
                                   ws->iwork, ws->liwork);
    if (info || m != k)
        return dm_fail(err, DM_ENUMERIC, "eigen solve failed (LAPACK info %d, %d of %d pairs)",
                       (int)info, (int)m, k);
    info = LAPACKE_dtrtrs_work(LAPACK_COL_MAJOR, 'U', 'N', 'N', n, k, ws->B, n, ws->Z, n);
    if (info)
        return dm_fail(err, DM_ENUMERIC, "back-substitution failed (dtrtrs info %d)", (int)info);
    ws->modes.phi = ws->Z;
    ws->modes.mphi = NULL;
    return DM_OK;
}

/* The k lowest pairs from every pair, with M = L L' by the block-arrow
 * factor: C = L^-1 K L^-T (dm_arrow_chol_reduce), C = Z Lambda Z' by
 * dsyevd, and Phi = L^-T Z for the k wanted columns of Z (Phi' M Phi =
 * Z' Z = I). */
static int solve_all_arrow(dm_modal *ws, const dm_model *md, int k, dm_error *err)
{
    int n = ws->n;
    if (dm_arrow_chol_factor(&ws->mchol, &md->M, NULL))
        return dm_fail(err, DM_ENUMERIC, "mass matrix not positive definite");
    dm_arrow_chol_reduce(&ws->mchol, &md->K, ws->B, ws->A);
    lapack_int info = LAPACKE_dsyevd_work(LAPACK_COL_MAJOR, 'V', 'L', n, ws->B, n, ws->w,
                                          ws->work, ws->lwork, ws->iwork, ws->liwork);
    if (info)
        return dm_fail(err, DM_ENUMERIC, "dsyevd failed (info %d): no convergence", (int)info);
    for (int i = 0; i < n; i++) /* Z's k columns as an interleaved block */
        for (int j = 0; j < k; j++)
            ws->A[(size_t)i * k + j] = ws->B[i + (size_t)j * n];
    dm_arrow_chol_backward(&ws->mchol, ws->A, k);
    for (int i = 0; i < n; i++)
        for (int j = 0; j < k; j++)
            ws->Z[i + (size_t)j * n] = ws->A[(size_t)i * k + j];
    ws->modes.phi = ws->Z;
    ws->modes.mphi = NULL;
    return DM_OK;
}

static int solve_dense(dm_modal *ws, const dm_model *md, int k, dm_error *err)
{
    if (arrow_all(ws, k))
        return solve_all_arrow(ws, md, k, err);
    dm_model_dense(md, ws->A, ws->B);
    return ws->method == DM_EIGEN_ALL ? solve_all(ws, err) : solve_partial(ws, k, err);
}

/* ---- subspace iteration --------------------------------------------------------
 *
 * A = K^-1 M (one solve with the block-arrow factor of K and one product
 * with M per application) has the eigenvalues mu = 1 / lambda, the wanted
 * ones largest. Each round filters the block X by a Chebyshev polynomial
 * in A of degree d that is bounded by 1 on the unwanted part [0, 1/theta_q]
 * and grows fastest outside it, then does one Rayleigh-Ritz: a round of
 * degree d does what d rounds of plain subspace iteration would, with one
 * projection instead of d. The next round's first application checks the
 * residuals of the Ritz pairs; when the wanted ones have converged, a Sturm
 * count proves that no mode below them was missed. */

/* Number of Ritz pairs that must converge for k wanted modes: k, extended
 * through any cluster that k would cut (tracking and the Sturm count need
 * whole clusters), leaving at least one buffer vector; 0 when there is no
 * gap inside the subspace. */
static int wanted_count(const double *theta, int q, int k)
{
    for (int j = k; j < q; j++)
        if (theta[j] > theta[j - 1] * (1 + CLUSTER_GAP))
            return j;
    return 0;
}

static int active(const dm_modal *ws) { return ws->q - ws->nl; }

/* The residual at which the kw wanted pairs count as converged. */
static double converged_at(const dm_modal *ws, int kw)
{
    double t0 = ws->theta[0], tw = ws->theta[kw - 1];
    return t0 > 0 && tw > SPREAD_TIGHT * t0 ? TIGHTER * CONVERGED : CONVERGED;
}

/* out = A in for the active block, made M-orthogonal to the locked
 * vectors; min = M in. For locked eigenvectors XL, XL' M A y = Theta_L^-1
 * XL' M y: what to remove follows from M y, which the product gives. */
static void apply_A(dm_modal *ws, const dm_model *md, const dm_arrow_chol *L, const double *in,
                    double *min, double *out)
{
    int qa = active(ws), n = ws->n, nl = ws->nl;
    dm_model_mult_M(md, in, qa, min);
    memcpy(out, min, sizeof(double) * n * qa);
    dm_arrow_chol_solve(L, out, qa);
    if (!nl)
        return;
    /* interleaved n x qa == column-major qa x n */
    cblas_dgemm(CblasColMajor, CblasTrans, CblasTrans, nl, qa, n, 1.0, ws->XL, n, min, qa, 0.0,
                ws->C, nl);
    for (int j = 0; j < qa; j++)
        for (int i = 0; i < nl; i++)
            ws->C[j * nl + i] /= ws->theta[i];
    cblas_dgemm(CblasColMajor, CblasTrans, CblasTrans, qa, n, nl, -1.0, ws->C, nl, ws->XL, n, 1.0,
                out, qa);
}

/* A filtered block whose scaled Gram matrix has a Cholesky pivot below
 * this is too close to rank-deficient for the projection through that
 * factor (its errors grow with the square of the block's condition). It
 * is first made M-orthonormal through the Gram matrix's eigenvectors
 * (rebase_block), which loses only the first power: a direction whose
 * Gram eigenvalue is S (of the largest) comes out with round-off
 * eps / sqrt(S) (relative). Below REBASE_MIN that exceeds the residual a
 * pair converges to (CONVERGED), and the block is filtered again with a
 * lower degree. (Rebased or not, a pair is accepted only on the residual
 * of the next round's fresh products, and the Sturm count follows.)
 * The filter damps a buffer column's own mode and amplifies the wanted
 * ones it carries, so the last column is the one that collapses: on
 * chen2018's 64 x 64 sweep at 210 DOF at 1 049 of 4 350 solves, all
 * redone before with a lower degree (4 applications lost each; 7.0
 * applications a solve, now 6.0). */
#define COLLAPSED_PIVOT 1e-6
#define REBASE_MIN 1e-16

/* K~ = V' K V, M~ = V' M V over the active block (q columns), each column
 * scaled to unit M-norm (a filtered block is far from orthogonal), both
 * exactly symmetric. */
static void project_block(dm_modal *ws, const double *V, const double *KV, const double *MV)
{
    int n = ws->n, q = active(ws);
    cblas_dgemm(CblasColMajor, CblasNoTrans, CblasTrans, q, q, n, 1.0, V, q, KV, q, 0.0, ws->Kt, q);
    cblas_dgemm(CblasColMajor, CblasNoTrans, CblasTrans, q, q, n, 1.0, V, q, MV, q, 0.0, ws->Mt, q);
    for (int j = 0; j < q; j++)
        ws->scale[j] = 1.0 / sqrt(ws->Mt[j * q + j]);
    for (int j = 0; j < q; j++) /* scaled, exactly symmetric */
        for (int i = 0; i <= j; i++) {
            double sij = ws->scale[i] * ws->scale[j];
            ws->Kt[j * q + i] = ws->Kt[i * q + j] =
                0.5 * (ws->Kt[j * q + i] + ws->Kt[i * q + j]) * sij;
            ws->Mt[j * q + i] = 0.5 * (ws->Mt[j * q + i] + ws->Mt[i * q + j]) * sij;
        }
}

/* M~ = R'R in place (dpotrf 'U'); 0 if a pivot fails or falls below
 * COLLAPSED_PIVOT. */
static int factor_gram(double *Mt, int q)
{
    if (LAPACKE_dpotrf_work(LAPACK_COL_MAJOR, 'U', q, Mt, q))
        return 0;
    for (int j = 0; j < q; j++)
        if (!(Mt[j * q + j] >= COLLAPSED_PIVOT))
            return 0;
    return 1;
}

/* The filtered block V = T (K V in MX, M V in MT) made M-orthonormal
 * (SVQB: Stathopoulos & Wu 2002): with its scaled Gram matrix D V' M V D
 * = U S U' (given in C, the scaling in ws->scale), W = D U S^-1/2 and
 * V W into Y, K V W into X, M V W into T, the same subspace. 0 when the
 * Gram matrix has lost a direction. */
static int rebase_block(dm_modal *ws)
{
    int n = ws->n, q = active(ws);
    double *S = ws->res, *U = ws->C, *W = ws->Mt; /* scratch until the next round */
    if (LAPACKE_dsyevd_work(LAPACK_COL_MAJOR, 'V', 'U', q, U, q, S, ws->swork, ws->slwork,
                            ws->siwork, ws->sliwork) ||
        !(S[0] >= REBASE_MIN * S[q - 1]))
        return 0;
    for (int j = 0; j < q; j++)
        for (int i = 0; i < q; i++)
            W[j * q + i] = ws->scale[i] * U[j * q + i] / sqrt(S[j]);
    /* interleaved n x q == column-major q x n: (V W)_t = W' V_t */
    cblas_dgemm(CblasColMajor, CblasTrans, CblasNoTrans, q, n, q, 1.0, W, q, ws->T, q, 0.0, ws->Y, q);
    cblas_dgemm(CblasColMajor, CblasTrans, CblasNoTrans, q, n, q, 1.0, W, q, ws->MX, q, 0.0, ws->X, q);
    cblas_dgemm(CblasColMajor, CblasTrans, CblasNoTrans, q, n, q, 1.0, W, q, ws->MT, q, 0.0, ws->T, q);
    return 1;
}

/* Rayleigh-Ritz on span(V), V = T the active block, with K V in MX and
 * M V in MT: X = V Q, ascending Ritz values after the locked ones. A
 * filtered block that collapsed is rebased first where `may_rebase`.
 * DM_ENUMERIC when V has collapsed beyond that. */
static int rayleigh_ritz(dm_modal *ws, int may_rebase)
{
    int n = ws->n, q = active(ws);
    double *theta = ws->theta + ws->nl;
    const double *V = ws->T;
    ws->mx_fresh = 0; /* X changes, MX does not */
    project_block(ws, V, ws->MX, ws->MT);
    if (may_rebase) /* the Gram matrix, for a rebase */
        memcpy(ws->C, ws->Mt, sizeof(double) * q * q);
    if (!factor_gram(ws->Mt, q)) {
        if (!may_rebase || !rebase_block(ws))
            return DM_ENUMERIC;
        ws->stats.rebased++;
        V = ws->Y;
        project_block(ws, V, ws->X, ws->T);
        if (!factor_gram(ws->Mt, q))
            return DM_ENUMERIC;
    }
    /* C = R^-T K~ R^-1 = Z Theta Z', Q = R^-1 Z (what dsygvd does, with a
     * look at the pivots) */
    if (reduce_to_standard(q, ws->Mt, ws->Kt) ||
        LAPACKE_dsyevd_work(LAPACK_COL_MAJOR, 'V', 'U', q, ws->Kt, q, theta, ws->swork,
                            ws->slwork, ws->siwork, ws->sliwork))
        return DM_ENUMERIC;
    cblas_dtrsm(CblasColMajor, CblasLeft, CblasUpper, CblasNoTrans, CblasNonUnit, q, q, 1.0,
                ws->Mt, q, ws->Kt, q);
    for (int j = 0; j < q; j++) /* undo the scaling: X = V D Q */
        for (int i = 0; i < q; i++)
            ws->Kt[j * q + i] *= ws->scale[i];
    /* X_t = Q' V_t (V is T or Y, never X) */
    cblas_dgemm(CblasColMajor, CblasTrans, CblasNoTrans, q, n, q, 1.0, ws->Kt, q, V, q, 0.0, ws->X, q);
    return DM_OK;
}

/* res_j = ||x_j - theta_j A x_j||_M for the active pairs, from X, M X,
 * T = A X and M T. */
static void residuals(dm_modal *ws)
{
    int n = ws->n, q = active(ws);
    const double *theta = ws->theta + ws->nl;
    for (int j = 0; j < q; j++)
        ws->res[j] = 0;
    for (int i = 0; i < n; i++) {
        const double *x = ws->X + (size_t)i * q, *mx = ws->MX + (size_t)i * q;
        const double *t = ws->T + (size_t)i * q, *mt = ws->MT + (size_t)i * q;
        for (int j = 0; j < q; j++)
            ws->res[j] += (x[j] - theta[j] * t[j]) * (mx[j] - theta[j] * mt[j]);
    }
    for (int j = 0; j < q; j++)
        ws->res[j] = sqrt(fabs(ws->res[j]));
}

/* Drop the first m columns of an interleaved block of width q (in place:
 * every value moves to a lower address). */
static void drop_columns(double *X, int n, int q, int m)
{
    int qn = q - m;
    for (int i = 0; i < n; i++)
        for (int j = 0; j < qn; j++)
            X[(size_t)i * qn + j] = X[(size_t)i * q + m + j];
}

/* The most of the m leading active pairs that end on a gap (a cluster is
 * locked whole or not at all). */
static int uncut(const dm_modal *ws, int m)
{
    int nl = ws->nl;
    while (m > 0 && nl + m < ws->q && ws->theta[nl + m] <= ws->theta[nl + m - 1] * (1 + CLUSTER_GAP))
        m--;
    return m;
}

/* Lock the leading active pairs that have converged, up to the kw wanted,
 * never half a cluster: they leave the filtered block, which stays
 * M-orthogonal to them (apply_A). */
static void lock_converged(dm_modal *ws, int kw, double conv)
{
    int n = ws->n, qa = active(ws), nl = ws->nl, m = 0;
    while (nl + m < kw && ws->res[m] <= conv)
        m++;
    m = uncut(ws, m);
    if (nl + m < kw) { /* not the last: the active block a multiple of SUBSPACE_STEP */
        while (m > 0 && (qa - m) % SUBSPACE_STEP)
            m--;
        m = uncut(ws, m);
    }
    if (!m)
        return;
    for (int j = 0; j < m; j++) {
        ws->stats.residual = fmax(ws->stats.residual, ws->res[j]);
        for (int i = 0; i < n; i++)
            ws->XL[(size_t)(nl + j) * n + i] = ws->X[(size_t)i * qa + j];
        for (int i = 0; i < n && ws->mx_fresh; i++)
            ws->MXL[(size_t)(nl + j) * n + i] = ws->MX[(size_t)i * qa + j];
    }
    ws->mxl_whole &= ws->mx_fresh || m == 0;
    double *blocks[] = {ws->X, ws->MX, ws->T, ws->MT};
    for (int b = 0; b < 4; b++)
        drop_columns(blocks[b], n, qa, m);
    memmove(ws->res, ws->res + m, sizeof(double) * (qa - m));
    ws->nl += m;
}

/* What a filter of degree d gains on the components outside the subspace
 * against the last wanted mode: mu T_{d-1}(2 mu / b - 1) / b at mu = 1 /
 * lambda_kw, b = 1 / theta_q, i.e. (1 + g) T_{d-1}(1 + 2 g). */
static double filter_gain(int d, double g)
{
    return (1 + g) * cosh((d - 1) * acosh(1 + 2 * g));
}

/* The filter also amplifies the lowest active mode more than the last
 * wanted one, by (theta_kw / theta_0) T_{d-1}(2 theta_q / theta_0 - 1) /
 * T_{d-1}(2 theta_q / theta_kw - 1): a column's error along the lowest
 * modes grows by that against its own mode, and past a point the block is
 * too close to rank-deficient for an accurate projection. Locking the low
 * modes as they converge keeps this small. */
static double filter_skew(int d, double t0, double tw, double tq)
{
    return tw / t0 * cosh((d - 1) * acosh(2 * tq / t0 - 1)) / cosh((d - 1) * acosh(2 * tq / tw - 1));
}
#define MAX_SKEW 10.0

/* The lowest degree that gains `reduction`, within the skew limit for
 * columns whose error is `error`. */
static int filter_degree(double reduction, double error, double t0, double tw, double tq)
{
    double g = tq / tw - 1;
    int d = 1;
    while (d < MAX_DEGREE && filter_gain(d, g) < reduction &&
           filter_skew(d + 1, t0, tw, tq) * error <= MAX_SKEW)
        d++;
    return d;
}

/* Y_{j+1} = 2 (c A Y_j - Y_j) - Y_{j-1} with A Y_j in T, in place of Y_{j-1} */
static void chebyshev_step(double *prev, const double *cur, const double *T, double c, size_t len)
{
    for (size_t i = 0; i < len; i++)
        prev[i] = 2 * (c * T[i] - cur[i]) - prev[i];
}

/* One filter of degree d on the active block, then Rayleigh-Ritz. */
static int filter_once(dm_modal *ws, const dm_model *md, const dm_arrow_chol *L, int d,
                       double c, int have_mt)
{
    int qa = active(ws);
    size_t len = (size_t)ws->n * qa;
    if (d > 1) { /* Y0 = X, Y1 = c A X - X, ..., then V = A Y_{d-1} in T */
        double *prev = ws->X, *cur = ws->Y;
        for (size_t i = 0; i < len; i++)
            cur[i] = c * ws->T[i] - prev[i];
        for (int j = 1; j < d - 1; j++) {
            apply_A(ws, md, L, cur, ws->MT, ws->T);
            chebyshev_step(prev, cur, ws->T, c, len);
            double *t = prev;
            prev = cur;
            cur = t;
        }
        apply_A(ws, md, L, cur, ws->MX, ws->T); /* K V = M Y_{d-1} */
        ws->stats.iterations += d - 1;
    }
    if (d > 1 || !have_mt) /* M V (for d = 1 after a check it is M A X, done) */
        dm_model_mult_M(md, ws->T, qa, ws->MT);
    return rayleigh_ritz(ws, 1);
}

/* Filter the active block by degree d and project: V = A p_{d-1}(A) X,
 * from X, T = A X and M X; a block that collapsed (beyond a rebase) is
 * filtered again from the same start with a lower degree. Returns the
 * degree used, 0 if even d = 1 collapsed. */
static int filter_and_project(dm_modal *ws, const dm_model *md, const dm_arrow_chol *L, int d,
                              double c, int have_mt)
{
    size_t len = (size_t)ws->n * active(ws);
    if (d > 1) { /* kept for a retry (degree 1 has none) */
        memcpy(ws->Xs, ws->X, sizeof(double) * len);
        memcpy(ws->Ts, ws->T, sizeof(double) * len);
        memcpy(ws->MXs, ws->MX, sizeof(double) * len);
    }
    for (; d >= 1; d--) {
        if (filter_once(ws, md, L, d, c, have_mt) == DM_OK)
            return d;
        if (d == 1)
            break;
        memcpy(ws->X, ws->Xs, sizeof(double) * len);
        memcpy(ws->T, ws->Ts, sizeof(double) * len);
        memcpy(ws->MX, ws->MXs, sizeof(double) * len);
        have_mt = 0;
    }
    return 0;
}


/* What the block in ws->X is at the start of iterate(). */
enum start {
    START_WARM,  /* another pose's Ritz pairs: theta approximate */
    START_DENSE, /* this pose's eigenpairs from the dense solver: vectors
                    good, values only to eps * lambda_max */
};

/* The dense start converged as it is: one Rayleigh-Ritz on span(A X)
 * gives the values to the vectors' accuracy (its K-projection X' M A X
 * needs no product with K, whose round-off is what the dense values
 * carry), then the kw wanted pairs are locked. */
static int finish_dense(dm_modal *ws, int kw)
{
    if (rayleigh_ritz(ws, 0))
        return 0;
    ws->stats.rounds++;
    for (int j = 0; j < kw; j++)
        ws->res[j] = 0; /* converged before the projection, which keeps them */
    lock_converged(ws, kw, CONVERGED);
    return ws->nl >= kw ? kw : 0;
}

/* Rounds of filter + Rayleigh-Ritz from the block in ws->X (q vectors,
 * nothing locked) until the wanted pairs converge and are locked. Returns
 * the number of converged pairs (>= k), or 0. */
static int iterate(dm_modal *ws, const dm_model *md, const dm_arrow_chol *L, int k,
                   enum start start)
{
    int ritz = start == START_DENSE; /* X holds pairs of this pose */
    int q = ws->q;
    double first_gain = 0; /* of a warm start's first filter */
    double last_worst = INFINITY; /* the wanted pairs' largest residual, last round */
    ws->nl = 0;
    ws->mxl_whole = 1;
    for (int round = 0; round <= MAX_ROUNDS; round++) {
        apply_A(ws, md, L, ws->X, ws->MX, ws->T); /* T = A X */
        ws->mx_fresh = 1;
        ws->stats.iterations++;
        int kw = wanted_count(ws->theta, q, k);
        double error = ws->warm_error;
        /* (the dense start, the last resort, keeps the usual residual: its
         * pairs are already as good as this pose's round-off allows) */
        double conv = start == START_DENSE ? CONVERGED : converged_at(ws, kw ? kw : k);
        if (ritz) { /* check the pairs in X, lock the converged */
            dm_model_mult_M(md, ws->T, active(ws), ws->MT);
            residuals(ws);
            double worst = 0;
            for (int j = 0; j < (kw ? kw : k) - ws->nl; j++)
                worst = fmax(worst, ws->res[j]);
            /* the tighter residual out of reach (round-off stalls it, or
             * the rounds run out): the usual one */
            if (conv < CONVERGED && (worst > 0.5 * last_worst || round == MAX_ROUNDS))
                conv = CONVERGED;
            last_worst = worst;
            /* how far off a warm start was, measured whether or not this
             * round converges (measured only when it did not, the estimate
             * never came down along a path: chen2018's and zheng2017's
             * first filters kept degree 3 and 4 where 2 and 1 converge) */
            if (start == START_WARM && round == 1 && first_gain > 0)
                ws->warm_error = fmin(1e-1, fmax(1e-9, worst * first_gain));
            if (kw && start == START_DENSE && round == 0) {
                if (worst <= conv) {
                    ws->stats.residual = worst;
                    return finish_dense(ws, kw);
                }
            } else if (kw) {
                lock_converged(ws, kw, conv);
            }
            if (kw && ws->nl >= kw)
                return kw;
            error = 0; /* of the wanted pairs: the buffer's do not count */
            for (int j = 0; j < (kw ? kw : k) - ws->nl; j++)
                error = fmax(error, ws->res[j]);
        }
        if (round == MAX_ROUNDS)
            break;
        /* the filter: unwanted interval [0, b], b = 1 / theta_q, with the
         * Ritz values of this pose, or of the last one for a warm start;
         * without any (a start given from outside): plain subspace iteration */
        double t0 = ws->theta[ws->nl], tw = ws->theta[(kw ? kw : k) - 1], tq = ws->theta[q - 1];
        /* the skew limit needs how far a column strays towards the lowest
         * modes, which residuals do not show (the projection removes it):
         * for another pose's vectors, assume WARM_ERROR (BETWEEN_MIX
         * between seeds) */
        double mix = ritz ? error : fmax(error, ws->mix_floor);
        int d = t0 > 0 && tw > t0 && tq > tw
                    ? filter_degree(fmax(error, conv) / (TARGET * conv), mix, t0, tw, tq)
                    : 1;
        if (!(d = filter_and_project(ws, md, L, d, 2 * tq, ritz)))
            return 0;
        if (round == 0 && start == START_WARM)
            first_gain = filter_gain(d, tq / tw - 1);
        ritz = 1;
        ws->stats.rounds++;
    }
    return 0;
}

/* After convergence: locked and active vectors back into one block of q
 * (the start of the next solve), in ascending order. */
static void merge_block(dm_modal *ws)
{
    int n = ws->n, q = ws->q, nl = ws->nl, qa = active(ws);
    for (int i = 0; i < n; i++) {
        for (int j = 0; j < nl; j++)
            ws->Y[(size_t)i * q + j] = ws->XL[(size_t)j * n + i];
        for (int j = 0; j < qa; j++)
            ws->Y[(size_t)i * q + nl + j] = ws->X[(size_t)i * qa + j];
    }
    double *t = ws->X;
    ws->X = ws->Y;
    ws->Y = t;
    ws->nl = 0;
}

/* The eigenvalues below sigma, or below a shift a little above it where a
 * pivot at sigma makes the count untrustworthy (sigma on an eigenvalue of
 * a block). */
static int count_near(dm_arrow_ldl *ldl, const dm_model *md, double sigma, dm_modal_count *c)
{
    for (int attempt = 0; attempt < 4; attempt++, sigma *= 1 + 0.05 * CLUSTER_GAP)
        if (dm_arrow_count_below(ldl, &md->K, &md->M, sigma, &c->count) == DM_OK) {
            c->sigma = sigma;
            return 1;
        }
    return 0;
}

/* Count the eigenvalues below a shift in the gap after the kw-th Ritz
 * value: it must be kw, else a mode was missed. A count made ahead at a
 * shift at or above this one proves it as well when it is kw (a missed
 * mode below the lower shift would be below the higher one too); when it
 * is not, the count here decides, as without it. */
static int sturm_check(dm_modal *ws, const dm_model *md, int kw)
{
    double sigma = ws->theta[kw - 1] * (1 + 0.5 * CLUSTER_GAP);
    ws->stats.shift = sigma;
    if (ws->offer.count == kw && ws->offer.sigma >= sigma) {
        ws->stats.sigma = ws->offer.sigma;
        ws->stats.counted_ahead = 1;
        return 1;
    }
    dm_modal_count c;
    if (!count_near(&ws->ldl, md, sigma, &c))
        return 0;
    ws->stats.sigma = c.sigma;
    return c.count == kw;
}

/* Where the prediction from the solves before puts a count made ahead,
 * relative to the predicted shift: a quarter of the cluster gap above it.
 * The solve's own shift lies half a gap above its last converged Ritz
 * value, the next Ritz value (not in the cluster) a gap or more above it:
 * a count a quarter gap above the prediction lands between the two while
 * the prediction is off by less than a quarter gap (2.5e-4 relative; the
 * quadratic extrapolation over 1 ms steps is off by < 1e-6, measured on
 * the presets' paper trajectories). */
#define AHEAD_SLACK (0.25 * CLUSTER_GAP)

int dm_modal_count_ahead(dm_arrow_ldl *ldl, const dm_model *md, const double shift[3],
                         dm_modal_count *out)
{
    /* the quadratic through steps -2, -3, -4, at step 0 */
    double predicted = 6 * shift[0] - 8 * shift[1] + 3 * shift[2];
    if (!(predicted > 0) || !isfinite(predicted))
        return DM_ENUMERIC;
    return count_near(ldl, md, predicted * (1 + AHEAD_SLACK), out) ? DM_OK : DM_ENUMERIC;
}

void dm_modal_offer_count(dm_modal *ws, const dm_modal_count *count) { ws->offer = *count; }

/* The subspace for kw wanted pairs given the lowest eigenvalues w[0 ..
 * count - 1] (ascending): the smallest q (with two buffer vectors at
 * least) whose next eigenvalue is SUBSPACE_RATIO (PATH_RATIO along a
 * path) times the last wanted one, else the q with the widest such ratio,
 * rounded up to a multiple of SUBSPACE_STEP, at most `most`; 0 if count
 * leaves no choice. */
static int subspace_size(const dm_modal *ws, const double *w, int count, int kw, int most)
{
    int q = 0;
    double best = 0, enough = ws->follow ? PATH_RATIO : SUBSPACE_RATIO;
    for (int j = kw + 2; j < count; j++) {
        double ratio = w[j] / w[kw - 1];
        if (ratio > best * 1.05) {
            best = ratio;
            q = j;
        }
        if (ratio >= enough)
            break;
    }
    if (q > 0) {
        int up = (q + SUBSPACE_STEP - 1) / SUBSPACE_STEP * SUBSPACE_STEP;
        assert(q <= most);
        q = up < most ? up : most;
    }
    return q;
}

/* The dense cold start: the dense solver's lowest pairs, and the subspace
 * sized from them. */
static int cold_start(dm_modal *ws, const dm_model *md, int k, dm_error *err)
{
    int rc = solve_dense(ws, md, ws->kdense, err);
    if (rc)
        return rc;
    int kw = wanted_count(ws->w, ws->qmax, k), n = ws->n;
    if (!kw)
        kw = k;
    int count = ws->qmax + 1 < ws->kdense ? ws->qmax + 1 : ws->kdense;
    int q = subspace_size(ws, ws->w, count, kw, count < ws->qmax ? count : ws->qmax);
    ws->q = q ? q : ws->qmax;
    for (int j = 0; j < ws->q; j++) {
        ws->theta[j] = ws->w[j];
        for (int i = 0; i < n; i++)
            ws->X[(size_t)i * ws->q + j] = ws->Z[(size_t)j * n + i];
    }
    return DM_OK;
}

/* A cold start without the dense solver: the largest subspace, of
 * pseudo-random vectors (the same sequence at every call, so a result
 * does not depend on what was solved before), iterated like a warm start
 * whose Ritz values are not known yet (the first round is one plain
 * application of K^-1 M). At 210 DOF it converges the 10-14 lowest modes
 * in 7-14 applications (see starts_random). */
static void random_start(dm_modal *ws)
{
    dm_rng rng = {.state = 0x9e3779b97f4a7c15u};
    ws->q = ws->qmax;
    ws->nl = 0;
    for (size_t i = 0; i < (size_t)ws->n * ws->q; i++)
        ws->X[i] = dm_rng_uniform(&rng) - 0.5;
    for (int j = 0; j < ws->q; j++)
        ws->theta[j] = 0;
}

/* Above DM_SMALL_MODEL DOF the random block is measured faster than the
 * dense solver (1.7x at 102 DOF, 3-4x at 210, 5-8x at 426); at 66 it is
 * not (dsterf/dstein's small-model path). */
static int starts_random(const dm_modal *ws)
{
    return ws->cold == DM_COLD_RANDOM || (ws->cold == DM_COLD_AUTO && ws->n > DM_SMALL_MODEL);
}

void dm_modal_set_cold_start(dm_modal *ws, dm_cold_start how) { ws->cold = how; }

/* Keep the first q columns of the merged block (a random start's
 * subspace, cut to the size a dense start would have chosen). */
static void shrink_block(dm_modal *ws, int q)
{
    if (q < ws->kmax + 2 || q >= ws->q)
        return;
    for (int i = 0; i < ws->n; i++)
        for (int j = 0; j < q; j++)
            ws->X[(size_t)i * q + j] = ws->X[(size_t)i * ws->q + j];
    ws->q = q;
}

/* P = H (H' M X) for the first m columns of X and H: the part of X in
 * span(H), M-orthogonally (H's columns M-orthonormal at a neighbouring
 * pose, which is accurate to first order in the step: enough for a
 * start). MX = M X given (interleaved rows of ldmx); H and P blocks of q
 * interleaved, P's other columns left as they are. */
static void project_on(const dm_modal *ws, const double *H, const double *MX, int ldmx, double *P,
                       int m)
{
    int n = ws->n, q = ws->q;
    /* interleaved n x q == column-major q x n: m columns are its first m rows */
    cblas_dgemm(CblasColMajor, CblasNoTrans, CblasTrans, m, m, n, 1.0, H, q, MX, ldmx, 0.0, ws->C,
                m);
    cblas_dgemm(CblasColMajor, CblasTrans, CblasNoTrans, m, n, m, 1.0, ws->C, m, H, q, 0.0, P, q);
}

/* Along a path, the start of the next solve: the converged subspaces of
 * the last solves (X_t, X_t-1, X_t-2, equally spaced) extrapolated,
 * linearly or quadratically: X_t + (X_t - P_t-1 X_t), or 3 X_t -
 * 3 P_t-1 X_t + P_t-2 X_t, with P_s X_t the part of X_t in span(X_s)
 * (which aligns the bases: Ritz vectors come with any sign, pairs in any
 * rotation). The error of the start drops from O(h) to O(h^2) or O(h^3),
 * and the filter planned from the measured error needs a lower degree.
 * Only the leading columns that converged at all three solves take part:
 * the buffer's Ritz vectors carry unconverged parts of the modes above the
 * block, and a span that holds them passes them on to every column
 * projected on it (chen2018's circle at 210 DOF, whose 19th vector is a
 * mode with a near neighbour above: the wanted pairs started 1e-4 off, a
 * block of 18 whose last vector converges with them 3e-7; 5.7
 * applications a step, now 4). The buffer columns start where they
 * were. */
static void extrapolate(dm_modal *ws, const dm_model *md)
{
    int n = ws->n, q = ws->q, m = ws->kc;
    for (int h = 0; h < ws->nhist; h++)
        m = m < ws->hist_kc[h] ? m : ws->hist_kc[h];
    if (ws->nhist > 0 && m > 0) { /* M times the m columns extrapolated alone (Y is free) */
        for (int i = 0; i < n; i++)
            for (int j = 0; j < m; j++)
                ws->Y[(size_t)i * m + j] = ws->X[(size_t)i * q + j];
        dm_model_mult_M(md, ws->Y, m, ws->MX);
        project_on(ws, ws->hist[0], ws->MX, m, ws->T, m);
        if (ws->nhist > 1)
            project_on(ws, ws->hist[1], ws->MX, m, ws->MT, m);
    }
    double *oldest = ws->hist[1]; /* X_t joins the history, X_t-2 leaves */
    ws->hist[1] = ws->hist[0];
    ws->hist[0] = oldest;
    ws->hist_kc[1] = ws->hist_kc[0];
    ws->hist_kc[0] = ws->kc;
    memcpy(ws->hist[0], ws->X, sizeof(double) * n * q);
    for (int i = 0; i < n && ws->nhist > 0; i++)
        for (int j = 0; j < m; j++) {
            size_t l = (size_t)i * q + j;
            ws->X[l] = ws->nhist == 1 ? 2 * ws->X[l] - ws->T[l]
                                      : 3 * (ws->X[l] - ws->T[l]) + ws->MT[l];
        }
    ws->nhist += ws->nhist < 2;
}

/* A start between seeds: X + sum_d f_d (P_d X - X), with P_d X the part of
 * the seed's block X in span(toward_d), which aligns the bases as in
 * extrapolate(): linear interpolation of the subspace along each lattice
 * axis, so the start's error drops from O(h) to O(h^2) in the distance h
 * to the seed's pose. */
static void interpolate(dm_modal *ws, const dm_model *md)
{
    size_t len = (size_t)ws->n * ws->q;
    dm_model_mult_M(md, ws->X, ws->q, ws->MX);
    memcpy(ws->Y, ws->X, sizeof(double) * len);
    for (int d = 0; d < ws->ntoward; d++) {
        project_on(ws, ws->toward[d], ws->MX, ws->q, ws->T, ws->q);
        for (size_t i = 0; i < len; i++)
            ws->Y[i] += ws->tfrac[d] * (ws->T[i] - ws->X[i]);
    }
    double *t = ws->X;
    ws->X = ws->Y;
    ws->Y = t;
    ws->ntoward = 0;
}

static int solve_subspace(dm_modal *ws, const dm_model *md, const dm_static *factor, int k,
                          dm_error *err)
{
    const dm_arrow_chol *L = dm_static_chol(factor);
    memset(&ws->stats, 0, sizeof ws->stats);
    ws->stats.warm = ws->have_start;
    int kw = 0, rc = DM_OK;
    if (ws->have_start) {
        if (ws->ntoward)
            interpolate(ws, md);
        if (ws->follow)
            extrapolate(ws, md);
        kw = iterate(ws, md, L, k, START_WARM);
        ws->mix_floor = WARM_ERROR; /* an interpolated start's, for this solve only */
        if (kw && !sturm_check(ws, md, kw))
            kw = 0;
        ws->stats.fallback = !kw;
    }
    ws->nhist = kw ? ws->nhist : 0; /* a cold start may change the subspace's size */
    if (!kw && starts_random(ws)) {
        random_start(ws);
        kw = iterate(ws, md, L, k, START_WARM);
        if (kw && !sturm_check(ws, md, kw))
            kw = 0;
        ws->stats.random = kw > 0;
    }
    if (!kw) {
        ws->have_start = 0;
        if ((rc = cold_start(ws, md, k, err)))
            return rc;
        /* the dense pairs are the lowest: iterate only to converge them */
        if (!(kw = iterate(ws, md, L, k, START_DENSE)) || !sturm_check(ws, md, kw))
            return dm_fail(err, DM_ENUMERIC,
                           "eigen solve: subspace iteration did not converge on %d modes", k);
    }
    ws->stats.subspace = ws->q;
    ws->stats.converged = kw;
    ws->kc = kw;
    ws->have_start = 1;
    for (int j = 0; j < k; j++) /* the locked vectors are the modes */
        ws->w[j] = ws->theta[j];
    memcpy(ws->phi, ws->XL, sizeof(double) * ws->n * k);
    if (ws->mxl_whole) /* (a dense start's pairs locked after a projection: none) */
        memcpy(ws->mphi, ws->MXL, sizeof(double) * ws->n * k);
    merge_block(ws);
    if (ws->stats.random) /* Ritz values of the block: converged, or upper bounds */
        shrink_block(ws, subspace_size(ws, ws->theta, ws->q, kw, ws->q));
    ws->modes.phi = ws->phi;
    ws->modes.mphi = ws->mxl_whole ? ws->mphi : NULL;
    return DM_OK;
}

int dm_modal_omega(const double *lambda, int k, double *omega, dm_error *err)
{
    for (int j = 0; j < k; j++) {
        if (!(lambda[j] > 0))
            return dm_fail(err, DM_ENUMERIC,
                           "mode %d has eigenvalue %g <= 0: the structure is a mechanism", j + 1,
                           lambda[j]);
        omega[j] = sqrt(lambda[j]);
    }
    return DM_OK;
}

int dm_modal_solve(dm_modal *ws, const dm_model *md, const dm_static *factor, int k,
                   const dm_modes **modes, dm_error *err)
{
    if (k < 1 || k > ws->kmax) {
        ws->offer.count = -1; /* a count made ahead is for this solve alone */
        return dm_fail(err, DM_EINVAL, "modes: %d requested, workspace holds 1..%d", k,
                       ws->kmax);
    }
    assert(md->n == ws->n);
    int rc;
    if (uses_subspace(ws)) {
        assert(factor);
        rc = solve_subspace(ws, md, factor, k, err);
    } else {
        memset(&ws->stats, 0, sizeof ws->stats);
        rc = solve_dense(ws, md, k, err);
    }
    ws->offer.count = -1; /* it was for this model alone */
    if (rc)
        return rc;
    ws->modes.n = ws->n;
    ws->modes.k = k;
    if ((rc = dm_modal_omega(ws->w, k, ws->modes.omega_rad_s, err)))
        return rc;
    for (int j = 0; j < k; j++)
        ws->modes.freq_hz[j] = ws->modes.omega_rad_s[j] / (2.0 * M_PI);
    *modes = &ws->modes;
    return DM_OK;
}

/* ---- shapes ----------------------------------------------------------------- */

void dm_modal_mode_platform_share(const double *MP, int ld, const double *phiP, double *share,
                                  int *direction)
{
    double best = -1;
    *share = 0;
    for (int r = 0; r < 6; r++) {
        double row = 0;
        for (int c = 0; c < 6; c++)
            row += MP[(size_t)ld * c + r] * phiP[c];
        double energy = phiP[r] * row; /* diagonal contribution by direction */
        *share += energy;
        if (energy > best) {
            best = energy;
            *direction = r;
        }
    }
}

void dm_modal_platform_share(dm_modal *ws, const dm_model *md)
{
    dm_modes *mo = &ws->modes;
    for (int j = 0; j < mo->k; j++)
        dm_modal_mode_platform_share(md->platform_mass, 6,
                                     mo->phi + (size_t)j * mo->n + md->platform_dof,
                                     &mo->platform_share[j], &mo->direction[j]);
}

const char *dm_direction_name(int d)
{
    static const char *const names[] = {"x", "y", "z", "rx", "ry", "rz"};
    return d >= 0 && d < 6 ? names[d] : "?";
}

/* M-products of the references: a[j + kc f] = phi_j' M ref_f, and
 * norms2[f] = ref_f' M ref_f. work: 2 n kr doubles. */
static void reference_products(const double *ref, int kr, const dm_modes *mo, int kc,
                               const dm_model *md, double *a, double *norms2, double *work)
{
    int n = md->n;
    double *R = work, *MR = work + (size_t)n * kr; /* interleaved */
    for (int i = 0; i < kr; i++)
        for (int r = 0; r < n; r++)
            R[(size_t)r * kr + i] = ref[(size_t)i * n + r];
    dm_model_mult_M(md, R, kr, MR);
    /* MR interleaved == column-major kr x n; a = phi' MR'. (The product
     * the other way round, MR phi, makes OpenBLAS's OpenMP build allocate
     * at every call inside a parallel region: the per-pose path does not
     * allocate.) */
    cblas_dgemm(CblasColMajor, CblasTrans, CblasTrans, kc, kr, n, 1.0, mo->phi, n, MR, kr, 0.0,
                a, kc);
    for (int i = 0; i < kr; i++)
        norms2[i] = cblas_ddot(n, R + i, kr, MR + i, kr);
}

void dm_modal_track(const double *ref, int kr, const dm_modes *mo, int kc, const dm_model *md,
                    int *assign, double *mac, double *shapes, double *work)
{
    int n = md->n;
    assert(kr <= DM_TRACK_MAX && kc <= DM_TRACK_MAX && kr <= kc);
    double *a = work + 2 * (size_t)n * kr, norms2[DM_TRACK_MAX];
    reference_products(ref, kr, mo, kc, md, a, norms2, work);
    dm_modal_track_products(a, norms2, kr, mo->freq_hz, kc, mo->phi, n, assign, mac, shapes);
}

void dm_modal_track_products(const double *a, const double *norms2, int kr, const double *freq_hz,
                             int kc, const double *vec, int n, int *assign, double *mac,
                             double *shapes)
{
    assert(kr <= DM_TRACK_MAX && kc <= DM_TRACK_MAX && kr <= kc);
    double cm[DM_TRACK_MAX][DM_TRACK_MAX];
    int first[DM_TRACK_MAX + 1], nclu = 0, room[DM_TRACK_MAX], of[DM_TRACK_MAX];
    /* clusters: runs of modes closer than DM_TRACK_GAP (relative) */
    for (int j = 0; j < kc; j++)
        if (j == 0 || freq_hz[j] > freq_hz[j - 1] * (1 + DM_TRACK_GAP))
            first[nclu++] = j;
    first[nclu] = kc;
    /* each family's MAC with each cluster's invariant subspace */
    for (int f = 0; f < kr; f++)
        for (int c = 0; c < nclu; c++) {
            double s = 0;
            for (int j = first[c]; j < first[c + 1]; j++)
                s += a[j + (size_t)kc * f] * a[j + (size_t)kc * f];
            cm[f][c] = s / norms2[f];
        }
    for (int c = 0; c < nclu; c++)
        room[c] = first[c + 1] - first[c];
    for (int f = 0; f < kr; f++)
        of[f] = -1;
    /* greedy by decreasing MAC; values within 1e-9 count as equal and go
     * in index order, so rounding cannot reorder them */
    for (int round = 0; round < kr; round++) {
        int bf = -1, bc = -1;
        for (int f = 0; f < kr; f++)
            for (int c = 0; c < nclu && of[f] < 0; c++)
                if (room[c] && (bf < 0 || cm[f][c] > cm[bf][bc] + 1e-9)) {
                    bf = f;
                    bc = c;
                }
        if (bf < 0)
            break;
        of[bf] = bc;
        room[bc]--;
        mac[bf] = cm[bf][bc];
    }
    /* inside a cluster its families, in index order, take its modes in
     * ascending frequency: the tracked order there is a function of the
     * frequencies, not of an arbitrary basis */
    int next[DM_TRACK_MAX];
    for (int c = 0; c < nclu; c++)
        next[c] = first[c];
    for (int f = 0; f < kr; f++) {
        assign[f] = of[f] < 0 ? -1 : next[of[f]]++;
        if (of[f] < 0 || !shapes)
            continue;
        /* the family's next reference: its shape projected on the cluster */
        double *dst = shapes + (size_t)f * n, s2 = 0;
        memset(dst, 0, sizeof(double) * n);
        for (int j = first[of[f]]; j < first[of[f] + 1]; j++) {
            double c = a[j + (size_t)kc * f];
            s2 += c * c;
            cblas_daxpy(n, c, vec + (size_t)j * n, 1, dst, 1);
        }
        if (s2 > 0)
            cblas_dscal(n, 1 / sqrt(s2), dst, 1);
    }
}
