// SPDX-License-Identifier: MIT
/*
 * test_polhemus.c - the Polhemus driver against a simulated Liberty HS
 * behind libusb (tests/fake/fake_usb.c, linked in with
 * -Wl,--wrap=libusb_...): the same driver code as with the hardware, the
 * device replaced at the library boundary. The device obeys the ASCII
 * set-up commands and streams tests/data/polhemus-cmu_141_16.cap, made by
 * tools/gen-captures.py from real motion (a CMU clip): head on station 1,
 * hands on 2 and 3.
 *
 * First the decoder alone (records, frames, station mapping, records split
 * anywhere, garbage and resynchronisation, error records, frame counts,
 * product headers, the whole capture against the clip), then a real
 * gateway (gw_open / gw_cycle, this thread playing the loop) with a
 * polhemus source on the simulated device: the set-up, the poses
 * published, and the faults: unplug and replug (hot-plug events, or
 * enumeration without them), a halted endpoint once and for good, a
 * device that stops streaming, records split across transfers, garbage
 * bytes, frame-count gaps, the pre-firmware product id, no permission.
 * Every FRAME published is decoded and checked (tests/fake/gwtest.c). The
 * steps every device goes through (up, unplugged and replugged, denied,
 * listed, the loop's allocations, a capture played) are
 * tests/fake/devtest.c's, shared with test_hydra.c: here, what they are
 * for a Polhemus and what only a Polhemus does.
 */
#include "fake/clip.h"
#include "fake/devtest.h"
#include "fake/fake.h"
#include "fake/gwtest.h"
#include "trackers/device.h"
#include "trackers/polhemus.h"

#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <cmocka.h>

#include <libusb-1.0/libusb.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define CAPTURE "tests/data/polhemus-cmu_141_16.cap"
#define CLIP "config/clips/cmu_141_16.csv"
/* where tools/gen-captures.py put the source, and the clip time of the first frame */
static const double src_origin[3] = { 0.1, 0.6, 2.2 };
#define SRC_YAW 30.0
#define CAPTURE_T0 2.5
#define RATE 240.0

/* float32 cm: 1e-7 relative */
#define POS_TOL 2e-6
#define ANG_TOL 2e-5

static const struct polhemus_timing default_timing = { 50, 500, 200, 2, 3 };

#define CONF_S(stale_ms)                                                                                               \
	"[daemon]\n"                                                                                                   \
	"rate = 500\n"                                                                                                 \
	"control_socket =\n"                                                                                           \
	"stale_ms = " stale_ms "\n"                                                                                    \
	"[avatar a]\n"                                                                                                 \
	"person = polhemus\n"                                                                                          \
	"[source polhemus]\n"                                                                                          \
	"type = polhemus\n"                                                                                            \
	"origin = 0.1 0.6 2.2\n"                                                                                       \
	"yaw = 30\n"                                                                                                   \
	"model = liberty_hs\n"                                                                                         \
	"hemisphere = 0 0 1\n"

#define CONF CONF_S("100")
/* for the tests that step through frames: a slow machine must not make samples STALE meanwhile */
#define CONF_STEPPED CONF_S("5000")

static int setup(void **state)
{
	(void)state;
	polhemus_timing = default_timing;
	fake_usb_reset(CAPTURE);
	return 0;
}

/* ---- the decoder --------------------------------------------------------------------- */

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

struct codec {
	struct cfg_source cfg;
	struct polhemus_opts opt;
	void *st;
	struct device_counts *c;
};

static void codec_open(struct codec *k, int model, const char *sensors)
{
	char err[128];

	memset(&k->cfg, 0, sizeof(k->cfg));
	memset(&k->opt, 0, sizeof(k->opt));
	k->cfg.opt = &k->opt;
	k->opt.model = model;
	snprintf(k->opt.stations, sizeof(k->opt.stations), "%s", sensors);
	k->st = calloc(1, polhemus_codec.size);
	assert_int_equal(polhemus_codec.init(k->st, &k->cfg, err, sizeof(err)), 0);
	polhemus_codec.reset(k->st);
	k->c = k->st;
}

static int feed(struct codec *k, const uint8_t *b, size_t len, struct got *g)
{
	return polhemus_codec.feed(k->st, b, len, collect, g);
}

