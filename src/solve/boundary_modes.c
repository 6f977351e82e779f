/* The boundary problem's modes (dm_boundary.h): the Wittrick-Williams
 * count from the members' exact dynamic stiffness, and the reduced
 * eigenproblem on the member bases. */
#include <assert.h>
#include <cblas.h>
#include <math.h>
#include <string.h>

#include "boundary_impl.h"
#include "dm_modal.h"
#include "dm_static.h"

/* T (nB x nB) += s Cc' X Cc on member m's columns (X: nb x nb). */
static void congruence(const dm_boundary *bw, int m, const double *X, double s, double *T)
{
    int nc = bw->nc[m], nB = bw->nB;
    const int *cols = bw->cols[m];
    double V[12 * 12];
    dm_boundary_congruence(bw, m, X, V);
    for (int b = 0; b < nc; b++)
        for (int a = 0; a < nc; a++)
            T[(size_t)cols[b] * nB + cols[a]] += s * V[a + b * nc];
}

/* M_BB at the pose, made at its first use. */
static const double *pose_mass(dm_boundary *bw)
{
    int nB = bw->nB;
    if (!bw->have_mbb) {
        memcpy(bw->Mbb, bw->ms->Mb, sizeof(double) * nB * nB);
        for (int m = 0; m < DM_MEMBERS_N; m++)
            congruence(bw, m, bw->ms->member[m].Mhat, 1.0, bw->Mbb);
        bw->have_mbb = 1;
    }
    return bw->Mbb;
}

void dm_boundary_mass(dm_boundary *bw, double *T, int ld)
{
    const double *Mbb = pose_mass(bw);
    for (int c = 0; c < bw->nB; c++)
        memcpy(T + (size_t)c * ld, Mbb + (size_t)c * bw->nB, sizeof(double) * bw->nB);
}

/* Sylvester's inertia from D's Bunch-Kaufman factor (the path's kernel:
 * dsytf2's pivoting, the blocks' signs). */
int dm_boundary_negatives(double *D, int n)
{
    return boundary_kernels()->negatives(n, D, n);
}

/* What every count at one pose shares: M_BB (the members' couplings are
 * the pose's, dm_boundary_solve's). */
typedef struct count_pose {
    const double *Mbb; /* nB x nB */
} count_pose;

static void count_prepare(dm_boundary *bw, count_pose *cp)
{
    cp->Mbb = pose_mass(bw);
}

static int count_at(dm_boundary *bw, const count_pose *cp, double sigma, int *count,
                    dm_error *err)
{
    const dm_members *ms = bw->ms;
    const dm_boundary_kernels *kr = boundary_kernels();
    int nB = bw->nB, below = 0;
    double G[81];
    for (size_t k = 0; k < (size_t)nB * nB; k++) /* D(sigma) = S - sigma M_BB - ... */
        bw->D[k] = bw->Sk[k] - sigma * cp->Mbb[k];
    for (int m = 0; m < DM_MEMBERS_N; m++) {
        const dm_member_basis *mb = &ms->member[m];
        int nb = mb->nb, ni = mb->ni;
        double *w = bw->wcount, *Gw = w + ni, *Gt = Gw + (size_t)ni * nb; /* (wcount's room) */
        assert(nb <= 9);
        for (int j = 0; j < ni; j++) {
            double d = mb->lambda[j] - sigma;
            if (d == 0)
                return dm_fail(err, DM_ENUMERIC, "count: the shift is a member's own eigenvalue");
            below += d < 0;
            w[j] = 1 / d;
        }
        /* G = sum_j gam_j gam_j' w_j = Gam' diag(w) Gam (Gam ni x nb): its
         * rows scaled, then one product by the path's kernels (its upper
         * triangle, mirrored); the loops over each entry's weighted dot
         * took 2.5 times as long */
        kr->scale_rows(ni, nb, w, mb->Gam, ni, Gw, ni);
        for (int c = 0; c < nb; c++)
            for (int j = 0; j < ni; j++)
                Gt[c + (size_t)j * nb] = mb->Gam[j + (size_t)c * ni];
        kr->mult_upper(nb, nb, ni, Gt, nb, Gw, ni, G, nb);
        for (int c = 0; c < nb; c++)
            for (int r = c + 1; r < nb; r++)
                G[r + c * nb] = G[c + r * nb];
        congruence(bw, m, G, -sigma * sigma, bw->D);
    }
    int neg = dm_boundary_negatives(bw->D, nB);
    if (neg < 0)
        return dm_fail(err, DM_ENUMERIC, "count: the shift is an eigenvalue of the boundary problem");
    *count = below + neg;
    return DM_OK;
}

