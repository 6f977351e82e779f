/* dm_file — files that appear whole or not at all, and the temporaries of
 * their writers.
 *
 * Every file deltamap writes (store chunks and metadata, CSV and JSON
 * outputs, robot files) is written under a temporary name beside it,
 * PATH.tmp.HOST.PID, and renamed into place when complete: a reader, a
 * concurrent process or a rerun after a kill sees the old file or the new
 * one, never part of one. HOST.PID names the writer, so that another
 * process can tell a dead writer's leftovers from a live one's. */
#ifndef DM_FILE_H
#define DM_FILE_H

#include <stddef.h>
#include <stdio.h>

#include "dm_error.h"

/* An output being written: f writes to tmp until commit renames it to
 * path, or abort removes it. */
typedef struct dm_file_out {
    FILE *f;
    char path[1024], tmp[1200];
} dm_file_out;

int dm_file_out_open(dm_file_out *out, const char *path, dm_error *err);
/* Flushed and fsync'd (an output a user keeps), then renamed. DM_EIO on a
 * failed write, flush, close or rename; the temporary is gone then. */
int dm_file_out_commit(dm_file_out *out, dm_error *err);
void dm_file_out_abort(dm_file_out *out);

/* Write n bytes as the whole of path (no fsync: store chunks, which a
 * checksum guards and a rerun recomputes). */
int dm_file_write_atomic(const char *path, const void *data, size_t n, dm_error *err);

/* The temporary name of path for this process: PATH.tmp.HOST.PID. */
void dm_file_temp_name(const char *path, char *out, size_t len);

/* A temporary of another host counts as abandoned after this long. */
#define DM_TEMP_STALE_S 3600

/* In directory dir, remove the temporaries BASE.tmp.HOST.PID (any BASE when
 * base is NULL; files or whole directories) whose writer is gone: on this
 * host, no process PID exists; of another host, older than
 * DM_TEMP_STALE_S. Returns how many were removed. */
int dm_file_remove_stale_temps(const char *dir, const char *base);

/* rm -r (0, or -1 with errno; an absent path is not an error) */
int dm_file_remove_tree(const char *path);

/* mkdir -p of path, creating no component within its first `keep`
 * characters (0: any). */
int dm_file_mkdirs(const char *path, size_t keep, dm_error *err);

#endif
