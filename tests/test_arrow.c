/* Block-arrow matrices against their dense expansion: products, the
 * Cholesky solve and its Schur complement, ln det, and Sturm counts, on
 * random symmetric matrices whose rows start at irregular columns (a
 * profile that is not monotone, as joint springs make it). */
#include "dm_test.h"

#include <lapacke.h>
#include <stdlib.h>

#include "dm_arrow.h"
#include "dm_isa.h"
#include "../src/model/arrow_impl.h" /* each path's kernels, called side by side */

static double uniform(unsigned *s)
{
    *s = *s * 1664525u + 1013904223u;
    return (*s >> 8) / 16777216.0 - 0.5;
}

/* A random block-arrow matrix, diagonally dominant (SPD) when spd, through
 * dm_arrow_add calls for every (i, j) of the full matrix, recording the
 * pattern. Row i of block c reaches back to a random first column. */
static void random_arrow(dm_arrow *a, dm_arrow *b, unsigned seed, int spd)
{
    const dm_arrow_layout *lay = &a->lay;
    unsigned s = seed;
    assert_int_equal(dm_arrow_record(a, NULL), 0);
    assert_int_equal(dm_arrow_record(b, NULL), 0);
    for (int c = 0; c < DM_ARROW_BLOCKS; c++) {
        int off = lay->off[c], nb = lay->nb[c], kd = lay->kd[c];
        for (int i = 0; i < nb; i++) {
            int back = (int)((uniform(&s) + 0.5) * (kd + 1));
            for (int j = i - back > 0 ? i - back : 0; j < i; j++) {
                double v = uniform(&s), w = uniform(&s);
                dm_arrow_add(a, off + i, off + j, v);
                dm_arrow_add(a, off + j, off + i, v);
                dm_arrow_add(b, off + i, off + j, 0.1 * w);
                dm_arrow_add(b, off + j, off + i, 0.1 * w);
            }
            dm_arrow_add(a, off + i, off + i, spd ? 2.0 * kd + 2 : uniform(&s) * 4);
            dm_arrow_add(b, off + i, off + i, 1.0 + 2 * kd * 0.1);
            if (i >= nb - 4) /* the last rows of a block reach the border */
                for (int m = 0; m < DM_ARROW_BORDER; m++) {
                    double v = uniform(&s);
                    dm_arrow_add(a, off + i, lay->border + m, v);
                    dm_arrow_add(a, lay->border + m, off + i, v);
                }
        }
    }
    for (int m = 0; m < DM_ARROW_BORDER; m++) {
        dm_arrow_add(a, lay->border + m, lay->border + m, 40.0);
        dm_arrow_add(b, lay->border + m, lay->border + m, 1.0);
    }
}

typedef struct {
    dm_arrow_layout lay;
    dm_arrow a, b;
    dm_arrow_pattern pat;
    double *A, *B;
    int n;
} fixture;

static void setup_fixture(fixture *f, unsigned seed, int spd)
{
    const int nb[3] = {23, 17, 30}, kd[3] = {7, 5, 9};
    dm_arrow_layout_make(&f->lay, nb, kd);
    f->n = f->lay.n;
    assert_int_equal(dm_arrow_init(&f->a, &f->lay, NULL), 0);
    assert_int_equal(dm_arrow_init(&f->b, &f->lay, NULL), 0);
    random_arrow(&f->a, &f->b, seed, spd);
    assert_int_equal(dm_arrow_pattern_make(&f->pat, &f->a, &f->b, NULL), 0);
    f->a.pattern = f->b.pattern = &f->pat;
    f->A = malloc(sizeof(double) * f->n * f->n);
    f->B = malloc(sizeof(double) * f->n * f->n);
    dm_arrow_to_dense(&f->a, f->A);
    dm_arrow_to_dense(&f->b, f->B);
}

