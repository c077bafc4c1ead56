// SPDX-License-Identifier: MIT
/*
 * modbus_server.c - a Modbus TCP server (libmodbus) whose input registers
 * hold each published avatar's block (publish/modbus_map.h, docs/MODBUS.md).
 *
 * Two threads, no lock between them. The loop thread's send() turns each
 * FRAME into its avatar's block and stores it under a sequence lock (the
 * writer never waits). The server thread, started at open(), owns
 * everything libmodbus touches: the listening socket, the clients, the
 * modbus_t and its register mapping. For each request it copies the blocks
 * the request covers out of the sequence locks (retrying a block that
 * changed while read), so every request is answered from one consistent
 * frame per avatar, then lets modbus_reply() build the response.
 *
 * The server frames requests itself, by the MBAP header's length, from a
 * buffer per client: modbus_receive() would block the whole server while a
 * client dribbles a request byte by byte, and it sizes a request by its
 * function code, so a request whose header lies about its length would
 * desynchronise the stream. Every request is checked here before libmodbus
 * sees it, and answered with the exception the Modbus specification asks
 * for: 01 ILLEGAL FUNCTION for what this server does not do (coils, writes
 * while writable_registers is 0), 02 ILLEGAL DATA ADDRESS outside the map,
 * 03 ILLEGAL DATA VALUE for a bad quantity or a PDU of the wrong length.
 * (modbus_reply() would answer those itself too, but only after sleeping
 * for the response timeout and flushing the socket, which would stall the
 * other clients.) A header that is not Modbus (protocol id not 0, length
 * out of range) ends the connection. A client that sends nothing for
 * idle_timeout, or leaves half a request for a second, is closed, so a
 * silent client holds a slot for a bounded time and never holds the thread.
 */
#include "publish/output.h"
#include "base/json.h"
#include "publish/modbus_server.h"
#include "base/clock.h"
#include "publish/listen.h"

#include "avatargw/wire.h"
#include "base/log.h"
#include "base/seqlock.h"
#include "publish/modbus_map.h"

#include <modbus/modbus.h>

#include <errno.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

static const struct cfg_key modbus_keys[] = {
	{ .name = "address",
	  .kind = CFG_STR,
	  CFG_AT(struct modbus_out_opts, address),
	  .def = "127.0.0.1",
	  .doc = "address to listen on (0.0.0.0 or ::: every interface)" },
	{ .name = "port",
	  .kind = CFG_INT,
	  CFG_AT(struct modbus_out_opts, port),
	  .min = 1,
	  .max = 65535,
	  .missing = "Modbus TCP's own port 502 needs CAP_NET_BIND_SERVICE; 1502 is usual otherwise",
	  .doc = "TCP port to listen on (required)" },
	{ .name = "max_clients",
	  .kind = CFG_INT,
	  CFG_AT(struct modbus_out_opts, max_clients),
	  .min = 1,
	  .max = 256,
	  .def = "8",
	  .doc = "clients at most; when all are taken, a new one takes the slot of the one that has sent no request "
		 "the longest (a second at least), else it is refused" },
	{ .name = "clients_per_address",
	  .kind = CFG_INT,
	  CFG_AT(struct modbus_out_opts, clients_per_address),
	  .min = 0,
	  .max = 256,
	  .def = "4",
	  .doc = "clients at most from one host (IP address); a further one takes the slot of that host's client idle "
		 "the longest, else it is refused; 0: no limit but max_clients" },
	{ .name = "register_base",
	  .kind = CFG_INT,
	  CFG_AT(struct modbus_out_opts, reg_base),
	  .min = 0,
	  .max = 65535,
	  .def = "0",
	  .doc = "input register (0-based) where the first avatar's block starts (docs/MODBUS.md)" },
	{ .name = "register_stride",
	  .kind = CFG_INT,
	  CFG_AT(struct modbus_out_opts, reg_stride),
	  .min = 66,
	  .max = 65536,
	  .def = "100",
	  .doc = "registers from one avatar's block to the next's (a block uses 66)" },
	{ .name = "word_order",
	  .kind = CFG_ENUM,
	  CFG_AT(struct modbus_out_opts, word_order),
	  .def = "abcd",
	  .enums = cfg_word_orders,
	  .doc = "byte order of 32-bit values over two registers, A = most significant byte" },
	{ .name = "writable_registers",
	  .kind = CFG_INT,
	  CFG_AT(struct modbus_out_opts, writable_regs),
	  .min = 0,
	  .max = 10000,
	  .def = "0",
	  .doc = "holding registers clients may write and read back (the daemon acts on none); 0: writes refused" },
	{ .name = "idle_timeout",
	  .kind = CFG_DOUBLE,
	  CFG_AT(struct modbus_out_opts, idle_timeout),
	  .min = 0,
	  .max = 86400,
	  .def = "60",
	  .unit = "s",
	  .doc = "a client that sends no request for this long is disconnected; 0: never" },
};

