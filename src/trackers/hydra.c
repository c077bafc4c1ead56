// SPDX-License-Identifier: MIT
/*
 * hydra.c - the Razer Hydra: two magnetically tracked wands with buttons,
 * a joystick and a trigger each, over hidapi's hidraw back end (which
 * leaves the kernel's drivers attached: the gamepad keeps working).
 *
 * The facts (docs/TRACKERS.md, ../shared/protocols/trackers.md section 1):
 * the device comes up in gamepad mode; a 91-byte feature report on the
 * control interface switches it into motion mode, after which its motion
 * interface sends 52-byte reports at about 250 Hz: a sequence byte (7),
 * then a 22-byte block per wand (left at 8, right at 30) with the position
 * in mm (int16 x y z), the orientation (int16 w x y z / 32768, not quite
 * unit length), a button byte, the joystick (int16 x y / 32768) and the
 * trigger (uint8 / 255).
 *
 * Frames. Positions and orientations come in the base's frame as VRPN
 * documents it (x out of the base's right side, y out of its front, z
 * down) once the quaternion's y and z are negated (the handedness fix of
 * VRPN and Monado); the wand's own frame, joystick vertical, is x right, y
 * forward (towards the trigger), z up along the joystick. Our tracker
 * frame is that base frame turned 180 degrees about its x axis, so that z
 * points up: p = (x, -y, -z), q = Rx(180) * q. The source's origin and yaw
 * place it in the world.
 *
 * Hemispheres. The magnetic field gives a position only up to its sign:
 * the base reports -p for p on one side of it. Each wand starts on a known
 * side (the left wand left of the base, x < 0; the right one right of it,
 * as in the docks) and from then on every report takes, of p and -p, the
 * one closer to the previous position. A new stream (reconnect, stall)
 * starts over from the sides.
 *
 * The device thread: enumerate (every search_ms while nothing is found),
 * open both interfaces' nodes, probe for motion reports, else send the
 * motion-mode request and wait, again and again; then read with a 100 ms
 * timeout. A read error is an unplug: close, FAULTY, enumerate. No motion
 * report for stall_ms, or a run of reports of the wrong length (the mode
 * changed behind our back, as the Windows configurator can do): ask for
 * motion mode again. Gamepad mode is restored when the source closes if
 * that is how the device was found.
 */
#include "trackers/hydra.h"

#include "trackers/device.h"

#include <hidapi/hidapi.h>

#include <errno.h>
#include <limits.h>
#include <math.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>
#include <syslog.h>
#include <unistd.h>
#include <wchar.h>

static const struct cfg_key hydra_keys[] = {
	{ .name = "interface",
	  .kind = CFG_INT,
	  CFG_AT(struct hydra_opts, hid_interface),
	  .min = 0,
	  .max = 255,
	  .def = "0",
	  .doc = "USB interface number of the 52-byte motion reports" },
	{ .name = "control_interface",
	  .kind = CFG_INT,
	  CFG_AT(struct hydra_opts, control_interface),
	  .min = 0,
	  .max = 255,
	  .def = "1",
	  .doc = "USB interface number that takes the feature report switching between gamepad and motion mode" },
};

static const struct hydra_opts *opts_of(const struct cfg_source *c)
{
	return c->opt;
}

struct hydra_timing hydra_timing = {
	.probe_ms = 250,  /* 60 reports' worth: a device in motion mode has sent some by then */
	.retry_ms = 5000, /* VRPN's wait after a mode request */
	.stall_ms = 500,
	.search_ms = 200,
	.bad_run = 25, /* 0.1 s of reports */
};

/* hidapi is not thread-safe for enumeration, opening and closing: one lock for every Hydra source */
static pthread_mutex_t hydra_hid_lock = PTHREAD_MUTEX_INITIALIZER;

/*
 * The Hydras this process has open, and how each was found. A reload opens
 * the new configuration's sources before it closes the old ones: the new
 * source finds the device in motion mode (the old one put it there) but
 * must still put it back into gamepad mode in the end, and the old one
 * must not put it back while the new one reads. So the mode it was found
 * in belongs to the device, and the last source to close it restores it.
 * Guarded by hydra_hid_lock.
 */
