/* The statics from member bases (dm_boundary, issue 39 step 2) against
 * an extended-precision solve (and beside the full model's factor):
 * static error, compliance, ln det K and the whole static displacement,
 * for the three presets at meshes 1,1, 4,4 and 8,8, without and with
 * every pose-free effect; the fallback to the full model under geometric
 * stiffness; the Wittrick-Williams count against the dense inertia, and
 * the reduced modes with their certified bounds (step 3). */
#include "dm_test.h"

#include <lapacke.h>
#include <stdlib.h>

#include "dm_boundary.h"
#include "dm_loads.h"
#include "dm_members_fixtures.h"
#include "dm_reference.h"

/* The full model's statics at a pose (deltamap's arrow Cholesky). */
static void full_solve(dm_model *md, dm_static *st, const dm_pose *pose, dm_boundary_statics *f)
{
    assert_int_equal(dm_model_build(md, pose, NULL), 0);
    assert_int_equal(dm_static_factor(st, md, NULL), 0);
    assert_int_equal(dm_static_platform_error(st, md, md->F_gravity, f->static_error, NULL), 0);
    assert_int_equal(dm_static_compliance(st, md, f->compliance, NULL), 0);
    f->logdet_K = dm_static_logdet(st);
}

/* The exact answers at a pose: K^-1 [F, platform unit loads] and ln det K
 * in long double (dm_reference.h) from the dense K, and LAPACK's bound
 * for a backward-stable Cholesky solve of that K (LUG §4.4). */
typedef struct {
    int n, p;
    double *x;   /* n x 7: displacement under gravity, then the six compliance columns */
    double W;    /* F' K^-1 F */
    double logdet;
    dm_solve_bound bound;
} reference;

static void reference_at(const dm_model *md, reference *ref)
{
    int n = md->n, p = md->platform_dof;
    double *K = malloc(sizeof(double) * n * n), *B = calloc((size_t)n * 7, sizeof(double));
    ldbl *X = malloc(sizeof(ldbl) * n * 7), *L = malloc(sizeof(ldbl) * n * n);
    assert_true(K && B && X && L);
    dm_model_dense(md, K, NULL);
    memcpy(B, md->F_gravity, sizeof(double) * n);
    for (int j = 0; j < 6; j++)
        B[(size_t)(j + 1) * n + p + j] = 1.0;
    assert_int_equal(dm_reference_solve(K, n, B, 7, X), 0);
    for (size_t k = 0; k < (size_t)n * n; k++)
        L[k] = K[k];
    assert_int_equal(ref_cholesky(L, n), 0);
    ldbl logdet = 0, W = 0;
    for (int k = 0; k < n; k++) {
        logdet += 2 * logl(L[(size_t)k * n + k]);
        W += (ldbl)md->F_gravity[k] * X[k];
    }
    ref->n = n;
    ref->p = p;
    ref->x = malloc(sizeof(double) * n * 7);
    for (size_t k = 0; k < (size_t)n * 7; k++)
        ref->x[k] = (double)X[k];
    ref->W = (double)W;
    ref->logdet = (double)logdet;
    assert_int_equal(dm_solve_bound_init(K, n, 1, &ref->bound), 0);
    free(K);
    free(B);
    free(X);
    free(L);
}

/* Worst errors against the reference, each scaled by what bounds the
 * quantity (Cauchy-Schwarz, K^-1 SPD): |C_jk| <= sqrt(C_jj C_kk),
 * |u_j| <= sqrt(C_jj W) at the platform, the whole displacement by its
 * largest entry, ln det K by itself; `lapack` counts the values whose
 * error exceeded 1e-10 of that scale but stayed within LAPACK's bound. */
typedef struct {
    double C, u6, u, logdet;
    int lapack, values;
} errors;

/* |got - exact| <= max(1e-10 scale, LAPACK's bound for component i of
 * column col). */
static void check(errors *e, double *worst, const reference *ref, int col, int i, double got,
                  double scale)
{
    const double *x = ref->x + (size_t)col * ref->n;
    double d = fabs(got - x[i]), bound = dm_solve_bound_at(&ref->bound, x, i);
    if (!(d <= fmax(1e-10 * scale, bound)))
        print_error("column %d, DOF %d: %.17g, exact %.17g, error %.2e > 1e-10 x %.2e and "
                    "LAPACK's %.2e\n", col, i, got, x[i], d, scale, bound);
    assert_true(d <= fmax(1e-10 * scale, bound));
    e->lapack += d > 1e-10 * scale;
    e->values++;
    *worst = fmax(*worst, d / scale);
}

