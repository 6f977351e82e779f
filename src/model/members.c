/* The model's members in their own frames, once per robot (dm_members.h). */
#include "dm_members.h"

#include <assert.h>
#include <lapacke.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "dm_vec3.h"

/* ---- layout: which member DOF each node DOF is -------------------------- */

/* A member's nodes and, per node and local DOF (u, v, w, tx, ty, tz), the
 * member DOF it is (-1: held at zero). Boundary DOFs first. */
typedef struct {
    int nodes;
    int *dof;          /* nodes x 6 */
    int spring_node[2], spring_bound[2]; /* joint springs: node, first boundary DOF (-1: none) */
} member_map;

static const dm_element *first_element(const dm_model *md, int m)
{
    int i = m / 3, r = m % 3;
    return md->elem + i * (md->na + 2 * md->nb) + (r == 0 ? 0 : md->na + (r - 1) * md->nb);
}

static void add_run(dm_member_basis *mb, int interior, int model_dof, int count, int rotate)
{
    mb->run[mb->nrun++] = (dm_members_run){interior, model_dof, count, rotate};
}

/* Arm: boundary = tip (6) + root translations on a compliant base (3);
 * interior = the actuator rotation (about t_i, the arm's local y) and
 * nodes 1..na-1. */
static void arm_map(const dm_model *md, int m, dm_member_basis *mb, member_map *mm)
{
    const dm_element *e = first_element(md, m);
    const dm_nodemap *root = &e[0].node[0];
    int base = dm_effects_base_compliant(&md->robot->effects, mb->chain);
    int act = md->robot->effects.actuator_stiffness_nm_per_rad > 0, in = 0;
    mb->nb = 6 + 3 * base;
    for (int k = 0; k < 6; k++)
        mm->dof[6 * md->na + k] = k;
    for (int k = 0; k < 3 && base; k++)
        mm->dof[k] = 6 + k;
    if (act) {
        mm->dof[4] = mb->nb + in;
        add_run(mb, in++, root->idx[root->m - 1], 1, 0);
    }
    for (int nd = 1; nd < md->na; nd++) {
        for (int k = 0; k < 6; k++)
            mm->dof[6 * nd + k] = mb->nb + in + k;
        add_run(mb, in, e[nd].node[0].idx[0], 6, 1);
        in += 6;
    }
    mb->ni = in;
}

/* One rod end (node nd, map nm): its two own rotations (local y, z) and,
 * with joint springs, its own translations tied to the short-bar point. */
static int rod_end_map(dm_member_basis *mb, member_map *mm, int nd, const dm_nodemap *nm, int bound,
                       int in, int end)
{
    int joint = nm->m == 5, rot = joint ? nm->idx[3] : nm->idx[6];
    mm->dof[6 * nd + 4] = mb->nb + in;
    mm->dof[6 * nd + 5] = mb->nb + in + 1;
    add_run(mb, in, rot, 2, 0);
    in += 2;
    for (int k = 0; k < 3; k++)
        mm->dof[6 * nd + k] = joint ? mb->nb + in + k : bound + k;
    if (joint) {
        add_run(mb, in, nm->idx[0], 3, 1);
        mm->spring_node[end] = nd;
        mm->spring_bound[end] = bound;
        in += 3;
    }
    return in;
}

/* Rod: boundary = the short-bar points at the elbow (3) and at the
 * platform (3); interior = its ends' own DOFs and nodes 1..nb-1. */
static void rod_map(const dm_model *md, int m, dm_member_basis *mb, member_map *mm)
{
    const dm_element *e = first_element(md, m);
    int nb = md->nb, in = 0;
    mb->nb = 6;
    in = rod_end_map(mb, mm, 0, &e[0].node[0], 0, in, 0);
    for (int nd = 1; nd < nb; nd++) {
        for (int k = 0; k < 6; k++)
            mm->dof[6 * nd + k] = mb->nb + in + k;
        add_run(mb, in, e[nd].node[0].idx[0], 6, 1);
        in += 6;
    }
    in = rod_end_map(mb, mm, nb, &e[nb - 1].node[1], 3, in, 1);
    mb->ni = in;
}

/* ---- member matrices ------------------------------------------------------ */

static double *new_array(size_t n, int *fail)
{
    double *p = calloc(n ? n : 1, sizeof *p);
    *fail |= !p;
    return p;
}

/* K, M and G from the elements (local frame, one length for all) and the
 * joint springs. */
