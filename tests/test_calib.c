// SPDX-License-Identifier: MIT
/*
 * test_calib.c - body-dimension calibration (ik/calib.h), double build.
 *
 * Readings are generated with the arm chain itself (arm_fk of both arms in
 * the standard poses), placed in a world frame turned and shifted
 * differently for every pose, so the calibration is checked against the
 * kinematics the avatar uses, not against its own pose table. Random
 * numbers come from a fixed-seed xorshift: every run checks the same
 * inputs.
 */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "ik/arm.h"
#include "ik/avatar.h"
#include "ik/calib.h"

#include "testutil.h"

#define DEG2RAD 0.017453292519943295

#define assert_rc(got, want)                                                                                           \
	do {                                                                                                           \
		int g_ = (got), w_ = (want);                                                                           \
		if (g_ != w_)                                                                                          \
			fail_msg("%s: %s returned %d (%s), want %d (%s)", ctx, #got, g_, calib_strerror(g_), w_,       \
				 calib_strerror(w_));                                                                  \
	} while (0)

/* ---- a synthetic person -------------------------------------------------------- */

struct person {
	struct arm_dims dims;
	double neck;
	double head_right, head_fwd; /* head sensor offset from the chain origin, chest frame */
};

/* a plausible adult, or a child, or a tall adult */
static void random_person(struct person *p, double hand)
{
	p->dims.shoulder = rnd_range(0.10, 0.22);
	p->dims.arm = rnd_range(0.20, 0.36);
	p->dims.forearm = rnd_range(0.17, 0.30);
	p->dims.hand = hand;
	p->neck = rnd_range(0.06, 0.30);
	p->head_right = rnd_range(-0.03, 0.03);
	p->head_fwd = rnd_range(-0.06, 0.12);
}

/* joint angles of the standard poses (arm.h: q = 0 is the paper's initial pose) */
static void pose_q(enum calib_pose pose, double q[ARM_DOF])
{
	memset(q, 0, sizeof(double) * ARM_DOF);
	switch (pose) {
	case CALIB_POSE_INITIAL:
		break;
	case CALIB_POSE_DOWN:
		q[4] = -90 * DEG2RAD; /* elbow straight */
		break;
	case CALIB_POSE_FORWARD:
		q[2] = 90 * DEG2RAD; /* shoulder flexion */
		q[4] = -90 * DEG2RAD;
		break;
	case CALIB_POSE_SIDE:
		q[1] = -90 * DEG2RAD; /* shoulder abduction */
		q[4] = -90 * DEG2RAD;
		break;
	}
}

/* a world placement of the chest frame: yaw about z, then a shift */
struct place {
	double yaw;
	struct vec3 t;
};

static void random_place(struct place *w)
{
	w->yaw = rnd_range(-3.1, 3.1);
	w->t = (struct vec3){ rnd_range(-2, 2), rnd_range(-2, 2), rnd_range(0.9, 1.6) };
}

static void to_world(const struct place *w, const struct vec3 *c, struct vec3 *out)
{
	double cy = cos(w->yaw), sy = sin(w->yaw);

	out->x = cy * c->x - sy * c->y + w->t.x;
	out->y = sy * c->x + cy * c->y + w->t.y;
	out->z = c->z + w->t.z;
}

/* hand sensor of one arm in the chest frame: the chain's end effector */
static void hand_in_chest(const struct person *p, enum arm_side side, enum calib_pose pose, struct vec3 *out)
{
	struct arm a;
	struct dq ee;
	double q[ARM_DOF];

	arm_init(&a, side, &p->dims, NULL);
	pose_q(pose, q);
	assert_true(arm_in_limits(&a, q));
	arm_fk(&a, q, &ee);
	dq_translation(&ee, out);
}

/* one reading of the person in a pose at a world placement */
static void make_obs(const struct person *p, enum calib_pose pose, const struct place *w, struct calib_obs *o)
{
	struct vec3 r, l, h = { p->head_right, p->head_fwd, p->neck };

	hand_in_chest(p, ARM_RIGHT, pose, &r);
	hand_in_chest(p, ARM_LEFT, pose, &l);
	o->pose = pose;
	to_world(w, &h, &o->head);
	to_world(w, &r, &o->rhand);
	to_world(w, &l, &o->lhand);
}

