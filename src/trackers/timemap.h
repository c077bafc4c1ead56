/* SPDX-License-Identifier: MIT */
/*
 * timemap.h - a remote clock's timestamps on our clock (the vrpn and dtrack
 * sources: docs/TRACKERS.md, "Sample times").
 *
 * Each report carries the sender's time s and arrives at our time a
 * (CLOCK_REALTIME). a - s is the clocks' offset plus the report's delay;
 * its smallest value over the last two to four seconds is the offset plus
 * the least delay, and s + that minimum is the report's time on our clock:
 * never after its arrival, steady while the delay jitters, following a
 * slow drift of either clock. A step of either clock by more than a
 * second starts the estimate again.
 */
#ifndef AGW_TIMEMAP_H
#define AGW_TIMEMAP_H

#include <stdbool.h>
#include <stdint.h>

#define TIMEMAP_BLOCK_NS 2000000000ll /* the minimum is kept per block of 2 s, over the last two */
#define TIMEMAP_STEP_NS 1000000000ll

struct timemap {
	bool have;
	int64_t cur, prev;    /* smallest a - s of this block and of the one before */
	uint64_t block_start; /* a at this block's start */
	int64_t offset;	      /* the estimate used last (a - s, ns) */
};

static inline void timemap_reset(struct timemap *m)
{
	m->have = false;
}

/* the report's time on our clock */
static inline uint64_t timemap_map(struct timemap *m, uint64_t src_ns, uint64_t arrival_ns)
{
	int64_t d = (int64_t)(arrival_ns - src_ns), est;

	if (m->have && (d - m->offset > TIMEMAP_STEP_NS || m->offset - d > TIMEMAP_STEP_NS))
		m->have = false; /* a clock stepped */
	if (!m->have) {
		m->have = true;
		m->cur = m->prev = d;
		m->block_start = arrival_ns;
	} else if ((int64_t)(arrival_ns - m->block_start) > TIMEMAP_BLOCK_NS) {
		m->prev = m->cur;
		m->cur = d;
		m->block_start = arrival_ns;
	} else if (d < m->cur) {
		m->cur = d;
	}
	est = m->cur < m->prev ? m->cur : m->prev;
	m->offset = est;
	return src_ns + (uint64_t)est;
}

#endif /* AGW_TIMEMAP_H */
