/* The reduced problem's lowest modes by warm-started, Chebyshev-filtered
 * subspace iteration (dm_boundary.h, dm_boundary_eig_solve: the method and
 * the bound). The block's products, the Cholesky factors and their
 * inverses and the projected eigenproblems' tridiagonal forms go through
 * the path's kernels (boundary_kernels.c), the tridiagonal eigenproblems
 * too (dsteqr's algorithm). */
#include <assert.h>
#include <cblas.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "boundary_impl.h"
#include "dm_rng.h"

/* GUARD: a cold block's guard vectors, and what a block grows by when a
 * wanted cluster reaches its top; each solve's spectrum may then keep a
 * cheaper block with at least GUARD_MIN (choose_block). */
enum { GUARD = 6, GUARD_MIN = 2, MAX_GROW = 4, MAX_ROUNDS = 20, MAX_DEGREE = 12, MAX_RESTARTS = 3 };
#define CLUSTER 1e-3 /* Ritz values within 0.1 % share one block bound */
#define COUNT_SHIFT 1e-9
/* How far apart the filter lets the block's columns drift before a
 * Cholesky QR (filter): Y'MY's condition stays below SKEW_MAX^2 = 1e14,
 * a factor 45 under 1 / eps where dpotrf may fail. (1e6 until 2026-12-07:
 * two rescales a solve in a chen2018 4,4 sweep, g1 ~ 240 an application;
 * 1e7 takes 1.52 with the same applications and bits of the figures of
 * test_boundary_eig; 1e8 would take 1.05 but lets the condition reach
 * 1 / eps.) */
#define SKEW_MAX 1e7
/* What a filter plans the first-order estimates down to: a hundredth of
 * the tolerance (degree_for, and plan_next's degrees to spare) */
#define FILTER_TARGET (1e-2 * DM_BOUNDARY_EIG_TOL)

struct dm_boundary_eig {
    const dm_members *ms;
    const dm_boundary_kernels *kr; /* the process's path (boundary_kernels), looked up once */
    int k, p, pmax, nr, nB, nv; /* p: the block's columns, growing to pmax */
    int q0[DM_MEMBERS_N];  /* each member's first interior coordinate */
    /* B's non-zero blocks: runs of boundary columns (the first c0, count
     * nc) whose rows are one range (the first r0, count nrow) */
    int nrun, *run;        /* 4 ints a run: c0, nc, r0, nrow */
    double *d;           /* nv: K's interior diagonal */
    double *B, *Mbb, *D; /* nv x nB: M_qB at the pose; nB x nB: M_BB; count scratch */
    double *Bt;          /* B' (nB x nv) */
    double *X, *W, *KW, *MW, *T; /* nr x 2p each (X and T trade buffers: rotate_block) */
    double *KX;          /* K and M times the block before its Ritz rotation, side by
                            side: nr x 2p (ritz_on_start, for residuals) */
    double *MQ;          /* M times the wanted clusters' Ritz vectors (residuals; nr x
                            their count, at least k): the moves' M Phi */
    double *H, *Z, *w, *s, *est, *work; /* projected problem (2p x 2p), residual norms;
                                           work: the tridiagonal form's subdiagonal */
    double ahead;        /* estimates(): the wanted clusters' worst first-order estimate */
    double *Sinv, *dinv; /* K^-1 explicitly for the filter: S^-1 (nB x nB), 1/d (nv) */
    int plan;            /* the next warm start's first degree (0: measure it) */
    double b;            /* the last solve's filter end, 1 / its block's top Ritz value */
    int nstart;
    dm_rng rng;
    /* along a path (dm_boundary_eig_follow_path): the wanted Ritz vectors
     * of the two solves before the last (hist[0] the later), their count */
    int path, nhist, hist_m[2], last_m;
    double *hist[2];
    double residual_target; /* 0: none (dm_boundary_eig_residual_target) */
    double sigma; /* the last solve's count: its shift and the modes below it */
    int count, whole; /* (whole: the whole model's there, -1 if singular; proven_by_whole_count) */
};

void dm_boundary_eig_free(dm_boundary_eig *e)
{
    if (!e)
        return;
    double *a[] = {e->d, e->B, e->Mbb, e->D,   e->X,    e->KX,   e->W,    e->KW, e->MW, e->T,
                   e->MQ, e->H, e->Z, e->w,   e->s,   e->est,  e->work, e->Sinv, e->dinv, e->Bt,
                   e->hist[0], e->hist[1]};
    for (size_t i = 0; i < sizeof a / sizeof *a; i++)
        free(a[i]);
    free(e->run);
    free(e);
}

/* d: the kept modes' eigenvalues and the residual vectors' stiffness (each
 * member's basis is K_ii-orthogonal: dm_member_basis.kres). */
static void interior_stiffness(dm_boundary_eig *e, const dm_members *ms)
{
    int q = 0;
    for (int m = 0; m < DM_MEMBERS_N; m++) {
        const dm_member_basis *mb = &ms->member[m];
        e->q0[m] = q;
        for (int j = 0; j < mb->nkeep; j++)
            e->d[q++] = mb->lambda[j];
        for (int j = 0; j < mb->nres; j++)
            e->d[q++] = mb->kres[j];
    }
    assert(q == e->nv);
}

/* The runs of B's columns (see the struct): a column's rows are the
 * interiors of the members that reach it (each member's are contiguous),
 * merged where they touch; neighbouring columns with the same rows share
 * a run. A chain's elbow is reached by its arm and rods alone (one range),
 * the platform by every rod (three ranges: the arms' interiors lie between
 * the chains' rods, and a single range over them, a fifth of its rows
 * zero, was 8 % of the products with M): six runs. */
