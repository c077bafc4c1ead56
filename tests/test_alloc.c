// SPDX-License-Identifier: MIT
/*
 * test_alloc.c - nothing is allocated after start-up.
 *
 * malloc, calloc, realloc and free are wrapped at link time
 * (-Wl,--wrap=..., see the Makefile): every call from avatargw's own code
 * and the IK core is counted. The gateway is built (allocation allowed),
 * then the real loop thread runs for a while with a TCP and a Unix
 * subscriber connected, a slow subscriber that never reads, several
 * avatars, sim and replay sources, DESCRIBEs, the recorder (samples and
 * messages, its writer thread flushing), a replay of another site's
 * avatars, and the counters must not move. mallinfo2() must not move
 * either, which also catches allocations made inside libc on our behalf.
 */
#include "config/config.h"
#include "daemon/gateway.h"
#include "daemon/loop.h"
#include "record/recfile.h"
#include "record/recorder.h"

#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <cmocka.h>

#include <dirent.h>
#include <malloc.h>
#include <netinet/in.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <time.h>
#include <unistd.h>

#include "publish/output.h"

void *__real_malloc(size_t n);
void *__real_calloc(size_t n, size_t m);
void *__real_realloc(void *p, size_t n);
void __real_free(void *p);

static _Atomic int counting;
static _Atomic long allocs;

void *__wrap_malloc(size_t n);
void *__wrap_calloc(size_t n, size_t m);
void *__wrap_realloc(void *p, size_t n);
void __wrap_free(void *p);

void *__wrap_malloc(size_t n)
{
	if (atomic_load(&counting))
		atomic_fetch_add(&allocs, 1);
	return __real_malloc(n);
}

void *__wrap_calloc(size_t n, size_t m)
{
	if (atomic_load(&counting))
		atomic_fetch_add(&allocs, 1);
	return __real_calloc(n, m);
}

void *__wrap_realloc(void *p, size_t n)
{
	if (atomic_load(&counting))
		atomic_fetch_add(&allocs, 1);
	return __real_realloc(p, n);
}

void __wrap_free(void *p)
{
	if (atomic_load(&counting) && p)
		atomic_fetch_add(&allocs, 1);
	__real_free(p);
}

/* the ports are chosen at run time (free ones): printf with udp port, tcp port */
static const char conf_fmt[] = "[daemon]\n"
			       "rate = 480\n"
			       "control_socket =\n"
			       "describe_interval = 0.1\n"
			       "stale_ms = 20\n"
			       "record_dir = /tmp/avatargw-test-alloc-rec\n"
			       "record_messages = yes\n"
			       "record_flush = 0.02\n"
			       "[source sim]\n"
			       "type = sim\n"
			       "people = 3\n"
			       "[source clip]\n"
			       "type = replay\n"
			       "file = builtin:cmu_141_16.csv\n"
			       "[avatar crowd]\n"
			       "person = sim/p0\n"
			       "count = 3\n"
			       "[avatar clip]\n"
			       "person = clip\n"
			       "[avatar mixed]\n"
			       "person = sim/p0\n"
			       "right_hand = clip/right_hand\n"
			       "[output udp]\n"
			       "type = udp\n"
			       "address = 127.0.0.1\n"
			       "port = %d\n"
			       "[output tcp]\n"
			       "type = tcp\n"
			       "address = 127.0.0.1\n"
			       "port = %d\n"
			       "client_buffer = 4096\n"
			       "[output unix]\n"
			       "type = unix\n"
			       "path = /tmp/avatargw-test-alloc.sock\n";

static int free_tcp_port(void);

static void sleep_ms(int ms)
{
	struct timespec ts = { ms / 1000, (ms % 1000) * 1000000L };

	while (nanosleep(&ts, &ts))
		;
}

/* a recording directory and its files */
static void remove_dir(const char *dir)
{
	DIR *d = opendir(dir);
	struct dirent *de;
	char p[512];

	while (d && (de = readdir(d)))
		if (de->d_name[0] != '.') {
			snprintf(p, sizeof(p), "%s/%s", dir, de->d_name);
			unlink(p);
		}
	if (d)
		closedir(d);
	rmdir(dir);
}

