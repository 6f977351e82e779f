/* Kinematics: IK/FK round trip, analytic rates and accelerations against
 * central finite differences, unreachable poses, elbow branch. */
#include "dm_test.h"

#include "dm_kinematics.h"
#include "dm_vec3.h"

static const char *const PRESETS[] = {"chen2018", "zheng2017", "han2011"};

/* A few poses around each robot's home, inside its workspace. */
static void sample_pose(const dm_robot *rb, int k, double P[3])
{
    double s = 0.15 * rb->arm_length_m;
    const double off[5][3] = {{0, 0, 0}, {1, 0, 0}, {-0.3, 0.8, 0.5}, {0.5, -0.6, -0.4}, {0, 1, 0.2}};
    for (int d = 0; d < 3; d++)
        P[d] = rb->home_m[d] + s * off[k][d];
}

static void ik_fk_round_trip(void **state)
{
    (void)state;
    for (int r = 0; r < 3; r++) {
        dm_robot rb;
        assert_int_equal(dm_robot_load(PRESETS[r], &rb, NULL), 0);
        for (int k = 0; k < 5; k++) {
            double P[3], sol[2][3];
            dm_pose pose;
            sample_pose(&rb, k, P);
            assert_int_equal(dm_kin_inverse(&rb, P, &pose, NULL), 0);
            for (int i = 0; i < 3; i++) { /* every rod closes at length lb */
                double L[3];
                dm_sub3(pose.B[i], pose.C[i], L);
                assert_rel(dm_norm3(L), rb.rod_length_m, 1e-12, "%s rod %d length", PRESETS[r], i);
            }
            int n = dm_kin_forward(&rb, pose.alpha, sol);
            assert_true(n >= 1);
            double best = INFINITY;
            for (int s = 0; s < n; s++) {
                double d[3];
                dm_sub3(sol[s], P, d);
                best = fmin(best, dm_norm3(d));
            }
            assert_abs(best, 0.0, 1e-10, "%s pose %d: FK(IK(P)) == P (m)", PRESETS[r], k);
        }
    }
}

static void elbow_out_is_outer_root(void **state)
{
    (void)state;
    dm_robot rb;
    dm_pose out, in;
    assert_int_equal(dm_robot_load("chen2018", &rb, NULL), 0);
    assert_int_equal(dm_kin_inverse(&rb, rb.home_m, &out, NULL), 0);
    rb.elbow_in = 1;
    assert_int_equal(dm_kin_inverse(&rb, rb.home_m, &in, NULL), 0);
    for (int i = 0; i < 3; i++)
        assert_true(dm_dot3(out.B[i], out.e[i]) > dm_dot3(in.B[i], in.e[i]));
    /* chen2018 at its centre: alpha = 22.185 deg (hand computation in docs/model-choices.md) */
    assert_rel(out.alpha[0] * 180 / M_PI, 22.1846, 1e-4, "chen2018 home arm angle");
}

static void rates_match_finite_differences(void **state)
{
    (void)state;
    for (int r = 0; r < 3; r++) {
        dm_robot rb;
        assert_int_equal(dm_robot_load(PRESETS[r], &rb, NULL), 0);
        const double v[3] = {0.7, -0.4, 0.3}, a[3] = {-5.0, 8.0, 3.0};
        double P[3], ad[3], add[3], h = 1e-5;
        dm_pose p0, pp, pm;
        sample_pose(&rb, 2, P);
        assert_int_equal(dm_kin_inverse(&rb, P, &p0, NULL), 0);
        assert_int_equal(dm_kin_rates(&rb, &p0, v, ad, NULL), 0);
        assert_int_equal(dm_kin_accelerations(&rb, &p0, v, a, add, NULL), 0);
        /* P(t) = P + v t + a t^2/2: central differences in t */
        double Pp[3], Pm[3];
        for (int d = 0; d < 3; d++) {
            Pp[d] = P[d] + v[d] * h + 0.5 * a[d] * h * h;
            Pm[d] = P[d] - v[d] * h + 0.5 * a[d] * h * h;
        }
        assert_int_equal(dm_kin_inverse(&rb, Pp, &pp, NULL), 0);
        assert_int_equal(dm_kin_inverse(&rb, Pm, &pm, NULL), 0);
        for (int i = 0; i < 3; i++) {
            double fd1 = (pp.alpha[i] - pm.alpha[i]) / (2 * h);
            double fd2 = (pp.alpha[i] - 2 * p0.alpha[i] + pm.alpha[i]) / (h * h);
            /* O(h^2) truncation ~1e-9 relative; second differences lose ~1e-16/h^2 = 1e-6 */
            assert_rel(ad[i], fd1, 1e-7, "%s alpha_dot[%d]", PRESETS[r], i);
            assert_rel(add[i], fd2, 1e-4, "%s alpha_ddot[%d]", PRESETS[r], i);
        }
    }
}

