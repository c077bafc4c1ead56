// SPDX-License-Identifier: MIT
/*
 * recorder.c - the loop's side (encode into a ring, never wait) and the
 * writer thread (ring -> file, flush policy, rotation). See recorder.h and
 * docs/RECORDING.md.
 *
 * The ring carries records exactly as they go into the file, framed but not
 * sealed: the writer computes the CRCs, so the loop pays for a memcpy only.
 * Records are never split across files; a new file starts with the header
 * and a copy of the latest SESSION record, so that every file stands alone.
 */
#include "record/recorder.h"
#include "base/clock.h"
#include "base/counter.h"

#include "base/log.h"
#include "avatargw/wire.h"
#include "record/recfile.h"

#include <errno.h>
#include <fcntl.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#define WRITE_BUF (256 * 1024)
#define TICK_NS 10000000ull    /* the writer looks at the ring every 10 ms at most */
#define RETRY_NS 1000000000ull /* a file that could not be opened is tried again after 1 s */
#define RECORDER_NAME_MAX (CFG_PATH_MAX + 64)

struct ring {
	uint8_t *buf;
	size_t cap, mask;
	_Atomic size_t head; /* written by the producer */
	_Atomic size_t tail; /* written by the consumer */
};

struct recorder {
	/* configuration */
	char dir[CFG_PATH_MAX];
	bool messages, fsync;
	uint64_t flush_ns;
	uint64_t flush_records;
	uint64_t rotate_bytes;
	uint64_t rotate_ns;
	uint64_t kf_period_ns;
	struct cfg_daemon cfg; /* as opened, to tell whether a reload changes it */

	struct ring ring;
	struct recorder_stats st;

	/* loop side */
	uint32_t *kf_base; /* per attached source: first index into kf_due */
	uint64_t *kf_due;  /* per sensor: arrival time at which the next keyframe is due */
	int kf_sources;

	/* writer thread */
	pthread_t thread;
	_Atomic bool stop;
	int fd;
	uint32_t seq;
	uint64_t file_bytes, file_records, file_opened_ns, next_retry_ns;
	uint8_t *wbuf;
	size_t wlen, wcap; /* wcap: the larger of WRITE_BUF and the ring: any record fits */
	uint64_t wrecords; /* records in wbuf */
	uint64_t last_flush_ns;
	uint8_t *session; /* the latest SESSION record, sealed (ring capacity) */
	size_t session_len;
	uint64_t gap_records, gap_bytes; /* drops already marked in the file */

	pthread_mutex_t mu; /* guards cur_path */
	char cur_path[RECORDER_NAME_MAX];

	/* control thread: what recorder_log() reported last */
	uint64_t seen_dropped, seen_errors, seen_skipped, seen_files;
};

/* ---- the ring ------------------------------------------------------------------------- */

static size_t ring_used(const struct ring *q)
{
	return atomic_load_explicit(&q->head, memory_order_acquire) -
	       atomic_load_explicit(&q->tail, memory_order_acquire);
}

/* producer: the whole record or nothing */
static bool ring_push(struct ring *q, const uint8_t *rec, size_t n)
{
	size_t h = atomic_load_explicit(&q->head, memory_order_relaxed);
	size_t t = atomic_load_explicit(&q->tail, memory_order_acquire);
	size_t at, first;

	if (q->cap - (h - t) < n)
		return false;
	at = h & q->mask;
	first = q->cap - at < n ? q->cap - at : n;
	memcpy(q->buf + at, rec, first);
	memcpy(q->buf, rec + first, n - first);
	atomic_store_explicit(&q->head, h + n, memory_order_release);
	return true;
}

static void ring_copy_out(const struct ring *q, size_t from, uint8_t *dst, size_t n)
{
	size_t at = from & q->mask, first = q->cap - at < n ? q->cap - at : n;

	memcpy(dst, q->buf + at, first);
	memcpy(dst + first, q->buf, n - first);
}

/* ---- the loop's side -------------------------------------------------------------------- */

static void drop(struct recorder *r, size_t n)
{
	ctr_add(&r->st.dropped_records, 1);
	ctr_add(&r->st.dropped_bytes, n);
}

