/* Shapes (dm_shape) as `deltamap modes --json` prints them: gathered back
 * to the model's reduced DOFs they solve K phi = lambda M phi, equal the
 * solver's vectors and are M-normalised; the static deflection solves
 * K u = F_gravity and is static_error at the platform node; the drawn
 * robot has the robot's lengths. The JSON is read from the deltamap
 * built beside this test (build/deltamap for build/tests/test_shape), or
 * $DELTAMAP. */
#include "dm_test.h"

#include <jansson.h>
#include <lapacke.h>
#include <libgen.h>

#include "dm_analysis.h"
#include "dm_shape.h"
#include "dm_threads.h"
#include "dm_vec3.h"

static char deltamap[1200];

typedef struct {
    const char *robot, *at, *sets; /* as given to deltamap modes */
    double P[3];
    int na, nb, k;
} shape_case;

/* Chen's home pose at mesh 2,2; zheng2017 off centre at 3,2 with every
 * extension that changes a node map (joint springs: rod ends with own
 * translations; actuator and base springs: arm-root DOFs). */
static const shape_case CASES[] = {
    {"chen2018", NULL, "", {0, 0, 0}, 2, 2, 6},
    {"zheng2017", "0.05,-0.03,-0.45",
     "--set effects.joint_stiffness=2e6 --set effects.actuator_stiffness=3e4 "
     "--set effects.base_stiffness=5e6,5e6,8e6",
     {0.05, -0.03, -0.45}, 3, 2, 5},
};

static json_t *run_modes(const shape_case *c)
{
    char cmd[2048];
    snprintf(cmd, sizeof cmd, "%s modes --robot %s %s%s --mesh %d,%d --modes %d %s --json",
             deltamap, c->robot, c->at ? "--at " : "", c->at ? c->at : "", c->na, c->nb, c->k,
             c->sets);
    FILE *f = popen(cmd, "r");
    assert_non_null(f);
    json_error_t jerr;
    json_t *o = json_loadf(f, 0, &jerr);
    assert_int_equal(pclose(f), 0);
    if (!o)
        fail_msg("%s: %s", cmd, jerr.text);
    return o;
}

/* The robot of a case, with its --set effects applied the same way. */
static void load_robot(const shape_case *c, dm_robot *rb)
{
    assert_int_equal(dm_robot_load(c->robot, rb, NULL), 0);
    if (c->sets[0]) {
        rb->effects.joint_stiffness_n_per_m = 2e6;
        rb->effects.actuator_stiffness_nm_per_rad = 3e4;
        for (int i = 0; i < 3; i++) {
            rb->effects.base_stiffness_n_per_m[i][0] = 5e6;
            rb->effects.base_stiffness_n_per_m[i][1] = 5e6;
            rb->effects.base_stiffness_n_per_m[i][2] = 8e6;
        }
    }
}

/* Node displacements d (6 per node, from a JSON array of rows) back to
 * reduced DOFs: the least-squares solution of A U = d, A the nodes'
 * maps stacked (every reduced DOF moves some node, so A has full column
 * rank and U is exact up to round-off). */
static void gather(const dm_shape_mesh *mesh, int n, json_t *rows, double *U)
{
    int m = 6 * mesh->nnodes;
    assert_int_equal((int)json_array_size(rows), mesh->nnodes);
    double *A = calloc((size_t)m * n, sizeof *A), *b = calloc((size_t)m, sizeof *b);
    for (int j = 0; j < mesh->nnodes; j++) {
        const dm_nodemap *map = &mesh->map[j];
        for (int r = 0; r < 6; r++) {
            b[6 * j + r] = json_real_value(json_array_get(json_array_get(rows, j), r));
            for (int c = 0; c < map->m; c++)
                A[(size_t)map->idx[c] * m + 6 * j + r] += map->c[r][c];
        }
    }
    assert_int_equal(LAPACKE_dgels(LAPACK_COL_MAJOR, 'N', m, n, 1, A, m, b, m), 0);
    memcpy(U, b, (size_t)n * sizeof *U);
    free(A);
    free(b);
}

static double norm(const double *v, int n)
{
    double s = 0;
    for (int i = 0; i < n; i++)
        s += v[i] * v[i];
    return sqrt(s);
}

static void matvec(const double *A, const double *x, int n, double *y)
{
    for (int i = 0; i < n; i++) {
        double s = 0;
        for (int j = 0; j < n; j++)
            s += A[(size_t)j * n + i] * x[j];
        y[i] = s;
    }
}

