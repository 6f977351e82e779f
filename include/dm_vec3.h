/* dm_vec3 — small 3-vector helpers shared by the geometric modules.
 * Plain inline functions on double[3]; no state. */
#ifndef DM_VEC3_H
#define DM_VEC3_H

#include <math.h>

static inline double dm_dot3(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static inline double dm_norm3(const double a[3]) { return sqrt(dm_dot3(a, a)); }

static inline void dm_cross3(const double a[3], const double b[3], double out[3])
{
    double c0 = a[1] * b[2] - a[2] * b[1];
    double c1 = a[2] * b[0] - a[0] * b[2];
    double c2 = a[0] * b[1] - a[1] * b[0];
    out[0] = c0;
    out[1] = c1;
    out[2] = c2;
}

/* out = a + s*b */
static inline void dm_axpy3(const double a[3], double s, const double b[3], double out[3])
{
    out[0] = a[0] + s * b[0];
    out[1] = a[1] + s * b[1];
    out[2] = a[2] + s * b[2];
}

static inline void dm_sub3(const double a[3], const double b[3], double out[3])
{
    out[0] = a[0] - b[0];
    out[1] = a[1] - b[1];
    out[2] = a[2] - b[2];
}

static inline void dm_scale3(double s, const double a[3], double out[3])
{
    out[0] = s * a[0];
    out[1] = s * a[1];
    out[2] = s * a[2];
}

static inline void dm_copy3(const double a[3], double out[3])
{
    out[0] = a[0];
    out[1] = a[1];
    out[2] = a[2];
}

/* Matrix S with S*w == s x w, row-major 3x3. */
static inline void dm_skew3(const double s[3], double S[9])
{
    S[0] = 0;     S[1] = -s[2]; S[2] = s[1];
    S[3] = s[2];  S[4] = 0;     S[5] = -s[0];
    S[6] = -s[1]; S[7] = s[0];  S[8] = 0;
}

#endif
