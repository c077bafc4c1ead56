// SPDX-License-Identifier: MIT
/*
 * test_wire.c - the protocol of avatargw/wire.h: FRAME and DESCRIBE round
 * trips down to the bit pattern of every float, golden bytes of a
 * hand-built header, every decoder error, forward compatibility (extra
 * header and payload bytes), the size budget of the worst-case DESCRIBE,
 * and the stream length prefix.
 */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "avatargw/wire.h"

#include "testutil.h"

/* the sizes docs/PROTOCOL.md gives */
#define FRAME_PAYLOAD 460
#define FRAME_LEN (WIRE_HEADER_LEN + FRAME_PAYLOAD)

/* room for any message plus a guard zone the encoders must not touch */
#define BUF_LEN 4096
#define GUARD 0xa5

/* ---- checks ---------------------------------------------------------------- */

/* the same 32 bits: NaN payloads and signs included */
#define assert_f32_same(got, want)                                                                                     \
	do {                                                                                                           \
		float g_ = (got), w_ = (want);                                                                         \
		uint32_t gb_, wb_;                                                                                     \
		memcpy(&gb_, &g_, 4);                                                                                  \
		memcpy(&wb_, &w_, 4);                                                                                  \
		if (gb_ != wb_)                                                                                        \
			fail_msg("%s: %s = %.9g (0x%08x), want %.9g (0x%08x)", ctx, #got, g_, (unsigned)gb_, w_,       \
				 (unsigned)wb_);                                                                       \
	} while (0)

static void assert_pose_same(const struct wire_pose *got, const struct wire_pose *want)
{
	for (int k = 0; k < 3; k++)
		assert_f32_same(got->p[k], want->p[k]);
	for (int k = 0; k < 4; k++)
		assert_f32_same(got->q[k], want->q[k]);
}

/* the header fields a sender chooses (the encoder fills in the rest) */
static void assert_header_same(const struct wire_header *got, const struct wire_header *want)
{
	assert_int_equal(got->flags, want->flags);
	assert_int_equal(got->source_id, want->source_id);
	assert_int_equal(got->seq, want->seq);
	assert_int_equal(got->describe_rev, want->describe_rev);
	assert_true(got->sample_time_ns == want->sample_time_ns);
	assert_int_equal(got->avatar_id, want->avatar_id);
}

static void assert_frame_same(const struct wire_frame *got, const struct wire_frame *want)
{
	set_ctx("frame header");
	assert_header_same(&got->h, &want->h);
	for (int i = 0; i < WIRE_SENSORS; i++) {
		set_ctx("sensor %d", i);
		assert_int_equal(got->sensor[i].state, want->sensor[i].state);
		assert_int_equal(got->sensor[i].age_100us, want->sensor[i].age_100us);
		assert_pose_same(&got->sensor[i].pose, &want->sensor[i].pose);
	}
	for (int i = 0; i < WIRE_ARMS; i++) {
		set_ctx("arm %d", i);
		assert_int_equal(got->arm[i].ik_flags, want->arm[i].ik_flags);
		assert_int_equal(got->arm[i].iters, want->arm[i].iters);
		assert_f32_same(got->arm[i].pos_err, want->arm[i].pos_err);
	}
	for (int i = 0; i < WIRE_JOINTS; i++) {
		set_ctx("joint %d", i);
		assert_f32_same(got->joint[i], want->joint[i]);
	}
	for (int i = 0; i < WIRE_SEGMENTS; i++) {
		set_ctx("segment %d", i);
		assert_pose_same(&got->segment[i], &want->segment[i]);
	}
}

static void assert_describe_same(const struct wire_describe *got, const struct wire_describe *want)
{
	set_ctx("describe header");
	assert_header_same(&got->h, &want->h);
	set_ctx("describe body");
	assert_f32_same(got->rate_hz, want->rate_hz);
	for (int k = 0; k < 4; k++)
		assert_f32_same(got->dims[k], want->dims[k]);
	for (int k = 0; k < 3; k++)
		assert_f32_same(got->head_offset[k], want->head_offset[k]);
	assert_string_equal(got->avatar_name, want->avatar_name);
	assert_string_equal(got->conventions, want->conventions);
	for (int i = 0; i < WIRE_JOINTS; i++) {
		const struct wire_joint_desc *g = &got->joint[i], *w = &want->joint[i];

		set_ctx("joint %d", i);
		assert_string_equal(g->name, w->name);
		assert_int_equal(g->segment, w->segment);
		assert_f32_same(g->lo, w->lo);
		assert_f32_same(g->hi, w->hi);
		for (int k = 0; k < 3; k++) {
			assert_f32_same(g->axis[k], w->axis[k]);
			assert_f32_same(g->trans[k], w->trans[k]);
		}
	}
	for (int i = 0; i < WIRE_SEGMENTS; i++) {
		set_ctx("segment %d", i);
		assert_string_equal(got->segment[i].name, want->segment[i].name);
		assert_int_equal(got->segment[i].parent, want->segment[i].parent);
	}
	for (int i = 0; i < WIRE_SENSORS; i++) {
		set_ctx("sensor %d", i);
		assert_string_equal(got->sensor[i], want->sensor[i]);
	}
}

/* bytes [from, BUF_LEN) still hold the guard pattern */
static void assert_guard(const uint8_t *buf, size_t from)
{
	for (size_t i = from; i < BUF_LEN; i++)
		if (buf[i] != GUARD)
			fail_msg("the encoder wrote byte %zu, past the %zu bytes it returned", i, from);
}

/* ---- makers ---------------------------------------------------------------- */

static float f32_bits(uint32_t v)
{
	float f;

	memcpy(&f, &v, 4);
	return f;
}

static float rnd_f32(void)
{
	return (float)rnd_range(-10, 10);
}

/* NaN with distinct payloads and signs, infinities, -0, a subnormal */
static float special_f32(int i)
{
	static const uint32_t bits[] = { 0x7fc00000, 0xffc00000, 0x7fc12345, 0x7f800000,
					 0xff800000, 0x80000000, 0x00000001 };

	return f32_bits(bits[i % (int)(sizeof(bits) / sizeof(bits[0]))]);
}

static void rnd_pose(struct wire_pose *p)
{
	for (int k = 0; k < 3; k++)
		p->p[k] = rnd_f32();
	for (int k = 0; k < 4; k++)
		p->q[k] = rnd_f32();
}

