/* SPDX-License-Identifier: MIT */
/*
 * modbus_in.h - the options of modbus_in.c's configuration sections (its keys' values),
 * and its conversion of registers to a pose (for tests and the fuzz harness).
 */
#ifndef AGW_MODBUS_IN_H
#define AGW_MODBUS_IN_H

#include "config/config.h"

#include <stdbool.h>
#include <stdint.h>

enum cfg_reg_type { CFG_REGS_HOLDING, CFG_REGS_INPUT };
enum cfg_reg_format { CFG_REG_INT16, CFG_REG_UINT16, CFG_REG_INT32, CFG_REG_UINT32, CFG_REG_FLOAT32 };
enum cfg_orientation { CFG_ORI_ROTVEC, CFG_ORI_QUAT_WXYZ, CFG_ORI_QUAT_XYZW, CFG_ORI_RPY, CFG_ORI_NONE };

struct modbus_in_opts {
	char address[CFG_PATH_MAX]; /* host of the device */
	int port;
	int unit_id;
	int register_type; /* enum cfg_reg_type */
	int sensors;	   /* modbus, can: poses read */
	int sensor_stride; /* registers from one sensor's block to the next */
	int pos_register;
	int pos_format;	  /* enum cfg_reg_format */
	double pos_scale; /* modbus, can: m per count */
	int ori_register;
	int ori_format;
	double ori_scale; /* rad (or unit quaternion) per count */
	int orientation;  /* enum cfg_orientation */
	int word_order;	  /* enum cfg_word_order: 32-bit values */
	double poll_rate; /* Hz */
	double timeout_ms;
};

/*
 * Sensor k's pose from the source's register map: img holds the registers
 * from lo on (every register the map names for sensor k). q: w x y z, p:
 * metres. False: malformed (a value not finite, a quaternion far from unit
 * length).
 */
bool modbus_in_decode_pose(const struct modbus_in_opts *o, const uint16_t *img, int lo, int k, double q[4],
			   double p[3]);

#endif /* AGW_MODBUS_IN_H */
