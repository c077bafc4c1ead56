// SPDX-License-Identifier: MIT
/*
 * avatargw-dump - subscribes to avatargw's protocol (docs/PROTOCOL.md) and
 * prints what arrives as JSON lines, or once a second per avatar the
 * statistics of the stream (rate, loss, reordering, latency).
 *
 *   avatargw-dump [--udp [ADDR:]PORT [--interface IF] | --tcp HOST:PORT | --unix PATH]
 *                 [--count N] [--timeout SECONDS] [--stats] [--describe] [--avatar ID]
 *
 * One message per datagram on UDP; on TCP and Unix stream sockets every
 * message is preceded by its length (u32, little-endian) and may arrive in
 * pieces. Malformed input is counted, never trusted. Exit status: 0 after
 * --count frames or on SIGINT/SIGTERM, 1 on a timeout, a closed stream or
 * an error, 2 on a usage error.
 *
 * Needs _GNU_SOURCE (the Makefile defines it): signalfd, struct ip_mreqn.
 */
#include <arpa/inet.h>
#include <errno.h>
#include <getopt.h>
#include <ifaddrs.h>
#include <inttypes.h>
#include <math.h>
#include <net/if.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/udp.h>
#include <poll.h>
#include <signal.h>
#include <stddef.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/signalfd.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <time.h>
#include <unistd.h>

#include "avatargw/wire.h"

#define DUMP_MAX_AVATARS 64
#define DUMP_MAX_SITES 32     /* remote sites whose figures --stats prints */
#define DUMP_LAT_SAMPLES 8192 /* per avatar and interval; a reservoir beyond */
#define DUMP_SEQ_WINDOW 64    /* sequence numbers remembered behind the newest */
#define DUMP_UDP_BATCH 64     /* datagrams read per wake-up before timers are checked */
/* the longest message a header can announce: larger stream lengths mean lost framing */
#define DUMP_STREAM_MAX (2 * 0xffff)
#define DUMP_NS 1000000000LL

enum dump_transport {
	DUMP_UDP,
	DUMP_TCP,
	DUMP_UNIX,
};

struct dump_opts {
	enum dump_transport transport;
	const char *addr; /* --udp, --tcp or --unix argument */
	const char *iface;
	unsigned long count; /* FRAMEs to print, 0: no limit */
	double timeout_s;    /* 0: wait forever */
	bool stats;
	bool describe;
	long avatar; /* -1: every avatar */
};

/* FRAME sequence tracking of one avatar, reset by a new source_id */
struct dump_seq {
	bool init;
	uint32_t source;
	uint32_t newest;
	uint64_t seen; /* bit i: newest - i has arrived */
};

struct dump_count {
	uint64_t frames, lost, reordered, duplicate, stale, held;
};

struct dump_avatar {
	bool used;
	uint16_t id;
	struct dump_seq seq;
	struct dump_count iv; /* this interval */
	struct dump_count total;
	uint64_t restarts;
	/* latency of this interval, milliseconds */
	uint64_t lat_n;
	double lat_sum, lat_max;
	float lat[DUMP_LAT_SAMPLES];
};

struct dump {
	struct dump_opts o;
	int fd, sfd;
	/* stream reassembly */
	uint8_t *sbuf;
	size_t shave;
	/* counters */
	uint64_t frames_out;   /* FRAMEs that passed the filter */
	uint64_t malformed;    /* total */
	uint32_t kernel_drops; /* SO_RXQ_OVFL: datagrams the socket dropped, total */
	uint64_t coalesced;    /* datagrams that came several to a buffer (UDP_GRO), total */
	uint32_t errs_told;    /* bit e: decode error e was reported on stderr */
	int64_t last_rx_mono;  /* last accepted message */
	int64_t iv_start_mono;
	uint64_t rng;
	struct dump_avatar av[DUMP_MAX_AVATARS];
	struct wire_site site[DUMP_MAX_SITES]; /* the newest figures of each remote site, from DESCRIBEs */
	uint64_t untracked;		       /* FRAMEs of avatars beyond DUMP_MAX_AVATARS */
};

/* ---- time ----------------------------------------------------------------------- */

static int64_t dump_now(clockid_t clk)
{
	struct timespec ts;

	clock_gettime(clk, &ts);
	return (int64_t)ts.tv_sec * DUMP_NS + ts.tv_nsec;
}

/* ---- JSON --------------------------------------------------------------------- */

/* %.9g round-trips every float; NaN and infinities are not JSON: null */
static void dump_json_f(float v)
{
	if (isfinite(v))
		printf("%.9g", (double)v);
	else
		fputs("null", stdout);
}

static void dump_json_fv(const float *v, int n)
{
	putchar('[');
	for (int i = 0; i < n; i++) {
		if (i)
			putchar(',');
		dump_json_f(v[i]);
	}
	putchar(']');
}

/* length of the well-formed UTF-8 sequence at s (at most n bytes), 0 if none */
static size_t dump_utf8_len(const unsigned char *s, size_t n)
{
	size_t len;
	uint32_t cp;

	if (s[0] < 0x80)
		return 1;
	if (s[0] >= 0xc2 && s[0] <= 0xdf) {
		len = 2;
		cp = s[0] & 0x1f;
	} else if (s[0] >= 0xe0 && s[0] <= 0xef) {
		len = 3;
		cp = s[0] & 0x0f;
	} else if (s[0] >= 0xf0 && s[0] <= 0xf4) {
		len = 4;
		cp = s[0] & 0x07;
	} else {
		return 0;
	}
	if (len > n)
		return 0;
	for (size_t i = 1; i < len; i++) {
		if ((s[i] & 0xc0) != 0x80)
			return 0;
		cp = cp << 6 | (s[i] & 0x3f);
	}
	/* overlong forms, surrogates, beyond U+10FFFF */
	if ((len == 3 && cp < 0x800) || (len == 4 && cp < 0x10000) || (cp >= 0xd800 && cp <= 0xdfff) || cp > 0x10ffff)
		return 0;
	return len;
}

