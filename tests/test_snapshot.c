// SPDX-License-Identifier: MIT
/*
 * test_snapshot.c - the loop-to-thread hand-over of the renderer outputs:
 * a writer thread puts frames as fast as it can while a reader takes them;
 * every entry the reader gets must be one whole frame (never two frames
 * mixed), newer than the one before, and the newest once the writer stops.
 */
#include "publish/snapshot.h"

#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <cmocka.h>

#include <pthread.h>
#include <stdatomic.h>
#include <string.h>

#define N_AVATARS 3
#define N_FRAMES 200000

struct shared {
	struct snap snap;
	bool wants[N_AVATARS];
	_Atomic bool done;
};

static struct out_msg make(struct wire_frame *fp, uint8_t *buf, uint16_t avatar, uint32_t seq)
{
	struct wire_frame f;

	memset(&f, 0, sizeof(f));
	f.in.buttons[0] = seq;
	f.h.avatar_id = avatar;
	f.h.seq = seq;
	f.h.sample_time_ns = seq;
	/* every field carries the sequence number: a mix of two frames shows */
	for (int j = 0; j < WIRE_JOINTS; j++)
		f.joint[j] = (float)seq;
	for (int s = 0; s < WIRE_SEGMENTS; s++)
		for (int k = 0; k < 3; k++)
			f.segment[s].p[k] = (float)seq;
	*fp = f;
	return out_msg_frame(fp, buf, avatar);
}

static void *writer(void *arg)
{
	struct shared *sh = arg;
	uint8_t buf[N_AVATARS][WIRE_MAX_MSG];
	struct wire_frame f[N_AVATARS];
	struct out_msg m[N_AVATARS];

	for (uint32_t seq = 1; seq <= N_FRAMES; seq++) {
		for (int a = 0; a < N_AVATARS; a++)
			m[a] = make(&f[a], buf[a], (uint16_t)a, seq);
		snap_put_batch(&sh->snap, sh->wants, m, N_AVATARS, seq);
	}
	atomic_store(&sh->done, true);
	return NULL;
}

static void test_whole_and_newest(void **state)
{
	static struct shared sh;
	pthread_t t;
	uint32_t last[N_AVATARS] = { 0 };
	long taken = 0;

	(void)state;
	assert_int_equal(snap_init(&sh.snap, N_AVATARS), 0);
	sh.wants[0] = sh.wants[2] = true; /* avatar 1 is not this output's */
	for (int a = 0; a < N_AVATARS; a++) {
		bool fresh;

		assert_null(snap_take(&sh.snap, a, &fresh));
		assert_false(fresh);
	}
	pthread_create(&t, NULL, writer, &sh);
	while (!atomic_load(&sh.done)) {
		for (int a = 0; a < N_AVATARS; a += 2) {
			bool fresh;
			const struct snap_entry *e = snap_take(&sh.snap, a, &fresh);
			uint32_t seq;

			if (!e)
				continue;
			seq = e->f.h.seq;
			assert_int_equal(e->f.h.avatar_id, a);
			for (int j = 0; j < WIRE_JOINTS; j++)
				assert_true(e->f.joint[j] == (float)seq);
			for (int s = 0; s < WIRE_SEGMENTS; s++)
				assert_true(e->f.segment[s].p[2] == (float)seq);
			assert_int_equal(e->buttons[0], seq);
			assert_true(fresh ? seq > last[a] : seq == last[a]);
			last[a] = seq;
			taken += fresh;
		}
	}
	pthread_join(t, NULL);
	for (int a = 0; a < N_AVATARS; a += 2) {
		bool fresh;
		const struct snap_entry *e = snap_take(&sh.snap, a, &fresh);

		assert_non_null(e);
		assert_int_equal(e->f.h.seq, N_FRAMES);
		assert_int_equal(e->put_mono_ns, N_FRAMES);
	}
	{
		bool fresh;

		assert_null(snap_take(&sh.snap, 1, &fresh));
	}
	print_message("%ld fresh entries taken while %d frames were put per avatar\n", taken, N_FRAMES);
	assert_true(taken > 0);
	snap_free(&sh.snap);
}

static void test_names_from_describe(void **state)
{
	struct snap s;
	struct wire_describe d;
	uint8_t dbuf[WIRE_MAX_MSG], fbuf[WIRE_MAX_MSG];
	struct wire_frame fr;
	struct out_msg m[2];
	bool wants[1] = { true }, fresh;
	const struct snap_entry *e;

	(void)state;
	memset(&d, 0, sizeof(d));
	strcpy(d.avatar_name, "alice");
	m[0] = out_msg_describe(&d, dbuf, 0);
	m[1] = make(&fr, fbuf, 0, 5);
	assert_int_equal(snap_init(&s, 1), 0);
	snap_put_batch(&s, wants, &m[1], 1, 1); /* before the DESCRIBE: no name yet */
	e = snap_take(&s, 0, &fresh);
	assert_string_equal(e->name, "");
	snap_put_batch(&s, wants, m, 2, 2);
	e = snap_take(&s, 0, &fresh);
	assert_true(fresh);
	assert_string_equal(e->name, "alice");
	snap_free(&s);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_whole_and_newest),
		cmocka_unit_test(test_names_from_describe),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
