// SPDX-License-Identifier: MIT
/*
 * modbus_in.c - poses polled from a Modbus TCP device (a robot controller's
 * tool pose, a laser tracker) with libmodbus.
 *
 * libmodbus blocks and allocates, so it lives in a thread of its own
 * started at open(): it connects, reads the registers at poll_rate (to
 * absolute deadlines), turns them into poses and hands each sensor's pose
 * to the loop through a sequence lock (base/seqlock.h); the loop's poll()
 * takes what is new and never waits.
 *
 * The register map is configured: for each sensor a position (x, y, z) and
 * an orientation (rotation vector, quaternion, roll-pitch-yaw, or none), as
 * 16- or 32-bit integers or floats with a scale; 32-bit values in any word
 * order (wire/regcodec.h). Registers that lie next to each other are read
 * in one request, so a pose whose position and orientation are adjacent
 * (Universal Robots: 400-405) is one consistent sample.
 *
 * A device that does not answer within timeout_ms, refuses the connection
 * or closes it makes the source FAULTY (its sensors MISSING) until it
 * answers again; the connection is retried after 0.2 s, doubling up to 5 s.
 * A device that answers with a Modbus exception (a wrong register map) is
 * FAULTY too, and asked again at the next poll. Values that are not finite
 * or a quaternion far from unit length are counted as malformed and dropped.
 */
#include "trackers/tracker.h"
#include "base/json.h"
#include "trackers/modbus_in.h"

#include "base/log.h"
#include "base/seqlock.h"
#include "wire/regcodec.h"

#include <modbus/modbus.h>

#include <errno.h>
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/eventfd.h>
#include <time.h>
#include <unistd.h>

static const char *const e_regtype[] = { "holding", "input", NULL };
static const char *const e_regfmt[] = { "int16", "uint16", "int32", "uint32", "float32", NULL };
static const char *const e_ori[] = { "rotvec", "quat_wxyz", "quat_xyzw", "rpy", "none", NULL };

static const struct cfg_key modbus_keys[] = {
	{ .name = "address",
	  .kind = CFG_STR,
	  CFG_AT(struct modbus_in_opts, address),
	  .doc = "host name or address of the Modbus TCP device (required)" },
	{ .name = "port",
	  .kind = CFG_INT,
	  CFG_AT(struct modbus_in_opts, port),
	  .min = 1,
	  .max = 65535,
	  .def = "502",
	  .doc = "TCP port of the Modbus device" },
	{ .name = "unit_id",
	  .kind = CFG_INT,
	  CFG_AT(struct modbus_in_opts, unit_id),
	  .min = 0,
	  .max = 255,
	  .def = "1",
	  .doc = "Modbus unit identifier of the requests" },
	{ .name = "register_type",
	  .kind = CFG_ENUM,
	  CFG_AT(struct modbus_in_opts, register_type),
	  .def = "holding",
	  .enums = e_regtype,
	  .doc = "holding (function 3) or input (function 4) registers" },
	{ .name = "sensors",
	  .kind = CFG_INT,
	  CFG_AT(struct modbus_in_opts, sensors),
	  .min = 1,
	  .max = 16,
	  .def = "1",
	  .doc = "poses the device reports; they are sensors pose0, pose1, ..." },
	{ .name = "sensor_stride",
	  .kind = CFG_INT,
	  CFG_AT(struct modbus_in_opts, sensor_stride),
	  .min = 0,
	  .max = 65535,
	  .def = "0",
	  .doc = "registers from one sensor's position (and orientation) to the next's; needed when sensors > 1" },
	{ .name = "position_register",
	  .kind = CFG_INT,
	  CFG_AT(struct modbus_in_opts, pos_register),
	  .min = 0,
	  .max = 65535,
	  .def = "0",
	  .doc = "first register of the position x, y, z (0-based protocol address)" },
	{ .name = "position_format",
	  .kind = CFG_ENUM,
	  CFG_AT(struct modbus_in_opts, pos_format),
	  .def = "int16",
	  .enums = e_regfmt,
	  .doc = "type of each position value (32-bit types take two registers)" },
	{ .name = "position_scale",
	  .kind = CFG_DOUBLE,
	  CFG_AT(struct modbus_in_opts, pos_scale),
	  .min = 1e-9,
	  .max = 1e3,
	  .def = "0.001",
	  .unit = "m",
	  .doc = "metres per count of a position value (0.0001 for 0.1 mm)" },
	{ .name = "orientation_register",
	  .kind = CFG_INT,
	  CFG_AT(struct modbus_in_opts, ori_register),
	  .min = 0,
	  .max = 65535,
	  .def = "3",
	  .doc = "first register of the orientation values (0-based protocol address)" },
	{ .name = "orientation_format",
	  .kind = CFG_ENUM,
	  CFG_AT(struct modbus_in_opts, ori_format),
	  .def = "int16",
	  .enums = e_regfmt,
	  .doc = "type of each orientation value" },
	{ .name = "orientation_scale",
	  .kind = CFG_DOUBLE,
	  CFG_AT(struct modbus_in_opts, ori_scale),
	  .min = 1e-12,
	  .max = 1e3,
	  .def = "0.001",
	  .doc = "radians per count (rotvec, rpy) or quaternion units per count (quat_*)" },
	{ .name = "orientation",
	  .kind = CFG_ENUM,
	  CFG_AT(struct modbus_in_opts, orientation),
	  .def = "rotvec",
	  .enums = e_ori,
	  .doc = "rotvec (rx ry rz, axis times angle), quat_wxyz, quat_xyzw, rpy (roll pitch yaw about fixed x, "
		 "y, z) or none" },
	{ .name = "word_order",
	  .kind = CFG_ENUM,
	  CFG_AT(struct modbus_in_opts, word_order),
	  .def = "abcd",
	  .enums = cfg_word_orders,
	  .doc = "byte order of 32-bit values over two registers, A = most significant byte" },
	{ .name = "poll_rate",
	  .kind = CFG_DOUBLE,
	  CFG_AT(struct modbus_in_opts, poll_rate),
	  .min = 0.1,
	  .max = 1000,
	  .def = "50",
	  .unit = "Hz",
	  .doc = "requests per second" },
	{ .name = "timeout_ms",
	  .kind = CFG_DOUBLE,
	  CFG_AT(struct modbus_in_opts, timeout_ms),
	  .min = 1,
	  .max = 60000,
	  .def = "200",
	  .unit = "ms",
	  .doc = "a response (or a connection) taking longer fails; the connection is then made again" },
};

