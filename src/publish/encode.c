// SPDX-License-Identifier: MIT
/*
 * encode.c - from the IK core's result to the protocol's structs.
 *
 * Segment frames along an arm (k[i] = Q1...Qi, see ik/arm.h): the shoulder
 * sits at k[3]'s origin with k[4]'s rotation (the upper arm), the elbow at
 * k[4] with k[5]'s rotation (the forearm), the wrist at k[7] with k[8]'s
 * rotation (the hand), the hand at k[8] (the end effector, which tracks the
 * hand sensor). arm_fk_pose() gives exactly these, as positions and
 * rotations in the chest frame, and the avatar keeps them with its posture
 * (avatar_pose.seg, from the solver's last evaluation: no kinematics are
 * evaluated again here); each is taken to the world with one
 * matrix product (the chest's rotation as a matrix, once) and a rotation with
 * one quaternion product (no dual-quaternion products here:
 * this runs for every avatar at every cycle).
 */
#include "publish/encode.h"

#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <string.h>

/* a pose whose translation t is known */
static void put_pose_t(const struct dq *d, const struct vec3 *t, struct wire_pose *p)
{
	p->p[0] = (float)t->x;
	p->p[1] = (float)t->y;
	p->p[2] = (float)t->z;
	p->q[0] = (float)d->r.w;
	p->q[1] = (float)d->r.x;
	p->q[2] = (float)d->r.y;
	p->q[3] = (float)d->r.z;
}

static void put_pose(const struct dq *d, struct wire_pose *p)
{
	struct vec3 t;

	dq_translation(d, &t);
	put_pose_t(d, &t, p);
}

/* the chest's rotation as a matrix (cm) and its position (cp): a point in the chest frame to the world */
static void put_point_chest(const sc_t cm[3][3], const struct vec3 *cp, const struct vec3 *p, struct wire_pose *out)
{
	out->p[0] = (float)(cp->x + cm[0][0] * p->x + cm[0][1] * p->y + cm[0][2] * p->z);
	out->p[1] = (float)(cp->y + cm[1][0] * p->x + cm[1][1] * p->y + cm[1][2] * p->z);
	out->p[2] = (float)(cp->z + cm[2][0] * p->x + cm[2][1] * p->y + cm[2][2] * p->z);
}

/* a rotation in the chest frame (r) to the world (cr r) */
static void put_rot_chest(const struct quat *cr, const struct quat *r, struct wire_pose *out)
{
	struct quat q;

	quat_mul(cr, r, &q);
	out->q[0] = (float)q.w;
	out->q[1] = (float)q.x;
	out->q[2] = (float)q.y;
	out->q[3] = (float)q.z;
}

static void nan_pose(struct wire_pose *p)
{
	for (int i = 0; i < 3; i++)
		p->p[i] = NAN;
	for (int i = 0; i < 4; i++)
		p->q[i] = NAN;
}

