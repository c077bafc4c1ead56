/* SPDX-License-Identifier: MIT */
/*
 * wire.h - avatargw's UDP protocol, version 1 (docs/PROTOCOL.md).
 *
 * Every message is one datagram of at most WIRE_MAX_MSG bytes: a 40-byte
 * header, then a payload. All integers and floats are little-endian; floats
 * are IEEE 754 binary32. On a stream (TCP, Unix) each message is preceded
 * by its length as a u32 (little-endian).
 *
 * World frame: right-handed, z up, metres. Quaternions are Hamilton,
 * body to world, stored w, x, y, z. Angles are radians.
 *
 * This header and src/wire/wire.c are all a C or C++ client needs: they
 * use no other part of avatargw and allocate nothing.
 */
#ifndef AVATARGW_WIRE_H
#define AVATARGW_WIRE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define WIRE_MAGIC 0x57475641u /* bytes 'A' 'V' 'G' 'W' */
#define WIRE_VERSION 1
#define WIRE_HEADER_LEN 40
#define WIRE_MAX_MSG 1200
#define WIRE_DEFAULT_PORT 7770

enum wire_type {
	WIRE_FRAME = 1,	   /* one solved avatar */
	WIRE_DESCRIBE = 2, /* an avatar's skeleton: names, limits, lengths, axes */
};

/* header flags of a FRAME */
enum wire_flag {
	WIRE_F_STALE = 1u << 0,	     /* a sensor is stale or missing (see its state) */
	WIRE_F_UNREACHED = 1u << 1,  /* an arm's target was out of reach or invalid: closest posture */
	WIRE_F_HELD = 1u << 2,	     /* no valid head: the previous frame's posture, repeated */
	WIRE_F_NEW_SAMPLE = 1u << 3, /* a sensor sample arrived since the previous frame */
	WIRE_F_INPUTS = 1u << 4,     /* the FRAME ends with an input block (buttons, analog values) */
};

/* per-sensor state in a FRAME */
enum wire_sensor_state {
	WIRE_SENSOR_OK = 0,
	WIRE_SENSOR_STALE = 1,	 /* no new sample for longer than the configured stale time */
	WIRE_SENSOR_MISSING = 2, /* never seen, or its tracker is FAULTY; pose is NaN */
};

/* the fixed content of version 1 */
#define WIRE_SENSORS 3 /* head, left hand, right hand */
#define WIRE_ARMS 2    /* right, left */
#define WIRE_JOINTS 17 /* chest_yaw, then 8 right-arm and 8 left-arm joints */
#define WIRE_SEGMENTS 10
/*
 * Longest name, bytes; the conventions string may hold 4 times as many.
 * 15 is the most that keeps the longest DESCRIBE (every string at its
 * maximum) within WIRE_MAX_MSG: exactly 1200 bytes.
 */
#define WIRE_NAME_MAX 15

enum wire_sensor { WIRE_S_HEAD, WIRE_S_LEFT_HAND, WIRE_S_RIGHT_HAND };
enum wire_arm { WIRE_ARM_RIGHT, WIRE_ARM_LEFT };
enum wire_segment {
	WIRE_SEG_CHEST,
	WIRE_SEG_HEAD,
	WIRE_SEG_R_SHOULDER,
	WIRE_SEG_R_ELBOW,
	WIRE_SEG_R_WRIST,
	WIRE_SEG_R_HAND,
	WIRE_SEG_L_SHOULDER,
	WIRE_SEG_L_ELBOW,
	WIRE_SEG_L_WRIST,
	WIRE_SEG_L_HAND,
};

struct wire_pose {
	float p[3]; /* metres */
	float q[4]; /* w, x, y, z */
};

struct wire_header {
	uint8_t version;
	uint8_t type;
	uint16_t header_len;
	uint16_t payload_len;
	uint16_t flags;
	uint32_t source_id;	 /* random, chosen at each start of the daemon */
	uint32_t seq;		 /* per avatar and message type, +1 per message */
	uint32_t describe_rev;	 /* the DESCRIBE revision this message belongs to */
	uint64_t sample_time_ns; /* CLOCK_REALTIME of the newest tracker sample used */
	uint16_t avatar_id;
	uint8_t n_joints;
	uint8_t n_segments;
	uint8_t n_sensors;
};

struct wire_sensor_sample {
	uint8_t state;	       /* enum wire_sensor_state */
	uint16_t age_100us;    /* age of the sample at publication, 0.1 ms, saturating */
	struct wire_pose pose; /* world, NaN when MISSING */
};

struct wire_arm_result {
	uint16_t ik_flags; /* the IK core's IK_* flags */
	uint8_t iters;	   /* Newton iterations */
	float pos_err;	   /* hand position residual, metres */
};

#define WIRE_ANALOG 4	   /* analog values per sensor in an input block */
#define WIRE_FRAME_LEN 500 /* a FRAME without input block */
#define WIRE_INPUTS_LEN 64 /* the input block that follows it when WIRE_F_INPUTS is set */

/*
 * Buttons and analog values of the sensors that have them (a Razer Hydra
 * wand: buttons, joystick x and y, trigger; see docs/TRACKERS.md for each
 * driver's meaning of the bits and values). Sent after the FRAME's other
 * fields when the header's flags have WIRE_F_INPUTS.
 */
struct wire_inputs {
	uint8_t present;			 /* bit i: sensor i's buttons and analog values are current */
	uint32_t buttons[WIRE_SENSORS];		 /* bit k: button k pressed */
	float analog[WIRE_SENSORS][WIRE_ANALOG]; /* -1..1 (axes), 0..1 (triggers), 0 when unused */
};