static void teardown_fixture(fixture *f)
{
    dm_arrow_release(&f->a);
    dm_arrow_release(&f->b);
    dm_arrow_pattern_release(&f->pat);
    free(f->A);
    free(f->B);
}

/* The block-arrow Cholesky factor of one of the fixture's matrices (the
 * caller releases it). */
static void factor_of(const fixture *f, const dm_arrow *a, dm_arrow_chol *L)
{
    assert_int_equal(dm_arrow_chol_init(L, &f->lay, NULL), 0);
    assert_int_equal(dm_arrow_chol_factor(L, a, NULL), 0);
}

static void products_match_dense(void **state)
{
    (void)state;
    fixture f;
    setup_fixture(&f, 7, 1);
    int n = f.n, q = 5;
    double *X = malloc(sizeof(double) * n * q), *Y = malloc(sizeof(double) * n * q);
    unsigned s = 99;
    for (int i = 0; i < n * q; i++)
        X[i] = uniform(&s);
    dm_arrow_mult(&f.a, X, q, Y); /* interleaved: X[i q + r] */
    for (int r = 0; r < q; r++)
        for (int i = 0; i < n; i++) {
            double e = 0;
            for (int j = 0; j < n; j++)
                e += f.A[(size_t)j * n + i] * X[(size_t)j * q + r];
            assert_abs(Y[(size_t)i * q + r], e, 1e-13 * (1 + fabs(e)), "(A X)[%d, %d]", i, r);
        }
    free(X);
    free(Y);
    teardown_fixture(&f);
}

/* Column r of a block of q (interleaved, rows q apart) into x. */
static void column_of(const double *X, int n, int q, int r, double *x)
{
    for (int i = 0; i < n; i++)
        x[i] = X[(size_t)i * q + r];
}

/* The kernels take a block's columns in slices of 4 up to the path's
 * widest (24 on AVX2 and AVX-512, 12 on SSE2, held in vector registers)
 * and then 3, 2, 1 (plain loops): every column of a
 * block of any width must come out bit for bit as that column alone
 * (q = 1), in the product (with the recorded pattern and over the full
 * band), the solve and its two halves. A slice that mixed columns, lost
 * its last four or summed in another order would fail here. */
static void block_widths_give_each_column_alone(void **state)
{
    (void)state;
    fixture f;
    setup_fixture(&f, 13, 1);
    int n = f.n;
    dm_arrow_chol L;
    factor_of(&f, &f.a, &L);
    enum { QMAX = 33, OPS = 5 };
    const int widths[] = {2, 3, 4, 5, 7, 8, 9, 12, 13, 16, 19, 20, 21, 24, 27, 28, 33};
    double *X = malloc(sizeof(double) * n * QMAX), *Y = malloc(sizeof(double) * n * QMAX);
    double *x = malloc(sizeof(double) * n), *y = malloc(sizeof(double) * n);
    double *col = malloc(sizeof(double) * n);
    unsigned s = 17;
    for (int i = 0; i < n * QMAX; i++)
        X[i] = uniform(&s);
    for (size_t w = 0; w < sizeof widths / sizeof widths[0]; w++) {
        int q = widths[w];
        for (int op = 0; op < OPS; op++) {
            const dm_arrow_pattern *keep = f.a.pattern;
            f.a.pattern = op == 1 ? NULL : keep; /* op 1: every entry of the band */
            for (int i = 0; i < n * q; i++) /* the block: X's first q columns */
                Y[i] = X[(size_t)(i / q) * QMAX + i % q];
            double *Z = malloc(sizeof(double) * n * q);
            if (op <= 1)
                dm_arrow_mult(&f.a, Y, q, Z);
            else
                memcpy(Z, Y, sizeof(double) * n * q);
            if (op == 2)
                dm_arrow_chol_solve(&L, Z, q);
            if (op == 3)
                dm_arrow_chol_forward(&L, Z, q);
            if (op == 4)
                dm_arrow_chol_backward(&L, Z, q);
            for (int r = 0; r < q; r++) {
                column_of(X, n, QMAX, r, x);
                if (op <= 1)
                    dm_arrow_mult(&f.a, x, 1, y);
                else
                    memcpy(y, x, sizeof(double) * n);
                if (op == 2)
                    dm_arrow_chol_solve(&L, y, 1);
                if (op == 3)
                    dm_arrow_chol_forward(&L, y, 1);
                if (op == 4)
                    dm_arrow_chol_backward(&L, y, 1);
                column_of(Z, n, q, r, col);
                if (memcmp(col, y, sizeof(double) * n))
                    fail_msg("operation %d, column %d of a block of %d differs from it alone", op,
                             r, q);
            }
            free(Z);
            f.a.pattern = keep;
        }
    }
    free(X), free(Y), free(x), free(y), free(col);
    dm_arrow_chol_release(&L);
    teardown_fixture(&f);
}

