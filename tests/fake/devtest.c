// SPDX-License-Identifier: MIT
/*
 * devtest.c - see devtest.h.
 */
#include "fake/devtest.h"

#include "fake/fake.h"

#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* the source in state, and each of its sensors in the last FRAME in sensor_state */
static bool in_state(struct gwt *t, const struct devtest *dev, uint32_t state, uint8_t sensor_state)
{
	if (gwt_state(t, dev->source) != state)
		return false;
	for (int s = 0; s < WIRE_SENSORS; s++)
		if (dev->sensors & 1u << s && t->f.sensor[s].state != sensor_state)
			return false;
	return true;
}

struct reads_to {
	const struct devtest *dev;
	uint64_t n;
};

static bool read_to(struct gwt *t, void *arg)
{
	const struct reads_to *r = arg;

	(void)t;
	return r->dev->reads() >= r->n;
}

void devtest_run_reading(struct gwt *t, const struct devtest *dev, int ms, int n)
{
	struct reads_to r = { dev, dev->reads() + (uint64_t)n };

	gwt_run(t, ms);
	assert_true(gwt_until(t, read_to, &r, 5000) >= 0);
}

bool devtest_ok(struct gwt *t, void *dev)
{
	return in_state(t, dev, TRACKER_OK, WIRE_SENSOR_OK);
}

bool devtest_missing(struct gwt *t, void *dev)
{
	return in_state(t, dev, TRACKER_FAULTY, WIRE_SENSOR_MISSING);
}

bool devtest_stale(struct gwt *t, void *dev)
{
	return in_state(t, dev, TRACKER_STALE, WIRE_SENSOR_STALE);
}

/* the source OK: the FRAME has its sensors' inputs if they have any, and has none otherwise */
static void check_inputs(struct gwt *t, const struct devtest *dev)
{
	if (dev->inputs) {
		assert_true(t->f.h.flags & WIRE_F_INPUTS);
		assert_int_equal(t->f.in.present & dev->sensors, dev->sensors);
	} else {
		assert_false(t->f.h.flags & WIRE_F_INPUTS);
	}
}

struct tracker *devtest_up(struct gwt *t, const struct devtest *dev)
{
	dev->plug();
	gwt_open(t, dev->conf);
	assert_true(gwt_until(t, devtest_ok, (void *)dev, 5000) >= 0);
	check_inputs(t, dev);
	return gwt_tracker(t, dev->source);
}

static bool set_up(struct gwt *t, void *dev)
{
	(void)t;
	return ((const struct devtest *)dev)->set_up();
}

struct tracker *devtest_stepped(struct gwt *t, const struct devtest *dev, const char *conf)
{
	dev->stepped(true);
	dev->plug();
	gwt_open(t, conf);
	assert_true(gwt_until(t, set_up, (void *)dev, 3000) >= 0);
	return gwt_tracker(t, dev->source);
}

void devtest_unplug_replug(struct gwt *t, const struct devtest *dev)
{
	struct tracker *tr = devtest_up(t, dev);
	uint64_t f0;
	int ms;

	/* FAULTY from the start until the first sample (unless a sample beat the first cycle) */
	f0 = ctr_get(&tr->st.faults);
	assert_true(f0 <= 1);
	gwt_run(t, 200);
	dev->unplug();
	ms = gwt_until(t, devtest_missing, (void *)dev, 1000);
	print_message("[source %s] unplugged: FAULTY after %d ms\n", dev->source, ms);
	assert_true(ms >= 0);
	/* the daemon keeps running: the frames say STALE, the other sources' sensors track on */
	gwt_run(t, 300);
	assert_true(devtest_missing(t, (void *)dev));
	assert_true(t->f.h.flags & WIRE_F_STALE);
	for (int s = 0; s < WIRE_SENSORS; s++)
		if (!(dev->sensors & 1u << s))
			assert_int_equal(t->f.sensor[s].state, WIRE_SENSOR_OK);
	/* no inputs (the other sources have none); the avatar keeps a posture, its last one if the head went (HELD) */
	assert_false(t->f.h.flags & WIRE_F_INPUTS);
	for (int j = 0; j < WIRE_JOINTS; j++)
		assert_true(isfinite(t->f.joint[j]));
	if (dev->sensors & 1u << WIRE_S_HEAD)
		assert_true(t->f.h.flags & WIRE_F_HELD);
	assert_int_equal(ctr_get(&tr->st.faults), f0 + 1);
	/* replugged: found again by the driver itself */
	dev->plug();
	ms = gwt_until(t, devtest_ok, (void *)dev, 3000);
	print_message("[source %s] replugged: OK again after %d ms\n", dev->source, ms);
	assert_true(ms >= 0 && ms < 1000);
	assert_int_equal(ctr_get(&tr->st.reconnects), 1);
	assert_int_equal(ctr_get(&tr->st.faults), f0 + 1);
	gwt_take_notes(t);
	assert_non_null(strstr(t->notes, "unplugged"));
}

