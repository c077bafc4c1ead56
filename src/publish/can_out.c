// SPDX-License-Identifier: MIT
/*
 * can_out.c - joint angles as CAN frames (wire/cancodec.h, docs/CAN.md).
 *
 * Each published avatar gets CANCODEC_FRAMES frames per command at its own
 * block of identifiers: the four joint frames first, the STATUS frame last,
 * so a receiver that acts on STATUS already holds the angles of the same
 * command. Writes are non-blocking on the loop thread; a full queue
 * (ENOBUFS on a real interface, EAGAIN on a socketpair) drops the rest of
 * that avatar's command, counted.
 *
 * Safe mode is for driving hardware. A command goes out only when the frame
 * is fresh, solved and complete: no STALE, HELD or UNREACHED flag, every
 * angle finite, and the avatar's joint limits known (from its DESCRIBE,
 * which the loop sends before the first frame). Each angle is clamped to
 * its limits, then moved at most max_speed times the time since the last
 * command towards its target; that time counts at most one nominal period
 * (decimate / rate from the DESCRIBE), so after a pause the command ramps
 * from where it stopped instead of jumping. The first command after start
 * has nothing to ramp from and is sent as it is (clamped).
 *
 * When the kernel has no CAN or the interface is missing, open() logs one
 * line and the output stays disabled: the daemon carries on without it.
 */
#include "publish/output.h"
#include "base/json.h"
#include "publish/can_out.h"
#include "base/clock.h"

#include "avatargw/wire.h"
#include "base/log.h"
#include "ik/ik.h"
#include "wire/can_port.h"
#include "wire/cancodec.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static const struct cfg_key can_keys[] = {
	{ .name = "interface",
	  .kind = CFG_STR,
	  CFG_AT(struct can_out_opts, interface),
	  .missing = "a CAN interface such as can0",
	  .doc = "SocketCAN interface to send on (can0), or fd:N for an inherited descriptor (required)" },
	{ .name = "base_id",
	  .kind = CFG_INT,
	  CFG_AT(struct can_out_opts, base_id),
	  .min = 0,
	  .max = 536870911,
	  .def = "0x100",
	  .doc = "CAN identifier of the first avatar's status frame; its joint frames follow (docs/CAN.md)" },
	{ .name = "extended_ids",
	  .kind = CFG_BOOL,
	  CFG_AT(struct can_out_opts, extended_ids),
	  .def = "no",
	  .doc = "29-bit CAN identifiers instead of 11-bit" },
	{ .name = "safe",
	  .kind = CFG_BOOL,
	  CFG_AT(struct can_out_opts, safe),
	  .def = "yes",
	  .doc = "clamp to the joint limits, limit the speed, send nothing stale, held, unreached or unknown" },
	{ .name = "max_speed",
	  .kind = CFG_DEG,
	  CFG_AT(struct can_out_opts, max_speed),
	  .min = 1,
	  .max = 3600,
	  .def = "90",
	  .unit = "deg/s",
	  .doc = "safe mode: fastest change of any joint's command" },
};

/* the identifiers of n avatars exist (8 per avatar, 5 used: docs/CAN.md); -1 and why if not */
static int id_room(const struct can_out_opts *opt, long n, char *why, size_t len)
{
	long max = opt->extended_ids ? 0x1FFFFFFFL : 0x7FFL, last = opt->base_id + 8 * (n - 1) + 4;

	if (!n || last <= max)
		return 0;
	snprintf(why, len, "base_id: %ld avatars need identifiers up to 0x%lX, above 0x%lX%s", n, last, max,
		 opt->extended_ids ? "" : " (extended_ids = yes gives 29 bits)");
	return -1;
}

/* at configuration time: the configured avatars and [site]'s slots */
static int can_out_check(const struct config *c, const void *section, const char **key, char *why, size_t len)
{
	const struct cfg_output *o = section;

	*key = "type";
	return id_room(o->opt, cfg_output_avatars(c, o), why, len);
}

