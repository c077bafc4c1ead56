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
#include "trackers/tracker.h"

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

enum sect { S_DAEMON, S_SOURCE, S_AVATAR, S_OUTPUT, S_COUNT };
static const char *const sect_names[S_COUNT] = { "daemon", "source", "avatar", "output" };

enum kind {
	K_INT,
	K_U32,
	K_DOUBLE,
	K_DEG, /* degrees in the file, radians in memory */
	K_BOOL,
	K_ENUM,
	K_STR,
	K_PATH,
	K_VEC3,
	K_RANGE,  /* two numbers in degrees: lo hi */
	K_SENSOR, /* SOURCE/SENSOR */
	K_PERSON, /* SOURCE[/PREFIX]: head, left_hand, right_hand at once */
	K_LIST,	  /* avatar names, or all */
	K_MOUNT,  /* mount_SENSOR: x y z [qw qx qy qz], one key per sensor */
	K_NAMES,  /* sensor names separated by spaces, "-" for none */
};

static const char *const e_mode[] = { "deadline", "events", NULL };
static const char *const e_log[] = { "err", "warning", "info", "debug", NULL };
static const char *const e_solver[] = { "dq", "matrix", NULL };
static const char *const e_out[] = { "udp",  "multicast", "tcp",    "unix",	 "modbus", "can",
				     "vrpn", "vmc",	  "vrchat", "websocket", NULL };
static const char *const e_word[] = { "abcd", "cdab", "badc", "dcba", NULL };
static const char *const e_regtype[] = { "holding", "input", NULL };
static const char *const e_regfmt[] = { "int16", "uint16", "int32", "uint32", "float32", NULL };
static const char *const e_ori[] = { "rotvec", "quat_wxyz", "quat_xyzw", "rpy", "none", NULL };
static const char *const e_quat[] = { "wxyz", "xyzw", NULL };
static const char *const e_interp[] = { "none", "linear", "catmull-rom", "natural", NULL };
static const char *const e_model[] = { "auto", "liberty", "liberty_hs", "patriot", "patriot_hs", NULL };

struct key_def {
	int sect;
	const char *name;
	int kind;
	size_t off, off2;
	double min, max;
	const char *def; /* NULL: required (or, for sensors, given by person) */
	const char *unit;
	const char *const *enums;
	const char *only; /* source: drivers, output: types that take the key; NULL = all */
	const char *doc;
};

#define D(f) offsetof(struct cfg_daemon, f)
#define SRC(f) offsetof(struct cfg_source, f)
#define AV(f) offsetof(struct cfg_avatar, f)
#define OUT(f) offsetof(struct cfg_output, f)

