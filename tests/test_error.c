/* dm_error: messages are printable UTF-8 whatever bytes they quote. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <cmocka.h>
#include <stdio.h>
#include <string.h>

#include "dm_error.h"

static void keeps_utf8_tabs_and_newlines(void **state)
{
    (void)state;
    const char *in = "caf\xC3\xA9 \xE6\x97\xA5 \xF0\x9D\x84\x9E\tline\nnext";
    char out[64];
    size_t n = dm_printable(out, sizeof out, in);
    assert_string_equal(out, in);
    assert_int_equal(n, strlen(in));
}

/* Each byte that is not part of a well-formed character becomes \xNN:
 * a lone lead byte, a lead byte before ASCII, an overlong form, a
 * surrogate, a byte above U+10FFFF's leads, a stray continuation, C0
 * controls and DEL. */
static void escapes_every_other_byte(void **state)
{
    (void)state;
    static const struct { const char *in, *want; } cases[] = {
        {"a\xE0", "a\\xE0"},
        {"\xE0" "A", "\\xE0" "A"},
        {"\xC0\xAF", "\\xC0\\xAF"},
        {"\xED\xA0\x80", "\\xED\\xA0\\x80"},
        {"\xF5\x80\x80\x80", "\\xF5\\x80\\x80\\x80"},
        {"\x80x", "\\x80x"},
        {"\x01\x1B[2J\x7F", "\\x01\\x1B[2J\\x7F"},
        {"\xE2\x82", "\\xE2\\x82"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        char out[64];
        dm_printable(out, sizeof out, cases[i].in);
        assert_string_equal(out, cases[i].want);
    }
}

/* Truncation never splits a character or an escape. */
static void truncates_at_a_character_boundary(void **state)
{
    (void)state;
    char out[6];
    assert_int_equal(dm_printable(out, sizeof out, "ab\xC3\xA9\xC3\xA9"), 4);
    assert_string_equal(out, "ab\xC3\xA9");
    assert_int_equal(dm_printable(out, sizeof out, "ab\xFF"), 2);
    assert_string_equal(out, "ab");
    assert_int_equal(dm_printable(out, 1, "abc"), 0);
    assert_string_equal(out, "");
}

static void dm_fail_makes_its_message_printable(void **state)
{
    (void)state;
    dm_error err;
    assert_int_equal(dm_fail(&err, DM_EIO, "%s:%d: invalid token near '%s'", "s/zarr.json", 3,
                             "\xE0z"),
                     DM_EIO);
    assert_int_equal(err.code, DM_EIO);
    assert_string_equal(err.msg, "s/zarr.json:3: invalid token near '\\xE0z'");
    /* a message built on the previous one */
    dm_fail(&err, DM_EINVAL, "reading: %s", err.msg);
    assert_string_equal(err.msg, "reading: s/zarr.json:3: invalid token near '\\xE0z'");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(keeps_utf8_tabs_and_newlines),
        cmocka_unit_test(escapes_every_other_byte),
        cmocka_unit_test(truncates_at_a_character_boundary),
        cmocka_unit_test(dm_fail_makes_its_message_printable),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
