// SPDX-License-Identifier: MIT
/*
 * wire.c - encoder and decoder of the avatargw protocol (see avatargw/wire.h
 * and docs/PROTOCOL.md). Explicit little-endian byte writes: the same bytes
 * on every host, no struct layout on the wire.
 */
#include "avatargw/wire.h"

#include <math.h>
#include <string.h>

const char *const wire_joint_names[WIRE_JOINTS] = {
	"chest_yaw",   "r_girdle",  "r_sh_abd",	   "r_sh_flex", "r_sh_rot", "r_elbow",
	"r_pronation", "r_wr_flex", "r_wr_dev",	   "l_girdle",	"l_sh_abd", "l_sh_flex",
	"l_sh_rot",    "l_elbow",   "l_pronation", "l_wr_flex", "l_wr_dev",
};

const char *const wire_segment_names[WIRE_SEGMENTS] = {
	"chest", "head", "r_shoulder", "r_elbow", "r_wrist", "r_hand", "l_shoulder", "l_elbow", "l_wrist", "l_hand",
};

const char *const wire_sensor_names[WIRE_SENSORS] = { "head", "left_hand", "right_hand" };

const char *wire_strerror(int err)
{
	switch (err < 0 ? -err : err) {
	case 0:
		return "no error";
	case WIRE_ESHORT:
		return "message shorter than its header says";
	case WIRE_EMAGIC:
		return "not an avatargw message (bad magic)";
	case WIRE_EVERSION:
		return "unsupported protocol version";
	case WIRE_ETYPE:
		return "unexpected message type";
	case WIRE_ECOUNT:
		return "counts do not fit this protocol version";
	case WIRE_ELONG:
		return "message too long";
	case WIRE_ESTRING:
		return "name too long";
	default:
		return "unknown wire error";
	}
}

/* ---- byte writer / reader ------------------------------------------------- */

struct wbuf {
	uint8_t *p;
	size_t n;
};

static void put_u8(struct wbuf *w, uint8_t v)
{
	w->p[w->n++] = v;
}

/*
 * Bytes go through a local pointer and the count moves once: a uint8_t
 * store may alias w->n, so writing through w->p[w->n++] would reload the
 * count after every byte. This way the compiler emits one store per field
 * on a little-endian host.
 */
static inline void put_u16(struct wbuf *w, uint16_t v)
{
	uint8_t *d = w->p + w->n;

	d[0] = (uint8_t)v;
	d[1] = (uint8_t)(v >> 8);
	w->n += 2;
}

static inline void put_u32(struct wbuf *w, uint32_t v)
{
	uint8_t *d = w->p + w->n;

	d[0] = (uint8_t)v;
	d[1] = (uint8_t)(v >> 8);
	d[2] = (uint8_t)(v >> 16);
	d[3] = (uint8_t)(v >> 24);
	w->n += 4;
}

static inline void put_u64(struct wbuf *w, uint64_t v)
{
	put_u32(w, (uint32_t)v);
	put_u32(w, (uint32_t)(v >> 32));
}

static inline void put_f32(struct wbuf *w, float f)
{
	uint32_t v;

	memcpy(&v, &f, sizeof(v));
	put_u32(w, v);
}

/* at most max bytes: what the decoder accepts for this field (no strnlen: plain C11) */
static void put_str(struct wbuf *w, const char *s, size_t max)
{
	size_t len = 0;

	while (len < max && s[len])
		len++;

	put_u8(w, (uint8_t)len);
	memcpy(w->p + w->n, s, len);
	w->n += len;
}

/*
 * n floats stored back to back (an array, or structs of floats only): one copy
 * where the host's floats already are the wire's (little-endian IEEE 754).
 */
static inline void put_f32s(struct wbuf *w, const void *src, size_t n)
{
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__ && defined(__STDC_IEC_559__)
	memcpy(w->p + w->n, src, n * sizeof(float));
	w->n += n * sizeof(float);
#else
	const uint8_t *b = src;

	for (size_t i = 0; i < n; i++) {
		float f;

		memcpy(&f, b + i * sizeof(float), sizeof(f));
		put_f32(w, f);
	}
#endif
}