static void putf(uint8_t *b, float f)
{
	uint32_t v;

	memcpy(&v, &f, 4);
	for (int i = 0; i < 4; i++)
		b[i] = (uint8_t)(v >> (8 * i));
}

/* one record of O*,2,7,9,0 as docs/TRACKERS.md lays it out: 41 bytes */
static size_t record(uint8_t *b, const char *hdr, int station, char err, const float p[3], const float q[4],
		     uint32_t frame)
{
	b[0] = (uint8_t)hdr[0];
	b[1] = (uint8_t)hdr[1];
	b[2] = (uint8_t)station;
	b[3] = 'C';
	b[4] = (uint8_t)err;
	b[5] = 0;
	b[6] = 33;
	b[7] = 0;
	for (int i = 0; i < 3; i++)
		putf(b + 8 + 4 * i, p[i]);
	for (int i = 0; i < 4; i++)
		putf(b + 20 + 4 * i, q[i]);
	for (int i = 0; i < 4; i++)
		b[36 + i] = (uint8_t)(frame >> (8 * i));
	b[40] = ' ';
	return 41;
}

/* a frame of three stations, positions offset by station */
static size_t frame3(uint8_t *b, uint32_t frame)
{
	size_t n = 0;

	for (int st = 1; st <= 3; st++) {
		const float p[3] = { 10.0f * st, 20.0f, 30.0f }, q[4] = { 1, 0, 0, 0 };

		n += record(b + n, "LY", st, ' ', p, q, frame);
	}
	return n;
}

static void test_record_layout(void **state)
{
	struct codec k;
	struct got g = { 0 };
	uint8_t b[64];
	const float p[3] = { 12.5f, -40.0f, 75.0f };
	/* 90 degrees about the source's z (which points down) */
	const float q[4] = { 0.70710678f, 0, 0, 0.70710678f };
	double pp[3], qq[4];

	(void)state;
	codec_open(&k, CFG_PH_AUTO, "head left_hand right_hand");
	record(b, "LY", 2, ' ', p, q, 77);
	assert_int_equal(feed(&k, b, 41, &g), 1);
	assert_int_equal(g.sensor[0], 1); /* station 2: the second name */
	devtest_pose(&g.s[0], pp, qq);
	/* cm -> m; the source's z points down, ours up: (x, -y, -z) */
	assert_float_equal(pp[0], 0.125, 1e-7);
	assert_float_equal(pp[1], 0.400, 1e-7);
	assert_float_equal(pp[2], -0.750, 1e-7);
	/* Rx(180) * (c, 0, 0, s) = (0, c, -s, 0): the same turn, now about our -z... seen from the flipped frame */
	assert_float_equal(fabs(qq[1]), 0.70710678, 1e-6);
	assert_float_equal(qq[0], 0, 1e-7);
	assert_float_equal(qq[2] / qq[1], -1, 1e-6);
	assert_float_equal(qq[3], 0, 1e-7);
	assert_false(g.s[0].inputs);
	assert_int_equal(k.c->reports, 1);
	assert_int_equal(k.c->malformed, 0);
	free(k.st);
}

static void test_station_map(void **state)
{
	struct codec k;
	struct got g = { 0 };
	uint8_t b[256];
	size_t n = frame3(b, 1);

	(void)state;
	/* station 2 unused, station 3 is the second sensor */
	codec_open(&k, CFG_PH_AUTO, "head - right_hand");
	assert_int_equal(feed(&k, b, n, &g), 2);
	assert_int_equal(g.sensor[0], 0);
	assert_int_equal(g.sensor[1], 1);
	{
		double p[3], q[4];

		devtest_pose(&g.s[1], p, q);
		assert_float_equal(p[0], 0.30, 1e-7);
	}
	/* all three decoded (reports), two of them used */
	assert_int_equal(k.c->reports, 3);
	assert_int_equal(k.c->malformed, 0);
	free(k.st);
}

/* a frame cut in two anywhere, or fed byte by byte: the same samples */
static void test_split_anywhere(void **state)
{
	uint8_t b[256];
	size_t n = frame3(b, 1);

	(void)state;
	for (size_t at = 1; at < n; at++) {
		struct codec k;
		struct got g = { 0 };

		codec_open(&k, CFG_PH_LIBERTY_HS, "head left_hand right_hand");
		feed(&k, b, at, &g);
		feed(&k, b + at, n - at, &g);
		assert_int_equal(g.n, 3);
		assert_int_equal(k.c->malformed, 0);
		free(k.st);
	}
	{
		struct codec k;
		struct got g = { 0 };

		codec_open(&k, CFG_PH_LIBERTY_HS, "head left_hand right_hand");
		for (size_t i = 0; i < n; i++)
			feed(&k, b + i, 1, &g);
		assert_int_equal(g.n, 3);
		assert_int_equal(k.c->malformed, 0);
		free(k.st);
	}
}