static const struct can_out_opts *opts_of(const struct cfg_output *c)
{
	return c->opt;
}

struct can_avatar {
	double lo[WIRE_JOINTS], hi[WIRE_JOINTS]; /* rad, from the DESCRIBE */
	bool have_limits;
	double period_s;	 /* nominal time between commands */
	double cmd[WIRE_JOINTS]; /* the last command sent, rad */
	bool have_cmd;
	uint64_t last_ns; /* when it was sent */
	uint8_t counter;
};

struct can_out {
	struct can_port port;
	bool disabled;
	char why[192];
	char iface[CFG_NAME_MAX];
	canid_t id0; /* the first avatar's STATUS identifier, with CAN_EFF_FLAG */
	int n;	     /* avatars published */
	int *slot;   /* per avatar index: its block, or -1 */
	struct can_avatar *av;
	_Atomic uint64_t commands;  /* commands sent whole */
	_Atomic uint64_t withheld;  /* safe mode: frames not turned into a command */
	_Atomic uint64_t no_limits; /* of those: the joint limits were not known yet */
	_Atomic uint64_t limited;   /* commands with a joint clamped or slowed */
};

static void free_priv(struct can_out *c)
{
	if (!c)
		return;
	can_port_close(&c->port);
	free(c->slot);
	free(c->av);
	free(c);
}

static int can_out_open(struct output *o, char *err, size_t errlen)
{
	const struct cfg_output *cfg = o->cfg;
	struct can_out *c = calloc(1, sizeof(*c));
	char why[160];
	int rc;

	if (!c)
		return -ENOMEM;
	c->port.fd = -1;
	snprintf(c->iface, sizeof(c->iface), "%s", opts_of(cfg)->interface);
	c->id0 = (canid_t)opts_of(cfg)->base_id | (opts_of(cfg)->extended_ids ? CAN_EFF_FLAG : 0);
	c->slot = calloc((size_t)o->n_avatars + 1, sizeof(*c->slot));
	c->av = calloc((size_t)o->n_avatars + 1, sizeof(*c->av));
	if (!c->slot || !c->av) {
		free_priv(c);
		snprintf(err, errlen, "[output %s]: out of memory", cfg->name);
		return -ENOMEM;
	}
	for (int i = 0; i < o->n_avatars; i++)
		c->slot[i] = o->wants[i] ? c->n++ : -1;
	/* at start: every avatar carried, a replayed recording's remote avatars too */
	if (id_room(opts_of(cfg), c->n, why, sizeof(why))) {
		snprintf(err, errlen, "[output %s]: %s", cfg->name, why);
		free_priv(c);
		return -EINVAL;
	}
	rc = can_port_open(&c->port, opts_of(cfg)->interface, false, why, sizeof(why));
	if (rc) {
		/* not a reason to stop the daemon: this output stays quiet, the others run */
		c->disabled = true;
		snprintf(c->why, sizeof(c->why), "%s", why);
		pr_warning("output %s: %s: CAN output disabled, the daemon carries on without it", cfg->name, why);
	}
	o->priv = c;
	return 0;
}

static void can_out_close(struct output *o)
{
	free_priv(o->priv);
	o->priv = NULL;
}

static void take_describe(struct output *o, struct can_avatar *a, const struct out_msg *m)
{
	const struct wire_describe *d = m->describe;

	for (int j = 0; j < WIRE_JOINTS; j++) {
		a->lo[j] = d->joint[j].lo;
		a->hi[j] = d->joint[j].hi;
	}
	a->period_s = d->rate_hz > 0 ? (o->cfg->decimate > 1 ? o->cfg->decimate : 1) / (double)d->rate_hz : 0;
	a->have_limits = a->period_s > 0;
}

