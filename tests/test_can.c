// SPDX-License-Identifier: MIT
/*
 * test_can.c - the CAN side of the industrial gateway, without a CAN bus.
 *
 *  - the frame codec against golden vectors kept as candump -L lines
 *    (tests/data/can_*.log), written by an independent Python packer
 *    (tests/data/gen-can-vectors.py) from known angles: encoded here they
 *    must give the same bytes, decoded the same angles;
 *  - the port (wire/can_port.h) on one end of a socketpair(AF_UNIX,
 *    SOCK_SEQPACKET) carrying struct can_frame records, the test holding the
 *    other end: frames, oversize records, a full queue, a peer gone;
 *  - the can output through the real output_open()/send(), fed FRAME and
 *    DESCRIBE messages made with the wire encoder: frame order, unknown
 *    angles, safe mode (no limits yet, clamping, the speed limit and its
 *    ramp after a pause, nothing stale, held, unreached or NaN), a full queue;
 *  - the can source through the real tracker_open()/poll(): good frames,
 *    unknown identifiers, wrong lengths, bad quaternions, CAN FD records;
 *  - both without CAN in the kernel: they open, say why, and stay quiet.
 */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <cmocka.h>

#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include "trackers/can_in.h"
#include "avatargw/wire.h"
#include "config/config.h"
#include "base/counter.h"
#include "base/hist.h"
#include "ik/ik.h"
#include "publish/output.h"
#include "trackers/tracker.h"
#include "wire/can_port.h"
#include "wire/cancodec.h"

#include "testutil.h"

#define DATA "tests/data/"
#define DEG (M_PI / 180.0)

/* ---- helpers ------------------------------------------------------------------------ */

static FILE *open_data(const char *name)
{
	FILE *f = fopen(name, "r");

	if (!f)
		fail_msg("%s: %s (run from the repository root)", name, strerror(errno));
	return f;
}

/* the next line that is not a comment, without its newline; false at the end */
static bool next_line(FILE *f, char *buf, size_t len)
{
	while (fgets(buf, (int)len, f)) {
		buf[strcspn(buf, "\n")] = '\0';
		if (buf[0] && buf[0] != '#')
			return true;
	}
	return false;
}

static void sleep_ms(int ms)
{
	struct timespec ts = { ms / 1000, (ms % 1000) * 1000000L };

	while (nanosleep(&ts, &ts))
		;
}

/* one record from the test's end of the pair; false if none is waiting */
static bool peer_read(int fd, struct can_frame *f)
{
	ssize_t n = recv(fd, f, sizeof(*f), MSG_DONTWAIT);

	if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK))
		return false;
	assert_int_equal(n, sizeof(*f));
	return true;
}

static int peer_count(int fd)
{
	struct can_frame f;
	int n = 0;

	while (peer_read(fd, &f))
		n++;
	return n;
}

static void pair(int sv[2])
{
	assert_int_equal(socketpair(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0, sv), 0);
}

/* ---- the codec ------------------------------------------------------------------------ */

static void test_centideg(void **state)
{
	(void)state;
	assert_int_equal(cancodec_centideg(0), 0);
	assert_int_equal(cancodec_centideg(1 * DEG), 100);
	assert_int_equal(cancodec_centideg(-1 * DEG), -100);
	assert_int_equal(cancodec_centideg(0.004 * DEG), 0);
	assert_int_equal(cancodec_centideg(0.006 * DEG), 1);
	assert_int_equal(cancodec_centideg(-0.006 * DEG), -1);
	assert_int_equal(cancodec_centideg(327.67 * DEG), 32767);
	assert_int_equal(cancodec_centideg(400 * DEG), 32767);
	assert_int_equal(cancodec_centideg(-400 * DEG), -32767);
	assert_int_equal(cancodec_centideg(INFINITY), 32767);
	assert_int_equal(cancodec_centideg(-INFINITY), -32767);
	assert_int_equal(cancodec_centideg(NAN), CANCODEC_UNKNOWN);
	assert_true(isnan(cancodec_rad(CANCODEC_UNKNOWN)));
	assert_near(cancodec_rad(-9000), -M_PI / 2, 1e-15);
	assert_int_equal(cancodec_id(0x100, 4), 0x104);
	assert_int_equal(cancodec_id(0x18FF0100u | CAN_EFF_FLAG, 3), 0x18FF0103u | CAN_EFF_FLAG);
}

struct golden_cmd {
	canid_t id0;
	struct cancodec_avatar a;
	double deg[CANCODEC_JOINTS];
};

static bool read_cmd(FILE *f, struct golden_cmd *g)
{
	char line[1024], *s, *end;
	unsigned long v[7];

	if (!next_line(f, line, sizeof(line)))
		return false;
	s = line;
	for (int i = 0; i < 7; i++) {
		v[i] = strtoul(s, &end, 0);
		assert_true(end != s);
		s = end;
	}
	g->id0 = (canid_t)v[1] | (v[0] ? CAN_EFF_FLAG : 0);
	g->a = (struct cancodec_avatar){ (uint8_t)v[2], (uint8_t)v[3],	(uint8_t)v[4],
					 (uint8_t)v[5], (uint16_t)v[6], { 0 } };
	for (int j = 0; j < CANCODEC_JOINTS; j++) {
		g->deg[j] = strtod(s, &end);
		assert_true(end != s);
		s = end;
		g->a.joint[j] = cancodec_centideg(g->deg[j] * DEG);
	}
	return true;
}

