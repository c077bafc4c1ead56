// SPDX-License-Identifier: MIT
/*
 * test_vrpn_in.c - the VRPN client source's decoder (trackers/vrpn_in.c) fed
 * messages built here from the protocol: descriptions, tracker reports
 * (x y z w on the wire, w x y z in the sample), buttons and analog values
 * given to channels, channels not taken, other devices, truncated and
 * malformed messages, a new connection forgetting the server's ids, the
 * sample times; the device names it accepts; the framing shared with the
 * server (wire/vrpn_proto.c). tests/e2e/test_cave.py runs the source
 * against the daemon's own VRPN server and a misbehaving one.
 */
#include "trackers/vrpn_in.h"

#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "testutil.h"

struct got {
	int n;
	int sensor[8];
	struct device_sample s[8];
};

static void collect(void *ctx, int sensor, const struct device_sample *s)
{
	struct got *g = ctx;

	if (g->n < 8) {
		g->sensor[g->n] = sensor;
		g->s[g->n] = *s;
	}
	g->n++;
}

static struct vrpn_in_codec_st *codec_open(struct cfg_source *cfg)
{
	struct vrpn_in_codec_st *v = calloc(1, vrpn_in_codec.size);
	char err[256];

	assert_non_null(v);
	assert_int_equal(vrpn_in_codec.init(v, cfg, err, sizeof(err)), 0);
	return v;
}

static int feed(struct vrpn_in_codec_st *v, const uint8_t *m, size_t len, struct got *g)
{
	g->n = 0;
	return vrpn_in_codec.feed(v, m, len, collect, g);
}

/* the server's descriptions: its device Tracker0 as sender 3, its types as 10 + VT_* */
static void describe(struct vrpn_in_codec_st *v, const char *device)
{
	static const char *const types[] = { VRPN_T_POS_QUAT, VRPN_T_BUTTON_CHANGE, VRPN_T_BUTTON_STATES, VRPN_T_ANALOG,
					     VRPN_T_PONG };
	uint8_t m[256];
	struct got g;
	size_t n;

	n = vrpn_msg_description(m, VRPN_SENDER_DESCRIPTION, 2, "SomethingElse", 0);
	assert_int_equal(feed(v, m, n, &g), 0);
	n = vrpn_msg_description(m, VRPN_SENDER_DESCRIPTION, 3, device, 0);
	assert_int_equal(feed(v, m, n, &g), 0);
	for (int i = 0; i < 5; i++) {
		n = vrpn_msg_description(m, VRPN_TYPE_DESCRIPTION, 10 + i, types[i], 0);
		assert_int_equal(feed(v, m, n, &g), 0);
	}
}

static size_t pos_quat(uint8_t *m, int32_t sender, int32_t ch, const double p[3], const double xyzw[4], uint64_t t)
{
	uint8_t *q = vrpn_msg_header(m, 10, sender, t, VRPN_POS_QUAT_LEN);

	vrpn_put32(q, (uint32_t)ch);
	vrpn_put32(q + 4, 0);
	for (int i = 0; i < 3; i++)
		vrpn_put_f64(q + 8 + 8 * i, p[i]);
	for (int i = 0; i < 4; i++)
		vrpn_put_f64(q + 32 + 8 * i, xyzw[i]);
	return VRPN_MSG_LEN(VRPN_POS_QUAT_LEN);
}

static struct vrpn_in_opts base_opts;

static struct cfg_source base_cfg(void)
{
	struct cfg_source cfg;

	memset(&cfg, 0, sizeof(cfg));
	memset(&base_opts, 0, sizeof(base_opts));
	snprintf(base_opts.dev.device, sizeof(base_opts.dev.device), "Tracker0@localhost");
	base_opts.sensors = 4;
	cfg.opt = &base_opts;
	return cfg;
}

