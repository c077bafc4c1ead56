/* SPDX-License-Identifier: MIT */
/*
 * fuzz.h - what every harness of tests/fuzz shares (docs/FUZZING.md): the
 * libFuzzer entry points, the invariants checked on what a decoder lets
 * out, and a private scratch directory for harnesses that need files.
 *
 * A broken invariant prints what and where, then aborts: libFuzzer (and
 * the corpus driver of make test) report the input as a crash.
 */
#ifndef AGW_FUZZ_H
#define AGW_FUZZ_H

#include "ik/dq.h"

#include <errno.h>
#include <math.h>
#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerInitialize(int *argc, char ***argv);

/* a TCP port of the loopback that was free a moment ago (for a harness's own server) */
static inline int fuzz_free_port(void)
{
	struct sockaddr_in a = { .sin_family = AF_INET, .sin_addr.s_addr = htonl(INADDR_LOOPBACK) };
	socklen_t l = sizeof(a);
	int fd = socket(AF_INET, SOCK_STREAM, 0), p;

	if (fd < 0 || bind(fd, (struct sockaddr *)&a, sizeof(a)) || getsockname(fd, (struct sockaddr *)&a, &l))
		abort();
	p = ntohs(a.sin_port);
	close(fd);
	return p;
}

#define FUZZ_CHECK(cond, ...)                                                                                          \
	do {                                                                                                           \
		if (!(cond)) {                                                                                         \
			fprintf(stderr, "%s:%d: invariant broken: %s: ", __FILE__, __LINE__, #cond);                   \
			fprintf(stderr, __VA_ARGS__);                                                                  \
			fputc('\n', stderr);                                                                           \
			abort();                                                                                       \
		}                                                                                                      \
	} while (0)

/* the tolerance of "a unit quaternion" for what a decoder lets out */
#define FUZZ_UNIT_TOL 1e-3

/* every value finite */
static inline void fuzz_finite(const double *v, int n, const char *what)
{
	for (int i = 0; i < n; i++)
		FUZZ_CHECK(isfinite(v[i]), "%s[%d] = %g", what, i, v[i]);
}

static inline void fuzz_finite_f(const float *v, int n, const char *what)
{
	for (int i = 0; i < n; i++)
		FUZZ_CHECK(isfinite(v[i]), "%s[%d] = %g", what, i, (double)v[i]);
}

/* a unit quaternion w x y z of finite numbers */
static inline void fuzz_unit_quat(const double q[4], const char *what)
{
	double n;

	fuzz_finite(q, 4, what);
	n = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
	FUZZ_CHECK(fabs(n - 1) < FUZZ_UNIT_TOL, "%s: |q| = %.9g", what, n);
}

/* a pose: finite position, unit rotation; both are published as float32, so each must be finite as one too */
static inline void fuzz_pose(const struct dq *d, const char *what)
{
	struct vec3 p;
	double q[4] = { sc_to_double(d->r.w), sc_to_double(d->r.x), sc_to_double(d->r.y), sc_to_double(d->r.z) };
	double t[3];

	fuzz_unit_quat(q, what);
	dq_translation(d, &p);
	t[0] = sc_to_double(p.x);
	t[1] = sc_to_double(p.y);
	t[2] = sc_to_double(p.z);
	fuzz_finite(t, 3, what);
	for (int i = 0; i < 3; i++)
		FUZZ_CHECK(isfinite((float)t[i]), "%s: position[%d] = %g is not finite as a float", what, i, t[i]);
}

/* CLOCK_MONOTONIC, ns: deadlines of the harnesses that wait on a server (generous: a loaded host) */
static inline uint64_t fuzz_mono_ns(void)
{
	struct timespec ts;

	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (uint64_t)ts.tv_sec * 1000000000ull + (uint64_t)ts.tv_nsec;
}

#define FUZZ_WAIT_NS 30000000000ull /* 30 s */

/*
 * A TCP connection to 127.0.0.1:port, non-blocking, from a loopback address
 * of its own (127.0.0.2 to 127.0.0.251 in turn): thousands of connections a
 * second leave their ports in TIME_WAIT, and one source address would run
 * out of ports within seconds.
 */
static inline int fuzz_connect(int port)
{
	static unsigned serial;
	struct sockaddr_in a = { .sin_family = AF_INET,
				 .sin_port = htons((uint16_t)port),
				 .sin_addr.s_addr = htonl(INADDR_LOOPBACK) };
	struct sockaddr_in from = { .sin_family = AF_INET,
				    .sin_addr.s_addr = htonl(INADDR_LOOPBACK + 1 + serial++ % 250) };
	int fd = socket(AF_INET, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0), one = 1, e = 0;
	socklen_t el = sizeof(e);
	uint64_t end = fuzz_mono_ns() + FUZZ_WAIT_NS;

	FUZZ_CHECK(fd >= 0, "socket: %s", strerror(errno));
	setsockopt(fd, IPPROTO_IP, IP_BIND_ADDRESS_NO_PORT, &one, sizeof(one));
	FUZZ_CHECK(bind(fd, (struct sockaddr *)&from, sizeof(from)) == 0, "bind: %s", strerror(errno));
	if (connect(fd, (struct sockaddr *)&a, sizeof(a)) == 0)
		return fd;
	FUZZ_CHECK(errno == EINPROGRESS || errno == EINTR, "connect: %s", strerror(errno));
	for (;;) {
		struct pollfd p = { fd, POLLOUT, 0 };

		if (poll(&p, 1, 100) == 1)
			break;
		FUZZ_CHECK(fuzz_mono_ns() < end, "connect: no connection in 30 s");
	}
	getsockopt(fd, SOL_SOCKET, SO_ERROR, &e, &el);
	FUZZ_CHECK(e == 0, "connect: %s", strerror(e));
	return fd;
}

/* a directory of this process's own for harnesses that need files ($TMPDIR/agw-fuzz-PID), removed at exit */
static char fuzz_scratch_dir[256];

static inline void fuzz_scratch_rm(void)
{
	char cmd[300];

	snprintf(cmd, sizeof(cmd), "rm -rf '%s'", fuzz_scratch_dir);
	if (system(cmd))
		fprintf(stderr, "fuzz: could not remove %s\n", fuzz_scratch_dir);
}

static inline const char *fuzz_scratch(void)
{
	if (!fuzz_scratch_dir[0]) {
		const char *tmp = getenv("TMPDIR");

		snprintf(fuzz_scratch_dir, sizeof(fuzz_scratch_dir), "%s/agw-fuzz-%d", tmp && *tmp ? tmp : "/tmp",
			 (int)getpid());
		if (mkdir(fuzz_scratch_dir, 0700)) {
			perror(fuzz_scratch_dir);
			abort();
		}
		atexit(fuzz_scratch_rm);
	}
	return fuzz_scratch_dir;
}

/* writes len bytes to path; 0 or -1 */
static inline int fuzz_write_file(const char *path, const void *data, size_t len)
{
	FILE *f = fopen(path, "wb");
	int rc;

	if (!f)
		return -1;
	rc = len && fwrite(data, 1, len, f) != len ? -1 : 0;
	return fclose(f) || rc ? -1 : 0;
}

#endif /* AGW_FUZZ_H */