static void compare(const reference *ref, const dm_boundary_statics *b, const double *u,
                    errors *e)
{
    int n = ref->n, p = ref->p;
    double C[6];
    for (int j = 0; j < 6; j++)
        C[j] = ref->x[(size_t)(j + 1) * n + p + j];
    for (int j = 0; j < 6; j++) {
        check(e, &e->u6, ref, 0, p + j, b->static_error[j], sqrt(C[j] * ref->W));
        for (int k = 0; k < 6; k++)
            check(e, &e->C, ref, k + 1, p + j, b->compliance[6 * k + j], sqrt(C[j] * C[k]));
    }
    double umax = 0;
    for (int k = 0; k < n; k++)
        umax = fmax(umax, fabs(ref->x[k]));
    for (int k = 0; u && k < n; k++)
        check(e, &e->u, ref, 0, k, u[k], umax);
    double d = fabs(b->logdet_K - ref->logdet) / fabs(ref->logdet);
    assert_true(d <= 1e-10);
    e->logdet = fmax(e->logdet, d);
}

/* One robot at one mesh: home and 3 random poses; the boundary engine
 * (eb) and the full solve (ef) against the same reference. */
static void one_case(const char *preset, int na, int nb, int effects, dm_rng *rng, errors *eb,
                     errors *ef)
{
    dm_robot rb;
    dm_pose pose;
    load(&rb, preset, effects ? ALL_EFFECTS : NULL);
    dm_model *md = dm_model_alloc(&rb, na, nb, NULL);
    assert_non_null(md);
    dm_static *st = dm_static_alloc(md, NULL);
    assert_non_null(st);
    assert_int_equal(dm_kin_pose(&rb, rb.home_m, &pose, NULL), 0);
    assert_int_equal(dm_model_build(md, &pose, NULL), 0);
    dm_members *ms = dm_members_build(md, 0, NULL);
    assert_non_null(ms);
    dm_boundary *bw = dm_boundary_alloc(ms, NULL);
    assert_non_null(bw);
    double *u = malloc(sizeof(double) * md->n);
    for (int t = 0; t < 4; t++) {
        if (t)
            random_pose(&rb, rng, &pose);
        dm_boundary_statics b, f;
        reference ref;
        assert_int_equal(dm_boundary_solve(bw, &pose, &b, NULL), 0);
        assert_int_equal(b.full, 0);
        dm_boundary_displacement(bw, u);
        full_solve(md, st, &pose, &f);
        reference_at(md, &ref);
        compare(&ref, &b, u, eb);
        compare(&ref, &f, NULL, ef);
        free(ref.x);
        dm_solve_bound_free(&ref.bound);
    }
    free(u);
    dm_boundary_free(bw);
    dm_members_free(ms);
    dm_static_free(st);
    dm_model_free(md);
}

/* Both engines against the long-double reference: within 1e-10 of each
 * quantity's scale, or, where K's condition allows no better (soft
 * springs at fine meshes), within LAPACK's bound for any backward-stable
 * solve; ln det K within 1e-10. The worst figures of both are printed. */
static void statics_equal_the_exact_solve(void **state)
{
    (void)state;
    const char *presets[] = {"chen2018", "zheng2017", "han2011"};
    const int meshes[3][2] = {{1, 1}, {4, 4}, {8, 8}};
    dm_rng rng = {2026};
    errors eb[2] = {{0}}, ef[2] = {{0}};
    for (int r = 0; r < 3; r++)
        for (int m = 0; m < 3; m++)
            for (int fx = 0; fx < 2; fx++)
                one_case(presets[r], meshes[m][0], meshes[m][1], fx, &rng, &eb[fx], &ef[fx]);
    for (int fx = 0; fx < 2; fx++) {
        print_message("%s: members: compliance %.2e, static error %.2e, displacement %.2e, "
                      "ln det K %.2e; %d of %d values past 1e-10 (within LAPACK's bound)\n",
                      fx ? "all effects" : "no effects", eb[fx].C, eb[fx].u6, eb[fx].u,
                      eb[fx].logdet, eb[fx].lapack, eb[fx].values);
        print_message("             full:    compliance %.2e, static error %.2e, ln det K %.2e; "
                      "%d of %d past 1e-10\n",
                      ef[fx].C, ef[fx].u6, ef[fx].logdet, ef[fx].lapack, ef[fx].values);
    }
}

