// SPDX-License-Identifier: MIT
/*
 * gwtest.c - see gwtest.h.
 */
#include "fake/gwtest.h"

#include "trackers/device.h"

#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <string.h>
#include <time.h>

uint64_t gwt_ms(void)
{
	return mono_ns() / 1000000ull;
}

void gwt_sleep_ms(int ms)
{
	struct timespec ts = { ms / 1000, (ms % 1000) * 1000000L };

	while (nanosleep(&ts, &ts))
		;
}

static struct gwt *gwt_current;

void gwt_open(struct gwt *t, const char *conf)
{
	struct config c;
	char err[1024];

	memset(t, 0, sizeof(*t));
	if (config_load_text(&c, "test.conf", conf, err, sizeof(err)))
		fail_msg("configuration: %s", err);
	if (gw_open(&t->g, &c, NULL, 7, err, sizeof(err)))
		fail_msg("gw_open: %s", err);
	t->open = true;
	gwt_current = t;
}

void gwt_close(struct gwt *t)
{
	if (t->open)
		gw_close(&t->g);
	t->open = false;
	if (gwt_current == t)
		gwt_current = NULL;
}

int gwt_teardown(void **state)
{
	(void)state;
	if (gwt_current)
		gwt_close(gwt_current);
	return 0;
}

static bool finite_pose(const struct wire_pose *p)
{
	for (int k = 0; k < 3; k++)
		if (!isfinite(p->p[k]))
			return false;
	for (int k = 0; k < 4; k++)
		if (!isfinite(p->q[k]))
			return false;
	return true;
}

static bool nan_pose(const struct wire_pose *p)
{
	for (int k = 0; k < 3; k++)
		if (!isnan(p->p[k]))
			return false;
	for (int k = 0; k < 4; k++)
		if (!isnan(p->q[k]))
			return false;
	return true;
}

/* what a client may rely on (docs/PROTOCOL.md): the test fails on anything else */
static void check_frame(const struct wire_frame *f)
{
	bool posture = true;

	for (int i = 0; i < WIRE_SENSORS; i++) {
		const struct wire_sensor_sample *s = &f->sensor[i];

		if (s->state == WIRE_SENSOR_MISSING) {
			if (!nan_pose(&s->pose))
				fail_msg("sensor %d MISSING with a pose that is not NaN", i);
			continue;
		}
		if (s->state != WIRE_SENSOR_OK && s->state != WIRE_SENSOR_STALE)
			fail_msg("sensor %d: state %u", i, s->state);
		if (!finite_pose(&s->pose))
			fail_msg("sensor %d (state %u): a pose that is not finite", i, s->state);
		double qn = 0, pn = 0;

		for (int k = 0; k < 4; k++)
			qn += (double)s->pose.q[k] * s->pose.q[k];
		for (int k = 0; k < 3; k++)
			pn += (double)s->pose.p[k] * s->pose.p[k];
		if (fabs(qn - 1) > 1e-4)
			fail_msg("sensor %d: quaternion of norm^2 %g", i, qn);
		if (pn > 5.0 * 5.0)
			fail_msg("sensor %d: at %g m from the origin: not a person in the room", i, sqrt(pn));
		if (!(f->h.flags & WIRE_F_STALE) && s->state != WIRE_SENSOR_OK)
			fail_msg("sensor %d not OK and no STALE flag", i);
	}
	for (int j = 0; j < WIRE_JOINTS; j++)
		if (!isfinite(f->joint[j]))
			posture = false;
	if (!posture) {
		if (!(f->h.flags & WIRE_F_UNREACHED))
			fail_msg("joints not finite without UNREACHED");
		for (int j = 0; j < WIRE_JOINTS; j++)
			if (!isnan(f->joint[j]))
				fail_msg("some joints finite, others not");
	} else {
		for (int s = 0; s < WIRE_SEGMENTS; s++)
			if (s != WIRE_SEG_HEAD && !finite_pose(&f->segment[s]))
				fail_msg("segment %d not finite", s);
	}
	if (f->h.flags & WIRE_F_INPUTS)
		for (int i = 0; i < WIRE_SENSORS; i++)
			for (int k = 0; k < WIRE_ANALOG; k++)
				if (!isfinite(f->in.analog[i][k]) || fabsf(f->in.analog[i][k]) > 1.0f)
					fail_msg("sensor %d analog %d: %g", i, k, (double)f->in.analog[i][k]);
}

void gwt_cycle(struct gwt *t)
{
	struct tracker_clock now;
	int n, rc;

	gw_clock(&now);
	n = gw_cycle(&t->g, &now);
	if (n != t->g.n_avatars)
		fail_msg("a cycle published %d frames for %d avatars", n, t->g.n_avatars);
	rc = wire_decode_frame(t->g.msgs[0].data, t->g.msgs[0].len, &t->f);
	if (rc)
		fail_msg("the published FRAME does not decode: %s", wire_strerror(rc));
	check_frame(&t->f);
	t->frames++;
}

int gwt_until(struct gwt *t, bool (*pred)(struct gwt *t, void *arg), void *arg, int ms)
{
	uint64_t t0 = gwt_ms();

	for (;;) {
		gwt_cycle(t);
		if (pred(t, arg))
			return (int)(gwt_ms() - t0);
		if (gwt_ms() - t0 > (uint64_t)ms)
			return -1;
		gwt_sleep_ms(2);
	}
}

void gwt_run(struct gwt *t, int ms)
{
	uint64_t t0 = gwt_ms();

	while (gwt_ms() - t0 < (uint64_t)ms) {
		gwt_cycle(t);
		gwt_sleep_ms(2);
	}
}

struct tracker *gwt_tracker(struct gwt *t, const char *name)
{
	for (int i = 0; i < t->g.n_trackers; i++)
		if (!strcmp(t->g.trk[i].name, name))
			return &t->g.trk[i];
	fail_msg("no tracker %s", name);
	return NULL;
}

uint32_t gwt_state(struct gwt *t, const char *name)
{
	return atomic_load(&gwt_tracker(t, name)->st.state);
}

void gwt_take_notes(struct gwt *t)
{
	for (int i = 0; i < t->g.n_trackers; i++) {
		struct tracker *tr = &t->g.trk[i];
		char text[DEVICE_NOTE_LEN];
		int level;

		while (tr->drv->note && tr->drv->note(tr, &level, text, sizeof(text))) {
			size_t n = strlen(t->notes);

			snprintf(t->notes + n, sizeof(t->notes) - n, "%s\n", text);
		}
	}
}

bool gwt_tracker_ok(struct gwt *t, void *name)
{
	return gwt_state(t, name) == TRACKER_OK;
}

bool gwt_tracker_faulty(struct gwt *t, void *name)
{
	return gwt_state(t, name) == TRACKER_FAULTY;
}

bool gwt_tracker_stale(struct gwt *t, void *name)
{
	return gwt_state(t, name) == TRACKER_STALE;
}

bool gwt_tracker_ended(struct gwt *t, void *name)
{
	return gwt_state(t, name) == TRACKER_ENDED;
}
