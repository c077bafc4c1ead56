/* SPDX-License-Identifier: MIT */
/*
 * encode.h - a solved avatar as protocol messages (avatargw/wire.h):
 * joint angles, the world poses of its segments, its sensors, and the
 * DESCRIBE of its skeleton. No NaN leaves here except where the protocol
 * says NaN means unknown (a missing sensor, an avatar never solved).
 */
#ifndef AGW_ENCODE_H
#define AGW_ENCODE_H

#include "avatargw/wire.h"
#include "frames/frame.h"
#include "ik/avatar.h"

struct encode_in {
	const struct avatar *av;
	const struct pose_frame *pf;
	const struct avatar_pose *pose; /* NULL: never solved */
	bool held;			/* pose is the previous frame's */
};

void encode_frame(const struct encode_in *in, struct wire_frame *out);
/*
 * Every float of the frame finite but where NaN means unknown (checked
 * before anything is published): a missing sensor's record and the head
 * segment while the head is missing, and the whole posture when not solved
 * (the joints, segments and pos_err of a frame that has none). Sensor
 * records, pos_err and the input block's analog values are checked too.
 */
bool encode_frame_finite(const struct wire_frame *f, bool solved);
void encode_describe(const struct avatar *av, const char *name, double rate_hz, struct wire_describe *out);

#endif /* AGW_ENCODE_H */