static void assemble(const dm_model *md, dm_member_basis *mb, const member_map *mm)
{
    const dm_beam_props *p = &md->props[mb->kind];
    double Ke[144], Me[144];
    dm_beam_stiffness(p, mb->element_m, Ke);
    dm_beam_mass(p, mb->element_m, Me);
    int nm = mb->nm;
    for (int el = 0; el < mb->nel; el++)
        for (int a = 0; a < 12; a++) {
            int ra = mm->dof[6 * el + a];
            if (ra < 0)
                continue;
            for (int b = 0; b < 12; b++) {
                int cb = mm->dof[6 * el + b], c = b % 6;
                /* the node's fraction of the member's length: the
                 * accelerations of dm_loads are affine along a link */
                double s = (double)(el + b / 6) / mb->nel;
                if (c < 3) { /* unit acceleration along local c, uniform and growing */
                    mb->G[c * nm + ra] += Me[12 * a + b];
                    mb->G[(3 + c) * nm + ra] += s * Me[12 * a + b];
                } else { /* unit angular acceleration about local c - 3 */
                    mb->G[(3 + c) * nm + ra] += Me[12 * a + b];
                }
                if (cb < 0)
                    continue;
                mb->K[(size_t)cb * nm + ra] += Ke[12 * a + b];
                mb->M[(size_t)cb * nm + ra] += Me[12 * a + b];
            }
        }
    double kj = md->robot->effects.joint_stiffness_n_per_m;
    for (int end = 0; end < 2; end++)
        for (int k = 0; k < 3 && mm->spring_bound[end] >= 0; k++) {
            int u = mm->dof[6 * mm->spring_node[end] + k], b = mm->spring_bound[end] + k;
            mb->K[(size_t)u * nm + u] += kj;
            mb->K[(size_t)b * nm + b] += kj;
            mb->K[(size_t)u * nm + b] -= kj;
            mb->K[(size_t)b * nm + u] -= kj;
        }
    if (mb->kind == DM_MEMBER_ARM && md->robot->effects.actuator_stiffness_nm_per_rad > 0) {
        int a = mm->dof[4];
        mb->K[(size_t)a * nm + a] += md->robot->effects.actuator_stiffness_nm_per_rad;
    }
}

/* The ni x nc block of X (nm x nm) from row r0, column c0. */
static void block(const dm_member_basis *mb, const double *X, int r0, int nr, int c0, int nc, double *B)
{
    for (int c = 0; c < nc; c++)
        for (int r = 0; r < nr; r++)
            B[(size_t)c * nr + r] = X[(size_t)(c0 + c) * mb->nm + r0 + r];
}

/* Clamp the member at its boundary: factor K_ii, ln det K_ii, the
 * constraint modes Psi = -K_ii^-1 K_ib, the condensed Khat and Ghat, and
 * Ui = K_ii^-1 G_i. */
static int condense(dm_member_basis *mb)
{
    int nb = mb->nb, ni = mb->ni, nm = mb->nm;
    block(mb, mb->K, nb, ni, nb, ni, mb->Lii);
    block(mb, mb->K, nb, ni, 0, nb, mb->Psi);
    for (int c = 0; c < 3; c++)
        memcpy(mb->Ui + (size_t)c * ni, mb->G + (size_t)c * nm + nb, ni * sizeof(double));
    if (ni > 0) {
        if (LAPACKE_dpotrf(LAPACK_COL_MAJOR, 'L', ni, mb->Lii, ni))
            return DM_ENUMERIC;
        if (LAPACKE_dpotrs(LAPACK_COL_MAJOR, 'L', ni, nb, mb->Lii, ni, mb->Psi, ni) ||
            LAPACKE_dpotrs(LAPACK_COL_MAJOR, 'L', ni, 3, mb->Lii, ni, mb->Ui, ni))
            return DM_ENUMERIC;
    }
    mb->logdet_ii = 0;
    for (int k = 0; k < ni; k++)
        mb->logdet_ii += 2 * log(mb->Lii[(size_t)k * ni + k]);
    for (size_t k = 0; k < (size_t)ni * nb; k++)
        mb->Psi[k] = -mb->Psi[k];
    for (int c = 0; c < nb; c++) /* Khat = K_bb + K_bi Psi, Ghat = G_b + Psi' G_i */
        for (int r = 0; r < nb; r++) {
            double s = mb->K[(size_t)c * nm + r];
            for (int k = 0; k < ni; k++)
                s += mb->K[(size_t)(nb + k) * nm + r] * mb->Psi[(size_t)c * ni + k];
            mb->Khat[(size_t)c * nb + r] = s;
        }
    for (int c = 0; c < nb; c++) /* symmetric to the last bit */
        for (int r = c + 1; r < nb; r++)
            mb->Khat[(size_t)c * nb + r] = mb->Khat[(size_t)r * nb + c];
    for (int a = 0; a < DM_MEMBERS_LOADS; a++)
        for (int r = 0; r < nb; r++) {
            double s = mb->G[(size_t)a * nm + r];
            for (int k = 0; k < ni; k++)
                s += mb->Psi[(size_t)r * ni + k] * mb->G[(size_t)a * nm + nb + k];
            mb->Ghat[(size_t)a * nb + r] = s;
        }
    return DM_OK;
}

