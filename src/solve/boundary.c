/* The statics of a pose from the member bases (dm_boundary.h). */
#include "dm_boundary.h"
#include "boundary_impl.h"

#include <assert.h>
#include <lapacke.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

dm_boundary *dm_boundary_alloc(const dm_members *ms, dm_error *err)
{
    dm_boundary *bw = calloc(1, sizeof *bw);
    int fail = !bw;
    if (bw) {
        size_t nB = (size_t)ms->nbound, nr;
        bw->ms = ms;
        bw->nB = ms->nbound;
        bw->nred = dm_members_reduced_size(ms);
        nr = (size_t)bw->nred;
        size_t nimax = 1, ncmax = 1, nmmax = 1;
        for (int m = 0; m < DM_MEMBERS_N; m++) {
            const dm_member_basis *mb = &ms->member[m];
            size_t nc = (size_t)(mb->nb + mb->nkeep + mb->nres);
            nimax = (size_t)mb->ni > nimax ? (size_t)mb->ni : nimax;
            nmmax = (size_t)mb->nm > nmmax ? (size_t)mb->nm : nmmax;
            ncmax = nc > ncmax ? nc : ncmax;
        }
        bw->lwork = 1 + 6 * bw->nred + 2 * bw->nred * bw->nred;
        bw->liwork = 3 + 5 * bw->nred;
        double **arrays[] = {&bw->S,  &bw->Sk,  &bw->D,   &bw->F,    &bw->X6,
                             &bw->Mbb, &bw->z,   &bw->Kr,  &bw->Mr,   &bw->wr,
                             &bw->work, &bw->wcount, &bw->shW, &bw->shZt, &bw->shZ,
                             &bw->shM};
        size_t sizes[] = {nB * nB, nB * nB, nB * nB, nB, nB * 6, nB * nB,
                          (size_t)ms->n, nr * nr, nr * nr, nr, (size_t)bw->lwork,
                          nimax * (1 + 2 * 9),
                          ncmax * nr, nr * nimax, (size_t)ms->n * nr,
                          ((size_t)ms->n + 2 * nmmax) * nr};
        for (size_t k = 0; k < sizeof sizes / sizeof *sizes; k++)
            fail |= !(*arrays[k] = malloc(sizeof(double) * sizes[k]));
        bw->iwork = malloc(sizeof(lapack_int) * (size_t)bw->liwork);
        fail |= !bw->iwork;
    }
    if (fail) {
        dm_boundary_free(bw);
        dm_fail(err, DM_ENOMEM, "out of memory for the boundary workspace");
        return NULL;
    }
    return bw;
}

void dm_boundary_free(dm_boundary *bw)
{
    if (!bw)
        return;
    double *arrays[] = {bw->S,    bw->Sk,  bw->D,      bw->F,   bw->X6,   bw->Mbb,
                        bw->z,    bw->Kr,  bw->Mr,     bw->wr,  bw->work,
                        bw->wcount, bw->shW, bw->shZt, bw->shZ, bw->shM};
    for (size_t k = 0; k < sizeof arrays / sizeof *arrays; k++)
        free(arrays[k]);
    free(bw->iwork);
    free(bw);
}

/* Each member's coupling at the pose, on the columns it reaches. */
static void pose_couplings(dm_boundary *bw)
{
    double C[9 * DM_MEMBERS_MAX_BOUND];
    for (int m = 0; m < DM_MEMBERS_N; m++) {
        int nb = bw->ms->member[m].nb, nc = dm_members_columns(bw->ms, m, bw->cols[m]);
        dm_members_coupling(bw->ms, &bw->mp, m, C);
        for (int a = 0; a < nc; a++) {
            memcpy(bw->Cc[m] + a * nb, C + (size_t)bw->cols[m][a] * nb, sizeof(double) * nb);
            for (int r = 0; r < nb; r++)
                bw->Cct[m][a + r * nc] = bw->Cc[m][a * nb + r];
        }
        bw->nc[m] = nc;
    }
    bw->have_mbb = 0;
}

void dm_boundary_congruence(const dm_boundary *bw, int m, const double *X, double *V)
{
    const dm_boundary_kernels *kr = boundary_kernels();
    int nb = bw->ms->member[m].nb, nc = bw->nc[m];
    double XC[9 * 12];
    assert(nb <= 9 && nc <= 12);
    kr->mult(nb, nc, nb, X, nb, bw->Cc[m], nb, 0, XC, nb);     /* X Cc */
    kr->mult(nc, nc, nb, bw->Cct[m], nc, XC, nb, 0, V, nc); /* Cc' (X Cc) */
}

