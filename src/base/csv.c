/* The CSV reader of deltamap's input files (see dm_csv.h). */
#include "dm_csv.h"

#include <assert.h>
#include <errno.h>
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

int dm_csv_open(dm_csv *c, const char *path, dm_error *err)
{
    memset(c, 0, sizeof *c);
    c->path = path;
    c->f = fopen(path, "r");
    if (!c->f)
        return dm_fail(err, DM_EIO, "%s: cannot open: %s", path, strerror(errno));
    return DM_OK;
}

void dm_csv_close(dm_csv *c)
{
    if (c->f)
        fclose(c->f);
    c->f = NULL;
}

/* Cut the line into cells (blanks around each removed); their count. */
static int split(char *line, char *cells[DM_CSV_MAXCOL], int *more)
{
    assert(line && cells);
    int n = 0;
    char *p = line;
    *more = 0;
    for (;;) {
        size_t len = strcspn(p, ",\r\n");
        char end = p[len];
        p[len] = '\0';
        char *cell = p + strspn(p, " \t");
        for (char *e = cell + strlen(cell); e > cell && (e[-1] == ' ' || e[-1] == '\t');)
            *--e = '\0';
        cells[n++] = cell;
        if (end != ',')
            return n;
        if (n == DM_CSV_MAXCOL) {
            *more = 1;
            return n;
        }
        p += len + 1;
    }
}

int dm_csv_next(dm_csv *c, dm_csv_line *kind, dm_error *err)
{
    assert(c->f);
    for (;;) {
        *kind = DM_CSV_END;
        c->comment = NULL;
        if (!fgets(c->buf, sizeof c->buf, c->f))
            return DM_OK;
        c->line++;
        size_t len = strlen(c->buf);
        if (len == sizeof c->buf - 1 && c->buf[len - 1] != '\n' && !feof(c->f))
            return dm_fail(err, DM_EINVAL, "%s:%d: line longer than %d characters", c->path,
                           c->line, DM_CSV_MAXLINE - 2);
        char *p = c->buf + strspn(c->buf, " \t");
        if (*p == '#') {
            c->comment = p + 1;
            *kind = DM_CSV_COMMENT;
            return DM_OK;
        }
        if (*p == '\n' || *p == '\r' || !*p)
            continue; /* blank */
        int more;
        c->ncells = split(p, c->cells, &more);
        if (c->ncol) {
            *kind = DM_CSV_ROW;
            return DM_OK;
        }
        if (more)
            return dm_fail(err, DM_EINVAL, "%s:%d: header has more than %d columns", c->path,
                           c->line, DM_CSV_MAXCOL);
        c->ncol = c->ncells;
        for (int i = 0; i < c->ncol; i++)
            snprintf(c->names[i], sizeof c->names[i], "%s", c->cells[i]);
        *kind = DM_CSV_HEADER;
        return DM_OK;
    }
}

int dm_csv_column(const dm_csv *c, const char *name)
{
    for (int i = 0; i < c->ncol; i++)
        if (!strcmp(c->names[i], name))
            return i;
    return -1;
}

int dm_csv_number(const dm_csv *c, int col, double *out, dm_error *err)
{
    assert(col >= 0 && col < c->ncol);
    const char *name = c->names[col];
    if (col >= c->ncells || !*c->cells[col])
        return dm_fail(err, DM_EINVAL, "%s:%d: column %d (%s): empty", c->path, c->line, col + 1,
                       name);
    char *end;
    errno = 0;
    *out = strtod(c->cells[col], &end);
    /* subnormals refused however written (0x1p-1074 reads without ERANGE,
     * 4.94e-324 with), so that what deltamap writes reads back */
    if (end == c->cells[col] || *end || !isfinite(*out) || errno == ERANGE ||
        (*out != 0 && fabs(*out) < DBL_MIN))
        return dm_fail(err, DM_EINVAL, "%s:%d: column %d (%s): '%s' is not a number in range",
                       c->path, c->line, col + 1, name, c->cells[col]);
    return DM_OK;
}
