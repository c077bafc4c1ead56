/* SPDX-License-Identifier: MIT */
/* ik_private.h - helpers shared by the kinematics backends; not installed. */
#ifndef IK_PRIVATE_H
#define IK_PRIVATE_H

#include "ik/arm.h"

/*
 * Fully unrolls the loop that follows (and, once its bounds are constant,
 * the loops inside it) where the compiler knows the pragma: the 6x6 and 6x8
 * kernels of the least-squares step are a third shorter and faster that way.
 * Elsewhere it is nothing; -funroll-loops for the whole core is slower.
 */
#if defined(__clang__) || (defined(__GNUC__) && __GNUC__ >= 8)
#define IK_UNROLL _Pragma("GCC unroll 8")
#else
#define IK_UNROLL
#endif

/* the posture src into dst */
static inline void ik_q_copy(sc_t dst[ARM_DOF], const sc_t src[ARM_DOF])
{
	for (int i = 0; i < ARM_DOF; i++)
		dst[i] = src[i];
}

/* every joint of q inside its limits and in [-pi, pi) (false for NaN): what arm_clamp leaves alone */
static inline bool ik_q_inside(const struct arm *a, const sc_t q[ARM_DOF])
{
	for (int i = 0; i < ARM_DOF; i++)
		if (!(q[i] >= a->lim.lo[i] && q[i] <= a->lim.hi[i] && q[i] >= -SC_PI && q[i] < SC_PI))
			return false;
	return true;
}

/* how far v lies outside [lo, hi], 0 inside */
static inline sc_t ik_violation(sc_t v, sc_t lo, sc_t hi)
{
	return v < lo ? lo - v : (v > hi ? v - hi : SC_C(0));
}

/* (a^T b)[i][j] for row-major 3x3 matrices */
static inline sc_t ik_m3_tdot(const sc_t a[3][3], const sc_t b[3][3], int i, int j)
{
	return sc_acc_get(sc_mac(sc_mac(sc_mac(sc_acc0(), a[0][i], b[0][j]), a[1][i], b[1][j]), a[2][i], b[2][j]));
}

/*
 * sc_wrap_pi of an angle in [0, 2 pi] (one from atan2 plus or minus pi):
 * the same value in one comparison (NaN stays NaN: the callers' ranking
 * chooses the same branch either way)
 */
static inline sc_t ik_wrap_0_2pi(sc_t x)
{
	return x >= SC_PI ? x - 2 * SC_PI : x;
}

/*
 * M = Ry(a) Rx(b) Rz(c): both angle triples, the one inside the limits
 * [i0, i0+2] chosen (else the one violating them least). Returns the
 * violation in radians.
 */
static inline sc_t ik_euler_yxz(const sc_t m[3][3], const struct arm_limits *lim, int i0, sc_t out[3])
{
#if IK_COMPACT
	sc_t e[2][3], v[2] = { 0, 0 };
	int k, br;

	e[0][0] = sc_atan2(m[0][2], m[2][2]);
	e[0][1] = sc_asin(-m[1][2]);
	e[0][2] = sc_atan2(m[1][0], m[1][1]);
	e[1][0] = sc_wrap_pi(e[0][0] + SC_PI);
	e[1][1] = sc_wrap_pi(SC_PI - e[0][1]);
	e[1][2] = sc_wrap_pi(e[0][2] + SC_PI);
	for (br = 0; br < 2; br++)
		for (k = 0; k < 3; k++)
			v[br] += ik_violation(e[br][k], lim->lo[i0 + k], lim->hi[i0 + k]);
	br = v[1] < v[0];
	for (k = 0; k < 3; k++)
		out[k] = e[br][k];
	return v[br];
#else
	const sc_t *lo = &lim->lo[i0], *hi = &lim->hi[i0];
	sc_t b = sc_asin(-m[1][2]), a = sc_atan2(m[0][2], m[2][2]), c = sc_atan2(m[1][0], m[1][1]);
	sc_t v0 = ik_violation(a, lo[0], hi[0]) + ik_violation(b, lo[1], hi[1]) + ik_violation(c, lo[2], hi[2]), a1, b1,
	     c1, v1;

	if (v0 == 0) {
		/* inside: the other triple cannot violate less */
		out[0] = a, out[1] = b, out[2] = c;
		return v0;
	}
	a1 = ik_wrap_0_2pi(a + SC_PI), b1 = ik_wrap_0_2pi(SC_PI - b), c1 = ik_wrap_0_2pi(c + SC_PI);
	v1 = ik_violation(a1, lo[0], hi[0]) + ik_violation(b1, lo[1], hi[1]) + ik_violation(c1, lo[2], hi[2]);
	if (v1 < v0) {
		out[0] = a1, out[1] = b1, out[2] = c1;
		return v1;
	}
	out[0] = a, out[1] = b, out[2] = c;
	return v0;
#endif
}

/* p + k u */
static inline void ik_add_scaled(const struct vec3 *p, sc_t k, const struct vec3 *u, struct vec3 *out)
{
	out->x = p->x + sc_mul(k, u->x);
	out->y = p->y + sc_mul(k, u->y);
	out->z = p->z + sc_mul(k, u->z);
}

