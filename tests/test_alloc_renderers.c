// SPDX-License-Identifier: MIT
/*
 * test_alloc_renderers.c - the renderer outputs keep the loop clean: with a
 * VRPN client, a VMC and a VRChat destination and a browser on the
 * websocket, the loop thread allocates nothing and never calls liblo or
 * libwebsockets (which allocate: their threads do that).
 *
 * malloc and friends, and the library entry points our outputs use, are
 * wrapped at link time (see the Makefile); a call counts as a fault when it
 * comes from the thread named "avatargw-loop". The outputs' own threads may
 * allocate and call their libraries, and the test checks that they did
 * their work meanwhile (something was sent on every output).
 */
#include "config/config.h"
#include "daemon/gateway.h"
#include "daemon/loop.h"

#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <cmocka.h>

#include <arpa/inet.h>
#include <libwebsockets.h>
#include <lo/lo.h>
#include <netinet/in.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

static _Atomic int counting;
static _Atomic long loop_allocs, loop_lib_calls, other_lib_calls;

static bool on_loop(void)
{
	char name[16] = "";

	/* for the calling thread glibc asks the kernel (prctl): no allocation */
	pthread_getname_np(pthread_self(), name, sizeof(name));
	return !strcmp(name, "avatargw-loop");
}

static void alloc_seen(void)
{
	if (atomic_load(&counting) && on_loop())
		atomic_fetch_add(&loop_allocs, 1);
}

static void lib_seen(void)
{
	if (!atomic_load(&counting))
		return;
	if (on_loop())
		atomic_fetch_add(&loop_lib_calls, 1);
	else
		atomic_fetch_add(&other_lib_calls, 1);
}

void *__real_malloc(size_t n);
void *__real_calloc(size_t n, size_t m);
void *__real_realloc(void *p, size_t n);
void __real_free(void *p);
void *__wrap_malloc(size_t n);
void *__wrap_calloc(size_t n, size_t m);
void *__wrap_realloc(void *p, size_t n);
void __wrap_free(void *p);

void *__wrap_malloc(size_t n)
{
	alloc_seen();
	return __real_malloc(n);
}

void *__wrap_calloc(size_t n, size_t m)
{
	alloc_seen();
	return __real_calloc(n, m);
}

void *__wrap_realloc(void *p, size_t n)
{
	alloc_seen();
	return __real_realloc(p, n);
}

void __wrap_free(void *p)
{
	if (p)
		alloc_seen();
	__real_free(p);
}

/* the library calls of osc.c and websocket.c */
lo_message __real_lo_message_new(void);
int __real_lo_send_message(lo_address a, const char *path, lo_message m);
int __real_lo_send_bundle(lo_address a, lo_bundle b);
int __real_lws_write(struct lws *wsi, unsigned char *buf, size_t len, enum lws_write_protocol wp);
int __real_lws_callback_on_writable_all_protocol(const struct lws_context *c, const struct lws_protocols *p);
lo_message __wrap_lo_message_new(void);
int __wrap_lo_send_message(lo_address a, const char *path, lo_message m);
int __wrap_lo_send_bundle(lo_address a, lo_bundle b);
int __wrap_lws_write(struct lws *wsi, unsigned char *buf, size_t len, enum lws_write_protocol wp);
int __wrap_lws_callback_on_writable_all_protocol(const struct lws_context *c, const struct lws_protocols *p);

lo_message __wrap_lo_message_new(void)
{
	lib_seen();
	return __real_lo_message_new();
}

int __wrap_lo_send_message(lo_address a, const char *path, lo_message m)
{
	lib_seen();
	return __real_lo_send_message(a, path, m);
}

int __wrap_lo_send_bundle(lo_address a, lo_bundle b)
{
	lib_seen();
	return __real_lo_send_bundle(a, b);
}

int __wrap_lws_write(struct lws *wsi, unsigned char *buf, size_t len, enum lws_write_protocol wp)
{
	lib_seen();
	return __real_lws_write(wsi, buf, len, wp);
}

int __wrap_lws_callback_on_writable_all_protocol(const struct lws_context *c, const struct lws_protocols *p)
{
	lib_seen();
	return __real_lws_callback_on_writable_all_protocol(c, p);
}

static int free_port(int type)
{
	struct sockaddr_in a = { .sin_family = AF_INET, .sin_addr.s_addr = htonl(INADDR_LOOPBACK) };
	socklen_t l = sizeof(a);
	int fd = socket(AF_INET, type, 0), port;

	assert_int_equal(bind(fd, (struct sockaddr *)&a, sizeof(a)), 0);
	getsockname(fd, (struct sockaddr *)&a, &l);
	port = ntohs(a.sin_port);
	close(fd);
	return port;
}

static int connect_tcp(int port)
{
	struct sockaddr_in a = { .sin_family = AF_INET,
				 .sin_port = htons((uint16_t)port),
				 .sin_addr.s_addr = htonl(INADDR_LOOPBACK) };
	int fd = socket(AF_INET, SOCK_STREAM, 0);

	assert_int_equal(connect(fd, (struct sockaddr *)&a, sizeof(a)), 0);
	return fd;
}

static void sleep_ms(int ms)
{
	struct timespec ts = { ms / 1000, (ms % 1000) * 1000000L };

	while (nanosleep(&ts, &ts))
		;
}

static long drain(int fd)
{
	char buf[65536];
	long total = 0;
	ssize_t n;

	while ((n = recv(fd, buf, sizeof(buf), MSG_DONTWAIT)) > 0)
		total += n;
	return total;
}

