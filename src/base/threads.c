/* Thread counts of the parallel stages (see dm_threads.h). */
#include "dm_threads.h"

#include <cblas.h>
#include <omp.h>

int dm_threads_count(int requested)
{
    return requested > 0 ? requested : omp_get_max_threads();
}

dm_threads_saved dm_threads_serial_blas(void)
{
    dm_threads_saved s = {omp_get_max_threads(), openblas_get_num_threads(), 0};
    if (omp_in_parallel())
        return s; /* BLAS is serial in an active region already; the setting is process-wide */
    s.changed = 1;
    openblas_set_num_threads(1);
    omp_set_num_threads(1);
    return s;
}

void dm_threads_restore(dm_threads_saved s)
{
    if (!s.changed)
        return;
    omp_set_num_threads(s.omp);
    openblas_set_num_threads(s.blas);
}
