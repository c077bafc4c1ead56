// SPDX-License-Identifier: MIT
/*
 * polhemus.c - Polhemus Liberty, Liberty HS (also sold as Latus) and
 * Patriot: magnetic 6-DOF trackers with up to 16 sensors (stations) on one
 * source, over vendor-specific USB bulk endpoints through libusb.
 *
 * The facts (docs/TRACKERS.md, ../shared/protocols/trackers.md section 2):
 * commands are ASCII lines ending in CR; the driver stops any output (P),
 * drains what is in flight, asks for binary output (F1), centimetres (U1),
 * the sensors' hemisphere (H*,x,y,z), the output list position +
 * quaternion + frame count + space (O*,2,7,9,0), then continuous output
 * (C). Each station then sends a 41-byte record per frame: 'L' 'Y' (or
 * "LU" Latus, "PA" Patriot), the station number (binary, from 1), the
 * command that made it ('C'), an error byte (a space when fine), a
 * reserved byte, the payload size (uint16 LE, 33), then float32 LE x y z
 * (cm), w x y z, the uint32 frame count and a space. Records arrive
 * back to back in transfers of any size: they are reassembled from the
 * byte stream, and a stream that loses its framing (garbage, a record
 * that fails its checks) is resynchronised on the next header.
 *
 * Frames: the source's +z points down. Our tracker frame is the source's
 * turned 180 degrees about x (z up): p = (x, -y, -z) / 100, q = Rx(180) *
 * q. Station k feeds the k-th name of `sensors`.
 *
 * Liberty and Patriot have no firmware of their own: they enumerate with
 * one product id, wait for fxload to send their firmware, and come back
 * with another. A device still at the first id gets a message naming
 * fxload and the udev rule, and the driver waits for the second id.
 *
 * The device thread: libusb hot-plug events (where the platform has them)
 * wake the search at once; the search also runs every search_ms. Then:
 * claim interface 0, find the bulk endpoints, set up, stream with 100 ms
 * reads. NO_DEVICE is an unplug (close, FAULTY, search); a halted
 * endpoint (PIPE) is cleared, and after pipe_limit in a row the device is
 * reopened; no record for stall_ms means set up again, and after restarts
 * set-ups without a record the device is closed and reopened.
 */
#include "trackers/polhemus.h"

#include "trackers/device.h"

#include <libusb-1.0/libusb.h>

#include <errno.h>
#include <math.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>
#include <syslog.h>

static const char *const e_model[] = { "auto", "liberty", "liberty_hs", "patriot", "patriot_hs", NULL };

static const struct cfg_key polhemus_keys[] = {
	{ .name = "model",
	  .kind = CFG_ENUM,
	  CFG_AT(struct polhemus_opts, model),
	  .def = "auto",
	  .enums = e_model,
	  .doc = "which Polhemus product to open: auto (any of them) or one; it sets the expected record header "
		 "and rate" },
	{ .name = "sensors",
	  .kind = CFG_NAMES,
	  CFG_AT(struct polhemus_opts, stations),
	  .min = 1,
	  .max = CFG_MAX_STATIONS,
	  .def = "head left_hand right_hand",
	  .doc = "sensor names of stations 1, 2, 3, ... in order (- skips a station)" },
	{ .name = "hemisphere",
	  .kind = CFG_VEC3,
	  CFG_AT(struct polhemus_opts, hemisphere),
	  .min = -1,
	  .max = 1,
	  .def = "1 0 0",
	  .doc = "the hemisphere the sensors stay in, a vector in the Polhemus source's frame (its H command)" },
};

static const struct polhemus_opts *opts_of(const struct cfg_source *c)
{
	return c->opt;
}

struct polhemus_timing polhemus_timing = {
	.drain_ms = 50, /* what the Polhemus drivers use */
	.stall_ms = 500,
	.search_ms = 200,
	.restarts = 2,
	.pipe_limit = 3,
};

static const struct polhemus_product products[] = {
	{ 0xff11, "Liberty", CFG_PH_LIBERTY, true, 0xff12, "-t fx -I LbtyUsb.hex -s a3load.hex", 240, 0, 0 },
	{ 0xff12, "Liberty", CFG_PH_LIBERTY, false, 0, NULL, 240, 0x02, 0x82 },
	{ 0xff21, "Liberty HS", CFG_PH_LIBERTY_HS, true, 0xff20, "-t fx2 -I LbtyUsbHS.hex -s a3load.hex", 240, 0, 0 },
	{ 0xff20, "Liberty HS", CFG_PH_LIBERTY_HS, false, 0, NULL, 240, 0x04, 0x88 },
	{ 0xef11, "Patriot", CFG_PH_PATRIOT, true, 0xef12, "-t fx -I PatriotUSB.hex", 60, 0, 0 },
	{ 0xef12, "Patriot", CFG_PH_PATRIOT, false, 0, NULL, 60, 0x02, 0x82 },
	{ 0xef21, "Patriot HS", CFG_PH_PATRIOT_HS, true, 0xef20, "-t fx2 -I PatriotUSB2.hex", 60, 0, 0 },
	{ 0xef20, "Patriot HS", CFG_PH_PATRIOT_HS, false, 0, NULL, 60, 0, 0 },
};