/* encoded from the known angles, the frames are those of the log, byte for byte */
static void test_golden_joints_encode(void **state)
{
	static const int order[CANCODEC_FRAMES] = { 1, 2, 3, 4, 0 };
	FILE *txt = open_data(DATA "can_joints.txt"), *log = open_data(DATA "can_joints.log");
	struct golden_cmd g;
	int cmds = 0;

	(void)state;
	while (read_cmd(txt, &g)) {
		struct can_frame f[CANCODEC_FRAMES];

		cancodec_encode_avatar(&g.a, g.id0, f);
		for (int i = 0; i < CANCODEC_FRAMES; i++) {
			char want[128], got[128];
			uint64_t t_us;
			struct can_frame lf;

			assert_true(next_line(log, want, sizeof(want)));
			assert_int_equal(cancodec_parse_line(want, &lf, &t_us, NULL, 0), 0);
			assert_true(cancodec_format_line(&f[order[i]], t_us, "vcan0", got, sizeof(got)) > 0);
			if (strcmp(got, want))
				fail_msg("command %d frame %d:\n got  %s\n want %s", cmds, i, got, want);
		}
		cmds++;
	}
	assert_int_equal(cmds, 7);
	fclose(txt);
	fclose(log);
}

/* decoded, the log's frames give back the angles (to 0.005 degree), saturated or unknown as the codec says */
static void test_golden_joints_decode(void **state)
{
	FILE *txt = open_data(DATA "can_joints.txt"), *log = open_data(DATA "can_joints.log");
	struct golden_cmd g;

	(void)state;
	while (read_cmd(txt, &g)) {
		struct cancodec_avatar a;
		int seen = 0;

		memset(&a, 0xa5, sizeof(a));
		for (int i = 0; i < CANCODEC_FRAMES; i++) {
			char line[128];
			struct can_frame f;
			int k;

			assert_true(next_line(log, line, sizeof(line)));
			assert_int_equal(cancodec_parse_line(line, &f, NULL, NULL, 0), 0);
			k = cancodec_decode_avatar(&f, g.id0, &a);
			assert_true(k >= 0 && k < CANCODEC_FRAMES);
			seen |= 1 << k;
			/* another avatar's decoder does not take it */
			assert_int_equal(cancodec_decode_avatar(&f, cancodec_id(g.id0, CANCODEC_ID_STRIDE), &a),
					 -ENOENT);
		}
		assert_int_equal(seen, 0x1f);
		assert_int_equal(a.counter, g.a.counter);
		assert_int_equal(a.flags, g.a.flags);
		assert_int_equal(a.sensors, g.a.sensors);
		assert_int_equal(a.ik, g.a.ik);
		assert_int_equal(a.age_ms, g.a.age_ms);
		for (int j = 0; j < CANCODEC_JOINTS; j++) {
			double got = cancodec_rad(a.joint[j]) / DEG, want = g.deg[j];

			set_ctx("id 0x%x joint %d", g.id0, j);
			if (isnan(want)) {
				assert_true(isnan(got));
				continue;
			}
			want = want > 327.67 ? 327.67 : want < -327.67 ? -327.67 : want;
			assert_near(got, want, 0.005 + 1e-9);
		}
	}
	fclose(txt);
	fclose(log);
}

static void test_decode_rejects(void **state)
{
	struct cancodec_avatar a;
	struct can_frame f = { .can_id = 0x101, .len = 8 };

	(void)state;
	assert_int_equal(cancodec_decode_avatar(&f, 0x100, &a), CANCODEC_RIGHT_1);
	f.len = 7;
	assert_int_equal(cancodec_decode_avatar(&f, 0x100, &a), -EBADMSG);
	f.len = 8;
	f.can_id = 0x105;
	assert_int_equal(cancodec_decode_avatar(&f, 0x100, &a), -ENOENT);
	f.can_id = 0x0ff;
	assert_int_equal(cancodec_decode_avatar(&f, 0x100, &a), -ENOENT);
	f.can_id = 0x101 | CAN_RTR_FLAG;
	assert_int_equal(cancodec_decode_avatar(&f, 0x100, &a), -ENOENT);
	f.can_id = 0x101 | CAN_EFF_FLAG; /* the same number, 29-bit: another identifier */
	assert_int_equal(cancodec_decode_avatar(&f, 0x100, &a), -ENOENT);
}

static const struct cancodec_sensor_map default_map = {
	.ori_id = 0x200,
	.pos_id = 0x280,
	.n = 2,
	.quat_scale = 32768,
	.xyzw = false,
	.pos_scale = 0.001,
};

/* every frame of can_sensors.log is what can_sensors.txt says it is */
static void test_golden_sensors(void **state)
{
	FILE *txt = open_data(DATA "can_sensors.txt"), *log = open_data(DATA "can_sensors.log");
	char what[256], line[128];
	int n = 0;

	(void)state;
	while (next_line(txt, what, sizeof(what))) {
		struct cancodec_sensor_value v;
		struct can_frame f;
		char kind[16];
		double w[4] = { 0 };
		int k = -1, rc;

		assert_true(next_line(log, line, sizeof(line)));
		assert_int_equal(cancodec_parse_line(line, &f, NULL, NULL, 0), 0);
		rc = cancodec_decode_sensor(&default_map, &f, &v);
		sscanf(what, "%15s %d %lf %lf %lf %lf", kind, &k, &w[0], &w[1], &w[2], &w[3]);
		set_ctx("%s", line);
		if (!strcmp(kind, "unknown")) {
			assert_int_equal(rc, -ENOENT);
		} else if (!strcmp(kind, "bad_length")) {
			assert_int_equal(rc, -EBADMSG);
		} else if (!strcmp(kind, "bad_value")) {
			assert_int_equal(rc, -EDOM);
		} else {
			bool ori = !strcmp(kind, "ori");

			assert_int_equal(rc, 0);
			assert_int_equal(v.sensor, k);
			assert_int_equal(v.kind, ori ? CANCODEC_ORIENTATION : CANCODEC_POSITION);
			for (int i = 0; i < (ori ? 4 : 3); i++)
				assert_near(v.v[i], w[i], ori ? 1e-4 : 1e-9);
			/* and back: the same bytes */
			{
				struct can_frame e;

				if (ori)
					cancodec_encode_orientation(&default_map, k, w, &e);
				else
					cancodec_encode_position(&default_map, k, w, &e);
				assert_int_equal(e.can_id, f.can_id);
				assert_memory_equal(e.data, f.data, ori ? 8 : 6);
			}
		}
		n++;
	}
	assert_int_equal(n, 12);
	fclose(txt);
	fclose(log);
}

