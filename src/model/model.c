/* The frozen-configuration model: DOFs, assembly of M, K and the gravity
 * load (docs/model.md §2). */
#include "dm_model.h"

#include <assert.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "dm_vec3.h"

/* ---- DOF numbering -------------------------------------------------------- */

/* Inside a chain: arm-root DOFs (model extensions), arm nodes 1..na, the
 * two upper rod ends, then the two rods' interior nodes interleaved (node
 * k of rod +d, node k of rod -d, k = 1..nb-1), then the two lower ends.
 * The rods run side by side from the elbow to the platform, so the
 * half-bandwidth is that of two nodes (17) whatever the mesh; numbering
 * one rod after the other made it grow with nb (35 at mesh 4,4). */
static int chain_size(const dm_model *md, int i)
{
    return md->root_dofs[i] + 6 * md->na + 2 * (2 * md->end_dofs + 6 * (md->nb - 1));
}

/* First DOF of arm node k (1..na) in chain i. */
static int arm_node_dof(const dm_model *md, int i, int k)
{
    assert(k >= 1 && k <= md->na);
    return md->chain_dof[i] + md->root_dofs[i] + 6 * (k - 1);
}

/* Own DOFs of the upper end of rod s (0: +d, 1: -d). */
static int upper_end_dof(const dm_model *md, int i, int s)
{
    return md->chain_dof[i] + md->root_dofs[i] + 6 * md->na + s * md->end_dofs;
}

/* Interior node k (1..nb-1) of rod s. */
static int interior_dof(const dm_model *md, int i, int s, int k)
{
    assert(k >= 1 && k < md->nb);
    return upper_end_dof(md, i, 0) + 2 * md->end_dofs + 12 * (k - 1) + 6 * s;
}

/* Own DOFs of the lower end of rod s. */
static int lower_end_dof(const dm_model *md, int i, int s)
{
    return upper_end_dof(md, i, 0) + 2 * md->end_dofs + 12 * (md->nb - 1) + s * md->end_dofs;
}

/* Span (last DOF - first DOF) of up to three DOF ranges [from, from + len);
 * ranges with len 0 are absent. */
static int span3(const int from[3], const int len[3])
{
    int lo = 1 << 30, hi = -1;
    for (int j = 0; j < 3; j++)
        if (len[j] > 0) {
            lo = from[j] < lo ? from[j] : lo;
            hi = from[j] + len[j] - 1 > hi ? from[j] + len[j] - 1 : hi;
        }
    return hi < 0 ? 0 : hi - lo;
}

static int imax(int a, int b) { return a > b ? a : b; }

/* Half-bandwidth of chain i: the widest element (or spring) in the chain's
 * own DOFs. An upper rod end reaches the elbow (through the short bar, or
 * through the joint spring); a lower end reaches only the platform, which
 * is the border. */
static int chain_half_bandwidth(const dm_model *md, int i)
{
    int kd = 0, e = md->end_dofs, nb = md->nb, elbow = arm_node_dof(md, i, md->na);
    for (int k = 0; k < md->na; k++) {
        int from[3] = {k ? arm_node_dof(md, i, k) : md->chain_dof[i], arm_node_dof(md, i, k + 1), 0};
        int len[3] = {k ? 6 : md->root_dofs[i], 6, 0};
        kd = imax(kd, span3(from, len));
    }
    for (int r = 0; r < 2; r++)
        for (int k = 0; k < nb; k++) {
            int from[3] = {k ? interior_dof(md, i, r, k) : upper_end_dof(md, i, r),
                           k + 1 < nb ? interior_dof(md, i, r, k + 1) : lower_end_dof(md, i, r),
                           elbow};
            int len[3] = {k ? 6 : e, k + 1 < nb ? 6 : e, k == 0 ? 6 : 0};
            kd = imax(kd, span3(from, len));
        }
    return kd;
}

static void set_layout(dm_model *md, const dm_robot *robot, int na, int nb)
{
    const dm_effects *fx = &robot->effects;
    md->robot = robot;
    md->na = na;
    md->nb = nb;
    md->end_dofs = fx->joint_stiffness_n_per_m > 0 ? 5 : 2;
    int next = 0;
    for (int i = 0; i < 3; i++) {
        md->root_dofs[i] = 3 * dm_effects_base_compliant(fx, i) +
                           (fx->actuator_stiffness_nm_per_rad > 0);
        md->chain_dof[i] = next;
        next += chain_size(md, i);
    }
    md->platform_dof = next;
    md->n = md->platform_dof + 6;
    for (int i = 0; i < 3; i++)
        md->elbow_dof[i] = arm_node_dof(md, i, na);
}