#define HYDRA_OPEN_MAX 8

static struct hydra_open {
	char path[PATH_MAX];
	int users;
	bool found_gamepad;
} hydra_opens[HYDRA_OPEN_MAX];

/* takes a user of path's entry (a new one when nobody has it); the entry, or NULL when the table is full */
static struct hydra_open *hydra_open_get(const char *path, bool *shared)
{
	struct hydra_open *free_slot = NULL;

	for (int i = 0; i < HYDRA_OPEN_MAX; i++) {
		struct hydra_open *o = &hydra_opens[i];

		if (o->users && !strcmp(o->path, path)) {
			o->users++;
			*shared = true;
			return o;
		}
		if (!o->users && !free_slot)
			free_slot = o;
	}
	*shared = false;
	if (free_slot) {
		snprintf(free_slot->path, sizeof(free_slot->path), "%s", path);
		free_slot->users = 1;
		free_slot->found_gamepad = false;
	}
	return free_slot;
}

static const char *const hydra_sensors[2] = { "left", "right" };

/* ---- the codec ---------------------------------------------------------------------- */

struct hydra_codec_st {
	struct device_counts c;
	bool have_seq;
	uint8_t seq;
	bool tracking[2];
	double prev[2][3];    /* the previous position of each wand, base frame, mm, hemisphere resolved */
	int jumps;	      /* reports in a row rejected for an impossible jump */
	uint64_t rejected[4]; /* bit d: number seq + d came in a rejected report (received: not lost) */
	uint64_t flips;	      /* positions taken as -p */
};

/*
 * Plausibility: a hand moves at most a few m/s, 10-40 mm per report; 150
 * mm per report elapsed (2 m at most) is impossible, so such a report is
 * garbage. After
 * HYDRA_MAX_JUMPS of them in a row the wands are taken to really be where
 * the reports say (continuity was lost): tracking restarts from the sides.
 */
#define HYDRA_MAX_STEP_MM 150.0
#define HYDRA_MAX_GAP_MM 2000.0 /* however many reports were lost (the counter wraps at 256) */
#define HYDRA_MAX_JUMPS 25

/*
 * A report of the right length was rejected (not a unit quaternion, an
 * impossible jump): its number is noted, not taken as the reference
 * (garbage that passed the other checks would derail the count). If the
 * next good report shows a gap that this number falls in, the report was
 * received: malformed, not lost as well. Noted by distance from the last
 * good number, which stays put until the next good report.
 */
static void hydra_note_rejected(struct hydra_codec_st *h, const uint8_t *buf)
{
	uint8_t d = (uint8_t)(buf[7] - h->seq);

	if (h->have_seq && d)
		h->rejected[d >> 6] |= 1ull << (d & 63);
}

/*
 * A good report step numbers after the last: of the step - 1 numbers in
 * between, those not received at all, each counted once however many
 * rejects carried it and in whatever order they came. The notes go.
 */
static unsigned hydra_gap_lost(struct hydra_codec_st *h, unsigned step)
{
	unsigned lost = step - 1u;

	for (unsigned d = 1; d < step; d++)
		lost -= (unsigned)(h->rejected[d >> 6] >> (d & 63) & 1u);
	memset(h->rejected, 0, sizeof(h->rejected));
	return lost;
}

static int16_t le16(const uint8_t *p)
{
	return (int16_t)(uint16_t)(p[0] | (unsigned)p[1] << 8);
}

/* the device's button byte in our bit order (VRPN's numbering) */
static uint32_t hydra_buttons(uint8_t raw)
{
	uint32_t b = 0;

	/* bit 7 reads 1 on real devices and means nothing */
	if (raw & 0x01)
		b |= HYDRA_BTN_BUMPER;
	if (raw & 0x02)
		b |= HYDRA_BTN_3;
	if (raw & 0x04)
		b |= HYDRA_BTN_1;
	if (raw & 0x08)
		b |= HYDRA_BTN_2;
	if (raw & 0x10)
		b |= HYDRA_BTN_4;
	if (raw & 0x20)
		b |= HYDRA_BTN_START;
	if (raw & 0x40)
		b |= HYDRA_BTN_JOYSTICK;
	return b;
}

