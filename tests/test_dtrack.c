// SPDX-License-Identifier: MIT
/*
 * test_dtrack.c - the DTrack source's decoder (trackers/dtrack.c) fed
 * frames written here from the published format: bodies in mm with a
 * rotation matrix column by column, Flysticks with buttons and joystick,
 * untracked bodies (quality < 0), bodies appearing and disappearing,
 * empty frames, CRLF, very long lines, datagrams cut short, garbage, frame
 * counter gaps; the matrix to quaternion conversion on random rotations;
 * and a y-up tracker with a mounted sensor read through a capture, whose
 * sample arrives at the expected z-up pose (axes and mount.N).
 * tests/e2e/test_cave.py sends such frames to the daemon over UDP.
 */
#include "config/config.h"
#include "trackers/dtrack.h"
#include "trackers/tracker.h"

#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "testutil.h"

struct got {
	int n;
	int sensor[64];
	struct device_sample s[64];
};

static void collect(void *ctx, int sensor, const struct device_sample *s)
{
	struct got *g = ctx;

	if (g->n < 64) {
		g->sensor[g->n] = sensor;
		g->s[g->n] = *s;
	}
	g->n++;
}

static struct dtrack_codec_st *codec_open(int bodies, int flysticks)
{
	struct cfg_source cfg;
	static struct dtrack_opts o;
	struct dtrack_codec_st *d = calloc(1, dtrack_codec.size);
	char err[256];

	memset(&cfg, 0, sizeof(cfg));
	memset(&o, 0, sizeof(o));
	o.sensors = bodies;
	o.flysticks = flysticks;
	cfg.opt = &o;
	assert_non_null(d);
	assert_int_equal(dtrack_codec.init(d, &cfg, err, sizeof(err)), 0);
	return d;
}

static int feed(struct dtrack_codec_st *d, const char *text, struct got *g)
{
	g->n = 0;
	return dtrack_codec.feed(d, (const uint8_t *)text, strlen(text), collect, g);
}

/* the sample of sensor s in g, or NULL */
static const struct device_sample *find(const struct got *g, int s)
{
	for (int i = 0; i < g->n && i < 64; i++)
		if (g->sensor[i] == s)
			return &g->s[i];
	return NULL;
}

/* a rotation about z by a degrees, DTrack's order (column by column) */
static void rot_z(double a, char *out, size_t len)
{
	double c = cos(a * M_PI / 180), s = sin(a * M_PI / 180);

	/* columns: (c, s, 0), (-s, c, 0), (0, 0, 1) */
	snprintf(out, len, "%.6f %.6f 0.000000 %.6f %.6f 0.000000 0.000000 0.000000 1.000000", c, s, -s, c);
}

