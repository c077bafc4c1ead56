// SPDX-License-Identifier: MIT
/*
 * dtrack.c - the ART DTrack source (type = dtrack; see dtrack.h for the
 * lines it reads, docs/TRACKERS.md for its use), written from the
 * published format.
 *
 * A device thread (trackers/device.h) receives the datagrams on the
 * configured port; the loop copies the newest samples out of the device's
 * triple buffer. A frame is decoded line by line; a line that does not
 * parse whole (a datagram cut short, a number that is no number, a block
 * count that does not match) is dropped and counted, its bodies keep
 * their last samples and go STALE. A body with quality < 0 is not
 * tracked: it gets no sample (STALE after stale_ms, never a frozen pose
 * passed off as new). DTrack has no connection: while no frame arrives
 * for timeout_ms the source is FAULTY, and the first frame after makes it
 * OK again.
 */
#include "trackers/dtrack.h"

#include <arpa/inet.h>
#include <errno.h>
#include <math.h>
#include <netdb.h>
#include <netinet/in.h>
#include <poll.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <syslog.h>
#include <time.h>
#include <unistd.h>

#define DAY_NS (86400ull * 1000000000ull)
#define DT_MAX_BUTTON_WORDS 8 /* 256 buttons: more than any Flystick has */
#define DT_MAX_JOYSTICK 16

/* ---- parsing ------------------------------------------------------------------------- */

static const char *skip_ws(const char *s)
{
	while (*s == ' ' || *s == '\t')
		s++;
	return s;
}

/* an integer; NULL when none */
static const char *get_int(const char *s, long *v)
{
	char *end;

	s = skip_ws(s);
	errno = 0;
	*v = strtol(s, &end, 10);
	if (end == s || errno)
		return NULL;
	return end;
}

/* "[a b c ...]" with exactly n numbers; NULL when not */
static const char *get_block(const char *s, double *v, int n)
{
	s = skip_ws(s);
	if (*s++ != '[')
		return NULL;
	for (int i = 0; i < n; i++) {
		char *end;

		s = skip_ws(s);
		v[i] = strtod(s, &end);
		if (end == s || !isfinite(v[i]))
			return NULL;
		s = end;
	}
	s = skip_ws(s);
	if (*s++ != ']')
		return NULL;
	return s;
}

bool dtrack_matrix_quat(const double r[9], double q[4])
{
	/* m[row][col] = r[col * 3 + row] */
#define M(i, j) r[(j)*3 + (i)]
	double det = M(0, 0) * (M(1, 1) * M(2, 2) - M(1, 2) * M(2, 1)) -
		     M(0, 1) * (M(1, 0) * M(2, 2) - M(1, 2) * M(2, 0)) +
		     M(0, 2) * (M(1, 0) * M(2, 1) - M(1, 1) * M(2, 0));
	double t = M(0, 0) + M(1, 1) + M(2, 2), n;

	/* DTrack prints 6 decimals: a rotation to about 1e-6, anything far from one is not */
	if (fabs(det - 1) > 0.01)
		return false;
	for (int c = 0; c < 3; c++) {
		double l = M(0, c) * M(0, c) + M(1, c) * M(1, c) + M(2, c) * M(2, c);

		if (fabs(l - 1) > 0.01)
			return false;
	}
	if (t > 0) {
		double s = sqrt(1 + t) * 2;

		q[0] = s / 4;
		q[1] = (M(2, 1) - M(1, 2)) / s;
		q[2] = (M(0, 2) - M(2, 0)) / s;
		q[3] = (M(1, 0) - M(0, 1)) / s;
	} else if (M(0, 0) > M(1, 1) && M(0, 0) > M(2, 2)) {
		double s = sqrt(1 + M(0, 0) - M(1, 1) - M(2, 2)) * 2;

		q[0] = (M(2, 1) - M(1, 2)) / s;
		q[1] = s / 4;
		q[2] = (M(0, 1) + M(1, 0)) / s;
		q[3] = (M(0, 2) + M(2, 0)) / s;
	} else if (M(1, 1) > M(2, 2)) {
		double s = sqrt(1 + M(1, 1) - M(0, 0) - M(2, 2)) * 2;

		q[0] = (M(0, 2) - M(2, 0)) / s;
		q[1] = (M(0, 1) + M(1, 0)) / s;
		q[2] = s / 4;
		q[3] = (M(1, 2) + M(2, 1)) / s;
	} else {
		double s = sqrt(1 + M(2, 2) - M(0, 0) - M(1, 1)) * 2;

		q[0] = (M(1, 0) - M(0, 1)) / s;
		q[1] = (M(0, 2) + M(2, 0)) / s;
		q[2] = (M(1, 2) + M(2, 1)) / s;
		q[3] = s / 4;
	}
#undef M
	n = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
	for (int i = 0; i < 4; i++)
		q[i] /= n;
	if (q[0] < 0)
		for (int i = 0; i < 4; i++)
			q[i] = -q[i];
	return true;
}

