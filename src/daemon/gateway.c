// SPDX-License-Identifier: MIT
/*
 * gateway.c - a configuration made real, and the body of one cycle.
 */
#include "daemon/gateway.h"
#include "base/clock.h"

#include "base/log.h"
#include "base/seqlock.h"
#include "publish/encode.h"
#include "record/recfile.h"
#include "record/recorder.h"
#include "sites/site.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

void gw_clock(struct tracker_clock *c)
{
	struct timespec r;

	c->mono_ns = mono_ns();
	clock_gettime(CLOCK_REALTIME, &r);
	c->real_off_ns = (int64_t)((uint64_t)r.tv_sec * 1000000000ull + (uint64_t)r.tv_nsec) - (int64_t)c->mono_ns;
}

static void avatar_setup(struct gateway *g, struct gw_avatar *a, const struct cfg_avatar *c, uint8_t *describe,
			 struct wire_describe *d)
{
	struct arm_dims dims = { c->dims[0], c->dims[1], c->dims[2], c->dims[3] };
	struct vec3 off = { c->head_offset[0], c->head_offset[1], c->head_offset[2] };
	struct arm_limits lim;
	struct avatar *body = &g->bodies[g->n_bodies];

	a->cfg = c;
	a->id = c->id;
	for (int j = 0; j < ARM_DOF; j++) {
		lim.lo[j] = c->lo[j];
		lim.hi[j] = c->hi[j];
	}
	memset(body, 0, sizeof(*body));
	avatar_init(body, &dims, &off, &lim);
	avatar_set_rest_pronation(body, c->rest_pronation * (M_PI / 180));
	/* avatars made by one section's `count` have one body: share it */
	if (g->n_bodies && !memcmp(&g->bodies[g->n_bodies - 1], body, sizeof(*body)))
		body = &g->bodies[g->n_bodies - 1];
	else
		g->n_bodies++;
	a->av = body;
	a->describe_msg = describe;
	a->describe = d;
	a->kin = c->solver == CFG_SOLVER_MATRIX ? &ik_kin_mat : &ik_kin_dq;
	ik_default_opts(&a->opts);
	a->opts.max_iter = c->max_iter;
	a->opts.tol_pos = c->tol_mm * 1e-3;
	a->opts.tol_rot = c->tol_rot_deg * (M_PI / 180);
	a->opts.max_evals = c->max_evals;
	a->opts.warm_iter = c->warm_iter;
	for (int r = 0; r < FRAME_SENSORS; r++) {
		a->fs.trk[r] = &g->trk[c->sensor[r].source];
		a->fs.sensor[r] = c->sensor[r].sensor;
	}
	encode_describe(a->av, c->name, g->cfg.daemon.rate, d);
	d->h.source_id = g->source_id;
	d->h.avatar_id = c->id;
	a->describe_len = (uint16_t)wire_encode_describe(d, describe);
}

/* the DESCRIBE payloads differ (the header's seq and rev do not count) */
static bool describe_changed(const struct gw_avatar *a, const struct gw_avatar *b)
{
	return a->describe_len != b->describe_len ||
	       memcmp(a->describe_msg + WIRE_HEADER_LEN, b->describe_msg + WIRE_HEADER_LEN,
		      (size_t)a->describe_len - WIRE_HEADER_LEN);
}

/*
 * Every avatar's DESCRIBE goes out soon: at the next cycle when there are
 * few avatars; spread over GW_DESCRIBE_BURST_NS when there are many, so that
 * no cycle carries them all (1000 avatars: 1.2 MB).
 */
#define GW_DESCRIBE_BURST_NS 100000000ull
#define GW_DESCRIBE_AT_ONCE 32

static void describe_soon(struct gateway *g, uint64_t now_ns)
{
	int n = g->n_avatars + g->n_remote;

	for (int i = 0; i < n; i++)
		g->av[i].next_describe_ns =
			n <= GW_DESCRIBE_AT_ONCE ? 0 : now_ns + GW_DESCRIBE_BURST_NS * (uint64_t)i / (uint64_t)n;
}

/*
 * Makes every page of a fresh allocation resident (a write per page; the
 * contents stay): with mlockall(MCL_ONFAULT) it is then locked too.
 */
