/* The standard moves' small vector loops (standard_move.c), compiled once
 * per instruction-set path as the block-arrow kernels are (dm_isa.h,
 * src/model/arrow_kernels.c): the path's table is
 * dm_move_kernels_PATH. None contracts a multiply and an add, and each
 * sum runs in a fixed order whatever the vector width: every path gives
 * the same bits. Measured when they were GCC clones (2026-12-03): 9-13 %
 * fewer instructions in the moves than the baseline build. */
#include <math.h>
#include <string.h>

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

/* Each entry's terms subtracted in column order: a column at a time
 * down the entries, in the path's vectors (the same bits as one entry
 * at a time). */
static void subtract_combination(int n, int m, const double *B, int ldb, const double *c,
                                 double *x)
{
    for (int j = 0; j < m; j++) {
        const double *restrict b = B + (size_t)j * ldb;
        double *restrict y = x, cj = c[j];
#pragma omp simd
        for (int i = 0; i < n; i++)
            y[i] -= cj * b[i];
    }
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

/* The batch's points side by side, in vectors of the path's width (SSE2
 * and NEON 2 doubles, AVX2 4, AVX-512 8): each point's state and sums
 * take the operations node_sums and step_modes would, in the same order,
 * whatever the width. */
#if defined(__AVX512F__)
#define WIDTH 8
#elif defined(__AVX2__)
#define WIDTH 4
#else
#define WIDTH 2
#endif
typedef double vw __attribute__((vector_size(8 * WIDTH)));

static inline vw load_w(const double *p)
{
    vw x;
    memcpy(&x, p, sizeof x);
    return x;
}

static inline void store_w(double *p, vw x) { memcpy(p, &x, sizeof x); }

/* larger() of standard_move.c lane by lane: a where a > b or b is NaN */
static inline vw larger_w(vw a, vw b)
{
    typedef long long vl __attribute__((vector_size(8 * WIDTH)));
    vl m = (a > b) | (b != b), ai, bi;
    memcpy(&ai, &a, sizeof a);
    memcpy(&bi, &b, sizeof b);
    vl r = (ai & m) | (bi & ~m);
    memcpy(&a, &r, sizeof a);
    return a;
}

/* The sums of points g..g+WIDTH (l, d, f by component) from one state. */
static void group_sums(int nm, int ns, const double *pw, const double *q, const double *v,
                       const double *p4, double *Q, double *V, int g, vw out[9])
{
    enum { B = DM_MOVE_BATCH };
    vw zero = {0}, l0 = zero, l1 = zero, l2 = zero, d0 = zero, d1 = zero, d2 = zero;
    vw f0 = zero, f1 = zero, f2 = zero;
    for (int j = 0; j < nm; j++) {
        const double *a = pw + (size_t)j * 4 * B + g, *p = p4 + 4 * j;
        vw qj = load_w(a) * q[j] + load_w(a + B) * v[j];
        vw vj = load_w(a + 2 * B) * q[j] + load_w(a + 3 * B) * v[j];
        store_w(Q + (size_t)j * B + g, qj);
        store_w(V + (size_t)j * B + g, vj);
        if (j < ns) {
            l0 += qj * p[0], l1 += qj * p[1], l2 += qj * p[2];
            d0 += vj * p[0], d1 += vj * p[1], d2 += vj * p[2];
        } else {
            f0 += qj * p[0], f1 += qj * p[1], f2 += qj * p[2];
        }
    }
    out[0] = l0, out[1] = l1, out[2] = l2, out[3] = d0, out[4] = d1, out[5] = d2;
    out[6] = f0, out[7] = f1, out[8] = f2;
}

static void batch_nodes(int nm, int ns, const double *pw, const double *q, const double *v,
                        const double *p4, const double yp[3], double h, double *Q, double *V,
                        double *out)
{
    enum { B = DM_MOVE_BATCH };
    for (int g = 0; g < B; g += WIDTH) {
        vw sm[9];
        group_sums(nm, ns, pw, q, v, p4, Q, V, g, sm);
        vw l[3], y[3], ep[3], em[3];
        for (int c = 0; c < 3; c++) {
            l[c] = yp[c] + sm[c]; /* as eval_node and interval_bound do it */
            y[c] = l[c] + sm[6 + c];
            ep[c] = l[c] + h * sm[3 + c];
            em[c] = l[c] + -h * sm[3 + c];
            store_w(out + c * B + g, l[c]);
            store_w(out + (3 + c) * B + g, sm[3 + c]);
            store_w(out + (6 + c) * B + g, y[c]);
        }
        vw yy = y[0] * y[0] + y[1] * y[1] + y[2] * y[2];
        vw ll = l[0] * l[0] + l[1] * l[1] + l[2] * l[2];
        vw pp = ep[0] * ep[0] + ep[1] * ep[1] + ep[2] * ep[2];
        vw mm = em[0] * em[0] + em[1] * em[1] + em[2] * em[2];
        store_w(out + 9 * B + g, yy);
        store_w(out + 10 * B + g, larger_w(ll, pp));
        store_w(out + 11 * B + g, larger_w(ll, mm));
    }
}

static void halve_transitions(int nm, int nmax, const double *above, double *t, const double *rz,
                              const double *iwd, const double *wwd)
{
    const double *restrict c1 = above + 4 * nmax, *restrict s1 = above + 5 * nmax;
    const double *restrict e1 = above + 6 * nmax, *restrict x1 = above + 7 * nmax;
    double *restrict a11 = t, *restrict a12 = t + nmax, *restrict a21 = t + 2 * nmax;
    double *restrict a22 = t + 3 * nmax, *restrict c = t + 4 * nmax, *restrict s = t + 5 * nmax;
    double *restrict e = t + 6 * nmax, *restrict x = t + 7 * nmax;
#pragma omp simd
    for (int j = 0; j < nm; j++) {
        double cj = sqrt((1 + c1[j]) * 0.5), sj = s1[j] / (2 * cj), ej = sqrt(e1[j]);
        c[j] = cj, s[j] = sj, e[j] = ej, x[j] = x1[j] * 0.5;
        a11[j] = ej * (cj + rz[j] * sj);
        a12[j] = ej * sj * iwd[j];
        a21[j] = -ej * wwd[j] * sj;
        a22[j] = ej * (cj - rz[j] * sj);
    }
}

const dm_move_kernels DM_ISA_TABLE(dm_move_kernels_) = {
    .halve_transitions = halve_transitions,
    .dot = dot,
    .subtract_combination = subtract_combination,
    .step_modes = step_modes,
    .node_sums = node_sums,
    .batch_nodes = batch_nodes,
};