_Static_assert(sizeof(struct wire_pose) == 7 * sizeof(float), "a wire_pose is 7 floats, no padding");

static inline void put_pose(struct wbuf *w, const struct wire_pose *p)
{
	for (int i = 0; i < 3; i++)
		put_f32(w, p->p[i]);
	for (int i = 0; i < 4; i++)
		put_f32(w, p->q[i]);
}

struct rbuf {
	const uint8_t *p;
	size_t n, len;
	int err;
};

/* the first error sticks: later reads return 0 and keep it */
static uint8_t get_u8(struct rbuf *r)
{
	if (r->err)
		return 0;
	if (r->n + 1 > r->len) {
		r->err = WIRE_ESHORT;
		return 0;
	}
	return r->p[r->n++];
}

static uint16_t get_u16(struct rbuf *r)
{
	uint16_t lo = get_u8(r);

	return (uint16_t)(lo | (uint16_t)get_u8(r) << 8);
}

static uint32_t get_u32(struct rbuf *r)
{
	uint32_t lo = get_u16(r);

	return lo | (uint32_t)get_u16(r) << 16;
}

static uint64_t get_u64(struct rbuf *r)
{
	uint64_t lo = get_u32(r);

	return lo | (uint64_t)get_u32(r) << 32;
}

static float get_f32(struct rbuf *r)
{
	uint32_t v = get_u32(r);
	float f;

	memcpy(&f, &v, sizeof(f));
	return f;
}

static void get_str(struct rbuf *r, char *out, size_t cap)
{
	size_t len = get_u8(r);

	out[0] = '\0';
	if (r->err)
		return;
	if (len >= cap) {
		r->err = WIRE_ESTRING;
		return;
	}
	if (r->n + len > r->len) {
		r->err = WIRE_ESHORT;
		return;
	}
	memcpy(out, r->p + r->n, len);
	out[len] = '\0';
	r->n += len;
}

static void get_pose(struct rbuf *r, struct wire_pose *p)
{
	for (int i = 0; i < 3; i++)
		p->p[i] = get_f32(r);
	for (int i = 0; i < 4; i++)
		p->q[i] = get_f32(r);
}

/* ---- header ------------------------------------------------------------------- */

static void put_header(struct wbuf *w, const struct wire_header *h, uint8_t type)
{
	put_u32(w, WIRE_MAGIC);
	put_u8(w, WIRE_VERSION);
	put_u8(w, type);
	put_u16(w, WIRE_HEADER_LEN);
	put_u16(w, 0); /* payload length, patched by finish() */
	put_u16(w, h->flags);
	put_u32(w, h->source_id);
	put_u32(w, h->seq);
	put_u32(w, h->describe_rev);
	put_u64(w, h->sample_time_ns);
	put_u16(w, h->avatar_id);
	put_u8(w, WIRE_JOINTS);
	put_u8(w, WIRE_SEGMENTS);
	put_u8(w, WIRE_SENSORS);
	put_u8(w, 0);
	put_u16(w, 0);
}

/* the header's seq and describe_rev, as put_header lays them out: magic, version, type, lengths, flags, source */
#define WIRE_SEQ_AT 16
#define WIRE_REV_AT 20

void wire_restamp(uint8_t *msg, uint32_t seq, uint32_t describe_rev)
{
	for (int b = 0; b < 4; b++) {
		msg[WIRE_SEQ_AT + b] = (uint8_t)(seq >> (8 * b));
		msg[WIRE_REV_AT + b] = (uint8_t)(describe_rev >> (8 * b));
	}
}

static size_t finish(struct wbuf *w)
{
	uint16_t pl = (uint16_t)(w->n - WIRE_HEADER_LEN);

	w->p[8] = (uint8_t)pl;
	w->p[9] = (uint8_t)(pl >> 8);
	return w->n;
}

