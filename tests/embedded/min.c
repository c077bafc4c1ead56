// SPDX-License-Identifier: MIT
/*
 * min.c - the smallest firmware that solves an arm, to measure what the IK
 * core adds to an image (tools/embedded-report.sh): built with IKT_MIN_SOLVE
 * (avatargw's solver, ik_solve: limits, closed-form search, Newton), with
 * IKT_MIN_NEWTON (the paper's Newton iteration alone, ik_newton) and with
 * neither (the same start-up and I/O, no solver); the differences in code
 * size are the solver's. Inputs and outputs are volatile so that nothing is
 * folded away. Runs once under QEMU and exits.
 */
#include "ik/ik.h"
#include "ikt.h"

volatile sc_t ikt_min_in[7] = { SC_C(0.18), SC_C(0.34), SC_C(-0.30), SC_C(1), 0, 0, 0 };
volatile sc_t ikt_min_out[ARM_DOF + 1];

int ikt_run(void)
{
#if defined(IKT_MIN_SOLVE) || defined(IKT_MIN_NEWTON)
	static const struct arm_dims dims = { SC_C(0.18), SC_C(0.30), SC_C(0.26), SC_C(0.08) };
	struct vec3 p = { ikt_min_in[0], ikt_min_in[1], ikt_min_in[2] };
	struct quat r = { ikt_min_in[3], ikt_min_in[4], ikt_min_in[5], ikt_min_in[6] };
	sc_t q[ARM_DOF] = { 0 };
	struct arm a;
	struct ik_opts o;
	struct ik_target t;
	struct ik_result res;
	int i;

	arm_init(&a, ARM_RIGHT, &dims, NULL);
	ik_default_opts(&o);
	ik_target_set(&t, &p, &r);
#ifdef IKT_MIN_SOLVE
	ik_solve(&a, &ik_kin_dq, &t, NULL, &o, q, &res);
#else
	ik_newton(&a, &ik_kin_dq, &t, q, &o, q, &res);
#endif
	for (i = 0; i < ARM_DOF; i++)
		ikt_min_out[i] = q[i];
	ikt_min_out[ARM_DOF] = (sc_t)res.flags;
	return !(res.flags & IK_REACHED);
#else
	int i;

	/* no "i % 7": a signed division would link libgcc's __divsi3 (0.5 kB) into this image alone */
	for (i = 0; i < ARM_DOF; i++)
		ikt_min_out[i] = ikt_min_in[i < 7 ? i : i - 7];
	return 0;
#endif
}
