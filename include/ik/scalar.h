/* SPDX-License-Identifier: MIT */
/*
 * scalar.h - the one scalar type of an IK core build.
 *
 * Every source of the IK core is compiled once per scalar type, chosen with
 * -DSC_TYPE=SC_DOUBLE (default), SC_FLOAT or SC_FIXQ (int32 Q5.26 fixed
 * point: value = raw / 2^26, range [-32, 32), resolution 1.5e-8; see
 * docs/EMBEDDED.md). Generic code never touches the representation:
 *   - constants go through SC_C(1.5) (compile-time constants only: in fixed
 *     point it is folded by the compiler); run-time integers through
 *     sc_from_int(), sc_mul_int() and sc_div_int();
 *   - products, quotients, roots and trig go through sc_mul(), sc_div(),
 *     sc_sqrt(), sc_sincos(), sc_atan2();
 *   - dot products go through an accumulator (sc_acc0/sc_mac/sc_acc_get) so
 *     the fixed back end accumulates in int64 and rounds once; a norm is
 *     sc_acc_sqrt() of the accumulator, so that small norms keep their bits;
 *   - a normalisation divides by a norm through sc_recip()/sc_mul_recip(),
 *     because 1/n need not be representable in fixed point;
 *   - +, -, unary minus, comparisons and integer multiples (2 * x) are
 *     allowed on sc_t directly: they are exact on a Q-format int32 too, and
 *     the core keeps its quantities small enough that they cannot overflow
 *     (unit quaternions, metres of an arm, radians; see docs/EMBEDDED.md).
 * SCN(name) appends the type suffix (_d, _f, _q) so several builds of the
 * core link into one binary.
 */
#ifndef IK_SCALAR_H
#define IK_SCALAR_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#define SC_DOUBLE 1
#define SC_FLOAT 2
#define SC_FIXQ 3

#ifndef SC_TYPE
#define SC_TYPE SC_DOUBLE
#endif

#define SC_CAT_(a, b) a##b
#define SC_CAT(a, b) SC_CAT_(a, b)

#if SC_TYPE == SC_DOUBLE
typedef double sc_t;
typedef double sc_acc_t;
#define SC_SUFFIX _d
#define SC_C(x) ((double)(x))
#define SC_NAME "double"
/* smallest step worth taking and the solver's default tolerances */
#define SC_EPS SC_C(1e-12)
#define SC_TOL_POS SC_C(1e-7)
#define SC_TOL_ROT SC_C(1e-7)
/* the IK's least squares use the normal equations when cond(J J^T) provably stays below this */
#define SC_NE_COND SC_C(1e10)
#define sc_builtin_sqrt __builtin_sqrt
#define sc_builtin_sin __builtin_sin
#define sc_builtin_cos __builtin_cos
#define sc_builtin_atan2 __builtin_atan2
#define sc_builtin_fabs __builtin_fabs
#elif SC_TYPE == SC_FLOAT
typedef float sc_t;
typedef float sc_acc_t;
#define SC_SUFFIX _f
#define SC_C(x) ((float)(x))
#define SC_NAME "float"
#define SC_EPS SC_C(1e-6)
#define SC_TOL_POS SC_C(2e-6)
#define SC_TOL_ROT SC_C(4e-6)
/* float: the normal equations would keep too few bits; always the QR */
#define SC_NE_COND SC_C(0)
#define sc_builtin_sqrt __builtin_sqrtf
#define sc_builtin_sin __builtin_sinf
#define sc_builtin_cos __builtin_cosf
#define sc_builtin_atan2 __builtin_atan2f
#define sc_builtin_fabs __builtin_fabsf
#elif SC_TYPE == SC_FIXQ
/* Q5.26; a sum of products is Q11.52, rounded once by sc_acc_get */
typedef int32_t sc_t;
typedef int64_t sc_acc_t;
#ifndef SC_SUFFIX
#define SC_SUFFIX _q
#endif
#define SC_FRAC 26
/* rounds half away from zero; a constant argument folds to an integer at compile time */
#define SC_C(x) ((sc_t)((x)*67108864.0 + ((x) < 0 ? -0.5 : 0.5)))
#define SC_NAME "Q5.26"
/* one unit in the last place */
#define SC_EPS ((sc_t)1)
/*
 * The tolerances sit above the floor that rounding leaves in the
 * kinematics (forward kinematics through 8 joints: up to 0.18 um and
 * 0.19 urad, measured) so that Newton stops there instead of running to its
 * cap, and far enough below the goals (1 um and 0.001 deg = 17 urad of the
 * double solution) that a solve within them meets them. docs/EMBEDDED.md.
 */