static void link_motion_is_rigid(void **state)
{
    (void)state;
    dm_robot rb;
    dm_pose p0, pp, pm;
    dm_link_motion m;
    assert_int_equal(dm_robot_load("zheng2017", &rb, NULL), 0);
    double P[3], h = 1e-5;
    const double v[3] = {0.3, 0.5, -0.2}, a[3] = {4.0, -2.0, 6.0};
    sample_pose(&rb, 3, P);
    assert_int_equal(dm_kin_inverse(&rb, P, &p0, NULL), 0);
    assert_int_equal(dm_kin_link_motion(&rb, &p0, v, a, &m, NULL), 0);
    double Pp[3], Pm[3];
    for (int d = 0; d < 3; d++) {
        Pp[d] = P[d] + v[d] * h + 0.5 * a[d] * h * h;
        Pm[d] = P[d] - v[d] * h + 0.5 * a[d] * h * h;
    }
    assert_int_equal(dm_kin_inverse(&rb, Pp, &pp, NULL), 0);
    assert_int_equal(dm_kin_inverse(&rb, Pm, &pm, NULL), 0);
    for (int i = 0; i < 3; i++)
        for (int d = 0; d < 3; d++) {
            double vB = (pp.B[i][d] - pm.B[i][d]) / (2 * h);
            double aB = (pp.B[i][d] - 2 * p0.B[i][d] + pm.B[i][d]) / (h * h);
            assert_abs(m.vB[i][d], vB, 1e-8, "elbow velocity chain %d comp %d (m/s)", i, d);
            assert_abs(m.aB[i][d], aB, 1e-4, "elbow acceleration chain %d comp %d (m/s^2)", i, d);
        }
    /* Rod angular velocity: dL/dt == omega x L for the rod vector L = C - B. */
    for (int i = 0; i < 3; i++) {
        double Lp[3], Lm[3], L[3], oxL[3];
        dm_sub3(pp.C[i], pp.B[i], Lp);
        dm_sub3(pm.C[i], pm.B[i], Lm);
        dm_sub3(p0.C[i], p0.B[i], L);
        dm_cross3(m.rod_omega[i], L, oxL);
        for (int d = 0; d < 3; d++)
            assert_abs(oxL[d], (Lp[d] - Lm[d]) / (2 * h), 1e-8, "rod %d dL/dt", i);
        assert_abs(dm_dot3(m.rod_omega[i], L), 0.0, 1e-12, "rod %d has no spin", i);
    }
}

static void unreachable_is_detected(void **state)
{
    (void)state;
    dm_robot rb;
    dm_pose pose;
    dm_error err;
    assert_int_equal(dm_robot_load("han2011", &rb, NULL), 0);
    const double above[3] = {0, 0, 1.2}, ok[3] = {0, 0, 1.0}, far[3] = {3.0, 0, 0.9};
    assert_int_equal(dm_kin_inverse(&rb, ok, &pose, NULL), 0);
    assert_int_equal(dm_kin_inverse(&rb, above, &pose, &err), DM_EUNREACHABLE);
    assert_non_null(strstr(err.msg, "unreachable"));
    assert_int_equal(dm_kin_inverse(&rb, far, &pose, &err), DM_EUNREACHABLE);
}

static void condition_number_symmetric_centre(void **state)
{
    (void)state;
    dm_robot rb;
    dm_pose pose;
    double J[9];
    assert_int_equal(dm_robot_load("chen2018", &rb, NULL), 0);
    assert_int_equal(dm_kin_inverse(&rb, rb.home_m, &pose, NULL), 0);
    assert_int_equal(dm_kin_jacobian(&rb, &pose, J, NULL), 0);
    assert_true(pose.cond >= 1.0 && pose.cond < 10.0);
    /* Near the side boundary one chain's arm and rod align first, its row of J
     * grows without bound and so does cond(J). (At the symmetric bottom point
     * all rows grow alike and cond(J) stays finite.) */
    double in = 0.0, out = 1.5; /* bisect along x at the home height */
    for (int it = 0; it < 60; it++) {
        double mid[3] = {0.5 * (in + out), 0, rb.home_m[2]};
        if (dm_kin_inverse(&rb, mid, &pose, NULL) == DM_OK)
            in = mid[0];
        else
            out = mid[0];
    }
    double edge[3] = {in - 1e-7, 0, rb.home_m[2]};
    assert_int_equal(dm_kin_inverse(&rb, edge, &pose, NULL), 0);
    assert_true(pose.cond > 50.0);
    assert_true(pose.cond > rb.singular_cond); /* flagged near-singular */
}