static void test_resync(void **state)
{
	struct codec k;
	struct got g = { 0 };
	uint8_t b[1024];
	size_t n = 0;
	const float p[3] = { 1, 2, 3 }, q[4] = { 1, 0, 0, 0 };

	(void)state;
	codec_open(&k, CFG_PH_LIBERTY_HS, "head left_hand right_hand");
	/* garbage, then header look-alikes: a bad station, a size that is not ours, no trailing space */
	memcpy(b, "\x01\x02garbage\xff", 10);
	n = 10;
	memcpy(b + n,
	       "LY\x00"
	       "C \x00\x21\x00",
	       8); /* station 0 */
	n += 8;
	n += record(b + n, "LY", 1, ' ', p, q, 5);
	b[n - 1] = 'x'; /* no space at the end: not a record */
	n += frame3(b + n, 6);
	assert_int_equal(feed(&k, b, n, &g), 3);
	assert_int_equal(g.n, 3);
	/* one episode of lost framing: counted once */
	assert_int_equal(k.c->resyncs, 1);
	assert_int_equal(k.c->malformed, 1);
	/* the stream is in sync again: the next frame goes through untouched */
	n = frame3(b, 7);
	g.n = 0;
	assert_int_equal(feed(&k, b, n, &g), 3);
	assert_int_equal(k.c->malformed, 1);
	/* an answer to another command is skipped whole; "LY" inside a record's payload means nothing */
	n = frame3(b, 8);
	b[50] = 'L';
	b[51] = 'Y';
	b[3] = 'Q';
	g.n = 0;
	feed(&k, b, n, &g);
	assert_int_equal(g.n, 2);
	free(k.st);
}

static void test_error_and_bad_records(void **state)
{
	struct codec k;
	struct got g = { 0 };
	uint8_t b[256];
	const float p[3] = { 1, 2, 3 }, q[4] = { 1, 0, 0, 0 }, zero[4] = { 0, 0, 0, 0 }, nanq[4] = { NAN, 0, 0, 1 };
	size_t n = 0;

	(void)state;
	codec_open(&k, CFG_PH_LIBERTY_HS, "head left_hand right_hand");
	n += record(b + n, "LY", 1, 'E', p, q, 1); /* the device says the record is in error */
	n += record(b + n, "LY", 2, ' ', p, zero, 1);
	n += record(b + n, "LY", 3, ' ', p, nanq, 1);
	assert_int_equal(feed(&k, b, n, &g), 0);
	assert_int_equal(k.c->malformed, 3);
	assert_int_equal(k.c->resyncs, 0);
	free(k.st);
}

static void test_frame_counts(void **state)
{
	struct codec k;
	struct got g = { 0 };
	uint8_t b[256];

	(void)state;
	codec_open(&k, CFG_PH_LIBERTY_HS, "head left_hand right_hand");
	feed(&k, b, frame3(b, 100), &g);
	feed(&k, b, frame3(b, 101), &g);
	feed(&k, b, frame3(b, 105), &g); /* 102-104 lost, for each of three stations */
	assert_int_equal(k.c->lost, 9);
	g.n = 0;
	assert_int_equal(feed(&k, b, frame3(b, 105), &g), 0); /* the same frame again */
	assert_int_equal(k.c->malformed, 3);
	free(k.st);
}

