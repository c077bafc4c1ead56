/* SPDX-License-Identifier: MIT */
/*
 * recfile.h - the recording file format (docs/RECORDING.md): a 32-byte
 * header, then records, each framed by a sync word and its length and
 * closed by a CRC-32, so that a reader can check every record, stop at a
 * truncated tail and find the next good record after damage.
 *
 * All integers little-endian, floats IEEE 754. Pure functions over caller
 * buffers: no allocation (but recfile_session_parse, which says so), no I/O.
 * The CRC is zlib's crc32() (the CRC-32 of gzip, PNG and Ethernet).
 */
#ifndef AGW_RECFILE_H
#define AGW_RECFILE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#define RECFILE_MAGIC                                                                                                  \
	"\x89"                                                                                                         \
	"AGWR\r\n\x1a"
#define RECFILE_MAGIC_LEN 8
#define RECFILE_VERSION 1
#define RECFILE_HEADER_LEN 32

/* header flags */
#define RECFILE_F_MESSAGES 0x1	/* the published wire messages are recorded too */
#define RECFILE_F_KEYFRAMES 0x2 /* samples were kept at a reduced rate (record_keyframe_rate) */

/* record framing: sync (4), word = type | length << 8 (4), payload, CRC-32 (4) */
#define RECFILE_SYNC0 0xa5
#define RECFILE_SYNC1 'R'
#define RECFILE_SYNC2 'E'
#define RECFILE_SYNC3 'C'
#define RECFILE_REC_HEAD 8
#define RECFILE_REC_OVERHEAD 12
#define RECFILE_MAX_PAYLOAD 0xffffffu

enum recfile_type {
	RECFILE_SESSION = 1, /* who is recorded: sources, sensors, avatars; at the start of every file and reload */
	RECFILE_SAMPLE = 2,  /* one sensor sample as the daemon took it in */
	RECFILE_MESSAGE = 3, /* one published wire message (FRAME or DESCRIBE) */
	RECFILE_GAP = 4,     /* records lost because the recorder's buffer was full */
	RECFILE_END = 5,     /* the file was closed on purpose (stop or rotation) */
	RECFILE_REMOTE = 6,  /* a remote avatar's FRAME or DESCRIBE ([site]): solved elsewhere, replayed as it was */
};

#define RECFILE_SAMPLE_LEN 52	     /* without analog values */
#define RECFILE_SAMPLE_LEN_ANALOG 68 /* with the four analog values */
#define RECFILE_GAP_LEN 24
#define RECFILE_END_LEN 17
#define RECFILE_MESSAGE_HEAD 8 /* mono time before the message bytes (MESSAGE and REMOTE) */

struct recfile_header {
	uint16_t version;
	uint32_t flags;
	uint64_t created_ns; /* CLOCK_REALTIME when the file was opened */
	uint32_t seq;	     /* 0 for the first file of a daemon run, + 1 at each rotation */
};

struct recfile_record {
	uint8_t type;
	uint32_t len; /* payload bytes */
	const uint8_t *payload;
	size_t off;  /* of the record's first byte in the buffer */
	size_t size; /* of the whole record, RECFILE_REC_OVERHEAD + len */
};

/* bytes that recfile_next() skipped: damage, or a record cut off at the end of the buffer */
struct recfile_damage {
	size_t off;
	size_t len;
	bool truncated; /* the bytes run to the end of the buffer and start like a record cut short */
};

struct recfile_sample {
	uint16_t source; /* index in the SESSION's sources */
	uint16_t sensor; /* index in that source's sensors */
	uint32_t buttons;
	uint64_t t_ns;	     /* the tracker's sample time, CLOCK_REALTIME */
	uint64_t arrival_ns; /* when the daemon took it in, CLOCK_MONOTONIC */
	float p[3];	     /* world position, m */
	float q[4];	     /* world orientation, w x y z */
	bool has_analog;
	float analog[4];
};

struct recfile_gap {
	uint64_t mono_ns; /* when the writer noticed */
	uint64_t records; /* lost since the previous GAP */
	uint64_t bytes;
};

struct recfile_end {
	uint64_t mono_ns;
	uint64_t records; /* records in this file before END */
	uint8_t reason;	  /* 0 the recorder stopped, 1 rotation */
};

bool recfile_is_recording(const uint8_t *buf, size_t len);
void recfile_header_encode(const struct recfile_header *h, uint8_t out[RECFILE_HEADER_LEN]);
/* 0; -1 not a recording (magic); -2 a damaged header (CRC); -3 a version this reader does not know */
int recfile_header_decode(const uint8_t *buf, size_t len, struct recfile_header *h);

