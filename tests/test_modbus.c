// SPDX-License-Identifier: MIT
/*
 * test_modbus.c - the Modbus codecs: 32-bit values in two registers in the
 * four word orders (wire/regcodec.h) against byte vectors written out by
 * hand and against libmodbus's own float getters (which decode correctly in
 * Debian 12's 3.1.6, unlike its setters); and one avatar's register block
 * (publish/modbus_map.h) from a FRAME. The server and the source are tested
 * end to end against pymodbus (tests/e2e/test_modbus.py).
 */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <modbus/modbus.h>
#include <stdio.h>
#include <string.h>

#include "ik/ik.h"
#include "publish/modbus_map.h"
#include "wire/regcodec.h"

#include "testutil.h"

struct vec {
	float f;
	uint16_t r[4][2]; /* ABCD, CDAB, BADC, DCBA */
};

/* 123456.0 = 0x47F12000 (the value of the libmodbus reports), -1.5 = 0xBFC00000, pi = 0x40490FDB */
static const struct vec vecs[] = {
	{ 123456.0f, { { 0x47F1, 0x2000 }, { 0x2000, 0x47F1 }, { 0xF147, 0x0020 }, { 0x0020, 0xF147 } } },
	{ -1.5f, { { 0xBFC0, 0x0000 }, { 0x0000, 0xBFC0 }, { 0xC0BF, 0x0000 }, { 0x0000, 0xC0BF } } },
	{ 3.14159265f, { { 0x4049, 0x0FDB }, { 0x0FDB, 0x4049 }, { 0x4940, 0xDB0F }, { 0xDB0F, 0x4940 } } },
};

static void test_float_vectors(void **state)
{
	(void)state;
	for (size_t i = 0; i < sizeof(vecs) / sizeof(vecs[0]); i++) {
		for (int o = 0; o < 4; o++) {
			uint16_t r[2];

			set_ctx("%g in %s", vecs[i].f, regcodec_order_name(o));
			regcodec_put_f32(r, vecs[i].f, o);
			if (r[0] != vecs[i].r[o][0] || r[1] != vecs[i].r[o][1])
				fail_msg("%s: %04X %04X, want %04X %04X", ctx, r[0], r[1], vecs[i].r[o][0],
					 vecs[i].r[o][1]);
			assert_true(regcodec_get_f32(vecs[i].r[o], o) == vecs[i].f);
		}
	}
}

static void test_u32_vectors(void **state)
{
	static const uint16_t want[4][2] = {
		{ 0x0102, 0x0304 }, { 0x0304, 0x0102 }, { 0x0201, 0x0403 }, { 0x0403, 0x0201 }
	};

	(void)state;
	for (int o = 0; o < 4; o++) {
		uint16_t r[2];

		regcodec_put_u32(r, 0x01020304u, o);
		assert_int_equal(r[0], want[o][0]);
		assert_int_equal(r[1], want[o][1]);
		assert_int_equal(regcodec_get_u32(want[o], o), 0x01020304u);
	}
	assert_string_equal(regcodec_order_name(REGCODEC_CDAB), "CDAB");
}

/* libmodbus's getters read our registers back: an independent decoder of each order */
static void test_against_libmodbus_getters(void **state)
{
	float (*const get[4])(const uint16_t *) = { modbus_get_float_abcd, modbus_get_float_cdab, modbus_get_float_badc,
						    modbus_get_float_dcba };

	(void)state;
	rng_seed(6);
	for (int i = 0; i < 1000; i++) {
		float v = (float)rnd_range(-1e6, 1e6);

		for (int o = 0; o < 4; o++) {
			uint16_t r[2];

			regcodec_put_f32(r, v, o);
			set_ctx("%.9g in %s", v, regcodec_order_name(o));
			if (get[o](r) != v)
				fail_msg("%s: libmodbus reads %.9g", ctx, get[o](r));
		}
	}
}

static void test_specials_round_trip(void **state)
{
	const float v[] = { 0.0f, -0.0f, INFINITY, -INFINITY, 1e-45f, 3.4028235e38f };

	(void)state;
	for (size_t i = 0; i < sizeof(v) / sizeof(v[0]); i++)
		for (int o = 0; o < 4; o++) {
			uint16_t r[2];
			float g;

			regcodec_put_f32(r, v[i], o);
			g = regcodec_get_f32(r, o);
			assert_memory_equal(&g, &v[i], sizeof(g));
		}
	for (int o = 0; o < 4; o++) {
		uint16_t r[2];

		regcodec_put_f32(r, NAN, o);
		assert_true(isnan(regcodec_get_f32(r, o)));
	}
}

