// SPDX-License-Identifier: MIT
/*
 * test_recorder.c - the daemon's recorder (record/recorder.h) with the real
 * gateway and loop thread: what is recorded is what the trackers took in,
 * files rotate and each stands alone, a full buffer drops and says so in
 * the file, a directory that cannot be written is counted, not fatal.
 */
#include "config/config.h"
#include "config/builtin.h"
#include "daemon/gateway.h"
#include "daemon/loop.h"
#include "record/recload.h"
#include "record/recorder.h"

#include <dirent.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>
#include <cmocka.h>

static void sleep_ms(int ms)
{
	struct timespec ts = { ms / 1000, (ms % 1000) * 1000000L };

	while (nanosleep(&ts, &ts))
		;
}

/* a fresh directory; its files are listed sorted by name */
static void tmp_dir(char *dir, size_t len)
{
	snprintf(dir, len, "/tmp/avatargw-test-rec-XXXXXX");
	assert_non_null(mkdtemp(dir));
}

static int cmp_str(const void *a, const void *b)
{
	return strcmp(*(char *const *)a, *(char *const *)b);
}

static int list_files(const char *dir, char names[][512], int max)
{
	char *p[64];
	int n = 0;
	DIR *d = opendir(dir);
	struct dirent *de;

	assert_non_null(d);
	while ((de = readdir(d)) && n < max && n < 64)
		if (strstr(de->d_name, ".agwrec")) {
			p[n] = strdup(de->d_name);
			n++;
		}
	closedir(d);
	qsort(p, (size_t)n, sizeof(p[0]), cmp_str);
	for (int i = 0; i < n; i++) {
		snprintf(names[i], 512, "%s/%s", dir, p[i]);
		free(p[i]);
	}
	return n;
}

static void rm_dir(const char *dir)
{
	char names[64][512];
	int n = list_files(dir, names, 64);

	for (int i = 0; i < n; i++)
		unlink(names[i]);
	rmdir(dir);
}

static void open_gateway(struct gateway *g, const char *dir, const char *extra)
{
	char text[2048], err[512];
	struct config c;

	snprintf(text, sizeof(text),
		 "[daemon]\nrate = 240\ncontrol_socket =\nrecord_dir = %s\n%s"
		 "[source clip]\ntype = replay\nfile = builtin:cmu_141_16.csv\n"
		 "[avatar demo]\nperson = clip\n"
		 "[output udp]\ntype = udp\naddress = 127.0.0.1\nport = 9\n",
		 dir, extra);
	assert_int_equal(config_load_text(&c, "rec.conf", text, err, sizeof(err)), 0);
	assert_int_equal(gw_open(g, &c, NULL, 42, err, sizeof(err)), 0);
}

/* the clip's right-hand positions, row by row */
static int clip_rows(double (*rh)[3], int max)
{
	const char *text = builtin_find("cmu_141_16.csv", NULL), *line;
	int n = 0, cx = -1, i = 0;
	char hdr[4096];

	assert_non_null(text);
	snprintf(hdr, sizeof(hdr), "%.*s", (int)strcspn(text, "\n"), text);
	for (char *save, *tok = strtok_r(hdr, ",", &save); tok; tok = strtok_r(NULL, ",", &save), i++)
		if (!strcmp(tok, "rhand_x"))
			cx = i;
	assert_true(cx > 0);
	for (line = strchr(text, '\n'); line && line[1] && n < max; line = strchr(line + 1, '\n')) {
		const char *s = line + 1;
		char *end;

		for (i = 0; i < cx; i++)
			s = strchr(s, ',') + 1;
		for (i = 0; i < 3; i++) {
			rh[n][i] = strtod(s, &end);
			s = end + 1;
		}
		n++;
	}
	return n;
}