/* Geometric stiffness: no member cache can be built, so the caller has
 * none and the full model serves (res.full); its numbers are the full
 * solve's, bit for bit. Without it the members serve. */
static void geometric_stiffness_falls_back(void **state)
{
    (void)state;
    const char *on[] = {"effects.geometric_stiffness=on", NULL};
    for (int gs = 0; gs < 2; gs++) {
        dm_robot rb;
        dm_pose pose;
        dm_rng rng = {99};
        load(&rb, "chen2018", gs ? on : NULL);
        dm_model *md = dm_model_alloc(&rb, 4, 4, NULL);
        dm_static *st = md ? dm_static_alloc(md, NULL) : NULL;
        assert_non_null(st);
        random_pose(&rb, &rng, &pose);
        assert_int_equal(dm_model_build(md, &pose, NULL), 0);
        dm_members *ms = dm_members_build(md, 0, NULL);
        assert_true((ms == NULL) == gs);
        dm_boundary *bw = ms ? dm_boundary_alloc(ms, NULL) : NULL;
        dm_boundary_statics b, f;
        assert_int_equal(dm_boundary_statics_or_full(bw, md, st, &pose, &b, NULL), 0);
        assert_int_equal(b.full, gs);
        full_solve(md, st, &pose, &f);
        if (gs) {
            assert_memory_equal(b.static_error, f.static_error, sizeof b.static_error);
            assert_memory_equal(b.compliance, f.compliance, sizeof b.compliance);
            assert_true(b.logdet_K == f.logdet_K);
        } else {
            assert_rel(b.static_error[2], f.static_error[2], 1e-10, "dz through the members");
        }
        dm_boundary_free(bw);
        dm_members_free(ms);
        dm_static_free(st);
        dm_model_free(md);
    }
}

/* Negative eigenvalues of K - sigma M (dense, LAPACK's LDL'): Sylvester's
 * inertia, the oracle of the count. */
static int dense_inertia(const double *K, const double *M, int n, double sigma)
{
    double *A = malloc(sizeof(double) * n * n);
    lapack_int *ipiv = malloc(sizeof(lapack_int) * n);
    for (size_t k = 0; k < (size_t)n * n; k++)
        A[k] = K[k] - sigma * M[k];
    assert_int_equal(LAPACKE_dsytrf(LAPACK_COL_MAJOR, 'L', n, A, n, ipiv), 0);
    int neg = 0;
    for (int k = 0; k < n; k++) {
        double a = A[(size_t)k * n + k];
        if (ipiv[k] > 0) {
            neg += a < 0;
            continue;
        }
        double b = A[(size_t)k * n + k + 1], c = A[(size_t)(k + 1) * n + k + 1];
        neg += a * c - b * b < 0 ? 1 : (a + c < 0 ? 2 : 0);
        k++;
    }
    free(A);
    free(ipiv);
    return neg;
}

/* The Wittrick-Williams count equals the dense inertia of K - sigma M and
 * the long-double reference's count: just below and above each of the 16
 * lowest eigenvalues (1e-8 of it: the counts resolve ~1e-10, measured)
 * and at 12 random shifts below lambda_16, at a random pose of each
 * preset and mesh. */
static void count_equals_dense_inertia(void **state)
{
    (void)state;
    const char *presets[] = {"chen2018", "zheng2017", "han2011"};
    const int meshes[3] = {1, 4, 8};
    dm_rng rng = {31};
    for (int r = 0; r < 3; r++)
        for (int me = 0; me < 3; me++) {
            dm_robot rb;
            dm_pose pose;
            dm_boundary_statics b;
            load(&rb, presets[r], NULL);
            dm_model *md = dm_model_alloc(&rb, meshes[me], meshes[me], NULL);
            assert_non_null(md);
            random_pose(&rb, &rng, &pose);
            assert_int_equal(dm_model_build(md, &pose, NULL), 0);
            dm_members *ms = dm_members_build(md, 0, NULL);
            dm_boundary *bw = ms ? dm_boundary_alloc(ms, NULL) : NULL;
            assert_non_null(bw);
            assert_int_equal(dm_boundary_solve(bw, &pose, &b, NULL), 0);
            int n = md->n;
            double *K = malloc(sizeof(double) * n * n), *M = malloc(sizeof(double) * n * n);
            ldbl lam[16];
            dm_model_dense(md, K, M);
            assert_int_equal(dm_reference_eigen(K, M, n, 16, lam, NULL), 0);
            for (int t = 0; t < 44; t++) {
                double sigma = t < 32 ? (double)lam[t / 2] * (t % 2 ? 1 + 1e-8 : 1 - 1e-8)
                                      : (double)lam[15] * dm_rng_uniform(&rng);
                int count, exact = 0;
                for (int j = 0; j < 16; j++)
                    exact += lam[j] < sigma;
                assert_int_equal(dm_boundary_count(bw, sigma, &count, NULL), 0);
                assert_int_equal(count, dense_inertia(K, M, n, sigma));
                assert_int_equal(count, exact);
            }
            free(K);
            free(M);
            dm_boundary_free(bw);
            dm_members_free(ms);
            dm_model_free(md);
        }
}