static void touch(void *p, size_t n)
{
	volatile char *c = p;

	for (size_t i = 0; i < n; i += 4096)
		c[i] = c[i];
	if (n)
		c[n - 1] = c[n - 1];
}

/* the bytes of the longest FRAME (with its input block), rounded up to a cache line: the arena's stride */
static size_t frame_slot(void)
{
	static uint8_t buf[WIRE_MAX_MSG];
	struct wire_frame f;

	memset(&f, 0, sizeof(f));
	f.h.flags = WIRE_F_INPUTS;
	return (wire_encode_frame(&f, buf) + 63) & ~(size_t)63;
}

int gw_open(struct gateway *g, struct config *cfg, struct gateway *old, uint32_t source_id, char *err, size_t errlen)
{
	uint16_t *ids;
	size_t n_all;
	int rc = 0;
	bool kept = false; /* g->site is old's, taken over */

	memset(g, 0, sizeof(*g));
	g->cfg = *cfg;
	memset(cfg, 0, sizeof(*cfg));
	g->source_id = source_id;
	g->stale_ns = (uint64_t)(g->cfg.daemon.stale_ms * 1e6);
	g->describe_ns = (uint64_t)(g->cfg.daemon.describe_interval * 1e9);
	for (int i = 0; i < g->cfg.n_sources; i++) {
		rc = tracker_open(&g->trk[i], &g->cfg.source[i], err, errlen);
		if (rc)
			goto fail;
		g->n_trackers++;
	}
	g->frame_slot = frame_slot();
	if (g->cfg.site.present) {
		/* the other sites' avatars: slots reserved now, after the configured ones */
		if (old && old->site && site_keeps(old->site, &g->cfg)) {
			/* a reload that leaves [site] as it was: the participant and the remote avatars stay */
			g->site = old->site;
			kept = true;
		} else {
			rc = site_open(&g->site, &g->cfg, source_id, err, errlen);
			if (rc)
				goto fail;
		}
		g->n_site = site_n_remote(g->site);
	}
	g->n_remote = g->n_site;
	for (int i = 0; i < g->n_trackers; i++)
		if (g->trk[i].drv->solved_count)
			g->n_remote += g->trk[i].drv->solved_count(&g->trk[i]);
	n_all = (size_t)g->cfg.n_avatars + (size_t)g->n_remote;
	g->av = calloc(n_all + 1, sizeof(*g->av));
	g->arena = malloc((n_all + 1) * g->frame_slot);
	g->describe = malloc((n_all + 1) * WIRE_MAX_MSG);
	g->bodies = calloc((size_t)g->cfg.n_avatars + 1, sizeof(*g->bodies));
	g->msgs = calloc(n_all * 2 + 1, sizeof(*g->msgs));
	g->frames = calloc(n_all + 1, sizeof(*g->frames));
	g->wframes = calloc(n_all + 1, sizeof(*g->wframes));
	g->describes = calloc(n_all + 1, sizeof(*g->describes));
	ids = calloc(n_all + 1, sizeof(*ids));
	if (!g->av || !g->arena || !g->describe || !g->bodies || !g->msgs || !g->frames || !g->wframes ||
	    !g->describes || !ids) {
		free(ids);
		snprintf(err, errlen, "out of memory");
		rc = -ENOMEM;
		goto fail;
	}
	/* written now, so that the loop never takes a first-touch page fault in them */
	touch(g->arena, (n_all + 1) * g->frame_slot);
	touch(g->describe, (n_all + 1) * WIRE_MAX_MSG);
	touch(g->msgs, (n_all * 2 + 1) * sizeof(*g->msgs));
	touch(g->frames, (n_all + 1) * sizeof(*g->frames));
	touch(g->wframes, (n_all + 1) * sizeof(*g->wframes));
	touch(g->describes, (n_all + 1) * sizeof(*g->describes));
	for (int i = 0; i < g->cfg.n_avatars; i++) {
		struct gw_avatar *a = &g->av[i];

		avatar_setup(g, a, &g->cfg.avatar[i], g->describe + (size_t)i * WIRE_MAX_MSG, &g->describes[i]);
		ids[i] = a->cfg->id;
		for (int j = 0; old && j < old->n_avatars; j++) {
			const struct gw_avatar *o = &old->av[j];

			if (o->cfg->id != a->cfg->id)
				continue;
			a->seq = o->seq;
			a->dseq = o->dseq;
			a->describe_rev = o->describe_rev + (describe_changed(a, o) ? 1 : 0);
		}
		g->n_avatars++;
	}
	for (int i = 0; kept && i < g->n_avatars; i++)
		kept = site_keeps_describe(g->site, i, g->av[i].describe);
	if (g->site && !kept && old && g->site == old->site) {
		/* a local avatar's description changed: published by a new participant */
		g->site = NULL;
		rc = site_open(&g->site, &g->cfg, source_id, err, errlen);
		if (rc) {
			free(ids);
			goto fail;
		}
	}
	for (int i = 0; g->site && !kept && i < g->n_avatars; i++)
		site_describe_local(g->site, i, g->av[i].describe);
	for (int k = 0, t = 0, j = 0; k < g->n_remote; k++) {
		struct gw_avatar *a = &g->av[g->n_avatars + k];

		a->describe_msg = g->describe + (size_t)(g->n_avatars + k) * WIRE_MAX_MSG;
		a->describe = &g->describes[g->n_avatars + k];
		if (k < g->n_site) {
			a->id = site_remote_id(g->site, k);
			if (kept) {
				/* the same avatar in the same slot: its numbering goes on */
				const struct gw_avatar *o = &old->av[old->n_avatars + k];

				a->seq = o->seq;
				a->dseq = o->dseq;
				a->describe_rev = o->describe_rev;
				/* and its description: the site does not describe it again (no new revision) */
				*a->describe = *o->describe;
				memcpy(a->describe_msg, o->describe_msg, o->describe_len);
				a->describe_len = o->describe_len;
				atomic_store_explicit(&a->st.frames, ctr_get(&o->st.frames), memory_order_relaxed);
				atomic_store_explicit(&a->st.gone,
						      atomic_load_explicit(&o->st.gone, memory_order_relaxed),
						      memory_order_relaxed);
			}
		} else {
			/* a recording's remote avatar: the id it had at the recording site */
			while (!g->trk[t].drv->solved_count || j >= g->trk[t].drv->solved_count(&g->trk[t])) {
				t++;
				j = 0;
			}
			a->solved_trk = &g->trk[t];
			a->solved_k = j++;
			g->trk[t].drv->solved_name(&g->trk[t], a->solved_k, &a->id);
			for (int i = 0; i < g->n_avatars + k; i++)
				if (ids[i] == a->id) {
					uint16_t id;
					const char *name = g->trk[t].drv->solved_name(&g->trk[t], a->solved_k, &id);

					snprintf(err, errlen,
						 "[source %s]: the recording's remote avatar %s has id %u, %s",
						 g->trk[t].name, name, id,
						 i < g->n_avatars		? "as an avatar of this configuration"
						 : i < g->n_avatars + g->n_site ? "among the [site] remote ids"
										: "as another replayed remote avatar");
					free(ids);
					rc = -EINVAL;
					goto fail;
				}
		}
		ids[g->n_avatars + k] = a->id;
	}
	describe_soon(g, mono_ns());
	for (int i = 0; i < g->cfg.n_outputs; i++) {
		struct output *prev = NULL;

		for (int j = 0; old && j < old->n_outputs; j++)
			if (!strcmp(old->out[j].name, g->cfg.output[i].name))
				prev = &old->out[j];
		rc = output_open(&g->out[i], &g->cfg.output[i], ids, g->n_avatars + g->n_remote, prev, err, errlen);
		if (rc)
			break;
		g->n_outputs++;
	}
	free(ids);
	if (rc) {
		/* give adopted subscribers back before anything is closed */
		for (int i = 0; old && i < g->n_outputs; i++)
			for (int j = 0; j < old->n_outputs; j++)
				if (!strcmp(old->out[j].name, g->out[i].name))
					output_unadopt(&g->out[i], &old->out[j]);
		goto fail;
	}
	if (kept) {
		old->site = NULL;
		site_adopt(g->site, &g->cfg);
		pr_info("[site] unchanged: the DDS participant and the remote avatars stay");
	} else if (g->site && old && old->site) {
		pr_info("[site] changed: a new DDS participant; the remote avatars come back as it discovers them");
	}
	if (g->site && !kept && (rc = site_start(g->site, err, errlen)))
		goto fail;
	return 0;
fail:
	if (kept)
		g->site = NULL; /* still old's */
	gw_close(g);
	return rc;
}

