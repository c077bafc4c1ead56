/* SPDX-License-Identifier: MIT */
/*
 * clock.h - the daemon's two clocks in nanoseconds: CLOCK_MONOTONIC for
 * deadlines, ages and latencies; CLOCK_REALTIME for sample times on the wire
 * and in recordings.
 */
#ifndef AGW_CLOCK_H
#define AGW_CLOCK_H

#include <stdint.h>
#include <sys/timerfd.h>
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

/*
 * A non-blocking timerfd on CLOCK_MONOTONIC that expires every period_ns
 * (100 us at least), the first time one period from now: what an event-mode
 * loop waits on for a source that has no descriptor of its own. -1 if the
 * kernel refuses one.
 */
static inline int periodic_timerfd(uint64_t period_ns)
{
	int fd = timerfd_create(CLOCK_MONOTONIC, TFD_NONBLOCK | TFD_CLOEXEC);
	struct itimerspec its;

	if (period_ns < 100000)
		period_ns = 100000;
	its.it_interval.tv_sec = (time_t)(period_ns / 1000000000ull);
	its.it_interval.tv_nsec = (long)(period_ns % 1000000000ull);
	its.it_value = its.it_interval;
	if (fd >= 0)
		timerfd_settime(fd, 0, &its, NULL);
	return fd;
}

#endif /* AGW_CLOCK_H */
