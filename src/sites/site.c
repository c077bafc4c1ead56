// SPDX-License-Identifier: MIT
/*
 * site.c - see site.h. Built when Cyclone DDS is installed (sites.mk); the
 * types come from avatargw.idl through idlc.
 */
#include "sites/site.h"

#include "avatargw.h"
#include "ros2.h"
#include "base/clock.h"
#include "base/counter.h"
#include "base/json.h"
#include "base/hist.h"
#include "base/seqlock.h"

#include <dds/dds.h>

#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <poll.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>
#include <sys/eventfd.h>
#include <time.h>
#include <unistd.h>

const bool site_built_in = true;

#define FRAME_MAX (WIRE_FRAME_LEN + WIRE_INPUTS_LEN)
#define OUT_WORDS (1 + FRAME_MAX / 4)	   /* length, then the FRAME's bytes */
#define IN_HEAD 3			   /* length, arrival (CLOCK_MONOTONIC, 2 words) */
#define IN_WORDS (IN_HEAD + FRAME_MAX / 4) /* then the FRAME's bytes */
#define DESC_WORDS (1 + WIRE_MAX_MSG / 4)  /* length, then the DESCRIBE's bytes */
#define SITE_MAX_PEERS 32		   /* remote sites followed at most */
#define TAKE_MAX 32			   /* samples taken at once */
#define PING_NS 1000000000ull		   /* clock pings: one a second */
#define CLOCK_KEEP_NS 10000000000ull	   /* a clock estimate is replaced by a worse one after 10 s */
#define MAX_AUTO_INDEX 9 /* participants per host with unicast discovery: each peer's ports 0-9 are probed */

_Static_assert(FRAME_MAX % 4 == 0 && WIRE_MAX_MSG % 4 == 0, "whole words");

/* "SITE/AVATAR" and its NUL; a remote site's figures (struct wire_site) */
#define NAME_WORDS ((CFG_SITE_NAME_MAX + WIRE_NAME_MAX + 4) / 4)
#define FIG_WORDS ((int)(sizeof(struct wire_site) + 3) / 4)

static const char *const topic_frame = "avatargw_frame";
static const char *const topic_desc = "avatargw_description";
static const char *const topic_clock = "avatargw_clock";

/* a local avatar's FRAME, from the loop to the publishing thread */
struct out_slot {
	_Atomic uint32_t seq;
	_Atomic uint32_t w[OUT_WORDS];
	uint32_t sent;	   /* publishing thread: the sequence written last */
	uint32_t samples;  /* publishing thread: samples written (the Frame's seq) */
	uint32_t last_seq; /* publishing thread: the FRAME sequence written last */
	bool have_last;
};

/* a remote avatar */
struct rslot {
	/* shared: written by the receiving thread, read by the loop */
	_Atomic uint32_t gen; /* odd: live; +1 at each arrival and departure */
	_Atomic uint32_t fseq;
	_Atomic uint32_t fw[IN_WORDS];
	_Atomic uint32_t dseq;
	_Atomic uint32_t dw[DESC_WORDS];
	/* shared with the control thread: "SITE/AVATAR", written when the slot is given to an avatar */
	_Atomic uint32_t nseq;
	_Atomic uint32_t nw[NAME_WORDS];
	/* the receiving thread's */
	char site[CFG_SITE_NAME_MAX];
	char avatar[WIRE_NAME_MAX + 1];
	bool used;
	bool live;
	_Atomic int peer; /* its site in peer[], -1: none; the loop reads it too (site_remote_site) */
	uint32_t last_seq;
	bool have_seq;
	dds_instance_handle_t writer; /* the remote writer of its last frame */
	uint64_t last_use;	      /* for reuse of a gone slot: the oldest goes first */
	/* the loop's */
	uint32_t l_gen, l_fseq, l_dseq;
	uint32_t l_figs; /* the peer's figures' sequence last read */
	bool l_desc, l_have;
	uint64_t l_arrival;
	struct wire_frame l_wf;
};

/* a remote site: written by the receiving thread, read by the control thread */
struct peer {
	char name[CFG_SITE_NAME_MAX];
	_Atomic int used;
	_Atomic uint64_t frames, lost, descriptions, joins, departures;
	_Atomic uint64_t avatars; /* live now */
	_Atomic uint64_t last_mono;
	_Atomic int64_t offset_ns; /* its clock minus ours */
	_Atomic int64_t rtt_ns;	   /* of the estimate in use, -1: none yet */
	struct hist delay;	   /* its sample time (on our clock) -> arrival here */
	uint64_t best_at;	   /* receiving thread: when the estimate in use was made */
	/* receiving thread, once a second: the rate, and every figure for the loop's DESCRIBEs */
	uint64_t r_frames, r_t;
	_Atomic uint32_t rate_bits; /* float, frames a second */
	_Atomic uint32_t fseq;
	_Atomic uint32_t fw[FIG_WORDS]; /* struct wire_site */
};

struct site {
	struct cfg_site cfg;
	uint32_t source_id;
	double rate;
	uint64_t stale_ns, deadline_ns, lease_ns;
	int n_local;
	char (*local_name)[WIRE_NAME_MAX + 1];
	struct out_slot *out;
	avatargw_sites_Description *local_desc;
	bool *local_described;
	int n_remote;
	struct rslot *rs;
	struct peer peer[SITE_MAX_PEERS];
	/* DDS */
	dds_entity_t pp, pub, sub, t_frame, t_desc, t_clock, w_frame, w_desc, w_clock, r_frame, r_desc, r_clock;
	dds_entity_t ws, c_frame, c_desc, c_clock;
	/* ROS 2 (ros2 = yes): outside the session's partition, where ROS 2 nodes are */
	struct site_ros2 *ros;
	int domain_ref; /* index into domains[], -1: none */
	/* threads */
	int efd;
	_Atomic bool stop;
	pthread_t pub_thr, sub_thr;
	bool pub_started, sub_started;
	bool put_any; /* loop: a FRAME was put this cycle */
	/* the threads' buffers, allocated at start-up */
	avatargw_sites_Frame *fbuf; /* the receiving thread's */
	avatargw_sites_Frame *pbuf; /* the publishing thread's sample */
	avatargw_sites_Description *dbuf;
	avatargw_sites_Clock *cbuf;
	/* counters */
	_Atomic uint64_t written, write_errors, wakeups, no_slot, bad_samples, coalesced;
	uint64_t last_ping;
};

static dds_qos_t *qos_common(void);
static int fail_dds(char *err, size_t errlen, const char *what, dds_return_t rc);

/* ---- ROS 2: JointState per avatar, TF for all --------------------------------------------------------- */

#define ROS_NAME_MAX 96

/* one local avatar's messages, their buffers allocated at start-up and filled in place */
struct ros2_avatar {
	dds_entity_t topic, writer;
	sensor_msgs_msg_dds__JointState_ js;
	char *joint_name[WIRE_JOINTS];
	double position[WIRE_JOINTS];
	geometry_msgs_msg_dds__TransformStamped_ tf[WIRE_SEGMENTS];
	char child[WIRE_SEGMENTS][ROS_NAME_MAX];
};

struct site_ros2 {
	dds_entity_t pub, t_tf, w_tf;
	tf2_msgs_msg_dds__TFMessage_ tfm;
	struct ros2_avatar *av;
};

static char ros_empty[] = "";
static char ros_world[] = "world";

/* a ROS 2 name component: letters, digits and underscores, not starting with a digit */
static void ros_component(char *out, size_t n, const char *in)
{
	size_t k = 0;

	if (isdigit((unsigned char)in[0]) && k + 1 < n)
		out[k++] = '_';
	for (; *in && k + 1 < n; in++)
		out[k++] = isalnum((unsigned char)*in) ? *in : '_';
	out[k] = '\0';
}

/* the ROS 2 header of a sample at sample time t (CLOCK_REALTIME ns) */
static void ros_stamp(std_msgs_msg_dds__Header_ *h, uint64_t t)
{
	h->stamp.sec = (int32_t)(t / 1000000000ull);
	h->stamp.nanosec = (uint32_t)(t % 1000000000ull);
}

