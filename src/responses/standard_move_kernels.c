/* The standard moves' small vector loops (standard_move.c), compiled once
 * per instruction-set path as the block-arrow kernels are (dm_isa.h,
 * src/model/arrow_kernels.c): the path's table is
 * dm_move_kernels_PATH. None contracts a multiply and an add, and each
 * sum runs in a fixed order whatever the vector width: every path gives
 * the same bits. Measured when they were GCC clones (2026-12-03): 9-13 %
 * fewer instructions in the moves than the baseline build. */
#include "standard_move_impl.h"


/* Four partial sums: one running sum waits on each addition (a dot of
 * n = 210 cost ~4n cycles, and the carried modes take some 200 per pose). */
static double dot(const double *a, const double *b, int n)
{
    double s[4] = {0, 0, 0, 0};
    int i = 0;
    for (; i + 4 <= n; i += 4)
        for (int r = 0; r < 4; r++)
            s[r] += a[i + r] * b[i + r];
    for (; i < n; i++)
        s[0] += a[i] * b[i];
    return (s[0] + s[1]) + (s[2] + s[3]);
}

static void step_modes(int nm, const double *t, int nmax, const double *q, const double *v,
                       double *qo, double *vo)
{
    const double *restrict a11 = t, *restrict a12 = t + nmax, *restrict a21 = t + 2 * nmax;
    const double *restrict a22 = t + 3 * nmax;
#pragma omp simd
    for (int j = 0; j < nm; j++) {
        qo[j] = a11[j] * q[j] + a12[j] * v[j];
        vo[j] = a21[j] * q[j] + a22[j] * v[j];
    }
}

/* Four doubles, any alignment: the x, y, z (and 0) of a mode's platform
 * translation, and sums of them. */
typedef double v4d __attribute__((vector_size(32), aligned(8)));

/* The three components are summed side by side in one vector (each over
 * the modes in order, as three plain sums would: the same bits), which
 * takes a third of the operations where the CPU has 4-wide vectors. Over
 * a dozen modes this beats vectorising each sum over the modes (the
 * reductions' set-up and horizontal adds cost more than they save). */
static void node_sums(const double *p4, const double *q, const double *v, int ns, int nm,
                      double l[4], double d[4], double f[4])
{
    const v4d *p = (const v4d *)p4;
    v4d ls = {0, 0, 0, 0}, ds = ls, fs = ls;
    for (int j = 0; j < ns; j++) {
        ls += p[j] * q[j];
        ds += p[j] * v[j];
    }
    for (int j = ns; j < nm; j++)
        fs += p[j] * q[j];
    for (int r = 0; r < 4; r++)
        l[r] = ls[r], d[r] = ds[r], f[r] = fs[r];
}

const dm_move_kernels DM_ISA_TABLE(dm_move_kernels_) = {
    .dot = dot,
    .step_modes = step_modes,
    .node_sums = node_sums,
};
