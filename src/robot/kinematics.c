/* Inverse/forward kinematics, rates, accelerations and the singularity
 * measure of the Delta robot (docs/model.md §1). */
#include "dm_kinematics.h"

#include <assert.h>
#include <lapacke.h>
#include <math.h>
#include <string.h>

#include "dm_symeig.h"
#include "dm_vec3.h"

/* One chain's geometry: nominal, or the real one with the geometry errors. */
typedef struct {
    double R, r, la, lb, theta, alpha0;
} chain_geom;

static void chain_geometry(const dm_robot *rb, int i, int real, chain_geom *g)
{
    assert(i >= 0 && i < 3);
    const dm_effects *e = &rb->effects;
    g->R = rb->base_radius_m + (real ? e->err_base_radius_m[i] : 0);
    g->r = rb->platform_radius_m + (real ? e->err_platform_radius_m[i] : 0);
    g->la = rb->arm_length_m + (real ? e->err_arm_length_m[i] : 0);
    g->lb = rb->rod_length_m + (real ? e->err_rod_length_m[i] : 0);
    g->theta = rb->theta0_rad + i * 2.0 * M_PI / 3.0 + (real ? e->err_theta_rad[i] : 0);
    g->alpha0 = real ? e->err_alpha0_rad[i] : 0;
}

static void chain_axes(const chain_geom *g, double e[3], double t[3])
{
    e[0] = cos(g->theta); e[1] = sin(g->theta); e[2] = 0;
    t[0] = -sin(g->theta); t[1] = cos(g->theta); t[2] = 0;
}

/* Elbow position for arm angle a. */
static void elbow_at(const chain_geom *g, const double A[3], const double e[3], double a,
                     double B[3])
{
    B[0] = A[0] + g->la * cos(a) * e[0];
    B[1] = A[1] + g->la * cos(a) * e[1];
    B[2] = A[2] - g->la * sin(a);
}

/* dB/dalpha = t x (B - A) and d2B/dalpha2 = t x (t x (B - A)): the arm
 * turns about t_i through A_i; from the pose alone, for any geometry. */
static void elbow_derivatives(const dm_pose *p, int i, double b1[3], double b2[3])
{
    assert(i >= 0 && i < 3);
    double r[3];
    dm_sub3(p->B[i], p->A[i], r);
    dm_cross3(p->t[i], r, b1);
    dm_cross3(p->t[i], b1, b2);
}

/* A, B, C, e, t of every chain for platform position P and arm angles. */
static void place_chains(const dm_robot *rb, int real, const double P[3], const double alpha[3],
                         dm_pose *pose)
{
    dm_copy3(P, pose->P);
    for (int i = 0; i < 3; i++) {
        chain_geom g;
        chain_geometry(rb, i, real, &g);
        chain_axes(&g, pose->e[i], pose->t[i]);
        dm_scale3(g.R, pose->e[i], pose->A[i]);
        dm_axpy3(P, g.r, pose->e[i], pose->C[i]);
        pose->alpha[i] = alpha[i];
        elbow_at(&g, pose->A[i], pose->e[i], alpha[i], pose->B[i]);
    }
}

static double condition_number(const double J[9])
{
    /* J is row-major: its columns' singular values are J's */
    double a[9], s[3];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            a[i + 3 * j] = J[3 * i + j];
    if (dm_symeig_singular_values(3, 3, a, 3, s))
        return INFINITY;
    return s[2] > 0 ? s[0] / s[2] : INFINITY;
}

int dm_kin_inverse(const dm_robot *rb, const double P[3], dm_pose *pose, dm_error *err)
{
    double la = rb->arm_length_m, lb = rb->rod_length_m, alpha[3];
    memset(pose, 0, sizeof *pose);
    for (int i = 0; i < 3; i++) {
        chain_geom g;
        double e[3], t[3], Q[3];
        chain_geometry(rb, i, 0, &g);
        chain_axes(&g, e, t);
        dm_axpy3(P, g.r - g.R, e, Q);
        double qe = dm_dot3(Q, e), qz = Q[2];
        double kappa = (dm_dot3(Q, Q) + la * la - lb * lb) / (2.0 * la);
        double rho = hypot(qe, qz);
        if (!(fabs(kappa) <= rho) || rho == 0.0)
            return dm_fail(err, DM_EUNREACHABLE,
                           "pose (%g, %g, %g) m is unreachable: chain %d cannot close "
                           "(|kappa| = %.6g m > rho = %.6g m)",
                           P[0], P[1], P[2], i, fabs(kappa), rho);
        /* qe cos a - qz sin a = rho cos(a + psi) = kappa */
        double psi = atan2(qz, qe), delta = acos(fmin(1.0, kappa / rho));
        double a1 = remainder(-psi + delta, 2.0 * M_PI);
        double a2 = remainder(-psi - delta, 2.0 * M_PI);
        int out_first = cos(a1) >= cos(a2); /* elbow-out: larger B.e */
        alpha[i] = (out_first != rb->elbow_in) ? a1 : a2;
    }
    place_chains(rb, 0, P, alpha, pose);
    double J[9];
    pose->cond = dm_kin_jacobian(rb, pose, J, NULL) ? INFINITY : condition_number(J);
    return DM_OK;
}