static const char *const model_names[] = { "auto", "liberty", "liberty_hs", "patriot", "patriot_hs" };

const struct polhemus_product *polhemus_product(uint16_t pid)
{
	for (size_t i = 0; i < sizeof(products) / sizeof(products[0]); i++)
		if (products[i].pid == pid)
			return &products[i];
	return NULL;
}

/* ---- sensors --------------------------------------------------------------------------- */

/* station (1-based) -> sensor index or -1, from `sensors`; returns the number of sensors */
static int station_map(const struct cfg_source *cfg, int map[CFG_MAX_STATIONS + 1], char names[][CFG_NAME_MAX])
{
	char buf[CFG_PATH_MAX], *save, *tok;
	int st = 1, n = 0;

	for (int i = 0; i <= CFG_MAX_STATIONS; i++)
		map[i] = -1;
	snprintf(buf, sizeof(buf), "%s", opts_of(cfg)->stations);
	for (tok = strtok_r(buf, " \t,", &save); tok && st <= CFG_MAX_STATIONS;
	     tok = strtok_r(NULL, " \t,", &save), st++) {
		if (!strcmp(tok, "-"))
			continue;
		if (names)
			snprintf(names[n], CFG_NAME_MAX, "%s", tok);
		map[st] = n++;
	}
	return n;
}

static int polhemus_sensor_count(const struct cfg_source *cfg)
{
	int map[CFG_MAX_STATIONS + 1];

	return station_map(cfg, map, NULL);
}

static void polhemus_sensor_name(const struct cfg_source *cfg, int i, char *buf, size_t len)
{
	int map[CFG_MAX_STATIONS + 1];
	char names[CFG_MAX_STATIONS][CFG_NAME_MAX];
	int n = station_map(cfg, map, names);

	snprintf(buf, len, "%s", i < n ? names[i] : "?");
}

/* ---- the codec ---------------------------------------------------------------------- */

#define POLHEMUS_BUF 8192

struct polhemus_codec_st {
	struct device_counts c;
	int sensor_of[CFG_MAX_STATIONS + 1];
	char magic[3][2];
	int n_magic;
	double period;
	bool in_sync;
	bool have_frame[CFG_MAX_STATIONS + 1];
	uint32_t frame[CFG_MAX_STATIONS + 1];
	uint64_t error_records; /* records whose error byte was not a space */
	uint8_t last_error;
	uint64_t skipped; /* bytes dropped while looking for a header */
	size_t len;
	uint8_t buf[POLHEMUS_BUF];
};

static int polhemus_codec_init(void *st, const struct cfg_source *cfg, char *err, size_t errlen)
{
	struct polhemus_codec_st *p = st;

	(void)err;
	(void)errlen;
	memset(p, 0, sizeof(*p));
	station_map(cfg, p->sensor_of, NULL);
	/* the record header names the product: accept only the configured one's */
	if (opts_of(cfg)->model == CFG_PH_AUTO || opts_of(cfg)->model == CFG_PH_LIBERTY ||
	    opts_of(cfg)->model == CFG_PH_LIBERTY_HS)
		memcpy(p->magic[p->n_magic++], "LY", 2);
	if (opts_of(cfg)->model == CFG_PH_AUTO || opts_of(cfg)->model == CFG_PH_LIBERTY_HS)
		memcpy(p->magic[p->n_magic++], "LU", 2);
	if (opts_of(cfg)->model == CFG_PH_AUTO || opts_of(cfg)->model == CFG_PH_PATRIOT ||
	    opts_of(cfg)->model == CFG_PH_PATRIOT_HS)
		memcpy(p->magic[p->n_magic++], "PA", 2);
	p->period = opts_of(cfg)->model == CFG_PH_PATRIOT || opts_of(cfg)->model == CFG_PH_PATRIOT_HS ? 1.0 / 60
												      : 1.0 / 240;
	p->in_sync = true;
	return 0;
}

static void polhemus_codec_reset(void *st)
{
	struct polhemus_codec_st *p = st;

	p->len = 0;
	p->in_sync = true;
	memset(p->have_frame, 0, sizeof(p->have_frame));
}

static double polhemus_period(const void *st)
{
	return ((const struct polhemus_codec_st *)st)->period;
}

static bool is_magic(const struct polhemus_codec_st *p, const uint8_t *r)
{
	for (int i = 0; i < p->n_magic; i++)
		if (r[0] == (uint8_t)p->magic[i][0] && r[1] == (uint8_t)p->magic[i][1])
			return true;
	return false;
}

static float lef(const uint8_t *b)
{
	uint32_t v = (uint32_t)b[0] | (uint32_t)b[1] << 8 | (uint32_t)b[2] << 16 | (uint32_t)b[3] << 24;
	float f;

	memcpy(&f, &v, sizeof(f));
	return f;
}

