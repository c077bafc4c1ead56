// SPDX-License-Identifier: MIT
/*
 * osc_recv.c - an OSC receiver built on liblo for the tests (liblo-tools'
 * oscdump prints six digits; the tests compare exact float32 values).
 *
 * usage: osc-recv PORT SECONDS
 * Prints "ready" once listening, then one line per message,
 *   PATH TYPES ARG...      (floats as %.9g, which round-trips a float32)
 * with "bundle" and "end" around the messages of a bundle.
 */
#include <lo/lo.h>

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static int on_message(const char *path, const char *types, lo_arg **argv, int argc, lo_message msg, void *user)
{
	(void)msg;
	(void)user;
	printf("%s %s", path, types);
	for (int i = 0; i < argc; i++) {
		/* liblo's arguments are only 4-byte aligned: read them as bytes, not through the union */
		const void *a = argv[i];
		float f;
		int32_t n;

		switch (types[i]) {
		case 'f':
			memcpy(&f, a, sizeof(f));
			printf(" %.9g", f);
			break;
		case 'i':
			memcpy(&n, a, sizeof(n));
			printf(" %d", n);
			break;
		case 's':
			printf(" %s", (const char *)a);
			break;
		default:
			printf(" ?");
		}
	}
	putchar('\n');
	return 0;
}

static int on_bundle_start(lo_timetag t, void *user)
{
	(void)t;
	(void)user;
	puts("bundle");
	return 0;
}

static int on_bundle_end(void *user)
{
	(void)user;
	puts("end");
	return 0;
}

static void on_error(int num, const char *msg, const char *where)
{
	fprintf(stderr, "osc-recv: liblo error %d: %s (%s)\n", num, msg, where ? where : "");
}

int main(int argc, char **argv)
{
	struct timespec t0, t;
	lo_server s;
	double secs;

	if (argc != 3) {
		fprintf(stderr, "usage: osc-recv PORT SECONDS\n");
		return 2;
	}
	secs = atof(argv[2]);
	s = lo_server_new(argv[1], on_error);
	if (!s)
		return 1;
	lo_server_add_method(s, NULL, NULL, on_message, NULL);
	lo_server_add_bundle_handlers(s, on_bundle_start, on_bundle_end, NULL);
	puts("ready");
	fflush(stdout);
	clock_gettime(CLOCK_MONOTONIC, &t0);
	for (;;) {
		clock_gettime(CLOCK_MONOTONIC, &t);
		if ((double)(t.tv_sec - t0.tv_sec) + (double)(t.tv_nsec - t0.tv_nsec) * 1e-9 > secs)
			break;
		lo_server_recv_noblock(s, 20);
	}
	fflush(stdout);
	lo_server_free(s);
	return 0;
}
