// SPDX-License-Identifier: MIT
/*
 * main.c - avatargw: the control thread.
 *
 * Start-up, in this order (torn down in reverse): configuration, gateway
 * (trackers, avatars, outputs), the control socket, mlockall, the loop
 * thread, READY=1. Then the control thread waits on its signalfd and the
 * control socket: SIGHUP reloads (a bad configuration is rejected and the
 * running one stays), SIGTERM/SIGINT stop, and once a second it feeds the
 * watchdog if the loop advanced, refreshes STATUS= and logs what the loop
 * counted.
 */
#include "config/config.h"
#include "daemon/ctl.h"
#include "daemon/gateway.h"
#include "trackers/replay.h"
#include "base/log.h"
#include "daemon/loop.h"
#include "daemon/notify.h"
#include "record/recorder.h"
#include "trackers/probe.h"
#include "trackers/tracker.h"

#include <errno.h>
#include <fcntl.h>
#include <getopt.h>
#include <poll.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/random.h>
#include <sys/signalfd.h>
#include <time.h>
#include <unistd.h>

#define DEFAULT_CONFIG "/etc/avatargw/avatargw.conf"
#define DEMO_CONFIG "builtin:demo.conf"
#define MAX_SETS 64

#ifndef AVATARGW_VERSION
#define AVATARGW_VERSION "0.3"
#endif

static void usage(FILE *out)
{
	fprintf(out,
		"usage: avatargw [-c FILE | --demo] [--set SECTION.KEY=VALUE]... [--check-config]\n"
		"       avatargw --list-devices | --keys | --probe URL\n"
		"\n"
		"  -c, --config FILE   configuration (default " DEFAULT_CONFIG "), plus FILE's conf.d/*.conf\n"
		"      --demo          the configuration compiled in (config/demo.conf): a replayed clip, no hardware\n"
		"  -s, --set S.K=V     override one key, e.g. --set 'output local.port=7771'\n"
		"      --check-config  check the configuration, print it with every default, exit (78 if wrong)\n"
		"      --keys          every configuration key with default, unit and meaning\n"
		"      --list-devices  the supported trackers plugged in, each with the configuration lines to use it\n"
		"      --probe URL     look at a network tracker for two seconds (vrpn://Tracker0@host[:port],\n"
		"                      dtrack://[address]:port): what it sends, and the configuration lines to read "
		"it\n"
		"  -V, --version\n"
		"  -h, --help\n"
		"\n"
		"Signals: SIGHUP reloads the configuration, SIGTERM/SIGINT stop. avatargw-ctl status shows the "
		"state.\n");
}

static double mono_s(void)
{
	struct timespec ts;

	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (double)ts.tv_sec + ts.tv_nsec * 1e-9;
}

static uint32_t random_source_id(void)
{
	uint32_t id = 0;

	if (getrandom(&id, sizeof(id), GRND_NONBLOCK) != sizeof(id)) {
		struct timespec ts;

		clock_gettime(CLOCK_REALTIME, &ts);
		id = (uint32_t)ts.tv_nsec ^ (uint32_t)getpid() << 16;
	}
	return id ? id : 1;
}

static int level_of(int cfg_level)
{
	static const int map[] = { LOG_ERR, LOG_WARNING, LOG_INFO, LOG_DEBUG };

	return map[cfg_level];
}

/* what the loop counted since last time, logged with a rate limit (once a second at most per kind) */
struct seen {
	uint64_t overruns, poll_errors;
	uint64_t *dropped, *errors, *nan, *malformed, *faults;
	int n_out, n_av, n_trk;
};

