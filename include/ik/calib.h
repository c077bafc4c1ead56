/* SPDX-License-Identifier: MIT */
/*
 * calib.h - body dimensions of the avatar from tracker readings.
 *
 * The avatar model (ik/arm.h): chest frame x = the person's right,
 * y = forward, z = up, metres. The chain origin lies on the shoulder line,
 * midway between the shoulders; each arm starts S to the side of it, then A
 * (upper arm), F (forearm) and H (wrist centre -> hand sensor). The head
 * sensor sits Neck above the origin: the chest follows the head.
 *
 * Two calibrations:
 *
 *  - calib_paper(): the heuristic of the paper's section 3. One reading of
 *    the head and right-hand sensors in the paper's initial pose (upper arm
 *    hanging, elbow bent 90 degrees forward); fixed ratios split the
 *    distances into segments (Neck = Arm, Forearm:Hand = 0.7:0.3).
 *
 *  - calib_poses(): ours. Readings of the head and both hands in two or more
 *    standard poses; a linear least-squares fit gives S, A, F + H, Neck and
 *    the horizontal offset of the head sensor from the chain origin, without
 *    fixed ratios. H cannot be told apart from F by positions in straight-arm
 *    poses; it is an input (the known mounting of the hand sensor, 0 when it
 *    sits at the wrist).
 *
 * Common assumptions: positions are metres in one tracking world frame whose
 * z axis points up (against gravity); its horizontal axes may point anywhere
 * unless a function says otherwise. Sensor positions are those of the
 * sensor origins (head sensor: wherever it is mounted; hand sensor: on the
 * hand's long axis, H beyond the wrist centre). The person stands upright.
 *
 * Pure functions: no allocation, no I/O. Every function checks its input,
 * returns 0 or a negative CALIB_E* code, and on failure writes a zeroed
 * struct calib_body (never NaN).
 */
#ifndef IK_CALIB_H
#define IK_CALIB_H

#include "ik/arm.h"

