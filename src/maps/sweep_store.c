/* Opening, creating or joining a sweep's map store (see sweep_impl.h). */
#include <dirent.h>
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <omp.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "dm_file.h"
#include "sweep_impl.h"

/* ---- opening or creating the store ------------------------------------------
 * Any number of processes, on any hosts, may open or create one store at
 * once. A store is created whole: its metadata and coordinates are written
 * under a temporary name beside it and renamed into place, so the others
 * see no store or a complete one, never a half-made directory. Whoever
 * renames first owns it; the others find its fingerprint and join it, or
 * are refused and touch nothing. */

enum { STORE_ABSENT = -1, STORE_RETRY = -2 };
#define PREPARE_PATIENCE_S 60.0 /* NFS's default longest attribute cache time */

static json_t *fingerprint_of(json_t *group_attributes)
{
    return json_object_get(json_object_get(group_attributes, "deltamap"), "fingerprint");
}

/* Whether the two fingerprints hold the same value at key (both without
 * it is the same: json_equal says NULLs differ). */
static int same_at(json_t *ofp, json_t *nfp, const char *key)
{
    json_t *a = json_object_get(ofp, key), *b = json_object_get(nfp, key);
    return (!a && !b) || json_equal(a, b);
}

/* What differs between the store's fingerprint and ours, in words. */
static void difference(json_t *ofp, json_t *nfp, char *out, size_t len)
{
    const char *ov = json_string_value(json_object_get(ofp, "version"));
    const char *nv = json_string_value(json_object_get(nfp, "version"));
    const char *what = "other options (modes, mesh, tile, move or version)";
    if (!ofp)
        what = "an unreadable store";
    else if (ov && nv && strcmp(ov, nv)) { /* its layout may differ: not checked, not resumed */
        snprintf(out, len, "another version, made by %.60s (this is %s)", ov, nv);
        return;
    } else if (!same_at(ofp, nfp, "robot_ini"))
        what = "another robot";
    else if (!same_at(ofp, nfp, "grid"))
        what = "another grid";
    else if (!same_at(ofp, nfp, "tolerance"))
        what = "other tolerance Monte Carlo settings (samples, seed, spec, tolerances or "
               "their law, or none)";
    else if (!same_at(ofp, nfp, "method"))
        what = "another --method (the member bases or the full model)";
    snprintf(out, len, "%s", what);
}

/* "maps/xy" -> parent "maps", base "xy" ("." for a bare name). */
static const char *split_path(const char *path, char *parent, size_t len)
{
    const char *slash = strrchr(path, '/');
    if (!slash)
        snprintf(parent, len, ".");
    else
        snprintf(parent, len, "%.*s", slash == path ? 1 : (int)(slash - path), path);
    return slash ? slash + 1 : path;
}

static int dir_is_empty(const char *path)
{
    DIR *d = opendir(path);
    if (!d)
        return 1; /* absent: created later */
    struct dirent *e;
    int n = 0;
    while ((e = readdir(d)))
        n += strcmp(e->d_name, ".") && strcmp(e->d_name, "..");
    closedir(d);
    return n == 0;
}

static int same_dir(const struct stat *a, const struct stat *b)
{
    return a->st_dev == b->st_dev && a->st_ino == b->st_ino;
}

/* What dead runs left of the store's skeleton: staging directories beside
 * it, metadata and coordinate temporaries inside (data chunks' ones are
 * cleaned tile by tile, by the shard that recomputes the tile). */
static void clean_skeleton(const sweep_ctx *c, const char *path)
{
    char parent[1024], dir[1200];
    dm_file_remove_stale_temps(parent, split_path(path, parent, sizeof parent));
    dm_file_remove_stale_temps(path, "zarr.json");
    for (int a = 0; a < c->store.narr; a++) {
        snprintf(dir, sizeof dir, "%s/%s", path, c->store.arr[a].name);
        dm_file_remove_stale_temps(dir, "zarr.json");
        snprintf(dir, sizeof dir, "%s/%s/c", path, c->store.arr[a].name);
        if (a >= c->ndata)
            dm_file_remove_stale_temps(dir, "0");
    }
}

