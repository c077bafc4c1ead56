// SPDX-License-Identifier: MIT
/*
 * avatar.c - the chest from the head, both arms toward the hands.
 * See ik/avatar.h.
 */
#include "ik/avatar.h"

void avatar_init(struct avatar *av, const struct arm_dims *dims, const struct vec3 *head_offset,
		 const struct arm_limits *lim)
{
	av->body.dims = *dims;
	av->body.head_offset = *head_offset;
	if (lim)
		av->body.lim = *lim;
	else
		arm_default_limits(&av->body.lim);
	arm_init(&av->arm[ARM_RIGHT], ARM_RIGHT, dims, &av->body.lim);
	arm_init(&av->arm[ARM_LEFT], ARM_LEFT, dims, &av->body.lim);
}

sc_t avatar_head_yaw(const struct quat *head)
{
	/* the twist of q about z is (w, 0, 0, z) normalised: yaw = 2 atan2(z, w) */
	sc_t w = head->w, z = head->z;

	if (sc_abs(w) + sc_abs(z) < SC_C(1e-6))
		return 0;
	if (w < 0) {
		w = -w;
		z = -z;
	}
	return 2 * sc_atan2(z, w);
}

bool avatar_chest(const struct avatar *av, const struct dq *head, struct dq *chest, sc_t *yaw)
{
	struct quat r;
	struct vec3 hp, off, o;
	sc_t s, c;

	if (!dq_is_finite(head) || !quat_normalize(&head->r, &r)) {
		dq_identity(chest);
		*yaw = 0;
		return false;
	}
	*yaw = avatar_head_yaw(&r);
	sc_sincos(sc_mul(*yaw, SC_C(0.5)), &s, &c);
	r = (struct quat){ c, 0, 0, s };
	dq_translation(head, &hp);
	quat_rotate(&r, &av->body.head_offset, &off);
	o = (struct vec3){ hp.x - off.x, hp.y - off.y, hp.z - off.z };
	dq_from_rt(&r, &o, chest);
	return true;
}

void avatar_arm_target(const struct dq *chest, const struct dq *hand, struct ik_target *t)
{
	struct dq ci, local;
	struct vec3 p;

	if (!dq_is_finite(hand)) {
		struct vec3 nanp = { 0, 0, 0 };
		struct quat zero = { 0, 0, 0, 0 };

		ik_target_set(t, &nanp, &zero); /* marked invalid */
		return;
	}
	dq_conj(chest, &ci);
	dq_mul(&ci, hand, &local);
	dq_translation(&local, &p);
	ik_target_set(t, &p, &local.r);
}

unsigned avatar_solve(const struct avatar *av, const struct ik_kin *kin, const struct ik_opts *o,
		      const struct dq *head, const struct dq *lhand, const struct dq *rhand,
		      const struct avatar_pose *prev, struct avatar_pose *out)
{
	const struct dq *hand[2] = { rhand, lhand };
	unsigned flags = 0;
	int side;

	if (!avatar_chest(av, head, &out->chest, &out->head_yaw)) {
		/* no head: keep the previous frame, flagged */
		for (side = 0; side < 2; side++) {
			int i;

			for (i = 0; i < ARM_DOF; i++)
				out->q[side][i] = prev ? prev->q[side][i] : SC_C(0);
			if (!prev)
				ik_rest_posture(&av->arm[side], out->q[side]);
			out->res[side] = (struct ik_result){ IK_BAD_TARGET, 0, 0, { 0, 0 } };
		}
		if (prev)
			out->chest = prev->chest;
		return IK_BAD_TARGET;
	}
	for (side = 0; side < 2; side++) {
		struct ik_target t;

		avatar_arm_target(&out->chest, hand[side], &t);
		flags |= ik_solve(&av->arm[side], kin, &t, prev ? prev->q[side] : NULL, o, out->q[side],
				  &out->res[side]);
	}
	return flags;
}
