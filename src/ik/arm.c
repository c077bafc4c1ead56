// SPDX-License-Identifier: MIT
/*
 * arm.c - the 8-DOF arm chain: joint dual quaternions, forward kinematics as
 * their product, the screw-axis Jacobian. See ik/arm.h.
 */
#include "ik/arm.h"
#include "ik_private.h"

#define DEG(x) SC_C((x)*0.017453292519943295)

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
		a->sgn[i] = ax.x + ax.y + ax.z;
		a->trans[i] = (struct vec3){ 0, 0, 0 };
	}
	for (i = 0; i < ARM_DOF; i++) {
		sc_sincos(a->lim.lo[i], &a->lim_cs[i][1], &a->lim_cs[i][0]);
		sc_sincos(a->lim.hi[i], &a->lim_cs[i][3], &a->lim_cs[i][2]);
	}
	a->inv_arm = dims->arm > 0 ? sc_div(SC_C(1), dims->arm) : SC_C(0);
	a->inv_forearm = dims->forearm > 0 ? sc_div(SC_C(1), dims->forearm) : SC_C(0);
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

/* r <- r Rot(e_k, angle) with s, c the sine and cosine of half the angle: a sparse quaternion product */
static inline void rot_x(struct quat *r, sc_t s, sc_t c)
{
	struct quat o;

	o.w = sc_mul(r->w, c) - sc_mul(r->x, s);
	o.x = sc_mul(r->w, s) + sc_mul(r->x, c);
	o.y = sc_mul(r->y, c) + sc_mul(r->z, s);
	o.z = sc_mul(r->z, c) - sc_mul(r->y, s);
	*r = o;
}

static inline void rot_y(struct quat *r, sc_t s, sc_t c)
{
	struct quat o;

	o.w = sc_mul(r->w, c) - sc_mul(r->y, s);
	o.x = sc_mul(r->x, c) - sc_mul(r->z, s);
	o.y = sc_mul(r->w, s) + sc_mul(r->y, c);
	o.z = sc_mul(r->x, s) + sc_mul(r->z, c);
	*r = o;
}

static inline void rot_z(struct quat *r, sc_t s, sc_t c)
{
	struct quat o;

	o.w = sc_mul(r->w, c) - sc_mul(r->z, s);
	o.x = sc_mul(r->x, c) + sc_mul(r->y, s);
	o.y = sc_mul(r->y, c) - sc_mul(r->x, s);
	o.z = sc_mul(r->w, s) + sc_mul(r->z, c);
	*r = o;
}

/* columns of the rotation matrix of a unit quaternion: R e_x, R e_y, R e_z (as in quat_to_mat3) */
static inline void col_x(const struct quat *q, struct vec3 *o)
{
	o->x = SC_C(1) - 2 * (sc_mul(q->y, q->y) + sc_mul(q->z, q->z));
	o->y = 2 * (sc_mul(q->x, q->y) + sc_mul(q->w, q->z));
	o->z = 2 * (sc_mul(q->x, q->z) - sc_mul(q->w, q->y));
}

static inline void col_y(const struct quat *q, struct vec3 *o)
{
	o->x = 2 * (sc_mul(q->x, q->y) - sc_mul(q->w, q->z));
	o->y = SC_C(1) - 2 * (sc_mul(q->x, q->x) + sc_mul(q->z, q->z));
	o->z = 2 * (sc_mul(q->y, q->z) + sc_mul(q->w, q->x));
}

static inline void col_z(const struct quat *q, struct vec3 *o)
{
	o->x = 2 * (sc_mul(q->x, q->z) + sc_mul(q->w, q->y));
	o->y = 2 * (sc_mul(q->y, q->z) - sc_mul(q->w, q->x));
	o->z = SC_C(1) - 2 * (sc_mul(q->x, q->x) + sc_mul(q->y, q->y));
}

#if IK_COMPACT
/*
 * The compact form of arm_chain_eval and arm_chain_jacobian below (IK_COMPACT,
 * dq.h): one loop over the joints, the axis and translation of each from
 * the arm, the same products in the same order.
 */
/* axis of joint i: 0 x, 1 y, 2 z */
static const unsigned char chain_axis[ARM_DOF] = { 2, 1, 0, 2, 0, 1, 0, 2 };

