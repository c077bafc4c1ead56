// SPDX-License-Identifier: MIT
/*
 * config.c - reads INI files with inih into a list of entries, then checks
 * every entry against one typed table of keys.
 *
 * Two passes because drop-ins override key by key: first every file is read
 * (a key given twice in one file is an error, a later file replaces an
 * earlier file's value), then each section is built from its entries in a
 * fixed order (daemon, sources, avatars, outputs: later ones refer to
 * earlier ones). The Debian build of inih does not pass line numbers to the
 * handler, so the line reader counts them.
 */
#include "config/config.h"

#include "config/builtin.h"

#include <ini.h>

#include <ctype.h>
#include <dirent.h>
#include <errno.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#define DEG (M_PI / 180.0)

const char *const cfg_sensor_roles[3] = { "head", "left_hand", "right_hand" };

/* built in this order: [site] after the avatars (their ids), before the outputs (which carry its avatars too) */
enum sect { S_DAEMON, S_SOURCE, S_AVATAR, S_SITE, S_OUTPUT, S_COUNT };
static const char *const sect_names[S_COUNT] = { "daemon", "source", "avatar", "site", "output" };

static const char *const e_mode[] = { "deadline", "events", NULL };
static const char *const e_log[] = { "err", "warning", "info", "debug", NULL };
static const char *const e_solver[] = { "dq", "matrix", NULL };
const char *const cfg_word_orders[] = { "abcd", "cdab", "badc", "dcba", NULL };

/*
 * The keys every section of a kind has; a source's and an output's type
 * adds its own (struct cfg_type). "type" is read first: it decides which
 * keys exist.
 */
static const struct cfg_key daemon_keys[] = {
	{ .name = "rate",
	  .kind = CFG_DOUBLE,
	  CFG_AT(struct cfg_daemon, rate),
	  .min = 1,
	  .max = 4000,
	  .def = "240",
	  .unit = "Hz",
	  .doc = "avatars solved and published per second (deadline mode)" },
	{ .name = "mode",
	  .kind = CFG_ENUM,
	  CFG_AT(struct cfg_daemon, mode),
	  .def = "deadline",
	  .enums = e_mode,
	  .doc = "deadline: a cycle at every period, to absolute deadlines; events: a cycle when a source has new "
		 "samples" },
	{ .name = "stale_ms",
	  .kind = CFG_DOUBLE,
	  CFG_AT(struct cfg_daemon, stale_ms),
	  .min = 1,
	  .max = 60000,
	  .def = "100",
	  .unit = "ms",
	  .doc = "a sensor without a new sample for this long is STALE" },
	{ .name = "realtime_priority",
	  .kind = CFG_INT,
	  CFG_AT(struct cfg_daemon, realtime_priority),
	  .min = 0,
	  .max = 99,
	  .def = "0",
	  .doc = "SCHED_FIFO priority of the loop thread, 0 = normal scheduling" },
	{ .name = "cpu",
	  .kind = CFG_INT,
	  CFG_AT(struct cfg_daemon, cpu),
	  .min = -1,
	  .max = 1023,
	  .def = "-1",
	  .doc = "pin the loop thread to this CPU, -1 = no pinning" },
	{ .name = "busy_wait",
	  .kind = CFG_BOOL,
	  CFG_AT(struct cfg_daemon, busy_wait),
	  .def = "no",
	  .doc = "the loop spins to each deadline instead of sleeping: a whole CPU for the lowest latency "
		 "(deadline mode)" },
	{ .name = "lock_memory",
	  .kind = CFG_BOOL,
	  CFG_AT(struct cfg_daemon, lock_memory),
	  .def = "yes",
	  .doc = "mlockall() at start-up so that the loop never page-faults" },
	{ .name = "control_socket",
	  .kind = CFG_PATH,
	  CFG_AT(struct cfg_daemon, control_socket),
	  .def = "auto",
	  .doc = "Unix socket of avatargw-ctl; auto = $RUNTIME_DIRECTORY/control, else "
		 "$XDG_RUNTIME_DIR/avatargw.control, else $TMPDIR/avatargw-UID/control (a directory made with mode "
		 "0700); empty = none" },
	{ .name = "describe_interval",
	  .kind = CFG_DOUBLE,
	  CFG_AT(struct cfg_daemon, describe_interval),
	  .min = 0.1,
	  .max = 3600,
	  .def = "1",
	  .unit = "s",
	  .doc = "period of the DESCRIBE messages (also sent when an avatar's description changes)" },
	{ .name = "log_level",
	  .kind = CFG_ENUM,
	  CFG_AT(struct cfg_daemon, log_level),
	  .def = "info",
	  .enums = e_log,
	  .doc = "least important messages logged" },
	{ .name = "record_dir",
	  .kind = CFG_PATH,
	  CFG_AT(struct cfg_daemon, record_dir),
	  .def = "",
	  .doc = "record every sensor sample into files in this directory (created if missing); empty = no "
		 "recording" },
	{ .name = "record_messages",
	  .kind = CFG_BOOL,
	  CFG_AT(struct cfg_daemon, record_messages),
	  .def = "no",
	  .doc = "also record every published message (FRAME and DESCRIBE)" },
	{ .name = "record_flush",
	  .kind = CFG_DOUBLE,
	  CFG_AT(struct cfg_daemon, record_flush),
	  .min = 0,
	  .max = 3600,
	  .def = "1",
	  .unit = "s",
	  .doc = "write what was recorded at least this often: a crash or kill -9 loses at most this much" },
	{ .name = "record_flush_records",
	  .kind = CFG_INT,
	  CFG_AT(struct cfg_daemon, record_flush_records),
	  .min = 0,
	  .max = 100000,
	  .def = "0",
	  .doc = "also write after this many records, 0 = by time only" },
	{ .name = "record_fsync",
	  .kind = CFG_BOOL,
	  CFG_AT(struct cfg_daemon, record_fsync),
	  .def = "no",
	  .doc = "fdatasync after every write, so that a power loss loses no more than record_flush either" },
	{ .name = "record_rotate_size",
	  .kind = CFG_DOUBLE,
	  CFG_AT(struct cfg_daemon, record_rotate_size),
	  .min = 0,
	  .max = 100000,
	  .def = "0",
	  .unit = "MiB",
	  .doc = "start a new file when this one would grow past this size, 0 = never" },
	{ .name = "record_rotate_time",
	  .kind = CFG_DOUBLE,
	  CFG_AT(struct cfg_daemon, record_rotate_time),
	  .min = 0,
	  .max = 604800,
	  .def = "0",
	  .unit = "s",
	  .doc = "start a new file when this one is this old, 0 = never" },
	{ .name = "record_buffer",
	  .kind = CFG_INT,
	  CFG_AT(struct cfg_daemon, record_buffer),
	  .min = 64,
	  .max = 262144,
	  .def = "1024",
	  .unit = "KiB",
	  .doc = "buffer between the loop and the writer thread; a record that does not fit is dropped and "
		 "counted" },
	{ .name = "record_keyframe_rate",
	  .kind = CFG_DOUBLE,
	  CFG_AT(struct cfg_daemon, record_keyframe_rate),
	  .min = 0,
	  .max = 10000,
	  .def = "0",
	  .unit = "Hz",
	  .doc = "keep at most this many samples per second of each sensor (the paper's low-rate storage), 0 = "
		 "every sample" },
};

static const struct cfg_key source_keys[] = {
	{ .name = "type", .kind = CFG_STR, .doc = "the driver (below, each with its own keys)" },
	{ .name = "origin",
	  .kind = CFG_VEC3,
	  CFG_AT(struct cfg_source, origin),
	  .min = -1e4,
	  .max = 1e4,
	  .def = "0 0 0",
	  .unit = "m",
	  .doc = "position of the tracker's frame in the world (x y z)" },
	{ .name = "yaw",
	  .kind = CFG_DEG,
	  CFG_AT(struct cfg_source, yaw),
	  .min = -360,
	  .max = 360,
	  .def = "0",
	  .unit = "deg",
	  .doc = "rotation of the tracker's frame about the world's z axis" },
	{ .name = "max_distance",
	  .kind = CFG_DOUBLE,
	  CFG_AT(struct cfg_source, max_distance),
	  .min = 0.01,
	  .max = 1e6,
	  .def = "100",
	  .unit = "m",
	  .doc = "a sample farther than this from the world's origin, or whose orientation is not a unit quaternion, "
		 "is malformed: dropped and counted (the sensor keeps its last good sample and goes STALE)" },
	{ .name = "axes",
	  .kind = CFG_AXES,
	  CFG_AT(struct cfg_source, axes),
	  .def = "z-up",
	  .doc = "the tracker's axes: z-up (as the world's), y-up (x right, y up, z towards the viewer: most CAVE "
		 "and VRPN set-ups), the world directions of the tracker's x, y and z axes (y-up is x z -y), or a "
		 "rotation qw qx qy qz; applied before yaw and origin" },
	{ .name = "mount_SENSOR",
	  .kind = CFG_MOUNT,
	  .min = -10,
	  .max = 10,
	  .def = "0 0 0",
	  .unit = "m",
	  .doc = "SENSOR's tracked point in the sensor's own frame: x y z, optionally followed by a rotation qw "
		 "qx qy qz (a head sensor on glasses is not the head's centre); one key per sensor, also written "
		 "mount.SENSOR (mount.0 for channel 0 of a vrpn or dtrack source)" },
};