/* An existing store of this sweep: every array's metadata and the
 * coordinate and label chunks as this sweep writes them, those that are
 * not rewritten (the same bytes as at its creation) and reported. */
static int repair_skeleton(sweep_ctx *c, dm_error *err)
{
    long found;
    return dm_sweep_schema_check(c, 1, c->o.on_repair, c->o.repair_user, &found, NULL, NULL, err);
}

/* replace (--replace) on a store of another sweep: rename it aside, check that it was
 * the store judged (a concurrent process may have replaced it already:
 * then put that one back and look again), remove it. */
static int move_aside(const char *path, const struct stat *judged, dm_error *err)
{
    char aside[1200];
    struct stat sb;
    dm_file_temp_name(path, aside, sizeof aside);
    dm_file_remove_tree(aside);
    if (rename(path, aside))
        return errno == ENOENT ? STORE_RETRY
                               : dm_fail(err, DM_EIO, "%s: cannot replace the store: %s", path,
                                         strerror(errno));
    if (stat(aside, &sb) || !same_dir(&sb, judged)) {
        if (rename(aside, path))
            return dm_fail(err, DM_EIO,
                           "%s: another process replaced the store at the same moment; the "
                           "store it made is now %s",
                           path, aside);
        return STORE_RETRY;
    }
    if (dm_file_remove_tree(aside))
        return dm_fail(err, DM_EIO, "%s: cannot remove the old store (moved to %s): %s", path,
                       aside, strerror(errno));
    return STORE_ABSENT;
}

/* The store at path: DM_OK when it holds this sweep, STORE_ABSENT when
 * there is none (or --replace moved another sweep's away), STORE_RETRY when
 * it changed while we looked. `racing`: we just lost a creation race, so a
 * directory without metadata may be a store not yet visible to this host. */
static int open_existing(sweep_ctx *c, const char *path, int racing, dm_error *err)
{
    char file[1100];
    struct stat dir, again;
    snprintf(file, sizeof file, "%s/zarr.json", path);
    if (stat(path, &dir))
        return STORE_ABSENT;
    int has_group = access(file, F_OK) == 0;
    if (!S_ISDIR(dir.st_mode) || (!has_group && !dir_is_empty(path)))
        return racing ? STORE_RETRY
                      : dm_fail(err, DM_EINVAL,
                                "%s exists and is not a map store (%s: no such file); choose "
                                "another store", path, file);
    if (!has_group)
        return STORE_ABSENT; /* an empty directory */
    json_t *attrs = NULL;
    dm_error rerr;
    int rc = dm_store_read_group(path, &attrs, &rerr);
    if (rc == DM_ENOMEM)
        return dm_fail(err, rc, "%s", rerr.msg); /* no verdict on the store */
    json_t *ofp = rc ? NULL : fingerprint_of(attrs);
    json_t *nfp = fingerprint_of(c->store.group_attributes);
    int same = ofp && json_equal(ofp, nfp);
    char what[800];
    difference(ofp, nfp, what, sizeof what);
    json_decref(attrs);
    /* the group's metadata names the sweep: one that records this sweep's
     * fingerprint but differs elsewhere cannot be told apart from another
     * sweep's (or another version's), so it is not rewritten */
    char why[300];
    if (same && (rc = dm_sweep_schema_check_group(c, why, sizeof why, err)))
        return rc;
    if (same && why[0]) {
        same = 0;
        snprintf(what, sizeof what, "unknown origin (the file records this sweep but is not "
                 "what it writes: %s; it cannot be told apart from another sweep's)", why);
    }
    if (stat(path, &again) || !same_dir(&dir, &again))
        return STORE_RETRY; /* replaced while we read it */
    if (same) {
        clean_skeleton(c, path);
        return repair_skeleton(c, err);
    }
    if (!c->o.replace) {
        c->store_refused = 1;
        return dm_fail(err, DM_EINVAL,
                       "%s/zarr.json: the store holds a sweep of %s: it is replaced only on "
                       "request; or choose another store", path, what);
    }
    return move_aside(path, &dir, err);
}