static void ros2_publish(struct site *s, int i, const struct wire_frame *f)
{
	struct site_ros2 *r = s->ros;
	struct ros2_avatar *a = &r->av[i];
	uint64_t t = f->h.sample_time_ns ? f->h.sample_time_ns : real_ns();

	ros_stamp(&a->js.header, t);
	for (int j = 0; j < WIRE_JOINTS; j++)
		a->position[j] = f->joint[j];
	if (dds_write(a->writer, &a->js) < 0)
		ctr_add(&s->write_errors, 1);
	for (int k = 0; k < WIRE_SEGMENTS; k++) {
		geometry_msgs_msg_dds__TransformStamped_ *ts = &a->tf[k];
		const struct wire_pose *p = &f->segment[k];

		ros_stamp(&ts->header, t);
		ts->transform.translation.x = p->p[0];
		ts->transform.translation.y = p->p[1];
		ts->transform.translation.z = p->p[2];
		ts->transform.rotation.w = p->q[0];
		ts->transform.rotation.x = p->q[1];
		ts->transform.rotation.y = p->q[2];
		ts->transform.rotation.z = p->q[3];
	}
	r->tfm.transforms._buffer = a->tf;
	if (dds_write(r->w_tf, &r->tfm) < 0)
		ctr_add(&s->write_errors, 1);
}

/* ROS 2's entities and each local avatar's messages; 0 or a negative errno */
static int ros2_open(struct site *s, char *err, size_t errlen)
{
	struct site_ros2 *r = calloc(1, sizeof(*r));
	dds_qos_t *q;
	char site[ROS_NAME_MAX / 2], av[ROS_NAME_MAX / 2], topic[2 * ROS_NAME_MAX];

	s->ros = r;
	if (!r || !(r->av = calloc((size_t)s->n_local + 1, sizeof(*r->av))))
		return snprintf(err, errlen, "out of memory"), -ENOMEM;
	/* ROS 2's defaults: reliable, volatile, keep last 10 (TF: 100); XCDR1 */
	q = qos_common();
	dds_qset_reliability(q, DDS_RELIABILITY_RELIABLE, DDS_MSECS(0));
	dds_qset_history(q, DDS_HISTORY_KEEP_LAST, 10);
	r->pub = dds_create_publisher(s->pp, NULL, NULL);
	r->t_tf = dds_create_topic(s->pp, &tf2_msgs_msg_dds__TFMessage__desc, "rt/tf", NULL, NULL);
	ros_component(site, sizeof(site), s->cfg.name);
	for (int i = 0; i < s->n_local; i++) {
		struct ros2_avatar *a = &r->av[i];

		ros_component(av, sizeof(av), s->local_name[i]);
		snprintf(topic, sizeof(topic), "rt/%s/%s/joint_states", site, av);
		a->topic = dds_create_topic(s->pp, &sensor_msgs_msg_dds__JointState__desc, topic, NULL, NULL);
		a->writer = a->topic < 0 ? a->topic : dds_create_writer(r->pub, a->topic, q, NULL);
		if (a->writer < 0) {
			dds_delete_qos(q);
			return fail_dds(err, errlen, "ROS 2 JointState writer", a->writer);
		}
		for (int j = 0; j < WIRE_JOINTS; j++)
			a->joint_name[j] = (char *)wire_joint_names[j];
		a->js.header.frame_id = ros_empty;
		a->js.name = (dds_sequence_string){ WIRE_JOINTS, WIRE_JOINTS, a->joint_name, false };
		a->js.position = (dds_sequence_double){ WIRE_JOINTS, WIRE_JOINTS, a->position, false };
		for (int k = 0; k < WIRE_SEGMENTS; k++) {
			snprintf(a->child[k], sizeof(a->child[k]), "%.31s/%s/%s", s->cfg.name, s->local_name[i],
				 wire_segment_names[k]);
			a->tf[k].header.frame_id = ros_world;
			a->tf[k].child_frame_id = a->child[k];
		}
	}
	dds_qset_history(q, DDS_HISTORY_KEEP_LAST, 100);
	r->w_tf = r->t_tf < 0 ? r->t_tf : dds_create_writer(r->pub, r->t_tf, q, NULL);
	dds_delete_qos(q);
	if (r->pub < 0 || r->w_tf < 0)
		return fail_dds(err, errlen, "ROS 2 TF writer", r->pub < 0 ? r->pub : r->w_tf);
	r->tfm.transforms._maximum = r->tfm.transforms._length = WIRE_SEGMENTS;
	r->tfm.transforms._release = false;
	return 0;
}

static void ros2_free(struct site *s)
{
	if (s->ros)
		free(s->ros->av);
	free(s->ros);
}

/* ---- the domain: one per domain id and process, shared across a reload ---------------------------------- */

static struct {
	dds_domainid_t id;
	dds_entity_t dom;
	int refs;
	char xml[4096]; /* its configuration: a reload cannot change it while the domain runs */
} domains[4];
static pthread_mutex_t domains_mu = PTHREAD_MUTEX_INITIALIZER;

static void xml_add(char *x, size_t n, const char *fmt, const char *arg)
{
	size_t l = strlen(x);

	if (l < n)
		snprintf(x + l, n - l, fmt, arg);
}

/* Cyclone DDS's configuration for the site: interfaces, discovery, lease, security */
static int make_xml(const struct cfg_site *c, char *x, size_t n, char *err, size_t errlen)
{
	char buf[64], peers[CFG_PATH_MAX];
	char *save = NULL;

	x[0] = '\0';
	xml_add(x, n, "%s", "<CycloneDDS><Domain id=\"any\"><General>");
	if (c->interface[0]) {
		/* an address or an interface's name */
		bool addr = strspn(c->interface, "0123456789.:abcdefABCDEF") == strlen(c->interface) &&
			    strpbrk(c->interface, ".:");

		xml_add(x, n,
			addr ? "<Interfaces><NetworkInterface address=\"%s\"/></Interfaces>"
			     : "<Interfaces><NetworkInterface name=\"%s\"/></Interfaces>",
			c->interface);
	}
	if (c->peers[0])
		xml_add(x, n, "%s", "<AllowMulticast>false</AllowMulticast>");
	xml_add(x, n, "%s", "</General><Discovery>");
	if (c->peers[0]) {
		snprintf(buf, sizeof(buf), "%d", MAX_AUTO_INDEX);
		xml_add(x, n, "<ParticipantIndex>auto</ParticipantIndex><MaxAutoParticipantIndex>%s", buf);
		xml_add(x, n, "%s", "</MaxAutoParticipantIndex><Peers>");
		snprintf(peers, sizeof(peers), "%s", c->peers);
		for (char *p = strtok_r(peers, " \t,", &save); p; p = strtok_r(NULL, " \t,", &save)) {
			if (strpbrk(p, "<>\"&'"))
				return snprintf(err, errlen, "[site] peers: '%s' is not an address", p), -EINVAL;
			xml_add(x, n, "<Peer address=\"%s\"/>", p);
		}
		xml_add(x, n, "%s", "</Peers>");
	}
	/* a site that stops is gone after its lease; announcements twice per lease (frames renew it too) */
	snprintf(buf, sizeof(buf), "%.0fms", c->lease * 1000);
	xml_add(x, n, "<LeaseDuration>%s</LeaseDuration>", buf);
	snprintf(buf, sizeof(buf), "%.0fms", c->lease * 500);
	xml_add(x, n, "<SPDPInterval>%s</SPDPInterval>", buf);
	xml_add(x, n, "%s", "</Discovery>");
	if (c->security[0]) {
		const char *d = c->security;

		if (strpbrk(d, "<>\"&'"))
			return snprintf(err, errlen, "[site] security: the path has characters XML cannot take"),
			       -EINVAL;
		xml_add(x, n, "%s", "<Security><Authentication>");
		xml_add(x, n, "<Library path=\"%s/libdds_security_auth.so\" initFunction=\"init_authentication\" ",
			SITES_PLUGINS);
		xml_add(x, n, "%s", "finalizeFunction=\"finalize_authentication\"/>");
		xml_add(x, n, "<IdentityCA>file:%s/ca.pem</IdentityCA>", d);
		xml_add(x, n, "<IdentityCertificate>file:%s/cert.pem</IdentityCertificate>", d);
		xml_add(x, n, "<PrivateKey>file:%s/key.pem</PrivateKey>", d);
		xml_add(x, n, "%s", "</Authentication><AccessControl>");
		xml_add(x, n, "<Library path=\"%s/libdds_security_ac.so\" initFunction=\"init_access_control\" ",
			SITES_PLUGINS);
		xml_add(x, n, "%s", "finalizeFunction=\"finalize_access_control\"/>");
		xml_add(x, n, "<PermissionsCA>file:%s/ca.pem</PermissionsCA>", d);
		xml_add(x, n, "<Governance>file:%s/governance.p7s</Governance>", d);
		xml_add(x, n, "<Permissions>file:%s/permissions.p7s</Permissions>", d);
		xml_add(x, n, "%s", "</AccessControl><Cryptographic>");
		xml_add(x, n, "<Library path=\"%s/libdds_security_crypto.so\" initFunction=\"init_crypto\" ",
			SITES_PLUGINS);
		xml_add(x, n, "%s", "finalizeFunction=\"finalize_crypto\"/></Cryptographic></Security>");
	}
	if (getenv("AVATARGW_DDS_TRACE")) {
		/* Cyclone's own trace, for diagnosing discovery (docs/SITES.md) */
		if (strpbrk(getenv("AVATARGW_DDS_TRACE"), "<>\"&'"))
			return snprintf(err, errlen, "AVATARGW_DDS_TRACE: not a file name"), -EINVAL;
		xml_add(x, n, "<Tracing><Verbosity>finer</Verbosity><OutputFile>%s</OutputFile></Tracing>",
			getenv("AVATARGW_DDS_TRACE"));
	}
	xml_add(x, n, "%s", "</Domain></CycloneDDS>");
	if (strlen(x) + 1 >= n)
		return snprintf(err, errlen, "[site]: the DDS configuration is too long"), -EINVAL;
	return 0;
}