/* Jacobian column i: the joint's line (l, p x l), l = sgn u */
static inline void ik_jac_col(sc_t J[6][ARM_DOF], int i, const struct vec3 *p, sc_t sgn, const struct vec3 *u)
{
	struct vec3 l = { sc_mul(sgn, u->x), sc_mul(sgn, u->y), sc_mul(sgn, u->z) }, m;

	v3_cross(p, &l, &m);
	J[0][i] = l.x;
	J[1][i] = l.y;
	J[2][i] = l.z;
	J[3][i] = m.x;
	J[4][i] = m.y;
	J[5][i] = m.z;
}

/*
 * (1 - x cot x) / (4 x^2): the coefficient of [w]^2 in the inverse of the
 * SE(3) left Jacobian at rotation angle 2x; s = sin x, c = cos x.
 */
static inline sc_t ik_log_k(sc_t x, sc_t s, sc_t c)
{
	sc_t x2 = sc_mul(x, x);

	if (x < SC_C(0.05)) {
		/* series: 1/12 + x^2/180 + x^4/1890 + x^6/18900 (next term below 1e-16 here) */
		sc_t p = SC_C(1.0 / 18900);

		p = sc_mul(p, x2) + SC_C(1.0 / 1890);
		p = sc_mul(p, x2) + SC_C(1.0 / 180);
		return sc_mul(p, x2) + SC_C(1.0 / 12);
	}
	return sc_div(SC_C(1) - sc_div(sc_mul(x, c), s), 4 * x2);
}

/*
 * The frames of the chain in rotation-and-origin form: k[i] = (r[i], p[i]),
 * the frame reached by joints 1..i with their translations (r[0] = 1,
 * p[0] = 0, r[8], p[8] the end effector). This is the dual quaternion
 * r + eps 1/2 p r with its dual part kept as the translation: a joint turns
 * about a coordinate axis and moves along one, so its product is sparse, and
 * the Jacobian needs the origins anyway.
 */
struct arm_chain {
	struct quat r[ARM_DOF + 1];
	struct vec3 p[ARM_DOF + 1];
};

#define arm_chain_eval SCN(arm_chain_eval)
#define arm_chain_jacobian SCN(arm_chain_jacobian)
#define dq_log_twist_rt SCN(dq_log_twist_rt)

/*
 * Forward kinematics of a (built by arm_init: axes z y x z x y x z, each +-1
 * on its coordinate, translations along x, z, y, y after J1, J4, J5, J8) and,
 * if J is not NULL, the spatial Jacobian of arm_jacobian.
 */
void arm_chain_eval(const struct arm *a, const sc_t q[ARM_DOF], struct arm_chain *c, sc_t J[6][ARM_DOF]);
#define arm_chain_pose SCN(arm_chain_pose)
/* the segment poses of a chain (what arm_fk_pose gives) */
void arm_chain_pose(const struct arm_chain *c, struct arm_pose *out);
/* the Jacobian of a chain arm_chain_eval computed (with J NULL) */
void arm_chain_jacobian(const struct arm *a, const struct arm_chain *c, sc_t J[6][ARM_DOF]);
/*
 * dq_log_twist of the transform x' = R x + t given as its rotation r (unit)
 * and translation t; writes half the rotation angle, in [0, pi/2], to
 * half_angle.
 */
void dq_log_twist_rt(const struct quat *r, const struct vec3 *t, struct twist *out, sc_t *half_angle);

/*
 * atan2(s, c) for s >= 0, c > 0: half the angle of a rotation quaternion from
 * the norm s of its vector part and its scalar part c. Below s/c = 1e-3 (every
 * Newton step near convergence) the series u (1 - u^2/3 + u^4/5), u = s/c,
 * whose next term is below 1e-21 u; g receives 1 - u^2/3 + u^4/5 = x / u there
 * and 0 otherwise.
 */
#if DQ_OUTLINE && !defined(DQ_DEFINE_OUTLINE)
/* one copy, in dq.c (see dq.h) */
#define ik_half_angle SCN(ik_half_angle)
sc_t ik_half_angle(sc_t s, sc_t c, sc_t *ic, sc_t *g);
#else
#if DQ_OUTLINE
#define ik_half_angle SCN(ik_half_angle)
#endif
DQ_SMALL sc_t ik_half_angle(sc_t s, sc_t c, sc_t *ic, sc_t *g)
{
	if (s < sc_mul(SC_C(1e-3), c)) {
		sc_t u, u2;

		*ic = sc_div(SC_C(1), c);
		u = sc_mul(s, *ic);
		u2 = sc_mul(u, u);
		*g = SC_C(1) - sc_mul(u2, SC_C(1.0 / 3) - sc_mul(u2, SC_C(0.2)));
		return sc_mul(u, *g);
	}
	*ic = 0;
	*g = 0;
	return sc_atan2(s, c);
}
#endif

#endif /* IK_PRIVATE_H */