/* What joint clearances do to each chain (dm_kin_play). */
typedef dm_kin_play chain_play;

static int forward_lb(const dm_robot *rb, int real, const double alpha[3], const chain_play *play,
                      double P[2][3]);

static int forward(const dm_robot *rb, int real, const double alpha[3], double P[2][3])
{
    chain_play none;
    memset(&none, 0, sizeof none);
    return forward_lb(rb, real, alpha, &none, P);
}

/* Forward kinematics with the chains' clearance play. */
static int forward_lb(const dm_robot *rb, int real, const double alpha[3], const chain_play *play,
                      double P[2][3])
{
    /* Each chain: |P - S_i| = lb_i with S_i = B_i - r_i e_i. Subtracting the
     * spheres pairwise gives two planes; their line meets sphere 0 in 0-2
     * points. */
    double S[3][3], e[3], t[3], lb2[3];
    for (int i = 0; i < 3; i++) {
        double A[3], B[3];
        chain_geom g;
        chain_geometry(rb, i, real, &g);
        chain_axes(&g, e, t);
        dm_scale3(g.R, e, A);
        elbow_at(&g, A, e, alpha[i] + g.alpha0, B);
        dm_axpy3(B, -g.r, e, S[i]);
        dm_axpy3(S[i], 1.0, play->shift[i], S[i]);
        lb2[i] = (g.lb + play->dlb[i]) * (g.lb + play->dlb[i]);
    }
    double n1[3], n2[3], dir[3];
    dm_sub3(S[1], S[0], n1);
    dm_sub3(S[2], S[0], n2);
    double c1 = 0.5 * (dm_dot3(S[1], S[1]) - dm_dot3(S[0], S[0]) - lb2[1] + lb2[0]);
    double c2 = 0.5 * (dm_dot3(S[2], S[2]) - dm_dot3(S[0], S[0]) - lb2[2] + lb2[0]);
    dm_cross3(n1, n2, dir);
    double dd = dm_dot3(dir, dir);
    if (dd == 0.0)
        return 0;
    /* point X0 on both planes: X0 = (c1 (n2 x dir) + c2 (dir x n1)) / |dir|^2 */
    double a1[3], a2[3], X0[3];
    dm_cross3(n2, dir, a1);
    dm_cross3(dir, n1, a2);
    for (int k = 0; k < 3; k++)
        X0[k] = (c1 * a1[k] + c2 * a2[k]) / dd;
    double w[3];
    dm_sub3(X0, S[0], w);
    double qa = dd, qb = 2.0 * dm_dot3(w, dir), qc = dm_dot3(w, w) - lb2[0];
    double disc = qb * qb - 4.0 * qa * qc;
    if (disc < 0)
        return 0;
    double s1 = (-qb - sqrt(disc)) / (2 * qa), s2 = (-qb + sqrt(disc)) / (2 * qa);
    dm_axpy3(X0, s1, dir, P[0]);
    dm_axpy3(X0, s2, dir, P[1]);
    if (P[0][2] > P[1][2]) {
        double tmp[3];
        dm_copy3(P[0], tmp);
        dm_copy3(P[1], P[0]);
        dm_copy3(tmp, P[1]);
    }
    return disc == 0 ? 1 : 2;
}

int dm_kin_forward(const dm_robot *rb, const double alpha[3], double P[2][3])
{
    return forward(rb, 0, alpha, P);
}

/* Rod forces N_i (tension > 0) from the platform's equilibrium
 * sum_i N_i u_i + W = 0, u_i the unit vector from C_i to B_i. */
static void rod_forces(const dm_pose *p, const double W[3], double N[3])
{
    double U[9], b[3];
    for (int i = 0; i < 3; i++) {
        double u[3];
        dm_sub3(p->B[i], p->C[i], u);
        dm_scale3(1.0 / dm_norm3(u), u, u);
        for (int k = 0; k < 3; k++)
            U[3 * k + i] = u[k]; /* row-major: column i = u_i */
        b[i] = -W[i];
    }
    lapack_int ipiv[3];
    if (LAPACKE_dgesv(LAPACK_ROW_MAJOR, 3, 1, U, 3, ipiv, b, 1))
        b[0] = b[1] = b[2] = 0;
    memcpy(N, b, sizeof b);
}

