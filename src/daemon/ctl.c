// SPDX-License-Identifier: MIT
/*
 * ctl.c - see ctl.h. Runs in the control thread only: it may allocate and
 * take its time; it reads the loop's counters with relaxed atomic loads.
 */
#include "daemon/ctl.h"
#include "base/json.h"
#include "base/clock.h"
#include "base/seqlock.h"
#include "publish/listen.h"

#include "record/recorder.h"
#include "sites/site.h"
#include "trackers/replay.h"

#include <errno.h>
#include <poll.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <time.h>
#include <sys/un.h>
#include <unistd.h>

static const char *const tracker_states[] = { "OK", "STALE", "FAULTY", "ENDED" };
static const char *const sensor_states[] = { "OK", "STALE", "MISSING" };
void ctl_resolve_path(const char *configured, char *out, size_t len)
{
	const char *d;

	if (strcmp(configured, "auto")) {
		snprintf(out, len, "%s", configured);
		return;
	}
	if ((d = getenv("RUNTIME_DIRECTORY")) && d[0]) {
		/* systemd may list several, separated by ':' */
		size_t n = strcspn(d, ":");

		snprintf(out, len, "%.*s/control", (int)n, d);
	} else if ((d = getenv("XDG_RUNTIME_DIR")) && d[0]) {
		snprintf(out, len, "%s/avatargw.control", d);
	} else {
		/* a directory of our own (made with mode 0700), never a name in /tmp itself */
		d = getenv("TMPDIR");
		snprintf(out, len, "%s/avatargw-%u/control", d && d[0] == '/' ? d : "/tmp", (unsigned)geteuid());
	}
}

/*
 * The socket's directory: made (mode 0700) when missing, refused when
 * another user could replace or pre-empt the socket in it (a directory
 * writable by everyone, or owned by someone else than us or root).
 */
static int check_dir(const char *path, char *err, size_t errlen)
{
	char dir[CFG_PATH_MAX];
	const char *slash = strrchr(path, '/');
	struct stat st;

	if (!slash)
		snprintf(dir, sizeof(dir), ".");
	else
		snprintf(dir, sizeof(dir), "%.*s", slash == path ? 1 : (int)(slash - path), path);
	if (stat(dir, &st) && errno == ENOENT && mkdir(dir, 0700) && errno != EEXIST) {
		snprintf(err, errlen, "cannot make its directory %s: %s", dir, strerror(errno));
		return -errno;
	}
	if (stat(dir, &st)) {
		snprintf(err, errlen, "%s: %s", dir, strerror(errno));
		return -errno;
	}
	if (!S_ISDIR(st.st_mode)) {
		snprintf(err, errlen, "%s is not a directory", dir);
		return -ENOTDIR;
	}
	if (st.st_uid != geteuid() && st.st_uid != 0) {
		snprintf(err, errlen, "its directory %s belongs to user %u, not to us (%u) or root: not safe", dir,
			 (unsigned)st.st_uid, (unsigned)geteuid());
		return -EPERM;
	}
	if (st.st_mode & S_IWOTH) {
		snprintf(err, errlen,
			 "its directory %s is writable by every user, who could take the socket's name first: not "
			 "safe",
			 dir);
		return -EPERM;
	}
	return 0;
}

/* a client of the control socket: its request line, then its answer */
struct ctl_client {
	int fd; /* -1: free */
	char req[128];
	size_t got;
	char *text; /* the answer, NULL while the request is read */
	size_t off, len;
	double deadline; /* CLOCK_MONOTONIC s */
};

struct ctl_server {
	int lfd;
	char path[CFG_PATH_MAX];
	struct ctl_client cl[CTL_CLIENTS];
};

static double mono_s(void)
{
	return (double)mono_ns() * 1e-9;
}