static void test_device_names(void **state)
{
	char name[VRPN_NAME_MAX], host[128];
	int port;
	bool tcp;

	(void)state;
	assert_int_equal(vrpn_in_parse_device("Tracker0@host", name, sizeof(name), host, sizeof(host), &port, &tcp), 0);
	assert_string_equal(name, "Tracker0");
	assert_string_equal(host, "host");
	assert_int_equal(port, 3883);
	assert_false(tcp);
	assert_int_equal(
		vrpn_in_parse_device("DTrack@10.0.0.2:3884", name, sizeof(name), host, sizeof(host), &port, &tcp), 0);
	assert_string_equal(host, "10.0.0.2");
	assert_int_equal(port, 3884);
	assert_int_equal(
		vrpn_in_parse_device("T@tcp://cave.lab:4000", name, sizeof(name), host, sizeof(host), &port, &tcp), 0);
	assert_true(tcp);
	assert_string_equal(host, "cave.lab");
	assert_int_equal(port, 4000);
	assert_int_equal(vrpn_in_parse_device("T@tcp:cave", name, sizeof(name), host, sizeof(host), &port, &tcp), 0);
	assert_true(tcp);
	assert_string_equal(host, "cave");
	assert_int_equal(vrpn_in_parse_device("T@[::1]:3885", name, sizeof(name), host, sizeof(host), &port, &tcp), 0);
	assert_string_equal(host, "::1");
	assert_int_equal(port, 3885);
	/* refused: no name, no host, a bad port, a bare IPv6 address, an unclosed bracket */
	assert_int_equal(vrpn_in_parse_device("@host", name, sizeof(name), host, sizeof(host), &port, &tcp), -1);
	assert_int_equal(vrpn_in_parse_device("Tracker0", name, sizeof(name), host, sizeof(host), &port, &tcp), -1);
	assert_int_equal(vrpn_in_parse_device("T@", name, sizeof(name), host, sizeof(host), &port, &tcp), -1);
	assert_int_equal(vrpn_in_parse_device("T@h:0", name, sizeof(name), host, sizeof(host), &port, &tcp), -1);
	assert_int_equal(vrpn_in_parse_device("T@h:70000", name, sizeof(name), host, sizeof(host), &port, &tcp), -1);
	assert_int_equal(vrpn_in_parse_device("T@h:x", name, sizeof(name), host, sizeof(host), &port, &tcp), -1);
	assert_int_equal(vrpn_in_parse_device("T@::1", name, sizeof(name), host, sizeof(host), &port, &tcp), -1);
	assert_int_equal(vrpn_in_parse_device("T@[::1", name, sizeof(name), host, sizeof(host), &port, &tcp), -1);
}

static void test_pose(void **state)
{
	struct cfg_source cfg = base_cfg();
	struct vrpn_in_codec_st *v = codec_open(&cfg);
	double p[3] = { 0.5, -1.25, 2.0 }, q[4] = { 0.1, 0.2, 0.3, 0.0 }, w = sqrt(1 - 0.14);
	uint8_t m[256];
	struct got g;
	struct vec3 t;
	uint64_t before, after;

	(void)state;
	q[3] = w;
	/* before the server said which sender is Tracker0: not ours */
	assert_int_equal(feed(v, m, pos_quat(m, 3, 1, p, q, real_ns()), &g), 0);
	assert_int_equal(g.n, 0);
	describe(v, "Tracker0");
	before = real_ns();
	assert_int_equal(feed(v, m, pos_quat(m, 3, 1, p, q, before), &g), 1);
	after = real_ns();
	assert_int_equal(g.n, 1);
	assert_int_equal(g.sensor[0], 1);
	dq_translation(&g.s[0].pose, &t);
	assert_near(t.x, 0.5, 1e-12);
	assert_near(t.y, -1.25, 1e-12);
	assert_near(t.z, 2.0, 1e-12);
	/* x y z w on the wire, w x y z here */
	assert_near(g.s[0].pose.r.w, w, 1e-12);
	assert_near(g.s[0].pose.r.x, 0.1, 1e-12);
	assert_near(g.s[0].pose.r.y, 0.2, 1e-12);
	assert_near(g.s[0].pose.r.z, 0.3, 1e-12);
	assert_false(g.s[0].inputs);
	/* the sample time: the server's (microseconds) on our clock, never after it arrived */
	assert_true(g.s[0].t_ns >= before - 1000 && g.s[0].t_ns <= after);
	/* another sender's report, a channel not taken: not samples */
	assert_int_equal(feed(v, m, pos_quat(m, 2, 1, p, q, real_ns()), &g), 0);
	assert_int_equal(feed(v, m, pos_quat(m, 3, 4, p, q, real_ns()), &g), 0);
	assert_int_equal(g.n, 0);
	assert_int_equal(v->ignored, 1);
	assert_int_equal(v->others, 2); /* with the report before the descriptions */
	assert_int_equal(v->seen[1], 1);
	assert_int_equal(v->seen[4], 1);
	assert_int_equal(v->c.malformed, 0);
	free(v);
}

