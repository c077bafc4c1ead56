// SPDX-License-Identifier: MIT
/*
 * fake_usb.c - a simulated Polhemus Liberty HS behind libusb's interface
 * (see fake.h). Every libusb function the driver calls is defined here as
 * __wrap_NAME (libusb_error_name and libusb_strerror are not: they only
 * turn numbers into text and the real ones serve).
 *
 * The device obeys the Liberty's ASCII commands as docs/TRACKERS.md lists
 * them: P (no CR) stops continuous output; F1, U1, H*,x,y,z and O*,2,7,9,0
 * (each ending in CR) set binary output, centimetres, the hemisphere and
 * the output list the capture was made with; C starts continuous output,
 * but only once binary, centimetres and that output list have been asked
 * for since it was plugged in: a driver that skips a step gets nothing.
 */
#include "fake/fake.h"
#include "fake/player.h"

#include "trackers/capture.h"

#include <libusb-1.0/libusb.h>

#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define EP_OUT 0x04
#define EP_IN 0x88
#define MAX_EVENTS 32

struct libusb_context {
	libusb_hotplug_callback_fn cb;
	void *ud;
	int events;
	int pending[MAX_EVENTS];
	int n_pending;
	struct libusb_context *next;
};

struct libusb_device {
	unsigned gen;
	uint16_t pid;
	uint8_t addr;
};

struct libusb_device_handle {
	unsigned gen;
};

static struct {
	struct player p; /* the capture, its pace, injected transfers, the lock */
	bool plugged, hotplug_capable;
	unsigned gen;
	uint16_t pid;
	uint8_t addr;
	int deny;
	uint32_t frame;
	/* the device's command state */
	char line[128];
	size_t line_len;
	bool f1, u1, olist, streaming;
	/* faults */
	int split_at;
	uint8_t rest[4096];
	size_t rest_len;
	int halt_count;
	const struct libusb_device_handle *claimed; /* the handle holding interface 0 */
	struct fake_usb_stats st;
	struct libusb_context *ctxs;
} U = { .p = PLAYER_INIT };

static void note_cmd(const char *c)
{
	size_t n = strlen(U.st.commands);

	snprintf(U.st.commands + n, sizeof(U.st.commands) - n, "%s|", c);
}

static void queue_event(int ev)
{
	for (struct libusb_context *c = U.ctxs; c; c = c->next)
		if (c->cb && (c->events & ev) && c->n_pending < MAX_EVENTS)
			c->pending[c->n_pending++] = ev;
	player_wake_locked(&U.p);
}

void fake_usb_reset(const char *capture)
{
	pthread_mutex_lock(&U.p.mu);
	player_reset_locked(&U.p, capture, "fake_usb", 1000000 / 240);
	U.plugged = false;
	U.hotplug_capable = true;
	U.gen++;
	U.deny = 0;
	U.frame = 5000;
	U.line_len = 0;
	U.f1 = U.u1 = U.olist = U.streaming = false;
	U.split_at = 0;
	U.rest_len = 0;
	U.halt_count = 0;
	U.claimed = NULL;
	memset(&U.st, 0, sizeof(U.st));
	U.st.last_index = -1;
	player_wake_locked(&U.p);
	pthread_mutex_unlock(&U.p.mu);
}

void fake_usb_plug(uint16_t pid)
{
	pthread_mutex_lock(&U.p.mu);
	U.gen++;
	U.addr = (uint8_t)(U.addr % 120 + 2);
	U.pid = pid;
	U.claimed = NULL;
	U.plugged = true;
	/* powered up: no set-up, no output */
	U.f1 = U.u1 = U.olist = U.streaming = false;
	U.line_len = 0;
	U.rest_len = 0;
	U.halt_count = 0;
	queue_event(LIBUSB_HOTPLUG_EVENT_DEVICE_ARRIVED);
	pthread_mutex_unlock(&U.p.mu);
}

void fake_usb_unplug(void)
{
	pthread_mutex_lock(&U.p.mu);
	U.plugged = false;
	U.streaming = false;
	queue_event(LIBUSB_HOTPLUG_EVENT_DEVICE_LEFT);
	pthread_mutex_unlock(&U.p.mu);
}

void fake_usb_hotplug(bool capable)
{
	pthread_mutex_lock(&U.p.mu);
	U.hotplug_capable = capable;
	pthread_mutex_unlock(&U.p.mu);
}

void fake_usb_deny_open(int libusb_err)
{
	pthread_mutex_lock(&U.p.mu);
	U.deny = libusb_err;
	pthread_mutex_unlock(&U.p.mu);
}

