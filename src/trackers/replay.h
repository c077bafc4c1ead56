/* SPDX-License-Identifier: MIT */
/*
 * replay.h - what the replay driver offers beyond struct tracker_driver:
 * stepping and the damage found in a recording. Control thread only.
 */
#ifndef AGW_REPLAY_H
#define AGW_REPLAY_H

#include "config/config.h"

#include "record/recfile.h"
#include "trackers/tracker.h"

/* true if t is a replay source with step = yes */
bool replay_is_stepped(const struct tracker *t);
/* step = yes: plays n more instants (or samples, with interpolate); -EINVAL for another source */
int replay_step(struct tracker *t, unsigned n);
/* the i-th region of the recording that was skipped (damaged or cut off): 0, or -1 past the last */
int replay_damage(const struct tracker *t, size_t i, struct recfile_damage *d);
/* control thread: logs the damaged regions a replay skipped (nothing for another source) */
void replay_log_damage(const struct tracker *t);
/* the line of the first unreadable row of a CSV (0: none) */
int replay_malformed_line(const struct tracker *t);

struct replay_opts {
	double sample_rate; /* Hz */
	char file[CFG_PATH_MAX];
	double speed;
	bool loop;
	double start;	 /* s into the file */
	bool step;	 /* advance on avatargw-ctl step only */
	int interpolate; /* 0 none, else 1 + enum kf_interp */
};

#endif /* AGW_REPLAY_H */
