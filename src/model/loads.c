/* Inertial loads of the nominal rigid motion (docs/model.md §3). */
#include "dm_loads.h"

#include <assert.h>

/* Rigid accelerations are affine along a straight link: interpolate its end
 * accelerations. Arms: 0 at A, aB at B; rods: aB at the top (the short bar
 * turns with the arm about t_i, so it adds nothing), aP at the bottom. */
static void node_acceleration(const dm_element *e, double s, const double aB[3],
                              const double aP[3], double a[3])
{
    for (int k = 0; k < 3; k++)
        a[k] = e->member == DM_MEMBER_ARM ? s * aB[k] : (1 - s) * aB[k] + s * aP[k];
}

#define MAX_MOTIONS 8

void dm_loads_add_inertial_many(const dm_model *md, const dm_rigid_motion *mo, int q, double *F)
{
    assert(q >= 1 && q <= MAX_MOTIONS);
    dm_link_motion lm[MAX_MOTIONS];
    for (int l = 0; l < q; l++)
        dm_kin_link_accelerations(&md->pose, mo[l].alpha_dot, mo[l].alpha_ddot, mo[l].aP, &lm[l]);
    for (int k = 0; k < md->nelem; k++) {
        const dm_element *e = &md->elem[k];
        double a12[MAX_MOTIONS][12];
        for (int l = 0; l < q; l++) {
            double *a = a12[l];
            node_acceleration(e, e->s1, lm[l].aB[e->chain], mo[l].aP, a);
            node_acceleration(e, e->s2, lm[l].aB[e->chain], mo[l].aP, a + 6);
            const double *ang = e->member == DM_MEMBER_ARM ? lm[l].arm_alpha[e->chain]
                                                           : lm[l].rod_alpha[e->chain];
            for (int c = 0; c < 3; c++)
                a[3 + c] = a[9 + c] = ang[c];
            for (int c = 0; c < 12; c++)
                a[c] = -a[c]; /* G_e = -M_e a_e */
        }
        dm_model_add_element_loads(md, e, q, a12[0], F);
    }
    int pd = md->platform_dof, n = md->n;
    for (int l = 0; l < q; l++) {
        double *Fl = F + (size_t)l * n;
        for (int r = 0; r < 6; r++) /* platform and payload */
            for (int c = 0; c < 3; c++)
                Fl[pd + r] -= md->platform_mass[6 * c + r] * mo[l].aP[c];
        for (int i = 0; i < 3; i++) /* elbow point masses */
            for (int c = 0; c < 3; c++)
                Fl[md->elbow_dof[i] + c] -= md->robot->effects.elbow_mass_kg * lm[l].aB[i][c];
    }
}

void dm_loads_add_inertial(const dm_model *md, const dm_rigid_motion *mo, double *F)
{
    dm_loads_add_inertial_many(md, mo, 1, F);
}

void dm_loads_add_platform_wrench(const dm_model *md, const double force[3],
                                  const double torque[3], double *F)
{
    for (int k = 0; k < 3; k++) {
        F[md->platform_dof + k] += force[k];
        F[md->platform_dof + 3 + k] += torque[k];
    }
}
