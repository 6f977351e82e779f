/* Small symmetric eigenproblems by Jacobi (dm_symeig): the eigenvalues
 * of matrices of known spectrum and of random ones against LAPACK's
 * dsyev within c n eps |A| (c = 4: both solvers' backward errors, a few
 * ulps of |A| each), eigenvectors orthonormal to 4 n eps and residuals
 * |A v - w v| within 4 n eps |A|; w ascending; NaN refused. Orders 1-8
 * (the moves ask at most 4). The singular values (the pose's Jacobian:
 * 3 x 3) against known ones and dgesvd's. */
#include "dm_test.h"

#include <float.h>

#include "dm_rng.h"
#include "dm_symeig.h"

enum { NMAX = 8 };
#define TOL(n) (4.0 * (n) * DBL_EPSILON)

/* A = Q diag(lam) Q' for a random orthogonal Q (both triangles; in long
 * double, so that A's spectrum is lam to its rounding). */
static void with_spectrum(dm_rng *rng, int n, const double *lam, double *A)
{
    double Q[NMAX * NMAX];
    dm_test_random_orthogonal(rng, n, Q);
    for (int j = 0; j < n; j++)
        for (int i = 0; i < n; i++) {
            long double s = 0;
            for (int r = 0; r < n; r++)
                s += (long double)Q[i + r * n] * Q[j + r * n] * lam[r];
            A[i + j * n] = (double)s;
        }
    for (int j = 0; j < n; j++) /* exactly symmetric */
        for (int i = j + 1; i < n; i++)
            A[i + j * n] = A[j + i * n];
}

static double norm_max(int n, const double *A)
{
    double m = 0;
    for (int i = 0; i < n * n; i++)
        m = fmax(m, fabs(A[i]));
    return m;
}

/* w ascending, V orthonormal, A V = V diag(w) within the bounds, and w
 * against `ref` (ascending) within c n eps |A|. */
static void check_pairs(int n, const double *A, const double *w, const double *V,
                        const double *ref)
{
    double a = norm_max(n, A) * n; /* a bound of |A|_2 */
    for (int j = 0; j < n; j++) {
        if (j > 0)
            assert_true(w[j] >= w[j - 1]);
        assert_true(fabs(w[j] - ref[j]) <= TOL(n) * a);
        for (int k = 0; k < n; k++) {
            double d = 0;
            for (int i = 0; i < n; i++)
                d += V[i + j * n] * V[i + k * n];
            assert_true(fabs(d - (j == k)) <= TOL(n));
        }
        for (int i = 0; i < n; i++) {
            double r = -w[j] * V[i + j * n];
            for (int k = 0; k < n; k++)
                r += A[i + k * n] * V[k + j * n];
            assert_true(fabs(r) <= TOL(n) * a);
        }
    }
}

/* Spectra with both signs, zeros, a pair 1e-9 apart, a triple, a graded
 * one: the values come back, each within the bound. */
static void known_spectra(void **state)
{
    (void)state;
    dm_rng rng = {0x5eed};
    double kinds[][NMAX] = {
        {3, -1, 2, 0.5, 7, -4, 1e-3, 10},
        {1, 1 + 1e-9, 2, 3, 5, 8, 13, 21},
        {2, 2, 2, 1, 1e6, 1e-6, 4, 4},
        {1e-8, 1e-4, 1, 1e4, 1e8, 0, -1e2, 5},
    };
    for (size_t k = 0; k < sizeof kinds / sizeof kinds[0]; k++)
        for (int n = 1; n <= NMAX; n++) {
            double A[NMAX * NMAX], B[NMAX * NMAX], w[NMAX], V[NMAX * NMAX], ref[NMAX];
            memcpy(ref, kinds[k], sizeof(double) * n);
            for (int i = 1; i < n; i++) /* ascending */
                for (int j = i; j > 0 && ref[j] < ref[j - 1]; j--) {
                    double t = ref[j];
                    ref[j] = ref[j - 1], ref[j - 1] = t;
                }
            with_spectrum(&rng, n, kinds[k], A);
            memcpy(B, A, sizeof(double) * n * n);
            assert_int_equal(dm_symeig(n, B, n, w, V, n), 0);
            check_pairs(n, A, w, V, ref);
        }
}

/* Random symmetric matrices (only the upper triangle given: below it
 * NaN, which must not be read) against dsyev's eigenvalues. */
static void random_against_dsyev(void **state)
{
    (void)state;
    dm_rng rng = {0xa11ce};
    for (int trial = 0; trial < 200; trial++) {
        int n = 1 + trial % NMAX;
        double A[NMAX * NMAX], B[NMAX * NMAX], L[NMAX * NMAX], w[NMAX], ref[NMAX];
        double V[NMAX * NMAX];
        for (int j = 0; j < n; j++)
            for (int i = 0; i <= j; i++)
                A[i + j * n] = A[j + i * n] = dm_rng_normal(&rng) * (trial % 3 ? 1 : 1e3);
        memcpy(L, A, sizeof(double) * n * n);
        assert_int_equal(LAPACKE_dsyev(LAPACK_COL_MAJOR, 'N', 'U', n, L, n, ref), 0);
        memcpy(B, A, sizeof(double) * n * n);
        for (int j = 0; j < n; j++)
            for (int i = j + 1; i < n; i++)
                B[i + j * n] = NAN;
        assert_int_equal(dm_symeig(n, B, n, w, V, n), 0);
        check_pairs(n, A, w, V, ref);
    }
}

/* A diagonal matrix comes back as it is (sorted, V a permutation), and
 * a leading dimension beyond n is honoured. */