static void jitter(struct vec3 *v, double a)
{
	v->x += rnd_range(-a, a);
	v->y += rnd_range(-a, a);
	v->z += rnd_range(-a, a);
}

static void assert_body_zero(const struct calib_body *b)
{
	const double v[] = { b->dims.shoulder, b->dims.arm,	 b->dims.forearm,  b->dims.hand,
			     b->head_offset.x, b->head_offset.y, b->head_offset.z, b->rms };
	size_t i;

	for (i = 0; i < sizeof(v) / sizeof(v[0]); i++)
		if (v[i] != 0)
			fail_msg("%s: field %zu of the result is %g after a failure, want 0", ctx, i, v[i]);
}

static void assert_body_finite(const struct calib_body *b)
{
	const double v[] = { b->dims.shoulder, b->dims.arm,	 b->dims.forearm,  b->dims.hand,
			     b->head_offset.x, b->head_offset.y, b->head_offset.z, b->rms };
	size_t i;

	for (i = 0; i < sizeof(v) / sizeof(v[0]); i++)
		if (!isfinite(v[i]))
			fail_msg("%s: field %zu of the result is %g", ctx, i, v[i]);
}

static void assert_body(const struct calib_body *b, const struct person *p, double tol)
{
	assert_near(b->dims.shoulder, p->dims.shoulder, tol);
	assert_near(b->dims.arm, p->dims.arm, tol);
	assert_near(b->dims.forearm, p->dims.forearm, tol);
	assert_near(b->dims.hand, p->dims.hand, tol);
	assert_near(b->head_offset.z, p->neck, tol);
	assert_near(b->head_offset.x, p->head_right, tol);
	assert_near(b->head_offset.y, p->head_fwd, tol);
}

/* ---- the chain's poses are what calib.h says they are ---------------------------- */

static void test_pose_table(void **state)
{
	struct person p = { .dims = { 0.17, 0.29, 0.20, 0.05 } };
	const double S = 0.17, A = 0.29, L = 0.25;
	const struct {
		enum calib_pose pose;
		struct vec3 r;
	} want[] = {
		{ CALIB_POSE_INITIAL, { S, L, -A } },
		{ CALIB_POSE_DOWN, { S, 0, -(A + L) } },
		{ CALIB_POSE_FORWARD, { S, A + L, 0 } },
		{ CALIB_POSE_SIDE, { S + A + L, 0, 0 } },
	};
	size_t i;

	(void)state;
	for (i = 0; i < sizeof(want) / sizeof(want[0]); i++) {
		struct vec3 r, l;

		set_ctx("pose %d", want[i].pose);
		hand_in_chest(&p, ARM_RIGHT, want[i].pose, &r);
		hand_in_chest(&p, ARM_LEFT, want[i].pose, &l);
		assert_near(r.x, want[i].r.x, 1e-12);
		assert_near(r.y, want[i].r.y, 1e-12);
		assert_near(r.z, want[i].r.z, 1e-12);
		assert_near(l.x, -want[i].r.x, 1e-12);
		assert_near(l.y, want[i].r.y, 1e-12);
		assert_near(l.z, want[i].r.z, 1e-12);
	}
}

/* ---- the paper's heuristic ----------------------------------------------------------- */