/* one body's pose from its location (mm) and matrix; false: not a pose */
static bool body_pose(const double loc[3], const double rot[9], struct device_sample *s)
{
	double q[4];
	struct quat r;
	struct vec3 p;

	for (int i = 0; i < 3; i++)
		if (fabs(loc[i]) > 1e7)
			return false;
	if (!dtrack_matrix_quat(rot, q))
		return false;
	r = (struct quat){ q[0], q[1], q[2], q[3] };
	p = (struct vec3){ loc[0] * 0.001, loc[1] * 0.001, loc[2] * 0.001 };
	dq_from_rt(&r, &p, &s->pose);
	return true;
}

/* ---- the codec ------------------------------------------------------------------------- */

static void dt_reset(void *st)
{
	struct dtrack_codec_st *d = st;

	d->have_frame = false;
	timemap_reset(&d->tm);
}

static const struct dtrack_opts *opts_of(const struct cfg_source *c)
{
	return c->opt;
}

static int dt_init(void *st, const struct cfg_source *cfg, char *err, size_t errlen)
{
	struct dtrack_codec_st *d = st;

	(void)err;
	(void)errlen;
	memset(d, 0, offsetof(struct dtrack_codec_st, text));
	d->n_bodies = opts_of(cfg)->sensors;
	d->n_fly = opts_of(cfg)->flysticks;
	d->calibrated = -1;
	dt_reset(d);
	return 0;
}

static double dt_period(const void *st)
{
	(void)st;
	return 1.0 / 60; /* DTrack's usual rate */
}

/* ts: seconds since midnight UTC, on the day that puts it nearest to now */
static uint64_t ts_to_ns(double ts, uint64_t now)
{
	uint64_t day = now - now % DAY_NS, t = day + (uint64_t)llround(ts * 1e9);

	if (t > now + DAY_NS / 2)
		t -= DAY_NS;
	else if (t + DAY_NS / 2 < now)
		t += DAY_NS;
	return t;
}

/* a 6d line's bodies: all of them, or none when the line does not parse whole */
static int line_6d(struct dtrack_codec_st *d, const char *s, uint64_t t_ns, device_emit_fn *emit, void *ctx)
{
	struct {
		int id;
		double qu, loc[3], rot[9];
	} b[64];
	long n;
	int got = 0, nb;

	if (!(s = get_int(s, &n)) || n < 0 || n > 1000)
		return -1;
	nb = (int)n;
	for (int i = 0; i < nb; i++) {
		double h[2], loc[3], rot[9];

		if (!(s = get_block(s, h, 2)) || h[0] < 0 || h[0] != floor(h[0]) || h[0] > 1e6 ||
		    !(s = get_block(s, loc, 3)) || !(s = get_block(s, rot, 9)))
			return -1;
		if (i >= 64)
			continue; /* more bodies in a line than kept: checked, not used */
		b[i].id = (int)h[0];
		b[i].qu = h[1];
		memcpy(b[i].loc, loc, sizeof(loc));
		memcpy(b[i].rot, rot, sizeof(rot));
	}
	if (*skip_ws(s))
		return -1;
	for (int i = 0; i < nb && i < 64; i++) {
		struct device_sample smp;

		if (b[i].id < DTRACK_SEEN)
			d->seen[b[i].id]++;
		if (b[i].qu < 0) {
			d->untracked++;
			continue;
		}
		if (b[i].id >= d->n_bodies) {
			d->ignored++;
			continue;
		}
		if (!body_pose(b[i].loc, b[i].rot, &smp)) {
			d->c.malformed++;
			continue;
		}
		smp.buttons = 0;
		memset(smp.analog, 0, sizeof(smp.analog));
		smp.inputs = false;
		smp.t_ns = t_ns;
		emit(ctx, b[i].id, &smp);
		got++;
	}
	return got;
}

