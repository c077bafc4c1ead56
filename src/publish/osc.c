// SPDX-License-Identifier: MIT
/*
 * osc.c - OSC through liblo (docs/OSC.md): the VMC protocol as a performer
 * (type vmc) and VRChat's OSC trackers (type vrchat), one avatar each.
 *
 * liblo allocates for every message, so it never runs on the loop: the
 * loop's send() puts the batch into a snapshot (snapshot.h) and a thread of
 * this output wakes `rate` times a second on absolute deadlines, takes the
 * newest frame and sends it. A frame that is not newer than the last one
 * sent is not sent again; a destination that is not there costs nothing
 * but the datagram.
 *
 * Neither protocol can say that a pose is old, so when the person stops
 * (every sensor of the avatar STALE or MISSING: a replay that ended,
 * trackers switched off) the messages stop too, although the loop keeps
 * publishing frames that repeat the last posture; VMC gets one last bundle
 * whose /VMC/Ext/OK says tracking 0. They resume with the first frame that
 * has a sensor OK again.
 *
 * Both speak Unity's frame: left-handed, y up, z forward, metres. From
 * avatargw's world (right-handed, z up; a person facing +y has +x to the
 * right) a point (x, y, z) is Unity's (x, z, y), and a rotation with
 * quaternion (w, x, y, z) is Unity's (w, -x, -z, -y): swapping two axes is
 * a reflection, which turns the rotation axis with it and reverses the
 * sense of the angle.
 *
 * The bones are Unity's HumanBodyBones in a VRM-normalised rig: every bone's
 * rotation is the identity in a T-pose facing +z. Each avatargw segment
 * therefore gets a fixed correction, its orientation in that T-pose undone
 * (the upper arm hangs along its -z, the forearm and hand point along their
 * +y with the back of the hand up at avatargw's rest posture).
 */
#include "publish/output.h"
#include "publish/osc.h"
#include "ik/dq.h"
#include "base/clock.h"
#include "publish/snapshot.h"

#include <lo/lo.h>

#include <errno.h>
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

/* the keys its types share (read before each type's own) */
static const struct cfg_key osc_shared_keys[] = {
	{ .name = "address",
	  .kind = CFG_STR,
	  CFG_AT(struct osc_opts, address),
	  .def = "127.0.0.1",
	  .doc = "vmc, vrchat: destination host; websocket: listen address (any other address shows the viewer to "
		 "the network)" },
	{ .name = "rate",
	  .kind = CFG_DOUBLE,
	  CFG_AT(struct osc_opts, rate),
	  .min = 1,
	  .max = 240,
	  .def = "60",
	  .unit = "Hz",
	  .doc = "OSC bundles per second (the newest frame each time)" },
};

static const struct cfg_key vmc_keys[] = {
	{ .name = "port",
	  .kind = CFG_INT,
	  CFG_AT(struct osc_opts, port),
	  .min = 1,
	  .max = 65535,
	  .def = "39539",
	  .doc = "UDP destination port of the VMC marionette" },
	{ .name = "torso",
	  .kind = CFG_DOUBLE,
	  CFG_AT(struct osc_opts, torso),
	  .min = 0.1,
	  .max = 1.5,
	  .def = "0.5",
	  .unit = "m",
	  .doc = "shoulder line to hips: places the Hips bone below the tracked chest" },
};

static const struct cfg_key vrchat_keys[] = {
	{ .name = "port",
	  .kind = CFG_INT,
	  CFG_AT(struct osc_opts, port),
	  .min = 1,
	  .max = 65535,
	  .def = "9000",
	  .doc = "UDP port VRChat listens on for OSC" },
	{ .name = "head",
	  .kind = CFG_BOOL,
	  CFG_AT(struct osc_opts, head),
	  .def = "yes",
	  .doc = "also send the head pose (/tracking/trackers/head/*), which VRChat uses to align our space with "
		 "its own" },
};

