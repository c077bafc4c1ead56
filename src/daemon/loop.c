// SPDX-License-Identifier: MIT
/*
 * loop.c - see loop.h.
 *
 * Deadline mode: next += period, clock_nanosleep(TIMER_ABSTIME, next); a
 * cycle that ends past the next deadline counts an overrun and the
 * schedule skips to the next period boundary still ahead (no burst of
 * catch-up cycles). Event mode: epoll on the trackers' descriptors, with a
 * timeout of 100 ms so that staleness is still published.
 */
#include "daemon/loop.h"

#include <errno.h>
#include <sched.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/epoll.h>
#include <time.h>
#include <unistd.h>

#define LOOP_STACK (512 * 1024)
#define EVENT_TIMEOUT_MS 100

enum { CMD_RUN, CMD_PAUSE, CMD_STOP };

struct loop {
	pthread_t thread;
	pthread_mutex_t mu;
	pthread_cond_t cv;
	struct gateway *g; /* guarded by mu while paused */
	_Atomic int cmd;
	bool paused; /* guarded by mu */
	_Atomic uint64_t heartbeat;
	int rt;
	int epfd;
};

/* the CPU time of the calling thread: what a cycle cost, whatever preempted it */
static uint64_t thread_cpu_ns(void)
{
	struct timespec ts;

	clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
	return (uint64_t)ts.tv_sec * 1000000000u + (uint64_t)ts.tv_nsec;
}

static void ts_from_ns(uint64_t ns, struct timespec *ts)
{
	ts->tv_sec = (time_t)(ns / 1000000000ull);
	ts->tv_nsec = (long)(ns % 1000000000ull);
}

/* between cycles: obey a pause; false means stop */
static bool checkpoint(struct loop *l)
{
	int cmd = atomic_load_explicit(&l->cmd, memory_order_acquire);

	if (cmd == CMD_RUN)
		return true;
	if (cmd == CMD_STOP)
		return false;
	pthread_mutex_lock(&l->mu);
	l->paused = true;
	pthread_cond_broadcast(&l->cv);
	while (atomic_load_explicit(&l->cmd, memory_order_acquire) == CMD_PAUSE)
		pthread_cond_wait(&l->cv, &l->mu);
	l->paused = false;
	pthread_mutex_unlock(&l->mu);
	return atomic_load_explicit(&l->cmd, memory_order_acquire) != CMD_STOP;
}

/* a spin-wait's pause: lets a sibling hyperthread run and saves power while spinning */
static inline void cpu_relax(void)
{
#if defined(__x86_64__) || defined(__i386__)
	__builtin_ia32_pause();
#elif defined(__aarch64__) || defined(__arm__)
	__asm__ volatile("yield");
#endif
}

static void arm_events(struct loop *l)
{
	int fds[CFG_MAX_SOURCES], n;

	if (l->epfd >= 0)
		close(l->epfd);
	l->epfd = -1;
	if (l->g->cfg.daemon.mode != CFG_LOOP_EVENTS)
		return;
	l->epfd = epoll_create1(EPOLL_CLOEXEC);
	n = gw_event_fds(l->g, fds, CFG_MAX_SOURCES);
	for (int i = 0; i < n && l->epfd >= 0; i++) {
		struct epoll_event ev = { .events = EPOLLIN, .data.fd = fds[i] };

		epoll_ctl(l->epfd, EPOLL_CTL_ADD, fds[i], &ev);
	}
}

/* touches the stack the loop may use, so that it never faults a page in later (mlockall MCL_ONFAULT) */
static __attribute__((noinline)) void prefault_stack(void)
{
	volatile char buf[LOOP_STACK - 64 * 1024];

	for (size_t i = 0; i < sizeof(buf); i += 4096)
		buf[i] = 0;
}