/* a 6df2 line's Flysticks: all of them, or none */
static int line_6df2(struct dtrack_codec_st *d, const char *s, uint64_t t_ns, device_emit_fn *emit, void *ctx)
{
	struct device_sample smp[CHAN_MAX_FLYSTICKS];
	bool ok[CHAN_MAX_FLYSTICKS] = { false };
	long ncal, n;
	int got = 0;

	if (!(s = get_int(s, &ncal)) || !(s = get_int(s, &n)) || ncal < 0 || n < 0 || n > 100)
		return -1;
	for (int i = 0; i < (int)n; i++) {
		double h[4], loc[3], rot[9], v[DT_MAX_BUTTON_WORDS + DT_MAX_JOYSTICK];
		int nbt, nct, words;

		if (!(s = get_block(s, h, 4)) || h[0] != i || h[2] < 0 || h[3] < 0 || h[2] > 32 * DT_MAX_BUTTON_WORDS ||
		    h[3] > DT_MAX_JOYSTICK || h[2] != floor(h[2]) || h[3] != floor(h[3]))
			return -1;
		nbt = (int)h[2];
		nct = (int)h[3];
		words = (nbt + 31) / 32;
		if (!(s = get_block(s, loc, 3)) || !(s = get_block(s, rot, 9)) || !(s = get_block(s, v, words + nct)))
			return -1;
		if (i < CHAN_MAX_FLYSTICKS)
			d->fly_seen[i]++;
		if (i >= d->n_fly) {
			d->ignored++;
			continue;
		}
		if (h[1] < 0) {
			d->untracked++;
			continue;
		}
		/* the first button word is a 32-bit integer (a Flystick has at most 32 buttons we keep) */
		if (!body_pose(loc, rot, &smp[i]) ||
		    (words && !(v[0] >= 0 && v[0] <= UINT32_MAX && v[0] == floor(v[0])))) {
			d->c.malformed++;
			continue;
		}
		smp[i].buttons = words ? (uint32_t)v[0] : 0;
		if (nbt < 32)
			smp[i].buttons &= (1u << nbt) - 1;
		for (int k = 0; k < SENSOR_ANALOG_MAX; k++) {
			double a = k < nct ? v[words + k] : 0;

			smp[i].analog[k] = (float)(a < -1 ? -1 : a > 1 ? 1 : a);
		}
		smp[i].inputs = true;
		smp[i].t_ns = t_ns;
		ok[i] = true;
	}
	if (*skip_ws(s))
		return -1;
	for (int i = 0; i < (int)n && i < d->n_fly; i++)
		if (ok[i]) {
			emit(ctx, d->n_bodies + i, &smp[i]);
			got++;
		}
	return got;
}

