// SPDX-License-Identifier: MIT
/*
 * device.c - device threads and their handoff to the loop (see device.h).
 *
 * The triple buffer: three snapshots; the writer owns one (back), the
 * reader one (front), and the third (mid) sits between them. The writer
 * fills back and swaps it with mid, setting the fresh bit; the reader, if
 * the bit is set, swaps front with mid. Each side touches only its own
 * buffer, so neither ever waits, and the reader always finds the newest
 * complete snapshot. A snapshot holds every sensor's latest sample with a
 * running count, so samples the loop was too slow to see are still
 * counted (the count jumps) and never mixed up.
 */
#include "trackers/device.h"
#include "base/clock.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/eventfd.h>
#include <syslog.h>
#include <time.h>
#include <unistd.h>

#define DEVICE_FRESH 4u
#define DEVICE_IDX 3u

/*
 * The keys of every device source (struct device_opts starts its options):
 * the first DEVICE_N_CAPTURE_KEYS are every device driver's (hydra,
 * polhemus, vrpn, dtrack); `device` is the USB ones' (vrpn names its
 * server with a key of its own).
 */
const struct cfg_key device_keys[DEVICE_N_KEYS] = {
	{ .name = "capture",
	  .kind = CFG_PATH,
	  CFG_AT(struct device_opts, capture),
	  .def = "",
	  .doc = "play this capture (hex, a line per report, message or datagram, as record writes it) instead of "
		 "reading the device, server or network; relative to this file's directory; empty = none" },
	{ .name = "record",
	  .kind = CFG_PATH,
	  CFG_AT(struct device_opts, record),
	  .def = "",
	  .doc = "write everything read (the device's raw reports, the VRPN server's messages with its timestamps, "
		 "DTrack's datagrams) to this capture file with its time, for a bug report or a test (avatargw-decode "
		 "reads it); relative to this file's directory; empty = none" },
	{ .name = "speed",
	  .kind = CFG_DOUBLE,
	  CFG_AT(struct device_opts, speed),
	  .min = 0.01,
	  .max = 100,
	  .def = "1",
	  .doc = "playback speed of the capture, 1 = real time" },
	{ .name = "loop",
	  .kind = CFG_BOOL,
	  CFG_AT(struct device_opts, loop),
	  .def = "yes",
	  .doc = "start the capture again at its end; otherwise the source ENDS and its sensors go STALE" },
	{ .name = "device",
	  .kind = CFG_STR,
	  CFG_AT(struct device_opts, device),
	  .def = "auto",
	  .doc = "which device: auto (the first found); hydra: a hidraw node of its motion interface "
		 "(/dev/hidraw3, or a udev symlink) or its USB port; polhemus: its USB port; a USB port is "
		 "BUS-PORT[.PORT...] as avatargw --list-devices shows it" },
};

int device_check(const struct config *c __attribute__((unused)), const void *section, const char **key, char *err,
		 size_t errlen)
{
	const struct device_opts *o = ((const struct cfg_source *)section)->opt;
	struct capture cap;

	*key = "capture"; /* what a failure blames */
	if (!o->capture[0])
		return 0;
	if (capture_load(&cap, o->capture, err, errlen))
		return -1;
	capture_free(&cap);
	return 0;
}

const struct device_codec *device_codec_find(const char *name)
{
	static const struct device_codec *const all[] = {
#if !defined(HAVE_HIDAPI) || HAVE_HIDAPI
		&hydra_codec,
#endif
#if !defined(HAVE_LIBUSB) || HAVE_LIBUSB
		&polhemus_codec,
#endif
		&vrpn_in_codec,
		&dtrack_codec,
		NULL,
	};

	for (size_t i = 0; all[i]; i++)
		if (!strcmp(all[i]->name, name))
			return all[i];
	return NULL;
}

int device_init(struct device *d, struct tracker *t, const struct device_codec *codec, int n_sensors, char *err,
		size_t errlen)
{
	pthread_condattr_t ca;

	memset(d, 0, sizeof(*d));
	d->t = t;
	d->codec = codec;
	d->n_sensors = n_sensors;
	d->efd = -1;
	if (n_sensors > DEVICE_MAX_SENSORS) {
		snprintf(err, errlen, "[source %s]: more than %d sensors", t->name, DEVICE_MAX_SENSORS);
		return -EINVAL;
	}
	d->buf = calloc(3, sizeof(*d->buf));
	d->codec_st = calloc(1, codec->size);
	if (!d->buf || !d->codec_st) {
		free(d->buf);
		free(d->codec_st);
		snprintf(err, errlen, "[source %s]: out of memory", t->name);
		return -ENOMEM;
	}
	if (codec->init(d->codec_st, t->cfg, err, errlen)) {
		free(d->buf);
		free(d->codec_st);
		return -EINVAL;
	}
	d->back = 0;
	atomic_init(&d->mid, 1);
	d->front = 2;
	atomic_init(&d->link, DEVICE_DOWN);
	atomic_init(&d->stop, false);
	pthread_mutex_init(&d->mu, NULL);
	pthread_condattr_init(&ca);
	pthread_condattr_setclock(&ca, CLOCK_MONOTONIC);
	pthread_cond_init(&d->cv, &ca);
	pthread_condattr_destroy(&ca);
	d->efd = eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
	snprintf(d->status, sizeof(d->status), "starting");
	return 0;
}