static void test_product_headers(void **state)
{
	uint8_t b[64];
	const float p[3] = { 1, 2, 3 }, q[4] = { 1, 0, 0, 0 };
	static const struct {
		int model;
		const char *hdr;
		int ok;
	} cases[] = {
		{ CFG_PH_AUTO, "LY", 1 },    { CFG_PH_AUTO, "PA", 1 },	  { CFG_PH_AUTO, "LU", 1 },
		{ CFG_PH_LIBERTY, "LY", 1 }, { CFG_PH_LIBERTY, "PA", 0 }, { CFG_PH_LIBERTY_HS, "LU", 1 },
		{ CFG_PH_PATRIOT, "PA", 1 }, { CFG_PH_PATRIOT, "LY", 0 }, { CFG_PH_PATRIOT_HS, "PA", 1 },
	};

	(void)state;
	for (size_t i = 0; i < sizeof(cases) / sizeof(cases[0]); i++) {
		struct codec k;
		struct got g = { 0 };

		codec_open(&k, cases[i].model, "head left_hand right_hand");
		record(b, cases[i].hdr, 1, ' ', p, q, 1);
		assert_int_equal(feed(&k, b, 41, &g), cases[i].ok);
		free(k.st);
	}
	/* the rates: 240 Hz Liberty, 60 Hz Patriot (a capture without timestamps plays at that pace) */
	{
		struct codec k;

		codec_open(&k, CFG_PH_PATRIOT, "head");
		assert_float_equal(polhemus_codec.period(k.st), 1.0 / 60, 1e-12);
		free(k.st);
		codec_open(&k, CFG_PH_LIBERTY_HS, "head");
		assert_float_equal(polhemus_codec.period(k.st), 1.0 / 240, 1e-12);
		free(k.st);
		/* model = auto: the records tell, a Patriot's (PA) at 60 Hz, a Liberty's at 240 */
		codec_open(&k, CFG_PH_AUTO, "head");
		{
			struct got g = { 0 };

			record(b, "PA", 1, ' ', p, q, 1);
			assert_int_equal(feed(&k, b, 41, &g), 1);
			assert_float_equal(polhemus_codec.period(k.st), 1.0 / 60, 1e-12);
			record(b, "LY", 1, ' ', p, q, 2);
			assert_int_equal(feed(&k, b, 41, &g), 1);
			assert_float_equal(polhemus_codec.period(k.st), 1.0 / 240, 1e-12);
		}
		free(k.st);
	}
	assert_non_null(polhemus_product(0xff20));
	assert_true(polhemus_product(0xff21)->needs_firmware);
	assert_int_equal(polhemus_product(0xff21)->ready_pid, 0xff20);
	assert_int_equal(polhemus_product(0xef11)->ready_pid, 0xef12);
	assert_int_equal(polhemus_product(0xff20)->ep_in, 0x88);
	assert_int_equal(polhemus_product(0xff12)->ep_out, 0x02);
	assert_null(polhemus_product(0xbf01));
}

static void check_against_clip(const struct clip *clip, int station, double t, const double local_p[3],
			       const double local_q[4], double *worst_p, double *worst_a)
{
	static const enum clip_role role[3] = { CLIP_HEAD, CLIP_LHAND, CLIP_RHAND };
	struct clip_pose local, world, want;

	memcpy(local.p, local_p, sizeof(local.p));
	memcpy(local.q, local_q, sizeof(local.q));
	clip_to_world(src_origin, SRC_YAW, &local, &world);
	clip_at(clip, role[station], CAPTURE_T0 + t, &want);
	*worst_p = fmax(*worst_p, clip_dist(world.p, want.p));
	*worst_a = fmax(*worst_a, clip_angle(world.q, want.q));
}

static void test_capture_matches_clip(void **state)
{
	struct capture cap;
	struct clip clip;
	struct codec k;
	char err[256];
	double worst_p = 0, worst_a = 0;
	static struct got g;

	(void)state;
	assert_int_equal(capture_load(&cap, CAPTURE, err, sizeof(err)), 0);
	assert_false(cap.timed);
	assert_int_equal(clip_load(&clip, CLIP), 0);
	codec_open(&k, CFG_PH_LIBERTY_HS, "head left_hand right_hand");
	for (int i = 0; i < cap.n; i++) {
		g.n = 0;
		assert_int_equal(feed(&k, cap.bytes + cap.rep[i].off, cap.rep[i].len, &g), 3);
		for (int s = 0; s < 3; s++) {
			double p[3], q[4];

			assert_int_equal(g.sensor[s], s);
			devtest_pose(&g.s[s], p, q);
			check_against_clip(&clip, s, i / RATE, p, q, &worst_p, &worst_a);
		}
	}
	print_message("polhemus capture: %d frames, worst position error %.4f mm, angle %.6f rad\n", cap.n,
		      worst_p * 1e3, worst_a);
	assert_true(worst_p <= POS_TOL);
	assert_true(worst_a <= ANG_TOL);
	assert_int_equal(k.c->malformed, 0);
	assert_int_equal(k.c->lost, 0);
	free(k.st);
	clip_free(&clip);
	capture_free(&cap);
}

