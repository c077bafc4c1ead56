// SPDX-License-Identifier: MIT
/*
 * avatargw-decode - decodes a capture of raw tracker reports and prints the
 * samples as CSV, through the very decoders the daemon's drivers use.
 *
 *   avatargw-decode --driver hydra|polhemus [--set KEY=VALUE]... FILE
 *
 * FILE is a capture (src/trackers/capture.h: hex, one report per line, an
 * optional leading timestamp in seconds); "-" reads standard input. The
 * --set options are keys of the driver's [source] section (model, sensors,
 * ...), as in the configuration. One CSV line per sample: the time (the
 * capture's timestamp, else the report's index times the device's nominal
 * period), the capture line, the sensor's name, its pose in the tracker's
 * frame (z up, metres, quaternion w x y z; before the source's origin, yaw
 * and mount offsets), its buttons and analog values. A summary goes to
 * standard error. Exit status: 0, 1 when the capture cannot be read, 2 on
 * a usage or configuration error.
 */
#include "config/config.h"
#include "trackers/capture.h"
#include "trackers/device.h"
#include "trackers/tracker.h"

#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define DECODE_MAX_SETS 32

struct decode_ctx {
	const struct cfg_source *cfg;
	const struct tracker_driver *drv;
	double t;
	unsigned line;
	unsigned long samples;
};

static void decode_usage(FILE *out)
{
	fputs("usage: avatargw-decode --driver hydra|polhemus [--set KEY=VALUE]... FILE\n"
	      "  prints the samples in a capture of raw reports as CSV (FILE - : standard input)\n",
	      out);
}

static void decode_emit(void *ctx, int sensor, const struct device_sample *s)
{
	struct decode_ctx *c = ctx;
	char name[CFG_NAME_MAX * 2];
	struct vec3 p;

	c->drv->type.sensor_name(c->cfg, sensor, name, sizeof(name));
	dq_translation(&s->pose, &p);
	printf("%.6f,%u,%s,%.6f,%.6f,%.6f,%.9f,%.9f,%.9f,%.9f,%u,%.6f,%.6f,%.6f,%.6f\n", c->t, c->line, name, p.x, p.y,
	       p.z, s->pose.r.w, s->pose.r.x, s->pose.r.y, s->pose.r.z, s->buttons, s->analog[0], s->analog[1],
	       s->analog[2], s->analog[3]);
	c->samples++;
}

static char *decode_read_all(FILE *f)
{
	size_t len = 0, cap = 65536, got;
	char *buf = malloc(cap);

	while (buf) {
		got = fread(buf + len, 1, cap - len - 1, f);
		len += got;
		if (got == 0)
			break;
		if (len + 1 == cap) {
			char *n = realloc(buf, cap *= 2);

			if (!n)
				free(buf);
			buf = n;
		}
	}
	if (buf)
		buf[len] = '\0';
	return buf;
}

int main(int argc, char **argv)
{
	static const struct option opts[] = {
		{ "driver", required_argument, NULL, 'd' },
		{ "set", required_argument, NULL, 's' },
		{ "help", no_argument, NULL, 'h' },
		{ NULL, 0, NULL, 0 },
	};
	const char *driver = NULL, *sets[DECODE_MAX_SETS];
	int n_sets = 0, opt, rc;
	char text[4096], err[1024];
	size_t tl;
	struct config cfg;
	struct capture cap;
	const struct device_codec *codec;
	struct decode_ctx ctx = { 0 };
	void *st;
	const struct device_counts *cnt;

	while ((opt = getopt_long(argc, argv, "d:s:h", opts, NULL)) != -1) {
		switch (opt) {
		case 'd':
			driver = optarg;
			break;
		case 's':
			if (n_sets == DECODE_MAX_SETS) {
				fprintf(stderr, "avatargw-decode: more than %d --set\n", DECODE_MAX_SETS);
				return 2;
			}
			sets[n_sets++] = optarg;
			break;
		case 'h':
			decode_usage(stdout);
			return 0;
		default:
			decode_usage(stderr);
			return 2;
		}
	}
	if (!driver || optind != argc - 1) {
		decode_usage(stderr);
		return 2;
	}
	codec = device_codec_find(driver);
	if (!codec) {
		fprintf(stderr, "avatargw-decode: no decoder for driver '%s' (hydra, polhemus)\n", driver);
		return 2;
	}
	/* the driver's section as a configuration file would give it: every default, checked */
	tl = (size_t)snprintf(text, sizeof(text), "[source decode]\ntype = %s\n", driver);
	for (int i = 0; i < n_sets && tl < sizeof(text); i++) {
		const char *eq = strchr(sets[i], '=');

		if (!eq) {
			fprintf(stderr, "avatargw-decode: --set %s: expected KEY=VALUE\n", sets[i]);
			return 2;
		}
		tl += (size_t)snprintf(text + tl, sizeof(text) - tl, "%.*s = %s\n", (int)(eq - sets[i]), sets[i],
				       eq + 1);
	}
	if (config_load_text(&cfg, "--set", text, err, sizeof(err))) {
		fprintf(stderr, "avatargw-decode: %s\n", err);
		return 2;
	}
	if (!strcmp(argv[optind], "-")) {
		char *all = decode_read_all(stdin);

		rc = all ? capture_parse(&cap, "(stdin)", all, err, sizeof(err)) : -1;
		if (!all)
			snprintf(err, sizeof(err), "(stdin): out of memory");
		free(all);
	} else {
		rc = capture_load(&cap, argv[optind], err, sizeof(err));
	}
	if (rc) {
		fprintf(stderr, "avatargw-decode: %s\n", err);
		config_free(&cfg);
		return 1;
	}
	st = calloc(1, codec->size);
	if (!st || codec->init(st, &cfg.source[0], err, sizeof(err))) {
		fprintf(stderr, "avatargw-decode: %s\n", st ? err : "out of memory");
		free(st);
		capture_free(&cap);
		config_free(&cfg);
		return 2;
	}
	ctx.cfg = &cfg.source[0];
	ctx.drv = trackers_table[cfg.source[0].driver];
	codec->reset(st);
	puts("t,line,sensor,x,y,z,qw,qx,qy,qz,buttons,a0,a1,a2,a3");
	for (int i = 0; i < cap.n; i++) {
		const struct capture_report *r = &cap.rep[i];

		ctx.t = cap.timed ? r->t : i * codec->period(st);
		ctx.line = r->line;
		codec->feed(st, cap.bytes + r->off, r->len, decode_emit, &ctx);
	}
	cnt = st;
	fprintf(stderr,
		"avatargw-decode: %d reports, %lu samples, %llu decoded, %llu malformed, %llu lost (sequence gaps), "
		"%llu resynchronisations\n",
		cap.n, ctx.samples, (unsigned long long)cnt->reports, (unsigned long long)cnt->malformed,
		(unsigned long long)cnt->lost, (unsigned long long)cnt->resyncs);
	free(st);
	capture_free(&cap);
	config_free(&cfg);
	return 0;
}