static void seen_reset(struct seen *s, struct gateway *g)
{
	free(s->dropped);
	free(s->errors);
	free(s->nan);
	free(s->malformed);
	free(s->faults);
	memset(s, 0, sizeof(*s));
	s->n_out = g->n_outputs;
	s->n_av = g->n_avatars;
	s->n_trk = g->n_trackers;
	s->dropped = calloc((size_t)s->n_out + 1, sizeof(uint64_t));
	s->errors = calloc((size_t)s->n_out + 1, sizeof(uint64_t));
	s->nan = calloc((size_t)s->n_av + 1, sizeof(uint64_t));
	s->malformed = calloc((size_t)s->n_trk + 1, sizeof(uint64_t));
	s->faults = calloc((size_t)s->n_trk + 1, sizeof(uint64_t));
}

/* what the trackers' device threads left for the log */
static void drain_notes(struct gateway *g)
{
	for (int i = 0; i < g->n_trackers; i++) {
		struct tracker *t = &g->trk[i];
		char text[600]; /* a device note: DEVICE_NOTE_LEN */
		int level;

		while (t->drv->note && t->drv->note(t, &level, text, sizeof(text)))
			log_msg(level, "%s", text);
	}
}

static int list_devices(void)
{
	int n = 0;

	for (int i = 0; i < trackers_count; i++)
		if (trackers_table[i]->list_devices)
			n += trackers_table[i]->list_devices(stdout);
	if (!n)
		printf("no supported tracker found: Razer Hydra (1532:0300), Polhemus Liberty, Liberty HS, Patriot "
		       "(0f44:ff12, ff20, ef12, ef20; ff11, ff21, ef11, ef21 before their firmware).\n"
		       "Is it plugged in (lsusb)? README.md, \"Setting up a tracker\", goes through it step by "
		       "step.\n");
	return 0;
}

static void report(struct seen *s, struct gateway *g)
{
	uint64_t v;

	drain_notes(g);
	if (!s->dropped || !s->errors || !s->nan || !s->malformed || !s->faults)
		return;
	if ((v = ctr_get(&g->st.overruns)) != s->overruns) {
		pr_warning("loop: %llu overruns (cycles that missed their deadline), %llu in all",
			   (unsigned long long)(v - s->overruns), (unsigned long long)v);
		s->overruns = v;
	}
	for (int i = 0; i < s->n_out; i++) {
		struct output *o = &g->out[i];

		if ((v = ctr_get(&o->st.dropped)) != s->dropped[i]) {
			pr_info("output %s: %llu messages dropped (a full socket or a slow subscriber), %llu in all",
				o->name, (unsigned long long)(v - s->dropped[i]), (unsigned long long)v);
			s->dropped[i] = v;
		}
		if ((v = ctr_get(&o->st.errors)) != s->errors[i]) {
			pr_warning("output %s: %llu send errors, last: %s", o->name,
				   (unsigned long long)(v - s->errors[i]),
				   strerror(atomic_load_explicit(&o->st.last_errno, memory_order_relaxed)));
			s->errors[i] = v;
		}
	}
	for (int i = 0; i < s->n_av; i++)
		if ((v = ctr_get(&g->av[i].st.nan_blocked)) != s->nan[i]) {
			pr_err("avatar %s: %llu frames not published: a number was not finite", g->av[i].cfg->name,
			       (unsigned long long)(v - s->nan[i]));
			s->nan[i] = v;
		}
	for (int i = 0; i < s->n_trk; i++) {
		struct tracker *t = &g->trk[i];

		if ((v = ctr_get(&t->st.malformed)) != s->malformed[i]) {
			pr_warning("source %s: %llu malformed samples dropped", t->name,
				   (unsigned long long)(v - s->malformed[i]));
			s->malformed[i] = v;
		}
		if ((v = ctr_get(&t->st.faults)) != s->faults[i]) {
			char why[256] = "";

			if (t->drv->status)
				t->drv->status(t, why, sizeof(why));
			pr_err("source %s: FAULTY (%llu faults in all)%s%s", t->name, (unsigned long long)v,
			       why[0] ? ": " : "", why);
			s->faults[i] = v;
		}
	}
}