void gw_close(struct gateway *g)
{
	for (int i = g->n_outputs - 1; i >= 0; i--)
		output_close(&g->out[i]);
	for (int i = g->n_trackers - 1; i >= 0; i--)
		tracker_close(&g->trk[i]);
	site_close(g->site);
	free(g->msgs);
	free(g->frames);
	free(g->wframes);
	free(g->describes);
	free(g->arena);
	free(g->describe);
	free(g->bodies);
	free(g->av);
	config_free(&g->cfg);
	memset(g, 0, sizeof(*g));
}

/* the recording tap of every tracker: its sample as the recording stores it */
static void tap_sample(void *ctx, uint16_t source, uint16_t sensor, const struct sensor_slot *s)
{
	struct recfile_sample smp;
	struct vec3 p;

	dq_translation(&s->pose, &p);
	smp.source = source;
	smp.sensor = sensor;
	smp.buttons = s->buttons;
	smp.t_ns = s->t_ns;
	smp.arrival_ns = s->arrival_ns;
	smp.p[0] = (float)p.x;
	smp.p[1] = (float)p.y;
	smp.p[2] = (float)p.z;
	smp.q[0] = (float)s->pose.r.w;
	smp.q[1] = (float)s->pose.r.x;
	smp.q[2] = (float)s->pose.r.y;
	smp.q[3] = (float)s->pose.r.z;
	smp.has_analog = false;
	for (int i = 0; i < 4; i++) {
		smp.analog[i] = s->analog[i];
		smp.has_analog |= s->analog[i] != 0.0f;
	}
	recorder_sample(ctx, &smp);
}

