/* The CSV reader: comments, blanks and the header; cells with blanks;
 * every error names the file, the line and the column. */
#include "dm_test.h"

#include <stdlib.h>
#include <unistd.h>

#include "dm_csv.h"

static const char *write_file(char *path, const char *text)
{
    strcpy(path, "/tmp/dm_csv_XXXXXX");
    int fd = mkstemp(path);
    assert_true(fd >= 0);
    FILE *f = fdopen(fd, "w");
    fputs(text, f);
    fclose(f);
    return path;
}

static void lines_of_a_file(void **state)
{
    (void)state;
    char path[64];
    write_file(path, "# robot: x\n\n  t , x,y\n# mid\n1, 2.5 ,-3e-2\n\n4,,6\n");
    dm_csv c;
    dm_csv_line kind;
    assert_int_equal(dm_csv_open(&c, path, NULL), 0);
    assert_int_equal(dm_csv_next(&c, &kind, NULL), 0);
    assert_int_equal(kind, DM_CSV_COMMENT);
    assert_string_equal(c.comment, " robot: x\n");
    assert_int_equal(dm_csv_next(&c, &kind, NULL), 0);
    assert_int_equal(kind, DM_CSV_HEADER);
    assert_int_equal(c.line, 3);
    assert_int_equal(c.ncol, 3);
    assert_int_equal(dm_csv_column(&c, "t"), 0);
    assert_int_equal(dm_csv_column(&c, "y"), 2);
    assert_int_equal(dm_csv_column(&c, "z"), -1);
    assert_int_equal(dm_csv_next(&c, &kind, NULL), 0);
    assert_int_equal(kind, DM_CSV_COMMENT);
    assert_int_equal(dm_csv_next(&c, &kind, NULL), 0);
    assert_int_equal(kind, DM_CSV_ROW);
    double v[3];
    for (int i = 0; i < 3; i++)
        assert_int_equal(dm_csv_number(&c, i, &v[i], NULL), 0);
    assert_true(v[0] == 1 && v[1] == 2.5 && v[2] == -3e-2);
    assert_int_equal(dm_csv_next(&c, &kind, NULL), 0);
    assert_int_equal(kind, DM_CSV_ROW);
    assert_int_equal(c.line, 7);
    dm_error err;
    assert_int_equal(dm_csv_number(&c, 1, &v[1], &err), DM_EINVAL);
    assert_non_null(strstr(err.msg, ":7: column 2 (x): empty"));
    assert_int_equal(dm_csv_next(&c, &kind, NULL), 0);
    assert_int_equal(kind, DM_CSV_END);
    dm_csv_close(&c);
    unlink(path);
}

static void expect_number_error(const char *cell, const char *what)
{
    char path[64], text[128];
    snprintf(text, sizeof text, "a,b\n1,%s\n", cell);
    write_file(path, text);
    dm_csv c;
    dm_csv_line kind;
    dm_error err;
    double v;
    assert_int_equal(dm_csv_open(&c, path, NULL), 0);
    assert_int_equal(dm_csv_next(&c, &kind, NULL), 0);
    assert_int_equal(dm_csv_next(&c, &kind, NULL), 0);
    assert_int_equal(kind, DM_CSV_ROW);
    int rc = dm_csv_number(&c, 1, &v, &err);
    if (rc != DM_EINVAL || !strstr(err.msg, what) || !strstr(err.msg, path)) {
        print_error("cell '%s': expected an error with '%s', got %d: %s\n", cell, what, rc,
                    rc ? err.msg : "");
        fail();
    }
    dm_csv_close(&c);
    unlink(path);
}

static void numbers_and_their_errors(void **state)
{
    (void)state;
    expect_number_error("abc", ":2: column 2 (b): 'abc' is not a number in range");
    expect_number_error("1.5x", "'1.5x' is not a number");
    expect_number_error("inf", "'inf' is not a number");
    expect_number_error("nan", "'nan' is not a number");
    expect_number_error("1e999", "'1e999' is not a number");
    expect_number_error("4.94e-324", "is not a number in range");
    expect_number_error("0x1p-1074", "is not a number in range");
    expect_number_error("", "column 2 (b): empty");
}

static void lines_too_long_or_too_wide(void **state)
{
    (void)state;
    char path[64];
    char *text = malloc(DM_CSV_MAXLINE + 64);
    snprintf(text, 8, "a,b\n1,");
    memset(text + 6, '1', DM_CSV_MAXLINE);
    strcpy(text + 6 + DM_CSV_MAXLINE, "\n");
    write_file(path, text);
    dm_csv c;
    dm_csv_line kind;
    dm_error err;
    assert_int_equal(dm_csv_open(&c, path, NULL), 0);
    assert_int_equal(dm_csv_next(&c, &kind, NULL), 0);
    assert_int_equal(dm_csv_next(&c, &kind, &err), DM_EINVAL);
    assert_non_null(strstr(err.msg, ":2: line longer than"));
    dm_csv_close(&c);
    text[0] = '\0';
    for (int i = 0; i <= DM_CSV_MAXCOL; i++)
        strcat(text, i ? ",c" : "c");
    strcat(text, "\n");
    write_file(path, text);
    assert_int_equal(dm_csv_open(&c, path, NULL), 0);
    assert_int_equal(dm_csv_next(&c, &kind, &err), DM_EINVAL);
    assert_non_null(strstr(err.msg, ":1: header has more than"));
    dm_csv_close(&c);
    unlink(path);
    free(text);
    assert_int_equal(dm_csv_open(&c, "/nonexistent/x.csv", &err), DM_EIO);
    assert_non_null(strstr(err.msg, "/nonexistent/x.csv: cannot open"));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(lines_of_a_file),
        cmocka_unit_test(numbers_and_their_errors),
        cmocka_unit_test(lines_too_long_or_too_wide),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
