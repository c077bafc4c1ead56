// SPDX-License-Identifier: MIT
/* player.c - the capture player the simulated trackers share (player.h) */
#include "fake/player.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

uint64_t player_now_ns(void)
{
	struct timespec ts;

	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (uint64_t)ts.tv_sec * 1000000000ull + (uint64_t)ts.tv_nsec;
}

void player_reset_locked(struct player *p, const char *capture, const char *who, int period_us)
{
	char err[256];

	if (!p->init) {
		pthread_condattr_t ca;

		pthread_condattr_init(&ca);
		pthread_condattr_setclock(&ca, CLOCK_MONOTONIC);
		pthread_cond_init(&p->cv, &ca);
		pthread_condattr_destroy(&ca);
		p->init = true;
	}
	if (capture && !p->cap.n && capture_load(&p->cap, capture, err, sizeof(err))) {
		fprintf(stderr, "%s: %s\n", who, err);
		abort();
	}
	p->stepped = false;
	p->period_us = period_us;
	p->released = 0;
	p->idx = 0;
	p->dir = 1;
	p->next_due = 0;
	p->inj_head = p->inj_n = 0;
}

void player_wait_until_locked(struct player *p, uint64_t t)
{
	struct timespec ts = { (time_t)(t / 1000000000ull), (long)(t % 1000000000ull) };

	pthread_cond_timedwait(&p->cv, &p->mu, &ts);
}

void player_wake_locked(struct player *p)
{
	pthread_cond_broadcast(&p->cv);
}

void player_period_us(struct player *p, int us)
{
	pthread_mutex_lock(&p->mu);
	p->period_us = us;
	pthread_mutex_unlock(&p->mu);
}

void player_stepped(struct player *p, bool on)
{
	pthread_mutex_lock(&p->mu);
	p->stepped = on;
	p->released = 0;
	p->next_due = player_now_ns();
	player_wake_locked(p);
	pthread_mutex_unlock(&p->mu);
}

void player_release(struct player *p, long n)
{
	pthread_mutex_lock(&p->mu);
	p->released += n;
	player_wake_locked(p);
	pthread_mutex_unlock(&p->mu);
}

void player_seek(struct player *p, int index)
{
	pthread_mutex_lock(&p->mu);
	p->idx = index;
	p->dir = 1;
	pthread_mutex_unlock(&p->mu);
}

void player_inject(struct player *p, const uint8_t *bytes, size_t len)
{
	pthread_mutex_lock(&p->mu);
	if (p->inj_n < PLAYER_INJ_MAX && len <= PLAYER_INJ_LEN) {
		int k = (p->inj_head + p->inj_n++) % PLAYER_INJ_MAX;

		memcpy(p->inj[k], bytes, len);
		p->inj_len[k] = len;
	}
	player_wake_locked(p);
	pthread_mutex_unlock(&p->mu);
}

void player_advance_locked(struct player *p)
{
	if (p->idx + p->dir < 0 || p->idx + p->dir >= p->cap.n)
		p->dir = -p->dir;
	p->idx += p->dir;
}

int player_take_injected_locked(struct player *p, uint8_t *out, size_t cap)
{
	size_t n;

	if (!p->inj_n)
		return -1;
	n = p->inj_len[p->inj_head] < cap ? p->inj_len[p->inj_head] : cap;
	memcpy(out, p->inj[p->inj_head], n);
	p->inj_head = (p->inj_head + 1) % PLAYER_INJ_MAX;
	p->inj_n--;
	return (int)n;
}

bool player_due_locked(struct player *p, uint64_t now, uint64_t *wake_at)
{
	if (p->stepped) {
		if (p->released > 0) {
			p->released--;
			return true;
		}
		return false;
	}
	if (now >= p->next_due) {
		p->next_due += (uint64_t)p->period_us * 1000ull;
		if (p->next_due + 100000000ull < now)
			p->next_due = now; /* after a long pause: no burst */
		return true;
	}
	if (p->next_due < *wake_at)
		*wake_at = p->next_due;
	return false;
}

const uint8_t *player_report(const struct player *p, int i, size_t *len)
{
	*len = p->cap.rep[i].len;
	return p->cap.bytes + p->cap.rep[i].off;
}
