/* Zarr v3 store: metadata with jansson, checksummed chunk files. */
#define _XOPEN_SOURCE 700 /* nftw */
#include "dm_store.h"

#include "dm_file.h"

#include <assert.h>
#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <ftw.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

/* ---- CRC-32C ---------------------------------------------------------------
 * Table-driven, reflected polynomial 0x82F63B78. No Debian package offers a C
 * CRC-32C; this is the textbook algorithm (checked against the standard test
 * vector "123456789" -> 0xE3069283 and against zarr-python in the tests). */
static uint32_t crc_table_entry(uint32_t i)
{
    for (int k = 0; k < 8; k++)
        i = (i >> 1) ^ (0x82F63B78u & (0u - (i & 1u)));
    return i;
}

uint32_t dm_crc32c(const void *data, size_t n)
{
    static uint32_t table[256]; /* immutable once filled; filling is idempotent */
    static int ready;
    if (!__atomic_load_n(&ready, __ATOMIC_ACQUIRE)) {
        for (uint32_t i = 0; i < 256; i++)
            table[i] = crc_table_entry(i);
        __atomic_store_n(&ready, 1, __ATOMIC_RELEASE);
    }
    const unsigned char *p = data;
    uint32_t c = 0xFFFFFFFFu;
    while (n--)
        c = table[(c ^ *p++) & 0xFF] ^ (c >> 8);
    return c ^ 0xFFFFFFFFu;
}

size_t dm_dtype_size(dm_dtype t) { return t == DM_DTYPE_FLOAT64 ? 8 : t == DM_DTYPE_INT32 ? 4 : 1; }

static const char *dtype_name(dm_dtype t)
{
    return t == DM_DTYPE_FLOAT64 ? "float64" : t == DM_DTYPE_INT32 ? "int32" : "uint8";
}

/* ---- metadata --------------------------------------------------------------- */

static json_t *array_json(const dm_array_spec *a)
{
    json_t *shape = json_array(), *chunk = json_array(), *dims = json_array();
    for (int d = 0; d < a->ndim; d++) {
        json_array_append_new(shape, json_integer(a->shape[d]));
        json_array_append_new(chunk, json_integer(a->chunk[d]));
        json_array_append_new(dims, json_string(a->dims[d]));
    }
    json_t *fill = a->dtype == DM_DTYPE_FLOAT64 ? json_string("NaN")
                                                 : json_integer(a->dtype == DM_DTYPE_UINT8 ? 255 : -1);
    json_t *attrs = a->attributes ? json_deep_copy(a->attributes) : json_object();
    return json_pack("{s:i, s:s, s:o, s:s, s:{s:s, s:{s:o}}, s:{s:s, s:{s:s}}, s:o, "
                     "s:[{s:s, s:{s:s}}, {s:s}], s:o, s:o}",
                     "zarr_format", 3, "node_type", "array", "shape", shape, "data_type",
                     dtype_name(a->dtype), "chunk_grid", "name", "regular", "configuration",
                     "chunk_shape", chunk, "chunk_key_encoding", "name", "default",
                     "configuration", "separator", "/", "fill_value", fill, "codecs", "name",
                     "bytes", "configuration", "endian", "little", "name", "crc32c",
                     "attributes", attrs, "dimension_names", dims);
}

void dm_store_add_array(dm_store *st, const char *name, dm_dtype type, int ndim,
                        const int64_t *shape, const int *chunk, const char *const *dims,
                        json_t *attributes)
{
    assert(st->narr < DM_STORE_MAXARR && ndim >= 1 && ndim <= DM_STORE_MAXDIM);
    assert(strlen(name) < sizeof st->arr[0].name);
    dm_array_spec *a = &st->arr[st->narr++];
    memset(a, 0, sizeof *a);
    snprintf(a->name, sizeof a->name, "%s", name);
    a->dtype = type;
    a->ndim = ndim;
    for (int d = 0; d < ndim; d++) {
        assert(shape[d] >= 0 && chunk[d] >= 1);
        a->shape[d] = shape[d];
        a->chunk[d] = chunk[d];
        snprintf(a->dims[d], sizeof a->dims[d], "%s", dims[d]);
    }
    a->attributes = attributes;
}

/* The group's zarr.json: its attributes name the arrays and the sweep. */
static json_t *group_json(const dm_store *st)
{
    json_t *at = st->group_attributes ? json_incref(st->group_attributes) : json_object();
    return json_pack("{s:i, s:s, s:o}", "zarr_format", 3, "node_type", "group", "attributes", at);
}

