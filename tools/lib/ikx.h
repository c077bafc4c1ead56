/* SPDX-License-Identifier: MIT */
/*
 * ikx.h - the IK core of one scalar type, called with doubles: what the
 * tools and tests that compare the double, float and Q5.26 builds need.
 * tools/lib/ikx.c is compiled once per type (ikx_solve_d, ikx_solve_f,
 * ikx_solve_q, ...); every value crosses as a double (sc_from_double and
 * sc_to_double at the edge), so the caller sees the rounding of the type.
 */
#ifndef IKX_H
#define IKX_H

#include <stdbool.h>

#define IKX_DOF 8

struct ikx_setup {
	double dims[4]; /* S, A, F, H, metres */
	int left;	/* 0: right arm */
	int matrix;	/* 0: dual-quaternion kinematics, 1: 4x4 matrices */
	int newton;	/* 0: avatargw's solver, 1: the paper's Newton (no limits, plain step, 100 iterations) */
	bool limits;	/* false: the default limits; true: lo, hi below (radians) */
	double lo[IKX_DOF], hi[IKX_DOF];
};

struct ikx_result {
	unsigned flags; /* IK_* */
	int iters, evals;
	double err_pos, err_rot; /* the solver's own final errors */
};

#define IKX_DECLARE(s)                                                                                                 \
	void ikx_fk##s(const struct ikx_setup *o, const double q[IKX_DOF], double out[7]);                             \
	void ikx_jacobian##s(const struct ikx_setup *o, const double q[IKX_DOF], double J[6][IKX_DOF]);                \
	int ikx_lsq##s(const double J[6][IKX_DOF], const double V[6], const bool *free, double x[IKX_DOF]);            \
	unsigned ikx_solve##s(const struct ikx_setup *o, const double p[3], const double r[4], const double *seed,     \
			      double q[IKX_DOF], struct ikx_result *res);                                              \
	const char *ikx_name##s(void);                                                                                 \
	void ikx_limits##s(const struct ikx_setup *o, double lo[IKX_DOF], double hi[IKX_DOF]);

/* out = px, py, pz, qw, qx, qy, qz of the end effector */
/* seed NULL: a reset (the rest posture, or q = 0 for the paper's Newton) */
/* ikx_limits: the joint limits as this type holds them (rounded), radians */
IKX_DECLARE(_d)
IKX_DECLARE(_f)
IKX_DECLARE(_q)

#endif /* IKX_H */
