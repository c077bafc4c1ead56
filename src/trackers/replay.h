/* SPDX-License-Identifier: MIT */
/*
 * replay.h - what the replay driver offers beyond struct tracker_driver:
 * stepping and the damage found in a recording. Control thread only.
 */
#ifndef AGW_REPLAY_H
#define AGW_REPLAY_H

#include "record/recfile.h"
#include "trackers/tracker.h"

/* true if t is a replay source with step = yes */
bool replay_is_stepped(const struct tracker *t);
/* step = yes: plays n more instants (or samples, with interpolate); -EINVAL for another source */
int replay_step(struct tracker *t, unsigned n);
/* the i-th region of the recording that was skipped (damaged or cut off): 0, or -1 past the last */
int replay_damage(const struct tracker *t, size_t i, struct recfile_damage *d);
/* the line of the first unreadable row of a CSV (0: none) */
int replay_malformed_line(const struct tracker *t);

#endif /* AGW_REPLAY_H */