/*
 * Plays a capture through the codec at its recorded pace (or the codec's
 * period), speed times faster, from the top again at its end when loop;
 * the link is UP while it plays and ENDED after. Returns when done or
 * stopping.
 */
static void device_play(struct device *d, const struct capture *cap, double speed, bool loop);

/* the thread: the driver's run, or the capture that stands in for its device */
static void *device_main(void *arg)
{
	struct device *d = arg;
	const struct device_opts *o = d->t->cfg->opt;

	if (d->use_capture) {
		device_set_status(d, "playing capture %s", o->capture);
		device_play(d, &d->cap, o->speed, o->loop);
	} else {
		d->run(d);
	}
	return NULL;
}

int device_start(struct device *d, device_run_fn *run, void *drv, const char *name, char *err, size_t errlen)
{
	int rc;

	d->run = run;
	d->drv = drv;
	rc = pthread_create(&d->thread, NULL, device_main, d);
	if (rc) {
		snprintf(err, errlen, "[source %s]: device thread: %s", d->t->name, strerror(rc));
		return -rc;
	}
	pthread_setname_np(d->thread, name);
	d->started = true;
	return 0;
}

int device_begin(struct device *d, device_run_fn *run, void *drv, const char *name, char *err, size_t errlen)
{
	const struct device_opts *cfg = d->t->cfg->opt; /* the first member of the driver's options */
	int rc;

	if (cfg->capture[0]) {
		if (capture_load(&d->cap, cfg->capture, err, errlen)) {
			device_close(d);
			return -EINVAL;
		}
		d->use_capture = true;
	} else if (cfg->record[0] && (rc = device_record(d, cfg->record, err, errlen))) {
		device_close(d);
		return rc;
	}
	rc = device_start(d, run, drv, name, err, errlen);
	if (rc) {
		device_close(d);
		capture_free(&d->cap);
	}
	return rc;
}

int device_record(struct device *d, const char *path, char *err, size_t errlen)
{
	d->rec = fopen(path, "we");
	if (!d->rec) {
		int e = errno;

		snprintf(err, errlen, "[source %s] record: %s: %s", d->t->name, path, strerror(e));
		return -e;
	}
	fprintf(d->rec, "# avatargw %s capture of source %s: seconds since the first report, then its bytes\n",
		d->codec->name, d->t->name);
	return 0;
}

void device_close(struct device *d)
{
	if (d->started) {
		pthread_mutex_lock(&d->mu);
		atomic_store(&d->stop, true);
		pthread_cond_broadcast(&d->cv);
		pthread_mutex_unlock(&d->mu);
		pthread_join(d->thread, NULL);
		d->started = false;
	}
	if (d->efd >= 0)
		close(d->efd);
	d->efd = -1;
	if (d->rec)
		fclose(d->rec);
	d->rec = NULL;
	pthread_cond_destroy(&d->cv);
	pthread_mutex_destroy(&d->mu);
	free(d->buf);
	free(d->codec_st);
	d->buf = NULL;
	d->codec_st = NULL;
}

/* ---- the loop thread --------------------------------------------------------------- */

int device_poll(struct device *d, const struct tracker_clock *now)
{
	struct tracker *t = d->t;
	const struct device_snap *snap;
	int n = 0, link;

	if (d->efd >= 0) {
		uint64_t v;

		/* event mode: the counter only says "something came"; the snapshot says what */
		if (read(d->efd, &v, sizeof(v)) < 0) {
			/* EAGAIN: nothing since the last poll, which is fine */
		}
	}
	if (atomic_load_explicit(&d->mid, memory_order_acquire) & DEVICE_FRESH)
		d->front = atomic_exchange_explicit(&d->mid, d->front, memory_order_acq_rel) & DEVICE_IDX;
	snap = &d->buf[d->front];
	for (int i = 0; i < d->n_sensors; i++) {
		const struct device_slot *sl = &snap->slot[i];
		struct sensor_slot *s = &t->slot[i];
		uint32_t delta = sl->count - d->seen[i];

		if (!delta)
			continue;
		/*
		 * The device thread may have read it after this cycle read its clock:
		 * the loop takes it in now, never later (ages and staleness are
		 * differences with now).
		 */
		tracker_put(t, i, &sl->s.pose, sl->t_ns, sl->arrival_ns < now->mono_ns ? sl->arrival_ns : now->mono_ns);
		/* samples that came and went between two polls count too */
		if (delta > 1)
			ctr_add(&t->st.samples, delta - 1);
		s->buttons = sl->s.buttons;
		for (int k = 0; k < SENSOR_ANALOG_MAX; k++)
			s->analog[k] = sl->s.analog[k];
		s->inputs = sl->s.inputs;
		d->seen[i] = sl->count;
		n++;
	}
	link = atomic_load_explicit(&d->link, memory_order_acquire);
	if (link == DEVICE_ENDED) {
		atomic_store_explicit(&t->st.state, TRACKER_ENDED, memory_order_relaxed);
		return n;
	}
	if (!n && link != DEVICE_UP)
		return -ENODEV;
	return n;
}

