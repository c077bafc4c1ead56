/* SPDX-License-Identifier: MIT */
/*
 * device.h - what the hardware drivers (hydra.c, polhemus.c) share: a
 * device thread per tracker, the handoff of its newest samples to the
 * loop, and the decoders (codecs) that turn raw reports into samples for
 * the device, for captures and for avatargw-decode alike.
 *
 * Threads. Everything that can block or allocate runs on the device
 * thread: enumeration, opening, the mode and set-up handshakes with their
 * waits and retries, blocking reads, reopening after an unplug, and the
 * libraries themselves (hidapi and libusb allocate). The loop's poll()
 * only copies the newest sample of each sensor out of a triple buffer
 * (device_poll(): no lock, no allocation, no system call but an eventfd
 * read). What the device thread has to say goes to a small queue of
 * notes and a status line that the control thread reads and logs;
 * counters go straight into the tracker's statistics (the device thread
 * is their only writer: malformed, lost, reconnects).
 *
 * Link states. DOWN: no device (searching, or it failed); STARTING: found
 * and opened, handshake under way; UP: reports flow; ENDED: a capture that
 * played to its end. poll() returns -ENODEV while the link is not UP and
 * no new sample came, which makes the loop mark the tracker FAULTY (its
 * sensors are then MISSING in the frames); the first sample after the
 * link is UP again makes it OK.
 */
#ifndef AGW_DEVICE_H
#define AGW_DEVICE_H

#include "base/clock.h"
#include "config/config.h"
#include "trackers/capture.h"
#include "trackers/tracker.h"

#include <pthread.h>
#include <stdarg.h>
#include <stdatomic.h>

#define DEVICE_MAX_SENSORS CFG_MAX_STATIONS
#define DEVICE_NOTES 16 /* notes kept for the control thread; older ones are dropped (and counted) */
#define DEVICE_NOTE_LEN 512

/* the keys of every device source: the first member of its options (hydra_opts, polhemus_opts) */
struct device_opts {
	char device[CFG_PATH_MAX];  /* auto, or which one: hidraw node (hydra), USB port (polhemus) */
	char capture[CFG_PATH_MAX]; /* a capture of raw reports to play instead of the device; "" = none */
	char record[CFG_PATH_MAX];  /* write the raw reports read from the device to this capture; "" = none */
	double speed;		    /* capture playback speed */
	bool loop;		    /* play the capture again at its end */
};

/* their keys: shared by the device drivers' types (cfg_type.shared); the first four by every one */
#define DEVICE_N_KEYS 5
#define DEVICE_N_CAPTURE_KEYS 4 /* capture, record, speed, loop */
extern const struct cfg_key device_keys[DEVICE_N_KEYS];
#define DEVICE_CAPTURE_KEYS .shared = device_keys, .n_shared = DEVICE_N_CAPTURE_KEYS

/* the configuration check of every device source (cfg_type.check): a capture it names must load */
int device_check(const struct config *c, const void *section, const char **key, char *err, size_t errlen);

/* one decoded sample, in the tracker's frame (z up, metres, unit quaternion) */
struct device_sample {
	struct dq pose;
	uint32_t buttons; /* the driver's button bits (docs/TRACKERS.md) */
	float analog[SENSOR_ANALOG_MAX];
	bool inputs;   /* the sensor has buttons and analog values */
	uint64_t t_ns; /* the device's own sample time, CLOCK_REALTIME (vrpn, dtrack); 0: when it was read */
};

/* what a codec counted; the first member of every codec's state */
struct device_counts {
	uint64_t malformed; /* reports or records dropped: wrong length, bad header, not a unit quaternion... */
	uint64_t lost;	    /* reports the device numbered but that never arrived */
	uint64_t resyncs;   /* times a byte stream lost its framing and searched for the next header */
	uint64_t reports;   /* reports or records decoded */
};

typedef void device_emit_fn(void *ctx, int sensor, const struct device_sample *s);

/* a decoder: the same code for a device, a capture and avatargw-decode */
struct device_codec {
	const char *name; /* the driver's name in config */
	size_t size;	  /* of its state, which starts with struct device_counts */
	/* prepares the state for a source; 0, or -1 with err */
	int (*init)(void *st, const struct cfg_source *cfg, char *err, size_t errlen);
	/* a new stream starts (reopened device, capture from the top): continuity is forgotten, counts are kept */
	void (*reset)(void *st);
	/* one report (Hydra) or bulk transfer (Polhemus); emits its samples; returns how many */
	int (*feed)(void *st, const uint8_t *buf, size_t len, device_emit_fn *emit, void *ctx);
	/* nominal time between reports, s: the pace of a capture without timestamps */
	double (*period)(const void *st);
};

extern const struct device_codec hydra_codec;
extern const struct device_codec polhemus_codec;
extern const struct device_codec vrpn_in_codec;
extern const struct device_codec dtrack_codec;
/* by driver name, or NULL */
const struct device_codec *device_codec_find(const char *name);

enum device_link { DEVICE_DOWN, DEVICE_STARTING, DEVICE_UP, DEVICE_ENDED };

struct device_slot {
	struct device_sample s;
	uint64_t t_ns;	     /* CLOCK_REALTIME when the report was read */
	uint64_t arrival_ns; /* CLOCK_MONOTONIC, the same moment */
	uint32_t count;	     /* samples of this sensor so far */
};