int dm_boundary_count(dm_boundary *bw, double sigma, int *count, dm_error *err)
{
    count_pose cp;
    count_prepare(bw, &cp);
    return count_at(bw, &cp, sigma, count, err);
}

/* The reduced pair in (x_B, each member's kept modes q and residual
 * vectors r): K = diag(S, Lambda_keep, kres), M = [M_BB, C' Gam'; ., I]. */
static void reduced_matrices(dm_boundary *bw)
{
    const dm_members *ms = bw->ms;
    int nB = bw->nB, nr = bw->nred, at = nB;
    double *K = bw->Kr, *M = bw->Mr;
    memset(K, 0, sizeof(double) * nr * nr);
    memset(M, 0, sizeof(double) * nr * nr);
    for (int c = 0; c < nB; c++)
        memcpy(K + (size_t)c * nr, bw->Sk + (size_t)c * nB, sizeof(double) * nB);
    dm_boundary_mass(bw, M, nr);
    for (int m = 0; m < DM_MEMBERS_N; m++) {
        const dm_member_basis *mb = &ms->member[m];
        int nb = mb->nb, ni = mb->ni, nv = mb->nkeep + mb->nres;
        for (int j = 0; j < nv; j++, at++) {
            int keep = j < mb->nkeep, a = j - mb->nkeep;
            K[(size_t)at * nr + at] = keep ? mb->lambda[j] : mb->kres[a];
            M[(size_t)at * nr + at] = 1;
            for (int b = 0; b < bw->nc[m]; b++) { /* M_B,j = C' gam_j */
                int c = bw->cols[m][b];
                double v = 0;
                for (int r = 0; r < nb; r++)
                    v += bw->Cc[m][b * nb + r] *
                         (keep ? mb->Gam[(size_t)r * ni + j] : mb->GamR[(size_t)r * mb->nres + a]);
                M[(size_t)at * nr + c] = M[(size_t)c * nr + at] = v;
            }
        }
    }
    assert(at == nr);
}

int dm_boundary_reduced_modes(dm_boundary *bw, int k, double *lambda, dm_error *err)
{
    int nr = bw->nred;
    assert(k <= nr);
    reduced_matrices(bw);
    lapack_int *iwork = bw->iwork;
    if (LAPACKE_dsygvd_work(LAPACK_COL_MAJOR, 1, 'V', 'L', nr, bw->Kr, nr, bw->Mr, nr, bw->wr,
                            bw->work, bw->lwork, iwork, bw->liwork))
        return dm_fail(err, DM_ENUMERIC, "reduced eigenproblem (member bases) failed");
    memcpy(lambda, bw->wr, sizeof(double) * k);
    return DM_OK;
}

/* Bracket the cluster of modes a..b (their values within the first shift
 * of each other): the fewest model eigenvalues below lambda_a (1 - tau)
 * and the most below lambda_b (1 + tau) for the smallest tau that works;
 * every mode of the cluster is then between the two (counts are monotone),
 * and its bound the farther end. */
