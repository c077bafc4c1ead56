// SPDX-License-Identifier: MIT
/*
 * replay.c - plays a recorded sensor stream: a recording of the daemon
 * (docs/RECORDING.md; told by its magic), the CSV of ../shared/mocap/csv
 * (named columns; t in seconds; positions in metres; quaternions w,x,y,z;
 * world z up) or a clip compiled into the daemon (builtin:NAME).
 *
 * The whole file is read at open(), so the loop never touches the disk.
 * Both kinds become one list of events (time from the start, sensor, world
 * pose, buttons, analog values); an instant is the set of events with one
 * time (a CSV row; the samples a recording daemon took in at one poll).
 *
 * Clocked (step = no): clip time = start + speed * (now - t0); every event
 * whose time the clip time has passed is released in order (stamped with
 * the moment it was due), so nothing recorded is skipped unless the clock
 * jumps far ahead (then only the newest few instants are released).
 * Stepped (step = yes): the first instant at start is released, then one
 * more per step (avatargw-ctl step N).
 * Interpolated (interpolate = linear | catmull-rom | natural): the events
 * are keyframes; every 1 / sample_rate s of clip time each sensor gets a
 * sample rebuilt from them (record/keyframe.h), the paper's replay of a
 * low-rate recording. A step is then one sample period.
 *
 * Unreadable CSV rows (a wrong field count, a number that is not one, a
 * zero quaternion) are counted and skipped; in a recording, damaged regions
 * and a cut-off end are skipped up to the next good record, counted, and
 * listed for the control thread to log (replay_damage()).
 */
#include "trackers/replay.h"
#include "base/clock.h"
#include "base/log.h"

#include "config/builtin.h"
#include "record/keyframe.h"
#include "record/recload.h"

#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

static const char *const e_interp[] = { "none", "linear", "catmull-rom", "natural", NULL };

static const struct cfg_key replay_keys[] = {
	{ .name = "sample_rate",
	  .kind = CFG_DOUBLE,
	  CFG_AT(struct replay_opts, sample_rate),
	  .min = 1,
	  .max = 4000,
	  .def = "240",
	  .unit = "Hz",
	  .doc = "sensor samples per second (replay: made between keyframes when interpolate is set)" },
	{ .name = "file",
	  .kind = CFG_PATH,
	  CFG_AT(struct replay_opts, file),
	  .missing = "the recording to replay",
	  .doc = "a recording of avatargw (record_dir) or a sensor CSV (columns t, head_x..head_qz, lhand_*, "
		 "rhand_*), relative to this file's directory; builtin:NAME for a clip compiled into the daemon" },
	{ .name = "speed",
	  .kind = CFG_DOUBLE,
	  CFG_AT(struct replay_opts, speed),
	  .min = 0.01,
	  .max = 100,
	  .def = "1",
	  .doc = "playback speed of the recording, 1 = real time" },
	{ .name = "loop",
	  .kind = CFG_BOOL,
	  CFG_AT(struct replay_opts, loop),
	  .def = "yes",
	  .doc = "start the recording again at its end; otherwise the source ENDS and its sensors go STALE" },
	{ .name = "start",
	  .kind = CFG_DOUBLE,
	  CFG_AT(struct replay_opts, start),
	  .min = 0,
	  .max = 1e6,
	  .def = "0",
	  .unit = "s",
	  .doc = "begin this far into the recording" },
	{ .name = "step",
	  .kind = CFG_BOOL,
	  CFG_AT(struct replay_opts, step),
	  .def = "no",
	  .doc = "stepped: play the first instant, then one more per 'avatargw-ctl step' (speed is ignored)" },
	{ .name = "interpolate",
	  .kind = CFG_ENUM,
	  CFG_AT(struct replay_opts, interpolate),
	  .def = "none",
	  .enums = e_interp,
	  .doc = "treat the samples as keyframes and rebuild sample_rate samples per second between them: linear "
		 "(and slerp), catmull-rom or natural (cubic splines, and squad)" },
};

extern const struct tracker_driver replay_driver;

static const struct replay_opts *opts_of(const struct cfg_source *c)
{
	return c->opt;
}

#define CSV_ROLES 3

struct replay_ev {
	double t; /* s from the first event (first: last_due reads it) */
	uint32_t sensor;
	uint32_t buttons;
	struct dq pose;
	float analog[SENSOR_ANALOG_MAX];
};

/* one sensor's keyframes, for interpolate */
struct replay_track {
	struct kf_track tr;
	double *t;
	struct kf_pose *key;
	double (*d2)[3];
	double (*s)[4];
	double *work;
};

/* a remote avatar's recorded FRAME or DESCRIBE ([site]), its bytes in replay.rbytes */
struct replay_rmsg {
	double t; /* s from the first event, as the samples (first: last_due reads it) */
	uint32_t avatar;
	uint8_t type;
	uint16_t len;
	size_t off;
};

/* a recorded remote avatar as it plays (the loop's) */
struct replay_solved {
	uint16_t id;
	char name[WIRE_NAME_MAX + 1];
	struct wire_frame wf;
	struct wire_describe d;
	uint64_t arrival; /* CLOCK_MONOTONIC when its newest frame was played */
	bool have_f, have_d, new_f, new_d;
	bool gone; /* its site had left when recorded (a DESCRIBE saying so), until its next frame */
};

