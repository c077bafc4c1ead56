/* SPDX-License-Identifier: MIT */
/*
 * codec.h - the body of the hardware decoders' harnesses (fuzz_hydra.c,
 * fuzz_polhemus.c): the driver's codec (trackers/device.h), set up from a
 * [source] section as the configuration gives it, fed a stream of reports.
 *
 * Input: byte 0 picks the section's variant (codec_config() of the
 * harness), then reports, each a little-endian u16 length and that many
 * bytes (a length past the end takes what is left); a length of 0xFFFF
 * resets the codec (a reopened device). Seeds: tools/fuzz-seeds.sh turns
 * the captures of tests/data into this form.
 *
 * Invariants: every sample emitted is a finite pose with a unit
 * quaternion, finite analog values, for a sensor the source has; the
 * counts only grow.
 */
#ifndef AGW_FUZZ_CODEC_H
#define AGW_FUZZ_CODEC_H

#include "fuzz/fuzz.h"

#include "config/config.h"
#include "trackers/device.h"

#include <string.h>

/* the harness's: the [source] section's text for variant v */
static const char *codec_config(unsigned v);

struct codec_ctx {
	int n_sensors;
	unsigned emitted;
};

static void codec_emit(void *ctx, int sensor, const struct device_sample *s)
{
	struct codec_ctx *c = ctx;

	FUZZ_CHECK(sensor >= 0 && sensor < c->n_sensors, "sample of sensor %d (the source has %d)", sensor,
		   c->n_sensors);
	fuzz_pose(&s->pose, "sample pose");
	fuzz_finite_f(s->analog, SENSOR_ANALOG_MAX, "sample analog");
	c->emitted++;
}

static int codec_run(const char *driver, const uint8_t *data, size_t size)
{
	static struct config cfg[8];
	static bool loaded[8];
	const struct device_codec *codec = device_codec_find(driver);
	struct codec_ctx ctx = { 0 };
	struct device_counts before;
	unsigned v;
	void *st;
	char err[512];
	size_t at = 1;

	FUZZ_CHECK(codec, "no codec %s", driver);
	if (size < 1)
		return 0;
	v = data[0] % 8;
	if (!loaded[v]) {
		if (config_load_text(&cfg[v], "fuzz", codec_config(v), err, sizeof(err))) {
			fprintf(stderr, "fuzz: %s\n", err);
			abort();
		}
		loaded[v] = true;
	}
	ctx.n_sensors = cfg_source_type(cfg[v].source[0].driver)->sensor_count(&cfg[v].source[0]);
	st = calloc(1, codec->size);
	FUZZ_CHECK(st, "out of memory");
	FUZZ_CHECK(codec->init(st, &cfg[v].source[0], err, sizeof(err)) == 0, "init: %s", err);
	codec->reset(st);
	FUZZ_CHECK(isfinite(codec->period(st)) && codec->period(st) > 0, "period %g", codec->period(st));
	while (at + 2 <= size) {
		size_t len = (size_t)data[at] | (size_t)data[at + 1] << 8;
		int rc;

		at += 2;
		if (len == 0xFFFF) {
			codec->reset(st);
			continue;
		}
		if (len > size - at)
			len = size - at;
		memcpy(&before, st, sizeof(before));
		{
			/* the report alone in a buffer of its own length: a read past it is ASan's */
			uint8_t *rep = malloc(len ? len : 1);

			FUZZ_CHECK(rep, "out of memory");
			memcpy(rep, data + at, len);
			rc = codec->feed(st, rep, len, codec_emit, &ctx);
			free(rep);
		}
		{
			const struct device_counts *now = st;

			FUZZ_CHECK(now->malformed >= before.malformed && now->lost >= before.lost &&
					   now->resyncs >= before.resyncs && now->reports >= before.reports,
				   "a count went down");
		}
		(void)rc;
		at += len;
	}
	free(st);
	return 0;
}

#endif /* AGW_FUZZ_CODEC_H */
