// SPDX-License-Identifier: MIT
/*
 * sim.c - synthetic people: head and hands moving like a person standing
 * and gesturing, for any number of people, with no hardware.
 *
 * The motion is made in joint space, inside the default human limits, and
 * turned into sensor poses with the same forward kinematics the avatar
 * uses (default body): every simulated hand is reachable, and an avatar
 * with the default body reproduces the motion exactly. Head yaw, pitch,
 * roll and position sway slowly; each arm joint follows a sum of two sines.
 * All frequencies are whole multiples of 1/SIM_CYCLE_S so the motion loops
 * without a seam, and one cycle is tabulated at open(): a poll costs a table
 * read per person, whatever the number of people. Person k reads the table
 * at its own offset (a fixed stride), stands k * spacing along x, and moves
 * with its own phase.
 */
#include "trackers/tracker.h"
#include "trackers/sim.h"
#include "base/clock.h"

#include "ik/arm.h"
#include "ik/avatar.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <stdbool.h>
#include <unistd.h>

static const struct cfg_key sim_keys[] = {
	{ .name = "people",
	  .kind = CFG_INT,
	  CFG_AT(struct sim_opts, people),
	  .min = 1,
	  .max = CFG_MAX_AVATARS,
	  .def = "1",
	  .doc = "simulated people; their sensors are pN.head, pN.left_hand, pN.right_hand" },
	{ .name = "seed",
	  .kind = CFG_U32,
	  CFG_AT(struct sim_opts, seed),
	  .min = 0,
	  .max = 4294967295.0,
	  .def = "1",
	  .doc = "seed of the motion (same seed, same motion)" },
	{ .name = "sample_rate",
	  .kind = CFG_DOUBLE,
	  CFG_AT(struct sim_opts, sample_rate),
	  .min = 1,
	  .max = 4000,
	  .def = "240",
	  .unit = "Hz",
	  .doc = "sensor samples per second (replay: made between keyframes when interpolate is set)" },
	{ .name = "spacing",
	  .kind = CFG_DOUBLE,
	  CFG_AT(struct sim_opts, spacing),
	  .min = 0,
	  .max = 100,
	  .def = "1",
	  .unit = "m",
	  .doc = "distance between simulated people along x" },
};

static const struct sim_opts *opts_of(const struct cfg_source *c)
{
	return c->opt;
}

#define SIM_CYCLE_S 20.0
#define SIM_ROLES 3

struct sim {
	int people;
	int n_table;	  /* samples per cycle */
	struct dq *table; /* [n_table][3]: head, left hand, right hand at the origin */
	uint64_t period_ns;
	uint64_t t0_ns; /* CLOCK_MONOTONIC of sample 0 */
	int64_t last;	/* last sample index delivered */
	int tfd;
	bool tfd_used; /* an event-mode loop waits on tfd (sim_fd was asked) */
};

static const char *const roles[SIM_ROLES] = { "head", "left_hand", "right_hand" };

static int sim_sensor_count(const struct cfg_source *cfg)
{
	return opts_of(cfg)->people * SIM_ROLES;
}

static void sim_sensor_name(const struct cfg_source *cfg, int i, char *buf, size_t len)
{
	(void)cfg;
	snprintf(buf, len, "p%d.%s", i / SIM_ROLES, roles[i % SIM_ROLES]);
}

/* a smooth pseudo-random phase from the seed */
static double phase(uint32_t seed, int i)
{
	uint32_t x = seed * 2654435761u + (uint32_t)i * 40503u + 0x9e3779b9u;

	x ^= x >> 15;
	x *= 0x2c1b3c6du;
	x ^= x >> 12;
	return (double)(x % 100000u) / 100000.0 * 2 * M_PI;
}

/* whole cycles per SIM_CYCLE_S: frequency k / SIM_CYCLE_S Hz */
static double wave(double t, int cycles, double ph)
{
	return sin(2 * M_PI * cycles * t / SIM_CYCLE_S + ph);
}

static void sim_pose_at(const struct avatar *av, uint32_t seed, double t, struct dq out[SIM_ROLES])
{
	static const int cyc[ARM_DOF][2] = { { 3, 7 },	{ 4, 9 },  { 5, 11 }, { 3, 8 },
					     { 6, 13 }, { 4, 10 }, { 7, 15 }, { 5, 12 } };
	double yaw = 0.45 * wave(t, 2, phase(seed, 100)) + 0.1 * wave(t, 5, phase(seed, 101));
	double pitch = 0.12 * wave(t, 3, phase(seed, 102));
	double roll = 0.05 * wave(t, 4, phase(seed, 103));
	struct vec3 hp = { 0.04 * wave(t, 1, phase(seed, 104)), 0.03 * wave(t, 2, phase(seed, 105)),
			   1.55 + 0.01 * wave(t, 6, phase(seed, 106)) };
	struct quat qy = { cos(yaw / 2), 0, 0, sin(yaw / 2) }, qp = { cos(pitch / 2), sin(pitch / 2), 0, 0 },
		    qr = { cos(roll / 2), 0, sin(roll / 2), 0 }, tmp, hr;
	struct dq chest;
	sc_t cy;

	/* head: yaw about world z, then pitch about its x, roll about its y */
	quat_mul(&qy, &qp, &tmp);
	quat_mul(&tmp, &qr, &hr);
	dq_from_rt(&hr, &hp, &out[0]);
	avatar_chest(av, &out[0], &chest, &cy);
	for (int side = 0; side < 2; side++) {
		const struct arm *a = &av->arm[side];
		sc_t q[ARM_DOF];
		struct dq local;

		for (int j = 0; j < ARM_DOF; j++) {
			double mid = 0.5 * (a->lim.lo[j] + a->lim.hi[j]), half = 0.5 * (a->lim.hi[j] - a->lim.lo[j]);
			double s = 0.6 * wave(t, cyc[j][0], phase(seed, 10 * side + j)) +
				   0.25 * wave(t, cyc[j][1], phase(seed, 50 + 10 * side + j));

			/* arms hang lower than mid-range most of the time: flexion and abduction biased down */
			if (j == 1)
				mid += 0.25 * half;
			if (j == 2)
				mid -= 0.3 * half;
			q[j] = mid + 0.8 * half * s;
			if (q[j] < a->lim.lo[j])
				q[j] = a->lim.lo[j];
			if (q[j] > a->lim.hi[j])
				q[j] = a->lim.hi[j];
		}
		arm_fk(a, q, &local);
		/* ARM_RIGHT = 0 -> right hand (role 2), ARM_LEFT = 1 -> left hand (role 1) */
		dq_mul(&chest, &local, &out[side == ARM_RIGHT ? 2 : 1]);
	}
}