static int domain_get(const struct cfg_site *c, char *err, size_t errlen)
{
	char xml[4096];
	int rc = make_xml(c, xml, sizeof(xml), err, errlen), slot = -1;

	if (rc)
		return rc;
	pthread_mutex_lock(&domains_mu);
	for (int i = 0; i < (int)(sizeof(domains) / sizeof(domains[0])); i++) {
		if (domains[i].refs && domains[i].id == (dds_domainid_t)c->domain) {
			/* a reload: the domain of the running configuration, whose network settings Cyclone fixed */
			if (strcmp(domains[i].xml, xml)) {
				pthread_mutex_unlock(&domains_mu);
				snprintf(err, errlen,
					 "[site]: interface, peers, security or lease changed: Cyclone DDS "
					 "cannot change them in a running domain; restart the daemon to apply them");
				return -EBUSY;
			}
			domains[i].refs++;
			pthread_mutex_unlock(&domains_mu);
			return i;
		}
		if (!domains[i].refs && slot < 0)
			slot = i;
	}
	if (slot < 0) {
		pthread_mutex_unlock(&domains_mu);
		return snprintf(err, errlen, "[site]: too many DDS domains"), -EBUSY;
	}
	domains[slot].dom = dds_create_domain((dds_domainid_t)c->domain, xml);
	if (domains[slot].dom < 0) {
		pthread_mutex_unlock(&domains_mu);
		snprintf(err, errlen, "[site]: Cyclone DDS refused the domain (%s)%s",
			 dds_strretcode(domains[slot].dom),
			 c->security[0] ? ": check the files of security =" : ": check interface =");
		return -EINVAL;
	}
	domains[slot].id = (dds_domainid_t)c->domain;
	domains[slot].refs = 1;
	snprintf(domains[slot].xml, sizeof(domains[slot].xml), "%s", xml);
	pthread_mutex_unlock(&domains_mu);
	return slot;
}

static void domain_put(int i)
{
	if (i < 0)
		return;
	pthread_mutex_lock(&domains_mu);
	if (--domains[i].refs == 0)
		dds_delete(domains[i].dom);
	pthread_mutex_unlock(&domains_mu);
}

/* ---- conversions between the wire messages and the DDS samples -------------------------------------- */

static void pose_to(const struct wire_pose *w, avatargw_sites_Pose *d)
{
	memcpy(d->p, w->p, sizeof(d->p));
	memcpy(d->q, w->q, sizeof(d->q));
}

static void pose_from(const avatargw_sites_Pose *d, struct wire_pose *w)
{
	memcpy(w->p, d->p, sizeof(w->p));
	memcpy(w->q, d->q, sizeof(w->q));
}

static void frame_to_dds(const struct wire_frame *f, avatargw_sites_Frame *d)
{
	d->flags = f->h.flags;
	for (int i = 0; i < WIRE_SENSORS; i++) {
		d->sensor[i].state = f->sensor[i].state;
		d->sensor[i].age_100us = f->sensor[i].age_100us;
		pose_to(&f->sensor[i].pose, &d->sensor[i].sample_pose);
	}
	for (int i = 0; i < WIRE_ARMS; i++) {
		d->arm[i].ik_flags = f->arm[i].ik_flags;
		d->arm[i].iters = f->arm[i].iters;
		d->arm[i].pos_err = f->arm[i].pos_err;
	}
	memcpy(d->joint, f->joint, sizeof(d->joint));
	for (int i = 0; i < WIRE_SEGMENTS; i++)
		pose_to(&f->segment[i], &d->segment[i]);
	d->inputs._d = (f->h.flags & WIRE_F_INPUTS) != 0;
	if (d->inputs._d) {
		d->inputs._u.block.present = f->in.present;
		memcpy(d->inputs._u.block.buttons, f->in.buttons, sizeof(d->inputs._u.block.buttons));
		memcpy(d->inputs._u.block.analog, f->in.analog, sizeof(d->inputs._u.block.analog));
	} else {
		d->inputs._u.none = 0;
	}
}

/* t_ns: the sample's source timestamp, the FRAME's sample time */
static void frame_from_dds(const avatargw_sites_Frame *d, uint64_t t_ns, struct wire_frame *f)
{
	memset(f, 0, sizeof(*f));
	f->h.seq = d->seq;
	f->h.flags = d->flags & (uint16_t)~WIRE_F_INPUTS;
	f->h.sample_time_ns = t_ns;
	for (int i = 0; i < WIRE_SENSORS; i++) {
		f->sensor[i].state =
			d->sensor[i].state <= WIRE_SENSOR_MISSING ? d->sensor[i].state : WIRE_SENSOR_MISSING;
		f->sensor[i].age_100us = d->sensor[i].age_100us;
		pose_from(&d->sensor[i].sample_pose, &f->sensor[i].pose);
	}
	for (int i = 0; i < WIRE_ARMS; i++) {
		f->arm[i].ik_flags = d->arm[i].ik_flags;
		f->arm[i].iters = d->arm[i].iters;
		f->arm[i].pos_err = d->arm[i].pos_err;
	}
	memcpy(f->joint, d->joint, sizeof(f->joint));
	for (int i = 0; i < WIRE_SEGMENTS; i++)
		pose_from(&d->segment[i], &f->segment[i]);
	if (d->inputs._d) {
		f->h.flags |= WIRE_F_INPUTS;
		f->in.present = d->inputs._u.block.present;
		memcpy(f->in.buttons, d->inputs._u.block.buttons, sizeof(f->in.buttons));
		memcpy(f->in.analog, d->inputs._u.block.analog, sizeof(f->in.analog));
	}
}

/* a remote FRAME must not carry a number that is not finite where the protocol has none */
static bool frame_finite(const struct wire_frame *f)
{
	for (int j = 0; j < WIRE_JOINTS; j++)
		if (isinf(f->joint[j]))
			return false;
	for (int s = 0; s < WIRE_SEGMENTS; s++)
		for (int k = 0; k < 7; k++)
			if (isinf(k < 3 ? f->segment[s].p[k] : f->segment[s].q[k - 3]))
				return false;
	for (int r = 0; r < WIRE_SENSORS; r++)
		for (int k = 0; k < 7; k++) {
			float v = k < 3 ? f->sensor[r].pose.p[k] : f->sensor[r].pose.q[k - 3];

			if (isinf(v) || (isnan(v) && f->sensor[r].state != WIRE_SENSOR_MISSING))
				return false;
		}
	return true;
}