struct replay {
	struct replay_ev *ev;
	size_t n_ev;
	size_t *inst; /* first event of each instant, n_inst + 1 entries */
	size_t n_inst;
	double duration; /* of one pass, s: last time + the mean spacing of instants */
	uint32_t n_sensors;
	int malformed;
	int first_bad_line;
	struct recfile_damage *damage;
	size_t n_damage;
	/* interpolate */
	struct replay_track *track; /* n_sensors, NULL unless interpolating */
	double sample_period;
	/* playback (the loop) */
	uint64_t t0_ns;
	int64_t last;		    /* clocked: last event released, counting passes (pass * n_ev + index) */
	int64_t cur_inst;	    /* stepped: last instant released, counting passes; -1 none */
	int64_t last_sample;	    /* interpolated: last sample index released (clip time / period) */
	_Atomic uint64_t steps_req; /* stepped: added by the control thread */
	uint64_t steps_done;
	int tfd;
	bool tfd_used; /* an event-mode loop waits on tfd (replay_fd was asked) */
	/* a recording's remote avatars, published again as they were (not solved again) */
	struct replay_rmsg *rmsg;
	size_t n_rmsg;
	uint8_t *rbytes;
	struct replay_solved *solved;
	int n_solved;
	int64_t rlast;		   /* clocked: last message played, counting passes */
	struct wire_describe dtmp; /* the loop's: a DESCRIBE being decoded */
	double remote_end;	   /* s: the last remote message plus a loop period */
};

static const char *const roles[CSV_ROLES] = { "head", "left_hand", "right_hand" };
static const char *const prefixes[CSV_ROLES] = { "head", "lhand", "rhand" };
static const char *const fields[7] = { "x", "y", "z", "qw", "qx", "qy", "qz" };

/* ---- which kind of file, and its sensors (config time: cached) ------------------------------ */

/*
 * Configuration asks a source for its sensors many times (every avatar's
 * every sensor reference). For a recording the names are in the file, so
 * they are kept for the file as it is now (path, inode, size, mtime).
 */
#define NAME_CACHE 8

struct name_cache {
	char path[CFG_PATH_MAX];
	dev_t dev;
	ino_t ino;
	off_t size;
	struct timespec mtime;
	bool recording;
	uint32_t n;
	char **names;
	unsigned age;
};

static struct name_cache cache[NAME_CACHE];
static unsigned cache_clock;

static void cache_drop(struct name_cache *c)
{
	for (uint32_t i = 0; c->names && i < c->n; i++)
		free(c->names[i]);
	free(c->names);
	memset(c, 0, sizeof(*c));
}

/* the sensor names of an index, kept by the cache; the rest freed */
static void take_names(struct name_cache *c, struct rec_index *ix)
{
	c->n = ix->n_sensors;
	c->names = ix->names;
	ix->names = NULL;
	ix->n_sensors = 0;
	rec_index_free(ix);
}

/* reads the magic and, for a recording, its first good SESSION's sensor names */
static struct name_cache *file_kind(const char *path)
{
	struct name_cache *c, *old = &cache[0];
	struct stat st;
	unsigned char hdr[RECFILE_HEADER_LEN + RECFILE_REC_HEAD];
	uint8_t *rec = NULL;
	ssize_t got;
	int fd;

	if (!strncmp(path, "builtin:", 8) || stat(path, &st))
		return NULL;
	for (int i = 0; i < NAME_CACHE; i++) {
		c = &cache[i];
		if (c->path[0] && !strcmp(c->path, path) && c->dev == st.st_dev && c->ino == st.st_ino &&
		    c->size == st.st_size && c->mtime.tv_sec == st.st_mtim.tv_sec &&
		    c->mtime.tv_nsec == st.st_mtim.tv_nsec) {
			c->age = ++cache_clock;
			return c;
		}
		if (c->age < old->age)
			old = c;
	}
	c = old;
	cache_drop(c);
	fd = open(path, O_RDONLY | O_CLOEXEC);
	if (fd < 0)
		return NULL;
	got = read(fd, hdr, sizeof(hdr));
	if (got >= RECFILE_MAGIC_LEN && recfile_is_recording(hdr, (size_t)got)) {
		struct rec_index ix;
		struct recfile_header h;
		size_t n;

		c->recording = true;
		/* the first record must be the SESSION: parse just that one */
		if (got == (ssize_t)sizeof(hdr) && !recfile_header_decode(hdr, sizeof(hdr), &h) &&
		    hdr[RECFILE_HEADER_LEN + 4] == RECFILE_SESSION) {
			n = RECFILE_REC_OVERHEAD + recfile_framed_len(hdr + RECFILE_HEADER_LEN);
			rec = n < 64u << 20 ? malloc(RECFILE_HEADER_LEN + n) : NULL;
			if (rec && pread(fd, rec, RECFILE_HEADER_LEN + n, 0) == (ssize_t)(RECFILE_HEADER_LEN + n) &&
			    !rec_index_parse(rec, RECFILE_HEADER_LEN + n, &ix, (char[64]){ 0 }, 64))
				take_names(c, &ix);
			free(rec);
		}
		/*
		 * The first record damaged or not a SESSION that parses: the loader
		 * resynchronises to the first good one, so the names are that one's
		 * (read the way the loader reads them, else config and open disagree)
		 */
		if (!c->names && !rec_index_load(path, &ix, (char[64]){ 0 }, 64))
			take_names(c, &ix);
	}
	close(fd);
	snprintf(c->path, sizeof(c->path), "%s", path);
	c->dev = st.st_dev;
	c->ino = st.st_ino;
	c->size = st.st_size;
	c->mtime = st.st_mtim;
	c->age = ++cache_clock;
	return c;
}

static int replay_sensor_count(const struct cfg_source *cfg)
{
	struct name_cache *c = file_kind(opts_of(cfg)->file);

	return c && c->recording ? (int)c->n : CSV_ROLES;
}

static void replay_sensor_name(const struct cfg_source *cfg, int i, char *buf, size_t len)
{
	struct name_cache *c = file_kind(opts_of(cfg)->file);

	if (c && c->recording)
		snprintf(buf, len, "%s", i >= 0 && (uint32_t)i < c->n ? c->names[i] : "?");
	else
		snprintf(buf, len, "%s", i >= 0 && i < CSV_ROLES ? roles[i] : "?");
}