static void rnd_header(struct wire_header *h)
{
	memset(h, 0, sizeof(*h));
	h->flags = (uint16_t)(rnd() * 65536);
	h->source_id = (uint32_t)(rnd() * 4294967296.0);
	h->seq = (uint32_t)(rnd() * 4294967296.0);
	h->describe_rev = (uint32_t)(rnd() * 4294967296.0);
	h->sample_time_ns = (uint64_t)(rnd() * 4294967296.0) << 32 | (uint64_t)(rnd() * 4294967296.0);
	h->avatar_id = (uint16_t)(rnd() * 65536);
}

/* every field random, some floats replaced by NaN and other specials */
static void make_frame(struct wire_frame *f)
{
	memset(f, 0, sizeof(*f));
	rnd_header(&f->h);
	/* every flag but the one that adds the input block (test_inputs_*) */
	f->h.flags &= (uint16_t)~WIRE_F_INPUTS;
	for (int i = 0; i < WIRE_SENSORS; i++) {
		f->sensor[i].state = (uint8_t)(rnd() * 256);
		f->sensor[i].age_100us = (uint16_t)(rnd() * 65536);
		rnd_pose(&f->sensor[i].pose);
	}
	for (int i = 0; i < WIRE_ARMS; i++) {
		f->arm[i].ik_flags = (uint16_t)(rnd() * 65536);
		f->arm[i].iters = (uint8_t)(rnd() * 256);
		f->arm[i].pos_err = rnd_f32();
	}
	for (int i = 0; i < WIRE_JOINTS; i++)
		f->joint[i] = rnd_f32();
	for (int i = 0; i < WIRE_SEGMENTS; i++)
		rnd_pose(&f->segment[i]);
	/* a MISSING sensor, unknown joints, a special in every section */
	f->sensor[WIRE_S_LEFT_HAND].state = WIRE_SENSOR_MISSING;
	for (int k = 0; k < 3; k++)
		f->sensor[WIRE_S_LEFT_HAND].pose.p[k] = special_f32(k);
	for (int k = 0; k < 4; k++)
		f->sensor[WIRE_S_LEFT_HAND].pose.q[k] = special_f32(k + 3);
	f->arm[WIRE_ARM_LEFT].pos_err = special_f32(0);
	for (int i = 9; i < WIRE_JOINTS; i++)
		f->joint[i] = special_f32(i);
	f->segment[WIRE_SEG_L_HAND].q[0] = special_f32(2);
	f->segment[WIRE_SEG_R_ELBOW].p[1] = special_f32(1);
}

/* a string of exactly len bytes from a varied alphabet (no NUL) */
static void fill_name(char *out, size_t len, int seed)
{
	static const char alpha[] = "abcdefghijklmnopqrstuvwxyz_0123456789-\"\\\x01\x7f\xc3\xa9";

	for (size_t i = 0; i < len; i++)
		out[i] = alpha[(i * 7 + (size_t)seed * 13) % (sizeof(alpha) - 1)];
	out[len] = '\0';
}

/* a realistic skeleton: the names of version 1, the arm chain's axes */
static void make_describe(struct wire_describe *d)
{
	static const uint8_t seg_of[8] = { WIRE_SEG_R_SHOULDER, WIRE_SEG_R_SHOULDER, WIRE_SEG_R_SHOULDER,
					   WIRE_SEG_R_SHOULDER, WIRE_SEG_R_ELBOW,    WIRE_SEG_R_WRIST,
					   WIRE_SEG_R_WRIST,	WIRE_SEG_R_WRIST };
	static const uint8_t parent[WIRE_SEGMENTS] = { 255, 0, 0, 2, 3, 4, 0, 6, 7, 8 };

	memset(d, 0, sizeof(*d));
	rnd_header(&d->h);
	d->rate_hz = 90;
	d->dims[0] = 0.18f;
	d->dims[1] = 0.30f;
	d->dims[2] = 0.26f;
	d->dims[3] = 0.08f;
	d->head_offset[0] = 0;
	d->head_offset[1] = special_f32(2); /* NaN survives here too */
	d->head_offset[2] = 0.25f;
	strcpy(d->avatar_name, "operator-1");
	strcpy(d->conventions, "z-up rh m rad q=wxyz");
	for (int i = 0; i < WIRE_JOINTS; i++) {
		struct wire_joint_desc *j = &d->joint[i];

		strcpy(j->name, wire_joint_names[i]);
		j->segment = i == 0 ? WIRE_SEG_CHEST : (uint8_t)(seg_of[(i - 1) % 8] + (i > 8 ? 4 : 0));
		j->lo = rnd_f32();
		j->hi = rnd_f32();
		for (int k = 0; k < 3; k++) {
			j->axis[k] = rnd_f32();
			j->trans[k] = rnd_f32();
		}
	}
	d->joint[16].hi = special_f32(5);
	for (int i = 0; i < WIRE_SEGMENTS; i++) {
		strcpy(d->segment[i].name, wire_segment_names[i]);
		d->segment[i].parent = parent[i];
	}
	for (int i = 0; i < WIRE_SENSORS; i++)
		strcpy(d->sensor[i], wire_sensor_names[i]);
}

/* every string as long as its field allows */
static void make_describe_worst(struct wire_describe *d)
{
	make_describe(d);
	fill_name(d->avatar_name, sizeof(d->avatar_name) - 1, 1);
	fill_name(d->conventions, sizeof(d->conventions) - 1, 2);
	for (int i = 0; i < WIRE_JOINTS; i++)
		fill_name(d->joint[i].name, sizeof(d->joint[i].name) - 1, 3 + i);
	for (int i = 0; i < WIRE_SEGMENTS; i++)
		fill_name(d->segment[i].name, sizeof(d->segment[i].name) - 1, 20 + i);
	for (int i = 0; i < WIRE_SENSORS; i++)
		fill_name(d->sensor[i], sizeof(d->sensor[i]) - 1, 30 + i);
}

static void put16(uint8_t *p, uint16_t v)
{
	p[0] = (uint8_t)v;
	p[1] = (uint8_t)(v >> 8);
}

static size_t encode_frame(uint8_t *buf)
{
	struct wire_frame f;

	make_frame(&f);
	return wire_encode_frame(&f, buf);
}

/* ---- round trips ---------------------------------------------------------------- */

