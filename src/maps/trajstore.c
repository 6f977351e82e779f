/* A trajectory run's store: its layout, and a store checked against it
 * (see dm_trajstore.h). */
#include "dm_trajstore.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "dm_file.h"
#include "dm_version.h"

#define TRAJ_VERSION "deltamap " DM_VERSION

/* One array along time (and a second axis of length m), chunked by
 * DM_TRAJSTORE_CHUNK samples. */
static void time_array(dm_store *st, const char *name, const char *dim2, int m, const char *units,
                       const char *long_name, long n)
{
    const int64_t shape[2] = {n, m};
    const int chunk[2] = {n < DM_TRAJSTORE_CHUNK ? (int)n : DM_TRAJSTORE_CHUNK, m};
    const char *dims[2] = {"time", dim2};
    dm_store_add_array(st, name, DM_DTYPE_FLOAT64, dim2 ? 2 : 1, shape, chunk, dims,
                       json_pack("{s:s, s:s}", "units", units, "long_name", long_name));
}

void dm_trajstore_define(dm_store *st, const char *path, const char *robot, const char *traj,
                         long n, int nfreq)
{
    memset(st, 0, sizeof *st);
    snprintf(st->path, sizeof st->path, "%s", path);
    time_array(st, "time", NULL, 1, "s", "time", n);
    time_array(st, "position", "axis", 3, "m", "commanded platform centre", n);
    time_array(st, "error", "component", 6, "m, rad", "platform error dx dy dz (m) ex ey ez (rad)", n);
    time_array(st, "error_norm", NULL, 1, "m", "|(dx, dy, dz)|", n);
    time_array(st, "tool_error", "axis", 3, "m", "tool point error", n);
    time_array(st, "frequencies_hz", "mode", nfreq, "Hz", "frequencies of the frozen configuration", n);
    time_array(st, "coupling_index_log10", NULL, 1, "1",
               "log10 of Zheng's coupling index (eq. 33), det K of the frozen model", n);
    time_array(st, "coupling_index_change_log10", NULL, 1, "1",
               "coupling_index_log10 minus the nominal robot's (every effect off) at the same "
               "pose and mesh", n);
    json_t *names = json_array();
    for (int a = 0; a < st->narr; a++)
        json_array_append_new(names, json_string(st->arr[a].name));
    /* samples and modes: what the arrays' metadata follows from, so a
     * check needs no array's word for it */
    json_t *rec = json_pack("{s:s, s:s, s:s, s:o, s:I, s:i}", "tool", TRAJ_VERSION, "robot", robot,
                            "path", traj, "arrays", names, "samples", (json_int_t)n, "modes", nfreq);
    dm_store_seal_record(rec);
    st->group_attributes = json_pack("{s:s, s:o}", "title", DM_TRAJSTORE_TITLE, "deltamap", rec);
}

int dm_trajstore_is(json_t *attrs)
{
    const char *title = json_string_value(json_object_get(attrs, "title"));
    return title && !strcmp(title, DM_TRAJSTORE_TITLE);
}

/* Every chunk of every array against its checksum, each bad one reported. */
static int check_chunks(dm_sweep_check *chk, dm_sweep_damage_fn report, void *user, dm_error *err)
{
    for (int a = 0; a < chk->store.narr; a++) {
        const dm_array_spec *s = &chk->store.arr[a];
        void *buf = malloc(dm_store_chunk_elems(&chk->store, a) * dm_dtype_size(s->dtype));
        if (!buf)
            return dm_fail(err, DM_ENOMEM, "out of memory");
        int64_t c[DM_STORE_MAXDIM] = {0};
        for (c[0] = 0; c[0] * s->chunk[0] < s->shape[0]; c[0]++) {
            int missing;
            dm_error e;
            char path[1200];
            if (dm_store_read_chunk(&chk->store, a, c, buf, &missing, &e)) {
                chk->problems++;
                chk->chunk_problems++;
                dm_store_chunk_path(&chk->store, a, c, path, sizeof path);
                if (report)
                    report(user, path, missing ? "missing" : strstr(e.msg, "checksum")
                                                               ? "checksum mismatch (corrupt chunk)"
                                                               : "wrong size (corrupt chunk)", 0);
            }
        }
        free(buf);
    }
    return DM_OK;
}