static void test_malformed(void **state)
{
	struct cfg_source cfg = base_cfg();
	struct vrpn_in_codec_st *v = codec_open(&cfg);
	double p[3] = { 0, 0, 1 }, q[4] = { 0, 0, 0, 1 };
	uint8_t m[256];
	struct got g;
	size_t n;
	uint64_t bad = 0;

	(void)state;
	describe(v, "Tracker0");
	n = pos_quat(m, 3, 0, p, q, real_ns());
	/* cut short: shorter than its header says, shorter than a header */
	assert_true(feed(v, m, n - 8, &g) < 0);
	assert_int_equal(v->c.malformed, ++bad);
	assert_true(feed(v, m, 20, &g) < 0);
	assert_int_equal(v->c.malformed, ++bad);
	/* a length no VRPN peer writes */
	vrpn_put32(m, 8);
	assert_true(feed(v, m, n, &g) < 0);
	assert_int_equal(v->c.malformed, ++bad);
	/* a Pos_Quat whose payload is too short for a pose */
	vrpn_msg_header(m, 10, 3, real_ns(), 40);
	assert_true(feed(v, m, VRPN_MSG_LEN(40), &g) < 0);
	assert_int_equal(v->c.malformed, ++bad);
	/* not a unit quaternion, NaN, a negative channel, microseconds past a second */
	q[3] = 0.5;
	assert_true(feed(v, m, pos_quat(m, 3, 0, p, q, real_ns()), &g) < 0);
	q[3] = NAN;
	assert_true(feed(v, m, pos_quat(m, 3, 0, p, q, real_ns()), &g) < 0);
	q[3] = 1;
	p[1] = INFINITY;
	assert_true(feed(v, m, pos_quat(m, 3, 0, p, q, real_ns()), &g) < 0);
	p[1] = 0;
	assert_true(feed(v, m, pos_quat(m, 3, -1, p, q, real_ns()), &g) < 0);
	n = pos_quat(m, 3, 0, p, q, real_ns());
	vrpn_put32(m + 8, 1000000);
	assert_true(feed(v, m, n, &g) < 0);
	bad += 5;
	assert_int_equal(v->c.malformed, bad);
	/* a description whose name runs past its message */
	n = vrpn_msg_description(m, VRPN_SENDER_DESCRIPTION, 4, "Tracker1", 0);
	vrpn_put32(m + VRPN_HEADER_LEN, 200);
	assert_true(feed(v, m, n, &g) < 0);
	assert_int_equal(v->c.malformed, ++bad);
	/* analog and button states claiming more values than they carry */
	{
		uint8_t *pl = vrpn_msg_header(m, 13, 3, 0, 16);

		vrpn_put_f64(pl, 5);
		assert_true(feed(v, m, VRPN_MSG_LEN(16), &g) < 0);
		pl = vrpn_msg_header(m, 12, 3, 0, 8);
		vrpn_put32(pl, 9);
		assert_true(feed(v, m, VRPN_MSG_LEN(8), &g) < 0);
		bad += 2;
	}
	assert_int_equal(v->c.malformed, bad);
	/* and a good report still decodes */
	assert_int_equal(feed(v, m, pos_quat(m, 3, 0, p, q, real_ns()), &g), 1);
	free(v);
}