static void test_paper_exact(void **state)
{
	int k;

	(void)state;
	rng_seed(1);
	for (k = 0; k < 200; k++) {
		struct person p;
		struct place w;
		struct calib_obs o;
		struct calib_body b;
		struct quat hq;
		const struct vec3 z = { 0, 0, 1 };

		/* the paper's own body: Neck = Arm, Hand = 3/7 Forearm, head straight above the origin */
		random_person(&p, 0);
		p.dims.hand = p.dims.forearm * 3.0 / 7.0;
		p.neck = p.dims.arm;
		p.head_right = p.head_fwd = 0;

		/* facing +y as the paper wants: no head orientation needed */
		set_ctx("paper person %d, world aligned", k);
		w.yaw = 0;
		w.t = (struct vec3){ rnd_range(-2, 2), rnd_range(-2, 2), 1.2 };
		make_obs(&p, CALIB_POSE_INITIAL, &w, &o);
		assert_rc(calib_paper(&o.head, &o.rhand, NULL, CALIB_HAND_RATIO, &b), CALIB_OK);
		assert_body(&b, &p, 1e-12);
		assert_near(b.rms, 0, 0);

		/* facing -y: the paper's absolute values make that work too */
		set_ctx("paper person %d, facing -y", k);
		w.yaw = 3.14159265358979323846;
		make_obs(&p, CALIB_POSE_INITIAL, &w, &o);
		assert_rc(calib_paper(&o.head, &o.rhand, NULL, CALIB_HAND_RATIO, &b), CALIB_OK);
		assert_body(&b, &p, 1e-12);

		/* facing anywhere: the head sensor's heading turns the axes */
		set_ctx("paper person %d, turned", k);
		random_place(&w);
		make_obs(&p, CALIB_POSE_INITIAL, &w, &o);
		quat_from_axis_angle(&z, w.yaw, &hq);
		assert_rc(calib_paper(&o.head, &o.rhand, &hq, CALIB_HAND_RATIO, &b), CALIB_OK);
		assert_body(&b, &p, 1e-12);

		/* the same person with the sensor at the wrist */
		set_ctx("paper person %d, wrist sensor", k);
		p.dims.hand = 0;
		make_obs(&p, CALIB_POSE_INITIAL, &w, &o);
		assert_rc(calib_paper(&o.head, &o.rhand, &hq, CALIB_HAND_WRIST, &b), CALIB_OK);
		assert_body(&b, &p, 1e-12);
	}
}

/* on a body that is not the paper's, the heuristic gives its formula, not the truth */
static void test_paper_formula(void **state)
{
	struct person p = { .dims = { 0.17, 0.29, 0.20, 0 }, .neck = 0.10, .head_right = 0.01, .head_fwd = -0.04 };
	struct place w = { 0, { 0.3, -0.2, 1.25 } };
	struct calib_obs o;
	struct calib_body b;

	(void)state;
	set_ctx("CMU-like body");
	make_obs(&p, CALIB_POSE_INITIAL, &w, &o);
	assert_rc(calib_paper(&o.head, &o.rhand, NULL, CALIB_HAND_RATIO, &b), CALIB_OK);
	assert_near(b.dims.shoulder, 0.17 - 0.01, 1e-12);
	assert_near(b.head_offset.z, (0.10 + 0.29) / 2, 1e-12);
	assert_near(b.dims.arm, (0.10 + 0.29) / 2, 1e-12);
	assert_near(b.dims.forearm, 0.7 * (0.20 + 0.04), 1e-12);
	assert_near(b.dims.hand, 0.3 * (0.20 + 0.04), 1e-12);
	assert_near(b.head_offset.x, 0, 0);
	assert_near(b.head_offset.y, 0, 0);
	assert_rc(calib_paper(&o.head, &o.rhand, NULL, CALIB_HAND_WRIST, &b), CALIB_OK);
	assert_near(b.dims.forearm, 0.20 + 0.04, 1e-12);
	assert_near(b.dims.hand, 0, 0);
}

