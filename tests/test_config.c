// SPDX-License-Identifier: MIT
/*
 * test_config.c - the configuration: INI files and drop-ins read through the
 * public API (config.h), every value and its unit conversion, every error with
 * its file:line and key, and the daemon's exit codes (--check-config).
 *
 * Files are written into a fresh directory under /tmp per test (mkdtemp) and
 * removed by the teardown, which also frees the configuration, so a failing
 * assertion leaks nothing. The daemon is build/avatargw beside this test's
 * own build directory (../avatargw from build/tests/), or $AVATARGW_BIN.
 */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <cmocka.h>

#include <errno.h>
#include <fcntl.h>
#include <ftw.h>
#include <ini.h>
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "trackers/sim.h"
#include "trackers/replay.h"
#include "trackers/polhemus.h"
#include "trackers/modbus_in.h"
#include "trackers/hydra.h"
#include "trackers/can_in.h"
#include "publish/websocket.h"
#include "publish/vrpn.h"
#include "publish/udp.h"
#include "publish/stream.h"
#include "publish/osc.h"
#include "publish/modbus_server.h"
#include "publish/can_out.h"
#include "config/config.h"
#include "record/recfile.h"
#include "trackers/tracker.h"

#include "testutil.h"

#define DEG (M_PI / 180.0)
#define ANG_TOL 1e-12

/* ---- per-test state ----------------------------------------------------------------------- */

struct fx {
	char dir[64]; /* the test's own directory under /tmp */
	struct config c;
	char err[1024];
	char *out, *errout; /* the daemon's stdout and stderr */
	char *printed;	    /* config_print's output */
	int rc;
};

static int setup(void **state)
{
	struct fx *f = calloc(1, sizeof(*f));

	if (!f)
		return -1;
	snprintf(f->dir, sizeof(f->dir), "/tmp/agw-test-config-XXXXXX");
	if (!mkdtemp(f->dir)) {
		free(f);
		return -1;
	}
	*state = f;
	return 0;
}

static int rm_one(const char *path, const struct stat *st, int flag, struct FTW *ftw)
{
	(void)st;
	(void)flag;
	(void)ftw;
	return remove(path);
}

static int teardown(void **state)
{
	struct fx *f = *state;

	config_free(&f->c); /* safe on a zeroed or failed configuration */
	free(f->out);
	free(f->errout);
	free(f->printed);
	nftw(f->dir, rm_one, 16, FTW_DEPTH | FTW_PHYS);
	free(f);
	return 0;
}

/* DIR/rel into buf */
static const char *at(const struct fx *f, const char *rel, char *buf, size_t len)
{
	snprintf(buf, len, "%s/%s", f->dir, rel);
	return buf;
}

/* writes len bytes to DIR/rel, making the directories on the way */
static void put_bytes(const struct fx *f, const char *rel, const char *data, size_t len)
{
	char path[512];
	FILE *fp;

	at(f, rel, path, sizeof(path));
	for (char *s = path + strlen(f->dir) + 1; (s = strchr(s, '/')); s++) {
		*s = '\0';
		if (mkdir(path, 0700) && errno != EEXIST)
			fail_msg("mkdir %s: %s", path, strerror(errno));
		*s = '/';
	}
	fp = fopen(path, "w");
	if (!fp)
		fail_msg("%s: %s", path, strerror(errno));
	assert_int_equal(fwrite(data, 1, len, fp), len);
	assert_int_equal(fclose(fp), 0);
}

static void put(const struct fx *f, const char *rel, const char *text)
{
	put_bytes(f, rel, text, strlen(text));
}

/* a sensor CSV with the columns replay needs (and a few it does not), n rows at 100 Hz */
static void put_csv(const struct fx *f, const char *rel, const char *drop_column, int n)
{
	static const char *const pre[] = { "head", "lhand", "rhand" };
	static const char *const suf[] = { "x", "y", "z", "qw", "qx", "qy", "qz" };
	char buf[8192];
	size_t len = 0;

	len += (size_t)snprintf(buf + len, sizeof(buf) - len, "frame,t");
	for (int r = 0; r < 3; r++)
		for (int s = 0; s < 7; s++) {
			char col[32];

			snprintf(col, sizeof(col), "%s_%s", pre[r], suf[s]);
			len += (size_t)snprintf(buf + len, sizeof(buf) - len, ",%s",
						drop_column && !strcmp(col, drop_column) ? "unused" : col);
		}
	len += (size_t)snprintf(buf + len, sizeof(buf) - len, ",chest_x\n");
	for (int i = 0; i < n; i++) {
		len += (size_t)snprintf(buf + len, sizeof(buf) - len, "%d,%.3f", i, i * 0.01);
		for (int r = 0; r < 3; r++)
			len += (size_t)snprintf(buf + len, sizeof(buf) - len, ",%.2f,0.1,%.2f,1,0,0,0",
						r == 0 ? 0.0 : (r == 1 ? -0.3 : 0.3), r == 0 ? 1.6 : 1.0);
		len += (size_t)snprintf(buf + len, sizeof(buf) - len, ",0\n");
	}
	assert_true(len < sizeof(buf));
	put(f, rel, buf);
}

/* ---- loading and errors ------------------------------------------------------------------- */

static struct config *load_text_ok(struct fx *f, const char *text)
{
	f->err[0] = '\0';
	if (config_load_text(&f->c, "e.conf", text, f->err, sizeof(f->err)))
		fail_msg("config_load_text failed: %s\n--- text:\n%s", f->err, text);
	return &f->c;
}

static struct config *load_file_ok(struct fx *f, const char *rel)
{
	char path[512];

	f->err[0] = '\0';
	if (config_load(&f->c, at(f, rel, path, sizeof(path)), f->err, sizeof(f->err)))
		fail_msg("config_load(%s) failed: %s", path, f->err);
	return &f->c;
}

/* the error must begin with prefix and contain each further string (NULL-terminated) */
static void check_err(const struct fx *f, const char *prefix, va_list ap)
{
	const char *s;

	if (strncmp(f->err, prefix, strlen(prefix)))
		fail_msg("error message\n  \"%s\"\ndoes not begin with\n  \"%s\"", f->err, prefix);
	while ((s = va_arg(ap, const char *)))
		if (!strstr(f->err, s))
			fail_msg("error message\n  \"%s\"\ndoes not contain\n  \"%s\"", f->err, s);
}

static void expect_text_err(struct fx *f, const char *text, const char *prefix, ...)
{
	va_list ap;

	f->err[0] = '\0';
	if (!config_load_text(&f->c, "e.conf", text, f->err, sizeof(f->err)))
		fail_msg("config_load_text accepted what it should refuse (want \"%s...\"):\n%s", prefix, text);
	va_start(ap, prefix);
	check_err(f, prefix, ap);
	va_end(ap);
	config_free(&f->c);
}

/* prefix may hold "%s" once, for the test directory */
static void expect_file_err(struct fx *f, const char *rel, const char *prefix_fmt, ...)
{
	char path[512], prefix[768];
	va_list ap;

	f->err[0] = '\0';
	if (!config_load(&f->c, at(f, rel, path, sizeof(path)), f->err, sizeof(f->err)))
		fail_msg("config_load(%s) accepted what it should refuse", path);
	snprintf(prefix, sizeof(prefix), prefix_fmt, f->dir);
	va_start(ap, prefix_fmt);
	check_err(f, prefix, ap);
	va_end(ap);
	config_free(&f->c);
}

/* config_print into a string, kept in f->printed (freed by the teardown) */
static const char *print_config(struct fx *f)
{
	size_t len = 0;
	FILE *m;

	free(f->printed);
	f->printed = NULL;
	m = open_memstream(&f->printed, &len);
	assert_non_null(m);
	config_print(&f->c, m);
	assert_int_equal(fclose(m), 0);
	return f->printed;
}

static void assert_has(const char *hay, const char *needle)
{
	if (!strstr(hay, needle))
		fail_msg("\"%s\" not found in:\n%s", needle, hay);
}

static void assert_range_deg(const struct cfg_avatar *a, int j, double lo, double hi)
{
	set_ctx("j%d", j + 1);
	assert_near(a->lo[j], lo * DEG, ANG_TOL);
	assert_near(a->hi[j], hi * DEG, ANG_TOL);
}

static void assert_sensor(const struct cfg_avatar *a, int role, int source, int sensor)
{
	if (a->sensor[role].source != source || a->sensor[role].sensor != sensor)
		fail_msg("avatar %s %s: source %d sensor %d, want source %d sensor %d", a->name, cfg_sensor_roles[role],
			 a->sensor[role].source, a->sensor[role].sensor, source, sensor);
}

static int source_index(const struct config *c, const char *name)
{
	for (int i = 0; i < c->n_sources; i++)
		if (!strcmp(c->source[i].name, name))
			return i;
	fail_msg("no source %s", name);
	return -1;
}

/* ---- the daemon binary -------------------------------------------------------------------- */

/* the directory holding this test binary's build directory, e.g. /work/main/build */
static void build_dir(char *buf, size_t len)
{
	char exe[PATH_MAX];
	ssize_t n = readlink("/proc/self/exe", exe, sizeof(exe) - 1);
	char *s;

	buf[0] = '\0';
	if (n <= 0)
		return;
	exe[n] = '\0';
	for (int up = 0; up < 2; up++) /* build/tests/test_config -> build */
		if ((s = strrchr(exe, '/')))
			*s = '\0';
	snprintf(buf, len, "%s", exe);
}

static void daemon_path(char *buf, size_t len)
{
	const char *env = getenv("AVATARGW_BIN");
	char bd[PATH_MAX];

	if (env && env[0]) {
		snprintf(buf, len, "%s", env);
		return;
	}
	build_dir(bd, sizeof(bd));
	if ((size_t)snprintf(buf, len, "%s/avatargw", bd) >= len || access(buf, X_OK))
		snprintf(buf, len, "build/avatargw");
	if (access(buf, X_OK))
		fail_msg("the daemon binary is missing (make build/avatargw, or set AVATARGW_BIN)");
}

/* a file of the repository: relative to the working directory, else to the build directory's parent */
static void repo_path(const char *rel, char *buf, size_t len)
{
	char bd[PATH_MAX], *s;

	snprintf(buf, len, "%s", rel);
	if (!access(buf, R_OK))
		return;
	build_dir(bd, sizeof(bd));
	if ((s = strrchr(bd, '/')))
		*s = '\0';
	if ((size_t)snprintf(buf, len, "%s/%s", bd, rel) >= len || access(buf, R_OK))
		fail_msg("%s not found (run from the repository root)", rel);
}

static char *slurp(const char *path)
{
	FILE *fp = fopen(path, "r");
	char *buf;
	long n;

	if (!fp)
		fail_msg("%s: %s", path, strerror(errno));
	fseek(fp, 0, SEEK_END);
	n = ftell(fp);
	rewind(fp);
	buf = malloc((size_t)n + 1);
	assert_non_null(buf);
	assert_int_equal(fread(buf, 1, (size_t)n, fp), (size_t)n);
	buf[n] = '\0';
	fclose(fp);
	return buf;
}

/* runs the daemon with args (NULL-terminated); its exit status in f->rc, its output in f->out, f->errout */
static void run_daemon(struct fx *f, ...)
{
	char bin[PATH_MAX], out[512], err[512];
	const char *argv[16];
	int argc = 0, status;
	va_list ap;
	pid_t pid;

	daemon_path(bin, sizeof(bin));
	argv[argc++] = bin;
	va_start(ap, f);
	while (argc < 15 && (argv[argc] = va_arg(ap, const char *)))
		argc++;
	va_end(ap);
	argv[argc] = NULL;
	at(f, "daemon.out", out, sizeof(out));
	at(f, "daemon.err", err, sizeof(err));
	fflush(NULL);
	pid = fork();
	assert_true(pid >= 0);
	if (pid == 0) {
		int o = open(out, O_WRONLY | O_CREAT | O_TRUNC, 0600),
		    e = open(err, O_WRONLY | O_CREAT | O_TRUNC, 0600);

		if (o < 0 || e < 0 || dup2(o, 1) < 0 || dup2(e, 2) < 0)
			_exit(127);
		execv(bin, (char *const *)argv);
		_exit(127);
	}
	assert_int_equal(waitpid(pid, &status, 0), pid);
	assert_true(WIFEXITED(status));
	f->rc = WEXITSTATUS(status);
	free(f->out);
	free(f->errout);
	f->out = slurp(out);
	f->errout = slurp(err);
	if (f->rc == 127)
		fail_msg("could not run %s: %s", bin, f->errout);
}