/* The text of one metadata file, as written: indented, 17 digits, a
 * final newline (and a terminator after it, not written). */
static char *json_text(json_t *o, size_t *len)
{
    char *text = o ? json_dumps(o, JSON_INDENT(2) | JSON_REAL_PRECISION(17)) : NULL;
    json_decref(o);
    if (!text)
        return NULL;
    *len = strlen(text);
    char *more = realloc(text, *len + 2);
    if (!more) {
        free(text);
        return NULL;
    }
    more[(*len)++] = '\n';
    more[*len] = '\0';
    return more;
}

char *dm_store_metadata_text(const dm_store *st, int a, size_t *len)
{
    return json_text(a < 0 ? group_json(st) : array_json(&st->arr[a]), len);
}

void dm_store_metadata_path(const dm_store *st, int a, char *out, size_t len)
{
    if (a < 0)
        snprintf(out, len, "%s/zarr.json", st->path);
    else
        snprintf(out, len, "%s/%s/zarr.json", st->path, st->arr[a].name);
}

int dm_store_write_metadata_file(const dm_store *st, int a, dm_error *err)
{
    char path[1200];
    size_t n;
    if (a >= 0) {
        snprintf(path, sizeof path, "%s/%s", st->path, st->arr[a].name);
        int rc = dm_file_mkdirs(path, 0, err);
        if (rc)
            return rc;
    }
    char *text = dm_store_metadata_text(st, a, &n);
    if (!text)
        return dm_fail(err, DM_ENOMEM, "out of memory");
    dm_store_metadata_path(st, a, path, sizeof path);
    int rc = dm_file_write_atomic(path, text, n, err);
    free(text);
    return rc;
}

int dm_store_write_metadata(const dm_store *st, dm_error *err)
{
    int rc = dm_file_mkdirs(st->path, 0, err);
    for (int a = 0; a < st->narr && !rc; a++)
        rc = dm_store_write_metadata_file(st, a, err);
    /* the group last: its presence says the arrays' metadata is complete */
    return rc ? rc : dm_store_write_metadata_file(st, -1, err);
}

/* jansson reports a failed allocation as a parse error, or as none: a file
 * that does not parse is taken as out of memory when a few times its size
 * cannot be allocated either (then it was not read, so it is not judged). */
static int load_failed_for_memory(const char *path, const json_error_t *je)
{
    if (json_error_code(je) == json_error_out_of_memory)
        return 1;
    struct stat sb;
    size_t want = (stat(path, &sb) == 0 ? (size_t)sb.st_size : 0) * 8 + 65536;
    void *probe = malloc(want);
    int failed = probe == NULL;
    free(probe);
    return failed;
}

/* A whole number in [lo, hi] at json_array_get(list, d), or -1 when it is not. */
static int64_t json_whole(json_t *list, int d, int64_t lo, int64_t hi)
{
    json_t *v = json_array_get(list, (size_t)d);
    if (!json_is_integer(v) || json_integer_value(v) < lo || json_integer_value(v) > hi)
        return -1;
    return json_integer_value(v);
}

/* Metadata read from disk is input: every field is checked before it is
 * used for sizes, file names or loops. */
