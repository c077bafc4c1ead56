// SPDX-License-Identifier: MIT
/*
 * test_vrpn.c - the VRPN output driven directly (send() and service() as the
 * loop calls them) with frames made here, read by a small client written
 * from the protocol description: button changes and states, the trackers'
 * analog values, unknown poses left out, timestamps, and a reload that
 * keeps or drops the clients. tests/e2e/test_vrpn.py checks the same
 * server against the daemon's UDP stream.
 */
#include "config/config.h"
#include "base/counter.h"
#include "base/hist.h"
#include "publish/output.h"

#include "avatargw/wire.h"

#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <cmocka.h>

#include <arpa/inet.h>
#include <endian.h>
#include <math.h>
#include <netinet/in.h>
#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>

#define T_US 1234567890123456ull /* a sample time, ns; VRPN carries it as seconds and microseconds */

struct vmsg {
	int32_t type, sender;
	uint32_t sec, usec;
	uint8_t pl[512];
	size_t plen;
};

struct peer {
	int fd;
	uint8_t buf[1 << 16];
	size_t len;
	char types[16][100]; /* the server's ids -> names */
	char senders[16][100];
};

static uint32_t be32(const uint8_t *p)
{
	uint32_t v;

	memcpy(&v, p, 4);
	return be32toh(v);
}

static double bef64(const uint8_t *p)
{
	uint64_t v;
	double d;

	memcpy(&v, p, 8);
	v = be64toh(v);
	memcpy(&d, &v, 8);
	return d;
}

static int free_port(void)
{
	struct sockaddr_in a = { .sin_family = AF_INET, .sin_addr.s_addr = htonl(INADDR_LOOPBACK) };
	socklen_t l = sizeof(a);
	int fd = socket(AF_INET, SOCK_STREAM, 0), port;

	assert_int_equal(bind(fd, (struct sockaddr *)&a, sizeof(a)), 0);
	getsockname(fd, (struct sockaddr *)&a, &l);
	port = ntohs(a.sin_port);
	close(fd);
	return port;
}

static void peer_connect(struct peer *p, int port)
{
	struct sockaddr_in a = { .sin_family = AF_INET,
				 .sin_port = htons((uint16_t)port),
				 .sin_addr.s_addr = htonl(INADDR_LOOPBACK) };
	char ck[24] = "vrpn: ver. 07.35  0";

	memset(p, 0, sizeof(*p));
	p->fd = socket(AF_INET, SOCK_STREAM, 0);
	assert_int_equal(connect(p->fd, (struct sockaddr *)&a, sizeof(a)), 0);
	assert_int_equal(send(p->fd, ck, sizeof(ck), 0), 24);
}

/* what the server sent so far (waits up to 50 ms for the first bytes) */
static void peer_read(struct peer *p)
{
	struct pollfd pf = { p->fd, POLLIN, 0 };

	while (poll(&pf, 1, 50) == 1) {
		ssize_t n = recv(p->fd, p->buf + p->len, sizeof(p->buf) - p->len, MSG_DONTWAIT);

		if (n <= 0)
			break;
		p->len += (size_t)n;
	}
}

/* the next message; its cookie is skipped first; descriptions are recorded */
static bool peer_next(struct peer *p, struct vmsg *m, size_t *pos)
{
	for (;;) {
		size_t len, total;
		const uint8_t *h;

		if (*pos == 0) {
			assert_true(p->len >= 24);
			assert_memory_equal(p->buf, "vrpn: ver. 07.", 14);
			*pos = 24;
		}
		if (p->len - *pos < 24)
			return false;
		h = p->buf + *pos;
		len = be32(h);
		total = 24 + ((len - 24 + 7) & ~7u);
		assert_true(len >= 24);
		if (p->len - *pos < total)
			return false;
		m->sec = be32(h + 4);
		m->usec = be32(h + 8);
		m->sender = (int32_t)be32(h + 12);
		m->type = (int32_t)be32(h + 16);
		m->plen = len - 24;
		assert_true(m->plen <= sizeof(m->pl));
		memcpy(m->pl, h + 24, m->plen);
		*pos += total;
		if (m->type == -1 || m->type == -2) {
			uint32_t n = be32(m->pl);

			assert_true(m->sender >= 0 && m->sender < 16);
			assert_int_equal(m->pl[4 + n - 1], 0);
			strcpy(m->type == -1 ? p->senders[m->sender] : p->types[m->sender], (char *)m->pl + 4);
			continue;
		}
		return true;
	}
}

