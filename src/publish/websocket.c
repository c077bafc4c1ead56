// SPDX-License-Identifier: MIT
/*
 * websocket.c - the browser viewer (docs/VIEWER.md): libwebsockets serves
 * the page (www/), Debian's three.js under /three/, and on the same port a
 * WebSocket ("avatargw-json") that carries the newest frame of every avatar
 * as JSON, `rate` times a second.
 *
 * libwebsockets allocates and is not thread-safe, so everything about it
 * lives in one thread of this output, which creates the context, services
 * it and destroys it. The loop only puts frames into a snapshot
 * (snapshot.h); a tick of the thread takes what is new, writes one JSON
 * text, and asks every browser for a write. A browser whose connection
 * still holds earlier bytes (lws_send_pipe_choked) skips that text and gets
 * a newer one later: a slow browser loses frames, never slows anything.
 *
 * On a reload the thread and its port go to the new output (adopt()): the
 * new configuration's snapshot is made beside the running one, each owned
 * by its output, and the thread switches to the new one when the new
 * output's first frames arrive; a reload that fails leaves the old one in
 * use. The thread's counters go to the output whose snapshot it reads.
 */
#include "publish/output.h"
#include "publish/websocket.h"
#include "publish/listen.h"
#include "base/clock.h"
#include "publish/snapshot.h"

#include "base/log.h"

#include <libwebsockets.h>

#include <errno.h>
#include <limits.h>
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

static const struct cfg_key websocket_keys[] = {
	{ .name = "address",
	  .kind = CFG_STR,
	  CFG_AT(struct websocket_opts, address),
	  .def = "127.0.0.1",
	  .doc = "vmc, vrchat: destination host; websocket: listen address (any other address shows the viewer to "
		 "the network)" },
	{ .name = "port",
	  .kind = CFG_INT,
	  CFG_AT(struct websocket_opts, port),
	  .min = 1,
	  .max = 65535,
	  .def = "7780",
	  .doc = "TCP port of the viewer page (HTTP) and its WebSocket" },
	{ .name = "max_clients",
	  .kind = CFG_INT,
	  CFG_AT(struct websocket_opts, max_clients),
	  .min = 1,
	  .max = 256,
	  .def = "8",
	  .doc = "browsers at most; when all are taken, a new one takes the slot of the one that has answered no ping "
		 "the longest (a second at least), else it is refused" },
	{ .name = "clients_per_address",
	  .kind = CFG_INT,
	  CFG_AT(struct websocket_opts, clients_per_address),
	  .min = 0,
	  .max = 256,
	  .def = "4",
	  .doc = "clients at most from one host (IP address); a further one takes the slot of that host's client idle "
		 "the longest, else it is refused; 0: no limit but max_clients" },
	{ .name = "client_timeout",
	  .kind = CFG_DOUBLE,
	  CFG_AT(struct websocket_opts, client_timeout),
	  .min = 1,
	  .max = 3600,
	  .def = "5",
	  .unit = "s",
	  .doc = "a connection that has not finished its HTTP request or WebSocket handshake this long is dropped" },
	{ .name = "idle_timeout",
	  .kind = CFG_DOUBLE,
	  CFG_AT(struct websocket_opts, idle_timeout),
	  .min = 2,
	  .max = 3600,
	  .def = "30",
	  .unit = "s",
	  .doc = "a browser that answers no ping for this long is disconnected (pinged when silent for half of it)" },
	{ .name = "rate",
	  .kind = CFG_DOUBLE,
	  CFG_AT(struct websocket_opts, rate),
	  .min = 1,
	  .max = 60,
	  .def = "30",
	  .unit = "Hz",
	  .doc = "JSON frames per second to each browser (the newest frame of each avatar each time)" },
	{ .name = "www",
	  .kind = CFG_PATH,
	  CFG_AT(struct websocket_opts, www),
	  .def = "auto",
	  .doc = "directory of the viewer page; auto = $AVATARGW_WWW, else ../share/avatargw/www or ../www beside "
		 "the program" },
	{ .name = "three",
	  .kind = CFG_PATH,
	  CFG_AT(struct websocket_opts, three),
	  .def = "/usr/share/javascript/three",
	  .doc = "directory of three.js (Debian's libjs-three), served as /three/" },
};