static const struct key_def keys[] = {
	{ S_DAEMON, "rate", K_DOUBLE, D(rate), 0, 1, 4000, "240", "Hz", NULL, NULL,
	  "avatars solved and published per second (deadline mode)" },
	{ S_DAEMON, "mode", K_ENUM, D(mode), 0, 0, 0, "deadline", NULL, e_mode, NULL,
	  "deadline: a cycle at every period, to absolute deadlines; events: a cycle when a source has new samples" },
	{ S_DAEMON, "stale_ms", K_DOUBLE, D(stale_ms), 0, 1, 60000, "100", "ms", NULL, NULL,
	  "a sensor without a new sample for this long is STALE" },
	{ S_DAEMON, "realtime_priority", K_INT, D(realtime_priority), 0, 0, 99, "0", NULL, NULL, NULL,
	  "SCHED_FIFO priority of the loop thread, 0 = normal scheduling" },
	{ S_DAEMON, "cpu", K_INT, D(cpu), 0, -1, 1023, "-1", NULL, NULL, NULL,
	  "pin the loop thread to this CPU, -1 = no pinning" },
	{ S_DAEMON, "busy_wait", K_BOOL, D(busy_wait), 0, 0, 0, "no", NULL, NULL, NULL,
	  "the loop spins to each deadline instead of sleeping: a whole CPU for the lowest latency (deadline mode)" },
	{ S_DAEMON, "lock_memory", K_BOOL, D(lock_memory), 0, 0, 0, "yes", NULL, NULL, NULL,
	  "mlockall() at start-up so that the loop never page-faults" },
	{ S_DAEMON, "control_socket", K_PATH, D(control_socket), 0, 0, 0, "auto", NULL, NULL, NULL,
	  "Unix socket of avatargw-ctl; auto = $RUNTIME_DIRECTORY/control, else $XDG_RUNTIME_DIR/avatargw.control, "
	  "else /tmp/avatargw-UID.control; empty = none" },
	{ S_DAEMON, "describe_interval", K_DOUBLE, D(describe_interval), 0, 0.1, 3600, "1", "s", NULL, NULL,
	  "period of the DESCRIBE messages (also sent when an avatar's description changes)" },
	{ S_DAEMON, "log_level", K_ENUM, D(log_level), 0, 0, 0, "info", NULL, e_log, NULL,
	  "least important messages logged" },
	{ S_DAEMON, "record_dir", K_PATH, D(record_dir), 0, 0, 0, "", NULL, NULL, NULL,
	  "record every sensor sample into files in this directory (created if missing); empty = no recording" },
	{ S_DAEMON, "record_messages", K_BOOL, D(record_messages), 0, 0, 0, "no", NULL, NULL, NULL,
	  "also record every published message (FRAME and DESCRIBE)" },
	{ S_DAEMON, "record_flush", K_DOUBLE, D(record_flush), 0, 0, 3600, "1", "s", NULL, NULL,
	  "write what was recorded at least this often: a crash or kill -9 loses at most this much" },
	{ S_DAEMON, "record_flush_records", K_INT, D(record_flush_records), 0, 0, 100000, "0", NULL, NULL, NULL,
	  "also write after this many records, 0 = by time only" },
	{ S_DAEMON, "record_fsync", K_BOOL, D(record_fsync), 0, 0, 0, "no", NULL, NULL, NULL,
	  "fdatasync after every write, so that a power loss loses no more than record_flush either" },
	{ S_DAEMON, "record_rotate_size", K_DOUBLE, D(record_rotate_size), 0, 0, 100000, "0", "MiB", NULL, NULL,
	  "start a new file when this one would grow past this size, 0 = never" },
	{ S_DAEMON, "record_rotate_time", K_DOUBLE, D(record_rotate_time), 0, 0, 604800, "0", "s", NULL, NULL,
	  "start a new file when this one is this old, 0 = never" },
	{ S_DAEMON, "record_buffer", K_INT, D(record_buffer), 0, 64, 262144, "1024", "KiB", NULL, NULL,
	  "buffer between the loop and the writer thread; a record that does not fit is dropped and counted" },
	{ S_DAEMON, "record_keyframe_rate", K_DOUBLE, D(record_keyframe_rate), 0, 0, 10000, "0", "Hz", NULL, NULL,
	  "keep at most this many samples per second of each sensor (the paper's low-rate storage), 0 = every sample" },

	{ S_SOURCE, "type", K_STR, 0, 0, 0, 0, NULL, NULL, NULL, NULL,
	  "the driver: sim, replay, hydra (Razer Hydra), polhemus (Liberty, Liberty HS, Patriot), modbus or can" },
	{ S_SOURCE, "origin", K_VEC3, SRC(origin), 0, -1e4, 1e4, "0 0 0", "m", NULL, NULL,
	  "position of the tracker's frame in the world (x y z)" },
	{ S_SOURCE, "yaw", K_DEG, SRC(yaw), 0, -360, 360, "0", "deg", NULL, NULL,
	  "rotation of the tracker's frame about the world's z axis" },
	{ S_SOURCE, "people", K_INT, SRC(people), 0, 1, CFG_MAX_AVATARS, "1", NULL, NULL, "sim",
	  "simulated people; their sensors are pN.head, pN.left_hand, pN.right_hand" },
	{ S_SOURCE, "seed", K_U32, SRC(seed), 0, 0, 4294967295.0, "1", NULL, NULL, "sim",
	  "seed of the motion (same seed, same motion)" },
	{ S_SOURCE, "sample_rate", K_DOUBLE, SRC(sample_rate), 0, 1, 4000, "240", "Hz", NULL, "sim replay",
	  "sensor samples per second (replay: made between keyframes when interpolate is set)" },
	{ S_SOURCE, "spacing", K_DOUBLE, SRC(spacing), 0, 0, 100, "1", "m", NULL, "sim",
	  "distance between simulated people along x" },
	{ S_SOURCE, "file", K_PATH, SRC(file), 0, 0, 0, NULL, NULL, NULL, "replay",
	  "a recording of avatargw (record_dir) or a sensor CSV (columns t, head_x..head_qz, lhand_*, rhand_*), "
	  "relative to this file's directory; builtin:NAME for a clip compiled into the daemon" },
	{ S_SOURCE, "speed", K_DOUBLE, SRC(speed), 0, 0.01, 100, "1", NULL, NULL, "replay hydra polhemus",
	  "playback speed of the recording or capture, 1 = real time" },
	{ S_SOURCE, "loop", K_BOOL, SRC(loop), 0, 0, 0, "yes", NULL, NULL, "replay hydra polhemus",
	  "start the recording or capture again at its end; otherwise the source ENDS and its sensors go STALE" },
	{ S_SOURCE, "start", K_DOUBLE, SRC(start), 0, 0, 1e6, "0", "s", NULL, "replay",
	  "begin this far into the recording" },
	{ S_SOURCE, "address", K_STR, SRC(address), 0, 0, 0, NULL, NULL, NULL, "modbus",
	  "host name or address of the Modbus TCP device (required)" },
	{ S_SOURCE, "port", K_INT, SRC(port), 0, 1, 65535, "502", NULL, NULL, "modbus",
	  "TCP port of the Modbus device" },
	{ S_SOURCE, "unit_id", K_INT, SRC(unit_id), 0, 0, 255, "1", NULL, NULL, "modbus",
	  "Modbus unit identifier of the requests" },
	{ S_SOURCE, "register_type", K_ENUM, SRC(register_type), 0, 0, 0, "holding", NULL, e_regtype, "modbus",
	  "holding (function 3) or input (function 4) registers" },
	{ S_SOURCE, "sensors", K_INT, SRC(sensors), 0, 1, 16, "1", NULL, NULL, "modbus can",
	  "poses the device reports; they are sensors pose0, pose1, ..." },
	{ S_SOURCE, "sensor_stride", K_INT, SRC(sensor_stride), 0, 0, 65535, "0", NULL, NULL, "modbus",
	  "registers from one sensor's position (and orientation) to the next's; needed when sensors > 1" },
	{ S_SOURCE, "position_register", K_INT, SRC(pos_register), 0, 0, 65535, "0", NULL, NULL, "modbus",
	  "first register of the position x, y, z (0-based protocol address)" },
	{ S_SOURCE, "position_format", K_ENUM, SRC(pos_format), 0, 0, 0, "int16", NULL, e_regfmt, "modbus",
	  "type of each position value (32-bit types take two registers)" },
	{ S_SOURCE, "position_scale", K_DOUBLE, SRC(pos_scale), 0, 1e-9, 1e3, "0.001", "m", NULL, "modbus can",
	  "metres per count of a position value (0.0001 for 0.1 mm)" },
	{ S_SOURCE, "orientation_register", K_INT, SRC(ori_register), 0, 0, 65535, "3", NULL, NULL, "modbus",
	  "first register of the orientation values (0-based protocol address)" },
	{ S_SOURCE, "orientation_format", K_ENUM, SRC(ori_format), 0, 0, 0, "int16", NULL, e_regfmt, "modbus",
	  "type of each orientation value" },
	{ S_SOURCE, "orientation_scale", K_DOUBLE, SRC(ori_scale), 0, 1e-12, 1e3, "0.001", NULL, NULL, "modbus",
	  "radians per count (rotvec, rpy) or quaternion units per count (quat_*)" },
	{ S_SOURCE, "orientation", K_ENUM, SRC(orientation), 0, 0, 0, "rotvec", NULL, e_ori, "modbus",
	  "rotvec (rx ry rz, axis times angle), quat_wxyz, quat_xyzw, rpy (roll pitch yaw about fixed x, y, z) or "
	  "none" },
	{ S_SOURCE, "word_order", K_ENUM, SRC(word_order), 0, 0, 0, "abcd", NULL, e_word, "modbus",
	  "byte order of 32-bit values over two registers, A = most significant byte" },
	{ S_SOURCE, "poll_rate", K_DOUBLE, SRC(poll_rate), 0, 0.1, 1000, "50", "Hz", NULL, "modbus",
	  "requests per second" },
	{ S_SOURCE, "timeout_ms", K_DOUBLE, SRC(timeout_ms), 0, 1, 60000, "200", "ms", NULL, "modbus",
	  "a response (or a connection) taking longer fails; the connection is then made again" },
	{ S_SOURCE, "interface", K_STR, SRC(interface), 0, 0, 0, NULL, NULL, NULL, "can",
	  "SocketCAN interface (can0), or fd:N for an inherited descriptor (required)" },
	{ S_SOURCE, "orientation_id", K_INT, SRC(ori_id), 0, 0, 536870911, "0x200", NULL, NULL, "can",
	  "CAN identifier of sensor 0's orientation frame; sensor k uses orientation_id + k" },
	{ S_SOURCE, "position_id", K_INT, SRC(pos_id), 0, -1, 536870911, "0x280", NULL, NULL, "can",
	  "CAN identifier of sensor 0's position frame; sensor k uses position_id + k; -1: orientation only" },
	{ S_SOURCE, "quaternion_scale", K_DOUBLE, SRC(quat_scale), 0, 1, 1e9, "32768", NULL, NULL, "can",
	  "the count that stands for 1.0 in a quaternion component (16384 for a BNO055)" },
	{ S_SOURCE, "quaternion_order", K_ENUM, SRC(quat_order), 0, 0, 0, "wxyz", NULL, e_quat, "can",
	  "order of the four components in the orientation frame" },
	{ S_SOURCE, "extended_ids", K_BOOL, SRC(extended_ids), 0, 0, 0, "no", NULL, NULL, "can",
	  "29-bit CAN identifiers instead of 11-bit" },
	{ S_SOURCE, "step", K_BOOL, SRC(step), 0, 0, 0, "no", NULL, NULL, "replay",
	  "stepped: play the first instant, then one more per 'avatargw-ctl step' (speed is ignored)" },
	{ S_SOURCE, "interpolate", K_ENUM, SRC(interpolate), 0, 0, 0, "none", NULL, e_interp, "replay",
	  "treat the samples as keyframes and rebuild sample_rate samples per second between them: "
	  "linear (and slerp), catmull-rom or natural (cubic splines, and squad)" },
	{ S_SOURCE, "device", K_STR, SRC(device), 0, 0, 0, "auto", NULL, NULL, "hydra polhemus",
	  "which device: auto (the first found); hydra: a hidraw node of its motion interface (/dev/hidraw3, "
	  "or a udev symlink) or its USB port; polhemus: its USB port; a USB port is BUS-PORT[.PORT...] as "
	  "avatargw --list-devices shows it" },
	{ S_SOURCE, "capture", K_PATH, SRC(capture), 0, 0, 0, "", NULL, NULL, "hydra polhemus",
	  "play this capture of raw reports (hex, one report per line) instead of reading the device; "
	  "relative to this file's directory; empty = the device" },
	{ S_SOURCE, "record", K_PATH, SRC(record), 0, 0, 0, "", NULL, NULL, "hydra polhemus",
	  "write every raw report read from the device to this capture file, with timestamps (for a bug report "
	  "or a test; avatargw-decode reads it); relative to this file's directory; empty = none" },
	{ S_SOURCE, "interface", K_INT, SRC(hid_interface), 0, 0, 255, "0", NULL, NULL, "hydra",
	  "USB interface number of the 52-byte motion reports" },
	{ S_SOURCE, "control_interface", K_INT, SRC(control_interface), 0, 0, 255, "1", NULL, NULL, "hydra",
	  "USB interface number that takes the feature report switching between gamepad and motion mode" },
	{ S_SOURCE, "model", K_ENUM, SRC(model), 0, 0, 0, "auto", NULL, e_model, "polhemus",
	  "which Polhemus product to open: auto (any of them) or one; it sets the expected record header and rate" },
	{ S_SOURCE, "sensors", K_NAMES, SRC(stations), 0, 1, CFG_MAX_STATIONS, "head left_hand right_hand", NULL, NULL,
	  "polhemus", "sensor names of stations 1, 2, 3, ... in order (- skips a station)" },
	{ S_SOURCE, "hemisphere", K_VEC3, SRC(hemisphere), 0, -1, 1, "1 0 0", NULL, NULL, "polhemus",
	  "the hemisphere the sensors stay in, a vector in the Polhemus source's frame (its H command)" },
	{ S_SOURCE, "mount_SENSOR", K_MOUNT, 0, 0, -10, 10, "0 0 0", "m", NULL, NULL,
	  "SENSOR's tracked point in the sensor's own frame: x y z, optionally followed by a rotation "
	  "qw qx qy qz (a head sensor on glasses is not the head's centre); one key per sensor" },

	{ S_AVATAR, "id", K_INT, AV(id), 0, 0, 65535, "auto", NULL, NULL, NULL,
	  "avatar id on the wire (auto: one more than the previous avatar's)" },
	{ S_AVATAR, "count", K_INT, 0, 0, 1, CFG_MAX_AVATARS, "1", NULL, NULL, NULL,
	  "this many avatars from consecutive people (person = SOURCE/p0 -> p0, p1, ...), ids counting up" },
	{ S_AVATAR, "person", K_PERSON, 0, 0, 0, 0, "", NULL, NULL, NULL,
	  "SOURCE or SOURCE/PREFIX: head, left_hand and right_hand are PREFIX.head, ... of that source" },
	{ S_AVATAR, "head", K_SENSOR, 0, 0, 0, 0, NULL, NULL, NULL, NULL, "head sensor, SOURCE/SENSOR" },
	{ S_AVATAR, "left_hand", K_SENSOR, 1, 0, 0, 0, NULL, NULL, NULL, NULL, "left hand sensor, SOURCE/SENSOR" },
	{ S_AVATAR, "right_hand", K_SENSOR, 2, 0, 0, 0, NULL, NULL, NULL, NULL, "right hand sensor, SOURCE/SENSOR" },
	{ S_AVATAR, "shoulder", K_DOUBLE, AV(dims[0]), 0, 0.01, 1, "0.1732", "m", NULL, NULL,
	  "chest centre to shoulder joint (the paper's Shoulder)" },
	{ S_AVATAR, "upper_arm", K_DOUBLE, AV(dims[1]), 0, 0.05, 1, "0.2886", "m", NULL, NULL, "shoulder to elbow" },
	{ S_AVATAR, "forearm", K_DOUBLE, AV(dims[2]), 0, 0.05, 1, "0.1955", "m", NULL, NULL, "elbow to wrist" },
	{ S_AVATAR, "hand", K_DOUBLE, AV(dims[3]), 0, 0, 0.5, "0", "m", NULL, NULL,
	  "wrist to the hand sensor, along the hand" },
	{ S_AVATAR, "head_offset", K_VEC3, AV(head_offset), 0, -1, 1, "0.008 -0.0386 0.0967", "m", NULL, NULL,
	  "head sensor from the chest centre, in the chest frame (x right, y forward, z up; the paper: 0 0 Neck)" },
	{ S_AVATAR, "j1", K_RANGE, AV(lo[0]), AV(hi[0]), -180, 180, "-30 30", "deg", NULL, NULL,
	  "limits of J1, shoulder girdle / chest yaw" },
	{ S_AVATAR, "j2", K_RANGE, AV(lo[1]), AV(hi[1]), -180, 180, "-120 10", "deg", NULL, NULL,
	  "limits of J2, shoulder abduction (-) / adduction (+)" },
	{ S_AVATAR, "j3", K_RANGE, AV(lo[2]), AV(hi[2]), -180, 180, "-60 120", "deg", NULL, NULL,
	  "limits of J3, shoulder extension (-) / flexion (+)" },
	{ S_AVATAR, "j4", K_RANGE, AV(lo[3]), AV(hi[3]), -180, 180, "-90 90", "deg", NULL, NULL,
	  "limits of J4, humeral rotation" },
	{ S_AVATAR, "j5", K_RANGE, AV(lo[4]), AV(hi[4]), -180, 180, "-90 60", "deg", NULL, NULL,
	  "limits of J5, elbow (anatomical flexion = 90 deg + J5)" },
	{ S_AVATAR, "j6", K_RANGE, AV(lo[5]), AV(hi[5]), -180, 180, "-90 90", "deg", NULL, NULL,
	  "limits of J6, forearm pronation / supination" },
	{ S_AVATAR, "j7", K_RANGE, AV(lo[6]), AV(hi[6]), -180, 180, "-30 30", "deg", NULL, NULL,
	  "limits of J7, wrist deviation (about the hand's x axis, across the palm)" },
	{ S_AVATAR, "j8", K_RANGE, AV(lo[7]), AV(hi[7]), -180, 180, "-80 80", "deg", NULL, NULL,
	  "limits of J8, wrist flexion (+) / extension (-) (about the hand's z axis, the thumb's)" },
	{ S_AVATAR, "solver", K_ENUM, AV(solver), 0, 0, 0, "dq", NULL, e_solver, NULL,
	  "kinematics of the IK: dual quaternions or 4x4 matrices" },
	{ S_AVATAR, "ik_max_iterations", K_INT, AV(max_iter), 0, 1, 200, "20", NULL, NULL, NULL,
	  "Newton iterations at most per arm and frame" },
	{ S_AVATAR, "ik_tolerance", K_DOUBLE, AV(tol_mm), 0, 1e-4, 10, "0.01", "mm", NULL, NULL,
	  "position error at which an arm counts as reached" },
	{ S_AVATAR, "ik_tolerance_rot", K_DOUBLE, AV(tol_rot_deg), 0, 1e-5, 10, "0.01", "deg", NULL, NULL,
	  "hand orientation error at which an arm counts as reached" },
	{ S_AVATAR, "ik_max_evals", K_INT, AV(max_evals), 0, 16, 100000, "800", NULL, NULL, NULL,
	  "closed-form search: postures evaluated at most (bounds the worst-case time)" },
	{ S_AVATAR, "ik_warm_iterations", K_INT, AV(warm_iter), 0, 0, 100, "6", NULL, NULL, NULL,
	  "Newton iterations tried from the previous frame before the closed-form search" },

	{ S_OUTPUT, "type", K_ENUM, OUT(type), 0, 0, 0, NULL, NULL, e_out, NULL,
	  "udp (unicast), multicast, tcp or unix (streams: u32 length + message), modbus (a Modbus TCP server), "
	  "can (SocketCAN frames); vrpn (a VRPN server), vmc or vrchat (OSC), websocket (JSON frames and the browser "
	  "viewer)" },
	{ S_OUTPUT, "address", K_STR, OUT(address), 0, 0, 0, "127.0.0.1", NULL, NULL, "udp multicast tcp modbus",
	  "udp: destination host; multicast: group (239.255.77.70 or ff15::7770 style); tcp, modbus: listen address" },
	{ S_OUTPUT, "port", K_INT, OUT(port), 0, 1, 65535, "7770", NULL, NULL, "udp multicast tcp modbus",
	  "UDP destination port or TCP listening port (modbus: required)" },
	{ S_OUTPUT, "interface", K_STR, OUT(interface), 0, 0, 0, "", NULL, NULL, "multicast can",
	  "multicast: network interface (empty: the kernel's choice); can: CAN interface or fd:N (required)" },
	{ S_OUTPUT, "address", K_STR, OUT(address), 0, 0, 0, "0.0.0.0", NULL, NULL, "vrpn",
	  "listen address for TCP connections and UDP connection requests (0.0.0.0: every IPv4 interface, ::: every "
	  "interface)" },
	{ S_OUTPUT, "address", K_STR, OUT(address), 0, 0, 0, "127.0.0.1", NULL, NULL, "vmc vrchat websocket",
	  "vmc, vrchat: destination host; websocket: listen address (any other address shows the viewer to the "
	  "network)" },
	{ S_OUTPUT, "port", K_INT, OUT(port), 0, 1, 65535, "3883", NULL, NULL, "vrpn",
	  "TCP and UDP port of the VRPN server (clients name it as NAME@host:port when it is not 3883)" },
	{ S_OUTPUT, "port", K_INT, OUT(port), 0, 1, 65535, "39539", NULL, NULL, "vmc",
	  "UDP destination port of the VMC marionette" },
	{ S_OUTPUT, "port", K_INT, OUT(port), 0, 1, 65535, "9000", NULL, NULL, "vrchat",
	  "UDP port VRChat listens on for OSC" },
	{ S_OUTPUT, "port", K_INT, OUT(port), 0, 1, 65535, "7780", NULL, NULL, "websocket",
	  "TCP port of the viewer page (HTTP) and its WebSocket" },
	{ S_OUTPUT, "ttl", K_INT, OUT(ttl), 0, 0, 255, "1", NULL, NULL, "multicast", "multicast hop limit" },
	{ S_OUTPUT, "loopback", K_BOOL, OUT(mcast_loop), 0, 0, 0, "yes", NULL, NULL, "multicast",
	  "deliver multicast to listeners on this host too" },
	{ S_OUTPUT, "gso", K_BOOL, OUT(gso), 0, 0, 0, "yes", NULL, NULL, "udp multicast",
	  "send runs of equal-length messages as one buffer the kernel cuts into datagrams (UDP_SEGMENT); off by "
	  "itself where refused" },
	{ S_OUTPUT, "path", K_PATH, OUT(path), 0, 0, 0, "/run/avatargw/stream", NULL, NULL, "unix",
	  "Unix socket path to listen on" },
	{ S_OUTPUT, "max_clients", K_INT, OUT(max_clients), 0, 1, 256, "8", NULL, NULL,
	  "tcp unix modbus vrpn websocket",
	  "stream subscribers (Modbus, VRPN, WebSocket clients) at most; more are refused" },
	{ S_OUTPUT, "client_buffer", K_INT, OUT(client_buffer), 0, 4096, 16777216, "65536", "bytes", NULL,
	  "tcp unix vrpn", "per-subscriber buffer; messages that do not fit are dropped and counted" },
	{ S_OUTPUT, "device", K_STR, OUT(device), 0, 0, 0, "Avatar%d", NULL, NULL, "vrpn",
	  "VRPN device name of each avatar, %d = its id: clients open Avatar0@host (tracker, analog and button)" },
	{ S_OUTPUT, "udp", K_BOOL, OUT(udp), 0, 0, 0, "yes", NULL, NULL, "vrpn",
	  "tracker and analog reports over UDP to clients that offer a UDP port (VRPN's low-latency class); no: all "
	  "over TCP" },
	{ S_OUTPUT, "client_timeout", K_DOUBLE, OUT(client_timeout), 0, 0.1, 3600, "5", "s", NULL, "vrpn",
	  "a client that has not finished its handshake, or whose buffer stays full, this long is dropped" },
	{ S_OUTPUT, "rate", K_DOUBLE, OUT(rate), 0, 1, 240, "60", "Hz", NULL, "vmc vrchat",
	  "OSC bundles per second (the newest frame each time)" },
	{ S_OUTPUT, "rate", K_DOUBLE, OUT(rate), 0, 1, 60, "30", "Hz", NULL, "websocket",
	  "JSON frames per second to each browser (the newest frame of each avatar each time)" },
	{ S_OUTPUT, "torso", K_DOUBLE, OUT(torso), 0, 0.1, 1.5, "0.5", "m", NULL, "vmc",
	  "shoulder line to hips: places the Hips bone below the tracked chest" },
	{ S_OUTPUT, "head", K_BOOL, OUT(head), 0, 0, 0, "yes", NULL, NULL, "vrchat",
	  "also send the head pose (/tracking/trackers/head/*), which VRChat uses to align our space with its own" },
	{ S_OUTPUT, "www", K_PATH, OUT(www), 0, 0, 0, "auto", NULL, NULL, "websocket",
	  "directory of the viewer page; auto = $AVATARGW_WWW, else ../share/avatargw/www or ../www beside the "
	  "program" },
	{ S_OUTPUT, "three", K_PATH, OUT(three), 0, 0, 0, "/usr/share/javascript/three", NULL, NULL, "websocket",
	  "directory of three.js (Debian's libjs-three), served as /three/" },
	{ S_OUTPUT, "decimate", K_INT, OUT(decimate), 0, 1, 1000, "1", NULL, NULL, NULL, "publish every n-th frame" },
	{ S_OUTPUT, "register_base", K_INT, OUT(reg_base), 0, 0, 65535, "0", NULL, NULL, "modbus",
	  "input register (0-based) where the first avatar's block starts (docs/MODBUS.md)" },
	{ S_OUTPUT, "register_stride", K_INT, OUT(reg_stride), 0, 66, 65536, "100", NULL, NULL, "modbus",
	  "registers from one avatar's block to the next's (a block uses 66)" },
	{ S_OUTPUT, "word_order", K_ENUM, OUT(word_order), 0, 0, 0, "abcd", NULL, e_word, "modbus",
	  "byte order of 32-bit values over two registers, A = most significant byte" },
	{ S_OUTPUT, "writable_registers", K_INT, OUT(writable_regs), 0, 0, 10000, "0", NULL, NULL, "modbus",
	  "holding registers clients may write and read back (the daemon acts on none); 0: writes refused" },
	{ S_OUTPUT, "idle_timeout", K_DOUBLE, OUT(idle_timeout), 0, 0, 86400, "60", "s", NULL, "modbus",
	  "a client that sends no request for this long is disconnected; 0: never" },
	{ S_OUTPUT, "base_id", K_INT, OUT(base_id), 0, 0, 536870911, "0x100", NULL, NULL, "can",
	  "CAN identifier of the first avatar's status frame; its joint frames follow (docs/CAN.md)" },
	{ S_OUTPUT, "extended_ids", K_BOOL, OUT(extended_ids), 0, 0, 0, "no", NULL, NULL, "can",
	  "29-bit CAN identifiers instead of 11-bit" },
	{ S_OUTPUT, "safe", K_BOOL, OUT(safe), 0, 0, 0, "yes", NULL, NULL, "can",
	  "clamp to the joint limits, limit the speed, send nothing stale, held, unreached or unknown" },
	{ S_OUTPUT, "max_speed", K_DEG, OUT(max_speed), 0, 1, 3600, "90", "deg/s", NULL, "can",
	  "safe mode: fastest change of any joint's command" },
	{ S_OUTPUT, "avatars", K_LIST, OUT(avatar_list), 0, 0, 0, "all", NULL, NULL, NULL,
	  "avatar names to publish (space separated), or all" },
};

