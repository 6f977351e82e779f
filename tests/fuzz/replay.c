/* Replay a fuzz target's corpus without libFuzzer: `make test` builds each
 * tests/fuzz/fuzz_TARGET.c with this main() and the normal compiler (with
 * ASan/UBSan under SANITIZE=1) and runs it over tests/fuzz/TARGET/.
 *
 *   replay-TARGET FILE|DIR...
 *
 * Every file is fed to LLVMFuzzerTestOneInput once. A crash, a sanitizer
 * report or a failed property aborts, naming the input; so does an input
 * that runs longer than DM_FUZZ_TIMEOUT seconds (default 10): a hang. */
#define _XOPEN_SOURCE 700
#include <dirent.h>
#include <signal.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "fuzz.h"

static const char *current;

static void on_alarm(int sig)
{
    (void)sig;
    static const char msg[] = "replay: input runs too long (a hang): ";
    if (write(2, msg, sizeof msg - 1) < 0 || write(2, current, strlen(current)) < 0 ||
        write(2, "\n", 1) < 0)
        _exit(3);
    _exit(3);
}

static int replay_file(const char *path, unsigned timeout)
{
    FILE *f = fopen(path, "rb");
    if (!f) {
        perror(path);
        return 1;
    }
    size_t cap = 1 << 16, n = 0, got;
    uint8_t *buf = malloc(cap);
    while (buf && (got = fread(buf + n, 1, cap - n, f)) > 0) {
        n += got;
        if (n == cap) {
            uint8_t *grown = realloc(buf, cap *= 2);
            if (!grown)
                free(buf);
            buf = grown;
        }
    }
    fclose(f);
    if (!buf) {
        fprintf(stderr, "replay: %s: out of memory\n", path);
        return 1;
    }
    /* an exact-size copy, so ASan sees reads past the input's end */
    uint8_t *exact = malloc(n ? n : 1);
    memcpy(exact, buf, n);
    free(buf);
    current = path;
    alarm(timeout);
    LLVMFuzzerTestOneInput(exact, n);
    alarm(0);
    free(exact);
    return 0;
}

static int cmp(const void *a, const void *b)
{
    return strcmp(*(char *const *)a, *(char *const *)b);
}

int main(int argc, char **argv)
{
    const char *t = getenv("DM_FUZZ_TIMEOUT");
    unsigned timeout = t ? (unsigned)atoi(t) : 10;
    signal(SIGALRM, on_alarm);
    int files = 0, bad = 0;
    for (int i = 1; i < argc; i++) {
        struct stat sb;
        if (stat(argv[i], &sb)) {
            perror(argv[i]);
            return 1;
        }
        if (!S_ISDIR(sb.st_mode)) {
            bad |= replay_file(argv[i], timeout);
            files++;
            continue;
        }
        DIR *d = opendir(argv[i]);
        struct dirent *e;
        char **names = NULL;
        int nn = 0;
        while (d && (e = readdir(d))) {
            if (e->d_name[0] == '.')
                continue;
            names = realloc(names, sizeof *names * (nn + 1));
            names[nn] = malloc(strlen(argv[i]) + strlen(e->d_name) + 2);
            sprintf(names[nn++], "%s/%s", argv[i], e->d_name);
        }
        if (d)
            closedir(d);
        qsort(names, nn, sizeof *names, cmp);
        for (int k = 0; k < nn; k++) {
            bad |= replay_file(names[k], timeout);
            files++;
            free(names[k]);
        }
        free(names);
    }
    fprintf(stderr, "%s: %d inputs replayed\n", argv[0], files);
    return bad || !files;
}
