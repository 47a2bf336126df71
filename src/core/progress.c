/* core — the progress hook (ffd_set_progress): long operations report the
 * fraction done of each stage to an optional caller function, at most about
 * 20 times a second, from the calling (master) thread only. The library
 * itself never draws anything. */
#include "core.h"

#ifdef _OPENMP
#include <omp.h>
#endif

/* Like the allocator, set once by the host before it calls the library. */
static ffd_progress_fn g_progress_fn;
static void *g_progress_user;

#define PROGRESS_INTERVAL 0.05 /* seconds between two reports of one stage */

void ffd_set_progress(ffd_progress_fn fn, void *user)
{
    g_progress_fn = fn;
    g_progress_user = fn ? user : NULL;
}

/* Only the thread that is not a worker of an OpenMP team reports: a call
 * from inside a parallel loop on another thread is dropped. */
static int reporting_thread(void)
{
#ifdef _OPENMP
    return omp_get_thread_num() == 0;
#else
    return 1;
#endif
}

void ffd_progress_begin(ffd_progress *p, const char *stage)
{
    p->stage = stage;
    p->fraction = 0;
    p->last_time = ffd_now();
    if (g_progress_fn && reporting_thread())
        g_progress_fn(g_progress_user, stage, 0.0);
}

void ffd_progress_update(ffd_progress *p, double fraction)
{
    if (!g_progress_fn || !reporting_thread())
        return;
    if (!(fraction > p->fraction)) /* monotone; also drops NaN */
        return;
    if (fraction >= 1)
        fraction = 1 - 1e-9; /* 1 is said once, by ffd_progress_end */
    double now = ffd_now();
    if (now - p->last_time < PROGRESS_INTERVAL)
        return;
    p->fraction = fraction;
    p->last_time = now;
    g_progress_fn(g_progress_user, p->stage, fraction);
}

void ffd_progress_end(ffd_progress *p)
{
    p->fraction = 1;
    if (g_progress_fn && reporting_thread())
        g_progress_fn(g_progress_user, p->stage, 1.0);
}