/* The 14 lowest eigenvalues from the members (the rule's bases, made at
 * home) against the long-double reference at home and 2 random poses:
 * within 1e-10, or where the pair's condition allows no better (the
 * all-effects set's soft actuators: dense dsygvd on the full pair is off
 * by 1.5e-10 there too) within LAPACK's bound for a dense solve; each
 * certified bound covers the true error up to that same bound (the
 * eigenvalue's own sensitivity to rounding, which the counts share: with
 * the soft actuators at 8,8 they err at 1e-9 of a 1.6 Hz mode); with a
 * poor basis (no fixed-interface mode kept) the bounds grow to cover
 * errors of 1e-3. */
static void reduced_modes_are_certified(void **state)
{
    (void)state;
    const char *presets[] = {"chen2018", "zheng2017", "han2011"};
    const int meshes[3] = {1, 4, 8};
    enum { K14 = 14 };
    dm_rng rng = {77};
    double worst[2] = {0}, worst_bound = 0, poor = 0;
    int lapack[2] = {0};
    for (int r = 0; r < 3; r++)
        for (int me = 0; me < 3; me++)
            for (int fx = 0; fx < 2; fx++) {
                dm_robot rb;
                dm_pose pose;
                load(&rb, presets[r], fx ? ALL_EFFECTS : NULL);
                dm_model *md = dm_model_alloc(&rb, meshes[me], meshes[me], NULL);
                assert_non_null(md);
                assert_int_equal(dm_kin_pose(&rb, rb.home_m, &pose, NULL), 0);
                assert_int_equal(dm_model_build(md, &pose, NULL), 0);
                dm_members *ms = dm_boundary_members_for_modes(md, K14, NULL);
                dm_members *bad = dm_members_build(md, 0, NULL);
                assert_true(ms && bad);
                dm_boundary *bw = dm_boundary_alloc(ms, NULL), *bb = dm_boundary_alloc(bad, NULL);
                int n = md->n;
                double *K = malloc(sizeof(double) * n * n), *M = malloc(sizeof(double) * n * n);
                for (int t = 0; t < 3; t++) {
                    dm_boundary_statics st;
                    double lam[K14], bound[K14];
                    ldbl ref[K14];
                    if (t) {
                        random_pose(&rb, &rng, &pose);
                        assert_int_equal(dm_model_build(md, &pose, NULL), 0);
                    }
                    dm_sygv_bound sb;
                    dm_model_dense(md, K, M);
                    assert_int_equal(dm_reference_eigen(K, M, n, K14, ref, NULL), 0);
                    assert_int_equal(dm_sygv_bound_init(K, M, n, &sb), 0);
                    for (int pass = 0; pass < 2; pass++) {
                        dm_boundary *w = pass ? bb : bw;
                        assert_int_equal(dm_boundary_solve(w, &pose, &st, NULL), 0);
                        assert_int_equal(dm_boundary_reduced_modes(w, K14, lam, NULL), 0);
                        assert_int_equal(dm_boundary_bounds(w, K14, lam, bound, NULL), 0);
                        for (int j = 0; j < K14; j++) {
                            double e = lam[j] - (double)ref[j];
                            double sens = dm_sygv_eerrbd(&sb, (double)ref[j]);
                            if (!(bound[j] + sens >= fabs(e)))
                                print_error("%s %d,%d effects %d pose %d basis %d mode %d: "
                                            "lambda %.17g exact %.17g bound %.2e\n",
                                            presets[r], meshes[me], meshes[me], fx, t, pass, j,
                                            lam[j], (double)ref[j], bound[j]);
                            assert_true(bound[j] + sens >= fabs(e));
                            if (pass) {
                                poor = fmax(poor, fabs(e) / (double)ref[j]);
                                continue;
                            }
                            double allowed = fmax(1e-10 * (double)ref[j], sens);
                            worst[fx] = fmax(worst[fx], fabs(e) / (double)ref[j]);
                            worst_bound = fmax(worst_bound, bound[j] / lam[j]);
                            lapack[fx] += fabs(e) > 1e-10 * (double)ref[j];
                            if (!(fabs(e) <= allowed))
                                print_error("%s %d,%d effects %d pose %d mode %d: rel err %.2e\n",
                                            presets[r], meshes[me], meshes[me], fx, t, j,
                                            e / (double)ref[j]);
                            assert_true(fabs(e) <= allowed);
                        }
                    }
                }
                free(K);
                free(M);
                dm_boundary_free(bw);
                dm_boundary_free(bb);
                dm_members_free(ms);
                dm_members_free(bad);
                dm_model_free(md);
            }
    print_message("14 lowest from the members: worst error %.2e without effects (%d of %d past "
                  "1e-10), %.2e with all (%d of %d past 1e-10, within LAPACK's bound for the "
                  "dense pair); worst certified bound %.2e; a poor basis: error %.2e, covered by "
                  "its bounds\n",
                  worst[0], lapack[0], 3 * 3 * 3 * K14, worst[1], lapack[1], 3 * 3 * 3 * K14,
                  worst_bound, poor);
    assert_true(poor > 1e-6); /* the poor basis really is poor: its bounds were exercised */
}