/* ---- the driver on the simulated device --------------------------------------------------- */

static struct fake_usb_stats stats(void)
{
	struct fake_usb_stats s;

	fake_usb_stats(&s);
	return s;
}

static bool set_up(struct gwt *t, void *arg)
{
	(void)t;
	return stats().setups >= *(int *)arg;
}

static bool samples_above(struct gwt *t, void *arg)
{
	return ctr_get(&gwt_tracker(t, "polhemus")->st.samples) >= *(uint64_t *)arg;
}

static uint64_t reads(void)
{
	return stats().frames;
}

static void plug_ready(void)
{
	fake_usb_plug(0xff20);
}

static void deny_open(bool deny)
{
	fake_usb_deny_open(deny ? LIBUSB_ERROR_ACCESS : 0);
}

/* the driver's set-up went through: C after the rest */
static bool set_up_once(void)
{
	return stats().setups >= 1;
}

/* the Liberty HS with its firmware, for the steps every device goes through (fake/devtest.h) */
static struct devtest polhemus = {
	.source = "polhemus",
	.conf = CONF,
	.sensors = 1u << WIRE_S_HEAD | 1u << WIRE_S_LEFT_HAND | 1u << WIRE_S_RIGHT_HAND,
	.inputs = false,
	.drv = &polhemus_driver,
	.plug = plug_ready,
	.unplug = fake_usb_unplug,
	.deny_open = deny_open,
	.denied = "Access denied",
	.stepped = fake_usb_stepped,
	.set_up = set_up_once,
	.reads = reads,
};

/* the set-up commands, then each frame of the capture through the gateway to the published avatar */
static void test_setup_and_published_poses(void **state)
{
	static struct gwt t;
	struct clip clip;
	double worst_p = 0, worst_a = 0;

	(void)state;
	assert_int_equal(clip_load(&clip, CLIP), 0);
	devtest_stepped(&t, &polhemus, CONF_STEPPED);
	/* stop, binary, centimetres, the hemisphere, the output list, continuous: exactly these */
	assert_string_equal(stats().commands, "P|F1|U1|H*,0,0,1|O*,2,7,9,0|C|");
	assert_int_equal(stats().claims, 1);
	for (int i = 0; i < fake_usb_capture_count(); i += 3) {
		uint64_t want = ctr_get(&gwt_tracker(&t, "polhemus")->st.samples) + 3;

		fake_usb_seek(i);
		fake_usb_release(1);
		assert_true(gwt_until(&t, samples_above, &want, 5000) >= 0);
		assert_int_equal(stats().last_index, i);
		for (int s = 0; s < 3; s++) {
			const struct wire_sensor_sample *ws = &t.f.sensor[s];
			double p[3], q[4];
			struct clip_pose want_p;
			static const enum clip_role role[3] = { CLIP_HEAD, CLIP_LHAND, CLIP_RHAND };

			assert_int_equal(ws->state, WIRE_SENSOR_OK);
			for (int c = 0; c < 3; c++)
				p[c] = ws->pose.p[c];
			for (int c = 0; c < 4; c++)
				q[c] = ws->pose.q[c];
			clip_at(&clip, role[s], CAPTURE_T0 + i / RATE, &want_p);
			worst_p = fmax(worst_p, clip_dist(p, want_p.p));
			worst_a = fmax(worst_a, clip_angle(q, want_p.q));
		}
		/* no buttons on a Polhemus: no input block */
		assert_false(t.f.h.flags & WIRE_F_INPUTS);
		/* the whole avatar from one Polhemus: solved */
		assert_true(isfinite(t.f.joint[5]));
	}
	print_message("published: worst position error %.4f mm, angle %.6f rad (float32 on the wire)\n", worst_p * 1e3,
		      worst_a);
	assert_true(worst_p <= 1e-5);
	assert_true(worst_a <= 1e-4);
	/* frames were skipped by seeking, but the device numbered what it sent: nothing lost */
	assert_int_equal(ctr_get(&gwt_tracker(&t, "polhemus")->st.lost), 0);
	assert_int_equal(ctr_get(&gwt_tracker(&t, "polhemus")->st.malformed), 0);
	gwt_close(&t);
	/* closing stops the continuous output */
	assert_non_null(strstr(stats().commands, "C|P|"));
	assert_int_equal(stats().opens, stats().closes);
	clip_free(&clip);
}

