/* modes --json's shapes: the numbers of dm_shape_set, printed. */
#include "cli_shapes.h"

static const char *const COMPONENTS[6] = {"u_m", "v_m", "w_m", "tx_rad", "ty_rad", "tz_rad"};

/* nrow rows of ncol numbers, each times `scale`. */
static json_t *json_rows(const double *v, int nrow, int ncol, double scale)
{
    json_t *a = json_array();
    for (int r = 0; r < nrow; r++) {
        json_t *row = json_array();
        for (int c = 0; c < ncol; c++)
            json_array_append_new(row, json_real(scale * v[(size_t)ncol * r + c]));
        json_array_append_new(a, row);
    }
    return a;
}

static json_t *mesh_json(const dm_shape_set *set)
{
    const dm_shape_mesh *mesh = set->mesh;
    json_t *m = json_object(), *lines = json_array(), *kinds = json_array(), *comp = json_array();
    for (int l = 0; l < mesh->nlines; l++) {
        json_array_append_new(lines, json_pack("[ii]", mesh->line[2 * l], mesh->line[2 * l + 1]));
        json_array_append_new(kinds, json_string(dm_line_kind_name(mesh->line_kind[l])));
    }
    for (int c = 0; c < 6; c++)
        json_array_append_new(comp, json_string(COMPONENTS[c]));
    json_object_set_new(m, "nodes_m", json_rows(mesh->xyz_m, mesh->nnodes, 3, 1.0));
    json_object_set_new(m, "platform_node", json_integer(dm_shape_platform_node(mesh)));
    json_object_set_new(m, "lines", lines);
    json_object_set_new(m, "line_kinds", kinds);
    json_object_set_new(m, "components", comp);
    json_object_set_new(m, "scaled_max_m", json_real(set->max_m));
    return m;
}

/* A shape (6 per node) as "shape", "shape_scaled" and "shape_scale" of o. */
static void shape_json(json_t *o, const dm_shape_mesh *mesh, const double *d, double scale)
{
    json_object_set_new(o, "shape", json_rows(d, mesh->nnodes, 6, 1.0));
    json_object_set_new(o, "shape_scaled", json_rows(d, mesh->nnodes, 6, scale));
    json_object_set_new(o, "shape_scale", json_real(scale));
}

void dm_cli_shapes_json(json_t *o, json_t *modes, const dm_shape_set *set)
{
    size_t per = 6 * (size_t)set->mesh->nnodes;
    json_object_set_new(o, "shape_mesh", mesh_json(set));
    for (int j = 0; j < set->k; j++)
        shape_json(json_array_get(modes, j), set->mesh, set->mode + per * j, set->mode_scale[j]);
    json_t *st = json_object();
    shape_json(st, set->mesh, set->deflection, set->deflection_scale);
    json_object_set_new(o, "static_deflection", st);
}