void dm_kin_platform_force(const dm_robot *rb, const double a[3], const double F[3], double W[3])
{
    double m = rb->platform_mass_kg + rb->effects.payload_kg;
    for (int k = 0; k < 3; k++)
        W[k] = m * (rb->gravity_ms2[k] - (a ? a[k] : 0)) + (F ? F[k] : 0);
}

int dm_kin_real_offset(const dm_robot *rb, const double P[3], const double a[3],
                       const double F[3], double offset[3])
{
    double W[3];
    dm_pose real;
    dm_kin_platform_force(rb, a, F, W);
    int found = dm_effects_geometry_errors(&rb->effects) &&
                !dm_kin_pose_loaded(rb, P, W, &real, NULL);
    for (int k = 0; k < 3; k++)
        offset[k] = found ? real.offset[k] : 0.0;
    return found;
}

int dm_kin_pose(const dm_robot *rb, const double P[3], dm_pose *pose, dm_error *err)
{
    double W[3];
    dm_kin_platform_force(rb, NULL, NULL, W);
    return dm_kin_pose_loaded(rb, P, W, pose, err);
}

/* Clearances open the way the joints are loaded (rod forces N from the
 * platform's equilibrium under W). Rod-end balls: each rod 2c longer in
 * tension, 2c shorter in compression. Actuator joint: the arm takes the
 * rods' pull F = -N u at its elbow; its revolute joint lets it slide by
 * c_axial along the axis t the way F.t points, and by c_radial across the
 * axis along F's part normal to t. */
static void clearance_play(const dm_robot *rb, const dm_pose *pose, const double W[3],
                           chain_play *play)
{
    const dm_effects *ef = &rb->effects;
    double N[3];
    rod_forces(pose, W, N);
    for (int i = 0; i < 3; i++) {
        double u[3], F[3], t[3], Fn[3];
        play->dlb[i] = 2 * ef->clearance_m * (N[i] >= 0 ? 1.0 : -1.0);
        dm_sub3(pose->B[i], pose->C[i], u);
        dm_scale3(-N[i] / dm_norm3(u), u, F);
        dm_copy3(pose->t[i], t);
        double Ft = dm_dot3(F, t);
        dm_axpy3(F, -Ft, t, Fn);
        double fn = dm_norm3(Fn);
        dm_scale3(ef->actuator_clearance_axial_m * (Ft >= 0 ? 1.0 : -1.0), t, play->shift[i]);
        if (fn > 0)
            dm_axpy3(play->shift[i], ef->actuator_clearance_radial_m / fn, Fn, play->shift[i]);
    }
}

/* The real closure: pose holds the nominal inverse kinematics at P; the
 * real arms turn to those angles (+ offset) and the platform goes where the
 * real chains, with their play, close (the solution nearest P). */
static int real_closure(const dm_robot *rb, const double P[3], const chain_play *play,
                        dm_pose *pose, dm_error *err)
{
    double sol[2][3], alpha[3];
    int n = forward_lb(rb, 1, pose->alpha, play, sol);
    if (n == 0)
        return dm_fail(err, DM_EUNREACHABLE,
                       "pose (%g, %g, %g) m: the real robot (with its geometry errors) cannot "
                       "close its chains there",
                       P[0], P[1], P[2]);
    double d0[3], d1[3];
    dm_sub3(sol[0], P, d0);
    dm_sub3(sol[1], P, d1);
    const double *real = n == 1 || dm_norm3(d0) <= dm_norm3(d1) ? sol[0] : sol[1];
    for (int i = 0; i < 3; i++) {
        chain_geom g;
        chain_geometry(rb, i, 1, &g);
        alpha[i] = pose->alpha[i] + g.alpha0;
    }
    place_chains(rb, 1, real, alpha, pose);
    dm_sub3(real, P, pose->offset);
    double J[9];
    pose->cond = dm_kin_jacobian(rb, pose, J, NULL) ? INFINITY : condition_number(J);
    return DM_OK;
}

int dm_kin_pose_loaded(const dm_robot *rb, const double P[3], const double W[3], dm_pose *pose,
                       dm_error *err)
{
    int rc = dm_kin_inverse(rb, P, pose, err);
    if (rc || !dm_effects_geometry_errors(&rb->effects))
        return rc;
    chain_play play;
    memset(&play, 0, sizeof play);
    if (dm_effects_clearance(&rb->effects))
        clearance_play(rb, pose, W, &play);
    return real_closure(rb, P, &play, pose, err);
}

int dm_kin_pose_play(const dm_robot *rb, const double P[3], const dm_kin_play *play,
                     dm_pose *pose, dm_error *err)
{
    int rc = dm_kin_inverse(rb, P, pose, err);
    return rc ? rc : real_closure(rb, P, play, pose, err);
}