static const struct cfg_key avatar_keys[] = {
	{ .name = "id",
	  .kind = CFG_INT,
	  CFG_AT(struct cfg_avatar, id),
	  .min = 0,
	  .max = 65535,
	  .def = "auto",
	  .doc = "avatar id on the wire (auto: one more than the previous avatar's)" },
	{ .name = "count",
	  .kind = CFG_INT,
	  .min = 1,
	  .max = CFG_MAX_AVATARS,
	  .def = "1",
	  .doc = "this many avatars from consecutive people (person = SOURCE/p0 -> p0, p1, ...), ids counting up" },
	{ .name = "person",
	  .kind = CFG_PERSON,
	  .def = "",
	  .doc = "SOURCE or SOURCE/PREFIX: head, left_hand and right_hand are PREFIX.head, ... of that source" },
	{ .name = "head", .kind = CFG_SENSOR, .doc = "head sensor, SOURCE/SENSOR" },
	{ .name = "left_hand", .kind = CFG_SENSOR, .off = 1, .doc = "left hand sensor, SOURCE/SENSOR" },
	{ .name = "right_hand", .kind = CFG_SENSOR, .off = 2, .doc = "right hand sensor, SOURCE/SENSOR" },
	{ .name = "shoulder",
	  .kind = CFG_DOUBLE,
	  CFG_AT(struct cfg_avatar, dims[0]),
	  .min = 0.01,
	  .max = 1,
	  .def = "0.1732",
	  .unit = "m",
	  .doc = "chest centre to shoulder joint (the paper's Shoulder)" },
	{ .name = "upper_arm",
	  .kind = CFG_DOUBLE,
	  CFG_AT(struct cfg_avatar, dims[1]),
	  .min = 0.05,
	  .max = 1,
	  .def = "0.2886",
	  .unit = "m",
	  .doc = "shoulder to elbow" },
	{ .name = "forearm",
	  .kind = CFG_DOUBLE,
	  CFG_AT(struct cfg_avatar, dims[2]),
	  .min = 0.05,
	  .max = 1,
	  .def = "0.1955",
	  .unit = "m",
	  .doc = "elbow to wrist" },
	{ .name = "hand",
	  .kind = CFG_DOUBLE,
	  CFG_AT(struct cfg_avatar, dims[3]),
	  .min = 0,
	  .max = 0.5,
	  .def = "0",
	  .unit = "m",
	  .doc = "wrist to the hand sensor, along the hand" },
	{ .name = "head_offset",
	  .kind = CFG_VEC3,
	  CFG_AT(struct cfg_avatar, head_offset),
	  .min = -1,
	  .max = 1,
	  .def = "0.008 -0.0386 0.0967",
	  .unit = "m",
	  .doc = "head sensor from the chest centre, in the chest frame (x right, y forward, z up; the paper: 0 0 "
		 "Neck)" },
	{ .name = "rest_pronation",
	  .kind = CFG_DOUBLE,
	  CFG_AT(struct cfg_avatar, rest_pronation),
	  .min = -90,
	  .max = 90,
	  .def = "-30",
	  .unit = "deg",
	  .doc = "the forearm's pronation at rest (J6; negative turns the thumb inward) that the elbow's place "
		 "from the hand's orientation is centred on; people differ by tens of degrees (docs/FIDELITY.md)" },
	{ .name = "j1",
	  .kind = CFG_RANGE,
	  .off = offsetof(struct cfg_avatar, lo[0]),
	  .off2 = offsetof(struct cfg_avatar, hi[0]),
	  .min = -180,
	  .max = 180,
	  .def = "-30 30",
	  .unit = "deg",
	  .doc = "limits of J1, shoulder girdle / chest yaw" },
	{ .name = "j2",
	  .kind = CFG_RANGE,
	  .off = offsetof(struct cfg_avatar, lo[1]),
	  .off2 = offsetof(struct cfg_avatar, hi[1]),
	  .min = -180,
	  .max = 180,
	  .def = "-170 30",
	  .unit = "deg",
	  .doc = "limits of J2, shoulder abduction (-) / adduction (+)" },
	{ .name = "j3",
	  .kind = CFG_RANGE,
	  .off = offsetof(struct cfg_avatar, lo[2]),
	  .off2 = offsetof(struct cfg_avatar, hi[2]),
	  .min = -180,
	  .max = 180,
	  .def = "-60 120",
	  .unit = "deg",
	  .doc = "limits of J3, shoulder extension (-) / flexion (+)" },
	{ .name = "j4",
	  .kind = CFG_RANGE,
	  .off = offsetof(struct cfg_avatar, lo[3]),
	  .off2 = offsetof(struct cfg_avatar, hi[3]),
	  .min = -180,
	  .max = 180,
	  .def = "-90 90",
	  .unit = "deg",
	  .doc = "limits of J4, humeral rotation" },
	{ .name = "j5",
	  .kind = CFG_RANGE,
	  .off = offsetof(struct cfg_avatar, lo[4]),
	  .off2 = offsetof(struct cfg_avatar, hi[4]),
	  .min = -180,
	  .max = 180,
	  .def = "-90 60",
	  .unit = "deg",
	  .doc = "limits of J5, elbow (anatomical flexion = 90 deg + J5)" },
	{ .name = "j6",
	  .kind = CFG_RANGE,
	  .off = offsetof(struct cfg_avatar, lo[5]),
	  .off2 = offsetof(struct cfg_avatar, hi[5]),
	  .min = -180,
	  .max = 180,
	  .def = "-90 90",
	  .unit = "deg",
	  .doc = "limits of J6, forearm pronation / supination" },
	{ .name = "j7",
	  .kind = CFG_RANGE,
	  .off = offsetof(struct cfg_avatar, lo[6]),
	  .off2 = offsetof(struct cfg_avatar, hi[6]),
	  .min = -180,
	  .max = 180,
	  .def = "-30 30",
	  .unit = "deg",
	  .doc = "limits of J7, wrist deviation (about the hand's x axis, across the palm)" },
	{ .name = "j8",
	  .kind = CFG_RANGE,
	  .off = offsetof(struct cfg_avatar, lo[7]),
	  .off2 = offsetof(struct cfg_avatar, hi[7]),
	  .min = -180,
	  .max = 180,
	  .def = "-80 80",
	  .unit = "deg",
	  .doc = "limits of J8, wrist flexion (+) / extension (-) (about the hand's z axis, the thumb's)" },
	{ .name = "solver",
	  .kind = CFG_ENUM,
	  CFG_AT(struct cfg_avatar, solver),
	  .def = "dq",
	  .enums = e_solver,
	  .doc = "kinematics of the IK: dual quaternions or 4x4 matrices" },
	{ .name = "ik_max_iterations",
	  .kind = CFG_INT,
	  CFG_AT(struct cfg_avatar, max_iter),
	  .min = 1,
	  .max = 200,
	  .def = "20",
	  .doc = "Newton iterations at most per arm and frame" },
	{ .name = "ik_tolerance",
	  .kind = CFG_DOUBLE,
	  CFG_AT(struct cfg_avatar, tol_mm),
	  .min = 1e-4,
	  .max = 10,
	  .def = "0.01",
	  .unit = "mm",
	  .doc = "position error at which an arm counts as reached" },
	{ .name = "ik_tolerance_rot",
	  .kind = CFG_DOUBLE,
	  CFG_AT(struct cfg_avatar, tol_rot_deg),
	  .min = 1e-5,
	  .max = 10,
	  .def = "0.01",
	  .unit = "deg",
	  .doc = "hand orientation error at which an arm counts as reached" },
	{ .name = "ik_max_evals",
	  .kind = CFG_INT,
	  CFG_AT(struct cfg_avatar, max_evals),
	  .min = 16,
	  .max = 100000,
	  .def = "800",
	  .doc = "closed-form search: postures evaluated at most (bounds the worst-case time)" },
	{ .name = "ik_warm_iterations",
	  .kind = CFG_INT,
	  CFG_AT(struct cfg_avatar, warm_iter),
	  .min = 0,
	  .max = 100,
	  .def = "6",
	  .doc = "Newton iterations tried from the previous frame before the closed-form search" },
};

static const struct cfg_key output_keys[] = {
	{ .name = "type", .kind = CFG_STR, .doc = "the output type (below, each with its own keys)" },
	{ .name = "decimate",
	  .kind = CFG_INT,
	  CFG_AT(struct cfg_output, decimate),
	  .min = 1,
	  .max = 1000,
	  .def = "1",
	  .doc = "publish every n-th frame" },
	{ .name = "avatars",
	  .kind = CFG_LIST,
	  CFG_AT(struct cfg_output, avatar_list),
	  .def = "all",
	  .doc = "avatar names to publish (space separated), or all" },
};

/* [site] (docs/SITES.md): one section without a name, like [daemon] */
static const struct cfg_key site_keys[] = {
	{ .name = "name",
	  .kind = CFG_STR,
	  CFG_AT(struct cfg_site, name),
	  .def = NULL,
	  .missing = "this site's name, unique in the session",
	  .doc = "this site's name, unique in the session (1-31 of A-Z a-z 0-9 _ - .): the others see its avatars "
		 "as SITE/NAME" },
	{ .name = "session",
	  .kind = CFG_STR,
	  CFG_AT(struct cfg_site, session),
	  .def = "avatargw",
	  .doc = "only sites of the same session see each other (a DDS partition, at most 63 characters)" },
	{ .name = "domain",
	  .kind = CFG_INT,
	  CFG_AT(struct cfg_site, domain),
	  .min = 0,
	  .max = 230,
	  .def = "0",
	  .doc = "DDS domain id" },
	{ .name = "peers",
	  .kind = CFG_STR,
	  CFG_AT(struct cfg_site, peers),
	  .def = "",
	  .doc = "addresses of the other sites, separated by spaces (unicast discovery, multicast off); empty: "
		 "multicast discovery on the local network" },
	{ .name = "interface",
	  .kind = CFG_STR,
	  CFG_AT(struct cfg_site, interface),
	  .def = "",
	  .doc = "network interface (or its address) DDS uses; empty: Cyclone DDS chooses" },
	{ .name = "publish",
	  .kind = CFG_BOOL,
	  CFG_AT(struct cfg_site, publish),
	  .def = "yes",
	  .doc = "share this site's avatars" },
	{ .name = "subscribe",
	  .kind = CFG_BOOL,
	  CFG_AT(struct cfg_site, subscribe),
	  .def = "yes",
	  .doc = "show the other sites' avatars here, through every output" },
	{ .name = "security",
	  .kind = CFG_PATH,
	  CFG_AT(struct cfg_site, security),
	  .def = "",
	  .doc = "directory with DDS Security's ca.pem, cert.pem, key.pem, governance.p7s, permissions.p7s "
		 "(tools/site-security.sh makes them); empty: none, anyone on the network can read and inject" },
	{ .name = "ros2",
	  .kind = CFG_BOOL,
	  CFG_AT(struct cfg_site, ros2),
	  .def = "no",
	  .doc = "also publish each local avatar for ROS 2: sensor_msgs/JointState on rt/SITE/AVATAR/joint_states, "
		 "tf2_msgs/TFMessage on rt/tf (frames SITE/AVATAR/SEGMENT in world), outside the session's "
		 "partition" },
	{ .name = "max_remote",
	  .kind = CFG_INT,
	  CFG_AT(struct cfg_site, max_remote),
	  .min = 0,
	  .max = 1024,
	  .def = "64",
	  .doc = "remote avatars shown at most (their slots are reserved at start-up)" },
	{ .name = "remote_id",
	  .kind = CFG_INT,
	  CFG_AT(struct cfg_site, remote_id),
	  .min = 0,
	  .max = 65535,
	  .def = "1000",
	  .doc = "the id of the first remote avatar; the others follow (remote_id + max_remote - 1 at most 65535)" },
	{ .name = "deadline_ms",
	  .kind = CFG_DOUBLE,
	  CFG_AT(struct cfg_site, deadline_ms),
	  .min = 10,
	  .max = 60000,
	  .def = "500",
	  .unit = "ms",
	  .doc = "a remote avatar without a new sample for this long is MISSING (STALE after [daemon] stale_ms)" },
	{ .name = "lease",
	  .kind = CFG_DOUBLE,
	  CFG_AT(struct cfg_site, lease),
	  .min = 0.2,
	  .max = 3600,
	  .def = "2",
	  .unit = "s",
	  .doc = "a site that stops (crash, network) is gone at the others after this long" },
};

