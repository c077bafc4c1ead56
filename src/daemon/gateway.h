/* SPDX-License-Identifier: MIT */
/*
 * gateway.h - everything a configuration becomes at start-up: trackers,
 * avatars, outputs, and the buffers of one cycle. gw_cycle() is the loop's
 * body: poll the trackers, gather each avatar's pose frame, solve it with
 * the IK core, encode it, hand the batch to every output. After gw_open()
 * nothing is allocated.
 */
#ifndef AGW_GATEWAY_H
#define AGW_GATEWAY_H

#include "avatargw/wire.h"
#include "config/config.h"
#include "base/clock.h"
#include "base/counter.h"
#include "base/hist.h"
#include "frames/frame.h"
#include "ik/avatar.h"
#include "publish/output.h"
#include "trackers/tracker.h"

struct gw_avatar_stats {
	_Atomic uint64_t frames;       /* published */
	_Atomic uint64_t new_frames;   /* with a new sample */
	_Atomic uint64_t stale_frames; /* with a sensor STALE or MISSING */
	_Atomic uint64_t held;	       /* no head: previous posture repeated */
	_Atomic uint64_t ik_solves;    /* arms solved */
	_Atomic uint64_t ik_iters;     /* Newton iterations, summed */
	_Atomic uint64_t ik_unreached; /* arms whose target was out of reach or invalid */
	_Atomic uint64_t nan_blocked;  /* frames not published because a number was not finite */
	_Atomic uint32_t state;	       /* worst sensor state of the last frame (enum wire_sensor_state) */
	_Atomic uint32_t gone;	       /* a remote avatar that left after it had published (its site, as recorded) */
	struct hist latency;	       /* newest sample's arrival -> datagrams sent */
};

/*
 * One avatar's state across cycles. What every cycle touches is kept here
 * and small (1000 avatars fit a core's caches better); the body (struct
 * avatar, read-only after start-up and shared by avatars whose bodies are
 * the same, as with `count`) and the DESCRIBE bytes live apart.
 */
struct gw_avatar {
	const struct cfg_avatar *cfg;
	uint16_t id; /* cfg->id, without a trip to the configuration every cycle */
	const struct avatar *av;
	const struct ik_kin *kin;
	struct ik_opts opts;
	struct frame_source fs;
	struct avatar_pose pose[2]; /* the posture, pose[cur], and where the next solve writes (no copy) */
	unsigned cur;
	bool have_pose;
	uint8_t solved_missing; /* sensors MISSING at the last solve (bit per sensor) */
	uint32_t seq, dseq;
	uint32_t describe_rev;
	uint64_t next_describe_ns;
	uint64_t pose_arrival_ns; /* arrival of the newest sample of the frame just queued, 0: none */
	uint8_t *describe_msg;	  /* its DESCRIBE, encoded at start-up (WIRE_MAX_MSG bytes in the describe arena) */
	uint16_t describe_len;
	struct wire_describe *describe; /* its values (made at start-up; seq and revision change) */
	struct gw_avatar_stats st;
	/* an avatar solved elsewhere that a source plays (a recording's remote avatar): its source and index */
	struct tracker *solved_trk;
	int solved_k;
};

struct gw_stats {
	_Atomic uint64_t cycles;
	_Atomic uint64_t overruns; /* cycles that started after their deadline had passed the next one */
	_Atomic uint64_t poll_errors;
	struct hist work;     /* time of one cycle's work */
	struct hist work_cpu; /* CPU time of the loop thread in it (wall minus preemption) */
	struct hist wake;     /* lateness of the wake-up after the deadline */
};

/*
 * The sensors of one avatar as the loop gathered them, for the control
 * socket's `sensors` request (a calibration takes its readings from it).
 * The control thread names the avatar in want; the loop, the only writer,
 * copies that avatar's three sensors each cycle under the sequence lock,
 * with the avatar's index (the reader takes only a copy of the avatar it
 * named); the control thread clears want when it has its copy. One
 * comparison per cycle otherwise, never a wait.
 */
#define GW_PROBE_SENSOR_WORDS 8 /* state, then x y z, qw qx qy qz as float bits */
#define GW_PROBE_HEAD 3		/* the cycle's time (2 words), the avatar's index */
#define GW_PROBE_WORDS (GW_PROBE_HEAD + FRAME_SENSORS * GW_PROBE_SENSOR_WORDS)

struct gw_probe {
	_Atomic int want; /* 1 + the avatar's index, 0: none */
	_Atomic uint32_t seq;
	_Atomic uint32_t words[GW_PROBE_WORDS];
};

struct site;

struct gateway {
	struct config cfg;
	int n_trackers;
	struct tracker trk[CFG_MAX_SOURCES];
	int n_avatars;
	/*
	 * av[0, n_avatars): the configured avatars, solved here; then n_remote
	 * avatars solved elsewhere (cfg and av are NULL in them): first n_site
	 * slots for the other sites' avatars ([site], src/sites/site.h), then
	 * the remote avatars of recordings that replay sources play
	 * (tracker_driver.solved).
	 */
	struct gw_avatar *av;
	int n_remote;
	int n_site;
	struct site *site; /* [site]: this daemon in a telecollaboration, or NULL */
	int n_outputs;
	struct output out[CFG_MAX_OUTPUTS];
	uint8_t *arena; /* one FRAME per avatar and cycle, frame_slot bytes apart */
	size_t frame_slot;
	uint8_t *describe;     /* one DESCRIBE per avatar, sent from here */
	struct avatar *bodies; /* the distinct bodies the avatars point to */
	int n_bodies;
	struct out_msg *msgs;
	struct pose_frame *frames;	 /* per avatar, the frame of this cycle */
	struct wire_frame *wframes;	 /* per avatar, what its FRAME of this cycle says (the outputs read it) */
	struct wire_describe *describes; /* per avatar */
	uint32_t source_id;
	uint64_t stale_ns;
	uint64_t describe_ns;
	struct gw_stats st;
	struct recorder *rec; /* recording this gateway (record/recorder.h), or NULL: gw_record() */
	struct gw_probe probe;
};

/*
 * Builds g from cfg (taken over: freed by gw_close). old: the gateway being
 * replaced, or NULL; avatars with the same id keep their sequence numbers,
 * stream outputs at the same address keep their subscribers. On failure old
 * is as it was. Returns 0 or a negative errno with err set.
 */
int gw_open(struct gateway *g, struct config *cfg, struct gateway *old, uint32_t source_id, char *err, size_t errlen);
void gw_close(struct gateway *g);
/* one cycle at now; returns the number of frames published */
int gw_cycle(struct gateway *g, const struct tracker_clock *now);
/*
 * Control thread, the loop paused or not started: opens, reopens or closes
 * *rp as g's record_* keys say (recorder_apply), and taps g's samples and
 * messages into it (or into nothing). 0 or a negative errno with err.
 */
int gw_record(struct gateway *g, struct recorder **rp, char *err, size_t errlen);
/* descriptors that wake an event-mode loop (trackers with one); returns how many were written */
int gw_event_fds(struct gateway *g, int *fds, int max);

void gw_clock(struct tracker_clock *c);

#endif /* AGW_GATEWAY_H */