/* The block-arrow layout of M and K: one banded block per chain, the
 * platform's 6 DOFs as the border. */
static void arrow_layout(const dm_model *md, dm_arrow_layout *lay)
{
    int nbk[3], kd[3];
    for (int i = 0; i < 3; i++) {
        nbk[i] = chain_size(md, i);
        kd[i] = chain_half_bandwidth(md, i);
    }
    dm_arrow_layout_make(lay, nbk, kd);
    assert(lay->border == md->platform_dof && lay->n == md->n);
}

int dm_model_dofs(const dm_robot *robot, int na, int nb)
{
    dm_model md;
    set_layout(&md, robot, na, nb);
    return md.n;
}

dm_model *dm_model_alloc(const dm_robot *robot, int na, int nb, dm_error *err)
{
    if (na < 1 || nb < 1 || na > 64 || nb > 64) {
        dm_fail(err, DM_EINVAL, "mesh %d,%d: elements per arm and rod must be 1..64", na, nb);
        return NULL;
    }
    dm_model *md = calloc(1, sizeof *md);
    if (!md) {
        dm_fail(err, DM_ENOMEM, "out of memory for the model");
        return NULL;
    }
    const dm_effects *fx = &robot->effects;
    set_layout(md, robot, na, nb);
    arrow_layout(md, &md->layout);
    md->nelem = 3 * (na + 2 * nb);
    md->elem = calloc((size_t)md->nelem, sizeof *md->elem);
    md->plan = malloc((size_t)md->nelem * sizeof *md->plan);
    md->F_gravity = calloc((size_t)md->n, sizeof *md->F_gravity);
    int rc = md->elem && md->plan && md->F_gravity ? DM_OK : DM_ENOMEM;
    if (!rc)
        rc = dm_arrow_init(&md->K, &md->layout, NULL);
    if (!rc)
        rc = dm_arrow_init(&md->M, &md->layout, NULL);
    if (!rc && fx->geometric_stiffness) {
        md->gs_factor = calloc(1, sizeof *md->gs_factor);
        md->u_static = malloc((size_t)md->n * sizeof *md->u_static);
        rc = md->gs_factor && md->u_static ? dm_arrow_chol_init(md->gs_factor, &md->layout, NULL)
                                           : DM_ENOMEM;
    }
    if (rc) {
        dm_fail(err, DM_ENOMEM, "out of memory for a %d-DOF model", md->n);
        dm_model_free(md);
        return NULL;
    }
    dm_beam_props_of(&robot->arm, &md->props[DM_MEMBER_ARM]);
    dm_beam_props_of(&robot->rod, &md->props[DM_MEMBER_ROD]);
    return md;
}

void dm_model_free(dm_model *md)
{
    if (!md)
        return;
    free(md->elem);
    free(md->plan);
    dm_arrow_release(&md->M);
    dm_arrow_release(&md->K);
    dm_arrow_pattern_release(&md->pattern);
    free(md->F_gravity);
    if (md->gs_factor)
        dm_arrow_chol_release(md->gs_factor);
    free(md->gs_factor);
    free(md->u_static);
    free(md);
}

/* ---- node maps ------------------------------------------------------------ */

/* Arm root: clamped, or with base translations (global axes) and/or the
 * actuator rotation about t_i as DOFs. */
static void map_root(const dm_model *md, int i, dm_nodemap *m)
{
    memset(m, 0, sizeof *m);
    int base = md->chain_dof[i];
    if (dm_effects_base_compliant(&md->robot->effects, i))
        for (int k = 0; k < 3; k++, m->m++) {
            m->idx[m->m] = base + m->m;
            m->c[k][m->m] = 1.0;
        }
    if (md->robot->effects.actuator_stiffness_nm_per_rad > 0) {
        m->idx[m->m] = base + m->m;
        for (int k = 0; k < 3; k++)
            m->c[3 + k][m->m] = md->pose.t[i][k];
        m->m++;
    }
}

static void map_free(dm_nodemap *m, int dof)
{
    memset(m, 0, sizeof *m);
    m->m = 6;
    for (int j = 0; j < 6; j++) {
        m->idx[j] = dof + j;
        m->c[j][j] = 1.0;
    }
}

