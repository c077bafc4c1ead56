/* SPDX-License-Identifier: MIT */
/*
 * cancodec.h - avatargw's CAN frames (docs/CAN.md, docs/avatargw.dbc), and
 * the candump -L text form of a frame. Pure functions: no I/O, no state.
 *
 * Output: one avatar is 5 classic frames of 8 bytes, little-endian, at
 * consecutive identifiers from its status frame's:
 *
 *   id + 0  STATUS   counter u8, flags u8, sensor states u8, IK u8,
 *                    chest_yaw i16, age_ms u16
 *   id + 1  RIGHT_1  right j1..j4, i16 each
 *   id + 2  RIGHT_2  right j5..j8
 *   id + 3  LEFT_1   left j1..j4
 *   id + 4  LEFT_2   left j5..j8
 *
 * Angles are signed 0.01 degree (+-327.67 degrees); -32768 means unknown.
 *
 * Input: sensor k's orientation is one frame at ori_id + k, four i16
 * quaternion components scaled by quat_scale (w x y z or x y z w); its
 * position one frame at pos_id + k, three i16 scaled by pos_scale metres
 * (6 or 8 bytes, the last two ignored).
 *
 * Identifiers given to these functions are can_id values: the 11 or 29
 * bits, with CAN_EFF_FLAG set for 29-bit ones.
 */
#ifndef AGW_CANCODEC_H
#define AGW_CANCODEC_H

#include <linux/can.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#define CANCODEC_JOINTS 17	   /* chest yaw, right j1..j8, left j1..j8 (the wire protocol's order) */
#define CANCODEC_FRAMES 5	   /* frames per avatar and cycle */
#define CANCODEC_ID_STRIDE 8	   /* identifiers from one avatar's status frame to the next's */
#define CANCODEC_UNKNOWN INT16_MIN /* an angle that is not known */
#define CANCODEC_NO_ID UINT32_MAX  /* no position frames */

enum cancodec_frame { CANCODEC_STATUS, CANCODEC_RIGHT_1, CANCODEC_RIGHT_2, CANCODEC_LEFT_1, CANCODEC_LEFT_2 };

/* STATUS flags: bits 0-3 are the wire protocol's FRAME flags */
#define CANCODEC_F_STALE 0x01	  /* a sensor is stale or missing */
#define CANCODEC_F_UNREACHED 0x02 /* an arm's target was out of reach: closest posture */
#define CANCODEC_F_HELD 0x04	  /* no head: the previous posture repeated */
#define CANCODEC_F_NEW_SAMPLE 0x08
#define CANCODEC_F_LIMITED 0x10 /* safe mode clamped or slowed a joint of this command */
#define CANCODEC_F_SAFE 0x40	/* sent by an output in safe mode */
#define CANCODEC_F_VALID 0x80	/* every angle is known */

struct cancodec_avatar {
	uint8_t counter;		/* +1 per command sent, wraps */
	uint8_t flags;			/* CANCODEC_F_* */
	uint8_t sensors;		/* 2 bits per sensor (head, left hand, right hand): 0 OK, 1 STALE, 2 MISSING */
	uint8_t ik;			/* bit 0: right arm reached its target, bit 1: left arm */
	uint16_t age_ms;		/* age of the newest sensor sample, saturating */
	int16_t joint[CANCODEC_JOINTS]; /* 0.01 degree */
};

/* radians to 0.01 degree, rounded, saturating at +-32767; NaN to CANCODEC_UNKNOWN */
int16_t cancodec_centideg(double rad);
/* 0.01 degree to radians; CANCODEC_UNKNOWN to NaN */
double cancodec_rad(int16_t centideg);

/* the identifier of frame `frame` of the avatar whose status frame is id0 */
canid_t cancodec_id(canid_t id0, int frame);
void cancodec_encode_avatar(const struct cancodec_avatar *a, canid_t id0, struct can_frame f[CANCODEC_FRAMES]);
/*
 * Takes what f carries into a; returns the frame (enum cancodec_frame),
 * -ENOENT for an identifier not of this avatar, -EBADMSG for a wrong length.
 */
int cancodec_decode_avatar(const struct can_frame *f, canid_t id0, struct cancodec_avatar *a);

/* ---- sensors in (the can source) ------------------------------------------------- */

struct cancodec_sensor_map {
	canid_t ori_id;	   /* sensor 0's orientation frame */
	canid_t pos_id;	   /* sensor 0's position frame, or CANCODEC_NO_ID */
	int n;		   /* sensors */
	double quat_scale; /* the count that stands for 1.0 */
	bool xyzw;	   /* components in the order x y z w (else w x y z) */
	double pos_scale;  /* metres per count */
};

enum cancodec_kind { CANCODEC_ORIENTATION, CANCODEC_POSITION };

struct cancodec_sensor_value {
	int sensor;
	int kind;    /* enum cancodec_kind */
	double v[4]; /* unit quaternion w x y z, or position x y z in metres */
};

/*
 * 0 with out filled, -ENOENT for an identifier of no sensor (or a remote or
 * error frame), -EBADMSG for a wrong length, -EDOM for a quaternion whose
 * length is not within 20 % of 1 (a wrong scale, an uninitialised sensor).
 */
int cancodec_decode_sensor(const struct cancodec_sensor_map *m, const struct can_frame *f,
			   struct cancodec_sensor_value *out);
/* the frames a sensor sends (for tests and tools); q: w x y z; values saturate */
void cancodec_encode_orientation(const struct cancodec_sensor_map *m, int sensor, const double q[4],
				 struct can_frame *f);
void cancodec_encode_position(const struct cancodec_sensor_map *m, int sensor, const double p[3], struct can_frame *f);

/* ---- candump -L lines: "(1436509052.249713) can0 123#0011223344556677" ---------------- */

/* no newline; returns the length, or -ENOSPC */
int cancodec_format_line(const struct can_frame *f, uint64_t t_us, const char *ifname, char *buf, size_t len);
/* 0, or -EINVAL for a line that is not one classic CAN frame in that form */
int cancodec_parse_line(const char *line, struct can_frame *f, uint64_t *t_us, char *ifname, size_t iflen);

#endif /* AGW_CANCODEC_H */
