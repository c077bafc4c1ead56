// SPDX-License-Identifier: MIT
/*
 * probe.c - avatargw --probe (see probe.h): the source itself (its driver,
 * device thread and all) run for a moment from a configuration made here,
 * its samples counted per sensor by polling as the loop would.
 */
#include "trackers/probe.h"

#include "base/clock.h"
#include "trackers/dtrack.h"
#include "trackers/tracker.h"
#include "trackers/vrpn_in.h"
#include "wire/vrpn_proto.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <syslog.h>
#include <time.h>

struct seen {
	uint64_t n, first, last; /* CLOCK_MONOTONIC */
	struct dq pose;
	uint32_t buttons;
	bool inputs;
};

/* a source's configuration with its options, as the configuration would make it */
struct probe_cfg {
	struct cfg_source src;
	union {
		struct vrpn_in_opts vrpn;
		struct dtrack_opts dtrack;
	} o;
};

/* vrpn://SPEC or dtrack://[ADDRESS]:PORT into a source's configuration; 0 or -1 */
static int probe_cfg(const char *url, struct probe_cfg *pc)
{
	struct cfg_source *c = &pc->src;

	memset(pc, 0, sizeof(*pc));
	c->axes[0] = 1;
	c->max_distance = 1e6; /* whatever a tracker reports: the probe shows it */
	c->opt = &pc->o;
	if (!strncmp(url, "vrpn://", 7)) {
		struct vrpn_in_opts *o = &pc->o.vrpn;
		const char *key;

		snprintf(c->name, sizeof(c->name), "cave");
		c->driver = cfg_source_type_find("vrpn");
		if (c->driver < 0 || strlen(url + 7) >= sizeof(o->dev.device))
			return -1;
		snprintf(o->dev.device, sizeof(o->dev.device), "%s", url + 7);
		o->dev.speed = 1;
		o->sensors = CHAN_MAX;
		o->udp = true;
		o->timeout_ms = 1000;
		return cfg_source_type(c->driver)->check(NULL, c, &key, (char[256]){ 0 }, 256) ? -1 : 0;
	}
	if (!strncmp(url, "dtrack://", 9)) {
		struct dtrack_opts *o = &pc->o.dtrack;
		const char *a = url + 9, *colon = strrchr(a, ':');
		char *end;
		long port;

		snprintf(c->name, sizeof(c->name), "dtrack");
		c->driver = cfg_source_type_find("dtrack");
		if (c->driver < 0 || !colon)
			return -1;
		port = strtol(colon + 1, &end, 10);
		if (*end || port < 1 || port > 65535 || (size_t)(colon - a) >= sizeof(o->address))
			return -1;
		o->port = (int)port;
		if (a[0] == '[' && colon > a && colon[-1] == ']')
			snprintf(o->address, sizeof(o->address), "%.*s", (int)(colon - a - 2), a + 1);
		else if (colon > a)
			snprintf(o->address, sizeof(o->address), "%.*s", (int)(colon - a), a);
		else
			snprintf(o->address, sizeof(o->address), "0.0.0.0");
		o->dev.speed = 1;
		o->sensors = CHAN_MAX - CHAN_MAX_FLYSTICKS;
		o->flysticks = CHAN_MAX_FLYSTICKS;
		o->timeout_ms = 1000;
		return 0;
	}
	return -1;
}

/* the Flysticks that reported (they follow the bodies) */
static int flysticks_seen(const struct seen *seen, int bodies)
{
	int n = 0;

	for (int i = 0; i < CHAN_MAX_FLYSTICKS; i++)
		n += seen[bodies + i].n != 0;
	return n;
}

