// SPDX-License-Identifier: MIT
/*
 * test_encode.c - the last check before a FRAME leaves: encode_frame_finite
 * refuses any NaN or infinity in a joint or a solved segment, wherever it
 * sits, and lets through every finite value (the largest, subnormals, -0)
 * and the head segment's NaN (the head sensor's own pose while it is missing).
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
	assert_true(encode_frame_finite(&f));
	for (int k = 0; k < 3; k++)
		f.segment[WIRE_SEG_HEAD].p[k] = NAN;
	for (int k = 0; k < 4; k++)
		f.segment[WIRE_SEG_HEAD].q[k] = NAN;
	assert_true(encode_frame_finite(&f));
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
			assert_false(encode_frame_finite(&f));
			checked++;
		}
		for (int s = 0; s < WIRE_SEGMENTS; s++) {
			for (int k = 0; k < 7; k++) {
				finite_frame(&f);
				if (k < 3)
					f.segment[s].p[k] = bad[b];
				else
					f.segment[s].q[k - 3] = bad[b];
				if (s == WIRE_SEG_HEAD)
					assert_true(encode_frame_finite(&f));
				else
					assert_false(encode_frame_finite(&f));
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
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