static void test_loop_allocates_nothing(void **state)
{
	static struct gateway g;
	struct config c;
	char err[512];
	struct loop *l = NULL;
	struct recorder *rec = NULL;
	uint64_t rec_before;
	int tport = free_tcp_port();
	struct sockaddr_in sin = { .sin_family = AF_INET,
				   .sin_port = htons((uint16_t)tport),
				   .sin_addr.s_addr = htonl(INADDR_LOOPBACK) };
	char conf[4096];
	struct sockaddr_un sun = { .sun_family = AF_UNIX, .sun_path = "/tmp/avatargw-test-alloc.sock" };
	struct mallinfo2 before, after;
	int tcp, ux, rx;
	long n;
	char buf[65536];
	uint64_t frames = 0;

	(void)state;
	/* the UDP port: any; nobody needs to listen */
	snprintf(conf, sizeof(conf), conf_fmt, free_tcp_port(), tport);
	assert_int_equal(config_load_text(&c, "alloc.conf", conf, err, sizeof(err)), 0);
	assert_int_equal(gw_open(&g, &c, NULL, 42, err, sizeof(err)), 0);
	assert_int_equal(gw_record(&g, &rec, err, sizeof(err)), 0);
	assert_int_equal(loop_start(&l, &g, err, sizeof(err)), 0);
	/* subscribers: one that reads, one (TCP) that never reads and falls behind */
	tcp = socket(AF_INET, SOCK_STREAM, 0);
	ux = socket(AF_UNIX, SOCK_STREAM, 0);
	assert_int_equal(connect(tcp, (struct sockaddr *)&sin, sizeof(sin)), 0);
	assert_int_equal(connect(ux, (struct sockaddr *)&sun, sizeof(sun)), 0);
	sleep_ms(300); /* warm: accepted, first DESCRIBEs out, the slow buffer full */
	before = mallinfo2();
	rec_before = ctr_get(&recorder_stats(rec)->records);
	atomic_store(&counting, 1);
	for (int i = 0; i < 20; i++) {
		sleep_ms(50);
		rx = (int)recv(ux, buf, sizeof(buf), MSG_DONTWAIT);
		(void)rx;
	}
	atomic_store(&counting, 0);
	after = mallinfo2();
	n = atomic_load(&allocs);
	loop_stop(l);
	/* the recorder wrote all along, and lost nothing */
	print_message("recorded %llu records while counting\n",
		      (unsigned long long)(ctr_get(&recorder_stats(rec)->records) - rec_before));
	assert_true(ctr_get(&recorder_stats(rec)->records) - rec_before > 1000);
	assert_int_equal(ctr_get(&recorder_stats(rec)->dropped_records), 0);
	recorder_close(rec);
	remove_dir("/tmp/avatargw-test-alloc-rec");
	for (int i = 0; i < g.n_avatars; i++)
		frames += ctr_get(&g.av[i].st.frames);
	print_message("cycles %llu, frames %llu, tcp dropped %llu, allocations while running: %ld\n",
		      (unsigned long long)ctr_get(&g.st.cycles), (unsigned long long)frames,
		      (unsigned long long)ctr_get(&g.out[1].st.dropped), n);
	/* the loop did run, the slow subscriber did lose messages, and nothing was allocated */
	assert_true(ctr_get(&g.st.cycles) > 200);
	assert_int_equal(g.n_avatars, 5);
	assert_true(ctr_get(&g.out[1].st.dropped) > 0);
	assert_int_equal(ctr_get(&g.out[1].st.clients), 1);
	assert_int_equal(n, 0);
	assert_int_equal(before.uordblks, after.uordblks);
	assert_int_equal(before.hblkhd, after.hblkhd);
	close(tcp);
	close(ux);
	gw_close(&g);
}

/*
 * A recording of another site's avatar (REMOTE records only: a site without
 * trackers), written here, replayed in a loop while it is recorded again:
 * the replay's remote avatars (decoded in the loop, their DESCRIBEs
 * re-encoded with their site's figures) and the recorder's REMOTE records
 * allocate nothing.
 */
