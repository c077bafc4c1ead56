// SPDX-License-Identifier: MIT
/*
 * avatargw-ctl - asks a running avatargw over its control socket.
 *
 *   avatargw-ctl [-s SOCKET] status [--json]
 *   avatargw-ctl [-s SOCKET] reload
 *   avatargw-ctl [-s SOCKET] step [N] [SOURCE]
 *
 * Without -s the socket is found as the daemon finds it with
 * control_socket = auto ($RUNTIME_DIRECTORY, then $XDG_RUNTIME_DIR, then
 * /tmp), then /run/avatargw/control.
 */
#include "daemon/ctl.h"

#include <errno.h>
#include <getopt.h>
#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

static void usage(FILE *out)
{
	fprintf(out, "usage: avatargw-ctl [-s SOCKET] status [--json]\n"
		     "       avatargw-ctl [-s SOCKET] reload\n"
		     "       avatargw-ctl [-s SOCKET] step [N] [SOURCE]   N more instants of stepped replays\n"
		     "  -s, --socket PATH  the daemon's control socket (daemon.control_socket)\n");
}

static int connect_to(const char *path)
{
	struct sockaddr_un sun = { .sun_family = AF_UNIX };
	int fd;

	if (strlen(path) >= sizeof(sun.sun_path))
		return -ENAMETOOLONG;
	strcpy(sun.sun_path, path);
	fd = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
	if (fd < 0)
		return -errno;
	if (connect(fd, (struct sockaddr *)&sun, sizeof(sun))) {
		int rc = -errno;

		close(fd);
		return rc;
	}
	return fd;
}

int main(int argc, char **argv)
{
	static const struct option opts[] = {
		{ "socket", required_argument, NULL, 's' },
		{ "json", no_argument, NULL, 'j' },
		{ "help", no_argument, NULL, 'h' },
		{ NULL, 0, NULL, 0 },
	};
	char path[CFG_PATH_MAX] = "", req[128], buf[4096];
	bool json = false;
	int opt, fd;
	const char *cmd;

	while ((opt = getopt_long(argc, argv, "s:jh", opts, NULL)) != -1) {
		switch (opt) {
		case 's':
			snprintf(path, sizeof(path), "%s", optarg);
			break;
		case 'j':
			json = true;
			break;
		case 'h':
			usage(stdout);
			return 0;
		default:
			usage(stderr);
			return 64;
		}
	}
	if (optind >= argc) {
		usage(stderr);
		return 64;
	}
	cmd = argv[optind];
	if (!strcmp(cmd, "step")) {
		size_t n = (size_t)snprintf(req, sizeof(req), "step");

		for (int i = optind + 1; i < argc && n < sizeof(req); i++)
			n += (size_t)snprintf(req + n, sizeof(req) - n, " %s", argv[i]);
		if (n + 2 > sizeof(req) || argc - optind > 3) {
			usage(stderr);
			return 64;
		}
		req[n] = '\n';
		req[n + 1] = '\0';
		goto send;
	}
	/* "status --json" with the option after the command */
	for (int i = optind + 1; i < argc; i++) {
		if (!strcmp(argv[i], "--json"))
			json = true;
		else {
			usage(stderr);
			return 64;
		}
	}
	if (!strcmp(cmd, "status"))
		snprintf(req, sizeof(req), "status%s\n", json ? " json" : "");
	else if (!strcmp(cmd, "reload"))
		snprintf(req, sizeof(req), "reload\n");
	else {
		usage(stderr);
		return 64;
	}
send:
	if (path[0]) {
		fd = connect_to(path);
	} else {
		ctl_resolve_path("auto", path, sizeof(path));
		fd = connect_to(path);
		if (fd < 0) {
			snprintf(path, sizeof(path), "/run/avatargw/control");
			fd = connect_to(path);
		}
	}
	if (fd < 0) {
		fprintf(stderr, "avatargw-ctl: %s: %s (is avatargw running? -s names its control socket)\n", path,
			strerror(-fd));
		return 69; /* EX_UNAVAILABLE */
	}
	if (send(fd, req, strlen(req), MSG_NOSIGNAL) < 0) {
		fprintf(stderr, "avatargw-ctl: send: %s\n", strerror(errno));
		close(fd);
		return 74;
	}
	for (;;) {
		struct pollfd p = { fd, POLLIN, 0 };
		ssize_t n;

		if (poll(&p, 1, 5000) <= 0) {
			fprintf(stderr, "avatargw-ctl: no answer within 5 s\n");
			close(fd);
			return 75;
		}
		n = read(fd, buf, sizeof(buf));
		if (n <= 0)
			break;
		fwrite(buf, 1, (size_t)n, stdout);
	}
	close(fd);
	return 0;
}
