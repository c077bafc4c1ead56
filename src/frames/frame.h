/* SPDX-License-Identifier: MIT */
/*
 * frame.h - one person's pose frame: the latest head, left-hand and
 * right-hand samples, each with its state (OK, STALE, MISSING) and age.
 * A stale sample is passed on as it was, flagged: never extrapolated.
 */
#ifndef AGW_FRAME_H
#define AGW_FRAME_H

#include "trackers/tracker.h"

#define FRAME_SENSORS 3 /* head, left hand, right hand (cfg_sensor_roles) */

struct pose_frame {
	struct dq sensor[FRAME_SENSORS];		/* world; meaningful when state != MISSING */
	uint8_t state[FRAME_SENSORS];			/* enum wire_sensor_state */
	uint32_t buttons[FRAME_SENSORS];		/* the sensor's buttons (bit i: button i), 0 when it has none */
	float analog[FRAME_SENSORS][SENSOR_ANALOG_MAX]; /* its analog values, 0 when absent */
	uint8_t inputs;			/* bit i: sensor i has buttons and analog values, and they are current */
	uint64_t age_ns[FRAME_SENSORS]; /* now - arrival */
	uint64_t t_ns;			/* newest tracker sample time, CLOCK_REALTIME */
	uint64_t arrival_ns;		/* CLOCK_MONOTONIC arrival of the newest sample */
	bool new_sample;		/* a sample arrived since the previous frame */
};

struct frame_source {
	const struct tracker *trk[FRAME_SENSORS];
	int sensor[FRAME_SENSORS];
	uint32_t last_count[FRAME_SENSORS]; /* samples seen at the previous frame */
};

/* Gathers the latest samples; stale_ns: age beyond which a sample is STALE. */
void frame_gather(struct frame_source *src, uint64_t now_mono, uint64_t stale_ns, struct pose_frame *out);

struct wire_frame;
/* The frame's buttons and analog values into a FRAME's input block (and its flag), if it has any. */
void frame_inputs(const struct pose_frame *pf, struct wire_frame *wf);

#endif /* AGW_FRAME_H */
