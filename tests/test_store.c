/* The map store: CRC-32C, chunk round trip, corruption and truncation
 * detection, atomic writes. */
#include "dm_test.h"

#include <dirent.h>
#include <stdlib.h>
#include <unistd.h>

#include "dm_store.h"

static void crc32c_known_vectors(void **state)
{
    (void)state;
    assert_int_equal(dm_crc32c("123456789", 9), 0xE3069283u); /* the standard check value */
    assert_int_equal(dm_crc32c("", 0), 0u);
    unsigned char zeros[32] = {0};
    assert_int_equal(dm_crc32c(zeros, 32), 0x8A9136AAu); /* RFC 3720 B.4 */
}

static void make_store(dm_store *st, const char *dir)
{
    memset(st, 0, sizeof *st);
    snprintf(st->path, sizeof st->path, "%s", dir);
    dm_array_spec *a = &st->arr[st->narr++];
    snprintf(a->name, sizeof a->name, "values");
    a->dtype = DM_DTYPE_FLOAT64;
    a->ndim = 2;
    a->shape[0] = 5;
    a->shape[1] = 3;
    a->chunk[0] = 2;
    a->chunk[1] = 3;
    snprintf(a->dims[0], sizeof a->dims[0], "x");
    snprintf(a->dims[1], sizeof a->dims[1], "mode");
    a->attributes = json_pack("{s:s}", "units", "Hz");
    st->group_attributes = json_pack("{s:{s:[s]}}", "deltamap", "arrays", "values");
}

static int count_tmp(const char *dir)
{
    char path[512];
    snprintf(path, sizeof path, "%s/values/c/1", dir);
    DIR *d = opendir(path);
    int n = 0;
    struct dirent *e;
    while (d && (e = readdir(d)))
        n += strstr(e->d_name, ".tmp.") != NULL;
    if (d)
        closedir(d);
    return n;
}

static void chunks_round_trip_and_detect_damage(void **state)
{
    (void)state;
    char dir[] = "/tmp/dm_store_XXXXXX";
    assert_non_null(mkdtemp(dir));
    dm_store st, back;
    dm_error err;
    make_store(&st, dir);
    assert_int_equal(dm_store_write_metadata(&st, &err), 0);
    double data[6] = {1, 2, 3, 4, 5, NAN}, got[6];
    const int64_t c[2] = {1, 0};
    int missing;
    assert_int_equal(dm_store_chunk_elems(&st, 0), 6);
    assert_int_equal(dm_store_read_chunk(&st, 0, c, got, &missing, &err), DM_EIO);
    assert_true(missing);
    assert_int_equal(dm_store_write_chunk(&st, 0, c, data, &err), 0);
    assert_int_equal(count_tmp(dir), 0);
    assert_int_equal(dm_store_read_chunk(&st, 0, c, got, &missing, &err), 0);
    assert_memory_equal(data, got, sizeof data);
    /* metadata reads back */
    assert_int_equal(dm_store_read_metadata(dir, &back, &err), 0);
    assert_int_equal(back.narr, 1);
    assert_int_equal(back.arr[0].shape[0], 5);
    assert_int_equal(back.arr[0].chunk[0], 2);
    assert_string_equal(back.arr[0].dims[1], "mode");
    assert_string_equal(json_string_value(json_object_get(back.arr[0].attributes, "units")), "Hz");
    /* flip one byte: the checksum catches it */
    char path[600];
    dm_store_chunk_path(&st, 0, c, path, sizeof path);
    FILE *f = fopen(path, "r+b");
    fseek(f, 13, SEEK_SET);
    fputc(0x5A, f);
    fclose(f);
    assert_int_equal(dm_store_read_chunk(&st, 0, c, got, &missing, &err), DM_EIO);
    assert_false(missing);
    assert_non_null(strstr(err.msg, "checksum"));
    /* truncated */
    assert_int_equal(truncate(path, 20), 0);
    assert_int_equal(dm_store_read_chunk(&st, 0, c, got, &missing, &err), DM_EIO);
    assert_non_null(strstr(err.msg, "size"));
    dm_store_release(&back);
    dm_store_release(&st);
    char cmd[600];
    snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
    assert_int_equal(system(cmd), 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(crc32c_known_vectors),
        cmocka_unit_test(chunks_round_trip_and_detect_damage),
    };
    return cmocka_run_group_tests_name("store", tests, NULL, NULL);
}