void recorder_sample(struct recorder *r, const struct recfile_sample *smp)
{
	uint8_t rec[RECFILE_REC_OVERHEAD + RECFILE_SAMPLE_LEN_ANALOG];
	size_t len;

	if (r->kf_period_ns && smp->source < r->kf_sources) {
		/* keyframes: the first sample at or after each multiple of the period */
		uint64_t *due = &r->kf_due[r->kf_base[smp->source] + smp->sensor];

		if (smp->arrival_ns < *due)
			return;
		*due = *due && smp->arrival_ns - *due < r->kf_period_ns ? *due + r->kf_period_ns
									: smp->arrival_ns + r->kf_period_ns;
	}
	len = recfile_sample_encode(smp, rec + RECFILE_REC_HEAD);
	recfile_frame(rec, RECFILE_SAMPLE, (uint32_t)len);
	if (!ring_push(&r->ring, rec, RECFILE_REC_OVERHEAD + len))
		drop(r, RECFILE_REC_OVERHEAD + len);
}

static void push_message(struct recorder *r, uint8_t type, uint64_t mono, const uint8_t *data, size_t n)
{
	uint8_t rec[RECFILE_REC_OVERHEAD + RECFILE_MESSAGE_HEAD + WIRE_MAX_MSG];
	size_t len = RECFILE_MESSAGE_HEAD + n;

	if (n > WIRE_MAX_MSG)
		return;
	recfile_frame(rec, type, (uint32_t)len);
	recfile_put64(rec + RECFILE_REC_HEAD, mono);
	memcpy(rec + RECFILE_REC_HEAD + RECFILE_MESSAGE_HEAD, data, n);
	if (!ring_push(&r->ring, rec, RECFILE_REC_OVERHEAD + len))
		drop(r, RECFILE_REC_OVERHEAD + len);
}

void recorder_message(struct recorder *r, uint64_t mono, const uint8_t *data, size_t n)
{
	if (r->messages)
		push_message(r, RECFILE_MESSAGE, mono, data, n);
}

void recorder_remote(struct recorder *r, uint64_t mono, const uint8_t *data, size_t n)
{
	push_message(r, RECFILE_REMOTE, mono, data, n);
}

/* ---- the writer thread -------------------------------------------------------------------------- */

static void set_path(struct recorder *r, const char *p)
{
	pthread_mutex_lock(&r->mu);
	snprintf(r->cur_path, sizeof(r->cur_path), "%s", p);
	pthread_mutex_unlock(&r->mu);
}

static void werror(struct recorder *r, int e)
{
	ctr_add(&r->st.write_errors, 1);
	atomic_store_explicit(&r->st.last_errno, e, memory_order_relaxed);
}

static int write_all(int fd, const uint8_t *p, size_t n)
{
	while (n) {
		ssize_t w = write(fd, p, n);

		if (w < 0 && errno == EINTR)
			continue;
		if (w <= 0)
			return w < 0 ? -errno : -EIO;
		p += w;
		n -= (size_t)w;
	}
	return 0;
}

static void close_file(struct recorder *r)
{
	if (r->fd < 0)
		return;
	if (r->fsync && fdatasync(r->fd))
		werror(r, errno);
	close(r->fd);
	r->fd = -1;
	set_path(r, "");
}

/* the write buffer to the file; on failure the file is given up (a new one is opened later) */
static void flush_buf(struct recorder *r)
{
	int rc;

	r->last_flush_ns = mono_ns();
	if (!r->wlen)
		return;
	if (r->fd < 0) {
		ctr_add(&r->st.skipped_records, r->wrecords);
	} else if ((rc = write_all(r->fd, r->wbuf, r->wlen))) {
		werror(r, -rc);
		ctr_add(&r->st.skipped_records, r->wrecords);
		close_file(r);
		r->next_retry_ns = r->last_flush_ns + RETRY_NS;
	} else {
		r->file_bytes += r->wlen;
		r->file_records += r->wrecords;
		ctr_add(&r->st.bytes, r->wlen);
		ctr_add(&r->st.records, r->wrecords);
		ctr_add(&r->st.flushes, 1);
		if (r->fsync && fdatasync(r->fd))
			werror(r, errno);
	}
	r->wlen = 0;
	r->wrecords = 0;
}