/* T = L^-1 A L^-T the plain way: forward solves over all n columns, of
 * the rows of A (dense, symmetric) and then of (L^-1 A)'. S: n x n scratch. */
static void reduce_by_forward_solves(const dm_arrow_chol *L, const double *A, int n, double *S,
                                     double *T)
{
    memcpy(S, A, sizeof(double) * n * n);
    dm_arrow_chol_forward(L, S, n);
    for (int i = 0; i < n; i++)
        for (int j = 0; j < n; j++)
            T[(size_t)i * n + j] = S[(size_t)j * n + i];
    dm_arrow_chol_forward(L, T, n);
}

/* Solves against LAPACK's (1e-12), the solve's halves (L^-1 then L^-T:
 * the solve, bit for bit; L^-1 A L^-T = I to 1e-12), ln det A and the
 * border block of A^-1 = S^-1. */
static void cholesky_solves_and_schur_complement(void **state)
{
    (void)state;
    fixture f;
    setup_fixture(&f, 11, 1);
    int n = f.n, q = 3;
    dm_arrow_chol L;
    factor_of(&f, &f.a, &L);
    double *X = malloc(sizeof(double) * n * q), *D = malloc(sizeof(double) * n * q);
    unsigned s = 5;
    for (int i = 0; i < n * q; i++)
        X[i] = uniform(&s);
    for (int r = 0; r < q; r++) /* column-major copy for LAPACK */
        for (int i = 0; i < n; i++)
            D[(size_t)r * n + i] = X[(size_t)i * q + r];
    double *Af = malloc(sizeof(double) * n * n);
    memcpy(Af, f.A, sizeof(double) * n * n);
    assert_int_equal(LAPACKE_dposv(LAPACK_COL_MAJOR, 'L', n, q, Af, n, D, n), 0);
    double *Y = malloc(sizeof(double) * n * q);
    memcpy(Y, X, sizeof(double) * n * q);
    dm_arrow_chol_solve(&L, X, q);
    for (int r = 0; r < q; r++)
        for (int i = 0; i < n; i++)
            assert_abs(X[(size_t)i * q + r], D[(size_t)r * n + i], 1e-12, "A^-1 b [%d, %d]", i, r);
    /* its halves: forward then backward is the solve, bit for bit */
    dm_arrow_chol_forward(&L, Y, q);
    dm_arrow_chol_backward(&L, Y, q);
    assert_memory_equal(X, Y, sizeof(double) * n * q);
    /* L^-1 A L^-T = I: the rows of A, then of (L^-1 A)', as blocks of n */
    double *C = malloc(sizeof(double) * n * n), *T = malloc(sizeof(double) * n * n);
    reduce_by_forward_solves(&L, f.A, n, C, T);
    for (int i = 0; i < n; i++)
        for (int j = 0; j < n; j++)
            assert_abs(T[(size_t)i * n + j], i == j, 1e-12, "L^-1 A L^-T (%d, %d)", i, j);
    free(Y), free(C), free(T);
    /* the border block of A^-1 is S^-1 */
    double Sinv[36];
    assert_int_equal(dm_arrow_chol_border_inverse(&L, Sinv), 0);
    memcpy(Af, f.A, sizeof(double) * n * n);
    assert_int_equal(LAPACKE_dpotrf(LAPACK_COL_MAJOR, 'L', n, Af, n), 0);
    double logdet = 0;
    for (int i = 0; i < n; i++)
        logdet += 2 * log(Af[(size_t)i * n + i]);
    assert_rel(dm_arrow_chol_logdet(&L), logdet, 1e-12, "ln det A");
    assert_int_equal(LAPACKE_dpotri(LAPACK_COL_MAJOR, 'L', n, Af, n), 0);
    for (int m = 0; m < 6; m++)
        for (int l = m; l < 6; l++) {
            double e = Af[(size_t)(f.lay.border + m) * n + f.lay.border + l];
            assert_abs(Sinv[m * 6 + l], e, 1e-12 * fabs(Sinv[m * 6 + m]), "S^-1 (%d, %d)", l, m);
        }
    dm_arrow_chol_release(&L);
    free(X), free(D), free(Af);
    teardown_fixture(&f);
}

