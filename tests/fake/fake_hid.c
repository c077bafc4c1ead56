// SPDX-License-Identifier: MIT
/*
 * fake_hid.c - a simulated Razer Hydra behind hidapi's interface (see
 * fake.h). Every hidapi function the driver calls is defined here as
 * __wrap_NAME; the linker sends the driver's calls to these.
 */
#include "fake/fake.h"

#include "trackers/capture.h"

#include <hidapi/hidapi.h>

#include <errno.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <wchar.h>

struct hid_device_ {
	int iface;
	unsigned gen;
};

#define INJ_MAX 64

static struct {
	pthread_mutex_t mu;
	pthread_cond_t cv;
	bool init;
	struct capture cap;
	bool plugged, motion, ignore, stepped;
	unsigned gen;
	int deny;
	int period_us;
	long released;
	int idx, dir;
	uint8_t seq;
	uint64_t next_due, stall_until;
	uint8_t inj[INJ_MAX][128];
	size_t inj_len[INJ_MAX];
	int inj_head, inj_n;
	struct fake_hid_stats st;
} F = { .mu = PTHREAD_MUTEX_INITIALIZER };

static uint64_t now_ns(void)
{
	struct timespec ts;

	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (uint64_t)ts.tv_sec * 1000000000ull + (uint64_t)ts.tv_nsec;
}

static void wait_until(uint64_t t)
{
	struct timespec ts = { (time_t)(t / 1000000000ull), (long)(t % 1000000000ull) };

	pthread_cond_timedwait(&F.cv, &F.mu, &ts);
}

static void wake(void)
{
	pthread_cond_broadcast(&F.cv);
}

void fake_hid_reset(const char *capture)
{
	char err[256];

	pthread_mutex_lock(&F.mu);
	if (!F.init) {
		pthread_condattr_t ca;

		pthread_condattr_init(&ca);
		pthread_condattr_setclock(&ca, CLOCK_MONOTONIC);
		pthread_cond_init(&F.cv, &ca);
		pthread_condattr_destroy(&ca);
		F.init = true;
	}
	if (capture && !F.cap.n && capture_load(&F.cap, capture, err, sizeof(err))) {
		fprintf(stderr, "fake_hid: %s\n", err);
		abort();
	}
	F.plugged = F.motion = F.ignore = F.stepped = false;
	F.gen++;
	F.deny = 0;
	F.period_us = 4000;
	F.released = 0;
	F.idx = 0;
	F.dir = 1;
	F.seq = 0x10;
	F.next_due = F.stall_until = 0;
	F.inj_head = F.inj_n = 0;
	memset(&F.st, 0, sizeof(F.st));
	F.st.last_index = -1;
	wake();
	pthread_mutex_unlock(&F.mu);
}

void fake_hid_plug(bool motion_mode)
{
	pthread_mutex_lock(&F.mu);
	F.gen++;
	F.plugged = true;
	F.motion = motion_mode;
	F.next_due = now_ns();
	wake();
	pthread_mutex_unlock(&F.mu);
}

void fake_hid_unplug(void)
{
	pthread_mutex_lock(&F.mu);
	F.plugged = false;
	wake();
	pthread_mutex_unlock(&F.mu);
}

void fake_hid_ignore_requests(bool on)
{
	pthread_mutex_lock(&F.mu);
	F.ignore = on;
	pthread_mutex_unlock(&F.mu);
}

void fake_hid_set_mode(bool motion)
{
	pthread_mutex_lock(&F.mu);
	F.motion = motion;
	F.next_due = now_ns();
	wake();
	pthread_mutex_unlock(&F.mu);
}

void fake_hid_deny_open(int err)
{
	pthread_mutex_lock(&F.mu);
	F.deny = err;
	pthread_mutex_unlock(&F.mu);
}

void fake_hid_period_us(int us)
{
	pthread_mutex_lock(&F.mu);
	F.period_us = us;
	pthread_mutex_unlock(&F.mu);
}

void fake_hid_stepped(bool on)
{
	pthread_mutex_lock(&F.mu);
	F.stepped = on;
	F.released = 0;
	F.next_due = now_ns();
	wake();
	pthread_mutex_unlock(&F.mu);
}

void fake_hid_release(int n)
{
	pthread_mutex_lock(&F.mu);
	F.released += n;
	wake();
	pthread_mutex_unlock(&F.mu);
}

void fake_hid_seek(int index)
{
	pthread_mutex_lock(&F.mu);
	F.idx = index;
	F.dir = 1;
	pthread_mutex_unlock(&F.mu);
}

