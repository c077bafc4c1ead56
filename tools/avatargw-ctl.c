// SPDX-License-Identifier: MIT
/*
 * avatargw-ctl - asks a running avatargw over its control socket.
 *
 *   avatargw-ctl [-s SOCKET] status [--json]
 *   avatargw-ctl [-s SOCKET] reload
 *   avatargw-ctl [-s SOCKET] step [N] [SOURCE]
 *   avatargw-ctl [-s SOCKET] sensors AVATAR
 *   avatargw-ctl [-s SOCKET] calibrate AVATAR [--rounds N] [--side] [--hand M]
 *                [--samples N] [--still CM] [--write FILE]
 *
 * calibrate walks the person through the standard poses (docs/CALIBRATION.md),
 * takes each pose's sensors from the daemon (`sensors`, averaged over half a
 * second, held still), fits the body with calib_poses() and prints the
 * avatar's configuration keys (or writes them to a drop-in).
 *
 * Without -s the socket is found as the daemon finds it with
 * control_socket = auto ($RUNTIME_DIRECTORY, then $XDG_RUNTIME_DIR, then
 * /tmp), then /run/avatargw/control.
 */
#include "daemon/ctl.h"
#include "ik/calib.h"

#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <poll.h>
#include <pwd.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <time.h>
#include <unistd.h>

#define SERVICE_USER "avatargw" /* the systemd unit's User= (systemd/avatargw.sysusers) */

static void usage(FILE *out)
{
	fprintf(out, "usage: avatargw-ctl [-s SOCKET] status [--json]\n"
		     "       avatargw-ctl [-s SOCKET] reload\n"
		     "       avatargw-ctl [-s SOCKET] step [N] [SOURCE]   N more instants of stepped replays\n"
		     "       avatargw-ctl [-s SOCKET] sensors AVATAR      its head and hand sensors, now (JSON)\n"
		     "       avatargw-ctl [-s SOCKET] calibrate AVATAR [--rounds N] [--side] [--hand M] [--samples N]\n"
		     "                    [--still CM] [--write FILE]\n"
		     "  -s, --socket PATH  the daemon's control socket (daemon.control_socket)\n"
		     "calibrate: the person holds the standard poses in turn, Enter when each is held;\n"
		     "  --rounds N   times round the poses (default 2: posing errors average out)\n"
		     "  --side       the arms-out T-pose too (needs room to the sides)\n"
		     "  --hand M     wrist centre to hand sensor along the hand, m (default: the configured one)\n"
		     "  --samples N  readings averaged per pose, 20 ms apart (default 25)\n"
		     "  --still CM   the most a sensor may move while a pose is read (default 2)\n"
		     "  --write FILE the avatar's keys as a drop-in (e.g. /etc/avatargw/conf.d/60-NAME.conf);\n"
		     "               `avatargw-ctl reload` applies it\n");
}

/*
 * The process answering on the socket must be the daemon: running as root,
 * as us, or as the service's user (avatargw). Anyone else may have bound the
 * path first (a socket in a directory others can write to), to answer in
 * the daemon's place or to read what we send.
 */
static bool peer_trusted(int fd, const char *path)
{
	struct ucred cr;
	socklen_t len = sizeof(cr);
	const struct passwd *pw;

	if (getsockopt(fd, SOL_SOCKET, SO_PEERCRED, &cr, &len)) {
		fprintf(stderr, "avatargw-ctl: %s: who listens there (SO_PEERCRED): %s\n", path, strerror(errno));
		return false;
	}
	if (cr.uid == 0 || cr.uid == getuid() || cr.uid == geteuid() ||
	    ((pw = getpwnam(SERVICE_USER)) && cr.uid == pw->pw_uid))
		return true;
	pw = getpwuid(cr.uid);
	fprintf(stderr,
		"avatargw-ctl: %s: the process listening there (pid %ld) runs as user %s (%u), not as the daemon's "
		"user (" SERVICE_USER "), root or you: not talking to it\n",
		path, (long)cr.pid, pw ? pw->pw_name : "?", (unsigned)cr.uid);
	return false;
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
	if (!peer_trusted(fd, path)) {
		close(fd);
		return -EPERM;
	}
	return fd;
}