static void column_runs(dm_boundary_eig *e, const dm_members *ms)
{
    e->nrun = 0;
    int prev0 = -1, prevn = 0; /* the first run of the previous column, and how many */
    for (int c = 0; c < e->nB; c++) {
        int lo[DM_MEMBERS_N], hi[DM_MEMBERS_N], nr = 0;
        for (int m = 0; m < DM_MEMBERS_N; m++) { /* members in row order */
            int cols[12], nc = dm_members_columns(ms, m, cols), reach = 0;
            for (int a = 0; a < nc; a++)
                reach |= cols[a] == c;
            if (!reach)
                continue;
            int r0 = e->q0[m], r1 = r0 + ms->member[m].nkeep + ms->member[m].nres;
            if (nr && hi[nr - 1] == r0)
                hi[nr - 1] = r1;
            else
                lo[nr] = r0, hi[nr] = r1, nr++;
        }
        int same = nr == prevn && nr > 0; /* the previous column's ranges again: widen its runs */
        for (int k = 0; same && k < nr; k++) {
            const int *r = e->run + 4 * (prev0 + k);
            same = r[0] + r[1] == c && r[2] == lo[k] && r[3] == hi[k] - lo[k];
        }
        if (same) {
            for (int k = 0; k < nr; k++)
                e->run[4 * (prev0 + k) + 1]++;
            continue;
        }
        prev0 = e->nrun, prevn = nr;
        for (int k = 0; k < nr; k++, e->nrun++) {
            int *r = e->run + 4 * e->nrun;
            r[0] = c, r[1] = 1, r[2] = lo[k], r[3] = hi[k] - lo[k];
        }
    }
}

dm_boundary_eig *dm_boundary_eig_alloc(dm_boundary *bw, int k, dm_error *err)
{
    dm_boundary_eig *e = calloc(1, sizeof *e);
    if (!e) {
        dm_fail(err, DM_ENOMEM, "out of memory for the reduced eigensolver");
        return NULL;
    }
    int nr = bw->nred, nB = bw->nB, p = k + MAX_GROW * GUARD < nr ? k + MAX_GROW * GUARD : nr;
    int q = 2 * p;
    assert(k >= 1 && k < nr);
    e->kr = boundary_kernels();
    e->ms = bw->ms, e->k = k, e->pmax = p, e->p = k + GUARD < p ? k + GUARD : p, e->nr = nr, e->nB = nB, e->nv = nr - nB;
    e->rng.state = 0x39e1;
    size_t n2 = (size_t)nr * q;
    double **a[] = {&e->d, &e->B, &e->Mbb, &e->D,   &e->X,    &e->KX,   &e->W,
                    &e->KW, &e->MW, &e->T, &e->MQ, &e->H,   &e->Z,    &e->w,    &e->s,
                    &e->est, &e->work, &e->Sinv, &e->dinv, &e->Bt, &e->hist[0], &e->hist[1]};
    size_t sz[] = {e->nv, (size_t)e->nv * nB, (size_t)nB * nB, (size_t)nB * nB,
                   n2, n2, n2, n2, n2, n2, n2,
                   (size_t)q * q, (size_t)q * q, q, q, q, q, (size_t)nB * nB, e->nv,
                   (size_t)nB * e->nv, (size_t)nr * p, (size_t)nr * p};
    int fail = 0;
    for (size_t i = 0; i < sizeof sz / sizeof *sz; i++)
        fail |= !(*a[i] = malloc(sizeof(double) * sz[i]));
    fail |= !(e->run = malloc(sizeof(int) * 4 * nB * DM_MEMBERS_N));
    if (fail) {
        dm_boundary_eig_free(e);
        dm_fail(err, DM_ENOMEM, "out of memory for the reduced eigensolver");
        return NULL;
    }
    interior_stiffness(e, bw->ms);
    column_runs(e, bw->ms);
    /* B's columns a member does not reach stay zero at every pose */
    memset(e->B, 0, sizeof(double) * e->nv * nB);
    memset(e->Bt, 0, sizeof(double) * e->nv * nB);
    return e;
}

const dm_boundary_kernels *dm_boundary_kernels_of(dm_isa isa)
{
    assert(dm_isa_available(isa));
    return DM_ISA_SELECT(dm_boundary_kernels_, isa);
}

/* B = M_qB at the pose: C' Gam' rows for the kept modes, C' GamR' for
 * the residual vectors, on the boundary columns each member reaches (the
 * others are zero, set at the allocation); and M_BB. */
static void pose_mass(dm_boundary_eig *e, dm_boundary *bw)
{
    const dm_members *ms = bw->ms;
    const dm_boundary_kernels *kr = e->kr;
    int nB = e->nB, nv = e->nv;
    double *P = e->T; /* a member's Gam' C (its columns: those it reaches) */
    dm_boundary_mass(bw, e->Mbb, nB);
    for (int m = 0; m < DM_MEMBERS_N; m++) {
        const dm_member_basis *mb = &ms->member[m];
        int nb = mb->nb, nk = mb->nkeep, nres = mb->nres, nq = nk + nres, nc = bw->nc[m];
        assert((size_t)nq * nc <= (size_t)e->nr * 2 * e->pmax);
        kr->mult(nk, nc, nb, mb->Gam, mb->ni, bw->Cc[m], nb, 0, P, nq);
        if (nres)
            kr->mult(nres, nc, nb, mb->GamR, nres, bw->Cc[m], nb, 0, P + nk, nq);
        for (int a = 0; a < nc; a++) {
            int c = bw->cols[m][a];
            const double *v = P + (size_t)a * nq;
            memcpy(e->B + (size_t)c * nv + e->q0[m], v, sizeof(double) * nq);
            for (int j = 0; j < nq; j++)
                e->Bt[(size_t)(e->q0[m] + j) * nB + c] = v[j];
        }
    }
}

/* Y = M X (ncol columns, leading dimension nr). Mbb is symmetric; B' is
 * kept beside B, so that both products read their matrix down its
 * columns. */
static void apply_M(const dm_boundary_eig *e, const double *X, int ncol, double *Y)
{
    const dm_boundary_kernels *kr = e->kr;
    int nr = e->nr, nB = e->nB, nv = e->nv;
    kr->mult(nB, ncol, nB, e->Mbb, nB, X, nr, 0, Y, nr);
    for (int a = 0; a < e->nrun; a++) { /* B's runs alone (column_runs) */
        const int *r = e->run + 4 * a;
        kr->mult(r[1], ncol, r[3], e->Bt + (size_t)r[2] * nB + r[0], nB, X + nB + r[2], nr, 1,
                 Y + r[0], nr);
    }
    for (int c = 0; c < ncol; c++)
        memcpy(Y + (size_t)c * nr + nB, X + (size_t)c * nr + nB, sizeof(double) * nv);
    for (int a = 0; a < e->nrun; a++) {
        const int *r = e->run + 4 * a;
        kr->mult(r[3], ncol, r[1], e->B + (size_t)r[0] * nv + r[2], nv, X + r[0], nr, 1,
                 Y + nB + r[2], nr);
    }
}