/* VMC and VRChat speak for one body: the output carries exactly one avatar */
static int osc_check(const struct config *c, const void *section, const char **key, char *why, size_t len)
{
	const struct cfg_output *o = section;
	int n = cfg_output_avatars(c, o);

	if (n == 1)
		return 0;
	*key = "avatars";
	snprintf(why, len, "avatars: a %s output carries one avatar, not %d (avatars = NAME)",
		 cfg_output_type(o->type)->name, n);
	return -1;
}

static const struct osc_opts *opts_of(const struct cfg_output *c)
{
	return c->opt;
}

/* the IK core's quaternions (double build), by value */
static struct quat q_mul(struct quat a, struct quat b)
{
	struct quat o;

	quat_mul(&a, &b, &o);
	return o;
}

static struct quat q_conj(struct quat q)
{
	struct quat o;

	quat_conj(&q, &o);
	return o;
}

static struct quat q_axis(double x, double y, double z, double angle)
{
	struct vec3 axis = { x, y, z };
	struct quat o;

	quat_from_axis_angle(&axis, angle, &o);
	return o;
}

static struct vec3 q_rot(struct quat q, struct vec3 v)
{
	struct vec3 o;

	quat_rotate(&q, &v, &o);
	return o;
}

static struct vec3 v_sub(struct vec3 a, struct vec3 b)
{
	return (struct vec3){ a.x - b.x, a.y - b.y, a.z - b.z };
}

static struct vec3 unity_p(struct vec3 p)
{
	return (struct vec3){ p.x, p.z, p.y };
}

static struct quat unity_q(struct quat q)
{
	return (struct quat){ q.w, -q.x, -q.z, -q.y };
}

static struct vec3 pose_p(const struct wire_pose *p)
{
	return (struct vec3){ p->p[0], p->p[1], p->p[2] };
}

static struct quat pose_q(const struct wire_pose *p)
{
	return (struct quat){ p->q[0], p->q[1], p->q[2], p->q[3] };
}

/*
 * Unity's Quaternion.Euler(x, y, z) turns about z, then x, then y (fixed
 * axes): R = Ry Rx Rz. Its angles back from a rotation, degrees.
 */
static struct vec3 unity_euler(struct quat q)
{
	double m02 = 2 * (q.x * q.z + q.w * q.y), m12 = 2 * (q.y * q.z - q.w * q.x),
	       m22 = 1 - 2 * (q.x * q.x + q.y * q.y);
	double m10 = 2 * (q.x * q.y + q.w * q.z), m11 = 1 - 2 * (q.x * q.x + q.z * q.z);
	double deg = 180.0 / M_PI, s = -m12;

	if (s > 1)
		s = 1;
	if (s < -1)
		s = -1;
	if (fabs(s) > 0.9999995) {
		/* looking straight up or down: y and z turn about the same axis, put it all in y */
		double m00 = 1 - 2 * (q.y * q.y + q.z * q.z), m20 = 2 * (q.x * q.z - q.w * q.y);

		return (struct vec3){ asin(s) * deg, atan2(-m20, m00) * deg, 0 };
	}
	return (struct vec3){ asin(s) * deg, atan2(m02, m22) * deg, atan2(m10, m11) * deg };
}

/* ---- the skeleton in Unity's terms --------------------------------------------------- */

enum bone {
	B_HIPS,
	B_SPINE,
	B_CHEST,
	B_UPPER_CHEST,
	B_NECK,
	B_HEAD,
	B_L_SHOULDER,
	B_L_UPPER_ARM,
	B_L_LOWER_ARM,
	B_L_HAND,
	B_R_SHOULDER,
	B_R_UPPER_ARM,
	B_R_LOWER_ARM,
	B_R_HAND,
	B_COUNT,
	B_ROOT = -1,
};

static const char *const bone_names[B_COUNT] = {
	"Hips",		"Spine",	"Chest",    "UpperChest",    "Neck",	      "Head",	       "LeftShoulder",
	"LeftUpperArm", "LeftLowerArm", "LeftHand", "RightShoulder", "RightUpperArm", "RightLowerArm", "RightHand",
};