static int hydra_codec_init(void *st, const struct cfg_source *cfg, char *err, size_t errlen)
{
	(void)cfg;
	(void)err;
	(void)errlen;
	memset(st, 0, sizeof(struct hydra_codec_st));
	return 0;
}

static void hydra_codec_reset(void *st)
{
	struct hydra_codec_st *h = st;

	h->have_seq = false;
	h->tracking[0] = h->tracking[1] = false;
	h->jumps = 0;
	memset(h->rejected, 0, sizeof(h->rejected));
}

static double hydra_period(const void *st)
{
	(void)st;
	return 1.0 / HYDRA_RATE_HZ;
}

static int hydra_feed(void *st, const uint8_t *buf, size_t len, device_emit_fn *emit, void *ctx)
{
	struct hydra_codec_st *h = st;
	struct device_sample s[2];
	double p[2][3];
	unsigned step = 1;
	bool jump = false, neg[2] = { false, false };

	if (len != HYDRA_REPORT_LEN) {
		/* not a motion report (hidraw reads whole reports): it has no number, and none is lost by it */
		h->c.malformed++;
		return -EMSGSIZE;
	}
	for (int w = 0; w < 2; w++) {
		const uint8_t *b = buf + 8 + 22 * w;
		struct quat raw = { le16(b + 6) / 32768.0, le16(b + 8) / 32768.0, le16(b + 10) / 32768.0,
				    le16(b + 12) / 32768.0 };
		double n = sqrt(raw.w * raw.w + raw.x * raw.x + raw.y * raw.y + raw.z * raw.z);

		/* int16 / 32768 is a unit quaternion to 1e-4; anything far from it is not a report */
		if (n < 0.9 || n > 1.1) {
			h->c.malformed++;
			hydra_note_rejected(h, buf);
			return -EINVAL;
		}
	}
	if (h->have_seq) {
		step = (uint8_t)(buf[7] - h->seq);
		if (!step) {
			/* the same report twice: nothing new */
			h->c.malformed++;
			return -EINVAL;
		}
	}
	/* positions, each on its side of the base */
	for (int w = 0; w < 2; w++) {
		const uint8_t *b = buf + 8 + 22 * w;

		p[w][0] = le16(b);
		p[w][1] = le16(b + 2);
		p[w][2] = le16(b + 4);
		if (!h->tracking[w]) {
			/* the known start: the left wand left of the base, the right one right of it */
			if (w == HYDRA_LEFT ? p[w][0] > 0 : p[w][0] < 0)
				for (int i = 0; i < 3; i++)
					p[w][i] = -p[w][i];
		} else {
			double dp = 0, dm = 0;

			/* continuity: of p and -p, the one closer to where the wand was */
			for (int i = 0; i < 3; i++) {
				dp += (p[w][i] - h->prev[w][i]) * (p[w][i] - h->prev[w][i]);
				dm += (-p[w][i] - h->prev[w][i]) * (-p[w][i] - h->prev[w][i]);
			}
			if (dm < dp) {
				for (int i = 0; i < 3; i++)
					p[w][i] = -p[w][i];
				dp = dm;
				neg[w] = true;
			}
			/* a hand does not move this far in one report: the bytes are not a report */
			if (sqrt(dp) > fmin(HYDRA_MAX_STEP_MM * step, HYDRA_MAX_GAP_MM))
				jump = true;
		}
	}
	if (jump) {
		h->c.malformed++;
		hydra_note_rejected(h, buf);
		/* so many in a row that the wands must really be there: start over from the sides */
		if (++h->jumps >= HYDRA_MAX_JUMPS) {
			h->tracking[0] = h->tracking[1] = false;
			h->jumps = 0;
		}
		return -EINVAL;
	}
	h->jumps = 0;
	if (h->have_seq)
		h->c.lost += hydra_gap_lost(h, step);
	h->have_seq = true;
	h->seq = buf[7];
	for (int w = 0; w < 2; w++) {
		const uint8_t *b = buf + 8 + 22 * w;
		const struct quat flip = { 0, 1, 0, 0 }; /* Rx(180): base frame (z down) -> tracker frame (z up) */
		struct quat qb = { le16(b + 6), le16(b + 8), -le16(b + 10), -le16(b + 12) }, qn, qt;
		struct vec3 pt;

		h->flips += neg[w];
		h->tracking[w] = true;
		for (int i = 0; i < 3; i++)
			h->prev[w][i] = p[w][i];
		quat_normalize(&qb, &qn);
		quat_mul(&flip, &qn, &qt);
		pt = (struct vec3){ p[w][0] * 1e-3, -p[w][1] * 1e-3, -p[w][2] * 1e-3 };
		dq_from_rt(&qt, &pt, &s[w].pose);
		s[w].buttons = hydra_buttons(b[14]);
		s[w].analog[HYDRA_AN_JOY_X] = (float)(le16(b + 15) / 32768.0);
		s[w].analog[HYDRA_AN_JOY_Y] = (float)(le16(b + 17) / 32768.0);
		s[w].analog[HYDRA_AN_TRIGGER] = (float)(b[19] / 255.0);
		s[w].analog[3] = 0;
		s[w].inputs = true;
		s[w].t_ns = 0;
	}
	h->c.reports++;
	for (int w = 0; w < 2; w++)
		emit(ctx, w, &s[w]);
	return 2;
}

