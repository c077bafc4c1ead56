/* SPDX-License-Identifier: MIT */
/*
 * vrpn_in.h - the VRPN client source (type = vrpn): a device NAME@host
 * read as VRPN's own remote objects read it (docs/TRACKERS.md, "From a
 * VRPN server"). The decoder is a device codec (trackers/device.h): one
 * VRPN message in, the samples of its tracker reports out.
 */
#ifndef AGW_VRPN_IN_H
#define AGW_VRPN_IN_H

#include "config/config.h"
#include "trackers/channels.h"
#include "trackers/device.h"
#include "trackers/timemap.h"
#include "wire/vrpn_proto.h"

#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>

#define VRPN_IN_BUTTONS 1024 /* device buttons kept; higher numbers are dropped (counted) */
#define VRPN_IN_ANALOG 128   /* device analog channels kept */
#define VRPN_IN_SEEN 64	     /* channels whose reports are counted one by one (the probe's list) */

enum { VT_POS_QUAT, VT_BUTTON_CHANGE, VT_BUTTON_STATES, VT_ANALOG, VT_PONG, VT_COUNT };

/* a vrpn source's keys */
struct vrpn_in_opts {
	struct device_opts dev;		  /* device (NAME@host[:port]), capture, record, speed, loop: first */
	bool udp;			  /* ask for the reports over UDP */
	int sensors;			  /* channels 0 .. sensors-1 taken */
	double timeout_ms;		  /* nothing from the server this long: the connection is dropped */
	struct cfg_per names[CHAN_MAX];	  /* sensor.N = NAME */
	struct cfg_per buttons[CHAN_MAX]; /* buttons.N = FIRST [COUNT] */
	struct cfg_per analog[CHAN_MAX];  /* analog.N = FIRST [COUNT] */
};

struct vrpn_in_codec_st {
	struct device_counts c; /* first: the device code reads it */
	char device[VRPN_NAME_MAX];
	int n; /* channels taken */
	int btn[CHAN_MAX][2], an[CHAN_MAX][2];
	int32_t sender;		/* the server's id of our device, -1: not described yet */
	int32_t type[VT_COUNT]; /* the server's ids of the types we read, -1: not described */
	uint32_t buttons[VRPN_IN_BUTTONS / 32];
	double analog[VRPN_IN_ANALOG];
	struct timemap tm;
	uint64_t ignored; /* tracker reports of channels not taken */
	uint64_t others;  /* messages of other devices, or of types we do not read */
	uint64_t pongs;
	uint64_t seen[VRPN_IN_SEEN]; /* tracker reports per channel */
	uint64_t last_src_ns;	     /* the server's time of the newest report */
	char devices[160];	     /* the server's other devices, as described (for a name that is not there) */
};

/* "NAME@host[:port]", "NAME@tcp://host[:port]", "NAME@tcp:host..." ("[v6]" hosts in brackets); 0 or -1 */
int vrpn_in_parse_device(const char *spec, char *name, size_t nlen, char *host, size_t hlen, int *port, bool *tcp);

#endif /* AGW_VRPN_IN_H */
