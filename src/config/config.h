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

enum cfg_polhemus_model { CFG_PH_AUTO, CFG_PH_LIBERTY, CFG_PH_LIBERTY_HS, CFG_PH_PATRIOT, CFG_PH_PATRIOT_HS };

struct cfg_source {
	char name[CFG_NAME_MAX];
	int driver;		/* index into trackers_table */
	struct cfg_where where; /* its first line */
	/* every tracker */
	double origin[3]; /* world position of the tracker's frame, m */
	double yaw;	  /* rotation of the tracker's frame about world z, rad */
	/* sim */
	int people;
	uint32_t seed;
	double sample_rate; /* Hz */
	double spacing;	    /* m between simulated people */
	/* replay */
	char file[CFG_PATH_MAX];
	double speed;
	bool loop;
	double start; /* s into the file */
	/* modbus (a Modbus TCP device polled for poses) */
	char address[CFG_PATH_MAX]; /* host of the device */
	int port;
	int unit_id;
	int register_type; /* enum cfg_reg_type */
	int sensors;	   /* modbus, can: poses read */
	int sensor_stride; /* registers from one sensor's block to the next */
	int pos_register;
	int pos_format;	  /* enum cfg_reg_format */
	double pos_scale; /* modbus, can: m per count */
	int ori_register;
	int ori_format;
	double ori_scale; /* rad (or unit quaternion) per count */
	int orientation;  /* enum cfg_orientation */
	int word_order;	  /* enum cfg_word_order: 32-bit values */
	double poll_rate; /* Hz */
	double timeout_ms;
	/* can (SocketCAN frames) */
	char interface[CFG_NAME_MAX]; /* "can0", or "fd:N" for an inherited descriptor */
	int ori_id;		      /* sensor k's orientation frame: ori_id + k */
	int pos_id;		      /* sensor k's position frame: pos_id + k; -1: none */
	double quat_scale;	      /* the count that stands for 1.0 */
	int quat_order;		      /* enum cfg_quat_order */
	bool extended_ids;	      /* 29-bit identifiers */
	bool step;		      /* advance on avatargw-ctl step only */
	int interpolate;	      /* 0 none, else 1 + enum kf_interp */
	/* hydra, polhemus */
	char device[CFG_PATH_MAX];   /* auto, or which one: hidraw node (hydra), USB port (polhemus) */
	char capture[CFG_PATH_MAX];  /* a capture of raw reports to play instead of the device; "" = none */
	char record[CFG_PATH_MAX];   /* write the raw reports read from the device to this capture; "" = none */
	int hid_interface;	     /* hydra: USB interface of the motion reports */
	int control_interface;	     /* hydra: USB interface that takes the mode feature report */
	int model;		     /* polhemus: enum cfg_polhemus_model */
	char stations[CFG_PATH_MAX]; /* polhemus: sensor names of stations 1, 2, ...; "-" = unused */
	double hemisphere[3];	     /* polhemus: the H command's vector, Polhemus frame */
	/* every tracker */
	int n_mounts;
	struct cfg_mount mount[CFG_MAX_MOUNTS];
};

/* how 32-bit values lie in two 16-bit registers (A = most significant byte) */
enum cfg_word_order { CFG_WORD_ABCD, CFG_WORD_CDAB, CFG_WORD_BADC, CFG_WORD_DCBA };
enum cfg_reg_type { CFG_REGS_HOLDING, CFG_REGS_INPUT };
enum cfg_reg_format { CFG_REG_INT16, CFG_REG_UINT16, CFG_REG_INT32, CFG_REG_UINT32, CFG_REG_FLOAT32 };
enum cfg_orientation { CFG_ORI_ROTVEC, CFG_ORI_QUAT_WXYZ, CFG_ORI_QUAT_XYZW, CFG_ORI_RPY, CFG_ORI_NONE };
enum cfg_quat_order { CFG_QUAT_WXYZ, CFG_QUAT_XYZW };

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
	double lo[8], hi[8];		 /* rad */
	int solver;
	int max_iter;
	double tol_mm;
	double tol_rot_deg;
	int max_evals;
	int warm_iter;
};

enum cfg_output_type {
	CFG_OUT_UDP,
	CFG_OUT_MULTICAST,
	CFG_OUT_TCP,
	CFG_OUT_UNIX,
	CFG_OUT_MODBUS,	   /* Modbus TCP server (docs/MODBUS.md) */
	CFG_OUT_CAN,	   /* joint angles as CAN frames (docs/CAN.md) */
	CFG_OUT_VRPN,	   /* VRPN server (docs/VRPN.md) */
	CFG_OUT_VMC,	   /* OSC, VMC protocol performer (docs/OSC.md) */
	CFG_OUT_VRCHAT,	   /* OSC, VRChat trackers */
	CFG_OUT_WEBSOCKET, /* JSON frames and the browser viewer (docs/VIEWER.md) */
};

struct cfg_output {
	char name[CFG_NAME_MAX];
	int type;
	struct cfg_where where;
	char address[CFG_PATH_MAX]; /* udp/multicast: destination; tcp: listen address */
	int port;
	char interface[CFG_NAME_MAX]; /* multicast: network interface; can: CAN interface or fd:N */
	int ttl;
	bool mcast_loop;
	bool gso;
	char path[CFG_PATH_MAX]; /* unix */
	int max_clients;
	int client_buffer; /* bytes per stream client */
	int decimate;	   /* publish every n-th frame */
	/* modbus */
	int reg_base;	     /* input register of the first avatar's block */
	int reg_stride;	     /* registers from one avatar's block to the next */
	int word_order;	     /* enum cfg_word_order */
	int writable_regs;   /* holding registers clients may write, 0: writes refused */
	double idle_timeout; /* s, 0: never */
	/* can */
	int base_id; /* first CAN identifier */
	bool extended_ids;
	bool safe;		   /* clamp, limit the speed, send nothing stale */
	double max_speed;	   /* rad/s per joint (safe mode) */
	char device[CFG_PATH_MAX]; /* vrpn: device name pattern, %d = avatar id */
	bool udp;		   /* vrpn: low-latency reports over UDP when a client offers a port */
	double client_timeout;	   /* vrpn: s a client may stall or take over its handshake */
	double rate;		   /* vmc, vrchat, websocket: messages per second */
	double torso;		   /* vmc: shoulder line to hips, m */
	bool head;		   /* vrchat: send the head for alignment */
	char www[CFG_PATH_MAX];	   /* websocket: the viewer page's directory, or auto */
	char three[CFG_PATH_MAX];  /* websocket: libjs-three's directory */
	/* which avatars: all when n_avatars == 0 */
	int n_avatars;
	uint16_t *avatar_ids; /* resolved ids */
	char avatar_list[CFG_PATH_MAX];
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

/* the sensor roles of an avatar */
extern const char *const cfg_sensor_roles[3];

#endif /* AGW_CONFIG_H */