/* the daemon's socket: path as given, else as the daemon finds it, else the system one */
static int open_socket(char *path, size_t len)
{
	int fd;

	if (path[0])
		return connect_to(path);
	ctl_resolve_path("auto", path, len);
	fd = connect_to(path);
	if (fd < 0 && fd != -EPERM) {
		snprintf(path, len, "/run/avatargw/control");
		fd = connect_to(path);
	}
	return fd;
}

/*
 * One request. The answer goes to out as it comes (to stderr instead when
 * the daemon refused the request: it starts with "error:"), or, with out
 * NULL, into reply (NUL-terminated, cut at rlen - 1). Returns 0, 65 for a
 * refusal written to out, or an exit status with a message.
 */
static int converse(char *path, size_t plen, const char *req, FILE *out, char *reply, size_t rlen)
{
	char buf[4096];
	size_t got = 0;
	bool refused = false;
	int fd = open_socket(path, plen);

	if (fd == -EPERM)
		return 77; /* EX_NOPERM: said why */
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
	for (bool first = true;; first = false) {
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
		if (first && n >= 6 && !memcmp(buf, "error:", 6))
			refused = true;
		if (out) {
			fwrite(buf, 1, (size_t)n, refused ? stderr : out);
		} else {
			size_t k = (size_t)n < rlen - 1 - got ? (size_t)n : rlen - 1 - got;

			memcpy(reply + got, buf, k);
			got += k;
		}
	}
	if (!out)
		reply[got] = '\0';
	close(fd);
	return out && refused ? 65 : 0; /* EX_DATAERR */
}

/* one request, its whole answer into reply */
static int ask(char *path, size_t plen, const char *req, char *reply, size_t rlen)
{
	return converse(path, plen, req, NULL, reply, rlen);
}

/* ---- calibrate ----------------------------------------------------------------------- */

struct reading {
	bool ok[3];
	double p[3][3]; /* head, left hand, right hand */
	char state[3][16];
	char section[64]; /* the [avatar SECTION] the avatar comes from */
	int shared;	  /* the avatars that section makes (count = N) */
	double hand;	  /* its configured hand length */
};

/* a `sensors` answer: the three sensors' states and positions; false if it is not one */
static bool parse_sensors(const char *s, struct reading *r)
{
	static const char *const roles[3] = { "\"role\":\"head\"", "\"role\":\"left_hand\"",
					      "\"role\":\"right_hand\"" };

	const char *sec = strstr(s, "\"section\":\""), *sh = strstr(s, "\"section_avatars\":");
	const char *hd = strstr(s, "\"hand\":");

	if (!sec || sscanf(sec + 11, "%63[^\"]", r->section) != 1 || !sh || sscanf(sh + 18, "%d", &r->shared) != 1 ||
	    !hd || sscanf(hd + 7, "%lf", &r->hand) != 1)
		return false;
	for (int k = 0; k < 3; k++) {
		const char *at = strstr(s, roles[k]), *st, *p;

		if (!at || !(st = strstr(at, "\"state\":\"")) || sscanf(st + 9, "%15[a-z]", r->state[k]) != 1)
			return false;
		r->ok[k] = !strcmp(r->state[k], "ok");
		p = strstr(at, "\"p\":[");
		if (r->ok[k] && (!p || sscanf(p + 5, "%lf,%lf,%lf", &r->p[k][0], &r->p[k][1], &r->p[k][2]) != 3))
			return false;
	}
	return true;
}