const struct device_codec hydra_codec = {
	.name = "hydra",
	.size = sizeof(struct hydra_codec_st),
	.init = hydra_codec_init,
	.reset = hydra_codec_reset,
	.feed = hydra_feed,
	.period = hydra_period,
};

/* ---- finding the device ----------------------------------------------------------------- */

struct hydra_node {
	char path[PATH_MAX];
	char port[64]; /* USB port, "" if unknown */
	int iface;
};

/* the USB port of a hidraw node ("1-2.3"), read from sysfs; "" when unknown */
static void hydra_port_of(const char *path, char *port, size_t len)
{
	const char *base = strrchr(path, '/');
	char sys[PATH_MAX], real[PATH_MAX], *save, *c;

	port[0] = '\0';
	snprintf(sys, sizeof(sys), "/sys/class/hidraw/%s/device", base ? base + 1 : path);
	if (!realpath(sys, real))
		return;
	/* .../usb1/1-2/1-2:1.0/0003:1532:0300.0005: the interface is "PORT:CONFIG.IFACE" */
	for (c = strtok_r(real, "/", &save); c; c = strtok_r(NULL, "/", &save)) {
		char *colon = strchr(c, ':');

		if (colon && strchr(c, '-') && strchr(c, '-') < colon && strchr(colon, '.') &&
		    (size_t)(colon - c) < len) {
			memcpy(port, c, (size_t)(colon - c));
			port[colon - c] = '\0';
		}
	}
}

/* the Hydras plugged in: each one's motion and control nodes; returns how many (at most max) */
static int hydra_find(int iface, int ctrl_iface, struct hydra_node data[][2], int max)
{
	struct hid_device_info *all, *i;
	struct hydra_node ctl[8];
	int n = 0, nc = 0;

	pthread_mutex_lock(&hydra_hid_lock);
	all = hid_enumerate(HYDRA_VID, HYDRA_PID);
	for (i = all; i; i = i->next) {
		struct hydra_node node;

		snprintf(node.path, sizeof(node.path), "%s", i->path);
		hydra_port_of(i->path, node.port, sizeof(node.port));
		node.iface = i->interface_number;
		if (i->interface_number == iface && n < max)
			data[n++][0] = node;
		if (i->interface_number == ctrl_iface && nc < 8)
			ctl[nc++] = node;
	}
	hid_free_enumeration(all);
	pthread_mutex_unlock(&hydra_hid_lock);
	/* pair each motion node with the control node of the same device: same port, else the same rank */
	for (int k = 0; k < n; k++) {
		int pick = -1;

		for (int j = 0; j < nc && pick < 0; j++)
			if (data[k][0].port[0] && !strcmp(ctl[j].port, data[k][0].port))
				pick = j;
		if (pick < 0 && k < nc)
			pick = k;
		if (pick >= 0)
			data[k][1] = ctl[pick];
		else
			data[k][1].path[0] = '\0';
	}
	return n;
}