/* the command of one frame; false: withheld (safe mode) */
static bool make_command(struct can_out *c, struct output *o, struct can_avatar *a, const struct wire_frame *wf,
			 uint64_t now, double q[WIRE_JOINTS], uint8_t *flags)
{
	bool finite = true, limited = false;
	double step;

	for (int j = 0; j < WIRE_JOINTS; j++) {
		q[j] = wf->joint[j];
		finite &= isfinite(q[j]) != 0;
	}
	*flags = (uint8_t)(wf->h.flags & 0x0f) | (finite ? CANCODEC_F_VALID : 0);
	if (!opts_of(o->cfg)->safe)
		return true;
	*flags |= CANCODEC_F_SAFE;
	if (!finite || (wf->h.flags & (WIRE_F_STALE | WIRE_F_HELD | WIRE_F_UNREACHED)) || !a->have_limits) {
		ctr_add(&c->withheld, 1);
		if (!a->have_limits)
			ctr_add(&c->no_limits, 1);
		return false;
	}
	step = a->have_cmd ? opts_of(o->cfg)->max_speed * fmin((double)(now - a->last_ns) * 1e-9, a->period_s)
			   : INFINITY;
	for (int j = 0; j < WIRE_JOINTS; j++) {
		double t = fmin(fmax(q[j], a->lo[j]), a->hi[j]);

		if (t - a->cmd[j] > step && a->have_cmd)
			t = a->cmd[j] + step;
		else if (a->cmd[j] - t > step && a->have_cmd)
			t = a->cmd[j] - step;
		limited |= t != q[j];
		q[j] = t;
	}
	if (limited) {
		*flags |= CANCODEC_F_LIMITED;
		ctr_add(&c->limited, 1);
	}
	return true;
}

static void send_avatar(struct can_out *c, struct output *o, struct can_avatar *a, int k, const struct wire_frame *wf,
			uint64_t now)
{
	static const int order[CANCODEC_FRAMES] = { CANCODEC_RIGHT_1, CANCODEC_RIGHT_2, CANCODEC_LEFT_1,
						    CANCODEC_LEFT_2, CANCODEC_STATUS };
	struct cancodec_avatar ca = { 0 };
	struct can_frame f[CANCODEC_FRAMES];
	double q[WIRE_JOINTS];
	uint64_t age = UINT64_MAX;
	int sent = 0;

	if (!make_command(c, o, a, wf, now, q, &ca.flags))
		return;
	ca.counter = a->counter;
	for (int s = 0; s < WIRE_SENSORS; s++) {
		ca.sensors |= (uint8_t)((wf->sensor[s].state & 3) << (2 * s));
		if (wf->sensor[s].state != WIRE_SENSOR_MISSING && wf->sensor[s].age_100us < age)
			age = wf->sensor[s].age_100us;
	}
	ca.age_ms = age == UINT64_MAX ? 65535 : (uint16_t)(age / 10);
	ca.ik = (uint8_t)((wf->arm[WIRE_ARM_RIGHT].ik_flags & IK_REACHED ? 1 : 0) |
			  (wf->arm[WIRE_ARM_LEFT].ik_flags & IK_REACHED ? 2 : 0));
	for (int j = 0; j < WIRE_JOINTS; j++)
		ca.joint[j] = cancodec_centideg(q[j]);
	cancodec_encode_avatar(&ca, cancodec_id(c->id0, k * CANCODEC_ID_STRIDE), f);
	for (int i = 0; i < CANCODEC_FRAMES; i++) {
		int fr = order[i], rc = can_port_send(&c->port, &f[fr]);

		if (rc == -EAGAIN || rc == -ENOBUFS) {
			/* the queue is full: the rest of this command (its STATUS too) stays here */
			ctr_add(&o->st.dropped, (uint64_t)(CANCODEC_FRAMES - i));
			break;
		}
		if (rc) {
			ctr_add(&o->st.errors, 1);
			atomic_store_explicit(&o->st.last_errno, -rc, memory_order_relaxed);
			break;
		}
		ctr_add(&o->st.sent, 1);
		sent++;
		/* what the receiver now holds: the ramp goes on from there */
		if (fr == CANCODEC_STATUS) {
			a->cmd[0] = q[0];
		} else {
			for (int j = 1 + 4 * (fr - 1); j < 5 + 4 * (fr - 1); j++)
				a->cmd[j] = q[j];
		}
	}
	if (sent) {
		a->last_ns = now;
		/* partly sent: the commands held differ joint by joint, still each one was sent */
		a->have_cmd = true;
	}
	if (sent == CANCODEC_FRAMES) {
		a->counter++;
		ctr_add(&c->commands, 1);
	}
}

