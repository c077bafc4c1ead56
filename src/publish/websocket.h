/* SPDX-License-Identifier: MIT */
/*
 * websocket.h - the options of websocket.c's configuration sections (its keys' values).
 */
#ifndef AGW_WEBSOCKET_H
#define AGW_WEBSOCKET_H

#include "config/config.h"

struct websocket_opts {
	char address[CFG_PATH_MAX]; /* udp/multicast: destination; tcp: listen address */
	int port;
	int max_clients;
	double rate;		  /* vmc, vrchat, websocket: messages per second */
	char www[CFG_PATH_MAX];	  /* websocket: the viewer page's directory, or auto */
	char three[CFG_PATH_MAX]; /* websocket: libjs-three's directory */
};

#endif /* AGW_WEBSOCKET_H */