#define SC_TOL_POS SC_C(3e-7)
#define SC_TOL_ROT SC_C(1e-6)
/* the normal equations square cond(J): too few bits; always the QR */
#define SC_NE_COND SC_C(0)
#else
#error "SC_TYPE: SC_DOUBLE, SC_FLOAT or SC_FIXQ"
#endif

#define SCN(name) SC_CAT(name, SC_SUFFIX)

#define SC_PI SC_C(3.14159265358979323846)
#define SC_HALF_PI SC_C(1.57079632679489661923)

#if SC_TYPE != SC_FIXQ
/* larger than any value the solver ranks (limit violations, distances): "none yet" */
#define SC_BIG SC_C(1e3)
/* a Newton step larger than this (radians) is scaled down even without max_step (0: never) */
#define SC_STEP_CAP SC_C(0)
/* targets farther than this (metres) are pulled in along their direction (0: never) */
#define SC_REACH_MAX SC_C(0)
/* inputs with a component beyond this are scaled down before their norm is taken (0: never) */
#define SC_SQ_SAFE SC_C(0)

static inline sc_t sc_mul(sc_t a, sc_t b)
{
	return a * b;
}

/* a / b; callers guarantee b != 0 */
static inline sc_t sc_div(sc_t a, sc_t b)
{
	return a / b;
}

static inline sc_t sc_abs(sc_t a)
{
	return sc_builtin_fabs(a);
}

/* sqrt of a non-negative value; negative input (rounding) gives 0 */
static inline sc_t sc_sqrt(sc_t a)
{
	return a > 0 ? sc_builtin_sqrt(a) : SC_C(0);
}

/*
 * sin and cos together. For |a| <= 8 (every joint angle and half angle): one
 * reduction by the nearest multiple of pi/2 (pi/2 in three parts, exact far
 * below the result's precision), then minimax polynomials on [-pi/4, pi/4]:
 * sin r = r + r^3 P(r^2), cos r = 1 - r^2/2 + r^4 Q(r^2) with the rounding of
 * 1 - r^2/2 carried (coefficients by Remez exchange in 60-digit arithmetic;
 * approximation errors 2^-58 and 2^-64 in double, 2^-28 and 2^-33 in float;
 * measured against long double: under 0.8 ulp on [-pi/4, pi/4], under 1.5
 * ulp after reduction). The quadrant is applied without branches. The
 * kinematics take 8 per evaluation; libm's sincos costs more, and results no
 * longer depend on the libm at hand. Larger and non-finite angles: libm.
 */
#if SC_TYPE == SC_DOUBLE
/* 1.5 * 2^52: x + this rounds x to an integer k held in the low bits (k mod 4 in the lowest two) */
#define SC_RND_MAGIC 6755399441055744.0
typedef uint64_t sc_bits_t;
#else
#define SC_RND_MAGIC 12582912.0f /* 1.5 * 2^23 */
typedef uint32_t sc_bits_t;
#endif

/*
 * The reduction and the polynomials of sc_sincos, written once for the
 * scalar and the vector form (the same operations in the same order: the
 * same bits): the nearest multiple of pi/2, its count k in y's low bits (n)
 * and as a value (fn); then sin and cos of the remainder r in ps and pc.
 */