static void can_out_send(struct output *o, const struct out_msg *m, int n)
{
	struct can_out *c = o->priv;
	bool frames = o->cfg->decimate <= 1 || o->cycle % (uint32_t)o->cfg->decimate == 0;
	uint64_t now = 0;

	o->cycle++;
	if (c->disabled)
		return;
	for (int i = 0; i < n; i++) {
		int k = c->slot[m[i].avatar];
		struct can_avatar *a;

		if (k < 0)
			continue;
		a = &c->av[k];
		if (m[i].type == WIRE_DESCRIBE) {
			take_describe(o, a, &m[i]);
			continue;
		}
		if (!frames)
			continue;
		if (!now)
			now = mono_ns();
		send_avatar(c, o, a, k, m[i].frame, now);
	}
}

static void can_out_service(struct output *o)
{
	(void)o;
}

/* the same bus and identifiers: the new configuration goes on from the commands already sent */
static bool can_out_adopt(struct output *o, struct output *old)
{
	struct can_out *c = old->priv;
	int n = 0;

	if (!c || c->disabled || strcmp(c->iface, opts_of(o->cfg)->interface) ||
	    c->id0 != ((canid_t)opts_of(o->cfg)->base_id | (opts_of(o->cfg)->extended_ids ? CAN_EFF_FLAG : 0)) ||
	    old->n_avatars != o->n_avatars)
		return false;
	for (int i = 0; i < o->n_avatars; i++) {
		if ((c->slot[i] >= 0) != o->wants[i])
			return false;
		n += o->wants[i];
	}
	if (n != c->n)
		return false;
	o->priv = c;
	old->priv = NULL;
	return true;
}

static void can_out_report(struct output *o, FILE *out, bool json)
{
	struct can_out *c = o->priv;

	if (!c)
		return;
	if (json) {
		fputs(",\"can\":{\"interface\":", out);
		json_string(out, c->iface);
		fprintf(out, ",\"state\":\"%s\",\"why\":", c->disabled ? "disabled" : "open");
		json_string(out, c->why);
		fprintf(out, ",\"safe\":%s,\"commands\":%llu,\"withheld\":%llu,\"no_limits\":%llu,\"limited\":%llu}",
			opts_of(o->cfg)->safe ? "true" : "false",
			(unsigned long long)atomic_load_explicit(&c->commands, memory_order_relaxed),
			(unsigned long long)atomic_load_explicit(&c->withheld, memory_order_relaxed),
			(unsigned long long)atomic_load_explicit(&c->no_limits, memory_order_relaxed),
			(unsigned long long)atomic_load_explicit(&c->limited, memory_order_relaxed));
		return;
	}
	if (c->disabled) {
		fprintf(out, "  %s: disabled: %s\n", o->name, c->why);
		return;
	}
	fprintf(out, "  %s: CAN %s, safe mode %s: %llu commands, %llu withheld, %llu limited\n", o->name, c->iface,
		opts_of(o->cfg)->safe ? "on" : "off",
		(unsigned long long)atomic_load_explicit(&c->commands, memory_order_relaxed),
		(unsigned long long)atomic_load_explicit(&c->withheld, memory_order_relaxed),
		(unsigned long long)atomic_load_explicit(&c->limited, memory_order_relaxed));
}

const struct output_ops can_output_ops = {
	.type = { CFG_TYPE("can", "joint angles as SocketCAN frames", can_keys, struct can_out_opts),
		  .check = can_out_check },
	.open = can_out_open,
	.close = can_out_close,
	.send = can_out_send,
	.service = can_out_service,
	.adopt = can_out_adopt,
	.report = can_out_report,
};
