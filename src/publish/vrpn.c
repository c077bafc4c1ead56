// SPDX-License-Identifier: MIT
/*
 * vrpn.c - a VRPN server (docs/VRPN.md): every avatar is one VRPN device,
 * Avatar0@host by default, that is a tracker (segment and sensor poses), an
 * analog (joint angles, then the trackers' analog values) and a button
 * device (the trackers' buttons) at once, as VRPN's own multi-class devices
 * are.
 *
 * It runs in the loop's send() and service(): plain non-blocking sockets,
 * buffers allocated at open(), nothing that can wait. Each message is
 * encoded once per avatar and cycle and copied to every client, because
 * VRPN's sender and type ids are the sender's own: each client maps our
 * ids to its own through the descriptions we send after the handshake.
 *
 * Two ways in, as in VRPN: a client that names "tcp://host" connects to
 * our TCP port; a plain "Avatar0@host" client sends a UDP datagram
 * "<its address> <its port>" to our port, and we connect back to it over
 * TCP. Either way both sides send a 24-byte cookie, then messages. A
 * client that offers a UDP port gets the tracker and analog reports (VRPN's
 * low-latency class) as UDP datagrams from our port; the rest (descriptions,
 * pongs, buttons) goes over TCP.
 *
 * A client is dropped, without disturbing the others, when it closes, when
 * it sends something that is not VRPN (a bad cookie, a length no VRPN peer
 * writes, a broken description), when its handshake takes longer than
 * client_timeout, or when its buffer has been dropping messages for that
 * long. Reports that do not fit a client's buffer are dropped whole and
 * counted; a button change that does not fit makes the full button state
 * go again once there is room, so a client never misses a release.
 */
#include "publish/output.h"
#include "publish/vrpn.h"
#include "base/clock.h"
#include "publish/listen.h"

#include "avatargw/wire.h"
#include "wire/vrpn_proto.h"

#include <arpa/inet.h>
#include <ctype.h>
#include <endian.h>
#include <errno.h>
#include <math.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

static const struct cfg_key vrpn_keys[] = {
	{ .name = "address",
	  .kind = CFG_STR,
	  CFG_AT(struct vrpn_opts, address),
	  .def = "127.0.0.1",
	  .doc = "listen address for TCP connections and UDP connection requests (0.0.0.0: every IPv4 interface, "
		 "::: every interface; the default serves this host only)" },
	{ .name = "port",
	  .kind = CFG_INT,
	  CFG_AT(struct vrpn_opts, port),
	  .min = 1,
	  .max = 65535,
	  .def = "3883",
	  .doc = "TCP and UDP port of the VRPN server (clients name it as NAME@host:port when it is not 3883)" },
	{ .name = "max_clients",
	  .kind = CFG_INT,
	  CFG_AT(struct vrpn_opts, max_clients),
	  .min = 1,
	  .max = 256,
	  .def = "8",
	  .doc = "clients at most; when all are taken, a new one takes the slot of the one that has sent nothing the "
		 "longest (a second at least), else it is refused" },
	{ .name = "clients_per_address",
	  .kind = CFG_INT,
	  CFG_AT(struct vrpn_opts, clients_per_address),
	  .min = 0,
	  .max = 256,
	  .def = "4",
	  .doc = "clients at most from one host (IP address); a further one takes the slot of that host's client idle "
		 "the longest, else it is refused; 0: no limit but max_clients" },
	{ .name = "client_buffer",
	  .kind = CFG_INT,
	  CFG_AT(struct vrpn_opts, client_buffer),
	  .min = 4096,
	  .max = 16777216,
	  .def = "65536",
	  .unit = "bytes",
	  .doc = "per-subscriber buffer; messages that do not fit are dropped and counted" },
	{ .name = "device",
	  .kind = CFG_STR,
	  CFG_AT(struct vrpn_opts, device),
	  .def = "Avatar%d",
	  .doc = "VRPN device name of each avatar, %d = its id: clients open Avatar0@host (tracker, analog and "
		 "button)" },
	{ .name = "udp",
	  .kind = CFG_BOOL,
	  CFG_AT(struct vrpn_opts, udp),
	  .def = "yes",
	  .doc = "tracker and analog reports over UDP to clients that offer a UDP port (VRPN's low-latency "
		 "class); no: all over TCP" },
	{ .name = "client_timeout",
	  .kind = CFG_DOUBLE,
	  CFG_AT(struct vrpn_opts, client_timeout),
	  .min = 0.1,
	  .max = 3600,
	  .def = "5",
	  .unit = "s",
	  .doc = "a client that has not finished its handshake, or whose buffer stays full, this long is dropped" },
};

static const struct vrpn_opts *opts_of(const struct cfg_output *c)
{
	return c->opt;
}

/* our type ids, announced to every client */
enum { T_POS_QUAT, T_ANALOG, T_BUTTON_CHANGE, T_BUTTON_STATES, T_PONG, T_PING, T_COUNT };
static const char *const vrpn_types[T_COUNT] = {
	VRPN_T_POS_QUAT, VRPN_T_ANALOG, VRPN_T_BUTTON_CHANGE, VRPN_T_BUTTON_STATES, VRPN_T_PONG, VRPN_T_PING,
};