/* the registers of every avatar the output carries exist (a block is 66 registers: docs/MODBUS.md) */
static int modbus_server_check(const struct config *c, const void *section, const char **key, char *why, size_t len)
{
	const struct cfg_output *o = section;
	const struct modbus_out_opts *opt = o->opt;
	long n = cfg_output_avatars(c, o), last = opt->reg_base + (long)opt->reg_stride * (n - 1) + 66 - 1;

	if (!n || last <= 65535)
		return 0;
	*key = "type";
	snprintf(why, len, "register_base, register_stride: %ld avatars need registers up to %ld, above 65535", n,
		 last);
	return -1;
}

static const struct modbus_out_opts *opts_of(const struct cfg_output *c)
{
	return c->opt;
}

#define MB_ADU_MAX 260		    /* MBAP header (7) + PDU (253) */
#define MB_PARTIAL_NS 1000000000ull /* half a request may wait this long */
#define MB_TICK_MS 100		    /* the server thread's timeout sweep */

enum { EX_FUNCTION = 1, EX_ADDRESS = 2, EX_VALUE = 3 };

/* registers 2i (high half) and 2i + 1, then CLOCK_MONOTONIC ns of the update (high, low) */
#define MB_WORDS (MODBUS_MAP_REGS / 2 + 2)

/* one avatar's registers: written by the loop, read by the server thread */
struct mb_block {
	_Atomic uint32_t seq;
	_Atomic uint32_t w[MB_WORDS];
};

struct mb_client {
	int fd; /* -1: free */
	uint8_t buf[MB_ADU_MAX];
	size_t len;
	struct out_peer peer; /* its host; active_ns: its last complete request (or the connection) */
	uint64_t partial_ns;  /* when the bytes now waiting began to arrive */
};

struct mb_stats {
	_Atomic uint64_t requests;	 /* answered with data */
	_Atomic uint64_t exceptions[4];	 /* answered with exception 1, 2, 3 (index = code) */
	_Atomic uint64_t writes;	 /* writes done (writable registers) */
	_Atomic uint64_t writes_refused; /* write functions answered ILLEGAL FUNCTION */
	_Atomic uint64_t malformed;	 /* PDUs of the wrong length (exception 3) and broken headers (closed) */
	_Atomic uint64_t idle_closed;	 /* clients closed for silence or half a request */
	_Atomic uint64_t evicted;	 /* idle clients closed to make room for a new one */
	_Atomic uint64_t send_errors;	 /* responses a client could not take: closed */
	_Atomic uint64_t clients, accepted, refused, closed;
	_Atomic uint64_t updates; /* blocks stored by the loop */
};

struct mb_server {
	/* settings, copied: the thread outlives nothing it points to */
	char addr[CFG_PATH_MAX + 8];
	int base, stride, order, writable, max_clients, per_addr, n;
	uint64_t idle_ns;
	int *slot; /* per avatar index: its block, or -1 */
	int n_avatars;

	struct mb_block *blk;
	struct mb_stats st;

	/* the server thread's */
	int lfd, stop_fd;
	pthread_t th;
	bool started;
	modbus_t *ctx;
	modbus_mapping_t *map;
	struct mb_client *cl;
	struct pollfd *pfd;
	int *pfd_client;
};

/* the server thread is the one writer of every mb_stats counter but updates */
static void bump(_Atomic uint64_t *c)
{
	atomic_store_explicit(c, atomic_load_explicit(c, memory_order_relaxed) + 1, memory_order_relaxed);
}

