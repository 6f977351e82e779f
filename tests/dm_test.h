/* Shared helpers for deltamap's cmocka tests. */
#ifndef DM_TEST_H
#define DM_TEST_H

#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <string.h>

#include <cmocka.h>
#include <lapacke.h>
#include <stdlib.h>

#include "dm_rng.h"

/* DM_TEST=PATTERN runs only the tests whose names match (cmocka's glob:
 * * and ?), e.g. DM_TEST='standard_move*' build/tests/test_integrate. */
__attribute__((constructor)) static void dm_test_filter_from_env(void)
{
    const char *pattern = getenv("DM_TEST");
    if (pattern && *pattern)
        cmocka_set_test_filter(pattern);
}

/* |value - expected| <= tol * |expected|, with a description of what is
 * being checked (after gsl_test_rel). */
#define assert_rel(value, expected, tol, ...)                                              \
    do {                                                                                   \
        double v_ = (value), e_ = (expected), t_ = (tol);                                  \
        if (!(fabs(v_ - e_) <= t_ * fabs(e_))) {                                           \
            print_error("%s:%d: ", __FILE__, __LINE__);                                    \
            print_error(__VA_ARGS__);                                                      \
            print_error(": got %.12g, expected %.12g (rel err %.3g > %.3g)\n", v_, e_,     \
                        fabs(v_ - e_) / fabs(e_), t_);                                     \
            fail();                                                                        \
        }                                                                                  \
    } while (0)

#define assert_abs(value, expected, tol, ...)                                              \
    do {                                                                                   \
        double v_ = (value), e_ = (expected), t_ = (tol);                                  \
        if (!(fabs(v_ - e_) <= t_)) {                                                      \
            print_error("%s:%d: ", __FILE__, __LINE__);                                    \
            print_error(__VA_ARGS__);                                                      \
            print_error(": got %.12g, expected %.12g (abs err %.3g > %.3g)\n", v_, e_,     \
                        fabs(v_ - e_), t_);                                                \
            fail();                                                                        \
        }                                                                                  \
    } while (0)

/* Q (n x n, column-major, leading dimension n) a random orthogonal
 * matrix: the Q of a Gaussian matrix's QR (LAPACK's dgeqrf, dorgqr). */
static inline void dm_test_random_orthogonal(dm_rng *rng, int n, double *Q)
{
    double tau[n > 0 ? n : 1];
    for (int i = 0; i < n * n; i++)
        Q[i] = dm_rng_normal(rng);
    assert_int_equal(LAPACKE_dgeqrf(LAPACK_COL_MAJOR, n, n, Q, n, tau), 0);
    assert_int_equal(LAPACKE_dorgqr(LAPACK_COL_MAJOR, n, n, n, Q, n, tau), 0);
}

#endif