/* the avatar holds its last posture meanwhile (HELD), never a NaN joint: devtest_unplug_replug */
static void replug(bool hotplug)
{
	static struct gwt t;

	fake_usb_hotplug(hotplug);
	devtest_unplug_replug(&t, &polhemus);
	print_message("(found again by %s)\n", hotplug ? "a hot-plug event" : "enumeration");
	assert_int_equal(stats().setups, 2);
	assert_int_equal(stats().opens, 2);
	assert_int_equal(stats().hotplug_registered, hotplug ? 1 : 0);
	if (hotplug)
		assert_true(stats().hotplug_callbacks >= 2);
	gwt_close(&t);
}

static void test_unplug_replug_hotplug(void **state)
{
	(void)state;
	replug(true);
}

static void test_unplug_replug_no_hotplug(void **state)
{
	(void)state;
	replug(false);
}

static void test_halt_once(void **state)
{
	static struct gwt t;
	uint64_t m0;

	(void)state;
	devtest_up(&t, &polhemus);
	m0 = ctr_get(&gwt_tracker(&t, "polhemus")->st.malformed);
	fake_usb_halt(1);
	gwt_run(&t, 200);
	/* cleared and carried on: same device handle, OK all along */
	assert_int_equal(stats().clear_halts, 1);
	assert_int_equal(stats().opens, 1);
	assert_true(devtest_ok(&t, &polhemus));
	assert_int_equal(ctr_get(&gwt_tracker(&t, "polhemus")->st.malformed), m0);
	gwt_close(&t);
}

static int count(const char *text, const char *needle)
{
	int n = 0;

	for (const char *p = text; (p = strstr(p, needle)); p++)
		n++;
	return n;
}

static void test_stuck_endpoint(void **state)
{
	static struct gwt t;
	uint64_t t0;
	int ms;

	(void)state;
	devtest_up(&t, &polhemus);
	/* it halts again after every clear */
	fake_usb_halt(1000000);
	t0 = gwt_ms();
	assert_true(gwt_until(&t, devtest_missing, &polhemus, 1500) >= 0);
	gwt_run(&t, 1000);
	/* reopened, again and again, but not in a tight loop (search_ms apart), and not logged each time */
	print_message("stuck endpoint: %d opens in %d ms\n", stats().opens, (int)(gwt_ms() - t0));
	assert_true(stats().opens >= 3);
	assert_true(stats().opens <= 2 + (int)(gwt_ms() - t0) / 150);
	gwt_take_notes(&t);
	assert_int_equal(count(t.notes, "halted 3 times in a row: reopening"), 1);
	assert_true(count(t.notes, "set-up failed") <= 2);
	assert_non_null(strstr(t.notes, "further failures in a row are not logged"));
	/* someone unjams it */
	fake_usb_halt(0);
	ms = gwt_until(&t, devtest_ok, &polhemus, 2000);
	print_message("endpoint unstuck: OK again after %d ms\n", ms);
	assert_true(ms >= 0 && ms < 1000);
	gwt_close(&t);
}

static void test_stops_streaming(void **state)
{
	static struct gwt t;
	uint64_t t0;
	int two = 2, ms;

	(void)state;
	devtest_up(&t, &polhemus);
	fake_usb_stop_streaming();
	t0 = gwt_ms();
	assert_true(gwt_until(&t, devtest_stale, &polhemus, 400) >= 0);
	/* set up again after stall_ms: the device streams once it hears C */
	assert_true(gwt_until(&t, set_up, &two, 5000) >= 0);
	ms = gwt_until(&t, devtest_ok, &polhemus, 2000);
	print_message("stopped streaming: OK again %d ms later (stall_ms 500 + set-up)\n", (int)(gwt_ms() - t0));
	assert_true(ms >= 0 && gwt_ms() - t0 < 500 + 1000);
	assert_int_equal(stats().opens, 1);
	gwt_take_notes(&t);
	assert_non_null(strstr(t.notes, "setting it up again"));
	gwt_close(&t);
}

