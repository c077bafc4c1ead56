// SPDX-License-Identifier: MIT
/*
 * test_hydra.c - the Razer Hydra driver against a simulated Hydra behind
 * hidapi (tests/fake/fake_hid.c, linked in with -Wl,--wrap=hid_...): the
 * same driver code as with the hardware, the device replaced at the
 * library boundary. The device replays tests/data/hydra-cmu_141_16.cap,
 * made by tools/gen-captures.py from real motion (a CMU clip), with the
 * hemisphere flips a real base produces.
 *
 * First the decoder alone (report layout, frames, hemispheres, sequence
 * numbers, malformed reports, each report counted once whatever was
 * rejected or lost around it, the whole capture against the clip), then a
 * real gateway (gw_open / gw_cycle, this thread playing the loop) with a
 * hydra source on the simulated device: the handshake, the poses and
 * inputs published, and the faults: unplug and replug, short, long and
 * garbage reports, a device stuck in gamepad mode, sequence gaps, reports
 * damaged on their way, stalls, the mode changed behind the driver's back,
 * no permission. Every FRAME published is decoded and checked
 * (tests/fake/gwtest.c). The steps every device goes through (up,
 * unplugged and replugged, denied, listed, the loop's allocations, a
 * capture played) are tests/fake/devtest.c's, shared with
 * test_polhemus.c: here, what they are for a Hydra and what only a Hydra
 * does.
 */
#include "fake/clip.h"
#include "fake/devtest.h"
#include "fake/fake.h"
#include "fake/gwtest.h"
#include "trackers/device.h"
#include "trackers/hydra.h"

#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <cmocka.h>

#include <errno.h>
#include <inttypes.h>
#include <math.h>
#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define CAPTURE "tests/data/hydra-cmu_141_16.cap"
#define CLIP "config/clips/cmu_141_16.csv"
/* where tools/gen-captures.py put the base, and the clip time of the capture's first report */
static const double base_origin[3] = { 0, 0.5, 1.45 };
#define BASE_YAW -20.0
#define CAPTURE_T0 0.4

/* quantisation of the device: 1 mm per axis, int16 quaternion components */
#define POS_TOL (0.5e-3 * 1.7321 + 1e-6)
#define ANG_TOL 3e-4

static const struct hydra_timing default_timing = { 250, 5000, 500, 200, 25 };

#define CONF_HEAD_S(stale_ms)                                                                                          \
	"[daemon]\n"                                                                                                   \
	"rate = 500\n"                                                                                                 \
	"control_socket =\n"                                                                                           \
	"stale_ms = " stale_ms "\n"                                                                                    \
	"[avatar a]\n"                                                                                                 \
	"head = clip/head\n"                                                                                           \
	"left_hand = hydra/left\n"                                                                                     \
	"right_hand = hydra/right\n"                                                                                   \
	"[source clip]\n"                                                                                              \
	"type = replay\n"                                                                                              \
	"file = builtin:cmu_141_16.csv\n"                                                                              \
	"[source hydra]\n"                                                                                             \
	"type = hydra\n"                                                                                               \
	"origin = 0 0.5 1.45\n"                                                                                        \
	"yaw = -20\n"

#define CONF_HEAD CONF_HEAD_S("100")

/* the head from a replayed clip, the hands from the Hydra; more hydra keys may follow */
static const char conf_device[] = CONF_HEAD;
/* for the tests that step through reports: a slow machine must not make samples STALE meanwhile */
static const char conf_stepped[] = CONF_HEAD_S("5000");

static int setup(void **state)
{
	(void)state;
	hydra_timing = default_timing;
	fake_hid_reset(CAPTURE);
	return 0;
}

/* ---- the decoder --------------------------------------------------------------------- */

struct got {
	int n;
	int sensor[8];
	struct device_sample s[8];
};

static void collect(void *ctx, int sensor, const struct device_sample *s)
{
	struct got *g = ctx;

	g->sensor[g->n] = sensor;
	g->s[g->n++] = *s;
}

struct codec {
	void *st;
	struct device_counts *c;
};

static void codec_open(struct codec *k)
{
	struct cfg_source cfg = { 0 };
	char err[128];

	k->st = calloc(1, hydra_codec.size);
	assert_int_equal(hydra_codec.init(k->st, &cfg, err, sizeof(err)), 0);
	hydra_codec.reset(k->st);
	k->c = k->st;
}

static int feed(struct codec *k, const uint8_t *b, size_t len, struct got *g)
{
	g->n = 0;
	return hydra_codec.feed(k->st, b, len, collect, g);
}

static void put16(uint8_t *b, int v)
{
	b[0] = (uint8_t)(v & 0xff);
	b[1] = (uint8_t)((v >> 8) & 0xff);
}

/* a report as the device sends it: 52 bytes, blocks at 8 and 30 */
static void make_report(uint8_t r[52], uint8_t seq, const int pos[2][3], const int quat[2][4], const uint8_t buttons[2],
			const int joy[2][2], const uint8_t trigger[2])
{
	static const uint8_t head[7] = { 0x01, 0x00, 0x34, 0x00, 0x02, 0x00, 0x01 };

	memset(r, 0, 52);
	memcpy(r, head, 7);
	r[7] = seq;
	for (int w = 0; w < 2; w++) {
		uint8_t *b = r + 8 + 22 * w;

		for (int i = 0; i < 3; i++)
			put16(b + 2 * i, pos[w][i]);
		for (int i = 0; i < 4; i++)
			put16(b + 6 + 2 * i, quat[w][i]);
		b[14] = buttons[w];
		put16(b + 15, joy[w][0]);
		put16(b + 17, joy[w][1]);
		b[19] = trigger[w];
	}
}

static void simple_report(uint8_t r[52], uint8_t seq, int lx, int ly, int lz, int rx, int ry, int rz)
{
	const int pos[2][3] = { { lx, ly, lz }, { rx, ry, rz } };
	const int quat[2][4] = { { 32767, 0, 0, 0 }, { 32767, 0, 0, 0 } };
	const uint8_t buttons[2] = { 0x80, 0x80 }, trig[2] = { 0, 0 };
	const int joy[2][2] = { { 0, 0 }, { 0, 0 } };

	make_report(r, seq, pos, quat, buttons, joy, trig);
}