static uint32_t le32(const uint8_t *b)
{
	return (uint32_t)b[0] | (uint32_t)b[1] << 8 | (uint32_t)b[2] << 16 | (uint32_t)b[3] << 24;
}

/* the framing is lost: counted once, until a good record comes again */
static void lose_sync(struct polhemus_codec_st *p)
{
	if (p->in_sync) {
		p->in_sync = false;
		p->c.resyncs++;
		p->c.malformed++;
	}
}

/* one P&O record's payload; false if it is not a pose */
static bool decode_pose(const uint8_t *pl, struct device_sample *s)
{
	float v[7];
	struct quat qp, qn, qt;
	const struct quat flip = { 0, 1, 0, 0 }; /* Rx(180): the source's z points down, ours up */
	struct vec3 pt;
	double n;

	for (int i = 0; i < 7; i++) {
		v[i] = lef(pl + 4 * i);
		if (!isfinite(v[i]))
			return false;
	}
	qp = (struct quat){ v[3], v[4], v[5], v[6] };
	n = sqrt((double)v[3] * v[3] + (double)v[4] * v[4] + (double)v[5] * v[5] + (double)v[6] * v[6]);
	if (n < 0.9 || n > 1.1 || fabsf(v[0]) > 1e4f || fabsf(v[1]) > 1e4f || fabsf(v[2]) > 1e4f)
		return false;
	quat_normalize(&qp, &qn);
	quat_mul(&flip, &qn, &qt);
	pt = (struct vec3){ v[0] * 0.01, -v[1] * 0.01, -v[2] * 0.01 };
	dq_from_rt(&qt, &pt, &s->pose);
	s->buttons = 0;
	memset(s->analog, 0, sizeof(s->analog));
	s->inputs = false;
	s->t_ns = 0;
	return true;
}

static int polhemus_feed(void *st, const uint8_t *in, size_t n, device_emit_fn *emit, void *ctx)
{
	struct polhemus_codec_st *p = st;
	size_t pos = 0;
	int emitted = 0;

	if (n > POLHEMUS_BUF - p->len) {
		/* cannot happen while records are parsed as they come; a flood of junk ends here */
		lose_sync(p);
		p->skipped += p->len;
		p->len = 0;
		if (n > POLHEMUS_BUF) {
			p->skipped += n - POLHEMUS_BUF;
			in += n - POLHEMUS_BUF;
			n = POLHEMUS_BUF;
		}
	}
	memcpy(p->buf + p->len, in, n);
	p->len += n;
	while (p->len - pos >= POLHEMUS_HEADER) {
		const uint8_t *r = p->buf + pos;
		unsigned station = r[2], size = (unsigned)r[6] | (unsigned)r[7] << 8;
		struct device_sample s;

		if (!is_magic(p, r) || station < 1 || station > CFG_MAX_STATIONS || size > 1024) {
			lose_sync(p);
			p->skipped++;
			pos++;
			continue;
		}
		if (r[3] != 'C' && r[3] != 'P') {
			/*
			 * The answer to another command (the station map is 4
			 * bytes): not ours to read. A long one is a corrupt
			 * header that would swallow good records.
			 */
			if (size > 256) {
				lose_sync(p);
				p->skipped++;
				pos++;
				continue;
			}
			if (p->len - pos < POLHEMUS_HEADER + size)
				break;
			pos += POLHEMUS_HEADER + size;
			continue;
		}
		if (size != POLHEMUS_PAYLOAD) {
			/* a header look-alike, or not our output list: search on from the next byte */
			lose_sync(p);
			p->skipped++;
			pos++;
			continue;
		}
		if (p->len - pos < POLHEMUS_RECORD)
			break; /* the rest is in a later transfer */
		if (r[POLHEMUS_RECORD - 1] != ' ') {
			/* a header look-alike, or not our output list: search on from the next byte */
			lose_sync(p);
			p->skipped++;
			pos++;
			continue;
		}
		pos += POLHEMUS_RECORD;
		p->in_sync = true;
		/* the header names the product: Patriots (PA) stream at 60 Hz, Liberties (LY, LU) at 240 */
		p->period = r[0] == 'P' ? 1.0 / 60 : 1.0 / 240;
		if (r[4] != ' ') {
			p->error_records++;
			p->last_error = r[4];
			p->c.malformed++;
			continue;
		}
		if (!decode_pose(r + POLHEMUS_HEADER, &s)) {
			p->c.malformed++;
			continue;
		}
		{
			uint32_t fc = le32(r + POLHEMUS_HEADER + 28), step = fc - p->frame[station];

			if (p->have_frame[station]) {
				if (!step) {
					p->c.malformed++; /* the same frame twice */
					continue;
				}
				if (step < 0x80000000u)
					p->c.lost += step - 1u;
			}
			p->have_frame[station] = true;
			p->frame[station] = fc;
		}
		p->c.reports++;
		if (p->sensor_of[station] >= 0) {
			emit(ctx, p->sensor_of[station], &s);
			emitted++;
		}
	}
	memmove(p->buf, p->buf + pos, p->len - pos);
	p->len -= pos;
	return emitted;
}