static bool is(const struct peer *p, const struct vmsg *m, const char *type)
{
	return m->type >= 0 && m->type < 16 && !strcmp(p->types[m->type], type);
}

struct fixture {
	struct config cfg;
	struct output o;
	uint16_t ids[2];
	int port;
};

static void open_output(struct fixture *fx, const char *device, struct output *old)
{
	char text[512], err[256];

	fx->port = old ? fx->port : free_port();
	snprintf(text, sizeof(text),
		 "[source s]\ntype = sim\npeople = 2\n[avatar a]\nid = 3\nperson = s/p0\n[avatar b]\nid = 9\nperson = "
		 "s/p1\n"
		 "[output v]\ntype = vrpn\naddress = 127.0.0.1\nport = %d\ndevice = %s\nclient_timeout = 1\n",
		 fx->port, device);
	assert_int_equal(config_load_text(&fx->cfg, "vrpn.conf", text, err, sizeof(err)), 0);
	fx->ids[0] = 3;
	fx->ids[1] = 9;
	assert_int_equal(output_open(&fx->o, &fx->cfg.output[0], fx->ids, 2, old, err, sizeof(err)), 0);
}

static void close_output(struct fixture *fx)
{
	output_close(&fx->o);
	config_free(&fx->cfg);
}

static void cycle(struct output *o, const struct out_msg *m, int n)
{
	o->ops->service(o);
	o->ops->send(o, m, n);
}

/* a frame of avatar index a: every segment finite but the head; joints j * 0.01 */
static struct out_msg make_frame(struct wire_frame *fp, uint8_t *buf, uint16_t id, uint16_t avatar)
{
	struct wire_frame f;

	memset(&f, 0, sizeof(f));
	f.h.avatar_id = id;
	f.h.sample_time_ns = T_US * 1000ull + 789;
	for (int s = 0; s < WIRE_SEGMENTS; s++) {
		struct wire_pose *p = &f.segment[s];

		p->p[0] = 0.1f * (float)s;
		p->p[1] = 0.25f;
		p->p[2] = 1.5f;
		p->q[0] = 0.5f; /* w */
		p->q[1] = 0.5f;
		p->q[2] = -0.5f;
		p->q[3] = 0.5f;
	}
	for (int k = 0; k < 7; k++)
		f.segment[WIRE_SEG_HEAD].p[k % 3] = f.segment[WIRE_SEG_HEAD].q[k % 4] = NAN;
	for (int s = 0; s < WIRE_SENSORS; s++) {
		f.sensor[s].state = s == WIRE_S_HEAD ? WIRE_SENSOR_MISSING : WIRE_SENSOR_OK;
		for (int k = 0; k < 3; k++)
			f.sensor[s].pose.p[k] = s == WIRE_S_HEAD ? NAN : 2.0f + (float)k;
		for (int k = 0; k < 4; k++)
			f.sensor[s].pose.q[k] = s == WIRE_S_HEAD ? NAN : (k == 0 ? 1.0f : 0.0f);
	}
	for (int j = 0; j < WIRE_JOINTS; j++)
		f.joint[j] = 0.01f * (float)j;
	*fp = f;
	return out_msg_frame(fp, buf, avatar);
}