#define N_KEYS (sizeof(keys) / sizeof(keys[0]))

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

/* "a, b or c" (last: " or ") or "a, b, c" (last: ", "): the names of a table, for messages */
static void name_list(char *buf, size_t len, const char *(*name)(int i), int n, const char *last)
{
	size_t at = 0;

	buf[0] = '\0';
	for (int i = 0; i < n && at < len; i++)
		at += (size_t)snprintf(buf + at, len - at, "%s%s", i == 0 ? "" : i == n - 1 ? last : ", ", name(i));
}

static const char *driver_name(int i)
{
	return trackers_table[i]->name;
}

static const char *output_name(int i)
{
	return e_out[i];
}

static int output_count(void)
{
	int n = 0;

	while (e_out[n])
		n++;
	return n;
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
	const char *name; /* the section's name after its kind */
	const char *full; /* as written */
	void *obj;
	const char *type; /* source driver or output type name (keys with only) */
	struct cfg_where first;
};

static bool word_in(const char *word, const char *list)
{
	size_t n = strlen(word);

	for (const char *s = list; (s = strstr(s, word)); s += n)
		if ((s == list || s[-1] == ' ') && (s[n] == ' ' || s[n] == '\0'))
			return true;
	return false;
}

/* a key may have one entry per set of types (a port with another default...): the one for type */
static const struct key_def *find_key(int sect, const char *name, const char *type)
{
	const struct key_def *any = NULL;

	for (size_t i = 0; i < N_KEYS; i++) {
		if (keys[i].sect != sect)
			continue;
		/* mount_SENSOR: the key's name ends in a sensor's name */
		if (strcmp(keys[i].name, name) && !(keys[i].kind == K_MOUNT && !strncmp(name, "mount_", 6) && name[6]))
			continue;
		if (!keys[i].only || (type && word_in(type, keys[i].only)))
			return &keys[i];
		any = any ? any : &keys[i];
	}
	return any;
}