static void test_sensor_order_and_scale(void **state)
{
	struct cancodec_sensor_map m = default_map;
	struct cancodec_sensor_value v;
	struct can_frame f;
	const double q[4] = { 0.5, -0.5, 0.5, 0.5 }; /* w x y z */

	(void)state;
	m.xyzw = true;
	m.quat_scale = 16384;
	cancodec_encode_orientation(&m, 1, q, &f);
	/* x y z w on the bus */
	assert_int_equal((int16_t)(f.data[0] | f.data[1] << 8), -8192);
	assert_int_equal((int16_t)(f.data[6] | f.data[7] << 8), 8192);
	assert_int_equal(cancodec_decode_sensor(&m, &f, &v), 0);
	for (int i = 0; i < 4; i++)
		assert_near(v.v[i], q[i], 1e-12);
	m.pos_id = CANCODEC_NO_ID;
	f.can_id = 0x281;
	assert_int_equal(cancodec_decode_sensor(&m, &f, &v), -ENOENT);
}

static void test_candump_lines(void **state)
{
	static const char *const bad[] = {
		"",
		"1436509052.249713 can0 123#00",
		"(1436509052.24971) can0 123#00",
		"(1436509052.249713)can0 123#00",
		"(1436509052.249713) can0 1234#00",
		"(1436509052.249713) can0 123#0",
		"(1436509052.249713) can0 123#001122334455667788",
		"(1436509052.249713) can0 123##0011",
		"(1436509052.249713) can0 800#00",
		"(1436509052.249713) can0 123#00 x",
		"(1436509052.249713) can0 123",
		"(1436509052.249713) can0 3FFFFFFF#00",
	};
	struct can_frame f;
	char ifname[16], out[128];
	uint64_t t;

	(void)state;
	assert_int_equal(
		cancodec_parse_line("(1436509052.249713) vcan0 123#0011223344556677", &f, &t, ifname, sizeof(ifname)),
		0);
	assert_int_equal(f.can_id, 0x123);
	assert_int_equal(f.len, 8);
	assert_int_equal(f.data[7], 0x77);
	assert_true(t == 1436509052249713ull);
	assert_string_equal(ifname, "vcan0");
	assert_int_equal(cancodec_format_line(&f, t, ifname, out, sizeof(out)), 46);
	assert_string_equal(out, "(1436509052.249713) vcan0 123#0011223344556677");
	assert_int_equal(cancodec_parse_line("(0000000001.000002) can1 1ABCDEF0#", &f, &t, NULL, 0), 0);
	assert_int_equal(f.can_id, 0x1ABCDEF0u | CAN_EFF_FLAG);
	assert_int_equal(f.len, 0);
	cancodec_format_line(&f, t, "can1", out, sizeof(out));
	assert_string_equal(out, "(0000000001.000002) can1 1ABCDEF0#");
	assert_int_equal(cancodec_parse_line("(0000000001.000002) can1 123#R", &f, &t, NULL, 0), 0);
	assert_int_equal(f.can_id, 0x123 | CAN_RTR_FLAG);
	for (size_t i = 0; i < sizeof(bad) / sizeof(bad[0]); i++) {
		set_ctx("'%s'", bad[i]);
		if (cancodec_parse_line(bad[i], &f, &t, NULL, 0) != -EINVAL)
			fail_msg("accepted %s", ctx);
	}
	assert_int_equal(cancodec_format_line(&f, t, "can1", out, 20), -ENOSPC);
}

/* ---- the port ------------------------------------------------------------------------- */

static void test_port_socketpair(void **state)
{
	struct can_port p;
	struct can_frame f = { .can_id = 0x123, .len = 3, .data = { 1, 2, 3 } }, g;
	char err[256], name[16];
	uint8_t big[72] = { 0 };
	int sv[2], n = 0, rc;

	(void)state;
	pair(sv);
	snprintf(name, sizeof(name), "fd:%d", sv[0]);
	assert_int_equal(can_port_open(&p, name, true, err, sizeof(err)), 0);
	assert_true(p.fd != sv[0]); /* a duplicate: the inherited descriptor stays the caller's */
	close(sv[0]);
	assert_int_equal(can_port_recv(&p, &g), 0);
	assert_int_equal(can_port_send(&p, &f), 0);
	assert_true(peer_read(sv[1], &g));
	assert_int_equal(g.can_id, 0x123);
	assert_memory_equal(g.data, f.data, 3);
	/* a frame, a CAN FD record, a short record, a frame claiming 12 bytes */
	assert_int_equal(send(sv[1], &f, sizeof(f), 0), sizeof(f));
	assert_int_equal(send(sv[1], big, sizeof(big), 0), sizeof(big));
	assert_int_equal(send(sv[1], big, 12, 0), 12);
	g = f;
	g.len = 12;
	assert_int_equal(send(sv[1], &g, sizeof(g), 0), sizeof(g));
	assert_int_equal(can_port_recv(&p, &g), 1);
	assert_int_equal(g.can_id, 0x123);
	assert_int_equal(can_port_recv(&p, &g), -EMSGSIZE);
	assert_int_equal(can_port_recv(&p, &g), -EMSGSIZE);
	assert_int_equal(can_port_recv(&p, &g), -EMSGSIZE);
	assert_int_equal(can_port_recv(&p, &g), 0);
	/* nobody reads: the queue fills and the port says so instead of blocking */
	while ((rc = can_port_send(&p, &f)) == 0)
		assert_true(++n < 1000000);
	assert_int_equal(rc, -EAGAIN);
	assert_true(n > 10);
	/* the peer goes, with our frames unread: reset; a hard error either way, not "nothing waiting" */
	close(sv[1]);
	rc = can_port_recv(&p, &g);
	assert_true(rc == -ECONNRESET || rc == -EPIPE);
	rc = can_port_send(&p, &f);
	assert_true(rc == -ECONNRESET || rc == -EPIPE);
	can_port_close(&p);
	assert_int_equal(can_port_open(&p, "fd:x1", true, err, sizeof(err)), -EINVAL);
	assert_int_equal(can_port_open(&p, "fd:", true, err, sizeof(err)), -EINVAL);
	assert_int_equal(can_port_open(&p, "fd:1000", true, err, sizeof(err)), -EBADF);
	assert_non_null(strstr(err, "fd:1000"));
}

