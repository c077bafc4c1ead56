// SPDX-License-Identifier: MIT
/*
 * test_recfile.c - the recording format (record/recfile.h, docs/RECORDING.md)
 * and its reader (record/recload.h): byte layouts, round trips, and what a
 * reader does with damage: a flipped byte, a record cut off at the end,
 * garbage between records, a bad header, a second SESSION after a reload;
 * and the replay source naming the sensors of a file whose first record is
 * damaged, and refusing samples whose analog values are not finite.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

#include <zlib.h>

#include "config/config.h"
#include "record/recload.h"
#include "trackers/replay.h"
#include "trackers/tracker.h"

#include <unistd.h>

#define BUF (1 << 16)

struct rec_buf {
	uint8_t b[BUF];
	size_t len;
	size_t off[256]; /* where each record starts */
	int n;
};

static void put_header(struct rec_buf *r)
{
	struct recfile_header h = { RECFILE_VERSION, RECFILE_F_MESSAGES, 1795290370520187076ull, 3 };

	recfile_header_encode(&h, r->b);
	r->len = RECFILE_HEADER_LEN;
	r->n = 0;
}

static void put_record(struct rec_buf *r, uint8_t type, const uint8_t *payload, uint32_t len)
{
	r->off[r->n++] = r->len;
	recfile_frame(r->b + r->len, type, len);
	memcpy(r->b + r->len + RECFILE_REC_HEAD, payload, len);
	recfile_seal(r->b + r->len);
	r->len += RECFILE_REC_OVERHEAD + len;
}

/* sources "clip" (head, left_hand, right_hand) and "sim" (p0.head .. p1.right_hand); one avatar */
static void put_session(struct rec_buf *r, bool swapped)
{
	static const char *const clip[3] = { "head", "left_hand", "right_hand" };
	static const char *const sim[6] = { "p0.head", "p0.left_hand", "p0.right_hand",
					    "p1.head", "p1.left_hand", "p1.right_hand" };
	uint8_t p[1024];
	struct recfile_writer w = { p, sizeof(p), 0, false };

	recfile_w_u64(&w, 1000);
	recfile_w_u64(&w, 2000);
	recfile_w_f64(&w, 240);
	recfile_w_u32(&w, 0xabcd);
	recfile_w_u16(&w, 2);
	recfile_w_u16(&w, 1);
	for (int s = 0; s < 2; s++) {
		bool is_clip = (s == 0) != swapped;

		recfile_w_str(&w, is_clip ? "clip" : "sim");
		recfile_w_str(&w, is_clip ? "replay" : "sim");
		recfile_w_u32(&w, is_clip ? 3 : 6);
		for (int k = 0; k < (is_clip ? 3 : 6); k++)
			recfile_w_str(&w, is_clip ? clip[k] : sim[k]);
		for (int k = 0; k < 4; k++)
			recfile_w_f64(&w, k * 0.5);
	}
	recfile_w_str(&w, "demo");
	recfile_w_u16(&w, 7);
	for (int k = 0; k < 3; k++) {
		recfile_w_u16(&w, swapped ? 1 : 0);
		recfile_w_u16(&w, (uint16_t)k);
	}
	for (int k = 0; k < 7; k++)
		recfile_w_f64(&w, 0.1 * k);
	assert_false(w.overflow);
	put_record(r, RECFILE_SESSION, p, (uint32_t)w.len);
}

static void put_sample(struct rec_buf *r, uint16_t src, uint16_t sensor, uint64_t t, bool analog)
{
	struct recfile_sample s = { src,
				    sensor,
				    0x5,
				    t + 7,
				    t,
				    { 1.5f, -2.25f, 0.125f + (float)t * 1e-9f },
				    { 1, 0, 0, 0 },
				    analog,
				    { 0.5f, -1, 0, 0.25f } };
	uint8_t p[RECFILE_SAMPLE_LEN_ANALOG];
	size_t n = recfile_sample_encode(&s, p);

	put_record(r, RECFILE_SAMPLE, p, (uint32_t)n);
}