static int dt_feed(void *st, const uint8_t *buf, size_t len, device_emit_fn *emit, void *ctx)
{
	struct dtrack_codec_st *d = st;
	uint64_t t_ns = 0, now = real_ns();
	char *line, *save = NULL;
	int got = 0;

	if (len > DTRACK_MAX_DATAGRAM) {
		d->c.malformed++;
		return -EMSGSIZE;
	}
	memcpy(d->text, buf, len);
	d->text[len] = '\0';
	if (strlen(d->text) != len) {
		d->c.malformed++; /* a NUL inside: not DTrack's text */
		return -EBADMSG;
	}
	d->frames++;
	for (line = strtok_r(d->text, "\r\n", &save); line; line = strtok_r(NULL, "\r\n", &save)) {
		const char *s = skip_ws(line);
		int rc = 0;

		if (!*s)
			continue;
		if (!strncmp(s, "fr ", 3)) {
			long fr;

			if (!get_int(s + 3, &fr) || fr < 0 || fr > 0xffffffffl) {
				rc = -1;
			} else {
				uint32_t f = (uint32_t)fr;

				/* frames DTrack numbered that never came (a restart counts from anew) */
				if (d->have_frame && f > d->frame && f - d->frame < 100000)
					d->c.lost += f - d->frame - 1;
				d->frame = f;
				d->have_frame = true;
			}
		} else if (!strncmp(s, "ts ", 3)) {
			char *end;
			double ts = strtod(s + 3, &end);

			if (end == s + 3 || !isfinite(ts) || ts < 0 || ts > 86401 || *skip_ws(end))
				rc = -1;
			else
				t_ns = timemap_map(&d->tm, ts_to_ns(ts, now), now);
		} else if (!strncmp(s, "6dcal ", 6)) {
			long n;

			if (!get_int(s + 6, &n) || n < 0 || n > 1000000)
				rc = -1;
			else
				d->calibrated = (int)n;
		} else if (!strncmp(s, "6d ", 3)) {
			rc = line_6d(d, s + 3, t_ns, emit, ctx);
		} else if (!strncmp(s, "6df2 ", 5)) {
			rc = line_6df2(d, s + 5, t_ns, emit, ctx);
		} else {
			/* another kind of line (3d, gl, 6di ...: a word of a-z and 0-9, then its data) */
			size_t w = strspn(s, "abcdefghijklmnopqrstuvwxyz0123456789");
			static const char *const ours[] = { "fr", "ts", "6dcal", "6d", "6df2" };

			if (!w || (s[w] && s[w] != ' ' && s[w] != '\t'))
				rc = -1;
			for (size_t k = 0; k < sizeof(ours) / sizeof(ours[0]); k++)
				if (strlen(ours[k]) == w && !strncmp(s, ours[k], w))
					rc = -1; /* ours, without its data */
			if (!rc)
				d->other++;
		}
		if (rc < 0)
			d->c.malformed++;
		else
			got += rc;
	}
	d->c.reports++;
	return got;
}

const struct device_codec dtrack_codec = {
	.name = "dtrack",
	.size = sizeof(struct dtrack_codec_st),
	.init = dt_init,
	.reset = dt_reset,
	.feed = dt_feed,
	.period = dt_period,
};

/* ---- the device thread ------------------------------------------------------------------ */

struct dtrack {
	struct device dev; /* first: the device_drv_* entries reach it through t->priv */
	int fd;
	uint8_t buf[DTRACK_MAX_DATAGRAM + 1];
	_Atomic uint64_t datagrams, silences;
};

static int dt_socket(const struct cfg_source *src, char *err, size_t errlen)
{
	const struct dtrack_opts *cfg = opts_of(src);
	struct addrinfo hints = { .ai_socktype = SOCK_DGRAM, .ai_flags = AI_NUMERICSERV | AI_PASSIVE }, *ai;
	char port[8];
	int fd, one = 1, rcv = 1 << 20, rc;

	snprintf(port, sizeof(port), "%d", cfg->port);
	rc = getaddrinfo(cfg->address[0] ? cfg->address : NULL, port, &hints, &ai);
	if (rc) {
		snprintf(err, errlen, "[source %s] address: %s: %s", src->name, cfg->address, gai_strerror(rc));
		return -EINVAL;
	}
	fd = socket(ai->ai_family, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
	if (fd < 0 || setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof(one)) ||
	    bind(fd, ai->ai_addr, ai->ai_addrlen)) {
		rc = -errno;
		snprintf(err, errlen, "[source %s]: UDP %s port %d: %s", src->name, cfg->address, cfg->port,
			 strerror(errno));
		if (fd >= 0)
			close(fd);
		freeaddrinfo(ai);
		return rc;
	}
	setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &rcv, sizeof(rcv));
	if (ai->ai_family == AF_INET && IN_MULTICAST(ntohl(((struct sockaddr_in *)ai->ai_addr)->sin_addr.s_addr))) {
		struct ip_mreq m = { .imr_multiaddr = ((struct sockaddr_in *)ai->ai_addr)->sin_addr };

		m.imr_interface.s_addr = htonl(INADDR_ANY);
		if (setsockopt(fd, IPPROTO_IP, IP_ADD_MEMBERSHIP, &m, sizeof(m))) {
			rc = -errno;
			snprintf(err, errlen, "[source %s]: joining %s: %s", src->name, cfg->address, strerror(errno));
			close(fd);
			freeaddrinfo(ai);
			return rc;
		}
	}
	freeaddrinfo(ai);
	return fd;
}