/* this kernel has no CAN; one with CAN has no interface of that name */
static void test_port_no_can(void **state)
{
	struct can_port p;
	char err[256];
	int rc = can_port_open(&p, "agwnocan0", false, err, sizeof(err));

	(void)state;
	print_message("can_port_open(agwnocan0): %s\n", err);
	assert_true(rc == -EAFNOSUPPORT || rc == -ENODEV);
	assert_non_null(strstr(err, "agwnocan0"));
	assert_non_null(strstr(err, rc == -EAFNOSUPPORT ? "no CAN support" : "no such CAN interface"));
	assert_int_equal(p.fd, -1);
}

/* ---- the output ------------------------------------------------------------------------ */

struct out_fx {
	struct config c;
	struct output o;
	int sv[2];
	uint8_t frame_msg[WIRE_MAX_MSG], desc_msg[WIRE_MAX_MSG];
	uint32_t seq;
};

static const char out_conf[] = "[source s]\ntype = sim\npeople = 2\n"
			       "[avatar a]\nperson = s/p0\n[avatar b]\nperson = s/p1\n"
			       "[output can]\ntype = can\ninterface = %s\nmax_speed = 90\n%s";

static struct out_fx *out_setup(const char *iface, const char *extra)
{
	struct out_fx *x = calloc(1, sizeof(*x));
	char text[1024], name[32], err[512];
	const uint16_t ids[2] = { 0, 1 };

	assert_non_null(x);
	x->sv[0] = x->sv[1] = -1;
	if (!iface) {
		pair(x->sv);
		snprintf(name, sizeof(name), "fd:%d", x->sv[0]);
		iface = name;
	}
	snprintf(text, sizeof(text), out_conf, iface, extra);
	if (config_load_text(&x->c, "can.conf", text, err, sizeof(err)))
		fail_msg("%s", err);
	if (output_open(&x->o, &x->c.output[0], ids, 2, NULL, err, sizeof(err)))
		fail_msg("%s", err);
	if (x->sv[0] >= 0)
		close(x->sv[0]);
	return x;
}

static void out_teardown(struct out_fx *x)
{
	output_close(&x->o);
	if (x->sv[1] >= 0)
		close(x->sv[1]);
	config_free(&x->c);
	free(x);
}

/* a DESCRIBE with the default human limits, at rate_hz */
static void send_describe(struct out_fx *x, int avatar, double rate_hz)
{
	static const double lim[8][2] = { { -30, 30 }, { -90, 30 }, { -60, 120 }, { -90, 90 },
					  { -90, 60 }, { -90, 90 }, { -70, 70 },  { -30, 30 } };
	struct wire_describe d;
	struct out_msg m;

	memset(&d, 0, sizeof(d));
	d.h.avatar_id = (uint16_t)avatar;
	d.rate_hz = (float)rate_hz;
	snprintf(d.avatar_name, sizeof(d.avatar_name), "a");
	for (int j = 0; j < WIRE_JOINTS; j++) {
		snprintf(d.joint[j].name, sizeof(d.joint[j].name), "%s", wire_joint_names[j]);
		d.joint[j].lo = (float)((j ? lim[(j - 1) % 8][0] : -30) * DEG);
		d.joint[j].hi = (float)((j ? lim[(j - 1) % 8][1] : 30) * DEG);
	}
	m = out_msg_describe(&d, x->desc_msg, (uint16_t)avatar);
	x->o.ops->send(&x->o, &m, 1);
}

/* a FRAME of the given joints (degrees) and flags */
static void send_frame(struct out_fx *x, int avatar, const double deg[WIRE_JOINTS], uint16_t flags)
{
	struct wire_frame f;
	struct out_msg m;

	memset(&f, 0, sizeof(f));
	f.h.flags = flags;
	f.h.seq = x->seq++;
	f.h.avatar_id = (uint16_t)avatar;
	for (int s = 0; s < WIRE_SENSORS; s++) {
		f.sensor[s].state = WIRE_SENSOR_OK;
		f.sensor[s].age_100us = (uint16_t)(25 + s);
		f.sensor[s].pose.q[0] = 1;
	}
	f.arm[WIRE_ARM_RIGHT].ik_flags = IK_REACHED;
	f.arm[WIRE_ARM_LEFT].ik_flags = IK_REACHED | IK_LIMITED;
	for (int j = 0; j < WIRE_JOINTS; j++)
		f.joint[j] = (float)(deg[j] * DEG);
	m = out_msg_frame(&f, x->frame_msg, (uint16_t)avatar);
	x->o.ops->send(&x->o, &m, 1);
}