#if SC_TYPE == SC_DOUBLE
#define SC_SINCOS_POLY(a, y, fn, n, r, z, p, q, ps, pc, hz, w)                                                         \
	do {                                                                                                           \
		y = a * SC_C(0.63661977236758134308) + SC_RND_MAGIC;                                                   \
		fn = y - SC_RND_MAGIC;                                                                                 \
		__builtin_memcpy(&n, &y, sizeof(n));                                                                   \
		r = ((a - fn * 1.5707963267341256) - fn * 6.077100506303966e-11) - fn * 2.0222662487959506e-21;        \
		z = r * r;                                                                                             \
		p = -2.5050747763608083e-08 + z * 1.589623019695111e-10;                                               \
		p = 2.755731362139104e-06 + z * p;                                                                     \
		p = -0.00019841269829589555 + z * p;                                                                   \
		p = 0.008333333333322118 + z * p;                                                                      \
		p = -0.1666666666666663 + z * p;                                                                       \
		q = 2.0875700841863214e-09 + z * -1.1358536519516824e-11;                                              \
		q = -2.7557314179295147e-07 + z * q;                                                                   \
		q = 2.4801587288851694e-05 + z * q;                                                                    \
		q = -0.0013888888888873056 + z * q;                                                                    \
		q = 0.041666666666666595 + z * q;                                                                      \
		ps = r + r * z * p;                                                                                    \
		hz = SC_C(0.5) * z;                                                                                    \
		w = SC_C(1) - hz;                                                                                      \
		pc = w + (((SC_C(1) - w) - hz) + z * z * q);                                                           \
	} while (0)
#else
#define SC_SINCOS_POLY(a, y, fn, n, r, z, p, q, ps, pc, hz, w)                                                         \
	do {                                                                                                           \
		y = a * SC_C(0.63661977236758134308) + SC_RND_MAGIC;                                                   \
		fn = y - SC_RND_MAGIC;                                                                                 \
		__builtin_memcpy(&n, &y, sizeof(n));                                                                   \
		r = ((a - fn * 1.5703125f) - fn * 4.837512969970703e-4f) - fn * 7.549789954891882e-08f;                \
		z = r * r;                                                                                             \
		p = 0.008332160762195971f + z * -0.0001951528322646598f;                                               \
		p = -0.16666654609555026f + z * p;                                                                     \
		q = -0.0013887316254782307f + z * 2.4433157107133406e-05f;                                             \
		q = 0.04166664568298217f + z * q;                                                                      \
		ps = r + r * z * p;                                                                                    \
		hz = SC_C(0.5) * z;                                                                                    \
		w = SC_C(1) - hz;                                                                                      \
		pc = w + (((SC_C(1) - w) - hz) + z * z * q);                                                           \
	} while (0)
#endif

static inline void sc_sincos(sc_t a, sc_t *s, sc_t *c)
{
	sc_t y, fn, r, z, p, q, ps, pc, hz, w, ts, tc;
	sc_bits_t n;

	if (!(a <= SC_C(8) && a >= SC_C(-8))) {
		*s = sc_builtin_sin(a);
		*c = sc_builtin_cos(a);
		return;
	}
	SC_SINCOS_POLY(a, y, fn, n, r, z, p, q, ps, pc, hz, w);
	/* quadrant n: (s, c) = (ps, pc), (pc, -ps), (-ps, -pc), (-pc, ps) */
	ts = n & 1u ? pc : ps;
	tc = n & 1u ? ps : pc;
	*s = n & 2u ? -ts : ts;
	*c = (n + 1u) & 2u ? -tc : tc;
}

#if defined(__GNUC__) && !defined(SC_NO_VECTOR) && (defined(__SSE2__) || defined(__ARM_NEON) || defined(__aarch64__))
/*
 * Four sc_sincos at once in GCC's generic vectors, where the machine has
 * vector registers (SSE2 and NEON: two doubles or four floats per
 * instruction; a Cortex-M would only get longer code): the
 * same operations in the same order, the quadrant by bit masks, so every lane
 * equals sc_sincos bit for bit. Callers check |a| <= 8 first.
 */
#define SC_VEC 1
typedef sc_t sc_v4 __attribute__((vector_size(4 * sizeof(sc_t))));
#if SC_TYPE == SC_DOUBLE
typedef int64_t sc_v4i __attribute__((vector_size(4 * sizeof(sc_t))));
#else
typedef int32_t sc_v4i __attribute__((vector_size(4 * sizeof(sc_t))));
#endif

static inline void sc_sincos_v4(const sc_v4 *pa, sc_v4 *s, sc_v4 *c)
{
	const int sign = 8 * (int)sizeof(sc_t) - 1;
	const sc_v4 a = *pa;
	sc_v4 y, fn, r, z, p, q, ps, pc, hz, w;
	sc_v4i n, odd, is, ic, ts, tc;

	SC_SINCOS_POLY(a, y, fn, n, r, z, p, q, ps, pc, hz, w);
	odd = -(n & 1);
	__builtin_memcpy(&is, &ps, sizeof(is));
	__builtin_memcpy(&ic, &pc, sizeof(ic));
	ts = (is & ~odd) | (ic & odd);
	tc = (ic & ~odd) | (is & odd);
	ts ^= (n & 2) << (sign - 1);
	tc ^= ((n + 1) & 2) << (sign - 1);
	__builtin_memcpy(s, &ts, sizeof(*s));
	__builtin_memcpy(c, &tc, sizeof(*c));
}
#endif