int gw_record(struct gateway *g, struct recorder **rp, char *err, size_t errlen)
{
	int rc = recorder_apply(rp, &g->cfg, g->source_id, err, errlen);
	struct recorder *r = rc ? NULL : *rp;

	for (int i = 0; i < g->n_trackers; i++) {
		g->trk[i].tap = r ? tap_sample : NULL;
		g->trk[i].tap_ctx = r;
		g->trk[i].tap_source = (uint16_t)i;
	}
	g->rec = r;
	return rc;
}

int gw_event_fds(struct gateway *g, int *fds, int max)
{
	int n = 0;

	for (int i = 0; i < g->n_trackers && n < max; i++) {
		int fd = g->trk[i].drv->fd ? g->trk[i].drv->fd(&g->trk[i]) : -1;

		if (fd >= 0)
			fds[n++] = fd;
	}
	return n;
}

static void poll_trackers(struct gateway *g, const struct tracker_clock *now)
{
	for (int i = 0; i < g->n_trackers; i++) {
		struct tracker *t = &g->trk[i];
		int rc = t->drv->poll(t, now);
		uint32_t st = atomic_load_explicit(&t->st.state, memory_order_relaxed);
		uint64_t newest = 0;

		if (rc < 0) {
			ctr_add(&g->st.poll_errors, 1);
			if (st != TRACKER_FAULTY)
				ctr_add(&t->st.faults, 1);
			atomic_store_explicit(&t->st.state, TRACKER_FAULTY, memory_order_relaxed);
			continue;
		}
		if (st == TRACKER_ENDED || (st == TRACKER_FAULTY && rc == 0))
			continue;
		for (int s = 0; s < t->n_sensors; s++)
			if (t->slot[s].arrival_ns > newest)
				newest = t->slot[s].arrival_ns;
		st = newest && now->mono_ns - newest <= g->stale_ns ? TRACKER_OK : TRACKER_STALE;
		atomic_store_explicit(&t->st.state, st, memory_order_relaxed);
	}
}

static uint8_t *slot_of(struct gateway *g, int k)
{
	return g->arena + (size_t)k * g->frame_slot;
}

/*
 * A cycle walks 1000 avatars' state (several kB each, more than a core's
 * cache holds) while each avatar's solve takes microseconds: so the avatar
 * after next is fetched ahead, and the next one's sensor slots (reached
 * through its state, which by then is in the cache), and its FRAME slot.
 */