/* a new file: header and the latest SESSION; false if it could not be opened */
static bool open_file(struct recorder *r)
{
	char name[RECORDER_NAME_MAX];
	uint8_t hdr[RECFILE_HEADER_LEN];
	struct recfile_header h = { RECFILE_VERSION, 0, real_ns(), r->seq };
	struct tm tm;
	time_t now = (time_t)(h.created_ns / 1000000000ull);
	int rc;

	if (mkdir(r->dir, 0750) && errno != EEXIST) {
		werror(r, errno);
		return false;
	}
	gmtime_r(&now, &tm);
	for (int k = 0; k < 1000; k++) {
		/* UTC to the millisecond: names sort in time order */
		size_t n = (size_t)snprintf(name, sizeof(name), "%s/avatargw-%04d%02d%02dT%02d%02d%02d.%03dZ", r->dir,
					    tm.tm_year + 1900, tm.tm_mon + 1, tm.tm_mday, tm.tm_hour, tm.tm_min,
					    tm.tm_sec, (int)(h.created_ns / 1000000ull % 1000));

		if (k && n < sizeof(name))
			n += (size_t)snprintf(name + n, sizeof(name) - n, "-%d", k);
		if (n < sizeof(name))
			snprintf(name + n, sizeof(name) - n, ".agwrec");
		r->fd = open(name, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0640);
		if (r->fd >= 0 || errno != EEXIST)
			break;
	}
	if (r->fd < 0) {
		werror(r, errno);
		return false;
	}
	h.flags = (r->messages ? RECFILE_F_MESSAGES : 0) | (r->kf_period_ns ? RECFILE_F_KEYFRAMES : 0);
	recfile_header_encode(&h, hdr);
	rc = write_all(r->fd, hdr, sizeof(hdr));
	if (!rc && r->session_len)
		rc = write_all(r->fd, r->session, r->session_len);
	if (rc) {
		werror(r, -rc);
		close(r->fd);
		r->fd = -1;
		unlink(name);
		return false;
	}
	r->seq++;
	r->file_bytes = sizeof(hdr) + r->session_len;
	r->file_records = r->session_len ? 1 : 0;
	r->file_opened_ns = mono_ns();
	ctr_add(&r->st.bytes, r->file_bytes);
	ctr_add(&r->st.files, 1);
	set_path(r, name);
	return true;
}

static void append_small(struct recorder *r, uint8_t type, const uint8_t *payload, uint32_t len)
{
	uint8_t rec[RECFILE_REC_OVERHEAD + 32];

	if (r->wlen + RECFILE_REC_OVERHEAD + len > r->wcap)
		flush_buf(r);
	recfile_frame(rec, type, len);
	memcpy(rec + RECFILE_REC_HEAD, payload, len);
	recfile_seal(rec);
	memcpy(r->wbuf + r->wlen, rec, RECFILE_REC_OVERHEAD + len);
	r->wlen += RECFILE_REC_OVERHEAD + len;
	r->wrecords++;
}

static void append_end(struct recorder *r, uint8_t reason)
{
	uint8_t p[RECFILE_END_LEN];
	struct recfile_end e = { mono_ns(), r->file_records + r->wrecords, reason };

	recfile_end_encode(&e, p);
	append_small(r, RECFILE_END, p, sizeof(p));
}

static void rotate(struct recorder *r)
{
	append_end(r, 1);
	flush_buf(r);
	close_file(r);
	open_file(r);
}

/* what may still be appended after the last rotation check: a GAP mark and the END record */
#define ROTATE_RESERVE (2 * RECFILE_REC_OVERHEAD + RECFILE_GAP_LEN + RECFILE_END_LEN)

static bool want_rotation(const struct recorder *r, size_t next, uint64_t now)
{
	if (r->fd < 0 || r->file_records + r->wrecords <= (r->session_len ? 1 : 0))
		return false; /* never an empty file */
	if (r->rotate_bytes && r->file_bytes + r->wlen + next + ROTATE_RESERVE > r->rotate_bytes)
		return true;
	return r->rotate_ns && now > r->file_opened_ns && now - r->file_opened_ns >= r->rotate_ns;
}

/* marks in the file what the loop could not queue since the last time */
static void mark_gap(struct recorder *r, uint64_t now)
{
	uint64_t d = ctr_get(&r->st.dropped_records), b = ctr_get(&r->st.dropped_bytes);
	uint8_t p[RECFILE_GAP_LEN];
	struct recfile_gap g = { now, d - r->gap_records, b - r->gap_bytes };

	if (d == r->gap_records)
		return;
	r->gap_records = d;
	r->gap_bytes = b;
	recfile_gap_encode(&g, p);
	append_small(r, RECFILE_GAP, p, sizeof(p));
}