static void *loop_main(void *arg)
{
	struct loop *l = arg;
	struct gateway *g = l->g;
	uint64_t period = 0, next = 0, cpu0;
	struct tracker_clock now;

	prefault_stack();
	for (;;) {
		if (atomic_load_explicit(&l->cmd, memory_order_acquire) != CMD_RUN) {
			if (!checkpoint(l))
				break;
			/* perhaps a new gateway: restart the schedule */
			if (g != l->g || !period) {
				g = l->g;
				arm_events(l);
			}
			next = 0;
		}
		if (!next) {
			period = (uint64_t)(1e9 / g->cfg.daemon.rate);
			next = mono_ns() + period;
		}
		if (l->epfd >= 0) {
			struct epoll_event ev[CFG_MAX_SOURCES];
			int n = epoll_wait(l->epfd, ev, CFG_MAX_SOURCES, EVENT_TIMEOUT_MS);

			(void)n;
			cpu0 = thread_cpu_ns();
			gw_clock(&now);
		} else {
			struct timespec ts;
			uint64_t woke;

			if (g->cfg.daemon.busy_wait) {
				/* a CPU that never idles keeps its caches: the cycle starts warm */
				while (mono_ns() < next)
					cpu_relax();
			} else {
				ts_from_ns(next, &ts);
				while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, NULL) == EINTR)
					;
			}
			/* before the clock that stamps the samples: outside the latency it measures */
			cpu0 = thread_cpu_ns();
			gw_clock(&now);
			woke = now.mono_ns;
			hist_add(&g->st.wake, woke > next ? woke - next : 0);
		}
		gw_cycle(g, &now);
		{
			uint64_t end = mono_ns(), cpu1 = thread_cpu_ns();

			hist_add(&g->st.work, end - now.mono_ns);
			hist_add(&g->st.work_cpu, cpu1 > cpu0 ? cpu1 - cpu0 : 0);
			if (l->epfd < 0) {
				next += period;
				if (end > next) {
					/* overran: skip to the next boundary ahead */
					ctr_add(&g->st.overruns, 1);
					next += ((end - next) / period + 1) * period;
				}
			}
		}
		atomic_store_explicit(&l->heartbeat, atomic_load_explicit(&l->heartbeat, memory_order_relaxed) + 1,
				      memory_order_release);
	}
	return NULL;
}

int loop_start(struct loop **lp, struct gateway *g, char *err, size_t errlen)
{
	struct loop *l = calloc(1, sizeof(*l));
	pthread_attr_t attr;
	int rc;

	if (!l)
		return -ENOMEM;
	l->g = g;
	l->epfd = -1;
	atomic_init(&l->cmd, CMD_RUN);
	pthread_mutex_init(&l->mu, NULL);
	pthread_cond_init(&l->cv, NULL);
	arm_events(l);
	pthread_attr_init(&attr);
	pthread_attr_setstacksize(&attr, LOOP_STACK);
	if (g->cfg.daemon.realtime_priority > 0) {
		struct sched_param sp = { .sched_priority = g->cfg.daemon.realtime_priority };

		pthread_attr_setinheritsched(&attr, PTHREAD_EXPLICIT_SCHED);
		pthread_attr_setschedpolicy(&attr, SCHED_FIFO);
		pthread_attr_setschedparam(&attr, &sp);
		l->rt = 1;
	}
	rc = pthread_create(&l->thread, &attr, loop_main, l);
	if (rc == EPERM && l->rt) {
		/* no permission for SCHED_FIFO: run, and say so */
		pthread_attr_setinheritsched(&attr, PTHREAD_INHERIT_SCHED);
		l->rt = -EPERM;
		rc = pthread_create(&l->thread, &attr, loop_main, l);
	}
	pthread_attr_destroy(&attr);
	if (rc) {
		snprintf(err, errlen, "loop thread: %s", strerror(rc));
		free(l);
		return -rc;
	}
	pthread_setname_np(l->thread, "avatargw-loop");
	if (g->cfg.daemon.cpu >= 0) {
		cpu_set_t set;

		CPU_ZERO(&set);
		CPU_SET(g->cfg.daemon.cpu, &set);
		pthread_setaffinity_np(l->thread, sizeof(set), &set);
	}
	*lp = l;
	return 0;
}

void loop_pause(struct loop *l)
{
	pthread_mutex_lock(&l->mu);
	atomic_store_explicit(&l->cmd, CMD_PAUSE, memory_order_release);
	while (!l->paused)
		pthread_cond_wait(&l->cv, &l->mu);
	pthread_mutex_unlock(&l->mu);
}

void loop_resume(struct loop *l, struct gateway *g)
{
	pthread_mutex_lock(&l->mu);
	l->g = g;
	atomic_store_explicit(&l->cmd, CMD_RUN, memory_order_release);
	pthread_cond_broadcast(&l->cv);
	pthread_mutex_unlock(&l->mu);
}

void loop_stop(struct loop *l)
{
	if (!l)
		return;
	pthread_mutex_lock(&l->mu);
	atomic_store_explicit(&l->cmd, CMD_STOP, memory_order_release);
	pthread_cond_broadcast(&l->cv);
	pthread_mutex_unlock(&l->mu);
	pthread_join(l->thread, NULL);
	if (l->epfd >= 0)
		close(l->epfd);
	pthread_mutex_destroy(&l->mu);
	pthread_cond_destroy(&l->cv);
	free(l);
}

uint64_t loop_heartbeat(struct loop *l)
{
	return atomic_load_explicit(&l->heartbeat, memory_order_acquire);
}

int loop_rt_status(struct loop *l)
{
	return l->rt;
}