/* Rod end on a rigid body: translation u = u_ref + theta_ref x s (s from the
 * body's reference point to the end), rotation = phi_y y + phi_z z with the
 * rod's local y, z (ball joint: no rotation about the rod axis). */
static void map_rod_end(dm_nodemap *m, int ref_dof, const double s[3], int rot_dof,
                        const double lambda[9])
{
    double S[9];
    map_free(m, ref_dof);
    dm_skew3(s, S);
    for (int r = 0; r < 3; r++) {
        for (int c = 0; c < 3; c++)
            m->c[r][3 + c] = -S[3 * r + c]; /* theta x s = -s x theta */
        m->c[3 + r][3 + r] = 0.0;           /* the rotations are the rod end's own */
    }
    m->m = 8;
    m->idx[6] = rot_dof;
    m->idx[7] = rot_dof + 1;
    for (int r = 0; r < 3; r++) {
        m->c[3 + r][6] = lambda[3 + r];
        m->c[3 + r][7] = lambda[6 + r];
    }
}

/* With joint springs the rod end's translations are DOFs of its own (the
 * short-bar point keeps the map above; a spring ties the two). */
static void map_free_end(dm_nodemap *m, int own, const double lambda[9])
{
    memset(m, 0, sizeof *m);
    m->m = 5;
    for (int k = 0; k < 3; k++) {
        m->idx[k] = own + 2 + k;
        m->c[k][k] = 1.0;
    }
    m->idx[3] = own;
    m->idx[4] = own + 1;
    for (int r = 0; r < 3; r++) {
        m->c[3 + r][3] = lambda[3 + r];
        m->c[3 + r][4] = lambda[6 + r];
    }
}

static void map_end(const dm_model *md, dm_nodemap *m, int ref_dof, const double s[3], int own,
                    const double lambda[9])
{
    if (md->end_dofs == 5)
        map_free_end(m, own, lambda);
    else
        map_rod_end(m, ref_dof, s, own, lambda);
}

void dm_model_nodemap_apply(const dm_nodemap *map, const double *U, double out[6])
{
    for (int r = 0; r < 6; r++) {
        double s = 0;
        for (int j = 0; j < map->m; j++)
            s += map->c[r][j] * U[map->idx[j]];
        out[r] = s;
    }
}

/* ---- elements ------------------------------------------------------------- */

static void lerp3(const double a[3], const double b[3], double s, double out[3])
{
    for (int k = 0; k < 3; k++)
        out[k] = a[k] + s * (b[k] - a[k]);
}

/* An element of a member (arm or rod) cut into `parts` equal elements:
 * its length and frame are the member's, the same numbers for every
 * element of the member (so their global matrices are computed once). */
static int set_geometry(dm_element *e, dm_member_kind kind, int chain, const double x1[3],
                        const double x2[3], const double member_axis[3], int parts,
                        const double y_hint[3], dm_error *err)
{
    e->member = kind;
    e->chain = chain;
    dm_copy3(x1, e->x1);
    dm_copy3(x2, e->x2);
    e->length_m = dm_norm3(member_axis) / parts;
    if (dm_beam_frame(member_axis, y_hint, e->lambda))
        return dm_fail(err, DM_ENUMERIC,
                       "chain %d: %s element has no local frame (axis parallel to t_i)",
                       chain, kind == DM_MEMBER_ARM ? "arm" : "rod");
    return DM_OK;
}

static int build_arm(dm_model *md, int i, dm_element *e, dm_error *err)
{
    const dm_pose *p = &md->pose;
    double axis[3];
    dm_sub3(p->B[i], p->A[i], axis);
    for (int k = 0; k < md->na; k++, e++) {
        double x1[3], x2[3];
        lerp3(p->A[i], p->B[i], (double)k / md->na, x1);
        lerp3(p->A[i], p->B[i], (double)(k + 1) / md->na, x2);
        int rc = set_geometry(e, DM_MEMBER_ARM, i, x1, x2, axis, md->na, p->t[i], err);
        e->s1 = (double)k / md->na;
        e->s2 = (double)(k + 1) / md->na;
        if (rc)
            return rc;
        if (k == 0)
            map_root(md, i, &e->node[0]);
        else
            map_free(&e->node[0], arm_node_dof(md, i, k));
        map_free(&e->node[1], arm_node_dof(md, i, k + 1));
    }
    return DM_OK;
}