int wire_peek(const uint8_t *buf, size_t len, struct wire_header *h)
{
	struct rbuf r = { buf, 0, len, 0 };
	uint32_t magic;

	if (len < WIRE_HEADER_LEN)
		return -WIRE_ESHORT;
	magic = get_u32(&r);
	if (magic != WIRE_MAGIC)
		return -WIRE_EMAGIC;
	h->version = get_u8(&r);
	if (h->version != WIRE_VERSION)
		return -WIRE_EVERSION;
	h->type = get_u8(&r);
	h->header_len = get_u16(&r);
	h->payload_len = get_u16(&r);
	h->flags = get_u16(&r);
	h->source_id = get_u32(&r);
	h->seq = get_u32(&r);
	h->describe_rev = get_u32(&r);
	h->sample_time_ns = get_u64(&r);
	h->avatar_id = get_u16(&r);
	h->n_joints = get_u8(&r);
	h->n_segments = get_u8(&r);
	h->n_sensors = get_u8(&r);
	if (h->header_len < WIRE_HEADER_LEN)
		return -WIRE_ESHORT;
	if ((size_t)h->header_len + h->payload_len > len)
		return -WIRE_ESHORT;
	if ((size_t)h->header_len + h->payload_len > WIRE_MAX_MSG)
		return -WIRE_ELONG;
	if (h->n_joints != WIRE_JOINTS || h->n_segments != WIRE_SEGMENTS || h->n_sensors != WIRE_SENSORS)
		return -WIRE_ECOUNT;
	return h->type;
}

/* ---- FRAME -------------------------------------------------------------------- */

size_t wire_encode_frame(const struct wire_frame *f, uint8_t *buf)
{
	struct wbuf w = { buf, 0 };

	put_header(&w, &f->h, WIRE_FRAME);
	for (int i = 0; i < WIRE_SENSORS; i++) {
		put_u8(&w, f->sensor[i].state);
		put_u8(&w, 0);
		put_u16(&w, f->sensor[i].age_100us);
		put_pose(&w, &f->sensor[i].pose);
	}
	for (int i = 0; i < WIRE_ARMS; i++) {
		put_u16(&w, f->arm[i].ik_flags);
		put_u8(&w, f->arm[i].iters);
		put_u8(&w, 0);
		put_f32(&w, f->arm[i].pos_err);
	}
	put_f32s(&w, f->joint, WIRE_JOINTS);
	put_f32s(&w, f->segment, 7 * WIRE_SEGMENTS);
	if (f->h.flags & WIRE_F_INPUTS) {
		/* a compatible addition: after the last field of the first FRAME layout */
		put_u8(&w, f->in.present);
		put_u8(&w, WIRE_ANALOG);
		put_u16(&w, 0);
		for (int i = 0; i < WIRE_SENSORS; i++) {
			put_u32(&w, f->in.buttons[i]);
			for (int k = 0; k < WIRE_ANALOG; k++)
				put_f32(&w, f->in.analog[i][k]);
		}
	}
	return finish(&w);
}

/* the header of a message of type want, and a reader of its payload; 0 or -WIRE_E* */
static int payload_of(const uint8_t *buf, size_t len, int want, struct wire_header *h, struct rbuf *r)
{
	int type = wire_peek(buf, len, h);

	if (type < 0)
		return type;
	if (type != want)
		return -WIRE_ETYPE;
	*r = (struct rbuf){ buf, h->header_len, (size_t)h->header_len + h->payload_len, 0 };
	return 0;
}