/* ---- the device thread ---------------------------------------------------------------- */

struct hydra {
	struct device dev;
	hid_device *data, *ctrl;
	bool ctrl_is_data;
	bool found_gamepad;	 /* this connection switched it from gamepad mode (or one before it did) */
	struct hydra_open *open; /* the device's entry in hydra_opens */
	bool ever_up;
	char path[PATH_MAX];
	char port[64];
	unsigned attempts;   /* mode requests of this connection */
	char told[PATH_MAX]; /* the node last told about (an open failure): not again every second */
	int told_errno;
	uint64_t requests; /* mode requests in all */
};

static void hydra_feature(uint8_t rep[HYDRA_FEATURE_LEN], bool motion)
{
	memset(rep, 0, HYDRA_FEATURE_LEN);
	rep[6] = 0x01;
	rep[8] = 0x04;
	rep[9] = motion ? 0x03 : 0x00;
	rep[89] = motion ? 0x06 : 0x05;
}

static const char *hydra_errstr(hid_device *h)
{
	const wchar_t *w = hid_error(h);
	static _Thread_local char buf[128];

	if (!w)
		return "unknown error";
	if (wcstombs(buf, w, sizeof(buf)) == (size_t)-1)
		return "unknown error";
	buf[sizeof(buf) - 1] = '\0';
	return buf;
}

/* the device's node matches the configured device (auto, a node or its symlink, a USB port) */
static bool hydra_wanted(const char *want, const struct hydra_node pair[2])
{
	char real[PATH_MAX];

	if (!strcmp(want, "auto"))
		return true;
	if (want[0] != '/')
		return pair[0].port[0] && !strcmp(want, pair[0].port);
	if (!realpath(want, real))
		snprintf(real, sizeof(real), "%s", want);
	return !strcmp(real, pair[0].path) || (pair[1].path[0] && !strcmp(real, pair[1].path));
}

static void hydra_close_dev(struct hydra *h, bool restore)
{
	pthread_mutex_lock(&hydra_hid_lock);
	if (h->open) {
		/* another source of this process still reads it (a reload): leave the mode alone */
		if (--h->open->users)
			restore = false;
		else
			restore = restore && h->open->found_gamepad;
		h->open = NULL;
	} else {
		restore = restore && h->found_gamepad;
	}
	if (restore && h->ctrl) {
		uint8_t rep[HYDRA_FEATURE_LEN];

		/* leave it as we found it: a gamepad for the next program */
		hydra_feature(rep, false);
		if (hid_send_feature_report(h->ctrl, rep, sizeof(rep)) < 0)
			device_note(&h->dev, LOG_WARNING, "[source %s] Razer Hydra: back to gamepad mode failed: %s",
				    h->dev.t->name, hydra_errstr(h->ctrl));
		else
			device_note(&h->dev, LOG_INFO, "[source %s] Razer Hydra: back in gamepad mode", h->dev.t->name);
	}
	if (h->ctrl && !h->ctrl_is_data)
		hid_close(h->ctrl);
	if (h->data)
		hid_close(h->data);
	h->data = h->ctrl = NULL;
	pthread_mutex_unlock(&hydra_hid_lock);
}

