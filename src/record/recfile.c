// SPDX-License-Identifier: MIT
/*
 * recfile.c - the recording format's codec. See recfile.h and
 * docs/RECORDING.md.
 */
#include "record/recfile.h"

#include <stdlib.h>
#include <string.h>
#include <zlib.h>

/* ---- little-endian -------------------------------------------------------------------- */

void recfile_put16(uint8_t *p, uint16_t v)
{
	p[0] = (uint8_t)v;
	p[1] = (uint8_t)(v >> 8);
}

void recfile_put32(uint8_t *p, uint32_t v)
{
	for (int i = 0; i < 4; i++)
		p[i] = (uint8_t)(v >> (8 * i));
}

void recfile_put64(uint8_t *p, uint64_t v)
{
	for (int i = 0; i < 8; i++)
		p[i] = (uint8_t)(v >> (8 * i));
}

void recfile_putf32(uint8_t *p, float v)
{
	uint32_t u;

	memcpy(&u, &v, sizeof(u));
	recfile_put32(p, u);
}

void recfile_putf64(uint8_t *p, double v)
{
	uint64_t u;

	memcpy(&u, &v, sizeof(u));
	recfile_put64(p, u);
}

uint16_t recfile_get16(const uint8_t *p)
{
	return (uint16_t)(p[0] | p[1] << 8);
}

