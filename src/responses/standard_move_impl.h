/* What standard_move.c and its vector loops share (private to
 * src/responses/): the loops are built once per instruction-set path
 * (standard_move_kernels.c), each build defining a table; the moves call
 * through the table of the path dm_isa_active() names. */
#ifndef STANDARD_MOVE_IMPL_H
#define STANDARD_MOVE_IMPL_H

#include "dm_isa.h"

/* Points of the coarse scan evaluated in one batch (batch_nodes). */
#define DM_MOVE_BATCH 16

typedef struct dm_move_kernels {
    /* a'b over n values, in four partial sums */
    double (*dot)(const double *a, const double *b, int n);
    /* x[i] -= sum_j c[j] B[i + j ldb] over m columns, in j order (n
     * entries) */
    void (*subtract_combination)(int n, int m, const double *B, int ldb, const double *c,
                                 double *x);
    /* one step of nm modes' (q, v) by their transitions t (4 rows nmax
     * apart: a11, a12, a21, a22) */
    void (*step_modes)(int nm, const double *t, int nmax, const double *q, const double *v,
                       double *qo, double *vo);
    /* l = sum_{j<ns} p_j q_j, d = sum_{j<ns} p_j v_j, f = sum_{ns<=j<nm}
     * p_j q_j over the modes' platform translations p (4 doubles each) */
    void (*node_sums)(const double *p4, const double *q, const double *v, int ns, int nm,
                      double l[4], double d[4], double f[4]);
    /* DM_MOVE_BATCH points from one state (q, v) of nm modes, ns of them
     * slow: point r's state is Q[j B + r], V[j B + r] = powers r of the
     * modes' transitions (pw, per mode a11, a12, a21, a22, B each) times
     * (q_j, v_j); row s of out (out[s B + r]) holds for s < 3 its node's
     * l (yp plus the slow modes' part, as eval_node's), 3..5 l', 6..8 y,
     * 9 |y|^2, 10 and 11 the squared ends interval_bound takes of it as
     * an interval's start (max |l|^2, |l + h l'|^2) and end (|l - h l'|^2),
     * each sum over the modes in order */
    void (*batch_nodes)(int nm, int ns, const double *pw, const double *q, const double *v,
                        const double *p4, const double yp[3], double h, double *Q, double *V,
                        double *out);
    /* A level's transitions of nm underdamped modes from the level
     * above's (rows nmax apart: a11, a12, a21, a22, then cos, sin, decay
     * and angle): the parts by the half-angle formulas (standard_move.c,
     * halves_apply), the transitions from them and each mode's factors
     * rz, iwd, wwd as mode_transition makes them one mode at a time (the
     * same operations: the same bits). Valid only for the modes whose
     * angle above is at most pi / 2. */
    void (*halve_transitions)(int nm, int nmax, const double *above, double *t, const double *rz,
                              const double *iwd, const double *wwd);
} dm_move_kernels;

DM_ISA_DECLARE(dm_move_kernels, dm_move_kernels_);

#endif