/* S += Cc' Khat Cc and F += Cc' Ghat (lambda g) for member m. */
static void add_member(dm_boundary *bw, int m)
{
    const dm_member_basis *mb = &bw->ms->member[m];
    const double *L = bw->mp.lambda[m], *g = bw->mp.gravity;
    const int *cols = bw->cols[m];
    int nb = mb->nb, nB = bw->nB, nc = bw->nc[m];
    double f[9];
    for (int r = 0; r < 3; r++)
        bw->gl[m][r] = L[3 * r] * g[0] + L[3 * r + 1] * g[1] + L[3 * r + 2] * g[2];
    for (int r = 0; r < nb; r++) {
        f[r] = 0;
        for (int k = 0; k < 3; k++)
            f[r] += mb->Ghat[k * nb + r] * bw->gl[m][k];
    }
    double V[12 * 12];
    dm_boundary_congruence(bw, m, mb->Khat, V);
    dm_boundary_member_add_forces(bw, m, f, bw->F);
    for (int b = 0; b < nc; b++) {
        for (int a = b; a < nc; a++) { /* into S's lower triangle */
            double v = V[a + b * nc];
            int hi = cols[a] > cols[b] ? cols[a] : cols[b], lo = cols[a] + cols[b] - hi;
            bw->S[(size_t)lo * nB + hi] += v;
        }
    }
}

int dm_boundary_solve(dm_boundary *bw, const dm_pose *pose, dm_boundary_statics *res,
                      dm_error *err)
{
    const dm_members *ms = bw->ms;
    int nB = bw->nB, p = ms->bplat, rc = dm_members_at(ms, pose, &bw->mp, err);
    if (rc)
        return rc;
    pose_couplings(bw);
    memcpy(bw->S, ms->Kb, sizeof(double) * nB * nB);
    memcpy(bw->F, ms->Fb, sizeof(double) * nB);
    res->logdet_K = 0;
    for (int m = 0; m < DM_MEMBERS_N; m++) {
        add_member(bw, m);
        res->logdet_K += ms->member[m].logdet_ii;
    }
    for (int c = 0; c < nB; c++) /* S whole, for the modes */
        for (int r = c; r < nB; r++)
            bw->Sk[(size_t)c * nB + r] = bw->Sk[(size_t)r * nB + c] = bw->S[(size_t)c * nB + r];
    const dm_boundary_kernels *kr = boundary_kernels();
    memcpy(bw->S, bw->Sk, sizeof(double) * nB * nB);
    if (kr->cholesky_upper(nB, bw->S, nB))
        return dm_fail(err, DM_ENUMERIC,
                       "boundary problem (member bases) is not positive definite at this pose");
    for (int k = 0; k < nB; k++)
        res->logdet_K += 2 * log(bw->S[(size_t)k * nB + k]);
    memset(bw->X6, 0, sizeof(double) * nB * 6);
    for (int j = 0; j < 6; j++)
        bw->X6[(size_t)j * nB + p + j] = 1.0;
    kr->cholesky_solve(nB, bw->S, nB, bw->F, nB, 1);
    kr->cholesky_solve(nB, bw->S, nB, bw->X6, nB, 6);
    for (int j = 0; j < 6; j++) {
        res->static_error[j] = bw->F[p + j];
        for (int r = 0; r < 6; r++) /* symmetric to the last bit, as S^-1 is */
            res->compliance[6 * j + r] =
                r >= j ? bw->X6[(size_t)j * nB + p + r] : bw->X6[(size_t)r * nB + p + j];
    }
    res->full = 0;
    return DM_OK;
}

/* Member m's boundary displacements x_b = C y from the boundary vector y. */
void dm_boundary_member_dofs(dm_boundary *bw, int m, const double *y, double *xb)
{
    int nb = bw->ms->member[m].nb;
    for (int r = 0; r < nb; r++) {
        xb[r] = 0;
        for (int a = 0; a < bw->nc[m]; a++)
            xb[r] += bw->Cc[m][a * nb + r] * y[bw->cols[m][a]];
    }
}