/* r <- r (c, s e_k): with i, j the next axes, as rot_x, rot_y, rot_z */
static void rot_k(struct quat *r, int k, sc_t s, sc_t c)
{
	static const unsigned char next[5] = { 1, 2, 0, 1, 2 };
	sc_t *u = &r->x, w = r->w, ui, uj;
	int i = next[k], j = next[k + 1];

	ui = sc_mul_add(u[i], c, u[j], s);
	uj = sc_mul_sub(u[j], c, u[i], s);
	r->w = sc_mul_sub(w, c, u[k], s);
	u[k] = sc_mul_add(w, s, u[k], c);
	u[i] = ui;
	u[j] = uj;
}

void arm_chain_eval(const struct arm *a, const sc_t q[ARM_DOF], struct arm_chain *ch, sc_t J[6][ARM_DOF])
{
	struct quat *r = ch->r;
	struct vec3 *p = ch->p, u;
	int i, k;

	r[0] = (struct quat){ SC_C(1), 0, 0, 0 };
	p[0] = (struct vec3){ 0, 0, 0 };
	for (i = 0; i < ARM_DOF; i++) {
		const sc_t *t = SC_CV(&a->trans[i]);
		sc_t s, c;

		k = chain_axis[i];
		sc_sincos(sc_mul(q[i], SC_C(0.5)), &s, &c);
		r[i + 1] = r[i];
		rot_k(&r[i + 1], k, sc_mul(SC_CV(&a->axis[i])[k], s), c);
		p[i + 1] = p[i];
		/* the translation after J1, J4, J5, J8: along one axis of the new frame */
		for (k = 0; k < 3; k++) {
			if (t[k]) {
				quat_axis(&r[i + 1], k, &u);
				ik_add_scaled(&p[i], t[k], &u, &p[i + 1]);
			}
		}
	}
	if (J)
		arm_chain_jacobian(a, ch, J);
}

void arm_chain_jacobian(const struct arm *a, const struct arm_chain *ch, sc_t J[6][ARM_DOF])
{
	/* the frame whose axis column serves for joint i (before or after it turns: the same axis) */
	static const unsigned char frame[ARM_DOF] = { 0, 1, 2, 4, 5, 5, 6, 8 };
	struct vec3 u;
	int i;

	for (i = 0; i < ARM_DOF; i++) {
		int k = chain_axis[i];

		quat_axis(&ch->r[frame[i]], k, &u);
		ik_jac_col(J, i, &ch->p[i], SC_CV(&a->axis[i])[k], &u);
	}
}
#else
void arm_chain_eval(const struct arm *a, const sc_t q[ARM_DOF], struct arm_chain *ch, sc_t J[6][ARM_DOF])
{
	/*
	 * Joint i turns by q[i] about sgn_i e_k (sgn_i = +-1, the left arm's y and
	 * z axes are reversed): its quaternion is (c, sgn_i s e_k) with s, c of
	 * q[i] / 2, and r[i+1] = r[i] (c, sgn_i s e_k) costs 8 products instead
	 * of a general quaternion's 16 (a dual quaternion's 48). Its translation
	 * runs along one column of R(r[i+1]): 6 products for the column.
	 */
	const sc_t *sg = a->sgn;
	sc_t h[ARM_DOF], s[ARM_DOF], c[ARM_DOF];
	struct quat *r = ch->r;
	struct vec3 *p = ch->p, u1x, u4z, u5y, u8y;
	int i;

	for (i = 0; i < ARM_DOF; i++)
		h[i] = sc_mul(q[i], SC_C(0.5));
	sc_sincos8(h, s, c);
	for (i = 0; i < ARM_DOF; i++)
		s[i] = sc_mul(sg[i], s[i]);
	r[0].w = SC_C(1);
	r[0].x = r[0].y = r[0].z = 0;
	p[0].x = p[0].y = p[0].z = 0;
	/* J1 about z, then (S, 0, 0) */
	r[1].w = c[0];
	r[1].x = r[1].y = 0;
	r[1].z = s[0];
	col_x(&r[1], &u1x);
	ik_add_scaled(&p[0], a->trans[0].x, &u1x, &p[1]);
	/* J2 about y, J3 about x, J4 about z then (0, 0, -A) */
	r[2] = r[1];
	rot_y(&r[2], s[1], c[1]);
	r[3] = r[2];
	rot_x(&r[3], s[2], c[2]);
	r[4] = r[3];
	rot_z(&r[4], s[3], c[3]);
	p[2] = p[3] = p[1];
	col_z(&r[4], &u4z);
	ik_add_scaled(&p[3], a->trans[3].z, &u4z, &p[4]);
	/* J5 about x then (0, F, 0) */
	r[5] = r[4];
	rot_x(&r[5], s[4], c[4]);
	col_y(&r[5], &u5y);
	ik_add_scaled(&p[4], a->trans[4].y, &u5y, &p[5]);
	/* J6 about y, J7 about x, J8 about z then (0, H, 0) */
	r[6] = r[5];
	rot_y(&r[6], s[5], c[5]);
	r[7] = r[6];
	rot_x(&r[7], s[6], c[6]);
	r[8] = r[7];
	rot_z(&r[8], s[7], c[7]);
	p[6] = p[7] = p[5];
	col_y(&r[8], &u8y);
	ik_add_scaled(&p[7], a->trans[7].y, &u8y, &p[8]);
	if (J)
		arm_chain_jacobian(a, ch, J);
}

