/* SPDX-License-Identifier: MIT */
/*
 * testutil.h - what several tests share: a deterministic random generator
 * (xorshift64*, one state per test program) and a tolerance assertion that
 * names its context. Include after <cmocka.h>, <math.h> and <stdio.h>.
 */
#ifndef AVATARGW_TESTUTIL_H
#define AVATARGW_TESTUTIL_H

#include <stdint.h>

static uint64_t rng_state;

static inline void rng_seed(uint64_t s)
{
	rng_state = s * 0x9e3779b97f4a7c15ull + 0x2545f4914f6cdd1dull;
	if (!rng_state)
		rng_state = 1;
}

/* uniform in [0, 1) */
static inline double rnd(void)
{
	rng_state ^= rng_state >> 12;
	rng_state ^= rng_state << 25;
	rng_state ^= rng_state >> 27;
	return (double)((rng_state * 0x2545f4914f6cdd1dull) >> 11) * (1.0 / 9007199254740992.0);
}

static inline double rnd_range(double lo, double hi)
{
	return lo + (hi - lo) * rnd();
}

/* what the failing check was looking at, printed with it */
static char ctx[200];

#define set_ctx(...) snprintf(ctx, sizeof(ctx), __VA_ARGS__)

#define assert_near(got, want, tol)                                                                                    \
	do {                                                                                                           \
		double g_ = (got), w_ = (want), t_ = (tol);                                                            \
		if (!(fabs(g_ - w_) <= t_))                                                                            \
			fail_msg("%s: %s = %.17g, want %s = %.17g (diff %.3g, tol %.3g)", ctx, #got, g_, #want, w_,    \
				 fabs(g_ - w_), t_);                                                                   \
	} while (0)

#define assert_v3_near(a, b, tol)                                                                                      \
	do {                                                                                                           \
		assert_near((a).x, (b).x, (tol));                                                                      \
		assert_near((a).y, (b).y, (tol));                                                                      \
		assert_near((a).z, (b).z, (tol));                                                                      \
	} while (0)

#define assert_quat_near(a, b, tol)                                                                                    \
	do {                                                                                                           \
		assert_near((a).w, (b).w, (tol));                                                                      \
		assert_near((a).x, (b).x, (tol));                                                                      \
		assert_near((a).y, (b).y, (tol));                                                                      \
		assert_near((a).z, (b).z, (tol));                                                                      \
	} while (0)

#endif /* AVATARGW_TESTUTIL_H */