void encode_frame(const struct encode_in *in, struct wire_frame *out)
{
	const struct pose_frame *pf = in->pf;
	const struct avatar_pose *pose = in->pose;
	static const int seg0[2] = { WIRE_SEG_R_SHOULDER, WIRE_SEG_L_SHOULDER };
	uint16_t flags = 0;
	struct vec3 cp;
	sc_t cm[3][3];

	for (int i = 0; i < WIRE_SENSORS; i++) {
		struct wire_sensor_sample *s = &out->sensor[i];
		uint64_t a = pf->age_ns[i] / 100000u;

		s->state = pf->state[i];
		s->age_100us = a > 65535 ? 65535 : (uint16_t)a;
		if (s->state == WIRE_SENSOR_MISSING)
			nan_pose(&s->pose);
		else
			put_pose(&pf->sensor[i], &s->pose);
		if (s->state != WIRE_SENSOR_OK)
			flags |= WIRE_F_STALE;
	}
	if (pf->new_sample)
		flags |= WIRE_F_NEW_SAMPLE;
	if (in->held)
		flags |= WIRE_F_HELD;
	if (!pose) {
		memset(out->arm, 0, sizeof(out->arm));
		for (int i = 0; i < WIRE_JOINTS; i++)
			out->joint[i] = NAN;
		for (int i = 0; i < WIRE_SEGMENTS; i++)
			nan_pose(&out->segment[i]);
		out->h.flags = flags | WIRE_F_UNREACHED;
		return;
	}
	dq_translation(&pose->chest, &cp);
	quat_to_mat3(&pose->chest.r, cm);
	out->joint[0] = (float)pose->head_yaw;
	put_pose_t(&pose->chest, &cp, &out->segment[WIRE_SEG_CHEST]);
	/* the head segment is the head sensor's pose, written above */
	out->segment[WIRE_SEG_HEAD] = out->sensor[WIRE_S_HEAD].pose;
	for (int side = 0; side < 2; side++) {
		const struct ik_result *r = &pose->res[side];
		const struct arm_pose *ap;
		struct wire_pose *seg = &out->segment[seg0[side]];

		out->arm[side].ik_flags = (uint16_t)r->flags;
		out->arm[side].iters = (uint8_t)(r->iters > 255 ? 255 : r->iters);
		out->arm[side].pos_err = (float)r->err.pos;
		if (r->flags & (IK_UNREACHABLE | IK_BAD_TARGET))
			flags |= WIRE_F_UNREACHED;
		for (int j = 0; j < ARM_DOF; j++)
			out->joint[1 + side * ARM_DOF + j] = (float)pose->q[side][j];
		ap = &pose->seg[side];
		put_point_chest((const sc_t(*)[3])cm, &cp, &ap->shoulder, &seg[0]);
		put_point_chest((const sc_t(*)[3])cm, &cp, &ap->elbow, &seg[1]);
		put_point_chest((const sc_t(*)[3])cm, &cp, &ap->wrist, &seg[2]);
		put_point_chest((const sc_t(*)[3])cm, &cp, &ap->hand, &seg[3]);
		put_rot_chest(&pose->chest.r, &ap->upper_arm, &seg[0]);
		put_rot_chest(&pose->chest.r, &ap->forearm, &seg[1]);
		put_rot_chest(&pose->chest.r, &ap->hand_rot, &seg[2]);
		memcpy(seg[3].q, seg[2].q, sizeof(seg[3].q)); /* the wrist and the hand turn together */
	}
	out->h.flags = flags;
}

/*
 * All finite: a float is NaN or infinite exactly when its 8 exponent bits
 * are all ones, and then adding one to that field carries into bit 31.
 * Masked, carried and ORed over a run, bit 31 says it for the whole run:
 * no comparison or branch per value, and the loop is plain integer
 * arithmetic, done four at a time in a vector register (GCC's generic
 * vectors: SSE2, NEON; this runs for every FRAME).
 */
typedef uint32_t u32x4 __attribute__((vector_size(16)));

static uint32_t nonfinite_bits(const void *src, size_t n)
{
	const uint8_t *b = src, *end = b + n * sizeof(uint32_t);
	u32x4 m4 = { 0, 0, 0, 0 };
	uint32_t m = 0;

	/* two vectors a round where the run is long (half the loop's own instructions) */
	for (; end - b >= 2 * (ptrdiff_t)sizeof(m4); b += 2 * sizeof(m4)) {
		u32x4 v, w;

		memcpy(&v, b, sizeof(v));
		memcpy(&w, b + sizeof(v), sizeof(w));
		m4 |= ((v & 0x7f800000u) + 0x00800000u) | ((w & 0x7f800000u) + 0x00800000u);
	}
	for (; end - b >= (ptrdiff_t)sizeof(m4); b += sizeof(m4)) {
		u32x4 v;

		memcpy(&v, b, sizeof(v));
		m4 |= (v & 0x7f800000u) + 0x00800000u;
	}
	for (; b < end; b += sizeof(m)) {
		uint32_t v;

		memcpy(&v, b, sizeof(v));
		m |= (v & 0x7f800000u) + 0x00800000u;
	}
	return (m | m4[0] | m4[1] | m4[2] | m4[3]) & 0x80000000u;
}