static const struct websocket_opts *opts_of(const struct cfg_output *c)
{
	return c->opt;
}

#define WS_PROTOCOL "avatargw-json"
#define WS_AVATAR_JSON 4096 /* bytes of one avatar's record, at most */
#define WS_BODY 7	    /* DESCRIBE's dims (shoulder, upper arm, forearm, hand) and head_offset */

struct ws_view {
	const struct output *owner;
	bool *wants; /* a copy: the owner's goes when it closes, maybe before the thread notices */
	struct snap snap;
	uint32_t *sent; /* per avatar: records sent with a new frame (the page measures loss from gaps) */
	/*
	 * Per avatar: its body from the newest DESCRIBE (NaN until one came), written by the loop and
	 * read by the thread value by value: a change caught halfway draws one picture of mixed sizes.
	 */
	_Atomic float (*body)[WS_BODY];
};

struct ws_srv {
	pthread_t thread;
	pthread_mutex_t mu;	 /* the thread's tick; a reload's adopt(); close() */
	struct lws_context *ctx; /* the thread's; guarded by mu for lws_cancel_service() */
	bool started;
	int start_rc;
	char start_err[256];
	pthread_cond_t started_cv;
	_Atomic bool stop;
	char key[3 * CFG_PATH_MAX + 128]; /* what adopt() compares */
	char address[CFG_PATH_MAX];
	int port;
	int max_clients;
	int per_addr;		      /* clients_per_address */
	unsigned handshake_s, idle_s; /* client_timeout, idle_timeout */
	lws_retry_bo_t idle;	      /* pings when silent for half of idle_s, hangs up at idle_s */
	uint64_t period_us;
	char www[PATH_MAX];
	char three[PATH_MAX];
	struct lws_http_mount mount_three, mount_www;
	struct lws_protocols protocols[3];
	lws_sorted_usec_list_t tick;
	struct ws_view view[2];
	_Atomic int active;
	/* the text of the current tick: LWS_PRE bytes, then the JSON */
	char *text;
	size_t cap, len;
	uint64_t gen; /* texts written so far */
	int clients;
	struct ws_session **sessions; /* the admitted browsers, max_clients slots */
};

/* one browser */
struct ws_session {
	uint64_t gen; /* the text it last got */
	bool counted; /* admitted (under max_clients) */
	struct lws *wsi;
	struct out_peer host; /* its address; active_ns: its connection, or its last pong */
};

static struct output *ws_owner(struct ws_srv *w)
{
	return (struct output *)w->view[atomic_load_explicit(&w->active, memory_order_acquire)].owner;
}

/* ---- JSON ------------------------------------------------------------------------- */

struct jbuf {
	char *p;
	size_t len, cap;
	bool full;
};