static void test_inputs(void **state)
{
	struct cfg_source cfg = base_cfg();
	struct vrpn_in_codec_st *v;
	double p[3] = { 0, 0, 1 }, q[4] = { 0, 0, 0, 1 };
	uint8_t m[512], *pl;
	struct got g;

	(void)state;
	/* channel 2 is a Flystick: buttons 8-15 of the device, analog channels 2 and 3 */
	snprintf(base_opts.buttons[0].key, sizeof(base_opts.buttons[0].key), "buttons.2");
	snprintf(base_opts.buttons[0].value, sizeof(base_opts.buttons[0].value), "8 8");
	snprintf(base_opts.analog[3].key, sizeof(base_opts.analog[3].key), "analog.2");
	snprintf(base_opts.analog[3].value, sizeof(base_opts.analog[3].value), "2 2");
	v = codec_open(&cfg);
	describe(v, "Tracker0");
	/* the states of 16 buttons: 1, 8 and 10 pressed */
	pl = vrpn_msg_header(m, 12, 3, 0, 4 + 16 * 4);
	vrpn_put32(pl, 16);
	for (int b = 0; b < 16; b++)
		vrpn_put32(pl + 4 + 4 * b, b == 1 || b == 8 || b == 10);
	assert_int_equal(feed(v, m, VRPN_MSG_LEN(4 + 16 * 4), &g), 0);
	/* a change: 15 pressed, 10 released */
	pl = vrpn_msg_header(m, 11, 3, 0, 8);
	vrpn_put32(pl, 15);
	vrpn_put32(pl + 4, 1);
	assert_int_equal(feed(v, m, VRPN_MSG_LEN(8), &g), 0);
	vrpn_put32(pl, 10);
	vrpn_put32(pl + 4, 0);
	assert_int_equal(feed(v, m, VRPN_MSG_LEN(8), &g), 0);
	/* four analog channels */
	pl = vrpn_msg_header(m, 13, 3, 0, 8 + 4 * 8);
	vrpn_put_f64(pl, 4);
	for (int i = 0; i < 4; i++)
		vrpn_put_f64(pl + 8 + 8 * i, 0.25 * (i + 1) - (i == 3 ? 2 : 0));
	assert_int_equal(feed(v, m, VRPN_MSG_LEN(8 + 4 * 8), &g), 0);
	assert_int_equal(feed(v, m, pos_quat(m, 3, 2, p, q, real_ns()), &g), 1);
	assert_true(g.s[0].inputs);
	/* device buttons 8 and 15 are the channel's 0 and 7 */
	assert_int_equal(g.s[0].buttons, 0x81);
	assert_near(g.s[0].analog[0], 0.75, 1e-7);
	assert_near(g.s[0].analog[1], -1.0, 1e-7);
	assert_near(g.s[0].analog[2], 0, 0);
	/* channel 1 has no inputs */
	assert_int_equal(feed(v, m, pos_quat(m, 3, 1, p, q, real_ns()), &g), 1);
	assert_false(g.s[0].inputs);
	assert_int_equal(g.s[0].buttons, 0);
	/* a new connection: the ids and the device's inputs are forgotten */
	vrpn_in_codec.reset(v);
	assert_int_equal(feed(v, m, pos_quat(m, 3, 2, p, q, real_ns()), &g), 0);
	describe(v, "Tracker0");
	assert_int_equal(feed(v, m, pos_quat(m, 3, 2, p, q, real_ns()), &g), 1);
	assert_int_equal(g.s[0].buttons, 0);
	/* the sender described again as another device: no longer ours */
	{
		size_t n = vrpn_msg_description(m, VRPN_SENDER_DESCRIPTION, 3, "Other", 0);

		assert_int_equal(feed(v, m, n, &g), 0);
	}
	assert_int_equal(feed(v, m, pos_quat(m, 3, 2, p, q, real_ns()), &g), 0);
	assert_int_equal(v->c.malformed, 0);
	free(v);
}