static void write_remote_recording(const char *path)
{
	static uint8_t buf[1 << 20];
	uint8_t msg[WIRE_MAX_MSG];
	struct recfile_header h = { RECFILE_VERSION, 0, 1, 0 };
	struct recfile_writer w;
	struct wire_describe d;
	struct wire_frame f;
	size_t len = RECFILE_HEADER_LEN;
	FILE *o;

	recfile_header_encode(&h, buf);
	/* SESSION: no sources, no avatars */
	w = (struct recfile_writer){ buf + len + RECFILE_REC_HEAD, 256, 0, false };
	recfile_w_u64(&w, 1);
	recfile_w_u64(&w, 1);
	recfile_w_f64(&w, 480);
	recfile_w_u32(&w, 42);
	recfile_w_u16(&w, 0);
	recfile_w_u16(&w, 0);
	recfile_frame(buf + len, RECFILE_SESSION, (uint32_t)w.len);
	recfile_seal(buf + len);
	len += RECFILE_REC_OVERHEAD + w.len;
	memset(&d, 0, sizeof(d));
	d.h.avatar_id = 1000;
	strcpy(d.avatar_name, "lab-a/person0");
	d.site = (struct wire_site){ true, "lab-a", 0, 1, 240, 10, 0, 0.5f, 1, 0, 0.25f };
	for (int i = 0; i < 400; i++) {
		size_t n;

		memset(&f, 0, sizeof(f));
		f.h.avatar_id = 1000;
		f.h.sample_time_ns = 1000 + (uint64_t)i;
		f.joint[1] = 0.001f * (float)i;
		/* a DESCRIBE every 100 frames, as a daemon records them once a second */
		n = i % 100 ? wire_encode_frame(&f, msg) : wire_encode_describe(&d, msg);
		recfile_put64(buf + len + RECFILE_REC_HEAD, 1000000 + 4166666 * (uint64_t)i);
		memcpy(buf + len + RECFILE_REC_HEAD + RECFILE_MESSAGE_HEAD, msg, n);
		recfile_frame(buf + len, RECFILE_REMOTE, (uint32_t)(RECFILE_MESSAGE_HEAD + n));
		recfile_seal(buf + len);
		len += RECFILE_REC_OVERHEAD + RECFILE_MESSAGE_HEAD + n;
	}
	o = fopen(path, "wb");
	assert_non_null(o);
	assert_int_equal(fwrite(buf, 1, len, o), len);
	fclose(o);
}

static void test_remote_replay_allocates_nothing(void **state)
{
	static struct gateway g;
	static const char file[] = "/tmp/avatargw-test-alloc-remote.agwrec";
	struct config c;
	char err[512], conf[1024];
	struct loop *l = NULL;
	struct recorder *rec = NULL;
	struct mallinfo2 before, after;
	uint64_t remote0;
	long n;

	(void)state;
	write_remote_recording(file);
	snprintf(conf, sizeof(conf),
		 "[daemon]\nrate = 480\ncontrol_socket =\ndescribe_interval = 0.1\n"
		 "record_dir = /tmp/avatargw-test-alloc-rec2\nrecord_flush = 0.02\n"
		 "[source rec]\ntype = replay\nfile = %s\nspeed = 4\n"
		 "[output udp]\ntype = udp\naddress = 127.0.0.1\nport = %d\n",
		 file, free_tcp_port());
	if (config_load_text(&c, "alloc.conf", conf, err, sizeof(err)))
		fail_msg("%s", err);
	assert_int_equal(gw_open(&g, &c, NULL, 42, err, sizeof(err)), 0);
	assert_int_equal(g.n_remote, 1);
	assert_int_equal(gw_record(&g, &rec, err, sizeof(err)), 0);
	assert_int_equal(loop_start(&l, &g, err, sizeof(err)), 0);
	sleep_ms(300);
	before = mallinfo2();
	remote0 = ctr_get(&g.av[0].st.new_frames);
	atomic_store(&allocs, 0);
	atomic_store(&counting, 1);
	sleep_ms(1000); /* the clip (0.4 s at speed 4) loops: its DESCRIBEs and frames again and again */
	atomic_store(&counting, 0);
	after = mallinfo2();
	n = atomic_load(&allocs);
	loop_stop(l);
	print_message("replayed remote frames %llu, records %llu, allocations while running: %ld\n",
		      (unsigned long long)(ctr_get(&g.av[0].st.new_frames) - remote0),
		      (unsigned long long)ctr_get(&recorder_stats(rec)->records), n);
	assert_true(ctr_get(&g.av[0].st.new_frames) - remote0 > 100); /* they did play (a new one in most cycles) */
	assert_int_equal(ctr_get(&recorder_stats(rec)->dropped_records), 0);
	recorder_close(rec);
	remove_dir("/tmp/avatargw-test-alloc-rec2");
	unlink(file);
	assert_int_equal(n, 0);
	assert_int_equal(before.uordblks, after.uordblks);
	assert_int_equal(before.hblkhd, after.hblkhd);
	gw_close(&g);
}