/* the byte layout of the header and of a sample, as docs/RECORDING.md gives them */
static void test_layout(void **state)
{
	static struct rec_buf r;
	const uint8_t *b = r.b;

	(void)state;
	put_header(&r);
	assert_memory_equal(b,
			    "\x89"
			    "AGWR\r\n\x1a",
			    8);
	assert_int_equal(recfile_get16(b + 8), 1);
	assert_int_equal(recfile_get16(b + 10), 32);
	assert_int_equal(recfile_get32(b + 12), RECFILE_F_MESSAGES);
	assert_true(recfile_get64(b + 16) == 1795290370520187076ull);
	assert_int_equal(recfile_get32(b + 24), 3);
	put_sample(&r, 1, 2, 123456789, false);
	b = r.b + RECFILE_HEADER_LEN;
	assert_memory_equal(b, "\xa5REC", 4);
	assert_int_equal(b[4], RECFILE_SAMPLE);
	assert_int_equal(recfile_get32(b + 4) >> 8, 52);
	assert_int_equal(recfile_get16(b + 8), 1);
	assert_int_equal(recfile_get16(b + 10), 2);
	assert_int_equal(recfile_get32(b + 12), 5);
	assert_true(recfile_get64(b + 16) == 123456789 + 7);
	assert_true(recfile_get64(b + 24) == 123456789);
	assert_true(recfile_getf32(b + 32) == 1.5f);
	assert_true(recfile_getf32(b + 36) == -2.25f);
	assert_true(recfile_getf32(b + 44) == 1.0f);
	/* 8 + 52 + 4: a sample record is 64 bytes */
	assert_int_equal(r.len - RECFILE_HEADER_LEN, 64);
	/* the CRC (zlib's crc32) covers the word and the payload */
	assert_int_equal(recfile_get32(b + 60), (uint32_t)crc32(crc32(0L, Z_NULL, 0), b + 4, 56));
}

static void test_layout_crc(void **state)
{
	static struct rec_buf r;
	struct recfile_record rec;
	size_t off = RECFILE_HEADER_LEN;

	(void)state;
	put_header(&r);
	put_sample(&r, 1, 2, 123456789, false);
	assert_int_equal(recfile_next(r.b, r.len, &off, &rec, NULL), 1);
	assert_int_equal(off, r.len);
	/* any single flipped bit of the word, payload or CRC is caught */
	for (size_t i = RECFILE_HEADER_LEN + 4; i < r.len; i++) {
		for (int bit = 0; bit < 8; bit += 3) {
			struct recfile_damage d;

			r.b[i] ^= (uint8_t)(1 << bit);
			off = RECFILE_HEADER_LEN;
			assert_int_equal(recfile_next(r.b, r.len, &off, &rec, &d), 0);
			assert_int_equal(d.off, RECFILE_HEADER_LEN);
			r.b[i] ^= (uint8_t)(1 << bit);
		}
	}
}

static void test_header(void **state)
{
	static struct rec_buf r;
	struct recfile_header h;

	(void)state;
	put_header(&r);
	assert_int_equal(recfile_header_decode(r.b, r.len, &h), 0);
	assert_int_equal(h.seq, 3);
	assert_int_equal(h.flags, RECFILE_F_MESSAGES);
	assert_true(recfile_is_recording(r.b, 8));
	assert_int_equal(recfile_header_decode((const uint8_t *)"frame,t,head_x\n", 15, &h), -1);
	r.b[20] ^= 1;
	assert_int_equal(recfile_header_decode(r.b, r.len, &h), -2);
	r.b[20] ^= 1;
	recfile_put16(r.b + 8, 2);
	recfile_put32(r.b + 28, 0);
	{
		/* a later version with a valid CRC */
		struct recfile_header v2 = { 2, 0, 0, 0 };

		recfile_header_encode(&v2, r.b);
		assert_int_equal(recfile_header_decode(r.b, r.len, &h), -3);
	}
}

static void test_sample_round_trip(void **state)
{
	struct recfile_sample a = { 3,
				    40000,
				    0xdeadbeef,
				    1ull << 62,
				    12345,
				    { 1.0f / 3, -7.5f, 1e-7f },
				    { 0.5f, 0.5f, -0.5f, 0.5f },
				    true,
				    { 1, -1, 0.25f, 0 } },
			      b;
	uint8_t p[RECFILE_SAMPLE_LEN_ANALOG];

	(void)state;
	assert_int_equal(recfile_sample_encode(&a, p), RECFILE_SAMPLE_LEN_ANALOG);
	assert_int_equal(recfile_sample_decode(p, RECFILE_SAMPLE_LEN_ANALOG, &b), 0);
	assert_memory_equal(&a.p, &b.p, sizeof(a.p));
	assert_memory_equal(&a.q, &b.q, sizeof(a.q));
	assert_memory_equal(&a.analog, &b.analog, sizeof(a.analog));
	assert_true(a.t_ns == b.t_ns && a.arrival_ns == b.arrival_ns && a.buttons == b.buttons);
	assert_true(a.source == b.source && a.sensor == b.sensor && b.has_analog);
	a.has_analog = false;
	assert_int_equal(recfile_sample_encode(&a, p), RECFILE_SAMPLE_LEN);
	assert_int_equal(recfile_sample_decode(p, RECFILE_SAMPLE_LEN, &b), 0);
	assert_false(b.has_analog);
	assert_true(b.analog[0] == 0);
	assert_int_equal(recfile_sample_decode(p, 51, &b), -1);
}

