// SPDX-License-Identifier: MIT
/*
 * stream.c - TCP and Unix stream subscribers, each message preceded by its
 * length (u32, little-endian).
 *
 * Every subscriber has a buffer allocated at open(); a cycle appends whole
 * messages to it and writes what the socket takes without blocking. A
 * message that does not fit is dropped whole and counted, so a slow reader
 * loses messages, never the framing, and never slows the loop or the other
 * subscribers. A reader that is gone (EOF, reset, EPIPE) is closed and its
 * slot reused. On a reload with the same address the listening socket and
 * the subscribers are handed to the new configuration (adopt()).
 */
#include "publish/output.h"
#include "publish/stream.h"
#include "publish/listen.h"
#include "base/clock.h"

#include "avatargw/wire.h"

#include <errno.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

/* the keys its types share (read before each type's own) */
static const struct cfg_key stream_shared_keys[] = {
	{ .name = "max_clients",
	  .kind = CFG_INT,
	  CFG_AT(struct stream_opts, max_clients),
	  .min = 1,
	  .max = 256,
	  .def = "8",
	  .doc = "stream subscribers at most; when all are taken, a new one takes the slot of the one that has taken "
		 "nothing the longest (a second at least), else it is refused" },
	{ .name = "clients_per_address",
	  .kind = CFG_INT,
	  CFG_AT(struct stream_opts, clients_per_address),
	  .min = 0,
	  .max = 256,
	  .def = "4",
	  .doc = "tcp: clients at most from one host (IP address); a further one takes the slot of that host's client "
		 "idle the longest, else it is refused; 0: no limit but max_clients (unix: no hosts, no limit)" },
	{ .name = "client_buffer",
	  .kind = CFG_INT,
	  CFG_AT(struct stream_opts, client_buffer),
	  .min = 4096,
	  .max = 16777216,
	  .def = "65536",
	  .unit = "bytes",
	  .doc = "per-subscriber buffer; messages that do not fit are dropped and counted" },
};

static const struct cfg_key tcp_keys[] = {
	{ .name = "address",
	  .kind = CFG_STR,
	  CFG_AT(struct stream_opts, address),
	  .def = "127.0.0.1",
	  .doc = "address to listen on (0.0.0.0 or ::: every interface)" },
	{ .name = "port",
	  .kind = CFG_INT,
	  CFG_AT(struct stream_opts, port),
	  .min = 1,
	  .max = 65535,
	  .def = "7770",
	  .doc = "TCP port to listen on" },
};

static const struct cfg_key unix_keys[] = {
	{ .name = "path",
	  .kind = CFG_PATH,
	  CFG_AT(struct stream_opts, path),
	  .def = "/run/avatargw/stream",
	  .doc = "Unix socket path to listen on" },
};

static const struct stream_opts *opts_of(const struct cfg_output *c)
{
	return c->opt;
}

struct client {
	int fd; /* -1: free slot */
	uint8_t *buf;
	size_t off, len;
	struct out_peer host; /* its host (TCP); active_ns: when its socket last took bytes (or it connected) */
};

struct stream {
	int lfd;
	bool is_unix;		     /* a Unix stream socket, else TCP */
	char addr[CFG_PATH_MAX + 8]; /* what adopt() compares */
	int max_clients, per_addr;
	size_t buf_size;
	struct client *cl;
	uint8_t *pool;
};

static void describe_addr(const struct cfg_output *cfg, char *buf, size_t len)
{
	if (cfg_output_is(cfg, "unix"))
		snprintf(buf, len, "unix:%s", opts_of(cfg)->path);
	else
		snprintf(buf, len, "tcp:%s:%d", opts_of(cfg)->address, opts_of(cfg)->port);
}

/* the listening socket of the output a reload replaces, when it has the same address */
static int inherited(const struct output *o, const char *addr)
{
	const struct stream *p = o->prev ? o->prev->priv : NULL;

	return p && !strcmp(p->addr, addr) ? p->lfd : -1;
}