/* the layout of docs/TRACKERS.md, field by field */
static void test_report_layout(void **state)
{
	const int pos[2][3] = { { -100, 200, -300 }, { 50, 0, 400 } };
	/* left: 120 degrees about (1,1,1)/sqrt(3), a little off unit length; right: raw (0, 1, 0, 0) */
	const int quat[2][4] = { { 16400, 16400, 16400, 16400 }, { 0, 32767, 0, 0 } };
	/* device bits: 0 bumper, 1 "3", 2 "1", 3 "2", 4 "4", 5 start, 6 joystick; bit 7 always set */
	const uint8_t buttons[2] = { 0x80 | 0x01 | 0x20, 0x80 | 0x04 | 0x40 | 0x02 };
	const int joy[2][2] = { { -16384, 32767 }, { 8192, -32768 } };
	const uint8_t trig[2] = { 255, 51 };
	struct codec k;
	struct got g;
	uint8_t r[52];
	double p[3], q[4];

	(void)state;
	codec_open(&k);
	make_report(r, 0x22, pos, quat, buttons, joy, trig);
	assert_int_equal(feed(&k, r, sizeof(r), &g), 2);
	assert_int_equal(g.n, 2);
	assert_int_equal(g.sensor[0], HYDRA_LEFT);
	assert_int_equal(g.sensor[1], HYDRA_RIGHT);
	/* positions: mm, base frame (x right, y front, z down) -> tracker frame (x, -y, -z), metres */
	devtest_pose(&g.s[0], p, q);
	assert_float_equal(p[0], -0.100, 1e-9);
	assert_float_equal(p[1], -0.200, 1e-9);
	assert_float_equal(p[2], 0.300, 1e-9);
	/*
	 * Orientation: the device's (w, x, y, z) with y and z negated is the
	 * wand in the base frame; the tracker frame is the base turned by
	 * Rx(180). With q_b = (1,1,-1,-1)/2: Rx(180) q_b = (-1, 1, 1, -1)/2.
	 */
	assert_float_equal(fabs(q[0]), 0.5, 1e-9);
	assert_float_equal(q[1] / q[0], -1, 1e-9);
	assert_float_equal(q[2] / q[0], -1, 1e-9);
	assert_float_equal(q[3] / q[0], 1, 1e-9);
	/* our bits, VRPN's numbering: 0 start, 1-4 numbered, 5 bumper, 6 joystick */
	assert_int_equal(g.s[0].buttons, HYDRA_BTN_START | HYDRA_BTN_BUMPER);
	assert_int_equal(g.s[1].buttons, HYDRA_BTN_1 | HYDRA_BTN_3 | HYDRA_BTN_JOYSTICK);
	assert_float_equal(g.s[0].analog[HYDRA_AN_JOY_X], -0.5, 1e-6);
	assert_float_equal(g.s[0].analog[HYDRA_AN_JOY_Y], 32767.0 / 32768, 1e-6);
	assert_float_equal(g.s[0].analog[HYDRA_AN_TRIGGER], 1.0, 1e-6);
	assert_float_equal(g.s[1].analog[HYDRA_AN_JOY_X], 0.25, 1e-6);
	assert_float_equal(g.s[1].analog[HYDRA_AN_JOY_Y], -1.0, 1e-6);
	assert_float_equal(g.s[1].analog[HYDRA_AN_TRIGGER], 0.2, 1e-6);
	assert_true(g.s[0].inputs && g.s[1].inputs);
	/* the right wand: raw (0,1,0,0) is the wand upright, along the tracker's axes: identity */
	devtest_pose(&g.s[1], p, q);
	assert_float_equal(p[0], 0.050, 1e-9);
	assert_float_equal(p[1], 0.0, 1e-9);
	assert_float_equal(p[2], -0.400, 1e-9);
	assert_float_equal(fabs(q[0]), 1, 1e-9);
	assert_float_equal(q[1], 0, 1e-9);
	assert_float_equal(q[2], 0, 1e-9);
	assert_float_equal(q[3], 0, 1e-9);
	assert_int_equal(k.c->malformed, 0);
	free(k.st);
}

/* the side rule at the start, then continuity through mirror flips */
static void test_hemisphere(void **state)
{
	struct codec k;
	struct got g;
	uint8_t r[52];
	double p[3], q[4];
	uint8_t seq = 0;

	(void)state;
	codec_open(&k);
	/* both wands reported mirrored: left at x > 0, right at x < 0; the start puts them back */
	simple_report(r, seq++, 150, -100, 80, -200, -120, 60);
	assert_int_equal(feed(&k, r, sizeof(r), &g), 2);
	devtest_pose(&g.s[0], p, q);
	assert_float_equal(p[0], -0.150, 1e-9);
	devtest_pose(&g.s[1], p, q);
	assert_float_equal(p[0], 0.200, 1e-9);
	/* the right wand rises through the base's z = 0 plane: the base reports -p beyond it */
	for (int z = -60; z <= 60; z += 5) {
		int rz = z > 0 ? -z : z, sgn = z > 0 ? -1 : 1;

		simple_report(r, seq++, -150, 100, -80, sgn * 200, sgn * 120, rz);
		assert_int_equal(feed(&k, r, sizeof(r), &g), 2);
		devtest_pose(&g.s[1], p, q);
		assert_float_equal(p[0], 0.200, 1e-9);
		assert_float_equal(p[1], -0.120, 1e-9);
		assert_float_equal(p[2], -z * 1e-3, 1e-9);
	}
	/* a new stream forgets: the side rule again */
	hydra_codec.reset(k.st);
	simple_report(r, 0, -150, 100, -80, -200, -120, 60);
	assert_int_equal(feed(&k, r, sizeof(r), &g), 2);
	devtest_pose(&g.s[1], p, q);
	assert_float_equal(p[0], 0.200, 1e-9);
	assert_int_equal(k.c->malformed, 0);
	free(k.st);
}

static void test_sequence(void **state)
{
	static const uint8_t seqs[] = { 10, 11, 15, 16, 254, 255, 0, 1, 3 };
	struct codec k;
	struct got g;
	uint8_t r[52];

	(void)state;
	codec_open(&k);
	for (size_t i = 0; i < sizeof(seqs); i++) {
		simple_report(r, seqs[i], -150, 100, -80, 200, 120, -60);
		assert_int_equal(feed(&k, r, sizeof(r), &g), 2);
	}
	/* 12-14 lost (3), 17-253 lost (237), 2 lost (1) */
	assert_int_equal(k.c->lost, 3 + 237 + 1);
	assert_int_equal(k.c->reports, sizeof(seqs));
	/* the same report twice: dropped */
	assert_true(feed(&k, r, sizeof(r), &g) < 0);
	assert_int_equal(g.n, 0);
	assert_int_equal(k.c->malformed, 1);
	free(k.st);
}