const struct device_codec polhemus_codec = {
	.name = "polhemus",
	.size = sizeof(struct polhemus_codec_st),
	.init = polhemus_codec_init,
	.reset = polhemus_codec_reset,
	.feed = polhemus_feed,
	.period = polhemus_period,
};

/* ---- USB ---------------------------------------------------------------------------- */

struct polhemus {
	struct device dev;
	libusb_context *ctx;
	libusb_hotplug_callback_handle hp;
	bool hotplug;
	_Atomic bool arrived; /* a hot-plug arrival since the last search */
	libusb_device_handle *h;
	const struct polhemus_product *prod;
	char port[64];
	uint8_t ep_in, ep_out;
	uint16_t out_packet;
	bool ever_up;
	char told_fw[64];	/* the port last told to need firmware */
	uint64_t error_records; /* told so far */
	int failures;		/* set-ups or streams that failed in a row (notes are spared after the first few) */
	char told_open[64];	/* the port whose open failure was told (not again every second) */
	int told_rc;
	uint64_t busy_since; /* CLOCK_MONOTONIC since the interface is held by someone else, 0: it is not */
};

/*
 * A reload opens the new sources before it closes the old ones, so for a
 * moment our own previous source holds the interface: BUSY for this long
 * is waited out quietly, 100 ms at a time.
 */
#define POLHEMUS_BUSY_GRACE_MS 3000

static void port_of(libusb_device *dev, char *buf, size_t len)
{
	uint8_t ports[8];
	int n = libusb_get_port_numbers(dev, ports, (int)sizeof(ports));
	size_t k = (size_t)snprintf(buf, len, "%u", libusb_get_bus_number(dev));

	for (int i = 0; i < n && k < len; i++)
		k += (size_t)snprintf(buf + k, len - k, "%c%u", i ? '.' : '-', ports[i]);
	if (n <= 0 && k < len)
		snprintf(buf + k, len - k, "-0");
}

static int LIBUSB_CALL hotplug_cb(libusb_context *ctx, libusb_device *dev, libusb_hotplug_event ev, void *user)
{
	struct polhemus *p = user;

	(void)ctx;
	(void)dev;
	/* no I/O in here: the device thread does it once this returns */
	if (ev == LIBUSB_HOTPLUG_EVENT_DEVICE_ARRIVED)
		atomic_store(&p->arrived, true);
	return 0;
}

static int usb_write(struct polhemus *p, const char *cmd)
{
	int len = (int)strlen(cmd), sent = 0, rc;

	rc = libusb_bulk_transfer(p->h, p->ep_out, (unsigned char *)cmd, len, &sent, 1000);
	if (rc)
		return rc;
	/* a write of whole packets needs a zero-length packet to end it */
	if (p->out_packet && len % p->out_packet == 0)
		rc = libusb_bulk_transfer(p->h, p->ep_out, (unsigned char *)cmd, 0, &sent, 1000);
	return rc;
}

/* reads until drain_ms pass without data; LIBUSB_SUCCESS or the error that ended it */
static int usb_drain(struct polhemus *p)
{
	unsigned char buf[4096];
	int pipes = 0;

	/* 200 reads at most: a device that never stops talking has not heard P */
	for (int i = 0; i < 200 && !device_stopping(&p->dev); i++) {
		int got = 0, rc = libusb_bulk_transfer(p->h, p->ep_in, buf, sizeof(buf), &got,
						       (unsigned)polhemus_timing.drain_ms);

		if (rc == LIBUSB_ERROR_TIMEOUT && !got)
			return 0;
		if (rc == LIBUSB_ERROR_PIPE) {
			/* one halt is cleared; an endpoint that halts again is stuck */
			if (pipes++)
				return rc;
			libusb_clear_halt(p->h, p->ep_in);
			continue;
		}
		if (rc && rc != LIBUSB_ERROR_TIMEOUT)
			return rc;
	}
	return 0;
}

/* the bulk endpoints of interface 0, from the descriptor; the known ones otherwise */
static void find_endpoints(struct polhemus *p, libusb_device *dev)
{
	struct libusb_config_descriptor *cd;

	p->ep_in = p->prod->ep_in;
	p->ep_out = p->prod->ep_out;
	p->out_packet = 64;
	if (libusb_get_active_config_descriptor(dev, &cd))
		return;
	if (cd->bNumInterfaces > 0 && cd->interface[0].num_altsetting > 0) {
		const struct libusb_interface_descriptor *id = &cd->interface[0].altsetting[0];
		bool in = false, out = false;

		for (int i = 0; i < id->bNumEndpoints; i++) {
			const struct libusb_endpoint_descriptor *e = &id->endpoint[i];

			if ((e->bmAttributes & LIBUSB_TRANSFER_TYPE_MASK) != LIBUSB_TRANSFER_TYPE_BULK)
				continue;
			if ((e->bEndpointAddress & LIBUSB_ENDPOINT_DIR_MASK) == LIBUSB_ENDPOINT_IN && !in) {
				p->ep_in = e->bEndpointAddress;
				in = true;
			} else if ((e->bEndpointAddress & LIBUSB_ENDPOINT_DIR_MASK) == LIBUSB_ENDPOINT_OUT && !out) {
				p->ep_out = e->bEndpointAddress;
				p->out_packet = e->wMaxPacketSize;
				out = true;
			}
		}
	}
	libusb_free_config_descriptor(cd);
}