/* what a device carries (docs/VRPN.md) */
#define VRPN_SENSORS (WIRE_SEGMENTS + WIRE_SENSORS) /* segments 0-9, then the raw sensors 10-12 */
#define VRPN_CHANNELS (WIRE_JOINTS + FRAME_SENSORS * SENSOR_ANALOG_MAX)
#define VRPN_BUTTONS (FRAME_SENSORS * 32)

#define POS_QUAT_LEN VRPN_POS_QUAT_LEN
#define ANALOG_LEN (8 * (1 + VRPN_CHANNELS))
#define STATES_LEN (4 * (1 + VRPN_BUTTONS))
/* one avatar's reports of one cycle: low-latency part, then the reliable button changes */
#define MSG_LEN(payload) VRPN_MSG_LEN(payload)
#define LOW_MAX (VRPN_SENSORS * MSG_LEN(POS_QUAT_LEN) + MSG_LEN(ANALOG_LEN))
#define REL_MAX (VRPN_BUTTONS * MSG_LEN(8))

#define IN_BUF 4096	   /* longer client messages are skipped, not kept */
#define REMOTE_SENDERS 256 /* client sender ids we remember (its devices that are ours) */

enum vcl_state { VC_FREE, VC_CONNECTING, VC_COOKIE, VC_DESCRIBING, VC_LIVE };

struct vcl {
	int fd;
	enum vcl_state state;
	uint64_t since_ns;    /* entered this state */
	struct out_peer host; /* its host; active_ns: when it last sent us something (or connected) */
	uint64_t dropping_ns; /* first message dropped since the buffer was last empty, 0 none */
	struct sockaddr_storage peer;
	socklen_t peer_len;
	struct sockaddr_storage udp_to; /* where its low-latency reports go, when udp */
	bool udp;
	uint8_t *out; /* TCP bytes waiting, buf_size */
	size_t off, len;
	uint8_t in[IN_BUF];
	size_t in_len;
	size_t skip;	   /* bytes of an overlong message still to discard */
	int desc_next;	   /* descriptions sent: our types, then one per avatar */
	int32_t ping_type; /* its id of "vrpn_Base ping_message", -1 unknown */
	int states_next;   /* the next device whose states go again, -1: none due */
	int n_remote;
	struct vremote {
		int32_t remote, avatar;
	} remote[REMOTE_SENDERS];
};

/* the devices of one configuration: the names and button memory per avatar index */
struct vmap {
	const struct output *owner;
	int n;
	bool *wants;
	char (*name)[VRPN_NAME_MAX];
	uint32_t (*buttons)[FRAME_SENSORS];
	bool *buttons_known;
};

struct vrpn {
	int lfd, ufd;
	int family;
	char key[CFG_PATH_MAX + 32]; /* what adopt() compares */
	int max_clients, per_addr;
	size_t buf_size;
	bool udp;
	uint64_t timeout_ns;
	struct vcl *cl;
	uint8_t *pool;
	/* a reload builds the new configuration's devices beside the running ones (two owners) */
	struct vmap map[2];
	int active;
	bool same_names; /* the other map names the same devices: keep the clients */
	/* one cycle's encoded reports of one avatar */
	uint8_t low[LOW_MAX];
	uint8_t rel[REL_MAX];
	uint8_t dgram[VRPN_UDP_MAX];
};

/* ---- encoding: big-endian, 8-byte aligned (wire/vrpn_proto.h) --------------------------- */

static size_t msg_states(uint8_t *p, int32_t sender, const uint32_t buttons[FRAME_SENSORS], uint64_t t_ns)
{
	uint8_t *q = vrpn_msg_header(p, T_BUTTON_STATES, sender, t_ns, STATES_LEN);

	vrpn_put32(q, VRPN_BUTTONS);
	for (int b = 0; b < VRPN_BUTTONS; b++)
		vrpn_put32(q + 4 + 4 * b, (buttons[b / 32] >> (b % 32)) & 1u);
	return MSG_LEN(STATES_LEN);
}

