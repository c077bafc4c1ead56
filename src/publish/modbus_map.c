// SPDX-License-Identifier: MIT
/*
 * modbus_map.c - see modbus_map.h.
 */
#include "publish/modbus_map.h"

#include "wire/regcodec.h"

#include <math.h>
#include <string.h>

static uint16_t centideg(float rad)
{
	double v = rad * (18000.0 / M_PI);

	/* joints stay within +-180 degrees; saturate anyway rather than wrap */
	if (v >= 32767)
		return 32767;
	if (v <= -32767)
		return (uint16_t)-32767;
	return (uint16_t)(int16_t)lround(v);
}

void modbus_map_encode(const struct wire_frame *f, int order, uint16_t r[MODBUS_MAP_REGS])
{
	uint64_t ms = f->h.sample_time_ns / 1000000u;
	bool valid = true;

	memset(r, 0, sizeof(uint16_t) * MODBUS_MAP_REGS);
	r[MODBUS_MAP_R_VERSION] = MODBUS_MAP_VERSION;
	r[MODBUS_MAP_R_AVATAR] = f->h.avatar_id;
	r[MODBUS_MAP_R_COUNTER] = (uint16_t)f->h.seq;
	regcodec_put_u32(&r[MODBUS_MAP_R_TIME], (uint32_t)ms, order);
	for (int s = 0; s < WIRE_SENSORS; s++)
		r[MODBUS_MAP_R_SENSORS] |= (uint16_t)((f->sensor[s].state & 3) << (2 * s));
	r[MODBUS_MAP_R_IK_RIGHT] = f->arm[WIRE_ARM_RIGHT].ik_flags;
	r[MODBUS_MAP_R_IK_LEFT] = f->arm[WIRE_ARM_LEFT].ik_flags;
	r[MODBUS_MAP_R_JOINTS] = WIRE_JOINTS;
	for (int j = 0; j < WIRE_JOINTS; j++)
		valid &= isfinite(f->joint[j]) != 0;
	r[MODBUS_MAP_R_STATUS] = (uint16_t)((f->h.flags & 0x0f) | (valid ? MODBUS_MAP_S_VALID : 0));
	if (!valid)
		return; /* no NaN on the bus: the angles read 0 and VALID is clear */
	for (int j = 0; j < WIRE_JOINTS; j++) {
		r[MODBUS_MAP_R_DEG100 + j] = centideg(f->joint[j]);
		regcodec_put_f32(&r[MODBUS_MAP_R_RAD + 2 * j], f->joint[j], order);
	}
}