static int parse_array(const char *path, const char *name, dm_array_spec *a, dm_error *err)
{
    json_error_t je;
    json_t *o = json_load_file(path, 0, &je);
    if (!o)
        return load_failed_for_memory(path, &je)
                   ? dm_fail(err, DM_ENOMEM, "%s: out of memory reading it", path)
                   : dm_fail(err, DM_EIO, "%s:%d: %s", path, je.line, je.text);
    memset(a, 0, sizeof *a);
    snprintf(a->name, sizeof a->name, "%s", name);
    json_t *shape = json_object_get(o, "shape"), *dims = json_object_get(o, "dimension_names");
    json_t *chunk = json_object_get(json_object_get(json_object_get(o, "chunk_grid"),
                                                    "configuration"), "chunk_shape");
    const char *dt = json_string_value(json_object_get(o, "data_type"));
    int rc = DM_OK;
    if (!json_is_array(shape) || !json_is_array(chunk) || !dt || json_array_size(shape) < 1 ||
        json_array_size(shape) > DM_STORE_MAXDIM || json_array_size(shape) != json_array_size(chunk))
        rc = dm_fail(err, DM_EINVAL, "%s: not an array written by deltamap (shape, chunk_shape "
                     "or data_type missing, or not 1 to %d dimensions)", path, DM_STORE_MAXDIM);
    else if (strcmp(dt, "float64") && strcmp(dt, "int32") && strcmp(dt, "uint8"))
        rc = dm_fail(err, DM_EINVAL, "%s: data_type '%.40s' is not float64, int32 or uint8", path, dt);
    else {
        a->ndim = (int)json_array_size(shape);
        a->dtype = !strcmp(dt, "float64") ? DM_DTYPE_FLOAT64
                   : !strcmp(dt, "int32") ? DM_DTYPE_INT32 : DM_DTYPE_UINT8;
        uint64_t bytes = dm_dtype_size(a->dtype);
        for (int d = 0; d < a->ndim && !rc; d++) {
            int64_t n = json_whole(shape, d, 0, DM_STORE_MAX_EXTENT);
            int64_t c = json_whole(chunk, d, 1, DM_STORE_MAX_CHUNK_BYTES);
            if (n < 0)
                rc = dm_fail(err, DM_EINVAL, "%s: shape[%d] is not a whole number from 0 to %lld",
                             path, d, (long long)DM_STORE_MAX_EXTENT);
            else if (c < 0 || (bytes *= (uint64_t)c) > DM_STORE_MAX_CHUNK_BYTES)
                rc = dm_fail(err, DM_EINVAL, "%s: chunk_shape[%d]: chunks must have at least one "
                             "element along each dimension and at most %lld bytes",
                             path, d, (long long)DM_STORE_MAX_CHUNK_BYTES);
            else {
                a->shape[d] = n;
                a->chunk[d] = (int)c;
                const char *dn = json_string_value(json_array_get(dims, (size_t)d));
                snprintf(a->dims[d], sizeof a->dims[d], "%s", dn ? dn : "?");
            }
        }
        if (!rc)
            a->attributes = json_incref(json_object_get(o, "attributes"));
    }
    json_decref(o);
    return rc;
}

/* An array name is one plain path component that fits dm_array_spec. */
static int array_name_ok(const char *name)
{
    if (!name || !*name || name[0] == '.' || strlen(name) >= sizeof ((dm_array_spec *)0)->name)
        return 0;
    for (const char *p = name; *p; p++)
        if (*p == '/' || *p == '\\' || (unsigned char)*p < 0x20)
            return 0;
    return 1;
}

int dm_store_read_group(const char *path, json_t **attributes, dm_error *err)
{
    char file[1200];
    json_error_t je;
    snprintf(file, sizeof file, "%s/zarr.json", path);
    json_t *g = json_load_file(file, 0, &je);
    if (!g && load_failed_for_memory(file, &je))
        return dm_fail(err, DM_ENOMEM, "%s: out of memory reading zarr.json", path);
    if (!g)
        return json_error_code(&je) == json_error_cannot_open_file
                   ? dm_fail(err, DM_EIO, "%s: cannot open it (%s): not a map store", file,
                             strerror(errno))
                   : dm_fail(err, DM_EIO, "%s: not a map store (line %d: %s)", file, je.line,
                             je.text);
    *attributes = json_incref(json_object_get(g, "attributes"));
    json_decref(g);
    return DM_OK;
}

int dm_store_read_metadata(const char *path, dm_store *st, dm_error *err)
{
    char file[1200];
    memset(st, 0, sizeof *st);
    snprintf(st->path, sizeof st->path, "%s", path);
    int grc = dm_store_read_group(path, &st->group_attributes, err);
    if (grc)
        return grc;
    json_t *names = json_object_get(json_object_get(st->group_attributes, "deltamap"), "arrays");
    size_t i;
    json_t *v;
    json_array_foreach(names, i, v) {
        if (st->narr == DM_STORE_MAXARR)
            break;
        const char *name = json_string_value(v);
        if (!array_name_ok(name)) {
            dm_store_release(st);
            return dm_fail(err, DM_EINVAL, "%s: attributes.deltamap.arrays[%zu] is not an array "
                           "name (1 to 47 characters, no '/', not starting with '.')", file, i);
        }
        snprintf(file, sizeof file, "%s/%s/zarr.json", path, name);
        int rc = parse_array(file, name, &st->arr[st->narr], err);
        if (rc) {
            dm_store_release(st);
            return rc;
        }
        st->narr++;
    }
    return DM_OK;
}

void dm_store_release(dm_store *st)
{
    for (int a = 0; a < st->narr; a++)
        json_decref(st->arr[a].attributes);
    json_decref(st->group_attributes);
    st->narr = 0;
    st->group_attributes = NULL;
}