static void jprintf(struct jbuf *b, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

static void jprintf(struct jbuf *b, const char *fmt, ...)
{
	va_list ap;
	int n;

	if (b->full)
		return;
	va_start(ap, fmt);
	n = vsnprintf(b->p + b->len, b->cap - b->len, fmt, ap);
	va_end(ap);
	if (n < 0 || (size_t)n >= b->cap - b->len) {
		b->full = true;
		return;
	}
	b->len += (size_t)n;
}

/* a number, or null for NaN (JSON has no NaN) */
static void jnum(struct jbuf *b, const char *sep, double v)
{
	if (isfinite(v))
		jprintf(b, "%s%.7g", sep, v);
	else
		jprintf(b, "%snull", sep);
}

static void jpose(struct jbuf *b, const char *sep, const struct wire_pose *p)
{
	jprintf(b, "%s[", sep);
	for (int i = 0; i < 3; i++)
		jnum(b, i ? "," : "", p->p[i]);
	for (int i = 0; i < 4; i++)
		jnum(b, ",", p->q[i]);
	jprintf(b, "]");
}

/* the name as a JSON string: DESCRIBE names are ASCII, anything else is dropped */
static void jname(struct jbuf *b, const char *s)
{
	jprintf(b, "\"");
	for (; *s; s++)
		if (*s >= 0x20 && *s < 0x7f && *s != '"' && *s != '\\')
			jprintf(b, "%c", *s);
	jprintf(b, "\"");
}

static void json_avatar(struct jbuf *b, const struct snap_entry *e, _Atomic float *body, uint32_t sent,
			uint64_t now_real, uint64_t now_mono)
{
	const struct wire_frame *f = &e->f;

	jprintf(b, "{\"id\":%u,\"name\":", f->h.avatar_id);
	jname(b, e->name);
	jprintf(b, ",\"seq\":%u,\"k\":%u,\"flags\":%u,\"t\":%.3f,\"srv_ms\":%.3f,\"hold_ms\":%.3f", f->h.seq, sent,
		f->h.flags, (double)f->h.sample_time_ns * 1e-6,
		f->h.sample_time_ns ? ((double)now_real - (double)f->h.sample_time_ns) * 1e-6 : 0.0,
		(double)(now_mono - e->put_mono_ns) * 1e-6);
	jprintf(b, ",\"sensors\":[");
	for (int s = 0; s < WIRE_SENSORS; s++) {
		jprintf(b, "%s{\"state\":%u,\"age_ms\":%.1f,\"pose\":", s ? "," : "", f->sensor[s].state,
			f->sensor[s].age_100us * 0.1);
		jpose(b, "", &f->sensor[s].pose);
		jprintf(b, ",\"buttons\":%u,\"analog\":[", e->buttons[s]);
		for (int i = 0; i < SENSOR_ANALOG_MAX; i++)
			jnum(b, i ? "," : "", e->analog[s][i]);
		jprintf(b, "]}");
	}
	jprintf(b, "],\"segments\":[");
	for (int s = 0; s < WIRE_SEGMENTS; s++)
		jpose(b, s ? "," : "", &f->segment[s]);
	jprintf(b, "],\"joints\":[");
	for (int j = 0; j < WIRE_JOINTS; j++)
		jnum(b, j ? "," : "", f->joint[j]);
	jprintf(b, "],\"ik\":[%u,%u],\"ik_err\":[", f->arm[0].ik_flags, f->arm[1].ik_flags);
	jnum(b, "", f->arm[0].pos_err);
	jnum(b, ",", f->arm[1].pos_err);
	jprintf(b, "],\"dims\":[");
	for (int i = 0; i < 4; i++)
		jnum(b, i ? "," : "", atomic_load_explicit(&body[i], memory_order_relaxed));
	jprintf(b, "],\"head_offset\":[");
	for (int i = 4; i < WS_BODY; i++)
		jnum(b, i > 4 ? "," : "", atomic_load_explicit(&body[i], memory_order_relaxed));
	jprintf(b, "]");
	if (e->site.present) {
		/* another site's avatar: how that site's samples reach the daemon (docs/SITES.md) */
		jprintf(b, ",\"site\":");
		jname(b, e->site.name);
		jprintf(b, ",\"site_stats\":{\"state\":\"%s\",\"avatars\":%u,\"frames\":%u,\"lost\":%u",
			e->site.state ? "gone" : "present", e->site.avatars, e->site.frames, e->site.lost);
		jnum(b, ",\"rate_hz\":", e->site.rate_hz);
		jnum(b, ",\"delay_p50_ms\":", e->site.delay_p50_ms);
		jnum(b, ",\"delay_p99_ms\":", e->site.delay_p99_ms);
		jnum(b, ",\"clock_offset_ms\":", e->site.clock_offset_ms);
		jnum(b, ",\"rtt_ms\":", e->site.rtt_ms);
		jprintf(b, "}");
	}
	jprintf(b, "}");
}

/* the text of this tick: every avatar with a frame newer than the last tick's; false if none */
static bool ws_compose(struct ws_srv *w, struct ws_view *v)
{
	struct jbuf b = { w->text + LWS_PRE, 0, w->cap - LWS_PRE, false };
	uint64_t now_real = real_ns(), now_mono = mono_ns();
	int n = 0;

	jprintf(&b, "{\"type\":\"frames\",\"gen\":%llu,\"t\":%.3f,\"avatars\":[", (unsigned long long)w->gen + 1,
		(double)now_real * 1e-6);
	for (int i = 0; i < v->snap.n; i++) {
		bool fresh;
		const struct snap_entry *e;
		size_t mark = b.len;

		if (!v->wants[i])
			continue;
		e = snap_take(&v->snap, i, &fresh);
		if (!e || !fresh)
			continue;
		if (n)
			jprintf(&b, ",");
		json_avatar(&b, e, v->body[i], ++v->sent[i], now_real, now_mono);
		if (b.full) {
			/* cannot happen with the room reserved per avatar; never send a cut text */
			b.len = mark;
			b.full = false;
			break;
		}
		n++;
	}
	jprintf(&b, "]}");
	if (!n || b.full)
		return false;
	w->len = b.len;
	w->gen++;
	return true;
}

/* ---- libwebsockets ---------------------------------------------------------------- */

static void ws_count(struct ws_srv *w, size_t field_off, uint64_t n);

static void ws_tick(lws_sorted_usec_list_t *sul)
{
	struct ws_srv *w = lws_container_of(sul, struct ws_srv, tick);
	uint64_t missed = 0;
	bool any;

	/* a browser that has not taken the previous text yet (its connection is full) loses it */
	for (int i = 0; i < w->max_clients; i++)
		missed += w->sessions[i] && w->sessions[i]->gen != w->gen;
	if (missed)
		ws_count(w, offsetof(struct output_stats, dropped), missed);
	pthread_mutex_lock(&w->mu);
	any = ws_compose(w, &w->view[atomic_load_explicit(&w->active, memory_order_acquire)]);
	pthread_mutex_unlock(&w->mu);
	if (any)
		lws_callback_on_writable_all_protocol(w->ctx, &w->protocols[1]);
	lws_sul_schedule(w->ctx, 0, &w->tick, ws_tick, (lws_usec_t)w->period_us);
}

static void ws_count(struct ws_srv *w, size_t field_off, uint64_t n)
{
	struct output *o;

	pthread_mutex_lock(&w->mu);
	o = ws_owner(w);
	ctr_add((_Atomic uint64_t *)((char *)&o->st + field_off), n);
	pthread_mutex_unlock(&w->mu);
}

static void ws_clients(struct ws_srv *w)
{
	pthread_mutex_lock(&w->mu);
	atomic_store_explicit(&ws_owner(w)->st.clients, (uint64_t)w->clients, memory_order_relaxed);
	pthread_mutex_unlock(&w->mu);
}

/* forgets an admitted browser (its connection closes, or is being closed) */
static void ws_forget(struct ws_srv *w, struct ws_session *s)
{
	for (int i = 0; i < w->max_clients; i++)
		if (w->sessions[i] == s)
			w->sessions[i] = NULL;
	w->clients--;
	s->counted = false;
	ws_count(w, offsetof(struct output_stats, closed), 1);
	ws_clients(w);
}

/*
 * Room for a browser from `from`: under max_clients and clients_per_address,
 * or by closing the browser idle the longest (no pong for a second at least;
 * of this host's own when it has its share). False: refuse it.
 */
static bool ws_make_room(struct ws_srv *w, const struct sockaddr_storage *from, uint64_t now)
{
	struct ws_session *idlest = NULL, *idlest_same = NULL, *victim;
	int same = 0;

	for (int i = 0; i < w->max_clients; i++) {
		struct ws_session *s = w->sessions[i];

		if (!s)
			continue;
		if (!idlest || s->host.active_ns < idlest->host.active_ns)
			idlest = s;
		if (out_same_host(&s->host.addr, from)) {
			same++;
			if (!idlest_same || s->host.active_ns < idlest_same->host.active_ns)
				idlest_same = s;
		}
	}
	if (w->per_addr > 0 && same >= w->per_addr)
		victim = idlest_same;
	else if (w->clients < w->max_clients)
		return true;
	else
		victim = idlest;
	if (!victim || now - victim->host.active_ns < OUT_MIN_IDLE_NS)
		return false;
	lws_set_timeout(victim->wsi, PENDING_TIMEOUT_USER_OK, LWS_TO_KILL_ASYNC);
	ws_forget(w, victim);
	return true;
}

static int ws_callback(struct lws *wsi, enum lws_callback_reasons reason, void *user, void *in, size_t len)
{
	struct ws_srv *w = lws_context_user(lws_get_context(wsi));
	struct ws_session *s = user;

	(void)in;
	(void)len;
	switch (reason) {
	case LWS_CALLBACK_ESTABLISHED: {
		struct sockaddr_storage from = { 0 };
		socklen_t fl = sizeof(from);
		uint64_t now = mono_ns();

		getpeername(lws_get_socket_fd(wsi), (struct sockaddr *)&from, &fl);
		if (!ws_make_room(w, &from, now)) {
			ws_count(w, offsetof(struct output_stats, refused), 1);
			return -1;
		}
		s->counted = true;
		s->wsi = wsi;
		s->host = (struct out_peer){ from, now };
		s->gen = w->gen;
		w->clients++;
		for (int i = 0; i < w->max_clients; i++)
			if (!w->sessions[i]) {
				w->sessions[i] = s;
				break;
			}
		{
			/* a small kernel queue: a browser that falls behind gets recent frames, not old ones */
			int sndbuf = 32768;

			setsockopt(lws_get_socket_fd(wsi), SOL_SOCKET, SO_SNDBUF, &sndbuf, sizeof(sndbuf));
		}
		ws_count(w, offsetof(struct output_stats, accepted), 1);
		ws_clients(w);
		break;
	}
	case LWS_CALLBACK_CLOSED:
		if (s->counted)
			ws_forget(w, s);
		break;
	case LWS_CALLBACK_SERVER_WRITEABLE:
		if (!s->counted || s->gen == w->gen)
			break;
		if (lws_send_pipe_choked(wsi))
			break; /* still sending an older text: this one is skipped (the tick counts it) */
		{
			int n;

			/* under mu: a reload's adopt() may grow the text buffer */
			pthread_mutex_lock(&w->mu);
			n = lws_write(wsi, (unsigned char *)w->text + LWS_PRE, w->len, LWS_WRITE_TEXT);
			pthread_mutex_unlock(&w->mu);
			if (n < (int)w->len)
				return -1;
		}
		s->gen = w->gen;
		ws_count(w, offsetof(struct output_stats, sent), 1);
		break;
	case LWS_CALLBACK_RECEIVE:
		/*
		 * The page sends nothing: whatever comes (an unmasked frame, a
		 * fragment of an endless message, a 2^62-byte one) is not it.
		 */
		ws_count(w, offsetof(struct output_stats, malformed), 1);
		return -1;
	case LWS_CALLBACK_RECEIVE_PONG:
		s->host.active_ns = mono_ns(); /* a browser answers its pings by itself */
		break;
	case LWS_CALLBACK_EVENT_WAIT_CANCELLED:
		break; /* close() woke us: the service loop looks at stop */
	default:
		break;
	}
	return 0;
}

static void ws_log(int level, const char *line)
{
	size_t n = strlen(line);

	/* lws ends its lines with a newline; ours does not */
	while (n && (line[n - 1] == '\n' || line[n - 1] == '\r'))
		n--;
	if (level & LLL_ERR)
		pr_warning("websocket: %.*s", (int)n, line);
}

static void *ws_main(void *arg)
{
	struct ws_srv *w = arg;
	struct lws_context_creation_info info;
	struct lws_context *ctx;

	memset(&info, 0, sizeof(info));
	info.port = w->port;
	info.iface = w->address[0] ? w->address : NULL;
	info.protocols = w->protocols;
	info.mounts = &w->mount_www;
	info.user = w;
	/* the HTTP request and the WebSocket handshake get client_timeout; then pings prove the browser there */
	info.timeout_secs = w->handshake_s;
	info.timeout_secs_ah_idle = w->handshake_s; /* a request that stops half-way */
	info.keepalive_timeout = (int)w->handshake_s;
	info.retry_and_idle_policy = &w->idle;
	/* an IPv4 address to listen on: no IPv6 socket (lws would try to bind it there too) */
	if (!strchr(w->address, ':'))
		info.options |= LWS_SERVER_OPTION_DISABLE_IPV6;
	ctx = lws_create_context(&info);
	pthread_mutex_lock(&w->mu);
	w->ctx = ctx;
	w->started = true;
	if (!ctx) {
		w->start_rc = -EADDRINUSE;
		snprintf(w->start_err, sizeof(w->start_err),
			 "cannot serve on %.100s port %d (in use, or not an address of this host)", w->address,
			 w->port);
	}
	pthread_cond_broadcast(&w->started_cv);
	pthread_mutex_unlock(&w->mu);
	if (!ctx)
		return NULL;
	lws_sul_schedule(ctx, 0, &w->tick, ws_tick, (lws_usec_t)w->period_us);
	while (!atomic_load_explicit(&w->stop, memory_order_acquire))
		if (lws_service(ctx, 0) < 0)
			break;
	pthread_mutex_lock(&w->mu);
	w->ctx = NULL;
	pthread_mutex_unlock(&w->mu);
	lws_context_destroy(ctx);
	return NULL;
}

/* ---- where the page is ------------------------------------------------------------- */

static bool has_file(const char *dir, const char *file)
{
	char p[PATH_MAX + 64];
	struct stat st;

	snprintf(p, sizeof(p), "%s/%s", dir, file);
	return !stat(p, &st) && S_ISREG(st.st_mode);
}

/* "auto": $AVATARGW_WWW, the installation's share/avatargw/www, the source tree's www/ */
static int find_www(const char *configured, char *out, size_t len, char *tried, size_t tlen)
{
	char exe[PATH_MAX], *slash;
	const char *env = getenv("AVATARGW_WWW");
	ssize_t n;

	tried[0] = '\0';
	if (strcmp(configured, "auto")) {
		snprintf(out, len, "%s", configured);
		snprintf(tried, tlen, "%s", configured);
		return has_file(out, "index.html") ? 0 : -ENOENT;
	}
	if (env && env[0]) {
		snprintf(out, len, "%s", env);
		snprintf(tried, tlen, "%s ($AVATARGW_WWW)", env);
		return has_file(out, "index.html") ? 0 : -ENOENT;
	}
	n = readlink("/proc/self/exe", exe, sizeof(exe) - 1);
	if (n <= 0)
		return -ENOENT;
	exe[n] = '\0';
	slash = strrchr(exe, '/');
	if (!slash)
		return -ENOENT;
	*slash = '\0';
	snprintf(out, len, "%.*s/../share/avatargw/www", (int)(len - 32), exe);
	snprintf(tried, tlen, "%s", out);
	if (has_file(out, "index.html"))
		return 0;
	snprintf(out, len, "%.*s/../www", (int)(len - 32), exe);
	snprintf(tried + strlen(tried), tlen - strlen(tried), ", %s", out);
	return has_file(out, "index.html") ? 0 : -ENOENT;
}

/* ---- the output --------------------------------------------------------------------- */

static int view_init(struct ws_view *v, const struct output *o)
{
	memset(v, 0, sizeof(*v));
	v->owner = o;
	v->sent = calloc((size_t)o->n_avatars + 1, sizeof(*v->sent));
	v->wants = calloc((size_t)o->n_avatars + 1, sizeof(*v->wants));
	v->body = calloc((size_t)o->n_avatars + 1, sizeof(*v->body));
	if (!v->sent || !v->wants || !v->body || snap_init(&v->snap, o->n_avatars)) {
		free(v->sent);
		free(v->wants);
		free(v->body);
		memset(v, 0, sizeof(*v));
		return -ENOMEM;
	}
	for (int i = 0; i < o->n_avatars; i++)
		for (int k = 0; k < WS_BODY; k++)
			atomic_init(&v->body[i][k], NAN);
	memcpy(v->wants, o->wants, (size_t)o->n_avatars * sizeof(*v->wants));
	return 0;
}

static void view_free(struct ws_view *v)
{
	snap_free(&v->snap);
	free(v->sent);
	free(v->wants);
	free(v->body);
	memset(v, 0, sizeof(*v));
}

static size_t text_size(int n_avatars)
{
	return LWS_PRE + 256 + (size_t)n_avatars * WS_AVATAR_JSON;
}

static void srv_free(struct ws_srv *w)
{
	view_free(&w->view[0]);
	view_free(&w->view[1]);
	free(w->text);
	free(w->sessions);
	pthread_mutex_destroy(&w->mu);
	pthread_cond_destroy(&w->started_cv);
	free(w);
}

static void describe_key(const struct cfg_output *cfg, char *buf, size_t len)
{
	snprintf(buf, len, "%s|%d|%d|%d|%.9g|%.9g|%.9g|%s|%s", opts_of(cfg)->address, opts_of(cfg)->port,
		 opts_of(cfg)->max_clients, opts_of(cfg)->clients_per_address, opts_of(cfg)->client_timeout,
		 opts_of(cfg)->idle_timeout, opts_of(cfg)->rate, opts_of(cfg)->www, opts_of(cfg)->three);
}

static int ws_open(struct output *o, char *err, size_t errlen)
{
	const struct cfg_output *cfg = o->cfg;
	struct ws_srv *w = calloc(1, sizeof(*w));
	char tried[2 * PATH_MAX + 64];
	int rc;

	if (!w)
		return -ENOMEM;
	pthread_mutex_init(&w->mu, NULL);
	pthread_cond_init(&w->started_cv, NULL);
	describe_key(cfg, w->key, sizeof(w->key));
	snprintf(w->address, sizeof(w->address), "%s", opts_of(cfg)->address);
	w->port = opts_of(cfg)->port;
	w->max_clients = opts_of(cfg)->max_clients;
	w->per_addr = opts_of(cfg)->clients_per_address;
	w->handshake_s = (unsigned)ceil(opts_of(cfg)->client_timeout);
	w->idle_s = (unsigned)ceil(opts_of(cfg)->idle_timeout);
	w->idle = (lws_retry_bo_t){ .secs_since_valid_ping = (uint16_t)(w->idle_s / 2),
				    .secs_since_valid_hangup = (uint16_t)w->idle_s };
	w->period_us = (uint64_t)(1e6 / opts_of(cfg)->rate);
	if (find_www(opts_of(cfg)->www, w->www, sizeof(w->www), tried, sizeof(tried))) {
		snprintf(err, errlen, "[output %s] www: no viewer page (index.html) in %s", cfg->name, tried);
		srv_free(w);
		return -ENOENT;
	}
	snprintf(w->three, sizeof(w->three), "%s", opts_of(cfg)->three);
	if (!has_file(w->three, "build/three.module.js")) {
		snprintf(err, errlen,
			 "[output %s] three: no build/three.module.js in %s (install Debian's libjs-three)", cfg->name,
			 w->three);
		srv_free(w);
		return -ENOENT;
	}
	w->cap = text_size(o->n_avatars);
	w->text = malloc(w->cap);
	w->sessions = calloc((size_t)w->max_clients, sizeof(*w->sessions));
	if (!w->text || !w->sessions || view_init(&w->view[0], o)) {
		snprintf(err, errlen, "[output %s]: out of memory", cfg->name);
		srv_free(w);
		return -ENOMEM;
	}
	/* /three/ is libjs-three, the rest is the page (OrbitControls imports ../../../build/three.module.js) */
	w->mount_three = (struct lws_http_mount){
		.mountpoint = "/three", .origin = w->three, .origin_protocol = LWSMPRO_FILE, .mountpoint_len = 6
	};
	w->mount_www = (struct lws_http_mount){ .mount_next = &w->mount_three,
						.mountpoint = "/",
						.origin = w->www,
						.def = "index.html",
						.origin_protocol = LWSMPRO_FILE,
						.mountpoint_len = 1 };
	w->protocols[0] = (struct lws_protocols){ .name = "http", .callback = lws_callback_http_dummy };
	w->protocols[1] = (struct lws_protocols){ .name = WS_PROTOCOL,
						  .callback = ws_callback,
						  .per_session_data_size = sizeof(struct ws_session) };
	lws_set_log_level(LLL_ERR, ws_log);
	o->priv = w;
	rc = pthread_create(&w->thread, NULL, ws_main, w);
	if (rc) {
		snprintf(err, errlen, "[output %s]: thread: %s", cfg->name, strerror(rc));
		o->priv = NULL;
		srv_free(w);
		return -rc;
	}
	pthread_setname_np(w->thread, "avatargw-ws");
	/* the listening socket is made in the thread: wait to say whether it worked */
	pthread_mutex_lock(&w->mu);
	while (!w->started)
		pthread_cond_wait(&w->started_cv, &w->mu);
	rc = w->start_rc;
	pthread_mutex_unlock(&w->mu);
	if (rc) {
		snprintf(err, errlen, "[output %s]: %s", cfg->name, w->start_err);
		pthread_join(w->thread, NULL);
		o->priv = NULL;
		srv_free(w);
		return rc;
	}
	return 0;
}

static void ws_close(struct output *o)
{
	struct ws_srv *w = o->priv;

	if (!w)
		return;
	atomic_store_explicit(&w->stop, true, memory_order_release);
	pthread_mutex_lock(&w->mu);
	if (w->ctx)
		lws_cancel_service(w->ctx);
	pthread_mutex_unlock(&w->mu);
	pthread_join(w->thread, NULL);
	srv_free(w);
	o->priv = NULL;
}

static bool ws_adopt(struct output *o, struct output *old)
{
	struct ws_srv *w = old->priv;
	char key[sizeof(w->key)];
	size_t cap = text_size(o->n_avatars);
	int k;

	if (!w)
		return false;
	describe_key(o->cfg, key, sizeof(key));
	if (strcmp(key, w->key))
		return false;
	pthread_mutex_lock(&w->mu);
	k = 1 - atomic_load_explicit(&w->active, memory_order_relaxed);
	view_free(&w->view[k]);
	if (cap > w->cap) {
		char *t = realloc(w->text, cap);

		if (!t) {
			pthread_mutex_unlock(&w->mu);
			return false;
		}
		w->text = t;
		w->cap = cap;
	}
	if (view_init(&w->view[k], o)) {
		pthread_mutex_unlock(&w->mu);
		return false;
	}
	pthread_mutex_unlock(&w->mu);
	o->priv = w;
	old->priv = NULL;
	atomic_store_explicit(&o->st.clients, atomic_load_explicit(&old->st.clients, memory_order_relaxed),
			      memory_order_relaxed);
	return true;
}

/* the loop: an avatar's body lengths from its DESCRIBE */
static void ws_describe(struct ws_view *v, const struct out_msg *m)
{
	const struct wire_describe *d = m->describe;

	for (int k = 0; k < WS_BODY; k++)
		atomic_store_explicit(&v->body[m->avatar][k], k < 4 ? d->dims[k] : d->head_offset[k - 4],
				      memory_order_relaxed);
}

static void ws_send(struct output *o, const struct out_msg *m, int n)
{
	struct ws_srv *w = o->priv;
	int k = w->view[0].owner == o ? 0 : 1;
	struct timespec ts;

	o->cycle++;
	for (int j = 0; j < n; j++)
		if (m[j].type == WIRE_DESCRIBE && m[j].describe && m[j].avatar < o->n_avatars && o->wants[m[j].avatar])
			ws_describe(&w->view[k], &m[j]);
	clock_gettime(CLOCK_MONOTONIC, &ts);
	snap_put_batch(&w->view[k].snap, o->wants, m, n, (uint64_t)ts.tv_sec * 1000000000ull + (uint64_t)ts.tv_nsec);
	/* the first frames of a new configuration: the thread reads this output's snapshot from now on */
	if (atomic_load_explicit(&w->active, memory_order_relaxed) != k)
		atomic_store_explicit(&w->active, k, memory_order_release);
}

static void ws_service(struct output *o)
{
	(void)o;
}

const struct output_ops websocket_output_ops = {
	.type = { CFG_TYPE("websocket", "JSON frames and the browser viewer (HTTP and WebSocket)", websocket_keys,
			   struct websocket_opts) },
	.open = ws_open,
	.close = ws_close,
	.send = ws_send,
	.service = ws_service,
	.adopt = ws_adopt,
};