/* sc_sincos of eight angles (the chain's half angles), four at a time where the compiler vectorises */
static inline void sc_sincos8(const sc_t a[8], sc_t s[8], sc_t c[8])
{
	int i;
#ifdef SC_VEC
	sc_t m = 0;

	/*
	 * the largest |a[i]| (a NaN may be passed over: the polynomials give NaN
	 * for it as libm does, and an infinity is never passed over)
	 */
	for (i = 0; i < 8; i++) {
		sc_t v = sc_builtin_fabs(a[i]);

		m = v > m ? v : m;
	}
	if (m <= SC_C(8)) {
		for (i = 0; i < 8; i += 4) {
			sc_v4 va, vs, vc;

			__builtin_memcpy(&va, &a[i], sizeof(va));
			sc_sincos_v4(&va, &vs, &vc);
			__builtin_memcpy(&s[i], &vs, sizeof(vs));
			__builtin_memcpy(&c[i], &vc, sizeof(vc));
		}
		return;
	}
#endif
	for (i = 0; i < 8; i++)
		sc_sincos(a[i], &s[i], &c[i]);
}

/*
 * atan2 with one division: of |y| and |x| the smaller over the larger is
 * t in [0, 1]; beyond tan(pi/12) the argument is taken down by pi/6 in the
 * same quotient, (sqrt3 lo - hi) / (sqrt3 hi + lo) = tan(atan t - pi/6),
 * so |t| <= tan(pi/12) where the odd series to t^19 is accurate to 1e-13
 * (libm's atan2 costs several times more, and the IK's closed-form search
 * and the avatar's posture call it in their inner loops). The octant is
 * put back without branches on the value. atan2 in (-pi, pi];
 * atan2(0, 0) = 0.
 */
static inline sc_t sc_atan2(sc_t y, sc_t x)
{
	sc_t ax = sc_builtin_fabs(x), ay = sc_builtin_fabs(y), lo, hi, t, t2, nt2, p, a;
	bool steep = ay > ax, far;

	/* one test each for inf and NaN (the library's rules; also for sums past 1e300) and for (0, 0) */
	if (!(ax + ay < SC_C(1e300)))
		return sc_builtin_atan2(y, x);
	lo = steep ? ax : ay;
	hi = steep ? ay : ax;
	if (hi == 0)
		return 0;
	far = lo > SC_C(0.26794919243112270) * hi;
	t = far ? (SC_C(1.7320508075688772) * lo - hi) / (SC_C(1.7320508075688772) * hi + lo) : lo / hi;
	t2 = t * t;
	/*
	 * atan t = t - t^3 (1/3 - t^2 (1/5 - t^2 (1/7 - ...))); c - t^2 p
	 * written c + (-t^2) p, the same value, which needs no register for c
	 */
	nt2 = -t2;
	p = SC_C(1.0 / 19);
	p = SC_C(1.0 / 17) + nt2 * p;
	p = SC_C(1.0 / 15) + nt2 * p;
	p = SC_C(1.0 / 13) + nt2 * p;
	p = SC_C(1.0 / 11) + nt2 * p;
	p = SC_C(1.0 / 9) + nt2 * p;
	p = SC_C(1.0 / 7) + nt2 * p;
	p = SC_C(1.0 / 5) + nt2 * p;
	p = SC_C(1.0 / 3) + nt2 * p;
	a = (far ? SC_C(0.52359877559829887) : SC_C(0)) + (t - t * t2 * p);
	a = steep ? SC_HALF_PI - a : a;
	a = x < 0 ? SC_PI - a : a;
	return y < 0 ? -a : a;
}

/* false for NaN and +-inf (a fixed back end is always finite) */
static inline bool sc_isfinite(sc_t a)
{
	return __builtin_isfinite(a);
}

/* accumulators: one rounding per dot product in fixed point */
static inline sc_acc_t sc_acc0(void)
{
	return 0;
}

