/* SPDX-License-Identifier: MIT */
/*
 * site.h - telecollaboration between sites over Cyclone DDS (docs/SITES.md).
 *
 * A [site] makes one DDS participant with two threads of its own:
 *
 *  - publishing: the loop puts each local avatar's FRAME into a sequence-
 *    locked slot (site_put) and wakes the thread once per cycle through an
 *    eventfd (site_flush); the thread writes the DDS samples. The loop
 *    never calls into DDS: a Cyclone write serialises, allocates and takes
 *    the writer's lock.
 *  - receiving: takes the other sites' frames and descriptions and keeps
 *    each remote avatar in one of max_remote slots reserved at start-up,
 *    sequence-locked too; the loop reads them (site_remote) without ever
 *    waiting, and publishes them through every output as avatars of their
 *    own ("SITE/NAME", id remote_id + slot). The joint angles pass through
 *    bit for bit: nothing is solved again.
 *
 * Without Cyclone DDS at build time, site_open() says so (site_none.c).
 */
#ifndef AGW_SITE_H
#define AGW_SITE_H

#include "avatargw/wire.h"
#include "config/config.h"

#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>

struct site;

/* whether this daemon was built with DDS */
extern const bool site_built_in;

/*
 * Creates the participant, its topics, readers and writers (no thread yet).
 * cfg: the whole configuration (its [site], [daemon] rate and stale_ms, the
 * avatars' names); source_id: the daemon's, put in the remote avatars'
 * DESCRIBE headers. 0 or a negative errno with err set.
 */
int site_open(struct site **out, const struct config *cfg, uint32_t source_id, char *err, size_t errlen);
/* a local avatar's DESCRIBE, published as its description; before site_start */
void site_describe_local(struct site *s, int idx, const struct wire_describe *d);
/*
 * A reload: whether the running site s can serve configuration cfg as it is
 * (the same [site] keys and loop rate, the same local avatars by name; the
 * caller then checks each local avatar's DESCRIBE with site_keeps_describe).
 * Kept, the participant, its threads and the remote avatars stay: the new
 * gateway takes s over and calls site_adopt (loop paused) instead of
 * site_start. Otherwise a new site is opened beside it, in the same DDS
 * domain, whose network settings cannot change (site_open refuses).
 */
bool site_keeps(const struct site *s, const struct config *cfg);
bool site_keeps_describe(const struct site *s, int idx, const struct wire_describe *d);
void site_adopt(struct site *s, const struct config *cfg);
/* starts the threads: 0 or a negative errno */
int site_start(struct site *s, char *err, size_t errlen);
void site_close(struct site *s);
/* slots of remote avatars (max_remote, 0 when not subscribing) */
int site_n_remote(const struct site *s);
/* the id a remote slot's avatar has here */
uint16_t site_remote_id(const struct site *s, int k);

/* ---- the loop thread: never waits, allocates nothing ---- */

/* local avatar idx's FRAME of this cycle */
void site_put(struct site *s, int idx, const uint8_t *msg, size_t len);
/* end of the cycle: wakes the publishing thread if anything was put */
void site_flush(struct site *s);
/*
 * Remote slot k at now_mono: false when it has nothing to publish (free,
 * gone, or not described yet). Otherwise wf is its frame (the caller sets
 * the header's source_id, avatar_id, seq and describe_rev), with its
 * sensors STALE after [daemon] stale_ms without a new sample and MISSING
 * after [site] deadline_ms; *fresh when it carries a sample new since the
 * previous call. *described when its description changed (or the avatar
 * appeared): the new one is in d, to be sent at once.
 */
bool site_remote(struct site *s, int k, uint64_t now_mono, struct wire_frame *wf, struct wire_describe *d,
		 bool *described, bool *fresh);

/*
 * Remote slot k's site figures (rate, loss, delay, clock offset, round
 * trip: struct wire_site) into ws, for its DESCRIBE; after site_remote()
 * returned true for k. ws is left as it was when nothing changed since the
 * last call (they change once a second).
 */
void site_remote_site(struct site *s, int k, struct wire_site *ws);

/* ---- the control thread ---- */

/*
 * Remote slot k's avatar: its full name "SITE/AVATAR" in buf and whether it
 * is there now (*live; false: its site left or stopped sending). False when
 * the slot has never had an avatar.
 */
bool site_remote_name(struct site *s, int k, char *buf, size_t len, bool *live);

/* the site and every remote site: JSON members after a comma (",\"site\":{...}"), or text lines */
void site_report(struct site *s, FILE *out, bool json);

#endif /* AGW_SITE_H */