static void test_frame_round_trip(void **state)
{
	(void)state;
	rng_seed(1);
	for (int n = 0; n < 200; n++) {
		struct wire_frame f, g;
		uint8_t buf[BUF_LEN];
		size_t len;
		int ret;

		make_frame(&f);
		memset(buf, GUARD, sizeof(buf));
		len = wire_encode_frame(&f, buf);
		assert_int_equal(len, FRAME_LEN);
		assert_guard(buf, len);
		memset(&g, 0x5a, sizeof(g));
		ret = wire_decode_frame(buf, len, &g);
		assert_int_equal(ret, 0);
		assert_int_equal(g.h.version, WIRE_VERSION);
		assert_int_equal(g.h.type, WIRE_FRAME);
		assert_int_equal(g.h.header_len, WIRE_HEADER_LEN);
		assert_int_equal(g.h.payload_len, FRAME_PAYLOAD);
		assert_int_equal(g.h.n_joints, WIRE_JOINTS);
		assert_int_equal(g.h.n_segments, WIRE_SEGMENTS);
		assert_int_equal(g.h.n_sensors, WIRE_SENSORS);
		assert_frame_same(&g, &f);
		/* NaN really went through as NaN */
		assert_true(isnan(g.joint[9]));
		assert_true(isnan(g.sensor[WIRE_S_LEFT_HAND].pose.p[0]));
	}
}

static void test_frame_encoder_owns_header(void **state)
{
	struct wire_frame f;
	struct wire_header h;
	uint8_t buf[BUF_LEN];

	(void)state;
	rng_seed(2);
	make_frame(&f);
	/* whatever the caller leaves in these, the encoder writes version 1's values */
	f.h.version = 9;
	f.h.type = WIRE_DESCRIBE;
	f.h.header_len = 7;
	f.h.payload_len = 3;
	f.h.n_joints = 1;
	f.h.n_segments = 2;
	f.h.n_sensors = 4;
	assert_int_equal(wire_encode_frame(&f, buf), FRAME_LEN);
	assert_int_equal(wire_peek(buf, FRAME_LEN, &h), WIRE_FRAME);
	assert_int_equal(h.version, WIRE_VERSION);
	assert_int_equal(h.header_len, WIRE_HEADER_LEN);
	assert_int_equal(h.payload_len, FRAME_PAYLOAD);
	assert_int_equal(h.n_joints, WIRE_JOINTS);
	assert_int_equal(h.n_segments, WIRE_SEGMENTS);
	assert_int_equal(h.n_sensors, WIRE_SENSORS);
	/* reserved bytes are zero */
	assert_int_equal(buf[37], 0);
	assert_int_equal(buf[38], 0);
	assert_int_equal(buf[39], 0);
}

static void test_describe_round_trip(void **state)
{
	(void)state;
	rng_seed(3);
	for (int n = 0; n < 50; n++) {
		struct wire_describe d, e;
		uint8_t buf[BUF_LEN];
		size_t len, want;
		int ret;

		make_describe(&d);
		/* a varied avatar name length, up to the field's maximum */
		fill_name(d.avatar_name, (size_t)n % sizeof(d.avatar_name), n);
		memset(buf, GUARD, sizeof(buf));
		len = wire_encode_describe(&d, buf);
		/* 40 + 32 fixed + 7 per string's count and body + 33 per joint + 1 per segment */
		want = WIRE_HEADER_LEN + 32 + 2 + strlen(d.avatar_name) + strlen(d.conventions);
		for (int i = 0; i < WIRE_JOINTS; i++)
			want += 1 + strlen(d.joint[i].name) + 1 + 8 * 4;
		for (int i = 0; i < WIRE_SEGMENTS; i++)
			want += 1 + strlen(d.segment[i].name) + 1;
		for (int i = 0; i < WIRE_SENSORS; i++)
			want += 1 + strlen(d.sensor[i]);
		assert_int_equal(len, want);
		assert_true(len <= WIRE_MAX_MSG);
		assert_guard(buf, len);
		memset(&e, 0x5a, sizeof(e));
		ret = wire_decode_describe(buf, len, &e);
		assert_int_equal(ret, 0);
		assert_int_equal(e.h.type, WIRE_DESCRIBE);
		assert_int_equal(e.h.payload_len, len - WIRE_HEADER_LEN);
		assert_describe_same(&e, &d);
		assert_true(isnan(e.head_offset[1]));
	}
}

/* the size docs/PROTOCOL.md quotes for the names of version 1 */
static void test_describe_v1_size(void **state)
{
	struct wire_describe d;
	uint8_t buf[BUF_LEN];

	(void)state;
	rng_seed(4);
	make_describe(&d);
	d.avatar_name[0] = '\0';
	d.conventions[0] = '\0';
	assert_int_equal(wire_encode_describe(&d, buf), 912);
}

/*
 * The worst case: every string as long as the format lets it be. It must
 * fit in one datagram, and the encoder must stay within WIRE_MAX_MSG bytes,
 * the size wire.h asks callers to provide.
 */
static void test_describe_worst_case_fits(void **state)
{
	struct wire_describe d, e;
	uint8_t buf[BUF_LEN];
	size_t len;

	(void)state;
	rng_seed(5);
	make_describe_worst(&d);
	memset(buf, GUARD, sizeof(buf));
	len = wire_encode_describe(&d, buf);
	if (len > WIRE_MAX_MSG)
		fail_msg("the worst-case DESCRIBE takes %zu bytes, more than WIRE_MAX_MSG = %d", len, WIRE_MAX_MSG);
	assert_guard(buf, len);
	assert_int_equal(wire_decode_describe(buf, len, &e), 0);
	assert_describe_same(&e, &d);
}

/* ---- golden bytes ------------------------------------------------------------------ */