/* a recording indexed: names, samples in order, no damage, a clean end */
static void test_index(void **state)
{
	static struct rec_buf r;
	struct rec_index ix;
	char err[256], label[64];
	int s[3];

	(void)state;
	put_header(&r);
	put_session(&r, false);
	for (int i = 0; i < 30; i++)
		put_sample(&r, (uint16_t)(i % 2), (uint16_t)(i % 3), 1000 + (uint64_t)i, i == 4);
	{
		uint8_t e[RECFILE_END_LEN];
		struct recfile_end end = { 99, 31, 0 };

		recfile_end_encode(&end, e);
		put_record(&r, RECFILE_END, e, sizeof(e));
	}
	assert_int_equal(rec_index_parse(r.b, r.len, &ix, err, sizeof(err)), 0);
	assert_int_equal(ix.n_sensors, 9);
	assert_string_equal(ix.names[0], "clip.head");
	assert_string_equal(ix.names[3], "sim.p0.head");
	assert_string_equal(ix.names[8], "sim.p1.right_hand");
	assert_int_equal(ix.n_events, 30);
	assert_int_equal(ix.n_damage, 0);
	assert_true(ix.clean_end);
	assert_int_equal(ix.events[1].sensor, 3 + 1); /* sim, sensor 1 */
	assert_true(ix.events[4].analog[0] == 0.5f && ix.events[3].analog[0] == 0);
	assert_int_equal(ix.session.n_avatars, 1);
	assert_string_equal(ix.session.avatars[0].name, "demo");
	assert_int_equal(ix.session.avatars[0].id, 7);
	assert_int_equal(rec_index_person(&ix, NULL, s, label, sizeof(label), err, sizeof(err)), 0);
	assert_true(s[0] == 0 && s[1] == 1 && s[2] == 2);
	assert_int_equal(rec_index_person(&ix, "sim/p1", s, label, sizeof(label), err, sizeof(err)), 0);
	assert_true(s[0] == 6 && s[1] == 7 && s[2] == 8);
	assert_int_equal(rec_index_person(&ix, "sim/p2", s, label, sizeof(label), err, sizeof(err)), -1);
	assert_non_null(strstr(err, "sim.p2.head"));
	rec_index_free(&ix);
}

/* REMOTE records: a remote avatar's DESCRIBE and FRAMEs kept with its id and name; a bad one counted */
static void put_remote(struct rec_buf *r, uint64_t mono, const uint8_t *msg, size_t n)
{
	uint8_t p[RECFILE_MESSAGE_HEAD + WIRE_MAX_MSG];

	recfile_put64(p, mono);
	memcpy(p + RECFILE_MESSAGE_HEAD, msg, n);
	put_record(r, RECFILE_REMOTE, p, (uint32_t)(RECFILE_MESSAGE_HEAD + n));
}

/* a recording that starts with the DESCRIBE of remote avatar 1000, lab-a/person0, at mono */
static void remote_start(struct rec_buf *r, struct wire_describe *d, uint64_t mono)
{
	uint8_t msg[WIRE_MAX_MSG];

	put_header(r);
	put_session(r, false);
	memset(d, 0, sizeof(*d));
	d->h.avatar_id = 1000;
	strcpy(d->avatar_name, "lab-a/person0");
	d->site = (struct wire_site){ true, "lab-a", 0, 1, 240, 10, 0, 0.5f, 1, 0, 0.25f };
	put_remote(r, mono, msg, wire_encode_describe(d, msg));
}