static void test_bodies(void **state)
{
	struct dtrack_codec_st *d = codec_open(4, 1);
	char r90[128], text[1024];
	struct got g;
	const struct device_sample *s;
	struct vec3 p;
	double now = fmod((double)time(NULL), 86400.0);

	(void)state;
	rot_z(90, r90, sizeof(r90));
	snprintf(text, sizeof(text),
		 "fr 1000\nts %.3f\n6dcal 3\n"
		 "6d 2 [0 1.000][100.000 -200.000 1500.500][%s] [2 0.800][0 0 0][1 0 0 0 1 0 0 0 1]\n",
		 now, r90);
	assert_int_equal(feed(d, text, &g), 2);
	s = find(&g, 0);
	assert_non_null(s);
	dq_translation(&s->pose, &p);
	assert_near(p.x, 0.1, 1e-9);
	assert_near(p.y, -0.2, 1e-9);
	assert_near(p.z, 1.5005, 1e-9);
	/* 90 degrees about z */
	assert_near(s->pose.r.w, sqrt(0.5), 1e-6);
	assert_near(s->pose.r.z, sqrt(0.5), 1e-6);
	assert_near(s->pose.r.x, 0, 1e-6);
	assert_false(s->inputs);
	/* ts: today's time, within the second of time() */
	assert_true(s->t_ns > 0);
	{
		struct timespec ts;

		clock_gettime(CLOCK_REALTIME, &ts);
		assert_true(llabs((long long)s->t_ns - (long long)ts.tv_sec * 1000000000ll) < 2000000000ll);
	}
	s = find(&g, 2);
	assert_non_null(s);
	assert_near(s->pose.r.w, 1, 1e-12);
	assert_int_equal(d->calibrated, 3);
	assert_int_equal(d->c.malformed, 0);
	/* the next frame: body 0 not tracked (quality -1), body 2 gone, body 3 appears; frames 1001-1002 lost */
	assert_int_equal(
		feed(d, "fr 1003\n6d 2 [0 -1.000][0 0 0][0 0 0 0 0 0 0 0 0] [3 1.000][10 20 30][1 0 0 0 1 0 0 0 1]\n",
		     &g),
		1);
	assert_int_equal(g.sensor[0], 3);
	assert_int_equal(g.s[0].t_ns, 0); /* no ts line: the time it was read */
	assert_int_equal(d->untracked, 1);
	assert_int_equal(d->c.lost, 2);
	/* a body id beyond sensors = 4: counted, not a sample */
	assert_int_equal(feed(d, "fr 1004\n6d 1 [7 1.000][0 0 0][1 0 0 0 1 0 0 0 1]\n", &g), 0);
	assert_int_equal(d->ignored, 1);
	assert_int_equal(d->seen[7], 1);
	/* an empty frame, and one with no body at all */
	assert_int_equal(feed(d, "", &g), 0);
	assert_int_equal(feed(d, "fr 1005\nts 1.0\n6dcal 3\n6d 0\n", &g), 0);
	assert_int_equal(d->c.malformed, 0);
	/* lines of kinds not read are passed over */
	assert_int_equal(
		feed(d, "fr 1006\n3d 1 [1 1.000][1 2 3]\ngl 0\n6d 1 [1 1.000][0 0 0][1 0 0 0 1 0 0 0 1]\n", &g), 1);
	assert_int_equal(d->other, 2);
	assert_int_equal(d->c.malformed, 0);
	free(d);
}

static void test_flystick(void **state)
{
	struct dtrack_codec_st *d = codec_open(2, 2);
	struct got g;
	const struct device_sample *s;
	struct vec3 p;

	(void)state;
	/* Flystick 0: 6 buttons (trigger and 2 pressed), joystick x -0.5 y 1; Flystick 1 not tracked */
	assert_int_equal(feed(d,
			      "fr 5\r\n6df2 2 2 [0 1.000 6 2][500 600 700][1 0 0 0 1 0 0 0 1][5 -0.500 1.000] "
			      "[1 -1.000 6 2][0 0 0][0 0 0 0 0 0 0 0 0][0 0.000 0.000]\r\n",
			      &g),
			 1);
	s = find(&g, 2); /* after the two bodies */
	assert_non_null(s);
	dq_translation(&s->pose, &p);
	assert_near(p.x, 0.5, 1e-9);
	assert_near(p.z, 0.7, 1e-9);
	assert_true(s->inputs);
	assert_int_equal(s->buttons, 5);
	assert_near(s->analog[0], -0.5, 1e-7);
	assert_near(s->analog[1], 1.0, 1e-7);
	assert_near(s->analog[2], 0, 0);
	assert_int_equal(d->untracked, 1);
	/* button bits past the Flystick's count are not buttons */
	assert_int_equal(feed(d, "6df2 1 1 [0 1.000 3 0][0 0 0][1 0 0 0 1 0 0 0 1][255]\n", &g), 1);
	assert_int_equal(g.s[0].buttons, 7);
	assert_int_equal(d->c.malformed, 0);
	/* the block count must match what the Flystick says it has */
	assert_int_equal(feed(d, "6df2 1 1 [0 1.000 3 2][0 0 0][1 0 0 0 1 0 0 0 1][1]\n", &g), 0);
	assert_int_equal(d->c.malformed, 1);
	/* a button word that is no 32-bit integer (found by tests/fuzz/fuzz_dtrack.c: 7.8e88 made a long
	 * overflow): that Flystick's record is malformed, the rest of the frame stands */
	assert_int_equal(feed(d,
			      "6df2 2 2 [0 1.000 6 0][0 0 0][1 0 0 0 1 0 0 0 1][7.8e88] "
			      "[1 1.000 6 0][0 0 0][1 0 0 0 1 0 0 0 1][2]\n",
			      &g),
			 1);
	assert_int_equal(g.s[0].buttons, 2);
	assert_int_equal(d->c.malformed, 2);
	assert_int_equal(feed(d, "6df2 1 1 [0 1.000 6 0][0 0 0][1 0 0 0 1 0 0 0 1][4294967296]\n", &g), 0);
	assert_int_equal(feed(d, "6df2 1 1 [0 1.000 6 0][0 0 0][1 0 0 0 1 0 0 0 1][-1]\n", &g), 0);
	assert_int_equal(feed(d, "6df2 1 1 [0 1.000 6 0][0 0 0][1 0 0 0 1 0 0 0 1][2.5]\n", &g), 0);
	assert_int_equal(d->c.malformed, 5);
	free(d);
}

