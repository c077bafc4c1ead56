// SPDX-License-Identifier: MIT
/*
 * fixq.c - the out-of-line operations of the Q5.26 fixed-point scalar type
 * (ik/scalar.h): division, square roots, reciprocals, sin/cos and atan2.
 * Compiled for every type like the rest of the core; only the fixed build
 * has anything in it.
 *
 * Everything here is integer arithmetic, so the results are the same bits
 * on every machine. Trig works in Q1.31 (a 32 x 32 -> 64 bit product per
 * step, which Cortex-M3/M4 do in one SMULL) and rounds once to Q5.26 at
 * the end; the argument reduction works in Q6.56. No table, no floating
 * point, no libc.
 */
/* with SC_FIXQ_OUTLINE on ARMv6-M this file holds the one copy of sc_sat and sc_abs (scalar.h) */
#define SC_FIXQ_DEFINE_SMALL
#include "ik/scalar.h"

#if SC_TYPE == SC_FIXQ

#ifdef SC_FIXQ_STATS
unsigned long sc_saturations;
#endif

#define Q31_ONE ((int64_t)1 << 31)

#if SC_FIXQ_OUTLINE
/* (noinline: under link-time optimisation as well, one call per use is what makes them small) */
__attribute__((noinline)) sc_t sc_acc_get(sc_acc_t s)
{
	return sc_acc_get_inline(s);
}

__attribute__((noinline)) sc_t sc_mul(sc_t a, sc_t b)
{
	return sc_acc_get((sc_acc_t)a * b);
}

__attribute__((noinline)) sc_acc_t sc_mac(sc_acc_t s, sc_t a, sc_t b)
{
	return sc_mac_inline(s, a, b);
}

__attribute__((noinline)) sc_t sc_mul_int(sc_t a, int n)
{
	return sc_sat((int64_t)a * n);
}

__attribute__((noinline)) sc_acc_t sc_msb(sc_acc_t s, sc_t a, sc_t b)
{
	return -sc_mac(-s, a, b);
}
#endif

/* a b in Q1.31, rounded half up */
/* one copy on a core that calls a helper for the product anyway (smaller) */
#if defined(__ARM_ARCH_6M__)
__attribute__((noinline)) static int64_t mul31(int64_t a, int64_t b)
#else
static inline int64_t mul31(int64_t a, int64_t b)
#endif
{
	return (a * b + ((int64_t)1 << 30)) >> 31;
}

/* k[0] + z (k[1] + z (... k[n - 1])) in Q1.31 */
static int64_t horner31(int64_t z, const int32_t *k, int n)
{
	int64_t t = k[--n];

	while (n--)
		t = k[n] + mul31(z, t);
	return t;
}

/* Q1.31 -> Q5.26, rounded half up; |v| < 2^36 */
static inline sc_t q31_to_q26(int64_t v)
{
	return (sc_t)((v + 16) >> 5);
}

/*
 * n / d for a quotient that fits 32 bits ((n >> 32) < d), and the
 * remainder; every division of the back end is one of these. A Cortex-M0
 * has no divider, and libgcc's general 64-bit division would add about
 * 900 bytes to its image: there it is a restoring division, one quotient
 * bit per turn. Elsewhere the compiler's (hardware-assisted) division. The
 * quotient is exact either way.
 */
static uint32_t udiv64_32(uint64_t n, uint32_t d, uint32_t *rem)
{
#if defined(__ARM_ARCH_6M__)
	uint32_t r = (uint32_t)(n >> 32), q = (uint32_t)n;
	int i;

	for (i = 0; i < 32; i++) {
		uint32_t carry = r >> 31;

		r = r << 1 | q >> 31;
		q <<= 1;
		if (carry || r >= d) {
			r -= d;
			q |= 1;
		}
	}
	*rem = r;
	return q;
#else
	uint64_t q = n / d;

	*rem = (uint32_t)(n - q * d);
	return (uint32_t)q;
#endif
}

static uint32_t mag(sc_t a)
{
	return a < 0 ? (uint32_t)0 - (uint32_t)a : (uint32_t)a;
}