static void describe_to_dds(const struct wire_describe *w, avatargw_sites_Description *d)
{
	snprintf(d->display_name, sizeof(d->display_name), "%s/%s", d->site, w->avatar_name);
	d->describe_rev = w->h.describe_rev;
	d->rate_hz = w->rate_hz;
	memcpy(d->dims, w->dims, sizeof(d->dims));
	memcpy(d->head_offset, w->head_offset, sizeof(d->head_offset));
	snprintf(d->conventions, sizeof(d->conventions), "%s", w->conventions);
	for (int j = 0; j < WIRE_JOINTS; j++) {
		snprintf(d->joint[j].name, sizeof(d->joint[j].name), "%s", w->joint[j].name);
		d->joint[j].segment = w->joint[j].segment;
		d->joint[j].lo = w->joint[j].lo;
		d->joint[j].hi = w->joint[j].hi;
		memcpy(d->joint[j].axis, w->joint[j].axis, sizeof(d->joint[j].axis));
		memcpy(d->joint[j].trans, w->joint[j].trans, sizeof(d->joint[j].trans));
	}
	for (int s = 0; s < WIRE_SEGMENTS; s++) {
		snprintf(d->segment[s].name, sizeof(d->segment[s].name), "%s", w->segment[s].name);
		d->segment[s].parent = w->segment[s].parent;
	}
	for (int r = 0; r < WIRE_SENSORS; r++)
		snprintf(d->sensor[r], sizeof(d->sensor[r]), "%s", w->sensor[r]);
}

/* the remote avatar's DESCRIBE here: its name SITE/NAME (cut to the protocol's 15 bytes), our ids */
static void describe_from_dds(const avatargw_sites_Description *d, struct wire_describe *w, uint32_t source_id,
			      uint16_t id)
{
	char name[CFG_SITE_NAME_MAX + WIRE_NAME_MAX + 2];

	memset(w, 0, sizeof(*w));
	w->h.source_id = source_id;
	w->h.avatar_id = id;
	w->rate_hz = d->rate_hz;
	memcpy(w->dims, d->dims, sizeof(w->dims));
	memcpy(w->head_offset, d->head_offset, sizeof(w->head_offset));
	snprintf(name, sizeof(name), "%s/%s", d->site, d->avatar);
	memcpy(w->avatar_name, name, WIRE_NAME_MAX);
	w->avatar_name[WIRE_NAME_MAX] = '\0';
	snprintf(w->conventions, sizeof(w->conventions), "%.*s", WIRE_NAME_MAX * 4, d->conventions);
	for (int j = 0; j < WIRE_JOINTS; j++) {
		snprintf(w->joint[j].name, sizeof(w->joint[j].name), "%s", d->joint[j].name);
		w->joint[j].segment = d->joint[j].segment < WIRE_SEGMENTS ? d->joint[j].segment : 0;
		w->joint[j].lo = d->joint[j].lo;
		w->joint[j].hi = d->joint[j].hi;
		memcpy(w->joint[j].axis, d->joint[j].axis, sizeof(w->joint[j].axis));
		memcpy(w->joint[j].trans, d->joint[j].trans, sizeof(w->joint[j].trans));
	}
	for (int s = 0; s < WIRE_SEGMENTS; s++) {
		snprintf(w->segment[s].name, sizeof(w->segment[s].name), "%s", d->segment[s].name);
		w->segment[s].parent = d->segment[s].parent;
	}
	for (int r = 0; r < WIRE_SENSORS; r++)
		snprintf(w->sensor[r], sizeof(w->sensor[r]), "%s", d->sensor[r]);
}

/* ---- words in and out of the sequence locks ------------------------------------------------------------ */

static void bytes_to_words(uint32_t *w, const uint8_t *b, size_t len)
{
	memcpy(w, b, len);
	if (len % 4)
		memset((uint8_t *)w + len, 0, 4 - len % 4);
}

/* ---- the publishing thread ------------------------------------------------------------------------------ */

static void publish_all(struct site *s)
{
	uint32_t w[OUT_WORDS];
	avatargw_sites_Frame *d = s->pbuf;
	struct wire_frame f;

	for (int i = 0; i < s->n_local; i++) {
		struct out_slot *o = &s->out[i];
		uint32_t sq;

		if (seqlock_peek(&o->seq) == o->sent)
			continue;
		sq = seqlock_read(&o->seq, o->w, w, OUT_WORDS);
		if (sq == o->sent || w[0] > FRAME_MAX || wire_decode_frame((const uint8_t *)(w + 1), w[0], &f)) {
			o->sent = sq;
			continue;
		}
		o->sent = sq;
		/* the loop was faster than this thread: frames it replaced before they were written */
		if (o->have_last && f.h.seq - o->last_seq > 1)
			ctr_add(&s->coalesced, f.h.seq - o->last_seq - 1);
		o->last_seq = f.h.seq;
		o->have_last = true;
		memset(d, 0, sizeof(*d));
		snprintf(d->site, sizeof(d->site), "%.31s", s->cfg.name);
		snprintf(d->avatar, sizeof(d->avatar), "%s", s->local_name[i]);
		frame_to_dds(&f, d);
		d->seq = ++o->samples;
		/* the sample time is the source timestamp (a frame without any sample yet: now) */
		if (dds_write_ts(s->w_frame, d, f.h.sample_time_ns ? (dds_time_t)f.h.sample_time_ns : dds_time()) < 0)
			ctr_add(&s->write_errors, 1);
		else
			ctr_add(&s->written, 1);
		if (s->ros)
			ros2_publish(s, i, &f);
	}
}

static void *pub_main(void *arg)
{
	struct site *s = arg;
	struct pollfd pfd = { .fd = s->efd, .events = POLLIN };

	pthread_setname_np(pthread_self(), "agw-site-pub");
	/* every local avatar's description, once: TRANSIENT_LOCAL keeps them for late joiners */
	for (int i = 0; i < s->n_local; i++)
		if (s->local_described[i] && dds_write(s->w_desc, &s->local_desc[i]) < 0)
			ctr_add(&s->write_errors, 1);
	while (!atomic_load_explicit(&s->stop, memory_order_acquire)) {
		uint64_t v;

		if (poll(&pfd, 1, 100) <= 0)
			continue;
		if (read(s->efd, &v, sizeof(v)) != sizeof(v))
			continue;
		ctr_add(&s->wakeups, 1);
		publish_all(s);
	}
	return NULL;
}

/* ---- the receiving thread ------------------------------------------------------------------------------- */

static int peer_of(struct site *s, const char *name)
{
	int free_i = -1;

	for (int i = 0; i < SITE_MAX_PEERS; i++) {
		if (atomic_load_explicit(&s->peer[i].used, memory_order_relaxed)) {
			if (!strcmp(s->peer[i].name, name))
				return i;
		} else if (free_i < 0) {
			free_i = i;
		}
	}
	if (free_i < 0)
		return -1;
	snprintf(s->peer[free_i].name, sizeof(s->peer[free_i].name), "%s", name);
	atomic_store_explicit(&s->peer[free_i].rtt_ns, -1, memory_order_relaxed);
	atomic_store_explicit(&s->peer[free_i].used, 1, memory_order_release);
	return free_i;
}

/* the slot of (site, avatar): its own if it had one (an avatar that comes back keeps its id), else a new one */
static struct rslot *slot_of(struct site *s, const char *site, const char *avatar, bool create)
{
	struct rslot *spare = NULL;

	for (int k = 0; k < s->n_remote; k++) {
		struct rslot *r = &s->rs[k];

		if (r->used && !strcmp(r->site, site) && !strcmp(r->avatar, avatar))
			return r;
		if (!r->used && !spare)
			spare = r;
	}
	if (!create)
		return NULL;
	if (!spare) {
		/* every slot has had an avatar: the one gone longest */
		for (int k = 0; k < s->n_remote; k++) {
			struct rslot *r = &s->rs[k];

			if (!r->live && (!spare || r->last_use < spare->last_use))
				spare = r;
		}
		if (!spare)
			return NULL;
		/* its description no longer applies */
		atomic_store_explicit(&spare->dseq, 0, memory_order_release);
	}
	spare->used = true;
	spare->live = false;
	spare->have_seq = false;
	spare->peer = peer_of(s, site);
	snprintf(spare->site, sizeof(spare->site), "%s", site);
	snprintf(spare->avatar, sizeof(spare->avatar), "%s", avatar);
	{
		uint32_t w[NAME_WORDS] = { 0 };

		snprintf((char *)w, sizeof(w), "%s/%s", site, avatar);
		seqlock_write(&spare->nseq, spare->nw, w, NAME_WORDS);
	}
	return spare;
}

