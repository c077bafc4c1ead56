/* SPDX-License-Identifier: MIT */
/*
 * hydra.h - the Razer Hydra (1532:0300) over hidapi's hidraw back end:
 * facts of its protocol (docs/TRACKERS.md) and the waits of its driver.
 */
#ifndef AGW_HYDRA_H
#define AGW_HYDRA_H

#include "config/config.h"
#include "trackers/device.h"

#define HYDRA_VID 0x1532
#define HYDRA_PID 0x0300
#define HYDRA_REPORT_LEN 52  /* motion report, no report id */
#define HYDRA_FEATURE_LEN 91 /* mode feature report, report id 0 included */
#define HYDRA_RATE_HZ 250.0  /* interrupt endpoint polled every 4 ms */

/* sensors of a hydra source, in this order */
#define HYDRA_LEFT 0  /* the wand with LB/LT: report block A */
#define HYDRA_RIGHT 1 /* RB/RT: block B */

/* our button bits (VRPN's numbering) */
#define HYDRA_BTN_START (1u << 0)
#define HYDRA_BTN_1 (1u << 1)
#define HYDRA_BTN_2 (1u << 2)
#define HYDRA_BTN_3 (1u << 3)
#define HYDRA_BTN_4 (1u << 4)
#define HYDRA_BTN_BUMPER (1u << 5)
#define HYDRA_BTN_JOYSTICK (1u << 6)

/* analog values of a wand */
#define HYDRA_AN_JOY_X 0
#define HYDRA_AN_JOY_Y 1
#define HYDRA_AN_TRIGGER 2

/*
 * The driver's waits, ms. Constants in practice; a variable so that the
 * tests of the retry paths need not wait 5 s per attempt.
 */
struct hydra_timing {
	int probe_ms;  /* after opening: a motion report within this long means motion mode already */
	int retry_ms;  /* after the motion-mode request: wait this long for motion reports, then ask again */
	int stall_ms;  /* no motion report for this long while running: ask for motion mode again */
	int search_ms; /* while no Hydra is found: enumerate this often */
	int bad_run;   /* this many reports of the wrong length in a row: the device left motion mode */
};

extern struct hydra_timing hydra_timing;

struct hydra_opts {
	struct device_opts dev; /* device, capture, record, speed, loop: first (device.c reads them) */
	int hid_interface;	/* hydra: USB interface of the motion reports */
	int control_interface;	/* hydra: USB interface that takes the mode feature report */
};

extern const struct tracker_driver hydra_driver;

#endif /* AGW_HYDRA_H */
