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
/* a pose made of finite numbers only (checked before anything is published) */
bool encode_frame_finite(const struct wire_frame *f);
void encode_describe(const struct avatar *av, const char *name, double rate_hz, struct wire_describe *out);

#endif /* AGW_ENCODE_H */
