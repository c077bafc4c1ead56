/* SPDX-License-Identifier: MIT */
/*
 * vrpn_proto.h - the VRPN wire protocol as both our VRPN server
 * (publish/vrpn.c) and our VRPN client source (trackers/vrpn_in.c) speak
 * it. Facts from VRPN's vrpn_Connection.[Ch], vrpn_Tracker.C,
 * vrpn_Analog.C and vrpn_Button.C (docs/VRPN.md, docs/TRACKERS.md).
 *
 * A connection starts with a 24-byte cookie each way (the magic, two
 * spaces, a log-mode digit, padding); then messages: a 24-byte header of
 * big-endian 32-bit words (length without padding, seconds, microseconds,
 * sender id, type id, a sequence word no peer reads), the payload, padding
 * to a multiple of 8. Sender and type ids are each side's own; a side
 * announces its names with description messages (negative types) and the
 * other maps them. UDP datagrams carry whole messages, several per
 * datagram.
 */
#ifndef AGW_VRPN_PROTO_H
#define AGW_VRPN_PROTO_H

#include <endian.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#define VRPN_MAGIC "vrpn: ver. 07.35" /* 16 bytes; peers compare up to the last '.' */
#define VRPN_MAGIC_LEN 16
#define VRPN_MAJOR_LEN 14  /* "vrpn: ver. 07." */
#define VRPN_COOKIE_LEN 24 /* magic, two spaces, the log mode digit, padding */
#define VRPN_HEADER_LEN 24 /* five be32 (length, sec, usec, sender, type), padded to 8 */
#define VRPN_ALIGN 8
#define VRPN_NAME_MAX 100  /* a name with its NUL (VRPN's cName) */
#define VRPN_DEVICE_MAX 95 /* a peer refuses a description (length + name + NUL) over 100 */
#define VRPN_ID_MAX 2000   /* VRPN's translation tables */
#define VRPN_LONGEST 64000 /* no VRPN peer sends a longer message (its TCP buffer) */
#define VRPN_UDP_MAX 1472  /* one Ethernet frame, as VRPN sends */
#define VRPN_DEFAULT_PORT 3883
#define VRPN_POS_QUAT_LEN 64 /* be32 sensor, be32 pad, 3 x f64 position (m), 4 x f64 quaternion x y z w */

enum {
	VRPN_SENDER_DESCRIPTION = -1,
	VRPN_TYPE_DESCRIPTION = -2,
	VRPN_UDP_DESCRIPTION = -3,
	VRPN_LOG_DESCRIPTION = -4,
	VRPN_DISCONNECT = -5,
};

/* the message types' names */
#define VRPN_T_POS_QUAT "vrpn_Tracker Pos_Quat"
#define VRPN_T_ANALOG "vrpn_Analog Channel"
#define VRPN_T_BUTTON_CHANGE "vrpn_Button Change"
#define VRPN_T_BUTTON_STATES "vrpn_Button States"
#define VRPN_T_PONG "vrpn_Base pong_message"
#define VRPN_T_PING "vrpn_Base ping_message"

/* a message of this payload length, header and padding included */
#define VRPN_MSG_LEN(payload) (VRPN_HEADER_LEN + (((payload) + VRPN_ALIGN - 1) & ~(size_t)(VRPN_ALIGN - 1)))

static inline void vrpn_put32(uint8_t *p, uint32_t v)
{
	v = htobe32(v);
	memcpy(p, &v, 4);
}

static inline uint32_t vrpn_get32(const uint8_t *p)
{
	uint32_t v;

	memcpy(&v, p, 4);
	return be32toh(v);
}

static inline void vrpn_put_f64(uint8_t *p, double d)
{
	uint64_t v;

	memcpy(&v, &d, 8);
	v = htobe64(v);
	memcpy(p, &v, 8);
}

static inline double vrpn_get_f64(const uint8_t *p)
{
	uint64_t v;
	double d;

	memcpy(&v, p, 8);
	v = be64toh(v);
	memcpy(&d, &v, 8);
	return d;
}

/* a decoded header */
struct vrpn_header {
	uint32_t len; /* header and payload, no padding */
	uint32_t sec, usec;
	int32_t sender, type;
};

/* a message's header at p (zeroed padding after the payload); returns where its payload goes */
uint8_t *vrpn_msg_header(uint8_t *p, int32_t type, int32_t sender, uint64_t t_ns, size_t payload);
/* a sender or type description (the id described goes in the sender field); returns its length */
size_t vrpn_msg_description(uint8_t *p, int32_t kind, int32_t id, const char *name, uint64_t t_ns);
/* our cookie, asking the peer for log mode 0 (none) */
void vrpn_cookie(uint8_t out[VRPN_COOKIE_LEN]);
/* the peer's cookie: the same major version and a log mode digit */
bool vrpn_cookie_ok(const uint8_t *ck);

enum vrpn_split_rc {
	VRPN_SPLIT_OK = 0,   /* a whole message of *total bytes (padding included) */
	VRPN_SPLIT_MORE = 1, /* fewer bytes than its header or its length say: wait for more */
	VRPN_SPLIT_BAD = -1, /* a length no VRPN peer writes: the stream is lost */
};
/* the message at the start of buf */
enum vrpn_split_rc vrpn_split(const uint8_t *buf, size_t len, struct vrpn_header *h, size_t *total);
/* a description's name (NUL-terminated into name); false when malformed */
bool vrpn_description_name(const uint8_t *pl, size_t plen, char name[VRPN_NAME_MAX]);

#endif /* AGW_VRPN_PROTO_H */
