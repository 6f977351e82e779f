/* Every mode of a pose, kept factored as Phi = L^-T Q Z (see dm_spectrum.h). */
#include "dm_spectrum.h"

#include <assert.h>
#include <cblas.h>
#include <lapacke.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "dm_modal.h"

struct dm_spectrum {
    int n;
    dm_arrow_chol L;   /* M = L L' */
    double *QR, *tau;  /* dsytrd's reflectors (below QR's subdiagonal) and factors */
    double *Z;         /* n x n: the tridiagonal's eigenvectors */
    double *omega;     /* n, ascending */
    double *S, *T;     /* n x DM_SPECTRUM_QMAX: an interleaved and a column-major block */
    double *mwork;     /* dormtr's */
    lapack_int lmwork;
};

/* dsytrd's panel width, set through its workspace (LAPACK's default is
 * 32): measured on the reduced C, one thread, 8 is 19 % faster at 210 DOF
 * and 12 % at 426 (4: 13 % slower than 8 at 210; 16: 5 %); at 48-102
 * DOF all are within 5 %. */
#define TRIDIAGONAL_PANEL 8

struct dm_spectrum_solver {
    int n;
    double *dense;     /* n x n: the reduction's scratch */
    double *d, *e;     /* the tridiagonal */
    double *work;
    lapack_int *iwork, lwork, liwork;
};

void dm_spectrum_free(dm_spectrum *sp)
{
    if (!sp)
        return;
    dm_arrow_chol_release(&sp->L);
    free(sp->QR), free(sp->tau), free(sp->Z), free(sp->omega), free(sp->S), free(sp->T);
    free(sp->mwork);
    free(sp);
}

dm_spectrum *dm_spectrum_alloc(const dm_model *model, dm_error *err)
{
    size_t n = (size_t)model->n;
    dm_spectrum *sp = calloc(1, sizeof *sp);
    if (!sp) {
        dm_fail(err, DM_ENOMEM, "out of memory for a spectrum");
        return NULL;
    }
    if (dm_arrow_chol_init(&sp->L, &model->layout, err)) {
        free(sp);
        return NULL;
    }
    sp->n = (int)n;
    /* dormtr's room for DM_SPECTRUM_QMAX columns (a query needs no matrix) */
    double wq = 0;
    LAPACKE_dormtr_work(LAPACK_COL_MAJOR, 'L', 'L', 'T', sp->n, DM_SPECTRUM_QMAX, NULL, sp->n,
                        NULL, NULL, sp->n, &wq, -1);
    sp->lmwork = (lapack_int)wq > DM_SPECTRUM_QMAX ? (lapack_int)wq : DM_SPECTRUM_QMAX;
    sp->QR = malloc(sizeof(double) * n * n);
    sp->Z = malloc(sizeof(double) * n * n);
    sp->tau = malloc(sizeof(double) * n);
    sp->omega = malloc(sizeof(double) * n);
    sp->S = malloc(sizeof(double) * n * DM_SPECTRUM_QMAX);
    sp->T = malloc(sizeof(double) * n * DM_SPECTRUM_QMAX);
    sp->mwork = malloc(sizeof(double) * (size_t)sp->lmwork);
    if (!sp->QR || !sp->Z || !sp->tau || !sp->omega || !sp->S || !sp->T || !sp->mwork) {
        dm_spectrum_free(sp);
        dm_fail(err, DM_ENOMEM, "out of memory for a %d-DOF spectrum", (int)n);
        return NULL;
    }
    return sp;
}

void dm_spectrum_solver_free(dm_spectrum_solver *sv)
{
    if (!sv)
        return;
    free(sv->dense), free(sv->d), free(sv->e), free(sv->work), free(sv->iwork);
    free(sv);
}