/* a string from the wire: escaped, invalid UTF-8 replaced by U+FFFD */
static void dump_json_s(const char *str)
{
	const unsigned char *s = (const unsigned char *)str;
	size_t n = strlen(str);

	putchar('"');
	while (n) {
		size_t len = dump_utf8_len(s, n);

		if (!len) {
			fputs("\\ufffd", stdout);
			len = 1;
		} else if (*s == '"' || *s == '\\') {
			printf("\\%c", *s);
		} else if (*s < 0x20 || *s == 0x7f) {
			printf("\\u%04x", *s);
		} else {
			fwrite(s, 1, len, stdout);
		}
		s += len;
		n -= len;
	}
	putchar('"');
}

static const char *dump_state_name(uint8_t state)
{
	switch (state) {
	case WIRE_SENSOR_OK:
		return "OK";
	case WIRE_SENSOR_STALE:
		return "STALE";
	case WIRE_SENSOR_MISSING:
		return "MISSING";
	default:
		return NULL;
	}
}

static void dump_json_flags(uint16_t flags)
{
	static const char *const names[] = { "STALE", "UNREACHED", "HELD", "NEW_SAMPLE", "INPUTS" };
	bool first = true;

	putchar('[');
	for (int b = 0; b < 16; b++) {
		if (!(flags & 1u << b))
			continue;
		if (!first)
			putchar(',');
		first = false;
		if (b < (int)(sizeof(names) / sizeof(names[0])))
			printf("\"%s\"", names[b]);
		else
			printf("\"bit%d\"", b); /* a flag of a later revision */
	}
	putchar(']');
}

/* rx_ns: when the message arrived (the kernel's receive time on UDP), CLOCK_REALTIME */
static void dump_print_frame(const struct wire_frame *f, int64_t rx_ns)
{
	const struct wire_header *h = &f->h;

	printf("{\"type\":\"frame\",\"source\":%" PRIu32 ",\"avatar\":%u,\"seq\":%" PRIu32 ",\"t_ns\":%" PRIu64
	       ",\"rx_ns\":%" PRId64 ",\"rev\":%" PRIu32 ",\"flags\":",
	       h->source_id, h->avatar_id, h->seq, h->sample_time_ns, rx_ns, h->describe_rev);
	dump_json_flags(h->flags);
	fputs(",\"sensors\":[", stdout);
	for (int i = 0; i < WIRE_SENSORS; i++) {
		const struct wire_sensor_sample *s = &f->sensor[i];
		const char *state = dump_state_name(s->state);

		printf("%s{\"name\":\"%s\",\"state\":", i ? "," : "", wire_sensor_names[i]);
		if (state)
			printf("\"%s\"", state);
		else
			printf("\"state%u\"", s->state);
		printf(",\"age_ms\":%.1f,\"p\":", s->age_100us / 10.0);
		dump_json_fv(s->pose.p, 3);
		fputs(",\"q\":", stdout);
		dump_json_fv(s->pose.q, 4);
		putchar('}');
	}
	fputs("],\"arms\":[", stdout);
	for (int i = 0; i < WIRE_ARMS; i++) {
		const struct wire_arm_result *a = &f->arm[i];

		printf("%s{\"side\":\"%s\",\"ik_flags\":%u,\"iters\":%u,\"pos_err\":", i ? "," : "",
		       i == WIRE_ARM_RIGHT ? "right" : "left", a->ik_flags, a->iters);
		dump_json_f(a->pos_err);
		putchar('}');
	}
	fputs("],\"joints\":{", stdout);
	for (int i = 0; i < WIRE_JOINTS; i++) {
		printf("%s\"%s\":", i ? "," : "", wire_joint_names[i]);
		dump_json_f(f->joint[i]);
	}
	fputs("},\"segments\":{", stdout);
	for (int i = 0; i < WIRE_SEGMENTS; i++) {
		printf("%s\"%s\":{\"p\":", i ? "," : "", wire_segment_names[i]);
		dump_json_fv(f->segment[i].p, 3);
		fputs(",\"q\":", stdout);
		dump_json_fv(f->segment[i].q, 4);
		putchar('}');
	}
	putchar('}');
	if (h->flags & WIRE_F_INPUTS) {
		bool first = true;

		/* the sensors with buttons and analog values (a Hydra wand: joystick x, y, trigger) */
		fputs(",\"inputs\":[", stdout);
		for (int i = 0; i < WIRE_SENSORS; i++) {
			if (!(f->in.present & 1u << i))
				continue;
			printf("%s{\"sensor\":\"%s\",\"buttons\":%" PRIu32 ",\"analog\":", first ? "" : ",",
			       wire_sensor_names[i], f->in.buttons[i]);
			dump_json_fv(f->in.analog[i], WIRE_ANALOG);
			putchar('}');
			first = false;
		}
		putchar(']');
	}
	fputs("}\n", stdout);
}

static void dump_json_site(const struct wire_site *ws)
{
	fputs("\"name\":", stdout);
	dump_json_s(ws->name);
	printf(",\"state\":\"%s\",\"avatars\":%u,\"rate_hz\":%.2f,\"frames\":%" PRIu32 ",\"lost\":%" PRIu32,
	       ws->state ? "gone" : "present", ws->avatars, (double)ws->rate_hz, ws->frames, ws->lost);
	if (ws->delay_p50_ms >= 0)
		printf(",\"delay_ms\":{\"p50\":%.3f,\"p99\":%.3f}", (double)ws->delay_p50_ms, (double)ws->delay_p99_ms);
	else
		fputs(",\"delay_ms\":null", stdout);
	if (ws->rtt_ms >= 0)
		printf(",\"clock_offset_ms\":%.3f,\"rtt_ms\":%.3f", (double)ws->clock_offset_ms, (double)ws->rtt_ms);
	else
		fputs(",\"clock_offset_ms\":null,\"rtt_ms\":null", stdout);
}