int ctl_open(struct ctl_server **out, const char *path, char *err, size_t errlen)
{
	struct ctl_server *s;
	char why[CFG_PATH_MAX + 160];
	int rc;

	*out = NULL;
	if ((rc = check_dir(path, why, sizeof(why)))) {
		snprintf(err, errlen, "control socket %s: %s", path, why);
		return rc;
	}
	s = calloc(1, sizeof(*s));
	if (!s) {
		snprintf(err, errlen, "control socket %s: out of memory", path);
		return -ENOMEM;
	}
	snprintf(s->path, sizeof(s->path), "%s", path);
	for (int i = 0; i < CTL_CLIENTS; i++)
		s->cl[i].fd = -1;
	/* 0600: the daemon's user (and root) only; a request can reload the configuration */
	s->lfd = out_listen_unix(path, 0600, why, sizeof(why));
	if (s->lfd < 0) {
		rc = s->lfd;
		snprintf(err, errlen, "control socket %s", why);
		free(s);
		return rc;
	}
	*out = s;
	return 0;
}

static void client_end(struct ctl_client *c)
{
	close(c->fd);
	free(c->text);
	*c = (struct ctl_client){ .fd = -1 };
}

void ctl_close(struct ctl_server *s)
{
	if (!s)
		return;
	for (int i = 0; i < CTL_CLIENTS; i++)
		if (s->cl[i].fd >= 0)
			client_end(&s->cl[i]);
	out_unix_close(s->lfd, s->path);
	free(s);
}

int ctl_pollfds(struct ctl_server *s, struct pollfd *pf, int max, double *wait_s)
{
	double now = mono_s();
	int n = 0;

	if (!s || max < 1)
		return 0;
	pf[n++] = (struct pollfd){ s->lfd, POLLIN, 0 };
	for (int i = 0; i < CTL_CLIENTS && n < max; i++) {
		struct ctl_client *c = &s->cl[i];

		if (c->fd < 0)
			continue;
		pf[n++] = (struct pollfd){ c->fd, c->text ? POLLOUT : POLLIN, 0 };
		if (c->deadline - now < *wait_s)
			*wait_s = c->deadline - now;
	}
	return n;
}

int ctl_rates_update(struct ctl_rates *r, struct gateway *g)
{
	struct timespec ts;
	double t, dt;
	int n_av = g->n_avatars + g->n_remote;

	clock_gettime(CLOCK_MONOTONIC, &ts);
	t = (double)ts.tv_sec + ts.tv_nsec * 1e-9;
	if (r->n_trackers != g->n_trackers || r->n_avatars != n_av || !r->trk_samples) {
		/* a new configuration: start over */
		ctl_rates_free(r);
		r->n_trackers = g->n_trackers;
		r->n_avatars = n_av;
		r->trk_samples = calloc((size_t)g->n_trackers + 1, sizeof(uint64_t));
		r->trk_rate = calloc((size_t)g->n_trackers + 1, sizeof(double));
		r->av_frames = calloc((size_t)n_av + 1, sizeof(uint64_t));
		r->av_rate = calloc((size_t)n_av + 1, sizeof(double));
		if (!r->trk_samples || !r->trk_rate || !r->av_frames || !r->av_rate)
			return -ENOMEM;
		r->t = 0;
	}
	dt = t - r->t;
	for (int i = 0; i < g->n_trackers; i++) {
		uint64_t s = ctr_get(&g->trk[i].st.samples);

		if (r->t > 0 && dt > 0)
			r->trk_rate[i] =
				(double)(s - r->trk_samples[i]) / dt / (g->trk[i].n_sensors ? g->trk[i].n_sensors : 1);
		r->trk_samples[i] = s;
	}
	for (int i = 0; i < n_av; i++) {
		uint64_t f = ctr_get(&g->av[i].st.frames);

		if (r->t > 0 && dt > 0)
			r->av_rate[i] = (double)(f - r->av_frames[i]) / dt;
		r->av_frames[i] = f;
	}
	r->t = t;
	return 0;
}

void ctl_rates_free(struct ctl_rates *r)
{
	free(r->trk_samples);
	free(r->trk_rate);
	free(r->av_frames);
	free(r->av_rate);
	memset(r, 0, sizeof(*r));
}

static double us(uint64_t ns)
{
	return (double)ns / 1000.0;
}

/*
 * Remote avatar k (gateway av[n_avatars + k]): its name ("SITE/NAME") and
 * state word; false for a slot that never had one. A [site] slot whose site
 * left is GONE; a replayed one counts once it has published, and is GONE
 * where the recording says its site left.
 */