/* R = Phi_d U_r: the left singular vectors of c = Lambda_d^-1 Phi_d' F
 * (dropped modes d; F's nl load columns) with sigma > 1e-12 sigma_max, so
 * R is M_ii-orthonormal and M_ii-orthogonal to the kept modes by
 * construction; then turned within their span to be K_ii-orthogonal too
 * (kres = R' K_ii R, diagonal, ascending). */
static int residual_vectors(dm_member_basis *mb, const double *F, int nl, double *c, double *sv,
                            double *U)
{
    int ni = mb->ni, k0 = mb->nkeep, nd = ni - k0;
    mb->nres = 0;
    if (nd == 0)
        return DM_OK;
    for (int j = 0; j < nl; j++)
        for (int d = 0; d < nd; d++) {
            const double *phi = mb->Phi + (size_t)(k0 + d) * ni;
            double s = 0;
            for (int r = 0; r < ni; r++)
                s += phi[r] * F[(size_t)j * ni + r];
            c[(size_t)j * nd + d] = s / mb->lambda[k0 + d];
        }
    int mn = nd < nl ? nd : nl;
    if (LAPACKE_dgesvd(LAPACK_COL_MAJOR, 'S', 'N', nd, nl, c, nd, sv, U, nd, NULL, 1, sv + mn))
        return DM_ENUMERIC;
    while (mb->nres < mn && sv[mb->nres] > 1e-12 * sv[0])
        mb->nres++;
    /* turned K_ii-orthogonal: U <- U W, W the eigenvectors of U' Lambda_d U
     * (R' K_ii R), so the reduced K is diagonal inside every member */
    int nr = mb->nres;
    double *W = c; /* c is spent */
    for (int a = 0; a < nr; a++)
        for (int b = 0; b < nr; b++) {
            double s = 0;
            for (int d = 0; d < nd; d++)
                s += U[(size_t)a * nd + d] * mb->lambda[k0 + d] * U[(size_t)b * nd + d];
            W[(size_t)b * nr + a] = s;
        }
    if (nr && LAPACKE_dsyev(LAPACK_COL_MAJOR, 'V', 'L', nr, W, nr, mb->kres))
        return DM_ENUMERIC;
    for (int j = 0; j < nr; j++)
        if (!(mb->kres[j] > 0))
            return DM_ENUMERIC;
    for (int d = 0; d < nd; d++) { /* U <- U W, row by row */
        double t[DM_MEMBERS_MAX_BOUND + 1];
        for (int j = 0; j < nr; j++) {
            t[j] = 0;
            for (int a = 0; a < nr; a++)
                t[j] += U[(size_t)a * nd + d] * W[(size_t)j * nr + a];
        }
        for (int j = 0; j < nr; j++)
            U[(size_t)j * nd + d] = t[j];
    }
    for (int j = 0; j < nr; j++) /* R = Phi_d U */
        for (int r = 0; r < ni; r++) {
            double s = 0;
            for (int d = 0; d < nd; d++)
                s += mb->Phi[(size_t)(k0 + d) * ni + r] * U[(size_t)j * nd + d];
            mb->R[(size_t)j * ni + r] = s;
        }
    return DM_OK;
}

/* Fixed-interface modes (all of them) and the rule's basis: the modes
 * with lambda <= cut, and the residual vectors R = Phi_d c, c = Lambda_d^-1
 * Phi_d' F, F = M_ib + M_ii Psi the inertia loads of unit boundary
 * accelerations on the clamped member, Phi_d the dropped modes: the static
 * part of the dropped modes' response, orthonormalised through the SVD of
 * c (columns with sigma <= 1e-12 sigma_max dropped). */