/* Y = diag(A, v) X: A (nB x nB, both triangles) on the boundary rows, v
 * (nv) on the interior ones; ncol columns, leading dimension nr. K is
 * diag(S, d), and the filter's K^-1 diag(S^-1, 1/d). */
static void block_diag_times(const dm_boundary_eig *e, const double *A, const double *v,
                             const double *X, int ncol, double *Y)
{
    int nr = e->nr, nB = e->nB;
    e->kr->mult(nB, ncol, nB, A, nB, X, nr, 0, Y, nr);
    e->kr->scale_rows(e->nv, ncol, v, X + nB, nr, Y + nB, nr);
}

/* Y = K X; and X = K^-1 X in place (S's Cholesky factor from the statics). */
static void apply_K(const dm_boundary_eig *e, const dm_boundary *bw, const double *X, int ncol,
                    double *Y)
{
    block_diag_times(e, bw->Sk, e->d, X, ncol, Y);
}

static void solve_K(const dm_boundary_eig *e, const dm_boundary *bw, double *X, int ncol)
{
    int nr = e->nr, nB = e->nB;
    e->kr->cholesky_solve(nB, bw->S, nB, X, nr, ncol);
    for (int c = 0; c < ncol; c++)
        for (int i = 0; i < e->nv; i++)
            X[(size_t)c * nr + nB + i] /= e->d[i];
}

/* At = A' for A k x p (leading dimension lda): four columns of A at a
 * time, so that At is written along its columns. The Gram products
 * A'B then go through the path's kernels in the order they read best
 * (a transposition and a product: 2.2 us where dgemm took 3.5 for
 * 20 x 20 from 123 rows, AVX2). */
static void transpose(const double *A, int k, int p, int lda, double *At)
{
    int c0 = 0;
    for (; c0 + 4 <= p; c0 += 4) {
        const double *a0 = A + (size_t)c0 * lda, *a1 = a0 + lda, *a2 = a1 + lda, *a3 = a2 + lda;
        double *t = At + c0;
        for (int r = 0; r < k; r++, t += p)
            t[0] = a0[r], t[1] = a1[r], t[2] = a2[r], t[3] = a3[r];
    }
    for (; c0 < p; c0++)
        for (int r = 0; r < k; r++)
            At[c0 + (size_t)r * p] = A[r + (size_t)c0 * lda];
}

/* Sinv = S^-1 and dinv = 1/d: the filter's K^-1 as two products, which
 * take a third of the time of the triangular solves at these sizes (0.5
 * against 4.9 us for 24 x 24 on 20 columns, measured). S^-1 = U^-1 U^-T
 * from the statics' factor S = U'U (the kernels' inverse and one
 * product: LAPACK's dpotri took 46 000 instructions a call at 24 x 24,
 * 1.5 % of a chen2018 sweep's). Only the filter and the residuals'
 * estimates use them: the filter's rounding is corrected by the
 * projection that follows. */
static void inverse_K(dm_boundary_eig *e, const dm_boundary *bw)
{
    int nB = e->nB;
    double *Ui = e->D, *UiT = e->T; /* scratch: the count's, the block's */
    memcpy(Ui, bw->S, sizeof(double) * nB * nB); /* the statics' factor */
    e->kr->inverse_upper(nB, Ui, nB);
    for (int c = 0; c < nB; c++)
        for (int r = c + 1; r < nB; r++)
            Ui[(size_t)c * nB + r] = 0;
    transpose(Ui, nB, nB, nB, UiT);
    e->kr->mult_upper(nB, nB, nB, Ui, nB, UiT, nB, e->Sinv, nB);
    for (int c = 0; c < nB; c++)
        for (int r = c + 1; r < nB; r++)
            e->Sinv[(size_t)c * nB + r] = e->Sinv[(size_t)r * nB + c];
    for (int i = 0; i < e->nv; i++)
        e->dinv[i] = 1 / e->d[i];
}

/* Y = K^-1 X through Sinv and dinv (ncol columns, leading dimension nr). */
static void inverse_K_times(const dm_boundary_eig *e, const double *X, int ncol, double *Y)
{
    block_diag_times(e, e->Sinv, e->dinv, X, ncol, Y);
}

/* X = X Q for Q p x p (ld q): made into T, whose buffer X then takes
 * (both hold nr x 2 pmax). */
static void rotate_block(dm_boundary_eig *e, const double *Q, int q)
{
    e->kr->mult(e->nr, e->p, e->p, e->X, e->nr, Q, q, 0, e->T, e->nr);
    double *old = e->X;
    e->X = e->T, e->T = old;
}

/* G (upper triangle, p x p) = U'U, U^-1 left in it; -1 when G is not
 * positive definite. */
static int factor_inverse(const dm_boundary_eig *e, int p, double *G)
{
    if (e->kr->cholesky_upper(p, G, p))
        return -1;
    e->kr->inverse_upper(p, G, p);
    return 0;
}

/* The pencil (H, G) (upper triangles) as the standard problem
 * U^-T H U^-1 (into T, p x p), G = U'U: G becomes U^-1 with zeros below
 * its diagonal, H is overwritten. What dsygv does, but with the
 * triangular products through the path's kernels instead of dsygst's
 * level-2 BLAS calls and dtrsm (a sixth of dsygv's time at 20 columns).
 * -1 when G is not positive definite. */
static int standard_form(dm_boundary_eig *e, double *G)
{
    int p = e->p;
    double *H = e->H;
    if (factor_inverse(e, p, G))
        return -1;
    for (int j = 0; j < p; j++)
        for (int i = j + 1; i < p; i++) {
            G[(size_t)j * p + i] = 0;
            H[(size_t)j * p + i] = H[(size_t)i * p + j]; /* H whole */
        }
    e->kr->mult_upper_in_place(p, p, H, p, G, p);     /* H U^-1 */
    transpose(H, p, p, p, e->T);                         /* U^-T H */
    e->kr->mult_upper_in_place(p, p, e->T, p, G, p); /* U^-T H U^-1 */
    return 0;
}

