// SPDX-License-Identifier: MIT
/*
 * fuzz_config.c - the configuration (src/config/config.c): a main file and
 * its conf.d drop-ins, every key's parser and check, the merge of the
 * files, and the printing of the effective configuration.
 *
 * Input: text. Without a line "%%", it is one file read by
 * config_load_text. Each line "%%" starts a drop-in: the text before the
 * first is the main file, the rest conf.d/10.conf, conf.d/11.conf, ...,
 * written to a scratch directory and read by config_load as the daemon
 * reads them. A configuration is trusted (its author runs the daemon), so
 * inputs naming /dev, /proc or /sys are skipped: a file there (a replay
 * file = /dev/zero) never ends.
 *
 * Invariants: a configuration that loads has every number finite (a
 * quaternion of a mount unit), names within their arrays, sensor
 * references to sources and sensors that exist; an error names
 * a place (file:line or the file); printing it reads only what it has.
 */
#include "fuzz/fuzz.h"

#include "config/config.h"

#include <errno.h>
#include <string.h>

/* every number a type's keys put in its options is finite; strings end within their buffers */
static void check_keys(const struct cfg_key *keys, int n, const void *opt, const char *what)
{
	const char *base = opt;

	for (int i = 0; keys && i < n; i++) {
		const struct cfg_key *k = &keys[i];

		switch (k->kind) {
		case CFG_DOUBLE:
		case CFG_DEG:
			fuzz_finite((const double *)(base + k->off), 1, k->name);
			break;
		case CFG_VEC3:
			fuzz_finite((const double *)(base + k->off), 3, k->name);
			break;
		case CFG_RANGE:
			fuzz_finite((const double *)(base + k->off), 1, k->name);
			fuzz_finite((const double *)(base + k->off2), 1, k->name);
			break;
		case CFG_STR:
		case CFG_PATH:
			FUZZ_CHECK(memchr(base + k->off, 0, k->size), "%s %s: not terminated", what, k->name);
			break;
		default:
			break;
		}
	}
}

static void check_type(const struct cfg_type *t, const void *opt, const char *what)
{
	FUZZ_CHECK(t && (opt || !t->opt_size), "%s: no type or no options", what);
	check_keys(t->shared, t->n_shared, opt, what);
	check_keys(t->keys, t->n_keys, opt, what);
}

static void check_config(const struct config *c)
{
	const struct cfg_daemon *d = &c->daemon;
	double dv[] = { d->rate,
			d->stale_ms,
			d->describe_interval,
			d->record_flush,
			d->record_rotate_size,
			d->record_rotate_time,
			d->record_keyframe_rate };

	fuzz_finite(dv, (int)(sizeof(dv) / sizeof(dv[0])), "[daemon]");
	FUZZ_CHECK(c->n_sources >= 0 && c->n_sources <= CFG_MAX_SOURCES, "%d sources", c->n_sources);
	for (int i = 0; i < c->n_sources; i++) {
		const struct cfg_source *s = &c->source[i];

		FUZZ_CHECK(memchr(s->name, 0, sizeof(s->name)), "source %d's name", i);
		fuzz_finite(s->origin, 3, "origin");
		fuzz_finite(&s->yaw, 1, "yaw");
		check_type(cfg_source_type(s->driver), s->opt, s->name);
		FUZZ_CHECK(s->n_mounts >= 0 && s->n_mounts <= CFG_MAX_MOUNTS, "%d mounts", s->n_mounts);
		for (int m = 0; m < s->n_mounts; m++) {
			fuzz_finite(s->mount[m].p, 3, "mount position");
			fuzz_unit_quat(s->mount[m].q, "mount rotation");
		}
	}
	for (int i = 0; i < c->n_avatars; i++) {
		const struct cfg_avatar *a = &c->avatar[i];

		fuzz_finite(a->dims, 4, "avatar dims");
		fuzz_finite(a->head_offset, 3, "avatar head_offset");
		fuzz_finite(a->lo, 8, "avatar joint lo");
		fuzz_finite(a->hi, 8, "avatar joint hi");
		fuzz_finite(&a->tol_mm, 1, "ik_tolerance");
		fuzz_finite(&a->tol_rot_deg, 1, "ik_tolerance_rot");
		for (int r = 0; r < 3; r++) {
			const struct cfg_sensor_ref *ref = &a->sensor[r];
			int n;

			FUZZ_CHECK(ref->source >= 0 && ref->source < c->n_sources, "avatar %d sensor %d: source %d", i,
				   r, ref->source);
			n = cfg_source_type(c->source[ref->source].driver)->sensor_count(&c->source[ref->source]);
			FUZZ_CHECK(ref->sensor >= 0 && ref->sensor < n, "avatar %d sensor %d: sensor %d of %d", i, r,
				   ref->sensor, n);
		}
	}
	for (int i = 0; i < c->n_outputs; i++) {
		const struct cfg_output *o = &c->output[i];

		check_type(cfg_output_type(o->type), o->opt, o->name);
		FUZZ_CHECK(o->n_avatars >= 0 && (!o->n_avatars || o->avatar_ids), "output %d avatars", i);
	}
}

static int load_files(struct config *c, char *text, char *err, size_t errlen)
{
	char dir[512], path[600], *part = text, *next;
	int n = 0, rc;

	snprintf(dir, sizeof(dir), "%s/conf.d", fuzz_scratch());
	if (mkdir(dir, 0700) && errno != EEXIST)
		abort();
	for (; part; part = next, n++) {
		next = strstr(part, "\n%%\n");
		if (next) {
			next[1] = '\0';
			next += 4;
		}
		if (n == 0)
			snprintf(path, sizeof(path), "%s/main.conf", fuzz_scratch());
		else
			snprintf(path, sizeof(path), "%s/%d.conf", dir, 9 + n);
		if (fuzz_write_file(path, part, strlen(part)))
			abort();
	}
	snprintf(path, sizeof(path), "%s/main.conf", fuzz_scratch());
	rc = config_load(c, path, err, errlen);
	/* the next input's drop-ins only */
	for (int i = 1; i < n; i++) {
		snprintf(path, sizeof(path), "%s/%d.conf", dir, 9 + i);
		unlink(path);
	}
	return rc;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	static FILE *null;
	struct config c;
	char *text = malloc(size + 1), err[1024];
	int rc;

	FUZZ_CHECK(text, "out of memory");
	memcpy(text, data, size);
	text[size] = '\0';
	if (strlen(text) != size || strstr(text, "/dev") || strstr(text, "/proc") || strstr(text, "/sys")) {
		free(text);
		return 0;
	}
	if (!null)
		null = fopen("/dev/null", "w");
	err[0] = '\0';
	if (strstr(text, "\n%%\n"))
		rc = load_files(&c, text, err, sizeof(err));
	else
		rc = config_load_text(&c, "fuzz.conf", text, err, sizeof(err));
	if (rc) {
		FUZZ_CHECK(err[0], "an error without a message");
	} else {
		check_config(&c);
		config_print(&c, null);
		config_free(&c);
	}
	free(text);
	return 0;
}
