/* SPDX-License-Identifier: MIT */
/*
 * loop.h - the real-time thread: cycles of gw_cycle() to absolute deadlines
 * (or on source events), paused while the control thread swaps in a new
 * configuration, stopped on shutdown. It never allocates, logs or blocks on
 * anything but its clock or its event descriptors.
 */
#ifndef AGW_LOOP_H
#define AGW_LOOP_H

#include "daemon/gateway.h"

#include <pthread.h>

struct loop;

/* start-up: the thread runs g; priority > 0 asks for SCHED_FIFO; cpu >= 0 pins it */
int loop_start(struct loop **lp, struct gateway *g, char *err, size_t errlen);
/* waits until the thread is between cycles and holds it there */
void loop_pause(struct loop *l);
/* resumes with g (the same or a new gateway) */
void loop_resume(struct loop *l, struct gateway *g);
void loop_stop(struct loop *l);
/* cycles done: the watchdog is fed only while this advances */
uint64_t loop_heartbeat(struct loop *l);
/* what the thread got: 1 SCHED_FIFO granted, 0 not asked, -errno refused */
int loop_rt_status(struct loop *l);

#endif /* AGW_LOOP_H */
