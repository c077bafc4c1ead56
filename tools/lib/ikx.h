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
#include <stddef.h>

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

/* the whole avatar (ik/avatar.h): avatar_init with the default limits and model, ik_default_opts */
struct ikx_avatar_setup {
	double dims[4];	       /* S, A, F, H, metres (both arms) */
	double head_offset[3]; /* head sensor from the chest origin, chest frame, metres */
	unsigned options;      /* AVATAR_* options added to AVATAR_MODEL_DEFAULT */
	unsigned without;      /* AVATAR_* choices taken from it */
};

/* one frame's sensor poses, world: x y z qw qx qy qz */
struct ikx_avatar_frame {
	double head[7], lhand[7], rhand[7];
};

/* one solved frame; arrays per arm are indexed ARM_RIGHT (0), ARM_LEFT (1) */
struct ikx_avatar_out {
	unsigned flags[2];	       /* IK_* */
	double err_pos[2], err_rot[2]; /* the solver's own final errors */
	double chest[7];	       /* chest frame in the world: x y z qw qx qy qz */
	double q[2][IKX_DOF];
	double shoulder[2][3], elbow[2][3], wrist[2][3], hand[2][3]; /* chest frame */
	bool finite;		   /* every value of the pose finite (always so in fixed point) */
	unsigned long saturations; /* results that saturated in this frame: the counting build only, else 0 */
};

#define IKX_DECLARE(s)                                                                                                 \
	void ikx_fk##s(const struct ikx_setup *o, const double q[IKX_DOF], double out[7]);                             \
	void ikx_jacobian##s(const struct ikx_setup *o, const double q[IKX_DOF], double J[6][IKX_DOF]);                \
	int ikx_lsq##s(const double J[6][IKX_DOF], const double V[6], const bool *free, double x[IKX_DOF]);            \
	unsigned ikx_solve##s(const struct ikx_setup *o, const double p[3], const double r[4], const double *seed,     \
			      double q[IKX_DOF], struct ikx_result *res);                                              \
	const char *ikx_name##s(void);                                                                                 \
	void ikx_limits##s(const struct ikx_setup *o, double lo[IKX_DOF], double hi[IKX_DOF]);                         \
	void ikx_tolerances##s(double *pos, double *rot);                                                              \
	void ikx_avatar_run##s(const struct ikx_avatar_setup *o, const struct ikx_avatar_frame *in, size_t n,          \
			       struct ikx_avatar_out *out);

/* out = px, py, pz, qw, qx, qy, qz of the end effector */
/* seed NULL: a reset (the rest posture, or q = 0 for the paper's Newton) */
/* ikx_limits: the joint limits as this type holds them (rounded), radians */
/* ikx_tolerances: ik_default_opts' tol_pos (m) and tol_rot (rad) of this type */
/*
 * ikx_avatar_run: avatar_solve over n frames as the daemon tracks, each from
 * the previous frame's pose (the first from the rest posture), in out[0..n-1]
 */
IKX_DECLARE(_d)
IKX_DECLARE(_f)
IKX_DECLARE(_q)

#endif /* IKX_H */