int wire_decode_frame(const uint8_t *buf, size_t len, struct wire_frame *f)
{
	struct rbuf r;
	int rc = payload_of(buf, len, WIRE_FRAME, &f->h, &r);

	if (rc)
		return rc;
	for (int i = 0; i < WIRE_SENSORS; i++) {
		f->sensor[i].state = get_u8(&r);
		(void)get_u8(&r);
		f->sensor[i].age_100us = get_u16(&r);
		get_pose(&r, &f->sensor[i].pose);
	}
	for (int i = 0; i < WIRE_ARMS; i++) {
		f->arm[i].ik_flags = get_u16(&r);
		f->arm[i].iters = get_u8(&r);
		(void)get_u8(&r);
		f->arm[i].pos_err = get_f32(&r);
	}
	for (int i = 0; i < WIRE_JOINTS; i++)
		f->joint[i] = get_f32(&r);
	for (int i = 0; i < WIRE_SEGMENTS; i++)
		get_pose(&r, &f->segment[i]);
	memset(&f->in, 0, sizeof(f->in));
	if (!r.err && (f->h.flags & WIRE_F_INPUTS)) {
		uint8_t n_analog;

		f->in.present = get_u8(&r);
		n_analog = get_u8(&r);
		(void)get_u16(&r);
		for (int i = 0; i < WIRE_SENSORS; i++) {
			f->in.buttons[i] = get_u32(&r);
			/* a later revision may send more values per sensor: read ours, skip the rest */
			for (int k = 0; k < n_analog; k++) {
				float v = get_f32(&r);

				if (k < WIRE_ANALOG)
					f->in.analog[i][k] = v;
			}
		}
		if (n_analog < WIRE_ANALOG && !r.err)
			r.err = WIRE_ECOUNT;
	} else if (!r.err) {
		f->h.flags &= (uint16_t)~WIRE_F_INPUTS;
	}
	return r.err ? -r.err : 0;
}

/* ---- DESCRIBE ----------------------------------------------------------------- */

/* the longest DESCRIBE, every string at its maximum, fits one datagram */
#define WIRE_DESCRIBE_WORST                                                                                            \
	(WIRE_HEADER_LEN + 32 + (1 + WIRE_NAME_MAX) + (1 + 4 * WIRE_NAME_MAX) +                                        \
	 WIRE_JOINTS * (1 + WIRE_NAME_MAX + 1 + 8 * 4) + WIRE_SEGMENTS * (1 + WIRE_NAME_MAX + 1) +                     \
	 WIRE_SENSORS * (1 + WIRE_NAME_MAX))
_Static_assert(WIRE_DESCRIBE_WORST <= WIRE_MAX_MSG, "a DESCRIBE can exceed WIRE_MAX_MSG");
/* a remote avatar's site block: tag, length, then its fields; sent only when it fits */
#define WIRE_SITE_WORST (2 + 1 + WIRE_SITE_NAME_MAX + 1 + 2 + 4 * 8)

size_t wire_encode_describe(const struct wire_describe *d, uint8_t *buf)
{
	struct wbuf w = { buf, 0 };

	put_header(&w, &d->h, WIRE_DESCRIBE);
	put_f32(&w, d->rate_hz);
	for (int i = 0; i < 4; i++)
		put_f32(&w, d->dims[i]);
	for (int i = 0; i < 3; i++)
		put_f32(&w, d->head_offset[i]);
	put_str(&w, d->avatar_name, WIRE_NAME_MAX);
	put_str(&w, d->conventions, WIRE_NAME_MAX * 4);
	for (int i = 0; i < WIRE_JOINTS; i++) {
		const struct wire_joint_desc *j = &d->joint[i];

		put_str(&w, j->name, WIRE_NAME_MAX);
		put_u8(&w, j->segment);
		put_f32(&w, j->lo);
		put_f32(&w, j->hi);
		for (int k = 0; k < 3; k++)
			put_f32(&w, j->axis[k]);
		for (int k = 0; k < 3; k++)
			put_f32(&w, j->trans[k]);
	}
	for (int i = 0; i < WIRE_SEGMENTS; i++) {
		put_str(&w, d->segment[i].name, WIRE_NAME_MAX);
		put_u8(&w, d->segment[i].parent);
	}
	for (int i = 0; i < WIRE_SENSORS; i++)
		put_str(&w, d->sensor[i], WIRE_NAME_MAX);
	if (d->site.present && w.n + WIRE_SITE_WORST <= WIRE_MAX_MSG) {
		/* always with the protocol's names (987 bytes at most before it) */
		size_t at;

		put_u8(&w, WIRE_SITE_BLOCK);
		at = w.n;
		put_u8(&w, 0);
		put_str(&w, d->site.name, WIRE_SITE_NAME_MAX);
		put_u8(&w, d->site.state);
		put_u16(&w, d->site.avatars);
		put_f32(&w, d->site.rate_hz);
		put_u32(&w, d->site.frames);
		put_u32(&w, d->site.lost);
		put_f32(&w, d->site.delay_p50_ms);
		put_f32(&w, d->site.delay_p99_ms);
		put_f32(&w, d->site.clock_offset_ms);
		put_f32(&w, d->site.rtt_ms);
		w.p[at] = (uint8_t)(w.n - at - 1);
	}
	return finish(&w);
}

