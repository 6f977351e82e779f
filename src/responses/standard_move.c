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
 * their static remainder (zero to round-off) is added quasi-statically.
 *
 * All of it is prepared either in the full model's DOFs or in the member
 * engine's reduced coordinates (dm_standard_moves_reduced; `space` below):
 * what follows the preparation reads only each carried mode's frequency,
 * force and platform translation. */
#include <assert.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "standard_move_impl.h"
#include "dm_boundary.h"
#include "dm_integrate.h"
#include "dm_kinematics.h"
#include "dm_loads.h"
#include "dm_static.h"
#include "dm_symeig.h"
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

/* The extremes of the response are found by bounded bisection (see
 * "exact extremes" below): a phase is scanned on at most MAX_INTERVALS
 * intervals, which are halved at most MAX_LEVEL times. */
#define MAX_INTERVALS 1024
#define MAX_LEVEL 40
/* A level's transitions: a11, a12, a21, a22, then cos, sin, the decay and
 * the angle they come from (level_transitions) */
#define TRANS_ROWS 8

/* The modes one direction carries: the k retained ones, then its Ritz
 * modes. During a phase of constant load, q holds each mode's free motion
 * about its static value under that load (see "exact extremes"). */
typedef struct {
    int nm;
    double *om, *z, *g, *q, *v, *normP;  /* nm each */
    double *rz, *iwd, *wwd;              /* an underdamped mode's z om / wd, 1 / wd and
                                            om^2 / wd (wd: the damped frequency), for its
                                            transitions at every level */
    double *p4;                          /* platform translation of each mode: x, y, z,
                                            0 (4 a mode, summed as one vector) */
    int *src;                            /* the retained mode each one is, or -1 (Ritz) */
    double rP[3];                        /* static remainder on the platform */
} carried;

/* The deviation y at an instant, and l, l' of the nslow modes slower than
 * a cut-off (see "exact extremes" below). */
typedef struct {
    double y[3], l[3], dl[3];
    int nslow;
} node;

/* A stored interval of the coarse scan: its first node, the state there,
 * its bound and its end nodes. */
typedef struct {
    int node;
    double bound;
    double *q, *v;
    node a, b;
} candidate;

struct dm_move_ws {
    const dm_move_kernels *kr;           /* the process's path's vector loops (kernels) */
    int n, kmax, nmax;                   /* nmax = kmax + MAXRITZ */
    double *G, *r;                       /* n per direction */
    double *R, *MR, *KR;                 /* per direction a Krylov block, n x MAXRITZ,
                                            and M, K times it */
    double *MPhi;                        /* n x kmax: M times the retained modes */
    double *coef;                        /* kmax + MAXRITZ: a projection's parts */
    double *X, *Y;                       /* interleaved blocks for the kernels */
    carried dir[MAXDIR];
    double *pool;
    /* transitions of each level (2 families: the move's halves, the
     * window), structure of arrays a11, a12, a21, a22 of nmax each, then
     * the parts they are made of (TRANS_ROWS: cos, sin, decay, angle) */
    double *trans[2];
    unsigned char have[2][MAX_LEVEL + 1];
    short slow[2][MAX_LEVEL + 3];        /* slow_at's counts by level (-1: not yet) */
    /* the retained modes' transitions (4 x kmax a level), the same in every
     * direction: made by the first, copied by the others */
    double *rtrans[2];
    unsigned char rhave[2][MAX_LEVEL + 1];
    int *srcpool;
    candidate *cand[2];                  /* two stores of MAX_INTERVALS + 1 (the move's
                                            halves are both scanned before either is
                                            refined) */
    double *cand_pool[2];
    double *stack;                       /* MAX_LEVEL + 2 levels x 4 states of nmax */
    double *blocks[2];                   /* bounds per block of the coarse scan (state_bounds),
                                            per store */
    double *scan;                        /* 2 x nmax: the coarse scan's state */
    /* the coarse scan's batches (batch_nodes): powers 1..B of a level's
     * transitions (4 B a mode), the states (B a mode) and the points' sums (12 B) */
    double *pw, *Qb, *Vb, *sums;
};

static size_t carried_len(int kmax) { return (size_t)(kmax + MAXRITZ) * 13; }

dm_move_ws *dm_move_alloc(int n, int kmax, dm_error *err)
{
    dm_move_ws *w = calloc(1, sizeof *w);
    if (w) {
        size_t nmax = (size_t)kmax + MAXRITZ;
        w->kr = DM_ISA_SELECT(dm_move_kernels_, dm_isa_active()); /* the path's, chosen once */
        w->n = n;
        w->kmax = kmax;
        w->nmax = (int)nmax;
        w->G = malloc(sizeof(double) * n * MAXDIR);
        size_t blk = (size_t)n * MAXRITZ * MAXDIR;
        w->r = malloc(sizeof(double) * n * MAXDIR);
        w->R = malloc(sizeof(double) * blk);
        w->MR = malloc(sizeof(double) * blk);
        w->KR = malloc(sizeof(double) * blk);
        w->MPhi = malloc(sizeof(double) * n * kmax);
        w->coef = malloc(sizeof(double) * nmax);
        w->X = malloc(sizeof(double) * blk);
        w->Y = malloc(sizeof(double) * blk);
        w->pool = malloc(sizeof(double) * carried_len(kmax) * MAXDIR);
        w->trans[0] = malloc(sizeof(double) * TRANS_ROWS * nmax * (MAX_LEVEL + 1));
        w->trans[1] = malloc(sizeof(double) * TRANS_ROWS * nmax * (MAX_LEVEL + 1));
        w->rtrans[0] = malloc(sizeof(double) * TRANS_ROWS * kmax * (MAX_LEVEL + 1));
        w->rtrans[1] = malloc(sizeof(double) * TRANS_ROWS * kmax * (MAX_LEVEL + 1));
        w->srcpool = malloc(sizeof(int) * nmax * MAXDIR);
        for (int st = 0; st < 2; st++) {
            w->cand[st] = malloc(sizeof(candidate) * (MAX_INTERVALS + 1));
            w->cand_pool[st] = malloc(sizeof(double) * 2 * nmax * (MAX_INTERVALS + 1));
            w->blocks[st] = malloc(sizeof(double) * 2 * (nmax + 1) * (MAX_INTERVALS / 16 + 1));
        }
        w->stack = malloc(sizeof(double) * 4 * nmax * (MAX_LEVEL + 2));
        w->scan = malloc(sizeof(double) * 2 * nmax);
        w->pw = malloc(sizeof(double) * 4 * DM_MOVE_BATCH * nmax);
        w->Qb = malloc(sizeof(double) * DM_MOVE_BATCH * nmax);
        w->Vb = malloc(sizeof(double) * DM_MOVE_BATCH * nmax);
        w->sums = malloc(sizeof(double) * 12 * DM_MOVE_BATCH);
    }
    if (!w || !w->G || !w->r || !w->R || !w->MR || !w->KR || !w->MPhi || !w->coef || !w->X ||
        !w->Y || !w->pool || !w->trans[0] || !w->trans[1] || !w->rtrans[0] || !w->rtrans[1] ||
        !w->srcpool || !w->cand[0] || !w->cand[1] || !w->cand_pool[0] || !w->cand_pool[1] ||
        !w->stack || !w->scan || !w->blocks[0] || !w->blocks[1] || !w->pw || !w->Qb || !w->Vb ||
        !w->sums) {
        dm_move_free(w);
        dm_fail(err, DM_ENOMEM, "out of memory for the standard move");
        return NULL;
    }
    for (int d = 0; d < MAXDIR; d++) {
        carried *c = &w->dir[d];
        double *p = w->pool + carried_len(kmax) * d;
        size_t m = (size_t)kmax + MAXRITZ;
        double **arr[] = {&c->om, &c->z, &c->g, &c->q, &c->v, &c->normP, &c->rz, &c->iwd, &c->wwd};
        for (size_t i = 0; i < sizeof arr / sizeof arr[0]; i++, p += m)
            *arr[i] = p; /* 9 arrays of kmax + MAXRITZ, then p4 of 4 times that */
        c->p4 = p;
        c->src = w->srcpool + m * d;
    }
    for (int i = 0; i <= MAX_INTERVALS; i++) {
        for (int st = 0; st < 2; st++) {
            w->cand[st][i].q = w->cand_pool[st] + (size_t)2 * w->nmax * i;
            w->cand[st][i].v = w->cand[st][i].q + w->nmax;
        }
    }
    return w;
}