void dm_boundary_member_add_forces(const dm_boundary *bw, int m, const double *f, double *F)
{
    int nb = bw->ms->member[m].nb;
    for (int a = 0; a < bw->nc[m]; a++) {
        double s = 0;
        for (int r = 0; r < nb; r++)
            s += bw->Cc[m][a * nb + r] * f[r];
        F[bw->cols[m][a]] += s;
    }
}

void dm_boundary_displacement(dm_boundary *bw, double *U)
{
    const dm_members *ms = bw->ms;
    memcpy(bw->z, bw->F, sizeof(double) * bw->nB);
    for (int m = 0; m < DM_MEMBERS_N; m++) {
        const dm_member_basis *mb = &ms->member[m];
        double xb[9];
        dm_boundary_member_dofs(bw, m, bw->F, xb);
        double *zi = bw->z + ms->interior0[m];
        for (int r = 0; r < mb->ni; r++) { /* u_i = Ui (lambda g) + Psi C x_B */
            double s = 0;
            for (int k = 0; k < 3; k++)
                s += mb->Ui[(size_t)k * mb->ni + r] * bw->gl[m][k];
            for (int k = 0; k < mb->nb; k++)
                s += mb->Psi[(size_t)k * mb->ni + r] * xb[k];
            zi[r] = s;
        }
    }
    dm_members_scatter(ms, &bw->mp, bw->z, U);
}

int dm_boundary_statics_or_full(dm_boundary *bw, dm_model *md, dm_static *st,
                                const dm_pose *pose, dm_boundary_statics *res, dm_error *err)
{
    dm_error ignored;
    int rc = bw ? dm_boundary_solve(bw, pose, res, &ignored) : DM_EINVAL;
    if (rc != DM_EINVAL) /* served, or a singular pose either way */
        return rc ? dm_fail(err, rc, "%s", ignored.msg) : DM_OK;
    res->full = 1;
    rc = dm_model_build(md, pose, err);
    if (!rc)
        rc = dm_static_factor(st, md, err);
    if (!rc)
        rc = dm_static_platform_error(st, md, md->F_gravity, res->static_error, err);
    if (!rc)
        rc = dm_static_compliance(st, md, res->compliance, err);
    if (!rc)
        res->logdet_K = dm_static_logdet(st);
    return rc;
}

/* Rigid motions whose loads are made side by side (the products' columns) */
enum { INERTIAL_BATCH = 4 };

/* Member m's accelerations in its frame for one rigid motion, as the
 * coefficients c of its unit loads (dm_member_basis.G: uniform, growing
 * along it, rotational; dm_loads' affine field along a link), negated:
 * their inertia is -G c. */
static void member_coefficients(const dm_boundary *bw, int m, const dm_link_motion *lm,
                                double c[DM_MEMBERS_LOADS])
{
    const dm_member_basis *mb = &bw->ms->member[m];
    const double *L = bw->mp.lambda[m];
    int i = mb->chain, arm = mb->kind == DM_MEMBER_ARM;
    double glob[3][3];
    for (int k = 0; k < 3; k++) { /* uniform, growing, rotational (global axes) */
        glob[0][k] = arm ? 0 : lm->aB[i][k];
        glob[1][k] = arm ? lm->aB[i][k] : lm->aP[k] - lm->aB[i][k];
        glob[2][k] = arm ? lm->arm_alpha[i][k] : lm->rod_alpha[i][k];
    }
    for (int part = 0; part < 3; part++) /* into the member's frame, negated: -M a */
        for (int r = 0; r < 3; r++)
            c[3 * part + r] = -(L[3 * r] * glob[part][0] + L[3 * r + 1] * glob[part][1] +
                                L[3 * r + 2] * glob[part][2]);
}

/* Member m's share of T' G for the q load cases whose coefficients of
 * its unit loads are c (DM_MEMBERS_LOADS each) into G (columns nred
 * apart, the member's coordinates from row q0): G c condensed onto the
 * boundary (C' Ghat c) and projected on its kept modes and residual
 * vectors (Gq c). The products by Ghat and Gq go through the path's
 * kernels, each entry's sum over the load cases in order. */