/* what the replay source took in is in the file, sample for sample; messages too; a clean end */
static void test_round_trip(void **state)
{
	static struct gateway g;
	static double rows[400][3];
	struct recorder *rec = NULL;
	struct loop *l = NULL;
	struct rec_index ix;
	char dir[64], err[512], files[4][512];
	int n_rows = clip_rows(rows, 400), right, k0 = -1, matched = 0;
	uint64_t took;

	(void)state;
	tmp_dir(dir, sizeof(dir));
	open_gateway(&g, dir, "record_messages = yes\nrecord_flush = 0.05\n");
	assert_int_equal(gw_record(&g, &rec, err, sizeof(err)), 0);
	assert_non_null(rec);
	assert_int_equal(loop_start(&l, &g, err, sizeof(err)), 0);
	sleep_ms(600);
	loop_stop(l);
	took = ctr_get(&g.trk[0].st.samples);
	recorder_close(rec);
	assert_int_equal(list_files(dir, files, 4), 1);
	assert_int_equal(rec_index_load(files[0], &ix, err, sizeof(err)), 0);
	print_message("%s: %zu samples (the source took %llu), %zu messages, %zu bytes\n", files[0], ix.n_events,
		      (unsigned long long)took, ix.n_messages, ix.file_size);
	assert_int_equal(ix.n_sensors, 3);
	assert_string_equal(ix.names[0], "clip.head");
	assert_string_equal(ix.names[2], "clip.right_hand");
	assert_true(ix.n_events == took);
	assert_true(ix.n_events > 60);
	assert_true(ix.n_messages > 100); /* a FRAME per cycle, a DESCRIBE a second */
	assert_true(ix.clean_end);
	assert_int_equal(ix.n_damage, 0);
	assert_int_equal(ix.n_gaps, 0);
	assert_true(ix.hdr.flags & RECFILE_F_MESSAGES);
	assert_string_equal(ix.session.avatars[0].name, "demo");
	/* the right hand's samples are consecutive rows of the clip, to float precision */
	right = rec_index_sensor(&ix, "clip.right_hand");
	for (size_t i = 0; i < ix.n_events; i++) {
		const struct rec_event *e = &ix.events[i];

		if ((int)e->sensor != right)
			continue;
		if (k0 < 0) {
			for (int k = 0; k < n_rows && k0 < 0; k++)
				if (fabs(rows[k][0] - e->p[0]) < 1e-6 && fabs(rows[k][1] - e->p[1]) < 1e-6 &&
				    fabs(rows[k][2] - e->p[2]) < 1e-6)
					k0 = k;
			assert_true(k0 >= 0);
		}
		for (int c = 0; c < 3; c++)
			assert_true(fabs(rows[(k0 + matched) % n_rows][c] - e->p[c]) < 1e-6);
		matched++;
	}
	assert_true(matched > 20);
	rec_index_free(&ix);
	gw_close(&g);
	rm_dir(dir);
}

/* rotation by size or age: several files, each with its header and SESSION, nothing lost between them */
static void rotation(const char *keys, double max_size)
{
	static struct gateway g;
	struct recorder *rec = NULL;
	struct loop *l = NULL;
	char dir[64], err[512], files[32][512];
	size_t total = 0;
	uint64_t took;
	int n;

	tmp_dir(dir, sizeof(dir));
	open_gateway(&g, dir, keys);
	assert_int_equal(gw_record(&g, &rec, err, sizeof(err)), 0);
	assert_int_equal(loop_start(&l, &g, err, sizeof(err)), 0);
	sleep_ms(700);
	loop_stop(l);
	took = ctr_get(&g.trk[0].st.samples);
	recorder_close(rec);
	n = list_files(dir, files, 32);
	print_message("%d files\n", n);
	assert_true(n >= 3);
	for (int i = 0; i < n; i++) {
		struct rec_index ix;

		assert_int_equal(rec_index_load(files[i], &ix, err, sizeof(err)), 0);
		assert_int_equal(ix.hdr.seq, (uint32_t)i);
		assert_int_equal(ix.n_damage, 0);
		assert_true(ix.clean_end);
		assert_int_equal(ix.n_sensors, 3);
		/* a rotated file ends before it passes the size, unless one record alone is bigger */
		assert_true(ix.file_size <= (size_t)(max_size * 1048576) || i == n - 1);
		total += ix.n_events;
		rec_index_free(&ix);
	}
	assert_true(total == took);
	gw_close(&g);
	rm_dir(dir);
}

static void test_rotation_size(void **state)
{
	(void)state;
	rotation("record_messages = yes\nrecord_rotate_size = 0.02\nrecord_flush = 0\n", 0.02);
}

static void test_rotation_time(void **state)
{
	(void)state;
	rotation("record_rotate_time = 0.15\nrecord_flush = 0\n", 1e6);
}