struct wire_frame {
	struct wire_header h;
	struct wire_sensor_sample sensor[WIRE_SENSORS];
	struct wire_arm_result arm[WIRE_ARMS];
	float joint[WIRE_JOINTS];		 /* radians, NaN = unknown */
	struct wire_pose segment[WIRE_SEGMENTS]; /* world */
	/*
	 * Encoded only when h.flags has WIRE_F_INPUTS; the decoder fills it
	 * from the message, or zeroes it and clears the flag when the message
	 * has no input block.
	 */
	struct wire_inputs in;
};

struct wire_joint_desc {
	char name[WIRE_NAME_MAX + 1];
	uint8_t segment; /* the segment this joint moves */
	float lo, hi;	 /* limits, radians */
	float axis[3];	 /* rotation axis, in the frame of the joints before it */
	float trans[3];	 /* translation after the rotation, metres */
};

struct wire_segment_desc {
	char name[WIRE_NAME_MAX + 1];
	uint8_t parent; /* index of the parent segment, 255 = world */
};

/*
 * A remote avatar's site ([site], docs/SITES.md): how its site's samples
 * reach this daemon, refreshed in each of its DESCRIBEs (an optional block
 * after the sensor names, docs/PROTOCOL.md; a change of these figures is no
 * new describe_rev). present: the DESCRIBE carries the block.
 */
#define WIRE_SITE_NAME_MAX 31
#define WIRE_SITE_BLOCK 1 /* the block's tag */

/* a remote avatar's site as the daemon sees it (its DESCRIBE's site block) */
enum wire_site_state {
	WIRE_SITE_PRESENT = 0,
	WIRE_SITE_GONE = 1, /* left (its lease ran out, or it said goodbye) */
};

struct wire_site {
	bool present;
	char name[WIRE_SITE_NAME_MAX + 1];
	uint8_t state;	       /* enum wire_site_state */
	uint16_t avatars;      /* the site's avatars here now */
	float rate_hz;	       /* its frames arriving per second, all its avatars */
	uint32_t frames;       /* received from it */
	uint32_t lost;	       /* lost on the way (gaps in its numbering) */
	float delay_p50_ms;    /* one way: its sample time, on our clock, to the arrival here; -1: no estimate yet */
	float delay_p99_ms;    /* -1: no estimate yet */
	float clock_offset_ms; /* its clock minus ours (0 until rtt_ms >= 0) */
	float rtt_ms;	       /* round trip of the clock estimate in use; -1: none yet */
};

struct wire_describe {
	struct wire_header h;
	float rate_hz;
	float dims[4];	      /* shoulder, upper arm, forearm, hand: metres */
	float head_offset[3]; /* head sensor from the chest origin, chest frame */
	char avatar_name[WIRE_NAME_MAX + 1];
	char conventions[WIRE_NAME_MAX * 4 + 1];
	struct wire_joint_desc joint[WIRE_JOINTS];
	struct wire_segment_desc segment[WIRE_SEGMENTS];
	char sensor[WIRE_SENSORS][WIRE_NAME_MAX + 1];
	struct wire_site site; /* a remote avatar's site, when present */
};

/* errors of the decoders (returned negated) */
enum wire_error {
	WIRE_ESHORT = 1, /* shorter than its header says */
	WIRE_EMAGIC,	 /* not an avatargw message */
	WIRE_EVERSION,	 /* a version this decoder does not read */
	WIRE_ETYPE,	 /* not the message type asked for */
	WIRE_ECOUNT,	 /* counts that do not fit this version */
	WIRE_ELONG,	 /* header_len + payload_len above WIRE_MAX_MSG */
	WIRE_ESTRING,	 /* a name longer than WIRE_NAME_MAX */
};

const char *wire_strerror(int err);

/*
 * Encoders: write into buf (at least WIRE_MAX_MSG bytes), fill in the
 * header's lengths, counts and type, and return the message length. A
 * FRAME is WIRE_FRAME_LEN bytes, WIRE_FRAME_LEN + WIRE_INPUTS_LEN with an
 * input block (h.flags & WIRE_F_INPUTS).
 */
/* the person stopped: no sensor of the frame is OK (every one STALE or MISSING) */
bool wire_frame_stopped(const struct wire_frame *f);
/* every number of the pose is finite (a pose the frame does not know is NaN) */
bool wire_pose_finite(const struct wire_pose *p);

size_t wire_encode_frame(const struct wire_frame *f, uint8_t *buf);
/* an encoded message's seq and describe_rev set anew (a DESCRIBE sent again: the rest is the same) */
void wire_restamp(uint8_t *msg, uint32_t seq, uint32_t describe_rev);
size_t wire_encode_describe(const struct wire_describe *d, uint8_t *buf);

/* Reads the header; returns its type (> 0) or -WIRE_E*. */
int wire_peek(const uint8_t *buf, size_t len, struct wire_header *h);
/* Decoders: 0 or -WIRE_E*. Later versions' extra header or payload bytes are skipped. */
int wire_decode_frame(const uint8_t *buf, size_t len, struct wire_frame *f);
int wire_decode_describe(const uint8_t *buf, size_t len, struct wire_describe *d);

/* Stream framing: the u32 length prefix. */
void wire_put_len(uint8_t out[4], uint32_t len);
uint32_t wire_get_len(const uint8_t in[4]);

/* The fixed names of version 1. */
extern const char *const wire_joint_names[WIRE_JOINTS];
extern const char *const wire_segment_names[WIRE_SEGMENTS];
extern const char *const wire_sensor_names[WIRE_SENSORS];

#ifdef __cplusplus
}
#endif

#endif /* AVATARGW_WIRE_H */