/* ---- a valid configuration, every value ---------------------------------------------------- */

static void test_values_daemon(void **state)
{
	struct fx *f = *state;
	const struct config *c = load_text_ok(f, "[daemon]\n"
						 "rate = 500.5\n"
						 "mode = events\n"
						 "stale_ms = 250.25\n"
						 "realtime_priority = 42\n"
						 "cpu = 3\n"
						 "lock_memory = no\n"
						 "control_socket = /run/x/ctl\n"
						 "describe_interval = 0.5\n"
						 "log_level = debug\n"
						 "[source s]\ntype = sim\n"
						 "[avatar a]\nperson = s/p0\n");

	assert_near(c->daemon.rate, 500.5, 0);
	assert_int_equal(c->daemon.mode, CFG_LOOP_EVENTS);
	assert_near(c->daemon.stale_ms, 250.25, 0);
	assert_int_equal(c->daemon.realtime_priority, 42);
	assert_int_equal(c->daemon.cpu, 3);
	assert_false(c->daemon.lock_memory);
	assert_string_equal(c->daemon.control_socket, "/run/x/ctl");
	assert_near(c->daemon.describe_interval, 0.5, 0);
	assert_int_equal(c->daemon.log_level, CFG_LOG_DEBUG);
	assert_int_equal(c->n_files, 1);
	assert_string_equal(c->files[0], "e.conf");
}

/* the recording keys of [daemon] (docs/RECORDING.md) */
static void test_values_record(void **state)
{
	struct fx *f = *state;
	const struct config *c = load_text_ok(f, "[daemon]\n"
						 "record_dir = /var/lib/avatargw/rec\n"
						 "record_messages = yes\n"
						 "record_flush = 0.25\n"
						 "record_flush_records = 500\n"
						 "record_fsync = yes\n"
						 "record_rotate_size = 64\n"
						 "record_rotate_time = 3600\n"
						 "record_buffer = 4096\n"
						 "record_keyframe_rate = 10\n"
						 "[source s]\ntype = sim\n"
						 "[avatar a]\nperson = s/p0\n");

	assert_string_equal(c->daemon.record_dir, "/var/lib/avatargw/rec");
	assert_true(c->daemon.record_messages);
	assert_near(c->daemon.record_flush, 0.25, 0);
	assert_int_equal(c->daemon.record_flush_records, 500);
	assert_true(c->daemon.record_fsync);
	assert_near(c->daemon.record_rotate_size, 64, 0);
	assert_near(c->daemon.record_rotate_time, 3600, 0);
	assert_int_equal(c->daemon.record_buffer, 4096);
	assert_near(c->daemon.record_keyframe_rate, 10, 0);
	config_free(&f->c);
	/* the defaults: no recording */
	c = load_text_ok(f, "[source s]\ntype = sim\n[avatar a]\nperson = s/p0\n");
	assert_string_equal(c->daemon.record_dir, "");
	assert_false(c->daemon.record_messages);
	assert_near(c->daemon.record_flush, 1, 0);
	assert_int_equal(c->daemon.record_flush_records, 0);
	assert_false(c->daemon.record_fsync);
	assert_near(c->daemon.record_rotate_size, 0, 0);
	assert_near(c->daemon.record_rotate_time, 0, 0);
	assert_int_equal(c->daemon.record_buffer, 1024);
	assert_near(c->daemon.record_keyframe_rate, 0, 0);
	config_free(&f->c);
	/* a relative record_dir: beside the file that says it */
	put(f, "etc/main.conf", "[daemon]\nrecord_dir = rec\n[source s]\ntype = sim\n[avatar a]\nperson = s/p0\n");
	c = load_file_ok(f, "etc/main.conf");
	{
		char want[600];

		snprintf(want, sizeof(want), "%s/etc/rec", f->dir);
		assert_string_equal(c->daemon.record_dir, want);
	}
}

static void test_err_record(void **state)
{
	expect_text_err(*state, "[daemon]\nrecord_buffer = 32\n",
			"e.conf:2: [daemon] record_buffer: 32 is out of range [64, 262144] KiB", NULL);
	expect_text_err(*state, "[daemon]\nrecord_flush = -1\n", "e.conf:2: [daemon] record_flush: -1 is out of range",
			NULL);
	expect_text_err(*state, "[daemon]\nrecord_flush_records = 2.5\n",
			"e.conf:2: [daemon] record_flush_records: '2.5' is not a whole number", NULL);
	expect_text_err(*state, "[daemon]\nrecord_fsync = always\n",
			"e.conf:2: [daemon] record_fsync: 'always' is not yes or no", NULL);
	expect_text_err(*state, "[source c]\ntype = replay\nfile = builtin:cmu_141_16.csv\ninterpolate = cubic\n",
			"e.conf:4: [source c] interpolate: 'cubic' is not one of: none, linear, catmull-rom, natural",
			NULL);
	expect_text_err(*state, "[source s]\ntype = sim\nstep = yes\n",
			"e.conf:3: [source s] step: unknown key for type sim", NULL);
}

static void test_values_replay_modes(void **state)
{
	struct fx *f = *state;
	const struct config *c = load_text_ok(f, "[source c]\ntype = replay\nfile = builtin:cmu_141_16.csv\n"
						 "step = yes\ninterpolate = natural\nsample_rate = 120\n"
						 "[source d]\ntype = replay\nfile = builtin:cmu_141_16.csv\n");

	assert_true(((const struct replay_opts *)(c->source[0]).opt)->step);
	assert_int_equal(((const struct replay_opts *)(c->source[0]).opt)->interpolate, 3);
	assert_near(((const struct replay_opts *)(c->source[0]).opt)->sample_rate, 120, 0);
	assert_false(((const struct replay_opts *)(c->source[1]).opt)->step);
	assert_int_equal(((const struct replay_opts *)(c->source[1]).opt)->interpolate, 0);
	assert_near(((const struct replay_opts *)(c->source[1]).opt)->sample_rate, 240, 0);
}

/* a recording as the replay file: its sensors are SOURCE.SENSOR; a damaged header is refused */
static void test_replay_recording(void **state)
{
	static const char *const names[3] = { "head", "left_hand", "right_hand" };
	struct fx *f = *state;
	uint8_t buf[1024], *r;
	size_t len = RECFILE_HEADER_LEN;
	struct recfile_header h = { RECFILE_VERSION, 0, 1, 0 };
	struct recfile_writer w;
	const struct config *c;
	char path[512];

	recfile_header_encode(&h, buf);
	r = buf + len;
	w = (struct recfile_writer){ r + RECFILE_REC_HEAD, 512, 0, false };
	recfile_w_u64(&w, 1);
	recfile_w_u64(&w, 2);
	recfile_w_f64(&w, 240);
	recfile_w_u32(&w, 1);
	recfile_w_u16(&w, 1);
	recfile_w_u16(&w, 0);
	recfile_w_str(&w, "clip");
	recfile_w_str(&w, "replay");
	recfile_w_u32(&w, 3);
	for (int i = 0; i < 3; i++)
		recfile_w_str(&w, names[i]);
	for (int i = 0; i < 4; i++)
		recfile_w_f64(&w, 0);
	recfile_frame(r, RECFILE_SESSION, (uint32_t)w.len);
	recfile_seal(r);
	len += RECFILE_REC_OVERHEAD + w.len;
	for (int k = 0; k < 6; k++) {
		struct recfile_sample smp = { 0,	   (uint16_t)(k % 3), 0,     0,	   (uint64_t)(k / 3) * 10000000,
					      { 0, 0, 1 }, { 1, 0, 0, 0 },    false, { 0 } };

		r = buf + len;
		recfile_frame(r, RECFILE_SAMPLE, (uint32_t)recfile_sample_encode(&smp, r + RECFILE_REC_HEAD));
		recfile_seal(r);
		len += RECFILE_REC_OVERHEAD + RECFILE_SAMPLE_LEN;
	}
	put_bytes(f, "rec/a.agwrec", (const char *)buf, len);
	put(f, "main.conf", "[source rec]\ntype = replay\nfile = rec/a.agwrec\n[avatar a]\nperson = rec/clip\n");
	c = load_file_ok(f, "main.conf");
	for (int i = 0; i < 3; i++)
		assert_sensor(&c->avatar[0], i, 0, i);
	config_free(&f->c);
	put(f, "main.conf", "[source rec]\ntype = replay\nfile = rec/a.agwrec\n[avatar a]\nperson = rec\n");
	expect_file_err(f, "main.conf", "%s/main.conf:5: [avatar a] person: source 'rec' has no sensor 'head'",
			"(it has: clip.head, clip.left_hand, clip.right_hand)", NULL);
	buf[20] ^= 1;
	put_bytes(f, "rec/a.agwrec", (const char *)buf, len);
	put(f, "main.conf", "[source rec]\ntype = replay\nfile = rec/a.agwrec\n");
	at(f, "rec/a.agwrec", path, sizeof(path));
	expect_file_err(f, "main.conf",
			"%s/main.conf:3: [source rec] file: ", "a.agwrec: the file header is damaged (CRC)", NULL);
}

static void test_values_sim_source(void **state)
{
	struct fx *f = *state;
	const struct config *c = load_text_ok(f, "[source left]\n"
						 "type = sim\n"
						 "origin = 1.5, -2 0.25\n"
						 "yaw = 90\n"
						 "people = 3\n"
						 "seed = 4294967295\n"
						 "sample_rate = 120\n"
						 "spacing = 0.75\n"
						 "[source right]\n"
						 "type = sim\n"
						 "yaw = -45\n"
						 "[avatar a]\nperson = left/p2\n");
	const struct cfg_source *s = &c->source[0];

	assert_int_equal(c->n_sources, 2);
	assert_string_equal(s->name, "left");
	assert_int_equal(s->driver, cfg_source_type_find("sim"));
	assert_int_equal(s->where.line, 2); /* its first key */
	assert_near(s->origin[0], 1.5, 0);
	assert_near(s->origin[1], -2, 0);
	assert_near(s->origin[2], 0.25, 0);
	set_ctx("yaw 90 degrees");
	assert_near(s->yaw, M_PI / 2, ANG_TOL);
	assert_int_equal(((const struct sim_opts *)(s)->opt)->people, 3);
	assert_true(((const struct sim_opts *)(s)->opt)->seed == 4294967295u);
	assert_near(((const struct sim_opts *)(s)->opt)->sample_rate, 120, 0);
	assert_near(((const struct sim_opts *)(s)->opt)->spacing, 0.75, 0);
	set_ctx("yaw -45 degrees");
	assert_near(c->source[1].yaw, -M_PI / 4, ANG_TOL);
	assert_string_equal(c->source[1].name, "right");
}

static void test_values_hardware_sources(void **state)
{
	struct fx *f = *state;
	const struct config *c =
		load_text_ok(f, "[source h]\n"
				"type = hydra\n"
				"device = /dev/hydra\n"
				"interface = 2\n"
				"control_interface = 2\n"
				"record = /tmp/h.cap\n"
				"mount_left = 0 0.04 0\n"
				"mount_right = 0.01 0 0 0 0 0 2\n"
				"[source p]\n"
				"type = polhemus\n"
				"model = patriot\n"
				"device = 1-4.2\n"
				"sensors = head - right_hand\n"
				"hemisphere = 0 0 -1\n"
				"[source q]\n"
				"type = polhemus\n"
				"[avatar a]\nhead = p/head\nleft_hand = h/left\nright_hand = p/right_hand\n");
	const struct cfg_source *h = &c->source[0], *p = &c->source[1], *q = &c->source[2];

	assert_int_equal(h->driver, cfg_source_type_find("hydra"));
	assert_string_equal(((const struct hydra_opts *)(h)->opt)->dev.device, "/dev/hydra");
	assert_int_equal(((const struct hydra_opts *)(h)->opt)->hid_interface, 2);
	assert_int_equal(((const struct hydra_opts *)(h)->opt)->control_interface, 2);
	assert_string_equal(((const struct hydra_opts *)(h)->opt)->dev.record, "/tmp/h.cap");
	assert_string_equal(((const struct hydra_opts *)(h)->opt)->dev.capture, "");
	assert_int_equal(h->n_mounts, 2);
	assert_string_equal(h->mount[0].sensor, "left");
	assert_near(h->mount[0].p[1], 0.04, 0);
	assert_near(h->mount[0].q[0], 1, 0);
	/* the rotation is normalised: 0 0 0 2 is a half turn about z */
	assert_string_equal(h->mount[1].sensor, "right");
	assert_near(h->mount[1].q[0], 0, 0);
	assert_near(h->mount[1].q[3], 1, 0);
	assert_int_equal(((const struct polhemus_opts *)(p)->opt)->model, CFG_PH_PATRIOT);
	assert_string_equal(((const struct polhemus_opts *)(p)->opt)->dev.device, "1-4.2");
	assert_near(((const struct polhemus_opts *)(p)->opt)->hemisphere[2], -1, 0);
	/* station 2 skipped: two sensors */
	assert_int_equal(cfg_source_type(p->driver)->sensor_count(p), 2);
	assert_int_equal(cfg_sensor_lookup(p, "right_hand"), 1);
	assert_int_equal(c->avatar[0].sensor[2].sensor, 1);
	/* defaults */
	assert_string_equal(((const struct polhemus_opts *)(q)->opt)->dev.device, "auto");
	assert_int_equal(((const struct polhemus_opts *)(q)->opt)->model, CFG_PH_AUTO);
	assert_string_equal(((const struct polhemus_opts *)(q)->opt)->stations, "head left_hand right_hand");
	assert_near(((const struct polhemus_opts *)(q)->opt)->hemisphere[0], 1, 0);
	assert_int_equal(((const struct hydra_opts *)(c->source[0]).opt)->hid_interface, 2);
	assert_has(print_config(f), "mount_right = 0.01 0 0 0 0 0 1    ; e.conf:8\n");
}