void fake_usb_period_us(int us)
{
	player_period_us(&U.p, us);
}

void fake_usb_stepped(bool on)
{
	player_stepped(&U.p, on);
}

void fake_usb_release(int n)
{
	player_release(&U.p, n);
}

void fake_usb_seek(int index)
{
	player_seek(&U.p, index);
}

void fake_usb_inject(const uint8_t *bytes, size_t len)
{
	player_inject(&U.p, bytes, len);
}

void fake_usb_split(int at)
{
	pthread_mutex_lock(&U.p.mu);
	U.split_at = at;
	pthread_mutex_unlock(&U.p.mu);
}

void fake_usb_skip(int n)
{
	pthread_mutex_lock(&U.p.mu);
	U.frame += (uint32_t)n;
	for (int i = 0; i < n; i++)
		player_advance_locked(&U.p);
	pthread_mutex_unlock(&U.p.mu);
}

void fake_usb_stop_streaming(void)
{
	pthread_mutex_lock(&U.p.mu);
	U.streaming = false;
	pthread_mutex_unlock(&U.p.mu);
}

void fake_usb_halt(int times)
{
	pthread_mutex_lock(&U.p.mu);
	U.halt_count = times;
	player_wake_locked(&U.p);
	pthread_mutex_unlock(&U.p.mu);
}

void fake_usb_stats(struct fake_usb_stats *s)
{
	pthread_mutex_lock(&U.p.mu);
	*s = U.st;
	pthread_mutex_unlock(&U.p.mu);
}

const uint8_t *fake_usb_capture_frame(int i, size_t *len)
{
	return player_report(&U.p, i, len);
}

int fake_usb_capture_count(void)
{
	return U.p.cap.n;
}

/* ---- the device's side of the wire ------------------------------------------------------------ */

static void command(const char *c)
{
	note_cmd(c);
	if (!strcmp(c, "F1"))
		U.f1 = true;
	else if (!strcmp(c, "F0"))
		U.f1 = false;
	else if (!strcmp(c, "U1"))
		U.u1 = true;
	else if (!strcmp(c, "U0"))
		U.u1 = false;
	else if (!strncmp(c, "O*,", 3))
		U.olist = !strcmp(c, "O*,2,7,9,0");
	else if (!strcmp(c, "C") && U.f1 && U.u1 && U.olist) {
		U.streaming = true;
		U.p.next_due = player_now_ns();
		U.st.setups++;
		player_wake_locked(&U.p);
	}
}

static void device_out(const unsigned char *d, int len)
{
	for (int i = 0; i < len; i++) {
		if (d[i] == 'P' && !U.line_len) {
			/* P needs no CR: one record, and the end of continuous output */
			U.streaming = false;
			U.rest_len = 0;
			note_cmd("P");
			continue;
		}
		if (d[i] == '\r') {
			U.line[U.line_len] = '\0';
			command(U.line);
			U.line_len = 0;
		} else if (U.line_len < sizeof(U.line) - 1) {
			U.line[U.line_len++] = (char)d[i];
		}
	}
}

/* the next frame (one transfer), its records' frame counts the device's own */
static int next_frame(unsigned char *out, int len)
{
	const struct capture_report *r = &U.p.cap.rep[U.p.idx];
	uint8_t f[4096];
	int n = r->len, first;

	memcpy(f, U.p.cap.bytes + r->off, (size_t)n);
	for (int k = 0; k + 41 <= n; k += 41) {
		f[k + 36] = (uint8_t)U.frame;
		f[k + 37] = (uint8_t)(U.frame >> 8);
		f[k + 38] = (uint8_t)(U.frame >> 16);
		f[k + 39] = (uint8_t)(U.frame >> 24);
	}
	U.frame++;
	U.st.frames++;
	U.st.last_index = U.p.idx;
	player_advance_locked(&U.p);
	first = U.split_at > 0 && U.split_at < n ? U.split_at : n;
	if (first > len)
		first = len;
	memcpy(out, f, (size_t)first);
	U.rest_len = (size_t)(n - first);
	memcpy(U.rest, f + first, U.rest_len);
	return first;
}

static bool alive(const struct libusb_device_handle *h)
{
	return U.plugged && h->gen == U.gen;
}

/* ---- libusb ----------------------------------------------------------------------------- */

