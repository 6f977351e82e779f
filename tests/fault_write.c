/* LD_PRELOAD shim for fault_tests.sh: a disk that fills up.
 *
 * Counts the calls that put data on a regular file or make it permanent:
 * write, pwrite, fsync, fflush, fclose (of a stream on a regular file
 * opened for writing) and rename. From the DM_FAIL_IO-th such call on
 * (1 = the first), every one fails with ENOSPC, as on a full disk: write
 * and pwrite write nothing; fflush and fclose still flush and close (the
 * data may be on disk, but the caller is told it is not, as with a
 * delayed write error); fsync and rename do nothing. stdout, stderr,
 * pipes and terminals are never touched. DM_FAIL_REPORT=FILE receives
 * "CALLS INJECTED" at exit. (stdio's own writes inside libc cannot be
 * interposed; its errors are seen at fflush/fclose.) */
#include <dlfcn.h>
#include <errno.h>
#include <fcntl.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <unistd.h>

typedef ssize_t (*write_fn)(int, const void *, size_t);
static long fail_at = -1, calls;
static int injected;

static void report(void)
{
    const char *path = getenv("DM_FAIL_REPORT");
    if (!path)
        return;
    int fd = open(path, O_WRONLY | O_CREAT | O_TRUNC, 0666);
    if (fd >= 0) {
        char buf[64];
        int n = snprintf(buf, sizeof buf, "%ld %d\n", calls, injected);
        write_fn real_write = (write_fn)dlsym(RTLD_NEXT, "write");
        if (real_write(fd, buf, (size_t)n) < 0)
            n = 0;
        close(fd);
    }
}

static int fail_now(void)
{
    if (fail_at < 0) {
        const char *s = getenv("DM_FAIL_IO");
        fail_at = s ? atol(s) : 0;
        atexit(report);
    }
    calls++;
    if (fail_at > 0 && calls >= fail_at) {
        injected = 1;
        return 1;
    }
    return 0;
}

static int regular_fd(int fd)
{
    struct stat sb;
    return fd > 2 && fstat(fd, &sb) == 0 && S_ISREG(sb.st_mode);
}

static int writing_stream(FILE *f)
{
    if (!f)
        return 0;
    int fd = fileno(f);
    return fd >= 0 && regular_fd(fd) && (fcntl(fd, F_GETFL) & O_ACCMODE) != O_RDONLY;
}

typedef ssize_t (*pwrite_fn)(int, const void *, size_t, off_t);
typedef int (*fd_fn)(int);
typedef int (*stream_fn)(FILE *);
typedef int (*rename_fn)(const char *, const char *);
/* the next definition of `name` (libc's), looked up once */
#define REAL(name, type)                                                               \
    static type real_##name;                                                           \
    if (!real_##name)                                                                  \
    real_##name = (type)dlsym(RTLD_NEXT, #name)

ssize_t write(int fd, const void *buf, size_t n)
{
    REAL(write, write_fn);
    if (regular_fd(fd) && fail_now()) {
        errno = ENOSPC;
        return -1;
    }
    return real_write(fd, buf, n);
}

ssize_t pwrite(int fd, const void *buf, size_t n, off_t off)
{
    REAL(pwrite, pwrite_fn);
    if (regular_fd(fd) && fail_now()) {
        errno = ENOSPC;
        return -1;
    }
    return real_pwrite(fd, buf, n, off);
}

int fsync(int fd)
{
    REAL(fsync, fd_fn);
    if (regular_fd(fd) && fail_now()) {
        errno = ENOSPC;
        return -1;
    }
    return real_fsync(fd);
}

int fflush(FILE *f)
{
    REAL(fflush, stream_fn);
    int inject = writing_stream(f) && fail_now();
    int rc = real_fflush(f);
    if (inject) {
        errno = ENOSPC;
        return EOF;
    }
    return rc;
}

int fclose(FILE *f)
{
    REAL(fclose, stream_fn);
    int inject = writing_stream(f) && fail_now();
    int rc = real_fclose(f);
    if (inject) {
        errno = ENOSPC;
        return EOF;
    }
    return rc;
}

int rename(const char *from, const char *to)
{
    REAL(rename, rename_fn);
    if (fail_now()) {
        errno = ENOSPC;
        return -1;
    }
    return real_rename(from, to);
}