/* the tracker and analog reports of one frame; returns their length */
static size_t encode_low(uint8_t *p, int32_t sender, const struct wire_frame *f)
{
	uint64_t t = f->h.sample_time_ns ? f->h.sample_time_ns : real_ns();
	size_t n = 0;
	bool joints = true;

	for (int s = 0; s < VRPN_SENSORS; s++) {
		const struct wire_pose *pose = s < WIRE_SEGMENTS ? &f->segment[s] : &f->sensor[s - WIRE_SEGMENTS].pose;
		uint8_t *q;

		/* an unknown pose is not sent: VRPN has no way to say unknown, and NaN is never published */
		if (!wire_pose_finite(pose))
			continue;
		q = vrpn_msg_header(p + n, T_POS_QUAT, sender, t, POS_QUAT_LEN);
		vrpn_put32(q, (uint32_t)s);
		vrpn_put32(q + 4, 0);
		for (int i = 0; i < 3; i++)
			vrpn_put_f64(q + 8 + 8 * i, pose->p[i]);
		/* VRPN stores x, y, z, w; the wire stores w, x, y, z */
		for (int i = 0; i < 4; i++)
			vrpn_put_f64(q + 32 + 8 * i, pose->q[(i + 1) % 4]);
		n += MSG_LEN(POS_QUAT_LEN);
	}
	for (int j = 0; j < WIRE_JOINTS; j++)
		joints &= isfinite(f->joint[j]) != 0;
	if (joints) {
		uint8_t *q = vrpn_msg_header(p + n, T_ANALOG, sender, t, ANALOG_LEN);

		vrpn_put_f64(q, VRPN_CHANNELS);
		for (int j = 0; j < WIRE_JOINTS; j++)
			vrpn_put_f64(q + 8 + 8 * j, f->joint[j]);
		for (int s = 0; s < FRAME_SENSORS; s++)
			for (int i = 0; i < SENSOR_ANALOG_MAX; i++) {
				float v = f->in.analog[s][i];

				vrpn_put_f64(q + 8 + 8 * (WIRE_JOINTS + s * SENSOR_ANALOG_MAX + i),
					     isfinite(v) ? v : 0.0);
			}
		n += MSG_LEN(ANALOG_LEN);
	}
	return n;
}

/* ---- devices ------------------------------------------------------------------------- */

static void map_free(struct vmap *m)
{
	free(m->wants);
	free(m->name);
	free(m->buttons);
	free(m->buttons_known);
	memset(m, 0, sizeof(*m));
}

/* "Avatar%d" with the id; %% is a percent sign. Returns 0 or -EINVAL with why. */
static int device_name(const char *pattern, unsigned id, char *out, size_t len, const char **why)
{
	size_t n = 0;

	for (const char *s = pattern; *s; s++) {
		char num[16];
		const char *add = num;

		if (*s != '%') {
			num[0] = *s;
			num[1] = '\0';
		} else if (s[1] == 'd') {
			snprintf(num, sizeof(num), "%u", id);
			s++;
		} else if (s[1] == '%') {
			strcpy(num, "%");
			s++;
		} else {
			*why = "only %d (the avatar id) and %% may follow a %";
			return -EINVAL;
		}
		for (; *add; add++) {
			if (n + 1 >= len) {
				*why = "a device name is longer than the 95 characters VRPN takes";
				return -EINVAL;
			}
			out[n++] = *add;
		}
	}
	out[n] = '\0';
	if (!n) {
		*why = "empty";
		return -EINVAL;
	}
	return 0;
}

static int map_build(struct vmap *m, const struct output *o, char *err, size_t errlen)
{
	const char *why = NULL;

	memset(m, 0, sizeof(*m));
	m->owner = o;
	m->n = o->n_avatars;
	m->wants = calloc((size_t)m->n + 1, sizeof(*m->wants));
	m->name = calloc((size_t)m->n + 1, sizeof(*m->name));
	m->buttons = calloc((size_t)m->n + 1, sizeof(*m->buttons));
	m->buttons_known = calloc((size_t)m->n + 1, sizeof(*m->buttons_known));
	if (!m->wants || !m->name || !m->buttons || !m->buttons_known) {
		map_free(m);
		snprintf(err, errlen, "[output %s]: out of memory", o->name);
		return -ENOMEM;
	}
	for (int i = 0; i < m->n; i++) {
		m->wants[i] = o->wants[i];
		if (device_name(opts_of(o->cfg)->device, o->ids[i], m->name[i], VRPN_DEVICE_MAX + 1, &why)) {
			snprintf(err, errlen, "[output %s] device: '%s': %s", o->name, opts_of(o->cfg)->device, why);
			map_free(m);
			return -EINVAL;
		}
		for (int j = 0; j < i; j++)
			if (m->wants[j] && m->wants[i] && !strcmp(m->name[i], m->name[j])) {
				snprintf(err, errlen,
					 "[output %s] device: '%s' names two avatars (ids %u and %u): put %%d in it",
					 o->name, m->name[i], o->ids[j], o->ids[i]);
				map_free(m);
				return -EINVAL;
			}
	}
	return 0;
}

static bool maps_name_alike(const struct vmap *a, const struct vmap *b)
{
	if (a->n != b->n)
		return false;
	for (int i = 0; i < a->n; i++)
		if (a->wants[i] != b->wants[i] || (a->wants[i] && strcmp(a->name[i], b->name[i])))
			return false;
	return true;
}

/* ---- clients ------------------------------------------------------------------------- */

static void vcl_drop(struct output *o, struct vcl *c, bool malformed)
{
	close(c->fd);
	c->fd = -1;
	c->state = VC_FREE;
	ctr_add(malformed ? &o->st.malformed : &o->st.closed, 1);
	atomic_store_explicit(&o->st.clients, atomic_load_explicit(&o->st.clients, memory_order_relaxed) - 1,
			      memory_order_relaxed);
}

static void vcl_start(struct vcl *c, int fd, enum vcl_state st, uint64_t now)
{
	c->fd = fd;
	c->state = st;
	c->since_ns = now;
	c->host.active_ns = now;
	c->dropping_ns = 0;
	c->udp = false;
	c->off = c->len = 0;
	c->in_len = 0;
	c->skip = 0;
	c->desc_next = 0;
	c->states_next = -1;
	c->ping_type = -1;
	c->n_remote = 0;
}

