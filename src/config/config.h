/* SPDX-License-Identifier: MIT */
/*
 * config.h - avatargw's configuration: INI files read with inih, checked
 * against one typed table of keys (config.c), merged from a main file and
 * its conf.d drop-ins (*.conf , sorted by name; later files win key by key).
 *
 * Every error names file:line, the section and the key; the daemon exits
 * with EX_CONFIG (78). Units are in the key names' documentation
 * (config/avatargw.conf): metres, degrees in the file, radians in memory.
 */
#ifndef AGW_CONFIG_H
#define AGW_CONFIG_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#define EX_CONFIG_CODE 78

#define CFG_NAME_MAX 32
#define CFG_PATH_MAX 256
#define CFG_MAX_SOURCES 16
#define CFG_MAX_OUTPUTS 16
#define CFG_MAX_AVATARS 4096
#define CFG_MAX_FILES 64
#define CFG_MAX_MOUNTS 32
#define CFG_MAX_STATIONS 16 /* Polhemus stations (sensor ports) at most */

/* where a value came from: files[file] line, or file < 0 for a default */
struct cfg_where {
	int file;
	int line;
};

enum cfg_log_level { CFG_LOG_ERR, CFG_LOG_WARNING, CFG_LOG_INFO, CFG_LOG_DEBUG };
enum cfg_loop_mode { CFG_LOOP_DEADLINE, CFG_LOOP_EVENTS };

struct cfg_daemon {
	double rate; /* Hz */
	int mode;    /* enum cfg_loop_mode */
	double stale_ms;
	int realtime_priority; /* SCHED_FIFO, 0 = off */
	int cpu;	       /* -1 = no affinity */
	bool busy_wait;	       /* spin to each deadline instead of sleeping */
	bool lock_memory;
	char control_socket[CFG_PATH_MAX];
	double describe_interval; /* seconds */
	int log_level;
	bool ik_stats;
	/* recording (docs/RECORDING.md) */
	char record_dir[CFG_PATH_MAX]; /* empty: no recording */
	bool record_messages;
	double record_flush;	  /* s */
	int record_flush_records; /* 0: by time only */
	bool record_fsync;
	double record_rotate_size;   /* MiB, 0: never */
	double record_rotate_time;   /* s, 0: never */
	int record_buffer;	     /* KiB */
	double record_keyframe_rate; /* Hz, 0: every sample */
};

/* mount_SENSOR = x y z [qw qx qy qz]: the tracked point in the sensor's frame */
struct cfg_mount {
	char sensor[CFG_NAME_MAX * 2];
	double p[3]; /* m */
	double q[4]; /* w x y z, unit */
	struct cfg_where where;
};

/*
 * A key of a section, in a typed table: the daemon's, avatars' and what
 * every source and output has are config.c's; each tracker driver and
 * output type declares its own (struct cfg_type), whose values land in its
 * options struct (cfg_source.opt, cfg_output.opt). One table gives the
 * parser, the defaults, the errors, --check-config's printout and --keys
 * (from which the man page and the reference file are checked).
 */
enum cfg_kind {
	CFG_INT,
	CFG_U32,
	CFG_DOUBLE,
	CFG_DEG, /* degrees in the file, radians in memory */
	CFG_BOOL,
	CFG_ENUM, /* one of enums[], stored as its index (int) */
	CFG_STR,
	CFG_PATH, /* relative to the directory of the file that says it */
	CFG_VEC3,
	CFG_RANGE,  /* two numbers in degrees: lo hi (off, off2) */
	CFG_SENSOR, /* SOURCE/SENSOR */
	CFG_PERSON, /* SOURCE[/PREFIX]: head, left_hand, right_hand at once */
	CFG_LIST,   /* avatar names, or all */
	CFG_MOUNT,  /* mount_SENSOR: x y z [qw qx qy qz], one key per sensor */
	CFG_NAMES,  /* sensor names separated by spaces, "-" for none; max = how many */
	CFG_AXES,   /* a tracker's axes: z-up, y-up, three signed axes (x z -y) or qw qx qy qz (double[4]) */
	CFG_PER,    /* NAME.X = VALUE, one key per X (sensor.3 = glasses): struct cfg_per[max], read by check() */
};

/* a CFG_PER key as given: the type's check() and driver read it (X and VALUE are the type's to judge) */
struct cfg_per {
	char key[24];		      /* the whole key, "sensor.3" ("" = a free entry) */
	char value[CFG_NAME_MAX * 2]; /* as written */
};

