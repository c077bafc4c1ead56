// SPDX-License-Identifier: MIT
/*
 * bench-cycle - the loop's cycle (gw_cycle) on a gateway built from a
 * configuration, without the loop's sleep: what one cycle costs, apart from
 * how the host schedules it.
 *
 *   bench-cycle [--avatars N] [--cycles M] [--warmup W] [--rate HZ] [--conf FILE]
 *
 * Without --conf the gateway is N sim people, one avatar each, and a UDP
 * output to a socket of this program (nobody reads it: once its buffer is
 * full the kernel drops what comes). The clock the cycle sees is simulated:
 * cycle k runs at start + k periods, so every cycle brings each person a new
 * sample, whatever the time the cycle took. The gateway's own reads of
 * CLOCK_MONOTONIC in cycle k (the time its datagrams were sent) read
 * BENCH_SEND_NS after the cycle's start (clock_gettime is wrapped at link
 * time), so that its latency histogram takes the same input in every run and
 * the instructions counted are the same. W cycles warm up, then M cycles are measured by bench_measure(), the
 * function to give callgrind (--toggle-collect=bench_measure: only the
 * measured cycles are counted).
 *
 * Per measured cycle: the loop thread's CPU time (CLOCK_THREAD_CPUTIME_ID:
 * what the cycle cost, not the time others had the CPU) and its wall time
 * from reading the samples to the return of the last send. Prints one JSON
 * line: per avatar and cycle the CPU time (median and mean of the cycles),
 * the capacity it implies at the rate (period / that), the wall time's p50,
 * p99 and max per cycle.
 */
#include "daemon/gateway.h"

#include <arpa/inet.h>
#include <getopt.h>
#include <netinet/in.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

/* what the gateway's clock reads from the start of a cycle to its end */
#define BENCH_SEND_NS 10000u

/*
 * The time the gateway's CLOCK_MONOTONIC reads in this thread (see above), 0:
 * the real clock. Also set while the gateway is built: the sim takes its
 * start from it, so that cycle k reads sample k of each person in every run.
 * Other threads (a configuration's own) see the real clock.
 */
static _Thread_local uint64_t mono_frozen;

int __real_clock_gettime(clockid_t id, struct timespec *ts);
int __wrap_clock_gettime(clockid_t id, struct timespec *ts);

int __wrap_clock_gettime(clockid_t id, struct timespec *ts)
{
	int rc = __real_clock_gettime(id, ts);

	if (!rc && id == CLOCK_MONOTONIC && mono_frozen) {
		ts->tv_sec = (time_t)(mono_frozen / 1000000000ull);
		ts->tv_nsec = (long)(mono_frozen % 1000000000ull);
	}
	return rc;
}

/* the real clock */
static uint64_t clock_of(clockid_t id)
{
	struct timespec ts;

	__real_clock_gettime(id, &ts);
	return (uint64_t)ts.tv_sec * 1000000000ull + (uint64_t)ts.tv_nsec;
}

static int cmp_u64(const void *a, const void *b)
{
	uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;

	return (x > y) - (x < y);
}

/* the p-quantile of v[0..n) sorted */
static uint64_t quantile(const uint64_t *v, int n, double p)
{
	int i = (int)(p * (double)(n - 1) + 0.5);

	return v[i < n ? i : n - 1];
}

/*
 * cycles [from, to) at start + k * period; the CPU and wall time of each in cpu[], wall[].
 * Not static and never inlined or cloned: callgrind finds it by this name.
 */
int bench_measure(struct gateway *g, uint64_t start, uint64_t period, int from, int to, uint64_t *cpu, uint64_t *wall);
__attribute__((noipa)) int bench_measure(struct gateway *g, uint64_t start, uint64_t period, int from, int to,
					 uint64_t *cpu, uint64_t *wall)
{
	int frames = 0;

	for (int k = from; k < to; k++) {
		struct tracker_clock now = { start + (uint64_t)k * period, 0 };
		uint64_t c0 = clock_of(CLOCK_THREAD_CPUTIME_ID), w0 = clock_of(CLOCK_MONOTONIC), w1;

		mono_frozen = now.mono_ns + BENCH_SEND_NS;
		frames += gw_cycle(g, &now);
		w1 = clock_of(CLOCK_MONOTONIC);
		cpu[k - from] = clock_of(CLOCK_THREAD_CPUTIME_ID) - c0;
		wall[k - from] = w1 - w0;
	}
	return frames;
}

static void usage(FILE *f)
{
	fprintf(f, "usage: bench-cycle [--avatars N] [--cycles M] [--warmup W] [--rate HZ] [--conf FILE]\n");
}