static const struct {
	const struct cfg_key *keys;
	int n;
} common[S_COUNT] = {
	[S_DAEMON] = { daemon_keys, CFG_N(daemon_keys) }, [S_SOURCE] = { source_keys, CFG_N(source_keys) },
	[S_AVATAR] = { avatar_keys, CFG_N(avatar_keys) }, [S_OUTPUT] = { output_keys, CFG_N(output_keys) },
	[S_SITE] = { site_keys, CFG_N(site_keys) },
};

/* ---- errors ----------------------------------------------------------------------- */

struct parse {
	struct config *c;
	char *err;
	size_t errlen;
	int failed;
	int fail_line; /* line of the first error when it is in the file being read, else 0 */
	/* the file being read */
	int file;
	int line;
	int first_entry; /* index of this file's first entry: duplicates within a file */
	/* the line reader */
	const char *text;
	size_t pos;
	int long_line;
};

static int failf(struct parse *p, struct cfg_where w, const char *fmt, ...) __attribute__((format(printf, 3, 4)));

static int failf(struct parse *p, struct cfg_where w, const char *fmt, ...)
{
	va_list ap;
	size_t n;

	if (p->failed++)
		return -1; /* the first error is the one reported */
	p->fail_line = w.file >= 0 && w.file == p->file ? w.line : 0;
	if (w.file >= 0)
		n = (size_t)snprintf(p->err, p->errlen, "%s:%d: ", p->c->files[w.file], w.line);
	else
		n = (size_t)snprintf(p->err, p->errlen, "%s: ", w.file == -2 ? "(command line)" : "(default)");
	if (n >= p->errlen)
		return -1;
	va_start(ap, fmt);
	vsnprintf(p->err + n, p->errlen - n, fmt, ap);
	va_end(ap);
	return -1;
}

const char *config_where(const struct config *c, struct cfg_where w, char *buf, size_t len)
{
	if (w.file >= 0)
		snprintf(buf, len, "%s:%d", c->files[w.file], w.line);
	else
		snprintf(buf, len, "default");
	return buf;
}

/* ---- pass 1: files to entries ---------------------------------------------------- */

static char *dupstr(const char *s)
{
	size_t n = strlen(s) + 1;
	char *d = malloc(n);

	if (d)
		memcpy(d, s, n);
	return d;
}

static char *line_reader(char *str, int num, void *stream)
{
	struct parse *p = stream;
	size_t i = 0, start = p->pos;

	if (!p->text[p->pos])
		return NULL;
	while (p->text[p->pos] && p->text[p->pos] != '\n') {
		if (i + 2 < (size_t)num)
			str[i++] = p->text[p->pos];
		p->pos++;
	}
	size_t len = p->pos - start;

	if (p->text[p->pos] == '\n')
		p->pos++;
	p->line++;
	if (len > (size_t)num - 2 && !p->long_line)
		p->long_line = p->line;
	str[i++] = '\n';
	str[i] = '\0';
	return str;
}

static int add_entry(struct parse *p, const char *section, const char *key, const char *value)
{
	struct config *c = p->c;
	struct cfg_where w = { p->file, p->line };

	for (size_t i = 0; i < c->n_entries; i++) {
		struct cfg_entry *e = &c->entries[i];

		if (strcmp(e->section, section) || strcmp(e->key, key))
			continue;
		if (e->where.file == p->file) {
			char prev[CFG_PATH_MAX + 16];

			return failf(p, w, "[%s] %s: given twice in one file (first at %s)", section, key,
				     config_where(c, e->where, prev, sizeof(prev)));
		}
		/* a later file wins */
		free(e->value);
		e->value = dupstr(value);
		e->where = w;
		return e->value ? 0 : failf(p, w, "out of memory");
	}
	if (c->n_entries == c->cap_entries) {
		size_t cap = c->cap_entries ? 2 * c->cap_entries : 64;
		struct cfg_entry *ne = realloc(c->entries, cap * sizeof(*ne));

		if (!ne)
			return failf(p, w, "out of memory");
		c->entries = ne;
		c->cap_entries = cap;
	}
	c->entries[c->n_entries] = (struct cfg_entry){ dupstr(section), dupstr(key), dupstr(value), w };
	if (!c->entries[c->n_entries].section || !c->entries[c->n_entries].key || !c->entries[c->n_entries].value)
		return failf(p, w, "out of memory");
	c->n_entries++;
	return 0;
}

static int on_entry(void *user, const char *section, const char *name, const char *value)
{
	struct parse *p = user;

	if (!section[0]) {
		failf(p, (struct cfg_where){ p->file, p->line }, "%s: a key outside any section", name);
		return 0;
	}
	return add_entry(p, section, name, value) == 0;
}

static int read_text(struct parse *p, const char *name, const char *text)
{
	int rc, first;

	if (p->c->n_files == CFG_MAX_FILES)
		return failf(p, (struct cfg_where){ -2, 0 }, "%s: more than %d configuration files", name,
			     CFG_MAX_FILES);
	p->c->files[p->c->n_files] = dupstr(name);
	p->file = p->c->n_files++;
	p->line = 0;
	p->text = text;
	p->pos = 0;
	p->long_line = 0;
	p->first_entry = (int)p->c->n_entries;
	rc = ini_parse_stream(line_reader, p, on_entry, p);
	/* inih reads on after a syntax error, so a handler may have failed on a later line */
	first = p->failed ? p->fail_line : INT_MAX;
	if (p->long_line && p->long_line <= first) {
		p->failed = 0;
		return failf(p, (struct cfg_where){ p->file, p->long_line }, "line longer than %d characters",
			     INI_MAX_LINE - 2);
	}
	if (rc > 0 && rc < first) {
		p->failed = 0;
		return failf(p, (struct cfg_where){ p->file, rc },
			     "syntax error: expected [section], key = value, or a comment");
	}
	return p->failed ? -1 : 0;
}

static int read_file(struct parse *p, const char *path)
{
	FILE *f = fopen(path, "r");
	char *text = NULL;
	size_t len = 0, cap = 0;
	int rc;

	if (!f)
		return failf(p, (struct cfg_where){ -2, 0 }, "%s: %s", path, strerror(errno));
	for (;;) {
		if (len + 4096 + 1 > cap) {
			char *n = realloc(text, cap = cap ? 2 * cap : 8192);

			if (!n) {
				free(text);
				fclose(f);
				return failf(p, (struct cfg_where){ -2, 0 }, "%s: out of memory", path);
			}
			text = n;
		}
		size_t got = fread(text + len, 1, 4096, f);

		len += got;
		if (got < 4096)
			break;
	}
	rc = ferror(f);
	fclose(f);
	if (rc) {
		free(text);
		return failf(p, (struct cfg_where){ -2, 0 }, "%s: read error", path);
	}
	text[len] = '\0';
	if (strlen(text) != len) {
		free(text);
		return failf(p, (struct cfg_where){ -2, 0 }, "%s: not a text file (NUL byte)", path);
	}
	rc = read_text(p, path, text);
	free(text);
	return rc;
}

static int cmp_str(const void *a, const void *b)
{
	return strcmp(*(char *const *)a, *(char *const *)b);
}

static int read_dropins(struct parse *p, const char *main_path)
{
	char dir[CFG_PATH_MAX + 16];
	const char *slash = strrchr(main_path, '/');
	char *names[CFG_MAX_FILES];
	int n = 0, rc = 0;
	struct dirent *de;
	DIR *d;

	if (slash)
		snprintf(dir, sizeof(dir), "%.*s/conf.d", (int)(slash - main_path), main_path);
	else
		snprintf(dir, sizeof(dir), "conf.d");
	d = opendir(dir);
	if (!d)
		return errno == ENOENT ? 0 : failf(p, (struct cfg_where){ -2, 0 }, "%s: %s", dir, strerror(errno));
	while ((de = readdir(d))) {
		size_t l = strlen(de->d_name);

		if (de->d_name[0] == '.' || l < 6 || strcmp(de->d_name + l - 5, ".conf"))
			continue;
		if (n == CFG_MAX_FILES - 1) {
			rc = failf(p, (struct cfg_where){ -2, 0 }, "%s: too many drop-ins", dir);
			break;
		}
		names[n] = malloc(strlen(dir) + l + 2);
		if (!names[n])
			break;
		sprintf(names[n], "%s/%s", dir, de->d_name);
		n++;
	}
	closedir(d);
	qsort(names, (size_t)n, sizeof(names[0]), cmp_str);
	for (int i = 0; i < n; i++) {
		if (!rc)
			rc = read_file(p, names[i]);
		free(names[i]);
	}
	return rc;
}

/* ---- pass 2: values ------------------------------------------------------------------ */

/* the entry of a key in a section, or NULL */
static const struct cfg_entry *entry_of(const struct config *c, const char *section, const char *key)
{
	for (size_t i = 0; i < c->n_entries; i++)
		if (!strcmp(c->entries[i].section, section) && !strcmp(c->entries[i].key, key))
			return &c->entries[i];
	return NULL;
}

/* "a, b or c" (last: " or ") or "a, b, c" (last: ", "): the names of a type table, for messages */
static void name_list(char *buf, size_t len, const struct cfg_type *(*type)(int i), const char *last)
{
	size_t at = 0;
	int n = 0;

	while (type(n))
		n++;
	buf[0] = '\0';
	for (int i = 0; i < n && at < len; i++)
		at += (size_t)snprintf(buf + at, len - at, "%s%s",
				       i == 0	    ? ""
				       : i == n - 1 ? last
						    : ", ",
				       type(i)->name);
}