int wire_decode_describe(const uint8_t *buf, size_t len, struct wire_describe *d)
{
	struct rbuf r;
	int rc = payload_of(buf, len, WIRE_DESCRIBE, &d->h, &r);

	if (rc)
		return rc;
	d->rate_hz = get_f32(&r);
	for (int i = 0; i < 4; i++)
		d->dims[i] = get_f32(&r);
	for (int i = 0; i < 3; i++)
		d->head_offset[i] = get_f32(&r);
	get_str(&r, d->avatar_name, sizeof(d->avatar_name));
	get_str(&r, d->conventions, sizeof(d->conventions));
	for (int i = 0; i < WIRE_JOINTS; i++) {
		struct wire_joint_desc *j = &d->joint[i];

		get_str(&r, j->name, sizeof(j->name));
		j->segment = get_u8(&r);
		j->lo = get_f32(&r);
		j->hi = get_f32(&r);
		for (int k = 0; k < 3; k++)
			j->axis[k] = get_f32(&r);
		for (int k = 0; k < 3; k++)
			j->trans[k] = get_f32(&r);
	}
	for (int i = 0; i < WIRE_SEGMENTS; i++) {
		get_str(&r, d->segment[i].name, sizeof(d->segment[i].name));
		d->segment[i].parent = get_u8(&r);
	}
	for (int i = 0; i < WIRE_SENSORS; i++)
		get_str(&r, d->sensor[i], sizeof(d->sensor[i]));
	memset(&d->site, 0, sizeof(d->site));
	if (!r.err && r.n + 2 <= r.len && r.p[r.n] == WIRE_SITE_BLOCK && r.n + 2 + r.p[r.n + 1] <= r.len) {
		/* the site block; a block of another tag (a later revision) is skipped */
		struct rbuf b = { r.p, r.n + 2, r.n + 2 + r.p[r.n + 1], 0 };

		get_str(&b, d->site.name, sizeof(d->site.name));
		d->site.state = get_u8(&b);
		d->site.avatars = get_u16(&b);
		d->site.rate_hz = get_f32(&b);
		d->site.frames = get_u32(&b);
		d->site.lost = get_u32(&b);
		d->site.delay_p50_ms = get_f32(&b);
		d->site.delay_p99_ms = get_f32(&b);
		d->site.clock_offset_ms = get_f32(&b);
		d->site.rtt_ms = get_f32(&b);
		/* a figure that is not a number: the block is not taken */
		if (b.err || !isfinite(d->site.rate_hz) || !isfinite(d->site.delay_p50_ms) ||
		    !isfinite(d->site.delay_p99_ms) || !isfinite(d->site.clock_offset_ms) || !isfinite(d->site.rtt_ms))
			memset(&d->site, 0, sizeof(d->site));
		else
			d->site.present = true;
	}
	return r.err ? -r.err : 0;
}

void wire_put_len(uint8_t out[4], uint32_t len)
{
	out[0] = (uint8_t)len;
	out[1] = (uint8_t)(len >> 8);
	out[2] = (uint8_t)(len >> 16);
	out[3] = (uint8_t)(len >> 24);
}

uint32_t wire_get_len(const uint8_t in[4])
{
	return (uint32_t)in[0] | (uint32_t)in[1] << 8 | (uint32_t)in[2] << 16 | (uint32_t)in[3] << 24;
}

bool wire_pose_finite(const struct wire_pose *p)
{
	for (int i = 0; i < 3; i++)
		if (!isfinite(p->p[i]))
			return false;
	for (int i = 0; i < 4; i++)
		if (!isfinite(p->q[i]))
			return false;
	return true;
}

bool wire_frame_stopped(const struct wire_frame *f)
{
	for (int i = 0; i < WIRE_SENSORS; i++)
		if (f->sensor[i].state == WIRE_SENSOR_OK)
			return false;
	return true;
}
