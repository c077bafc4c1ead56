/* SPDX-License-Identifier: MIT */
/* ik_private.h - helpers shared by the kinematics backends; not installed. */
#ifndef IK_PRIVATE_H
#define IK_PRIVATE_H

#include "ik/arm.h"

/* for the few kernels that must be specialised at their call site (a constant size) */
#if defined(__GNUC__)
#define IK_ALWAYS_INLINE inline __attribute__((always_inline))
#else
#define IK_ALWAYS_INLINE inline
#endif

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
/* the Jacobian of a chain arm_chain_eval computed (with J NULL) */
void arm_chain_jacobian(const struct arm *a, const struct arm_chain *c, sc_t J[6][ARM_DOF]);
/*
 * dq_log_twist of the transform x' = R x + t given as its rotation r (unit)
 * and translation t; writes half the rotation angle, in [0, pi/2], to
 * half_angle.
 */
void dq_log_twist_rt(const struct quat *r, const struct vec3 *t, struct twist *out, sc_t *half_angle);

#endif /* IK_PRIVATE_H */