static int type_find(const struct cfg_type *(*type)(int i), const char *name)
{
	for (int i = 0; type(i); i++)
		if (!strcmp(type(i)->name, name))
			return i;
	return -1;
}

int cfg_source_type_find(const char *name)
{
	return type_find(cfg_source_type, name);
}

int cfg_output_type_find(const char *name)
{
	return type_find(cfg_output_type, name);
}

bool cfg_output_is(const struct cfg_output *o, const char *type)
{
	const struct cfg_type *t = cfg_output_type(o->type);

	return t && !strcmp(t->name, type);
}

int cfg_sensor_lookup(const struct cfg_source *s, const char *name)
{
	const struct cfg_type *d = cfg_source_type(s->driver);
	int n = d->sensor_count(s);
	char buf[CFG_NAME_MAX * 2];

	for (int i = 0; i < n; i++) {
		d->sensor_name(s, i, buf, sizeof(buf));
		if (!strcmp(buf, name))
			return i;
	}
	return d->sensor_alias ? d->sensor_alias(s, name) : -1;
}

/*
 * The type named by a section's type entry: its index, or -1 after an error
 * (unknown, or known but left out of this build). *opt: its options, zeroed.
 */
static int section_type(struct parse *p, const char *full, const struct cfg_entry *t,
			const struct cfg_type *(*type)(int i), void **opt)
{
	int i = type_find(type, t->value);
	char names[256];

	if (i < 0) {
		name_list(names, sizeof(names), type, ", ");
		return type == cfg_source_type
			       ? failf(p, t->where, "[%s] type: unknown driver '%s' (known: %s)", full, t->value, names)
			       : failf(p, t->where, "[%s] type: '%s' is not one of: %s", full, t->value, names);
	}
	if (!type(i)->built)
		return failf(p, t->where, "[%s] type: %s is not built into this daemon (%s was missing at build time)",
			     full, t->value, type(i)->doc);
	*opt = calloc(1, type(i)->opt_size + 1);
	if (!*opt)
		return failf(p, t->where, "out of memory");
	return i;
}

/* the type's own check, the blame on the key it names (else on the type's line) */
static int type_check(struct parse *p, const char *full, const struct cfg_type *type, const void *section,
		      const struct cfg_entry *t)
{
	const char *key = NULL;
	const struct cfg_entry *e;
	char why[256];

	if (!type->check || !type->check(p->c, section, &key, why, sizeof(why)))
		return 0;
	e = key ? entry_of(p->c, full, key) : NULL;
	return failf(p, e ? e->where : t->where, "[%s] %s", full, why);
}

static bool valid_name(const char *s)
{
	size_t n = strlen(s);

	if (n == 0 || n >= CFG_NAME_MAX)
		return false;
	for (; *s; s++)
		if (!isalnum((unsigned char)*s) && *s != '_' && *s != '-' && *s != '.')
			return false;
	return true;
}

/* one number, the whole string */
static bool parse_num(const char *s, double *v)
{
	char *end;

	errno = 0;
	*v = strtod(s, &end);
	if (end == s || errno == ERANGE || !isfinite(*v))
		return false;
	while (isspace((unsigned char)*end))
		end++;
	return *end == '\0';
}

/* n numbers separated by spaces or commas */
static bool parse_nums(const char *s, double *v, int n)
{
	for (int i = 0; i < n; i++) {
		char *end;

		while (isspace((unsigned char)*s) || (i && *s == ','))
			s++;
		errno = 0;
		v[i] = strtod(s, &end);
		if (end == s || errno == ERANGE || !isfinite(v[i]))
			return false;
		s = end;
	}
	while (isspace((unsigned char)*s))
		s++;
	return *s == '\0';
}

struct section_ctx {
	struct parse *p;
	int sect;
	const char *name;	     /* the section's name after its kind */
	const char *full;	     /* as written */
	void *obj;		     /* the section's struct: the common keys' values */
	const struct cfg_type *type; /* a source's or output's type: its keys' values go to opt */
	void *opt;
	struct cfg_where first;
};

/* the i-th key of a section's kind and type (common keys first), and the struct its value goes to */
static const struct cfg_key *key_at(const struct section_ctx *s, int i, void **obj)
{
	if (i < common[s->sect].n) {
		if (obj)
			*obj = s->obj;
		return &common[s->sect].keys[i];
	}
	i -= common[s->sect].n;
	if (!s->type || i >= s->type->n_shared + s->type->n_keys)
		return NULL;
	if (obj)
		*obj = s->opt;
	return i < s->type->n_shared ? &s->type->shared[i] : &s->type->keys[i - s->type->n_shared];
}

/*
 * The key called name in the section, or NULL. mount_SENSOR (or mount.SENSOR): the key's name ends in a
 * sensor's name; a CFG_PER key NAME.N matches NAME. followed by anything.
 */
static const struct cfg_key *find_key(const struct section_ctx *s, const char *name, void **obj)
{
	const struct cfg_key *k;

	for (int i = 0; (k = key_at(s, i, obj)); i++)
		if (k->kind == CFG_MOUNT ? (!strncmp(name, "mount_", 6) || !strncmp(name, "mount.", 6)) && name[6]
		    : k->kind == CFG_PER ? !strncmp(name, k->name, strlen(k->name) - 1) && name[strlen(k->name) - 1]
					 : !strcmp(k->name, name))
			return k;
	return NULL;
}

/* mount_SENSOR = x y z [qw qx qy qz] */
static int set_mount(struct section_ctx *s, const struct cfg_key *k, const char *key, const char *value,
		     struct cfg_where w)
{
	struct cfg_source *src = s->obj;
	struct cfg_mount *m;
	double v[7] = { 0, 0, 0, 1, 0, 0, 0 }, n;
	const char *sensor = key + 6;

	if (strlen(sensor) >= sizeof(m->sensor))
		return failf(s->p, w, "[%s] %s: sensor name too long", s->full, key);
	if (!parse_nums(value, v, 3) && !parse_nums(value, v, 7))
		return failf(s->p, w, "[%s] %s: '%s' is not x y z or x y z qw qx qy qz", s->full, key, value);
	for (int i = 0; i < 3; i++)
		if (v[i] < k->min || v[i] > k->max)
			return failf(s->p, w, "[%s] %s: %g is out of range [%g, %g] m", s->full, key, v[i], k->min,
				     k->max);
	n = sqrt(v[3] * v[3] + v[4] * v[4] + v[5] * v[5] + v[6] * v[6]);
	if (n < 1e-6)
		return failf(s->p, w, "[%s] %s: the rotation qw qx qy qz is zero", s->full, key);
	for (int i = 0; i < src->n_mounts; i++)
		if (!strcmp(src->mount[i].sensor, sensor)) {
			m = &src->mount[i];
			goto store;
		}
	if (src->n_mounts == CFG_MAX_MOUNTS)
		return failf(s->p, w, "[%s] %s: more than %d mount_ keys", s->full, key, CFG_MAX_MOUNTS);
	m = &src->mount[src->n_mounts++];
store:
	snprintf(m->sensor, sizeof(m->sensor), "%s", sensor);
	for (int i = 0; i < 3; i++)
		m->p[i] = v[i];
	for (int i = 0; i < 4; i++)
		m->q[i] = v[3 + i] / n;
	m->where = w;
	return 0;
}

/* every mount_SENSOR names a sensor of the source */
static int check_mounts(struct parse *p, const char *full, const struct cfg_source *src)
{
	for (int i = 0; i < src->n_mounts; i++) {
		const struct cfg_mount *m = &src->mount[i];
		const struct cfg_type *d = cfg_source_type(src->driver);
		int cnt = d->sensor_count(src);
		char names[256], nm[CFG_NAME_MAX * 2];
		size_t n = 0;

		if (cfg_sensor_lookup(src, m->sensor) >= 0)
			continue;
		names[0] = '\0';
		for (int j = 0; j < cnt && j < 6 && n < sizeof(names); j++) {
			d->sensor_name(src, j, nm, sizeof(nm));
			n += (size_t)snprintf(names + n, sizeof(names) - n, "%s%s", j ? ", " : "", nm);
		}
		return failf(p, m->where, "[%s] mount_%s: the source has no sensor '%s' (it has: %s%s)", full,
			     m->sensor, m->sensor, names, cnt > 6 ? ", ..." : "");
	}
	return 0;
}

static void list_keys(const struct section_ctx *s, char *buf, size_t len)
{
	const struct cfg_key *k;
	size_t n = 0;

	buf[0] = '\0';
	for (int i = 0; (k = key_at(s, i, NULL)) && n < len; i++)
		n += (size_t)snprintf(buf + n, len - n, "%s%s", n ? ", " : "", k->name);
}

/* NAME.X = VALUE: kept as written, one entry per key, for the type to read */
static int set_per(struct section_ctx *s, const struct cfg_key *k, void *into, const char *key, const char *value,
		   struct cfg_where w)
{
	struct cfg_per *per = (struct cfg_per *)((char *)into + k->off), *free_one = NULL;

	if (strlen(key) >= sizeof(per->key) || strlen(value) >= sizeof(per->value))
		return failf(s->p, w, "[%s] %s: too long", s->full, key);
	for (int i = 0; i < (int)k->max; i++) {
		if (!strcmp(per[i].key, key)) {
			free_one = &per[i];
			break;
		}
		if (!per[i].key[0] && !free_one)
			free_one = &per[i];
	}
	if (!free_one)
		return failf(s->p, w, "[%s] %s: more than %d %s keys", s->full, key, (int)k->max, k->name);
	snprintf(free_one->key, sizeof(free_one->key), "%s", key);
	snprintf(free_one->value, sizeof(free_one->value), "%s", value);
	return 0;
}