/* ---- loading a CSV ------------------------------------------------------------------------ */

/* the file's text: builtin or read whole; *owned says whether to free it */
static char *load_text(const char *path, bool *owned, char *err, size_t errlen)
{
	FILE *f;
	char *buf = NULL;
	size_t len = 0, cap = 0, got;

	if (!strncmp(path, "builtin:", 8)) {
		const char *b = builtin_find(path + 8, NULL);

		*owned = false;
		if (!b)
			snprintf(err, errlen, "file: %s: no such builtin clip", path);
		return (char *)b;
	}
	*owned = true;
	f = fopen(path, "r");
	if (!f) {
		snprintf(err, errlen, "file: %s: %s", path, strerror(errno));
		return NULL;
	}
	do {
		if (len + 65536 + 1 > cap) {
			char *n = realloc(buf, cap = cap ? 2 * cap : 131072);

			if (!n) {
				free(buf);
				fclose(f);
				snprintf(err, errlen, "file: %s: out of memory", path);
				return NULL;
			}
			buf = n;
		}
		got = fread(buf + len, 1, 65536, f);
		len += got;
	} while (got == 65536);
	fclose(f);
	buf[len] = '\0';
	return buf;
}

/* column index of every needed field; -1 if missing */
static int header_columns(char *line, int col[CSV_ROLES][7], char *missing, size_t mlen)
{
	char *save, *tok;
	int i = 0, ct = -1;

	for (int r = 0; r < CSV_ROLES; r++)
		for (int f = 0; f < 7; f++)
			col[r][f] = -1;
	for (tok = strtok_r(line, ",\r", &save); tok; tok = strtok_r(NULL, ",\r", &save), i++) {
		while (*tok == ' ')
			tok++;
		if (!strcmp(tok, "t"))
			ct = i;
		for (int r = 0; r < CSV_ROLES; r++) {
			size_t pl = strlen(prefixes[r]);

			if (strncmp(tok, prefixes[r], pl) || tok[pl] != '_')
				continue;
			for (int f = 0; f < 7; f++)
				if (!strcmp(tok + pl + 1, fields[f]))
					col[r][f] = i;
		}
	}
	if (ct < 0) {
		snprintf(missing, mlen, "t");
		return -1;
	}
	for (int r = 0; r < CSV_ROLES; r++)
		for (int f = 0; f < 7; f++)
			if (col[r][f] < 0) {
				snprintf(missing, mlen, "%s_%s", prefixes[r], fields[f]);
				return -1;
			}
	return ct;
}

static int push_ev(struct replay *rp, size_t *cap, const struct replay_ev *e)
{
	if (rp->n_ev == *cap) {
		size_t nc = *cap ? 2 * *cap : 3072;
		struct replay_ev *n = realloc(rp->ev, nc * sizeof(*n));

		if (!n)
			return -1;
		rp->ev = n;
		*cap = nc;
	}
	rp->ev[rp->n_ev++] = *e;
	return 0;
}

/* parses text into events; 0 or -1 with err */
static int parse_csv(struct replay *rp, char *text, const char *path, char *err, size_t errlen)
{
	char *line, *next, missing[32];
	int col[CSV_ROLES][7], ct, lineno = 1, maxcol = 0;
	double vals[256], t_first = 0, t_last = 0;
	size_t cap = 0, rows = 0;

	next = strchr(text, '\n');
	if (next)
		*next++ = '\0';
	ct = header_columns(text, col, missing, sizeof(missing));
	if (ct < 0) {
		snprintf(err, errlen,
			 "file: %s:1: no column '%s' (a sensor CSV has t, head_x..head_qz, "
			 "lhand_*, rhand_*)",
			 path, missing);
		return -1;
	}
	maxcol = ct;
	for (int r = 0; r < CSV_ROLES; r++)
		for (int f = 0; f < 7; f++)
			if (col[r][f] > maxcol)
				maxcol = col[r][f];
	if (maxcol >= 256) {
		snprintf(err, errlen, "file: %s:1: more than 256 columns", path);
		return -1;
	}
	for (line = next; line && *line; line = next) {
		int n = 0;
		bool ok = true;
		char *p = line;
		struct replay_ev e[CSV_ROLES];

		lineno++;
		next = strchr(line, '\n');
		if (next)
			*next++ = '\0';
		if (line[0] == '\r' || line[0] == '\0' || line[0] == '#')
			continue;
		while (n <= maxcol) {
			char *end;

			vals[n] = strtod(p, &end);
			if (end == p || !isfinite(vals[n])) {
				ok = false;
				break;
			}
			n++;
			while (*end == ' ' || *end == '\r')
				end++;
			if (*end == ',')
				p = end + 1;
			else if (*end == '\0')
				break;
			else {
				ok = false;
				break;
			}
		}
		if (ok && n <= maxcol)
			ok = false;
		if (ok && rows && vals[ct] <= t_last)
			ok = false; /* time must increase */
		for (int r = 0; ok && r < CSV_ROLES; r++) {
			struct quat q = { vals[col[r][3]], vals[col[r][4]], vals[col[r][5]], vals[col[r][6]] }, qn;
			struct vec3 v = { vals[col[r][0]], vals[col[r][1]], vals[col[r][2]] };

			if (!quat_normalize(&q, &qn)) {
				ok = false;
				break;
			}
			memset(&e[r], 0, sizeof(e[r]));
			e[r].sensor = (uint32_t)r;
			dq_from_rt(&qn, &v, &e[r].pose);
		}
		if (!ok) {
			if (!rp->malformed++)
				rp->first_bad_line = lineno;
			continue;
		}
		if (!rows)
			t_first = vals[ct];
		t_last = vals[ct];
		rows++;
		for (int r = 0; r < CSV_ROLES; r++) {
			e[r].t = vals[ct] - t_first;
			if (push_ev(rp, &cap, &e[r])) {
				snprintf(err, errlen, "file: %s: out of memory", path);
				return -1;
			}
		}
	}
	if (rows < 2) {
		snprintf(err, errlen, "file: %s: fewer than two readable rows%s", path,
			 rp->malformed ? " (the others are malformed)" : "");
		return -1;
	}
	rp->n_sensors = CSV_ROLES;
	return 0;
}

