// SPDX-License-Identifier: MIT
/*
 * avatargw-view - the avatar in a terminal: a front and a side view of the
 * stick figure, redrawn 20 times a second from a stream output.
 *
 *   avatargw-view [--tcp HOST:PORT | --unix PATH] [--avatar ID] [--frames N]
 *
 * Default: the demo's TCP stream, 127.0.0.1:7771. Both views are drawn in
 * the chest's heading (the figure always faces you) so that the arms read
 * well whatever way the person turns; the heading itself is printed.
 * --frames N draws N pictures and exits (without clearing the screen).
 */
#include "avatargw/wire.h"

#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <netdb.h>
#include <poll.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <time.h>
#include <unistd.h>

#define W 36	   /* columns per view */
#define H 22	   /* rows */
#define SPAN_X 1.4 /* metres across a view */

static volatile sig_atomic_t quit;

static void on_signal(int sig)
{
	(void)sig;
	quit = 1;
}

static int connect_tcp(const char *hostport)
{
	char host[256];
	const char *colon = strrchr(hostport, ':');
	struct addrinfo hints = { .ai_socktype = SOCK_STREAM }, *ai;
	int fd;

	if (!colon || (size_t)(colon - hostport) >= sizeof(host))
		return -EINVAL;
	snprintf(host, sizeof(host), "%.*s", (int)(colon - hostport), hostport);
	if (getaddrinfo(host, colon + 1, &hints, &ai))
		return -EHOSTUNREACH;
	fd = socket(ai->ai_family, SOCK_STREAM, 0);
	if (fd < 0 || connect(fd, ai->ai_addr, ai->ai_addrlen)) {
		int rc = -errno;

		if (fd >= 0)
			close(fd);
		freeaddrinfo(ai);
		return rc;
	}
	freeaddrinfo(ai);
	return fd;
}

static int connect_unix(const char *path)
{
	struct sockaddr_un sun = { .sun_family = AF_UNIX };
	int fd = socket(AF_UNIX, SOCK_STREAM, 0);

	snprintf(sun.sun_path, sizeof(sun.sun_path), "%s", path);
	if (fd < 0 || connect(fd, (struct sockaddr *)&sun, sizeof(sun))) {
		int rc = -errno;

		if (fd >= 0)
			close(fd);
		return rc;
	}
	return fd;
}

static void plot(char g[H][W + 1], int c, int r, char ch)
{
	if (c >= 0 && c < W && r >= 0 && r < H)
		g[r][c] = ch;
}

static void line(char g[H][W + 1], int c0, int r0, int c1, int r1, char ch)
{
	int dc = abs(c1 - c0), dr = -abs(r1 - r0), sc = c0 < c1 ? 1 : -1, sr = r0 < r1 ? 1 : -1, e = dc + dr;

	for (;;) {
		int e2 = 2 * e;

		plot(g, c0, r0, ch);
		if (c0 == c1 && r0 == r1)
			break;
		if (e2 >= dr) {
			e += dr;
			c0 += sc;
		}
		if (e2 <= dc) {
			e += dc;
			r0 += sr;
		}
	}
}

/* one view: horizontal axis u (0 = x across, 1 = y forward), vertical z; points relative to the chest */
static void draw(char g[H][W + 1], const double pts[WIRE_SEGMENTS][3], int u)
{
	static const int bones[][2] = {
		{ WIRE_SEG_CHEST, WIRE_SEG_HEAD },	   { WIRE_SEG_CHEST, WIRE_SEG_R_SHOULDER },
		{ WIRE_SEG_R_SHOULDER, WIRE_SEG_R_ELBOW }, { WIRE_SEG_R_ELBOW, WIRE_SEG_R_WRIST },
		{ WIRE_SEG_R_WRIST, WIRE_SEG_R_HAND },	   { WIRE_SEG_CHEST, WIRE_SEG_L_SHOULDER },
		{ WIRE_SEG_L_SHOULDER, WIRE_SEG_L_ELBOW }, { WIRE_SEG_L_ELBOW, WIRE_SEG_L_WRIST },
		{ WIRE_SEG_L_WRIST, WIRE_SEG_L_HAND }
	};
	int col[WIRE_SEGMENTS], row[WIRE_SEGMENTS];

	for (int r = 0; r < H; r++) {
		memset(g[r], ' ', W);
		g[r][W] = '\0';
	}
	for (int r = 0; r < H; r++)
		g[r][W / 2] = ':';
	for (int i = 0; i < WIRE_SEGMENTS; i++) {
		/* 2 columns per row: terminal cells are about twice as tall as wide */
		col[i] = (int)lround(W / 2 + pts[i][u] / SPAN_X * W);
		row[i] = (int)lround(H * 0.3 - pts[i][2] / (SPAN_X * 2) * H * 2);
	}
	for (size_t b = 0; b < sizeof(bones) / sizeof(bones[0]); b++)
		line(g, col[bones[b][0]], row[bones[b][0]], col[bones[b][1]], row[bones[b][1]], '#');
	plot(g, col[WIRE_SEG_HEAD], row[WIRE_SEG_HEAD], 'O');
	plot(g, col[WIRE_SEG_R_ELBOW], row[WIRE_SEG_R_ELBOW], 'o');
	plot(g, col[WIRE_SEG_L_ELBOW], row[WIRE_SEG_L_ELBOW], 'o');
	plot(g, col[WIRE_SEG_R_HAND], row[WIRE_SEG_R_HAND], 'R');
	plot(g, col[WIRE_SEG_L_HAND], row[WIRE_SEG_L_HAND], 'L');
}