/* axes: the rotation from the tracker's axes to z-up ones, as a quaternion w x y z */
static int set_axes(struct section_ctx *s, const struct cfg_key *k, double *q, const char *value, struct cfg_where w)
{
	double m[3][3] = { { 0 } }, v[4], n;
	char buf[64], *save, *tok;
	int col = 0;

	if (!strcmp(value, "z-up")) {
		q[0] = 1;
		q[1] = q[2] = q[3] = 0;
		return 0;
	}
	if (!strcmp(value, "y-up")) {
		/* +90 degrees about x: the tracker's y (up) is the world's z, its z (towards the viewer) the world's -y
		 */
		q[0] = q[1] = sqrt(0.5);
		q[2] = q[3] = 0;
		return 0;
	}
	if (parse_nums(value, v, 4)) {
		n = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2] + v[3] * v[3]);
		if (n < 1e-6)
			return failf(s->p, w, "[%s] %s: the rotation qw qx qy qz is zero", s->full, k->name);
		for (int i = 0; i < 4; i++)
			q[i] = v[i] / n;
		return 0;
	}
	snprintf(buf, sizeof(buf), "%s", value);
	for (tok = strtok_r(buf, " \t", &save); tok; tok = strtok_r(NULL, " \t", &save), col++) {
		int sign = 1, axis;

		if (*tok == '-' || *tok == '+')
			sign = *tok++ == '-' ? -1 : 1;
		axis = tok[0] >= 'x' && tok[0] <= 'z' && !tok[1] ? tok[0] - 'x' : -1;
		if (axis < 0 || col > 2)
			break;
		m[axis][col] = sign;
	}
	if (col == 3 && !tok) {
		/* the columns are the world directions of the tracker's axes: a rotation when they are right-handed */
		double det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
			     m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
			     m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
		double t = m[0][0] + m[1][1] + m[2][2];

		if (det < 0.5)
			return failf(s->p, w,
				     "[%s] %s: '%s' is not a rotation (the three axes must differ and keep the hand: a "
				     "left-handed tracker's frame needs an axis negated)",
				     s->full, k->name, value);
		/* to a quaternion (entries 0 and +-1: the largest diagonal term keeps the root away from 0) */
		if (t > 0) {
			double r = sqrt(1 + t) * 2;

			v[0] = r / 4;
			v[1] = (m[2][1] - m[1][2]) / r;
			v[2] = (m[0][2] - m[2][0]) / r;
			v[3] = (m[1][0] - m[0][1]) / r;
		} else if (m[0][0] >= m[1][1] && m[0][0] >= m[2][2]) {
			double r = sqrt(1 + m[0][0] - m[1][1] - m[2][2]) * 2;

			v[0] = (m[2][1] - m[1][2]) / r;
			v[1] = r / 4;
			v[2] = (m[0][1] + m[1][0]) / r;
			v[3] = (m[0][2] + m[2][0]) / r;
		} else if (m[1][1] >= m[2][2]) {
			double r = sqrt(1 + m[1][1] - m[0][0] - m[2][2]) * 2;

			v[0] = (m[0][2] - m[2][0]) / r;
			v[1] = (m[0][1] + m[1][0]) / r;
			v[2] = r / 4;
			v[3] = (m[1][2] + m[2][1]) / r;
		} else {
			double r = sqrt(1 + m[2][2] - m[0][0] - m[1][1]) * 2;

			v[0] = (m[1][0] - m[0][1]) / r;
			v[1] = (m[0][2] + m[2][0]) / r;
			v[2] = (m[1][2] + m[2][1]) / r;
			v[3] = r / 4;
		}
		for (int i = 0; i < 4; i++)
			q[i] = v[i];
		return 0;
	}
	return failf(s->p, w,
		     "[%s] %s: '%s' is not z-up, y-up, three axes (the world directions of the tracker's x y z, as in "
		     "x z -y) or a rotation qw qx qy qz",
		     s->full, k->name, value);
}

static int set_value(struct section_ctx *s, const struct cfg_key *k, void *into, const char *value, struct cfg_where w)
{
	struct parse *p = s->p;
	char *obj = into;
	double v[3];

	switch (k->kind) {
	case CFG_INT:
	case CFG_U32:
	case CFG_DOUBLE:
	case CFG_DEG:
		if (!parse_num(value, v))
			return failf(p, w, "[%s] %s: '%s' is not a number", s->full, k->name, value);
		if (v[0] < k->min || v[0] > k->max)
			return failf(p, w, "[%s] %s: %s is out of range [%g, %g]%s%s", s->full, k->name, value, k->min,
				     k->max, k->unit ? " " : "", k->unit ? k->unit : "");
		if ((k->kind == CFG_INT || k->kind == CFG_U32) && v[0] != floor(v[0]))
			return failf(p, w, "[%s] %s: '%s' is not a whole number", s->full, k->name, value);
		if (k->kind == CFG_INT)
			*(int *)(obj + k->off) = (int)v[0];
		else if (k->kind == CFG_U32)
			*(uint32_t *)(obj + k->off) = (uint32_t)v[0];
		else
			*(double *)(obj + k->off) = k->kind == CFG_DEG ? v[0] * DEG : v[0];
		return 0;
	case CFG_BOOL:
		if (!strcasecmp(value, "yes") || !strcasecmp(value, "true") || !strcasecmp(value, "on") ||
		    !strcmp(value, "1"))
			*(bool *)(obj + k->off) = true;
		else if (!strcasecmp(value, "no") || !strcasecmp(value, "false") || !strcasecmp(value, "off") ||
			 !strcmp(value, "0"))
			*(bool *)(obj + k->off) = false;
		else
			return failf(p, w, "[%s] %s: '%s' is not yes or no", s->full, k->name, value);
		return 0;
	case CFG_ENUM:
		for (int i = 0; k->enums[i]; i++)
			if (!strcmp(value, k->enums[i])) {
				*(int *)(obj + k->off) = i;
				return 0;
			}
		{
			char opts[128];
			size_t n = 0;

			opts[0] = '\0';
			for (int i = 0; k->enums[i]; i++)
				n += (size_t)snprintf(opts + n, sizeof(opts) - n, "%s%s", i ? ", " : "", k->enums[i]);
			return failf(p, w, "[%s] %s: '%s' is not one of: %s", s->full, k->name, value, opts);
		}
	case CFG_STR:
	case CFG_PATH:
	case CFG_LIST: {
		size_t cap = k->size ? k->size : CFG_PATH_MAX;
		char *dst = obj + k->off;

		if (strlen(value) >= cap)
			return failf(p, w, "[%s] %s: longer than %zu characters", s->full, k->name, cap - 1);
		if (k->kind == CFG_PATH && value[0] && value[0] != '/' && strncmp(value, "builtin:", 8) &&
		    strcmp(value, "auto") && w.file >= 0) {
			/* relative to the directory of the file that says it */
			const char *f = p->c->files[w.file];
			const char *slash = strrchr(f, '/');

			if (slash && (size_t)(slash - f) + 1 + strlen(value) < cap) {
				size_t dl = (size_t)(slash - f);

				memcpy(dst, f, dl);
				dst[dl] = '/';
				memcpy(dst + dl + 1, value, strlen(value) + 1);
				return 0;
			}
			if (slash)
				return failf(p, w, "[%s] %s: path too long", s->full, k->name);
		}
		snprintf(dst, cap, "%s", value);
		return 0;
	}
	case CFG_VEC3:
		if (!parse_nums(value, v, 3))
			return failf(p, w, "[%s] %s: '%s' is not three numbers (x y z)", s->full, k->name, value);
		for (int i = 0; i < 3; i++) {
			if (v[i] < k->min || v[i] > k->max)
				return failf(p, w, "[%s] %s: %g is out of range [%g, %g] %s", s->full, k->name, v[i],
					     k->min, k->max, k->unit);
			((double *)(obj + k->off))[i] = v[i];
		}
		return 0;
	case CFG_NAMES: {
		char buf[CFG_PATH_MAX], *save, *tok, *seen[CFG_MAX_STATIONS];
		int n = 0, named = 0;

		if (strlen(value) >= CFG_PATH_MAX)
			return failf(p, w, "[%s] %s: longer than %d characters", s->full, k->name, CFG_PATH_MAX - 1);
		snprintf(buf, sizeof(buf), "%s", value);
		for (tok = strtok_r(buf, " \t,", &save); tok; tok = strtok_r(NULL, " \t,", &save)) {
			if (n == (int)k->max)
				return failf(p, w, "[%s] %s: more than %d names", s->full, k->name, (int)k->max);
			if (strcmp(tok, "-")) {
				if (!valid_name(tok))
					return failf(
						p, w,
						"[%s] %s: '%s' is not a valid sensor name (1-%d of A-Z a-z 0-9 _ - .)",
						s->full, k->name, tok, CFG_NAME_MAX - 1);
				for (int i = 0; i < named; i++)
					if (!strcmp(seen[i], tok))
						return failf(p, w, "[%s] %s: '%s' named twice", s->full, k->name, tok);
				seen[named++] = tok;
			}
			n++;
		}
		if (!named)
			return failf(p, w, "[%s] %s: no sensor named", s->full, k->name);
		snprintf(obj + k->off, CFG_PATH_MAX, "%s", value);
		return 0;
	}
	case CFG_AXES:
		return set_axes(s, k, (double *)(obj + k->off), value, w);
	case CFG_RANGE:
		if (!parse_nums(value, v, 2))
			return failf(p, w, "[%s] %s: '%s' is not two numbers (lo hi, degrees)", s->full, k->name,
				     value);
		if (v[0] < k->min || v[1] > k->max || v[0] > v[1])
			return failf(p, w, "[%s] %s: '%s' must satisfy %g <= lo <= hi <= %g degrees", s->full, k->name,
				     value, k->min, k->max);
		*(double *)(obj + k->off) = v[0] * DEG;
		*(double *)(obj + k->off2) = v[1] * DEG;
		return 0;
	default:
		return 0; /* CFG_SENSOR, CFG_PERSON: resolved by the avatar code */
	}
}

/* keys the section code reads itself (type, id, count, the sensors), not through set_value */
static bool special_key(const struct section_ctx *s, const struct cfg_key *k)
{
	return k->kind == CFG_SENSOR || k->kind == CFG_PERSON || !strcmp(k->name, "type") ||
	       (s->sect == S_AVATAR && (!strcmp(k->name, "id") || !strcmp(k->name, "count")));
}