static void test_odd_frames(void **state)
{
	struct dtrack_codec_st *d = codec_open(16, 0);
	static char text[DTRACK_MAX_DATAGRAM];
	struct got g;
	size_t n = 0;
	uint64_t bad = 0;

	(void)state;
	/* a very long line: 60 bodies (only 16 taken), over 4 kB */
	n += (size_t)snprintf(text + n, sizeof(text) - n, "fr 1\n6d 60");
	for (int i = 0; i < 60; i++)
		n += (size_t)snprintf(text + n, sizeof(text) - n,
				      " [%d 1.000][%d.123 %d.456 1000.000][1.000000 0.000000 0.000000 0.000000 "
				      "1.000000 0.000000 0.000000 0.000000 1.000000]",
				      i, i * 10, -i);
	n += (size_t)snprintf(text + n, sizeof(text) - n, "\n");
	assert_true(n > 4096);
	assert_int_equal(feed(d, text, &g), 16);
	assert_int_equal(d->ignored, 44);
	assert_int_equal(d->c.malformed, 0);
	/* the same datagram cut short in the middle of a body: the 6d line is dropped whole, fr is read */
	text[n / 2] = '\0';
	assert_int_equal(feed(d, text, &g), 0);
	assert_int_equal(d->c.malformed, ++bad);
	assert_int_equal(d->frame, 1);
	/* cut right after a block: the count says more bodies */
	assert_int_equal(feed(d, "fr 2\n6d 2 [0 1.000][0 0 0][1 0 0 0 1 0 0 0 1]", &g), 0);
	assert_int_equal(d->c.malformed, ++bad);
	/* not numbers, a block short of a value, text after the bodies, a NUL inside */
	assert_int_equal(feed(d, "6d 1 [0 1.000][a b c][1 0 0 0 1 0 0 0 1]\n", &g), 0);
	assert_int_equal(feed(d, "6d 1 [0 1.000][0 0][1 0 0 0 1 0 0 0 1]\n", &g), 0);
	assert_int_equal(feed(d, "6d 1 [0 1.000][0 0 0][1 0 0 0 1 0 0 0 1] junk\n", &g), 0);
	assert_int_equal(feed(d, "fr x\nts -5\n6dcal q\n", &g), 0);
	bad += 6;
	g.n = 0;
	assert_true(dtrack_codec.feed(d, (const uint8_t *)"fr 3\0\n6d 0\n", 12, collect, &g) < 0);
	assert_int_equal(d->c.malformed, ++bad);
	/* a matrix that is no rotation (a scale, a mirror) */
	assert_int_equal(feed(d, "6d 1 [0 1.000][0 0 0][2 0 0 0 2 0 0 0 2]\n", &g), 0);
	assert_int_equal(feed(d, "6d 1 [0 1.000][0 0 0][-1 0 0 0 1 0 0 0 1]\n", &g), 0);
	bad += 2;
	assert_int_equal(d->c.malformed, bad);
	/* garbage: three lines, each counted */
	assert_int_equal(feed(d, "\x01\x02\xff\xfe garbage\n[[[]]]\n6d\n", &g), 0);
	bad += 3;
	assert_int_equal(d->c.malformed, bad);
	/* and a good frame after all that */
	assert_int_equal(feed(d, "fr 10\r\n6d 1 [3 0.9][1 2 3][1 0 0 0 1 0 0 0 1]\r\n", &g), 1);
	assert_int_equal(g.sensor[0], 3);
	free(d);
}