void dm_move_free(dm_move_ws *w)
{
    if (!w)
        return;
    free(w->G);
    free(w->r);
    free(w->R);
    free(w->MR);
    free(w->KR);
    free(w->MPhi);
    free(w->coef);
    free(w->X);
    free(w->Y);
    free(w->pool);
    free(w->trans[0]);
    free(w->trans[1]);
    free(w->rtrans[0]);
    free(w->rtrans[1]);
    free(w->srcpool);
    for (int st = 0; st < 2; st++) {
        free(w->cand[st]);
        free(w->cand_pool[st]);
        free(w->blocks[st]);
    }
    free(w->stack);
    free(w->scan);
    free(w->pw);
    free(w->Qb);
    free(w->Vb);
    free(w->sums);
    free(w);
}

static void add_mode(carried *c, double om, double g, const double phiP[3], int src)
{
    int j = c->nm++;
    c->src[j] = src;
    c->om[j] = om;
    c->g[j] = g;
    double *p4 = c->p4 + 4 * j;
    p4[0] = phiP[0], p4[1] = phiP[1], p4[2] = phiP[2], p4[3] = 0;
    c->normP[j] = dm_norm3(phiP);
}

/* ---- the carried modes --------------------------------------------------
 *
 * The three directions are prepared side by side: every product with M or
 * K and every solve with K's factor takes the directions' vectors as one
 * block (the block kernels cost little more for three vectors than for
 * one). Each direction's arithmetic is its own: the results do not depend
 * on which directions are prepared together. */

/* The coordinates the moves are prepared in: the full model's DOFs (its
 * products and K's factor) or the member engine's reduced coordinates
 * (dm_boundary: K_red = diag(S, ...), M_red's apply), with the retained
 * modes in them. Everything after the preparation reads only each
 * carried mode's frequency, force and platform translation. */
typedef struct {
    int n, pd;                    /* coordinates; the platform's first translation */
    const double *phi, *mphi;     /* the k retained modes (n x k), M times them (or NULL) */
    const double *omega;          /* their circular frequencies */
    const dm_model *md;           /* the full model and the factor of its K, */
    const dm_static *st;
    dm_boundary *bw;              /* or the reduced model's parts */
    dm_boundary_eig *eig;
} space;

/* Column j of direction d's Krylov block, and M times it. */
static double *krylov(const dm_move_ws *w, int d, int j)
{
    return w->R + ((size_t)d * MAXRITZ + j) * w->n;
}

static double *m_krylov(const dm_move_ws *w, int d, int j)
{
    return w->MR + ((size_t)d * MAXRITZ + j) * w->n;
}

/* What a block operation does to the q vectors it is given. */
typedef enum { OP_MULT_M, OP_MULT_K, OP_SOLVE } block_op;

/* The reduced model's operation on q vectors: gathered into one
 * column-major block, one call, scattered back. */
static void on_reduced_block(dm_move_ws *w, const space *sp, block_op op, const double *const *in,
                             double *const *out, int q)
{
    int n = sp->n;
    for (int r = 0; r < q; r++)
        memcpy(w->X + (size_t)r * n, in[r], sizeof(double) * n);
    const double *res = w->Y;
    if (op == OP_SOLVE)
        dm_boundary_eig_solve_K(sp->eig, sp->bw, w->X, q), res = w->X;
    else if (op == OP_MULT_M)
        dm_boundary_eig_mult_M(sp->eig, w->X, q, w->Y);
    else
        dm_boundary_eig_mult_K(sp->eig, sp->bw, w->X, q, w->Y);
    for (int r = 0; r < q; r++)
        memcpy(out[r], res + (size_t)r * n, sizeof(double) * n);
}

/* out[r] = op(in[r]) for r < q (in place when out[r] == in[r]). On the
 * full model: gathered into one interleaved block, one kernel call,
 * scattered back. The block is padded with zero columns to a multiple of
 * 4, the kernels' vector slice (dm_arrow): 3 or 9 vectors cost more than
 * 4 or 12 (a solve at the default mesh 5.6 against 4.6 us, 10.7 against
 * 7.6); columns are independent, so the padding changes no bit of the
 * others. */
static void on_block(dm_move_ws *w, const space *sp, block_op op, const double *const *in,
                     double *const *out, int q)
{
    int n = sp->n, qp = (q + 3) & ~3;
    assert(q >= 1 && qp <= MAXDIR * MAXRITZ);
    if (sp->eig) {
        on_reduced_block(w, sp, op, in, out, q);
        return;
    }
    for (int i = 0; i < n; i++) {
        double *xi = w->X + (size_t)i * qp;
        for (int r = 0; r < q; r++)
            xi[r] = in[r][i];
        for (int r = q; r < qp; r++)
            xi[r] = 0;
    }
    if (op == OP_SOLVE)
        dm_arrow_chol_solve(dm_static_chol(sp->st), w->X, qp);
    else
        (op == OP_MULT_M ? dm_model_mult_M : dm_model_mult_K)(sp->md, w->X, qp, w->Y);
    const double *res = op == OP_SOLVE ? w->X : w->Y;
    for (int i = 0; i < n; i++)
        for (int r = 0; r < q; r++)
            out[r][i] = res[(size_t)i * qp + r];
}

static double dot(const dm_move_ws *w, const double *a, const double *b, int n)
{
    return w->kr->dot(a, b, n);
}

/* M Phi of the k retained modes, once a pose: the Krylov vectors' parts
 * along them are then (M phi_j)' x, with no product with M of x itself.
 * The subspace solver hands it out with the modes (the products its last
 * check made: the same bits as these); else it is made here. */
static const double *retained_m(dm_move_ws *w, const space *sp, int k)
{
    if (sp->mphi)
        return sp->mphi;
    const int most = MAXDIR * MAXRITZ; /* on_block's widest */
    for (int j0 = 0; j0 < k; j0 += most) {
        int q = k - j0 < most ? k - j0 : most;
        const double *in[MAXDIR * MAXRITZ];
        double *out[MAXDIR * MAXRITZ];
        for (int r = 0; r < q; r++) {
            in[r] = sp->phi + (size_t)(j0 + r) * sp->n;
            out[r] = w->MPhi + (size_t)(j0 + r) * sp->n;
        }
        on_block(w, sp, OP_MULT_M, in, out, q);
    }
    return w->MPhi;
}

/* x -= B c, c = (M B)' x: x's part in span(B) removed M-orthogonally, for
 * B's m columns M-orthonormal (n x m, M B beside it); c returned. */
static void project_out(const dm_move_ws *w, double *x, const double *B, const double *MB, int n,
                        int ldb, int m, double *c)
{
    for (int j = 0; j < m; j++)
        c[j] = dot(w, MB + (size_t)j * ldb, x, n);
    w->kr->subtract_combination(n, m, B, ldb, c, x);
}