/* The profile Cholesky (our own loop, see dm_arrow_chol_factor) against
 * LAPACK's band Cholesky dpbtrf and band solve dtbtrs on the same blocks:
 * L_c and W_c = L_c^-1 C_c to 1e-13 of their column's largest entry (the
 * same factor, which is unique: the difference is round-off), over the
 * recorded profile and over the full band (no pattern); an indefinite
 * matrix fails at the chain and pivot dpbtrf names. */
static void cholesky_factor_matches_lapack_band(void **state)
{
    (void)state;
    fixture f;
    setup_fixture(&f, 31, 1);
    dm_arrow_chol L;
    assert_int_equal(dm_arrow_chol_init(&L, &f.lay, NULL), 0);
    for (int profile = 1; profile >= 0; profile--) {
        f.a.pattern = profile ? &f.pat : NULL;
        assert_int_equal(dm_arrow_chol_factor(&L, &f.a, NULL), 0);
        for (int c = 0; c < DM_ARROW_BLOCKS; c++) {
            int nb = f.lay.nb[c], kd = f.lay.kd[c], ld = kd + 1;
            double *band = malloc(sizeof(double) * ld * nb), *W = malloc(sizeof(double) * nb * 6);
            memcpy(band, f.a.band[c], sizeof(double) * ld * nb);
            memcpy(W, f.a.cpl[c], sizeof(double) * nb * 6);
            assert_int_equal(LAPACKE_dpbtrf(LAPACK_COL_MAJOR, 'L', nb, kd, band, ld), 0);
            assert_int_equal(LAPACKE_dtbtrs(LAPACK_COL_MAJOR, 'L', 'N', 'N', nb, kd, 6, band, ld,
                                            W, nb),
                             0);
            for (int j = 0; j < nb; j++) {
                double big = fabs(band[(size_t)j * ld]);
                for (int i = 0; i < ld && j + i < nb; i++)
                    assert_abs(L.band[c][(size_t)j * ld + i], band[(size_t)j * ld + i],
                               1e-13 * big, "L_%d (%d, %d), profile %d", c, j + i, j, profile);
            }
            for (int m = 0; m < 6; m++) {
                double big = 0;
                for (int i = 0; i < nb; i++)
                    big = fmax(big, fabs(W[i + (size_t)m * nb]));
                for (int i = 0; i < nb; i++)
                    assert_abs(L.W[c][i + (size_t)m * nb], W[i + (size_t)m * nb], 1e-13 * big,
                               "W_%d (%d, %d), profile %d", c, i, m, profile);
            }
            free(band), free(W);
        }
    }
    dm_arrow_chol_release(&L);
    teardown_fixture(&f);
    setup_fixture(&f, 23, 0); /* indefinite */
    assert_int_equal(dm_arrow_chol_init(&L, &f.lay, NULL), 0);
    char expect[128] = "";
    for (int c = 0; c < DM_ARROW_BLOCKS && !expect[0]; c++) {
        int nb = f.lay.nb[c], kd = f.lay.kd[c], ld = kd + 1;
        double *band = malloc(sizeof(double) * ld * nb);
        memcpy(band, f.a.band[c], sizeof(double) * ld * nb);
        lapack_int info = LAPACKE_dpbtrf(LAPACK_COL_MAJOR, 'L', nb, kd, band, ld);
        if (info > 0)
            snprintf(expect, sizeof expect, "(chain %d, pivot %d)", c, (int)info);
        free(band);
    }
    assert_true(expect[0]);
    dm_error err;
    assert_int_equal(dm_arrow_chol_factor(&L, &f.a, &err), DM_ENUMERIC);
    assert_non_null(strstr(err.msg, expect));
    dm_arrow_chol_release(&L);
    teardown_fixture(&f);
}