static void test_frame_golden_header(void **state)
{
	static const uint8_t want[WIRE_HEADER_LEN] = {
		0x41, 0x56, 0x47, 0x57,				/*  0 magic "AVGW" */
		0x01,						/*  4 version */
		0x01,						/*  5 type FRAME */
		0x28, 0x00,					/*  6 header_len 40 */
		0xcc, 0x01,					/*  8 payload_len 460 */
		0x09, 0x00,					/* 10 flags STALE | NEW_SAMPLE */
		0xef, 0xbe, 0xad, 0xde,				/* 12 source_id 0xdeadbeef */
		0x04, 0x03, 0x02, 0x01,				/* 16 seq 0x01020304 */
		0x05, 0x00, 0x00, 0x00,				/* 20 describe_rev 5 */
		0x15, 0x81, 0xe9, 0x7d, 0xf4, 0x10, 0x22, 0x11, /* 24 sample_time_ns 0x112210f47de98115 */
		0x0b, 0x0a,					/* 32 avatar_id 0x0a0b */
		0x11, 0x0a, 0x03,				/* 34 counts 17, 10, 3 */
		0x00, 0x00, 0x00,				/* 37 reserved */
	};
	struct wire_frame f;
	uint8_t buf[BUF_LEN];
	size_t len;

	(void)state;
	memset(&f, 0, sizeof(f));
	f.h.flags = WIRE_F_STALE | WIRE_F_NEW_SAMPLE;
	f.h.source_id = 0xdeadbeef;
	f.h.seq = 0x01020304;
	f.h.describe_rev = 5;
	f.h.sample_time_ns = 1234567890123456789ull; /* 0x112210f47de98115 */
	f.h.avatar_id = 0x0a0b;
	f.sensor[WIRE_S_HEAD].state = WIRE_SENSOR_STALE;
	f.sensor[WIRE_S_HEAD].age_100us = 0x1234;
	f.sensor[WIRE_S_HEAD].pose.p[0] = 1.0f;
	f.sensor[WIRE_S_HEAD].pose.q[0] = -2.0f;
	f.arm[WIRE_ARM_RIGHT].ik_flags = 0x0019;
	f.arm[WIRE_ARM_RIGHT].iters = 7;
	f.arm[WIRE_ARM_LEFT].pos_err = 0.5f;
	f.joint[0] = f32_bits(0x7fc00000);
	f.joint[16] = 0.25f;
	f.segment[WIRE_SEG_CHEST].p[0] = 1.5f;
	f.segment[WIRE_SEG_L_HAND].q[3] = -1.0f;

	memset(buf, GUARD, sizeof(buf));
	len = wire_encode_frame(&f, buf);
	assert_int_equal(len, 500);
	assert_memory_equal(buf, want, sizeof(want));

	/* the payload at the offsets of docs/PROTOCOL.md */
	assert_int_equal(buf[40], WIRE_SENSOR_STALE); /* head state */
	assert_int_equal(buf[41], 0);		      /* pad */
	assert_int_equal(buf[42], 0x34);	      /* head age, little-endian */
	assert_int_equal(buf[43], 0x12);
	assert_memory_equal(buf + 44, "\x00\x00\x80\x3f", 4);  /* head p.x = 1.0f */
	assert_memory_equal(buf + 56, "\x00\x00\x00\xc0", 4);  /* head q.w = -2.0f */
	assert_int_equal(buf[72], 0);			       /* left hand state OK */
	assert_memory_equal(buf + 136, "\x19\x00\x07\x00", 4); /* right arm flags, iters, pad */
	assert_memory_equal(buf + 148, "\x00\x00\x00\x3f", 4); /* left arm pos_err = 0.5f */
	assert_memory_equal(buf + 152, "\x00\x00\xc0\x7f", 4); /* chest_yaw NaN */
	assert_memory_equal(buf + 216, "\x00\x00\x80\x3e", 4); /* l_wr_dev = 0.25f */
	assert_memory_equal(buf + 220, "\x00\x00\xc0\x3f", 4); /* chest p.x = 1.5f */
	assert_memory_equal(buf + 496, "\x00\x00\x80\xbf", 4); /* l_hand q.z = -1.0f, the last bytes */
	assert_guard(buf, len);
}

/* ---- the input block ------------------------------------------------------------------ */

static void make_inputs(struct wire_frame *f)
{
	f->h.flags |= WIRE_F_INPUTS;
	f->in.present = 1u << WIRE_S_LEFT_HAND | 1u << WIRE_S_RIGHT_HAND;
	f->in.buttons[WIRE_S_LEFT_HAND] = 0x21;
	f->in.buttons[WIRE_S_RIGHT_HAND] = 0x44;
	f->in.analog[WIRE_S_LEFT_HAND][0] = -0.5f;
	f->in.analog[WIRE_S_LEFT_HAND][2] = 1.0f;
	f->in.analog[WIRE_S_RIGHT_HAND][1] = 0.25f;
}

/* the block at offset 500 as docs/PROTOCOL.md lays it out, the rest of the FRAME unchanged */
static void test_inputs_golden_layout(void **state)
{
	struct wire_frame f, g;
	uint8_t buf[BUF_LEN], plain[BUF_LEN];
	size_t len, plain_len;

	(void)state;
	rng_seed(30);
	make_frame(&f);
	plain_len = wire_encode_frame(&f, plain);
	make_inputs(&f);
	memset(buf, GUARD, sizeof(buf));
	len = wire_encode_frame(&f, buf);
	assert_int_equal(len, WIRE_FRAME_LEN + WIRE_INPUTS_LEN);
	assert_int_equal(len, 564);
	assert_guard(buf, len);
	assert_int_equal(buf[8] | buf[9] << 8, 524); /* payload_len */
	assert_true((buf[10] | buf[11] << 8) & 0x0010);
	/* every byte of the first 500 but the lengths and flags is what the plain FRAME had */
	assert_memory_equal(buf + 12, plain + 12, plain_len - 12);
	assert_int_equal(buf[500], 0x06);		       /* present: left and right hand */
	assert_int_equal(buf[501], 4);			       /* n_analog */
	assert_memory_equal(buf + 502, "\x00\x00", 2);	       /* reserved */
	assert_memory_equal(buf + 504, "\0\0\0\0", 4);	       /* head: buttons 0 */
	assert_memory_equal(buf + 524, "\x21\0\0\0", 4);       /* left hand buttons */
	assert_memory_equal(buf + 528, "\x00\x00\x00\xbf", 4); /* left joystick x -0.5 */
	assert_memory_equal(buf + 536, "\x00\x00\x80\x3f", 4); /* left trigger 1.0 */
	assert_memory_equal(buf + 544, "\x44\0\0\0", 4);       /* right hand buttons */
	assert_memory_equal(buf + 552, "\x00\x00\x80\x3e", 4); /* right joystick y 0.25 */
	memset(&g, 0x5a, sizeof(g));
	assert_int_equal(wire_decode_frame(buf, len, &g), 0);
	assert_frame_same(&g, &f);
	assert_int_equal(g.in.present, f.in.present);
	assert_memory_equal(g.in.buttons, f.in.buttons, sizeof(f.in.buttons));
	assert_memory_equal(g.in.analog, f.in.analog, sizeof(f.in.analog));
	/* without the flag: no block, and the decoder says so */
	memset(&g, 0x5a, sizeof(g));
	assert_int_equal(wire_decode_frame(plain, plain_len, &g), 0);
	assert_false(g.h.flags & WIRE_F_INPUTS);
	assert_int_equal(g.in.present, 0);
	assert_int_equal(g.in.buttons[WIRE_S_LEFT_HAND], 0);
	assert_true(g.in.analog[WIRE_S_RIGHT_HAND][3] == 0.0f);
}

