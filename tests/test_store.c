/* The map store: CRC-32C, chunk round trip, corruption and truncation
 * detection, atomic writes. */
#include "dm_test.h"

#include <dirent.h>
#include <fcntl.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "dm_file.h"
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

static void touch(const char *dir, const char *name, long age_s)
{
    char path[600];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fclose(f);
    struct timespec t[2] = {{time(NULL) - age_s, 0}, {time(NULL) - age_s, 0}};
    assert_int_equal(utimensat(AT_FDCWD, path, t, 0), 0);
}

static int exists(const char *dir, const char *name)
{
    char path[600];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    return access(path, F_OK) == 0;
}

/* Temporaries are PATH.tmp.HOST.PID; only those of writers that are gone
 * are removed: on this host a PID that does not exist, of another host a
 * file older than DM_TEMP_STALE_S. Live writers' files stay. */
static void only_dead_writers_temporaries_are_removed(void **state)
{
    (void)state;
    char dir[] = "/tmp/dm_store_XXXXXX", host[64], name[200], mine[700];
    assert_non_null(mkdtemp(dir));
    assert_int_equal(gethostname(host, sizeof host), 0);
    pid_t dead = fork(); /* a PID that surely existed and is gone */
    if (!dead)
        _exit(0);
    assert_int_equal(waitpid(dead, NULL, 0), dead);
    snprintf(name, sizeof name, "0.tmp.%s.%ld", host, (long)dead);
    touch(dir, name, 0);                                   /* dead, here: removed */
    snprintf(name, sizeof name, "1.tmp.%s.%ld", host, (long)getppid());
    touch(dir, name, 0);                                   /* alive, here: kept */
    snprintf(name, sizeof name, "2.tmp.%s.%ld", host, (long)getpid());
    touch(dir, name, 0);                                   /* ourselves: kept */
    touch(dir, "3.tmp.elsewhere.example.org.4242", 60);    /* another host, fresh: kept */
    touch(dir, "4.tmp.elsewhere.example.org.4242", DM_TEMP_STALE_S + 60); /* old: removed */
    touch(dir, "5.tmp.notapid", 0);                         /* not ours: kept */
    touch(dir, "6", 0);                                     /* data: kept */
    snprintf(name, sizeof name, "zarr.json.tmp.%s.%ld", host, (long)dead);
    touch(dir, name, 0);
    assert_int_equal(dm_file_remove_stale_temps(dir, "6"), 0); /* another base */
    assert_int_equal(dm_file_remove_stale_temps(dir, "zarr.json"), 1);
    assert_int_equal(dm_file_remove_stale_temps(dir, NULL), 2);
    snprintf(name, sizeof name, "0.tmp.%s.%ld", host, (long)dead);
    assert_false(exists(dir, name));
    assert_false(exists(dir, "4.tmp.elsewhere.example.org.4242"));
    snprintf(name, sizeof name, "1.tmp.%s.%ld", host, (long)getppid());
    assert_true(exists(dir, name));
    snprintf(name, sizeof name, "2.tmp.%s.%ld", host, (long)getpid());
    assert_true(exists(dir, name));
    assert_true(exists(dir, "3.tmp.elsewhere.example.org.4242"));
    assert_true(exists(dir, "5.tmp.notapid"));
    assert_true(exists(dir, "6"));
    /* our own temporary name carries host and PID */
    dm_file_temp_name("a/b", mine, sizeof mine);
    snprintf(name, sizeof name, "a/b.tmp.%s.%ld", host, (long)getpid());
    assert_string_equal(mine, name);
    char cmd[600];
    snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
    assert_int_equal(system(cmd), 0);
}

/* A chunk write into a store whose array directory is gone fails and does
 * not recreate it: a writer whose store was removed or replaced leaves no
 * stray tree. */
static void chunk_write_does_not_recreate_a_removed_store(void **state)
{
    (void)state;
    char dir[] = "/tmp/dm_store_XXXXXX", cmd[600], path[600];
    assert_non_null(mkdtemp(dir));
    dm_store st;
    dm_error err;
    make_store(&st, dir);
    assert_int_equal(dm_store_write_metadata(&st, &err), 0);
    double data[6] = {1, 2, 3, 4, 5, 6};
    const int64_t c[2] = {2, 0};
    snprintf(cmd, sizeof cmd, "rm -rf %s/values", dir);
    assert_int_equal(system(cmd), 0);
    assert_int_equal(dm_store_write_chunk(&st, 0, c, data, &err), DM_EIO);
    snprintf(path, sizeof path, "%s/values", dir);
    assert_int_not_equal(access(path, F_OK), 0);
    dm_store_release(&st);
    snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
    assert_int_equal(system(cmd), 0);
}

