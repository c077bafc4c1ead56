// SPDX-License-Identifier: MIT
/*
 * fuzz_replay.c - the replay source (src/trackers/replay.c) on a sensor CSV
 * or a recording: the file written to a scratch directory, read as the
 * daemon reads it (the configuration's check, then open()), then played
 * through the driver's poll() as the loop calls it: stepped, clocked, or
 * rebuilt from keyframes by each interpolation.
 *
 * Input: byte 0 picks the playing (bits 0-1 interpolate none, linear,
 * catmull-rom, natural; bit 2 step; bit 3 loop; bit 4 start = 0.5 s);
 * bit 7 set: the rest is a recording's records without their framing
 * (tests/fuzz/recframe.h); clear: the rest is the file as it is.
 *
 * Invariant: every sample the source puts in its slots is a finite pose
 * with a unit quaternion within the source's max_distance of the origin,
 * with finite analog values.
 */
#include "fuzz/fuzz.h"
#include "fuzz/recframe.h"

#include "config/config.h"
#include "trackers/replay.h"
#include "trackers/tracker.h"

#include <string.h>

static void check_slots(const struct tracker *t, uint32_t *seen)
{
	for (int i = 0; i < t->n_sensors; i++) {
		const struct sensor_slot *s = &t->slot[i];

		if (s->count == seen[i])
			continue;
		seen[i] = s->count;
		fuzz_pose(&s->pose, "replayed pose");
		{
			struct vec3 p;
			double d;

			dq_translation(&s->pose, &p);
			d = sqrt(p.x * p.x + p.y * p.y + p.z * p.z);
			FUZZ_CHECK(d <= t->cfg->max_distance * (1 + 1e-6),
				   "replayed pose %g m from the origin (max_distance %g)", d, t->cfg->max_distance);
		}
		fuzz_finite_f(s->analog, SENSOR_ANALOG_MAX, "replayed analog");
	}
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	static const char *const interp[] = { "none", "linear", "catmull-rom", "natural" };
	static unsigned serial;
	char path[600], text[1024], err[512];
	struct config cfg;
	struct tracker t;
	uint8_t mode;
	int rc;

	if (size < 1)
		return 0;
	mode = data[0];
	/* a new name each time: the source remembers what it read of a file by its name and inode */
	snprintf(path, sizeof(path), "%s/replay-%u", fuzz_scratch(), serial++);
	if (mode & 0x80) {
		size_t len;
		uint8_t *rec = fuzz_frame_records(data + 1, size - 1, 0, &len);

		rc = fuzz_write_file(path, rec, len);
		free(rec);
	} else {
		rc = fuzz_write_file(path, data + 1, size - 1);
	}
	FUZZ_CHECK(rc == 0, "cannot write %s", path);
	snprintf(text, sizeof(text),
		 "[source r]\ntype = replay\nfile = %s\ninterpolate = %s\nstep = %s\nloop = %s\nstart = %s\n"
		 "sample_rate = 100\n",
		 path, interp[mode & 3], mode & 4 ? "yes" : "no", mode & 8 ? "yes" : "no", mode & 16 ? "0.5" : "0");
	if (config_load_text(&cfg, "fuzz", text, err, sizeof(err))) {
		unlink(path);
		return 0;
	}
	rc = tracker_open(&t, &cfg.source[0], err, sizeof(err));
	FUZZ_CHECK(rc == 0, "the configuration's check passed, open failed: %s", err);
	{
		uint32_t *seen = calloc((size_t)t.n_sensors + 1, sizeof(*seen));
		struct tracker_clock now = { 1000000000000ull, 0 };

		FUZZ_CHECK(seen, "out of memory");
		for (int k = 0; k < 64; k++) {
			if (mode & 4)
				FUZZ_CHECK(replay_step(&t, 1 + (unsigned)k % 3) == 0, "step");
			rc = t.drv->poll(&t, &now);
			FUZZ_CHECK(rc >= 0, "poll returned %d", rc);
			check_slots(&t, seen);
			/* clocked: a frame of 240 Hz, then now and then a stall of a second */
			now.mono_ns += k % 16 == 15 ? 1000000000ull : 4166667ull;
		}
		free(seen);
	}
	tracker_close(&t);
	config_free(&cfg);
	unlink(path);
	return 0;
}