static void test_matrix(void **state)
{
	(void)state;
	rng_seed(17);
	for (int k = 0; k < 2000; k++) {
		double q[4] = { rnd_range(-1, 1), rnd_range(-1, 1), rnd_range(-1, 1), rnd_range(-1, 1) }, n, r[9],
		       got[4];
		struct quat qq;

		n = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
		for (int i = 0; i < 4; i++)
			q[i] /= n;
		if (q[0] < 0)
			for (int i = 0; i < 4; i++)
				q[i] = -q[i];
		qq = (struct quat){ q[0], q[1], q[2], q[3] };
		/* column c is the image of axis c */
		for (int c = 0; c < 3; c++) {
			struct vec3 e = { c == 0, c == 1, c == 2 }, img;

			quat_rotate(&qq, &e, &img);
			r[c * 3 + 0] = img.x;
			r[c * 3 + 1] = img.y;
			r[c * 3 + 2] = img.z;
		}
		set_ctx("rotation %d", k);
		assert_true(dtrack_matrix_quat(r, got));
		for (int i = 0; i < 4; i++)
			assert_near(got[i], q[i], 1e-9);
	}
}

/* a y-up tracker: the world (z-up) pose of a sensor at a known y-up pose, with its mount */
static void test_axes_and_mount(void **state)
{
	char dir[] = "/tmp/agw-dtrack-XXXXXX", cap[256], conf[2048], err[512], hex[4096];
	const char *frame = "fr 1\n6d 1 [1 1.000][1000 1500 -2000][1 0 0 0 1 0 0 0 1]\n";
	struct config c;
	struct tracker t;
	struct dq want;
	struct vec3 p;
	FILE *f;
	size_t k = 0;
	uint64_t end;

	(void)state;
	assert_non_null(mkdtemp(dir));
	for (const char *s = frame; *s; s++)
		k += (size_t)snprintf(hex + k, sizeof(hex) - k, "%02x ", (unsigned char)*s);
	snprintf(cap, sizeof(cap), "%s/frame.cap", dir);
	f = fopen(cap, "w");
	assert_non_null(f);
	fprintf(f, "%s\n", hex);
	fclose(f);
	/* the tracker y-up, its origin 0.5 m along the world's x; the sensor's point 0.1 m along its own -z */
	snprintf(conf, sizeof(conf),
		 "[daemon]\ncontrol_socket =\n[source dt]\ntype = dtrack\ncapture = %s\nloop = no\nsensors = 2\n"
		 "flysticks = 0\naxes = y-up\norigin = 0.5 0 0\nsensor.1 = glasses\nmount.1 = 0 0 -0.1\n"
		 "[avatar a]\nhead = dt/glasses\nleft_hand = dt/0\nright_hand = dt/0\n"
		 "[output u]\ntype = udp\nport = 9\n",
		 cap);
	assert_int_equal(config_load_text(&c, "test", conf, err, sizeof(err)), 0);
	assert_int_equal(tracker_open(&t, &c.source[0], err, sizeof(err)), 0);
	end = (uint64_t)time(NULL) + 10;
	while (!t.slot[1].seen && (uint64_t)time(NULL) < end) {
		struct timespec ts;
		struct tracker_clock now;

		clock_gettime(CLOCK_MONOTONIC, &ts);
		now.mono_ns = (uint64_t)ts.tv_sec * 1000000000ull + (uint64_t)ts.tv_nsec;
		now.real_off_ns = 0;
		t.drv->poll(&t, &now);
		usleep(1000);
	}
	assert_true(t.slot[1].seen);
	/*
	 * y-up (1, 1.5, -2) is z-up (1, 2, 1.5): x stays, the tracker's y (up) is z, its z (towards the
	 * viewer) is -y; the origin adds 0.5 along x. The sensor's own -z (y-up) is the world's +y, so its
	 * point 0.1 m along its -z is 0.1 m further along +y. Its orientation is the axes' rotation.
	 */
	dq_translation(&t.slot[1].pose, &p);
	assert_near(p.x, 1.5, 1e-9);
	assert_near(p.y, 2.1, 1e-9);
	assert_near(p.z, 1.5, 1e-9);
	want.r = (struct quat){ sqrt(0.5), sqrt(0.5), 0, 0 };
	assert_near(t.slot[1].pose.r.w, want.r.w, 1e-9);
	assert_near(t.slot[1].pose.r.x, want.r.x, 1e-9);
	assert_near(t.slot[1].pose.r.y, 0, 1e-9);
	assert_near(t.slot[1].pose.r.z, 0, 1e-9);
	/* mount.1 and sensor.1: the channel's number reaches the named sensor */
	assert_int_equal(cfg_sensor_lookup(&c.source[0], "1"), 1);
	assert_int_equal(cfg_sensor_lookup(&c.source[0], "glasses"), 1);
	tracker_close(&t);
	config_free(&c);
	unlink(cap);
	rmdir(dir);
}

