// SPDX-License-Identifier: MIT
/*
 * avatargw-rec - looks into recordings of the daemon (docs/RECORDING.md).
 *
 *   avatargw-rec info [--json] FILE
 *       header, sessions (sources, sensors, avatars), what the file holds,
 *       and what is wrong with it: damaged regions with their byte offsets,
 *       a cut-off end, records lost while recording. Exit 0 for a file
 *       without damage, 1 for a readable file with damage, 2 if unreadable.
 *   avatargw-rec csv [--person SOURCE[/PREFIX]] FILE
 *       one person's sensors as a sensor CSV (the format of
 *       ../shared/mocap/csv, which the replay source and avatargw-eval read):
 *       one row per moment at which one of them has a new sample.
 *   avatargw-rec keyframes --rate HZ IN OUT
 *       a copy of IN with, per sensor, only the first sample at or after
 *       each multiple of 1 / HZ s (the paper's low-rate storage; replay it
 *       with interpolate = catmull-rom). Damaged regions are left out.
 */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <fcntl.h>
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "record/recload.h"

static void usage(FILE *f)
{
	fprintf(f, "usage: avatargw-rec info [--json] FILE\n"
		   "       avatargw-rec csv [--person SOURCE[/PREFIX]] FILE\n"
		   "       avatargw-rec keyframes --rate HZ IN OUT\n");
}

static void json_str(const char *s)
{
	putchar('"');
	for (; *s; s++) {
		if (*s == '"' || *s == '\\')
			printf("\\%c", *s);
		else if ((unsigned char)*s < 0x20)
			printf("\\u%04x", *s);
		else
			putchar(*s);
	}
	putchar('"');
}

static double span_s(const struct rec_index *ix)
{
	return ix->n_events ? (double)(ix->events[ix->n_events - 1].arrival_ns - ix->events[0].arrival_ns) * 1e-9 : 0;
}

static int cmd_info(const char *path, bool json)
{
	struct rec_index ix;
	char err[512];
	const struct recfile_session *s;
	int rc;

	if (rec_index_load(path, &ix, err, sizeof(err))) {
		fprintf(stderr, "avatargw-rec: %s\n", err);
		return 2;
	}
	s = &ix.session;
	if (json) {
		printf("{\"file\":");
		json_str(path);
		printf(",\"size\":%zu,\"version\":%u,\"flags\":%u,\"created_ns\":%llu,\"seq\":%u,\"sessions\":%zu,"
		       "\"samples\":%zu,\"messages\":%zu,\"gaps\":%zu,\"lost_records\":%llu,\"unmapped\":%zu,"
		       "\"bad\":%zu,\"other\":%zu,\"duration_s\":%.6f,\"clean_end\":%s,\"truncated\":%s,"
		       "\"damaged_bytes\":%zu,\"damage\":[",
		       ix.file_size, ix.hdr.version, ix.hdr.flags, (unsigned long long)ix.hdr.created_ns, ix.hdr.seq,
		       ix.n_sessions, ix.n_events, ix.n_messages, ix.n_gaps, (unsigned long long)ix.lost_records,
		       ix.n_unmapped, ix.n_bad, ix.n_other, span_s(&ix), ix.clean_end ? "true" : "false",
		       ix.truncated ? "true" : "false", ix.damaged_bytes);
		for (size_t i = 0; i < ix.n_damage; i++)
			printf("%s{\"offset\":%zu,\"length\":%zu,\"truncated\":%s}", i ? "," : "", ix.damage[i].off,
			       ix.damage[i].len, ix.damage[i].truncated ? "true" : "false");
		printf("],\"first_arrival_ns\":%llu,\"last_arrival_ns\":%llu,\"rate_hz\":%.6g,\"source_id\":%u,"
		       "\"sensors\":[",
		       (unsigned long long)(ix.n_events ? ix.events[0].arrival_ns : 0),
		       (unsigned long long)(ix.n_events ? ix.events[ix.n_events - 1].arrival_ns : 0), s->rate,
		       s->source_id);
		for (uint32_t i = 0; i < ix.n_sensors; i++) {
			size_t n = 0;

			for (size_t k = 0; k < ix.n_events; k++)
				n += ix.events[k].sensor == i;
			printf("%s{\"name\":", i ? "," : "");
			json_str(ix.names[i]);
			printf(",\"samples\":%zu}", n);
		}
		printf("],\"avatars\":[");
		for (int i = 0; i < s->n_avatars; i++) {
			const struct recfile_avatar *a = &s->avatars[i];

			printf("%s{\"name\":", i ? "," : "");
			json_str(a->name);
			printf(",\"id\":%u,\"dims\":[%.6g,%.6g,%.6g,%.6g],\"head_offset\":[%.6g,%.6g,%.6g]}", a->id,
			       a->dims[0], a->dims[1], a->dims[2], a->dims[3], a->head_offset[0], a->head_offset[1],
			       a->head_offset[2]);
		}
		printf("],\"remote_avatars\":[");
		for (size_t i = 0; i < ix.n_remote_avatars; i++) {
			printf("%s{\"name\":", i ? "," : "");
			json_str(ix.remote_avatars[i].name);
			printf(",\"id\":%u,\"frames\":%zu}", ix.remote_avatars[i].id, ix.remote_avatars[i].frames);
		}
		printf("]}\n");
	} else {
		printf("%s: avatargw recording v%u, %zu bytes, file %u of its run%s%s\n", path, ix.hdr.version,
		       ix.file_size, ix.hdr.seq, ix.hdr.flags & RECFILE_F_MESSAGES ? ", with messages" : "",
		       ix.hdr.flags & RECFILE_F_KEYFRAMES ? ", keyframes only" : "");
		printf("loop %.6g Hz, %zu session record%s, %.3f s of samples\n", s->rate, ix.n_sessions,
		       ix.n_sessions == 1 ? "" : "s", span_s(&ix));
		for (int i = 0; i < s->n_sources; i++)
			printf("  source %s (%s): %u sensors\n", s->sources[i].name, s->sources[i].driver,
			       s->sources[i].n_sensors);
		for (int i = 0; i < s->n_avatars; i++)
			printf("  avatar %s (id %u)\n", s->avatars[i].name, s->avatars[i].id);
		for (size_t i = 0; i < ix.n_remote_avatars; i++)
			printf("  remote avatar %s (id %u): %zu frames, solved at its site\n",
			       ix.remote_avatars[i].name, ix.remote_avatars[i].id, ix.remote_avatars[i].frames);
		printf("%zu samples, %zu messages, %zu unmapped, %zu undecodable\n", ix.n_events, ix.n_messages,
		       ix.n_unmapped, ix.n_bad);
		if (ix.n_gaps)
			printf("%llu records were lost while recording (buffer full), in %zu places\n",
			       (unsigned long long)ix.lost_records, ix.n_gaps);
		for (size_t i = 0; i < ix.n_damage; i++)
			printf("%s at bytes %zu..%zu (%zu bytes)\n",
			       ix.damage[i].truncated ? "cut-off record" : "damaged region", ix.damage[i].off,
			       ix.damage[i].off + ix.damage[i].len, ix.damage[i].len);
		printf("%s\n", ix.clean_end ? "closed cleanly (END record)"
					    : "no END record: the recording daemon stopped without closing the file");
	}
	rc = ix.n_damage ? 1 : 0;
	rec_index_free(&ix);
	return rc;
}