struct cfg_key {
	const char *name;
	enum cfg_kind kind;
	size_t off, off2; /* where the value goes in the section's struct (off2: a range's hi) */
	size_t size;	  /* strings: the buffer's size */
	double min, max;
	const char *def;	  /* NULL: required */
	const char *unit;	  /* or NULL */
	const char *const *enums; /* CFG_ENUM: the words, NULL-terminated */
	const char *doc;
	const char *missing; /* required keys: what to say when it is not given (or NULL) */
};

/* a key's place in an options struct: .off and .size of field f of struct type t */
#define CFG_AT(t, f) .off = offsetof(t, f), .size = sizeof(((t *)0)->f)
#define CFG_N(a) ((int)(sizeof(a) / sizeof((a)[0])))

struct config;
struct cfg_source;

/*
 * A source driver or an output type, as the configuration sees it: its
 * `type =` word, its keys and its options struct, and the checks no single
 * key can make. The tables of them are the drivers' and outputs' own
 * (trackers.c, outputs.c): cfg_source_type() and cfg_output_type() give
 * the i-th, NULL past the end.
 */
struct cfg_type {
	const char *name;
	const char *doc; /* one line: what it is */
	const struct cfg_key *keys;
	int n_keys;
	/* keys it shares with other types whose options start alike (read before its own), or NULL */
	const struct cfg_key *shared;
	int n_shared;
	size_t opt_size; /* its options struct, allocated and filled by the configuration */
	bool built;	 /* false: known, but its library was missing at build time */
	/*
	 * After every key: what depends on several keys, on a file's content or
	 * on the avatars (section: the struct cfg_source or cfg_output). 0, or
	 * -1 with why set and *key the key to blame (else the type's line).
	 */
	int (*check)(const struct config *c, const void *section, const char **key, char *why, size_t len);
	/* sources: the sensors one of this type has, from its configuration alone */
	int (*sensor_count)(const struct cfg_source *s);
	void (*sensor_name)(const struct cfg_source *s, int i, char *buf, size_t len);
	/* optional: a sensor by another name it answers to (a channel's number under its given name), or -1 */
	int (*sensor_alias)(const struct cfg_source *s, const char *name);
};

/* a built type's name, doc, keys and options struct, inside its designated initializer */
#define CFG_TYPE(nm, what, k, opts)                                                                                    \
	.name = nm, .doc = what, .keys = k, .n_keys = CFG_N(k), .opt_size = sizeof(opts), .built = true
/* ... and the keys it shares with other types */
#define CFG_SHARED(k) .shared = k, .n_shared = CFG_N(k)

const struct cfg_type *cfg_source_type(int i);
const struct cfg_type *cfg_output_type(int i);

struct cfg_source {
	char name[CFG_NAME_MAX];
	int driver;		/* index of its type: cfg_source_type(driver) */
	struct cfg_where where; /* its first line */
	double origin[3];	/* world position of the tracker's frame, m */
	double yaw;		/* rotation of the tracker's frame about world z, rad */
	double max_distance;	/* m from the world's origin: farther samples are malformed */
	double axes[4];		/* rotation from the tracker's axes to z-up ones (w x y z): axes = z-up, y-up, ... */
	int n_mounts;
	struct cfg_mount mount[CFG_MAX_MOUNTS];
	void *opt; /* the driver's options (its cfg_type's keys) */
};

/* how 32-bit values lie in two 16-bit registers (A = most significant byte) */
enum cfg_word_order { CFG_WORD_ABCD, CFG_WORD_CDAB, CFG_WORD_BADC, CFG_WORD_DCBA };
extern const char *const cfg_word_orders[]; /* the words of enum cfg_word_order */

/* a sensor reference: a source and one of its sensors */
struct cfg_sensor_ref {
	int source;
	int sensor;
	struct cfg_where where;
};

enum cfg_solver { CFG_SOLVER_DQ, CFG_SOLVER_MATRIX };

struct cfg_avatar {
	char name[CFG_NAME_MAX];
	char section[CFG_NAME_MAX]; /* NAME of the [avatar NAME] it comes from (count = N: NAME-k's NAME) */
	uint16_t id;
	struct cfg_sensor_ref sensor[3]; /* head, left hand, right hand */
	double dims[4];			 /* shoulder, upper arm, forearm, hand, m */
	double head_offset[3];		 /* m, chest frame */
	double rest_pronation;		 /* deg */
	double lo[8], hi[8];		 /* rad */
	int solver;
	int max_iter;
	double tol_mm;
	double tol_rot_deg;
	int max_evals;
	int warm_iter;
};

