/* dm_csv — the one reader of deltamap's CSV input: path samples
 * (dm_trajectory) and measured data (dm_measure).
 *
 * A file is lines: '#' comments and blank lines anywhere, then one header
 * naming the columns, then rows. Cells are separated by ','; blanks around
 * a cell are ignored. A number is what strtod reads, wholly, finite and
 * not subnormal (deltamap writes numbers that read back; a subnormal's
 * decimal form may not). Errors name the file, the line and the column
 * (number and header name). */
#ifndef DM_CSV_H
#define DM_CSV_H

#include <stdio.h>

#include "dm_error.h"

#define DM_CSV_MAXCOL 32
#define DM_CSV_MAXLINE 4096

typedef enum { DM_CSV_END = 0, DM_CSV_COMMENT, DM_CSV_HEADER, DM_CSV_ROW } dm_csv_line;

typedef struct dm_csv {
    FILE *f;
    const char *path;
    int line;                        /* number of the current line, from 1 */
    int ncol;                        /* columns of the header */
    char names[DM_CSV_MAXCOL][32];   /* their names */
    int ncells;                      /* cells of the current row */
    char *cells[DM_CSV_MAXCOL];      /* into buf */
    const char *comment;             /* a comment line's text after '#' */
    char buf[DM_CSV_MAXLINE];
} dm_csv;

/* Open path for reading (path must outlive the reader). DM_EIO names it. */
int dm_csv_open(dm_csv *csv, const char *path, dm_error *err);
void dm_csv_close(dm_csv *csv);

/* The next line: its kind in *kind (DM_CSV_END at the end of the file).
 * DM_EINVAL for a line longer than DM_CSV_MAXLINE or a header longer than
 * DM_CSV_MAXCOL columns. */
int dm_csv_next(dm_csv *csv, dm_csv_line *kind, dm_error *err);

/* Index of the header's column `name`, or -1. */
int dm_csv_column(const dm_csv *csv, const char *name);

/* The number in column col of the current row (DM_EINVAL: empty, absent
 * or not a number, naming line and column). */
int dm_csv_number(const dm_csv *csv, int col, double *out, dm_error *err);

#endif