/* M-orthonormalise Krylov column m of the directions in dirs[0..q) against
 * the retained modes and their columns 0..m-1; ok[d] = 0 where nothing is
 * left (the column already in their span). One pass: the Krylov vectors
 * are orthogonal to the retained modes in exact arithmetic already (A
 * keeps the complement of an invariant subspace); the projection removes
 * the round-off of their shapes. The parts come from M Phi (mphi, see
 * retained_m) and the earlier columns' stored M products, so x's product
 * with M is needed after the projection only; its M-norm before it is
 * that after it plus the squares of the parts (Pythagoras: the basis is
 * M-orthonormal). */
static void orthonormalise(dm_move_ws *w, const space *sp, const double *mphi, int k, int m,
                           const int *dirs, int q, int *ok)
{
    int n = sp->n;
    double *x[MAXDIR], *mx[MAXDIR], removed[MAXDIR], *c = w->coef;
    for (int r = 0; r < q; r++) {
        x[r] = krylov(w, dirs[r], m), mx[r] = m_krylov(w, dirs[r], m);
        project_out(w, x[r], sp->phi, mphi, n, n, k, c);
        if (m > 0)
            project_out(w, x[r], krylov(w, dirs[r], 0), m_krylov(w, dirs[r], 0), n, w->n, m,
                        c + k);
        removed[r] = dot(w, c, c, k + m);
    }
    on_block(w, sp, OP_MULT_M, (const double *const *)x, mx, q);
    for (int r = 0; r < q; r++) {
        double after = dot(w, x[r], mx[r], n);
        ok[dirs[r]] = after > 1e-20 * (after + removed[r]) && after > 0;
        if (!ok[dirs[r]])
            continue;
        double s = 1 / sqrt(after);
        for (int i = 0; i < n; i++) {
            x[r][i] *= s;
            mx[r][i] *= s;
        }
    }
}

/* The Krylov blocks span(r, A r, ...) (A = K^-1 M) of the directions,
 * nritz[d] columns at most (0: none); nkept[d] columns kept. */
static void krylov_blocks(dm_move_ws *w, const space *sp, int k, int ndir, const int *nritz,
                          int *nkept)
{
    int n = sp->n, active[MAXDIR], ok[MAXDIR], q = 0;
    for (int d = 0; d < ndir; d++) {
        nkept[d] = 0;
        if (nritz[d] > 0) {
            memcpy(krylov(w, d, 0), w->r + (size_t)d * n, sizeof(double) * n);
            active[q++] = d;
        }
    }
    const double *mphi = q > 0 ? retained_m(w, sp, k) : NULL;
    for (int m = 0; q > 0; m++) {
        orthonormalise(w, sp, mphi, k, m, active, q, ok);
        int still = 0;
        double *from[MAXDIR], *to[MAXDIR];
        for (int r = 0; r < q; r++) {
            int d = active[r];
            if (!ok[d])
                continue;
            nkept[d] = m + 1;
            if (m + 1 < nritz[d]) { /* the next Krylov vector: A times this one */
                from[still] = m_krylov(w, d, m), to[still] = krylov(w, d, m + 1);
                active[still++] = d;
            }
        }
        if ((q = still) > 0)
            on_block(w, sp, OP_SOLVE, (const double *const *)from, to, q);
    }
}

/* The Ritz modes of each direction's Krylov block: Rayleigh-Ritz with K
 * (the blocks are M-orthonormal). */
static void ritz_modes(dm_move_ws *w, const space *sp, int ndir, const int *nkept)
{
    int n = sp->n, pd = sp->pd, q = 0;
    double *x[MAXDIR * MAXRITZ], *kx[MAXDIR * MAXRITZ];
    for (int d = 0; d < ndir; d++)
        for (int j = 0; j < nkept[d]; j++, q++)
            x[q] = krylov(w, d, j), kx[q] = w->KR + (size_t)q * n;
    if (!q)
        return;
    on_block(w, sp, OP_MULT_K, (const double *const *)x, kx, q);
    q = 0;
    for (int d = 0; d < ndir; d++) {
        int m = nkept[d];
        double KR[MAXRITZ * MAXRITZ], Z[MAXRITZ * MAXRITZ], ev[MAXRITZ], xG[MAXRITZ];
        const double *G = w->G + (size_t)d * n;
        for (int j = 0; j < m; j++) {
            xG[j] = dot(w, x[q + j], G, n);
            for (int i = 0; i < m; i++)
                KR[j * m + i] = dot(w, x[q + i], kx[q + j], n);
        }
        for (int j = 0; j < m; j++) /* symmetric */
            for (int i = 0; i < j; i++)
                KR[j * m + i] = KR[i * m + j] = 0.5 * (KR[j * m + i] + KR[i * m + j]);
        if (m && !dm_symeig(m, KR, m, ev, Z, m)) {
            for (int i = 0; i < m; i++) {
                if (!(ev[i] > 0))
                    continue;
                double g = 0, phiP[3] = {0, 0, 0};
                for (int j = 0; j < m; j++) {
                    double z = Z[i * m + j];
                    g += z * xG[j];
                    for (int c3 = 0; c3 < 3; c3++)
                        phiP[c3] += z * x[q + j][pd + c3];
                }
                add_mode(&w->dir[d], sqrt(ev[i]), g, phiP, -1);
            }
        }
        q += m;
    }
}

/* Load of a unit acceleration along each direction (in the space's
 * coordinates: the model's G, or T' G), and the retained modes' forces
 * and platform shapes. */
static int direction_loads(dm_move_ws *w, const space *sp, const dm_robot *rb,
                           const dm_pose *pose, int k, const double (*dir)[3], int ndir,
                           dm_error *err)
{
    int n = sp->n, pd = sp->pd;
    const double v0[3] = {0, 0, 0};
    dm_rigid_motion m[MAXDIR];
    for (int d = 0; d < ndir; d++) {
        m[d] = (dm_rigid_motion){{0, 0, 0}, {0, 0, 0}, {dir[d][0], dir[d][1], dir[d][2]}};
        int rc = dm_kin_accelerations(rb, pose, v0, dir[d], m[d].alpha_ddot, err);
        if (rc)
            return rc;
    }
    if (sp->bw)
        dm_boundary_inertial_loads(sp->bw, pose, m, ndir, w->G);
    else {
        memset(w->G, 0, sizeof(double) * n * ndir);
        dm_loads_add_inertial_many(sp->md, m, ndir, w->G);
    }
    for (int d = 0; d < ndir; d++) {
        carried *c = &w->dir[d];
        const double *G = w->G + (size_t)d * n;
        c->nm = 0;
        for (int j = 0; j < k; j++) {
            const double *ph = sp->phi + (size_t)j * n;
            add_mode(c, sp->omega[j], dot(w, ph, G, n), ph + pd, j);
        }
        memset(c->rP, 0, sizeof c->rP);
    }
    return DM_OK;
}

/* The modes each direction carries (retained, then Ritz) with their modal
 * forces and platform shapes; what stays static of the dropped modes'
 * response. */
