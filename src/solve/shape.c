/* The robot's nodes and lines, and displacements of the model at them. */
#include "dm_shape.h"

#include <assert.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

static int chain_nodes(const dm_shape_mesh *mesh) { return mesh->na + 1 + 2 * (mesh->nb + 1); }

int dm_shape_arm_node(const dm_shape_mesh *mesh, int i, int k)
{
    assert(i >= 0 && i < 3 && k >= 0 && k <= mesh->na);
    return i * chain_nodes(mesh) + k;
}

int dm_shape_rod_node(const dm_shape_mesh *mesh, int i, int s, int k)
{
    assert(i >= 0 && i < 3 && (s == 0 || s == 1) && k >= 0 && k <= mesh->nb);
    return i * chain_nodes(mesh) + mesh->na + 1 + s * (mesh->nb + 1) + k;
}

int dm_shape_platform_node(const dm_shape_mesh *mesh) { return 3 * chain_nodes(mesh); }

static void add_line(dm_shape_mesh *mesh, int a, int b, dm_line_kind kind)
{
    mesh->line[2 * mesh->nlines] = a;
    mesh->line[2 * mesh->nlines + 1] = b;
    mesh->line_kind[mesh->nlines++] = kind;
}

/* Members and short bars: the same at every pose. */
static void member_lines(dm_shape_mesh *mesh)
{
    for (int i = 0; i < 3; i++) {
        for (int k = 0; k < mesh->na; k++)
            add_line(mesh, dm_shape_arm_node(mesh, i, k), dm_shape_arm_node(mesh, i, k + 1),
                     DM_LINE_ARM);
        for (int s = 0; s < 2; s++) {
            for (int k = 0; k < mesh->nb; k++)
                add_line(mesh, dm_shape_rod_node(mesh, i, s, k),
                         dm_shape_rod_node(mesh, i, s, k + 1), DM_LINE_ROD);
            add_line(mesh, dm_shape_arm_node(mesh, i, mesh->na), dm_shape_rod_node(mesh, i, s, 0),
                     DM_LINE_SHORT_BAR);
        }
    }
}

/* The platform: the six lower rod ends in angle about P (a hexagon that
 * does not cross itself at any pose of the same robot), and spokes. */
static void platform_lines(dm_shape_mesh *mesh)
{
    int end[6], P = dm_shape_platform_node(mesh);
    double angle[6];
    const double *c = mesh->xyz_m + 3 * P;
    for (int j = 0; j < 6; j++) {
        end[j] = dm_shape_rod_node(mesh, j / 2, j % 2, mesh->nb);
        const double *x = mesh->xyz_m + 3 * end[j];
        angle[j] = atan2(x[1] - c[1], x[0] - c[0]);
    }
    for (int a = 1; a < 6; a++) /* insertion sort by angle */
        for (int b = a; b > 0 && angle[b - 1] > angle[b]; b--) {
            double t = angle[b];
            angle[b] = angle[b - 1];
            angle[b - 1] = t;
            int e = end[b];
            end[b] = end[b - 1];
            end[b - 1] = e;
        }
    for (int j = 0; j < 6; j++)
        add_line(mesh, end[j], end[(j + 1) % 6], DM_LINE_PLATFORM);
    for (int j = 0; j < 6; j++)
        add_line(mesh, P, end[j], DM_LINE_PLATFORM);
}

dm_shape_mesh *dm_shape_mesh_alloc(const dm_model *model, dm_error *err)
{
    dm_shape_mesh *mesh = calloc(1, sizeof *mesh);
    if (mesh) {
        mesh->na = model->na;
        mesh->nb = model->nb;
        mesh->nnodes = 3 * chain_nodes(mesh) + 1;
        int lines = 3 * (model->na + 2 * model->nb + 2) + 12;
        mesh->xyz_m = calloc((size_t)mesh->nnodes * 3, sizeof *mesh->xyz_m);
        mesh->map = calloc((size_t)mesh->nnodes, sizeof *mesh->map);
        mesh->line = calloc((size_t)lines * 2, sizeof *mesh->line);
        mesh->line_kind = calloc((size_t)lines, sizeof *mesh->line_kind);
    }
    if (!mesh || !mesh->xyz_m || !mesh->map || !mesh->line || !mesh->line_kind) {
        dm_shape_mesh_free(mesh);
        dm_fail(err, DM_ENOMEM, "out of memory (shape mesh)");
        return NULL;
    }
    dm_shape_mesh_update(mesh, model);
    return mesh;
}

void dm_shape_mesh_free(dm_shape_mesh *mesh)
{
    if (!mesh)
        return;
    free(mesh->xyz_m);
    free(mesh->map);
    free(mesh->line);
    free(mesh->line_kind);
    free(mesh);
}

static void set_node(dm_shape_mesh *mesh, int node, const double x[3], const dm_nodemap *map)
{
    memcpy(mesh->xyz_m + 3 * node, x, 3 * sizeof *x);
    mesh->map[node] = *map;
}

/* A member's nodes from its elements: node k is element k's first node,
 * the last node the last element's second. */
static void member_nodes(dm_shape_mesh *mesh, const dm_element *e, int parts, int first_node)
{
    for (int k = 0; k < parts; k++)
        set_node(mesh, first_node + k, e[k].x1, &e[k].node[0]);
    set_node(mesh, first_node + parts, e[parts - 1].x2, &e[parts - 1].node[1]);
}