/* one command from the peer: its 5 frames in the order sent; false if nothing came */
static bool read_command(struct out_fx *x, canid_t id0, struct cancodec_avatar *a)
{
	static const int order[CANCODEC_FRAMES] = { 1, 2, 3, 4, 0 };
	struct can_frame f;

	if (!peer_read(x->sv[1], &f))
		return false;
	for (int i = 0; i < CANCODEC_FRAMES; i++) {
		if (i)
			assert_true(peer_read(x->sv[1], &f));
		assert_int_equal(cancodec_decode_avatar(&f, id0, a), order[i]);
	}
	return true;
}

static uint64_t report_value(struct output *o, const char *key)
{
	char buf[1024], pat[64], *s;
	FILE *m = fmemopen(buf, sizeof(buf), "w");

	assert_non_null(m);
	o->ops->report(o, m, true);
	fclose(m);
	snprintf(pat, sizeof(pat), "\"%s\":", key);
	s = strstr(buf, pat);
	if (!s)
		fail_msg("no %s in %s", key, buf);
	return strtoull(s + strlen(pat), NULL, 10);
}

static void test_out_plain_mode(void **state)
{
	struct out_fx *x = out_setup(NULL, "safe = no\nbase_id = 0x300\n");
	struct cancodec_avatar a;
	double deg[WIRE_JOINTS];

	(void)state;
	for (int j = 0; j < WIRE_JOINTS; j++)
		deg[j] = j * 10.5 - 80; /* beyond some limits: sent as they are */
	send_frame(x, 1, deg, WIRE_F_NEW_SAMPLE | WIRE_F_STALE);
	assert_true(read_command(x, 0x308, &a)); /* the second avatar */
	assert_int_equal(a.counter, 0);
	assert_int_equal(a.flags, CANCODEC_F_VALID | CANCODEC_F_NEW_SAMPLE | CANCODEC_F_STALE);
	assert_int_equal(a.ik, 3);
	assert_int_equal(a.age_ms, 2);
	for (int j = 0; j < WIRE_JOINTS; j++)
		assert_int_equal(a.joint[j], lround(deg[j] * 100));
	deg[5] = NAN;
	send_frame(x, 0, deg, 0);
	assert_true(read_command(x, 0x300, &a));
	assert_int_equal(a.counter, 0);
	assert_int_equal(a.flags, 0);
	assert_int_equal(a.joint[5], CANCODEC_UNKNOWN);
	assert_int_equal(a.joint[4], lround(deg[4] * 100));
	send_frame(x, 0, deg, 0);
	assert_true(read_command(x, 0x300, &a));
	assert_int_equal(a.counter, 1);
	assert_false(read_command(x, 0x300, &a));
	assert_int_equal(ctr_get(&x->o.st.sent), 15);
	assert_int_equal(report_value(&x->o, "commands"), 3);
	out_teardown(x);
}

static void test_out_safe_needs_limits(void **state)
{
	struct out_fx *x = out_setup(NULL, "");
	struct cancodec_avatar a;
	double deg[WIRE_JOINTS] = { 0 };

	(void)state;
	send_frame(x, 0, deg, 0);
	assert_false(read_command(x, 0x100, &a));
	assert_int_equal(report_value(&x->o, "withheld"), 1);
	assert_int_equal(report_value(&x->o, "no_limits"), 1);
	send_describe(x, 0, 100);
	send_frame(x, 0, deg, 0);
	assert_true(read_command(x, 0x100, &a));
	assert_int_equal(a.flags, CANCODEC_F_VALID | CANCODEC_F_SAFE);
	/* avatar 1 has no DESCRIBE yet */
	send_frame(x, 1, deg, 0);
	assert_false(read_command(x, 0x108, &a));
	out_teardown(x);
}

static void test_out_safe_clamps(void **state)
{
	struct out_fx *x = out_setup(NULL, "");
	struct cancodec_avatar a;
	double deg[WIRE_JOINTS];

	(void)state;
	send_describe(x, 0, 100);
	for (int j = 0; j < WIRE_JOINTS; j++)
		deg[j] = j % 2 ? 170 : -170;
	send_frame(x, 0, deg, 0);
	assert_true(read_command(x, 0x100, &a));
	assert_int_equal(a.flags, CANCODEC_F_VALID | CANCODEC_F_SAFE | CANCODEC_F_LIMITED);
	/* chest -30 30; arm j1 -30 30, j2 -90 30, j3 -60 120, j4 -90 90, j5 -90 60, j6 -90 90, j7 -70 70, j8 -30 30 */
	assert_int_equal(a.joint[0], -3000);
	assert_int_equal(a.joint[1], 3000);
	assert_int_equal(a.joint[2], -9000);
	assert_int_equal(a.joint[3], 12000);
	assert_int_equal(a.joint[4], -9000);
	assert_int_equal(a.joint[5], 6000);
	assert_int_equal(a.joint[6], -9000);
	assert_int_equal(a.joint[7], 7000);
	assert_int_equal(a.joint[8], -3000);
	assert_int_equal(a.joint[9], 3000);
	assert_int_equal(a.joint[16], -3000);
	assert_int_equal(report_value(&x->o, "limited"), 1);
	out_teardown(x);
}