static void test_paper_bad_input(void **state)
{
	const struct vec3 head = { 0, 0, 1.6 }, hand = { 0.17, 0.25, 1.2 };
	const double bad[] = { NAN, INFINITY, -INFINITY };
	const struct quat q_nan = { NAN, 0, 0, 0 }, q_zero = { 0, 0, 0, 0 };
	struct quat q_roll;
	const struct vec3 y = { 0, 1, 0 };
	struct calib_body b;
	size_t i;
	int c;

	(void)state;
	for (i = 0; i < 3; i++)
		for (c = 0; c < 6; c++) {
			struct vec3 h = head, r = hand;
			double *f = c < 3 ? &h.x : &r.x;

			f[c % 3] = bad[i];
			set_ctx("paper, coordinate %d = %g", c, bad[i]);
			memset(&b, 0x55, sizeof(b));
			assert_rc(calib_paper(&h, &r, NULL, CALIB_HAND_RATIO, &b), CALIB_EINVAL);
			assert_body_zero(&b);
		}
	set_ctx("paper, NULL");
	assert_rc(calib_paper(NULL, &hand, NULL, CALIB_HAND_RATIO, &b), CALIB_EINVAL);
	assert_body_zero(&b);
	assert_rc(calib_paper(&head, NULL, NULL, CALIB_HAND_RATIO, &b), CALIB_EINVAL);
	assert_rc(calib_paper(&head, &hand, NULL, CALIB_HAND_RATIO, NULL), CALIB_EINVAL);
	set_ctx("paper, bad mode");
	assert_rc(calib_paper(&head, &hand, NULL, (enum calib_hand)7, &b), CALIB_EINVAL);
	assert_body_zero(&b);

	set_ctx("paper, coincident sensors");
	memset(&b, 0x55, sizeof(b));
	assert_rc(calib_paper(&head, &head, NULL, CALIB_HAND_RATIO, &b), CALIB_EDEGENERATE);
	assert_body_zero(&b);

	set_ctx("paper, NaN head orientation");
	assert_rc(calib_paper(&head, &hand, &q_nan, CALIB_HAND_RATIO, &b), CALIB_EINVAL);
	assert_body_zero(&b);
	set_ctx("paper, zero head orientation");
	assert_rc(calib_paper(&head, &hand, &q_zero, CALIB_HAND_RATIO, &b), CALIB_EDEGENERATE);
	assert_body_zero(&b);
	set_ctx("paper, head rolled 90 degrees");
	quat_from_axis_angle(&y, 90 * DEG2RAD, &q_roll);
	assert_rc(calib_paper(&head, &hand, &q_roll, CALIB_HAND_RATIO, &b), CALIB_EDEGENERATE);
	assert_body_zero(&b);

	/* the hand straight below the head: no shoulder width */
	set_ctx("paper, hand below the head");
	{
		const struct vec3 below = { 0, 0.25, 1.2 };

		assert_rc(calib_paper(&head, &below, NULL, CALIB_HAND_RATIO, &b), CALIB_ERANGE);
		assert_body_zero(&b);
	}
	/* finite input whose difference overflows */
	set_ctx("paper, huge coordinates");
	{
		const struct vec3 far1 = { 1e308, 0, 0 }, far2 = { -1e308, 0, 0 };

		assert_rc(calib_paper(&far1, &far2, NULL, CALIB_HAND_RATIO, &b), CALIB_ERANGE);
		assert_body_zero(&b);
	}
}

/* ---- our multi-pose fit --------------------------------------------------------------- */

static const enum calib_pose set_ifd[] = { CALIB_POSE_INITIAL, CALIB_POSE_DOWN, CALIB_POSE_FORWARD };
static const enum calib_pose set_is[] = { CALIB_POSE_INITIAL, CALIB_POSE_SIDE };
static const enum calib_pose set_all[] = { CALIB_POSE_SIDE, CALIB_POSE_FORWARD, CALIB_POSE_INITIAL, CALIB_POSE_DOWN };

static void test_poses_exact(void **state)
{
	const struct {
		const enum calib_pose *p;
		size_t n;
		const char *name;
	} sets[] = {
		{ set_ifd, 3, "initial+down+forward" },
		{ set_is, 2, "initial+side" },
		{ set_all, 4, "all four" },
	};
	int k;

	(void)state;
	rng_seed(2);
	for (k = 0; k < 300; k++) {
		const double hand = (k % 3 == 0) ? 0 : rnd_range(0, 0.1);
		struct person p;
		size_t s, i;

		random_person(&p, hand);
		for (s = 0; s < 3; s++) {
			struct calib_obs o[4];
			struct calib_body b;

			/* every pose at its own place and heading: the person turns and steps */
			for (i = 0; i < sets[s].n; i++) {
				struct place w;

				random_place(&w);
				make_obs(&p, sets[s].p[i], &w, &o[i]);
			}
			set_ctx("person %d, %s, H %.3f", k, sets[s].name, hand);
			memset(&b, 0x55, sizeof(b));
			assert_rc(calib_poses(o, sets[s].n, hand, &b), CALIB_OK);
			assert_body(&b, &p, 1e-12);
			assert_near(b.rms, 0, 1e-12);
		}
	}
}