/* ---- loading a recording ---------------------------------------------------------------------- */

static int cmp_ev(const void *a, const void *b)
{
	const struct replay_ev *x = a, *y = b;

	/* buttons holds the file position while sorting: a stable order for equal times */
	if (x->t != y->t)
		return x->t < y->t ? -1 : 1;
	return x->buttons < y->buttons ? -1 : x->buttons > y->buttons;
}

/* the recording's remote avatars and their messages, on the samples' time base */
static int load_remote(struct replay *rp, struct rec_index *ix, uint64_t base)
{
	if (!ix->n_remote)
		return 0;
	rp->rmsg = calloc(ix->n_remote, sizeof(*rp->rmsg));
	rp->solved = calloc(ix->n_remote_avatars, sizeof(*rp->solved));
	if (!rp->rmsg || !rp->solved)
		return -1;
	rp->rbytes = ix->remote_bytes;
	ix->remote_bytes = NULL;
	for (size_t i = 0; i < ix->n_remote; i++) {
		const struct rec_remote *r = &ix->remote[i];

		rp->rmsg[i] = (struct replay_rmsg){ (double)(int64_t)(r->mono_ns - base) * 1e-9, r->avatar, r->type,
						    r->len, r->off };
		if (i && rp->rmsg[i].t < rp->rmsg[i - 1].t)
			rp->rmsg[i].t = rp->rmsg[i - 1].t; /* one cycle after another: never backwards */
	}
	rp->n_rmsg = ix->n_remote;
	for (size_t a = 0; a < ix->n_remote_avatars; a++) {
		rp->solved[a].id = ix->remote_avatars[a].id;
		memcpy(rp->solved[a].name, ix->remote_avatars[a].name, sizeof(rp->solved[a].name));
	}
	rp->n_solved = (int)ix->n_remote_avatars;
	return 0;
}

static int load_recording(struct replay *rp, const char *path, char *err, size_t errlen)
{
	struct rec_index ix;
	char why[512];
	bool sorted = true;
	uint64_t base;

	if (rec_index_load(path, &ix, why, sizeof(why))) {
		snprintf(err, errlen, "file: %s", why);
		return -1;
	}
	if (ix.n_events < 1 && ix.n_remote < 1) {
		snprintf(err, errlen, "file: %s: a recording without samples", path);
		rec_index_free(&ix);
		return -1;
	}
	/* time 0: the first sample, or the first remote avatar's message if that came before */
	base = ix.n_events ? ix.events[0].arrival_ns : ix.remote[0].mono_ns;
	if (ix.n_remote && ix.remote[0].mono_ns < base)
		base = ix.remote[0].mono_ns;
	rp->ev = calloc(ix.n_events + 1, sizeof(*rp->ev));
	if (!rp->ev || load_remote(rp, &ix, base)) {
		snprintf(err, errlen, "file: %s: out of memory (%zu samples)", path, ix.n_events);
		rec_index_free(&ix);
		return -1;
	}
	for (size_t i = 0; i < ix.n_events; i++) {
		const struct rec_event *s = &ix.events[i];
		struct replay_ev *e = &rp->ev[i];
		struct quat q = { s->q[0], s->q[1], s->q[2], s->q[3] }, qn;
		struct vec3 p = { s->p[0], s->p[1], s->p[2] };

		bool analog_ok = true;

		for (int k = 0; k < SENSOR_ANALOG_MAX; k++)
			analog_ok &= isfinite(s->analog[k]) != 0;
		if (!quat_normalize(&q, &qn) || !isfinite(p.x) || !isfinite(p.y) || !isfinite(p.z) || !analog_ok) {
			/* a good CRC around numbers that are not a pose or analog values: counted, never played */
			rp->malformed++;
			continue;
		}
		e = &rp->ev[rp->n_ev++];
		e->t = (double)(int64_t)(s->arrival_ns - base) * 1e-9;
		e->sensor = s->sensor;
		e->buttons = (uint32_t)i;
		dq_from_rt(&qn, &p, &e->pose);
		memcpy(e->analog, s->analog, sizeof(e->analog));
		if (rp->n_ev > 1 && e->t < rp->ev[rp->n_ev - 2].t)
			sorted = false;
	}
	if (!sorted)
		qsort(rp->ev, rp->n_ev, sizeof(*rp->ev), cmp_ev);
	for (size_t i = 0; i < rp->n_ev; i++) {
		const struct replay_ev *e = &rp->ev[i];

		rp->ev[i].buttons = ix.events[e->buttons].buttons;
	}
	rp->n_sensors = ix.n_sensors;
	rp->malformed += (int)(ix.n_damage + ix.n_bad);
	if (ix.n_damage) {
		rp->damage = malloc(ix.n_damage * sizeof(*rp->damage));
		if (rp->damage) {
			memcpy(rp->damage, ix.damage, ix.n_damage * sizeof(*rp->damage));
			rp->n_damage = ix.n_damage;
		}
	}
	if (rp->n_rmsg) {
		/* a pass lasts until the remote avatars' last message too, plus one loop period */
		double end = rp->rmsg[rp->n_rmsg - 1].t + (ix.session.rate > 0 ? 1.0 / ix.session.rate : 0.0);

		rp->remote_end = end;
	}
	rec_index_free(&ix);
	if (rp->n_ev < 1 && !rp->n_rmsg) {
		snprintf(err, errlen, "file: %s: no readable samples", path);
		return -1;
	}
	return 0;
}

