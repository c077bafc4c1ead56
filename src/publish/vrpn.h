/* SPDX-License-Identifier: MIT */
/*
 * vrpn.h - the options of vrpn.c's configuration sections (its keys' values),
 * and the parser of the UDP requests of plain "Avatar0@host" clients (for
 * tests and the fuzz harness).
 */
#ifndef AGW_VRPN_H
#define AGW_VRPN_H

#include "config/config.h"

struct vrpn_opts {
	char address[CFG_PATH_MAX]; /* udp/multicast: destination; tcp: listen address */
	int port;
	int max_clients;
	int clients_per_address;   /* 0: no limit but max_clients */
	int client_buffer;	   /* bytes per stream client */
	char device[CFG_PATH_MAX]; /* vrpn: device name pattern, %d = avatar id */
	bool udp;		   /* vrpn: low-latency reports over UDP when a client offers a port */
	double client_timeout;	   /* vrpn: s a client may stall or take over its handshake */
};

/*
 * A request "<host> <port>" (a client waiting for us to connect to it):
 * 0 with the host (letters, digits, '.', ':', '-') and the port
 * (1024-65535), or -1 for anything else.
 */
int vrpn_parse_request(const char *msg, char host[128], int *port);

#endif /* AGW_VRPN_H */
