// SPDX-License-Identifier: MIT
/*
 * test_udp.c - the UDP output on loopback: every message arrives as its own
 * datagram whether the kernel segments runs (GSO) or not, in order, with
 * DESCRIBEs of other lengths between the FRAMEs; a kernel that refuses
 * segmentation (sendmmsg wrapped at link time to fail like one) turns it off
 * and loses nothing; a full socket drops and counts.
 */
#include "avatargw/wire.h"
#include "publish/output.h"
#include "publish/udp.h"

#include <arpa/inet.h>
#include <errno.h>
#include <netinet/in.h>
#include <poll.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#define stat_out(c) ((int)atomic_load(c))

int __real_sendmmsg(int fd, struct mmsghdr *v, unsigned n, int flags);

/* what the wrapped sendmmsg() does */
static struct {
	bool refuse_gso; /* fail with EIO on a header that carries UDP_SEGMENT */
	bool eagain;	 /* fail every call with EAGAIN */
	int calls;
	int gso_headers; /* headers seen with a control message */
} fake;

int __wrap_sendmmsg(int fd, struct mmsghdr *v, unsigned n, int flags)
{
	fake.calls++;
	for (unsigned i = 0; i < n; i++)
		if (v[i].msg_hdr.msg_controllen)
			fake.gso_headers++;
	if (fake.eagain) {
		errno = EAGAIN;
		return -1;
	}
	if (fake.refuse_gso && v[0].msg_hdr.msg_controllen) {
		errno = EIO;
		return -1;
	}
	return __real_sendmmsg(fd, v, n, flags);
}

#define N_AV 150 /* more than two GSO runs of 64 */

struct fix {
	int rx;
	int port;
	struct cfg_output cfg;
	struct udp_opts opt;
	struct output out;
	uint16_t ids[N_AV];
	uint8_t buf[N_AV + 2][WIRE_MAX_MSG];
	struct out_msg msgs[N_AV + 2];
	int n;
};

static int setup(void **state)
{
	static struct fix f;
	struct sockaddr_in a = { .sin_family = AF_INET, .sin_addr.s_addr = htonl(INADDR_LOOPBACK) };
	socklen_t al = sizeof(a);
	int big = 4 << 20;

	memset(&f, 0, sizeof(f));
	memset(&fake, 0, sizeof(fake));
	f.rx = socket(AF_INET, SOCK_DGRAM, 0);
	assert_true(f.rx >= 0);
	setsockopt(f.rx, SOL_SOCKET, SO_RCVBUF, &big, sizeof(big));
	assert_int_equal(bind(f.rx, (struct sockaddr *)&a, sizeof(a)), 0);
	assert_int_equal(getsockname(f.rx, (struct sockaddr *)&a, &al), 0);
	f.port = ntohs(a.sin_port);
	snprintf(f.cfg.name, sizeof(f.cfg.name), "u");
	f.cfg.type = cfg_output_type_find("udp");
	f.cfg.opt = &f.opt;
	snprintf(f.opt.address, sizeof(f.opt.address), "127.0.0.1");
	f.opt.port = f.port;
	f.cfg.decimate = 1;
	f.opt.gso = true;
	for (int i = 0; i < N_AV; i++)
		f.ids[i] = (uint16_t)i;
	/* N_AV FRAME-sized messages, with two longer ones (DESCRIBE-like) inside */
	for (int i = 0; i < N_AV + 2; i++) {
		bool longer = i == 10 || i == 100;
		uint16_t len = longer ? 1200 : 500;

		memset(f.buf[i], 0, len);
		f.buf[i][5] = longer ? WIRE_DESCRIBE : WIRE_FRAME;
		memcpy(&f.buf[i][8], &i, sizeof(i)); /* a serial number to check the order */
		f.msgs[i] = (struct out_msg){ f.buf[i], len, longer ? WIRE_DESCRIBE : WIRE_FRAME, (uint16_t)(i % N_AV),
					      NULL,	NULL };
	}
	f.n = N_AV + 2;
	*state = &f;
	return 0;
}

static int teardown(void **state)
{
	struct fix *f = *state;

	output_close(&f->out);
	close(f->rx);
	return 0;
}

/* receives everything sent; checks each datagram's length and order */
static int drain(struct fix *f, int expect)
{
	uint8_t b[2048];
	int got = 0;

	while (got < expect) {
		struct pollfd p = { f->rx, POLLIN, 0 };
		ssize_t r;
		int serial;

		if (poll(&p, 1, 1000) <= 0)
			break;
		r = recv(f->rx, b, sizeof(b), 0);
		assert_true(r > 0);
		memcpy(&serial, &b[8], sizeof(serial));
		assert_int_equal(serial, got);
		assert_int_equal(r, f->msgs[got].len);
		got++;
	}
	return got;
}

static void open_out(struct fix *f)
{
	char err[256] = "";

	assert_int_equal(output_open(&f->out, &f->cfg, f->ids, N_AV, NULL, err, sizeof(err)), 0);
}

static void test_gso_datagrams(void **state)
{
	struct fix *f = *state;

	open_out(f);
	f->out.ops->send(&f->out, f->msgs, f->n);
	assert_int_equal(drain(f, f->n), f->n);
	assert_int_equal(stat_out(&f->out.st.sent), f->n);
	assert_int_equal(stat_out(&f->out.st.gso_off), 0);
	/* runs: 0-9, [10], 11-74, 75-99, [100], 101-151 at most 64 long: segmentation was asked for */
	assert_true(fake.gso_headers >= 4);
	assert_int_equal(fake.calls, 1);
}

static void test_gso_off_by_config(void **state)
{
	struct fix *f = *state;

	f->opt.gso = false;
	open_out(f);
	f->out.ops->send(&f->out, f->msgs, f->n);
	assert_int_equal(drain(f, f->n), f->n);
	assert_int_equal(fake.gso_headers, 0);
}

static void test_gso_refused(void **state)
{
	struct fix *f = *state;

	fake.refuse_gso = true;
	open_out(f);
	for (int rep = 0; rep < 2; rep++) {
		f->out.ops->send(&f->out, f->msgs, f->n);
		assert_int_equal(drain(f, f->n), f->n);
	}
	assert_int_equal(stat_out(&f->out.st.sent), 2 * f->n);
	assert_int_equal(stat_out(&f->out.st.dropped), 0);
	assert_int_equal(stat_out(&f->out.st.errors), 0);
	/* refused once, then never asked again */
	assert_int_equal(stat_out(&f->out.st.gso_off), 1);
	fake.gso_headers = 0;
	f->out.ops->send(&f->out, f->msgs, f->n);
	assert_int_equal(fake.gso_headers, 0);
	assert_int_equal(drain(f, f->n), f->n);
}

static void test_full_socket_drops(void **state)
{
	struct fix *f = *state;

	fake.eagain = true;
	open_out(f);
	f->out.ops->send(&f->out, f->msgs, f->n);
	/* every message counted as dropped, once; none sent */
	assert_int_equal(stat_out(&f->out.st.dropped), f->n);
	assert_int_equal(stat_out(&f->out.st.sent), 0);
	assert_int_equal(stat_out(&f->out.st.gso_off), 0);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test_setup_teardown(test_gso_datagrams, setup, teardown),
		cmocka_unit_test_setup_teardown(test_gso_off_by_config, setup, teardown),
		cmocka_unit_test_setup_teardown(test_gso_refused, setup, teardown),
		cmocka_unit_test_setup_teardown(test_full_socket_drops, setup, teardown),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