static void test_err_hardware_sources(void **state)
{
	expect_text_err(*state, "[source h]\ntype = hydra\nmount_wrist = 0 0 0\n",
			"e.conf:3: [source h] mount_wrist: the source has no sensor 'wrist' (it has: left, right)",
			NULL);
	expect_text_err(*state, "[source h]\ntype = hydra\nmount_left = 0 0\n",
			"e.conf:3: [source h] mount_left: '0 0' is not x y z or x y z qw qx qy qz", NULL);
	expect_text_err(*state, "[source h]\ntype = hydra\nmount_left = 0 0 0 0 0 0 0\n",
			"e.conf:3: [source h] mount_left: the rotation qw qx qy qz is zero", NULL);
	expect_text_err(*state, "[source h]\ntype = hydra\nmount_left = 20 0 0\n",
			"e.conf:3: [source h] mount_left: 20 is out of range [-10, 10] m", NULL);
	expect_text_err(*state, "[source h]\ntype = hydra\nmodel = liberty\n",
			"e.conf:3: [source h] model: unknown key for type hydra", NULL);
	expect_text_err(*state, "[source p]\ntype = polhemus\nmodel = fastrak\n",
			"e.conf:3: [source p] model: 'fastrak' is not one of: auto, liberty, liberty_hs, patriot, "
			"patriot_hs",
			NULL);
	expect_text_err(*state, "[source p]\ntype = polhemus\nsensors = a b a\n",
			"e.conf:3: [source p] sensors: 'a' named twice", NULL);
	expect_text_err(*state, "[source p]\ntype = polhemus\nsensors = - -\n",
			"e.conf:3: [source p] sensors: no sensor named", NULL);
	expect_text_err(*state, "[source p]\ntype = polhemus\nsensors = a/b\n",
			"e.conf:3: [source p] sensors: 'a/b' is not a valid sensor name", NULL);
	expect_text_err(*state, "[source p]\ntype = polhemus\nsensors = 1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16 17\n",
			"e.conf:3: [source p] sensors: more than 16 names", NULL);
	expect_text_err(*state, "[source p]\ntype = polhemus\ncapture = /nonexistent.cap\n",
			"e.conf:3: [source p] capture /nonexistent.cap: No such file or directory", NULL);
	expect_text_err(*state, "[source p]\ntype = polhemus\n[avatar a]\nperson = p\nsensors = x\n",
			"e.conf:5: [avatar a] sensors: unknown key", NULL);
	expect_text_err(*state, "[source s]\ntype = sim\nmount_p1.head = 0 0 0\n",
			"e.conf:3: [source s] mount_p1.head: the source has no sensor 'p1.head'", NULL);
}

static void test_values_avatar(void **state)
{
	struct fx *f = *state;
	const struct config *c = load_text_ok(f, "[avatar bob]\n"
						 "id = 42\n"
						 "head = s/p1.head\n"
						 "left_hand = s/p0.left_hand\n"
						 "right_hand = s/p1.right_hand\n"
						 "shoulder = 0.2\n"
						 "upper_arm = 0.31\n"
						 "forearm = 0.27\n"
						 "hand = 0.05\n"
						 "head_offset = 0.01 -0.02 0.15\n"
						 "rest_pronation = 12.5\n"
						 "j1 = -10 11\n"
						 "j2 = -80 20\n"
						 "j3 = -50 110\n"
						 "j4 = -85 75\n"
						 "j5 = -90 45\n"
						 "j6 = -60 70\n"
						 "j7 = -45 35\n"
						 "j8 = -15 25\n"
						 "solver = matrix\n"
						 "ik_max_iterations = 30\n"
						 "ik_tolerance = 0.5\n"
						 "ik_max_evals = 1000\n"
						 "ik_warm_iterations = 0\n"
						 "[source s]\ntype = sim\npeople = 2\n");
	const struct cfg_avatar *a = &c->avatar[0];
	static const double lim[8][2] = { { -10, 11 }, { -80, 20 }, { -50, 110 }, { -85, 75 },
					  { -90, 45 }, { -60, 70 }, { -45, 35 },  { -15, 25 } };

	assert_int_equal(c->n_avatars, 1);
	assert_string_equal(a->name, "bob");
	assert_int_equal(a->id, 42);
	/* sim sensors: person N's head, left hand, right hand are 3N, 3N+1, 3N+2 */
	assert_sensor(a, 0, 0, 3);
	assert_sensor(a, 1, 0, 1);
	assert_sensor(a, 2, 0, 5);
	assert_int_equal(a->sensor[0].where.line, 3);
	assert_near(a->dims[0], 0.2, 0);
	assert_near(a->dims[1], 0.31, 0);
	assert_near(a->dims[2], 0.27, 0);
	assert_near(a->dims[3], 0.05, 0);
	assert_near(a->head_offset[0], 0.01, 0);
	assert_near(a->head_offset[1], -0.02, 0);
	assert_near(a->head_offset[2], 0.15, 0);
	assert_near(a->rest_pronation, 12.5, 0);
	for (int j = 0; j < 8; j++)
		assert_range_deg(a, j, lim[j][0], lim[j][1]);
	assert_int_equal(a->solver, CFG_SOLVER_MATRIX);
	assert_int_equal(a->max_iter, 30);
	assert_near(a->tol_mm, 0.5, 0);
	assert_int_equal(a->max_evals, 1000);
	assert_int_equal(a->warm_iter, 0);
}

static void test_values_outputs(void **state)
{
	struct fx *f = *state;
	const struct config *c = load_text_ok(f, "[source s]\ntype = sim\npeople = 2\n"
						 "[avatar a]\nperson = s/p0\n"
						 "[avatar b]\nperson = s/p1\n"
						 "[output u]\ntype = udp\naddress = 10.0.0.1\nport = 9000\n"
						 "decimate = 4\navatars = b a\n"
						 "[output m]\ntype = multicast\naddress = 239.255.77.70\nport = 7700\n"
						 "interface = lo\nttl = 8\nloopback = no\n"
						 "[output t]\ntype = tcp\naddress = 0.0.0.0\nport = 7771\n"
						 "max_clients = 3\nclient_buffer = 8192\n"
						 "[output x]\ntype = unix\npath = /tmp/agw.sock\navatars = b\n");
	const struct cfg_output *o = c->output;

	assert_int_equal(c->n_outputs, 4);
	assert_string_equal(o[0].name, "u");
	assert_int_equal(o[0].type, cfg_output_type_find("udp"));
	assert_string_equal(((const struct udp_opts *)(o[0]).opt)->address, "10.0.0.1");
	assert_int_equal(((const struct udp_opts *)(o[0]).opt)->port, 9000);
	assert_int_equal(o[0].decimate, 4);
	assert_int_equal(o[0].n_avatars, 2);
	assert_int_equal(o[0].avatar_ids[0], 1); /* in the order listed */
	assert_int_equal(o[0].avatar_ids[1], 0);

	assert_int_equal(o[1].type, cfg_output_type_find("multicast"));
	assert_string_equal(((const struct udp_opts *)(o[1]).opt)->address, "239.255.77.70");
	assert_int_equal(((const struct udp_opts *)(o[1]).opt)->port, 7700);
	assert_string_equal(((const struct udp_opts *)(o[1]).opt)->interface, "lo");
	assert_int_equal(((const struct udp_opts *)(o[1]).opt)->ttl, 8);
	assert_false(((const struct udp_opts *)(o[1]).opt)->mcast_loop);
	assert_int_equal(o[1].n_avatars, 0); /* all */

	assert_int_equal(o[2].type, cfg_output_type_find("tcp"));
	assert_string_equal(((const struct stream_opts *)(o[2]).opt)->address, "0.0.0.0");
	assert_int_equal(((const struct stream_opts *)(o[2]).opt)->port, 7771);
	assert_int_equal(((const struct stream_opts *)(o[2]).opt)->max_clients, 3);
	assert_int_equal(((const struct stream_opts *)(o[2]).opt)->client_buffer, 8192);

	assert_int_equal(o[3].type, cfg_output_type_find("unix"));
	assert_string_equal(((const struct stream_opts *)(o[3]).opt)->path, "/tmp/agw.sock");
	assert_int_equal(o[3].n_avatars, 1);
	assert_int_equal(o[3].avatar_ids[0], 1);
}

static void test_defaults(void **state)
{
	struct fx *f = *state;
	const struct config *c = load_text_ok(f, "[source s]\ntype = sim\n"
						 "[source r]\ntype = replay\nfile = builtin:cmu_141_16.csv\n"
						 "[avatar a]\nperson = s/p0\n"
						 "[output u]\ntype = udp\n"
						 "[output m]\ntype = multicast\naddress = 239.255.77.70\n"
						 "[output t]\ntype = tcp\n"
						 "[output x]\ntype = unix\n");
	const struct cfg_source *s = &c->source[0], *r = &c->source[1];
	const struct cfg_avatar *a = &c->avatar[0];
	static const double lim[8][2] = { { -30, 30 }, { -170, 30 }, { -60, 120 }, { -90, 90 },
					  { -90, 60 }, { -90, 90 },  { -30, 30 },  { -80, 80 } };

	assert_near(c->daemon.rate, 240, 0);
	assert_int_equal(c->daemon.mode, CFG_LOOP_DEADLINE);
	assert_near(c->daemon.stale_ms, 100, 0);
	assert_int_equal(c->daemon.realtime_priority, 0);
	assert_int_equal(c->daemon.cpu, -1);
	assert_false(c->daemon.busy_wait);
	assert_true(c->daemon.lock_memory);
	assert_string_equal(c->daemon.control_socket, "auto");
	assert_near(c->daemon.describe_interval, 1, 0);
	assert_int_equal(c->daemon.log_level, CFG_LOG_INFO);

	for (int i = 0; i < 3; i++) {
		assert_near(s->origin[i], 0, 0);
		assert_near(r->origin[i], 0, 0);
	}
	assert_near(s->yaw, 0, 0);
	assert_int_equal(((const struct sim_opts *)(s)->opt)->people, 1);
	assert_int_equal(((const struct sim_opts *)(s)->opt)->seed, 1);
	assert_near(((const struct sim_opts *)(s)->opt)->sample_rate, 240, 0);
	assert_near(((const struct sim_opts *)(s)->opt)->spacing, 1, 0);
	assert_int_equal(r->driver, cfg_source_type_find("replay"));
	assert_string_equal(((const struct replay_opts *)(r)->opt)->file, "builtin:cmu_141_16.csv");
	assert_near(((const struct replay_opts *)(r)->opt)->speed, 1, 0);
	assert_true(((const struct replay_opts *)(r)->opt)->loop);
	assert_near(((const struct replay_opts *)(r)->opt)->start, 0, 0);

	assert_int_equal(a->id, 0);
	assert_near(a->dims[0], 0.1732, 0);
	assert_near(a->dims[1], 0.2886, 0);
	assert_near(a->dims[2], 0.1955, 0);
	assert_near(a->dims[3], 0, 0);
	assert_near(a->head_offset[0], 0.008, 0);
	assert_near(a->head_offset[1], -0.0386, 0);
	assert_near(a->head_offset[2], 0.0967, 0);
	assert_near(a->rest_pronation, -30, 0);
	for (int j = 0; j < 8; j++)
		assert_range_deg(a, j, lim[j][0], lim[j][1]);
	assert_int_equal(a->solver, CFG_SOLVER_DQ);
	assert_int_equal(a->max_iter, 20);
	assert_near(a->tol_mm, 0.01, 0);
	assert_int_equal(a->max_evals, 800);
	assert_int_equal(a->warm_iter, 6);

	for (int i = 0; i < 4; i++) {
		assert_int_equal(c->output[i].decimate, 1);
		assert_int_equal(c->output[i].n_avatars, 0);
		assert_null(c->output[i].avatar_ids);
		assert_string_equal(c->output[i].avatar_list, "all");
	}
	assert_string_equal(((const struct udp_opts *)(c->output[0]).opt)->address, "127.0.0.1");
	assert_int_equal(((const struct udp_opts *)(c->output[0]).opt)->port, 7770);
	assert_int_equal(((const struct udp_opts *)(c->output[1]).opt)->ttl, 1);
	assert_true(((const struct udp_opts *)(c->output[1]).opt)->mcast_loop);
	assert_string_equal(((const struct udp_opts *)(c->output[1]).opt)->interface, "");
	assert_int_equal(((const struct udp_opts *)(c->output[1]).opt)->port, 7770);
	assert_string_equal(((const struct stream_opts *)(c->output[2]).opt)->address, "127.0.0.1");
	assert_int_equal(((const struct stream_opts *)(c->output[2]).opt)->max_clients, 8);
	assert_int_equal(((const struct stream_opts *)(c->output[2]).opt)->client_buffer, 65536);
	assert_string_equal(((const struct stream_opts *)(c->output[3]).opt)->path, "/run/avatargw/stream");
	assert_int_equal(((const struct stream_opts *)(c->output[3]).opt)->max_clients, 8);
}