static uint64_t get(_Atomic uint64_t *c)
{
	return atomic_load_explicit(c, memory_order_relaxed);
}

/* ---- the sequence lock ------------------------------------------------------------ */

static void block_store(struct mb_block *b, const uint16_t r[MODBUS_MAP_REGS], uint64_t now)
{
	uint32_t w[MB_WORDS];

	for (int i = 0; i < MODBUS_MAP_REGS / 2; i++)
		w[i] = (uint32_t)r[2 * i] << 16 | r[2 * i + 1];
	w[MB_WORDS - 2] = (uint32_t)(now >> 32);
	w[MB_WORDS - 1] = (uint32_t)now;
	seqlock_write(&b->seq, b->w, w, MB_WORDS);
}

static void block_load(struct mb_block *b, uint16_t r[MODBUS_MAP_REGS], uint64_t *t)
{
	uint32_t w[MB_WORDS];

	seqlock_read(&b->seq, b->w, w, MB_WORDS);
	for (int i = 0; i < MODBUS_MAP_REGS / 2; i++) {
		r[2 * i] = (uint16_t)(w[i] >> 16);
		r[2 * i + 1] = (uint16_t)w[i];
	}
	*t = (uint64_t)w[MB_WORDS - 2] << 32 | w[MB_WORDS - 1];
}

/* ---- requests ---------------------------------------------------------------------- */

static void fill_input(struct mb_server *s, int addr, int nb)
{
	uint16_t *tab = s->map->tab_input_registers;
	uint64_t now = mono_ns();
	int a = addr - s->base, end = a + nb;

	while (a < end) {
		int k = a / s->stride, stop = (k + 1) * s->stride < end ? (k + 1) * s->stride : end;
		uint16_t r[MODBUS_MAP_REGS];
		uint64_t t;

		block_load(&s->blk[k], r, &t);
		if (t && r[MODBUS_MAP_R_VERSION]) {
			uint64_t age = (now - t) / 1000000u;

			r[MODBUS_MAP_R_AGE] = age > 65535 ? 65535 : (uint16_t)age;
		} else {
			r[MODBUS_MAP_R_AGE] = 65535;
		}
		for (; a < stop; a++) {
			int o = a - k * s->stride;

			tab[a] = o < MODBUS_MAP_REGS ? r[o] : 0;
		}
	}
}

static int u16at(const uint8_t *b)
{
	return b[0] << 8 | b[1];
}

/* the exception a request deserves (0: none), after filling what it reads */
static int check_request(struct mb_server *s, const uint8_t *req, int len, bool *write)
{
	int fc = req[7], pdu = len - 7;
	int addr = pdu >= 3 ? u16at(req + 8) : 0, nb = pdu >= 5 ? u16at(req + 10) : 0;
	int n_input = s->n ? (s->n - 1) * s->stride + MODBUS_MAP_REGS : 0;

	*write = false;
	switch (fc) {
	case MODBUS_FC_READ_INPUT_REGISTERS:
		if (pdu != 5)
			goto malformed;
		if (nb < 1 || nb > MODBUS_MAX_READ_REGISTERS)
			return EX_VALUE;
		if (addr < s->base || addr + nb > s->base + n_input)
			return EX_ADDRESS;
		fill_input(s, addr, nb);
		return 0;
	case MODBUS_FC_READ_HOLDING_REGISTERS:
		if (!s->writable)
			return EX_FUNCTION;
		if (pdu != 5)
			goto malformed;
		if (nb < 1 || nb > MODBUS_MAX_READ_REGISTERS)
			return EX_VALUE;
		return addr + nb > s->writable ? EX_ADDRESS : 0;
	case MODBUS_FC_WRITE_SINGLE_REGISTER:
		*write = true;
		if (!s->writable)
			return EX_FUNCTION;
		if (pdu != 5)
			goto malformed;
		return addr >= s->writable ? EX_ADDRESS : 0;
	case MODBUS_FC_WRITE_MULTIPLE_REGISTERS:
		*write = true;
		if (!s->writable)
			return EX_FUNCTION;
		if (pdu < 6 || pdu != 6 + req[12])
			goto malformed;
		if (nb < 1 || nb > MODBUS_MAX_WRITE_REGISTERS || req[12] != 2 * nb)
			return EX_VALUE;
		return addr + nb > s->writable ? EX_ADDRESS : 0;
	case MODBUS_FC_MASK_WRITE_REGISTER:
		*write = true;
		if (!s->writable)
			return EX_FUNCTION;
		if (pdu != 7)
			goto malformed;
		return addr >= s->writable ? EX_ADDRESS : 0;
	case MODBUS_FC_WRITE_AND_READ_REGISTERS: {
		int waddr, wnb;

		*write = true;
		if (!s->writable)
			return EX_FUNCTION;
		if (pdu < 10 || pdu != 10 + req[16])
			goto malformed;
		waddr = u16at(req + 12);
		wnb = u16at(req + 14);
		if (nb < 1 || nb > MODBUS_MAX_WR_READ_REGISTERS || wnb < 1 || wnb > MODBUS_MAX_WR_WRITE_REGISTERS ||
		    req[16] != 2 * wnb)
			return EX_VALUE;
		return addr + nb > s->writable || waddr + wnb > s->writable ? EX_ADDRESS : 0;
	}
	case MODBUS_FC_WRITE_SINGLE_COIL:
	case MODBUS_FC_WRITE_MULTIPLE_COILS:
		*write = true;
		return EX_FUNCTION;
	default:
		/* coils, discrete inputs, diagnostics, identification...: not this server's */
		return EX_FUNCTION;
	}
malformed:
	bump(&s->st.malformed);
	return EX_VALUE;
}

