/* The tile partition: a partition, balanced in count, interleaved, free of
 * the aliasing of t mod N, and fixed (the same on every machine). */
#include "dm_test.h"

#include <stdlib.h>

#include "dm_kinematics.h"
#include "dm_shard.h"
#include "dm_sweep.h"

/* Every tile has one shard in 0..N-1; every aligned run of N tiles holds
 * each shard once, so the counts differ by at most one. */
static void partition_is_interleaved_and_even(void **state)
{
    (void)state;
    static const long totals[] = {1, 7, 100, 1001, 4096};
    for (size_t i = 0; i < sizeof totals / sizeof *totals; i++)
        for (long n = 1; n <= 40; n++) {
            long T = totals[i], *count = calloc((size_t)n, sizeof(long));
            char *seen = calloc((size_t)n, 1);
            for (long t = 0; t < T; t++) {
                long k = dm_shard_of(t, n);
                assert_true(k >= 0 && k < n);
                count[k]++;
                if (t % n == 0)
                    memset(seen, 0, (size_t)n);
                assert_false(seen[k]); /* once per run */
                seen[k] = 1;
            }
            for (long k = 0; k < n; k++)
                assert_true(count[k] == T / n || count[k] == T / n + 1);
            free(count);
            free(seen);
        }
    assert_int_equal(dm_shard_of(12345, 1), 0);
    assert_int_equal(dm_shard_of(12345, 0), 0);
}

/* Pinned values: all processes of a sweep, on any machine and any build,
 * must agree on the partition. */
static void partition_is_fixed(void **state)
{
    (void)state;
    assert_int_equal(dm_shard_of(0, 4), 0);
    assert_int_equal(dm_shard_of(4, 4), 2);
    assert_int_equal(dm_shard_of(5, 4), 3);
    assert_int_equal(dm_shard_of(999, 7), 3);
    assert_int_equal(dm_shard_of(123456789, 100), 25);
}

/* max shard load / mean shard load */
static double imbalance(const double *cost, long T, long n, int modulo)
{
    double *load = calloc((size_t)n, sizeof(double)), total = 0, worst = 0;
    for (long t = 0; t < T; t++) {
        load[modulo ? t % n : dm_shard_of(t, n)] += cost[t];
        total += cost[t];
    }
    for (long k = 0; k < n; k++)
        worst = load[k] > worst ? load[k] : worst;
    free(load);
    return worst * n / total;
}

/* One expensive tile in every run of N (a cost with the period of the
 * partition): t mod N gives all of them to shard 0. */
static void no_aliasing_with_a_periodic_cost(void **state)
{
    (void)state;
    enum { N = 8, T = 64 * N };
    double cost[T];
    for (long t = 0; t < T; t++)
        cost[t] = t % N == 0 ? 100 : 1;
    assert_true(imbalance(cost, T, N, 1) > 5);
    double ours = imbalance(cost, T, N, 0);
    if (ours > 1.25) {
        print_error("periodic cost: imbalance %.3f\n", ours);
        fail();
    }
}

/* A 3-D chen2018 grid of 6 x 6 x 16 tiles, cost 20 per reachable point and
 * 1 per unreachable one (an unreachable point costs its inverse kinematics
 * only): with N = 16 tiles along z, t mod N gives each shard one height —
 * 20 % over the mean for the worst. The interleave stays within 10 %. */
static void balanced_on_a_workspace(void **state)
{
    (void)state;
    dm_robot rb;
    dm_grid g;
    assert_int_equal(dm_robot_load("chen2018", &rb, NULL), 0);
    assert_int_equal(dm_grid_parse("x=-0.8:0.8:81,y=-0.8:0.8:81,z=-1.0:-0.2:16", &g, NULL), 0);
    enum { T = 6 * 6 * 16 };
    static double cost[T];
    for (int i = 0; i < 81; i++)
        for (int j = 0; j < 81; j++)
            for (int k = 0; k < 16; k++) {
                int idx[3] = {i, j, k};
                double P[3];
                dm_pose pose;
                dm_grid_position(&g, idx, P);
                cost[((i / 16) * 6 + j / 16) * 16 + k] +=
                    dm_kin_inverse(&rb, P, &pose, NULL) == DM_OK ? 20 : 1;
            }
    assert_true(imbalance(cost, T, 16, 1) > 1.15); /* the case is a real one */
    for (long n = 2; n <= 16; n *= 2) {
        double ours = imbalance(cost, T, n, 0);
        if (ours > 1.10) {
            print_error("%ld shards: imbalance %.3f\n", n, ours);
            fail();
        }
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(partition_is_interleaved_and_even),
        cmocka_unit_test(partition_is_fixed),
        cmocka_unit_test(no_aliasing_with_a_periodic_cost),
        cmocka_unit_test(balanced_on_a_workspace),
    };
    return cmocka_run_group_tests_name("shard", tests, NULL, NULL);
}