/* 90 deg/s at 100 Hz: at most 0.9 degree per command, however far the target */
static void test_out_safe_speed_limit(void **state)
{
	struct out_fx *x = out_setup(NULL, "");
	struct cancodec_avatar a;
	struct timespec t0;
	double deg[WIRE_JOINTS] = { 0 }, prev = 0;

	(void)state;
	send_describe(x, 0, 100);
	send_frame(x, 0, deg, 0); /* the first command: nothing to ramp from */
	assert_true(read_command(x, 0x100, &a));
	assert_int_equal(a.joint[3], 0);
	deg[3] = 20; /* right shoulder flexion: 20 degrees away */
	for (int i = 1; i <= 5; i++) {
		sleep_ms(15); /* longer than a period: the step is capped at one period's worth */
		clock_gettime(CLOCK_MONOTONIC, &t0); /* before this command is stamped */
		send_frame(x, 0, deg, 0);
		assert_true(read_command(x, 0x100, &a));
		assert_int_equal(a.joint[3], 90 * i);
		assert_true(a.flags & CANCODEC_F_LIMITED);
	}
	/* commands closer together than a period move less: max_speed times the time between them */
	{
		struct timespec t1;
		double dt;

		prev = a.joint[3];
		sleep_ms(4); /* less than a period */
		send_frame(x, 0, deg, 0);
		clock_gettime(CLOCK_MONOTONIC, &t1);
		/*
		 * An upper bound of the time between the two commands: from before the previous one
		 * was sent (t0) to after this one was. Reading the previous command back, and any
		 * preemption, falls inside it.
		 */
		dt = (double)(t1.tv_sec - t0.tv_sec) + (t1.tv_nsec - t0.tv_nsec) * 1e-9;
		assert_true(read_command(x, 0x100, &a));
		print_message("a command %.3f ms after the previous one moved %d\n", dt * 1e3, a.joint[3] - (int)prev);
		assert_true(a.joint[3] >= prev + 9000 * 0.004 - 1); /* the sleep was at least 4 ms */
		assert_true(a.joint[3] <= prev + 9000 * fmin(dt, 0.01) + 1);
	}
	/* back down, as fast as allowed */
	deg[3] = -5;
	prev = a.joint[3];
	sleep_ms(15);
	send_frame(x, 0, deg, 0);
	assert_true(read_command(x, 0x100, &a));
	assert_int_equal(a.joint[3], prev - 90);
	out_teardown(x);
}

/* stale, held, unreached or unknown: nothing goes out; afterwards the command ramps from where it stopped */
static void test_out_safe_stops(void **state)
{
	static const uint16_t bad_flags[] = { WIRE_F_STALE, WIRE_F_HELD, WIRE_F_UNREACHED, WIRE_F_STALE | WIRE_F_HELD };
	struct out_fx *x = out_setup(NULL, "");
	struct cancodec_avatar a;
	double deg[WIRE_JOINTS] = { 0 };

	(void)state;
	send_describe(x, 0, 100);
	deg[13] = 10;
	send_frame(x, 0, deg, WIRE_F_NEW_SAMPLE);
	assert_true(read_command(x, 0x100, &a));
	assert_int_equal(a.joint[13], 1000);
	deg[13] = 40;
	for (size_t i = 0; i < sizeof(bad_flags) / sizeof(bad_flags[0]); i++) {
		send_frame(x, 0, deg, bad_flags[i]);
		assert_false(read_command(x, 0x100, &a));
	}
	deg[2] = NAN;
	send_frame(x, 0, deg, 0);
	assert_false(read_command(x, 0x100, &a));
	deg[2] = INFINITY;
	send_frame(x, 0, deg, 0);
	assert_false(read_command(x, 0x100, &a));
	assert_int_equal(report_value(&x->o, "withheld"), 6);
	assert_int_equal(report_value(&x->o, "no_limits"), 0);
	deg[2] = 0;
	sleep_ms(200); /* a long pause: still one step of 0.9 degree, not a jump to 40 */
	send_frame(x, 0, deg, 0);
	assert_true(read_command(x, 0x100, &a));
	assert_int_equal(a.joint[13], 1090);
	assert_int_equal(a.counter, 1);
	assert_int_equal(report_value(&x->o, "commands"), 2);
	out_teardown(x);
}

/* a queue that takes nothing more: the command is dropped from there on, STATUS included, and counted */
static void test_out_full_queue(void **state)
{
	struct out_fx *x = out_setup(NULL, "safe = no\n");
	struct cancodec_avatar a;
	double deg[WIRE_JOINTS] = { 0 };
	uint64_t sent, dropped, whole;
	int n = 0;

	(void)state;
	/* the test's end reads nothing until the queue is full */
	while (ctr_get(&x->o.st.dropped) == 0) {
		send_frame(x, 0, deg, 0);
		assert_true(++n < 1000000);
	}
	sent = ctr_get(&x->o.st.sent);
	dropped = ctr_get(&x->o.st.dropped);
	whole = report_value(&x->o, "commands");
	print_message("queue full after %llu frames\n", (unsigned long long)sent);
	/* what the port took is all there; the command that did not fit lost the rest of its frames */
	assert_int_equal((uint64_t)peer_count(x->sv[1]), sent);
	assert_int_equal(sent % 5 + dropped, 5);
	assert_int_equal(whole, sent / 5);
	assert_int_equal(ctr_get(&x->o.st.errors), 0);
	/* drained: commands flow again, and the counter counted whole commands only */
	send_frame(x, 0, deg, 0);
	assert_true(read_command(x, 0x100, &a));
	assert_int_equal(a.counter, (uint8_t)whole);
	out_teardown(x);
}