uint32_t recfile_get32(const uint8_t *p)
{
	return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

uint64_t recfile_get64(const uint8_t *p)
{
	return (uint64_t)recfile_get32(p) | (uint64_t)recfile_get32(p + 4) << 32;
}

float recfile_getf32(const uint8_t *p)
{
	uint32_t u = recfile_get32(p);
	float v;

	memcpy(&v, &u, sizeof(v));
	return v;
}

double recfile_getf64(const uint8_t *p)
{
	uint64_t u = recfile_get64(p);
	double v;

	memcpy(&v, &u, sizeof(v));
	return v;
}

static uint32_t crc(const uint8_t *p, size_t n)
{
	return (uint32_t)crc32(crc32(0L, Z_NULL, 0), p, (uInt)n);
}

/* ---- header ----------------------------------------------------------------------------- */

bool recfile_is_recording(const uint8_t *buf, size_t len)
{
	return len >= RECFILE_MAGIC_LEN && !memcmp(buf, RECFILE_MAGIC, RECFILE_MAGIC_LEN);
}

void recfile_header_encode(const struct recfile_header *h, uint8_t out[RECFILE_HEADER_LEN])
{
	memcpy(out, RECFILE_MAGIC, RECFILE_MAGIC_LEN);
	recfile_put16(out + 8, h->version);
	recfile_put16(out + 10, RECFILE_HEADER_LEN);
	recfile_put32(out + 12, h->flags);
	recfile_put64(out + 16, h->created_ns);
	recfile_put32(out + 24, h->seq);
	recfile_put32(out + 28, crc(out, 28));
}

int recfile_header_decode(const uint8_t *buf, size_t len, struct recfile_header *h)
{
	if (len < RECFILE_HEADER_LEN || !recfile_is_recording(buf, len))
		return -1;
	if (recfile_get32(buf + 28) != crc(buf, 28))
		return -2;
	h->version = recfile_get16(buf + 8);
	if (h->version != RECFILE_VERSION || recfile_get16(buf + 10) != RECFILE_HEADER_LEN)
		return -3;
	h->flags = recfile_get32(buf + 12);
	h->created_ns = recfile_get64(buf + 16);
	h->seq = recfile_get32(buf + 24);
	return 0;
}

/* ---- records ---------------------------------------------------------------------------- */

void recfile_frame(uint8_t *rec, uint8_t type, uint32_t len)
{
	rec[0] = RECFILE_SYNC0;
	rec[1] = RECFILE_SYNC1;
	rec[2] = RECFILE_SYNC2;
	rec[3] = RECFILE_SYNC3;
	recfile_put32(rec + 4, (uint32_t)type | len << 8);
}

uint32_t recfile_framed_len(const uint8_t *rec)
{
	return recfile_get32(rec + 4) >> 8;
}

void recfile_seal(uint8_t *rec)
{
	uint32_t len = recfile_framed_len(rec);

	/* the CRC covers the word and the payload: a damaged length fails it too */
	recfile_put32(rec + RECFILE_REC_HEAD + len, crc(rec + 4, 4 + (size_t)len));
}

static bool is_sync(const uint8_t *p)
{
	return p[0] == RECFILE_SYNC0 && p[1] == RECFILE_SYNC1 && p[2] == RECFILE_SYNC2 && p[3] == RECFILE_SYNC3;
}

enum { REC_BAD, REC_GOOD, REC_SHORT };

/* what is at off: a good record, a record cut short by the end of the buffer, or neither */
static int check_at(const uint8_t *buf, size_t len, size_t off, struct recfile_record *rec)
{
	uint32_t plen;
	size_t size;

	if (len - off < RECFILE_REC_HEAD)
		return len - off >= 1 && !memcmp(buf + off, "\xa5REC", len - off < 4 ? len - off : 4) ? REC_SHORT
												      : REC_BAD;
	if (!is_sync(buf + off))
		return REC_BAD;
	plen = recfile_framed_len(buf + off);
	size = RECFILE_REC_OVERHEAD + (size_t)plen;
	if (size > len - off)
		return REC_SHORT;
	if (recfile_get32(buf + off + RECFILE_REC_HEAD + plen) != crc(buf + off + 4, 4 + (size_t)plen))
		return REC_BAD;
	rec->type = buf[off + 4];
	rec->len = plen;
	rec->payload = buf + off + RECFILE_REC_HEAD;
	rec->off = off;
	rec->size = size;
	return REC_GOOD;
}

int recfile_next(const uint8_t *buf, size_t len, size_t *off, struct recfile_record *rec, struct recfile_damage *dmg)
{
	size_t start = *off, p;
	int first;

	if (dmg)
		*dmg = (struct recfile_damage){ start, 0, false };
	if (start >= len)
		return 0;
	first = check_at(buf, len, start, rec);
	if (first == REC_GOOD) {
		*off = start + rec->size;
		return 1;
	}
	/* resynchronise: the next sync word that starts a good record */
	for (p = start + 1; p + RECFILE_REC_OVERHEAD <= len; p++) {
		const uint8_t *s = memchr(buf + p, RECFILE_SYNC0, len - p);

		if (!s)
			break;
		p = (size_t)(s - buf);
		if (p + RECFILE_REC_OVERHEAD > len)
			break;
		if (check_at(buf, len, p, rec) == REC_GOOD) {
			if (dmg)
				*dmg = (struct recfile_damage){ start, p - start, false };
			*off = p + rec->size;
			return 1;
		}
	}
	if (dmg)
		*dmg = (struct recfile_damage){ start, len - start, first == REC_SHORT };
	*off = len;
	return 0;
}

/* ---- payloads ------------------------------------------------------------------------------ */

size_t recfile_sample_encode(const struct recfile_sample *s, uint8_t *p)
{
	recfile_put16(p, s->source);
	recfile_put16(p + 2, s->sensor);
	recfile_put32(p + 4, s->buttons);
	recfile_put64(p + 8, s->t_ns);
	recfile_put64(p + 16, s->arrival_ns);
	for (int i = 0; i < 3; i++)
		recfile_putf32(p + 24 + 4 * i, s->p[i]);
	for (int i = 0; i < 4; i++)
		recfile_putf32(p + 36 + 4 * i, s->q[i]);
	if (!s->has_analog)
		return RECFILE_SAMPLE_LEN;
	for (int i = 0; i < 4; i++)
		recfile_putf32(p + 52 + 4 * i, s->analog[i]);
	return RECFILE_SAMPLE_LEN_ANALOG;
}

int recfile_sample_decode(const uint8_t *p, uint32_t len, struct recfile_sample *s)
{
	if (len != RECFILE_SAMPLE_LEN && len != RECFILE_SAMPLE_LEN_ANALOG)
		return -1;
	s->source = recfile_get16(p);
	s->sensor = recfile_get16(p + 2);
	s->buttons = recfile_get32(p + 4);
	s->t_ns = recfile_get64(p + 8);
	s->arrival_ns = recfile_get64(p + 16);
	for (int i = 0; i < 3; i++)
		s->p[i] = recfile_getf32(p + 24 + 4 * i);
	for (int i = 0; i < 4; i++)
		s->q[i] = recfile_getf32(p + 36 + 4 * i);
	s->has_analog = len == RECFILE_SAMPLE_LEN_ANALOG;
	for (int i = 0; i < 4; i++)
		s->analog[i] = s->has_analog ? recfile_getf32(p + 52 + 4 * i) : 0.0f;
	return 0;
}

void recfile_gap_encode(const struct recfile_gap *g, uint8_t p[RECFILE_GAP_LEN])
{
	recfile_put64(p, g->mono_ns);
	recfile_put64(p + 8, g->records);
	recfile_put64(p + 16, g->bytes);
}

int recfile_gap_decode(const uint8_t *p, uint32_t len, struct recfile_gap *g)
{
	if (len != RECFILE_GAP_LEN)
		return -1;
	g->mono_ns = recfile_get64(p);
	g->records = recfile_get64(p + 8);
	g->bytes = recfile_get64(p + 16);
	return 0;
}

void recfile_end_encode(const struct recfile_end *e, uint8_t p[RECFILE_END_LEN])
{
	recfile_put64(p, e->mono_ns);
	recfile_put64(p + 8, e->records);
	p[16] = e->reason;
}

int recfile_end_decode(const uint8_t *p, uint32_t len, struct recfile_end *e)
{
	if (len != RECFILE_END_LEN)
		return -1;
	e->mono_ns = recfile_get64(p);
	e->records = recfile_get64(p + 8);
	e->reason = p[16];
	return 0;
}

/* ---- SESSION --------------------------------------------------------------------------------- */

static uint8_t *w_room(struct recfile_writer *w, size_t n)
{
	uint8_t *p;

	if (w->overflow || w->cap - w->len < n) {
		w->overflow = true;
		return NULL;
	}
	p = w->buf + w->len;
	w->len += n;
	return p;
}

void recfile_w_u8(struct recfile_writer *w, uint8_t v)
{
	uint8_t *p = w_room(w, 1);

	if (p)
		*p = v;
}

/* recfile_w_u16, _u32, _u64, _f64: a little-endian value */
#define RECFILE_W_FIXED(name, type, size, put)                                                                         \
	void recfile_w_##name(struct recfile_writer *w, type v)                                                        \
	{                                                                                                              \
		uint8_t *p = w_room(w, size);                                                                          \
                                                                                                                       \
		if (p)                                                                                                 \
			put(p, v);                                                                                     \
	}
RECFILE_W_FIXED(u16, uint16_t, 2, recfile_put16)
RECFILE_W_FIXED(u32, uint32_t, 4, recfile_put32)
RECFILE_W_FIXED(u64, uint64_t, 8, recfile_put64)
RECFILE_W_FIXED(f64, double, 8, recfile_putf64)

void recfile_w_str(struct recfile_writer *w, const char *s)
{
	size_t n = strlen(s);
	uint8_t *p;

	if (n > RECFILE_NAME_MAX)
		n = RECFILE_NAME_MAX;
	p = w_room(w, 1 + n);
	if (!p)
		return;
	p[0] = (uint8_t)n;
	memcpy(p + 1, s, n);
}

struct reader {
	const uint8_t *p;
	size_t len, off;
	bool bad;
};

static const uint8_t *r_take(struct reader *r, size_t n)
{
	const uint8_t *p;

	if (r->bad || r->len - r->off < n) {
		r->bad = true;
		return NULL;
	}
	p = r->p + r->off;
	r->off += n;
	return p;
}

/* r_u16, r_u32, r_u64, r_f64: a little-endian value, 0 past the end (and the reader marked bad) */
#define R_FIXED(name, type, size, get)                                                                                 \
	static type r_##name(struct reader *r)                                                                         \
	{                                                                                                              \
		const uint8_t *p = r_take(r, size);                                                                    \
                                                                                                                       \
		return p ? get(p) : 0;                                                                                 \
	}
R_FIXED(u16, uint16_t, 2, recfile_get16)
R_FIXED(u32, uint32_t, 4, recfile_get32)
R_FIXED(u64, uint64_t, 8, recfile_get64)
R_FIXED(f64, double, 8, recfile_getf64)

static char *r_str(struct reader *r)
{
	const uint8_t *n = r_take(r, 1), *p;
	char *s;

	if (!n)
		return NULL;
	p = r_take(r, *n);
	if (!p)
		return NULL;
	s = malloc((size_t)*n + 1);
	if (!s) {
		r->bad = true;
		return NULL;
	}
	memcpy(s, p, *n);
	s[*n] = '\0';
	if (strlen(s) != *n) {
		/* a NUL inside a name: not ours */
		free(s);
		r->bad = true;
		return NULL;
	}
	return s;
}

int recfile_session_parse(const uint8_t *payload, uint32_t len, struct recfile_session *s)
{
	struct reader r = { payload, len, 0, false };

	memset(s, 0, sizeof(*s));
	s->real_ns = r_u64(&r);
	s->mono_ns = r_u64(&r);
	s->rate = r_f64(&r);
	s->source_id = r_u32(&r);
	s->n_sources = r_u16(&r);
	s->n_avatars = r_u16(&r);
	if (r.bad)
		return -1;
	s->sources = calloc((size_t)s->n_sources + 1, sizeof(*s->sources));
	s->avatars = calloc((size_t)s->n_avatars + 1, sizeof(*s->avatars));
	if (!s->sources || !s->avatars)
		goto bad;
	for (int i = 0; i < s->n_sources && !r.bad; i++) {
		struct recfile_source *src = &s->sources[i];

		src->name = r_str(&r);
		src->driver = r_str(&r);
		src->n_sensors = r_u32(&r);
		if (r.bad || src->n_sensors > 65536 || src->n_sensors > len)
			goto bad;
		src->sensor = calloc((size_t)src->n_sensors + 1, sizeof(*src->sensor));
		if (!src->sensor)
			goto bad;
		for (uint32_t k = 0; k < src->n_sensors && !r.bad; k++)
			src->sensor[k] = r_str(&r);
		for (int k = 0; k < 3; k++)
			src->origin[k] = r_f64(&r);
		src->yaw = r_f64(&r);
	}
	for (int i = 0; i < s->n_avatars && !r.bad; i++) {
		struct recfile_avatar *a = &s->avatars[i];

		a->name = r_str(&r);
		a->id = r_u16(&r);
		for (int k = 0; k < 3; k++) {
			a->source[k] = r_u16(&r);
			a->sensor[k] = r_u16(&r);
			if (!r.bad &&
			    (a->source[k] >= s->n_sources || a->sensor[k] >= s->sources[a->source[k]].n_sensors))
				r.bad = true;
		}
		for (int k = 0; k < 4; k++)
			a->dims[k] = r_f64(&r);
		for (int k = 0; k < 3; k++)
			a->head_offset[k] = r_f64(&r);
	}
	if (r.bad || r.off != len)
		goto bad;
	return 0;
bad:
	recfile_session_free(s);
	return -1;
}

void recfile_session_free(struct recfile_session *s)
{
	for (int i = 0; s->sources && i < s->n_sources; i++) {
		struct recfile_source *src = &s->sources[i];

		free(src->name);
		free(src->driver);
		for (uint32_t k = 0; src->sensor && k < src->n_sensors; k++)
			free(src->sensor[k]);
		free(src->sensor);
	}
	for (int i = 0; s->avatars && i < s->n_avatars; i++)
		free(s->avatars[i].name);
	free(s->sources);
	free(s->avatars);
	memset(s, 0, sizeof(*s));
}

const char *recfile_type_name(uint8_t type)
{
	switch (type) {
	case RECFILE_SESSION:
		return "SESSION";
	case RECFILE_SAMPLE:
		return "SAMPLE";
	case RECFILE_MESSAGE:
		return "MESSAGE";
	case RECFILE_GAP:
		return "GAP";
	case RECFILE_END:
		return "END";
	case RECFILE_REMOTE:
		return "REMOTE";
	default:
		return "unknown";
	}
}