dm_spectrum_solver *dm_spectrum_solver_alloc(const dm_model *model, dm_error *err)
{
    int n = model->n;
    dm_spectrum_solver *sv = calloc(1, sizeof *sv);
    if (!sv) {
        dm_fail(err, DM_ENOMEM, "out of memory for a spectrum's solver");
        return NULL;
    }
    sv->n = n;
    /* room for dsytrd and for dstedc computing Z (queried; no matrix needed) */
    double wt = 0, wd = 0;
    lapack_int iw = 0;
    LAPACKE_dsytrd_work(LAPACK_COL_MAJOR, 'L', n, NULL, n, NULL, NULL, NULL, &wt, -1);
    LAPACKE_dstedc_work(LAPACK_COL_MAJOR, 'I', n, NULL, NULL, NULL, n, &wd, -1, &iw, -1);
    sv->lwork = (lapack_int)fmax(wt, wd);
    sv->liwork = iw;
    sv->dense = malloc(sizeof(double) * n * n);
    sv->d = malloc(sizeof(double) * n);
    sv->e = malloc(sizeof(double) * n);
    sv->work = malloc(sizeof(double) * (size_t)sv->lwork);
    sv->iwork = malloc(sizeof(lapack_int) * (size_t)sv->liwork);
    if (!sv->dense || !sv->d || !sv->e || !sv->work || !sv->iwork) {
        dm_spectrum_solver_free(sv);
        dm_fail(err, DM_ENOMEM, "out of memory for a %d-DOF spectrum's solver", n);
        return NULL;
    }
    return sv;
}

int dm_spectrum_solve(dm_spectrum *sp, const dm_model *model, dm_spectrum_solver *sv,
                      dm_error *err)
{
    int n = sp->n;
    assert(model->n == n && sv->n == n);
    if (dm_arrow_chol_factor(&sp->L, &model->M, NULL))
        return dm_fail(err, DM_ENUMERIC, "mass matrix not positive definite");
    dm_arrow_chol_reduce(&sp->L, &model->K, sp->QR, sv->dense);
    lapack_int panel = (lapack_int)TRIDIAGONAL_PANEL * n;
    lapack_int info = LAPACKE_dsytrd_work(LAPACK_COL_MAJOR, 'L', n, sp->QR, n, sv->d, sv->e,
                                          sp->tau, sv->work, panel < sv->lwork ? panel : sv->lwork);
    if (!info)
        info = LAPACKE_dstedc_work(LAPACK_COL_MAJOR, 'I', n, sv->d, sv->e, sp->Z, n, sv->work,
                                   sv->lwork, sv->iwork, sv->liwork);
    if (info)
        return dm_fail(err, DM_ENUMERIC, "tridiagonal eigen solve failed (info %d)", (int)info);
    return dm_modal_omega(sv->d, n, sp->omega, err);
}

int dm_spectrum_size(const dm_spectrum *sp)
{
    return sp->n;
}

const double *dm_spectrum_omega(const dm_spectrum *sp)
{
    return sp->omega;
}

/* dst (interleaved, n x q row-major) = src (column-major), and back. */
static void interleave(int n, int q, const double *src, double *dst)
{
    for (int i = 0; i < n; i++)
        for (int j = 0; j < q; j++)
            dst[(size_t)i * q + j] = src[i + (size_t)j * n];
}

static void deinterleave(int n, int q, const double *src, double *dst)
{
    for (int i = 0; i < n; i++)
        for (int j = 0; j < q; j++)
            dst[i + (size_t)j * n] = src[(size_t)i * q + j];
}

/* T = Q' T or Q T (dormtr on q columns). */
static void apply_Q(dm_spectrum *sp, char trans, int q)
{
    lapack_int info = LAPACKE_dormtr_work(LAPACK_COL_MAJOR, 'L', 'L', trans, sp->n, q, sp->QR,
                                          sp->n, sp->tau, sp->T, sp->n, sp->mwork, sp->lmwork);
    assert(info == 0); /* only argument errors, ruled out at allocation */
    (void)info;
}

void dm_spectrum_project(dm_spectrum *sp, const double *V, int q, double *Y)
{
    int n = sp->n;
    assert(q >= 1 && q <= DM_SPECTRUM_QMAX);
    interleave(n, q, V, sp->S);
    dm_arrow_chol_forward(&sp->L, sp->S, q);
    deinterleave(n, q, sp->S, sp->T);
    apply_Q(sp, 'T', q);
    cblas_dgemm(CblasColMajor, CblasTrans, CblasNoTrans, n, q, n, 1.0, sp->Z, n, sp->T, n, 0.0,
                Y, n);
}

void dm_spectrum_expand(dm_spectrum *sp, const double *Y, int q, double *X)
{
    int n = sp->n;
    assert(q >= 1 && q <= DM_SPECTRUM_QMAX);
    cblas_dgemm(CblasColMajor, CblasNoTrans, CblasNoTrans, n, q, n, 1.0, sp->Z, n, Y, n, 0.0,
                sp->T, n);
    apply_Q(sp, 'N', q);
    interleave(n, q, sp->T, sp->S);
    dm_arrow_chol_backward(&sp->L, sp->S, q);
    deinterleave(n, q, sp->S, X);
}