static void test_malformed_reports(void **state)
{
	static const size_t lens[] = { 0, 1, 12, 51, 53, 64 };
	struct codec k;
	struct got g;
	uint8_t r[64] = { 0 }, good[52];
	uint64_t m = 0;

	(void)state;
	codec_open(&k);
	simple_report(good, 1, -150, 100, -80, 200, 120, -60);
	assert_int_equal(feed(&k, good, 52, &g), 2);
	for (size_t i = 0; i < sizeof(lens) / sizeof(lens[0]); i++) {
		memcpy(r, good, 52);
		assert_true(feed(&k, r, lens[i], &g) < 0);
		assert_int_equal(g.n, 0);
		assert_int_equal(k.c->malformed, ++m);
	}
	/* a zero quaternion, and one far from unit length */
	memcpy(r, good, 52);
	r[7] = 2;
	memset(r + 8 + 6, 0, 8);
	assert_true(feed(&k, r, 52, &g) < 0);
	memcpy(r, good, 52);
	r[7] = 2;
	put16(r + 30 + 6, 32767);
	put16(r + 30 + 8, 32767);
	assert_true(feed(&k, r, 52, &g) < 0);
	/* a unit quaternion but a wand 30 m away from where it was 4 ms ago */
	simple_report(r, 2, -150, 100, -80, 30000, 120, -60);
	assert_true(feed(&k, r, 52, &g) < 0);
	assert_int_equal(k.c->malformed, m + 3);
	/* 256 random reports: none gets through (seeded: the same bytes every run) */
	srand(4);
	for (int n = 0; n < 256; n++) {
		for (int i = 0; i < 52; i++)
			r[i] = (uint8_t)(rand() >> 7);
		assert_true(feed(&k, r, 52, &g) < 0);
	}
	/* the sequence went on from the last good report: nothing counted lost */
	simple_report(r, 2, -150, 101, -80, 200, 121, -60);
	assert_int_equal(feed(&k, r, 52, &g), 2);
	assert_int_equal(k.c->lost, 0);
	assert_int_equal(k.c->reports, 2);
	free(k.st);
}

/* a long enough run of "impossible" positions is the truth: tracking restarts from the sides */
static void test_jump_restart(void **state)
{
	struct codec k;
	struct got g;
	uint8_t r[52];
	double p[3], q[4];
	uint8_t seq = 0;

	(void)state;
	codec_open(&k);
	simple_report(r, seq++, -150, 100, -80, 200, 120, -60);
	assert_int_equal(feed(&k, r, 52, &g), 2);
	/* 3 m: too far even for the longest gap the sequence byte can show */
	for (int i = 0; i < 24; i++) {
		simple_report(r, seq++, -3000, 100, -80, 200, 120, -60);
		assert_true(feed(&k, r, 52, &g) < 0);
	}
	simple_report(r, seq++, -3000, 100, -80, 200, 120, -60);
	assert_true(feed(&k, r, 52, &g) < 0);
	simple_report(r, seq++, -3000, 100, -80, 200, 120, -60);
	assert_int_equal(feed(&k, r, 52, &g), 2);
	devtest_pose(&g.s[0], p, q);
	assert_float_equal(p[0], -3.0, 1e-9);
	/* the 25 rejected reports came in sequence: received (malformed), not lost as well */
	assert_int_equal(k.c->malformed, 25);
	assert_int_equal(k.c->lost, 0);
	/* one rejected in line, then one lost, then a good one: 1 malformed, 1 lost */
	simple_report(r, seq++, -3000, 100, -80, 2000, 120, -60);
	assert_true(feed(&k, r, 52, &g) < 0);
	seq++;
	simple_report(r, seq++, -3000, 101, -80, 200, 121, -60);
	assert_int_equal(feed(&k, r, 52, &g), 2);
	assert_int_equal(k.c->malformed, 26);
	assert_int_equal(k.c->lost, 1);
	free(k.st);
}

/*
 * How a script of reports counts. Each step is a report fed, or a number
 * the device sent that never came: G a good report, J one with an
 * impossible jump of the left wand, Q one whose quaternion is not unit
 * length, S one of the wrong length, D a repeat of the last good number,
 * L a number lost. The number is the step's own (S and D have none of theirs).
 */
struct step {
	char kind;
	uint8_t seq;
};

static void feed_step(struct codec *k, struct step s, uint8_t last_good)
{
	struct got g;
	uint8_t r[52];

	switch (s.kind) {
	case 'G':
		simple_report(r, s.seq, -150, 100, -80, 200, 120, -60);
		assert_int_equal(feed(k, r, 52, &g), 2);
		break;
	case 'J':
		/* 3 m away: too far even for the longest gap the sequence byte can show */
		simple_report(r, s.seq, -3000, 100, -80, 200, 120, -60);
		assert_int_equal(feed(k, r, 52, &g), -EINVAL);
		break;
	case 'Q':
		simple_report(r, s.seq, -150, 100, -80, 200, 120, -60);
		memset(r + 8 + 6, 0, 8);
		assert_int_equal(feed(k, r, 52, &g), -EINVAL);
		break;
	case 'S':
		simple_report(r, s.seq, -150, 100, -80, 200, 120, -60);
		assert_int_equal(feed(k, r, 12, &g), -EMSGSIZE);
		break;
	case 'D':
		simple_report(r, last_good, -150, 100, -80, 200, 120, -60);
		assert_int_equal(feed(k, r, 52, &g), -EINVAL);
		break;
	case 'L':
		return;
	default:
		fail_msg("no step '%c'", s.kind);
	}
	assert_true(s.kind == 'G' || g.n == 0);
}

/*
 * A rejected report whose number lies between the good reports around it
 * was received: malformed, and not lost as well, whatever else was
 * rejected or lost among them (docs/TRACKERS.md, Sequence numbers).
 */