static const struct modbus_in_opts *opts_of(const struct cfg_source *c)
{
	return c->opt;
}

#define MODBUS_IN_BACKOFF_MIN_NS 200000000ull  /* first retry after 0.2 s */
#define MODBUS_IN_BACKOFF_MAX_NS 5000000000ull /* then doubling up to 5 s */
#define MODBUS_IN_MAX_READS 64		       /* 16 sensors, position and orientation apart */

enum modbus_in_link { MODBUS_IN_CONNECTING, MODBUS_IN_UP, MODBUS_IN_DOWN };

/* one sensor's newest pose, as the thread hands it over */
struct modbus_in_pose {
	double q[4], p[3];
	uint64_t t_ns, arrival_ns;
};

#define MODBUS_IN_WORDS ((int)(sizeof(struct modbus_in_pose) / sizeof(uint32_t)))

struct modbus_in_slot {
	_Atomic uint32_t seq;
	_Atomic uint32_t w[MODBUS_IN_WORDS];
};

struct modbus_in_read {
	int addr, count;
};

struct modbus_in {
	/* settings */
	char name[CFG_NAME_MAX];
	char where[CFG_PATH_MAX + 16]; /* host:port, for messages */
	int n;
	uint64_t period_ns;
	int reads;
	struct modbus_in_read read[MODBUS_IN_MAX_READS];
	int lo, span;		      /* the registers read: [lo, lo + span) */
	const struct cfg_source *cfg; /* valid until close(), which joins the thread first */

	/* the thread */
	pthread_t th;
	bool started;
	pthread_mutex_t mu;
	pthread_cond_t cv;
	bool stop; /* under mu */
	modbus_t *ctx;
	uint16_t *img; /* the registers [lo, lo + span) */
	int efd;       /* readable when a poll brought poses (event-mode loops) */

	/* handed to the loop */
	struct modbus_in_slot *slot;
	_Atomic uint32_t link; /* enum modbus_in_link */
	_Atomic int32_t last_errno;
	_Atomic uint64_t polls, connects, losses, exceptions, timeouts, malformed;