static void test_inputs_errors_and_extension(void **state)
{
	struct wire_frame f, g;
	uint8_t buf[BUF_LEN], ext[BUF_LEN];
	size_t len;

	(void)state;
	rng_seed(31);
	make_frame(&f);
	make_inputs(&f);
	len = wire_encode_frame(&f, buf);
	/* the flag without the whole block: short */
	put16(buf + 8, (uint16_t)(len - WIRE_HEADER_LEN - 1));
	assert_int_equal(wire_decode_frame(buf, len - 1, &g), -WIRE_ESHORT);
	put16(buf + 8, FRAME_PAYLOAD);
	assert_int_equal(wire_decode_frame(buf, FRAME_LEN, &g), -WIRE_ESHORT);
	put16(buf + 8, (uint16_t)(len - WIRE_HEADER_LEN));
	/* fewer analog values than this revision's: an error */
	buf[501] = 3;
	assert_int_equal(wire_decode_frame(buf, len, &g), -WIRE_ECOUNT);
	/* a later revision with 6 values per sensor: the first 4 are read, the rest skipped */
	memcpy(ext, buf, 504);
	ext[501] = 6;
	for (int i = 0; i < WIRE_SENSORS; i++) {
		uint8_t *e = ext + 504 + 28 * i;

		memcpy(e, buf + 504 + 20 * i, 20);
		memset(e + 20, 0x7f, 8);
	}
	put16(ext + 8, (uint16_t)(504 + 28 * WIRE_SENSORS - WIRE_HEADER_LEN));
	assert_int_equal(wire_decode_frame(ext, 504 + 28 * WIRE_SENSORS, &g), 0);
	assert_memory_equal(g.in.buttons, f.in.buttons, sizeof(f.in.buttons));
	assert_memory_equal(g.in.analog, f.in.analog, sizeof(f.in.analog));
}

/* the DESCRIBE's layout at the offsets of docs/PROTOCOL.md */
static void test_describe_golden_layout(void **state)
{
	struct wire_describe d;
	uint8_t buf[BUF_LEN];
	size_t len, at;

	(void)state;
	memset(&d, 0, sizeof(d));
	d.h.seq = 3;
	d.h.describe_rev = 0x0102;
	d.rate_hz = 240.0f;	 /* 0x43700000 */
	d.dims[0] = 1.0f;	 /* 0x3f800000 */
	d.dims[3] = -2.0f;	 /* 0xc0000000 */
	d.head_offset[2] = 0.5f; /* 0x3f000000 */
	strcpy(d.avatar_name, "ab");
	strcpy(d.conventions, "xyz");
	strcpy(d.joint[0].name, "j");
	d.joint[0].segment = 9;
	d.joint[0].lo = -1.0f; /* 0xbf800000 */
	d.joint[0].hi = 2.0f;  /* 0x40000000 */
	d.joint[0].axis[2] = 1.0f;
	d.joint[0].trans[0] = 0.25f; /* 0x3e800000 */
	strcpy(d.segment[0].name, "s0");
	d.segment[0].parent = 255;
	strcpy(d.sensor[2], "hand");
	memset(buf, GUARD, sizeof(buf));
	len = wire_encode_describe(&d, buf);

	assert_memory_equal(buf, "AVGW\x01\x02\x28\x00", 8); /* magic, version, DESCRIBE, header_len */
	assert_int_equal(buf[8] | buf[9] << 8, len - WIRE_HEADER_LEN);
	assert_memory_equal(buf + 16, "\x03\x00\x00\x00\x02\x01\x00\x00", 8); /* seq, describe_rev */
	assert_memory_equal(buf + 40, "\x00\x00\x70\x43", 4);		      /* rate_hz */
	assert_memory_equal(buf + 44, "\x00\x00\x80\x3f", 4);		      /* dims[0] */
	assert_memory_equal(buf + 56, "\x00\x00\x00\xc0", 4);		      /* dims[3] */
	assert_memory_equal(buf + 68, "\x00\x00\x00\x3f", 4);		      /* head_offset[2] */
	assert_memory_equal(buf + 72,
			    "\x02"
			    "ab"
			    "\x03"
			    "xyz",
			    7); /* avatar name, conventions */
	at = 79;		/* joint 0: name, segment, lo, hi, axis, trans */
	assert_memory_equal(buf + at, "\x01j\x09", 3);
	assert_memory_equal(buf + at + 3,
			    "\x00\x00\x80\xbf"
			    "\x00\x00\x00\x40",
			    8);
	assert_memory_equal(buf + at + 11,
			    "\x00\x00\x00\x00"
			    "\x00\x00\x00\x00"
			    "\x00\x00\x80\x3f",
			    12);
	assert_memory_equal(buf + at + 23,
			    "\x00\x00\x80\x3e"
			    "\x00\x00\x00\x00"
			    "\x00\x00\x00\x00",
			    12);
	at += 35; /* joints 1..16: empty name, 34 bytes each */
	for (int i = 1; i < WIRE_JOINTS; i++, at += 34)
		assert_int_equal(buf[at], 0);
	assert_memory_equal(buf + at, "\x02s0\xff", 4); /* segment 0: name, parent = world */
	at += 4;
	for (int i = 1; i < WIRE_SEGMENTS; i++, at += 2)
		assert_memory_equal(buf + at, "\x00\x00", 2);
	assert_memory_equal(buf + at, "\x00\x00\x04hand", 7); /* sensors */
	at += 7;
	assert_int_equal(len, at);
	assert_guard(buf, len);
}

/* ---- decoder errors --------------------------------------------------------------- */

/* all three readers agree on a message that is broken before its type matters */
static void assert_all_fail(const uint8_t *buf, size_t len, int err)
{
	struct wire_header h;
	struct wire_frame f;
	struct wire_describe d;

	assert_int_equal(wire_peek(buf, len, &h), -err);
	assert_int_equal(wire_decode_frame(buf, len, &f), -err);
	assert_int_equal(wire_decode_describe(buf, len, &d), -err);
}

static void test_error_short(void **state)
{
	uint8_t buf[BUF_LEN];
	struct wire_frame f;
	size_t len;

	(void)state;
	rng_seed(10);
	len = encode_frame(buf);
	/* shorter than a header, down to nothing */
	for (size_t n = 0; n < WIRE_HEADER_LEN; n++)
		assert_all_fail(buf, n, WIRE_ESHORT);
	/* a whole header, then the payload cut anywhere */
	for (size_t n = WIRE_HEADER_LEN; n < len; n++)
		assert_all_fail(buf, n, WIRE_ESHORT);
	assert_int_equal(wire_decode_frame(buf, len, &f), 0);
	/* payload_len one past the buffer */
	put16(buf + 8, FRAME_PAYLOAD + 1);
	assert_all_fail(buf, len, WIRE_ESHORT);
	/* payload_len too small for what version 1 puts in a FRAME */
	put16(buf + 8, FRAME_PAYLOAD - 4);
	assert_int_equal(wire_decode_frame(buf, len, &f), -WIRE_ESHORT);
	/* header_len shorter than version 1's header */
	put16(buf + 8, FRAME_PAYLOAD);
	put16(buf + 6, WIRE_HEADER_LEN - 1);
	assert_all_fail(buf, len, WIRE_ESHORT);
}