static void test_bool_spellings(void **state)
{
	struct fx *f = *state;
	static const char *const yes[] = { "yes", "YES", "true", "On", "1" };
	static const char *const no[] = { "no", "No", "false", "OFF", "0" };
	char text[128];

	for (int i = 0; i < 5; i++) {
		snprintf(text, sizeof(text), "[daemon]\nlock_memory = %s\n[source s]\ntype = sim\n", yes[i]);
		set_ctx("%s", yes[i]);
		assert_true(load_text_ok(f, text)->daemon.lock_memory);
		config_free(&f->c);
		snprintf(text, sizeof(text), "[daemon]\nlock_memory = %s\n[source s]\ntype = sim\n", no[i]);
		assert_false(load_text_ok(f, text)->daemon.lock_memory);
		config_free(&f->c);
	}
}

/* config/avatargw.conf as shipped: no hardware, one simulated person, UDP to 127.0.0.1:7770 */
static void test_shipped_config(void **state)
{
	struct fx *f = *state;
	char path[PATH_MAX];
	const struct config *c = &f->c;

	repo_path("config/avatargw.conf", path, sizeof(path));
	if (config_load(&f->c, path, f->err, sizeof(f->err)))
		fail_msg("%s", f->err);
	assert_int_equal(c->n_sources, 1);
	assert_int_equal(c->source[0].driver, cfg_source_type_find("sim"));
	assert_int_equal(c->n_avatars, 1);
	for (int r = 0; r < 3; r++)
		assert_sensor(&c->avatar[0], r, 0, r); /* sim/p0.* */
	assert_int_equal(c->n_outputs, 1);
	assert_int_equal(c->output[0].type, cfg_output_type_find("udp"));
	assert_string_equal(((const struct udp_opts *)(c->output[0]).opt)->address, "127.0.0.1");
	assert_int_equal(((const struct udp_opts *)(c->output[0]).opt)->port, 7770);
	assert_int_equal(c->output[0].n_avatars, 0);
}

/* ---- errors: file:line, section, key, what ------------------------------------------------- */

static void test_err_unknown_key(void **state)
{
	expect_text_err(
		*state, "[daemon]\nrate = 100\nrat = 100\n", "e.conf:3: [daemon] rat: unknown key",
		"(known: rate, mode, stale_ms, realtime_priority, cpu, busy_wait, lock_memory, control_socket, "
		"describe_interval, log_level, record_dir, record_messages, record_flush, record_flush_records, "
		"record_fsync, record_rotate_size, record_rotate_time, record_buffer, record_keyframe_rate",
		NULL);
}

/* a key of another driver or output type is unknown here, and the list shows this type's keys */
static void test_err_key_of_other_type(void **state)
{
	expect_text_err(*state, "[source clip]\ntype = replay\nfile = builtin:cmu_141_16.csv\npeople = 2\n",
			"e.conf:4: [source clip] people: unknown key for type replay",
			"(known: type, origin, yaw, max_distance, axes, mount_SENSOR, sample_rate, file, speed, loop, "
			"start, step, interpolate)",
			NULL);
	expect_text_err(*state, "[output o]\ntype = udp\npath = /tmp/x\n",
			"e.conf:3: [output o] path: unknown key for type udp",
			"(known: type, decimate, avatars, port, gso, address)", NULL);
}

static void test_err_unknown_section(void **state)
{
	expect_text_err(*state, "[daemon]\nrate = 100\n\n[sources s]\ntype = sim\n",
			"e.conf:5: [sources s]: unknown section", NULL);
	expect_text_err(*state, "[daemon x]\nrate = 100\n", "e.conf:2: [daemon x]: the daemon section has no name",
			NULL);
	expect_text_err(*state, "[source a/b]\ntype = sim\n", "e.conf:2: [source a/b]: 'a/b' is not a valid name",
			NULL);
}

static void test_err_key_outside_section(void **state)
{
	expect_text_err(*state, "; a comment\nrate = 100\n[daemon]\n", "e.conf:2: rate: a key outside any section",
			NULL);
}

static void test_busy_wait(void **state)
{
	struct fx *f = *state;

	assert_true(load_text_ok(f, "[daemon]\nbusy_wait = yes\ncpu = 1\n[source s]\ntype = sim\n"
				    "[avatar a]\nperson = s/p0\n")
			    ->daemon.busy_wait);
	config_free(&f->c);
	expect_text_err(*state, "[daemon]\nmode = events\n; spin\nbusy_wait = yes\n",
			"e.conf:4: [daemon] busy_wait: only with mode = deadline", NULL);
	expect_text_err(*state, "[daemon]\nbusy_wait = sometimes\n", "e.conf:2: [daemon] busy_wait:", NULL);
}

static void test_err_key_twice(void **state)
{
	expect_text_err(*state, "[daemon]\nrate = 100\nmode = events\nrate = 200\n",
			"e.conf:4: [daemon] rate: given twice in one file (first at e.conf:2)", NULL);
	/* a section may be reopened, but not to give a key again */
	expect_text_err(*state, "[source s]\ntype = sim\n[daemon]\ncpu = 1\n[source s]\ntype = sim\n",
			"e.conf:6: [source s] type: given twice in one file (first at e.conf:2)", NULL);
}

static void test_err_out_of_range(void **state)
{
	expect_text_err(*state, "[daemon]\n\nrate = 0\n", "e.conf:3: [daemon] rate: 0 is out of range [1, 4000] Hz",
			NULL);
	expect_text_err(*state, "[daemon]\nstale_ms = 60001\n", "e.conf:2: [daemon] stale_ms: 60001 is out of range",
			NULL);
	expect_text_err(*state, "[source s]\ntype = sim\nyaw = 361\n", "e.conf:3: [source s] yaw: 361 is out of range",
			"360", NULL);
	expect_text_err(*state, "[avatar a]\nperson = s/p0\nhead_offset = 0 0 2\n[source s]\ntype = sim\n",
			"e.conf:3: [avatar a] head_offset: 2 is out of range [-1, 1] m", NULL);
	expect_text_err(*state, "[avatar a]\nperson = s/p0\nrest_pronation = -91\n[source s]\ntype = sim\n",
			"e.conf:3: [avatar a] rest_pronation: -91 is out of range [-90, 90] deg", NULL);
	expect_text_err(*state, "[avatar a]\nperson = s/p0\nid = 65536\n[source s]\ntype = sim\n",
			"e.conf:3: [avatar a] id: '65536' is not a whole number in [0, 65535]", NULL);
}

static void test_err_not_a_number(void **state)
{
	expect_text_err(*state, "[daemon]\nrate = fast\n", "e.conf:2: [daemon] rate: 'fast' is not a number", NULL);
	expect_text_err(*state, "[daemon]\nrate = 100Hz\n", "e.conf:2: [daemon] rate: '100Hz' is not a number", NULL);
	expect_text_err(*state, "[daemon]\nrate =\n", "e.conf:2: [daemon] rate: '' is not a number", NULL);
	expect_text_err(*state, "[daemon]\nrate = nan\n", "e.conf:2: [daemon] rate: 'nan' is not a number", NULL);
}

static void test_err_not_whole(void **state)
{
	expect_text_err(*state, "[daemon]\nrealtime_priority = 1.5\n",
			"e.conf:2: [daemon] realtime_priority: '1.5' is not a whole number", NULL);
	expect_text_err(*state, "[source s]\ntype = sim\npeople = 2.5\n",
			"e.conf:3: [source s] people: '2.5' is not a whole number", NULL);
}

static void test_err_bad_bool(void **state)
{
	expect_text_err(*state, "[daemon]\nlock_memory = maybe\n",
			"e.conf:2: [daemon] lock_memory: 'maybe' is not yes or no", NULL);
}

static void test_err_bad_enum(void **state)
{
	expect_text_err(*state, "[daemon]\nmode = sometimes\n",
			"e.conf:2: [daemon] mode: 'sometimes' is not one of: deadline, events", NULL);
	expect_text_err(*state, "[output o]\ntype = serial\n",
			"e.conf:2: [output o] type: 'serial' is not one of: udp, multicast, tcp, unix", NULL);
	expect_text_err(*state, "[avatar a]\nperson = s/p0\nsolver = Matrix\n[source s]\ntype = sim\n",
			"e.conf:3: [avatar a] solver: 'Matrix' is not one of: dq, matrix", NULL);
}

static void test_err_vec3(void **state)
{
	expect_text_err(*state, "[source s]\ntype = sim\norigin = 1 2\n",
			"e.conf:3: [source s] origin: '1 2' is not three numbers (x y z)", NULL);
	expect_text_err(*state, "[source s]\ntype = sim\norigin = 1 2 3 4\n",
			"e.conf:3: [source s] origin: '1 2 3 4' is not three numbers", NULL);
}

static void test_err_range(void **state)
{
	const char *tail = "[source s]\ntype = sim\n";
	char text[256];

	snprintf(text, sizeof(text), "[avatar a]\nperson = s/p0\nj5 = 10 -10\n%s", tail);
	expect_text_err(*state, text, "e.conf:3: [avatar a] j5: '10 -10' must satisfy -180 <= lo <= hi <= 180", NULL);
	snprintf(text, sizeof(text), "[avatar a]\nperson = s/p0\nj1 = -200 0\n%s", tail);
	expect_text_err(*state, text, "e.conf:3: [avatar a] j1: '-200 0' must satisfy", NULL);
	snprintf(text, sizeof(text), "[avatar a]\nperson = s/p0\nj8 = 30\n%s", tail);
	expect_text_err(*state, text, "e.conf:3: [avatar a] j8: '30' is not two numbers (lo hi, degrees)", NULL);
}

static void test_err_source_type(void **state)
{
	expect_text_err(
		*state, "[daemon]\nrate = 100\n[source s]\npeople = 2\n",
		"e.conf:4: [source s] type: missing (sim, replay, modbus, can, hydra, polhemus, vrpn or dtrack)", NULL);
	expect_text_err(*state, "[source s]\n\ntype = vive\n",
			"e.conf:3: [source s] type: unknown driver 'vive' (known: sim, replay, modbus, can, hydra, "
			"polhemus, vrpn, dtrack)",
			NULL);
}

