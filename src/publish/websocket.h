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
	int clients_per_address;  /* 0: no limit but max_clients */
	double client_timeout;	  /* s for the HTTP request and the handshake */
	double idle_timeout;	  /* s without a pong */
	double rate;		  /* vmc, vrchat, websocket: messages per second */
	char www[CFG_PATH_MAX];	  /* websocket: the viewer page's directory, or auto */
	char three[CFG_PATH_MAX]; /* websocket: libjs-three's directory */
};

#endif /* AGW_WEBSOCKET_H */