int tracker_probe(const char *url, double secs, FILE *out, FILE *err)
{
	struct probe_cfg *pc = calloc(1, sizeof(*pc));
	struct cfg_source *c = pc ? &pc->src : NULL;
	struct tracker t;
	struct seen *seen;
	char why[512], status[512] = "", nm[CFG_NAME_MAX * 2];
	uint64_t t0, end;
	int any = 0, top = -1, level, yup_votes = 0, zup_votes = 0;
	bool vrpn;
	int bodies;

	if (!pc || probe_cfg(url, pc)) {
		fprintf(err,
			"avatargw: --probe %s: not vrpn://NAME@host[:port] (or NAME@tcp://host[:port]) nor "
			"dtrack://[address]:port\n",
			url);
		free(pc);
		return 64;
	}
	vrpn = !strcmp(cfg_source_type(c->driver)->name, "vrpn");
	bodies = vrpn ? pc->o.vrpn.sensors : pc->o.dtrack.sensors;
	if (tracker_open(&t, c, why, sizeof(why))) {
		fprintf(err, "avatargw: --probe %s: %s\n", url, why);
		free(pc);
		return 1;
	}
	seen = calloc((size_t)t.n_sensors, sizeof(*seen));
	t0 = mono_ns();
	end = t0 + (uint64_t)(secs * 1e9);
	while (seen && mono_ns() < end) {
		struct tracker_clock now = { mono_ns(), 0 };
		struct timespec ts = { 0, 2000000 };

		now.real_off_ns = (int64_t)(real_ns() - now.mono_ns);
		t.drv->poll(&t, &now);
		for (int i = 0; i < t.n_sensors; i++) {
			const struct sensor_slot *s = &t.slot[i];

			if (s->count == seen[i].n)
				continue;
			if (!seen[i].n)
				seen[i].first = s->arrival_ns;
			seen[i].n = s->count;
			seen[i].last = s->arrival_ns;
			seen[i].pose = s->pose;
			seen[i].buttons |= s->buttons;
			seen[i].inputs |= s->inputs;
		}
		while (t.drv->note && t.drv->note(&t, &level, why, sizeof(why)))
			fprintf(err, "%s\n", why);
		nanosleep(&ts, NULL);
	}
	if (t.drv->status)
		t.drv->status(&t, status, sizeof(status));
	fprintf(out, "%s (%.1f s)\n", status, secs);
	for (int i = 0; seen && i < t.n_sensors; i++) {
		struct vec3 p;
		double rate;

		if (!seen[i].n)
			continue;
		if (!any++)
			fprintf(out, "%-8s %8s %8s  %-26s %-34s %s\n", vrpn ? "channel" : "body", "reports", "rate/s",
				"position (m)", "orientation (qw qx qy qz)", "buttons");
		t.drv->type.sensor_name(c, i, nm, sizeof(nm));
		dq_translation(&seen[i].pose, &p);
		rate = seen[i].n > 1 && seen[i].last > seen[i].first
			       ? (double)(seen[i].n - 1) * 1e9 / (double)(seen[i].last - seen[i].first)
			       : 0;
		fprintf(out, "%-8s %8llu %8.1f  %8.3f %8.3f %8.3f  %8.4f %8.4f %8.4f %8.4f", nm,
			(unsigned long long)seen[i].n, rate, p.x, p.y, p.z, seen[i].pose.r.w, seen[i].pose.r.x,
			seen[i].pose.r.y, seen[i].pose.r.z);
		if (seen[i].inputs)
			fprintf(out, "  0x%x", seen[i].buttons);
		fputc('\n', out);
		if (i < bodies)
			top = i;
		/* a tracked person's sensors are 0.5 to 2.5 m above the floor: which axis says so */
		if (p.y > 0.5 && p.y < 2.5 && fabs(p.z) < 1.5)
			yup_votes++;
		else if (p.z > 0.5 && p.z < 2.5)
			zup_votes++;
	}
	if (!any) {
		fprintf(out, "nothing received: %s\n",
			vrpn ? "is the server running, the device name right (VRPN names are case-sensitive), a "
			       "firewall in the way (try NAME@tcp://host, and udp = no)?"
			     : "is DTrack sending to this host and port (its output settings), a firewall in the way?");
	} else {
		fprintf(out, "\n[source %s]\ntype = %s\n", c->name, vrpn ? "vrpn" : "dtrack");
		if (vrpn)
			fprintf(out, "device = %s\n", pc->o.vrpn.dev.device);
		else
			fprintf(out, "port = %d\n%saddress = %s\n", pc->o.dtrack.port,
				strcmp(pc->o.dtrack.address, "0.0.0.0") ? "" : "; ", pc->o.dtrack.address);
		if (top >= 0)
			fprintf(out, "sensors = %d\n", top + 1);
		if (!vrpn)
			fprintf(out, "flysticks = %d\n", flysticks_seen(seen, bodies));
		fprintf(out, "%saxes = y-up    ; %s\n", yup_votes > zup_votes ? "" : "; ",
			yup_votes > zup_votes ? "the sensors' y looks like their height: y is up"
					      : "if the tracker's y axis is up (docs/TRACKERS.md, \"Room frames\")");
		if (top >= 0)
			fprintf(out,
				"; sensor.%d = NAME    ; a name for channel %d (then head = %s/NAME), one key per "
				"channel\n",
				top, top, c->name);
	}
	tracker_close(&t);
	free(seen);
	free(pc);
	return any ? 0 : 1;
}
