/* dm_threads — how many threads a parallel stage uses, and BLAS kept on
 * one thread inside it. The one place thread counts are chosen: stages
 * pass the count to their own `num_threads` clauses; what is process-wide
 * (OpenBLAS's and OpenMP's defaults) is changed only for a stage and
 * restored after it.
 *
 * Why BLAS on one thread: the stages parallelise over poses, tiles or
 * candidate fits, each thread with its own workspaces; BLAS threads inside
 * them would oversubscribe the cores, and on matrices of 48-430 rows spin
 * more than they compute. Results never depend on either count. */
#ifndef DM_THREADS_H
#define DM_THREADS_H

/* requested > 0: that many; else OpenMP's default (OMP_NUM_THREADS, or the
 * cores). */
int dm_threads_count(int requested);

typedef struct dm_threads_saved {
    int omp, blas, changed;
} dm_threads_saved;

/* BLAS (and OpenMP outside parallel regions, from which OpenBLAS's OpenMP
 * build takes its count) on one thread until dm_threads_restore. Inside
 * an active parallel region it changes nothing (BLAS runs serially there,
 * and the setting is process-wide). Every library stage that runs threads
 * of its own calls it: OpenBLAS threads its kernels outside active
 * regions, one stage thread is not an active region, and threaded kernels
 * round differently, so one thread and several would disagree. */
dm_threads_saved dm_threads_serial_blas(void);
void dm_threads_restore(dm_threads_saved saved);

#endif
