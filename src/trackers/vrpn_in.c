// SPDX-License-Identifier: MIT
/*
 * vrpn_in.c - a VRPN client source (type = vrpn; docs/TRACKERS.md, "From a
 * VRPN server"), written from the protocol (wire/vrpn_proto.h) as our VRPN
 * server is: no VRPN library.
 *
 * The network runs on a device thread (trackers/device.h): connecting,
 * the cookie handshake, reading TCP and UDP, pings, timeouts and retries
 * all happen there; the loop only copies the newest samples out of the
 * device's triple buffer. A server that floods, sends garbage or stalls
 * costs that thread, never the loop.
 *
 * Connecting. NAME@host asks the server to call back, as VRPN clients do:
 * we listen on a TCP port and send "<our address> <port>" in UDP datagrams
 * to the server's port until it connects to us. NAME@tcp://host connects
 * to the server's TCP port. Either way each side sends its cookie, then we
 * describe our device (its name, for the server's pongs) and the ping
 * type, and, with udp = yes, our UDP port: the server then sends its
 * low-latency messages (tracker and analog reports) as UDP datagrams.
 *
 * The server describes its own senders and types; the codec maps the
 * device we read and the types we know, and decodes Pos_Quat (a channel's
 * pose), Button Change and States and Analog Channel (the device's
 * buttons and analog values, which buttons.N and analog.N give to
 * channels). A ping every timeout_ms / 4 keeps a quiet device's
 * connection known alive; nothing received for timeout_ms (or the
 * connection closing, or a framing no VRPN peer writes) drops the
 * connection, makes the source FAULTY, and a new one is tried after 50 ms,
 * then less often, up to every 400 ms.
 */
#include "trackers/vrpn_in.h"

#include "trackers/device.h"

#include <arpa/inet.h>
#include <ctype.h>
#include <errno.h>
#include <float.h>
#include <math.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <syslog.h>
#include <time.h>
#include <unistd.h>

#define VIN_BUF (2 * 65536) /* TCP bytes not yet decoded: more than the longest message */
#define VIN_UDP_BATCH 64    /* datagrams read per wake-up before the stream is looked at again */
#define VIN_BACKOFF_MIN_MS 50
#define VIN_BACKOFF_MAX_MS 400
#define VIN_LOB_MS 200 /* a connection request goes again this often */

static const char *const vt_names[VT_COUNT] = { VRPN_T_POS_QUAT, VRPN_T_BUTTON_CHANGE, VRPN_T_BUTTON_STATES,
						VRPN_T_ANALOG, VRPN_T_PONG };

/* ---- the codec: one message in ----------------------------------------------------- */

int vrpn_in_parse_device(const char *spec, char *name, size_t nlen, char *host, size_t hlen, int *port, bool *tcp)
{
	const char *at = strchr(spec, '@'), *h, *colon;
	size_t hl;

	if (!at || at == spec || (size_t)(at - spec) >= nlen || (size_t)(at - spec) > VRPN_DEVICE_MAX)
		return -1;
	memcpy(name, spec, (size_t)(at - spec));
	name[at - spec] = '\0';
	h = at + 1;
	*tcp = false;
	if (!strncmp(h, "tcp://", 6)) {
		*tcp = true;
		h += 6;
	} else if (!strncmp(h, "tcp:", 4)) {
		*tcp = true;
		h += 4;
	}
	*port = VRPN_DEFAULT_PORT;
	if (*h == '[') {
		const char *end = strchr(h, ']');

		if (!end)
			return -1;
		hl = (size_t)(end - h - 1);
		if (!hl || hl >= hlen)
			return -1;
		memcpy(host, h + 1, hl);
		host[hl] = '\0';
		colon = end[1] == ':' ? end + 1 : NULL;
		if (end[1] && !colon)
			return -1;
	} else {
		colon = strchr(h, ':');
		if (colon && strchr(colon + 1, ':'))
			return -1; /* a bare IPv6 address: it needs its brackets */
		hl = colon ? (size_t)(colon - h) : strlen(h);
		if (!hl || hl >= hlen)
			return -1;
		memcpy(host, h, hl);
		host[hl] = '\0';
	}
	if (colon) {
		char *end;
		long p = strtol(colon + 1, &end, 10);

		if (!colon[1] || *end || p < 1 || p > 65535)
			return -1;
		*port = (int)p;
	}
	return 0;
}

static void vin_codec_reset(void *st)
{
	struct vrpn_in_codec_st *v = st;

	/* a new connection: the server's ids and the device's inputs are its own again */
	v->sender = -1;
	v->devices[0] = '\0';
	for (int i = 0; i < VT_COUNT; i++)
		v->type[i] = -1;
	memset(v->buttons, 0, sizeof(v->buttons));
	memset(v->analog, 0, sizeof(v->analog));
	timemap_reset(&v->tm);
}

static const struct vrpn_in_opts *opts_of(const struct cfg_source *c)
{
	return c->opt;
}