static void test_index_remote(void **state)
{
	static struct rec_buf r;
	struct rec_index ix;
	struct wire_describe d;
	struct wire_frame f;
	uint8_t msg[WIRE_MAX_MSG];
	char err[256];

	(void)state;
	remote_start(&r, &d, 500);
	for (int i = 0; i < 5; i++) {
		memset(&f, 0, sizeof(f));
		f.h.avatar_id = 1000;
		f.joint[3] = 0.25f * (float)i;
		put_sample(&r, 0, 0, 1000 + (uint64_t)i, false);
		put_remote(&r, 1000 + (uint64_t)i, msg, wire_encode_frame(&f, msg));
	}
	put_remote(&r, 2000, (const uint8_t *)"not a message", 13);
	assert_string_equal(recfile_type_name(RECFILE_REMOTE), "REMOTE");
	assert_int_equal(rec_index_parse(r.b, r.len, &ix, err, sizeof(err)), 0);
	assert_int_equal(ix.n_events, 5);
	assert_int_equal(ix.n_remote, 6);
	assert_int_equal(ix.n_bad, 1);
	assert_int_equal(ix.n_other, 0);
	assert_int_equal(ix.n_remote_avatars, 1);
	assert_int_equal(ix.remote_avatars[0].id, 1000);
	assert_string_equal(ix.remote_avatars[0].name, "lab-a/person0");
	assert_int_equal(ix.remote_avatars[0].frames, 5);
	assert_int_equal(ix.remote[0].type, WIRE_DESCRIBE);
	assert_true(ix.remote[0].mono_ns == 500 && ix.remote[5].mono_ns == 1004);
	assert_int_equal(wire_decode_frame(ix.remote_bytes + ix.remote[5].off, ix.remote[5].len, &f), 0);
	assert_true(f.joint[3] == 1.0f);
	rec_index_free(&ix);
}

/* damage in the middle: reported at its offset, the records after it kept */
static void test_damage_resync(void **state)
{
	static struct rec_buf r;
	struct rec_index ix;
	char err[256];
	size_t hit;

	(void)state;
	put_header(&r);
	put_session(&r, false);
	for (int i = 0; i < 20; i++)
		put_sample(&r, 0, (uint16_t)(i % 3), 1000 + (uint64_t)i, false);
	/* sample 7 (record 8): one flipped byte in its payload */
	hit = r.off[8] + 20;
	r.b[hit] ^= 0x40;
	/* between samples 12 and 13: 37 bytes of garbage pushed in, holding a false sync word */
	memmove(r.b + r.off[14] + 37, r.b + r.off[14], r.len - r.off[14]);
	memset(r.b + r.off[14], 0x5a, 37);
	memcpy(r.b + r.off[14] + 10, "\xa5REC\x02\x34\x00\x00", 8);
	r.len += 37;
	assert_int_equal(rec_index_parse(r.b, r.len, &ix, err, sizeof(err)), 0);
	assert_int_equal(ix.n_damage, 2);
	assert_int_equal(ix.damage[0].off, r.off[8]);
	assert_int_equal(ix.damage[0].len, 64);
	assert_false(ix.damage[0].truncated);
	assert_int_equal(ix.damage[1].off, r.off[14]);
	assert_int_equal(ix.damage[1].len, 37);
	assert_int_equal(ix.n_events, 19);
	assert_true(ix.events[6].arrival_ns == 1006 && ix.events[7].arrival_ns == 1008);
	assert_true(ix.events[18].arrival_ns == 1019);
	assert_false(ix.clean_end);
	rec_index_free(&ix);
}

/* a file cut in the middle of its last record (kill -9, a full disk): everything before is read */
static void test_truncated(void **state)
{
	static struct rec_buf r;
	struct rec_index ix;
	char err[256];

	(void)state;
	put_header(&r);
	put_session(&r, false);
	for (int i = 0; i < 10; i++)
		put_sample(&r, 0, 0, 1000 + (uint64_t)i, false);
	for (size_t cut = 1; cut < 64; cut += 7) {
		assert_int_equal(rec_index_parse(r.b, r.len - cut, &ix, err, sizeof(err)), 0);
		assert_int_equal(ix.n_events, 9);
		assert_int_equal(ix.n_damage, 1);
		assert_true(ix.truncated);
		assert_int_equal(ix.damage[0].off, r.off[10]);
		assert_int_equal(ix.damage[0].len, 64 - cut);
		rec_index_free(&ix);
	}
	/* cut exactly between records: nothing wrong but the missing END */
	assert_int_equal(rec_index_parse(r.b, r.len, &ix, err, sizeof(err)), 0);
	assert_int_equal(ix.n_damage, 0);
	assert_false(ix.truncated);
	assert_false(ix.clean_end);
	rec_index_free(&ix);
	/* the header alone, or less */
	assert_int_equal(rec_index_parse(r.b, RECFILE_HEADER_LEN, &ix, err, sizeof(err)), -1);
	assert_non_null(strstr(err, "SESSION"));
	assert_int_equal(rec_index_parse(r.b, 20, &ix, err, sizeof(err)), -1);
}