#ifdef __cplusplus
extern "C" {
#endif

/* return codes */
#define CALIB_OK 0
#define CALIB_EINVAL (-1)      /* NULL, NaN or inf input, negative hand length, no observation */
#define CALIB_EDEGENERATE (-2) /* coincident sensors, no usable heading, tilted head sensor */
#define CALIB_EUNDERDET (-3)   /* the poses given do not determine every dimension */
#define CALIB_ERANGE (-4)      /* a dimension came out <= 0 or absurdly large: wrong pose or sensors swapped */

/* Upper bound on any estimated length, metres; larger means garbage in. */
#define CALIB_MAX_LEN SC_C(3)

/*
 * Result of a calibration. dims and head_offset are what avatar_init()
 * takes. head_offset is the head sensor's position relative to the chain
 * origin in the chest frame, with the head looking straight ahead:
 * x = sideways (+ right), y = forward (+ ahead of the shoulder line),
 * z = the paper's Neck. The paper's model has x = y = 0.
 */
struct calib_body {
	struct arm_dims dims;	 /* S, A, F, H, metres, shared by both arms */
	struct vec3 head_offset; /* (head_right, head_fwd, Neck) */
	sc_t rms;		 /* rms residual of the fit per coordinate, metres (0: exact or not a fit) */
};

/* How the paper's heuristic splits the forward distance of the hand sensor. */
enum calib_hand {
	CALIB_HAND_RATIO = 0, /* the paper: Forearm = 0.7 |dy|, Hand = 0.3 |dy| */
	CALIB_HAND_WRIST = 1, /* the sensor sits at the wrist centre: Forearm = |dy|, Hand = 0 */
};

/* Standard poses of calib_poses(); every one with both arms alike. */
enum calib_pose {
	/*
	 * the paper's initial pose: upper arms hanging straight down, elbows
	 * bent 90 degrees, forearms and hands horizontal and pointing forward
	 * (all joint angles zero). Hand sensor at (+-S, F + H, -A).
	 */
	CALIB_POSE_INITIAL = 0,
	/* arms hanging straight down beside the body: (+-S, 0, -(A + F + H)) */
	CALIB_POSE_DOWN = 1,
	/* arms straight, horizontal, pointing forward: (+-S, A + F + H, 0) */
	CALIB_POSE_FORWARD = 2,
	/* arms straight, horizontal, out to the sides (T-pose): (+-(S + A + F + H), 0, 0) */
	CALIB_POSE_SIDE = 3,
};

#define CALIB_NPOSES 4

/* One reading of the three sensors while the person holds a standard pose. */
struct calib_obs {
	enum calib_pose pose;
	struct vec3 head;  /* head sensor position, world frame, metres */
	struct vec3 lhand; /* left-hand sensor position */
	struct vec3 rhand; /* right-hand sensor position */
};

#define calib_paper SCN(calib_paper)
#define calib_poses SCN(calib_poses)
#define calib_heading SCN(calib_heading)
#define calib_strerror SCN(calib_strerror)

/*
 * The paper's heuristic (section 3).
 *
 * head, rhand: head and right-hand sensor positions, metres, read while the
 *   person stands in CALIB_POSE_INITIAL (with the right arm at least).
 * head_q: NULL, or the head sensor orientation in the avatar convention
 *   (x right, y forward, z up when upright and looking straight ahead).
 *   NULL: as in the paper, the world axes are the person's: x right,
 *   y forward, z up. Otherwise the difference rhand - head is taken in the
 *   upright frame turned by the head's heading (see calib_heading()).
 * mode: CALIB_HAND_RATIO, the paper's fixed split of the forward distance
 *   into forearm and hand; CALIB_HAND_WRIST for a hand sensor at the wrist.
 *
 * With d = rhand - head in that frame: S = |dx|, Neck = A = |dz| / 2,
 * F = 0.7 |dy| and H = 0.3 |dy| (RATIO) or F = |dy| and H = 0 (WRIST).
 * Assumes the head sensor straight above the chain origin, Neck = A (the
 * paper's "heuristic ergonomic" ratios), both arms alike. rms = 0,
 * head_offset = (0, 0, Neck).
 *
 * Returns CALIB_OK; CALIB_EINVAL for NULL or non-finite input or an unknown
 * mode; CALIB_EDEGENERATE if the two sensors are less than 1 cm apart or
 * head_q is given but its heading is undefined; CALIB_ERANGE if S, A or F
 * is below 1 mm or above CALIB_MAX_LEN (the wrong pose, swapped sensors).
 */
int calib_paper(const struct vec3 *head, const struct vec3 *rhand, const struct quat *head_q, enum calib_hand mode,
		struct calib_body *out);

/*
 * Our calibration: least squares over readings in standard poses.
 *
 * obs[0..n-1]: readings, any poses, any order, repeats allowed (they are
 *   averaged). The set must determine every dimension: CALIB_POSE_INITIAL
 *   with CALIB_POSE_SIDE, or CALIB_POSE_INITIAL with CALIB_POSE_DOWN and
 *   CALIB_POSE_FORWARD (the recommended set: no pose above the head or
 *   out to the sides). Both hands are needed in every reading.
 * hand: H, the known distance from the wrist centre to the hand sensor
 *   along the straight hand, metres, >= 0 (0 for a sensor at the wrist);
 *   F = (fitted F + H) - H.
 *
 * Each reading is taken in its own upright frame: z = world up, x = the
 * horizontal direction from the left to the right hand (both arms posed
 * alike make it the person's right), y = z x x. So the person may face any
 * way and turn or step between poses; only hand - head differences are
 * used. In that frame the model says, for the right hand (left: x mirrored),
 *   hand - head = p_pose(S, A, F + H) - (c, head_offset.y, head_offset.z),
 * with p_pose the positions listed at enum calib_pose. The lateral offset c
 * is taken per reading (it also absorbs the small turn of the frame when
 * one hand is ahead of the other) and head_offset.x is its mean; the rest
 * is linear in the five unknowns S, A, F + H, Neck, head_fwd, solved by least
 * squares (normal equations, Cholesky). Assumes the shoulders symmetric about the
 * chain origin and fixed while posing, both arms of the same lengths (the
 * fit averages them), straight arms where the pose says straight, and the
 * trunk upright. rms tells how well the readings fit the model: a few
 * millimetres for careful posing, centimetres for a wrong pose.
 *
 * Returns CALIB_OK; CALIB_EINVAL for NULL obs/out, n == 0, an unknown pose,
 * non-finite input or hand < 0; CALIB_EDEGENERATE if in a reading the two
 * hands are less than 5 cm apart horizontally; CALIB_EUNDERDET if the poses
 * leave a dimension undetermined; CALIB_ERANGE if S, A, F or Neck comes out
 * below 1 mm or above CALIB_MAX_LEN.
 */
int calib_poses(const struct calib_obs *obs, size_t n, sc_t hand, struct calib_body *out);

/*
 * The heading of a sensor in the avatar convention: the unit horizontal
 * vector of its x axis (the person's right), written to *right; the
 * forward direction is then (-right.y, right.x, 0). Returns false (and
 * writes (1, 0, 0) unless right is NULL) if q is NULL, not finite or zero,
 * or its x axis is within about 6 degrees of vertical. For an upright head
 * this agrees with avatar_head_yaw(); they differ when the head is both
 * pitched and rolled (by 5 degrees at 30 degrees pitch and 20 roll).
 */
bool calib_heading(const struct quat *q, struct vec3 *right);

/* a short English text for a CALIB_* return code */
const char *calib_strerror(int err);

#ifdef __cplusplus
}
#endif

#endif /* IK_CALIB_H */