static void prefetch_ahead(const struct gateway *g, int i)
{
	if (i + 2 < g->n_avatars) {
		const char *a = (const char *)&g->av[i + 2], *f = (const char *)&g->frames[i + 2];

		for (size_t off = 0; off < offsetof(struct gw_avatar, st); off += 64)
			__builtin_prefetch(a + off, 1);
		for (size_t off = 0; off < sizeof(struct pose_frame); off += 64)
			__builtin_prefetch(f + off, 1);
	}
	if (i + 1 < g->n_avatars) {
		const struct frame_source *fs = &g->av[i + 1].fs;

		for (int r = 0; r < FRAME_SENSORS; r++)
			__builtin_prefetch(&fs->trk[r]->slot[fs->sensor[r]]);
	}
}

/* the probed avatar's sensors, for the control thread (struct gw_probe) */
static void probe_write(struct gateway *g, int idx, const struct pose_frame *pf, uint64_t now_ns)
{
	uint32_t w[GW_PROBE_WORDS];

	w[0] = (uint32_t)now_ns;
	w[1] = (uint32_t)(now_ns >> 32);
	w[2] = (uint32_t)idx;
	for (int r = 0; r < FRAME_SENSORS; r++) {
		uint32_t *o = w + GW_PROBE_HEAD + r * GW_PROBE_SENSOR_WORDS;
		struct vec3 p;
		float v[7];

		dq_translation(&pf->sensor[r], &p);
		v[0] = (float)p.x;
		v[1] = (float)p.y;
		v[2] = (float)p.z;
		v[3] = (float)pf->sensor[r].r.w;
		v[4] = (float)pf->sensor[r].r.x;
		v[5] = (float)pf->sensor[r].r.y;
		v[6] = (float)pf->sensor[r].r.z;
		o[0] = pf->state[r];
		memcpy(o + 1, v, sizeof(v));
	}
	seqlock_write(&g->probe.seq, g->probe.words, w, GW_PROBE_WORDS);
}

/* avatar i's DESCRIBE into the batch when its time has come; returns the batch's new length */
static int queue_describe(struct gateway *g, struct gw_avatar *a, int i, uint64_t now_ns, int n)
{
	if (now_ns < a->next_describe_ns)
		return n;
	/* encoded at start-up (a remote avatar's: when it changed): only its sequence number and revision change */
	a->describe->h.seq = a->dseq;
	a->describe->h.describe_rev = a->describe_rev;
	wire_restamp(a->describe_msg, a->dseq++, a->describe_rev);
	g->msgs[n++] =
		(struct out_msg){ a->describe_msg, a->describe_len, WIRE_DESCRIBE, (uint16_t)i, NULL, a->describe };
	/*
	 * Each avatar keeps its own phase within the period, i/n of it,
	 * so that the DESCRIBEs of many avatars spread over the second
	 * instead of all leaving in one cycle; after a burst (start, a
	 * new subscriber) each goes back to its phase.
	 */
	{
		uint64_t phase = g->describe_ns * (uint64_t)i / (uint64_t)(g->n_avatars + g->n_remote);
		uint64_t k = now_ns > phase ? (now_ns - phase) / g->describe_ns : 0;

		a->next_describe_ns = phase + (k + 1) * g->describe_ns;
	}
	return n;
}

/*
 * A remote avatar that published and now left (its site's lease ran out or
 * it stopped; in a replay, the recording says so): recorded as its DESCRIBE
 * with the site block saying gone, which a replay takes as the departure.
 */
static void remote_left(struct gateway *g, struct gw_avatar *a, int k, uint64_t now_ns)
{
	struct wire_describe d = *a->describe;
	uint8_t msg[WIRE_MAX_MSG];

	atomic_store_explicit(&a->st.gone, 1, memory_order_relaxed);
	if (!g->rec)
		return;
	if (k < g->n_site)
		site_remote_site(g->site, k, &d.site);
	d.site.present = true;
	d.site.state = WIRE_SITE_GONE;
	recorder_remote(g->rec, now_ns, msg, wire_encode_describe(&d, msg));
}