struct cfg_output {
	char name[CFG_NAME_MAX];
	int type; /* index of its type: cfg_output_type(type) */
	struct cfg_where where;
	int decimate; /* publish every n-th frame */
	/* which avatars: all when n_avatars == 0 */
	int n_avatars;
	uint16_t *avatar_ids; /* resolved ids */
	char avatar_list[CFG_PATH_MAX];
	void *opt; /* the output type's options (its cfg_type's keys) */
};

/* [site]: this daemon's place in a telecollaboration over DDS (docs/SITES.md) */
#define CFG_SITE_NAME_MAX 32 /* a site's name, with its NUL */
struct cfg_site {
	bool present;		      /* a [site] section was given: without one, no DDS at all */
	struct cfg_where where;	      /* its first line */
	char name[CFG_SITE_NAME_MAX]; /* unique per site, 1-31 characters, no '/' */
	char session[64];	      /* the DDS partition: only sites of one session see each other */
	int domain;		      /* DDS domain id */
	char peers[CFG_PATH_MAX];     /* static unicast peers, separated by spaces; set: multicast off */
	char interface[CFG_NAME_MAX]; /* network interface DDS uses, empty: Cyclone's choice */
	bool publish;		      /* share this site's avatars */
	bool subscribe;		      /* show the other sites' avatars here */
	char security[CFG_PATH_MAX];  /* directory of the DDS Security files, empty: none */
	bool ros2;		      /* also JointState and TF for ROS 2 */
	int max_remote;		      /* remote avatars this site shows at most (slots reserved at start-up) */
	int remote_id;		      /* the id of the first remote slot; slot k has remote_id + k */
	double deadline_ms;	      /* a remote avatar without a sample for this long is MISSING */
	double lease;		      /* s: a site that stops is gone after this long */
};

/* one key=value as read, kept to print the effective configuration */
struct cfg_entry {
	char *section;
	char *key;
	char *value;
	struct cfg_where where;
};

struct config {
	struct cfg_daemon daemon;
	int n_sources;
	struct cfg_source source[CFG_MAX_SOURCES];
	int n_avatars;
	struct cfg_avatar *avatar;
	int n_outputs;
	struct cfg_output output[CFG_MAX_OUTPUTS];
	struct cfg_site site;

	/* the files read, in order */
	int n_files;
	char *files[CFG_MAX_FILES];
	size_t n_entries, cap_entries;
	struct cfg_entry *entries;
};

/*
 * Reads path and the *.conf files of conf.d/ beside it (if that directory
 * exists), or the text given (name is then what errors call it). Returns 0,
 * or -1 with the message in err (file:line: [section] key: what) and c
 * freed (config_free() on it again is harmless).
 */
int config_load(struct config *c, const char *path, char *err, size_t errlen);
/*
 * The same, then overrides "SECTION.KEY=VALUE" (the last '.' before '='
 * splits section and key: "output local.port=7771"); path "builtin:NAME"
 * reads a file compiled into the daemon, without drop-ins.
 */
int config_load_ex(struct config *c, const char *path, const char *const *sets, int n_sets, char *err, size_t errlen);
int config_load_text(struct config *c, const char *name, const char *text, char *err, size_t errlen);
void config_free(struct config *c);

/* The effective configuration, every key, with where each value came from. */
void config_print(const struct config *c, FILE *out);
/* Every key of the table with its default, unit and documentation (config/avatargw.conf is checked against it). */
void config_print_reference(FILE *out);

const char *config_where(const struct config *c, struct cfg_where w, char *buf, size_t len);

/* the avatars an output carries */
static inline int cfg_output_avatars(const struct config *c, const struct cfg_output *o)
{
	/* all: this site's avatars and the other sites' ([site] subscribe: max_remote slots) */
	return o->n_avatars ? o->n_avatars
			    : c->n_avatars + (c->site.present && c->site.subscribe ? c->site.max_remote : 0);
}

/* the output is of this type (its type's name) */
bool cfg_output_is(const struct cfg_output *o, const char *type);
/* a source's sensor by name, or -1 */
int cfg_sensor_lookup(const struct cfg_source *s, const char *name);
/* the index of a type by name, or -1 (also for a type that is known but not built in) */
int cfg_source_type_find(const char *name);
int cfg_output_type_find(const char *name);

/* the sensor roles of an avatar */
extern const char *const cfg_sensor_roles[3];

#endif /* AGW_CONFIG_H */