static int listen_tcp(const struct output *o, const char *addr, char *err, size_t errlen)
{
	const struct cfg_output *cfg = o->cfg;

	return out_listen_tcp(cfg->name, opts_of(cfg)->address, opts_of(cfg)->port, "listen", inherited(o, addr), err,
			      errlen);
}

static int listen_unix(const struct output *o, const char *addr, char *err, size_t errlen)
{
	const struct cfg_output *cfg = o->cfg;
	char why[CFG_PATH_MAX + 128];
	int fd, old = inherited(o, addr);

	if (old >= 0) {
		fd = out_unix_share(old, opts_of(cfg)->path);
		if (fd < 0)
			snprintf(err, errlen, "[output %s]: listen on %s: %s", cfg->name, opts_of(cfg)->path,
				 strerror(-fd));
		return fd;
	}
	/* 0660: the daemon's user and group may subscribe (under systemd: its runtime directory's mode) */
	fd = out_listen_unix(opts_of(cfg)->path, 0660, why, sizeof(why));
	if (fd < 0)
		snprintf(err, errlen, "[output %s] path: %s", cfg->name, why);
	return fd;
}

static int stream_open(struct output *o, char *err, size_t errlen)
{
	const struct cfg_output *cfg = o->cfg;
	struct stream *s = calloc(1, sizeof(*s));

	if (!s)
		return -ENOMEM;
	s->is_unix = cfg_output_is(cfg, "unix");
	describe_addr(cfg, s->addr, sizeof(s->addr));
	s->max_clients = opts_of(cfg)->max_clients;
	s->per_addr = s->is_unix ? 0 : opts_of(cfg)->clients_per_address;
	s->buf_size = (size_t)opts_of(cfg)->client_buffer;
	s->cl = calloc((size_t)s->max_clients, sizeof(*s->cl));
	s->pool = malloc((size_t)s->max_clients * s->buf_size);
	if (!s->cl || !s->pool) {
		free(s->cl);
		free(s->pool);
		free(s);
		return -ENOMEM;
	}
	for (int i = 0; i < s->max_clients; i++) {
		s->cl[i].fd = -1;
		s->cl[i].buf = s->pool + (size_t)i * s->buf_size;
	}
	s->lfd = s->is_unix ? listen_unix(o, s->addr, err, errlen) : listen_tcp(o, s->addr, err, errlen);
	if (s->lfd < 0) {
		int rc = s->lfd;

		free(s->cl);
		free(s->pool);
		free(s);
		return rc;
	}
	o->priv = s;
	return 0;
}

static void drop_client(struct output *o, struct client *c)
{
	close(c->fd);
	c->fd = -1;
	c->off = c->len = 0;
	ctr_add(&o->st.closed, 1);
	atomic_store_explicit(&o->st.clients, atomic_load_explicit(&o->st.clients, memory_order_relaxed) - 1,
			      memory_order_relaxed);
}

static void stream_close(struct output *o)
{
	struct stream *s = o->priv;

	if (!s)
		return;
	for (int i = 0; i < s->max_clients; i++)
		if (s->cl[i].fd >= 0)
			close(s->cl[i].fd);
	if (s->is_unix)
		out_unix_close(s->lfd, s->addr + 5); /* "unix:" */
	else
		close(s->lfd);
	free(s->cl);
	free(s->pool);
	free(s);
	o->priv = NULL;
}

static void flush_client(struct output *o, struct client *c, uint64_t now)
{
	size_t had = c->len;

	if (out_send_pending(c->fd, c->buf, &c->off, &c->len))
		drop_client(o, c);
	else if (c->len < had || !c->len)
		c->host.active_ns = now; /* it reads: a subscriber in good health */
}

