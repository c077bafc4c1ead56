/* SPDX-License-Identifier: MIT */
/* ik_private.h - helpers shared by the kinematics backends; not installed. */
#ifndef IK_PRIVATE_H
#define IK_PRIVATE_H

#include "ik/scalar.h"

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

#endif /* IK_PRIVATE_H */