static int bracket_cluster(dm_boundary *bw, count_pose *cp, const double *lambda, int a, int b,
                           double *bound, dm_error *err)
{
    /* from 1e-9: the counts themselves resolve ~1e-11 of an eigenvalue at
     * mesh 4,4, ~1e-10 at 8,8 and worse with soft springs (wrong counts
     * at 1.2e-10 measured with the 2000 N m/rad actuators at 8,8) */
    for (double tau = 1e-9; tau < 0.5; tau *= sqrt(10.0)) {
        double lo = lambda[a] * (1 - tau), hi = lambda[b] * (1 + tau);
        int below, above, rc = count_at(bw, cp, lo, &below, err);
        if (!rc)
            rc = count_at(bw, cp, hi, &above, err);
        if (rc)
            return rc;
        if (below <= a && above >= b + 1) {
            for (int j = a; j <= b; j++)
                bound[j] = fmax(lambda[j] - lo, hi - lambda[j]);
            return DM_OK;
        }
    }
    return dm_fail(err, DM_ENUMERIC,
                   "member bases: mode %d is not bracketed (a mode missed below it)", a + 1);
}

int dm_boundary_bounds(dm_boundary *bw, int k, const double *lambda, double *bound,
                       dm_error *err)
{
    count_pose cp;
    count_prepare(bw, &cp);
    /* two counts a cluster, not a mode: a degenerate pair's brackets would
     * be the same shifts twice */
    for (int a = 0, b; a < k; a = b + 1) {
        for (b = a; b + 1 < k && lambda[b + 1] * (1 - 1e-9) <= lambda[b] * (1 + 1e-9); b++)
            ;
        int rc = bracket_cluster(bw, &cp, lambda, a, b, bound, err);
        if (rc)
            return rc;
    }
    return DM_OK;
}

/* The model's k-th eigenvalue, from its own solver (cold, certified by
 * its count like every solve of it): the basis rule's scale. */
static int kth_eigenvalue(const dm_model *md, int k, double *lambda_k, dm_error *err)
{
    dm_static *st = dm_static_alloc(md, err);
    dm_modal *mw = st ? dm_modal_alloc(md, k, DM_EIGEN_PARTIAL, err) : NULL;
    const dm_modes *mo;
    int rc = mw ? dm_static_factor(st, md, err) : err ? err->code : DM_ENOMEM;
    if (!rc)
        rc = dm_modal_solve(mw, md, st, k, &mo, err);
    if (!rc)
        *lambda_k = mo->omega_rad_s[k - 1] * mo->omega_rad_s[k - 1];
    dm_modal_free(mw);
    dm_static_free(st);
    return rc;
}

dm_members *dm_boundary_members_for_modes(const dm_model *md, int k, dm_error *err)
{
    double lambda_k;
    assert(k >= 1 && k < md->n);
    if (dm_members_serves(md->robot, err) || kth_eigenvalue(md, k, &lambda_k, err))
        return NULL;
    return dm_members_build(md, DM_BOUNDARY_CUT * lambda_k, err);
}

/* Member m's share of M Z for the k shapes Z (n x k, leading dimension
 * n: (boundary, interiors), its frame) into MZ: its local
 * displacements w = [C Z_B; Z_i], v = M_m w, then C' v_b onto the
 * boundary rows and v_i into its interior's. */
static void member_mass(dm_boundary *bw, int m, int k, const double *Z, double *MZ)
{
    const dm_members *ms = bw->ms;
    const dm_member_basis *mb = &ms->member[m];
    const dm_boundary_kernels *kr = boundary_kernels();
    int nb = mb->nb, ni = mb->ni, nm = mb->nm, n = ms->n, i0 = ms->interior0[m];
    double *w = bw->shM + (size_t)n * bw->nred, *v = w + (size_t)nm * bw->nred;
    for (int j = 0; j < k; j++) {
        const double *z = Z + (size_t)j * n;
        double *wj = w + (size_t)j * nm;
        dm_boundary_member_dofs(bw, m, z, wj);
        memcpy(wj + nb, z + i0, sizeof(double) * ni);
    }
    kr->mult(nm, k, nm, mb->M, nm, w, nm, 0, v, nm);
    for (int j = 0; j < k; j++) {
        const double *vj = v + (size_t)j * nm;
        double *out = MZ + (size_t)j * n;
        dm_boundary_member_add_forces(bw, m, vj, out);
        memcpy(out + i0, vj + nb, sizeof(double) * ni);
    }
}

