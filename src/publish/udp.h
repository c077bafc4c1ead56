/* SPDX-License-Identifier: MIT */
/*
 * udp.h - the options of udp.c's configuration sections (its keys' values).
 */
#ifndef AGW_UDP_H
#define AGW_UDP_H

#include "config/config.h"

struct udp_opts {
	char address[CFG_PATH_MAX]; /* udp/multicast: destination; tcp: listen address */
	int port;
	bool gso;
	char interface[CFG_NAME_MAX]; /* multicast: network interface; can: CAN interface or fd:N */
	int ttl;
	bool mcast_loop;
};

#endif /* AGW_UDP_H */