/* The pencil (A, B) in standard form, C = L^-1 A L^-T with B = L L': the
 * same bits as two forward solves over all n columns (the reduction skips
 * only the chains where a column is zero), and LAPACK's dpotrf + dsygst
 * to 1e-13 of C's largest entry (Cholesky factors are unique, so both
 * reduce with the same L; the difference is round-off). */
static void reduction_to_standard_form(void **state)
{
    (void)state;
    fixture f;
    setup_fixture(&f, 23, 1);
    int n = f.n;
    dm_arrow_chol L;
    factor_of(&f, &f.b, &L);
    double *C = malloc(sizeof(double) * n * n), *S = malloc(sizeof(double) * n * n);
    double *T = malloc(sizeof(double) * n * n);
    dm_arrow_chol_reduce(&L, &f.a, C, S);
    reduce_by_forward_solves(&L, f.A, n, S, T);
    assert_memory_equal(C, T, sizeof(double) * n * n);
    double *Bf = malloc(sizeof(double) * n * n), cmax = 0;
    memcpy(Bf, f.B, sizeof(double) * n * n);
    memcpy(S, f.A, sizeof(double) * n * n);
    assert_int_equal(LAPACKE_dpotrf(LAPACK_COL_MAJOR, 'L', n, Bf, n), 0);
    assert_int_equal(LAPACKE_dsygst(LAPACK_COL_MAJOR, 1, 'L', n, S, n, Bf, n), 0);
    for (int i = 0; i < n * n; i++)
        cmax = fmax(cmax, fabs(C[i]));
    for (int j = 0; j < n; j++)
        for (int i = j; i < n; i++) {
            assert_abs(C[(size_t)j * n + i], S[(size_t)j * n + i], 1e-13 * cmax, "C (%d, %d)", i, j);
            assert_abs(C[(size_t)i * n + j], C[(size_t)j * n + i], 1e-13 * cmax, "C' (%d, %d)", i,
                       j);
        }
    dm_arrow_chol_release(&L);
    free(C), free(S), free(T), free(Bf);
    teardown_fixture(&f);
}

static void sturm_counts_match_eigenvalues(void **state)
{
    (void)state;
    fixture f;
    setup_fixture(&f, 23, 0); /* indefinite A, B positive definite */
    int n = f.n;
    double *A = malloc(sizeof(double) * n * n), *B = malloc(sizeof(double) * n * n);
    double *w = malloc(sizeof(double) * n);
    memcpy(A, f.A, sizeof(double) * n * n);
    memcpy(B, f.B, sizeof(double) * n * n);
    assert_int_equal(LAPACKE_dsygvd(LAPACK_COL_MAJOR, 1, 'N', 'L', n, A, n, B, n, w), 0);
    dm_arrow_ldl ldl;
    assert_int_equal(dm_arrow_ldl_init(&ldl, &f.lay, NULL), 0);
    int checked = 0;
    for (int j = 0; j + 1 < n; j += 3) { /* shifts midway between eigenvalues */
        if (w[j + 1] - w[j] < 1e-6 * (fabs(w[j]) + 1))
            continue;
        double sigma = 0.5 * (w[j] + w[j + 1]);
        int count;
        if (dm_arrow_count_below(&ldl, &f.a, &f.b, sigma, &count) != DM_OK)
            continue; /* a pivot too small to trust: the caller moves sigma */
        assert_int_equal(count, j + 1);
        checked++;
    }
    assert_true(checked > n / 6);
    dm_arrow_ldl_release(&ldl);
    free(A), free(B), free(w);
    teardown_fixture(&f);
}