/* ---- both ----------------------------------------------------------------------------------------- */

static int index_instants(struct replay *rp, const char *path, char *err, size_t errlen)
{
	size_t k = 0;

	rp->inst = malloc((rp->n_ev + 1) * sizeof(*rp->inst));
	if (!rp->inst) {
		snprintf(err, errlen, "file: %s: out of memory", path);
		return -1;
	}
	for (size_t i = 0; i < rp->n_ev; i++)
		if (!i || rp->ev[i].t != rp->ev[i - 1].t)
			rp->inst[k++] = i;
	rp->inst[k] = rp->n_ev;
	rp->n_inst = k;
	/* one pass: the last instant plus the mean spacing, so a loop keeps the rhythm */
	rp->duration = k > 1 ? rp->ev[rp->n_ev - 1].t * (double)k / (double)(k - 1) : 1.0;
	if (rp->n_rmsg && (rp->remote_end > rp->duration || !k))
		rp->duration = rp->remote_end > 1e-3 ? rp->remote_end : 1e-3;
	return 0;
}

static void free_tracks(struct replay *rp)
{
	for (uint32_t i = 0; rp->track && i < rp->n_sensors; i++) {
		struct replay_track *tk = &rp->track[i];

		free(tk->t);
		free(tk->key);
		free(tk->d2);
		free(tk->s);
		free(tk->work);
	}
	free(rp->track);
	rp->track = NULL;
}

/* the keyframe tracks of every sensor (interpolate) */
static int build_tracks(struct replay *rp, enum kf_interp m, const char *path, char *err, size_t errlen)
{
	size_t *count = calloc(rp->n_sensors + 1, sizeof(*count));

	rp->track = calloc(rp->n_sensors + 1, sizeof(*rp->track));
	if (!count || !rp->track)
		goto nomem;
	for (size_t i = 0; i < rp->n_ev; i++)
		count[rp->ev[i].sensor]++;
	for (uint32_t s = 0; s < rp->n_sensors; s++) {
		struct replay_track *tk = &rp->track[s];
		size_t n = count[s] ? count[s] : 1;

		tk->t = calloc(n, sizeof(*tk->t));
		tk->key = calloc(n, sizeof(*tk->key));
		tk->d2 = calloc(n, sizeof(*tk->d2));
		tk->s = calloc(n, sizeof(*tk->s));
		tk->work = calloc(n, sizeof(*tk->work));
		if (!tk->t || !tk->key || !tk->d2 || !tk->s || !tk->work)
			goto nomem;
		tk->tr = (struct kf_track){ m, 0, tk->t, tk->key, tk->d2, tk->s, tk->work };
	}
	for (size_t i = 0; i < rp->n_ev; i++) {
		const struct replay_ev *e = &rp->ev[i];
		struct replay_track *tk = &rp->track[e->sensor];
		struct kf_pose *k = &tk->key[tk->tr.n];
		struct vec3 p;

		if (tk->tr.n && e->t <= tk->t[tk->tr.n - 1])
			continue; /* two samples of one sensor at one time: the first stays */
		dq_translation(&e->pose, &p);
		tk->t[tk->tr.n] = e->t;
		*k = (struct kf_pose){ { p.x, p.y, p.z }, { e->pose.r.w, e->pose.r.x, e->pose.r.y, e->pose.r.z } };
		tk->tr.n++;
	}
	for (uint32_t s = 0; s < rp->n_sensors; s++)
		if (rp->track[s].tr.n && kf_prepare(&rp->track[s].tr)) {
			snprintf(err, errlen, "file: %s: the samples of sensor %u cannot be interpolated", path, s);
			free(count);
			return -1;
		}
	free(count);
	return 0;
nomem:
	free(count);
	snprintf(err, errlen, "file: %s: out of memory", path);
	return -1;
}

static void replay_free(struct replay *rp)
{
	if (!rp)
		return;
	free_tracks(rp);
	free(rp->ev);
	free(rp->inst);
	free(rp->damage);
	free(rp->rmsg);
	free(rp->rbytes);
	free(rp->solved);
	free(rp);
}

static int load(struct replay *rp, const struct cfg_source *cfg, char *err, size_t errlen)
{
	struct name_cache *kind = file_kind(opts_of(cfg)->file);
	int rc;

	if (kind && kind->recording) {
		rc = load_recording(rp, opts_of(cfg)->file, err, errlen);
	} else {
		bool owned;
		char *text = load_text(opts_of(cfg)->file, &owned, err, errlen), *copy;

		if (!text)
			return -1;
		copy = owned ? text : strdup(text);
		if (!copy) {
			snprintf(err, errlen, "file: out of memory");
			return -1;
		}
		rc = parse_csv(rp, copy, opts_of(cfg)->file, err, errlen);
		free(copy);
	}
	if (!rc)
		rc = index_instants(rp, opts_of(cfg)->file, err, errlen);
	if (!rc && opts_of(cfg)->interpolate)
		rc = build_tracks(rp, (enum kf_interp)(opts_of(cfg)->interpolate - 1), opts_of(cfg)->file, err, errlen);
	return rc;
}

static int replay_check(const struct config *c __attribute__((unused)), const void *section, const char **key,
			char *err, size_t errlen)
{
	const struct cfg_source *cfg = section;
	struct replay *rp = calloc(1, sizeof(*rp));
	int rc;

	*key = "file"; /* what a failure blames */
	if (!rp) {
		snprintf(err, errlen, "file: out of memory");
		return -1;
	}
	rc = load(rp, cfg, err, errlen);
	replay_free(rp);
	return rc;
}