/* x' M y for the dense column-major M. */
static double m_product(const double *M, int n, const double *x, const double *y)
{
    double s = 0;
    for (int c = 0; c < n; c++) {
        double mc = 0;
        for (int r = 0; r < n; r++)
            mc += M[(size_t)c * n + r] * x[r];
        s += mc * y[c];
    }
    return s;
}

/* The mode shapes recovered from the rule's member bases against the
 * long-double reference's vectors at 2 random poses of each preset at
 * meshes 4,4 and 8,8: M-normalised (1e-10), and each lies in its
 * reference cluster (eigenvalues within 1e-3 of each other: the robot's
 * near-symmetric pairs) to 1 - 1e-8 in the M-inner product, the cluster
 * MAC sum_b (phi_a' M phi_ref,b)^2. */
static void mode_shapes_match_the_reference(void **state)
{
    (void)state;
    const char *presets[] = {"chen2018", "zheng2017", "han2011"};
    enum { K14 = 14 };
    dm_rng rng = {5};
    double worst = 0;
    for (int r = 0; r < 3; r++)
        for (int mesh = 4; mesh <= 8; mesh += 4) {
            dm_robot rb;
            dm_pose pose;
            load(&rb, presets[r], NULL);
            dm_model *md = dm_model_alloc(&rb, mesh, mesh, NULL);
            assert_non_null(md);
            assert_int_equal(dm_kin_pose(&rb, rb.home_m, &pose, NULL), 0);
            assert_int_equal(dm_model_build(md, &pose, NULL), 0);
            dm_members *ms = dm_boundary_members_for_modes(md, K14, NULL);
            dm_boundary *bw = ms ? dm_boundary_alloc(ms, NULL) : NULL;
            assert_non_null(bw);
            int n = md->n;
            double *K = malloc(sizeof(double) * n * n), *M = malloc(sizeof(double) * n * n);
            double *phi = malloc(sizeof(double) * n * K14), *ref = malloc(sizeof(double) * n * K14);
            for (int t = 0; t < 2; t++) {
                dm_boundary_statics st;
                double lam[K14];
                ldbl rl[K14];
                random_pose(&rb, &rng, &pose);
                assert_int_equal(dm_model_build(md, &pose, NULL), 0);
                dm_model_dense(md, K, M);
                assert_int_equal(dm_reference_eigen(K, M, n, K14, rl, ref), 0);
                assert_int_equal(dm_boundary_solve(bw, &pose, &st, NULL), 0);
                assert_int_equal(dm_boundary_reduced_modes(bw, K14, lam, NULL), 0);
                dm_boundary_mode_shapes(bw, K14, phi);
                for (int a = 0; a < K14; a++) {
                    const double *pa = phi + (size_t)a * n;
                    assert_abs(m_product(M, n, pa, pa), 1.0, 1e-10, "phi' M phi, mode %d", a);
                    double mac = 0;
                    for (int b = 0; b < K14; b++)
                        if (fabs((double)(rl[b] - rl[a])) <= 1e-3 * (double)rl[a]) {
                            double p = m_product(M, n, pa, ref + (size_t)b * n);
                            mac += p * p;
                        }
                    worst = fmax(worst, 1 - mac);
                    assert_true(mac > 1 - 1e-8);
                }
            }
            free(K);
            free(M);
            free(phi);
            free(ref);
            dm_boundary_free(bw);
            dm_members_free(ms);
            dm_model_free(md);
        }
    print_message("mode shapes from the members: worst 1 - cluster MAC %.2e\n", worst);
}

