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

#include "base/log.h"
#include "wire/can_port.h"
#include "wire/cancodec.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

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
	return cfg->sensors;
}

static void can_in_sensor_name(const struct cfg_source *cfg, int i, char *buf, size_t len)
{
	(void)cfg;
	snprintf(buf, len, "pose%d", i);
}

static int can_in_check(const struct cfg_source *cfg, char *err, size_t errlen)
{
	long max = cfg->extended_ids ? CAN_EFF_MASK : CAN_SFF_MASK;
	long o0 = cfg->ori_id, o1 = o0 + cfg->sensors - 1, p0 = cfg->pos_id, p1 = p0 + cfg->sensors - 1;

	if (!cfg->interface[0]) {
		snprintf(err, errlen, "interface: missing (a CAN interface such as can0)");
		return -1;
	}
	if (o1 > max || p1 > max) {
		snprintf(err, errlen,
			 "orientation_id, position_id: %d sensors need identifiers up to 0x%lX, above "
			 "0x%lX (set extended_ids = yes for 29-bit identifiers)",
			 cfg->sensors, o1 > p1 ? o1 : p1, max);
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
	canid_t eff = cfg->extended_ids ? CAN_EFF_FLAG : 0;
	size_t n = (size_t)cfg->sensors;
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
		.ori_id = (canid_t)cfg->ori_id | eff,
		.pos_id = cfg->pos_id < 0 ? CANCODEC_NO_ID : (canid_t)cfg->pos_id | eff,
		.n = cfg->sensors,
		.quat_scale = cfg->quat_scale,
		.xyzw = cfg->quat_order == CFG_QUAT_XYZW,
		.pos_scale = cfg->pos_scale,
	};
	if (can_port_open(&c->port, cfg->interface, true, why, sizeof(why))) {
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
		fprintf(out, ",\"can\":{\"interface\":\"%s\",\"state\":\"%s\",\"why\":\"", t->cfg->interface,
			c->disabled ? "disabled" : "open");
		for (const char *s = c->disabled ? c->why : e ? strerror(e) : ""; *s; s++)
			fprintf(out, *s == '"' || *s == '\\' ? "\\%c" : "%c", *s);
		fprintf(out, "\",\"frames\":%llu,\"unknown_id\":%llu,\"bad_length\":%llu,\"bad_value\":%llu}",
			(unsigned long long)ctr_get(&c->frames), (unsigned long long)ctr_get(&c->unknown_id),
			(unsigned long long)ctr_get(&c->bad_length), (unsigned long long)ctr_get(&c->bad_value));
		return;
	}
	if (c->disabled) {
		fprintf(out, "  %s: disabled: %s\n", t->name, c->why);
		return;
	}
	fprintf(out, "  %s: CAN %s: %llu frames, %llu of other identifiers, %llu of a wrong length, %llu bad values\n",
		t->name, t->cfg->interface, (unsigned long long)ctr_get(&c->frames),
		(unsigned long long)ctr_get(&c->unknown_id), (unsigned long long)ctr_get(&c->bad_length),
		(unsigned long long)ctr_get(&c->bad_value));
}

const struct tracker_driver can_driver = {
	.name = "can",
	.summary = "sensor orientations (int16 quaternions) and positions from SocketCAN frames",
	.sensor_count = can_in_sensor_count,
	.sensor_name = can_in_sensor_name,
	.check = can_in_check,
	.open = can_in_open,
	.close = can_in_close,
	.poll = can_in_poll,
	.fd = can_in_fd,
	.report = can_in_report,
};