static bool remote_row(struct gateway *g, int k, char *name, size_t len, const char **state, const char **via)
{
	const struct gw_avatar *a = &g->av[g->n_avatars + k];
	uint32_t st = atomic_load_explicit(&a->st.state, memory_order_relaxed) % 3;
	bool live = true;

	if (k < g->n_site) {
		if (!site_remote_name(g->site, k, name, len, &live))
			return false;
		*via = "site";
	} else {
		uint16_t id;

		if (!ctr_get(&a->st.frames))
			return false;
		snprintf(name, len, "%s", a->solved_trk->drv->solved_name(a->solved_trk, a->solved_k, &id));
		*via = a->solved_trk->name;
		live = !atomic_load_explicit(&a->st.gone, memory_order_relaxed);
	}
	*state = live ? sensor_states[st] : "GONE";
	return true;
}

void ctl_status(FILE *out, const struct ctl_info *info, bool json)
{
	struct gateway *g = info->g;
	const struct ctl_rates *r = info->rates;
	struct timespec ts;
	double up;
	int rt = loop_rt_status(info->l);
	const char *rts = rt > 0 ? "SCHED_FIFO" : rt < 0 ? "refused" : "off";
	const struct hist *wk = &g->st.work, *wa = &g->st.wake;

	clock_gettime(CLOCK_MONOTONIC, &ts);
	up = (double)ts.tv_sec + ts.tv_nsec * 1e-9 - info->started;
	if (json) {
		fprintf(out, "{\"uptime_s\":%.3f,\"config\":", up);
		json_string(out, info->config_name);
		fprintf(out,
			",\"source_id\":%u,\"rate_hz\":%.6g,\"mode\":\"%s\","
			"\"realtime\":\"%s\",\"reloads\":%llu,\"reload_failures\":%llu,",
			g->source_id, g->cfg.daemon.rate, g->cfg.daemon.mode == CFG_LOOP_EVENTS ? "events" : "deadline",
			rts, (unsigned long long)info->reloads, (unsigned long long)info->reload_failures);
		fprintf(out,
			"\"loop\":{\"cycles\":%llu,\"overruns\":%llu,\"poll_errors\":%llu,"
			"\"work_us\":{\"p50\":%.1f,\"p99\":%.1f,\"max\":%.1f},"
			"\"work_cpu_us\":{\"p50\":%.1f,\"p99\":%.1f,\"max\":%.1f},"
			"\"wake_late_us\":{\"p50\":%.1f,\"p99\":%.1f,\"max\":%.1f}},",
			(unsigned long long)ctr_get(&g->st.cycles), (unsigned long long)ctr_get(&g->st.overruns),
			(unsigned long long)ctr_get(&g->st.poll_errors), us(hist_percentile(wk, 0.5)),
			us(hist_percentile(wk, 0.99)), us(ctr_get(&wk->max_ns)),
			us(hist_percentile(&g->st.work_cpu, 0.5)), us(hist_percentile(&g->st.work_cpu, 0.99)),
			us(ctr_get(&g->st.work_cpu.max_ns)), us(hist_percentile(wa, 0.5)),
			us(hist_percentile(wa, 0.99)), us(ctr_get(&wa->max_ns)));
		fputs("\"sources\":[", out);
		for (int i = 0; i < g->n_trackers; i++) {
			struct tracker *t = &g->trk[i];

			fprintf(out, "%s{\"name\":", i ? "," : "");
			json_string(out, t->name);
			fputs(",\"driver\":", out);
			json_string(out, t->drv->type.name);
			fprintf(out,
				",\"state\":\"%s\",\"sensors\":%d,"
				"\"samples\":%llu,\"rate_hz\":%.2f,\"malformed\":%llu,\"faults\":%llu,\"lost\":%llu,"
				"\"reconnects\":%llu",
				tracker_states[atomic_load_explicit(&t->st.state, memory_order_relaxed) & 3],
				t->n_sensors, (unsigned long long)ctr_get(&t->st.samples),
				r && i < r->n_trackers ? r->trk_rate[i] : 0.0,
				(unsigned long long)ctr_get(&t->st.malformed),
				(unsigned long long)ctr_get(&t->st.faults), (unsigned long long)ctr_get(&t->st.lost),
				(unsigned long long)ctr_get(&t->st.reconnects));
			if (t->drv->status) {
				char dev[256];

				t->drv->status(t, dev, sizeof(dev));
				fputs(",\"device\":\"", out);
				json_escape(out, dev);
				fputc('"', out);
			}
			if (t->drv->report)
				t->drv->report(t, out, true);
			fputc('}', out);
		}
		fputs("],\"avatars\":[", out);
		for (int i = 0; i < g->n_avatars; i++) {
			struct gw_avatar *a = &g->av[i];
			uint64_t solves = ctr_get(&a->st.ik_solves);

			fprintf(out, "%s{\"name\":", i ? "," : "");
			json_string(out, a->cfg->name);
			fprintf(out,
				",\"id\":%u,\"state\":\"%s\",\"remote\":false,\"frames\":%llu,\"rate_hz\":%.2f,"
				"\"new_frames\":%llu,\"stale_frames\":%llu,\"held\":%llu,\"ik_iters_per_arm\":%.3f,"
				"\"ik_unreached\":%llu,\"nan_blocked\":%llu,"
				"\"latency_us\":{\"n\":%llu,\"p50\":%.1f,\"p99\":%.1f,\"p999\":%.1f,\"max\":%.1f}}",
				a->cfg->id, sensor_states[atomic_load_explicit(&a->st.state, memory_order_relaxed) % 3],
				(unsigned long long)ctr_get(&a->st.frames), r && i < r->n_avatars ? r->av_rate[i] : 0.0,
				(unsigned long long)ctr_get(&a->st.new_frames),
				(unsigned long long)ctr_get(&a->st.stale_frames),
				(unsigned long long)ctr_get(&a->st.held),
				solves ? (double)ctr_get(&a->st.ik_iters) / (double)solves : 0.0,
				(unsigned long long)ctr_get(&a->st.ik_unreached),
				(unsigned long long)ctr_get(&a->st.nan_blocked),
				(unsigned long long)ctr_get(&a->st.latency.n), us(hist_percentile(&a->st.latency, 0.5)),
				us(hist_percentile(&a->st.latency, 0.99)), us(hist_percentile(&a->st.latency, 0.999)),
				us(ctr_get(&a->st.latency.max_ns)));
		}
		for (int k = 0, n = g->n_avatars; k < g->n_remote; k++) {
			const struct gw_avatar *a = &g->av[g->n_avatars + k];
			const char *state, *via;
			char name[64];

			if (!remote_row(g, k, name, sizeof(name), &state, &via))
				continue;
			/* solved at its site: no IK figures of ours; its name is what the network said */
			fprintf(out, "%s{\"name\":", n++ ? "," : "");
			json_string(out, name);
			fprintf(out, ",\"id\":%u,\"state\":\"%s\",\"remote\":true,\"via\":", a->id, state);
			json_string(out, via);
			fprintf(out, ",\"frames\":%llu,\"rate_hz\":%.2f,\"new_frames\":%llu,\"stale_frames\":%llu}",
				(unsigned long long)ctr_get(&a->st.frames),
				r && g->n_avatars + k < r->n_avatars ? r->av_rate[g->n_avatars + k] : 0.0,
				(unsigned long long)ctr_get(&a->st.new_frames),
				(unsigned long long)ctr_get(&a->st.stale_frames));
		}
		fputs("],\"outputs\":[", out);
		for (int i = 0; i < g->n_outputs; i++) {
			struct output *o = &g->out[i];

			fprintf(out, "%s{\"name\":", i ? "," : "");
			json_string(out, o->name);
			fprintf(out,
				",\"type\":\"%s\",\"sent\":%llu,\"dropped\":%llu,\"errors\":%llu,"
				"\"clients\":%llu,\"accepted\":%llu,\"refused\":%llu,\"closed\":%llu,\"gso_off\":%llu,"
				"\"malformed\":%llu",
				o->ops->type.name, (unsigned long long)ctr_get(&o->st.sent),
				(unsigned long long)ctr_get(&o->st.dropped), (unsigned long long)ctr_get(&o->st.errors),
				(unsigned long long)ctr_get(&o->st.clients),
				(unsigned long long)ctr_get(&o->st.accepted),
				(unsigned long long)ctr_get(&o->st.refused), (unsigned long long)ctr_get(&o->st.closed),
				(unsigned long long)ctr_get(&o->st.gso_off),
				(unsigned long long)ctr_get(&o->st.malformed));
			if (o->ops->report)
				o->ops->report(o, out, true);
			fputc('}', out);
		}
		fputs("]", out);
		site_report(g->site, out, true);
		if (g->rec) {
			const struct recorder_stats *rs = recorder_stats(g->rec);
			char file[CFG_PATH_MAX + 64];
			uint64_t used, cap;

			recorder_current_file(g->rec, file, sizeof(file));
			recorder_ring_use(g->rec, &used, &cap);
			fputs(",\"recorder\":{\"dir\":", out);
			json_string(out, g->cfg.daemon.record_dir);
			fputs(",\"file\":", out);
			json_string(out, file);
			fprintf(out,
				",\"files\":%llu,\"records\":%llu,"
				"\"bytes\":%llu,\"flushes\":%llu,\"dropped\":%llu,\"skipped\":%llu,\"write_errors\":%"
				"llu,"
				"\"buffer_used\":%llu,\"buffer_size\":%llu}",
				(unsigned long long)ctr_get(&rs->files), (unsigned long long)ctr_get(&rs->records),
				(unsigned long long)ctr_get(&rs->bytes), (unsigned long long)ctr_get(&rs->flushes),
				(unsigned long long)ctr_get(&rs->dropped_records),
				(unsigned long long)ctr_get(&rs->skipped_records),
				(unsigned long long)ctr_get(&rs->write_errors), (unsigned long long)used,
				(unsigned long long)cap);
		}
		fputs("}\n", out);
		return;
	}
	fprintf(out, "avatargw: up %.1f s, config %s, %.6g Hz %s, real-time %s, reloads %llu (%llu failed)\n", up,
		info->config_name, g->cfg.daemon.rate,
		g->cfg.daemon.mode == CFG_LOOP_EVENTS ? "on events" : "to deadlines", rts,
		(unsigned long long)info->reloads, (unsigned long long)info->reload_failures);
	fprintf(out,
		"loop: %llu cycles, %llu overruns, work p50 %.1f p99 %.1f max %.1f us, wake-up late p99 %.1f max %.1f "
		"us\n",
		(unsigned long long)ctr_get(&g->st.cycles), (unsigned long long)ctr_get(&g->st.overruns),
		us(hist_percentile(wk, 0.5)), us(hist_percentile(wk, 0.99)), us(ctr_get(&wk->max_ns)),
		us(hist_percentile(wa, 0.99)), us(ctr_get(&wa->max_ns)));
	fprintf(out, "\n%-16s %-8s %-7s %8s %10s %9s %7s %7s %6s\n", "SOURCE", "DRIVER", "STATE", "RATE/s", "SAMPLES",
		"MALFORMED", "FAULTS", "LOST", "RECONN");
	for (int i = 0; i < g->n_trackers; i++) {
		struct tracker *t = &g->trk[i];

		fprintf(out, "%-16s %-8s %-7s %8.1f %10llu %9llu %7llu %7llu %6llu\n", t->name, t->drv->type.name,
			tracker_states[atomic_load_explicit(&t->st.state, memory_order_relaxed) & 3],
			r && i < r->n_trackers ? r->trk_rate[i] : 0.0, (unsigned long long)ctr_get(&t->st.samples),
			(unsigned long long)ctr_get(&t->st.malformed), (unsigned long long)ctr_get(&t->st.faults),
			(unsigned long long)ctr_get(&t->st.lost), (unsigned long long)ctr_get(&t->st.reconnects));
		if (t->drv->status) {
			char dev[256];

			t->drv->status(t, dev, sizeof(dev));
			fprintf(out, "  device: %s\n", dev);
		}
	}
	fprintf(out, "\n%-16s %5s %-6s %8s %9s %7s %6s %8s %9s %5s %26s\n", "AVATAR", "ID", "STATE", "RATE/s", "FRAMES",
		"STALE", "HELD", "IK_IT/ARM", "UNREACHED", "NAN", "LATENCY us p50/p99/max");
	for (int i = 0; i < g->n_avatars; i++) {
		struct gw_avatar *a = &g->av[i];
		uint64_t solves = ctr_get(&a->st.ik_solves);

		fprintf(out, "%-16s %5u %-6s %8.1f %9llu %7llu %6llu %8.2f %9llu %5llu %10.1f/%.1f/%.1f\n",
			a->cfg->name, a->cfg->id,
			sensor_states[atomic_load_explicit(&a->st.state, memory_order_relaxed) % 3],
			r && i < r->n_avatars ? r->av_rate[i] : 0.0, (unsigned long long)ctr_get(&a->st.frames),
			(unsigned long long)ctr_get(&a->st.stale_frames), (unsigned long long)ctr_get(&a->st.held),
			solves ? (double)ctr_get(&a->st.ik_iters) / (double)solves : 0.0,
			(unsigned long long)ctr_get(&a->st.ik_unreached),
			(unsigned long long)ctr_get(&a->st.nan_blocked), us(hist_percentile(&a->st.latency, 0.5)),
			us(hist_percentile(&a->st.latency, 0.99)), us(ctr_get(&a->st.latency.max_ns)));
	}
	for (int k = 0; k < g->n_remote; k++) {
		const struct gw_avatar *a = &g->av[g->n_avatars + k];
		const char *state, *via;
		char name[64];

		if (!remote_row(g, k, name, sizeof(name), &state, &via))
			continue;
		fprintf(out, "%-16s %5u %-6s %8.1f %9llu %7llu %6s %8s %9s %5s %26s\n", name, a->id, state,
			r && g->n_avatars + k < r->n_avatars ? r->av_rate[g->n_avatars + k] : 0.0,
			(unsigned long long)ctr_get(&a->st.frames), (unsigned long long)ctr_get(&a->st.stale_frames),
			"-", "-", "-", "-", strcmp(via, "site") ? "replayed" : "remote");
	}
	fprintf(out, "\n%-16s %-9s %10s %9s %7s %8s\n", "OUTPUT", "TYPE", "SENT", "DROPPED", "ERRORS", "CLIENTS");
	for (int i = 0; i < g->n_outputs; i++) {
		struct output *o = &g->out[i];

		fprintf(out, "%-16s %-9s %10llu %9llu %7llu %8llu\n", o->name, o->ops->type.name,
			(unsigned long long)ctr_get(&o->st.sent), (unsigned long long)ctr_get(&o->st.dropped),
			(unsigned long long)ctr_get(&o->st.errors), (unsigned long long)ctr_get(&o->st.clients));
	}
	for (int i = 0; i < g->n_trackers; i++)
		if (g->trk[i].drv->report)
			g->trk[i].drv->report(&g->trk[i], out, false);
	for (int i = 0; i < g->n_outputs; i++)
		if (g->out[i].ops->report)
			g->out[i].ops->report(&g->out[i], out, false);
	site_report(g->site, out, false);
	if (g->rec) {
		const struct recorder_stats *rs = recorder_stats(g->rec);
		char file[CFG_PATH_MAX + 64];

		recorder_current_file(g->rec, file, sizeof(file));
		fprintf(out,
			"\nrecording: %s\n  %llu files, %llu records, %.1f MiB written, %llu dropped (buffer full), "
			"%llu not written, %llu write errors\n",
			file[0] ? file : "(no file open)", (unsigned long long)ctr_get(&rs->files),
			(unsigned long long)ctr_get(&rs->records), (double)ctr_get(&rs->bytes) / 1048576.0,
			(unsigned long long)ctr_get(&rs->dropped_records),
			(unsigned long long)ctr_get(&rs->skipped_records),
			(unsigned long long)ctr_get(&rs->write_errors));
	}
}