/* channel ch's inputs, from buttons.N and analog.N ({0, 0}: none) */
static void vin_inputs_of(const struct vrpn_in_opts *o, int ch, int btn[2], int an[2])
{
	char key[32];
	const char *v;

	btn[0] = btn[1] = an[0] = an[1] = 0;
	snprintf(key, sizeof(key), "buttons.%d", ch);
	if ((v = chan_value(o->buttons, CHAN_MAX, key)) && !chan_range(v, 32, btn))
		btn[0] = btn[1] = 0;
	snprintf(key, sizeof(key), "analog.%d", ch);
	if ((v = chan_value(o->analog, CHAN_MAX, key)) && !chan_range(v, SENSOR_ANALOG_MAX, an))
		an[0] = an[1] = 0;
}

static int vin_codec_init(void *st, const struct cfg_source *cfg, char *err, size_t errlen)
{
	const struct vrpn_in_opts *o = opts_of(cfg);
	struct vrpn_in_codec_st *v = st;
	char host[256];
	int port;
	bool tcp;

	memset(v, 0, sizeof(*v));
	if (vrpn_in_parse_device(o->dev.device, v->device, sizeof(v->device), host, sizeof(host), &port, &tcp)) {
		snprintf(err, errlen,
			 "device: '%s' is not NAME@host[:port] or NAME@tcp://host[:port] (a name of at most %d "
			 "characters)",
			 o->dev.device, VRPN_DEVICE_MAX);
		return -1;
	}
	v->n = o->sensors < CHAN_MAX ? o->sensors : CHAN_MAX;
	for (int ch = 0; ch < v->n; ch++)
		vin_inputs_of(o, ch, v->btn[ch], v->an[ch]);
	vin_codec_reset(v);
	return 0;
}

static double vin_codec_period(const void *st)
{
	(void)st;
	return 1.0 / 60; /* a capture without timestamps: VRPN servers of optical trackers send 60 Hz and more */
}

/* channel ch's inputs from the device's buttons and analog values */
static void vin_inputs(const struct vrpn_in_codec_st *v, int ch, struct device_sample *s)
{
	const int *b = v->btn[ch], *a = v->an[ch];

	s->buttons = 0;
	memset(s->analog, 0, sizeof(s->analog));
	s->inputs = b[1] > 0 || a[1] > 0;
	for (int i = 0; i < b[1]; i++) {
		int k = b[0] + i;

		if (k < VRPN_IN_BUTTONS && (v->buttons[k / 32] >> (k % 32) & 1u))
			s->buttons |= 1u << i;
	}
	for (int i = 0; i < a[1] && i < SENSOR_ANALOG_MAX; i++) {
		int k = a[0] + i;

		s->analog[i] = k < VRPN_IN_ANALOG ? (float)v->analog[k] : 0.0f;
	}
}

static void vin_set_button(struct vrpn_in_codec_st *v, uint32_t b, uint32_t state)
{
	if (b >= VRPN_IN_BUTTONS) {
		v->others++;
		return;
	}
	if (state)
		v->buttons[b / 32] |= 1u << (b % 32);
	else
		v->buttons[b / 32] &= ~(1u << (b % 32));
}