/* room for n more bytes at the end of the buffer (compacting it if that makes room) */
static uint8_t *vcl_room(struct vrpn *v, struct vcl *c, size_t n)
{
	if (c->off + c->len + n > v->buf_size && c->off) {
		memmove(c->out, c->out + c->off, c->len);
		c->off = 0;
	}
	if (c->len + n > v->buf_size)
		return NULL;
	return c->out + c->off + c->len;
}

static void vcl_flush(struct output *o, struct vcl *c)
{
	if (out_send_pending(c->fd, c->out, &c->off, &c->len)) {
		vcl_drop(o, c, false);
		return;
	}
	if (!c->len)
		c->dropping_ns = 0;
}

static void vcl_dropped(struct output *o, struct vcl *c, uint64_t now)
{
	ctr_add(&o->st.dropped, 1);
	if (!c->dropping_ns)
		c->dropping_ns = now;
}

static int remote_avatar(const struct vcl *c, int32_t remote)
{
	for (int i = 0; i < c->n_remote; i++)
		if (c->remote[i].remote == remote)
			return c->remote[i].avatar;
	return -1;
}

static void remote_set(struct vcl *c, int32_t remote, int avatar)
{
	for (int i = 0; i < c->n_remote; i++)
		if (c->remote[i].remote == remote) {
			if (avatar >= 0) {
				c->remote[i].avatar = avatar;
			} else {
				c->remote[i] = c->remote[c->n_remote - 1];
				c->n_remote--;
			}
			return;
		}
	if (avatar >= 0 && c->n_remote < REMOTE_SENDERS)
		c->remote[c->n_remote++] = (struct vremote){ remote, avatar };
}

/* a ping from one of its devices: pong, and the buttons' states (what VRPN's servers do) */
static void vcl_ping(struct vrpn *v, struct vcl *c, const struct vmap *m, int avatar)
{
	uint8_t *p = vcl_room(v, c, MSG_LEN(0) + MSG_LEN(STATES_LEN));
	uint64_t t = real_ns();

	if (!p)
		return; /* it pings again in a second */
	vrpn_msg_header(p, T_PONG, avatar, t, 0);
	c->len += MSG_LEN(0);
	c->len += msg_states(p + MSG_LEN(0), avatar, m->buttons[avatar], t);
}

/* its device a has been described to it (pongs and button changes may go) */
static bool vcl_knows(const struct vcl *c, int a)
{
	return c->state == VC_LIVE || (c->state == VC_DESCRIBING && c->desc_next > T_COUNT + a);
}

/* one message from a client; false: it is not speaking VRPN */
static bool vcl_dispatch(struct vrpn *v, struct vcl *c, const struct vmap *m, int32_t type, int32_t sender,
			 const uint8_t *pl, size_t plen)
{
	if (type == VRPN_SENDER_DESCRIPTION || type == VRPN_TYPE_DESCRIPTION) {
		char name[VRPN_NAME_MAX];

		if (sender < 0 || sender >= VRPN_ID_MAX || !vrpn_description_name(pl, plen, name))
			return false;
		if (type == VRPN_TYPE_DESCRIPTION) {
			if (!strcmp(name, vrpn_types[T_PING]))
				c->ping_type = sender;
			else if (c->ping_type == sender)
				c->ping_type = -1;
			return true;
		}
		{
			int found = -1;

			for (int i = 0; i < m->n && found < 0; i++)
				if (m->wants[i] && !strcmp(m->name[i], name))
					found = i;
			remote_set(c, sender, found);
		}
		return true;
	}
	if (type == VRPN_UDP_DESCRIPTION) {
		/* the sender field is its UDP port; we answer the address its TCP comes from */
		if (sender <= 0 || sender > 65535)
			return false;
		if (v->udp) {
			memcpy(&c->udp_to, &c->peer, sizeof(c->peer));
			if (c->udp_to.ss_family == AF_INET)
				((struct sockaddr_in *)&c->udp_to)->sin_port = htons((uint16_t)sender);
			else
				((struct sockaddr_in6 *)&c->udp_to)->sin6_port = htons((uint16_t)sender);
			c->udp = true;
		}
		return true;
	}
	if (type < 0)
		return true; /* log requests, disconnect markers: nothing a server must do */
	if (type == c->ping_type) {
		int a = remote_avatar(c, sender);

		if (a >= 0 && a < m->n && vcl_knows(c, a))
			vcl_ping(v, c, m, a);
	}
	return true; /* other messages (text, requests to the tracker) need no answer */
}