int dm_sweep_store_engine(const sweep_ctx *c, const char *path)
{
    json_t *attrs = NULL;
    dm_error err;
    if (dm_store_read_group(path, &attrs, &err))
        return -1;
    json_t *ofp = json_deep_copy(fingerprint_of(attrs));
    json_t *nfp = json_deep_copy(fingerprint_of(c->store.group_attributes));
    json_decref(attrs);
    int engine = -1;
    if (json_is_object(ofp) && json_is_object(nfp)) {
        const char *method = json_string_value(json_object_get(ofp, "method"));
        int members = method && !strcmp(method, "members"); /* before del frees it */
        json_object_del(ofp, "method");
        json_object_del(nfp, "method");
        if (json_equal(ofp, nfp))
            engine = members ? DM_SWEEP_MEMBERS : DM_SWEEP_FULL_MODEL;
    }
    json_decref(ofp);
    json_decref(nfp);
    return engine;
}

/* Build the store under PATH.tmp.HOST.PID, rename it to PATH. STORE_RETRY:
 * another process created it first (the rename found PATH not empty). */
static int create_store(sweep_ctx *c, const char *path, dm_error *err)
{
    char parent[1024], stage[1024], keep[sizeof c->store.path];
    const char *base = split_path(path, parent, sizeof parent);
    int rc = dm_file_mkdirs(parent, 0, err);
    if (rc)
        return rc;
    dm_file_remove_stale_temps(parent, base);
    dm_file_temp_name(path, stage, sizeof stage);
    dm_file_remove_tree(stage); /* left by an earlier process with our PID */
    memcpy(keep, c->store.path, sizeof keep);
    snprintf(c->store.path, sizeof c->store.path, "%s", stage);
    rc = dm_store_write_metadata(&c->store, err);
    if (!rc)
        rc = dm_sweep_schema_write_coordinates(c, err);
    memcpy(c->store.path, keep, sizeof keep);
    if (!rc && !rename(stage, path))
        return DM_OK;
    int e = errno;
    dm_file_remove_tree(stage);
    if (rc)
        return rc;
    if (e == ENOTEMPTY || e == EEXIST)
        return STORE_RETRY;
    return dm_fail(err, DM_EIO, "%s: cannot create the store: %s", path, strerror(e));
}

/* Open the store if it holds this sweep, or create it; another sweep's is
 * refused unless replace (which replaces only a store of another sweep, so
 * any number of processes may be given it). A lost race is retried: at
 * once, as a rule, but a network filesystem may show the winner's store to
 * this host only after its attribute cache expires. */
int dm_sweep_store_prepare(sweep_ctx *c, const char *path, dm_error *err)
{
    double t0 = omp_get_wtime();
    int rc;
    for (int attempt = 0;; attempt++) {
        double waited = omp_get_wtime() - t0;
        rc = open_existing(c, path, attempt > 0 && waited < PREPARE_PATIENCE_S, err);
        if (rc == STORE_ABSENT)
            rc = create_store(c, path, err);
        if (rc != STORE_RETRY || waited >= PREPARE_PATIENCE_S)
            break;
        long ms = attempt < 50 ? 10 * (attempt + 1) : 500;
        struct timespec pause = {ms / 1000, 1000000L * (ms % 1000)};
        nanosleep(&pause, NULL);
    }
    if (rc == STORE_RETRY)
        rc = dm_fail(err, DM_EIO, "%s: the store kept changing while this process opened it", path);
    return rc;
}