static bool model_matches(int want, const struct polhemus_product *pr)
{
	return want == CFG_PH_AUTO || want == pr->model;
}

/* opens the wanted device; 0, -ENOENT (none there) or another negative errno (noted) */
static int usb_open(struct polhemus *p)
{
	const struct cfg_source *cfg = p->dev.t->cfg;
	libusb_device **list, *pick = NULL;
	const struct polhemus_product *pick_pr = NULL;
	char port[64], pick_port[64] = "";
	ssize_t n = libusb_get_device_list(p->ctx, &list);
	int rc;

	if (n < 0) {
		device_set_status(&p->dev, "cannot list USB devices: %s", libusb_error_name((int)n));
		return -EIO;
	}
	for (ssize_t i = 0; i < n; i++) {
		struct libusb_device_descriptor dd;
		const struct polhemus_product *pr;

		if (libusb_get_device_descriptor(list[i], &dd) || dd.idVendor != POLHEMUS_VID)
			continue;
		pr = polhemus_product(dd.idProduct);
		port_of(list[i], port, sizeof(port));
		if (!pr || !model_matches(opts_of(cfg)->model, pr) ||
		    (strcmp(opts_of(cfg)->dev.device, "auto") && strcmp(opts_of(cfg)->dev.device, port)))
			continue;
		if (pr->needs_firmware) {
			device_set_status(&p->dev,
					  "Polhemus %s (0f44:%04x) on USB port %s waits for its firmware (fxload)",
					  pr->name, pr->pid, port);
			if (strcmp(p->told_fw, port)) {
				device_note(&p->dev, LOG_ERR,
					    "[source %s] Polhemus %s (0f44:%04x) on USB port %s has no firmware yet: "
					    "it needs "
					    "fxload at every plug-in. Install Polhemus' Linux tools and add a udev "
					    "rule beside "
					    "60-avatargw.rules: ACTION==\"add\", SUBSYSTEM==\"usb\", "
					    "ATTR{idVendor}==\"0f44\", "
					    "ATTR{idProduct}==\"%04x\", RUN+=\"/sbin/fxload %s -D $devnode\" "
					    "(docs/TRACKERS.md); "
					    "waiting for it as 0f44:%04x",
					    p->dev.t->name, pr->name, pr->pid, port, pr->pid, pr->fxload,
					    pr->ready_pid);
				snprintf(p->told_fw, sizeof(p->told_fw), "%s", port);
			}
			continue;
		}
		if (!pick) {
			pick = list[i];
			pick_pr = pr;
			snprintf(pick_port, sizeof(pick_port), "%s", port);
		}
	}
	if (!pick) {
		libusb_free_device_list(list, 1);
		return -ENOENT;
	}
	p->prod = pick_pr;
	snprintf(p->port, sizeof(p->port), "%s", pick_port);
	p->told_fw[0] = '\0';
	rc = libusb_open(pick, &p->h);
	if (!rc) {
		find_endpoints(p, pick);
		libusb_set_auto_detach_kernel_driver(p->h, 1);
	}
	libusb_free_device_list(list, 1);
	if (rc) {
		device_set_status(&p->dev, "Polhemus %s on USB port %s: cannot open: %s", pick_pr->name, pick_port,
				  libusb_error_name(rc));
		p->h = NULL;
		if (!strcmp(p->told_open, pick_port) && p->told_rc == rc)
			return -EACCES;
		snprintf(p->told_open, sizeof(p->told_open), "%s", pick_port);
		p->told_rc = rc;
		device_note(&p->dev, LOG_ERR, "[source %s] Polhemus %s on USB port %s: cannot open: %s%s",
			    p->dev.t->name, pick_pr->name, pick_port, libusb_strerror(rc),
			    rc == LIBUSB_ERROR_ACCESS ? " (install systemd/60-avatargw.rules and be in the group "
							"avatargw: README, Setting up a tracker)"
						      : "");
		p->h = NULL;
		return -EACCES;
	}
	p->told_open[0] = '\0';
	/* configuration 1 is the only one; busy means it is set already, which is what we want */
	rc = libusb_set_configuration(p->h, 1);
	if (rc && rc != LIBUSB_ERROR_BUSY)
		goto fail;
	rc = libusb_claim_interface(p->h, 0);
	if (rc)
		goto fail;
	if (!p->ep_in || !p->ep_out) {
		device_note(&p->dev, LOG_ERR,
			    "[source %s] Polhemus %s on USB port %s: no bulk endpoints on interface 0", p->dev.t->name,
			    pick_pr->name, pick_port);
		libusb_release_interface(p->h, 0);
		rc = LIBUSB_ERROR_NOT_FOUND;
		goto fail;
	}
	p->busy_since = 0;
	return 0;
fail:
	if (rc == LIBUSB_ERROR_BUSY) {
		uint64_t now = mono_ns();

		if (!p->busy_since)
			p->busy_since = now;
		if (now - p->busy_since < POLHEMUS_BUSY_GRACE_MS * 1000000ull) {
			device_set_status(&p->dev,
					  "Polhemus %s on USB port %s: waiting for its interface to be released",
					  pick_pr->name, pick_port);
			libusb_close(p->h);
			p->h = NULL;
			return -EAGAIN;
		}
	}
	device_note(&p->dev, LOG_ERR, "[source %s] Polhemus %s on USB port %s: %s%s", p->dev.t->name, pick_pr->name,
		    pick_port, libusb_strerror(rc),
		    rc == LIBUSB_ERROR_BUSY ? " (another program holds it: PiTerm, another avatargw?)" : "");
	device_set_status(&p->dev, "Polhemus %s on USB port %s: %s", pick_pr->name, pick_port, libusb_error_name(rc));
	libusb_close(p->h);
	p->h = NULL;
	return -EBUSY;
}