static void test_error_magic(void **state)
{
	uint8_t buf[BUF_LEN];
	size_t len;

	(void)state;
	rng_seed(11);
	len = encode_frame(buf);
	for (int i = 0; i < 4; i++) {
		uint8_t keep = buf[i];

		buf[i] ^= 0x20; /* "aVGW", "AvGW", ...: case matters */
		assert_all_fail(buf, len, WIRE_EMAGIC);
		buf[i] = keep;
	}
	/* magic in big-endian order */
	memcpy(buf, "WGVA", 4);
	assert_all_fail(buf, len, WIRE_EMAGIC);
}

static void test_error_version(void **state)
{
	static const uint8_t versions[] = { 0, 2, 255 };
	uint8_t buf[BUF_LEN];
	size_t len;

	(void)state;
	rng_seed(12);
	len = encode_frame(buf);
	for (size_t i = 0; i < sizeof(versions); i++) {
		buf[4] = versions[i];
		assert_all_fail(buf, len, WIRE_EVERSION);
	}
}

static void test_error_type(void **state)
{
	uint8_t fbuf[BUF_LEN], dbuf[BUF_LEN];
	struct wire_frame f;
	struct wire_describe d;
	struct wire_header h;
	size_t flen, dlen;

	(void)state;
	rng_seed(13);
	flen = encode_frame(fbuf);
	make_describe(&d);
	dlen = wire_encode_describe(&d, dbuf);
	assert_int_equal(wire_peek(fbuf, flen, &h), WIRE_FRAME);
	assert_int_equal(wire_peek(dbuf, dlen, &h), WIRE_DESCRIBE);
	assert_int_equal(wire_decode_describe(fbuf, flen, &d), -WIRE_ETYPE);
	assert_int_equal(wire_decode_frame(dbuf, dlen, &f), -WIRE_ETYPE);
	/* a type this version does not know: peek reports it so a client can skip it */
	fbuf[5] = 7;
	assert_int_equal(wire_peek(fbuf, flen, &h), 7);
	assert_int_equal(wire_decode_frame(fbuf, flen, &f), -WIRE_ETYPE);
	assert_int_equal(wire_decode_describe(fbuf, flen, &d), -WIRE_ETYPE);
}

static void test_error_counts(void **state)
{
	uint8_t buf[BUF_LEN];
	size_t len;

	(void)state;
	rng_seed(14);
	len = encode_frame(buf);
	for (int at = 34; at <= 36; at++) {
		uint8_t keep = buf[at];

		buf[at] = (uint8_t)(keep + 1);
		assert_all_fail(buf, len, WIRE_ECOUNT);
		buf[at] = (uint8_t)(keep - 1);
		assert_all_fail(buf, len, WIRE_ECOUNT);
		buf[at] = 0;
		assert_all_fail(buf, len, WIRE_ECOUNT);
		buf[at] = keep;
	}
}

static void test_error_long(void **state)
{
	static uint8_t big[2 * 0xffff];
	uint8_t buf[BUF_LEN];
	struct wire_frame f, g;

	(void)state;
	rng_seed(15);
	make_frame(&f);
	memset(buf, 0, sizeof(buf));
	wire_encode_frame(&f, buf);
	/* exactly WIRE_MAX_MSG: accepted, the unknown tail skipped */
	put16(buf + 8, WIRE_MAX_MSG - WIRE_HEADER_LEN);
	assert_int_equal(wire_decode_frame(buf, WIRE_MAX_MSG, &g), 0);
	assert_frame_same(&g, &f);
	/* one byte more, in a buffer that holds it */
	put16(buf + 8, WIRE_MAX_MSG - WIRE_HEADER_LEN + 1);
	assert_all_fail(buf, BUF_LEN, WIRE_ELONG);
	/* a long header, in a buffer that holds it */
	put16(buf + 8, FRAME_PAYLOAD);
	put16(buf + 6, WIRE_MAX_MSG);
	assert_all_fail(buf, BUF_LEN, WIRE_ELONG);
	/* the largest lengths the fields can hold, in a buffer that holds them */
	memcpy(big, buf, WIRE_HEADER_LEN);
	put16(big + 6, 0xffff);
	put16(big + 8, 0xffff);
	assert_all_fail(big, sizeof(big), WIRE_ELONG);
	/* and in one that does not: short comes first */
	assert_all_fail(big, BUF_LEN, WIRE_ESHORT);
}

/* offset of the first joint name's count byte in an encoded DESCRIBE */
static size_t describe_joint0(const struct wire_describe *d)
{
	return WIRE_HEADER_LEN + 32 + 1 + strlen(d->avatar_name) + 1 + strlen(d->conventions);
}

static void test_error_string(void **state)
{
	struct wire_describe d, e;
	uint8_t buf[BUF_LEN];
	size_t len, at;

	(void)state;
	rng_seed(16);
	make_describe(&d);
	len = wire_encode_describe(&d, buf);
	assert_int_equal(wire_decode_describe(buf, len, &e), 0);

	/* avatar name: its count byte sits right after the 32 fixed bytes */
	at = WIRE_HEADER_LEN + 32;
	assert_int_equal(buf[at], strlen(d.avatar_name));
	buf[at] = WIRE_NAME_MAX + 1;
	assert_int_equal(wire_decode_describe(buf, len, &e), -WIRE_ESTRING);
	buf[at] = 255;
	assert_int_equal(wire_decode_describe(buf, len, &e), -WIRE_ESTRING);
	buf[at] = (uint8_t)strlen(d.avatar_name);

	/* conventions: up to sizeof(conventions) - 1 bytes */
	at += 1 + strlen(d.avatar_name);
	assert_int_equal(buf[at], strlen(d.conventions));
	buf[at] = (uint8_t)sizeof(d.conventions);
	assert_int_equal(wire_decode_describe(buf, len, &e), -WIRE_ESTRING);
	buf[at] = (uint8_t)strlen(d.conventions);

	/* the first joint's name */
	at = describe_joint0(&d);
	assert_int_equal(buf[at], strlen(d.joint[0].name));
	buf[at] = WIRE_NAME_MAX + 1;
	assert_int_equal(wire_decode_describe(buf, len, &e), -WIRE_ESTRING);
	buf[at] = (uint8_t)strlen(d.joint[0].name);

	/* the last sensor name: the final count byte */
	at = len - 1 - strlen(d.sensor[WIRE_SENSORS - 1]);
	assert_int_equal(buf[at], strlen(d.sensor[WIRE_SENSORS - 1]));
	buf[at] = WIRE_NAME_MAX + 1;
	assert_int_equal(wire_decode_describe(buf, len, &e), -WIRE_ESTRING);
	/* a legal length whose bytes run past the payload */
	buf[at] = (uint8_t)(strlen(d.sensor[WIRE_SENSORS - 1]) + 1);
	assert_int_equal(wire_decode_describe(buf, len, &e), -WIRE_ESHORT);
	buf[at] = (uint8_t)strlen(d.sensor[WIRE_SENSORS - 1]);
	assert_int_equal(wire_decode_describe(buf, len, &e), 0);
	assert_describe_same(&e, &d);
}