/* T' G by the definition: the model's inertial loads G (dm_loads, n),
 * in (boundary, interiors) coordinates z = Q' G, then the boundary rows
 * z_B + sum_m C_m' Psi_m' z_i and each member's [Phi_kept, R]' z_i. */
static void loads_by_definition(const dm_members *ms, const dm_members_pose *mp, const double *G,
                                double *out)
{
    int nB = ms->nbound, q0 = nB;
    double *z = malloc(sizeof(double) * ms->n), C[9 * DM_MEMBERS_MAX_BOUND];
    assert_non_null(z);
    dm_members_gather(ms, mp, G, z);
    memcpy(out, z, sizeof(double) * nB);
    for (int m = 0; m < DM_MEMBERS_N; m++) {
        const dm_member_basis *mb = &ms->member[m];
        const double *zi = z + ms->interior0[m];
        dm_members_coupling(ms, mp, m, C);
        for (int r = 0; r < mb->nb; r++) {
            double psi_z = 0;
            for (int k = 0; k < mb->ni; k++)
                psi_z += mb->Psi[(size_t)r * mb->ni + k] * zi[k];
            for (int c = 0; c < nB; c++)
                out[c] += C[(size_t)c * mb->nb + r] * psi_z;
        }
        for (int j = 0; j < mb->nkeep + mb->nres; j++) {
            const double *v = j < mb->nkeep ? mb->Phi + (size_t)j * mb->ni
                                            : mb->R + (size_t)(j - mb->nkeep) * mb->ni;
            double s = 0;
            for (int k = 0; k < mb->ni; k++)
                s += v[k] * zi[k];
            out[q0 + j] = s;
        }
        q0 += mb->nkeep + mb->nres;
    }
    free(z);
}

/* |got - want| <= 1e-12 of want's largest entry (n of them): both are the
 * same few hundred products summed in other orders, and 1e-12 is some
 * hundred roundings of it. Returns that ratio. */
static double within_roundings(const double *got, const double *want, int n, const char *what)
{
    double size = 0, err = 0;
    for (int i = 0; i < n; i++)
        size = fmax(size, fabs(want[i]));
    for (int i = 0; i < n; i++)
        err = fmax(err, fabs(got[i] - want[i]));
    assert_true(size > 0);
    if (!(err <= 1e-12 * size))
        fail_msg("%s off by %.3e of %.3e", what, err, size);
    return err / size;
}

/* The reduced inertial and gravity loads (dm_boundary_inertial_loads,
 * dm_boundary_gravity_loads: each member's unit loads combined) equal T'
 * G of the model's own loads, for the standard move's three directions
 * from rest and a motion with arm rates (centripetal terms); and the
 * members' M times the mode shapes (dm_boundary_mass_shapes) equals the
 * assembled model's; the three presets at meshes 1,1 and 4,4 without and
 * with every pose-free effect, 3 random poses each, each within
 * within_roundings. */