static void stream_send(struct output *o, const struct out_msg *m, int n)
{
	struct stream *s = o->priv;
	bool frames = o->cfg->decimate <= 1 || o->cycle % (uint32_t)o->cfg->decimate == 0;
	uint64_t now = mono_ns();

	o->cycle++;
	for (int i = 0; i < s->max_clients; i++) {
		struct client *c = &s->cl[i];

		if (c->fd < 0)
			continue;
		for (int j = 0; j < n; j++) {
			size_t need = 4u + m[j].len;

			if (!o->wants[m[j].avatar] || (!frames && m[j].type == WIRE_FRAME))
				continue;
			if (c->off + c->len + need > s->buf_size && c->off) {
				memmove(c->buf, c->buf + c->off, c->len);
				c->off = 0;
			}
			if (c->len + need > s->buf_size) {
				ctr_add(&o->st.dropped, 1);
				continue;
			}
			wire_put_len(c->buf + c->off + c->len, m[j].len);
			memcpy(c->buf + c->off + c->len + 4, m[j].data, m[j].len);
			c->len += need;
			ctr_add(&o->st.sent, 1);
		}
		flush_client(o, c, now);
	}
}

static void stream_service(struct output *o)
{
	struct stream *s = o->priv;
	uint8_t junk[256];
	uint64_t now = mono_ns();

	for (;;) {
		struct sockaddr_storage from = { 0 };
		socklen_t fl = sizeof(from);
		int fd = accept4(s->lfd, (struct sockaddr *)&from, &fl, SOCK_NONBLOCK | SOCK_CLOEXEC), slot, one = 1;
		bool drop;

		if (fd < 0)
			break;
		/* a free slot, or the one of the subscriber that has taken nothing the longest */
		slot = out_slot_for(s->cl, sizeof(*s->cl), offsetof(struct client, fd), offsetof(struct client, host),
				    s->max_clients, &from, s->per_addr, now, &drop);
		if (slot < 0) {
			close(fd);
			ctr_add(&o->st.refused, 1);
			continue;
		}
		if (drop)
			drop_client(o, &s->cl[slot]);
		if (!s->is_unix)
			setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof(one));
		{
			/* a small kernel queue: a slow reader gets recent frames, not seconds-old ones */
			int sndbuf = (int)s->buf_size;

			setsockopt(fd, SOL_SOCKET, SO_SNDBUF, &sndbuf, sizeof(sndbuf));
		}
		s->cl[slot].fd = fd;
		s->cl[slot].off = s->cl[slot].len = 0;
		s->cl[slot].host = (struct out_peer){ from, now };
		ctr_add(&o->st.accepted, 1);
		ctr_add(&o->st.clients, 1);
	}
	/* subscribers send nothing: a readable socket means EOF (gone) or noise to discard */
	for (int i = 0; i < s->max_clients; i++) {
		struct client *c = &s->cl[i];
		ssize_t n;

		if (c->fd < 0)
			continue;
		n = recv(c->fd, junk, sizeof(junk), MSG_DONTWAIT);
		if (n == 0 || (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR))
			drop_client(o, c);
	}
}

static bool stream_adopt(struct output *o, struct output *old)
{
	struct stream *s = old->priv;
	char addr[CFG_PATH_MAX + 8];

	if (!s)
		return false;
	describe_addr(o->cfg, addr, sizeof(addr));
	if (strcmp(addr, s->addr) || s->max_clients != opts_of(o->cfg)->max_clients ||
	    s->per_addr != (s->is_unix ? 0 : opts_of(o->cfg)->clients_per_address) ||
	    s->buf_size != (size_t)opts_of(o->cfg)->client_buffer)
		return false;
	o->priv = s;
	old->priv = NULL;
	atomic_store_explicit(&o->st.clients, atomic_load_explicit(&old->st.clients, memory_order_relaxed),
			      memory_order_relaxed);
	return true;
}

const struct output_ops tcp_output_ops = {
	.type = { CFG_TYPE("tcp", "TCP server, each message after a u32 length", tcp_keys, struct stream_opts),
		  CFG_SHARED(stream_shared_keys) },
	.open = stream_open,
	.close = stream_close,
	.send = stream_send,
	.service = stream_service,
	.adopt = stream_adopt,
};

const struct output_ops unix_output_ops = {
	.type = { CFG_TYPE("unix", "Unix stream socket server, each message after a u32 length", unix_keys,
			   struct stream_opts),
		  CFG_SHARED(stream_shared_keys) },
	.open = stream_open,
	.close = stream_close,
	.send = stream_send,
	.service = stream_service,
	.adopt = stream_adopt,
};