static inline sc_acc_t sc_mac(sc_acc_t s, sc_t a, sc_t b)
{
	return s + a * b;
}

static inline sc_acc_t sc_msb(sc_acc_t s, sc_t a, sc_t b)
{
	return s - a * b;
}

/* the sum of two partial accumulators (a dot product split in two shorter dependency chains) */
static inline sc_acc_t sc_acc_add(sc_acc_t a, sc_acc_t b)
{
	return a + b;
}

static inline sc_t sc_acc_get(sc_acc_t s)
{
	return s;
}

/* host-side conversions (tests, tools, the daemon) */
static inline sc_t sc_from_double(double x)
{
	return (sc_t)x;
}

static inline double sc_to_double(sc_t a)
{
	return (double)a;
}

static inline sc_t sc_from_int(int n)
{
	return (sc_t)n;
}

/* a n and a / n for an integer n (n != 0) */
static inline sc_t sc_mul_int(sc_t a, int n)
{
	return a * (sc_t)n;
}

static inline sc_t sc_div_int(sc_t a, int n)
{
	return a / (sc_t)n;
}

/* the square root of a sum of products: the norm of a vector */
static inline sc_t sc_acc_sqrt(sc_acc_t s)
{
	return sc_sqrt(s);
}

/* a / n for several a: one reciprocal, then products */
typedef struct {
	sc_t k;
} sc_recip_t;

static inline sc_recip_t sc_recip(sc_t n)
{
	sc_recip_t r = { SC_C(1) / n };

	return r;
}

static inline sc_t sc_mul_recip(sc_t a, sc_recip_t r)
{
	return a * r.k;
}

/* wrap an angle to [-pi, pi); non-finite or absurd (|a| > 1e6) input becomes 0 */
static inline sc_t sc_wrap_pi(sc_t a)
{
	if (!sc_isfinite(a) || a > SC_C(1e6) || a < SC_C(-1e6))
		return SC_C(0);
	if (a >= SC_PI || a < -SC_PI) {
		/* a - 2 pi floor((a + pi) / 2 pi) */
		sc_t n = (a + SC_PI) / (2 * SC_PI);
		long k = (long)n;

		if (n < 0 && (sc_t)k != n)
			k--;
		a -= (sc_t)k * (2 * SC_PI);
	}
	/* rounding at the edges */
	if (a >= SC_PI)
		a -= 2 * SC_PI;
	if (a < -SC_PI)
		a += 2 * SC_PI;
	return a;
}

#else /* SC_FIXQ */

/*
 * Fixed point: every quantity is int32 Q5.26. Products are exact in int64
 * and rounded once (half up); results that do not fit saturate to the
 * nearest representable value instead of wrapping. The quantities of the
 * core stay far inside the range (unit quaternions and rotation entries
 * <= 1, lengths of an arm < 2 m, Jacobian entries < 3, angles < 2 pi); a
 * saturation only happens on hopeless input (checked by the tests with a
 * counting build, SC_FIXQ_STATS). Trig, square roots and quotients are
 * out of line in src/ik/fixq.c and work at higher precision internally
 * (Q1.31 polynomials, 64-bit integer square root, 64/32 division), so each
 * result is within about 0.6 ulp of the exact value, and all of it is
 * integer arithmetic: the same bits on every machine.
 */
#define SC_BIG ((sc_t)INT32_MAX)
/*
 * Bounded steps and targets: q + x must stay representable, and the sum of
 * four squares must fit the accumulator (2^11), so input with a component
 * beyond 16 is scaled down before its norm is taken. The solver squares
 * distances (the law of cosines at the elbow), which must stay below 32 m^2,
 * and its error twist holds w x (w x t) with |w| <= pi: a target farther
 * than 2 m from the chest, out of any human arm's reach (the segments of a
 * fixed-point arm must add up to less than that), is pulled in to 2 m
 * along its direction, which is all that matters about it.
 */
#define SC_STEP_CAP SC_C(8)
#define SC_REACH_MAX SC_C(2)
#define SC_SQ_SAFE SC_C(16)

#ifdef SC_FIXQ_STATS
/* counting build (tests): how many results saturated */
#define sc_saturations SCN(sc_saturations)
extern unsigned long sc_saturations;
#define SC_FIXQ_SATURATED() ((void)sc_saturations++)
#else
#define SC_FIXQ_SATURATED() ((void)0)
#endif

