/* SPDX-License-Identifier: MIT */
/*
 * stream.h - the options of stream.c's configuration sections (its keys' values).
 */
#ifndef AGW_STREAM_H
#define AGW_STREAM_H

#include "config/config.h"

struct stream_opts {
	char address[CFG_PATH_MAX]; /* udp/multicast: destination; tcp: listen address */
	int port;
	int max_clients;
	int clients_per_address; /* tcp: 0: no limit but max_clients */
	int client_buffer;	 /* bytes per stream client */
	char path[CFG_PATH_MAX]; /* unix */
};

#endif /* AGW_STREAM_H */
