// SPDX-License-Identifier: MIT
/*
 * fuzz_vrpn.c - the VRPN server (src/publish/vrpn.c): what a client sends
 * over its TCP connection (the cookie, then messages: descriptions of its
 * senders and types, its UDP port, pings, anything else), and the UDP
 * request of a plain client (vrpn_parse_request).
 *
 * Input: byte 0 bit 0 set: the rest is a UDP request, parsed. Clear: the
 * rest is a client's TCP stream, sent (in up to four writes, at the
 * offsets bytes 1-3 choose) to a VRPN output served as the loop serves
 * it, on a free loopback port, two avatars (no UDP: a port the client
 * names gets no datagrams from the harness); then the client shuts its side
 * and the server must let it go. Frames are published between the writes,
 * so that pings and button states meet the client's descriptions.
 *
 * Invariants: a request accepted names a port from 1024 to 65535 and a host
 * of the allowed characters; the server never reads past what it was sent
 * (ASan), answers within its buffers, and lets every client go once it
 * has shut its side (no slot kept).
 */
#include "fuzz/fuzz.h"

#include "avatargw/wire.h"
#include "config/config.h"
#include "publish/output.h"
#include "publish/vrpn.h"

#include <arpa/inet.h>
#include <ctype.h>
#include <errno.h>
#include <netinet/in.h>
#include <poll.h>
#include <string.h>
#include <sys/socket.h>

static struct config cfg;
static struct output out;
static int port;
static uint8_t frame[2][WIRE_MAX_MSG];
static struct wire_frame wf[2];

static void setup(void)
{
	static const uint16_t ids[2] = { 0, 7 };
	char text[512], err[256];
	for (int tries = 0;; tries++) {
		port = fuzz_free_port();
		snprintf(text, sizeof(text),
			 "[source s]\ntype = sim\npeople = 2\n[avatar a]\nid = 0\nperson = s/p0\n[avatar b]\nid = 7\n"
			 "person = s/p1\n[output v]\ntype = vrpn\naddress = 127.0.0.1\nport = %d\nmax_clients = 2\n"
			 "client_buffer = 65536\nudp = no\n",
			 port);
		if (config_load_text(&cfg, "fuzz", text, err, sizeof(err))) {
			fprintf(stderr, "fuzz: %s\n", err);
			abort();
		}
		if (!output_open(&out, &cfg.output[0], ids, 2, NULL, err, sizeof(err)))
			break;
		config_free(&cfg);
		if (tries == 10) {
			fprintf(stderr, "fuzz: %s\n", err);
			abort();
		}
	}
	for (int a = 0; a < 2; a++) {
		struct wire_frame *f = &wf[a];

		memset(f, 0, sizeof(*f));
		f->h.avatar_id = ids[a];
		f->h.flags = WIRE_F_INPUTS;
		f->in.present = 7;
		for (int s = 0; s < WIRE_SEGMENTS; s++)
			f->segment[s].q[0] = 1;
		for (int s = 0; s < WIRE_SENSORS; s++)
			f->sensor[s].pose.q[0] = 1;
	}
}

/* takes what the server sent, so that its buffers drain; false: it closed */
static bool drain(int fd)
{
	uint8_t buf[65536];

	for (;;) {
		ssize_t n = recv(fd, buf, sizeof(buf), MSG_DONTWAIT);

		if (n == 0)
			return false;
		if (n < 0)
			return errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR;
	}
}

static void cycle(void)
{
	static uint32_t buttons;
	struct out_msg m[2];

	/* a button changes at every cycle: Change messages, and the states again when one did not fit */
	buttons = buttons * 1103515245u + 12345u;
	for (int a = 0; a < 2; a++) {
		wf[a].in.buttons[a] = buttons;
		m[a] = out_msg_frame(&wf[a], frame[a], (uint16_t)a);
	}
	out.ops->service(&out);
	out.ops->send(&out, m, 2);
}

static void client_stream(const uint8_t *data, size_t size)
{
	int fd = fuzz_connect(port), k = 0;
	size_t cut[5] = { 0, 0, 0, 0, size };
	bool open = true;

	for (int i = 1; i < 4; i++)
		cut[i] = size > 3 ? 3 + (size - 3) * data[i - 1] / 255 : size;
	for (int i = 1; i < 5; i++)
		if (cut[i] < cut[i - 1])
			cut[i] = cut[i - 1];
	cut[0] = size > 3 ? 3 : size;
	for (int i = 0; i < 4; i++) {
		size_t off = cut[i];

		while (open && off < cut[i + 1]) {
			ssize_t n = send(fd, data + off, cut[i + 1] - off, MSG_NOSIGNAL | MSG_DONTWAIT);

			if (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR)
				open = false;
			if (n > 0)
				off += (size_t)n;
			cycle();
			open = open && drain(fd);
		}
		cycle();
		open = open && drain(fd);
	}
	shutdown(fd, SHUT_WR);
	/* the server reads up to the end, then lets the client go */
	for (uint64_t end = fuzz_mono_ns() + FUZZ_WAIT_NS; atomic_load(&out.st.clients) && fuzz_mono_ns() < end; k++) {
		struct pollfd p = { fd, POLLIN, 0 };

		cycle();
		if (!drain(fd))
			open = false;
		if (atomic_load(&out.st.clients))
			poll(&p, 1, 1);
	}
	FUZZ_CHECK(!atomic_load(&out.st.clients), "a client that shut its side is still served after %d cycles", k);
	close(fd);
}

static void request(const uint8_t *data, size_t size)
{
	char msg[201], host[128];
	size_t n = size < sizeof(msg) - 1 ? size : sizeof(msg) - 1;
	int p = 0;

	/* as the server takes a datagram: at most 200 bytes, then a NUL */
	memcpy(msg, data, n);
	msg[n] = '\0';
	if (vrpn_parse_request(msg, host, &p))
		return;
	FUZZ_CHECK(p >= 1024 && p <= 65535, "port %d", p);
	FUZZ_CHECK(memchr(host, 0, 128) && host[0], "host");
	for (const char *h = host; *h; h++)
		FUZZ_CHECK(isalnum((unsigned char)*h) || *h == '.' || *h == ':' || *h == '-', "host '%s'", host);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	if (!out.ops)
		setup();
	if (size < 1)
		return 0;
	if (data[0] & 1)
		request(data + 1, size - 1);
	else
		client_stream(data + 1, size - 1);
	return 0;
}