/* Rayleigh-Ritz on the block X alone (a start): X becomes M-orthonormal
 * Ritz vectors, w their values; [KX MX] (the products of the block
 * before) and the eigenvectors Q (in H) are kept for the residuals. -1 if
 * X'MX is singular. */
static int ritz_on_start(dm_boundary_eig *e, const dm_boundary *bw)
{
    int nr = e->nr, p = e->p;
    double *G = e->Z, *MX = e->KX + (size_t)nr * p;
    apply_K(e, bw, e->X, p, e->KX);
    apply_M(e, e->X, p, MX);
    transpose(e->X, nr, p, nr, e->T); /* X'KX and X'MX, their upper triangles */
    e->kr->mult_upper(p, p, nr, e->T, p, e->KX, nr, e->H, p);
    e->kr->mult_upper(p, p, nr, e->T, p, MX, nr, G, p);
    if (standard_form(e, G))
        return -1;
    /* its eigenpairs as dsyev makes them: the tridiagonal form and its
     * QL iteration (the kernels), the eigenvectors Q~ into KW (free
     * between filters) */
    double *Qt = e->KW, *sub = e->work;
    e->kr->tridiagonalise(p, e->T, p, e->w, sub, Qt, p);
    if (e->kr->tridiagonal_eigen(p, e->w, sub, Qt, p, p))
        return -1;
    e->kr->mult(p, p, p, G, p, Qt, p, 0, e->H, p); /* Q = U^-1 Q~ */
    rotate_block(e, e->H, p);
    return 0;
}

/* The end of the cluster that holds Ritz value a: the values within
 * CLUSTER of their neighbour share one bound (estimates). */
static int cluster_end(const dm_boundary_eig *e, int a)
{
    int b = a;
    while (b + 1 < e->p && e->w[b + 1] <= e->w[b] * (1 + CLUSTER))
        b++;
    return b;
}

/* The last wanted cluster's end: the k-th value's cluster is wanted
 * whole. */
static int wanted_end(const dm_boundary_eig *e)
{
    return cluster_end(e, e->k - 1);
}

/* Residuals R = K X - M X Theta of the first ncol Ritz vectors (the
 * wanted clusters': the only ones a bound is asked of) into T, as
 * K (X Q) - (M X Q) Theta: K X Q made afresh on the rotated block (K is
 * block-diagonal: nB^2 + nv products a column, where rotating K X took
 * nr p), M X Q from the product ritz_on_start kept (M's product costs
 * more than the rotation; M X Q is kept: the moves' M Phi, a product by M
 * fewer a pose); preconditioned W = K^-1 R, and s_j = r_j' K^-1 r_j.
 * K^-1 is the filter's explicit one (inverse_K): s only steers the
 * iteration (estimates; the certified bounds come from counts,
 * dm_boundary_bounds), and the inverse's relative error, some
 * kappa(S) eps, is far below the estimates' own first-order slack. Its
 * product takes a tenth of the triangular solves' time (dpotrs was 3 %
 * of a chen2018 sweep's instructions). */
static void residuals(dm_boundary_eig *e, const dm_boundary *bw, int ncol)
{
    int nr = e->nr, p = e->p;
    apply_K(e, bw, e->X, ncol, e->T);
    e->kr->mult(nr, ncol, p, e->KX + (size_t)nr * p, nr, e->H, p, 0, e->MQ, nr);
    for (int j = 0; j < ncol; j++) {
        double *r = e->T + (size_t)j * nr, th = e->w[j];
        const double *mq = e->MQ + (size_t)j * nr;
        for (int i = 0; i < nr; i++)
            r[i] -= th * mq[i];
    }
    inverse_K_times(e, e->T, ncol, e->W);
    for (int j = 0; j < ncol; j++)
        e->s[j] = fabs(cblas_ddot(nr, e->T + (size_t)j * nr, 1, e->W + (size_t)j * nr, 1));
}

/* est_j: the relative bound of dm_boundary.h from the residuals s and the
 * Ritz values' clusters, for the wanted clusters (columns 0..top,
 * wanted_end); INFINITY for a cluster that reaches the block's top (no
 * gap known above it); ahead: their largest x / rho, the estimate's
 * first-order part, finite below the top even where the bound is not
 * (what the filter must remove). */
static void estimates(dm_boundary_eig *e, int top)
{
    int p = e->p;
    e->ahead = 0;
    for (int a = 0; a <= top;) {
        int b = cluster_end(e, a);
        assert(b <= top); /* a cluster ends at top (wanted_end) */
        double sum = 0, delta = INFINITY;
        for (int i = a; i <= b; i++)
            sum += e->s[i] / (e->w[i] * e->w[i] * e->w[i]);
        if (a > 0)
            delta = 1 / e->w[a - 1] - 1 / e->w[a];
        delta = b + 1 < p ? fmin(delta, 1 / e->w[b] - 1 / e->w[b + 1]) : 0;
        for (int i = a; i <= b; i++) {
            double rho = 1 / e->w[i], x = delta > 0 ? sum / delta : INFINITY;
            e->est[i] = x < rho ? x / (rho - x) : INFINITY;
            e->ahead = fmax(e->ahead, x / rho);
        }
        a = b + 1;
    }
}

/* Cholesky QR of the block Y (M-orthonormal again, the same span): R'R =
 * Y'MY, R^-1 into H (rescale_factor); the filter's step then goes on
 * from Y, MY and the recurrence's previous term, and its result and Y
 * (the next step's previous term) are right-multiplied by R^-1
 * (rescale_block): the recurrence is linear in its terms, so the step
 * commutes with the transform (p(A) Y R^-1 = (p(A) Y) R^-1), and two
 * blocks are transformed instead of Y, MY and the previous term. After
 * it the block's columns are far from parallel again however much the
 * filter amplified the lowest modes. -1 when Y'MY is not positive
 * definite. */
static int rescale_factor(dm_boundary_eig *e, const double *Y, const double *MY)
{
    int nr = e->nr, p = e->p;
    double *G = e->H;
    transpose(Y, nr, p, nr, e->T); /* T is free while the filter runs */
    e->kr->mult_upper(p, p, nr, e->T, p, MY, nr, G, p);
    return factor_inverse(e, p, G);
}