	/* the loop's */
	uint32_t *seen; /* per sensor: sequence taken in */
	bool reported;	/* the current outage was returned to the loop */
	uint64_t malformed_seen;
};

static int modbus_in_sensor_count(const struct cfg_source *cfg)
{
	return opts_of(cfg)->sensors;
}

static void modbus_in_sensor_name(const struct cfg_source *cfg, int i, char *buf, size_t len)
{
	(void)cfg;
	snprintf(buf, len, "pose%d", i);
}

static int width(int fmt)
{
	return fmt == CFG_REG_INT32 || fmt == CFG_REG_UINT32 || fmt == CFG_REG_FLOAT32 ? 2 : 1;
}

static int ori_values(int ori)
{
	return ori == CFG_ORI_NONE ? 0 : ori == CFG_ORI_QUAT_WXYZ || ori == CFG_ORI_QUAT_XYZW ? 4 : 3;
}

static int modbus_in_check(const struct config *c __attribute__((unused)), const void *section,
			   const char **key __attribute__((unused)), char *err, size_t errlen)
{
	const struct cfg_source *cfg = section;
	int pn = 3 * width(opts_of(cfg)->pos_format),
	    on = ori_values(opts_of(cfg)->orientation) * width(opts_of(cfg)->ori_format);
	long last = (long)(opts_of(cfg)->sensors - 1) * opts_of(cfg)->sensor_stride;

	if (!opts_of(cfg)->address[0]) {
		snprintf(err, errlen, "address: missing (the Modbus device's host name or address)");
		return -1;
	}
	if (opts_of(cfg)->unit_id > 247 && opts_of(cfg)->unit_id != 255) {
		snprintf(err, errlen, "unit_id: %d is reserved (0-247, or 255)", opts_of(cfg)->unit_id);
		return -1;
	}
	if (opts_of(cfg)->sensors > 1 && opts_of(cfg)->sensor_stride == 0) {
		snprintf(err, errlen, "sensor_stride: missing (%d sensors need the registers from one to the next)",
			 opts_of(cfg)->sensors);
		return -1;
	}
	if (opts_of(cfg)->pos_register + last + pn > 65536 || opts_of(cfg)->ori_register + last + on > 65536) {
		snprintf(err, errlen,
			 "position_register, orientation_register: the map of %d sensors goes beyond "
			 "register 65535",
			 opts_of(cfg)->sensors);
		return -1;
	}
	for (int k = 0; k < opts_of(cfg)->sensors && on; k++) {
		long p0 = opts_of(cfg)->pos_register + (long)k * opts_of(cfg)->sensor_stride,
		     o0 = opts_of(cfg)->ori_register + (long)k * opts_of(cfg)->sensor_stride;

		if (p0 < o0 + on && o0 < p0 + pn) {
			snprintf(err, errlen,
				 "position_register, orientation_register: sensor %d's position (%ld-%ld) "
				 "and orientation (%ld-%ld) overlap",
				 k, p0, p0 + pn - 1, o0, o0 + on - 1);
			return -1;
		}
	}
	return 0;
}

static int cmp_read(const void *a, const void *b)
{
	return ((const struct modbus_in_read *)a)->addr - ((const struct modbus_in_read *)b)->addr;
}

/* the requests: every sensor's registers, adjacent ranges merged up to the 125 of one request */
static void plan_reads(struct modbus_in *m, const struct cfg_source *cfg)
{
	struct modbus_in_read r[MODBUS_IN_MAX_READS];
	int n = 0, on = ori_values(opts_of(cfg)->orientation) * width(opts_of(cfg)->ori_format);

	for (int k = 0; k < opts_of(cfg)->sensors; k++) {
		r[n++] = (struct modbus_in_read){ opts_of(cfg)->pos_register + k * opts_of(cfg)->sensor_stride,
						  3 * width(opts_of(cfg)->pos_format) };
		if (on)
			r[n++] = (struct modbus_in_read){ opts_of(cfg)->ori_register + k * opts_of(cfg)->sensor_stride,
							  on };
	}
	qsort(r, (size_t)n, sizeof(r[0]), cmp_read);
	m->reads = 0;
	for (int i = 0; i < n; i++) {
		struct modbus_in_read *last = m->reads ? &m->read[m->reads - 1] : NULL;

		if (last && r[i].addr <= last->addr + last->count &&
		    r[i].addr + r[i].count - last->addr <= MODBUS_MAX_READ_REGISTERS) {
			if (r[i].addr + r[i].count > last->addr + last->count)
				last->count = r[i].addr + r[i].count - last->addr;
			continue;
		}
		m->read[m->reads++] = r[i];
	}
	m->lo = m->read[0].addr;
	m->span = 0;
	for (int i = 0; i < m->reads; i++)
		if (m->read[i].addr + m->read[i].count - m->lo > m->span)
			m->span = m->read[i].addr + m->read[i].count - m->lo;
}