/* The inertia the boundary sees through the clamped member: Mhat =
 * [I; Psi]' M [I; Psi] = M_bb + M_bi Psi + Psi' F, the coupling to every
 * fixed-interface mode Gam = Phi' F, and to the residual vectors
 * GamR = R' F. */
static void inertia_terms(dm_member_basis *mb, const double *F)
{
    int nb = mb->nb, ni = mb->ni, nm = mb->nm, nr = mb->nres;
    for (int c = 0; c < nb; c++)
        for (int r = 0; r < nb; r++) {
            double s = mb->M[(size_t)c * nm + r];
            for (int k = 0; k < ni; k++)
                s += mb->M[(size_t)(nb + k) * nm + r] * mb->Psi[(size_t)c * ni + k] +
                     mb->Psi[(size_t)r * ni + k] * F[(size_t)c * ni + k];
            mb->Mhat[(size_t)c * nb + r] = s;
        }
    for (int c = 0; c < nb; c++) /* symmetric to the last bit */
        for (int r = c + 1; r < nb; r++)
            mb->Mhat[(size_t)c * nb + r] = mb->Mhat[(size_t)r * nb + c];
    for (int c = 0; c < nb; c++)
        for (int j = 0; j < ni + nr; j++) {
            const double *v = j < ni ? mb->Phi + (size_t)j * ni : mb->R + (size_t)(j - ni) * ni;
            double s = 0;
            for (int r = 0; r < ni; r++)
                s += v[r] * F[(size_t)c * ni + r];
            if (j < ni)
                mb->Gam[(size_t)c * ni + j] = s;
            else
                mb->GamR[(size_t)c * nr + j - ni] = s;
        }
}

static int fixed_interface_basis(dm_member_basis *mb, double cut)
{
    int nb = mb->nb, ni = mb->ni, nm = mb->nm, rc = DM_OK;
    if (ni == 0) {
        inertia_terms(mb, NULL);
        return DM_OK;
    }
    int arm = mb->kind == DM_MEMBER_ARM, nl = nb + arm;
    double *B = malloc(sizeof(double) * ni * ni), *F = malloc(sizeof(double) * ni * nl);
    double *c = malloc(sizeof(double) * ni * nl), *sv = malloc(sizeof(double) * 2 * (nl + ni));
    double *U = malloc(sizeof(double) * ni * nl);
    if (!B || !F || !c || !sv || !U)
        rc = DM_ENOMEM;
    if (!rc) {
        block(mb, mb->K, nb, ni, nb, ni, mb->Phi);
        block(mb, mb->M, nb, ni, nb, ni, B);
        if (LAPACKE_dsygvd(LAPACK_COL_MAJOR, 1, 'V', 'L', ni, mb->Phi, ni, B, ni, mb->lambda))
            rc = DM_ENUMERIC;
    }
    if (!rc) {
        block(mb, mb->M, nb, ni, 0, nb, F);
        for (int j = 0; j < nb; j++) /* F = M_ib + M_ii Psi */
            for (int k = 0; k < ni; k++) {
                double p = mb->Psi[(size_t)j * ni + k];
                for (int r = 0; r < ni && p != 0; r++)
                    F[(size_t)j * ni + r] += mb->M[(size_t)(nb + k) * nm + nb + r] * p;
            }
        /* an arm's own rotation about its actuator axis (local y) through
         * its root, the nominal motion's load on it (dm_loads: -M a, a
         * growing along -z to -L at the tip, rotations about y): not an
         * inertia load of its boundary's accelerations when the root is
         * held, so its static response joins the residual vectors'
         * loads (then K^-1 G is exact in the bases; dm_standard_moves_
         * reduced) */
        for (int r = 0; arm && r < ni; r++)
            F[(size_t)nb * ni + r] = -mb->nel * mb->element_m * mb->G[(size_t)5 * nm + nb + r] +
                                     mb->G[(size_t)7 * nm + nb + r];
        mb->nkeep = 0;
        while (mb->nkeep < ni && mb->lambda[mb->nkeep] <= cut)
            mb->nkeep++;
        rc = residual_vectors(mb, F, nl, c, sv, U);
    }
    if (!rc)
        inertia_terms(mb, F);
    free(B);
    free(F);
    free(c);
    free(sv);
    free(U);
    return rc;
}

/* The unit loads' parts along the basis: Gq = [Phi_kept, R]' G_i (the
 * reduced coordinates of a member's interior, dm_boundary). */