/*
 * Column i is the line of joint i's axis, sgn_i R(r[i]) e_k through p[i]; a
 * turn about e_k keeps R e_k, so R(r[i+1]) e_k serves as well where that
 * column is the one the translation used.
 */
void arm_chain_jacobian(const struct arm *a, const struct arm_chain *ch, sc_t J[6][ARM_DOF])
{
	const struct quat *r = ch->r;
	const struct vec3 *p = ch->p;
	struct vec3 u;

	/* the axis of J1 passes through the origin: (0, 0, sgn), no moment */
	J[0][0] = J[1][0] = 0;
	J[2][0] = a->axis[0].z;
	J[3][0] = J[4][0] = J[5][0] = 0;
	col_y(&r[1], &u);
	ik_jac_col(J, 1, &p[1], a->axis[1].y, &u);
	col_x(&r[2], &u);
	ik_jac_col(J, 2, &p[2], a->axis[2].x, &u);
	col_z(&r[4], &u);
	ik_jac_col(J, 3, &p[3], a->axis[3].z, &u);
	col_x(&r[5], &u);
	ik_jac_col(J, 4, &p[4], a->axis[4].x, &u);
	col_y(&r[5], &u);
	ik_jac_col(J, 5, &p[5], a->axis[5].y, &u);
	col_x(&r[6], &u);
	ik_jac_col(J, 6, &p[6], a->axis[6].x, &u);
	col_z(&r[8], &u);
	ik_jac_col(J, 7, &p[7], a->axis[7].z, &u);
}
#endif /* IK_COMPACT */

void arm_fk_frames(const struct arm *a, const sc_t q[ARM_DOF], struct dq k[ARM_DOF + 1])
{
	struct arm_chain ch;
	int i;

	arm_chain_eval(a, q, &ch, NULL);
	for (i = 0; i <= ARM_DOF; i++)
		dq_from_rt(&ch.r[i], &ch.p[i], &k[i]);
}

void arm_fk(const struct arm *a, const sc_t q[ARM_DOF], struct dq *ee)
{
	struct arm_chain ch;

	arm_chain_eval(a, q, &ch, NULL);
	dq_from_rt(&ch.r[ARM_DOF], &ch.p[ARM_DOF], ee);
}

void arm_chain_pose(const struct arm_chain *ch, struct arm_pose *out)
{
	out->shoulder = ch->p[1];
	out->elbow = ch->p[4];
	out->wrist = ch->p[5];
	out->hand = ch->p[8];
	out->upper_arm = ch->r[4];
	out->forearm = ch->r[5];
	out->hand_rot = ch->r[8];
}

void arm_fk_pose(const struct arm *a, const sc_t q[ARM_DOF], struct arm_pose *out)
{
	struct arm_chain ch;

	arm_chain_eval(a, q, &ch, NULL);
	arm_chain_pose(&ch, out);
}

void arm_jacobian(const struct arm *a, const sc_t q[ARM_DOF], sc_t J[6][ARM_DOF], struct dq *ee)
{
	struct arm_chain ch;

	arm_chain_eval(a, q, &ch, J);
	if (ee)
		dq_from_rt(&ch.r[ARM_DOF], &ch.p[ARM_DOF], ee);
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
		sc_t w;

		/* inside the limits and in [-pi, pi) already (false for NaN): nothing to do */
		if (q[i] >= a->lim.lo[i] && q[i] <= a->lim.hi[i] && q[i] >= -SC_PI && q[i] < SC_PI)
			continue;
		w = sc_clamp(sc_wrap_pi(q[i]), a->lim.lo[i], a->lim.hi[i]);
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
