// SPDX-License-Identifier: MIT
/*
 * agree.c - forward kinematics through the core build of this translation
 * unit's scalar type, with double in and out, so that one test can hold the
 * float build against the double one. Compiled once per type: agree_fk_d and
 * agree_fk_f.
 */
#include "ik/arm.h"

void SCN(agree_fk)(int left, const double dims[4], const double q[ARM_DOF], double out[7]);

/* out = px, py, pz, qw, qx, qy, qz of the end effector */
void SCN(agree_fk)(int left, const double dims[4], const double q[ARM_DOF], double out[7])
{
	struct arm_dims d = { sc_from_double(dims[0]), sc_from_double(dims[1]), sc_from_double(dims[2]),
			      sc_from_double(dims[3]) };
	sc_t qs[ARM_DOF];
	struct arm a;
	struct dq ee;
	struct vec3 p;
	int i;

	arm_init(&a, left ? ARM_LEFT : ARM_RIGHT, &d, NULL);
	for (i = 0; i < ARM_DOF; i++)
		qs[i] = sc_from_double(q[i]);
	arm_fk(&a, qs, &ee);
	dq_translation(&ee, &p);
	out[0] = sc_to_double(p.x);
	out[1] = sc_to_double(p.y);
	out[2] = sc_to_double(p.z);
	out[3] = sc_to_double(ee.r.w);
	out[4] = sc_to_double(ee.r.x);
	out[5] = sc_to_double(ee.r.y);
	out[6] = sc_to_double(ee.r.z);
}