/* repeats are averaged; order does not matter */
static void test_poses_repeats(void **state)
{
	struct person p;
	struct calib_obs o[9];
	struct calib_body b1, b2;
	size_t i;

	(void)state;
	rng_seed(3);
	random_person(&p, 0);
	for (i = 0; i < 9; i++) {
		struct place w;

		random_place(&w);
		make_obs(&p, set_ifd[i % 3], &w, &o[i]);
		jitter(&o[i].head, 0.003);
		jitter(&o[i].lhand, 0.003);
		jitter(&o[i].rhand, 0.003);
	}
	set_ctx("nine readings");
	assert_rc(calib_poses(o, 9, 0, &b1), CALIB_OK);
	/* reverse the order */
	for (i = 0; i < 4; i++) {
		struct calib_obs t = o[i];

		o[i] = o[8 - i];
		o[8 - i] = t;
	}
	assert_rc(calib_poses(o, 9, 0, &b2), CALIB_OK);
	assert_near(b2.dims.shoulder, b1.dims.shoulder, 1e-12);
	assert_near(b2.dims.arm, b1.dims.arm, 1e-12);
	assert_near(b2.dims.forearm, b1.dims.forearm, 1e-12);
	assert_near(b2.head_offset.z, b1.head_offset.z, 1e-12);
	assert_near(b2.head_offset.y, b1.head_offset.y, 1e-12);
	assert_near(b2.rms, b1.rms, 1e-12);
	assert_true(b1.rms > 0.0005 && b1.rms < 0.003);
}

/*
 * Sensor noise: +-2 mm uniform on every coordinate (sd 1.15 mm). Arm and
 * Neck are differences of readings, so one estimate may be off by twice the
 * noise; every estimate must stay within 6 mm, their mean errors within
 * 1.5 mm, and rms must see the noise.
 */
static void test_poses_noise(void **state)
{
	double sum[7] = { 0 }, worst = 0, rms_sum = 0;
	const int trials = 500;
	int k, j;

	(void)state;
	rng_seed(4);
	for (k = 0; k < trials; k++) {
		struct person p;
		struct calib_obs o[3];
		struct calib_body b;
		double e[7];
		size_t i;

		random_person(&p, 0);
		for (i = 0; i < 3; i++) {
			struct place w;

			random_place(&w);
			make_obs(&p, set_ifd[i], &w, &o[i]);
			jitter(&o[i].head, 0.002);
			jitter(&o[i].lhand, 0.002);
			jitter(&o[i].rhand, 0.002);
		}
		set_ctx("noisy trial %d", k);
		assert_rc(calib_poses(o, 3, 0, &b), CALIB_OK);
		assert_body(&b, &p, 0.006);
		/* each residual is a difference of two readings: within 4 mm per coordinate */
		assert_true(b.rms > 0 && b.rms < 0.004);
		rms_sum += b.rms;
		e[0] = b.dims.shoulder - p.dims.shoulder;
		e[1] = b.dims.arm - p.dims.arm;
		e[2] = b.dims.forearm - p.dims.forearm;
		e[3] = b.head_offset.z - p.neck;
		e[4] = b.head_offset.x - p.head_right;
		e[5] = b.head_offset.y - p.head_fwd;
		e[6] = b.dims.hand - p.dims.hand;
		for (j = 0; j < 7; j++) {
			sum[j] += fabs(e[j]);
			worst = fmax(worst, fabs(e[j]));
		}
	}
	set_ctx("mean errors over %d noisy trials (worst %.4f)", trials, worst);
	for (j = 0; j < 7; j++)
		assert_near(sum[j] / trials, 0, 0.0015);
	assert_near(sum[6], 0, 0); /* H is an input */
	/* uniform +-2 mm has sd 1.15 mm; the residual keeps 12 of 18 degrees of freedom per hand pair */
	assert_near(rms_sum / trials, 0.00085, 0.00025);
}

/*
 * Posing noise: every arm segment off its pose direction by up to 3 degrees.
 * The fit is linear in the readings, so the errors stay of the order of
 * segment length times angle (about 1.5 cm at most) and rms grows with them.
 */
static void test_poses_posing_error(void **state)
{
	int k;

	(void)state;
	rng_seed(5);
	for (k = 0; k < 300; k++) {
		struct person p;
		struct calib_obs o[3];
		struct calib_body b;
		size_t i;

		random_person(&p, 0);
		for (i = 0; i < 3; i++) {
			struct place w;
			struct arm a;
			struct dq ee;
			struct vec3 r, l, h = { p.head_right, p.head_fwd, p.neck };
			double q[ARM_DOF];
			int j;

			random_place(&w);
			for (j = 0; j < 2; j++) {
				arm_init(&a, j ? ARM_LEFT : ARM_RIGHT, &p.dims, NULL);
				pose_q(set_ifd[i], q);
				q[1] += rnd_range(-3, 3) * DEG2RAD;
				q[2] += rnd_range(-3, 3) * DEG2RAD;
				q[4] += rnd_range(-3, 3) * DEG2RAD;
				if (q[4] < -90 * DEG2RAD)
					q[4] = -180 * DEG2RAD - q[4]; /* no hyperextension: mirror back */
				arm_fk(&a, q, &ee);
				dq_translation(&ee, j ? &l : &r);
			}
			o[i].pose = set_ifd[i];
			to_world(&w, &h, &o[i].head);
			to_world(&w, &r, &o[i].rhand);
			to_world(&w, &l, &o[i].lhand);
		}
		set_ctx("posing error trial %d", k);
		assert_rc(calib_poses(o, 3, 0, &b), CALIB_OK);
		assert_body(&b, &p, 0.03);
		assert_true(b.rms < 0.02);
	}
}