static void test_rejects_counted_once(void **state)
{
	static const struct {
		const char *what;
		const char *kinds;
		uint8_t first;
		uint64_t malformed, lost;
	} cases[] = {
		/* the chain of jumps cut by another kind of reject: each report counted once */
		{ "jump, bad quaternion, jump", "GJQJG", 0, 3, 0 },
		{ "a bad quaternion alone", "GQG", 10, 1, 0 },
		{ "bad quaternion, then jumps, then a loss", "GQJJLG", 20, 3, 1 },
		{ "bad quaternions and jumps taking turns", "GJQJQJQG", 30, 6, 0 },
		/* the chain cut by a loss: the jumps after it were received too */
		{ "a loss inside the chain", "GJLJG", 40, 2, 1 },
		{ "a loss before the chain", "GLJJG", 50, 2, 1 },
		{ "losses around a jump", "GLLJLG", 60, 1, 3 },
		/* numberless or out-of-line rejects do not cut it, and were never lost */
		{ "jump, short report, jump", "GJSJG", 70, 3, 0 },
		{ "jump, repeat of the last good, jump", "GJDJG", 80, 3, 0 },
		{ "across the wrap", "GJQJG", 254, 3, 0 },
		{ "across the wrap, with a loss", "GQLJLG", 253, 2, 2 },
		/* the rule as it was (test_jump_restart) still holds */
		{ "jumps only, in line", "GJJJG", 90, 3, 0 },
		{ "a jump, then a loss", "GJLG", 100, 1, 1 },
	};

	(void)state;
	for (size_t c = 0; c < sizeof(cases) / sizeof(cases[0]); c++) {
		struct codec k;
		uint8_t seq = cases[c].first, last = 0;

		print_message("%s: %s\n", cases[c].what, cases[c].kinds);
		codec_open(&k);
		for (const char *p = cases[c].kinds; *p; p++) {
			struct step s = { *p, seq };

			feed_step(&k, s, last);
			if (*p == 'G')
				last = seq;
			if (*p != 'S' && *p != 'D')
				seq++;
		}
		assert_int_equal(k.c->reports, 2);
		assert_int_equal(k.c->malformed, cases[c].malformed);
		assert_int_equal(k.c->lost, cases[c].lost);
		free(k.st);
	}
	/* garbage numbered outside the gap takes nothing off it, nor off a later one */
	{
		struct codec k;

		codec_open(&k);
		feed_step(&k, (struct step){ 'G', 0 }, 0);
		feed_step(&k, (struct step){ 'Q', 200 }, 0);
		feed_step(&k, (struct step){ 'J', 5 }, 0);
		feed_step(&k, (struct step){ 'G', 2 }, 0);
		assert_int_equal(k.c->lost, 1);
		feed_step(&k, (struct step){ 'G', 7 }, 2);
		assert_int_equal(k.c->lost, 1 + 4);
		assert_int_equal(k.c->malformed, 2);
		free(k.st);
	}
}

/* the restart after 25 jumps, the chain cut by a bad quaternion: still nothing lost */
static void test_jump_restart_cut(void **state)
{
	struct codec k;
	uint8_t seq = 0;

	(void)state;
	codec_open(&k);
	feed_step(&k, (struct step){ 'G', seq++ }, 0);
	for (int i = 0; i < 12; i++)
		feed_step(&k, (struct step){ 'J', seq++ }, 0);
	feed_step(&k, (struct step){ 'Q', seq++ }, 0);
	/* 13 more jumps: 25 in a row but for the bad quaternion, which neither counts nor breaks the run */
	for (int i = 0; i < 13; i++)
		feed_step(&k, (struct step){ 'J', seq++ }, 0);
	/* tracking restarted from the sides: a report 3 m away is taken */
	{
		struct got g;
		uint8_t r[52];

		simple_report(r, seq++, -3000, 100, -80, 200, 120, -60);
		assert_int_equal(feed(&k, r, 52, &g), 2);
	}
	assert_int_equal(k.c->reports, 2);
	assert_int_equal(k.c->malformed, 26);
	assert_int_equal(k.c->lost, 0);
	free(k.st);
}

/* a new stream forgets the numbers rejected in the old one */
static void test_reset_forgets_rejects(void **state)
{
	struct codec k;

	(void)state;
	codec_open(&k);
	feed_step(&k, (struct step){ 'G', 0 }, 0);
	feed_step(&k, (struct step){ 'Q', 1 }, 0);
	feed_step(&k, (struct step){ 'J', 2 }, 0);
	hydra_codec.reset(k.st);
	/* the same numbers again, this time lost */
	feed_step(&k, (struct step){ 'G', 0 }, 0);
	feed_step(&k, (struct step){ 'G', 3 }, 0);
	assert_int_equal(k.c->malformed, 2);
	assert_int_equal(k.c->lost, 2);
	free(k.st);
}

/*
 * Many numbers, each good, rejected or lost at random, with numberless
 * and repeated reports between them: every number is counted once, as a
 * report, a malformed one or a lost one (seeded: the same script every run).
 */
static void test_every_number_once(void **state)
{
	struct codec k;
	uint8_t seq = 7, last = 7;
	uint64_t good = 0, bad = 0, gone = 0, extra = 0;
	int run = 0;

	(void)state;
	codec_open(&k);
	srand(11);
	feed_step(&k, (struct step){ 'G', seq++ }, 0);
	good++;
	for (int n = 0; n < 3000; n++) {
		static const char kinds[] = "GGGGJJQL";
		/* fewer than 25 rejects in a row (no restart), gaps well under 256 */
		char kind = run >= 10 || n == 2999 ? 'G' : kinds[rand() % 8];

		if (rand() % 8 == 0) {
			feed_step(&k, (struct step){ rand() % 2 ? 'S' : 'D', 0 }, last);
			extra++;
		}
		feed_step(&k, (struct step){ kind, seq }, last);
		if (kind == 'G') {
			last = seq;
			good++;
			run = 0;
		} else {
			run++;
			if (kind == 'L')
				gone++;
			else
				bad++;
		}
		seq++;
	}
	print_message("%" PRIu64 " good, %" PRIu64 " rejected, %" PRIu64 " lost, %" PRIu64 " without a number\n", good,
		      bad, gone, extra);
	assert_int_equal(k.c->reports, good);
	assert_int_equal(k.c->malformed, bad + extra);
	assert_int_equal(k.c->lost, gone);
	free(k.st);
}