static int prepare(dm_move_ws *w, const space *sp, const dm_robot *rb, const dm_pose *pose,
                   int k, const double (*dir)[3], int ndir, const dm_move_opts *o, dm_error *err)
{
    int n = sp->n, pd = sp->pd;
    int rc = direction_loads(w, sp, rb, pose, k, dir, ndir, err);
    if (rc || !o->quasi_static)
        return rc;
    /* r = K^-1 G - sum_j phi_j g_j / omega_j^2, all directions in one solve */
    double *r[MAXDIR], *G[MAXDIR];
    for (int d = 0; d < MAXDIR; d++)
        r[d] = w->r + (size_t)d * n, G[d] = w->G + (size_t)d * n;
    on_block(w, sp, OP_SOLVE, (const double *const *)G, r, ndir);
    int nritz[MAXDIR], nkept[MAXDIR];
    for (int d = 0; d < ndir; d++) {
        carried *c = &w->dir[d];
        double sr[3] = {0, 0, 0};
        for (int j = 0; j < k; j++) {
            const double *ph = sp->phi + (size_t)j * n;
            double f = c->g[j] / (c->om[j] * c->om[j]);
            for (int i = 0; i < n; i++)
                r[d][i] -= f * ph[i];
            for (int c3 = 0; c3 < 3; c3++)
                sr[c3] += c->p4[4 * j + c3] * f;
        }
        for (int c3 = 0; c3 < 3; c3++)
            c->rP[c3] = r[d][pd + c3];
        /* Ritz vectors only where the dropped modes matter: their dynamic
         * response cannot exceed ~4 |rP| (a bang-bang reverses its load),
         * so below 5e-4 of the retained modes' static response they would
         * change nothing beyond 0.2 % (han2011: 1e-5..1e-4) */
        nritz[d] = dm_norm3(c->rP) > 5e-4 * dm_norm3(sr) ? o->ritz_vectors : 0;
        nritz[d] = nritz[d] < MAXRITZ ? nritz[d] : MAXRITZ;
    }
    krylov_blocks(w, sp, k, ndir, nritz, nkept);
    ritz_modes(w, sp, ndir, nkept);
    for (int d = 0; d < ndir; d++) {
        carried *c = &w->dir[d];
        for (int j = k; j < c->nm; j++) { /* what the Ritz modes carry statically */
            double s = c->g[j] / (c->om[j] * c->om[j]);
            for (int c3 = 0; c3 < 3; c3++)
                c->rP[c3] -= c->p4[4 * j + c3] * s;
        }
    }
    return DM_OK;
}

/* Carried modes in ascending frequency (a Ritz mode may lie below a
 * retained one): the modes slower than any cut-off are then a prefix. */
static void sort_by_frequency(carried *c)
{
    double *arr[] = {c->om, c->g, c->normP};
    for (int j = 1; j < c->nm; j++)
        for (int i = j; i > 0 && c->om[i] < c->om[i - 1]; i--) {
            for (size_t a = 0; a < sizeof arr / sizeof arr[0]; a++) {
                double t = arr[a][i];
                arr[a][i] = arr[a][i - 1];
                arr[a][i - 1] = t;
            }
            for (int r = 0; r < 4; r++) {
                double t = c->p4[4 * i + r];
                c->p4[4 * i + r] = c->p4[4 * (i - 1) + r];
                c->p4[4 * (i - 1) + r] = t;
            }
            int t = c->src[i];
            c->src[i] = c->src[i - 1];
            c->src[i - 1] = t;
        }
}

/* ---- exact extremes of the platform deviation -----------------------------
 *
 * Over a phase of constant load a the deviation from the static platform
 * position is
 *     y(t) = yp + sum_j p_j h_j(t),   yp = a rP + sum_j p_j a g_j / omega_j^2,
 * with h_j the free motion of mode j about its static value under a (kept
 * in carried.q, its rate in carried.v) and p_j the mode's platform
 * translation. A free mode's amplitude never grows: from any instant on,
 * |h_j| <= D0_j and |h_j''| <= D2_j (underdamped: D2 = omega^2 D0, see
 * mode_bounds). Over an interval of half-length h, every point lies within
 * h of an end; from there a slow mode (omega h < sqrt 2) is its tangent to
 * within D2 h^2 / 2, and a fast one lies within D0 of nothing, so
 *     max |y| <= max(|l(a)|, |l(a) + h l'(a)|, |l(b)|, |l(b) - h l'(b)|)
 *                + sum_slow |p_j| D2_j h^2 / 2 + sum_fast |p_j| D0_j,
 * l being yp plus the slow modes' part. A coarse scan samples y exactly
 * (each mode advanced by its exact transition; BLOCK points at a time from
 * one state, by the transition's powers) on intervals short enough for
 * that bound to be within COARSE_SLACK of the response's size; the
 * intervals whose bound exceeds the largest sample are halved, and halved
 * again, until no bound exceeds it by MAX_REL. The maximum found is the
 * true maximum of the continuous response to MAX_REL, from a few samples
 * per period of the modes that matter (fixed sampling at 20 per period of
 * the highest one costs thousands per second and still misses up to 1.2 %
 * of a peak between its samples). The settling time is the last instant
 * at which |y| exceeds the band, found by the same bounds to SETTLE_RES. */

#define SQRT2 1.4142135623730951
/* Bound slack of the coarse scan, relative to the response's size. The
 * scan's points cost ~15 ns each in batches, a refinement's ~65: a fine
 * scan leaves fewer intervals to halve (chen2018's window: 125 candidates
 * and 418 evaluations a move at 0.1, 56 and 237 at 0.02; 0.01 and 0.005
 * no faster, docs/model-choices.md "Standard moves"). */
#define COARSE_SLACK 0.02
/* Relative accuracy of the maxima; time resolution of the settling time
 * (fraction of the window). */
#define MAX_REL 1e-9
#define SETTLE_RES 1e-9

/* The parts of an underdamped mode's transition over h: cos and sin of
 * the damped angle wd h, the decay e^(-z om h) and the angle itself (NaN
 * for a mode damped critically or more, whose transition has no such
 * parts). */
static void transition_parts(double om, double z, double h, double cs[4])
{
    if (z < 1 - 1e-6) {
        double wd = om * sqrt(1 - z * z);
        cs[0] = cos(wd * h), cs[1] = sin(wd * h), cs[2] = exp(-z * om * h), cs[3] = wd * h;
        return;
    }
    cs[0] = cs[1] = cs[2] = cs[3] = NAN;
}

/* Whether a mode's parts over h / 2 may come from those over h (angle
 * x there) by the half-angle formulas (cos^2(x/2) = (1 + cos x) / 2,
 * sin x = 2 sin(x/2) cos(x/2), the decay's square root; the kernel's
 * halve_transitions): for angles up to pi/2, where 1 + cos x >= 1 loses
 * nothing, each halving adds about an ulp to the parts (some 40 ulps at
 * the deepest level, against the maxima's 1e-9). Not for a larger angle,
 * nor for a mode without parts (NaN). */
static int halves_apply(double x) { return x <= M_PI / 2; }

/* Transition of carried mode j over h: (h, h') <- [a11 a12; a21 a22]
 * (h, h'), from its parts over h (an underdamped mode: closed form, as
 * dm_sdof_step's, with the mode's factors made once a move: a square root
 * and three divisions fewer a level). */
static void mode_transition(const carried *cm, int j, double h, const double cs[4], double a[4])
{
    double om = cm->om[j], z = cm->z[j];
    if (z < 1 - 1e-6) {
        double e = cs[2], c = cs[0], s = cs[1], r = cm->rz[j];
        a[0] = e * (c + r * s);
        a[1] = e * s * cm->iwd[j];
        a[2] = -e * cm->wwd[j] * s;
        a[3] = e * (c - r * s);
        return;
    }
    double q = 1, v = 0;
    dm_sdof_step(om, z, 0, 0, h, &q, &v);
    a[0] = q, a[2] = v;
    q = 0, v = 1;
    dm_sdof_step(om, z, 0, 0, h, &q, &v);
    a[1] = q, a[3] = v;
}

/* Bounds on |h| and |h''| from now on for a free mode in state (q, v). */
static void mode_bounds(double om, double z, double q, double v, double *d0, double *d2)
{
    if (z < 1 - 1e-6) { /* h = R e^(-z om t) cos(wd t + phi), each derivative x om */
        double wd = om * sqrt(1 - z * z), c2 = (v + z * om * q) / wd;
        *d0 = sqrt(q * q + c2 * c2);
        *d2 = om * om * *d0;
    } else if (z > 1 + 1e-6) { /* c1 e^(r1 t) + c2 e^(r2 t), both decaying */
        double rt = om * sqrt(z * z - 1), r1 = -z * om + rt, r2 = -z * om - rt;
        double c1 = (v - r2 * q) / (r1 - r2), c2 = q - c1;
        *d0 = fabs(c1) + fabs(c2);
        *d2 = fabs(c1) * r1 * r1 + fabs(c2) * r2 * r2;
    } else { /* (q + c t) e^(-om t); t e^(-om t) <= 1 / (e om) */
        double c = v + om * q;
        *d0 = fabs(q) + fabs(c) / (M_E * om);
        *d2 = om * om * fabs(q) + 2 * om * fabs(c) + om * fabs(c) / M_E;
    }
}