static int vin_codec_feed(void *st, const uint8_t *buf, size_t len, device_emit_fn *emit, void *ctx)
{
	struct vrpn_in_codec_st *v = st;
	struct vrpn_header h;
	const uint8_t *pl;
	size_t total, plen;

	if (vrpn_split(buf, len, &h, &total) != VRPN_SPLIT_OK || h.usec >= 1000000u) {
		v->c.malformed++;
		return -EBADMSG;
	}
	pl = buf + VRPN_HEADER_LEN;
	plen = h.len - VRPN_HEADER_LEN;
	if (h.type == VRPN_SENDER_DESCRIPTION || h.type == VRPN_TYPE_DESCRIPTION) {
		char name[VRPN_NAME_MAX];

		if (h.sender < 0 || h.sender >= VRPN_ID_MAX || !vrpn_description_name(pl, plen, name)) {
			v->c.malformed++;
			return -EBADMSG;
		}
		if (h.type == VRPN_SENDER_DESCRIPTION) {
			size_t n = strlen(v->devices);

			if (!strcmp(name, v->device)) {
				v->sender = h.sender;
				return 0;
			}
			if (v->sender == h.sender)
				v->sender = -1;
			/* the server's other devices: what to say when the one asked for is not among them */
			if (n + strlen(name) + 3 < sizeof(v->devices))
				snprintf(v->devices + n, sizeof(v->devices) - n, "%s%s", n ? ", " : "", name);
			return 0;
		}
		for (int i = 0; i < VT_COUNT; i++) {
			if (!strcmp(name, vt_names[i]))
				v->type[i] = h.sender;
			else if (v->type[i] == h.sender)
				v->type[i] = -1;
		}
		return 0;
	}
	if (h.type < 0)
		return 0; /* UDP and log descriptions, disconnect markers: nothing a client reads */
	if (h.sender != v->sender || v->sender < 0) {
		v->others++;
		return 0;
	}
	if (h.type == v->type[VT_POS_QUAT]) {
		struct device_sample s;
		struct quat q;
		struct vec3 p;
		double n, x[7];
		int32_t ch;

		if (plen < VRPN_POS_QUAT_LEN) {
			v->c.malformed++;
			return -EBADMSG;
		}
		ch = (int32_t)vrpn_get32(pl);
		for (int i = 0; i < 7; i++) {
			x[i] = vrpn_get_f64(pl + 8 + 8 * i);
			if (!isfinite(x[i]) || fabs(x[i]) > 1e5) {
				v->c.malformed++;
				return -EBADMSG;
			}
		}
		n = sqrt(x[3] * x[3] + x[4] * x[4] + x[5] * x[5] + x[6] * x[6]);
		/* VRPN's quaternions are unit to rounding; anything far from it is not a pose */
		if (ch < 0 || n < 0.9 || n > 1.1) {
			v->c.malformed++;
			return -EBADMSG;
		}
		v->c.reports++;
		if (ch < VRPN_IN_SEEN)
			v->seen[ch]++;
		v->last_src_ns = (uint64_t)h.sec * 1000000000ull + (uint64_t)h.usec * 1000u;
		if (ch >= v->n) {
			v->ignored++;
			return 0;
		}
		/* VRPN sends x y z w */
		q = (struct quat){ x[6] / n, x[3] / n, x[4] / n, x[5] / n };
		p = (struct vec3){ x[0], x[1], x[2] };
		dq_from_rt(&q, &p, &s.pose);
		vin_inputs(v, ch, &s);
		s.t_ns = timemap_map(&v->tm, v->last_src_ns, real_ns());
		emit(ctx, ch, &s);
		return 1;
	}
	if (h.type == v->type[VT_BUTTON_CHANGE]) {
		if (plen < 8) {
			v->c.malformed++;
			return -EBADMSG;
		}
		vin_set_button(v, vrpn_get32(pl), vrpn_get32(pl + 4));
		return 0;
	}
	if (h.type == v->type[VT_BUTTON_STATES]) {
		uint32_t nb;

		if (plen < 4 || (nb = vrpn_get32(pl)) > (plen - 4) / 4) {
			v->c.malformed++;
			return -EBADMSG;
		}
		for (uint32_t b = 0; b < nb; b++)
			vin_set_button(v, b, vrpn_get32(pl + 4 + 4 * b));
		return 0;
	}
	if (h.type == v->type[VT_ANALOG]) {
		double nc;

		if (plen < 8 || !isfinite(nc = vrpn_get_f64(pl)) || nc < 0 || nc > (double)((plen - 8) / 8) ||
		    nc != floor(nc)) {
			v->c.malformed++;
			return -EBADMSG;
		}
		for (int i = 0; i < (int)nc && i < VRPN_IN_ANALOG; i++) {
			double a = vrpn_get_f64(pl + 8 + 8 * i);

			/* published as float32: a value past its range (or not finite) is unknown, 0 */
			v->analog[i] = isfinite(a) && fabs(a) <= FLT_MAX ? a : 0.0;
		}
		return 0;
	}
	if (h.type == v->type[VT_PONG]) {
		v->pongs++;
		return 0;
	}
	v->others++;
	return 0;
}

const struct device_codec vrpn_in_codec = {
	.name = "vrpn",
	.size = sizeof(struct vrpn_in_codec_st),
	.init = vin_codec_init,
	.reset = vin_codec_reset,
	.feed = vin_codec_feed,
	.period = vin_codec_period,
};

/* ---- the device thread ------------------------------------------------------------- */

struct vrpn_in {
	struct device dev; /* first: the device_drv_* entries reach it through t->priv */
	char name[VRPN_NAME_MAX], host[128];
	int port;
	bool tcp;
	int fd, ufd; /* the TCP connection, our UDP port */
	struct sockaddr_storage server;
	socklen_t server_len;
	uint8_t in[VIN_BUF];
	size_t in_len;
	uint64_t last_rx; /* CLOCK_MONOTONIC of the last bytes from the server */
	bool ever_up;
	/* for status and report (control thread) */
	_Atomic uint64_t tcp_msgs, udp_msgs, connects, stalls;
	_Atomic int64_t offset_us;
};

static void vin_close_conn(struct vrpn_in *v)
{
	if (v->fd >= 0)
		close(v->fd);
	if (v->ufd >= 0)
		close(v->ufd);
	v->fd = v->ufd = -1;
	v->in_len = 0;
}

static int vin_resolve(struct vrpn_in *v, char *why, size_t wlen)
{
	struct addrinfo hints = { .ai_socktype = SOCK_STREAM, .ai_flags = AI_NUMERICSERV }, *ai;
	char port[8];
	int rc;

	snprintf(port, sizeof(port), "%d", v->port);
	rc = getaddrinfo(v->host, port, &hints, &ai);
	if (rc) {
		snprintf(why, wlen, "%s: %s", v->host, gai_strerror(rc));
		return -1;
	}
	memcpy(&v->server, ai->ai_addr, ai->ai_addrlen);
	v->server_len = ai->ai_addrlen;
	freeaddrinfo(ai);
	return 0;
}

