// SPDX-License-Identifier: MIT
/*
 * can_in.c - sensor poses from CAN frames (wire/cancodec.h, docs/CAN.md):
 * per sensor an orientation frame (an int16 quaternion) and, optionally, a
 * position frame, at configured identifiers.
 *
 * The port is read on the loop thread, non-blocking, up to a budget of
 * frames per cycle; its descriptor wakes an event-mode loop. A sensor's
 * pose is its newest orientation with its newest position; it is taken in
 * when a frame of either kind arrives, once both have been seen.
 *
 * What the bus carries besides our frames is counted, never taken in:
 * frames of other identifiers (normal on a shared bus: "unknown_id", not a
 * malformed sample), frames of our identifiers with a wrong length, CAN FD
 * frames, and quaternions far from unit length (malformed, logged).
 *
 * Where the kernel has no CAN or the interface is missing, open() logs one
 * line and the source is FAULTY for good (its sensors MISSING); a reload
 * tries again.
 */
#include "trackers/tracker.h"
#include "base/json.h"
#include "trackers/can_in.h"

#include "base/log.h"
#include "wire/can_port.h"
#include "wire/cancodec.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char *const e_quat[] = { "wxyz", "xyzw", NULL };

static const struct cfg_key can_keys[] = {
	{ .name = "sensors",
	  .kind = CFG_INT,
	  CFG_AT(struct can_in_opts, sensors),
	  .min = 1,
	  .max = 16,
	  .def = "1",
	  .doc = "poses the device reports; they are sensors pose0, pose1, ..." },
	{ .name = "position_scale",
	  .kind = CFG_DOUBLE,
	  CFG_AT(struct can_in_opts, pos_scale),
	  .min = 1e-9,
	  .max = 1e3,
	  .def = "0.001",
	  .unit = "m",
	  .doc = "metres per count of a position value (0.0001 for 0.1 mm)" },
	{ .name = "interface",
	  .kind = CFG_STR,
	  CFG_AT(struct can_in_opts, interface),
	  .doc = "SocketCAN interface (can0), or fd:N for an inherited descriptor (required)" },
	{ .name = "orientation_id",
	  .kind = CFG_INT,
	  CFG_AT(struct can_in_opts, ori_id),
	  .min = 0,
	  .max = 536870911,
	  .def = "0x200",
	  .doc = "CAN identifier of sensor 0's orientation frame; sensor k uses orientation_id + k" },
	{ .name = "position_id",
	  .kind = CFG_INT,
	  CFG_AT(struct can_in_opts, pos_id),
	  .min = -1,
	  .max = 536870911,
	  .def = "0x280",
	  .doc = "CAN identifier of sensor 0's position frame; sensor k uses position_id + k; -1: orientation "
		 "only" },
	{ .name = "quaternion_scale",
	  .kind = CFG_DOUBLE,
	  CFG_AT(struct can_in_opts, quat_scale),
	  .min = 1,
	  .max = 1e9,
	  .def = "32768",
	  .doc = "the count that stands for 1.0 in a quaternion component (16384 for a BNO055)" },
	{ .name = "quaternion_order",
	  .kind = CFG_ENUM,
	  CFG_AT(struct can_in_opts, quat_order),
	  .def = "wxyz",
	  .enums = e_quat,
	  .doc = "order of the four components in the orientation frame" },
	{ .name = "extended_ids",
	  .kind = CFG_BOOL,
	  CFG_AT(struct can_in_opts, extended_ids),
	  .def = "no",
	  .doc = "29-bit CAN identifiers instead of 11-bit" },
};

static const struct can_in_opts *opts_of(const struct cfg_source *c)
{
	return c->opt;
}

#define CAN_IN_BUDGET 1024 /* frames read per cycle at most */

struct can_in {
	struct can_port port;
	bool disabled; /* no CAN here, or no such interface */
	char why[192];
	bool failed; /* the port failed; reported to the loop once */
	struct cancodec_sensor_map map;
	double (*q)[4]; /* per sensor: newest orientation */
	double (*p)[3]; /* newest position */
	bool *have_q, *have_p;
	_Atomic uint64_t frames, unknown_id, bad_length, bad_value;
	_Atomic int32_t last_errno;
};

