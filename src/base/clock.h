/* SPDX-License-Identifier: MIT */
/*
 * clock.h - the daemon's two clocks in nanoseconds: CLOCK_MONOTONIC for
 * deadlines, ages and latencies; CLOCK_REALTIME for sample times on the wire
 * and in recordings.
 */
#ifndef AGW_CLOCK_H
#define AGW_CLOCK_H

#include <stdint.h>
#include <time.h>

static inline uint64_t ts_ns(const struct timespec *ts)
{
	return (uint64_t)ts->tv_sec * 1000000000ull + (uint64_t)ts->tv_nsec;
}

static inline uint64_t mono_ns(void)
{
	struct timespec ts;

	clock_gettime(CLOCK_MONOTONIC, &ts);
	return ts_ns(&ts);
}

static inline uint64_t real_ns(void)
{
	struct timespec ts;

	clock_gettime(CLOCK_REALTIME, &ts);
	return ts_ns(&ts);
}

#endif /* AGW_CLOCK_H */