/* Y = Y R^-1 by rescale_factor's R^-1 (a product: dtrsm took 2.5 times as
 * long) */
static void rescale_block(dm_boundary_eig *e, double *Y)
{
    e->kr->mult_upper_in_place(e->nr, e->p, Y, e->nr, e->H, e->p);
}

/* X = T_d((A - c) / c) X, A = K^-1 M (eigenvalues mu = 1/lambda), c = b/2:
 * the Chebyshev polynomial of degree d on [0, b] mapped to [-1, 1]. Every
 * component with mu <= b stays within 1 while one with mu > b grows as
 * T_d(2 mu / b - 1): d applications of A do what many more of plain
 * subspace iteration would, with no projection between them. The lowest
 * mode (mu_1 = 1 / theta_1) grows fastest, by up to g1 = t + sqrt(t^2 - 1)
 * an application, t = 2 mu_1 / b - 1, over the damped columns; a Cholesky
 * QR (rescale) before the block's columns drift further apart than
 * SKEW_MAX keeps them apart (Y'MY's condition below SKEW_MAX^2: Cholesky
 * QR is safe; every rescale costs more than an application). -1 when the
 * block collapses all the same. */
static int filter(dm_boundary_eig *e, int degree, double b, double theta1)
{
    size_t np = (size_t)e->nr * e->p;
    double c = b / 2, t = 2 / (theta1 * b) - 1, g1 = t + sqrt(fmax(t * t - 1, 0)), skew = 1;
    double *Y = e->X, *Yp = e->W, *Yn = e->KW, *MY = e->MW;
    for (int j = 0; j < degree; j++, skew *= g1) {
        apply_M(e, Y, e->p, MY);
        int rescaled = skew * g1 > SKEW_MAX;
        if (rescaled) {
            if (rescale_factor(e, Y, MY))
                return -1;
            skew = 1;
        }
        inverse_K_times(e, MY, e->p, Yn);
        /* T_1 = t, T_j+1 = 2 t T_j - T_j-1 */
        e->kr->chebyshev_step(np, c, Y, j ? Yp : NULL, Yn);
        if (rescaled) {
            rescale_block(e, Yn);
            rescale_block(e, Y);
        }
        double *old = Yp;
        Yp = Y, Y = Yn, Yn = old;
    }
    if (Y != e->X) { /* the block's buffer is Y's now (all hold nr x 2 pmax) */
        double **slot = Y == e->W ? &e->W : &e->KW;
        assert(*slot == Y);
        *slot = e->X, e->X = Y;
    }
    return 0;
}

/* The filter's degree for the estimates to fall below a hundredth of the
 * tolerance: the slowest wanted Ritz value theta_top grows by T_d(t),
 * t = 2 theta_p / theta_top - 1 (theta_p the block's top, the damped
 * interval's end), against everything outside the block, and the
 * estimates are quadratic in the residuals. At least 1, at most
 * MAX_DEGREE. */
static int degree_for(const dm_boundary_eig *e, int top)
{
    double t = 2 * e->w[e->p - 1] / e->w[top] - 1;
    double need = sqrt(fmax(e->ahead / FILTER_TARGET, 1.0));
    if (!(t > 1 + 1e-6) || !isfinite(need))
        return MAX_DEGREE;
    int d = (int)ceil(acosh(need) / acosh(t));
    return d < 1 ? 1 : d > MAX_DEGREE ? MAX_DEGREE : d;
}

/* Wittrick-Williams for the reduced pair: interior coordinates below
 * sigma plus the negative eigenvalues of
 *   S - sigma M_BB - sigma^2 B' (d - sigma)^-1 B.  -1 when singular.
 * The product runs over B's runs (column_runs): the block of columns of
 * run a and b gets the rows both reach; only its lower triangle is made,
 * all that dm_boundary_negatives reads (the runs ascend by column). */
static int count_reduced(dm_boundary_eig *e, dm_boundary *bw, double sigma, int *count)
{
    int nB = e->nB, nv = e->nv, below = 0;
    assert((size_t)nv * nB <= (size_t)e->nr * 2 * e->pmax);
    for (int i = 0; i < nv; i++) {
        double f = e->d[i] - sigma;
        if (f == 0)
            return -1;
        below += f < 0;
    }
    /* T = -sigma^2 B' (d - sigma)^-1 on the runs (B' down its columns, as
     * the products read it) */
    for (int a = 0; a < e->nrun; a++) {
        const int *r = e->run + 4 * a;
        for (int i = r[2]; i < r[2] + r[3]; i++) {
            double f = -sigma * sigma / (e->d[i] - sigma);
            for (int c = r[0]; c < r[0] + r[1]; c++)
                e->T[(size_t)i * nB + c] = f * e->Bt[(size_t)i * nB + c];
        }
    }
    for (size_t a = 0; a < (size_t)nB * nB; a++)
        e->D[a] = bw->Sk[a] - sigma * e->Mbb[a];
    for (int a = 0; a < e->nrun; a++)
        for (int b = a; b < e->nrun; b++) {
            const int *ra = e->run + 4 * a, *rb = e->run + 4 * b;
            int i0 = ra[2] > rb[2] ? ra[2] : rb[2];
            int i1 = ra[2] + ra[3] < rb[2] + rb[3] ? ra[2] + ra[3] : rb[2] + rb[3];
            if (i1 <= i0)
                continue; /* no member reaches both */
            e->kr->mult(rb[1], ra[1], i1 - i0, e->T + (size_t)i0 * nB + rb[0], nB,
                        e->B + (size_t)ra[0] * nv + i0, nv, 1, e->D + (size_t)ra[0] * nB + rb[0],
                        nB);
        }
    int neg = dm_boundary_negatives(e->D, nB);
    *count = below + neg;
    return neg < 0 ? -1 : 0;
}

/* Columns from..p-1 of X: random, then one step of K^-1 M (away from the
 * stiff end of the spectrum). */
static void random_columns(dm_boundary_eig *e, const dm_boundary *bw, int from)
{
    int nr = e->nr, nc = e->p - from;
    double *X = e->X + (size_t)from * nr;
    for (size_t a = 0; a < (size_t)nr * nc; a++)
        e->W[a] = dm_rng_normal(&e->rng);
    apply_M(e, e->W, nc, X);
    solve_K(e, bw, X, nc);
}

