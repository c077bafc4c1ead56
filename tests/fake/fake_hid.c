// SPDX-License-Identifier: MIT
/*
 * fake_hid.c - a simulated Razer Hydra behind hidapi's interface (see
 * fake.h). Every hidapi function the driver calls is defined here as
 * __wrap_NAME; the linker sends the driver's calls to these.
 */
#include "fake/fake.h"
#include "fake/player.h"

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

static struct {
	struct player p; /* the capture, its pace, injected reports, the lock */
	bool plugged, motion, ignore;
	unsigned gen;
	int deny;
	uint8_t seq;
	char damage[64]; /* what happens to the next reports, a letter each (fake_hid_damage) */
	int damage_at;
	uint64_t stall_until;
	struct fake_hid_stats st;
} F = { .p = PLAYER_INIT };

void fake_hid_reset(const char *capture)
{
	pthread_mutex_lock(&F.p.mu);
	player_reset_locked(&F.p, capture, "fake_hid", 4000);
	F.plugged = F.motion = F.ignore = false;
	F.gen++;
	F.deny = 0;
	F.seq = 0x10;
	F.damage[0] = '\0';
	F.damage_at = 0;
	F.stall_until = 0;
	memset(&F.st, 0, sizeof(F.st));
	F.st.last_index = -1;
	player_wake_locked(&F.p);
	pthread_mutex_unlock(&F.p.mu);
}

void fake_hid_plug(bool motion_mode)
{
	pthread_mutex_lock(&F.p.mu);
	F.gen++;
	F.plugged = true;
	F.motion = motion_mode;
	F.p.next_due = player_now_ns();
	player_wake_locked(&F.p);
	pthread_mutex_unlock(&F.p.mu);
}

void fake_hid_unplug(void)
{
	pthread_mutex_lock(&F.p.mu);
	F.plugged = false;
	player_wake_locked(&F.p);
	pthread_mutex_unlock(&F.p.mu);
}

void fake_hid_ignore_requests(bool on)
{
	pthread_mutex_lock(&F.p.mu);
	F.ignore = on;
	pthread_mutex_unlock(&F.p.mu);
}

void fake_hid_set_mode(bool motion)
{
	pthread_mutex_lock(&F.p.mu);
	F.motion = motion;
	F.p.next_due = player_now_ns();
	player_wake_locked(&F.p);
	pthread_mutex_unlock(&F.p.mu);
}

void fake_hid_deny_open(int err)
{
	pthread_mutex_lock(&F.p.mu);
	F.deny = err;
	pthread_mutex_unlock(&F.p.mu);
}

void fake_hid_period_us(int us)
{
	player_period_us(&F.p, us);
}

void fake_hid_stepped(bool on)
{
	player_stepped(&F.p, on);
}

void fake_hid_release(int n)
{
	player_release(&F.p, n);
}

void fake_hid_seek(int index)
{
	player_seek(&F.p, index);
}

void fake_hid_inject(const uint8_t *rep, size_t len)
{
	player_inject(&F.p, rep, len);
}

void fake_hid_skip(int n)
{
	pthread_mutex_lock(&F.p.mu);
	F.seq = (uint8_t)(F.seq + n);
	for (int i = 0; i < n; i++)
		player_advance_locked(&F.p); /* the reports that were lost still moved the wands */
	pthread_mutex_unlock(&F.p.mu);
}

void fake_hid_damage(const char *script)
{
	pthread_mutex_lock(&F.p.mu);
	snprintf(F.damage, sizeof(F.damage), "%s", script);
	F.damage_at = 0;
	pthread_mutex_unlock(&F.p.mu);
}

void fake_hid_stall(int ms)
{
	pthread_mutex_lock(&F.p.mu);
	F.stall_until = player_now_ns() + (uint64_t)ms * 1000000ull;
	pthread_mutex_unlock(&F.p.mu);
}

void fake_hid_stats(struct fake_hid_stats *s)
{
	pthread_mutex_lock(&F.p.mu);
	*s = F.st;
	pthread_mutex_unlock(&F.p.mu);
}

const uint8_t *fake_hid_capture_report(int i, size_t *len)
{
	return player_report(&F.p, i, len);
}