/* a reload reorders the sources: samples still land on their sensors, by name */
static void test_second_session(void **state)
{
	static struct rec_buf r;
	struct rec_index ix;
	char err[256];

	(void)state;
	put_header(&r);
	put_session(&r, false);
	put_sample(&r, 1, 4, 1000, false); /* sim.p1.left_hand */
	put_session(&r, true);
	put_sample(&r, 0, 4, 1001, false); /* sources swapped: still sim.p1.left_hand */
	put_sample(&r, 1, 2, 1002, false); /* clip.right_hand */
	assert_int_equal(rec_index_parse(r.b, r.len, &ix, err, sizeof(err)), 0);
	assert_int_equal(ix.n_sessions, 2);
	assert_int_equal(ix.n_events, 3);
	assert_int_equal(ix.events[0].sensor, 7);
	assert_int_equal(ix.events[1].sensor, 7);
	assert_int_equal(ix.events[2].sensor, 2);
	rec_index_free(&ix);
}

/* gaps are counted, unknown record types skipped, and a sample of no source is not played */
static void test_gap_unknown_bad(void **state)
{
	static struct rec_buf r;
	struct rec_index ix;
	char err[256];
	uint8_t g[RECFILE_GAP_LEN];
	struct recfile_gap gap = { 5, 17, 1088 };

	(void)state;
	put_header(&r);
	put_session(&r, false);
	put_sample(&r, 0, 0, 1000, false);
	recfile_gap_encode(&gap, g);
	put_record(&r, RECFILE_GAP, g, sizeof(g));
	put_record(&r, 99, (const uint8_t *)"later", 5);
	put_sample(&r, 5, 0, 1001, false);
	put_sample(&r, 0, 9, 1002, false);
	put_sample(&r, 0, 1, 1003, false);
	assert_int_equal(rec_index_parse(r.b, r.len, &ix, err, sizeof(err)), 0);
	assert_int_equal(ix.n_gaps, 1);
	assert_true(ix.lost_records == 17);
	assert_int_equal(ix.n_other, 1);
	assert_int_equal(ix.n_bad, 2);
	assert_int_equal(ix.n_events, 2);
	rec_index_free(&ix);
}

/* a sample before any SESSION cannot be named: the file is refused, not guessed at */
static void test_no_session(void **state)
{
	static struct rec_buf r;
	struct rec_index ix;
	char err[256];

	(void)state;
	put_header(&r);
	put_sample(&r, 0, 0, 1000, false);
	assert_int_equal(rec_index_parse(r.b, r.len, &ix, err, sizeof(err)), -1);
	assert_non_null(strstr(err, "SESSION"));
}

/* r written to a new temporary file: its name in path (char[] "/tmp/avatargw-test-recfile-XXXXXX") */
static void write_temp(const struct rec_buf *r, char *path)
{
	int fd = mkstemp(path);
	FILE *f;

	assert_true(fd >= 0);
	f = fdopen(fd, "wb");
	assert_non_null(f);
	assert_int_equal(fwrite(r->b, 1, r->len, f), r->len);
	assert_int_equal(fclose(f), 0);
}

/* r as a replay source's file (a temporary one, its name in path) with the keys given; opened */
static void replay_open(const struct rec_buf *r, char *path, const char *keys, struct config *cfg, struct tracker *t)
{
	char text[256], err[512];

	write_temp(r, path);
	snprintf(text, sizeof(text), "[source r]\ntype = replay\nfile = %s\n%s", path, keys);
	assert_int_equal(config_load_text(cfg, "t.conf", text, err, sizeof(err)), 0);
	assert_int_equal(tracker_open(t, &cfg->source[0], err, sizeof(err)), 0);
}

static void replay_close(struct tracker *t, struct config *cfg, const char *path)
{
	tracker_close(t);
	config_free(cfg);
	unlink(path);
}