void dm_boundary_eig_start(dm_boundary_eig *e, const double *Y, int ncol)
{
    assert(ncol >= 0 && ncol <= e->pmax);
    if (ncol > e->k) /* the block is these columns */
        e->p = ncol;
    memcpy(e->X, Y, sizeof(double) * e->nr * ncol);
    e->nstart = ncol;
    e->nhist = 0; /* a start of the caller's: a new path */
}

/* A seed: everything a warm solve reads of the solves before it — the
 * block and its size, the planned filter (degree, interval, the lowest
 * Ritz value it is scaled by) and the generator of guard vectors — so a
 * solve from a seed does not depend on what the solver did before. */
typedef struct eig_seed {
    int p, nstart, plan;
    double b, w0;
    dm_rng rng;
} eig_seed;

size_t dm_boundary_eig_seed_size(const dm_boundary_eig *e)
{
    return sizeof(eig_seed) + sizeof(double) * (size_t)e->nr * e->pmax;
}

int dm_boundary_eig_seed_save(const dm_boundary_eig *e, void *seed)
{
    if (!e->nstart)
        return 0;
    eig_seed h = {e->p, e->nstart, e->plan, e->b, e->w[0], e->rng};
    memcpy(seed, &h, sizeof h);
    memcpy((char *)seed + sizeof h, e->X, sizeof(double) * (size_t)e->nr * e->nstart);
    return 1;
}

void dm_boundary_eig_seed_load(dm_boundary_eig *e, const void *seed)
{
    eig_seed h;
    memcpy(&h, seed, sizeof h);
    assert(h.p >= 1 && h.p <= e->pmax && h.nstart >= 1 && h.nstart <= h.p);
    e->p = h.p, e->nstart = h.nstart, e->plan = h.plan;
    e->b = h.b, e->w[0] = h.w0, e->rng = h.rng;
    e->nhist = 0; /* a seed's start: a new path */
    memcpy(e->X, (const char *)seed + sizeof h, sizeof(double) * (size_t)e->nr * h.nstart);
}

void dm_boundary_reduced_vectors(const dm_boundary *bw, int k, double *Y)
{
    memcpy(Y, bw->Kr, sizeof(double) * bw->nred * k);
}

/* The wanted pairs' largest relative residual, sqrt(r' K^-1 r / theta)
 * = ||x - theta K^-1 M x||_K / sqrt(theta) (x M-normalised): at least
 * the M-norm that dm_modal's CONVERGED bounds, for every component of
 * the error above theta. */
static double largest_residual(const dm_boundary_eig *e, int top)
{
    double worst = 0;
    for (int j = 0; j <= top; j++)
        worst = fmax(worst, sqrt(e->s[j] / e->w[j]));
    return worst;
}

/* Filter and project the block X until every wanted cluster meets the
 * tolerance, each projection from products made afresh (so the bound is
 * judged on them); *top: the last wanted cluster's end. A warm start
 * with a planned degree is filtered at once, on the last solve's interval
 * (the spectrum moves little between neighbours), which saves the start's
 * projection; any other start is projected first and the degree chosen
 * from its estimates. -1 when it does not converge, 1 when the block
 * must grow. */
static int converge(dm_boundary_eig *e, const dm_boundary *bw, int planned, int *top,
                    dm_boundary_eig_info *info)
{
    if (planned && filter(e, planned, e->b, e->w[0]))
        return -1;
    info->applications += planned;
    if (ritz_on_start(e, bw))
        return -1;
    double last = INFINITY; /* the last round's largest residual */
    for (int round = 0;; round++) {
        *top = wanted_end(e);
        residuals(e, bw, *top + 1);
        estimates(e, *top);
        double worst = largest_residual(e, *top);
        int done = 1;
        for (int j = 0; j <= *top; j++)
            done &= e->est[j] <= DM_BOUNDARY_EIG_TOL;
        /* the residual target too, unless round-off has stalled it (the
         * residual no longer halves a round: accepted on the bound); the
         * filter's degree is still the bound's plan (planned for the
         * residual as well, han2011's trajectories took 13 % more
         * instructions, against 0-0.3 % so) */
        if (done && e->residual_target > 0 && worst > e->residual_target && worst < 0.5 * last &&
            round < MAX_ROUNDS)
            done = 0;
        last = worst;
        if (done)
            return 0;
        /* a wanted cluster at the block's top has no gap above it, and
         * one near the top converges slowly: more guard vectors */
        if (e->p < e->pmax && (*top == e->p - 1 || round == 4))
            return 1;
        int d = degree_for(e, *top);
        if (round == MAX_ROUNDS || filter(e, d, 1 / e->w[e->p - 1], e->w[0]) ||
            ritz_on_start(e, bw))
            return -1;
        info->iterations++, info->applications += d;
    }
}

/* Growth per application of the filter whose interval ends at the
 * block's top Ritz value wtop, at Ritz value w (at most 1 unless w lies
 * below wtop: plan_next's, choose_block's). */
static double growth(double wtop, double w)
{
    double t = 2 * wtop / w - 1;
    return t + sqrt(fmax(t * t - 1, 0));
}

/* What a warm solve with a block of pc columns is predicted to cost, in
 * microseconds of the AVX-512 path at chen2018 4,4 (the constants are
 * measured there at pc = 20: an application of K^-1 M with its product
 * by M 7.5, a Cholesky QR 9.5, the Rayleigh-Ritz 39 and the residuals 13,
 * scaled by the block's columns as their operations are). A warm start
 * takes about APPLY_LOG / ln g applications, g the growth at the last
 * wanted Ritz value (16.3-18.8 measured on the bench's maps of the three
 * presets with blocks of 16 to 20), and one Cholesky QR each time the
 * lowest mode's growth reaches SKEW_MAX. */
#define APPLY_LOG 16.7
/* A block's top Ritz value must lie this far below the next (relative):
 * a top within a cluster mixes its columns and moves the filter's end
 * (with 5 %, chen2018's blocks of 19, splitting its pair near 188 Hz, took
 * 14 % longer than the block of 20 the cost alone ranked below them). */
