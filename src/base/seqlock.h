/* SPDX-License-Identifier: MIT */
/*
 * seqlock.h - a sequence lock for one writer that must never wait (the loop
 * thread, or a device thread) and readers that retry instead: a snapshot
 * handed between threads without a mutex and without allocating.
 *
 * The protected data is an array of _Atomic uint32_t words read and written
 * with relaxed atomics, so a torn read is detected (by the sequence number)
 * rather than being a data race.
 *
 *	writer:  seqlock_write(&seq, words, src, n)
 *	reader:  seqlock_read(&seq, words, dst, n)   (returns the sequence read; may wait)
 *	loop:    seqlock_try_read(&seq, words, dst, n, &s)   (never waits)
 */
#ifndef AGW_SEQLOCK_H
#define AGW_SEQLOCK_H

#include <sched.h>
#include <stdbool.h>
#include <stdatomic.h>
#include <stdint.h>

static inline void seqlock_write(_Atomic uint32_t *seq, _Atomic uint32_t *words, const uint32_t *src, int n)
{
	uint32_t s = atomic_load_explicit(seq, memory_order_relaxed);

	atomic_store_explicit(seq, s + 1, memory_order_relaxed);
	atomic_thread_fence(memory_order_release);
	for (int i = 0; i < n; i++)
		atomic_store_explicit(&words[i], src[i], memory_order_relaxed);
	atomic_store_explicit(seq, s + 2, memory_order_release);
}

/* a consistent copy of the words; returns the (even) sequence number it belongs to */
static inline uint32_t seqlock_read(_Atomic uint32_t *seq, _Atomic uint32_t *words, uint32_t *dst, int n)
{
	for (int tries = 0;; tries++) {
		uint32_t s1 = atomic_load_explicit(seq, memory_order_acquire);

		if (!(s1 & 1)) {
			for (int i = 0; i < n; i++)
				dst[i] = atomic_load_explicit(&words[i], memory_order_relaxed);
			atomic_thread_fence(memory_order_acquire);
			if (atomic_load_explicit(seq, memory_order_relaxed) == s1)
				return s1;
		}
		/* the writer is inside (a few hundred ns); after a few spins let it run */
		if (tries > 16)
			sched_yield();
	}
}

/*
 * One attempt, for a reader that must never wait (the loop thread): true
 * with a consistent copy and its sequence number, false while the writer
 * is inside (keep the previous data and try at the next cycle). A SCHED_FIFO
 * loop spinning on a normal-priority writer pinned to its CPU would never
 * let the writer finish.
 */
static inline bool seqlock_try_read(_Atomic uint32_t *seq, _Atomic uint32_t *words, uint32_t *dst, int n,
				    uint32_t *seq_out)
{
	uint32_t s1 = atomic_load_explicit(seq, memory_order_acquire);

	if (s1 & 1)
		return false;
	for (int i = 0; i < n; i++)
		dst[i] = atomic_load_explicit(&words[i], memory_order_relaxed);
	atomic_thread_fence(memory_order_acquire);
	if (atomic_load_explicit(seq, memory_order_relaxed) != s1)
		return false;
	*seq_out = s1;
	return true;
}

/* the sequence number only (has anything been written since?) */
static inline uint32_t seqlock_peek(_Atomic uint32_t *seq)
{
	return atomic_load_explicit(seq, memory_order_acquire);
}

#endif /* AGW_SEQLOCK_H */