static void test_err_replay_file(void **state)
{
	struct fx *f = *state;

	expect_text_err(f, "[source clip]\ntype = replay\nspeed = 2\n",
			"e.conf:2: [source clip] file: missing (the recording to replay)", NULL);
	/* a file that is not there: the path as resolved, at the line of the key */
	put(f, "main.conf", "[source clip]\ntype = replay\nfile = nope.csv\n");
	expect_file_err(f, "main.conf", "%s/main.conf:3: [source clip] file: ", "/nope.csv: No such file or directory",
			NULL);
	/* a CSV without a needed column */
	put_csv(f, "clips/partial.csv", "rhand_qz", 3);
	put(f, "main.conf", "[source clip]\ntype = replay\nfile = clips/partial.csv\n");
	expect_file_err(f, "main.conf",
			"%s/main.conf:3: [source clip] file: ", "clips/partial.csv:1: no column 'rhand_qz'", NULL);
	put(f, "nocol.csv", "frame,time,head_x\n0,0,0\n");
	put(f, "main.conf", "[source clip]\ntype = replay\nfile = nocol.csv\n");
	expect_file_err(f, "main.conf", "%s/main.conf:3: [source clip] file: ", "no column 't'", NULL);
	expect_text_err(f, "[source clip]\ntype = replay\nfile = builtin:nothing.csv\n",
			"e.conf:3: [source clip] file: builtin:nothing.csv: no such builtin clip", NULL);
}

static void test_err_sensor_reference(void **state)
{
	expect_text_err(*state, "[source s]\ntype = sim\n[avatar a]\nperson = s/p0\nhead = t/p0.head\n",
			"e.conf:5: [avatar a] head: no [source t] is configured", NULL);
	expect_text_err(*state, "[source s]\ntype = sim\n[avatar a]\nperson = t/p0\n",
			"e.conf:4: [avatar a] person: no [source t] is configured", NULL);
	expect_text_err(*state, "[source s]\ntype = sim\n[avatar a]\nperson = s/p0\nleft_hand = s/p0.lhand\n",
			"e.conf:5: [avatar a] left_hand: source 's' has no sensor 'p0.lhand' "
			"(it has: p0.head, p0.left_hand, p0.right_hand)",
			NULL);
	/* person = SOURCE suits replay, not sim (whose sensors carry a prefix) */
	expect_text_err(*state, "[source s]\ntype = sim\n[avatar a]\nperson = s\n",
			"e.conf:4: [avatar a] person: source 's' has no sensor 'head'", NULL);
	expect_text_err(*state, "[source s]\ntype = sim\n[avatar a]\nperson = s/p0\nhead = s\n",
			"e.conf:5: [avatar a] head: 's' names no sensor (SOURCE/SENSOR)", NULL);
}

static void test_err_avatar_without_sensors(void **state)
{
	expect_text_err(*state, "[source s]\ntype = sim\n[avatar a]\nshoulder = 0.2\n",
			"e.conf:4: [avatar a] head: missing (give head = SOURCE/SENSOR or person = SOURCE)", NULL);
	expect_text_err(*state, "[source s]\ntype = sim\n[avatar a]\nhead = s/p0.head\nleft_hand = s/p0.left_hand\n",
			"e.conf:4: [avatar a] right_hand: missing", NULL);
}

static void test_err_duplicate_avatar_id(void **state)
{
	expect_text_err(*state,
			"[source s]\ntype = sim\npeople = 2\n"
			"[avatar a]\nperson = s/p0\nid = 7\n"
			"[avatar b]\nperson = s/p1\nid = 7\n",
			"e.conf:9: [avatar b] id: 7 is already avatar 'a'", NULL);
}

static void test_err_output_unknown_avatar(void **state)
{
	expect_text_err(*state,
			"[source s]\ntype = sim\n[avatar a]\nperson = s/p0\n"
			"[output o]\ntype = udp\navatars = a ghost\n",
			"e.conf:7: [output o] avatars: no avatar named 'ghost'", NULL);
	expect_text_err(*state,
			"[source s]\ntype = sim\n[avatar a]\nperson = s/p0\n[output o]\ntype = udp\navatars =\n",
			"e.conf:7: [output o] avatars: empty list (say all)", NULL);
}

static void test_err_multicast_without_address(void **state)
{
	expect_text_err(*state, "[output lan]\ntype = multicast\nport = 7770\n",
			"e.conf:2: [output lan] address: missing (a multicast group)", NULL);
}

/* ---- the industrial buses: modbus and can sources and outputs ----------------------------------- */

static void test_values_bus(void **state)
{
	struct fx *f = *state;
	const struct config *c =
		load_text_ok(f, "[source robot]\ntype = modbus\naddress = robot.local\nport = 5020\n"
				"unit_id = 255\nregister_type = input\nsensors = 2\nsensor_stride = 16\n"
				"position_register = 400\nposition_format = float32\nposition_scale = 1\n"
				"orientation_register = 406\norientation_format = int32\n"
				"orientation_scale = 0.0001\norientation = quat_xyzw\nword_order = dcba\n"
				"poll_rate = 125\ntimeout_ms = 50\n"
				"[source imu]\ntype = can\ninterface = fd:3\nsensors = 3\n"
				"orientation_id = 0x18FF0000\nposition_id = -1\nquaternion_scale = 16384\n"
				"quaternion_order = xyzw\nposition_scale = 0.0005\nextended_ids = yes\n"
				"[avatar a]\nhead = robot/pose0\nleft_hand = robot/pose1\nright_hand = imu/pose2\n"
				"[output plc]\ntype = modbus\naddress = 0.0.0.0\nport = 1502\nmax_clients = 3\n"
				"register_base = 1000\nregister_stride = 66\nword_order = cdab\n"
				"writable_registers = 8\nidle_timeout = 0\n"
				"[output arm]\ntype = can\ninterface = can1\nbase_id = 0x7F8\nsafe = no\n"
				"max_speed = 45\ndecimate = 2\n");
	const struct cfg_source *r = &c->source[0], *i = &c->source[1];
	const struct cfg_output *m = &c->output[0], *a = &c->output[1];

	assert_int_equal(r->driver, cfg_source_type_find("modbus"));
	assert_string_equal(((const struct modbus_in_opts *)(r)->opt)->address, "robot.local");
	assert_int_equal(((const struct modbus_in_opts *)(r)->opt)->port, 5020);
	assert_int_equal(((const struct modbus_in_opts *)(r)->opt)->unit_id, 255);
	assert_int_equal(((const struct modbus_in_opts *)(r)->opt)->register_type, CFG_REGS_INPUT);
	assert_int_equal(((const struct modbus_in_opts *)(r)->opt)->sensors, 2);
	assert_int_equal(((const struct modbus_in_opts *)(r)->opt)->sensor_stride, 16);
	assert_int_equal(((const struct modbus_in_opts *)(r)->opt)->pos_register, 400);
	assert_int_equal(((const struct modbus_in_opts *)(r)->opt)->pos_format, CFG_REG_FLOAT32);
	assert_near(((const struct modbus_in_opts *)(r)->opt)->pos_scale, 1, 0);
	assert_int_equal(((const struct modbus_in_opts *)(r)->opt)->ori_register, 406);
	assert_int_equal(((const struct modbus_in_opts *)(r)->opt)->ori_format, CFG_REG_INT32);
	assert_near(((const struct modbus_in_opts *)(r)->opt)->ori_scale, 0.0001, 0);
	assert_int_equal(((const struct modbus_in_opts *)(r)->opt)->orientation, CFG_ORI_QUAT_XYZW);
	assert_int_equal(((const struct modbus_in_opts *)(r)->opt)->word_order, CFG_WORD_DCBA);
	assert_near(((const struct modbus_in_opts *)(r)->opt)->poll_rate, 125, 0);
	assert_near(((const struct modbus_in_opts *)(r)->opt)->timeout_ms, 50, 0);
	assert_int_equal(i->driver, cfg_source_type_find("can"));
	assert_string_equal(((const struct can_in_opts *)(i)->opt)->interface, "fd:3");
	assert_int_equal(((const struct can_in_opts *)(i)->opt)->sensors, 3);
	assert_int_equal(((const struct can_in_opts *)(i)->opt)->ori_id, 0x18FF0000);
	assert_int_equal(((const struct can_in_opts *)(i)->opt)->pos_id, -1);
	assert_near(((const struct can_in_opts *)(i)->opt)->quat_scale, 16384, 0);
	assert_int_equal(((const struct can_in_opts *)(i)->opt)->quat_order, CFG_QUAT_XYZW);
	assert_near(((const struct can_in_opts *)(i)->opt)->pos_scale, 0.0005, 0);
	assert_true(((const struct can_in_opts *)(i)->opt)->extended_ids);
	assert_sensor(&c->avatar[0], 2, 1, 2);
	assert_int_equal(m->type, cfg_output_type_find("modbus"));
	assert_string_equal(((const struct modbus_out_opts *)(m)->opt)->address, "0.0.0.0");
	assert_int_equal(((const struct modbus_out_opts *)(m)->opt)->port, 1502);
	assert_int_equal(((const struct modbus_out_opts *)(m)->opt)->max_clients, 3);
	assert_int_equal(((const struct modbus_out_opts *)(m)->opt)->reg_base, 1000);
	assert_int_equal(((const struct modbus_out_opts *)(m)->opt)->reg_stride, 66);
	assert_int_equal(((const struct modbus_out_opts *)(m)->opt)->word_order, CFG_WORD_CDAB);
	assert_int_equal(((const struct modbus_out_opts *)(m)->opt)->writable_regs, 8);
	assert_near(((const struct modbus_out_opts *)(m)->opt)->idle_timeout, 0, 0);
	assert_int_equal(a->type, cfg_output_type_find("can"));
	assert_string_equal(((const struct can_out_opts *)(a)->opt)->interface, "can1");
	assert_int_equal(((const struct can_out_opts *)(a)->opt)->base_id, 0x7F8);
	assert_false(((const struct can_out_opts *)(a)->opt)->safe);
	set_ctx("max_speed 45 deg/s");
	assert_near(((const struct can_out_opts *)(a)->opt)->max_speed, 45 * DEG, ANG_TOL);
	assert_int_equal(a->decimate, 2);
}

static void test_defaults_bus(void **state)
{
	struct fx *f = *state;
	const struct config *c =
		load_text_ok(f, "[source robot]\ntype = modbus\naddress = 192.0.2.1\n"
				"[source imu]\ntype = can\ninterface = can0\n"
				"[avatar a]\nhead = robot/pose0\nleft_hand = imu/pose0\nright_hand = robot/pose0\n"
				"[output plc]\ntype = modbus\nport = 1502\n"
				"[output arm]\ntype = can\ninterface = can0\n");
	const struct cfg_source *r = &c->source[0], *i = &c->source[1];
	const struct cfg_output *m = &c->output[0], *a = &c->output[1];

	assert_int_equal(((const struct modbus_in_opts *)(r)->opt)->port, 502);
	assert_int_equal(((const struct modbus_in_opts *)(r)->opt)->unit_id, 1);
	assert_int_equal(((const struct modbus_in_opts *)(r)->opt)->register_type, CFG_REGS_HOLDING);
	assert_int_equal(((const struct modbus_in_opts *)(r)->opt)->sensors, 1);
	assert_int_equal(((const struct modbus_in_opts *)(r)->opt)->sensor_stride, 0);
	assert_int_equal(((const struct modbus_in_opts *)(r)->opt)->pos_register, 0);
	assert_int_equal(((const struct modbus_in_opts *)(r)->opt)->pos_format, CFG_REG_INT16);
	assert_near(((const struct modbus_in_opts *)(r)->opt)->pos_scale, 0.001, 0);
	assert_int_equal(((const struct modbus_in_opts *)(r)->opt)->ori_register, 3);
	assert_int_equal(((const struct modbus_in_opts *)(r)->opt)->ori_format, CFG_REG_INT16);
	assert_near(((const struct modbus_in_opts *)(r)->opt)->ori_scale, 0.001, 0);
	assert_int_equal(((const struct modbus_in_opts *)(r)->opt)->orientation, CFG_ORI_ROTVEC);
	assert_int_equal(((const struct modbus_in_opts *)(r)->opt)->word_order, CFG_WORD_ABCD);
	assert_near(((const struct modbus_in_opts *)(r)->opt)->poll_rate, 50, 0);
	assert_near(((const struct modbus_in_opts *)(r)->opt)->timeout_ms, 200, 0);
	assert_int_equal(((const struct can_in_opts *)(i)->opt)->sensors, 1);
	assert_int_equal(((const struct can_in_opts *)(i)->opt)->ori_id, 0x200);
	assert_int_equal(((const struct can_in_opts *)(i)->opt)->pos_id, 0x280);
	assert_near(((const struct can_in_opts *)(i)->opt)->quat_scale, 32768, 0);
	assert_int_equal(((const struct can_in_opts *)(i)->opt)->quat_order, CFG_QUAT_WXYZ);
	assert_false(((const struct can_in_opts *)(i)->opt)->extended_ids);
	assert_string_equal(((const struct modbus_out_opts *)(m)->opt)->address, "127.0.0.1");
	assert_int_equal(((const struct modbus_out_opts *)(m)->opt)->max_clients, 8);
	assert_int_equal(((const struct modbus_out_opts *)(m)->opt)->reg_base, 0);
	assert_int_equal(((const struct modbus_out_opts *)(m)->opt)->reg_stride, 100);
	assert_int_equal(((const struct modbus_out_opts *)(m)->opt)->word_order, CFG_WORD_ABCD);
	assert_int_equal(((const struct modbus_out_opts *)(m)->opt)->writable_regs, 0);
	assert_near(((const struct modbus_out_opts *)(m)->opt)->idle_timeout, 60, 0);
	assert_int_equal(((const struct can_out_opts *)(a)->opt)->base_id, 0x100);
	assert_false(((const struct can_out_opts *)(a)->opt)->extended_ids);
	assert_true(((const struct can_out_opts *)(a)->opt)->safe);
	set_ctx("max_speed 90 deg/s");
	assert_near(((const struct can_out_opts *)(a)->opt)->max_speed, 90 * DEG, ANG_TOL);
}