int __wrap_libusb_init(libusb_context **ctx);
void __wrap_libusb_exit(libusb_context *ctx);
int __wrap_libusb_has_capability(uint32_t cap);
int __wrap_libusb_hotplug_register_callback(libusb_context *ctx, int events, int flags, int vid, int pid, int cls,
					    libusb_hotplug_callback_fn cb, void *ud, libusb_hotplug_callback_handle *h);
void __wrap_libusb_hotplug_deregister_callback(libusb_context *ctx, libusb_hotplug_callback_handle h);
int __wrap_libusb_handle_events_timeout_completed(libusb_context *ctx, struct timeval *tv, int *completed);
ssize_t __wrap_libusb_get_device_list(libusb_context *ctx, libusb_device ***list);
void __wrap_libusb_free_device_list(libusb_device **list, int unref);
int __wrap_libusb_get_device_descriptor(libusb_device *dev, struct libusb_device_descriptor *d);
uint8_t __wrap_libusb_get_bus_number(libusb_device *dev);
uint8_t __wrap_libusb_get_device_address(libusb_device *dev);
int __wrap_libusb_get_port_numbers(libusb_device *dev, uint8_t *ports, int len);
int __wrap_libusb_get_active_config_descriptor(libusb_device *dev, struct libusb_config_descriptor **cfg);
void __wrap_libusb_free_config_descriptor(struct libusb_config_descriptor *cfg);
int __wrap_libusb_open(libusb_device *dev, libusb_device_handle **h);
void __wrap_libusb_close(libusb_device_handle *h);
int __wrap_libusb_set_auto_detach_kernel_driver(libusb_device_handle *h, int enable);
int __wrap_libusb_set_configuration(libusb_device_handle *h, int c);
int __wrap_libusb_claim_interface(libusb_device_handle *h, int i);
int __wrap_libusb_release_interface(libusb_device_handle *h, int i);
int __wrap_libusb_clear_halt(libusb_device_handle *h, unsigned char ep);
int __wrap_libusb_bulk_transfer(libusb_device_handle *h, unsigned char ep, unsigned char *data, int len, int *got,
				unsigned int timeout);

int __wrap_libusb_init(libusb_context **ctx)
{
	struct libusb_context *c = calloc(1, sizeof(*c));

	pthread_mutex_lock(&U.p.mu);
	c->next = U.ctxs;
	U.ctxs = c;
	pthread_mutex_unlock(&U.p.mu);
	*ctx = c;
	return 0;
}

void __wrap_libusb_exit(libusb_context *ctx)
{
	pthread_mutex_lock(&U.p.mu);
	for (struct libusb_context **p = &U.ctxs; *p; p = &(*p)->next)
		if (*p == ctx) {
			*p = ctx->next;
			break;
		}
	pthread_mutex_unlock(&U.p.mu);
	free(ctx);
}

int __wrap_libusb_has_capability(uint32_t cap)
{
	int rc;

	pthread_mutex_lock(&U.p.mu);
	rc = cap == LIBUSB_CAP_HAS_HOTPLUG ? U.hotplug_capable : 0;
	pthread_mutex_unlock(&U.p.mu);
	return rc;
}

int __wrap_libusb_hotplug_register_callback(libusb_context *ctx, int events, int flags, int vid, int pid, int cls,
					    libusb_hotplug_callback_fn cb, void *ud, libusb_hotplug_callback_handle *h)
{
	(void)flags;
	(void)cls;
	pthread_mutex_lock(&U.p.mu);
	if (vid == 0x0f44 && pid == LIBUSB_HOTPLUG_MATCH_ANY) {
		ctx->cb = cb;
		ctx->ud = ud;
		ctx->events = events;
		U.st.hotplug_registered++;
	}
	pthread_mutex_unlock(&U.p.mu);
	*h = 1;
	return 0;
}

void __wrap_libusb_hotplug_deregister_callback(libusb_context *ctx, libusb_hotplug_callback_handle h)
{
	(void)h;
	pthread_mutex_lock(&U.p.mu);
	ctx->cb = NULL;
	ctx->n_pending = 0;
	pthread_mutex_unlock(&U.p.mu);
}