static void test_describe_short(void **state)
{
	struct wire_describe d, e;
	uint8_t buf[BUF_LEN];
	size_t len;

	(void)state;
	rng_seed(17);
	make_describe(&d);
	len = wire_encode_describe(&d, buf);
	/* the payload cut anywhere, by the buffer or by payload_len */
	for (size_t n = WIRE_HEADER_LEN; n < len; n++) {
		put16(buf + 8, (uint16_t)(len - WIRE_HEADER_LEN));
		assert_int_equal(wire_decode_describe(buf, n, &e), -WIRE_ESHORT);
		put16(buf + 8, (uint16_t)(n - WIRE_HEADER_LEN));
		assert_int_equal(wire_decode_describe(buf, len, &e), -WIRE_ESHORT);
	}
	put16(buf + 8, (uint16_t)(len - WIRE_HEADER_LEN));
	assert_int_equal(wire_decode_describe(buf, len, &e), 0);
}

static void test_strerror(void **state)
{
	static const int errs[] = { WIRE_ESHORT, WIRE_EMAGIC, WIRE_EVERSION, WIRE_ETYPE,
				    WIRE_ECOUNT, WIRE_ELONG,  WIRE_ESTRING };
	const char *unknown = wire_strerror(1000);
	size_t n = sizeof(errs) / sizeof(errs[0]);

	(void)state;
	assert_non_null(unknown);
	assert_string_equal(wire_strerror(-1000), unknown);
	assert_string_not_equal(wire_strerror(0), unknown);
	for (size_t i = 0; i < n; i++) {
		const char *s = wire_strerror(-errs[i]);

		assert_non_null(s);
		assert_true(strlen(s) > 0);
		assert_string_not_equal(s, unknown);
		assert_string_equal(wire_strerror(errs[i]), s);
		for (size_t k = 0; k < i; k++)
			assert_string_not_equal(s, wire_strerror(-errs[k]));
	}
}

/* ---- forward compatibility -------------------------------------------------------- */

/* a later version 1 sender: 8 more header bytes, 12 more payload bytes */
static void test_extra_bytes_skipped(void **state)
{
	struct wire_frame f, g;
	struct wire_describe d, e;
	uint8_t buf[BUF_LEN], ext[BUF_LEN];
	size_t len;

	(void)state;
	rng_seed(20);
	make_frame(&f);
	len = wire_encode_frame(&f, buf);
	memcpy(ext, buf, WIRE_HEADER_LEN);
	memset(ext + WIRE_HEADER_LEN, 0xee, 8);
	memcpy(ext + WIRE_HEADER_LEN + 8, buf + WIRE_HEADER_LEN, len - WIRE_HEADER_LEN);
	memset(ext + len + 8, 0xdd, 12);
	put16(ext + 6, WIRE_HEADER_LEN + 8);
	put16(ext + 8, (uint16_t)(len - WIRE_HEADER_LEN + 12));
	/* also: reserved bytes and unknown flags set */
	ext[37] = ext[38] = ext[39] = 0xff;
	assert_int_equal(wire_decode_frame(ext, len + 20, &g), 0);
	assert_int_equal(g.h.header_len, WIRE_HEADER_LEN + 8);
	assert_int_equal(g.h.payload_len, FRAME_PAYLOAD + 12);
	assert_frame_same(&g, &f);

	make_describe(&d);
	len = wire_encode_describe(&d, buf);
	memcpy(ext, buf, WIRE_HEADER_LEN);
	memset(ext + WIRE_HEADER_LEN, 0xee, 8);
	memcpy(ext + WIRE_HEADER_LEN + 8, buf + WIRE_HEADER_LEN, len - WIRE_HEADER_LEN);
	memset(ext + len + 8, 0xdd, 12);
	put16(ext + 6, WIRE_HEADER_LEN + 8);
	put16(ext + 8, (uint16_t)(len - WIRE_HEADER_LEN + 12));
	assert_int_equal(wire_decode_describe(ext, len + 20, &e), 0);
	assert_describe_same(&e, &d);

	/* a datagram longer than its message (trailing bytes): the message decodes */
	len = wire_encode_frame(&f, buf);
	memset(buf + len, 0x77, 30);
	assert_int_equal(wire_decode_frame(buf, len + 30, &g), 0);
	assert_frame_same(&g, &f);
}

/* ---- stream framing ------------------------------------------------------------- */

static void test_length_prefix(void **state)
{
	static const uint32_t vals[] = { 0, 1, 40, 500, WIRE_MAX_MSG, 0x12345678, 0x80000000u, 0xffffffffu };
	uint8_t b[4];

	(void)state;
	wire_put_len(b, 0x12345678);
	assert_memory_equal(b, "\x78\x56\x34\x12", 4);
	wire_put_len(b, 500);
	assert_memory_equal(b, "\xf4\x01\x00\x00", 4);
	for (size_t i = 0; i < sizeof(vals) / sizeof(vals[0]); i++) {
		wire_put_len(b, vals[i]);
		assert_int_equal(wire_get_len(b), vals[i]);
	}
	assert_int_equal(wire_get_len((const uint8_t *)"\x01\x02\x03\x04"), 0x04030201);
}

/*
 * Two messages on a stream, fed to a reassembler one byte at a time, come
 * out whole and in order: the way tools/avatargw-dump.c reads TCP and Unix.
 */