typedef struct {
    dm_robot rb;
    dm_analysis *an;
    dm_pose_result res;
    dm_shape_mesh *mesh;
    double *K, *M, *U, *KU, *MU;
} oracle;

static void oracle_make(const shape_case *c, oracle *o)
{
    load_robot(c, &o->rb);
    o->an = dm_analysis_alloc(&o->rb, c->na, c->nb, c->k, DM_EIGEN_PARTIAL, NULL);
    assert_non_null(o->an);
    const double *P = c->at ? c->P : o->rb.home_m;
    assert_int_equal(dm_analysis_run(o->an, P, c->k, &o->res, NULL), 0);
    o->mesh = dm_shape_mesh_alloc(o->an->model, NULL);
    assert_non_null(o->mesh);
    size_t n = (size_t)o->an->model->n;
    o->K = malloc(n * n * sizeof(double));
    o->M = malloc(n * n * sizeof(double));
    o->U = malloc(n * sizeof(double));
    o->KU = malloc(n * sizeof(double));
    o->MU = malloc(n * sizeof(double));
    dm_model_dense(o->an->model, o->K, o->M);
}

static void oracle_free(oracle *o)
{
    dm_shape_mesh_free(o->mesh);
    dm_analysis_free(o->an);
    free(o->K), free(o->M), free(o->U), free(o->KU), free(o->MU);
}

/* Tolerances: the JSON holds 17 significant digits (exact doubles); the
 * gather is a least-squares solve whose error is a few eps times the
 * condition of A (<= 1e3 here: maps of unit entries and lever arms of
 * 0.05-0.2 m), so 1e-10 relative for the vector and its norm; the
 * eigen residual is the 1e-8 relative (the solver's own
 * convergence is tighter). */
static void check_mode(const oracle *o, json_t *mode, int j, double max_m)
{
    int n = o->an->model->n;
    const double *phi = o->res.modes->phi + (size_t)j * n;
    gather(o->mesh, n, json_object_get(mode, "shape"), o->U);
    double f = json_real_value(json_object_get(mode, "freq_hz")), lambda = pow(2 * M_PI * f, 2);
    matvec(o->K, o->U, n, o->KU);
    matvec(o->M, o->U, n, o->MU);
    double r[n];
    for (int i = 0; i < n; i++)
        r[i] = o->KU[i] - lambda * o->MU[i];
    assert_true(norm(r, n) <= 1e-8 * norm(o->KU, n));
    for (int i = 0; i < n; i++)
        r[i] = o->U[i] - phi[i];
    assert_abs(norm(r, n) / norm(phi, n), 0.0, 1e-10, "mode %d: |gathered - solver's|", j + 1);
    double uMu = 0;
    for (int i = 0; i < n; i++)
        uMu += o->U[i] * o->MU[i];
    assert_rel(uMu, 1.0, 1e-10, "mode %d: phi' M phi", j + 1);
    /* the scaled shape: the same times shape_scale, largest translation max_m */
    json_t *s = json_object_get(mode, "shape"), *ss = json_object_get(mode, "shape_scaled");
    double scale = json_real_value(json_object_get(mode, "shape_scale")), tmax = 0;
    for (size_t a = 0; a < json_array_size(s); a++) {
        double t2 = 0;
        for (int c = 0; c < 6; c++) {
            double v = json_real_value(json_array_get(json_array_get(s, a), c));
            double w = json_real_value(json_array_get(json_array_get(ss, a), c));
            assert_abs(w, scale * v, 1e-15 * max_m, "mode %d node %zu scaled", j + 1, a);
            t2 += c < 3 ? w * w : 0;
        }
        tmax = fmax(tmax, sqrt(t2));
    }
    assert_rel(tmax, max_m, 1e-14, "mode %d: largest scaled translation", j + 1);
}

static void modes_json_shapes_solve_the_eigenproblem(void **state)
{
    (void)state;
    for (size_t c = 0; c < sizeof CASES / sizeof *CASES; c++) {
        oracle o;
        oracle_make(&CASES[c], &o);
        json_t *js = run_modes(&CASES[c]), *modes = json_object_get(js, "modes");
        json_t *mesh = json_object_get(js, "shape_mesh");
        double max_m = json_real_value(json_object_get(mesh, "scaled_max_m"));
        assert_rel(max_m, 0.1 * o.rb.arm_length_m, 1e-15, "stated maximum");
        assert_int_equal((int)json_array_size(json_object_get(mesh, "nodes_m")), o.mesh->nnodes);
        assert_int_equal((int)json_array_size(modes), CASES[c].k);
        for (int j = 0; j < CASES[c].k; j++)
            check_mode(&o, json_array_get(modes, j), j, max_m);
        json_decref(js);
        oracle_free(&o);
    }
}