/* defaults, the required keys, then the section's entries (keys of other types are errors) */
static int apply_section(struct section_ctx *s)
{
	struct parse *p = s->p;
	const struct config *c = p->c;
	const struct cfg_key *k;
	char known[512];
	void *into;

	for (int i = 0; (k = key_at(s, i, &into)); i++) {
		if (!k->def || special_key(s, k) || k->kind == CFG_MOUNT || k->kind == CFG_PER)
			continue;
		if (set_value(s, k, into, k->def, (struct cfg_where){ -1, 0 }))
			return -1;
	}
	for (int i = 0; (k = key_at(s, i, NULL)); i++) {
		const struct cfg_entry *t = entry_of(c, s->full, "type");

		if (k->def || special_key(s, k) || entry_of(c, s->full, k->name))
			continue;
		return failf(p, t ? t->where : s->first, "[%s] %s: missing (%s)", s->full, k->name,
			     k->missing ? k->missing : k->doc);
	}
	for (size_t i = 0; i < c->n_entries; i++) {
		const struct cfg_entry *e = &c->entries[i];

		if (strcmp(e->section, s->full))
			continue;
		k = find_key(s, e->key, &into);
		if (!k) {
			list_keys(s, known, sizeof(known));
			return failf(p, e->where, "[%s] %s: unknown key%s%s (known: %s)", s->full, e->key,
				     s->type ? " for type " : "", s->type ? s->type->name : "", known);
		}
		if (special_key(s, k))
			continue;
		if (k->kind == CFG_MOUNT) {
			if (set_mount(s, k, e->key, e->value, e->where))
				return -1;
			continue;
		}
		if (k->kind == CFG_PER) {
			if (set_per(s, k, into, e->key, e->value, e->where))
				return -1;
			continue;
		}
		if (set_value(s, k, into, e->value, e->where))
			return -1;
	}
	return 0;
}

/* sections in order of first appearance; the kind and name of a section header */
static int section_kind(const char *full, const char **name)
{
	for (int i = 0; i < S_COUNT; i++) {
		size_t n = strlen(sect_names[i]);

		if (strncmp(full, sect_names[i], n))
			continue;
		if (full[n] == '\0') {
			*name = "";
			return i;
		}
		if (full[n] == ' ' || full[n] == '\t') {
			const char *q = full + n;

			while (*q == ' ' || *q == '\t')
				q++;
			*name = q;
			return i;
		}
	}
	return -1;
}

static int resolve_sensor(struct parse *p, const char *full, const char *key, const char *ref, struct cfg_where w,
			  struct cfg_sensor_ref *out)
{
	const struct config *c = p->c;
	const char *slash = strchr(ref, '/');
	size_t sn = slash ? (size_t)(slash - ref) : strlen(ref);

	for (int i = 0; i < c->n_sources; i++) {
		const struct cfg_source *src = &c->source[i];

		if (strlen(src->name) != sn || strncmp(src->name, ref, sn))
			continue;
		if (!slash || !slash[1])
			return failf(p, w, "[%s] %s: '%s' names no sensor (SOURCE/SENSOR)", full, key, ref);
		out->source = i;
		out->sensor = cfg_sensor_lookup(src, slash + 1);
		out->where = w;
		if (out->sensor < 0) {
			char names[256], nm[CFG_NAME_MAX * 2];
			size_t n = 0;
			const struct cfg_type *d = cfg_source_type(src->driver);
			int cnt = d->sensor_count(src);

			names[0] = '\0';
			for (int j = 0; j < cnt && j < 6 && n < sizeof(names); j++) {
				d->sensor_name(src, j, nm, sizeof(nm));
				n += (size_t)snprintf(names + n, sizeof(names) - n, "%s%s", j ? ", " : "", nm);
			}
			return failf(p, w, "[%s] %s: source '%s' has no sensor '%s' (it has: %s%s)", full, key,
				     src->name, slash + 1, names, cnt > 6 ? ", ..." : "");
		}
		return 0;
	}
	return failf(p, w, "[%s] %s: no [source %.*s] is configured", full, key, (int)sn, ref);
}

static int build_avatars(struct parse *p, const char *full, const char *name, struct cfg_avatar *tmpl, int *next_id)
{
	struct config *c = p->c;
	const struct cfg_entry *e_count = entry_of(c, full, "count");
	const struct cfg_entry *e_id = entry_of(c, full, "id");
	const struct cfg_entry *e_person = entry_of(c, full, "person");
	const struct cfg_entry *e_role[3];
	int count = 1;
	double v;
	char prefix[CFG_PATH_MAX] = "";
	long pnum = -1;
	size_t pbase = 0;

	if (e_count) {
		if (!parse_num(e_count->value, &v) || v != floor(v) || v < 1 || v > CFG_MAX_AVATARS)
			return failf(p, e_count->where, "[%s] count: '%s' is not a whole number in [1, %d]", full,
				     e_count->value, CFG_MAX_AVATARS);
		count = (int)v;
	}
	if (e_id) {
		if (!parse_num(e_id->value, &v) || v != floor(v) || v < 0 || v + count - 1 > 65535)
			return failf(p, e_id->where, "[%s] id: '%s' is not a whole number in [0, %d]", full,
				     e_id->value, 65536 - count);
		*next_id = (int)v;
	}
	if (*next_id + count - 1 > 65535)
		return failf(p, e_count ? e_count->where : (struct cfg_where){ -1, 0 },
			     "[%s] id: avatar ids past 65535", full);
	for (int r = 0; r < 3; r++)
		e_role[r] = entry_of(c, full, cfg_sensor_roles[r]);
	if (e_person) {
		const char *slash;

		snprintf(prefix, sizeof(prefix), "%s", e_person->value);
		slash = strchr(prefix, '/');
		if (slash) {
			/* a trailing number counts up with count */
			size_t l = strlen(prefix);

			pbase = l;
			while (pbase > (size_t)(slash - prefix) + 1 && isdigit((unsigned char)prefix[pbase - 1]))
				pbase--;
			if (pbase < l)
				pnum = strtol(prefix + pbase, NULL, 10);
		}
		if (count > 1 && pnum < 0)
			return failf(p, e_person->where, "[%s] person: count = %d needs a numbered person (SOURCE/p0)",
				     full, count);
	} else if (count > 1) {
		return failf(p, e_count->where, "[%s] count: needs person = SOURCE/p0", full);
	}
	if (c->n_avatars + count > CFG_MAX_AVATARS)
		return failf(p, e_count ? e_count->where : (struct cfg_where){ -1, 0 }, "[%s]: more than %d avatars",
			     full, CFG_MAX_AVATARS);
	for (int k = 0; k < count; k++) {
		struct cfg_avatar *a = &c->avatar[c->n_avatars];

		*a = *tmpl;
		if (count > 1)
			snprintf(a->name, sizeof(a->name), "%.20s-%d", name, k % CFG_MAX_AVATARS); /* k < 4096 */
		else
			snprintf(a->name, sizeof(a->name), "%s", name);
		snprintf(a->section, sizeof(a->section), "%s", name);
		a->id = (uint16_t)(*next_id + k);
		for (int r = 0; r < 3; r++) {
			char ref[CFG_PATH_MAX + 32];
			struct cfg_where w;

			if (e_role[r]) {
				snprintf(ref, sizeof(ref), "%s", e_role[r]->value);
				w = e_role[r]->where;
			} else if (e_person) {
				if (pnum >= 0)
					snprintf(ref, sizeof(ref), "%.*s%ld.%s", (int)pbase, prefix, pnum + k,
						 cfg_sensor_roles[r]);
				else if (strchr(prefix, '/'))
					snprintf(ref, sizeof(ref), "%s.%s", prefix, cfg_sensor_roles[r]);
				else
					snprintf(ref, sizeof(ref), "%s/%s", prefix, cfg_sensor_roles[r]);
				w = e_person->where;
			} else {
				const struct cfg_entry *any = NULL;

				for (size_t i = 0; i < c->n_entries && !any; i++)
					if (!strcmp(c->entries[i].section, full))
						any = &c->entries[i];
				return failf(p, any ? any->where : (struct cfg_where){ -1, 0 },
					     "[%s] %s: missing (give %s = SOURCE/SENSOR or person = SOURCE)", full,
					     cfg_sensor_roles[r], cfg_sensor_roles[r]);
			}
			if (resolve_sensor(p, full, e_role[r] ? cfg_sensor_roles[r] : "person", ref, w, &a->sensor[r]))
				return -1;
		}
		for (int i = 0; i < c->n_avatars; i++) {
			if (c->avatar[i].id == a->id)
				return failf(p, e_id ? e_id->where : (struct cfg_where){ -1, 0 },
					     "[%s] id: %u is already avatar '%s'", full, a->id, c->avatar[i].name);
			if (!strcmp(c->avatar[i].name, a->name))
				return failf(p, e_id ? e_id->where : (struct cfg_where){ -1, 0 },
					     "[%s]: avatar name '%s' used twice", full, a->name);
		}
		c->n_avatars++;
	}
	*next_id += count;
	return 0;
}

static int resolve_output_avatars(struct parse *p, const char *full, struct cfg_output *o)
{
	const struct config *c = p->c;
	const struct cfg_entry *e = entry_of(c, full, "avatars");
	char buf[CFG_PATH_MAX], *save, *tok;
	int n = 0;

	if (!strcmp(o->avatar_list, "all"))
		return 0;
	o->avatar_ids = calloc((size_t)c->n_avatars + 1, sizeof(uint16_t));
	if (!o->avatar_ids)
		return failf(p, e->where, "out of memory");
	snprintf(buf, sizeof(buf), "%s", o->avatar_list);
	for (tok = strtok_r(buf, " ,", &save); tok; tok = strtok_r(NULL, " ,", &save)) {
		int found = 0;

		for (int i = 0; i < c->n_avatars; i++) {
			const char *an = c->avatar[i].name;
			size_t tl = strlen(tok);

			/* a counted avatar's name selects all its copies */
			if (!strcmp(an, tok) ||
			    (!strncmp(an, tok, tl) && an[tl] == '-' && isdigit((unsigned char)an[tl + 1]))) {
				bool dup = false;

				for (int j = 0; j < n; j++)
					dup |= o->avatar_ids[j] == c->avatar[i].id;
				if (!dup && n < c->n_avatars)
					o->avatar_ids[n++] = c->avatar[i].id;
				found = 1;
			}
		}
		if (!found)
			return failf(p, e->where, "[%s] avatars: no avatar named '%s'", full, tok);
	}
	if (!n)
		return failf(p, e->where, "[%s] avatars: empty list (say all)", full);
	o->n_avatars = n;
	return 0;
}