static void test_sample_times(void **state)
{
	struct cfg_source cfg = base_cfg();
	struct vrpn_in_codec_st *v = codec_open(&cfg);
	double p[3] = { 0, 0, 1 }, q[4] = { 0, 0, 0, 1 };
	uint8_t m[256];
	struct got g;
	uint64_t server = 1000000000ull * 1000; /* a server clock far behind ours */
	uint64_t first;

	(void)state;
	describe(v, "Tracker0");
	assert_int_equal(feed(v, m, pos_quat(m, 3, 0, p, q, server), &g), 1);
	first = g.s[0].t_ns;
	assert_true(first <= real_ns() && first > real_ns() - 1000000000ull);
	/* a report stamped 3 ms earlier that arrives now was 3 ms longer on its way: its time is its own */
	assert_int_equal(feed(v, m, pos_quat(m, 3, 0, p, q, server - 3000000), &g), 1);
	assert_true(first - g.s[0].t_ns >= 3000000 - 1000 && first - g.s[0].t_ns <= 3000000 + 1000);
	/* one stamped 5 ms later, 5 ms later: 5 ms after the first */
	{
		struct timespec ts = { 0, 5000000 };

		nanosleep(&ts, NULL);
	}
	assert_int_equal(feed(v, m, pos_quat(m, 3, 0, p, q, server + 5000000), &g), 1);
	assert_true(g.s[0].t_ns <= real_ns());
	assert_true(g.s[0].t_ns - first >= 5000000 - 1000 && g.s[0].t_ns - first <= 5000000 + 1000);
	/* a server clock that steps by a minute: the estimate starts again, the time stays near now */
	assert_int_equal(feed(v, m, pos_quat(m, 3, 0, p, q, server + 60000000000ull), &g), 1);
	assert_true(g.s[0].t_ns <= real_ns() && g.s[0].t_ns > real_ns() - 1000000000ull);
	server += 60000000000ull - 5000000;
	/* the raw server time is kept */
	assert_int_equal(v->last_src_ns, server + 5000000);
	free(v);
}

static void test_split(void **state)
{
	uint8_t m[128];
	struct vrpn_header h;
	size_t total;

	(void)state;
	vrpn_msg_header(m, 7, 9, 1500000000ull, 5);
	assert_int_equal(vrpn_split(m, 16, &h, &total), VRPN_SPLIT_MORE);
	assert_int_equal(vrpn_split(m, 24, &h, &total), VRPN_SPLIT_MORE);
	assert_int_equal(total, 32);
	assert_int_equal(vrpn_split(m, 32, &h, &total), VRPN_SPLIT_OK);
	assert_int_equal(h.type, 7);
	assert_int_equal(h.sender, 9);
	assert_int_equal(h.sec, 1);
	assert_int_equal(h.usec, 500000);
	vrpn_put32(m, 23);
	assert_int_equal(vrpn_split(m, 32, &h, &total), VRPN_SPLIT_BAD);
	vrpn_put32(m, VRPN_LONGEST + 1);
	assert_int_equal(vrpn_split(m, 32, &h, &total), VRPN_SPLIT_BAD);
	{
		uint8_t ck[VRPN_COOKIE_LEN];

		vrpn_cookie(ck);
		assert_true(vrpn_cookie_ok(ck));
		memcpy(ck, "vrpn: ver. 07.38", 16); /* another minor version: fine */
		assert_true(vrpn_cookie_ok(ck));
		ck[12] = '8'; /* another major version */
		assert_false(vrpn_cookie_ok(ck));
		memcpy(ck, "HTTP/1.1 200 OK\r\n\r\n12345", 24);
		assert_false(vrpn_cookie_ok(ck));
	}
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_device_names), cmocka_unit_test(test_pose),
		cmocka_unit_test(test_malformed),    cmocka_unit_test(test_inputs),
		cmocka_unit_test(test_sample_times), cmocka_unit_test(test_split),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