static const struct {
	enum calib_pose pose;
	const char *name, *how;
} pose_text[] = {
	{ CALIB_POSE_INITIAL, "initial",
	  "stand upright, look straight ahead; upper arms hanging at your sides, elbows bent 90 degrees, forearms "
	  "pointing forward, hands straight" },
	{ CALIB_POSE_DOWN, "down",
	  "stand upright, look straight ahead; both arms hanging straight down at your sides" },
	{ CALIB_POSE_FORWARD, "forward",
	  "stand upright, look straight ahead; both arms straight and level, pointing forward, shoulder-width apart" },
	{ CALIB_POSE_SIDE, "side",
	  "stand upright, look straight ahead; both arms straight and level, out to the sides" },
};

/* one pose read: samples readings 20 ms apart, every sensor OK, none moving more than still_m; 0 or exit status */
static int read_pose(char *path, size_t plen, const char *avatar, int samples, double still_m, struct calib_obs *o)
{
	char req[160], reply[2048];
	struct reading r[200];
	double mean[3][3] = { { 0 } }, worst = 0;
	int rc;

	snprintf(req, sizeof(req), "sensors %s\n", avatar);
	for (int i = 0; i < samples; i++) {
		struct timespec ts = { 0, 20 * 1000 * 1000 };

		if (i)
			nanosleep(&ts, NULL);
		rc = ask(path, plen, req, reply, sizeof(reply));
		if (rc)
			return rc;
		if (!strncmp(reply, "error:", 6)) {
			fprintf(stderr, "avatargw-ctl: %s", reply);
			return 65; /* EX_DATAERR */
		}
		if (!parse_sensors(reply, &r[i])) {
			fprintf(stderr, "avatargw-ctl: not an answer to sensors: %s\n", reply);
			return 76; /* EX_PROTOCOL */
		}
		for (int k = 0; k < 3; k++)
			if (!r[i].ok[k]) {
				fprintf(stderr, "  the %s sensor is %s: is its tracker on and in view?\n",
					k ? (k == 1 ? "left-hand" : "right-hand") : "head", r[i].state[k]);
				return -1;
			}
		for (int k = 0; k < 3; k++)
			for (int c = 0; c < 3; c++)
				mean[k][c] += r[i].p[k][c] / samples;
	}
	for (int i = 0; i < samples; i++)
		for (int k = 0; k < 3; k++) {
			double dx = r[i].p[k][0] - mean[k][0], dy = r[i].p[k][1] - mean[k][1],
			       dz = r[i].p[k][2] - mean[k][2];
			double d = sqrt(dx * dx + dy * dy + dz * dz);

			worst = d > worst ? d : worst;
		}
	if (worst > still_m) {
		fprintf(stderr, "  a sensor moved by %.1f cm while the pose was read: hold still\n", worst * 100);
		return -1;
	}
	o->head = (struct vec3){ mean[0][0], mean[0][1], mean[0][2] };
	o->lhand = (struct vec3){ mean[1][0], mean[1][1], mean[1][2] };
	o->rhand = (struct vec3){ mean[2][0], mean[2][1], mean[2][2] };
	return 0;
}

/* text into file, whole or not at all (a temporary file, synced, renamed over it); 0 or 73 with a message */
static int write_file(const char *file, const char *text)
{
	char tmp[CFG_PATH_MAX + 8];
	FILE *f;
	int bad;

	if ((size_t)snprintf(tmp, sizeof(tmp), "%s.tmp", file) >= sizeof(tmp)) {
		fprintf(stderr, "avatargw-ctl: %s: name too long\n", file);
		return 73;
	}
	f = fopen(tmp, "w");
	if (!f) {
		fprintf(stderr, "avatargw-ctl: %s: %s\n", tmp, strerror(errno));
		return 73; /* EX_CANTCREAT */
	}
	bad = fputs(text, f) < 0 || fflush(f) || fsync(fileno(f));
	if (fclose(f) || bad) {
		fprintf(stderr, "avatargw-ctl: %s: %s\n", tmp, strerror(errno));
		unlink(tmp);
		return 73;
	}
	if (rename(tmp, file)) {
		fprintf(stderr, "avatargw-ctl: %s: %s\n", file, strerror(errno));
		unlink(tmp);
		return 73;
	}
	return 0;
}

