/* SPDX-License-Identifier: MIT */
/*
 * dtrack.h - the ART DTrack source (type = dtrack): DTrack2 / DTRACK3
 * measurement frames, ASCII lines in UDP datagrams (docs/TRACKERS.md,
 * "From ART DTrack"). The decoder is a device codec (trackers/device.h):
 * one datagram in, its bodies' and Flysticks' samples out.
 *
 * The lines read (the others are counted and passed over):
 *   fr N                      frame counter
 *   ts T                      the frame's time, seconds since 00:00 UTC
 *   6dcal N                   bodies calibrated
 *   6d N [id qu][x y z][r0 .. r8] ...          N bodies tracked
 *   6df2 NCAL N [id qu nbt nct][x y z][r0 .. r8][bt.. ct..] ...   Flysticks
 * Positions in mm; r0 .. r8 a rotation matrix column by column; qu < 0:
 * not tracked in this frame. nbt buttons in ceil(nbt/32) integers, bit 0
 * the front button (the trigger); nct joystick values in -1..1 (x, y).
 */
#ifndef AGW_DTRACK_H
#define AGW_DTRACK_H

#include "config/config.h"
#include "trackers/channels.h"
#include "trackers/device.h"
#include "trackers/timemap.h"

#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>

#define DTRACK_MAX_DATAGRAM 65536
#define DTRACK_SEEN 64 /* bodies whose reports are counted one by one (the probe's list) */

/* a dtrack source's keys */
struct dtrack_opts {
	struct device_opts dev; /* capture, record, speed, loop (device: unused): first */
	int port;
	char address[CFG_PATH_MAX];
	int sensors;   /* body ids 0 .. sensors-1 taken */
	int flysticks; /* Flysticks 0 .. flysticks-1 taken: sensors after the bodies */
	double timeout_ms;
	struct cfg_per names[CHAN_MAX + CHAN_MAX_FLYSTICKS]; /* sensor.N, sensor.fN = NAME */
};

struct dtrack_codec_st {
	struct device_counts c; /* first: the device code reads it */
	int n_bodies, n_fly;
	bool have_frame;
	uint32_t frame;	    /* the last fr */
	int calibrated;	    /* the last 6dcal, -1 none yet */
	uint64_t untracked; /* bodies and Flysticks reported with quality < 0 */
	uint64_t ignored;   /* bodies and Flysticks beyond those taken */
	uint64_t other;	    /* lines of kinds not read (3d, gl, 6di ...) */
	uint64_t frames;    /* datagrams decoded */
	uint64_t seen[DTRACK_SEEN], fly_seen[CHAN_MAX_FLYSTICKS];
	struct timemap tm;
	char text[DTRACK_MAX_DATAGRAM + 1]; /* the datagram, NUL-terminated */
};

/* a rotation matrix given column by column (DTrack's order) as a unit quaternion; false: not a rotation */
bool dtrack_matrix_quat(const double r[9], double q[4]);

#endif /* AGW_DTRACK_H */