void fake_hid_inject(const uint8_t *rep, size_t len)
{
	pthread_mutex_lock(&F.mu);
	if (F.inj_n < INJ_MAX && len <= sizeof(F.inj[0])) {
		int k = (F.inj_head + F.inj_n++) % INJ_MAX;

		memcpy(F.inj[k], rep, len);
		F.inj_len[k] = len;
	}
	wake();
	pthread_mutex_unlock(&F.mu);
}

void fake_hid_skip(int n)
{
	pthread_mutex_lock(&F.mu);
	F.seq = (uint8_t)(F.seq + n);
	for (int i = 0; i < n; i++) {
		/* the reports that were lost still moved the wands */
		if (F.idx + F.dir < 0 || F.idx + F.dir >= F.cap.n)
			F.dir = -F.dir;
		F.idx += F.dir;
	}
	pthread_mutex_unlock(&F.mu);
}

void fake_hid_stall(int ms)
{
	pthread_mutex_lock(&F.mu);
	F.stall_until = now_ns() + (uint64_t)ms * 1000000ull;
	pthread_mutex_unlock(&F.mu);
}

void fake_hid_stats(struct fake_hid_stats *s)
{
	pthread_mutex_lock(&F.mu);
	*s = F.st;
	pthread_mutex_unlock(&F.mu);
}

const uint8_t *fake_hid_capture_report(int i, size_t *len)
{
	*len = F.cap.rep[i].len;
	return F.cap.bytes + F.cap.rep[i].off;
}

int fake_hid_capture_count(void)
{
	return F.cap.n;
}

/* ---- hidapi ------------------------------------------------------------------------- */

int __wrap_hid_init(void);
int __wrap_hid_exit(void);
struct hid_device_info *__wrap_hid_enumerate(unsigned short vid, unsigned short pid);
void __wrap_hid_free_enumeration(struct hid_device_info *devs);
hid_device *__wrap_hid_open_path(const char *path);
void __wrap_hid_close(hid_device *dev);
int __wrap_hid_read_timeout(hid_device *dev, unsigned char *data, size_t length, int ms);
int __wrap_hid_send_feature_report(hid_device *dev, const unsigned char *data, size_t length);
int __wrap_hid_get_feature_report(hid_device *dev, unsigned char *data, size_t length);
const wchar_t *__wrap_hid_error(hid_device *dev);

int __wrap_hid_init(void)
{
	return 0;
}

int __wrap_hid_exit(void)
{
	return 0;
}

static void node_path(char *buf, size_t len, unsigned gen, int iface)
{
	snprintf(buf, len, "/dev/fake-hidraw%u", gen * 2 + (unsigned)iface);
}

struct hid_device_info *__wrap_hid_enumerate(unsigned short vid, unsigned short pid)
{
	struct hid_device_info *head = NULL;

	pthread_mutex_lock(&F.mu);
	F.st.enumerations++;
	if (F.plugged && (!vid || vid == 0x1532) && (!pid || pid == 0x0300)) {
		for (int iface = 1; iface >= 0; iface--) {
			struct hid_device_info *i = calloc(1, sizeof(*i));
			char p[64];

			node_path(p, sizeof(p), F.gen, iface);
			i->path = strdup(p);
			i->vendor_id = 0x1532;
			i->product_id = 0x0300;
			i->interface_number = iface;
			i->usage_page = iface ? 0x01 : 0xff00;
			i->next = head;
			head = i;
		}
	}
	pthread_mutex_unlock(&F.mu);
	return head;
}

void __wrap_hid_free_enumeration(struct hid_device_info *devs)
{
	while (devs) {
		struct hid_device_info *n = devs->next;

		free(devs->path);
		free(devs);
		devs = n;
	}
}

hid_device *__wrap_hid_open_path(const char *path)
{
	hid_device *d = NULL;

	pthread_mutex_lock(&F.mu);
	for (int iface = 0; iface < 2 && F.plugged; iface++) {
		char p[64];

		node_path(p, sizeof(p), F.gen, iface);
		if (strcmp(p, path))
			continue;
		if (F.deny) {
			errno = F.deny;
			break;
		}
		d = malloc(sizeof(*d));
		d->iface = iface;
		d->gen = F.gen;
		F.st.opens++;
	}
	if (!d) {
		F.st.open_fails++;
		if (!F.deny)
			errno = ENOENT;
	}
	pthread_mutex_unlock(&F.mu);
	return d;
}