/* the axes forms agree: y-up, "x z -y" and its quaternion; a mirror is refused */
static void test_axes_forms(void **state)
{
	static const char *const forms[] = { "y-up", "x z -y", "0.7071067811865476 0.7071067811865476 0 0" };
	char conf[512], err[512];
	struct config c;

	(void)state;
	for (int i = 0; i < 3; i++) {
		snprintf(conf, sizeof(conf),
			 "[daemon]\ncontrol_socket =\n[source s]\ntype = sim\naxes = %s\n[avatar a]\nperson = s/p0\n"
			 "[output u]\ntype = udp\nport = 9\n",
			 forms[i]);
		set_ctx("axes = %s", forms[i]);
		assert_int_equal(config_load_text(&c, "test", conf, err, sizeof(err)), 0);
		assert_near(c.source[0].axes[0], sqrt(0.5), 1e-12);
		assert_near(c.source[0].axes[1], sqrt(0.5), 1e-12);
		assert_near(c.source[0].axes[2], 0, 1e-12);
		assert_near(c.source[0].axes[3], 0, 1e-12);
		config_free(&c);
	}
	snprintf(conf, sizeof(conf),
		 "[daemon]\ncontrol_socket =\n[source s]\ntype = sim\naxes = x y -z\n[avatar a]\nperson = s/p0\n"
		 "[output u]\ntype = udp\nport = 9\n");
	assert_int_equal(config_load_text(&c, "test", conf, err, sizeof(err)), -1);
	assert_non_null(strstr(err, "test:5:"));
	assert_non_null(strstr(err, "not a rotation"));
	/* sensor.N beyond sensors, and two sensors of one name, are config errors */
	snprintf(conf, sizeof(conf),
		 "[daemon]\ncontrol_socket =\n[source d]\ntype = dtrack\nsensors = 2\nsensor.2 = x\n[avatar a]\n"
		 "head = d/0\nleft_hand = d/0\nright_hand = d/0\n[output u]\ntype = udp\nport = 9\n");
	assert_int_equal(config_load_text(&c, "test", conf, err, sizeof(err)), -1);
	assert_non_null(strstr(err, "test:6:"));
	snprintf(conf, sizeof(conf),
		 "[daemon]\ncontrol_socket =\n[source d]\ntype = dtrack\nsensors = 2\nsensor.0 = 1\n[avatar a]\n"
		 "head = d/0\nleft_hand = d/0\nright_hand = d/0\n[output u]\ntype = udp\nport = 9\n");
	assert_int_equal(config_load_text(&c, "test", conf, err, sizeof(err)), -1);
	assert_non_null(strstr(err, "two sensors are named '1'"));
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_bodies), cmocka_unit_test(test_flystick),	      cmocka_unit_test(test_odd_frames),
		cmocka_unit_test(test_matrix), cmocka_unit_test(test_axes_and_mount), cmocka_unit_test(test_axes_forms),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
