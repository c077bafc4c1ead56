/* SPDX-License-Identifier: MIT */
/*
 * avatar.h - one person's upper body: the chest placed from the head sensor,
 * two arm chains solved toward the hand sensors.
 *
 * World frame: z up, metres. The paper's placement: the chest frame turns
 * with the head's yaw (its rotation about world z; the paper's "Head" angle
 * added to J1) and stays upright; its origin, the midpoint of the shoulder
 * line, lies at a fixed offset below the head sensor, expressed in that
 * yawed frame: origin = head - Rz(yaw) head_offset. The paper's offset is
 * (0, 0, Neck). Pitch and roll of the head do not move the chest (in the
 * paper; AVATAR_NECK below bends the offset).
 *
 * What avatargw adds to the paper (struct avatar_body.model, each measured
 * on motion capture in docs/FIDELITY.md):
 *  - AVATAR_HAND_ELBOW: the arm's redundancy (the elbow's swivel about the
 *    shoulder-wrist line) is resolved where the wrist the hand sensor's
 *    orientation then asks for is most plausible: little deviation (J7),
 *    flexion or extension (J8) within a wide range, the forearm a little
 *    pronated (J6), with a pull toward the elbow's natural place (down,
 *    turned out) as strong as lifting the arm there is tiring (the
 *    elbow's circle's radius and the shoulder-wrist line's tilt from the
 *    vertical). The hand frame: y along
 *    the hand, z toward the thumb. The IK starts from that posture instead
 *    of the previous frame's.
 *  - AVATAR_REACH_FIRST: when no posture inside the joint limits gives the
 *    hand both the sensor's position and its orientation, the hand still
 *    goes to the sensor's position and the wrist turns as far toward the
 *    orientation as its limits allow (the paper's Newton iteration and our
 *    solver otherwise trade position for orientation).
 *  - AVATAR_YAW_REACH: the chest's yaw is the head's turned toward a hand
 *    held forward (a right hand forward turns the chest left, the shoulder
 *    going with the arm): by 36.4 degrees per arm length of each hand's
 *    forward reach from the shoulders, as far as the hand is raised (none
 *    hanging, all from the shoulders' height up), right minus left.
 *  - AVATAR_YAW_HANDS (an option): the chest's yaw is pulled toward the
 *    heading of the line from the left to the right hand when the two
 *    agree (the head turns more often than the chest).
 *  - AVATAR_REACH_CHEST: hand sensors beyond the straight arms' reach
 *    move the chest toward them by the least move that brings them within
 *    it, both at once, at most 8 cm (the trunk leans, the shoulder girdle
 *    protracts), before the arms are solved.
 *  - AVATAR_NECK: the neck bends: head_offset turns about the chest origin
 *    by half of the head's tilt (its pitch and roll, the rest of a nod being
 *    the head's own joint), so a nod or a bow leaves the chest behind
 *    instead of carrying it forward and down with the head.
 *  - AVATAR_BOW: a hand below or behind the shoulders that the upright
 *    chest still leaves off its sensor (a joint limit in the way) tries the
 *    chest bowed forward at the waist, 15
 *    to 75 degrees about its x axis, turned with the neck and head about the
 *    head sensor; the bow that lays the arms nearest along the trunk and
 *    reaches both hands is kept. The chest is then no longer upright; its
 *    yaw (the twist about world z) is still the published chest_yaw.
 *  - AVATAR_REACH_ROLL: with AVATAR_REACH_CHEST, when both hands are
 *    beyond reach, the chest also rolls about its forward axis (a lateral
 *    lean: one shoulder up, the other down), by the least move that gives
 *    both arms what they miss, at most 20 degrees.
 *  - AVATAR_BOW_HEAD: a head pitched forward by more than the neck's 30
 *    degrees is a bow: the chest pitches by the rest about the head
 *    sensor.
 *  - AVATAR_KEEP_BRANCH: an elbow that moves 10 cm more than its hand in
 *    one frame (another branch of the arm) is held on the branch it was on
 *    if the hand stays within 1 mm of its sensor (or no farther than the
 *    jump left it) and 20 degrees of the jump's orientation.
 *  - AVATAR_LEAN: raised hands that the arms, against their limits, leave
 *    off their sensors bend the trunk: sideways away from one raised arm
 *    (5 to 20 degrees), or back (5 to 20 degrees about the head sensor),
 *    the first bend that puts every hand on kept.
 *  - AVATAR_RAISE_ROLL: a raised arm's shoulder rises (4 cm times the sine
 *    of the shoulder-wrist line's elevation); the chest rolls by half the
 *    two shoulders' difference (one arm raised: the trunk bent away).
 *  - AVATAR_ARM_TWIST (an option): with AVATAR_HAND_ELBOW, a nearly
 *    straight arm's swivel (one turn with the forearm's pronation) is
 *    pulled toward the upper arm's untwisted place, the hanging arm's
 *    elbow axis carried along the shoulder-wrist line by the least
 *    rotation.
 */