int __wrap_libusb_handle_events_timeout_completed(libusb_context *ctx, struct timeval *tv, int *completed)
{
	uint64_t end = player_now_ns() + (uint64_t)tv->tv_sec * 1000000000ull + (uint64_t)tv->tv_usec * 1000ull;
	int ev[MAX_EVENTS], n;
	struct libusb_device dev;

	(void)completed;
	pthread_mutex_lock(&U.p.mu);
	while (!ctx->n_pending && player_now_ns() < end)
		player_wait_until_locked(&U.p, end);
	n = ctx->n_pending;
	memcpy(ev, ctx->pending, sizeof(int) * (size_t)n);
	ctx->n_pending = 0;
	dev = (struct libusb_device){ U.gen, U.pid, U.addr };
	U.st.hotplug_callbacks += n;
	pthread_mutex_unlock(&U.p.mu);
	/* as libusb does: callbacks run from the event handler, outside any lock of ours */
	for (int i = 0; i < n; i++)
		if (ctx->cb)
			ctx->cb(ctx, &dev, (libusb_hotplug_event)ev[i], ctx->ud);
	return 0;
}

ssize_t __wrap_libusb_get_device_list(libusb_context *ctx, libusb_device ***list)
{
	ssize_t n = 0;

	(void)ctx;
	pthread_mutex_lock(&U.p.mu);
	U.st.enumerations++;
	*list = calloc(2, sizeof(**list));
	if (U.plugged) {
		struct libusb_device *d = malloc(sizeof(*d));

		*d = (struct libusb_device){ U.gen, U.pid, U.addr };
		(*list)[n++] = d;
	}
	pthread_mutex_unlock(&U.p.mu);
	return n;
}

void __wrap_libusb_free_device_list(libusb_device **list, int unref)
{
	for (int i = 0; unref && list[i]; i++)
		free(list[i]);
	free(list);
}

int __wrap_libusb_get_device_descriptor(libusb_device *dev, struct libusb_device_descriptor *d)
{
	memset(d, 0, sizeof(*d));
	d->bLength = LIBUSB_DT_DEVICE_SIZE;
	d->bDescriptorType = LIBUSB_DT_DEVICE;
	d->bcdUSB = 0x0200;
	d->bMaxPacketSize0 = 64;
	d->idVendor = 0x0f44;
	d->idProduct = dev->pid;
	d->bNumConfigurations = 1;
	return 0;
}

uint8_t __wrap_libusb_get_bus_number(libusb_device *dev)
{
	(void)dev;
	return 1;
}

uint8_t __wrap_libusb_get_device_address(libusb_device *dev)
{
	return dev->addr;
}

int __wrap_libusb_get_port_numbers(libusb_device *dev, uint8_t *ports, int len)
{
	(void)dev;
	if (len < 1)
		return LIBUSB_ERROR_OVERFLOW;
	ports[0] = 4;
	return 1;
}

struct fake_config {
	struct libusb_config_descriptor c; /* first: freeing it frees the lot */
	struct libusb_interface itf;
	struct libusb_interface_descriptor alt;
	struct libusb_endpoint_descriptor ep[2];
};

int __wrap_libusb_get_active_config_descriptor(libusb_device *dev, struct libusb_config_descriptor **cfg)
{
	struct fake_config *f = calloc(1, sizeof(*f));

	(void)dev;
	/* the Liberty HS: vendor class, one interface, bulk OUT 0x04 and IN 0x88, 512-byte packets */
	f->ep[0] = (struct libusb_endpoint_descriptor){ .bLength = LIBUSB_DT_ENDPOINT_SIZE,
							.bDescriptorType = LIBUSB_DT_ENDPOINT,
							.bEndpointAddress = EP_OUT,
							.bmAttributes = LIBUSB_TRANSFER_TYPE_BULK,
							.wMaxPacketSize = 512 };
	f->ep[1] = f->ep[0];
	f->ep[1].bEndpointAddress = EP_IN;
	f->alt.bLength = LIBUSB_DT_INTERFACE_SIZE;
	f->alt.bDescriptorType = LIBUSB_DT_INTERFACE;
	f->alt.bNumEndpoints = 2;
	f->alt.bInterfaceClass = LIBUSB_CLASS_VENDOR_SPEC;
	f->alt.endpoint = f->ep;
	f->itf.altsetting = &f->alt;
	f->itf.num_altsetting = 1;
	f->c.bLength = LIBUSB_DT_CONFIG_SIZE;
	f->c.bDescriptorType = LIBUSB_DT_CONFIG;
	f->c.bNumInterfaces = 1;
	f->c.bConfigurationValue = 1;
	f->c.interface = &f->itf;
	*cfg = &f->c;
	return 0;
}

void __wrap_libusb_free_config_descriptor(struct libusb_config_descriptor *cfg)
{
	free(cfg);
}

