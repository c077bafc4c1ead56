/* SPDX-License-Identifier: MIT */
/*
 * ik.h - inverse kinematics of one arm.
 *
 * Two solvers share one Newton iteration (the paper's section 5): forward
 * kinematics, screw-axis Jacobian J (6x8), twist V of D C^-1, the
 * minimum-norm least-squares step dq = J+ V (ik_lsq_step), until the error is
 * below tolerance or the iteration cap is reached.
 *
 *  - ik_newton(): the paper's algorithm as written, from the given start,
 *    without joint limits. Kept for reference and comparison.
 *  - ik_solve(): avatargw's solver. Every returned solution lies inside the
 *    arm's joint limits. The 2-dimensional redundancy (J1 and the elbow's
 *    swivel about the shoulder-wrist line) is resolved in closed form with
 *    the limits as constraints, preferring the posture closest to the seed
 *    (the previous frame, or the rest posture); Newton polishes the result,
 *    clamping joints at their limits and re-solving with the rest, and it is
 *    the fallback for targets out of reach. See docs/IK.md.
 *
 * The kinematics are pluggable (struct ik_kin) so that the same iteration
 * runs on dual quaternions (ik_kin_dq) or on 4x4 matrices (ik_kin_mat).
 *
 * Pure functions: no allocation, no I/O, bounded work. Never writes NaN:
 * non-finite input gives the clamped seed (or the rest posture) and
 * IK_BAD_TARGET.
 */
#ifndef IK_IK_H
#define IK_IK_H

#include "ik/arm.h"