static void test_out_extended_ids(void **state)
{
	struct out_fx *x = out_setup(NULL, "safe = no\nextended_ids = yes\nbase_id = 0x18FF0100\n");
	struct cancodec_avatar a;
	double deg[WIRE_JOINTS] = { 0 };

	(void)state;
	send_frame(x, 1, deg, 0);
	assert_true(read_command(x, 0x18FF0108u | CAN_EFF_FLAG, &a));
	out_teardown(x);
}

/* the identifiers are checked again at start with every avatar carried (a replayed recording's remote
 * avatars are known only then): two configured avatars fit below 0x7FF from 0x7F0, a third does not */
static void test_out_id_room_at_start(void **state)
{
	struct config c;
	struct output o;
	char text[1024], err[512];
	const uint16_t ids[3] = { 0, 1, 1000 };

	(void)state;
	snprintf(text, sizeof(text), out_conf, "agwnocan0", "base_id = 0x7F0\n");
	assert_int_equal(config_load_text(&c, "can.conf", text, err, sizeof(err)), 0);
	assert_int_equal(output_open(&o, &c.output[0], ids, 2, NULL, err, sizeof(err)), 0);
	output_close(&o);
	assert_int_not_equal(output_open(&o, &c.output[0], ids, 3, NULL, err, sizeof(err)), 0);
	print_message("%s\n", err);
	assert_non_null(strstr(err, "[output can]: base_id: 3 avatars need identifiers up to 0x804, above 0x7FF"));
	config_free(&c);
}

static void test_out_without_can(void **state)
{
	struct out_fx *x = out_setup("agwnocan0", "");
	double deg[WIRE_JOINTS] = { 0 };
	char buf[1024];
	FILE *m = fmemopen(buf, sizeof(buf), "w");

	(void)state;
	send_describe(x, 0, 100);
	send_frame(x, 0, deg, 0);
	assert_int_equal(ctr_get(&x->o.st.sent), 0);
	assert_int_equal(ctr_get(&x->o.st.errors), 0);
	x->o.ops->report(&x->o, m, true);
	fclose(m);
	print_message("%s\n", buf);
	assert_non_null(strstr(buf, "\"state\":\"disabled\""));
	assert_non_null(strstr(buf, "agwnocan0"));
	out_teardown(x);
}

/* ---- the source ------------------------------------------------------------------------ */

struct in_fx {
	struct config c;
	struct tracker t;
	int sv[2];
};

static struct in_fx *in_setup(const char *iface, const char *extra)
{
	struct in_fx *x = calloc(1, sizeof(*x));
	char text[1024], name[32], err[512];

	assert_non_null(x);
	x->sv[0] = x->sv[1] = -1;
	if (!iface) {
		pair(x->sv);
		snprintf(name, sizeof(name), "fd:%d", x->sv[0]);
		iface = name;
	}
	snprintf(text, sizeof(text), "[source bus]\ntype = can\ninterface = %s\nsensors = 2\n%s", iface, extra);
	if (config_load_text(&x->c, "in.conf", text, err, sizeof(err)))
		fail_msg("%s", err);
	if (tracker_open(&x->t, &x->c.source[0], err, sizeof(err)))
		fail_msg("%s", err);
	if (x->sv[0] >= 0)
		close(x->sv[0]);
	return x;
}

static void in_teardown(struct in_fx *x)
{
	tracker_close(&x->t);
	if (x->sv[1] >= 0)
		close(x->sv[1]);
	config_free(&x->c);
	free(x);
}

static int in_poll(struct in_fx *x)
{
	struct tracker_clock now = { 1000000000ull, 1700000000000000000ll };

	return x->t.drv->poll(&x->t, &now);
}

static uint64_t in_report(struct in_fx *x, const char *key)
{
	char buf[1024], pat[64], *s;
	FILE *m = fmemopen(buf, sizeof(buf), "w");

	assert_non_null(m);
	x->t.drv->report(&x->t, m, true);
	fclose(m);
	snprintf(pat, sizeof(pat), "\"%s\":", key);
	s = strstr(buf, pat);
	if (!s)
		fail_msg("no %s in %s", key, buf);
	return strtoull(s + strlen(pat), NULL, 10);
}

static void feed_line(struct in_fx *x, const char *line)
{
	struct can_frame f;

	assert_int_equal(cancodec_parse_line(line, &f, NULL, NULL, 0), 0);
	assert_int_equal(send(x->sv[1], &f, sizeof(f), 0), sizeof(f));
}

/* the golden sensor frames through the source: poses taken in, the rest counted */
static void test_in_golden(void **state)
{
	struct in_fx *x = in_setup(NULL, "");
	FILE *log = open_data(DATA "can_sensors.log");
	char line[128];
	struct vec3 p;
	int lines = 0;

	(void)state;
	/* sensor 0's orientation alone is no pose yet */
	assert_true(next_line(log, line, sizeof(line)));
	feed_line(x, line);
	assert_int_equal(in_poll(x), 0);
	assert_false(x->t.slot[0].seen);
	while (next_line(log, line, sizeof(line))) {
		feed_line(x, line);
		lines++;
	}
	fclose(log);
	assert_int_equal(lines, 11);
	/* pos 0, ori 1, pos 1, ori 0 -> 3 poses; then 7 frames counted and dropped */
	assert_int_equal(in_poll(x), 3);
	assert_int_equal(x->t.slot[0].count, 2);
	assert_int_equal(x->t.slot[1].count, 1);
	assert_int_equal(ctr_get(&x->t.st.samples), 3);
	assert_int_equal(ctr_get(&x->t.st.malformed), 4);
	assert_int_equal(in_report(x, "frames"), 12);
	assert_int_equal(in_report(x, "unknown_id"), 3);
	assert_int_equal(in_report(x, "bad_length"), 2);
	assert_int_equal(in_report(x, "bad_value"), 2);
	/* sensor 0: the last good orientation (0.5 0.5 -0.5 0.5) at 0.1 -0.2 1.5 */
	dq_translation(&x->t.slot[0].pose, &p);
	set_ctx("sensor 0");
	assert_near(p.x, 0.1, 1e-9);
	assert_near(p.y, -0.2, 1e-9);
	assert_near(p.z, 1.5, 1e-9);
	assert_near(x->t.slot[0].pose.r.w, 0.5, 1e-4);
	assert_near(x->t.slot[0].pose.r.y, -0.5, 1e-4);
	dq_translation(&x->t.slot[1].pose, &p);
	set_ctx("sensor 1");
	assert_near(p.x, -1, 1e-9);
	assert_near(p.z, 32.767, 1e-9);
	assert_near(x->t.slot[1].pose.r.z, sqrt(0.5), 1e-4);
	/* CLOCK_REALTIME of the poll */
	assert_true(x->t.slot[0].t_ns == 1700000001000000000ull);
	assert_int_equal(in_poll(x), 0);
	in_teardown(x);
}