#ifndef IK_AVATAR_H
#define IK_AVATAR_H

#include "ik/ik.h"

#ifdef __cplusplus
extern "C" {
#endif

/* struct avatar_body.model */
#define AVATAR_PAPER 0x0 /* the paper's avatar: chest from the head's yaw, arms tracked from the last frame */
#define AVATAR_HAND_ELBOW 0x1
#define AVATAR_REACH_FIRST 0x2
#define AVATAR_YAW_HANDS 0x4
#define AVATAR_REACH_CHEST 0x8
#define AVATAR_NECK 0x10
#define AVATAR_BOW 0x20
#define AVATAR_KEEP_BRANCH 0x40
#define AVATAR_REACH_ROLL 0x80
#define AVATAR_BOW_HEAD 0x100
#define AVATAR_LEAN 0x200
#define AVATAR_RAISE_ROLL 0x400
#define AVATAR_ARM_TWIST 0x800
#define AVATAR_YAW_REACH 0x1000
#define AVATAR_MODEL_DEFAULT                                                                                           \
	(AVATAR_HAND_ELBOW | AVATAR_REACH_FIRST | AVATAR_YAW_REACH | AVATAR_REACH_CHEST | AVATAR_BOW |                 \
	 AVATAR_KEEP_BRANCH | AVATAR_REACH_ROLL | AVATAR_BOW_HEAD | AVATAR_LEAN | AVATAR_RAISE_ROLL)

struct avatar_body {
	struct arm_dims dims;	 /* the right arm (and the left one unless avatar_set_left_arm() says otherwise) */
	struct vec3 head_offset; /* head sensor from the chain origin, chest frame (paper: 0, 0, Neck) */
	struct arm_limits lim;	 /* both arms (the left is mirrored) */
	unsigned model;		 /* AVATAR_* choices, AVATAR_MODEL_DEFAULT after avatar_init() */
	sc_t rest_pronation;	 /* J6 of a forearm at rest, radians (avatar_set_rest_pronation) */
};

struct avatar {
	struct avatar_body body;
	struct arm arm[2];     /* ARM_RIGHT, ARM_LEFT */
	sc_t rest6_c, rest6_s; /* cosine and sine of body.rest_pronation */
};

/* One solved frame. */
struct avatar_pose {
	struct dq chest;	 /* chest frame in the world */
	sc_t head_yaw;		 /* radians about world z */
	sc_t q[2][ARM_DOF];	 /* joint angles per arm */
	struct ik_result res[2]; /* per arm */
	/*
	 * AVATAR_HAND_ELBOW, per arm: running mean of the least cost of the
	 * elbow's placement (the wrist's cost and the pulls; 1 is about one
	 * natural range of one wrist joint). A diagnostic only.
	 */
	sc_t hand_misfit[2];
	struct arm_pose seg[2]; /* per arm, the segment poses at q (arm_fk_pose), for publishing */
};

#define avatar_init SCN(avatar_init)
#define avatar_default_limits SCN(avatar_default_limits)
#define avatar_set_left_arm SCN(avatar_set_left_arm)
#define avatar_set_rest_pronation SCN(avatar_set_rest_pronation)
#define avatar_head_yaw SCN(avatar_head_yaw)
#define avatar_chest SCN(avatar_chest)
#define avatar_chest_hands SCN(avatar_chest_hands)
#define avatar_arm_solve SCN(avatar_arm_solve)
#define avatar_arm_target SCN(avatar_arm_target)
#define avatar_solve SCN(avatar_solve)

/*
 * The avatar's default joint limits: the benchmark's (arm_default_limits)
 * but J2 from -170 degrees, so that an arm raised over the head (a wave
 * overhead, both hands up; the shoulder blade turns with the arm) stays
 * reachable: -90 and -120 cut the motion-capture clips' overhead frames
 * (docs/FIDELITY.md, each limit decided by folds of clips); and J7 -30..30,
 * J8 -80..80: with the hand's z toward the thumb, J7 (about x, across the
 * palm) is the wrist's deviation and J8 (about z) its flexion and extension
 * (the benchmark's -70..70 and -30..30 fit a hand frame whose z is the
 * palm's normal). The daemon's j1..j8 defaults are these.
 */
void avatar_default_limits(struct arm_limits *out);
/* lim NULL: avatar_default_limits(); model = AVATAR_MODEL_DEFAULT (change it after, if wanted) */
void avatar_init(struct avatar *av, const struct arm_dims *dims, const struct vec3 *head_offset,
		 const struct arm_limits *lim);
/* the left arm's own lengths, when the two arms differ (shoulder is shared: the chain origin is midway) */
void avatar_set_left_arm(struct avatar *av, sc_t arm, sc_t forearm, sc_t hand);
/*
 * AVATAR_HAND_ELBOW's forearm at rest: the pronation (J6, radians; negative
 * turns the thumb inward) the wrist's cost is centred on, -30 degrees after
 * avatar_init(). People differ by tens of degrees (docs/FIDELITY.md).
 */
void avatar_set_rest_pronation(struct avatar *av, sc_t j6);
/* yaw of a rotation about world z (swing-twist); 0 when undefined (upside down) */
sc_t avatar_head_yaw(const struct quat *head);
/*
 * The chest frame in the world from the head sensor pose (and, with
 * AVATAR_YAW_REACH and AVATAR_YAW_HANDS, the hand sensors: NULL or non-finite
 * ones are ignored);
 * false if the head pose is not finite.
 */
bool avatar_chest(const struct avatar *av, const struct dq *head, struct dq *chest, sc_t *yaw);
bool avatar_chest_hands(const struct avatar *av, const struct dq *head, const struct dq *lhand, const struct dq *rhand,
			struct dq *chest, sc_t *yaw);
/* a hand sensor pose (world) as the target of one arm (chest frame) */
void avatar_arm_target(const struct dq *chest, const struct dq *hand, struct ik_target *t);
/*
 * One arm toward its target (chest frame) as avatar_solve does it, with the
 * body's model choices: writes out->q[side], out->res[side] and
 * out->hand_misfit[side]. prev: the previous frame or NULL.
 */
unsigned avatar_arm_solve(const struct avatar *av, int side, const struct ik_kin *kin, const struct ik_opts *o,
			  const struct ik_target *t, const struct avatar_pose *prev, struct avatar_pose *out);
/*
 * Places the chest and solves both arms. prev: the previous frame's pose
 * to track from (NULL: reset to the rest posture). Returns the flags of both
 * arms or'ed.
 */
unsigned avatar_solve(const struct avatar *av, const struct ik_kin *kin, const struct ik_opts *o, const struct dq *head,
		      const struct dq *lhand, const struct dq *rhand, const struct avatar_pose *prev,
		      struct avatar_pose *out);

#ifdef __cplusplus
}
#endif

#endif /* IK_AVATAR_H */