/*
 * The other sites' avatars ([site]): their frames come solved, the joint
 * angles as the sending site published them; only the header is ours
 * (source, id, sequence, revision). A newcomer's DESCRIBE goes out at once.
 */
static int remote_frames(struct gateway *g, uint64_t now_ns, int n, int *frames)
{
	for (int k = 0; k < g->n_remote; k++) {
		int i = g->n_avatars + k;
		struct gw_avatar *a = &g->av[i];
		struct wire_frame *wf = &g->wframes[i];
		bool described, fresh;
		int m;

		if (k < g->n_site ? !site_remote(g->site, k, now_ns, wf, a->describe, &described, &fresh)
				  : !a->solved_trk->drv->solved(a->solved_trk, a->solved_k, now_ns, g->stale_ns, wf,
								a->describe, &described, &fresh)) {
			if (ctr_get(&a->st.frames) && !atomic_load_explicit(&a->st.gone, memory_order_relaxed))
				remote_left(g, a, k, now_ns);
			continue;
		}
		atomic_store_explicit(&a->st.gone, 0, memory_order_relaxed);
		if (described) {
			a->describe->h.source_id = g->source_id;
			a->describe->h.avatar_id = a->id;
			a->describe_rev++;
			a->describe_len = (uint16_t)wire_encode_describe(a->describe, a->describe_msg);
			a->next_describe_ns = 0;
		}
		wf->h.source_id = g->source_id;
		wf->h.seq = a->seq++;
		wf->h.describe_rev = a->describe_rev;
		wf->h.avatar_id = a->id;
		g->msgs[n++] = out_msg_frame(wf, slot_of(g, *frames), (uint16_t)i);
		(*frames)++;
		ctr_add(&a->st.frames, 1);
		if (fresh)
			ctr_add(&a->st.new_frames, 1);
		if (wf->h.flags & WIRE_F_STALE)
			ctr_add(&a->st.stale_frames, 1);
		atomic_store_explicit(&a->st.state, wf->sensor[0].state, memory_order_relaxed);
		/* recorded as what it is, a remote avatar: a replay publishes it again as it was */
		if (g->rec && fresh)
			recorder_remote(g->rec, now_ns, g->msgs[n - 1].data, g->msgs[n - 1].len);
		if (now_ns >= a->next_describe_ns) {
			/* its site's figures of now in the DESCRIBE (no new revision: the skeleton is the same) */
			if (k < g->n_site)
				site_remote_site(g->site, k, &a->describe->site);
			a->describe_len = (uint16_t)wire_encode_describe(a->describe, a->describe_msg);
		}
		m = n;
		n = queue_describe(g, a, i, now_ns, n);
		if (g->rec && n > m)
			recorder_remote(g->rec, now_ns, g->msgs[m].data, g->msgs[m].len);
	}
	return n;
}