/* the whole capture, decoded, against the motion it was made from */
static void test_capture_matches_clip(void **state)
{
	struct capture cap;
	struct clip clip;
	struct codec k;
	struct got g;
	char err[256];
	double worst_p = 0, worst_a = 0;
	int mirrored = 0, crossings = 0;
	bool was[2] = { false, false };

	(void)state;
	assert_int_equal(capture_load(&cap, CAPTURE, err, sizeof(err)), 0);
	assert_true(cap.timed);
	assert_int_equal(clip_load(&clip, CLIP), 0);
	codec_open(&k);
	for (int i = 0; i < cap.n; i++) {
		const uint8_t *b = cap.bytes + cap.rep[i].off;

		assert_int_equal(feed(&k, b, cap.rep[i].len, &g), 2);
		assert_float_equal(cap.rep[i].t, i / 250.0, 1e-6);
		for (int w = 0; w < 2; w++) {
			struct clip_pose local, world, want;
			const uint8_t *blk = b + 8 + 22 * w;
			uint32_t bits = 0;

			devtest_pose(&g.s[w], local.p, local.q);
			/* the report's x against the decoded one (the tracker frame keeps the base's x) */
			{
				bool neg = (int16_t)(blk[0] | blk[1] << 8) * local.p[0] < 0;

				mirrored += neg;
				crossings += i && neg != was[w];
				was[w] = neg;
			}
			clip_to_world(base_origin, BASE_YAW, &local, &world);
			clip_at(&clip, w == HYDRA_LEFT ? CLIP_LHAND : CLIP_RHAND, CAPTURE_T0 + cap.rep[i].t, &want);
			worst_p = fmax(worst_p, clip_dist(world.p, want.p));
			worst_a = fmax(worst_a, clip_angle(world.q, want.q));
			/* the inputs, by the table of docs/TRACKERS.md */
			bits |= blk[14] & 0x01 ? 1u << 5 : 0;
			bits |= blk[14] & 0x02 ? 1u << 3 : 0;
			bits |= blk[14] & 0x04 ? 1u << 1 : 0;
			bits |= blk[14] & 0x08 ? 1u << 2 : 0;
			bits |= blk[14] & 0x10 ? 1u << 4 : 0;
			bits |= blk[14] & 0x20 ? 1u << 0 : 0;
			bits |= blk[14] & 0x40 ? 1u << 6 : 0;
			assert_int_equal(g.s[w].buttons, bits);
			assert_float_equal(g.s[w].analog[0], (int16_t)(blk[15] | blk[16] << 8) / 32768.0, 1e-6);
			assert_float_equal(g.s[w].analog[1], (int16_t)(blk[17] | blk[18] << 8) / 32768.0, 1e-6);
			assert_float_equal(g.s[w].analog[2], blk[19] / 255.0, 1e-6);
		}
	}
	print_message("hydra capture: %d reports, worst position error %.3f mm, angle %.5f rad\n", cap.n, worst_p * 1e3,
		      worst_a);
	assert_true(worst_p <= POS_TOL);
	assert_true(worst_a <= ANG_TOL);
	assert_int_equal(k.c->malformed, 0);
	assert_int_equal(k.c->lost, 0);
	/* the capture crosses the base's plane: without the continuity the error would be metres */
	print_message("reports where the base gave the mirror image: %d, crossings: %d\n", mirrored, crossings);
	assert_true(mirrored > 0 && crossings >= 2);
	free(k.st);
	clip_free(&clip);
	capture_free(&cap);
}

/* ---- the driver on the simulated device --------------------------------------------------- */

static struct fake_hid_stats stats(void)
{
	struct fake_hid_stats s;

	fake_hid_stats(&s);
	return s;
}

static bool requested(struct gwt *t, void *arg)
{
	(void)t;
	return stats().motion_requests >= *(int *)arg;
}

static bool samples_above(struct gwt *t, void *arg)
{
	uint64_t *n = arg;

	return ctr_get(&gwt_tracker(t, "hydra")->st.samples) > *n;
}

static uint64_t reads(void)
{
	return stats().delivered;
}

/* what the drivers noted so far holds arg (t->notes keeps them) */
static bool noted(struct gwt *t, void *arg)
{
	gwt_take_notes(t);
	return strstr(t->notes, arg) != NULL;
}

/* the hands' wire sensor indices: FRAME sensors are head, left hand, right hand */
static const int wire_of[2] = { WIRE_S_LEFT_HAND, WIRE_S_RIGHT_HAND };

static void plug_motion(void)
{
	fake_hid_plug(true);
}

static void plug_gamepad(void)
{
	fake_hid_plug(false);
}

static void deny_open(bool deny)
{
	fake_hid_deny_open(deny ? EACCES : 0);
}

/* the driver probed, found gamepad mode and sent the motion-mode request */
static bool motion_requested(void)
{
	return stats().motion_requests >= 1;
}

/* the Hydra for the steps every device goes through (fake/devtest.h), plugged in by plug_fn */
#define HYDRA_DEVTEST(plug_fn)                                                                                         \
	{                                                                                                              \
		.source = "hydra", .conf = conf_device, .sensors = 1u << WIRE_S_LEFT_HAND | 1u << WIRE_S_RIGHT_HAND,   \
		.inputs = true, .drv = &hydra_driver, .plug = plug_fn, .unplug = fake_hid_unplug,                      \
		.deny_open = deny_open, .denied = "Permission denied", .stepped = fake_hid_stepped,                    \
		.set_up = motion_requested, .reads = reads,                                                            \
	}

/* found streaming (left in motion mode by a program before us) */
static struct devtest hydra = HYDRA_DEVTEST(plug_motion);
/* as it comes from the box, and back from every replug: in gamepad mode, to be switched */
static struct devtest hydra_gamepad = HYDRA_DEVTEST(plug_gamepad);