/* One phase of constant load: family 0 the move's halves, 1 the window;
 * its length is the step of level 0, level l steps by base / 2^l. */
typedef struct {
    dm_move_ws *w;
    const carried *c;
    int family;
    double base, t0;   /* length; start time (reported times add it) */
    double yp[3];      /* static part of y */
    double tol;        /* settling band (window of a damped robot), else < 0 */
    double L, tL;      /* largest |y| found, and when */
    const double *bounds;  /* those a refinement uses (state_bounds) */
    int store;         /* where its scan keeps candidates and bounds (0, 1) */
    int undamped;      /* no mode decays: the bounds of its start hold throughout */
} phase;

/* base / 2^level, exactly (a power of two's product; ldexp's library call
 * was 2 % of the moves) */
static inline double step_of(const phase *ph, int level)
{
    assert(level >= 0 && level <= MAX_LEVEL + 2);
    return ph->base * (1.0 / (double)(1ULL << level));
}

/* The transitions of a phase's level for the direction's carried modes.
 * A retained mode's (the same frequency, damping and step in every
 * direction) is made by the first direction that needs the level and
 * copied by the others: the same numbers, a third of the sines. */
static const double *level_transitions(const phase *ph, int level)
{
    dm_move_ws *w = ph->w;
    int nmax = w->nmax, f = ph->family, kmax = w->kmax;
    double *t = w->trans[f] + (size_t)TRANS_ROWS * nmax * level;
    if (!w->have[f][level]) {
        double h = step_of(ph, level), a[4], cs[4];
        double *rt = w->rtrans[f] + (size_t)TRANS_ROWS * kmax * level;
        /* the level above, where this direction made it: its parts halved
         * instead of a sine, a cosine and an exponential, all the modes
         * side by side (the kernel halve_transitions: the half-angle
         * formulas, then mode_transition's operations), then those it
         * does not serve (halves_apply) one by one */
        const double *above = level && w->have[f][level - 1] ? t - (size_t)TRANS_ROWS * nmax : NULL;
        const carried *c = ph->c;
        if (above)
            w->kr->halve_transitions(c->nm, nmax, above, t, c->rz, c->iwd, c->wwd);
        for (int j = 0; j < c->nm; j++) {
            int s = c->src[j];
            if (s >= 0 && w->rhave[f][level]) {
                for (int r = 0; r < TRANS_ROWS; r++)
                    t[r * nmax + j] = rt[r * kmax + s];
                continue;
            }
            if (!above || !halves_apply(above[7 * nmax + j])) {
                transition_parts(c->om[j], c->z[j], h, cs);
                mode_transition(c, j, h, cs, a);
                double x[TRANS_ROWS] = {a[0], a[1], a[2], a[3], cs[0], cs[1], cs[2], cs[3]};
                for (int r = 0; r < TRANS_ROWS; r++)
                    t[r * nmax + j] = x[r];
            }
            if (s >= 0)
                for (int r = 0; r < TRANS_ROWS; r++)
                    rt[r * kmax + s] = t[r * nmax + j];
        }
        w->have[f][level] = 1;
        w->rhave[f][level] = 1; /* (every direction carries all the retained modes) */
    }
    return t;
}

static void step_modes(const phase *ph, const double *t, const double *q, const double *v,
                       double *qo, double *vo)
{
    ph->w->kr->step_modes(ph->c->nm, t, ph->w->nmax, q, v, qo, vo);
}

/* How many modes are slower than wlim (a prefix: sort_by_frequency). */
static int slow_count(const carried *c, double wlim)
{
    int n = 0;
    while (n < c->nm && c->om[n] < wlim)
        n++;
    return n;
}

/* The modes slow over intervals of half-length step_of(level) (omega h <
 * sqrt 2), counted once a direction and family: a halving asked it at
 * every node. */
static int slow_at(const phase *ph, int level)
{
    short *n = &ph->w->slow[ph->family][level];
    if (*n < 0)
        *n = (short)slow_count(ph->c, SQRT2 / step_of(ph, level));
    return *n;
}

/* y at a state, and l, l' of its ns slowest modes (the sums:
 * standard_move_kernels.c). */
static void eval_node(const phase *ph, const double *q, const double *v, int ns, node *nd)
{
    const carried *c = ph->c;
    double l[4], d[4], f[4];
    ph->w->kr->node_sums(c->p4, q, v, ns, c->nm, l, d, f);
    const double *p = ph->yp;
    for (int r = 0; r < 3; r++) {
        nd->l[r] = p[r] + l[r];
        nd->y[r] = nd->l[r] + f[r];
        nd->dl[r] = d[r];
    }
    nd->nslow = ns;
}

/* Bounds from a state on (valid for all later times), as sums over the
 * modes in frequency order: b[j] = sum_{i<j} |p_i| D2_i (what the j
 * slowest modes can bend) and b[nmax + 1 + j] = sum_{i>=j} |p_i| D0_i
 * (how far the others can stray). */
static void state_bounds(const phase *ph, const double *q, const double *v, double *b)
{
    const carried *c = ph->c;
    int nm = c->nm;
    double *pre2 = b, *suf0 = b + ph->w->nmax + 1;
    pre2[0] = 0;
    suf0[nm] = 0;
    for (int j = 0; j < nm; j++) {
        double d0, d2;
        mode_bounds(c->om[j], c->z[j], q[j], v[j], &d0, &d2);
        pre2[j + 1] = pre2[j] + c->normP[j] * d2;
        suf0[j] = c->normP[j] * d0; /* summed below, from the fastest */
    }
    for (int j = nm - 1; j >= 0; j--)
        suf0[j] += suf0[j + 1];
}

/* The bound terms for the ns slowest modes: sum over them of |p| D2, over
 * the others of |p| D0, and over all of |p| D0 (how far y can still move
 * from yp). */
typedef struct {
    double slow2, fast0, env;
} slack;

static void slack_of(const phase *ph, const double *b, int ns, slack *s)
{
    const double *suf0 = b + ph->w->nmax + 1;
    s->slow2 = b[ns], s->fast0 = suf0[ns], s->env = suf0[0];
}

static double offset_norm2(const double y[3], const double d[3], double h)
{
    double e[3] = {y[0] + h * d[0], y[1] + h * d[1], y[2] + h * d[2]};
    return dm_dot3(e, e);
}

/* fmax's result, inline (the library call was 3 % of the moves): the
 * larger, and the other one where one is NaN. */
static inline double larger(double a, double b) { return a > b || isnan(b) ? a : b; }

/* The upper bound of |y| over the interval (a, b) of half-length h is
 * sqrt(ends) + slow2 h^2 / 2 + fast0 (see "exact extremes"), ends the
 * largest square of the end terms (one root of the largest square: the
 * same number as the largest root). */
static double interval_ends(const node *a, const node *b, double h)
{
    return larger(larger(dm_dot3(a->l, a->l), offset_norm2(a->l, a->dl, h)),
                  larger(dm_dot3(b->l, b->l), offset_norm2(b->l, b->dl, -h)));
}

/* The squares sq below which sqrt(sq) + x + y (rounded as written)
 * cannot exceed t: 1e-12 short of the threshold's square, with room for
 * the sum's rounding; -inf where no square is (t too close to x + y). */
