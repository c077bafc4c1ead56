// SPDX-License-Identifier: MIT
/*
 * hist.c - the latency histogram.
 */
#include "base/hist.h"

#include "base/counter.h"

static int bucket_of(uint64_t us)
{
	int oct = 0;
	uint64_t base = HIST_LINEAR;

	if (us < HIST_LINEAR)
		return (int)us;
	while (oct < HIST_OCTAVES - 1 && us >= 2 * base) {
		base *= 2;
		oct++;
	}
	if (us >= 2 * base)
		return HIST_BUCKETS - 1;
	return HIST_LINEAR + oct * HIST_SUB + (int)((us - base) * HIST_SUB / base);
}

/* the upper edge of a bucket, in us */
static uint64_t bucket_top(int b)
{
	uint64_t base = HIST_LINEAR;
	int oct, sub;

	if (b < HIST_LINEAR)
		return (uint64_t)b + 1;
	oct = (b - HIST_LINEAR) / HIST_SUB;
	sub = (b - HIST_LINEAR) % HIST_SUB;
	for (int i = 0; i < oct; i++)
		base *= 2;
	return base + base * (uint64_t)(sub + 1) / HIST_SUB;
}

void hist_add(struct hist *h, uint64_t ns)
{
	int b = bucket_of(ns / 1000);

	atomic_store_explicit(&h->b[b], atomic_load_explicit(&h->b[b], memory_order_relaxed) + 1, memory_order_relaxed);
	ctr_add(&h->n, 1);
	if (ns > atomic_load_explicit(&h->max_ns, memory_order_relaxed))
		atomic_store_explicit(&h->max_ns, ns, memory_order_relaxed);
}

uint64_t hist_percentile(const struct hist *h, double p)
{
	uint64_t total = 0, want, acc = 0;
	uint32_t c[HIST_BUCKETS];

	for (int i = 0; i < HIST_BUCKETS; i++) {
		c[i] = atomic_load_explicit((_Atomic uint32_t *)&h->b[i], memory_order_relaxed);
		total += c[i];
	}
	if (!total)
		return 0;
	want = (uint64_t)(p * (double)total + 0.5);
	if (want < 1)
		want = 1;
	for (int i = 0; i < HIST_BUCKETS; i++) {
		acc += c[i];
		if (acc >= want) {
			uint64_t top = bucket_top(i) * 1000;
			uint64_t mx = ctr_get(&h->max_ns);

			return top < mx || !mx ? top : mx;
		}
	}
	return ctr_get(&h->max_ns);
}