static const int bone_parent[B_COUNT] = {
	B_ROOT,	      B_HIPS,	     B_SPINE,	    B_CHEST,	   B_UPPER_CHEST, B_NECK,	 B_UPPER_CHEST,
	B_L_SHOULDER, B_L_UPPER_ARM, B_L_LOWER_ARM, B_UPPER_CHEST, B_R_SHOULDER,  B_R_UPPER_ARM, B_R_LOWER_ARM,
};

struct body {
	struct vec3 root_p;
	struct quat root_q;
	struct vec3 p[B_COUNT]; /* Unity world */
	struct quat q[B_COUNT];
};

/* the bones of a frame, in Unity's world frame; false if it has no posture */
static bool body_of(const struct wire_frame *f, double torso, struct body *b)
{
	const double h = M_PI / 2;
	struct vec3 p[B_COUNT], c, zc;
	struct quat q[B_COUNT], qc, qy;
	/* the segment, then the correction that makes the T-pose the identity */
	static const struct {
		int bone, seg;
		double ax, ay, az, angle;
	} arm[] = {
		{ B_R_UPPER_ARM, WIRE_SEG_R_SHOULDER, 0, 1, 0, 1 }, { B_R_LOWER_ARM, WIRE_SEG_R_ELBOW, 0, 0, 1, 1 },
		{ B_R_HAND, WIRE_SEG_R_WRIST, 0, 0, 1, 1 },	    { B_L_UPPER_ARM, WIRE_SEG_L_SHOULDER, 0, 1, 0, -1 },
		{ B_L_LOWER_ARM, WIRE_SEG_L_ELBOW, 0, 0, 1, -1 },   { B_L_HAND, WIRE_SEG_L_WRIST, 0, 0, 1, -1 },
	};

	if (!wire_pose_finite(&f->segment[WIRE_SEG_CHEST]))
		return false;
	for (int s = WIRE_SEG_R_SHOULDER; s <= WIRE_SEG_L_HAND; s++)
		if (!wire_pose_finite(&f->segment[s]))
			return false;
	if (!isfinite(f->joint[1]) || !isfinite(f->joint[9]))
		return false;
	c = pose_p(&f->segment[WIRE_SEG_CHEST]);
	qc = pose_q(&f->segment[WIRE_SEG_CHEST]);
	{
		/* the chest's heading alone (its twist about z): a bow leaves the hips upright */
		double n = sqrt(qc.w * qc.w + qc.z * qc.z);

		qy = n > 1e-9 ? (struct quat){ qc.w / n, 0, 0, qc.z / n } : (struct quat){ 1, 0, 0, 0 };
	}
	/*
	 * The trunk: the hips a torso down the chest's own axis (below it when
	 * upright, behind it in a bow), upright and turned by the chest's yaw;
	 * the spine bones evenly between, turned as the chest.
	 */
	zc = q_rot(qc, (struct vec3){ 0, 0, 1 });
	for (int k = B_HIPS; k <= B_NECK; k++) {
		double frac = (double)(k - B_HIPS) / (B_NECK - B_HIPS);

		p[k] = (struct vec3){ c.x - torso * (1 - frac) * zc.x, c.y - torso * (1 - frac) * zc.y,
				      c.z - torso * (1 - frac) * zc.z };
		q[k] = k == B_HIPS ? qy : qc;
	}
	if (wire_pose_finite(&f->segment[WIRE_SEG_HEAD])) {
		p[B_HEAD] = pose_p(&f->segment[WIRE_SEG_HEAD]);
		q[B_HEAD] = pose_q(&f->segment[WIRE_SEG_HEAD]);
	} else {
		p[B_HEAD] = c; /* a held frame has no head: keep it on the neck */
		q[B_HEAD] = qc;
	}
	/* the clavicles pivot at the chest origin by J1 (about z on the right, -z on the left) */
	p[B_R_SHOULDER] = p[B_L_SHOULDER] = c;
	q[B_R_SHOULDER] = q_mul(qc, q_axis(0, 0, 1, f->joint[1]));
	q[B_L_SHOULDER] = q_mul(qc, q_axis(0, 0, -1, f->joint[9]));
	for (size_t i = 0; i < sizeof(arm) / sizeof(arm[0]); i++) {
		p[arm[i].bone] = pose_p(&f->segment[arm[i].seg]);
		q[arm[i].bone] = q_mul(pose_q(&f->segment[arm[i].seg]),
				       q_axis(arm[i].ax, arm[i].ay, arm[i].az, arm[i].angle * h));
	}
	/* the root stands on the floor (z = 0) under the hips, facing the chest's way */
	b->root_p = unity_p((struct vec3){ p[B_HIPS].x, p[B_HIPS].y, 0 });
	b->root_q = unity_q(qy);
	for (int k = 0; k < B_COUNT; k++) {
		b->p[k] = unity_p(p[k]);
		b->q[k] = unity_q(q[k]);
	}
	return true;
}