static void test_err_bus(void **state)
{
	static const char people[] = "[source s]\ntype = sim\npeople = 300\n[avatar a]\nperson = s/p0\ncount = 300\n";
	char text[1024];

	expect_text_err(*state, "[output plc]\ntype = modbus\n", "e.conf:2: [output plc] port: missing", "1502", NULL);
	expect_text_err(*state, "[output arm]\ntype = can\nport = 1\n", "e.conf:2: [output arm] interface: missing",
			NULL);
	expect_text_err(*state, "[output u]\ntype = udp\nsafe = no\n", "e.conf:3: [output u] safe: unknown key", NULL);
	expect_text_err(*state, "[output plc]\ntype = modbus\nport = 1502\nregister_stride = 65\n",
			"e.conf:4: [output plc] register_stride: 65 is out of range [66, 65536]", NULL);
	expect_text_err(*state, "[output plc]\ntype = modbus\nport = 1502\nword_order = big\n",
			"e.conf:4: [output plc] word_order: 'big' is not one of: abcd, cdab, badc, dcba", NULL);
	snprintf(text, sizeof(text), "%s[output arm]\ntype = can\ninterface = can0\n", people);
	expect_text_err(*state, text, "e.conf:8: [output arm] base_id: 300 avatars need identifiers up to 0xA5C",
			"extended_ids", NULL);
	snprintf(text, sizeof(text), "%s[output plc]\ntype = modbus\nport = 1502\nregister_base = 40000\n", people);
	expect_text_err(*state, text,
			"e.conf:8: [output plc] register_base, register_stride: 300 avatars need "
			"registers up to 69965",
			NULL);
	expect_text_err(*state, "[source r]\ntype = modbus\n", "e.conf:2: [source r] address: missing", NULL);
	expect_text_err(*state, "[source r]\ntype = modbus\naddress = h\nunit_id = 248\n",
			"e.conf:2: [source r] unit_id: 248", NULL);
	expect_text_err(*state, "[source r]\ntype = modbus\naddress = h\nsensors = 3\n",
			"e.conf:2: [source r] sensor_stride", NULL);
	expect_text_err(*state, "[source r]\ntype = modbus\naddress = h\norientation_register = 2\n",
			"e.conf:2: [source r] position_register, orientation_register: sensor 0's", "overlap", NULL);
	expect_text_err(*state, "[source r]\ntype = modbus\naddress = h\norientation = euler\n",
			"e.conf:4: [source r] orientation: 'euler' is not one of", NULL);
	expect_text_err(*state, "[source c]\ntype = can\n", "e.conf:2: [source c] interface: missing", NULL);
	expect_text_err(*state, "[source c]\ntype = can\ninterface = a_name_longer_than_31_characters\n",
			"e.conf:3: [source c] interface: longer than 31 characters", NULL);
	expect_text_err(*state, "[source c]\ntype = can\ninterface = can0\nposition_id = -2\n",
			"e.conf:4: [source c] position_id: -2 is out of range", NULL);
	expect_text_err(*state, "[source c]\ntype = can\ninterface = can0\npoll_rate = 5\n",
			"e.conf:4: [source c] poll_rate: unknown key for type can", NULL);
}

static void test_err_syntax(void **state)
{
	expect_text_err(*state, "[daemon]\nrate = 100\nlog_level debug\n",
			"e.conf:3: syntax error: expected [section], key = value, or a comment", NULL);
	/* an unclosed '[' after a section: its keys would land in the previous one */
	expect_text_err(*state, "[daemon]\nrate = 100\n\n[source s\ntype = sim\n", "e.conf:4: syntax error", NULL);
}

static void test_err_long_line(void **state)
{
	char text[INI_MAX_LINE + 200], want[64];
	size_t n = 0;

	n += (size_t)snprintf(text + n, sizeof(text) - n, "[daemon]\nrate = 100\n;");
	memset(text + n, 'x', INI_MAX_LINE + 100);
	n += INI_MAX_LINE + 100;
	snprintf(text + n, sizeof(text) - n, "\nmode = events\n");
	snprintf(want, sizeof(want), "e.conf:3: line longer than %d characters", INI_MAX_LINE - 2);
	expect_text_err(*state, text, want, NULL);
}

static void test_err_nul_byte(void **state)
{
	struct fx *f = *state;
	static const char bytes[] = "[daemon]\nrate = 1\0\n";

	put_bytes(f, "nul.conf", bytes, sizeof(bytes) - 1);
	expect_file_err(f, "nul.conf", "", "/nul.conf: not a text file (NUL byte)", NULL);
}

static void test_err_missing_file(void **state)
{
	expect_file_err(*state, "absent.conf", "", "/absent.conf: No such file or directory", NULL);
}

/* ---- drop-ins -------------------------------------------------------------------------------- */

static void put_dropin_tree(struct fx *f)
{
	put(f, "main.conf",
	    "[daemon]\n"
	    "rate = 100\n"
	    "stale_ms = 50\n"
	    "log_level = warning\n"
	    "[source sim]\ntype = sim\npeople = 2\n"
	    "[avatar a]\nperson = sim/p0\n");
	/* created neither in the order of their names nor in its reverse: only sorting gets it right */
	put(f, "conf.d/20-b.conf",
	    "[daemon]\n"
	    "rate = 300\n"
	    "[output o]\ntype = udp\nport = 7000\n");
	put(f, "conf.d/10-a.conf",
	    "[daemon]\n"
	    "rate = 200\n"
	    "stale_ms = 60\n");
	put(f, "conf.d/30-c.conf",
	    "[daemon]\n"
	    "describe_interval = 2\n");
	/* not *.conf, or hidden: ignored (they would not parse) */
	put(f, "conf.d/README", "this is not = a [configuration\n");
	put(f, "conf.d/30-c.conf.disabled", "[daemon]\nrate = fast\n");
	put(f, "conf.d/.40-hidden.conf", "[daemon]\nrate = fast\n");
	put(f, "conf.d/notes.txt", "rate = 1\n");
}

static void test_dropins_later_wins(void **state)
{
	struct fx *f = *state;
	char want[512];
	const struct config *c;
	const char *p;

	put_dropin_tree(f);
	c = load_file_ok(f, "main.conf");
	assert_int_equal(c->n_files, 4);
	assert_true(strstr(c->files[0], "/main.conf") != NULL);
	assert_true(strstr(c->files[1], "/conf.d/10-a.conf") != NULL);
	assert_true(strstr(c->files[2], "/conf.d/20-b.conf") != NULL);
	assert_true(strstr(c->files[3], "/conf.d/30-c.conf") != NULL);
	assert_near(c->daemon.describe_interval, 2, 0);
	assert_near(c->daemon.rate, 300, 0);			/* 20-b over 10-a over main */
	assert_near(c->daemon.stale_ms, 60, 0);			/* 10-a over main */
	assert_int_equal(c->daemon.log_level, CFG_LOG_WARNING); /* main only */
	assert_int_equal(c->n_outputs, 1);			/* a drop-in adds a section */
	assert_int_equal(((const struct udp_opts *)(c->output[0]).opt)->port, 7000);

	p = print_config(f);
	snprintf(want, sizeof(want),
		 "; effective configuration, from: %s/main.conf %s/conf.d/10-a.conf %s/conf.d/20-b.conf "
		 "%s/conf.d/30-c.conf\n",
		 f->dir, f->dir, f->dir, f->dir);
	assert_has(p, want);
	snprintf(want, sizeof(want), "\nrate = 300    ; %s/conf.d/20-b.conf:2\n", f->dir);
	assert_has(p, want);
	snprintf(want, sizeof(want), "\nstale_ms = 60    ; %s/conf.d/10-a.conf:3\n", f->dir);
	assert_has(p, want);
	snprintf(want, sizeof(want), "\nlog_level = warning    ; %s/main.conf:4\n", f->dir);
	assert_has(p, want);
	snprintf(want, sizeof(want), "\nport = 7000    ; %s/conf.d/20-b.conf:5\n", f->dir);
	assert_has(p, want);
	assert_has(p, "\nmode = deadline    ; default\n");
}

static void test_dropin_error_location(void **state)
{
	struct fx *f = *state;

	put_dropin_tree(f);
	put(f, "conf.d/20-b.conf", "[daemon]\nmode = events\nrate = 0\n");
	expect_file_err(f, "main.conf", "%s/conf.d/20-b.conf:3: [daemon] rate: 0 is out of range", NULL);
	put(f, "conf.d/20-b.conf", "[daemon]\nmode = events\nbogus = 1\n");
	expect_file_err(f, "main.conf", "%s/conf.d/20-b.conf:3: [daemon] bogus: unknown key", NULL);
}

/* ---- --set ------------------------------------------------------------------------------------ */

static void test_set_overrides(void **state)
{
	struct fx *f = *state;
	const char *sets[] = { "daemon.rate=500", "output o.port=7771", "source sim.people=3", "avatar a.person=sim/p2",
			       "output extra.type=tcp" };
	char path[512];
	const struct config *c = &f->c;
	const char *p;

	put_dropin_tree(f);
	if (config_load_ex(&f->c, at(f, "main.conf", path, sizeof(path)), sets, 5, f->err, sizeof(f->err)))
		fail_msg("%s", f->err);
	assert_near(c->daemon.rate, 500, 0); /* over main and both drop-ins */
	assert_near(c->daemon.stale_ms, 60, 0);
	assert_int_equal(((const struct udp_opts *)(c->output[0]).opt)->port, 7771);
	assert_int_equal(((const struct sim_opts *)(c->source[0]).opt)->people, 3);
	for (int r = 0; r < 3; r++)
		assert_sensor(&c->avatar[0], r, 0, 6 + r);
	assert_int_equal(c->n_outputs, 2);
	assert_string_equal(c->output[1].name, "extra");
	assert_int_equal(c->output[1].type, cfg_output_type_find("tcp"));
	p = print_config(f);
	assert_has(p, "\nrate = 500    ; --set:2\n");
	assert_has(p, "\nport = 7771    ; --set:2\n");
}

static void test_set_malformed(void **state)
{
	struct fx *f = *state;
	static const char *const bad[] = { "daemon", "daemon=5", "rate", ".rate=5", "daemon.=5", "daemon.rate" };
	char path[512], want[128];

	put(f, "main.conf", "[source s]\ntype = sim\n");
	at(f, "main.conf", path, sizeof(path));
	for (size_t i = 0; i < sizeof(bad) / sizeof(bad[0]); i++) {
		const char *sets[] = { "daemon.rate=100", bad[i] };

		if (!config_load_ex(&f->c, path, sets, 2, f->err, sizeof(f->err)))
			fail_msg("--set %s accepted", bad[i]);
		snprintf(want, sizeof(want), "(command line): --set %s: expected SECTION.KEY=VALUE", bad[i]);
		assert_string_equal(f->err, want);
		config_free(&f->c);
	}
	/* well formed, but a wrong value or key: reported like a file's */
	{
		const char *sets[] = { "daemon.rate=0" };

		assert_int_equal(config_load_ex(&f->c, path, sets, 1, f->err, sizeof(f->err)), -1);
		assert_string_equal(f->err, "--set:2: [daemon] rate: 0 is out of range [1, 4000] Hz");
		config_free(&f->c);
	}
	{
		const char *sets[] = { "source s.colour=red" };

		assert_int_equal(config_load_ex(&f->c, path, sets, 1, f->err, sizeof(f->err)), -1);
		assert_has(f->err, "--set:2: [source s] colour: unknown key for type sim");
	}
}