/* ---- the group's record of what made the store -------------------------------- */

/* CRC-32C of rec's canonical text (compact, keys sorted, 17 digits) less
 * its own "crc32c" member; 0 when it cannot be printed. */
static uint32_t record_crc(json_t *rec)
{
    json_t *copy = json_deep_copy(rec);
    json_object_del(copy, "crc32c");
    char *text = copy ? json_dumps(copy, JSON_COMPACT | JSON_SORT_KEYS | JSON_REAL_PRECISION(17))
                      : NULL;
    json_decref(copy);
    uint32_t crc = text ? dm_crc32c(text, strlen(text)) : 0;
    free(text);
    return crc;
}

void dm_store_seal_record(json_t *rec)
{
    json_object_set_new(rec, "crc32c", json_integer(record_crc(rec)));
}

int dm_store_record_sealed(json_t *rec)
{
    json_t *crc = json_object_get(rec, "crc32c");
    return json_is_integer(crc) && json_integer_value(crc) == (json_int_t)record_crc(rec);
}

/* ---- a file against the bytes it should hold ---------------------------------- */

enum { SAME = 0, MISSING = 1, DIFFERS = 2 };

/* The file at path against want[0..n-1]. Up to n + 1 bytes are read (a
 * longer file differs) into buf, which holds n + 1; *got: how many. */
static int compare_file(const char *path, const void *want, size_t n, unsigned char *buf,
                        size_t *got)
{
    FILE *f = fopen(path, "rb");
    *got = 0;
    if (!f)
        return MISSING;
    *got = fread(buf, 1, n + 1, f);
    fclose(f);
    return *got == n && !memcmp(buf, want, n) ? SAME : DIFFERS;
}

/* The first place where have departs from want, as a field path
 * ("chunk_grid.configuration.chunk_shape[2]") appended to out. */
static void first_difference(json_t *want, json_t *have, char *out, size_t len)
{
    size_t used = strlen(out);
    const char *key;
    json_t *v;
    if (json_is_object(want) && json_is_object(have)) {
        json_object_foreach(want, key, v)
            if (!json_equal(v, json_object_get(have, key))) {
                snprintf(out + used, len - used, "%s%.60s", used ? "." : "", key);
                first_difference(v, json_object_get(have, key), out, len);
                return;
            }
        json_object_foreach(have, key, v)
            if (!json_object_get(want, key)) {
                snprintf(out + used, len - used, "%s%.60s", used ? "." : "", key);
                return;
            }
    }
    if (json_is_array(want) && json_is_array(have) && json_array_size(want) == json_array_size(have))
        for (size_t i = 0; i < json_array_size(want); i++)
            if (!json_equal(json_array_get(want, i), json_array_get(have, i))) {
                snprintf(out + used, len - used, "[%zu]", i);
                first_difference(json_array_get(want, i), json_array_get(have, i), out, len);
                return;
            }
}

/* What is wrong with a metadata file that differs from want, in words. */
static void metadata_problem(const unsigned char *got, size_t n, const char *want, size_t wantlen,
                             char *why, size_t len)
{
    json_error_t je, jw;
    json_t *have = json_loadb((const char *)got, n, 0, &je);
    json_t *exp = json_loadb(want, wantlen, 0, &jw);
    char field[256] = "", raw[400];
    /* jansson's text quotes the damaged bytes ("invalid token near '...'") */
    if (!have) {
        snprintf(raw, sizeof raw, "not JSON (line %d: %.80s)", je.line, je.text);
        dm_printable(why, len, raw);
    } else if (exp && !json_equal(exp, have)) {
        first_difference(exp, have, field, sizeof field);
        snprintf(raw, sizeof raw, "field '%s' is not what deltamap writes for this store", field);
        dm_printable(why, len, raw);
    } else
        snprintf(why, len, "the same fields as deltamap writes for this store, in other text");
    json_decref(have);
    json_decref(exp);
}

/* What is wrong with a chunk file that differs from want. */
static void chunk_problem(const unsigned char *got, size_t n, size_t wantlen, char *why, size_t len)
{
    if (n != wantlen)
        snprintf(why, len, "%s (%zu bytes, not %zu)", n > wantlen ? "too long" : "too short", n,
                 wantlen);
    else {
        uint32_t stored = got[n - 4] | got[n - 3] << 8 | got[n - 2] << 16 | (uint32_t)got[n - 1] << 24;
        snprintf(why, len, "%s", stored != dm_crc32c(got, n - 4)
                                     ? "checksum mismatch (corrupt chunk)"
                                     : "values are not those deltamap writes for this store (checksum valid)");
    }
}