/* waits for fd to be ready for events, at most ms; 1 ready, 0 not (or stopping), -1 error */
static int vin_wait(struct vrpn_in *v, int fd, short events, int ms)
{
	uint64_t end = mono_ns() + (uint64_t)ms * 1000000ull;

	while (!device_stopping(&v->dev)) {
		struct pollfd p = { fd, events, 0 };
		uint64_t now = mono_ns();
		int left = now >= end ? 0 : (int)((end - now) / 1000000ull) + 1, r;

		r = poll(&p, 1, left < 50 ? left : 50);
		if (r > 0)
			return (p.revents & (POLLERR | POLLNVAL)) && !(p.revents & events) ? -1 : 1;
		if (r < 0 && errno != EINTR)
			return -1;
		if (now >= end)
			return 0;
	}
	return 0;
}

static void vin_addr_text(const struct sockaddr_storage *a, char *buf, size_t len)
{
	if (a->ss_family == AF_INET6)
		inet_ntop(AF_INET6, &((const struct sockaddr_in6 *)a)->sin6_addr, buf, (socklen_t)len);
	else
		inet_ntop(AF_INET, &((const struct sockaddr_in *)a)->sin_addr, buf, (socklen_t)len);
}

/* NAME@tcp://host: connect to the server's port */
static int vin_connect_tcp(struct vrpn_in *v, char *why, size_t wlen)
{
	int fd = socket(v->server.ss_family, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0), e = 0, r;
	socklen_t el = sizeof(e);

	if (fd < 0) {
		snprintf(why, wlen, "socket: %s", strerror(errno));
		return -1;
	}
	if (connect(fd, (struct sockaddr *)&v->server, v->server_len) && errno != EINPROGRESS) {
		snprintf(why, wlen, "connect: %s", strerror(errno));
		close(fd);
		return -1;
	}
	r = vin_wait(v, fd, POLLOUT, 1000);
	if (r <= 0 || getsockopt(fd, SOL_SOCKET, SO_ERROR, &e, &el) || e) {
		snprintf(why, wlen, "connect: %s", e ? strerror(e) : r == 0 ? "timed out" : "failed");
		close(fd);
		return -1;
	}
	v->fd = fd;
	return 0;
}

/* NAME@host: ask the server (UDP) to connect to our TCP port, as VRPN clients do */
static int vin_connect_lob(struct vrpn_in *v, char *why, size_t wlen)
{
	struct sockaddr_storage me;
	socklen_t ml = sizeof(me);
	char ip[INET6_ADDRSTRLEN], msg[INET6_ADDRSTRLEN + 16];
	int u = socket(v->server.ss_family, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
	int l = socket(v->server.ss_family, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0), rc = -1;
	uint64_t end = mono_ns() + 1000000000ull;

	if (u < 0 || l < 0 || connect(u, (struct sockaddr *)&v->server, v->server_len) ||
	    getsockname(u, (struct sockaddr *)&me, &ml)) {
		snprintf(why, wlen, "UDP to %s: %s", v->host, strerror(errno));
		goto out;
	}
	/* our address as the server reaches it, any port: the TCP port it is to call */
	if (me.ss_family == AF_INET6)
		((struct sockaddr_in6 *)&me)->sin6_port = 0;
	else
		((struct sockaddr_in *)&me)->sin_port = 0;
	if (bind(l, (struct sockaddr *)&me, ml) || listen(l, 1) || getsockname(l, (struct sockaddr *)&me, &ml)) {
		snprintf(why, wlen, "TCP listen: %s", strerror(errno));
		goto out;
	}
	vin_addr_text(&me, ip, sizeof(ip));
	snprintf(msg, sizeof(msg), "%s %d", ip,
		 ntohs(me.ss_family == AF_INET6 ? ((struct sockaddr_in6 *)&me)->sin6_port
						: ((struct sockaddr_in *)&me)->sin_port));
	snprintf(why, wlen, "no call back from the server");
	while (!device_stopping(&v->dev) && mono_ns() < end) {
		int fd;

		/* refused (nothing on the port yet): the next one may find it */
		if (send(u, msg, strlen(msg) + 1, MSG_DONTWAIT) < 0 && errno != ECONNREFUSED && errno != EAGAIN)
			snprintf(why, wlen, "UDP to %s: %s", v->host, strerror(errno));
		if (vin_wait(v, l, POLLIN, VIN_LOB_MS) <= 0)
			continue;
		fd = accept4(l, NULL, NULL, SOCK_NONBLOCK | SOCK_CLOEXEC);
		if (fd >= 0) {
			v->fd = fd;
			rc = 0;
			break;
		}
	}
out:
	if (u >= 0)
		close(u);
	if (l >= 0)
		close(l);
	return rc;
}

/* all of buf, waiting a little for room; false: the connection is no good */
static bool vin_send(struct vrpn_in *v, const uint8_t *buf, size_t len)
{
	while (len) {
		ssize_t n = send(v->fd, buf, len, MSG_DONTWAIT | MSG_NOSIGNAL);

		if (n > 0) {
			buf += n;
			len -= (size_t)n;
			continue;
		}
		if (n < 0 && errno == EINTR)
			continue;
		if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK) && vin_wait(v, v->fd, POLLOUT, 500) > 0)
			continue;
		return false;
	}
	return true;
}