static int replay_open(struct tracker *t, char *err, size_t errlen)
{
	struct replay *rp = calloc(1, sizeof(*rp));
	double dt;

	if (!rp) {
		snprintf(err, errlen, "[source %s]: out of memory", t->cfg->name);
		return -ENOMEM;
	}
	if (load(rp, t->cfg, err, errlen)) {
		replay_free(rp);
		return -EINVAL;
	}
	if (rp->n_sensors != (uint32_t)t->n_sensors) {
		/* the file changed between reading the configuration and now */
		snprintf(err, errlen, "[source %s] file: %s changed while the configuration was read", t->cfg->name,
			 opts_of(t->cfg)->file);
		replay_free(rp);
		return -EINVAL;
	}
	ctr_add(&t->st.malformed, (uint64_t)rp->malformed);
	rp->t0_ns = 0; /* the clip starts at the first poll, not while the daemon is still starting */
	rp->last = -1;
	rp->cur_inst = -1;
	rp->last_sample = -1;
	rp->sample_period = 1.0 / opts_of(t->cfg)->sample_rate;
	rp->rlast = -1;
	/* event mode: wake at the instants' mean rate, or the sample rate when interpolating */
	dt = opts_of(t->cfg)->interpolate ? rp->sample_period
	     : rp->n_inst		  ? rp->duration / (double)rp->n_inst
					  : 1.0 / 240; /* only remote avatars: about a loop period */
	dt /= opts_of(t->cfg)->step ? 1.0 : opts_of(t->cfg)->speed;
	if (!(dt <= 1.0))
		dt = 1.0; /* instants far apart (or a clip whose times are absurd): a look a second is enough */
	else if (dt < 0)
		dt = 0;
	rp->tfd = periodic_timerfd((uint64_t)(dt * 1e9));
	t->priv = rp;
	return 0;
}

static void replay_close(struct tracker *t)
{
	struct replay *rp = t->priv;

	if (!rp)
		return;
	if (rp->tfd >= 0)
		close(rp->tfd);
	replay_free(rp);
	t->priv = NULL;
}

/* ---- playing (the loop) -------------------------------------------------------------------------------- */

static void put_event(struct tracker *t, const struct replay_ev *e, uint64_t due_mono, const struct tracker_clock *now)
{
	struct sensor_slot *s = &t->slot[e->sensor];

	s->buttons = e->buttons;
	memcpy(s->analog, e->analog, sizeof(s->analog));
	tracker_put(t, (int)e->sensor, &e->pose, (uint64_t)((int64_t)due_mono + now->real_off_ns), now->mono_ns);
}

/* clip time in s since the first event, for the clocked modes; -1 before the start */
static double clip_elapsed(const struct replay *rp, const struct cfg_source *cfg, const struct tracker_clock *now)
{
	return (double)(now->mono_ns - rp->t0_ns) * 1e-9 * opts_of(cfg)->speed + opts_of(cfg)->start;
}

/* the monotonic time at which clip time ct (counting passes) was due */
static uint64_t due_at(const struct replay *rp, const struct cfg_source *cfg, double ct,
		       const struct tracker_clock *now)
{
	uint64_t due = rp->t0_ns + (uint64_t)llround((ct - opts_of(cfg)->start) / opts_of(cfg)->speed * 1e9);

	return due > now->mono_ns ? now->mono_ns : due;
}

/*
 * The last of n time-ordered elements (replay_ev, replay_rmsg: a double t
 * first) with t <= ct; 0 when none is (the caller checks element 0's t).
 */
static size_t last_due(const void *a, size_t n, size_t size, double ct)
{
	size_t lo = 0, hi = n - 1;

	while (lo < hi) {
		size_t mid = (lo + hi + 1) / 2;
		double t;

		memcpy(&t, (const char *)a + mid * size, sizeof(t));
		if (t <= ct)
			lo = mid;
		else
			hi = mid - 1;
	}
	return lo;
}

/* a recorded remote avatar's message played: its frame or description is the newest */
static void play_rmsg(struct replay *rp, const struct replay_rmsg *m, uint64_t now_mono)
{
	struct replay_solved *a = &rp->solved[m->avatar];
	const uint8_t *b = rp->rbytes + m->off;

	if (m->type == WIRE_FRAME) {
		if (wire_decode_frame(b, m->len, &a->wf) == 0) {
			a->have_f = a->new_f = true;
			a->arrival = now_mono;
			if (a->gone) {
				a->gone = false;
				a->new_d = true; /* back: its DESCRIBE at once, as a site that comes back sends it */
			}
		}
	} else {
		struct wire_describe *d = &rp->dtmp;
		size_t from = offsetof(struct wire_describe, rate_hz), to = offsetof(struct wire_describe, site);

		/* recorded once a second: a new one only when the skeleton changed (its site's figures always) */
		memset(d, 0, sizeof(*d));
		if (wire_decode_describe(b, m->len, d))
			return;
		if (d->site.present && d->site.state == WIRE_SITE_GONE) {
			a->gone = true; /* the recording daemon saw it leave: no frames until it comes back */
			return;
		}
		if (!a->have_d || memcmp((const char *)d + from, (const char *)&a->d + from, to - from))
			a->new_d = true;
		a->d = *d;
		a->have_d = true;
	}
}