/* a TCP port nobody listens on now */
static int free_tcp_port(void)
{
	struct sockaddr_in sin = { .sin_family = AF_INET, .sin_addr.s_addr = htonl(INADDR_LOOPBACK) };
	socklen_t len = sizeof(sin);
	int fd = socket(AF_INET, SOCK_STREAM, 0), port;

	assert_true(fd >= 0);
	assert_int_equal(bind(fd, (struct sockaddr *)&sin, sizeof(sin)), 0);
	assert_int_equal(getsockname(fd, (struct sockaddr *)&sin, &len), 0);
	port = ntohs(sin.sin_port);
	close(fd);
	return port;
}

static uint64_t count_in(struct output *o, const char *key)
{
	char buf[1024], pat[64], *s;
	FILE *m = fmemopen(buf, sizeof(buf), "w");

	assert_non_null(m);
	o->ops->report(o, m, true);
	fclose(m);
	snprintf(pat, sizeof(pat), "\"%s\":", key);
	s = strstr(buf, pat);
	assert_non_null(s);
	return strtoull(s + strlen(pat), NULL, 10);
}

/*
 * The industrial outputs and sources: a Modbus server answering a client
 * and the daemon's own Modbus source (which polls that server from its
 * thread), a CAN output and a CAN source on socketpairs the test feeds and
 * drains. Nothing is allocated by anyone once they run: the loop thread,
 * the Modbus server's thread, the Modbus source's thread.
 */