struct device_snap {
	struct device_slot slot[DEVICE_MAX_SENSORS];
};

struct device_note {
	int level; /* syslog level */
	char text[DEVICE_NOTE_LEN];
};

struct device;
typedef void device_run_fn(struct device *d);

struct device {
	struct tracker *t;
	const struct device_codec *codec;
	void *codec_st;
	struct device_counts told; /* what was added to the tracker's counters already */
	int n_sensors;
	void *drv;	    /* the driver's own state */
	device_run_fn *run; /* the thread's body: returns when device_stopping() */
	FILE *rec;	    /* record = FILE: every report fed, as a capture line */
	struct capture cap; /* capture = FILE: played instead of the device */
	bool use_capture;
	uint64_t rec_t0; /* CLOCK_MONOTONIC of the first recorded report */

	pthread_t thread;
	bool started;
	_Atomic bool stop;
	_Atomic int link; /* enum device_link */
	int efd;	  /* eventfd: readable when a sample was handed over */

	/* the handoff: a triple buffer (no lock, no tearing; the reader always gets the newest) */
	struct device_snap work;	   /* the device thread's current state */
	struct device_snap *buf;	   /* [3] */
	_Atomic unsigned mid;		   /* index of the buffer between the two, | DEVICE_FRESH when new */
	unsigned back;			   /* the device thread's */
	unsigned front;			   /* the loop's */
	uint32_t seen[DEVICE_MAX_SENSORS]; /* the loop's: counts already put */

	/* control thread's view */
	pthread_mutex_t mu; /* notes, status; also the stop wait */
	pthread_cond_t cv;
	struct device_note notes[DEVICE_NOTES];
	unsigned note_head, note_count, notes_dropped;
	char status[DEVICE_NOTE_LEN];
};

/* start-up (control thread): the handoff, the codec; 0 or a negative errno with err */
int device_init(struct device *d, struct tracker *t, const struct device_codec *codec, int n_sensors, char *err,
		size_t errlen);
/* record = FILE: opens the capture the device thread writes (control thread, at start-up); 0 or -errno with err */
int device_record(struct device *d, const char *path, char *err, size_t errlen);
/* starts the device thread on run (named name, at most 15 characters); 0 or a negative errno */
int device_start(struct device *d, device_run_fn *run, void *drv, const char *name, char *err, size_t errlen);
/*
 * The common rest of a hardware driver's open(), after device_init(): the
 * source's capture to play instead of the device (d->use_capture set) or the
 * capture to record, then the device thread. On failure it undoes what
 * device_init() and it made (the driver frees its own state); 0 or -errno.
 */
int device_begin(struct device *d, device_run_fn *run, void *drv, const char *name, char *err, size_t errlen);
/* asks the thread to stop and joins it (its reads time out within 100 ms), then frees */
void device_close(struct device *d);

/* ---- the loop thread --------------------------------------------------------------- */

/* copies the newest samples into t's slots; the tracker driver's poll() */
int device_poll(struct device *d, const struct tracker_clock *now);
int device_fd(struct device *d);

/* ---- the device thread --------------------------------------------------------------- */

static inline bool device_stopping(struct device *d)
{
	return atomic_load_explicit(&d->stop, memory_order_relaxed);
}

void device_set_link(struct device *d, enum device_link link);
enum device_link device_link_of(struct device *d);
/* one report or transfer, read now: recorded (record = FILE), decoded, counted, handed to the loop; returns samples */
int device_feed(struct device *d, const uint8_t *buf, size_t len);
/* the same, never recorded: what device_play() feeds */
int device_feed_quiet(struct device *d, const uint8_t *buf, size_t len);
/* sleeps, waking early when asked to stop; false when stopping */
bool device_sleep_ms(struct device *d, int ms);
/* a message for the log (kept until the control thread takes it) */
void device_note(struct device *d, int level, const char *fmt, ...) __attribute__((format(printf, 3, 4)));
/* the one-line condition that status() shows */
void device_set_status(struct device *d, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

/* ---- the control thread ---------------------------------------------------------- */

void device_status(struct device *d, char *buf, size_t len);
int device_take_note(struct device *d, int *level, char *buf, size_t len);

/*
 * The tracker_driver entries poll, fd, status and note of a driver whose
 * private state (t->priv) begins with its struct device: the hardware
 * drivers name these in their tables instead of each wrapping the four.
 */
int device_drv_poll(struct tracker *t, const struct tracker_clock *now);
int device_drv_fd(struct tracker *t);
void device_drv_status(struct tracker *t, char *buf, size_t len);
int device_drv_note(struct tracker *t, int *level, char *buf, size_t len);

/*
 * open() and close() of such a driver: device_drv_open allocates t->priv
 * (size bytes, zeroed) and readies its struct device; the driver sets its
 * own fields, then device_drv_start plays the capture or starts the device
 * thread on run (named name). Each returns 0 or -errno with err, and on
 * failure leaves t->priv NULL. device_drv_close joins the thread and frees.
 */
int device_drv_open(struct tracker *t, size_t size, const struct device_codec *codec, int n_sensors, char *err,
		    size_t errlen);
int device_drv_start(struct tracker *t, device_run_fn *run, const char *name, char *err, size_t errlen);
void device_drv_close(struct tracker *t);

/* ---- helpers of the drivers --------------------------------------------------------- */

#endif /* AGW_DEVICE_H */