static int cmd_csv(const char *path, const char *person)
{
	static const char *const pre[3] = { "head", "lhand", "rhand" };
	struct rec_index ix;
	char err[512], label[300];
	int sensor[3];
	const struct rec_event *latest[3] = { NULL, NULL, NULL };
	size_t row = 0;
	uint64_t last_t = 0;

	if (rec_index_load(path, &ix, err, sizeof(err))) {
		fprintf(stderr, "avatargw-rec: %s\n", err);
		return 2;
	}
	if (rec_index_person(&ix, person, sensor, label, sizeof(label), err, sizeof(err))) {
		fprintf(stderr, "avatargw-rec: %s: %s\n", path, err);
		rec_index_free(&ix);
		return 2;
	}
	printf("frame,t");
	for (int r = 0; r < 3; r++)
		printf(",%s_x,%s_y,%s_z,%s_qw,%s_qx,%s_qy,%s_qz", pre[r], pre[r], pre[r], pre[r], pre[r], pre[r],
		       pre[r]);
	putchar('\n');
	for (size_t i = 0; i < ix.n_events; i++) {
		const struct rec_event *e = &ix.events[i];
		uint64_t t;

		for (int r = 0; r < 3; r++)
			if ((int)e->sensor == sensor[r])
				latest[r] = e;
		if (!latest[0] || !latest[1] || !latest[2])
			continue;
		if (i + 1 < ix.n_events && ix.events[i + 1].arrival_ns == e->arrival_ns)
			continue;
		t = e->arrival_ns - ix.events[0].arrival_ns;
		if (row && t <= last_t)
			continue;
		last_t = t;
		printf("%zu,%.9f", row++, (double)t * 1e-9);
		for (int r = 0; r < 3; r++)
			printf(",%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g", latest[r]->p[0], latest[r]->p[1], latest[r]->p[2],
			       latest[r]->q[0], latest[r]->q[1], latest[r]->q[2], latest[r]->q[3]);
		putchar('\n');
	}
	fprintf(stderr, "avatargw-rec: %s: %s, %zu rows\n", path, label, row);
	rec_index_free(&ix);
	return 0;
}

static int write_all(int fd, const uint8_t *p, size_t n)
{
	while (n) {
		ssize_t w = write(fd, p, n);

		if (w < 0 && errno == EINTR)
			continue;
		if (w <= 0)
			return -1;
		p += w;
		n -= (size_t)w;
	}
	return 0;
}