static void dump_print_describe(const struct wire_describe *d)
{
	const struct wire_header *h = &d->h;

	printf("{\"type\":\"describe\",\"source\":%" PRIu32 ",\"avatar\":%u,\"seq\":%" PRIu32 ",\"rev\":%" PRIu32
	       ",\"rate_hz\":",
	       h->source_id, h->avatar_id, h->seq, h->describe_rev);
	dump_json_f(d->rate_hz);
	fputs(",\"dims\":", stdout);
	dump_json_fv(d->dims, 4);
	fputs(",\"head_offset\":", stdout);
	dump_json_fv(d->head_offset, 3);
	fputs(",\"name\":", stdout);
	dump_json_s(d->avatar_name);
	fputs(",\"conventions\":", stdout);
	dump_json_s(d->conventions);
	fputs(",\"joints\":[", stdout);
	for (int i = 0; i < WIRE_JOINTS; i++) {
		const struct wire_joint_desc *j = &d->joint[i];

		fputs(i ? ",{\"name\":" : "{\"name\":", stdout);
		dump_json_s(j->name);
		printf(",\"segment\":%u,\"lo\":", j->segment);
		dump_json_f(j->lo);
		fputs(",\"hi\":", stdout);
		dump_json_f(j->hi);
		fputs(",\"axis\":", stdout);
		dump_json_fv(j->axis, 3);
		fputs(",\"trans\":", stdout);
		dump_json_fv(j->trans, 3);
		putchar('}');
	}
	fputs("],\"segments\":[", stdout);
	for (int i = 0; i < WIRE_SEGMENTS; i++) {
		fputs(i ? ",{\"name\":" : "{\"name\":", stdout);
		dump_json_s(d->segment[i].name);
		if (d->segment[i].parent == 255)
			fputs(",\"parent\":null}", stdout);
		else
			printf(",\"parent\":%u}", d->segment[i].parent);
	}
	fputs("],\"sensors\":[", stdout);
	for (int i = 0; i < WIRE_SENSORS; i++) {
		if (i)
			putchar(',');
		dump_json_s(d->sensor[i]);
	}
	putchar(']');
	if (d->site.present) {
		fputs(",\"site\":{", stdout);
		dump_json_site(&d->site);
		putchar('}');
	}
	fputs("}\n", stdout);
}

/* ---- statistics ------------------------------------------------------------------ */

static struct dump_avatar *dump_avatar_get(struct dump *d, uint16_t id)
{
	for (int i = 0; i < DUMP_MAX_AVATARS; i++) {
		struct dump_avatar *a = &d->av[i];

		if (a->used && a->id == id)
			return a;
		if (!a->used) {
			a->used = true;
			a->id = id;
			return a;
		}
	}
	return NULL;
}

/*
 * Sequence numbers are per avatar and type, +1 per FRAME, wrapping: compare
 * them as differences. A jump forward opens a gap (lost); a late arrival
 * that fills a remembered gap is reordered and no longer lost; one already
 * seen is a duplicate. A new source_id (the daemon restarted) starts over.
 */
static void dump_seq_update(struct dump_avatar *a, uint32_t source, uint32_t seq)
{
	struct dump_seq *s = &a->seq;
	uint32_t ahead = seq - s->newest, behind = s->newest - seq;

	if (!s->init || s->source != source) {
		if (s->init)
			a->restarts++;
		s->init = true;
		s->source = source;
		s->newest = seq;
		s->seen = 1;
		return;
	}
	if (ahead && ahead < 0x80000000u) {
		uint64_t gap = ahead - 1;

		a->iv.lost += gap;
		a->total.lost += gap;
		s->seen = ahead >= DUMP_SEQ_WINDOW ? 1 : s->seen << ahead | 1;
		s->newest = seq;
	} else if (!ahead || (behind < DUMP_SEQ_WINDOW && (s->seen >> behind & 1))) {
		a->iv.duplicate++;
		a->total.duplicate++;
	} else {
		a->iv.reordered++;
		a->total.reordered++;
		if (behind < DUMP_SEQ_WINDOW) {
			/* it filled a gap counted as lost (in this interval or before) */
			s->seen |= 1ull << behind;
			if (a->iv.lost)
				a->iv.lost--;
			if (a->total.lost)
				a->total.lost--;
		}
	}
}

static uint64_t dump_rand(struct dump *d)
{
	d->rng ^= d->rng << 13;
	d->rng ^= d->rng >> 7;
	d->rng ^= d->rng << 17;
	return d->rng;
}

static void dump_stats_frame(struct dump *d, const struct wire_frame *f, int64_t rx_ns)
{
	struct dump_avatar *a = dump_avatar_get(d, f->h.avatar_id);
	double ms;

	if (!a) {
		d->untracked++;
		return;
	}
	a->iv.frames++;
	a->total.frames++;
	if (f->h.flags & WIRE_F_STALE) {
		a->iv.stale++;
		a->total.stale++;
	}
	if (f->h.flags & WIRE_F_HELD) {
		a->iv.held++;
		a->total.held++;
	}
	dump_seq_update(a, f->h.source_id, f->h.seq);
	if (!f->h.sample_time_ns)
		return;
	/* modulo 2^64, then signed: any sample time from the wire, no overflow */
	ms = (double)(int64_t)((uint64_t)rx_ns - f->h.sample_time_ns) / 1e6;
	a->lat_sum += ms;
	if (!a->lat_n || ms > a->lat_max)
		a->lat_max = ms;
	if (a->lat_n < DUMP_LAT_SAMPLES) {
		a->lat[a->lat_n] = (float)ms;
	} else {
		/* reservoir sampling: every sample equally likely to be kept */
		uint64_t j = dump_rand(d) % (a->lat_n + 1);

		if (j < DUMP_LAT_SAMPLES)
			a->lat[j] = (float)ms;
	}
	a->lat_n++;
}