static void render(const struct wire_frame *f, bool clear)
{
	double yaw = f->joint[0], c = cos(-yaw), s = sin(-yaw), pts[WIRE_SEGMENTS][3];
	const float *o = f->segment[WIRE_SEG_CHEST].p;
	char front[H][W + 1], side[H][W + 1];

	for (int i = 0; i < WIRE_SEGMENTS; i++) {
		double dx = f->segment[i].p[0] - o[0], dy = f->segment[i].p[1] - o[1];

		/* into the chest's heading: x to the person's right, y forward */
		pts[i][0] = c * dx - s * dy;
		pts[i][1] = s * dx + c * dy;
		pts[i][2] = f->segment[i].p[2] - o[2];
		if (!isfinite(pts[i][0]) || !isfinite(pts[i][1]) || !isfinite(pts[i][2]))
			pts[i][0] = pts[i][1] = pts[i][2] = 0;
	}
	/* the front view as seen by someone facing the person: their right is our left */
	for (int i = 0; i < WIRE_SEGMENTS; i++)
		pts[i][0] = -pts[i][0];
	draw(front, pts, 0);
	draw(side, pts, 1);
	if (clear)
		fputs("\033[H\033[2J", stdout);
	printf("avatar %u  seq %u  heading %+6.1f deg  chest at (%.2f, %.2f, %.2f) m  %s%s\n", f->h.avatar_id, f->h.seq,
	       yaw * 180 / M_PI, o[0], o[1], o[2], f->h.flags & WIRE_F_STALE ? "STALE " : "",
	       f->h.flags & WIRE_F_UNREACHED ? "UNREACHED" : "");
	printf("%-*s  %s\n", W, "front (facing the person)", "side (the person faces right)");
	for (int r = 0; r < H; r++)
		printf("%s  %s\n", front[r], side[r]);
	printf("elbows: right %+6.1f  left %+6.1f deg (flexion = 90 + J5)\n", 90 + f->joint[5] * 180 / M_PI,
	       90 + f->joint[13] * 180 / M_PI);
	fflush(stdout);
}

int main(int argc, char **argv)
{
	static const struct option opts[] = {
		{ "tcp", required_argument, NULL, 't' },    { "unix", required_argument, NULL, 'u' },
		{ "avatar", required_argument, NULL, 'a' }, { "frames", required_argument, NULL, 'n' },
		{ "help", no_argument, NULL, 'h' },	    { NULL, 0, NULL, 0 },
	};
	const char *tcp = "127.0.0.1:7771", *unix_path = NULL;
	long want = -1, frames = -1;
	static uint8_t buf[1 << 16];
	size_t have = 0;
	static struct wire_frame last;
	bool got = false;
	struct timespec next = { 0 }, now;
	int fd, opt;

	while ((opt = getopt_long(argc, argv, "t:u:a:n:h", opts, NULL)) != -1) {
		switch (opt) {
		case 't':
			tcp = optarg;
			break;
		case 'u':
			unix_path = optarg;
			break;
		case 'a':
			want = strtol(optarg, NULL, 10);
			break;
		case 'n':
			frames = strtol(optarg, NULL, 10);
			break;
		case 'h':
			printf("usage: avatargw-view [--tcp HOST:PORT | --unix PATH] [--avatar ID] [--frames N]\n");
			return 0;
		default:
			return 2;
		}
	}
	signal(SIGINT, on_signal);
	signal(SIGTERM, on_signal);
	fd = unix_path ? connect_unix(unix_path) : connect_tcp(tcp);
	if (fd < 0) {
		fprintf(stderr, "avatargw-view: %s: %s (is avatargw running with a stream output?)\n",
			unix_path ? unix_path : tcp, strerror(-fd));
		return 1;
	}
	while (!quit && frames != 0) {
		struct pollfd p = { fd, POLLIN, 0 };
		ssize_t n;

		if (poll(&p, 1, 2000) <= 0) {
			fprintf(stderr, "avatargw-view: no data for 2 s\n");
			return 1;
		}
		n = read(fd, buf + have, sizeof(buf) - have);
		if (n <= 0) {
			fprintf(stderr, "avatargw-view: the daemon closed the stream\n");
			return 1;
		}
		have += (size_t)n;
		/* every whole message: length prefix, then the message */
		while (have >= 4) {
			uint32_t len = wire_get_len(buf);
			struct wire_frame f;

			if (len > WIRE_MAX_MSG) {
				fprintf(stderr, "avatargw-view: lost the framing\n");
				return 1;
			}
			if (have < 4 + len)
				break;
			if (wire_decode_frame(buf + 4, len, &f) == 0 && (want < 0 || f.h.avatar_id == want)) {
				last = f;
				got = true;
			}
			memmove(buf, buf + 4 + len, have - 4 - len);
			have -= 4 + len;
		}
		clock_gettime(CLOCK_MONOTONIC, &now);
		if (got && (now.tv_sec > next.tv_sec || (now.tv_sec == next.tv_sec && now.tv_nsec >= next.tv_nsec))) {
			render(&last, frames < 0);
			if (frames > 0)
				frames--;
			next = now;
			next.tv_nsec += 50000000;
			if (next.tv_nsec >= 1000000000) {
				next.tv_sec++;
				next.tv_nsec -= 1000000000;
			}
		}
	}
	close(fd);
	return 0;
}