/*
 * `sensors NAME`: the avatar's head, left and right hand as the loop gathered
 * them in a cycle after the request (struct gw_probe), one JSON line, with
 * the [avatar SECTION] it comes from and how many avatars that section
 * makes (count = N); for a calibration. Waits for such a cycle: 250 ms or
 * three periods, whichever is longer.
 */
static void ctl_sensors(FILE *out, const struct ctl_info *info, const char *name)
{
	static const char *const roles[FRAME_SENSORS] = { "head", "left_hand", "right_hand" };
	static const char *const states[] = { "ok", "stale", "missing" };
	struct gateway *g = info->g;
	uint32_t w[GW_PROBE_WORDS], s0;
	uint64_t t;
	int idx = -1, shared = 0, wait_ms = (int)(3000.0 / g->cfg.daemon.rate);

	while (*name == ' ')
		name++;
	for (int i = 0; i < g->n_avatars && idx < 0; i++)
		if (!strcmp(g->av[i].cfg->name, name))
			idx = i;
	if (idx < 0) {
		fprintf(out, "error: no avatar '%s'\n", name);
		return;
	}
	for (int i = 0; i < g->n_avatars; i++)
		shared += !strcmp(g->av[i].cfg->section, g->av[idx].cfg->section);
	if (wait_ms < 250)
		wait_ms = 250;
	/*
	 * A copy written after the request (the write count moved on by two:
	 * one whole write after the request) of the avatar named (its index in
	 * the copy: a cycle that read want before the request wrote another).
	 */
	atomic_store_explicit(&g->probe.want, idx + 1, memory_order_relaxed);
	s0 = seqlock_peek(&g->probe.seq) & ~1u;
	for (int k = 0;; k++) {
		uint32_t s = seqlock_peek(&g->probe.seq);

		if (!(s & 1) && s - s0 >= 4 &&
		    (seqlock_read(&g->probe.seq, g->probe.words, w, GW_PROBE_WORDS), w[2]) == (uint32_t)idx)
			break;
		if (k >= wait_ms) {
			atomic_store_explicit(&g->probe.want, 0, memory_order_relaxed);
			fprintf(out, "error: the loop has not run for %d ms\n", wait_ms);
			return;
		}
		usleep(1000);
	}
	atomic_store_explicit(&g->probe.want, 0, memory_order_relaxed);
	t = (uint64_t)w[0] | (uint64_t)w[1] << 32;
	fputs("{\"avatar\":", out);
	json_string(out, name);
	fprintf(out, ",\"id\":%u,\"section\":", g->av[idx].cfg->id);
	json_string(out, g->av[idx].cfg->section);
	fprintf(out, ",\"section_avatars\":%d,\"hand\":%.4f,\"mono_ns\":%llu,\"sensors\":[", shared,
		(double)g->av[idx].av->body.dims.hand, (unsigned long long)t);
	for (int r = 0; r < FRAME_SENSORS; r++) {
		const uint32_t *o = w + GW_PROBE_HEAD + r * GW_PROBE_SENSOR_WORDS;
		float v[7];

		memcpy(v, o + 1, sizeof(v));
		fprintf(out, "%s{\"role\":\"%s\",\"state\":\"%s\"", r ? "," : "", roles[r], states[o[0] % 3]);
		if (o[0] != WIRE_SENSOR_MISSING)
			fprintf(out, ",\"p\":[%.6f,%.6f,%.6f],\"q\":[%.6f,%.6f,%.6f,%.6f]", v[0], v[1], v[2], v[3],
				v[4], v[5], v[6]);
		fputc('}', out);
	}
	fputs("]}\n", out);
}