static void slot_live(struct site *s, struct rslot *r, bool live)
{
	struct peer *p = r->peer >= 0 ? &s->peer[r->peer] : NULL;

	if (r->live == live)
		return;
	r->live = live;
	r->last_use = mono_ns();
	atomic_store_explicit(&r->gen, atomic_load_explicit(&r->gen, memory_order_relaxed) + 1, memory_order_release);
	if (!p)
		return;
	if (live) {
		ctr_add(&p->joins, 1);
		ctr_add(&p->avatars, 1);
	} else {
		ctr_add(&p->departures, 1);
		atomic_store_explicit(&p->avatars, ctr_get(&p->avatars) - 1, memory_order_relaxed);
	}
}

static bool own(const struct site *s, const char *site)
{
	return !strcmp(site, s->cfg.name);
}

static void take_frames(struct site *s)
{
	void *ptr[TAKE_MAX];
	dds_sample_info_t info[TAKE_MAX];
	uint32_t w[IN_WORDS];
	int n;

	for (int i = 0; i < TAKE_MAX; i++)
		ptr[i] = &s->fbuf[i];
	while ((n = dds_take(s->r_frame, ptr, info, TAKE_MAX, TAKE_MAX)) > 0) {
		uint64_t arrival = mono_ns(), arrival_real = real_ns();

		for (int i = 0; i < n; i++) {
			avatargw_sites_Frame *d = &s->fbuf[i];
			struct wire_frame f;
			struct rslot *r;
			struct peer *p;
			size_t len;

			d->site[sizeof(d->site) - 1] = '\0';
			d->avatar[sizeof(d->avatar) - 1] = '\0';
			if (own(s, d->site))
				continue;
			if (!info[i].valid_data) {
				/* the instance's writer is gone (lease, crash) or disposed it (a site that stopped) */
				if (info[i].instance_state != DDS_IST_ALIVE &&
				    (r = slot_of(s, d->site, d->avatar, false)))
					slot_live(s, r, false);
				continue;
			}
			r = slot_of(s, d->site, d->avatar, true);
			if (!r) {
				ctr_add(&s->no_slot, 1);
				continue;
			}
			frame_from_dds(d, (uint64_t)info[i].source_timestamp, &f);
			if (!frame_finite(&f)) {
				ctr_add(&s->bad_samples, 1);
				continue;
			}
			p = r->peer >= 0 ? &s->peer[r->peer] : NULL;
			if (p) {
				int64_t off = atomic_load_explicit(&p->offset_ns, memory_order_relaxed);

				ctr_add(&p->frames, 1);
				atomic_store_explicit(&p->last_mono, arrival, memory_order_relaxed);
				if (r->have_seq && d->seq - r->last_seq > 1 && d->seq - r->last_seq < 1000000)
					ctr_add(&p->lost, d->seq - r->last_seq - 1);
				if (atomic_load_explicit(&p->rtt_ns, memory_order_relaxed) >= 0 && f.h.sample_time_ns) {
					int64_t delay = (int64_t)(arrival_real - f.h.sample_time_ns) + off;

					hist_add(&p->delay, delay > 0 ? (uint64_t)delay : 0);
				}
			}
			r->last_seq = d->seq;
			r->have_seq = true;
			r->writer = info[i].publication_handle;
			len = wire_encode_frame(&f, (uint8_t *)(w + IN_HEAD));
			w[0] = (uint32_t)len;
			w[1] = (uint32_t)arrival;
			w[2] = (uint32_t)(arrival >> 32);
			if (len % 4)
				memset((uint8_t *)(w + IN_HEAD) + len, 0, 4 - len % 4);
			seqlock_write(&r->fseq, r->fw, w, IN_WORDS);
			slot_live(s, r, true);
		}
	}
}

/*
 * A remote writer no longer matched (its site stopped, or its lease ran out
 * after a crash): the avatars it wrote are gone. Cyclone tells the reader
 * through the subscription-matched status; the instances' NOT_ALIVE states
 * are also taken (take_frames) but this does not depend on them.
 */
static void sweep_writers(struct site *s)
{
	dds_subscription_matched_status_t st;
	dds_instance_handle_t h[256];
	int32_t n;

	if (dds_get_subscription_matched_status(s->r_frame, &st) < 0 || st.current_count_change >= 0)
		return;
	n = dds_get_matched_publications(s->r_frame, h, sizeof(h) / sizeof(h[0]));
	if (n < 0 || n > (int32_t)(sizeof(h) / sizeof(h[0])))
		return;
	for (int k = 0; k < s->n_remote; k++) {
		struct rslot *r = &s->rs[k];
		bool found = false;

		if (!r->live)
			continue;
		for (int i = 0; i < n && !found; i++)
			found = h[i] == r->writer;
		if (!found)
			slot_live(s, r, false);
	}
}

static void take_descriptions(struct site *s)
{
	void *ptr[TAKE_MAX];
	dds_sample_info_t info[TAKE_MAX];
	uint8_t msg[WIRE_MAX_MSG];
	uint32_t w[DESC_WORDS];
	int n;

	for (int i = 0; i < TAKE_MAX; i++)
		ptr[i] = &s->dbuf[i];
	while ((n = dds_take(s->r_desc, ptr, info, TAKE_MAX, TAKE_MAX)) > 0) {
		for (int i = 0; i < n; i++) {
			avatargw_sites_Description *d = &s->dbuf[i];
			struct wire_describe wd;
			struct rslot *r;
			size_t len;

			d->site[sizeof(d->site) - 1] = '\0';
			d->avatar[sizeof(d->avatar) - 1] = '\0';
			if (own(s, d->site) || !info[i].valid_data)
				continue;
			r = slot_of(s, d->site, d->avatar, true);
			if (!r) {
				ctr_add(&s->no_slot, 1);
				continue;
			}
			describe_from_dds(d, &wd, s->source_id, site_remote_id(s, (int)(r - s->rs)));
			len = wire_encode_describe(&wd, msg);
			w[0] = (uint32_t)len;
			bytes_to_words(w + 1, msg, len);
			seqlock_write(&r->dseq, r->dw, w, DESC_WORDS);
			if (r->peer >= 0)
				ctr_add(&s->peer[r->peer].descriptions, 1);
		}
	}
}

static void take_clock(struct site *s)
{
	void *ptr[TAKE_MAX];
	dds_sample_info_t info[TAKE_MAX];
	int n;

	for (int i = 0; i < TAKE_MAX; i++)
		ptr[i] = &s->cbuf[i];
	while ((n = dds_take(s->r_clock, ptr, info, TAKE_MAX, TAKE_MAX)) > 0) {
		uint64_t t4 = real_ns();

		for (int i = 0; i < n; i++) {
			avatargw_sites_Clock *c = &s->cbuf[i];
			int pi;

			c->site[sizeof(c->site) - 1] = '\0';
			c->to[sizeof(c->to) - 1] = '\0';
			if (!info[i].valid_data || own(s, c->site))
				continue;
			if (!c->to[0]) {
				/* a ping: the answer at once */
				avatargw_sites_Clock a;

				memset(&a, 0, sizeof(a));
				snprintf(a.site, sizeof(a.site), "%.31s", s->cfg.name);
				snprintf(a.to, sizeof(a.to), "%s", c->site);
				a.t1 = c->t1;
				a.t2 = t4;
				a.t3 = real_ns();
				dds_write(s->w_clock, &a);
			} else if (own(s, c->to) && (pi = peer_of(s, c->site)) >= 0) {
				/* an answer to our ping: offset and round trip as NTP does */
				struct peer *p = &s->peer[pi];
				int64_t rtt = (int64_t)(t4 - c->t1) - (int64_t)(c->t3 - c->t2);
				int64_t off = ((int64_t)(c->t2 - c->t1) + (int64_t)(c->t3 - t4)) / 2;
				int64_t best = atomic_load_explicit(&p->rtt_ns, memory_order_relaxed);
				uint64_t now = mono_ns();

				atomic_store_explicit(&p->last_mono, now, memory_order_relaxed);
				if (rtt < 0)
					continue;
				if (best < 0 || rtt <= best || now - p->best_at > CLOCK_KEEP_NS) {
					atomic_store_explicit(&p->offset_ns, off, memory_order_relaxed);
					atomic_store_explicit(&p->rtt_ns, rtt, memory_order_relaxed);
					p->best_at = now;
				}
			}
		}
	}
}

static void ping(struct site *s)
{
	avatargw_sites_Clock c;

	memset(&c, 0, sizeof(c));
	snprintf(c.site, sizeof(c.site), "%.31s", s->cfg.name);
	c.t1 = real_ns();
	dds_write(s->w_clock, &c);
}