/* Joint spring kj*I3 between a rod end's own translations (own+2..own+4)
 * and its short-bar point u_ref + theta_ref x s:
 * K += kj D'D, D = [I3 on the end | -(bar map) on the body's 6 DOFs]. */
static void add_joint_spring(dm_model *md, int ref_dof, const double s[3], int own)
{
    dm_nodemap bar;
    const double no_frame[9] = {0};
    double D[3][9], kj = md->robot->effects.joint_stiffness_n_per_m;
    int idx[9];
    map_rod_end(&bar, ref_dof, s, own, no_frame);
    for (int r = 0; r < 3; r++) {
        for (int j = 0; j < 3; j++)
            D[r][j] = r == j;
        for (int j = 0; j < 6; j++)
            D[r][3 + j] = -bar.c[r][j];
    }
    for (int j = 0; j < 3; j++)
        idx[j] = own + 2 + j;
    for (int j = 0; j < 6; j++)
        idx[3 + j] = ref_dof + j;
    for (int a = 0; a < 9; a++)
        for (int b = 0; b < 9; b++) {
            double v = 0;
            for (int r = 0; r < 3; r++)
                v += D[r][a] * D[r][b];
            dm_arrow_add(&md->K, idx[a], idx[b], kj * v);
        }
}

void dm_model_rod_ends(const dm_robot *rb, const dm_pose *p, int i, int s, double top[3],
                       double bottom[3], double bar[3], double plat_arm[3])
{
    double sign = s == 0 ? 1.0 : -1.0;
    dm_scale3(sign * rb->rod_half_spacing_m, p->t[i], bar);
    dm_axpy3(p->B[i], 1.0, bar, top);
    dm_axpy3(p->C[i], 1.0, bar, bottom);
    dm_sub3(p->C[i], p->P, plat_arm); /* P -> lower end: r_i e_i + bar */
    dm_axpy3(plat_arm, 1.0, bar, plat_arm);
}

static int build_rod(dm_model *md, int i, int s, dm_element *e, dm_error *err)
{
    const dm_pose *p = &md->pose;
    double bar[3], top[3], bottom[3], plat_arm[3];
    dm_model_rod_ends(md->robot, p, i, s, top, bottom, bar, plat_arm);
    int base = upper_end_dof(md, i, s), nb = md->nb;
    int lower = lower_end_dof(md, i, s);
    double axis[3];
    dm_sub3(bottom, top, axis);
    for (int k = 0; k < nb; k++, e++) {
        double x1[3], x2[3];
        lerp3(top, bottom, (double)k / nb, x1);
        lerp3(top, bottom, (double)(k + 1) / nb, x2);
        int rc = set_geometry(e, DM_MEMBER_ROD, i, x1, x2, axis, nb, p->t[i], err);
        e->s1 = (double)k / nb;
        e->s2 = (double)(k + 1) / nb;
        if (rc)
            return rc;
        if (k == 0)
            map_end(md, &e->node[0], arm_node_dof(md, i, md->na), bar, base, e->lambda);
        else
            map_free(&e->node[0], interior_dof(md, i, s, k));
        if (k == nb - 1)
            map_end(md, &e->node[1], md->platform_dof, plat_arm, lower, e->lambda);
        else
            map_free(&e->node[1], interior_dof(md, i, s, k + 1));
    }
    if (md->end_dofs == 5) {
        add_joint_spring(md, arm_node_dof(md, i, md->na), bar, base);
        add_joint_spring(md, md->platform_dof, plat_arm, lower);
    }
    return DM_OK;
}

/* The element's reduced DOFs: u_node = S U[idx] (global frame), S block
 * diagonal (node 0's rows reach only its own columns), kept as its
 * non-zeros: a free node's S is the identity, a rod end's holds its rigid
 * offset and two rotation axes. */
typedef struct {
    int m, nnz, identity; /* identity: S = I (12 x 12) */
    int idx[2 * DM_NODEMAP_MAX];
    unsigned char row[12 * DM_NODEMAP_MAX], col[12 * DM_NODEMAP_MAX];
    double v[12 * DM_NODEMAP_MAX];
} reduction;