/* "step [N] [SOURCE]": N more instants of every stepped replay source, or of SOURCE */
static void ctl_step(FILE *out, const struct ctl_info *info, const char *args)
{
	struct gateway *g = info->g;
	char name[128] = "";
	unsigned long n = 1;
	int done = 0;

	while (*args == ' ')
		args++;
	if (*args >= '0' && *args <= '9') {
		char *end;

		n = strtoul(args, &end, 10);
		args = end;
		while (*args == ' ')
			args++;
	}
	if (*args)
		snprintf(name, sizeof(name), "%s", args);
	if (n < 1 || n > 1000000) {
		fputs("error: step N: N from 1 to 1000000\n", out);
		return;
	}
	for (int i = 0; i < g->n_trackers; i++) {
		struct tracker *t = &g->trk[i];

		if (name[0] && strcmp(name, t->name))
			continue;
		if (!replay_is_stepped(t)) {
			if (name[0]) {
				fprintf(out, "error: source %s is not a replay with step = yes\n", name);
				return;
			}
			continue;
		}
		replay_step(t, (unsigned)n);
		fprintf(out, "%s: %lu more\n", t->name, n);
		done++;
	}
	if (!done)
		fprintf(out, "error: %s%s\n", name[0] ? "no source named " : "no replay source has step = yes",
			name[0] ? name : "");
}