int main(int argc, char **argv)
{
	static const struct option opts[] = { { "avatars", required_argument, NULL, 'n' },
					      { "cycles", required_argument, NULL, 'm' },
					      { "warmup", required_argument, NULL, 'w' },
					      { "rate", required_argument, NULL, 'r' },
					      { "conf", required_argument, NULL, 'c' },
					      { "help", no_argument, NULL, 'h' },
					      { NULL, 0, NULL, 0 } };
	int n = 100, m = 240, w = 240, rate = 240, opt, frames, sink = -1;
	const char *conf_path = NULL;
	char err[1024], text[1024];
	struct sockaddr_in sa = { .sin_family = AF_INET, .sin_addr.s_addr = htonl(INADDR_LOOPBACK) };
	socklen_t sl = sizeof(sa);
	struct config cfg;
	static struct gateway g;
	uint64_t *cpu, *wall, period, start, cpu_sum = 0;
	double cpu_med, cpu_mean;

	while ((opt = getopt_long(argc, argv, "n:m:w:r:c:h", opts, NULL)) != -1) {
		switch (opt) {
		case 'n':
			n = atoi(optarg);
			break;
		case 'm':
			m = atoi(optarg);
			break;
		case 'w':
			w = atoi(optarg);
			break;
		case 'r':
			rate = atoi(optarg);
			break;
		case 'c':
			conf_path = optarg;
			break;
		case 'h':
			usage(stdout);
			return 0;
		default:
			usage(stderr);
			return 64;
		}
	}
	if (optind != argc || n < 1 || m < 1 || w < 0 || rate < 1 || rate > 4000) {
		usage(stderr);
		return 64;
	}
	if (conf_path) {
		if (config_load(&cfg, conf_path, err, sizeof(err))) {
			fprintf(stderr, "bench-cycle: %s\n", err);
			return 78;
		}
	} else {
		sink = socket(AF_INET, SOCK_DGRAM, 0);
		if (sink < 0 || bind(sink, (struct sockaddr *)&sa, sizeof(sa)) ||
		    getsockname(sink, (struct sockaddr *)&sa, &sl)) {
			perror("bench-cycle: socket");
			return 1;
		}
		snprintf(text, sizeof(text),
			 "[daemon]\nrate = %d\n[source sim]\ntype = sim\npeople = %d\n"
			 "[avatar a]\nperson = sim/p0\ncount = %d\n"
			 "[output udp]\ntype = udp\naddress = 127.0.0.1\nport = %u\n",
			 rate, n, n, ntohs(sa.sin_port));
		if (config_load_text(&cfg, "bench-cycle.conf", text, err, sizeof(err))) {
			fprintf(stderr, "bench-cycle: %s\n", err);
			return 78;
		}
	}
	mono_frozen = clock_of(CLOCK_MONOTONIC);
	start = mono_frozen;
	if (gw_open(&g, &cfg, NULL, 1, err, sizeof(err))) {
		fprintf(stderr, "bench-cycle: %s\n", err);
		return 1;
	}
	n = g.n_avatars;
	rate = (int)g.cfg.daemon.rate;
	cpu = calloc((size_t)m, sizeof(*cpu));
	wall = calloc((size_t)m, sizeof(*wall));
	if (!cpu || !wall) {
		fprintf(stderr, "bench-cycle: out of memory\n");
		return 1;
	}
	period = (uint64_t)(1e9 / g.cfg.daemon.rate);
	start += period;
	mono_frozen = 0;
	/* the warm-up: the same cycles, outside bench_measure */
	for (int k = 0; k < w; k++) {
		struct tracker_clock now = { start + (uint64_t)k * period, 0 };

		mono_frozen = now.mono_ns + BENCH_SEND_NS;
		gw_cycle(&g, &now);
	}
	frames = bench_measure(&g, start, period, w, w + m, cpu, wall);
	mono_frozen = 0;
	for (int k = 0; k < m; k++)
		cpu_sum += cpu[k];
	qsort(cpu, (size_t)m, sizeof(*cpu), cmp_u64);
	qsort(wall, (size_t)m, sizeof(*wall), cmp_u64);
	cpu_med = (double)quantile(cpu, m, 0.5) / n;
	cpu_mean = (double)cpu_sum / m / n;
	printf("{\"avatars\":%d,\"cycles\":%d,\"warmup\":%d,\"rate_hz\":%d,\"frames\":%d,"
	       "\"cpu_ns_per_avatar\":{\"p50\":%.1f,\"mean\":%.1f},\"capacity_per_core\":%.0f,"
	       "\"wall_us_per_cycle\":{\"p50\":%.2f,\"p99\":%.2f,\"max\":%.2f}}\n",
	       n, m, w, rate, frames, cpu_med, cpu_mean, (double)period / cpu_med, quantile(wall, m, 0.5) / 1e3,
	       quantile(wall, m, 0.99) / 1e3, wall[m - 1] / 1e3);
	gw_close(&g);
	free(cpu);
	free(wall);
	if (sink >= 0)
		close(sink);
	return 0;
}
