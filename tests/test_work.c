/* The one work check: each kind judged against its limit (0: not judged,
 * NaN never within), force_long passing everything, the refusal's status
 * DM_ETOOBIG and a message naming exactly the kinds exceeded. */
#include "dm_test.h"

#include <math.h>

#include "dm_work.h"

static const dm_work LIMIT = {3600, 1e9, 1000};

static void within_the_limits_passes(void **state)
{
    (void)state;
    dm_error err;
    dm_error_clear(&err);
    assert_int_equal(dm_work_check("w", (dm_work){3600, 1e9, 1000}, LIMIT, "h", 0, &err), DM_OK);
    assert_int_equal(err.code, DM_OK); /* untouched */
    /* a kind whose limit is 0 is not judged, however large */
    assert_int_equal(dm_work_check("w", (dm_work){1, 1e30, 1e30}, (dm_work){3600, 0, 0}, "h", 0,
                                   &err), DM_OK);
}

static void each_kind_beyond_is_refused_by_its_status(void **state)
{
    (void)state;
    struct { dm_work need; const char *msg; } cases[] = {
        {{7200, 0, 0}, "job: about 2 hours of work (the limit is 1): less, or force it"},
        {{0, 3e9, 0}, "job: about 3 GB of memory (the limit is 1): less, or force it"},
        {{0, 0, 2500}, "job: about 2.5e+03 files (the limit is 1e+03): less, or force it"},
        {{7200, 3e9, 2500}, "job: about 2 hours of work (the limit is 1) and 3 GB of memory (the "
                            "limit is 1) and 2.5e+03 files (the limit is 1e+03): less, or force it"},
        {{NAN, 0, 0}, "job: about nan hours of work (the limit is 1): less, or force it"},
    };
    for (size_t c = 0; c < sizeof cases / sizeof *cases; c++) {
        dm_error err;
        assert_int_equal(dm_work_check("job", cases[c].need, LIMIT, "less", 0, &err), DM_ETOOBIG);
        assert_int_equal(err.code, DM_ETOOBIG);
        assert_string_equal(err.msg, cases[c].msg);
        /* forced, the same work passes */
        assert_int_equal(dm_work_check("job", cases[c].need, LIMIT, "less", 1, &err), DM_OK);
    }
    assert_int_equal(dm_work_check("job", (dm_work){7200, 0, 0}, LIMIT, "less", 0, NULL),
                     DM_ETOOBIG);
    assert_string_equal(dm_status_name(DM_ETOOBIG), "refused as too much work");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(within_the_limits_passes),
        cmocka_unit_test(each_kind_beyond_is_refused_by_its_status),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