/* Every kernel of every path this CPU has gives the bits of the baseline
 * path's, on the same inputs: the product (with the pattern and over the
 * full band), the solve and its halves on blocks of 1-33 columns, the
 * chains' Cholesky and its border, and the LDL' of the Sturm count with
 * its Schur complement. A path whose vectors reordered a sum, contracted
 * a multiply-add or dropped a lane would fail here (tests/isa_tests.sh
 * compares whole sweeps' stores across paths). */
static void every_path_gives_the_same_bits(void **state)
{
    (void)state;
    fixture f;
    setup_fixture(&f, 29, 1);
    int n = f.n, checked = 0;
    dm_arrow_chol L;
    factor_of(&f, &f.a, &L);
    enum { QMAX = 33 };
    const int widths[] = {1, 3, 4, 8, 12, 13, 20, 24, 27, 33};
    double *X = malloc(sizeof(double) * n * QMAX), *R = malloc(sizeof(double) * n * QMAX);
    double *Y = malloc(sizeof(double) * n * QMAX);
    unsigned s = 31;
    for (int i = 0; i < n * QMAX; i++)
        X[i] = uniform(&s);
    const dm_arrow_kernels *base = dm_arrow_kernels_of(DM_ISA_DEFAULT);
    for (int isa = DM_ISA_DEFAULT + 1; isa < DM_ISA_COUNT; isa++) {
        if (!dm_isa_available((dm_isa)isa))
            continue;
        const dm_arrow_kernels *k = dm_arrow_kernels_of((dm_isa)isa);
        assert_ptr_not_equal(k, base);
        for (size_t w = 0; w < sizeof widths / sizeof widths[0]; w++) {
            int q = widths[w];
            for (int op = 0; op < 5; op++) {
                const dm_arrow_pattern *keep = f.a.pattern;
                f.a.pattern = op == 1 ? NULL : keep;
                const dm_arrow_kernels *both[2] = {base, k};
                double *out[2] = {R, Y};
                for (int b = 0; b < 2; b++) {
                    memcpy(out[b], X, sizeof(double) * n * q);
                    if (op <= 1)
                        both[b]->mult(&f.a, X, q, out[b]);
                    if (op == 2)
                        both[b]->chol_solve(&L, out[b], q);
                    if (op == 3)
                        both[b]->chol_forward(&L, out[b], q);
                    if (op == 4)
                        both[b]->chol_backward(&L, out[b], q);
                }
                f.a.pattern = keep;
                if (memcmp(R, Y, sizeof(double) * n * q))
                    fail_msg("path %s, operation %d on %d columns differs from the baseline's",
                             dm_isa_name((dm_isa)isa), op, q);
                checked++;
            }
        }
        for (int c = 0; c < DM_ARROW_BLOCKS; c++) { /* factors and their borders */
            int nb = f.lay.nb[c], kd = f.lay.kd[c], len = (kd + 1) * nb;
            const int *colend = f.pat.colend[c];
            double *band[2], *Z[2], *W[2], S[2][36] = {{0}};
            for (int b = 0; b < 2; b++) {
                const dm_arrow_kernels *kb = b ? k : base;
                band[b] = malloc(sizeof(double) * len);
                Z[b] = malloc(sizeof(double) * nb * 6);
                W[b] = malloc(sizeof(double) * nb * 6);
                memcpy(band[b], f.a.band[c], sizeof(double) * len);
                assert_int_equal(kb->band_chol(band[b], nb, kd, colend), 0);
                kb->border_of_factor(band[b], nb, kd, colend, f.a.cpl[c], Z[b], W[b], S[b]);
            }
            assert_memory_equal(band[0], band[1], sizeof(double) * len);
            assert_memory_equal(W[0], W[1], sizeof(double) * nb * 6);
            assert_memory_equal(S[0], S[1], sizeof S[0]);
            for (int b = 0; b < 2; b++) { /* the Sturm count's LDL' of A - 0.3 B */
                const dm_arrow_kernels *kb = b ? k : base;
                for (int i = 0; i < len; i++)
                    band[b][i] = f.a.band[c][i] - 0.3 * f.b.band[c][i];
                memset(S[b], 0, sizeof S[b]);
                assert_true(kb->band_ldl(band[b], nb, kd, colend) >= 0);
                kb->border_schur(band[b], nb, kd, colend, f.a.cpl[c], Z[b], S[b]);
            }
            assert_memory_equal(band[0], band[1], sizeof(double) * len);
            assert_memory_equal(S[0], S[1], sizeof S[0]);
            for (int b = 0; b < 2; b++)
                free(band[b]), free(Z[b]), free(W[b]);
        }
    }
    free(X), free(R), free(Y);
    dm_arrow_chol_release(&L);
    teardown_fixture(&f);
    if (!checked)
        skip(); /* a CPU with the baseline path only: nothing to compare */
}