/* the loop's and the recorder's counters at the end, for the journal: final once the loop has stopped */
static void final_line(struct gateway *g, struct recorder *rec)
{
	char tail[160] = "";

	if (rec) {
		const struct recorder_stats *rs = recorder_stats(rec);

		snprintf(tail, sizeof(tail), "; recorder: %llu records, %llu dropped, %llu write errors",
			 (unsigned long long)ctr_get(&rs->records), (unsigned long long)ctr_get(&rs->dropped_records),
			 (unsigned long long)ctr_get(&rs->write_errors));
	}
	pr_info("stopped after %llu cycles, %llu overruns, %llu poll errors%s",
		(unsigned long long)ctr_get(&g->st.cycles), (unsigned long long)ctr_get(&g->st.overruns),
		(unsigned long long)ctr_get(&g->st.poll_errors), tail);
}

static void status_line(struct gateway *g)
{
	int ok = 0;

	for (int i = 0; i < g->n_avatars; i++)
		ok += atomic_load_explicit(&g->av[i].st.state, memory_order_relaxed) == 0;
	notify_sendf("STATUS=%d avatars (%d tracking), %d sources, %d outputs, %llu overruns", g->n_avatars, ok,
		     g->n_trackers, g->n_outputs, (unsigned long long)ctr_get(&g->st.overruns));
}

/*
 * Locks what the daemon uses in memory, not everything it maps: with
 * MCL_ONFAULT a page is locked when first touched, so the libraries linked
 * for outputs or trackers a configuration does not use (and their own
 * dependencies: libwebsockets brings OpenSSL) cost no RAM. What the loop
 * touches is faulted in before it runs: the gateway's buffers are written
 * at gw_open(), the loop thread's stack at its start, and our own code here
 * (the libraries' few pages on the loop's path are taken, and locked, in
 * its first cycle).
 */
static int lock_memory(void)
{
	extern const char __executable_start[], etext[];
	long page = sysconf(_SC_PAGESIZE);
	int flags = MCL_CURRENT | MCL_FUTURE;

#ifdef MCL_ONFAULT
	flags |= MCL_ONFAULT;
#endif
	if (mlockall(flags))
		return -1;
	for (const char *p = __executable_start; p < etext; p += page)
		(void)*(const volatile char *)p;
	return 0;
}