/* opens the wanted Hydra; 0, -ENOENT (none there) or another negative errno (noted) */
static int hydra_open_dev(struct hydra *h)
{
	const struct cfg_source *cfg = h->dev.t->cfg;
	struct hydra_node found[8][2];
	int n = hydra_find(opts_of(cfg)->hid_interface, opts_of(cfg)->control_interface, found, 8), k, e;

	for (k = 0; k < n; k++)
		if (hydra_wanted(opts_of(cfg)->dev.device, found[k]))
			break;
	if (k == n)
		return -ENOENT;
	if (!found[k][1].path[0]) {
		device_set_status(&h->dev, "Razer Hydra on %s: no node for the control interface %d", found[k][0].path,
				  opts_of(cfg)->control_interface);
		return -ENODEV;
	}
	pthread_mutex_lock(&hydra_hid_lock);
	errno = 0;
	h->data = hid_open_path(found[k][0].path);
	e = errno;
	h->ctrl_is_data = opts_of(cfg)->control_interface == opts_of(cfg)->hid_interface;
	if (h->data && !h->ctrl_is_data) {
		errno = 0;
		h->ctrl = hid_open_path(found[k][1].path);
		e = errno;
		if (!h->ctrl) {
			hid_close(h->data);
			h->data = NULL;
		}
	} else {
		h->ctrl = h->data;
	}
	pthread_mutex_unlock(&hydra_hid_lock);
	if (!h->data) {
		const char *bad = found[k][h->ctrl_is_data ? 0 : 1].path;

		device_set_status(&h->dev, "Razer Hydra: cannot open %s: %s", bad, e ? strerror(e) : "failed");
		if (!strcmp(h->told, bad) && h->told_errno == e)
			return e ? -e : -EIO;
		snprintf(h->told, sizeof(h->told), "%s", bad);
		h->told_errno = e;
		device_note(&h->dev, LOG_ERR, "[source %s] Razer Hydra: cannot open %s: %s%s", h->dev.t->name, bad,
			    e ? strerror(e) : "failed",
			    e == EACCES || e == EPERM ? " (install systemd/60-avatargw.rules and be in the group "
							"avatargw: README, Setting up a tracker)"
						      : "");
		return e ? -e : -EIO;
	}
	snprintf(h->path, sizeof(h->path), "%s", found[k][0].path);
	snprintf(h->port, sizeof(h->port), "%s", found[k][0].port[0] ? found[k][0].port : "?");
	h->told[0] = '\0';
	return 0;
}

/* reads until a motion report comes or ms pass; 1: motion report fed, 0: none, -1: the device is gone */
static int hydra_await_motion(struct hydra *h, int ms)
{
	uint64_t end = mono_ns() + (uint64_t)ms * 1000000ull;
	uint8_t buf[64];

	while (!device_stopping(&h->dev)) {
		uint64_t now = mono_ns();
		int left = now >= end ? 0 : (int)((end - now) / 1000000ull), n;

		if (now >= end)
			return 0;
		n = hid_read_timeout(h->data, buf, sizeof(buf), left < 100 ? left + 1 : 100);
		if (n < 0)
			return -1;
		if (n == HYDRA_REPORT_LEN && device_feed(&h->dev, buf, (size_t)n) > 0)
			return 1;
		/* gamepad reports, or nothing: keep waiting */
	}
	return 0;
}

/* into motion mode; 1: reports flow, 0: stopping, -1: the device is gone */
static int hydra_handshake(struct hydra *h, bool first)
{
	uint8_t rep[HYDRA_FEATURE_LEN], got[HYDRA_FEATURE_LEN];
	int rc;

	device_set_link(&h->dev, DEVICE_STARTING);
	h->dev.codec->reset(h->dev.codec_st);
	device_set_status(&h->dev, "Razer Hydra on %s (USB port %s): probing", h->path, h->port);
	rc = hydra_await_motion(h, hydra_timing.probe_ms);
	if (rc || device_stopping(&h->dev))
		return rc;
	if (first) {
		h->found_gamepad = true;
		pthread_mutex_lock(&hydra_hid_lock);
		if (h->open)
			h->open->found_gamepad = true;
		pthread_mutex_unlock(&hydra_hid_lock);
	}
	for (h->attempts = 1; !device_stopping(&h->dev); h->attempts++) {
		h->requests++;
		hydra_feature(rep, true);
		if (hid_send_feature_report(h->ctrl, rep, sizeof(rep)) < 0) {
			device_note(&h->dev, LOG_WARNING,
				    "[source %s] Razer Hydra on %s: the motion-mode request failed: %s", h->dev.t->name,
				    h->path, hydra_errstr(h->ctrl));
		} else {
			/* as VRPN and Monado do: read the feature report back, which some firmware wants */
			memset(got, 0, sizeof(got));
			hid_get_feature_report(h->ctrl, got, sizeof(got));
		}
		device_set_status(&h->dev,
				  "Razer Hydra on %s (USB port %s): in gamepad mode, motion-mode request %u sent",
				  h->path, h->port, h->attempts);
		rc = hydra_await_motion(h, hydra_timing.retry_ms);
		if (rc)
			return rc;
		device_note(&h->dev, LOG_WARNING,
			    "[source %s] Razer Hydra on %s: still no motion report %d ms after motion-mode request %u; "
			    "asking again",
			    h->dev.t->name, h->path, hydra_timing.retry_ms, h->attempts);
	}
	return 0;
}

