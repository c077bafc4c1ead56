/* SPDX-License-Identifier: MIT */
/*
 * player.h - what the simulated trackers of fake.h share: a capture played
 * free-running (a report every period, forwards then backwards so the motion
 * stays continuous) or stepped (a report when the test releases one), a
 * queue of injected bytes delivered first, and the lock and condition
 * variable that the test thread and the driver's device thread meet on.
 * Functions named *_locked expect the caller to hold p->mu; the others lock.
 */
#ifndef AGW_TEST_PLAYER_H
#define AGW_TEST_PLAYER_H

#include "trackers/capture.h"

#include <pthread.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#define PLAYER_INJ_MAX 64
#define PLAYER_INJ_LEN 1024

struct player {
	pthread_mutex_t mu;
	pthread_cond_t cv;
	bool init;
	struct capture cap;
	bool stepped;
	int period_us;
	long released;
	int idx, dir;	   /* the next capture index, and which way the play goes */
	uint64_t next_due; /* free-running: when the next report is due (CLOCK_MONOTONIC) */
	uint8_t inj[PLAYER_INJ_MAX][PLAYER_INJ_LEN];
	size_t inj_len[PLAYER_INJ_MAX];
	int inj_head, inj_n;
};

#define PLAYER_INIT                                                                                                    \
	{                                                                                                              \
		.mu = PTHREAD_MUTEX_INITIALIZER                                                                        \
	}

uint64_t player_now_ns(void);
/* the condition variable on CLOCK_MONOTONIC (once), the capture (once; aborts naming who if it cannot be read),
 * and the play back at its start: free-running at period_us, nothing injected */
void player_reset_locked(struct player *p, const char *capture, const char *who, int period_us);
void player_wait_until_locked(struct player *p, uint64_t t);
void player_wake_locked(struct player *p);

void player_period_us(struct player *p, int us);
void player_stepped(struct player *p, bool on);
void player_release(struct player *p, long n);
void player_seek(struct player *p, int index);
void player_inject(struct player *p, const uint8_t *bytes, size_t len);

/* one step along the capture, turning at either end */
void player_advance_locked(struct player *p);
/* the oldest injected bytes into out (at most cap): their length, or -1 if none is queued */
int player_take_injected_locked(struct player *p, uint8_t *out, size_t cap);
/*
 * Whether a report is due now: stepped, when one is released (it is taken);
 * free-running, when its time has come (the next is scheduled, without a
 * burst after a long pause). If not, *wake_at comes down to when it will be.
 */
bool player_due_locked(struct player *p, uint64_t now, uint64_t *wake_at);
const uint8_t *player_report(const struct player *p, int i, size_t *len);

#endif /* AGW_TEST_PLAYER_H */
