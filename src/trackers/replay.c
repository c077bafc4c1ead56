// SPDX-License-Identifier: MIT
/*
 * replay.c - plays a recorded sensor stream: the CSV of ../shared/mocap/csv
 * (named columns; t in seconds; positions in metres; quaternions w,x,y,z;
 * world z up) or a clip compiled into the daemon (builtin:NAME).
 *
 * The whole file is read at open(), so the loop never touches the disk.
 * Clip time = start + speed * (now - t0); a row becomes a sample when the
 * clip time passes its t, stamped with the moment it was due. Rows that
 * cannot be read (a wrong field count, a number that is not one, a zero
 * quaternion) are counted and skipped, never played.
 */
#include "trackers/tracker.h"

#include "config/builtin.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/timerfd.h>
#include <time.h>
#include <unistd.h>

#define REPLAY_ROLES 3

struct replay_row {
	double t;
	struct dq pose[REPLAY_ROLES];
};

struct replay {
	struct replay_row *rows;
	int n_rows;
	int malformed;
	int first_bad_line;
	double duration;   /* of one pass, s: last t + one row period */
	uint64_t t0_ns;
	int64_t last;      /* last row index delivered, counting passes (pass * n_rows + row) */
	int tfd;
};

static const char *const roles[REPLAY_ROLES] = { "head", "left_hand", "right_hand" };
static const char *const prefixes[REPLAY_ROLES] = { "head", "lhand", "rhand" };
static const char *const fields[7] = { "x", "y", "z", "qw", "qx", "qy", "qz" };

static int replay_sensor_count(const struct cfg_source *cfg)
{
	(void)cfg;
	return REPLAY_ROLES;
}

