/* SPDX-License-Identifier: MIT */
/*
 * modbus_map.h - one avatar's block of Modbus input registers (version 1 of
 * the map, docs/MODBUS.md), made from a FRAME message. Addresses are
 * offsets from the block's first register (register_base + k *
 * register_stride for the k-th avatar an output publishes).
 */
#ifndef AGW_MODBUS_MAP_H
#define AGW_MODBUS_MAP_H

#include "avatargw/wire.h"

#include <stdint.h>

#define MODBUS_MAP_VERSION 1

enum modbus_map_reg {
	MODBUS_MAP_R_VERSION = 0,  /* MODBUS_MAP_VERSION */
	MODBUS_MAP_R_AVATAR = 1,   /* avatar id */
	MODBUS_MAP_R_COUNTER = 2,  /* frame counter: the FRAME's seq, low 16 bits */
	MODBUS_MAP_R_TIME = 3,	   /* 3-4: sample time, ms since the Unix epoch, low 32 bits (word order) */
	MODBUS_MAP_R_AGE = 5,	   /* ms since the block was updated, at the request; 65535 = never or longer */
	MODBUS_MAP_R_STATUS = 6,   /* MODBUS_MAP_S_* */
	MODBUS_MAP_R_SENSORS = 7,  /* 2 bits per sensor: head 1-0, left hand 3-2, right hand 5-4 */
	MODBUS_MAP_R_IK_RIGHT = 8, /* the right arm's IK flags (IK_REACHED 1, UNREACHABLE 2, ...) */
	MODBUS_MAP_R_IK_LEFT = 9,
	MODBUS_MAP_R_JOINTS = 10, /* number of joints: 17 */
	MODBUS_MAP_R_DEG100 = 12, /* 12-28: int16 joint angles, 0.01 degree */
	MODBUS_MAP_R_RAD = 32,	  /* 32-65: float32 joint angles, radians, two registers each (word order) */
	MODBUS_MAP_REGS = 66,	  /* registers a block uses */
};

/* status bits: 0-3 are the FRAME's flags */
#define MODBUS_MAP_S_STALE 0x0001
#define MODBUS_MAP_S_UNREACHED 0x0002
#define MODBUS_MAP_S_HELD 0x0004
#define MODBUS_MAP_S_NEW_SAMPLE 0x0008
#define MODBUS_MAP_S_VALID 0x0100 /* the angles are a solved posture; when clear they read 0 */

/* the block of f, word order an enum regcodec_order; the age register reads 0 */
void modbus_map_encode(const struct wire_frame *f, int order, uint16_t r[MODBUS_MAP_REGS]);

#endif /* AGW_MODBUS_MAP_H */