static void dt_run(struct device *dv)
{
	struct dtrack *d = dv->drv;
	const struct dtrack_opts *cfg = opts_of(dv->t->cfg);
	uint64_t timeout = (uint64_t)(cfg->timeout_ms * 1e6), last = 0;
	bool up = false, ever = false;

	device_set_status(dv, "waiting for DTrack frames on UDP %s port %d", cfg->address, cfg->port);
	while (!device_stopping(dv)) {
		struct pollfd p = { d->fd, POLLIN, 0 };
		uint64_t now;

		if (poll(&p, 1, 20) > 0) {
			/* a bounded batch, then the clock and the stop flag again */
			for (int k = 0; k < 64; k++) {
				ssize_t n = recv(d->fd, d->buf, sizeof(d->buf), MSG_DONTWAIT | MSG_TRUNC);

				if (n < 0)
					break;
				atomic_fetch_add_explicit(&d->datagrams, 1, memory_order_relaxed);
				last = mono_ns();
				if (!up) {
					up = true;
					if (ever)
						ctr_add(&dv->t->st.reconnects, 1);
					ever = true;
					device_set_link(dv, DEVICE_UP);
					device_set_status(dv, "DTrack frames arriving on UDP %s port %d", cfg->address,
							  cfg->port);
					device_note(dv, LOG_INFO, "[source %s] DTrack frames arriving on port %d",
						    dv->t->name, cfg->port);
				}
				if ((size_t)n > DTRACK_MAX_DATAGRAM) {
					/* cut by our buffer: a frame longer than any DTrack sends */
					ctr_add(&dv->t->st.malformed, 1);
					continue;
				}
				device_feed(dv, d->buf, (size_t)n);
			}
		}
		now = mono_ns();
		if (up && now - last > timeout) {
			up = false;
			atomic_fetch_add_explicit(&d->silences, 1, memory_order_relaxed);
			device_set_link(dv, DEVICE_DOWN);
			device_set_status(dv, "no DTrack frame on UDP port %d for %.0f ms; waiting", cfg->port,
					  cfg->timeout_ms);
			device_note(dv, LOG_WARNING, "[source %s] no DTrack frame for %.0f ms", dv->t->name,
				    cfg->timeout_ms);
		}
	}
}

/* ---- the driver ------------------------------------------------------------------------ */

static int dt_sensor_count(const struct cfg_source *cfg)
{
	return opts_of(cfg)->sensors + opts_of(cfg)->flysticks;
}

/* the default name of sensor i: its body id, or fN */
static void dt_default_name(const struct dtrack_opts *o, int i, char *buf, size_t len)
{
	if (i < o->sensors)
		snprintf(buf, len, "%d", i);
	else
		snprintf(buf, len, "f%d", i - o->sensors);
}

static void dt_sensor_name(const struct cfg_source *cfg, int i, char *buf, size_t len)
{
	const struct dtrack_opts *o = opts_of(cfg);
	char key[32], def[16];
	const char *v;

	dt_default_name(o, i, def, sizeof(def));
	snprintf(key, sizeof(key), "sensor.%s", def);
	v = chan_value(o->names, CHAN_MAX + CHAN_MAX_FLYSTICKS, key);
	snprintf(buf, len, "%s", v ? v : def);
}

/* "art/3" is body 3 and "art/f0" Flystick 0, whatever sensor.N named them */
static int dt_sensor_alias(const struct cfg_source *cfg, const char *name)
{
	const struct dtrack_opts *o = opts_of(cfg);
	char def[16];

	for (int i = 0; i < o->sensors + o->flysticks; i++) {
		dt_default_name(o, i, def, sizeof(def));
		if (!strcmp(def, name))
			return i;
	}
	return -1;
}

static int dt_check(const struct config *c, const void *section, const char **key, char *err, size_t errlen)
{
	const struct cfg_source *cfg = section;
	const struct dtrack_opts *o = opts_of(cfg);

	*key = "flysticks";
	if (o->sensors + o->flysticks > DEVICE_MAX_SENSORS) {
		snprintf(err, errlen, "sensors + flysticks: %d sensors, more than %d", o->sensors + o->flysticks,
			 DEVICE_MAX_SENSORS);
		return -1;
	}
	if (chan_check(cfg, o->names, CHAN_MAX + CHAN_MAX_FLYSTICKS, o->sensors, o->flysticks, 0, key, err, errlen))
		return -1;
	return device_check(c, section, key, err, errlen);
}

