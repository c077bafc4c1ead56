/* SPDX-License-Identifier: MIT */
/*
 * tracker.h - the tracker driver interface: one const struct of operations
 * per device family (sim.c, replay.c, ...), listed in trackers.c's table
 * which maps config names to drivers.
 *
 * A tracker owns its sensors' latest samples (struct sensor_slot). The loop
 * calls poll() at every cycle; poll() never blocks, never allocates and
 * never logs: it counts. Samples are stored in the world frame (z up,
 * metres, unit quaternions), through the tracker's transform from config.
 */
#ifndef AGW_TRACKER_H
#define AGW_TRACKER_H

#include "avatargw/wire.h"
#include "base/counter.h"
#include "config/config.h"
#include "ik/dq.h"

#include <stdatomic.h>
#include <stdio.h>

struct tracker;

enum tracker_state {
	TRACKER_OK = 0,
	TRACKER_STALE = 1,  /* no new sample for longer than the stale time */
	TRACKER_FAULTY = 2, /* the device failed: retried */
	TRACKER_ENDED = 3,  /* a replay that reached its end */
};

#define SENSOR_ANALOG_MAX 4 /* analog values a sensor may carry (joystick x, y, trigger, ...) */

struct sensor_slot {
	struct dq pose;			 /* world */
	uint32_t buttons;		 /* bit i: button i pressed (devices that have buttons) */
	float analog[SENSOR_ANALOG_MAX]; /* -1..1 for axes, 0..1 for triggers; 0 when absent */
	uint64_t t_ns;			 /* tracker sample time, CLOCK_REALTIME */
	uint64_t arrival_ns;		 /* CLOCK_MONOTONIC when the daemon took it in */
	uint32_t count;			 /* samples taken in */
	bool seen;
	bool inputs; /* buttons and analog are the device's (published), not just absent */
};

struct tracker_clock {
	uint64_t mono_ns;    /* CLOCK_MONOTONIC now */
	int64_t real_off_ns; /* CLOCK_REALTIME - CLOCK_MONOTONIC */
};

struct tracker_driver {
	/* its name, keys, options, checks and sensors, as the configuration sees them */
	struct cfg_type type;
	/* start-up: allocate, open; 0 or a negative errno (err says why) */
	int (*open)(struct tracker *t, char *err, size_t errlen);
	void (*close)(struct tracker *t);
	/* non-blocking: take in what has arrived; returns the number of new samples or a negative errno */
	int (*poll)(struct tracker *t, const struct tracker_clock *now);
	/* a descriptor that becomes readable when samples arrive (event mode), or -1 */
	int (*fd)(struct tracker *t);
	/*
	 * The driver's own counters for avatargw-ctl status (control thread):
	 * JSON members after a comma (",\"x\":1"), or one line of text. May
	 * be NULL.
	 */
	void (*report)(struct tracker *t, FILE *out, bool json);
	/*
	 * Optional, hardware drivers. Control thread only (never the loop):
	 * status() writes one line on the device's condition ("Razer Hydra on
	 * /dev/hidraw3, motion mode"); note() takes the oldest message the
	 * driver left for the log (1 and the text, or 0 when none is left);
	 * list_devices() prints the devices of this family that are plugged
	 * in, each with the configuration lines that use it, and returns how
	 * many it found.
	 */
	void (*status)(struct tracker *t, char *buf, size_t len);
	int (*note)(struct tracker *t, int *level, char *buf, size_t len);
	int (*list_devices)(FILE *out);
	/*
	 * Optional: avatars that come already solved (a recording's remote
	 * avatars, replayed). solved_count() and solved_name() at start-up and
	 * in the control thread (their names and ids are fixed at open());
	 * solved() in the loop, as site_remote() (src/sites/site.h): false when
	 * avatar k has nothing to publish yet; else its frame in wf (the
	 * caller sets the header's source_id, seq and describe_rev), sensors
	 * STALE after stale_ns without a new frame, *fresh when it carries a
	 * new one, *described with its DESCRIBE in d when that changed.
	 */
	int (*solved_count)(struct tracker *t);
	const char *(*solved_name)(struct tracker *t, int k, uint16_t *id);
	bool (*solved)(struct tracker *t, int k, uint64_t now_mono, uint64_t stale_ns, struct wire_frame *wf,
		       struct wire_describe *d, bool *described, bool *fresh);
};

struct tracker_stats {
	_Atomic uint64_t samples;
	_Atomic uint64_t malformed;
	_Atomic uint64_t faults;
	_Atomic uint64_t lost;	     /* samples the device numbered but never delivered (sequence gaps) */
	_Atomic uint64_t reconnects; /* the device came back (or restarted its stream) after a fault */
	_Atomic uint32_t state;
};

struct tracker {
	const struct tracker_driver *drv;
	const struct cfg_source *cfg;
	char name[CFG_NAME_MAX];
	int n_sensors;
	struct sensor_slot *slot;
	struct dq world;     /* tracker frame -> world */
	bool world_identity; /* the tracker's frame is the world's: no product per sample */
	struct dq *mount;    /* per sensor: the tracked point in the sensor's frame (mount_SENSOR) */
	bool *mounted;	     /* per sensor: mount is not the identity */
	struct tracker_stats st;
	void *priv; /* the driver's state */
	/*
	 * A tap on every sample stored (recording: the gateway sets it), or
	 * NULL. Called by tracker_put in the loop with the slot just updated.
	 */
	void (*tap)(void *ctx, uint16_t source, uint16_t sensor, const struct sensor_slot *s);
	void *tap_ctx;
	uint16_t tap_source; /* this tracker's index in the configuration */
};

/* the table: index = cfg_source.driver (trackers.c) */
extern const struct tracker_driver *const trackers_table[];
extern const int trackers_count;

/* start-up: allocates the slots and calls the driver's open() */
int tracker_open(struct tracker *t, const struct cfg_source *cfg, char *err, size_t errlen);
void tracker_close(struct tracker *t);
/*
 * A sample in the tracker's frame, stored in world coordinates (through the
 * sensor's mount, if any). A pose that is not finite as single-precision
 * floats, farther than the source's max_distance from the world's origin, or
 * whose rotation is not a unit quaternion to TRACKER_QUAT_TOL is not stored:
 * counted as malformed (the slot keeps its last good sample).
 */
#define TRACKER_QUAT_TOL 1e-3
void tracker_put(struct tracker *t, int sensor, const struct dq *local, uint64_t t_ns, uint64_t arrival_ns);

#endif /* AGW_TRACKER_H */