static double reg_value(const uint16_t *r, int fmt, int order)
{
	switch (fmt) {
	case CFG_REG_INT16:
		return (int16_t)r[0];
	case CFG_REG_UINT16:
		return r[0];
	case CFG_REG_INT32:
		return (int32_t)regcodec_get_u32(r, order);
	case CFG_REG_UINT32:
		return regcodec_get_u32(r, order);
	default:
		return regcodec_get_f32(r, order);
	}
}

bool modbus_in_decode_pose(const struct modbus_in_opts *o, const uint16_t *img, int lo, int k, double q[4], double p[3])
{
	int pw = width(o->pos_format), ow = width(o->ori_format), nv = ori_values(o->orientation);
	const uint16_t *pr = img + (o->pos_register + k * o->sensor_stride - lo);
	const uint16_t *orr = img + (o->ori_register + k * o->sensor_stride - lo);
	double v[4] = { 0, 0, 0, 0 }, n;

	for (int i = 0; i < 3; i++) {
		p[i] = reg_value(pr + i * pw, o->pos_format, o->word_order) * o->pos_scale;
		if (!isfinite(p[i]))
			return false;
	}
	for (int i = 0; i < nv; i++) {
		v[i] = reg_value(orr + i * ow, o->ori_format, o->word_order) * o->ori_scale;
		if (!isfinite(v[i]))
			return false;
	}
	switch (o->orientation) {
	case CFG_ORI_ROTVEC:
		/* axis times angle, radians (Universal Robots' rx ry rz) */
		n = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
		q[0] = cos(n / 2);
		for (int i = 0; i < 3; i++)
			q[1 + i] = n > 1e-12 ? sin(n / 2) * v[i] / n : 0;
		return true;
	case CFG_ORI_QUAT_WXYZ:
	case CFG_ORI_QUAT_XYZW:
		n = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2] + v[3] * v[3]);
		if (!(n > 0.8 && n < 1.2))
			return false;
		for (int i = 0; i < 4; i++)
			q[i] = (o->orientation == CFG_ORI_QUAT_XYZW ? v[(i + 3) % 4] : v[i]) / n;
		return true;
	case CFG_ORI_RPY: {
		/* R = Rz(yaw) Ry(pitch) Rx(roll): roll, pitch, yaw about the fixed x, y, z axes */
		double cr = cos(v[0] / 2), sr = sin(v[0] / 2), cp = cos(v[1] / 2), sp = sin(v[1] / 2);
		double cy = cos(v[2] / 2), sy = sin(v[2] / 2);

		q[0] = cy * cp * cr + sy * sp * sr;
		q[1] = cy * cp * sr - sy * sp * cr;
		q[2] = cy * sp * cr + sy * cp * sr;
		q[3] = sy * cp * cr - cy * sp * sr;
		return true;
	}
	default:
		q[0] = 1;
		q[1] = q[2] = q[3] = 0;
		return true;
	}
}

/* the pose of sensor k from the register image; false: malformed */
static bool decode_pose(const struct modbus_in *m, int k, struct modbus_in_pose *out)
{
	return modbus_in_decode_pose(opts_of(m->cfg), m->img, m->lo, k, out->q, out->p);
}

static uint64_t clock_ns(clockid_t id)
{
	struct timespec ts;

	clock_gettime(id, &ts);
	return (uint64_t)ts.tv_sec * 1000000000ull + (uint64_t)ts.tv_nsec;
}