/* ---- the output ---------------------------------------------------------------------- */

struct osc {
	bool vmc;     /* the VMC protocol, else VRChat's */
	bool stopped; /* the thread's: every sensor was stale or missing at the last fresh frame */
	lo_address addr;
	struct snap snap;
	int avatar; /* the one avatar (index) */
	double torso;
	bool head;
	uint64_t period_ns;
	pthread_t thread;
	pthread_mutex_t mu;
	pthread_cond_t cv;
	bool stop; /* guarded by mu */
	double t0; /* start, for /VMC/Ext/T */
};

static void count(struct output *o, struct osc *s, int rc)
{
	if (rc >= 0) {
		ctr_add(&o->st.sent, 1);
		return;
	}
	ctr_add(&o->st.errors, 1);
	atomic_store_explicit(&o->st.last_errno, lo_address_errno(s->addr) ? lo_address_errno(s->addr) : EIO,
			      memory_order_relaxed);
}

static lo_message pose_message(const char *name, struct vec3 p, struct quat q)
{
	lo_message m = lo_message_new();

	if (!m)
		return NULL;
	if (name)
		lo_message_add_string(m, name);
	lo_message_add_float(m, (float)p.x);
	lo_message_add_float(m, (float)p.y);
	lo_message_add_float(m, (float)p.z);
	lo_message_add_float(m, (float)q.x);
	lo_message_add_float(m, (float)q.y);
	lo_message_add_float(m, (float)q.z);
	lo_message_add_float(m, (float)q.w);
	return m;
}

/* one VMC bundle: the root, every bone relative to its parent, OK, T */
static void send_vmc(struct output *o, struct osc *s, const struct snap_entry *e, double t)
{
	struct body b;
	lo_bundle bundle;
	lo_message m;
	bool ok = true, tracking;

	if (!body_of(&e->f, s->torso, &b))
		return;
	bundle = lo_bundle_new(LO_TT_IMMEDIATE);
	if (!bundle)
		return;
	m = pose_message("root", b.root_p, b.root_q);
	ok &= m && !lo_bundle_add_message(bundle, "/VMC/Ext/Root/Pos", m);
	for (int k = 0; k < B_COUNT; k++) {
		int par = bone_parent[k];
		struct vec3 pp = par == B_ROOT ? b.root_p : b.p[par];
		struct quat pq = par == B_ROOT ? b.root_q : b.q[par];
		struct quat inv = q_conj(pq);

		m = pose_message(bone_names[k], q_rot(inv, v_sub(b.p[k], pp)), q_mul(inv, b.q[k]));
		ok &= m && !lo_bundle_add_message(bundle, "/VMC/Ext/Bone/Pos", m);
	}
	/* loaded, calibrated (3), normal calibration mode (0), tracking status */
	tracking = !(e->f.h.flags & (WIRE_F_STALE | WIRE_F_HELD));
	m = lo_message_new();
	if (m) {
		lo_message_add_int32(m, 1);
		lo_message_add_int32(m, 3);
		lo_message_add_int32(m, 0);
		lo_message_add_int32(m, tracking);
	}
	ok &= m && !lo_bundle_add_message(bundle, "/VMC/Ext/OK", m);
	m = lo_message_new();
	if (m)
		lo_message_add_float(m, (float)t);
	ok &= m && !lo_bundle_add_message(bundle, "/VMC/Ext/T", m);
	count(o, s, ok ? lo_send_bundle(s->addr, bundle) : -1);
	lo_bundle_free_recursive(bundle);
}