static void drop_client(struct mb_server *s, struct mb_client *c)
{
	close(c->fd);
	c->fd = -1;
	c->len = 0;
	bump(&s->st.closed);
	atomic_store_explicit(&s->st.clients, get(&s->st.clients) - 1, memory_order_relaxed);
}

/* answers the complete requests waiting in c's buffer; false: c was closed */
static bool serve_buffer(struct mb_server *s, struct mb_client *c, uint64_t now)
{
	while (c->len >= 7) {
		int proto = u16at(c->buf + 2), mlen = u16at(c->buf + 4), len = 6 + mlen, ex, rc;
		bool write;

		if (proto != 0 || mlen < 2 || mlen > MB_ADU_MAX - 6) {
			/* not Modbus, or a length no request has: the stream cannot be followed */
			bump(&s->st.malformed);
			drop_client(s, c);
			return false;
		}
		if ((size_t)len > c->len)
			break;
		ex = check_request(s, c->buf, len, &write);
		modbus_set_socket(s->ctx, c->fd);
		rc = ex ? modbus_reply_exception(s->ctx, c->buf, (unsigned)ex)
			: modbus_reply(s->ctx, c->buf, len, s->map);
		if (ex) {
			bump(&s->st.exceptions[ex]);
			if (write && ex == EX_FUNCTION)
				bump(&s->st.writes_refused);
		} else {
			bump(&s->st.requests);
			if (write)
				bump(&s->st.writes);
		}
		if (rc < 0) {
			/* a client that does not read its responses */
			bump(&s->st.send_errors);
			drop_client(s, c);
			return false;
		}
		memmove(c->buf, c->buf + len, c->len - (size_t)len);
		c->len -= (size_t)len;
		c->peer.active_ns = now;
		c->partial_ns = now;
	}
	return true;
}

static void read_client(struct mb_server *s, struct mb_client *c, uint64_t now)
{
	for (;;) {
		ssize_t n = recv(c->fd, c->buf + c->len, sizeof(c->buf) - c->len, MSG_DONTWAIT);

		if (n > 0) {
			if (!c->len)
				c->partial_ns = now;
			c->len += (size_t)n;
			if (!serve_buffer(s, c, now))
				return;
			continue;
		}
		if (n < 0 && errno == EINTR)
			continue;
		if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK))
			return;
		drop_client(s, c); /* EOF or reset */
		return;
	}
}

