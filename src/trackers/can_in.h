/* SPDX-License-Identifier: MIT */
/*
 * can_in.h - the options of can_in.c's configuration sections (its keys' values).
 */
#ifndef AGW_CAN_IN_H
#define AGW_CAN_IN_H

#include "config/config.h"

enum cfg_quat_order { CFG_QUAT_WXYZ, CFG_QUAT_XYZW };

struct can_in_opts {
	int sensors;		      /* modbus, can: poses read */
	double pos_scale;	      /* modbus, can: m per count */
	char interface[CFG_NAME_MAX]; /* "can0", or "fd:N" for an inherited descriptor */
	int ori_id;		      /* sensor k's orientation frame: ori_id + k */
	int pos_id;		      /* sensor k's position frame: pos_id + k; -1: none */
	double quat_scale;	      /* the count that stands for 1.0 */
	int quat_order;		      /* enum cfg_quat_order */
	bool extended_ids;	      /* 29-bit identifiers */
};

#endif /* AGW_CAN_IN_H */