static inline double quiet_below(double x, double y, double t)
{
    double r = t - x - y - 1e-12 * (t + x + y);
    return r > 0 ? r * r * (1 - 1e-12) : -INFINITY;
}

/* Whether sqrt(sq) + x + y can exceed t, decided without the root where
 * sq is far enough below: the test is exact, the root is taken only
 * within 1e-12 of the threshold. */
static inline int may_exceed(double sq, double x, double y, double t)
{
    return !(sq < quiet_below(x, y, t));
}

static void note_sample(phase *ph, const node *nd, double t)
{
    double val = dm_norm3(nd->y);
    if (val > ph->L) {
        ph->L = val;
        ph->tL = ph->t0 + t;
    }
}

/* The two halves of the interval of `level` that starts in state (q, v),
 * with end nodes a and b: the middle state (into the stack), the nodes
 * under the halves' cut-off (a and b evaluated again only when it moved
 * a mode from fast to slow) and the bounds of both halves, kept without
 * their roots: sqrt(ends[right]) + x + y (interval_ends). The decisions
 * take a root only near their threshold (half_exceeds): the two halves'
 * roots were 4.5 % of a chen2018 sweep's time (AVX2). */
typedef struct {
    double *qm, *vm;
    node a, m, b;
    double ends[2], x, y;
} halves;

static double half_bound(const halves *hv, int right)
{
    return sqrt(hv->ends[right]) + hv->x + hv->y;
}

/* half_bound(hv, right) > t, exactly */
static int half_exceeds(const halves *hv, int right, double t)
{
    return may_exceed(hv->ends[right], hv->x, hv->y, t) && half_bound(hv, right) > t;
}

static void split(phase *ph, int level, const double *q, const double *v, const node *a,
                  const node *b, halves *hv)
{
    int nmax = ph->w->nmax;
    double *slot = ph->w->stack + (size_t)4 * nmax * (level + 1);
    hv->qm = slot, hv->vm = slot + nmax;
    const double *t = level_transitions(ph, level + 1);
    step_modes(ph, t, q, v, hv->qm, hv->vm);
    double half = step_of(ph, level + 2);
    int ns = slow_at(ph, level + 2);
    eval_node(ph, hv->qm, hv->vm, ns, &hv->m);
    hv->a = *a;
    hv->b = *b;
    if (a->nslow != ns)
        eval_node(ph, q, v, ns, &hv->a);
    if (b->nslow != ns) {
        double *qb = slot + 2 * nmax, *vb = slot + 3 * nmax;
        step_modes(ph, t, hv->qm, hv->vm, qb, vb);
        eval_node(ph, qb, vb, ns, &hv->b);
    }
    slack s;
    slack_of(ph, ph->bounds, ns, &s);
    hv->ends[0] = interval_ends(&hv->a, &hv->m, half);
    hv->ends[1] = interval_ends(&hv->m, &hv->b, half);
    hv->x = s.slow2 * half * half / 2, hv->y = s.fast0;
}

/* Halve the interval of `level` starting at t in state (q, v), ends a and
 * b, until no part of it can exceed the largest sample by MAX_REL. */
static void refine_max(phase *ph, int level, double t, const double *q, const double *v,
                       const node *a, const node *b)
{
    if (level >= MAX_LEVEL)
        return;
    halves hv;
    split(ph, level, q, v, a, b, &hv);
    double len = step_of(ph, level + 1);
    note_sample(ph, &hv.m, t + len);
    /* the half with the larger bound first, where both may hold a larger
     * value (where one cannot now, it never will: L only grows) */
    double top = ph->L * (1 + MAX_REL);
    int right_first = half_exceeds(&hv, 1, top) &&
                      (!half_exceeds(&hv, 0, top) || half_bound(&hv, 1) > half_bound(&hv, 0));
    for (int k = 0; k < 2; k++) {
        int right = k ^ !right_first;
        if (!half_exceeds(&hv, right, ph->L * (1 + MAX_REL)))
            continue;
        if (right)
            refine_max(ph, level + 1, t + len, hv.qm, hv.vm, &hv.m, &hv.b);
        else
            refine_max(ph, level + 1, t, q, v, &hv.a, &hv.m);
    }
}

/* The last instant in the interval of `level` starting at t (state q, v;
 * ends a, b) at which |y| exceeds the band, to SETTLE_RES of the window;
 * -1 if none. */
static double latest_above(phase *ph, int level, double t, const double *q, const double *v,
                           const node *a, const node *b)
{
    double len = step_of(ph, level + 1);
    if (dm_norm3(b->y) > ph->tol)
        return t + 2 * len;
    if (level >= MAX_LEVEL || 2 * len < SETTLE_RES * ph->base)
        return dm_norm3(a->y) > ph->tol ? t : -1;
    halves hv;
    split(ph, level, q, v, a, b, &hv);
    if (half_exceeds(&hv, 1, ph->tol)) {
        double r = latest_above(ph, level + 1, t + len, hv.qm, hv.vm, &hv.m, &hv.b);
        if (r >= 0)
            return r;
    }
    if (dm_norm3(hv.m.y) > ph->tol)
        return t + len;
    return half_exceeds(&hv, 0, ph->tol) ? latest_above(ph, level + 1, t, q, v, &hv.a, &hv.m) : -1;
}

/* Coarse level of a phase: the fewest intervals (a power of two, at most
 * MAX_INTERVALS) whose bound slack is within COARSE_SLACK of the size of
 * the response, from the bounds b of its start. */
static int coarse_level(const phase *ph, const double *b)
{
    slack s;
    slack_of(ph, b, 0, &s);
    double size = dm_norm3(ph->yp) + s.env;
    int level = 0;
    for (; (1 << level) < MAX_INTERVALS; level++) {
        double h = step_of(ph, level + 1);
        slack_of(ph, b, slow_at(ph, level + 1), &s);
        if (s.slow2 * h * h / 2 + s.fast0 <= COARSE_SLACK * size)
            break;
    }
    return level;
}

/* A phase's coarse scan, kept for its refinements. */
typedef struct {
    int level;                      /* of its intervals */
    int ncand, last_above, stopped; /* last node above the band (-1: none) */
    double end_value;               /* |y| at the phase's end */
} scan_result;

/* Bounds of block b of the coarse scan (BLOCK intervals each: one batch). */
#define BLOCK DM_MOVE_BATCH
static double *block_bounds(const phase *ph, int b)
{
    if (ph->undamped) /* an undamped mode's amplitude is the same from any instant */
        b = 0;
    return ph->w->blocks[ph->store] + (size_t)2 * (ph->w->nmax + 1) * b;
}

/* Powers 1..BLOCK of a level's transitions, per mode (batch_nodes's
 * layout): P_r = T P_(r-1), products of 2 x 2 matrices (their round-off,
 * ~r eps of the state, is what stepping r times would leave too). */
static const double *level_powers(const phase *ph, int level)
{
    const double *t = level_transitions(ph, level);
    int nmax = ph->w->nmax;
    enum { B = BLOCK };
    for (int j = 0; j < ph->c->nm; j++) {
        double *a = ph->w->pw + (size_t)j * 4 * B;
        double t11 = t[j], t12 = t[nmax + j], t21 = t[2 * nmax + j], t22 = t[3 * nmax + j];
        a[0] = t11, a[B] = t12, a[2 * B] = t21, a[3 * B] = t22;
        for (int r = 1; r < B; r++) {
            double p11 = a[r - 1], p12 = a[B + r - 1], p21 = a[2 * B + r - 1];
            double p22 = a[3 * B + r - 1];
            a[r] = t11 * p11 + t12 * p21;
            a[B + r] = t11 * p12 + t12 * p22;
            a[2 * B + r] = t21 * p11 + t22 * p21;
            a[3 * B + r] = t21 * p12 + t22 * p22;
        }
    }
    return ph->w->pw;
}

