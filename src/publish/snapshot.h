/* SPDX-License-Identifier: MIT */
/*
 * snapshot.h - the newest frame of each avatar, handed from the loop to an
 * output's service thread (osc.c, websocket.c), whose libraries allocate and
 * so must stay off the loop.
 *
 * One triple buffer per avatar: the loop (the only writer) fills a spare
 * buffer and swaps it in with one atomic exchange; the thread (the only
 * reader) swaps the newest one out the same way. Neither ever waits for the
 * other, nothing is allocated after snap_init(), and a reader slower than
 * the loop simply sees the newest frame when it comes, the ones between
 * being overwritten.
 */
#ifndef AGW_SNAPSHOT_H
#define AGW_SNAPSHOT_H

#include "avatargw/wire.h"
#include "publish/output.h"

#include <stdatomic.h>
#include <stdbool.h>
#include <stdint.h>

struct snap_entry {
	struct wire_frame f; /* decoded */
	uint32_t buttons[FRAME_SENSORS];
	float analog[FRAME_SENSORS][SENSOR_ANALOG_MAX];
	uint64_t put_mono_ns;	      /* when the loop handed it over */
	char name[WIRE_NAME_MAX + 1]; /* from its DESCRIBE; "" until one came */
	struct wire_site site;	      /* a remote avatar's site, from its DESCRIBE (site.present) */
};

struct snap_slot {
	struct snap_entry buf[3];
	_Atomic unsigned mid;	      /* index of the buffer between the two sides, | SNAP_NEW */
	unsigned back;		      /* the writer's */
	unsigned front;		      /* the reader's */
	bool seen;		      /* the reader has taken at least one */
	char name[WIRE_NAME_MAX + 1]; /* writer: the avatar's name */
	struct wire_site site;	      /* writer: its site's figures */
};

struct snap {
	int n;
	struct snap_slot *slot;
};

/* start-up: room for n avatars (the gateway's indices); 0 or -ENOMEM */
int snap_init(struct snap *s, int n);
void snap_free(struct snap *s);

/*
 * The loop: each FRAME of the batch for the avatars in wants goes in (its
 * buttons and analog values with it), each DESCRIBE gives the avatar's
 * name (and a remote avatar's site figures). No allocation, no waiting.
 */
void snap_put_batch(struct snap *s, const bool *wants, const struct out_msg *m, int n, uint64_t now_mono);

/*
 * The reader: avatar i's newest entry, or NULL if none was ever put. *fresh
 * tells whether it is newer than the previous call's. The entry stays valid
 * until the next snap_take() of the same avatar.
 */
const struct snap_entry *snap_take(struct snap *s, int i, bool *fresh);

#endif /* AGW_SNAPSHOT_H */