static void make_frame(struct wire_frame *f)
{
	memset(f, 0, sizeof(*f));
	f->h.avatar_id = 513;
	f->h.seq = 0x12345;
	f->h.flags = WIRE_F_NEW_SAMPLE | WIRE_F_UNREACHED;
	f->h.sample_time_ns = 1700000000123456789ull;
	f->sensor[0].state = WIRE_SENSOR_OK;
	f->sensor[1].state = WIRE_SENSOR_STALE;
	f->sensor[2].state = WIRE_SENSOR_MISSING;
	f->arm[WIRE_ARM_RIGHT].ik_flags = IK_REACHED | IK_ANALYTIC;
	f->arm[WIRE_ARM_LEFT].ik_flags = IK_UNREACHABLE | IK_LIMITED;
	for (int j = 0; j < WIRE_JOINTS; j++)
		f->joint[j] = (float)((j - 8) * 0.2);
	f->joint[16] = (float)M_PI; /* 180 degrees */
}

static void test_map_block(void **state)
{
	struct wire_frame f;
	uint16_t r[MODBUS_MAP_REGS];

	(void)state;
	make_frame(&f);
	for (int o = 0; o < 4; o++) {
		set_ctx("%s", regcodec_order_name(o));
		modbus_map_encode(&f, o, r);
		assert_int_equal(r[MODBUS_MAP_R_VERSION], 1);
		assert_int_equal(r[MODBUS_MAP_R_AVATAR], 513);
		assert_int_equal(r[MODBUS_MAP_R_COUNTER], 0x2345);
		/* 1700000000123 ms, low 32 bits */
		assert_int_equal(regcodec_get_u32(&r[MODBUS_MAP_R_TIME], o), (uint32_t)1700000000123ull);
		assert_int_equal(r[MODBUS_MAP_R_AGE], 0);
		assert_int_equal(r[MODBUS_MAP_R_STATUS],
				 MODBUS_MAP_S_VALID | MODBUS_MAP_S_NEW_SAMPLE | MODBUS_MAP_S_UNREACHED);
		assert_int_equal(r[MODBUS_MAP_R_SENSORS], 0 | 1 << 2 | 2 << 4);
		assert_int_equal(r[MODBUS_MAP_R_IK_RIGHT], IK_REACHED | IK_ANALYTIC);
		assert_int_equal(r[MODBUS_MAP_R_IK_LEFT], IK_UNREACHABLE | IK_LIMITED);
		assert_int_equal(r[MODBUS_MAP_R_JOINTS], 17);
		for (int j = 0; j < WIRE_JOINTS; j++) {
			assert_int_equal((int16_t)r[MODBUS_MAP_R_DEG100 + j], lround(f.joint[j] * 18000.0 / M_PI));
			assert_true(regcodec_get_f32(&r[MODBUS_MAP_R_RAD + 2 * j], o) == f.joint[j]);
		}
		assert_int_equal((int16_t)r[MODBUS_MAP_R_DEG100 + 16], 18000);
		assert_int_equal((int16_t)r[MODBUS_MAP_R_DEG100], -9167); /* -1.6 rad = -91.67 degrees */
		for (int i = MODBUS_MAP_R_DEG100 + WIRE_JOINTS; i < MODBUS_MAP_R_RAD; i++)
			assert_int_equal(r[i], 0);
	}
	/* byte for byte, ABCD: 0.2 rad = 0x3E4CCCCD */
	modbus_map_encode(&f, REGCODEC_ABCD, r);
	assert_int_equal(r[MODBUS_MAP_R_RAD + 2 * 9], 0x3E4C);
	assert_int_equal(r[MODBUS_MAP_R_RAD + 2 * 9 + 1], 0xCCCD);
}

/* an avatar never solved: no NaN on the bus, VALID clear, angles 0 */
static void test_map_unknown(void **state)
{
	struct wire_frame f;
	uint16_t r[MODBUS_MAP_REGS];

	(void)state;
	make_frame(&f);
	f.joint[3] = NAN;
	modbus_map_encode(&f, REGCODEC_CDAB, r);
	assert_int_equal(r[MODBUS_MAP_R_STATUS] & MODBUS_MAP_S_VALID, 0);
	assert_int_equal(r[MODBUS_MAP_R_VERSION], 1);
	for (int i = MODBUS_MAP_R_DEG100; i < MODBUS_MAP_REGS; i++)
		assert_int_equal(r[i], 0);
	/* far beyond +-327 degrees saturates, not wraps */
	make_frame(&f);
	f.joint[0] = 1000;
	f.joint[1] = -1000;
	modbus_map_encode(&f, REGCODEC_ABCD, r);
	assert_int_equal((int16_t)r[MODBUS_MAP_R_DEG100], 32767);
	assert_int_equal((int16_t)r[MODBUS_MAP_R_DEG100 + 1], -32767);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_float_vectors),
		cmocka_unit_test(test_u32_vectors),
		cmocka_unit_test(test_against_libmodbus_getters),
		cmocka_unit_test(test_specials_round_trip),
		cmocka_unit_test(test_map_block),
		cmocka_unit_test(test_map_unknown),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