static void accept_clients(struct mb_server *s, uint64_t now)
{
	for (;;) {
		struct sockaddr_storage from = { 0 };
		socklen_t fl = sizeof(from);
		int fd = accept4(s->lfd, (struct sockaddr *)&from, &fl, SOCK_NONBLOCK | SOCK_CLOEXEC), slot, one = 1;
		bool drop;

		if (fd < 0)
			return;
		/* a free slot, or the one of the client idle the longest (this host's own when it has its share) */
		slot = out_slot_for(s->cl, sizeof(*s->cl), offsetof(struct mb_client, fd),
				    offsetof(struct mb_client, peer), s->max_clients, &from, s->per_addr, now, &drop);
		if (slot < 0) {
			close(fd);
			bump(&s->st.refused);
			continue;
		}
		if (drop) {
			bump(&s->st.evicted);
			drop_client(s, &s->cl[slot]);
		}
		setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof(one));
		s->cl[slot] = (struct mb_client){ .fd = fd, .len = 0, .peer = { from, now }, .partial_ns = now };
		bump(&s->st.accepted);
		bump(&s->st.clients);
	}
}

static void *mb_thread(void *arg)
{
	struct mb_server *s = arg;

	for (;;) {
		int n = 0;
		uint64_t now;

		s->pfd[n++] = (struct pollfd){ s->stop_fd, POLLIN, 0 };
		s->pfd[n++] = (struct pollfd){ s->lfd, POLLIN, 0 };
		for (int i = 0; i < s->max_clients; i++) {
			if (s->cl[i].fd < 0)
				continue;
			s->pfd_client[n] = i;
			s->pfd[n++] = (struct pollfd){ s->cl[i].fd, POLLIN, 0 };
		}
		if (poll(s->pfd, (nfds_t)n, MB_TICK_MS) < 0 && errno != EINTR) {
			pr_err("modbus server %s: poll: %s: the server stops", s->addr, strerror(errno));
			break;
		}
		if (s->pfd[0].revents)
			break;
		now = mono_ns();
		for (int i = 2; i < n; i++)
			if (s->pfd[i].revents && s->cl[s->pfd_client[i]].fd >= 0)
				read_client(s, &s->cl[s->pfd_client[i]], now);
		if (s->pfd[1].revents & POLLIN)
			accept_clients(s, now);
		for (int i = 0; i < s->max_clients; i++) {
			struct mb_client *c = &s->cl[i];

			if (c->fd < 0)
				continue;
			if ((s->idle_ns && now - c->peer.active_ns > s->idle_ns) ||
			    (c->len && now - c->partial_ns > MB_PARTIAL_NS)) {
				bump(&s->st.idle_closed);
				drop_client(s, c);
			}
		}
	}
	return NULL;
}

/* ---- the output --------------------------------------------------------------------- */

static void describe_addr(const struct cfg_output *cfg, char *buf, size_t len)
{
	snprintf(buf, len, "%s:%d", opts_of(cfg)->address, opts_of(cfg)->port);
}

/* a reload that changes the server's settings shares the old server's socket until it closes */
static int listen_on(const struct output *o, const char *addr, char *err, size_t errlen)
{
	const struct cfg_output *cfg = o->cfg;
	const struct mb_server *p = o->prev ? o->prev->priv : NULL;

	return out_listen_tcp(cfg->name, opts_of(cfg)->address, opts_of(cfg)->port, "Modbus server",
			      p && !strcmp(p->addr, addr) ? p->lfd : -1, err, errlen);
}

static void free_server(struct mb_server *s)
{
	if (!s)
		return;
	if (s->started) {
		uint64_t one = 1;

		if (write(s->stop_fd, &one, sizeof(one)) != sizeof(one))
			pr_err("modbus: cannot stop the server thread: %s", strerror(errno));
		pthread_join(s->th, NULL);
	}
	for (int i = 0; s->cl && i < s->max_clients; i++)
		if (s->cl[i].fd >= 0)
			close(s->cl[i].fd);
	if (s->lfd >= 0)
		close(s->lfd);
	if (s->stop_fd >= 0)
		close(s->stop_fd);
	if (s->map)
		modbus_mapping_free(s->map);
	if (s->ctx)
		modbus_free(s->ctx);
	free(s->cl);
	free(s->pfd);
	free(s->pfd_client);
	free(s->blk);
	free(s->slot);
	free(s);
}