int dm_store_compare_file(const char *path, const void *want, size_t n, int chunk, char *why,
                          size_t len, int *differs, dm_error *err)
{
    size_t got;
    unsigned char *buf = malloc(n + 1);
    *differs = 0;
    if (!buf)
        return dm_fail(err, DM_ENOMEM, "out of memory");
    int how = compare_file(path, want, n, buf, &got);
    if (how == MISSING)
        snprintf(why, len, "missing");
    else if (how == DIFFERS && chunk)
        chunk_problem(buf, got, n, why, len);
    else if (how == DIFFERS)
        metadata_problem(buf, got, want, n, why, len);
    free(buf);
    *differs = how != SAME;
    return DM_OK;
}

/* ---- chunks ------------------------------------------------------------------ */

void dm_store_chunk_path(const dm_store *st, int a, const int64_t *c, char *out, size_t len)
{
    int n = snprintf(out, len, "%s/%s/c", st->path, st->arr[a].name);
    for (int d = 0; d < st->arr[a].ndim && n > 0 && (size_t)n < len; d++)
        n += snprintf(out + n, len - (size_t)n, "/%lld", (long long)c[d]);
}

size_t dm_store_chunk_elems(const dm_store *st, int a)
{
    size_t e = 1;
    for (int d = 0; d < st->arr[a].ndim; d++)
        e *= (size_t)st->arr[a].chunk[d];
    return e;
}

unsigned char *dm_store_encode_chunk(const dm_store *st, int a, const void *data, size_t *len)
{
    size_t nbytes = dm_store_chunk_elems(st, a) * dm_dtype_size(st->arr[a].dtype);
    unsigned char *buf = malloc(nbytes + 4);
    if (!buf)
        return NULL;
    memcpy(buf, data, nbytes); /* x86-64 and aarch64 Linux are little-endian */
    uint32_t crc = dm_crc32c(buf, nbytes);
    for (int b = 0; b < 4; b++)
        buf[nbytes + b] = (unsigned char)(crc >> (8 * b));
    *len = nbytes + 4;
    return buf;
}

int dm_store_write_chunk(const dm_store *st, int a, const int64_t *c, const void *data,
                         dm_error *err)
{
    char path[1200];
    size_t len;
    unsigned char *buf = dm_store_encode_chunk(st, a, data, &len);
    if (!buf)
        return dm_fail(err, DM_ENOMEM, "out of memory");
    dm_store_chunk_path(st, a, c, path, sizeof path);
    /* directories below the array's own, never the array or the store: a
     * writer whose store was removed (or replaced by --replace) fails here
     * instead of leaving a stray tree */
    char *slash = strrchr(path, '/');
    *slash = '\0';
    int rc = dm_file_mkdirs(path, strlen(st->path) + strlen(st->arr[a].name) + 1, err);
    *slash = '/';
    if (!rc)
        rc = dm_file_write_atomic(path, buf, len, err);
    free(buf);
    return rc;
}

void dm_store_clean_chunk(const dm_store *st, int a, const int64_t *c)
{
    char path[1200];
    dm_store_chunk_path(st, a, c, path, sizeof path);
    char *slash = strrchr(path, '/');
    *slash = '\0';
    dm_file_remove_stale_temps(path, slash + 1);
}

int dm_store_read_chunk(const dm_store *st, int a, const int64_t *c, void *data, int *missing,
                        dm_error *err)
{
    char path[1200];
    size_t nbytes = dm_store_chunk_elems(st, a) * dm_dtype_size(st->arr[a].dtype);
    dm_store_chunk_path(st, a, c, path, sizeof path);
    *missing = 0;
    FILE *f = fopen(path, "rb");
    if (!f) {
        *missing = 1;
        return dm_fail(err, DM_EIO, "%s: missing", path);
    }
    unsigned char tail[5];
    size_t got = fread(data, 1, nbytes, f);
    size_t got_tail = fread(tail, 1, 5, f);
    fclose(f);
    if (got != nbytes || got_tail != 4)
        return dm_fail(err, DM_EIO, "%s: wrong size (corrupt chunk)", path);
    uint32_t stored = tail[0] | tail[1] << 8 | tail[2] << 16 | (uint32_t)tail[3] << 24;
    if (stored != dm_crc32c(data, nbytes))
        return dm_fail(err, DM_EIO, "%s: checksum mismatch (corrupt chunk)", path);
    return DM_OK;
}