/* everything queued: into the write buffer, then the flush policy */
static void drain(struct recorder *r)
{
	struct ring *q = &r->ring;
	size_t t = atomic_load_explicit(&q->tail, memory_order_relaxed);
	size_t h = atomic_load_explicit(&q->head, memory_order_acquire);
	uint64_t now = mono_ns();

	if (r->fd < 0 && now >= r->next_retry_ns && !open_file(r))
		r->next_retry_ns = now + RETRY_NS;
	while (t != h) {
		uint8_t head[RECFILE_REC_HEAD];
		size_t n;

		ring_copy_out(q, t, head, sizeof(head));
		n = RECFILE_REC_OVERHEAD + recfile_framed_len(head);
		if (want_rotation(r, n, now))
			rotate(r);
		if (r->wlen + n > r->wcap)
			flush_buf(r);
		ring_copy_out(q, t, r->wbuf + r->wlen, n);
		recfile_seal(r->wbuf + r->wlen);
		if (head[4] == RECFILE_SESSION) {
			memcpy(r->session, r->wbuf + r->wlen, n);
			r->session_len = n;
		}
		t += n;
		atomic_store_explicit(&q->tail, t, memory_order_release);
		/* in place: append() without the copy */
		r->wlen += n;
		r->wrecords++;
		if (r->flush_records && r->wrecords >= r->flush_records)
			flush_buf(r);
		if (t == h)
			h = atomic_load_explicit(&q->head, memory_order_acquire);
	}
	mark_gap(r, now);
	if (want_rotation(r, 0, now))
		rotate(r);
	if (r->wlen && now - r->last_flush_ns >= r->flush_ns)
		flush_buf(r);
}

static void *writer_main(void *arg)
{
	struct recorder *r = arg;
	uint64_t tick = r->flush_ns && r->flush_ns < TICK_NS ? r->flush_ns : TICK_NS;

	if (tick < 1000000)
		tick = 1000000;
	r->last_flush_ns = mono_ns();
	while (!atomic_load_explicit(&r->stop, memory_order_acquire)) {
		struct timespec ts = { 0, (long)tick };

		nanosleep(&ts, NULL);
		drain(r);
	}
	drain(r);
	if (r->fd >= 0)
		append_end(r, 0);
	flush_buf(r);
	close_file(r);
	return NULL;
}

/* ---- the control thread's side ---------------------------------------------------------------------- */

static void set_config(struct recorder *r, const struct cfg_daemon *d)
{
	r->cfg = *d;
	snprintf(r->dir, sizeof(r->dir), "%s", d->record_dir);
	r->messages = d->record_messages;
	r->fsync = d->record_fsync;
	r->flush_ns = (uint64_t)(d->record_flush * 1e9);
	r->flush_records = (uint64_t)d->record_flush_records;
	r->rotate_bytes = (uint64_t)(d->record_rotate_size * 1048576.0);
	r->rotate_ns = (uint64_t)(d->record_rotate_time * 1e9);
	r->kf_period_ns = d->record_keyframe_rate > 0 ? (uint64_t)(1e9 / d->record_keyframe_rate) : 0;
}

bool recorder_config_changed(const struct cfg_daemon *a, const struct cfg_daemon *b)
{
	return strcmp(a->record_dir, b->record_dir) || a->record_messages != b->record_messages ||
	       a->record_flush != b->record_flush || a->record_flush_records != b->record_flush_records ||
	       a->record_fsync != b->record_fsync || a->record_rotate_size != b->record_rotate_size ||
	       a->record_rotate_time != b->record_rotate_time || a->record_buffer != b->record_buffer ||
	       a->record_keyframe_rate != b->record_keyframe_rate;
}