static int modbus_server_open(struct output *o, char *err, size_t errlen)
{
	const struct cfg_output *cfg = o->cfg;
	struct mb_server *s = calloc(1, sizeof(*s));
	int n_input, rc;

	if (!s)
		return -ENOMEM;
	s->lfd = s->stop_fd = -1;
	describe_addr(cfg, s->addr, sizeof(s->addr));
	s->base = opts_of(cfg)->reg_base;
	s->stride = opts_of(cfg)->reg_stride;
	s->order = opts_of(cfg)->word_order;
	s->writable = opts_of(cfg)->writable_regs;
	s->max_clients = opts_of(cfg)->max_clients;
	s->per_addr = opts_of(cfg)->clients_per_address;
	s->idle_ns = (uint64_t)(opts_of(cfg)->idle_timeout * 1e9);
	s->n_avatars = o->n_avatars;
	s->slot = calloc((size_t)o->n_avatars + 1, sizeof(*s->slot));
	for (int i = 0; s->slot && i < o->n_avatars; i++)
		s->slot[i] = o->wants[i] ? s->n++ : -1;
	n_input = s->n ? (s->n - 1) * s->stride + MODBUS_MAP_REGS : 0;
	if (s->slot && s->base + n_input > 65536) {
		snprintf(err, errlen,
			 "[output %s]: %d avatars at register_base %d and register_stride %d need registers up to %d, "
			 "beyond 65535",
			 cfg->name, s->n, s->base, s->stride, s->base + n_input - 1);
		free_server(s);
		return -EINVAL;
	}
	s->blk = calloc((size_t)s->n + 1, sizeof(*s->blk));
	s->cl = calloc((size_t)s->max_clients, sizeof(*s->cl));
	s->pfd = calloc((size_t)s->max_clients + 2, sizeof(*s->pfd));
	s->pfd_client = calloc((size_t)s->max_clients + 2, sizeof(*s->pfd_client));
	/* the context only frames responses: its sockets are ours (modbus_set_socket) */
	s->ctx = modbus_new_tcp(NULL, 0);
	s->map = modbus_mapping_new_start_address(0, 0, 0, 0, 0, s->writable, (unsigned)s->base, (unsigned)n_input);
	if (!s->slot || !s->blk || !s->cl || !s->pfd || !s->pfd_client || !s->ctx || !s->map) {
		snprintf(err, errlen, "[output %s]: out of memory", cfg->name);
		free_server(s);
		return -ENOMEM;
	}
	for (int i = 0; i < s->max_clients; i++)
		s->cl[i].fd = -1;
	s->stop_fd = eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
	if (s->stop_fd < 0) {
		rc = -errno;
		snprintf(err, errlen, "[output %s]: eventfd: %s", cfg->name, strerror(errno));
		free_server(s);
		return rc;
	}
	s->lfd = listen_on(o, s->addr, err, errlen);
	if (s->lfd < 0) {
		rc = s->lfd;
		s->lfd = -1;
		free_server(s);
		return rc;
	}
	rc = pthread_create(&s->th, NULL, mb_thread, s);
	if (rc) {
		snprintf(err, errlen, "[output %s]: server thread: %s", cfg->name, strerror(rc));
		free_server(s);
		return -rc;
	}
	s->started = true;
	o->priv = s;
	return 0;
}

static void modbus_server_close(struct output *o)
{
	free_server(o->priv);
	o->priv = NULL;
}

static void modbus_server_send(struct output *o, const struct out_msg *m, int n)
{
	struct mb_server *s = o->priv;
	bool frames = o->cfg->decimate <= 1 || o->cycle % (uint32_t)o->cfg->decimate == 0;
	uint64_t now = 0;

	o->cycle++;
	if (!frames)
		return;
	for (int i = 0; i < n; i++) {
		int k = s->slot[m[i].avatar];
		uint16_t r[MODBUS_MAP_REGS];

		if (k < 0 || m[i].type != WIRE_FRAME)
			continue;
		if (!now)
			now = mono_ns();
		modbus_map_encode(m[i].frame, s->order, r);
		block_store(&s->blk[k], r, now);
		ctr_add(&s->st.updates, 1);
	}
}