static void reduction_of(const dm_element *e, reduction *S)
{
    S->m = S->nnz = 0;
    for (int nd = 0; nd < 2; nd++) {
        const dm_nodemap *nm = &e->node[nd];
        for (int j = 0; j < nm->m; j++, S->m++) {
            S->idx[S->m] = nm->idx[j];
            for (int r = 0; r < 6; r++)
                if (nm->c[r][j] != 0) {
                    S->row[S->nnz] = (unsigned char)(6 * nd + r);
                    S->col[S->nnz] = (unsigned char)S->m;
                    S->v[S->nnz++] = nm->c[r][j];
                }
        }
    }
    S->identity = S->m == 12 && S->nnz == 12;
    for (int k = 0; k < S->nnz && S->identity; k++)
        S->identity = S->row[k] == k && S->col[k] == k && S->v[k] == 1;
}

/* G = T' X T for the element rotation T = diag(L, L, L, L) (L = lambda,
 * rows the local axes): each 3 x 3 block L' B L as a sum over the
 * non-zeros of the local block B, of which a beam has at most two per
 * block (axial, torsion, and one bending coupling in each plane). Lower
 * blocks, then mirrored. */
static void to_global(const double L[9], const double X[144], double G[144])
{
    memset(G, 0, 144 * sizeof *G);
    for (int I = 0; I < 4; I++)
        for (int J = 0; J <= I; J++)
            for (int r = 0; r < 3; r++)
                for (int c = 0; c < 3; c++) {
                    double b = X[(3 * I + r) * 12 + 3 * J + c];
                    if (b == 0)
                        continue;
                    for (int p = 0; p < 3; p++) {
                        double bp = b * L[3 * r + p];
                        for (int s = 0; s < 3; s++)
                            G[(3 * I + p) * 12 + 3 * J + s] += bp * L[3 * c + s];
                    }
                }
    for (int I = 0; I < 4; I++)
        for (int J = I + 1; J < 4; J++)
            for (int p = 0; p < 3; p++)
                for (int s = 0; s < 3; s++)
                    G[(3 * I + p) * 12 + 3 * J + s] = G[(3 * J + s) * 12 + 3 * I + p];
}

/* X[idx, idx] += S' G S: an element matrix in the global frame (G = T' Xe
 * T, to_global) reduced through the non-zeros of S. */
static void scatter(dm_arrow *X, const double G[144], const reduction *S, const dm_arrow_plan *plan)
{
    enum { MM = 2 * DM_NODEMAP_MAX };
    if (S->identity) { /* two free nodes: E = G, column-major */
        double E[144];
        for (int c = 0; c < 12; c++)
            for (int r = 0; r < 12; r++)
                E[c * 12 + r] = G[r * 12 + c];
        dm_arrow_add_planned(X, plan, E);
        return;
    }
    double GS[12][MM] = {{0}}, E[MM * MM] = {0};
    int m = S->m;
    for (int k = 0; k < S->nnz; k++) /* GS = G S */
        for (int p = 0; p < 12; p++)
            GS[p][S->col[k]] += G[p * 12 + S->row[k]] * S->v[k];
    for (int k = 0; k < S->nnz; k++) /* E = S' GS, column-major */
        for (int b = 0; b < m; b++)
            E[b * m + S->col[k]] += S->v[k] * GS[S->row[k]][b];
    dm_arrow_add_planned(X, plan, E);
}

void dm_model_add_element_loads(const dm_model *md, const dm_element *e, int q,
                                const double *a12, double *F)
{
    const double *L = e->lambda;
    double Me[144], aloc[12], f[12], fg[12];
    reduction S;
    assert(q >= 1);
    reduction_of(e, &S);
    dm_beam_mass(&md->props[e->member], e->length_m, Me);
    for (int l = 0; l < q; l++) { /* the reduction and M_e once for all q loads */
        const double *a = a12 + 12 * l;
        for (int blk = 0; blk < 4; blk++) /* local = T global */
            for (int r = 0; r < 3; r++)
                aloc[3 * blk + r] = L[3 * r] * a[3 * blk] + L[3 * r + 1] * a[3 * blk + 1] +
                                    L[3 * r + 2] * a[3 * blk + 2];
        for (int r = 0; r < 12; r++) {
            double s = 0;
            for (int k = 0; k < 12; k++)
                s += Me[r * 12 + k] * aloc[k];
            f[r] = s;
        }
        for (int blk = 0; blk < 4; blk++) /* global = T' local */
            for (int k = 0; k < 3; k++)
                fg[3 * blk + k] = L[k] * f[3 * blk] + L[3 + k] * f[3 * blk + 1] +
                                  L[6 + k] * f[3 * blk + 2];
        double *Fl = F + (size_t)l * md->n;
        for (int j = 0; j < S.nnz; j++)
            Fl[S.idx[S.col[j]]] += S.v[j] * fg[S.row[j]];
    }
}