static int dump_cmp_float(const void *x, const void *y)
{
	float a = *(const float *)x, b = *(const float *)y;

	return (a > b) - (a < b);
}

/* nearest rank of a sorted array */
static double dump_pct(const float *v, size_t n, double p)
{
	size_t k = (size_t)ceil(p * (double)n);

	return v[k ? k - 1 : 0];
}

static void dump_json_count(const struct dump_count *c)
{
	printf("\"frames\":%" PRIu64 ",\"lost\":%" PRIu64 ",\"reordered\":%" PRIu64 ",\"duplicate\":%" PRIu64
	       ",\"stale\":%" PRIu64 ",\"held\":%" PRIu64,
	       c->frames, c->lost, c->reordered, c->duplicate, c->stale, c->held);
}

/* a remote avatar's DESCRIBE: its site's figures replace the ones held (--stats prints them) */
static void dump_site_take(struct dump *d, const struct wire_site *ws)
{
	int i = 0;

	while (i < DUMP_MAX_SITES && d->site[i].present && strcmp(d->site[i].name, ws->name))
		i++;
	if (i < DUMP_MAX_SITES)
		d->site[i] = *ws;
}

/* one line per avatar for the interval that ends now, then a new interval */
static void dump_stats_print(struct dump *d, bool final)
{
	int64_t now = dump_now(CLOCK_MONOTONIC);
	double secs = (double)(now - d->iv_start_mono) / 1e9;
	bool any = false;

	for (int i = 0; i < DUMP_MAX_AVATARS && d->av[i].used; i++) {
		struct dump_avatar *a = &d->av[i];
		size_t kept = a->lat_n < DUMP_LAT_SAMPLES ? (size_t)a->lat_n : DUMP_LAT_SAMPLES;

		any = true;
		printf("{\"type\":\"stats\",\"avatar\":%u,\"source\":%" PRIu32 ",\"interval_s\":%.3f,\"rate_hz\":%.2f,",
		       a->id, a->seq.source, secs, secs > 0 ? (double)a->iv.frames / secs : 0.0);
		dump_json_count(&a->iv);
		if (kept) {
			qsort(a->lat, kept, sizeof(a->lat[0]), dump_cmp_float);
			printf(",\"latency_ms\":{\"mean\":%.3f,\"p50\":%.3f,\"p99\":%.3f,\"max\":%.3f}",
			       a->lat_sum / (double)a->lat_n, dump_pct(a->lat, kept, 0.5), dump_pct(a->lat, kept, 0.99),
			       a->lat_max);
		} else {
			fputs(",\"latency_ms\":null", stdout);
		}
		fputs(",\"total\":{", stdout);
		dump_json_count(&a->total);
		printf(",\"restarts\":%" PRIu64 "},\"malformed\":%" PRIu64 ",\"kernel_drops\":%" PRIu32
		       ",\"coalesced\":%" PRIu64,
		       a->restarts, d->malformed, d->kernel_drops, d->coalesced);
		if (d->untracked) /* FRAMEs of avatars beyond the table: counted, not analysed */
			printf(",\"untracked\":%" PRIu64, d->untracked);
		fputs(final ? ",\"final\":true}\n" : "}\n", stdout);
		memset(&a->iv, 0, sizeof(a->iv));
		a->lat_n = 0;
		a->lat_sum = a->lat_max = 0;
	}
	for (int i = 0; i < DUMP_MAX_SITES && d->site[i].present; i++) {
		/* each remote site as the daemon measures its samples' arrival */
		fputs("{\"type\":\"site\",", stdout);
		dump_json_site(&d->site[i]);
		fputs(final ? ",\"final\":true}\n" : "}\n", stdout);
	}
	if (!any)
		printf("{\"type\":\"stats\",\"avatar\":null,\"interval_s\":%.3f,\"rate_hz\":0,\"malformed\":%" PRIu64
		       ",\"kernel_drops\":%" PRIu32 ",\"coalesced\":%" PRIu64 "%s}\n",
		       secs, d->malformed, d->kernel_drops, d->coalesced, final ? ",\"final\":true" : "");
	d->iv_start_mono = now;
}

/* ---- messages ---------------------------------------------------------------------- */

static void dump_malformed(struct dump *d, int err)
{
	d->malformed++;
	/* say what is wrong once per kind, the counter says how often */
	if (-err < 32 && !(d->errs_told & 1u << -err)) {
		fprintf(stderr, "avatargw-dump: malformed message: %s (further ones only counted)\n",
			wire_strerror(err));
		d->errs_told |= 1u << -err;
	}
}

/* one whole message; rx_ns: when it arrived, CLOCK_REALTIME */
static void dump_message(struct dump *d, const uint8_t *buf, size_t len, int64_t rx_ns)
{
	static struct wire_frame f;
	static struct wire_describe desc;
	struct wire_header h;
	int type = wire_peek(buf, len, &h);
	int ret;

	if (type < 0) {
		dump_malformed(d, type);
		return;
	}
	if (d->o.avatar >= 0 && h.avatar_id != d->o.avatar)
		return;
	switch (type) {
	case WIRE_FRAME:
		ret = wire_decode_frame(buf, len, &f);
		if (ret < 0) {
			dump_malformed(d, ret);
			return;
		}
		d->frames_out++;
		if (d->o.stats)
			dump_stats_frame(d, &f, rx_ns);
		else
			dump_print_frame(&f, rx_ns);
		break;
	case WIRE_DESCRIBE:
		ret = wire_decode_describe(buf, len, &desc);
		if (ret < 0) {
			dump_malformed(d, ret);
			return;
		}
		if (desc.site.present)
			dump_site_take(d, &desc.site);
		if (d->o.describe)
			dump_print_describe(&desc);
		break;
	default:
		break; /* a message type of a later revision: skipped */
	}
	d->last_rx_mono = dump_now(CLOCK_MONOTONIC);
}