static void test_builtin_demo(void **state)
{
	struct fx *f = *state;
	const struct config *c = &f->c;
	int clip;

	if (config_load_ex(&f->c, "builtin:demo.conf", NULL, 0, f->err, sizeof(f->err)))
		fail_msg("%s", f->err);
	assert_int_equal(c->n_files, 1);
	assert_string_equal(c->files[0], "builtin:demo.conf");
	clip = source_index(c, "clip");
	assert_int_equal(c->source[clip].driver, cfg_source_type_find("replay"));
	assert_string_equal(((const struct replay_opts *)(c->source[clip]).opt)->file,
			    "builtin:cmu_141_16.csv"); /* not made relative */
	assert_true(c->n_avatars >= 1);
	/* make run shows the browser viewer: the demo has one, on this host only */
	{
		int v = -1;

		for (int i = 0; i < c->n_outputs; i++)
			if (c->output[i].type == cfg_output_type_find("websocket"))
				v = i;
		assert_true(v >= 0);
		assert_string_equal(c->output[v].name, "viewer");
		assert_string_equal(((const struct websocket_opts *)(c->output[v]).opt)->address, "127.0.0.1");
		assert_int_equal(((const struct websocket_opts *)(c->output[v]).opt)->port, 7780);
	}
	config_free(&f->c);
	assert_int_equal(config_load_ex(&f->c, "builtin:nothing.conf", NULL, 0, f->err, sizeof(f->err)), -1);
	assert_has(f->err, "builtin:nothing.conf: no such builtin configuration");
}

/* ---- avatars: count, person, ids ------------------------------------------------------------- */

static void test_count_expansion(void **state)
{
	struct fx *f = *state;
	const struct config *c = load_text_ok(f, "[source sim]\ntype = sim\npeople = 5\n"
						 "[avatar crowd]\nperson = sim/p1\ncount = 3\nid = 10\nshoulder = 0.2\n"
						 "[avatar solo]\nperson = sim/p4\n"
						 "[output all]\ntype = udp\n"
						 "[output some]\ntype = udp\navatars = crowd\n"
						 "[output pick]\ntype = udp\navatars = solo crowd-1 crowd-1\n");

	assert_int_equal(c->n_avatars, 4);
	for (int k = 0; k < 3; k++) {
		const struct cfg_avatar *a = &c->avatar[k];
		char name[32];

		snprintf(name, sizeof(name), "crowd-%d", k);
		assert_string_equal(a->name, name);
		assert_int_equal(a->id, 10 + k);
		for (int r = 0; r < 3; r++)
			assert_sensor(a, r, 0, (1 + k) * 3 + r); /* p1, p2, p3 */
		assert_near(a->dims[0], 0.2, 0);
	}
	assert_string_equal(c->avatar[3].name, "solo");
	assert_int_equal(c->avatar[3].id, 13); /* auto: after the last of the crowd */
	assert_sensor(&c->avatar[3], 0, 0, 12);
	assert_int_equal(c->output[0].n_avatars, 0);
	assert_int_equal(c->output[1].n_avatars, 3);
	for (int k = 0; k < 3; k++)
		assert_int_equal(c->output[1].avatar_ids[k], 10 + k);
	assert_int_equal(c->output[2].n_avatars, 2); /* a name given twice counts once */
	assert_int_equal(c->output[2].avatar_ids[0], 13);
	assert_int_equal(c->output[2].avatar_ids[1], 11);
}

static void test_count_errors(void **state)
{
	expect_text_err(*state, "[source sim]\ntype = sim\npeople = 2\n[avatar c]\nperson = sim/p1\ncount = 2\n",
			"e.conf:5: [avatar c] person: source 'sim' has no sensor 'p2.head'", NULL);
	expect_text_err(*state,
			"[source r]\ntype = replay\nfile = builtin:cmu_141_16.csv\n[avatar c]\nperson = r\ncount = 2\n",
			"e.conf:5: [avatar c] person: count = 2 needs a numbered person (SOURCE/p0)", NULL);
	expect_text_err(*state, "[source sim]\ntype = sim\n[avatar c]\nhead = sim/p0.head\ncount = 2\n",
			"e.conf:5: [avatar c] count: needs person = SOURCE/p0", NULL);
	expect_text_err(*state, "[source sim]\ntype = sim\n[avatar c]\nperson = sim/p0\ncount = 0\n",
			"e.conf:5: [avatar c] count: '0' is not a whole number in [1, 4096]", NULL);
	expect_text_err(*state,
			"[source sim]\ntype = sim\npeople = 3\n[avatar c]\nperson = sim/p0\ncount = 3\nid = 65534\n",
			"e.conf:7: [avatar c] id: '65534' is not a whole number in [0, 65533]", NULL);
}

static void test_person_replay(void **state)
{
	struct fx *f = *state;
	const struct config *c = load_text_ok(f, "[source sim]\ntype = sim\npeople = 2\n"
						 "[source clip]\ntype = replay\nfile = builtin:cmu_141_16.csv\n"
						 "[avatar a]\nperson = clip\n"
						 "[avatar b]\nperson = clip\nright_hand = sim/p1.right_hand\n");
	int clip = source_index(c, "clip"), sim = source_index(c, "sim");

	for (int r = 0; r < 3; r++)
		assert_sensor(&c->avatar[0], r, clip, r); /* clip/head, clip/left_hand, clip/right_hand */
	assert_sensor(&c->avatar[1], 0, clip, 0);
	assert_sensor(&c->avatar[1], 1, clip, 1);
	assert_sensor(&c->avatar[1], 2, sim, 5); /* the single key wins over person */
	assert_int_equal(c->avatar[1].sensor[2].where.line, 11);
	assert_int_equal(c->avatar[1].sensor[1].where.line, 10);
}

static void test_auto_ids(void **state)
{
	struct fx *f = *state;
	const struct config *c = load_text_ok(f, "[source s]\ntype = sim\npeople = 3\n"
						 "[avatar a]\nperson = s/p0\n"
						 "[avatar b]\nperson = s/p1\nid = 5\n"
						 "[avatar c]\nperson = s/p2\n");

	assert_int_equal(c->avatar[0].id, 0);
	assert_int_equal(c->avatar[1].id, 5);
	assert_int_equal(c->avatar[2].id, 6);
}

/* ---- relative paths ----------------------------------------------------------------------------- */

static void test_relative_replay_path(void **state)
{
	struct fx *f = *state;
	char want[512];
	const struct config *c;

	put_csv(f, "clips/tiny.csv", NULL, 4);
	put(f, "main.conf", "[source clip]\ntype = replay\nfile = clips/tiny.csv\n[avatar a]\nperson = clip\n");
	/* a drop-in's relative path is taken from its own directory */
	put(f, "conf.d/10-more.conf", "[source more]\ntype = replay\nfile = ../clips/tiny.csv\n");
	snprintf(want, sizeof(want), "[source abs]\ntype = replay\nfile = %s/clips/tiny.csv\n", f->dir);
	put(f, "conf.d/20-abs.conf", want);
	c = load_file_ok(f, "main.conf");
	assert_int_equal(c->n_sources, 3);
	snprintf(want, sizeof(want), "%s/clips/tiny.csv", f->dir);
	assert_string_equal(((const struct replay_opts *)(c->source[source_index(c, "clip")]).opt)->file, want);
	assert_string_equal(((const struct replay_opts *)(c->source[source_index(c, "abs")]).opt)->file, want);
	snprintf(want, sizeof(want), "%s/conf.d/../clips/tiny.csv", f->dir);
	assert_string_equal(((const struct replay_opts *)(c->source[source_index(c, "more")]).opt)->file, want);
}

/* the copy of the demo clip, relative, also works: the real file is read and checked */
static void test_relative_path_real_clip(void **state)
{
	struct fx *f = *state;
	char src[PATH_MAX], *clip;
	const struct config *c;

	repo_path("config/clips/cmu_141_16.csv", src, sizeof(src));
	clip = slurp(src);
	put(f, "sub/dir/clip.csv", clip);
	free(clip);
	put(f, "sub/main.conf", "[source clip]\ntype = replay\nfile = dir/clip.csv\n[avatar a]\nperson = clip\n");
	c = load_file_ok(f, "sub/main.conf");
	assert_true(strstr(((const struct replay_opts *)(c->source[0]).opt)->file, "/sub/dir/clip.csv") != NULL);
	assert_int_equal(((const struct replay_opts *)(c->source[0]).opt)->file[0], '/');
}

/* ---- the daemon ---------------------------------------------------------------------------------- */

static void test_daemon_check_good(void **state)
{
	struct fx *f = *state;
	char path[512], want[600];

	put(f, "good.conf", "[source s]\ntype = sim\n[avatar a]\nperson = s/p0\n[output o]\ntype = udp\n");
	run_daemon(f, "--check-config", "-c", at(f, "good.conf", path, sizeof(path)), NULL);
	assert_int_equal(f->rc, 0);
	snprintf(want, sizeof(want), "; effective configuration, from: %s\n", path);
	assert_int_equal(strncmp(f->out, want, strlen(want)), 0);
	assert_has(f->out, "\n[daemon]\nrate = 240    ; default\n");
	snprintf(want, sizeof(want), "\nhead = s/p0.head    ; %s:4\n", path);
	assert_has(f->out, want);
	assert_has(f->out, "\n[output o]\n");
	assert_string_equal(f->errout, "");
}

static void test_daemon_check_bad(void **state)
{
	struct fx *f = *state;
	char path[512], want[600];

	put(f, "bad.conf", "[source s]\ntype = sim\nspacing = far\n");
	run_daemon(f, "-c", at(f, "bad.conf", path, sizeof(path)), "--check-config", NULL);
	assert_int_equal(f->rc, 78);
	snprintf(want, sizeof(want), "avatargw: configuration error: %s:3: [source s] spacing: 'far' is not a number\n",
		 path);
	assert_string_equal(f->errout, want);
	assert_string_equal(f->out, "");
}

static void test_daemon_missing_file(void **state)
{
	struct fx *f = *state;
	char path[512];

	run_daemon(f, "-c", at(f, "absent.conf", path, sizeof(path)), "--check-config", NULL);
	assert_int_equal(f->rc, 78);
	assert_has(f->errout, "avatargw: configuration error: ");
	assert_has(f->errout, path);
	assert_has(f->errout, "No such file or directory");
	assert_string_equal(f->out, "");
}

static void test_daemon_set(void **state)
{
	struct fx *f = *state;
	char path[512];

	put(f, "good.conf", "[source s]\ntype = sim\n[avatar a]\nperson = s/p0\n");
	at(f, "good.conf", path, sizeof(path));
	run_daemon(f, "-c", path, "--set", "daemon.rate=480", "-s", "source s.people=2", "--check-config", NULL);
	assert_int_equal(f->rc, 0);
	assert_has(f->out, "\nrate = 480    ; --set:2\n");
	assert_has(f->out, "\npeople = 2    ; --set:2\n");
	run_daemon(f, "-c", path, "--set", "rate=480", "--check-config", NULL);
	assert_int_equal(f->rc, 78);
	assert_string_equal(
		f->errout,
		"avatargw: configuration error: (command line): --set rate=480: expected SECTION.KEY=VALUE\n");
}

static void test_daemon_shipped_config(void **state)
{
	struct fx *f = *state;
	char path[PATH_MAX];

	repo_path("config/avatargw.conf", path, sizeof(path));
	run_daemon(f, "-c", path, "--check-config", NULL);
	if (f->rc != 0)
		fail_msg("%s --check-config: exit %d: %s", path, f->rc, f->errout);
	assert_has(f->out, "\n[source sim]\n");
	assert_has(f->out, "\nhead = sim/p0.head    ; ");
	assert_has(f->out, "\nport = 7770    ; ");
}

