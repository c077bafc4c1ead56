/* SPDX-License-Identifier: MIT */
/*
 * hist.h - latency histograms written by the loop thread (one writer,
 * relaxed atomics, no locked instructions) and read by the control thread
 * at any time.
 *
 * Histogram buckets: 1 us wide below 128 us, then 16 per power of two up
 * to ~1 s; a percentile is the upper edge of its bucket (at most 1/16 = 6 %
 * above the true value past 128 us).
 */
#ifndef AGW_HIST_H
#define AGW_HIST_H

#include <stdatomic.h>
#include <stdint.h>

#define HIST_LINEAR 128
#define HIST_SUB 16
#define HIST_OCTAVES 13
#define HIST_BUCKETS (HIST_LINEAR + HIST_SUB * HIST_OCTAVES)

struct hist {
	_Atomic uint32_t b[HIST_BUCKETS];
	_Atomic uint64_t n;
	_Atomic uint64_t max_ns;
};

void hist_add(struct hist *h, uint64_t ns);
/* p in [0, 1]: the value in ns below which that fraction lies (0 if empty) */
uint64_t hist_percentile(const struct hist *h, double p);

#endif /* AGW_HIST_H */