int main(int argc, char **argv)
{
	static const struct option opts[] = {
		{ "config", required_argument, NULL, 'c' }, { "demo", no_argument, NULL, 'D' },
		{ "set", required_argument, NULL, 's' },    { "check-config", no_argument, NULL, 'C' },
		{ "keys", no_argument, NULL, 'K' },	    { "version", no_argument, NULL, 'V' },
		{ "help", no_argument, NULL, 'h' },	    { "list-devices", no_argument, NULL, 'L' },
		{ "probe", required_argument, NULL, 'P' },  { NULL, 0, NULL, 0 },
	};
	static struct gateway gws[2];
	const char *path = DEFAULT_CONFIG;
	const char *sets[MAX_SETS];
	int n_sets = 0, cur = 0, sfd, opt;
	bool check = false, given = false;
	char err[1024], ctl_path[CFG_PATH_MAX];
	struct config cfg;
	struct loop *loop = NULL;
	struct ctl_server *ctl = NULL;
	struct recorder *rec = NULL;
	struct ctl_rates rates = { 0 };
	struct ctl_info info = { 0 };
	struct seen seen = { 0 };
	uint32_t source_id;
	uint64_t wd_usec, last_beat = 0;
	double next_tick, next_wd = 0;
	sigset_t sigs;
	bool stop = false;

	while ((opt = getopt_long(argc, argv, "c:s:Vh", opts, NULL)) != -1) {
		switch (opt) {
		case 'c':
			path = optarg;
			given = true;
			break;
		case 'D':
			path = DEMO_CONFIG;
			given = true;
			break;
		case 's':
			if (n_sets == MAX_SETS) {
				fprintf(stderr, "avatargw: more than %d --set\n", MAX_SETS);
				return 64;
			}
			sets[n_sets++] = optarg;
			break;
		case 'C':
			check = true;
			break;
		case 'K':
			config_print_reference(stdout);
			return 0;
		case 'L':
			return list_devices();
		case 'P':
			return tracker_probe(optarg, 2.0, stdout, stderr);
		case 'V':
			printf("avatargw %s\n", AVATARGW_VERSION);
			return 0;
		case 'h':
			usage(stdout);
			return 0;
		default:
			usage(stderr);
			return 64;
		}
	}
	if (optind < argc) {
		usage(stderr);
		return 64;
	}
	(void)given;
	if (config_load_ex(&cfg, path, sets, n_sets, err, sizeof(err))) {
		fprintf(stderr, "avatargw: configuration error: %s\n", err);
		return EX_CONFIG_CODE;
	}
	if (check) {
		config_print(&cfg, stdout);
		config_free(&cfg);
		return 0;
	}
	log_set_level(level_of(cfg.daemon.log_level));

	/* the loop thread inherits this mask: signals reach the signalfd only */
	sigemptyset(&sigs);
	sigaddset(&sigs, SIGHUP);
	sigaddset(&sigs, SIGTERM);
	sigaddset(&sigs, SIGINT);
	sigaddset(&sigs, SIGPIPE);
	pthread_sigmask(SIG_BLOCK, &sigs, NULL);
	sigdelset(&sigs, SIGPIPE);
	sfd = signalfd(-1, &sigs, SFD_CLOEXEC | SFD_NONBLOCK);
	if (sfd < 0) {
		pr_err("signalfd: %s", strerror(errno));
		return 1;
	}

	source_id = random_source_id();
	if (gw_open(&gws[cur], &cfg, NULL, source_id, err, sizeof(err))) {
		pr_err("%s", err);
		config_free(&cfg);
		/*
		 * An output that cannot be opened as configured (a port or a socket
		 * in use, an address that does not resolve): a restart would fail
		 * the same way, so the configuration error's status (the unit does
		 * not restart on it).
		 */
		return EX_CONFIG_CODE;
	}
	/* the control socket before anything runs: one that cannot be ours stops the start the same way */
	ctl_resolve_path(gws[cur].cfg.daemon.control_socket, ctl_path, sizeof(ctl_path));
	if (ctl_path[0] && ctl_open(&ctl, ctl_path, err, sizeof(err))) {
		pr_err("%s (daemon.control_socket; empty: none)", err);
		gw_close(&gws[cur]);
		return EX_CONFIG_CODE;
	}
	for (int i = 0; i < gws[cur].n_trackers; i++)
		replay_log_damage(&gws[cur].trk[i]);
	if (gw_record(&gws[cur], &rec, err, sizeof(err)))
		pr_err("%s: the daemon runs without recording", err);
	if (gws[cur].cfg.daemon.lock_memory && lock_memory())
		pr_warning("mlockall: %s: memory may be paged out (raise LimitMEMLOCK)", strerror(errno));
	if (loop_start(&loop, &gws[cur], err, sizeof(err))) {
		pr_err("%s", err);
		ctl_close(ctl);
		gw_close(&gws[cur]);
		return 1;
	}
	if (loop_rt_status(loop) < 0)
		pr_warning("SCHED_FIFO priority %d refused: the loop runs with normal scheduling (raise LimitRTPRIO)",
			   gws[cur].cfg.daemon.realtime_priority);
	info = (struct ctl_info){ &gws[cur], loop, &rates, mono_s(), path, 0, 0 };
	seen_reset(&seen, &gws[cur]);
	pr_info("serving %d avatars from %d sources to %d outputs at %.6g Hz (%s), source id %08x, control %s",
		gws[cur].n_avatars, gws[cur].n_trackers, gws[cur].n_outputs, gws[cur].cfg.daemon.rate, path, source_id,
		ctl ? ctl_path : "none");
	notify_send("READY=1");
	status_line(&gws[cur]);
	wd_usec = notify_watchdog_usec();
	next_tick = mono_s() + 1.0;

	while (!stop) {
		struct pollfd pf[1 + 1 + CTL_CLIENTS] = { { sfd, POLLIN, 0 } };
		double now = mono_s();
		double wait = next_tick - now;
		bool reload = false;
		int n_ctl;

		if (wd_usec && next_wd - now < wait)
			wait = next_wd - now;
		/* the control socket's clients never hold this thread: each has a deadline, polled here */
		n_ctl = ctl_pollfds(ctl, pf + 1, 1 + CTL_CLIENTS, &wait);
		if (poll(pf, (nfds_t)(1 + n_ctl), wait > 0 ? (int)(wait * 1000) + 1 : 0) < 0 && errno != EINTR) {
			pr_err("poll: %s", strerror(errno));
			break;
		}
		if (pf[0].revents & POLLIN) {
			struct signalfd_siginfo si;

			while (read(sfd, &si, sizeof(si)) == sizeof(si)) {
				if (si.ssi_signo == SIGHUP)
					reload = true;
				else
					stop = true;
			}
		}
		ctl_serve(ctl, pf + 1, n_ctl, &info, &reload);
		if (reload && !stop) {
			struct config ncfg;
			int nxt = 1 - cur;

			notify_sendf("RELOADING=1\nMONOTONIC_USEC=%llu", (unsigned long long)(mono_ns() / 1000));
			pr_info("reloading %s", path);
			if (config_load_ex(&ncfg, path, sets, n_sets, err, sizeof(err))) {
				pr_err("reload rejected, the running configuration stays: %s", err);
				info.reload_failures++;
			} else {
				loop_pause(loop);
				if (gw_open(&gws[nxt], &ncfg, &gws[cur], source_id, err, sizeof(err))) {
					loop_resume(loop, &gws[cur]);
					pr_err("reload failed, the running configuration stays: %s", err);
					info.reload_failures++;
				} else {
					for (int i = 0; i < gws[nxt].n_trackers; i++)
						replay_log_damage(&gws[nxt].trk[i]);
					if (gw_record(&gws[nxt], &rec, err, sizeof(err)))
						pr_err("%s: the daemon runs without recording", err);
					loop_resume(loop, &gws[nxt]);
					drain_notes(&gws[cur]);
					gw_close(&gws[cur]);
					cur = nxt;
					info.g = &gws[cur];
					info.reloads++;
					seen_reset(&seen, &gws[cur]);
					log_set_level(level_of(gws[cur].cfg.daemon.log_level));
					pr_info("reloaded: %d avatars, %d sources, %d outputs", gws[cur].n_avatars,
						gws[cur].n_trackers, gws[cur].n_outputs);
				}
			}
			notify_send("READY=1");
			status_line(&gws[cur]);
		}
		now = mono_s();
		if (wd_usec && now >= next_wd) {
			uint64_t beat = loop_heartbeat(loop);

			/* fed only while the loop advances: a stuck loop gets the service restarted */
			if (beat != last_beat)
				notify_send("WATCHDOG=1");
			last_beat = beat;
			next_wd = now + (double)wd_usec * 1e-6 / 2;
		}
		if (now >= next_tick) {
			ctl_rates_update(&rates, &gws[cur]);
			report(&seen, &gws[cur]);
			recorder_log(rec);
			status_line(&gws[cur]);
			next_tick = now + 1.0;
		}
	}

	notify_send("STOPPING=1");
	pr_info("stopping");
	ctl_close(ctl);
	loop_stop(loop);
	final_line(&gws[cur], rec);
	recorder_close(rec);
	drain_notes(&gws[cur]);
	gw_close(&gws[cur]);
	ctl_rates_free(&rates);
	seen_reset(&seen, &gws[cur]);
	free(seen.dropped);
	free(seen.errors);
	free(seen.nan);
	free(seen.malformed);
	free(seen.faults);
	close(sfd);
	return 0;
}