static int cmd_keyframes(const char *in, const char *out, double hz)
{
	uint8_t *buf = NULL, hdr[RECFILE_HEADER_LEN];
	struct recfile_header h;
	struct recfile_record rec;
	size_t len = 0, off = RECFILE_HEADER_LEN, kept = 0, dropped = 0;
	uint64_t period = (uint64_t)(1e9 / hz);
	/* the next due time per (source, sensor), reset by every SESSION */
	uint64_t *due = NULL;
	uint32_t *base = NULL;
	int n_src = 0, fd = -1, rc = 2;
	struct stat st;
	FILE *f = fopen(in, "rb");

	if (!f || fstat(fileno(f), &st)) {
		fprintf(stderr, "avatargw-rec: %s: %s\n", in, strerror(errno));
		goto out;
	}
	buf = malloc((size_t)st.st_size + 1);
	if (!buf || (len = fread(buf, 1, (size_t)st.st_size, f)) != (size_t)st.st_size) {
		fprintf(stderr, "avatargw-rec: %s: cannot read\n", in);
		goto out;
	}
	if (recfile_header_decode(buf, len, &h)) {
		fprintf(stderr, "avatargw-rec: %s: not a readable recording\n", in);
		goto out;
	}
	fd = open(out, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
	if (fd < 0) {
		fprintf(stderr, "avatargw-rec: %s: %s\n", out, strerror(errno));
		goto out;
	}
	h.flags |= RECFILE_F_KEYFRAMES;
	recfile_header_encode(&h, hdr);
	if (write_all(fd, hdr, sizeof(hdr)))
		goto werr;
	while (recfile_next(buf, len, &off, &rec, NULL)) {
		if (rec.type == RECFILE_SESSION) {
			struct recfile_session s;
			uint32_t n = 0;

			if (recfile_session_parse(rec.payload, rec.len, &s))
				continue;
			free(due);
			free(base);
			base = calloc((size_t)s.n_sources + 1, sizeof(*base));
			for (int i = 0; base && i < s.n_sources; i++) {
				base[i] = n;
				n += s.sources[i].n_sensors;
			}
			due = calloc((size_t)n + 1, sizeof(*due));
			n_src = s.n_sources;
			recfile_session_free(&s);
			if (!base || !due) {
				fprintf(stderr, "avatargw-rec: out of memory\n");
				goto out;
			}
		} else if (rec.type == RECFILE_SAMPLE) {
			struct recfile_sample smp;
			uint64_t *d;

			if (recfile_sample_decode(rec.payload, rec.len, &smp) || smp.source >= n_src)
				continue;
			d = &due[base[smp.source] + smp.sensor];
			if (smp.arrival_ns < *d) {
				dropped++;
				continue;
			}
			*d = *d && smp.arrival_ns - *d < period ? *d + period : smp.arrival_ns + period;
			kept++;
		}
		if (write_all(fd, buf + rec.off, rec.size))
			goto werr;
	}
	if (close(fd)) {
		fd = -1;
		goto werr;
	}
	fd = -1;
	fprintf(stderr, "avatargw-rec: %s: %zu samples kept, %zu left out (%g Hz per sensor)\n", out, kept, dropped,
		hz);
	rc = 0;
	goto out;
werr:
	fprintf(stderr, "avatargw-rec: %s: %s\n", out, strerror(errno));
out:
	if (fd >= 0)
		close(fd);
	if (f)
		fclose(f);
	free(buf);
	free(due);
	free(base);
	return rc;
}

int main(int argc, char **argv)
{
	static const struct option opts[] = {
		{ "json", no_argument, NULL, 'j' },
		{ "person", required_argument, NULL, 'p' },
		{ "rate", required_argument, NULL, 'r' },
		{ "help", no_argument, NULL, 'h' },
		{ NULL, 0, NULL, 0 },
	};
	const char *person = NULL, *cmd;
	bool json = false;
	double hz = 0;
	int opt;

	if (argc < 2) {
		usage(stderr);
		return 64;
	}
	cmd = argv[1];
	optind = 2;
	while ((opt = getopt_long(argc, argv, "h", opts, NULL)) != -1) {
		switch (opt) {
		case 'j':
			json = true;
			break;
		case 'p':
			person = optarg;
			break;
		case 'r':
			hz = strtod(optarg, NULL);
			break;
		case 'h':
			usage(stdout);
			return 0;
		default:
			usage(stderr);
			return 64;
		}
	}
	if (!strcmp(cmd, "info") && optind + 1 == argc)
		return cmd_info(argv[optind], json);
	if (!strcmp(cmd, "csv") && optind + 1 == argc)
		return cmd_csv(argv[optind], person);
	if (!strcmp(cmd, "keyframes") && optind + 2 == argc && hz > 0 && isfinite(hz))
		return cmd_keyframes(argv[optind], argv[optind + 1], hz);
	if (!strcmp(cmd, "-h") || !strcmp(cmd, "--help")) {
		usage(stdout);
		return 0;
	}
	usage(stderr);
	return 64;
}