/* records cut across transfers, in the header and in the payload */
static void test_split_transfers(void **state)
{
	static const int cuts[] = { 3, 50, 100 };
	static struct gwt t;

	(void)state;
	devtest_stepped(&t, &polhemus, CONF_STEPPED);
	for (size_t c = 0; c < sizeof(cuts) / sizeof(cuts[0]); c++) {
		fake_usb_split(cuts[c]);
		for (int i = 0; i < 20; i++) {
			uint64_t want = ctr_get(&gwt_tracker(&t, "polhemus")->st.samples) + 3;

			fake_usb_release(1);
			assert_true(gwt_until(&t, samples_above, &want, 5000) >= 0);
		}
	}
	assert_int_equal(ctr_get(&gwt_tracker(&t, "polhemus")->st.malformed), 0);
	assert_int_equal(ctr_get(&gwt_tracker(&t, "polhemus")->st.samples), 3 * 60);
	gwt_close(&t);
}

static void test_garbage_bytes(void **state)
{
	static struct gwt t;
	struct tracker *p;
	uint8_t junk[300];
	uint64_t s0, f0;

	(void)state;
	p = devtest_up(&t, &polhemus);
	srand(3);
	for (size_t i = 0; i < sizeof(junk); i++)
		junk[i] = (uint8_t)(rand() >> 4);
	memcpy(junk + 100,
	       "LY\x02"
	       "C ",
	       5); /* a header look-alike inside */
	fake_usb_inject(junk, sizeof(junk));
	fake_usb_inject(junk + 7, 17);
	s0 = ctr_get(&p->st.samples);
	f0 = ctr_get(&p->st.faults);
	devtest_run_reading(&t, &polhemus, 300, 40 + 4); /* 40 frames of 3 stations, and what the junk may cost */
	/* counted, resynchronised on the next header, nothing else happened */
	assert_true(ctr_get(&p->st.malformed) >= 1);
	assert_true(ctr_get(&p->st.samples) > s0 + 3 * 40);
	assert_true(devtest_ok(&t, &polhemus));
	assert_int_equal(ctr_get(&p->st.faults), f0);
	assert_int_equal(ctr_get(&p->st.lost), 0);
	gwt_close(&t);
}

static void test_frame_count_gap(void **state)
{
	static struct gwt t;

	(void)state;
	devtest_up(&t, &polhemus);
	fake_usb_skip(4);
	devtest_run_reading(&t, &polhemus, 100, 2);
	/* per sensor: 4 frames of 3 stations */
	assert_int_equal(ctr_get(&gwt_tracker(&t, "polhemus")->st.lost), 12);
	assert_true(devtest_ok(&t, &polhemus));
	gwt_close(&t);
}

static void test_before_firmware(void **state)
{
	static struct gwt t;
	struct tracker *p;
	char st[256];
	int ms;

	(void)state;
	fake_usb_plug(0xff21);
	gwt_open(&t, CONF);
	p = gwt_tracker(&t, "polhemus");
	gwt_run(&t, 500);
	assert_int_equal(gwt_state(&t, "polhemus"), TRACKER_FAULTY);
	assert_int_equal(stats().opens, 0);
	gwt_take_notes(&t);
	print_message("%s", t.notes);
	assert_non_null(strstr(t.notes, "0f44:ff21"));
	assert_non_null(strstr(t.notes, "fxload -t fx2"));
	assert_non_null(strstr(t.notes, "60-avatargw.rules"));
	assert_non_null(strstr(t.notes, "0f44:ff20"));
	/* said once, not at every look */
	assert_null(strstr(strstr(t.notes, "has no firmware") + 1, "has no firmware"));
	p->drv->status(p, st, sizeof(st));
	assert_non_null(strstr(st, "firmware"));
	/* fxload runs: the device leaves and comes back with its working id */
	fake_usb_unplug();
	gwt_run(&t, 50);
	fake_usb_plug(0xff20);
	ms = gwt_until(&t, devtest_ok, &polhemus, 2000);
	assert_true(ms >= 0 && ms < 1000);
	gwt_close(&t);
}

static void test_access_denied(void **state)
{
	static struct gwt t;

	(void)state;
	devtest_denied(&t, &polhemus);
	gwt_close(&t);
}