bool encode_frame_finite(const struct wire_frame *f, bool solved)
{
	uint32_t bad = 0;

	_Static_assert(sizeof(float) == sizeof(uint32_t) && sizeof(struct wire_pose) == 7 * sizeof(float),
		       "IEEE single floats; a wire_pose is 7 of them");
	/* the sensors' records: NaN (unknown) only while a sensor is missing */
	for (int i = 0; i < WIRE_SENSORS; i++)
		if (f->sensor[i].state != WIRE_SENSOR_MISSING)
			bad |= nonfinite_bits(&f->sensor[i].pose, 7);
	if (f->h.flags & WIRE_F_INPUTS)
		bad |= nonfinite_bits(f->in.analog, WIRE_SENSORS * WIRE_ANALOG);
	if (!solved)
		return !bad; /* the posture is NaN throughout: unknown */
	{
		float pos_err[WIRE_ARMS];

		for (int side = 0; side < WIRE_ARMS; side++)
			pos_err[side] = f->arm[side].pos_err;
		bad |= nonfinite_bits(pos_err, WIRE_ARMS);
	}
	/* the head segment is the head sensor's own pose: NaN while the sensor is missing */
	if (f->sensor[WIRE_S_HEAD].state != WIRE_SENSOR_MISSING) {
		/* the joints and every segment: one run of floats (the assertion) */
		_Static_assert(offsetof(struct wire_frame, segment) ==
				       offsetof(struct wire_frame, joint) + WIRE_JOINTS * sizeof(float),
			       "the segments follow the joints without a gap");
		return !(bad | nonfinite_bits((const uint8_t *)f + offsetof(struct wire_frame, joint),
					      WIRE_JOINTS + WIRE_SEGMENTS * 7));
	}
	return !(bad | nonfinite_bits(f->joint, WIRE_JOINTS) | nonfinite_bits(f->segment, WIRE_SEG_HEAD * 7) |
		 nonfinite_bits(&f->segment[WIRE_SEG_HEAD + 1], (WIRE_SEGMENTS - WIRE_SEG_HEAD - 1) * 7));
}

void encode_describe(const struct avatar *av, const char *name, double rate_hz, struct wire_describe *out)
{
	/* the segment each arm joint's rotation is applied at (see the file comment) */
	static const uint8_t joint_seg[ARM_DOF] = { 0, 0, 0, 0, 1, 2, 2, 2 };
	static const uint8_t seg_parent[WIRE_SEGMENTS] = { 255,
							   WIRE_SEG_CHEST,
							   WIRE_SEG_CHEST,
							   WIRE_SEG_R_SHOULDER,
							   WIRE_SEG_R_ELBOW,
							   WIRE_SEG_R_WRIST,
							   WIRE_SEG_CHEST,
							   WIRE_SEG_L_SHOULDER,
							   WIRE_SEG_L_ELBOW,
							   WIRE_SEG_L_WRIST };
	static const int seg0[2] = { WIRE_SEG_R_SHOULDER, WIRE_SEG_L_SHOULDER };

	memset(out, 0, sizeof(*out));
	out->rate_hz = (float)rate_hz;
	out->dims[0] = (float)av->body.dims.shoulder;
	out->dims[1] = (float)av->body.dims.arm;
	out->dims[2] = (float)av->body.dims.forearm;
	out->dims[3] = (float)av->body.dims.hand;
	out->head_offset[0] = (float)av->body.head_offset.x;
	out->head_offset[1] = (float)av->body.head_offset.y;
	out->head_offset[2] = (float)av->body.head_offset.z;
	snprintf(out->avatar_name, sizeof(out->avatar_name), "%s", name);
	snprintf(out->conventions, sizeof(out->conventions),
		 "z-up RH; m; rad; quat wxyz; "
		 "chest x right y fwd z up");
	snprintf(out->joint[0].name, sizeof(out->joint[0].name), "%s", wire_joint_names[0]);
	out->joint[0].segment = WIRE_SEG_CHEST;
	out->joint[0].lo = (float)-M_PI;
	out->joint[0].hi = (float)M_PI;
	out->joint[0].axis[2] = 1;
	for (int side = 0; side < 2; side++) {
		const struct arm *a = &av->arm[side];

		for (int j = 0; j < ARM_DOF; j++) {
			struct wire_joint_desc *d = &out->joint[1 + side * ARM_DOF + j];

			snprintf(d->name, sizeof(d->name), "%s", wire_joint_names[1 + side * ARM_DOF + j]);
			d->segment = (uint8_t)(seg0[side] + joint_seg[j]);
			d->lo = (float)a->lim.lo[j];
			d->hi = (float)a->lim.hi[j];
			d->axis[0] = (float)a->axis[j].x;
			d->axis[1] = (float)a->axis[j].y;
			d->axis[2] = (float)a->axis[j].z;
			d->trans[0] = (float)a->trans[j].x;
			d->trans[1] = (float)a->trans[j].y;
			d->trans[2] = (float)a->trans[j].z;
		}
	}
	for (int i = 0; i < WIRE_SEGMENTS; i++) {
		snprintf(out->segment[i].name, sizeof(out->segment[i].name), "%s", wire_segment_names[i]);
		out->segment[i].parent = seg_parent[i];
	}
	for (int i = 0; i < WIRE_SENSORS; i++)
		snprintf(out->sensor[i], sizeof(out->sensor[i]), "%s", wire_sensor_names[i]);
}