/* Geometry errors: without them the real pose is the commanded one; with
 * them every real chain closes with its real lengths; a mounting rotated by
 * the same angle on all chains rotates the whole robot about Z. */
static void geometry_errors_move_the_platform(void **state)
{
    (void)state;
    dm_robot rb;
    dm_pose nom, real;
    const double P[3] = {0.04, -0.03, -0.45};
    assert_int_equal(dm_robot_load("chen2018", &rb, NULL), 0);
    assert_int_equal(dm_kin_pose(&rb, P, &real, NULL), 0);
    assert_int_equal(dm_kin_inverse(&rb, P, &nom, NULL), 0);
    assert_memory_equal(&real, &nom, sizeof real);
    assert_int_equal(dm_robot_set(&rb, "effects.error_theta_deg=0.5,0.5,0.5", NULL), 0);
    assert_int_equal(dm_kin_pose(&rb, P, &real, NULL), 0);
    double c = cos(0.5 * M_PI / 180), s = sin(0.5 * M_PI / 180);
    const double rot[3] = {c * P[0] - s * P[1], s * P[0] + c * P[1], P[2]};
    for (int k = 0; k < 3; k++)
        assert_abs(real.P[k], rot[k], 1e-12, "rotated mounting rotates the platform, comp %d", k);
    assert_int_equal(dm_robot_set(&rb, "effects.error_theta_deg=0,0,0", NULL), 0);
    assert_int_equal(dm_robot_set(&rb, "effects.error_arm_length=0.002,-0.001,0", NULL), 0);
    assert_int_equal(dm_robot_set(&rb, "effects.error_rod_length=0,0.001,-0.002", NULL), 0);
    assert_int_equal(dm_robot_set(&rb, "effects.error_alpha0_deg=0.1,0,-0.2", NULL), 0);
    assert_int_equal(dm_robot_set(&rb, "effects.error_platform_radius=0.001,0,0", NULL), 0);
    assert_int_equal(dm_kin_pose(&rb, P, &real, NULL), 0);
    assert_int_equal(dm_kin_inverse(&rb, P, &nom, NULL), 0);
    const double dla[3] = {0.002, -0.001, 0}, dlb[3] = {0, 0.001, -0.002}, da[3] = {0.1, 0, -0.2};
    for (int i = 0; i < 3; i++) {
        double L[3], arm[3];
        dm_sub3(real.B[i], real.C[i], L);
        dm_sub3(real.B[i], real.A[i], arm);
        assert_rel(dm_norm3(L), rb.rod_length_m + dlb[i], 1e-12, "real rod %d closes", i);
        assert_rel(dm_norm3(arm), rb.arm_length_m + dla[i], 1e-12, "real arm %d length", i);
        assert_abs(real.alpha[i], nom.alpha[i] + da[i] * M_PI / 180, 1e-15, "actuator offset %d", i);
    }
    assert_true(dm_norm3(real.offset) > 1e-4 && dm_norm3(real.offset) < 1e-2);
}

/* Clearance: a hanging robot's rods are in tension under the platform's
 * weight, every rod is 2c longer and the platform drops by 2c / |u_z| at the
 * centre (u: rod direction); pushed up harder than its weight, it rises as
 * much. */
static void clearance_follows_the_load(void **state)
{
    (void)state;
    dm_robot rb;
    dm_pose down, up, nom;
    const double c = 20e-6;
    assert_int_equal(dm_robot_load("chen2018", &rb, NULL), 0);
    assert_int_equal(dm_robot_set(&rb, "effects.clearance=20e-6", NULL), 0);
    assert_int_equal(dm_kin_inverse(&rb, rb.home_m, &nom, NULL), 0);
    double u[3];
    dm_sub3(nom.B[0], nom.C[0], u);
    double uz = fabs(u[2]) / dm_norm3(u);
    const double Wdown[3] = {0, 0, -2.0}, Wup[3] = {0, 0, 30.0};
    assert_int_equal(dm_kin_pose_loaded(&rb, rb.home_m, Wdown, &down, NULL), 0);
    assert_int_equal(dm_kin_pose_loaded(&rb, rb.home_m, Wup, &up, NULL), 0);
    /* first order in c: the exact geometry differs by O(c^2 / lb) */
    assert_rel(down.offset[2], -2 * c / uz, 1e-3, "drop under tension");
    assert_rel(up.offset[2], 2 * c / uz, 1e-3, "rise under compression");
    assert_abs(down.offset[0], 0.0, 1e-12, "no sideways shift at the centre");
}