#ifdef __cplusplus
extern "C" {
#endif

/* result flags */
#define IK_REACHED 0x01	    /* within tolerance */
#define IK_UNREACHABLE 0x02 /* no posture within the limits reaches the target: closest returned */
#define IK_BAD_TARGET 0x04  /* NaN/inf or zero quaternion in the target or seed */
#define IK_LIMITED 0x08	    /* a joint limit is active in the returned posture */
#define IK_ANALYTIC 0x10    /* the closed-form swivel search found the posture */

/* The target end-effector pose, in the chest frame of the arm. */
struct ik_target {
	struct vec3 p;
	struct quat r;
	struct dq d;  /* the same as a dual quaternion */
	sc_t m[4][4]; /* the same as a matrix */
	bool valid;
};

/* Errors of the kinematics at the current posture. */
struct ik_err {
	sc_t pos; /* |p_target - p|, metres */
	sc_t rot; /* rotation angle between the orientations, radians */
};

/*
 * One backend: at posture q, the spatial Jacobian J and the twist V of
 * D C^-1 (angle times axis, velocity of the chest origin), and the errors.
 */
struct ik_kin {
	const char *name;
	void (*eval)(const struct arm *a, const sc_t q[ARM_DOF], const struct ik_target *t, sc_t J[6][ARM_DOF],
		     sc_t V[6], struct ik_err *err);
	/*
	 * Optional (NULL: eval is used): the same, except that when the errors
	 * are within tolerance (err->pos < tol_pos and err->rot < tol_rot) it
	 * returns true and leaves J and V unwritten. The last evaluation of a
	 * Newton iteration only checks convergence.
	 */
	bool (*eval_tol)(const struct arm *a, const sc_t q[ARM_DOF], const struct ik_target *t, sc_t tol_pos,
			 sc_t tol_rot, sc_t J[6][ARM_DOF], sc_t V[6], struct ik_err *err);
};

struct ik_opts {
	int max_iter;	    /* Newton iterations at most (polish and fallback) */
	sc_t tol_pos;	    /* metres */
	sc_t tol_rot;	    /* radians */
	sc_t max_step;	    /* largest joint step per iteration, radians (0: none) */
	int swivel_samples; /* closed-form search: samples of the swivel circle */
	int yaw_samples;    /* closed-form search: samples of J1 */
	int max_evals;	    /* closed-form search: postures evaluated at most (bounds the time); 0: no search,
			       Newton only, from the seed (an arm kept on its branch) */
	int warm_iter;	    /* Newton iterations tried from a seed before the closed-form search */
	sc_t center_gain;   /* tracking: fraction of the way to mid-range the redundancy moves per step */
};

struct ik_result {
	unsigned flags;
	int iters;	   /* Newton iterations done */
	int evals;	   /* closed-form postures evaluated */
	struct ik_err err; /* final error */
};

#define ik_kin_dq SCN(ik_kin_dq)
#define ik_kin_mat SCN(ik_kin_mat)
#define ik_default_opts SCN(ik_default_opts)
#define ik_target_set SCN(ik_target_set)
#define ik_lsq_step SCN(ik_lsq_step)
#define ik_newton SCN(ik_newton)
#define ik_solve SCN(ik_solve)
#define ik_solve_pose SCN(ik_solve_pose)
#define ik_rest_posture SCN(ik_rest_posture)
#define ik_swivel_solve SCN(ik_swivel_solve)

extern const struct ik_kin ik_kin_dq;
extern const struct ik_kin ik_kin_mat;

void ik_default_opts(struct ik_opts *o);
/* Normalises r; valid = false for non-finite values or a zero quaternion. */
void ik_target_set(struct ik_target *t, const struct vec3 *p, const struct quat *r);
/*
 * Minimum-norm least-squares solution of J x = V through a Householder QR of
 * J^T; directions whose pivot is below rcond (1e-6) times the largest are
 * dropped. With free != NULL only the columns with free[i] are used (the
 * others get 0). Returns the rank used.
 * With 6 or more free columns and J J^T provably well conditioned (a bound on
 * cond(J J^T) below SC_NE_COND: 1e10 in double, never in float) the same
 * solution comes from the normal equations, x = J^T (J J^T)^-1 V by LDL^T,
 * about 2.5 times faster; the QR would drop no pivot there (cond(J) <= 1e5).
 */
int ik_lsq_step(const sc_t J[6][ARM_DOF], const sc_t V[6], const bool *free, sc_t x[ARM_DOF]);
/* The paper's Newton iteration from seed (no limits). q may alias seed. */
unsigned ik_newton(const struct arm *a, const struct ik_kin *kin, const struct ik_target *t, const sc_t seed[ARM_DOF],
		   const struct ik_opts *o, sc_t q[ARM_DOF], struct ik_result *res);
/*
 * avatargw's solver: q inside the limits, closest to the seed's posture;
 * seed NULL means the rest posture (the paper's reset). q may alias seed.
 * Returns res->flags.
 */
unsigned ik_solve(const struct arm *a, const struct ik_kin *kin, const struct ik_target *t, const sc_t *seed,
		  const struct ik_opts *o, sc_t q[ARM_DOF], struct ik_result *res);
/*
 * ik_solve, and the arm's segment poses at the returned q in pose (what
 * arm_fk_pose gives): from the solver's own last evaluation, which is at q
 * whenever it ran Newton steps with the dual-quaternion backend (the common
 * case), else evaluated here.
 */
unsigned ik_solve_pose(const struct arm *a, const struct ik_kin *kin, const struct ik_target *t, const sc_t *seed,
		       const struct ik_opts *o, sc_t q[ARM_DOF], struct ik_result *res, struct arm_pose *pose);
/* The rest posture used by a reset: all zero (upper arm down, elbow at 90 deg), clamped to the limits. */
void ik_rest_posture(const struct arm *a, sc_t q[ARM_DOF]);
/*
 * The closed-form part on its own: searches J1 and the swivel for a posture
 * inside the limits that reaches t exactly, starting at pref's J1 and elbow
 * plane (the previous frame's, or the rest posture's). Returns true and
 * writes q if one was found, else writes the least violating posture seen;
 * evals counts the postures tried.
 */
bool ik_swivel_solve(const struct arm *a, const struct ik_target *t, const sc_t pref[ARM_DOF], const struct ik_opts *o,
		     sc_t q[ARM_DOF], int *evals);

#ifdef __cplusplus
}
#endif

#endif /* IK_IK_H */