/* handshake from gamepad mode, then every report of the capture, one at a time, through the gateway */
static void test_published_poses_and_inputs(void **state)
{
	static struct gwt t;
	struct clip clip;
	double worst_p = 0, worst_a = 0;

	(void)state;
	assert_int_equal(clip_load(&clip, CLIP), 0);
	/* the driver probes, finds gamepad mode, sends the motion-mode request to interface 1 */
	devtest_stepped(&t, &hydra_gamepad, conf_stepped);
	for (int i = 0; i < fake_hid_capture_count(); i++) {
		uint64_t before = ctr_get(&gwt_tracker(&t, "hydra")->st.samples);
		struct fake_hid_stats s;

		fake_hid_release(1);
		assert_true(gwt_until(&t, samples_above, &before, 5000) >= 0);
		s = stats();
		assert_int_equal(s.last_index, i);
		for (int w = 0; w < 2; w++) {
			const struct wire_sensor_sample *ws = &t.f.sensor[wire_of[w]];
			struct clip_pose want, got;
			size_t len;
			const uint8_t *blk = fake_hid_capture_report(i, &len) + 8 + 22 * w;

			assert_int_equal(ws->state, WIRE_SENSOR_OK);
			for (int k = 0; k < 3; k++)
				got.p[k] = ws->pose.p[k];
			for (int k = 0; k < 4; k++)
				got.q[k] = ws->pose.q[k];
			clip_at(&clip, w == HYDRA_LEFT ? CLIP_LHAND : CLIP_RHAND, CAPTURE_T0 + i / 250.0, &want);
			worst_p = fmax(worst_p, clip_dist(got.p, want.p));
			worst_a = fmax(worst_a, clip_angle(got.q, want.q));
			/* the input block: both hands present, the head has none */
			assert_true(t.f.h.flags & WIRE_F_INPUTS);
			assert_int_equal(t.f.in.present, 1u << WIRE_S_LEFT_HAND | 1u << WIRE_S_RIGHT_HAND);
			assert_float_equal(t.f.in.analog[wire_of[w]][2], blk[19] / 255.0, 1e-6);
			assert_float_equal(t.f.in.analog[wire_of[w]][0], (int16_t)(blk[15] | blk[16] << 8) / 32768.0,
					   1e-6);
			assert_int_equal(!!(t.f.in.buttons[wire_of[w]] & HYDRA_BTN_BUMPER), !!(blk[14] & 0x01));
			assert_int_equal(!!(t.f.in.buttons[wire_of[w]] & HYDRA_BTN_START), !!(blk[14] & 0x20));
		}
		assert_int_equal(gwt_state(&t, "hydra"), TRACKER_OK);
	}
	print_message("published: worst position error %.3f mm, angle %.5f rad (float32 on the wire)\n", worst_p * 1e3,
		      worst_a);
	assert_true(worst_p <= POS_TOL + 2e-6);
	assert_true(worst_a <= ANG_TOL + 1e-6);
	assert_int_equal(ctr_get(&gwt_tracker(&t, "hydra")->st.malformed), 0);
	assert_int_equal(ctr_get(&gwt_tracker(&t, "hydra")->st.lost), 0);
	assert_int_equal(stats().motion_requests, 1);
	assert_int_equal(stats().wrong_node, 0);
	assert_true(stats().get_features >= 1);
	gwt_close(&t);
	/* found in gamepad mode: left in gamepad mode */
	assert_int_equal(stats().gamepad_requests, 1);
	assert_int_equal(stats().closes, stats().opens);
	clip_free(&clip);
}

static void test_found_in_motion_mode(void **state)
{
	static struct gwt t;

	(void)state;
	devtest_up(&t, &hydra);
	gwt_close(&t);
	assert_int_equal(stats().motion_requests, 0);
	assert_int_equal(stats().gamepad_requests, 0);
}

/* in gamepad mode again after the replug: switched again */
static void test_unplug_replug(void **state)
{
	static struct gwt t;

	(void)state;
	devtest_unplug_replug(&t, &hydra_gamepad);
	assert_int_equal(stats().motion_requests, 2);
	gwt_take_notes(&t);
	assert_non_null(strstr(t.notes, "unplugged? Looking for it again"));
	gwt_close(&t);
	/* the unplugged handle was not told anything; the new one goes back to gamepad mode */
	assert_int_equal(stats().gamepad_requests, 1);
}

static void test_bad_reports(void **state)
{
	static struct gwt t;
	struct tracker *h;
	uint8_t junk[64];
	static const size_t lens[] = { 12, 51, 53, 64 };
	uint64_t m0, f0;

	(void)state;
	h = devtest_up(&t, &hydra);
	m0 = ctr_get(&h->st.malformed);
	f0 = ctr_get(&h->st.faults);
	memset(junk, 0x5a, sizeof(junk));
	for (size_t i = 0; i < sizeof(lens) / sizeof(lens[0]); i++)
		fake_hid_inject(junk, lens[i]);
	/* 52 bytes of garbage: random bytes, and a copy of a real report with the positions scrambled */
	srand(9);
	for (int i = 0; i < 52; i++)
		junk[i] = (uint8_t)(rand() >> 5);
	fake_hid_inject(junk, 52);
	{
		size_t len;

		memcpy(junk, fake_hid_capture_report(100, &len), 52);
		put16(junk + 8, 20000);
		put16(junk + 30 + 2, -25000);
		junk[7] = 0x77;
		fake_hid_inject(junk, 52);
	}
	devtest_run_reading(&t, &hydra, 300, 6 + 2);
	assert_int_equal(ctr_get(&h->st.malformed) - m0, 6);
	/* dropped and counted, nothing else: still OK, no sample lost, never a 20 m hand (gwt_cycle checks) */
	assert_int_equal(gwt_state(&t, "hydra"), TRACKER_OK);
	assert_int_equal(ctr_get(&h->st.faults), f0);
	assert_int_equal(ctr_get(&h->st.lost), 0);
	for (int w = 0; w < 2; w++)
		assert_true(clip_dist((double[3]){ t.f.sensor[wire_of[w]].pose.p[0], t.f.sensor[wire_of[w]].pose.p[1],
						   t.f.sensor[wire_of[w]].pose.p[2] },
				      base_origin) < 1.5);
	gwt_close(&t);
}

static void test_stuck_in_gamepad_mode(void **state)
{
	static struct gwt t;
	int three = 3, ms;

	(void)state;
	hydra_timing.retry_ms = 200; /* the real 5 s between requests would make this a long test */
	fake_hid_ignore_requests(true);
	fake_hid_plug(false);
	gwt_open(&t, conf_device);
	assert_true(gwt_until(&t, requested, &three, 3000) >= 0);
	assert_true(devtest_missing(&t, &hydra));
	assert_int_equal(ctr_get(&gwt_tracker(&t, "hydra")->st.samples), 0);
	gwt_take_notes(&t);
	assert_non_null(strstr(t.notes, "asking again"));
	{
		char st[256];
		struct tracker *h = gwt_tracker(&t, "hydra");

		h->drv->status(h, st, sizeof(st));
		assert_non_null(strstr(st, "gamepad mode"));
	}
	/* it finally obeys */
	fake_hid_ignore_requests(false);
	ms = gwt_until(&t, devtest_ok, &hydra, 2000);
	assert_true(ms >= 0 && ms < 1000);
	gwt_close(&t);
}

static void test_sequence_gaps(void **state)
{
	static struct gwt t;
	struct tracker *h;

	(void)state;
	h = devtest_up(&t, &hydra);
	fake_hid_skip(5);
	devtest_run_reading(&t, &hydra, 100, 2);
	fake_hid_skip(3);
	devtest_run_reading(&t, &hydra, 100, 2);
	assert_int_equal(ctr_get(&h->st.lost), 8);
	assert_int_equal(ctr_get(&h->st.malformed), 0);
	assert_int_equal(gwt_state(&t, "hydra"), TRACKER_OK);
	gwt_close(&t);
}