static void diagonal_and_leading_dimension(void **state)
{
    (void)state;
    enum { LD = 6 };
    double A[LD * 4] = {0}, w[4], V[LD * 4];
    double d[4] = {5, -2, 9, 0};
    for (int i = 0; i < 4; i++)
        A[i + i * LD] = d[i];
    A[4] = A[5] = 99; /* rows beyond n: not read */
    assert_int_equal(dm_symeig(4, A, LD, w, V, LD), 0);
    double want[4] = {-2, 0, 5, 9};
    int from[4] = {1, 3, 0, 2};
    for (int j = 0; j < 4; j++) {
        assert_true(w[j] == want[j]);
        for (int i = 0; i < 4; i++)
            assert_true(V[i + j * LD] == (i == from[j]));
    }
}

/* Singular values: of A = U diag(sig) V' (U m x n orthonormal columns,
 * V orthogonal; sig down to 1e-12 of the largest, and an exact zero)
 * within 4 n eps sig_max (a backward-stable bound, as dgesvd's), and of
 * random matrices against dgesvd's within the same; descending. */
static void singular_values_known_and_random(void **state)
{
    (void)state;
    dm_rng rng = {0x51ab};
    double sigs[][4] = {{3, 2, 1, 0.5}, {1, 1e-5, 1e-10, 1e-12}, {2, 2, 2, 0}, {7, 1, 1 + 1e-9, 4}};
    for (int trial = 0; trial < 120; trial++) {
        int n = 1 + trial % 4, m = n + (trial / 4) % 3;
        double A[8 * 4], B[8 * 4], U[8 * 8], V[4 * 4], s[4], ref[4];
        const double *sig = sigs[trial % 4];
        int known = trial % 2;
        dm_test_random_orthogonal(&rng, m, U);
        dm_test_random_orthogonal(&rng, n, V);
        for (int j = 0; j < n; j++)
            for (int i = 0; i < m; i++) {
                long double sum = 0;
                for (int r = 0; r < n; r++)
                    sum += (long double)U[i + r * m] * sig[r] * V[j + r * n];
                A[i + j * m] = known ? (double)sum : dm_rng_normal(&rng);
            }
        double smax = 0;
        if (known) {
            for (int r = 0; r < n; r++)
                ref[r] = sig[r], smax = fmax(smax, sig[r]);
            for (int i = 1; i < n; i++) /* descending */
                for (int j = i; j > 0 && ref[j] > ref[j - 1]; j--) {
                    double t = ref[j];
                    ref[j] = ref[j - 1], ref[j - 1] = t;
                }
        } else {
            double sup[4], u1[1], vt1[1];
            memcpy(B, A, sizeof(double) * m * n);
            assert_int_equal(LAPACKE_dgesvd(LAPACK_COL_MAJOR, 'N', 'N', m, n, B, m, ref, u1, 1,
                                            vt1, 1, sup), 0);
            smax = ref[0];
        }
        memcpy(B, A, sizeof(double) * m * n);
        assert_int_equal(dm_symeig_singular_values(m, n, B, m, s), 0);
        for (int j = 0; j < n; j++) {
            if (j > 0)
                assert_true(s[j] <= s[j - 1]);
            assert_true(fabs(s[j] - ref[j]) <= TOL(n) * smax);
        }
    }
    double nan3[9] = {1, 0, 0, 0, 1, 0, 0, NAN, 1}, s3[3];
    assert_int_equal(dm_symeig_singular_values(3, 3, nan3, 3, s3), -1);
}

/* Every matrix converges: a kinematic Jacobian of zheng2017 (column-major
 * here) whose columns' cosine stalls at 1.08 eps under rotation (a stop
 * at one ulp never came: the pose was taken for singular), and 20 000
 * random 3 x 3 matrices, each within 4 n eps of dgesvd's. */
static void singular_values_always_converge(void **state)
{
    (void)state;
    double J[9] = {0.081360346970362749, 4.0063048928536995, 5.5947334797691033,
                   -2.3260533470779792, -4.5789772243835669, 2.3686045013247199,
                   -12.207809173334962, -3.8057156375257573, -8.4555807862998265};
    dm_rng rng = {0x3a3};
    for (int trial = 0; trial <= 20000; trial++) {
        double A[9], B[9], s[3], ref[3], sup[3], u1[1], vt1[1];
        for (int i = 0; i < 9; i++)
            A[i] = trial ? dm_rng_normal(&rng) : J[i];
        memcpy(B, A, sizeof A);
        assert_int_equal(LAPACKE_dgesvd(LAPACK_COL_MAJOR, 'N', 'N', 3, 3, B, 3, ref, u1, 1, vt1, 1,
                                        sup), 0);
        memcpy(B, A, sizeof A);
        assert_int_equal(dm_symeig_singular_values(3, 3, B, 3, s), 0);
        for (int j = 0; j < 3; j++)
            assert_true(fabs(s[j] - ref[j]) <= TOL(3) * ref[0]);
    }
}

static void non_finite_refused(void **state)
{
    (void)state;
    double A[9] = {1, 0, 0, 0.5, 2, 0, NAN, 0.25, 3}, w[3], V[9];
    assert_int_equal(dm_symeig(3, A, 3, w, V, 3), -1);
    double B[4] = {1, 0, INFINITY, 2};
    assert_int_equal(dm_symeig(2, B, 2, w, V, 2), -1);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(known_spectra),
        cmocka_unit_test(random_against_dsyev),
        cmocka_unit_test(diagonal_and_leading_dimension),
        cmocka_unit_test(singular_values_known_and_random),
        cmocka_unit_test(singular_values_always_converge),
        cmocka_unit_test(non_finite_refused),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
