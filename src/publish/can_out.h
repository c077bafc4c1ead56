/* SPDX-License-Identifier: MIT */
/*
 * can_out.h - the options of can_out.c's configuration sections (its keys' values).
 */
#ifndef AGW_CAN_OUT_H
#define AGW_CAN_OUT_H

#include "config/config.h"

struct can_out_opts {
	char interface[CFG_NAME_MAX]; /* multicast: network interface; can: CAN interface or fd:N */
	int base_id;		      /* first CAN identifier */
	bool extended_ids;
	bool safe;	  /* clamp, limit the speed, send nothing stale */
	double max_speed; /* rad/s per joint (safe mode) */
};

#endif /* AGW_CAN_OUT_H */