#define TOP_GAP 0.1
/* A smaller block is taken only when predicted this much cheaper: the
 * model ranks blocks, it does not time them. */
#define MARGIN 0.1
static double block_cost(const dm_boundary_eig *e, int top, int pc)
{
    double g = growth(e->w[pc - 1], e->w[top]), g1 = growth(e->w[pc - 1], e->w[0]);
    if (!(g > 1 + 1e-3))
        return INFINITY; /* the block's top within the wanted cluster: no growth */
    double apps = APPLY_LOG / log(g), x = pc / 20.0;
    double per_qr = g1 > 1 ? fmax(1, floor(log(SKEW_MAX) / log(g1))) : apps;
    return apps * 7.5 * x + apps / per_qr * 9.5 * x * x + 39 * x * x * x + 13 * x * x;
}

/* The next warm solve's block: of this one's lowest pc >= top + 1 +
 * GUARD_MIN columns (the wanted clusters and a guard), the number whose
 * predicted cost is least (block_cost, from this solve's Ritz values);
 * a planned degree grows as the smaller block's growth falls. A block
 * never grows here: only when a wanted cluster reaches its top (converge).
 * Measured on the bench's 64 x 64 maps (one thread, --no-dynamic): the
 * best fixed guard was 6 for chen2018 (its gap above mode 20), which it
 * keeps, 2-5 for zheng2017, which now keeps 2, and 2 for han2011, which
 * now keeps 3 (docs/model-choices.md, "The block's size from the
 * spectrum"). */
static void choose_block(dm_boundary_eig *e, int top)
{
    int best = e->p;
    double cost = block_cost(e, top, best);
    for (int pc = top + 1 + GUARD_MIN; pc < e->p; pc++) {
        if (!(e->w[pc] > e->w[pc - 1] * (1 + TOP_GAP)))
            continue; /* a top within a cluster */
        double c = block_cost(e, top, pc);
        if (c < cost * (1 - MARGIN))
            best = pc, cost = c;
    }
    if (best == e->p)
        return;
    if (e->plan) {
        double more = log(growth(e->w[e->p - 1], e->w[top])) /
                      log(growth(e->w[best - 1], e->w[top]));
        int d = (int)ceil(e->plan * more - 1e-9);
        e->plan = d < 1 || d > MAX_DEGREE ? 0 : d; /* (< 1: no growth at the old top) */
    }
    e->p = best;
    e->b = 1 / e->w[best - 1];
}

/* The next warm start's degree: this solve's applications when it took
 * more than one round or none was planned; else its planned degree less
 * the degrees its estimates show to spare: the first-order estimate grows
 * by about g^2 = (t + sqrt(t^2 - 1))^2 per degree removed, and may reach
 * a hundredth of the tolerance, as degree_for plans. A restart measures
 * again. (Until 2026-12-06 one degree fewer after four such solves in a
 * row: a sweep's anchors then handed their points the degree of a start a
 * lattice step away, chen2018 5.18 applications a point against 4.28,
 * han2011 7.79 against 7.06, zheng2017 4.20 against 4.03, with as few
 * second rounds, 0.5 %; along paths of 0.3-20 mm steps as many or fewer,
 * and second rounds at most 0.05 a solve.) */
static void plan_next(dm_boundary_eig *e, int top, const dm_boundary_eig_info *info)
{
    double g = growth(e->w[e->p - 1], e->w[top]);
    e->b = 1 / e->w[e->p - 1];
    if (info->restarts || info->cold || info->applications > MAX_DEGREE) {
        e->plan = 0;
        return;
    }
    if (info->iterations || !e->plan) {
        e->plan = info->applications;
        return;
    }
    int spare = 0; /* each degree fewer: the first-order estimate x g^2 */
    for (double a = e->ahead * g * g; spare < e->plan - 1 && a <= FILTER_TARGET;
         a *= g * g)
        spare++;
    e->plan -= spare;
}

/* The whole model's Wittrick-Williams count at sigma (dm_boundary_count,
 * kept in e->whole; -1 when sigma is singular for it) proves the solve
 * complete when it is top + 1: the Ritz values are upper bounds of the
 * reduced problem's eigenvalues (a subspace of it), which are upper
 * bounds of the model's (the reduction is a projection), so the reduced
 * count lies between the top + 1 Ritz values below sigma and the whole
 * count: it is top + 1 too, and its own count is not made (4 % of a
 * chen2018 solve's instructions). Any other whole count leaves the question to
 * the reduced count: a mode the iteration missed (restart), or one the
 * bases miss (the caller compares the counts). */
static int proven_by_whole_count(dm_boundary_eig *e, dm_boundary *bw, double sigma, int top)
{
    if (dm_boundary_count(bw, sigma, &e->whole, NULL))
        e->whole = -1;
    if (e->whole != top + 1)
        return 0;
    e->sigma = sigma, e->count = top + 1;
    return 1;
}

/* Along a path, the start of the next solve as dm_modal's (src/solve/
 * modal.c, extrapolate): the wanted subspaces of the last three solves
 * (X_t, X_t-1, X_t-2, equally spaced) extrapolated, X_t + (X_t - P_t-1
 * X_t) or 3 X_t - 3 P_t-1 X_t + P_t-2 X_t, with P_s X_t = X_s X_s' M X_t
 * the part of X_t in span(X_s) (which aligns the bases: Ritz vectors come
 * with any sign, pairs in any rotation; M X_t the last solve's own, made
 * with its residuals: accurate to first order in the step, enough for a
 * start, and a product by M fewer, which took as long as the
 * applications it saved). The reduced coordinates
 * are the members' own and the boundary's global ones, continuous along
 * the path. Only the columns of the wanted clusters at every solve take
 * part (the guard columns carry unconverged parts of the modes above);
 * the guards start where they were. The start's error drops from O(h) to
 * O(h^3), and plan_next lowers the filter's degree as the estimates
 * allow. Called after inverse_K (T is free). */