int fake_hid_capture_count(void)
{
	return F.p.cap.n;
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

	pthread_mutex_lock(&F.p.mu);
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
	pthread_mutex_unlock(&F.p.mu);
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

	pthread_mutex_lock(&F.p.mu);
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
	pthread_mutex_unlock(&F.p.mu);
	return d;
}

void __wrap_hid_close(hid_device *dev)
{
	pthread_mutex_lock(&F.p.mu);
	F.st.closes++;
	pthread_mutex_unlock(&F.p.mu);
	free(dev);
}

static bool alive(const hid_device *dev)
{
	return F.plugged && dev->gen == F.gen;
}

static char next_damage(void)
{
	return F.damage[F.damage_at] ? F.damage[F.damage_at++] : '.';
}

/* the next capture report into data, with the device's own sequence number (and the damage asked for) */
static int deliver(unsigned char *data, size_t length)
{
	const struct capture_report *r;
	size_t n;
	char damage = next_damage();

	for (; damage == 'L'; damage = next_damage()) {
		F.seq++;
		player_advance_locked(&F.p);
	}
	r = &F.p.cap.rep[F.p.idx];
	n = r->len < length ? r->len : length;
	memcpy(data, F.p.cap.bytes + r->off, n);
	/* a short report: it bears no number, and this one is sent next */
	if (damage == 'S')
		return n < 12 ? (int)n : 12;
	if (n > 29) {
		data[7] = F.seq;
		data[29] = F.seq;
	}
	if (damage == 'J' && n >= 52) {
		/* the left wand's x 30 m away: a jump no hand makes */
		data[8] = 30000 & 0xff;
		data[9] = 30000 >> 8;
	}
	if (damage == 'Q' && n >= 52)
		memset(data + 8 + 6, 0, 8); /* the left wand's quaternion zero */
	F.seq++;
	F.st.delivered++;
	F.st.last_index = F.p.idx;
	player_advance_locked(&F.p); /* forwards, then backwards: the wands never jump */
	return (int)n;
}

int __wrap_hid_read_timeout(hid_device *dev, unsigned char *data, size_t length, int ms)
{
	uint64_t deadline = player_now_ns() + (uint64_t)(ms < 0 ? 3600000 : ms) * 1000000ull;
	int rc = 0;

	pthread_mutex_lock(&F.p.mu);
	for (;;) {
		uint64_t now = player_now_ns(), wake_at = deadline;

		if (!alive(dev)) {
			rc = -1;
			break;
		}
		if (dev->iface == 0 && (rc = player_take_injected_locked(&F.p, data, length)) >= 0)
			break;
		rc = 0;
		if (dev->iface == 0 && F.motion && F.p.cap.n && now >= F.stall_until) {
			if (player_due_locked(&F.p, now, &wake_at)) {
				rc = deliver(data, length);
				break;
			}
		} else if (dev->iface == 0 && F.motion && now < F.stall_until && F.stall_until < wake_at) {
			wake_at = F.stall_until;
		}
		if (now >= deadline)
			break;
		player_wait_until_locked(&F.p, wake_at);
	}
	pthread_mutex_unlock(&F.p.mu);
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

	pthread_mutex_lock(&F.p.mu);
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
			F.p.next_due = player_now_ns();
		}
	} else {
		F.st.gamepad_requests++;
		if (!F.ignore)
			F.motion = false;
	}
	player_wake_locked(&F.p);
out:
	pthread_mutex_unlock(&F.p.mu);
	return rc;
}

int __wrap_hid_get_feature_report(hid_device *dev, unsigned char *data, size_t length)
{
	int rc = (int)length;

	pthread_mutex_lock(&F.p.mu);
	if (!alive(dev))
		rc = -1;
	else
		memset(data + 1, 0, length - 1);
	F.st.get_features++;
	pthread_mutex_unlock(&F.p.mu);
	return rc;
}

const wchar_t *__wrap_hid_error(hid_device *dev)
{
	(void)dev;
	return F.plugged ? L"fake hidapi: input/output error" : L"fake hidapi: device disconnected";
}
