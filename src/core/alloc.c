/* core — the one place the library allocates (so tests can fail the N-th allocation).
 *
 * cJSON (rigs, the editor session) allocates through its process-wide hooks:
 * while an allocator is set they point here too (cJSON_InitHooks), so a
 * failing allocator fails cJSON's allocations as well, and cJSON memory and
 * ffd memory are interchangeable (cJSON_free == ffd_free). Without an
 * allocator the hooks are left alone (a host's own hooks are kept).
 * CHOLMOD is routed where it is used (the one file that includes it).
 * Qhull and LAPACK/OpenBLAS keep their own allocators (docs/reliability.md). */
#define _DEFAULT_SOURCE /* MADV_HUGEPAGE (Linux) */
#include "core.h"

#include <cjson/cJSON.h>
#include <sys/mman.h>

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

static ffd_allocator g_allocator; /* zero: the C library; set once by ffd_set_allocator */
static int g_json_hooked;         /* 1: cJSON's hooks point at ffd_malloc/ffd_free */
static _Thread_local unsigned long g_json_failures;

static void *json_malloc(size_t size)
{
    void *p = ffd_malloc(size);
    if (!p)
        g_json_failures++;
    return p;
}

void ffd_set_allocator(const ffd_allocator *allocator)
{
    if (allocator) {
        g_allocator = *allocator;
        cJSON_Hooks hooks = {json_malloc, ffd_free};
        cJSON_InitHooks(&hooks);
        g_json_hooked = 1;
    } else {
        memset(&g_allocator, 0, sizeof g_allocator);
        if (g_json_hooked)
            cJSON_InitHooks(NULL);
        g_json_hooked = 0;
    }
}

unsigned long ffd_json_alloc_failures(void)
{
    return g_json_failures;
}

/* Big arrays (mesh positions, spans, file bytes, bindings) are fresh memory
 * written once: at 4 KiB a page fault, 1M vertices cost ~20000 faults, which
 * on a virtual machine is most of a mesh read. Asking for transparent huge
 * pages (granted on request where /sys/kernel/mm/transparent_hugepage/enabled
 * is "madvise", Debian's default) makes that ~40 faults of 2 MiB. Advice
 * only: a failure is ignored and the contents are the same. */
void ffd_advise_huge(void *p, size_t bytes)
{
#if defined(MADV_HUGEPAGE)
    const size_t huge = (size_t)2 << 20;
    if (!p || bytes < 2 * huge)
        return;
    uintptr_t lo = ((uintptr_t)p + huge - 1) & ~(uintptr_t)(huge - 1);
    uintptr_t hi = ((uintptr_t)p + bytes) & ~(uintptr_t)(huge - 1);
    if (hi > lo)
        (void)madvise((void *)lo, hi - lo, MADV_HUGEPAGE);
#else
    (void)p;
    (void)bytes;
#endif
}

void *ffd_malloc(size_t size)
{
    if (size == 0)
        size = 1;
    if (g_allocator.malloc_fn)
        return g_allocator.malloc_fn(size, g_allocator.user);
    void *p = malloc(size);
    ffd_advise_huge(p, size);
    return p;
}

void *ffd_realloc(void *ptr, size_t size)
{
    if (size == 0)
        size = 1;
    if (g_allocator.realloc_fn)
        return g_allocator.realloc_fn(ptr, size, g_allocator.user);
    void *p = realloc(ptr, size);
    ffd_advise_huge(p, size);
    return p;
}

void ffd_free(void *ptr)
{
    if (!ptr)
        return;
    if (g_allocator.free_fn)
        g_allocator.free_fn(ptr, g_allocator.user);
    else
        free(ptr);
}

void *ffd_malloc_array(size_t count, size_t size)
{
    if (size && count > SIZE_MAX / size)
        return NULL;
    return ffd_malloc(count * size);
}

void *ffd_realloc_array(void *ptr, size_t count, size_t size)
{
    if (size && count > SIZE_MAX / size)
        return NULL;
    return ffd_realloc(ptr, count * size);
}

void *ffd_calloc(size_t count, size_t size)
{
    void *p = ffd_malloc_array(count, size);
    if (p)
        memset(p, 0, count * size);
    return p;
}

char *ffd_strdup(const char *s)
{
    if (!s)
        return NULL;
    size_t n = strlen(s) + 1;
    char *d = ffd_malloc(n);
    if (d)
        memcpy(d, s, n);
    return d;
}

bool ffd_grow(void **buf, size_t *cap, size_t need, size_t elem)
{
    if (need <= *cap)
        return true;
    size_t c = *cap ? *cap : 16;
    while (c < need) {
        if (c > SIZE_MAX / 2)
            return false;
        c *= 2;
    }
    void *p = ffd_realloc_array(*buf, c, elem);
    if (!p)
        return false;
    *buf = p;
    *cap = c;
    return true;
}