/*
 * The result feeds the avatar: with the calibrated dims and head offset,
 * avatar_chest() puts the chest where it was, and the chain reaches the
 * hand sensors of every pose from there.
 */
static void test_poses_feed_avatar(void **state)
{
	const struct vec3 z = { 0, 0, 1 };
	int k;

	(void)state;
	rng_seed(8);
	for (k = 0; k < 50; k++) {
		struct person p;
		struct place w[3];
		struct calib_obs o[3];
		struct calib_body b;
		struct avatar av;
		size_t i;

		random_person(&p, k % 2 ? 0.07 : 0);
		for (i = 0; i < 3; i++) {
			random_place(&w[i]);
			make_obs(&p, set_ifd[i], &w[i], &o[i]);
		}
		set_ctx("avatar person %d", k);
		assert_rc(calib_poses(o, 3, p.dims.hand, &b), CALIB_OK);
		avatar_init(&av, &b.dims, &b.head_offset, NULL);
		for (i = 0; i < 3; i++) {
			struct dq head, chest, ee, world;
			struct quat hq;
			struct vec3 c, want, zero = { 0, 0, 0 }, hand;
			double q[ARM_DOF];
			sc_t yaw;
			int side;

			/* the head looks straight ahead: its orientation is the chest's yaw */
			quat_from_axis_angle(&z, w[i].yaw, &hq);
			dq_from_rt(&hq, &o[i].head, &head);
			assert_true(avatar_chest(&av, &head, &chest, &yaw));
			dq_translation(&chest, &c);
			to_world(&w[i], &zero, &want);
			assert_near(c.x, want.x, 1e-12);
			assert_near(c.y, want.y, 1e-12);
			assert_near(c.z, want.z, 1e-12);
			pose_q(set_ifd[i], q);
			for (side = 0; side < 2; side++) {
				const struct vec3 *sensor = side ? &o[i].lhand : &o[i].rhand;

				arm_fk(&av.arm[side], q, &ee);
				dq_mul(&chest, &ee, &world);
				dq_translation(&world, &hand);
				assert_near(hand.x, sensor->x, 1e-12);
				assert_near(hand.y, sensor->y, 1e-12);
				assert_near(hand.z, sensor->z, 1e-12);
			}
		}
	}
}

static void test_poses_underdetermined(void **state)
{
	static const enum calib_pose only_i[] = { CALIB_POSE_INITIAL, CALIB_POSE_INITIAL };
	static const enum calib_pose i_d[] = { CALIB_POSE_INITIAL, CALIB_POSE_DOWN };
	static const enum calib_pose i_f[] = { CALIB_POSE_INITIAL, CALIB_POSE_FORWARD };
	static const enum calib_pose d_f_s[] = { CALIB_POSE_DOWN, CALIB_POSE_FORWARD, CALIB_POSE_SIDE };
	const struct {
		const enum calib_pose *p;
		size_t n;
		const char *name;
	} sets[] = {
		{ only_i, 1, "initial" },
		{ only_i, 2, "initial twice" },
		{ i_d, 2, "initial+down (Neck vs Arm)" },
		{ i_f, 2, "initial+forward (Forearm vs head offset)" },
		{ d_f_s, 3, "down+forward+side (Arm vs Forearm)" },
	};
	struct person p;
	size_t s, i;

	(void)state;
	rng_seed(6);
	random_person(&p, 0);
	for (s = 0; s < sizeof(sets) / sizeof(sets[0]); s++) {
		struct calib_obs o[3];
		struct calib_body b;

		for (i = 0; i < sets[s].n; i++) {
			struct place w;

			random_place(&w);
			make_obs(&p, sets[s].p[i], &w, &o[i]);
		}
		set_ctx("%s", sets[s].name);
		memset(&b, 0x55, sizeof(b));
		assert_rc(calib_poses(o, sets[s].n, 0, &b), CALIB_EUNDERDET);
		assert_body_zero(&b);
	}
}