/* ---- sockets ------------------------------------------------------------------------ */

/*
 * Splits "PORT", "HOST:PORT" or "[HOST]:PORT" (IPv6). host is "" when only
 * a port is given. Returns -1 on a malformed argument.
 */
static int dump_split(const char *arg, char *host, size_t hcap, char *port, size_t pcap)
{
	const char *colon = strrchr(arg, ':'), *p;
	size_t hlen;

	if (arg[0] == '[') {
		const char *end = strchr(arg, ']');

		if (!end || end[1] != ':')
			return -1;
		hlen = (size_t)(end - arg - 1);
		arg++;
		p = end + 2;
	} else if (!colon) {
		hlen = 0;
		p = arg;
	} else {
		if (strchr(arg, ':') != colon)
			return -1; /* a bare IPv6 address: write it in brackets */
		hlen = (size_t)(colon - arg);
		p = colon + 1;
	}
	if (hlen >= hcap || !*p || strlen(p) >= pcap)
		return -1;
	memcpy(host, arg, hlen);
	host[hlen] = '\0';
	strcpy(port, p);
	return 0;
}

/* an interface by name or by one of its addresses; 0 if not found */
static unsigned dump_ifindex(const char *s)
{
	unsigned idx = if_nametoindex(s);
	struct ifaddrs *ifs, *i;
	struct in6_addr a6;
	struct in_addr a4;
	bool v6 = inet_pton(AF_INET6, s, &a6) == 1, v4 = inet_pton(AF_INET, s, &a4) == 1;

	if (idx || (!v4 && !v6) || getifaddrs(&ifs) < 0)
		return idx;
	for (i = ifs; i && !idx; i = i->ifa_next) {
		if (!i->ifa_addr)
			continue;
		if (v4 && i->ifa_addr->sa_family == AF_INET &&
		    ((struct sockaddr_in *)i->ifa_addr)->sin_addr.s_addr == a4.s_addr)
			idx = if_nametoindex(i->ifa_name);
		if (v6 && i->ifa_addr->sa_family == AF_INET6 &&
		    !memcmp(&((struct sockaddr_in6 *)i->ifa_addr)->sin6_addr, &a6, sizeof(a6)))
			idx = if_nametoindex(i->ifa_name);
	}
	freeifaddrs(ifs);
	return idx;
}

static int dump_resolve(const char *host, const char *port, int socktype, int flags, struct addrinfo **res)
{
	struct addrinfo hints = { .ai_family = AF_UNSPEC, .ai_socktype = socktype, .ai_flags = flags };
	int ret = getaddrinfo(host, port, &hints, res);

	if (ret) {
		fprintf(stderr, "avatargw-dump: %s:%s: %s\n", host, port, gai_strerror(ret));
		return -1;
	}
	return 0;
}

static int dump_join(int fd, const struct sockaddr *group, unsigned ifindex)
{
	if (group->sa_family == AF_INET) {
		struct ip_mreqn mr = { .imr_multiaddr = ((const struct sockaddr_in *)group)->sin_addr,
				       .imr_ifindex = (int)ifindex };
		int off = 0;

		/* only this group's datagrams, not those of groups other sockets joined */
		setsockopt(fd, IPPROTO_IP, IP_MULTICAST_ALL, &off, sizeof(off));
		return setsockopt(fd, IPPROTO_IP, IP_ADD_MEMBERSHIP, &mr, sizeof(mr));
	} else {
		struct ipv6_mreq mr = { .ipv6mr_multiaddr = ((const struct sockaddr_in6 *)group)->sin6_addr,
					.ipv6mr_interface = ifindex };
#ifdef IPV6_MULTICAST_ALL
		int off = 0;

		setsockopt(fd, IPPROTO_IPV6, IPV6_MULTICAST_ALL, &off, sizeof(off));
#endif
		return setsockopt(fd, IPPROTO_IPV6, IPV6_JOIN_GROUP, &mr, sizeof(mr));
	}
}

static bool dump_is_multicast(const struct sockaddr *sa)
{
	if (sa->sa_family == AF_INET)
		return IN_MULTICAST(ntohl(((const struct sockaddr_in *)sa)->sin_addr.s_addr));
	return sa->sa_family == AF_INET6 && IN6_IS_ADDR_MULTICAST(&((const struct sockaddr_in6 *)sa)->sin6_addr);
}