/* DELTAMAP_ISA chooses the path (make test runs the suites under each):
 * the one in use is the one asked for, and a name that is no path, or a
 * path this CPU lacks, is an error naming the paths there are. */
static void the_path_is_the_one_asked_for(void **state)
{
    (void)state;
    const char *asked = getenv("DELTAMAP_ISA");
    dm_isa isa;
    dm_error err;
    if (asked && *asked)
        assert_string_equal(dm_isa_name(dm_isa_active()), asked);
    else
        assert_int_equal(dm_isa_active(), dm_isa_best());
    char keep[32] = "";
    if (asked)
        snprintf(keep, sizeof keep, "%s", asked);
    setenv("DELTAMAP_ISA", "avx3", 1);
    assert_int_equal(dm_isa_from_env(&isa, &err), DM_EINVAL);
    assert_non_null(strstr(err.msg, "DELTAMAP_ISA=avx3: unknown path"));
    for (int i = 0; i < DM_ISA_COUNT; i++) {
        setenv("DELTAMAP_ISA", dm_isa_name((dm_isa)i), 1);
        int rc = dm_isa_from_env(&isa, &err);
        assert_int_equal(rc, dm_isa_available((dm_isa)i) ? DM_OK : DM_EINVAL);
        if (rc)
            assert_non_null(strstr(err.msg, "this CPU or build has no"));
        else
            assert_int_equal(isa, i);
    }
    if (asked)
        setenv("DELTAMAP_ISA", keep, 1);
    else
        unsetenv("DELTAMAP_ISA");
    assert_int_equal(dm_isa_from_env(&isa, NULL), DM_OK);
    assert_int_equal(isa, dm_isa_active());
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(products_match_dense),
        cmocka_unit_test(block_widths_give_each_column_alone),
        cmocka_unit_test(cholesky_solves_and_schur_complement),
        cmocka_unit_test(cholesky_factor_matches_lapack_band),
        cmocka_unit_test(reduction_to_standard_form),
        cmocka_unit_test(sturm_counts_match_eigenvalues),
        cmocka_unit_test(every_path_gives_the_same_bits),
        cmocka_unit_test(the_path_is_the_one_asked_for),
    };
    return cmocka_run_group_tests_name("arrow", tests, NULL, NULL);
}