/*
 * Reports damaged on their way (a corrupted transfer): dropped, and each
 * counted once, received or lost, through the device thread to the
 * tracker's counters (the decoder's own cases: test_rejects_counted_once).
 */
static void test_damaged_reports(void **state)
{
	static const struct {
		const char *script;
		uint64_t malformed, lost;
	} cases[] = {
		{ "JQJ", 3, 0 },     /* a run of jumps cut by a bad quaternion */
		{ "LJSQLLJ", 4, 3 }, /* and by losses and a short report */
		{ "QLJJJL", 4, 2 },
	};
	static struct gwt t;
	struct tracker *h;
	uint64_t f0;

	(void)state;
	h = devtest_up(&t, &hydra);
	f0 = ctr_get(&h->st.faults);
	for (size_t c = 0; c < sizeof(cases) / sizeof(cases[0]); c++) {
		uint64_t m0 = ctr_get(&h->st.malformed), l0 = ctr_get(&h->st.lost);

		fake_hid_damage(cases[c].script);
		devtest_run_reading(&t, &hydra, 150, (int)strlen(cases[c].script) + 2);
		print_message("%s: %" PRIu64 " malformed, %" PRIu64 " lost\n", cases[c].script,
			      ctr_get(&h->st.malformed) - m0, ctr_get(&h->st.lost) - l0);
		assert_int_equal(ctr_get(&h->st.malformed) - m0, cases[c].malformed);
		assert_int_equal(ctr_get(&h->st.lost) - l0, cases[c].lost);
		assert_true(devtest_ok(&t, &hydra));
	}
	assert_int_equal(ctr_get(&h->st.faults), f0);
	gwt_close(&t);
}

static void test_stall(void **state)
{
	static struct gwt t;
	struct tracker *h;
	int ms;
	uint64_t t0;

	(void)state;
	h = devtest_up(&t, &hydra);
	fake_hid_stall(900);
	t0 = gwt_ms();
	/* no report: STALE after stale_ms (the hands keep their last pose, flagged) */
	assert_true(gwt_until(&t, devtest_stale, &hydra, 400) >= 0);
	/* then the driver gives up on the stream and asks for motion mode again: FAULTY meanwhile */
	assert_true(gwt_until(&t, gwt_tracker_faulty, "hydra", 1000) >= 0);
	ms = gwt_until(&t, devtest_ok, &hydra, 2000);
	print_message("stalled 900 ms: OK again %d ms after the stall ended\n", (int)(gwt_ms() - t0) - 900);
	assert_true(ms >= 0 && gwt_ms() - t0 < 900 + 1000);
	assert_int_equal(ctr_get(&h->st.reconnects), 1);
	gwt_take_notes(&t);
	assert_non_null(strstr(t.notes, "no motion report for 500 ms"));
	gwt_close(&t);
}

/* the Windows configurator or a glitch puts it back into gamepad mode while we read */
static void test_mode_changed_behind_our_back(void **state)
{
	static struct gwt t;
	uint8_t small[12] = { 0 };
	uint64_t t0;
	int two = 2;

	(void)state;
	devtest_up(&t, &hydra_gamepad);
	/* gamepad mode: no motion reports at all */
	fake_hid_set_mode(false);
	t0 = gwt_ms();
	assert_true(gwt_until(&t, requested, &two, 5000) >= 0);
	assert_true(gwt_until(&t, devtest_ok, &hydra, 5000) >= 0);
	assert_true(gwt_ms() - t0 < 500 + 250 + 1000);
	/* reports of the wrong length, a run of them: the driver takes it as a mode change */
	for (int i = 0; i < 30; i++)
		fake_hid_inject(small, sizeof(small));
	assert_true(gwt_until(&t, noted, "reports of the wrong length in a row", 5000) >= 0);
	assert_true(gwt_until(&t, devtest_ok, &hydra, 5000) >= 0);
	assert_int_equal(ctr_get(&gwt_tracker(&t, "hydra")->st.reconnects), 2);
	gwt_close(&t);
}

static void test_permission_denied(void **state)
{
	static struct gwt t;

	(void)state;
	devtest_denied(&t, &hydra);
	gwt_close(&t);
}

static void test_list_devices(void **state)
{
	static const char *const says[] = { "Razer Hydra (1532:0300)", "/dev/fake-hidraw",
					    "[source hydra]\n  type = hydra\n  device = /dev/fake-hidraw", NULL };

	(void)state;
	devtest_list_devices(&hydra_gamepad, says);
	/* listing leaves the device as it was */
	assert_int_equal(stats().motion_requests, 0);
	assert_int_equal(stats().opens, stats().closes);
}

/* the loop's side (poll, frames, encoding) allocates nothing, whatever the device thread does */
static void test_loop_allocates_nothing(void **state)
{
	static struct gwt t;

	(void)state;
	/* the replug in gamepad mode: the whole handshake again while the loop is counted */
	devtest_loop_allocates_nothing(&t, &hydra_gamepad);
}

/* event mode: the driver's descriptor wakes the loop when a report came */
static void test_event_fd(void **state)
{
	static struct gwt t;
	struct tracker *h;
	struct pollfd p;

	(void)state;
	h = devtest_stepped(&t, &hydra_gamepad, conf_device);
	gwt_run(&t, 20);
	p = (struct pollfd){ h->drv->fd(h), POLLIN, 0 };
	assert_true(p.fd >= 0);
	assert_int_equal(poll(&p, 1, 0), 0);
	fake_hid_release(1);
	assert_int_equal(poll(&p, 1, 1000), 1);
	gwt_cycle(&t);
	assert_int_equal(poll(&p, 1, 0), 0);
	gwt_close(&t);
}