static int dump_open_udp(const struct dump_opts *o)
{
	char host[256], port[32];
	struct addrinfo *res;
	struct sockaddr_storage bind_to;
	unsigned ifindex = 0;
	bool mcast;
	int fd, one = 1, rcvbuf = 1 << 20;

	if (dump_split(o->addr, host, sizeof(host), port, sizeof(port)) < 0) {
		fprintf(stderr, "avatargw-dump: --udp %s: expected [ADDR:]PORT ([ADDR]:PORT for IPv6)\n", o->addr);
		return -1;
	}
	if (dump_resolve(host[0] ? host : "0.0.0.0", port, SOCK_DGRAM, AI_PASSIVE, &res) < 0)
		return -1;
	memcpy(&bind_to, res->ai_addr, res->ai_addrlen);
	mcast = dump_is_multicast(res->ai_addr);
	if (o->iface) {
		if (!mcast) {
			fprintf(stderr, "avatargw-dump: --interface needs a multicast --udp address\n");
			goto fail_res;
		}
		ifindex = dump_ifindex(o->iface);
		if (!ifindex) {
			fprintf(stderr, "avatargw-dump: --interface %s: no such interface or address\n", o->iface);
			goto fail_res;
		}
	}
	fd = socket(res->ai_family, SOCK_DGRAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
	if (fd < 0) {
		perror("avatargw-dump: socket");
		goto fail_res;
	}
	/* best effort: a deeper queue, kernel receive times, the kernel's drop counter */
	setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &rcvbuf, sizeof(rcvbuf));
	setsockopt(fd, SOL_SOCKET, SO_TIMESTAMPNS, &one, sizeof(one));
	setsockopt(fd, SOL_SOCKET, SO_RXQ_OVFL, &one, sizeof(one));
	/*
	 * Runs of equal datagrams (the daemon's segmentation offload) arrive as one
	 * buffer, split here by the size the kernel reports: on loopback the
	 * sender's kernel then does not cut them up for us (Linux 5.0; older
	 * kernels refuse, and each datagram comes alone).
	 */
	setsockopt(fd, SOL_UDP, UDP_GRO, &one, sizeof(one));
	if (mcast) {
		/* several listeners of one group on one host */
		setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof(one));
		if (res->ai_family == AF_INET6) {
			/* the group filters; binding to it would need a scope for ff02:: */
			((struct sockaddr_in6 *)&bind_to)->sin6_addr = in6addr_any;
		}
	}
	if (bind(fd, (struct sockaddr *)&bind_to, res->ai_addrlen) < 0) {
		fprintf(stderr, "avatargw-dump: bind %s: %s\n", o->addr, strerror(errno));
		goto fail_fd;
	}
	if (mcast && dump_join(fd, res->ai_addr, ifindex) < 0) {
		fprintf(stderr, "avatargw-dump: joining %s: %s\n", host, strerror(errno));
		goto fail_fd;
	}
	freeaddrinfo(res);
	return fd;

fail_fd:
	close(fd);
fail_res:
	freeaddrinfo(res);
	return -1;
}

static int dump_open_tcp(const struct dump_opts *o)
{
	char host[256], port[32];
	struct addrinfo *res, *ai;
	int fd = -1, err = 0;

	if (dump_split(o->addr, host, sizeof(host), port, sizeof(port)) < 0 || !host[0]) {
		fprintf(stderr, "avatargw-dump: --tcp %s: expected HOST:PORT ([ADDR]:PORT for IPv6)\n", o->addr);
		return -1;
	}
	if (dump_resolve(host, port, SOCK_STREAM, 0, &res) < 0)
		return -1;
	for (ai = res; ai && fd < 0; ai = ai->ai_next) {
		fd = socket(ai->ai_family, SOCK_STREAM | SOCK_CLOEXEC, 0);
		if (fd < 0) {
			err = errno;
			continue;
		}
		if (connect(fd, ai->ai_addr, ai->ai_addrlen) < 0) {
			err = errno;
			close(fd);
			fd = -1;
		}
	}
	freeaddrinfo(res);
	if (fd < 0)
		fprintf(stderr, "avatargw-dump: connect %s: %s\n", o->addr, strerror(err));
	return fd;
}

/* PATH, or @NAME for Linux's abstract namespace */
static int dump_open_unix(const struct dump_opts *o)
{
	struct sockaddr_un sa = { .sun_family = AF_UNIX };
	size_t len = strlen(o->addr);
	socklen_t alen;
	int fd;

	if (!len || len >= sizeof(sa.sun_path)) {
		fprintf(stderr, "avatargw-dump: --unix %s: empty or too long\n", o->addr);
		return -1;
	}
	memcpy(sa.sun_path, o->addr, len);
	alen = (socklen_t)(offsetof(struct sockaddr_un, sun_path) + len + 1);
	if (o->addr[0] == '@') {
		sa.sun_path[0] = '\0';
		alen--; /* no terminating NUL in an abstract name */
	}
	fd = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
	if (fd < 0) {
		perror("avatargw-dump: socket");
		return -1;
	}
	if (connect(fd, (struct sockaddr *)&sa, alen) < 0) {
		fprintf(stderr, "avatargw-dump: connect %s: %s\n", o->addr, strerror(errno));
		close(fd);
		return -1;
	}
	return fd;
}

/* ---- reading -------------------------------------------------------------------------- */

/* drains the socket (a batch at most); -1 on a fatal error */
static int dump_read_udp(struct dump *d)
{
	static uint8_t buf[65536];
	char cbuf[CMSG_SPACE(sizeof(struct timespec)) + CMSG_SPACE(sizeof(uint32_t)) + CMSG_SPACE(sizeof(int))];
	struct iovec iov = { buf, sizeof(buf) };
	struct msghdr mh = { .msg_iov = &iov, .msg_iovlen = 1, .msg_control = cbuf };

	for (int n = 0; n < DUMP_UDP_BATCH; n++) {
		int64_t rx_ns = 0;
		ssize_t len;
		size_t seg = 0;

		mh.msg_controllen = sizeof(cbuf);
		len = recvmsg(d->fd, &mh, MSG_DONTWAIT);
		if (len < 0) {
			if (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR)
				return 0;
			/* ICMP errors surface here on some setups: not fatal for a listener */
			if (errno == ECONNREFUSED)
				continue;
			perror("avatargw-dump: recvmsg");
			return -1;
		}
		for (struct cmsghdr *c = CMSG_FIRSTHDR(&mh); c; c = CMSG_NXTHDR(&mh, c)) {
			if (c->cmsg_level == SOL_UDP && c->cmsg_type == UDP_GRO) {
				int gso;

				memcpy(&gso, CMSG_DATA(c), sizeof(gso));
				seg = gso > 0 ? (size_t)gso : 0;
				continue;
			}
			if (c->cmsg_level != SOL_SOCKET)
				continue;
			if (c->cmsg_type == SCM_TIMESTAMPNS) {
				struct timespec ts;

				memcpy(&ts, CMSG_DATA(c), sizeof(ts));
				rx_ns = (int64_t)ts.tv_sec * DUMP_NS + ts.tv_nsec;
			} else if (c->cmsg_type == SO_RXQ_OVFL) {
				memcpy(&d->kernel_drops, CMSG_DATA(c), sizeof(d->kernel_drops));
			}
		}
		if (!rx_ns)
			rx_ns = dump_now(CLOCK_REALTIME);
		if (mh.msg_flags & MSG_TRUNC) {
			dump_malformed(d, -WIRE_ELONG); /* longer than any message */
		} else {
			/* coalesced datagrams: each seg bytes long, the last one perhaps shorter */
			size_t step = seg ? seg : (size_t)len;

			if (step < (size_t)len)
				d->coalesced += ((size_t)len + step - 1) / step;

			for (size_t off = 0; off < (size_t)len; off += step) {
				dump_message(d, buf + off, (size_t)len - off < step ? (size_t)len - off : step, rx_ns);
				if (d->o.count && d->frames_out >= d->o.count)
					return 0;
			}
		}
		if (d->o.count && d->frames_out >= d->o.count)
			return 0;
	}
	return 0;
}

