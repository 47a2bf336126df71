/* Minimal test harness: each test is a static void function listed in a table. */
#ifndef FFD_TEST_CHECK_H
#define FFD_TEST_CHECK_H

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int check_failures;
static const char *check_current;

#define CHECK(cond)                                                                       \
    do {                                                                                  \
        if (!(cond)) {                                                                    \
            fprintf(stderr, "%s:%d: %s: CHECK failed: %s\n", __FILE__, __LINE__,          \
                    check_current, #cond);                                                \
            check_failures++;                                                             \
        }                                                                                 \
    } while (0)

#define CHECK_NEAR(a, b, tol)                                                             \
    do {                                                                                  \
        double check_a_ = (double)(a), check_b_ = (double)(b), check_t_ = (double)(tol);  \
        if (!(fabs(check_a_ - check_b_) <= check_t_)) {                                   \
            fprintf(stderr, "%s:%d: %s: CHECK_NEAR failed: %s = %.17g, %s = %.17g, "      \
                            "|diff| = %.3g > tol %.3g\n",                                 \
                    __FILE__, __LINE__, check_current, #a, check_a_, #b, check_b_,        \
                    fabs(check_a_ - check_b_), check_t_);                                 \
            check_failures++;                                                             \
        }                                                                                 \
    } while (0)

#define CHECK_OK(expr)                                                                    \
    do {                                                                                  \
        ffd_error check_err_ = {{0}};                                                     \
        (void)check_err_;                                                                 \
        ffd_status check_s_ = (expr);                                                     \
        if (check_s_ != FFD_OK) {                                                         \
            fprintf(stderr, "%s:%d: %s: %s returned %d\n", __FILE__, __LINE__,            \
                    check_current, #expr, (int)check_s_);                                 \
            check_failures++;                                                             \
        }                                                                                 \
    } while (0)

typedef struct {
    const char *name;
    void (*fn)(void);
} check_test;

/* Runs the tests whose name contains argv[1] (all when absent). */
static int check_run(const check_test *tests, size_t n, int argc, char **argv)
{
    size_t passed = 0, failed = 0;
    for (size_t i = 0; i < n; i++) {
        if (argc > 1 && !strstr(tests[i].name, argv[1]))
            continue;
        int before = check_failures;
        check_current = tests[i].name;
        tests[i].fn();
        if (check_failures == before) {
            passed++;
            printf("ok   %s\n", tests[i].name);
        } else {
            failed++;
            printf("FAIL %s\n", tests[i].name);
        }
    }
    printf("%zu passed, %zu failed\n", passed, failed);
    return failed ? 1 : 0;
}

/* Deterministic random numbers for tests (xorshift64*). */
static unsigned long long check_rng_state = 88172645463325252ull;
static inline double check_rand01(void)
{
    check_rng_state ^= check_rng_state >> 12;
    check_rng_state ^= check_rng_state << 25;
    check_rng_state ^= check_rng_state >> 27;
    return (double)((check_rng_state * 2685821657736338717ull) >> 11) * (1.0 / 9007199254740992.0);
}

/* The step of an allocation-failure sweep (for (k = 0;; k += check_sweep_step())):
 * every allocation normally; every 7th under valgrind (scripts/valgrind.sh sets
 * FFD_TEST_QUICK), where each failing run costs a hundred times more and the
 * release and ASan+LeakSanitizer builds still fail every allocation. */
static inline long check_sweep_step(void)
{
    return getenv("FFD_TEST_QUICK") ? 7 : 1;
}

/* An allocator (ffd_set_allocator) that fails after `left` successful
 * allocations (-1: never) and counts the calls, for the out-of-memory tests:
 *   fail_alloc fa = {k, 0};
 *   ffd_allocator a = {fa_malloc, fa_realloc, fa_free, &fa};  */
typedef struct check_fail_alloc {
    long left;
    long count;
} fail_alloc;

static inline void *fa_malloc(size_t n, void *u)
{
    fail_alloc *f = u;
    f->count++;
    if (f->left == 0)
        return NULL;
    if (f->left > 0)
        f->left--;
    return malloc(n);
}

static inline void *fa_realloc(void *p, size_t n, void *u)
{
    fail_alloc *f = u;
    f->count++;
    if (f->left == 0)
        return NULL;
    if (f->left > 0)
        f->left--;
    return realloc(p, n);
}

static inline void fa_free(void *p, void *u)
{
    (void)u;
    free(p);
}

#endif