int device_fd(struct device *d)
{
	return d->efd;
}

/* ---- the device thread --------------------------------------------------------------- */

void device_set_link(struct device *d, enum device_link link)
{
	atomic_store_explicit(&d->link, link, memory_order_release);
}

enum device_link device_link_of(struct device *d)
{
	return atomic_load_explicit(&d->link, memory_order_acquire);
}

struct feed_ctx {
	struct device *d;
	uint64_t t_ns, arrival_ns;
};

static void feed_emit(void *ctx, int sensor, const struct device_sample *s)
{
	struct feed_ctx *f = ctx;
	struct device_slot *sl;

	if (sensor < 0 || sensor >= f->d->n_sensors)
		return;
	sl = &f->d->work.slot[sensor];
	sl->s = *s;
	sl->t_ns = s->t_ns ? s->t_ns : f->t_ns;
	sl->arrival_ns = f->arrival_ns;
	sl->count++;
}

/* the codec's counts since last time, into the tracker's counters (this thread is their only writer) */
static void device_count(struct device *d)
{
	const struct device_counts *c = d->codec_st;

	if (c->malformed != d->told.malformed)
		ctr_add(&d->t->st.malformed, c->malformed - d->told.malformed);
	if (c->lost != d->told.lost)
		ctr_add(&d->t->st.lost, c->lost - d->told.lost);
	d->told = *c;
}

/* one capture line: the device thread writes it, buffered (the file is flushed when the source closes) */
static void record_report(struct device *d, uint64_t mono, const uint8_t *buf, size_t len)
{
	if (!d->rec_t0)
		d->rec_t0 = mono;
	fprintf(d->rec, "%.6f", (double)(mono - d->rec_t0) * 1e-9);
	for (size_t i = 0; i < len; i++)
		fprintf(d->rec, " %02x", buf[i]);
	fputc('\n', d->rec);
}

int device_feed(struct device *d, const uint8_t *buf, size_t len)
{
	if (d->rec)
		record_report(d, mono_ns(), buf, len);
	return device_feed_quiet(d, buf, len);
}

int device_feed_quiet(struct device *d, const uint8_t *buf, size_t len)
{
	struct feed_ctx f = { d, real_ns(), mono_ns() };
	int n = d->codec->feed(d->codec_st, buf, len, feed_emit, &f);

	device_count(d);
	if (n > 0) {
		uint64_t one = 1;

		d->buf[d->back] = d->work;
		d->back = atomic_exchange_explicit(&d->mid, d->back | DEVICE_FRESH, memory_order_acq_rel) & DEVICE_IDX;
		if (d->efd >= 0 && write(d->efd, &one, sizeof(one)) < 0) {
			/* the counter is full only if nobody reads it: the loop is not in event mode */
		}
	}
	return n;
}

bool device_sleep_ms(struct device *d, int ms)
{
	struct timespec ts;

	clock_gettime(CLOCK_MONOTONIC, &ts);
	ts.tv_sec += ms / 1000;
	ts.tv_nsec += (long)(ms % 1000) * 1000000L;
	if (ts.tv_nsec >= 1000000000L) {
		ts.tv_sec++;
		ts.tv_nsec -= 1000000000L;
	}
	pthread_mutex_lock(&d->mu);
	while (!device_stopping(d) && pthread_cond_timedwait(&d->cv, &d->mu, &ts) != ETIMEDOUT)
		;
	pthread_mutex_unlock(&d->mu);
	return !device_stopping(d);
}

static bool sleep_until(struct device *d, uint64_t until_ns)
{
	struct timespec ts = { (time_t)(until_ns / 1000000000ull), (long)(until_ns % 1000000000ull) };

	pthread_mutex_lock(&d->mu);
	while (!device_stopping(d) && mono_ns() < until_ns && pthread_cond_timedwait(&d->cv, &d->mu, &ts) != ETIMEDOUT)
		;
	pthread_mutex_unlock(&d->mu);
	return !device_stopping(d);
}