#define sc_div SCN(sc_div)
#define sc_sqrt SCN(sc_sqrt)
#define sc_acc_sqrt SCN(sc_acc_sqrt)
#define sc_sincos SCN(sc_sincos)
#define sc_atan2 SCN(sc_atan2)
#define sc_recip SCN(sc_recip)
#define sc_mul_recip SCN(sc_mul_recip)

/* a / b rounded to nearest; b == 0 saturates toward the sign of a (0 / 0 = 0) */
sc_t sc_div(sc_t a, sc_t b);
/* sqrt of a non-negative value, rounded to nearest; negative input gives 0 */
sc_t sc_sqrt(sc_t a);
/* the square root of a Q11.52 sum (exact integer square root): a norm keeps every bit */
sc_t sc_acc_sqrt(sc_acc_t s);
/* sin and cos of any representable angle, each within 0.6 ulp */
void sc_sincos(sc_t a, sc_t *s, sc_t *c);

static inline void sc_sincos8(const sc_t a[8], sc_t s[8], sc_t c[8])
{
	for (int i = 0; i < 8; i++)
		sc_sincos(a[i], &s[i], &c[i]);
}
/* atan2 in [-pi, pi], within 0.6 ulp; atan2(0, 0) = 0; odd in y */
sc_t sc_atan2(sc_t y, sc_t x);

/* 1/n as a 32-bit mantissa and a shift: representable for every n != 0 */
typedef struct {
	uint32_t m;
	uint8_t shift;
	bool neg;
} sc_recip_t;

/* n != 0 (0 gives a reciprocal whose products are 0) */
sc_recip_t sc_recip(sc_t n);
/* a / n through the reciprocal: within 0.55 ulp when |a / n| <= 1, 1.5 ulp at most; saturates */
sc_t sc_mul_recip(sc_t a, sc_recip_t r);

/*
 * Where every product is a call (ARMv6-M, SC_FIXQ_OUTLINE below), the
 * saturation (a 64-bit compare: a dozen instructions there) and sc_abs are
 * one function each in fixq.c instead of inline code at every use.
 */
#if defined(__ARM_ARCH_6M__) && !defined(SC_FIXQ_DEFINE_SMALL)
#define sc_sat SCN(sc_sat)
#define sc_abs SCN(sc_abs)
sc_t sc_sat(int64_t v);
sc_t sc_abs(sc_t a);
#else
#if defined(__ARM_ARCH_6M__)
#define sc_sat SCN(sc_sat)
#define sc_abs SCN(sc_abs)
/* (and kept a call under link-time optimisation) */
#define SC_FIXQ_SMALL __attribute__((noinline))
#else
#define SC_FIXQ_SMALL static inline
#endif
SC_FIXQ_SMALL sc_t sc_sat(int64_t v)
{
	if (v > INT32_MAX) {
		SC_FIXQ_SATURATED();
		return INT32_MAX;
	}
	if (v < INT32_MIN) {
		SC_FIXQ_SATURATED();
		return INT32_MIN;
	}
	return (sc_t)v;
}

SC_FIXQ_SMALL sc_t sc_abs(sc_t a)
{
	return a >= 0 ? a : (a == INT32_MIN ? INT32_MAX : -a);
}
#endif

/* Q(2F) -> Q(F), rounding half up (GCC's >> on a negative int64 is arithmetic) */
static inline sc_t sc_acc_get_inline(sc_acc_t s)
{
	return sc_sat((s + ((sc_acc_t)1 << (SC_FRAC - 1))) >> SC_FRAC);
}

static inline sc_t sc_mul_inline(sc_t a, sc_t b)
{
	return sc_acc_get_inline((sc_acc_t)a * b);
}

static inline sc_acc_t sc_mac_inline(sc_acc_t s, sc_t a, sc_t b)
{
	return s + (sc_acc_t)a * b;
}

/*
 * A core without a 32 x 32 -> 64 multiply (ARMv6-M: Cortex-M0/M0+) calls a
 * helper for every product; there products, accumulation and rounding are
 * functions of their own (src/ik/fixq.c), so that each use is a call
 * instead of some 40 bytes of inline code. The results are the same bits.
 * SC_FIXQ_OUTLINE=0 or 1 overrides the choice.
 */