/* ---- regressions: behaviour config.c gets wrong as of this writing ------------------------------- */

/* a key given twice in a drop-in is an error even when an earlier file has it too */
static void test_dropin_key_twice(void **state)
{
	struct fx *f = *state;

	put(f, "main.conf", "[daemon]\nrate = 100\n[source s]\ntype = sim\n");
	put(f, "conf.d/10-a.conf", "[daemon]\nrate = 200\nrate = 300\n");
	expect_file_err(f, "main.conf", "%s/conf.d/10-a.conf:3: [daemon] rate: given twice in one file (first at ",
			"10-a.conf:2)", NULL);
}

/* control_socket = auto is a word (ctl_resolve_path picks the directory), not a path beside the file */
static void test_control_socket_auto(void **state)
{
	struct fx *f = *state;

	put(f, "main.conf", "[daemon]\ncontrol_socket = auto\n[source s]\ntype = sim\n");
	assert_string_equal(load_file_ok(f, "main.conf")->daemon.control_socket, "auto");
}

/* config_print says where a counted avatar's values came from */
static void test_print_counted_avatar_origin(void **state)
{
	struct fx *f = *state;
	load_text_ok(f,
		     "[source s]\ntype = sim\npeople = 2\n[avatar crowd]\nperson = s/p0\ncount = 2\nshoulder = 0.2\n");
	assert_has(print_config(f), "\n[avatar crowd-1]\nshoulder = 0.2    ; e.conf:7\n");
}

/* a line of INI_MAX_LINE - 2 characters fits (the message says "longer than" that); one more does not */
static void test_line_of_max_length(void **state)
{
	struct fx *f = *state;
	char text[INI_MAX_LINE + 64];
	size_t n;

	for (int extra = 0; extra < 2; extra++) {
		n = (size_t)snprintf(text, sizeof(text), "[daemon]\n;");
		memset(text + n, 'x', INI_MAX_LINE - 3 + extra);
		n += INI_MAX_LINE - 3 + extra;
		snprintf(text + n, sizeof(text) - n, "\n[source s]\ntype = sim\n");
		set_ctx("a line of %d characters", INI_MAX_LINE - 2 + extra);
		if (!extra) {
			load_text_ok(f, text);
			config_free(&f->c);
		} else {
			expect_text_err(f, text, "e.conf:2: line longer than", NULL);
		}
	}
}

/* the first error in the file is the one reported, syntax errors included */
static void test_first_error_reported(void **state)
{
	expect_text_err(*state, "[daemon\nrate = 100\n", "e.conf:1: syntax error", NULL);
	expect_text_err(*state, "[daemon]\nrate 100\nrate = 1\nrate = 2\n", "e.conf:2: syntax error", NULL);
}

/* the renderer outputs: their keys, and defaults that differ by type */
static void test_values_renderer_outputs(void **state)
{
	struct fx *f = *state;
	const struct config *c =
		load_text_ok(f, "[source s]\ntype = sim\npeople = 2\n"
				"[avatar a]\nperson = s/p0\n"
				"[avatar b]\nperson = s/p1\n"
				"[output v]\ntype = vrpn\n"
				"[output v2]\ntype = vrpn\naddress = ::\nport = 3884\ndevice = Body%d\nudp = no\n"
				"client_timeout = 0.5\nmax_clients = 2\nclient_buffer = 4096\n"
				"[output m]\ntype = vmc\navatars = b\n"
				"[output m2]\ntype = vmc\naddress = 10.0.0.2\nport = 39540\nrate = 120\n"
				"torso = 0.45\navatars = a\n"
				"[output r]\ntype = vrchat\navatars = a\nhead = no\nrate = 240\n"
				"[output w]\ntype = websocket\n"
				"[output w2]\ntype = websocket\naddress = 0.0.0.0\nport = 8080\nrate = 60\n"
				"www = /srv/www\nthree = /opt/three\n");
	const struct cfg_output *o = c->output;

	assert_int_equal(c->n_outputs, 7);
	assert_int_equal(o[0].type, cfg_output_type_find("vrpn"));
	/* vrpn listens on this host only by default */
	assert_string_equal(((const struct vrpn_opts *)(o[0]).opt)->address, "127.0.0.1");
	assert_int_equal(((const struct vrpn_opts *)(o[0]).opt)->port, 3883);
	assert_string_equal(((const struct vrpn_opts *)(o[0]).opt)->device, "Avatar%d");
	assert_true(((const struct vrpn_opts *)(o[0]).opt)->udp);
	assert_true(((const struct vrpn_opts *)(o[0]).opt)->client_timeout == 5);
	assert_int_equal(((const struct vrpn_opts *)(o[0]).opt)->max_clients, 8);
	assert_int_equal(((const struct vrpn_opts *)(o[0]).opt)->client_buffer, 65536);
	assert_string_equal(((const struct vrpn_opts *)(o[1]).opt)->address, "::");
	assert_int_equal(((const struct vrpn_opts *)(o[1]).opt)->port, 3884);
	assert_string_equal(((const struct vrpn_opts *)(o[1]).opt)->device, "Body%d");
	assert_false(((const struct vrpn_opts *)(o[1]).opt)->udp);
	assert_true(((const struct vrpn_opts *)(o[1]).opt)->client_timeout == 0.5);
	assert_int_equal(((const struct vrpn_opts *)(o[1]).opt)->max_clients, 2);
	assert_int_equal(((const struct vrpn_opts *)(o[1]).opt)->client_buffer, 4096);

	assert_int_equal(o[2].type, cfg_output_type_find("vmc"));
	assert_string_equal(((const struct osc_opts *)(o[2]).opt)->address, "127.0.0.1");
	assert_int_equal(((const struct osc_opts *)(o[2]).opt)->port, 39539);
	assert_true(((const struct osc_opts *)(o[2]).opt)->rate == 60);
	assert_true(((const struct osc_opts *)(o[2]).opt)->torso == 0.5);
	assert_int_equal(o[2].n_avatars, 1);
	assert_int_equal(o[2].avatar_ids[0], 1);
	assert_string_equal(((const struct osc_opts *)(o[3]).opt)->address, "10.0.0.2");
	assert_int_equal(((const struct osc_opts *)(o[3]).opt)->port, 39540);
	assert_true(((const struct osc_opts *)(o[3]).opt)->rate == 120);
	assert_true(((const struct osc_opts *)(o[3]).opt)->torso == 0.45);

	assert_int_equal(o[4].type, cfg_output_type_find("vrchat"));
	assert_int_equal(((const struct osc_opts *)(o[4]).opt)->port, 9000);
	assert_false(((const struct osc_opts *)(o[4]).opt)->head);
	assert_true(((const struct osc_opts *)(o[4]).opt)->rate == 240);

	assert_int_equal(o[5].type, cfg_output_type_find("websocket"));
	assert_string_equal(((const struct websocket_opts *)(o[5]).opt)->address, "127.0.0.1");
	assert_int_equal(((const struct websocket_opts *)(o[5]).opt)->port, 7780);
	assert_true(((const struct websocket_opts *)(o[5]).opt)->rate == 30);
	assert_string_equal(((const struct websocket_opts *)(o[5]).opt)->www, "auto");
	assert_string_equal(((const struct websocket_opts *)(o[5]).opt)->three, "/usr/share/javascript/three");
	assert_string_equal(((const struct websocket_opts *)(o[6]).opt)->address, "0.0.0.0");
	assert_int_equal(((const struct websocket_opts *)(o[6]).opt)->port, 8080);
	assert_true(((const struct websocket_opts *)(o[6]).opt)->rate == 60);
	assert_string_equal(((const struct websocket_opts *)(o[6]).opt)->www, "/srv/www");
	assert_string_equal(((const struct websocket_opts *)(o[6]).opt)->three, "/opt/three");
}

static void test_err_renderer_outputs(void **state)
{
	/* keys of one renderer are unknown to the others */
	expect_text_err(*state, "[output o]\ntype = tcp\ndevice = X%d\n",
			"e.conf:3: [output o] device: unknown key for type tcp", NULL);
	expect_text_err(*state, "[output o]\ntype = vrpn\nrate = 30\n",
			"e.conf:3: [output o] rate: unknown key for type vrpn",
			"(known: type, decimate, avatars, address, port, max_clients, clients_per_address, "
			"client_buffer, device, udp, "
			"client_timeout)",
			NULL);
	expect_text_err(*state, "[output o]\ntype = websocket\nclient_buffer = 4096\n",
			"e.conf:3: [output o] client_buffer: unknown key for type websocket", NULL);
	/* one key, two ranges: a browser gets at most 60 frames a second, an OSC peer 240 */
	expect_text_err(*state, "[output o]\ntype = websocket\nrate = 61\n",
			"e.conf:3: [output o] rate: 61 is out of range [1, 60] Hz", NULL);
	expect_text_err(*state, "[output o]\ntype = vrchat\nrate = 241\n",
			"e.conf:3: [output o] rate: 241 is out of range [1, 240] Hz", NULL);
	expect_text_err(*state, "[output o]\ntype = vrpn\nclient_timeout = 0\n",
			"e.conf:3: [output o] client_timeout: 0 is out of range", NULL);
	/* VMC and VRChat carry one avatar */
	expect_text_err(*state,
			"[source s]\ntype = sim\npeople = 2\n[avatar a]\nperson = s/p0\ncount = 2\n"
			"[output o]\ntype = vmc\n",
			"e.conf:8: [output o] avatars: a vmc output carries one avatar, not 2 (avatars = NAME)", NULL);
	expect_text_err(*state,
			"[source s]\ntype = sim\npeople = 2\n[avatar a]\nperson = s/p0\ncount = 2\n"
			"[output o]\ntype = vrchat\navatars = a\n",
			"e.conf:9: [output o] avatars: a vrchat output carries one avatar, not 2", NULL);
	expect_text_err(*state, "[output o]\ntype = osc\n",
			"e.conf:2: [output o] type: 'osc' is not one of: udp, multicast, tcp, unix, modbus, can, vrpn, "
			"vmc, vrchat, websocket",
			NULL);
}

int main(void)
{
#define T(fn) cmocka_unit_test_setup_teardown(fn, setup, teardown)
	const struct CMUnitTest tests[] = {
		T(test_values_daemon),
		T(test_values_record),
		T(test_err_record),
		T(test_values_replay_modes),
		T(test_replay_recording),
		T(test_values_sim_source),
		T(test_values_hardware_sources),
		T(test_err_hardware_sources),
		T(test_values_avatar),
		T(test_values_outputs),
		T(test_defaults),
		T(test_bool_spellings),
		T(test_shipped_config),
		T(test_err_unknown_key),
		T(test_err_key_of_other_type),
		T(test_err_unknown_section),
		T(test_err_key_outside_section),
		T(test_err_key_twice),
		T(test_busy_wait),
		T(test_err_out_of_range),
		T(test_err_not_a_number),
		T(test_err_not_whole),
		T(test_err_bad_bool),
		T(test_err_bad_enum),
		T(test_err_vec3),
		T(test_err_range),
		T(test_err_source_type),
		T(test_err_replay_file),
		T(test_err_sensor_reference),
		T(test_err_avatar_without_sensors),
		T(test_err_duplicate_avatar_id),
		T(test_err_output_unknown_avatar),
		T(test_err_multicast_without_address),
		T(test_values_bus),
		T(test_defaults_bus),
		T(test_err_bus),
		T(test_err_syntax),
		T(test_err_long_line),
		T(test_err_nul_byte),
		T(test_err_missing_file),
		T(test_dropins_later_wins),
		T(test_dropin_error_location),
		T(test_set_overrides),
		T(test_set_malformed),
		T(test_builtin_demo),
		T(test_count_expansion),
		T(test_count_errors),
		T(test_person_replay),
		T(test_auto_ids),
		T(test_relative_replay_path),
		T(test_relative_path_real_clip),
		T(test_daemon_check_good),
		T(test_daemon_check_bad),
		T(test_daemon_missing_file),
		T(test_daemon_set),
		T(test_daemon_shipped_config),
		T(test_dropin_key_twice),
		T(test_control_socket_auto),
		T(test_print_counted_avatar_origin),
		T(test_line_of_max_length),
		T(test_first_error_reported),
		T(test_values_renderer_outputs),
		T(test_err_renderer_outputs),
	};
#undef T

	return cmocka_run_group_tests(tests, NULL, NULL);
}