static float peer_rate(struct peer *p)
{
	uint32_t b = atomic_load_explicit(&p->rate_bits, memory_order_relaxed);
	float f;

	memcpy(&f, &b, sizeof(f));
	return f;
}

/* present: it has avatars here, or it was heard from within its lease */
static bool peer_present(const struct site *s, struct peer *p, uint64_t now)
{
	uint64_t last = atomic_load_explicit(&p->last_mono, memory_order_relaxed);

	return ctr_get(&p->avatars) || (last && now - last < s->lease_ns);
}

/* once a second: each remote site's rate, and its figures for the loop (remote avatars' DESCRIBEs) */
static void figures_update(struct site *s, uint64_t now)
{
	for (int i = 0; i < SITE_MAX_PEERS; i++) {
		struct peer *p = &s->peer[i];
		uint64_t f = ctr_get(&p->frames);
		int64_t rtt = atomic_load_explicit(&p->rtt_ns, memory_order_relaxed);
		union {
			struct wire_site ws;
			uint32_t w[FIG_WORDS];
		} u;
		float rate;
		uint32_t b;

		if (!atomic_load_explicit(&p->used, memory_order_acquire))
			continue;
		if (p->r_t && now > p->r_t) {
			rate = (float)((double)(f - p->r_frames) / ((double)(now - p->r_t) * 1e-9));
			memcpy(&b, &rate, sizeof(b));
			atomic_store_explicit(&p->rate_bits, b, memory_order_relaxed);
		}
		p->r_frames = f;
		p->r_t = now;
		memset(&u, 0, sizeof(u));
		u.ws.present = true;
		snprintf(u.ws.name, sizeof(u.ws.name), "%s", p->name);
		u.ws.state = peer_present(s, p, now) ? WIRE_SITE_PRESENT : WIRE_SITE_GONE;
		u.ws.avatars = (uint16_t)ctr_get(&p->avatars);
		u.ws.rate_hz = peer_rate(p);
		u.ws.frames = (uint32_t)f;
		u.ws.lost = (uint32_t)ctr_get(&p->lost);
		u.ws.delay_p50_ms = ctr_get(&p->delay.n) ? (float)(hist_percentile(&p->delay, 0.5) * 1e-6) : -1.0f;
		u.ws.delay_p99_ms = ctr_get(&p->delay.n) ? (float)(hist_percentile(&p->delay, 0.99) * 1e-6) : -1.0f;
		u.ws.clock_offset_ms =
			rtt >= 0 ? (float)(atomic_load_explicit(&p->offset_ns, memory_order_relaxed) * 1e-6) : 0.0f;
		u.ws.rtt_ms = rtt >= 0 ? (float)(rtt * 1e-6) : -1.0f;
		seqlock_write(&p->fseq, p->fw, u.w, FIG_WORDS);
	}
}

static void *sub_main(void *arg)
{
	struct site *s = arg;

	pthread_setname_np(pthread_self(), "agw-site-sub");
	while (!atomic_load_explicit(&s->stop, memory_order_acquire)) {
		uint64_t now;

		dds_waitset_wait(s->ws, NULL, 0, DDS_MSECS(100));
		if (s->r_frame > 0) {
			take_descriptions(s);
			take_frames(s);
			sweep_writers(s);
		}
		take_clock(s);
		now = mono_ns();
		if (now - s->last_ping >= PING_NS) {
			s->last_ping = now;
			ping(s);
			figures_update(s, now);
		}
	}
	return NULL;
}

/* ---- set-up --------------------------------------------------------------------------------------------- */

static dds_qos_t *qos_common(void)
{
	dds_qos_t *q = dds_create_qos();

	dds_qset_data_representation(q, 1, (dds_data_representation_id_t[]){ DDS_DATA_REPRESENTATION_XCDR1 });
	return q;
}

static int fail_dds(char *err, size_t errlen, const char *what, dds_return_t rc)
{
	snprintf(err, errlen, "[site]: %s: %s", what, dds_strretcode(rc));
	return -EIO;
}

int site_open(struct site **out, const struct config *cfg, uint32_t source_id, char *err, size_t errlen)
{
	struct site *s = calloc(1, sizeof(*s));
	dds_qos_t *q;
	int rc;

	*out = NULL;
	if (!s)
		return snprintf(err, errlen, "out of memory"), -ENOMEM;
	s->cfg = cfg->site;
	s->source_id = source_id;
	s->rate = cfg->daemon.rate;
	s->stale_ns = (uint64_t)(cfg->daemon.stale_ms * 1e6);
	s->deadline_ns = (uint64_t)(s->cfg.deadline_ms * 1e6);
	s->lease_ns = (uint64_t)(s->cfg.lease * 1e9);
	s->efd = -1;
	s->domain_ref = -1;
	s->n_local = s->cfg.publish ? cfg->n_avatars : 0;
	s->n_remote = s->cfg.subscribe ? s->cfg.max_remote : 0;
	s->local_name = calloc((size_t)s->n_local + 1, sizeof(*s->local_name));
	s->out = calloc((size_t)s->n_local + 1, sizeof(*s->out));
	s->local_desc = calloc((size_t)s->n_local + 1, sizeof(*s->local_desc));
	s->local_described = calloc((size_t)s->n_local + 1, sizeof(bool));
	s->rs = calloc((size_t)s->n_remote + 1, sizeof(*s->rs));
	s->fbuf = calloc(TAKE_MAX, sizeof(*s->fbuf));
	s->pbuf = calloc(1, sizeof(*s->pbuf));
	s->dbuf = calloc(TAKE_MAX, sizeof(*s->dbuf));
	s->cbuf = calloc(TAKE_MAX, sizeof(*s->cbuf));
	*out = s;
	if (!s->local_name || !s->out || !s->local_desc || !s->local_described || !s->rs || !s->fbuf || !s->pbuf ||
	    !s->dbuf || !s->cbuf)
		return snprintf(err, errlen, "out of memory"), -ENOMEM;
	for (int i = 0; i < s->n_local; i++) {
		/* a local avatar's name on the wire: its first 15 bytes */
		snprintf(s->local_name[i], sizeof(s->local_name[i]), "%.*s", WIRE_NAME_MAX, cfg->avatar[i].name);
		s->out[i].sent = 0;
	}
	s->efd = eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
	if (s->efd < 0)
		return snprintf(err, errlen, "[site]: eventfd: %s", strerror(errno)), -errno;
	rc = domain_get(&s->cfg, err, errlen);
	if (rc < 0)
		return rc;
	s->domain_ref = rc;
	q = dds_create_qos();
	dds_qset_userdata(q, s->cfg.name, strlen(s->cfg.name));
	s->pp = dds_create_participant((dds_domainid_t)s->cfg.domain, q, NULL);
	dds_delete_qos(q);
	if (s->pp < 0)
		return fail_dds(err, errlen, s->cfg.security[0] ? "participant (security files?)" : "participant",
				s->pp);
	q = dds_create_qos();
	dds_qset_partition1(q, s->cfg.session);
	s->pub = dds_create_publisher(s->pp, q, NULL);
	s->sub = dds_create_subscriber(s->pp, q, NULL);
	dds_delete_qos(q);
	if (s->pub < 0 || s->sub < 0)
		return fail_dds(err, errlen, "publisher", s->pub < 0 ? s->pub : s->sub);
	s->t_frame = dds_create_topic(s->pp, &avatargw_sites_Frame_desc, topic_frame, NULL, NULL);
	s->t_desc = dds_create_topic(s->pp, &avatargw_sites_Description_desc, topic_desc, NULL, NULL);
	s->t_clock = dds_create_topic(s->pp, &avatargw_sites_Clock_desc, topic_clock, NULL, NULL);
	if (s->t_frame < 0 || s->t_desc < 0 || s->t_clock < 0)
		return fail_dds(err, errlen, "topic", s->t_frame < 0 ? s->t_frame : s->t_desc);
	/* frames: latest value wins, a deadline, and a lease after which the avatar is gone */
	q = qos_common();
	dds_qset_reliability(q, DDS_RELIABILITY_BEST_EFFORT, 0);
	dds_qset_history(q, DDS_HISTORY_KEEP_LAST, 1);
	dds_qset_deadline(q, DDS_MSECS((int64_t)s->cfg.deadline_ms));
	dds_qset_liveliness(q, DDS_LIVELINESS_AUTOMATIC, DDS_MSECS((int64_t)(s->cfg.lease * 1000)));
	if (s->n_local)
		s->w_frame = dds_create_writer(s->pub, s->t_frame, q, NULL);
	if (s->n_remote)
		s->r_frame = dds_create_reader(s->sub, s->t_frame, q, NULL);
	dds_delete_qos(q);
	/* descriptions: reliable and kept for late joiners */
	q = qos_common();
	dds_qset_reliability(q, DDS_RELIABILITY_RELIABLE, DDS_SECS(1));
	dds_qset_durability(q, DDS_DURABILITY_TRANSIENT_LOCAL);
	dds_qset_history(q, DDS_HISTORY_KEEP_LAST, 1);
	dds_qset_liveliness(q, DDS_LIVELINESS_AUTOMATIC, DDS_MSECS((int64_t)(s->cfg.lease * 1000)));
	if (s->n_local)
		s->w_desc = dds_create_writer(s->pub, s->t_desc, q, NULL);
	if (s->n_remote)
		s->r_desc = dds_create_reader(s->sub, s->t_desc, q, NULL);
	dds_delete_qos(q);
	/* the clock pings */
	q = qos_common();
	dds_qset_reliability(q, DDS_RELIABILITY_BEST_EFFORT, 0);
	dds_qset_history(q, DDS_HISTORY_KEEP_LAST, 8);
	s->w_clock = dds_create_writer(s->pub, s->t_clock, q, NULL);
	s->r_clock = dds_create_reader(s->sub, s->t_clock, q, NULL);
	dds_delete_qos(q);
	if (s->w_frame < 0 || s->r_frame < 0 || s->w_desc < 0 || s->r_desc < 0 || s->w_clock < 0 || s->r_clock < 0)
		return fail_dds(err, errlen, "reader or writer", -1);
	s->ws = dds_create_waitset(s->pp);
	if (s->ws < 0)
		return fail_dds(err, errlen, "waitset", s->ws);
	if (s->r_frame > 0) {
		s->c_frame = dds_create_readcondition(s->r_frame, DDS_ANY_STATE);
		s->c_desc = dds_create_readcondition(s->r_desc, DDS_ANY_STATE);
		dds_waitset_attach(s->ws, s->c_frame, 0);
		/* a writer that goes away wakes the thread too */
		dds_set_status_mask(s->r_frame, DDS_SUBSCRIPTION_MATCHED_STATUS);
		dds_waitset_attach(s->ws, s->r_frame, 1);
		dds_waitset_attach(s->ws, s->c_desc, 0);
	}
	s->c_clock = dds_create_readcondition(s->r_clock, DDS_ANY_STATE);
	dds_waitset_attach(s->ws, s->c_clock, 0);
	for (int k = 0; k < s->n_remote; k++)
		s->rs[k].peer = -1;
	if (s->cfg.ros2 && s->n_local)
		return ros2_open(s, err, errlen);
	return 0;
}

