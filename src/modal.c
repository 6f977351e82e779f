/* Generalized symmetric-definite eigenproblem with LAPACK (MODEL.md §4). */
#include "dm_modal.h"

#include <cblas.h>
#include <lapacke.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

struct dm_modal {
    int n, kmax;
    dm_eigen_method method;
    double *A, *B;           /* copies of K and M, overwritten by LAPACK */
    double *w, *Z;           /* eigenvalues (n), eigenvectors (n x n) */
    double *work;
    lapack_int *iwork, *isuppz;
    lapack_int lwork, liwork;
    double *d, *e, *tau, *dd, *ee; /* small models: tridiagonal T = Q' C Q and a copy */
    lapack_int *iblock, *isplit, *ifail;
    dm_modes modes;
};

/* Below this size LAPACK's tridiagonal stage for a few pairs (bisection
 * and inverse iteration inside dsyevr) costs more than the reduction; all
 * eigenvalues by the root-free QR (dsterf, O(n^2)) and inverse iteration
 * for the k wanted vectors (dstein) are measured 30 % faster at n = 48 and
 * slower beyond n ~ 100 (see make bench). */
#define DM_SMALL_MODEL 96

static int small_model(const dm_modal *ws)
{
    return ws->method == DM_EIGEN_PARTIAL && ws->n <= DM_SMALL_MODEL;
}

