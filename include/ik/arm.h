/* SPDX-License-Identifier: MIT */
/*
 * arm.h - the paper's 8-DOF arm chain (eq. 2), right and left.
 *
 * Chest frame: x = the person's right, y = forward, z = up; metres, radians.
 * Joint i rotates about its local axis by q[i], then translates in the
 * rotated frame; T = T1(q1) T2(q2) ... T8(q8) (base-first; the paper writes
 * K8 = Q8 * ... * Q1 for the same thing).
 *
 *   joint  axis  then translate   meaning (q = 0: upper arm down, elbow 90 deg forward)
 *   J1     z     (S, 0, 0)        shoulder girdle / chest yaw (paper: theta1 + Head)
 *   J2     y                      shoulder abduction (-) / adduction (+)
 *   J3     x                      shoulder extension (-) / flexion (+)
 *   J4     z     (0, 0, -A)       humeral rotation
 *   J5     x     (0, F, 0)        elbow; anatomical flexion = 90 deg + q5
 *   J6     y                      forearm pronation / supination
 *   J7     x                      wrist flexion / extension
 *   J8     z     (0, H, 0)        wrist deviation
 *
 * The left arm is the mirror image in the plane x = 0: translation S -> -S,
 * axes along y and z reversed, so that the same angle means the same
 * anatomical motion on both sides and one limit table serves both:
 * FK_left(q) = M FK_right(q) M with M = diag(-1, 1, 1).
 *
 * The chain origin (the chest frame) lies on the shoulder line, midway
 * between the shoulders.
 */
#ifndef IK_ARM_H
#define IK_ARM_H

#include "ik/dq.h"

#ifdef __cplusplus
extern "C" {
#endif

#define ARM_DOF 8

enum arm_side {
	ARM_RIGHT = 0,
	ARM_LEFT = 1,
};

/* Segment lengths, metres (the paper's Shoulder, Arm, Forearm, Hand). */
struct arm_dims {
	sc_t shoulder; /* S: chain origin to shoulder joint */
	sc_t arm;      /* A: shoulder to elbow */
	sc_t forearm;  /* F: elbow to wrist centre */
	sc_t hand;     /* H: wrist centre to the end effector (the hand sensor) */
};

/* Joint limits, radians, lo <= hi, within [-pi, pi]. */
struct arm_limits {
	sc_t lo[ARM_DOF];
	sc_t hi[ARM_DOF];
};

/* Positions and frames along the chain, in the chest frame. */
struct arm_pose {
	struct vec3 shoulder, elbow, wrist, hand;
	struct quat upper_arm; /* frame after J4: -z along the upper arm */
	struct quat forearm;   /* frame after J5: +y along the forearm */
	struct quat hand_rot;  /* end-effector frame: +y along the hand */
};

struct arm {
	enum arm_side side;
	struct arm_dims dims;
	struct arm_limits lim;
	/*
	 * derived by arm_init(): local joint axis and translation after it. The
	 * kinematics rely on this layout (axes +-z y x z x y x z, translations
	 * along x, z, y, y after J1, J4, J5, J8): build an arm with arm_init only.
	 */
	struct vec3 axis[ARM_DOF];
	struct vec3 trans[ARM_DOF];
	sc_t sgn[ARM_DOF];	   /* +-1: joint i's axis on its coordinate (the left arm's y and z reversed) */
	sc_t inv_arm, inv_forearm; /* 1 / A and 1 / F (0 for a length that is not positive) */
	sc_t lim_cs[ARM_DOF][4];   /* cos lo, sin lo, cos hi, sin hi: limit tests without atan2 */
};

#define arm_default_limits SCN(arm_default_limits)
#define arm_init SCN(arm_init)
#define arm_joint_dq SCN(arm_joint_dq)
#define arm_fk SCN(arm_fk)
#define arm_fk_frames SCN(arm_fk_frames)
#define arm_fk_pose SCN(arm_fk_pose)
#define arm_jacobian SCN(arm_jacobian)
#define arm_in_limits SCN(arm_in_limits)
#define arm_clamp SCN(arm_clamp)
#define arm_mirror_dq SCN(arm_mirror_dq)

/* The human limits of the benchmark (degrees, converted):
 * J1 -30..30, J2 -90..30, J3 -60..120, J4 -90..90, J5 -90..60,
 * J6 -90..90, J7 -70..70, J8 -30..30. */
void arm_default_limits(struct arm_limits *out);
/* lim NULL: the default limits. */
void arm_init(struct arm *a, enum arm_side side, const struct arm_dims *dims, const struct arm_limits *lim);
/* Q_i = Rot(axis_i, qi) Trans(t_i), i in 0..7 */
void arm_joint_dq(const struct arm *a, int i, sc_t qi, struct dq *out);
/* end effector in the chest frame: the product Q_1 Q_2 ... Q_8 */
void arm_fk(const struct arm *a, const sc_t q[ARM_DOF], struct dq *ee);
/* k[0] = identity, k[i] = Q_1 ... Q_i, k[8] = end effector */
void arm_fk_frames(const struct arm *a, const sc_t q[ARM_DOF], struct dq k[ARM_DOF + 1]);
void arm_fk_pose(const struct arm *a, const sc_t q[ARM_DOF], struct arm_pose *out);
/*
 * Spatial (chest-frame) Jacobian: column i is the screw axis of joint i,
 * (l_i, p_i x l_i), the joint's line through the origin of k[i] (the frame
 * reached by joints 1..i-1 with their translations), l_i its direction.
 * Rows: wx wy wz vx vy vz. Writes the end effector to ee if not NULL.
 */
void arm_jacobian(const struct arm *a, const sc_t q[ARM_DOF], sc_t J[6][ARM_DOF], struct dq *ee);
bool arm_in_limits(const struct arm *a, const sc_t q[ARM_DOF]);
/* Clamps into the limits (wrapping to [-pi, pi) first); returns true if anything moved. */
bool arm_clamp(const struct arm *a, sc_t q[ARM_DOF]);
/* M X M for M = diag(-1, 1, 1): a right-arm pose <-> its mirror image */
void arm_mirror_dq(const struct dq *in, struct dq *out);

#ifdef __cplusplus
}
#endif

#endif /* IK_ARM_H */
