// SPDX-License-Identifier: MIT
/*
 * fake_alloc.c - counts the allocations of one thread (see fake.h): the
 * test's own thread plays the loop, the device threads and the fakes
 * allocate as they please.
 */
#include "fake/fake.h"

#include <stdlib.h>

void *__real_malloc(size_t n);
void *__real_calloc(size_t n, size_t m);
void *__real_realloc(void *p, size_t n);
void __real_free(void *p);
void *__wrap_malloc(size_t n);
void *__wrap_calloc(size_t n, size_t m);
void *__wrap_realloc(void *p, size_t n);
void __wrap_free(void *p);

static _Thread_local int counting;
static _Thread_local long allocs;

void *__wrap_malloc(size_t n)
{
	allocs += counting;
	return __real_malloc(n);
}

void *__wrap_calloc(size_t n, size_t m)
{
	allocs += counting;
	return __real_calloc(n, m);
}

void *__wrap_realloc(void *p, size_t n)
{
	allocs += counting;
	return __real_realloc(p, n);
}

void __wrap_free(void *p)
{
	allocs += counting && p;
	__real_free(p);
}

void fake_alloc_count_start(void)
{
	allocs = 0;
	counting = 1;
}

long fake_alloc_count_stop(void)
{
	counting = 0;
	return allocs;
}
