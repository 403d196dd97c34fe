/*
 * rt_assert.h -- contracts checked at run time in checking builds.
 *
 * RT_ASSERT(cond) states an invariant that an essay at the top of a file
 * numbers (the recorder's buffer bound, a queue's links, a stack's depth).
 * It is a statement about the program, not about its input: bad input is
 * reported through rt_err like any other failure, never through RT_ASSERT.
 *
 * Builds: configure --enable-sanitizers or --enable-debug turns the checks
 * on (RT_ASSERTS is defined to 1 in config.h); --enable-asserts and
 * --disable-asserts choose explicitly. Otherwise RT_ASSERT compiles away:
 * the condition is not evaluated (it must have no side effects), only
 * type-checked through sizeof, so release builds pay nothing and variables
 * used only in a contract raise no warning.
 *
 * A failed check is a bug in raytraffic: it writes one line naming the
 * file, line, function and condition to stderr and aborts, so that a
 * sanitizer build stops at the first broken contract with a core or a
 * stack trace. This is the library's only write to stderr; it happens
 * only when the program is already wrong.
 */
#ifndef RT_ASSERT_H
#define RT_ASSERT_H

#include "config.h"

#if defined(RT_ASSERTS) && RT_ASSERTS
#include <stdio.h>
#include <stdlib.h>

#if defined(__GNUC__)
__attribute__((noreturn, cold))
#endif
static inline void
rt_assert_fail(const char *cond, const char *file, int line, const char *func)
{
    fprintf(stderr, "%s:%d: %s: contract broken: %s\n", file, line, func, cond);
    fflush(stderr);
    abort();
}

#define RT_ASSERT(cond) ((cond) ? (void)0 : rt_assert_fail(#cond, __FILE__, __LINE__, __func__))
#define RT_ASSERTS_ON 1
#else
#define RT_ASSERT(cond) ((void)sizeof((cond) ? 1 : 0))
#define RT_ASSERTS_ON 0
#endif

#endif