int gw_cycle(struct gateway *g, const struct tracker_clock *now)
{
	static const struct dq nan_dq = { { NAN, NAN, NAN, NAN }, { NAN, NAN, NAN, NAN } };
	int n = 0, frames = 0, probed = atomic_load_explicit(&g->probe.want, memory_order_relaxed) - 1;
	uint64_t sent_ns;

	poll_trackers(g, now);
	for (int i = 0; i < g->n_avatars; i++) {
		struct gw_avatar *a = &g->av[i];
		struct pose_frame *pf = &g->frames[i];
		struct wire_frame *wf = &g->wframes[i];
		struct encode_in in = { a->av, pf, NULL, false };
		const struct dq *s[FRAME_SENSORS];
		uint8_t missing = 0;

		prefetch_ahead(g, i);
		frame_gather(&a->fs, now->mono_ns, g->stale_ns, pf);
		if (i == probed)
			probe_write(g, i, pf, now->mono_ns);
		{
			uint32_t worst = 0;

			for (int r = 0; r < FRAME_SENSORS; r++)
				worst = pf->state[r] > worst ? pf->state[r] : worst;
			atomic_store_explicit(&a->st.state, worst, memory_order_relaxed);
		}
		for (int r = 0; r < FRAME_SENSORS; r++)
			s[r] = pf->state[r] == WIRE_SENSOR_MISSING ? &nan_dq : &pf->sensor[r];
		for (int r = 0; r < FRAME_SENSORS; r++)
			missing |= (uint8_t)((pf->state[r] == WIRE_SENSOR_MISSING) << r);
		if (pf->state[0] != WIRE_SENSOR_MISSING && !pf->new_sample && a->have_pose &&
		    missing == a->solved_missing) {
			/*
			 * The very samples of the last solve: its posture is the answer.
			 * Solving again would only move the redundancy a little further
			 * toward mid-range, so the same input would not always give the
			 * same frame; and a 60 Hz tracker in a 240 Hz loop would cost
			 * four solves per sample.
			 */
			in.pose = &a->pose[a->cur];
		} else if (pf->state[0] != WIRE_SENSOR_MISSING) {
			struct avatar_pose *next = &a->pose[a->cur ^ 1u];

			a->solved_missing = missing;
			avatar_solve(a->av, a->kin, &a->opts, s[0], s[1], s[2], a->have_pose ? &a->pose[a->cur] : NULL,
				     next);
			a->cur ^= 1u;
			a->have_pose = true;
			in.pose = next;
			for (int side = 0; side < 2; side++) {
				ctr_add(&a->st.ik_iters, (uint64_t)next->res[side].iters);
				if (next->res[side].flags & (IK_UNREACHABLE | IK_BAD_TARGET))
					ctr_add(&a->st.ik_unreached, 1);
			}
			ctr_add(&a->st.ik_solves, 2);
		} else if (a->have_pose) {
			in.pose = &a->pose[a->cur];
			in.held = true;
			ctr_add(&a->st.held, 1);
		}
		memset(&wf->h, 0, sizeof(wf->h));
		encode_frame(&in, wf);
		frame_inputs(pf, wf); /* buttons and analog values: an input block after the FRAME */
		if (!encode_frame_finite(wf, in.pose != NULL)) {
			/* never publish a NaN or an infinity: count, and forget the posture as a seed */
			ctr_add(&a->st.nan_blocked, 1);
			if (in.pose)
				a->have_pose = false;
			continue;
		}
		wf->h.source_id = g->source_id;
		wf->h.seq = a->seq++;
		wf->h.describe_rev = a->describe_rev;
		wf->h.sample_time_ns = pf->t_ns;
		wf->h.avatar_id = a->id;
		g->msgs[n++] = out_msg_frame(wf, slot_of(g, frames), (uint16_t)i);
		frames++;
		ctr_add(&a->st.frames, 1);
		if (pf->new_sample) {
			ctr_add(&a->st.new_frames, 1);
			a->pose_arrival_ns = pf->arrival_ns;
		}
		if (wf->h.flags & WIRE_F_STALE)
			ctr_add(&a->st.stale_frames, 1);
		if (g->site)
			site_put(g->site, i, g->msgs[n - 1].data, g->msgs[n - 1].len);
		n = queue_describe(g, a, i, now->mono_ns, n);
	}
	if (g->site)
		site_flush(g->site);
	if (g->n_remote)
		n = remote_frames(g, now->mono_ns, n, &frames);
	for (int i = 0; g->rec && i < n; i++)
		recorder_message(g->rec, now->mono_ns, g->msgs[i].data, g->msgs[i].len);
	for (int o = 0; o < g->n_outputs; o++) {
		uint64_t acc = ctr_get(&g->out[o].st.accepted);

		g->out[o].ops->service(&g->out[o]);
		g->out[o].ops->send(&g->out[o], g->msgs, n);
		/*
		 * A new subscriber of a stream, the viewer or VRPN gets every
		 * DESCRIBE now, not a second later. Not for a Modbus client: an HMI
		 * that connects for every poll would flood every other output.
		 */
		if (ctr_get(&g->out[o].st.accepted) != acc && !g->out[o].ops->quiet_accept)
			describe_soon(g, now->mono_ns);
	}
	sent_ns = mono_ns();
	for (int i = 0; i < g->n_avatars; i++) {
		struct gw_avatar *a = &g->av[i];

		/* frames carrying a sample that arrived since the previous cycle */
		if (a->pose_arrival_ns) {
			hist_add(&a->st.latency, sent_ns - a->pose_arrival_ns);
			a->pose_arrival_ns = 0;
		}
	}
	ctr_add(&g->st.cycles, 1);
	return frames;
}