int __wrap_libusb_open(libusb_device *dev, libusb_device_handle **h)
{
	int rc = 0;

	pthread_mutex_lock(&U.p.mu);
	if (!U.plugged || dev->gen != U.gen)
		rc = LIBUSB_ERROR_NO_DEVICE;
	else if (U.deny)
		rc = U.deny;
	if (!rc) {
		*h = malloc(sizeof(**h));
		(*h)->gen = U.gen;
		U.st.opens++;
	}
	pthread_mutex_unlock(&U.p.mu);
	return rc;
}

void __wrap_libusb_close(libusb_device_handle *h)
{
	pthread_mutex_lock(&U.p.mu);
	U.st.closes++;
	if (U.claimed == h)
		U.claimed = NULL;
	pthread_mutex_unlock(&U.p.mu);
	free(h);
}

int __wrap_libusb_set_auto_detach_kernel_driver(libusb_device_handle *h, int enable)
{
	(void)h;
	(void)enable;
	return 0;
}

int __wrap_libusb_set_configuration(libusb_device_handle *h, int c)
{
	int rc;

	pthread_mutex_lock(&U.p.mu);
	rc = !alive(h) ? LIBUSB_ERROR_NO_DEVICE : c == 1 ? 0 : LIBUSB_ERROR_NOT_FOUND;
	pthread_mutex_unlock(&U.p.mu);
	return rc;
}

int __wrap_libusb_claim_interface(libusb_device_handle *h, int i)
{
	int rc;

	pthread_mutex_lock(&U.p.mu);
	rc = !alive(h) ? LIBUSB_ERROR_NO_DEVICE : i == 0 ? 0 : LIBUSB_ERROR_NOT_FOUND;
	/* one claim at a time, as the kernel's usbfs does */
	if (!rc && U.claimed && U.claimed != h)
		rc = LIBUSB_ERROR_BUSY;
	if (!rc) {
		U.claimed = h;
		U.st.claims++;
	}
	pthread_mutex_unlock(&U.p.mu);
	return rc;
}

int __wrap_libusb_release_interface(libusb_device_handle *h, int i)
{
	(void)i;
	pthread_mutex_lock(&U.p.mu);
	if (U.claimed == h)
		U.claimed = NULL;
	pthread_mutex_unlock(&U.p.mu);
	return 0;
}

int __wrap_libusb_clear_halt(libusb_device_handle *h, unsigned char ep)
{
	int rc = 0;

	pthread_mutex_lock(&U.p.mu);
	if (!alive(h))
		rc = LIBUSB_ERROR_NO_DEVICE;
	else if (ep == EP_IN) {
		U.st.clear_halts++;
		if (U.halt_count > 0)
			U.halt_count--;
	}
	pthread_mutex_unlock(&U.p.mu);
	return rc;
}

int __wrap_libusb_bulk_transfer(libusb_device_handle *h, unsigned char ep, unsigned char *data, int len, int *got,
				unsigned int timeout)
{
	uint64_t deadline = player_now_ns() + (uint64_t)timeout * 1000000ull;
	int rc = LIBUSB_ERROR_TIMEOUT;

	*got = 0;
	pthread_mutex_lock(&U.p.mu);
	if (!alive(h)) {
		rc = LIBUSB_ERROR_NO_DEVICE;
		goto out;
	}
	if (ep == EP_OUT) {
		if (!len)
			U.st.zlp++;
		device_out(data, len);
		*got = len;
		rc = 0;
		goto out;
	}
	if (ep != EP_IN) {
		rc = LIBUSB_ERROR_PIPE; /* no such endpoint: the device stalls the request */
		goto out;
	}
	for (;;) {
		uint64_t now = player_now_ns(), wake_at = deadline;

		if (!alive(h)) {
			rc = LIBUSB_ERROR_NO_DEVICE;
			break;
		}
		if (U.halt_count > 0) {
			rc = LIBUSB_ERROR_PIPE;
			break;
		}
		if (U.rest_len) {
			size_t n = U.rest_len < (size_t)len ? U.rest_len : (size_t)len;

			memcpy(data, U.rest, n);
			memmove(U.rest, U.rest + n, U.rest_len - n);
			U.rest_len -= n;
			*got = (int)n;
			rc = 0;
			break;
		}
		if ((*got = player_take_injected_locked(&U.p, data, (size_t)len)) >= 0) {
			rc = 0;
			break;
		}
		*got = 0;
		if (U.streaming && U.p.cap.n && player_due_locked(&U.p, now, &wake_at)) {
			*got = next_frame(data, len);
			rc = 0;
			break;
		}
		if (now >= deadline)
			break;
		player_wait_until_locked(&U.p, wake_at);
	}
out:
	pthread_mutex_unlock(&U.p.mu);
	return rc;
}