/* Rigid platform (mass, inertia about P) plus the payload point mass at
 * offset o: u = uP + eps x o = S [uP; eps], S = [I3, -skew(o)], so the
 * payload adds m S'S to the mass and S' m g to the load. */
void dm_model_platform(const dm_robot *rb, double MP[36], double F6[6])
{
    const dm_effects *fx = &rb->effects;
    double S[3][6], Ssk[9], mg[3];
    memset(MP, 0, 36 * sizeof *MP);
    for (int k = 0; k < 3; k++) {
        MP[7 * k] = rb->platform_mass_kg;
        MP[7 * (k + 3)] = rb->platform_inertia_kgm2[k];
    }
    dm_skew3(fx->payload_offset_m, Ssk);
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 3; c++) {
            S[r][c] = r == c;
            S[r][3 + c] = -Ssk[3 * r + c];
        }
    for (int a = 0; a < 6; a++)
        for (int b = 0; b < 6; b++)
            for (int r = 0; r < 3; r++)
                MP[6 * b + a] += fx->payload_kg * S[r][a] * S[r][b];
    dm_scale3(fx->payload_kg, rb->gravity_ms2, mg);
    for (int k = 0; k < 3; k++)
        F6[k] += rb->platform_mass_kg * rb->gravity_ms2[k];
    for (int a = 0; a < 6; a++)
        for (int r = 0; r < 3; r++)
            F6[a] += S[r][a] * mg[r];
}

static void add_platform(dm_model *md)
{
    int p = md->platform_dof;
    dm_model_platform(md->robot, md->platform_mass, md->F_gravity + p);
    for (int c = 0; c < 6; c++)
        for (int r = 0; r < 6; r++)
            dm_arrow_add(&md->M, p + r, p + c, md->platform_mass[6 * c + r]);
}

/* Springs to ground at the arm roots, point masses at the elbows. */
static void add_root_springs_and_elbow_masses(dm_model *md)
{
    const dm_effects *fx = &md->robot->effects;
    for (int i = 0; i < 3; i++) {
        int d = md->chain_dof[i];
        if (dm_effects_base_compliant(fx, i))
            for (int k = 0; k < 3; k++, d++)
                dm_arrow_add(&md->K, d, d, fx->base_stiffness_n_per_m[i][k]);
        if (fx->actuator_stiffness_nm_per_rad > 0)
            dm_arrow_add(&md->K, d, d, fx->actuator_stiffness_nm_per_rad);
        int b = arm_node_dof(md, i, md->na);
        for (int k = 0; k < 3 && fx->elbow_mass_kg > 0; k++) {
            dm_arrow_add(&md->M, b + k, b + k, fx->elbow_mass_kg);
            md->F_gravity[b + k] += fx->elbow_mass_kg * md->robot->gravity_ms2[k];
        }
    }
}

/* Stress stiffening (docs/model.md §6): axial forces N = EA (u2 - u1)/L from one
 * linear static gravity solve, then K += sum of the elements' K_G(N). */
static int add_geometric_stiffness(dm_model *md, dm_error *err)
{
    int n = md->n;
    double *u = md->u_static;
    memcpy(u, md->F_gravity, sizeof(double) * n);
    if (dm_arrow_chol_factor(md->gs_factor, &md->K, NULL))
        return dm_fail(err, DM_ENUMERIC, "geometric stiffness: static gravity solve failed");
    dm_arrow_chol_solve(md->gs_factor, u, 1);
    for (int k = 0; k < md->nelem; k++) {
        const dm_element *e = &md->elem[k];
        double KG[144], ug[12] = {0}, du = 0;
        reduction S;
        reduction_of(e, &S);
        for (int j = 0; j < S.nnz; j++) /* the nodes' displacements, global */
            ug[S.row[j]] += S.v[j] * u[S.idx[S.col[j]]];
        for (int k = 0; k < 3; k++) /* local axial displacement, node 2 - node 1 */
            du += e->lambda[k] * (ug[6 + k] - ug[k]);
        const dm_beam_props *p = &md->props[e->member];
        double G[144];
        dm_beam_geometric(p, p->EA * du / e->length_m, e->length_m, KG);
        to_global(e->lambda, KG, G);
        scatter(&md->K, G, &S, &md->plan[k]);
    }
    return DM_OK;
}

