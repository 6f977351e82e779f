/* Small symmetric eigenproblems and singular values by cyclic Jacobi
 * (dm_symeig.h). */
#include "dm_symeig.h"

#include <assert.h>
#include <float.h>
#include <math.h>
#include <stddef.h>

enum { MAX_SWEEPS = 50 };

#define AT(i, j) A[(i) + (size_t)(j) * lda]
#define VT(i, j) V[(i) + (size_t)(j) * ldv]

/* The rotation that zeroes the off-diagonal entry apq of the symmetric
 * pair [app apq; apq aqq]: t = tan, s = sin and tau = s / (1 + c)
 * (Rutishauser's form: each entry then updated as a small correction). */
static void rotation_of(double app, double aqq, double apq, double *t, double *s, double *tau)
{
    double theta = (aqq - app) / (2 * apq);
    *t = fabs(theta) > 1e150 ? 0.5 / theta /* theta^2 would overflow */
                             : copysign(1, theta) / (fabs(theta) + sqrt(theta * theta + 1));
    double c = 1 / sqrt(*t * *t + 1);
    *s = *t * c, *tau = *s / (1 + c);
}

/* (g, h) = (c g - s h, s g + c h) in that form */
static inline void rotate(double *g, double *h, double s, double tau)
{
    double a = *g, b = *h;
    *g = a - s * (b + a * tau);
    *h = b + s * (a - b * tau);
}

/* One rotation in the plane (p, q) that zeroes A(p, q), applied to A's
 * rows and columns and to V's columns. 0 when the
 * entry is already negligible (then made 0: below half an ulp of its
 * diagonal pair, it moves no eigenvalue by more than that). */
static int annihilate(int n, double *A, int lda, double *V, int ldv, int p, int q)
{
    double apq = AT(p, q), app = AT(p, p), aqq = AT(q, q);
    if (fabs(apq) <= 0.5 * DBL_EPSILON * sqrt(fabs(app)) * sqrt(fabs(aqq))) {
        AT(p, q) = AT(q, p) = 0;
        return 0;
    }
    double t, s, tau;
    rotation_of(app, aqq, apq, &t, &s, &tau);
    AT(p, p) = app - t * apq;
    AT(q, q) = aqq + t * apq;
    AT(p, q) = AT(q, p) = 0;
    for (int r = 0; r < n; r++) {
        if (r == p || r == q)
            continue;
        rotate(&AT(r, p), &AT(r, q), s, tau);
        AT(p, r) = AT(r, p), AT(q, r) = AT(r, q);
    }
    for (int r = 0; r < n; r++)
        rotate(&VT(r, p), &VT(r, q), s, tau);
    return 1;
}

/* A's upper triangle mirrored into the lower, V = I; -1 for a non-finite
 * entry. */
static int start(int n, double *A, int lda, double *V, int ldv)
{
    for (int j = 0; j < n; j++) {
        for (int i = 0; i <= j; i++) {
            if (!isfinite(AT(i, j)))
                return -1;
            AT(j, i) = AT(i, j);
        }
        for (int i = 0; i < n; i++)
            VT(i, j) = i == j;
    }
    return 0;
}

/* w ascending, V's columns with them (a selection sort: n is small). */
static void sort_pairs(int n, double *w, double *V, int ldv)
{
    for (int i = 0; i + 1 < n; i++) {
        int k = i;
        for (int j = i + 1; j < n; j++)
            if (w[j] < w[k])
                k = j;
        if (k == i)
            continue;
        double t = w[i];
        w[i] = w[k], w[k] = t;
        for (int r = 0; r < n; r++) {
            t = VT(r, i);
            VT(r, i) = VT(r, k), VT(r, k) = t;
        }
    }
}

int dm_symeig(int n, double *A, int lda, double *w, double *V, int ldv)
{
    assert(n >= 1 && lda >= n && ldv >= n);
    if (start(n, A, lda, V, ldv))
        return -1;
    for (int sweep = 0;; sweep++) {
        int rotated = 0;
        for (int p = 0; p < n; p++)
            for (int q = p + 1; q < n; q++)
                rotated |= annihilate(n, A, lda, V, ldv, p, q);
        if (!rotated)
            break;
        if (sweep == MAX_SWEEPS)
            return -1;
    }
    for (int j = 0; j < n; j++)
        w[j] = AT(j, j);
    sort_pairs(n, w, V, ldv);
    return 0;
}

/* Columns p and q of A (m rows) made orthogonal by one rotation (the
 * two-sided rotation of A'A's entry (p, q), applied to A's columns); 0
 * when their cosine is already below m ulps: the rounding of the columns'
 * dot product and of the rotation leave a cosine of a few ulps that no
 * rotation lowers (a kinematic Jacobian of zheng2017 stalled at 1.08 eps,
 * the limit an ulp then never reached; dgesvj stops at sqrt(m) eps). */
static int orthogonalise(int m, double *A, int lda, int p, int q)
{
    double *a = A + (size_t)p * lda, *b = A + (size_t)q * lda, app = 0, aqq = 0, apq = 0;
    for (int r = 0; r < m; r++) {
        app += a[r] * a[r];
        aqq += b[r] * b[r];
        apq += a[r] * b[r];
    }
    if (fabs(apq) <= m * DBL_EPSILON * sqrt(app) * sqrt(aqq))
        return 0;
    double t, s, tau;
    rotation_of(app, aqq, apq, &t, &s, &tau);
    for (int r = 0; r < m; r++)
        rotate(&a[r], &b[r], s, tau);
    return 1;
}

int dm_symeig_singular_values(int m, int n, double *A, int lda, double *s)
{
    assert(n >= 1 && m >= n && lda >= m);
    for (int j = 0; j < n; j++)
        for (int i = 0; i < m; i++)
            if (!isfinite(A[i + (size_t)j * lda]))
                return -1;
    for (int sweep = 0;; sweep++) {
        int rotated = 0;
        for (int p = 0; p < n; p++)
            for (int q = p + 1; q < n; q++)
                rotated |= orthogonalise(m, A, lda, p, q);
        if (!rotated)
            break;
        if (sweep == MAX_SWEEPS)
            return -1;
    }
    for (int j = 0; j < n; j++) {
        const double *a = A + (size_t)j * lda;
        double ss = 0;
        for (int r = 0; r < m; r++)
            ss += a[r] * a[r];
        s[j] = sqrt(ss);
    }
    for (int i = 0; i + 1 < n; i++) /* descending */
        for (int j = i + 1; j < n; j++)
            if (s[j] > s[i]) {
                double t = s[i];
                s[i] = s[j], s[j] = t;
            }
    return 0;
}