/* sleeps until the CLOCK_MONOTONIC time t, or until stopped; returns true if stopped */
static bool wait_until(struct modbus_in *m, uint64_t t)
{
	struct timespec ts = { (time_t)(t / 1000000000ull), (long)(t % 1000000000ull) };
	bool stop;

	pthread_mutex_lock(&m->mu);
	while (!m->stop && pthread_cond_timedwait(&m->cv, &m->mu, &ts) != ETIMEDOUT)
		;
	stop = m->stop;
	pthread_mutex_unlock(&m->mu);
	return stop;
}

static void bump(_Atomic uint64_t *c)
{
	/* the thread is the one writer of these */
	ctr_add(c, 1);
}

static void set_link(struct modbus_in *m, int link, int err)
{
	int prev = (int)atomic_load_explicit(&m->link, memory_order_relaxed);

	if (err)
		atomic_store_explicit(&m->last_errno, err, memory_order_relaxed);
	atomic_store_explicit(&m->link, (uint32_t)link, memory_order_release);
	/* one line per change, not per attempt */
	if (link == MODBUS_IN_UP && prev != MODBUS_IN_UP)
		pr_info("source %s: Modbus %s: %s", m->name, m->where,
			prev == MODBUS_IN_DOWN ? "answering again" : "connected");
	else if (link == MODBUS_IN_DOWN && prev != MODBUS_IN_DOWN)
		pr_warning("source %s: Modbus %s: %s; retrying (after 0.2 s, then up to every 5 s)", m->name, m->where,
			   modbus_strerror(err));
}

/* one poll: 0, or the errno of the failure */
static int poll_device(struct modbus_in *m)
{
	const struct cfg_source *cfg = m->cfg;
	uint64_t arrival, real;

	for (int i = 0; i < m->reads; i++) {
		const struct modbus_in_read *r = &m->read[i];
		uint16_t *dst = m->img + (r->addr - m->lo);
		int rc = opts_of(cfg)->register_type == CFG_REGS_INPUT
				 ? modbus_read_input_registers(m->ctx, r->addr, r->count, dst)
				 : modbus_read_registers(m->ctx, r->addr, r->count, dst);

		if (rc != r->count)
			return rc < 0 ? errno : EMBBADDATA;
	}
	arrival = clock_ns(CLOCK_MONOTONIC);
	real = clock_ns(CLOCK_REALTIME);
	for (int k = 0; k < m->n; k++) {
		struct modbus_in_pose p;
		uint32_t w[MODBUS_IN_WORDS];

		if (!decode_pose(m, k, &p)) {
			bump(&m->malformed);
			continue;
		}
		p.t_ns = real;
		p.arrival_ns = arrival;
		memcpy(w, &p, sizeof(w));
		seqlock_write(&m->slot[k].seq, m->slot[k].w, w, MODBUS_IN_WORDS);
	}
	bump(&m->polls);
	{
		uint64_t one = 1;

		if (write(m->efd, &one, sizeof(one)) < 0 && errno != EAGAIN)
			return errno;
	}
	return 0;
}

static bool is_exception(int err)
{
	/* the device answered, with a Modbus exception code */
	return err > MODBUS_ENOBASE && err < MODBUS_ENOBASE + MODBUS_EXCEPTION_MAX;
}

static void *modbus_in_thread(void *arg)
{
	struct modbus_in *m = arg;
	uint64_t backoff = MODBUS_IN_BACKOFF_MIN_NS, next = clock_ns(CLOCK_MONOTONIC);
	bool connected = false;

	for (;;) {
		uint64_t now;
		int err;

		if (!connected) {
			if (modbus_connect(m->ctx)) {
				set_link(m, MODBUS_IN_DOWN, errno);
				if (wait_until(m, clock_ns(CLOCK_MONOTONIC) + backoff))
					break;
				backoff =
					backoff * 2 > MODBUS_IN_BACKOFF_MAX_NS ? MODBUS_IN_BACKOFF_MAX_NS : backoff * 2;
				continue;
			}
			connected = true;
			bump(&m->connects);
			next = clock_ns(CLOCK_MONOTONIC);
		}
		err = poll_device(m);
		if (!err) {
			backoff = MODBUS_IN_BACKOFF_MIN_NS;
			set_link(m, MODBUS_IN_UP, 0);
		} else if (is_exception(err)) {
			/* the connection is fine, the map is not: FAULTY, asked again next time */
			bump(&m->exceptions);
			set_link(m, MODBUS_IN_DOWN, err);
		} else {
			if (err == ETIMEDOUT)
				bump(&m->timeouts);
			bump(&m->losses);
			set_link(m, MODBUS_IN_DOWN, err);
			modbus_close(m->ctx);
			connected = false;
			/* reconnect at once the first time: a device that restarted is back in no time */
			continue;
		}
		now = clock_ns(CLOCK_MONOTONIC);
		next += m->period_ns;
		if (next < now)
			next = now + m->period_ns; /* late: skip, do not burst */
		if (wait_until(m, next))
			break;
	}
	if (connected)
		modbus_close(m->ctx);
	return NULL;
}