static int query_workspace(dm_modal *ws)
{
    double wq;
    lapack_int iq, n = ws->n, m;
    lapack_int info;
    if (ws->method == DM_EIGEN_ALL)
        info = LAPACKE_dsygvd_work(LAPACK_COL_MAJOR, 1, 'V', 'U', n, ws->A, n, ws->B, n,
                                   ws->w, &wq, -1, &iq, -1);
    else
        info = LAPACKE_dsyevr_work(LAPACK_COL_MAJOR, 'V', 'I', 'U', n, ws->A, n, 0, 0, 1,
                                   ws->kmax, 0.0, &m, ws->w, ws->Z, n, ws->isuppz, &wq, -1,
                                   &iq, -1);
    ws->lwork = (lapack_int)wq + 1;
    ws->liwork = iq;
    if (!info && small_model(ws)) { /* dsytrd, dormtr, dstein (5n, n) need room too */
        lapack_int k = ws->kmax;
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

dm_modal *dm_modal_alloc(int n, int kmax, dm_eigen_method method, dm_error *err)
{
    if (n < 1 || kmax < 1 || kmax > n) {
        dm_fail(err, DM_EINVAL, "modes: asked for %d modes of a %d-DOF model", kmax, n);
        return NULL;
    }
    dm_modal *ws = calloc(1, sizeof *ws);
    size_t nn = (size_t)n * n;
    if (ws) {
        ws->n = n;
        ws->kmax = kmax;
        ws->method = method;
        ws->A = malloc(nn * sizeof(double));
        ws->B = malloc(nn * sizeof(double));
        ws->Z = malloc(nn * sizeof(double));
        ws->w = malloc((size_t)n * sizeof(double));
        ws->isuppz = malloc(2 * (size_t)n * sizeof(lapack_int));
        ws->modes.freq_hz = malloc((size_t)kmax * sizeof(double));
        ws->modes.omega_rad_s = malloc((size_t)kmax * sizeof(double));
        ws->modes.platform_share = calloc((size_t)kmax, sizeof(double));
        ws->modes.direction = calloc((size_t)kmax, sizeof(int));
        ws->d = malloc(5 * (size_t)n * sizeof(double)); /* d, e, tau, dd, ee */
        ws->iblock = malloc(3 * (size_t)n * sizeof(lapack_int)); /* iblock, isplit, ifail */
        if (ws->d && ws->iblock) {
            ws->e = ws->d + n, ws->tau = ws->e + n, ws->dd = ws->tau + n, ws->ee = ws->dd + n;
            ws->isplit = ws->iblock + n, ws->ifail = ws->isplit + n;
        }
    }
    if (!ws || !ws->A || !ws->B || !ws->Z || !ws->w || !ws->isuppz || !ws->modes.freq_hz ||
        !ws->modes.omega_rad_s || !ws->modes.platform_share || !ws->modes.direction || !ws->d ||
        !ws->iblock || query_workspace(ws)) {
        dm_modal_free(ws);
        dm_fail(err, DM_ENOMEM, "out of memory for a %d-DOF eigen workspace", n);
        return NULL;
    }
    ws->work = malloc((size_t)ws->lwork * sizeof(double));
    ws->iwork = malloc((size_t)ws->liwork * sizeof(lapack_int));
    if (!ws->work || !ws->iwork) {
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
    free(ws->A);
    free(ws->B);
    free(ws->Z);
    free(ws->w);
    free(ws->work);
    free(ws->iwork);
    free(ws->isuppz);
    free(ws->d);
    free(ws->iblock);
    free(ws->modes.freq_hz);
    free(ws->modes.omega_rad_s);
    free(ws->modes.platform_share);
    free(ws->modes.direction);
    free(ws);
}

static int solve_all(dm_modal *ws, dm_error *err)
{
    lapack_int n = ws->n;
    lapack_int info = LAPACKE_dsygvd_work(LAPACK_COL_MAJOR, 1, 'V', 'U', n, ws->A, n, ws->B, n,
                                          ws->w, ws->work, ws->lwork, ws->iwork, ws->liwork);
    if (info)
        return dm_fail(err, DM_ENUMERIC, "dsygvd failed (info %d): %s", (int)info,
                       info > n ? "mass matrix not positive definite" : "no convergence");
    ws->modes.phi = ws->A; /* eigenvectors overwrite A, B-orthonormal */
    return DM_OK;
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
    info = LAPACKE_dpotrf_work(LAPACK_COL_MAJOR, 'U', n, ws->B, n);
    if (info)
        return dm_fail(err, DM_ENUMERIC, "mass matrix not positive definite (dpotrf info %d)",
                       (int)info);
    info = LAPACKE_dsygst_work(LAPACK_COL_MAJOR, 1, 'U', n, ws->A, n, ws->B, n);
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
    return DM_OK;
}

int dm_modal_solve(dm_modal *ws, const double *K, const double *M, int k,
                   const dm_modes **modes, dm_error *err)
{
    if (k < 1 || k > ws->kmax)
        return dm_fail(err, DM_EINVAL, "modes: %d requested, workspace holds 1..%d", k,
                       ws->kmax);
    size_t nn = (size_t)ws->n * ws->n;
    memcpy(ws->A, K, nn * sizeof *K);
    memcpy(ws->B, M, nn * sizeof *M);
    int rc = ws->method == DM_EIGEN_ALL ? solve_all(ws, err) : solve_partial(ws, k, err);
    if (rc)
        return rc;
    ws->modes.n = ws->n;
    ws->modes.k = k;
    for (int j = 0; j < k; j++) {
        double lam = ws->w[j];
        if (!(lam > 0))
            return dm_fail(err, DM_ENUMERIC,
                           "mode %d has eigenvalue %g <= 0: the structure is a mechanism", j + 1,
                           lam);
        ws->modes.omega_rad_s[j] = sqrt(lam);
        ws->modes.freq_hz[j] = sqrt(lam) / (2.0 * M_PI);
    }
    *modes = &ws->modes;
    return DM_OK;
}

void dm_modal_platform_share(dm_modal *ws, const dm_model *md)
{
    dm_modes *mo = &ws->modes;
    const double *MP = md->platform_mass;
    for (int j = 0; j < mo->k; j++) {
        const double *ph = mo->phi + (size_t)j * mo->n + md->platform_dof;
        double share = 0, best = -1;
        for (int r = 0; r < 6; r++) {
            double row = 0;
            for (int c = 0; c < 6; c++)
                row += MP[6 * c + r] * ph[c];
            double energy = ph[r] * row; /* diagonal contribution by direction */
            share += energy;
            if (energy > best) {
                best = energy;
                mo->direction[j] = r;
            }
        }
        mo->platform_share[j] = share;
    }
}

const char *dm_direction_name(int d)
{
    static const char *const names[] = {"x", "y", "z", "rx", "ry", "rz"};
    return d >= 0 && d < 6 ? names[d] : "?";
}

void dm_modal_mac_match(const double *ref, int kr, const dm_modes *mo, int kc, const double *M,
                        int n, int *assign, double *mac, double *work)
{
    double *MPhi = work, *W = work + (size_t)n * kc; /* W[i + kr j] = ref_i' M phi_j */
    cblas_dsymm(CblasColMajor, CblasLeft, CblasUpper, n, kc, 1.0, M, n, mo->phi, n, 0.0, MPhi, n);
    cblas_dgemm(CblasColMajor, CblasTrans, CblasNoTrans, kr, kc, n, 1.0, ref, n, MPhi, n, 0.0, W, kr);
    for (int i = 0; i < kr; i++) { /* normalise: phi' M phi = 1 already */
        const double *a = ref + (size_t)i * n;
        double aMa = 0;
        for (int r = 0; r < n; r++) {
            double s = 0;
            for (int c = 0; c < n; c++)
                s += M[(size_t)c * n + r] * a[c];
            aMa += a[r] * s;
        }
        for (int j = 0; j < kc; j++)
            W[i + (size_t)kr * j] = W[i + (size_t)kr * j] * W[i + (size_t)kr * j] / aMa;
        assign[i] = -1;
    }
    for (int round = 0; round < kr; round++) {
        int bi = -1, bj = -1;
        double best = -1;
        for (int i = 0; i < kr; i++)
            for (int j = 0; j < kc && assign[i] < 0; j++)
                if (W[i + (size_t)kr * j] > best) {
                    best = W[i + (size_t)kr * j];
                    bi = i;
                    bj = j;
                }
        if (bi < 0)
            break;
        assign[bi] = bj;
        mac[bi] = best;
        for (int i = 0; i < kr; i++) /* mode bj is taken */
            W[i + (size_t)kr * bj] = -2;
    }
}