/* The global K_e and M_e of the last element: the elements of a member
 * share them (set_geometry), so they are computed once per member. */
typedef struct {
    int member;            /* dm_member_kind, -1: none yet */
    double length_m, lambda[9];
    double K[144], M[144];
} element_cache;

static void global_matrices(const dm_model *md, const dm_element *e, element_cache *c)
{
    if ((int)e->member == c->member && e->length_m == c->length_m &&
        !memcmp(e->lambda, c->lambda, sizeof c->lambda))
        return;
    double Ke[144], Me[144];
    dm_beam_stiffness(&md->props[e->member], e->length_m, Ke);
    dm_beam_mass(&md->props[e->member], e->length_m, Me);
    to_global(e->lambda, Ke, c->K);
    to_global(e->lambda, Me, c->M);
    c->member = (int)e->member;
    c->length_m = e->length_m;
    memcpy(c->lambda, e->lambda, sizeof c->lambda);
}

/* F += S' G_M g: an element's consistent gravity load, from its global
 * mass matrix (dm_model_add_element_loads's T' M_e T a, with T' M_e T
 * already at hand). */
static void add_gravity(const double GM[144], const double g12[12], const reduction *S, double *F)
{
    double fg[12];
    for (int r = 0; r < 12; r++) {
        double s = 0;
        for (int k = 0; k < 12; k++)
            s += GM[r * 12 + k] * g12[k];
        fg[r] = s;
    }
    for (int j = 0; j < S->nnz; j++)
        F[S->idx[S->col[j]]] += S->v[j] * fg[S->row[j]];
}

int dm_model_build(dm_model *md, const dm_pose *pose, dm_error *err)
{
    md->pose = *pose;
    dm_arrow_zero(&md->M);
    dm_arrow_zero(&md->K);
    /* the first build records which entries the assembly touches: the
     * pattern is the same at every pose */
    int first = !md->have_pattern, rc = DM_OK;
    if (first && ((rc = dm_arrow_record(&md->K, err)) || (rc = dm_arrow_record(&md->M, err))))
        return rc;
    memset(md->F_gravity, 0, (size_t)md->n * sizeof *md->F_gravity);
    dm_element *e = md->elem;
    for (int i = 0; i < 3; i++) {
        rc = build_arm(md, i, e, err);
        e += md->na;
        for (int s = 0; s < 2 && !rc; s++, e += md->nb)
            rc = build_rod(md, i, s, e, err);
        if (rc)
            return rc;
    }
    const double *g = md->robot->gravity_ms2;
    const double g12[12] = {g[0], g[1], g[2], 0, 0, 0, g[0], g[1], g[2], 0, 0, 0};
    element_cache cache = {.member = -1};
    for (int k = 0; k < md->nelem; k++) {
        const dm_element *el = &md->elem[k];
        reduction S;
        reduction_of(el, &S);
        global_matrices(md, el, &cache);
        if (first) /* the DOF numbering, so the plans, are the same at every pose */
            dm_arrow_plan_make(&md->layout, S.idx, S.m, &md->plan[k]);
        scatter(&md->K, cache.K, &S, &md->plan[k]);
        scatter(&md->M, cache.M, &S, &md->plan[k]);
        add_gravity(cache.M, g12, &S, md->F_gravity);
    }
    add_platform(md);
    add_root_springs_and_elbow_masses(md);
    if (md->robot->effects.geometric_stiffness)
        rc = add_geometric_stiffness(md, err);
    if (!rc && first) {
        if ((rc = dm_arrow_pattern_make(&md->pattern, &md->K, &md->M, err)))
            return rc;
        md->K.pattern = md->M.pattern = &md->pattern;
        md->have_pattern = 1;
    }
    return rc;
}

void dm_model_dense(const dm_model *md, double *K, double *M)
{
    if (K)
        dm_arrow_to_dense(&md->K, K);
    if (M)
        dm_arrow_to_dense(&md->M, M);
}

void dm_model_mult_M(const dm_model *md, const double *X, int q, double *Y)
{
    dm_arrow_mult(&md->M, X, q, Y);
}

void dm_model_mult_K(const dm_model *md, const double *X, int q, double *Y)
{
    dm_arrow_mult(&md->K, X, q, Y);
}