void site_describe_local(struct site *s, int idx, const struct wire_describe *w)
{
	avatargw_sites_Description *d;

	if (!s || idx >= s->n_local)
		return;
	d = &s->local_desc[idx];
	memset(d, 0, sizeof(*d));
	snprintf(d->site, sizeof(d->site), "%.31s", s->cfg.name);
	snprintf(d->avatar, sizeof(d->avatar), "%s", s->local_name[idx]);
	describe_to_dds(w, d);
	s->local_described[idx] = true;
}

/* the [site] keys of a and b are the same (where they were written does not count) */
static bool site_cfg_same(const struct cfg_site *a, const struct cfg_site *b)
{
	return a->present == b->present && !strcmp(a->name, b->name) && !strcmp(a->session, b->session) &&
	       a->domain == b->domain && !strcmp(a->peers, b->peers) && !strcmp(a->interface, b->interface) &&
	       a->publish == b->publish && a->subscribe == b->subscribe && !strcmp(a->security, b->security) &&
	       a->ros2 == b->ros2 && a->max_remote == b->max_remote && a->remote_id == b->remote_id &&
	       a->deadline_ms == b->deadline_ms && a->lease == b->lease;
}

bool site_keeps(const struct site *s, const struct config *cfg)
{
	if (!site_cfg_same(&s->cfg, &cfg->site) || s->rate != cfg->daemon.rate ||
	    s->n_local != (cfg->site.publish ? cfg->n_avatars : 0))
		return false;
	for (int i = 0; i < s->n_local; i++) {
		char name[WIRE_NAME_MAX + 1];

		snprintf(name, sizeof(name), "%.*s", WIRE_NAME_MAX, cfg->avatar[i].name);
		if (strcmp(s->local_name[i], name))
			return false;
	}
	return true;
}

bool site_keeps_describe(const struct site *s, int idx, const struct wire_describe *w)
{
	avatargw_sites_Description d;

	if (idx >= s->n_local)
		return true;
	memset(&d, 0, sizeof(d));
	snprintf(d.site, sizeof(d.site), "%.31s", s->cfg.name);
	snprintf(d.avatar, sizeof(d.avatar), "%s", s->local_name[idx]);
	describe_to_dds(w, &d);
	return s->local_described[idx] && !memcmp(&d, &s->local_desc[idx], sizeof(d));
}

void site_adopt(struct site *s, const struct config *cfg)
{
	/* the new gateway took the remote avatars' descriptions over: the loop's view of the slots stays */
	s->stale_ns = (uint64_t)(cfg->daemon.stale_ms * 1e6);
}

int site_start(struct site *s, char *err, size_t errlen)
{
	int rc;

	if (s->n_local) {
		rc = pthread_create(&s->pub_thr, NULL, pub_main, s);
		if (rc)
			return snprintf(err, errlen, "[site]: thread: %s", strerror(rc)), -rc;
		s->pub_started = true;
	}
	rc = pthread_create(&s->sub_thr, NULL, sub_main, s);
	if (rc)
		return snprintf(err, errlen, "[site]: thread: %s", strerror(rc)), -rc;
	s->sub_started = true;
	return 0;
}

void site_close(struct site *s)
{
	if (!s)
		return;
	atomic_store_explicit(&s->stop, true, memory_order_release);
	if (s->pub_started)
		pthread_join(s->pub_thr, NULL);
	if (s->sub_started)
		pthread_join(s->sub_thr, NULL);
	/* deleting the participant disposes this site's instances: the others see it leave at once */
	if (s->pp > 0)
		dds_delete(s->pp);
	domain_put(s->domain_ref);
	if (s->efd >= 0)
		close(s->efd);
	free(s->local_name);
	free(s->out);
	free(s->local_desc);
	free(s->local_described);
	free(s->rs);
	free(s->fbuf);
	free(s->pbuf);
	free(s->dbuf);
	free(s->cbuf);
	ros2_free(s);
	free(s);
}

int site_n_remote(const struct site *s)
{
	return s ? s->n_remote : 0;
}

uint16_t site_remote_id(const struct site *s, int k)
{
	return (uint16_t)(s->cfg.remote_id + k);
}

bool site_remote_name(struct site *s, int k, char *buf, size_t len, bool *live)
{
	struct rslot *r = &s->rs[k];
	uint32_t w[NAME_WORDS];

	if (!seqlock_peek(&r->nseq))
		return false;
	seqlock_read(&r->nseq, r->nw, w, NAME_WORDS);
	((char *)w)[sizeof(w) - 1] = '\0';
	snprintf(buf, len, "%s", (const char *)w);
	*live = atomic_load_explicit(&r->gen, memory_order_acquire) & 1;
	return true;
}

/* ---- the loop ------------------------------------------------------------------------------------------- */

void site_put(struct site *s, int idx, const uint8_t *msg, size_t len)
{
	uint32_t w[OUT_WORDS];

	if (idx >= s->n_local || len > FRAME_MAX)
		return;
	w[0] = (uint32_t)len;
	bytes_to_words(w + 1, msg, len);
	seqlock_write(&s->out[idx].seq, s->out[idx].w, w, 1 + ((int)len + 3) / 4);
	s->put_any = true;
}

void site_flush(struct site *s)
{
	static const uint64_t one = 1;

	if (!s->put_any)
		return;
	s->put_any = false;
	/* non-blocking: a full counter (never, in practice) only means the thread is already woken */
	if (write(s->efd, &one, sizeof(one)) < 0)
		return;
}

static uint16_t age_add(uint16_t a, uint64_t ns)
{
	uint64_t v = a + ns / 100000;

	return v > 0xFFFF ? 0xFFFF : (uint16_t)v;
}