static void load_terms(dm_member_basis *mb)
{
    int ni = mb->ni, nm = mb->nm, nq = mb->nkeep + mb->nres;
    for (int a = 0; a < DM_MEMBERS_LOADS; a++)
        for (int j = 0; j < nq; j++) {
            const double *v = j < mb->nkeep ? mb->Phi + (size_t)j * ni
                                            : mb->R + (size_t)(j - mb->nkeep) * ni;
            const double *g = mb->G + (size_t)a * nm + mb->nb;
            double s = 0;
            for (int r = 0; r < ni; r++)
                s += v[r] * g[r];
            mb->Gq[(size_t)a * nq + j] = s;
        }
}

static int member_alloc(dm_member_basis *mb)
{
    size_t nm = (size_t)mb->nm, ni = (size_t)mb->ni, nb = (size_t)mb->nb;
    int fail = 0;
    mb->K = new_array(nm * nm, &fail);
    mb->M = new_array(nm * nm, &fail);
    mb->G = new_array(nm * DM_MEMBERS_LOADS, &fail);
    mb->Lii = new_array(ni * ni, &fail);
    mb->Psi = new_array(ni * nb, &fail);
    mb->Khat = new_array(nb * nb, &fail);
    mb->Ghat = new_array(nb * DM_MEMBERS_LOADS, &fail);
    mb->Gq = new_array((ni + nb + 1) * DM_MEMBERS_LOADS, &fail);
    mb->Ui = new_array(ni * 3, &fail);
    mb->lambda = new_array(ni, &fail);
    mb->Phi = new_array(ni * ni, &fail);
    mb->R = new_array(ni * (nb + 1), &fail); /* nres <= nb + 1 (an arm's rotation) */
    mb->Mhat = new_array(nb * nb, &fail);
    mb->Gam = new_array(ni * nb, &fail);
    mb->GamR = new_array((nb + 1) * nb, &fail);
    mb->kres = new_array(nb + 1, &fail);
    return fail ? DM_ENOMEM : DM_OK;
}

static void member_release(dm_member_basis *mb)
{
    double *arrays[] = {mb->K,   mb->M,   mb->G,      mb->Lii, mb->Psi,  mb->Khat, mb->Ghat,
                        mb->Ui,  mb->lambda, mb->Phi, mb->R,   mb->Mhat, mb->Gam,  mb->GamR,
                        mb->kres, mb->Gq};
    for (size_t k = 0; k < sizeof arrays / sizeof *arrays; k++)
        free(arrays[k]);
    free(mb->run);
}

/* Member m of the model: its layout, matrices, condensation and basis. */
static int member_build(const dm_model *md, int m, double cut, dm_member_basis *mb)
{
    const dm_element *e = first_element(md, m);
    mb->kind = m % 3 == 0 ? DM_MEMBER_ARM : DM_MEMBER_ROD;
    mb->chain = m / 3;
    mb->side = m % 3 == 2;
    mb->nel = mb->kind == DM_MEMBER_ARM ? md->na : md->nb;
    mb->element_m = e->length_m;
    member_map mm = {.nodes = mb->nel + 1, .spring_node = {-1, -1}, .spring_bound = {-1, -1}};
    mm.dof = malloc(sizeof(int) * 6 * mm.nodes);
    mb->run = malloc(sizeof *mb->run * (mb->nel + 5));
    if (!mm.dof || !mb->run) {
        free(mm.dof);
        return DM_ENOMEM;
    }
    for (int k = 0; k < 6 * mm.nodes; k++)
        mm.dof[k] = -1;
    if (mb->kind == DM_MEMBER_ARM)
        arm_map(md, m, mb, &mm);
    else
        rod_map(md, m, mb, &mm);
    mb->nm = mb->nb + mb->ni;
    int rc = member_alloc(mb);
    if (!rc) {
        assemble(md, mb, &mm);
        rc = condense(mb);
    }
    if (!rc)
        rc = fixed_interface_basis(mb, cut);
    if (!rc)
        load_terms(mb);
    free(mm.dof);
    return rc;
}

/* ---- the boundary ----------------------------------------------------------- */

/* Boundary DOFs in model order: per chain its base translations (compliant
 * base) and its elbow, then the platform. */
