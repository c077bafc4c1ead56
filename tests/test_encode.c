// SPDX-License-Identifier: MIT
/*
 * test_encode.c - the last check before a FRAME leaves: encode_frame_finite
 * refuses any NaN or infinity in a joint, a solved segment, a sensor record,
 * an arm's pos_err or an analog value, wherever it sits, and lets through
 * every finite value (the largest, subnormals, -0) and the NaN the protocol
 * gives for unknown: a missing sensor's record, the head segment while the
 * head is missing, the posture of a frame never solved.
 */
#include "publish/encode.h"

#include <float.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <string.h>
#include <cmocka.h>

static void finite_frame(struct wire_frame *f)
{
	memset(f, 0, sizeof(*f));
	for (int i = 0; i < WIRE_SENSORS; i++) {
		f->sensor[i].state = WIRE_SENSOR_OK;
		for (int k = 0; k < 3; k++)
			f->sensor[i].pose.p[k] = FLT_MAX / (float)(k + 1);
		f->sensor[i].pose.q[0] = 1;
		for (int k = 0; k < WIRE_ANALOG; k++)
			f->in.analog[i][k] = -1.0f + (float)k * 0.5f;
	}
	f->h.flags = WIRE_F_INPUTS;
	f->arm[0].pos_err = 0;
	f->arm[1].pos_err = FLT_MAX;
	for (int i = 0; i < WIRE_JOINTS; i++)
		f->joint[i] = (i & 1) ? -FLT_MAX : FLT_MIN / 4; /* the largest magnitude, a subnormal */
	for (int s = 0; s < WIRE_SEGMENTS; s++) {
		for (int k = 0; k < 3; k++)
			f->segment[s].p[k] = (float)(s - k) * 0.25f;
		f->segment[s].q[0] = -0.0f;
		f->segment[s].q[1] = FLT_MAX;
		f->segment[s].q[2] = 1;
		f->segment[s].q[3] = -1e-30f;
	}
}

static void test_finite_passes(void **state)
{
	struct wire_frame f;

	(void)state;
	finite_frame(&f);
	assert_true(encode_frame_finite(&f, true));
	assert_true(encode_frame_finite(&f, false));
	/* the head missing: its record and the head segment are NaN */
	f.sensor[WIRE_S_HEAD].state = WIRE_SENSOR_MISSING;
	for (int k = 0; k < 3; k++)
		f.segment[WIRE_SEG_HEAD].p[k] = f.sensor[WIRE_S_HEAD].pose.p[k] = NAN;
	for (int k = 0; k < 4; k++)
		f.segment[WIRE_SEG_HEAD].q[k] = f.sensor[WIRE_S_HEAD].pose.q[k] = NAN;
	assert_true(encode_frame_finite(&f, true));
	/* never solved: the whole posture is NaN */
	finite_frame(&f);
	for (int i = 0; i < WIRE_JOINTS; i++)
		f.joint[i] = NAN;
	for (int s = 0; s < WIRE_SEGMENTS; s++)
		for (int k = 0; k < 3; k++)
			f.segment[s].p[k] = NAN;
	f.arm[0].pos_err = f.arm[1].pos_err = INFINITY;
	assert_true(encode_frame_finite(&f, false));
	assert_false(encode_frame_finite(&f, true));
}

/* sensor records (but a missing sensor's), pos_err and analog values: each float, each bad value */
static void test_sensors_pos_err_analog(void **state)
{
	const float bad[] = { NAN, -NAN, INFINITY, -INFINITY };
	struct wire_frame f;

	(void)state;
	for (size_t b = 0; b < sizeof(bad) / sizeof(bad[0]); b++) {
		for (int i = 0; i < WIRE_SENSORS; i++) {
			for (int k = 0; k < 7; k++) {
				for (int st = WIRE_SENSOR_OK; st <= WIRE_SENSOR_MISSING; st++) {
					finite_frame(&f);
					f.sensor[i].state = (uint8_t)st;
					if (k < 3)
						f.sensor[i].pose.p[k] = bad[b];
					else
						f.sensor[i].pose.q[k - 3] = bad[b];
					if (i == WIRE_S_HEAD && st == WIRE_SENSOR_MISSING)
						for (int j = 0; j < 3; j++)
							f.segment[WIRE_SEG_HEAD].p[j] = NAN;
					for (int solved = 0; solved < 2; solved++)
						assert_int_equal(encode_frame_finite(&f, solved),
								 st == WIRE_SENSOR_MISSING);
				}
			}
			for (int k = 0; k < WIRE_ANALOG; k++) {
				finite_frame(&f);
				f.in.analog[i][k] = bad[b];
				assert_false(encode_frame_finite(&f, true));
				assert_false(encode_frame_finite(&f, false));
				f.h.flags = 0; /* no input block: not published */
				assert_true(encode_frame_finite(&f, true));
			}
		}
		for (int side = 0; side < WIRE_ARMS; side++) {
			finite_frame(&f);
			f.arm[side].pos_err = bad[b];
			assert_false(encode_frame_finite(&f, true));
		}
		/* the head present: its segment must be finite */
		finite_frame(&f);
		f.segment[WIRE_SEG_HEAD].q[2] = bad[b];
		assert_false(encode_frame_finite(&f, true));
	}
}

static void test_every_place_is_checked(void **state)
{
	const float bad[] = { NAN, -NAN, INFINITY, -INFINITY };
	struct wire_frame f;
	int checked = 0;

	(void)state;
	for (size_t b = 0; b < sizeof(bad) / sizeof(bad[0]); b++) {
		for (int i = 0; i < WIRE_JOINTS; i++) {
			finite_frame(&f);
			f.joint[i] = bad[b];
			assert_false(encode_frame_finite(&f, true));
			checked++;
		}
		for (int s = 0; s < WIRE_SEGMENTS; s++) {
			for (int k = 0; k < 7; k++) {
				finite_frame(&f);
				if (k < 3)
					f.segment[s].p[k] = bad[b];
				else
					f.segment[s].q[k - 3] = bad[b];
				assert_false(encode_frame_finite(&f, true));
				checked++;
			}
		}
	}
	assert_int_equal(checked, 4 * (WIRE_JOINTS + 7 * WIRE_SEGMENTS));
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_finite_passes),
		cmocka_unit_test(test_every_place_is_checked),
		cmocka_unit_test(test_sensors_pos_err_analog),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