/* a FRAME of remote avatar 1000 (remote_start's) at mono, its sample time and J5 given */
static void put_remote_frame(struct rec_buf *r, uint64_t mono, uint64_t sample_time, float j5)
{
	struct wire_frame f;
	uint8_t msg[WIRE_MAX_MSG];

	memset(&f, 0, sizeof(f));
	f.h.avatar_id = 1000;
	f.h.sample_time_ns = sample_time;
	f.joint[5] = j5;
	put_remote(r, mono, msg, wire_encode_frame(&f, msg));
}

/*
 * The replay source names a recording's sensors at configuration time from
 * the first record alone; when that one is damaged, the loader finds the
 * next good SESSION. Both must agree (found by tests/fuzz/fuzz_replay.c:
 * the configuration said 0 sensors, open() then failed with "changed while
 * the configuration was read").
 */
static void test_replay_damaged_first_session(void **state)
{
	static struct rec_buf r;
	static struct config cfg;
	char path[] = "/tmp/avatargw-test-recfile-XXXXXX", text[256], err[512];
	struct tracker t;
	const struct cfg_type *drv;

	(void)state;
	put_header(&r);
	put_session(&r, false);
	r.b[r.off[0] + 30] ^= 0x01; /* the first SESSION's CRC no longer holds */
	put_session(&r, false);
	for (int i = 0; i < 6; i++)
		put_sample(&r, 0, (uint16_t)(i % 3), 1000 + 1000000 * (uint64_t)i, false);
	write_temp(&r, path);
	snprintf(text, sizeof(text), "[source r]\ntype = replay\nfile = %s\nstep = yes\n", path);
	assert_int_equal(config_load_text(&cfg, "t.conf", text, err, sizeof(err)), 0);
	drv = cfg_source_type(cfg.source[0].driver);
	assert_int_equal(drv->sensor_count(&cfg.source[0]), 9);
	{
		char name[64];

		drv->sensor_name(&cfg.source[0], 4, name, sizeof(name));
		assert_string_equal(name, "sim.p0.left_hand");
	}
	assert_int_equal(tracker_open(&t, &cfg.source[0], err, sizeof(err)), 0);
	assert_int_equal(t.n_sensors, 9);
	tracker_close(&t);
	config_free(&cfg);
	unlink(path);
}

/*
 * A sample of a recording whose analog values are not finite is malformed:
 * counted and never played, like one whose pose is not a pose (found by
 * tests/fuzz/fuzz_replay.c: a NaN went into the sensor's slot, and from
 * there into the FRAME's input block).
 */
static void test_replay_nonfinite_analog(void **state)
{
	static struct rec_buf r;
	static struct config cfg;
	char path[] = "/tmp/avatargw-test-recfile-XXXXXX", text[256], err[512];
	struct tracker_clock now = { 1000000000000ull, 0 };
	struct tracker t;
	int played = 0;

	(void)state;
	put_header(&r);
	put_session(&r, false);
	for (int i = 0; i < 6; i++) {
		struct recfile_sample s = {
			0,    (uint16_t)(i % 3),     0, 7, 1000 + 1000000 * (uint64_t)i, { 1, 2, 3 }, { 1, 0, 0, 0 },
			true, { 0.5f, -1, 0, 0.25f }
		};
		uint8_t p[RECFILE_SAMPLE_LEN_ANALOG];

		if (i == 2)
			s.analog[1] = NAN;
		if (i == 4)
			s.analog[3] = INFINITY;
		put_record(&r, RECFILE_SAMPLE, p, (uint32_t)recfile_sample_encode(&s, p));
	}
	write_temp(&r, path);
	snprintf(text, sizeof(text), "[source r]\ntype = replay\nfile = %s\nstep = yes\nloop = no\n", path);
	assert_int_equal(config_load_text(&cfg, "t.conf", text, err, sizeof(err)), 0);
	assert_int_equal(tracker_open(&t, &cfg.source[0], err, sizeof(err)), 0);
	assert_int_equal(atomic_load(&t.st.malformed), 2);
	for (int k = 0; k < 8; k++) {
		int n;

		if (k)
			assert_int_equal(replay_step(&t, 1), 0);
		n = t.drv->poll(&t, &now);
		assert_true(n >= 0);
		played += n;
		for (int i = 0; i < t.n_sensors; i++)
			for (int a = 0; a < SENSOR_ANALOG_MAX; a++)
				assert_true(isfinite(t.slot[i].analog[a]));
	}
	assert_int_equal(played, 4);
	assert_true(t.slot[0].analog[0] == 0.5f && t.slot[0].analog[3] == 0.25f);
	tracker_close(&t);
	config_free(&cfg);
	unlink(path);
}