static void boundary_layout(const dm_model *md, dm_members *ms)
{
    ms->nbound = 0;
    for (int i = 0; i < 3; i++) {
        ms->bbase[i] = -1;
        if (dm_effects_base_compliant(&md->robot->effects, i)) {
            ms->bbase[i] = ms->nbound;
            for (int k = 0; k < 3; k++)
                ms->bdof[ms->nbound++] = md->chain_dof[i] + k;
        }
        ms->belbow[i] = ms->nbound;
        for (int k = 0; k < 6; k++)
            ms->bdof[ms->nbound++] = md->elbow_dof[i] + k;
    }
    ms->bplat = ms->nbound;
    for (int k = 0; k < 6; k++)
        ms->bdof[ms->nbound++] = md->platform_dof + k;
    assert(ms->nbound <= DM_MEMBERS_MAX_BOUND);
}

/* What acts on the boundary alone, global axes: base springs, the
 * platform with its payload, the elbow masses, and their weight. */
static void boundary_terms(const dm_model *md, dm_members *ms)
{
    const dm_effects *fx = &md->robot->effects;
    const double *g = md->robot->gravity_ms2;
    int nB = ms->nbound, p = ms->bplat;
    double MP[36];
    memset(ms->Fb, 0, sizeof ms->Fb);
    dm_model_platform(md->robot, MP, ms->Fb + p);
    for (int c = 0; c < 6; c++)
        for (int r = 0; r < 6; r++)
            ms->Mb[(size_t)(p + c) * nB + p + r] = MP[6 * c + r];
    for (int i = 0; i < 3; i++) {
        for (int k = 0; k < 3 && ms->bbase[i] >= 0; k++) {
            int b = ms->bbase[i] + k;
            ms->Kb[(size_t)b * nB + b] = fx->base_stiffness_n_per_m[i][k];
        }
        for (int k = 0; k < 3; k++) {
            int b = ms->belbow[i] + k;
            ms->Mb[(size_t)b * nB + b] = fx->elbow_mass_kg;
            ms->Fb[b] = fx->elbow_mass_kg * g[k];
        }
    }
}

int dm_members_serves(const dm_robot *robot, dm_error *err)
{
    if (robot->effects.geometric_stiffness)
        return dm_fail(err, DM_EINVAL,
                       "member bases: geometric stiffness makes each member's K follow the "
                       "pose's axial forces; the full model serves this robot");
    return DM_OK;
}

dm_members *dm_members_build(const dm_model *md, double lambda_cut, dm_error *err)
{
    int rc = dm_members_serves(md->robot, err);
    if (rc)
        return NULL;
    assert(md->have_pattern); /* assembled once: element lengths and node maps */
    dm_members *ms = calloc(1, sizeof *ms);
    if (!ms) {
        dm_fail(err, DM_ENOMEM, "out of memory for the member bases");
        return NULL;
    }
    ms->robot = md->robot;
    ms->na = md->na;
    ms->nb = md->nb;
    ms->n = md->n;
    ms->lambda_cut = lambda_cut;
    boundary_layout(md, ms);
    ms->Kb = calloc((size_t)ms->nbound * ms->nbound, sizeof(double));
    ms->Mb = calloc((size_t)ms->nbound * ms->nbound, sizeof(double));
    rc = ms->Kb && ms->Mb ? DM_OK : DM_ENOMEM;
    if (!rc)
        boundary_terms(md, ms);
    int next = ms->nbound;
    for (int m = 0; m < DM_MEMBERS_N && !rc; m++) {
        rc = member_build(md, m, lambda_cut, &ms->member[m]);
        ms->interior0[m] = next;
        next += ms->member[m].ni;
    }
    if (rc) {
        dm_fail(err, rc, rc == DM_ENOMEM ? "out of memory for the member bases"
                                         : "member bases: a clamped member is singular");
        dm_members_free(ms);
        return NULL;
    }
    assert(next == md->n); /* every DOF is on the boundary or inside one member */
    return ms;
}

void dm_members_free(dm_members *ms)
{
    if (!ms)
        return;
    for (int m = 0; m < DM_MEMBERS_N; m++)
        member_release(&ms->member[m]);
    free(ms->Kb);
    free(ms->Mb);
    free(ms);
}

/* ---- a pose ------------------------------------------------------------------ */

