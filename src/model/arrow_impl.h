/* What arrow.c and the kernels it runs share (private to src/model/). The
 * kernels (arrow_kernels.c) are built once per instruction-set path; each
 * build defines a table, and arrow.c calls through the table of the path
 * dm_isa_active() names. */
#ifndef ARROW_IMPL_H
#define ARROW_IMPL_H

#include "dm_arrow.h"
#include "dm_isa.h"

typedef struct dm_arrow_kernels {
    /* Y = A X (q columns, interleaved) */
    void (*mult)(const dm_arrow *a, const double *X, int q, double *Y);
    /* In-place Cholesky of a banded block over the profile colend (or the
     * band): 0, or the failed column + 1 when a pivot is not positive. */
    int (*band_chol)(double *ab, int n, int kd, const int *colend);
    /* W = L^-1 C for the factor in ab, S -= W'W; C's first non-zero row */
    int (*border_of_factor)(const double *ab, int nb, int kd, const int *colend,
                            const double *C, double *Z, double *W,
                            double S[DM_ARROW_BORDER * DM_ARROW_BORDER]);
    /* X = L^-T L^-1 X, X = L^-1 X, X = L^-T X */
    void (*chol_solve)(const dm_arrow_chol *f, double *X, int q);
    void (*chol_forward)(const dm_arrow_chol *f, double *X, int q);
    void (*chol_backward)(const dm_arrow_chol *f, double *X, int q);
    /* the forward solve of columns o0 .. o1-1 that are zero outside chains
     * c0 .. c1-1 and the border */
    void (*chains_forward)(const dm_arrow_chol *f, int c0, int c1, double *X, int q, int o0,
                           int o1);
    /* In-place LDL' of a banded block: the negative pivots, or -1 */
    int (*band_ldl)(double *ab, int n, int kd, const int *colend);
    /* S -= Z' D^-1 Z, Z = L^-1 C, for band_ldl's factor in ab */
    void (*border_schur)(const double *ab, int nb, int kd, const int *colend, const double *C,
                         double *Z, double S[DM_ARROW_BORDER * DM_ARROW_BORDER]);
    int slice_max; /* the widest slice of columns the path holds in registers */
} dm_arrow_kernels;

DM_ISA_DECLARE(dm_arrow_kernels, dm_arrow_kernels_);

/* The table of a path this build has (dm_isa_available). */
const dm_arrow_kernels *dm_arrow_kernels_of(dm_isa isa);

#endif