static uint64_t out_stat(struct gateway *g, const char *name, size_t off)
{
	for (int i = 0; i < g->n_outputs; i++)
		if (!strcmp(g->out[i].name, name))
			return ctr_get((_Atomic uint64_t *)((char *)&g->out[i].st + off));
	fail_msg("no output %s", name);
	return 0;
}

static void test_renderer_outputs_keep_the_loop_clean(void **state)
{
	static struct gateway g;
	char text[2048], err[512];
	struct config c;
	struct loop *l = NULL;
	int vrpn_port = free_port(SOCK_STREAM), ws_port = free_port(SOCK_STREAM);
	int vmc_port = free_port(SOCK_DGRAM), vrc_port = free_port(SOCK_DGRAM);
	const char cookie[24] = "vrpn: ver. 07.35  0";
	const char *upgrade = "GET / HTTP/1.1\r\nHost: 127.0.0.1\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
			      "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n"
			      "Sec-WebSocket-Protocol: avatargw-json\r\n\r\n";
	int vrpn, ws;
	long got_vrpn = 0, got_ws = 0;

	(void)state;
	snprintf(text, sizeof(text),
		 "[daemon]\nrate = 480\ncontrol_socket =\ndescribe_interval = 0.1\n"
		 "[source clip]\ntype = replay\nfile = builtin:cmu_141_16.csv\n"
		 "[source sim]\ntype = sim\npeople = 2\n"
		 "[avatar demo]\nperson = clip\n[avatar crowd]\nperson = sim/p0\ncount = 2\n"
		 "[output v]\ntype = vrpn\naddress = 127.0.0.1\nport = %d\n"
		 "[output m]\ntype = vmc\nport = %d\navatars = demo\nrate = 100\n"
		 "[output r]\ntype = vrchat\nport = %d\navatars = crowd-1\nrate = 100\n"
		 "[output w]\ntype = websocket\nport = %d\nrate = 60\n",
		 vrpn_port, vmc_port, vrc_port, ws_port);
	setenv("AVATARGW_WWW", "www", 1); /* the page of this tree (the tests run from its root) */
	assert_int_equal(config_load_text(&c, "renderers.conf", text, err, sizeof(err)), 0);
	if (gw_open(&g, &c, NULL, 7, err, sizeof(err)))
		fail_msg("%s", err);
	assert_int_equal(loop_start(&l, &g, err, sizeof(err)), 0);
	vrpn = connect_tcp(vrpn_port);
	assert_int_equal(send(vrpn, cookie, sizeof(cookie), 0), 24);
	ws = connect_tcp(ws_port);
	assert_int_equal(send(ws, upgrade, strlen(upgrade), 0), (ssize_t)strlen(upgrade));
	sleep_ms(300); /* warm: handshakes done, first frames through every output */
	atomic_store(&counting, 1);
	for (int i = 0; i < 20; i++) {
		sleep_ms(50);
		got_vrpn += drain(vrpn);
		got_ws += drain(ws);
	}
	atomic_store(&counting, 0);
	loop_stop(l);
	print_message("loop cycles %llu; loop thread: %ld allocations, %ld library calls; other threads: %ld "
		      "library calls; read %ld bytes of VRPN, %ld of WebSocket\n",
		      (unsigned long long)ctr_get(&g.st.cycles), atomic_load(&loop_allocs),
		      atomic_load(&loop_lib_calls), atomic_load(&other_lib_calls), got_vrpn, got_ws);
	/* the outputs worked meanwhile... */
	assert_true(ctr_get(&g.st.cycles) > 300);
	assert_true(got_vrpn > 100000);
	assert_true(got_ws > 10000);
	assert_true(out_stat(&g, "m", offsetof(struct output_stats, sent)) > 50);
	assert_true(out_stat(&g, "r", offsetof(struct output_stats, sent)) > 50 * 8);
	assert_true(out_stat(&g, "w", offsetof(struct output_stats, sent)) > 30);
	assert_int_equal(out_stat(&g, "v", offsetof(struct output_stats, clients)), 1);
	/* ...through their libraries, from their own threads */
	assert_true(atomic_load(&other_lib_calls) > 100);
	/* and the loop did none of it */
	assert_int_equal(atomic_load(&loop_allocs), 0);
	assert_int_equal(atomic_load(&loop_lib_calls), 0);
	close(vrpn);
	close(ws);
	gw_close(&g);
}

/* the wrappers see the loop thread: a control the test can fail */
static void *pretend_loop(void *arg)
{
	void *volatile p;

	(void)arg;
	pthread_setname_np(pthread_self(), "avatargw-loop");
	p = malloc(8);
	free(p);
	lo_message_free(lo_message_new());
	return NULL;
}

static void test_wrappers_see_the_loop(void **state)
{
	pthread_t t;

	(void)state;
	atomic_store(&loop_allocs, 0);
	atomic_store(&counting, 1);
	pthread_create(&t, NULL, pretend_loop, NULL);
	pthread_join(t, NULL);
	atomic_store(&counting, 0);
	assert_int_equal(atomic_load(&loop_allocs), 2);
	assert_int_equal(atomic_load(&loop_lib_calls), 1);
	atomic_store(&loop_allocs, 0);
	atomic_store(&loop_lib_calls, 0);
	atomic_store(&other_lib_calls, 0);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_wrappers_see_the_loop),
		cmocka_unit_test(test_renderer_outputs_keep_the_loop_clean),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