static void test_list_devices(void **state)
{
	static const char *const says[] = {
		"Polhemus Liberty HS (0f44:ff20) on USB port 1-4",
		"[source polhemus]\n  type = polhemus\n  model = liberty_hs\n  device = 1-4\n", NULL
	};
	char *text;

	(void)state;
	devtest_list_devices(&polhemus, says);
	/* before its firmware: what to load, and how */
	fake_usb_deny_open(0);
	fake_usb_plug(0xff21);
	text = devtest_listing(&polhemus, 1);
	assert_non_null(strstr(text, "no firmware yet: load it with fxload -t fx2"));
	free(text);
	assert_int_equal(stats().setups, 0);
}

static void test_loop_allocates_nothing(void **state)
{
	static struct gwt t;

	(void)state;
	devtest_loop_allocates_nothing(&t, &polhemus);
}

/* capture = FILE: the same decoder, no device (and no libusb at all) */
static void test_capture_source(void **state)
{
	static struct gwt t;

	(void)state;
	devtest_capture(&t, &polhemus, CONF "capture = " CAPTURE "\nspeed = 4\nloop = no\n", 3 * 360);
	assert_int_equal(stats().enumerations, 0);
	gwt_close(&t);
}

/* a reload: the new source waits quietly for the old one to let go of the interface */
static void test_reload_hands_over(void **state)
{
	static struct gwt a, b;
	uint64_t t0;
	int ms;

	(void)state;
	devtest_up(&a, &polhemus);
	gwt_open(&b, CONF);
	gwt_run(&b, 300);
	assert_int_equal(gwt_state(&b, "polhemus"), TRACKER_FAULTY);
	gwt_cycle(&a);
	assert_true(devtest_ok(&a, &polhemus));
	t0 = gwt_ms();
	gwt_close(&a);
	ms = gwt_until(&b, devtest_ok, &polhemus, 2000);
	print_message("reload: the new source streams %d ms after the old one closed\n", (int)(gwt_ms() - t0));
	assert_true(ms >= 0 && gwt_ms() - t0 < 1000);
	gwt_take_notes(&b);
	assert_null(strstr(b.notes, "another program"));
	assert_int_equal(stats().claims, 2);
	gwt_close(&b);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test_setup_teardown(test_record_layout, setup, gwt_teardown),
		cmocka_unit_test_setup_teardown(test_station_map, setup, gwt_teardown),
		cmocka_unit_test_setup_teardown(test_split_anywhere, setup, gwt_teardown),
		cmocka_unit_test_setup_teardown(test_resync, setup, gwt_teardown),
		cmocka_unit_test_setup_teardown(test_error_and_bad_records, setup, gwt_teardown),
		cmocka_unit_test_setup_teardown(test_frame_counts, setup, gwt_teardown),
		cmocka_unit_test_setup_teardown(test_product_headers, setup, gwt_teardown),
		cmocka_unit_test_setup_teardown(test_capture_matches_clip, setup, gwt_teardown),
		cmocka_unit_test_setup_teardown(test_setup_and_published_poses, setup, gwt_teardown),
		cmocka_unit_test_setup_teardown(test_unplug_replug_hotplug, setup, gwt_teardown),
		cmocka_unit_test_setup_teardown(test_unplug_replug_no_hotplug, setup, gwt_teardown),
		cmocka_unit_test_setup_teardown(test_halt_once, setup, gwt_teardown),
		cmocka_unit_test_setup_teardown(test_stuck_endpoint, setup, gwt_teardown),
		cmocka_unit_test_setup_teardown(test_stops_streaming, setup, gwt_teardown),
		cmocka_unit_test_setup_teardown(test_split_transfers, setup, gwt_teardown),
		cmocka_unit_test_setup_teardown(test_garbage_bytes, setup, gwt_teardown),
		cmocka_unit_test_setup_teardown(test_frame_count_gap, setup, gwt_teardown),
		cmocka_unit_test_setup_teardown(test_before_firmware, setup, gwt_teardown),
		cmocka_unit_test_setup_teardown(test_access_denied, setup, gwt_teardown),
		cmocka_unit_test_setup_teardown(test_list_devices, setup, gwt_teardown),
		cmocka_unit_test_setup_teardown(test_loop_allocates_nothing, setup, gwt_teardown),
		cmocka_unit_test_setup_teardown(test_capture_source, setup, gwt_teardown),
		cmocka_unit_test_setup_teardown(test_reload_hands_over, setup, gwt_teardown),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