static void usb_close(struct polhemus *p, bool alive)
{
	if (!p->h)
		return;
	if (alive)
		usb_write(p, "P"); /* stop continuous output: the next program finds it quiet */
	libusb_release_interface(p->h, 0);
	libusb_close(p->h);
	p->h = NULL;
}

/* P, drain, F1, U1, H, O, drain, C; a libusb error or 0 */
static int usb_setup(struct polhemus *p)
{
	const struct cfg_source *cfg = p->dev.t->cfg;
	char hemi[96];
	const char *const cmds[] = { "F1\r", "U1\r", hemi, POLHEMUS_OUTPUT_LIST };
	int rc;

	device_set_link(&p->dev, DEVICE_STARTING);
	p->dev.codec->reset(p->dev.codec_st);
	snprintf(hemi, sizeof(hemi), "H*,%g,%g,%g\r", opts_of(cfg)->hemisphere[0], opts_of(cfg)->hemisphere[1],
		 opts_of(cfg)->hemisphere[2]);
	if ((rc = usb_write(p, "P")) || (rc = usb_drain(p)))
		return rc;
	for (size_t i = 0; i < sizeof(cmds) / sizeof(cmds[0]); i++)
		if ((rc = usb_write(p, cmds[i])))
			return rc;
	if ((rc = usb_drain(p)))
		return rc;
	p->dev.codec->reset(p->dev.codec_st);
	return usb_write(p, "C\r");
}

/* reads records; -1: the device went or must be reopened, 0: stopping */
static int usb_stream(struct polhemus *p)
{
	const struct polhemus_codec_st *cs = p->dev.codec_st;
	uint64_t last = mono_ns();
	unsigned char buf[4096];
	int restarts = 0, pipes = 0, errors = 0;

	while (!device_stopping(&p->dev)) {
		int got = 0, rc = libusb_bulk_transfer(p->h, p->ep_in, buf, sizeof(buf), &got, 100);
		uint64_t now = mono_ns();

		/* a transfer that timed out may still have brought bytes */
		if (got > 0 && device_feed(&p->dev, buf, (size_t)got) > 0) {
			last = now;
			restarts = pipes = errors = 0;
			if (device_link_of(&p->dev) != DEVICE_UP) {
				device_set_link(&p->dev, DEVICE_UP);
				device_set_status(&p->dev, "Polhemus %s on USB port %s: streaming", p->prod->name,
						  p->port);
			}
		}
		if (cs->error_records != p->error_records) {
			device_note(&p->dev, LOG_WARNING,
				    "[source %s] Polhemus %s: %llu records with error code '%c' (0x%02x) dropped",
				    p->dev.t->name, p->prod->name,
				    (unsigned long long)(cs->error_records - p->error_records),
				    cs->last_error >= 0x20 && cs->last_error < 0x7f ? cs->last_error : '?',
				    cs->last_error);
			p->error_records = cs->error_records;
		}
		switch (rc) {
		case 0:
		case LIBUSB_ERROR_TIMEOUT:
			break;
		case LIBUSB_ERROR_NO_DEVICE:
			device_note(&p->dev, LOG_ERR,
				    "[source %s] Polhemus %s on USB port %s: unplugged; waiting for it", p->dev.t->name,
				    p->prod->name, p->port);
			device_set_status(&p->dev, "Polhemus %s on USB port %s lost; waiting for it", p->prod->name,
					  p->port);
			return -1;
		case LIBUSB_ERROR_PIPE:
			/* the endpoint halted: clear it and go on; a device that keeps halting is reopened */
			libusb_clear_halt(p->h, p->ep_in);
			if (++pipes >= polhemus_timing.pipe_limit) {
				if (p->failures < 3)
					device_note(&p->dev, LOG_ERR,
						    "[source %s] Polhemus %s: endpoint 0x%02x halted %d times in a "
						    "row: reopening",
						    p->dev.t->name, p->prod->name, p->ep_in, pipes);
				device_set_status(&p->dev, "Polhemus %s on USB port %s: endpoint 0x%02x keeps halting",
						  p->prod->name, p->port, p->ep_in);
				return -2;
			}
			continue;
		default:
			if (++errors >= 3) {
				if (p->failures < 3)
					device_note(&p->dev, LOG_ERR, "[source %s] Polhemus %s: %s: reopening",
						    p->dev.t->name, p->prod->name, libusb_strerror(rc));
				return -2;
			}
			continue;
		}
		if (now - last <= (uint64_t)polhemus_timing.stall_ms * 1000000ull)
			continue;
		if (restarts >= polhemus_timing.restarts) {
			if (p->failures < 3)
				device_note(&p->dev, LOG_ERR,
					    "[source %s] Polhemus %s: no record after %d set-ups: reopening",
					    p->dev.t->name, p->prod->name, restarts);
			device_set_status(&p->dev, "Polhemus %s on USB port %s: sends nothing", p->prod->name, p->port);
			return -2;
		}
		restarts++;
		if (p->failures < 3)
			device_note(&p->dev, LOG_WARNING,
				    "[source %s] Polhemus %s: no record for %d ms: setting it up again", p->dev.t->name,
				    p->prod->name, polhemus_timing.stall_ms);
		rc = usb_setup(p);
		if (rc == LIBUSB_ERROR_NO_DEVICE)
			return -1;
		last = mono_ns();
	}
	return 0;
}