/* a replay test of remote avatars: its recording, source and what the remote avatar published */
struct remote_fx {
	struct rec_buf r;
	struct config cfg;
	struct wire_describe d, dout;
	char path[40];
	struct tracker_clock now;
	struct wire_frame out;
	struct tracker t;
	bool described, fresh;
};

static struct remote_fx *remote_fx(void)
{
	static struct remote_fx x;

	memset(&x, 0, sizeof(x));
	snprintf(x.path, sizeof(x.path), "/tmp/avatargw-test-recfile-XXXXXX");
	x.now.mono_ns = 1000000000000ull;
	return &x;
}

/* remote avatar 0 of the replay now (stale after 50 ms): whether it publishes, its frame in x->out */
static bool remote_now(struct remote_fx *x)
{
	return x->t.drv->solved(&x->t, 0, x->now.mono_ns, 50000000, &x->out, &x->dout, &x->described, &x->fresh);
}

/* a recording of remote avatars only (a site without trackers): replayed as recorded, on its clock */
static void test_replay_remote_only(void **state)
{
	struct remote_fx *x = remote_fx();
	uint16_t id;

	(void)state;
	remote_start(&x->r, &x->d, 5000000);
	for (int i = 0; i < 10; i++)
		put_remote_frame(&x->r, 5000000 + 10000000 * (uint64_t)i, 77 + (uint64_t)i, 0.1f * (float)i);
	replay_open(&x->r, x->path, "loop = no\n", &x->cfg, &x->t);
	assert_int_equal(x->t.drv->solved_count(&x->t), 1);
	assert_string_equal(x->t.drv->solved_name(&x->t, 0, &id), "lab-a/person0");
	assert_int_equal(id, 1000);
	/* the first poll starts the clip: the DESCRIBE and the first frame (both at clip time 0) */
	assert_int_equal(x->t.drv->poll(&x->t, &x->now), 0);
	assert_true(remote_now(x));
	assert_true(x->described && x->fresh);
	assert_string_equal(x->dout.avatar_name, "lab-a/person0");
	assert_true(x->dout.site.present && x->dout.site.rtt_ms == 0.25f);
	assert_true(x->out.h.sample_time_ns == 77 && x->out.joint[5] == 0.0f && (x->out.h.flags & WIRE_F_NEW_SAMPLE));
	/* 45 ms later: the frame recorded at 40 ms, joint angles as recorded */
	x->now.mono_ns += 45000000;
	x->t.drv->poll(&x->t, &x->now);
	assert_true(remote_now(x));
	assert_true(!x->described && x->fresh);
	assert_true(x->out.h.sample_time_ns == 81 && x->out.joint[5] == 0.4f);
	assert_int_equal(x->out.sensor[0].state, WIRE_SENSOR_OK);
	/* past the end: nothing new, STALE after the stale time */
	x->now.mono_ns += 500000000;
	x->t.drv->poll(&x->t, &x->now);
	assert_true(remote_now(x));
	assert_int_equal(x->out.h.sample_time_ns, 86);
	x->now.mono_ns += 60000000;
	assert_true(remote_now(x));
	assert_false(x->fresh);
	assert_true((x->out.h.flags & WIRE_F_STALE) && x->out.sensor[0].state == WIRE_SENSOR_STALE);
	assert_int_equal(atomic_load(&x->t.st.state), TRACKER_ENDED);
	replay_close(&x->t, &x->cfg, x->path);
}