static void test_poses_bad_input(void **state)
{
	const double bad[] = { NAN, INFINITY, -INFINITY };
	struct person p;
	struct calib_obs o[3], t[3];
	struct calib_body b;
	size_t i, c, v;

	(void)state;
	rng_seed(7);
	random_person(&p, 0);
	for (i = 0; i < 3; i++) {
		struct place w;

		random_place(&w);
		make_obs(&p, set_ifd[i], &w, &o[i]);
	}
	set_ctx("clean readings");
	assert_rc(calib_poses(o, 3, 0, &b), CALIB_OK);

	/* any NaN or inf anywhere */
	for (i = 0; i < 3; i++)
		for (c = 0; c < 9; c++)
			for (v = 0; v < 3; v++) {
				struct vec3 *s;

				memcpy(t, o, sizeof(t));
				s = c < 3 ? &t[i].head : c < 6 ? &t[i].lhand : &t[i].rhand;
				(&s->x)[c % 3] = bad[v];
				set_ctx("reading %zu, coordinate %zu = %g", i, c, bad[v]);
				memset(&b, 0x55, sizeof(b));
				assert_rc(calib_poses(t, 3, 0, &b), CALIB_EINVAL);
				assert_body_zero(&b);
			}

	set_ctx("NULL and empty");
	assert_rc(calib_poses(NULL, 3, 0, &b), CALIB_EINVAL);
	assert_body_zero(&b);
	assert_rc(calib_poses(o, 0, 0, &b), CALIB_EINVAL);
	assert_body_zero(&b);
	assert_rc(calib_poses(o, 3, 0, NULL), CALIB_EINVAL);

	set_ctx("bad hand length");
	assert_rc(calib_poses(o, 3, -0.01, &b), CALIB_EINVAL);
	assert_body_zero(&b);
	assert_rc(calib_poses(o, 3, NAN, &b), CALIB_EINVAL);
	assert_rc(calib_poses(o, 3, INFINITY, &b), CALIB_EINVAL);
	/* a hand longer than the measured forearm + hand */
	assert_rc(calib_poses(o, 3, 1.0, &b), CALIB_ERANGE);
	assert_body_zero(&b);

	set_ctx("unknown pose");
	memcpy(t, o, sizeof(t));
	t[1].pose = (enum calib_pose)CALIB_NPOSES;
	assert_rc(calib_poses(t, 3, 0, &b), CALIB_EINVAL);
	assert_body_zero(&b);

	set_ctx("coincident hands");
	memcpy(t, o, sizeof(t));
	t[2].lhand = t[2].rhand;
	memset(&b, 0x55, sizeof(b));
	assert_rc(calib_poses(t, 3, 0, &b), CALIB_EDEGENERATE);
	assert_body_zero(&b);

	set_ctx("hands one above the other");
	memcpy(t, o, sizeof(t));
	t[0].lhand = t[0].rhand;
	t[0].lhand.z += 0.4;
	assert_rc(calib_poses(t, 3, 0, &b), CALIB_EDEGENERATE);
	assert_body_zero(&b);

	set_ctx("all sensors at one point");
	for (i = 0; i < 3; i++) {
		t[i].pose = set_ifd[i];
		t[i].head = t[i].lhand = t[i].rhand = (struct vec3){ 1, 2, 3 };
	}
	assert_rc(calib_poses(t, 3, 0, &b), CALIB_EDEGENERATE);
	assert_body_zero(&b);

	/* left and right swapped: the person seems to face backwards, lengths come out negative */
	set_ctx("hands swapped");
	memcpy(t, o, sizeof(t));
	for (i = 0; i < 3; i++) {
		struct vec3 s = t[i].lhand;

		t[i].lhand = t[i].rhand;
		t[i].rhand = s;
	}
	assert_rc(calib_poses(t, 3, 0, &b), CALIB_ERANGE);
	assert_body_zero(&b);

	/* poses mislabelled: forward labelled down and back */
	set_ctx("poses mislabelled");
	memcpy(t, o, sizeof(t));
	t[1].pose = CALIB_POSE_FORWARD;
	t[2].pose = CALIB_POSE_DOWN;
	memset(&b, 0x55, sizeof(b));
	{
		int rc = calib_poses(t, 3, 0, &b);

		assert_body_finite(&b);
		if (rc == CALIB_OK)
			assert_true(b.rms > 0.05);
		else
			assert_rc(rc, CALIB_ERANGE);
	}

	/* a head sensor below the shoulder line (say, worn on the belt) */
	set_ctx("head below the shoulders");
	{
		struct person low = p;

		low.neck = -0.05;
		for (i = 0; i < 3; i++) {
			struct place w;

			random_place(&w);
			make_obs(&low, set_ifd[i], &w, &t[i]);
		}
		memset(&b, 0x55, sizeof(b));
		assert_rc(calib_poses(t, 3, 0, &b), CALIB_ERANGE);
		assert_body_zero(&b);
	}

	set_ctx("huge coordinates");
	memcpy(t, o, sizeof(t));
	t[0].rhand.x = 1e308;
	t[0].lhand.x = -1e308;
	assert_rc(calib_poses(t, 3, 0, &b), CALIB_ERANGE);
	assert_body_zero(&b);
}