static void free_priv(struct modbus_in *m)
{
	if (!m)
		return;
	if (m->started) {
		pthread_mutex_lock(&m->mu);
		m->stop = true;
		pthread_cond_signal(&m->cv);
		pthread_mutex_unlock(&m->mu);
		pthread_join(m->th, NULL);
		pthread_cond_destroy(&m->cv);
		pthread_mutex_destroy(&m->mu);
	}
	if (m->ctx)
		modbus_free(m->ctx);
	if (m->efd >= 0)
		close(m->efd);
	free(m->img);
	free(m->slot);
	free(m->seen);
	free(m);
}

static int modbus_in_open(struct tracker *t, char *err, size_t errlen)
{
	const struct cfg_source *cfg = t->cfg;
	struct modbus_in *m = calloc(1, sizeof(*m));
	char port[8];
	pthread_condattr_t ca;
	uint32_t to_ms = (uint32_t)opts_of(cfg)->timeout_ms;
	int rc;

	if (!m)
		return -ENOMEM;
	m->efd = eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
	snprintf(m->name, sizeof(m->name), "%s", cfg->name);
	snprintf(m->where, sizeof(m->where), "%s:%d", opts_of(cfg)->address, opts_of(cfg)->port);
	m->cfg = cfg;
	m->n = opts_of(cfg)->sensors;
	m->period_ns = (uint64_t)(1e9 / opts_of(cfg)->poll_rate);
	plan_reads(m, cfg);
	m->img = calloc((size_t)m->span, sizeof(uint16_t));
	m->slot = calloc((size_t)m->n, sizeof(*m->slot));
	m->seen = calloc((size_t)m->n, sizeof(*m->seen));
	snprintf(port, sizeof(port), "%d", opts_of(cfg)->port);
	/* the _pi variant takes host names and IPv6 addresses */
	m->ctx = modbus_new_tcp_pi(opts_of(cfg)->address, port);
	if (!m->img || !m->slot || !m->seen || !m->ctx || m->efd < 0) {
		snprintf(err, errlen, "[source %s]: %s", cfg->name, m->ctx ? "out of memory" : modbus_strerror(errno));
		free_priv(m);
		return -ENOMEM;
	}
	if (modbus_set_slave(m->ctx, opts_of(cfg)->unit_id) ||
	    modbus_set_response_timeout(m->ctx, to_ms / 1000, (to_ms % 1000) * 1000 + (to_ms ? 0 : 1000))) {
		snprintf(err, errlen, "[source %s]: %s", cfg->name, modbus_strerror(errno));
		free_priv(m);
		return -EINVAL;
	}
	/* a byte late by the whole timeout is as good as lost */
	modbus_set_byte_timeout(m->ctx, to_ms / 1000, (to_ms % 1000) * 1000);
	pthread_condattr_init(&ca);
	pthread_condattr_setclock(&ca, CLOCK_MONOTONIC);
	pthread_mutex_init(&m->mu, NULL);
	pthread_cond_init(&m->cv, &ca);
	pthread_condattr_destroy(&ca);
	rc = pthread_create(&m->th, NULL, modbus_in_thread, m);
	if (rc) {
		snprintf(err, errlen, "[source %s]: thread: %s", cfg->name, strerror(rc));
		pthread_cond_destroy(&m->cv);
		pthread_mutex_destroy(&m->mu);
		free_priv(m);
		return -rc;
	}
	m->started = true;
	t->priv = m;
	return 0;
}

static void modbus_in_close(struct tracker *t)
{
	free_priv(t->priv);
	t->priv = NULL;
}

