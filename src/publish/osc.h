/* SPDX-License-Identifier: MIT */
/*
 * osc.h - the options of osc.c's configuration sections (its keys' values).
 */
#ifndef AGW_OSC_H
#define AGW_OSC_H

#include "config/config.h"

struct osc_opts {
	char address[CFG_PATH_MAX]; /* udp/multicast: destination; tcp: listen address */
	int port;
	double rate;  /* vmc, vrchat, websocket: messages per second */
	double torso; /* vmc: shoulder line to hips, m */
	bool head;    /* vrchat: send the head for alignment */
};

#endif /* AGW_OSC_H */