/* Batch point r's state (column r of Qb, Vb) into (q, v). */
static void batch_state(const phase *ph, int r, double *q, double *v)
{
    const dm_move_ws *w = ph->w;
    for (int j = 0; j < ph->c->nm; j++) {
        q[j] = w->Qb[(size_t)j * BLOCK + r];
        v[j] = w->Vb[(size_t)j * BLOCK + r];
    }
}

/* Rows of batch_nodes's output. */
enum { ROW_L = 0, ROW_DL = 3, ROW_Y = 6, ROW_YY = 9, ROW_START = 10, ROW_END = 11 };

/* Batch point r's node (as eval_node makes it). */
static void batch_node(const phase *ph, int r, int ns, node *nd)
{
    const double *o = ph->w->sums + r;
    for (int c = 0; c < 3; c++) {
        nd->l[c] = o[(ROW_L + c) * BLOCK];
        nd->y[c] = o[(ROW_Y + c) * BLOCK];
        nd->dl[c] = o[(ROW_DL + c) * BLOCK];
    }
    nd->nslow = ns;
}

/* Keep the scan's interval from node i - 1 (state q, v; ends a, b) for
 * refinement. */
static void keep_candidate(phase *ph, scan_result *sr, int i, double bound, const node *a,
                           const node *b, const double *q, const double *v)
{
    candidate *cd = &ph->w->cand[ph->store][sr->ncand++];
    cd->node = i - 1;
    cd->bound = bound;
    cd->a = *a;
    cd->b = *b;
    memcpy(cd->q, q, sizeof(double) * ph->c->nm);
    memcpy(cd->v, v, sizeof(double) * ph->c->nm);
}

/* Whether the batch's points (sums o, nb of them; the squared start ends
 * of the node before ps) leave everything as it is: no sample above the
 * largest, no interval whose bound may exceed it, nothing beyond the
 * band (the loop of scan_batch would decide nothing; most of an
 * undamped window's batches). The same tests without the loop's
 * branches: the thresholds do not move within such a batch. */
static int batch_is_quiet(const phase *ph, const double *o, int nb, double x, double fast0,
                          double ps)
{
    double ythr = quiet_below(0, 0, ph->L), ethr = quiet_below(x, fast0, ph->L * (1 + MAX_REL));
    if (ph->tol >= 0) {
        ythr = fmin(ythr, quiet_below(0, 0, ph->tol));
        ethr = fmin(ethr, quiet_below(x, fast0, ph->tol));
    }
    int quiet = 1;
    for (int r = 0; r < nb; r++) {
        double ends = larger(ps, o[ROW_END * BLOCK + r]);
        ps = o[ROW_START * BLOCK + r];
        quiet &= o[ROW_YY * BLOCK + r] < ythr && ends < ethr;
    }
    return quiet;
}

/* The scan's points of one batch (nb of them, the first node i0 + 1; prev
 * the node before, its squared start ends in *prev_start): samples,
 * candidates, the last point above the band; prev left at the last. */
static void scan_batch(phase *ph, scan_result *sr, int i0, int nb, double H, int ns,
                       const slack *s, const double *qa, const double *va, node *prev,
                       double *prev_start)
{
    const double *o = ph->w->sums;
    double h = H / 2, x = s->slow2 * h * h / 2, *qp = ph->w->stack, *vp = qp + ph->w->nmax;
    if (batch_is_quiet(ph, o, nb, x, s->fast0, *prev_start)) {
        *prev_start = o[ROW_START * BLOCK + nb - 1];
        batch_node(ph, nb - 1, ns, prev);
        return;
    }
    for (int r = 0; r < nb; r++) {
        int i = i0 + r + 1, cand = 0;
        double yy = o[ROW_YY * BLOCK + r], ends = larger(*prev_start, o[ROW_END * BLOCK + r]);
        *prev_start = o[ROW_START * BLOCK + r];
        if (may_exceed(yy, 0, 0, ph->L) && sqrt(yy) > ph->L) {
            ph->L = sqrt(yy);
            ph->tL = ph->t0 + i * H;
        }
        double top = ph->L * (1 + MAX_REL);
        int settling = ph->tol >= 0 && i - 1 >= sr->last_above;
        if (may_exceed(ends, x, s->fast0, settling && ph->tol < top ? ph->tol : top)) {
            double bound = sqrt(ends) + x + s->fast0; /* the interval's bound */
            cand = bound > top || (settling && bound > ph->tol);
            if (cand) {
                node a = *prev, b;
                if (r > 0) {
                    batch_node(ph, r - 1, ns, &a);
                    batch_state(ph, r - 1, qp, vp);
                }
                batch_node(ph, r, ns, &b);
                keep_candidate(ph, sr, i, bound, &a, &b, r ? qp : qa, r ? vp : va);
            }
        }
        if (ph->tol >= 0 && may_exceed(yy, 0, 0, ph->tol) && sqrt(yy) > ph->tol)
            sr->last_above = i;
    }
    batch_node(ph, nb - 1, ns, prev);
}

/* The coarse scan of a phase from state (q, v), left at the phase's end
 * state (unless the scan stopped early): samples, and the intervals that
 * may hold a larger value or the last excursion beyond the band. The
 * points are evaluated a block at a time from the block's first state
 * (batch_nodes), the bounds of the block's intervals from that state. */
static void scan_phase(phase *ph, double *q, double *v, scan_result *sr)
{
    dm_move_ws *w = ph->w;
    int nmax = w->nmax, nm = ph->c->nm;
    double *bb = block_bounds(ph, 0);
    state_bounds(ph, q, v, bb);
    int level = coarse_level(ph, bb), N = 1 << level;
    double H = step_of(ph, level);
    int ns = slow_at(ph, level + 1); /* (H / 2 is step_of(level + 1) exactly) */
    const double *pw = level_powers(ph, level);
    double *qa = w->scan, *va = qa + nmax;
    memcpy(qa, q, sizeof(double) * nm);
    memcpy(va, v, sizeof(double) * nm);
    node prev;
    slack s;
    eval_node(ph, qa, va, ns, &prev);
    note_sample(ph, &prev, 0);
    double prev_start = larger(dm_dot3(prev.l, prev.l), offset_norm2(prev.l, prev.dl, H / 2));
    sr->ncand = 0;
    sr->stopped = 0;
    sr->last_above = ph->tol >= 0 && dm_norm3(prev.y) > ph->tol ? 0 : -1;
    for (int i0 = 0; i0 < N; i0 += BLOCK) {
        bb = block_bounds(ph, i0 / BLOCK); /* bounds from here on, lowered by damping */
        if (i0 > 0 && !ph->undamped)
            state_bounds(ph, qa, va, bb);
        slack_of(ph, bb, ns, &s);
        if (ph->tol >= 0 && s.env < ph->tol && s.env * (1 + MAX_REL) < ph->L) {
            sr->stopped = 1; /* y = 0 + what can still move: below both for good */
            break;
        }
        w->kr->batch_nodes(nm, ns, pw, qa, va, ph->c->p4, ph->yp, H / 2, w->Qb, w->Vb, w->sums);
        int nb = N - i0 < BLOCK ? N - i0 : BLOCK;
        scan_batch(ph, sr, i0, nb, H, ns, &s, qa, va, &prev, &prev_start);
        batch_state(ph, nb - 1, qa, va);
    }
    sr->end_value = sr->stopped ? 0 : dm_norm3(prev.y);
    memcpy(q, qa, sizeof(double) * nm);
    memcpy(v, va, sizeof(double) * nm);
    sr->level = level;
}

/* Refinements use the bounds of the candidate's block (valid from its
 * start on). */
static void use_block(phase *ph, const candidate *cd)
{
    ph->bounds = block_bounds(ph, cd->node / BLOCK);
}

