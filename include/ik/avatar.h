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
 * (0, 0, Neck). Pitch and roll of the head do not move the chest.
 */
#ifndef IK_AVATAR_H
#define IK_AVATAR_H

#include "ik/ik.h"

#ifdef __cplusplus
extern "C" {
#endif

struct avatar_body {
	struct arm_dims dims;     /* both arms */
	struct vec3 head_offset;  /* head sensor from the chain origin, chest frame (paper: 0, 0, Neck) */
	struct arm_limits lim;    /* both arms (the left is mirrored) */
};

struct avatar {
	struct avatar_body body;
	struct arm arm[2]; /* ARM_RIGHT, ARM_LEFT */
};

/* One solved frame. */
struct avatar_pose {
	struct dq chest;             /* chest frame in the world */
	sc_t head_yaw;               /* radians about world z */
	sc_t q[2][ARM_DOF];          /* joint angles per arm */
	struct ik_result res[2];     /* per arm */
};

#define avatar_init SCN(avatar_init)
#define avatar_head_yaw SCN(avatar_head_yaw)
#define avatar_chest SCN(avatar_chest)
#define avatar_arm_target SCN(avatar_arm_target)
#define avatar_solve SCN(avatar_solve)

/* lim NULL: the default limits */
void avatar_init(struct avatar *av, const struct arm_dims *dims, const struct vec3 *head_offset,
		 const struct arm_limits *lim);
/* yaw of a rotation about world z (swing-twist); 0 when undefined (upside down) */
sc_t avatar_head_yaw(const struct quat *head);
/* the chest frame in the world from the head sensor pose; false if the pose is not finite */
bool avatar_chest(const struct avatar *av, const struct dq *head, struct dq *chest, sc_t *yaw);
/* a hand sensor pose (world) as the target of one arm (chest frame) */
void avatar_arm_target(const struct dq *chest, const struct dq *hand, struct ik_target *t);
/*
 * Places the chest and solves both arms. prev: the previous frame's pose
 * to track from (NULL: reset to the rest posture). Returns the flags of both
 * arms or'ed.
 */
unsigned avatar_solve(const struct avatar *av, const struct ik_kin *kin, const struct ik_opts *o,
		      const struct dq *head, const struct dq *lhand, const struct dq *rhand,
		      const struct avatar_pose *prev, struct avatar_pose *out);

#ifdef __cplusplus
}
#endif

#endif /* IK_AVATAR_H */