/*
 * Appends what the stream has and hands over every complete message. A
 * message may arrive in any number of pieces; a length no header could
 * announce means the framing is lost, which is fatal.
 */
static int dump_read_stream(struct dump *d)
{
	size_t cap = 4 + DUMP_STREAM_MAX, off = 0;
	struct iovec iov = { d->sbuf + d->shave, cap - d->shave };
	struct msghdr mh = { .msg_iov = &iov, .msg_iovlen = 1 };
	ssize_t len = recvmsg(d->fd, &mh, MSG_DONTWAIT);
	int64_t rx_ns = dump_now(CLOCK_REALTIME);

	if (len < 0) {
		if (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR)
			return 0;
		perror("avatargw-dump: recvmsg");
		return -1;
	}
	if (len == 0) {
		fprintf(stderr, "avatargw-dump: %s: connection closed\n", d->o.addr);
		return -1;
	}
	d->shave += (size_t)len;
	while (d->shave - off >= 4) {
		uint32_t mlen = wire_get_len(d->sbuf + off);

		if (mlen > DUMP_STREAM_MAX) {
			fprintf(stderr, "avatargw-dump: %s: length prefix %" PRIu32 ": stream out of step\n", d->o.addr,
				mlen);
			d->malformed++;
			return -1;
		}
		if (d->shave - off < 4 + (size_t)mlen)
			break;
		dump_message(d, d->sbuf + off + 4, mlen, rx_ns);
		off += 4 + mlen;
		if (d->o.count && d->frames_out >= d->o.count)
			break;
	}
	memmove(d->sbuf, d->sbuf + off, d->shave - off);
	d->shave -= off;
	return 0;
}

/* ---- main --------------------------------------------------------------------------- */

static void dump_usage(FILE *f)
{
	fprintf(f,
		"usage: avatargw-dump [--udp [ADDR:]PORT [--interface IF] | --tcp HOST:PORT | --unix PATH]\n"
		"                     [--count N] [--timeout SECONDS] [--stats] [--describe] [--avatar ID]\n"
		"\n"
		"Prints avatargw's messages (docs/PROTOCOL.md) as JSON lines; a frame's t_ns is its\n"
		"sample time, rx_ns when it arrived (the kernel's receive time on UDP), both in\n"
		"nanoseconds of CLOCK_REALTIME.\n"
		"\n"
		"  --udp [ADDR:]PORT   listen for datagrams (default 0.0.0.0:%d); a multicast ADDR joins\n"
		"                      the group (239.255.77.70:7770, [ff15::7770]:7770)\n"
		"  --interface IF      the interface (name or address) to join the group on\n"
		"  --tcp HOST:PORT     connect to a stream endpoint (u32 LE length + message)\n"
		"  --unix PATH         the same on a Unix stream socket (@NAME: abstract)\n"
		"  --count N           exit 0 after N frames\n"
		"  --timeout SECONDS   exit 1 if no message arrives for that long (0: wait forever)\n"
		"  --stats             instead of frames, per avatar once a second and at exit: rate,\n"
		"                      loss, reordering, latency (receive time - sample time); and per\n"
		"                      remote site ([site]) its figures as the daemon measures them\n"
		"  --describe          also print DESCRIBE messages\n"
		"  --avatar ID         only this avatar\n"
		"  --help              this text\n",
		WIRE_DEFAULT_PORT);
}