/* what it sent; false: drop it (closed, or malformed said by *bad) */
static bool vcl_read(struct vrpn *v, struct vcl *c, const struct vmap *m, uint64_t now, bool *bad)
{
	/* a bounded amount per cycle: a client that floods us cannot hold the loop */
	for (int reads = 0; reads < 8; reads++) {
		ssize_t n = recv(c->fd, c->in + c->in_len, sizeof(c->in) - c->in_len, MSG_DONTWAIT);
		size_t pos = 0;

		if (n == 0)
			return false;
		if (n < 0)
			return errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR;
		c->in_len += (size_t)n;
		c->host.active_ns = now;
		if (c->state == VC_COOKIE) {
			if (c->in_len < VRPN_COOKIE_LEN)
				continue;
			if (!vrpn_cookie_ok(c->in)) {
				*bad = true;
				return false;
			}
			pos = VRPN_COOKIE_LEN;
			c->state = VC_DESCRIBING;
			c->since_ns = now;
		}
		while (pos < c->in_len) {
			size_t avail = c->in_len - pos, len, total;
			const uint8_t *h = c->in + pos;

			if (c->skip) {
				size_t k = c->skip < avail ? c->skip : avail;

				c->skip -= k;
				pos += k;
				continue;
			}
			if (avail < VRPN_HEADER_LEN)
				break;
			len = vrpn_get32(h);
			if (len < VRPN_HEADER_LEN || len > VRPN_LONGEST) {
				*bad = true;
				return false;
			}
			total = MSG_LEN(len - VRPN_HEADER_LEN);
			if (total > sizeof(c->in)) {
				/* longer than anything we need to read: pass over it */
				c->skip = total;
				continue;
			}
			if (avail < total)
				break;
			if (!vcl_dispatch(v, c, m, (int32_t)vrpn_get32(h + 16), (int32_t)vrpn_get32(h + 12),
					  h + VRPN_HEADER_LEN, len - VRPN_HEADER_LEN)) {
				*bad = true;
				return false;
			}
			pos += total;
		}
		memmove(c->in, c->in + pos, c->in_len - pos);
		c->in_len -= pos;
	}
	return true;
}

/* descriptions, then each device's buttons: as many as fit now */
static void vcl_describe(struct vrpn *v, struct vcl *c, const struct vmap *m)
{
	uint64_t t = real_ns();

	while (c->desc_next < T_COUNT + m->n) {
		int k = c->desc_next;
		uint8_t *p;

		if (k < T_COUNT) {
			if (!(p = vcl_room(v, c, MSG_LEN(4 + VRPN_NAME_MAX))))
				return;
			c->len += vrpn_msg_description(p, VRPN_TYPE_DESCRIPTION, k, vrpn_types[k], t);
		} else if (m->wants[k - T_COUNT]) {
			int a = k - T_COUNT;

			if (!(p = vcl_room(v, c, MSG_LEN(4 + VRPN_NAME_MAX) + MSG_LEN(STATES_LEN))))
				return;
			c->len += vrpn_msg_description(p, VRPN_SENDER_DESCRIPTION, a, m->name[a], t);
			c->len += msg_states(c->out + c->off + c->len, a, m->buttons[a], t);
		}
		c->desc_next++;
	}
	c->state = VC_LIVE;
}

/* a button change did not fit earlier: the whole state of every device, as room allows */
static void vcl_states(struct vrpn *v, struct vcl *c, const struct vmap *m)
{
	uint64_t t = real_ns();

	for (; c->states_next < m->n; c->states_next++) {
		uint8_t *p;

		if (!m->wants[c->states_next])
			continue;
		if (!(p = vcl_room(v, c, MSG_LEN(STATES_LEN))))
			return;
		c->len += msg_states(p, c->states_next, m->buttons[c->states_next], t);
	}
	c->states_next = -1;
}

/* ---- the server ---------------------------------------------------------------------- */