char *ctl_answer(const char *line, const struct ctl_info *info, bool *want_reload, size_t *len)
{
	char req[128], *text = NULL;
	FILE *out;

	snprintf(req, sizeof(req), "%s", line);
	req[strcspn(req, "\r\n")] = '\0';
	out = open_memstream(&text, len);
	if (!out)
		return NULL;
	if (!strcmp(req, "status"))
		ctl_status(out, info, false);
	else if (!strcmp(req, "status json"))
		ctl_status(out, info, true);
	else if (!strcmp(req, "reload")) {
		*want_reload = true;
		fputs("reloading\n", out);
	} else if (!strcmp(req, "step") || !strncmp(req, "step ", 5))
		ctl_step(out, info, req + 4);
	else if (!strncmp(req, "sensors ", 8))
		ctl_sensors(out, info, req + 8);
	else
		fprintf(out,
			"error: unknown request '%s' (status, status json, reload, step [N] [SOURCE], sensors "
			"AVATAR)\n",
			req);
	fclose(out);
	return text;
}

/* what the client takes of its answer now; true when it is all sent (or the client is gone) */
static bool client_send(struct ctl_client *c)
{
	while (c->off < c->len) {
		ssize_t n = send(c->fd, c->text + c->off, c->len - c->off, MSG_NOSIGNAL | MSG_DONTWAIT);

		if (n > 0) {
			c->off += (size_t)n;
			continue;
		}
		if (n < 0 && errno == EINTR)
			continue;
		return !(n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK));
	}
	return true;
}