/* a stepped replay plays the remote avatars too: at each instant, what was recorded up to its time */
static void test_replay_remote_stepped(void **state)
{
	struct remote_fx *x = remote_fx();

	(void)state;
	/* instants every 10 ms from 1 ms, the remote avatar's frames 5 ms after each */
	remote_start(&x->r, &x->d, 1000000);
	for (int i = 0; i < 6; i++) {
		for (uint16_t s = 0; s < 3; s++)
			put_sample(&x->r, 0, s, 1000000 + 10000000 * (uint64_t)i, false);
		put_remote_frame(&x->r, 6000000 + 10000000 * (uint64_t)i, 77 + (uint64_t)i, 0.1f * (float)i);
	}
	replay_open(&x->r, x->path, "step = yes\nloop = no\n", &x->cfg, &x->t);
	assert_int_equal(x->t.drv->solved_count(&x->t), 1);
	/* the first instant: the DESCRIBE recorded with it, no frame yet */
	assert_int_equal(x->t.drv->poll(&x->t, &x->now), 3);
	assert_false(remote_now(x));
	/* no step, however long: nothing new */
	x->now.mono_ns += 1000000000;
	assert_int_equal(x->t.drv->poll(&x->t, &x->now), 0);
	assert_false(remote_now(x));
	for (int k = 1; k < 6; k++) {
		assert_int_equal(replay_step(&x->t, 1), 0);
		x->now.mono_ns += 1000000;
		assert_int_equal(x->t.drv->poll(&x->t, &x->now), 3);
		assert_true(remote_now(x));
		assert_true(x->fresh);
		assert_true(x->out.h.sample_time_ns == 77 + (uint64_t)(k - 1) &&
			    x->out.joint[5] == 0.1f * (float)(k - 1));
	}
	/* the step past the last instant ends the source and plays the frame recorded after it */
	assert_int_equal(replay_step(&x->t, 1), 0);
	x->now.mono_ns += 1000000;
	assert_int_equal(x->t.drv->poll(&x->t, &x->now), 0);
	assert_int_equal(atomic_load(&x->t.st.state), TRACKER_ENDED);
	assert_true(remote_now(x));
	assert_true(x->out.h.sample_time_ns == 82 && x->out.joint[5] == 0.5f);
	replay_close(&x->t, &x->cfg, x->path);
}

/* a remote avatar whose site left while recording (its DESCRIBE saying gone): no frames in the replay from
 * then on, as live, until a frame of it comes again (then its DESCRIBE at once) */
static void test_replay_remote_departure(void **state)
{
	struct remote_fx *x = remote_fx();
	uint8_t msg[WIRE_MAX_MSG];

	(void)state;
	remote_start(&x->r, &x->d, 1000000);
	for (int i = 0; i < 3; i++)
		put_remote_frame(&x->r, 1000000 + 10000000 * (uint64_t)i, 77 + (uint64_t)i, 0);
	x->d.site.state = WIRE_SITE_GONE; /* 25 ms: its site left */
	put_remote(&x->r, 26000000, msg, wire_encode_describe(&x->d, msg));
	x->d.site.state = WIRE_SITE_PRESENT;
	put_remote_frame(&x->r, 101000000, 177, 0); /* 100 ms: back */
	replay_open(&x->r, x->path, "loop = no\n", &x->cfg, &x->t);
	x->t.drv->poll(&x->t, &x->now);
	assert_true(remote_now(x));
	assert_true(x->described && x->out.h.sample_time_ns == 77);
	x->now.mono_ns += 21000000;
	x->t.drv->poll(&x->t, &x->now);
	assert_true(remote_now(x));
	assert_true(x->fresh && !x->described && x->out.h.sample_time_ns == 79);
	/* gone: nothing, not even stale frames */
	for (int k = 0; k < 7; k++) {
		x->now.mono_ns += 10000000;
		x->t.drv->poll(&x->t, &x->now);
		assert_false(remote_now(x));
	}
	/* back at 100 ms: its frame, and its DESCRIBE again */
	x->now.mono_ns += 10000000;
	x->t.drv->poll(&x->t, &x->now);
	assert_true(remote_now(x));
	assert_true(x->fresh && x->described && x->out.h.sample_time_ns == 177);
	assert_int_equal(x->dout.site.state, WIRE_SITE_PRESENT);
	replay_close(&x->t, &x->cfg, x->path);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_layout),
		cmocka_unit_test(test_layout_crc),
		cmocka_unit_test(test_header),
		cmocka_unit_test(test_sample_round_trip),
		cmocka_unit_test(test_index),
		cmocka_unit_test(test_damage_resync),
		cmocka_unit_test(test_truncated),
		cmocka_unit_test(test_second_session),
		cmocka_unit_test(test_gap_unknown_bad),
		cmocka_unit_test(test_no_session),
		cmocka_unit_test(test_index_remote),
		cmocka_unit_test(test_replay_remote_only),
		cmocka_unit_test(test_replay_remote_stepped),
		cmocka_unit_test(test_replay_remote_departure),
		cmocka_unit_test(test_replay_damaged_first_session),
		cmocka_unit_test(test_replay_nonfinite_analog),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