static void loads_and_mass_equal_the_model(void **state)
{
    (void)state;
    const char *presets[] = {"chen2018", "zheng2017", "han2011"};
    dm_rng rng = {11};
    double worst = 0, worst_g = 0, worst_m = 0;
    for (int r = 0; r < 3; r++)
        for (int mesh = 1; mesh <= 4; mesh += 3)
            for (int fx = 0; fx < 2; fx++) {
                dm_robot rb;
                dm_pose pose;
                load(&rb, presets[r], fx ? ALL_EFFECTS : NULL);
                dm_model *md = dm_model_alloc(&rb, mesh, mesh, NULL);
                assert_non_null(md);
                assert_int_equal(dm_kin_pose(&rb, rb.home_m, &pose, NULL), 0);
                assert_int_equal(dm_model_build(md, &pose, NULL), 0);
                dm_members *ms = dm_boundary_members_for_modes(md, 10, NULL);
                dm_boundary *bw = ms ? dm_boundary_alloc(ms, NULL) : NULL;
                assert_non_null(bw);
                int n = md->n, nr = dm_boundary_reduced_size(bw);
                double *G = malloc(sizeof(double) * n * 4), *got = malloc(sizeof(double) * nr * 4);
                double *want = malloc(sizeof(double) * (nr > n ? nr : n));
                double *phi = malloc(sizeof(double) * n * 10), *mphi = malloc(sizeof(double) * n * 10);
                double *X = malloc(sizeof(double) * n * 10), *Y = malloc(sizeof(double) * n * 10);
                assert_non_null(Y);
                for (int t = 0; t < 3; t++) {
                    dm_boundary_statics st;
                    dm_rigid_motion mo[4] = {{{0}, {0}, {1, 0, 0}}, {{0}, {0}, {0, 1, 0}},
                                             {{0}, {0}, {0, 0, 1}}, {{0}, {0}, {0.3, -0.5, 0.8}}};
                    const double v0[3] = {0, 0, 0}, v[3] = {0.4, 0.2, -0.3};
                    random_pose(&rb, &rng, &pose);
                    for (int l = 0; l < 4; l++)
                        assert_int_equal(dm_kin_accelerations(&rb, &pose, l < 3 ? v0 : v,
                                                              mo[l].aP, mo[l].alpha_ddot, NULL), 0);
                    assert_int_equal(dm_kin_rates(&rb, &pose, v, mo[3].alpha_dot, NULL), 0);
                    assert_int_equal(dm_model_build(md, &pose, NULL), 0);
                    memset(G, 0, sizeof(double) * n * 4);
                    dm_loads_add_inertial_many(md, mo, 4, G);
                    assert_int_equal(dm_boundary_solve(bw, &pose, &st, NULL), 0);
                    dm_boundary_inertial_loads(bw, &pose, mo, 4, got);
                    dm_members_pose mp;
                    assert_int_equal(dm_members_at(ms, &pose, &mp, NULL), 0);
                    for (int l = 0; l < 4; l++) {
                        loads_by_definition(ms, &mp, G + (size_t)l * n, want);
                        worst = fmax(worst, within_roundings(got + (size_t)l * nr, want, nr,
                                                             "inertial loads"));
                    }
                    dm_boundary_gravity_loads(bw, got);
                    loads_by_definition(ms, &mp, md->F_gravity, want);
                    worst_g = fmax(worst_g, within_roundings(got, want, nr, "gravity loads"));
                    double lam[10];
                    assert_int_equal(dm_boundary_reduced_modes(bw, 10, lam, NULL), 0);
                    dm_boundary_mode_shapes(bw, 10, phi);
                    dm_boundary_mass_shapes(bw, 10, mphi);
                    for (int i = 0; i < n; i++) /* the model's products take rows of 10 */
                        for (int j = 0; j < 10; j++)
                            X[(size_t)i * 10 + j] = phi[(size_t)j * n + i];
                    dm_model_mult_M(md, X, 10, Y);
                    for (int j = 0; j < 10; j++) {
                        for (int i = 0; i < n; i++)
                            want[i] = Y[(size_t)i * 10 + j];
                        worst_m = fmax(worst_m, within_roundings(mphi + (size_t)j * n, want, n,
                                                                 "M phi"));
                    }
                }
                free(G), free(got), free(want), free(phi), free(mphi), free(X), free(Y);
                dm_boundary_free(bw);
                dm_members_free(ms);
                dm_model_free(md);
            }
    print_message("against the model: inertial loads %.2e, gravity %.2e, M phi %.2e of the largest "
                  "entry\n", worst, worst_g, worst_m);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(statics_equal_the_exact_solve),
        cmocka_unit_test(geometric_stiffness_falls_back),
        cmocka_unit_test(count_equals_dense_inertia),
        cmocka_unit_test(reduced_modes_are_certified),
        cmocka_unit_test(mode_shapes_match_the_reference),
        cmocka_unit_test(loads_and_mass_equal_the_model),
    };
    return cmocka_run_group_tests_name("boundary", tests, NULL, NULL);
}
