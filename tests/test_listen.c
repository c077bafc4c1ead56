// SPDX-License-Identifier: MIT
/*
 * test_listen.c - what the listeners share (publish/listen.c): the slot a new
 * client takes (out_slot_for: a free one, else the idlest client's after a
 * second of idleness, a host's own client once it has its share), and Unix
 * sockets that are never taken over and removed only while still ours.
 */
#include "publish/listen.h"

#include <arpa/inet.h>
#include <errno.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>
#include <cmocka.h>

#define S 1000000000ull

struct slot {
	int fd;
	struct out_peer peer;
};

static struct sockaddr_storage host(const char *ip)
{
	struct sockaddr_storage a = { 0 };
	struct sockaddr_in *in = (struct sockaddr_in *)&a;

	in->sin_family = AF_INET;
	in->sin_port = htons(40000);
	inet_pton(AF_INET, ip, &in->sin_addr);
	return a;
}

static void take(struct slot *s, int fd, const char *ip, uint64_t active)
{
	s->fd = fd;
	s->peer.addr = host(ip);
	s->peer.active_ns = active;
}

static int pick(struct slot *sl, int n, const char *ip, int per_addr, uint64_t now, bool *drop)
{
	struct sockaddr_storage from = host(ip);

	return out_slot_for(sl, sizeof(*sl), offsetof(struct slot, fd), offsetof(struct slot, peer), n, &from, per_addr,
			    now, drop);
}

static void test_free_slot_first(void **state)
{
	struct slot sl[3] = { { .fd = -1 }, { .fd = -1 }, { .fd = -1 } };
	bool drop = true;

	(void)state;
	assert_int_equal(pick(sl, 3, "10.0.0.1", 0, 5 * S, &drop), 0);
	assert_false(drop);
	take(&sl[0], 10, "10.0.0.1", 1 * S);
	assert_int_equal(pick(sl, 3, "10.0.0.2", 0, 5 * S, &drop), 1);
	assert_false(drop);
}

static void test_full_gives_up_the_idlest(void **state)
{
	struct slot sl[3];
	bool drop = false;

	(void)state;
	take(&sl[0], 10, "10.0.0.1", 4 * S);
	take(&sl[1], 11, "10.0.0.2", 2 * S); /* idle the longest */
	take(&sl[2], 12, "10.0.0.3", 3 * S);
	assert_int_equal(pick(sl, 3, "10.0.0.9", 0, 5 * S, &drop), 1);
	assert_true(drop);
	/* all active within the last second: the newcomer is refused */
	assert_int_equal(pick(sl, 3, "10.0.0.9", 0, 2 * S + S / 2, &drop), -1);
}

static void test_a_host_gives_up_its_own(void **state)
{
	struct slot sl[4] = { { .fd = -1 }, { .fd = -1 }, { .fd = -1 }, { .fd = -1 } };
	bool drop = false;

	(void)state;
	take(&sl[0], 10, "10.0.0.7", 1 * S); /* another host, idle the longest of all */
	take(&sl[1], 11, "10.0.0.1", 3 * S);
	take(&sl[2], 12, "10.0.0.1", 2 * S); /* the host's idlest */
	/* 10.0.0.1 has its share (2): its third takes its own idlest's slot, not the free one nor 10.0.0.7's */
	assert_int_equal(pick(sl, 4, "10.0.0.1", 2, 5 * S, &drop), 2);
	assert_true(drop);
	/* ... and only after a second idle */
	assert_int_equal(pick(sl, 4, "10.0.0.1", 2, 2 * S + S / 2, &drop), -1);
	/* another host still gets the free slot */
	assert_int_equal(pick(sl, 4, "10.0.0.2", 2, 5 * S, &drop), 3);
	assert_false(drop);
	/* no limit per host: the free slot */
	assert_int_equal(pick(sl, 4, "10.0.0.1", 0, 5 * S, &drop), 3);
	assert_false(drop);
}

static void test_same_host(void **state)
{
	struct sockaddr_storage a = host("10.1.2.3"), b = host("10.1.2.3"), c = host("10.1.2.4");
	struct sockaddr_storage u = { .ss_family = AF_UNIX };

	(void)state;
	((struct sockaddr_in *)&b)->sin_port = htons(1);
	assert_true(out_same_host(&a, &b));
	assert_false(out_same_host(&a, &c));
	assert_false(out_same_host(&a, &u));
}

static void tmp_path(char *buf, size_t len, const char *name)
{
	const char *d = getenv("TMPDIR");

	snprintf(buf, len, "%s/agw-test-listen-%d-%s", d && d[0] ? d : "/tmp", (int)getpid(), name);
}

static void test_unix_never_taken_over(void **state)
{
	char path[108], err[256];
	struct stat st;
	int a, b, fd;

	(void)state;
	tmp_path(path, sizeof(path), "sock");
	unlink(path);
	a = out_listen_unix(path, 0600, err, sizeof(err));
	assert_true(a >= 0);
	assert_int_equal(stat(path, &st), 0);
	assert_int_equal(st.st_mode & 0777, 0600);
	/* something listens there: refused, the socket stays */
	b = out_listen_unix(path, 0600, err, sizeof(err));
	assert_true(b < 0);
	assert_int_equal(stat(path, &st), 0);
	/* a second descriptor (a reload): the file stays until the last one closes */
	fd = out_unix_share(a, path);
	assert_true(fd >= 0);
	out_unix_close(a, path);
	assert_int_equal(stat(path, &st), 0);
	out_unix_close(fd, path);
	assert_int_equal(stat(path, &st), -1);
	assert_int_equal(errno, ENOENT);
}

static void test_unix_stale_replaced_and_foreign_kept(void **state)
{
	struct sockaddr_un sun = { .sun_family = AF_UNIX };
	char path[108], err[256];
	struct stat st;
	int s, a;

	(void)state;
	tmp_path(path, sizeof(path), "stale");
	unlink(path);
	strcpy(sun.sun_path, path);
	/* a socket nobody listens on (a run killed with -9): replaced */
	s = socket(AF_UNIX, SOCK_STREAM, 0);
	assert_int_equal(bind(s, (struct sockaddr *)&sun, sizeof(sun)), 0);
	close(s);
	a = out_listen_unix(path, 0660, err, sizeof(err));
	assert_true(a >= 0);
	/* someone else's socket at the path by the time we close: left alone */
	assert_int_equal(unlink(path), 0);
	s = socket(AF_UNIX, SOCK_STREAM, 0);
	assert_int_equal(bind(s, (struct sockaddr *)&sun, sizeof(sun)), 0);
	out_unix_close(a, path);
	assert_int_equal(stat(path, &st), 0);
	close(s);
	unlink(path);
	/* a file that is not a socket: refused, left alone */
	s = open(path, O_CREAT | O_WRONLY, 0600);
	assert_true(s >= 0);
	close(s);
	assert_int_equal(out_listen_unix(path, 0600, err, sizeof(err)), -EEXIST);
	assert_int_equal(stat(path, &st), 0);
	unlink(path);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_free_slot_first),
		cmocka_unit_test(test_full_gives_up_the_idlest),
		cmocka_unit_test(test_a_host_gives_up_its_own),
		cmocka_unit_test(test_same_host),
		cmocka_unit_test(test_unix_never_taken_over),
		cmocka_unit_test(test_unix_stale_replaced_and_foreign_kept),
	};

	return cmocka_run_group_tests(tests, NULL, NULL);
}