static int dump_parse(int argc, char **argv, struct dump_opts *o)
{
	static const struct option longopts[] = {
		{ "udp", required_argument, NULL, 'u' },
		{ "interface", required_argument, NULL, 'i' },
		{ "tcp", required_argument, NULL, 't' },
		{ "unix", required_argument, NULL, 'x' },
		{ "count", required_argument, NULL, 'n' },
		{ "timeout", required_argument, NULL, 'T' },
		{ "stats", no_argument, NULL, 's' },
		{ "describe", no_argument, NULL, 'd' },
		{ "avatar", required_argument, NULL, 'a' },
		{ "help", no_argument, NULL, 'h' },
		{ NULL, 0, NULL, 0 },
	};
	static char default_udp[16];
	int c, transports = 0;
	char *end;

	snprintf(default_udp, sizeof(default_udp), "%d", WIRE_DEFAULT_PORT);
	*o = (struct dump_opts){ .transport = DUMP_UDP, .addr = default_udp, .avatar = -1 };
	while ((c = getopt_long(argc, argv, "u:i:t:x:n:T:sda:h", longopts, NULL)) != -1) {
		switch (c) {
		case 'u':
			o->transport = DUMP_UDP;
			o->addr = optarg;
			transports++;
			break;
		case 't':
			o->transport = DUMP_TCP;
			o->addr = optarg;
			transports++;
			break;
		case 'x':
			o->transport = DUMP_UNIX;
			o->addr = optarg;
			transports++;
			break;
		case 'i':
			o->iface = optarg;
			break;
		case 'n':
			errno = 0;
			o->count = strtoul(optarg, &end, 10);
			if (errno || *end || optarg[0] == '-' || !o->count) {
				fprintf(stderr, "avatargw-dump: --count %s: expected a positive integer\n", optarg);
				return -1;
			}
			break;
		case 'T':
			o->timeout_s = strtod(optarg, &end);
			if (*end || !(o->timeout_s >= 0) || o->timeout_s > 1e6) {
				fprintf(stderr, "avatargw-dump: --timeout %s: expected seconds >= 0\n", optarg);
				return -1;
			}
			break;
		case 's':
			o->stats = true;
			break;
		case 'd':
			o->describe = true;
			break;
		case 'a':
			errno = 0;
			o->avatar = strtol(optarg, &end, 10);
			if (errno || *end || o->avatar < 0 || o->avatar > 65535) {
				fprintf(stderr, "avatargw-dump: --avatar %s: expected 0..65535\n", optarg);
				return -1;
			}
			break;
		case 'h':
			dump_usage(stdout);
			exit(0);
		default:
			dump_usage(stderr);
			return -1;
		}
	}
	if (optind < argc || transports > 1) {
		fprintf(stderr, "avatargw-dump: %s\n", optind < argc ? "unexpected argument" : "one transport at most");
		dump_usage(stderr);
		return -1;
	}
	if (o->iface && o->transport != DUMP_UDP) {
		fprintf(stderr, "avatargw-dump: --interface goes with --udp\n");
		return -1;
	}
	return 0;
}

/* milliseconds until the next stats line or the timeout, -1: none */
static int dump_poll_timeout(const struct dump *d, int64_t now)
{
	int64_t wait = -1;

	if (d->o.stats)
		wait = d->iv_start_mono + DUMP_NS - now;
	if (d->o.timeout_s > 0) {
		int64_t t = d->last_rx_mono + (int64_t)(d->o.timeout_s * 1e9) - now;

		if (wait < 0 || t < wait)
			wait = t;
	}
	if (wait < 0)
		return d->o.stats || d->o.timeout_s > 0 ? 0 : -1;
	return (int)((wait + 999999) / 1000000); /* round up: never wake early and spin */
}

int main(int argc, char **argv)
{
	static struct dump d;
	struct pollfd pfd[2];
	sigset_t sigs;
	int status = 0;

	if (dump_parse(argc, argv, &d.o) < 0)
		return 2;
	/* SIGINT and SIGTERM arrive as data on a file descriptor beside the socket */
	sigemptyset(&sigs);
	sigaddset(&sigs, SIGINT);
	sigaddset(&sigs, SIGTERM);
	if (sigprocmask(SIG_BLOCK, &sigs, NULL) < 0 || (d.sfd = signalfd(-1, &sigs, SFD_CLOEXEC)) < 0) {
		perror("avatargw-dump: signalfd");
		return 1;
	}
	switch (d.o.transport) {
	case DUMP_UDP:
		d.fd = dump_open_udp(&d.o);
		break;
	case DUMP_TCP:
		d.fd = dump_open_tcp(&d.o);
		break;
	case DUMP_UNIX:
		d.fd = dump_open_unix(&d.o);
		break;
	}
	if (d.fd < 0)
		return 1;
	if (d.o.transport != DUMP_UDP) {
		d.sbuf = malloc(4 + DUMP_STREAM_MAX);
		if (!d.sbuf) {
			perror("avatargw-dump");
			return 1;
		}
	}
	/* one line per message, also into a pipe */
	setvbuf(stdout, NULL, _IOLBF, 0);
	d.rng = (uint64_t)dump_now(CLOCK_MONOTONIC) | 1;
	d.last_rx_mono = d.iv_start_mono = dump_now(CLOCK_MONOTONIC);
	pfd[0] = (struct pollfd){ .fd = d.fd, .events = POLLIN };
	pfd[1] = (struct pollfd){ .fd = d.sfd, .events = POLLIN };

	for (;;) {
		int64_t now = dump_now(CLOCK_MONOTONIC);
		int n = poll(pfd, 2, dump_poll_timeout(&d, now));

		if (n < 0 && errno != EINTR) {
			perror("avatargw-dump: poll");
			status = 1;
			break;
		}
		if (n > 0 && pfd[1].revents)
			break; /* SIGINT or SIGTERM: final stats, status 0 */
		if (n > 0 && pfd[0].revents) {
			int ret = d.o.transport == DUMP_UDP ? dump_read_udp(&d) : dump_read_stream(&d);

			if (ret < 0) {
				status = 1;
				break;
			}
		}
		if (d.o.count && d.frames_out >= d.o.count)
			break;
		now = dump_now(CLOCK_MONOTONIC);
		if (d.o.timeout_s > 0 && now - d.last_rx_mono >= (int64_t)(d.o.timeout_s * 1e9)) {
			fprintf(stderr, "avatargw-dump: nothing received for %g s\n", d.o.timeout_s);
			status = 1;
			break;
		}
		if (d.o.stats && now - d.iv_start_mono >= DUMP_NS)
			dump_stats_print(&d, false);
	}
	if (d.o.stats)
		dump_stats_print(&d, true);
	fflush(stdout);
	free(d.sbuf);
	close(d.fd);
	close(d.sfd);
	return status;
}