static void replay_sensor_name(const struct cfg_source *cfg, int i, char *buf, size_t len)
{
	(void)cfg;
	snprintf(buf, len, "%s", roles[i]);
}

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
static int header_columns(char *line, int col_t, int col[REPLAY_ROLES][7], char *missing, size_t mlen)
{
	char *save, *tok;
	int i = 0;

	(void)col_t;
	for (int r = 0; r < REPLAY_ROLES; r++)
		for (int f = 0; f < 7; f++)
			col[r][f] = -1;
	int ct = -1;

	for (tok = strtok_r(line, ",\r", &save); tok; tok = strtok_r(NULL, ",\r", &save), i++) {
		while (*tok == ' ')
			tok++;
		if (!strcmp(tok, "t"))
			ct = i;
		for (int r = 0; r < REPLAY_ROLES; r++) {
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
	for (int r = 0; r < REPLAY_ROLES; r++)
		for (int f = 0; f < 7; f++)
			if (col[r][f] < 0) {
				snprintf(missing, mlen, "%s_%s", prefixes[r], fields[f]);
				return -1;
			}
	return ct;
}

/* parses text into rows; 0 or -1 with err */
static int parse_csv(struct replay *rp, char *text, const char *path, char *err, size_t errlen)
{
	char *line, *next, missing[32];
	int col[REPLAY_ROLES][7], ct, lineno = 1, cap = 0, maxcol = 0;
	double vals[256];

	next = strchr(text, '\n');
	if (next)
		*next++ = '\0';
	ct = header_columns(text, 0, col, missing, sizeof(missing));
	if (ct < 0) {
		snprintf(err, errlen, "file: %s:1: no column '%s' (a sensor CSV has t, head_x..head_qz, "
			 "lhand_*, rhand_*)", path, missing);
		return -1;
	}
	maxcol = ct;
	for (int r = 0; r < REPLAY_ROLES; r++)
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
		struct replay_row row;

		if (ok) {
			row.t = vals[ct];
			if (rp->n_rows && row.t <= rp->rows[rp->n_rows - 1].t)
				ok = false; /* time must increase */
		}
		for (int r = 0; ok && r < REPLAY_ROLES; r++) {
			struct quat q = { vals[col[r][3]], vals[col[r][4]], vals[col[r][5]], vals[col[r][6]] }, qn;
			struct vec3 v = { vals[col[r][0]], vals[col[r][1]], vals[col[r][2]] };

			if (!quat_normalize(&q, &qn)) {
				ok = false;
				break;
			}
			dq_from_rt(&qn, &v, &row.pose[r]);
		}
		if (!ok) {
			if (!rp->malformed++)
				rp->first_bad_line = lineno;
			continue;
		}
		if (rp->n_rows == cap) {
			struct replay_row *nr = realloc(rp->rows, (size_t)(cap = cap ? 2 * cap : 1024) * sizeof(*nr));

			if (!nr) {
				snprintf(err, errlen, "file: %s: out of memory", path);
				return -1;
			}
			rp->rows = nr;
		}
		rp->rows[rp->n_rows++] = row;
	}
	if (rp->n_rows < 2) {
		snprintf(err, errlen, "file: %s: fewer than two readable rows%s", path,
			 rp->malformed ? " (the others are malformed)" : "");
		return -1;
	}
	rp->duration = rp->rows[rp->n_rows - 1].t - rp->rows[0].t +
		       (rp->rows[rp->n_rows - 1].t - rp->rows[0].t) / (rp->n_rows - 1);
	return 0;
}

static int load(struct replay *rp, const struct cfg_source *cfg, char *err, size_t errlen)
{
	bool owned;
	char *text = load_text(cfg->file, &owned, err, errlen), *copy;
	int rc;

	if (!text)
		return -1;
	copy = owned ? text : strdup(text);
	if (!copy) {
		snprintf(err, errlen, "file: out of memory");
		return -1;
	}
	rc = parse_csv(rp, copy, cfg->file, err, errlen);
	free(copy);
	return rc;
}

static int replay_check(const struct cfg_source *cfg, char *err, size_t errlen)
{
	struct replay rp = { 0 };
	int rc = load(&rp, cfg, err, errlen);

	free(rp.rows);
	return rc;
}

static int replay_open(struct tracker *t, char *err, size_t errlen)
{
	struct replay *rp = calloc(1, sizeof(*rp));
	struct timespec now;

	if (!rp) {
		snprintf(err, errlen, "[source %s]: out of memory", t->cfg->name);
		return -ENOMEM;
	}
	if (load(rp, t->cfg, err, errlen)) {
		free(rp->rows);
		free(rp);
		return -EINVAL;
	}
	ctr_add(&t->st.malformed, (uint64_t)rp->malformed);
	clock_gettime(CLOCK_MONOTONIC, &now);
	rp->t0_ns = (uint64_t)now.tv_sec * 1000000000ull + (uint64_t)now.tv_nsec;
	rp->last = -1;
	rp->tfd = timerfd_create(CLOCK_MONOTONIC, TFD_NONBLOCK | TFD_CLOEXEC);
	if (rp->tfd >= 0) {
		/* event mode: wake at the rows' mean rate */
		double dt = rp->duration / rp->n_rows / t->cfg->speed;
		long ns = (long)(dt * 1e9);
		struct itimerspec its = { { ns / 1000000000, ns % 1000000000 }, { ns / 1000000000, ns % 1000000000 } };

		timerfd_settime(rp->tfd, 0, &its, NULL);
	}
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
	free(rp->rows);
	free(rp);
	t->priv = NULL;
}

int replay_malformed_line(const struct tracker *t)
{
	return ((const struct replay *)t->priv)->first_bad_line;
}

static int replay_poll(struct tracker *t, const struct tracker_clock *now)
{
	struct replay *rp = t->priv;
	const struct cfg_source *cfg = t->cfg;
	double el = (double)(now->mono_ns - rp->t0_ns) * 1e-9 * cfg->speed + cfg->start;
	double t_first = rp->rows[0].t;
	int64_t pass = 0, idx;
	int lo, hi;
	double ct;
	uint64_t due;

	if (rp->tfd >= 0) {
		uint64_t exp;

		while (read(rp->tfd, &exp, sizeof(exp)) > 0)
			;
	}
	if (cfg->loop) {
		pass = (int64_t)floor(el / rp->duration);
		ct = t_first + (el - (double)pass * rp->duration);
	} else {
		ct = t_first + el;
		if (ct > rp->rows[rp->n_rows - 1].t + rp->duration / rp->n_rows) {
			atomic_store_explicit(&t->st.state, TRACKER_ENDED, memory_order_relaxed);
			if (rp->last >= rp->n_rows - 1)
				return 0;
		}
	}
	/* last row with t <= ct */
	lo = 0;
	hi = rp->n_rows - 1;
	if (ct < rp->rows[0].t)
		return 0;
	while (lo < hi) {
		int mid = (lo + hi + 1) / 2;

		if (rp->rows[mid].t <= ct)
			lo = mid;
		else
			hi = mid - 1;
	}
	idx = pass * rp->n_rows + lo;
	if (idx == rp->last)
		return 0;
	rp->last = idx;
	/* the moment the row was due, on the monotonic clock */
	due = rp->t0_ns + (uint64_t)llround(((double)pass * rp->duration + rp->rows[lo].t - t_first - cfg->start) /
					    cfg->speed * 1e9);
	if (due > now->mono_ns)
		due = now->mono_ns;
	for (int r = 0; r < REPLAY_ROLES; r++)
		tracker_put(t, r, &rp->rows[lo].pose[r], (uint64_t)((int64_t)due + now->real_off_ns), now->mono_ns);
	return REPLAY_ROLES;
}

static int replay_fd(struct tracker *t)
{
	return ((struct replay *)t->priv)->tfd;
}

const struct tracker_driver replay_driver = {
	.name = "replay",
	.summary = "plays a recorded sensor CSV (../shared/mocap/csv format) in real time or faster",
	.sensor_count = replay_sensor_count,
	.sensor_name = replay_sensor_name,
	.check = replay_check,
	.open = replay_open,
	.close = replay_close,
	.poll = replay_poll,
	.fd = replay_fd,
};