static int can_in_sensor_count(const struct cfg_source *cfg)
{
	return opts_of(cfg)->sensors;
}

static void can_in_sensor_name(const struct cfg_source *cfg, int i, char *buf, size_t len)
{
	(void)cfg;
	snprintf(buf, len, "pose%d", i);
}

static int can_in_check(const struct config *c __attribute__((unused)), const void *section,
			const char **key __attribute__((unused)), char *err, size_t errlen)
{
	const struct cfg_source *cfg = section;
	long max = opts_of(cfg)->extended_ids ? CAN_EFF_MASK : CAN_SFF_MASK;
	long o0 = opts_of(cfg)->ori_id, o1 = o0 + opts_of(cfg)->sensors - 1, p0 = opts_of(cfg)->pos_id,
	     p1 = p0 + opts_of(cfg)->sensors - 1;

	if (!opts_of(cfg)->interface[0]) {
		snprintf(err, errlen, "interface: missing (a CAN interface such as can0)");
		return -1;
	}
	if (o1 > max || p1 > max) {
		snprintf(err, errlen,
			 "orientation_id, position_id: %d sensors need identifiers up to 0x%lX, above "
			 "0x%lX (set extended_ids = yes for 29-bit identifiers)",
			 opts_of(cfg)->sensors, o1 > p1 ? o1 : p1, max);
		return -1;
	}
	if (p0 >= 0 && o0 <= p1 && p0 <= o1) {
		snprintf(err, errlen, "orientation_id, position_id: the ranges 0x%lX-0x%lX and 0x%lX-0x%lX overlap", o0,
			 o1, p0, p1);
		return -1;
	}
	return 0;
}

static void free_priv(struct can_in *c)
{
	if (!c)
		return;
	can_port_close(&c->port);
	free(c->q);
	free(c->p);
	free(c->have_q);
	free(c->have_p);
	free(c);
}

static int can_in_open(struct tracker *t, char *err, size_t errlen)
{
	const struct cfg_source *cfg = t->cfg;
	struct can_in *c = calloc(1, sizeof(*c));
	canid_t eff = opts_of(cfg)->extended_ids ? CAN_EFF_FLAG : 0;
	size_t n = (size_t)opts_of(cfg)->sensors;
	char why[160];

	if (!c)
		return -ENOMEM;
	c->port.fd = -1;
	c->q = calloc(n, sizeof(*c->q));
	c->p = calloc(n, sizeof(*c->p));
	c->have_q = calloc(n, sizeof(bool));
	c->have_p = calloc(n, sizeof(bool));
	if (!c->q || !c->p || !c->have_q || !c->have_p) {
		free_priv(c);
		snprintf(err, errlen, "[source %s]: out of memory", cfg->name);
		return -ENOMEM;
	}
	c->map = (struct cancodec_sensor_map){
		.ori_id = (canid_t)opts_of(cfg)->ori_id | eff,
		.pos_id = opts_of(cfg)->pos_id < 0 ? CANCODEC_NO_ID : (canid_t)opts_of(cfg)->pos_id | eff,
		.n = opts_of(cfg)->sensors,
		.quat_scale = opts_of(cfg)->quat_scale,
		.xyzw = opts_of(cfg)->quat_order == CFG_QUAT_XYZW,
		.pos_scale = opts_of(cfg)->pos_scale,
	};
	if (can_port_open(&c->port, opts_of(cfg)->interface, true, why, sizeof(why))) {
		c->disabled = true;
		snprintf(c->why, sizeof(c->why), "%s", why);
		pr_warning("source %s: %s: CAN source disabled (its sensors are missing), the daemon carries on",
			   cfg->name, why);
	}
	t->priv = c;
	return 0;
}

static void can_in_close(struct tracker *t)
{
	free_priv(t->priv);
	t->priv = NULL;
}

static void put_pose(struct tracker *t, struct can_in *c, int k, const struct tracker_clock *now)
{
	struct quat q = { c->q[k][0], c->q[k][1], c->q[k][2], c->q[k][3] };
	struct vec3 p = { c->p[k][0], c->p[k][1], c->p[k][2] };
	struct dq d;

	dq_from_rt(&q, &p, &d);
	tracker_put(t, k, &d, (uint64_t)((int64_t)now->mono_ns + now->real_off_ns), now->mono_ns);
}

