/* Element matrices of the 3-D Euler–Bernoulli beam (docs/model.md §2). */
#include "dm_beam.h"

#include <math.h>
#include <string.h>

#include "dm_vec3.h"

void dm_beam_props_of(const dm_member *m, dm_beam_props *p)
{
    const dm_section *s = &m->section;
    p->EA = m->youngs_pa * s->area_m2;
    p->EIy = m->youngs_pa * s->iy_m4;
    p->EIz = m->youngs_pa * s->iz_m4;
    p->GJ = m->shear_pa * s->j_m4;
    p->rhoA = m->density_kgm3 * s->area_m2;
    p->rhoIp = m->density_kgm3 * s->ip_m4;
    p->A = s->area_m2;
    p->Ip = s->ip_m4;
}

/* Add s * pattern (4x4, row-major) at local DOFs dof[4]. */
static void place4(double X[144], const int dof[4], double s, const double pat[16])
{
    for (int r = 0; r < 4; r++)
        for (int c = 0; c < 4; c++)
            X[dof[r] * 12 + dof[c]] += s * pat[r * 4 + c];
}

/* Add s * [1 -1; -1 1] or s * [2 1; 1 2] style 2x2 patterns at (i, j). */
static void place2(double X[144], int i, int j, double diag, double off)
{
    X[i * 12 + i] += diag;
    X[j * 12 + j] += diag;
    X[i * 12 + j] += off;
    X[j * 12 + i] += off;
}

static const int XY_PLANE[4] = {1, 5, 7, 11}; /* v1, theta_z1, v2, theta_z2 */
static const int XZ_PLANE[4] = {2, 4, 8, 10}; /* w1, theta_y1, w2, theta_y2 */

/* The x-z plane uses theta_y = -dw/dx: flip the sign of every entry that
 * couples a rotation with a translation. */
static void flip_rotation_coupling(const double in[16], double out[16])
{
    for (int r = 0; r < 4; r++)
        for (int c = 0; c < 4; c++)
            out[r * 4 + c] = ((r & 1) != (c & 1)) ? -in[r * 4 + c] : in[r * 4 + c];
}

static void bending_pair(double X[144], const double xy[16], double s_xy, double s_xz)
{
    double xz[16];
    flip_rotation_coupling(xy, xz);
    place4(X, XY_PLANE, s_xy, xy);
    place4(X, XZ_PLANE, s_xz, xz);
}

void dm_beam_stiffness(const dm_beam_props *p, double L, double K[144])
{
    memset(K, 0, 144 * sizeof *K);
    place2(K, 0, 6, p->EA / L, -p->EA / L);
    place2(K, 3, 9, p->GJ / L, -p->GJ / L);
    double L2 = L * L;
    const double bend[16] = {12, 6 * L, -12, 6 * L,
                             6 * L, 4 * L2, -6 * L, 2 * L2,
                             -12, -6 * L, 12, -6 * L,
                             6 * L, 2 * L2, -6 * L, 4 * L2};
    double L3 = L2 * L;
    bending_pair(K, bend, p->EIz / L3, p->EIy / L3);
}

void dm_beam_mass(const dm_beam_props *p, double L, double M[144])
{
    memset(M, 0, 144 * sizeof *M);
    place2(M, 0, 6, p->rhoA * L / 3.0, p->rhoA * L / 6.0);
    place2(M, 3, 9, p->rhoIp * L / 3.0, p->rhoIp * L / 6.0);
    double L2 = L * L;
    const double herm[16] = {156, 22 * L, 54, -13 * L,
                             22 * L, 4 * L2, 13 * L, -3 * L2,
                             54, 13 * L, 156, -22 * L,
                             -13 * L, -3 * L2, -22 * L, 4 * L2};
    double s = p->rhoA * L / 420.0;
    bending_pair(M, herm, s, s);
}

void dm_beam_geometric(const dm_beam_props *p, double N, double L, double KG[144])
{
    memset(KG, 0, 144 * sizeof *KG);
    double L2 = L * L;
    const double geo[16] = {6.0 / 5, L / 10, -6.0 / 5, L / 10,
                            L / 10, 2 * L2 / 15, -L / 10, -L2 / 30,
                            -6.0 / 5, -L / 10, 6.0 / 5, -L / 10,
                            L / 10, -L2 / 30, -L / 10, 2 * L2 / 15};
    bending_pair(KG, geo, N / L, N / L);
    double kt = N * p->Ip / (p->A * L);
    place2(KG, 3, 9, kt, -kt);
}

int dm_beam_frame(const double axis[3], const double y_hint[3], double lambda[9])
{
    double x[3], y[3], z[3], n = dm_norm3(axis);
    if (!(n > 0))
        return -1;
    dm_scale3(1.0 / n, axis, x);
    dm_axpy3(y_hint, -dm_dot3(y_hint, x), x, y);
    double ny = dm_norm3(y);
    if (!(ny > 1e-12 * dm_norm3(y_hint)))
        return -1; /* hint parallel to the axis */
    dm_scale3(1.0 / ny, y, y);
    dm_cross3(x, y, z);
    for (int k = 0; k < 3; k++) {
        lambda[k] = x[k];
        lambda[3 + k] = y[k];
        lambda[6 + k] = z[k];
    }
    return 0;
}