void dm_shape_mesh_update(dm_shape_mesh *mesh, const dm_model *model)
{
    assert(model->na == mesh->na && model->nb == mesh->nb);
    const dm_element *e = model->elem; /* per chain: the arm's na, then each rod's nb */
    for (int i = 0; i < 3; i++) {
        member_nodes(mesh, e, mesh->na, dm_shape_arm_node(mesh, i, 0));
        e += mesh->na;
        for (int s = 0; s < 2; s++, e += mesh->nb)
            member_nodes(mesh, e, mesh->nb, dm_shape_rod_node(mesh, i, s, 0));
    }
    dm_nodemap platform = {.m = 6};
    for (int j = 0; j < 6; j++) {
        platform.idx[j] = model->platform_dof + j;
        platform.c[j][j] = 1.0;
    }
    set_node(mesh, dm_shape_platform_node(mesh), model->pose.P, &platform);
    mesh->nlines = 0;
    member_lines(mesh);
    platform_lines(mesh);
}

void dm_shape_displace(const dm_shape_mesh *mesh, const double *U, double *d)
{
    for (int j = 0; j < mesh->nnodes; j++)
        dm_model_nodemap_apply(&mesh->map[j], U, d + 6 * j);
}

double dm_shape_max_translation(const dm_shape_mesh *mesh, const double *d)
{
    double m = 0;
    for (int j = 0; j < mesh->nnodes; j++) {
        const double *u = d + 6 * j;
        m = fmax(m, sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]));
    }
    return m;
}

double dm_shape_scale_to(const dm_shape_mesh *mesh, const double *d, double max_m)
{
    double m = dm_shape_max_translation(mesh, d);
    return m > 0 ? max_m / m : 0.0;
}

void dm_shape_deformed(const dm_shape_mesh *mesh, const double *d, double factor, double *xyz)
{
    for (int j = 0; j < mesh->nnodes; j++)
        for (int c = 0; c < 3; c++)
            xyz[3 * j + c] = mesh->xyz_m[3 * j + c] + factor * d[6 * j + c];
}

void dm_shape_split(const dm_shape_mesh *mesh, const double *d, double factor, double *trans,
                    double *rot)
{
    for (int j = 0; j < mesh->nnodes; j++)
        for (int c = 0; c < 3; c++) {
            trans[3 * j + c] = factor * d[6 * j + c];
            rot[3 * j + c] = factor * d[6 * j + 3 + c];
        }
}

int dm_shape_static(const dm_static *ws, const dm_model *model, double *U, dm_error *err)
{
    memcpy(U, model->F_gravity, (size_t)model->n * sizeof *U);
    return dm_static_solve(ws, U, 1, err);
}

const char *dm_line_kind_name(int kind)
{
    static const char *const names[] = {"arm", "rod", "short_bar", "platform"};
    assert(kind >= 0 && kind < 4);
    return names[kind];
}

double dm_shape_default_max(const dm_robot *robot) { return 0.1 * robot->arm_length_m; }

void dm_shape_set_free(dm_shape_set *set)
{
    if (!set)
        return;
    dm_shape_mesh_free(set->mesh);
    free(set->mode);
    free(set->mode_scale);
    free(set->deflection);
    free(set);
}

static int shape_set_alloc(const dm_analysis *an, int k, dm_shape_set **out, dm_error *err)
{
    dm_shape_set *set = calloc(1, sizeof *set);
    *out = set;
    if (!set)
        return dm_fail(err, DM_ENOMEM, "out of memory (shapes)");
    if (!(set->mesh = dm_shape_mesh_alloc(an->model, err)))
        return err ? err->code : DM_ENOMEM;
    size_t per = 6 * (size_t)set->mesh->nnodes;
    set->k = k;
    set->mode = malloc(per * (k > 0 ? k : 1) * sizeof *set->mode);
    set->mode_scale = calloc(k > 0 ? k : 1, sizeof *set->mode_scale);
    set->deflection = malloc(per * sizeof *set->deflection);
    if (!set->mode || !set->mode_scale || !set->deflection)
        return dm_fail(err, DM_ENOMEM, "out of memory (shapes)");
    return DM_OK;
}

dm_shape_set *dm_shape_set_make(const dm_analysis *an, const dm_pose_result *res, double max_m,
                                dm_error *err)
{
    const dm_modes *mo = res->modes;
    const dm_model *md = an->model;
    dm_shape_set *set = NULL;
    double *U = malloc((size_t)md->n * sizeof *U);
    int rc = U ? shape_set_alloc(an, mo->k, &set, err)
               : dm_fail(err, DM_ENOMEM, "out of memory (shapes)");
    if (!rc)
        rc = dm_shape_static(an->statics, md, U, err);
    if (!rc) {
        size_t per = 6 * (size_t)set->mesh->nnodes;
        set->max_m = max_m;
        for (int j = 0; j < mo->k; j++) {
            dm_shape_displace(set->mesh, mo->phi + (size_t)j * md->n, set->mode + per * j);
            set->mode_scale[j] = dm_shape_scale_to(set->mesh, set->mode + per * j, max_m);
        }
        dm_shape_displace(set->mesh, U, set->deflection);
        set->deflection_scale = dm_shape_scale_to(set->mesh, set->deflection, max_m);
    }
    free(U);
    if (rc) {
        dm_shape_set_free(set);
        return NULL;
    }
    return set;
}