/* [site] (docs/SITES.md): one section without a name, checked once every avatar is known */
static int build_site(struct parse *p, const struct cfg_entry *e, const char *name)
{
	struct config *c = p->c;
	struct cfg_site *st = &c->site;
	struct section_ctx s = { p, S_SITE, "", "site", st, NULL, NULL, e->where };
	const struct cfg_entry *k;

	if (name[0])
		return failf(p, e->where, "[%s]: the site section has no name ([site], then name = ...)", e->section);
	memset(st, 0, sizeof(*st));
	st->present = true;
	st->where = e->where;
	if (apply_section(&s))
		return -1;
	k = entry_of(c, "site", "name");
	if (!valid_name(st->name))
		return failf(p, k ? k->where : e->where,
			     "[site] name: '%s' is not a valid site name (1-%d of A-Z a-z 0-9 _ - .)", st->name,
			     CFG_SITE_NAME_MAX - 1);
	k = entry_of(c, "site", "session");
	for (const char *ch = st->session; *ch; ch++)
		if ((unsigned char)*ch < 0x20 || *ch == 0x7f || strchr("*?[]\\\"", *ch))
			return failf(p, k ? k->where : e->where,
				     "[site] session: '%s' is not a session name (1-63 characters, no * ? [ ] \\ \")",
				     st->session);
	if (!st->session[0])
		return failf(p, k ? k->where : e->where, "[site] session: empty");
	k = entry_of(c, "site", "remote_id");
	if ((long)st->remote_id + st->max_remote - 1 > 65535)
		return failf(p, k ? k->where : e->where, "[site] remote_id: %d + max_remote %d goes past 65535",
			     st->remote_id, st->max_remote);
	for (int i = 0; i < c->n_avatars && st->subscribe; i++)
		if (c->avatar[i].id >= st->remote_id && c->avatar[i].id < st->remote_id + st->max_remote)
			return failf(p, k ? k->where : e->where,
				     "[site] remote_id: avatar %s has id %u, among the remote ids %d-%d",
				     c->avatar[i].name, c->avatar[i].id, st->remote_id,
				     st->remote_id + st->max_remote - 1);
	return 0;
}

static int build(struct parse *p)
{
	struct config *c = p->c;
	const char *seen[CFG_MAX_SOURCES + CFG_MAX_OUTPUTS + CFG_MAX_AVATARS + 1];
	int n_seen = 0, next_id = 0;
	struct cfg_avatar tmpl;

	c->avatar = calloc(CFG_MAX_AVATARS, sizeof(*c->avatar));
	if (!c->avatar)
		return failf(p, (struct cfg_where){ -2, 0 }, "out of memory");
	/* the daemon section always exists */
	{
		struct section_ctx s = { p, S_DAEMON, "", "daemon", &c->daemon, NULL, NULL, { -1, 0 } };

		if (apply_section(&s))
			return -1;
		if (c->daemon.busy_wait && c->daemon.mode == CFG_LOOP_EVENTS) {
			const struct cfg_entry *b = entry_of(c, "daemon", "busy_wait");

			return failf(p, b ? b->where : (struct cfg_where){ -1, 0 },
				     "[daemon] busy_wait: only with mode = deadline (an event-mode loop waits for its "
				     "sources)");
		}
	}
	/* each kind in turn, sections in order of first appearance */
	for (int pass = 0; pass < S_COUNT; pass++) {
		n_seen = 0;
		for (size_t i = 0; i < c->n_entries; i++) {
			const struct cfg_entry *e = &c->entries[i];
			const char *name = "";
			int kind = section_kind(e->section, &name);
			bool dup = false;

			for (int j = 0; j < n_seen; j++)
				dup |= !strcmp(seen[j], e->section);
			if (dup)
				continue;
			if (n_seen < (int)(sizeof(seen) / sizeof(seen[0])))
				seen[n_seen++] = e->section;
			if (kind < 0) {
				if (pass == 0)
					return failf(p, e->where,
						     "[%s]: unknown section (daemon, source NAME, avatar NAME, output "
						     "NAME, site)",
						     e->section);
				continue;
			}
			if (kind != pass || kind == S_DAEMON) {
				if (kind == S_DAEMON && pass == 0 && name[0])
					return failf(p, e->where, "[%s]: the daemon section has no name", e->section);
				continue;
			}
			if (kind == S_SITE) {
				if (build_site(p, e, name))
					return -1;
				continue;
			}
			if (!valid_name(name))
				return failf(p, e->where, "[%s]: '%s' is not a valid name (1-%d of A-Z a-z 0-9 _ - .)",
					     e->section, name, CFG_NAME_MAX - 1);
			if (kind == S_SOURCE) {
				const struct cfg_entry *t = entry_of(c, e->section, "type");
				struct cfg_source *src;
				struct section_ctx s;

				if (c->n_sources == CFG_MAX_SOURCES)
					return failf(p, e->where, "[%s]: more than %d sources", e->section,
						     CFG_MAX_SOURCES);
				if (!t) {
					char names[256];

					name_list(names, sizeof(names), cfg_source_type, " or ");
					return failf(p, e->where, "[%s] type: missing (%s)", e->section, names);
				}
				src = &c->source[c->n_sources];
				memset(src, 0, sizeof(*src));
				snprintf(src->name, sizeof(src->name), "%s", name);
				src->where = e->where;
				for (int j = 0; j < c->n_sources; j++)
					if (!strcmp(c->source[j].name, name))
						return failf(p, e->where, "[%s]: source name used twice", e->section);
				src->driver = section_type(p, e->section, t, cfg_source_type, &src->opt);
				if (src->driver < 0)
					return -1;
				c->n_sources++; /* counted now: config_free frees its options */
				s = (struct section_ctx){ p,	      S_SOURCE, name,
							  e->section, src,	cfg_source_type(src->driver),
							  src->opt,   e->where };
				if (apply_section(&s) || check_mounts(p, e->section, src) ||
				    type_check(p, e->section, s.type, src, t))
					return -1;
			} else if (kind == S_AVATAR) {
				struct section_ctx s;

				memset(&tmpl, 0, sizeof(tmpl));
				s = (struct section_ctx){ p, S_AVATAR, name, e->section, &tmpl, NULL, NULL, e->where };
				if (apply_section(&s) || build_avatars(p, e->section, name, &tmpl, &next_id))
					return -1;
			} else if (kind == S_OUTPUT) {
				const struct cfg_entry *t = entry_of(c, e->section, "type");
				struct cfg_output *o;
				struct section_ctx s;

				if (c->n_outputs == CFG_MAX_OUTPUTS)
					return failf(p, e->where, "[%s]: more than %d outputs", e->section,
						     CFG_MAX_OUTPUTS);
				if (!t) {
					char names[256];

					name_list(names, sizeof(names), cfg_output_type, " or ");
					return failf(p, e->where, "[%s] type: missing (%s)", e->section, names);
				}
				o = &c->output[c->n_outputs];
				memset(o, 0, sizeof(*o));
				snprintf(o->name, sizeof(o->name), "%s", name);
				o->where = e->where;
				for (int j = 0; j < c->n_outputs; j++)
					if (!strcmp(c->output[j].name, name))
						return failf(p, e->where, "[%s]: output name used twice", e->section);
				o->type = section_type(p, e->section, t, cfg_output_type, &o->opt);
				if (o->type < 0)
					return -1;
				c->n_outputs++; /* counted now: config_free frees its options and avatar list */
				s = (struct section_ctx){ p,	      S_OUTPUT, name,
							  e->section, o,	cfg_output_type(o->type),
							  o->opt,     e->where };
				if (apply_section(&s) || resolve_output_avatars(p, e->section, o) ||
				    type_check(p, e->section, s.type, o, t))
					return -1;
			}
		}
	}
	return 0;
}

static void config_init(struct config *c)
{
	memset(c, 0, sizeof(*c));
}

int config_load(struct config *c, const char *path, char *err, size_t errlen)
{
	struct parse p = { .c = c, .err = err, .errlen = errlen };

	config_init(c);
	if (read_file(&p, path) || read_dropins(&p, path) || build(&p)) {
		config_free(c); /* a failed load leaves nothing to free */
		return -1;
	}
	return 0;
}

static int load_ex(struct config *c, const char *path, const char *const *sets, int n_sets, char *err, size_t errlen)
{
	struct parse p = { .c = c, .err = err, .errlen = errlen };

	config_init(c);
	if (!strncmp(path, "builtin:", 8)) {
		const char *text = builtin_find(path + 8, NULL);

		if (!text)
			return failf(&p, (struct cfg_where){ -2, 0 }, "%s: no such builtin configuration", path);
		if (read_text(&p, path, text))
			return -1;
	} else if (read_file(&p, path) || read_dropins(&p, path)) {
		return -1;
	}
	for (int i = 0; i < n_sets; i++) {
		const char *eq = strchr(sets[i], '=');
		const char *dot = NULL;
		char *text;
		int rc;

		for (const char *q = sets[i]; eq && q < eq; q++)
			if (*q == '.')
				dot = q;
		if (!eq || !dot || dot == sets[i] || dot + 1 == eq)
			return failf(&p, (struct cfg_where){ -2, 0 }, "--set %s: expected SECTION.KEY=VALUE", sets[i]);
		if (asprintf(&text, "[%.*s]\n%.*s = %s\n", (int)(dot - sets[i]), sets[i], (int)(eq - dot - 1), dot + 1,
			     eq + 1) < 0)
			return failf(&p, (struct cfg_where){ -2, 0 }, "out of memory");
		rc = read_text(&p, "--set", text);
		free(text);
		if (rc)
			return -1;
	}
	return build(&p);
}

int config_load_ex(struct config *c, const char *path, const char *const *sets, int n_sets, char *err, size_t errlen)
{
	if (load_ex(c, path, sets, n_sets, err, errlen)) {
		config_free(c);
		return -1;
	}
	return 0;
}

int config_load_text(struct config *c, const char *name, const char *text, char *err, size_t errlen)
{
	struct parse p = { .c = c, .err = err, .errlen = errlen };

	config_init(c);
	if (read_text(&p, name, text) || build(&p)) {
		config_free(c);
		return -1;
	}
	return 0;
}

void config_free(struct config *c)
{
	for (int i = 0; i < c->n_sources; i++)
		free(c->source[i].opt);
	for (int i = 0; i < c->n_outputs; i++) {
		free(c->output[i].avatar_ids);
		free(c->output[i].opt);
	}
	for (size_t i = 0; i < c->n_entries; i++) {
		free(c->entries[i].section);
		free(c->entries[i].key);
		free(c->entries[i].value);
	}
	for (int i = 0; i < c->n_files; i++)
		free(c->files[i]);
	free(c->entries);
	free(c->avatar);
	memset(c, 0, sizeof(*c));
}

