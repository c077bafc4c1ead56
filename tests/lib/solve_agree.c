// SPDX-License-Identifier: MIT
/*
 * solve_agree.c - one IK solve, or the closed-form search alone, through
 * plain doubles, built once per scalar type (solve_agree_d, solve_agree_f,
 * swivel_agree_q, ...) so a test can compare the builds.
 */
#include "ik/ik.h"

/* a right arm of these dimensions, the default options, the target (p, r), in this build's type */
static void setup(const double dims[4], const double p[3], const double r[4], struct arm *a, struct ik_opts *o,
		  struct ik_target *t)
{
	struct arm_dims d = { sc_from_double(dims[0]), sc_from_double(dims[1]), sc_from_double(dims[2]),
			      sc_from_double(dims[3]) };
	struct vec3 pp = { sc_from_double(p[0]), sc_from_double(p[1]), sc_from_double(p[2]) };
	struct quat rr = { sc_from_double(r[0]), sc_from_double(r[1]), sc_from_double(r[2]), sc_from_double(r[3]) };

	arm_init(a, ARM_RIGHT, &d, NULL);
	ik_default_opts(o);
	ik_target_set(t, &pp, &rr);
}

unsigned SCN(solve_agree)(const double dims[4], const double p[3], const double r[4], double q_out[ARM_DOF],
			  double fk_out[7]);

unsigned SCN(solve_agree)(const double dims[4], const double p[3], const double r[4], double q_out[ARM_DOF],
			  double fk_out[7])
{
	struct arm a;
	struct ik_opts o;
	struct ik_target t;
	struct ik_result res;
	struct dq fk;
	struct vec3 pc;
	sc_t q[ARM_DOF];
	int i;

	setup(dims, p, r, &a, &o, &t);
	ik_solve(&a, &ik_kin_dq, &t, NULL, &o, q, &res);
	arm_fk(&a, q, &fk);
	dq_translation(&fk, &pc);
	for (i = 0; i < ARM_DOF; i++)
		q_out[i] = sc_to_double(q[i]);
	fk_out[0] = sc_to_double(pc.x);
	fk_out[1] = sc_to_double(pc.y);
	fk_out[2] = sc_to_double(pc.z);
	fk_out[3] = sc_to_double(fk.r.w);
	fk_out[4] = sc_to_double(fk.r.x);
	fk_out[5] = sc_to_double(fk.r.y);
	fk_out[6] = sc_to_double(fk.r.z);
	return res.flags;
}

bool SCN(swivel_agree)(const double dims[4], const double p[3], const double r[4], double q_out[ARM_DOF],
		       double *outside);

/*
 * The closed-form search alone (ik_swivel_solve from the rest posture, the
 * default options): returns its verdict, true for a posture inside the
 * limits, and writes that posture in q_out and in *outside how far it lies
 * outside the limits as this type holds them (radians; 0 inside).
 */
bool SCN(swivel_agree)(const double dims[4], const double p[3], const double r[4], double q_out[ARM_DOF],
		       double *outside)
{
	struct arm a;
	struct ik_opts o;
	struct ik_target t;
	sc_t rest[ARM_DOF], q[ARM_DOF];
	double m = 0;
	bool found;
	int evals, i;

	setup(dims, p, r, &a, &o, &t);
	ik_rest_posture(&a, rest);
	found = ik_swivel_solve(&a, &t, rest, &o, q, &evals);
	for (i = 0; i < ARM_DOF; i++) {
		double v = sc_to_double(q[i]), lo = sc_to_double(a.lim.lo[i]), hi = sc_to_double(a.lim.hi[i]);

		q_out[i] = v;
		if (v < lo && lo - v > m)
			m = lo - v;
		if (v > hi && v - hi > m)
			m = v - hi;
	}
	*outside = m;
	return found;
}