/* mount_SENSOR = x y z [qw qx qy qz] */
static int set_mount(struct section_ctx *s, const struct key_def *k, const char *key, const char *value,
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
		const struct tracker_driver *d = trackers_table[src->driver];
		int cnt = d->sensor_count(src);
		char names[256], nm[CFG_NAME_MAX * 2];
		size_t n = 0;

		if (tracker_sensor_lookup(src, m->sensor) >= 0)
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

static void list_keys(int sect, const char *type, char *buf, size_t len)
{
	size_t n = 0;

	buf[0] = '\0';
	for (size_t i = 0; i < N_KEYS && n < len; i++)
		if (keys[i].sect == sect && (!keys[i].only || (type && word_in(type, keys[i].only))))
			n += (size_t)snprintf(buf + n, len - n, "%s%s", n ? ", " : "", keys[i].name);
}

static int set_value(struct section_ctx *s, const struct key_def *k, const char *value, struct cfg_where w)
{
	struct parse *p = s->p;
	char *obj = s->obj;
	double v[3];

	switch (k->kind) {
	case K_INT:
	case K_U32:
	case K_DOUBLE:
	case K_DEG:
		if (!parse_num(value, v))
			return failf(p, w, "[%s] %s: '%s' is not a number", s->full, k->name, value);
		if (v[0] < k->min || v[0] > k->max)
			return failf(p, w, "[%s] %s: %s is out of range [%g, %g]%s%s", s->full, k->name, value, k->min,
				     k->max, k->unit ? " " : "", k->unit ? k->unit : "");
		if ((k->kind == K_INT || k->kind == K_U32) && v[0] != floor(v[0]))
			return failf(p, w, "[%s] %s: '%s' is not a whole number", s->full, k->name, value);
		if (k->kind == K_INT)
			*(int *)(obj + k->off) = (int)v[0];
		else if (k->kind == K_U32)
			*(uint32_t *)(obj + k->off) = (uint32_t)v[0];
		else
			*(double *)(obj + k->off) = k->kind == K_DEG ? v[0] * DEG : v[0];
		return 0;
	case K_BOOL:
		if (!strcasecmp(value, "yes") || !strcasecmp(value, "true") || !strcasecmp(value, "on") ||
		    !strcmp(value, "1"))
			*(bool *)(obj + k->off) = true;
		else if (!strcasecmp(value, "no") || !strcasecmp(value, "false") || !strcasecmp(value, "off") ||
			 !strcmp(value, "0"))
			*(bool *)(obj + k->off) = false;
		else
			return failf(p, w, "[%s] %s: '%s' is not yes or no", s->full, k->name, value);
		return 0;
	case K_ENUM:
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
	case K_STR:
	case K_PATH:
	case K_LIST: {
		size_t cap = k->kind == K_STR && !strcmp(k->name, "interface") ? CFG_NAME_MAX : CFG_PATH_MAX;
		char *dst = obj + k->off;

		if (strlen(value) >= cap)
			return failf(p, w, "[%s] %s: longer than %zu characters", s->full, k->name, cap - 1);
		if (k->kind == K_PATH && value[0] && value[0] != '/' && strncmp(value, "builtin:", 8) &&
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
	case K_VEC3:
		if (!parse_nums(value, v, 3))
			return failf(p, w, "[%s] %s: '%s' is not three numbers (x y z)", s->full, k->name, value);
		for (int i = 0; i < 3; i++) {
			if (v[i] < k->min || v[i] > k->max)
				return failf(p, w, "[%s] %s: %g is out of range [%g, %g] %s", s->full, k->name, v[i],
					     k->min, k->max, k->unit);
			((double *)(obj + k->off))[i] = v[i];
		}
		return 0;
	case K_NAMES: {
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
	case K_RANGE:
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
		return 0; /* K_SENSOR, K_PERSON: resolved by the avatar code */
	}
}

/* the entry of a key in a section, or NULL */
static const struct cfg_entry *entry_of(const struct config *c, const char *section, const char *key)
{
	for (size_t i = 0; i < c->n_entries; i++)
		if (!strcmp(c->entries[i].section, section) && !strcmp(c->entries[i].key, key))
			return &c->entries[i];
	return NULL;
}

/* defaults, then the section's entries; keys of other types are errors */
static int apply_section(struct section_ctx *s)
{
	struct parse *p = s->p;
	const struct config *c = p->c;
	char known[512];

	for (size_t i = 0; i < N_KEYS; i++) {
		const struct key_def *k = &keys[i];

		if (k->sect != s->sect || !k->def || (k->only && !word_in(s->type, k->only)))
			continue;
		if (k->kind == K_SENSOR || k->kind == K_PERSON || k->kind == K_MOUNT || !strcmp(k->name, "count") ||
		    (s->sect == S_SOURCE && !strcmp(k->name, "type")))
			continue;
		if (s->sect == S_AVATAR && !strcmp(k->name, "id"))
			continue;
		if (set_value(s, k, k->def, (struct cfg_where){ -1, 0 }))
			return -1;
	}
	for (size_t i = 0; i < c->n_entries; i++) {
		const struct cfg_entry *e = &c->entries[i];
		const struct key_def *k;

		if (strcmp(e->section, s->full))
			continue;
		k = find_key(s->sect, e->key, s->type);
		if (!k || (k->only && !word_in(s->type, k->only))) {
			list_keys(s->sect, s->type, known, sizeof(known));
			return failf(p, e->where, "[%s] %s: unknown key%s%s%s (known: %s)", s->full, e->key,
				     s->type ? " for type " : "", s->type ? s->type : "", "", known);
		}
		if (k->kind == K_SENSOR || k->kind == K_PERSON || (s->sect == S_AVATAR && !strcmp(k->name, "id")) ||
		    !strcmp(k->name, "count") || (s->sect == S_SOURCE && !strcmp(k->name, "type")))
			continue;
		if (k->kind == K_MOUNT) {
			if (set_mount(s, k, e->key, e->value, e->where))
				return -1;
			continue;
		}
		if (set_value(s, k, e->value, e->where))
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
		out->sensor = tracker_sensor_lookup(src, slash + 1);
		out->where = w;
		if (out->sensor < 0) {
			char names[256], nm[CFG_NAME_MAX * 2];
			size_t n = 0;
			const struct tracker_driver *d = trackers_table[src->driver];
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

/* the identifiers (can) or registers (modbus) of all the output's avatars must exist */
static int check_bus_output(struct parse *p, const char *full, const struct cfg_output *o)
{
	const struct config *c = p->c;
	const struct cfg_entry *t = entry_of(c, full, "type");
	long n = o->n_avatars ? o->n_avatars : c->n_avatars, last;

	if (!n)
		return 0;
	if (o->type == CFG_OUT_CAN) {
		long max = o->extended_ids ? 0x1FFFFFFFL : 0x7FFL;

		last = o->base_id + 8 * (n - 1) + 4; /* 8 identifiers per avatar, 5 used (docs/CAN.md) */
		if (last > max)
			return failf(p, t->where,
				     "[%s] base_id: %ld avatars need identifiers up to 0x%lX, above 0x%lX%s", full, n,
				     last, max, o->extended_ids ? "" : " (extended_ids = yes gives 29 bits)");
	}
	if (o->type == CFG_OUT_MODBUS) {
		last = o->reg_base + (long)o->reg_stride * (n - 1) + 66 -
		       1; /* a block is 66 registers (docs/MODBUS.md) */
		if (last > 65535)
			return failf(p, t->where,
				     "[%s] register_base, register_stride: %ld avatars need registers up "
				     "to %ld, above 65535",
				     full, n, last);
	}
	return 0;
}

/* VMC and VRChat speak for one body: their output names exactly one avatar */
static int one_avatar(struct parse *p, const char *full, const struct cfg_output *o, const struct cfg_entry *t)
{
	const struct cfg_entry *e = entry_of(p->c, full, "avatars");
	int n = o->n_avatars ? o->n_avatars : p->c->n_avatars;

	if ((o->type != CFG_OUT_VMC && o->type != CFG_OUT_VRCHAT) || n == 1)
		return 0;
	return failf(p, e ? e->where : t->where,
		     "[%s] avatars: a %s output carries one avatar, not %d (avatars = NAME)", full, e_out[o->type], n);
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
		struct section_ctx s = { p, S_DAEMON, "", "daemon", &c->daemon, NULL, { -1, 0 } };

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
					return failf(
						p, e->where,
						"[%s]: unknown section (daemon, source NAME, avatar NAME, output NAME)",
						e->section);
				continue;
			}
			if (kind != pass || kind == S_DAEMON) {
				if (kind == S_DAEMON && pass == 0 && name[0])
					return failf(p, e->where, "[%s]: the daemon section has no name", e->section);
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
					char names[160];

					name_list(names, sizeof(names), driver_name, trackers_count, " or ");
					return failf(p, e->where, "[%s] type: missing (%s)", e->section, names);
				}
				src = &c->source[c->n_sources];
				memset(src, 0, sizeof(*src));
				snprintf(src->name, sizeof(src->name), "%s", name);
				src->where = e->where;
				src->driver = trackers_find(t->value);
				if (src->driver < 0) {
					char names[160];

					name_list(names, sizeof(names), driver_name, trackers_count, ", ");
					return failf(p, t->where, "[%s] type: unknown driver '%s' (known: %s)",
						     e->section, t->value, names);
				}
				for (int j = 0; j < c->n_sources; j++)
					if (!strcmp(c->source[j].name, name))
						return failf(p, e->where, "[%s]: source name used twice", e->section);
				s = (struct section_ctx){ p, S_SOURCE, name, e->section, src, t->value, e->where };
				if (apply_section(&s) || check_mounts(p, e->section, src))
					return -1;
				if (trackers_table[src->driver] == &replay_driver && !src->file[0])
					return failf(p, t->where, "[%s] file: missing (the recording to replay)",
						     e->section);
				if (trackers_table[src->driver]->check) {
					char why[256];

					if (trackers_table[src->driver]->check(src, why, sizeof(why))) {
						const struct cfg_entry *fe = entry_of(c, e->section, "file");

						if (!fe)
							fe = entry_of(c, e->section, "capture");

						return failf(p, fe ? fe->where : t->where, "[%s] %s", e->section, why);
					}
				}
				c->n_sources++;
			} else if (kind == S_AVATAR) {
				struct section_ctx s;

				memset(&tmpl, 0, sizeof(tmpl));
				s = (struct section_ctx){ p, S_AVATAR, name, e->section, &tmpl, NULL, e->where };
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
					char names[160];

					name_list(names, sizeof(names), output_name, output_count(), " or ");
					return failf(p, e->where, "[%s] type: missing (%s)", e->section, names);
				}
				o = &c->output[c->n_outputs];
				memset(o, 0, sizeof(*o));
				snprintf(o->name, sizeof(o->name), "%s", name);
				o->where = e->where;
				for (int j = 0; j < c->n_outputs; j++)
					if (!strcmp(c->output[j].name, name))
						return failf(p, e->where, "[%s]: output name used twice", e->section);
				/* the type first: it decides which keys exist */
				s = (struct section_ctx){ p, S_OUTPUT, name, e->section, o, NULL, e->where };
				if (set_value(&s, find_key(S_OUTPUT, "type", NULL), t->value, t->where))
					return -1;
				s.type = e_out[o->type];
				if (o->type == CFG_OUT_MULTICAST) {
					/* a multicast output without an address has no sensible default */
					if (!entry_of(c, e->section, "address"))
						return failf(p, t->where, "[%s] address: missing (a multicast group)",
							     e->section);
				}
				if (o->type == CFG_OUT_MODBUS && !entry_of(c, e->section, "port"))
					return failf(p, t->where,
						     "[%s] port: missing (Modbus TCP's own port 502 needs "
						     "CAP_NET_BIND_SERVICE; 1502 is usual otherwise)",
						     e->section);
				if (o->type == CFG_OUT_CAN && !entry_of(c, e->section, "interface"))
					return failf(p, t->where,
						     "[%s] interface: missing (a CAN interface such as can0)",
						     e->section);
				if (apply_section(&s) || resolve_output_avatars(p, e->section, o) ||
				    check_bus_output(p, e->section, o) || one_avatar(p, e->section, o, t)) {
					free(o->avatar_ids); /* not counted in n_outputs: config_free would miss it */
					o->avatar_ids = NULL;
					return -1;
				}
				c->n_outputs++;
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
	for (int i = 0; i < c->n_outputs; i++)
		free(c->output[i].avatar_ids);
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

static void print_value(FILE *out, const struct key_def *k, const void *obj)
{
	const char *o = obj;

	switch (k->kind) {
	case K_INT:
		fprintf(out, "%d", *(const int *)(o + k->off));
		break;
	case K_U32:
		fprintf(out, "%u", *(const uint32_t *)(o + k->off));
		break;
	case K_DOUBLE:
		fprintf(out, "%.10g", *(const double *)(o + k->off));
		break;
	case K_DEG:
		fprintf(out, "%.10g", *(const double *)(o + k->off) / DEG);
		break;
	case K_BOOL:
		fputs(*(const bool *)(o + k->off) ? "yes" : "no", out);
		break;
	case K_ENUM:
		fputs(k->enums[*(const int *)(o + k->off)], out);
		break;
	case K_STR:
	case K_PATH:
	case K_LIST:
	case K_NAMES:
		fputs(o + k->off, out);
		break;
	case K_VEC3: {
		const double *v = (const double *)(o + k->off);

		fprintf(out, "%.10g %.10g %.10g", v[0], v[1], v[2]);
		break;
	}
	case K_RANGE:
		fprintf(out, "%.10g %.10g", *(const double *)(o + k->off) / DEG, *(const double *)(o + k->off2) / DEG);
		break;
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
			  const char *type, const void *obj)
{
	fprintf(out, "\n[%s]\n", full);
	if (sect == S_SOURCE) {
		fprintf(out, "type = %s", type);
		print_origin(out, c, from, "type");
	}
	for (size_t i = 0; i < N_KEYS; i++) {
		const struct key_def *k = &keys[i];

		if (k->sect != sect || (k->only && !word_in(type, k->only)))
			continue;
		if (k->kind == K_SENSOR || k->kind == K_PERSON || !strcmp(k->name, "count") || !strcmp(k->name, "id") ||
		    (sect == S_SOURCE && !strcmp(k->name, "type")))
			continue;
		if (k->kind == K_MOUNT) {
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
		fprintf(out, "%s = ", k->name);
		print_value(out, k, obj);
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
	print_section(out, c, S_DAEMON, "daemon", "daemon", NULL, &c->daemon);
	for (int i = 0; i < c->n_sources; i++) {
		const struct cfg_source *s = &c->source[i];
		const char *type = trackers_table[s->driver]->name;

		snprintf(full, sizeof(full), "source %s", s->name);
		print_section(out, c, S_SOURCE, full, full, type, s);
	}
	for (int i = 0; i < c->n_avatars; i++) {
		const struct cfg_avatar *a = &c->avatar[i];

		char from[CFG_NAME_MAX + 16];

		snprintf(full, sizeof(full), "avatar %s", a->name);
		snprintf(from, sizeof(from), "avatar %s", a->section);
		print_section(out, c, S_AVATAR, full, from, NULL, a);
		fprintf(out, "id = %u\n", a->id);
		for (int r = 0; r < 3; r++) {
			const struct cfg_source *s = &c->source[a->sensor[r].source];
			char nm[CFG_NAME_MAX * 2], w[CFG_PATH_MAX + 16];

			trackers_table[s->driver]->sensor_name(s, a->sensor[r].sensor, nm, sizeof(nm));
			fprintf(out, "%s = %s/%s    ; %s\n", cfg_sensor_roles[r], s->name, nm,
				config_where(c, a->sensor[r].where, w, sizeof(w)));
		}
	}
	for (int i = 0; i < c->n_outputs; i++) {
		const struct cfg_output *o = &c->output[i];

		snprintf(full, sizeof(full), "output %s", o->name);
		print_section(out, c, S_OUTPUT, full, full, e_out[o->type], o);
	}
}

void config_print_reference(FILE *out)
{
	for (int s = 0; s < S_COUNT; s++) {
		fprintf(out, "[%s%s]\n", sect_names[s], s == S_DAEMON ? "" : " NAME");
		for (size_t i = 0; i < N_KEYS; i++) {
			const struct key_def *k = &keys[i];

			if (k->sect != s)
				continue;
			fprintf(out, "%s\t%s\t%s\t%s\t%s\n", k->name, k->def ? k->def : "(required)",
				k->unit ? k->unit : "-", k->only ? k->only : "all", k->doc);
		}
	}
}