/* clocked: the remote avatars' messages up to clip time ct of pass pass */
static void play_remote(struct replay *rp, int64_t pass, double ct, uint64_t now_mono)
{
	int64_t target, from;
	size_t lo;

	if (!rp->n_rmsg)
		return;
	lo = last_due(rp->rmsg, rp->n_rmsg, sizeof(*rp->rmsg), ct);
	if (rp->rmsg[lo].t > ct) {
		if (!pass)
			return;
		pass--;
		lo = rp->n_rmsg - 1;
	}
	target = pass * (int64_t)rp->n_rmsg + (int64_t)lo;
	from = rp->rlast + 1;
	/* a clock far ahead: the newest few messages (each avatar's DESCRIBE comes again within a second) */
	if (target - from >= 4 * (int64_t)rp->n_solved + 64)
		from = target - (4 * (int64_t)rp->n_solved + 64) + 1;
	for (int64_t g = from; g <= target; g++)
		play_rmsg(rp, &rp->rmsg[g % (int64_t)rp->n_rmsg], now_mono);
	if (target > rp->rlast)
		rp->rlast = target;
}

/* clocked, events as recorded */
static int poll_clocked(struct tracker *t, struct replay *rp, const struct tracker_clock *now)
{
	const struct cfg_source *cfg = t->cfg;
	double el = clip_elapsed(rp, cfg, now), ct;
	int64_t pass = 0, target, from, cap;
	size_t lo;
	int put = 0;

	if (opts_of(cfg)->loop) {
		pass = (int64_t)floor(el / rp->duration);
		ct = el - (double)pass * rp->duration;
	} else {
		ct = el;
		if (ct > rp->duration) {
			atomic_store_explicit(&t->st.state, TRACKER_ENDED, memory_order_relaxed);
			if (rp->last >= (int64_t)rp->n_ev - 1) {
				play_remote(rp, 0, ct, now->mono_ns); /* the remote avatars' last messages */
				return 0;
			}
		}
	}
	if (ct < 0)
		return 0;
	play_remote(rp, pass, ct, now->mono_ns);
	if (!rp->n_ev)
		return 0;
	lo = last_due(rp->ev, rp->n_ev, sizeof(*rp->ev), ct);
	if (rp->ev[lo].t > ct) {
		if (!pass)
			return 0;
		pass--; /* before the first event of this pass: the previous pass's end */
		lo = rp->n_ev - 1;
	}
	target = pass * (int64_t)rp->n_ev + (int64_t)lo;
	if (target <= rp->last)
		return 0;
	/* a clock far ahead (start, a long stall): the newest few instants are enough */
	cap = 4 * (int64_t)rp->n_sensors + 64;
	from = rp->last + 1;
	if (target - from >= cap)
		from = target - cap + 1;
	for (int64_t g = from; g <= target; g++) {
		int64_t p = g / (int64_t)rp->n_ev;
		const struct replay_ev *e = &rp->ev[g % (int64_t)rp->n_ev];

		put_event(t, e, due_at(rp, cfg, (double)p * rp->duration + e->t, now), now);
		put++;
	}
	rp->last = target;
	return put;
}

/* stepped, events as recorded: the instant at start, then one per step */
static int poll_stepped(struct tracker *t, struct replay *rp, const struct tracker_clock *now)
{
	uint64_t req = atomic_load_explicit(&rp->steps_req, memory_order_acquire);
	uint64_t steps = req - rp->steps_done;
	int put = 0;

	rp->steps_done = req;
	if (!rp->n_inst)
		return 0; /* only remote avatars, which play by the clock only */
	if (rp->cur_inst < 0) {
		size_t k = 0;

		/* the first instant comes by itself */
		while (k + 1 < rp->n_inst && rp->ev[rp->inst[k + 1]].t <= opts_of(t->cfg)->start)
			k++;
		rp->cur_inst = (int64_t)k - 1;
		steps++;
	}
	while (steps--) {
		int64_t next = rp->cur_inst + 1;
		size_t k = (size_t)(next % (int64_t)rp->n_inst);

		if (!opts_of(t->cfg)->loop && next >= (int64_t)rp->n_inst) {
			atomic_store_explicit(&t->st.state, TRACKER_ENDED, memory_order_relaxed);
			play_remote(rp, 0, rp->duration, now->mono_ns); /* the remote avatars' last messages */
			break;
		}
		for (size_t i = rp->inst[k]; i < rp->inst[k + 1]; i++, put++)
			put_event(t, &rp->ev[i], now->mono_ns, now);
		rp->cur_inst = next;
	}
	/* the remote avatars as they were at the instant played (recorded up to its time, this pass) */
	if (rp->cur_inst >= 0)
		play_remote(rp, rp->cur_inst / (int64_t)rp->n_inst,
			    rp->ev[rp->inst[rp->cur_inst % (int64_t)rp->n_inst]].t, now->mono_ns);
	return put;
}

/* interpolated: one sample of every sensor per sample period of clip time */
static int poll_interpolated(struct tracker *t, struct replay *rp, const struct tracker_clock *now)
{
	const struct cfg_source *cfg = t->cfg;
	int64_t k;
	double ct, el;
	uint64_t due;
	int put = 0;

	if (opts_of(cfg)->step) {
		uint64_t req = atomic_load_explicit(&rp->steps_req, memory_order_acquire);

		if (rp->last_sample >= 0 && req == rp->steps_done)
			return 0;
		k = rp->last_sample < 0 ? (int64_t)floor(opts_of(cfg)->start / rp->sample_period)
					: rp->last_sample + (int64_t)(req - rp->steps_done);
		rp->steps_done = req;
		due = now->mono_ns;
	} else {
		el = clip_elapsed(rp, cfg, now);
		if (el < 0)
			return 0;
		k = (int64_t)floor(el / rp->sample_period);
		if (k <= rp->last_sample)
			return 0;
		due = due_at(rp, cfg, (double)k * rp->sample_period, now);
	}
	rp->last_sample = k;
	el = (double)k * rp->sample_period;
	if (opts_of(cfg)->loop) {
		ct = fmod(el, rp->duration);
	} else {
		ct = el;
		if (ct > rp->duration) {
			atomic_store_explicit(&t->st.state, TRACKER_ENDED, memory_order_relaxed);
			play_remote(rp, 0, ct, now->mono_ns); /* the remote avatars' last messages */
			return 0;
		}
	}
	play_remote(rp, opts_of(cfg)->loop ? (int64_t)floor(el / rp->duration) : 0, ct, now->mono_ns);
	for (uint32_t s = 0; s < rp->n_sensors; s++) {
		struct replay_track *tk = &rp->track[s];
		struct kf_pose o;
		struct quat q;
		struct vec3 p;
		struct dq d;

		if (!tk->tr.n || ct < tk->t[0])
			continue;
		kf_eval(&tk->tr, ct, &o);
		q = (struct quat){ o.q[0], o.q[1], o.q[2], o.q[3] };
		p = (struct vec3){ o.p[0], o.p[1], o.p[2] };
		dq_from_rt(&q, &p, &d);
		tracker_put(t, (int)s, &d, (uint64_t)((int64_t)due + now->real_off_ns), now->mono_ns);
		put++;
	}
	return put;
}

