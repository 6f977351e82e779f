/* Files that appear whole or not at all, and the temporaries of their
 * writers (see dm_file.h). */
#define _XOPEN_SOURCE 700 /* nftw */
#include "dm_file.h"

#include <assert.h>
#include <dirent.h>
#include <errno.h>
#include <ftw.h>
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

/* mkdir -p of path, creating no component within its first `keep`
 * characters. Deepest first: on a network filesystem every mkdir is a
 * round trip to the metadata server, and as a rule the parent exists. */
int dm_file_mkdirs(const char *path, size_t keep, dm_error *err)
{
    if (!mkdir(path, 0777) || errno == EEXIST)
        return DM_OK;
    char parent[1024];
    const char *slash = strrchr(path, '/');
    int e = errno;
    if (e != ENOENT || !slash || slash == path || (size_t)(slash - path) <= keep ||
        (size_t)(slash - path) >= sizeof parent)
        return dm_fail(err, DM_EIO, "%s: cannot create directory: %s", path, strerror(e));
    snprintf(parent, sizeof parent, "%.*s", (int)(slash - path), path);
    int rc = dm_file_mkdirs(parent, keep, err);
    if (rc)
        return rc;
    if (mkdir(path, 0777) && errno != EEXIST)
        return dm_fail(err, DM_EIO, "%s: cannot create directory: %s", path, strerror(errno));
    return DM_OK;
}

/* ---- temporaries -------------------------------------------------------------
 * PATH.tmp.HOST.PID: the host and process that write it, so that another
 * process can tell a live writer's file from a dead one's. */

static void host_name(char *out, size_t len)
{
    assert(len > 0);
    if (gethostname(out, len) || !out[0])
        snprintf(out, len, "localhost");
    out[len - 1] = '\0';
    for (char *p = out; *p; p++)
        if (*p == '/')
            *p = '_';
}

void dm_file_temp_name(const char *path, char *out, size_t len)
{
    char host[64];
    host_name(host, sizeof host);
    snprintf(out, len, "%s.tmp.%s.%ld", path, host, (long)getpid());
}

/* "HOST.PID" (or "PID", as earlier versions wrote them) after ".tmp.": is its
 * writer gone? On this host: its process no longer exists. On another:
 * the file is older than DM_TEMP_STALE_S (a writer holds one for
 * milliseconds), as no process here can ask that host. */
static int temp_is_stale(const char *writer, time_t mtime)
{
    const char *dot = strrchr(writer, '.');
    char *end;
    long pid = strtol(dot ? dot + 1 : writer, &end, 10);
    if (*end || pid <= 0)
        return 0; /* not our naming: leave it */
    char host[64], theirs[64] = "";
    host_name(host, sizeof host);
    if (dot)
        snprintf(theirs, sizeof theirs, "%.*s", (int)(dot - writer), writer);
    if (dot && strcmp(theirs, host))
        return time(NULL) - mtime > DM_TEMP_STALE_S;
    return pid != (long)getpid() && kill((pid_t)pid, 0) && errno == ESRCH;
}

static int remove_entry(const char *path, const struct stat *sb, int flag, struct FTW *ftw)
{
    (void)sb, (void)flag, (void)ftw;
    return remove(path) && errno != ENOENT;
}

int dm_file_remove_tree(const char *path)
{
    struct stat sb;
    if (lstat(path, &sb))
        return errno == ENOENT ? 0 : -1;
    return nftw(path, remove_entry, 16, FTW_DEPTH | FTW_PHYS) ? -1 : 0;
}

int dm_file_remove_stale_temps(const char *dir, const char *base)
{
    DIR *d = opendir(dir);
    if (!d)
        return 0;
    size_t blen = base ? strlen(base) : 0;
    int removed = 0;
    struct dirent *e;
    while ((e = readdir(d))) {
        const char *tag = base ? e->d_name + blen : strstr(e->d_name, ".tmp.");
        if ((base && strncmp(e->d_name, base, blen)) || !tag || strncmp(tag, ".tmp.", 5))
            continue;
        char path[2048];
        struct stat sb;
        snprintf(path, sizeof path, "%s/%s", dir, e->d_name);
        if (!lstat(path, &sb) && temp_is_stale(tag + 5, sb.st_mtime) && !dm_file_remove_tree(path))
            removed++;
    }
    closedir(d);
    return removed;
}

long dm_file_count_temps(const char *dir)
{
    DIR *d = opendir(dir);
    if (!d)
        return 0;
    long n = 0;
    struct dirent *e;
    while ((e = readdir(d))) {
        if (!strcmp(e->d_name, ".") || !strcmp(e->d_name, ".."))
            continue;
        char path[2048];
        struct stat sb;
        snprintf(path, sizeof path, "%s/%s", dir, e->d_name);
        int is_dir = e->d_type == DT_DIR ||
                     (e->d_type == DT_UNKNOWN && !lstat(path, &sb) && S_ISDIR(sb.st_mode));
        if (strstr(e->d_name, ".tmp."))
            n++;
        else if (is_dir)
            n += dm_file_count_temps(path);
    }
    closedir(d);
    return n;
}


/* ---- whole files -------------------------------------------------------------- */

int dm_file_out_open(dm_file_out *out, const char *path, dm_error *err)
{
    snprintf(out->path, sizeof out->path, "%s", path);
    dm_file_temp_name(path, out->tmp, sizeof out->tmp);
    out->f = fopen(out->tmp, "w");
    if (!out->f)
        return dm_fail(err, DM_EIO, "%s: cannot write: %s", out->tmp, strerror(errno));
    return DM_OK;
}

/* Close the temporary and rename it into place; on any failure remove it. */
static int finish(dm_file_out *out, int durable, dm_error *err)
{
    int bad = ferror(out->f) | fflush(out->f);
    if (durable && !bad)
        bad = fsync(fileno(out->f));
    bad |= fclose(out->f);
    out->f = NULL;
    if (bad || rename(out->tmp, out->path)) {
        int e = errno;
        remove(out->tmp);
        return dm_fail(err, DM_EIO, "%s: write failed: %s", out->path, strerror(e));
    }
    return DM_OK;
}

int dm_file_out_commit(dm_file_out *out, dm_error *err)
{
    return finish(out, 1, err);
}

void dm_file_out_abort(dm_file_out *out)
{
    if (out->f)
        fclose(out->f);
    out->f = NULL;
    remove(out->tmp);
}

int dm_file_write_atomic(const char *path, const void *data, size_t n, dm_error *err)
{
    dm_file_out out;
    int rc = dm_file_out_open(&out, path, err);
    if (rc)
        return rc;
    if (fwrite(data, 1, n, out.f) != n) {
        int e = errno;
        dm_file_out_abort(&out);
        return dm_fail(err, DM_EIO, "%s: write failed: %s", path, strerror(e));
    }
    return finish(&out, 0, err);
}
