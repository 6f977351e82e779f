/* dm_shape — the robot drawn from its model's nodes, and a displacement of
 * the model (a mode shape, the static gravity deflection, a trajectory's
 * state) as the 6-D displacement of every node (docs/shapes.md).
 *
 * Nodes, per chain i = 0, 1, 2: the arm's nodes 0..na (0 the root at A_i,
 * na the elbow B_i), then for each rod s = 0 (+d), 1 (-d) its nodes 0..nb
 * (0 the upper end at B_i + s d t_i, nb the lower end); after the three
 * chains one node at the platform centre P. A node's displacement is the
 * model's node map applied to the reduced DOFs (dm_model_nodemap_apply):
 * (u, v, w) in m and (tx, ty, tz) in rad, global axes; the platform node's
 * is the platform's six DOFs. Rod ends carry their own rotation (ball
 * joints), so the rigid short bars and the platform are drawn as lines
 * between nodes: each short bar from the elbow to its rod's upper end, the
 * platform as the hexagon through the six lower rod ends (in angle about
 * P) and a spoke from P to each. */
#ifndef DM_SHAPE_H
#define DM_SHAPE_H

#include "dm_analysis.h"
#include "dm_error.h"
#include "dm_model.h"
#include "dm_static.h"

typedef enum {
    DM_LINE_ARM = 0,
    DM_LINE_ROD,
    DM_LINE_SHORT_BAR,
    DM_LINE_PLATFORM
} dm_line_kind;

typedef struct dm_shape_mesh {
    int na, nb;
    int nnodes, nlines;
    double *xyz_m;     /* 3 per node: position at the model's pose */
    dm_nodemap *map;   /* per node: its 6 displacements from the reduced DOFs */
    int *line;         /* 2 per line: node indices */
    int *line_kind;    /* per line: dm_line_kind */
} dm_shape_mesh;

/* The nodes and lines of `model`'s mesh; positions and maps are those of
 * its last build (call dm_shape_mesh_update after each later build). */
dm_shape_mesh *dm_shape_mesh_alloc(const dm_model *model, dm_error *err);
void dm_shape_mesh_free(dm_shape_mesh *mesh);
void dm_shape_mesh_update(dm_shape_mesh *mesh, const dm_model *model);

/* Index of arm node k of chain i, node k of rod s of chain i, the platform. */
int dm_shape_arm_node(const dm_shape_mesh *mesh, int i, int k);
int dm_shape_rod_node(const dm_shape_mesh *mesh, int i, int s, int k);
int dm_shape_platform_node(const dm_shape_mesh *mesh);

/* d (6 per node) = each node's displacement for reduced DOFs U. */
void dm_shape_displace(const dm_shape_mesh *mesh, const double *U, double *d);

/* Largest translation |(u, v, w)| over the nodes of d (m, or m/sqrt(kg)
 * for a mass-normalised mode). */
double dm_shape_max_translation(const dm_shape_mesh *mesh, const double *d);

/* The factor that scales d so that its largest node translation is
 * max_m (0 when d does not move any node). */
double dm_shape_scale_to(const dm_shape_mesh *mesh, const double *d, double max_m);

/* Node positions moved by d magnified `factor` times: xyz + factor (u, v, w)
 * (3 per node). */
void dm_shape_deformed(const dm_shape_mesh *mesh, const double *d, double factor, double *xyz);

/* The translations (3 per node, times factor) and the rotations (likewise)
 * of d, apart: the vectors a viewer draws. */
void dm_shape_split(const dm_shape_mesh *mesh, const double *d, double factor, double *trans,
                    double *rot);

/* The static gravity deflection U = K^-1 F_gravity (n) with the factor of
 * the model's K (dm_static_factor); its platform DOFs are
 * dm_static_platform_error's static error. */
int dm_shape_static(const dm_static *ws, const dm_model *model, double *U, dm_error *err);

const char *dm_line_kind_name(int kind);

/* The shapes at one analysed pose: the mesh, each of the k modes as node
 * displacements (mass-normalised: m/sqrt(kg), rad/sqrt(kg)) and the
 * factor that scales it so its largest node translation is max_m, the
 * static gravity deflection (m, rad) and its factor likewise. */
typedef struct dm_shape_set {
    dm_shape_mesh *mesh;
    int k;
    double max_m;
    double *mode;         /* 6 nnodes per mode */
    double *mode_scale;   /* k */
    double *deflection;   /* 6 nnodes */
    double deflection_scale;
} dm_shape_set;

/* The stated maximum of scaled shapes unless one is asked for: a tenth of
 * the arm length (a mode drawn at that size is plain to see and still
 * looks like the robot). */
double dm_shape_default_max(const dm_robot *robot);

/* The shapes of the analysis' last run (dm_analysis_run with res). */
dm_shape_set *dm_shape_set_make(const dm_analysis *an, const dm_pose_result *res, double max_m,
                                dm_error *err);
void dm_shape_set_free(dm_shape_set *set);

#endif