static int replay_poll(struct tracker *t, const struct tracker_clock *now)
{
	struct replay *rp = t->priv;

	if (rp->tfd_used) {
		/* one read takes every expiration since the last; a periodic loop never waits on it */
		uint64_t exp;
		ssize_t rd = read(rp->tfd, &exp, sizeof(exp));

		(void)rd;
	}
	if (!rp->t0_ns)
		rp->t0_ns = now->mono_ns;
	if (rp->track)
		return poll_interpolated(t, rp, now);
	if (opts_of(t->cfg)->step)
		return poll_stepped(t, rp, now);
	return poll_clocked(t, rp, now);
}

static int replay_fd(struct tracker *t)
{
	struct replay *rp = t->priv;

	rp->tfd_used = rp->tfd >= 0;
	return rp->tfd;
}

/* the loop: a recorded remote avatar now (struct tracker_driver.solved) */
static bool replay_solved(struct tracker *t, int k, uint64_t now_mono, uint64_t stale_ns, struct wire_frame *wf,
			  struct wire_describe *d, bool *described, bool *fresh)
{
	struct replay *rp = t->priv;
	struct replay_solved *a = &rp->solved[k];
	uint64_t age;

	*described = *fresh = false;
	if (!a->have_f || !a->have_d || a->gone)
		return false;
	if (a->new_d) {
		*d = a->d;
		a->new_d = false;
		*described = true;
	}
	d->site = a->d.site; /* its site's figures as recorded: they go out with its next DESCRIBE */
	*fresh = a->new_f;
	a->new_f = false;
	*wf = a->wf;
	wf->h.flags = (uint16_t)(*fresh ? wf->h.flags | WIRE_F_NEW_SAMPLE : wf->h.flags & ~WIRE_F_NEW_SAMPLE);
	age = now_mono > a->arrival ? now_mono - a->arrival : 0;
	if (age > stale_ns) {
		/* no recorded frame for a while (the site was gone, or the replay ended) */
		for (int i = 0; i < WIRE_SENSORS; i++)
			if (wf->sensor[i].state == WIRE_SENSOR_OK)
				wf->sensor[i].state = WIRE_SENSOR_STALE;
		wf->h.flags |= WIRE_F_STALE;
	}
	return true;
}

/* ---- the control thread's side ------------------------------------------------------------------------ */

static int replay_solved_count(struct tracker *t)
{
	return ((struct replay *)t->priv)->n_solved;
}

static const char *replay_solved_name(struct tracker *t, int k, uint16_t *id)
{
	const struct replay_solved *a = &((struct replay *)t->priv)->solved[k];

	*id = a->id;
	return a->name;
}

bool replay_is_stepped(const struct tracker *t)
{
	return t->drv == &replay_driver && t->priv && opts_of(t->cfg)->step;
}

int replay_step(struct tracker *t, unsigned n)
{
	struct replay *rp = t->priv;

	if (!replay_is_stepped(t))
		return -EINVAL;
	atomic_fetch_add_explicit(&rp->steps_req, n, memory_order_release);
	return 0;
}

int replay_damage(const struct tracker *t, size_t i, struct recfile_damage *d)
{
	const struct replay *rp = t->priv;

	if (t->drv != &replay_driver || !rp || i >= rp->n_damage)
		return -1;
	*d = rp->damage[i];
	return 0;
}

int replay_malformed_line(const struct tracker *t)
{
	return ((const struct replay *)t->priv)->first_bad_line;
}

const struct tracker_driver replay_driver = {
	.type = { CFG_TYPE("replay",
			   "plays a recording of the daemon or a sensor CSV (../shared/mocap/csv format): real time, "
			   "faster, "
			   "stepped, or rebuilt from keyframes",
			   replay_keys, struct replay_opts),
		  .check = replay_check, .sensor_count = replay_sensor_count, .sensor_name = replay_sensor_name },
	.open = replay_open,
	.close = replay_close,
	.poll = replay_poll,
	.fd = replay_fd,
	.solved_count = replay_solved_count,
	.solved_name = replay_solved_name,
	.solved = replay_solved,
};

void replay_log_damage(const struct tracker *t)
{
	struct recfile_damage d;

	for (size_t k = 0; replay_damage(t, k, &d) == 0; k++) {
		if (k == 20) {
			pr_warning("source %s: more damaged regions not listed", t->name);
			break;
		}
		pr_warning("source %s: %s: %s at bytes %zu..%zu (%zu bytes) skipped%s", t->name, opts_of(t->cfg)->file,
			   d.truncated ? "cut-off record" : "damaged region", d.off, d.off + d.len, d.len,
			   d.truncated ? "" : ", replay resumes at the next good record");
	}
}