static void send_vec(struct output *o, struct osc *s, const char *path, struct vec3 v)
{
	lo_message m = lo_message_new();

	if (!m) {
		count(o, s, -1);
		return;
	}
	lo_message_add_float(m, (float)v.x);
	lo_message_add_float(m, (float)v.y);
	lo_message_add_float(m, (float)v.z);
	count(o, s, lo_send_message(s->addr, path, m));
	lo_message_free(m);
}

static void send_tracker(struct output *o, struct osc *s, const char *id, struct vec3 p, struct quat q)
{
	char path[64];

	snprintf(path, sizeof(path), "/tracking/trackers/%s/position", id);
	send_vec(o, s, path, p);
	snprintf(path, sizeof(path), "/tracking/trackers/%s/rotation", id);
	send_vec(o, s, path, unity_euler(q));
}

/*
 * VRChat: trackers 1 chest (the chest segment), 2 left and 3 right elbow, and the head for
 * alignment. VRChat's elbow trackers belong to the upper arms: each sits at the elbow and turns
 * with the upper arm, so that bending the elbow does not twist it.
 */
static void send_vrchat(struct output *o, struct osc *s, const struct snap_entry *e)
{
	struct body b;

	if (!body_of(&e->f, 0.5, &b))
		return;
	send_tracker(o, s, "1", b.p[B_NECK], b.q[B_NECK]);
	send_tracker(o, s, "2", b.p[B_L_LOWER_ARM], b.q[B_L_UPPER_ARM]);
	send_tracker(o, s, "3", b.p[B_R_LOWER_ARM], b.q[B_R_UPPER_ARM]);
	if (s->head && wire_pose_finite(&e->f.segment[WIRE_SEG_HEAD]))
		send_tracker(o, s, "head", b.p[B_HEAD], b.q[B_HEAD]);
}

static void *osc_main(void *arg)
{
	struct output *o = arg;
	struct osc *s = o->priv;
	uint64_t next = mono_ns();

	pthread_mutex_lock(&s->mu);
	while (!s->stop) {
		struct timespec ts;
		const struct snap_entry *e;
		bool fresh;

		next += s->period_ns;
		ts.tv_sec = (time_t)(next / 1000000000ull);
		ts.tv_nsec = (long)(next % 1000000000ull);
		while (!s->stop && pthread_cond_timedwait(&s->cv, &s->mu, &ts) != ETIMEDOUT)
			;
		if (s->stop)
			break;
		pthread_mutex_unlock(&s->mu);
		e = snap_take(&s->snap, s->avatar, &fresh);
		if (e && fresh) {
			bool was = s->stopped;

			/* once stopped, nothing new to say (VMC's last bundle said tracking 0) */
			s->stopped = wire_frame_stopped(&e->f); /* the protocols have no word for a stale pose */
			if (s->vmc && (!s->stopped || !was))
				send_vmc(o, s, e, (double)(mono_ns() - (uint64_t)s->t0) * 1e-9);
			else if (!s->vmc && !s->stopped)
				send_vrchat(o, s, e);
		}
		pthread_mutex_lock(&s->mu);
		{
			uint64_t now = mono_ns();

			/* late by more than a period (a suspended host): start again from now */
			if (now > next + s->period_ns)
				next = now;
		}
	}
	pthread_mutex_unlock(&s->mu);
	return NULL;
}

static void osc_free(struct osc *s)
{
	if (s->addr)
		lo_address_free(s->addr);
	snap_free(&s->snap);
	free(s);
}