/* Row i of J is L_i / (L_i . dB_i/dalpha_i), from d/dt |B_i - C_i|^2 = 0. */
int dm_kin_jacobian(const dm_robot *rb, const dm_pose *p, double J[9], dm_error *err)
{
    (void)rb; /* the pose carries its own (nominal or real) geometry */
    for (int i = 0; i < 3; i++) {
        double L[3], b1[3], b2[3];
        dm_sub3(p->B[i], p->C[i], L);
        elbow_derivatives(p, i, b1, b2);
        double den = dm_dot3(L, b1);
        if (fabs(den) <= 1e-12 * dm_norm3(L) * dm_norm3(b1))
            return dm_fail(err, DM_ENUMERIC, "chain %d is at a serial singularity", i);
        for (int k = 0; k < 3; k++)
            J[3 * i + k] = L[k] / den;
    }
    return DM_OK;
}

int dm_kin_rates(const dm_robot *rb, const dm_pose *p, const double v[3], double alpha_dot[3],
                 dm_error *err)
{
    double J[9];
    int rc = dm_kin_jacobian(rb, p, J, err);
    if (rc)
        return rc;
    for (int i = 0; i < 3; i++)
        alpha_dot[i] = dm_dot3(&J[3 * i], v);
    return DM_OK;
}

/* From d2/dt2 |B - C|^2 = 0:
 * |L_dot|^2 + L.(alpha_ddot b1 + alpha_dot^2 b2 - a) = 0. */
int dm_kin_accelerations(const dm_robot *rb, const dm_pose *p, const double v[3],
                         const double a[3], double alpha_ddot[3], dm_error *err)
{
    double ad[3];
    int rc = dm_kin_rates(rb, p, v, ad, err);
    if (rc)
        return rc;
    for (int i = 0; i < 3; i++) {
        double L[3], b1[3], b2[3], Ldot[3];
        dm_sub3(p->B[i], p->C[i], L);
        elbow_derivatives(p, i, b1, b2);
        for (int k = 0; k < 3; k++)
            Ldot[k] = ad[i] * b1[k] - v[k];
        alpha_ddot[i] = (dm_dot3(L, a) - ad[i] * ad[i] * dm_dot3(L, b2) - dm_dot3(Ldot, Ldot)) /
                        dm_dot3(L, b1);
    }
    return DM_OK;
}

void dm_kin_link_accelerations(const dm_pose *p, const double alpha_dot[3],
                               const double alpha_ddot[3], const double aP[3], dm_link_motion *m)
{
    dm_copy3(alpha_dot, m->alpha_dot);
    dm_copy3(alpha_ddot, m->alpha_ddot);
    dm_copy3(aP, m->aP);
    for (int i = 0; i < 3; i++) {
        double b1[3], b2[3], L[3], da[3];
        elbow_derivatives(p, i, b1, b2);
        double w = alpha_dot[i], wd = alpha_ddot[i];
        for (int k = 0; k < 3; k++) {
            m->aB[i][k] = wd * b1[k] + w * w * b2[k];
            m->arm_alpha[i][k] = wd * p->t[i][k];
        }
        /* Rods swing without spin: omega = L x (vC - vB)/|L|^2, L = C - B;
         * its rate is L x (aC - aB)/|L|^2 since L_dot x L_dot = 0. */
        dm_sub3(p->C[i], p->B[i], L);
        dm_sub3(aP, m->aB[i], da);
        dm_cross3(L, da, m->rod_alpha[i]);
        dm_scale3(1.0 / dm_dot3(L, L), m->rod_alpha[i], m->rod_alpha[i]);
    }
}

int dm_kin_link_motion(const dm_robot *rb, const dm_pose *p, const double v[3],
                       const double a[3], dm_link_motion *m, dm_error *err)
{
    memset(m, 0, sizeof *m);
    double w[3], wd[3];
    int rc = dm_kin_rates(rb, p, v, w, err);
    if (!rc)
        rc = dm_kin_accelerations(rb, p, v, a, wd, err);
    if (rc)
        return rc;
    dm_kin_link_accelerations(p, w, wd, a, m);
    dm_copy3(v, m->vP);
    for (int i = 0; i < 3; i++) {
        double b1[3], b2[3], L[3], dv[3];
        elbow_derivatives(p, i, b1, b2);
        for (int k = 0; k < 3; k++)
            m->vB[i][k] = w[i] * b1[k];
        dm_sub3(p->C[i], p->B[i], L);
        dm_sub3(v, m->vB[i], dv);
        dm_cross3(L, dv, m->rod_omega[i]);
        dm_scale3(1.0 / dm_dot3(L, L), m->rod_omega[i], m->rod_omega[i]);
    }
    return DM_OK;
}