static int dt_open(struct tracker *t, char *err, size_t errlen)
{
	int rc = device_drv_open(t, sizeof(struct dtrack), &dtrack_codec, t->n_sensors, err, errlen);
	struct dtrack *d = t->priv;
	int fd = -1;

	if (rc)
		return rc;
	if (!opts_of(t->cfg)->dev.capture[0]) {
		fd = dt_socket(t->cfg, err, errlen);
		if (fd < 0) {
			device_drv_close(t);
			return fd;
		}
	}
	d->fd = fd;
	rc = device_drv_start(t, dt_run, "agw-dtrack", err, errlen);
	if (rc && fd >= 0)
		close(fd);
	return rc;
}

static void dt_close(struct tracker *t)
{
	struct dtrack *d = t->priv;
	int fd = d ? d->fd : -1;

	device_drv_close(t); /* the thread joined first: the socket is no longer read */
	if (fd >= 0)
		close(fd);
}

_Static_assert(offsetof(struct dtrack, dev) == 0, "struct dtrack begins with its struct device");

static void dt_report(struct tracker *t, FILE *out, bool json)
{
	struct dtrack *d = t->priv;
	unsigned long long n, sil;

	if (!d)
		return;
	n = atomic_load_explicit(&d->datagrams, memory_order_relaxed);
	sil = atomic_load_explicit(&d->silences, memory_order_relaxed);
	if (json)
		fprintf(out, ",\"datagrams\":%llu,\"silences\":%llu", n, sil);
	else
		fprintf(out, "%llu datagrams, %llu silences", n, sil);
}

static const struct cfg_key dtrack_keys[] = {
	{ .name = "port",
	  .kind = CFG_INT,
	  CFG_AT(struct dtrack_opts, port),
	  .min = 1,
	  .max = 65535,
	  .def = "5000",
	  .doc = "UDP port DTrack sends its frames to (its output settings)" },
	{ .name = "address",
	  .kind = CFG_STR,
	  CFG_AT(struct dtrack_opts, address),
	  .def = "0.0.0.0",
	  .doc = "local address to receive on (0.0.0.0: every IPv4 interface, ::: every interface); a multicast "
		 "group (224.0.0.0/4) is joined" },
	{ .name = "sensors",
	  .kind = CFG_INT,
	  CFG_AT(struct dtrack_opts, sensors),
	  .min = 1,
	  .max = CHAN_MAX,
	  .def = "8",
	  .doc = "body ids taken, 0 to N-1 (the ids of DTrack's data, which its user interface numbers from 1): "
		 "sensors named by their id (SOURCE/0, ...) unless sensor.N names them; other bodies are counted and "
		 "dropped" },
	{ .name = "flysticks",
	  .kind = CFG_INT,
	  CFG_AT(struct dtrack_opts, flysticks),
	  .min = 0,
	  .max = CHAN_MAX_FLYSTICKS,
	  .def = "1",
	  .doc = "Flysticks taken (6df2 ids 0 to N-1): sensors f0, f1, ... with their buttons and joystick" },
	{ .name = "sensor.N",
	  .kind = CFG_PER,
	  CFG_AT(struct dtrack_opts, names),
	  .max = CHAN_MAX + CHAN_MAX_FLYSTICKS,
	  .def = "",
	  .doc = "a name for body N (sensor.fN: Flystick N): sensor.1 = glasses makes SOURCE/glasses (SOURCE/1 "
		 "still works); one key per body" },
	{ .name = "timeout_ms",
	  .kind = CFG_DOUBLE,
	  CFG_AT(struct dtrack_opts, timeout_ms),
	  .min = 50,
	  .max = 60000,
	  .def = "500",
	  .unit = "ms",
	  .doc = "no frame for this long: the source is FAULTY until the next one" },
};

const struct tracker_driver dtrack_driver = {
	.type = { CFG_TYPE("dtrack", "ART DTrack2/DTRACK3 frames over UDP: bodies (6d) and Flysticks (6df2)",
			   dtrack_keys, struct dtrack_opts),
		  DEVICE_CAPTURE_KEYS, .check = dt_check, .sensor_count = dt_sensor_count,
		  .sensor_name = dt_sensor_name, .sensor_alias = dt_sensor_alias },
	.open = dt_open,
	.close = dt_close,
	.poll = device_drv_poll,
	.fd = device_drv_fd,
	.report = dt_report,
	.status = device_drv_status,
	.note = device_drv_note,
};