/* a full buffer: the record is dropped, counted, and the file says how many were lost where */
static void test_overflow_marked(void **state)
{
	static struct gateway g;
	struct recorder *rec = NULL;
	struct recfile_sample smp;
	struct rec_index ix;
	char dir[64], err[512], files[4][512];
	const struct recorder_stats *st;
	const int pushes = 100000;

	(void)state;
	tmp_dir(dir, sizeof(dir));
	open_gateway(&g, dir, "record_buffer = 64\nrecord_flush = 0\n");
	assert_int_equal(gw_record(&g, &rec, err, sizeof(err)), 0);
	memset(&smp, 0, sizeof(smp));
	smp.sensor = 1;
	smp.q[0] = 1;
	/* faster than any writer: 6.4 MB in a burst into a 64 KiB buffer (this thread is the only producer) */
	for (int i = 0; i < pushes; i++) {
		smp.arrival_ns = (uint64_t)i + 1;
		recorder_sample(rec, &smp);
	}
	st = recorder_stats(rec);
	sleep_ms(50);
	{
		uint64_t dropped = ctr_get(&st->dropped_records);

		print_message("dropped %llu of %d\n", (unsigned long long)dropped, pushes);
		assert_true(dropped > 0);
		recorder_close(rec);
		assert_int_equal(list_files(dir, files, 4), 1);
		assert_int_equal(rec_index_load(files[0], &ix, err, sizeof(err)), 0);
		assert_true(ix.n_gaps >= 1);
		assert_true(ix.lost_records == dropped);
		assert_true(ix.n_events + dropped == (uint64_t)pushes);
		/* what was kept is in order */
		for (size_t i = 1; i < ix.n_events; i++)
			assert_true(ix.events[i].arrival_ns > ix.events[i - 1].arrival_ns);
		rec_index_free(&ix);
	}
	gw_close(&g);
	rm_dir(dir);
}

/* a directory that cannot be made: the recorder counts and retries, the daemon goes on */
static void test_unwritable(void **state)
{
	static struct gateway g;
	struct recorder *rec = NULL;
	struct loop *l = NULL;
	char err[512];
	const struct recorder_stats *st;

	(void)state;
	open_gateway(&g, "/proc/avatargw-no-such-dir", "record_flush = 0\n");
	assert_int_equal(gw_record(&g, &rec, err, sizeof(err)), 0);
	assert_int_equal(loop_start(&l, &g, err, sizeof(err)), 0);
	st = recorder_stats(rec);
	/* until the loop has run a while and the writer has tried (a loaded host: up to 20 s) */
	for (int i = 0;
	     i < 2000 && (ctr_get(&g.st.cycles) <= 30 || !ctr_get(&st->write_errors) || !ctr_get(&st->skipped_records));
	     i++)
		sleep_ms(10);
	loop_stop(l);
	assert_true(ctr_get(&st->write_errors) > 0);
	assert_true(ctr_get(&st->skipped_records) > 0);
	assert_true(ctr_get(&st->files) == 0);
	assert_true(ctr_get(&g.st.cycles) > 30);
	recorder_close(rec);
	gw_close(&g);
}

/* a reload with other record_* keys reopens the recorder; the same keys keep it and add a SESSION */
static void test_apply(void **state)
{
	static struct gateway g1, g2, g3;
	struct recorder *rec = NULL, *first;
	char dir[64], err[512], files[8][512];
	struct rec_index ix;

	(void)state;
	tmp_dir(dir, sizeof(dir));
	open_gateway(&g1, dir, "");
	assert_int_equal(gw_record(&g1, &rec, err, sizeof(err)), 0);
	first = rec;
	open_gateway(&g2, dir, "");
	assert_int_equal(gw_record(&g2, &rec, err, sizeof(err)), 0);
	assert_ptr_equal(rec, first);
	assert_ptr_equal(g2.trk[0].tap_ctx, rec);
	assert_ptr_equal(g2.rec, rec);
	open_gateway(&g3, dir, "record_fsync = yes\n");
	assert_int_equal(gw_record(&g3, &rec, err, sizeof(err)), 0);
	assert_non_null(rec);
	recorder_close(rec);
	/* two writers, two files (the second named -1 if opened within the same second): 2 + 1 SESSIONs */
	assert_int_equal(list_files(dir, files, 8), 2);
	{
		size_t sessions[2];

		for (int i = 0; i < 2; i++) {
			assert_int_equal(rec_index_load(files[i], &ix, err, sizeof(err)), 0);
			sessions[i] = ix.n_sessions;
			assert_int_equal(ix.n_events, 0);
			assert_true(ix.clean_end);
			rec_index_free(&ix);
		}
		assert_true(sessions[0] + sessions[1] == 3 && sessions[0] * sessions[1] == 2);
	}
	gw_close(&g1);
	gw_close(&g2);
	gw_close(&g3);
	rm_dir(dir);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_round_trip),    cmocka_unit_test(test_rotation_size),
		cmocka_unit_test(test_rotation_time), cmocka_unit_test(test_overflow_marked),
		cmocka_unit_test(test_unwritable),    cmocka_unit_test(test_apply),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
