/* SPDX-License-Identifier: MIT */
/*
 * devtest.h - what the hardware drivers' tests (test_hydra.c,
 * test_polhemus.c) share: a real gateway (gwtest.h) with one source on its
 * simulated device (fake.h), and the steps every such device goes through
 * whatever it is: it comes up; it is unplugged (FAULTY, its sensors
 * MISSING, the rest going on) and replugged (retried, OK again, counted);
 * it cannot be opened for want of permission, says what fixes it, and is
 * retried until it can; it is listed, or not; the loop allocates nothing
 * meanwhile; a capture plays to its end. What is particular to a device
 * comes in struct devtest; each test file keeps its own checks.
 */
#ifndef AGW_TEST_DEVTEST_H
#define AGW_TEST_DEVTEST_H

#include "fake/gwtest.h"
#include "trackers/device.h"

#include <stdbool.h>
#include <stdint.h>

struct devtest {
	const char *source; /* the source's name and its type, in conf and in the listing */
	const char *conf;   /* a configuration with that source on the simulated device */
	unsigned sensors;   /* the FRAME sensors it feeds: bits 1u << WIRE_S_... */
	bool inputs;	    /* they have buttons and analog values (the conf's other sources have none) */
	const struct tracker_driver *drv;
	void (*plug)(void); /* the device appears (the way this test wants it) */
	void (*unplug)(void);
	void (*deny_open)(bool deny); /* opening it fails for want of permission, or no longer */
	const char *denied;	      /* what the driver says of that permission (the library's words) */
	void (*stepped)(bool on);     /* stepped play: a report only when the test releases one */
	bool (*set_up)(void);	      /* the device saw the driver's handshake through (stepped: no report yet) */
	uint64_t (*reads)(void);      /* reports (or frames) the driver has read from it so far */
};

/* predicates for gwt_until (arg: the struct devtest) */
bool devtest_ok(struct gwt *t, void *dev);	/* the source is OK, and its sensors in the last FRAME */
bool devtest_missing(struct gwt *t, void *dev); /* the source is FAULTY, its sensors MISSING */
bool devtest_stale(struct gwt *t, void *dev);	/* the source is STALE, its sensors too */

/*
 * Cycles for at least ms, and until the driver has read n more reports than
 * it had: it has then dealt with every one before the last it read (one
 * device thread, one report after the other), so what a test injected is
 * counted however long a loaded host kept that thread from it.
 */
void devtest_run_reading(struct gwt *t, const struct devtest *dev, int ms, int n);

/* the device plugged, the gateway opened on dev->conf, the source OK within 2 s, its inputs published: the source */
struct tracker *devtest_up(struct gwt *t, const struct devtest *dev);
/* stepped play, the device plugged, the gateway opened on conf, the device set up within 3 s: the source */
struct tracker *devtest_stepped(struct gwt *t, const struct devtest *dev, const char *conf);
/*
 * Up, then unplugged: FAULTY within 1 s, its sensors MISSING and the rest
 * as it was, counted as one fault; replugged: OK again within 1 s, one
 * reconnect, the unplug noted. The gateway stays open for the device's
 * own checks.
 */
void devtest_unplug_replug(struct gwt *t, const struct devtest *dev);
/* permission denied: FAULTY, the fix noted; granted: OK within 3 s without help. The gateway stays open. */
void devtest_denied(struct gwt *t, const struct devtest *dev);
/* the loop allocates nothing while the device streams, is unplugged, retried and comes back (closes) */
void devtest_loop_allocates_nothing(struct gwt *t, const struct devtest *dev);
/* what list_devices writes (for free()); it must find want devices */
char *devtest_listing(const struct devtest *dev, int want);
/*
 * list_devices: nothing when there is no device; the device plugged, one
 * entry with every string of says (NULL-terminated) and its [source]
 * section; denied, why and what fixes it. Leaves the device plugged and
 * denied.
 */
void devtest_list_devices(const struct devtest *dev, const char *const *says);
/*
 * conf plays a capture: OK within 1 s (its inputs published), ENDED within
 * 2 s, samples in all, then its sensors STALE. Stays open.
 */
void devtest_capture(struct gwt *t, const struct devtest *dev, const char *conf, uint64_t samples);

/* a decoded sample's pose as clip.h takes it: position p, quaternion q (w x y z) */
void devtest_pose(const struct device_sample *s, double p[3], double q[4]);

#endif /* AGW_TEST_DEVTEST_H */