static void extrapolate(dm_boundary_eig *e)
{
    int nr = e->nr, m = e->last_m;
    for (int h = 0; h < e->nhist; h++)
        m = m < e->hist_m[h] ? m : e->hist_m[h];
    /* M X_t: the last solve's, made with its residuals (the pose before's
     * M, as good as the new one's to first order) */
    const double *MX = e->MQ;
    double *C = e->H, *Ht = e->KW, *P[2] = {e->MW, e->T};
    for (int h = 0; h < e->nhist; h++) {
        transpose(e->hist[h], nr, m, nr, Ht);
        e->kr->mult(m, m, nr, Ht, m, MX, nr, 0, C, m);
        e->kr->mult(nr, m, m, e->hist[h], nr, C, m, 0, P[h], nr);
    }
    double *oldest = e->hist[1]; /* X_t joins the history, X_t-2 leaves */
    e->hist[1] = e->hist[0], e->hist_m[1] = e->hist_m[0];
    e->hist[0] = oldest, e->hist_m[0] = e->last_m;
    memcpy(e->hist[0], e->X, sizeof(double) * nr * e->last_m);
    for (size_t l = 0; e->nhist > 0 && l < (size_t)nr * m; l++)
        e->X[l] = e->nhist == 1 ? 2 * e->X[l] - P[0][l]
                                : 3 * (e->X[l] - P[0][l]) + P[1][l];
    e->nhist += e->nhist < 2;
}

void dm_boundary_eig_residual_target(dm_boundary_eig *e, double residual)
{
    assert(residual >= 0);
    e->residual_target = residual;
}

void dm_boundary_eig_follow_path(dm_boundary_eig *e, int on)
{
    e->path = on;
    e->nhist = 0;
}

int dm_boundary_eig_solve(dm_boundary_eig *e, dm_boundary *bw, double *lambda, double *estimate,
                          dm_boundary_eig_info *info, dm_error *err)
{
    dm_boundary_eig_info dummy;
    info = info ? info : &dummy;
    memset(info, 0, sizeof *info);
    pose_mass(e, bw);
    inverse_K(e, bw);
    info->cold = e->nstart == 0;
    if (e->path && e->nstart)
        extrapolate(e);
    else
        e->nhist = 0;
    random_columns(e, bw, e->nstart);
    int planned = e->nstart == e->p ? e->plan : 0, top = 0;
    for (int attempt = 0;; attempt++, planned = 0) {
        int count, rc = converge(e, bw, planned, &top, info);
        if (rc == 1) { /* a cluster wider than the guard: grow the block */
            int from = e->p;
            e->p = e->p + GUARD < e->pmax ? e->p + GUARD : e->pmax;
            random_columns(e, bw, from);
            attempt--;
            continue;
        }
        if (rc) {
            e->nstart = 0, e->plan = 0, e->nhist = 0;
            return dm_fail(err, DM_ENUMERIC, "reduced eigensolver: no convergence");
        }
        /* just above the wanted clusters (their values are within the
         * tolerance, far below the shift's 1e-9; the counts resolve ~1e-11) */
        double sigma = e->w[top] * (1 + COUNT_SHIFT);
        if (proven_by_whole_count(e, bw, sigma, top))
            break;
        if (count_reduced(e, bw, sigma, &count)) {
            e->nstart = 0, e->plan = 0, e->nhist = 0;
            return dm_fail(err, DM_ENUMERIC, "reduced eigensolver: the count's shift is singular");
        }
        if (count == top + 1) {
            e->sigma = sigma, e->count = count;
            break;
        }
        if (count < top + 1 || attempt == MAX_RESTARTS) { /* Ritz values are upper bounds */
            e->nstart = 0, e->plan = 0, e->nhist = 0;
            return dm_fail(err, DM_ENUMERIC, "reduced eigensolver: %d modes below %d Ritz values",
                           count, top + 1);
        }
        info->restarts++; /* a mode missed below: fresh guard vectors find it */
        random_columns(e, bw, top + 1);
    }
    info->block = e->p;
    /* the whole block, before the next start keeps fewer of its columns:
     * dm_boundary_mode_shapes and dm_boundary_reduced_vectors read them */
    memcpy(bw->Kr, e->X, sizeof(double) * e->nr * e->p);
    plan_next(e, top, info);
    choose_block(e, top);
    e->last_m = top + 1 < e->p ? top + 1 : e->p;
    for (int j = 0; j < e->k; j++) {
        lambda[j] = e->w[j];
        if (estimate)
            estimate[j] = e->est[j];
    }
    e->nstart = e->p;
    return DM_OK;
}

void dm_boundary_eig_forget(dm_boundary_eig *e)
{
    e->nstart = 0, e->plan = 0, e->b = 0, e->nhist = 0;
    e->p = e->k + GUARD < e->pmax ? e->k + GUARD : e->pmax;
    e->rng.state = 0x39e1; /* as allocated: a cold solve's bits depend on its pose alone */
}

void dm_boundary_eig_count_point(const dm_boundary_eig *e, double *sigma, int *count, int *whole)
{
    *sigma = e->sigma, *count = e->count, *whole = e->whole;
}

int dm_boundary_eig_count(dm_boundary_eig *e, dm_boundary *bw, double sigma, int *count,
                          dm_error *err)
{
    if (count_reduced(e, bw, sigma, count))
        return dm_fail(err, DM_ENUMERIC, "reduced count: the shift %.17g is singular", sigma);
    return DM_OK;
}

void dm_boundary_eig_mult_M(const dm_boundary_eig *e, const double *Y, int ncol, double *MY)
{
    apply_M(e, Y, ncol, MY);
}

void dm_boundary_eig_products(const dm_boundary_eig *e, const double *A, int na, const double *B,
                              int nb, double *C, double *work)
{
    transpose(A, e->nr, na, e->nr, work); /* A' (na x nr) */
    e->kr->mult(na, nb, e->nr, work, na, B, e->nr, 0, C, na);
}

const double *dm_boundary_eig_mass_vectors(const dm_boundary_eig *e)
{
    return e->MQ;
}

void dm_boundary_eig_mult_K(const dm_boundary_eig *e, const dm_boundary *bw, const double *Y, int ncol,
                            double *KY)
{
    apply_K(e, bw, Y, ncol, KY);
}

void dm_boundary_eig_solve_K(const dm_boundary_eig *e, const dm_boundary *bw, double *Y, int ncol)
{
    solve_K(e, bw, Y, ncol);
}