int recorder_open(struct recorder **rp, const struct cfg_daemon *d, char *err, size_t errlen)
{
	struct recorder *r = calloc(1, sizeof(*r));
	size_t cap = 4096;
	int rc;

	*rp = NULL;
	if (!r) {
		snprintf(err, errlen, "recorder: out of memory");
		return -ENOMEM;
	}
	set_config(r, d);
	while (cap < (size_t)d->record_buffer * 1024)
		cap <<= 1;
	r->ring.cap = cap;
	r->ring.mask = cap - 1;
	r->ring.buf = malloc(cap);
	r->session = malloc(cap);
	r->wcap = cap > WRITE_BUF ? cap : WRITE_BUF;
	r->wbuf = malloc(r->wcap);
	r->fd = -1;
	pthread_mutex_init(&r->mu, NULL);
	if (!r->ring.buf || !r->session || !r->wbuf) {
		snprintf(err, errlen, "recorder: out of memory (record_buffer = %d KiB)", d->record_buffer);
		rc = -ENOMEM;
		goto fail;
	}
	/* touch the ring now: mlockall keeps it resident, the loop never faults on it */
	memset(r->ring.buf, 0, cap);
	rc = pthread_create(&r->thread, NULL, writer_main, r);
	if (rc) {
		snprintf(err, errlen, "recorder: writer thread: %s", strerror(rc));
		rc = -rc;
		goto fail;
	}
	pthread_setname_np(r->thread, "avatargw-record");
	*rp = r;
	return 0;
fail:
	pthread_mutex_destroy(&r->mu);
	free(r->ring.buf);
	free(r->session);
	free(r->wbuf);
	free(r);
	return rc;
}

void recorder_close(struct recorder *r)
{
	if (!r)
		return;
	atomic_store_explicit(&r->stop, true, memory_order_release);
	pthread_join(r->thread, NULL);
	pthread_mutex_destroy(&r->mu);
	free(r->ring.buf);
	free(r->session);
	free(r->wbuf);
	free(r->kf_base);
	free(r->kf_due);
	free(r);
}

/* the SESSION payload of configuration c */
static size_t session_payload(const struct config *c, uint32_t source_id, uint8_t *buf, size_t cap)
{
	struct recfile_writer w = { buf, cap, 0, false };
	struct timespec rt, mt;
	char name[CFG_PATH_MAX];

	clock_gettime(CLOCK_REALTIME, &rt);
	clock_gettime(CLOCK_MONOTONIC, &mt);
	recfile_w_u64(&w, (uint64_t)rt.tv_sec * 1000000000ull + (uint64_t)rt.tv_nsec);
	recfile_w_u64(&w, (uint64_t)mt.tv_sec * 1000000000ull + (uint64_t)mt.tv_nsec);
	recfile_w_f64(&w, c->daemon.rate);
	recfile_w_u32(&w, source_id);
	recfile_w_u16(&w, (uint16_t)c->n_sources);
	recfile_w_u16(&w, (uint16_t)c->n_avatars);
	for (int i = 0; i < c->n_sources; i++) {
		const struct cfg_source *src = &c->source[i];
		const struct cfg_type *type = cfg_source_type(src->driver);
		int n = type->sensor_count(src);

		recfile_w_str(&w, src->name);
		recfile_w_str(&w, type->name);
		recfile_w_u32(&w, (uint32_t)n);
		for (int k = 0; k < n; k++) {
			type->sensor_name(src, k, name, sizeof(name));
			recfile_w_str(&w, name);
		}
		for (int k = 0; k < 3; k++)
			recfile_w_f64(&w, src->origin[k]);
		recfile_w_f64(&w, src->yaw);
	}
	for (int i = 0; i < c->n_avatars; i++) {
		const struct cfg_avatar *a = &c->avatar[i];

		recfile_w_str(&w, a->name);
		recfile_w_u16(&w, a->id);
		for (int k = 0; k < 3; k++) {
			recfile_w_u16(&w, (uint16_t)a->sensor[k].source);
			recfile_w_u16(&w, (uint16_t)a->sensor[k].sensor);
		}
		for (int k = 0; k < 4; k++)
			recfile_w_f64(&w, a->dims[k]);
		for (int k = 0; k < 3; k++)
			recfile_w_f64(&w, a->head_offset[k]);
	}
	return w.overflow ? 0 : w.len;
}

/* the sensors of source i */
static int sensors_of(const struct config *c, int i)
{
	return cfg_source_type(c->source[i].driver)->sensor_count(&c->source[i]);
}