/* The layout the group's attributes record: 1 when they record one this
 * version writes (and the store is defined at path). */
static int layout_from(json_t *attrs, const char *path, dm_store *st)
{
    json_t *dm = json_object_get(attrs, "deltamap");
    const char *robot = json_string_value(json_object_get(dm, "robot"));
    const char *traj = json_string_value(json_object_get(dm, "path"));
    json_t *n = json_object_get(dm, "samples"), *k = json_object_get(dm, "modes");
    if (!robot || !traj || !json_is_integer(n) || !json_is_integer(k) ||
        json_integer_value(n) < 1 || json_integer_value(n) > DM_STORE_MAX_EXTENT ||
        json_integer_value(k) < 0 || json_integer_value(k) > DM_MAX_MODES)
        return 0;
    dm_trajstore_define(st, path, robot, traj, (long)json_integer_value(n),
                        (int)json_integer_value(k));
    return 1;
}

int dm_trajstore_check(const char *path, json_t *attrs, int repair, dm_sweep_damage_fn report,
                       void *user, dm_sweep_check *chk, dm_error *err)
{
    const char *tool = json_string_value(json_object_get(json_object_get(attrs, "deltamap"), "tool"));
    char why[300], file[1200];
    int rc = DM_OK, differs;
    memset(chk, 0, sizeof *chk);
    chk->trajectory = 1;
    snprintf(chk->made_by, sizeof chk->made_by, "%s", tool ? tool : "");
    chk->other_version = tool && strcmp(tool, TRAJ_VERSION);
    int sealed = dm_store_record_sealed(json_object_get(attrs, "deltamap"));
    if (!chk->other_version && sealed && layout_from(attrs, path, &chk->store)) {
        chk->verified = 1;
        for (int a = -1; a < chk->store.narr && !rc; a++) {
            size_t n;
            char *text = dm_store_metadata_text(&chk->store, a, &n);
            if (!text)
                return dm_fail(err, DM_ENOMEM, "out of memory");
            dm_store_metadata_path(&chk->store, a, file, sizeof file);
            rc = dm_store_compare_file(file, text, n, 0, why, sizeof why, &differs, err);
            free(text);
            if (rc || !differs)
                continue;
            chk->problems++;
            /* the group's names the run: never rewritten */
            int fixed = repair && a >= 0 && !(rc = dm_store_write_metadata_file(&chk->store, a, err));
            chk->repaired += fixed;
            if (report && !rc)
                report(user, file, why, fixed);
        }
    } else {
        if (!chk->other_version) {
            snprintf(file, sizeof file, "%s/zarr.json", path);
            chk->problems++;
            if (report)
                report(user, file, sealed ? "records no trajectory run this version writes "
                                        "(attributes.deltamap: robot, path, samples, modes)"
                                      : "attributes.deltamap fails its checksum (crc32c): the "
                                        "run it records cannot be trusted, nothing is checked "
                                        "or repaired against it", 0);
        }
        rc = dm_store_read_metadata(path, &chk->store, err);
    }
    if (!rc)
        rc = check_chunks(chk, report, user, err);
    if (rc)
        dm_store_release(&chk->store);
    return rc;
}

/* ---- writing a run ------------------------------------------------------ */

int dm_trajstore_keep(dm_trajstore_samples *l, const dm_integ_sample *s, double change)
{
    if (l->n == l->cap) {
        long cap = l->cap ? 2 * l->cap : 1024;
        dm_integ_sample *grown = realloc(l->s, sizeof *grown * cap);
        if (grown)
            l->s = grown;
        double *more = grown ? realloc(l->change, sizeof *more * cap) : NULL;
        if (!more)
            return 1;
        l->change = more;
        l->cap = cap;
    }
    l->change[l->n] = change;
    l->s[l->n++] = *s;
    return 0;
}