/* waits for a hot-plug arrival or search_ms */
static void usb_wait(struct polhemus *p)
{
	uint64_t end = mono_ns() + (uint64_t)polhemus_timing.search_ms * 1000000ull;

	if (!p->hotplug) {
		device_sleep_ms(&p->dev, polhemus_timing.search_ms);
		return;
	}
	while (!device_stopping(&p->dev) && !atomic_load(&p->arrived) && mono_ns() < end) {
		struct timeval tv = { 0, 50000 };

		libusb_handle_events_timeout_completed(p->ctx, &tv, NULL);
	}
}

static void polhemus_run(struct device *d)
{
	struct polhemus *p = d->drv;
	bool told_missing = false;
	int rc;

	while (!device_stopping(d) && (rc = libusb_init(&p->ctx))) {
		device_set_status(d, "libusb: %s", libusb_error_name(rc));
		device_note(d, LOG_ERR, "[source %s] libusb: %s; trying again", d->t->name, libusb_strerror(rc));
		p->ctx = NULL;
		device_sleep_ms(d, 2000);
	}
	if (!p->ctx)
		return;
	if (libusb_has_capability(LIBUSB_CAP_HAS_HOTPLUG))
		p->hotplug = !libusb_hotplug_register_callback(
			p->ctx, LIBUSB_HOTPLUG_EVENT_DEVICE_ARRIVED | LIBUSB_HOTPLUG_EVENT_DEVICE_LEFT, 0, POLHEMUS_VID,
			LIBUSB_HOTPLUG_MATCH_ANY, LIBUSB_HOTPLUG_MATCH_ANY, hotplug_cb, p, &p->hp);
	while (!device_stopping(d)) {
		atomic_store(&p->arrived, false);
		device_set_link(d, DEVICE_DOWN);
		rc = usb_open(p);
		if (rc == -ENOENT) {
			if (!told_missing)
				device_note(d, LOG_WARNING,
					    "[source %s] no Polhemus found (model = %s, device = %s); waiting for one",
					    d->t->name, model_names[opts_of(d->t->cfg)->model],
					    opts_of(d->t->cfg)->dev.device);
			if (!p->told_fw[0])
				device_set_status(d, "no Polhemus%s%s found; waiting (%s)",
						  strcmp(opts_of(d->t->cfg)->dev.device, "auto") ? " on USB port " : "",
						  strcmp(opts_of(d->t->cfg)->dev.device, "auto")
							  ? opts_of(d->t->cfg)->dev.device
							  : "",
						  p->hotplug ? "hot-plug events" : "looking every 200 ms");
			told_missing = true;
			usb_wait(p);
			continue;
		}
		if (rc) {
			device_sleep_ms(d, rc == -EAGAIN ? 100 : 1000);
			continue;
		}
		told_missing = false;
		if (p->failures < 3)
			device_note(d, LOG_INFO,
				    "[source %s] Polhemus %s (0f44:%04x) on USB port %s opened (bulk out 0x%02x, in "
				    "0x%02x)",
				    d->t->name, p->prod->name, p->prod->pid, p->port, p->ep_out, p->ep_in);
		device_set_status(d, "Polhemus %s on USB port %s: setting up", p->prod->name, p->port);
		rc = usb_setup(p);
		if (!rc) {
			uint64_t before = ((const struct device_counts *)d->codec_st)->reports;

			if (p->ever_up)
				ctr_add(&d->t->st.reconnects, 1);
			p->ever_up = true;
			rc = usb_stream(p);
			if (((const struct device_counts *)d->codec_st)->reports != before)
				p->failures = 0;
		} else {
			if (p->failures < 3)
				device_note(d, LOG_ERR, "[source %s] Polhemus %s: set-up failed: %s%s", d->t->name,
					    p->prod->name, libusb_strerror(rc),
					    p->failures == 2 ? " (further failures in a row are not logged)" : "");
			device_set_status(d, "Polhemus %s on USB port %s: set-up failed: %s", p->prod->name, p->port,
					  libusb_error_name(rc));
			rc = rc == LIBUSB_ERROR_NO_DEVICE ? -1 : -2;
		}
		device_set_link(d, DEVICE_DOWN);
		usb_close(p, rc != -1);
		/* a device that must be reopened is not reopened in a tight loop */
		if (rc == -2) {
			p->failures++;
			device_sleep_ms(d, polhemus_timing.search_ms);
		}
	}
	if (p->hotplug)
		libusb_hotplug_deregister_callback(p->ctx, p->hp);
	libusb_exit(p->ctx);
	p->ctx = NULL;
}