int recorder_attach(struct recorder *r, const struct config *c, uint32_t source_id, char *err, size_t errlen)
{
	uint8_t *rec;
	size_t len, waited = 0;
	uint32_t *base;
	uint64_t *due;
	uint32_t n = 0;

	if (!r)
		return 0;
	for (int i = 0; i < c->n_sources; i++) {
		if (sensors_of(c, i) > 65535) {
			snprintf(err, errlen, "recorder: source %s has more than 65535 sensors", c->source[i].name);
			return -EINVAL;
		}
		n += (uint32_t)sensors_of(c, i);
	}
	base = calloc((size_t)c->n_sources + 1, sizeof(*base));
	due = calloc((size_t)n + 1, sizeof(*due));
	rec = malloc(r->ring.cap);
	if (!base || !due || !rec) {
		free(base);
		free(due);
		free(rec);
		snprintf(err, errlen, "recorder: out of memory");
		return -ENOMEM;
	}
	n = 0;
	for (int i = 0; i < c->n_sources; i++) {
		base[i] = n;
		n += (uint32_t)sensors_of(c, i);
	}
	/* the loop is paused: the old tables can go */
	free(r->kf_base);
	free(r->kf_due);
	r->kf_base = base;
	r->kf_due = due;
	r->kf_sources = c->n_sources;

	len = r->ring.cap > RECFILE_REC_OVERHEAD
		      ? session_payload(c, source_id, rec + RECFILE_REC_HEAD, r->ring.cap - RECFILE_REC_OVERHEAD)
		      : 0;
	if (!len || len > RECFILE_MAX_PAYLOAD) {
		free(rec);
		snprintf(err, errlen,
			 "recorder: the SESSION record of this configuration does not fit record_buffer "
			 "(%zu KiB): raise it",
			 r->ring.cap / 1024);
		return -ENOSPC;
	}
	recfile_frame(rec, RECFILE_SESSION, (uint32_t)len);
	/* the only producer now (the loop waits): room frees up as the writer drains */
	while (!ring_push(&r->ring, rec, RECFILE_REC_OVERHEAD + len)) {
		struct timespec ts = { 0, 1000000 };

		if (++waited > 5000) {
			free(rec);
			snprintf(err, errlen, "recorder: the writer does not drain its buffer");
			return -EBUSY;
		}
		nanosleep(&ts, NULL);
	}
	free(rec);
	return 0;
}

const struct recorder_stats *recorder_stats(const struct recorder *r)
{
	return &r->st;
}

void recorder_current_file(struct recorder *r, char *buf, size_t len)
{
	pthread_mutex_lock(&r->mu);
	snprintf(buf, len, "%s", r->cur_path);
	pthread_mutex_unlock(&r->mu);
}

void recorder_ring_use(const struct recorder *r, uint64_t *used, uint64_t *cap)
{
	*used = ring_used(&r->ring);
	*cap = r->ring.cap;
}

void recorder_log(struct recorder *r)
{
	uint64_t v;
	char path[RECORDER_NAME_MAX];

	if (!r)
		return;
	if ((v = ctr_get(&r->st.files)) != r->seen_files) {
		recorder_current_file(r, path, sizeof(path));
		if (path[0])
			pr_info("recording to %s", path);
		r->seen_files = v;
	}
	if ((v = ctr_get(&r->st.dropped_records)) != r->seen_dropped) {
		pr_warning("recorder: %llu records lost to a full buffer (raise record_buffer, or the disk is slow), "
			   "%llu in all",
			   (unsigned long long)(v - r->seen_dropped), (unsigned long long)v);
		r->seen_dropped = v;
	}
	if ((v = ctr_get(&r->st.write_errors)) != r->seen_errors) {
		pr_err("recorder: %llu errors writing to %s: %s", (unsigned long long)(v - r->seen_errors), r->dir,
		       strerror(atomic_load_explicit(&r->st.last_errno, memory_order_relaxed)));
		r->seen_errors = v;
	}
	if ((v = ctr_get(&r->st.skipped_records)) != r->seen_skipped) {
		pr_warning("recorder: %llu records not written (no file), %llu in all",
			   (unsigned long long)(v - r->seen_skipped), (unsigned long long)v);
		r->seen_skipped = v;
	}
}

int recorder_apply(struct recorder **rp, const struct config *c, uint32_t source_id, char *err, size_t errlen)
{
	const struct cfg_daemon *d = &c->daemon;
	int rc;

	if (*rp && (!d->record_dir[0] || recorder_config_changed(&(*rp)->cfg, d))) {
		recorder_close(*rp);
		*rp = NULL;
		pr_info("recording stopped");
	}
	if (!*rp && d->record_dir[0]) {
		rc = recorder_open(rp, d, err, errlen);
		if (rc)
			return rc;
	}
	return recorder_attach(*rp, c, source_id, err, errlen);
}