/* ---- printing ------------------------------------------------------------------------ */

static void print_value(FILE *out, const struct cfg_key *k, const void *obj)
{
	const char *o = obj;

	switch (k->kind) {
	case CFG_INT:
		fprintf(out, "%d", *(const int *)(o + k->off));
		break;
	case CFG_U32:
		fprintf(out, "%u", *(const uint32_t *)(o + k->off));
		break;
	case CFG_DOUBLE:
		fprintf(out, "%.10g", *(const double *)(o + k->off));
		break;
	case CFG_DEG:
		fprintf(out, "%.10g", *(const double *)(o + k->off) / DEG);
		break;
	case CFG_BOOL:
		fputs(*(const bool *)(o + k->off) ? "yes" : "no", out);
		break;
	case CFG_ENUM:
		fputs(k->enums[*(const int *)(o + k->off)], out);
		break;
	case CFG_STR:
	case CFG_PATH:
	case CFG_LIST:
	case CFG_NAMES:
		fputs(o + k->off, out);
		break;
	case CFG_VEC3: {
		const double *v = (const double *)(o + k->off);

		fprintf(out, "%.10g %.10g %.10g", v[0], v[1], v[2]);
		break;
	}
	case CFG_RANGE:
		fprintf(out, "%.10g %.10g", *(const double *)(o + k->off) / DEG, *(const double *)(o + k->off2) / DEG);
		break;
	case CFG_AXES: {
		const double *q = (const double *)(o + k->off);

		if (q[0] == 1)
			fputs("z-up", out);
		else if (q[0] == sqrt(0.5) && q[1] == sqrt(0.5) && !q[2] && !q[3])
			fputs("y-up", out);
		else
			fprintf(out, "%.10g %.10g %.10g %.10g", q[0], q[1], q[2], q[3]);
		break;
	}
	default:
		break;
	}
}

static void print_origin(FILE *out, const struct config *c, const char *section, const char *key)
{
	const struct cfg_entry *e = entry_of(c, section, key);
	char w[CFG_PATH_MAX + 16];

	if (e)
		fprintf(out, "    ; %s\n", config_where(c, e->where, w, sizeof(w)));
	else
		fputs("    ; default\n", out);
}

/* full: the section printed; from: the section its entries are in (a counted avatar's) */
static void print_section(FILE *out, const struct config *c, int sect, const char *full, const char *from,
			  const struct cfg_type *type, void *obj, void *opt)
{
	struct section_ctx s = { NULL, sect, "", full, obj, type, opt, { -1, 0 } };
	const struct cfg_key *k;
	void *into;

	fprintf(out, "\n[%s]\n", full);
	if (type) {
		fprintf(out, "type = %s", type->name);
		print_origin(out, c, from, "type");
	}
	for (int i = 0; (k = key_at(&s, i, &into)); i++) {
		if (special_key(&s, k))
			continue;
		if (k->kind == CFG_MOUNT) {
			const struct cfg_source *src = obj;
			char w[CFG_PATH_MAX + 16];

			for (int m = 0; m < src->n_mounts; m++) {
				const struct cfg_mount *mt = &src->mount[m];

				fprintf(out, "mount_%s = %.10g %.10g %.10g %.10g %.10g %.10g %.10g    ; %s\n",
					mt->sensor, mt->p[0], mt->p[1], mt->p[2], mt->q[0], mt->q[1], mt->q[2],
					mt->q[3], config_where(c, mt->where, w, sizeof(w)));
			}
			continue;
		}
		if (k->kind == CFG_PER) {
			const struct cfg_per *per = (const struct cfg_per *)((const char *)into + k->off);

			for (int m = 0; m < (int)k->max; m++)
				if (per[m].key[0]) {
					fprintf(out, "%s = %s", per[m].key, per[m].value);
					print_origin(out, c, from, per[m].key);
				}
			continue;
		}
		fprintf(out, "%s = ", k->name);
		print_value(out, k, into);
		print_origin(out, c, from, k->name);
	}
}

void config_print(const struct config *c, FILE *out)
{
	char full[CFG_NAME_MAX + 16];

	fprintf(out, "; effective configuration, from:");
	for (int i = 0; i < c->n_files; i++)
		fprintf(out, " %s", c->files[i]);
	fputc('\n', out);
	print_section(out, c, S_DAEMON, "daemon", "daemon", NULL, (void *)&c->daemon, NULL);
	for (int i = 0; i < c->n_sources; i++) {
		const struct cfg_source *s = &c->source[i];

		snprintf(full, sizeof(full), "source %s", s->name);
		print_section(out, c, S_SOURCE, full, full, cfg_source_type(s->driver), (void *)s, s->opt);
	}
	for (int i = 0; i < c->n_avatars; i++) {
		const struct cfg_avatar *a = &c->avatar[i];
		char from[CFG_NAME_MAX + 16];

		snprintf(full, sizeof(full), "avatar %s", a->name);
		snprintf(from, sizeof(from), "avatar %s", a->section);
		print_section(out, c, S_AVATAR, full, from, NULL, (void *)a, NULL);
		fprintf(out, "id = %u\n", a->id);
		for (int r = 0; r < 3; r++) {
			const struct cfg_source *s = &c->source[a->sensor[r].source];
			char nm[CFG_NAME_MAX * 2], w[CFG_PATH_MAX + 16];

			cfg_source_type(s->driver)->sensor_name(s, a->sensor[r].sensor, nm, sizeof(nm));
			fprintf(out, "%s = %s/%s    ; %s\n", cfg_sensor_roles[r], s->name, nm,
				config_where(c, a->sensor[r].where, w, sizeof(w)));
		}
	}
	for (int i = 0; i < c->n_outputs; i++) {
		const struct cfg_output *o = &c->output[i];

		snprintf(full, sizeof(full), "output %s", o->name);
		print_section(out, c, S_OUTPUT, full, full, cfg_output_type(o->type), (void *)o, o->opt);
	}
	if (c->site.present)
		print_section(out, c, S_SITE, "site", "site", NULL, (void *)&c->site, NULL);
}

static const char *kind_names[] = {
	[CFG_INT] = "int",	[CFG_U32] = "u32",     [CFG_DOUBLE] = "number", [CFG_DEG] = "degrees",
	[CFG_BOOL] = "bool",	[CFG_ENUM] = "enum",   [CFG_STR] = "string",	[CFG_PATH] = "path",
	[CFG_VEC3] = "vec3",	[CFG_RANGE] = "range", [CFG_SENSOR] = "sensor", [CFG_PERSON] = "person",
	[CFG_LIST] = "avatars", [CFG_MOUNT] = "mount", [CFG_NAMES] = "names",	[CFG_AXES] = "axes",
	[CFG_PER] = "per-key",
};

static bool same_str(const char *a, const char *b)
{
	return a == b || (a && b && !strcmp(a, b));
}

/* two types' keys that print as one line of --keys */
static bool same_key(const struct cfg_key *a, const struct cfg_key *b)
{
	return !strcmp(a->name, b->name) && a->kind == b->kind && a->min == b->min && a->max == b->max &&
	       same_str(a->def, b->def) && same_str(a->unit, b->unit) && same_str(a->doc, b->doc) &&
	       a->enums == b->enums;
}

/* name, default, unit, types, doc, then kind, min, max and the enum's words */
static void print_key(FILE *out, const struct cfg_key *k, const char *types, const char *doc)
{
	fprintf(out, "%s\t%s\t%s\t%s\t%s\t%s\t%.10g\t%.10g\t", k->name, k->def ? k->def : "(required)",
		k->unit ? k->unit : "-", types, doc ? doc : k->doc, kind_names[k->kind], k->min, k->max);
	for (int i = 0; k->enums && k->enums[i]; i++)
		fprintf(out, "%s%s", i ? " " : "", k->enums[i]);
	fputc('\n', out);
}

/* the i-th key of type t (shared ones first), or NULL */
static const struct cfg_key *type_key(const struct cfg_type *t, int i)
{
	if (i < t->n_shared)
		return &t->shared[i];
	i -= t->n_shared;
	return i < t->n_keys ? &t->keys[i] : NULL;
}

/* a section kind's reference: its common keys, then each key of its types once, with the types that take it */
static void print_kind(FILE *out, int sect, const struct cfg_type *(*type)(int i))
{
	char doc[2048], types[512];
	size_t n = 0;

	fprintf(out, "[%s%s]\n", sect_names[sect], sect == S_DAEMON || sect == S_SITE ? "" : " NAME");
	doc[0] = '\0';
	for (int t = 0; type && type(t); t++)
		n += (size_t)snprintf(doc + n, n < sizeof(doc) ? sizeof(doc) - n : 0, "%s%s (%s%s)", t ? ", " : "",
				      type(t)->name, type(t)->doc,
				      type(t)->built ? "" : "; not built into this daemon");
	for (int i = 0; i < common[sect].n; i++) {
		const struct cfg_key *k = &common[sect].keys[i];

		print_key(out, k, "all", type && !strcmp(k->name, "type") ? doc : NULL);
	}
	for (int t = 0; type && type(t); t++) {
		const struct cfg_key *k, *o;

		for (int i = 0; (k = type_key(type(t), i)); i++) {
			bool printed = false;

			for (int u = 0; u < t && !printed; u++)
				for (int j = 0; (o = type_key(type(u), j)) && !printed; j++)
					printed = same_key(k, o);
			if (printed)
				continue;
			n = 0;
			types[0] = '\0';
			for (int u = t; type(u); u++)
				for (int j = 0; (o = type_key(type(u), j)); j++)
					if (same_key(k, o) && n < sizeof(types))
						n += (size_t)snprintf(types + n, sizeof(types) - n, "%s%s",
								      n ? " " : "", type(u)->name);
			print_key(out, k, types, NULL);
		}
	}
}

void config_print_reference(FILE *out)
{
	print_kind(out, S_DAEMON, NULL);
	print_kind(out, S_SOURCE, cfg_source_type);
	print_kind(out, S_AVATAR, NULL);
	print_kind(out, S_OUTPUT, cfg_output_type);
	print_kind(out, S_SITE, NULL);
}