/* A file against the bytes it should hold: the metadata text is what is
 * written; an edited field, a flipped chunk byte, a chunk with a valid
 * checksum but other values, a longer file and a missing one are each
 * told apart, and named. */
static void files_compared_with_what_is_written(void **state)
{
    (void)state;
    char dir[] = "/tmp/dm_store_XXXXXX", path[600], why[300];
    assert_non_null(mkdtemp(dir));
    dm_store st;
    dm_error err;
    make_store(&st, dir);
    assert_int_equal(dm_store_write_metadata(&st, &err), DM_OK);
    size_t n, len;
    char *text = dm_store_metadata_text(&st, 0, &n);
    dm_store_metadata_path(&st, 0, path, sizeof path);
    int differs = -1;
    assert_int_equal(dm_store_compare_file(path, text, n, 0, why, sizeof why, &differs, &err), DM_OK);
    assert_int_equal(differs, 0);
    /* chunk_shape [2, 3] -> [2, 4]: still JSON, another layout */
    char *edited = strdup(text);
    char *at = strstr(strstr(edited, "chunk_shape"), "3");
    *at = '4';
    FILE *f = fopen(path, "wb");
    fwrite(edited, 1, n, f);
    fclose(f);
    dm_store_compare_file(path, text, n, 0, why, sizeof why, &differs, &err);
    assert_int_equal(differs, 1);
    assert_non_null(strstr(why, "chunk_grid.configuration.chunk_shape[1]"));
    /* the same bytes and one more */
    f = fopen(path, "wb");
    fwrite(text, 1, n, f);
    fputc(' ', f);
    fclose(f);
    dm_store_compare_file(path, text, n, 0, why, sizeof why, &differs, &err);
    assert_int_equal(differs, 1);
    assert_non_null(strstr(why, "in other text"));
    remove(path);
    dm_store_compare_file(path, text, n, 0, why, sizeof why, &differs, &err);
    assert_true(differs && !strcmp(why, "missing"));
    /* chunks: the encoded bytes, a flipped byte, other values with a valid checksum */
    double v[6] = {1, 2, 3, 4, 5, 6}, w[6] = {1, 2, 3, 4, 5, 7};
    const int64_t c[2] = {0, 0};
    assert_int_equal(dm_store_write_chunk(&st, 0, c, v, &err), DM_OK);
    unsigned char *want = dm_store_encode_chunk(&st, 0, v, &len);
    assert_int_equal(len, 6 * 8 + 4);
    dm_store_chunk_path(&st, 0, c, path, sizeof path);
    dm_store_compare_file(path, want, len, 1, why, sizeof why, &differs, &err);
    assert_int_equal(differs, 0);
    assert_int_equal(dm_store_write_chunk(&st, 0, c, w, &err), DM_OK);
    dm_store_compare_file(path, want, len, 1, why, sizeof why, &differs, &err);
    assert_true(differs && strstr(why, "checksum valid"));
    want[3] ^= 1;
    f = fopen(path, "wb");
    fwrite(want, 1, len, f);
    fclose(f);
    want[3] ^= 1;
    dm_store_compare_file(path, want, len, 1, why, sizeof why, &differs, &err);
    assert_true(differs && strstr(why, "checksum mismatch"));
    f = fopen(path, "wb");
    fwrite(want, 1, len - 1, f);
    fclose(f);
    dm_store_compare_file(path, want, len, 1, why, sizeof why, &differs, &err);
    assert_true(differs && strstr(why, "too short"));
    free(want);
    free(edited);
    free(text);
    dm_store_release(&st);
    dm_file_remove_tree(dir);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(crc32c_known_vectors),
        cmocka_unit_test(chunks_round_trip_and_detect_damage),
        cmocka_unit_test(only_dead_writers_temporaries_are_removed),
        cmocka_unit_test(chunk_write_does_not_recreate_a_removed_store),
        cmocka_unit_test(files_compared_with_what_is_written),
    };
    return cmocka_run_group_tests_name("store", tests, NULL, NULL);
}