static void test_heading(void **state)
{
	const struct vec3 x = { 1, 0, 0 }, y = { 0, 1, 0 }, z = { 0, 0, 1 };
	struct quat q, q2, q3;
	struct vec3 r;
	int k;

	(void)state;
	set_ctx("heading");
	for (k = -170; k <= 180; k += 10) {
		quat_from_axis_angle(&z, k * DEG2RAD, &q);
		/* looking down 60 degrees and tilting the head 30 degrees change nothing */
		quat_from_axis_angle(&x, -60 * DEG2RAD, &q2);
		quat_mul(&q, &q2, &q3);
		assert_true(calib_heading(&q3, &r));
		assert_near(r.x, cos(k * DEG2RAD), 1e-12);
		assert_near(r.y, sin(k * DEG2RAD), 1e-12);
		assert_near(r.z, 0, 0);
		quat_from_axis_angle(&y, 30 * DEG2RAD, &q2);
		quat_mul(&q, &q2, &q3);
		/* an unnormalised quaternion is fine */
		q3.w *= 3;
		q3.x *= 3;
		q3.y *= 3;
		q3.z *= 3;
		assert_true(calib_heading(&q3, &r));
		assert_near(r.x, cos(k * DEG2RAD), 1e-12);
		assert_near(r.y, sin(k * DEG2RAD), 1e-12);
	}
	quat_from_axis_angle(&y, 88 * DEG2RAD, &q);
	assert_false(calib_heading(&q, &r));
	assert_near(r.x, 1, 0);
	assert_near(r.y, 0, 0);
	q = (struct quat){ NAN, 0, 0, 0 };
	assert_false(calib_heading(&q, &r));
	q = (struct quat){ 0, 0, 0, 0 };
	assert_false(calib_heading(&q, &r));
	assert_near(r.x, 1, 0);
}

static void test_strerror(void **state)
{
	const int codes[] = { CALIB_OK, CALIB_EINVAL, CALIB_EDEGENERATE, CALIB_EUNDERDET, CALIB_ERANGE };
	size_t i, j;

	(void)state;
	for (i = 0; i < 5; i++) {
		assert_non_null(calib_strerror(codes[i]));
		for (j = 0; j < i; j++)
			assert_string_not_equal(calib_strerror(codes[i]), calib_strerror(codes[j]));
	}
	assert_non_null(calib_strerror(12345));
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_pose_table),	  cmocka_unit_test(test_paper_exact),
		cmocka_unit_test(test_paper_formula),	  cmocka_unit_test(test_paper_bad_input),
		cmocka_unit_test(test_poses_exact),	  cmocka_unit_test(test_poses_repeats),
		cmocka_unit_test(test_poses_noise),	  cmocka_unit_test(test_poses_posing_error),
		cmocka_unit_test(test_poses_feed_avatar), cmocka_unit_test(test_poses_underdetermined),
		cmocka_unit_test(test_poses_bad_input),	  cmocka_unit_test(test_heading),
		cmocka_unit_test(test_strerror),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