/* reads what the client sent; once its line is whole (or it stopped sending), answers it */
static void client_read(struct ctl_client *c, const struct ctl_info *info, bool *want_reload)
{
	bool whole = false;

	for (;;) {
		ssize_t n = recv(c->fd, c->req + c->got, sizeof(c->req) - 1 - c->got, MSG_DONTWAIT);

		if (n > 0) {
			c->got += (size_t)n;
			c->req[c->got] = '\0';
			if (memchr(c->req, '\n', c->got) || c->got == sizeof(c->req) - 1) {
				whole = true;
				break;
			}
			continue;
		}
		if (n < 0 && errno == EINTR)
			continue;
		if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK))
			return;
		whole = n == 0 && c->got; /* a request without its newline, then EOF (shutdown) */
		break;
	}
	if (!whole) {
		client_end(c);
		return;
	}
	c->text = ctl_answer(c->req, info, want_reload, &c->len);
	c->off = 0;
	/* the answer gets its own second to be taken */
	c->deadline = mono_s() + CTL_DEADLINE_S;
	if (!c->text || client_send(c))
		client_end(c);
}

void ctl_serve(struct ctl_server *s, const struct pollfd *pf, int n, const struct ctl_info *info, bool *want_reload)
{
	double now = mono_s();

	if (!s || n < 1)
		return;
	for (int k = 1; k < n; k++) {
		for (int i = 0; i < CTL_CLIENTS; i++) {
			struct ctl_client *c = &s->cl[i];

			if (c->fd != pf[k].fd || !pf[k].revents)
				continue;
			if (c->text) {
				if (client_send(c))
					client_end(c);
			} else {
				client_read(c, info, want_reload);
			}
			break;
		}
	}
	/* new clients: each has CTL_DEADLINE_S for its request line */
	if (pf[0].revents & POLLIN) {
		for (int k = 0; k < CTL_CLIENTS; k++) {
			int fd = accept4(s->lfd, NULL, NULL, SOCK_NONBLOCK | SOCK_CLOEXEC), slot = -1;

			if (fd < 0)
				break;
			for (int i = 0; i < CTL_CLIENTS && slot < 0; i++)
				if (s->cl[i].fd < 0)
					slot = i;
			if (slot < 0) {
				/* every slot waits on a client: this one is refused, not queued */
				static const char busy[] = "error: busy (too many clients at once), try again\n";

				ssize_t r = send(fd, busy, sizeof(busy) - 1, MSG_NOSIGNAL | MSG_DONTWAIT);

				(void)r;
				close(fd);
				continue;
			}
			s->cl[slot] = (struct ctl_client){ .fd = fd, .deadline = now + CTL_DEADLINE_S };
			/* a request sent with the connection is answered now */
			client_read(&s->cl[slot], info, want_reload);
		}
	}
	now = mono_s();
	for (int i = 0; i < CTL_CLIENTS; i++)
		if (s->cl[i].fd >= 0 && now >= s->cl[i].deadline)
			client_end(&s->cl[i]); /* too slow to ask, or to take its answer */
}