/* The static deflection: K u = F_gravity (1e-10: the factor's backward
 * error is ~1e-14 at these condition numbers, the gather's above), and at
 * the platform node exactly static_error (the same solve). */
static void static_deflection_is_the_static_error(void **state)
{
    (void)state;
    for (size_t c = 0; c < sizeof CASES / sizeof *CASES; c++) {
        oracle o;
        oracle_make(&CASES[c], &o);
        int n = o.an->model->n;
        json_t *js = run_modes(&CASES[c]), *st = json_object_get(js, "static_deflection");
        json_t *rows = json_object_get(st, "shape");
        gather(o.mesh, n, rows, o.U);
        matvec(o.K, o.U, n, o.KU);
        double r[n];
        for (int i = 0; i < n; i++)
            r[i] = o.KU[i] - o.an->model->F_gravity[i];
        assert_true(norm(r, n) <= 1e-10 * norm(o.an->model->F_gravity, n));
        int p = (int)json_integer_value(
            json_object_get(json_object_get(js, "shape_mesh"), "platform_node"));
        json_t *err = json_object_get(js, "static_error");
        for (int k = 0; k < 6; k++)
            assert_true(json_real_value(json_array_get(json_array_get(rows, p), k)) ==
                        json_real_value(json_array_get(err, k)));
        json_decref(js);
        oracle_free(&o);
    }
}

/* Line lengths: the arm's elements add up to la, each rod's to lb, each
 * short bar is d, the platform's spokes are |r e_i + d t_i|; every node is
 * on some line and the platform node is at P. */
static void drawn_robot_has_the_robots_lengths(void **state)
{
    (void)state;
    oracle o;
    oracle_make(&CASES[1], &o);
    const dm_shape_mesh *m = o.mesh;
    double sum[4] = {0};
    int used[256] = {0}, count[4] = {0};
    assert_true(m->nnodes <= 256);
    for (int l = 0; l < m->nlines; l++) {
        const double *a = m->xyz_m + 3 * m->line[2 * l], *b = m->xyz_m + 3 * m->line[2 * l + 1];
        double d[3];
        dm_sub3(b, a, d);
        sum[m->line_kind[l]] += dm_norm3(d);
        count[m->line_kind[l]]++;
        used[m->line[2 * l]] = used[m->line[2 * l + 1]] = 1;
    }
    for (int j = 0; j < m->nnodes; j++)
        assert_true(used[j]);
    assert_int_equal(count[DM_LINE_ARM], 3 * m->na);
    assert_int_equal(count[DM_LINE_ROD], 6 * m->nb);
    assert_int_equal(count[DM_LINE_SHORT_BAR], 6);
    assert_int_equal(count[DM_LINE_PLATFORM], 12);
    assert_rel(sum[DM_LINE_ARM], 3 * o.rb.arm_length_m, 1e-12, "arm lengths");
    assert_rel(sum[DM_LINE_ROD], 6 * o.rb.rod_length_m, 1e-9, "rod lengths (kinematics' tolerance)");
    assert_rel(sum[DM_LINE_SHORT_BAR], 6 * o.rb.rod_half_spacing_m, 1e-12, "short bars");
    const double *P = m->xyz_m + 3 * dm_shape_platform_node(m);
    for (int k = 0; k < 3; k++)
        assert_true(P[k] == o.res.pose.P[k]);
    oracle_free(&o);
}

int main(int argc, char **argv)
{
    (void)argc;
    /* BLAS on one thread, as `deltamap modes` runs it: the same arithmetic,
     * so the same basis of a degenerate pair (chen2018's home pose has
     * two) as the solver's vector the JSON is compared with */
    dm_threads_serial_blas();
    /* $DELTAMAP when set (an emulator's wrapper: tools/test-arm64.sh),
     * else the deltamap built beside this test */
    char self[1024];
    const char *env = getenv("DELTAMAP");
    snprintf(self, sizeof self, "%s", argv[0]);
    if (env && *env)
        snprintf(deltamap, sizeof deltamap, "%s", env);
    else
        snprintf(deltamap, sizeof deltamap, "%s/../deltamap", dirname(self));
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(modes_json_shapes_solve_the_eigenproblem),
        cmocka_unit_test(static_deflection_is_the_static_error),
        cmocka_unit_test(drawn_robot_has_the_robots_lengths),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