static int member_frame(const dm_members *ms, int m, const double axis[3], const double t[3],
                        double lambda[9], dm_error *err)
{
    const dm_member_basis *mb = &ms->member[m];
    const char *what = mb->kind == DM_MEMBER_ARM ? "arm" : "rod";
    double le = dm_norm3(axis) / mb->nel;
    if (!(fabs(le - mb->element_m) <= 1e-12 * mb->element_m))
        return dm_fail(err, DM_EINVAL,
                       "member bases: chain %d's %s is %.12g m long at this pose, %.12g m in "
                       "the cache (joint clearance or another geometry); use the full model",
                       mb->chain, what, le * mb->nel, mb->element_m * mb->nel);
    if (dm_beam_frame(axis, t, lambda))
        return dm_fail(err, DM_ENUMERIC, "chain %d: %s has no local frame (axis parallel to t_i)",
                       mb->chain, what);
    return DM_OK;
}

int dm_members_at(const dm_members *ms, const dm_pose *p, dm_members_pose *mp, dm_error *err)
{
    dm_copy3(ms->robot->gravity_ms2, mp->gravity);
    for (int i = 0; i < 3; i++) {
        double axis[3], top[3], bottom[3];
        dm_sub3(p->B[i], p->A[i], axis);
        int rc = member_frame(ms, 3 * i, axis, p->t[i], mp->lambda[3 * i], err);
        for (int s = 0; s < 2 && !rc; s++) {
            int m = 3 * i + 1 + s;
            dm_model_rod_ends(ms->robot, p, i, s, top, bottom, mp->bar[m], mp->plat_arm[m]);
            dm_sub3(bottom, top, axis);
            rc = member_frame(ms, m, axis, p->t[i], mp->lambda[m], err);
        }
        if (rc)
            return rc;
    }
    return DM_OK;
}

/* C[row0.., col0..] = L [I, -skew(s)] (3 x 6), or L alone (s NULL, 3 x 3). */
static void put_rigid(double *C, int ld, int row0, int col0, const double L[9], const double *s)
{
    double S[9] = {0};
    if (s)
        dm_skew3(s, S);
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 3; c++) {
            C[(size_t)(col0 + c) * ld + row0 + r] = L[3 * r + c];
            if (!s)
                continue;
            double v = 0; /* (L (-S))[r][c] */
            for (int k = 0; k < 3; k++)
                v -= L[3 * r + k] * S[3 * k + c];
            C[(size_t)(col0 + 3 + c) * ld + row0 + r] = v;
        }
}

void dm_members_coupling(const dm_members *ms, const dm_members_pose *mp, int m, double *C)
{
    const dm_member_basis *mb = &ms->member[m];
    const double *L = mp->lambda[m];
    int nb = mb->nb, i = mb->chain;
    memset(C, 0, sizeof(double) * nb * ms->nbound);
    if (mb->kind == DM_MEMBER_ARM) {
        put_rigid(C, nb, 0, ms->belbow[i], L, NULL);
        put_rigid(C, nb, 3, ms->belbow[i] + 3, L, NULL);
        if (ms->bbase[i] >= 0)
            put_rigid(C, nb, 6, ms->bbase[i], L, NULL);
    } else {
        put_rigid(C, nb, 0, ms->belbow[i], L, mp->bar[m]);
        put_rigid(C, nb, 3, ms->bplat, L, mp->plat_arm[m]);
    }
}

int dm_members_columns(const dm_members *ms, int m, int cols[12])
{
    const dm_member_basis *mb = &ms->member[m];
    int i = mb->chain, nc = 0;
    int other = mb->kind == DM_MEMBER_ARM ? ms->bbase[i] : ms->bplat;
    int nother = mb->kind == DM_MEMBER_ARM ? 3 * (ms->bbase[i] >= 0) : 6;
    for (int k = 0; k < 6; k++)
        cols[nc++] = ms->belbow[i] + k;
    for (int k = 0; k < nother; k++)
        cols[nc++] = other + k;
    return nc;
}

/* One run of a member's interior from the model (global) into the
 * member's frame: z = L u. */
static void run_to_local(const dm_members_run *run, const double L[9], const double *u, double *z)
{
    if (!run->rotate) {
        memcpy(z, u, sizeof(double) * run->count);
        return;
    }
    for (int t = 0; t < run->count; t += 3) {
        double a = u[t], b = u[t + 1], c = u[t + 2];
        z[t] = 0.0 + L[0] * a + L[1] * b + L[2] * c;
        z[t + 1] = 0.0 + L[3] * a + L[4] * b + L[5] * c;
        z[t + 2] = 0.0 + L[6] * a + L[7] * b + L[8] * c;
    }
}