void devtest_denied(struct gwt *t, const struct devtest *dev)
{
	int ms;

	dev->deny_open(true);
	dev->plug();
	gwt_open(t, dev->conf);
	gwt_run(t, 300);
	assert_true(devtest_missing(t, (void *)dev));
	gwt_take_notes(t);
	assert_non_null(strstr(t->notes, "cannot open"));
	assert_non_null(strstr(t->notes, dev->denied));
	assert_non_null(strstr(t->notes, "60-avatargw.rules"));
	assert_non_null(strstr(t->notes, "group avatargw"));
	/* someone fixes the udev rule: the driver tries again by itself */
	dev->deny_open(false);
	ms = gwt_until(t, devtest_ok, (void *)dev, 3000);
	print_message("[source %s] permission granted: OK after %d ms\n", dev->source, ms);
	assert_true(ms >= 0);
}

/*
 * Cycles as the daemon's loop does, for ms or until the source is in
 * state (-1: the whole time); no FRAME decoded, the test's checks are not
 * the loop's. Whether it got there.
 */
static bool loop_until(struct gwt *t, const struct devtest *dev, int state, int ms)
{
	uint64_t t0 = gwt_ms();

	do {
		struct tracker_clock now;

		gw_clock(&now);
		gw_cycle(&t->g, &now);
		if (state >= 0 && gwt_state(t, dev->source) == (uint32_t)state)
			return true;
		gwt_sleep_ms(4);
	} while (gwt_ms() - t0 < (uint64_t)ms);
	return state < 0;
}

void devtest_loop_allocates_nothing(struct gwt *t, const struct devtest *dev)
{
	bool faulty, back;
	long n;

	devtest_up(t, dev);
	fake_alloc_count_start();
	loop_until(t, dev, -1, 400);
	/* the device thread allocates while it searches and reopens; the loop must not */
	dev->unplug();
	faulty = loop_until(t, dev, TRACKER_FAULTY, 1000);
	loop_until(t, dev, -1, 200);
	dev->plug();
	back = loop_until(t, dev, TRACKER_OK, 2000);
	loop_until(t, dev, -1, 200);
	n = fake_alloc_count_stop();
	assert_int_equal(n, 0);
	/* and all of that happened while they were counted */
	assert_true(faulty);
	assert_true(back);
	assert_true(gwt_until(t, devtest_ok, (void *)dev, 5000) >= 0);
	gwt_close(t);
}

char *devtest_listing(const struct devtest *dev, int want)
{
	char *text = NULL;
	size_t len = 0;
	FILE *out = open_memstream(&text, &len);

	assert_non_null(out);
	assert_int_equal(dev->drv->list_devices(out), want);
	fclose(out);
	return text;
}

void devtest_list_devices(const struct devtest *dev, const char *const *says)
{
	char *text, want[128];

	/* no device: nothing at all */
	text = devtest_listing(dev, 0);
	assert_string_equal(text, "");
	free(text);

	dev->plug();
	text = devtest_listing(dev, 1);
	print_message("%s", text);
	for (; *says; says++)
		assert_non_null(strstr(text, *says));
	snprintf(want, sizeof(want), "[source %s]\n  type = %s\n", dev->source, dev->source);
	assert_non_null(strstr(text, want));
	assert_null(strstr(text, "cannot open"));
	free(text);

	dev->deny_open(true);
	text = devtest_listing(dev, 1);
	snprintf(want, sizeof(want), "cannot open it: %s", dev->denied);
	assert_non_null(strstr(text, want));
	assert_non_null(strstr(text, "group avatargw"));
	free(text);
}

void devtest_capture(struct gwt *t, const struct devtest *dev, const char *conf, uint64_t samples)
{
	gwt_open(t, conf);
	assert_true(gwt_until(t, devtest_ok, (void *)dev, 5000) >= 0);
	check_inputs(t, dev);
	/* played at its speed to the end: the source ENDS and its last samples go STALE */
	assert_true(gwt_until(t, gwt_tracker_ended, (void *)dev->source, 10000) >= 0);
	gwt_run(t, 150);
	assert_int_equal(gwt_state(t, dev->source), TRACKER_ENDED);
	assert_int_equal(ctr_get(&gwt_tracker(t, dev->source)->st.samples), samples);
	for (int s = 0; s < WIRE_SENSORS; s++)
		if (dev->sensors & 1u << s)
			assert_int_equal(t->f.sensor[s].state, WIRE_SENSOR_STALE);
}

void devtest_pose(const struct device_sample *s, double p[3], double q[4])
{
	struct vec3 v;

	dq_translation(&s->pose, &v);
	p[0] = v.x;
	p[1] = v.y;
	p[2] = v.z;
	q[0] = s->pose.r.w;
	q[1] = s->pose.r.x;
	q[2] = s->pose.r.y;
	q[3] = s->pose.r.z;
}
