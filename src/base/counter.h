/* SPDX-License-Identifier: MIT */
/*
 * counter.h - the counters of the loop and device threads: relaxed atomics
 * with one writer, read by the control thread at any time. The writer adds
 * with a relaxed load and store (no locked instruction); a reader sees each
 * counter whole, if not the newest value.
 */
#ifndef AGW_COUNTER_H
#define AGW_COUNTER_H

#include <stdatomic.h>
#include <stdint.h>

/* one writer only: the thread that owns the counter */
static inline void ctr_add(_Atomic uint64_t *c, uint64_t n)
{
	atomic_store_explicit(c, atomic_load_explicit(c, memory_order_relaxed) + n, memory_order_relaxed);
}

static inline uint64_t ctr_get(const _Atomic uint64_t *c)
{
	return atomic_load_explicit((_Atomic uint64_t *)c, memory_order_relaxed);
}

#endif /* AGW_COUNTER_H */