static int can_in_poll(struct tracker *t, const struct tracker_clock *now)
{
	struct can_in *c = t->priv;
	bool positions = c->map.pos_id != CANCODEC_NO_ID;
	int got = 0;

	if (c->disabled) {
		/* FAULTY once (counted as a fault), then quiet: there is nothing to retry until a reload */
		if (!c->failed) {
			c->failed = true;
			return -ENODEV;
		}
		return 0;
	}
	for (int i = 0; i < CAN_IN_BUDGET; i++) {
		struct cancodec_sensor_value v;
		struct can_frame f;
		int rc = can_port_recv(&c->port, &f);

		if (rc == 0)
			break;
		if (rc == -EMSGSIZE) {
			ctr_add(&c->bad_length, 1);
			ctr_add(&t->st.malformed, 1);
			continue;
		}
		if (rc < 0) {
			atomic_store_explicit(&c->last_errno, -rc, memory_order_relaxed);
			if (c->failed)
				return got;
			c->failed = true;
			return rc;
		}
		c->failed = false;
		ctr_add(&c->frames, 1);
		rc = cancodec_decode_sensor(&c->map, &f, &v);
		if (rc == -ENOENT) {
			ctr_add(&c->unknown_id, 1);
			continue;
		}
		if (rc) {
			ctr_add(rc == -EBADMSG ? &c->bad_length : &c->bad_value, 1);
			ctr_add(&t->st.malformed, 1);
			continue;
		}
		if (v.kind == CANCODEC_ORIENTATION) {
			memcpy(c->q[v.sensor], v.v, sizeof(c->q[0]));
			c->have_q[v.sensor] = true;
		} else {
			memcpy(c->p[v.sensor], v.v, sizeof(c->p[0]));
			c->have_p[v.sensor] = true;
		}
		if (c->have_q[v.sensor] && (c->have_p[v.sensor] || !positions)) {
			put_pose(t, c, v.sensor, now);
			got++;
		}
	}
	return got;
}

static int can_in_fd(struct tracker *t)
{
	struct can_in *c = t->priv;

	return c->disabled ? -1 : c->port.fd;
}

static void can_in_report(struct tracker *t, FILE *out, bool json)
{
	struct can_in *c = t->priv;
	int e = atomic_load_explicit(&c->last_errno, memory_order_relaxed);

	if (json) {
		fputs(",\"can\":{\"interface\":", out);
		json_string(out, opts_of(t->cfg)->interface);
		fprintf(out, ",\"state\":\"%s\",\"why\":", c->disabled ? "disabled" : "open");
		json_string(out, c->disabled ? c->why : e ? strerror(e) : "");
		fprintf(out, ",\"frames\":%llu,\"unknown_id\":%llu,\"bad_length\":%llu,\"bad_value\":%llu}",
			(unsigned long long)ctr_get(&c->frames), (unsigned long long)ctr_get(&c->unknown_id),
			(unsigned long long)ctr_get(&c->bad_length), (unsigned long long)ctr_get(&c->bad_value));
		return;
	}
	if (c->disabled) {
		fprintf(out, "  %s: disabled: %s\n", t->name, c->why);
		return;
	}
	fprintf(out, "  %s: CAN %s: %llu frames, %llu of other identifiers, %llu of a wrong length, %llu bad values\n",
		t->name, opts_of(t->cfg)->interface, (unsigned long long)ctr_get(&c->frames),
		(unsigned long long)ctr_get(&c->unknown_id), (unsigned long long)ctr_get(&c->bad_length),
		(unsigned long long)ctr_get(&c->bad_value));
}

const struct tracker_driver can_driver = {
	.type = { CFG_TYPE("can", "sensor orientations (int16 quaternions) and positions from SocketCAN frames",
			   can_keys, struct can_in_opts),
		  .check = can_in_check, .sensor_count = can_in_sensor_count, .sensor_name = can_in_sensor_name },
	.open = can_in_open,
	.close = can_in_close,
	.poll = can_in_poll,
	.fd = can_in_fd,
	.report = can_in_report,
};