/* |n| / d rounded half away from zero, signed by neg, saturating */
static sc_t div_round(uint64_t n, uint32_t d, bool neg)
{
	uint32_t q, r;

	if ((n >> 32) >= d) {
		SC_FIXQ_SATURATED();
		return neg ? INT32_MIN : INT32_MAX;
	}
	q = udiv64_32(n, d, &r);
	if (r >= d - r) {
		if (q == UINT32_MAX) {
			SC_FIXQ_SATURATED();
			return neg ? INT32_MIN : INT32_MAX;
		}
		q++;
	}
	return sc_sat(neg ? -(int64_t)q : (int64_t)q);
}

sc_t sc_div(sc_t a, sc_t b)
{
	if (b == 0) {
		if (a == 0)
			return 0;
		SC_FIXQ_SATURATED();
		return a > 0 ? INT32_MAX : INT32_MIN;
	}
	return div_round((uint64_t)mag(a) << SC_FRAC, mag(b), (a < 0) != (b < 0));
}

sc_t sc_div_int(sc_t a, int n)
{
	return div_round(mag(a), n < 0 ? (uint32_t)0 - (uint32_t)n : (uint32_t)n, (a < 0) != (n < 0));
}

/* floor(sqrt(v)) and the remainder v - root^2, bit by bit (no multiplier needed) */
static uint64_t isqrt64(uint64_t v, uint64_t *rem)
{
	uint64_t root = 0, bit = (uint64_t)1 << 62;

	while (bit > v)
		bit >>= 2;
	while (bit) {
		if (v >= root + bit) {
			v -= root + bit;
			root = (root >> 1) + bit;
		} else {
			root >>= 1;
		}
		bit >>= 2;
	}
	*rem = v;
	return root;
}

/* sqrt of a Q(2F) integer as a Q(F) integer, rounded to nearest: (r + 1/2)^2 = r^2 + r + 1/4 */
static sc_t sqrt_q52(uint64_t v)
{
	uint64_t rem, r = isqrt64(v, &rem);

	if (rem > r)
		r++;
	return sc_sat((int64_t)r);
}

sc_t sc_acc_sqrt(sc_acc_t s)
{
	return s > 0 ? sqrt_q52((uint64_t)s) : 0;
}

sc_t sc_sqrt(sc_t a)
{
	return a > 0 ? sqrt_q52((uint64_t)a << SC_FRAC) : 0;
}

/*
 * 1/|n| = m 2^-(32 + b) with b the position of n's leading bit and
 * m = floor((2^63 - 1) / (|n| 2^(31 - b))) in [2^31, 2^32): relative error
 * below 2^-31. Then a / n in Q5.26 is a m 2^-(6 + b). n == 0 gives m = 0.
 */
sc_recip_t sc_recip(sc_t n)
{
	sc_recip_t r = { 0, 1, n < 0 };
	uint32_t u = mag(n), rem;
	int b;

	if (!u)
		return r;
	b = 31 - __builtin_clz(u);
	r.m = udiv64_32((uint64_t)INT64_MAX, u << (31 - b), &rem);
	r.shift = (uint8_t)(6 + b);
	return r;
}

sc_t sc_mul_recip(sc_t a, sc_recip_t r)
{
	/* on magnitudes: |a| m < 2^63, and rounding half away from zero keeps a / -n = -(a / n) */
	uint64_t p = (a < 0 ? (uint64_t)0 - (uint64_t)(int64_t)a : (uint64_t)a) * r.m;

	p = (p + ((uint64_t)1 << (r.shift - 1))) >> r.shift;
	if (p > INT32_MAX) {
		SC_FIXQ_SATURATED();
		p = INT32_MAX;
	}
	return (a < 0) != r.neg ? -(sc_t)p : (sc_t)p;
}