/* reads motion reports until the device goes (-1), stalls or leaves motion mode (0) or the source stops (0) */
static int hydra_stream(struct hydra *h)
{
	uint64_t last = mono_ns();
	uint8_t buf[64];
	int bad = 0;

	while (!device_stopping(&h->dev)) {
		int n = hid_read_timeout(h->data, buf, sizeof(buf), 100);
		uint64_t now = mono_ns();

		if (n < 0)
			return -1;
		if (n > 0 && device_feed(&h->dev, buf, (size_t)n) > 0) {
			last = now;
			bad = 0;
			continue;
		}
		if (n > 0 && n != HYDRA_REPORT_LEN && ++bad >= hydra_timing.bad_run) {
			device_note(&h->dev, LOG_WARNING,
				    "[source %s] Razer Hydra on %s: %d reports of the wrong length in a row: it left "
				    "motion mode",
				    h->dev.t->name, h->path, bad);
			return 0;
		}
		if (now - last > (uint64_t)hydra_timing.stall_ms * 1000000ull) {
			device_note(&h->dev, LOG_WARNING, "[source %s] Razer Hydra on %s: no motion report for %d ms",
				    h->dev.t->name, h->path, hydra_timing.stall_ms);
			return 0;
		}
	}
	return 0;
}

static void hydra_run(struct device *d)
{
	struct hydra *h = d->drv;
	bool told_missing = false;

	while (!device_stopping(d)) {
		bool first = true;
		int rc = hydra_open_dev(h);

		device_set_link(d, DEVICE_DOWN);
		if (rc == -ENOENT) {
			device_set_status(
				d, "no Razer Hydra%s%s found; looking every %d ms",
				strcmp(opts_of(d->t->cfg)->dev.device, "auto") ? " at " : "",
				strcmp(opts_of(d->t->cfg)->dev.device, "auto") ? opts_of(d->t->cfg)->dev.device : "",
				hydra_timing.search_ms);
			if (!told_missing)
				device_note(d, LOG_WARNING,
					    "[source %s] no Razer Hydra (1532:0300) found; waiting for one",
					    d->t->name);
			told_missing = true;
			device_sleep_ms(d, hydra_timing.search_ms);
			continue;
		}
		if (rc) {
			/* present but not usable (permissions, a node missing): try again, less often */
			device_sleep_ms(d, 1000);
			continue;
		}
		told_missing = false;
		{
			bool shared;

			pthread_mutex_lock(&hydra_hid_lock);
			h->open = hydra_open_get(h->path, &shared);
			/* opened by another source of ours already (a reload): how that one found it counts */
			h->found_gamepad = shared && h->open->found_gamepad;
			pthread_mutex_unlock(&hydra_hid_lock);
		}
		device_note(d, LOG_INFO, "[source %s] Razer Hydra on %s (USB port %s) opened", d->t->name, h->path,
			    h->port);
		for (;;) {
			rc = hydra_handshake(h, first);
			if (rc <= 0)
				break;
			if (!first || h->ever_up)
				ctr_add(&d->t->st.reconnects, 1);
			first = false;
			h->ever_up = true;
			device_set_link(d, DEVICE_UP);
			device_set_status(d, "Razer Hydra on %s (USB port %s): motion mode (%s)", h->path, h->port,
					  h->found_gamepad ? "switched from gamepad mode" : "found in motion mode");
			device_note(d, LOG_INFO, "[source %s] Razer Hydra on %s: motion reports flowing (%s)",
				    d->t->name, h->path,
				    h->found_gamepad ? "switched from gamepad mode" : "was in motion mode");
			rc = hydra_stream(h);
			if (rc < 0)
				break;
		}
		device_set_link(d, DEVICE_DOWN);
		if (rc < 0) {
			device_note(d, LOG_ERR, "[source %s] Razer Hydra on %s: %s: unplugged? Looking for it again",
				    d->t->name, h->path, hydra_errstr(h->data));
			device_set_status(d, "Razer Hydra on %s lost; looking for it", h->path);
		}
		/* an unplugged device cannot be told anything; one that is still there goes back to gamepad mode */
		hydra_close_dev(h, rc >= 0);
	}
}