/* The same for k vectors (n apart) the other way: u = L' z. */
static void run_to_model(const dm_members_run *run, const double L[9], const double *z, double *u,
                         int k, int n)
{
    for (int j = 0; j < k; j++) {
        const double *zj = z + (size_t)j * n;
        double *uj = u + (size_t)j * n;
        if (!run->rotate) {
            memcpy(uj, zj, sizeof(double) * run->count);
            continue;
        }
        for (int t = 0; t < run->count; t += 3) {
            double a = zj[t], b = zj[t + 1], c = zj[t + 2];
            uj[t] = 0.0 + L[0] * a + L[3] * b + L[6] * c;
            uj[t + 1] = 0.0 + L[1] * a + L[4] * b + L[7] * c;
            uj[t + 2] = 0.0 + L[2] * a + L[5] * b + L[8] * c;
        }
    }
}

void dm_members_gather(const dm_members *ms, const dm_members_pose *mp, const double *U, double *z)
{
    for (int b = 0; b < ms->nbound; b++)
        z[b] = U[ms->bdof[b]];
    for (int m = 0; m < DM_MEMBERS_N; m++) {
        const dm_member_basis *mb = &ms->member[m];
        for (int r = 0; r < mb->nrun; r++) {
            const dm_members_run *run = &mb->run[r];
            run_to_local(run, mp->lambda[m], U + run->model_dof,
                         z + ms->interior0[m] + run->interior);
        }
    }
}

void dm_members_scatter_many(const dm_members *ms, const dm_members_pose *mp, const double *z,
                             int k, double *U)
{
    int n = ms->n;
    for (int j = 0; j < k; j++)
        for (int b = 0; b < ms->nbound; b++)
            U[(size_t)j * n + ms->bdof[b]] = z[(size_t)j * n + b];
    for (int m = 0; m < DM_MEMBERS_N; m++) {
        const dm_member_basis *mb = &ms->member[m];
        for (int r = 0; r < mb->nrun; r++) {
            const dm_members_run *run = &mb->run[r];
            run_to_model(run, mp->lambda[m], z + ms->interior0[m] + run->interior,
                         U + run->model_dof, k, n);
        }
    }
}

void dm_members_scatter(const dm_members *ms, const dm_members_pose *mp, const double *z, double *U)
{
    dm_members_scatter_many(ms, mp, z, 1, U);
}

int dm_members_mult(const dm_members *ms, const dm_members_pose *mp, char which, const double *z,
                    double *y)
{
    int nB = ms->nbound;
    const double *X = which == 'K' ? ms->Kb : ms->Mb;
    double *C = malloc(sizeof(double) * 9 * nB), *w = malloc(sizeof(double) * ms->n * 2);
    if (!C || !w) {
        free(C);
        free(w);
        return DM_ENOMEM;
    }
    for (int r = 0; r < nB; r++) {
        double s = 0;
        for (int c = 0; c < nB; c++)
            s += X[(size_t)c * nB + r] * z[c];
        y[r] = s;
    }
    for (int m = 0; m < DM_MEMBERS_N; m++) {
        const dm_member_basis *mb = &ms->member[m];
        const double *Xm = which == 'K' ? mb->K : mb->M;
        double *v = w + mb->nm;
        dm_members_coupling(ms, mp, m, C);
        for (int r = 0; r < mb->nb; r++) { /* w = [C z_B; z_i] */
            double s = 0;
            for (int c = 0; c < nB; c++)
                s += C[(size_t)c * mb->nb + r] * z[c];
            w[r] = s;
        }
        memcpy(w + mb->nb, z + ms->interior0[m], sizeof(double) * mb->ni);
        for (int r = 0; r < mb->nm; r++) {
            double s = 0;
            for (int c = 0; c < mb->nm; c++)
                s += Xm[(size_t)c * mb->nm + r] * w[c];
            v[r] = s;
        }
        for (int c = 0; c < nB; c++) /* y_B += C' v_b */
            for (int r = 0; r < mb->nb; r++)
                y[c] += C[(size_t)c * mb->nb + r] * v[r];
        memcpy(y + ms->interior0[m], v + mb->nb, sizeof(double) * mb->ni);
    }
    free(C);
    free(w);
    return DM_OK;
}

int dm_members_reduced_size(const dm_members *ms)
{
    int nred = ms->nbound;
    for (int m = 0; m < DM_MEMBERS_N; m++)
        nred += ms->member[m].nkeep + ms->member[m].nres;
    return nred;
}