static int calibrate(char *path, size_t plen, int argc, char **argv)
{
	static const struct option opts[] = {
		{ "rounds", required_argument, NULL, 'r' },
		{ "side", no_argument, NULL, 'S' },
		{ "hand", required_argument, NULL, 'H' },
		{ "samples", required_argument, NULL, 'n' },
		{ "still", required_argument, NULL, 't' },
		{ "write", required_argument, NULL, 'w' },
		{ NULL, 0, NULL, 0 },
	};
	long rounds = 2, samples = 25;
	int n_poses, n = 0, opt, rc;
	double hand = 0, still = 0.02;
	bool side = false, hand_given = false;
	struct reading first;
	const char *avatar, *file = NULL;
	struct calib_obs obs[4 * 10];
	struct calib_body b;
	char text[1024], line[256];
	size_t len;

	optind = 0; /* GNU getopt starts over (and permutes again) */
	while ((opt = getopt_long(argc, argv, "", opts, NULL)) != -1) {
		char *end = NULL;

		switch (opt) {
		case 'r':
			rounds = strtol(optarg, &end, 10);
			break;
		case 'S':
			side = true;
			break;
		case 'H':
			hand = strtod(optarg, &end);
			hand_given = true;
			break;
		case 'n':
			samples = strtol(optarg, &end, 10);
			break;
		case 't':
			still = strtod(optarg, &end) / 100;
			break;
		case 'w':
			file = optarg;
			break;
		default:
			usage(stderr);
			return 64;
		}
		if (end && (*end || end == optarg)) {
			fprintf(stderr, "avatargw-ctl: calibrate: not a number: %s\n", optarg);
			return 64;
		}
	}
	if (optind + 1 != argc || rounds < 1 || rounds > 10 || samples < 1 || samples > 200 ||
	    !(hand >= 0 && hand < 0.5) || !(still > 0)) {
		usage(stderr);
		return 64;
	}
	avatar = argv[optind];
	n_poses = side ? 4 : 3;
	/* before any posing: the avatar is there, and its keys can be written where asked */
	{
		char req[160], reply[2048];

		snprintf(req, sizeof(req), "sensors %s\n", avatar);
		rc = ask(path, plen, req, reply, sizeof(reply));
		if (rc)
			return rc;
		if (!strncmp(reply, "error:", 6)) {
			fprintf(stderr, "avatargw-ctl: %s", reply);
			return 65;
		}
		if (!parse_sensors(reply, &first)) {
			fprintf(stderr, "avatargw-ctl: not an answer to sensors: %s\n", reply);
			return 76; /* EX_PROTOCOL */
		}
	}
	if (!hand_given)
		hand = first.hand; /* the configured one: the fit's forearm is then the configuration's */
	if (file && first.shared > 1) {
		fprintf(stderr,
			"avatargw-ctl: %s is one of the %d avatars of [avatar %s] (count = %d), which share one body: "
			"not written (the keys are printed; put them in that section by hand if they fit them all)\n",
			avatar, first.shared, first.section, first.shared);
		file = NULL;
	}
	if (file) {
		/* the temporary file can be made next to it (the file itself stays as it is until the end) */
		char tmp[CFG_PATH_MAX + 8];
		FILE *f;

		snprintf(tmp, sizeof(tmp), "%s.tmp", file);
		f = fopen(tmp, "w");
		if (!f) {
			fprintf(stderr, "avatargw-ctl: %s: %s\n", tmp, strerror(errno));
			return 73;
		}
		fclose(f);
		unlink(tmp);
	}
	fprintf(stderr, "Calibrating %s: %d poses, %ld time%s round. Hold each pose, then press Enter.\n", avatar,
		n_poses, rounds, rounds > 1 ? "s" : "");
	for (long round = 0; round < rounds; round++)
		for (int k = 0; k < n_poses; k++) {
			for (;;) {
				fprintf(stderr, "[%ld/%ld] %s: %s. Enter when held: ", round * n_poses + k + 1,
					rounds * n_poses, pose_text[k].name, pose_text[k].how);
				if (!fgets(line, sizeof(line), stdin)) {
					fprintf(stderr, "\navatargw-ctl: calibration abandoned (end of input)\n");
					return 1;
				}
				obs[n].pose = pose_text[k].pose;
				rc = read_pose(path, plen, avatar, (int)samples, still, &obs[n]);
				if (rc > 0)
					return rc;
				if (rc == 0)
					break;
				/* not held, or a sensor missing: the same pose again */
			}
			n++;
		}
	rc = calib_poses(obs, (size_t)n, hand, &b);
	if (rc != CALIB_OK) {
		fprintf(stderr, "avatargw-ctl: the fit failed: %s\n", calib_strerror(rc));
		return 65;
	}
	if (b.rms > 0.02)
		fprintf(stderr,
			"avatargw-ctl: the readings fit the poses only to %.1f cm (rms): a pose was not held as "
			"asked; consider calibrating again\n",
			b.rms * 100);
	/* the hand's length only when given: a drop-in would otherwise reset the configured one */
	len = (size_t)snprintf(text, sizeof(text),
			       "; avatargw-ctl calibrate %s: %d readings, the fit's rms %.1f mm\n"
			       "[avatar %s]\nshoulder = %.4f\nupper_arm = %.4f\nforearm = %.4f\n",
			       avatar, n, b.rms * 1000, first.section, b.dims.shoulder, b.dims.arm, b.dims.forearm);
	if (hand_given)
		len += (size_t)snprintf(text + len, sizeof(text) - len, "hand = %.4f\n", b.dims.hand);
	len += (size_t)snprintf(text + len, sizeof(text) - len, "head_offset = %.4f %.4f %.4f\n", b.head_offset.x,
				b.head_offset.y, b.head_offset.z);
	fwrite(text, 1, len, stdout);
	if (file) {
		rc = write_file(file, text);
		if (rc)
			return rc;
		fprintf(stderr, "avatargw-ctl: written to %s; `avatargw-ctl reload` applies it\n", file);
	}
	return 0;
}

