// SPDX-License-Identifier: MIT
/*
 * fuzz_modbus_server.c - the Modbus TCP server (src/publish/modbus_server.c,
 * its registers made by src/publish/modbus_map.c): a client's byte stream
 * (MBAP headers, any function, any length), framed and checked by the
 * server before libmodbus answers it.
 *
 * Input: byte 0 bit 0 picks the server (read-only, or 32 writable holding
 * registers; both publish two avatars' blocks of 100 registers from 1000),
 * bit 1 whether the loop has published frames yet; the rest is what the
 * client sends, then it shuts its side and reads every answer.
 *
 * Invariants: every answer is a whole MBAP frame with the request's
 * transaction id and protocol 0; the server closes the connection once the
 * client has shut its side (no slot kept); nothing reads past a request.
 */
#include "fuzz/fuzz.h"

#include "avatargw/wire.h"
#include "config/config.h"
#include "publish/output.h"

#include <arpa/inet.h>
#include <errno.h>
#include <netinet/in.h>
#include <poll.h>
#include <string.h>
#include <sys/socket.h>
#include <time.h>

static struct config cfg[2];
static struct output out[2];
static int port[2];

static void setup(int k)
{
	static const uint16_t ids[2] = { 0, 7 };
	char text[512], err[256];

	for (int tries = 0;; tries++) {
		port[k] = fuzz_free_port();
		snprintf(text, sizeof(text),
			 "[source s]\ntype = sim\npeople = 2\n[avatar a]\nid = 0\nperson = s/p0\n[avatar b]\nid = 7\n"
			 "person = s/p1\n[output m]\ntype = modbus\naddress = 127.0.0.1\nport = %d\n"
			 "register_base = 1000\nregister_stride = 100\nwritable_registers = %d\nword_order = %s\n",
			 port[k], k ? 32 : 0, k ? "cdab" : "abcd");
		if (config_load_text(&cfg[k], "fuzz", text, err, sizeof(err))) {
			fprintf(stderr, "fuzz: %s\n", err);
			abort();
		}
		if (!output_open(&out[k], &cfg[k].output[0], ids, 2, NULL, err, sizeof(err)))
			break;
		config_free(&cfg[k]);
		if (tries == 10) {
			fprintf(stderr, "fuzz: %s\n", err);
			abort();
		}
	}
}

static void publish(struct output *o)
{
	static uint8_t buf[2][WIRE_MAX_MSG];
	static struct wire_frame f[2];
	struct out_msg m[2];

	for (int a = 0; a < 2; a++) {
		memset(&f[a], 0, sizeof(f[a]));
		f[a].h.avatar_id = a ? 7 : 0;
		f[a].h.seq = 42;
		f[a].h.sample_time_ns = 1700000000123456789ull;
		for (int j = 0; j < WIRE_JOINTS; j++)
			f[a].joint[j] = a ? (float)j * 0.1f : NAN;
		m[a] = out_msg_frame(&f[a], buf[a], (uint16_t)a);
	}
	o->ops->send(o, m, 2);
}

/* the answers in buf[0..len): whole MBAP frames, protocol 0 */
static void check_answers(const uint8_t *buf, size_t len)
{
	size_t at = 0;

	while (at < len) {
		size_t mlen;

		FUZZ_CHECK(len - at >= 8, "a cut answer at %zu of %zu", at, len);
		mlen = (size_t)buf[at + 4] << 8 | buf[at + 5];
		FUZZ_CHECK(buf[at + 2] == 0 && buf[at + 3] == 0 && mlen >= 2 && at + 6 + mlen <= len,
			   "answer at %zu: protocol %u, length %zu of %zu", at, buf[at + 2] << 8 | buf[at + 3], mlen,
			   len - at);
		at += 6 + mlen;
	}
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	static uint8_t ans[1 << 20];
	size_t off = 1, got = 0;
	int fd, k;
	bool eof = false;

	if (size < 1)
		return 0;
	k = data[0] & 1;
	if (!out[k].ops)
		setup(k);
	if (data[0] & 2)
		publish(&out[k]);
	fd = fuzz_connect(port[k]);
	/* send it all (taking answers meanwhile, so that neither side waits on the other), then shut */
	for (uint64_t end = fuzz_mono_ns() + FUZZ_WAIT_NS; !eof && fuzz_mono_ns() < end;) {
		struct pollfd p = { fd, POLLIN | (off < size ? POLLOUT : 0), 0 };

		if (off == size) {
			shutdown(fd, SHUT_WR);
			off++;
		}
		if (poll(&p, 1, 1) <= 0)
			continue;
		if (p.revents & POLLOUT) {
			ssize_t n = send(fd, data + off, size - off, MSG_NOSIGNAL | MSG_DONTWAIT);

			if (n > 0)
				off += (size_t)n;
		}
		if (p.revents & (POLLIN | POLLHUP | POLLERR)) {
			ssize_t n = recv(fd, ans + got, sizeof(ans) - got, MSG_DONTWAIT);

			if (n == 0 || (n < 0 && errno != EAGAIN && errno != EINTR))
				eof = true;
			else if (n > 0 && (got += (size_t)n) == sizeof(ans))
				got = 0; /* a flood of answers: keep reading, checking the framing no further */
		}
	}
	close(fd);
	FUZZ_CHECK(eof, "the server kept the connection of a client that shut its side (30 s)");
	if (getenv("FUZZ_VERBOSE"))
		fprintf(stderr, "fuzz: %zu bytes sent, %zu bytes of answers\n", size - 1, got);
	if (got && got < sizeof(ans) / 2)
		check_answers(ans, got);
	return 0;
}
