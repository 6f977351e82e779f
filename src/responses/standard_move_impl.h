/* What standard_move.c and its vector loops share (private to
 * src/responses/): the loops are built once per instruction-set path
 * (standard_move_kernels.c), each build defining a table; the moves call
 * through the table of the path dm_isa_active() names. */
#ifndef STANDARD_MOVE_IMPL_H
#define STANDARD_MOVE_IMPL_H

#include "dm_isa.h"

typedef struct dm_move_kernels {
    /* a'b over n values, in four partial sums */
    double (*dot)(const double *a, const double *b, int n);
    /* one step of nm modes' (q, v) by their transitions t (4 rows nmax
     * apart: a11, a12, a21, a22) */
    void (*step_modes)(int nm, const double *t, int nmax, const double *q, const double *v,
                       double *qo, double *vo);
    /* l = sum_{j<ns} p_j q_j, d = sum_{j<ns} p_j v_j, f = sum_{ns<=j<nm}
     * p_j q_j over the modes' platform translations p (4 doubles each) */
    void (*node_sums)(const double *p4, const double *q, const double *v, int ns, int nm,
                      double l[4], double d[4], double f[4]);
} dm_move_kernels;

extern const dm_move_kernels dm_move_kernels_default;
#if defined(__x86_64__)
extern const dm_move_kernels dm_move_kernels_avx2, dm_move_kernels_avx512;
#endif

#endif