int main(int argc, char **argv)
{
	static const struct option opts[] = {
		{ "socket", required_argument, NULL, 's' },
		{ "json", no_argument, NULL, 'j' },
		{ "help", no_argument, NULL, 'h' },
		{ NULL, 0, NULL, 0 },
	};
	char path[CFG_PATH_MAX] = "", req[128];
	bool json = false;
	int opt;
	const char *cmd;

	/* the command's own options follow it: stop at the first non-option */
	while ((opt = getopt_long(argc, argv, "+s:jh", opts, NULL)) != -1) {
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
	if (!strcmp(cmd, "calibrate"))
		return calibrate(path, sizeof(path), argc - optind, argv + optind);
	if (!strcmp(cmd, "sensors")) {
		if (argc - optind != 2 || strlen(argv[optind + 1]) > 100) {
			usage(stderr);
			return 64;
		}
		snprintf(req, sizeof(req), "sensors %s\n", argv[optind + 1]);
		goto send;
	}
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
	/* "status --json" (and -s SOCKET) with the option after the command */
	for (int i = optind + 1; i < argc; i++) {
		if (!strcmp(argv[i], "--json")) {
			json = true;
		} else if ((!strcmp(argv[i], "-s") || !strcmp(argv[i], "--socket")) && i + 1 < argc) {
			snprintf(path, sizeof(path), "%s", argv[++i]);
		} else {
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
	return converse(path, sizeof(path), req, stdout, NULL, 0);
}