static void member_loads(dm_boundary *bw, int m, const double *c, int q, int q0, double *G)
{
    const dm_member_basis *mb = &bw->ms->member[m];
    const dm_boundary_kernels *kr = boundary_kernels();
    int nb = mb->nb, nq = mb->nkeep + mb->nres, nr = bw->nred;
    double F[9 * INERTIAL_BATCH];
    assert(q <= INERTIAL_BATCH && nb <= 9);
    kr->mult(nb, q, DM_MEMBERS_LOADS, mb->Ghat, nb, c, DM_MEMBERS_LOADS, 0, F, nb);
    for (int l = 0; l < q; l++) {
        double *g = G + (size_t)l * nr;
        const double *f = F + l * nb;
        for (int a = 0; a < bw->nc[m]; a++)
            for (int r = 0; r < nb; r++)
                g[bw->cols[m][a]] += bw->Cc[m][a * nb + r] * f[r];
    }
    kr->mult(nq, q, DM_MEMBERS_LOADS, mb->Gq, nq, c, DM_MEMBERS_LOADS, 0, G + q0, nr);
}

/* Member m's share of T' G for q rigid motions: its accelerations as
 * coefficients of its unit loads, negated (member_coefficients). */
static void member_inertial_loads(dm_boundary *bw, int m, const dm_link_motion *lm, int q, int q0,
                                  double *G)
{
    double C[DM_MEMBERS_LOADS * INERTIAL_BATCH];
    assert(q <= INERTIAL_BATCH);
    for (int l = 0; l < q; l++)
        member_coefficients(bw, m, &lm[l], C + l * DM_MEMBERS_LOADS);
    member_loads(bw, m, C, q, q0, G);
}

/* The loads of q <= INERTIAL_BATCH rigid motions: the boundary's own
 * share -M_b a_B (one product for all of them), then each member's. */
static void inertial_batch(dm_boundary *bw, const dm_pose *pose, const dm_rigid_motion *motion,
                           int q, double *G)
{
    const dm_members *ms = bw->ms;
    int nB = bw->nB, nr = bw->nred;
    dm_link_motion lm[INERTIAL_BATCH];
    double aB[DM_MEMBERS_MAX_BOUND * INERTIAL_BATCH] = {0}, T[DM_MEMBERS_MAX_BOUND * INERTIAL_BATCH];
    for (int l = 0; l < q; l++) {
        const dm_rigid_motion *mo = &motion[l];
        double *a = aB + (size_t)l * nB;
        dm_kin_link_accelerations(pose, mo->alpha_dot, mo->alpha_ddot, mo->aP, &lm[l]);
        for (int i = 0; i < 3; i++) /* the boundary's rigid accelerations */
            for (int k = 0; k < 3; k++) {
                a[ms->belbow[i] + k] = lm[l].aB[i][k];
                a[ms->belbow[i] + 3 + k] = lm[l].arm_alpha[i][k];
            }
        for (int k = 0; k < 3; k++)
            a[ms->bplat + k] = mo->aP[k];
    }
    boundary_kernels()->mult(nB, q, nB, ms->Mb, nB, aB, nB, 0, T, nB);
    for (int l = 0; l < q; l++) /* what acts on the boundary alone: -M_b a_B */
        for (int r = 0; r < nB; r++)
            G[(size_t)l * nr + r] = -T[(size_t)l * nB + r];
    for (int m = 0, q0 = nB; m < DM_MEMBERS_N; m++) {
        member_inertial_loads(bw, m, lm, q, q0, G);
        q0 += ms->member[m].nkeep + ms->member[m].nres;
    }
}

void dm_boundary_gravity_loads(dm_boundary *bw, double *G)
{
    const dm_members *ms = bw->ms;
    memcpy(G, ms->Fb, sizeof(double) * bw->nB); /* the boundary's own weight */
    for (int m = 0, q0 = bw->nB; m < DM_MEMBERS_N; m++) {
        double c[DM_MEMBERS_LOADS] = {0}; /* uniform: gravity in the member's frame */
        memcpy(c, bw->gl[m], sizeof bw->gl[m]);
        member_loads(bw, m, c, 1, q0, G);
        q0 += ms->member[m].nkeep + ms->member[m].nres;
    }
}

void dm_boundary_inertial_loads(dm_boundary *bw, const dm_pose *pose,
                                const dm_rigid_motion *motion, int q, double *G)
{
    for (int l = 0; l < q; l += INERTIAL_BATCH)
        inertial_batch(bw, pose, motion + l, q - l < INERTIAL_BATCH ? q - l : INERTIAL_BATCH,
                       G + (size_t)l * bw->nred);
}