/* the table of avatargw-ctl status shows what the server thread counted */
static void modbus_server_service(struct output *o)
{
	struct mb_server *s = o->priv;
	uint64_t ex = get(&s->st.exceptions[1]) + get(&s->st.exceptions[2]) + get(&s->st.exceptions[3]);

	atomic_store_explicit(&o->st.sent, get(&s->st.requests) + ex, memory_order_relaxed);
	atomic_store_explicit(&o->st.errors, get(&s->st.send_errors), memory_order_relaxed);
	atomic_store_explicit(&o->st.clients, get(&s->st.clients), memory_order_relaxed);
	atomic_store_explicit(&o->st.accepted, get(&s->st.accepted), memory_order_relaxed);
	atomic_store_explicit(&o->st.refused, get(&s->st.refused), memory_order_relaxed);
	atomic_store_explicit(&o->st.closed, get(&s->st.closed), memory_order_relaxed);
}

/* the same server: its clients stay connected across a reload */
static bool modbus_server_adopt(struct output *o, struct output *old)
{
	const struct cfg_output *cfg = o->cfg;
	struct mb_server *s = old->priv;
	char addr[sizeof(s->addr)];
	int n = 0;

	if (!s)
		return false;
	describe_addr(cfg, addr, sizeof(addr));
	if (strcmp(addr, s->addr) || s->base != opts_of(cfg)->reg_base || s->stride != opts_of(cfg)->reg_stride ||
	    s->order != opts_of(cfg)->word_order || s->writable != opts_of(cfg)->writable_regs ||
	    s->max_clients != opts_of(cfg)->max_clients || s->per_addr != opts_of(cfg)->clients_per_address ||
	    s->idle_ns != (uint64_t)(opts_of(cfg)->idle_timeout * 1e9) || s->n_avatars != o->n_avatars)
		return false;
	for (int i = 0; i < o->n_avatars; i++) {
		if ((s->slot[i] >= 0) != o->wants[i])
			return false;
		n += o->wants[i];
	}
	if (n != s->n)
		return false;
	o->priv = s;
	old->priv = NULL;
	return true;
}

static void modbus_server_report(struct output *o, FILE *out, bool json)
{
	struct mb_server *s = o->priv;

	if (!s)
		return;
	if (json) {
		fputs(",\"modbus\":{\"address\":", out);
		json_string(out, s->addr);
		fprintf(out,
			",\"avatars\":%d,\"requests\":%llu,"
			"\"illegal_function\":%llu,\"illegal_address\":%llu,\"illegal_value\":%llu,"
			"\"malformed\":%llu,\"writes\":%llu,\"writes_refused\":%llu,\"idle_closed\":%llu,"
			"\"evicted\":%llu,\"send_errors\":%llu,\"updates\":%llu}",
			s->n, (unsigned long long)get(&s->st.requests), (unsigned long long)get(&s->st.exceptions[1]),
			(unsigned long long)get(&s->st.exceptions[2]), (unsigned long long)get(&s->st.exceptions[3]),
			(unsigned long long)get(&s->st.malformed), (unsigned long long)get(&s->st.writes),
			(unsigned long long)get(&s->st.writes_refused), (unsigned long long)get(&s->st.idle_closed),
			(unsigned long long)get(&s->st.evicted), (unsigned long long)get(&s->st.send_errors),
			(unsigned long long)get(&s->st.updates));
		return;
	}
	fprintf(out,
		"  %s: Modbus %s: %llu requests, exceptions 01/02/03 %llu/%llu/%llu, %llu malformed, "
		"%llu writes refused, %llu idle closed, %llu dropped for a new client\n",
		o->name, s->addr, (unsigned long long)get(&s->st.requests),
		(unsigned long long)get(&s->st.exceptions[1]), (unsigned long long)get(&s->st.exceptions[2]),
		(unsigned long long)get(&s->st.exceptions[3]), (unsigned long long)get(&s->st.malformed),
		(unsigned long long)get(&s->st.writes_refused), (unsigned long long)get(&s->st.idle_closed),
		(unsigned long long)get(&s->st.evicted));
}

const struct output_ops modbus_output_ops = {
	.type = { CFG_TYPE("modbus", "Modbus TCP server: frame, states and joint angles as input registers",
			   modbus_keys, struct modbus_out_opts),
		  .check = modbus_server_check },
	.quiet_accept = true,
	.open = modbus_server_open,
	.close = modbus_server_close,
	.send = modbus_server_send,
	.service = modbus_server_service,
	.adopt = modbus_server_adopt,
	.report = modbus_server_report,
};