static int vrpn_listen(struct vrpn *v, const struct cfg_output *cfg, char *err, size_t errlen)
{
	struct addrinfo hints = { .ai_flags = AI_NUMERICSERV | AI_PASSIVE }, *ai;
	char port[8];
	int one = 1, rc;

	snprintf(port, sizeof(port), "%d", opts_of(cfg)->port);
	hints.ai_socktype = SOCK_STREAM;
	rc = getaddrinfo(opts_of(cfg)->address[0] ? opts_of(cfg)->address : NULL, port, &hints, &ai);
	if (rc) {
		snprintf(err, errlen, "[output %s] address: %s: %s", cfg->name, opts_of(cfg)->address,
			 gai_strerror(rc));
		return -EINVAL;
	}
	v->family = ai->ai_family;
	v->lfd = socket(ai->ai_family, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
	v->ufd = socket(ai->ai_family, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
	if (v->lfd < 0 || v->ufd < 0 || setsockopt(v->lfd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof(one)) ||
	    bind(v->lfd, ai->ai_addr, ai->ai_addrlen) || listen(v->lfd, 16) ||
	    bind(v->ufd, ai->ai_addr, ai->ai_addrlen)) {
		rc = -errno;
		snprintf(err, errlen, "[output %s]: VRPN server on %s port %d (TCP and UDP): %s", cfg->name,
			 opts_of(cfg)->address, opts_of(cfg)->port, strerror(errno));
		freeaddrinfo(ai);
		return rc;
	}
	freeaddrinfo(ai);
	return 0;
}

static void vrpn_free(struct vrpn *v)
{
	for (int i = 0; v->cl && i < v->max_clients; i++)
		if (v->cl[i].fd >= 0)
			close(v->cl[i].fd);
	if (v->lfd >= 0)
		close(v->lfd);
	if (v->ufd >= 0)
		close(v->ufd);
	map_free(&v->map[0]);
	map_free(&v->map[1]);
	free(v->cl);
	free(v->pool);
	free(v);
}

static void describe_key(const struct cfg_output *cfg, char *buf, size_t len)
{
	snprintf(buf, len, "%s|%d|%d|%d|%d|%d|%.9g", opts_of(cfg)->address, opts_of(cfg)->port, opts_of(cfg)->udp,
		 opts_of(cfg)->max_clients, opts_of(cfg)->clients_per_address, opts_of(cfg)->client_buffer,
		 opts_of(cfg)->client_timeout);
}

static int vrpn_open(struct output *o, char *err, size_t errlen)
{
	const struct cfg_output *cfg = o->cfg;
	struct vrpn *v = calloc(1, sizeof(*v));
	int rc;

	if (!v)
		return -ENOMEM;
	v->lfd = v->ufd = -1;
	v->max_clients = opts_of(cfg)->max_clients;
	v->per_addr = opts_of(cfg)->clients_per_address;
	v->buf_size = (size_t)opts_of(cfg)->client_buffer;
	v->udp = opts_of(cfg)->udp;
	v->timeout_ns = (uint64_t)(opts_of(cfg)->client_timeout * 1e9);
	describe_key(cfg, v->key, sizeof(v->key));
	v->cl = calloc((size_t)v->max_clients, sizeof(*v->cl));
	v->pool = malloc((size_t)v->max_clients * v->buf_size);
	if (!v->cl || !v->pool) {
		vrpn_free(v);
		snprintf(err, errlen, "[output %s]: out of memory", cfg->name);
		return -ENOMEM;
	}
	for (int i = 0; i < v->max_clients; i++) {
		v->cl[i].fd = -1;
		v->cl[i].out = v->pool + (size_t)i * v->buf_size;
	}
	rc = map_build(&v->map[0], o, err, errlen);
	if (!rc)
		rc = vrpn_listen(v, cfg, err, errlen);
	if (rc) {
		vrpn_free(v);
		return rc;
	}
	o->priv = v;
	return 0;
}

static void vrpn_close(struct output *o)
{
	if (o->priv)
		vrpn_free(o->priv);
	o->priv = NULL;
}

/* this output's devices; the first cycle after a reload makes them the ones served */
static struct vmap *vrpn_map(struct output *o, struct vrpn *v)
{
	int k = v->map[v->active].owner == o ? v->active : 1 - v->active;

	if (k != v->active) {
		/* other devices: the clients reconnect and learn them (VRPN clients retry by themselves) */
		if (!v->same_names)
			for (int i = 0; i < v->max_clients; i++)
				if (v->cl[i].fd >= 0)
					vcl_drop(o, &v->cl[i], false);
		v->active = k;
	}
	return &v->map[k];
}

static bool vrpn_adopt(struct output *o, struct output *old)
{
	struct vrpn *v = old->priv;
	char key[sizeof(v->key)], err[256];
	int k;

	if (!v)
		return false;
	describe_key(o->cfg, key, sizeof(key));
	if (strcmp(key, v->key))
		return false;
	k = 1 - v->active;
	map_free(&v->map[k]);
	if (map_build(&v->map[k], o, err, sizeof(err)))
		return false; /* open() will say why */
	v->same_names = maps_name_alike(&v->map[k], &v->map[v->active]);
	o->priv = v;
	old->priv = NULL;
	atomic_store_explicit(&o->st.clients, atomic_load_explicit(&old->st.clients, memory_order_relaxed),
			      memory_order_relaxed);
	return true;
}

int vrpn_parse_request(const char *msg, char host[128], int *port)
{
	if (sscanf(msg, "%127s %d", host, port) != 2 || *port < 1024 || *port > 65535)
		return -1;
	for (const char *h = host; *h; h++)
		if (!isalnum((unsigned char)*h) && *h != '.' && *h != ':' && *h != '-')
			return -1;
	return 0;
}

/* a UDP datagram "<host> <port>": a client waiting for us to connect to it */
static void vrpn_lob(struct output *o, struct vrpn *v, const char *msg, const struct sockaddr_storage *from,
		     socklen_t from_len, uint64_t now)
{
	char host[128];
	int port = 0, fd, slot;
	struct sockaddr_storage to;
	bool drop;

	if (vrpn_parse_request(msg, host, &port)) {
		ctr_add(&o->st.malformed, 1);
		return;
	}
	/* connect to the address the request came from (as VRPN does: the client may have several) */
	memcpy(&to, from, sizeof(to));
	if (to.ss_family == AF_INET)
		((struct sockaddr_in *)&to)->sin_port = htons((uint16_t)port);
	else
		((struct sockaddr_in6 *)&to)->sin6_port = htons((uint16_t)port);
	for (int i = 0; i < v->max_clients; i++) {
		struct vcl *c = &v->cl[i];

		/* it lobs again every two seconds until called back: one call per client */
		if (c->fd >= 0 && c->peer_len == from_len && !memcmp(&c->peer, &to, from_len))
			return;
	}
	/* a free slot, or the one of the client idle the longest (this host's own when it has its share) */
	slot = out_slot_for(v->cl, sizeof(*v->cl), offsetof(struct vcl, fd), offsetof(struct vcl, host), v->max_clients,
			    &to, v->per_addr, now, &drop);
	if (slot < 0) {
		ctr_add(&o->st.refused, 1);
		return;
	}
	fd = socket(to.ss_family, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
	if (fd < 0) {
		ctr_add(&o->st.errors, 1);
		atomic_store_explicit(&o->st.last_errno, errno, memory_order_relaxed);
		return;
	}
	if (connect(fd, (struct sockaddr *)&to, from_len) && errno != EINPROGRESS) {
		close(fd);
		ctr_add(&o->st.errors, 1);
		atomic_store_explicit(&o->st.last_errno, errno, memory_order_relaxed);
		return;
	}
	if (drop)
		vcl_drop(o, &v->cl[slot], false);
	vcl_start(&v->cl[slot], fd, VC_CONNECTING, now);
	memcpy(&v->cl[slot].peer, &to, sizeof(to));
	v->cl[slot].peer_len = from_len;
	v->cl[slot].host.addr = to;
	ctr_add(&o->st.clients, 1);
}

static void vcl_connected(struct output *o, struct vrpn *v, struct vcl *c, uint64_t now)
{
	int one = 1, sndbuf = (int)v->buf_size;
	uint8_t *p = vcl_room(v, c, VRPN_COOKIE_LEN);

	setsockopt(c->fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof(one));
	/* a small kernel queue: a slow reader gets recent reports, not seconds-old ones */
	setsockopt(c->fd, SOL_SOCKET, SO_SNDBUF, &sndbuf, sizeof(sndbuf));
	vrpn_cookie(p);
	c->len += VRPN_COOKIE_LEN;
	c->state = VC_COOKIE;
	c->since_ns = now;
	ctr_add(&o->st.accepted, 1);
	vcl_flush(o, c);
}

static void vrpn_service(struct output *o)
{
	struct vrpn *v = o->priv;
	struct vmap *m = vrpn_map(o, v);
	uint64_t now = mono_ns();

	/* clients that connect to us (a bounded number per cycle: a flood cannot hold the loop) */
	for (int k = 0; k < 16; k++) {
		struct sockaddr_storage peer;
		socklen_t pl = sizeof(peer);
		int fd = accept4(v->lfd, (struct sockaddr *)&peer, &pl, SOCK_NONBLOCK | SOCK_CLOEXEC), slot;
		bool drop;

		if (fd < 0)
			break;
		/* a free slot, or the one of the client idle the longest (this host's own when it has its share) */
		slot = out_slot_for(v->cl, sizeof(*v->cl), offsetof(struct vcl, fd), offsetof(struct vcl, host),
				    v->max_clients, &peer, v->per_addr, now, &drop);
		if (slot < 0) {
			close(fd);
			ctr_add(&o->st.refused, 1);
			continue;
		}
		if (drop)
			vcl_drop(o, &v->cl[slot], false);
		vcl_start(&v->cl[slot], fd, VC_CONNECTING, now);
		memcpy(&v->cl[slot].peer, &peer, sizeof(peer));
		v->cl[slot].peer_len = pl;
		v->cl[slot].host.addr = peer;
		ctr_add(&o->st.clients, 1);
		vcl_connected(o, v, &v->cl[slot], now);
	}
	/* clients that ask us to connect to them */
	for (int k = 0; k < 16; k++) {
		char msg[201];
		struct sockaddr_storage from;
		socklen_t fl = sizeof(from);
		ssize_t n = recvfrom(v->ufd, msg, sizeof(msg) - 1, MSG_DONTWAIT, (struct sockaddr *)&from, &fl);

		if (n < 0)
			break;
		msg[n] = '\0';
		vrpn_lob(o, v, msg, &from, fl, now);
	}
	for (int i = 0; i < v->max_clients; i++) {
		struct vcl *c = &v->cl[i];
		bool bad = false;

		if (c->fd < 0)
			continue;
		if (c->state == VC_CONNECTING) {
			struct pollfd p = { c->fd, POLLOUT, 0 };
			int e = 0;
			socklen_t el = sizeof(e);

			if (poll(&p, 1, 0) == 1) {
				getsockopt(c->fd, SOL_SOCKET, SO_ERROR, &e, &el);
				if (e) {
					vcl_drop(o, c, false);
					continue;
				}
				vcl_connected(o, v, c, now);
				if (c->fd < 0)
					continue;
			}
		}
		if (c->state >= VC_COOKIE && !vcl_read(v, c, m, now, &bad)) {
			vcl_drop(o, c, bad);
			continue;
		}
		if (c->state < VC_LIVE && now - c->since_ns > v->timeout_ns) {
			vcl_drop(o, c, false); /* a handshake that does not finish */
			continue;
		}
		if (c->dropping_ns && now - c->dropping_ns > v->timeout_ns) {
			vcl_drop(o, c, false); /* stalled: its buffer has been full for too long */
			continue;
		}
		if (c->state == VC_DESCRIBING)
			vcl_describe(v, c, m);
		if (c->state == VC_LIVE && c->states_next >= 0)
			vcl_states(v, c, m);
		vcl_flush(o, c);
	}
}

/* the changes of one avatar's buttons since the previous frame, as Change messages */
static size_t encode_buttons(uint8_t *p, struct vmap *m, int a, const struct wire_inputs *in, uint64_t t_ns)
{
	size_t n = 0;

	for (int s = 0; s < FRAME_SENSORS; s++) {
		uint32_t was = m->buttons_known[a] ? m->buttons[a][s] : 0, now = in->buttons[s], diff = was ^ now;

		for (int b = 0; diff && b < 32; b++) {
			uint8_t *q;

			if (!(diff & (1u << b)))
				continue;
			q = vrpn_msg_header(p + n, T_BUTTON_CHANGE, a, t_ns, 8);
			vrpn_put32(q, (uint32_t)(s * 32 + b));
			vrpn_put32(q + 4, (now >> b) & 1u);
			n += MSG_LEN(8);
		}
		m->buttons[a][s] = now;
	}
	m->buttons_known[a] = true;
	return n;
}

static void vcl_udp_flush(struct output *o, struct vrpn *v, struct vcl *c, size_t *dlen)
{
	socklen_t tl = c->udp_to.ss_family == AF_INET ? sizeof(struct sockaddr_in) : sizeof(struct sockaddr_in6);

	if (!*dlen)
		return;
	if (sendto(v->ufd, v->dgram, *dlen, MSG_DONTWAIT, (struct sockaddr *)&c->udp_to, tl) < 0) {
		if (errno == EAGAIN || errno == EWOULDBLOCK || errno == ENOBUFS) {
			ctr_add(&o->st.dropped, 1);
		} else {
			ctr_add(&o->st.errors, 1);
			atomic_store_explicit(&o->st.last_errno, errno, memory_order_relaxed);
		}
	} else {
		ctr_add(&o->st.sent, 1);
	}
	*dlen = 0;
}

static void vrpn_send(struct output *o, const struct out_msg *msgs, int n)
{
	struct vrpn *v = o->priv;
	struct vmap *m = vrpn_map(o, v);
	bool frames = o->cfg->decimate <= 1 || o->cycle % (uint32_t)o->cfg->decimate == 0;
	uint64_t now = mono_ns();
	int live = 0;

	o->cycle++;
	for (int i = 0; i < v->max_clients; i++)
		live += v->cl[i].fd >= 0 && v->cl[i].state == VC_LIVE;
	for (int j = 0; j < n; j++) {
		const struct out_msg *msg = &msgs[j];
		const struct wire_frame *f = msg->frame;
		size_t low, rel;
		int a = msg->avatar;

		/* VRPN has no word for a stale pose: a person who stopped gets no new reports */
		if (msg->type != WIRE_FRAME || a >= m->n || !m->wants[a] || wire_frame_stopped(f))
			continue;
		/* button changes are never decimated away: they are events */
		rel = encode_buttons(v->rel, m, a, &f->in, f->h.sample_time_ns ? f->h.sample_time_ns : real_ns());
		if (!live || (!frames && !rel))
			continue;
		low = frames ? encode_low(v->low, a, f) : 0;
		for (int i = 0; i < v->max_clients; i++) {
			struct vcl *c = &v->cl[i];
			uint8_t *p;

			if (c->fd < 0 || !vcl_knows(c, a))
				continue;
			if (rel) {
				if ((p = vcl_room(v, c, rel))) {
					memcpy(p, v->rel, rel);
					c->len += rel;
				} else {
					c->states_next = 0;
					vcl_dropped(o, c, now);
				}
			}
			if (!low || c->state != VC_LIVE)
				continue;
			if (c->udp) {
				/* several messages per datagram, never split */
				size_t dlen = 0;

				for (size_t k = 0; k < low;) {
					size_t len = MSG_LEN(vrpn_get32(v->low + k) - VRPN_HEADER_LEN);

					if (dlen + len > sizeof(v->dgram))
						vcl_udp_flush(o, v, c, &dlen);
					memcpy(v->dgram + dlen, v->low + k, len);
					dlen += len;
					k += len;
				}
				vcl_udp_flush(o, v, c, &dlen);
			} else if ((p = vcl_room(v, c, low))) {
				memcpy(p, v->low, low);
				c->len += low;
				ctr_add(&o->st.sent, 1);
			} else {
				vcl_dropped(o, c, now);
			}
		}
	}
	for (int i = 0; i < v->max_clients; i++)
		if (v->cl[i].fd >= 0 && v->cl[i].state == VC_LIVE && v->cl[i].len)
			vcl_flush(o, &v->cl[i]);
}

const struct output_ops vrpn_output_ops = {
	.type = { CFG_TYPE("vrpn", "VRPN server: a tracker, an analog and buttons per avatar", vrpn_keys,
			   struct vrpn_opts) },
	.open = vrpn_open,
	.close = vrpn_close,
	.send = vrpn_send,
	.service = vrpn_service,
	.adopt = vrpn_adopt,
};