void device_note(struct device *d, int level, const char *fmt, ...)
{
	struct device_note *n;
	va_list ap;

	pthread_mutex_lock(&d->mu);
	if (d->note_count == DEVICE_NOTES) {
		/* the control thread reads once a second: only a burst gets here; keep the newest */
		d->note_head = (d->note_head + 1) % DEVICE_NOTES;
		d->note_count--;
		d->notes_dropped++;
	}
	n = &d->notes[(d->note_head + d->note_count) % DEVICE_NOTES];
	n->level = level;
	va_start(ap, fmt);
	vsnprintf(n->text, sizeof(n->text), fmt, ap);
	va_end(ap);
	d->note_count++;
	pthread_mutex_unlock(&d->mu);
}

void device_set_status(struct device *d, const char *fmt, ...)
{
	va_list ap;

	pthread_mutex_lock(&d->mu);
	va_start(ap, fmt);
	vsnprintf(d->status, sizeof(d->status), fmt, ap);
	va_end(ap);
	pthread_mutex_unlock(&d->mu);
}

static void device_play(struct device *d, const struct capture *cap, double speed, bool loop)
{
	device_set_link(d, DEVICE_UP);
	do {
		uint64_t t0 = mono_ns();
		/*
		 * An untimed capture is paced at the codec's period, which the
		 * codec may learn from the records themselves (a Polhemus record
		 * names its product, and with it the rate): asked after each one.
		 */
		double at = 0, period = d->codec->period(d->codec_st);

		d->codec->reset(d->codec_st);
		for (int i = 0; i < cap->n; i++) {
			const struct capture_report *r = &cap->rep[i];

			if (!sleep_until(d, t0 + (uint64_t)((cap->timed ? r->t : at) / speed * 1e9)))
				return;
			device_feed_quiet(d, cap->bytes + r->off, r->len);
			period = d->codec->period(d->codec_st);
			at += period;
		}
		/* one period after the last report: the next pass starts on the beat */
		if (!sleep_until(d, t0 + (uint64_t)((cap->timed ? cap->rep[cap->n - 1].t + period : at) / speed * 1e9)))
			return;
	} while (loop);
	device_set_link(d, DEVICE_ENDED);
	device_set_status(d, "capture played to its end");
}

/* ---- the control thread ---------------------------------------------------------- */

void device_status(struct device *d, char *buf, size_t len)
{
	pthread_mutex_lock(&d->mu);
	snprintf(buf, len, "%s", d->status);
	pthread_mutex_unlock(&d->mu);
}

int device_take_note(struct device *d, int *level, char *buf, size_t len)
{
	int got = 0;

	pthread_mutex_lock(&d->mu);
	if (d->notes_dropped) {
		*level = LOG_WARNING;
		snprintf(buf, len, "%u further messages were dropped (a burst)", d->notes_dropped);
		d->notes_dropped = 0;
		got = 1;
	} else if (d->note_count) {
		const struct device_note *n = &d->notes[d->note_head];

		*level = n->level;
		snprintf(buf, len, "%s", n->text);
		d->note_head = (d->note_head + 1) % DEVICE_NOTES;
		d->note_count--;
		got = 1;
	}
	pthread_mutex_unlock(&d->mu);
	return got;
}

/* ---- the drivers' table entries ------------------------------------------------------ */

int device_drv_open(struct tracker *t, size_t size, const struct device_codec *codec, int n_sensors, char *err,
		    size_t errlen)
{
	struct device *d = calloc(1, size);
	int rc;

	if (!d) {
		snprintf(err, errlen, "[source %s]: out of memory", t->cfg->name);
		return -ENOMEM;
	}
	rc = device_init(d, t, codec, n_sensors, err, errlen);
	if (rc) {
		free(d);
		return rc;
	}
	t->priv = d;
	return 0;
}

int device_drv_start(struct tracker *t, device_run_fn *run, const char *name, char *err, size_t errlen)
{
	int rc = device_begin(t->priv, run, t->priv, name, err, errlen);

	if (rc) {
		free(t->priv);
		t->priv = NULL;
	}
	return rc;
}

void device_drv_close(struct tracker *t)
{
	struct device *d = t->priv;

	if (!d)
		return;
	device_close(d); /* joins the thread first: what it uses is freed after */
	capture_free(&d->cap);
	free(d);
	t->priv = NULL;
}

int device_drv_poll(struct tracker *t, const struct tracker_clock *now)
{
	return device_poll(t->priv, now);
}

int device_drv_fd(struct tracker *t)
{
	return device_fd(t->priv);
}

void device_drv_status(struct tracker *t, char *buf, size_t len)
{
	device_status(t->priv, buf, len);
}

int device_drv_note(struct tracker *t, int *level, char *buf, size_t len)
{
	return device_take_note(t->priv, level, buf, len);
}