static void test_in_records(void **state)
{
	struct in_fx *x = in_setup(NULL, "position_id = -1\nquaternion_order = xyzw\nquaternion_scale = 16384\n");
	uint8_t big[72] = { 0 };
	struct can_frame f = { .can_id = 0x201,
			       .len = 8,
			       .data = { 0, 0, 0, 0, 0, 0, 0, 0x40 } }; /* x y z w: identity */

	(void)state;
	assert_int_equal(send(x->sv[1], big, sizeof(big), 0), sizeof(big));
	assert_int_equal(send(x->sv[1], &f, sizeof(f), 0), sizeof(f));
	assert_int_equal(in_poll(x), 1); /* orientation only: a pose at once */
	assert_true(x->t.slot[1].seen);
	assert_near(x->t.slot[1].pose.r.w, 1, 1e-12);
	assert_int_equal(ctr_get(&x->t.st.malformed), 1);
	assert_int_equal(in_report(x, "bad_length"), 1);
	/* the sender goes away: a fault, reported once */
	close(x->sv[1]);
	x->sv[1] = -1;
	assert_int_equal(in_poll(x), -EPIPE);
	assert_int_equal(in_poll(x), 0);
	in_teardown(x);
}

static void test_in_config_checks(void **state)
{
	struct config c;
	char err[512];

	(void)state;
	assert_int_equal(config_load_text(&c, "x.conf", "[source bus]\ntype = can\n", err, sizeof(err)), -1);
	assert_non_null(strstr(err, "interface: missing"));
	assert_int_equal(config_load_text(&c, "x.conf",
					  "[source bus]\ntype = can\ninterface = can0\nsensors = 16\n"
					  "orientation_id = 0x7F8\n",
					  err, sizeof(err)),
			 -1);
	assert_non_null(strstr(err, "extended_ids"));
	assert_int_equal(config_load_text(&c, "x.conf",
					  "[source bus]\ntype = can\ninterface = can0\nsensors = 4\n"
					  "orientation_id = 0x280\nposition_id = 0x282\n",
					  err, sizeof(err)),
			 -1);
	assert_non_null(strstr(err, "overlap"));
	assert_int_equal(config_load_text(&c, "x.conf", "[output o]\ntype = can\n", err, sizeof(err)), -1);
	assert_non_null(strstr(err, "x.conf:2: [output o] interface: missing"));
	assert_int_equal(config_load_text(&c, "x.conf",
					  "[source bus]\ntype = can\ninterface = can0\n"
					  "orientation_id = 0x18FF0000\nextended_ids = yes\n",
					  err, sizeof(err)),
			 0);
	assert_int_equal(((const struct can_in_opts *)(c.source[0]).opt)->ori_id, 0x18FF0000);
	assert_int_equal(((const struct can_in_opts *)(c.source[0]).opt)->pos_id, 0x280);
	assert_true(((const struct can_in_opts *)(c.source[0]).opt)->extended_ids);
	assert_near(((const struct can_in_opts *)(c.source[0]).opt)->quat_scale, 32768, 0);
	config_free(&c);
}

static void test_in_without_can(void **state)
{
	struct in_fx *x = in_setup("agwnocan0", "");

	(void)state;
	assert_int_equal(x->t.drv->fd(&x->t), -1);
	assert_int_equal(in_poll(x), -ENODEV);
	assert_int_equal(in_poll(x), 0);
	assert_int_equal(in_poll(x), 0);
	in_teardown(x);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_centideg),
		cmocka_unit_test(test_golden_joints_encode),
		cmocka_unit_test(test_golden_joints_decode),
		cmocka_unit_test(test_decode_rejects),
		cmocka_unit_test(test_golden_sensors),
		cmocka_unit_test(test_sensor_order_and_scale),
		cmocka_unit_test(test_candump_lines),
		cmocka_unit_test(test_port_socketpair),
		cmocka_unit_test(test_port_no_can),
		cmocka_unit_test(test_out_plain_mode),
		cmocka_unit_test(test_out_safe_needs_limits),
		cmocka_unit_test(test_out_safe_clamps),
		cmocka_unit_test(test_out_safe_speed_limit),
		cmocka_unit_test(test_out_safe_stops),
		cmocka_unit_test(test_out_full_queue),
		cmocka_unit_test(test_out_extended_ids),
		cmocka_unit_test(test_out_id_room_at_start),
		cmocka_unit_test(test_out_without_can),
		cmocka_unit_test(test_in_golden),
		cmocka_unit_test(test_in_records),
		cmocka_unit_test(test_in_config_checks),
		cmocka_unit_test(test_in_without_can),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