static int modbus_in_poll(struct tracker *t, const struct tracker_clock *now)
{
	struct modbus_in *m = t->priv;
	uint64_t bad = ctr_get(&m->malformed);
	int got = 0;

	(void)now;
	{
		uint64_t ticks;

		if (read(m->efd, &ticks, sizeof(ticks)) < 0 && errno != EAGAIN)
			return -errno;
	}
	if (bad != m->malformed_seen) {
		ctr_add(&t->st.malformed, bad - m->malformed_seen);
		m->malformed_seen = bad;
	}
	for (int k = 0; k < m->n; k++) {
		uint32_t w[MODBUS_IN_WORDS], seq;
		struct modbus_in_pose p;
		struct quat q;
		struct vec3 v;
		struct dq d;

		if (seqlock_peek(&m->slot[k].seq) == m->seen[k])
			continue;
		/* the device thread is writing this very slot: take it at the next cycle */
		if (!seqlock_try_read(&m->slot[k].seq, m->slot[k].w, w, MODBUS_IN_WORDS, &seq))
			continue;
		m->seen[k] = seq;
		memcpy(&p, w, sizeof(p));
		q = (struct quat){ p.q[0], p.q[1], p.q[2], p.q[3] };
		v = (struct vec3){ p.p[0], p.p[1], p.p[2] };
		dq_from_rt(&q, &v, &d);
		tracker_put(t, k, &d, p.t_ns, p.arrival_ns);
		got++;
	}
	if (atomic_load_explicit(&m->link, memory_order_acquire) == MODBUS_IN_DOWN) {
		/* a new outage is a fault (FAULTY, counted once); then quiet until the device answers */
		if (!m->reported) {
			m->reported = true;
			return -ENOTCONN;
		}
		return 0;
	}
	m->reported = false;
	return got;
}

static int modbus_in_fd(struct tracker *t)
{
	return ((struct modbus_in *)t->priv)->efd;
}

static void modbus_in_report(struct tracker *t, FILE *out, bool json)
{
	static const char *const links[] = { "connecting", "up", "down" };
	struct modbus_in *m = t->priv;
	int link = (int)atomic_load_explicit(&m->link, memory_order_relaxed) % 3;
	int e = atomic_load_explicit(&m->last_errno, memory_order_relaxed);

	if (json) {
		fputs(",\"modbus\":{\"device\":", out);
		json_string(out, m->where);
		fprintf(out, ",\"link\":\"%s\",\"last_error\":", links[link]);
		json_string(out, e ? modbus_strerror(e) : "");
		fprintf(out,
			",\"polls\":%llu,"
			"\"connects\":%llu,\"losses\":%llu,\"timeouts\":%llu,\"exceptions\":%llu,\"reads_per_poll\":%"
			"d}",
			(unsigned long long)ctr_get(&m->polls), (unsigned long long)ctr_get(&m->connects),
			(unsigned long long)ctr_get(&m->losses), (unsigned long long)ctr_get(&m->timeouts),
			(unsigned long long)ctr_get(&m->exceptions), m->reads);
		return;
	}
	fprintf(out, "  %s: Modbus %s %s%s%s: %llu polls, %llu connects, %llu losses, %llu timeouts, %llu exceptions\n",
		t->name, m->where, links[link], link == MODBUS_IN_DOWN && e ? ": " : "",
		link == MODBUS_IN_DOWN && e ? modbus_strerror(e) : "", (unsigned long long)ctr_get(&m->polls),
		(unsigned long long)ctr_get(&m->connects), (unsigned long long)ctr_get(&m->losses),
		(unsigned long long)ctr_get(&m->timeouts), (unsigned long long)ctr_get(&m->exceptions));
}

const struct tracker_driver modbus_driver = {
	.type = { CFG_TYPE("modbus", "poses polled from a Modbus TCP device (robot tool pose, laser tracker)",
			   modbus_keys, struct modbus_in_opts),
		  .check = modbus_in_check, .sensor_count = modbus_in_sensor_count,
		  .sensor_name = modbus_in_sensor_name },
	.open = modbus_in_open,
	.close = modbus_in_close,
	.poll = modbus_in_poll,
	.fd = modbus_in_fd,
	.report = modbus_in_report,
};