/*
 * sin and cos. The angle is reduced by the nearest multiple n of pi/2 in
 * Q6.56 (pi/2 to 57 bits: exact far below the result's precision for any
 * representable angle), leaving r in [-pi/4, pi/4] as Q1.31. There the
 * Taylor series to r^11 (sin) and r^12 (cos) are within 1e-11; Horner in
 * Q1.31 adds a few 2^-31, so each result is within 0.6 ulp of Q5.26.
 */
#define PIO2_Q56 INT64_C(113187804032455044)
#define TWO_OVER_PI_Q32 INT64_C(2734261102)

void sc_sincos(sc_t a, sc_t *s, sc_t *c)
{
	static const int32_t sin_k[5] = { -357913941, 17895697, -426088, 5918, -54 };	     /* -1/3!, 1/5!, ... */
	static const int32_t cos_k[6] = { -1073741824, 89478485, -2982616, 53261, -592, 4 }; /* -1/2!, 1/4!, ... */
	int64_t n = ((int64_t)a * TWO_OVER_PI_Q32 + ((int64_t)1 << 57)) >> 58;
	int64_t r56 = (int64_t)a * ((int64_t)1 << 30) - n * PIO2_Q56;
	int64_t x = (r56 + ((int64_t)1 << 24)) >> 25, z = mul31(x, x), ps, pc, t;
	unsigned q = (unsigned)n;

	t = horner31(z, sin_k, 5);
	ps = x + mul31(x, mul31(z, t));
	t = horner31(z, cos_k, 6);
	pc = Q31_ONE + mul31(z, t);
	/* quadrant q: (s, c) = (ps, pc), (pc, -ps), (-ps, -pc), (-pc, ps) */
	{
		sc_t vs = q31_to_q26(q & 1u ? pc : ps), vc = q31_to_q26(q & 1u ? ps : pc);

		*s = q & 2u ? -vs : vs;
		*c = (q + 1u) & 2u ? -vc : vc;
	}
}

/*
 * atan of t in [0, 1] (Q1.31): one reduction by pi/6 brings t below
 * tan(pi/12) = 0.268, where the odd series to t^15 is within 1e-11.
 */
static int64_t atan_unit31(int64_t t)
{
	static const int32_t k[7] = {
		-715827883, 429496730, -306783378, 238609294, -195225786, 165191050, -143165577
	}; /* -1/3, 1/5, ... -1/15 */
	const int64_t sqrt3 = INT64_C(3719550787), tan_pi12 = INT64_C(575416509), pi6 = INT64_C(1124419809);
	int64_t off = 0, z, p;

	if (t > tan_pi12) {
		/* atan t = pi/6 + atan((sqrt3 t - 1) / (sqrt3 + t)); den / 2 fits 32 bits, |num| < den */
		int64_t num = mul31(sqrt3, t) - Q31_ONE, den = sqrt3 + t;
		uint32_t rem, q = udiv64_32((uint64_t)(num < 0 ? -num : num) << 30, (uint32_t)(den >> 1), &rem);

		t = num < 0 ? -(int64_t)q : (int64_t)q;
		off = pi6;
	}
	z = mul31(t, t);
	p = horner31(z, k, 7);
	return off + t + mul31(t, mul31(z, p));
}

sc_t sc_atan2(sc_t y, sc_t x)
{
	const int64_t pi = INT64_C(6746518852), half_pi = INT64_C(3373259426); /* Q1.31 */
	uint32_t ax = mag(x), ay = mag(y), rem;
	int64_t a;
	sc_t v;

	if (!ax && !ay)
		return 0;
	/* the ratio of the smaller to the larger, in Q1.31, rounded to nearest */
	if (ay <= ax)
		a = atan_unit31(udiv64_32(((uint64_t)ay << 31) + ax / 2, ax, &rem));
	else
		a = half_pi - atan_unit31(udiv64_32(((uint64_t)ax << 31) + ay / 2, ay, &rem));
	if (x < 0)
		a = pi - a;
	v = q31_to_q26(a);
	return y < 0 ? -v : v;
}

#else
/* the floating-point types need nothing from here (ISO C wants a declaration) */
typedef int sc_fixq_unused;
#endif