static int sim_open(struct tracker *t, char *err, size_t errlen)
{
	const struct cfg_source *cfg = t->cfg;
	struct sim *s = calloc(1, sizeof(*s));
	const struct arm_dims dims = { 0.1732, 0.2886, 0.1955, 0.0 };
	const struct vec3 head_off = { 0.008, -0.0386, 0.0967 };
	struct avatar av;

	if (!s) {
		snprintf(err, errlen, "[source %s]: out of memory", cfg->name);
		return -ENOMEM;
	}
	s->people = opts_of(cfg)->people;
	s->n_table = (int)lround(SIM_CYCLE_S * opts_of(cfg)->sample_rate);
	s->table = malloc((size_t)s->n_table * SIM_ROLES * sizeof(*s->table));
	if (!s->table) {
		free(s);
		snprintf(err, errlen, "[source %s]: out of memory", cfg->name);
		return -ENOMEM;
	}
	avatar_init(&av, &dims, &head_off, NULL);
	for (int i = 0; i < s->n_table; i++)
		sim_pose_at(&av, opts_of(cfg)->seed, i / opts_of(cfg)->sample_rate, &s->table[i * SIM_ROLES]);
	s->period_ns = (uint64_t)llround(1e9 / opts_of(cfg)->sample_rate);
	s->t0_ns = mono_ns();
	s->last = -1;
	s->tfd = periodic_timerfd(s->period_ns);
	t->priv = s;
	return 0;
}

static void sim_close(struct tracker *t)
{
	struct sim *s = t->priv;

	if (!s)
		return;
	if (s->tfd >= 0)
		close(s->tfd);
	free(s->table);
	free(s);
	t->priv = NULL;
}

static int sim_poll(struct tracker *t, const struct tracker_clock *now)
{
	struct sim *s = t->priv;
	int64_t n;
	uint64_t t_ns;

	if (s->tfd_used) {
		/*
		 * One read takes every expiration since the last; a periodic loop
		 * never waits on it. Read first, whatever this poll puts: the timer
		 * fires a little after each period starts (it was armed after t0),
		 * so a cycle woken by another source may take the period's samples
		 * before the timer fires; its expiration, left unread, would keep
		 * an event loop spinning until the next period.
		 */
		uint64_t exp;
		ssize_t rd = read(s->tfd, &exp, sizeof(exp));

		(void)rd;
	}
	if (now->mono_ns < s->t0_ns)
		return 0;
	n = (int64_t)((now->mono_ns - s->t0_ns) / s->period_ns);
	if (n == s->last)
		return 0;
	s->last = n;
	t_ns = (uint64_t)((int64_t)(s->t0_ns + (uint64_t)n * s->period_ns) + now->real_off_ns);
	for (int k = 0; k < s->people; k++) {
		/* each person at its own place in the cycle: a stride coprime with most table sizes */
		int64_t i = (n + (int64_t)k * 7919) % s->n_table;
		const struct dq *row = &s->table[i * SIM_ROLES];
		/* a pure translation along x: the dual part gains x/2 times the rotation */
		sc_t hx = SC_C(0.5) * k * opts_of(t->cfg)->spacing;

		for (int r = 0; r < SIM_ROLES; r++) {
			struct dq placed = row[r];
			const struct quat *q = &row[r].r;

			placed.d.w -= hx * q->x;
			placed.d.x += hx * q->w;
			placed.d.y -= hx * q->z;
			placed.d.z += hx * q->y;
			tracker_put(t, k * SIM_ROLES + r, &placed, t_ns, now->mono_ns);
		}
	}
	return s->people * SIM_ROLES;
}

static int sim_fd(struct tracker *t)
{
	struct sim *s = t->priv;

	s->tfd_used = s->tfd >= 0;
	return s->tfd;
}

const struct tracker_driver sim_driver = {
	.type = { CFG_TYPE("sim", "synthetic human-like head and hand motion, any number of people", sim_keys,
			   struct sim_opts),
		  .sensor_count = sim_sensor_count, .sensor_name = sim_sensor_name },
	.open = sim_open,
	.close = sim_close,
	.poll = sim_poll,
	.fd = sim_fd,
};