/* cookie, our descriptions, our UDP port; then the server's cookie */
static int vin_handshake(struct vrpn_in *v, const struct vrpn_in_opts *cfg, char *why, size_t wlen)
{
	uint8_t out[VRPN_COOKIE_LEN + 3 * VRPN_MSG_LEN(4 + VRPN_NAME_MAX)], *p = out;
	uint64_t t = real_ns(), end;
	int one = 1;

	setsockopt(v->fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof(one));
	vrpn_cookie(p);
	p += VRPN_COOKIE_LEN;
	/* our device (the server answers its pings) and the ping type, both our id 0 */
	p += vrpn_msg_description(p, VRPN_SENDER_DESCRIPTION, 0, v->name, t);
	p += vrpn_msg_description(p, VRPN_TYPE_DESCRIPTION, 0, VRPN_T_PING, t);
	if (cfg->udp) {
		struct sockaddr_storage me;
		socklen_t ml = sizeof(me);
		char ip[INET6_ADDRSTRLEN];
		int port;

		/* a UDP port on the address our TCP connection has: where the server sends its reports */
		v->ufd = socket(v->server.ss_family, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
		if (v->ufd < 0 || getsockname(v->fd, (struct sockaddr *)&me, &ml)) {
			snprintf(why, wlen, "UDP socket: %s", strerror(errno));
			return -1;
		}
		if (me.ss_family == AF_INET6)
			((struct sockaddr_in6 *)&me)->sin6_port = 0;
		else
			((struct sockaddr_in *)&me)->sin_port = 0;
		if (bind(v->ufd, (struct sockaddr *)&me, ml) || getsockname(v->ufd, (struct sockaddr *)&me, &ml)) {
			snprintf(why, wlen, "UDP bind: %s", strerror(errno));
			return -1;
		}
		{
			int rcv = 1 << 20;

			setsockopt(v->ufd, SOL_SOCKET, SO_RCVBUF, &rcv, sizeof(rcv));
		}
		vin_addr_text(&me, ip, sizeof(ip));
		port = ntohs(me.ss_family == AF_INET6 ? ((struct sockaddr_in6 *)&me)->sin6_port
						      : ((struct sockaddr_in *)&me)->sin_port);
		{
			size_t n = strlen(ip) + 1;
			uint8_t *q = vrpn_msg_header(p, VRPN_UDP_DESCRIPTION, port, t, n);

			memcpy(q, ip, n);
			p += VRPN_MSG_LEN(n);
		}
	}
	if (!vin_send(v, out, (size_t)(p - out))) {
		snprintf(why, wlen, "sending our cookie: %s", strerror(errno));
		return -1;
	}
	end = mono_ns() + (uint64_t)(cfg->timeout_ms > 1000 ? cfg->timeout_ms : 1000) * 1000000ull;
	while (v->in_len < VRPN_COOKIE_LEN) {
		ssize_t n;
		uint64_t now = mono_ns();

		if (now >= end || vin_wait(v, v->fd, POLLIN, (int)((end - now) / 1000000ull) + 1) <= 0) {
			snprintf(why, wlen, "no cookie from the server");
			return -1;
		}
		n = recv(v->fd, v->in + v->in_len, VRPN_COOKIE_LEN - v->in_len, MSG_DONTWAIT);
		if (n == 0 || (n < 0 && errno != EAGAIN && errno != EINTR)) {
			snprintf(why, wlen, "closed before its cookie%s%s", n ? ": " : "", n ? strerror(errno) : "");
			return -1;
		}
		if (n > 0)
			v->in_len += (size_t)n;
	}
	if (!vrpn_cookie_ok(v->in)) {
		ctr_add(&v->dev.t->st.malformed, 1);
		snprintf(why, wlen, "its cookie is not VRPN's (%.16s)", (const char *)v->in);
		return -1;
	}
	v->in_len = 0;
	v->last_rx = mono_ns();
	return 0;
}

/* the messages in one UDP datagram; false when one is cut or malformed (the rest is dropped) */
static void vin_datagram(struct vrpn_in *v, const uint8_t *buf, size_t len)
{
	size_t pos = 0;

	while (pos < len) {
		struct vrpn_header h;
		size_t total;

		if (vrpn_split(buf + pos, len - pos, &h, &total) != VRPN_SPLIT_OK) {
			ctr_add(&v->dev.t->st.malformed, 1);
			return;
		}
		device_feed(&v->dev, buf + pos, total);
		atomic_fetch_add_explicit(&v->udp_msgs, 1, memory_order_relaxed);
		pos += total;
	}
}

/* reads until the connection ends or stalls; returns why in why */
static void vin_stream(struct vrpn_in *v, const struct vrpn_in_opts *cfg, char *why, size_t wlen)
{
	uint64_t timeout = (uint64_t)(cfg->timeout_ms * 1e6), ping_every = timeout / 4, next_ping = 0;
	uint64_t named_by = mono_ns() + timeout / 2; /* the server describes its devices right after its cookie */
	uint8_t dgram[65536];

	while (!device_stopping(&v->dev)) {
		struct pollfd p[2] = { { v->fd, POLLIN, 0 }, { v->ufd, POLLIN, 0 } };
		uint64_t now;
		int r = poll(p, v->ufd >= 0 ? 2 : 1, 20);

		if (r < 0 && errno != EINTR) {
			snprintf(why, wlen, "poll: %s", strerror(errno));
			return;
		}
		if (p[0].revents) {
			ssize_t n = recv(v->fd, v->in + v->in_len, sizeof(v->in) - v->in_len, MSG_DONTWAIT);
			size_t pos = 0;

			if (n == 0) {
				snprintf(why, wlen, "the server closed the connection");
				return;
			}
			if (n < 0 && errno != EAGAIN && errno != EINTR) {
				snprintf(why, wlen, "%s", strerror(errno));
				return;
			}
			if (n > 0) {
				v->in_len += (size_t)n;
				v->last_rx = mono_ns();
			}
			for (;;) {
				struct vrpn_header h;
				size_t total;
				enum vrpn_split_rc rc = vrpn_split(v->in + pos, v->in_len - pos, &h, &total);

				if (rc == VRPN_SPLIT_MORE)
					break;
				if (rc == VRPN_SPLIT_BAD) {
					/* a stream that lost its framing cannot find it again: start over */
					ctr_add(&v->dev.t->st.malformed, 1);
					snprintf(why, wlen, "a message of length %u: not VRPN", h.len);
					return;
				}
				device_feed(&v->dev, v->in + pos, total);
				atomic_fetch_add_explicit(&v->tcp_msgs, 1, memory_order_relaxed);
				pos += total;
			}
			memmove(v->in, v->in + pos, v->in_len - pos);
			v->in_len -= pos;
		}
		if (v->ufd >= 0 && p[1].revents) {
			for (int k = 0; k < VIN_UDP_BATCH; k++) {
				struct sockaddr_storage from;
				socklen_t fl = sizeof(from);
				ssize_t n = recvfrom(v->ufd, dgram, sizeof(dgram), MSG_DONTWAIT,
						     (struct sockaddr *)&from, &fl);
				bool same;

				if (n < 0)
					break;
				/* from the server's address (any port): nobody else's datagrams are reports */
				same = from.ss_family == v->server.ss_family &&
				       (from.ss_family == AF_INET6
						? !memcmp(&((struct sockaddr_in6 *)&from)->sin6_addr,
							  &((struct sockaddr_in6 *)&v->server)->sin6_addr, 16)
						: ((struct sockaddr_in *)&from)->sin_addr.s_addr ==
							  ((struct sockaddr_in *)&v->server)->sin_addr.s_addr);
				if (!same) {
					ctr_add(&v->dev.t->st.malformed, 1);
					continue;
				}
				v->last_rx = mono_ns();
				vin_datagram(v, dgram, (size_t)n);
			}
		}
		now = mono_ns();
		if (now - v->last_rx > timeout) {
			atomic_fetch_add_explicit(&v->stalls, 1, memory_order_relaxed);
			snprintf(why, wlen, "nothing from the server for %.0f ms", cfg->timeout_ms);
			return;
		}
		if (named_by && now > named_by) {
			const struct vrpn_in_codec_st *c = v->dev.codec_st;

			named_by = 0;
			if (c->sender < 0) {
				snprintf(why, wlen, "the server has no device '%s' (it described: %s)", v->name,
					 c->devices[0] ? c->devices : "none");
				return;
			}
		}
		if (now >= next_ping) {
			uint8_t ping[VRPN_HEADER_LEN];

			/* our device's ping (our ids 0): the server's pong says it is alive when its device is quiet */
			vrpn_msg_header(ping, 0, 0, real_ns(), 0);
			if (send(v->fd, ping, sizeof(ping), MSG_DONTWAIT | MSG_NOSIGNAL) < 0 && errno != EAGAIN &&
			    errno != EWOULDBLOCK) {
				snprintf(why, wlen, "%s", strerror(errno));
				return;
			}
			next_ping = now + ping_every;
		}
		{
			const struct vrpn_in_codec_st *c = v->dev.codec_st;

			atomic_store_explicit(&v->offset_us, c->tm.have ? c->tm.offset / 1000 : 0,
					      memory_order_relaxed);
		}
	}
}

static void vin_run(struct device *d)
{
	struct vrpn_in *v = d->drv;
	const struct vrpn_in_opts *cfg = opts_of(d->t->cfg);
	int backoff = VIN_BACKOFF_MIN_MS;
	uint64_t reports;
	bool quiet = false; /* the last connection brought no report: its "connected" was said */
	char why[512], last_why[512] = "";

	while (!device_stopping(d)) {
		int rc;

		device_set_link(d, DEVICE_DOWN);
		why[0] = '\0';
		rc = vin_resolve(v, why, sizeof(why));
		if (!rc)
			rc = v->tcp ? vin_connect_tcp(v, why, sizeof(why)) : vin_connect_lob(v, why, sizeof(why));
		if (!rc)
			rc = vin_handshake(v, cfg, why, sizeof(why));
		if (rc) {
			vin_close_conn(v);
			if (device_stopping(d))
				break;
			device_set_status(d, "no connection to %s: %s; trying again every %d ms", cfg->dev.device, why,
					  backoff);
			if (strcmp(why, last_why))
				device_note(d, LOG_WARNING, "[source %s] VRPN %s: %s; trying again", d->t->name,
					    cfg->dev.device, why);
			snprintf(last_why, sizeof(last_why), "%s", why);
			device_sleep_ms(d, backoff);
			backoff = backoff * 2 > VIN_BACKOFF_MAX_MS ? VIN_BACKOFF_MAX_MS : backoff * 2;
			continue;
		}
		d->codec->reset(d->codec_st);
		atomic_fetch_add_explicit(&v->connects, 1, memory_order_relaxed);
		if (v->ever_up)
			ctr_add(&d->t->st.reconnects, 1);
		v->ever_up = true;
		device_set_link(d, DEVICE_UP);
		device_set_status(d, "VRPN %s: connected (%s%s)", cfg->dev.device,
				  v->tcp ? "we connected" : "called back",
				  v->ufd >= 0 ? ", reports over UDP" : ", everything over TCP");
		if (!quiet)
			device_note(d, LOG_INFO, "[source %s] VRPN %s: connected%s", d->t->name, cfg->dev.device,
				    v->ufd >= 0 ? " (reports over UDP)" : "");
		reports = ((const struct vrpn_in_codec_st *)d->codec_st)->c.reports;
		vin_stream(v, cfg, why, sizeof(why));
		device_set_link(d, DEVICE_DOWN);
		vin_close_conn(v);
		if (device_stopping(d))
			break;
		/* said once while it stays the same; a connection that brought nothing is retried less often */
		if (strcmp(why, last_why))
			device_note(d, LOG_WARNING, "[source %s] VRPN %s: %s; connecting again", d->t->name,
				    cfg->dev.device, why);
		device_set_status(d, "VRPN %s: %s; connecting again", cfg->dev.device, why);
		snprintf(last_why, sizeof(last_why), "%s", why);
		quiet = ((const struct vrpn_in_codec_st *)d->codec_st)->c.reports == reports;
		if (!quiet)
			backoff = VIN_BACKOFF_MIN_MS;
		device_sleep_ms(d, backoff);
		backoff = backoff * 2 > VIN_BACKOFF_MAX_MS ? VIN_BACKOFF_MAX_MS : backoff * 2;
	}
	vin_close_conn(v);
}

/* ---- the driver ------------------------------------------------------------------------ */

static int vin_sensor_count(const struct cfg_source *cfg)
{
	return opts_of(cfg)->sensors;
}

static void vin_sensor_name(const struct cfg_source *cfg, int i, char *buf, size_t len)
{
	char key[32];
	const char *v;

	snprintf(key, sizeof(key), "sensor.%d", i);
	v = chan_value(opts_of(cfg)->names, CHAN_MAX, key);
	if (v)
		snprintf(buf, len, "%s", v);
	else
		snprintf(buf, len, "%d", i);
}

/* "cave/3" is channel 3 whatever sensor.3 named it */
static int vin_sensor_alias(const struct cfg_source *cfg, const char *name)
{
	char *end;
	long n = strtol(name, &end, 10);

	return isdigit((unsigned char)name[0]) && !*end && n < opts_of(cfg)->sensors ? (int)n : -1;
}

static int vin_check(const struct config *c, const void *section, const char **key, char *err, size_t errlen)
{
	const struct cfg_source *cfg = section;
	const struct vrpn_in_opts *o = opts_of(cfg);
	char name[VRPN_NAME_MAX], host[256];
	int port;
	bool tcp;

	*key = "device";
	if (vrpn_in_parse_device(o->dev.device, name, sizeof(name), host, sizeof(host), &port, &tcp)) {
		snprintf(err, errlen,
			 "'%s' is not NAME@host[:port] or NAME@tcp://host[:port] (a name of at most %d characters)",
			 o->dev.device, VRPN_DEVICE_MAX);
		return -1;
	}
	if (chan_check(cfg, o->names, CHAN_MAX, o->sensors, -1, 0, key, err, errlen) ||
	    chan_check(cfg, o->buttons, CHAN_MAX, o->sensors, -1, 32, key, err, errlen) ||
	    chan_check(cfg, o->analog, CHAN_MAX, o->sensors, -1, SENSOR_ANALOG_MAX, key, err, errlen))
		return -1;
	return device_check(c, section, key, err, errlen);
}

static int vin_open(struct tracker *t, char *err, size_t errlen)
{
	int rc = device_drv_open(t, sizeof(struct vrpn_in), &vrpn_in_codec, t->n_sensors, err, errlen);
	struct vrpn_in *v = t->priv;

	if (rc)
		return rc;
	v->fd = v->ufd = -1;
	if (vrpn_in_parse_device(opts_of(t->cfg)->dev.device, v->name, sizeof(v->name), v->host, sizeof(v->host),
				 &v->port, &v->tcp)) {
		snprintf(err, errlen, "[source %s] device: '%s' is not NAME@host[:port]", t->cfg->name,
			 opts_of(t->cfg)->dev.device);
		device_drv_close(t);
		return -EINVAL;
	}
	return device_drv_start(t, vin_run, "agw-vrpn", err, errlen);
}

_Static_assert(offsetof(struct vrpn_in, dev) == 0, "struct vrpn_in begins with its struct device");

static void vin_report(struct tracker *t, FILE *out, bool json)
{
	struct vrpn_in *v = t->priv;
	unsigned long long tcp, udp, con, stalls;
	long long off;

	if (!v)
		return;
	tcp = atomic_load_explicit(&v->tcp_msgs, memory_order_relaxed);
	udp = atomic_load_explicit(&v->udp_msgs, memory_order_relaxed);
	con = atomic_load_explicit(&v->connects, memory_order_relaxed);
	stalls = atomic_load_explicit(&v->stalls, memory_order_relaxed);
	off = (long long)atomic_load_explicit(&v->offset_us, memory_order_relaxed);
	if (json)
		fprintf(out,
			",\"tcp_messages\":%llu,\"udp_messages\":%llu,\"connects\":%llu,\"stalls\":%llu,"
			"\"clock_offset_us\":%lld",
			tcp, udp, con, stalls, off);
	else
		fprintf(out, "messages %llu TCP, %llu UDP; connected %llu times, %llu stalls; server clock %+lld us",
			tcp, udp, con, stalls, -off);
}

static const struct cfg_key vrpn_in_keys[] = {
	{ .name = "device",
	  .kind = CFG_STR,
	  CFG_AT(struct vrpn_in_opts, dev.device),
	  .doc = "the VRPN device: NAME@host[:port] (the server calls back over TCP, as VRPN clients ask) or "
		 "NAME@tcp://host[:port] (we connect to it); port 3883 when not given",
	  .missing = "the VRPN device to read, NAME@host[:port]" },
	{ .name = "udp",
	  .kind = CFG_BOOL,
	  CFG_AT(struct vrpn_in_opts, udp),
	  .def = "yes",
	  .doc = "ask the server to send the tracker and analog reports over UDP (VRPN's low-latency path); no: "
		 "everything over the TCP connection (firewalls)" },
	{ .name = "sensors",
	  .kind = CFG_INT,
	  CFG_AT(struct vrpn_in_opts, sensors),
	  .min = 1,
	  .max = CHAN_MAX,
	  .def = "8",
	  .doc = "channels taken, 0 to N-1: sensors named by their number (SOURCE/0, ...) unless sensor.N names "
		 "them; reports of other channels are counted and dropped" },
	{ .name = "sensor.N",
	  .kind = CFG_PER,
	  CFG_AT(struct vrpn_in_opts, names),
	  .max = CHAN_MAX,
	  .def = "",
	  .doc = "a name for channel N: sensor.0 = glasses makes SOURCE/glasses (SOURCE/0 still works); one key "
		 "per channel" },
	{ .name = "buttons.N",
	  .kind = CFG_PER,
	  CFG_AT(struct vrpn_in_opts, buttons),
	  .max = CHAN_MAX,
	  .def = "",
	  .doc = "FIRST [COUNT]: the device's vrpn_Button buttons FIRST to FIRST+COUNT-1 (COUNT 1 to 32, default "
		 "32) are channel N's buttons (a Flystick's); one key per channel" },
	{ .name = "analog.N",
	  .kind = CFG_PER,
	  CFG_AT(struct vrpn_in_opts, analog),
	  .max = CHAN_MAX,
	  .def = "",
	  .doc = "FIRST [COUNT]: the device's vrpn_Analog channels FIRST to FIRST+COUNT-1 (COUNT 1 to 4, default "
		 "4) are channel N's analog values (a joystick's x and y); one key per channel" },
	{ .name = "timeout_ms",
	  .kind = CFG_DOUBLE,
	  CFG_AT(struct vrpn_in_opts, timeout_ms),
	  .min = 50,
	  .max = 60000,
	  .def = "500",
	  .unit = "ms",
	  .doc = "nothing from the server (no report, no answer to the pings we send four times as often) for "
		 "this long: the source is FAULTY and connects again" },
};

const struct tracker_driver vrpn_in_driver = {
	.type = { CFG_TYPE("vrpn", "a VRPN server's tracker, with its buttons and analog values (NAME@host)",
			   vrpn_in_keys, struct vrpn_in_opts),
		  DEVICE_CAPTURE_KEYS, .check = vin_check, .sensor_count = vin_sensor_count,
		  .sensor_name = vin_sensor_name, .sensor_alias = vin_sensor_alias },
	.open = vin_open,
	.close = device_drv_close,
	.poll = device_drv_poll,
	.fd = device_drv_fd,
	.report = vin_report,
	.status = device_drv_status,
	.note = device_drv_note,
};
