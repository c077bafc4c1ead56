/* SPDX-License-Identifier: MIT */
/*
 * polhemus.h - Polhemus Liberty, Liberty HS (Latus) and Patriot over
 * libusb bulk endpoints: facts of the protocol (docs/TRACKERS.md) and the
 * waits of the driver.
 */
#ifndef AGW_POLHEMUS_H
#define AGW_POLHEMUS_H

#include "config/config.h"
#include "trackers/device.h"

#include <stdbool.h>
#include <stdint.h>

#define POLHEMUS_VID 0x0f44

/*
 * The output list the driver asks for (O*,2,7,9,0): position (cm, float32
 * x y z), orientation (float32 quaternion w x y z), frame count (uint32),
 * a space. With the 8-byte header a record is 41 bytes per station.
 */
#define POLHEMUS_OUTPUT_LIST "O*,2,7,9,0\r"
#define POLHEMUS_HEADER 8
#define POLHEMUS_PAYLOAD 33
#define POLHEMUS_RECORD (POLHEMUS_HEADER + POLHEMUS_PAYLOAD)

struct polhemus_product {
	uint16_t pid;
	const char *name;
	int model;	       /* enum cfg_polhemus_model */
	bool needs_firmware;   /* the id before fxload sent the firmware */
	uint16_t ready_pid;    /* needs_firmware: the id it comes back with */
	const char *fxload;    /* needs_firmware: the fxload arguments Polhemus' tools use */
	double rate_hz;	       /* per sensor, continuous mode, default */
	uint8_t ep_out, ep_in; /* known bulk endpoints (0: take them from the descriptor) */
};

/* the products of vendor 0f44 this driver knows, or NULL */
const struct polhemus_product *polhemus_product(uint16_t pid);

/* The driver's waits, ms (a variable so that the tests of the retry paths run quickly). */
struct polhemus_timing {
	int drain_ms;	/* reads this short with nothing in them end a drain */
	int stall_ms;	/* no record for this long while streaming: set up again */
	int search_ms;	/* no device: look again this often (hot-plug events wake it sooner) */
	int restarts;	/* set-ups without a record before the device is closed and reopened */
	int pipe_limit; /* halted endpoints in a row (cleared each time) before the device is reopened */
};

extern struct polhemus_timing polhemus_timing;

enum cfg_polhemus_model { CFG_PH_AUTO, CFG_PH_LIBERTY, CFG_PH_LIBERTY_HS, CFG_PH_PATRIOT, CFG_PH_PATRIOT_HS };

struct polhemus_opts {
	struct device_opts dev;	     /* device, capture, record, speed, loop: first (device.c reads them) */
	int model;		     /* polhemus: enum cfg_polhemus_model */
	char stations[CFG_PATH_MAX]; /* polhemus: sensor names of stations 1, 2, ...; "-" = unused */
	double hemisphere[3];	     /* polhemus: the H command's vector, Polhemus frame */
};

extern const struct tracker_driver polhemus_driver;

#endif /* AGW_POLHEMUS_H */