/* capture = FILE: the same decoder, no device; the mount offset moves the tracked point */
static void test_capture_source_and_mount(void **state)
{
	static struct gwt t;
	char conf[2048];
	struct clip clip;
	struct clip_pose want;
	double off[3], q[4], want_p[3];

	(void)state;
	snprintf(conf, sizeof(conf), CONF_HEAD "capture = %s\nspeed = 4\nloop = no\nmount_left = 0 0.1 0\n", CAPTURE);
	assert_int_equal(clip_load(&clip, CLIP), 0);
	/* 2 s of capture at 4x */
	devtest_capture(&t, &hydra, conf, 2 * 500);
	assert_int_equal(stats().enumerations, 0);
	/* the last report's left wand, 10 cm along its own y */
	clip_at(&clip, CLIP_LHAND, CAPTURE_T0 + 499 / 250.0, &want);
	for (int k = 0; k < 4; k++)
		q[k] = want.q[k];
	off[0] = 2 * (q[1] * q[2] - q[0] * q[3]) * 0.1;
	off[1] = (1 - 2 * (q[1] * q[1] + q[3] * q[3])) * 0.1;
	off[2] = 2 * (q[2] * q[3] + q[0] * q[1]) * 0.1;
	for (int k = 0; k < 3; k++)
		want_p[k] = want.p[k] + off[k];
	assert_true(
		clip_dist((double[3]){ t.f.sensor[WIRE_S_LEFT_HAND].pose.p[0], t.f.sensor[WIRE_S_LEFT_HAND].pose.p[1],
				       t.f.sensor[WIRE_S_LEFT_HAND].pose.p[2] },
			  want_p) < POS_TOL + 1e-5);
	gwt_close(&t);
	clip_free(&clip);
}

/* record = FILE: what the device sent, as a capture that plays back the same */
static void test_record(void **state)
{
	static struct gwt t;
	char conf[2048], path[64], err[256];
	struct capture cap;

	(void)state;
	snprintf(path, sizeof(path), "/tmp/avatargw-test-record-%d.cap", (int)getpid());
	snprintf(conf, sizeof(conf), CONF_HEAD "record = %s\n", path);
	devtest_stepped(&t, &hydra_gamepad, conf);
	for (int i = 0; i < 10; i++) {
		uint64_t before = ctr_get(&gwt_tracker(&t, "hydra")->st.samples);

		fake_hid_release(1);
		assert_true(gwt_until(&t, samples_above, &before, 5000) >= 0);
	}
	gwt_close(&t);
	assert_int_equal(capture_load(&cap, path, err, sizeof(err)), 0);
	unlink(path);
	assert_int_equal(cap.n, 10);
	assert_true(cap.timed);
	for (int i = 0; i < 10; i++) {
		size_t len;
		const uint8_t *want = fake_hid_capture_report(i, &len), *got = cap.bytes + cap.rep[i].off;

		assert_int_equal(cap.rep[i].len, 52);
		/* the device's bytes, its own sequence number in 7 and 29 */
		for (int b = 0; b < 52; b++)
			if (b != 7 && b != 29)
				assert_int_equal(got[b], want[b]);
		if (i)
			assert_int_equal((uint8_t)(got[7] - cap.bytes[cap.rep[i - 1].off + 7]), 1);
		assert_true(cap.rep[i].t >= (i ? cap.rep[i - 1].t : 0));
	}
	capture_free(&cap);
}

/*
 * A reload opens the new configuration's source while the old one still
 * reads the device, then closes the old one: the device must stay in
 * motion mode throughout and go back to gamepad mode only at the very end.
 */
static void test_reload_keeps_the_mode(void **state)
{
	static struct gwt a, b;

	(void)state;
	devtest_up(&a, &hydra_gamepad);
	gwt_open(&b, conf_device);
	assert_true(gwt_until(&b, devtest_ok, &hydra, 5000) >= 0);
	gwt_close(&a);
	for (uint64_t t0 = gwt_ms(); gwt_ms() - t0 < 800;) {
		gwt_cycle(&b);
		/* never lost (a loaded host may leave a sample late enough to be STALE for a cycle) */
		assert_int_not_equal(atomic_load(&gwt_tracker(&b, "hydra")->st.state), TRACKER_FAULTY);
		gwt_sleep_ms(5);
	}
	assert_true(gwt_until(&b, devtest_ok, &hydra, 5000) >= 0);
	assert_int_equal(stats().gamepad_requests, 0);
	assert_int_equal(stats().motion_requests, 1);
	assert_int_equal(ctr_get(&gwt_tracker(&b, "hydra")->st.reconnects), 0);
	gwt_close(&b);
	assert_int_equal(stats().gamepad_requests, 1);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test_setup_teardown(test_report_layout, setup, gwt_teardown),
		cmocka_unit_test_setup_teardown(test_hemisphere, setup, gwt_teardown),
		cmocka_unit_test_setup_teardown(test_sequence, setup, gwt_teardown),
		cmocka_unit_test_setup_teardown(test_malformed_reports, setup, gwt_teardown),
		cmocka_unit_test_setup_teardown(test_jump_restart, setup, gwt_teardown),
		cmocka_unit_test_setup_teardown(test_rejects_counted_once, setup, gwt_teardown),
		cmocka_unit_test_setup_teardown(test_jump_restart_cut, setup, gwt_teardown),
		cmocka_unit_test_setup_teardown(test_reset_forgets_rejects, setup, gwt_teardown),
		cmocka_unit_test_setup_teardown(test_every_number_once, setup, gwt_teardown),
		cmocka_unit_test_setup_teardown(test_capture_matches_clip, setup, gwt_teardown),
		cmocka_unit_test_setup_teardown(test_published_poses_and_inputs, setup, gwt_teardown),
		cmocka_unit_test_setup_teardown(test_found_in_motion_mode, setup, gwt_teardown),
		cmocka_unit_test_setup_teardown(test_unplug_replug, setup, gwt_teardown),
		cmocka_unit_test_setup_teardown(test_bad_reports, setup, gwt_teardown),
		cmocka_unit_test_setup_teardown(test_stuck_in_gamepad_mode, setup, gwt_teardown),
		cmocka_unit_test_setup_teardown(test_sequence_gaps, setup, gwt_teardown),
		cmocka_unit_test_setup_teardown(test_damaged_reports, setup, gwt_teardown),
		cmocka_unit_test_setup_teardown(test_stall, setup, gwt_teardown),
		cmocka_unit_test_setup_teardown(test_mode_changed_behind_our_back, setup, gwt_teardown),
		cmocka_unit_test_setup_teardown(test_permission_denied, setup, gwt_teardown),
		cmocka_unit_test_setup_teardown(test_list_devices, setup, gwt_teardown),
		cmocka_unit_test_setup_teardown(test_loop_allocates_nothing, setup, gwt_teardown),
		cmocka_unit_test_setup_teardown(test_event_fd, setup, gwt_teardown),
		cmocka_unit_test_setup_teardown(test_capture_source_and_mount, setup, gwt_teardown),
		cmocka_unit_test_setup_teardown(test_record, setup, gwt_teardown),
		cmocka_unit_test_setup_teardown(test_reload_keeps_the_mode, setup, gwt_teardown),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