static void test_reports_buttons_and_analog(void **state)
{
	struct fixture fx;
	struct peer p;
	struct wire_frame pf[2];
	uint8_t frames[2][WIRE_MAX_MSG];
	struct out_msg m[2];
	struct vmsg msg;
	size_t pos = 0;
	int poses = 0, analogs = 0, changes = 0, states = 0;

	(void)state;
	open_output(&fx, "Rig-%d", NULL);
	for (int a = 0; a < 2; a++)
		m[a] = make_frame(&pf[a], frames[a], fx.ids[a], (uint16_t)a);
	pf[0].in.analog[2][1] = 0.75f; /* right hand, second value */
	pf[0].in.buttons[1] = 1u << 4; /* left hand, button 4: held from the start */
	cycle(&fx.o, m, 2);	       /* the server knows the buttons before the client comes */
	peer_connect(&p, fx.port);
	for (int i = 0; i < 5; i++)
		cycle(&fx.o, m, 2);
	/* a press and a release on avatar 9 */
	pf[1].in.buttons[2] = 1u << 31;
	cycle(&fx.o, m, 2);
	pf[1].in.buttons[2] = 0;
	cycle(&fx.o, m, 2);
	peer_read(&p);
	while (peer_next(&p, &msg, &pos)) {
		const char *dev = p.senders[msg.sender];

		if (is(&p, &msg, "vrpn_Tracker Pos_Quat")) {
			int32_t s = (int32_t)be32(msg.pl);

			assert_int_equal(msg.plen, 64);
			/* the head is unknown: neither its segment (1) nor its sensor (10) is sent */
			assert_true(s != 1 && s != 10 && s >= 0 && s < 13);
			assert_int_equal(msg.sec, T_US / 1000000);
			assert_int_equal(msg.usec, T_US % 1000000);
			if (s < 10) {
				assert_true(bef64(msg.pl + 8) == (double)(0.1f * (float)s));
				/* x, y, z, w */
				assert_true(bef64(msg.pl + 32) == 0.5 && bef64(msg.pl + 40) == -0.5 &&
					    bef64(msg.pl + 48) == 0.5 && bef64(msg.pl + 56) == 0.5);
			} else {
				assert_true(bef64(msg.pl + 16) == 3.0 && bef64(msg.pl + 56) == 1.0);
			}
			poses++;
		} else if (is(&p, &msg, "vrpn_Analog Channel")) {
			assert_int_equal(msg.plen, 8 * 30);
			assert_true(bef64(msg.pl) == 29.0);
			for (int j = 0; j < 17; j++)
				assert_true(bef64(msg.pl + 8 + 8 * j) == (double)(0.01f * (float)j));
			/* the trackers' values: channel 17 + 4 x sensor + value */
			if (!strcmp(dev, "Rig-3"))
				assert_true(bef64(msg.pl + 8 + 8 * (17 + 4 * 2 + 1)) == 0.75);
			analogs++;
		} else if (is(&p, &msg, "vrpn_Button States")) {
			assert_int_equal(be32(msg.pl), 96);
			/* at connection: Rig-3's left-hand button 4 is down (32 + 4) */
			for (int b = 0; b < 96; b++)
				assert_int_equal(be32(msg.pl + 4 + 4 * b), !strcmp(dev, "Rig-3") && b == 36);
			states++;
		} else if (is(&p, &msg, "vrpn_Button Change")) {
			assert_string_equal(dev, "Rig-9");
			assert_int_equal(be32(msg.pl), 64 + 31);
			assert_int_equal(be32(msg.pl + 4), changes == 0 ? 1 : 0);
			changes++;
		}
	}
	assert_string_equal(p.senders[0], "Rig-3");
	assert_string_equal(p.senders[1], "Rig-9");
	assert_int_equal(states, 2);
	assert_int_equal(changes, 2);
	/* the cycles after the handshake: 11 poses each for 2 avatars */
	assert_true(poses >= 2 * 11 * 5 && poses % 11 == 0);
	assert_int_equal(analogs * 11, poses);
	close(p.fd);
	close_output(&fx);
}

/* a person whose sensors are all STALE or MISSING gets no new reports, and gets them again when one is OK */
static void test_stopped_person_sends_nothing(void **state)
{
	struct fixture fx;
	struct peer p;
	uint8_t frame[WIRE_MAX_MSG];
	struct wire_frame f;
	struct out_msg m;
	struct vmsg msg;
	size_t pos = 0;
	int poses = 0;

	(void)state;
	open_output(&fx, "Avatar%d", NULL);
	m = make_frame(&f, frame, 3, 0);
	peer_connect(&p, fx.port);
	for (int i = 0; i < 3; i++)
		cycle(&fx.o, &m, 1); /* the handshake, then reports */
	peer_read(&p);
	while (peer_next(&p, &msg, &pos))
		poses += is(&p, &msg, "vrpn_Tracker Pos_Quat");
	assert_true(poses > 0);
	poses = 0;
	for (int s = 0; s < WIRE_SENSORS; s++)
		f.sensor[s].state = s ? WIRE_SENSOR_STALE : WIRE_SENSOR_MISSING;
	for (int i = 0; i < 5; i++)
		cycle(&fx.o, &m, 1);
	peer_read(&p);
	while (peer_next(&p, &msg, &pos))
		poses += is(&p, &msg, "vrpn_Tracker Pos_Quat");
	assert_int_equal(poses, 0);
	f.sensor[WIRE_S_LEFT_HAND].state = WIRE_SENSOR_OK;
	cycle(&fx.o, &m, 1);
	peer_read(&p);
	while (peer_next(&p, &msg, &pos))
		poses += is(&p, &msg, "vrpn_Tracker Pos_Quat");
	assert_int_equal(poses, 11);
	close(p.fd);
	close_output(&fx);
}