/* The candidate with the largest bound (the first of equals). */
static int largest_bound(const candidate *cs, int ncand)
{
    int top = 0;
    for (int k = 1; k < ncand; k++)
        if (cs[k].bound > cs[top].bound)
            top = k;
    return top;
}

/* Refine the scan's candidates that may exceed the largest value found
 * (ph->L, ph->tL: of this phase or an earlier one). The one with the
 * largest bound goes first, then the others in time order: it usually
 * holds the maximum, which then prunes most of the rest unrefined
 * (chen2018's 32 x 32 map: 983 halvings a pose, now 878; zheng2017 400
 * and 373, han2011 586 and 502; a full sort by bound would save 13 more
 * on chen2018, for an O(n log n) sort of each phase's candidates). */
static void refine_maxima(phase *ph, const scan_result *s)
{
    double H = step_of(ph, s->level);
    const candidate *cs = ph->w->cand[ph->store];
    int top = s->ncand ? largest_bound(cs, s->ncand) : -1;
    for (int k = -1; k < s->ncand; k++) {
        if (k == top) /* done first (k = -1), or no candidate at all */
            continue;
        const candidate *cd = &cs[k < 0 ? top : k];
        if (!(cd->bound > ph->L * (1 + MAX_REL)))
            continue;
        use_block(ph, cd);
        refine_max(ph, s->level, cd->node * H, cd->q, cd->v, &cd->a, &cd->b);
    }
}

/* The last instant after the phase's start at which |y| exceeds its band
 * (0: never; INFINITY: at the end still). */
static double settling(phase *ph, const scan_result *sr)
{
    double H = step_of(ph, sr->level);
    if (!sr->stopped && sr->end_value > ph->tol)
        return INFINITY;
    for (int k = sr->ncand - 1; k >= 0; k--) { /* latest first */
        const candidate *cd = &ph->w->cand[ph->store][k];
        if (cd->node < sr->last_above || !(cd->bound > ph->tol))
            continue;
        use_block(ph, cd);
        double r = latest_above(ph, sr->level, cd->node * H, cd->q, cd->v, &cd->a, &cd->b);
        if (r >= 0)
            return r;
    }
    return sr->last_above < 0 ? 0.0 : sr->last_above * H;
}

/* Start a phase of load a: each mode's free motion is now about its
 * static value under a (q shifts by the change of that value). */
static void start_phase(phase *ph, carried *c, double a_old, double a)
{
    ph->c = c;
    for (int r = 0; r < 3; r++)
        ph->yp[r] = a * c->rP[r];
    for (int j = 0; j < c->nm; j++) {
        double s = c->g[j] / (c->om[j] * c->om[j]);
        c->q[j] += (a_old - a) * s;
        for (int r = 0; r < 3; r++)
            ph->yp[r] += c->p4[4 * j + r] * a * s;
    }
}

/* One direction's move and ring-down: +amax for tau/2, -amax for tau/2,
 * then the window with no load; starting at rest in static equilibrium. */
static void one_move(dm_move_ws *w, carried *c, double alpha, double beta, const dm_move_opts *o,
                     dm_move_result *res)
{
    int damped = 0;
    for (int j = 0; j < c->nm; j++) {
        c->z[j] = dm_rayleigh_zeta(alpha, beta, c->om[j]);
        damped |= c->z[j] > 0;
        double wd = c->om[j] * sqrt(fmax(1 - c->z[j] * c->z[j], 0));
        c->rz[j] = c->z[j] * c->om[j] / wd, c->iwd[j] = 1 / wd;
        c->wwd[j] = c->om[j] * c->om[j] / wd; /* (used only where z < 1) */
        c->q[j] = c->v[j] = 0;
    }
    memset(w->have, 0, sizeof w->have);
    memset(w->slow, -1, sizeof w->slow);
    double A = o->amax_ms2;
    /* the move's halves are both scanned before either is refined, the
     * second (where the peak usually is: the deceleration adds to the
     * ringing) first: the larger maximum found first prunes the other
     * half's candidates without refining them */
    phase first = {w, c, 0, 0.5 * o->tau_s, 0, {0, 0, 0}, -1, 0, 0, NULL, 0, !damped};
    phase second = first;
    scan_result s1, s2;
    start_phase(&first, c, 0, A);
    scan_phase(&first, c->q, c->v, &s1);
    second.t0 = 0.5 * o->tau_s;
    second.store = 1;
    second.L = first.L;
    second.tL = first.tL;
    start_phase(&second, c, A, -A);
    scan_phase(&second, c->q, c->v, &s2);
    refine_maxima(&second, &s2);
    first.L = second.L;
    first.tL = second.tL;
    refine_maxima(&first, &s1);
    res->peak_m = first.L;
    res->peak_t_s = first.tL;
    phase win = {w, c, 1, o->window_s, 0, {0, 0, 0}, damped ? o->tol_m : -1, 0, 0, NULL, 0,
                 !damped};
    scan_result sw;
    start_phase(&win, c, -A, 0);
    scan_phase(&win, c->q, c->v, &sw);
    refine_maxima(&win, &sw);
    res->residual_m = win.L;
    res->residual_t_s = win.tL;
    res->settling_s = damped ? settling(&win, &sw) : INFINITY;
}

/* The moves once the space is set: prepared, then each direction's. */
static int moves_in(dm_move_ws *w, const space *sp, const dm_robot *rb, const dm_pose *pose,
                    int k, const double (*dir)[3], int ndir, const dm_move_opts *o,
                    dm_move_result *res, dm_error *err)
{
    if (k > w->kmax || ndir < 1 || ndir > MAXDIR || sp->n > w->n)
        return dm_fail(err, DM_EINVAL, "standard move: %d modes of %d coordinates, workspace "
                       "holds %d of %d", k, sp->n, w->kmax, w->n);
    int rc = prepare(w, sp, rb, pose, k, dir, ndir, o, err);
    if (rc)
        return rc;
    memset(w->rhave, 0, sizeof w->rhave); /* this pose's modes */
    for (int d = 0; d < ndir; d++)
        sort_by_frequency(&w->dir[d]);
    for (int d = 0; d < ndir; d++)
        one_move(w, &w->dir[d], rb->rayleigh_alpha, rb->rayleigh_beta, o, &res[d]);
    return DM_OK;
}

int dm_standard_moves(dm_move_ws *w, const dm_model *md, const dm_modes *mo, int k,
                      const dm_static *st, const double (*dir)[3], int ndir,
                      const dm_move_opts *o, dm_move_result *res, dm_error *err)
{
    if (k > mo->k)
        return dm_fail(err, DM_EINVAL, "standard move: %d modes of %d", k, mo->k);
    space sp = {md->n, md->platform_dof, mo->phi, mo->mphi, mo->omega_rad_s, md, st, NULL, NULL};
    return moves_in(w, &sp, md->robot, &md->pose, k, dir, ndir, o, res, err);
}

int dm_standard_moves_reduced(dm_move_ws *w, dm_boundary *bw, dm_boundary_eig *eig,
                              const dm_robot *rb, const dm_pose *pose, const double *Y,
                              const double *MY, const double *omega, int k,
                              const double (*dir)[3], int ndir, const dm_move_opts *o,
                              dm_move_result *res, dm_error *err)
{
    space sp = {dm_boundary_reduced_size(bw), dm_boundary_platform_row(bw), Y, MY, omega, NULL, NULL, bw, eig};
    return moves_in(w, &sp, rb, pose, k, dir, ndir, o, res, err);
}

int dm_standard_move(dm_move_ws *w, const dm_model *md, const dm_modes *mo, int k,
                     const dm_static *st, const double dir[3], const dm_move_opts *o,
                     dm_move_result *res, dm_error *err)
{
    const double one[1][3] = {{dir[0], dir[1], dir[2]}};
    return dm_standard_moves(w, md, mo, k, st, one, 1, o, res, err);
}