/* little-endian stores and loads */
void recfile_put16(uint8_t *p, uint16_t v);
void recfile_put32(uint8_t *p, uint32_t v);
void recfile_put64(uint8_t *p, uint64_t v);
void recfile_putf32(uint8_t *p, float v);
void recfile_putf64(uint8_t *p, double v);
uint16_t recfile_get16(const uint8_t *p);
uint32_t recfile_get32(const uint8_t *p);
uint64_t recfile_get64(const uint8_t *p);
float recfile_getf32(const uint8_t *p);
double recfile_getf64(const uint8_t *p);

/*
 * A record in rec[0 .. RECFILE_REC_OVERHEAD + len): recfile_frame() writes
 * the sync and the word (the payload goes at rec + RECFILE_REC_HEAD);
 * recfile_seal() writes the CRC after the payload. A writer may frame a
 * record, fill it, and seal it later (the recorder seals in its writer
 * thread, not in the loop).
 */
void recfile_frame(uint8_t *rec, uint8_t type, uint32_t len);
void recfile_seal(uint8_t *rec);
/* the payload length a framed record claims (no check) */
uint32_t recfile_framed_len(const uint8_t *rec);

/*
 * The next good record at or after *off in buf[0 .. len). Returns 1 with
 * *rec and *off moved past it; 0 at the end of the buffer. Bytes that do
 * not form a good record (wrong sync, length past the end, CRC mismatch) are
 * skipped up to the next sync word that starts a good record; if any were,
 * dmg->len > 0 says where (a return of 0 with dmg->len > 0: damage or a
 * truncated record at the end). dmg may be NULL.
 */
int recfile_next(const uint8_t *buf, size_t len, size_t *off, struct recfile_record *rec, struct recfile_damage *dmg);

size_t recfile_sample_encode(const struct recfile_sample *s, uint8_t *payload);
int recfile_sample_decode(const uint8_t *payload, uint32_t len, struct recfile_sample *s);
void recfile_gap_encode(const struct recfile_gap *g, uint8_t payload[RECFILE_GAP_LEN]);
int recfile_gap_decode(const uint8_t *payload, uint32_t len, struct recfile_gap *g);
void recfile_end_encode(const struct recfile_end *e, uint8_t payload[RECFILE_END_LEN]);
int recfile_end_decode(const uint8_t *payload, uint32_t len, struct recfile_end *e);

/* ---- SESSION ---------------------------------------------------------------------------- */

#define RECFILE_NAME_MAX 255

struct recfile_source {
	char *name;
	char *driver;
	uint32_t n_sensors;
	char **sensor;	  /* n_sensors names */
	double origin[3]; /* the source's transform to the world (samples are already in the world) */
	double yaw;	  /* rad */
};

struct recfile_avatar {
	char *name;
	uint16_t id;
	uint16_t source[3]; /* head, left hand, right hand */
	uint16_t sensor[3];
	double dims[4]; /* S, A, F, H, m */
	double head_offset[3];
};

struct recfile_session {
	uint64_t real_ns; /* CLOCK_REALTIME and CLOCK_MONOTONIC at the same instant */
	uint64_t mono_ns;
	double rate;	    /* loop rate, Hz */
	uint32_t source_id; /* the wire protocol's source id */
	uint16_t n_sources;
	uint16_t n_avatars;
	struct recfile_source *sources;
	struct recfile_avatar *avatars;
};

/*
 * Writing a SESSION: a cursor over the caller's buffer; every put checks
 * room and the final length says whether everything fitted.
 */
struct recfile_writer {
	uint8_t *buf;
	size_t cap;
	size_t len;
	bool overflow;
};

void recfile_w_u8(struct recfile_writer *w, uint8_t v);
void recfile_w_u16(struct recfile_writer *w, uint16_t v);
void recfile_w_u32(struct recfile_writer *w, uint32_t v);
void recfile_w_u64(struct recfile_writer *w, uint64_t v);
void recfile_w_f64(struct recfile_writer *w, double v);
void recfile_w_str(struct recfile_writer *w, const char *s); /* u8 length + bytes; longer strings are cut at 255 */

/* Parses a SESSION payload into *s. Allocates (free with recfile_session_free). 0 or -1 (malformed or no memory). */
int recfile_session_parse(const uint8_t *payload, uint32_t len, struct recfile_session *s);
void recfile_session_free(struct recfile_session *s);

const char *recfile_type_name(uint8_t type);

#endif /* AGW_RECFILE_H */