bool site_remote(struct site *s, int k, uint64_t now_mono, struct wire_frame *wf, struct wire_describe *d,
		 bool *described, bool *fresh)
{
	struct rslot *r = &s->rs[k];
	uint32_t gen = atomic_load_explicit(&r->gen, memory_order_acquire), sq, ds, fs;
	uint64_t age;

	*described = *fresh = false;
	if (gen != r->l_gen) {
		/* arrived or left: a newcomer's DESCRIBE goes out at once */
		r->l_gen = gen;
		r->l_dseq = 0;
		r->l_desc = false;
		r->l_have = false;
		r->l_fseq = 0;
	}
	if (!(gen & 1))
		return false;
	ds = seqlock_peek(&r->dseq);
	if (ds && !(ds & 1) && ds != r->l_dseq) {
		uint32_t w[DESC_WORDS];

		if (seqlock_try_read(&r->dseq, r->dw, w, DESC_WORDS, &sq) && w[0] <= WIRE_MAX_MSG &&
		    !wire_decode_describe((const uint8_t *)(w + 1), w[0], d)) {
			r->l_dseq = sq;
			r->l_desc = true;
			*described = true;
		}
	}
	fs = seqlock_peek(&r->fseq);
	if (fs && !(fs & 1) && fs != r->l_fseq) {
		uint32_t w[IN_WORDS];

		if (seqlock_try_read(&r->fseq, r->fw, w, IN_WORDS, &sq) && w[0] <= FRAME_MAX &&
		    !wire_decode_frame((const uint8_t *)(w + IN_HEAD), w[0], &r->l_wf)) {
			r->l_fseq = sq;
			r->l_arrival = (uint64_t)w[1] | (uint64_t)w[2] << 32;
			r->l_have = true;
			*fresh = true;
		}
	}
	if (!r->l_desc || !r->l_have)
		return false;
	*wf = r->l_wf;
	age = now_mono > r->l_arrival ? now_mono - r->l_arrival : 0;
	wf->h.flags = (uint16_t)(*fresh ? wf->h.flags | WIRE_F_NEW_SAMPLE : wf->h.flags & ~WIRE_F_NEW_SAMPLE);
	for (int i = 0; i < WIRE_SENSORS; i++) {
		struct wire_sensor_sample *ss = &wf->sensor[i];

		ss->age_100us = age_add(ss->age_100us, age);
		if (age > s->deadline_ns) {
			/* no sample for a deadline: the person is not there, the posture is held */
			ss->state = WIRE_SENSOR_MISSING;
			for (int c = 0; c < 3; c++)
				ss->pose.p[c] = NAN;
			for (int c = 0; c < 4; c++)
				ss->pose.q[c] = NAN;
			wf->h.flags |= WIRE_F_STALE | WIRE_F_HELD;
		} else if (age > s->stale_ns && ss->state == WIRE_SENSOR_OK) {
			ss->state = WIRE_SENSOR_STALE;
			wf->h.flags |= WIRE_F_STALE;
		}
	}
	return true;
}

void site_remote_site(struct site *s, int k, struct wire_site *ws)
{
	struct rslot *r = &s->rs[k];
	int pi = atomic_load_explicit(&r->peer, memory_order_relaxed);
	struct peer *p;
	uint32_t w[FIG_WORDS], sq;

	/* set before the slot became live, which the caller's site_remote() saw */
	if (pi < 0)
		return;
	p = &s->peer[pi];
	if (ws->present && seqlock_peek(&p->fseq) == r->l_figs)
		return; /* what ws holds (a DESCRIBE decoded anew holds none) */
	if (seqlock_try_read(&p->fseq, p->fw, w, FIG_WORDS, &sq)) {
		memcpy(ws, w, sizeof(*ws));
		r->l_figs = sq;
	}
}

/* ---- the control thread --------------------------------------------------------------------------------- */

static double ms(int64_t ns)
{
	return (double)ns / 1e6;
}

void site_report(struct site *s, FILE *out, bool json)
{
	uint64_t now = mono_ns();
	int np = 0;

	if (!s)
		return;
	if (json) {
		fprintf(out,
			",\"site\":{\"name\":\"%s\",\"session\":\"%s\",\"domain\":%d,\"publish\":%s,\"subscribe\":%s,"
			"\"security\":%s,\"written\":%llu,\"coalesced\":%llu,\"write_errors\":%llu,\"no_slot\":%llu,"
			"\"bad_samples\":%llu,"
			"\"remote_slots\":%d,\"peers\":[",
			s->cfg.name, s->cfg.session, s->cfg.domain, s->cfg.publish ? "true" : "false",
			s->cfg.subscribe ? "true" : "false", s->cfg.security[0] ? "true" : "false",
			(unsigned long long)ctr_get(&s->written), (unsigned long long)ctr_get(&s->coalesced),
			(unsigned long long)ctr_get(&s->write_errors), (unsigned long long)ctr_get(&s->no_slot),
			(unsigned long long)ctr_get(&s->bad_samples), s->n_remote);
	} else {
		fprintf(out,
			"\nsite %s, session %s, domain %d%s: %llu samples written, %llu frames coalesced, %llu write "
			"errors\n",
			s->cfg.name, s->cfg.session, s->cfg.domain, s->cfg.security[0] ? ", DDS Security" : "",
			(unsigned long long)ctr_get(&s->written), (unsigned long long)ctr_get(&s->coalesced),
			(unsigned long long)ctr_get(&s->write_errors));
		fprintf(out, "%-16s %-8s %7s %8s %10s %8s %10s %10s %9s\n", "REMOTE SITE", "STATE", "AVATARS", "RATE/s",
			"FRAMES", "LOST", "OFFSET ms", "RTT ms", "DELAY p50/p99 ms");
	}
	for (int i = 0; i < SITE_MAX_PEERS; i++) {
		struct peer *p = &s->peer[i];
		uint64_t avatars;
		int64_t rtt;
		const char *state;

		if (!atomic_load_explicit(&p->used, memory_order_acquire))
			continue;
		avatars = ctr_get(&p->avatars);
		rtt = atomic_load_explicit(&p->rtt_ns, memory_order_relaxed);
		state = peer_present(s, p, now) ? "present" : "gone";
		if (json) {
			/* a remote site's name is what the network said: escaped */
			fprintf(out, "%s{\"name\":", np ? "," : "");
			json_string(out, p->name);
			fprintf(out,
				",\"state\":\"%s\",\"avatars\":%llu,\"rate_hz\":%.2f,\"frames\":%llu,"
				"\"lost\":%llu,\"joins\":%llu,\"departures\":%llu,\"descriptions\":%llu,"
				"\"clock_offset_ms\":%.3f,\"rtt_ms\":%.3f,"
				"\"delay_ms\":{\"n\":%llu,\"p50\":%.3f,\"p99\":%.3f,\"max\":%.3f}}",
				state, (unsigned long long)avatars, (double)peer_rate(p),
				(unsigned long long)ctr_get(&p->frames), (unsigned long long)ctr_get(&p->lost),
				(unsigned long long)ctr_get(&p->joins), (unsigned long long)ctr_get(&p->departures),
				(unsigned long long)ctr_get(&p->descriptions),
				rtt >= 0 ? ms(atomic_load_explicit(&p->offset_ns, memory_order_relaxed)) : 0.0,
				rtt >= 0 ? ms(rtt) : -1.0, (unsigned long long)ctr_get(&p->delay.n),
				ms((int64_t)hist_percentile(&p->delay, 0.5)),
				ms((int64_t)hist_percentile(&p->delay, 0.99)), ms((int64_t)ctr_get(&p->delay.max_ns)));
		} else {
			fprintf(out, "%-16s %-8s %7llu %8.1f %10llu %8llu %10.3f %10.3f %8.3f/%.3f\n", p->name, state,
				(unsigned long long)avatars, (double)peer_rate(p),
				(unsigned long long)ctr_get(&p->frames), (unsigned long long)ctr_get(&p->lost),
				rtt >= 0 ? ms(atomic_load_explicit(&p->offset_ns, memory_order_relaxed)) : 0.0,
				rtt >= 0 ? ms(rtt) : -1.0, ms((int64_t)hist_percentile(&p->delay, 0.5)),
				ms((int64_t)hist_percentile(&p->delay, 0.99)));
		}
		np++;
	}
	if (json)
		fputs("]}", out);
}