static void test_stream_reassembly(void **state)
{
	struct wire_frame f, g;
	struct wire_describe d, e;
	uint8_t stream[2 * BUF_LEN], acc[BUF_LEN];
	size_t n = 0, have = 0, got = 0;
	int seen_frame = 0, seen_describe = 0;

	(void)state;
	rng_seed(21);
	make_frame(&f);
	make_describe(&d);
	n = 4 + wire_encode_describe(&d, stream + 4);
	wire_put_len(stream, (uint32_t)(n - 4));
	got = wire_encode_frame(&f, stream + n + 4);
	wire_put_len(stream + n, (uint32_t)got);
	n += 4 + got;

	for (size_t i = 0; i < n; i++) {
		uint32_t len;

		acc[have++] = stream[i];
		if (have < 4)
			continue;
		len = wire_get_len(acc);
		assert_true(len <= WIRE_MAX_MSG);
		if (have < 4 + len)
			continue;
		if (!seen_describe) {
			assert_int_equal(wire_decode_describe(acc + 4, len, &e), 0);
			assert_describe_same(&e, &d);
			seen_describe = 1;
		} else {
			assert_int_equal(wire_decode_frame(acc + 4, len, &g), 0);
			assert_frame_same(&g, &f);
			seen_frame = 1;
		}
		have = 0;
	}
	assert_true(seen_describe && seen_frame);
	assert_int_equal(have, 0);
}

/* a remote avatar's site block after the sensor names: round trip, skipped by its absence or an unknown tag */
static void test_describe_site_block(void **state)
{
	struct wire_describe d, back;
	uint8_t buf[BUF_LEN];
	size_t plain, len;

	(void)state;
	memset(&d, 0, sizeof(d));
	strcpy(d.avatar_name, "lab-a/p0");
	plain = wire_encode_describe(&d, buf);
	assert_int_equal(wire_decode_describe(buf, plain, &back), 0);
	assert_false(back.site.present);
	d.site = (struct wire_site){ true, "lab-a", 1, 3, 239.5f, 1000, 7, 0.5f, 4.75f, -0.25f, 0.125f };
	len = wire_encode_describe(&d, buf);
	/* tag, length, name (1 + 5), state, avatars, rate, frames, lost, 4 figures */
	assert_int_equal(len, plain + 2 + 6 + 1 + 2 + 4 + 4 + 4 + 16);
	assert_int_equal(buf[plain], WIRE_SITE_BLOCK);
	assert_int_equal(buf[plain + 1], len - plain - 2);
	memset(&back, 0x55, sizeof(back));
	assert_int_equal(wire_decode_describe(buf, len, &back), 0);
	assert_true(back.site.present);
	assert_string_equal(back.site.name, "lab-a");
	assert_int_equal(back.site.state, 1);
	assert_int_equal(back.site.avatars, 3);
	assert_true(back.site.rate_hz == 239.5f && back.site.frames == 1000 && back.site.lost == 7);
	assert_true(back.site.delay_p50_ms == 0.5f && back.site.delay_p99_ms == 4.75f);
	assert_true(back.site.clock_offset_ms == -0.25f && back.site.rtt_ms == 0.125f);
	assert_string_equal(back.avatar_name, "lab-a/p0");
	/* a block of another tag (a later revision): skipped, the DESCRIBE still decodes */
	buf[plain] = 0x7f;
	assert_int_equal(wire_decode_describe(buf, len, &back), 0);
	assert_false(back.site.present);
	/* a figure that is not a number: not taken */
	d.site.delay_p99_ms = NAN;
	len = wire_encode_describe(&d, buf);
	assert_int_equal(wire_decode_describe(buf, len, &back), 0);
	assert_false(back.site.present);
	d.site.delay_p99_ms = 4.75f;
	len = wire_encode_describe(&d, buf);
	/* a block cut short (its length past the payload): not taken */
	buf[plain] = WIRE_SITE_BLOCK;
	buf[plain + 1] = 200;
	assert_int_equal(wire_decode_describe(buf, len, &back), 0);
	assert_false(back.site.present);
}

/* ---- the fixed names --------------------------------------------------------- */

static void test_names(void **state)
{
	(void)state;
	assert_string_equal(wire_joint_names[0], "chest_yaw");
	assert_string_equal(wire_joint_names[1], "r_girdle");
	assert_string_equal(wire_joint_names[8], "r_wr_dev");
	assert_string_equal(wire_joint_names[9], "l_girdle");
	assert_string_equal(wire_joint_names[16], "l_wr_dev");
	assert_string_equal(wire_segment_names[WIRE_SEG_CHEST], "chest");
	assert_string_equal(wire_segment_names[WIRE_SEG_R_HAND], "r_hand");
	assert_string_equal(wire_segment_names[WIRE_SEG_L_HAND], "l_hand");
	assert_string_equal(wire_sensor_names[WIRE_S_HEAD], "head");
	assert_string_equal(wire_sensor_names[WIRE_S_LEFT_HAND], "left_hand");
	assert_string_equal(wire_sensor_names[WIRE_S_RIGHT_HAND], "right_hand");
	/* the left arm's joints are the right arm's, r_ -> l_ */
	for (int i = 1; i <= 8; i++) {
		assert_int_equal(wire_joint_names[i][0], 'r');
		assert_int_equal(wire_joint_names[i + 8][0], 'l');
		assert_string_equal(wire_joint_names[i] + 1, wire_joint_names[i + 8] + 1);
	}
	for (int i = 0; i < WIRE_JOINTS; i++)
		assert_true(strlen(wire_joint_names[i]) <= WIRE_NAME_MAX);
	for (int i = 0; i < WIRE_SEGMENTS; i++)
		assert_true(strlen(wire_segment_names[i]) <= WIRE_NAME_MAX);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_frame_round_trip),
		cmocka_unit_test(test_frame_encoder_owns_header),
		cmocka_unit_test(test_describe_round_trip),
		cmocka_unit_test(test_describe_v1_size),
		cmocka_unit_test(test_describe_worst_case_fits),
		cmocka_unit_test(test_frame_golden_header),
		cmocka_unit_test(test_describe_golden_layout),
		cmocka_unit_test(test_inputs_golden_layout),
		cmocka_unit_test(test_inputs_errors_and_extension),
		cmocka_unit_test(test_error_short),
		cmocka_unit_test(test_error_magic),
		cmocka_unit_test(test_error_version),
		cmocka_unit_test(test_error_type),
		cmocka_unit_test(test_error_counts),
		cmocka_unit_test(test_error_long),
		cmocka_unit_test(test_error_string),
		cmocka_unit_test(test_describe_short),
		cmocka_unit_test(test_strerror),
		cmocka_unit_test(test_extra_bytes_skipped),
		cmocka_unit_test(test_length_prefix),
		cmocka_unit_test(test_stream_reassembly),
		cmocka_unit_test(test_names),
		cmocka_unit_test(test_describe_site_block),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