void dm_boundary_mass_shapes(dm_boundary *bw, int k, double *mphi)
{
    const dm_members *ms = bw->ms;
    int nB = bw->nB, n = ms->n;
    assert(k <= bw->nred);
    double *MZ = bw->shM;
    /* what acts on the boundary alone: M_b Z_B */
    boundary_kernels()->mult(nB, k, nB, ms->Mb, nB, bw->shZ, n, 0, MZ, n);
    for (int m = 0; m < DM_MEMBERS_N; m++)
        member_mass(bw, m, k, bw->shZ, MZ);
    dm_members_scatter_many(ms, &bw->mp, MZ, k, mphi);
}

int dm_boundary_reduced_size(const dm_boundary *bw) { return bw->nred; }

int dm_boundary_platform_row(const dm_boundary *bw) { return bw->ms->bplat; }

void dm_boundary_reduced_pair(dm_boundary *bw, double *K, double *M)
{
    size_t n2 = (size_t)bw->nred * bw->nred;
    reduced_matrices(bw);
    memcpy(K, bw->Kr, sizeof(double) * n2);
    memcpy(M, bw->Mr, sizeof(double) * n2);
}

/* Member m's coefficients of the k modes in bw->shW (ncoef x k): its
 * boundary displacements C y_B, then its kept modes' and residual
 * vectors' coordinates (from reduced row q0). */
static void member_coefficients(dm_boundary *bw, int m, int k, int q0)
{
    const dm_member_basis *mb = &bw->ms->member[m];
    int nb = mb->nb, nq = mb->nkeep + mb->nres, nc = nb + nq, nr = bw->nred;
    for (int j = 0; j < k; j++) {
        const double *y = bw->Kr + (size_t)j * nr;
        double *w = bw->shW + (size_t)j * nc;
        dm_boundary_member_dofs(bw, m, y, w);
        memcpy(w + nb, y + q0, sizeof(double) * nq);
    }
}

void dm_boundary_mode_shapes(dm_boundary *bw, int k, double *phi)
{
    const dm_members *ms = bw->ms;
    int nB = bw->nB, nr = bw->nred, n = ms->n, q0 = nB;
    assert(k <= nr);
    for (int j = 0; j < k; j++)
        memcpy(bw->shZ + (size_t)j * n, bw->Kr + (size_t)j * nr, sizeof(double) * nB);
    for (int m = 0; m < DM_MEMBERS_N; m++) {
        const dm_member_basis *mb = &ms->member[m];
        int nb = mb->nb, ni = mb->ni, nc = nb + mb->nkeep + mb->nres;
        member_coefficients(bw, m, k, q0);
        /* interior' (k x ni) = W' [Psi Phi_keep R]': all k modes in three
         * products, transposed both ways (OpenBLAS 0.3.21's NoTrans x
         * NoTrans small kernels allocate: boundary_eig.c, apply_M) */
        const double *W = bw->shW;
        cblas_dgemm(CblasColMajor, CblasTrans, CblasTrans, k, ni, nb, 1, W, nc, mb->Psi, ni, 0,
                    bw->shZt, k);
        if (mb->nkeep)
            cblas_dgemm(CblasColMajor, CblasTrans, CblasTrans, k, ni, mb->nkeep, 1, W + nb, nc,
                        mb->Phi, ni, 1, bw->shZt, k);
        if (mb->nres)
            cblas_dgemm(CblasColMajor, CblasTrans, CblasTrans, k, ni, mb->nres, 1,
                        W + nb + mb->nkeep, nc, mb->R, ni, 1, bw->shZt, k);
        for (int j = 0; j < k; j++) {
            double *zi = bw->shZ + (size_t)j * n + ms->interior0[m];
            for (int r = 0; r < ni; r++)
                zi[r] = bw->shZt[(size_t)r * k + j];
        }
        q0 += mb->nkeep + mb->nres;
    }
    dm_members_scatter_many(ms, &bw->mp, bw->shZ, k, phi);
}