/* Sample i's value j of array `array` (dm_trajstore_define's order). */
static double sample_value(const dm_trajstore_samples *l, long i, int array, int j)
{
    const dm_integ_sample *s = &l->s[i];
    switch (array) {
    case 0: return s->t_s;
    case 1: return s->P_m[j];
    case 2: return s->error[j];
    case 3: return sqrt(s->error[0] * s->error[0] + s->error[1] * s->error[1] + s->error[2] * s->error[2]);
    case 4: return s->tool_error_m[j];
    case 5: return j < s->nfreq ? s->freq_hz[j] : NAN;
    case 6: return s->coupling_index_log10;
    default: return l->change[i];
    }
}

/* A run's store appears whole or not at all: it is written as PATH.tmp.PID
 * and renamed over PATH, replacing an earlier run's store (a directory
 * whose zarr.json is a deltamap trajectory run) but nothing else. */
static int replace_store(const char *tmp, const char *path, dm_error *err)
{
    if (!rename(tmp, path))
        return DM_OK;
    if (errno == ENOTEMPTY || errno == EEXIST) {
        char file[1100];
        snprintf(file, sizeof file, "%s/zarr.json", path);
        json_error_t je;
        json_t *g = json_load_file(file, 0, &je);
        if (!g && json_error_code(&je) == json_error_out_of_memory)
            return dm_fail(err, DM_ENOMEM, "%s: out of memory", file);
        const char *title = json_string_value(json_object_get(json_object_get(g, "attributes"), "title"));
        int ours = title && !strcmp(title, "deltamap trajectory run");
        json_decref(g);
        if (!ours)
            return dm_fail(err, DM_EINVAL, "%s exists and is not a trajectory store written by "
                           "deltamap; choose another --out", path);
        if (!dm_file_remove_tree(path) && !rename(tmp, path))
            return DM_OK;
    }
    return dm_fail(err, DM_EIO, "%s: cannot replace: %s", path, strerror(errno));
}

int dm_trajstore_write(const char *path, const char *robot, const char *traj,
                       const dm_trajstore_samples *l, dm_error *err)
{
    int nfreq = l->n ? l->s[0].nfreq : 0;
    dm_store st;
    char tmp[sizeof st.path];
    snprintf(tmp, sizeof tmp, "%s.tmp.%ld", path, (long)getpid());
    dm_trajstore_define(&st, tmp, robot, traj, l->n, nfreq);
    int rc = dm_store_write_metadata(&st, err);
    size_t most = 0; /* elements of the largest chunk */
    for (int a = 0; a < st.narr; a++)
        most = dm_store_chunk_elems(&st, a) > most ? dm_store_chunk_elems(&st, a) : most;
    double *buf = rc ? NULL : malloc(sizeof(double) * most);
    if (!rc && !buf)
        rc = dm_fail(err, DM_ENOMEM, "out of memory");
    for (int a = 0; a < st.narr && !rc; a++) {
        int m = st.arr[a].ndim > 1 ? (int)st.arr[a].shape[1] : 1, ch = st.arr[a].chunk[0];
        for (long c0 = 0; c0 * ch < l->n && !rc; c0++) {
            for (long i = 0; i < ch; i++)
                for (int j = 0; j < m; j++)
                    buf[i * m + j] = c0 * ch + i < l->n ? sample_value(l, c0 * ch + i, a, j) : NAN;
            const int64_t c[2] = {c0, 0};
            rc = dm_store_write_chunk(&st, a, c, buf, err);
        }
    }
    free(buf);
    dm_store_release(&st);
    if (!rc)
        rc = replace_store(st.path, path, err);
    if (rc)
        dm_file_remove_tree(st.path);
    return rc;
}

void dm_trajstore_samples_free(dm_trajstore_samples *l)
{
    free(l->s);
    free(l->change);
    memset(l, 0, sizeof *l);
}
