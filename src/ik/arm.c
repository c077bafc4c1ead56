// SPDX-License-Identifier: MIT
/*
 * arm.c - the 8-DOF arm chain: joint dual quaternions, forward kinematics as
 * their product, the screw-axis Jacobian. See ik/arm.h.
 */
#include "ik/arm.h"

#define DEG(x) SC_C((x) * 0.017453292519943295)

void arm_default_limits(struct arm_limits *out)
{
	static const struct arm_limits human = {
		.lo = { DEG(-30), DEG(-90), DEG(-60), DEG(-90), DEG(-90), DEG(-90), DEG(-70), DEG(-30) },
		.hi = { DEG(30), DEG(30), DEG(120), DEG(90), DEG(60), DEG(90), DEG(70), DEG(30) },
	};

	*out = human;
}

void arm_init(struct arm *a, enum arm_side side, const struct arm_dims *dims, const struct arm_limits *lim)
{
	/* right arm: axes z y x z x y x z; the left mirrors y and z axes and S */
	static const signed char axis_idx[ARM_DOF] = { 2, 1, 0, 2, 0, 1, 0, 2 };
	sc_t mirror = side == ARM_LEFT ? SC_C(-1) : SC_C(1);
	int i;

	a->side = side;
	a->dims = *dims;
	if (lim)
		a->lim = *lim;
	else
		arm_default_limits(&a->lim);
	for (i = 0; i < ARM_DOF; i++) {
		struct vec3 ax = { 0, 0, 0 };

		switch (axis_idx[i]) {
		case 0:
			ax.x = SC_C(1);
			break;
		case 1:
			ax.y = mirror;
			break;
		default:
			ax.z = mirror;
			break;
		}
		a->axis[i] = ax;
		a->trans[i] = (struct vec3){ 0, 0, 0 };
	}
	for (i = 0; i < ARM_DOF; i++) {
		sc_sincos(a->lim.lo[i], &a->lim_cs[i][1], &a->lim_cs[i][0]);
		sc_sincos(a->lim.hi[i], &a->lim_cs[i][3], &a->lim_cs[i][2]);
	}
	a->trans[0].x = sc_mul(mirror, dims->shoulder);
	a->trans[3].z = -dims->arm;
	a->trans[4].y = dims->forearm;
	a->trans[7].y = dims->hand;
}

void arm_joint_dq(const struct arm *a, int i, sc_t qi, struct dq *out)
{
	/* Rot(axis, qi) Trans(t): x' = R (x + t), so d = 1/2 (R t) r = 1/2 r t */
	struct quat r, tq;
	const struct vec3 *t = &a->trans[i];

	quat_from_axis_angle(&a->axis[i], qi, &r);
	tq = (struct quat){ 0, sc_mul(t->x, SC_C(0.5)), sc_mul(t->y, SC_C(0.5)), sc_mul(t->z, SC_C(0.5)) };
	out->r = r;
	quat_mul(&r, &tq, &out->d);
}

void arm_fk_frames(const struct arm *a, const sc_t q[ARM_DOF], struct dq k[ARM_DOF + 1])
{
	struct dq qi;
	int i;

	dq_identity(&k[0]);
	for (i = 0; i < ARM_DOF; i++) {
		arm_joint_dq(a, i, q[i], &qi);
		dq_mul(&k[i], &qi, &k[i + 1]);
	}
}

void arm_fk(const struct arm *a, const sc_t q[ARM_DOF], struct dq *ee)
{
	struct dq k[ARM_DOF + 1];

	arm_fk_frames(a, q, k);
	*ee = k[ARM_DOF];
}

void arm_fk_pose(const struct arm *a, const sc_t q[ARM_DOF], struct arm_pose *out)
{
	struct dq k[ARM_DOF + 1];

	arm_fk_frames(a, q, k);
	dq_translation(&k[1], &out->shoulder);
	dq_translation(&k[4], &out->elbow);
	dq_translation(&k[5], &out->wrist);
	dq_translation(&k[8], &out->hand);
	out->upper_arm = k[4].r;
	out->forearm = k[5].r;
	out->hand_rot = k[8].r;
}

void arm_jacobian(const struct arm *a, const sc_t q[ARM_DOF], sc_t J[6][ARM_DOF], struct dq *ee)
{
	struct dq k[ARM_DOF + 1];
	int i;

	arm_fk_frames(a, q, k);
	for (i = 0; i < ARM_DOF; i++) {
		/* the axis of joint i sits in k[i]: joints 1..i-1 and their translations */
		struct vec3 l, p, m;

		quat_rotate(&k[i].r, &a->axis[i], &l);
		dq_translation(&k[i], &p);
		v3_cross(&p, &l, &m);
		J[0][i] = l.x;
		J[1][i] = l.y;
		J[2][i] = l.z;
		J[3][i] = m.x;
		J[4][i] = m.y;
		J[5][i] = m.z;
	}
	if (ee)
		*ee = k[ARM_DOF];
}

bool arm_in_limits(const struct arm *a, const sc_t q[ARM_DOF])
{
	int i;

	for (i = 0; i < ARM_DOF; i++) {
		sc_t w = sc_wrap_pi(q[i]);

		if (!sc_isfinite(q[i]) || w < a->lim.lo[i] || w > a->lim.hi[i])
			return false;
	}
	return true;
}

bool arm_clamp(const struct arm *a, sc_t q[ARM_DOF])
{
	bool moved = false;
	int i;

	for (i = 0; i < ARM_DOF; i++) {
		sc_t w = sc_clamp(sc_wrap_pi(q[i]), a->lim.lo[i], a->lim.hi[i]);

		if (w != q[i]) {
			q[i] = w;
			moved = true;
		}
	}
	return moved;
}

void arm_mirror_dq(const struct dq *in, struct dq *out)
{
	struct vec3 t;
	struct quat r = { in->r.w, in->r.x, -in->r.y, -in->r.z };

	dq_translation(in, &t);
	t.x = -t.x;
	dq_from_rt(&r, &t, out);
}