static void test_bus_loop_allocates_nothing(void **state)
{
	static struct gateway g;
	static const uint8_t fc4[] = { 0, 1, 0, 0, 0, 6, 1, 4, 0, 0, 0, 66 };
	struct config c;
	char err[512], conf_text[2048];
	struct loop *l = NULL;
	struct mallinfo2 before, after;
	int can_in[2], can_out[2], port = free_tcp_port(), cl;
	struct sockaddr_in sin = { .sin_family = AF_INET,
				   .sin_port = htons((uint16_t)port),
				   .sin_addr.s_addr = htonl(INADDR_LOOPBACK) };
	uint64_t req0, cmd0, samples0, mbin0;
	long n;
	uint8_t buf[4096];

	(void)state;
	assert_int_equal(socketpair(AF_UNIX, SOCK_SEQPACKET, 0, can_in), 0);
	assert_int_equal(socketpair(AF_UNIX, SOCK_SEQPACKET, 0, can_out), 0);
	snprintf(conf_text, sizeof(conf_text),
		 "[daemon]\nrate = 480\ncontrol_socket =\ndescribe_interval = 0.1\n"
		 "[source sim]\ntype = sim\npeople = 2\n"
		 "[source bus]\ntype = can\ninterface = fd:%d\nposition_id = -1\n"
		 "[source plc]\ntype = modbus\naddress = 127.0.0.1\nport = %d\nregister_type = input\n"
		 "position_register = 12\norientation = none\npoll_rate = 200\n"
		 "[avatar crowd]\nperson = sim/p0\ncount = 2\n"
		 "[avatar mixed]\nperson = sim/p0\nleft_hand = bus/pose0\nright_hand = plc/pose0\n"
		 "[output mb]\ntype = modbus\nport = %d\n"
		 "[output arm]\ntype = can\ninterface = fd:%d\n"
		 "[output plain]\ntype = can\ninterface = fd:%d\nsafe = no\nbase_id = 0x200\n",
		 can_in[0], port, port, can_out[0], can_out[0]);
	assert_int_equal(config_load_text(&c, "bus.conf", conf_text, err, sizeof(err)), 0);
	assert_int_equal(gw_open(&g, &c, NULL, 42, err, sizeof(err)), 0);
	assert_int_equal(loop_start(&l, &g, err, sizeof(err)), 0);
	cl = socket(AF_INET, SOCK_STREAM, 0);
	assert_int_equal(connect(cl, (struct sockaddr *)&sin, sizeof(sin)), 0);
	sleep_ms(400); /* warm: the source connected, DESCRIBEs out, a client served */
	req0 = count_in(&g.out[0], "requests");
	cmd0 = count_in(&g.out[1], "commands");
	samples0 = ctr_get(&g.trk[1].st.samples);
	mbin0 = ctr_get(&g.trk[2].st.samples);
	before = mallinfo2();
	atomic_store(&allocs, 0);
	atomic_store(&counting, 1);
	for (int i = 0; i < 40; i++) {
		/* a sensor frame in, an avatar block read over Modbus, the CAN commands drained */
		uint8_t ori[16] = { 0x00, 0x02, 0, 0, 8, 0, 0, 0, 0xff, 0x7f, 0, 0, 0, 0, 0, 0 };

		assert_int_equal(send(can_in[1], ori, sizeof(ori), 0), sizeof(ori));
		assert_int_equal(send(cl, fc4, sizeof(fc4), 0), sizeof(fc4));
		assert_true(recv(cl, buf, 9 + 132, MSG_WAITALL) == 9 + 132);
		while (recv(can_out[1], buf, sizeof(buf), MSG_DONTWAIT) > 0)
			;
		sleep_ms(10);
	}
	atomic_store(&counting, 0);
	after = mallinfo2();
	n = atomic_load(&allocs);
	print_message("modbus requests %llu, can commands %llu, can samples %llu, modbus samples %llu, "
		      "allocations while running: %ld\n",
		      (unsigned long long)(count_in(&g.out[0], "requests") - req0),
		      (unsigned long long)(count_in(&g.out[1], "commands") - cmd0),
		      (unsigned long long)(ctr_get(&g.trk[1].st.samples) - samples0),
		      (unsigned long long)(ctr_get(&g.trk[2].st.samples) - mbin0), n);
	loop_stop(l);
	/* everything ran */
	assert_true(count_in(&g.out[0], "requests") - req0 > 40); /* ours and the modbus source's */
	assert_true(count_in(&g.out[1], "commands") - cmd0 > 50);
	assert_true(count_in(&g.out[2], "commands") > 50);
	assert_int_equal(ctr_get(&g.trk[1].st.samples) - samples0, 40);
	assert_true(ctr_get(&g.trk[2].st.samples) - mbin0 > 10);
	/* and allocated nothing */
	assert_int_equal(n, 0);
	assert_int_equal(before.uordblks, after.uordblks);
	assert_int_equal(before.hblkhd, after.hblkhd);
	close(cl);
	gw_close(&g);
	for (int i = 0; i < 2; i++) {
		close(can_in[i]);
		close(can_out[i]);
	}
}

/* the wrapper counts: a control that the test can fail */
static void test_wrapper_counts(void **state)
{
	void *volatile p; /* not elided by the compiler */

	(void)state;
	atomic_store(&allocs, 0);
	atomic_store(&counting, 1);
	p = malloc(16);
	free(p);
	atomic_store(&counting, 0);
	assert_int_equal(atomic_load(&allocs), 2);
	atomic_store(&allocs, 0);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_wrapper_counts),
		cmocka_unit_test(test_loop_allocates_nothing),
		cmocka_unit_test(test_bus_loop_allocates_nothing),
		cmocka_unit_test(test_remote_replay_allocates_nothing),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