/* ---- the driver ------------------------------------------------------------------------ */

static int hydra_sensor_count(const struct cfg_source *cfg)
{
	(void)cfg;
	return 2;
}

static void hydra_sensor_name(const struct cfg_source *cfg, int i, char *buf, size_t len)
{
	(void)cfg;
	snprintf(buf, len, "%s", hydra_sensors[i]);
}

static int hydra_open(struct tracker *t, char *err, size_t errlen)
{
	int rc = device_drv_open(t, sizeof(struct hydra), &hydra_codec, 2, err, errlen);

	/* its close is device_drv_close: joining the thread restores gamepad mode on its way out */
	return rc ? rc : device_drv_start(t, hydra_run, "agw-hydra", err, errlen);
}

/* the device comes first: the device_drv_* entries reach it through t->priv */
_Static_assert(offsetof(struct hydra, dev) == 0, "struct hydra begins with its struct device");

static int hydra_list(FILE *out)
{
	struct hydra_node found[8][2];
	int n = hydra_find(0, 1, found, 8);

	for (int k = 0; k < n; k++) {
		hid_device *h;
		int e;

		fprintf(out,
			"Razer Hydra (1532:0300) on USB port %s: motion reports on %s (interface 0), "
			"mode switch on %s (interface 1)\n",
			found[k][0].port[0] ? found[k][0].port : "?", found[k][0].path,
			found[k][1].path[0] ? found[k][1].path : "(none)");
		pthread_mutex_lock(&hydra_hid_lock);
		errno = 0;
		h = hid_open_path(found[k][0].path);
		e = errno;
		if (h)
			hid_close(h);
		pthread_mutex_unlock(&hydra_hid_lock);
		if (!h)
			fprintf(out, "  cannot open it: %s%s\n", e ? strerror(e) : "failed",
				e == EACCES || e == EPERM
					? " (udev rule and group avatargw: README, Setting up a tracker)"
					: "");
		char name[16];

		snprintf(name, sizeof(name), n > 1 ? "hydra%d" : "hydra", k);
		fprintf(out, "  [source %s]\n  type = hydra\n  device = %s\n", name,
			found[k][0].port[0] ? found[k][0].port : found[k][0].path);
		fprintf(out, "  ; its sensors: %s/left and %s/right (with buttons, joystick and trigger)\n\n", name,
			name);
	}
	return n;
}

const struct tracker_driver hydra_driver = {
	.type = { CFG_TYPE("hydra", "Razer Hydra over hidapi (hidraw): two wands, buttons, joysticks, triggers",
			   hydra_keys, struct hydra_opts),
		  CFG_SHARED(device_keys), .check = device_check, .sensor_count = hydra_sensor_count,
		  .sensor_name = hydra_sensor_name },
	.open = hydra_open,
	.close = device_drv_close,
	.poll = device_drv_poll,
	.fd = device_drv_fd,
	.status = device_drv_status,
	.note = device_drv_note,
	.list_devices = hydra_list,
};