/* 3x3 solve by Cramer's rule (row-major A): independent of the library. */
static void solve3(const double A[9], const double b[3], double x[3])
{
    double det = A[0] * (A[4] * A[8] - A[5] * A[7]) - A[1] * (A[3] * A[8] - A[5] * A[6]) +
                 A[2] * (A[3] * A[7] - A[4] * A[6]);
    for (int c = 0; c < 3; c++) {
        double M[9];
        memcpy(M, A, sizeof M);
        for (int r = 0; r < 3; r++)
            M[3 * r + c] = b[r];
        x[c] = (M[0] * (M[4] * M[8] - M[5] * M[7]) - M[1] * (M[3] * M[8] - M[5] * M[6]) +
                M[2] * (M[3] * M[7] - M[4] * M[6])) / det;
    }
}

/* Actuator-joint clearance: each arm slides by d_i = c_a sign(F.t) t
 * (axial) or c_r F_n / |F_n| (radial), F = -N u the rods' pull on the
 * elbow, N from the platform's equilibrium. To first order the chains close
 * where u_i . dP = u_i . d_i. Off the centre (there u.t = 0), under a
 * load with a sideways part, and reversed when the load is. */
static void actuator_clearance_follows_the_load(void **state)
{
    (void)state;
    const char *keys[2] = {"effects.actuator_clearance_axial=20e-6",
                           "effects.actuator_clearance_radial=20e-6"};
    const double c = 20e-6;
    for (int kind = 0; kind < 2; kind++)
        for (int flip = 0; flip < 2; flip++) {
            dm_robot rb;
            dm_pose nom, real;
            assert_int_equal(dm_robot_load("zheng2017", &rb, NULL), 0);
            assert_int_equal(dm_robot_set(&rb, keys[kind], NULL), 0);
            const double P[3] = {rb.home_m[0] + 0.05, rb.home_m[1] + 0.03, rb.home_m[2]};
            const double s = flip ? -1 : 1, W[3] = {8 * s, -5 * s, -30 * s};
            assert_int_equal(dm_kin_inverse(&rb, P, &nom, NULL), 0);
            assert_int_equal(dm_kin_pose_loaded(&rb, P, W, &real, NULL), 0);
            double U[9], u[3][3], N[3], mW[3] = {-W[0], -W[1], -W[2]}, b[3], dP[3];
            for (int i = 0; i < 3; i++) {
                dm_sub3(nom.B[i], nom.C[i], u[i]);
                dm_scale3(1 / dm_norm3(u[i]), u[i], u[i]);
                for (int k = 0; k < 3; k++)
                    U[3 * k + i] = u[i][k]; /* columns u_i: sum N_i u_i = -W */
            }
            solve3(U, mW, N);
            for (int i = 0; i < 3; i++) {
                double F[3], Fn[3], d[3];
                dm_scale3(-N[i], u[i], F);
                double Ft = dm_dot3(F, nom.t[i]);
                assert_true(fabs(Ft) > 1e-3 * dm_norm3(F)); /* the axial sign is defined */
                dm_axpy3(F, -Ft, nom.t[i], Fn);
                if (kind == 0)
                    dm_scale3(c * (Ft > 0 ? 1 : -1), nom.t[i], d);
                else
                    dm_scale3(c / dm_norm3(Fn), Fn, d);
                b[i] = dm_dot3(u[i], d);
                for (int k = 0; k < 3; k++)
                    U[3 * i + k] = u[i][k]; /* rows u_i: u_i . dP = u_i . d_i */
            }
            solve3(U, b, dP);
            for (int k = 0; k < 3; k++) /* first order in c: O(c^2 / lb) left */
                assert_abs(real.offset[k], dP[k], 1e-3 * dm_norm3(dP), "%s, load %+g, axis %d",
                           keys[kind], s, k);
            assert_true(dm_norm3(dP) > 0.05 * c); /* axial: ~0.1 c here (rods nearly normal to t) */
        }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(ik_fk_round_trip),
        cmocka_unit_test(elbow_out_is_outer_root),
        cmocka_unit_test(rates_match_finite_differences),
        cmocka_unit_test(link_motion_is_rigid),
        cmocka_unit_test(unreachable_is_detected),
        cmocka_unit_test(condition_number_symmetric_centre),
        cmocka_unit_test(geometry_errors_move_the_platform),
        cmocka_unit_test(clearance_follows_the_load),
        cmocka_unit_test(actuator_clearance_follows_the_load),
    };
    return cmocka_run_group_tests_name("kinematics", tests, NULL, NULL);
}