static void test_reload_keeps_or_drops_clients(void **state)
{
	struct fixture a, b, c;
	struct peer p;
	uint8_t frame[WIRE_MAX_MSG];
	struct wire_frame pf;
	struct out_msg m;
	struct vmsg msg;
	size_t pos = 0;
	int n = 0;

	(void)state;
	open_output(&a, "Avatar%d", NULL);
	m = make_frame(&pf, frame, 3, 0);
	peer_connect(&p, a.port);
	for (int i = 0; i < 3; i++)
		cycle(&a.o, &m, 1);
	assert_int_equal(ctr_get(&a.o.st.clients), 1);
	/* the same devices: the new output takes the server and its client over */
	b.port = a.port;
	open_output(&b, "Avatar%d", &a.o);
	assert_true(b.o.adopted);
	assert_null(a.o.priv);
	close_output(&a);
	for (int i = 0; i < 3; i++)
		cycle(&b.o, &m, 1);
	assert_int_equal(ctr_get(&b.o.st.clients), 1);
	peer_read(&p);
	while (peer_next(&p, &msg, &pos))
		n += is(&p, &msg, "vrpn_Tracker Pos_Quat");
	assert_int_equal(n, 11 * 6);
	/* other device names: the server stays, the client is let go to learn them */
	c.port = b.port;
	open_output(&c, "Body%d", &b.o);
	assert_true(c.o.adopted);
	close_output(&b);
	cycle(&c.o, &m, 1);
	assert_int_equal(ctr_get(&c.o.st.clients), 0);
	{
		char x;

		peer_read(&p);
		assert_int_equal(recv(p.fd, &x, 1, MSG_DONTWAIT), 0); /* closed by the server */
	}
	close(p.fd);
	peer_connect(&p, c.port);
	for (int i = 0; i < 3; i++)
		cycle(&c.o, &m, 1);
	peer_read(&p);
	pos = 0;
	while (peer_next(&p, &msg, &pos))
		;
	assert_string_equal(p.senders[0], "Body3");
	close(p.fd);
	close_output(&c);
}

static void test_device_names(void **state)
{
	struct config cfg;
	struct output o;
	uint16_t ids[2] = { 1, 2 };
	char err[256];
	const char *text = "[source s]\ntype = sim\npeople = 2\n[avatar a]\nperson = s/p0\ncount = 2\n"
			   "[output v]\ntype = vrpn\naddress = 127.0.0.1\nport = %d\ndevice = %s\n";
	char buf[512];
	static const struct {
		const char *device, *why;
	} bad[] = {
		{ "Tracker", "names two avatars" },
		{ "Avatar%s", "only %d" },
		{ "%d-%%-%x", "only %d" },
		/* 95 characters and the id: a description a VRPN client would refuse */
		{ "AvatarAvatarAvatarAvatarAvatarAvatarAvatarAvatarAvatarAvatarAvatarAvatarAvatarAvatarAvatarAvata%d",
		  "longer than the 95 characters" },
	};

	(void)state;
	for (size_t i = 0; i < sizeof(bad) / sizeof(bad[0]); i++) {
		snprintf(buf, sizeof(buf), text, free_port(), bad[i].device);
		assert_int_equal(config_load_text(&cfg, "v.conf", buf, err, sizeof(err)), 0);
		assert_true(output_open(&o, &cfg.output[0], ids, 2, NULL, err, sizeof(err)) < 0);
		assert_non_null(strstr(err, "[output v] device"));
		assert_non_null(strstr(err, bad[i].why));
		config_free(&cfg);
	}
	/* a percent sign, escaped, and one device for one avatar */
	snprintf(buf, sizeof(buf),
		 "[source s]\ntype = sim\n[avatar a]\nperson = s/p0\n[output v]\ntype = vrpn\naddress = 127.0.0.1\n"
		 "port = %d\ndevice = Head%%%%Tracker\n",
		 free_port());
	assert_int_equal(config_load_text(&cfg, "v.conf", buf, err, sizeof(err)), 0);
	assert_int_equal(output_open(&o, &cfg.output[0], ids, 1, NULL, err, sizeof(err)), 0);
	output_close(&o);
	config_free(&cfg);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_reports_buttons_and_analog),
		cmocka_unit_test(test_stopped_person_sends_nothing),
		cmocka_unit_test(test_reload_keeps_or_drops_clients),
		cmocka_unit_test(test_device_names),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