void __wrap_hid_close(hid_device *dev)
{
	pthread_mutex_lock(&F.mu);
	F.st.closes++;
	pthread_mutex_unlock(&F.mu);
	free(dev);
}

static bool alive(const hid_device *dev)
{
	return F.plugged && dev->gen == F.gen;
}

/* the next capture report into data, with the device's own sequence number */
static int deliver(unsigned char *data, size_t length)
{
	const struct capture_report *r = &F.cap.rep[F.idx];
	size_t n = r->len < length ? r->len : length;

	memcpy(data, F.cap.bytes + r->off, n);
	if (n > 29) {
		data[7] = F.seq;
		data[29] = F.seq;
	}
	F.seq++;
	F.st.delivered++;
	F.st.last_index = F.idx;
	/* forwards, then backwards: the wands never jump */
	if (F.idx + F.dir < 0 || F.idx + F.dir >= F.cap.n)
		F.dir = -F.dir;
	F.idx += F.dir;
	return (int)n;
}

int __wrap_hid_read_timeout(hid_device *dev, unsigned char *data, size_t length, int ms)
{
	uint64_t deadline = now_ns() + (uint64_t)(ms < 0 ? 3600000 : ms) * 1000000ull;
	int rc = 0;

	pthread_mutex_lock(&F.mu);
	for (;;) {
		uint64_t now = now_ns(), wake_at = deadline;

		if (!alive(dev)) {
			rc = -1;
			break;
		}
		if (dev->iface == 0 && F.inj_n) {
			size_t n = F.inj_len[F.inj_head] < length ? F.inj_len[F.inj_head] : length;

			memcpy(data, F.inj[F.inj_head], n);
			F.inj_head = (F.inj_head + 1) % INJ_MAX;
			F.inj_n--;
			rc = (int)n;
			break;
		}
		if (dev->iface == 0 && F.motion && F.cap.n && now >= F.stall_until) {
			if (F.stepped) {
				if (F.released > 0) {
					F.released--;
					rc = deliver(data, length);
					break;
				}
			} else if (now >= F.next_due) {
				F.next_due += (uint64_t)F.period_us * 1000ull;
				if (F.next_due + 100000000ull < now)
					F.next_due = now; /* after a long pause: no burst */
				rc = deliver(data, length);
				break;
			} else if (F.next_due < wake_at) {
				wake_at = F.next_due;
			}
		} else if (dev->iface == 0 && F.motion && now < F.stall_until && F.stall_until < wake_at) {
			wake_at = F.stall_until;
		}
		if (now >= deadline)
			break;
		wait_until(wake_at);
	}
	pthread_mutex_unlock(&F.mu);
	return rc;
}

static int request_kind(const unsigned char *d, size_t len)
{
	if (len != 91 || d[0] != 0 || d[6] != 0x01 || d[8] != 0x04)
		return 0;
	for (size_t i = 1; i < len; i++)
		if (i != 6 && i != 8 && i != 9 && i != 89 && d[i])
			return 0;
	if (d[9] == 0x03 && d[89] == 0x06)
		return 1;
	if (d[9] == 0x00 && d[89] == 0x05)
		return 2;
	return 0;
}

int __wrap_hid_send_feature_report(hid_device *dev, const unsigned char *data, size_t length)
{
	int rc = (int)length, kind;

	pthread_mutex_lock(&F.mu);
	if (!alive(dev)) {
		rc = -1;
		goto out;
	}
	kind = request_kind(data, length);
	if (!kind) {
		F.st.other_features++;
		goto out;
	}
	if (dev->iface != 1)
		F.st.wrong_node++;
	if (kind == 1) {
		F.st.motion_requests++;
		if (!F.ignore && !F.motion) {
			F.motion = true;
			F.next_due = now_ns();
		}
	} else {
		F.st.gamepad_requests++;
		if (!F.ignore)
			F.motion = false;
	}
	wake();
out:
	pthread_mutex_unlock(&F.mu);
	return rc;
}

int __wrap_hid_get_feature_report(hid_device *dev, unsigned char *data, size_t length)
{
	int rc = (int)length;

	pthread_mutex_lock(&F.mu);
	if (!alive(dev))
		rc = -1;
	else
		memset(data + 1, 0, length - 1);
	F.st.get_features++;
	pthread_mutex_unlock(&F.mu);
	return rc;
}

const wchar_t *__wrap_hid_error(hid_device *dev)
{
	(void)dev;
	return F.plugged ? L"fake hidapi: input/output error" : L"fake hidapi: device disconnected";
}