#ifndef SC_FIXQ_OUTLINE
#if defined(__ARM_ARCH_6M__)
#define SC_FIXQ_OUTLINE 1
#else
#define SC_FIXQ_OUTLINE 0
#endif
#endif

#if SC_FIXQ_OUTLINE
#define sc_acc_get SCN(sc_acc_get)
#define sc_mul SCN(sc_mul)
#define sc_mac SCN(sc_mac)
#define sc_msb SCN(sc_msb)
sc_t sc_acc_get(sc_acc_t s);
sc_t sc_mul(sc_t a, sc_t b);
sc_acc_t sc_mac(sc_acc_t s, sc_t a, sc_t b);
sc_acc_t sc_msb(sc_acc_t s, sc_t a, sc_t b);
#else
static inline sc_t sc_acc_get(sc_acc_t s)
{
	return sc_acc_get_inline(s);
}

static inline sc_t sc_mul(sc_t a, sc_t b)
{
	return sc_mul_inline(a, b);
}

static inline sc_acc_t sc_mac(sc_acc_t s, sc_t a, sc_t b)
{
	return sc_mac_inline(s, a, b);
}

static inline sc_acc_t sc_msb(sc_acc_t s, sc_t a, sc_t b)
{
	return s - (sc_acc_t)a * b;
}
#endif

static inline bool sc_isfinite(sc_t a)
{
	(void)a;
	return true;
}

static inline sc_acc_t sc_acc0(void)
{
	return 0;
}

static inline sc_acc_t sc_acc_add(sc_acc_t a, sc_acc_t b)
{
	return a + b;
}

/* saturates beyond [-32, 31] */
static inline sc_t sc_from_int(int n)
{
	return sc_sat((int64_t)n * ((int64_t)1 << SC_FRAC));
}

/* a n, saturating (a function where a 64-bit product is a call anyway) */
#if SC_FIXQ_OUTLINE
#define sc_mul_int SCN(sc_mul_int)
sc_t sc_mul_int(sc_t a, int n);
#else
static inline sc_t sc_mul_int(sc_t a, int n)
{
	return sc_sat((int64_t)a * n);
}
#endif

#define sc_div_int SCN(sc_div_int)
/* a / n rounded to nearest (half away from zero); n != 0 */
sc_t sc_div_int(sc_t a, int n);

#ifndef SC_NO_DOUBLE
/* host-side conversions (tests, tools): saturating, NaN gives 0; never in the core */
static inline sc_t sc_from_double(double x)
{
	double v = x * 67108864.0;

	if (!(v == v))
		return 0;
	if (v >= 2147483647.0)
		return INT32_MAX;
	if (v <= -2147483648.0)
		return INT32_MIN;
	return (sc_t)(v < 0 ? v - 0.5 : v + 0.5);
}

static inline double sc_to_double(sc_t a)
{
	return (double)a / 67108864.0;
}
#endif

/* wrap an angle to [-pi, pi): whole turns of the representable 2 pi, exactly */
static inline sc_t sc_wrap_pi(sc_t a)
{
	while (a >= SC_PI)
		a -= 2 * SC_PI;
	while (a < -SC_PI)
		a += 2 * SC_PI;
	return a;
}
#endif /* SC_TYPE */

static inline sc_t sc_min(sc_t a, sc_t b)
{
	return a < b ? a : b;
}

static inline sc_t sc_max(sc_t a, sc_t b)
{
	return a > b ? a : b;
}

static inline sc_t sc_clamp(sc_t a, sc_t lo, sc_t hi)
{
	return a < lo ? lo : (a > hi ? hi : a);
}

/* sin of a limit angle (setup work, not the inner loop) */
static inline sc_t sc_sin_lim(sc_t a)
{
	sc_t s, c;

	sc_sincos(a, &s, &c);
	return s;
}

/* asin and acos through atan2 and sqrt, so a fixed back end needs only those */
static inline sc_t sc_asin(sc_t x)
{
	x = sc_clamp(x, SC_C(-1), SC_C(1));
	return sc_atan2(x, sc_sqrt(SC_C(1) - sc_mul(x, x)));
}

static inline sc_t sc_acos(sc_t x)
{
	x = sc_clamp(x, SC_C(-1), SC_C(1));
	return sc_atan2(sc_sqrt(SC_C(1) - sc_mul(x, x)), x);
}

#endif /* IK_SCALAR_H */