static int osc_open(struct output *o, char *err, size_t errlen)
{
	const struct cfg_output *cfg = o->cfg;
	struct osc *s = calloc(1, sizeof(*s));
	pthread_condattr_t ca;
	char port[8];
	int rc;

	if (!s)
		return -ENOMEM;
	s->vmc = cfg_output_is(cfg, "vmc");
	s->torso = opts_of(cfg)->torso;
	s->head = opts_of(cfg)->head;
	s->period_ns = (uint64_t)(1e9 / opts_of(cfg)->rate);
	s->avatar = -1;
	for (int i = 0; i < o->n_avatars; i++)
		if (o->wants[i]) {
			if (s->avatar >= 0) {
				snprintf(err, errlen, "[output %s] avatars: an OSC output carries one avatar",
					 cfg->name);
				osc_free(s);
				return -EINVAL;
			}
			s->avatar = i;
		}
	if (s->avatar < 0) {
		snprintf(err, errlen, "[output %s] avatars: no avatar to send", cfg->name);
		osc_free(s);
		return -EINVAL;
	}
	snprintf(port, sizeof(port), "%d", opts_of(cfg)->port);
	s->addr = lo_address_new(opts_of(cfg)->address, port);
	if (!s->addr || snap_init(&s->snap, o->n_avatars)) {
		snprintf(err, errlen, "[output %s]: out of memory", cfg->name);
		osc_free(s);
		return -ENOMEM;
	}
	s->t0 = (double)mono_ns();
	pthread_mutex_init(&s->mu, NULL);
	pthread_condattr_init(&ca);
	pthread_condattr_setclock(&ca, CLOCK_MONOTONIC);
	pthread_cond_init(&s->cv, &ca);
	pthread_condattr_destroy(&ca);
	o->priv = s;
	rc = pthread_create(&s->thread, NULL, osc_main, o);
	if (rc) {
		snprintf(err, errlen, "[output %s]: thread: %s", cfg->name, strerror(rc));
		pthread_mutex_destroy(&s->mu);
		pthread_cond_destroy(&s->cv);
		osc_free(s);
		o->priv = NULL;
		return -rc;
	}
	pthread_setname_np(s->thread, cfg_output_is(cfg, "vmc") ? "avatargw-vmc" : "avatargw-vrchat");
	return 0;
}

static void osc_close(struct output *o)
{
	struct osc *s = o->priv;

	if (!s)
		return;
	pthread_mutex_lock(&s->mu);
	s->stop = true;
	pthread_cond_signal(&s->cv);
	pthread_mutex_unlock(&s->mu);
	pthread_join(s->thread, NULL);
	pthread_mutex_destroy(&s->mu);
	pthread_cond_destroy(&s->cv);
	osc_free(s);
	o->priv = NULL;
}

static void osc_send(struct output *o, const struct out_msg *m, int n)
{
	struct osc *s = o->priv;
	bool frames = o->cfg->decimate <= 1 || o->cycle % (uint32_t)o->cfg->decimate == 0;
	struct timespec ts;

	o->cycle++;
	if (!frames)
		return;
	clock_gettime(CLOCK_MONOTONIC, &ts);
	snap_put_batch(&s->snap, o->wants, m, n, (uint64_t)ts.tv_sec * 1000000000ull + (uint64_t)ts.tv_nsec);
}

static void osc_service(struct output *o)
{
	(void)o;
}

const struct output_ops vmc_output_ops = {
	.type = { CFG_TYPE("vmc", "the VMC protocol over OSC (VSeeFace, EVMC4U, VMC4UE)", vmc_keys, struct osc_opts),
		  CFG_SHARED(osc_shared_keys), .check = osc_check },
	.open = osc_open,
	.close = osc_close,
	.send = osc_send,
	.service = osc_service,
};

const struct output_ops vrchat_output_ops = {
	.type = { CFG_TYPE("vrchat", "VRChat's OSC trackers", vrchat_keys, struct osc_opts),
		  CFG_SHARED(osc_shared_keys), .check = osc_check },
	.open = osc_open,
	.close = osc_close,
	.send = osc_send,
	.service = osc_service,
};