/* ---- the driver ------------------------------------------------------------------------ */

static int polhemus_open(struct tracker *t, char *err, size_t errlen)
{
	int rc = device_drv_open(t, sizeof(struct polhemus), &polhemus_codec, t->n_sensors, err, errlen);

	return rc ? rc : device_drv_start(t, polhemus_run, "agw-polhemus", err, errlen);
}

/* the device comes first: the device_drv_* entries reach it through t->priv */
_Static_assert(offsetof(struct polhemus, dev) == 0, "struct polhemus begins with its struct device");

static int polhemus_list(FILE *out)
{
	libusb_context *ctx;
	libusb_device **list;
	ssize_t n;
	int found = 0;

	if (libusb_init(&ctx)) {
		fputs("Polhemus: libusb could not start: USB devices not listed\n", out);
		return 0;
	}
	n = libusb_get_device_list(ctx, &list);
	for (ssize_t i = 0; i < n; i++) {
		struct libusb_device_descriptor dd;
		const struct polhemus_product *pr;
		libusb_device_handle *h;
		char port[64], name[16];
		int rc;

		if (libusb_get_device_descriptor(list[i], &dd) || dd.idVendor != POLHEMUS_VID)
			continue;
		pr = polhemus_product(dd.idProduct);
		port_of(list[i], port, sizeof(port));
		if (!pr) {
			fprintf(out, "Polhemus device 0f44:%04x on USB port %s: not a product this driver knows\n\n",
				dd.idProduct, port);
			continue;
		}
		snprintf(name, sizeof(name), found ? "polhemus%d" : "polhemus", found);
		found++;
		fprintf(out, "Polhemus %s (0f44:%04x) on USB port %s (bus %u, address %u)\n", pr->name, pr->pid, port,
			libusb_get_bus_number(list[i]), libusb_get_device_address(list[i]));
		if (pr->needs_firmware) {
			fprintf(out,
				"  no firmware yet: load it with fxload %s -D /dev/bus/usb/%03u/%03u (Polhemus' Linux "
				"tools), or add the udev rule of docs/TRACKERS.md; it then shows up as 0f44:%04x\n",
				pr->fxload, libusb_get_bus_number(list[i]), libusb_get_device_address(list[i]),
				pr->ready_pid);
		} else if ((rc = libusb_open(list[i], &h))) {
			fprintf(out, "  cannot open it: %s%s\n", libusb_strerror(rc),
				rc == LIBUSB_ERROR_ACCESS
					? " (udev rule and group avatargw: README, Setting up a tracker)"
					: "");
		} else {
			libusb_close(h);
		}
		fprintf(out, "  [source %s]\n  type = polhemus\n  model = %s\n  device = %s\n", name,
			model_names[pr->model], port);
		fprintf(out,
			"  sensors = head left_hand right_hand\n  ; stations 1, 2, 3 are then %s/head, %s/left_hand, "
			"%s/right_hand\n\n",
			name, name, name);
	}
	if (n >= 0)
		libusb_free_device_list(list, 1);
	libusb_exit(ctx);
	return found;
}

const struct tracker_driver polhemus_driver = {
	.type = { CFG_TYPE("polhemus", "Polhemus Liberty, Liberty HS (Latus), Patriot over libusb bulk endpoints",
			   polhemus_keys, struct polhemus_opts),
		  CFG_SHARED(device_keys), .check = device_check, .sensor_count = polhemus_sensor_count,
		  .sensor_name = polhemus_sensor_name },
	.open = polhemus_open,
	.close = device_drv_close,
	.poll = device_drv_poll,
	.fd = device_drv_fd,
	.status = device_drv_status,
	.note = device_drv_note,
	.list_devices = polhemus_list,
};
