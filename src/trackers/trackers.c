// SPDX-License-Identifier: MIT
/*
 * trackers.c - the table of tracker drivers (config name -> driver) and
 * what every tracker shares: its sensor slots, its world transform and its
 * sensors' mounting offsets.
 */
#include "trackers/tracker.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

/*
 * Every tracker driver, one row each. Those whose library pkg-config did not
 * find at build time (the Makefile's HAVE_*) are left out, and the
 * configuration says so for their type.
 */
#ifndef HAVE_LIBMODBUS
#define HAVE_LIBMODBUS 1
#endif
#ifndef HAVE_HIDAPI
#define HAVE_HIDAPI 1
#endif
#ifndef HAVE_LIBUSB
#define HAVE_LIBUSB 1
#endif

extern const struct tracker_driver sim_driver, replay_driver, modbus_driver, can_driver, hydra_driver, polhemus_driver,
	vrpn_in_driver, dtrack_driver;

const struct tracker_driver *const trackers_table[] = {
	&sim_driver,	  &replay_driver,
#if HAVE_LIBMODBUS
	&modbus_driver,
#endif
	&can_driver,
#if HAVE_HIDAPI
	&hydra_driver,
#endif
#if HAVE_LIBUSB
	&polhemus_driver,
#endif
	&vrpn_in_driver,  &dtrack_driver,
};

const int trackers_count = (int)(sizeof(trackers_table) / sizeof(trackers_table[0]));

/* drivers this build left out: known, so that the configuration can say why (doc: the missing library) */
static const struct cfg_type not_built[] = {
#if !HAVE_LIBMODBUS
	{ .name = "modbus", .doc = "libmodbus" },
#endif
#if !HAVE_HIDAPI
	{ .name = "hydra", .doc = "hidapi" },
#endif
#if !HAVE_LIBUSB
	{ .name = "polhemus", .doc = "libusb" },
#endif
	{ .name = NULL },
};

const struct cfg_type *cfg_source_type(int i)
{
	if (i < 0)
		return NULL;
	if (i < trackers_count)
		return &trackers_table[i]->type;
	i -= trackers_count;
	return i < (int)(sizeof(not_built) / sizeof(not_built[0])) - 1 ? &not_built[i] : NULL;
}

static void free_slots(struct tracker *t)
{
	free(t->slot);
	free(t->mount);
	free(t->mounted);
	t->slot = NULL;
	t->mount = NULL;
	t->mounted = NULL;
}

int tracker_open(struct tracker *t, const struct cfg_source *cfg, char *err, size_t errlen)
{
	struct quat yaw = { cos(cfg->yaw / 2), 0, 0, sin(cfg->yaw / 2) }, r;
	/* the tracker's axes turned into z-up ones first (axes), then about z (yaw), then moved (origin) */
	struct quat axes = { cfg->axes[0], cfg->axes[1], cfg->axes[2], cfg->axes[3] };
	struct vec3 o = { cfg->origin[0], cfg->origin[1], cfg->origin[2] };
	bool axes_identity = axes.w == 1 || (axes.w == 0 && axes.x == 0 && axes.y == 0 && axes.z == 0);
	int rc;

	if (axes_identity)
		axes = (struct quat){ 1, 0, 0, 0 };
	memset(t, 0, sizeof(*t));
	t->drv = trackers_table[cfg->driver];
	t->cfg = cfg;
	snprintf(t->name, sizeof(t->name), "%s", cfg->name);
	quat_mul(&yaw, &axes, &r);
	dq_from_rt(&r, &o, &t->world);
	t->world_identity = cfg->yaw == 0 && axes_identity && o.x == 0 && o.y == 0 && o.z == 0;
	t->n_sensors = t->drv->type.sensor_count(cfg);
	t->slot = calloc((size_t)t->n_sensors, sizeof(*t->slot));
	t->mount = calloc((size_t)t->n_sensors, sizeof(*t->mount));
	t->mounted = calloc((size_t)t->n_sensors, sizeof(*t->mounted));
	if (!t->slot || !t->mount || !t->mounted) {
		snprintf(err, errlen, "[source %s]: out of memory", cfg->name);
		rc = -ENOMEM;
		goto fail;
	}
	for (int i = 0; i < cfg->n_mounts; i++) {
		const struct cfg_mount *m = &cfg->mount[i];
		int s = cfg_sensor_lookup(cfg, m->sensor);
		struct quat q = { m->q[0], m->q[1], m->q[2], m->q[3] };
		struct vec3 p = { m->p[0], m->p[1], m->p[2] };

		if (s < 0) {
			/* config.c checks the names: only a driver that changed its mind gets here */
			snprintf(err, errlen, "[source %s] mount_%s: no such sensor", cfg->name, m->sensor);
			rc = -EINVAL;
			goto fail;
		}
		dq_from_rt(&q, &p, &t->mount[s]);
		t->mounted[s] = true;
	}
	rc = t->drv->open(t, err, errlen);
	if (!rc)
		return 0;
fail:
	free_slots(t);
	return rc;
}

void tracker_close(struct tracker *t)
{
	if (t->drv && t->slot)
		t->drv->close(t);
	free_slots(t);
	t->drv = NULL;
}

/*
 * A world pose as it would be published (single-precision floats): finite,
 * within max_distance of the origin, its rotation a unit quaternion to
 * TRACKER_QUAT_TOL. A double that is finite may still become infinite as a
 * float (1e39), and a huge finite position makes the solver's numbers
 * overflow: both stop here, at the one place every driver's samples pass.
 */
static bool publishable(const struct dq *pose, double max_distance)
{
	struct vec3 t;
	float p[3], q[4];
	double d2 = 0, n2 = 0;

	dq_translation(pose, &t);
	p[0] = (float)t.x;
	p[1] = (float)t.y;
	p[2] = (float)t.z;
	q[0] = (float)pose->r.w;
	q[1] = (float)pose->r.x;
	q[2] = (float)pose->r.y;
	q[3] = (float)pose->r.z;
	/* an infinite or NaN float makes its sum of squares infinite or NaN (no test per value) */
	for (int i = 0; i < 3; i++)
		d2 += (double)p[i] * p[i];
	for (int i = 0; i < 4; i++)
		n2 += (double)q[i] * q[i];
	return isfinite(d2) && d2 <= max_distance * max_distance && fabs(sqrt(n2) - 1.0) <= TRACKER_QUAT_TOL;
}

void tracker_put(struct tracker *t, int sensor, const struct dq *local, uint64_t t_ns, uint64_t arrival_ns)
{
	struct sensor_slot *s = &t->slot[sensor];
	struct dq at, world;

	/* the tracked point is the mount offset away from the sensor, in the sensor's frame */
	if (t->mounted[sensor]) {
		dq_mul(local, &t->mount[sensor], &at);
		local = &at;
	}
	if (t->world_identity)
		world = *local;
	else
		dq_mul(&t->world, local, &world);
	if (!publishable(&world, t->cfg->max_distance)) {
		/* malformed: the sensor keeps its last good sample, which ages into STALE */
		ctr_add(&t->st.malformed, 1);
		return;
	}
	s->pose = world;
	s->t_ns = t_ns;
	s->arrival_ns = arrival_ns;
	s->count++;
	s->seen = true;
	ctr_add(&t->st.samples, 1);
	if (t->tap)
		t->tap(t->tap_ctx, t->tap_source, (uint16_t)sensor, s);
}
